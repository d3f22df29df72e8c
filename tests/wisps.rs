//! Toon wisps through the stage: snapshots of the shipped scenes, depth composition with the
//! head, and clear errors for bad skeletons.
//!
//! Snapshot tolerance as in `tests/snapshot.rs` (mean <= 0.25 of 255, at most 0.2 % of
//! pixels off by more than 24), at one sample per pixel: the ray march is the costly pass on
//! the software adapter.

mod common;
use common::{check_snapshot, Tolerance};
use kami::{KamiError, Scene};

const TOL: Tolerance = Tolerance {
    mean: 0.25,
    threshold: 24,
    share: 0.002,
};

fn render(scene: &Scene, size: (u32, u32)) -> image::RgbaImage {
    let gpu = common::gpu();
    kami::stage::render_scene(&gpu, scene, size).unwrap()
}

fn one_sample(name: &str) -> Scene {
    let mut s = common::scene(name);
    s.render.supersample = 1;
    s.render.msaa = 1;
    s
}

#[test]
fn toon_snapshot() {
    let img = render(&one_sample("toon"), (256, 256));
    check_snapshot("toon", &img, TOL);
}

#[test]
fn toon_divide_snapshot() {
    let img = render(&one_sample("toon_divide"), (192, 256));
    check_snapshot("toon_divide", &img, TOL);
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
    let bangs = share(50, 78, 12, 20, &is_hair);
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
    let (r, w, t) = (1.5, 2.5, 0.5);
    let vis = r * (1.0 - (t / (1.5 * w) as f64).sqrt());
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

fn invalid(text: &str) -> (String, String, String) {
    match Scene::from_ron(text, "toon.ron") {
        Err(KamiError::Invalid {
            file,
            field,
            value,
            allowed,
        }) => {
            assert_eq!(file, "toon.ron");
            (field, value, allowed)
        }
        other => panic!("expected a validation error, got {other:?}"),
    }
}

fn with(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "{from} not in the template");
    GOOD.replacen(from, to, 1)
}

#[test]
fn good_wisps_load() {
    let s = Scene::from_ron(GOOD, "toon.ron").unwrap();
    assert_eq!(s.wisps.unwrap().skeletons[0].nodes.len(), 3);
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
