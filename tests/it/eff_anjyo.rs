//! The External Force Field moves Anjyo's strands too: the projective dynamics (f64
//! reference and WGSL kernel) add the field, trilinear, at every segment. A field that blows
//! in one half of the grid moves the strands there and no others; the GPU still matches the
//! reference with a field (blowers, the outside force and its band, a gust), and several
//! frames per submission still match one by one (each substep carries its own gust scale).

use crate::common;

use glam::DVec3;
use kami::forces::eff::{Blower, EffDesc, EffSample, GustKey};
use kami::scene::Interp;
use kami::systems::anjyo::groom::{prepare, GroomInput};
use kami::systems::anjyo::projective::{CpuSim, DynSetup};
use kami::systems::anjyo::simulation::Simulation;
use kami::systems::anjyo::{cantilever, cantilever_gpu};
use kami::systems::Scene;

/// The gust scene, `1/thin` of its strands, still air: only the EFF can move the hair.
fn still_scene(thin: u32) -> Scene {
    let mut scene = common::scene("gust");
    for g in scene.groups_mut() {
        g.count /= thin;
    }
    scene.forces.wind.clear();
    scene.forces.gravity = [0.0; 3];
    scene
}

/// Every cell of an 8³ grid of 60 around the head defined: `force` where the cell centre has
/// z > 0, nothing where z < 0. Trilinear sampling is exactly zero for z <= -3.75 (the last
/// row of centres on that side).
fn half_field(scene: &Scene, force: DVec3) -> EffDesc {
    let center = DVec3::from(scene.head.center);
    let (n, extent) = (8u32, 60.0);
    let cell = extent / n as f64;
    let mut samples = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let at = center - 0.5 * extent
                    + DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * cell;
                let f = if at.z > center.z { force } else { DVec3::ZERO };
                samples.push(EffSample {
                    at: at.to_array(),
                    force: f.to_array(),
                });
            }
        }
    }
    EffDesc {
        center: center.to_array(),
        extent,
        resolution: [n; 3],
        samples,
        ..EffDesc::default()
    }
}

/// Per strand: (largest rest z, smallest rest z, largest node distance between two runs).
fn travel(
    input: &GroomInput,
    rest: &[DVec3],
    calm: &[DVec3],
    now: &[DVec3],
) -> Vec<(f64, f64, f64)> {
    let offsets = input.vertex_offsets();
    (0..input.roots.len())
        .map(|s| {
            let r = offsets[s] as usize..offsets[s + 1] as usize;
            let zmax = rest[r.clone()].iter().map(|p| p.z).fold(f64::MIN, f64::max);
            let zmin = rest[r.clone()].iter().map(|p| p.z).fold(f64::MAX, f64::min);
            let moved = r.map(|i| calm[i].distance(now[i])).fold(0.0, f64::max);
            (zmax, zmin, moved)
        })
        .collect()
}

