//! The mass-spring kernel (`shaders/wisps/springs.wgsl`): the f32 twin of the f64 reference
//! in `springs.rs`, one invocation per mass point, four dispatches per RK4 substep or two
//! per semi-implicit Euler substep; `tests/wisps_springs.rs` compares them.
//!
//! Buffers: `positions` holds every point as `vec4<f32>` (xyz world), all primaries first
//! in (skeleton, node) order, so the renderer binds its first `primaries()` entries as the
//! skeleton nodes. The head poses of a recording are uploaded per half substep (RK4 needs
//! the middle of each step), written with `queue.write_buffer` before the submission that
//! runs them: record once per submission.

use super::springs::{Lattice, NEWTON};
use crate::error::Result;
use crate::forces::Forces;
use crate::gpu::{self, Gpu, WORKGROUP};
use crate::scene::head::EPS_OUT;
use crate::scene::wisps::{Integrator, Springs};
use crate::scene::Head;
use crate::shaders::wgsl;
use bytemuck::{Pod, Zeroable};

/// The kernel's module (the wisps kind lists it as `("wisps/springs", SPRINGS)`).
pub const SPRINGS: &str = wgsl!("common/ellipsoid.wgsl", "wisps/springs.wgsl");

/// Bytes per substep slot of the dynamic uniform (the adapters' offset alignment).
const SLOT: u64 = 256;
/// Scratch regions per point: velocity, RK4 stage states A and B (x, v), the stage sums.
const REGIONS: u64 = 7;

/// Keep in sync with `struct Params` in `shaders/wisps/springs.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSpringParams {
    pub count: u32,
    pub row_stride: u32,
    pub collide: u32,
    pub _pad: u32,
    /// xyz gravity, w step length (seconds).
    pub gravity: [f32; 4],
    /// xyz hull centre, w c_damp.
    pub hull_center: [f32; 4],
    pub hull_radii: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuSpringParams>() == 64);

/// Keep in sync with `struct MassPoint`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMassPoint {
    /// xyz rest position, w inverse mass (0: kinematic).
    pub rest: [f32; 4],
    /// First spring, one past the last, unused, unused.
    pub edges: [u32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuMassPoint>() == 32);

/// Keep in sync with `struct Edge`.
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
    heads: wgpu::Buffer,
    steps: wgpu::Buffer,
    /// Substeps the `heads` and `steps` buffers hold.
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
    pub fn new(gpu: &Gpu, lattice: &Lattice, springs: &Springs, head: &Head) -> Result<Self> {
        let device = &gpu.device;
        let count = lattice.points.len() as u32;
        let dims = gpu.dispatch_dims(count, WORKGROUP)?;
        let module = gpu::shader_module(device, "wisps springs", SPRINGS)?;
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wisps springs"),
            entries: &[
                gpu::uniform_entry(0, cs),
                gpu::dynamic_uniform_entry(1, cs, SLOT),
                gpu::storage_entry(2, cs, true),
                gpu::storage_entry(3, cs, true),
                gpu::storage_entry(4, cs, true),
                gpu::storage_entry(5, cs, false),
                gpu::storage_entry(6, cs, false),
            ],
        });
        let [pin, rk1, rk2, rk3, rk4, kick, drift] = gpu::compute_pipelines(
            device,
            "wisps springs",
            &layout,
            &module,
            ["pin", "rk1", "rk2", "rk3", "rk4", "kick", "drift"],
            &[
                ("WORKGROUP", WORKGROUP as f64),
                ("NEWTON", NEWTON as f64),
                ("EPS_OUT", EPS_OUT),
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
        let (heads, steps) = Self::per_substep(gpu, 1)?;
        let bind_group = Self::bind(
            device, &layout, &params, &steps, &points, &edges, &heads, &positions, &scratch,
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
            heads,
            steps,
            capacity: 1,
            bind_group,
            dims,
            count,
            primaries: lattice.primaries(),
            substeps: springs.substeps.max(1),
            integrator: springs.integrator,
            rest,
        };
        me.update_params(gpu, springs, head);
        Ok(me)
    }

    /// Head poses (2 per substep + 1) and the substep slots for `capacity` substeps.
    fn per_substep(gpu: &Gpu, capacity: u32) -> Result<(wgpu::Buffer, wgpu::Buffer)> {
        let head_bytes = (2 * capacity as u64 + 1) * 64;
        gpu.check_storage_size("the wisp springs' head poses", head_bytes)?;
        let heads = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("wisps head poses"),
            size: head_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut slots = vec![0u8; capacity as usize * SLOT as usize];
        for i in 0..capacity as usize {
            slots[i * SLOT as usize..i * SLOT as usize + 4]
                .copy_from_slice(&(i as u32).to_le_bytes());
        }
        use wgpu::util::DeviceExt;
        let steps = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("wisps substeps"),
                contents: &slots,
                usage: wgpu::BufferUsages::UNIFORM,
            });
        Ok((heads, steps))
    }

    #[allow(clippy::too_many_arguments)]
    fn bind(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        params: &wgpu::Buffer,
        steps: &wgpu::Buffer,
        points: &wgpu::Buffer,
        edges: &wgpu::Buffer,
        heads: &wgpu::Buffer,
        positions: &wgpu::Buffer,
        scratch: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wisps springs"),
            layout,
            entries: &[
                gpu::entry(0, params),
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: steps,
                        offset: 0,
                        size: wgpu::BufferSize::new(SLOT),
                    }),
                },
                gpu::entry(2, points),
                gpu::entry(3, edges),
                gpu::entry(4, heads),
                gpu::entry(5, positions),
                gpu::entry(6, scratch),
            ],
        })
    }

    /// Take motion settings that keep the lattice (damping, gravity, step, integrator,
    /// collision); stiffness, masses and `hold_shape` need a new lattice.
    pub fn update_params(&mut self, gpu: &Gpu, springs: &Springs, head: &Head) {
        self.substeps = springs.substeps.max(1);
        self.integrator = springs.integrator;
        let dt = springs.frame_time / self.substeps as f64;
        let g = springs.gravity;
        let p = GpuSpringParams {
            count: self.count,
            row_stride: self.dims.0 * WORKGROUP,
            collide: u32::from(springs.collide),
            _pad: 0,
            gravity: [g[0] as f32, g[1] as f32, g[2] as f32, dt as f32],
            hull_center: [
                head.center[0] as f32,
                head.center[1] as f32,
                head.center[2] as f32,
                springs.damping as f32,
            ],
            hull_radii: [
                head.radii[0] as f32,
                head.radii[1] as f32,
                head.radii[2] as f32,
                0.0,
            ],
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
            let (heads, slots) = Self::per_substep(gpu, capacity)?;
            self.heads = heads;
            self.steps = slots;
            self.capacity = capacity;
            self.bind_group = Self::bind(
                &gpu.device,
                &self.layout,
                &self.params,
                &self.steps,
                &self.points,
                &self.edges,
                &self.heads,
                &self.positions,
                &self.scratch,
            );
        }
        let half = 2.0 * self.substeps as f64;
        let poses: Vec<[f32; 16]> = (0..=2 * steps as u64)
            .map(|j| {
                let frame = from_frame as f64 + j as f64 / half;
                forces.head_at(frame).as_mat4().to_cols_array()
            })
            .collect();
        gpu.queue
            .write_buffer(&self.heads, 0, bytemuck::cast_slice(&poses));
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wisps springs"),
            timestamp_writes: None,
        });
        let (x, y) = self.dims;
        pass.set_bind_group(0, &self.bind_group, &[0]);
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
