//! The wisps' meshed path (`wisps.draw: Mesh`): the f64 mesher against the field it
//! polygonises (`systems::wisps::mesh`), the mesh drawn on the GPU against the f64 truth,
//! `Auto`'s choice, re-meshing only where the surface changes, and bad input.

use crate::common;
use glam::DVec3;
use kami::systems::wisps::block::WispDraw;
use kami::systems::wisps::{curve, field, mesh, WispsSystem};
use kami::Scene;

/// A lone straight wisp of constant radius and weight along x.
fn straight(r: f64, w: f64) -> Vec<Vec<curve::Segment>> {
    let nodes: Vec<(DVec3, f64, f64)> = (0..4)
        .map(|i| (DVec3::new(4.0 * i as f64, 0.0, 0.0), r, w))
        .collect();
    vec![curve::segments(&nodes)]
}

fn polygonise(segs: &[Vec<curve::Segment>], threshold: f64, cell: f64) -> mesh::WispMesh {
    mesh::polygonise(&mesh::Input {
        wisps: segs,
        outlines: &[],
        taper: 0.0,
        threshold,
        method: Default::default(),
        cell,
        frame: None,
    })
    .unwrap()
}

/// A lone straight tube meshes to a closed surface, wound outward, its vertices on the
/// analytic radius (`mesh::surface_radius`) and its normals radial, away from the ends.
/// Breaks: winding every quad the other way fails the orientation check; no Newton steps
/// (`NEWTON = 0`) leaves vertices a fifth of a cell off the radius.
#[test]
fn a_lone_straight_wisp_meshes_to_its_tube() {
    let (r, w, threshold) = (2.0, 2.5, 0.5);
    let segs = straight(r, w);
    let m = polygonise(&segs, threshold, 0.3);
    let want = mesh::surface_radius(r, w, threshold);
    assert!(m.triangles() > 500, "{} triangles", m.triangles());
    let (mut worst_r, mut worst_n, mut body) = (0.0f64, 1.0f64, 0);
    for (p, n) in m.positions.iter().zip(&m.normals) {
        let p = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        if p.x < 2.0 || p.x > 10.0 {
            continue;
        }
        body += 1;
        let radial = DVec3::new(0.0, p.y, p.z);
        worst_r = worst_r.max((radial.length() - want).abs());
        let n = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
        worst_n = worst_n.min(n.dot(radial.normalize()));
    }
    eprintln!(
        "{body} body vertices: radius off by {worst_r:.2e} (cell 0.3), normal dot {worst_n:.6}"
    );
    assert!(body > 200);
    assert!(
        worst_r < 1e-3 * r,
        "a vertex is {worst_r} off the radius {want}"
    );
    assert!(worst_n > 0.9999, "a normal is {worst_n} from radial");
    // Closed: every edge is shared by exactly two triangles, once each way.
    let mut edges = std::collections::HashMap::new();
    for t in m.indices.chunks(3) {
        for k in 0..3 {
            *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    let open = edges
        .iter()
        .filter(|(&(a, b), &n)| n != 1 || edges.get(&(b, a)) != Some(&1))
        .count();
    assert_eq!(
        open, 0,
        "{open} edges are not shared by two triangles, once each way"
    );
    // Wound outward: each triangle's face normal along its vertices' normals.
    let v = |i: u32| {
        let p = m.positions[i as usize];
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    };
    let inward = m
        .indices
        .chunks(3)
        .filter(|t| {
            let face = (v(t[1]) - v(t[0])).cross(v(t[2]) - v(t[0]));
            let n = m.normals[t[0] as usize];
            face.dot(DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64)) <= 0.0
        })
        .count();
    assert_eq!(inward, 0, "{inward} triangles face inward");
}

/// The hull's offset (`mesh::shell_depth`, from the curvature stored per vertex) is where the
/// march's outline shell ends (f + |∇f| eps = 0 along the normal, solved here by bisection
/// on the f64 field) on a lone wisp, for outlines up to half its radius. Break: a shell depth
/// of eps (no curvature) is 27 % too deep at eps = r/2 and fails.
#[test]
fn the_outline_hull_ends_where_the_marchs_shell_does() {
    let (r, w, threshold) = (2.0, 2.5, 0.5);
    let segs = straight(r, w);
    let m = polygonise(&segs, threshold, 0.25);
    // A body vertex and its stored curvature.
    let k = m
        .positions
        .iter()
        .position(|p| (p[0] - 6.0).abs() < 0.5)
        .unwrap();
    let p = DVec3::new(
        m.positions[k][0] as f64,
        m.positions[k][1] as f64,
        m.positions[k][2] as f64,
    );
    let n = DVec3::new(
        m.normals[k][0] as f64,
        m.normals[k][1] as f64,
        m.normals[k][2] as f64,
    );
    let kappa = m.normals[k][3] as f64;
    let f = |s: f64| field::field(&segs, threshold, p + n * s, Default::default());
    for eps in [0.05, 0.2, 0.5, 1.0] {
        // The shell's edge: the last s where f + |∇f| eps ≥ 0.
        let (mut a, mut b) = (0.0, 4.0 * eps);
        for _ in 0..60 {
            let s = 0.5 * (a + b);
            let d = f(s);
            if d.rho + d.grad.length() * eps >= 0.0 {
                a = s;
            } else {
                b = s;
            }
        }
        let got = mesh::shell_depth(eps, kappa);
        eprintln!("eps {eps}: shell {a:.5}, hull {got:.5}");
        assert!(
            (got - a).abs() < 0.02 * eps + 1e-4,
            "eps {eps}: the shell ends at {a}, the hull at {got}"
        );
    }
}

/// A grid finer than the limits is refused before anything is allocated, naming the numbers;
/// a cell that is not positive is refused too.
#[test]
fn a_mesh_cell_past_the_limits_is_refused_with_the_numbers() {
    let segs = straight(2.0, 2.5);
    for cell in [1e-7, 0.0, -1.0, f64::NAN] {
        let e = mesh::polygonise(&mesh::Input {
            wisps: &segs,
            outlines: &[],
            taper: 0.0,
            threshold: 0.5,
            method: Default::default(),
            cell,
            frame: None,
        })
        .unwrap_err()
        .to_string();
        eprintln!("cell {cell}: {e}");
        assert!(e.contains("wisps.mesh.cell"), "{e}");
        if cell > 0.0 {
            assert!(e.contains("points"), "{e}");
        }
    }
    // In a scene: a negative cell is refused when it loads, naming the field.
    let mut s = common::scene("toon");
    s.wisps_mut().as_mut().unwrap().mesh.cell = -1.0;
    let (field, _, _) = common::invalid(&s.to_ron());
    assert_eq!(field, "wisps.mesh.cell");
}

/// A `draw` that is not a path is refused with the file and place, and `--set` names the
/// choices.
#[test]
fn a_draw_that_is_not_a_path_is_refused() {
    let text = common::scene("toon")
        .to_ron()
        .replacen("draw: Auto", "draw: Raster", 1);
    assert!(text.contains("draw: Raster"), "the scene writes its draw");
    let e = Scene::from_ron(&text, "bad.ron").unwrap_err().to_string();
    eprintln!("{e}");
    assert!(e.contains("bad.ron") && e.contains("Raster"), "{e}");
    let e = kami::systems::wisps::tools::parse_draw(Some("raster")).unwrap_err();
    assert!(e.contains("auto, march or mesh"), "{e}");
}

fn one_sample(name: &str, draw: WispDraw) -> Scene {
    let mut s = common::scene(name);
    s.render.supersample = 1;
    s.render.msaa = 1;
    s.head.visible = false;
    s.wisps_mut().as_mut().unwrap().draw = draw;
    s
}

/// The mesh on the GPU against the converged f64 truth (`field::render_reference` with
/// 4096 steps a ray, no head) on toon.ron at 128², outline and toon shadows included: within
/// `mesh_pass::MESH_ERROR_BOUND`, the bound `Auto` holds it to. Breaks: an outline hull
/// pushed out by the full eps (no curvature) gives mean 4.6 (no shadows: `docs/wisps.md`);
/// the rim's view along the camera axis instead of the pixel's ray is also caught.
#[test]
fn the_mesh_draws_the_truth_within_the_bound() {
    let gpu = common::gpu();
    let size = (128, 128);
    let scene = one_sample("toon", WispDraw::Mesh);
    let truth = converged_truth(&scene, size);
    let img = kami::stage::render_scene(gpu, &scene, size).unwrap();
    let (mean, share, _) = kami::bench::backends::difference(&truth, &img);
    let (bound_mean, bound_share) = kami::systems::wisps::mesh_pass::MESH_ERROR_BOUND;
    eprintln!(
        "mesh against the converged truth: mean {mean:.3}, {:.3} % over 24",
        share * 100.0
    );
    let hair = img
        .pixels()
        .filter(|p| p[2] as i32 - p[0] as i32 > 25)
        .count();
    assert!(hair > 3000, "{hair} hair pixels");
    assert!(
        mean <= bound_mean && share <= bound_share,
        "the mesh is off the truth by mean {mean:.3}, {:.3} % of pixels over 24",
        share * 100.0
    );
}

/// The mesh's look: `toon.ron` at 192², one sample per pixel, with the head (the march's
/// snapshot of the same view is `toon`).
#[test]
fn toon_mesh_snapshot() {
    let mut scene = one_sample("toon", WispDraw::Mesh);
    scene.head.visible = true;
    let img = kami::stage::render_scene(common::gpu(), &scene, (192, 192)).unwrap();
    common::check_snapshot(
        "toon_mesh",
        &img,
        common::Tolerance {
            mean: 0.25,
            threshold: 24,
            share: 0.002,
        },
    );
}

/// One stage draws the march, then the mesh (a `Redraw` from the Toon panel), then the march
/// again: each frame equals a fresh stage's with that path. The still hairstyle is meshed
/// once and not again while the camera orbits; a new threshold meshes it again.
#[test]
fn the_path_switches_live_and_a_still_hairstyle_is_meshed_once() {
    let gpu = common::gpu();
    let size = (96, 96);
    let march = one_sample("toon", WispDraw::March);
    let meshed = one_sample("toon", WispDraw::Mesh);
    let fresh = |s: &Scene| kami::stage::render_scene(gpu, s, size).unwrap();
    let mut stage = common::stage(gpu, &march);
    let frame = |stage: &mut kami::stage::Stage| common::draw(stage, size);
    assert!(
        frame(&mut stage) == fresh(&march),
        "the march's first frame"
    );
    stage.apply(gpu, &meshed).unwrap();
    assert!(
        frame(&mut stage) == fresh(&meshed),
        "after switching to the mesh, the frame is not a fresh stage's mesh"
    );
    let count = |stage: &kami::stage::Stage| {
        stage
            .system::<WispsSystem>()
            .unwrap()
            .mesh
            .as_ref()
            .map(|m| m.last.count)
    };
    assert_eq!(count(&stage), Some(1));
    // Orbit: the camera moves about the hair at the same distance.
    let mut orbit = meshed.clone();
    for k in 1..=3 {
        let a = 0.3 * k as f64;
        let c = &mut orbit.camera;
        let (t, e) = (DVec3::from(c.target), DVec3::from(c.eye));
        let q = glam::DQuat::from_rotation_y(a);
        c.eye = (t + q * (e - t)).to_array();
        stage.apply(gpu, &orbit).unwrap();
        frame(&mut stage);
    }
    assert_eq!(
        count(&stage),
        Some(1),
        "orbiting a still hairstyle meshed it again"
    );
    let mut thicker = orbit.clone();
    thicker.wisps_mut().as_mut().unwrap().threshold = 0.4;
    stage.apply(gpu, &thicker).unwrap();
    frame(&mut stage);
    assert_eq!(count(&stage), Some(2), "a new threshold did not mesh again");
    stage.apply(gpu, &march).unwrap();
    assert!(frame(&mut stage) == fresh(&march), "back to the march");
    assert_eq!(count(&stage), None, "the march keeps no mesh");
}

/// Moving wisps are meshed again every frame (from the springs' nodes of the frame before).
#[test]
fn moving_wisps_are_meshed_every_frame() {
    let gpu = common::gpu();
    let scene = one_sample("toon_shake", WispDraw::Mesh);
    let mut stage = common::stage(gpu, &scene);
    let out = kami::stage::target::Offscreen::new(gpu, (64, 64)).unwrap();
    for _ in 0..3 {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        stage.advance(gpu, &mut enc, 1).unwrap();
        let look = stage.look();
        stage
            .render(gpu, &mut enc, &out.view, (64, 64), &look)
            .unwrap();
        gpu.queue.submit([enc.finish()]);
    }
    let m = stage
        .system::<WispsSystem>()
        .unwrap()
        .mesh
        .as_ref()
        .unwrap();
    assert_eq!(m.last.count, 3);
    assert!(m.last.triangles > 1000, "{:?}", m.last);
}

/// `Auto` follows the measured file (`docs/wisps_draw.ron`) per adapter class, still or
/// moving, and a class not measured falls back as documented.
#[test]
fn auto_follows_the_measured_choices() {
    use kami::systems::wisps::mesh_pass::{auto_draws_mesh, choices, parse_choices};
    let cpu = wgpu::DeviceType::Cpu;
    let gpu_kind = wgpu::DeviceType::DiscreteGpu;
    assert!(auto_draws_mesh(WispDraw::Mesh, cpu, true));
    assert!(!auto_draws_mesh(WispDraw::March, gpu_kind, false));
    let c = choices().as_ref().expect("docs/wisps_draw.ron reads");
    let own = |still: bool| {
        c.software
            .as_ref()
            .map(|s| (if still { s.still } else { s.moving }) == WispDraw::Mesh)
    };
    if let Some(still) = own(true) {
        assert_eq!(auto_draws_mesh(WispDraw::Auto, cpu, false), still);
        assert_eq!(
            auto_draws_mesh(WispDraw::Auto, cpu, true),
            own(false).unwrap()
        );
    }
    if c.hardware.is_none() {
        assert!(
            auto_draws_mesh(WispDraw::Auto, gpu_kind, true),
            "moving wisps on an unmeasured hardware GPU draw the mesh (meshed on the GPU)"
        );
    }
    use kami::systems::wisps::mesh_pass::auto_meshes_on_gpu;
    assert!(auto_meshes_on_gpu(gpu_kind, true));
    assert!(
        !auto_meshes_on_gpu(gpu_kind, false),
        "still wisps mesh once on the CPU"
    );
    assert!(
        !auto_meshes_on_gpu(cpu, true),
        "a software adapter meshes on the CPU"
    );
    assert!(parse_choices("(software: None, hardware: None)").is_ok());
    let e = parse_choices(
        "(software: Some((adapter: \"x\", still: Auto, moving: Mesh)), hardware: None)",
    )
    .unwrap_err();
    assert!(e.contains("March or Mesh"), "{e}");
}

/// The GPU mesher (`shaders/wisps/mesher.wgsl`) over toon.ron's drawn wisps against its f64
/// reference, `mesh::polygonise` on the same grid from the same nodes: the same vertices
/// (matched by position) and triangles, each vertex where the reference puts it with its
/// normal, outline scale and shell curvature, the triangles wound outward, nothing dropped.
fn gpu_mesher_against_the_reference(name: &str, cell_scale: f64) -> (f64, f64) {
    use kami::systems::wisps::{march, mesh_gpu};
    let gpu = common::gpu();
    let scene = common::scene(name);
    let wisps = scene.wisps().clone().unwrap();
    let (mut curves, mut mesher) = curves_and_mesher(&wisps);
    let (centre, radius) = march::bounds(&wisps, false);
    let cell = mesh::auto_cell(&wisps) * cell_scale;
    let plan = mesh_gpu::plan(&wisps, centre, radius, cell, 1 << 30).unwrap();
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    curves.record(gpu, &mut enc, glam::DMat4::IDENTITY, true);
    mesher.record(gpu, &mut enc, &curves, &wisps, plan);
    gpu.queue.submit([enc.finish()]);
    let (g, counters) = mesher.read(gpu).unwrap();
    assert!(!counters.overflowed(), "{counters:?}");
    let segs = curve::drawn_segments(&wisps);
    let outlines = mesh::wisp_outlines(&wisps, &segs);
    let r = mesh::polygonise(&mesh::Input {
        wisps: &segs,
        outlines: &outlines,
        taper: wisps.toon.outline_taper,
        threshold: wisps.threshold,
        method: wisps.march.distance,
        cell: plan.cell,
        frame: Some(plan.frame()),
    })
    .unwrap();
    let (nv, nr) = (g.positions.len(), r.positions.len());
    eprintln!(
        "{name} at cell {:.4}: GPU {nv} vertices, {} triangles; f64 {nr}, {} ({counters:?})",
        plan.cell,
        g.triangles(),
        r.triangles()
    );
    assert!(nr > 1000, "{nr} reference vertices");
    // Nearest GPU vertex of each reference vertex, by a hash of cells.
    let h = plan.cell;
    let key = |p: [f32; 4]| {
        [
            (p[0] as f64 / h).floor() as i64,
            (p[1] as f64 / h).floor() as i64,
            (p[2] as f64 / h).floor() as i64,
        ]
    };
    let mut table: std::collections::HashMap<[i64; 3], Vec<usize>> = Default::default();
    for (k, &p) in g.positions.iter().enumerate() {
        table.entry(key(p)).or_default().push(k);
    }
    let (mut matched, mut worst_p, mut worst_n, mut worst_o, mut worst_k) =
        (0, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (k, &p) in r.positions.iter().enumerate() {
        let c = key(p);
        let mut best = (f64::INFINITY, usize::MAX);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    for &j in table
                        .get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                        .into_iter()
                        .flatten()
                    {
                        let q = g.positions[j];
                        let d = (0..3)
                            .map(|a| (p[a] as f64 - q[a] as f64).powi(2))
                            .sum::<f64>()
                            .sqrt();
                        if d < best.0 {
                            best = (d, j);
                        }
                    }
                }
            }
        }
        if best.0 > 1e-2 * h {
            continue;
        }
        matched += 1;
        let j = best.1;
        worst_p = worst_p.max(best.0 / h);
        let (a, b) = (r.normals[k], g.normals[j]);
        let dot = (0..3).map(|i| a[i] as f64 * b[i] as f64).sum::<f64>();
        worst_n = worst_n.max(dot.clamp(-1.0, 1.0).acos().to_degrees());
        worst_o = worst_o.max((p[3] - g.positions[j][3]).abs() as f64);
        worst_k = worst_k.max((a[3] - b[3]).abs() as f64 / (a[3].abs() as f64).max(1.0 / h));
    }
    let unmatched = (nr - matched) as f64 / nr as f64;
    eprintln!(
        "matched {matched} of {nr} ({:.4} % not), worst offset {worst_p:.2e} cells, normal \
         {worst_n:.3}°, outline scale {worst_o:.2e}, κ {worst_k:.2e} (relative)",
        unmatched * 100.0
    );
    // Outward: each triangle's face normal along its vertices' normals.
    let inward = g
        .indices
        .chunks(3)
        .filter(|t| {
            let p = |i: u32| glam::Vec3::from_slice(&g.positions[i as usize][..3]);
            let n = |i: u32| glam::Vec3::from_slice(&g.normals[i as usize][..3]);
            let f = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
            f.dot(n(t[0]) + n(t[1]) + n(t[2])) < 0.0
        })
        .count();
    assert!(g.indices.iter().all(|&i| (i as usize) < nv));
    let tri_off = (g.triangles() as f64 - r.triangles() as f64).abs() / r.triangles() as f64;
    assert!(
        unmatched <= 2e-3 && (nv as f64 - nr as f64).abs() / (nr as f64) <= 2e-3 && tri_off <= 2e-3,
        "{unmatched} of the reference's vertices unmatched; {nv} against {nr} vertices, \
         triangles {tri_off} off"
    );
    assert!(
        worst_p <= 1e-3,
        "a vertex {worst_p} cells from the reference's"
    );
    assert!(worst_n <= 0.5, "a normal {worst_n}° off");
    assert!(worst_o <= 1e-3, "an outline scale {worst_o} off");
    assert!(worst_k <= 1e-2, "a shell curvature {worst_k} off");
    assert!(
        (inward as f64) <= 1e-3 * g.triangles() as f64,
        "{inward} of {} triangles face inward",
        g.triangles()
    );
    (unmatched, worst_p)
}

