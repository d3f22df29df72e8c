//! The world every kind's kernels read, on the GPU. The stage owns one [`WorldGpu`] per scene
//! and uploads into it, once, what the simulation kernels read of the world that holds for
//! the whole scene: the head's hull (ellipsoid, or a mesh head's signed distance field) and
//! the External Force Field's grid and cells, and gravity. Every simulation kernel (Anjyo's
//! cantilever, projective and follower passes, the wisps' springs, the strips' motion) binds
//! its bind group at [`WORLD_GROUP`] and reads it through `shaders/common/world.wgsl`; no
//! kind uploads a copy of its own. A kind gets the world through `DrawSetup::world` when it
//! is built.
//!
//! What changes within a frame (keyed wind, the gust scale, the head's pose) is the world's
//! too: a kind asks [`WorldGpu::sample`] (through the handle [`WorldSteps`] it keeps) for the
//! stage's `Forces` at the times its integrator needs (its own substep times, in f64, as its
//! f64 reference evaluates them), the world evaluates them once into `world_steps`
//! ([`GpuWorldStep`]) and the kind's per-dispatch slot carries the sample indices only.
//! [`WorldGpu::begin`] starts a submission (`Stage::advance` calls it). The f64 side
//! (`forces::eff::Eff`, `forces::Forces`) stays in `forces`, which knows no GPU.

use crate::error::{KamiError, Result};
use crate::forces::eff::{Eff, GpuEffGrid};
use crate::forces::Forces;
use crate::gpu::{bind, Gpu};
use crate::scene::hull::HeadHull;
use crate::scene::Sampling;
use bytemuck::{Pod, Zeroable};
use std::cell::Cell;
use std::sync::{Arc, Mutex};

/// The bind group index of the world in every simulation kernel's pipeline layout (groups
/// 0 to 2 are the kernel's own, or the frame, kind and splat/cast groups of draw passes).
pub const WORLD_GROUP: u32 = 3;

/// Twin of `struct World` in `shaders/common/world.wgsl` (`tests/it/gpu_twins.rs` checks it).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuWorld {
    /// `HeadHull::gpu_params().0`: xyz the ellipsoid's centre, w 1 when the hull is the SDF.
    pub hull_center: [f32; 4],
    /// `HeadHull::gpu_params().1`: xyz the ellipsoid's radii, w 0.
    pub hull_radii: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuWorld>() == 32);

impl GpuWorld {
    /// Gravity and wind are not here: kernels read them per substep from the samples
    /// (`GpuWorldStep::force`).
    pub fn new(hull: &HeadHull) -> GpuWorld {
        let (hull_center, hull_radii) = hull.gpu_params();
        GpuWorld {
            hull_center,
            hull_radii,
        }
    }
}

/// One sample of the world at a time (fractional frames): what a kernel reads per substep,
/// picked by index from its own slot. Twin of `struct WorldStep` in
/// `shaders/common/world.wgsl` (`tests/it/gpu_twins.rs` checks it).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuWorldStep {
    /// xyz `Forces::uniform_at(t)` (gravity plus keyed wind, summed in f64), w
    /// `Forces::eff_scale(t)` (the EFF's gust scale, 0 without one).
    pub force: [f32; 4],
    /// `Forces::head_at(t)`.
    pub head: [[f32; 4]; 4],
    /// Its inverse, inverted in f64.
    pub head_inv: [[f32; 4]; 4],
}
const _: () = assert!(std::mem::size_of::<GpuWorldStep>() == 144);

impl GpuWorldStep {
    /// The world of `forces` at `t` (frames).
    pub fn at(forces: &Forces, t: f64) -> GpuWorldStep {
        let force = forces.uniform_at(t);
        let head = forces.head_at(t);
        let m = |m: glam::DMat4| m.as_mat4().to_cols_array_2d();
        GpuWorldStep {
            force: [
                force.x as f32,
                force.y as f32,
                force.z as f32,
                forces.eff_scale(t) as f32,
            ],
            head: m(head),
            head_inv: m(head.inverse()),
        }
    }
}

