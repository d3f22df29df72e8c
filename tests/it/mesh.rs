//! Mesh loading for fur: OBJ, OFF and PLY, normals computed where missing, awkward but valid
//! meshes accepted, malformed files refused with the place they broke (never a panic).

use crate::common;

use common::{largest_allocation, off_text as off, uv_sphere as sphere};
use glam::DVec3;
use kami::error::KamiError;
use kami::scene::mesh::{vertex_normals, Mesh};
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
    let fur = kami::systems::fur::block::Fur {
        mesh: kami::scene::MeshSource::Critter,
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

pub fn coat() -> kami::systems::fur::block::Coat {
    kami::systems::fur::block::Coat {
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

/// A PLY whose header holds a free-text line (Blender 2.47's exporter wrote "Created by
/// Blender3D 247 ..."; assimp reads such files) loads the same cube, ascii and binary, with a
/// warning naming the line; later errors still name their own lines. A header that never
/// ends is still refused.
#[test]
fn free_text_in_a_ply_header_is_read_as_a_comment() {
    const FREE: &str = "Created by Blender3D 247 - www.blender.org, source file: 'cube.blend'\n";
    let ascii = cube_ply_ascii().replacen(
        "format ascii 1.0\n",
        &format!("format ascii 1.0\n{FREE}"),
        1,
    );
    let (m, warned) = common::warnings(|| Mesh::from_ply(ascii.as_bytes(), "blender.ply"));
    check_cube(&m.unwrap());
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert!(
        warned[0].starts_with("blender.ply: header line 3 is not a PLY keyword"),
        "{warned:?}"
    );
    let bin = cube_ply_binary();
    let at = bin.windows(2).position(|w| w == b"\ne").unwrap() + 1;
    let mut with_free = bin[..at].to_vec();
    with_free.extend_from_slice(FREE.as_bytes());
    with_free.extend_from_slice(&bin[at..]);
    let (m, warned) = common::warnings(|| Mesh::from_ply(&with_free, "blender_bin.ply"));
    check_cube(&m.unwrap());
    assert_eq!(warned.len(), 1, "{warned:?}");
    // The body's lines keep their numbers: the bad vertex is on line 13, one below its
    // place in the plain cube.
    let bad = ascii.replace("1 1 0\n", "1 x 0\n");
    broken(
        Mesh::from_ply(bad.as_bytes(), "blender.ply"),
        Some(13),
        &["1 x 0"],
    );
    // No end_header: the junk line is the error, as before.
    broken(
        Mesh::from_ply(
            b"ply\nformat ascii 1.0\nelement vertex 1\nbanana\n",
            "bad.ply",
        ),
        Some(4),
        &["bad.ply", "banana"],
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
    fur.mesh = kami::scene::MeshSource::CgalDemo("lion-head.off".into());
    fur.size = Some(1.6);
    fur.hairs = 50_000;
    let s = kami::systems::fur::setup::FurSetup::new(&fur, 3).unwrap();
    assert_eq!(s.mesh.triangles.len(), 16674);
    let (_, r) = s.mesh.bounds();
    assert!((r - 1.6).abs() < 1e-9, "fitted radius {r}");
    let total = s.coats[0].total as f64;
    assert!((total - 50_000.0).abs() < 4.5 * 50_000f64.sqrt().max(1.0) / 2.0);
}

fn common_fur() -> kami::systems::fur::block::Fur {
    kami::systems::fur::block::Fur {
        mesh: kami::scene::MeshSource::Critter,
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
    let setup = kami::systems::fur::setup::FurSetup::new(s.fur().as_ref().unwrap(), 1).unwrap();
    check_cube(&setup.mesh);
    // A missing mesh names the file.
    std::fs::write(dir.join("t.ron"), scene.replace("cube.obj", "gone.obj")).unwrap();
    let s = kami::Scene::load(dir.join("t.ron")).unwrap();
    let e = kami::systems::fur::setup::FurSetup::new(s.fur().as_ref().unwrap(), 1)
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
    fur.mesh = kami::scene::MeshSource::CgalDemo("no-such-mesh.off".into());
    let e = kami::systems::fur::setup::FurSetup::new(&fur, 1)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no-such-mesh.off"), "{e}");
}

/// A unique, empty temporary folder for one test.
fn temp_dir(what: &str) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("mesh-{what}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn a_directory_or_an_unreadable_file_is_named() {
    let dir = temp_dir("unreadable");
    let d = dir.join("looks-like.obj");
    std::fs::create_dir_all(&d).unwrap();
    let e = Mesh::load(&d).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("looks-like.obj") && msg.contains("is a directory"),
        "{msg}"
    );
    assert!(matches!(e, KamiError::Mesh { .. }), "{e:?}");

    let f = dir.join("locked.off");
    std::fs::write(&f, cube_off()).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&f, std::fs::Permissions::from_mode(0o000)).unwrap();
    // Root (as in many CI containers) reads a mode-000 file anyway: nothing to refuse then.
    if std::fs::read(&f).is_err() {
        let e = Mesh::load(&f).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("locked.off"), "{msg}");
        assert!(matches!(e, KamiError::Io { .. }), "{e:?}");
    } else {
        check_cube(&Mesh::load(&f).unwrap());
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn huge_headers_over_short_bodies_fail_before_allocating() {
    const LIMIT: usize = 256 << 20;
    let body = "0 0 0\n1 0 0\n0 1 0\n";
    let off = format!("OFF\n49999999 1 0\n{body}3 0 1 2\n");
    let (r, peak) = largest_allocation(|| Mesh::from_off(&off, "huge.off"));
    assert!(
        peak < LIMIT,
        "the OFF loader allocated {peak} bytes at once"
    );
    broken(r, Some(2), &["huge.off:2", "49999999 vertices"]);

    let header = |format: &str, nv: &str| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex {nv}\nproperty float x\n\
             property float y\nproperty float z\nelement face 1\n\
             property list uchar int vertex_indices\nend_header\n"
        )
    };
    let ply = header("ascii", "49999999") + body + "3 0 1 2\n";
    let (r, peak) = largest_allocation(|| Mesh::from_ply(ply.as_bytes(), "huge.ply"));
    assert!(
        peak < LIMIT,
        "the ascii PLY loader allocated {peak} bytes at once"
    );
    broken(r, Some(3), &["huge.ply:3", "49999999 vertex"]);

    let mut ply = header("binary_little_endian", "49999999").into_bytes();
    for c in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        ply.extend_from_slice(&c.to_le_bytes());
    }
    let (r, peak) = largest_allocation(|| Mesh::from_ply(&ply, "huge.ply"));
    assert!(
        peak < LIMIT,
        "the binary PLY loader allocated {peak} bytes at once"
    );
    broken(r, Some(3), &["49999999 vertex", "bytes"]);

    // Beyond the cap whatever the body.
    let ply = header("ascii", "4000000000") + body;
    broken(
        Mesh::from_ply(ply.as_bytes(), "huge.ply"),
        Some(3),
        &["50 million"],
    );
}

#[test]
fn meshes_without_area_are_refused() {
    let words = ["every triangle has zero area", "no surface to grow fur on"];
    // Collinear, all vertices equal, and collinear with rounding in the coordinates.
    broken(
        Mesh::from_off("OFF\n3 1 0\n0 0 0\n1 1 1\n2 2 2\n3 0 1 2\n", "flat.off"),
        None,
        &words,
    );
    broken(
        Mesh::from_off(
            "OFF\n4 2 0\n1 1 1\n1 1 1\n1 1 1\n1 1 1\n3 0 1 2\n3 1 2 3\n",
            "point.off",
        ),
        None,
        &words,
    );
    broken(
        Mesh::from_obj(
            "v 0.1 0.2 0.3\nv 0.2 0.4 0.6\nv 0.7 1.4 2.1\nf 1 2 3\nf 3 2 1\n",
            "line.obj",
        ),
        None,
        &words,
    );
    // Tiny but real triangles are a surface.
    let m = Mesh::from_off(
        "OFF\n3 1 0\n0 0 0\n1e-90 0 0\n0 1e-90 0\n3 0 1 2\n",
        "t.off",
    );
    assert!(m.unwrap().normals.iter().all(|n| n.z > 0.99));
    // Coordinates whose products would overflow.
    broken(
        Mesh::from_off("OFF\n3 1 0\n0 0 0\n1e200 0 0\n0 1 0\n3 0 1 2\n", "far.off"),
        None,
        &["vertex 1", "overflow"],
    );
}

#[test]
fn isolated_degenerate_triangles_never_give_nan_normals() {
    let p = vec![
        DVec3::ZERO,
        DVec3::X,
        DVec3::Y,
        // A collinear triangle and a point triangle, sharing nothing with the real one.
        DVec3::new(5.0, 0.0, 0.0),
        DVec3::new(6.0, 0.0, 0.0),
        DVec3::new(7.0, 0.0, 0.0),
        DVec3::splat(9.0),
        DVec3::splat(9.0),
        DVec3::splat(9.0),
    ];
    let t = vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]];
    for n in vertex_normals(&p, &t[1..]) {
        assert!(n.is_finite() && (n.length() - 1.0).abs() < 1e-12, "{n}");
    }
    let m = Mesh::new(p, t, None, "isolated").unwrap();
    for n in &m.normals {
        assert!(n.is_finite() && (n.length() - 1.0).abs() < 1e-12, "{n}");
    }
    assert!(m.normals[..3].iter().all(|n| n.z > 0.99));
}

