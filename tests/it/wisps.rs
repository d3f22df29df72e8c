//! Toon wisps through the stage: snapshots of the shipped scenes, depth composition with the
//! head, and clear errors for bad skeletons.
//!
//! Snapshot tolerance as in `tests/it/snapshot.rs` (mean <= 0.25 of 255, at most 0.2 % of
//! pixels off by more than 24), at one sample per pixel: the ray march is the costly pass on
//! the software adapter.

use crate::common;
use crate::common::invalid;
use common::{check_snapshot, Tolerance};
use kami::Scene;

const TOL: Tolerance = Tolerance {
    mean: 0.25,
    threshold: 24,
    share: 0.002,
};

fn render(scene: &Scene, size: (u32, u32)) -> image::RgbaImage {
    let gpu = common::gpu();
    kami::stage::render_scene(gpu, &marched(scene), size).unwrap()
}

/// The tests here are the ray march's: they draw with it whatever `Auto` picks on the
/// adapter (the meshed path's tests are in `wisps_mesh.rs`).
pub fn marched(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    if let Some(w) = s.wisps_mut().as_mut() {
        w.draw = kami::systems::wisps::block::WispDraw::March;
    }
    s
}

fn one_sample(name: &str) -> Scene {
    let mut s = marched(&common::scene(name));
    s.render.supersample = 1;
    s.render.msaa = 1;
    s
}

#[test]
fn toon_snapshot() {
    let img = render(&one_sample("toon"), (192, 192));
    check_snapshot("toon", &img, TOL);
}

#[test]
fn toon_divide_snapshot() {
    let img = render(&one_sample("toon_divide"), (192, 256));
    check_snapshot("toon_divide", &img, TOL);
}

/// Fig. 13: the head shaking side to side, the wisps on mass springs (RK4 on the GPU) at
/// frame 16, turned hard left with the hair still swinging from the right.
#[test]
fn toon_shake_frame_16_snapshot() {
    let gpu = common::gpu();
    let scene = one_sample("toon_shake");
    kami::stage::render_animation(gpu, &scene, (128, 128), 16..=16, |_, img| {
        check_snapshot("toon_shake_16", &img, TOL);
        Ok(())
    })
    .unwrap();
}

/// The march in compute (a hardware GPU's default, `block::MarchOn`) draws the image the
/// march in fragments draws (the software adapter's default): the same march per pixel,
/// its colour and depth composited by depth, with the head in front of the back hair.
#[test]
fn march_in_compute_draws_the_fragment_image() {
    use kami::systems::wisps::block::MarchOn;
    let on = |on: MarchOn| {
        let mut s = one_sample("toon");
        s.wisps_mut().as_mut().unwrap().march.on = on;
        render(&s, (160, 160))
    };
    let (compute, fragment) = (on(MarchOn::Compute), on(MarchOn::Fragment));
    let differ = compute
        .pixels()
        .zip(fragment.pixels())
        .filter(|(a, b)| (0..3).any(|c| a[c].abs_diff(b[c]) > 2))
        .count();
    let hair = fragment.pixels().filter(|p| is_hair(p)).count();
    assert!(hair > 3000, "{hair} hair pixels");
    assert_eq!(
        differ, 0,
        "{differ} pixels differ between the march in compute and in fragments"
    );
}

fn is_skin(p: &image::Rgba<u8>) -> bool {
    // The toon head's skin (0.98, 0.86, 0.78) lit: red well above blue.
    p[0] as i32 - p[2] as i32 > 25
}

fn is_hair(p: &image::Rgba<u8>) -> bool {
    // Every toon tone of the scene is blue-violet: blue well above red.
    p[2] as i32 - p[0] as i32 > 25
}

/// Wisps write the depth of their surface: the face (head in front of the back hair) shows
/// skin, and the bangs (in front of the forehead) show hair. Depth from the proxy boxes
/// instead of the surface would let the back hair's boxes paint over the face.
#[test]
fn wisps_composite_with_the_head_by_depth() {
    let scene = one_sample("toon");
    let img = render(&scene, (128, 128));
    let share = |x0: u32, x1: u32, y0: u32, y1: u32, f: &dyn Fn(&image::Rgba<u8>) -> bool| {
        let mut n = 0;
        let mut hit = 0;
        for y in y0..y1 {
            for x in x0..x1 {
                n += 1;
                hit += u32::from(f(img.get_pixel(x, y)));
            }
        }
        hit as f64 / n as f64
    };
    // The face below the bangs, and the hair at the front of the crown (from the snapshot).
    let face = share(58, 68, 60, 70, &is_skin);
    let bangs = share(50, 78, 24, 34, &is_hair);
    assert!(face > 0.9, "face shows skin on {face:.2} of its pixels");
    assert!(bangs > 0.9, "bangs show hair on {bangs:.2} of their pixels");
    // Without the head the same face pixels show the back hair behind it.
    let mut headless = scene.clone();
    headless.head.visible = false;
    let img2 = render(&headless, (128, 128));
    let mut behind = 0;
    for y in 60..70 {
        for x in 58..68 {
            behind += u32::from(is_hair(img2.get_pixel(x, y)));
        }
    }
    assert!(
        behind > 25,
        "without the head the back hair shows through the face ({behind} of 100 pixels)"
    );
}

