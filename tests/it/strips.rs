//! Kazama's strips through the stage: the shipped scene's snapshots, the whole system (HOM,
//! EFF read from its file with the gust, GPU dynamics) against the f64 reference, key-frame
//! editing (eq 4) reaching its target without a jump in acceleration, how edits are
//! classified, and clear errors for bad strips.
//!
//! Snapshot tolerance as in `tests/it/snapshot.rs` (mean <= 0.25 of 255, at most 0.2 % of
//! pixels off by more than 24), one sample per pixel.

use crate::common;
use common::{check_snapshot, Tolerance};
use glam::DVec3;
use kami::forces::Forces;
use kami::stage::{target, Quality, Stage};
use kami::systems::strips::block::Edit;
use kami::systems::strips::{dynamics, hom, keyframe, StripsSystem};
use kami::systems::Change;
use kami::{KamiError, Scene};

const TOL: Tolerance = Tolerance {
    mean: 0.25,
    threshold: 24,
    share: 0.002,
};

fn one_sample(name: &str) -> Scene {
    let mut s = common::scene(name);
    s.render.supersample = 1;
    s.render.msaa = 1;
    s
}

/// Frames 0 (rest) and 30 (the gust at its strongest) of `assets/scenes/strips.ron`.
#[test]
fn strips_snapshots() {
    let gpu = common::gpu();
    let scene = one_sample("strips");
    kami::stage::render_animation(gpu, &scene, (160, 128), 0..=30, |f, img| {
        if f == 0 || f == 30 {
            check_snapshot(&format!("strips_{f}"), &img, TOL);
        }
        Ok(())
    })
    .unwrap();
}

/// `assets/scenes/eff_capture.ron` (the field fitted from the capture round trip) at frame
/// 20.
#[test]
fn eff_capture_snapshot() {
    let gpu = common::gpu();
    let scene = one_sample("eff_capture");
    kami::stage::render_animation(gpu, &scene, (160, 128), 20..=20, |_, img| {
        check_snapshot("eff_capture_20", &img, TOL);
        Ok(())
    })
    .unwrap();
}

/// The stage's strips after `frames` frames (one frame per submission, as the viewer and
/// renders record them): world control points, strip-major.
fn gpu_points(gpu: &kami::gpu::Gpu, scene: &Scene, frames: u32) -> (Vec<DVec3>, usize) {
    let mut stage = Stage::new(gpu, scene, target::OUTPUT_FORMAT, Quality::new(1, 1)).unwrap();
    for _ in 0..frames {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        stage.advance(gpu, &mut enc, 1).unwrap();
        gpu.queue.submit([enc.finish()]);
    }
    let sys = stage.system::<StripsSystem>().expect("a strips system");
    let pts = sys.dynamics.read_points(gpu).unwrap();
    (
        pts.iter()
            .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .collect(),
        sys.dynamics.stride() as usize,
    )
}

/// The whole shipped scene (120 strips, the EFF from its file, the gust keys) on the GPU
/// against the f64 reference (`dynamics::simulate` with the same forces): worst point
/// within 1e-3 of its strip's length after 30 frames, and the gust moved the tips.
#[test]
fn shipped_scene_on_the_gpu_matches_the_f64_reference() {
    let gpu = common::gpu();
    let scene = common::scene("strips");
    let st = scene.strips().as_ref().unwrap();
    let frames = 30;
    let (gp, stride) = gpu_points(gpu, &scene, frames);
    let forces = Forces::new(&scene.forces, &scene.head);
    assert!(forces.eff.is_some(), "the scene's EFF file was read");
    let rest = hom::build(st, &scene.head).unwrap();
    let clip = dynamics::simulate(&rest, &st.motion, &forces, &scene.head, &[], frames).unwrap();
    let (first, last) = (&clip[0], &clip[frames as usize]);
    assert_eq!(last.len(), gp.len());
    let mut worst: f64 = 0.0;
    let mut moved: f64 = 0.0;
    for (i, (g, c)) in gp.iter().zip(last).enumerate() {
        let len = st.layers[rest[i / stride].layer as usize].length;
        worst = worst.max((*g - *c).length() / len);
        moved = moved.max((*c - first[i]).length());
    }
    eprintln!(
        "strips scene, {frames} frames on {}: worst {worst:.2e} of a strip's length, tips \
         moved up to {moved:.2} cm",
        gpu.describe()
    );
    assert!(moved > 3.0, "the gust should move the strips: {moved} cm");
    assert!(
        worst < 1e-3,
        "GPU against f64: {worst:e} of a strip's length"
    );
}

