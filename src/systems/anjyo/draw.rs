//! Hair ribbons (`shaders/anjyo/draw.wgsl`): one instanced triangle strip per group, each
//! instance a strand, its vertices built from the strand storage buffers in the vertex
//! shader. With MSAA, sub-pixel coverage becomes a per-sample stochastic sample mask
//! (`shaders/common/coverage.wgsl`: hashed from pixel, strand and sample, so thin hairs add
//! up as real coverage does, in any order); without MSAA it is alpha-blended.
//!
//! The screen-space level of detail (`systems::lod`) reaches the pass as a share of each
//! group's strands (times the viewer's budget), a width factor and a node step, the last two
//! in a small uniform (`prepare`): the vertex shader draws every step-th node and the last.
//!
//! With `render.strands: Compute` the same strands go through the compute rasteriser for
//! thin strands instead (`shaders/common/splat.wgsl`, f64 reference in `splat.rs`), bound to
//! the same buffers and shaded by the same code (`shaders/common/strand_shade.wgsl`).

use super::gpu_data::{GpuLook, GpuMaterial};
use crate::error::Result;
use crate::gpu::gpu_data::{linear_rgb, GpuStrand};
use crate::gpu::pipeline::{self, DrawPipeline, Variant};
use crate::gpu::splat::{KernelSource, LazyKernels, SplatKernels, SplatLayouts, TileBins};
use crate::gpu::strands::StrandBuffers;
use crate::gpu::{self, bind, Gpu};
use crate::systems::anjyo::block::Material;

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
    frame_layout: wgpu::BindGroupLayout,
    splat_layouts: SplatLayouts,
    /// The compute rasteriser for the current MSAA sample count (the depth it reads),
    /// made on the first frame that splats.
    splat: LazyKernels,
    /// Bin the segments by screen tile (`bin_*` kernels) rather than walk each strand with
    /// global atomics (`splat`); the same accumulation either way. Off until a hardware GPU
    /// shows binning faster: on lavapipe it is 2.2 times slower (`kami bench scale`,
    /// docs/raster.md), where atomics are cheap and its repeated node shading is not.
    binned: bool,
    /// The tile lists while binning, for the target size of the last `prepare`.
    bins: Option<TileBins>,
    bins_layout: wgpu::BindGroupLayout,
    /// Group 2 of the shadow cast (`gpu::shadow`), and its pipeline once shadows are on.
    cast_layout: wgpu::BindGroupLayout,
    cast: std::cell::OnceCell<Option<wgpu::ComputePipeline>>,
    variant: Variant,
    /// Whether some group shades physically: the pipelines compile that mode only then.
    physical: bool,
    device: wgpu::Device,
    /// On GL a multisampled depth that a shader reads leaves the scene pass black
    /// (llvmpipe), so there the compute rasteriser runs only without MSAA.
    gl: bool,
    bound: Option<Bound>,
    /// x: width factor of the screen-space level of detail, y: node step (`prepare`).
    lod: wgpu::Buffer,
    step: u32,
}

struct Bound {
    bind_group: wgpu::BindGroup,
    materials: wgpu::Buffer,
    ranges: Vec<crate::gpu::strands::DrawRange>,
    /// Per range: first strand, one past the last drawn (the splat's level of detail).
    drawn: wgpu::Buffer,
    /// The share `drawn` holds (uploaded again only when it changes).
    drawn_fraction: f64,
    strand_count: u32,
}

impl GpuMaterial {
    /// A group's look; `shading` is the scene's (the group's own overrides it).
    pub fn from_material(m: &Material, shading: crate::scene::Shading) -> GpuMaterial {
        let c = linear_rgb(m.color);
        let bsdf = crate::systems::hair_bsdf::gpu_block(shading, m.shading, &m.physical, m.color);
        let varies = m.variation.melanin > 0.0 || m.variation.tint > 0.0;
        let vary_single = if bsdf.physical() && varies {
            use crate::systems::hair_bsdf::{gpu_varied_single, VARY_SPAN};
            gpu_varied_single(&m.physical.hair(m.color), VARY_SPAN)
        } else {
            Default::default()
        };
        GpuMaterial {
            color_ks: [c[0], c[1], c[2], m.ks as f32],
            params: [
                m.shininess as f32,
                m.kd as f32,
                m.width as f32,
                m.tip_width as f32,
            ],
            file: [0.0; 4],
            bsdf,
            variation: [
                m.variation.melanin as f32,
                m.variation.width as f32,
                m.variation.tint as f32,
                0.0,
            ],
            vary_single,
        }
    }
}

