//! Sakai's mass springs (section 7): the eq 24 rest-length solve, the integrators, the head
//! pose, the collision, bundles, and the f32 GPU kernel against the f64 reference.

use crate::common;

use glam::{DVec3, Vec3};
use kami::bench::wisps::springs as study;
use kami::forces::Forces;
use kami::scene::{Ellipsoid, Head, HeadKey, Interp};
use kami::systems::wisps::block::{Bundle, Integrator, Node, Skeleton, Springs, Wisps};
use kami::systems::wisps::springs::{self, Lattice, Motion, Point, Spring, State};
use kami::systems::wisps::springs_gpu;

fn wisps(skeletons: Vec<Skeleton>, springs: Springs, bundles: Vec<Bundle>) -> Wisps {
    Wisps {
        skeletons,
        threshold: 0.5,
        toon: Default::default(),
        march: Default::default(),
        springs: Some(springs),
        bundles,
        draw: Default::default(),
        mesh: Default::default(),
    }
}

fn skeleton(name: &str, p: &[DVec3], r: f64) -> Skeleton {
    Skeleton {
        name: name.into(),
        nodes: p
            .iter()
            .map(|p| Node {
                p: p.to_array(),
                r,
                w: 1.0,
            })
            .collect(),
        outline: 1.0,
    }
}

/// Standard gravity in cm/s², the scene's shared gravity of these cases (the springs keep
/// none of their own).
const G: DVec3 = DVec3::new(0.0, -980.0, 0.0);

fn still(head: &Head) -> Forces {
    Forces {
        gravity: G,
        wind: Vec::new(),
        head_motion: Vec::new(),
        center: DVec3::from(head.center),
        eff: None,
    }
}

/// A head turning about y by `deg` degrees and back, linearly between keys `every` frames
/// apart.
fn shake(head: &Head, deg: f64, every: f64, times: u32) -> Forces {
    let mut keys = vec![HeadKey {
        frame: 0.0,
        rotate: [0.0; 3],
        translate: [0.0; 3],
        interp: Interp::Linear,
    }];
    for i in 1..=times {
        let sign = if i % 2 == 1 { 1.0 } else { -1.0 };
        keys.push(HeadKey {
            frame: i as f64 * every,
            rotate: [0.0, sign * deg, 0.0],
            translate: [0.0; 3],
            interp: Interp::Linear,
        });
    }
    keys.push(HeadKey {
        frame: (times + 1) as f64 * every,
        rotate: [0.0; 3],
        translate: [0.0; 3],
        interp: Interp::Linear,
    });
    Forces {
        head_motion: keys,
        ..still(head)
    }
}

/// A styled wisp: leaves the scalp along its normal at polar angle `theta` on the +x side
/// and curves sideways and down (a bang sweeping out), `n` nodes over about `len`.
fn styled(head: &Head, theta: f64, n: usize, len: f64) -> Vec<DVec3> {
    let e = Ellipsoid::new(head.center, head.radii);
    let root = e.point(theta, 0.0);
    let out = e.normal(root);
    (0..n)
        .map(|i| {
            let s = i as f64 / (n - 1) as f64;
            root + out * (len * s) + DVec3::new(0.3, -1.0, 0.2) * (0.6 * len * s * s)
        })
        .collect()
}

fn springs_with(k: f64, hold: bool) -> Springs {
    Springs {
        stiffness: k,
        hold_shape: hold,
        ..Default::default()
    }
}

/// Largest distance of any primary from its drawn place.
fn drift(l: &Lattice, st: &State) -> f64 {
    (0..l.primaries() as usize)
        .map(|i| (st.x[i] - l.points[i].rest).length())
        .fold(0.0, f64::max)
}

/// Length of skeleton 0's chain.
fn chain_length(p: &[DVec3]) -> f64 {
    p.windows(2).map(|w| (w[1] - w[0]).length()).sum()
}

