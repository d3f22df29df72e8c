//! The strips' motion kernel (`shaders/strips/dynamics.wgsl`): the f32 twin of the f64
//! reference in `dynamics.rs`, one invocation per strip, one dispatch per step;
//! `tests/it/strips_dynamics.rs` compares them.
//!
//! What the CPU prepares in f64 and uploads: per joint its reference frame, rest angles,
//! outboard moment and the exact propagators of a full and a half step (they depend only on
//! I1, I2, τ and dt, so the kernel needs no transcendental branches); per step of a
//! recording the head-acceleration maps at the step's start and middle, the extra forces'
//! ramps, and the indices of the world's samples (`systems::world::WorldSteps`) at its start,
//! middle and end: the head's pose, gravity plus the keyed wind and the EFF's gust scale
//! there. These are written with `queue.write_buffer` before the submission that runs them:
//! record once per submission. At most `MAX_EXTRA` (16) extra forces (a uniform array):
//! `set_extra` refuses more.
//!
//! The EFF's grid and cells and the mesh head's signed distance field are the scene's world
//! (`systems::world::WorldGpu`, bound at `WORLD_GROUP`): the kernel samples the field
//! (`eff_field`) scaled by each step's gust, and on an ellipsoid head the pipeline compiles
//! the SDF path out (`SDF_HEAD`).

use super::dynamics::{check_extra, step_length, steps_per_frame, ExtraForce, Rig, MAX_EXTRA};
use super::dynamics::{HeadFrame, COLLISION_ACCEL};
use crate::error::{KamiError, Result};
use crate::forces::Forces;
use crate::gpu::{self, bind, Gpu, WORKGROUP};
use crate::scene::head::EPS_OUT;
use crate::scene::hull::SDF_EPS_OUT;
use crate::scene::Sampling;
use crate::shaders::wgsl;
use crate::systems::strips::block::Motion;
use crate::systems::world::{WorldGpu, WorldSteps, WORLD_GROUP};
use bytemuck::{Pod, Zeroable};

/// The kernel's module: the world (`common/world.wgsl` with the EFF and the hulls, the same
/// text every kind reads), then the kernel.
pub const DYNAMICS: &str = wgsl!(world; "strips/dynamics.wgsl");

/// Bytes per step slot of the dynamic uniform (the adapters' offset alignment).
const SLOT: u64 = 256;
/// Loop iterations the kernel may spend per stick and step, counting the worst hull
/// push-out (32 × 3 + 20) and the force sums (two, each over the extras and an EFF lookup
/// of up to 8 cells): llvmpipe stops a shader's loops after 65,535 in all.
const LOOPS_PER_STICK: u64 = 3 + 32 * 3 + 20 + 2 * (1 + MAX_EXTRA as u64 + 8);
const LOOP_LIMIT: u64 = 65_535;

/// Twin of `struct Params` (`tests/it/gpu_twins.rs` checks it) in `shaders/strips/dynamics.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuParams {
    pub count: u32,
    pub stride: u32,
    pub row_stride: u32,
    pub extras: u32,
    /// xyz 0 (gravity is the world's samples'), w spring k.
    pub gravity: [f32; 4],
    /// x collision κ, y Ψ at the surface for κ = 1 (the hull is the world's).
    pub collision: [f32; 4],
    /// x EFF sampling (0 nearest, 1 trilinear).
    pub flags: [u32; 4],
    pub extra_center: [[f32; 4]; MAX_EXTRA],
    pub extra_accel: [[f32; 4]; MAX_EXTRA],
}
const _: () = assert!(std::mem::size_of::<GpuParams>() == 64 + 2 * 16 * MAX_EXTRA);

/// One step's slot of the dynamic uniform: x is the step's index in `steps` (`struct Slot`
/// in `shaders/strips/dynamics.wgsl`; each slot is `SLOT` bytes apart).
type GpuSlot = [u32; 4];

/// Storage buffers the strips' kernel binds: six of its own and the world's three (WebGPU
/// guarantees 8; `super::check_limits` asks the adapter).
pub const STORAGE_BUFFERS: u32 = 9;

/// Twin of `struct Step` (`tests/it/gpu_twins.rs` checks it).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuStep {
    /// The head-acceleration maps at the step's start and middle.
    pub k0: [f32; 16],
    pub k1: [f32; 16],
    /// x: the world sample (`world_steps`) at the step's start; `x + 1` its middle, `x + 2`
    /// its end (the head's pose, gravity plus the keyed wind, the gust scale).
    pub samples: [u32; 4],
    pub ramp0: [f32; MAX_EXTRA],
    pub ramp1: [f32; MAX_EXTRA],
}
const _: () = assert!(std::mem::size_of::<GpuStep>() == 272);

