//! Every struct shared with WGSL, in one place: `#[repr(C)]`, `Pod`, explicit padding and a
//! compile-time size check. Each names the WGSL struct it must match.

use bytemuck::{Pod, Zeroable};

macro_rules! assert_size {
    ($t:ty, $n:expr) => {
        const _: () = assert!(std::mem::size_of::<$t>() == $n);
    };
}

/// One strand of any kind. Keep in sync with `struct Strand` in `shaders/common/strands.wgsl`.
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

/// Groom input per strand. Keep in sync with `struct Root` in `shaders/anjyo/cantilever.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRoot {
    /// xyz: pore; w: segment length d.
    pub pos: [f32; 4],
    /// xyz: unloaded direction; w: cut mask (bits, as f32 bits).
    pub dir: [f32; 4],
}
assert_size!(GpuRoot, 32);

/// Bending parameters per group. Keep in sync with `struct Group` in `shaders/anjyo/cantilever.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuGroomGroup {
    pub segments: u32,
    /// 0: paper, 1: converged.
    pub mode: u32,
    pub max_iterations: u32,
    pub first_load: u32,
    pub load_count: u32,
    pub first_cut: u32,
    pub cut_count: u32,
    pub _pad0: u32,
    pub rigidity: f32,
    pub tolerance: f32,
    pub _pad1: [f32; 2],
}
assert_size!(GpuGroomGroup, 48);

/// A load field limited to half-spaces. Keep in sync with `struct Load` in
/// `shaders/common/loads.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLoad {
    /// xyz: force (uniform) or target point (toward); w: 0 uniform, 1 toward.
    pub field: [f32; 4],
    /// x: strength (toward); y: number of planes.
    pub params: [f32; 4],
    /// xyz: unit normal, w: offset; inside where dot(n, p) >= offset.
    pub planes: [[f32; 4]; 4],
}
assert_size!(GpuLoad, 96);

/// A cut rule. Keep in sync with `struct Cut` in `shaders/anjyo/cantilever.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuCut {
    /// 0: below y, 1: by pore height, 2: near a point.
    pub kind: u32,
    pub _pad: [u32; 3],
    /// below: (y); by pore height: (low y, low k, high y, high k); near: (center, radius).
    pub a: [f32; 4],
}
assert_size!(GpuCut, 32);

/// Groom dispatch parameters. Keep in sync with `struct Params` in `shaders/anjyo/cantilever.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuGroomParams {
    pub strand_count: u32,
    pub total_vertices: u32,
    /// Invocations per row of the 2D dispatch.
    pub row_stride: u32,
    /// Converged-mode iterations per `iterate` dispatch.
    pub chunk: u32,
    pub head_center: [f32; 4],
    pub head_radii: [f32; 4],
}
assert_size!(GpuGroomParams, 48);

/// Per-frame view and light. Keep in sync with `struct Frame` in `shaders/common/frame.wgsl`.
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
}
assert_size!(GpuFrame, 160);

/// Look of a hair group. Keep in sync with `struct Material` in `shaders/anjyo/draw.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    /// rgb: linear hair colour; w: k_s.
    pub color_ks: [f32; 4],
    /// x: shininess n, y: k_d, z: root width (world), w: tip width ratio.
    pub params: [f32; 4],
}
assert_size!(GpuMaterial, 32);

/// The head mesh's uniform. Keep in sync with `struct Head` in `shaders/stage/head.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuHead {
    /// Model matrix of the unit sphere (scale by radii, then translate).
    pub model: [[f32; 4]; 4],
    /// The head pose's rotation (normals turn with it).
    pub rotation: [[f32; 4]; 4],
    /// rgb: linear skin colour.
    pub color: [f32; 4],
    /// 1 / radii^2 (for normals of the ellipsoid; 1 for a mesh head).
    pub inv_radii2: [f32; 4],
}
assert_size!(GpuHead, 160);

/// Projective-dynamics parameters. Keep in sync with `struct DynParams` in
/// `shaders/anjyo/projective.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuDynParams {
    pub strand_count: u32,
    pub row_stride: u32,
    pub collision: u32,
    pub pseudo: u32,
    pub density: f32,
    pub damping: f32,
    pub seed: u32,
    /// Fluctuation amplitude, radians.
    pub fluct_amp: f32,
    pub pseudo_alpha: f32,
    pub eps_pore: f32,
    pub eps_tip: f32,
    pub near: f32,
    /// Joint-angle limits, radians, and where the fall starts and ends (fractions).
    pub sigma_root: f32,
    pub sigma_tip: f32,
    pub sigma_start: f32,
    pub inertia_root: f32,
    pub inertia_tip: f32,
    pub sigma_end: f32,
    /// Entries per segment row of the segment-major angle state (the dynamic strands,
    /// rounded up to whole workgroups): segment i of strand column c is at
    /// `(i - 1) * state_stride + c`.
    pub state_stride: u32,
    pub _pad: f32,
    pub head_center: [f32; 4],
    pub head_radii: [f32; 4],
}
assert_size!(GpuDynParams, 112);

/// One substep's forces, in a 256-byte slot of a dynamic-offset uniform buffer. Keep in sync
/// with `struct Step` in `shaders/anjyo/projective.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuStep {
    /// xyz: gravity + wind; w: substep length h.
    pub force: [f32; 4],
    pub head: [[f32; 4]; 4],
    pub head_inv: [[f32; 4]; 4],
    pub accel: [[f32; 4]; 4],
    /// x: 1 when this substep kicks; y: kick bucket; z: 1 for the first step from rest.
    pub kick: [u32; 4],
    pub _pad: [u32; 8],
}
assert_size!(GpuStep, 256);

/// One simulated strand. Keep in sync with `struct DynStrand` in `shaders/anjyo/projective.wgsl`.
/// Uploaded as three columns (all `ids`, then all `root`, then all `extra`, each
/// `state_stride` long) so that neighbouring invocations read neighbouring 16-byte words.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuDynStrand {
    /// strand, first vertex, state column (its index among the dynamic strands), simulated
    /// segments.
    pub ids: [u32; 4],
    /// xyz: pore in head coordinates; w: segment length.
    pub root: [f32; 4],
    /// x: scalp inertia factor.
    pub extra: [f32; 4],
}
assert_size!(GpuDynStrand, 48);

/// One fur coat's generation parameters, in a 256-byte slot of a dynamic-offset uniform
/// buffer. Keep in sync with `struct Coat` in `shaders/fur/generate.wgsl`.
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

/// A fur coat's look (Van Gelder & Wilhelms Figure 2). Keep in sync with
/// `struct FurMaterial` in `shaders/fur/draw.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuFurMaterial {
    /// rgb: linear ambient; w: root width (world).
    pub ambient: [f32; 4],
    /// rgb: linear diffuse; w: style (0 line, 1 polyline, 2 curve, 3 tube).
    pub diffuse: [f32; 4],
    /// rgb: linear specular; w: shininess.
    pub specular: [f32; 4],
    /// x: normal randomize (share of 180 degrees), y: width scale (culling).
    pub extra: [f32; 4],
}
assert_size!(GpuFurMaterial, 64);

/// The fur mesh's skin. Keep in sync with `struct Skin` in `shaders/fur/skin.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuSkin {
    pub color: [f32; 4],
    pub motion: [f32; 4],
    pub motion_axis: [f32; 4],
    pub motion_dir: [f32; 4],
    /// x: where the skin's joints and weights start in the mesh buffer (0: not skinned).
    pub skin: [u32; 4],
}
assert_size!(GpuSkin, 80);

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
