//! The External Force Field (Kazama et al. 3.3, `kami::forces::eff`): the two fill rules on
//! hand-made grids and against an independent brute-force reading, sampling (nearest,
//! trilinear, the outside force and the band between), the gust, the brush, EFF files
//! (exact round trip, every bad case), scene-block validation, the shipped example file, and
//! the WGSL `eff_force` against `Eff::sample_at`.

use crate::common;

use glam::DVec3;
use kami::error::KamiError;
use kami::forces::eff::{Blower, Eff, EffDesc, EffSample, GustKey, BAND_CELLS, MAX_CELLS};
use kami::forces::Forces;
use kami::rng::pcg_hash;
use kami::scene::Sampling;
use kami::scene::{Interp, WindKey};
use kami::systems::world::{self, EffGpu};
use std::path::PathBuf;

/// A reproducible uniform number in [0, 1).
fn rnd(i: u32, salt: u32) -> f64 {
    (pcg_hash(i.wrapping_mul(7919) ^ pcg_hash(salt)) >> 8) as f64 / 16_777_216.0
}

fn desc(resolution: [u32; 3], extent: f64) -> EffDesc {
    EffDesc {
        resolution,
        extent,
        ..EffDesc::default()
    }
}

fn sample(at: DVec3, force: DVec3) -> EffSample {
    EffSample {
        at: at.to_array(),
        force: force.to_array(),
    }
}

/// A file name unique to this test process and `name`.
fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kami-eff-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
    (a - b).length() <= tol
}

const A: DVec3 = DVec3::new(10.0, -4.0, 2.0);
const B: DVec3 = DVec3::new(-6.0, 8.0, 1.0);

/// Rule (a) on a row of five cells (centres x = -4, -2, 0, 2, 4; the head at 0), defined
/// at both ends: the three inside cells are nearer the head than their nearest defined
/// cell, so each is linear between the two ends; the middle one is a tie (both ends 4
/// away), which goes to the lower index and gives the mean either way.
#[test]
fn rule_a_interpolates_between_the_two_nearest_defined_cells() {
    let mut d = desc([5, 1, 1], 10.0);
    d.samples = vec![
        sample(DVec3::new(-4.0, 0.0, 0.0), A),
        sample(DVec3::new(4.0, 0.0, 0.0), B),
    ];
    let e = Eff::build(&d).unwrap();
    assert_eq!(e.defined(), &[true, false, false, false, true]);
    let c = e.cells();
    assert_eq!(c[0], A);
    assert_eq!(c[4], B);
    for (i, t) in [(1, 0.25), (2, 0.5), (3, 0.75)] {
        assert!(
            close(c[i], A.lerp(B, t), 1e-12),
            "cell {i}: {} (want {})",
            c[i],
            A.lerp(B, t)
        );
    }
}

/// Rule (b) on the same row, defined only at the head (centre cell): every other cell is
/// farther from the head, so it goes linearly from the defined force at the centre to the
/// outside force where the ray from the centre through the cell leaves the grid (x = ±5):
/// 2/5 of the way at x = ±2, 4/5 at ±4. Also on a 3×3 slab along a diagonal (2/3 of the way
/// to the corner face).
#[test]
fn rule_b_interpolates_toward_the_outside_force() {
    let mut d = desc([5, 1, 1], 10.0);
    d.samples = vec![sample(DVec3::ZERO, A)];
    d.source = [-100.0, 0.0, 0.0];
    d.strength = 50.0;
    let e = Eff::build(&d).unwrap();
    let o = DVec3::new(50.0, 0.0, 0.0);
    assert_eq!(e.outside(), o);
    let c = e.cells();
    for (i, s) in [(0, 0.8), (1, 0.4), (3, 0.4), (4, 0.8)] {
        assert!(
            close(c[i], A.lerp(o, s), 1e-12),
            "cell {i}: {} (want {})",
            c[i],
            A.lerp(o, s)
        );
    }
    // Diagonal: the corner cell's centre (2, 2) lies 2√2 from the centre, the ray leaves the
    // grid at (3, 3), 3√2 away; the side cell (2, 0) at 2 of 3.
    let mut d = desc([3, 3, 1], 6.0);
    d.samples = vec![sample(DVec3::ZERO, A)];
    d.source = [0.0, 0.0, 40.0];
    d.strength = 9.0;
    let e = Eff::build(&d).unwrap();
    let o = DVec3::new(0.0, 0.0, -9.0);
    for ijk in [[2, 2, 0], [0, 0, 0], [2, 1, 0], [1, 0, 0]] {
        let i = e.index(ijk);
        assert!(
            close(e.cells()[i], A.lerp(o, 2.0 / 3.0), 1e-12),
            "cell {ijk:?}: {}",
            e.cells()[i]
        );
    }
}

/// Which rule applies depends on the head point, not the grid centre, and ties for the
/// nearest defined cell go to the lower index: head at x = -4, defined cells at x = 0 (A)
/// and 4 (B).
#[test]
fn the_head_point_chooses_the_rule_and_ties_go_to_the_lower_index() {
    let mut d = desc([5, 1, 1], 10.0);
    d.head = Some([-4.0, 0.0, 0.0]);
    d.source = [-4.0, 0.0, 50.0];
    d.strength = 20.0;
    d.samples = vec![
        sample(DVec3::new(0.0, 0.0, 0.0), A),
        sample(DVec3::new(4.0, 0.0, 0.0), B),
    ];
    let e = Eff::build(&d).unwrap();
    let o = DVec3::new(0.0, 0.0, -20.0);
    let c = e.cells();
    // x = -4 and -2: nearer the head than A -> (a) between A (d1) and B (d2).
    assert!(close(c[0], (A * 8.0 + B * 4.0) / 12.0, 1e-12), "{}", c[0]);
    assert!(close(c[1], (A * 6.0 + B * 2.0) / 8.0, 1e-12), "{}", c[1]);
    // x = 2: A and B both 2 away; A (lower index) is the nearest; farther from the head
    // than A -> (b) from A toward the outside force, 2 of the 5 to the face x = 5.
    assert!(close(c[3], A.lerp(o, 0.4), 1e-12), "{}", c[3]);
}

