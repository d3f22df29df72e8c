//! Numerical tests of the cantilever bending against the exact heavy cantilever (the
//! elastica, solved here by `kami::systems::anjyo::elastica`, itself checked against an independent
//! shooting solution and the linear limit), and invariants of real grooms.

use crate::common;
use glam::DVec3;
use kami::scene::Ellipsoid;
use kami::systems::anjyo::cantilever::{self, Beam};
use kami::systems::anjyo::cantilever_gpu;
use kami::systems::anjyo::elastica;
use kami::systems::anjyo::groom::prepare;

/// A unit-length beam clamped along +x under a uniform downward load G (EI = 1).
fn tip_drop(g: f64, k: u32, converged: bool) -> (f64, Vec<DVec3>) {
    let load = move |_: DVec3, _: DVec3| DVec3::new(0.0, -g, 0.0);
    let beam = Beam {
        root: DVec3::ZERO,
        dir: DVec3::X,
        seg_len: 1.0 / k as f64,
        segments: k,
        rigidity: 1.0,
        load: &load,
        hull: None,
    };
    let nodes = if converged {
        let (n, info) = cantilever::bend_converged(&beam, 50_000, 1e-12);
        assert!(info.converged, "G={g} k={k}: {info:?}");
        n
    } else {
        cantilever::bend_paper(&beam)
    };
    (-nodes.last().unwrap().y, nodes)
}

/// Euler–Bernoulli deflection of a uniformly loaded cantilever, per unit G, at x (L = 1).
fn euler_bernoulli(x: f64) -> f64 {
    (x.powi(4) - 4.0 * x.powi(3) + 6.0 * x * x) / 24.0
}

#[test]
fn elastica_tends_to_the_linear_tip_drop() {
    for g in [1e-4, 1e-3] {
        let r = elastica::tip_drop(g) / (g / 8.0);
        assert!((r - 1.0).abs() < 1e-4, "G={g}: ratio to G/8 is {r}");
    }
    // Large loads: well below the linear value, and below the length.
    let d = elastica::tip_drop(100.0);
    assert!(d < 1.0 && d > 0.9, "G=100 drop {d}");
}

#[test]
fn elastica_agrees_with_shooting() {
    for g in [0.1, 1.0, 10.0, 100.0] {
        let fd = elastica::Elastica::solve_grid(g, 2000);
        let tip = *fd.theta.last().unwrap();
        let (_, drop) = elastica::shoot_tip_angle(
            g,
            (
                (tip - 0.02).max(0.0),
                (tip + 0.02).min(std::f64::consts::FRAC_PI_2),
            ),
            20_000,
        )
        .unwrap_or_else(|| panic!("G={g}: no shooting root near {tip}"));
        let exact = elastica::tip_drop(g);
        assert!(
            (drop - exact).abs() < 1e-7,
            "G={g}: shooting {drop} FD {exact}"
        );
    }
}

/// The converged mode meets the bar: 1 % tip error for G up to 100 with at most 80
/// segments.
#[test]
fn converged_mode_reaches_one_percent_with_80_segments() {
    for g in [0.1, 1.0, 10.0, 100.0] {
        let exact = elastica::tip_drop(g);
        let (drop, _) = tip_drop(g, 80, true);
        let err = (drop - exact).abs() / exact;
        assert!(err < 0.01, "G={g}: error {err:.2e}");
    }
}

/// Second order in the segment length: halving d quarters the error.
#[test]
fn converged_mode_is_second_order() {
    for g in [1.0, 10.0, 100.0] {
        let exact = elastica::tip_drop(g);
        let e: Vec<f64> = [20, 40, 80]
            .iter()
            .map(|&k| (tip_drop(g, k, true).0 - exact).abs())
            .collect();
        for w in e.windows(2) {
            let order = (w[0] / w[1]).log2();
            assert!(
                (1.8..2.2).contains(&order),
                "G={g}: observed order {order:.2} from {e:?}"
            );
        }
    }
}

/// Small loads: the converged shape approaches the Euler–Bernoulli curve, closer as k grows.
#[test]
fn converged_small_load_approaches_euler_bernoulli_shape() {
    let g = 1e-3;
    let mut last = f64::INFINITY;
    for k in [10, 20, 40, 80] {
        let (tip, nodes) = tip_drop(g, k, true);
        let worst = nodes
            .iter()
            .map(|p| (-p.y - g * euler_bernoulli(p.x)).abs())
            .fold(0.0, f64::max);
        assert!(
            worst < last,
            "k={k}: deviation {worst:.3e} did not shrink from {last:.3e}"
        );
        last = worst;
        if k == 80 {
            assert!(
                worst < 1e-3 * tip,
                "k=80: shape deviation {worst:.3e} of tip drop {tip:.3e}"
            );
        }
    }
}