/// Samples `world_steps` holds when a world is made (it doubles when a submission needs more).
const FIRST_CAPACITY: u32 = 1024;

/// The per-submission samples of a world: `world_steps` and the bind group over it. Kinds
/// keep a handle (a clone of one `Arc`) from `WorldGpu::steps` when they are built.
#[derive(Clone)]
pub struct WorldSteps(Arc<Mutex<Steps>>);

struct Steps {
    layout: wgpu::BindGroupLayout,
    /// The world's fixed bindings (0 to 3), to bind again over a new `world_steps`.
    fixed: [wgpu::Buffer; 4],
    buffer: wgpu::Buffer,
    group: wgpu::BindGroup,
    capacity: u32,
    /// The times of entries `0..times.len()` written since the last `begin` (or growth).
    times: Vec<f64>,
    /// Whether `begin` was called since the buffer was last replaced: only then does a full
    /// buffer mean one submission needs more, and the new one doubles (a driver that never
    /// calls `begin` gets a fresh buffer of the same size each time one fills).
    begun: bool,
}

impl Steps {
    fn make(device: &wgpu::Device, capacity: u32) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("world steps"),
            size: capacity as u64 * std::mem::size_of::<GpuWorldStep>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    fn bind(&self, device: &wgpu::Device, buffer: &wgpu::Buffer) -> wgpu::BindGroup {
        let [a, b, c, d] = &self.fixed;
        bind::buffers(device, "world", &self.layout, &[a, b, c, d, buffer])
    }
}

impl WorldSteps {
    /// Start a submission: entries are written from the first again. Call only when every
    /// pass recorded since the last `begin` has been submitted (the queue's writes land
    /// before the next submission, and a pass recorded earlier in it would read them).
    pub fn begin(&self) {
        let mut s = self.0.lock().unwrap_or_else(|e| e.into_inner());
        s.times.clear();
        s.begun = true;
    }

    /// Evaluate `forces` at `times` (frames, f64: the kind's own substep times) into the next
    /// free entries of `world_steps`, in one queue write. Returns the first entry's index and
    /// the bind group to bind at [`WORLD_GROUP`] for the dispatches that read them: when the
    /// buffer is full a new one (of double the capacity when `begin` was called since the
    /// last, else the same, or more for a larger request) takes the samples and gets its own
    /// group, while passes already recorded keep the old group and its buffer: kinds bind the
    /// group they are given, never one they kept.
    pub fn sample(
        &self,
        gpu: &Gpu,
        forces: &Forces,
        times: &[f64],
    ) -> Result<(u32, wgpu::BindGroup)> {
        let mut s = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let need = s.times.len() + times.len();
        if need > s.capacity as usize {
            let grown = s.capacity as usize * if s.begun { 2 } else { 1 };
            let capacity = times.len().max(grown).next_power_of_two();
            let capacity = u32::try_from(capacity).map_err(|_| KamiError::TooLarge {
                what: "world samples in one submission".into(),
                needed: capacity as u64,
                limit: u32::MAX as u64,
                hint: "record fewer frames at once".into(),
            })?;
            let bytes = capacity as u64 * std::mem::size_of::<GpuWorldStep>() as u64;
            gpu.check_storage_size("the world's samples", bytes)?;
            s.buffer = Steps::make(&gpu.device, capacity);
            s.group = s.bind(&gpu.device, &s.buffer);
            s.capacity = capacity;
            s.times.clear();
            s.begun = false;
        }
        let first = s.times.len() as u32;
        if times.is_empty() {
            return Ok((first, s.group.clone()));
        }
        let records: Vec<GpuWorldStep> =
            times.iter().map(|&t| GpuWorldStep::at(forces, t)).collect();
        gpu.queue.write_buffer(
            &s.buffer,
            first as u64 * std::mem::size_of::<GpuWorldStep>() as u64,
            bytemuck::cast_slice(&records),
        );
        s.times.extend_from_slice(times);
        Ok((first, s.group.clone()))
    }

