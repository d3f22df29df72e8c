//! The projective-dynamics kernel (`shaders/anjyo/projective.wgsl`): the f32 twin of the f64
//! reference in `projective.rs`, one invocation per strand and one substep per dispatch;
//! `tests/it/contract.rs` and `tests/it/eff_anjyo.rs` (with an External Force Field) compare them.
//! The EFF and the head's hull and field are the scene's world (`systems::world`, bound at
//! `WORLD_GROUP`); each substep carries its own gust scale, so several frames recorded in
//! one submission each see their own.
//!
//! Layout for coalescing (one invocation per strand, so neighbouring invocations are
//! neighbouring strands): the angle state is segment-major, segment i of strand column c at
//! `(i - 1) * stride + c` with `stride` the dynamic strands rounded up to whole workgroups
//! ([`StateLayout`]); the strand records go up as three columns (ids, root, extra). The state
//! then holds `max segments * stride` entries instead of `sum (segments + 1)`: strands shorter
//! than the longest leave holes (at most the ratio of the longest to the mean length).
//! The node positions (`StrandBuffers::vertices`) stay strand-major because the draw passes,
//! the groom and the other systems read them so: each segment's node read and write is
//! `(segments + 1) * 16` bytes from its neighbour's, the one uncoalesced access left.

use super::gpu_data::GpuStep;
use super::gpu_data::{GpuDynParams, GpuDynStrand};
use super::projective::{DynSetup, StepForces, MAX_TURN, POLE_SIN};
use crate::error::Result;
use crate::forces::Forces;
use crate::gpu::strands::StrandBuffers;
use crate::gpu::{self, bind, Gpu, WORKGROUP};
use crate::systems::world::{WorldGpu, WorldSteps, WORLD_GROUP};
use glam::DMat4;
use std::sync::OnceLock;
use wgpu::util::DeviceExt;

const SLOT: u64 = 256;

/// Where the kernel keeps each strand's angles: segment-major, one row per segment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StateLayout {
    /// Entries per row: the dynamic strands rounded up to whole workgroups.
    pub stride: u32,
    /// Rows: the most segments of any dynamic strand.
    pub rows: u32,
}

impl StateLayout {
    pub fn of(setup: &DynSetup) -> StateLayout {
        StateLayout {
            stride: (setup.strands.len() as u32)
                .div_ceil(WORKGROUP)
                .max(1)
                .saturating_mul(WORKGROUP),
            rows: setup.strands.iter().map(|s| s.segments).max().unwrap_or(0),
        }
    }

    /// Entries in the state buffer (at least one: a buffer cannot be empty).
    pub fn entries(&self) -> u64 {
        (self.rows as u64 * self.stride as u64).max(1)
    }

    /// Index of segment `i` (1..=segments) of strand column `c`.
    pub fn index(&self, c: u32, i: u32) -> usize {
        (i as usize - 1) * self.stride as usize + c as usize
    }

    /// The state read back from the GPU in the f64 reference's strand-major order (entry
    /// `state_offset + i` for segment i, entry `state_offset` unused and zero).
    pub fn to_strand_major(&self, setup: &DynSetup, gpu_state: &[[f32; 4]]) -> Vec<[f32; 4]> {
        let mut out = vec![[0.0; 4]; setup.state_len as usize];
        for (c, s) in setup.strands.iter().enumerate() {
            for i in 1..=s.segments {
                out[(s.state_offset + i) as usize] = gpu_state[self.index(c as u32, i)];
            }
        }
        out
    }
}

/// The projective-dynamics kernel (`shaders/anjyo/projective.wgsl`).
pub struct ProjectivePass {
    init: wgpu::ComputePipeline,
    /// `advance` per [`Variant`] (by `Variant::index`), compiled when a job first needs it.
    advance: [OnceLock<wgpu::ComputePipeline>; 4],
    module: wgpu::ShaderModule,
    layout: wgpu::BindGroupLayout,
}