/// The paper's scheme turns each segment by the deflection of its end (half the end slope),
/// so in the limit it is an Euler–Bernoulli beam of rigidity 2EI: the small-load tip drop
/// tends to G/16, not G/8, and the shape to half the Euler–Bernoulli curve (first order in
/// the segment length).
#[test]
fn paper_mode_tends_to_rigidity_2ei() {
    let g = 1e-3;
    let mut last = f64::INFINITY;
    for k in [10, 20, 40, 80, 160, 320, 640] {
        let (tip, nodes) = tip_drop(g, k, false);
        let err = (tip / (g / 16.0) - 1.0).abs();
        // First order: the moment is taken at each segment's start.
        assert!(
            err < 0.6 * last,
            "k={k}: error {err:.3e} did not halve from {last:.3e}"
        );
        last = err;
        if k == 640 {
            assert!(err < 0.005, "k=640: tip {tip:.4e} vs G/16 {:.4e}", g / 16.0);
            let worst = nodes
                .iter()
                .map(|p| (-p.y - 0.5 * g * euler_bernoulli(p.x)).abs())
                .fold(0.0, f64::max);
            assert!(worst < 0.01 * tip, "shape deviation {worst:.3e}");
        }
    }
    // The moment per segment is the paper's closed form |g| d (k-i+1)^2 / 2: one segment
    // under load g turns by atan(y/d) with y = M d^2 / 2EI = g d^3 / 4 (G = g, d = 1).
    let (tip1, _) = tip_drop(0.4, 1, false);
    let expect = (0.4f64 / 4.0).atan().sin();
    assert!(
        (tip1 - expect).abs() < 1e-12,
        "one segment: {tip1} vs {expect}"
    );
}

fn check_groom_invariants(name: &str, scene: &kami::Scene) {
    let input = prepare(scene).unwrap();
    let out = cantilever::bend_all(&input);
    let offsets = input.vertex_offsets();
    for (i, r) in input.roots.iter().enumerate() {
        let nodes = &out.nodes[offsets[i] as usize..offsets[i + 1] as usize];
        for (j, p) in nodes.iter().enumerate() {
            assert!(p.is_finite(), "{name}: strand {i} node {j} not finite");
            let e = input.head.eval(*p);
            assert!(
                e >= -1e-9,
                "{name}: strand {i} node {j} inside the head (E = {e:.3e})"
            );
        }
        for w in nodes.windows(2) {
            let l = (w[1] - w[0]).length();
            assert!(
                (l - r.seg_len).abs() <= 1e-10 * r.seg_len,
                "{name}: strand {i} segment {l} vs d {}",
                r.seg_len
            );
        }
    }
}

#[test]
fn shipped_grooms_stay_outside_the_head_with_exact_lengths() {
    for (name, scene) in common::grown_scenes() {
        check_groom_invariants(&name, &scene);
    }
}

/// The same invariants on the GPU output (f32: E >= -1e-5, lengths within 1e-5 relative;
/// the kernel renormalises after its sin/cos, which GPUs may compute to only 2^-11).
#[test]
fn gpu_grooms_stay_outside_the_head_with_exact_lengths() {
    let gpu = common::gpu();
    for (name, scene) in common::grown_scenes() {
        let input = prepare(&scene).unwrap();
        let hair =
            cantilever_gpu::groom_gpu(gpu, &common::groom_world(gpu, &input), &input).unwrap();
        let v = hair.read_vertices(gpu).unwrap();
        let offsets = input.vertex_offsets();
        for (i, r) in input.roots.iter().enumerate() {
            let nodes: Vec<DVec3> = (offsets[i]..offsets[i + 1])
                .map(|j| {
                    DVec3::new(
                        v[j as usize][0] as f64,
                        v[j as usize][1] as f64,
                        v[j as usize][2] as f64,
                    )
                })
                .collect();
            for p in &nodes {
                assert!(
                    input.head.eval(*p) >= -1e-5,
                    "{name}: strand {i} inside (E = {:.2e})",
                    input.head.eval(*p)
                );
            }
            for w in nodes.windows(2) {
                let l = (w[1] - w[0]).length();
                assert!(
                    (l / r.seg_len - 1.0).abs() < 1e-5,
                    "{name}: strand {i} segment {l} vs d {}",
                    r.seg_len
                );
            }
        }
    }
}

