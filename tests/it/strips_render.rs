//! The look of the Hair Object Model (Kazama et al. 2.1): the layered rest strips (`hom`),
//! the generated strand texture and its mips (`texture`), the ribbon kernel against its f64
//! reference (`ribbon`), and the ribbons drawn offscreen with their alpha gaps.

use crate::common;

use glam::{DMat4, DQuat, DVec3, Mat4, Vec3, Vec4};
use kami::gpu::gpu_data::GpuFrame;
use kami::gpu::pipeline::Variant;
use kami::gpu::{self, Gpu};
use kami::rng::Rng;
use kami::scene::Shading;
use kami::scene::{Ellipsoid, Head};
use kami::stage::target::{DownsamplePass, Offscreen, SceneTargets, SCENE_FORMAT};
use kami::systems::hair_bsdf;
use kami::systems::strips::block::{Layer, Look, Strips};
use kami::systems::strips::ribbon::{self, GpuRibbonVertex, RibbonPass, RibbonVertex};
use kami::systems::strips::sky::SKY_SAMPLES;
use kami::systems::strips::{hom, texture, RestStrip};
use kami::KamiError;

fn layer(count: u32, polar: f64, azimuth: [f64; 2]) -> Layer {
    Layer {
        name: String::new(),
        count,
        polar,
        azimuth,
        length: 24.0,
        sticks: 8,
        width: [3.0, 0.6],
        droop: 0.6,
        curl: 0.0,
        stiffness: 1.0,
        color: [0.16, 0.09, 0.05],
    }
}

fn strips(layers: Vec<Layer>) -> Strips {
    Strips {
        layers,
        motion: Default::default(),
        look: Default::default(),
        edits: Vec::new(),
    }
}

/// A layered bob: an inner ring all round, a back layer, a fringe, with curl and droop.
fn bob() -> Strips {
    let mut inner = layer(12, 55.0, [0.0, 360.0]);
    inner.curl = 12.0;
    inner.droop = 0.8;
    let mut back = layer(9, 35.0, [90.0, 270.0]);
    back.length = 30.0;
    back.sticks = 10;
    back.stiffness = 0.7;
    back.color = [0.2, 0.1, 0.06];
    let mut fringe = layer(5, 20.0, [-50.0, 50.0]);
    fringe.length = 14.0;
    fringe.sticks = 6;
    fringe.width = [2.0, 0.4];
    fringe.curl = -8.0;
    strips(vec![inner, back, fringe])
}

fn hull(head: &Head) -> Ellipsoid {
    Ellipsoid::new(head.center, head.radii)
}

fn off_center_head() -> Head {
    Head {
        center: [0.5, 1.5, -0.3],
        ..Head::default()
    }
}

/// Azimuth of a root in the layers' convention (`Ellipsoid::point`): from +x (the face)
/// toward +z.
fn azimuth_deg(head: &Head, p: DVec3) -> f64 {
    let q = (p - DVec3::from(head.center)) / DVec3::from(head.radii);
    q.z.atan2(q.x).to_degrees()
}

#[test]
fn hom_counts_roots_and_layer_values() {
    let head = off_center_head();
    let s = bob();
    let rest = hom::build(&s, &head).unwrap();
    assert_eq!(hom::strip_count(&s), 26);
    assert_eq!(rest.len(), 26);
    let e = hull(&head);
    let mut i = 0;
    for (li, l) in s.layers.iter().enumerate() {
        for _ in 0..l.count {
            let r = &rest[i];
            assert_eq!(r.layer, li as u32);
            assert_eq!(r.points.len(), l.sticks as usize + 1);
            assert_eq!(
                (r.width, r.stiffness, r.color),
                (l.width, l.stiffness, l.color)
            );
            let root = r.points[0];
            assert!(
                e.eval(root).abs() < 1e-9,
                "root off the head: {}",
                e.eval(root)
            );
            let (theta, _) = e.polar(root);
            assert!(
                (theta.to_degrees() - l.polar).abs() < 1e-9,
                "layer {li} root at polar {} not {}",
                theta.to_degrees(),
                l.polar
            );
            assert!((r.normal - e.normal(root)).length() < 1e-12);
            i += 1;
        }
    }
}

#[test]
fn hom_stays_outside_the_head_with_exact_sticks() {
    // Shapes that would go through the head: hanging straight down past the bulge from
    // above the equator, curling hard under, and pointing into it with negative curl.
    let head = off_center_head();
    let mut hang = layer(8, 50.0, [0.0, 360.0]);
    hang.droop = 1.0;
    let mut curl = layer(8, 70.0, [0.0, 360.0]);
    curl.curl = 35.0;
    curl.length = 40.0;
    let mut inward = layer(6, 30.0, [0.0, 300.0]);
    inward.droop = 0.0;
    inward.curl = -40.0;
    let s = strips(vec![hang, curl, inward]);
    let rest = hom::build(&s, &head).unwrap();
    let e = hull(&head);
    let mut pushed = 0;
    for r in &rest {
        let l = &s.layers[r.layer as usize];
        let stick = l.length / l.sticks as f64;
        for (k, w) in r.points.windows(2).enumerate() {
            let len = (w[1] - w[0]).length();
            assert!(
                (len - stick).abs() < 1e-9 * stick,
                "stick {k} has length {len}, not {stick}"
            );
            assert!(e.eval(w[1]) > 0.0, "point {} inside the head", k + 1);
            // Within reach of the layer's shell: the point was pushed onto it.
            if e.eval(w[1]) < 0.2 {
                pushed += 1;
            }
        }
    }
    assert!(
        pushed > 20,
        "these shapes should rest on the head ({pushed} points do)"
    );
}