/// An independent brute-force reading of the documented rules on random sparse grids: the
/// k-d tree fill must agree with it to rounding. On the cubic grid (head at the centre, a
/// cell size and centre chosen so that rounding would split ties) exact ties are everywhere;
/// the reference compares them as integers (squared cell offsets), the tie rule picks the
/// lower index.
#[test]
fn fill_matches_a_brute_force_reading_of_the_rules() {
    let mut uneven = desc([9, 7, 5], 30.0);
    uneven.center = [1.0, -2.0, 0.5];
    uneven.head = Some([2.0, 1.0, -1.0]);
    // Awkward sizes, so that rounding would split ties if distances were not exact.
    let mut cubic = desc([7, 7, 7], 33.3);
    cubic.center = [0.3, -1.7, 2.9];
    for (mut d, count, is_cubic) in [(uneven, 40, false), (cubic, 25, true)] {
        d.source = [-40.0, 10.0, 30.0];
        d.strength = 70.0;
        let lo = DVec3::from(d.center) - 0.5 * d.extent;
        d.samples = (0..count)
            .map(|i| {
                let at = lo + DVec3::new(rnd(i, 1), rnd(i, 2), rnd(i, 3)) * d.extent * 0.999;
                let f = DVec3::new(rnd(i, 4), rnd(i, 5), rnd(i, 6)) * 200.0 - 100.0;
                sample(at, f)
            })
            .collect();
        let e = Eff::build(&d).unwrap();
        check_fill(&e, is_cubic);
    }
}

fn check_fill(e: &Eff, cubic: bool) {
    let defined: Vec<usize> = (0..e.cell_count()).filter(|&i| e.defined()[i]).collect();
    assert!(defined.len() > 15 && defined.len() < e.cell_count() / 4);
    let dims = e.dims();
    let size = e.cell_size() * DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64);
    let (lo, hi) = (e.origin(), e.origin() + size);
    let head = e.head();
    let ijk = |i: usize| e.ijk(i).map(|v| v as i64);
    // Squared distance between cells: an integer on the cubic grid, world units otherwise.
    let dist2 = |a: [i64; 3], b: [i64; 3]| -> f64 {
        let d = [0, 1, 2].map(|k| (a[k] - b[k]) as f64);
        if cubic {
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * 1e6
        } else {
            (0..3).map(|k| (d[k] * e.cell_size()[k]).powi(2)).sum()
        }
    };
    // Is cell a strictly nearer the head than cell b? (Cubic: the head is the grid centre,
    // at half-integer lattice coordinates; doubled, they are integers.)
    let nearer = |a: [i64; 3], b: [i64; 3]| -> bool {
        if cubic {
            let h2 = |c: [i64; 3]| -> i64 {
                (0..3).map(|k| (2 * c[k] - dims[k] as i64 + 1).pow(2)).sum()
            };
            h2(a) < h2(b)
        } else {
            let w = |c: [i64; 3]| e.cell_center(e.index(c.map(|v| v as u32)));
            w(a).distance(head) < w(b).distance(head)
        }
    };
    let (mut rule_a, mut rule_b) = (0, 0);
    for i in 0..e.cell_count() {
        if e.defined()[i] {
            continue;
        }
        let p = e.cell_center(i);
        let mut near: Vec<(f64, usize)> = defined
            .iter()
            .map(|&j| (dist2(ijk(i), ijk(j)), j))
            .collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let (n1, n2) = (near[0].1, near[1].1);
        let (d1, d2) = (p.distance(e.cell_center(n1)), p.distance(e.cell_center(n2)));
        let c1 = e.cell_center(n1);
        let want = if nearer(ijk(i), ijk(n1)) {
            rule_a += 1;
            (e.cells()[n1] * d2 + e.cells()[n2] * d1) / (d1 + d2)
        } else {
            rule_b += 1;
            let u = (p - c1) / d1;
            // Where the ray leaves the box, by bisection (independent of the code's slab test).
            let (mut a, mut b) = (0.0, 1e3);
            for _ in 0..200 {
                let m = 0.5 * (a + b);
                let q = c1 + u * m;
                if q.cmpge(lo).all() && q.cmple(hi).all() {
                    a = m;
                } else {
                    b = m;
                }
            }
            e.cells()[n1].lerp(e.outside(), d1 / a)
        };
        let err = (e.cells()[i] - want).length();
        assert!(
            err < 1e-9,
            "cell {:?}: {} but the rules say {want} (n1 {:?}, n2 {:?})",
            e.ijk(i),
            e.cells()[i],
            e.ijk(n1),
            e.ijk(n2)
        );
    }
    assert!(
        rule_a > 10 && rule_b > 10,
        "both rules ran: {rule_a}, {rule_b}"
    );
}

/// No defined cell: the only wind known is the outside force, everywhere.
#[test]
fn without_defined_cells_every_cell_is_the_outside_force() {
    let mut d = desc([4, 3, 2], 20.0);
    d.source = [0.0, 100.0, 0.0];
    d.strength = 30.0;
    let e = Eff::build(&d).unwrap();
    assert!(e.cells().iter().all(|c| *c == DVec3::new(0.0, -30.0, 0.0)));
    assert_eq!(e.max_force(), 30.0);
}

/// Several samples in one cell are averaged; samples in other cells are not mixed in.
#[test]
fn samples_in_one_cell_are_averaged() {
    let mut d = desc([2, 2, 2], 10.0);
    d.samples = vec![
        sample(DVec3::new(-4.0, -4.0, -4.0), A),
        sample(DVec3::new(-1.0, -2.0, -0.5), B),
        sample(DVec3::new(-3.0, -3.0, -3.0), DVec3::ONE),
        sample(DVec3::new(3.0, 3.0, 3.0), B),
    ];
    let e = Eff::build(&d).unwrap();
    assert_eq!(e.cells()[0], (A + B + DVec3::ONE) / 3.0);
    assert_eq!(e.cells()[7], B);
    assert_eq!(e.defined().iter().filter(|d| **d).count(), 2);
}