/// What a job's `advance` kernel is specialised for (the kernel's overridable flags). A
/// software adapter (lavapipe) executes both sides of every `if` under a lane mask, so a
/// path that a uniform flag turns off still costs its full price unless the pipeline
/// compiles it out: on the ellipsoid head of the gust scene the SDF sampling alone was
/// about half of the kernel's time. A job's head and field do not change after `prepare`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Variant {
    /// The head may be a signed distance field (`SDF_HEAD`); false for the ellipsoid.
    pub sdf_head: bool,
    /// The job has an External Force Field (`EFF_FIELD`).
    pub eff_field: bool,
}

impl Variant {
    pub fn of(setup: &DynSetup) -> Variant {
        Variant {
            sdf_head: setup.head.gpu_params().0[3] > 0.5,
            eff_field: setup.forces.eff.is_some(),
        }
    }

    fn index(self) -> usize {
        usize::from(self.sdf_head) | usize::from(self.eff_field) << 1
    }
}

/// Simulation buffers of one groom: parameters, the dynamic strands, the angle state and a
/// ring of per-substep uniforms. Only strands of dynamic groups get state.
pub struct ProjectiveJob {
    params: wgpu::Buffer,
    strands: wgpu::Buffer,
    pub state: wgpu::Buffer,
    steps: wgpu::Buffer,
    capacity: u32,
    /// The `advance` pipeline of this job's [`Variant`].
    advance: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// The world's group (the EFF, the head's hull and field), bound at `WORLD_GROUP`.
    world: wgpu::BindGroup,
    /// The world's per-submission samples (`advance` binds the group they return).
    steps_world: WorldSteps,
    dims: (u32, u32),
    pub layout: StateLayout,
}

fn mat(m: DMat4) -> [[f32; 4]; 4] {
    m.as_mat4().to_cols_array_2d()
}

/// Pack one substep for the GPU: its world samples are entries `start` (the substep's start
/// `f.t`: gravity + wind, the gust scale) and `start + 1` (its end `f.t_end`: the head pose)
/// of `world_steps`.
pub fn gpu_step(f: &StepForces, start: u32) -> GpuStep {
    GpuStep {
        h: [f.h as f32, 0.0, 0.0, 0.0],
        accel: mat(f.accel),
        kick: [
            u32::from(f.kick.is_some()),
            f.kick.unwrap_or(0),
            u32::from(f.first),
            0,
        ],
        samples: [start, start + 1, 0, 0],
        _pad: [[0; 4]; 9],
    }
}