#[test]
fn hom_droop_and_curl_shape_the_rest() {
    let head = Head::default();
    let e = hull(&head);
    // Below the equator nothing blocks a strip: droop 1 hangs straight down.
    let mut hang = layer(6, 110.0, [0.0, 360.0]);
    hang.droop = 1.0;
    for r in hom::build(&strips(vec![hang.clone()]), &head).unwrap() {
        for w in r.points.windows(2) {
            let d = (w[1] - w[0]).normalize();
            assert!(
                (d + DVec3::Y).length() < 1e-12,
                "droop 1 should hang down: {d}"
            );
        }
    }
    // Droop 0 leaves along the normal and stays straight.
    hang.droop = 0.0;
    for r in hom::build(&strips(vec![hang.clone()]), &head).unwrap() {
        for w in r.points.windows(2) {
            let d = (w[1] - w[0]).normalize();
            assert!(
                (d - r.normal).length() < 1e-12,
                "droop 0 should follow the normal"
            );
        }
    }
    // Curl turns each stick by `curl` degrees, outward → down → under (toward the head).
    hang.droop = 1.0;
    hang.curl = 10.0;
    for r in hom::build(&strips(vec![hang]), &head).unwrap() {
        let dirs: Vec<DVec3> = r
            .points
            .windows(2)
            .map(|w| (w[1] - w[0]).normalize())
            .collect();
        for w in dirs.windows(2) {
            let angle = w[0].dot(w[1]).clamp(-1.0, 1.0).acos().to_degrees();
            assert!((angle - 10.0).abs() < 1e-9, "curl turned by {angle}");
        }
        let inward = -(r.points[0] - e.center).with_y(0.0).normalize();
        assert!(
            dirs.last().unwrap().dot(inward) > 0.5,
            "positive curl should tuck the tip under toward the head"
        );
    }
}

#[test]
fn hom_azimuths_spread_over_the_range() {
    let head = off_center_head();
    let cases: [(u32, [f64; 2], Vec<f64>); 4] = [
        (5, [-60.0, 60.0], vec![-60.0, -30.0, 0.0, 30.0, 60.0]),
        (4, [0.0, 360.0], vec![0.0, 90.0, 180.0, -90.0]),
        (1, [90.0, 150.0], vec![120.0]),
        (3, [150.0, 210.0], vec![150.0, 180.0, -150.0]),
    ];
    for (n, range, want) in cases {
        let rest = hom::build(&strips(vec![layer(n, 80.0, range)]), &head).unwrap();
        let got: Vec<f64> = rest
            .iter()
            .map(|r| azimuth_deg(&head, r.points[0]))
            .collect();
        for (g, w) in got.iter().zip(&want) {
            let d = (g - w).rem_euclid(360.0);
            assert!(
                d.min(360.0 - d) < 1e-9,
                "range {range:?}: azimuths {got:?}, want {want:?}"
            );
        }
    }
}

/// Two identical layers: the inner one rests on the head closer than the outer one, and the
/// outer one stays outside where the inner one lies.
#[test]
fn hom_inner_layers_lie_closer_to_the_head() {
    let head = Head::default();
    let e = hull(&head);
    let mut l = layer(10, 45.0, [0.0, 360.0]);
    l.droop = 1.0;
    let rest = hom::build(&strips(vec![l.clone(), l]), &head).unwrap();
    let (inner, outer) = rest.split_at(10);
    let margin = hom::SHELL * DVec3::from(head.radii).element_sum() / 3.0;
    let mut closer = 0;
    for (a, b) in inner.iter().zip(outer) {
        assert_eq!(a.points[0], b.points[0], "same roots");
        for (p, q) in a.points.iter().zip(&b.points).skip(1) {
            assert!(
                e.eval(*p) <= e.eval(*q) + 1e-12,
                "the inner layer is outside the outer"
            );
            if e.eval(*p) < e.eval(*q) - 1e-3 {
                closer += 1;
            }
            // Each layer is outside its own shell.
            for (pt, shell) in [(p, margin), (q, 2.0 * margin)] {
                let s = Ellipsoid {
                    center: e.center,
                    radii: e.radii + DVec3::splat(shell),
                };
                assert!(s.eval(*pt) >= -1e-9, "a point inside its layer's shell");
            }
        }
    }
    assert!(
        closer >= 10,
        "the layers rest on the head at the same height ({closer})"
    );
}

#[test]
fn hom_is_deterministic_and_rejects_bad_layers() {
    let head = off_center_head();
    assert_eq!(
        hom::build(&bob(), &head).unwrap(),
        hom::build(&bob(), &head).unwrap()
    );
    type Break = Box<dyn Fn(&mut Layer)>;
    let bad: Vec<(&str, Break)> = vec![
        ("count", Box::new(|l| l.count = 0)),
        ("polar", Box::new(|l| l.polar = 0.0)),
        ("polar", Box::new(|l| l.polar = f64::NAN)),
        ("azimuth", Box::new(|l| l.azimuth = [40.0, 10.0])),
        ("length", Box::new(|l| l.length = -1.0)),
        ("sticks", Box::new(|l| l.sticks = 0)),
        ("sticks", Box::new(|l| l.sticks = 1 << 30)),
        ("width[0]", Box::new(|l| l.width = [0.0, 1.0])),
        ("droop", Box::new(|l| l.droop = 1.5)),
        ("curl", Box::new(|l| l.curl = f64::INFINITY)),
        ("color[0]", Box::new(|l| l.color = [2.0, 0.0, 0.0])),
    ];
    for (field, f) in bad {
        let mut s = bob();
        f(&mut s.layers[1]);
        match hom::build(&s, &head) {
            Err(KamiError::Invalid { field: got, .. }) => {
                assert_eq!(got, format!("strips.layers[1].{field}"))
            }
            other => panic!("bad {field} gave {other:?}"),
        }
    }
    let mut s = bob();
    s.layers[0].count = u32::MAX;
    s.layers[1].count = u32::MAX;
    assert!(
        hom::build(&s, &head).is_err(),
        "billions of strips must not allocate"
    );
}

// ---------------------------------------------------------------- texture

fn alpha_rows(tex: &[[u8; 4]], w: u32, h: u32) -> Vec<f64> {
    (0..h as usize)
        .map(|y| {
            tex[y * w as usize..(y + 1) * w as usize]
                .iter()
                .map(|t| t[3] as f64 / 255.0)
                .sum::<f64>()
                / w as f64
        })
        .collect()
}

/// Runs of texels below the alpha cutoff strictly inside a row (the gaps between hairs).
fn gaps(row: &[[u8; 4]], cutoff: f32) -> usize {
    let below = |t: &[u8; 4]| (t[3] as f32) < cutoff * 255.0;
    let mut n = 0;
    let mut seen_hair = false;
    let mut in_gap = false;
    for t in row {
        if below(t) {
            in_gap |= seen_hair;
        } else {
            if in_gap {
                n += 1;
            }
            in_gap = false;
            seen_hair = true;
        }
    }
    n
}

