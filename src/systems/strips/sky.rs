//! How much of the even ambient light each strip sees, for the physical mode (docs/shading.md,
//! "The strips' sky"). A strip lies among the other layers of the Hair Object Model: those
//! over it and beside it hide part of the sky, and the light that comes through them has
//! crossed fibres. Kami's ambient colour is what a fibre on the open surface of a dense
//! volume of hair gets (`DualScattering::ambient`); a fur fibre deep in its coat gets
//! `hair_bsdf::ambient_in_coat` of the coat's fibre-area index above it. The strips have no
//! coat to count, so the index is found by casting rays: at `SKY_SAMPLES` points along each
//! strip, `SKY_RAYS` rays over the hemisphere facing away from the head (cosine-weighted, as
//! irradiance is) cross the other strips' ribbons, each crossing at cosine mu to that
//! ribbon's normal letting through e^(-c / mu) (c its texture's hair coverage there), and
//! stop at the head. The mean of what comes through, V, is what a coat of index A lets
//! through unscattered, 2 E_3(A) (`hair_bsdf::ambient_transmittance`'s first term); the
//! strip's index is the A that gives V, so an open strip has A = 0 and a strip under a
//! flat sheet of coverage c has A = c.
//!
//! Baked once from the rest strips (as hair cards bake their occlusion): the strips move
//! under the dynamics but keep their layers, so the index stands for the moving strips too.
//! 120 strips of 8 sticks take a few tens of milliseconds (one thread).

use glam::{DMat4, DVec3};

use crate::scene::Head;
use crate::systems::hair_bsdf::expint;
use crate::systems::strips::block::Look;
use crate::systems::strips::{ribbon, texture, RestStrip};

/// Points along each strip where the index is baked: v = k / (SKY_SAMPLES - 1), root to tip
/// (v counts control points, as the ribbon's v does). The draw shader interpolates them.
pub const SKY_SAMPLES: usize = 8;

/// Rays per point, over the hemisphere facing away from the head.
pub const SKY_RAYS: usize = 64;

/// The index given where (almost) nothing comes through: 2 E_3(20) is about 1e-10.
pub const SKY_MAX_AREA: f64 = 20.0;

/// 2 E_3(a): the share of even light a coat of fibre-area index `a` lets through
/// unscattered (1 at a = 0).
pub fn open_share(a: f64) -> f64 {
    2.0 * expint(3, a.max(0.0))
}

/// The fibre-area index A with 2 E_3(A) = `v` (bisection; 0 for v >= 1 or NaN,
/// [`SKY_MAX_AREA`] for v at or below its share).
pub fn area_for_share(v: f64) -> f64 {
    if v.is_nan() || v >= 1.0 {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0f64, SKY_MAX_AREA);
    if v <= open_share(hi) {
        return hi;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if open_share(mid) > v {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The mean hair coverage (texture alpha, 0..1) of each texel row of `look`'s strand
/// texture, root (row 0) to tip.
pub fn row_coverage(look: &Look) -> Vec<f64> {
    let (w, h) = texture::texture_size(look);
    let tex = texture::strand_texture(look, w, h);
    tex.chunks(w as usize)
        .map(|row| row.iter().map(|t| t[3] as f64 / 255.0).sum::<f64>() / w as f64)
        .collect()
}

/// One ribbon as the rays see it: its triangles (corners and their v) and a bounding box.
struct Ribbon {
    tris: Vec<([DVec3; 3], [f64; 3])>,
    lo: DVec3,
    hi: DVec3,
}

/// The rest ribbons of `rest` (`ribbon::ribbon_reference` at the head's rest pose).
fn ribbons(rest: &[RestStrip]) -> (Vec<Ribbon>, Vec<ribbon::RibbonVertex>, usize) {
    let stride = rest
        .iter()
        .map(|s| s.points.len())
        .max()
        .unwrap_or(1)
        .max(1);
    let mut points = Vec::with_capacity(rest.len() * stride);
    for s in rest {
        let last = s.points.last().copied().unwrap_or(DVec3::ZERO);
        points.extend(s.points.iter().copied());
        points.extend(std::iter::repeat_n(last, stride - s.points.len()));
    }
    let info = ribbon::strip_info(rest);
    let verts = ribbon::ribbon_reference(&points, stride, &info, &DMat4::IDENTITY);
    let out = rest
        .iter()
        .enumerate()
        .map(|(s, strip)| {
            let at = |k: usize, side: usize| verts[2 * (s * stride + k) + side];
            let mut tris = Vec::new();
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for k in 0..strip.points.len().saturating_sub(1) {
                let [a0, a1, b0, b1] = [at(k, 0), at(k, 1), at(k + 1, 0), at(k + 1, 1)];
                for q in [a0, a1, b0, b1] {
                    lo = lo.min(q.position);
                    hi = hi.max(q.position);
                }
                tris.push(([a0.position, a1.position, b0.position], [a0.v, a1.v, b0.v]));
                tris.push(([a1.position, b1.position, b0.position], [a1.v, b1.v, b0.v]));
            }
            Ribbon { tris, lo, hi }
        })
        .collect();
    (out, verts, stride)
}

/// Whether the ray o + t d (t > 0) meets the box.
fn hits_box(o: DVec3, inv_d: DVec3, lo: DVec3, hi: DVec3) -> bool {
    let t0 = (lo - o) * inv_d;
    let t1 = (hi - o) * inv_d;
    let near = t0.min(t1).max_element();
    let far = t0.max(t1).min_element();
    far >= near.max(0.0)
}

/// Möller–Trumbore, both faces: the hit's barycentrics (of corners 1 and 2) for t > 0.
fn hit_triangle(o: DVec3, d: DVec3, p: &[DVec3; 3]) -> Option<(f64, f64)> {
    let e1 = p[1] - p[0];
    let e2 = p[2] - p[0];
    let h = d.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-18 {
        return None;
    }
    let s = o - p[0];
    let b1 = s.dot(h) / det;
    let q = s.cross(e1);
    let b2 = d.dot(q) / det;
    if b1 < 0.0 || b2 < 0.0 || b1 + b2 > 1.0 {
        return None;
    }
    (e2.dot(q) / det > 0.0).then_some((b1, b2))
}

/// Whether the ray o + t d (t > 0) meets the ellipsoid (`center`, `radii`).
fn hits_ellipsoid(o: DVec3, d: DVec3, center: DVec3, radii: DVec3) -> bool {
    let oo = (o - center) / radii;
    let dd = d / radii;
    let a = dd.dot(dd);
    let b = oo.dot(dd);
    let c = oo.dot(oo) - 1.0;
    let disc = b * b - a * c;
    a > 0.0 && disc >= 0.0 && -b + disc.sqrt() > 0.0
}

/// `rays` cosine-weighted directions about +z (a Fibonacci spiral: even, and the same on
/// every run).
fn directions(rays: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..rays)
        .map(|i| {
            let mu = ((i as f64 + 0.5) / rays as f64).sqrt();
            let r = (1.0 - mu * mu).max(0.0).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), mu)
        })
        .collect()
}

