//! Toon shading of the wisps' surface (Sakai 2014, eqs 14-22, in the head's frame) with the
//! controls artists expect of a toon shader (`wisps::block::Toon`): a feather on every step
//! (lit/shade, shade/dark, the halo's edge, the rim's edge), the angel halo's width
//! (t_specular), latitude offset, strength and colour over the shadow tones, a rim light on
//! the shadow side near the silhouette, and the per-wisp outline width tapered toward the
//! tips (data for the ray march). The f64 reference of `shaders/wisps/toon.wgsl`, which
//! follows the same steps in the same order; `tests/it/wisps_toon.rs` holds the two together.
//!
//! With every new control at its default (feathers 0, offset 0, strength 1, no halo shadow
//! colour, rim width 0, taper 0) the colour is bit for bit the hard-step shading of eqs
//! 20-22: a step of feather 0 is exactly 0 or 1, and `blend(a, b, w) = a (1 - w) + b w` is
//! exactly `a` or `b` there.

use super::march::GpuWispDraw;
use crate::gpu::gpu_data::linear_rgb;
use crate::systems::wisps::block::{Tones, Toon, Wisps};
use glam::{DMat3, DMat4, DVec3};

// The draw uniform stays a whole number of vec4s (its WGSL twin is `struct Draw` in
// `shaders/wisps/march.wgsl`; `tests/it/wisps_toon.rs` compares the sizes).
const _: () = assert!(std::mem::size_of::<GpuWispDraw>() == 240);
const _: () = assert!(std::mem::size_of::<GpuWispDraw>() % 16 == 0);

/// Toon intensities (eqs 14-19) in the head's frame: (I_spec, I_diff, I_lat, I_lon).
/// `n`, `l` (towards the light) are world directions, `head_rot` the head's rotation.
/// Kami's up is y, so the paper's E_z is local +y, E_x local +x, E_y local +z. Both vectors
/// are normalised here (a no-op for unit inputs). Where N or L points straight up or down
/// (horizontal length < 1e-6) it has no longitude: the product term of eq 19 is 0.
pub fn intensities(n: DVec3, l: DVec3, head_rot: DMat3) -> (f64, f64, f64, f64) {
    intensities_shifted(n, l, head_rot, 0.0)
}

/// `intensities` with the light's latitude raised by `offset` radians for I_spec only (the
/// halo band moves by `offset` toward the crown): with L at elevation φ_l and N at φ_n,
/// I_spec = cos(φ_n − φ_l − offset). Offset 0 is exactly `intensities`.
pub fn intensities_shifted(
    n: DVec3,
    l: DVec3,
    head_rot: DMat3,
    offset: f64,
) -> (f64, f64, f64, f64) {
    let rt = head_rot.transpose();
    let (n, l) = ((rt * n).normalize_or_zero(), (rt * l).normalize_or_zero());
    let (n_lat, l_lat) = (n.y, l.y);
    let (n_h, l_h) = (n.x.hypot(n.z), l.x.hypot(l.z));
    let (si, co) = offset.sin_cos();
    let (s_lat, s_h) = (l_lat * co + l_h * si, l_h * co - l_lat * si);
    let i_spec = n_lat * s_lat + n_h * s_h;
    let i_lat = 0.5 * (n_lat + 1.0);
    let prod = if n_h < 1e-6 || l_h < 1e-6 {
        0.0
    } else {
        (l.x / l_h) * (n.x / n_h) + (l.z / l_h) * (n.z / n_h)
    };
    let i_lon = 0.5 * (prod + 1.0);
    (i_spec, i_lat * i_lon, i_lat, i_lon)
}

/// sRGB scene colour to linear f64.
pub fn linear(c: [f32; 3]) -> DVec3 {
    let l = linear_rgb(c);
    DVec3::new(l[0] as f64, l[1] as f64, l[2] as f64)
}

/// A feathered step: exactly 0 or 1 (`x > t`) for `feather` ≤ 0, else the smoothstep that
/// rises from 0 at t − feather/2 to 1 at t + feather/2 (0.5 at t).
pub fn step(x: f64, t: f64, feather: f64) -> f64 {
    if feather <= 0.0 {
        if x > t {
            1.0
        } else {
            0.0
        }
    } else {
        let u = ((x - t) / feather + 0.5).clamp(0.0, 1.0);
        u * u * (3.0 - 2.0 * u)
    }
}

/// a (1 − w) + b w: exactly a at w = 0 and b at w = 1.
pub fn blend(a: DVec3, b: DVec3, w: f64) -> DVec3 {
    a * (1.0 - w) + b * w
}

/// The weights of one shading: the lit tone over the lower ones, the dark tone's share of the
/// lower ones (three tones), the halo and the rim (already masked to the shadow side).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights {
    pub lit: f64,
    pub shade_over_dark: f64,
    pub halo: f64,
    pub rim: f64,
}