/// A straight wisp of constant radius half buried in a sphere head, seen at an angle: every
/// pixel is classified (wisp, skin, background) by exact ray intersection with the sphere
/// and with the wisp's iso-surface (a capsule of radius r (1 - sqrt(T / 1.5 w)) for one
/// straight segment, eq 9), and the rendering must agree except on edge pixels. The cut where
/// the wisp enters the skin is decided by the depth the march writes, so any depth other
/// than the surface's moves it.
#[test]
fn wisp_depth_cuts_into_the_head_where_the_surfaces_meet() {
    use glam::DVec3;
    let (r, w, t): (f64, f64, f64) = (1.5, 2.5, 0.5);
    let vis = r * (1.0 - (t / (1.5 * w)).sqrt());
    let (a, b) = (DVec3::new(-9.0, 0.5, 3.2), DVec3::new(9.0, -0.5, 3.2));
    let text = format!(
        "Scene(head: Head(radii: (4.0, 4.0, 4.0), color: (0.98, 0.86, 0.78)), \
         wisps: Some(Wisps(threshold: {t}, toon: Toon(outline_width: 0.0), skeletons: [Skeleton(nodes: [\
         Node(p: ({}, {}, {}), r: {r}, w: {w}), Node(p: (0.0, 0.0, 3.2), r: {r}, w: {w}), \
         Node(p: ({}, {}, {}), r: {r}, w: {w})])])), \
         camera: CameraDesc(eye: (6.0, 14.0, 30.0), target: (0.0, 0.0, 0.0), fov_y: 30.0), \
         render: RenderSettings(supersample: 1, msaa: 1))",
        a.x, a.y, a.z, b.x, b.y, b.z
    );
    let scene = Scene::from_ron(&text, "capsule.ron").unwrap();
    let size = (160u32, 120u32);
    let img = render(&scene, size);
    let cam = &scene.camera;
    let eye = DVec3::from(cam.eye);
    let fwd = (DVec3::from(cam.target) - eye).normalize();
    let right = fwd.cross(DVec3::Y).normalize();
    let up = right.cross(fwd);
    let half = (0.5 * cam.fov_y.to_radians()).tan();
    let aspect = size.0 as f64 / size.1 as f64;
    // Nearest positive root of a ray against a sphere and against the capsule (the middle
    // node is on the line, so the spline is the straight segment a-b).
    let sphere = |d: DVec3, c: DVec3, rad: f64| -> Option<f64> {
        let oc = eye - c;
        let bq = oc.dot(d);
        let disc = bq * bq - (oc.length_squared() - rad * rad);
        (disc >= 0.0)
            .then(|| -bq - disc.sqrt())
            .filter(|&t| t > 0.0)
    };
    let capsule = |d: DVec3| -> Option<f64> {
        let ab = b - a;
        let (mut best, n) = (None::<f64>, 4000);
        // March finely along the ray: exact enough for classification.
        for i in 0..n {
            let tt = 10.0 + 40.0 * i as f64 / n as f64;
            let p = eye + tt * d;
            let u = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
            if (a + u * ab - p).length() <= vis {
                best = Some(tt);
                break;
            }
        }
        best
    };
    let (mut wrong, mut interior) = (0u32, 0u32);
    let mut wisp_pixels = 0u32;
    for y in 0..size.1 {
        for x in 0..size.0 {
            let nx = ((x as f64 + 0.5) / size.0 as f64 * 2.0 - 1.0) * half * aspect;
            let ny = (1.0 - (y as f64 + 0.5) / size.1 as f64 * 2.0) * half;
            let d = (fwd + nx * right + ny * up).normalize();
            let head = sphere(d, DVec3::ZERO, 4.0);
            let hair = capsule(d);
            let want = match (hair, head) {
                (Some(h), Some(s)) if h < s => 'w',
                (Some(_), None) => 'w',
                (_, Some(_)) => 's',
                (None, None) => '.',
            };
            // Edge pixels (a neighbouring ray classified otherwise) may go either way.
            let edge = [(-0.6, 0.0), (0.6, 0.0), (0.0, -0.6), (0.0, 0.6)]
                .iter()
                .any(|(ox, oy)| {
                    let nx = ((x as f64 + 0.5 + ox) / size.0 as f64 * 2.0 - 1.0) * half * aspect;
                    let ny = (1.0 - (y as f64 + 0.5 + oy) / size.1 as f64 * 2.0) * half;
                    let d = (fwd + nx * right + ny * up).normalize();
                    let other = match (capsule(d), sphere(d, DVec3::ZERO, 4.0)) {
                        (Some(h), Some(s)) if h < s => 'w',
                        (Some(_), None) => 'w',
                        (_, Some(_)) => 's',
                        (None, None) => '.',
                    };
                    other != want
                });
            if edge {
                continue;
            }
            interior += 1;
            let p = img.get_pixel(x, y);
            let got = if is_hair(p) {
                'w'
            } else if is_skin(p) {
                's'
            } else {
                '.'
            };
            wisp_pixels += u32::from(got == 'w');
            if got != want {
                wrong += 1;
            }
        }
    }
    assert!(wisp_pixels > 400, "the wisp shows on {wisp_pixels} pixels");
    assert!(
        (wrong as f64) < 0.002 * interior as f64,
        "{wrong} of {interior} non-edge pixels classified otherwise than exact intersection"
    );
}