    /// Write the samples taken since the last `begin` again from other `forces`, at the same
    /// times and entries (tests: what a kernel reads of the world is these entries).
    pub fn rewrite(&self, gpu: &Gpu, forces: &Forces) {
        let s = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let records: Vec<GpuWorldStep> = s
            .times
            .iter()
            .map(|&t| GpuWorldStep::at(forces, t))
            .collect();
        gpu.queue
            .write_buffer(&s.buffer, 0, bytemuck::cast_slice(&records));
    }

    /// The times sampled since the last `begin` (or the last growth), in entry order.
    pub fn times(&self) -> Vec<f64> {
        self.0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .times
            .clone()
    }
}

thread_local! {
    /// (EFF grids, head fields) uploaded by this thread: what `uploads` reports.
    static UPLOADS: Cell<(u64, u64)> = const { Cell::new((0, 0)) };
}

/// How many EFF grids and head signed distance fields this thread has uploaded to the GPU so
/// far (a new upload, not a rewrite in place): tests check a scene uploads each once.
pub fn uploads() -> (u64, u64) {
    UPLOADS.with(|u| u.get())
}

fn count_upload(eff: u64, sdf: u64) {
    UPLOADS.with(|u| {
        let (e, s) = u.get();
        u.set((e + eff, s + sdf));
    });
}

/// The world of one scene on the GPU (group [`WORLD_GROUP`] of every simulation kernel):
/// `GpuWorld` (binding 0), the EFF's grid and cells (1, 2; a one-cell grid flagged absent
/// without a field) and the head's SDF words (3; a placeholder on an ellipsoid head).
pub struct WorldGpu {
    layout: wgpu::BindGroupLayout,
    world: wgpu::Buffer,
    eff: EffGpu,
    sdf: wgpu::Buffer,
    /// Words `sdf` holds.
    sdf_words: usize,
    sdf_head: bool,
    has_eff: bool,
    group: wgpu::BindGroup,
    steps: WorldSteps,
    /// The EFF and the head field on the GPU now: `write` uploads a grid again only when it
    /// changed (the viewer applies every edit, most of which touch neither).
    eff_now: Option<std::sync::Arc<Eff>>,
    sdf_now: Option<std::sync::Arc<crate::scene::sdf::Sdf>>,
}

impl WorldGpu {
    /// Upload the world of a scene with these forces and this head hull.
    pub fn new(gpu: &Gpu, forces: &Forces, hull: &HeadHull) -> Result<WorldGpu> {
        let device = &gpu.device;
        let words = hull.gpu_sdf();
        gpu.check_storage_size("the head's signed distance field", 4 * words.len() as u64)?;
        let eff = EffGpu::new(gpu, forces.eff.as_deref())?;
        let sdf = crate::gpu::storage_buffer(
            device,
            "world head sdf",
            bytemuck::cast_slice(&words),
            wgpu::BufferUsages::empty(),
        );
        count_upload(0, 1);
        let world = crate::gpu::storage_buffer(
            device,
            "world",
            bytemuck::bytes_of(&GpuWorld::new(hull)),
            wgpu::BufferUsages::UNIFORM,
        );
        let layout = Self::make_layout(device);
        let buffer = Steps::make(device, FIRST_CAPACITY);
        let group = bind::buffers(
            device,
            "world",
            &layout,
            &[&world, &eff.grid, &eff.cells, &sdf, &buffer],
        );
        let steps = WorldSteps(Arc::new(Mutex::new(Steps {
            layout: layout.clone(),
            fixed: [
                world.clone(),
                eff.grid.clone(),
                eff.cells.clone(),
                sdf.clone(),
            ],
            buffer,
            group: group.clone(),
            capacity: FIRST_CAPACITY,
            times: Vec::new(),
            begun: false,
        })));
        Ok(WorldGpu {
            layout,
            world,
            eff,
            sdf,
            sdf_words: words.len(),
            sdf_head: hull.sdf().is_some(),
            has_eff: forces.eff.is_some(),
            group,
            steps,
            eff_now: forces.eff.clone(),
            sdf_now: hull_sdf(hull),
        })
    }