/// Eq 24 against its closed form: a vertical chain of primaries hanging from a pinned root
/// carries the weight below each spring, so l_natural = l - T / k exactly.
#[test]
fn eq24_hanging_chain_matches_closed_form() {
    let (n, l, m, k) = (7usize, 2.0, 1.5, 1e4);
    let g = DVec3::new(0.0, -980.0, 0.0);
    let points: Vec<Point> = (0..n)
        .map(|i| Point {
            rest: DVec3::new(0.0, 30.0 - l * i as f64, 0.0),
            mass: m,
            pinned: i == 0,
            skeleton: 0,
            node: i as u32,
        })
        .collect();
    let springs: Vec<Spring> = (0..n - 1)
        .map(|i| Spring {
            a: i as u32,
            b: i as u32 + 1,
            k,
            rest: l,
        })
        .collect();
    let mut lat = Lattice::new(points, springs, vec![0, n as u32], vec!["chain".into()]);
    let fit = lat.hold_shape(g, k).unwrap();
    let mut worst: f64 = 0.0;
    for (j, s) in lat.springs.iter().enumerate() {
        let tension = (n - 1 - j) as f64 * m * 980.0;
        let want = l - tension / k;
        worst = worst.max((s.rest - want).abs() / l);
    }
    eprintln!(
        "chain: worst |l_nat - (l - T/k)| / l = {worst:.2e}, residual {:.2e}",
        fit.residual
    );
    assert!(
        worst < 1e-12,
        "natural lengths off the closed form by {worst:e} of l"
    );
    assert!(fit.residual < 1e-12);
    // And the chain is in equilibrium there.
    let x: Vec<DVec3> = lat.points.iter().map(|p| p.rest).collect();
    let f = lat.static_forces(&x, g);
    let worst_f = f.iter().map(|v| v.length()).fold(0.0, f64::max) / (m * 980.0);
    assert!(worst_f < 1e-12, "residual force {worst_f:e} of a weight");
}

/// The full lattice of a styled wisp is in equilibrium in its drawn shape after eq 24; a
/// shape that cannot hold is refused with the wisp's name and the stiffness to reach, and
/// that stiffness then holds.
#[test]
fn eq24_full_lattice_balances_or_refuses() {
    let head = Head::default();
    let p = styled(&head, 0.9, 8, 10.0);
    let sp = springs_with(400.0, true);
    let w = wisps(vec![skeleton("bang", &p, 1.0)], sp.clone(), vec![]);
    let err = Lattice::build(&w, &sp, &head, &still(&head))
        .unwrap_err()
        .to_string();
    eprintln!("refusal: {err}");
    assert!(
        err.contains("wisp 0 (`bang`)") && err.contains("stiffness"),
        "{err}"
    );
    let above: f64 = err
        .split("above ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .and_then(|t| t.parse().ok())
        .expect("the refusal names a stiffness");
    let sp = springs_with(above * 1.01, true);
    let w = wisps(vec![skeleton("bang", &p, 1.0)], sp.clone(), vec![]);
    let lat = Lattice::build(&w, &sp, &head, &still(&head)).unwrap();
    let fit = lat.fit.unwrap();
    let x: Vec<DVec3> = lat.points.iter().map(|p| p.rest).collect();
    let f = lat.static_forces(&x, G);
    let weight = sp.mass * 980.0;
    let worst = f.iter().map(|v| v.length()).fold(0.0, f64::max) / weight;
    eprintln!(
        "at k = {:.4e}: {} points, {} springs, residual {:.2e} (solver {:.2e}), natural/drawn in [{:.4}, {:.3}]",
        above * 1.01,
        lat.points.len(),
        lat.springs.len(),
        worst,
        fit.residual,
        fit.min_ratio,
        fit.max_ratio
    );
    assert!(worst < 1e-9, "net force {worst:e} of a primary's weight");
    assert!(fit.min_ratio > 0.0);
    // A bundle makes one component of two wisps; the joined lattice balances too.
    let q: Vec<DVec3> = p.iter().map(|p| *p + DVec3::new(0.0, 0.0, 1.5)).collect();
    for bundled in [true, false] {
        let sp = springs_with(2e4, true);
        let bundles = if bundled {
            vec![Bundle {
                wisps: vec![0, 1],
                release_from: 4,
            }]
        } else {
            vec![]
        };
        let w = wisps(
            vec![skeleton("a", &p, 1.0), skeleton("b", &q, 1.0)],
            sp.clone(),
            bundles,
        );
        let t = std::time::Instant::now();
        let lat = Lattice::build(&w, &sp, &head, &still(&head)).unwrap();
        let took = t.elapsed();
        let fit = lat.fit.unwrap();
        let x: Vec<DVec3> = lat.points.iter().map(|p| p.rest).collect();
        let f = lat.static_forces(&x, G);
        let worst = f.iter().map(|v| v.length()).fold(0.0, f64::max) / weight;
        eprintln!(
            "bundled {bundled}: {} components, {} springs, net force {worst:.2e} of a weight, {} refinement passes, built in {took:?}",
            fit.components,
            lat.springs.len(),
            fit.refinements
        );
        assert_eq!(fit.components, if bundled { 1 } else { 2 });
        assert!(worst < 1e-9);
    }
}

/// With hold_shape a curved, sideways-reaching wisp stays drawn for 10 s (and comes back to
/// it after a head shake); without it, it sags.
#[test]
fn held_shape_holds_and_unheld_sags() {
    let head = Head::default();
    let p = styled(&head, 0.9, 8, 10.0);
    let len = chain_length(&p);
    let mut tip_drop = [0.0; 2];
    for hold in [true, false] {
        let sp = Springs {
            substeps: 48,
            ..springs_with(2e4, hold)
        };
        let w = wisps(vec![skeleton("bang", &p, 1.0)], sp.clone(), vec![]);
        let lat = Lattice::build(&w, &sp, &head, &still(&head)).unwrap();
        let m = Motion::new(&sp, &head).unwrap();
        let mut st = State::rest(&lat);
        springs::run_frames(&lat, &m, &still(&head), &mut st, 0, 300);
        let d = drift(&lat, &st);
        let tip = lat.primaries() as usize - 1;
        tip_drop[hold as usize] = lat.points[tip].rest.y - st.x[tip].y;
        eprintln!(
            "hold {hold}: worst node drift after 10 s {d:.3e} (wisp length {len:.2}), tip drop {:.3}",
            tip_drop[hold as usize]
        );
        if hold {
            assert!(d < 1e-9 * len, "held wisp drifted {d:e}");
            // Shaken for 1 s then left still for 9 s: back to the drawn shape.
            let mut st = State::rest(&lat);
            let f = shake(&head, 20.0, 6.0, 4);
            springs::run_frames(&lat, &m, &f, &mut st, 0, 30);
            let moved = drift(&lat, &st);
            springs::run_frames(&lat, &m, &f, &mut st, 30, 270);
            let back = drift(&lat, &st);
            eprintln!("hold: shaken {moved:.3}, 9 s later {back:.2e}");
            assert!(moved > 1.0, "the shake did not move the wisp ({moved})");
            assert!(
                back < 0.01,
                "the wisp did not return to its drawn shape ({back})"
            );
        }
    }
    assert!(
        tip_drop[0] > 3.0,
        "without hold_shape the tip drops only {}",
        tip_drop[0]
    );
}

fn fit_slope(rows: &[study::Row]) -> f64 {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.stable)
        .map(|r| (r.dt.ln(), r.error.ln()))
        .collect();
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    sxy / sxx
}

