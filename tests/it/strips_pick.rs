//! The strips' editing by mouse and timeline (Kazama section 4): picking a strip and a
//! target in the projected view, dragging a target in the plane facing the eye, the
//! timeline's geometry, the EFF brush's strokes, and the stage's seek that replays the clip
//! after an edit. The window-level gesture is `viewer_picks_a_strip_and_drags_its_target`
//! in tests/it/viewer.rs.

use crate::common;

use glam::{DMat4, DQuat, DVec2, DVec3};
use kami::stage::Stage;
use kami::systems::strips::block::Edit;
use kami::systems::strips::pick::{self, Timeline, TimelineGrab};
use kami::systems::strips::{panel, StripsSystem};
use kami::systems::wisps::edit::View;
use kami::systems::Change;

/// A camera 100 units down +z looking at the origin, 400×300 pixels.
fn view() -> View {
    let camera = kami::stage::camera::Camera {
        eye: DVec3::new(0.0, 0.0, 100.0),
        target: DVec3::ZERO,
        up: DVec3::Y,
        fov_y: 40f64.to_radians(),
    };
    View::from_camera(
        &camera,
        DMat4::IDENTITY,
        DVec2::new(400.0, 300.0),
        (DVec3::ZERO, 40.0),
    )
}

fn edit(strip: u32, from: u32, to: u32, target: [f64; 3]) -> Edit {
    Edit {
        strip,
        from,
        to,
        target,
        radius: 6.0,
    }
}

/// Where the cursor is nearer one strip, that one; where two strips cross on screen, the
/// one nearer the eye; away from every strip, none.
#[test]
fn a_press_picks_the_nearest_strip_and_the_front_one_where_they_cross() {
    let v = view();
    let back = vec![DVec3::new(-10.0, 0.0, -20.0), DVec3::new(10.0, 0.0, -20.0)];
    let front = vec![DVec3::new(0.0, -10.0, 10.0), DVec3::new(0.0, 10.0, 10.0)];
    let side = vec![DVec3::new(15.0, -10.0, 0.0), DVec3::new(15.0, 10.0, 0.0)];
    let strips = [back.clone(), front.clone(), side];
    let at = |p: DVec3| v.project(p).unwrap().truncate();
    let crossing = at(DVec3::ZERO.with_z(10.0));
    assert_eq!(pick::pick_strip(&strips, &v, crossing, 8.0), Some(1));
    // Reversed order: the front one still wins.
    let swapped = [front.clone(), back.clone()];
    assert_eq!(pick::pick_strip(&swapped, &v, crossing, 8.0), Some(0));
    // Along the back strip, away from the front one.
    let on_back = at(DVec3::new(-8.0, 0.0, -20.0));
    assert_eq!(pick::pick_strip(&strips, &v, on_back, 8.0), Some(0));
    // 5 px off the side strip: picked within 8 px, not within 4.
    let near_side = at(DVec3::new(15.0, 3.0, 0.0)) + DVec2::new(5.0, 0.0);
    assert_eq!(pick::pick_strip(&strips, &v, near_side, 8.0), Some(2));
    assert_eq!(pick::pick_strip(&strips, &v, near_side, 4.0), None);
    assert_eq!(
        pick::pick_strip(&strips, &v, DVec2::new(5.0, 5.0), 8.0),
        None
    );
}

