//! Kazama's strips on a mesh head (`assets/scenes/strips_mesh_head.ron`, CGAL's `head.off`):
//! every root moved onto the scalp, the rest shape outside the head's signed distance field,
//! no control point left inside the field while the head shakes and a gust presses the strips
//! onto it (the f64 reference and the GPU kernel), the kernel against the reference, the
//! snapshot, and clear errors for rings off the scalp.

use crate::common;
use common::{check_snapshot, Tolerance};
use glam::{DMat4, DVec3};
use kami::forces::Forces;
use kami::scene::hull::{head_hull, head_mesh, HeadHull, ROOT_TOLERANCE, SDF_EPS_OUT};
use kami::scene::sdf::{closest_point_triangle, Sdf};
use kami::scene::Ellipsoid;
use kami::systems::strips::dynamics::Rig;
use kami::systems::strips::dynamics_gpu::DynamicsGpu;
use kami::systems::strips::{hom, RestStrip};
use kami::Scene;

const SCENE: &str = "strips_mesh_head";

/// Frames of the hard case: the shake (frames 0 to 32) and the gust into the face (30 to
/// 56), and a while after, three seconds in all.
const FRAMES: u64 = 90;

fn rest(scene: &Scene) -> Vec<RestStrip> {
    hom::build(scene.strips().as_ref().unwrap(), &scene.head).unwrap()
}

/// Lowest field value of any control point but the roots, and the largest |field| at a
/// root, head-local through `pose`.
fn lowest(sdf: &Sdf, points: &[DVec3], stride: usize, pose: DMat4) -> (f64, f64) {
    let inv = pose.inverse();
    let (mut low, mut root) = (f64::INFINITY, 0.0f64);
    for (i, p) in points.iter().enumerate() {
        let v = sdf.sample(inv.transform_point3(*p));
        if i % stride == 0 {
            root = root.max(if v.is_nan() { f64::INFINITY } else { v.abs() });
        } else {
            low = low.min(if v.is_nan() { f64::NEG_INFINITY } else { v });
        }
    }
    (low, root)
}

/// Every strip's root lies on the mesh's scalp (the nearest triangle to its ring's point, the
/// same as a search of every triangle finds): on the SDF's zero level set, nearest a scalp
/// triangle (found here by brute force; the scalp is the triangles whose centroids lie in
/// the scene's regions, so a root near the scalp's edge may lie just outside them), leaving
/// along the field's normal; the rest shape lies outside the field.
#[test]
fn roots_lie_on_the_scalp() {
    let scene = common::scene(SCENE);
    let head = &scene.head;
    let mesh = head_mesh(head).unwrap().unwrap();
    let rest = rest(&scene);
    let m = &mesh.mesh;
    let nearest = |p: DVec3| {
        (0..m.triangles.len())
            .min_by(|&a, &b| {
                let d = |t: usize| {
                    let [x, y, z] = m.triangles[t].map(|i| m.positions[i as usize]);
                    (closest_point_triangle(p, x, y, z) - p).length()
                };
                d(a).total_cmp(&d(b))
            })
            .unwrap() as u32
    };
    // The placement's nearest triangle (it skips triangles by their bounding spheres) is the
    // one every triangle in order finds, from each ring's point on the ellipsoid.
    let hull = Ellipsoid::new(head.center, head.radii);
    let mut s = 0;
    for layer in &scene.strips().as_ref().unwrap().layers {
        for az in hom::azimuths(layer) {
            let drawn = hull.point(layer.polar.to_radians(), az.to_radians());
            let placed = mesh.place_on_scalp(drawn, f64::INFINITY).unwrap();
            assert_eq!(
                placed.triangle,
                nearest(drawn),
                "strip {s}: not the nearest"
            );
            assert!((placed.root - rest[s].points[0]).length() < 1e-12);
            s += 1;
        }
    }
    let (mut off, mut deepest): (f64, f64) = (0.0, f64::INFINITY);
    for (s, r) in rest.iter().enumerate() {
        let root = r.points[0];
        off = off.max(mesh.sdf.sample(root).abs());
        let t = nearest(root);
        assert!(
            mesh.scalp.contains(&t),
            "strip {s}: nearest triangle {t} is not scalp"
        );
        let n = mesh.sdf.gradient(root).normalize();
        assert!(
            (r.normal - n).length() < 1e-12,
            "strip {s}: not the field's normal"
        );
        for p in &r.points[1..] {
            deepest = deepest.min(mesh.sdf.sample(*p));
        }
    }
    eprintln!(
        "{} strips: largest |SDF| at a root {off:.2e}, lowest SDF of a rest point {deepest:.3}",
        rest.len()
    );
    assert_eq!(rest.len(), 74);
    assert!(
        off < ROOT_TOLERANCE,
        "a root off the zero level set by {off}"
    );
    assert!(deepest > 0.0, "a rest point inside the head ({deepest})");
}

