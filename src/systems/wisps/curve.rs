//! Skeleton curves (Sakai 2014, eqs 3-7 and 11-13): a natural cubic spline through a wisp's
//! nodes, one cubic Bézier segment per edge with its control-point box, and the distance from
//! a point to a segment (eq 10). f64 reference of the ray-march shader: the GPU follows the
//! same steps, so every choice is written down here.

use crate::systems::wisps::block::Distance;
use glam::DVec3;

/// One skeleton edge as a cubic Bézier with the end nodes' radius and weight (lerped in t).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub ctrl: [DVec3; 4],
    /// r at t = 0 and t = 1.
    pub r: [f64; 2],
    /// w at t = 0 and t = 1.
    pub w: [f64; 2],
    /// Box of the control points, not inflated: the curve lies in their convex hull.
    pub lo: DVec3,
    pub hi: DVec3,
    /// Bound on |∇ρ_e| where ρ_e > 0 (sphere-tracing step = -f / Σ lipschitz).
    pub lipschitz: f64,
}

impl Segment {
    /// B(t), Bernstein form (eq 11).
    pub fn point(&self, t: f64) -> DVec3 {
        let [v0, v1, v2, v3] = self.ctrl;
        let s = 1.0 - t;
        v0 * (s * s * s) + v1 * (3.0 * s * s * t) + v2 * (3.0 * s * t * t) + v3 * (t * t * t)
    }

    /// B'(t).
    pub fn derivative(&self, t: f64) -> DVec3 {
        let [v0, v1, v2, v3] = self.ctrl;
        let s = 1.0 - t;
        ((v1 - v0) * (s * s) + (v2 - v1) * (2.0 * s * t) + (v3 - v2) * (t * t)) * 3.0
    }

    /// B''(t).
    pub fn second_derivative(&self, t: f64) -> DVec3 {
        let [v0, v1, v2, v3] = self.ctrl;
        ((v2 - v1 * 2.0 + v0) * (1.0 - t) + (v3 - v2 * 2.0 + v1) * t) * 6.0
    }

    pub fn radius(&self, t: f64) -> f64 {
        self.r[0] + (self.r[1] - self.r[0]) * t
    }

    pub fn weight(&self, t: f64) -> f64 {
        self.w[0] + (self.w[1] - self.w[0]) * t
    }

    /// Largest radius of influence: beyond it from the box the segment adds nothing.
    pub fn r_max(&self) -> f64 {
        self.r[0].max(self.r[1])
    }

    /// Euclidean distance from `p` to the control-point box (0 inside).
    pub fn box_distance(&self, p: DVec3) -> f64 {
        (self.lo - p).max(p - self.hi).max(DVec3::ZERO).length()
    }
}

/// Natural cubic spline through `points` with node j at t = j (eq 4): per segment the power
/// coefficients (a, b, c, d) of S_j(t) = a t³ + b t² + c t + d, t ∈ [0, 1], C2 at interior
/// nodes (eqs 5-6), S'' = 0 at both ends (eq 7). Fewer than 2 points: no segments.
///
/// With M_j = S''(node j): M_0 = M_{N-1} = 0 and M_{j-1} + 4 M_j + M_{j+1} =
/// 6 (P_{j+1} - 2 P_j + P_{j-1}) for 0 < j < N-1, solved by the Thomas algorithm (no
/// pivoting: the matrix is strictly diagonally dominant); then a = (M_{j+1} - M_j)/6,
/// b = M_j/2, c = P_{j+1} - P_j - (2 M_j + M_{j+1})/6, d = P_j.
pub fn spline(points: &[DVec3]) -> Vec<[DVec3; 4]> {
    let n = points.len();
    if n < 2 {
        return Vec::new();
    }
    let mut m = vec![DVec3::ZERO; n];
    let k = n - 2; // interior unknowns M_1..M_{N-2}
    if k > 0 {
        // Forward sweep: cp = modified super-diagonal, dp = modified right-hand side.
        let mut cp = vec![0.0; k];
        let mut dp = vec![DVec3::ZERO; k];
        for i in 0..k {
            let j = i + 1;
            let rhs = (points[j + 1] - points[j] * 2.0 + points[j - 1]) * 6.0;
            let (prev_c, prev_d) = if i == 0 {
                (0.0, DVec3::ZERO)
            } else {
                (cp[i - 1], dp[i - 1])
            };
            let denom = 4.0 - prev_c;
            cp[i] = 1.0 / denom;
            dp[i] = (rhs - prev_d) / denom;
        }
        m[k] = dp[k - 1];
        for i in (0..k - 1).rev() {
            m[i + 1] = dp[i] - m[i + 2] * cp[i];
        }
    }
    (0..n - 1)
        .map(|j| {
            let (m0, m1) = (m[j], m[j + 1]);
            let a = (m1 - m0) / 6.0;
            let b = m0 * 0.5;
            let c = points[j + 1] - points[j] - (m0 * 2.0 + m1) / 6.0;
            [a, b, c, points[j]]
        })
        .collect()
}

