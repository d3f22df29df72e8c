//! The structs the fur's passes (generate, draw, skin) share with WGSL: `#[repr(C)]`, `Pod`,
//! explicit padding and a compile-time size check. Each names the WGSL struct it must match.

use crate::gpu::gpu_data::assert_size;
use bytemuck::{Pod, Zeroable};

/// One fur coat's generation parameters, in a 256-byte slot of a dynamic-offset uniform
/// buffer. Twin of `struct Coat` (`tests/it/gpu_twins.rs` checks it) in `shaders/fur/generate.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuFurCoat {
    pub drawn: u32,
    pub segments: u32,
    /// 0 line, 1 polyline, 2 curve, 3 tube.
    pub style: u32,
    pub tri_count: u32,
    pub first_vertex: u32,
    pub first_strand: u32,
    pub seed: u32,
    pub first_base: u32,
    pub offset_base: u32,
    pub rel_length: f32,
    pub floppiness: f32,
    pub end_rand: f32,
    pub dir_weight: f32,
    /// Where the skin's per-vertex joints and weights start in the mesh buffer (0: the mesh
    /// is not skinned).
    pub skin_base: u32,
    pub _pad: [u32; 2],
    pub up: [f32; 4],
    /// x amplitude, y 2 pi / wavelength, z phase offset (2 pi frame / period), w on.
    pub motion: [f32; 4],
    pub motion_axis: [f32; 4],
    pub motion_dir: [f32; 4],
    pub _slot: [u32; 32],
}
assert_size!(GpuFurCoat, 256);

/// A fur coat's look (Van Gelder & Wilhelms Figure 2). Twin of
/// `struct FurMaterial` (`tests/it/gpu_twins.rs` checks it) in `shaders/fur/draw.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuFurMaterial {
    /// rgb: linear ambient; w: root width (world).
    pub ambient: [f32; 4],
    /// rgb: linear diffuse; w: style (0 line, 1 polyline, 2 curve, 3 tube).
    pub diffuse: [f32; 4],
    /// rgb: linear specular; w: shininess.
    pub specular: [f32; 4],
    /// x: normal randomize (share of 180 degrees), y: width scale (culling), z: node step
    /// (ribbons), w: the coat's density (`FurSetup::coat_density`).
    pub extra: [f32; 4],
    /// The physical shading mode's parameters (`bsdf.sigma_a[3]` 1 when the coat uses it).
    pub bsdf: crate::systems::hair_bsdf::GpuHairBsdf,
}
assert_size!(GpuFurMaterial, 176);

/// The fur mesh's skin. Twin of `struct Skin` (`tests/it/gpu_twins.rs` checks it) in `shaders/fur/skin.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSkin {
    pub color: [f32; 4],
    pub motion: [f32; 4],
    pub motion_axis: [f32; 4],
    pub motion_dir: [f32; 4],
    /// x: where the skin's joints and weights start in the mesh buffer (0: not skinned);
    /// y: 1 for a closed mesh (`Mesh::closed`: its cast skips the side facing away).
    pub skin: [u32; 4],
    /// The physical coats over the skin, which dim its ambient (`draw::skin_coat`): rgb
    /// their a_f, w their fibre-area index per unit of the mesh's hair length (0: none).
    pub coat: [f32; 4],
}
assert_size!(GpuSkin, 96);
