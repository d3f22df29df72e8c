//! The meshed path on the GPU (`block::WispDraw::Mesh`): the mesh of `super::mesh` in vertex
//! and index buffers, drawn in the scene pass with the march's toon shading and an inverted
//! hull for the outline (`shaders/wisps/mesh.wgsl`), and the rule `Auto` follows.

use super::march::GpuWispDraw;
use super::mesh::WispMesh;
use crate::error::{KamiError, Result};
use crate::gpu::pipeline::{self, DrawPipeline, Variant};
use crate::gpu::{self, bind, Gpu};
use crate::shaders::wgsl;
use crate::systems::wisps::block::{MeshOn, WispDraw};
use bytemuck::{Pod, Zeroable};
use glam::DMat4;
use serde::{Deserialize, Serialize};
use std::sync::OnceLock;

/// The mesh's shading and outline hull.
pub const MESH: &str = wgsl!(
    "common/frame.wgsl",
    "common/shadow.wgsl",
    "wisps/draw.wgsl",
    "wisps/mesh.wgsl",
    "wisps/toon.wgsl"
);

/// Twin of `MeshUniform` in `shaders/wisps/mesh.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuMeshUniform {
    pub model: [[f32; 4]; 4],
    pub outline: [f32; 4],
}

/// What `kami bench wisps` wrote (`bench::wisps::paths_section`).
const MEASURED: &str = include_str!("../../../docs/wisps_draw.ron");

/// What one kind of adapter drew best, and where it was measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DrawChoice {
    /// The adapter the bench ran on.
    pub adapter: String,
    /// Still wisps (meshed once).
    pub still: WispDraw,
    /// Moving wisps (meshed every frame).
    pub moving: WispDraw,
    /// Where moving wisps were meshed cheaper (`Cpu` or `Gpu`; none: not measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub moving_on: Option<MeshOn>,
}

/// `docs/wisps_draw.ron`: per adapter class.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DrawChoices {
    pub software: Option<DrawChoice>,
    pub hardware: Option<DrawChoice>,
}

/// The measured choices, or why they cannot be read.
pub fn choices() -> &'static std::result::Result<DrawChoices, String> {
    static C: OnceLock<std::result::Result<DrawChoices, String>> = OnceLock::new();
    C.get_or_init(|| parse_choices(MEASURED).map_err(|e| format!("docs/wisps_draw.ron: {e}")))
}

/// A `wisps_draw.ron` text; `Auto` is not an answer.
pub fn parse_choices(text: &str) -> std::result::Result<DrawChoices, String> {
    let c: DrawChoices = ron::from_str(text).map_err(|e| e.to_string())?;
    for d in [&c.software, &c.hardware].into_iter().flatten() {
        if d.still == WispDraw::Auto || d.moving == WispDraw::Auto {
            return Err("still and moving must be March or Mesh".into());
        }
        if d.moving_on == Some(MeshOn::Auto) {
            return Err("moving_on must be Cpu or Gpu".into());
        }
    }
    Ok(c)
}

/// Whether the wisps draw with the mesh under `draw` on an adapter of `device_type`, still
/// or `moving`. `Auto` takes what `kami bench wisps` measured on that class of adapter: the
/// mesh where it was cheaper than the march at every wisp count and size swept and within
/// `MESH_ERROR_BOUND` (`docs/wisps.md`). A software adapter not measured takes the hardware
/// answer for still wisps and the march for moving ones; a hardware GPU not measured draws
/// the mesh, moving wisps meshed on the GPU (`auto_meshes_on_gpu`): not timed, but on
/// toon_shake.ron the mesher evaluates the field at about 1.7 million points a frame where
/// the march at 1280x720 takes 0.9 million rays of about 22 steps each.
pub fn auto_draws_mesh(draw: WispDraw, device_type: wgpu::DeviceType, moving: bool) -> bool {
    match draw {
        WispDraw::Mesh => true,
        WispDraw::March => false,
        WispDraw::Auto => {
            let Ok(c) = choices() else { return false };
            let software = device_type == wgpu::DeviceType::Cpu;
            let (own, other) = if software {
                (&c.software, &c.hardware)
            } else {
                (&c.hardware, &c.software)
            };
            match (own, other) {
                (Some(o), _) => (if moving { o.moving } else { o.still }) == WispDraw::Mesh,
                (None, _) if !software => true,
                (None, Some(o)) => !moving && o.still == WispDraw::Mesh,
                (None, None) => false,
            }
        }
    }
}

