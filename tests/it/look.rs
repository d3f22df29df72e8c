//! The exporter `kami bench look` hands the path tracer (`bench::look::write_mitsuba`):
//! the curve files hold every exported strand's points and radii (width / 2) in scene
//! units, and the camera and key light written are Kami's (a point projects to the same
//! pixel through Kami's view-projection and through the written Mitsuba camera). No
//! Mitsuba needed.

use glam::{DVec2, DVec3};
use kami::bench::look::{environment, irradiance, write_mitsuba};
use kami::formats::Groom;
use kami::gpu::view::{Camera, ScreenView};

/// The first `key="x, y, z"` triple after `after` in `xml`.
fn triple(xml: &str, after: &str, key: &str) -> DVec3 {
    let from = xml
        .find(after)
        .unwrap_or_else(|| panic!("no {after} in\n{xml}"));
    let rest = &xml[from..];
    let at = rest.find(&format!("{key}=\"")).unwrap() + key.len() + 2;
    let v: Vec<f64> = rest[at..at + rest[at..].find('"').unwrap()]
        .split(',')
        .map(|s| s.trim().parse().unwrap())
        .collect();
    DVec3::new(v[0], v[1], v[2])
}

/// The value of `<... name="name" value="v"/>` after `after`.
fn value(xml: &str, after: &str, name: &str) -> f64 {
    let rest = &xml[xml.find(after).unwrap()..];
    let tag = format!("name=\"{name}\" value=\"");
    let at = rest.find(&tag).unwrap() + tag.len();
    rest[at..at + rest[at..].find('"').unwrap()]
        .parse()
        .unwrap()
}

/// Mitsuba's `perspective` sensor (look_at frame: left = up x dir; `fov_axis` y): the pixel
/// `p` lands on, origin top left, y down.
fn mitsuba_pixel(o: DVec3, target: DVec3, up: DVec3, fov_deg: f64, size: DVec2, p: DVec3) -> DVec2 {
    let dir = (target - o).normalize();
    let left = up.cross(dir).normalize();
    let new_up = dir.cross(left);
    let q = p - o;
    let (x, y, z) = (q.dot(left), q.dot(new_up), q.dot(dir));
    let t = (0.5 * fov_deg.to_radians()).tan();
    let aspect = size.x / size.y;
    DVec2::new(
        (1.0 - x / (z * t * aspect)) * 0.5 * size.x,
        (1.0 - y / (z * t)) * 0.5 * size.y,
    )
}

