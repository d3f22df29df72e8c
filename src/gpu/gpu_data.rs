//! The structs every kind shares with WGSL (the strand, the frame, the head, a step):
//! `#[repr(C)]`, `Pod`, explicit padding and a compile-time size check (`assert_size!`).
//! Each names the WGSL struct it must match. A kind's own GPU structs live in its folder
//! (`systems/<kind>/gpu_data.rs`), made the same way.

use bytemuck::{Pod, Zeroable};

/// A compile-time check that a GPU struct has the size its WGSL twin has.
macro_rules! assert_size {
    ($t:ty, $n:expr) => {
        const _: () = assert!(std::mem::size_of::<$t>() == $n);
    };
}
pub(crate) use assert_size;

/// One strand of any kind. Twin of `struct Strand` (`tests/it/gpu_twins.rs` checks it) in `shaders/common/strands.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuStrand {
    /// Index of the root node in the vertex buffer.
    pub first_vertex: u32,
    /// Segments (nodes - 1).
    pub segments: u32,
    /// Index into the group tables (materials, solver parameters).
    pub group: u32,
    /// Solver state: for the cantilever, bit 0 = converged mode fell back to the paper's
    /// shape, bit 1 = converged, bits 8.. = iterations used.
    pub flags: u32,
    /// Drawn segments, fractional (cuts); written by the groom kernel.
    pub visible: f32,
    /// Ambient coefficient k_a.
    pub ka: f32,
    /// Segment length d.
    pub seg_len: f32,
    /// A uniform random number per strand.
    pub rand: f32,
}
assert_size!(GpuStrand, 32);

/// Per-frame view and light. Twin of `struct Frame` (`tests/it/gpu_twins.rs` checks it) in `shaders/common/frame.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuFrame {
    pub view_proj: [[f32; 4]; 4],
    /// xyz: eye position.
    pub eye: [f32; 4],
    /// xyz: unit direction towards the light; w: intensity I_s.
    pub light_dir: [f32; 4],
    /// rgb: light colour; w: ambient intensity I_a.
    pub light_color: [f32; 4],
    /// (width, height) of the target in samples, then 1/width, 1/height.
    pub viewport: [f32; 4],
    /// x: pixels per world unit at distance 1 (focal length in samples); y: narrowest
    /// strand drawn, samples; z: width scale of strand hair drawn at a level of detail
    /// (1/sqrt(share of hairs drawn)); w: MSAA samples per pixel (1 without MSAA), for the
    /// per-sample coverage of `shaders/common/coverage.wgsl`.
    pub raster: [f32; 4],
    /// x: 1 while the systems' diagnostic overlay is on (`systems::View::overlay`; Anjyo's
    /// strand shading then marks the segments the pseudo-force acted on); y: samples per
    /// output pixel along y (supersampling; set by `Stage::render` and read back as
    /// `systems::View::samples_per_px`, for widths given in output pixels such as the wisps'
    /// outline); z, w: unused (0).
    pub flags: [f32; 4],
    /// The hair shadows' light-space box (`stage::shadow`; all 0 while shadows are off).
    pub shadow: crate::gpu::shadow::GpuShadow,
}
assert_size!(GpuFrame, 336);

/// The head mesh's uniform. Twin of `struct Head` (`tests/it/gpu_twins.rs` checks it) in `shaders/stage/head.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuHead {
    /// Model matrix of the unit sphere (scale by radii, then translate).
    pub model: [[f32; 4]; 4],
    /// The head pose's rotation (normals turn with it).
    pub rotation: [[f32; 4]; 4],
    /// rgb: linear skin colour; w: 1 for the physical mode's Lambertian, 0 for the paper
    /// scenes' look (`shaders/stage/head.wgsl`).
    pub color: [f32; 4],
    /// 1 / radii^2 (for normals of the ellipsoid; 1 for a mesh head).
    pub inv_radii2: [f32; 4],
}
assert_size!(GpuHead, 160);

/// sRGB component (0..1) to linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB colour to linear rgb.
pub fn linear_rgb(c: [f32; 3]) -> [f32; 3] {
    [
        srgb_to_linear(c[0]),
        srgb_to_linear(c[1]),
        srgb_to_linear(c[2]),
    ]
}