/// Twin of `struct Strip` (`tests/it/gpu_twins.rs` checks it).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuStrip {
    /// xyz root (head rest frame), w Ψ's band.
    pub root: [f32; 4],
    /// First joint, sticks, unused, unused.
    pub info: [u32; 4],
}

/// Twin of `struct Joint` (`tests/it/gpu_twins.rs` checks it).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuJoint {
    pub c0: [f32; 4],
    pub c1: [f32; 4],
    pub c2: [f32; 4],
    pub rest: [f32; 4],
    pub goal: [f32; 4],
    pub full_step: [f32; 4],
    pub half_step: [f32; 4],
    pub forced: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuJoint>() == 128);

/// The strips' chains on the GPU and their pass.
pub struct DynamicsGpu {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    strips: wgpu::Buffer,
    joints: wgpu::Buffer,
    state: wgpu::Buffer,
    scratch: wgpu::Buffer,
    points: wgpu::Buffer,
    /// The world's samples: `record` binds the group `sample` returns at `WORLD_GROUP`.
    world: WorldSteps,
    steps: wgpu::Buffer,
    slots: wgpu::Buffer,
    /// Steps the `steps` and `slots` buffers hold.
    capacity: u32,
    bind_group: wgpu::BindGroup,
    dims: (u32, u32),
    count: u32,
    stride: u32,
    joint_count: u32,
    /// The rig (its joints for the propagators; `set_rig` swaps in new constants).
    rig: Rig,
    motion: Motion,
    extra: Vec<ExtraForce>,
    rest_state: Vec<[f32; 4]>,
    rest_points: Vec<[f32; 4]>,
}

