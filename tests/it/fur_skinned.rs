//! Fur on skinned, animated glTF meshes: loading (Debian's assimp `simple_skin.gltf`, read at
//! run time), linear blend skinning against a hand computation, the GPU generator against
//! its f64 reference on the skinned creature, roots that ride the skinned triangles,
//! malformed files refused with errors naming them, and a snapshot of `fur_creature`.

use crate::common;

use common::{check_snapshot, Tolerance};
use glam::DVec3;
use kami::scene::skinned::{self, Channel, Interpolation, Property};
use kami::scene::MeshSource;
use kami::systems::fur::block::Fur;
use kami::systems::fur::setup::{hair_points, FurSetup, TABLE};
use std::path::{Path, PathBuf};

/// From Debian's `assimp-testmodels` (apt-get install assimp-testmodels).
const SIMPLE_SKIN: &str = "/usr/share/assimp/models/glTF2/simple_skin/simple_skin.gltf";

fn simple_skin() -> &'static Path {
    let p = Path::new(SIMPLE_SKIN);
    assert!(
        p.exists(),
        "{SIMPLE_SKIN} is missing: apt-get install -y assimp-testmodels"
    );
    p
}

fn creature_fur(hairs: u32) -> Fur {
    let mut f = common::scene("fur_creature")
        .fur()
        .clone()
        .expect("a fur scene");
    f.hairs = hairs;
    f
}

#[test]
fn simple_skin_loads_with_its_joints_and_animation() {
    let s = skinned::load(simple_skin(), None, 24.0).unwrap();
    assert_eq!(s.mesh.positions.len(), 10);
    assert_eq!(s.mesh.triangles.len(), 8);
    assert_eq!(s.skin.joint_nodes, vec![1, 2]);
    let a = s.skin.animation.as_ref().expect("an animation");
    assert_eq!(a.duration, 5.5);
    assert_eq!(a.channels.len(), 1);
    assert_eq!(a.channels[0].property, Property::Rotation);
    assert_eq!(a.channels[0].interpolation, Interpolation::Linear);
    // Frames loop over the duration: 5.5 s at 24 fps is 132 frames.
    assert!((s.skin.seconds(24.0 * 1.25) - 1.25).abs() < 1e-12);
    assert!((s.skin.seconds(132.0 + 12.0) - 0.5).abs() < 1e-12);
}

/// At 1 s, joint 1 (node 2) is turned 90 degrees about z (key 2 of the file). By hand, with
/// both inverse bind matrices T(-0.5, -1, 0) and node 1 at T(0, 1, 0):
/// M0 = T(-0.5, 0, 0), M1 = T(0, 1, 0) Rz(90) T(-0.5, -1, 0).
/// Vertex 4 (0, 1, 0), weights 1/2, 1/2: M0 p = (-0.5, 1, 0), M1 p = (0, 0.5, 0) ->
/// (-0.25, 0.75, 0). Vertex 9 (1, 2, 0), weight 1 on joint 1: (-1, 1.5, 0). Vertex 0
/// (0, 0, 0), weight 1 on joint 0: (-0.5, 0, 0).
#[test]
fn skinned_vertices_match_a_hand_computation() {
    let s = skinned::load(simple_skin(), None, 24.0).unwrap();
    let mats = s.skin.joint_matrices(24.0);
    let at = |v: usize| {
        s.skin
            .skin_vertex(&mats, v, s.mesh.positions[v], s.mesh.normals[v])
            .0
    };
    // The file's quaternion (0, 0, 0.707, 0.707) is 90 degrees to its 3 digits.
    let cases = [
        (4, DVec3::new(-0.25, 0.75, 0.0)),
        (9, DVec3::new(-1.0, 1.5, 0.0)),
        (0, DVec3::new(-0.5, 0.0, 0.0)),
        (8, DVec3::new(-1.0, 0.5, 0.0)),
    ];
    for (v, want) in cases {
        let got = at(v);
        assert!(
            (got - want).length() < 1e-6,
            "vertex {v}: {got} instead of {want}"
        );
    }
    // Normals stay unit and perpendicular to the plane the strip stays in.
    let n = s
        .skin
        .skin_vertex(&mats, 9, s.mesh.positions[9], s.mesh.normals[9])
        .1;
    assert!((n.length() - 1.0).abs() < 1e-12 && n.z.abs() > 0.999999);
}

#[test]
fn step_linear_and_cubic_channels_sample_as_the_spec_says() {
    let key = |x: f64| glam::DVec4::new(x, 0.0, 0.0, 0.0);
    let mut c = Channel {
        node: 0,
        property: Property::Translation,
        interpolation: Interpolation::Linear,
        times: vec![1.0, 3.0],
        values: vec![key(2.0), key(6.0)],
    };
    assert_eq!(c.sample(2.5).x, 5.0);
    assert_eq!(c.sample(0.0).x, 2.0);
    assert_eq!(c.sample(9.0).x, 6.0);
    c.interpolation = Interpolation::Step;
    assert_eq!(c.sample(2.9).x, 2.0);
    // Cubic Hermite with tangents matching the line through the keys (slope 2 per second)
    // is the line.
    c.interpolation = Interpolation::CubicSpline;
    c.values = vec![key(2.0), key(2.0), key(2.0), key(2.0), key(6.0), key(2.0)];
    assert!((c.sample(2.5).x - 5.0).abs() < 1e-12);
}