/// A linear field stored at the cell centres is reproduced exactly by trilinear sampling
/// anywhere between the outermost centres; between them and the faces it is clamped (the
/// border cells' values, constant along that axis).
#[test]
fn trilinear_reproduces_a_linear_field() {
    let m = glam::DMat3::from_cols(
        DVec3::new(1.5, -0.5, 2.0),
        DVec3::new(0.25, 3.0, -1.0),
        DVec3::new(-2.0, 0.5, 0.75),
    );
    let b = DVec3::new(3.0, -7.0, 11.0);
    let field = |p: DVec3| m * p + b;
    let d = desc([6, 4, 5], 24.0);
    let mut e = Eff::build(&d).unwrap();
    for i in 0..e.cell_count() {
        e.set_cell(i, field(e.cell_center(i)));
    }
    let c0 = e.cell_center(0);
    let c1 = e.cell_center(e.cell_count() - 1);
    let mut worst = 0.0f64;
    for i in 0..500 {
        let t = DVec3::new(rnd(i, 11), rnd(i, 12), rnd(i, 13));
        let p = c0 + (c1 - c0) * t;
        worst = worst.max((e.sample(p, Sampling::Trilinear) - field(p)).length());
    }
    assert!(worst < 1e-10, "trilinear off a linear field by {worst:e}");
    // Clamped between the last centre and the face (x from 10 to 12 here).
    let p = DVec3::new(11.5, 0.3, -0.7);
    let want = field(DVec3::new(c1.x, 0.3, -0.7));
    assert!(close(e.sample(p, Sampling::Trilinear), want, 1e-10));
}

/// Nearest sampling returns exactly the value of the cell the point is in; a point on a
/// face between two cells belongs to the upper one.
#[test]
fn nearest_picks_the_cell_the_point_is_in() {
    let mut d = desc([5, 4, 3], 12.0);
    d.samples = (0..20)
        .map(|i| {
            sample(
                DVec3::new(rnd(i, 1) - 0.5, rnd(i, 2) - 0.5, rnd(i, 3) - 0.5) * 11.9,
                DVec3::new(rnd(i, 4), rnd(i, 5), rnd(i, 6)) * 10.0,
            )
        })
        .collect();
    let e = Eff::build(&d).unwrap();
    for i in 0..300 {
        let p = (DVec3::new(rnd(i, 7), rnd(i, 8), rnd(i, 9)) - 0.5) * 11.99;
        let cell = e.cell_of(p).unwrap();
        assert_eq!(e.sample(p, Sampling::Nearest), e.cells()[cell], "at {p}");
        let q = (p - e.origin()) / e.cell_size();
        assert_eq!(
            e.ijk(cell),
            [q.x.floor() as u32, q.y.floor() as u32, q.z.floor() as u32]
        );
    }
    // x = -6 + 2.4 is the face between cells 0 and 1 along x.
    let face = DVec3::new(e.origin().x + e.cell_size().x, 0.1, 0.1);
    assert_eq!(e.ijk(e.cell_of(face).unwrap())[0], 1);
    assert_eq!(
        e.sample(face, Sampling::Nearest),
        e.cells()[e.cell_of(face).unwrap()]
    );
}

/// Outside the grid (beyond the band) the force is `strength` along source → head, the same
/// direction at every point; across the band it blends continuously from the border value.
#[test]
fn outside_the_grid_the_force_blows_from_the_source_toward_the_head() {
    let mut d = desc([4, 4, 4], 20.0);
    d.center = [0.0, -5.0, 0.0];
    d.head = Some([0.0, 0.0, 0.0]);
    d.source = [30.0, 40.0, 0.0];
    d.strength = 100.0;
    d.samples = vec![sample(DVec3::new(0.0, -5.0, 0.0), A)];
    let e = Eff::build(&d).unwrap();
    let want = DVec3::new(-60.0, -80.0, 0.0);
    assert!(close(e.outside(), want, 1e-12));
    for p in [
        DVec3::new(100.0, 0.0, 0.0),
        DVec3::new(-40.0, 30.0, 7.0),
        DVec3::new(0.0, -5.0, -16.0),
        DVec3::new(0.0, -1000.0, 0.0),
    ] {
        for s in [Sampling::Nearest, Sampling::Trilinear] {
            assert!(
                close(e.sample(p, s), want, 1e-12),
                "at {p}: {}",
                e.sample(p, s)
            );
        }
    }
    // The band: continuous at the face, the outside force one cell (5) out, halfway between.
    let face = DVec3::new(10.0, -3.0, 1.0);
    let inner = e.sample(face - DVec3::X * 1e-9, Sampling::Trilinear);
    let outer = e.sample(face + DVec3::X * 1e-9, Sampling::Trilinear);
    assert!(
        close(inner, outer, 1e-6),
        "jump at the face: {inner} {outer}"
    );
    assert!(close(
        e.sample(face + DVec3::X * 5.0 * BAND_CELLS, Sampling::Trilinear),
        want,
        1e-12
    ));
    let half = e.sample(face + DVec3::X * 2.5 * BAND_CELLS, Sampling::Trilinear);
    assert!(close(half, 0.5 * (inner + want), 1e-9), "{half}");
}