impl ProjectivePass {
    /// The pipelines, over the layout of `world` at `WORLD_GROUP`.
    pub fn new(gpu: &Gpu, world: &WorldGpu) -> Result<ProjectivePass> {
        let device = &gpu.device;
        let module = gpu::shader_module(device, "projective", super::PROJECTIVE)?;
        let vec4 = bind::storage_rw::<[f32; 4]>;
        let layout = bind::layout(
            device,
            "projective",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::uniform::<GpuDynParams>(),
                bind::dynamic_uniform::<GpuStep>(),
                // The strand records as three columns of words (`GpuDynStrand` split).
                bind::storage::<[u32; 4]>(),
                vec4(),
                vec4(),
            ],
        );
        let [init] = world.compute_pipelines(
            device,
            "projective",
            &layout,
            &module,
            ["init"],
            &Self::constants(Variant {
                sdf_head: true,
                eff_field: true,
            }),
        );
        Ok(ProjectivePass {
            init,
            advance: Default::default(),
            module,
            layout,
        })
    }

    fn constants(v: Variant) -> [(&'static str, f64); 7] {
        [
            ("WORKGROUP", WORKGROUP as f64),
            ("EPS_OUT", crate::scene::head::EPS_OUT),
            ("SDF_EPS_OUT", crate::scene::hull::SDF_EPS_OUT),
            ("POLE_SIN", POLE_SIN),
            ("MAX_TURN", MAX_TURN),
            ("SDF_HEAD", f64::from(u8::from(v.sdf_head))),
            ("EFF_FIELD", f64::from(u8::from(v.eff_field))),
        ]
    }

    /// The `advance` pipeline specialised for `v` (compiled on first use).
    fn advance_pipeline(
        &self,
        device: &wgpu::Device,
        world: &WorldGpu,
        v: Variant,
    ) -> wgpu::ComputePipeline {
        self.advance[v.index()]
            .get_or_init(|| {
                let [advance] = world.compute_pipelines(
                    device,
                    "projective",
                    &self.layout,
                    &self.module,
                    ["advance"],
                    &Self::constants(v),
                );
                advance
            })
            .clone()
    }

    /// Upload the set-up; the angle state is initialised from the nodes by `init`.
    pub fn prepare(
        &self,
        gpu: &Gpu,
        world: &WorldGpu,
        setup: &DynSetup,
        hair: &StrandBuffers,
    ) -> Result<ProjectiveJob> {
        let device = &gpu.device;
        let dims = gpu.dispatch_dims(setup.strands.len() as u32, WORKGROUP)?;
        let layout = StateLayout::of(setup);
        let records: Vec<GpuDynStrand> = setup
            .strands
            .iter()
            .enumerate()
            .map(|(c, s)| GpuDynStrand {
                ids: [s.strand, s.first_vertex, c as u32, s.segments],
                root: [
                    s.root_local.x as f32,
                    s.root_local.y as f32,
                    s.root_local.z as f32,
                    s.seg_len as f32,
                ],
                extra: [s.scalp as f32, 0.0, 0.0, 0.0],
            })
            .collect();
        // Three columns of `stride` words each: ids, root, extra.
        let stride = layout.stride as usize;
        let mut columns = vec![[0u32; 4]; 3 * stride];
        for (c, r) in records.iter().enumerate() {
            columns[c] = r.ids;
            columns[stride + c] = bytemuck::cast(r.root);
            columns[2 * stride + c] = bytemuck::cast(r.extra);
        }
        let state_bytes = layout.entries() * std::mem::size_of::<[f32; 4]>() as u64;
        gpu.check_storage_size("the dynamics state", state_bytes)?;
        gpu.check_storage_size(
            "the dynamic strands",
            std::mem::size_of_val(columns.as_slice()) as u64,
        )?;
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("projective params"),
            contents: bytemuck::bytes_of(&gpu_params(setup, dims.0 * WORKGROUP, layout)),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let strands = gpu::storage_buffer(
            device,
            "dynamic strands",
            bytemuck::cast_slice(&columns),
            wgpu::BufferUsages::empty(),
        );
        let state = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("angle state"),
            size: state_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let capacity = 16;
        let steps = Self::step_ring(device, capacity);
        let bind_group = self.bind(device, [&params, &strands, &state], &steps, hair);
        let advance = self.advance_pipeline(device, world, Variant::of(setup));
        Ok(ProjectiveJob {
            params,
            strands,
            state,
            steps,
            capacity,
            advance,
            bind_group,
            world: world.group().clone(),
            steps_world: world.steps(),
            dims,
            layout,
        })
    }

    fn step_ring(device: &wgpu::Device, capacity: u32) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("projective substeps"),
            size: capacity as u64 * SLOT,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// The bind group; `[params, strands, state]` are the job's fixed buffers.
    fn bind(
        &self,
        device: &wgpu::Device,
        [params, strands, state]: [&wgpu::Buffer; 3],
        steps: &wgpu::Buffer,
        hair: &StrandBuffers,
    ) -> wgpu::BindGroup {
        bind::group(
            device,
            "projective",
            &self.layout,
            &[
                params.as_entire_binding(),
                bind::record(steps, SLOT),
                strands.as_entire_binding(),
                state.as_entire_binding(),
                hair.vertices.as_entire_binding(),
            ],
        )
    }

    /// Update parameters that do not change the layout (tuning from the viewer).
    pub fn update_params(&self, gpu: &Gpu, job: &ProjectiveJob, setup: &DynSetup) {
        gpu.queue.write_buffer(
            &job.params,
            0,
            bytemuck::bytes_of(&gpu_params(setup, job.dims.0 * WORKGROUP, job.layout)),
        );
    }

    /// Record the initialisation of the angles from the current nodes (at rest).
    pub fn init(&self, enc: &mut wgpu::CommandEncoder, job: &ProjectiveJob) {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("projective init"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.init);
        pass.set_bind_group(0, &job.bind_group, &[0]);
        pass.set_bind_group(WORLD_GROUP, &job.world, &[]);
        pass.dispatch_workgroups(job.dims.0, job.dims.1, 1);
    }

    /// Upload `substeps` and record one dispatch for each, the world sampled from `forces`
    /// at each substep's start and end. Call once per submission: the uniforms are written
    /// when the queue is submitted.
    pub fn advance(
        &self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        job: &mut ProjectiveJob,
        hair: &StrandBuffers,
        forces: &Forces,
        substeps: &[StepForces],
    ) -> Result<()> {
        if substeps.is_empty() {
            return Ok(());
        }
        let times: Vec<f64> = substeps.iter().flat_map(|f| [f.t, f.t_end]).collect();
        let (first, world) = job.steps_world.sample(gpu, forces, &times)?;
        if substeps.len() as u32 > job.capacity {
            job.capacity = (substeps.len() as u32).next_power_of_two();
            job.steps = Self::step_ring(&gpu.device, job.capacity);
            job.bind_group = self.bind(
                &gpu.device,
                [&job.params, &job.strands, &job.state],
                &job.steps,
                hair,
            );
        }
        let mut bytes = Vec::with_capacity(substeps.len() * SLOT as usize);
        for (i, f) in substeps.iter().enumerate() {
            bytes.extend_from_slice(bytemuck::bytes_of(&gpu_step(f, first + 2 * i as u32)));
        }
        gpu.queue.write_buffer(&job.steps, 0, &bytes);
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("projective advance"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&job.advance);
        pass.set_bind_group(WORLD_GROUP, &world, &[]);
        for i in 0..substeps.len() as u32 {
            pass.set_bind_group(0, &job.bind_group, &[i * SLOT as u32]);
            pass.dispatch_workgroups(job.dims.0, job.dims.1, 1);
        }
        Ok(())
    }
}

