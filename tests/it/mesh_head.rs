//! Heads that are meshes (issue 14, item 3): the signed distance field of CGAL's `head.off`
//! against brute-force exact distance, the pores on the scalp, the cantilever and projective
//! kernels on the mesh head against their f64 references, no node inside the head after
//! grooming and after a strong gust into the face, clear errors, and a snapshot.
//!
//! Speed and error figures come from `kami bench sdf` (docs/sdf.md), not from these tests.

use crate::common;
use common::{check_snapshot, Tolerance};
use glam::{DMat4, DVec3};
use kami::scene::hull::{head_mesh, HeadMeshData};
use kami::systems::anjyo::groom::prepare;
use kami::systems::anjyo::projective::{CpuSim, DynSetup};
use kami::systems::anjyo::{cantilever, cantilever_gpu};
use std::sync::Arc;

fn mesh_scene() -> kami::Scene {
    common::scene("mesh_head")
}

fn data(scene: &kami::Scene) -> Arc<HeadMeshData> {
    head_mesh(&scene.head)
        .unwrap()
        .expect("the scene has a mesh head")
}

/// A small deterministic generator (xorshift) for test points.
struct Xs(u64);
impl Xs {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Distance from `p` to the triangle `abc`, written apart from the field it checks (which
/// uses `sdf::closest_point_triangle`'s Voronoi regions): the distance to the plane where
/// `p` projects inside the triangle (three same-side tests), else the nearest edge.
fn triangle_distance(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let segment = |u: DVec3, v: DVec3| {
        let d = v - u;
        let t = if d.length_squared() > 0.0 {
            ((p - u).dot(d) / d.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p - (u + d * t)).length()
    };
    let n = (b - a).cross(c - a);
    let nn = n.length_squared();
    if nn > 0.0 {
        let q = p - n * ((p - a).dot(n) / nn);
        if [(a, b), (b, c), (c, a)]
            .iter()
            .all(|&(u, v)| (v - u).cross(q - u).dot(n) >= 0.0)
        {
            return (p - q).length();
        }
    }
    segment(a, b).min(segment(b, c)).min(segment(c, a))
}

/// Whether the ray from `p` along `dir` crosses the triangle `abc` (Möller–Trumbore).
fn ray_hits(p: DVec3, dir: DVec3, a: DVec3, b: DVec3, c: DVec3) -> bool {
    let (e1, e2) = (b - a, c - a);
    let h = dir.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-14 {
        return false;
    }
    let s = p - a;
    let u = s.dot(h) / det;
    let q = s.cross(e1);
    let v = dir.dot(q) / det;
    u >= 0.0 && v >= 0.0 && u + v <= 1.0 && e2.dot(q) / det > 0.0
}

/// The share of 16 rays from `p` (spread over the sphere, off every axis) that cross the
/// mesh an odd number of times: 1 deep inside a closed surface, 0 outside, in between where
/// rays leave through an opening (the neck). An inside test by ray parity, apart from the
/// field's winding number.
fn odd_share(positions: &[DVec3], triangles: &[[u32; 3]], p: DVec3) -> f64 {
    const RAYS: usize = 16;
    let odd = (0..RAYS)
        .filter(|&k| {
            // A Fibonacci spiral, turned off the axes so no ray runs along a mesh edge.
            let z = 1.0 - (2.0 * k as f64 + 1.0) / RAYS as f64;
            let phi = k as f64 * 2.399_963_229_728_653 + 0.3;
            let r = (1.0 - z * z).sqrt();
            let dir = DVec3::new(r * phi.cos(), z, r * phi.sin());
            let hits = triangles
                .iter()
                .filter(|t| {
                    let [a, b, c] = t.map(|v| positions[v as usize]);
                    ray_hits(p, dir, a, b, c)
                })
                .count();
            hits % 2 == 1
        })
        .count();
    odd as f64 / RAYS as f64
}

/// The field against brute-force exact signed distance at random points of its box (the
/// reference shares no code with the field: its own point-triangle distance, its sign by
/// ray parity), 400
/// of them uniform and 400 within 2 cells of the surface (near mesh vertices). Bounds:
/// worst |error| <= 0.5 cell everywhere (trilinear error on a curved surface, measured
/// 0.43 cell, at creases), sign right wherever |exact distance| > 1 cell (measured:
/// everywhere), |gradient| within 1 cell of the surface away from the mesh's open neck:
/// median within 10 % of 1, 90 % of the points in [0.6, 1.2] (thin features such as the ear
/// rims, where two sides of the surface share a cell, pull it down).
#[test]
fn sdf_matches_exact_distance() {
    let scene = mesh_scene();
    let m = data(&scene);
    let sdf = &m.sdf;
    println!(
        "SDF {}x{}x{} nodes, cell {:.4}, built in {:.2} s",
        sdf.dims[0], sdf.dims[1], sdf.dims[2], sdf.cell, m.build_seconds
    );
    let mut rng = Xs(0x9e3779b97f4a7c15);
    let (lo, hi) = (sdf.origin, sdf.max_corner());
    let mut points = Vec::new();
    for _ in 0..400 {
        points.push(lo + (hi - lo) * DVec3::new(rng.unit(), rng.unit(), rng.unit()));
    }
    for _ in 0..400 {
        let v = m.mesh.positions[(rng.unit() * m.mesh.positions.len() as f64) as usize];
        let off = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 2.0 - 1.0;
        points.push(v + off * 2.0 * sdf.cell);
    }
    let (mut worst, mut worst_sign_dist, mut sum) = (0.0f64, 0.0f64, 0.0);
    let mut grads = Vec::new();
    let mut ambiguous = Vec::new();
    for p in &points {
        // Across the open neck the share of rays that find the point inside passes 1/2
        // smoothly and the sign of the reference itself is a matter of definition: points
        // where it is within 0.3 of 1/2 are counted, not compared.
        let w = odd_share(&m.mesh.positions, &m.mesh.triangles, *p);
        if (w - 0.5).abs() < 0.3 {
            ambiguous.push(*p);
            continue;
        }
        let unsigned = m
            .mesh
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| m.mesh.positions[v as usize]);
                triangle_distance(*p, a, b, c)
            })
            .fold(f64::INFINITY, f64::min);
        let exact = if w > 0.5 { -unsigned } else { unsigned };
        let s = sdf.sample(*p);
        worst = worst.max((s - exact).abs());
        sum += (s - exact).abs();
        if s.signum() != exact.signum() {
            worst_sign_dist = worst_sign_dist.max(exact.abs());
        }
        // The neck is open: the field is not a distance across the opening.
        if exact.abs() < sdf.cell && p.y > -8.0 {
            grads.push(sdf.gradient(*p).length());
        }
    }
    grads.sort_by(f64::total_cmp);
    let gq = |q: f64| grads[((grads.len() - 1) as f64 * q) as usize];
    let (g05, g50, g95) = (gq(0.05), gq(0.5), gq(0.95));
    let highest = ambiguous.iter().map(|p| p.y).fold(f64::MIN, f64::max);
    println!(
        "{} points skipped where the share of rays finding them inside is within 0.3 of 1/2 (all at y <= {highest:.1}: the open neck and the tube above it)",
        ambiguous.len()
    );
    // Inside the open neck tube the winding number sinks towards 1/2 well above the opening
    // (measured: up to the jaw, y = 2.7), never near the scalp.
    assert!(
        ambiguous.iter().all(|p| p.y < 4.0) && ambiguous.len() < points.len() / 10,
        "ambiguous points away from the neck: {ambiguous:?}"
    );
    println!(
        "SDF vs exact over {} points: worst {:.4} ({:.3} cell), mean {:.5}; wrong sign only within {:.4} of the surface; |grad| near the surface ({} points): 5% {g05:.3}, median {g50:.3}, 95% {g95:.3}, range [{:.3}, {:.3}]",
        points.len() - ambiguous.len(),
        worst,
        worst / sdf.cell,
        sum / (points.len() - ambiguous.len()) as f64,
        worst_sign_dist,
        grads.len(),
        grads[0],
        grads[grads.len() - 1]
    );
    assert!(
        worst <= 0.5 * sdf.cell,
        "worst error {worst:.4}, cell {:.4}",
        sdf.cell
    );
    assert!(
        worst_sign_dist <= sdf.cell,
        "a point {worst_sign_dist:.4} from the surface has the wrong sign"
    );
    assert!(
        g50 > 0.9 && g50 < 1.1 && g05 > 0.6 && g95 < 1.2,
        "|grad| 5% {g05}, median {g50}, 95% {g95}"
    );
    // Sign: the skull's centre is inside, a point in front of the face and one above the
    // crown are outside.
    assert!(sdf.sample(DVec3::ZERO) < -3.0);
    assert!(sdf.sample(DVec3::new(16.0, 0.0, 0.0)) > 3.0);
    assert!(sdf.sample(DVec3::new(0.0, 14.0, 0.0)) > 0.5);
}