/// Issue 34's seams: a long straight wisp and a long arc, tapered as `toon.ron`'s long wisps
/// and lit from the side, drawn by the GPU march with no outline. Every edge between toon
/// tones (and the silhouette) must move at most two pixels from one column to the next along
/// the wisps: the light is the same everywhere, so a tone edge that jumps at a joint is a
/// seam. Before the open joints (`field::WispMax`), the edges jumped 4-9 pixels at joints.
#[test]
fn toon_tone_has_no_seams_along_tapered_wisps() {
    let radii = [3.0, 2.4, 1.8, 1.2, 0.8, 0.5, 0.3];
    let node =
        |p: (f64, f64), r: f64| format!("Node(p: ({:.4}, {:.4}, 0.0), r: {r}, w: 2.5)", p.0, p.1);
    let straight: Vec<String> = radii
        .iter()
        .enumerate()
        .map(|(i, &r)| node((-9.0 + 3.0 * i as f64, 5.0), r))
        .collect();
    // Nodes 0.3 rad apart on a circle of radius 11: the segments turn as the side wisps of
    // `toon.ron` do.
    let arc: Vec<String> = radii
        .iter()
        .enumerate()
        .map(|(i, &r)| {
            let a = -0.6 + 0.3 * i as f64;
            node((11.0 * a.sin(), 11.0 * a.cos() - 12.0), r)
        })
        .collect();
    // Each wisp alone, the camera on the middle of its tested part: from past the straight
    // one's root cap (from node 1 on the arc, where it is no steeper than 0.3) to where the
    // radius is 1.2 (node 3).
    let (w, h) = (768u32, 288u32);
    let half = 12.0 * 17f64.to_radians().tan();
    let px = h as f64 / (2.0 * half);
    let arc_mid = 11.0 - 12.0;
    let cases = [
        ("straight", &straight, (-4.5, 5.0), (-8.5, 0.0)),
        (
            "arc",
            &arc,
            (0.0, arc_mid),
            (11.0 * (-0.3f64).sin(), 11.0 * 0.3f64.sin()),
        ),
    ];
    let mut failures = Vec::new();
    for (name, nodes, (cx, cy), (xa, xb)) in cases {
        let text = format!(
            "Scene(head: Head(radii: (1.0, 1.0, 1.0), color: (0.98, 0.86, 0.78)), \
             wisps: Some(Wisps(threshold: 0.5, toon: Toon(outline_width: 0.0), skeletons: [\
             Skeleton(nodes: [{}])])), \
             light: Light(direction: (0.8, 0.35, 0.5), intensity: 1.0, ambient: 1.0), \
             camera: CameraDesc(eye: ({cx}, {cy}, 12.0), target: ({cx}, {cy}, 0.0), fov_y: 34.0), \
             render: RenderSettings(supersample: 1, msaa: 1, shadows: Shadows(on: false)))",
            nodes.join(", ")
        );
        let mut scene = Scene::from_ron(&text, "seams.ron").unwrap();
        scene.head.visible = false;
        let img = render(&scene, (w, h));
        let saved = std::env::temp_dir().join(format!("kami_toon_seams_{name}.png"));
        let _ = img.save(&saved);
        // A lone pixel of another tone (a march speckle) is not a seam: each pixel takes the
        // median of itself and its row neighbours, which keeps any step along the wisp.
        let at = |x: u32, y: u32| -> [i32; 3] {
            std::array::from_fn(|c| {
                let mut v = [x - 1, x, x + 1].map(|x| img.get_pixel(x, y)[c] as i32);
                v.sort_unstable();
                v[1]
            })
        };
        let diff = |a: [i32; 3], b: [i32; 3]| (0..3).any(|c| (a[c] - b[c]).abs() > 24);
        let col = |x: f64| (w as f64 / 2.0 + (x - cx) * px) as u32;
        let (x0, x1) = (col(xa), col(xb));
        let edges = |x: u32| -> Vec<u32> {
            (0..h - 1)
                .filter(|&y| diff(at(x, y), at(x, y + 1)))
                .collect()
        };
        let (mut worst, mut where_, mut n_edges) = (0u32, 0, 0usize);
        for x in x0..x1 {
            let (a, b) = (edges(x), edges(x + 1));
            n_edges += a.len();
            for (from, to) in [(&a, &b), (&b, &a)] {
                for &e in from {
                    let near = to.iter().map(|&f| e.abs_diff(f)).min().unwrap_or(u32::MAX);
                    if near > worst {
                        worst = near;
                        where_ = x;
                    }
                }
            }
        }
        println!(
            "{name}: {n_edges} tone edges over {} columns, the largest jump {worst} px at column {where_}",
            x1 - x0
        );
        assert!(
            n_edges > 4 * (x1 - x0) as usize,
            "{name}: {n_edges} edges: not drawn as expected (see {})",
            saved.display()
        );
        failures.extend((worst > 2).then(|| {
            format!(
                "{name}: a tone edge jumps {worst} pixels at column {where_} (a seam; see {})",
                saved.display()
            )
        }));
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

const GOOD: &str = r#"Scene(
    wisps: Some(Wisps(
        skeletons: [
            Skeleton(nodes: [
                Node(p: (0.0, 10.0, 0.0), r: 2.0, w: 2.0),
                Node(p: (0.0, 5.0, 3.0), r: 1.0, w: 2.0),
                Node(p: (0.0, 0.0, 4.0), r: 0.5, w: 2.0),
            ]),
        ],
    )),
)"#;

fn with(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "{from} not in the template");
    GOOD.replacen(from, to, 1)
}