/// Bézier control points of a t³ + b t² + c t + d on [0, 1]. The printed eqs 12-13 have
/// typos; matching the Bernstein form's power coefficients gives these.
pub fn bezier([a, b, c, d]: [DVec3; 4]) -> [DVec3; 4] {
    [d, d + c / 3.0, d + (c * 2.0 + b) / 3.0, a + b + c + d]
}

/// S(t) of power coefficients (a, b, c, d) (Horner).
pub fn power_eval([a, b, c, d]: [DVec3; 4], t: f64) -> DVec3 {
    ((a * t + b) * t + c) * t + d
}

/// The segments of one wisp from its nodes `(position, r, w)`, already posed in world space.
///
/// Lipschitz bound: |fd'| ≤ 2 and |∇D| = 1, while r(t*) and w(t*) move with the closest
/// parameter t* at a rate |∇t*| ≈ 1/|B'|; s = |v3 - v0|/2 (clamped ≥ 1e-9) stands in for the
/// least |B'|, so L = 2 w_max/r_min (1 + 2|Δr|/s) + 2|Δw|/s. Tested against finite
/// differences (tests/it/wisps_field.rs): the taper terms are needed just before a thin end; the
/// bound assumes ρ_e continuous, true for turns up to ~0.7 rad per node (from ~1 rad the
/// closest point jumps within r and Newton can stop in a local minimum).
pub fn segments(nodes: &[(DVec3, f64, f64)]) -> Vec<Segment> {
    let points: Vec<DVec3> = nodes.iter().map(|n| n.0).collect();
    spline(&points)
        .into_iter()
        .enumerate()
        .map(|(j, abcd)| {
            let ctrl = bezier(abcd);
            let (r, w) = ([nodes[j].1, nodes[j + 1].1], [nodes[j].2, nodes[j + 1].2]);
            let lo = ctrl[0].min(ctrl[1]).min(ctrl[2]).min(ctrl[3]);
            let hi = ctrl[0].max(ctrl[1]).max(ctrl[2]).max(ctrl[3]);
            Segment {
                ctrl,
                r,
                w,
                lo,
                hi,
                lipschitz: lipschitz(&ctrl, r, w),
            }
        })
        .collect()
}

/// The segments of every wisp of `wisps` as drawn (the rest pose, head still): what the f64
/// references of a still scene take.
pub fn drawn_segments(wisps: &crate::systems::wisps::block::Wisps) -> Vec<Vec<Segment>> {
    wisps
        .skeletons
        .iter()
        .map(|s| {
            let nodes: Vec<(DVec3, f64, f64)> = s
                .nodes
                .iter()
                .map(|n| (DVec3::from(n.p), n.r, n.w))
                .collect();
            segments(&nodes)
        })
        .collect()
}

/// See `segments`.
pub fn lipschitz(ctrl: &[DVec3; 4], r: [f64; 2], w: [f64; 2]) -> f64 {
    let s = (0.5 * (ctrl[3] - ctrl[0]).length()).max(1e-9);
    let (r_min, w_max) = (r[0].min(r[1]), w[0].max(w[1]));
    let (dr, dw) = ((r[1] - r[0]).abs(), (w[1] - w[0]).abs());
    2.0 * w_max / r_min * (1.0 + 2.0 * dr / s) + 2.0 * dw / s
}

/// The least distance between the line segments p0-p1 and q0-q1 (clamped closest points,
/// Ericson's Real-Time Collision Detection 5.1.9).
pub fn segment_distance(p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3) -> f64 {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let (s, t) = if a <= 1e-18 && e <= 1e-18 {
        (0.0, 0.0)
    } else if a <= 1e-18 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= 1e-18 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > 1e-18 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p0 + d1 * s) - (q0 + d2 * t)).length()
}

