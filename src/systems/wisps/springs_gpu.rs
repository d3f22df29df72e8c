//! The mass-spring kernel (`shaders/wisps/springs.wgsl`): the f32 twin of the f64 reference
//! in `springs.rs`, one invocation per mass point, four dispatches per RK4 substep or two
//! per semi-implicit Euler substep; `tests/it/wisps_springs.rs` compares them.
//!
//! Buffers: `positions` holds every point as `vec4<f32>` (xyz world), all primaries first
//! in (skeleton, node) order, so the renderer binds its first `primaries()` entries as the
//! skeleton nodes. A recording samples the world (`systems::world::WorldSteps`) at every
//! half substep for the head's pose (RK4 needs the middle of each step) and at each
//! substep's start, middle and end for gravity plus the keyed wind and the EFF's gust
//! scale; each substep's slot (`GpuSubstep`) holds the indices of its samples, written with
//! `queue.write_buffer` before the submission that runs them: record once per submission.
//! The scene's forces are read from the `Forces` handed to `record` (the stage's, each
//! frame): head motion, keyed wind and the gust scale act from the next
//! recording. The EFF's grid and cells and the mesh head's SDF are the scene's world
//! (`systems::world::WorldGpu`, bound at `WORLD_GROUP`, sampled with
//! `shaders/forces/eff.wgsl` and `shaders/common/sdf.wgsl`; the `SDF_HEAD` constant compiles
//! the SDF path out on ellipsoid heads); the shared gravity also sets the natural lengths, so
//! it builds the system again (`super::classify`).

use super::springs::{Lattice, NEWTON};
use crate::error::Result;
use crate::forces::Forces;
use crate::gpu::{self, bind, Gpu, WORKGROUP};
use crate::scene::head::EPS_OUT;
use crate::scene::hull::SDF_EPS_OUT;
use crate::shaders::wgsl;
use crate::systems::wisps::block::{Integrator, Springs};
use crate::systems::world::{WorldGpu, WorldSteps, WORLD_GROUP};
use bytemuck::{Pod, Zeroable};

/// The kernel's module (the wisps kind lists it as `("wisps/springs", SPRINGS)`): the world
/// (`common/world.wgsl` with the EFF and the hulls, the same text every kind reads), then
/// the kernel.
pub const SPRINGS: &str = wgsl!(world; "wisps/springs.wgsl");

/// Bytes per substep slot of the dynamic uniform (the adapters' offset alignment).
const SLOT: u64 = 256;
/// Scratch regions per point: velocity, RK4 stage states A and B (x, v), the stage sums.
const REGIONS: u64 = 7;

/// Twin of `struct Params` (`tests/it/gpu_twins.rs` checks it) in `shaders/wisps/springs.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSpringParams {
    pub count: u32,
    pub row_stride: u32,
    pub collide: u32,
    pub _pad: u32,
    /// x step length (seconds), y c_damp.
    pub step: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuSpringParams>() == 32);

/// One substep's slot of the dynamic uniform: indices into the world's samples. Twin of
/// `struct Substep` (`tests/it/gpu_twins.rs` checks it).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSubstep {
    /// x: the sample of the head's pose at the substep's start (`x + 1` middle, `x + 2`
    /// end); y: the sample of the field at its start (`y + 1` middle, `y + 2` end).
    pub sample: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuSubstep>() == 16);
const _: () = assert!(std::mem::size_of::<GpuSubstep>() as u64 <= SLOT);

/// Twin of `struct MassPoint` (`tests/it/gpu_twins.rs` checks it).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMassPoint {
    /// xyz rest position, w inverse mass (0: kinematic).
    pub rest: [f32; 4],
    /// First spring, one past the last, unused, unused.
    pub edges: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuMassPoint>() == 32);

/// Twin of `struct Edge` (`tests/it/gpu_twins.rs` checks it).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuEdge {
    pub other: u32,
    pub rest: f32,
    pub k: f32,
}
const _: () = assert!(std::mem::size_of::<GpuEdge>() == 12);