#[test]
fn good_wisps_load() {
    let s = Scene::from_ron(GOOD, "toon.ron").unwrap();
    assert_eq!(s.wisps().as_ref().unwrap().skeletons[0].nodes.len(), 3);
}

#[test]
fn skeleton_with_one_node_is_refused() {
    let text = with(
        r#"
                Node(p: (0.0, 5.0, 3.0), r: 1.0, w: 2.0),
                Node(p: (0.0, 0.0, 4.0), r: 0.5, w: 2.0),"#,
        "",
    );
    let (field, value, allowed) = invalid(&text);
    assert_eq!(field, "wisps.skeletons[0].nodes");
    assert_eq!(value, "1 node(s)");
    assert!(allowed.contains("at least 2 nodes"), "{allowed}");
}

#[test]
fn zero_and_negative_radius_are_refused() {
    for r in ["0.0", "-1.0"] {
        let (field, value, _) = invalid(&with("r: 1.0", &format!("r: {r}")));
        assert_eq!(field, "wisps.skeletons[0].nodes[1].r");
        assert_eq!(value.parse::<f64>().unwrap(), r.parse::<f64>().unwrap());
    }
}

#[test]
fn nan_weight_is_refused() {
    let (field, value, allowed) = invalid(&with(
        "w: 2.0),\n                Node(p: (0.0, 0.0",
        "w: NaN),\n                Node(p: (0.0, 0.0",
    ));
    assert_eq!(field, "wisps.skeletons[0].nodes[1].w");
    assert_eq!(value, "NaN");
    assert!(allowed.contains("finite"), "{allowed}");
}

#[test]
fn coincident_nodes_are_refused() {
    let (field, _, allowed) = invalid(&with("(0.0, 5.0, 3.0)", "(0.0, 10.0, 0.0)"));
    assert_eq!(field, "wisps.skeletons[0].nodes[1].p");
    assert!(allowed.contains("coincides with node 0"), "{allowed}");
}

#[test]
fn bundle_naming_a_missing_wisp_is_refused() {
    let text = GOOD.replace(
        "    )),\n)",
        "        bundles: [Bundle(wisps: [0, 3], release_from: 1)],\n    )),\n)",
    );
    let (field, value, _) = invalid(&text);
    assert_eq!(field, "wisps.bundles[0].wisps[1]");
    assert_eq!(value, "3");
}

/// The f64 nodes of a scene's wisps as the reference takes them (rest pose, head still).
fn reference_segments(
    w: &kami::systems::wisps::block::Wisps,
) -> Vec<Vec<kami::systems::wisps::curve::Segment>> {
    kami::systems::wisps::curve::drawn_segments(w)
}

/// A device and a stage of `scene` on it that has drawn one frame at `size` (the wisps'
/// march counting when `counting`).
fn drawn(
    scene: &Scene,
    size: (u32, u32),
    counting: bool,
) -> (&'static kami::gpu::Gpu, kami::stage::Stage) {
    drawn_with_slots(scene, size, counting, None)
}

/// `drawn` with the march's ray lists set to `slots` (None: the scene's own).
fn drawn_with_slots(
    scene: &Scene,
    size: (u32, u32),
    counting: bool,
    slots: Option<u32>,
) -> (&'static kami::gpu::Gpu, kami::stage::Stage) {
    use kami::systems::wisps::WispsSystem;
    let gpu = common::gpu();
    let scene = &marched(scene);
    let mut stage = kami::stage::Stage::new(
        gpu,
        scene,
        kami::stage::target::OUTPUT_FORMAT,
        kami::stage::Quality::of(scene),
    )
    .unwrap();
    let sys = stage.system_mut::<WispsSystem>().unwrap();
    sys.draw.counting = counting;
    if let Some(n) = slots {
        sys.draw.set_slots(gpu, n).unwrap();
    }
    let out = kami::stage::target::Offscreen::new(gpu, size).unwrap();
    let look = stage.look();
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    stage.render(gpu, &mut enc, &out.view, size, &look).unwrap();
    gpu.queue.submit([enc.finish()]);
    (gpu, stage)
}