    /// The world of a scene's `forces` around its `head` (the hull of `scene::hull::head_hull`).
    pub fn of(gpu: &Gpu, forces: &Forces, head: &crate::scene::Head) -> Result<WorldGpu> {
        Self::new(gpu, forces, &crate::scene::hull::head_hull(head)?)
    }

    /// The world of `scene` as the stage makes it (tests and benches that build one kind's
    /// passes without a stage).
    pub fn of_scene(gpu: &Gpu, scene: &crate::systems::scene::Scene) -> Result<WorldGpu> {
        Self::of(gpu, &Forces::new(&scene.forces, &scene.head), &scene.head)
    }

    fn make_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
        bind::layout(
            device,
            "world",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::uniform::<GpuWorld>(),
                bind::uniform::<GpuEffGrid>(),
                bind::storage::<[f32; 4]>(),
                bind::storage::<f32>(),
                bind::storage::<GpuWorldStep>(),
            ],
        )
    }

    /// The layout of group [`WORLD_GROUP`].
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// The bind group to bind at [`WORLD_GROUP`] for kernels that read no samples (those
    /// that do bind the group `sample` returns).
    pub fn group(&self) -> &wgpu::BindGroup {
        &self.group
    }

    /// The handle to this world's per-submission samples, which a kind keeps.
    pub fn steps(&self) -> WorldSteps {
        self.steps.clone()
    }

    /// Start a submission (see `WorldSteps::begin`).
    pub fn begin(&self) {
        self.steps.begin();
    }

    /// `WorldSteps::sample` of this world.
    pub fn sample(
        &self,
        gpu: &Gpu,
        forces: &Forces,
        times: &[f64],
    ) -> Result<(u32, wgpu::BindGroup)> {
        self.steps.sample(gpu, forces, times)
    }

    /// Whether the head is a mesh's SDF (kernels compile the SDF path in: `SDF_HEAD`).
    pub fn sdf_head(&self) -> bool {
        self.sdf_head
    }

    /// Whether the scene has an EFF (kernels compile its sampling in).
    pub fn has_eff(&self) -> bool {
        self.has_eff
    }

    /// The EFF's grid and cells (the probe `sample_on_gpu` binds them).
    pub fn eff(&self) -> &EffGpu {
        &self.eff
    }

    /// Whether `write` can take these forces and hull in place: the same EFF grid size and
    /// presence, the same kind of hull and SDF size. Otherwise the scene needs a new world,
    /// and every kernel built over this one is built again (they compile in or out what is
    /// present).
    pub fn fits(&self, forces: &Forces, hull: &HeadHull) -> bool {
        let cells = forces.eff.as_deref().map_or(1, |e| e.cell_count());
        forces.eff.is_some() == self.has_eff
            && cells == self.eff.count
            && hull.sdf().is_some() == self.sdf_head
            && (self.sdf_now == hull_sdf(hull) || hull.gpu_sdf().len() == self.sdf_words)
    }

    /// Rewrite the world in place (an edit of the forces or the head, or the EFF brush):
    /// refused, before writing anything, when it does not `fit`. The grids are written only
    /// when they changed.
    pub fn write(&mut self, gpu: &Gpu, forces: &Forces, hull: &HeadHull) -> Result<()> {
        if !self.fits(forces, hull) {
            return Err(KamiError::Gpu(
                "the world's grids changed size: make a new WorldGpu".into(),
            ));
        }
        gpu.queue
            .write_buffer(&self.world, 0, bytemuck::bytes_of(&GpuWorld::new(hull)));
        if self.eff_now != forces.eff {
            // The grid at gust scale 1, as `new` made it: kernels scale by their own
            // substep's gust (`EffGpu::write` takes a frame, not a scale).
            gpu.queue.write_buffer(
                &self.eff.grid,
                0,
                bytemuck::bytes_of(&GpuEffGrid::new(forces.eff.as_deref(), 1.0)),
            );
            if let Some(e) = forces.eff.as_deref() {
                self.eff.write_cells(gpu, e)?;
            }
            self.eff_now = forces.eff.clone();
        }
        let sdf = hull_sdf(hull);
        if self.sdf_now != sdf {
            gpu.queue
                .write_buffer(&self.sdf, 0, bytemuck::cast_slice(&hull.gpu_sdf()));
            self.sdf_now = sdf;
        }
        Ok(())
    }

    /// The compute pipelines of `entries` in `module` over the kernel's own group 0
    /// (`layout`) and the world at [`WORLD_GROUP`], with the module's overridable
    /// `constants` (as `gpu::compute_pipelines`).
    pub fn compute_pipelines<const N: usize>(
        &self,
        device: &wgpu::Device,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        module: &wgpu::ShaderModule,
        entries: [&str; N],
        constants: &[(&str, f64)],
    ) -> [wgpu::ComputePipeline; N] {
        let mut groups = [None; WORLD_GROUP as usize + 1];
        groups[0] = Some(layout);
        groups[WORLD_GROUP as usize] = Some(&self.layout);
        crate::gpu::compute_pipelines_over(device, label, &groups, module, entries, constants)
    }
}

