//! The shadow structure's GPU side (`stage::shadow` owns the pass): the light-space box
//! every shading module reads (in the frame uniform) and the resolved structure
//! (`shaders/common/shadow.wgsl`, group 0 binding 1), and the cast layout (group 2 of
//! every kind's cast pipeline, `shaders/common/shadow_cast.wgsl`). The read side and the cast side are different
//! buffers (the resolve copies one into the other), since wgpu forbids one buffer read-only
//! and read-write in one dispatch.

use crate::gpu::bind;
use crate::gpu::gpu_data::GpuFrame;
use bytemuck::{Pod, Zeroable};

/// Words per row of the resolved structure's texture (`SHADOW_ROW` in
/// `shaders/common/shadow.wgsl`; `tests/it/gpu_twins.rs` checks it).
pub const ROW: u32 = 256;

/// An `R32Float` texture holding `words` words, [`ROW`] a row (a 1 x 1 placeholder for 0).
pub fn map_texture(device: &wgpu::Device, words: u64) -> wgpu::Texture {
    let rows = words.div_ceil(ROW as u64).max(1) as u32;
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some("shadow map"),
        size: wgpu::Extent3d {
            width: if words == 0 { 1 } else { ROW },
            height: rows,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R32Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

/// The shadow structure a shading pipeline compiles a lookup for: the override
/// `SHADOW_LOOKUP` in `shaders/common/shadow.wgsl`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Lookup {
    /// No lookup: the shadow functions are constants (shadows off, or nothing casts).
    #[default]
    Off,
    /// The light-aligned density volume.
    Volume,
    /// Deep opacity maps.
    DeepOpacity,
}

/// What a shading pipeline compiles of the shadow lookup. A software rasteriser (llvmpipe,
/// lavapipe) runs both sides of every branch under a mask, so a lookup skipped by a test of
/// the frame uniform costs as much as one taken: with shadows off the viewer drew at half
/// its rate (docs/performance.md). Each pipeline that shades is built for the structure the
/// frame has, the others compiled out, and built again when it changes (the stage, like an
/// MSAA change).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ShadowVariant {
    pub lookup: Lookup,
    /// Toon steps (a scene with wisps: `shadow_toon`, `shadow_is_toon`).
    pub toon: bool,
    /// The skin map (a system casts opaque: fur's skin, `shadow_skin`).
    pub skin: bool,
}

impl ShadowVariant {
    /// No shadow lookup compiled in.
    pub const OFF: ShadowVariant = ShadowVariant {
        lookup: Lookup::Off,
        toon: false,
        skin: false,
    };

    /// `SHADOW_LOOKUP`: 0 none, 1 the volume, 2 deep opacity; plus 4 for toon steps, plus 8
    /// for the skin map.
    pub fn code(self) -> u32 {
        let lookup = match self.lookup {
            Lookup::Off => 0,
            Lookup::Volume => 1,
            Lookup::DeepOpacity => 2,
        };
        lookup + if self.toon { 4 } else { 0 } + if self.skin { 8 } else { 0 }
    }

    /// The pipeline-overridable constants of every module that includes
    /// `shaders/common/shadow.wgsl`.
    pub fn constants(self) -> [(&'static str, f64); 1] {
        [("SHADOW_LOOKUP", f64::from(self.code()))]
    }
}

/// Fixed-point scale of cast coverage (`SHADOW_FIXED` in `shaders/common/shadow_cast.wgsl`,
/// `FIXED` in `shaders/stage/shadow.wgsl`; `tests/it/gpu_twins.rs` checks both).
pub const FIXED: f64 = 4096.0;
/// Fixed-point scale of the nearest caster's depth, 2^24 - 1 (`SHADOW_DEPTH_SCALE`,
/// `DEPTH_SCALE` in the same shaders, checked the same way).
pub const DEPTH_SCALE: f64 = 16_777_215.0;

/// Twin of `struct ShadowParams` (`tests/it/gpu_twins.rs` checks it) in `shaders/common/frame.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuShadow {
    /// xyz: centre of the light-space box; w: 1 while shadows are on.
    pub center: [f32; 4],
    /// xyz: unit axis across the light; w: half the box's size.
    pub axis_u: [f32; 4],
    /// xyz: the other axis across; w: method (0 volume, 1 deep opacity).
    pub axis_v: [f32; 4],
    /// xyz: unit towards the light; w: absorption per strand.
    pub axis_l: [f32; 4],
    /// x, y: cells across; z: slices or layers; w: 1 with a head that shadows.
    pub dims: [f32; 4],
    /// Deep opacity: where each layer ends, world distance behind the first depth.
    pub layers: [f32; 4],
    /// x: how far towards the light a point on a layered strand reads the structure
    /// (`shadow_layered`), world units; y: 1 with a skin map (`stage::shadow::SKIN_TEXELS`),
    /// z: its first word in the structure, w: its depth bias (world; `shadow_skin`).
    pub layered: [f32; 4],
    /// World to the head ellipsoid's unit sphere.
    pub head_inv: [[f32; 4]; 4],
}

const _: () = assert!(std::mem::size_of::<GpuShadow>() == 176);

/// What every shader stage may read besides the frame uniform (which carries the
/// [`GpuShadow`]): group 0's binding 1, the resolved structure, an `R32Float` texture of
/// [`ROW`] words a row. Not a second uniform: one more uniform in group 0 crashed lavapipe
/// (Mesa 22.3) in the wisps' draws.
pub fn read_slot() -> bind::Slot {
    bind::texture_2d().seen_by(wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE)
}

/// Group 2 of a cast pipeline: the coverage being cast (read-write, atomic words) and the
/// phase (x; `vec4<u32>`).
pub fn cast_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    bind::layout(
        device,
        "shadow cast",
        wgpu::ShaderStages::COMPUTE,
        &[bind::storage_rw::<u32>(), bind::uniform::<[u32; 4]>()],
    )
}

/// Group 0 of every draw and cast: the frame uniform (binding 0,
/// `shaders/common/frame.wgsl`, with the shadow's box) and the resolved structure (binding
/// 1).
pub fn frame_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    bind::layout(
        device,
        "frame",
        wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
        &[bind::uniform::<GpuFrame>(), read_slot()],
    )
}

/// Group 0: the frame uniform and the resolved structure's view.
pub fn frame_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    frame: &wgpu::Buffer,
    map: &wgpu::TextureView,
) -> wgpu::BindGroup {
    bind::group(
        device,
        "frame",
        layout,
        &[
            frame.as_entire_binding(),
            wgpu::BindingResource::TextureView(map),
        ],
    )
}

/// A group 0 over `frame` (whose `shadow` is off) with no structure (passes drawn outside
/// the stage: tests).
pub fn frame_group_without_shadows(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    frame: &wgpu::Buffer,
) -> wgpu::BindGroup {
    let placeholder = map_texture(device, 0).create_view(&Default::default());
    frame_group(device, layout, frame, &placeholder)
}