/// Every pore lies on the scalp. The groups are opened to the whole head (no polar range,
/// no hairline) so only the scalp regions restrict them, and the regions are checked here
/// from their definition (zenith about the centre <= 118 degrees, y >= -5), not through
/// `in_scalp`. Each pore is on the SDF's zero level set and within a cell of the mesh.
#[test]
fn pores_lie_on_the_scalp() {
    let mut scene = mesh_scene();
    for g in scene.groups_mut() {
        g.roots.theta = (0.0, 180.0);
        g.roots.phi = (-180.0, 180.0);
        g.roots.hairline = None;
    }
    let m = data(&scene);
    let input = prepare(&scene).unwrap();
    let center = DVec3::from(scene.head.center);
    let mut worst_level = 0.0f64;
    let mut lowest = f64::MAX;
    for (i, r) in input.roots.iter().enumerate().step_by(7) {
        worst_level = worst_level.max(m.sdf.sample(r.pos).abs());
        let d = m
            .mesh
            .triangles
            .iter()
            .map(|tri| {
                let [a, b, c] = tri.map(|v| m.mesh.positions[v as usize]);
                triangle_distance(r.pos, a, b, c)
            })
            .fold(f64::MAX, f64::min);
        assert!(d < 0.25 * m.sdf.cell, "pore {i} is {d:.3} from the mesh");
        // Scalp triangles are chosen by their centroid: a pore may lie up to a triangle's
        // size (about 1.2 cm on this mesh) beyond the regions' boundary.
        let q = r.pos - center;
        let zenith = (q.y / q.length()).acos().to_degrees();
        assert!(
            zenith <= 118.0 + 8.0,
            "pore {i} at {} has zenith {zenith:.1}",
            r.pos
        );
        assert!(
            r.pos.y >= -5.0 - 1.2,
            "pore {i} at {} below the scalp",
            r.pos
        );
        lowest = lowest.min(r.pos.y);
        assert!(r.dir.is_normalized());
    }
    println!("pores: largest |SDF| at a pore {worst_level:.2e}, lowest pore y {lowest:.2}");
    assert!(
        worst_level < 1e-3,
        "a pore is {worst_level:.2e} off the zero level set"
    );
}