/// Gust keys scale the field over time (held or linear), and the shared forces add the EFF
/// at that scale to the keyed uniform wind.
#[test]
fn gust_keys_scale_the_field_and_forces_add_it_to_the_wind() {
    let mut d = desc([2, 2, 2], 10.0);
    d.samples = vec![sample(DVec3::splat(-2.0), A)];
    d.gust = vec![
        GustKey {
            frame: 5.0,
            scale: 1.0,
            interp: Interp::Step,
        },
        GustKey {
            frame: 10.0,
            scale: 2.0,
            interp: Interp::Linear,
        },
        GustKey {
            frame: 20.0,
            scale: 0.5,
            interp: Interp::Step,
        },
    ];
    let e = Eff::build(&d).unwrap();
    for (f, s) in [
        (0.0, 1.0),
        (7.0, 1.0),
        (10.0, 2.0),
        (15.0, 1.25),
        (20.0, 0.5),
        (99.0, 0.5),
    ] {
        assert_eq!(e.scale_at(f), s, "frame {f}");
    }
    let p = DVec3::new(-2.0, -2.0, -2.0);
    assert_eq!(e.sample_at(p, 15.0, Sampling::Nearest), A * 1.25);
    let forces = Forces {
        gravity: DVec3::ZERO,
        wind: vec![WindKey {
            frame: 0.0,
            force: [1.0, 2.0, 3.0],
            interp: Interp::Step,
        }],
        head_motion: Vec::new(),
        center: DVec3::ZERO,
        eff: Some(std::sync::Arc::new(e)),
    };
    assert_eq!(
        forces.wind_at_point(p, 15.0, Sampling::Nearest),
        DVec3::new(1.0, 2.0, 3.0) + A * 1.25
    );
    assert_eq!(forces.eff_scale(10.0), 2.0);
}

/// A blower defines the cells inside its jet (full force on the axis, none upstream or
/// outside the radius) and leaves the rest to the fill rules.
#[test]
fn a_blower_defines_the_cells_of_its_jet() {
    let mut d = desc([10, 10, 10], 20.0);
    d.blowers = vec![Blower {
        at: [-10.0, 1.0, 1.0],
        toward: [2.0, 0.0, 0.0],
        strength: 300.0,
        radius: 3.0,
        spread: 0.0,
    }];
    let e = Eff::build(&d).unwrap();
    for i in 0..e.cell_count() {
        let c = e.cell_center(i);
        let rho = DVec3::new(0.0, c.y - 1.0, c.z - 1.0).length();
        assert_eq!(e.defined()[i], rho < 3.0, "cell at {c}");
        if rho < 3.0 {
            let w = (1.0 - (rho / 3.0).powi(2)).powi(2);
            assert!(close(e.cells()[i], DVec3::X * 300.0 * w, 1e-9));
        }
    }
    // Upstream of the nozzle nothing is defined.
    d.blowers[0].at = [0.0, 1.0, 1.0];
    let e = Eff::build(&d).unwrap();
    assert!((0..e.cell_count()).all(|i| !e.defined()[i] || e.cell_center(i).x > 0.0));
}

/// The brush: full strength sets the centre cell, the falloff is smooth and monotone, cells
/// beyond the radius are untouched, strokes converge, and `refill` re-fills the rest.
#[test]
fn the_brush_paints_with_a_smooth_falloff() {
    let d = desc([11, 11, 11], 22.0);
    let mut e = Eff::build(&d).unwrap();
    let before = e.clone();
    let f = DVec3::new(0.0, 50.0, 0.0);
    let n = e.paint(DVec3::ZERO, 5.0, f, 1.0);
    assert!(n > 50, "{n} cells touched");
    let centre = e.cell_of(DVec3::ZERO).unwrap();
    assert_eq!(e.cells()[centre], f);
    let mut last = f64::INFINITY;
    for k in 0..=5 {
        let p = DVec3::new(2.0 * k as f64, 0.0, 0.0);
        let v = e.sample(p, Sampling::Nearest).y;
        assert!(v <= last, "falloff not monotone at {p}");
        last = v;
    }
    for i in 0..e.cell_count() {
        if e.cell_center(i).length() >= 5.0 {
            assert_eq!(e.cells()[i], before.cells()[i]);
            assert!(!e.defined()[i]);
        }
    }
    let side = e.cell_of(DVec3::new(4.0, 0.0, 0.0)).unwrap();
    let first = e.cells()[side].y;
    assert!(first > 0.0 && first < 50.0);
    for _ in 0..200 {
        e.paint(DVec3::ZERO, 5.0, f, 1.0);
    }
    assert!((e.cells()[side].y - 50.0).abs() < 1e-3);
    // Refill: the painted blob is the defined set now; cells around it follow rule (b)
    // toward the (zero) outside force.
    e.refill();
    let far = e.cell_of(DVec3::new(9.0, 0.0, 0.0)).unwrap();
    assert!(e.cells()[far].y > 0.0 && e.cells()[far].y < 50.0);
    assert_eq!(e.paint(DVec3::splat(100.0), 5.0, f, 1.0), 0);
}

/// Save then load gives the same grid bit for bit (awkward numbers included), and saving
/// the loaded grid writes the same bytes.
#[test]
fn file_round_trip_is_exact() {
    let mut d = desc([5, 3, 4], 17.3);
    d.center = [0.1, -0.2, 1.0 / 3.0];
    d.head = Some([0.3, 0.7, -1e-7]);
    d.source = [-33.3, 12.25, 1e5];
    d.strength = 123.456789;
    let mut e = Eff::build(&d).unwrap();
    let awkward = [
        0.1,
        -0.0,
        1e-300,
        5e-324,
        1.0 / 3.0,
        -2.5e8,
        f64::MIN_POSITIVE,
    ];
    for i in 0..e.cell_count() {
        if i % 3 == 0 {
            let a = |k: u32| awkward[(i + k as usize) % awkward.len()] * (1.0 + rnd(i as u32, k));
            e.set_cell(i, DVec3::new(a(0), a(1), a(2)));
        }
    }
    e.refill();
    let path = temp("round_trip.eff");
    e.save(&path).unwrap();
    let back = Eff::load(&path).unwrap();
    assert_eq!(back.dims(), e.dims());
    assert_eq!(back.origin(), e.origin());
    assert_eq!(back.cell_size(), e.cell_size());
    assert_eq!(back.source(), e.source());
    assert_eq!(back.head(), e.head());
    assert_eq!(back.strength(), e.strength());
    assert_eq!(back.defined(), e.defined());
    for (a, b) in back.cells().iter().zip(e.cells()) {
        assert_eq!(
            a.to_array().map(f64::to_bits),
            b.to_array().map(f64::to_bits)
        );
    }
    let again = temp("round_trip_again.eff");
    back.save(&again).unwrap();
    assert_eq!(
        std::fs::read(&path).unwrap(),
        std::fs::read(&again).unwrap()
    );
}