/// Degenerate collision cases: a hair aimed straight into the head (the plane of p(i-2),
/// p(i-1), p(i) degenerates), pores at the poles with the load along the hair, and a load
/// straight against the hair.
#[test]
fn collision_and_load_degenerate_cases() {
    let head = Ellipsoid::new([0.0; 3], [9.6, 11.5, 7.8]);
    let cases: Vec<(DVec3, DVec3, DVec3)> = vec![
        // (root, direction, load per unit length)
        (
            head.point(1.2, 0.3),
            -head.normal(head.point(1.2, 0.3)),
            DVec3::new(0.0, -1.0, 0.0),
        ),
        (head.point(0.0, 0.0), DVec3::Y, DVec3::new(0.0, -1.0, 0.0)),
        (
            head.point(std::f64::consts::PI, 0.0),
            -DVec3::Y,
            DVec3::new(0.0, -1.0, 0.0),
        ),
        (head.point(0.0, 0.0), DVec3::Y, DVec3::ZERO),
        (
            head.point(1.5, 1.0),
            head.normal(head.point(1.5, 1.0)),
            -head.normal(head.point(1.5, 1.0)) * 50.0,
        ),
    ];
    for (n, (root, dir, w)) in cases.into_iter().enumerate() {
        let load = move |_: DVec3, _: DVec3| w;
        for converged in [false, true] {
            let beam = Beam {
                root,
                dir,
                seg_len: 1.0,
                segments: 20,
                rigidity: 50.0,
                load: &load,
                hull: Some(&kami::scene::hull::HeadHull::Ellipsoid(head)),
            };
            let nodes = if converged {
                cantilever::bend_converged(&beam, 500, 1e-6).0
            } else {
                cantilever::bend_paper(&beam)
            };
            for (j, p) in nodes.iter().enumerate() {
                assert!(p.is_finite(), "case {n} node {j} not finite");
                assert!(
                    head.eval(*p) >= -1e-9,
                    "case {n} node {j} inside: {:.2e}",
                    head.eval(*p)
                );
            }
            for wnd in nodes.windows(2) {
                assert!(
                    ((wnd[1] - wnd[0]).length() - 1.0).abs() < 1e-12,
                    "case {n}: length"
                );
            }
        }
    }
    // A load along a straight hair bends nothing (Anjyo: hair at the crown "is not deformed
    // much, since the strands are essentially parallel to the gravity vector").
    let load = |_: DVec3, _: DVec3| DVec3::new(0.0, -1.0, 0.0);
    let beam = Beam {
        root: DVec3::ZERO,
        dir: DVec3::Y,
        seg_len: 1.0,
        segments: 10,
        rigidity: 1.0,
        load: &load,
        hull: None,
    };
    let nodes = cantilever::bend_paper(&beam);
    assert!((nodes[10] - DVec3::new(0.0, 10.0, 0.0)).length() < 1e-12);
}

/// The most extreme values validation allows give finite hair, never NaN.
#[test]
fn extreme_valid_parameters_stay_finite() {
    let head = Ellipsoid::new([0.0; 3], [9.6, 11.5, 7.8]);
    for (rigidity, w) in [(1e-9, 1e9), (1e15, 1e-9), (1e-9, 0.0)] {
        let load = move |_: DVec3, _: DVec3| DVec3::new(w, -w, 0.3 * w);
        let beam = Beam {
            root: head.point(0.8, 2.0),
            dir: head.normal(head.point(0.8, 2.0)),
            seg_len: 0.5,
            segments: 256,
            rigidity,
            load: &load,
            hull: Some(&kami::scene::hull::HeadHull::Ellipsoid(head)),
        };
        for nodes in [
            cantilever::bend_paper(&beam),
            cantilever::bend_converged(&beam, 50, 1e-6).0,
        ] {
            assert!(nodes.iter().all(|p| p.is_finite()), "EI {rigidity} w {w}");
            assert!(
                nodes.iter().all(|p| head.eval(*p) >= -1e-9),
                "EI {rigidity} w {w}: inside"
            );
        }
    }
}

/// Pores are area-uniform on the ellipsoid patch and respect the hairline.
#[test]
fn pores_follow_region_and_hairline() {
    let scene = common::scene("bob");
    let input = prepare(&scene).unwrap();
    for (gi, g) in scene.groups().iter().enumerate() {
        let grp = &input.groups[gi];
        for r in
            &input.roots[grp.first_strand as usize..(grp.first_strand + grp.strand_count) as usize]
        {
            assert!(input.head.eval(r.pos).abs() < 1e-9, "pore off the surface");
            let (t, p) = input.head.ellipsoid().polar(r.pos);
            let (t, p) = (t.to_degrees(), p.to_degrees());
            assert!(
                t >= g.roots.theta.0 - 1e-6 && t <= g.roots.theta.1 + 1e-6,
                "theta {t} outside {:?}",
                g.roots.theta
            );
            if let Some(line) = g.roots.hairline_theta(p) {
                assert!(
                    t <= line + 1e-6,
                    "pore below the hairline: theta {t} > {line} at phi {p}"
                );
            }
        }
    }
    // Same seed, same groom.
    let again = prepare(&scene).unwrap();
    assert_eq!(input.roots, again.roots);
}