/// A target marker is found where the head pose at its second key carries it, and a drag
/// moves it so that it projects under the cursor at the depth it had, in the head's rest
/// frame (the head pose at the key turned and moved).
#[test]
fn a_dragged_target_stays_under_the_cursor_at_its_depth() {
    let v = view();
    let head = |f: u32| {
        DMat4::from_rotation_translation(
            DQuat::from_rotation_y(0.02 * f64::from(f)),
            DVec3::new(0.1 * f64::from(f), 0.0, 0.0),
        )
    };
    let edits = [
        edit(3, 0, 10, [5.0, -12.0, 4.0]),
        edit(7, 5, 30, [-9.0, -15.0, 2.0]),
    ];
    for (i, e) in edits.iter().enumerate() {
        let w = pick::target_world(e, &head(e.to));
        let q = v.project(w).unwrap();
        let cursor = q.truncate() + DVec2::new(3.0, -2.0);
        assert_eq!(
            pick::pick_target(&edits, &head, &v, cursor, 8.0),
            Some(i),
            "edit {i}"
        );
        assert_eq!(pick::pick_target(&edits, &head, &v, cursor, 3.0), None);
        // Drag 50 px right and 20 up.
        let to = q.truncate() + DVec2::new(50.0, -20.0);
        let rest = pick::drag_target(&v, &head(e.to), q.z, to).unwrap();
        let moved = v.project(head(e.to).transform_point3(rest)).unwrap();
        assert!((moved.truncate() - to).length() < 1e-6, "{moved} vs {to}");
        assert!((moved.z - q.z).abs() < 1e-9);
        // It moved in the world, by about 50 px worth.
        assert!((rest - DVec3::from(e.target)).length() > 5.0);
    }
}

/// The timeline maps frames to pixels and back, grabs the nearer key within its radius and
/// scrubs elsewhere, and keeps a first key before the second.
#[test]
fn the_timeline_grabs_keys_and_scrubs_elsewhere() {
    let tl = Timeline {
        left: 10.0,
        width: 300.0,
        frames: 150,
    };
    for f in [0, 1, 75, 149, 150] {
        assert_eq!(tl.frame_at(tl.x_of(f64::from(f))), f);
    }
    assert_eq!(tl.frame_at(-50.0), 0);
    assert_eq!(tl.frame_at(1e6), 150);
    let edits = [edit(0, 10, 40, [0.0; 3]), edit(1, 60, 61, [0.0; 3])];
    let x = |f: u32| tl.x_of(f64::from(f));
    assert_eq!(
        tl.grab(&edits, Some(0), x(10) + 3.0, 6.0),
        TimelineGrab::From(0)
    );
    assert_eq!(
        tl.grab(&edits, Some(0), x(40) - 3.0, 6.0),
        TimelineGrab::To(0)
    );
    assert_eq!(tl.grab(&edits, Some(0), x(25), 6.0), TimelineGrab::Scrub);
    assert_eq!(tl.grab(&edits, None, x(10), 6.0), TimelineGrab::Scrub);
    assert_eq!(tl.grab(&edits, Some(5), x(10), 6.0), TimelineGrab::Scrub);
    // Keys one frame apart (2 px): the press takes the nearer.
    assert_eq!(
        tl.grab(&edits, Some(1), x(61) + 0.5, 6.0),
        TimelineGrab::To(1)
    );
    assert_eq!(
        tl.grab(&edits, Some(1), x(60) - 0.5, 6.0),
        TimelineGrab::From(1)
    );
    let mut e = edits[0].clone();
    pick::move_key(&mut e, TimelineGrab::From(0), 55);
    assert_eq!((e.from, e.to), (39, 40));
    pick::move_key(&mut e, TimelineGrab::To(0), 12);
    assert_eq!((e.from, e.to), (39, 40));
    pick::move_key(&mut e, TimelineGrab::To(0), 90);
    assert_eq!((e.from, e.to), (39, 90));
    pick::move_key(&mut e, TimelineGrab::From(0), 0);
    assert_eq!((e.from, e.to), (0, 90));
    // The span holds the last release (to + (to - from) / 2) with room after it.
    assert_eq!(Timeline::span(&[], 0, None), 120);
    assert_eq!(Timeline::span(&[e], 0, None), 90 + 45 + 30);
    assert_eq!(Timeline::span(&[], 200, None), 230);
    assert_eq!(Timeline::span(&[], 0, Some(688)), 688);
}

