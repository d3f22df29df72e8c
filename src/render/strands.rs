//! Hair ribbons (`shaders/strands.wgsl`): one instanced triangle strip per group, each
//! instance a strand, its vertices built from the strand storage buffers in the vertex
//! shader. With MSAA, sub-pixel coverage becomes a sample mask (alpha to coverage, order
//! independent); without, it is alpha-blended.

use crate::error::Result;
use crate::gpu::gpu_data::{linear_rgb, GpuMaterial};
use crate::gpu::strands::StrandBuffers;
use crate::gpu::{self, Gpu};
use crate::scene::Material;

pub struct StrandsPass {
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    bound: Option<Bound>,
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
        let module = gpu::shader_module(device, "strands", crate::shaders::STRANDS)?;
        let vs = wgpu::ShaderStages::VERTEX;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("strands"),
            entries: &[
                gpu::storage_entry(0, vs, true),
                gpu::storage_entry(1, vs, true),
                gpu::storage_entry(2, vs, true),
            ],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("strands"),
            bind_group_layouts: &[Some(frame_layout), Some(&layout)],
            immediate_size: 0,
        });
        let fs = super::hair_fragment_entry(gpu);
        let pipeline = Self::pipeline(device, &module, &pl, color_format, samples, fs);
        Ok(StrandsPass {
            module,
            pipeline_layout: pl,
            format: color_format,
            pipeline,
            layout,
            bound: None,
        })
    }

    /// Rebuild the pipeline for another MSAA sample count (the bound hair stays).
    pub fn set_samples(&mut self, gpu: &Gpu, samples: u32) {
        self.pipeline = Self::pipeline(
            &gpu.device,
            &self.module,
            &self.pipeline_layout,
            self.format,
            samples,
            super::hair_fragment_entry(gpu),
        );
    }

    fn pipeline(
        device: &wgpu::Device,
        module: &wgpu::ShaderModule,
        pl: &wgpu::PipelineLayout,
        color_format: wgpu::TextureFormat,
        samples: u32,
        fs: &str,
    ) -> wgpu::RenderPipeline {
        let msaa = samples > 1;
        let blend = if msaa {
            None
        } else {
            Some(wgpu::BlendState::ALPHA_BLENDING)
        };
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("strands"),
            layout: Some(pl),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleStrip,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(super::depth_state(true)),
            multisample: wgpu::MultisampleState {
                count: samples,
                mask: !0,
                alpha_to_coverage_enabled: false,
            },
            fragment: Some(wgpu::FragmentState {
                module,
                entry_point: Some(fs),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: color_format,
                    blend,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    }

    /// Bind the hair to draw (after a groom) and its group materials.
    pub fn set_hair(&mut self, gpu: &Gpu, hair: &StrandBuffers, materials: &[GpuMaterial]) {
        let materials = gpu::storage_buffer(
            &gpu.device,
            "materials",
            bytemuck::cast_slice(materials),
            wgpu::BufferUsages::empty(),
        );
        let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("strands"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: hair.strands.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: hair.vertices.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: materials.as_entire_binding(),
                },
            ],
        });
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

    /// Draw `fraction` of each group's hairs: the first ones, which are a uniform random
    /// subset because pores are drawn in random order (Van Gelder's creation-order culling).
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, fraction: f64) {
        let Some(b) = &self.bound else { return };
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(1, &b.bind_group, &[]);
        for r in &b.ranges {
            let count = ((r.strand_count as f64 * fraction.clamp(0.0, 1.0)).ceil() as u32)
                .min(r.strand_count);
            if count == 0 {
                continue;
            }
            pass.draw(
                0..2 * r.nodes_per_strand,
                r.first_strand..r.first_strand + count,
            );
        }
    }
}
