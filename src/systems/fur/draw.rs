//! Fur drawing (`shaders/fur/draw.wgsl`) and the fur mesh's skin (`shaders/fur/skin.wgsl`):
//! ribbons for line, polyline and curve hairs, 6-sided tubes for tube hairs, one instanced
//! draw per coat over the hairs the generator wrote this frame. Under the compute
//! rasteriser (`render.strands`) the line, polyline and curve coats go through
//! `shaders/common/splat.wgsl` instead (`shaders/fur/splat.wgsl` shades their nodes as the
//! ribbons do); tubes are always triangles.

use super::generate::{motion_uniform, style_code, FurGpu, GpuJoints};
use super::gpu_data::{GpuFurMaterial, GpuSkin};
use super::setup::FurSetup;
use crate::error::Result;
use crate::gpu::gpu_data::{linear_rgb, GpuStrand};
use crate::gpu::pipeline::{self, DrawPipeline, Variant};
use crate::gpu::splat::{KernelSource, LazyKernels, SplatKernels, SplatLayouts};
use crate::gpu::{self, bind, Gpu};
use crate::systems::fur::block::FurStyle;

pub struct FurPass {
    module: wgpu::ShaderModule,
    mesh_module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    mesh_pipeline_layout: wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
    ribbon: wgpu::RenderPipeline,
    tube: wgpu::RenderPipeline,
    skin: wgpu::RenderPipeline,
    variant: Variant,
    /// Whether some coat shades physically: the hair pipelines compile that mode only then.
    physical: bool,
    layout: wgpu::BindGroupLayout,
    mesh_layout: wgpu::BindGroupLayout,
    /// The shadow cast: its group 1 and pipeline (`shaders/fur/cast.wgsl`).
    cast_layout: wgpu::BindGroupLayout,
    cast: Option<wgpu::ComputePipeline>,
    /// The skin's cast into the skin map (`cast_skin` in `shaders/fur/skin.wgsl`, group 1
    /// the skin's own).
    cast_skin: wgpu::ComputePipeline,
    bound: Option<Bound>,
    /// The compute rasteriser's group 1 (the coats' strands, nodes, shading info,
    /// materials and drawn ranges), group 0 and the target's group 2 layouts.
    splat_layout: wgpu::BindGroupLayout,
    frame_layout: wgpu::BindGroupLayout,
    splat_layouts: SplatLayouts,
    /// Made on the first frame that splats, for the current MSAA sample count.
    splat: LazyKernels,
    device: wgpu::Device,
    /// On GL a multisampled depth that a shader reads leaves the scene pass black
    /// (llvmpipe): there the compute rasteriser runs only without MSAA.
    gl: bool,
}

struct Bound {
    bind_group: wgpu::BindGroup,
    mesh_bind_group: wgpu::BindGroup,
    cast_group: wgpu::BindGroup,
    /// Per coat: first hair, one past the last drawn (the cast's level of detail).
    cast_coats: wgpu::Buffer,
    materials: wgpu::Buffer,
    skin: wgpu::Buffer,
    /// Per coat: first strand, tube or not, vertices per instance.
    coats: Vec<(u32, bool, u32)>,
    /// The compute rasteriser's group 1 and its per-coat drawn ranges (tube coats empty).
    splat_group: wgpu::BindGroup,
    splat_coats: wgpu::Buffer,
    mesh_vertices: u32,
    skin_base: u32,
}

/// The coat materials for the GPU; `width_scale` widens hair when culling draws fewer.
/// `steps[coat]`: the screen-space level of detail's node step (ribbons; missing = 1);
/// `shading`: the scene's (a coat's own overrides it).
pub fn fur_materials(
    setup: &FurSetup,
    width_scale: f64,
    steps: &[u32],
    shading: crate::scene::Shading,
) -> Vec<GpuFurMaterial> {
    setup
        .fur
        .coats
        .iter()
        .enumerate()
        .map(|(ci, c)| {
            let m = &c.material;
            let step = steps.get(ci).copied().unwrap_or(1).max(1);
            let (a, d, s) = (
                linear_rgb(m.ambient),
                linear_rgb(m.diffuse),
                linear_rgb(m.specular),
            );
            GpuFurMaterial {
                ambient: [a[0], a[1], a[2], m.width as f32],
                diffuse: [d[0], d[1], d[2], style_code(c.style) as f32],
                specular: [s[0], s[1], s[2], m.shininess as f32],
                extra: [
                    c.normal_randomize as f32,
                    width_scale as f32,
                    step as f32,
                    setup.coat_density(ci) as f32,
                ],
                bsdf: crate::systems::hair_bsdf::gpu_block(
                    shading,
                    m.shading,
                    &m.physical,
                    m.diffuse,
                ),
            }
        })
        .collect()
}