/// The lattice on the GPU and its passes.
pub struct SpringsGpu {
    pin: wgpu::ComputePipeline,
    rk: [wgpu::ComputePipeline; 4],
    kick: wgpu::ComputePipeline,
    drift: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    points: wgpu::Buffer,
    edges: wgpu::Buffer,
    positions: wgpu::Buffer,
    scratch: wgpu::Buffer,
    steps: wgpu::Buffer,
    /// The world's samples: `record` binds the group `sample` returns at `WORLD_GROUP`.
    world: WorldSteps,
    /// Substeps the `steps` buffer holds.
    capacity: u32,
    bind_group: wgpu::BindGroup,
    dims: (u32, u32),
    count: u32,
    primaries: u32,
    substeps: u32,
    integrator: Integrator,
    rest: Vec<[f32; 4]>,
}

impl SpringsGpu {
    /// Upload `lattice` (see `Lattice::build`) with the motion settings of `springs`, over
    /// the scene's `world` (its EFF and the head's hull and field).
    pub fn new(gpu: &Gpu, world: &WorldGpu, lattice: &Lattice, springs: &Springs) -> Result<Self> {
        let device = &gpu.device;
        let count = lattice.points.len() as u32;
        let dims = gpu.dispatch_dims(count, WORKGROUP)?;
        let module = gpu::shader_module(device, "wisps springs", SPRINGS)?;
        let layout = bind::layout(
            device,
            "wisps springs",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::uniform::<GpuSpringParams>(),
                bind::dynamic_uniform::<GpuSubstep>(),
                bind::storage::<GpuMassPoint>(),
                bind::storage::<GpuEdge>(),
                bind::storage_rw::<[f32; 4]>(),
                bind::storage_rw::<[f32; 4]>(),
            ],
        );
        let [pin, rk1, rk2, rk3, rk4, kick, drift] = world.compute_pipelines(
            device,
            "wisps springs",
            &layout,
            &module,
            ["pin", "rk1", "rk2", "rk3", "rk4", "kick", "drift"],
            &[
                ("WORKGROUP", WORKGROUP as f64),
                ("NEWTON", NEWTON as f64),
                ("EPS_OUT", EPS_OUT),
                ("SDF_EPS_OUT", SDF_EPS_OUT),
                ("SDF_HEAD", f64::from(u8::from(world.sdf_head()))),
            ],
        );
        let records: Vec<GpuMassPoint> = lattice
            .points
            .iter()
            .enumerate()
            .map(|(i, p)| GpuMassPoint {
                rest: [
                    p.rest.x as f32,
                    p.rest.y as f32,
                    p.rest.z as f32,
                    if p.pinned { 0.0 } else { (1.0 / p.mass) as f32 },
                ],
                edges: [lattice.adj_start[i], lattice.adj_start[i + 1], 0, 0],
            })
            .collect();
        let edges: Vec<GpuEdge> = lattice
            .adj
            .iter()
            .map(|&[o, s]| {
                let s = &lattice.springs[s as usize];
                GpuEdge {
                    other: o,
                    rest: s.rest as f32,
                    k: s.k as f32,
                }
            })
            .collect();
        let rest: Vec<[f32; 4]> = lattice
            .points
            .iter()
            .map(|p| [p.rest.x as f32, p.rest.y as f32, p.rest.z as f32, 1.0])
            .collect();
        let scratch_bytes = REGIONS * count as u64 * 16;
        gpu.check_storage_size("the wisp springs' scratch state", scratch_bytes)?;
        gpu.check_storage_size(
            "the wisp springs",
            (edges.len() * std::mem::size_of::<GpuEdge>()) as u64,
        )?;
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wisps springs params"),
            size: std::mem::size_of::<GpuSpringParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let points = gpu::storage_buffer(
            device,
            "wisps mass points",
            bytemuck::cast_slice(&records),
            wgpu::BufferUsages::empty(),
        );
        let edges = gpu::storage_buffer(
            device,
            "wisps spring lists",
            bytemuck::cast_slice(&edges),
            wgpu::BufferUsages::empty(),
        );
        let positions = gpu::storage_buffer(
            device,
            "wisps positions",
            bytemuck::cast_slice(&rest),
            wgpu::BufferUsages::COPY_SRC,
        );
        let scratch = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wisps spring scratch"),
            size: scratch_bytes.max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let steps = Self::per_substep(gpu, 1)?;
        let bind_group = Self::bind(
            device,
            &layout,
            [&params, &steps, &points, &edges, &positions, &scratch],
        );
        let mut me = SpringsGpu {
            pin,
            rk: [rk1, rk2, rk3, rk4],
            kick,
            drift,
            layout,
            params,
            points,
            edges,
            positions,
            scratch,
            steps,
            world: world.steps(),
            capacity: 1,
            bind_group,
            dims,
            count,
            primaries: lattice.primaries(),
            substeps: springs.substeps.max(1),
            integrator: springs.integrator,
            rest,
        };
        me.update_params(gpu, springs);
        Ok(me)
    }

    /// The substep slots for `capacity` substeps.
    fn per_substep(gpu: &Gpu, capacity: u32) -> Result<wgpu::Buffer> {
        let steps = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wisps substeps"),
            size: capacity as u64 * SLOT,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(steps)
    }

    /// `buffers`: params, substep slots, points, edges, positions, scratch.
    fn bind(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        buffers: [&wgpu::Buffer; 6],
    ) -> wgpu::BindGroup {
        let [params, steps, points, edges, positions, scratch] = buffers;
        bind::group(
            device,
            "wisps springs",
            layout,
            &[
                params.as_entire_binding(),
                bind::record(steps, SLOT),
                points.as_entire_binding(),
                edges.as_entire_binding(),
                positions.as_entire_binding(),
                scratch.as_entire_binding(),
            ],
        )
    }

    /// Take motion settings that keep the lattice (damping, step, integrator, collision);
    /// stiffness, masses and `hold_shape` need a new lattice. The hull is the world's.
    pub fn update_params(&mut self, gpu: &Gpu, springs: &Springs) {
        self.substeps = springs.substeps.max(1);
        self.integrator = springs.integrator;
        let dt = springs.frame_time / self.substeps as f64;
        let p = GpuSpringParams {
            count: self.count,
            row_stride: self.dims.0 * WORKGROUP,
            collide: u32::from(springs.collide),
            _pad: 0,
            step: [dt as f32, springs.damping as f32, 0.0, 0.0],
        };
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
    }

    /// Record `frames` frames of substeps from frame `from_frame`. The head poses are
    /// written to the queue now, so call once per submission.
    pub fn record(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        forces: &Forces,
        from_frame: u64,
        frames: u32,
    ) -> Result<()> {
        let steps =
            frames
                .checked_mul(self.substeps)
                .ok_or_else(|| crate::error::KamiError::TooLarge {
                    what: "wisp springs substeps in one recording".into(),
                    needed: frames as u64 * self.substeps as u64,
                    limit: u32::MAX as u64,
                    hint: "record fewer frames at once".into(),
                })?;
        if steps == 0 {
            return Ok(());
        }
        if steps > self.capacity {
            let capacity = steps.next_power_of_two();
            self.steps = Self::per_substep(gpu, capacity)?;
            self.capacity = capacity;
            self.bind_group = Self::bind(
                &gpu.device,
                &self.layout,
                [
                    &self.params,
                    &self.steps,
                    &self.points,
                    &self.edges,
                    &self.positions,
                    &self.scratch,
                ],
            );
        }
        let half = 2.0 * self.substeps as f64;
        let mut times: Vec<f64> = (0..=2 * steps as u64)
            .map(|j| from_frame as f64 + j as f64 / half)
            .collect();
        times.extend(field_times(from_frame, self.substeps, steps));
        let (first, world) = self.world.sample(gpu, forces, &times)?;
        let slots = substep_slots(first, first + 2 * steps + 1, steps);
        gpu.queue
            .write_buffer(&self.steps, 0, bytemuck::cast_slice(&slots));
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wisps springs"),
            timestamp_writes: None,
        });
        let (x, y) = self.dims;
        pass.set_bind_group(0, &self.bind_group, &[0]);
        pass.set_bind_group(WORLD_GROUP, &world, &[]);
        pass.set_pipeline(&self.pin);
        pass.dispatch_workgroups(x, y, 1);
        for i in 0..steps {
            pass.set_bind_group(0, &self.bind_group, &[i * SLOT as u32]);
            let stages: &[&wgpu::ComputePipeline] = match self.integrator {
                Integrator::Rk4 => &[&self.rk[0], &self.rk[1], &self.rk[2], &self.rk[3]],
                Integrator::SemiImplicitEuler => &[&self.kick, &self.drift],
            };
            for p in stages {
                pass.set_pipeline(p);
                pass.dispatch_workgroups(x, y, 1);
            }
        }
        Ok(())
    }

    /// Every point, `vec4<f32>` xyz world, primaries first.
    pub fn positions(&self) -> &wgpu::Buffer {
        &self.positions
    }

    /// Leading entries of `positions` that are skeleton nodes.
    pub fn primaries(&self) -> u32 {
        self.primaries
    }

    /// Mass points in `positions`.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Back to the drawn pose (head rest frame), at rest.
    pub fn reset(&mut self, gpu: &Gpu) -> Result<()> {
        gpu.queue
            .write_buffer(&self.positions, 0, bytemuck::cast_slice(&self.rest));
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("wisps springs reset"),
            });
        enc.clear_buffer(&self.scratch, 0, None);
        gpu.queue.submit([enc.finish()]);
        gpu.take_error()
    }

    /// Read every point back (tests, benches).
    pub fn read_positions(&self, gpu: &Gpu) -> Result<Vec<[f32; 4]>> {
        gpu::read_buffer(gpu, &self.positions, self.count as u64 * 16)
    }
}

