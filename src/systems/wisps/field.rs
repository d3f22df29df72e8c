//! The blobby hair field (Sakai 2014, eqs 8-9), its sphere-traced ray march with a silhouette
//! shell, and a reference image shaded by `super::toon` (eqs 14-22 and the toon controls).
//! f64 reference ("the truth") of the wisps ray-march shader, which follows the same steps.

use super::curve::{self, Segment};
use crate::scene::wisps::{Distance, March, Toon};
use glam::{DMat3, DMat4, DVec3, DVec4};

/// Density profile of eq 9 (C1: fd and fd' continuous at 1/3 and 1).
pub fn fd(x: f64) -> f64 {
    if x > 1.0 {
        0.0
    } else if x > 1.0 / 3.0 {
        1.5 * (1.0 - x) * (1.0 - x)
    } else {
        1.0 - 3.0 * x * x
    }
}

/// d fd / dx; |fd'| ≤ 2 (at x = 1/3), which the Lipschitz bounds rest on.
pub fn fd_prime(x: f64) -> f64 {
    if x > 1.0 {
        0.0
    } else if x > 1.0 / 3.0 {
        -3.0 * (1.0 - x)
    } else {
        -6.0 * x
    }
}

/// A density and its gradient.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Density {
    pub rho: f64,
    pub grad: DVec3,
}

/// The closest point the distance method found: B(t) for Newton; for a polyline the point on
/// its chord (where t was interpolated), so that |v - point| = D exactly.
pub fn closest_point(seg: &Segment, t: f64, method: Distance) -> DVec3 {
    match method {
        Distance::Newton => seg.point(t),
        Distance::Polyline { pieces } => {
            let n = pieces.max(1) as f64;
            let k = (t * n).floor().clamp(0.0, n - 1.0);
            let (p0, p1) = (seg.point(k / n), seg.point((k + 1.0) / n));
            p0 + (p1 - p0) * (t * n - k)
        }
    }
}

/// ρ_e(v) = w(t)·fd(D/r(t)) and its gradient with r(t*), w(t*) held constant (the normal's
/// gradient; the true one also moves t*, which the Lipschitz bound covers).
pub fn segment_density(seg: &Segment, v: DVec3, method: Distance) -> Density {
    let (d, t) = curve::distance(seg, v, method);
    let (r, w) = (seg.radius(t), seg.weight(t));
    let x = d / r;
    if x > 1.0 {
        return Density::default();
    }
    let grad = if d > 0.0 {
        (v - closest_point(seg, t, method)) * (w * fd_prime(x) / (r * d))
    } else {
        DVec3::ZERO
    };
    Density {
        rho: w * fd(x),
        grad,
    }
}

/// Density of one wisp: the MAX over its segments, not the paper's sum over edges. Summed,
/// the two segments meeting at a node both reach full density there, doubling it and bulging
/// every joint; the max keeps a constant-r,w wisp a constant-radius tube. Wisps still blend
/// by summing (`field`). Ties keep the first segment.
pub fn wisp_density(segs: &[Segment], v: DVec3, method: Distance) -> Density {
    let mut best = Density::default();
    for s in segs {
        let d = segment_density(s, v, method);
        if d.rho > best.rho {
            best = d;
        }
    }
    best
}

/// f(v) = Σ_wisps ρ_wisp(v) − threshold (inside: f > 0) and its gradient (the sum of each
/// wisp's arg-max segment gradient). Every segment is evaluated.
pub fn field(wisps: &[Vec<Segment>], threshold: f64, v: DVec3, method: Distance) -> Density {
    let mut out = Density {
        rho: -threshold,
        grad: DVec3::ZERO,
    };
    for w in wisps {
        let d = wisp_density(w, v, method);
        out.rho += d.rho;
        out.grad += d.grad;
    }
    out
}

/// Outward unit normal −∇f/|∇f|; `fallback` (the ray's −dir) where the gradient vanishes.
pub fn normal(grad: DVec3, fallback: DVec3) -> DVec3 {
    let len = grad.length();
    if len > 0.0 {
        -grad / len
    } else {
        fallback
    }
}

/// One march sample: the field over the near segments only, and how far the point may move
/// in any direction without reaching the surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probe {
    /// f and ∇f (as `field`: far segments are exactly 0).
    pub f: Density,
    /// Sum of the near segments' Lipschitz bounds.
    pub l_near: f64,
    /// min over far segments of (distance − r_max); +∞ when none.
    pub far_gap: f64,
    /// The safe step (before `step_scale`): `min(max(-f / l_near, distance_step), far_gap)`
    /// where some segment is near, `far_gap` where none is.
    pub step: f64,
}