#[test]
fn the_gpu_mesher_matches_the_f64_mesher() {
    gpu_mesher_against_the_reference("toon", 1.0);
    gpu_mesher_against_the_reference("toon_shake", 0.7);
}

/// Frames of `scene` drawn on one stage at `size`, the last one read back.
fn after_frames(
    scene: &Scene,
    frames: u32,
    size: (u32, u32),
) -> (image::RgbaImage, kami::stage::Stage) {
    let gpu = common::gpu();
    let mut stage = common::stage(gpu, scene);
    let out = kami::stage::target::Offscreen::new(gpu, size).unwrap();
    for _ in 0..frames {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        stage.advance(gpu, &mut enc, 1).unwrap();
        let look = stage.look();
        stage.render(gpu, &mut enc, &out.view, size, &look).unwrap();
        gpu.queue.submit([enc.finish()]);
    }
    (out.read_rgba(gpu).unwrap(), stage)
}

/// Moving wisps meshed on the GPU (`wisps.mesh.on: Gpu`) each frame from the segments of
/// that frame, nothing read back: after 6 frames of toon_shake.ron the image is the march's
/// of the same frame within `MESH_ERROR_BOUND`, the mesher ran every frame and dropped
/// nothing. Break: the mesher not recorded (nothing drawn) fails on the difference.
#[test]
fn moving_wisps_meshed_on_the_gpu_draw_what_the_march_draws() {
    use kami::systems::wisps::block::MeshOn;
    let gpu = common::gpu();
    let size = (128, 128);
    let mut meshed = one_sample("toon_shake", WispDraw::Mesh);
    meshed.wisps_mut().as_mut().unwrap().mesh.on = MeshOn::Gpu;
    let march = one_sample("toon_shake", WispDraw::March);
    let (img, stage) = after_frames(&meshed, 6, size);
    let (truth, _) = after_frames(&march, 6, size);
    let (mean, share, _) = kami::bench::backends::difference(&truth, &img);
    eprintln!(
        "GPU mesh against the march after 6 frames: mean {mean:.3}, {:.3} % over 24",
        share * 100.0
    );
    let m = stage
        .system::<WispsSystem>()
        .unwrap()
        .mesh
        .as_ref()
        .unwrap();
    assert_eq!(m.last.count, 6, "meshed every frame");
    let g = m.gpu.as_ref().expect("meshed on the GPU");
    let c = g.counters(gpu).unwrap();
    assert!(!c.overflowed() && c.drawn > 6000, "{c:?}");
    let (bound_mean, bound_share) = kami::systems::wisps::mesh_pass::MESH_ERROR_BOUND;
    assert!(
        mean <= bound_mean && share <= bound_share,
        "the GPU mesh is off the march by mean {mean:.3}, {:.3} % over 24",
        share * 100.0
    );
}