#[test]
fn texture_has_hairs_gaps_and_ragged_ends() {
    let look = Look::default();
    let (w, h) = texture::texture_size(&look);
    assert_eq!((w, h), (128, 256));
    let tex = texture::strand_texture(&look, w, h);
    assert_eq!(tex.len(), (w * h) as usize);
    let rows = alpha_rows(&tex, w, h);
    let body = |v: f64| rows[(v * h as f64) as usize];
    // Along the body the hairs cover about two thirds of the strip, with a gap between
    // nearly every pair of hairs.
    let body_mean = (25..180).map(|y| rows[y]).sum::<f64>() / 155.0;
    assert!((0.5..0.8).contains(&body_mean), "body coverage {body_mean}");
    for y in (10..200).step_by(10) {
        let g = gaps(
            &tex[y * w as usize..(y + 1) * w as usize],
            look.alpha_cutoff,
        );
        assert!(
            g + 4 >= look.hairs as usize,
            "row {y}: {g} gaps between {} hairs",
            look.hairs
        );
    }
    // The ends are spread: coverage falls gradually over the last TIP_SPREAD + TIP_TAPER.
    assert!(body(0.8) > 0.8 * body_mean, "hairs end too early");
    assert!(
        body(0.9) < 0.85 * body_mean && body(0.9) > 0.15 * body_mean,
        "ends not spread: {}",
        body(0.9)
    );
    assert!(
        body(0.995) < 0.1 * body_mean,
        "hairs reach the tip row: {}",
        body(0.995)
    );
    // Different hairs end on different rows.
    let ends: std::collections::BTreeSet<usize> = (0..w as usize)
        .filter_map(|x| {
            (0..h as usize)
                .rev()
                .find(|&y| tex[y * w as usize + x][3] > 128)
        })
        .collect();
    assert!(ends.len() >= 10, "hair ends on only {} rows", ends.len());
}

/// Alpha-weighted mean brightness of a range of rows.
fn brightness(tex: &[[u8; 4]], w: u32, rows: std::ops::Range<usize>) -> f64 {
    let (mut s, mut a) = (0.0, 0.0);
    for y in rows {
        for t in &tex[y * w as usize..(y + 1) * w as usize] {
            s += t[0] as f64 * t[3] as f64;
            a += t[3] as f64;
        }
    }
    s / a
}

/// The root-to-tip gradient as the scene defines it: 1 at the root, `tip_shade` at the tip,
/// linear between.
fn gradient(tip_shade: f32, v: f64) -> f64 {
    1.0 + (tip_shade as f64 - 1.0) * v
}

#[test]
fn texture_gradient_runs_root_to_tip() {
    for tip in [1.6f32, 0.5] {
        let look = Look {
            tip_shade: tip,
            ..Look::default()
        };
        let (w, h) = texture::texture_size(&look);
        let tex = texture::strand_texture(&look, w, h);
        let root = brightness(&tex, w, 0..16);
        let tip_rows = brightness(&tex, w, 200..216);
        // Rows 0..16 sit at v ≈ 0.03 and 200..216 at v ≈ 0.81.
        let want = gradient(tip, 0.812) / gradient(tip, 0.031);
        let got = tip_rows / root;
        assert!(
            (got / want - 1.0).abs() < 0.03,
            "tip_shade {tip}: tip/root {got}, want {want}"
        );
        // The shader gain brings the stored values back to the gradient.
        let hair_mean = 0.89; // the hairs' mean brightness
        let abs_root = root / 255.0 * texture::gain(&look) as f64;
        assert!(
            (abs_root / (hair_mean * gradient(tip, 0.031)) - 1.0).abs() < 0.05,
            "root brightness {abs_root}"
        );
    }
}

#[test]
fn texture_is_deterministic() {
    let look = Look::default();
    let (w, h) = texture::texture_size(&look);
    assert_eq!(
        texture::strand_texture(&look, w, h),
        texture::strand_texture(&look, w, h)
    );
    let other = Look {
        hairs: 30,
        ..Look::default()
    };
    assert_ne!(
        texture::strand_texture(&look, w, h),
        texture::strand_texture(&other, w, h)
    );
}

#[test]
fn texture_mips_average_their_blocks() {
    let look = Look::default();
    let (w, h) = texture::texture_size(&look);
    let base = texture::strand_texture(&look, w, h);
    let levels = texture::mip_chain(&base, w, h);
    assert_eq!(levels.len(), 9, "256 texels tall: levels 256 down to 1");
    assert_eq!((levels[1].width, levels[1].height), (64, 128));
    assert_eq!((levels[8].width, levels[8].height), (1, 1));
    let overall = base.iter().map(|t| t[3] as f64).sum::<f64>() / base.len() as f64;
    for (k, l) in levels.iter().enumerate() {
        assert_eq!(l.texels.len(), (l.width * l.height) as usize);
        let (bw, bh) = (w / l.width, h / l.height);
        let mut worst: f64 = 0.0;
        for y in 0..l.height {
            for x in 0..l.width {
                let (mut sa, mut sc, mut n) = (0.0, 0.0, 0.0);
                for yy in y * bh..(y + 1) * bh {
                    for xx in x * bw..(x + 1) * bw {
                        let t = base[(yy * w + xx) as usize];
                        sa += t[3] as f64;
                        sc += t[0] as f64 * t[3] as f64;
                        n += 1.0;
                    }
                }
                let t = l.texels[(y * l.width + x) as usize];
                worst = worst.max((t[3] as f64 - sa / n).abs());
                if sa > 0.0 {
                    worst = worst.max((t[0] as f64 - sc / sa).abs());
                }
            }
        }
        assert!(
            worst <= 0.5 + 1e-9,
            "level {k}: a texel is {worst} off its block's average"
        );
        let mean = l.texels.iter().map(|t| t[3] as f64).sum::<f64>() / l.texels.len() as f64;
        assert!(
            (mean - overall).abs() < 0.5,
            "level {k} mean alpha {mean} vs {overall}"
        );
    }
}

// ---------------------------------------------------------------- ribbons