impl StrandsPass {
    /// `frame_layout` is the shared group 0 (frame uniform).
    pub fn new(
        gpu: &Gpu,
        frame_layout: &wgpu::BindGroupLayout,
        splat_layouts: &SplatLayouts,
        cast_layout: &wgpu::BindGroupLayout,
        color_format: wgpu::TextureFormat,
        variant: Variant,
    ) -> Result<StrandsPass> {
        let device = &gpu.device;
        let module = gpu::shader_module(device, "anjyo draw", super::DRAW)?;
        // Group 1 of `common/strand_shade.wgsl` (and `strand_drawn.wgsl`, compute only).
        let layout = bind::layout(
            device,
            "strands",
            wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::COMPUTE,
            &[
                bind::storage::<GpuStrand>(),
                bind::storage::<[f32; 4]>(),
                bind::storage::<GpuMaterial>(),
                bind::uniform::<[f32; 4]>(),
                bind::storage::<[u32; 2]>().seen_by(wgpu::ShaderStages::COMPUTE),
                bind::storage::<GpuLook>(),
            ],
        );
        let pl = pipeline::pipeline_layout(device, "strands", &[frame_layout, &layout]);
        let pipeline = Self::pipeline(gpu, &module, &pl, color_format, variant, false);

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
            frame_layout: frame_layout.clone(),
            splat_layouts: splat_layouts.clone(),
            splat: Default::default(),
            binned: false,
            bins: None,
            bins_layout: TileBins::layout(device),
            cast_layout: cast_layout.clone(),
            cast: Default::default(),
            variant,
            physical: false,
            device: gpu.device.clone(),
            gl: gpu.info.backend == wgpu::Backend::Gl,
            bound: None,
            lod,
            step: 1,
        })
    }

    /// The compute rasteriser reading a scene depth of `variant.samples` samples, shading
    /// with `variant.shadow`'s lookup.
    fn splat_pipeline(&self) -> Result<SplatKernels> {
        let source = KernelSource {
            label: "anjyo splat",
            modules: [super::SPLAT, super::SPLAT_MSAA],
            frame: &self.frame_layout,
            kind: &self.layout,
            bins: Some(&self.bins_layout),
        };
        SplatKernels::build(
            &self.device,
            &source,
            &self.splat_layouts,
            self.variant.samples,
            &self.variant.constants(Some(self.physical)),
        )
    }

    /// The shadow cast (`anjyo/cast.wgsl`) over groups 0, 1 and the cast group 2.
    fn cast_pipeline(&self) -> Result<wgpu::ComputePipeline> {
        let device = &self.device;
        let module = gpu::shader_module(device, "anjyo cast", super::CAST)?;
        let pl = pipeline::pipeline_layout(
            device,
            "strands cast",
            &[&self.frame_layout, &self.layout, &self.cast_layout],
        );
        Ok(
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("strands cast"),
                layout: Some(&pl),
                module: &module,
                entry_point: Some("cast_shadow"),
                compilation_options: Default::default(),
                cache: None,
            }),
        )
    }

    /// Deposit the drawn strands into the shadow structure; groups 0 and 2 are bound by
    /// the stage.
    pub fn cast(&self, pass: &mut wgpu::ComputePass<'_>) {
        let Some(b) = &self.bound else { return };
        let groups = b.strand_count.div_ceil(64);
        if groups == 0 {
            return;
        }
        let pipeline = self.cast.get_or_init(|| match self.cast_pipeline() {
            Ok(p) => Some(p),
            Err(e) => {
                log::error!("the hair's shadow cast: {e}");
                None
            }
        });
        let Some(pipeline) = pipeline else { return };
        pass.set_pipeline(pipeline);
        pass.set_bind_group(1, &b.bind_group, &[]);
        pass.dispatch_workgroups(groups.min(65535), groups.div_ceil(65535), 1);
    }

    /// Rebuild the pipelines for another MSAA sample count or shadow lookup (the bound hair
    /// stays).
    pub fn set_variant(&mut self, gpu: &Gpu, variant: Variant) {
        self.variant = variant;
        self.rebuild(gpu);
    }

    /// The pipelines for the current variant and shading (the compute rasteriser on its
    /// next use).
    fn rebuild(&mut self, gpu: &Gpu) {
        self.pipeline = Self::pipeline(
            gpu,
            &self.module,
            &self.pipeline_layout,
            self.format,
            self.variant,
            self.physical,
        );
        self.splat.reset();
    }

    fn pipeline(
        gpu: &Gpu,
        module: &wgpu::ShaderModule,
        pl: &wgpu::PipelineLayout,
        format: wgpu::TextureFormat,
        variant: Variant,
        physical: bool,
    ) -> wgpu::RenderPipeline {
        DrawPipeline {
            label: "strands",
            layout: pl,
            module,
            // A physical pass shades each fragment as its place on the fibre (the near
            // field, `vs_near`); Anjyo's interpolates the nodes' colours.
            vertex_entry: if physical { "vs_near" } else { "vs" },
            fragment_entry: if physical {
                pipeline::near_fragment_entry(gpu)
            } else {
                pipeline::hair_fragment_entry(gpu)
            },
            topology: wgpu::PrimitiveTopology::TriangleStrip,
            cull_mode: None,
            vertex_buffers: &[],
            blend: (variant.samples <= 1).then_some(wgpu::BlendState::ALPHA_BLENDING),
            format,
            variant,
            physical: Some(physical),
        }
        .build(&gpu.device)
    }

    /// Bind the hair to draw (after a groom), its group materials and, when strand files
    /// bring them, each node's own look (otherwise one placeholder entry is bound).
    pub fn set_hair(
        &mut self,
        gpu: &Gpu,
        hair: &StrandBuffers,
        materials: &[GpuMaterial],
        looks: Option<&[GpuLook]>,
    ) {
        self.set_physical(gpu, materials);
        let looks = gpu::storage_buffer(
            &gpu.device,
            "node looks",
            bytemuck::cast_slice(looks.unwrap_or(&[GpuLook::default()])),
            wgpu::BufferUsages::empty(),
        );
        let materials = gpu::storage_buffer(
            &gpu.device,
            "materials",
            bytemuck::cast_slice(materials),
            wgpu::BufferUsages::empty(),
        );
        let drawn: Vec<[u32; 2]> = hair
            .ranges
            .iter()
            .map(|r| [r.first_strand, r.first_strand + r.strand_count])
            .collect();
        let drawn = gpu::storage_buffer(
            &gpu.device,
            "strands drawn",
            bytemuck::cast_slice(&drawn),
            wgpu::BufferUsages::COPY_DST,
        );
        let bind_group = bind::buffers(
            &gpu.device,
            "strands",
            &self.layout,
            &[
                &hair.strands,
                &hair.vertices,
                &materials,
                &self.lod,
                &drawn,
                &looks,
            ],
        );
        self.bound = Some(Bound {
            bind_group,
            materials,
            ranges: hair.ranges.clone(),
            drawn,
            drawn_fraction: 1.0,
            strand_count: hair.strand_count,
        });
    }

    /// Update materials in place (look tweaks without a re-groom).
    pub fn update_materials(&mut self, gpu: &Gpu, materials: &[GpuMaterial]) {
        self.set_physical(gpu, materials);
        if let Some(b) = &self.bound {
            gpu.queue
                .write_buffer(&b.materials, 0, bytemuck::cast_slice(materials));
        }
    }

    /// Build the pipelines again when whether some group shades physically changed.
    fn set_physical(&mut self, gpu: &Gpu, materials: &[GpuMaterial]) {
        let physical = materials.iter().any(|m| m.bsdf.sigma_a[3] > 0.5);
        if physical != self.physical {
            self.physical = physical;
            self.rebuild(gpu);
        }
    }

    /// The screen-space level of detail's width factor and node step for the next draws,
    /// and the share `fraction` of each group the compute rasteriser draws.
    pub fn prepare(
        &mut self,
        queue: &wgpu::Queue,
        width_scale: f64,
        step: u32,
        fraction: f64,
        samples: (u32, u32),
    ) {
        self.step = step.max(1);
        let tiles = crate::gpu::splat::tile_grid(samples);
        if self.binned && self.bins.as_ref().is_none_or(|b| b.tiles != tiles) {
            self.bins = Some(TileBins::new(&self.device, &self.bins_layout, samples));
        }
        let lod = [width_scale as f32, self.step as f32, 0.0, 0.0];
        queue.write_buffer(&self.lod, 0, bytemuck::bytes_of(&lod));
        if let Some(b) = self.bound.as_mut().filter(|b| b.drawn_fraction != fraction) {
            b.drawn_fraction = fraction;
            let drawn: Vec<[u32; 2]> = b
                .ranges
                .iter()
                .map(|r| {
                    [
                        r.first_strand,
                        r.first_strand + drawn_count(r.strand_count, fraction),
                    ]
                })
                .collect();
            queue.write_buffer(&b.drawn, 0, bytemuck::cast_slice(&drawn));
        }
    }

    /// Whether the compute rasteriser can run at the current sample count (not over MSAA
    /// targets on GL; the ribbons draw there).
    pub fn can_splat(&self) -> bool {
        !(self.gl && self.variant.samples > 1)
    }

    /// Bin the segments by screen tile or walk each strand with global atomics (the
    /// default): the same accumulation (`tests/it/splat.rs`), timed side by side by
    /// `kami bench raster` and `kami bench scale`.
    pub fn set_binned(&mut self, binned: bool) {
        self.binned = binned;
        if !binned {
            self.bins = None;
        }
    }

    /// Record the compute rasteriser over every strand (those past each group's drawn share
    /// return at once); groups 0 and 2 are bound by the stage.
    pub fn splat(&self, pass: &mut wgpu::ComputePass<'_>) {
        let Some(b) = self.bound.as_ref().filter(|b| b.strand_count > 0) else {
            return;
        };
        let Some(kernels) = self.splat.get(|| self.splat_pipeline()) else {
            return;
        };
        pass.set_bind_group(1, &b.bind_group, &[]);
        // Binned from the first `prepare` after `set_binned(true)` on.
        let bins = self.bins.as_ref().filter(|_| self.binned);
        let segments = b
            .ranges
            .iter()
            .map(|r| self.drawn_nodes(r.nodes_per_strand).saturating_sub(1))
            .max()
            .unwrap_or(0);
        kernels.record(pass, b.strand_count, bins, segments);
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
