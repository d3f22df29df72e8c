//! The stage: it builds only the systems a scene names, keeps every system on one clock,
//! classifies edits per system, and resets to the rest pose.

mod common;

use kami::stage::{target, Quality, Stage};
use kami::systems::anjyo::AnjyoSystem;
use kami::systems::fur::FurSystem;
use kami::systems::{anjyo, fur, Change};

fn stage(gpu: &kami::gpu::Gpu, scene: &kami::Scene) -> Stage {
    Stage::new(gpu, scene, target::OUTPUT_FORMAT, Quality::of(scene)).unwrap()
}

fn kinds(s: &Stage) -> Vec<&'static str> {
    s.systems().iter().map(|s| s.kind()).collect()
}

/// The gust with a tenth of its hairs (the test is about bookkeeping, not looks).
fn small_gust() -> kami::Scene {
    let mut s = common::scene("gust");
    for g in &mut s.groups {
        g.count /= 10;
    }
    s
}

fn vertices(gpu: &kami::gpu::Gpu, s: &Stage) -> Vec<[f32; 4]> {
    s.system::<AnjyoSystem>()
        .unwrap()
        .hair
        .read_vertices(gpu)
        .unwrap()
}

fn advance(gpu: &kami::gpu::Gpu, s: &mut Stage, frames: u32) {
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    s.advance(gpu, &mut enc, frames).unwrap();
    gpu.queue.submit([enc.finish()]);
}

#[test]
fn only_the_systems_a_scene_names_are_built() {
    let gpu = common::gpu();
    let bob = stage(&gpu, &common::scene("bob"));
    assert_eq!(kinds(&bob), ["anjyo"]);
    assert!(
        bob.system::<AnjyoSystem>().unwrap().sim.is_none(),
        "a still groom allocates no simulation"
    );
    assert!(bob.has_head());
    let fur = stage(&gpu, &common::scene("fur"));
    assert_eq!(kinds(&fur), ["fur"]);
    assert!(!fur.has_head(), "an invisible head builds no head pass");
    let both = stage(&gpu, &common::scene("hair_and_fur"));
    assert_eq!(kinds(&both), ["anjyo", "fur"]);
    // The bounds hold both systems' spheres.
    let (c, r) = both.bounds();
    for s in both.systems() {
        let (sc, sr) = s.bounds();
        assert!(
            (sc - c).length() + sr <= r + 1e-9,
            "{} sticks out",
            s.kind()
        );
    }
}

#[test]
fn one_clock_for_every_system_and_reset_returns_to_rest() {
    let gpu = common::gpu();
    let mut s = stage(&gpu, &small_gust());
    let rest = vertices(&gpu, &s);
    advance(&gpu, &mut s, 5);
    assert_eq!(s.frame(), 5);
    let moved = vertices(&gpu, &s);
    let most = rest
        .iter()
        .zip(&moved)
        .map(|(a, b)| (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0f32, f32::max))
        .fold(0.0f32, f32::max);
    assert!(most > 1.0, "the hair did not move in 5 frames ({most})");
    // Five frames in one submission are five frames one by one.
    let mut t = stage(&gpu, &small_gust());
    for _ in 0..5 {
        advance(&gpu, &mut t, 1);
    }
    assert_eq!(vertices(&gpu, &t), moved);
    s.reset(&gpu).unwrap();
    assert_eq!(s.frame(), 0);
    assert_eq!(vertices(&gpu, &s), rest, "reset is the groomed rest pose");
    // And from rest the same motion again.
    advance(&gpu, &mut s, 5);
    assert_eq!(vertices(&gpu, &s), moved);
}