fn few(mut scene: kami::Scene, div: u32) -> kami::Scene {
    for g in scene.groups_mut() {
        g.count = (g.count / div).max(1);
    }
    scene
}

/// Largest depth below the zero level set over nodes 1.. (roots are on it), with the head at
/// `pose`.
fn deepest(m: &HeadMeshData, nodes: &[DVec3], offsets: &[u32], pose: DMat4) -> f64 {
    let inv = pose.inverse();
    let mut worst = 0.0f64;
    for s in 0..offsets.len() - 1 {
        for i in offsets[s] + 1..offsets[s + 1] {
            let p = inv.transform_point3(nodes[i as usize]);
            worst = worst.max(-m.sdf.sample(p));
        }
    }
    worst
}

/// The cantilever kernel on the mesh head against the f64 reference: every strand within
/// 1e-3 of its length (measured worst printed), 99 % within 1e-4; no node (GPU or CPU) below
/// the zero level set by more than 1e-3 (CPU) / 2e-3 (GPU, f32 positions near 15 cm).
#[test]
fn cantilever_on_mesh_head_matches_reference_and_stays_outside() {
    let gpu = common::gpu();
    let scene = few(mesh_scene(), 8);
    let m = data(&scene);
    let input = prepare(&scene).unwrap();
    let reference = cantilever::bend_all(&input);
    let hair = cantilever_gpu::groom_gpu(gpu, &common::groom_world(gpu, &input), &input).unwrap();
    let verts = hair.read_vertices(gpu).unwrap();
    let offsets = input.vertex_offsets();
    let mut errs = Vec::new();
    for (i, r) in input.roots.iter().enumerate() {
        let len = r.seg_len * input.groups[r.group as usize].segments as f64;
        let e = (offsets[i]..offsets[i + 1])
            .map(|v| {
                let p = verts[v as usize];
                (DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) - reference.nodes[v as usize])
                    .length()
                    / len
            })
            .fold(0.0, f64::max);
        errs.push(e);
    }
    errs.sort_by(f64::total_cmp);
    let n = errs.len();
    let gpu_nodes: Vec<DVec3> = verts
        .iter()
        .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .collect();
    let cpu_depth = deepest(&m, &reference.nodes, &offsets, DMat4::IDENTITY);
    let gpu_depth = deepest(&m, &gpu_nodes, &offsets, DMat4::IDENTITY);
    println!(
        "cantilever on the mesh head, {n} strands: median {:.2e}, 99% {:.2e}, worst {:.2e} of the length; deepest node CPU {cpu_depth:.2e}, GPU {gpu_depth:.2e}",
        errs[n / 2],
        errs[(n - 1) * 99 / 100],
        errs[n - 1]
    );
    assert!(
        cpu_depth < 1e-3,
        "a CPU node is {cpu_depth:.2e} inside the head"
    );
    assert!(
        gpu_depth < 2e-3,
        "a GPU node is {gpu_depth:.2e} inside the head"
    );
    assert!(
        errs[(n - 1) * 99 / 100] < 1e-4,
        "99% {:.2e}",
        errs[(n - 1) * 99 / 100]
    );
    assert!(errs[n - 1] < 1e-3, "worst strand {:.2e}", errs[n - 1]);
}