/// Distance from `v` to the segment and the parameter t of the closest point found.
pub fn distance(seg: &Segment, v: DVec3, method: Distance) -> (f64, f64) {
    match method {
        Distance::Newton => distance_newton(seg, v),
        Distance::Polyline { pieces } => distance_polyline(seg, v, pieces),
    }
}

/// Wang–Kearney–Atkinson: quadratic minimisation of g(t) = |B(t) - v|² from samples
/// t = 0, 0.5, 1 (4 iterations), then 3 Newton iterations from the best sample, then the
/// better of that and the two endpoints.
///
/// Decisions not fixed by the spec: the quadratic step stops when two samples are closer than
/// 1e-9 in t or the parabola's leading coefficient is not > 0; Newton starts from the sample
/// with the least g (first on ties); a Newton iteration with g'' ≤ 0 leaves t unchanged;
/// on equal g the earlier candidate wins (Newton result, then t = 0, then t = 1).
pub fn distance_newton(seg: &Segment, v: DVec3) -> (f64, f64) {
    let g = |t: f64| (seg.point(t) - v).length_squared();
    let mut ts: [f64; 3] = [0.0, 0.5, 1.0];
    let mut gs = [g(0.0), g(0.5), g(1.0)];
    for _ in 0..4 {
        let [t1, t2, t3] = ts;
        let [g1, g2, g3] = gs;
        let (d12, d13, d23) = (t1 - t2, t1 - t3, t2 - t3);
        if d12.abs() < 1e-9 || d13.abs() < 1e-9 || d23.abs() < 1e-9 {
            break;
        }
        // Leading coefficient (second divided difference) and the vertex of the parabola.
        let lead = g1 / (d12 * d13) - g2 / (d12 * d23) + g3 / (d13 * d23);
        if lead.is_nan() || lead <= 0.0 {
            break;
        }
        let num = (t2 * t2 - t3 * t3) * g1 + (t3 * t3 - t1 * t1) * g2 + (t1 * t1 - t2 * t2) * g3;
        let den = d23 * g1 + (t3 - t1) * g2 + d12 * g3;
        let t_new = (0.5 * num / den).clamp(0.0, 1.0);
        if !t_new.is_finite() {
            break;
        }
        let worst = if gs[0] >= gs[1] && gs[0] >= gs[2] {
            0
        } else if gs[1] >= gs[2] {
            1
        } else {
            2
        };
        ts[worst] = t_new;
        gs[worst] = g(t_new);
    }
    let best = if gs[0] <= gs[1] && gs[0] <= gs[2] {
        0
    } else if gs[1] <= gs[2] {
        1
    } else {
        2
    };
    let mut t = ts[best];
    for _ in 0..3 {
        let e = seg.point(t) - v;
        let d1 = seg.derivative(t);
        let g1 = 2.0 * e.dot(d1);
        let g2 = 2.0 * (d1.dot(d1) + e.dot(seg.second_derivative(t)));
        if g2 > 0.0 {
            t = (t - g1 / g2).clamp(0.0, 1.0);
        }
    }
    let mut out = (g(t), t);
    for te in [0.0, 1.0] {
        let ge = g(te);
        if ge < out.0 {
            out = (ge, te);
        }
    }
    (out.0.sqrt(), out.1)
}

/// The segment as `pieces` chords between B(k/pieces); closed-form point-to-chord distance;
/// t interpolated linearly along the best chord (the first on ties).
pub fn distance_polyline(seg: &Segment, v: DVec3, pieces: u32) -> (f64, f64) {
    let n = pieces.max(1) as usize;
    let point = |k: usize| seg.point(k as f64 / n as f64);
    if n <= 64 {
        let mut points = [DVec3::ZERO; 65];
        for (k, p) in points.iter_mut().enumerate().take(n + 1) {
            *p = point(k);
        }
        polyline_distance(&points[..=n], v)
    } else {
        polyline_distance(&(0..=n).map(point).collect::<Vec<_>>(), v)
    }
}