/// The spline kernel (f32, one invocation per wisp) against `curve::segments` (f64): control
/// points, radii, weights and Lipschitz bounds of every segment of the toon scene.
/// Measured worst: 1.5e-7 of the head size for the control points, 4.3e-7 relative for the
/// bounds (allowed 1e-5 each).
#[test]
fn spline_kernel_matches_the_f64_reference() {
    use kami::systems::wisps::WispsSystem;
    let scene = one_sample("toon");
    let w = scene.wisps().clone().unwrap();
    let (gpu, stage) = drawn(&scene, (32, 32), false);
    let sys = stage.system::<WispsSystem>().unwrap();
    let (segs, caps, counts) = sys.curves.read(gpu).unwrap();
    let want: Vec<_> = reference_segments(&w).into_iter().flatten().collect();
    assert_eq!(segs.len(), want.len());
    let (mut worst_p, mut worst_l) = (0.0f64, 0.0f64);
    for (g, c) in segs.iter().zip(&want) {
        for k in 0..4 {
            let p = glam::DVec3::new(g.c[k][0] as f64, g.c[k][1] as f64, g.c[k][2] as f64);
            worst_p = worst_p.max((p - c.ctrl[k]).length() / 11.5);
        }
        for (gv, cv) in [
            (g.c[0][3], c.r[0]),
            (g.c[1][3], c.r[1]),
            (g.c[2][3], c.w[0]),
            (g.c[3][3], c.w[1]),
        ] {
            assert!((gv as f64 - cv).abs() < 1e-6 * cv.abs().max(1.0));
        }
        worst_l = worst_l.max((g.lo[3] as f64 - c.lipschitz).abs() / c.lipschitz);
        let lo = glam::DVec3::new(g.lo[0] as f64, g.lo[1] as f64, g.lo[2] as f64);
        assert!((lo - c.lo).length() < 1e-4, "box {lo} vs {}", c.lo);
    }
    eprintln!("worst control point {worst_p:.2e} of the head, Lipschitz {worst_l:.2e}");
    assert!(
        worst_p < 1e-5,
        "worst control point difference {worst_p:.2e} of the head size"
    );
    assert!(
        worst_l < 1e-5,
        "worst Lipschitz bound difference {worst_l:.2e}"
    );
    // The capsules and wisp counts K against `curve::capsules`: K exactly, radii within
    // f32 rounding of the head size.
    let want_caps: Vec<_> =
        kami::systems::wisps::curve::capsules(&reference_segments(&w), w.threshold)
            .into_iter()
            .flatten()
            .collect();
    let mut worst_r = 0.0f64;
    for ((g, &k), c) in caps.iter().zip(&counts).zip(&want_caps) {
        assert_eq!(k, c.wisps_near, "wisps near a segment");
        worst_r = worst_r
            .max((g.a[3] as f64 - c.influence).abs())
            .max((g.b[3] as f64 - c.hit).abs());
        for i in 0..3 {
            worst_r = worst_r
                .max((g.a[i] as f64 - c.a[i]).abs())
                .max((g.b[i] as f64 - c.b[i]).abs());
        }
    }
    eprintln!("worst capsule difference {worst_r:.2e}");
    assert!(
        worst_r < 1e-4 * 11.5,
        "worst capsule difference {worst_r:.2e}"
    );
}