/// Each triangle as its three positions, in order.
fn corners(m: &Mesh) -> Vec<[DVec3; 3]> {
    m.triangles
        .iter()
        .map(|t| t.map(|i| m.positions[i as usize]))
        .collect()
}

fn total_area(m: &Mesh) -> f64 {
    (0..m.triangles.len()).map(|t| m.area(t)).sum()
}

#[test]
fn obj_relative_indices_count_back_from_the_last_vertex() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n\
               v 5 0 0\nv 6 0 0\nv 5 1 0\nf -3 -2 -1\nf 1 -2 -1\n";
    let m = Mesh::from_obj(obj, "rel.obj").unwrap();
    let v = DVec3::new;
    assert_eq!(
        corners(&m),
        vec![
            [v(0., 0., 0.), v(1., 0., 0.), v(0., 1., 0.)],
            [v(5., 0., 0.), v(6., 0., 0.), v(5., 1., 0.)],
            [v(0., 0., 0.), v(6., 0., 0.), v(5., 1., 0.)],
        ]
    );
    // Counting back past the first vertex is refused with its line.
    broken(
        Mesh::from_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n", "rel.obj"),
        Some(4),
        &["rel.obj:4"],
    );
}

/// A convex pentagon in z = 0, counter-clockwise, and its area (shoelace).
const PENTAGON: [[f64; 2]; 5] = [[0., 0.], [2., 0.], [3., 2.], [1., 3.], [-1., 2.]];