/// The tip of strip `s` per frame.
fn tips(clip: &[Vec<DVec3>], stride: usize, s: usize) -> Vec<DVec3> {
    clip.iter().map(|f| f[s * stride + stride - 1]).collect()
}

/// Largest change of the tip's acceleration from one frame to the next over `range`
/// (cm/s² per frame), from third differences of the positions.
fn largest_jump(tip: &[DVec3], ft: f64, range: std::ops::Range<usize>) -> f64 {
    let acc = |f: usize| (tip[f + 1] - 2.0 * tip[f] + tip[f - 1]) / (ft * ft);
    range
        .map(|f| (acc(f + 1) - acc(f)).length())
        .fold(0.0, f64::max)
}

/// The largest change per frame of the tip acceleration a key-frame edit adds, as a share
/// of its force: the ramps' steepest change is pi / 18 (0.17) of the force a frame, which
/// the strip's response (its root and the head) raises to 0.43 on the shipped scene; the
/// same edit with its ramps replaced by a step jumps by 3.1 times its force.
const EDIT_JUMP: f64 = 1.0;

/// Key-frame editing (section 4, eq 4): a strip at the nape swung 20° away from the head at
/// frame 24
/// from a first key at frame 6. The solved extra force brings its tip within
/// `keyframe::TOLERANCE` (0.05 cm) of the target at the second key (f64), the GPU within
/// 0.1 cm, and what the edit adds to the tip's path (edited minus unedited) changes its
/// acceleration from frame to frame by no more than the edit's own force (`EDIT_JUMP`: the
/// ramps start and end with zero slope and change by at most pi / 18 of the force a frame
/// over this edit's 9-frame release; a step in force jumps by more than the whole force).
#[test]
fn key_frame_edit_reaches_its_target_without_a_jump() {
    let mut scene = common::scene("strips");
    let st = scene.strips().as_ref().unwrap().clone();
    let forces = Forces::new(&scene.forces, &scene.head);
    let rest = hom::build(&st, &scene.head).unwrap();
    // The middle strip of the nape layer: it hangs down the back of the head.
    let s = st.layers[0].count as usize / 2;
    let (from, to) = (6u32, 24u32);
    let solo = std::slice::from_ref(&rest[s]);
    let free = dynamics::simulate(solo, &st.motion, &forces, &scene.head, &[], to + 14).unwrap();
    let stride = rest[s].points.len();
    let free_tip = tips(&free, stride, 0);
    // Swung 20° away from the head about its root (a force along a hanging strip cannot
    // shorten it, so an animator's target lies on the sphere the strip can reach).
    let tip = free_tip[to as usize];
    let root = free[to as usize][0];
    let out = (tip - DVec3::from(scene.head.center))
        .with_y(0.0)
        .normalize();
    let axis = (tip - root).cross(out).normalize();
    let target = root + glam::DQuat::from_axis_angle(axis, 20f64.to_radians()) * (tip - root);
    eprintln!(
        "free tip {tip:?}, target {target:?} ({:.2} cm away)",
        (target - tip).length()
    );
    let edit = Edit {
        strip: s as u32,
        from,
        to,
        target: target.to_array(),
        radius: 6.0,
    };
    let solved = keyframe::solve(
        &rest,
        &st.motion,
        &forces,
        &scene.head,
        std::slice::from_ref(&edit),
    )
    .unwrap();
    let extra = [solved[0].extra];
    eprintln!(
        "edit solved in {} iterations, miss {:.4} cm, accel {:?}",
        solved[0].iterations, solved[0].miss, extra[0].accel
    );
    assert!(solved[0].miss <= keyframe::TOLERANCE);
    let edited =
        dynamics::simulate(solo, &st.motion, &forces, &scene.head, &extra, to + 14).unwrap();
    let tip = tips(&edited, stride, 0);
    let miss = (tip[to as usize] - target).length();
    assert!(miss <= keyframe::TOLERANCE, "f64 tip misses by {miss} cm");
    // Before the first key the edit changes nothing.
    assert!((tip[from as usize] - free_tip[from as usize]).length() < 1e-9);
    let ft = st.motion.frame_time;
    // From before the first key to after the release (half the edit past the second key).
    let window = (from as usize - 2)..(to as usize + 12);
    let jump = largest_jump(&tip, ft, window.clone());
    let free_jump = largest_jump(&free_tip, ft, window.clone());
    // What the edit adds to the tip's path, apart from the clip's own motion (the gust).
    let added: Vec<DVec3> = tip.iter().zip(&free_tip).map(|(e, f)| *e - *f).collect();
    let edit_jump = largest_jump(&added, ft, window);
    let force = extra[0].accel.length();
    eprintln!(
        "largest change of tip acceleration per frame: edited {jump:.1}, unedited \
         {free_jump:.1}, the edit's own {edit_jump:.1} cm/s² (extra force {force:.1} cm/s²)"
    );
    assert!(
        edit_jump <= EDIT_JUMP * force,
        "the edit's acceleration jumps by {edit_jump} cm/s² per frame, more than {EDIT_JUMP} \
         of its force {force} (edited {jump}, unedited {free_jump})"
    );
    // The same edit in the scene, on the GPU.
    scene.strips_mut().as_mut().unwrap().edits = vec![edit];
    let gpu = common::gpu();
    let (gp, gstride) = gpu_points(gpu, &scene, to);
    let gtip = gp[s * gstride + stride - 1];
    let gmiss = (gtip - target).length();
    eprintln!("GPU tip misses by {gmiss:.4} cm on {}", gpu.describe());
    assert!(gmiss < 0.1, "GPU tip misses by {gmiss} cm");
}