/// Observed orders on a smooth case (a wisp released into gravity, head still, no contact):
/// RK4 about 4, semi-implicit Euler about 1.
#[test]
fn integrator_orders() {
    let head = Head::default();
    let p = styled(&head, 0.9, 8, 10.0);
    let sp = Springs {
        collide: false,
        ..springs_with(2e4, false)
    };
    let w = wisps(vec![skeleton("bang", &p, 1.0)], sp, vec![]);
    let rows = study::work_precision(&w, &head, &still(&head), 0.5, &[32, 64, 128, 256]).unwrap();
    for r in &rows {
        eprintln!(
            "{:?} dt {:.3e} error {:.3e} order {:?} stable {} {:.0} ns/step, largest stable dt {:.3e} (predicted {:.3e})",
            r.integrator, r.dt, r.error, r.order, r.stable, r.ns_per_step, r.largest_stable_dt, r.predicted_stable_dt
        );
    }
    let of = |i: Integrator| {
        let r: Vec<_> = rows.iter().copied().filter(|r| r.integrator == i).collect();
        assert!(r.iter().all(|r| r.stable), "{i:?}: unstable rows in {r:?}");
        fit_slope(&r)
    };
    let (rk4, euler) = (of(Integrator::Rk4), of(Integrator::SemiImplicitEuler));
    eprintln!("fitted orders: RK4 {rk4:.3}, semi-implicit Euler {euler:.3}");
    assert!((3.7..=4.3).contains(&rk4), "RK4 order {rk4}");
    assert!(
        (0.9..=1.1).contains(&euler),
        "semi-implicit Euler order {euler}"
    );
}