/// The bob's rest strips with every joint turned a little at random and the head pose
/// applied: a moved, three-dimensional set of chains (fixed seed). Strips 0 and 1 get a
/// zero-length stick and a full fold, the kernel's fallbacks.
fn moved(rest: &[RestStrip], stride: usize, pose: &DMat4) -> Vec<DVec3> {
    let mut rng = Rng::new(11, 0);
    let mut out = Vec::with_capacity(rest.len() * stride);
    for (s, r) in rest.iter().enumerate() {
        let mut p = vec![pose.transform_point3(r.points[0])];
        let mut turn = DQuat::IDENTITY;
        for (k, w) in r.points.windows(2).enumerate() {
            let axis = DVec3::new(rng.normal(), rng.normal(), rng.normal()).normalize();
            turn = DQuat::from_axis_angle(axis, rng.range(0.0, 0.5)) * turn;
            let mut d = pose.transform_vector3(turn * (w[1] - w[0]));
            if s == 0 && k == 2 {
                d = DVec3::ZERO;
            }
            if s == 1 && k == 3 {
                d = -(p[k] - p[k - 1]);
            }
            p.push(p[k] + d);
        }
        while p.len() < stride {
            p.push(*p.last().unwrap());
        }
        out.extend(p);
    }
    out
}

fn pose() -> DMat4 {
    DMat4::from_rotation_translation(
        DQuat::from_euler(glam::EulerRot::YXZ, 0.6, -0.3, 0.2),
        DVec3::new(1.0, -2.0, 0.5),
    )
}

#[test]
fn ribbon_reference_is_flat_tapered_and_untwisted() {
    let head = Head::default();
    let rest = hom::build(&bob(), &head).unwrap();
    let info = ribbon::strip_info(&rest);
    let stride = 11;
    let mut points = Vec::new();
    for r in &rest {
        let mut p = r.points.clone();
        p.resize(stride, *r.points.last().unwrap());
        points.extend(p);
    }
    let verts = ribbon::ribbon_reference(&points, stride, &info, &DMat4::IDENTITY);
    assert_eq!(verts.len(), 2 * rest.len() * stride);
    for (s, (r, inf)) in rest.iter().zip(&info).enumerate() {
        let n = r.points.len();
        for k in 0..stride {
            let (a, b) = (verts[2 * (s * stride + k)], verts[2 * (s * stride + k) + 1]);
            let kk = k.min(n - 1);
            let along = kk as f64 / (n - 1) as f64;
            let width = r.width[0] + (r.width[1] - r.width[0]) * along;
            assert!(((b.position - a.position).length() - width).abs() < 1e-12);
            assert!(((a.position + b.position) * 0.5 - r.points[kk]).length() < 1e-12);
            assert_eq!((a.u, b.u, a.v), (0.0, 1.0, along));
            let side = (b.position - a.position) / width;
            assert!(
                side.dot(a.tangent).abs() < 1e-12,
                "side not across the strip"
            );
            assert!((a.tangent.length() - 1.0).abs() < 1e-12);
            // The tangent: along the sticks at the ends, between them (the central
            // difference, as the sticks have equal lengths) inside.
            let (lo, hi) = (kk.saturating_sub(1), (kk + 1).min(n - 1));
            let want = (r.points[hi] - r.points[lo]).normalize();
            assert!(
                (a.tangent - want).length() < 1e-12,
                "strip {s} point {k}: tangent"
            );
            // A rest strip lies in the plane normal to the ring tangent: the side vector is
            // that tangent at every point (no twist).
            assert!(
                (side - inf.side).length() < 1e-9,
                "strip {s} point {k}: side {side} twisted from {}",
                inf.side
            );
        }
    }
    // Turning the head and the points together turns the ribbon with them.
    let m = pose();
    let turned: Vec<DVec3> = points.iter().map(|p| m.transform_point3(*p)).collect();
    let verts2 = ribbon::ribbon_reference(&turned, stride, &info, &m);
    for (a, b) in verts.iter().zip(&verts2) {
        assert!((m.transform_point3(a.position) - b.position).length() < 1e-9);
        assert!((m.transform_vector3(a.tangent) - b.tangent).length() < 1e-9);
    }
}

/// A helix (curved and twisted): each side vector is the previous one turned by the
/// smallest rotation taking the previous tangent to this one, so its component along that
/// rotation's axis is kept exactly (a Frenet frame or a projected fixed vector would not).
#[test]
fn ribbon_side_is_parallel_transported() {
    let n = 40;
    let points: Vec<DVec3> = (0..n)
        .map(|k| {
            let a = k as f64 * 0.25;
            DVec3::new(4.0 * a.cos(), -0.8 * k as f64, 4.0 * a.sin())
        })
        .collect();
    let info = [ribbon::StripInfo {
        points: n as u32,
        layer: 0,
        width: [2.0, 2.0],
        color: [1.0; 3],
        side: DVec3::X,
        normal: DVec3::Z,
    }];
    let v = ribbon::ribbon_reference(&points, n, &info, &DMat4::IDENTITY);
    let side = |k: usize| (v[2 * k + 1].position - v[2 * k].position) / 2.0;
    let mut turned = 0.0;
    for k in 0..n - 1 {
        let (t0, t1) = (v[2 * k].tangent, v[2 * k + 2].tangent);
        let axis = t0.cross(t1).normalize();
        let (s0, s1) = (side(k), side(k + 1));
        assert!(
            s1.dot(t1).abs() < 1e-12,
            "point {k}: side not across the strip"
        );
        assert!(
            (s1.dot(axis) - s0.dot(axis)).abs() < 1e-12,
            "point {k}: side turned about more than the tangents' rotation"
        );
        turned += s0.angle_between(s1);
    }
    assert!(
        turned > 1.0,
        "the helix should turn the side vector ({turned} rad)"
    );
}

fn points_buffer(gpu: &Gpu, points: &[DVec3]) -> wgpu::Buffer {
    let data: Vec<[f32; 4]> = points
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32, 1.0])
        .collect();
    gpu::storage_buffer(
        &gpu.device,
        "test points",
        bytemuck::cast_slice(&data),
        wgpu::BufferUsages::empty(),
    )
}

fn frame_layout(gpu: &Gpu) -> wgpu::BindGroupLayout {
    kami::gpu::shadow::frame_layout(&gpu.device)
}