/// A valid file, as text, for the bad-file cases to spoil.
fn good_file() -> String {
    let mut d = desc([2, 2, 1], 4.0);
    d.samples = vec![sample(DVec3::new(-1.0, -1.0, 0.0), A)];
    d.strength = 5.0;
    let path = temp("good.eff");
    Eff::build(&d).unwrap().save(&path).unwrap();
    std::fs::read_to_string(path).unwrap()
}

/// Load `text` as a file and return (line, message) of its `Data` error.
fn bad_file(name: &str, text: &str) -> (Option<usize>, String) {
    let path = temp(name);
    std::fs::write(&path, text).unwrap();
    match Eff::load(&path) {
        Err(KamiError::Data {
            path: p,
            line,
            message,
        }) => {
            assert_eq!(p, path.display().to_string());
            (line, message)
        }
        other => panic!("{name}: expected a data error, got {other:?}"),
    }
}

/// The line number (1-based) of the first line of `text` starting with `start`.
fn line_of(text: &str, start: &str) -> usize {
    text.lines().position(|l| l.starts_with(start)).unwrap() + 1
}

#[test]
fn bad_files_are_refused_with_the_line() {
    let good = good_file();
    let lines: Vec<&str> = good.lines().collect();
    let n = lines.len();
    let cells_at = line_of(&good, "cells");
    assert_eq!(n, cells_at + 4, "2x2x1 grid: four cell lines");
    let join = |v: &[&str]| v.join("\n") + "\n";

    // Too few cells: the error is at the end and says the size is wrong.
    let (line, m) = bad_file("short.eff", &join(&lines[..n - 1]));
    assert_eq!(line, Some(n - 1));
    assert!(
        m.contains("wrong size") && m.contains("4 cell lines") && m.contains("after 3"),
        "{m}"
    );
    // Too many cells: at the first extra line.
    let mut more = lines.clone();
    more.push("d 1.0 2.0 3.0");
    let (line, m) = bad_file("long.eff", &join(&more));
    assert_eq!(line, Some(n + 1));
    assert!(m.contains("wrong size"), "{m}");
    // NaN and infinity in a cell.
    for (name, v) in [("nan.eff", "NaN"), ("inf.eff", "inf")] {
        let mut bad = lines.clone();
        let row = format!("d 1.0 {v} 3.0");
        bad[cells_at + 1] = &row;
        let (line, m) = bad_file(name, &join(&bad));
        assert_eq!(line, Some(cells_at + 2));
        assert!(
            m.contains("not a finite number") && m.contains("cell [1, 0, 0]"),
            "{m}"
        );
    }
    // A cell line cut short (a truncated file without its last newline).
    let cut = good.trim_end().rsplit_once(' ').unwrap().0.to_string();
    let (line, m) = bad_file("cut.eff", &cut);
    assert_eq!(line, Some(n));
    assert!(m.contains("needs 3 numbers, found 2"), "{m}");
    // Not a number; a bad flag.
    let mut bad = lines.clone();
    bad[cells_at] = "d 1.0 x 3.0";
    assert!(bad_file("word.eff", &join(&bad))
        .1
        .contains("`x` is not a number"));
    bad[cells_at] = "q 1.0 2.0 3.0";
    assert!(bad_file("flag.eff", &join(&bad))
        .1
        .contains("starts with `d`"));
    // Header: no `cells` line, a missing key, an unknown key, a key twice, a bad version,
    // not an EFF file at all, an empty file.
    let (line, m) = bad_file("header_cut.eff", &join(&lines[..cells_at - 1]));
    assert_eq!(line, Some(cells_at - 1));
    assert!(m.contains("truncated header"), "{m}");
    let no_cell: Vec<&str> = lines
        .iter()
        .copied()
        .filter(|l| !l.starts_with("cell "))
        .collect();
    let (_, m) = bad_file("no_cell.eff", &join(&no_cell));
    assert!(m.contains("no `cell` line"), "{m}");
    let mut unknown = lines.clone();
    unknown.insert(2, "colour 1 2 3");
    let (line, m) = bad_file("unknown.eff", &join(&unknown));
    assert_eq!(line, Some(3));
    assert!(m.contains("unknown header key `colour`"), "{m}");
    let mut twice = lines.clone();
    let origin = line_of(&good, "origin") - 1;
    twice.insert(origin, lines[origin]);
    assert!(bad_file("twice.eff", &join(&twice))
        .1
        .contains("`origin` is given twice"));
    let mut version = lines.clone();
    version[0] = "kami-eff 2";
    let (line, m) = bad_file("version.eff", &join(&version));
    assert_eq!(line, Some(1));
    assert!(m.contains("unsupported version"), "{m}");
    assert!(bad_file("other.eff", "P3\n1 1\n")
        .1
        .contains("not an EFF file"));
    assert!(bad_file("empty.eff", "\n# nothing\n")
        .1
        .contains("empty file"));
    // Bad header values: zero or negative cell size, a NaN origin.
    for (name, key, value, want) in [
        ("cell0.eff", "cell ", "cell 1.0 0.0 1.0", "must be > 0"),
        (
            "origin_nan.eff",
            "origin",
            "origin 0 NaN 0",
            "not a finite number",
        ),
        (
            "res0.eff",
            "resolution",
            "resolution 2 0 1",
            "at least one cell",
        ),
        (
            "res_word.eff",
            "resolution",
            "resolution 2 two 1",
            "not a number",
        ),
    ] {
        let mut bad = lines.clone();
        let at = line_of(&good, key) - 1;
        bad[at] = value;
        let (line, m) = bad_file(name, &join(&bad));
        assert_eq!(line, Some(at + 1), "{name}");
        assert!(m.contains(want), "{name}: {m}");
    }
}

