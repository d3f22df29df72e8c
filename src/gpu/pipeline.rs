//! Render-pipeline and bind-group helpers shared by every draw pass (the stage's head and
//! resolve passes, each hair system's draw): the scene's formats, the depth test, and one
//! descriptor builder, so a pass states only what differs (shader entries, topology,
//! blending, vertex buffers).

use super::Gpu;

/// Format of the internal scene buffers: linear values stored as sRGB, so resolving and
/// averaging happen in linear light.
pub const SCENE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Depth test shared by the scene passes (everything drawn into the scene composites by
/// depth in one pass).
pub fn depth_state(write: bool) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(write),
        depth_compare: Some(wgpu::CompareFunction::Less),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

/// The fragment entry point of the hair shaders on this adapter: every hair pass makes the
/// same per-sample coverage decisions (`shaders/common/coverage.wgsl`); the GL backend gets
/// the per-sample-shading one because naga cannot write a sample mask in GLSL
/// (gfx-rs/wgpu#6085).
pub fn hair_fragment_entry(gpu: &Gpu) -> &'static str {
    if gpu.info.backend == wgpu::Backend::Gl {
        "fs_per_sample"
    } else {
        "fs"
    }
}

/// [`hair_fragment_entry`] of the strand ribbons' near-field pair (`shaders/anjyo/draw.wgsl`,
/// `fs_near`), which a pass that shades physically draws with.
pub fn near_fragment_entry(gpu: &Gpu) -> &'static str {
    if gpu.info.backend == wgpu::Backend::Gl {
        "fs_near_per_sample"
    } else {
        "fs_near"
    }
}

/// What a scene pipeline is built for besides its shader: the MSAA sample count of the
/// targets and the shadow lookup it compiles. A change of either builds the pipelines
/// again (`HairSystem::set_variant`, the stage's head pass).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Variant {
    pub samples: u32,
    pub shadow: super::shadow::ShadowVariant,
}

impl Variant {
    /// `samples` per pixel with no shadow lookup.
    pub fn samples(samples: u32) -> Variant {
        Variant {
            samples,
            shadow: super::shadow::ShadowVariant::OFF,
        }
    }

    /// The override constants of a module that includes `shaders/common/shadow.wgsl` and,
    /// with `physical` given, `shaders/common/hair_bsdf.wgsl`: whether the physical shading
    /// is compiled in (`HAIR_PHYSICAL`: some material of the pass shades physically). Like
    /// the shadow lookup, a mode tested per material at run time costs a software rasteriser
    /// the whole mode, taken or not.
    pub fn constants(&self, physical: Option<bool>) -> Vec<(&'static str, f64)> {
        let mut c = self.shadow.constants().to_vec();
        if let Some(p) = physical {
            c.push(("HAIR_PHYSICAL", f64::from(u8::from(p))));
        }
        c
    }
}

/// What distinguishes one scene render pipeline from another.
#[derive(Clone, Copy)]
pub struct DrawPipeline<'a> {
    pub label: &'a str,
    pub layout: &'a wgpu::PipelineLayout,
    pub module: &'a wgpu::ShaderModule,
    pub vertex_entry: &'a str,
    pub fragment_entry: &'a str,
    pub topology: wgpu::PrimitiveTopology,
    pub cull_mode: Option<wgpu::Face>,
    pub vertex_buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    /// Blend the colour over what is there (sub-pixel hair without MSAA).
    pub blend: Option<wgpu::BlendState>,
    pub format: wgpu::TextureFormat,
    /// The sample count and shadow lookup (the module includes `shaders/common/shadow.wgsl`).
    pub variant: Variant,
    /// Whether the physical shading is compiled in, for a module that includes
    /// `shaders/common/hair_bsdf.wgsl` (None for one that does not).
    pub physical: Option<bool>,
}

impl DrawPipeline<'_> {
    /// A depth-tested, depth-writing pipeline into the scene targets.
    pub fn build(&self, device: &wgpu::Device) -> wgpu::RenderPipeline {
        let constants = self.variant.constants(self.physical);
        let compilation_options = || wgpu::PipelineCompilationOptions {
            constants: &constants,
            ..Default::default()
        };
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(self.label),
            layout: Some(self.layout),
            vertex: wgpu::VertexState {
                module: self.module,
                entry_point: Some(self.vertex_entry),
                compilation_options: compilation_options(),
                buffers: self.vertex_buffers,
            },
            primitive: wgpu::PrimitiveState {
                topology: self.topology,
                cull_mode: self.cull_mode,
                ..Default::default()
            },
            depth_stencil: Some(depth_state(true)),
            multisample: wgpu::MultisampleState {
                count: self.variant.samples,
                mask: !0,
                alpha_to_coverage_enabled: false,
            },
            fragment: Some(wgpu::FragmentState {
                module: self.module,
                entry_point: Some(self.fragment_entry),
                compilation_options: compilation_options(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: self.format,
                    blend: self.blend,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    }
}

/// A pipeline layout over these bind group layouts (group 0 first).
pub fn pipeline_layout(
    device: &wgpu::Device,
    label: &str,
    groups: &[&wgpu::BindGroupLayout],
) -> wgpu::PipelineLayout {
    let groups: Vec<Option<&wgpu::BindGroupLayout>> = groups.iter().map(|g| Some(*g)).collect();
    device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &groups,
        immediate_size: 0,
    })
}