#[test]
fn the_reference_scene_holds_kamis_strands_camera_and_light() {
    let scene = kami::Scene::load(kami::scene::shipped("assets/scenes/bob.ron")).unwrap();
    // Three strands of two colours (two BSDF groups), widths tapering.
    let groom = Groom {
        counts: vec![3, 2, 4],
        points: vec![
            [1.0, 2.0, 3.0],
            [1.5, 1.0, 3.25],
            [2.0, -0.5, 3.5],
            [-4.0, 8.0, 1.0],
            [-4.5, 6.0, 1.5],
            [0.0, 10.0, 0.0],
            [0.25, 9.0, 0.5],
            [0.5, 8.0, 1.0],
            [0.75, 7.0, 1.5],
        ],
        widths: Some(vec![0.07, 0.05, 0.03, 0.08, 0.02, 0.1, 0.09, 0.08, 0.07]),
        colors: Some(
            [[0.2, 0.1, 0.05]; 3]
                .into_iter()
                .chain([[0.9, 0.8, 0.1]; 2])
                .chain([[0.2, 0.1, 0.05]; 4])
                .collect(),
        ),
        ..Default::default()
    };
    let dir = std::env::temp_dir().join("kami_look_export");
    let _ = std::fs::remove_dir_all(&dir);
    let size = (320, 200);
    let xml_path = write_mitsuba(&dir, &scene, &groom, size, 16, "test").unwrap();
    let xml = std::fs::read_to_string(&xml_path).unwrap();

    // Every strand, point and radius, read back from the curve files the XML names.
    let mut read: Vec<Vec<[f64; 4]>> = Vec::new();
    let mut k = 0;
    while let Some(at) = xml.find(&format!("value=\"hair_{k}.txt\"")) {
        assert!(xml[..at].rfind("<shape type=\"linearcurve\">").is_some());
        let text = std::fs::read_to_string(dir.join(format!("hair_{k}.txt"))).unwrap();
        for curve in text.split("\n\n") {
            read.push(
                curve
                    .lines()
                    .map(|l| {
                        let v: Vec<f64> = l.split(' ').map(|s| s.parse().unwrap()).collect();
                        assert_eq!(v.len(), 4, "{l:?}: x y z radius");
                        [v[0], v[1], v[2], v[3]]
                    })
                    .collect(),
            );
        }
        k += 1;
    }
    assert_eq!(k, 2, "one curve file per colour");
    assert_eq!(read.len(), groom.counts.len(), "every strand written once");
    let widths = groom.widths.as_ref().unwrap();
    let mut first = 0;
    for (i, &c) in groom.counts.iter().enumerate() {
        let want: Vec<[f64; 4]> = (first..first + c as usize)
            .map(|j| {
                let p = groom.points[j];
                [
                    p[0] as f64,
                    p[1] as f64,
                    p[2] as f64,
                    0.5 * widths[j] as f64,
                ]
            })
            .collect();
        first += c as usize;
        let hits = read
            .iter()
            .filter(|r| {
                r.len() == want.len()
                    && r.iter()
                        .zip(&want)
                        .all(|(a, b)| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6))
            })
            .count();
        assert_eq!(
            hits, 1,
            "strand {i} ({want:?}) not written exactly once: {read:?}"
        );
    }

    // The camera: a point projects where Kami draws it.
    let cam = Camera::from_desc(&scene.camera);
    let sz = DVec2::new(size.0 as f64, size.1 as f64);
    let view = ScreenView::from_camera(&cam, glam::DMat4::IDENTITY, sz, (DVec3::ZERO, 30.0));
    let o = triple(&xml, "<lookat", "origin");
    let t = triple(&xml, "<lookat", "target");
    let up = triple(&xml, "<lookat", "up");
    let fov = value(&xml, "<sensor", "fov");
    assert!(xml.contains("name=\"fov_axis\" value=\"y\""));
    assert_eq!(value(&xml, "<film", "width"), size.0 as f64);
    assert_eq!(value(&xml, "<film", "height"), size.1 as f64);
    for p in [
        DVec3::new(1.0, 2.0, 3.0),
        DVec3::new(-6.0, 9.0, -2.0),
        DVec3::new(8.0, -10.0, 4.0),
    ] {
        let kami = view.project(p).unwrap().truncate();
        let mitsuba = mitsuba_pixel(o, t, up, fov, sz, p);
        assert!(
            (kami - mitsuba).length() < 1e-3,
            "{p}: Kami draws it at {kami}, the reference at {mitsuba}"
        );
    }

    // The key light shines away from `light.direction`, with Kami's intensity and colour;
    // the environment is the documented share of the ambient.
    let d = triple(&xml, "<emitter type=\"directional\"", "value");
    let l = DVec3::from(scene.light.direction).normalize();
    assert!(
        (d + l).length() < 1e-9,
        "light travels along {d}, Kami's comes from {l}"
    );
    let e = triple(&xml, "name=\"irradiance\"", "value");
    assert!((e - DVec3::from(irradiance(&scene))).length() < 1e-9);
    assert!(
        (e.x - std::f64::consts::PI * scene.light.intensity * scene.light.color[0] as f64).abs()
            < 1e-9
    );
    let r = triple(&xml, "<emitter type=\"constant\"", "value");
    assert!((r - DVec3::from(environment(&scene))).length() < 1e-9);

    // The bob's head (an ellipsoid) is a mesh the reference can hold.
    assert!(dir.join("head.obj").is_file());
    assert!(xml.contains("value=\"head.obj\""));
}