/// The GPU ray march and toon shading (f32, tiles, capsules, clear steps) against
/// `field::render_reference` (f64, every segment for every pixel from the eye: the truth) on
/// toon_divide, outline included: the share of pixels whose colour differs by more than 24
/// of 255, allowed 0.2 % (the bound before the tiled march). Also against its f64 twin
/// `render_reference_tiled` (same steps, every segment a candidate), whose step and
/// candidate counts must match the GPU's within 1 %.
#[test]
fn ray_march_matches_the_f64_reference_image() {
    use glam::{DMat3, DMat4, DVec3};
    let gpu = common::gpu();
    let scene = one_sample("toon_divide");
    let size = (96u32, 128u32);
    let img = render(&scene, size);
    let stage = kami::stage::Stage::new(
        gpu,
        &scene,
        kami::stage::target::OUTPUT_FORMAT,
        kami::stage::Quality::of(&scene),
    )
    .unwrap();
    let look = stage.look();
    let frame = kami::stage::frame_uniform(&scene, &look, stage.bounds(), size, 1);
    let vp = DMat4::from_cols_array_2d(&frame.view_proj.map(|c| c.map(|v| v as f64)));
    let w = scene.wisps().as_ref().unwrap();
    let bg = kami::systems::wisps::field::linear(scene.render.background);
    let (colours, _) = kami::systems::wisps::field::render_reference(
        &reference_segments(w),
        w.threshold,
        &w.march,
        &w.toon,
        DVec3::from(scene.light.direction),
        DMat3::IDENTITY,
        look.camera.eye,
        vp.inverse(),
        frame.raster[0] as f64,
        size,
        bg,
    );
    let srgb = |v: f64| {
        let v = v.clamp(0.0, 1.0);
        let s = if v <= 0.0031308 {
            12.92 * v
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0).round() as i32
    };
    let (mut over, mut shaded) = (0u32, 0u32);
    for (i, c) in colours.iter().enumerate() {
        let p = img.get_pixel(i as u32 % size.0, i as u32 / size.0);
        let want = [srgb(c.x), srgb(c.y), srgb(c.z)];
        let worst = (0..3).map(|k| (p[k] as i32 - want[k]).abs()).max().unwrap();
        over += u32::from(worst > 24);
        shaded += u32::from((c - bg).length() > 1e-3);
    }
    let n = (size.0 * size.1) as f64;
    eprintln!("{over} of {n} pixels over 24, {shaded} wisp pixels in the reference");
    assert!(
        shaded > 1000,
        "the reference shows the wisps on {shaded} pixels"
    );
    assert!(
        (over as f64) < 0.002 * n,
        "{over} of {n} pixels differ by more than 24 from the f64 reference"
    );
    // The twin: the same march in f64.
    let (twin, _, count) = kami::systems::wisps::field::render_reference_tiled(
        &reference_segments(w),
        w.threshold,
        &w.march,
        &w.toon,
        DVec3::from(scene.light.direction),
        DMat3::IDENTITY,
        look.camera.eye,
        vp.inverse(),
        frame.raster[0] as f64,
        size,
        bg,
        &[],
    );
    let mut twin_over = 0u32;
    for (i, c) in twin.iter().enumerate() {
        let p = img.get_pixel(i as u32 % size.0, i as u32 / size.0);
        let want = [srgb(c.x), srgb(c.y), srgb(c.z)];
        let worst = (0..3).map(|k| (p[k] as i32 - want[k]).abs()).max().unwrap();
        twin_over += u32::from(worst > 24);
    }
    eprintln!("{twin_over} of {n} pixels over 24 against the tiled twin, {count:?}");
    assert!(
        (twin_over as f64) < 0.002 * n,
        "{twin_over} of {n} pixels differ by more than 24 from the tiled twin"
    );
    let stats = march_stats(&scene, size);
    let near = |a: u32, b: u32| (a as f64 - b as f64).abs() <= 0.01 * b as f64;
    assert!(
        near(stats.steps, count.steps) && near(stats.candidates, count.candidates),
        "GPU counts {stats:?} against the twin's {count:?}"
    );
    assert_eq!(count.overflow, 0);
    assert!(stats.complete(), "{stats:?}");
}

/// The march's counters after one frame of `scene` at `size` (one sample per pixel).
fn march_stats(scene: &Scene, size: (u32, u32)) -> kami::systems::wisps::tiles::MarchStats {
    march_stats_with(scene, size, None)
}

fn march_stats_with(
    scene: &Scene,
    size: (u32, u32),
    slots: Option<u32>,
) -> kami::systems::wisps::tiles::MarchStats {
    use kami::systems::wisps::WispsSystem;
    let (gpu, stage) = drawn_with_slots(scene, size, true, slots);
    let sys = stage.system::<WispsSystem>().unwrap();
    sys.draw.read_stats(gpu).unwrap().unwrap()
}