/// Bisection steps of `distance_step` (the shader's too).
pub const DISTANCE_STEP_ITERATIONS: u32 = 6;

/// The largest s (by bisection below `s_hi`, keeping the safe lower end) such that no point
/// within s of the sample can be inside, from the near segments' (D, r_max, w_max, wisp): a
/// segment's density there is at most w_max·fd(max(D − s, 0)/r_max), since D shrinks by at
/// most s, fd falls with distance and r, w are at most their largest along the segment; the
/// field stays below the threshold while the sum over wisps of the largest bound does. It
/// lets rays approach a wisp in long strides where the Lipschitz step (which must hold
/// everywhere in the thin tip's influence) would crawl.
pub fn distance_step(near: &[(f64, f64, f64, usize)], threshold: f64, s_hi: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, s_hi);
    for _ in 0..DISTANCE_STEP_ITERATIONS {
        let s = 0.5 * (lo + hi);
        let mut sum = 0.0;
        let mut wisp = usize::MAX;
        let mut wisp_max: f64 = 0.0;
        for &(d, rm, wm, wi) in near {
            if wi != wisp {
                sum += wisp_max;
                wisp = wi;
                wisp_max = 0.0;
            }
            wisp_max = wisp_max.max(wm * fd((d - s).max(0.0) / rm));
        }
        sum += wisp_max;
        if sum < threshold {
            lo = s;
        } else {
            hi = s;
        }
    }
    lo
}

/// Steps 1-2 of the march at `p`. A segment whose control-point box is at least r_max away
/// is far (every curve point is then ≥ r(t) away, so its density is 0 within `far_gap`); so
/// is one whose curve, by the distance method, is at least r_max away (gap D − r_max). Only
/// near segments add to the Lipschitz sum and to the distance step.
pub fn probe(wisps: &[Vec<Segment>], threshold: f64, p: DVec3, method: Distance) -> Probe {
    let mut out = Probe {
        f: Density {
            rho: -threshold,
            grad: DVec3::ZERO,
        },
        l_near: 0.0,
        far_gap: f64::INFINITY,
        step: f64::INFINITY,
    };
    let mut near = Vec::new();
    let mut s_hi = f64::INFINITY;
    for (wi, w) in wisps.iter().enumerate() {
        let mut best = Density::default();
        for s in w {
            let a = s.box_distance(p);
            let rm = s.r_max();
            if a >= rm {
                out.far_gap = out.far_gap.min(a - rm);
                continue;
            }
            let (d, _) = curve::distance(s, p, method);
            if d >= rm {
                out.far_gap = out.far_gap.min(d - rm);
                continue;
            }
            out.l_near += s.lipschitz;
            near.push((d, rm, s.w[0].max(s.w[1]), wi));
            s_hi = s_hi.min(d);
            let dens = segment_density(s, p, method);
            if dens.rho > best.rho {
                best = dens;
            }
        }
        out.f.rho += best.rho;
        out.f.grad += best.grad;
    }
    out.step = out.far_gap;
    if !near.is_empty() && out.f.rho < 0.0 {
        let s_lip = -out.f.rho / out.l_near;
        let s_dist = distance_step(&near, threshold, s_hi.min(out.far_gap));
        out.step = s_lip.max(s_dist).min(out.far_gap);
    }
    out
}

/// A ray p(t) = origin + t·dir, |dir| = 1, marched over [t0, t1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: DVec3,
    pub dir: DVec3,
    pub t0: f64,
    pub t1: f64,
}

impl Ray {
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }
}

/// What a ray found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hit {
    Surface {
        t: f64,
        pos: DVec3,
        normal: DVec3,
    },
    /// The ray passed within the outline shell without hitting: silhouette at shell entry.
    Outline {
        t: f64,
    },
    Miss,
}