/// The coarsest cell moving wisps take under the viewer's budget (`mesh::MOVING_COARSEST`
/// times the automatic cell) still draws toon.ron within `MESH_ERROR_BOUND` of the
/// converged truth at 128². Break: 1.5 (the value before) fails with 2.87 % over 24.
#[test]
fn the_coarsest_moving_cell_is_within_the_bound() {
    let gpu = common::gpu();
    let size = (128, 128);
    let mut scene = one_sample("toon", WispDraw::Mesh);
    let truth = converged_truth(&scene, size);
    let w = scene.wisps_mut().as_mut().unwrap();
    w.mesh.cell = mesh::auto_cell(w) * mesh::MOVING_COARSEST;
    let img = kami::stage::render_scene(gpu, &scene, size).unwrap();
    let (mean, share, _) = kami::bench::backends::difference(&truth, &img);
    eprintln!(
        "coarsest moving cell: mean {mean:.3}, {:.3} % over 24",
        share * 100.0
    );
    let (bound_mean, bound_share) = kami::systems::wisps::mesh_pass::MESH_ERROR_BOUND;
    assert!(mean <= bound_mean && share <= bound_share);
}

/// The GPU mesher's grid is refused before anything is allocated, naming `wisps.mesh.cell`
/// and the numbers, where it passes the limits or the adapter's buffers; a `mesh.on` that is
/// not a place is refused with the choices.
#[test]
fn a_gpu_mesh_past_the_limits_is_refused_with_the_numbers() {
    use kami::systems::wisps::{march, mesh_gpu};
    let scene = common::scene("toon_shake");
    let w = scene.wisps().clone().unwrap();
    let (c, r) = march::bounds(&w, true);
    for (cell, limit) in [
        (1e-6, 1u64 << 40),
        (0.0, 1 << 40),
        (f64::NAN, 1 << 40),
        (0.3, 1 << 16),
    ] {
        let e = mesh_gpu::plan(&w, c, r, cell, limit)
            .unwrap_err()
            .to_string();
        eprintln!("cell {cell}, limit {limit}: {e}");
        assert!(e.contains("wisps.mesh.cell"), "{e}");
        if limit < 1 << 30 {
            assert!(e.contains("bytes"), "{e}");
        }
    }
    let p = mesh_gpu::plan(&w, c, r, 0.3, 1 << 30).unwrap();
    assert!(p.bytes().iter().all(|&b| b <= 1 << 30));
    let e = kami::systems::wisps::tools::parse_mesh_on(Some("tpu")).unwrap_err();
    assert!(e.contains("auto, cpu or gpu"), "{e}");
}