/// Distance from `v` to the polyline through `points` (at least two), closed form per
/// chord, and t in [0, 1] over the whole polyline, interpolated linearly along the best
/// chord (the first on ties).
pub fn polyline_distance(points: &[DVec3], v: DVec3) -> (f64, f64) {
    let n = points.len().saturating_sub(1).max(1) as f64;
    let mut best = (f64::INFINITY, 0.0);
    for (k, w) in points.windows(2).enumerate() {
        let (p0, e) = (w[0], w[1] - w[0]);
        let len2 = e.length_squared();
        let u = if len2 > 0.0 {
            ((v - p0).dot(e) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d2 = (v - (p0 + e * u)).length_squared();
        if d2 < best.0 {
            best = (d2, (k as f64 + u) / n);
        }
    }
    (best.0.sqrt(), best.1)
}

/// Reference for tests: the best of `samples + 1` uniform samples, then golden-section search
/// on the bracket around it (down to 1e-15 in t), and the endpoints.
pub fn distance_brute(seg: &Segment, v: DVec3, samples: u32) -> (f64, f64) {
    let g = |t: f64| (seg.point(t) - v).length_squared();
    let n = samples.max(2);
    let mut k_best = 0;
    let mut g_best = f64::INFINITY;
    for k in 0..=n {
        let gk = g(k as f64 / n as f64);
        if gk < g_best {
            g_best = gk;
            k_best = k;
        }
    }
    let (mut a, mut b) = (
        k_best.saturating_sub(1) as f64 / n as f64,
        (k_best + 1).min(n) as f64 / n as f64,
    );
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (b - phi * (b - a), a + phi * (b - a));
    let (mut f1, mut f2) = (g(x1), g(x2));
    for _ in 0..100 {
        if b - a < 1e-15 {
            break;
        }
        if f1 < f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - phi * (b - a);
            f1 = g(x1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + phi * (b - a);
            f2 = g(x2);
        }
    }
    let mut out = (g_best, k_best as f64 / n as f64);
    for t in [0.5 * (a + b), 0.0, 1.0] {
        let gt = g(t);
        if gt < out.0 {
            out = (gt, t);
        }
    }
    (out.0.sqrt(), out.1)
}

/// x with fd(x) = y (eq 9 inverted), y in (0, 1].
pub fn fd_inverse(y: f64) -> f64 {
    if y <= 2.0 / 3.0 {
        1.0 - (y / 1.5).sqrt()
    } else {
        ((1.0 - y) / 3.0).sqrt()
    }
}

/// Distance from `p` to the chord `a`-`b`.
pub fn chord_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let l2 = ab.length_squared();
    let u = if l2 > 0.0 {
        ((p - a).dot(ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * u - p).length()
}

/// A segment's bounds for the tiled march (`shaders/wisps/curves.wgsl` `spline` and
/// `overlaps`): capsules round the chord c0-c3.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capsule {
    pub a: DVec3,
    pub b: DVec3,
    /// Holds the segment's whole influence: the control points' largest distance from the
    /// chord (the curve lies in their hull) plus r_max.
    pub influence: f64,
    /// Holds every point where this segment can be the arg-max of a point inside the
    /// surface; negative where it never can be.
    pub hit: f64,
    /// K: wisps whose influence box overlaps this segment's (itself included).
    pub wisps_near: u32,
}

impl Segment {
    /// The control-point box grown by r_max: every point the segment adds density to.
    pub fn influence_box(&self) -> (DVec3, DVec3) {
        let r = DVec3::splat(self.r_max());
        (self.lo - r, self.hi + r)
    }
}

/// The capsules of every segment of a scene (`wisps[i]` the segments of wisp i) for
/// `threshold`. Inside the surface Σ_wisps ρ ≥ threshold with at most K wisps adding density
/// (each has a segment whose influence box holds the point, so overlaps the arg-max
/// segment's box), so the densest wisp's arg-max segment has w_max fd(D / r_max) ≥
/// threshold / K: D ≤ r_max fd⁻¹(threshold / (K w_max)). 1e-4 r_max of slack covers f32.
pub fn capsules(wisps: &[Vec<Segment>], threshold: f64) -> Vec<Vec<Capsule>> {
    let boxes: Vec<(usize, (DVec3, DVec3))> = wisps
        .iter()
        .enumerate()
        .flat_map(|(wi, w)| w.iter().map(move |s| (wi, s.influence_box())))
        .collect();
    wisps
        .iter()
        .map(|w| {
            w.iter()
                .map(|s| {
                    let (lo, hi) = s.influence_box();
                    let mut k = 0u32;
                    let mut last = usize::MAX;
                    for &(wi, (l, h)) in &boxes {
                        if wi != last && l.cmple(hi).all() && lo.cmple(h).all() {
                            k += 1;
                            last = wi;
                        }
                    }
                    let [c0, c1, c2, c3] = s.ctrl;
                    let margin = chord_distance(c1, c0, c3).max(chord_distance(c2, c0, c3));
                    let y = threshold / (f64::from(k.max(1)) * s.w[0].max(s.w[1]));
                    let hit = if y <= 1.0 {
                        s.r_max() * (fd_inverse(y) + 1e-4) + margin
                    } else {
                        -1.0
                    };
                    Capsule {
                        a: c0,
                        b: c3,
                        influence: margin + s.r_max(),
                        hit,
                        wisps_near: k,
                    }
                })
                .collect()
        })
        .collect()
}

/// The interval of the ray `o + t d` (|d| = 1) inside the capsule round `a`-`b` of radius
/// `r`, or None: the union of the two end spheres' and the cylinder's intervals (the capsule
/// is convex, so it is one interval). Same steps as `ray_capsule` in
/// `shaders/wisps/march.wgsl`.
pub fn ray_capsule(o: DVec3, d: DVec3, a: DVec3, b: DVec3, r: f64) -> Option<(f64, f64)> {
    if r <= 0.0 {
        return None;
    }
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for c in [a, b] {
        let oc = o - c;
        let bq = oc.dot(d);
        let disc = bq * bq - (oc.length_squared() - r * r);
        if disc >= 0.0 {
            let s = disc.sqrt();
            lo = lo.min(-bq - s);
            hi = hi.max(-bq + s);
        }
    }
    let ba = b - a;
    let baba = ba.length_squared();
    if baba > 0.0 {
        let oa = o - a;
        let (bd, bo) = (ba.dot(d), ba.dot(oa));
        let dp = d - ba * (bd / baba);
        let op = oa - ba * (bo / baba);
        let qa = dp.length_squared();
        let qb = op.dot(dp);
        let qc = op.length_squared() - r * r;
        // The infinite cylinder's interval.
        let (c0, c1) = if qa > 1e-12 {
            let disc = qb * qb - qa * qc;
            if disc >= 0.0 {
                let s = disc.sqrt();
                ((-qb - s) / qa, (-qb + s) / qa)
            } else {
                (f64::INFINITY, f64::NEG_INFINITY)
            }
        } else if qc <= 0.0 {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (f64::INFINITY, f64::NEG_INFINITY)
        };
        // The slab 0 <= (oa + t d).ba <= |ba|² along the axis.
        let (s0, s1) = if bd.abs() > 1e-12 {
            let (u, v) = (-bo / bd, (baba - bo) / bd);
            (u.min(v), u.max(v))
        } else if (0.0..=baba).contains(&bo) {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (f64::INFINITY, f64::NEG_INFINITY)
        };
        let (x0, x1) = (c0.max(s0), c1.min(s1));
        if x0 <= x1 {
            lo = lo.min(x0);
            hi = hi.max(x1);
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// Pieces per segment of the march's distance bound: t in [k/8, (k+1)/8].
pub const PIECES: usize = 8;

/// The segment cut into `PIECES` pieces: the curve points at t = k/PIECES and each piece's
/// deviation from its chord (the largest distance of its sub-curve's inner control points,
/// B(a) + (b-a)/3 B'(a) and B(b) - (b-a)/3 B'(b), from the chord: the sub-curve lies in
/// their hull). A point's distance to piece k is at least its chord distance less the
/// deviation. As `spline` in `shaders/wisps/curves.wgsl` writes them.
pub fn pieces(seg: &Segment) -> ([DVec3; PIECES + 1], [f64; PIECES]) {
    let mut pts = [DVec3::ZERO; PIECES + 1];
    let mut dev = [0.0; PIECES];
    let h = 1.0 / PIECES as f64;
    for (k, p) in pts.iter_mut().enumerate() {
        *p = seg.point(k as f64 * h);
    }
    for k in 0..PIECES {
        let (a, b) = (k as f64 * h, (k + 1) as f64 * h);
        let q1 = pts[k] + seg.derivative(a) * (h / 3.0);
        let q2 = pts[k + 1] - seg.derivative(b) * (h / 3.0);
        dev[k] = chord_distance(q1, pts[k], pts[k + 1]).max(chord_distance(q2, pts[k], pts[k + 1]));
    }
    (pts, dev)
}