/// Split into (strands wholly in the still half, wholly in the blown half), 1 cm clear of
/// the blend between the rows of centres at z = ±3.75.
fn halves(t: &[(f64, f64, f64)]) -> (Vec<f64>, Vec<f64>) {
    let still = t.iter().filter(|s| s.0 < -4.75).map(|s| s.2).collect();
    let blown = t.iter().filter(|s| s.1 > 4.75).map(|s| s.2).collect();
    (still, blown)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Run the GPU simulation `frames` frames; the node positions.
fn run_gpu(gpu: &kami::gpu::Gpu, scene: &Scene, input: &GroomInput, frames: u32) -> Vec<DVec3> {
    let hair = cantilever_gpu::groom_gpu(gpu, &common::groom_world(gpu, input), input).unwrap();
    let mut sim = Simulation::new(gpu, &common::world(gpu, scene), scene, input, &hair)
        .unwrap()
        .unwrap();
    for _ in 0..frames {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        sim.record_frame(gpu, &mut enc, &hair).unwrap();
        gpu.queue.submit([enc.finish()]);
    }
    hair.read_vertices(gpu)
        .unwrap()
        .iter()
        .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .collect()
}

/// +x wind in the z > 0 half: against the same run without the field, the strands there
/// travel centimetres in 10 frames, those in the other half not at all (bit for bit, f64
/// and WGSL: the field adds exactly zero there).
#[test]
fn a_field_in_one_half_moves_only_the_strands_in_that_half() {
    let gpu = common::gpu();
    let mut scene = still_scene(20);
    let input = prepare(&scene).unwrap();
    let groomed = cantilever::bend_all(&input);
    let run_cpu = |scene: &Scene| {
        let mut cpu = CpuSim::new(
            DynSetup::new(scene, &input, &groomed.visible).unwrap(),
            groomed.nodes.clone(),
        );
        for _ in 0..10 {
            cpu.frame();
        }
        cpu.nodes
    };
    let calm_cpu = run_cpu(&scene);
    let calm_gpu = run_gpu(gpu, &scene, &input, 10);
    // Still air hardly moves anything (nodes rebuilt from angles, contacts settling).
    let settle = groomed
        .nodes
        .iter()
        .zip(&calm_cpu)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f64::max);
    assert!(settle < 1e-3, "still air moved a node {settle} cm");

    scene.forces.eff = Some(half_field(&scene, DVec3::new(200.0, 0.0, 0.0)));
    let mut medians = Vec::new();
    for (name, calm, blown) in [
        ("f64", &calm_cpu, run_cpu(&scene)),
        ("f32", &calm_gpu, run_gpu(gpu, &scene, &input, 10)),
    ] {
        let (rest, moved) = halves(&travel(&input, &groomed.nodes, calm, &blown));
        assert!(
            rest.len() > 20 && moved.len() > 20,
            "{} {}",
            rest.len(),
            moved.len()
        );
        let rest_worst = rest.iter().copied().fold(0.0, f64::max);
        let moved_median = median(moved.clone());
        eprintln!(
            "{name}: {} strands in the blown half move {moved_median:.2} cm (median), {} in \
             the other half at most {rest_worst:e}",
            moved.len(),
            rest.len()
        );
        assert!(
            rest_worst == 0.0,
            "{name}: a strand in the still half moved {rest_worst:e}"
        );
        assert!(
            moved_median > 1.0,
            "{name}: the blown strands moved {moved_median} cm"
        );
        medians.push(moved_median);
    }
    assert!(
        (medians[0] - medians[1]).abs() < 1e-2 * medians[0],
        "GPU blown median {} vs f64 {}",
        medians[1],
        medians[0]
    );
}

/// A field with everything in it: two blowers, an outside force (the 40 cm grid does not
/// hold the long hair, so the band and the outside are sampled), uneven cells, a gust that
/// ramps and steps, on top of the gust scene's own wind and pseudo-force.
fn busy_field(scene: &Scene) -> EffDesc {
    let c = DVec3::from(scene.head.center);
    EffDesc {
        center: (c + DVec3::new(2.0, -4.0, 0.0)).to_array(),
        extent: 40.0,
        resolution: [10, 9, 11],
        source: (c + DVec3::new(40.0, 0.0, -40.0)).to_array(),
        strength: 120.0,
        blowers: vec![
            Blower {
                at: (c + DVec3::new(25.0, 4.0, 10.0)).to_array(),
                toward: [-1.0, 0.0, -0.4],
                strength: 260.0,
                radius: 7.0,
                spread: 10.0,
            },
            Blower {
                at: (c + DVec3::new(-5.0, -20.0, 20.0)).to_array(),
                toward: [0.2, 0.6, -1.0],
                strength: 150.0,
                radius: 5.0,
                spread: 0.0,
            },
        ],
        gust: vec![
            GustKey {
                frame: 0.0,
                scale: 0.5,
                interp: Interp::Linear,
            },
            GustKey {
                frame: 8.0,
                scale: 1.5,
                interp: Interp::Step,
            },
            GustKey {
                frame: 14.0,
                scale: 0.8,
                interp: Interp::Step,
            },
        ],
        ..EffDesc::default()
    }
}