/// Past its capacities the GPU mesher writes nothing out of bounds and counts what it
/// dropped (`warnings` reports it): toon.ron with room for 1000 vertices and 600 indices,
/// then for 40 bricks. Break: `finish` drawing every index asked for, not the capacity's,
/// fails on `drawn`.
#[test]
fn the_gpu_mesher_counts_what_passes_its_capacities() {
    use kami::systems::wisps::{march, mesh_gpu};
    let gpu = common::gpu();
    let scene = common::scene("toon");
    let wisps = scene.wisps().clone().unwrap();
    let (mut curves, mut mesher) = curves_and_mesher(&wisps);
    let (centre, radius) = march::bounds(&wisps, false);
    let planned = mesh_gpu::plan(&wisps, centre, radius, 0.3, 1 << 30).unwrap();
    let mut run = |plan: mesh_gpu::Plan| {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        curves.record(gpu, &mut enc, glam::DMat4::IDENTITY, true);
        mesher.record(gpu, &mut enc, &curves, &wisps, plan);
        gpu.queue.submit([enc.finish()]);
        let (m, c) = mesher.read(gpu).unwrap();
        eprintln!("{c:?}");
        (m, c)
    };
    let (m, c) = run(mesh_gpu::Plan {
        vertex_cap: 1000,
        index_cap: 600,
        ..planned
    });
    assert!(
        c.overflowed() && c.vertices_over > 0 && c.quads_over > 0,
        "{c:?}"
    );
    assert_eq!(c.vertices, 1000 + c.vertices_over, "{c:?}");
    assert!(c.drawn <= 600 && c.drawn % 6 == 0, "{c:?}");
    assert!(m.positions.len() <= 1000);
    assert!(m.indices.iter().all(|&i| i < 1000));
    let (_, c) = run(mesh_gpu::Plan {
        slot_cap: 40,
        ..planned
    });
    assert!(c.overflowed() && c.slots_over == c.slots - 40, "{c:?}");
}

