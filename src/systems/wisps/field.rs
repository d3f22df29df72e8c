//! The blobby hair field (Sakai 2014, eqs 8-9), its sphere-traced ray march with a silhouette
//! shell, and a reference image shaded by `super::toon` (eqs 14-22 and the toon controls).
//! f64 reference ("the truth") of the wisps ray-march shader, which follows the same steps.

use super::curve::{self, Capsule, Segment};
use crate::systems::wisps::block::{Distance, March, Toon};
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
/// by summing (`field`). Ties keep the first segment. Interior joints are open (`WispMax`).
pub fn wisp_density(segs: &[Segment], v: DVec3, method: Distance) -> Density {
    let mut acc = WispMax::default();
    for (i, s) in segs.iter().enumerate() {
        let (d, t) = curve::distance(s, v, method);
        if d >= s.r_max() {
            continue;
        }
        acc.push(i, t, segment_density(s, v, method), 1.0);
    }
    acc.finish().0
}

/// The per-wisp maximum with open interior joints. A segment whose closest point is its end
/// at a joint (t = 1, or t = 0) would add its end sphere there; on a tapered wisp that sphere
/// (of the joint's radius) is wider than the next segment's tube just past the joint, so the
/// max took the sphere, and with it a normal radial from the joint, for a stretch past every
/// joint: a step in the toon tone where one segment met the next. So an end cap at a joint
/// counts only where the neighbour's closest point is its own end too (the outer side of a
/// bend, where both caps are the same sphere): where the neighbour's closest point is
/// interior, the neighbour's tube is the surface. The density stays continuous (at the
/// neighbour's end plane its tube and the cap agree) and so does the radial normal.
/// Segments are pushed in order, with their index in the wisp; a segment not pushed (far:
/// density 0, and then so is its neighbour's cap) breaks adjacency. As `field` in
/// `shaders/wisps/march.wgsl`.
#[derive(Clone, Copy, Debug, Default)]
pub struct WispMax {
    best: Density,
    best_tag: f64,
    prev: Option<(usize, f64)>,
    pending: Option<(Density, f64)>,
}

impl WispMax {
    /// Segment `index` of the wisp with closest parameter `t`, its density and a value to
    /// return with the maximum (the outline scale).
    pub fn push(&mut self, index: usize, t: f64, dens: Density, tag: f64) {
        let (mut drop_prev, mut drop_cur) = (false, false);
        if let Some((pi, pt)) = self.prev {
            if pi + 1 == index {
                drop_prev = pt >= 1.0 && t > 0.0;
                drop_cur = t <= 0.0 && pt < 1.0;
            }
        }
        if let Some(p) = self.pending.take() {
            if !drop_prev {
                self.fold(p);
            }
        }
        if !drop_cur {
            self.pending = Some((dens, tag));
        }
        self.prev = Some((index, t));
    }

    fn fold(&mut self, (d, tag): (Density, f64)) {
        if d.rho > self.best.rho {
            self.best = d;
            self.best_tag = tag;
        }
    }

    /// The wisp's density and the tag of its densest segment (1 where none is near).
    pub fn finish(mut self) -> (Density, f64) {
        if let Some(p) = self.pending.take() {
            self.fold(p);
        }
        if self.best.rho > 0.0 {
            (self.best, self.best_tag)
        } else {
            (self.best, 1.0)
        }
    }
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
    probe_segments(
        wisps
            .iter()
            .enumerate()
            .flat_map(|(wi, w)| w.iter().enumerate().map(move |(si, s)| (wi, si, s))),
        threshold,
        p,
        method,
    )
}