/// A header claiming a grid beyond the cap is refused at that line, before the cells are
/// allocated or read (4e9 cells would need about 100 GB).
#[test]
fn an_oversized_grid_is_refused_before_allocating() {
    let good = good_file();
    let at = line_of(&good, "resolution");
    let text = good.replace("resolution 2 2 1", "resolution 4000 1000 1000");
    let (line, m) = bad_file("huge.eff", &text);
    assert_eq!(line, Some(at));
    assert!(m.contains(&MAX_CELLS.to_string()), "{m}");
    // One past the cap, and a product that overflows u32.
    let text = good.replace("resolution 2 2 1", "resolution 129 128 128");
    assert!(bad_file("cap.eff", &text).1.contains("at most"));
    let text = good.replace(
        "resolution 2 2 1",
        "resolution 4294967295 4294967295 4294967295",
    );
    assert!(bad_file("overflow.eff", &text).1.contains("at most"));
}

/// Scene-block values that cannot make a grid are refused naming the field, before
/// anything is allocated.
#[test]
fn bad_blocks_are_refused_naming_the_field() {
    let field_of = |d: &EffDesc| match Eff::build(d) {
        Err(KamiError::Invalid { field, .. }) => field,
        other => panic!("expected an invalid-scene error, got {other:?}"),
    };
    let base = desc([4, 4, 4], 20.0);
    type Spoil = Box<dyn Fn(&mut EffDesc)>;
    let cases: Vec<(&str, Spoil)> = vec![
        (
            "forces.eff.resolution",
            Box::new(|d| d.resolution = [4, 0, 4]),
        ),
        (
            "forces.eff.resolution",
            Box::new(|d| d.resolution = [129, 128, 128]),
        ),
        (
            "forces.eff.resolution",
            Box::new(|d| d.resolution = [u32::MAX; 3]),
        ),
        ("forces.eff.extent", Box::new(|d| d.extent = 0.0)),
        ("forces.eff.extent", Box::new(|d| d.extent = -3.0)),
        ("forces.eff.extent", Box::new(|d| d.extent = f64::NAN)),
        (
            "forces.eff.center[1]",
            Box::new(|d| d.center[1] = f64::INFINITY),
        ),
        ("forces.eff.strength", Box::new(|d| d.strength = f64::NAN)),
        (
            "forces.eff.head[2]",
            Box::new(|d| d.head = Some([0.0, 0.0, f64::NAN])),
        ),
        (
            "forces.eff.source",
            Box::new(|d| {
                d.source = [0.0; 3];
                d.strength = 1.0
            }),
        ),
        (
            "forces.eff.samples[1].force[0]",
            Box::new(|d| {
                d.samples = vec![
                    sample(DVec3::ZERO, A),
                    sample(DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0)),
                ]
            }),
        ),
        (
            "forces.eff.samples[0].at",
            Box::new(|d| d.samples = vec![sample(DVec3::new(10.5, 0.0, 0.0), A)]),
        ),
        (
            "forces.eff.blowers[0].radius",
            Box::new(|d| {
                d.blowers = vec![Blower {
                    at: [0.0; 3],
                    toward: [1.0, 0.0, 0.0],
                    strength: 1.0,
                    radius: 0.0,
                    spread: 0.0,
                }]
            }),
        ),
        (
            "forces.eff.blowers[0].toward",
            Box::new(|d| {
                d.blowers = vec![Blower {
                    at: [0.0; 3],
                    toward: [0.0; 3],
                    strength: 1.0,
                    radius: 1.0,
                    spread: 0.0,
                }]
            }),
        ),
        (
            "forces.eff.gust[1].frame",
            Box::new(|d| {
                d.gust = vec![
                    GustKey {
                        frame: 5.0,
                        scale: 1.0,
                        interp: Interp::Step,
                    },
                    GustKey {
                        frame: 2.0,
                        scale: 1.0,
                        interp: Interp::Step,
                    },
                ]
            }),
        ),
    ];
    for (want, spoil) in cases {
        let mut d = base.clone();
        spoil(&mut d);
        assert_eq!(field_of(&d), want);
    }
    // With a file the grid is the file's: setting it in the block too is refused, and a
    // file that was never read (a scene not loaded with Scene::load) is named.
    let file = |extent: f64| EffDesc {
        file: Some("never_read.eff".into()),
        extent,
        ..EffDesc::default()
    };
    assert_eq!(field_of(&file(30.0)), "forces.eff.extent");
    assert_eq!(field_of(&file(60.0)), "forces.eff.file");
    assert!(Eff::build(&base).is_ok());
    // Extra samples (a capture fit): non-finite refused, outside the grid left out.
    assert!(Eff::from_samples(&base, &[(DVec3::ZERO, DVec3::NAN)]).is_err());
    let e = Eff::from_samples(&base, &[(DVec3::splat(50.0), A), (DVec3::ONE, B)]).unwrap();
    assert_eq!(e.defined().iter().filter(|d| **d).count(), 1);
}