/// Springs whose nodes do not move (frames drawn without a step of the clock) are meshed on
/// the CPU once and not again while no node moves `mesh::SETTLED` of a cell; stepping them
/// meshes every frame again. Break: `SETTLED` 0 meshes every drawn frame (count 4).
#[test]
fn springs_at_rest_are_not_meshed_again() {
    use kami::systems::wisps::block::MeshOn;
    let gpu = common::gpu();
    let mut scene = one_sample("toon_shake", WispDraw::Mesh);
    scene.wisps_mut().as_mut().unwrap().mesh.on = MeshOn::Cpu;
    let mut stage = common::stage(gpu, &scene);
    let size = (64, 64);
    let out = kami::stage::target::Offscreen::new(gpu, size).unwrap();
    let frame = |stage: &mut kami::stage::Stage, step: bool| {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        if step {
            stage.advance(gpu, &mut enc, 1).unwrap();
        }
        let look = stage.look();
        stage.render(gpu, &mut enc, &out.view, size, &look).unwrap();
        gpu.queue.submit([enc.finish()]);
    };
    let count = |stage: &kami::stage::Stage| {
        stage
            .system::<WispsSystem>()
            .unwrap()
            .mesh
            .as_ref()
            .unwrap()
            .last
            .count
    };
    for _ in 0..4 {
        frame(&mut stage, false);
    }
    assert_eq!(count(&stage), 1, "springs at rest were meshed again");
    for _ in 0..3 {
        frame(&mut stage, true);
    }
    // The mesh trails the springs by a frame: the first step is seen by the next frame.
    assert!(
        count(&stage) >= 3,
        "stepped springs meshed {} times",
        count(&stage)
    );
}