/// The hard case (`FRAMES` frames of `strips_mesh_head.ron`: the head shakes 25 degrees each
/// way, then a gust into the face and down presses the strips onto it), in the f64
/// reference and on the GPU, frame by frame: no control point ends a frame inside the
/// mesh head's SDF by more than `SDF_EPS_OUT` (0.1 mm), every root stays on the scalp (on
/// the field's zero level set as the head moves), and the GPU stays within a bound of the
/// reference (worst control point relative to its strip's length). With the ellipsoid as
/// the hull (the strips before mesh heads) points go well inside the mesh: the case is hard.
#[test]
fn strips_stay_out_of_the_sdf_and_gpu_matches_the_reference() {
    let gpu = common::gpu();
    let scene = common::scene(SCENE);
    let head = &scene.head;
    let st = scene.strips().as_ref().unwrap();
    let motion = &st.motion;
    let forces = Forces::new(&scene.forces, head);
    let hull = head_hull(head).unwrap();
    let sdf = hull.sdf().unwrap().clone();
    let rest = rest(&scene);
    let mut rig = Rig::posed(&rest, motion, head, forces.gravity).unwrap();
    rig.set_pose(forces.head_at(0.0));
    let stride = rig.stride();
    let mut ellipsoid = rig.clone();
    let ellipsoid_hull = HeadHull::Ellipsoid(Ellipsoid::new(head.center, head.radii));
    let mut g = DynamicsGpu::new(gpu, &common::still_world(gpu, head), &rig, motion).unwrap();
    let (mut cpu_low, mut gpu_low, mut ell_low) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
    let (mut cpu_root, mut gpu_root): (f64, f64) = (0.0, 0.0);
    let mut apart: Vec<f64> = Vec::new();
    let mut per_strip = vec![0.0f64; rig.strip_count()];
    let mut moved: f64 = 0.0;
    let start = rig.points();
    for f in 0..FRAMES {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        g.record(gpu, &mut enc, &forces, f, 1).unwrap();
        gpu.queue.submit([enc.finish()]);
        rig.run_frames(&forces, &hull, motion, &[], f, 1);
        ellipsoid.run_frames(&forces, &ellipsoid_hull, motion, &[], f, 1);
        let pose = forces.head_at((f + 1) as f64);
        let cp = rig.points();
        let gp: Vec<DVec3> = g
            .read_points(gpu)
            .unwrap()
            .iter()
            .map(|a| DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64))
            .collect();
        let (low, root) = lowest(&sdf, &cp, stride, pose);
        (cpu_low, cpu_root) = (cpu_low.min(low), cpu_root.max(root));
        let (low, root) = lowest(&sdf, &gp, stride, pose);
        (gpu_low, gpu_root) = (gpu_low.min(low), gpu_root.max(root));
        ell_low = ell_low.min(lowest(&sdf, &ellipsoid.points(), stride, pose).0);
        let mut worst: f64 = 0.0;
        for (i, (a, b)) in gp.iter().zip(&cp).enumerate() {
            let e = (*a - *b).length() / rig.length(i / stride);
            let e = if e.is_finite() { e } else { f64::INFINITY };
            worst = worst.max(e);
            per_strip[i / stride] = per_strip[i / stride].max(e);
            moved = moved.max((*b - start[i]).length() / rig.length(i / stride));
        }
        apart.push(worst);
    }
    gpu.take_error().unwrap();
    let parted = per_strip.iter().filter(|e| **e > PARTED).count();
    let every = |k: usize| {
        apart
            .iter()
            .step_by(k)
            .map(|v| (v * 1e5).round() / 1e5)
            .collect::<Vec<_>>()
    };
    let shake = apart[..32].iter().copied().fold(0.0, f64::max);
    let all = apart.iter().copied().fold(0.0, f64::max);
    assert!(all.is_finite(), "the GPU's strips are not finite");
    eprintln!(
        "{SCENE}, {FRAMES} frames on {}: lowest SDF of a control point at a frame's end: f64 {cpu_low:+.2e}, GPU {gpu_low:+.2e}, f64 with the ellipsoid as the hull {ell_low:.3}; largest |SDF| at a root: f64 {cpu_root:.1e}, GPU {gpu_root:.1e}; worst |GPU - f64| / length: shake (frames 1-32) {shake:.2e}, all {all:.2e}, every 10 frames {:?}; strips parted by more than {PARTED} of their length: {parted} of {}; moved {moved:.2}",
        gpu.describe(),
        every(10),
        per_strip.len()
    );
    let tolerance = -SDF_EPS_OUT;
    assert!(
        cpu_low >= tolerance,
        "f64: a point ended {} inside",
        -cpu_low
    );
    assert!(
        gpu_low >= tolerance,
        "GPU: a point ended {} inside",
        -gpu_low
    );
    assert!(
        cpu_root < 1e-9 + ROOT_TOLERANCE,
        "f64: a root left the scalp by {cpu_root}"
    );
    assert!(gpu_root < 1e-3, "GPU: a root left the scalp by {gpu_root}");
    assert!(
        ell_low < -0.3,
        "the case is not hard: with the ellipsoid {ell_low}"
    );
    assert!(moved > 0.2, "the scene should move the strips ({moved})");
    assert!(
        shake < SHAKE_BOUND,
        "GPU off the f64 reference by {shake:e} in the shake"
    );
    assert!(
        parted as f64 <= PARTED_SHARE * per_strip.len() as f64,
        "{parted} strips parted from the f64 reference"
    );
}