fn hull_sdf(hull: &HeadHull) -> Option<std::sync::Arc<crate::scene::sdf::Sdf>> {
    match hull {
        HeadHull::Sdf(s) => Some(s.clone()),
        HeadHull::Ellipsoid(_) => None,
    }
}

/// The EFF on the GPU: `grid` is the `EffGrid` uniform of `shaders/forces/eff.wgsl`, `cells`
/// its storage buffer (one `vec4<f32>` per cell). A scene without an EFF gets a one-cell
/// grid flagged absent, so kernels bind the same layout either way.
pub struct EffGpu {
    pub grid: wgpu::Buffer,
    pub cells: wgpu::Buffer,
    /// Cells the buffer holds (1 for the absent grid).
    count: usize,
}

impl EffGpu {
    pub fn new(gpu: &crate::gpu::Gpu, eff: Option<&Eff>) -> Result<EffGpu> {
        let data = crate::forces::eff::cell_data(eff);
        gpu.check_storage_size("the EFF grid", (data.len() * 16) as u64)?;
        count_upload(1, 0);
        let grid = crate::gpu::storage_buffer(
            &gpu.device,
            "eff grid",
            bytemuck::bytes_of(&GpuEffGrid::new(eff, 1.0)),
            wgpu::BufferUsages::UNIFORM,
        );
        let cells = crate::gpu::storage_buffer(
            &gpu.device,
            "eff cells",
            bytemuck::cast_slice(&data),
            wgpu::BufferUsages::empty(),
        );
        Ok(EffGpu {
            grid,
            cells,
            count: data.len(),
        })
    }

    /// Write the grid's uniform with the gust scale at `frame` (fractional): cheap, once per
    /// frame. A grid of another size than the one uploaded is written as absent (with a
    /// warning): upload it with `new`, or its cells with `write_cells`.
    pub fn write(&self, gpu: &crate::gpu::Gpu, eff: Option<&Eff>, frame: f64) {
        let eff = eff.filter(|e| {
            let fits = e.cell_count() == self.count;
            if !fits {
                log::warn!(
                    "EFF of {} cells written to a GPU grid of {}: ignored",
                    e.cell_count(),
                    self.count
                );
            }
            fits
        });
        let scale = eff.map_or(0.0, |e| e.scale_at(frame));
        gpu.queue.write_buffer(
            &self.grid,
            0,
            bytemuck::bytes_of(&GpuEffGrid::new(eff, scale)),
        );
    }

    /// Upload changed cells (the brush) of a grid of the same size.
    pub fn write_cells(&self, gpu: &crate::gpu::Gpu, eff: &Eff) -> Result<()> {
        if eff.cell_count() != self.count {
            return Err(KamiError::Gpu(format!(
                "EFF of {} cells does not fit the GPU grid of {}: make a new EffGpu",
                eff.cell_count(),
                self.count
            )));
        }
        gpu.queue.write_buffer(
            &self.cells,
            0,
            bytemuck::cast_slice(&crate::forces::eff::cell_data(Some(eff))),
        );
        Ok(())
    }
}

