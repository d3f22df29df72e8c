//! Alembic curves in (`kami::formats::abc`), from files the real Alembic library writes at
//! run time (`tests/abc_write.py`, pip `alembic3d`): linear curves with vertex widths and
//! colours, cubic curves with their basis reported, curves under transforms (checked against
//! Alembic's own matrices), a chosen time sample, and broken files refused with an error
//! naming the file, without a large allocation. No GPU needed.

use crate::common::{kami, largest_allocation, scratch};
use kami::formats::abc::{self, Basis, CurveType, Options, Sample, Wrap};
use kami::formats::{self, Groom};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Write `case` with Alembic into `dir` and return its path and what Alembic reads back at
/// `sample`: per curves object, its path and world-space points. Fails, naming the pip
/// command, when the Alembic bindings are missing.
pub(crate) fn write(dir: &Path, case: &str, sample: u32) -> (PathBuf, Vec<(String, Vec<f64>)>) {
    let path = dir.join(format!("{case}.abc"));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/abc_write.py");
    let out = Command::new("python3")
        .arg(&script)
        .arg(case)
        .arg(&path)
        .arg(sample.to_string())
        .output()
        .unwrap_or_else(|e| {
            panic!("python3 could not be run ({e}): install Python 3 and `python3 -m pip install alembic3d`")
        });
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("No module named 'alembic3d'") && !stderr.contains("No module named 'imath'"),
        "Alembic's Python bindings are not installed: run `python3 -m pip install alembic3d` (.ci/run does)"
    );
    assert!(out.status.success(), "abc_write.py {case} failed: {stderr}");
    let text = String::from_utf8(out.stdout).unwrap();
    let mut objects = Vec::new();
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        let name = line.strip_prefix("object ").expect(line).to_string();
        let points = lines.next().unwrap().split(' ').skip(1);
        objects.push((name, points.map(|v| v.parse().unwrap()).collect()));
    }
    (path, objects)
}

fn read(path: &Path, options: Options) -> abc::Curves {
    abc::read(path, &options).unwrap_or_else(|e| panic!("{e}"))
}

fn close(a: f32, b: f64) -> bool {
    (a as f64 - b).abs() <= 1e-5 * (1.0 + b.abs())
}