fn gpu_params(setup: &DynSetup, row_stride: u32, layout: StateLayout) -> GpuDynParams {
    let p = &setup.params;
    let pf = p.pseudo_force.as_ref();
    GpuDynParams {
        strand_count: setup.strands.len() as u32,
        row_stride,
        collision: u32::from(p.collision),
        pseudo: u32::from(pf.is_some()),
        density: p.density as f32,
        damping: p.damping as f32,
        seed: setup.seed,
        fluct_amp: p
            .fluctuation
            .as_ref()
            .map_or(0.0, |f| f.amplitude.to_radians() as f32),
        pseudo_alpha: pf.map_or(0.0, |f| f.alpha as f32),
        eps_pore: pf.map_or(1.0, |f| f.epsilon_pore as f32),
        eps_tip: pf.map_or(1.0, |f| f.epsilon_tip as f32),
        near: pf.map_or(0.0, |f| f.near as f32),
        sigma_root: p.stiffness.root.to_radians() as f32,
        sigma_tip: p.stiffness.tip.to_radians() as f32,
        sigma_start: p.stiffness.start as f32,
        inertia_root: p.inertia.root as f32,
        inertia_tip: p.inertia.tip as f32,
        sigma_end: p.stiffness.end as f32,
        state_stride: layout.stride,
        _pad: 0.0,
    }
}