/// The skin uniform at `frame`, under the coats' `materials` (`fur_materials`).
pub fn skin_uniform(
    setup: &FurSetup,
    materials: &[GpuFurMaterial],
    frame: f64,
    skin_base: u32,
) -> GpuSkin {
    let c = linear_rgb(setup.fur.skin);
    let (motion, axis, dir) = motion_uniform(setup.fur.motion.as_ref(), frame);
    GpuSkin {
        color: [c[0], c[1], c[2], 1.0],
        motion,
        motion_axis: axis,
        motion_dir: dir,
        skin: [skin_base, u32::from(setup.mesh.closed), 0, 0],
        coat: skin_coat(setup, materials),
    }
}

/// The physical coats over the skin, as the skin's ambient reads them: w the fibre-area
/// index of all of them per unit of the mesh's hair length (each coat's density times its
/// relative length times 0.75, the mean of the width's taper from 1 to `TIP_WIDTH`), rgb their a_f
/// weighted by it (exact for one coat). The skin's ambient is dimmed by
/// `hair_bsdf::ambient_transmittance(a_f, w * length)`, as a node's by the coat above it.
/// Zero where no coat shades physically (Anjyo's mode keeps the paper's skin).
pub fn skin_coat(setup: &FurSetup, materials: &[GpuFurMaterial]) -> [f32; 4] {
    let (mut w, mut a_f) = (0.0f64, [0.0f64; 3]);
    for (ci, (coat, m)) in setup.fur.coats.iter().zip(materials).enumerate() {
        if m.bsdf.sigma_a[3] <= 0.5 {
            continue;
        }
        let wc = setup.coat_density(ci) * coat.relative_length * (1.0 + super::TIP_WIDTH) / 2.0;
        w += wc;
        for (a, &f) in a_f.iter_mut().zip(&m.bsdf.a_f) {
            *a += wc * f as f64;
        }
    }
    if w <= 0.0 {
        return [0.0; 4];
    }
    [
        (a_f[0] / w) as f32,
        (a_f[1] / w) as f32,
        (a_f[2] / w) as f32,
        w as f32,
    ]
}