fn pentagon_area() -> f64 {
    (0..5)
        .map(|i| {
            let (a, b) = (PENTAGON[i], PENTAGON[(i + 1) % 5]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
        / 2.0
}

/// A 2x2 quad beside the pentagon: 2 + 3 triangles of total area 4 + the pentagon's, all
/// facing +z.
fn check_polygons(m: &Mesh) {
    assert_eq!(
        m.triangles.len(),
        5,
        "a quad makes 2 triangles, a pentagon 3"
    );
    let want = 4.0 + pentagon_area();
    assert!((total_area(m) - want).abs() < 1e-9, "{}", total_area(m));
    for t in corners(m) {
        assert!(
            (t[1] - t[0]).cross(t[2] - t[0]).z > 0.0,
            "{t:?} is wound the wrong way"
        );
    }
    assert!(m.normals.iter().all(|n| n.z > 0.999));
    assert_eq!(m.reoriented, 0, "an open mesh is left as it is");
    assert!(!m.closed, "a quad and a pentagon are open");
}

#[test]
fn quads_and_polygons_fan_into_triangles_in_every_format() {
    let quad = [[10., 0.], [12., 0.], [12., 2.], [10., 2.]];
    let verts: Vec<[f64; 2]> = quad.iter().chain(&PENTAGON).copied().collect();
    let mut obj = String::new();
    let mut off = format!("OFF\n{} 2 0\n", verts.len());
    for v in &verts {
        obj += &format!("v {} {} 0\n", v[0], v[1]);
        off += &format!("{} {} 0\n", v[0], v[1]);
    }
    obj += "f 1 2 3 4\nf 5 6 7 8 9\n";
    off += "4 0 1 2 3\n5 4 5 6 7 8\n";
    check_polygons(&Mesh::from_obj(&obj, "poly.obj").unwrap());
    check_polygons(&Mesh::from_off(&off, "poly.off").unwrap());
    let mut ply = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\n\
         property double z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n",
        verts.len()
    );
    for v in &verts {
        ply += &format!("{} {} 0\n", v[0], v[1]);
    }
    ply += "4 0 1 2 3\n5 4 5 6 7 8\n";
    check_polygons(&Mesh::from_ply(ply.as_bytes(), "poly.ply").unwrap());
}

#[derive(Clone, Copy)]
enum Ply {
    Ascii,
    Little,
    Big,
}

/// The cube as PLY with what real scanners write besides positions: normals, colours,
/// confidence, an edge element, and texture coordinates per face.
fn cube_ply_extra(enc: Ply) -> Vec<u8> {
    let format = match enc {
        Ply::Ascii => "ascii",
        Ply::Little => "binary_little_endian",
        Ply::Big => "binary_big_endian",
    };
    let mut b = format!(
        "ply\nformat {format} 1.0\ncomment written by a test\nelement vertex 8\n\
         property float x\nproperty float y\nproperty float z\nproperty float nx\n\
         property float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\n\
         property uchar blue\nproperty uchar alpha\nproperty float confidence\n\
         element face 6\nproperty list uchar int vertex_indices\n\
         property list uchar float texcoord\nelement edge 2\nproperty int vertex1\n\
         property int vertex2\nend_header\n"
    )
    .into_bytes();
    let f32s = |b: &mut Vec<u8>, xs: &[f32]| {
        for x in xs {
            match enc {
                Ply::Ascii => b.extend_from_slice(format!("{x} ").as_bytes()),
                Ply::Little => b.extend_from_slice(&x.to_le_bytes()),
                Ply::Big => b.extend_from_slice(&x.to_be_bytes()),
            }
        }
    };
    let i32s = |b: &mut Vec<u8>, xs: &[i32]| {
        for x in xs {
            match enc {
                Ply::Ascii => b.extend_from_slice(format!("{x} ").as_bytes()),
                Ply::Little => b.extend_from_slice(&x.to_le_bytes()),
                Ply::Big => b.extend_from_slice(&x.to_be_bytes()),
            }
        }
    };
    let u8s = |b: &mut Vec<u8>, xs: &[u8]| {
        for &x in xs {
            match enc {
                Ply::Ascii => b.extend_from_slice(format!("{x} ").as_bytes()),
                _ => b.push(x),
            }
        }
    };
    let eol = |b: &mut Vec<u8>| {
        if let Ply::Ascii = enc {
            b.push(b'\n')
        }
    };
    for v in CUBE_V {
        let p = v.map(|c| c as f32);
        let n = v.map(|c| (c as f32 - 0.5) / 0.75f32.sqrt());
        f32s(&mut b, &p);
        f32s(&mut b, &n);
        u8s(&mut b, &[200, 100, 50, 255]);
        f32s(&mut b, &[0.9]);
        eol(&mut b);
    }
    for f in CUBE_F {
        u8s(&mut b, &[4]);
        i32s(&mut b, &f.map(|i| i as i32));
        u8s(&mut b, &[8]);
        f32s(&mut b, &[0., 0., 1., 0., 1., 1., 0., 1.]);
        eol(&mut b);
    }
    for e in [[0, 1], [1, 2]] {
        i32s(&mut b, &e);
        eol(&mut b);
    }
    b
}

#[test]
fn ply_of_every_encoding_with_extra_properties_loads_the_same_cube() {
    let mut be = b"ply\nformat binary_big_endian 1.0\nelement vertex 8\nproperty float x\n\
property float y\nproperty float z\nelement face 6\nproperty list uchar uint vertex_indices\n\
end_header\n"
        .to_vec();
    for v in CUBE_V {
        for c in v {
            be.extend_from_slice(&(c as f32).to_be_bytes());
        }
    }
    for f in CUBE_F {
        be.push(4);
        for i in f {
            be.extend_from_slice(&i.to_be_bytes());
        }
    }
    let ascii = Mesh::from_ply(cube_ply_ascii().as_bytes(), "a.ply").unwrap();
    let little = Mesh::from_ply(&cube_ply_binary(), "le.ply").unwrap();
    let big = Mesh::from_ply(&be, "be.ply").unwrap();
    check_cube(&big);
    assert_eq!(ascii, little);
    assert_eq!(ascii, big);
    for enc in [Ply::Ascii, Ply::Little, Ply::Big] {
        let m = Mesh::from_ply(&cube_ply_extra(enc), "extra.ply").unwrap();
        check_cube(&m);
        assert_eq!(m.triangles, ascii.triangles);
        // The file's normals (the corners' diagonals) are the ones used.
        for (p, n) in m.positions.iter().zip(&m.normals) {
            assert!((*n - (*p - DVec3::splat(0.5)).normalize()).length() < 1e-6);
        }
    }
}

#[test]
fn ply_faces_with_bad_indices_are_named() {
    let name = "bad.ply";
    let s = cube_ply_ascii().replace("4 2 3 7 6", "4 2 -3 7 6");
    broken(
        Mesh::from_ply(s.as_bytes(), name),
        None,
        &[name, "face 3", "vertex -3"],
    );
    let s = cube_ply_ascii().replace("4 2 3 7 6", "4 2 3 7 60");
    broken(
        Mesh::from_ply(s.as_bytes(), name),
        None,
        &["face 3", "vertex 60", "8 vertices"],
    );
    let s = cube_ply_ascii().replace("4 2 3 7 6", "2 2 3");
    broken(
        Mesh::from_ply(s.as_bytes(), name),
        None,
        &["face 3", "2 vertices"],
    );
}

// Winding: closed components are turned outwards, open ones left alone.

/// Every triangle reversed, rotated too (`[c, b, a]`), so a fix that only swaps two corners
/// back is not what makes the sets equal.
fn reversed(t: &[[u32; 3]]) -> Vec<[u32; 3]> {
    t.iter().map(|&[a, b, c]| [c, b, a]).collect()
}

/// Triangles as sets of oriented corner triples, each rotated to start at its smallest
/// corner: equal for two meshes with the same faces wound the same way.
fn triangle_set(m: &Mesh) -> Vec<[[i64; 3]; 3]> {
    let mut set: Vec<[[i64; 3]; 3]> = corners(m)
        .into_iter()
        .map(|t| {
            let q = t.map(|p| (p * 1e9).round().as_i64vec3().to_array());
            let k = (0..3).min_by_key(|&k| q[k]).unwrap();
            [q[k], q[(k + 1) % 3], q[(k + 2) % 3]]
        })
        .collect();
    set.sort();
    set
}

/// Every vertex normal points away from `centre` (the nearest of them).
fn outward(m: &Mesh, centres: &[DVec3]) {
    for (p, n) in m.positions.iter().zip(&m.normals) {
        let c = centres
            .iter()
            .min_by(|a, b| (*p - **a).length().total_cmp(&(*p - **b).length()))
            .unwrap();
        assert!(n.dot(*p - *c) > 0.0, "normal {n} at {p} points in");
    }
    for t in corners(m) {
        let c = centres
            .iter()
            .min_by(|a, b| (t[0] - **a).length().total_cmp(&(t[0] - **b).length()))
            .unwrap();
        let f = (t[1] - t[0]).cross(t[2] - t[0]);
        assert!(f.dot(t[0] - *c) > 0.0, "triangle {t:?} faces in");
    }
}

#[test]
fn a_sphere_wound_inside_out_loads_like_the_right_one() {
    let (p, t) = sphere(DVec3::new(0.3, -0.2, 0.1), 1.5, 12, 24);
    let right = Mesh::from_off(&off(&p, &t), "s.off").unwrap();
    let wrong = Mesh::from_off(&off(&p, &reversed(&t)), "r.off").unwrap();
    assert!(
        triangle_set(&right) == triangle_set(&wrong),
        "OFF triangles differ"
    );
    outward(&right, &[DVec3::new(0.3, -0.2, 0.1)]);
    outward(&wrong, &[DVec3::new(0.3, -0.2, 0.1)]);
    assert_eq!(right.reoriented, 0);
    assert_eq!(wrong.reoriented, t.len());
    assert!(right.closed && wrong.closed, "a sphere is closed");
    // Through OBJ (tobj renumbers vertices) and PLY too.
    let obj = |t: &[[u32; 3]]| {
        let mut s = String::new();
        for v in &p {
            s += &format!("v {} {} {}\n", v.x, v.y, v.z);
        }
        for f in t {
            s += &format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
        }
        s
    };
    // (Compared with the right sphere through OBJ too: tobj keeps f32 coordinates.)
    let right = Mesh::from_obj(&obj(&t), "s.obj").unwrap();
    let m = Mesh::from_obj(&obj(&reversed(&t)), "r.obj").unwrap();
    assert!(
        triangle_set(&m) == triangle_set(&right),
        "OBJ triangles differ"
    );
    assert_eq!(m.reoriented, t.len());
}

#[test]
fn each_closed_component_is_turned_on_its_own() {
    let (c1, c2) = (DVec3::ZERO, DVec3::new(4.0, 0.0, 0.0));
    let (mut p, mut t) = sphere(c1, 1.0, 8, 16);
    let (p2, t2) = sphere(c2, 1.0, 10, 12);
    let base = p.len() as u32;
    p.extend(p2);
    t.extend(reversed(&t2).iter().map(|f| f.map(|i| i + base)));
    let m = Mesh::from_off(&off(&p, &t), "two.off").unwrap();
    outward(&m, &[c1, c2]);
    assert_eq!(m.reoriented, t2.len(), "only the second sphere is reversed");
}

#[test]
fn a_sphere_split_into_obj_groups_is_still_closed() {
    // tobj gives each `o` its own copy of the vertices it uses: welding by position closes
    // the sphere again.
    let (p, t) = sphere(DVec3::ZERO, 1.0, 8, 16);
    let mut s = String::new();
    for v in &p {
        s += &format!("v {} {} {}\n", v.x, v.y, v.z);
    }
    for (k, f) in reversed(&t).iter().enumerate() {
        if k % 40 == 0 {
            s += &format!("o part{k}\n");
        }
        s += &format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    let m = Mesh::from_obj(&s, "split.obj").unwrap();
    outward(&m, &[DVec3::ZERO]);
    assert_eq!(m.reoriented, t.len());
}

#[test]
fn a_cube_with_one_face_flipped_is_made_consistent() {
    let mut s = String::from("OFF\n8 6 0\n");
    for v in CUBE_V {
        s += &format!("{} {} {}\n", v[0], v[1], v[2]);
    }
    for (k, f) in CUBE_F.iter().enumerate() {
        let f = if k == 3 { [f[3], f[2], f[1], f[0]] } else { *f };
        s += &format!("4 {} {} {} {}\n", f[0], f[1], f[2], f[3]);
    }
    let m = Mesh::from_off(&s, "flipped.off").unwrap();
    check_cube(&m);
    assert_eq!(m.reoriented, 2, "the flipped quad's two triangles");
    // Consistent: every edge is run once each way.
    let mut directed: Vec<(u32, u32)> = m
        .triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .collect();
    directed.sort();
    for &(a, b) in &directed {
        assert!(
            directed.binary_search(&(b, a)).is_ok(),
            "edge {a}-{b} runs one way only"
        );
    }
    directed.dedup();
    assert_eq!(directed.len(), 36);
}

#[test]
fn an_open_hemisphere_is_left_as_the_file_winds_it() {
    let (p, t) = sphere(DVec3::ZERO, 1.0, 8, 16);
    // The northern half: triangles whose corners all lie at y >= 0.
    let north: Vec<[u32; 3]> = t
        .iter()
        .filter(|f| f.iter().all(|&i| p[i as usize].y >= -1e-12))
        .copied()
        .collect();
    let inward = reversed(&north);
    let m = Mesh::from_off(&off(&p, &inward), "bowl.off").unwrap();
    assert_eq!(m.reoriented, 0);
    assert_eq!(m.triangles, inward);
    let used: std::collections::HashSet<u32> = inward.iter().flatten().copied().collect();
    for &i in &used {
        let (p, n) = (m.positions[i as usize], m.normals[i as usize]);
        assert!(
            n.dot(p) < 0.0,
            "normal {n} at {p}: the file's winding must be kept"
        );
    }
}

#[test]
fn file_normals_on_a_closed_mesh_follow_its_outward_faces() {
    let (p, t) = sphere(DVec3::ZERO, 1.0, 8, 16);
    let obj = |t: &[[u32; 3]], sign: f64| {
        let mut s = String::new();
        for v in &p {
            s += &format!(
                "v {} {} {}\nvn {} {} {}\n",
                v.x,
                v.y,
                v.z,
                sign * v.x,
                sign * v.y,
                sign * v.z
            );
        }
        for f in t {
            s += &format!(
                "f {0}//{0} {1}//{1} {2}//{2}\n",
                f[0] + 1,
                f[1] + 1,
                f[2] + 1
            );
        }
        s
    };
    // Outward faces, inward normals: the normals are turned.
    let m = Mesh::from_obj(&obj(&t, -1.0), "in.obj").unwrap();
    outward(&m, &[DVec3::ZERO]);
    assert_eq!(m.reoriented, 0);
    // Inward faces, outward normals: the faces are turned, the normals kept.
    let m = Mesh::from_obj(&obj(&reversed(&t), 1.0), "out.obj").unwrap();
    outward(&m, &[DVec3::ZERO]);
    assert_eq!(m.reoriented, t.len());
    for (p, n) in m.positions.iter().zip(&m.normals) {
        assert!(
            (*n - p.normalize()).length() < 1e-6,
            "the file's normal at {p} was changed"
        );
    }
}

/// A binary PLY element with no properties takes no bytes per record, so no body bounds its
/// count: refused from the header (ply-rs-bw built a 3.4 GB map list for 50 M of them).
#[test]
fn binary_ply_elements_without_properties_are_refused() {
    let mut ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
property float y\nproperty float z\nelement junk 49999999\nelement face 1\n\
property list uchar int vertex_indices\nend_header\n"
        .to_vec();
    for v in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
        for c in v {
            ply.extend_from_slice(&c.to_le_bytes());
        }
    }
    ply.push(3);
    for i in [0i32, 1, 2] {
        ply.extend_from_slice(&i.to_le_bytes());
    }
    let (r, peak) = largest_allocation(|| Mesh::from_ply(&ply, "junk.ply"));
    let e = r.expect_err("an element of 49999999 empty records must be refused");
    assert!(peak < 256 << 20, "allocated {peak} bytes at once");
    let msg = e.to_string();
    assert!(
        msg.contains("junk.ply:7") && msg.contains("no properties"),
        "{msg}"
    );
}

/// OBJ polylines (`l`) of any length are not surfaces: no triangles come from them.
#[test]
fn obj_polylines_are_not_surfaces() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nf 1 2 3\nl 1 2 4 3\nl 2 5 3\n";
    let m = Mesh::from_obj(obj, "lines.obj").unwrap();
    assert_eq!(m.triangles.len(), 1, "polylines became triangles");
}

/// What `Mesh::load` refuses before reading: an unknown extension, and anything that is not a
/// regular file (a FIFO would block the read; `/dev/zero` would never end).
#[cfg(unix)]
#[test]
fn special_files_are_refused_before_reading() {
    let dir = std::env::temp_dir().join(format!("kami-mesh-special-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let zero = dir.join("zero.obj");
    let _ = std::fs::remove_file(&zero);
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let msg = Mesh::load(&zero).unwrap_err().to_string();
    assert!(
        msg.contains("zero.obj") && msg.contains("not a regular file"),
        "{msg}"
    );
    let msg = Mesh::load(dir.join("mesh.stl")).unwrap_err().to_string();
    assert!(msg.contains("unknown mesh format \"stl\""), "{msg}");
}

/// The OFF size check's message reads as one sentence (no run of spaces from a broken
/// string continuation).
#[test]
fn off_size_message_is_one_sentence() {
    let msg = Mesh::from_off("OFF\n49999999 1 0\n0 0 0\n", "huge.off")
        .unwrap_err()
        .to_string();
    assert!(msg.contains("the whole file is 2"), "{msg}");
    assert!(!msg.contains("  "), "{msg}");
}

/// Normals from a file are unit vectors whatever their scale: (0, 0, 1e308) squares to
/// infinity and used to come out as zero (found by the fuzzer).
#[test]
fn huge_file_normals_keep_their_direction() {
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n\
property double z\nproperty double nx\nproperty double ny\nproperty double nz\nelement face 1\n\
property list char int vertex_index\nend_header\n0 0 0 0 0 1\n1 0 0 0 0 1e308\n0 1 0 0 0 1\n3 0 1 2\n";
    let m = Mesh::from_ply(ply.as_bytes(), "huge_normal.ply").unwrap();
    for n in &m.normals {
        assert!((*n - DVec3::Z).length() < 1e-12, "normal {n}");
    }
}

/// Texture and normal indices that refer to nothing are refused with the line (tobj 4.0.5
/// overflowed on them: a panic in debug builds; found by the fuzzer).
#[test]
fn obj_texture_and_normal_indices_out_of_range_are_refused() {
    for (obj, says) in [
        ("v 1 0 1\nvn 0 0 1\nf 1//-7 1 3\n", "normal index -7"),
        (
            "v 1 1 0\nv 1 1 0\nv 1 1 0\nvt 0 1\nf 1 2 3/-4\n",
            "texture coordinate index -4",
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "vertex index 9"),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//9223372036854775807\n",
            "normal index 9223372036854775807",
        ),
    ] {
        let msg = Mesh::from_obj(obj, "bad.obj").unwrap_err().to_string();
        assert!(
            msg.contains("bad.obj:") && msg.contains(says),
            "{obj:?}: {msg}"
        );
    }
    // Relative indices that exist, and texture indices in a file without any, still load.
    let ok = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf -3//-1 -2//-1 -1//-1\nf 1/5 2/5 3/5\n";
    assert_eq!(Mesh::from_obj(ok, "ok.obj").unwrap().triangles.len(), 2);
}