/// The stage times (frames) of the field over a recording of `steps` substeps (`substeps` a
/// frame) from frame `from_frame`: each substep's start, middle and end, the GPU's side of
/// `springs::field_accel` (the EFF's cells are sampled in the kernel, scaled by the gust).
pub fn field_times(from_frame: u64, substeps: u32, steps: u32) -> Vec<f64> {
    let s = substeps.max(1);
    let per = s as f64;
    let mut out = Vec::with_capacity(3 * steps as usize);
    for i in 0..steps {
        // The stage times exactly as `springs::run_frames` and `springs::step` compute them,
        // so that a step key (an abrupt gust) falls on the same side of a stage time.
        let start = (from_frame + (i / s) as u64) as f64 + (i % s) as f64 / per;
        out.extend([start, start + 0.5 * (1.0 / per), start + 1.0 / per]);
    }
    out
}

/// The substep slots of a recording of `steps` substeps, one `SLOT` of bytes each: the
/// head's poses from world sample `poses` (two a substep, shared at the ends), the field
/// from `field` (three a substep).
pub fn substep_slots(poses: u32, field: u32, steps: u32) -> Vec<u8> {
    let slot_bytes = SLOT as usize;
    let mut out = vec![0u8; steps as usize * slot_bytes];
    for i in 0..steps {
        let slot = GpuSubstep {
            sample: [poses + 2 * i, field + 3 * i, 0, 0],
        };
        let at = i as usize * slot_bytes;
        out[at..at + std::mem::size_of::<GpuSubstep>()].copy_from_slice(bytemuck::bytes_of(&slot));
    }
    out
}