/// A scene names an EFF file relative to itself: `Scene::load` reads it (errors name the
/// EFF file and line), the block's samples override its cells, and the stage's forces
/// carry the grid with the block's gust.
#[test]
fn a_scene_reads_its_eff_file() {
    let dir = temp("scene");
    std::fs::create_dir_all(dir.join("eff")).unwrap();
    let mut d = desc([4, 4, 4], 40.0);
    d.samples = vec![sample(DVec3::new(5.0, 5.0, 5.0), B)];
    d.source = [0.0, 0.0, 80.0];
    d.strength = 40.0;
    let grid = Eff::build(&d).unwrap();
    grid.save(dir.join("eff/wind.eff")).unwrap();
    let bob = std::fs::read_to_string(common::root().join("assets/scenes/bob.ron")).unwrap();
    let end = bob.rfind(')').unwrap();
    let with = |block: &str| {
        format!(
            "{}\n    forces: ForcesDesc(eff: Some({block})),\n)",
            bob[..end].trim_end()
        )
    };
    let scene_path = dir.join("scene.ron");
    std::fs::write(
        &scene_path,
        with("EffDesc(file: Some(\"eff/wind.eff\"), gust: [GustKey(frame: 0.0, scale: 2.0)])"),
    )
    .unwrap();
    let scene = kami::Scene::load(&scene_path).unwrap();
    let forces = Forces::new(&scene.forces, &scene.head);
    let e = forces.eff.as_ref().expect("the scene's EFF is built");
    assert_eq!(e.cells(), grid.cells());
    assert_eq!(e.outside(), grid.outside());
    let p = DVec3::new(5.0, 5.0, 5.0);
    assert_eq!(forces.eff_at(p, 3.0, Sampling::Nearest), B * 2.0);

    // Samples in the block override the file's cells; the file's filled cells follow.
    std::fs::write(
        &scene_path,
        with("EffDesc(file: Some(\"eff/wind.eff\"), samples: [EffSample(at: (-15.0, -15.0, -15.0), force: (0.0, 9.0, 0.0))])"),
    )
    .unwrap();
    let scene = kami::Scene::load(&scene_path).unwrap();
    let e = Forces::new(&scene.forces, &scene.head).eff.unwrap();
    assert_eq!(e.cells()[0], DVec3::new(0.0, 9.0, 0.0));
    assert_eq!(e.sample(p, Sampling::Nearest), B);
    assert_eq!(e.defined().iter().filter(|d| **d).count(), 2);
    assert_ne!(e.cells()[1], grid.cells()[1]);

    // A bad EFF file fails the scene load, naming the EFF file and its line.
    let mut text = std::fs::read_to_string(dir.join("eff/wind.eff")).unwrap();
    text = text.replacen("\nd ", "\nd NaN ", 1);
    std::fs::write(dir.join("eff/bad.eff"), text).unwrap();
    std::fs::write(&scene_path, with("EffDesc(file: Some(\"eff/bad.eff\"))")).unwrap();
    let err = kami::Scene::load(&scene_path).unwrap_err().to_string();
    assert!(
        err.contains("eff/bad.eff:") && err.contains("needs 3 numbers"),
        "{err}"
    );
    // A missing file names it too; a bad block names the field.
    std::fs::write(&scene_path, with("EffDesc(file: Some(\"eff/none.eff\"))")).unwrap();
    let err = kami::Scene::load(&scene_path).unwrap_err().to_string();
    assert!(err.contains("none.eff"), "{err}");
    std::fs::write(&scene_path, with("EffDesc(resolution: (0, 4, 4))")).unwrap();
    let err = kami::Scene::load(&scene_path).unwrap_err().to_string();
    assert!(err.contains("forces.eff.resolution"), "{err}");
}

/// The example EFF shipped in assets/eff/: a gust from the front-left of the head (+z is the
/// face, +x the head's left). Regenerate with `UPDATE_EFF=1 cargo test --test eff
/// shipped_eff_file_is_current`.
fn front_left_gust() -> EffDesc {
    kami::forces::eff::front_left_gust()
}

#[test]
fn shipped_eff_file_is_current() {
    let path = common::root().join("assets/eff/front_left_gust.eff");
    let e = Eff::build(&front_left_gust()).unwrap();
    if std::env::var("UPDATE_EFF").is_ok_and(|v| v == "1") {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        e.save(&path).unwrap();
    }
    let shipped = Eff::load(&path).unwrap_or_else(|err| {
        panic!("{err}: regenerate it with UPDATE_EFF=1 cargo test --test eff shipped_eff_file_is_current")
    });
    assert!(
        same_grid(&shipped, &e),
        "assets/eff/front_left_gust.eff is stale: regenerate it with UPDATE_EFF=1 cargo test --test eff shipped_eff_file_is_current"
    );
    // It blows from the front-left: toward -x and -z in front of the face, and some cells
    // are measured (the jets), the rest filled.
    let front = e.sample(DVec3::new(8.0, 2.0, 12.0), Sampling::Trilinear);
    assert!(front.x < -50.0 && front.z < -50.0, "{front}");
    let defined = e.defined().iter().filter(|d| **d).count();
    assert!(defined > 20 && defined < e.cell_count() / 2, "{defined}");
}

/// Same grid, outside force and cells (bit for bit), whatever the recipe.
fn same_grid(a: &Eff, b: &Eff) -> bool {
    a.dims() == b.dims()
        && a.origin() == b.origin()
        && a.cell_size() == b.cell_size()
        && a.source() == b.source()
        && a.head() == b.head()
        && a.strength() == b.strength()
        && a.defined() == b.defined()
        && a.cells() == b.cells()
}

/// Random points inside, on cell faces and centres, across the band and far outside.
fn probe_points(e: &Eff) -> Vec<[f32; 3]> {
    let (o, c) = (e.origin(), e.cell_size());
    let size = c * DVec3::new(e.dims()[0] as f64, e.dims()[1] as f64, e.dims()[2] as f64);
    let mut pts = Vec::new();
    for i in 0..4000u32 {
        let t = DVec3::new(rnd(i, 21), rnd(i, 22), rnd(i, 23));
        let p = match i % 4 {
            // Inside.
            0 => o + size * t,
            // On faces: one coordinate on a cell face.
            1 => {
                let mut p = o + size * t;
                let a = (i / 4 % 3) as usize;
                p[a] = o[a] + c[a] * (t[a] * e.dims()[a] as f64).round();
                p
            }
            // Near and across the band.
            2 => o - c * 1.5 + (size + c * 3.0) * t,
            // Far and wide.
            _ => o - size + size * 3.0 * t,
        };
        pts.push(p.as_vec3().to_array());
    }
    // Cell centres and grid corners exactly.
    for i in (0..e.cell_count()).step_by(7) {
        pts.push(e.cell_center(i).as_vec3().to_array());
    }
    pts.push(o.as_vec3().to_array());
    pts.push((o + size).as_vec3().to_array());
    pts
}