/// Sphere-traces `ray` through the field. `eps_per_t` = outline width (px) / focal length
/// (px): the shell half-width eps(t) = eps_per_t·t is the outline's footprint at distance t
/// (0: no outline). Returns the hit and the march samples taken (bisection evaluations not
/// counted).
///
/// Decisions: a ray whose first sample is already inside (f ≥ 0 at t0) hits at t0 unrefined;
/// samples are taken only at t ≤ t1 (a safe step past t1 cannot skip the surface); in the
/// shell the step is at least eps(t)/4, so a wisp thinner than a quarter of the outline
/// footprint can be stepped over (it then draws as outline, not surface).
pub fn march(
    wisps: &[Vec<Segment>],
    threshold: f64,
    m: &March,
    ray: &Ray,
    eps_per_t: f64,
) -> (Hit, u32) {
    let mut t = ray.t0;
    let mut t_prev: Option<f64> = None;
    let mut entry: Option<f64> = None;
    let mut steps = 0;
    while steps < m.max_steps && t <= ray.t1 {
        let s = probe(wisps, threshold, ray.at(t), m.distance);
        steps += 1;
        let eps = eps_per_t * t;
        let in_shell = s.f.rho + s.f.grad.length() * eps >= 0.0;
        if s.f.rho >= 0.0 {
            let Some(mut a) = t_prev else {
                let pos = ray.at(t);
                return (
                    Hit::Surface {
                        t,
                        pos,
                        normal: normal(s.f.grad, -ray.dir),
                    },
                    steps,
                );
            };
            let mut b = t;
            for _ in 0..m.refine {
                let mid = 0.5 * (a + b);
                if probe(wisps, threshold, ray.at(mid), m.distance).f.rho >= 0.0 {
                    b = mid;
                } else {
                    a = mid;
                }
            }
            let t_hit = 0.5 * (a + b);
            let pos = ray.at(t_hit);
            let g = probe(wisps, threshold, pos, m.distance).f.grad;
            return (
                Hit::Surface {
                    t: t_hit,
                    pos,
                    normal: normal(g, -ray.dir),
                },
                steps,
            );
        }
        if let Some(te) = entry {
            if !in_shell {
                return (Hit::Outline { t: te }, steps);
            }
        } else if in_shell {
            entry = Some(t);
        }
        let mut step = s.step * m.step_scale;
        if step == f64::INFINITY {
            return (Hit::Miss, steps); // no segments at all
        }
        if in_shell {
            step = step.max(0.25 * eps);
        }
        step = step.max(1e-6 * (1.0 + t));
        t_prev = Some(t);
        t += step;
    }
    match entry {
        Some(te) => (Hit::Outline { t: te }, steps),
        None => (Hit::Miss, steps),
    }
}

// The toon shading (eqs 14-22 and the toon controls) lives in `super::toon`; re-exported
// for the callers that know it here.
pub use super::toon::{intensities, linear, shade, shade_at};

/// CPU reference image: one ray per pixel centre from `eye` through the far-plane point of
/// the pixel (ndc z = 1 unprojected; wgpu depth 0..1), t0 = 0, t1 = distance to that point.
/// Surfaces are shaded by `toon::shade_at` seen along the pixel's ray (the rim's V).
/// Returns linear colours and the NDC depth (z/w under view_proj) of each hit or outline,
/// NaN for a miss; row-major, y down. No head, no anti-aliasing.
#[allow(clippy::too_many_arguments)]
pub fn render_reference(
    wisps: &[Vec<Segment>],
    threshold: f64,
    march_params: &March,
    toon: &Toon,
    light_dir: DVec3,
    head_rot: DMat3,
    eye: DVec3,
    inv_view_proj: DMat4,
    focal_px: f64,
    size: (u32, u32),
    background_linear: DVec3,
) -> (Vec<DVec3>, Vec<f64>) {
    let (w, h) = size;
    let view_proj = inv_view_proj.inverse();
    let unproject = |x: f64, y: f64, z: f64| {
        let p = inv_view_proj * DVec4::new(x, y, z, 1.0);
        p.truncate() / p.w
    };
    let depth = |pos: DVec3| {
        let c = view_proj * pos.extend(1.0);
        c.z / c.w
    };
    let eps_per_t = toon.outline_width / focal_px;
    let outline = linear(toon.outline);
    let light = light_dir.normalize();
    let mut colours = Vec::with_capacity((w * h) as usize);
    let mut depths = Vec::with_capacity((w * h) as usize);
    for py in 0..h {
        for px in 0..w {
            let nx = (px as f64 + 0.5) / w as f64 * 2.0 - 1.0;
            let ny = 1.0 - (py as f64 + 0.5) / h as f64 * 2.0;
            let far = unproject(nx, ny, 1.0);
            let t1 = (far - eye).length();
            let ray = Ray {
                origin: eye,
                dir: (far - eye) / t1,
                t0: 0.0,
                t1,
            };
            let (hit, _) = march(wisps, threshold, march_params, &ray, eps_per_t);
            let (c, z) = match hit {
                Hit::Surface { pos, normal, .. } => (
                    shade_at(normal, light, -ray.dir, head_rot, toon),
                    depth(pos),
                ),
                Hit::Outline { t } => (outline, depth(ray.at(t))),
                Hit::Miss => (background_linear, f64::NAN),
            };
            colours.push(c);
            depths.push(z);
        }
    }
    (colours, depths)
}