/// Whether `MeshOn::Auto` polygonises on the GPU: never for still wisps (meshed once on the
/// CPU, in f64: orbiting costs only the raster); for moving wisps where `kami bench wisps`
/// measured it cheaper on this class of adapter (`DrawChoice::moving_on`), and where it did
/// not measure, on a hardware GPU (the nodes stay there, and the kernels run on the whole
/// chip) but not on a software adapter (whose compute runs on one of its threads).
pub fn auto_meshes_on_gpu(device_type: wgpu::DeviceType, moving: bool) -> bool {
    if !moving {
        return false;
    }
    let software = device_type == wgpu::DeviceType::Cpu;
    let measured = choices().as_ref().ok().and_then(|c| {
        if software {
            c.software.as_ref()
        } else {
            c.hardware.as_ref()
        }
        .and_then(|d| d.moving_on)
    });
    match measured {
        Some(on) => on == MeshOn::Gpu,
        None => !software,
    }
}

/// The image error the mesh may have against the converged f64 truth at 128²
/// (`kami bench wisps`) for `Auto` to draw it: mean error of 255 and the share of pixels
/// off by more than 24, the march's own figures before the mesh (issue 34).
pub const MESH_ERROR_BOUND: (f64, f64) = (2.4, 0.027);

/// Position (xyz, outline scale) and normal: one vertex.
const VERTEX_BYTES: u64 = 32;

/// The mesh on the GPU.
struct Buffers {
    positions: wgpu::Buffer,
    normals: wgpu::Buffer,
    indices: wgpu::Buffer,
    count: u32,
}

/// The meshed path's pipelines and buffers.
pub struct MeshPass {
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    surface: wgpu::RenderPipeline,
    hull: wgpu::RenderPipeline,
    draw_uniform: wgpu::Buffer,
    mesh_uniform: wgpu::Buffer,
    group: wgpu::BindGroup,
    buffers: Option<Buffers>,
    /// Whether the outline hull is drawn (an outline width above 0).
    outline: bool,
}

fn vertex_layouts() -> [Option<wgpu::VertexBufferLayout<'static>>; 2] {
    const POS: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x4];
    const NOR: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![1 => Float32x4];
    [
        Some(wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &POS,
        }),
        Some(wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &NOR,
        }),
    ]
}

impl MeshPass {
    pub fn new(
        gpu: &Gpu,
        frame_layout: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
        variant: Variant,
    ) -> Result<MeshPass> {
        let device = &gpu.device;
        let layout = bind::layout(
            device,
            "wisp mesh",
            wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
            &[
                bind::uniform::<GpuWispDraw>(),
                bind::uniform::<GpuMeshUniform>(),
            ],
        );
        let uniform = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let draw_uniform = uniform("wisp mesh draw", std::mem::size_of::<GpuWispDraw>() as u64);
        let mesh_uniform = uniform("wisp mesh", std::mem::size_of::<GpuMeshUniform>() as u64);
        let group = bind::group(
            device,
            "wisp mesh",
            &layout,
            &[
                draw_uniform.as_entire_binding(),
                mesh_uniform.as_entire_binding(),
            ],
        );
        let module = gpu::shader_module(device, "wisps/mesh", MESH)?;
        let pipeline_layout =
            pipeline::pipeline_layout(device, "wisp mesh", &[frame_layout, &layout]);
        let (surface, hull) = pipelines(device, &module, &pipeline_layout, format, variant);
        Ok(MeshPass {
            module,
            pipeline_layout,
            format,
            surface,
            hull,
            draw_uniform,
            mesh_uniform,
            group,
            buffers: None,
            outline: true,
        })
    }

    /// Rebuild the pipelines for another MSAA sample count or shadow lookup.
    pub fn set_variant(&mut self, gpu: &Gpu, variant: Variant) {
        (self.surface, self.hull) = pipelines(
            &gpu.device,
            &self.module,
            &self.pipeline_layout,
            self.format,
            variant,
        );
    }