/// What an edit asks of the strips system.
#[test]
fn edits_are_classified_by_what_they_touch() {
    let old = common::scene("strips");
    let classify = kami::systems::strips::classify;
    let with = |f: &dyn Fn(&mut Scene)| {
        let mut s = old.clone();
        f(&mut s);
        classify(&old, &s)
    };
    assert_eq!(classify(&old, &old), Change::None);
    assert_eq!(
        with(&|s| s.strips_mut().as_mut().unwrap().look.specular[0] = 0.9),
        Change::Redraw
    );
    assert_eq!(with(&|s| s.forces.gravity[1] = -500.0), Change::Resimulate);
    assert_eq!(
        with(&|s| s.forces.eff.as_mut().unwrap().gust.clear()),
        Change::Resimulate
    );
    // A key-frame edit re-solves its extra force; the viewer then replays the clip.
    assert_eq!(
        with(&|s| s.strips_mut().as_mut().unwrap().edits.push(
            kami::systems::strips::block::Edit {
                strip: 3,
                from: 2,
                to: 12,
                target: [0.0, -20.0, 5.0],
                radius: 6.0,
            }
        )),
        Change::Resimulate
    );
    // τ, I1, I2: new joint constants from the next step, the pose kept (an artist tunes
    // them while the clip plays).
    assert_eq!(
        with(&|s| s.strips_mut().as_mut().unwrap().motion.stiffness = 300.0),
        Change::Resimulate
    );
    assert_eq!(
        with(&|s| s.strips_mut().as_mut().unwrap().motion.inertia = 2.0),
        Change::Resimulate
    );
    assert_eq!(
        with(&|s| s.strips_mut().as_mut().unwrap().layers[0].count = 5),
        Change::Rebuild
    );
}

fn invalid_field(r: kami::error::Result<Scene>) -> String {
    match r {
        Err(KamiError::Invalid { field, .. }) => field,
        Err(e) => panic!("expected an invalid-value error, got {e}"),
        Ok(_) => panic!("expected an error"),
    }
}

/// Bad strips get an error naming the field, before anything is built.
#[test]
fn bad_strips_are_refused_with_the_field() {
    let text = std::fs::read_to_string(common::root().join("assets/scenes/strips.ron")).unwrap();
    let cases = [
        ("count: 22", "count: 0", "strips.layers[0].count"),
        (
            "sticks: 8, width: (3.0",
            "sticks: 0, width: (3.0",
            "strips.layers[0].sticks",
        ),
        ("polar: 108.0", "polar: 180.0", "strips.layers[0].polar"),
        ("length: 24.0", "length: -1.0", "strips.layers[0].length"),
        ("droop: 0.97", "droop: 1.5", "strips.layers[0].droop"),
        (
            "stiffness: 150.0",
            "stiffness: -1.0",
            "strips.motion.stiffness",
        ),
        (
            "motion: Motion(",
            "motion: Motion(steps_per_second: 1000000.0, frame_time: 1.0, ",
            "strips.motion.steps_per_second",
        ),
        (
            "motion: Motion(",
            "edits: [Edit(strip: 500, from: 1, to: 5, target: (0.0, 0.0, 0.0))], motion: Motion(",
            "strips.edits[0].strip",
        ),
        (
            "motion: Motion(",
            "edits: [Edit(strip: 5, from: 5, to: 5, target: (0.0, 0.0, 0.0))], motion: Motion(",
            "strips.edits[0].to",
        ),
    ];
    for (from, to, field) in cases {
        assert!(
            text.contains(from),
            "case {field}: {from:?} not in the scene"
        );
        let bad = text.replacen(from, to, 1);
        assert_eq!(invalid_field(Scene::from_ron(&bad, "strips.ron")), field);
    }
    // A missing EFF file is refused naming it.
    let dir = std::env::temp_dir().join("kami-strips-bad");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("missing_eff.ron");
    std::fs::write(
        &p,
        text.replace("../eff/front_left_gust.eff", "nowhere.eff"),
    )
    .unwrap();
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(e.contains("nowhere.eff"), "{e}");
}