/// `probe` over the segments `segs` yields, each with its wisp and its index in the wisp; a
/// wisp's segments must come one after the other, in order (the per-wisp maximum is taken
/// over a run of one wisp, `WispMax`).
pub fn probe_segments<'a>(
    segs: impl Iterator<Item = (usize, usize, &'a Segment)>,
    threshold: f64,
    p: DVec3,
    method: Distance,
) -> Probe {
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
    let mut wisp = usize::MAX;
    let mut acc = WispMax::default();
    for (wi, si, s) in segs {
        if wi != wisp {
            let best = std::mem::take(&mut acc).finish().0;
            out.f.rho += best.rho;
            out.f.grad += best.grad;
            wisp = wi;
        }
        let a = s.box_distance(p);
        let rm = s.r_max();
        if a >= rm {
            out.far_gap = out.far_gap.min(a - rm);
            continue;
        }
        let (d, t) = curve::distance(s, p, method);
        if d >= rm {
            out.far_gap = out.far_gap.min(d - rm);
            continue;
        }
        out.l_near += s.lipschitz;
        near.push((d, rm, s.w[0].max(s.w[1]), wi));
        s_hi = s_hi.min(d);
        acc.push(si, t, segment_density(s, p, method), 1.0);
    }
    let best = acc.finish().0;
    out.f.rho += best.rho;
    out.f.grad += best.grad;
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
/// NaN for a miss; row-major, y down. No head, no anti-aliasing. Every ray is marched by
/// `march` over every segment from the eye: the truth the tiled march is measured against.
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
    let eps_per_t = toon.outline_width / focal_px;
    let trace = |ray: &Ray| march(wisps, threshold, march_params, ray, eps_per_t).0;
    let look = Look {
        toon,
        light_dir,
        head_rot,
        eye,
        inv_view_proj,
        background_linear,
    };
    render_rays(&look, size, trace)
}

/// `render_reference` by the tiled march's steps (`march_tiled`, every segment a candidate
/// of every ray, in f64): the GPU march's twin. `outlines[wisp][segment]` as
/// `toon::segment_outlines` (empty: every wisp's scale 1). Also returns the counters summed
/// over rays.
#[allow(clippy::too_many_arguments)]
pub fn render_reference_tiled(
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
    outlines: &[Vec<[f32; 4]>],
) -> (Vec<DVec3>, Vec<f64>, MarchCount) {
    let eps_per_t = toon.outline_width / focal_px;
    let lines = Outlines {
        per_segment: outlines,
        taper: toon.outline_taper,
    };
    let caps = curve::capsules(wisps, threshold);
    let shells: Vec<Vec<f64>> = caps
        .iter()
        .map(|w| {
            w.iter()
                .map(|c| shell_radius(c, eye, eps_per_t * lines.widest()))
                .collect()
        })
        .collect();
    let slots = ray_slots(&caps);
    let total = std::cell::Cell::new(MarchCount::default());
    let trace = |ray: &Ray| {
        let cands = candidates(&caps, &shells, ray);
        let (hit, n) = march_tiled(
            wisps,
            &cands,
            threshold,
            march_params,
            ray,
            eps_per_t,
            &lines,
            slots,
        );
        let mut sum = total.get();
        sum.steps += n.steps;
        sum.candidates += n.candidates;
        sum.overflow += n.overflow;
        sum.exact += n.exact;
        total.set(sum);
        hit
    };
    let look = Look {
        toon,
        light_dir,
        head_rot,
        eye,
        inv_view_proj,
        background_linear,
    };
    let (c, z) = render_rays(&look, size, trace);
    (c, z, total.get())
}

/// What a reference image is shaded with.
struct Look<'a> {
    toon: &'a Toon,
    light_dir: DVec3,
    head_rot: DMat3,
    eye: DVec3,
    inv_view_proj: DMat4,
    background_linear: DVec3,
}

fn render_rays(
    look: &Look,
    size: (u32, u32),
    trace: impl Fn(&Ray) -> Hit,
) -> (Vec<DVec3>, Vec<f64>) {
    let (w, h) = size;
    let inv_view_proj = look.inv_view_proj;
    let view_proj = inv_view_proj.inverse();
    let unproject = |x: f64, y: f64, z: f64| {
        let p = inv_view_proj * DVec4::new(x, y, z, 1.0);
        p.truncate() / p.w
    };
    let depth = |pos: DVec3| {
        let c = view_proj * pos.extend(1.0);
        c.z / c.w
    };
    let outline = linear(look.toon.outline);
    let light = look.light_dir.normalize();
    let eye = look.eye;
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
            let (c, z) = match trace(&ray) {
                Hit::Surface { pos, normal, .. } => (
                    shade_at(normal, light, -ray.dir, look.head_rot, look.toon),
                    depth(pos),
                ),
                Hit::Outline { t } => (outline, depth(ray.at(t))),
                Hit::Miss => (look.background_linear, f64::NAN),
            };
            colours.push(c);
            depths.push(z);
        }
    }
    (colours, depths)
}

