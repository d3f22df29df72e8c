//! Bad input gets a clear error — naming the field, the value and what is allowed, or the
//! line and column — never a panic and never a NaN.

use crate::common;
use crate::common::invalid;
use crate::common::scratch;
use kami::{KamiError, Scene};

const GOOD: &str = r#"Scene(
    head: Head(radii: (9.6, 11.5, 7.8)),
    groups: [
        HairGroup(
            roots: Roots(theta: (3.0, 60.0), phi: (-180.0, 180.0)),
            count: 100,
            segments: 10,
            length: 12.0,
            rigidity: 50.0,
        ),
    ],
)"#;

fn with(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "{from} not in the template");
    GOOD.replacen(from, to, 1)
}

#[test]
fn good_scene_loads() {
    Scene::from_ron(GOOD, "test.ron").unwrap();
    for name in common::shipped_scenes() {
        common::scene(&name);
    }
}

#[test]
fn syntax_error_has_line_and_column() {
    let text = with("count: 100,", "count: 100,,");
    match Scene::from_ron(&text, "test.ron") {
        Err(KamiError::Parse {
            path,
            line,
            col,
            message,
        }) => {
            assert_eq!(path, "test.ron");
            assert_eq!(line, 6, "{message}");
            assert!(col > 1);
            let shown = Scene::from_ron(&text, "test.ron").unwrap_err().to_string();
            assert!(shown.starts_with("test.ron:6:"), "{shown}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn unknown_field_and_wrong_type_are_parse_errors() {
    for text in [
        with("rigidity: 50.0,", "rigidty: 50.0,"),
        with("count: 100,", "count: \"many\","),
    ] {
        let e = Scene::from_ron(&text, "test.ron").unwrap_err();
        assert!(matches!(e, KamiError::Parse { .. }), "{e}");
    }
    let e = Scene::from_ron(&with("rigidity: 50.0,", "rigidty: 50.0,"), "x.ron")
        .unwrap_err()
        .to_string();
    assert!(e.contains("rigidty"), "{e}");
}

#[test]
fn out_of_range_values_name_the_field() {
    let cases = [
        ("rigidity: 50.0,", "rigidity: -3.0,", "groups[0].rigidity"),
        ("rigidity: 50.0,", "rigidity: inf,", "groups[0].rigidity"),
        ("rigidity: 50.0,", "rigidity: NaN,", "groups[0].rigidity"),
        ("segments: 10,", "segments: 0,", "groups[0].segments"),
        ("segments: 10,", "segments: 100000,", "groups[0].segments"),
        ("count: 100,", "count: 0,", "groups[0].count"),
        ("length: 12.0,", "length: 0.0,", "groups[0].length"),
        ("theta: (3.0, 60.0)", "theta: (60.0, 3.0)", "groups[0].roots.theta"),
        ("theta: (3.0, 60.0)", "theta: (3.0, 200.0)", "groups[0].roots.theta.1"),
        ("phi: (-180.0, 180.0)", "phi: (-180.0, 300.0)", "groups[0].roots.phi"),
        ("radii: (9.6, 11.5, 7.8)", "radii: (9.6, 0.0, 7.8)", "head.radii[1]"),
        ("rigidity: 50.0,", "rigidity: 50.0, length_jitter: 2.0,", "groups[0].length_jitter"),
        ("rigidity: 50.0,", "rigidity: 50.0, material: Material(ks: -1.0),", "groups[0].material.ks"),
        ("rigidity: 50.0,", "rigidity: 50.0, material: Material(width: 0.0),", "groups[0].material.width"),
        ("rigidity: 50.0,", "rigidity: 50.0, bending: Converged(max_iterations: 0),", "groups[0].bending.max_iterations"),
        ("rigidity: 50.0,", "rigidity: 50.0, loads: [Uniform(force: (0.0, inf, 0.0))],", "groups[0].loads[0].force[1]"),
        ("rigidity: 50.0,", "rigidity: 50.0, loads: [Uniform(force: (1.0, 0.0, 0.0), region: [HalfSpace(normal: (0.0, 0.0, 0.0), offset: 0.0)])],", "groups[0].loads[0].region[0].normal"),
        ("rigidity: 50.0,", "rigidity: 50.0, cuts: [Cut(rule: ByPoreHeight(low: (5.0, 3), high: (1.0, 4)))],", "groups[0].cuts[0].rule"),
        ("rigidity: 50.0,", "rigidity: 50.0, cuts: [Cut(rule: ByPoreHeight(low: (1.0, 3), high: (5.0, 40)))],", "groups[0].cuts[0].rule.high.1"),
        ("rigidity: 50.0,", "rigidity: 50.0, direction: Blend(dir: (0.0, 0.0, 0.0), weight: 0.5),", "groups[0].direction.dir"),
        ("phi: (-180.0, 180.0)", "phi: (-180.0, 180.0), hairline: Some([(10.0, 50.0), (5.0, 60.0)])", "groups[0].roots.hairline[1].0"),
    ];
    for (from, to, field) in cases {
        let (f, value, allowed) = invalid(&with(from, to));
        assert_eq!(f, field, "for {to}");
        assert!(!value.is_empty() && !allowed.is_empty());
        let shown = KamiError::Invalid {
            file: String::new(),
            field: f,
            value,
            allowed,
        }
        .to_string();
        assert!(shown.contains(field), "{shown}");
    }
}

#[test]
fn scene_level_values_are_checked() {
    let tail = "    ],\n)";
    let cases = [
        ("    ],\n    camera: CameraDesc(eye: (1.0, 2.0, 3.0), target: (1.0, 2.0, 3.0)),\n)", "camera.target"),
        ("    ],\n    camera: CameraDesc(eye: (0.0, 10.0, 0.0), target: (0.0, 0.0, 0.0)),\n)", "camera.up"),
        ("    ],\n    camera: CameraDesc(eye: (40.0, 0.0, 0.0), target: (0.0, 0.0, 0.0), fov_y: 179.0),\n)", "camera.fov_y"),
        ("    ],\n    light: Light(direction: (0.0, 0.0, 0.0)),\n)", "light.direction"),
        ("    ],\n    render: RenderSettings(msaa: 2),\n)", "render.msaa"),
        ("    ],\n    render: RenderSettings(supersample: 9),\n)", "render.supersample"),
        ("    ],\n    render: RenderSettings(size: (0, 100)),\n)", "render.size.0"),
        ("    ],\n    groom_load: (0.0, NaN, 0.0),\n)", "groom_load[1]"),
        ("    ],\n    dynamics: Some(Dynamics(dt: 0.0)),\n)", "dynamics.dt"),
        ("    ],\n    dynamics: Some(Dynamics(dt: NaN)),\n)", "dynamics.dt"),
        ("    ],\n    dynamics: Some(Dynamics(damping: -1.0)),\n)", "dynamics.damping"),
        ("    ],\n    forces: ForcesDesc(wind: [WindKey(frame: 5.0, force: (1.0, 0.0, 0.0)), WindKey(frame: 5.0, force: (0.0, 1.0, 0.0))]),\n)", "forces.wind[1].frame"),
        ("    ],\n    forces: ForcesDesc(wind: [WindKey(frame: 0.0, force: (inf, 0.0, 0.0))]),\n)", "forces.wind[0].force[0]"),
        ("    ],\n    forces: ForcesDesc(head_motion: [HeadKey(frame: 0.0, rotate: (0.0, NaN, 0.0))]),\n)", "forces.head_motion[0].rotate[1]"),
        ("    ],\n    dynamics: Some(Dynamics(pseudo_force: Some(PseudoForce(alpha: -2.0, epsilon_pore: 0.1, near: 1.0)))),\n)", "dynamics.pseudo_force.alpha"),
        ("    ],\n    dynamics: Some(Dynamics(stiffness: Stiffness(tip: 200.0))),\n)", "dynamics.stiffness.tip"),
        ("    ],\n    dynamics: Some(Dynamics(stiffness: Stiffness(start: 0.5, end: 0.5))),\n)", "dynamics.stiffness.end"),
        ("    ],\n    dynamics: Some(Dynamics(fluctuation: Some(Fluctuation(amplitude: 5.0, period: 0)))),\n)", "dynamics.fluctuation.period"),
    ];
    for (replacement, field) in cases {
        let text = GOOD.replacen(tail, replacement, 1);
        assert_eq!(invalid(&text).0, field, "for {replacement}");
    }
    let empty = "Scene(head: Head(radii: (1.0, 1.0, 1.0)), groups: [])";
    assert_eq!(invalid(empty).0, "groups");
}

#[test]
fn missing_file_is_an_io_error() {
    let e = Scene::load("/nonexistent/scene.ron").unwrap_err();
    assert!(matches!(e, KamiError::Io { .. }), "{e}");
    assert!(e.to_string().contains("/nonexistent/scene.ron"));
}

#[test]
fn unknown_backend_and_no_adapter_are_clear() {
    let e = kami::gpu::parse_backend(Some("glide")).unwrap_err();
    assert!(
        e.to_string().contains("glide") && e.to_string().contains("vulkan"),
        "{e}"
    );
    assert_eq!(
        kami::gpu::parse_backend(Some("Vulkan")).unwrap(),
        wgpu::Backends::VULKAN
    );
    // No Metal on Linux, no DX12 outside Windows: "no adapter" must say what to install.
    let none = if cfg!(target_os = "macos") {
        wgpu::Backends::DX12
    } else {
        wgpu::Backends::METAL
    };
    match kami::gpu::Gpu::headless_on(none, kami::gpu::Preference::Software) {
        Err(e @ KamiError::NoAdapter { .. }) => {
            assert!(e.to_string().contains("mesa-vulkan-drivers"), "{e}")
        }
        Err(e) => panic!("expected NoAdapter, got {e}"),
        Ok(_) => panic!("expected no adapter on {none:?}"),
    }
}

#[test]
fn sizes_beyond_the_adapter_are_refused_before_allocating() {
    let gpu = common::gpu();
    let mut scene = Scene::from_ron(GOOD, "test.ron").unwrap();
    // 4 million hairs of 256 segments: gigabytes of vertices.
    scene.groups_mut()[0].count = 4_000_000;
    scene.groups_mut()[0].segments = 256;
    refused_as_too_large(gpu, &scene, "vertex");
    let mut scene = Scene::from_ron(GOOD, "test.ron").unwrap();
    scene.render.supersample = 4;
    let side = gpu.device.limits().max_texture_dimension_2d;
    match kami::stage::render_scene(gpu, &scene, (side, 16)) {
        Err(KamiError::TooLarge { what, .. }) => assert!(what.contains("width"), "{what}"),
        other => panic!("expected TooLarge, got {:?}", other.map(|_| ())),
    }
}

/// Extreme but valid parameters give finite hair on the GPU too.
#[test]
fn extreme_valid_scene_renders_finite_hair() {
    let gpu = common::gpu();
    let text = with(
        "rigidity: 50.0,",
        "rigidity: 1e-9, bending: Converged(max_iterations: 40),",
    )
    .replacen(
        "    ],\n)",
        "    ],\n    groom_load: (1e9, -1e9, 0.0),\n)",
        1,
    );
    let scene = Scene::from_ron(&text, "extreme.ron").unwrap();
    let input = kami::systems::anjyo::groom::prepare(&scene).unwrap();
    let hair = kami::systems::anjyo::cantilever_gpu::groom_gpu(
        gpu,
        &common::groom_world(gpu, &input),
        &input,
    )
    .unwrap();
    let v = hair.read_vertices(gpu).unwrap();
    assert!(
        v.iter().all(|p| p.iter().all(|c| c.is_finite())),
        "non-finite node"
    );
    let img = kami::stage::render_scene(gpu, &scene, (64, 64)).unwrap();
    assert_eq!(img.dimensions(), (64, 64));
}

/// The command line reports bad arguments and bad files without a panic.
#[test]
fn cli_reports_errors() {
    let exe = env!("CARGO_BIN_EXE_kami");
    let dir = std::env::temp_dir().join(format!("kami-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.ron");
    std::fs::write(&bad, with("rigidity: 50.0,", "rigidity: -1.0,")).unwrap();
    let run = |args: &[&str]| std::process::Command::new(exe).args(args).output().unwrap();
    let out = run(&[
        "render",
        bad.to_str().unwrap(),
        "-o",
        dir.join("x.png").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("groups[0].rigidity") && !err.contains("panicked"),
        "{err}"
    );
    let out = run(&["render", bad.to_str().unwrap(), "--size", "12by34"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("1280x720"), "{err}");
    let out = run(&["render", "/nonexistent.ron"]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("nonexistent"));
}

/// `kami bench dynamics` on a scene without dynamics says so and exits non-zero (it used to
/// panic on an `expect`).
#[test]
fn bench_dynamics_on_a_still_scene_is_a_clear_error() {
    let out_dir = std::env::temp_dir().join(format!("kami-bench-bob-{}", std::process::id()));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_kami"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "bench",
            "dynamics",
            "--software",
            "--scene",
            "assets/scenes/bob.ron",
            "--out",
        ])
        .arg(&out_dir)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("running kami bench dynamics");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "bench dynamics on bob succeeded");
    assert!(!err.contains("panicked"), "it panicked:\n{err}");
    assert!(
        err.contains("bob.ron") && err.contains("dynamics"),
        "the error does not name the file and the missing block:\n{err}"
    );
    assert!(!out_dir.exists(), "nothing is written for a refused scene");
}

/// Fur at the 4 million-hair cap (about 512 MB of nodes; software adapters bind 128 MB) is
/// refused by the limits check, before the mesh is read or any buffer is made (the check
/// iterates every kind of hair, not only Anjyo's groups).
#[test]
fn fur_beyond_the_adapter_is_refused_before_allocating() {
    let gpu = common::gpu();
    let mut scene = common::scene("fur");
    scene.fur_mut().as_mut().unwrap().hairs = 4_000_000;
    kami::systems::validate(&scene).unwrap();
    refused_as_too_large(gpu, &scene, "fur");
}

/// `check_limits` refuses `scene` with a `TooLarge` naming `what`, needing more than allowed.
fn refused_as_too_large(gpu: &kami::gpu::Gpu, scene: &Scene, what: &str) {
    match kami::stage::check_limits(gpu, scene, (64, 64)) {
        Err(KamiError::TooLarge {
            what: w,
            needed,
            limit,
            ..
        }) => {
            assert!(w.contains(what), "{w}");
            assert!(needed > limit);
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
}

/// A folder given as the scene says it is a folder (it used to be a bare "Is a directory").
#[test]
fn a_directory_as_scene_says_so() {
    let dir = scratch("dir");
    let e = Scene::load(&dir).unwrap_err();
    assert!(matches!(e, KamiError::Io { .. }), "{e:?}");
    let shown = e.to_string();
    assert!(
        shown.contains(&dir.display().to_string()) && shown.contains("it is a directory"),
        "{shown}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A file we may not read is an I/O error naming it and the reason.
#[test]
fn an_unreadable_scene_names_the_file() {
    use std::os::unix::fs::PermissionsExt;
    let dir = scratch("perm");
    let path = dir.join("locked.ron");
    std::fs::write(&path, GOOD).unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o000)).unwrap();
    // Root (as in many CI containers) reads a mode-000 file anyway: nothing to check then.
    if std::fs::File::open(&path).is_err() {
        let e = Scene::load(&path).unwrap_err();
        match &e {
            KamiError::Io { source, .. } => {
                assert_eq!(source.kind(), std::io::ErrorKind::PermissionDenied, "{e}")
            }
            other => panic!("expected Io, got {other:?}"),
        }
        assert!(e.to_string().contains("locked.ron"), "{e}");
    } else {
        eprintln!("running as root: a mode-000 file is readable, permission check skipped");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A scene that is not UTF-8 names the file, line, column and offset of the first bad byte.
#[test]
fn non_utf8_scene_names_the_first_bad_byte() {
    let dir = scratch("utf8");
    let path = dir.join("latin1.ron");
    // Line 6 is `            count: 100,`: the bad byte goes where `100` starts, after
    // a valid two-byte character so that columns count characters, not bytes.
    let text = with("count: 100,", "count: \u{e9}\u{ff}100,");
    let mut bytes = text.into_bytes();
    let at = bytes
        .windows(2)
        .position(|w| w == "\u{ff}".as_bytes())
        .unwrap();
    bytes.splice(at..at + 2, [0xff]);
    std::fs::write(&path, &bytes).unwrap();
    match Scene::load(&path) {
        Err(KamiError::Parse {
            path: p,
            line,
            col,
            message,
        }) => {
            assert!(p.ends_with("latin1.ron"), "{p}");
            assert_eq!((line, col), (6, 21), "{message}");
            assert!(
                message.contains("0xff") && message.contains(&format!("offset {at}")),
                "{message}"
            );
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// 100,000 nested brackets are a parse error, not a stack overflow; run on a 256 KiB stack so
/// the test does not lean on the main thread's large one.
#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    const N: usize = 100_000;
    let deep = |open: &str| open.repeat(N);
    let cases = [
        deep("("),
        deep("["),
        deep("{"),
        format!("Scene({}", deep("(")),
        GOOD.replacen(
            "    ],\n)",
            &format!("    ],\n    dynamics: {}", deep("Some(")),
            1,
        ),
        with("phi: (-180.0, 180.0)", &format!("phi: {}", deep("("))),
        with("rigidity: 50.0,", &format!("rigidity: {}", deep("["))),
        with(
            "rigidity: 50.0,",
            &format!(
                "rigidity: 50.0, loads: {}",
                deep("[Uniform(force: (1.0, 0.0, 0.0), region: ")
            ),
        ),
        // Unknown fields of struct variants were once skipped by parsing any value, the one
        // place where ron follows nesting that the scene types do not bound.
        with(
            "rigidity: 50.0,",
            &format!(
                "rigidity: 50.0, direction: Blend(dir: (1.0, 0.0, 0.0), weight: 0.5, x: {}",
                deep("(")
            ),
        ),
    ];
    let worker = std::thread::Builder::new()
        .stack_size(256 * 1024)
        .spawn(move || {
            cases
                .iter()
                .map(|text| Scene::from_ron(text, "deep.ron"))
                .collect::<Vec<_>>()
        })
        .unwrap();
    for result in worker.join().expect("the parser thread died") {
        match result {
            Err(KamiError::Parse { path, .. }) => assert_eq!(path, "deep.ron"),
            other => panic!("expected a parse error, got {other:?}"),
        }
    }
}

/// A misspelt optional field of a struct variant is an error, not silently its default.
#[test]
fn unknown_fields_of_variants_are_refused() {
    for (to, name) in [
        ("bending: Converged(max_iteration: 10),", "max_iteration"),
        ("direction: Blend(dir: (1.0, 0.0, 0.0), weight: 0.5, wieght: 0.1),", "wieght"),
        ("loads: [Uniform(force: (1.0, 0.0, 0.0), regions: [Above(0.0)])],", "regions"),
        ("loads: [Toward(point: (1.0, 0.0, 0.0), strength: 1.0, strenght: 2.0)],", "strenght"),
        ("loads: [Uniform(force: (1.0, 0.0, 0.0), region: [HalfSpace(normal: (1.0, 0.0, 0.0), offset: 0.0, ofset: 1.0)])],", "ofset"),
        ("cuts: [Cut(rule: Near(center: (0.0, 0.0, 0.0), radius: 1.0, radus: 2.0))],", "radus"),
    ] {
        let text = with("rigidity: 50.0,", &format!("rigidity: 50.0, {to}"));
        match Scene::from_ron(&text, "typo.ron") {
            Err(e @ KamiError::Parse { .. }) => assert!(e.to_string().contains(name), "{e}"),
            other => panic!("expected a parse error for {to}, got {other:?}"),
        }
    }
}

/// A fur scene using every block, each with a valid value to break one at a time.
const FUR: &str = r#"Scene(
    fur: Some(Fur(
        mesh: Critter,
        size: Some(2.0),
        hairs: 1000,
        length: 0.3,
        regions: [Region(center: (0.0, 0.0, 0.0), radius: 0.5, length_scale: 2.0, direction: Some((0.0, -1.0, 0.0)))],
        direction: (-1.0, 0.0, 0.0),
        up: (0.0, 1.0, 0.0),
        coats: [Coat(share: 1.0, relative_length: 1.0, stiffness: 0.5, normal_randomize: 0.5, end_randomize: 0.1, direction_weight: 0.3, material: FurMaterial(ambient: (0.1, 0.1, 0.1), diffuse: (0.3, 0.1, 0.0), specular: (0.6, 0.6, 0.6), shininess: 16.0, width: 0.004))],
        culling: Culling(enabled: true, full_distance: Some(5.0)),
        motion: Some(MeshMotion(amplitude: 0.1, wavelength: 4.0, period: 24.0, axis: (1.0, 0.0, 0.0), direction: (0.0, 1.0, 0.0))),
        skin: (0.45, 0.33, 0.25),
    )),
)"#;

/// Every fur field refuses NaN, infinities, zero, negative or absurd values, naming itself.
#[test]
fn every_fur_field_names_itself() {
    let region = "Region(center: (0.0, 0.0, 0.0), radius: 0.5, length_scale: 2.0, direction: Some((0.0, -1.0, 0.0)))";
    let coat = "Coat(share: 1.0, relative_length: 1.0, stiffness: 0.5, normal_randomize: 0.5, end_randomize: 0.1, direction_weight: 0.3, material: FurMaterial(ambient: (0.1, 0.1, 0.1), diffuse: (0.3, 0.1, 0.0), specular: (0.6, 0.6, 0.6), shininess: 16.0, width: 0.004))";
    let many = |item: &str, n: usize| vec![item; n].join(", ");
    #[rustfmt::skip]
    let cases: Vec<(&str, String, &str)> = vec![
        ("mesh: Critter", "mesh: File(\"  \")".into(), "fur.mesh"),
        ("mesh: Critter", "mesh: CgalDemo(\"../x.off\")".into(), "fur.mesh"),
        ("size: Some(2.0)", "size: Some(0.0)".into(), "fur.size"),
        ("size: Some(2.0)", "size: Some(NaN)".into(), "fur.size"),
        ("size: Some(2.0)", "size: Some(1e300)".into(), "fur.size"),
        ("hairs: 1000", "hairs: 0".into(), "fur.hairs"),
        ("hairs: 1000", "hairs: 4000001".into(), "fur.hairs"),
        ("hairs: 1000", "hairs: 4294967295".into(), "fur.hairs"),
        ("length: 0.3", "length: 0.0".into(), "fur.length"),
        ("length: 0.3", "length: -0.3".into(), "fur.length"),
        ("length: 0.3", "length: NaN".into(), "fur.length"),
        ("length: 0.3", "length: inf".into(), "fur.length"),
        ("length: 0.3", "length: 1e7".into(), "fur.length"),
        ("center: (0.0, 0.0, 0.0)", "center: (NaN, 0.0, 0.0)".into(), "fur.regions[0].center[0]"),
        ("center: (0.0, 0.0, 0.0)", "center: (0.0, 0.0, -1e9)".into(), "fur.regions[0].center[2]"),
        ("radius: 0.5", "radius: 0.0".into(), "fur.regions[0].radius"),
        ("radius: 0.5", "radius: -1.0".into(), "fur.regions[0].radius"),
        ("radius: 0.5", "radius: NaN".into(), "fur.regions[0].radius"),
        ("length_scale: 2.0", "length_scale: -1.0".into(), "fur.regions[0].length_scale"),
        ("length_scale: 2.0", "length_scale: 101.0".into(), "fur.regions[0].length_scale"),
        ("length_scale: 2.0", "length_scale: NaN".into(), "fur.regions[0].length_scale"),
        ("direction: Some((0.0, -1.0, 0.0))", "direction: Some((0.0, 0.0, 0.0))".into(), "fur.regions[0].direction"),
        ("direction: Some((0.0, -1.0, 0.0))", "direction: Some((0.0, inf, 0.0))".into(), "fur.regions[0].direction[1]"),
        // Scale 1, so that only the count refuses them.
        (region, many(&region.replace("length_scale: 2.0", "length_scale: 1.0"), 65), "fur.regions"),
        // Overlapping regions multiply: 0.3 x 100^4 is 3e7.
        (region, many(&region.replace("length_scale: 2.0", "length_scale: 100.0").replace(", direction: Some((0.0, -1.0, 0.0))", ""), 4), "fur.regions"),
        ("direction: (-1.0, 0.0, 0.0)", "direction: (0.0, 0.0, 0.0)".into(), "fur.direction"),
        ("direction: (-1.0, 0.0, 0.0)", "direction: (NaN, 0.0, 0.0)".into(), "fur.direction[0]"),
        ("up: (0.0, 1.0, 0.0)", "up: (0.0, 0.0, 0.0)".into(), "fur.up"),
        ("up: (0.0, 1.0, 0.0)", "up: (0.0, 1e10, 0.0)".into(), "fur.up[1]"),
        (coat, String::new(), "fur.coats"),
        (coat, many(coat, 5), "fur.coats"),
        ("share: 1.0", "share: 0.0".into(), "fur.coats[0].share"),
        ("share: 1.0", "share: -1.0".into(), "fur.coats[0].share"),
        ("share: 1.0", "share: NaN".into(), "fur.coats[0].share"),
        ("relative_length: 1.0", "relative_length: 0.0".into(), "fur.coats[0].relative_length"),
        ("relative_length: 1.0", "relative_length: 101.0".into(), "fur.coats[0].relative_length"),
        ("stiffness: 0.5", "stiffness: 1.5".into(), "fur.coats[0].stiffness"),
        ("stiffness: 0.5", "stiffness: NaN".into(), "fur.coats[0].stiffness"),
        ("normal_randomize: 0.5", "normal_randomize: -0.1".into(), "fur.coats[0].normal_randomize"),
        ("end_randomize: 0.1", "end_randomize: 3.0".into(), "fur.coats[0].end_randomize"),
        ("direction_weight: 0.3", "direction_weight: 2.0".into(), "fur.coats[0].direction_weight"),
        ("ambient: (0.1, 0.1, 0.1)", "ambient: (-1.0, 0.1, 0.1)".into(), "fur.coats[0].material.ambient[0]"),
        ("diffuse: (0.3, 0.1, 0.0)", "diffuse: (0.3, 11.0, 0.0)".into(), "fur.coats[0].material.diffuse[1]"),
        ("specular: (0.6, 0.6, 0.6)", "specular: (0.6, 0.6, NaN)".into(), "fur.coats[0].material.specular[2]"),
        ("shininess: 16.0", "shininess: -1.0".into(), "fur.coats[0].material.shininess"),
        ("shininess: 16.0", "shininess: 1e5".into(), "fur.coats[0].material.shininess"),
        ("width: 0.004", "width: 0.0".into(), "fur.coats[0].material.width"),
        ("width: 0.004", "width: inf".into(), "fur.coats[0].material.width"),
        ("full_distance: Some(5.0)", "full_distance: Some(0.0)".into(), "fur.culling.full_distance"),
        ("full_distance: Some(5.0)", "full_distance: Some(-5.0)".into(), "fur.culling.full_distance"),
        ("full_distance: Some(5.0)", "full_distance: Some(NaN)".into(), "fur.culling.full_distance"),
        ("full_distance: Some(5.0)", "full_distance: Some(inf)".into(), "fur.culling.full_distance"),
        ("amplitude: 0.1", "amplitude: NaN".into(), "fur.motion.amplitude"),
        ("amplitude: 0.1", "amplitude: -1e7".into(), "fur.motion.amplitude"),
        ("wavelength: 4.0", "wavelength: 0.0".into(), "fur.motion.wavelength"),
        ("wavelength: 4.0", "wavelength: 1e-300".into(), "fur.motion.wavelength"),
        ("wavelength: 4.0", "wavelength: NaN".into(), "fur.motion.wavelength"),
        ("period: 24.0", "period: 0.0".into(), "fur.motion.period"),
        ("period: 24.0", "period: -24.0".into(), "fur.motion.period"),
        ("period: 24.0", "period: inf".into(), "fur.motion.period"),
        ("axis: (1.0, 0.0, 0.0)", "axis: (0.0, 0.0, 0.0)".into(), "fur.motion.axis"),
        ("direction: (0.0, 1.0, 0.0))", "direction: (0.0, 0.0, 0.0))".into(), "fur.motion.direction"),
        ("skin: (0.45, 0.33, 0.25)", "skin: (2.0, 0.33, 0.25)".into(), "fur.skin[0]"),
    ];
    Scene::from_ron(FUR, "fur.ron").expect("the fur template is valid");
    for (from, to, field) in &cases {
        assert!(FUR.contains(from), "{from} not in the fur template");
        let text = FUR.replacen(from, to, 1);
        let (f, value, allowed) = invalid(&text);
        assert_eq!(&f, field, "for {to}");
        assert!(!value.is_empty() && !allowed.is_empty(), "for {to}");
    }
    // Fur and hair together beyond the strand cap: the error names both.
    let both = FUR.replacen("hairs: 1000", "hairs: 4000000", 1).replacen(
        "    fur: Some(",
        "    groups: [HairGroup(roots: Roots(theta: (3.0, 60.0), phi: (-180.0, 180.0)), count: 100, segments: 10, length: 12.0, rigidity: 50.0)],\n    fur: Some(",
        1,
    );
    assert_eq!(invalid(&both).0, "groups[..].count + fur.hairs");
    // Culling and motion are plain values too: a wrong type is a parse error naming the place.
    for to in [
        "culling: Culling(enabled: 1,",
        "culling: Culling(enabld: true,",
    ] {
        let text = FUR.replacen("culling: Culling(enabled: true,", to, 1);
        let e = Scene::from_ron(&text, "fur.ron").unwrap_err();
        assert!(matches!(e, KamiError::Parse { line: 11, .. }), "{e}");
    }
}