/// (file, field, value, allowed) of a validation error.
fn parts(e: KamiError) -> (String, String, String, String) {
    match e {
        KamiError::Invalid {
            file,
            field,
            value,
            allowed,
        } => (file, field, value, allowed),
        other => panic!("expected an invalid-value error, got {other}"),
    }
}

/// The strips block has one set of bounds: whatever the scene file may not hold, the
/// runtime types built from a scene in code (`hom::build`, `dynamics::Rig::new`,
/// `keyframe::solve`) refuse with the same field, value and words (the file's error names
/// the file too), and whatever it may hold they take. Before, a curl of 120° per stick was
/// refused by the file (±90°) and built by `hom` (±180°), a layer stiffness of 2e6 refused
/// by the file (at most 1e6) and simulated by `Rig` (only >= 0), 100 sticks refused by the
/// file (64) and built by `hom` (1024), 5000 steps per frame refused by the file (4096) and
/// run by `Rig` (a million).
#[test]
fn one_set_of_bounds_on_every_path() {
    use kami::systems::strips::block::{Layer, Motion, MAX_CURL, MAX_LAYER_STIFFNESS};
    let text = std::fs::read_to_string(common::root().join("assets/scenes/strips.ron")).unwrap();
    let base = Scene::from_ron(&text, "strips.ron").unwrap();
    // The scene validator's verdict on `s` as a scene file.
    let from_file = |s: &Scene| {
        Scene::from_ron(&s.to_ron(), "strips.ron")
            .map(|_| ())
            .map_err(parts)
    };
    assert_eq!(MAX_CURL, 90.0);
    type Change = fn(&mut Layer);
    let layers: [(&str, Change, bool); 11] = [
        ("curl", |l| l.curl = 120.0, false),
        ("curl", |l| l.curl = -120.0, false),
        ("curl", |l| l.curl = 180.0, false),
        ("curl", |l| l.curl = 90.0, true),
        ("curl", |l| l.curl = -90.0, true),
        ("stiffness", |l| l.stiffness = 2e6, false),
        ("stiffness", |l| l.stiffness = MAX_LAYER_STIFFNESS, true),
        ("stiffness", |l| l.stiffness = 0.0, true),
        ("sticks", |l| l.sticks = 100, false),
        ("width[1]", |l| l.width[1] = 0.0, false),
        ("azimuth", |l| l.azimuth = [0.0, 400.0], false),
    ];
    for (field, change, ok) in layers {
        let mut s = base.clone();
        change(&mut s.strips_mut().as_mut().unwrap().layers[0]);
        let file = from_file(&s);
        let built = hom::build(s.strips().as_ref().unwrap(), &s.head)
            .map(|_| ())
            .map_err(parts);
        if ok {
            assert!(file.is_ok(), "{field}: the file refused {file:?}");
            assert!(built.is_ok(), "{field}: hom::build refused {built:?}");
            continue;
        }
        let (f, got, value, allowed) = file.expect_err(&format!("the file took the bad {field}"));
        assert_eq!(
            (f.as_str(), got.as_str()),
            ("strips.ron", format!("strips.layers[0].{field}").as_str())
        );
        assert_eq!(
            built.expect_err(&format!("hom::build took the bad {field}")),
            (String::new(), got, value, allowed),
            "hom::build and the scene file disagree"
        );
    }
    // The message a user reads names the file and the field.
    let mut s = base.clone();
    s.strips_mut().as_mut().unwrap().layers[0].curl = 120.0;
    let e = Scene::from_ron(&s.to_ron(), "strips.ron")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("strips.ron")
            && e.contains("`strips.layers[0].curl` = 120")
            && e.contains("[-90, 90]"),
        "{e}"
    );

    // The motion: `Rig::new` (and the GPU pass, through the same `check_motion`).
    let rest = hom::build(base.strips().as_ref().unwrap(), &base.head).unwrap();
    type Move = fn(&mut Motion);
    let motions: [(&str, Move, bool); 6] = [
        ("stiffness", |m| m.stiffness = 2e9, false),
        ("stiffness", |m| m.stiffness = 1e9, true),
        ("spring", |m| m.spring = 2e9, false),
        ("collision", |m| m.collision = 2e9, false),
        (
            "steps_per_second",
            |m| {
                m.frame_time = 1.0;
                m.steps_per_second = 5000.0
            },
            false,
        ),
        ("frame_time", |m| m.frame_time = 11.0, false),
    ];
    for (field, change, ok) in motions {
        let mut s = base.clone();
        change(&mut s.strips_mut().as_mut().unwrap().motion);
        let m = &s.strips().as_ref().unwrap().motion;
        let file = from_file(&s);
        let rig = dynamics::Rig::new(&rest, m).map(|_| ()).map_err(parts);
        if ok {
            assert!(file.is_ok(), "{field}: the file refused {file:?}");
            assert!(rig.is_ok(), "{field}: Rig::new refused {rig:?}");
            continue;
        }
        let (f, got, value, allowed) = file.expect_err(&format!("the file took the bad {field}"));
        assert_eq!(
            (f.as_str(), got.as_str()),
            ("strips.ron", format!("strips.motion.{field}").as_str())
        );
        assert_eq!(
            rig.expect_err(&format!("Rig::new took the bad {field}")),
            (String::new(), got, value, allowed),
            "Rig::new and the scene file disagree"
        );
    }
    // A rest strip carries its layer's stiffness multiplier, under the layer's bound.
    let mut stiff = rest[..1].to_vec();
    stiff[0].stiffness = 2e6;
    let mut s = base.clone();
    s.strips_mut().as_mut().unwrap().layers[0].stiffness = 2e6;
    let (.., layer_allowed) = from_file(&s).unwrap_err();
    let (_, _, _, rig_allowed) = parts(dynamics::Rig::new(&stiff, &Motion::default()).unwrap_err());
    assert_eq!(rig_allowed, layer_allowed);

    // Key-frame edits: `keyframe::solve` refuses as the file does (a second key before the
    // first underflowed a frame count there).
    let forces = Forces::new(&base.forces, &base.head);
    let bad_edits = [
        (
            Edit {
                strip: 3,
                from: 5,
                to: 3,
                target: [0.0; 3],
                radius: 6.0,
            },
            "to",
        ),
        (
            Edit {
                strip: 500,
                from: 1,
                to: 5,
                target: [0.0; 3],
                radius: 6.0,
            },
            "strip",
        ),
    ];
    for (edit, field) in bad_edits {
        let mut s = base.clone();
        s.strips_mut().as_mut().unwrap().edits = vec![edit];
        let st = s.strips().as_ref().unwrap();
        let file = from_file(&s).unwrap_err();
        assert_eq!(file.1, format!("strips.edits[0].{field}"));
        let solved = keyframe::solve(&rest, &st.motion, &forces, &s.head, &st.edits)
            .map(|_| ())
            .map_err(parts)
            .unwrap_err();
        assert_eq!(solved, (String::new(), file.1, file.2, file.3));
    }
}