/// The fewest candidate slots per ray of the tiled march (`RAY_SLOTS` in
/// `shaders/wisps/march.wgsl`, set per scene by `ray_slots`): a ray's list is a window of
/// its candidates (`keep_nearest`), so only candidates touching the ray at once need a slot
/// each; a ray whose answer lies beyond one a full window dropped is counted.
pub const RAY_SLOTS: usize = 48;

/// The most slots a scene gets (private memory per pixel: 28 bytes a slot).
pub const MAX_RAY_SLOTS: usize = 512;

/// The slots a scene's rays need: `max_overlap`, a quarter more for wisps that move, a
/// multiple of 16, at least `RAY_SLOTS`; above `MAX_RAY_SLOTS` the lists hold that many and
/// the rays that need more are counted.
pub fn ray_slots(caps: &[Vec<Capsule>]) -> usize {
    (max_overlap(caps) * 5 / 4)
        .next_multiple_of(16)
        .clamp(RAY_SLOTS, MAX_RAY_SLOTS)
}

/// At most this many influence capsules hold one point (the candidates touching one ray at
/// once): the most capsules one capsule meets, plus itself (the largest degree of the graph
/// of capsules that meet bounds its largest clique). O(segments²) capsule tests after a box
/// check, once per scene (3 ms for 1,000 segments).
pub fn max_overlap(caps: &[Vec<Capsule>]) -> usize {
    let all: Vec<&Capsule> = caps.iter().flatten().collect();
    let boxes: Vec<(DVec3, DVec3)> = all
        .iter()
        .map(|c| {
            let r = DVec3::splat(c.influence);
            (c.a.min(c.b) - r, c.a.max(c.b) + r)
        })
        .collect();
    let mut degree = vec![0usize; all.len()];
    for i in 0..all.len() {
        for j in i + 1..all.len() {
            let (a, b) = (boxes[i], boxes[j]);
            if a.0.cmpgt(b.1).any() || b.0.cmpgt(a.1).any() {
                continue;
            }
            let d = curve::segment_distance(all[i].a, all[i].b, all[j].a, all[j].b);
            if d <= all[i].influence + all[j].influence {
                degree[i] += 1;
                degree[j] += 1;
            }
        }
    }
    degree.iter().max().map_or(0, |d| d + 1)
}

/// The radius round a segment's chord within which the march samples: the hit capsule grown
/// by twice the outline shell's half-width at the far side of the segment (`eps_per_t` t),
/// so that a ray passing within the outline of the surface is sampled there. Negative where
/// the segment can hold no hit. Same steps as `bound` in `shaders/wisps/tiles.wgsl`.
pub fn shell_radius(c: &Capsule, eye: DVec3, eps_per_t: f64) -> f64 {
    if c.hit < 0.0 {
        return -1.0;
    }
    let far = (eye - 0.5 * (c.a + c.b)).length() + 0.5 * (c.b - c.a).length() + c.influence;
    c.hit + 2.0 * eps_per_t * far
}

/// One segment a ray crosses: its influence interval (where it may add density) and its
/// shell interval (where the surface or its outline may be; empty: `s_in > s_out`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    pub wisp: usize,
    pub seg: usize,
    pub t_in: f64,
    pub t_out: f64,
    pub s_in: f64,
    pub s_out: f64,
}

/// Counters of one tiled march.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MarchCount {
    /// Field samples of the march (bisection and normal not counted).
    pub steps: u32,
    /// Segments whose influence the ray crosses.
    pub candidates: u32,
    /// 1 where the ray's answer lies beyond a candidate its full list (`RAY_SLOTS`) dropped:
    /// counted, never silent.
    pub overflow: u32,
    /// Samples that needed the exact field (the rest moved by the clear step).
    pub exact: u32,
}

