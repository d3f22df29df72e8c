//! The world every kind's kernels read, on the GPU: the External Force Field's grid and
//! cells (`EffGpu`, sampled by `shaders/forces/eff.wgsl`). The f64 side (`forces::eff::Eff`)
//! stays in `forces`, which knows no GPU; kinds reach the upload here.

use crate::error::{KamiError, Result};
use crate::forces::eff::{Eff, GpuEffGrid};
use crate::scene::Sampling;

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

/// The EFF's WGSL, to concatenate before a kernel that samples it.
pub const EFF_WGSL: &str = crate::shaders::wgsl!("forces/eff.wgsl");

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
    use crate::gpu::{self, bind, WORKGROUP};
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