/// The Key frames panel's "add an edit": the target is 5 cm from where the strip's tip would
/// be at the second key (swung out about the root), and the scene with the edit validates
/// and solves to within 0.1 cm.
#[test]
fn panel_adds_an_edit_that_solves() {
    let mut scene = common::scene("strips");
    let e = kami::systems::strips::panel::new_edit(&scene, 11, 4, 16).unwrap();
    assert_eq!((e.strip, e.from, e.to), (11, 4, 20));
    let st = scene.strips().as_ref().unwrap();
    let forces = Forces::new(&scene.forces, &scene.head);
    let rest = hom::build(st, &scene.head).unwrap();
    let clip = dynamics::simulate(
        std::slice::from_ref(&rest[11]),
        &st.motion,
        &forces,
        &scene.head,
        &[],
        20,
    )
    .unwrap();
    let tip = *clip[20].last().unwrap();
    let d = (DVec3::from(e.target) - tip).length();
    assert!((d - 5.0).abs() < 1e-9, "target {d} cm from the tip");
    scene.strips_mut().as_mut().unwrap().edits.push(e);
    kami::systems::validate(&scene).unwrap();
    let st = scene.strips().as_ref().unwrap();
    let solved = keyframe::solve(&rest, &st.motion, &forces, &scene.head, &st.edits).unwrap();
    // Not every target is exactly reachable by a force field (the strip bends rather than
    // swings): within 0.1 cm, 2 % of the 5 cm the panel asks for.
    assert!(
        solved[0].miss <= 0.1,
        "miss {} after {} iterations",
        solved[0].miss,
        solved[0].iterations
    );
}