/// The segments whose influence capsule `ray` crosses within [t0, t1], in segment order.
pub fn candidates(caps: &[Vec<Capsule>], shells: &[Vec<f64>], ray: &Ray) -> Vec<Candidate> {
    let mut out = Vec::new();
    for (wi, w) in caps.iter().enumerate() {
        for (si, c) in w.iter().enumerate() {
            let Some((t_in, t_out)) =
                curve::ray_capsule(ray.origin, ray.dir, c.a, c.b, c.influence)
            else {
                continue;
            };
            if t_out < ray.t0 || t_in > ray.t1 {
                continue;
            }
            let (s_in, s_out) = curve::ray_capsule(ray.origin, ray.dir, c.a, c.b, shells[wi][si])
                .unwrap_or((f64::INFINITY, f64::NEG_INFINITY));
            out.push(Candidate {
                wisp: wi,
                seg: si,
                t_in,
                t_out,
                s_in,
                s_out,
            });
        }
    }
    out
}

/// Per-wisp outline widths: `per_segment[wisp][segment]` as `toon::segment_outlines` (empty:
/// scale 1 everywhere), tapered by `taper` toward the tips.
#[derive(Clone, Copy, Debug)]
pub struct Outlines<'a> {
    pub per_segment: &'a [Vec<[f32; 4]>],
    pub taper: f64,
}

impl Outlines<'_> {
    /// The entry of one segment.
    pub fn of(&self, wisp: usize, seg: usize) -> [f32; 4] {
        self.per_segment
            .get(wisp)
            .and_then(|w| w.get(seg))
            .copied()
            .unwrap_or([1.0, 0.0, 0.0, 0.0])
    }

    /// The largest outline scale (the march's shells are that much wider).
    pub fn widest(&self) -> f64 {
        self.per_segment
            .iter()
            .flatten()
            .map(|o| f64::from(o[0]))
            .fold(
                if self.per_segment.is_empty() {
                    1.0
                } else {
                    0.0
                },
                f64::max,
            )
    }
}

/// A segment with its pieces (`curve::pieces`) and outline entry, as the tiled march reads
/// it.
#[derive(Clone, Copy, Debug)]
pub struct Pieced<'a> {
    pub wisp: usize,
    /// The segment's index in its wisp (adjacency for `WispMax`).
    pub index: usize,
    pub seg: &'a Segment,
    pub pts: &'a [DVec3; curve::PIECES + 1],
    pub dev: &'a [f64; curve::PIECES],
    pub outline: [f32; 4],
}

/// Upper bounds of piece k of `p`: (distance from `v` at least, r at most, w at most).
fn piece_bound(p: &Pieced, k: usize, v: DVec3) -> (f64, f64, f64) {
    let h = 1.0 / curve::PIECES as f64;
    let (ta, tb) = (k as f64 * h, (k + 1) as f64 * h);
    let d = (curve::chord_distance(v, p.pts[k], p.pts[k + 1]) - p.dev[k]).max(0.0);
    let r = p.seg.radius(ta).max(p.seg.radius(tb));
    let w = p.seg.weight(ta).max(p.seg.weight(tb));
    (d, r, w)
}

/// The clear step at `v`: no point within it is inside the surface. Each piece of each
/// segment bounds its wisp's density at distance s from `v` by w_k fd(max(d_k - s, 0) / r_k)
/// (d_k its chord distance less its deviation, r_k and w_k the largest along it); at s = 0
/// the wisps' bounds f_W sum to F. Where F < threshold, each wisp gets f_W plus an equal
/// share of the slack threshold - F, and the step is the least s at which some piece's
/// bound reaches its wisp's share (closed form through fd⁻¹): the shares sum to the
/// threshold, so the field stays below it within the step. 0 where F reaches the threshold;
/// +∞ without segments. `segs` in wisp order. As `clear_step` in
/// `shaders/wisps/march.wgsl`.
pub fn clear_step(segs: &[Pieced], threshold: f64, v: DVec3) -> f64 {
    let mut per_wisp: Vec<f64> = Vec::new();
    let mut wisp = usize::MAX;
    for p in segs {
        if p.wisp != wisp {
            per_wisp.push(0.0);
            wisp = p.wisp;
        }
        let m = per_wisp.last_mut().expect("pushed above");
        for k in 0..curve::PIECES {
            let (d, r, w) = piece_bound(p, k, v);
            *m = m.max(w * fd(d / r));
        }
    }
    if per_wisp.is_empty() {
        return f64::INFINITY;
    }
    let total: f64 = per_wisp.iter().sum();
    if total >= threshold {
        return 0.0;
    }
    let slack = (threshold - total) / per_wisp.len() as f64;
    let mut step = f64::INFINITY;
    let mut wi = 0;
    let mut wisp = usize::MAX;
    for p in segs {
        if p.wisp != wisp {
            if wisp != usize::MAX {
                wi += 1;
            }
            wisp = p.wisp;
        }
        let share = per_wisp[wi] + slack;
        for k in 0..curve::PIECES {
            let (d, r, w) = piece_bound(p, k, v);
            let y = share / w;
            if y < 1.0 {
                step = step.min(d - r * curve::fd_inverse(y));
            }
        }
    }
    step.max(0.0)
}

