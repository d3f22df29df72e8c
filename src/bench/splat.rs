//! A measurement for choosing how to draw sub-pixel strands on a software adapter (issue 12,
//! item 6: "measure before choosing"). Not a renderer: a compute pass that walks every
//! segment of the Anjyo hair in screen space, one invocation per strand, and adds one to a
//! per-pixel counter for every pixel it crosses (a DDA at one step per pixel, no depth, no
//! shading, no coverage). It is the lower bound of what a compute rasteriser for thin
//! strands would cost, set beside the triangle ribbons the stage draws now: when even this
//! bound is not far below the ribbons, the compute route is not the lever.

use crate::error::Result;
use crate::gpu::gpu_data::GpuStrand;
use crate::gpu::{self, bind, Gpu};
use crate::stage::camera::Camera;
use crate::stage::Stage;
use crate::systems::anjyo::AnjyoSystem;
use bytemuck::{Pod, Zeroable};
use std::time::Instant;
use wgpu::util::DeviceExt;

/// After `shaders/common/strands.wgsl` (the `Strand` record).
const SHADER: &str = r#"
struct Params {
    view_proj: mat4x4<f32>,
    size: vec2<u32>,
    count: u32,
    _pad: u32,
}
@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read> strands: array<Strand>;
@group(0) @binding(2) var<storage, read> verts: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> image: array<atomic<u32>>;

fn to_px(x: vec3<f32>) -> vec3<f32> {
    let c = p.view_proj * vec4<f32>(x, 1.0);
    let n = c.xy / max(c.w, 1e-6);
    return vec3<f32>((n.x * 0.5 + 0.5) * f32(p.size.x), (0.5 - n.y * 0.5) * f32(p.size.y), c.w);
}

@compute @workgroup_size(64)
fn splat(@builtin(global_invocation_id) id: vec3<u32>) {
    let si = id.x + id.y * 65535u * 64u;
    if si >= p.count {
        return;
    }
    let s = strands[si];
    var a = to_px(verts[s.first_vertex].xyz);
    for (var i = 1u; i <= s.segments; i++) {
        let b = to_px(verts[s.first_vertex + i].xyz);
        let d = b.xy - a.xy;
        let n = u32(clamp(ceil(max(abs(d.x), abs(d.y))), 1.0, 4096.0));
        for (var k = 0u; k < n; k++) {
            let q = a.xy + d * (f32(k) + 0.5) / f32(n);
            if q.x >= 0.0 && q.y >= 0.0 && q.x < f32(p.size.x) && q.y < f32(p.size.y) && a.z > 0.0 {
                atomicAdd(&image[u32(q.y) * p.size.x + u32(q.x)], 1u);
            }
        }
        a = b;
    }
}
"#;

/// The probe's `Params` (a twin of `struct Params` in `SHADER`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct ProbeParams {
    view_proj: [f32; 16],
    size: [u32; 2],
    count: u32,
    _pad: u32,
}

/// The probe's result: CPU wall milliseconds (median of `runs`, submit to wait) and the
/// pixel steps it counted (so a pass that did nothing cannot pass for a fast one).
pub struct Probe {
    pub ms: f64,
    pub pixel_steps: u64,
}

/// Run the probe over the stage's Anjyo hair as the stage's camera sees it at `size`.
pub fn probe(gpu: &Gpu, stage: &Stage, size: (u32, u32), runs: u32) -> Result<Option<Probe>> {
    let Some(anjyo) = stage.system::<AnjyoSystem>() else {
        return Ok(None);
    };
    let device = &gpu.device;
    let cam = Camera::from_desc(&stage.scene().camera);
    let (c, r) = stage.bounds();
    let (near, far) = cam.clip_planes(c, r);
    let vp = cam.view_proj(size.0 as f64 / size.1 as f64, near, far);
    let params = ProbeParams {
        view_proj: vp.to_cols_array(),
        size: [size.0, size.1],
        count: anjyo.hair.strand_count,
        _pad: 0,
    };
    let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("splat params"),
        contents: bytemuck::bytes_of(&params),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let pixels = size.0 as u64 * size.1 as u64;
    let image = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("splat image"),
        size: pixels * 4,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let source = format!(
        "{}\n{SHADER}",
        include_str!("../../shaders/common/strands.wgsl")
    );
    let module = gpu::shader_module(device, "splat probe", &source)?;
    let layout = bind::layout(
        device,
        "splat probe",
        wgpu::ShaderStages::COMPUTE,
        &[
            bind::uniform::<ProbeParams>(),
            bind::storage::<GpuStrand>(),
            bind::storage::<[f32; 4]>(),
            bind::storage_rw::<u32>(),
        ],
    );
    let [pipeline] =
        gpu::compute_pipelines(device, "splat probe", &layout, &module, ["splat"], &[]);
    let group = bind::buffers(
        device,
        "splat probe",
        &layout,
        &[&params, &anjyo.hair.strands, &anjyo.hair.vertices, &image],
    );
    let groups = anjyo.hair.strand_count.div_ceil(64);
    let (gx, gy) = (groups.min(65535), groups.div_ceil(65535));
    let mut times = Vec::new();
    for _ in 0..runs + 1 {
        let t = Instant::now();
        let mut enc = device.create_command_encoder(&Default::default());
        enc.clear_buffer(&image, 0, None);
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.remove(0);
    times.sort_by(f64::total_cmp);
    let counts: Vec<u32> = gpu::read_buffer(gpu, &image, pixels * 4)?;
    gpu.take_error()?;
    Ok(Some(Probe {
        ms: times[times.len() / 2],
        pixel_steps: counts.iter().map(|&c| c as u64).sum(),
    }))
}