fn turning(head: &Head) -> Forces {
    let key = |frame: f64, rotate: [f64; 3], translate: [f64; 3]| HeadKey {
        frame,
        rotate,
        translate,
        interp: Interp::Linear,
    };
    Forces {
        head_motion: vec![
            key(0.0, [0.0; 3], [0.0; 3]),
            key(10.0, [10.0, 35.0, 5.0], [1.0, 0.5, 0.0]),
            key(20.0, [0.0, -10.0, 0.0], [0.0; 3]),
        ],
        ..still(head)
    }
}

/// A keyed head turn: the root rings follow the head exactly, and the wisp lags behind it
/// (the head-local tip moves), on both integrators.
#[test]
fn pinned_points_follow_the_head() {
    let head = Head::default();
    let p = styled(&head, 0.9, 8, 10.0);
    let f = turning(&head);
    for integrator in [Integrator::Rk4, Integrator::SemiImplicitEuler] {
        let sp = Springs {
            substeps: 48,
            integrator,
            ..springs_with(2e4, true)
        };
        let w = wisps(vec![skeleton("bang", &p, 1.0)], sp.clone(), vec![]);
        let lat = Lattice::build(&w, &sp, &head, &still(&head)).unwrap();
        let m = Motion::new(&sp, &head).unwrap();
        let mut st = State::rest(&lat);
        let (mut pin_err, mut lag): (f64, f64) = (0.0, 0.0);
        let tip = lat.primaries() as usize - 1;
        for frame in 0..30u64 {
            springs::run_frames(&lat, &m, &f, &mut st, frame, 1);
            let h = f.head_at((frame + 1) as f64);
            for (x, pt) in st.x.iter().zip(&lat.points) {
                if pt.pinned {
                    pin_err = pin_err.max((*x - h.transform_point3(pt.rest)).length());
                }
            }
            let local = h.inverse().transform_point3(st.x[tip]);
            lag = lag.max((local - lat.points[tip].rest).length());
        }
        eprintln!("{integrator:?}: pinned off the head pose by {pin_err:.2e}, head-local tip moved up to {lag:.3}");
        assert!(pin_err < 1e-12, "pinned points off by {pin_err:e}");
        assert!(
            lag > 1.0,
            "the wisp only moved rigidly with the head ({lag})"
        );
    }
}

/// A wisp starting out along the scalp's tangent near the top of the head: without
/// hold_shape it swings down into the head under gravity.
fn draped(head: &Head) -> Vec<DVec3> {
    let e = Ellipsoid::new(head.center, head.radii);
    let root = e.point(0.35, 0.0);
    let n = e.normal(root);
    // Tilted towards +z so it slides off one way: drawn in the symmetry plane it would
    // balance on the crown and fall to either side on a rounding.
    let t = DVec3::new(n.y, -n.x, 0.5);
    let t = (t - t.dot(n) * n).normalize();
    let dir = (t + 0.3 * n).normalize();
    (0..8).map(|i| root + dir * (1.5 * i as f64)).collect()
}

fn deepest(l: &Lattice, st: &State, f: &Forces, frame: f64, hull: &Ellipsoid) -> f64 {
    let inv = f.head_at(frame).inverse();
    l.points
        .iter()
        .zip(&st.x)
        .filter(|(p, _)| !p.pinned)
        .map(|(_, x)| hull.eval(inv.transform_point3(*x)))
        .fold(f64::INFINITY, f64::min)
}