/// The field at `v` (as `field`, over `segs`) with the Lipschitz step of the tiled march:
/// -f over the sum over wisps of the largest bound of each wisp's near segments (the
/// gradient of a maximum is one of its terms'), never past where a far segment's influence
/// begins (as in `probe`); 0 where no segment is near. Returns (f with its gradient, step,
/// the outline scale of the densest wisp here (1 where none is near)).
pub fn exact_sample(
    segs: &[Pieced],
    threshold: f64,
    v: DVec3,
    method: Distance,
    taper: f64,
) -> (Density, f64, f64) {
    let mut f = Density {
        rho: -threshold,
        grad: DVec3::ZERO,
    };
    let mut lip = 0.0;
    let mut far_gap = f64::INFINITY;
    let mut wisp = usize::MAX;
    let mut acc = WispMax::default();
    let mut wisp_lip: f64 = 0.0;
    let (mut densest, mut densest_o) = (0.0, 1.0);
    let mut fold = |acc: WispMax, f: &mut Density| {
        let (best, o) = acc.finish();
        f.rho += best.rho;
        f.grad += best.grad;
        if best.rho > densest {
            densest = best.rho;
            densest_o = o;
        }
    };
    for p in segs {
        if p.wisp != wisp {
            fold(std::mem::take(&mut acc), &mut f);
            lip += wisp_lip;
            wisp_lip = 0.0;
            wisp = p.wisp;
        }
        let s = p.seg;
        let rm = s.r_max();
        let a = s.box_distance(v);
        if a >= rm {
            far_gap = far_gap.min(a - rm);
            continue;
        }
        let (d, t) = curve::distance(s, v, method);
        if d >= rm {
            far_gap = far_gap.min(d - rm);
            continue;
        }
        wisp_lip = wisp_lip.max(s.lipschitz);
        let o = super::toon::outline_scale(p.outline, t, taper);
        acc.push(p.index, t, segment_density(s, v, method), o);
    }
    fold(acc, &mut f);
    lip += wisp_lip;
    let step = if lip > 0.0 && f.rho < 0.0 {
        (-f.rho / lip).min(far_gap)
    } else {
        0.0
    };
    (f, step, densest_o)
}

/// A candidate's first touch of the ray: the nearer of its influence and shell entries.
fn entry_key(c: &Candidate) -> f64 {
    c.t_in.min(c.s_in)
}

/// Where a candidate stops touching the ray: the farther of its influence and shell exits.
fn reach(c: &Candidate) -> f64 {
    c.t_out.max(c.s_out)
}

/// A ray list's window (`gather` in `shaders/wisps/march.wgsl`): of the candidates still
/// touching the ray from `from` on, the first `RAY_SLOTS`, then each later one replaces the
/// kept one of farthest entry (the first such slot) if it begins nearer; back in segment
/// order. Returns them and t_drop, where the first dropped candidate begins (+∞: none
/// dropped): no dropped candidate touches the ray before it.
pub fn keep_nearest(cands: &[Candidate], from: f64, slots: usize) -> (Vec<Candidate>, f64) {
    let mut kept: Vec<Candidate> = Vec::with_capacity(slots);
    let mut t_drop = f64::INFINITY;
    for c in cands.iter().filter(|c| reach(c) >= from) {
        if kept.len() < slots {
            kept.push(*c);
            continue;
        }
        let mut slot = 0;
        for q in 1..slots {
            if entry_key(&kept[q]) > entry_key(&kept[slot]) {
                slot = q;
            }
        }
        if entry_key(c) >= entry_key(&kept[slot]) {
            t_drop = t_drop.min(entry_key(c));
            continue;
        }
        t_drop = t_drop.min(entry_key(&kept[slot]));
        kept[slot] = *c;
    }
    kept.sort_by_key(|c| (c.wisp, c.seg));
    (kept, t_drop)
}