#[test]
fn ribbon_kernel_matches_the_f64_reference() {
    let gpu = common::gpu();
    let head = off_center_head();
    let rest = hom::build(&bob(), &head).unwrap();
    let stride = 12;
    let m = pose();
    let points = moved(&rest, stride, &m);
    let layout = frame_layout(gpu);
    let pass = RibbonPass::new(
        gpu,
        &rest,
        stride,
        &Look::default(),
        &layout,
        SCENE_FORMAT,
        Variant::samples(1),
    )
    .unwrap();
    // First from another points buffer (the rest pose), then from the moved points: the
    // pass binds the buffer it is given.
    let mut still = Vec::new();
    for r in &rest {
        let mut p = r.points.clone();
        p.resize(stride, *r.points.last().unwrap());
        still.extend(p);
    }
    let first = points_buffer(gpu, &still);
    let buffer = points_buffer(gpu, &points);
    for b in [&first, &buffer] {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        pass.record(gpu, &mut enc, b, &m).unwrap();
        gpu.queue.submit([enc.finish()]);
    }
    let n = 2 * rest.len() * stride;
    let got: Vec<GpuRibbonVertex> = gpu::read_buffer(
        gpu,
        pass.vertices(),
        (n * std::mem::size_of::<GpuRibbonVertex>()) as u64,
    )
    .unwrap();
    // The reference reads the same f32-rounded points the kernel reads.
    let rounded: Vec<DVec3> = points.iter().map(|p| p.as_vec3().as_dvec3()).collect();
    let want: Vec<RibbonVertex> =
        ribbon::ribbon_reference(&rounded, stride, &ribbon::strip_info(&rest), &m);
    let (mut pos, mut tan, mut uv) = (0.0f64, 0.0f64, 0.0f64);
    let mut at = 0;
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        let p = Vec3::from_slice(&g.position[..3]).as_dvec3();
        let t = Vec3::from_slice(&g.tangent[..3]).as_dvec3();
        let e = (p - w.position).length();
        if e > pos {
            pos = e;
            at = i;
        }
        tan = tan.max((t - w.tangent).length());
        uv = uv
            .max((g.position[3] as f64 - w.u).abs())
            .max((g.tangent[3] as f64 - w.v).abs());
    }
    println!("{}: ribbon kernel vs f64: worst position {pos:.3e} cm (vertex {at}), tangent {tan:.3e}, uv {uv:.3e}", gpu.describe());
    // Positions are ~20 cm (f32 ulp ~2e-6); sides and tangents are rebuilt per point.
    assert!(pos < 1e-5, "worst position error {pos} at vertex {at}");
    assert!(tan < 1e-6, "worst tangent error {tan}");
    assert!(uv < 1e-6, "worst u/v error {uv}");
    gpu.take_error().unwrap();
}

#[test]
fn ribbon_pass_rejects_a_short_points_buffer_and_stride() {
    let gpu = common::gpu();
    let rest = hom::build(&bob(), &Head::default()).unwrap();
    let layout = frame_layout(gpu);
    assert!(RibbonPass::new(
        gpu,
        &rest,
        5,
        &Look::default(),
        &layout,
        SCENE_FORMAT,
        Variant::samples(1)
    )
    .is_err());
    let pass = RibbonPass::new(
        gpu,
        &rest,
        11,
        &Look::default(),
        &layout,
        SCENE_FORMAT,
        Variant::samples(1),
    )
    .unwrap();
    let short = points_buffer(gpu, &vec![DVec3::ZERO; 11 * rest.len() - 1]);
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    let err = pass
        .record(gpu, &mut enc, &short, &DMat4::IDENTITY)
        .unwrap_err();
    assert!(err.to_string().contains("points buffer"), "{err}");
}

