//! Hair ribbons (`shaders/anjyo/draw.wgsl`): one instanced triangle strip per group, each
//! instance a strand, its vertices built from the strand storage buffers in the vertex
//! shader. With MSAA, sub-pixel coverage becomes a per-sample stochastic sample mask
//! (`shaders/common/coverage.wgsl`: hashed from pixel, strand and sample, so thin hairs add
//! up as real coverage does, in any order); without MSAA it is alpha-blended.
//!
//! The screen-space level of detail (`systems::lod`) reaches the pass as a share of each
//! group's strands (times the viewer's budget), a width factor and a node step, the last two
//! in a small uniform (`prepare`): the vertex shader draws every step-th node and the last.

use crate::error::Result;
use crate::gpu::gpu_data::{linear_rgb, GpuMaterial};
use crate::gpu::pipeline::{self, DrawPipeline};
use crate::gpu::strands::StrandBuffers;
use crate::gpu::{self, Gpu};
use crate::scene::Material;

/// Strands of a group of `count` drawn at level of detail `fraction`: the first ones, a
/// uniform random subset because pores are drawn in random order (Van Gelder's
/// creation-order culling).
pub fn drawn_count(count: u32, fraction: f64) -> u32 {
    ((count as f64 * fraction.clamp(0.0, 1.0)).ceil() as u32).min(count)
}

pub struct StrandsPass {
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    bound: Option<Bound>,
    /// x: width factor of the screen-space level of detail, y: node step (`prepare`).
    lod: wgpu::Buffer,
    step: u32,
}

struct Bound {
    bind_group: wgpu::BindGroup,
    materials: wgpu::Buffer,
    ranges: Vec<crate::gpu::strands::DrawRange>,
}

impl GpuMaterial {
    pub fn from_material(m: &Material) -> GpuMaterial {
        let c = linear_rgb(m.color);
        GpuMaterial {
            color_ks: [c[0], c[1], c[2], m.ks as f32],
            params: [
                m.shininess as f32,
                m.kd as f32,
                m.width as f32,
                m.tip_width as f32,
            ],
        }
    }
}

impl StrandsPass {
    /// `frame_layout` is the shared group 0 (frame uniform).
    pub fn new(
        gpu: &Gpu,
        frame_layout: &wgpu::BindGroupLayout,
        color_format: wgpu::TextureFormat,
        samples: u32,
    ) -> Result<StrandsPass> {
        let device = &gpu.device;
        let module = gpu::shader_module(device, "anjyo draw", super::DRAW)?;
        let vs = wgpu::ShaderStages::VERTEX;
        let layout = pipeline::layout(
            device,
            "strands",
            &[
                gpu::storage_entry(0, vs, true),
                gpu::storage_entry(1, vs, true),
                gpu::storage_entry(2, vs, true),
                gpu::uniform_entry(3, vs),
            ],
        );
        let pl = pipeline::pipeline_layout(device, "strands", &[frame_layout, &layout]);
        let pipeline = Self::pipeline(gpu, &module, &pl, color_format, samples);
        let lod = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("strands lod"),
                contents: bytemuck::bytes_of(&[1.0f32; 4]),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            },
        );
        Ok(StrandsPass {
            module,
            pipeline_layout: pl,
            format: color_format,
            pipeline,
            layout,
            bound: None,
            lod,
            step: 1,
        })
    }

    /// Rebuild the pipeline for another MSAA sample count (the bound hair stays).
    pub fn set_samples(&mut self, gpu: &Gpu, samples: u32) {
        self.pipeline = Self::pipeline(
            gpu,
            &self.module,
            &self.pipeline_layout,
            self.format,
            samples,
        );
    }

    fn pipeline(
        gpu: &Gpu,
        module: &wgpu::ShaderModule,
        pl: &wgpu::PipelineLayout,
        format: wgpu::TextureFormat,
        samples: u32,
    ) -> wgpu::RenderPipeline {
        DrawPipeline {
            label: "strands",
            layout: pl,
            module,
            vertex_entry: "vs",
            fragment_entry: pipeline::hair_fragment_entry(gpu),
            topology: wgpu::PrimitiveTopology::TriangleStrip,
            cull_mode: None,
            vertex_buffers: &[],
            blend: (samples <= 1).then_some(wgpu::BlendState::ALPHA_BLENDING),
            format,
            samples,
        }
        .build(&gpu.device)
    }

    /// Bind the hair to draw (after a groom) and its group materials.
    pub fn set_hair(&mut self, gpu: &Gpu, hair: &StrandBuffers, materials: &[GpuMaterial]) {
        let materials = gpu::storage_buffer(
            &gpu.device,
            "materials",
            bytemuck::cast_slice(materials),
            wgpu::BufferUsages::empty(),
        );
        let bind_group = pipeline::bind_buffers(
            &gpu.device,
            "strands",
            &self.layout,
            &[&hair.strands, &hair.vertices, &materials, &self.lod],
        );
        self.bound = Some(Bound {
            bind_group,
            materials,
            ranges: hair.ranges.clone(),
        });
    }

    /// Update materials in place (look tweaks without a re-groom).
    pub fn update_materials(&self, queue: &wgpu::Queue, materials: &[GpuMaterial]) {
        if let Some(b) = &self.bound {
            queue.write_buffer(&b.materials, 0, bytemuck::cast_slice(materials));
        }
    }

    /// The screen-space level of detail's width factor and node step for the next draws.
    pub fn prepare(&mut self, queue: &wgpu::Queue, width_scale: f64, step: u32) {
        self.step = step.max(1);
        let lod = [width_scale as f32, self.step as f32, 0.0, 0.0];
        queue.write_buffer(&self.lod, 0, bytemuck::bytes_of(&lod));
    }

    /// Nodes drawn per strand of a group with `nodes_per_strand` nodes.
    pub fn drawn_nodes(&self, nodes_per_strand: u32) -> u32 {
        crate::systems::lod::drawn_nodes(nodes_per_strand.saturating_sub(1), self.step)
    }

    /// Draw `fraction` of each group's hairs (`drawn_count`), every `step`-th node.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, fraction: f64) {
        let Some(b) = &self.bound else { return };
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(1, &b.bind_group, &[]);
        for r in &b.ranges {
            let count = drawn_count(r.strand_count, fraction);
            if count == 0 {
                continue;
            }
            pass.draw(
                0..2 * self.drawn_nodes(r.nodes_per_strand),
                r.first_strand..r.first_strand + count,
            );
        }
    }
}