/// Every segment whose influence capsule a pixel's ray crosses (f64) is in that pixel's
/// tile list (GPU), and the lists are in segment order (a wisp's segments together); the
/// lists equal the f64 binning (`tiles::tile_lists`) but for entries on a rectangle's edge.
#[test]
fn tile_lists_hold_every_segment_a_pixel_ray_crosses() {
    use glam::{DMat4, DVec3, DVec4};
    use kami::systems::wisps::{curve, tiles, WispsSystem};
    let scene = one_sample("toon_divide");
    let size = (80u32, 112u32);
    let (gpu, stage) = drawn(&scene, size, false);
    let look = stage.look();
    let sys = stage.system::<WispsSystem>().unwrap();
    let lists = sys.draw.tiles().unwrap().read_lists(gpu).unwrap();
    let frame = kami::stage::frame_uniform(&scene, &look, stage.bounds(), size, 1);
    let vp = DMat4::from_cols_array_2d(&frame.view_proj.map(|c| c.map(|v| v as f64)));
    let inv = vp.inverse();
    let w = scene.wisps().as_ref().unwrap();
    let segs = reference_segments(w);
    let caps: Vec<curve::Capsule> = curve::capsules(&segs, w.threshold)
        .into_iter()
        .flatten()
        .collect();
    let boxes: Vec<_> = segs.iter().flatten().map(|s| s.influence_box()).collect();
    let want = tiles::tile_lists(&tiles::tile_rects(&caps, &boxes, vp, size), size);
    let (mut differ, mut entries) = (0usize, 0usize);
    for (g, c) in lists.iter().zip(&want) {
        assert!(
            g.windows(2).all(|p| p[0] < p[1]),
            "a list out of order: {g:?}"
        );
        entries += c.len();
        differ += g.iter().filter(|j| !c.contains(j)).count();
        differ += c.iter().filter(|j| !g.contains(j)).count();
    }
    assert!(entries > 100, "{entries} entries in the f64 lists");
    assert!(
        differ * 100 <= entries,
        "{differ} of {entries} tile entries differ from the f64 binning"
    );
    let eye = look.camera.eye;
    let (tx, _) = tiles::grid(size);
    let mut crossings = 0;
    for py in 0..size.1 {
        for px in 0..size.0 {
            let nx = (px as f64 + 0.5) / size.0 as f64 * 2.0 - 1.0;
            let ny = 1.0 - (py as f64 + 0.5) / size.1 as f64 * 2.0;
            let far = inv * DVec4::new(nx, ny, 1.0, 1.0);
            let far = far.truncate() / far.w;
            let dir = (far - eye).normalize();
            let list = &lists[((py / tiles::TILE) * tx + px / tiles::TILE) as usize];
            for (j, c) in caps.iter().enumerate() {
                let crosses = curve::ray_capsule(eye, dir, c.a, c.b, c.influence)
                    .is_some_and(|(a, b)| b >= 0.0 && a <= (far - eye).length());
                if crosses {
                    crossings += 1;
                    assert!(
                        list.contains(&(j as u32)),
                        "pixel ({px}, {py}): segment {j} crosses its ray but is not in its tile"
                    );
                }
            }
        }
    }
    assert!(crossings > 1000, "{crossings} crossings");
    let _ = DVec3::ZERO;
}

/// A ray through more influence capsules than its list holds (sixty faint wisps one behind
/// the other: weight 0.4 under the threshold 0.5, so none makes a surface and the ray
/// passes them all) keeps the nearest and counts the rays whose answer lies beyond a dropped
/// one (no outline, which would end them early): the stats say so, `Stage::warnings` names
/// it, and the f64 twin counts the centre
/// ray. A solid wisp in front of the stack ends every ray before the dropped ones: nothing
/// is counted.
/// A thick wisp across the view axis at depth `z`.
fn across(z: f64) -> String {
    format!("Skeleton(nodes: [Node(p: (-3.0, 0.0, {z}), r: 1.0, w: 2.5), Node(p: (3.0, 0.0, {z}), r: 1.0, w: 2.5)]),")
}

fn stack_scene(skeletons: &str, front: bool) -> Scene {
    let mut skeletons = skeletons.to_string();
    if front {
        skeletons += &across(14.0);
    }
    let text = format!(
        "Scene(head: Head(radii: (1.0, 1.0, 1.0), visible: false), \
         wisps: Some(Wisps(threshold: 0.5, toon: Toon(outline_width: 0.0), march: March(max_steps: 4096), draw: March, skeletons: [{skeletons}])), \
         camera: CameraDesc(eye: (0.0, 0.0, 40.0), target: (0.0, 0.0, 0.0), fov_y: 20.0), \
         render: RenderSettings(supersample: 1, msaa: 1))"
    );
    Scene::from_ron(&text, "stack.ron").unwrap()
}

/// The f64 twin's march of the ray down the axis of a `stack_scene`.
fn axis_march(
    scene: &Scene,
    slots: usize,
) -> (
    kami::systems::wisps::field::Hit,
    kami::systems::wisps::field::MarchCount,
    usize,
) {
    use kami::systems::wisps::field;
    let w = scene.wisps().as_ref().unwrap();
    let segs = reference_segments(w);
    let caps = kami::systems::wisps::curve::capsules(&segs, w.threshold);
    let shells: Vec<Vec<f64>> = caps
        .iter()
        .map(|c| c.iter().map(|c| c.hit).collect())
        .collect();
    let ray = field::Ray {
        origin: glam::DVec3::new(0.0, 0.0, 40.0),
        dir: glam::DVec3::new(0.0, 0.0, -1.0),
        t0: 0.0,
        t1: 100.0,
    };
    let cands = field::candidates(&caps, &shells, &ray);
    let lines = field::Outlines {
        per_segment: &[],
        taper: 0.0,
    };
    let (hit, count) = field::march_tiled(&segs, &cands, 0.5, &w.march, &ray, 0.0, &lines, slots);
    (hit, count, cands.len())
}