/// The two modules validate with naga without a GPU (until the strips kind lists them in
/// `kami::stage::shaders()`, which `tests/it/shader_validation.rs` walks).
#[test]
fn ribbon_shaders_validate() {
    for (name, source) in [
        ("strips/ribbon", ribbon::RIBBON),
        ("strips/draw", ribbon::DRAW),
    ] {
        let module = naga::front::wgsl::parse_str(source)
            .unwrap_or_else(|e| panic!("{name} does not parse:\n{}", e.emit_to_string(source)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::MULTISAMPLED_SHADING,
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name} does not validate:\n{}", e.emit_to_string(source)));
    }
}

// ---------------------------------------------------------------- drawing

const SIZE: u32 = 256;
/// Half the orthographic view, world units: 16 pixels per unit.
const HALF: f32 = 8.0;

/// One strip hanging straight down in the plane z = 0 from y = 6 to y = −6, 6 wide at the
/// root and 2 at the tip, facing the camera on +z.
fn test_strip() -> RestStrip {
    RestStrip {
        layer: 0,
        points: (0..=6)
            .map(|k| DVec3::new(0.0, 6.0 - 2.0 * k as f64, 0.0))
            .collect(),
        normal: DVec3::Z,
        width: [6.0, 2.0],
        stiffness: 1.0,
        color: [0.5, 0.3, 0.15],
    }
}

fn frame(size: (u32, u32), samples: u32) -> GpuFrame {
    let eye = Vec3::new(0.0, 0.0, 50.0);
    // Orthographic along −z from the eye: x, y scaled by 1 / HALF, depth 0..1 over 1..100.
    let vp = Mat4::from_rows(
        Vec4::new(1.0 / HALF, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 1.0 / HALF, 0.0, 0.0),
        Vec4::new(0.0, 0.0, -1.0 / 99.0, (eye.z - 1.0) / 99.0),
        Vec4::new(0.0, 0.0, 0.0, 1.0),
    );
    GpuFrame {
        view_proj: vp.to_cols_array_2d(),
        eye: [eye.x, eye.y, eye.z, 1.0],
        // From the upper right, in front: diffuse sin(T, L) = 0.82, little specular.
        light_dir: [0.57735, 0.57735, 0.57735, 1.0],
        light_color: [1.0, 1.0, 1.0, 0.1],
        viewport: [
            size.0 as f32,
            size.1 as f32,
            1.0 / size.0 as f32,
            1.0 / size.1 as f32,
        ],
        raster: [1.0, 1.0, 1.0, samples as f32],
        flags: [0.0, 1.0, 0.0, 0.0],
        shadow: Default::default(),
    }
}

/// Draw the test strip (8 hairs, so each is several pixels wide) with `samples` MSAA
/// samples through the stage's scene targets and resolve, on black.
fn render(gpu: &Gpu, samples: u32, look: &Look) -> image::RgbaImage {
    render_with(gpu, samples, look, None)
}

/// [`render`], or with `sky` (one strip's hidden-sky index) in the physical mode under the
/// ambient light alone.
fn render_with(
    gpu: &Gpu,
    samples: u32,
    look: &Look,
    sky: Option<[f32; SKY_SAMPLES]>,
) -> image::RgbaImage {
    render_tilted(gpu, samples, look, sky, 0.0)
}

/// [`render_with`], the strip turned about its axis by `tilt` radians (its width on screen
/// times cos tilt).
fn render_tilted(
    gpu: &Gpu,
    samples: u32,
    look: &Look,
    sky: Option<[f32; SKY_SAMPLES]>,
    tilt: f64,
) -> image::RgbaImage {
    let mut strip = test_strip();
    strip.normal = DVec3::new(tilt.sin(), 0.0, tilt.cos());
    render_strip(gpu, samples, look, sky, strip)
}

/// [`render_with`] of `strip` (7 control points).
fn render_strip(
    gpu: &Gpu,
    samples: u32,
    look: &Look,
    sky: Option<[f32; SKY_SAMPLES]>,
    strip: RestStrip,
) -> image::RgbaImage {
    let rest = vec![strip];
    let layout = frame_layout(gpu);
    // Built with the default look and MSAA off, then changed: the look and the sample count
    // reach the pipeline and the texture.
    let mut pass = RibbonPass::new(
        gpu,
        &rest,
        8,
        &Look::default(),
        &layout,
        SCENE_FORMAT,
        Variant::samples(1),
    )
    .unwrap();
    pass.set_variant(gpu, Variant::samples(samples));
    if let Some(sky) = sky {
        pass.set_shading(Shading::Physical);
        pass.set_sky(gpu, &[sky]).unwrap();
    }
    pass.write_look(gpu, look).unwrap();
    assert_eq!(pass.texture().size, texture::texture_size(look));
    let mut pts = rest[0].points.clone();
    pts.resize(8, *pts.last().unwrap());
    let points = points_buffer(gpu, &pts);
    let targets = SceneTargets::new(gpu, (SIZE, SIZE), samples, 1, false).unwrap();
    let mut f = frame(targets.size, samples);
    if sky.is_some() {
        // No direct light; an ambient strong enough that the dark hair reads well in 8 bits.
        f.light_dir[3] = 0.0;
        f.light_color[3] = SKY_AMBIENT;
    }
    let frame_buffer = gpu::storage_buffer(
        &gpu.device,
        "frame",
        bytemuck::bytes_of(&f),
        wgpu::BufferUsages::UNIFORM,
    );
    let frame_bg =
        kami::gpu::shadow::frame_group_without_shadows(&gpu.device, &layout, &frame_buffer);
    let out = Offscreen::new(gpu, (SIZE, SIZE)).unwrap();
    let down = DownsamplePass::new(gpu, out.format).unwrap();
    let down_bg = down.bind(gpu, &targets, None);
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    pass.record(gpu, &mut enc, &points, &DMat4::IDENTITY)
        .unwrap();
    {
        let mut rp = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("strips test"),
            color_attachments: &[Some(targets.color_attachment(wgpu::Color::BLACK))],
            depth_stencil_attachment: Some(targets.depth_attachment(false)),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        rp.set_bind_group(0, &frame_bg, &[]);
        pass.draw(&mut rp);
    }
    down.draw(
        &mut enc,
        &down_bg,
        &out.view,
        (SIZE, SIZE),
        wgpu::Color::BLACK,
    );
    gpu.queue.submit([enc.finish()]);
    let img = out.read_rgba(gpu).unwrap();
    gpu.take_error().unwrap();
    img
}

fn lit(p: &image::Rgba<u8>) -> bool {
    p[0] > 8 || p[1] > 8 || p[2] > 8
}

/// (covered share, gap runs) over the columns of row `y` inside the ribbon's span.
fn row_stats(img: &image::RgbaImage, y: u32, half_px: f64) -> (f64, usize) {
    let c = SIZE as f64 / 2.0;
    let (x0, x1) = ((c - half_px + 2.0) as u32, (c + half_px - 2.0) as u32);
    let mut covered = 0;
    let mut runs = 0;
    let mut prev = true;
    for x in x0..x1 {
        let l = lit(img.get_pixel(x, y));
        covered += u32::from(l);
        if !l && prev {
            runs += 1;
        }
        prev = l;
    }
    (covered as f64 / (x1 - x0) as f64, runs)
}

fn check_render(img: &image::RgbaImage, what: &str) {
    let px = SIZE as f64 / (2.0 * HALF as f64);
    let row_of = |y_world: f64| ((HALF as f64 - y_world) * px) as u32;
    // Outside the ribbon (beyond its width + 2 px, above the root, below the tip): black.
    for y in 0..SIZE {
        let yw = HALF as f64 - (y as f64 + 0.5) / px;
        let along = (6.0 - yw) / 12.0;
        for x in 0..SIZE {
            let xw = (x as f64 + 0.5) / px - HALF as f64;
            let inside = (-0.05..=1.05).contains(&along)
                && xw.abs() <= 0.5 * (6.0 - 4.0 * along.clamp(0.0, 1.0)) + 2.0 / px;
            if !inside {
                assert!(
                    !lit(img.get_pixel(x, y)),
                    "{what}: lit pixel ({x}, {y}) outside the ribbon"
                );
            }
        }
    }
    // Across the body: mostly covered, with gaps between the 8 hairs.
    for along in [0.1, 0.3, 0.5] {
        let half = 0.5 * (6.0 - 4.0 * along) * px;
        let (share, runs) = row_stats(img, row_of(6.0 - 12.0 * along), half);
        println!("{what}: v = {along}: covered {share:.2}, {runs} gaps");
        assert!(
            (0.4..0.92).contains(&share),
            "{what}: v = {along}: covered share {share}"
        );
        assert!(
            runs >= 5,
            "{what}: v = {along}: only {runs} gaps between 8 hairs"
        );
    }
    // Near the tip the ragged ends leave less hair: darker per pixel across the span, though
    // the gradient makes the hairs there 1.5 times as bright.
    let (tip, body) = (
        mean_red(img, row_of(6.0 - 12.0 * 0.985), 0.5 * 2.06 * px),
        mean_red(img, row_of(6.0 - 12.0 * 0.3), 0.5 * 4.8 * px),
    );
    println!("{what}: mean red across the span: body {body:.1}, tip {tip:.1}");
    assert!(tip < 0.5 * body, "{what}: tip rows {tip} vs body {body}");
}

/// Mean red (0..255, sRGB) over the columns of row `y` inside the ribbon's span.
fn mean_red(img: &image::RgbaImage, y: u32, half_px: f64) -> f64 {
    let c = SIZE as f64 / 2.0;
    let (x0, x1) = ((c - half_px) as u32, (c + half_px) as u32);
    (x0..x1).map(|x| img.get_pixel(x, y)[0] as f64).sum::<f64>() / (x1 - x0) as f64
}

/// u (0..1 across the ribbon) of the centres of the gaps in row `y`, whose span is
/// `half_px` either side of the middle.
fn gap_centres(img: &image::RgbaImage, y: u32, half_px: f64) -> Vec<f64> {
    let c = SIZE as f64 / 2.0;
    let (x0, x1) = ((c - half_px).ceil() as u32, (c + half_px).floor() as u32);
    let mut out = Vec::new();
    let mut start = None;
    for x in x0..=x1 {
        let l = x == x1 || lit(img.get_pixel(x, y));
        match (l, start) {
            (false, None) if x > x0 => start = Some(x),
            (true, Some(s)) => {
                let mid = 0.5 * (s + x - 1) as f64 + 0.5;
                out.push((mid - (c - half_px)) / (2.0 * half_px));
                start = None;
            }
            _ => {}
        }
    }
    out
}

#[test]
fn ribbons_cover_their_footprint_with_hair_gaps() {
    let gpu = common::gpu();
    let look = Look {
        hairs: 8,
        ..Look::default()
    };
    let img = render(gpu, 1, &look);
    check_render(&img, "no MSAA");
    // The hairs run straight along the tapered ribbon: within one stick (rows 96 to 128,
    // a trapezoid of two triangles) every gap stays at the same u. Interpolating u
    // affinely per triangle would bend them at the diagonal.
    let px = SIZE as f64 / (2.0 * HALF as f64);
    let half_at = |y: u32| {
        let along = ((y as f64 + 0.5) - 32.0) / 192.0;
        0.5 * (6.0 - 4.0 * along) * px
    };
    let first: Vec<f64> = gap_centres(&img, 97, half_at(97))
        .into_iter()
        .filter(|u| (0.05..0.95).contains(u))
        .collect();
    assert!(first.len() >= 4, "gaps in row 97: {first:?}");
    // Narrow gaps may close on a row; the others must be found within 0.06 (half the
    // hair spacing) and, found, within 0.02 of where they were.
    let (mut drift, mut found, mut tried) = (0.0f64, 0, 0);
    for y in (99..127).step_by(2) {
        let g = gap_centres(&img, y, half_at(y));
        for a in &first {
            tried += 1;
            let near = g
                .iter()
                .map(|b| (a - b).abs())
                .fold(f64::INFINITY, f64::min);
            if near < 0.06 {
                found += 1;
                drift = drift.max(near);
            }
        }
    }
    println!("gaps across one stick: {found} of {tried} kept, drift {drift:.4} of the width");
    assert!(
        found * 5 >= tried * 4,
        "the hairs bend within a stick: {found} of {tried} gaps kept"
    );
    assert!(
        drift < 0.02,
        "the hairs bend within a stick: gaps move by {drift} in u"
    );
    let p = img.get_pixel(128, 100);
    assert!(
        !lit(p) || (p[0] > p[1] && p[1] > p[2]),
        "the layer colour is warm: {p:?}"
    );
    // The gradient reaches the image. One wide hair covers the middle of the strip fully,
    // so its centre column shows the shading alone (no specular: it changes with the view
    // direction down the strip): near the tip end it is brighter than near the root by the
    // gradient's ratio (linear light; tip_shade 1.6).
    let one = render(
        gpu,
        1,
        &Look {
            hairs: 1,
            specular: [0.0, 40.0],
            ..Look::default()
        },
    );
    let lin = |y: u32| (one.get_pixel(SIZE / 2, y)[0] as f64 / 255.0).powf(2.2);
    let v = |row: u32| (row as f64 + 0.5 - 32.0) / 192.0;
    let want = gradient(look.tip_shade, v(160)) / gradient(look.tip_shade, v(40));
    let got = lin(160) / lin(40);
    println!("gradient in the image: tip / root {got:.3}, want {want:.3}");
    assert!(
        (got / want - 1.0).abs() < 0.05,
        "gradient: got {got}, want {want}"
    );
}

#[test]
fn ribbons_with_msaa_coverage() {
    let gpu = common::gpu();
    let look = Look {
        hairs: 8,
        ..Look::default()
    };
    let img = render(gpu, 4, &look);
    check_render(&img, "4x MSAA");
}

/// The light's `ambient` in the sky test: the physical hair's ambient colour is about 0.03.
const SKY_AMBIENT: f32 = 6.0;

/// sRGB byte to linear.
fn linear(c: u8) -> f64 {
    let c = c as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear RGB summed over the hair pixels of row `y` inside the ribbon's span.
fn row_sum(img: &image::RgbaImage, y: u32, half_px: f64) -> [f64; 3] {
    let c = SIZE as f64 / 2.0;
    let (x0, x1) = ((c - half_px + 1.0) as u32, (c + half_px - 1.0) as u32);
    let mut s = [0.0; 3];
    for x in x0..x1 {
        let p = img.get_pixel(x, y);
        for k in 0..3 {
            s[k] += linear(p[k]);
        }
    }
    s
}

/// The physical mode's ambient past the strips that hide a strip's sky (`strips::sky`): the
/// strip drawn under the ambient light alone with a hidden-sky index rising root to tip,
/// against the same strip under the open sky. Row by row, at the control points (where the
/// shader evaluates it), the ratio is the f64 `hair_bsdf::ambient_in_coat` of the index
/// interpolated there, per channel: texture, coverage and colour cancel.
#[test]
fn the_strips_ambient_follows_the_hidden_sky() {
    let gpu = common::gpu();
    let look = Look {
        hairs: 8,
        ..Look::default()
    };
    let ramp: [f32; SKY_SAMPLES] = std::array::from_fn(|k| 0.4 * k as f32);
    let open = render_with(gpu, 1, &look, Some([0.0; SKY_SAMPLES]));
    let hidden = render_with(gpu, 1, &look, Some(ramp));
    let bsdf = hair_bsdf::gpu_block(
        Shading::Physical,
        look.shading,
        &look.physical,
        test_strip().color,
    );
    let a_f = bsdf.a_f.map(f64::from);
    let px = SIZE as f64 / (2.0 * HALF as f64);
    let mut worst = 0.0f64;
    // Control points 1..=4 of the 7 (v = k / 6); the root and the ragged tip are left out.
    for k in 1..=4 {
        let v = k as f64 / 6.0;
        let y = ((HALF as f64 - (6.0 - 12.0 * v)) * px) as u32;
        let half = 0.5 * (6.0 - 4.0 * v) * px;
        let (a, b) = (row_sum(&open, y, half), row_sum(&hidden, y, half));
        let x = v * 7.0;
        let j = (x as usize).min(6);
        let index = ramp[j] as f64 + (ramp[j + 1] - ramp[j]) as f64 * (x - j as f64);
        let want = hair_bsdf::ambient_in_coat(
            [a_f[0], a_f[1], a_f[2]],
            index,
            hair_bsdf::SkyWeight::Sheet,
        );
        for c in 0..3 {
            let got = b[c] / a[c];
            let err = (got - want[c]).abs();
            println!(
                "v = {v:.3}, index {index:.3}, channel {c}: ratio {got:.4}, f64 {:.4}",
                want[c]
            );
            assert!(
                a[c] > 1.0,
                "v = {v}: too little light to compare ({})",
                a[c]
            );
            worst = worst.max(err);
        }
    }
    println!("worst ratio error {worst:.4}");
    assert!(worst < 0.015, "worst ratio error {worst}");
}

/// The physical mode's coverage of a strip seen obliquely (`oblique_coverage` in
/// `shaders/strips/draw.wgsl`): a strip of 128 hairs, far enough that a pixel averages
/// several texels, drawn face on and turned 60 degrees about its axis, under the ambient
/// light alone. Row by row, the light the turned strip sends is cos 60 times its coverage
/// 1 - (1 - a)^(1 / cos 60) over the face-on strip's a, with a the texture's alpha averaged
/// over each pixel's texels (f64, from the texture): the gaps close as round hairs overlap.
/// Without it the ratio is cos 60 and the worst error 0.30. Leaned back 60 degrees along its
/// hairs instead, the gaps keep their share and the light is cos 60 of the face-on strip's.
#[test]
fn an_oblique_strip_covers_more_of_its_width() {
    let gpu = common::gpu();
    let look = Look {
        hairs: 128,
        ..Look::default()
    };
    let open = Some([0.0; SKY_SAMPLES]);
    let tilt = 60f64.to_radians();
    let face = render_tilted(gpu, 1, &look, open, 0.0);
    let turned = render_tilted(gpu, 1, &look, open, tilt);
    let (w, h) = texture::texture_size(&look);
    let tex = texture::strand_texture(&look, w, h);
    let px = SIZE as f64 / (2.0 * HALF as f64);
    let cos = tilt.cos();
    let whole_row = |img: &image::RgbaImage, y: u32| -> f64 {
        (0..SIZE)
            .map(|x| {
                let p = img.get_pixel(x, y);
                (0..3).map(|c| linear(p[c])).sum::<f64>()
            })
            .sum()
    };
    let mut worst = 0.0f64;
    for v in [0.2, 0.35, 0.5, 0.65] {
        let y = ((HALF as f64 - (6.0 - 12.0 * v)) * px) as u32;
        let row = &tex[(v * h as f64) as usize * w as usize..][..w as usize];
        let alpha: Vec<f64> = row.iter().map(|t| f64::from(t[3]) / 255.0).collect();
        // Each pixel of the turned strip averages this many texels of the row.
        let width_px = (6.0 - 4.0 * v) * px * cos;
        let block = ((w as f64 / width_px).round() as usize).max(1);
        let covered: Vec<f64> = alpha
            .chunks(block)
            .map(|c| {
                let a = c.iter().sum::<f64>() / c.len() as f64;
                1.0 - (1.0 - a).powf(1.0 / cos)
            })
            .collect();
        let a0 = alpha.iter().sum::<f64>() / alpha.len() as f64;
        let a1 = covered.iter().sum::<f64>() / covered.len() as f64;
        let want = cos * a1 / a0;
        let (f, t) = (whole_row(&face, y), whole_row(&turned, y));
        assert!(f > 1.0, "v = {v}: too little light to compare ({f})");
        let got = t / f;
        println!("v = {v}: face-on coverage {a0:.3}, turned {a1:.3}; light ratio {got:.4}, f64 {want:.4}");
        worst = worst.max((got / want - 1.0).abs());
    }
    println!("worst relative error {worst:.4}");
    assert!(worst < 0.05, "worst relative error {worst}");
    // Leaned back along its hairs by 60 degrees instead, the strip's gaps keep their share:
    // its light is cos 60 of the face-on strip's, as its projected area is.
    let lean = 60f64.to_radians();
    let mut leaned = test_strip();
    leaned.points = (0..=6)
        .map(|k| {
            DVec3::new(
                0.0,
                6.0 - 2.0 * k as f64 * lean.cos(),
                -2.0 * k as f64 * lean.sin(),
            )
        })
        .collect();
    leaned.normal = DVec3::new(0.0, -lean.sin(), lean.cos());
    let back = render_strip(gpu, 1, &look, open, leaned);
    let total = |img: &image::RgbaImage| -> f64 { (0..SIZE).map(|y| whole_row(img, y)).sum() };
    let got = total(&back) / total(&face);
    println!(
        "leaned along its hairs: light ratio {got:.4}, cos 60 {:.4}",
        lean.cos()
    );
    assert!(
        (got / lean.cos() - 1.0).abs() < 0.05,
        "leaned along its hairs: light ratio {got}, want cos 60"
    );
}
