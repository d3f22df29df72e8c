//! Fur drawing (`shaders/fur.wgsl`) and the fur mesh's skin (`shaders/mesh.wgsl`): ribbons
//! for line, polyline and curve hairs, 6-sided tubes for tube hairs, one instanced draw per
//! coat over the hairs the generator wrote this frame.

use crate::error::Result;
use crate::gpu::gpu_data::{linear_rgb, GpuFurMaterial, GpuSkin};
use crate::gpu::{self, Gpu};
use crate::groom::fur::{motion_uniform, style_code, FurGpu, FurSetup};
use crate::scene::fur::FurStyle;

pub struct FurPass {
    module: wgpu::ShaderModule,
    mesh_module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    mesh_pipeline_layout: wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    ribbon: wgpu::RenderPipeline,
    tube: wgpu::RenderPipeline,
    skin: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    mesh_layout: wgpu::BindGroupLayout,
    bound: Option<Bound>,
}

struct Bound {
    bind_group: wgpu::BindGroup,
    mesh_bind_group: wgpu::BindGroup,
    materials: wgpu::Buffer,
    skin: wgpu::Buffer,
    /// Per coat: first strand, tube or not, vertices per instance.
    coats: Vec<(u32, bool, u32)>,
    mesh_vertices: u32,
}

/// The coat materials for the GPU; `width_scale` widens hair when culling draws fewer.
pub fn fur_materials(setup: &FurSetup, width_scale: f64) -> Vec<GpuFurMaterial> {
    setup
        .fur
        .coats
        .iter()
        .map(|c| {
            let m = &c.material;
            let (a, d, s) = (
                linear_rgb(m.ambient),
                linear_rgb(m.diffuse),
                linear_rgb(m.specular),
            );
            GpuFurMaterial {
                ambient: [a[0], a[1], a[2], m.width as f32],
                diffuse: [d[0], d[1], d[2], style_code(c.style) as f32],
                specular: [s[0], s[1], s[2], m.shininess as f32],
                extra: [c.normal_randomize as f32, width_scale as f32, 0.0, 0.0],
            }
        })
        .collect()
}

/// The skin uniform at `frame`.
pub fn skin_uniform(setup: &FurSetup, frame: f64) -> GpuSkin {
    let c = linear_rgb(setup.fur.skin);
    let (motion, axis, dir) = motion_uniform(setup.fur.motion.as_ref(), frame);
    GpuSkin {
        color: [c[0], c[1], c[2], 1.0],
        motion,
        motion_axis: axis,
        motion_dir: dir,
    }
}