/// `forces/eff.wgsl` with a kernel that samples it at given points (`sample_on_gpu`); also
/// the module that validates the file on its own (register it as `forces/eff`).
pub const EFF_MODULE: &str = concat!(
    crate::shaders::wgsl!("forces/eff.wgsl"),
    r#"
// Samples the EFF at points (tests and tools: `systems::world::sample_on_gpu`).
override WORKGROUP: u32;
struct SampleParams {
    // x: points, y: sampling (0 nearest, 1 trilinear), z: invocations per row of workgroups
    n: vec4<u32>,
}
@group(0) @binding(0) var<uniform> eff: EffGrid;
@group(0) @binding(1) var<storage, read> eff_cells: array<vec4<f32>>;
@group(0) @binding(2) var<uniform> sample_params: SampleParams;
@group(0) @binding(3) var<storage, read> sample_points: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> sample_out: array<vec4<f32>>;

@compute @workgroup_size(WORKGROUP)
fn eff_sample(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * sample_params.n.z;
    if i >= sample_params.n.x {
        return;
    }
    sample_out[i] = vec4<f32>(eff_force(sample_points[i].xyz, sample_params.n.y), 0.0);
}
"#
);

/// `eff_force` of `shaders/forces/eff.wgsl` at `points` (world), read back: the GPU twin of
/// `Eff::sample_at` for contract tests and tools (not for the frame loop).
pub fn sample_on_gpu(
    gpu: &crate::gpu::Gpu,
    eff: &EffGpu,
    points: &[[f32; 3]],
    sampling: Sampling,
) -> Result<Vec<[f32; 3]>> {
    use crate::gpu::{self, WORKGROUP};
    use wgpu::util::DeviceExt;
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let device = &gpu.device;
    let n = points.len() as u32;
    let dims = gpu.dispatch_dims(n, WORKGROUP)?;
    let bytes = points.len() as u64 * 16;
    gpu.check_storage_size("EFF sample points", bytes)?;
    let module = gpu::shader_module(device, "eff sample", EFF_MODULE)?;
    let layout = bind::layout(
        device,
        "eff sample",
        wgpu::ShaderStages::COMPUTE,
        &[
            bind::uniform::<GpuEffGrid>(),
            bind::storage::<[f32; 4]>(),
            bind::uniform::<[u32; 4]>(),
            bind::storage::<[f32; 4]>(),
            bind::storage_rw::<[f32; 4]>(),
        ],
    );
    let [pipeline] = gpu::compute_pipelines(
        device,
        "eff sample",
        &layout,
        &module,
        ["eff_sample"],
        &[("WORKGROUP", WORKGROUP as f64)],
    );
    let mode = match sampling {
        Sampling::Nearest => 0u32,
        Sampling::Trilinear => 1,
    };
    let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("eff sample params"),
        contents: bytemuck::bytes_of(&[n, mode, dims.0 * WORKGROUP, 0]),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let pts: Vec<[f32; 4]> = points.iter().map(|p| [p[0], p[1], p[2], 1.0]).collect();
    let input = gpu::storage_buffer(
        device,
        "eff sample points",
        bytemuck::cast_slice(&pts),
        wgpu::BufferUsages::empty(),
    );
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("eff sample out"),
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let group = bind::buffers(
        device,
        "eff sample",
        &layout,
        &[&eff.grid, &eff.cells, &params, &input, &output],
    );
    let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("eff sample"),
    });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("eff sample"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(dims.0, dims.1, 1);
    }
    gpu.queue.submit([enc.finish()]);
    let out: Vec<[f32; 4]> = gpu::read_buffer(gpu, &output, bytes)?;
    Ok(out.iter().map(|v| [v[0], v[1], v[2]]).collect())
}