/// Coverage at `v` (0 root .. 1 tip) from the rows of [`row_coverage`].
fn coverage_at(rows: &[f64], v: f64) -> f64 {
    if rows.is_empty() {
        return 0.0;
    }
    let i = ((v.clamp(0.0, 1.0) * rows.len() as f64) as usize).min(rows.len() - 1);
    rows[i]
}

/// The fibre-area index of the sky hidden from each strip at its [`SKY_SAMPLES`] points
/// (module docs). `head`'s ellipsoid stops rays (a mesh head is stood for by its scene
/// ellipsoid, as in the shadows).
pub fn bake(rest: &[RestStrip], head: &Head, look: &Look) -> Vec<[f32; SKY_SAMPLES]> {
    bake_rays(rest, head, look, SKY_RAYS)
}

/// [`bake`] with `rays` rays per point (at least 1): how the bake's error falls with its
/// rays (`tests/it/strips_sky.rs`).
pub fn bake_rays(
    rest: &[RestStrip],
    head: &Head,
    look: &Look,
    rays: usize,
) -> Vec<[f32; SKY_SAMPLES]> {
    let rays = rays.max(1);
    let rows = row_coverage(look);
    let (rib, verts, stride) = ribbons(rest);
    let dirs = directions(rays);
    let center = DVec3::from(head.center);
    // Drawn 2 % smaller, as the shadows' head, so a root on the scalp does not hide itself.
    let radii = DVec3::from(head.radii) * 0.98;
    let scale = rib
        .iter()
        .map(|r| (r.hi - r.lo).max_element())
        .fold(1e-9, f64::max);
    rest.iter()
        .enumerate()
        .map(|(s, strip)| {
            let n_pts = strip.points.len();
            std::array::from_fn(|j| {
                if n_pts < 2 {
                    return 0.0;
                }
                // The centre line and the ribbon's normal at v = j / (SKY_SAMPLES - 1).
                let x = j as f64 / (SKY_SAMPLES - 1) as f64 * (n_pts - 1) as f64;
                let k = (x.floor() as usize).min(n_pts - 2);
                let f = x - k as f64;
                let at = |k: usize, side: usize| verts[2 * (s * stride + k) + side];
                let mid = |k: usize| 0.5 * (at(k, 0).position + at(k, 1).position);
                let p = mid(k).lerp(mid(k + 1), f);
                let side = (at(k, 1).position - at(k, 0).position)
                    .lerp(at(k + 1, 1).position - at(k + 1, 0).position, f);
                let t = at(k, 0).tangent.lerp(at(k + 1, 0).tangent, f);
                let mut n = side
                    .cross(t)
                    .normalize_or(p - center)
                    .normalize_or(DVec3::Y);
                if n.dot(p - center) < 0.0 {
                    n = -n;
                }
                let (b1, b2) = n.any_orthonormal_pair();
                let o = p + n * (1e-7 * scale);
                let mut through = 0.0;
                for d0 in &dirs {
                    let d = b1 * d0.x + b2 * d0.y + n * d0.z;
                    if hits_ellipsoid(o, d, center, radii) {
                        continue;
                    }
                    let inv = d.recip();
                    let mut depth = 0.0;
                    for (r, ribbon) in rib.iter().enumerate() {
                        if r == s || !hits_box(o, inv, ribbon.lo, ribbon.hi) {
                            continue;
                        }
                        for (tri, v) in &ribbon.tris {
                            if let Some((u1, u2)) = hit_triangle(o, d, tri) {
                                let vv = v[0] + u1 * (v[1] - v[0]) + u2 * (v[2] - v[0]);
                                let normal = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
                                let mu = normal.normalize_or(n).dot(d).abs().max(1e-3);
                                depth += coverage_at(&rows, vv) / mu;
                            }
                        }
                    }
                    through += (-depth).exp();
                }
                area_for_share(through / rays as f64) as f32
            })
        })
        .collect()
}