/// Each drawn hair at `frame` (no culling), flat: (coat, triangle, creation index, nodes).
fn gpu_hairs(
    gpu: &kami::gpu::Gpu,
    setup: &FurSetup,
    frame: f64,
) -> Vec<(usize, usize, u32, Vec<DVec3>)> {
    common::gpu_hairs(gpu, setup, frame, 1.0)
        .into_iter()
        .enumerate()
        .flat_map(|(ci, coat)| coat.into_iter().map(move |(t, h, hp)| (ci, t, h, hp.nodes)))
        .collect()
}

/// The GPU's hairs on the skinned creature against the f64 reference (`hair_points`, which
/// skins with f64 joint matrices), between animation keys.
#[test]
fn gpu_skinned_fur_matches_the_reference() {
    let gpu = common::gpu();
    let setup = FurSetup::new(&creature_fur(6_000), 3).unwrap();
    assert!(setup.skin.is_some());
    for frame in [0.0, 17.3, 31.0] {
        let hairs = gpu_hairs(gpu, &setup, frame);
        assert!(hairs.len() > 5_000, "only {} hairs", hairs.len());
        let mut worst = 0.0f64;
        for (ci, t, h, got) in &hairs {
            let want = hair_points(&setup, *ci, *t, *h, frame);
            assert_eq!(got.len(), want.nodes.len());
            for (a, b) in got.iter().zip(&want.nodes) {
                worst = worst.max((*a - *b).length());
            }
        }
        eprintln!(
            "frame {frame}: {} hairs, worst node {worst:.2e}",
            hairs.len()
        );
        // f32 against f64 on a creature of radius 1 with hairs up to 0.2: 1e-5 of its size.
        assert!(
            worst < 1e-5,
            "frame {frame}: a node is {worst:.2e} from the reference"
        );
    }
}

/// Van Gelder 3.2: a root is a fixed barycentric point of its triangle, so at frame 20 every
/// GPU root is that point of the skinned triangle (skinned here with f64 joint matrices),
/// and the skin has moved.
#[test]
fn fur_rides_the_skinned_triangles() {
    let gpu = common::gpu();
    let s = FurSetup::new(&creature_fur(3_000), 5).unwrap();
    let skin = s.skin.as_ref().unwrap();
    let root_at = |t: usize, h: u32, frame: f64| {
        let mats = skin.joint_matrices(frame);
        let [b1, b2] = s.table[h as usize % TABLE];
        let bary = [b1, b2, 1.0 - b1 - b2];
        (0..3)
            .map(|k| {
                let v = s.mesh.triangles[t][k] as usize;
                bary[k]
                    * skin
                        .skin_vertex(&mats, v, s.mesh.positions[v], s.mesh.normals[v])
                        .0
            })
            .sum::<DVec3>()
    };
    let rest = gpu_hairs(gpu, &s, 0.0);
    let moved = gpu_hairs(gpu, &s, 20.0);
    assert_eq!(rest.len(), moved.len());
    let (mut worst, mut largest_move) = (0.0f64, 0.0f64);
    for ((c0, t0, h0, a), (c1, t1, h1, b)) in rest.iter().zip(&moved) {
        assert_eq!(
            (c0, t0, h0),
            (c1, t1, h1),
            "the same hairs in the same slots"
        );
        worst = worst.max((a[0] - root_at(*t0, *h0, 0.0)).length());
        worst = worst.max((b[0] - root_at(*t0, *h0, 20.0)).length());
        largest_move = largest_move.max((b[0] - a[0]).length());
    }
    eprintln!("roots: worst {worst:.2e}, largest move {largest_move:.3}");
    assert!(
        worst < 1e-5,
        "a root is {worst:.2e} off its skinned triangle"
    );
    assert!(largest_move > 0.2, "the skin barely moved: {largest_move}");
}

/// A one-triangle skinned glTF with an external buffer, to break on purpose.
fn tiny(dir: &Path, name: &str, weights: [f32; 4], joint: u16, attributes: &str) -> PathBuf {
    let mut bin: Vec<u8> = Vec::new();
    for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        bin.extend(p.iter().flat_map(|x| x.to_le_bytes()));
    }
    for _ in 0..3 {
        bin.extend([joint, 0, 0, 0].iter().flat_map(|x| x.to_le_bytes()));
    }
    for _ in 0..3 {
        bin.extend(weights.iter().flat_map(|x| x.to_le_bytes()));
    }
    std::fs::write(dir.join(format!("{name}.bin")), &bin).unwrap();
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0, "skin": 0}}, {{"name": "joint"}}],
  "meshes": [{{"primitives": [{{"attributes": {{{attributes}}}}}]}}],
  "skins": [{{"joints": [1]}}],
  "buffers": [{{"uri": "{name}.bin", "byteLength": {}}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 36}},
    {{"buffer": 0, "byteOffset": 36, "byteLength": 24}},
    {{"buffer": 0, "byteOffset": 60, "byteLength": 48}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5123, "count": 3, "type": "VEC4"}},
    {{"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC4"}}]}}"#,
        bin.len()
    );
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, json).unwrap();
    path
}

