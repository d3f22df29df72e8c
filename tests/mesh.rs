//! Mesh loading for fur: OBJ, OFF and PLY, normals computed where missing, awkward but valid
//! meshes accepted, malformed files refused with the place they broke (never a panic).

use glam::DVec3;
use kami::error::KamiError;
use kami::scene::mesh::Mesh;

/// A unit cube as text in each format, outward-facing triangles, no normals.
const CUBE_V: [[f64; 3]; 8] = [
    [0., 0., 0.],
    [1., 0., 0.],
    [1., 1., 0.],
    [0., 1., 0.],
    [0., 0., 1.],
    [1., 0., 1.],
    [1., 1., 1.],
    [0., 1., 1.],
];
/// Quads, counter-clockwise seen from outside.
const CUBE_F: [[u32; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [2, 3, 7, 6],
    [1, 2, 6, 5],
    [0, 4, 7, 3],
];

fn cube_obj() -> String {
    let mut s = String::from("# cube\no cube\n");
    for v in CUBE_V {
        s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    for f in CUBE_F {
        s += &format!("f {} {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1, f[3] + 1);
    }
    s
}

fn cube_off() -> String {
    let mut s = String::from("OFF\n# a comment\n8 6 12\n");
    for v in CUBE_V {
        s += &format!("{} {} {}\n", v[0], v[1], v[2]);
    }
    for f in CUBE_F {
        s += &format!("4 {} {} {} {}\n", f[0], f[1], f[2], f[3]);
    }
    s
}

fn cube_ply_ascii() -> String {
    let mut s = String::from(
        "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n\
         property float z\nelement face 6\nproperty list uchar int vertex_indices\nend_header\n",
    );
    for v in CUBE_V {
        s += &format!("{} {} {}\n", v[0], v[1], v[2]);
    }
    for f in CUBE_F {
        s += &format!("4 {} {} {} {}\n", f[0], f[1], f[2], f[3]);
    }
    s
}

fn cube_ply_binary() -> Vec<u8> {
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 8\nproperty float x\n\
property float y\nproperty float z\nelement face 6\nproperty list uchar uint vertex_indices\n\
end_header\n"
        .to_vec();
    for v in CUBE_V {
        for c in v {
            b.extend_from_slice(&(c as f32).to_le_bytes());
        }
    }
    for f in CUBE_F {
        b.push(4);
        for i in f {
            b.extend_from_slice(&i.to_le_bytes());
        }
    }
    b
}

/// Every normal of the cube points away from its centre and the surface area is 6.
fn check_cube(m: &Mesh) {
    assert_eq!(m.positions.len(), 8);
    assert_eq!(m.triangles.len(), 12, "quads are split into two triangles");
    let area: f64 = (0..m.triangles.len()).map(|t| m.area(t)).sum();
    assert!((area - 6.0).abs() < 1e-9, "area {area}");
    let c = DVec3::splat(0.5);
    for (p, n) in m.positions.iter().zip(&m.normals) {
        assert!((n.length() - 1.0).abs() < 1e-9);
        // A corner's area-weighted normal leans towards the diagonal (how far depends on
        // how the faces were split).
        let d = *p - c;
        assert!(n.dot(d.normalize()) > 0.9, "normal {n} at {p}");
        assert!((0..3).all(|k| n[k] * d[k] > 0.0), "normal {n} at {p}");
    }
}

#[test]
fn cube_loads_the_same_from_every_format() {
    check_cube(&Mesh::from_obj(&cube_obj(), "cube.obj").unwrap());
    check_cube(&Mesh::from_off(&cube_off(), "cube.off").unwrap());
    check_cube(&Mesh::from_ply(cube_ply_ascii().as_bytes(), "cube.ply").unwrap());
    check_cube(&Mesh::from_ply(&cube_ply_binary(), "cube.ply").unwrap());
}

#[test]
fn load_picks_the_format_by_extension() {
    let dir = std::env::temp_dir().join(format!("kami-mesh-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, bytes) in [
        ("c.obj", cube_obj().into_bytes()),
        ("c.OFF", cube_off().into_bytes()),
        ("c.ply", cube_ply_binary()),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        check_cube(&Mesh::load(&p).unwrap());
    }
    let p = dir.join("c.stl");
    std::fs::write(&p, "solid").unwrap();
    let e = Mesh::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("unknown mesh format") && e.contains(".obj"),
        "{e}"
    );
    let e = Mesh::load(dir.join("missing.obj")).unwrap_err().to_string();
    assert!(e.contains("missing.obj"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn normals_from_the_file_are_kept_and_normalised() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 2\nvn 0 0 2\nvn 0 0 2\nf 1//1 2//2 3//3\n";
    let m = Mesh::from_obj(obj, "t.obj").unwrap();
    assert!(m.normals.iter().all(|n| (*n - DVec3::Z).length() < 1e-12));
    // Flipped winding with file normals: the file wins.
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\nf 1//1 3//3 2//2\n";
    let m = Mesh::from_obj(obj, "t.obj").unwrap();
    assert!(m.normals.iter().all(|n| n.z > 0.99));
    // Without normals, the winding decides.
    let m = Mesh::from_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 3 2\n", "t.obj").unwrap();
    assert!(m.normals.iter().all(|n| n.z < -0.99));
}

#[test]
fn awkward_meshes_are_accepted() {
    // Triangle 1 is degenerate (repeated vertex), triangle 2 has zero area (collinear),
    // vertex 6 is unreferenced and far away, and the edge 0-1 is shared by three triangles
    // (non-manifold).
    let off = "OFF\n7 5 0\n\
               0 0 0\n1 0 0\n0 1 0\n0 0 1\n2 0 0\n0 -1 0\n100 100 100\n\
               3 0 1 2\n3 0 0 1\n3 0 1 4\n3 0 1 3\n3 0 1 5\n";
    let m = Mesh::from_off(off, "awkward.off").unwrap();
    assert_eq!(m.triangles.len(), 5);
    assert!(m
        .normals
        .iter()
        .all(|n| n.is_finite() && (n.length() - 1.0).abs() < 1e-9));
    assert_eq!(m.area(1), 0.0);
    assert_eq!(m.area(2), 0.0);
    // The unreferenced vertex does not count in the bounds.
    let (c, r) = m.bounds();
    assert!(r < 2.0 && c.length() < 2.0, "bounds {c} {r}");
    // Fur on it: hairs only on the triangles with area.
    let fur = kami::scene::fur::Fur {
        mesh: kami::scene::fur::MeshSource::Critter,
        size: None,
        hairs: 3000,
        length: 0.1,
        regions: vec![],
        direction: [-1.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        coats: vec![coat()],
        culling: Default::default(),
        motion: None,
        skin: [0.5; 3],
    };
    let setup = kami::systems::fur::setup::FurSetup::from_mesh(&fur, m, 1).unwrap();
    let a = &setup.coats[0];
    assert_eq!(a.count[1], 0);
    assert_eq!(a.count[2], 0);
    assert!(a.count[0] > 0 && a.count[3] > 0 && a.count[4] > 0);
}

pub fn coat() -> kami::scene::fur::Coat {
    kami::scene::fur::Coat {
        name: "c".into(),
        share: 1.0,
        relative_length: 1.0,
        stiffness: 0.5,
        normal_randomize: 0.0,
        end_randomize: 0.0,
        direction_weight: 0.0,
        style: Default::default(),
        material: Default::default(),
    }
}

/// The error names the file and the line.
fn broken(result: kami::error::Result<Mesh>, line: Option<usize>, words: &[&str]) {
    let l = refused(result, words);
    assert_eq!(l, line, "wrong line");
}

/// A mesh error that mentions `words`; returns its line.
fn refused(result: kami::error::Result<Mesh>, words: &[&str]) -> Option<usize> {
    let e = result.expect_err("a malformed mesh must be refused");
    let msg = e.to_string();
    for w in words {
        assert!(msg.contains(w), "{msg:?} should mention {w:?}");
    }
    match e {
        KamiError::Mesh { line, .. } => line,
        other => panic!("not a mesh error: {other:?}"),
    }
}

#[test]
fn malformed_obj_is_refused_with_its_line() {
    let name = "bad.obj";
    broken(
        Mesh::from_obj("v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", name),
        Some(2),
        &["bad.obj:2"],
    );
    broken(
        Mesh::from_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 9\n", name),
        Some(5),
        &[name],
    );
    broken(
        Mesh::from_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", name),
        Some(4),
        &[name],
    );
    broken(
        Mesh::from_obj("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", name),
        Some(2),
        &["finite"],
    );
    broken(
        Mesh::from_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\n", name),
        None,
        &["no triangles"],
    );
    broken(Mesh::from_obj("", name), None, &["no triangles"]);
}

#[test]
fn malformed_off_is_refused_with_its_line() {
    let name = "bad.off";
    broken(Mesh::from_off("", name), Some(1), &["empty"]);
    broken(
        Mesh::from_off("PLY\n3 1 0\n", name),
        Some(1),
        &["expected OFF"],
    );
    broken(
        Mesh::from_off("COFF\n3 1 0\n", name),
        Some(1),
        &["not supported"],
    );
    broken(
        Mesh::from_off("OFF\n3 x 0\n", name),
        Some(2),
        &["face count"],
    );
    broken(
        Mesh::from_off("OFF\n3 1 0\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n", name),
        Some(4),
        &["vertex 1", "zero"],
    );
    broken(
        Mesh::from_off("OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n", name),
        Some(4),
        &["finite"],
    );
    broken(
        Mesh::from_off("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", name),
        Some(6),
        &["vertex 3", "there are 3"],
    );
    broken(
        Mesh::from_off("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", name),
        Some(6),
        &["face 0 has 2 vertices"],
    );
    broken(
        Mesh::from_off("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", name),
        None,
        &["ends before face 1"],
    );
    broken(
        Mesh::from_off("OFF\n4000000000 1 0\n", name),
        None,
        &["50 million"],
    );
}

#[test]
fn malformed_ply_is_refused() {
    let name = "bad.ply";
    broken(Mesh::from_ply(b"", name), None, &[name]);
    broken(
        Mesh::from_ply(b"ply\nformat ascii 1.0\nelement vertex 1\nbanana\n", name),
        Some(4),
        &[name, "banana"],
    );
    // A vertex that is not a number.
    let s = cube_ply_ascii().replace("1 1 0\n", "1 x 0\n");
    broken(Mesh::from_ply(s.as_bytes(), name), Some(12), &["1 x 0"]);
    // Header promises more than the body holds.
    let mut b = cube_ply_binary();
    b.truncate(b.len() - 10);
    refused(Mesh::from_ply(&b, name), &[name, "end of file"]);
    // A face that points past the vertices.
    let s = cube_ply_ascii().replace("4 0 3 2 1", "4 0 3 2 8");
    broken(Mesh::from_ply(s.as_bytes(), name), None, &["vertex 8"]);
    // No faces at all.
    let s = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
             property float z\nend_header\n0 0 0\n";
    broken(Mesh::from_ply(s.as_bytes(), name), None, &["face"]);
}

/// A real mesh from a Debian package (`libcgal-demo`, installed by `.ci/run`): the CGAL lion
/// head, open at the neck. It loads, its normals point out, and fur covers it evenly.
#[test]
fn cgal_lion_head_loads_and_takes_fur() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("cgal");
    let path =
        kami::scene::mesh::cgal_demo_mesh("lion-head.off", &dir).unwrap_or_else(|e| panic!("{e}"));
    let m = Mesh::load(&path).unwrap();
    assert_eq!(m.positions.len(), 8356);
    assert_eq!(m.triangles.len(), 16674);
    let (c, _) = m.bounds();
    let outward = m
        .positions
        .iter()
        .zip(&m.normals)
        .filter(|(p, n)| n.dot(**p - c) > 0.0)
        .count();
    assert!(
        outward as f64 > 0.85 * m.positions.len() as f64,
        "only {outward} normals point away from the centre"
    );
    let mut fur = common_fur();
    fur.mesh = kami::scene::fur::MeshSource::CgalDemo("lion-head.off".into());
    fur.size = Some(1.6);
    fur.hairs = 50_000;
    let s = kami::systems::fur::setup::FurSetup::new(&fur, 3).unwrap();
    assert_eq!(s.mesh.triangles.len(), 16674);
    let (_, r) = s.mesh.bounds();
    assert!((r - 1.6).abs() < 1e-9, "fitted radius {r}");
    let total = s.coats[0].total as f64;
    assert!((total - 50_000.0).abs() < 4.5 * 50_000f64.sqrt().max(1.0) / 2.0);
}

fn common_fur() -> kami::scene::fur::Fur {
    kami::scene::fur::Fur {
        mesh: kami::scene::fur::MeshSource::Critter,
        size: None,
        hairs: 1000,
        length: 0.1,
        regions: vec![],
        direction: [-1.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        coats: vec![coat()],
        culling: Default::default(),
        motion: None,
        skin: [0.5; 3],
    }
}

#[test]
fn a_scene_names_its_mesh_relative_to_itself() {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("relative-mesh");
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    std::fs::write(dir.join("meshes/cube.obj"), cube_obj()).unwrap();
    let scene = "Scene(head: Head(visible: false), fur: Some(Fur(mesh: File(\"meshes/cube.obj\"), \
                 hairs: 500, length: 0.1, coats: [Coat(share: 1.0, stiffness: 0.5)])))";
    std::fs::write(dir.join("s.ron"), scene).unwrap();
    let s = kami::Scene::load(dir.join("s.ron")).unwrap();
    let setup = kami::systems::fur::setup::FurSetup::new(s.fur.as_ref().unwrap(), 1).unwrap();
    check_cube(&setup.mesh);
    // A missing mesh names the file.
    std::fs::write(dir.join("t.ron"), scene.replace("cube.obj", "gone.obj")).unwrap();
    let s = kami::Scene::load(dir.join("t.ron")).unwrap();
    let e = kami::systems::fur::setup::FurSetup::new(s.fur.as_ref().unwrap(), 1)
        .unwrap_err()
        .to_string();
    assert!(e.contains("gone.obj"), "{e}");
}

#[test]
fn bad_mesh_sources_are_refused_when_the_scene_loads() {
    for (mesh, words) in [
        ("File(\"\")", "must name"),
        ("CgalDemo(\"../etc/passwd\")", "file name"),
        ("CgalDemo(\"\")", "file name"),
    ] {
        let scene = format!(
            "Scene(fur: Some(Fur(mesh: {mesh}, hairs: 5, length: 0.1, \
             coats: [Coat(share: 1.0, stiffness: 0.5)])))"
        );
        let e = kami::Scene::from_ron(&scene, "bad.ron")
            .unwrap_err()
            .to_string();
        assert!(e.contains("fur.mesh") && e.contains(words), "{e}");
    }
    // A CGAL mesh that does not exist.
    let mut fur = common_fur();
    fur.mesh = kami::scene::fur::MeshSource::CgalDemo("no-such-mesh.off".into());
    let e = kami::systems::fur::setup::FurSetup::new(&fur, 1)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no-such-mesh.off"), "{e}");
}