#[test]
fn linear_curves_with_vertex_widths_and_colours() {
    let dir = scratch("linear");
    let (path, oracle) = write(&dir, "linear", 0);
    // Through the extension, as `kami view` and hair groups read it.
    let g = formats::read(&path).unwrap();
    let expected = Groom {
        counts: vec![3, 2],
        points: vec![
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 2.0, 0.5],
            [1.0, 0.0, 0.0],
            [1.0, 1.5, 0.0],
        ],
        widths: Some(vec![0.1, 0.2, 0.3, 0.4, 0.5]),
        // `opacity` is uniform (one per curve), expanded per point.
        opacities: Some(vec![0.5, 0.5, 0.5, 0.25, 0.25]),
        colors: Some(vec![
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 1.0],
        ]),
        ..Groom::default()
    };
    assert_eq!(g, expected);
    let points: Vec<f64> = g.points.iter().flatten().map(|&v| v as f64).collect();
    assert_eq!(oracle, vec![("/hair".to_string(), points)]);
    let c = read(&path, Options::default());
    assert_eq!(c.objects.len(), 1);
    let o = &c.objects[0];
    assert_eq!(
        (o.path.as_str(), o.strands.clone(), o.curve_type, o.wrap),
        ("/hair", 0..2, CurveType::Linear, Wrap::NonPeriodic)
    );
    // `kami view groom.abc` and the Files panel open it as a scene of its own.
    let scene = kami::Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.groups().len(), 1);
    // `kami convert` reads Alembic and refuses to write it.
    let usda = dir.join("out.usda");
    let out = kami(&["convert", path.to_str().unwrap(), usda.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(formats::read(&usda).unwrap(), expected);
    let out = kami(&[
        "convert",
        usda.to_str().unwrap(),
        dir.join("back.abc").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("back.abc") && err.contains("does not write"),
        "{err}"
    );
    let e = formats::write(&dir.join("w.abc"), &expected)
        .unwrap_err()
        .to_string();
    assert!(e.contains("w.abc") && e.contains("does not write"), "{e}");
}

#[test]
fn cubic_curves_keep_control_points_and_report_their_basis() {
    let dir = scratch("cubic");
    let (path, oracle) = write(&dir, "cubic", 0);
    let c = read(&path, Options::default());
    let kinds: Vec<_> = c
        .objects
        .iter()
        .map(|o| {
            (
                o.path.as_str(),
                o.strands.clone(),
                o.curve_type,
                o.basis,
                o.wrap,
            )
        })
        .collect();
    assert_eq!(
        kinds,
        vec![
            (
                "/bspline",
                0..1,
                CurveType::Cubic,
                Basis::Bspline,
                Wrap::NonPeriodic
            ),
            (
                "/catmull",
                1..2,
                CurveType::Cubic,
                Basis::CatmullRom,
                Wrap::NonPeriodic
            ),
            (
                "/bezier",
                2..4,
                CurveType::Cubic,
                Basis::Bezier,
                Wrap::Periodic
            ),
        ]
    );
    let g = &c.groom;
    assert_eq!(g.counts, vec![6, 4, 6, 6]);
    // The control points, as Alembic reads them.
    let ours: Vec<f64> = g.points.iter().flatten().map(|&v| v as f64).collect();
    let theirs: Vec<f64> = oracle.iter().flat_map(|(_, p)| p.clone()).collect();
    assert_eq!(ours, theirs);
    let w = g.widths.as_ref().unwrap();
    // Four varying widths on a 6-point bspline (one per segment end) spread over the
    // control points: point j at 3j/5 between them.
    let varying = [0.1f32, 0.2, 0.3, 0.4];
    for (j, &got) in w[..6].iter().enumerate() {
        let u = 3.0 * j as f32 / 5.0;
        let (lo, f) = ((u as usize).min(2), u - (u as usize).min(2) as f32);
        let want = varying[lo] + (varying[(lo + 1).min(3)] - varying[lo]) * f;
        assert!((got - want).abs() < 1e-6, "point {j}: {got} vs {want}");
    }
    assert_eq!(&w[6..10], &[0.25; 4], "constant");
    assert_eq!(&w[10..16], &[0.5; 6], "uniform");
    // Drawn as the curves their bases describe (objects of three bases: polylines, 8
    // samples a segment and the end): a B-spline starts at (P0 + 4 P1 + P2) / 6, a
    // Catmull-Rom segment at its second point, a closed Bézier ends where it began.
    let drawn = formats::read(&path).unwrap();
    assert_eq!(drawn.basis, formats::Basis::Linear);
    assert_eq!(drawn.counts, vec![3 * 8 + 1, 8 + 1, 2 * 8 + 1, 2 * 8 + 1]);
    let p = |i: usize| glam::DVec3::from(g.points[i].map(f64::from));
    let q = |i: usize| glam::DVec3::from(drawn.points[i].map(f64::from));
    assert!((q(0) - (p(0) + 4.0 * p(1) + p(2)) / 6.0).length() < 1e-5);
    assert!((q(25) - p(7)).length() < 1e-5);
    assert!((q(34) - q(34 + 16)).length() < 1e-6);
    assert_eq!(&w[16..22], &[0.6; 6], "uniform");
    // Indexed uniform colours (indices 1, 0) on the bezier only: dropped from the groom,
    // since the other objects have none (no colour is made up).
    assert_eq!(g.colors, None);
}

#[test]
fn indexed_colours_and_widths_expand() {
    // Uniform colours through indices (1, 0), a constant width through index 0.
    let dir = scratch("indexed");
    let (path, _) = write(&dir, "indexed", 0);
    let g = formats::read(&path).unwrap();
    assert_eq!(g.counts, vec![4, 4]);
    assert_eq!(
        g.colors,
        Some(
            [[0.9f32, 0.8, 0.7]; 4]
                .into_iter()
                .chain([[0.2, 0.3, 0.4]; 4])
                .collect()
        )
    );
    assert_eq!(g.widths, Some(vec![0.05; 8]), "indexed constant width");
}

#[test]
fn eight_bit_colours_are_read_and_other_types_passed_over() {
    // `Cs` holds integers (not a colour Kami reads): passed over for `Cd`, 8-bit, / 255.
    let dir = scratch("bytes");
    let (path, _) = write(&dir, "bytes", 0);
    let g = formats::read(&path).unwrap();
    assert_eq!(g.colors, Some(vec![[1.0, 0.0, 0.0], [0.0, 0.2, 1.0]]));
    assert_eq!(g.widths, None);
}

#[test]
fn transforms_are_applied_as_alembic_composes_them() {
    let dir = scratch("xforms");
    let (path, oracle) = write(&dir, "xforms", 0);
    let c = read(&path, Options::default());
    let paths: Vec<&str> = c.objects.iter().map(|o| o.path.as_str()).collect();
    assert_eq!(paths, ["/outer/inner/a", "/outer/alone/b", "/matrix/c"]);
    let ours: Vec<f32> = c.groom.points.iter().flatten().copied().collect();
    let theirs: Vec<f64> = oracle.iter().flat_map(|(_, p)| p.clone()).collect();
    assert_eq!(ours.len(), theirs.len());
    for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
        assert!(close(*a, *b), "value {i}: {a} vs Alembic's {b}");
    }
    // Widths scale with the transform: /outer scales by 2 (a inherits it, b does not), the
    // matrix above c scales volume by 3.
    let w = c.groom.widths.as_ref().unwrap();
    for (i, want) in [0.2, 0.2, 0.2, 0.1, 0.1, 0.1].into_iter().enumerate() {
        assert!(close(w[i], want), "width {i}: {}", w[i]);
    }
    assert!(close(w[6], 0.2 * 3f64.cbrt()), "{}", w[6]);
    // Without transforms: the points as the curves store them.
    let raw = read(
        &path,
        Options {
            transforms: false,
            ..Options::default()
        },
    );
    assert_eq!(
        raw.groom.points[..3],
        [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.5, 2.0, 0.0]]
    );
    assert_eq!(raw.groom.widths.as_ref().unwrap()[6], 0.2);
}