#[test]
fn edits_rebuild_resimulate_or_redraw_one_system() {
    let gpu = common::gpu();
    let scene = small_gust();
    let mut s = stage(&gpu, &scene);
    advance(&gpu, &mut s, 3);

    let mut look = scene.clone();
    look.groups[0].material.color = [0.9, 0.5, 0.1];
    let a = s.apply(&gpu, &look).unwrap();
    assert_eq!(a.changes, [("anjyo", Change::Redraw)]);
    assert!(!a.restarted);
    assert_eq!(s.frame(), 3, "a look change keeps the pose");

    let mut damp = look.clone();
    damp.dynamics.as_mut().unwrap().damping = 2.0;
    let a = s.apply(&gpu, &damp).unwrap();
    assert_eq!(a.changes, [("anjyo", Change::Resimulate)]);
    assert_eq!(s.frame(), 3);

    let mut stiff = damp.clone();
    stiff.groups[1].rigidity *= 2.0;
    let a = s.apply(&gpu, &stiff).unwrap();
    assert_eq!(a.changes, [("anjyo", Change::Rebuild)]);
    assert!(a.restarted);
    assert_eq!(s.frame(), 0, "a new rest pose restarts the clock");

    // Adding fur builds the fur system beside the hair; taking the hair away frees it.
    let mut with_fur = stiff.clone();
    with_fur.fur = common::scene("fur").fur;
    let a = s.apply(&gpu, &with_fur).unwrap();
    assert_eq!(
        a.changes,
        [("anjyo", Change::None), ("fur", Change::Rebuild)]
    );
    assert_eq!(kinds(&s), ["anjyo", "fur"]);
    let mut fur_only = with_fur.clone();
    fur_only.groups.clear();
    s.apply(&gpu, &fur_only).unwrap();
    assert_eq!(kinds(&s), ["fur"]);
    assert!(s.system::<FurSystem>().is_some());
}

/// Each kind's classification, without a GPU.
#[test]
fn each_kind_classifies_its_own_edits() {
    let a = common::scene("gust");
    let same = |b: &kami::Scene| (anjyo::classify(&a, b), fur::classify(&a, b));
    let mut b = a.clone();
    b.groups[0].material.width = 0.2;
    assert_eq!(same(&b), (Change::Redraw, Change::None));
    let mut b = a.clone();
    b.groups[0].material.ka_spread = 0.5;
    assert_eq!(
        same(&b).0,
        Change::Rebuild,
        "k_a is drawn per strand at groom"
    );
    let mut b = a.clone();
    b.dynamics = None;
    assert_eq!(same(&b).0, Change::Rebuild);
    let mut b = a.clone();
    b.render.msaa = 1;
    b.light.intensity = 2.0;
    assert_eq!(same(&b), (Change::None, Change::None), "the stage's own");

    let f = common::scene("fur");
    let mut g = f.clone();
    g.fur.as_mut().unwrap().coats[0].material.shininess = 5.0;
    assert_eq!(fur::classify(&f, &g), Change::Redraw);
    g.fur.as_mut().unwrap().hairs += 1;
    assert_eq!(fur::classify(&f, &g), Change::Rebuild);
    let mut g = f.clone();
    g.fur.as_mut().unwrap().coats[1].stiffness = 0.1;
    assert_eq!(fur::classify(&f, &g), Change::Rebuild, "shape, not look");
    let mut g = f.clone();
    g.seed += 1;
    assert_eq!(fur::classify(&f, &g), Change::Rebuild);
    assert_eq!(
        anjyo::classify(&f, &g),
        Change::Rebuild,
        "the seed draws the pores too"
    );
}

/// An edit the stage refuses (here fur beyond the adapter's limits, together with a hair
/// edit that would rebuild the hair) leaves the stage as it was: both systems, the clock,
/// the scene. It used to keep only the kinds handled before the failing one.
#[test]
fn a_refused_edit_keeps_what_was_drawn() {
    let gpu = common::gpu();
    let mut scene = small_gust();
    scene.fur = common::scene("fur").fur;
    let mut s = stage(&gpu, &scene);
    advance(&gpu, &mut s, 2);
    let before = vertices(&gpu, &s);
    let mut bad = scene.clone();
    bad.groups[1].rigidity *= 2.0;
    bad.fur.as_mut().unwrap().hairs = 3_900_000;
    kami::scene::validate(&bad).unwrap();
    assert!(
        s.apply(&gpu, &bad).is_err(),
        "3.9 M fur hairs should be refused"
    );
    assert_eq!(kinds(&s), ["anjyo", "fur"]);
    assert_eq!(s.frame(), 2);
    assert_eq!(*s.scene(), scene);
    assert_eq!(vertices(&gpu, &s), before, "the hair kept its pose");
    // And the stage still takes a good edit afterwards.
    let mut good = scene.clone();
    good.groups[1].rigidity *= 2.0;
    assert!(s.apply(&gpu, &good).unwrap().restarted);
    assert_eq!(kinds(&s), ["anjyo", "fur"]);
}
