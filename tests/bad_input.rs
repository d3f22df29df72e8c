//! Bad input gets a clear error — naming the field, the value and what is allowed, or the
//! line and column — never a panic and never a NaN.

mod common;
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

fn invalid(text: &str) -> (String, String, String) {
    match Scene::from_ron(text, "test.ron") {
        Err(KamiError::Invalid {
            field,
            value,
            allowed,
        }) => (field, value, allowed),
        other => panic!("expected Invalid, got {other:?}"),
    }
}

fn with(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "{from} not in the template");
    GOOD.replacen(from, to, 1)
}

#[test]
fn good_scene_loads() {
    Scene::from_ron(GOOD, "test.ron").unwrap();
    for name in common::SCENES {
        common::scene(name);
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
        ("    ],\n    gravity: (0.0, NaN, 0.0),\n)", "gravity[1]"),
        ("    ],\n    dynamics: Some(Dynamics(dt: 0.0)),\n)", "dynamics.dt"),
        ("    ],\n    dynamics: Some(Dynamics(dt: NaN)),\n)", "dynamics.dt"),
        ("    ],\n    dynamics: Some(Dynamics(damping: -1.0)),\n)", "dynamics.damping"),
        ("    ],\n    dynamics: Some(Dynamics(wind: [WindKey(frame: 5.0, force: (1.0, 0.0, 0.0)), WindKey(frame: 5.0, force: (0.0, 1.0, 0.0))])),\n)", "dynamics.wind[1].frame"),
        ("    ],\n    dynamics: Some(Dynamics(wind: [WindKey(frame: 0.0, force: (inf, 0.0, 0.0))])),\n)", "dynamics.wind[0].force[0]"),
        ("    ],\n    dynamics: Some(Dynamics(head_motion: [HeadKey(frame: 0.0, rotate: (0.0, NaN, 0.0))])),\n)", "dynamics.head_motion[0].rotate[1]"),
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
    scene.groups[0].count = 4_000_000;
    scene.groups[0].segments = 256;
    refused_as_too_large(&gpu, &scene, "vertex");
    let mut scene = Scene::from_ron(GOOD, "test.ron").unwrap();
    scene.render.supersample = 4;
    let side = gpu.device.limits().max_texture_dimension_2d;
    match kami::stage::render_scene(&gpu, &scene, (side, 16)) {
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
    .replacen("    ],\n)", "    ],\n    gravity: (1e9, -1e9, 0.0),\n)", 1);
    let scene = Scene::from_ron(&text, "extreme.ron").unwrap();
    let input = kami::systems::anjyo::groom::prepare(&scene).unwrap();
    let hair = kami::systems::anjyo::cantilever_gpu::groom_gpu(&gpu, &input).unwrap();
    let v = hair.read_vertices(&gpu).unwrap();
    assert!(
        v.iter().all(|p| p.iter().all(|c| c.is_finite())),
        "non-finite node"
    );
    let img = kami::stage::render_scene(&gpu, &scene, (64, 64)).unwrap();
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
    scene.fur.as_mut().unwrap().hairs = 4_000_000;
    kami::scene::validate(&scene).unwrap();
    refused_as_too_large(&gpu, &scene, "fur");
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