/// The hard case: a gust twice the scene's straight into the face for 12 frames, then down.
/// The projective kernel against the f64 reference: after one frame every strand within
/// 1e-3 of its length; after 20 frames the median within 1e-4, at most 10 % of strands
/// beyond 1e-2 and none beyond 0.5 (measured: 13 of 200 beyond 1e-2, worst 0.22 — looser
/// than the ellipsoid's 2 % and 5e-2 in tests/it/contract.rs: hair sliding over the SDF meets
/// its trilinear gradient's jumps at cell faces, where f32 and f64 can take different
/// push-out planes and pseudo-force decisions, and the strands then part ways). No node of
/// either inside the head by more than 1e-3 (CPU, every frame) / 2e-3 (GPU, every 5th).
#[test]
fn projective_on_mesh_head_matches_reference_and_stays_outside() {
    let gpu = common::gpu();
    let mut scene = few(mesh_scene(), 20);
    let dy = &mut scene.forces;
    dy.wind = vec![
        kami::scene::WindKey {
            frame: 0.0,
            force: [-400.0, 0.0, 0.0],
            interp: Default::default(),
        },
        kami::scene::WindKey {
            frame: 12.0,
            force: [-40.0, -400.0, 0.0],
            interp: Default::default(),
        },
    ];

    let m = data(&scene);
    let input = prepare(&scene).unwrap();
    let groomed = cantilever::bend_all(&input);
    let (hair, mut sim) = common::gpu_simulation(gpu, &scene, &input);
    let mut cpu = CpuSim::new(
        DynSetup::new(&scene, &input, &groomed.visible).unwrap(),
        groomed.nodes.clone(),
    );
    let offsets = input.vertex_offsets();
    let (mut cpu_depth, mut gpu_depth) = (0.0f64, 0.0f64);
    let rel_err =
        |v: &[[f32; 4]], cpu: &CpuSim| -> Vec<f64> { common::strand_errors(&input, v, &cpu.nodes) };
    for f in 0..20 {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        sim.record_frame(gpu, &mut enc, &hair).unwrap();
        gpu.queue.submit([enc.finish()]);
        cpu.frame();
        cpu_depth = cpu_depth.max(deepest(&m, &cpu.nodes, &offsets, DMat4::IDENTITY));
        if f == 0 {
            // One frame (10 steps) in, before contact chatter can amplify f32 rounding.
            let first = rel_err(&hair.read_vertices(gpu).unwrap(), &cpu);
            let worst = first[first.len() - 1];
            println!("after frame 1: worst strand {worst:.2e} of its length");
            assert!(
                worst < 1e-3,
                "after frame 1 a strand differs by {worst:.2e}"
            );
        }
        if f % 5 == 4 {
            let v = hair.read_vertices(gpu).unwrap();
            let nodes: Vec<DVec3> = v
                .iter()
                .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
                .collect();
            gpu_depth = gpu_depth.max(deepest(&m, &nodes, &offsets, DMat4::IDENTITY));
        }
    }
    let errs = rel_err(&hair.read_vertices(gpu).unwrap(), &cpu);
    let n = errs.len();
    let beyond = errs.iter().filter(|&&e| e > 1e-2).count();
    println!("{beyond} of {n} strands beyond 1e-2 of their length");
    println!(
        "projective on the mesh head, {n} strands, 20 frames of a gust into the face: median {:.2e}, 99% {:.2e}, worst {:.2e} of the length; deepest node CPU {cpu_depth:.2e}, GPU {gpu_depth:.2e}",
        errs[n / 2],
        errs[(n - 1) * 99 / 100],
        errs[n - 1]
    );
    assert!(errs[n / 2] < 1e-4, "median {:.2e}", errs[n / 2]);
    assert!(beyond * 10 <= n, "{beyond} of {n} strands beyond 1e-2");
    assert!(errs[n - 1] < 0.5, "worst strand {:.2e}", errs[n - 1]);
    assert!(
        cpu_depth < 1e-3,
        "a CPU node went {cpu_depth:.2e} into the head"
    );
    assert!(
        gpu_depth < 2e-3,
        "a GPU node went {gpu_depth:.2e} into the head"
    );
}