/// The draped wisp: with collision no free point ends a frame inside the head, while the
/// head turns and after it stops, and the wisp comes to rest on it. Without collision the
/// same case goes deep inside (it is a hard case).
#[test]
fn collision_keeps_points_out_of_the_head() {
    let head = Head::default();
    let hull = Ellipsoid::new(head.center, head.radii);
    let p = draped(&head);
    let f = turning(&head);
    for collide in [true, false] {
        let sp = Springs {
            substeps: 48,
            collide,
            ..springs_with(2e4, false)
        };
        let w = wisps(vec![skeleton("draped", &p, 0.5)], sp.clone(), vec![]);
        let lat = Lattice::build(&w, &sp, &head, &still(&head)).unwrap();
        let m = Motion::new(&sp, &head).unwrap();
        let mut st = State::rest(&lat);
        let mut worst = f64::INFINITY;
        for frame in 0..60u64 {
            springs::run_frames(&lat, &m, &f, &mut st, frame, 1);
            worst = worst.min(deepest(&lat, &st, &f, (frame + 1) as f64, &hull));
        }
        // Then 3 s more with the head still (its last key is at frame 20).
        let mut speeds = Vec::new();
        for frame in 60..150u64 {
            springs::run_frames(&lat, &m, &f, &mut st, frame, 1);
            worst = worst.min(deepest(&lat, &st, &f, (frame + 1) as f64, &hull));
            if frame % 15 == 14 {
                speeds.push((springs::max_speed(&st) * 10.0).round() / 10.0);
            }
        }
        let tip = lat.primaries() as usize - 1;
        eprintln!(
            "collide {collide}: lowest quadric value of a free point over 150 frames {worst:.3e}, tip drop {:.2}, top speed every 0.5 s after the head stops {speeds:?}",
            lat.points[tip].rest.y - st.x[tip].y
        );
        if collide {
            assert!(worst >= 0.0, "a free point ended inside the head ({worst})");
            // Resting on the head: a push-out that kept the velocity into the surface would
            // let gravity build it up every step (over 1000 cm/s when tried).
            let last = *speeds.last().unwrap();
            assert!(last < 20.0, "points on the head still move at {last} cm/s");
        } else {
            assert!(
                worst < -0.2,
                "the case is not hard: without collision the deepest is {worst}"
            );
        }
    }
}

/// Stiff springs at the largest step the work-precision table calls stable: 10 s of a shake
/// then stillness stay finite and bounded, on both integrators.
#[test]
fn stiff_case_stays_bounded_at_largest_stable_step() {
    let head = Head::default();
    let p = styled(&head, 0.9, 8, 10.0);
    let sp = Springs {
        collide: true,
        ..springs_with(1e5, true)
    };
    let w = wisps(vec![skeleton("bang", &p, 1.0)], sp.clone(), vec![]);
    let f = shake(&head, 25.0, 6.0, 4);
    let rows = study::work_precision(&w, &head, &f, 1.0, &[64, 128]).unwrap();
    let lat = Lattice::build(&w, &sp, &head, &still(&head)).unwrap();
    let reach = springs::reach(&lat);
    for integrator in [Integrator::Rk4, Integrator::SemiImplicitEuler] {
        let row = rows.iter().find(|r| r.integrator == integrator).unwrap();
        let dt = row.largest_stable_dt;
        let m = Motion {
            integrator,
            ..Motion::new(&sp, &head).unwrap()
        };
        let dframes = dt / sp.frame_time;
        let steps = (10.0 / dt) as u64;
        let mut st = State::rest(&lat);
        let mut far: f64 = 0.0;
        for i in 0..steps {
            springs::step(&lat, &m, &f, &mut st, i as f64 * dframes, dframes);
            if i % 64 == 0 || i + 1 == steps {
                assert!(
                    springs::bounded(&lat, &st, reach),
                    "{integrator:?} blew up at step {i} of {steps} with dt {dt:e}"
                );
                far = far.max(drift(&lat, &st));
            }
        }
        let last = drift(&lat, &st);
        eprintln!(
            "{integrator:?}: largest stable dt {dt:.4e} (bisection {:.4e}, linear bound {:.4e}), 10 s = {steps} steps, worst drift {far:.3}, final drift {last:.2e}",
            row.empirical_stable_dt,
            row.predicted_stable_dt,
        );
        assert!(far < 2.0 * chain_length(&p), "wandered {far}");
        // 9 s after the shake it is back in its drawn shape (not a tangled lattice).
        assert!(last < 0.05, "ended {last} from the drawn shape");
    }
}