/// WGSL `eff_force` against `Eff::sample_at` (f64) at the same f32 points, both modes, with
/// a gust scale: worst error over the field's largest force <= 1e-5 (f32 rounding; measured
/// 7e-8 nearest, 4.5e-7 trilinear on lavapipe and llvmpipe). Nearest sampling on a cell face may pick either neighbour in f32, so its
/// error there is taken against the nearest reference value within 1e-4 cell.
#[test]
fn gpu_sampling_matches_the_reference() {
    let gpu = common::gpu();
    let mut d = desc([7, 5, 6], 30.0);
    d.center = [1.5, -3.0, 2.0];
    d.head = Some([0.0, 0.0, 0.0]);
    d.source = [40.0, 20.0, -60.0];
    d.strength = 80.0;
    d.samples = (0..30)
        .map(|i| {
            sample(
                DVec3::from(d.center) + (DVec3::new(rnd(i, 1), rnd(i, 2), rnd(i, 3)) - 0.5) * 29.0,
                (DVec3::new(rnd(i, 4), rnd(i, 5), rnd(i, 6)) - 0.5) * 400.0,
            )
        })
        .collect();
    d.gust = vec![
        GustKey {
            frame: 0.0,
            scale: 1.0,
            interp: Interp::Linear,
        },
        GustKey {
            frame: 10.0,
            scale: 2.0,
            interp: Interp::Step,
        },
    ];
    let e = Eff::build(&d).unwrap();
    let frame = 7.0;
    let scale = e.scale_at(frame);
    assert_eq!(scale, 1.7);
    let g = EffGpu::new(gpu, Some(&e)).unwrap();
    g.write(gpu, Some(&e), frame);
    let pts = probe_points(&e);
    let delta = e.cell_size() * 1e-4;
    for sampling in [Sampling::Nearest, Sampling::Trilinear] {
        let out = world::sample_on_gpu(gpu, &g, &pts, sampling).unwrap();
        let mut worst = 0.0f64;
        for (p, v) in pts.iter().zip(&out) {
            let p = glam::Vec3::from(*p).as_dvec3();
            let v = glam::Vec3::from(*v).as_dvec3();
            let err = |q: DVec3| (e.sample_at(q, frame, sampling) - v).length();
            let mut best = err(p);
            if sampling == Sampling::Nearest {
                for k in 0..27 {
                    let s = DVec3::new((k % 3) as f64, (k / 3 % 3) as f64, (k / 9) as f64) - 1.0;
                    best = best.min(err(p + s * delta));
                }
            }
            worst = worst.max(best);
        }
        let rel = worst / (e.max_force() * scale);
        eprintln!("{sampling:?}: worst GPU error {worst:.3e} ({rel:.2e} of the largest force)");
        assert!(rel < 1e-5, "{sampling:?}: {rel:e}");
    }
    // No field: zero everywhere; a grid of another size written to it reads as no field.
    let none = EffGpu::new(gpu, None).unwrap();
    let out = world::sample_on_gpu(gpu, &none, &pts[..64], Sampling::Trilinear).unwrap();
    assert!(out.iter().all(|v| *v == [0.0; 3]));
    none.write(gpu, Some(&e), frame);
    let out = world::sample_on_gpu(gpu, &none, &pts[..64], Sampling::Trilinear).unwrap();
    assert!(out.iter().all(|v| *v == [0.0; 3]));
    // Painted cells reach the GPU with write_cells.
    let mut painted = e.clone();
    painted.paint(DVec3::from(d.center), 8.0, DVec3::new(0.0, 999.0, 0.0), 1.0);
    g.write_cells(gpu, &painted).unwrap();
    let c = DVec3::from(d.center).as_vec3().to_array();
    let out = world::sample_on_gpu(gpu, &g, &[c], Sampling::Nearest).unwrap();
    let want = painted.sample_at(glam::Vec3::from(c).as_dvec3(), frame, Sampling::Nearest);
    assert!((glam::Vec3::from(out[0]).as_dvec3() - want).length() < 1e-3 * want.length());
}

/// The world's EFF grid stays at gust scale 1 when an edit that fits rewrites it in place:
/// every kernel scales by its own substep's gust, so the world must not scale too (the
/// rewrite once passed a frame where the grid's writer takes a scale). Read through
/// `eff_force`, which multiplies by the grid's scale, far outside the grid.
#[test]
fn the_world_keeps_the_eff_unscaled_after_an_edit() {
    let gpu = common::gpu();
    let mut d = desc([5, 4, 6], 30.0);
    d.strength = 80.0;
    d.gust = vec![GustKey {
        frame: 0.0,
        scale: 0.5,
        interp: Interp::Step,
    }];
    let e = Eff::build(&d).unwrap();
    let head = kami::scene::Head::default();
    let mut forces = Forces::new(&Default::default(), &head);
    forces.eff = Some(std::sync::Arc::new(e.clone()));
    let hull = kami::scene::hull::head_hull(&head).unwrap();
    let mut w = kami::systems::world::WorldGpu::new(gpu, &forces, &hull).unwrap();
    let far = [[1e4f32, 2e3, -3e3]];
    let want = e.outside();
    let read = |w: &kami::systems::world::WorldGpu| {
        let v = world::sample_on_gpu(gpu, w.eff(), &far, Sampling::Nearest).unwrap()[0];
        glam::Vec3::from(v).as_dvec3()
    };
    assert!((read(&w) - want).length() < 1e-4 * want.length(), "new");
    // An edit that fits: painted cells, the same grid.
    let mut painted = e.clone();
    painted.paint(DVec3::from(d.center), 8.0, DVec3::new(0.0, 50.0, 0.0), 1.0);
    forces.eff = Some(std::sync::Arc::new(painted));
    assert!(w.fits(&forces, &hull));
    w.write(gpu, &forces, &hull).unwrap();
    let got = read(&w);
    assert!(
        (got - want).length() < 1e-4 * want.length(),
        "after an edit the world's grid reads {got}, not the unscaled {want}"
    );
}
