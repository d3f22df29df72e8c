//! The head: the collision ellipsoid drawn as a lit mesh (a unit UV sphere scaled by the
//! radii), or a mesh head's own triangles (`scene::hull`), z-buffered with the hair and moved
//! by the head pose.

use crate::error::Result;
use crate::gpu::gpu_data::{linear_rgb, GpuHead};
use crate::gpu::pipeline::{self, DrawPipeline, Variant};
use crate::gpu::{self, bind, Gpu};
use crate::scene::{Ellipsoid, HeadMesh};
use glam::{DMat4, DVec3, Mat4};
use wgpu::util::DeviceExt;

/// Drawn head radii relative to the collision hull.
pub const DRAWN_SCALE: f64 = 0.996;

/// A mesh head is drawn this far inside its surface (scene units) along its vertex normals,
/// for the same reason as `DRAWN_SCALE`.
pub const MESH_INSET: f64 = 0.03;

const RINGS: u32 = 48;
const SECTORS: u32 = 96;

pub struct HeadPass {
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    pipeline: wgpu::RenderPipeline,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    /// The mesh head the buffers hold (`None`: the unit sphere).
    mesh: Option<HeadMesh>,
    uniform: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

impl HeadPass {
    /// `frame_layout` is the shared group 0 (frame uniform).
    pub fn new(
        gpu: &Gpu,
        frame_layout: &wgpu::BindGroupLayout,
        color_format: wgpu::TextureFormat,
        variant: Variant,
    ) -> Result<HeadPass> {
        let device = &gpu.device;
        let module = gpu::shader_module(device, "head", crate::shaders::HEAD)?;
        let layout = bind::layout(
            device,
            "head",
            wgpu::ShaderStages::VERTEX_FRAGMENT,
            &[bind::uniform::<GpuHead>()],
        );
        let pl = pipeline::pipeline_layout(device, "head", &[frame_layout, &layout]);
        let pipeline = Self::pipeline(device, &module, &pl, color_format, variant);
        let (verts, idx) = unit_sphere();
        let (vertices, indices) = geometry(device, &verts, &idx);
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("head uniform"),
            size: std::mem::size_of::<GpuHead>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = bind::buffers(device, "head", &layout, &[&uniform]);
        Ok(HeadPass {
            module,
            pipeline_layout: pl,
            format: color_format,
            pipeline,
            vertices,
            indices,
            index_count: idx.len() as u32,
            mesh: None,
            uniform,
            bind_group,
        })
    }

    /// Rebuild the pipeline for another MSAA sample count or shadow lookup.
    pub fn set_variant(&mut self, gpu: &Gpu, variant: Variant) {
        self.pipeline = Self::pipeline(
            &gpu.device,
            &self.module,
            &self.pipeline_layout,
            self.format,
            variant,
        );
    }

    fn pipeline(
        device: &wgpu::Device,
        module: &wgpu::ShaderModule,
        pl: &wgpu::PipelineLayout,
        format: wgpu::TextureFormat,
        variant: Variant,
    ) -> wgpu::RenderPipeline {
        DrawPipeline {
            label: "head",
            layout: pl,
            module,
            vertex_entry: "vs",
            fragment_entry: "fs",
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: Some(wgpu::Face::Back),
            vertex_buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<[f32; 6]>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
            })],
            blend: None,
            format,
            variant,
            physical: None,
        }
        .build(device)
    }

    /// Draw the scene's mesh head (or the ellipsoid for `None`); buffers are rebuilt only
    /// when the mesh head changes.
    pub fn set_mesh(&mut self, gpu: &Gpu, head: &crate::scene::Head) -> Result<()> {
        if self.mesh == head.mesh {
            return Ok(());
        }
        let (verts, idx) = match crate::scene::hull::head_mesh(head)? {
            Some(m) => {
                let verts = m
                    .mesh
                    .positions
                    .iter()
                    .zip(&m.mesh.normals)
                    .map(|(p, n)| {
                        let q = (*p - *n * MESH_INSET).as_vec3();
                        let n = n.as_vec3();
                        [q.x, q.y, q.z, n.x, n.y, n.z]
                    })
                    .collect::<Vec<_>>();
                let idx: Vec<u32> = m.mesh.triangles.iter().flatten().copied().collect();
                (verts, idx)
            }
            None => unit_sphere(),
        };
        (self.vertices, self.indices) = geometry(&gpu.device, &verts, &idx);
        self.index_count = idx.len() as u32;
        self.mesh = head.mesh.clone();
        Ok(())
    }

    /// Set the ellipsoid (and its pose), colour and look (`physical`: a Lambertian, as the
    /// path tracer's head, for a scene shaded physically; else the paper scenes' soft wrap
    /// and highlight). The head is drawn `DRAWN_SCALE` smaller
    /// than the collision hull: nodes sit on the hull, so the chord between two of them dips
    /// below it by d^2/8R (0.01-0.03 cm here) and would vanish into the skin between nodes.
    pub fn prepare(
        &self,
        queue: &wgpu::Queue,
        hull: &Ellipsoid,
        pose: DMat4,
        color: [f32; 3],
        physical: bool,
    ) {
        // A mesh head's vertices are in head coordinates already.
        let radii = if self.mesh.is_some() {
            DVec3::ONE
        } else {
            hull.radii * DRAWN_SCALE
        };
        let center = if self.mesh.is_some() {
            DVec3::ZERO
        } else {
            hull.center
        };
        let model: Mat4 =
            (pose * DMat4::from_translation(center) * DMat4::from_scale(radii)).as_mat4();
        // Normals turn with the pose only (it is rigid).
        let rotation = DMat4::from_mat3(glam::DMat3::from_mat4(pose)).as_mat4();
        let c = linear_rgb(color);
        let r2 = radii * radii;
        let data = GpuHead {
            model: model.to_cols_array_2d(),
            rotation: rotation.to_cols_array_2d(),
            color: [c[0], c[1], c[2], if physical { 1.0 } else { 0.0 }],
            inv_radii2: [
                (1.0 / r2.x) as f32,
                (1.0 / r2.y) as f32,
                (1.0 / r2.z) as f32,
                0.0,
            ],
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&data));
    }

    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(1, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..self.index_count, 0, 0..1);
    }
}

fn geometry(
    device: &wgpu::Device,
    verts: &[[f32; 6]],
    idx: &[u32],
) -> (wgpu::Buffer, wgpu::Buffer) {
    let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("head vertices"),
        contents: bytemuck::cast_slice(verts),
        usage: wgpu::BufferUsages::VERTEX,
    });
    let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("head indices"),
        contents: bytemuck::cast_slice(idx),
        usage: wgpu::BufferUsages::INDEX,
    });
    (vertices, indices)
}

/// Unit UV sphere, counter-clockwise seen from outside: (position, normal) per vertex, the
/// normal being the position.
fn unit_sphere() -> (Vec<[f32; 6]>, Vec<u32>) {
    let mut v = Vec::new();
    for r in 0..=RINGS {
        let theta = std::f32::consts::PI * r as f32 / RINGS as f32;
        for s in 0..=SECTORS {
            let phi = std::f32::consts::TAU * s as f32 / SECTORS as f32;
            let (x, y, z) = (
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            v.push([x, y, z, x, y, z]);
        }
    }
    let mut idx = Vec::new();
    let row = SECTORS + 1;
    for r in 0..RINGS {
        for s in 0..SECTORS {
            let a = r * row + s;
            let b = a + row;
            idx.extend_from_slice(&[a, a + 1, b, a + 1, b + 1, b]);
        }
    }
    (v, idx)
}