impl FurPass {
    pub fn new(
        gpu: &Gpu,
        frame_layout: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
        samples: u32,
    ) -> Result<FurPass> {
        let device = &gpu.device;
        let module = gpu::shader_module(device, "fur", crate::shaders::FUR)?;
        let mesh_module = gpu::shader_module(device, "mesh", crate::shaders::MESH)?;
        let vs = wgpu::ShaderStages::VERTEX;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("fur"),
            entries: &[
                gpu::storage_entry(0, vs, true),
                gpu::storage_entry(1, vs, true),
                gpu::storage_entry(2, vs, true),
                gpu::storage_entry(3, vs, true),
            ],
        });
        let mesh_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("fur skin"),
            entries: &[
                gpu::uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
                gpu::storage_entry(1, vs, true),
                gpu::storage_entry(2, vs, true),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("fur"),
            bind_group_layouts: &[Some(frame_layout), Some(&layout)],
            immediate_size: 0,
        });
        let mesh_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("fur skin"),
            bind_group_layouts: &[Some(frame_layout), Some(&mesh_layout)],
            immediate_size: 0,
        });
        let (ribbon, tube, skin) = Self::pipelines(
            gpu,
            &module,
            &mesh_module,
            &pipeline_layout,
            &mesh_pipeline_layout,
            format,
            samples,
        );
        Ok(FurPass {
            module,
            mesh_module,
            pipeline_layout,
            mesh_pipeline_layout,
            format,
            ribbon,
            tube,
            skin,
            layout,
            mesh_layout,
            bound: None,
        })
    }

    /// Rebuild the pipelines for another MSAA sample count.
    pub fn set_samples(&mut self, gpu: &Gpu, samples: u32) {
        (self.ribbon, self.tube, self.skin) = Self::pipelines(
            gpu,
            &self.module,
            &self.mesh_module,
            &self.pipeline_layout,
            &self.mesh_pipeline_layout,
            self.format,
            samples,
        );
    }

    fn pipelines(
        gpu: &Gpu,
        module: &wgpu::ShaderModule,
        mesh_module: &wgpu::ShaderModule,
        pl: &wgpu::PipelineLayout,
        mesh_pl: &wgpu::PipelineLayout,
        format: wgpu::TextureFormat,
        samples: u32,
    ) -> (
        wgpu::RenderPipeline,
        wgpu::RenderPipeline,
        wgpu::RenderPipeline,
    ) {
        let device = &gpu.device;
        let hair_fs = super::hair_fragment_entry(gpu);
        let msaa = samples > 1;
        let make = |module: &wgpu::ShaderModule,
                    layout: &wgpu::PipelineLayout,
                    entry: &str,
                    fs: &str,
                    topology,
                    coverage: bool| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(entry),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState {
                    topology,
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
                        format,
                        blend: (!msaa && coverage).then_some(wgpu::BlendState::ALPHA_BLENDING),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        (
            make(
                module,
                pl,
                "vs_ribbon",
                hair_fs,
                wgpu::PrimitiveTopology::TriangleStrip,
                true,
            ),
            make(
                module,
                pl,
                "vs_tube",
                hair_fs,
                wgpu::PrimitiveTopology::TriangleList,
                false,
            ),
            make(
                mesh_module,
                mesh_pl,
                "vs",
                "fs",
                wgpu::PrimitiveTopology::TriangleList,
                false,
            ),
        )
    }

    /// Bind a fur generator's buffers (after it is built).
    pub fn set_fur(&mut self, gpu: &Gpu, setup: &FurSetup, fur: &FurGpu) {
        let (mesh, tris) = (&fur.mesh, &fur.tris);
        let device = &gpu.device;
        let materials = gpu::storage_buffer(
            device,
            "fur materials",
            bytemuck::cast_slice(&fur_materials(setup, 1.0)),
            wgpu::BufferUsages::empty(),
        );
        let skin = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fur skin"),
            size: std::mem::size_of::<GpuSkin>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let e = gpu::entry;
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("fur"),
            layout: &self.layout,
            entries: &[
                e(0, &fur.strands.strands),
                e(1, &fur.strands.vertices),
                e(2, &fur.info),
                e(3, &materials),
            ],
        });
        let mesh_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("fur skin"),
            layout: &self.mesh_layout,
            entries: &[e(0, &skin), e(1, mesh), e(2, tris)],
        });
        let coats = setup
            .fur
            .coats
            .iter()
            .zip(&fur.strands.ranges)
            .map(|(c, r)| {
                let tube = c.style == FurStyle::Tube;
                let verts = if tube {
                    36 * c.style.segments()
                } else {
                    2 * (c.style.segments() + 1)
                };
                (r.first_strand, tube, verts)
            })
            .collect();
        self.bound = Some(Bound {
            bind_group,
            mesh_bind_group,
            materials,
            skin,
            coats,
            mesh_vertices: setup.mesh.triangles.len() as u32 * 3,
        });
    }

    /// Per-frame uniforms: materials (culling widens hair) and the skin's motion.
    pub fn prepare(&self, gpu: &Gpu, setup: &FurSetup, frame: f64, width_scale: f64) {
        if let Some(b) = &self.bound {
            gpu.queue.write_buffer(
                &b.materials,
                0,
                bytemuck::cast_slice(&fur_materials(setup, width_scale)),
            );
            gpu.queue
                .write_buffer(&b.skin, 0, bytemuck::bytes_of(&skin_uniform(setup, frame)));
        }
    }

    /// Draw the skin and `drawn[coat]` hairs of each coat.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, drawn: &[u32]) {
        let Some(b) = &self.bound else { return };
        pass.set_pipeline(&self.skin);
        pass.set_bind_group(1, &b.mesh_bind_group, &[]);
        pass.draw(0..b.mesh_vertices, 0..1);
        pass.set_bind_group(1, &b.bind_group, &[]);
        for (&(first, tube, verts), &n) in b.coats.iter().zip(drawn) {
            if n == 0 {
                continue;
            }
            pass.set_pipeline(if tube { &self.tube } else { &self.ribbon });
            pass.draw(0..verts, first..first + n);
        }
    }
}