/// Moving wisps take the cell the viewer's budget asks for at once: a frame at full quality
/// meshes at the automatic cell, the next under a budget of 1 % of hairs at
/// `mesh::MOVING_COARSEST` times it. Break: the still wisps' zoom hysteresis (1.5) applied
/// to moving wisps holds the cell at the automatic one.
#[test]
fn moving_wisps_take_the_budgets_cell_at_once() {
    use kami::systems::wisps::block::MeshOn;
    let gpu = common::gpu();
    let mut scene = one_sample("toon_shake", WispDraw::Mesh);
    scene.wisps_mut().as_mut().unwrap().mesh.on = MeshOn::Cpu;
    let auto = mesh::auto_cell(scene.wisps().as_ref().unwrap());
    let mut stage = common::stage(gpu, &scene);
    let size = (256, 256);
    let out = kami::stage::target::Offscreen::new(gpu, size).unwrap();
    let mut cells = Vec::new();
    for lod in [1.0, 0.01] {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        stage.advance(gpu, &mut enc, 1).unwrap();
        let mut look = stage.look();
        look.lod = lod;
        stage.render(gpu, &mut enc, &out.view, size, &look).unwrap();
        gpu.queue.submit([enc.finish()]);
        let m = stage
            .system::<WispsSystem>()
            .unwrap()
            .mesh
            .as_ref()
            .unwrap();
        cells.push(m.last.cell);
    }
    eprintln!("automatic {auto:.4}, meshed at {cells:?}");
    assert!((cells[0] - auto).abs() < 1e-9, "{cells:?}");
    assert!(
        (cells[1] - auto * mesh::MOVING_COARSEST).abs() < 1e-9,
        "under the budget the cell stayed {} (automatic {auto})",
        cells[1]
    );
}

/// The curve kernels over `wisps`' drawn nodes and a GPU mesher over their segments.
fn curves_and_mesher(
    wisps: &kami::systems::wisps::block::Wisps,
) -> (
    kami::systems::wisps::march::CurvePass,
    kami::systems::wisps::mesh_gpu::Mesher,
) {
    use kami::systems::wisps::{march, mesh_gpu};
    let gpu = common::gpu();
    let nodes = kami::gpu::storage_buffer(
        &gpu.device,
        "test nodes",
        bytemuck::cast_slice(&march::drawn_positions(wisps)),
        wgpu::BufferUsages::empty(),
    );
    (
        march::CurvePass::new(gpu, wisps, &nodes).unwrap(),
        mesh_gpu::Mesher::new(gpu, wisps).unwrap(),
    )
}

/// The converged f64 truth of `scene` at `size` (4096 steps a ray, `field::render_reference`).
fn converged_truth(scene: &Scene, size: (u32, u32)) -> image::RgbaImage {
    let mut converged = scene.clone();
    converged.wisps_mut().as_mut().unwrap().march.max_steps = 4096;
    kami::bench::wisps::truth_image(common::gpu(), &converged, size).unwrap()
}