/// The tiled march of one ray (`fs` in `shaders/wisps/march.wgsl`; the GPU takes the
/// candidates from its screen tile's list, the same segments in the same order). The ray's
/// candidates come a window at a time (`keep_nearest`): the march is exact up to the
/// window's end, t_drop, and gathers again from its last sample there; only where more than
/// `slots` candidates touch the ray at once is one dropped for good (`overflow`, when the
/// answer lies beyond it). Samples only inside shell intervals, jumping the gaps between
/// them (no point there is inside, or in the outline); at each sample only the candidates
/// whose influence interval holds t count, and a step never passes the next influence entry
/// or the window's end. A sample whose clear step (the pieces' bound) exceeds twice the
/// outline half-width eps(t) is outside and off the outline: the ray moves by the clear step
/// less eps with no exact field. Elsewhere the exact field decides: a hit is refined by
/// bisection as in `march`, the outline shell is tested as there, and the step is the larger
/// of the Lipschitz and clear steps.
#[allow(clippy::too_many_arguments)]
pub fn march_tiled(
    wisps: &[Vec<Segment>],
    cands: &[Candidate],
    threshold: f64,
    m: &March,
    ray: &Ray,
    eps_per_t: f64,
    lines: &Outlines,
    slots: usize,
) -> (Hit, MarchCount) {
    let mut count = MarchCount {
        steps: 0,
        candidates: cands.len() as u32,
        overflow: 0,
        exact: 0,
    };
    let widest = lines.widest();
    let (kept, t_drop) = keep_nearest(cands, f64::NEG_INFINITY, slots);
    let pieced = piece_all(wisps, &kept);
    let mut w = Window {
        wisps,
        cands,
        threshold,
        m,
        ray,
        lines,
        slots,
        kept,
        pieced,
        t_drop,
        over: f64::INFINITY,
    };
    let first = w.kept.iter().map(|c| c.s_in).fold(f64::INFINITY, f64::min);
    // A dropped candidate's shell may begin before the kept ones' first shell.
    let mut t = first.min(w.t_drop).max(ray.t0);
    let mut t_prev: Option<f64> = None;
    let mut entry: Option<f64> = None;
    let mut result = None;
    while count.steps < m.max_steps && t <= ray.t1 {
        if w.t_drop.is_finite() && t >= w.t_drop {
            w.regather(t_prev.unwrap_or(t), t);
        }
        let inside = w.kept.iter().any(|c| c.s_in <= t && t <= c.s_out);
        let next_shell = w
            .kept
            .iter()
            .map(|c| c.s_in)
            .filter(|&s| s > t)
            .fold(w.t_drop, f64::min);
        let next_in = w
            .kept
            .iter()
            .map(|c| c.t_in)
            .filter(|&s| s > t)
            .fold(w.t_drop, f64::min);
        if !inside {
            // Between shell intervals: nothing here is inside or in the outline.
            if entry.is_some() {
                break;
            }
            t = next_shell;
            t_prev = None;
            continue;
        }
        count.steps += 1;
        let clear = w.sample(t, false).3;
        // Off every outline: the widest any wisp may draw.
        let eps = eps_per_t * t * widest;
        if clear > 2.0 * eps {
            if entry.is_some() {
                break;
            }
            let step = ((clear - eps) * m.step_scale)
                .min(next_in - t)
                .max(1e-6 * (1.0 + t));
            t_prev = Some(t);
            t += step;
            continue;
        }
        count.exact += 1;
        let (f, s_lip, o, _) = w.sample(t, true);
        let eps = eps_per_t * t * o;
        let in_shell = f.rho + f.grad.length() * eps >= 0.0;
        if f.rho >= 0.0 {
            result = Some(match t_prev {
                None => Hit::Surface {
                    t,
                    pos: ray.at(t),
                    normal: normal(f.grad, -ray.dir),
                },
                Some(a) => w.refine(a, t),
            });
            break;
        }
        if entry.is_some() {
            if !in_shell {
                break;
            }
        } else if in_shell {
            entry = Some(t);
        }
        let mut step = (s_lip.max(clear) * m.step_scale).min(next_in - t);
        if in_shell {
            step = step.max(0.25 * eps);
        }
        step = step.max(1e-6 * (1.0 + t));
        t_prev = Some(t);
        t += step;
    }
    let hit = result.unwrap_or(match entry {
        Some(te) => Hit::Outline { t: te },
        None => Hit::Miss,
    });
    let decided = match hit {
        Hit::Surface { t, .. } => t,
        Hit::Outline { t } if eps_per_t > 0.0 => t,
        _ => f64::INFINITY,
    };
    if w.over <= ray.t1 && decided >= w.over {
        count.overflow = 1;
    }
    (hit, count)
}