fn f4(v: glam::DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// Whether `extra` fits the GPU (at most `MAX_EXTRA`) and each force is well formed.
pub fn check_extras(extra: &[ExtraForce]) -> Result<()> {
    if extra.len() > MAX_EXTRA {
        return Err(KamiError::Invalid {
            file: String::new(),
            field: "strips extra forces (key-frame edits)".into(),
            value: format!("{} forces", extra.len()),
            allowed: format!("at most {MAX_EXTRA} on the GPU at once"),
        });
    }
    check_extra(extra)
}

impl DynamicsGpu {
    /// Upload `rig` (its current state) with the forces' settings of `motion`, over the
    /// scene's `world` (its EFF and the head's hull and field).
    pub fn new(gpu: &Gpu, world: &WorldGpu, rig: &Rig, motion: &Motion) -> Result<Self> {
        super::dynamics::check_motion(motion)?;
        let device = &gpu.device;
        let count = rig.strip_count() as u32;
        let stride = rig.stride() as u32;
        let longest = (0..rig.strip_count())
            .map(|s| rig.sticks(s))
            .max()
            .unwrap_or(0) as u64;
        let loops = longest * LOOPS_PER_STICK + stride as u64;
        if loops > LOOP_LIMIT {
            return Err(KamiError::TooLarge {
                what: "the strips' motion kernel (loop iterations per strip and step)".into(),
                needed: loops,
                limit: LOOP_LIMIT,
                hint: format!(
                    "use fewer sticks per strip (at most {})",
                    (LOOP_LIMIT - stride as u64) / LOOPS_PER_STICK
                ),
            });
        }
        let dims = gpu.dispatch_dims(count, WORKGROUP)?;
        let (layout, pipeline) = Self::pipeline(gpu, world)?;
        let strips: Vec<GpuStrip> = rig
            .strips
            .iter()
            .map(|s| GpuStrip {
                root: f4(s.root, s.band),
                info: [s.first as u32, s.sticks as u32, 0, 0],
            })
            .collect();
        let joint_count = rig.joints.len() as u32;
        let state: Vec<[f32; 4]> = rig
            .q
            .iter()
            .zip(&rig.v)
            .map(|(q, v)| [q[0] as f32, q[1] as f32, v[0] as f32, v[1] as f32])
            .collect();
        let points: Vec<[f32; 4]> = rig.points().iter().map(|p| f4(*p, 1.0)).collect();
        let mut rest = rig.clone();
        rest.reset();
        let rest_state: Vec<[f32; 4]> = rest
            .q
            .iter()
            .map(|q| [q[0] as f32, q[1] as f32, 0.0, 0.0])
            .collect();
        let rest_points: Vec<[f32; 4]> = rest.points().iter().map(|p| f4(*p, 1.0)).collect();
        for (what, bytes) in [
            ("the strips' joints", joint_count as u64 * 128),
            ("the strips' scratch", joint_count as u64 * 48),
            ("the strips' control points", points.len() as u64 * 16),
        ] {
            gpu.check_storage_size(what, bytes)?;
        }
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strips dynamics params"),
            size: std::mem::size_of::<GpuParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let strips_buf = gpu::storage_buffer(
            device,
            "strips",
            bytemuck::cast_slice(&strips),
            wgpu::BufferUsages::empty(),
        );
        let joints = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strips joints"),
            size: (joint_count as u64 * 128).max(128),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let state_buf = gpu::storage_buffer(
            device,
            "strips joint state",
            bytemuck::cast_slice(&state),
            wgpu::BufferUsages::COPY_SRC,
        );
        let scratch = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strips scratch"),
            size: (joint_count as u64 * 48).max(48),
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let points_buf = gpu::storage_buffer(
            device,
            "strips control points",
            bytemuck::cast_slice(&points),
            wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::VERTEX,
        );
        let (steps, slots) = Self::per_step(gpu, 1)?;
        let bind_group = Self::bind(
            device,
            &layout,
            [
                &params,
                &slots,
                &strips_buf,
                &joints,
                &steps,
                &state_buf,
                &scratch,
                &points_buf,
            ],
        );
        let mut me = DynamicsGpu {
            pipeline,
            layout,
            params,
            strips: strips_buf,
            joints,
            state: state_buf,
            scratch,
            points: points_buf,
            world: world.steps(),
            steps,
            slots,
            capacity: 1,
            bind_group,
            dims,
            count,
            stride,
            joint_count,
            rig: rig.clone(),
            motion: motion.clone(),
            extra: Vec::new(),
            rest_state,
            rest_points,
        };
        me.update_params(gpu, motion);
        Ok(me)
    }

    /// The kernel's own layout (group 0) and its pipeline over it and the world (on an
    /// ellipsoid head the SDF path compiled out).
    fn pipeline(
        gpu: &Gpu,
        world: &WorldGpu,
    ) -> Result<(wgpu::BindGroupLayout, wgpu::ComputePipeline)> {
        let device = &gpu.device;
        let constants = [
            ("WORKGROUP", WORKGROUP as f64),
            ("EPS_OUT", EPS_OUT),
            ("SDF_EPS_OUT", SDF_EPS_OUT),
            ("SDF_HEAD", f64::from(u8::from(world.sdf_head()))),
        ];
        let module = gpu::shader_module(device, "strips dynamics", DYNAMICS)?;
        let vec4_rw = bind::storage_rw::<[f32; 4]>;
        let layout = bind::layout(
            device,
            "strips dynamics",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::uniform::<GpuParams>(),
                bind::dynamic_uniform::<GpuSlot>(),
                bind::storage::<GpuStrip>(),
                bind::storage::<GpuJoint>(),
                bind::storage::<GpuStep>(),
                vec4_rw(),
                vec4_rw(),
                vec4_rw(),
            ],
        );
        let [pipeline] = world.compute_pipelines(
            device,
            "strips dynamics",
            &layout,
            &module,
            ["step"],
            &constants,
        );
        Ok((layout, pipeline))
    }

    /// Step records and their slots for `capacity` steps.
    fn per_step(gpu: &Gpu, capacity: u32) -> Result<(wgpu::Buffer, wgpu::Buffer)> {
        let bytes = capacity as u64 * std::mem::size_of::<GpuStep>() as u64;
        gpu.check_storage_size("the strips' step records", bytes)?;
        let steps = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("strips steps"),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut slots = vec![0u8; capacity as usize * SLOT as usize];
        for i in 0..capacity as usize {
            slots[i * SLOT as usize..i * SLOT as usize + 4]
                .copy_from_slice(&(i as u32).to_le_bytes());
        }
        use wgpu::util::DeviceExt;
        let slots = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("strips step slots"),
                contents: &slots,
                usage: wgpu::BufferUsages::UNIFORM,
            });
        Ok((steps, slots))
    }

    /// Buffers in binding order.
    fn bind(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        b: [&wgpu::Buffer; 8],
    ) -> wgpu::BindGroup {
        let mut resources: Vec<wgpu::BindingResource> =
            b.iter().map(|buf| buf.as_entire_binding()).collect();
        resources[1] = bind::record(b[1], SLOT);
        bind::group(device, "strips dynamics", layout, &resources)
    }

    fn rebind(&mut self, device: &wgpu::Device) {
        self.bind_group = Self::bind(
            device,
            &self.layout,
            [
                &self.params,
                &self.slots,
                &self.strips,
                &self.joints,
                &self.steps,
                &self.state,
                &self.scratch,
                &self.points,
            ],
        );
    }

    /// New joint constants (I1, I2, τ from a changed `Motion`) for the same strips: the
    /// rig must have the same strips, sticks and layout. They reach the GPU with the next
    /// `update_params`; the current pose stays.
    pub fn set_rig(&mut self, rig: Rig) -> Result<()> {
        self.check_rig(&rig)?;
        self.rig = rig;
        Ok(())
    }

    /// Whether `rig` can replace the one on the GPU: the same strips, sticks and layout,
    /// and the same groomed pose (what `reset` uploads).
    pub fn check_rig(&self, rig: &Rig) -> Result<()> {
        let layout = |r: &Rig| {
            (
                r.stride(),
                r.strips
                    .iter()
                    .map(|s| (s.first, s.sticks))
                    .collect::<Vec<_>>(),
            )
        };
        if layout(rig) != layout(&self.rig) || rig.start != self.rig.start {
            return Err(KamiError::Invalid {
                file: String::new(),
                field: "strips rig".into(),
                value: format!("{} strips, stride {}", rig.strip_count(), rig.stride()),
                allowed: "the same strips, sticks and groomed pose as the rig on the GPU \
                          (rebuild to change them)"
                    .into(),
            });
        }
        Ok(())
    }

    /// Take the forces' settings of `motion` (spring, collision, sampling, frame
    /// time and step rate), the joints' constants of the rig (see `set_rig`) and the hull
    /// of `head`.
    pub fn update_params(&mut self, gpu: &Gpu, motion: &Motion) {
        self.motion = motion.clone();
        let dt = step_length(motion);
        let props = self.rig.propagator_table(dt);
        let joints: Vec<GpuJoint> = self
            .rig
            .strips
            .iter()
            .flat_map(|s| (0..s.sticks).map(move |j| (s, j)))
            .map(|(s, j)| {
                let jt = &self.rig.joints[s.first + j];
                let [full, half] = props[s.first + j];
                let m = |p: &super::dynamics::Propagator| {
                    [
                        p.m[0][0] as f32,
                        p.m[0][1] as f32,
                        p.m[1][0] as f32,
                        p.m[1][1] as f32,
                    ]
                };
                GpuJoint {
                    c0: f4(jt.c.x_axis, jt.len),
                    c1: f4(jt.c.y_axis, jt.moment),
                    c2: f4(jt.c.z_axis, 0.0),
                    rest: [jt.rest[0] as f32, jt.rest[1] as f32, 0.0, 0.0],
                    goal: f4(s.rest[j + 1], 1.0),
                    full_step: m(&full),
                    half_step: m(&half),
                    forced: [
                        full.fq as f32,
                        full.fv as f32,
                        half.fq as f32,
                        half.fv as f32,
                    ],
                }
            })
            .collect();
        if !joints.is_empty() {
            gpu.queue
                .write_buffer(&self.joints, 0, bytemuck::cast_slice(&joints));
        }
        self.write_params(gpu);
    }

    fn write_params(&self, gpu: &Gpu) {
        let m = &self.motion;
        let mut p = GpuParams {
            count: self.count,
            stride: self.stride,
            row_stride: self.dims.0 * WORKGROUP,
            extras: self.extra.len() as u32,
            gravity: [0.0, 0.0, 0.0, m.spring as f32],
            collision: [m.collision as f32, COLLISION_ACCEL as f32, 0.0, 0.0],
            flags: [u32::from(m.sampling == Sampling::Trilinear), 0, 0, 0],
            extra_center: [[0.0; 4]; MAX_EXTRA],
            extra_accel: [[0.0; 4]; MAX_EXTRA],
        };
        for (i, e) in self.extra.iter().enumerate() {
            p.extra_center[i] = f4(e.center, e.radius);
            p.extra_accel[i] = f4(e.accel, 0.0);
        }
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
    }

    /// The key-frame edits' extra forces (at most `MAX_EXTRA`).
    pub fn set_extra(&mut self, gpu: &Gpu, extra: &[ExtraForce]) -> Result<()> {
        check_extras(extra)?;
        self.extra = extra.to_vec();
        self.write_params(gpu);
        Ok(())
    }

    /// Record `frames` frames of steps from frame `frame`. The step records are written to
    /// the queue now, so call once per submission.
    pub fn record(
        &mut self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        forces: &Forces,
        frame: u64,
        frames: u32,
    ) -> Result<()> {
        let spf = steps_per_frame(&self.motion);
        let steps = frames.checked_mul(spf).ok_or_else(|| KamiError::TooLarge {
            what: "strip steps in one recording".into(),
            needed: frames as u64 * spf as u64,
            limit: u32::MAX as u64,
            hint: "record fewer frames at once".into(),
        })?;
        if steps == 0 || self.count == 0 {
            return Ok(());
        }
        if steps > self.capacity {
            let capacity = steps.next_power_of_two();
            let (s, sl) = Self::per_step(gpu, capacity)?;
            self.steps = s;
            self.slots = sl;
            self.capacity = capacity;
            self.rebind(&gpu.device);
        }
        let dt = self.motion.frame_time / spf as f64;
        let ft = self.motion.frame_time;
        let width = (dt / ft).max(1.0);
        let start = |i: u64| frame as f64 + i as f64 / spf as f64;
        let mid = |i: u64| start(i) + 0.5 / spf as f64;
        // The world at each step's start, middle and end (the head's pose there, gravity
        // plus the keyed wind and the EFF's gust scale at the start and middle).
        let times: Vec<f64> = (0..steps as u64)
            .flat_map(|i| [start(i), mid(i), start(i) + 1.0 / spf as f64])
            .collect();
        let (first, world) = self.world.sample(gpu, forces, &times)?;
        let m4 = |m: glam::DMat4| m.as_mat4().to_cols_array();
        let records: Vec<GpuStep> = (0..steps as u64)
            .map(|i| {
                let (f0, fm) = (start(i), mid(i));
                let h0 = HeadFrame::at(forces, &self.motion, f0, width);
                let hm = HeadFrame::at(forces, &self.motion, fm, width);
                let mut ramp0 = [0.0f32; MAX_EXTRA];
                let mut ramp1 = [0.0f32; MAX_EXTRA];
                for (e, x) in self.extra.iter().enumerate() {
                    ramp0[e] = x.ramp(f0) as f32;
                    ramp1[e] = x.ramp(fm) as f32;
                }
                GpuStep {
                    k0: m4(h0.accel),
                    k1: m4(hm.accel),
                    samples: [first + 3 * i as u32, 0, 0, 0],
                    ramp0,
                    ramp1,
                }
            })
            .collect();
        gpu.queue
            .write_buffer(&self.steps, 0, bytemuck::cast_slice(&records));
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("strips dynamics"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(WORLD_GROUP, &world, &[]);
        let (x, y) = self.dims;
        for i in 0..steps {
            pass.set_bind_group(0, &self.bind_group, &[i * SLOT as u32]);
            pass.dispatch_workgroups(x, y, 1);
        }
        Ok(())
    }

    /// World control points: `array<vec4<f32>>`, index `strip * stride + k`, w = 1.
    pub fn points(&self) -> &wgpu::Buffer {
        &self.points
    }

    /// Control points per strip in `points`.
    pub fn stride(&self) -> u32 {
        self.stride
    }

    /// Strips.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Back to the groomed pose (the rig's start angles, which differ from the rest angles
    /// Φ0 under gravity preloading), still, the head at its rest pose.
    pub fn reset(&mut self, gpu: &Gpu) -> Result<()> {
        if self.joint_count > 0 {
            gpu.queue
                .write_buffer(&self.state, 0, bytemuck::cast_slice(&self.rest_state));
            gpu.queue
                .write_buffer(&self.points, 0, bytemuck::cast_slice(&self.rest_points));
        }
        gpu.queue.submit([]);
        gpu.take_error()
    }

    /// Read the control points back (tests, benches).
    pub fn read_points(&self, gpu: &Gpu) -> Result<Vec<[f32; 4]>> {
        gpu::read_buffer(
            gpu,
            &self.points,
            (self.rest_points.len() as u64 * 16).max(16),
        )
    }

    /// Read the joints' (θ, φ, θ', φ') back.
    pub fn read_state(&self, gpu: &Gpu) -> Result<Vec<[f32; 4]>> {
        gpu::read_buffer(gpu, &self.state, (self.joint_count as u64 * 16).max(16))
    }
}