/// The EFF brush: a stroke makes the painted cells samples of the scene's field, the field
/// built from the scene then holds the brush's force at the stroke, and painting the same
/// place again replaces those samples instead of piling up (and averaging) more.
#[test]
fn eff_strokes_become_samples_and_repeat_without_piling_up() {
    let mut scene = common::scene("strips");
    let field = kami::forces::Forces::new(&scene.forces, &scene.head)
        .eff
        .unwrap();
    let desc = scene.forces.eff.as_mut().unwrap();
    let before = desc.samples.len();
    let center = field.cell_center(field.index([3, 4, 5]));
    let force = DVec3::new(0.0, 900.0, 0.0);
    let n = panel::paint_into(desc, &field, center, 1.6 * field.cell_size().x, force);
    assert!(
        n >= 7,
        "a brush of 1.6 cells paints the centre and its neighbours: {n}"
    );
    assert_eq!(desc.samples.len(), before + n);
    let built = kami::forces::Forces::new(&scene.forces, &scene.head)
        .eff
        .unwrap();
    let at = built.cells()[built.index([3, 4, 5])];
    assert!((at - force).length() < 1e-6, "{at} vs {force}");
    // Once more at the same place, with a new force: as many samples, the new force.
    let desc = scene.forces.eff.as_mut().unwrap();
    let again = DVec3::new(-500.0, 0.0, 0.0);
    let m = panel::paint_into(desc, &built, center, 1.6 * field.cell_size().x, again);
    assert_eq!(m, n);
    assert_eq!(desc.samples.len(), before + n);
    let built = kami::forces::Forces::new(&scene.forces, &scene.head)
        .eff
        .unwrap();
    let at = built.cells()[built.index([3, 4, 5])];
    assert!((at - again).length() < 1e-6, "{at} vs {again}");
}

fn points(gpu: &kami::gpu::Gpu, stage: &Stage) -> Vec<[f32; 4]> {
    stage
        .system::<StripsSystem>()
        .unwrap()
        .dynamics
        .read_points(gpu)
        .unwrap()
}

/// The largest coordinate difference between two poses (0: bit for bit where finite).
fn worst(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| (0..4).map(move |k| (p[k] - q[k]).abs()))
        .fold(0.0, f32::max)
}

/// A key-frame edit re-solves the extra force without building the system again
/// (`Change::Resimulate`), and seeking then replays the clip: after the edit and a seek to
/// frame 24 the strips are where a stage built with the edit from the start has them after
/// 24 frames one by one, bit for bit; without the edit they are elsewhere.
#[test]
fn an_edit_and_a_seek_replay_the_clip_with_the_edit() {
    let gpu = common::gpu();
    let mut scene = common::scene("strips");
    for l in &mut scene.strips_mut().as_mut().unwrap().layers {
        l.count = l.count.div_ceil(4);
    }
    let mut edited = scene.clone();
    let e = panel::new_edit(&scene, 5, 4, 20).unwrap();
    edited.strips_mut().as_mut().unwrap().edits.push(e);
    assert_eq!(
        kami::systems::strips::classify(&scene, &edited),
        Change::Resimulate
    );

    let mut live = common::stage_one_sample(gpu, &scene);
    live.seek(gpu, 9).unwrap();
    let unedited = points(gpu, &{
        let mut s = common::stage_one_sample(gpu, &scene);
        s.seek(gpu, 24).unwrap();
        s
    });
    let applied = live.apply(gpu, &edited).unwrap();
    assert!(!applied.restarted, "an edit must not rebuild the strips");
    assert_eq!(live.frame(), 9);
    live.seek(gpu, 24).unwrap();
    assert_eq!(live.frame(), 24);
    let replayed = points(gpu, &live);

    let mut fresh = common::stage_one_sample(gpu, &edited);
    for _ in 0..24 {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        fresh.advance(gpu, &mut enc, 1).unwrap();
        gpu.queue.submit([enc.finish()]);
    }
    let want = points(gpu, &fresh);
    assert_eq!(
        replayed, want,
        "seek after the edit differs from a fresh run"
    );
    let moved = unedited
        .iter()
        .zip(&want)
        .map(|(a, b)| {
            let d = DVec3::new(
                f64::from(a[0] - b[0]),
                f64::from(a[1] - b[1]),
                f64::from(a[2] - b[2]),
            );
            d.length()
        })
        .fold(0.0, f64::max);
    assert!(moved > 1.0, "the edit moved nothing at frame 24: {moved}");
}