/// A segment's pieces (`curve::pieces`): their points and deviations.
type PiecesOf = ([DVec3; curve::PIECES + 1], [f64; curve::PIECES]);

/// The pieces of each kept candidate's segment, in `kept`'s order.
fn piece_all(wisps: &[Vec<Segment>], kept: &[Candidate]) -> Vec<PiecesOf> {
    kept.iter()
        .map(|c| curve::pieces(&wisps[c.wisp][c.seg]))
        .collect()
}

/// The tiled march's window on one ray: the candidates kept (`keep_nearest`) with their
/// pieces, where the window ends and where a candidate was dropped for good.
struct Window<'a> {
    wisps: &'a [Vec<Segment>],
    cands: &'a [Candidate],
    threshold: f64,
    m: &'a March,
    ray: &'a Ray,
    lines: &'a Outlines<'a>,
    slots: usize,
    kept: Vec<Candidate>,
    pieced: Vec<PiecesOf>,
    /// Where the first dropped candidate begins (+∞: none dropped).
    t_drop: f64,
    /// The nearest entry of a candidate dropped for good (+∞: none).
    over: f64,
}

impl Window<'_> {
    /// The window's end at `t`: gather again from the last sample `from` (bisection may go
    /// back). A candidate that begins no later than `t` is dropped for good.
    fn regather(&mut self, from: f64, t: f64) {
        let (k, nd) = keep_nearest(self.cands, from, self.slots);
        self.kept = k;
        self.pieced = piece_all(self.wisps, &self.kept);
        if nd <= t {
            self.over = self.over.min(nd);
            self.t_drop = f64::INFINITY;
        } else {
            self.t_drop = nd;
        }
    }

    /// The exact field (f, Lipschitz step, outline scale) or the clear step at t, over the
    /// kept candidates whose influence interval holds t.
    fn sample(&self, t: f64, exact: bool) -> (Density, f64, f64, f64) {
        let (wisps, lines, ray) = (self.wisps, self.lines, self.ray);
        let act: Vec<(Candidate, usize)> = self
            .kept
            .iter()
            .enumerate()
            .filter(|(_, c)| c.t_in <= t && t <= c.t_out)
            .map(|(i, c)| (*c, i))
            .collect();
        let segs: Vec<Pieced> = act
            .iter()
            .map(|(c, i)| Pieced {
                wisp: c.wisp,
                index: c.seg,
                seg: &wisps[c.wisp][c.seg],
                pts: &self.pieced[*i].0,
                dev: &self.pieced[*i].1,
                outline: lines.of(c.wisp, c.seg),
            })
            .collect();
        if exact {
            let (f, s, o) = exact_sample(
                &segs,
                self.threshold,
                ray.at(t),
                self.m.distance,
                lines.taper,
            );
            (f, s, o, 0.0)
        } else {
            let clear = clear_step(&segs, self.threshold, ray.at(t));
            (Density::default(), 0.0, 0.0, clear)
        }
    }

    /// A hit between the samples `a` (outside) and `b` (inside), refined by bisection as in
    /// `march`.
    fn refine(&self, mut a: f64, mut b: f64) -> Hit {
        for _ in 0..self.m.refine {
            let mid = 0.5 * (a + b);
            if self.sample(mid, true).0.rho >= 0.0 {
                b = mid;
            } else {
                a = mid;
            }
        }
        let t_hit = 0.5 * (a + b);
        let g = self.sample(t_hit, true).0.grad;
        Hit::Surface {
            t: t_hit,
            pos: self.ray.at(t_hit),
            normal: normal(g, -self.ray.dir),
        }
    }
}