/// The projective contract (tests/it/contract.rs) with an EFF: 20 frames, the same tolerances
/// on the per-strand largest node distance relative to the hair length (median <= 1e-4,
/// 99 % <= 1e-2, at most 2 % beyond 1e-2, none beyond 5e-2) and on the angle states. The
/// field must matter: without it the f64 tips end up elsewhere by centimetres.
#[test]
fn gpu_matches_the_reference_with_a_field() {
    let gpu = common::gpu();
    let mut scene = common::scene("gust");
    for g in scene.groups_mut() {
        g.count /= 20;
    }
    scene.forces.eff = Some(busy_field(&scene));
    let input = prepare(&scene).unwrap();
    let groomed = cantilever::bend_all(&input);
    let hair = cantilever_gpu::groom_gpu(gpu, &common::groom_world(gpu, &input), &input).unwrap();
    let mut sim = Simulation::new(gpu, &common::world(gpu, &scene), &scene, &input, &hair)
        .unwrap()
        .unwrap();
    let mut cpu = CpuSim::new(
        DynSetup::new(&scene, &input, &groomed.visible).unwrap(),
        groomed.nodes.clone(),
    );
    let mut without = CpuSim::new(
        DynSetup::new(
            &{
                let mut s = scene.clone();
                s.forces.eff = None;
                s
            },
            &input,
            &groomed.visible,
        )
        .unwrap(),
        groomed.nodes.clone(),
    );
    for _ in 0..20 {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        sim.record_frame(gpu, &mut enc, &hair).unwrap();
        gpu.queue.submit([enc.finish()]);
        cpu.frame();
        without.frame();
    }
    let offsets = input.vertex_offsets();
    let tips: Vec<usize> = (1..offsets.len())
        .map(|s| offsets[s] as usize - 1)
        .collect();
    let field_effect = median(
        tips.iter()
            .map(|&i| cpu.nodes[i].distance(without.nodes[i]))
            .collect(),
    );
    assert!(
        field_effect > 1.0,
        "the field moved the tips {field_effect} cm"
    );

    let v = hair.read_vertices(gpu).unwrap();
    let errs = common::strand_errors(&input, &v, &cpu.nodes);
    eprintln!("the field moves tips {field_effect:.2} cm (median)");
    let state = sim.read_state(gpu).unwrap();
    let (worst_angle, close) = common::angle_agreement(&cpu.angles, &state);
    common::assert_projective_agrees(&errs, worst_angle, close, 0.99);
}

/// Three frames per submission are the same motion as one by one, bit for bit, across the
/// gust's ramp and steps: each substep reads its own gust scale.
#[test]
fn several_frames_per_submission_see_their_own_gust() {
    let gpu = common::gpu();
    let mut scene = common::scene("gust");
    for g in scene.groups_mut() {
        g.count /= 50;
    }
    scene.forces.eff = Some(busy_field(&scene));
    let input = prepare(&scene).unwrap();
    let mut runs = Vec::new();
    for per_submit in [1, 3] {
        let hair =
            cantilever_gpu::groom_gpu(gpu, &common::groom_world(gpu, &input), &input).unwrap();
        let mut sim = Simulation::new(gpu, &common::world(gpu, &scene), &scene, &input, &hair)
            .unwrap()
            .unwrap();
        for _ in 0..18 / per_submit {
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            sim.record_frames(gpu, &mut enc, &hair, per_submit).unwrap();
            gpu.queue.submit([enc.finish()]);
        }
        runs.push(hair.read_vertices(gpu).unwrap());
    }
    let worst = runs[0]
        .iter()
        .zip(&runs[1])
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0f32, f32::max);
    assert!(worst == 0.0, "3 frames per submission differ by {worst}");
}

/// A field that is the same strong wind everywhere (no defined cells: every cell is the
/// outside force) is the keyed uniform wind by another name: the same substeps (the schedule
/// bounds the force with the field's largest value) and the same motion, to rounding.
#[test]
fn a_uniform_field_is_the_same_as_a_uniform_wind() {
    let scene = still_scene(50);
    let input = prepare(&scene).unwrap();
    let groomed = cantilever::bend_all(&input);
    let c = DVec3::from(scene.head.center);
    let w = DVec3::new(3000.0, -500.0, 800.0);
    let mut wind = scene.clone();
    wind.forces.wind = vec![kami::scene::WindKey {
        frame: 0.0,
        force: w.to_array(),
        interp: Interp::Step,
    }];
    let mut field = scene.clone();
    field.forces.eff = Some(EffDesc {
        center: c.to_array(),
        extent: 30.0,
        resolution: [3, 4, 5],
        source: (c - w.normalize() * 100.0).to_array(),
        head: Some(c.to_array()),
        strength: w.length(),
        ..EffDesc::default()
    });
    let mut runs = Vec::new();
    for s in [&wind, &field] {
        let setup = DynSetup::new(s, &input, &groomed.visible).unwrap();
        let substeps = setup.schedule(0).0.len();
        let mut cpu = CpuSim::new(setup, groomed.nodes.clone());
        for _ in 0..5 {
            cpu.frame();
        }
        runs.push((substeps, cpu.nodes));
    }
    assert!(runs[0].0 > 1, "a strong wind needs substeps");
    assert_eq!(
        runs[1].0, runs[0].0,
        "the field is substepped like the wind"
    );
    let moved = groomed
        .nodes
        .iter()
        .zip(&runs[0].1)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f64::max);
    let differ = runs[0]
        .1
        .iter()
        .zip(&runs[1].1)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f64::max);
    assert!(moved > 1.0, "the wind moved the hair {moved} cm");
    assert!(
        differ < 1e-9 * moved,
        "field and wind differ by {differ:e} cm"
    );
}