/// A missing mesh file is an error naming it; bad numbers and a scalp that holds no
/// triangle are errors naming the field.
#[test]
fn bad_mesh_head_input_is_a_clear_error() {
    use kami::scene::{MeshSource, ScalpRegion};
    let mut scene = mesh_scene();
    scene.head.mesh.as_mut().unwrap().source = MeshSource::File("/nonexistent/head.obj".into());
    let e = prepare(&scene).unwrap_err().to_string();
    assert!(e.contains("/nonexistent/head.obj"), "{e}");

    let mut scene = mesh_scene();
    scene.head.mesh.as_mut().unwrap().scalp = vec![ScalpRegion::Sphere {
        center: [100.0, 0.0, 0.0],
        radius: 1.0,
    }];
    let e = prepare(&scene).unwrap_err().to_string();
    assert!(e.contains("head.mesh.scalp"), "{e}");

    for (edit, field) in [
        (
            Box::new(|m: &mut kami::scene::HeadMesh| m.resolution = 4)
                as Box<dyn Fn(&mut kami::scene::HeadMesh)>,
            "head.mesh.resolution",
        ),
        (Box::new(|m| m.scale = 0.0), "head.mesh.scale"),
        (
            Box::new(|m| m.translate[1] = f64::NAN),
            "head.mesh.translate[1]",
        ),
        (
            Box::new(|m| {
                m.scalp = vec![ScalpRegion::Polar {
                    theta: (90.0, 10.0),
                    phi: (0.0, 90.0),
                }]
            }),
            "head.mesh.scalp[0].theta",
        ),
        (
            Box::new(|m| {
                m.scalp = vec![ScalpRegion::Sphere {
                    center: [0.0; 3],
                    radius: -1.0,
                }]
            }),
            "head.mesh.scalp[0].radius",
        ),
        (
            Box::new(|m| m.source = MeshSource::CgalDemo("../head.off".into())),
            "head.mesh.source",
        ),
    ] {
        let mut scene = mesh_scene();
        edit(scene.head.mesh.as_mut().unwrap());
        let e = kami::systems::validate(&scene).unwrap_err().to_string();
        assert!(e.contains(field), "{field}: {e}");
    }
}

/// The shipped scene at frame 12 of its gust (a quarter of its hairs). Tolerance: that of
/// tests/it/snapshot.rs (mean 0.25 of 255, 0.2 % of pixels off by more than 24).
#[test]
fn mesh_head_frame_12_snapshot() {
    let gpu = common::gpu();
    let scene = few(mesh_scene(), 4);
    kami::stage::render_animation(gpu, &scene, (256, 256), 12..=12, |_, img| {
        check_snapshot(
            "mesh_head_frame_12",
            &img,
            Tolerance {
                mean: 0.25,
                threshold: 24,
                share: 0.002,
            },
        );
        Ok(())
    })
    .unwrap();
}

/// A head mesh replaced on disk is read again when the scene is opened again (the cache is
/// keyed by the file's size and time, not only its path): a sphere of radius 9 becomes one
/// of radius 12, and the field at the centre follows.
#[test]
fn a_replaced_mesh_file_is_read_again() {
    let dir = std::env::temp_dir().join(format!("kami-mesh-again-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("ball.off");
    let write = |r: f64, rings: u32| {
        let (p, t) = common::uv_sphere(DVec3::ZERO, r, rings, 2 * rings);
        std::fs::write(&path, common::off_text(&p, &t)).unwrap();
    };
    write(9.0, 12);
    let mut scene = mesh_scene();
    let m = scene.head.mesh.as_mut().unwrap();
    m.source = kami::scene::MeshSource::File(path.display().to_string());
    m.scale = 1.0;
    m.rotate = [0.0; 3];
    m.translate = [0.0; 3];
    m.scalp.clear();
    m.resolution = 16;
    let first = data(&scene).sdf.sample(DVec3::ZERO);
    write(12.0, 16);
    let second = data(&scene).sdf.sample(DVec3::ZERO);
    assert!(
        first < -8.0 && second < first - 2.5,
        "the field at the centre: {first:.2} then {second:.2}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