/// The contract, worst control point relative to its strip's length. While the head shakes
/// (the strips swing and rest on the mesh) every strip within `SHAKE_BOUND` (measured
/// 3.2e-5 on llvmpipe). Under the gust that presses them onto the head a point just inside
/// the field in one precision and just outside in the other is pushed out by `SDF_EPS_OUT`
/// in one only, and strips sliding over the field's cell faces meet the trilinear
/// gradient's jumps (docs/mesh_head.md, weak points): a pressed strip may then part from
/// the reference and follow its own way round (measured: 7 of 74 strips beyond 1 % of their
/// length, the worst by 0.95; with the ellipsoid as the hull 2 beyond 1 %, the worst by
/// 0.026). At most `PARTED_SHARE` of the strips may part by more than `PARTED`.
const SHAKE_BOUND: f64 = 2e-4;
const PARTED: f64 = 0.01;
const PARTED_SHARE: f64 = 0.15;

/// `assets/scenes/strips_mesh_head.ron` at frame 12 (the head turning, the strips swinging
/// over the mesh), one sample per pixel.
#[test]
fn strips_mesh_head_frame_12_snapshot() {
    let gpu = common::gpu();
    let mut scene = common::scene(SCENE);
    scene.render.supersample = 1;
    scene.render.msaa = 1;
    const TOL: Tolerance = Tolerance {
        mean: 0.25,
        threshold: 24,
        share: 0.002,
    };
    kami::stage::render_animation(gpu, &scene, (160, 128), 12..=12, |_, img| {
        check_snapshot("strips_mesh_head_12", &img, TOL);
        Ok(())
    })
    .unwrap();
}

/// The shipped scene's text with `from` replaced by `to`, read as a scene file.
fn edited(from: &str, to: &str) -> kami::Result<Scene> {
    let path = kami::scene::shipped(&format!("assets/scenes/{SCENE}.ron"));
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.contains(from), "the scene has no {from:?}");
    Scene::from_ron(&text.replacen(from, to, 1), "edited.ron")
}

/// A ring whose roots fall off the scalp (on the face, below the scalp's plane) or far from
/// the mesh (radii that do not fit it) is refused with the file, the strip, its layer's
/// field and what to change; a ring on the scalp is accepted.
#[test]
fn rings_off_the_scalp_are_refused() {
    let cases = [
        (
            "Layer(name: \"bangs\", count: 8, polar: 32.0",
            "Layer(name: \"bangs\", count: 8, polar: 75.0",
            "strips.layers[4].azimuth",
            "which is not scalp",
        ),
        (
            "radii: (9.2, 8.6, 6.3)",
            "radii: (14.0, 8.6, 6.3)",
            "strips.layers[",
            "from the head mesh",
        ),
    ];
    for (from, to, field, says) in cases {
        let err = edited(from, to).unwrap_err().to_string();
        eprintln!("{err}");
        assert!(
            err.contains("edited.ron") && err.contains(field) && err.contains(says),
            "expected the file, {field} and {says:?} in: {err}"
        );
        assert!(err.contains("strip "), "no strip named in: {err}");
    }
    edited("polar: 24.0", "polar: 20.0").unwrap();
}