/// Sixty thin wisps stacked one behind the other along the view ray (each too thin to reach
/// the threshold alone) and a thick one behind them all: the ray crosses 61 influence
/// capsules, a few at a time. The list holds 48, so the march takes them a window at a time
/// and gathers again at each window's end: nothing is dropped, on the GPU or in the f64
/// twin, and the ray reaches the thick wisp at the back. (With one list per ray, as before,
/// the farthest were dropped and the ray was counted; without the second gather it would
/// see nothing.)
#[test]
fn deep_stacks_along_a_ray_are_marched_window_by_window() {
    let mut skeletons = String::new();
    for k in 0..60 {
        let z = -12.0 + 0.4 * k as f64;
        skeletons += &format!(
            "Skeleton(nodes: [Node(p: (-3.0, 0.0, {z}), r: 0.5, w: 0.4), Node(p: (3.0, 0.0, {z}), r: 0.5, w: 0.4)]),"
        );
    }
    skeletons += &across(-16.0);
    let scene = stack_scene(&skeletons, false);
    let stats = march_stats(&scene, (32, 32));
    assert_eq!(stats.slots, 48, "a few capsules meet: the fewest slots");
    assert!(stats.complete(), "{stats:?}");
    assert!(stats.candidates >= 61, "{stats:?}");
    let (hit, count, n) = axis_march(&scene, 48);
    assert_eq!(n, 61);
    assert_eq!(count.overflow, 0);
    match hit {
        kami::systems::wisps::field::Hit::Surface { t, .. } => assert!(
            (t - 55.365).abs() < 0.05,
            "hit at {t}: the back wisp's surface is at 56 - 0.635"
        ),
        h => panic!("{h:?}"),
    }
    // The centre pixel shows the thick wisp at the back (toon colours are blue-violet).
    let img = render(&scene, (32, 32));
    let centre = img.get_pixel(16, 16);
    assert!(is_hair(centre), "the back wisp is not drawn: {centre:?}");
}

/// Sixty wisps crossing at one point on the view axis: there all sixty touch the ray at once.
/// The scene's own lists hold them (`field::ray_slots` sizes them from the capsules that
/// meet); held to 48, one is dropped for good and the ray (whose hit lies beyond) is counted
/// and reported with the slots it needed, on the GPU and by the f64 twin; with a wisp in
/// front that hides the crossing, nothing is counted.
#[test]
fn overflowing_ray_lists_are_counted_and_reported() {
    let mut skeletons = String::new();
    for k in 0..60 {
        let a = std::f64::consts::PI * k as f64 / 60.0;
        let (c, s) = (3.0 * a.cos(), 3.0 * a.sin());
        skeletons += &format!(
            "Skeleton(nodes: [Node(p: ({}, {}, 0.0), r: 0.5, w: 0.4), Node(p: ({c}, {s}, 0.0), r: 0.5, w: 0.4)]),",
            -c, -s
        );
    }
    let scene = stack_scene(&skeletons, false);
    let own = march_stats(&scene, (32, 32));
    assert!(own.slots >= 64, "{own:?}");
    assert!(own.complete(), "{own:?}");
    let shielded = march_stats_with(&stack_scene(&skeletons, true), (32, 32), Some(48));
    assert!(shielded.complete(), "{shielded:?}");
    let stats = march_stats_with(&scene, (32, 32), Some(48));
    assert!(stats.ray_overflow > 0, "{stats:?}");
    assert!(stats.slots_needed > 48, "{stats:?}");
    assert!(!stats.complete());
    let (gpu, stage) = drawn_with_slots(&scene, (32, 32), false, Some(48));
    let warnings = stage.warnings(gpu).unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("dropped") && w.contains("the lists hold 48")),
        "{warnings:?}"
    );
    let (hit, count, n) = axis_march(&scene, 48);
    assert_eq!(n, 60);
    assert_eq!(count.overflow, 1);
    assert!(
        matches!(hit, kami::systems::wisps::field::Hit::Surface { .. }),
        "{hit:?}"
    );
}

/// Issue 34: 200 wisps (`toon.ron`'s 22 multiplied, `bench::wisps::with_count`) draw with
/// nothing dropped: no tile list and no ray list overflows. Near the crown, where the
/// copies' roots meet, more than 96 candidates touch one ray at once: the scene's lists are
/// sized for that (with 48 slots 151 rays overflowed, with 96 10, with 192 none).
#[test]
fn two_hundred_wisps_overflow_nothing() {
    let scene = kami::bench::wisps::with_count(&one_sample("toon"), 200);
    assert_eq!(scene.wisps().as_ref().unwrap().skeletons.len(), 200);
    let stats = march_stats(&scene, (320, 180));
    println!("{stats:?}");
    assert!(stats.covered > 5_000, "{stats:?}");
    assert!(stats.complete(), "{stats:?}");
}

/// Tile lists that cannot fit the adapter are refused before anything is allocated, with
/// the numbers.
#[test]
fn tile_lists_too_large_for_the_adapter_are_refused() {
    let gpu = common::gpu();
    let err = kami::systems::wisps::tiles::capacity(gpu, 500, 1 << 40).unwrap_err();
    let text = err.to_string();
    assert!(text.contains("tile lists"), "{text}");
    assert!(text.contains(&format!("{}", (1u64 << 40) * 64)), "{text}");
}