#[test]
fn a_chosen_time_sample_is_read() {
    let dir = scratch("animated");
    let (path, first) = write(&dir, "animated", 0);
    let (_, third) = write(&dir, "animated", 2);
    // The first sample by default.
    let g = formats::read(&path).unwrap();
    assert_eq!(g.points, vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    assert_eq!(g.widths, Some(vec![0.1, 0.2]));
    assert_eq!(first[0].1, vec![0.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    // Sample 2: the points moved, the parent moved, the widths changed.
    let c = read(
        &path,
        Options {
            sample: Sample::Index(2),
            ..Options::default()
        },
    );
    assert_eq!(c.groom.points, vec![[2.0, 0.0, 0.0], [2.0, 3.0, 0.0]]);
    assert_eq!(third[0].1, vec![2.0, 0.0, 0.0, 2.0, 3.0, 0.0]);
    assert!(close(c.groom.widths.as_ref().unwrap()[0], 0.3));
    assert_eq!((c.objects[0].sample, c.objects[0].time), (2, 2.0 / 24.0));
    // By time: the nearest sample (1/24 s is sample 1); past the end, the last one; an
    // index past the end is clamped too.
    let at = |sample| {
        read(
            &path,
            Options {
                sample,
                ..Options::default()
            },
        )
        .groom
        .points
    };
    assert_eq!(
        at(Sample::Time(1.1 / 24.0)),
        vec![[1.0, 0.0, 0.0], [1.0, 2.0, 0.0]]
    );
    assert_eq!(at(Sample::Time(0.9 / 24.0)), at(Sample::Time(1.1 / 24.0)));
    assert_eq!(at(Sample::Time(100.0)), c.groom.points);
    assert_eq!(at(Sample::Index(7)), c.groom.points);
    assert_eq!(at(Sample::Time(-1.0)), g.points);
    let e = abc::read(
        &path,
        &Options {
            sample: Sample::Time(f64::NAN),
            ..Options::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("not a number"), "{e}");
}

/// The error for `bytes` read as `name`, which must name the file, and the largest
/// allocation made while reading.
fn refused(dir: &Path, name: &str, bytes: &[u8]) -> (String, usize) {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let (r, biggest) = largest_allocation(|| formats::read(&path));
    let e = r.expect_err(name).to_string();
    assert!(
        e.contains(&path.display().to_string()),
        "{name}: the error does not name the file: {e}"
    );
    (e, biggest)
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}

#[test]
fn broken_alembic_files_are_refused() {
    let dir = scratch("broken");
    let (path, _) = write(&dir, "linear", 0);
    let good = std::fs::read(&path).unwrap();
    let n = good.len();
    // Every truncation is an error naming the file, never a panic or a large allocation.
    for cut in 0..n {
        let (r, biggest) = largest_allocation(|| formats::parse("cut.abc", &good[..cut]));
        let e = r.expect_err("a truncated file").to_string();
        assert!(e.starts_with("cut.abc: "), "cut at {cut}: {e}");
        assert!(
            biggest <= 4 * n,
            "cut at {cut}: an allocation of {biggest} bytes"
        );
    }
    let (e, _) = refused(&dir, "short.abc", &good[..10]);
    assert!(e.contains("too short"), "{e}");
    let mut magic = good.clone();
    magic[0] = b'X';
    assert!(refused(&dir, "magic.abc", &magic)
        .0
        .contains("not an Alembic (Ogawa) file"));
    let mut hdf5 = good.clone();
    hdf5[..8].copy_from_slice(b"\x89HDF\r\n\x1a\n");
    assert!(refused(&dir, "hdf5.abc", &hdf5).0.contains("HDF5"));
    let mut open = good.clone();
    open[5] = 0;
    assert!(refused(&dir, "open.abc", &open)
        .0
        .contains("not closed cleanly"));
    // The root group's offset past the end of the file.
    let mut past = good.clone();
    past[8..16].copy_from_slice(&(n as u64 + 100).to_le_bytes());
    let (e, _) = refused(&dir, "past.abc", &past);
    assert!(e.contains("past the end"), "{e}");
    // The root group claiming 2^60 children: refused before anything is allocated.
    let root = u64_at(&good, 8) as usize;
    let mut children = good.clone();
    children[root..root + 8].copy_from_slice(&(1u64 << 60).to_le_bytes());
    let (e, biggest) = refused(&dir, "children.abc", &children);
    assert!(e.contains("claims 1152921504606846976 children"), "{e}");
    assert!(biggest <= 4 * n, "{biggest}");
    // A data block (the time samplings, child 4 of the root) claiming 2^62 bytes.
    let ts = (u64_at(&good, root + 8 + 4 * 8) & !(1 << 63)) as usize;
    let mut size = good.clone();
    size[ts..ts + 8].copy_from_slice(&(1u64 << 62).to_le_bytes());
    let (e, biggest) = refused(&dir, "size.abc", &size);
    assert!(e.contains("claims 4611686018427387904 bytes"), "{e}");
    assert!(biggest <= 4 * n, "{biggest}");
    // nVertices (3, 2) claiming three million points: counts that do not fit P.
    let at = good
        .windows(8)
        .position(|w| w == [3, 0, 0, 0, 2, 0, 0, 0])
        .expect("the nVertices sample");
    let mut counts = good.clone();
    counts[at..at + 4].copy_from_slice(&3_000_000u32.to_le_bytes());
    let (e, biggest) = refused(&dir, "counts.abc", &counts);
    assert!(
        e.contains("object /hair: nVertices adds up to 3000002 points but P has 5"),
        "{e}"
    );
    assert!(biggest <= 4 * n, "{biggest}");
    counts[at..at + 4].copy_from_slice(&1u32.to_le_bytes());
    let (e, _) = refused(&dir, "one.abc", &counts);
    assert!(e.contains("curve 0 has 1 vertices"), "{e}");
    // A property name whose size runs past the end of its header block.
    let at = good
        .windows(10)
        .position(|w| w == b"\x09nVertices")
        .expect("the nVertices header");
    let mut name = good.clone();
    name[at] = 0xff;
    let (e, _) = refused(&dir, "name.abc", &name);
    assert!(e.contains("255 bytes are needed but only"), "{e}");
    // A NaN point.
    let at = good
        .windows(8)
        .position(|w| w == [0, 0, 0, 0x40, 0, 0, 0, 0x3f])
        .expect("the point (0, 2, 0.5)");
    let mut nan = good.clone();
    nan[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let (e, _) = refused(&dir, "nan.abc", &nan);
    assert!(e.contains("point 2 is not finite"), "{e}");
    // An archive with no curves.
    let (empty, _) = write(&dir, "empty", 0);
    let e = formats::read(&empty).unwrap_err().to_string();
    assert!(e.contains("empty.abc") && e.contains("no curves"), "{e}");
}

/// The chosen time reaches users: `kami convert --time` and a hair group's
/// `StrandFile(time: ...)` read the sample nearest that time; a time on a one-pose file is
/// refused, naming the field or the option.
#[test]
fn a_time_is_chosen_from_the_command_line_and_the_scene() {
    let dir = scratch("animated_cli");
    let (path, _) = write(&dir, "animated", 0);
    let sample1 = vec![[1.0, 0.0, 0.0], [1.0, 2.0, 0.0]];
    let out = dir.join("at.obj");
    let t = format!("{}", 1.1 / 24.0);
    let o = crate::common::kami(&[
        "convert",
        path.to_str().unwrap(),
        out.to_str().unwrap(),
        "--time",
        &t,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(formats::read(&out).unwrap().points, sample1);
    // Not for a one-pose file.
    let o = crate::common::kami(&["convert", out.to_str().unwrap(), "x.usda", "--time", "1"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && e.contains("is for Alembic and USD files"),
        "{e}"
    );
    // In a scene: the group's rest pose is that sample.
    let mut s = kami::Scene::load(&path).unwrap();
    s.groups_mut()[0].file.as_mut().unwrap().time = Some(1.1 / 24.0);
    let scene = dir.join("timed.ron");
    std::fs::write(&scene, s.to_ron()).unwrap();
    let s = kami::Scene::load(&scene).unwrap();
    let f = s.groups()[0].file.as_ref().unwrap();
    assert_eq!(f.time, Some(1.1 / 24.0));
    assert_eq!(f.groom.as_ref().unwrap().points, sample1);
    let hair = dir.join("one.hair");
    formats::write(&hair, &formats::read(&out).unwrap()).unwrap();
    let text = s
        .to_ron()
        .replace(&path.display().to_string(), &hair.display().to_string());
    std::fs::write(&scene, text).unwrap();
    let e = kami::Scene::load(&scene).unwrap_err().to_string();
    assert!(e.contains("groups[0].file.time"), "{e}");
}

/// Unreal's groom schema as MetaHuman and Houdini export it (`abc_write.py unreal`):
/// `groom_width` wins over Maya's `width`, `groom_color` is the colour, and per strand the
/// group id, the guide flag (a guides object with a constant `groom_guide`) and the root
/// UV; a guides object without colours takes the strands' mean instead of costing the
/// groom its colours. A file of guides only is refused, naming it.
#[test]
fn unreal_groom_attributes_are_read() {
    let dir = scratch("unreal");
    let (path, _) = write(&dir, "unreal", 0);
    let g = formats::read(&path).unwrap();
    assert_eq!(g.counts, vec![3; 8]);
    let w = g.widths.as_ref().unwrap();
    for (k, &x) in w[..18].iter().enumerate() {
        assert!(close(x, 0.01 * (k + 1) as f64), "width {k} is {x}");
    }
    assert!(
        w[18..].iter().all(|&x| close(x, 0.02)),
        "guide widths {w:?}"
    );
    let c = g.colors.as_ref().unwrap();
    for i in 0..6 {
        let want = [0.1 * i as f64, 0.5, 0.2];
        for k in 0..3 {
            assert!(
                close(c[3 * i][k], want[k]),
                "strand {i} colour {:?}",
                c[3 * i]
            );
        }
    }
    // The guides take the strands' mean colour.
    assert!(close(c[18][0], 0.25) && close(c[18][1], 0.5), "{:?}", c[18]);
    assert_eq!(g.group_ids, Some(vec![3, 3, 7, 7, 7, 3, 3, 7]));
    assert_eq!(
        g.guides,
        Some(vec![false, false, false, false, false, false, true, true])
    );
    let uv = g.root_uvs.as_ref().unwrap();
    assert!(
        close(uv[2][0], 2.0 / 6.0) && close(uv[2][1], 0.25),
        "{uv:?}"
    );
    assert_eq!(uv[6], [0.0, 0.0]);

    let (only, _) = write(&dir, "guides_only", 0);
    let e = formats::read(&only).unwrap_err().to_string();
    assert!(
        e.contains("guides_only.abc") && e.contains("every one of its 2 curves is a guide"),
        "{e}"
    );
}

/// Opened in Kami, Unreal's groups are Kami's groups (one per `groom_group_id`), and with
/// dynamics the file's guides are the simulated strands: every other strand follows the
/// guide of its own group.
#[test]
fn unreal_groups_and_guides_become_kamis() {
    use kami::systems::anjyo::{follow, groom, projective::DynSetup};
    let dir = scratch("unreal_scene");
    let (path, _) = write(&dir, "unreal", 0);
    let mut scene = kami::Scene::from_strand_file(&path).unwrap();
    let names: Vec<(&str, u32)> = scene
        .groups()
        .iter()
        .map(|g| (g.name.as_str(), g.count))
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    assert!(names[0].0.ends_with("(group 3)") && names[1].0.ends_with("(group 7)"));
    assert_eq!((names[0].1, names[1].1), (4, 4));
    *scene.dynamics_mut() = Some(Default::default());
    let input = groom::prepare(&scene).unwrap();
    let mask = follow::guide_mask(&scene, &input);
    // Group 3: strands 0, 1, 5 and its guide; group 7: strands 2, 3, 4 and its guide.
    assert_eq!(
        mask,
        vec![false, false, false, true, false, false, false, true]
    );
    let visible: Vec<f64> = input
        .roots
        .iter()
        .map(|r| input.groups[r.group as usize].segments as f64)
        .collect();
    let setup = DynSetup::new(&scene, &input, &visible).unwrap();
    assert_eq!(setup.strands.len(), 2);
    let f = follow::FollowSetup::new(&scene, &input, &visible, &setup).unwrap();
    assert_eq!(f.followers.len(), 6);
    for fo in &f.followers {
        let group = input.roots[fo.strand as usize].group;
        for g in &fo.guides {
            let guide = setup
                .strands
                .iter()
                .find(|s| s.first_vertex == g.first_vertex)
                .unwrap();
            assert_eq!(input.roots[guide.strand as usize].group, group);
        }
    }
}