/// The weights of `shade_at` (see there).
pub fn weights(n: DVec3, l: DVec3, v: DVec3, head_rot: DMat3, toon: &Toon) -> Weights {
    let (i_spec, i_diff, _, _) = intensities_shifted(n, l, head_rot, toon.halo_offset.to_radians());
    let lit = step(i_diff, toon.t_diffuse, toon.diffuse_feather);
    let shade_over_dark = match toon.tones {
        Tones::Two => 1.0,
        Tones::Three => step(i_diff, toon.t_dark, toon.dark_feather),
    };
    let halo = step(i_spec, toon.t_specular, toon.halo_feather);
    let rim = if toon.rim_width > 0.0 {
        step(toon.rim_width - n.dot(v), 0.0, toon.rim_feather) * (1.0 - lit)
    } else {
        0.0
    };
    Weights {
        lit,
        shade_over_dark,
        halo,
        rim,
    }
}

/// Toon colour (linear RGB) of a surface point with unit normal `n`, seen along `v` (unit,
/// from the point towards the eye), lit from `l`:
///
/// 1. the tone (eqs 20-22): lit over shade by `step(I_diff, t_diffuse, diffuse_feather)`,
///    shade over dark (three tones) by `step(I_diff, t_dark, dark_feather)`;
/// 2. the angel halo: where `step(I_spec', t_specular, halo_feather)` > 0, with I_spec' the
///    specular intensity of eq 16 for the light raised by `halo_offset` degrees of
///    latitude, adds `halo_strength` × that weight × the halo colour (c_specular; with
///    `halo_shadow`, that colour over the shadow tones blended by the lit weight);
/// 3. the rim: where `rim_width` > 0, adds `rim` × `step(rim_width − N·V, 0, rim_feather)`
///    × (1 − lit weight): near the silhouette, on the side away from the light;
/// 4. clamps each channel to 1.
pub fn shade_at(n: DVec3, l: DVec3, v: DVec3, head_rot: DMat3, toon: &Toon) -> DVec3 {
    let w = weights(n, l, v, head_rot, toon);
    let lower = match toon.tones {
        Tones::Two => linear(toon.shade),
        Tones::Three => blend(linear(toon.dark), linear(toon.shade), w.shade_over_dark),
    };
    let mut c = blend(lower, linear(toon.diffuse), w.lit);
    if w.halo > 0.0 {
        let spec = linear(toon.specular);
        let colour = match toon.halo_shadow {
            Some(s) => blend(linear(s), spec, w.lit),
            None => spec,
        };
        c += colour * (toon.halo_strength * w.halo);
    }
    if w.rim > 0.0 {
        c += linear(toon.rim) * w.rim;
    }
    c.min(DVec3::ONE)
}

/// `shade_at` seen head-on (V = N: no rim), the shading of eqs 20-22 with the halo and
/// feather controls.
pub fn shade(n: DVec3, l: DVec3, head_rot: DMat3, toon: &Toon) -> DVec3 {
    shade_at(n, l, n, head_rot, toon)
}

/// The camera's viewing direction (unit, from the eye into the scene) of a perspective
/// `view_proj` (clip w = depth along it): its w row. The view direction `toon(n)` in
/// `shaders/wisps/toon.wgsl` uses for the rim (V = −this) while the march does not pass the
/// ray's own (`toon_at(n, -dir)`).
pub fn camera_forward(view_proj: DMat4) -> DVec3 {
    DVec3::new(view_proj.x_axis.w, view_proj.y_axis.w, view_proj.z_axis.w).normalize()
}

/// Per node of `wisps` (skeletons one after the other, root first): the skeleton's outline
/// scale and the node's arc-length fraction u along the drawn skeleton (polyline through
/// its nodes: 0 at the root, 1 at the tip).
pub fn node_outlines(wisps: &Wisps) -> Vec<[f32; 2]> {
    let mut out = Vec::new();
    for sk in &wisps.skeletons {
        let mut s = vec![0.0f64];
        for w in sk.nodes.windows(2) {
            let d = (DVec3::from(w[1].p) - DVec3::from(w[0].p)).length();
            s.push(s.last().copied().unwrap_or(0.0) + d);
        }
        let total = s.last().copied().unwrap_or(0.0);
        for si in s {
            let u = if total > 0.0 { si / total } else { 0.0 };
            out.push([sk.outline as f32, u as f32]);
        }
    }
    out
}

/// Per segment of `wisps`, in the curve kernels' order (skeletons one after the other, root
/// to tip; `curve::segments`): `[outline scale, u at its start, u at its end, 0]`. What the
/// ray march reads to give each wisp its outline width (`outline_scale`).
pub fn segment_outlines(wisps: &Wisps) -> Vec<[f32; 4]> {
    let nodes = node_outlines(wisps);
    let mut out = Vec::new();
    let mut first = 0;
    for sk in &wisps.skeletons {
        let k = sk.nodes.len();
        for i in first..first + k - 1 {
            out.push([nodes[i][0], nodes[i][1], nodes[i + 1][1], 0.0]);
        }
        first += k;
    }
    out
}

/// The outline width multiplier at parameter `t` of a segment whose `segment_outlines` entry
/// is `o`: `o[0] (1 − taper ((1 − t) o[1] + t o[2]))` (`outline_scale` in toon.wgsl).
pub fn outline_scale(o: [f32; 4], t: f64, taper: f64) -> f64 {
    let u = o[1] as f64 * (1.0 - t) + o[2] as f64 * t;
    o[0] as f64 * (1.0 - taper * u)
}