    /// The mesh into new buffers, refused with the numbers where a buffer would pass the
    /// adapter's largest.
    pub fn upload(&mut self, gpu: &Gpu, mesh: &WispMesh) -> Result<()> {
        let limit = gpu.device.limits().max_buffer_size;
        let vertex_bytes = mesh.positions.len() as u64 * VERTEX_BYTES / 2;
        let index_bytes = mesh.indices.len() as u64 * 4;
        if vertex_bytes.max(index_bytes) > limit || mesh.positions.len() as u64 > u32::MAX as u64 {
            return Err(KamiError::Invalid {
                file: String::new(),
                field: "wisps.mesh.cell".into(),
                value: format!(
                    "{} vertices, {} triangles ({} and {} bytes)",
                    mesh.positions.len(),
                    mesh.triangles(),
                    vertex_bytes,
                    index_bytes
                ),
                allowed: format!(
                    "a mesh whose buffers fit the adapter's largest buffer ({limit} bytes): \
                     raise the cell"
                ),
            });
        }
        if mesh.indices.is_empty() {
            self.buffers = None;
            return Ok(());
        }
        let vb = |label, data: &[[f32; 4]]| {
            gpu::storage_buffer(
                &gpu.device,
                label,
                bytemuck::cast_slice(data),
                wgpu::BufferUsages::VERTEX,
            )
        };
        self.buffers = Some(Buffers {
            positions: vb("wisp mesh positions", &mesh.positions),
            normals: vb("wisp mesh normals", &mesh.normals),
            indices: gpu::storage_buffer(
                &gpu.device,
                "wisp mesh indices",
                bytemuck::cast_slice(&mesh.indices),
                wgpu::BufferUsages::INDEX,
            ),
            count: mesh.indices.len() as u32,
        });
        Ok(())
    }

    /// This frame's toon uniform, the mesh's frame (`model`) and the outline's half-width
    /// per unit distance (`eps_per_t`, as the march's; 0: no outline).
    pub fn write(&mut self, gpu: &Gpu, draw: &GpuWispDraw, model: DMat4, eps_per_t: f64) {
        gpu.queue
            .write_buffer(&self.draw_uniform, 0, bytemuck::bytes_of(draw));
        let u = GpuMeshUniform {
            model: model.as_mat4().to_cols_array_2d(),
            outline: [eps_per_t as f32, 0.0, 0.0, 0.0],
        };
        gpu.queue
            .write_buffer(&self.mesh_uniform, 0, bytemuck::bytes_of(&u));
        self.outline = eps_per_t > 0.0;
    }

    /// Triangles in the mesh drawn.
    pub fn triangles(&self) -> u32 {
        self.buffers.as_ref().map_or(0, |b| b.count / 3)
    }

    /// In the scene pass: the GPU mesher's mesh (`mesh_gpu`), drawn indirectly with the
    /// count its kernels left.
    pub fn draw_gpu(&self, pass: &mut wgpu::RenderPass<'_>, b: super::mesh_gpu::MeshBuffers<'_>) {
        pass.set_bind_group(1, &self.group, &[]);
        pass.set_vertex_buffer(0, b.positions);
        pass.set_vertex_buffer(1, b.normals);
        pass.set_index_buffer(b.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.set_pipeline(&self.surface);
        pass.draw_indexed_indirect(b.indirect, b.indirect_offset);
        if self.outline {
            pass.set_pipeline(&self.hull);
            pass.draw_indexed_indirect(b.indirect, b.indirect_offset);
        }
    }

    /// Drop the CPU mesh's buffers (the GPU mesher draws instead).
    pub fn clear(&mut self) {
        self.buffers = None;
    }

    /// In the scene pass: the surface, then the outline hull behind it.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        let Some(b) = &self.buffers else {
            return;
        };
        pass.set_bind_group(1, &self.group, &[]);
        pass.set_vertex_buffer(0, b.positions.slice(..));
        pass.set_vertex_buffer(1, b.normals.slice(..));
        pass.set_index_buffer(b.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.set_pipeline(&self.surface);
        pass.draw_indexed(0..b.count, 0, 0..1);
        if self.outline {
            pass.set_pipeline(&self.hull);
            pass.draw_indexed(0..b.count, 0, 0..1);
        }
    }
}

/// The surface (back faces culled: the mesh is closed and wound outward) and the outline
/// hull (front faces culled: only the pushed-out shell's far side shows, round silhouettes).
fn pipelines(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    variant: Variant,
) -> (wgpu::RenderPipeline, wgpu::RenderPipeline) {
    let buffers = vertex_layouts();
    let build = |label, vertex_entry, fragment_entry, cull_mode| {
        DrawPipeline {
            label,
            layout,
            module,
            vertex_entry,
            fragment_entry,
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode,
            vertex_buffers: &buffers,
            blend: None,
            format,
            variant,
            physical: None,
        }
        .build(device)
    };
    (
        build("wisp mesh", "vs", "fs", Some(wgpu::Face::Back)),
        build(
            "wisp mesh outline",
            "vs_outline",
            "fs_outline",
            Some(wgpu::Face::Front),
        ),
    )
}