impl FurPass {
    pub fn new(
        gpu: &Gpu,
        frame_layout: &wgpu::BindGroupLayout,
        splat_layouts: &SplatLayouts,
        shadow_cast_layout: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
        variant: Variant,
    ) -> Result<FurPass> {
        let device = &gpu.device;
        let module = gpu::shader_module(device, "fur draw", super::DRAW)?;
        let mesh_module = gpu::shader_module(device, "fur skin", super::SKIN)?;
        let vs = wgpu::ShaderStages::VERTEX;
        let layout = bind::layout(
            device,
            "fur",
            vs,
            &[
                bind::storage::<GpuStrand>(),
                bind::storage::<[f32; 4]>(),
                bind::storage::<[f32; 4]>(),
                bind::storage::<GpuFurMaterial>(),
            ],
        );
        // Read by the skin's draw and by its cast (compute).
        let mesh_layout = bind::layout(
            device,
            "fur skin",
            vs | wgpu::ShaderStages::COMPUTE,
            &[
                bind::uniform::<GpuSkin>()
                    .seen_by(wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE),
                bind::storage::<[f32; 4]>(),
                bind::storage::<[u32; 4]>(),
                bind::uniform::<GpuJoints>(),
            ],
        );
        let pipeline_layout = pipeline::pipeline_layout(device, "fur", &[frame_layout, &layout]);
        let mesh_pipeline_layout =
            pipeline::pipeline_layout(device, "fur skin", &[frame_layout, &mesh_layout]);
        let (ribbon, tube, skin) = Self::pipelines(
            gpu,
            (&module, &pipeline_layout),
            (&mesh_module, &mesh_pipeline_layout),
            format,
            variant,
            false,
        );
        let cast_layout = bind::layout(
            device,
            "fur cast",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::storage::<GpuStrand>(),
                bind::storage::<[f32; 4]>(),
                bind::storage::<GpuFurMaterial>(),
                bind::storage::<[u32; 2]>(),
            ],
        );
        let cast_module = gpu::shader_module(device, "fur cast", super::CAST)?;
        let cast_pl = pipeline::pipeline_layout(
            device,
            "fur cast",
            &[frame_layout, &cast_layout, shadow_cast_layout],
        );
        let cast = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("fur cast"),
            layout: Some(&cast_pl),
            module: &cast_module,
            entry_point: Some("cast_shadow"),
            compilation_options: Default::default(),
            cache: None,
        });
        let skin_cast_pl = pipeline::pipeline_layout(
            device,
            "fur skin cast",
            &[frame_layout, &mesh_layout, shadow_cast_layout],
        );
        let cast_skin = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("fur skin cast"),
            layout: Some(&skin_cast_pl),
            module: &mesh_module,
            entry_point: Some("cast_skin"),
            compilation_options: Default::default(),
            cache: None,
        });
        // Group 1 of `shaders/fur/splat.wgsl` (`strand_drawn.wgsl`'s ranges at 4).
        let splat_layout = bind::layout(
            device,
            "fur splat",
            wgpu::ShaderStages::COMPUTE,
            &[
                bind::storage::<GpuStrand>(),
                bind::storage::<[f32; 4]>(),
                bind::storage::<[f32; 4]>(),
                bind::storage::<GpuFurMaterial>(),
                bind::storage::<[u32; 2]>(),
            ],
        );
        Ok(FurPass {
            splat_layout,
            frame_layout: frame_layout.clone(),
            splat_layouts: splat_layouts.clone(),
            splat: Default::default(),
            device: device.clone(),
            gl: gpu.info.backend == wgpu::Backend::Gl,
            cast_layout,
            cast: Some(cast),
            cast_skin,
            module,
            mesh_module,
            pipeline_layout,
            mesh_pipeline_layout,
            format,
            ribbon,
            tube,
            skin,
            variant,
            physical: false,
            layout,
            mesh_layout,
            bound: None,
        })
    }

    /// Rebuild the pipelines for another MSAA sample count or shadow lookup.
    pub fn set_variant(&mut self, gpu: &Gpu, variant: Variant) {
        self.variant = variant;
        self.rebuild(gpu);
    }

    fn rebuild(&mut self, gpu: &Gpu) {
        self.splat.reset();
        (self.ribbon, self.tube, self.skin) = Self::pipelines(
            gpu,
            (&self.module, &self.pipeline_layout),
            (&self.mesh_module, &self.mesh_pipeline_layout),
            self.format,
            self.variant,
            self.physical,
        );
    }

    /// The hair's ribbon and tube pipelines from `(module, layout)`, the skin's from
    /// `(mesh_module, mesh_layout)`.
    fn pipelines(
        gpu: &Gpu,
        (module, pl): (&wgpu::ShaderModule, &wgpu::PipelineLayout),
        (mesh_module, mesh_pl): (&wgpu::ShaderModule, &wgpu::PipelineLayout),
        format: wgpu::TextureFormat,
        variant: Variant,
        physical: bool,
    ) -> (
        wgpu::RenderPipeline,
        wgpu::RenderPipeline,
        wgpu::RenderPipeline,
    ) {
        let hair_fs = pipeline::hair_fragment_entry(gpu);
        let base = DrawPipeline {
            label: "vs_ribbon",
            layout: pl,
            module,
            vertex_entry: "vs_ribbon",
            fragment_entry: hair_fs,
            topology: wgpu::PrimitiveTopology::TriangleStrip,
            cull_mode: None,
            vertex_buffers: &[],
            // Sub-pixel ribbons blend their coverage without MSAA; tubes are real geometry.
            blend: (variant.samples <= 1).then_some(wgpu::BlendState::ALPHA_BLENDING),
            format,
            variant,
            physical: Some(physical),
        };
        let tube = DrawPipeline {
            label: "vs_tube",
            vertex_entry: "vs_tube",
            topology: wgpu::PrimitiveTopology::TriangleList,
            blend: None,
            ..base
        };
        let skin = DrawPipeline {
            label: "fur skin",
            layout: mesh_pl,
            module: mesh_module,
            vertex_entry: "vs",
            fragment_entry: "fs",
            topology: wgpu::PrimitiveTopology::TriangleList,
            blend: None,
            physical: None,
            ..base
        };
        let device = &gpu.device;
        (base.build(device), tube.build(device), skin.build(device))
    }

    /// Bind a fur generator's buffers (after it is built).
    pub fn set_fur(&mut self, gpu: &Gpu, setup: &FurSetup, fur: &FurGpu) {
        let device = &gpu.device;
        let materials = gpu::storage_buffer(
            device,
            "fur materials",
            bytemuck::cast_slice(&fur_materials(setup, 1.0, &[], Default::default())),
            wgpu::BufferUsages::empty(),
        );
        let skin = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fur skin"),
            size: std::mem::size_of::<GpuSkin>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = bind::buffers(
            device,
            "fur",
            &self.layout,
            &[
                &fur.strands.strands,
                &fur.strands.vertices,
                &fur.info,
                &materials,
            ],
        );
        let mesh_bind_group = bind::buffers(
            device,
            "fur skin",
            &self.mesh_layout,
            &[&skin, &fur.mesh, &fur.tris, &fur.joints],
        );
        let coats: Vec<(u32, bool, u32)> = setup
            .fur
            .coats
            .iter()
            .zip(&fur.strands.ranges)
            .map(|(c, r)| {
                let tube = c.style == FurStyle::Tube;
                (r.first_strand, tube, c.style.segments())
            })
            .collect();
        let none: Vec<[u32; 2]> = coats.iter().map(|c| [c.0, c.0]).collect();
        let cast_coats = gpu::storage_buffer(
            device,
            "fur cast coats",
            bytemuck::cast_slice(&none),
            wgpu::BufferUsages::empty(),
        );
        let cast_group = bind::buffers(
            device,
            "fur cast",
            &self.cast_layout,
            &[
                &fur.strands.strands,
                &fur.strands.vertices,
                &materials,
                &cast_coats,
            ],
        );
        let splat_coats = gpu::storage_buffer(
            device,
            "fur splat coats",
            bytemuck::cast_slice(&none),
            wgpu::BufferUsages::empty(),
        );
        let splat_group = bind::buffers(
            device,
            "fur splat",
            &self.splat_layout,
            &[
                &fur.strands.strands,
                &fur.strands.vertices,
                &fur.info,
                &materials,
                &splat_coats,
            ],
        );
        self.bound = Some(Bound {
            splat_group,
            splat_coats,
            bind_group,
            mesh_bind_group,
            cast_group,
            cast_coats,
            materials,
            skin,
            coats,
            mesh_vertices: setup.mesh.triangles.len() as u32 * 3,
            skin_base: fur.skin_base,
        });
    }

    /// Per-frame uniforms: materials (culling widens hair) and the skin's motion.
    pub fn prepare(
        &mut self,
        gpu: &Gpu,
        setup: &FurSetup,
        frame: f64,
        width_scale: f64,
        steps: &[u32],
        shading: crate::scene::Shading,
    ) {
        let materials = fur_materials(setup, width_scale, steps, shading);
        let physical = materials.iter().any(|m| m.bsdf.sigma_a[3] > 0.5);
        if physical != self.physical {
            // Some coat took or left the physical mode: the hair pipelines compile it only
            // while one uses it.
            self.physical = physical;
            self.rebuild(gpu);
        }
        if let Some(b) = &self.bound {
            gpu.queue
                .write_buffer(&b.materials, 0, bytemuck::cast_slice(&materials));
            gpu.queue.write_buffer(
                &b.skin,
                0,
                bytemuck::bytes_of(&skin_uniform(setup, &materials, frame, b.skin_base)),
            );
        }
    }

    /// The hairs of this frame that cast (`drawn[coat]` per coat, as drawn).
    pub fn set_drawn(&self, gpu: &Gpu, drawn: &[u32]) {
        if let Some(b) = &self.bound {
            let r: Vec<[u32; 2]> = b
                .coats
                .iter()
                .zip(drawn)
                .map(|(c, &n)| [c.0, c.0 + n])
                .collect();
            if r.len() == b.coats.len() && !r.is_empty() {
                gpu.queue
                    .write_buffer(&b.cast_coats, 0, bytemuck::cast_slice(&r));
                // The compute rasteriser draws the same hairs, tubes aside.
                let thin: Vec<[u32; 2]> = b
                    .coats
                    .iter()
                    .zip(r)
                    .map(|(c, r)| if c.1 { [r[0], r[0]] } else { r })
                    .collect();
                gpu.queue
                    .write_buffer(&b.splat_coats, 0, bytemuck::cast_slice(&thin));
            }
        }
    }

    /// Deposit the drawn hairs into the shadow structure (groups 0 and 2 are bound).
    pub fn cast(&self, pass: &mut wgpu::ComputePass<'_>, hairs: u32) {
        let (Some(b), Some(p)) = (&self.bound, &self.cast) else {
            return;
        };
        let groups = hairs.div_ceil(64);
        if groups == 0 {
            return;
        }
        pass.set_pipeline(p);
        pass.set_bind_group(1, &b.cast_group, &[]);
        pass.dispatch_workgroups(groups.min(65535), groups.div_ceil(65535), 1);
    }

    /// Cast the skin's triangles into the skin map (groups 0 and 2 are bound).
    pub fn cast_skin(&self, pass: &mut wgpu::ComputePass<'_>) {
        let Some(b) = &self.bound else { return };
        let groups = (b.mesh_vertices / 3).div_ceil(64);
        if groups == 0 {
            return;
        }
        pass.set_pipeline(&self.cast_skin);
        pass.set_bind_group(1, &b.mesh_bind_group, &[]);
        pass.dispatch_workgroups(groups.min(65535), groups.div_ceil(65535), 1);
    }

    /// Draw the skin (opaque).
    pub fn draw_skin(&self, pass: &mut wgpu::RenderPass<'_>) {
        let Some(b) = &self.bound else { return };
        pass.set_pipeline(&self.skin);
        pass.set_bind_group(1, &b.mesh_bind_group, &[]);
        pass.draw(0..b.mesh_vertices, 0..1);
    }

    /// Draw `drawn[coat]` hairs of each coat, ribbons every `steps[coat]`-th node (tubes all);
    /// with `ribbons` false only the tube coats (the others splat).
    pub fn draw_hairs(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        drawn: &[u32],
        steps: &[u32],
        ribbons: bool,
    ) {
        let Some(b) = &self.bound else { return };
        pass.set_bind_group(1, &b.bind_group, &[]);
        for (ci, (&(first, tube, segments), &n)) in b.coats.iter().zip(drawn).enumerate() {
            if n == 0 || !(tube || ribbons) {
                continue;
            }
            let verts = if tube {
                36 * segments
            } else {
                let step = steps.get(ci).copied().unwrap_or(1);
                2 * crate::systems::lod::drawn_nodes(segments, step)
            };
            pass.set_pipeline(if tube { &self.tube } else { &self.ribbon });
            pass.draw(0..verts, first..first + n);
        }
    }

    /// Whether some coat is thin (line, polyline or curve: ribbons or the compute
    /// rasteriser) rather than tubes.
    pub fn has_thin_coats(&self) -> bool {
        self.bound
            .as_ref()
            .is_some_and(|b| b.coats.iter().any(|c| !c.1))
    }

    /// Whether the compute rasteriser can run at the current sample count (not over MSAA
    /// targets on GL; the ribbons draw there).
    pub fn can_splat(&self) -> bool {
        !(self.gl && self.variant.samples > 1)
    }

    /// No tile lists: fur walks one hair per invocation (binning is off by default).
    fn splat_kernels(&self) -> Result<SplatKernels> {
        let source = KernelSource {
            label: "fur splat",
            modules: [super::SPLAT, super::SPLAT_MSAA],
            frame: &self.frame_layout,
            kind: &self.splat_layout,
            bins: None,
        };
        SplatKernels::build(
            &self.device,
            &source,
            &self.splat_layouts,
            self.variant.samples,
            &self.variant.constants(Some(self.physical)),
        )
    }

    /// Record the compute rasteriser over the first `hairs` strands (each coat's drawn ones,
    /// tubes aside); groups 0 and 2 are bound by the stage.
    pub fn splat(&self, pass: &mut wgpu::ComputePass<'_>, hairs: u32) {
        let Some(b) = &self.bound else { return };
        let Some(kernels) = self.splat.get(|| self.splat_kernels()) else {
            return;
        };
        pass.set_bind_group(1, &b.splat_group, &[]);
        kernels.record(pass, hairs, None, 0);
    }
}
