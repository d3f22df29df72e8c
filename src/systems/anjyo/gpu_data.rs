//! The structs Anjyo's passes (groom, dynamics, draw) share with WGSL: `#[repr(C)]`, `Pod`,
//! explicit padding and a compile-time size check. Each names the WGSL struct it must match.

use crate::gpu::gpu_data::assert_size;
use bytemuck::{Pod, Zeroable};

/// Groom input per strand. Twin of `struct Root` (`tests/it/gpu_twins.rs` checks it) in `shaders/anjyo/cantilever.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRoot {
    /// xyz: pore; w: segment length d.
    pub pos: [f32; 4],
    /// xyz: unloaded direction; w: cut mask (bits, as f32 bits).
    pub dir: [f32; 4],
}
assert_size!(GpuRoot, 32);

/// Bending parameters per group. Twin of `struct Group` (`tests/it/gpu_twins.rs` checks it) in `shaders/anjyo/cantilever.wgsl`.
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

/// A load field limited to half-spaces. Twin of `struct Load` (`tests/it/gpu_twins.rs` checks it) in
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

/// A cut rule. Twin of `struct Cut` (`tests/it/gpu_twins.rs` checks it) in `shaders/anjyo/cantilever.wgsl`.
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

/// Groom dispatch parameters. Twin of `struct Params` (`tests/it/gpu_twins.rs` checks it) in `shaders/anjyo/cantilever.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuGroomParams {
    pub strand_count: u32,
    pub total_vertices: u32,
    /// Invocations per row of the 2D dispatch.
    pub row_stride: u32,
    /// Converged-mode iterations per `iterate` dispatch.
    pub chunk: u32,
}
assert_size!(GpuGroomParams, 16);

/// Look of a hair group. Twin of `struct Material` (`tests/it/gpu_twins.rs` checks it) in `shaders/anjyo/draw.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    /// rgb: linear hair colour; w: k_s.
    pub color_ks: [f32; 4],
    /// x: shininess n, y: k_d, z: root width (world), w: tip width ratio.
    pub params: [f32; 4],
    /// What the node looks (`GpuLook`) give instead of the above, 1 or 0: x colours,
    /// y widths, z opacities (a strand file's own, `block::StrandFile`).
    pub file: [f32; 4],
    /// The physical shading mode's parameters (`bsdf.sigma_a[3]` 1 when the group uses it).
    pub bsdf: crate::systems::hair_bsdf::GpuHairBsdf,
    /// Per-strand variation (`block::Variation`): x melanin, y width, z tint.
    pub variation: [f32; 4],
    /// A physical group that varies: the sky's single backscattering at absorption factors
    /// across the group's spread (`hair_bsdf::gpu_varied_single`; the first w the span in
    /// log). Zero otherwise.
    pub vary_single: [[f32; 4]; crate::systems::hair_bsdf::VARY_TABLE],
}
assert_size!(GpuMaterial, 448);

/// A node's own look, from a strand file. Twin of the elements of `looks` (`tests/it/gpu_twins.rs` checks it) in
/// `shaders/common/strand_shade.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLook {
    /// sRGB colour and opacity, 8 bits each (`unpack4x8unorm`: r in the low byte).
    pub rgba: u32,
    /// Width (world units, f32 bits).
    pub width: u32,
}
assert_size!(GpuLook, 8);

impl GpuLook {
    /// A look from the file's colour (0..1, stored as sRGB as Kami writes it), opacity and
    /// width.
    pub fn new(rgb: [f32; 3], opacity: f32, width: f32) -> GpuLook {
        let b = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u32;
        GpuLook {
            rgba: b(rgb[0]) | b(rgb[1]) << 8 | b(rgb[2]) << 16 | b(opacity) << 24,
            width: width.max(0.0).to_bits(),
        }
    }

    /// sRGB colour and opacity in 0..1 (what the shader's `unpack4x8unorm` gives).
    pub fn rgba(self) -> [f64; 4] {
        [0, 8, 16, 24].map(|s| ((self.rgba >> s) & 255) as f64 / 255.0)
    }
}

/// Projective-dynamics parameters. Twin of `struct DynParams` (`tests/it/gpu_twins.rs` checks it) in
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
}
assert_size!(GpuDynParams, 80);

/// One simulated strand. Twin of `struct DynStrand` (`tests/it/gpu_twins.rs` checks it) in `shaders/anjyo/projective.wgsl`.
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

/// One substep of the projective kernel, in a 256-byte slot of a dynamic-offset uniform
/// buffer. Twin of `struct Step` in `shaders/anjyo/projective.wgsl`. What the world gives
/// (gravity and wind, the gust scale, the head's pose) is read from `world_steps` at the
/// indices in `samples`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuStep {
    /// x: substep length h.
    pub h: [f32; 4],
    /// Root acceleration operator (from three head poses, in f64).
    pub accel: [[f32; 4]; 4],
    /// x: 1 when this substep kicks; y: kick bucket; z: 1 for the first step from rest.
    pub kick: [u32; 4],
    /// x: the world sample at the substep's start (force, gust), y: at its end (head pose).
    pub samples: [u32; 4],
    pub _pad: [[u32; 4]; 9],
}
assert_size!(GpuStep, 256);