/// τ, I1 and I2 change without a rebuild too: the stage keeps its clock and pose, and a
/// seek then gives a fresh run's strips with the new constants, bit for bit (so the GPU got
/// every new propagator), which differ from the old constants' strips.
#[test]
fn new_joint_constants_act_without_a_rebuild() {
    let gpu = common::gpu();
    let mut scene = common::scene("strips");
    for l in &mut scene.strips_mut().as_mut().unwrap().layers {
        l.count = l.count.div_ceil(4);
    }
    let mut stiff = scene.clone();
    {
        let m = &mut stiff.strips_mut().as_mut().unwrap().motion;
        m.stiffness *= 4.0;
        m.inertia *= 0.5;
        m.damping *= 2.0;
    }
    assert_eq!(
        kami::systems::strips::classify(&scene, &stiff),
        Change::Resimulate
    );
    let mut live = common::stage_one_sample(gpu, &scene);
    live.seek(gpu, 15).unwrap();
    let old = points(gpu, &live);
    let applied = live.apply(gpu, &stiff).unwrap();
    assert!(!applied.restarted);
    assert_eq!(live.frame(), 15);
    let off = worst(&points(gpu, &live), &old);
    assert!(off == 0.0, "the pose must stay: it moved by {off}");
    live.seek(gpu, 15).unwrap();
    let mut fresh = common::stage_one_sample(gpu, &stiff);
    fresh.seek(gpu, 15).unwrap();
    let want = points(gpu, &fresh);
    let off = worst(&points(gpu, &live), &want);
    assert!(
        off == 0.0,
        "seek with new constants differs from a fresh run by {off}"
    );
    let moved = worst(&want, &old);
    assert!(
        moved > 0.5,
        "the new constants moved the strips by only {moved}"
    );
}

/// A refused edit (here an edit naming a strip that does not exist, as a script could
/// hand the stage without validating) leaves the stage with its systems, its scene and its
/// pose: the error names the edit, and the clip goes on.
#[test]
fn a_refused_edit_keeps_the_stage_as_it_was() {
    let gpu = common::gpu();
    let mut scene = common::scene("strips");
    for l in &mut scene.strips_mut().as_mut().unwrap().layers {
        l.count = l.count.div_ceil(4);
    }
    let mut live = common::stage_one_sample(gpu, &scene);
    live.seek(gpu, 5).unwrap();
    let before = points(gpu, &live);
    let mut bad = scene.clone();
    bad.strips_mut()
        .as_mut()
        .unwrap()
        .edits
        .push(edit(9999, 0, 10, [0.0, -20.0, 5.0]));
    let e = live.apply(gpu, &bad).expect_err("an edit of strip 9999");
    assert!(e.to_string().contains("edits[0].strip"), "{e}");
    assert_eq!(live.systems().len(), 1, "the strips system was dropped");
    assert!(live.scene() == &scene, "the stage took the refused scene");
    let off = worst(&points(gpu, &live), &before);
    assert!(off == 0.0, "the refused edit moved the strips by {off}");
    live.seek(gpu, 6).unwrap();
    assert_eq!(live.frame(), 6);
}

/// The timeline's span stays finite for keys near the end of the frame range.
#[test]
fn the_timeline_span_does_not_overflow() {
    let far = edit(0, u32::MAX - 10, u32::MAX - 1, [0.0; 3]);
    assert_eq!(Timeline::span(&[far], 0, None), u32::MAX);
    assert_eq!(Timeline::span(&[], u64::MAX, None), u32::MAX);
}