#[test]
fn malformed_gltf_is_refused_with_the_file_named() {
    let dir = std::env::temp_dir().join(format!("kami-gltf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let all = r#""POSITION": 0, "JOINTS_0": 1, "WEIGHTS_0": 2"#;
    // The well-formed one loads.
    let good = tiny(&dir, "good", [1.0, 0.0, 0.0, 0.0], 0, all);
    let m = skinned::load(&good, None, 24.0).unwrap();
    assert_eq!(m.skin.weights[0], [1.0, 0.0, 0.0, 0.0]);
    let cases = [
        (
            tiny(
                &dir,
                "no_weights",
                [1.0, 0.0, 0.0, 0.0],
                0,
                r#""POSITION": 0, "JOINTS_0": 1"#,
            ),
            "no usable WEIGHTS_0",
        ),
        (
            tiny(
                &dir,
                "no_accessor",
                [1.0, 0.0, 0.0, 0.0],
                0,
                r#""POSITION": 7, "JOINTS_0": 1, "WEIGHTS_0": 2"#,
            ),
            "not usable glTF",
        ),
        (
            tiny(&dir, "joint_range", [1.0, 0.0, 0.0, 0.0], 3, all),
            "uses joint 3, but the skin has 1 joints",
        ),
        (
            tiny(&dir, "nan_weight", [f32::NAN, 0.0, 0.0, 0.0], 0, all),
            "must be finite",
        ),
        (
            tiny(&dir, "inf_weight", [1.0, f32::INFINITY, 0.0, 0.0], 0, all),
            "must be finite",
        ),
        (
            tiny(&dir, "zero_weight", [0.0; 4], 0, all),
            "has no joint weight",
        ),
        (dir.join("absent.gltf"), "not usable glTF"),
    ];
    for (path, want) in &cases {
        let e = skinned::load(path, None, 24.0)
            .expect_err(&format!("{} should be refused", path.display()))
            .to_string();
        let name = path.file_name().unwrap().to_str().unwrap();
        assert!(e.contains(name), "{e:?} does not name {name}");
        assert!(e.contains(want), "{e:?} does not say {want:?}");
    }
    // An unknown animation name lists the ones there are.
    let e = skinned::load(simple_skin(), Some("walk"), 24.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no animation named \"walk\""), "{e}");
    // The scene path: a fur block naming a bad file fails to build, no panic.
    let mut f = creature_fur(100);
    f.mesh = MeshSource::Gltf {
        file: cases[3].0.display().to_string(),
        animation: None,
        fps: 24.0,
    };
    assert!(FurSetup::new(&f, 1).is_err());
    std::fs::remove_dir_all(&dir).ok();
}

/// fur_creature mid-stride (frame 12, a quarter of the loop), half its hairs. Tolerance as
/// tests/it/snapshot.rs: mean |difference| 0.25 of 255, at most 0.2% of pixels off by more
/// than 24.
#[test]
fn fur_creature_frame_12() {
    let gpu = common::gpu();
    let mut scene = common::scene("fur_creature");
    if let Some(f) = scene.fur_mut().as_mut() {
        f.hairs /= 2;
    }
    let tol = Tolerance {
        mean: 0.25,
        threshold: 24,
        share: 0.002,
    };
    kami::stage::render_animation(gpu, &scene, (256, 256), 12..=12, |_, img| {
        check_snapshot("fur_creature_12", &img, tol);
        Ok(())
    })
    .unwrap();
}

/// The scene's `size` fits the rest mesh; the skinned pose must scale with it (the joint
/// matrices are conjugated by the fit): the creature fitted to radius 3 is the one fitted to
/// radius 1, three times larger, in every pose.
#[test]
fn fitting_scales_the_skinned_pose() {
    let mut f = creature_fur(200);
    let one = FurSetup::new(&f, 1).unwrap();
    f.size = Some(3.0);
    let three = FurSetup::new(&f, 1).unwrap();
    for frame in [0.0, 9.5, 40.0] {
        let (m1, m3) = (one.joint_matrices(frame), three.joint_matrices(frame));
        for v in (0..one.mesh.positions.len()).step_by(7) {
            let a = one.vertex_at(v, frame, m1.as_deref()).0;
            let b = three.vertex_at(v, frame, m3.as_deref()).0;
            assert!(
                (b - 3.0 * a).length() < 1e-9,
                "frame {frame} vertex {v}: {b} vs 3 x {a}"
            );
        }
    }
}
