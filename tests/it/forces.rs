//! The scene's one `forces` block reaches every kind: gravity and keyed wind, set once at the
//! scene's top level, move Anjyo's strands, the strips and the wisps' springs. Each kind's f64
//! reference is fed the way the stage feeds it (`Forces::new`), from a shipped scene
//! whose world is replaced: still (nothing moves), gravity alone (everything falls), wind
//! alone (everything goes downwind).

use crate::common;
use glam::DVec3;
use kami::forces::Forces;
use kami::scene::{ForcesDesc, Interp, WindKey};
use kami::systems::Scene;

/// Still air, no gravity, a still head.
fn still(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    s.forces = ForcesDesc::default();
    s
}

fn falling(scene: &Scene) -> Scene {
    let mut s = still(scene);
    s.forces.gravity = [0.0, -500.0, 0.0];
    s
}

fn windy(scene: &Scene) -> Scene {
    let mut s = still(scene);
    s.forces.wind = vec![WindKey {
        frame: 0.0,
        force: [0.0, 0.0, -500.0],
        interp: Interp::Step,
    }];
    s
}

/// Mean displacement of the tips after `frames` frames.
fn mean(moves: impl Iterator<Item = DVec3>) -> DVec3 {
    let (sum, n) = moves.fold((DVec3::ZERO, 0), |(s, n), d| (s + d, n + 1));
    assert!(n > 0);
    sum / n as f64
}

/// Anjyo's projective dynamics (f64 reference) on a thinned gust.
fn anjyo(scene: &Scene, frames: u32) -> DVec3 {
    use kami::systems::anjyo::projective::{CpuSim, DynSetup};
    use kami::systems::anjyo::{cantilever, groom::prepare};
    let input = prepare(scene).unwrap();
    let groomed = cantilever::bend_all(&input);
    let setup = DynSetup::new(scene, &input, &groomed.visible).unwrap();
    let mut sim = CpuSim::new(setup, groomed.nodes.clone());
    for _ in 0..frames {
        sim.frame();
    }
    let offsets = input.vertex_offsets();
    mean((1..offsets.len()).map(|s| {
        let tip = offsets[s] as usize - 1;
        sim.nodes[tip] - groomed.nodes[tip]
    }))
}

/// The strips' angular springs (f64 reference).
fn strips(scene: &Scene, frames: u32) -> DVec3 {
    use kami::systems::strips::{dynamics, hom};
    let st = scene.strips().as_ref().unwrap();
    let rest = hom::build(st, &scene.head).unwrap();
    let forces = Forces::new(&scene.forces, &scene.head);
    let clip = dynamics::simulate(&rest, &st.motion, &forces, &scene.head, &[], frames).unwrap();
    let stride = clip[0].len() / rest.len();
    mean((0..rest.len()).map(|s| {
        let tip = s * stride + stride - 1;
        clip[frames as usize][tip] - clip[0][tip]
    }))
}

/// The wisps' mass springs (f64 reference), with the drawn lengths as rest lengths (the
/// lattice built weightless), so that gravity shows as a sag.
fn wisps(scene: &Scene, frames: u32) -> DVec3 {
    use kami::systems::wisps::springs::{self, Lattice, Motion, State};
    let w = scene.wisps().as_ref().unwrap();
    let sp = w.springs.as_ref().unwrap();
    let still = still(scene);
    let lattice =
        Lattice::build(w, sp, &scene.head, &Forces::new(&still.forces, &still.head)).unwrap();
    let motion = Motion::new(sp, &scene.head).unwrap();
    let mut state = State::rest(&lattice);
    springs::run_frames(
        &lattice,
        &motion,
        &Forces::new(&scene.forces, &scene.head),
        &mut state,
        0,
        frames,
    );
    mean(
        springs::primaries(&lattice, &state)
            .iter()
            .zip(springs::primaries(&lattice, &State::rest(&lattice)))
            .map(|(now, rest)| *now.last().unwrap() - *rest.last().unwrap()),
    )
}

/// Still: little moves (less than `calm`); gravity: the tips go down by more than `least`
/// further than in the still world; wind: along -z by more than `least` further.
fn check(kind: &str, run: impl Fn(&Scene) -> DVec3, scene: &Scene, calm: f64, least: f64) {
    let (s, g, w) = (run(&still(scene)), run(&falling(scene)), run(&windy(scene)));
    eprintln!(
        "{kind}: still {:.3e}, gravity {g:.3}, wind {w:.3}",
        s.length()
    );
    assert!(s.length() < calm, "{kind}: moved {s} in a still world");
    assert!((g - s).y < -least, "{kind}: gravity moved the tips by {g}");
    assert!((w - s).z < -least, "{kind}: the wind moved the tips by {w}");
}

#[test]
fn gravity_and_wind_of_the_forces_block_reach_every_kind() {
    let mut gust = common::scene("gust");
    for g in gust.groups_mut() {
        g.count = (g.count / 100).max(8);
    }
    check("anjyo", |s| anjyo(s, 6), &gust, 1e-3, 0.1);
    let toon = common::scene("toon_wind");
    // Still, the strips ease into their collision band and curl springs (not preloaded).
    check("strips", |s| strips(s, 10), &toon, 0.5, 0.1);
    check("wisps", |s| wisps(s, 10), &toon, 1e-9, 0.1);
}
