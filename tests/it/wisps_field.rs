//! The toon wisps' f64 reference (`systems::wisps::{curve, field}`): the natural spline and
//! its Bézier form, the distance methods against a brute-force minimiser, the Lipschitz
//! bounds against finite differences, the per-wisp max (no bulge at joints), the sphere
//! tracer against a closed-form tube and on thin wisps, and the head-frame angel halo.

use glam::{DMat3, DMat4, DVec3};
use kami::rng::Rng;
use kami::systems::wisps::block::{Distance, March, Tones, Toon};
use kami::systems::wisps::curve::{self, Segment};
use kami::systems::wisps::field::{self, Hit, Ray};

fn rand_vec(rng: &mut Rng, s: f64) -> DVec3 {
    DVec3::new(rng.range(-s, s), rng.range(-s, s), rng.range(-s, s))
}

fn rand_unit(rng: &mut Rng) -> DVec3 {
    loop {
        let v = rand_vec(rng, 1.0);
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

/// A shipped-style skeleton: 4-10 nodes 2-4 apart, turning up to `bend` radians per node, r
/// tapering from ~1.2 to ~0.3, w in 1..2.
fn skeleton(rng: &mut Rng, bend: f64) -> Vec<(DVec3, f64, f64)> {
    let n = 4 + (rng.next_u32() % 7) as usize;
    let mut p = rand_vec(rng, 5.0);
    let mut d = rand_unit(rng);
    let (r0, r1) = (rng.range(1.0, 1.4), rng.range(0.2, 0.4));
    let mut out = Vec::new();
    for i in 0..n {
        let u = i as f64 / (n - 1) as f64;
        out.push((p, r0 + (r1 - r0) * u, rng.range(1.0, 2.0)));
        let axis = d.cross(rand_unit(rng)).normalize_or_zero();
        if axis != DVec3::ZERO {
            d = DMat3::from_axis_angle(axis, rng.range(0.0, bend)) * d;
        }
        p += d * rng.range(2.0, 4.0);
    }
    out
}

fn march_default() -> March {
    March::default()
}

#[test]
fn spline_interpolates_with_c2_joints_and_natural_ends() {
    let mut rng = Rng::new(1, 0);
    for n in 2..=12 {
        for _ in 0..20 {
            let pts: Vec<DVec3> = (0..n).map(|_| rand_vec(&mut rng, 10.0)).collect();
            let s = curve::spline(&pts);
            assert_eq!(s.len(), n - 1);
            let d1 = |[a, b, c, _]: [DVec3; 4], t: f64| a * (3.0 * t * t) + b * (2.0 * t) + c;
            let d2 = |[a, b, _, _]: [DVec3; 4], t: f64| a * (6.0 * t) + b * 2.0;
            for j in 0..n - 1 {
                let e0 = (curve::power_eval(s[j], 0.0) - pts[j]).length();
                let e1 = (curve::power_eval(s[j], 1.0) - pts[j + 1]).length();
                assert!(e0 < 1e-12 && e1 < 1e-11, "n={n} j={j}: {e0:e} {e1:e}");
                if j + 1 < n - 1 {
                    let c1 = (d1(s[j], 1.0) - d1(s[j + 1], 0.0)).length();
                    let c2 = (d2(s[j], 1.0) - d2(s[j + 1], 0.0)).length();
                    assert!(c1 < 1e-10 && c2 < 1e-10, "n={n} j={j}: C1 {c1:e} C2 {c2:e}");
                }
            }
            let ends = d2(s[0], 0.0).length() + d2(s[n - 2], 1.0).length();
            assert!(ends < 1e-10, "n={n}: S'' at the ends {ends:e}");
        }
    }
    let (p, q) = (DVec3::new(1.0, 2.0, 3.0), DVec3::new(-2.0, 0.5, 4.0));
    let s = curve::spline(&[p, q]);
    assert_eq!(
        s,
        vec![[DVec3::ZERO, DVec3::ZERO, q - p, p]],
        "N = 2: the line"
    );
    assert!(curve::spline(&[p]).is_empty());
}

#[test]
fn bezier_agrees_with_power_form() {
    let mut rng = Rng::new(2, 0);
    let mut worst = 0.0f64;
    for _ in 0..200 {
        let abcd = [0; 4].map(|_| rand_vec(&mut rng, 10.0));
        let seg = curve::segments(&[(DVec3::ZERO, 1.0, 1.0), (DVec3::X, 1.0, 1.0)])[0];
        let seg = Segment {
            ctrl: curve::bezier(abcd),
            ..seg
        };
        for k in 0..=100 {
            let t = k as f64 / 100.0;
            worst = worst.max((seg.point(t) - curve::power_eval(abcd, t)).length());
        }
    }
    println!("bezier vs power form: worst {worst:e}");
    assert!(worst < 1e-12, "{worst:e}");
}

#[test]
fn control_box_contains_the_curve() {
    let mut rng = Rng::new(3, 0);
    for _ in 0..50 {
        for seg in curve::segments(&skeleton(&mut rng, 1.2)) {
            for k in 0..1000 {
                let p = seg.point(k as f64 / 999.0);
                assert!(
                    p.cmpge(seg.lo - 1e-12).all() && p.cmple(seg.hi + 1e-12).all(),
                    "{p} outside [{}, {}]",
                    seg.lo,
                    seg.hi
                );
            }
        }
    }
}

/// Random points around the segments of random skeletons: a curve point plus an offset of
/// length up to `reach`·r(t).
fn near_points(
    rng: &mut Rng,
    skeletons: usize,
    per_seg: usize,
    reach: f64,
    bend: f64,
) -> Vec<(Segment, DVec3)> {
    let mut out = Vec::new();
    for _ in 0..skeletons {
        for seg in curve::segments(&skeleton(rng, bend)) {
            for _ in 0..per_seg {
                let t = rng.range(-0.1, 1.1);
                let base = seg.point(t.clamp(0.0, 1.0));
                let off = rand_unit(rng) * rng.range(0.0, reach) * seg.radius(t.clamp(0.0, 1.0));
                out.push((seg, base + off));
            }
        }
    }
    out
}

fn chord_len(seg: &Segment) -> f64 {
    (1..=64)
        .map(|k| (seg.point(k as f64 / 64.0) - seg.point((k - 1) as f64 / 64.0)).length())
        .sum()
}

#[test]
fn newton_distance_matches_brute_force() {
    let mut rng = Rng::new(4, 0);
    let pts = near_points(&mut rng, 60, 60, 1.0, 0.7);
    let (mut worst_in, mut worst_all, mut n_in) = (0.0f64, 0.0f64, 0);
    for (seg, v) in &pts {
        let (db, tb) = curve::distance_brute(seg, *v, 2000);
        let (dn, tn) = curve::distance_newton(seg, *v);
        assert!(
            (seg.point(tn) - *v).length() - dn < 1e-12,
            "D is |B(t) - v|"
        );
        assert!(dn >= db - 1e-12, "Newton below the minimum: {dn} < {db}");
        let rel = (dn - db) / chord_len(seg);
        worst_all = worst_all.max(rel);
        if db < seg.radius(tb) {
            n_in += 1;
            worst_in = worst_in.max(rel);
        }
    }
    println!(
        "Newton - brute force, relative to segment length: worst {worst_in:e} over {n_in} \
         points with D < r; worst {worst_all:e} over all {}",
        pts.len()
    );
    assert!(n_in > 1000);
    assert!(worst_in < 1e-6, "{worst_in:e}");
}

#[test]
fn polyline_distance_converges_quadratically() {
    let mut rng = Rng::new(5, 0);
    let pts = near_points(&mut rng, 20, 40, 1.0, 0.7);
    let brute: Vec<f64> = pts
        .iter()
        .map(|(s, v)| curve::distance_brute(s, *v, 2000).0)
        .collect();
    let mut errs = Vec::new();
    for pieces in [2u32, 4, 8, 16, 32, 64] {
        let worst = pts
            .iter()
            .zip(&brute)
            .map(|((s, v), db)| {
                let (d, t) = curve::distance(s, *v, Distance::Polyline { pieces });
                let cp = field::closest_point(s, t, Distance::Polyline { pieces });
                assert!(
                    ((cp - *v).length() - d).abs() < 1e-9,
                    "t locates the chord point"
                );
                (d - db).abs() / chord_len(s)
            })
            .fold(0.0f64, f64::max);
        println!("polyline pieces {pieces}: worst error / segment length {worst:e}");
        if let Some(&prev) = errs.last() {
            assert!(worst < 0.5 * prev, "no convergence at {pieces} pieces");
        }
        errs.push(worst);
    }
    // Worst-case errors are noisy per halving; the order over 2..64 pieces is steady.
    let order = (errs[0] / errs[5]).log2() / 5.0;
    println!("observed order over 2..64 pieces: {order:.3}");
    assert!(order > 1.8, "order {order} (expected 2)");
}

/// Worst |∇ρ_e| (central differences) over the segment's bound, at points with ρ_e > 0.
fn worst_lipschitz_ratio(pts: &[(Segment, DVec3)]) -> (f64, usize) {
    worst_gradient_ratio(pts, Distance::Newton, |s| s.lipschitz)
}

fn worst_gradient_ratio(
    pts: &[(Segment, DVec3)],
    method: Distance,
    bound: impl Fn(&Segment) -> f64,
) -> (f64, usize) {
    let h = 1e-6;
    let (mut worst, mut n_pos) = (0.0f64, 0);
    for (seg, v) in pts {
        let rho = |p: DVec3| field::segment_density(seg, p, method).rho;
        if rho(*v) <= 0.0 {
            continue;
        }
        n_pos += 1;
        let g = DVec3::new(
            rho(*v + DVec3::X * h) - rho(*v - DVec3::X * h),
            rho(*v + DVec3::Y * h) - rho(*v - DVec3::Y * h),
            rho(*v + DVec3::Z * h) - rho(*v - DVec3::Z * h),
        ) / (2.0 * h);
        worst = worst.max(g.length() / bound(seg));
    }
    (worst, n_pos)
}

#[test]
fn lipschitz_bound_holds_for_curved_tapering_wisps() {
    let mut rng = Rng::new(6, 0);
    for bend in [0.4, 0.7] {
        let pts = near_points(&mut rng, 100, 100, 1.3, bend);
        let (worst, n_pos) = worst_lipschitz_ratio(&pts);
        println!(
            "bend {bend} rad/node: worst |grad rho_e| / lipschitz over {n_pos} points with \
             rho > 0: {worst:.4}"
        );
        assert!(n_pos > 10_000);
        assert!(worst <= 1.0, "bound exceeded at bend {bend}: {worst}");
        // The polyline density (a different function) stays under the same bound.
        for pieces in [2, 4, 8] {
            let method = Distance::Polyline { pieces };
            let (worst, _) = worst_gradient_ratio(&pts, method, |s| s.lipschitz);
            println!("  {method:?}: {worst:.4}");
            assert!(
                worst <= 1.0,
                "bound exceeded at bend {bend}, {pieces} pieces: {worst}"
            );
        }
    }
    // Steep tapers, where the taper terms of the bound matter: a whole wisp's r range over one
    // edge (r 1.0-1.4 down to 0.2-0.3 in 2 units), w rising towards the thin end.
    let mut pts = Vec::new();
    for _ in 0..3000 {
        let d = rand_unit(&mut rng);
        let p0 = rand_vec(&mut rng, 5.0);
        let p1 = p0 + d * 2.0;
        let p2 = p1 + (d + rand_unit(&mut rng) * 0.6).normalize() * 2.0;
        let nodes = [
            (p0, rng.range(1.0, 1.4), rng.range(1.0, 1.2)),
            (p1, rng.range(0.2, 0.3), rng.range(1.8, 2.0)),
            (p2, 0.2, 2.0),
        ];
        let seg = curve::segments(&nodes)[0];
        for _ in 0..20 {
            let t = rng.range(0.0, 1.0);
            let v = seg.point(t) + rand_unit(&mut rng) * rng.range(0.0, 1.0) * seg.radius(t);
            pts.push((seg, v));
        }
    }
    let (worst, n_pos) = worst_lipschitz_ratio(&pts);
    println!("steep tapers: worst |grad rho_e| / lipschitz over {n_pos} points: {worst:.4}");
    assert!(worst <= 1.0, "bound exceeded on steep tapers: {worst}");
    // Where the taper terms are needed: constant w, x = D/r = 1/3 (|fd'| = 2) just before the
    // thin end, where 2 w/r(t) is nearly 2 w_max/r_min and moving t* adds a tangential part.
    let mut pts = Vec::new();
    for _ in 0..200 {
        let d = rand_unit(&mut rng);
        let p0 = rand_vec(&mut rng, 5.0);
        let p1 = p0 + d * 2.0;
        let p2 = p1 + (d + rand_unit(&mut rng) * 0.3).normalize() * 2.0;
        let nodes = [(p0, 1.2, 2.0), (p1, 0.3, 2.0), (p2, 0.3, 2.0)];
        let seg = curve::segments(&nodes)[0];
        for k in 1..=100 {
            let t = 1.0 - k as f64 * 2e-4;
            let side = seg.derivative(t).cross(rand_unit(&mut rng)).normalize();
            pts.push((seg, seg.point(t) + side * (seg.radius(t) / 3.0)));
        }
    }
    let (worst, _) = worst_lipschitz_ratio(&pts);
    let (plain, _) = worst_gradient_ratio(&pts, Distance::Newton, |s| {
        2.0 * s.w[0].max(s.w[1]) / s.r[0].min(s.r[1])
    });
    println!("tapered thin ends: worst ratio {worst:.4} (against 2 w_max/r_min alone: {plain:.4})");
    assert!(plain > 1.0, "the taper terms were not needed here");
    assert!(worst <= 1.0, "bound exceeded at thin ends: {worst}");
}

/// Within the shipped envelope (turns up to 0.7 rad per node) the closest point moves
/// continuously wherever ρ_e > 0 and Newton finds the global minimum, so ρ_e is continuous and
/// the Lipschitz bound is meaningful. (Measured beyond it: from ~1 rad per node the closest
/// point jumps inside the influence radius and Newton can settle on a local minimum.)
#[test]
fn closest_point_is_continuous_in_the_envelope() {
    let mut rng = Rng::new(60, 0);
    let pts = near_points(&mut rng, 40, 100, 1.3, 0.7);
    let h = 0.005;
    let (mut walks, mut jumps, mut wrong) = (0, 0, 0);
    for (seg, v) in &pts {
        if field::segment_density(seg, *v, Distance::Newton).rho <= 0.0 {
            continue;
        }
        walks += 1;
        let dir = rand_unit(&mut rng);
        let mut prev = curve::distance_newton(seg, *v).1;
        for k in 1..100 {
            let p = *v + dir * (k as f64 * h);
            let (d, t) = curve::distance_newton(seg, p);
            if d < seg.r_max() {
                jumps += usize::from((t - prev).abs() > 0.05);
                wrong += usize::from(d - curve::distance_brute(seg, p, 400).0 > 1e-9);
            }
            prev = t;
        }
    }
    println!("{walks} walks of 100 steps: {jumps} jumps of t, {wrong} local minima");
    assert!(walks > 5000);
    assert_eq!((jumps, wrong), (0, 0));
}

/// The step's Lipschitz sum covers the whole field where wisps blend: four wisps a radius
/// apart, |∇f| (central differences) ≤ L_near at random points around them.
#[test]
fn field_gradient_is_within_the_near_lipschitz_sum() {
    let mut rng = Rng::new(9, 0);
    let base = skeleton(&mut rng, 0.5);
    let wisps: Vec<Vec<Segment>> = (0..4)
        .map(|k| {
            let off = DVec3::new(0.4 * (k % 2) as f64, 0.0, 0.4 * (k / 2) as f64);
            curve::segments(
                &base
                    .iter()
                    .map(|&(p, r, w)| (p + off, r, w))
                    .collect::<Vec<_>>(),
            )
        })
        .collect();
    let h = 1e-6;
    let (mut worst, mut n) = (0.0f64, 0);
    for _ in 0..20_000 {
        let seg = &wisps[0][(rng.next_u32() as usize) % wisps[0].len()];
        let v = seg.point(rng.uniform()) + rand_vec(&mut rng, 1.5);
        let pr = field::probe(&wisps, 0.5, v, Distance::Newton);
        if pr.f.rho <= -0.5 {
            continue;
        }
        n += 1;
        let f = |p: DVec3| field::field(&wisps, 0.5, p, Distance::Newton).rho;
        let g = DVec3::new(
            f(v + DVec3::X * h) - f(v - DVec3::X * h),
            f(v + DVec3::Y * h) - f(v - DVec3::Y * h),
            f(v + DVec3::Z * h) - f(v - DVec3::Z * h),
        ) / (2.0 * h);
        worst = worst.max(g.length() / pr.l_near);
    }
    println!("blended wisps: worst |grad f| / L_near over {n} points: {worst:.4}");
    assert!(n > 5000);
    assert!(worst <= 1.0, "{worst}");
}

#[test]
fn fd_and_its_slope_are_continuous() {
    for x in [1.0 / 3.0, 1.0] {
        for d in [1e-9, 1e-12] {
            assert!(
                (field::fd(x - d) - field::fd(x + d)).abs() < 1e-8,
                "fd at {x}"
            );
            assert!(
                (field::fd_prime(x - d) - field::fd_prime(x + d)).abs() < 1e-8,
                "fd' at {x}"
            );
        }
    }
    assert_eq!(field::fd(0.0), 1.0);
    assert_eq!(field::fd(1.5), 0.0);
    let mut worst = 0.0f64;
    for k in 0..=1200 {
        let x = k as f64 / 1000.0;
        let num = (field::fd(x + 1e-7) - field::fd(x - 1e-7)) / 2e-7;
        worst = worst.max((num - field::fd_prime(x)).abs());
        assert!(field::fd_prime(x).abs() <= 2.0 + 1e-12);
    }
    assert!(worst < 1e-6, "fd' vs finite difference: {worst:e}");
}

/// Iso radius of a density along `dir` from `c`: bisection on rho(c + s dir) = threshold.
fn iso_radius(rho: impl Fn(DVec3) -> f64, c: DVec3, dir: DVec3, threshold: f64) -> f64 {
    let (mut a, mut b) = (0.0, 10.0);
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if rho(c + dir * m) >= threshold {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

#[test]
fn no_bulge_at_joints() {
    let (r, w, th) = (1.0, 1.5, 0.5);
    let nodes: Vec<_> = [-4.0, 0.0, 4.0]
        .iter()
        .map(|&x| (DVec3::new(x, 0.0, 0.0), r, w))
        .collect();
    let segs = curve::segments(&nodes);
    let rho = |p: DVec3| field::wisp_density(&segs, p, Distance::Newton).rho;
    let expected = r * (1.0 - (th / (1.5 * w)).sqrt());
    let dir = DVec3::new(0.0, 0.6, 0.8);
    let joint = iso_radius(rho, DVec3::ZERO, dir, th);
    let mid = iso_radius(rho, DVec3::new(-2.0, 0.0, 0.0), dir, th);
    println!("iso radius: joint {joint:.9}, mid-segment {mid:.9}, closed form {expected:.9}");
    assert!((joint - mid).abs() < 1e-6, "bulge: {joint} vs {mid}");
    assert!((mid - expected).abs() < 1e-6);
    // The paper's sum over edges would bulge here (the test can tell the two apart).
    let sum = |p: DVec3| {
        segs.iter()
            .map(|s| field::segment_density(s, p, Distance::Newton).rho)
            .sum::<f64>()
    };
    let bulge = iso_radius(sum, DVec3::ZERO, dir, th);
    println!("summed edges: joint radius {bulge:.6}");
    assert!(bulge > joint + 0.1);
}

/// Tapered wisps (a straight one and one bent into an arc, radius 2.9 down to 0.3 over six
/// segments, as the long wisps of `toon.ron`): walking along each just above its curve, the
/// surface normal turns smoothly, joints included. With each segment's end sphere counted at
/// a joint (the closed max before `WispMax`) the sphere of the joint's radius held the surface
/// for a stretch past every joint with a normal radial from it, and the normal jumped by
/// ~10-20 degrees where the next tube took over: the tone seams of issue 34.
#[test]
fn tapered_wisps_turn_their_normal_smoothly_across_joints() {
    let th = 0.5;
    let radii = [2.9, 2.4, 1.9, 1.4, 1.0, 0.6, 0.3];
    let straight: Vec<_> = radii
        .iter()
        .enumerate()
        .map(|(i, &r)| (DVec3::new(-12.0 + 4.0 * i as f64, 0.0, 0.0), r, 2.5))
        .collect();
    let arc: Vec<_> = radii
        .iter()
        .enumerate()
        .map(|(i, &r)| {
            let a = -0.9 + 0.3 * i as f64;
            (DVec3::new(14.0 * a.sin(), 14.0 * a.cos(), 0.0), r, 2.5)
        })
        .collect();
    for (name, nodes, side) in [
        ("straight", straight, DVec3::new(0.0, 0.6, 0.8)),
        ("arc", arc, DVec3::Z),
    ] {
        let segs = curve::segments(&nodes);
        let rho = |p: DVec3| field::wisp_density(&segs, p, Distance::Newton).rho;
        let mut prev: Option<(DVec3, f64)> = None;
        let mut worst: (f64, f64) = (0.0, 0.0);
        // Up to where the radius is 1.0: thinner, the tip's own end sphere is the surface.
        for k in 0..=800 {
            let u = 4.0 * k as f64 / 800.0;
            let (si, t) = ((u as usize).min(3), u - (u as usize).min(3) as f64);
            let c = segs[si].point(t);
            let rad = iso_radius(rho, c, side, th);
            let p = c + rad * side;
            let n = field::normal(
                field::field(std::slice::from_ref(&segs), th, p, Distance::Newton).grad,
                side,
            );
            if let Some((m, u0)) = prev {
                let turn = n.dot(m).clamp(-1.0, 1.0).acos().to_degrees();
                if turn > worst.0 {
                    worst = (turn, u0);
                }
            }
            prev = Some((n, u));
        }
        println!(
            "{name}: largest turn between samples 0.005 segment apart {:.3} deg at u {:.3}",
            worst.0, worst.1
        );
        assert!(
            worst.0 < 1.0,
            "{name}: the normal turns {:.2} deg in one step at segment parameter {:.3}",
            worst.0,
            worst.1
        );
    }
}

#[test]
fn near_far_split_is_exact() {
    let mut rng = Rng::new(7, 0);
    let wisps: Vec<Vec<Segment>> = (0..4)
        .map(|_| curve::segments(&skeleton(&mut rng, 0.7)))
        .collect();
    for _ in 0..3000 {
        let p = rand_vec(&mut rng, 15.0);
        let a = field::field(&wisps, 0.5, p, Distance::Newton);
        let b = field::probe(&wisps, 0.5, p, Distance::Newton);
        assert_eq!(a, b.f, "at {p}");
        assert!(b.far_gap >= 0.0);
    }
}

/// Ray/cylinder |(o + t d)_yz| = R, first root.
fn cylinder_hit(o: DVec3, d: DVec3, radius: f64) -> f64 {
    let (a, b, c) = (
        d.y * d.y + d.z * d.z,
        2.0 * (o.y * d.y + o.z * d.z),
        o.y * o.y + o.z * o.z - radius * radius,
    );
    (-b - (b * b - 4.0 * a * c).sqrt()) / (2.0 * a)
}

#[test]
fn march_hits_the_closed_form_tube() {
    let (r, w, th) = (0.8, 1.2, 0.5);
    let nodes: Vec<_> = [-6.0, -2.0, 2.0, 6.0]
        .iter()
        .map(|&x| (DVec3::new(x, 0.0, 0.0), r, w))
        .collect();
    let wisps = vec![curve::segments(&nodes)];
    let iso = r * (1.0 - (th / (1.5 * w)).sqrt());
    for method in [Distance::Newton, Distance::Polyline { pieces: 8 }] {
        let m = March {
            distance: method,
            ..march_default()
        };
        let mut worst = 0.0f64;
        let mut most_steps = 0;
        for k in 0..24 {
            let phi = k as f64 * 0.7;
            // From the side, obliquely, and nearly grazing, aimed at points near the axis.
            let tilt: f64 = [0.0, 0.6, 1.2][k % 3];
            let d = DVec3::new(tilt.sin(), phi.cos() * tilt.cos(), phi.sin() * tilt.cos());
            let aim = DVec3::new(-3.0 + 0.25 * k as f64, 0.1 * (k % 5) as f64 * iso, 0.0);
            let o = aim - d * 12.0;
            let ray = Ray {
                origin: o,
                dir: d,
                t0: 0.0,
                t1: 30.0,
            };
            let (hit, steps) = field::march(&wisps, th, &m, &ray, 0.0);
            most_steps = most_steps.max(steps);
            let Hit::Surface { t, pos, normal } = hit else {
                panic!("ray {k} ({method:?}): {hit:?}");
            };
            let expected = cylinder_hit(o, d, iso);
            worst = worst.max((t - expected).abs() / r);
            let radial = DVec3::new(0.0, pos.y, pos.z).normalize();
            assert!(
                (normal - radial).length() < 1e-5,
                "normal {normal} vs {radial}"
            );
        }
        println!("{method:?}: worst |t - closed form| / r = {worst:e}, most steps {most_steps}");
        assert!(worst < 1e-6, "{method:?}: {worst:e}");
    }
}

/// What `n` rays aimed at a thin wisp found.
#[derive(Debug)]
struct ThinRun {
    hits: usize,
    /// Misses before the step budget ran out: the surface was stepped over.
    skipped: usize,
    mean_steps: f64,
    most_steps: u32,
}

/// A thin curved wisp (r = 0.05, iso radius ≈ 0.021) and `n` rays from 20-60 units away
/// aimed at random points of its skeleton.
fn thin_wisp_hits(step_scale: f64, max_steps: u32, n: usize) -> ThinRun {
    let mut rng = Rng::new(8, 0);
    let nodes: Vec<_> = (0..7)
        .map(|i| {
            let a = i as f64 * 0.5;
            (
                DVec3::new(3.0 * a.cos(), 1.5 * i as f64, 3.0 * a.sin()),
                0.05,
                1.0,
            )
        })
        .collect();
    let wisps = vec![curve::segments(&nodes)];
    let m = March {
        step_scale,
        max_steps,
        ..march_default()
    };
    let eps_per_t = 1.5 / 1000.0;
    let (mut hits, mut skipped, mut steps, mut most_steps, mut worst_off) = (0, 0, 0u64, 0, 0.0f64);
    for _ in 0..n {
        let seg = &wisps[0][(rng.next_u32() % 6) as usize];
        let aim = seg.point(rng.uniform());
        let d = rand_unit(&mut rng);
        let dist = rng.range(20.0, 60.0);
        let ray = Ray {
            origin: aim - d * dist,
            dir: d,
            t0: 0.0,
            t1: dist + 20.0,
        };
        let (hit, s) = field::march(&wisps, 0.5, &m, &ray, eps_per_t);
        steps += s as u64;
        most_steps = most_steps.max(s);
        if let Hit::Surface { t, pos, .. } = hit {
            if step_scale <= 1.0 {
                assert!(t <= dist + 1e-9, "hit past the aimed point");
                // Off the surface by at most half the last bisection bracket, itself at most
                // the in-shell least step eps(t)/4 (safe steps never cross the surface).
                let f = field::field(&wisps, 0.5, pos, Distance::Newton);
                let off = f.rho.abs() / f.grad.length();
                let bound = 0.25 * eps_per_t * t / 2f64.powi(m.refine as i32 + 1);
                assert!(
                    off < 1.5 * bound,
                    "hit off the surface by {off:e} (bound {bound:e})"
                );
                worst_off = worst_off.max(off / bound);
            }
            hits += 1;
        } else if matches!(hit, Hit::Miss) && s < m.max_steps {
            skipped += 1;
        }
    }
    if step_scale <= 1.0 {
        println!("worst distance off the surface / bound: {worst_off:.3}");
    }
    ThinRun {
        hits,
        skipped,
        mean_steps: steps as f64 / n as f64,
        most_steps,
    }
}

impl std::fmt::Display for ThinRun {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(
            f,
            "{} hits, {} skipped, {:.1} steps per ray, at most {}",
            self.hits, self.skipped, self.mean_steps, self.most_steps
        )
    }
}

#[test]
fn thin_wisp_is_never_skipped() {
    // With the validator's largest budget every ray hits.
    let run = thin_wisp_hits(1.0, 4096, 1000);
    println!("step_scale 1, max_steps 4096: {run}");
    assert_eq!(run.hits, 1000);
    // The default budget runs out on rays that graze the wisp's boxes, but none skips it.
    let run = thin_wisp_hits(1.0, March::default().max_steps, 1000);
    println!("step_scale 1, max_steps 256: {run}");
    assert_eq!(run.skipped, 0);
    for scale in [1.2, 4.0] {
        let run = thin_wisp_hits(scale, 4096, 1000);
        println!("step_scale {scale}, max_steps 4096: {run}");
        assert!(
            run.skipped > 0,
            "step_scale {scale} should skip some (the test can fail)"
        );
    }
}

#[test]
fn angel_halo_is_a_band_of_latitude() {
    let toon = Toon::default();
    let elev = 40f64.to_radians();
    // Head turned and tilted: the halo follows the head's frame.
    for head in [
        DMat3::IDENTITY,
        DMat3::from_rotation_y(0.9) * DMat3::from_rotation_x(0.3),
    ] {
        let light = head * DVec3::new(0.0, elev.sin(), elev.cos());
        let half = toon.t_specular.acos();
        for i in 0..=90 {
            let lat = (-90.0 + 2.0 * i as f64).to_radians();
            let mut specs = Vec::new();
            for j in 0..72 {
                let lon = (j as f64 * 5.0).to_radians();
                let n_loc = DVec3::new(lat.cos() * lon.sin(), lat.sin(), lat.cos() * lon.cos());
                let (i_spec, i_diff, i_lat, i_lon) = field::intensities(head * n_loc, light, head);
                // Eqs 17-19: latitude of the normal, longitude difference to the light (at
                // longitude 0); at the poles no longitude.
                assert!((i_diff - i_lat * i_lon).abs() < 1e-12);
                assert!((i_lat - 0.5 * (lat.sin() + 1.0)).abs() < 1e-12);
                let want_lon = if lat.cos() < 1e-6 {
                    0.5
                } else {
                    0.5 * (lon.cos() + 1.0)
                };
                assert!(
                    (i_lon - want_lon).abs() < 1e-9,
                    "I_lon {i_lon} vs {want_lon}"
                );
                specs.push(i_spec);
                // The colour is a tone, plus the specular colour exactly in the band.
                let c = field::shade(head * n_loc, light, head, &toon);
                let spec = if i_spec > toon.t_specular {
                    field::linear(toon.specular)
                } else {
                    DVec3::ZERO
                };
                assert!(
                    [toon.diffuse, toon.shade, toon.dark]
                        .iter()
                        .any(|&tone| (field::linear(tone) + spec).min(DVec3::ONE) == c),
                    "{c}"
                );
            }
            let spread = specs.iter().cloned().fold(f64::MIN, f64::max)
                - specs.iter().cloned().fold(f64::MAX, f64::min);
            assert!(spread < 1e-12, "I_spec varies with longitude at lat {lat}");
            let in_band = specs[0] > toon.t_specular;
            let expect = (lat - elev).abs() < half;
            if ((lat - elev).abs() - half).abs() > 1e-6 {
                assert_eq!(in_band, expect, "lat {:.1}°", lat.to_degrees());
            }
            assert!((specs[0] - (lat - elev).cos()).abs() < 1e-12);
        }
    }
}

/// Eqs 20-22: the tone by the diffuse thresholds (two or three tones), specular added and
/// clamped. Normals sweep the latitude at the light's longitude, so I_diff = I_lat.
#[test]
fn toon_tones_follow_the_thresholds() {
    let light = DVec3::new(0.0, 0.2, 1.0).normalize();
    let lin = field::linear;
    for tones in [Tones::Two, Tones::Three] {
        let toon = Toon {
            tones,
            specular: [1.0, 1.0, 1.0],
            ..Toon::default()
        };
        let mut seen = [0; 3];
        for i in 0..=180 {
            let lat = (-90.0 + i as f64).to_radians();
            let n = DVec3::new(0.0, lat.sin(), lat.cos());
            let (i_spec, i_diff, _, _) = field::intensities(n, light, DMat3::IDENTITY);
            let tone = if i_diff > toon.t_diffuse {
                seen[0] += 1;
                lin(toon.diffuse)
            } else if tones == Tones::Two || i_diff > toon.t_dark {
                seen[1] += 1;
                lin(toon.shade)
            } else {
                seen[2] += 1;
                lin(toon.dark)
            };
            let want = if i_spec > toon.t_specular {
                DVec3::ONE // white specular saturates
            } else {
                tone
            };
            assert_eq!(
                field::shade(n, light, DMat3::IDENTITY, &toon),
                want,
                "lat {i}"
            );
        }
        println!("{tones:?}: diffuse/shade/dark over the sweep: {seen:?}");
        assert!(seen[0] > 0 && seen[1] > 0 && (seen[2] > 0) == (tones == Tones::Three));
    }
}

/// The silhouette shell: a ray grazing a front wisp within the outline width is an outline
/// even though it goes on to hit a wisp behind; further out it hits the back wisp.
#[test]
fn outline_shell_stops_grazing_rays() {
    let line = |y: f64, z: f64, r: f64| {
        curve::segments(&[-6.0, 0.0, 6.0].map(|x| (DVec3::new(x, y, z), r, 1.0)))
    };
    let wisps = vec![line(0.0, 0.0, 1.0), line(0.0, -8.0, 3.0)];
    let iso = 1.0 - (0.5f64 / 1.5).sqrt();
    let eps_per_t = 0.015; // eps = 0.3 at the front wisp, 20 away
    let m = march_default();
    let shoot = |y: f64| {
        let ray = Ray {
            origin: DVec3::new(0.5, y, 20.0),
            dir: -DVec3::Z,
            t0: 0.0,
            t1: 40.0,
        };
        field::march(&wisps, 0.5, &m, &ray, eps_per_t).0
    };
    let back = 20.0 + 8.0 - 3.0 * iso; // the back wisp's front, roughly (|y| < 1)
    for (y, want) in [
        (0.0, "front"),
        (iso - 0.05, "front"),
        (iso + 0.1, "outline"),
        (iso + 0.6, "back"),
    ] {
        let hit = shoot(y);
        println!("y = {y:.3}: {hit:?}");
        match (want, hit) {
            ("front", Hit::Surface { t, .. }) => {
                // Within half the last bracket: eps/4 / 2^(refine + 1) ≈ 1.5e-4.
                assert!(
                    (t - (20.0 - (iso * iso - y * y).sqrt())).abs() < 1.5e-4,
                    "y {y}: t {t}"
                )
            }
            ("outline", Hit::Outline { t }) => assert!(t > 18.5 && t < 20.0, "y {y}: t {t}"),
            ("back", Hit::Surface { t, .. }) => assert!(t > back - 0.5, "y {y}: t {t}"),
            _ => panic!("y {y}: wanted {want}, got {hit:?}"),
        }
    }
}

#[test]
fn reference_image_has_surface_outline_and_background() {
    let nodes: Vec<_> = (0..5)
        .map(|i| {
            let a = i as f64 * 0.4;
            (
                DVec3::new(2.0 * a.sin(), 3.0 - 1.5 * i as f64, 0.0),
                1.0 - 0.15 * i as f64,
                1.5,
            )
        })
        .collect();
    let wisps = vec![curve::segments(&nodes)];
    let (w, h) = (48u32, 40u32);
    let eye = DVec3::new(0.0, 0.0, 14.0);
    let fov = 0.8f64;
    let proj: DMat4 =
        glam::dcamera::rh::proj::directx::perspective(fov, w as f64 / h as f64, 0.5, 50.0);
    let view: DMat4 = glam::dcamera::rh::view::look_at_mat4(eye, DVec3::ZERO, DVec3::Y);
    let focal_px = 0.5 * h as f64 / (0.5 * fov).tan();
    let toon = Toon {
        outline_width: 2.0,
        ..Toon::default()
    };
    let bg = DVec3::new(0.5, 0.5, 0.5);
    let (c, z) = field::render_reference(
        &wisps,
        0.5,
        &march_default(),
        &toon,
        DVec3::new(0.0, 0.6, 0.8),
        DMat3::IDENTITY,
        eye,
        (proj * view).inverse(),
        focal_px,
        (w, h),
        bg,
    );
    let outline = field::linear(toon.outline);
    let (mut n_bg, mut n_out, mut n_surf) = (0, 0, 0);
    for (ci, zi) in c.iter().zip(&z) {
        if *ci == bg {
            assert!(zi.is_nan());
            n_bg += 1;
        } else {
            assert!((0.0..=1.0).contains(zi), "depth {zi}");
            if *ci == outline {
                n_out += 1;
            } else {
                n_surf += 1;
            }
        }
    }
    println!("{w}x{h}: {n_surf} surface, {n_out} outline, {n_bg} background pixels");
    assert!(n_surf > 50 && n_out > 20 && n_bg > 500);
    // The centre column crosses the wisp: background, outline, surface, outline, background.
    let row = (h / 2) as usize;
    let kinds: Vec<u8> = (0..w as usize)
        .map(|x| {
            let ci = c[row * w as usize + x];
            if ci == bg {
                0
            } else if ci == outline {
                1
            } else {
                2
            }
        })
        .collect();
    let mut runs = kinds.clone();
    runs.dedup();
    assert_eq!(runs, vec![0, 1, 2, 1, 0], "row {row}: {kinds:?}");
}

/// A tangle of curved, tapering wisps crossing one another (the crown's case: many wisps
/// add density at a point).
fn tangle(rng: &mut Rng, wisps: usize) -> Vec<Vec<Segment>> {
    (0..wisps)
        .map(|_| {
            let mut sk = skeleton(rng, 0.6);
            for n in &mut sk {
                n.0 *= 0.25;
                n.2 = rng.range(0.3, 0.9);
            }
            curve::segments(&sk)
        })
        .collect()
}

/// Every point inside the surface lies in the hit capsule of some segment (the march
/// samples nowhere else): on random points of crowded tangles where up to a dozen wisps
/// blend, none inside is outside every hit capsule. Without the wisp count K (each
/// segment's capsule as if it were alone) blended points fall outside.
#[test]
fn hit_capsules_hold_every_inside_point() {
    let mut rng = Rng::new(23, 1);
    let (mut inside, mut blended) = (0, 0);
    for _ in 0..20 {
        let wisps = tangle(&mut rng, 12);
        let threshold = 0.5;
        let caps = curve::capsules(&wisps, threshold);
        for _ in 0..4000 {
            let p = rand_vec(&mut rng, 3.0);
            let f = field::field(&wisps, threshold, p, Distance::Newton);
            if f.rho < 0.0 {
                continue;
            }
            inside += 1;
            let alone = wisps
                .iter()
                .filter(|w| field::wisp_density(w, p, Distance::Newton).rho > 0.0)
                .count();
            blended += usize::from(alone > 1);
            let held = caps
                .iter()
                .flatten()
                .any(|c| c.hit >= 0.0 && curve::chord_distance(p, c.a, c.b) <= c.hit);
            assert!(held, "inside point {p} is in no hit capsule");
        }
    }
    assert!(
        inside > 2000 && blended > 500,
        "{inside} inside, {blended} blended"
    );
}

/// No point within the clear step of a sample is inside the surface: random points of the
/// tangles, and around each many points at up to the step (on the sphere and within it).
#[test]
fn clear_step_never_reaches_the_surface() {
    let mut rng = Rng::new(24, 1);
    let (mut moved, mut long) = (0, 0);
    for _ in 0..10 {
        let wisps = tangle(&mut rng, 8);
        let threshold = 0.5;
        let pieces: Vec<Vec<_>> = wisps
            .iter()
            .map(|w| w.iter().map(curve::pieces).collect())
            .collect();
        let segs: Vec<field::Pieced> = wisps
            .iter()
            .enumerate()
            .flat_map(|(wi, w)| {
                let pieces = &pieces;
                w.iter().enumerate().map(move |(si, s)| field::Pieced {
                    wisp: wi,
                    index: si,
                    seg: s,
                    pts: &pieces[wi][si].0,
                    dev: &pieces[wi][si].1,
                    outline: [1.0, 0.0, 0.0, 0.0],
                })
            })
            .collect();
        for _ in 0..400 {
            let p = rand_vec(&mut rng, 4.0);
            let s = field::clear_step(&segs, threshold, p);
            if !s.is_finite() || s <= 0.0 {
                continue;
            }
            moved += 1;
            long += usize::from(s > 0.2);
            for k in 0..60 {
                let r = if k < 30 { s } else { s * rng.range(0.0, 1.0) };
                let q = p + rand_unit(&mut rng) * r * 0.999_999;
                let f = field::field(&wisps, threshold, q, Distance::Newton);
                assert!(
                    f.rho < 0.0,
                    "clear step {s} at {p}: {q} is inside (f = {})",
                    f.rho
                );
            }
        }
    }
    assert!(moved > 1000 && long > 100, "{moved} steps, {long} over 0.2");
}

/// `curve::segment_distance` against the least distance over 400 × 400 samples of the two
/// segments (parallel, crossing, skew, touching end to end and degenerate pairs included).
#[test]
fn segment_distance_matches_sampling() {
    let mut rng = Rng::new(31, 0);
    let mut pairs: Vec<[DVec3; 4]> = (0..200)
        .map(|_| std::array::from_fn(|_| rand_vec(&mut rng, 3.0)))
        .collect();
    let (a, b) = (DVec3::ZERO, DVec3::X);
    pairs.push([a, b, a + DVec3::Y, b + DVec3::Y]); // parallel, 1 apart
    pairs.push([a, b, DVec3::new(0.5, -1.0, 0.0), DVec3::new(0.5, 1.0, 0.0)]); // crossing
    pairs.push([a, b, b, b + DVec3::Y]); // end to end
    pairs.push([a, a, b, b]); // two points
    pairs.push([a, b, DVec3::new(3.0, 0.0, 0.0), DVec3::new(4.0, 0.0, 0.0)]); // collinear, apart
    let n = 400;
    let mut worst: f64 = 0.0;
    for [p0, p1, q0, q1] in pairs {
        let d = curve::segment_distance(p0, p1, q0, q1);
        let mut best = f64::INFINITY;
        for i in 0..=n {
            let p = p0.lerp(p1, i as f64 / n as f64);
            for j in 0..=n {
                best = best.min((p - q0.lerp(q1, j as f64 / n as f64)).length());
            }
        }
        // Sampling finds a distance no smaller than the true one, within the spacing.
        let h = ((p1 - p0).length() + (q1 - q0).length()) / n as f64;
        assert!(d <= best + 1e-12, "{d} above the sampled {best}");
        worst = worst.max(best - d);
        assert!(
            best - d <= h,
            "{d} below the sampled {best} by more than {h}"
        );
    }
    println!("largest gap to sampling {worst:.2e}");
}

/// `field::max_overlap` bounds the most influence capsules holding one point (the
/// candidates touching one ray at once; `ray_slots` pads it): random tangles, the depth
/// counted at 20,000 points each, never above the bound; and 30 capsules of radius 0.5
/// crossing near one point (each within 0.45 of it), where the bound is the depth itself.
#[test]
fn ray_slots_hold_the_deepest_overlap() {
    let mut rng = Rng::new(41, 0);
    let star: Vec<curve::Capsule> = (0..30)
        .map(|k| {
            let a = std::f64::consts::PI * k as f64 / 30.0;
            let dir = DVec3::new(a.cos(), a.sin(), 0.3 * (3.0 * a).sin()).normalize();
            let off = DVec3::new(0.0, 0.0, 0.45 * if k % 2 == 0 { 1.0 } else { -1.0 });
            curve::Capsule {
                a: off - 4.0 * dir,
                b: off + 4.0 * dir,
                influence: 0.5,
                hit: 0.4,
                wisps_near: 1,
            }
        })
        .collect();
    let bound = field::max_overlap(std::slice::from_ref(&star));
    let at_centre = star
        .iter()
        .filter(|c| curve::chord_distance(DVec3::ZERO, c.a, c.b) <= c.influence)
        .count();
    assert_eq!(at_centre, 30);
    assert!(bound >= 30, "30 capsules hold the centre, bound {bound}");
    for wisps in [4, 16, 40] {
        let segs = tangle(&mut rng, wisps);
        let caps = curve::capsules(&segs, 0.5);
        let slots = field::max_overlap(&caps);
        let flat: Vec<&curve::Capsule> = caps.iter().flatten().collect();
        let mut deepest = 0;
        for _ in 0..20_000 {
            let p = rand_vec(&mut rng, 3.0);
            let depth = flat
                .iter()
                .filter(|c| curve::chord_distance(p, c.a, c.b) <= c.influence)
                .count();
            deepest = deepest.max(depth);
        }
        println!(
            "{wisps} wisps, {} segments: deepest overlap {deepest}, bound {slots}",
            flat.len()
        );
        assert!(
            deepest <= slots,
            "{deepest} capsules hold one point, bound {slots}"
        );
    }
}