/// A thick wisp and a thinner one bundled up to node 4: without hold_shape the thin one
/// would sag away from the thick one, but the bundled nodes stay near their rest distance;
/// past the release they part.
#[test]
fn bundle_holds_then_releases() {
    let head = Head::default();
    let a = styled(&head, 0.9, 8, 10.0);
    let b: Vec<DVec3> = a.iter().map(|p| *p + DVec3::new(0.0, 0.0, 1.5)).collect();
    let release = 4;
    let mut change = [[0.0f64; 8]; 2];
    for bundle in [true, false] {
        let sp = Springs {
            substeps: 64,
            collide: false,
            ..springs_with(4e4, false)
        };
        let bundles = if bundle {
            vec![Bundle {
                wisps: vec![0, 1],
                release_from: release,
            }]
        } else {
            vec![]
        };
        let w = wisps(
            vec![skeleton("thick", &a, 1.0), skeleton("thin", &b, 0.7)],
            sp.clone(),
            bundles,
        );
        let lat = Lattice::build(&w, &sp, &head, &still(&head)).unwrap();
        let m = Motion::new(&sp, &head).unwrap();
        let mut st = State::rest(&lat);
        let c = &mut change[bundle as usize];
        for frame in 0..90 {
            springs::run_frames(&lat, &m, &still(&head), &mut st, frame, 1);
            for i in 0..8 {
                let d = (st.x[i] - st.x[8 + i]).length() - (a[i] - b[i]).length();
                c[i] = c[i].max(d.abs());
            }
        }
        eprintln!(
            "bundle {bundle}: largest change of the node distances over 3 s: {:?}",
            c.map(|v| (v * 1e3).round() / 1e3)
        );
    }
    let held = change[1][..release].iter().copied().fold(0.0, f64::max);
    let free = change[0][..release].iter().copied().fold(0.0, f64::max);
    assert!(
        held < 0.5,
        "bundled nodes moved {held} from their rest distance 1.5"
    );
    assert!(
        held * 4.0 < free,
        "the bundle barely helps: {held} against {free} unbundled"
    );
    assert!(
        change[1][7] > 3.0,
        "the released tips did not part ({})",
        change[1][7]
    );
}

/// The WGSL module validates (the wisps kind registers it in `stage::shaders`).
#[test]
fn springs_shader_validates() {
    let src = kami::systems::wisps::springs_gpu::SPRINGS;
    let module = naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("springs.wgsl does not parse:\n{}", e.emit_to_string(src)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("springs.wgsl does not validate:\n{}", e.emit_to_string(src)));
}

/// Two wisps (a held bang and a wisp hanging down the back, both shaken, touching the
/// head), the f32 kernel against the f64 reference over the same frames, recorded a frame
/// per submission and then many at once, for both integrators.
#[test]
fn gpu_matches_cpu() {
    let gpu = common::gpu();
    let head = Head::default();
    let e = Ellipsoid::new(head.center, head.radii);
    let bang = styled(&head, 0.9, 8, 10.0);
    let root = e.point(1.9, std::f64::consts::PI);
    let back: Vec<DVec3> = (0..6)
        .map(|i| root + DVec3::new(-1.0, -1.8, 0.3) * i as f64)
        .collect();
    // A 10 degree shake: the 25 degree one of the stiffness test folds rings over (section
    // "weak" of the report) and the motion turns chaotic, where no two roundings agree.
    let f = shake(&head, 10.0, 10.0, 4);
    for integrator in [Integrator::Rk4, Integrator::SemiImplicitEuler] {
        let sp = Springs {
            substeps: 48,
            integrator,
            ..springs_with(2e4, true)
        };
        let w = wisps(
            vec![skeleton("bang", &bang, 1.0), skeleton("back", &back, 0.8)],
            sp.clone(),
            vec![],
        );
        let lat = Lattice::build(&w, &sp, &head, &still(&head)).unwrap();
        let m = Motion::new(&sp, &head).unwrap();
        let mut gs =
            springs_gpu::SpringsGpu::new(gpu, &common::world_of(gpu, &f, &head), &lat, &sp)
                .unwrap();
        assert_eq!(gs.primaries(), 14);
        let mut st = State::rest(&lat);
        let t = std::time::Instant::now();
        let mut frame = 0u64;
        for chunk in [1u32, 1, 1, 1, 1, 5, 35] {
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            gs.record(gpu, &mut enc, &f, frame, chunk).unwrap();
            gpu.queue.submit([enc.finish()]);
            frame += chunk as u64;
        }
        let got = gs.read_positions(gpu).unwrap();
        let gpu_time = t.elapsed();
        springs::run_frames(&lat, &m, &f, &mut st, 0, frame as u32);
        let len = chain_length(&bang).max(chain_length(&back));
        // The root rings sit exactly on the head pose (up to f32).
        let h = f.head_at(frame as f64);
        let pinned = got
            .iter()
            .zip(&lat.points)
            .filter(|(_, p)| p.pinned)
            .map(|(g, p)| {
                (Vec3::new(g[0], g[1], g[2]).as_dvec3() - h.transform_point3(p.rest)).length()
            })
            .fold(0.0, f64::max);
        assert!(
            pinned < 1e-5,
            "GPU root rings off the head pose by {pinned}"
        );
        let mut worst: f64 = 0.0;
        let mut moved: f64 = 0.0;
        for (i, g) in got.iter().enumerate() {
            let g = Vec3::new(g[0], g[1], g[2]).as_dvec3();
            worst = worst.max((g - st.x[i]).length());
            moved = moved.max((st.x[i] - lat.points[i].rest).length());
        }
        eprintln!(
            "{integrator:?}: {} points, {frame} frames: worst |GPU - CPU| {worst:.3e} = {:.2e} of the wisp length (points moved up to {moved:.2}); root rings off the pose by {pinned:.1e}; GPU {gpu_time:?}",
            got.len(),
            worst / len
        );
        assert!(moved > 1.0);
        assert!(worst < 1e-4 * len, "GPU and CPU differ by {worst}");
        // Reset goes back to the drawn pose.
        gs.reset(gpu).unwrap();
        let again = gs.read_positions(gpu).unwrap();
        assert!(again
            .iter()
            .zip(&lat.points)
            .all(|(g, p)| (Vec3::new(g[0], g[1], g[2]).as_dvec3() - p.rest).length() < 1e-5));
    }
}

/// The collision on the GPU: the draped wisp of `collision_keeps_points_out_of_the_head`,
/// f32 against f64 (to 0.5% of the wisp length: contact makes the motion sensitive to
/// rounding, see below), and no free point inside the head.
#[test]
fn gpu_collision_matches_cpu() {
    let gpu = common::gpu();
    let head = Head::default();
    let hull = Ellipsoid::new(head.center, head.radii);
    let p = draped(&head);
    let f = turning(&head);
    for integrator in [Integrator::Rk4, Integrator::SemiImplicitEuler] {
        let sp = Springs {
            substeps: 48,
            integrator,
            ..springs_with(2e4, false)
        };
        let w = wisps(vec![skeleton("draped", &p, 0.5)], sp.clone(), vec![]);
        let lat = Lattice::build(&w, &sp, &head, &still(&head)).unwrap();
        let m = Motion::new(&sp, &head).unwrap();
        let mut gs =
            springs_gpu::SpringsGpu::new(gpu, &common::world_of(gpu, &f, &head), &lat, &sp)
                .unwrap();
        let mut st = State::rest(&lat);
        let mut history = Vec::new();
        let (mut worst, mut deep): (f64, f64) = (0.0, f64::INFINITY);
        for frame in 0..40u64 {
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            gs.record(gpu, &mut enc, &f, frame, 1).unwrap();
            gpu.queue.submit([enc.finish()]);
            springs::run_frames(&lat, &m, &f, &mut st, frame, 1);
            history.push(st.x.clone());
            let got: Vec<DVec3> = gs
                .read_positions(gpu)
                .unwrap()
                .iter()
                .map(|g| Vec3::new(g[0], g[1], g[2]).as_dvec3())
                .collect();
            for (g, c) in got.iter().zip(&st.x) {
                worst = worst.max((*g - *c).length());
            }
            let gst = State {
                x: got,
                v: st.v.clone(),
            };
            deep = deep.min(deepest(&lat, &gst, &f, (frame + 1) as f64, &hull));
        }
        eprintln!(
            "{integrator:?}: worst |GPU - CPU| {worst:.3e} over 40 frames in contact, GPU's lowest quadric value {deep:.2e}"
        );
        // Contact decisions (inside or not, by a rounding) branch the motion: the f64
        // reference itself, its state rounded to f32 after every step, strays about as far.
        let mut rounded = State::rest(&lat);
        let mut stray: f64 = 0.0;
        for frame in 0..40u64 {
            for k in 0..sp.substeps {
                let at = frame as f64 + k as f64 / sp.substeps as f64;
                springs::step(&lat, &m, &f, &mut rounded, at, 1.0 / sp.substeps as f64);
                for x in rounded.x.iter_mut().chain(rounded.v.iter_mut()) {
                    *x = x.as_vec3().as_dvec3();
                }
            }
            for (a, b) in rounded.x.iter().zip(&history[frame as usize]) {
                stray = stray.max((*a - *b).length());
            }
        }
        eprintln!(
            "{integrator:?}: the f64 reference with its state rounded to f32 strays {stray:.3e}"
        );
        assert!(
            worst < 5e-3 * chain_length(&p),
            "GPU and CPU differ by {worst}"
        );
        assert!(deep > -1e-5, "a GPU point ended inside the head ({deep})");
    }
}
