//! USD grooms as their authors made them (issue 26 item 1): cubic curves of every basis and
//! wrap evaluated as the USD spec defines them, widths and colours at every interpolation,
//! transforms and the stage's units and up axis. The files are written at run time by
//! Pixar's own USD (`usd-core`) through `tests/usd_curves.py`, which also computes, on its
//! own, the polylines Kami must make of them (the spec's basis matrices, USD's
//! `ComputeLocalToWorldTransform`). No GPU needed.

use glam::DVec3;
use kami::formats::{self, curves, Basis, Groom, Wrap};
use std::path::PathBuf;
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kami-usd-curves-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Run `tests/usd_curves.py MODE PATH` and return its `name values...` lines. Fails, naming
/// the install command, when Pixar's USD is missing.
fn python(mode: &str, path: &std::path::Path) -> Vec<(String, Vec<String>)> {
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/usd_curves.py");
    let out = Command::new("python3")
        .arg(&script)
        .arg(mode)
        .arg(path)
        .output()
        .unwrap_or_else(|e| {
            panic!("python3 could not be run ({e}): install Python 3 and `python3 -m pip install usd-core`")
        });
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("No module named 'pxr'"),
        "Pixar's USD is not installed: run `python3 -m pip install usd-core` (.ci/run does)"
    );
    assert!(
        out.status.success(),
        "usd_curves.py {mode} failed: {stderr}"
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| {
            let mut w = l.split(' ').map(String::from);
            (w.next().unwrap_or_default(), w.collect())
        })
        .collect()
}

/// Save the text layer `usda` as `out` (`.usdc` or `.usdz`) with Pixar's USD.
fn crate_of(usda: &std::path::Path, out: &std::path::Path) {
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/usd_curves.py");
    let o = Command::new("python3")
        .arg(&script)
        .args(["crate"])
        .arg(usda)
        .arg(out)
        .output()
        .expect("python3 runs");
    assert!(
        o.status.success(),
        "usd_curves.py crate failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn field(lines: &[(String, Vec<String>)], name: &str) -> Vec<f64> {
    lines
        .iter()
        .find(|l| l.0 == name)
        .unwrap_or_else(|| panic!("no `{name}` line"))
        .1
        .iter()
        .map(|v| v.parse().unwrap())
        .collect()
}

/// The worst difference of two equally long lists, relative to `scale`.
fn worst(a: &[f64], b: &[f64], scale: f64) -> f64 {
    assert_eq!(a.len(), b.len(), "lengths differ");
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / scale)
        .fold(0.0, f64::max)
}

fn flat3(v: &[[f32; 3]]) -> Vec<f64> {
    v.iter().flatten().map(|&x| x as f64).collect()
}

/// Every basis and wrap, widths per point and per segment end, colours and opacities per
/// curve, a parent
/// Xform (translate, rotateXYZ, scale) and an inner one, each prim with another op
/// (transform, orient, rotateZYX, a pivot with `!invert!`, scale, rotateY, translate), in
/// metres with z up: Kami's polylines match the spec's, moved as USD moves them, from the
/// same stage saved by USD as text, as a binary crate file and as a `.usdz` package.
#[test]
fn every_basis_wrap_and_transform_as_usd_defines_them() {
    let mut read = Vec::new();
    for ext in ["usda", "usdc", "usdz"] {
        let path = tmp(&format!("mixed.{ext}"));
        let expected = python("mixed", &path);
        let g = formats::read(&path).unwrap_or_else(|e| panic!("{ext}: {e}"));
        check_mixed(&g, &expected);
        read.push(g);
    }
    // The encodings hold the same numbers (text doubles read as f32 aside: the groom's
    // transform differs by an f32 rounding, which moves points by ulps).
    for g in &read[1..] {
        assert_eq!(g.counts, read[0].counts);
        let size = flat3(&read[0].points)
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let e = worst(&flat3(&g.points), &flat3(&read[0].points), size);
        assert!(e < 1e-6, "crate and text differ by {e:e}");
        assert_eq!(g.colors, read[0].colors);
        assert_eq!(g.opacities, read[0].opacities);
    }
}

fn check_mixed(g: &Groom, expected: &[(String, Vec<String>)]) {
    let expected = expected.to_vec();
    // Prims of different bases: one groom of polylines.
    assert_eq!((g.basis, g.wrap), (Basis::Linear, Wrap::Nonperiodic));
    let counts: Vec<u32> = field(&expected, "counts")
        .iter()
        .map(|&c| c as u32)
        .collect();
    assert_eq!(g.counts, counts, "samples per curve");
    let want = field(&expected, "points");
    let size = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // f32 points (the file's and Kami's) against f64 evaluation: a few ulps of the size.
    let e = worst(&flat3(&g.points), &want, size);
    assert!(e < 1e-6, "points off by {e:e} of the groom's size {size}");
    let w: Vec<f64> = g
        .widths
        .as_ref()
        .unwrap()
        .iter()
        .map(|&x| x as f64)
        .collect();
    let want_w = field(&expected, "widths");
    let wmax = want_w.iter().fold(0.0f64, |m, v| m.max(*v));
    let e = worst(&w, &want_w, wmax);
    assert!(e < 1e-6, "widths off by {e:e} of {wmax}");
    let e = worst(
        &flat3(g.colors.as_ref().unwrap()),
        &field(&expected, "colors"),
        1.0,
    );
    assert!(e < 1e-7, "colours off by {e:e}");
    let o: Vec<f64> = g
        .opacities
        .as_ref()
        .expect("displayOpacity is read")
        .iter()
        .map(|&x| x as f64)
        .collect();
    let e = worst(&o, &field(&expected, "opacities"), 1.0);
    assert!(e < 1e-7, "opacities off by {e:e}");
}

/// A groom of one basis stays cubic: its control points (moved by the prim's rotateY)
/// come in as the file has them, `kami convert` writes it back cubic with the same basis
/// and wrap, USD reads that, and its polylines are the spec's.
#[test]
fn one_basis_stays_cubic_through_convert() {
    let path = tmp("single.usda");
    let expected = python("single", &path);
    let g = formats::read(&path).unwrap();
    assert_eq!((g.basis, g.wrap), (Basis::CatmullRom, Wrap::Pinned));
    assert_eq!(g.counts, vec![4, 6, 2]);
    // The same layer as a crate file and a package: the same control points, to the ulps
    // the text reader's f32 parse of the parent's `double3` translate costs.
    for ext in ["usdc", "usdz"] {
        let other = tmp(&format!("single.{ext}"));
        crate_of(&path, &other);
        let c = formats::read(&other).unwrap_or_else(|e| panic!("{ext}: {e}"));
        assert_eq!((c.basis, c.wrap, &c.counts), (g.basis, g.wrap, &g.counts));
        let size = flat3(&g.points).iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let e = worst(&flat3(&c.points), &flat3(&g.points), size);
        assert!(e < 1e-6, "{ext}: control points off by {e:e}");
        assert_eq!(c.widths, g.widths, "{ext}: widths");
    }
    // Kami writes USD as text only, and says so.
    let e = formats::write(&tmp("out.usdc"), &g)
        .unwrap_err()
        .to_string();
    assert!(e.contains("writes USD as text"), "{e}");
    let lin = g.clone().into_linear();
    let want = field(&expected, "points");
    let size = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let e = worst(&flat3(&lin.points), &want, size);
    assert!(e < 1e-6, "points off by {e:e}");
    let out = tmp("single-out.usda");
    let status = Command::new(env!("CARGO_BIN_EXE_kami"))
        .args(["convert"])
        .arg(&path)
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let back = python("read", &out);
    let curve = &back.iter().find(|l| l.0 == "curve").unwrap().1;
    assert_eq!(curve, &["cubic", "catmullRom", "pinned"]);
    assert_eq!(field(&back, "counts"), vec![4.0, 6.0, 2.0]);
    let pts: Vec<f64> = field(&back, "points");
    assert_eq!(pts, flat3(&g.points), "control points written as read");
    let mpu = back.iter().find(|l| l.0 == "metersPerUnit").unwrap();
    assert_eq!(mpu.1, ["0.01", "upAxis", "Y"]);
    // And Kami reads its own cubic file back exactly.
    assert_eq!(formats::read(&out).unwrap(), g);
    // A format without cubic curves gets the polylines.
    let hair = tmp("single.hair");
    formats::write(&hair, &g).unwrap();
    let h = formats::read(&hair).unwrap();
    assert_eq!(h.counts, lin.counts);
    assert_eq!(h.points, lin.points);
}

/// The bases at parameters whose points the spec fixes, without Python: Catmull-Rom through
/// its inner points, a B-spline segment starting at (P0 + 4 P1 + P2) / 6, Bézier through
/// every third point, pinned curves through both ends, periodic curves closed.
#[test]
fn bases_pass_where_the_spec_says() {
    let p: Vec<DVec3> = (0..7)
        .map(|i| DVec3::new(i as f64, (i * i) as f64 * 0.3, (i as f64).sin()))
        .collect();
    let at = |b, w, pts: &[DVec3], u| curves::point_at(b, w, pts, u).unwrap();
    let close = |a: DVec3, b: DVec3| assert!((a - b).length() < 1e-12, "{a} != {b}");
    for s in 0..4 {
        close(
            at(Basis::CatmullRom, Wrap::Nonperiodic, &p, s as f64),
            p[s + 1],
        );
        close(
            at(Basis::Bspline, Wrap::Nonperiodic, &p, s as f64),
            (p[s] + 4.0 * p[s + 1] + p[s + 2]) / 6.0,
        );
    }
    close(at(Basis::CatmullRom, Wrap::Nonperiodic, &p, 4.0), p[5]);
    for s in 0..2 {
        close(at(Basis::Bezier, Wrap::Nonperiodic, &p, s as f64), p[3 * s]);
    }
    close(at(Basis::Bezier, Wrap::Nonperiodic, &p, 2.0), p[6]);
    // Bézier at t = 1/2: (P0 + 3 P1 + 3 P2 + P3) / 8.
    close(
        at(Basis::Bezier, Wrap::Nonperiodic, &p, 0.5),
        (p[0] + 3.0 * p[1] + 3.0 * p[2] + p[3]) / 8.0,
    );
    // Catmull-Rom at t = 1/2: (-P0 + 9 P1 + 9 P2 - P3) / 16.
    close(
        at(Basis::CatmullRom, Wrap::Nonperiodic, &p, 0.5),
        (-p[0] + 9.0 * p[1] + 9.0 * p[2] - p[3]) / 16.0,
    );
    for b in [Basis::Bspline, Basis::CatmullRom] {
        close(at(b, Wrap::Pinned, &p, 0.0), p[0]);
        close(at(b, Wrap::Pinned, &p, 6.0), p[6]);
        // Periodic: the end is the start.
        let segs = curves::segments(b, Wrap::Periodic, 7).unwrap();
        close(
            at(b, Wrap::Periodic, &p, segs as f64),
            at(b, Wrap::Periodic, &p, 0.0),
        );
    }
    // Into polylines: 8 samples a segment, then the end; pinned Catmull-Rom through every point.
    let g = Groom {
        counts: vec![7],
        points: p.iter().map(|v| v.as_vec3().to_array()).collect(),
        basis: Basis::CatmullRom,
        wrap: Wrap::Pinned,
        ..Groom::default()
    };
    let lin = g.clone().into_linear();
    assert_eq!(lin.counts, vec![6 * 8 + 1]);
    for (i, q) in g.points.iter().enumerate() {
        let s = lin.points[8 * i];
        let d = (0..3).map(|k| (s[k] - q[k]).abs()).fold(0.0f32, f32::max);
        assert!(d < 1e-5, "control point {i} missed by {d}");
    }
}

/// Counts a basis cannot make, unknown tokens, a bad unit or axis, an op the order names
/// but the prim lacks, a singular inverted op and varying values that do not fit: errors
/// naming the file and line.
#[test]
fn bad_cubic_files_name_the_place() {
    let curve = |head: &str, body: &str| {
        format!("#usda 1.0\n{head}\ndef BasisCurves \"c\" {{\n{body}\n}}\n")
    };
    let pts = "int[] curveVertexCounts = [5]\npoint3f[] points = [(0,0,0),(0,1,0),(0,2,0),(0,3,0),(0,4,0)]";
    let cases = [
        (
            curve("", &format!("uniform token type = \"cubic\"\nuniform token basis = \"bezier\"\n{pts}")),
            ":6: curve 0 has 5 points, which make no nonperiodic bezier curve: it needs 3k + 1 points",
        ),
        (
            curve("", &format!("uniform token type = \"cubic\"\nuniform token basis = \"hermite\"\n{pts}")),
            ":5: basis \"hermite\" is not one Kami evaluates",
        ),
        (
            curve("", &format!("uniform token type = \"cubic\"\nuniform token basis = \"bspline\"\nuniform token wrap = \"loop\"\n{pts}")),
            ":6: wrap \"loop\" is not nonperiodic, periodic or pinned",
        ),
        (
            curve("(\n    metersPerUnit = -1\n)", &format!("uniform token type = \"linear\"\n{pts}")),
            ":3: metersPerUnit is -1; it must be a positive number",
        ),
        (
            curve("(\n    upAxis = \"X\"\n)", &format!("uniform token type = \"linear\"\n{pts}")),
            ":3: upAxis is \"X\"",
        ),
        (
            curve("", &format!("uniform token type = \"linear\"\nuniform token[] xformOpOrder = [\"xformOp:translate\"]\n{pts}")),
            ":5: xformOpOrder names \"xformOp:translate\", which this prim does not set",
        ),
        (
            curve("", &format!("uniform token type = \"linear\"\nfloat3 xformOp:scale = (0, 1, 1)\nuniform token[] xformOpOrder = [\"!invert!xformOp:scale\"]\n{pts}")),
            ":5: xformOp:scale cannot be inverted",
        ),
        (
            curve("", &format!("uniform token type = \"cubic\"\nuniform token basis = \"bspline\"\n{pts}\nfloat[] widths = [1, 2, 3, 4] (interpolation = \"varying\")")),
            ":8: `widths` has 4 values with interpolation \"varying\", which does not fit 1 curves of 5 points (3 segment ends)",
        ),
    ];
    for (i, (text, want)) in cases.iter().enumerate() {
        let name = format!("bad{i}.usda");
        let e = formats::parse(&name, text.as_bytes())
            .err()
            .unwrap_or_else(|| panic!("case {i} was read:\n{text}"))
            .to_string();
        assert!(
            e.contains(&format!("{name}{want}")),
            "case {i}: {e}\n{text}"
        );
    }
}

/// A prim naming no `type` is what USD says (cubic Bézier) when its counts make Bézier
/// curves, and linear with a warning when they cannot (hand-written and older files).
#[test]
fn untyped_curves_follow_usd_or_are_read_linear_with_a_warning() {
    let file = |counts: &str, pts: &str| {
        format!("#usda 1.0\ndef BasisCurves \"c\" {{\n    int[] curveVertexCounts = [{counts}]\n    point3f[] points = [{pts}]\n}}\n")
    };
    let four = "(0,0,0),(0,1,0),(1,1,0),(1,0,0)";
    let (g, warned) =
        crate::common::warnings(|| formats::parse("b.usda", file("4", four).as_bytes()));
    let g = g.unwrap();
    assert_eq!((g.basis, g.counts.clone()), (Basis::Bezier, vec![4]));
    assert!(warned.is_empty(), "{warned:?}");
    let (g, warned) = crate::common::warnings(|| {
        formats::parse(
            "l.usda",
            file("2, 4", &format!("(5,5,5),(5,6,5),{four}")).as_bytes(),
        )
    });
    let g = g.unwrap();
    assert_eq!((g.basis, g.counts.clone()), (Basis::Linear, vec![2, 4]));
    assert!(
        warned.len() == 1 && warned[0].contains("l.usda:2: this BasisCurves names no `type`"),
        "{warned:?}"
    );
}

/// The same faults in crate files and packages (saved by Pixar's USD): errors name the
/// file and the prim's path, as the text reader names the line.
#[test]
fn bad_crate_files_name_the_file_and_prim() {
    let pts = "int[] curveVertexCounts = [5]\npoint3f[] points = [(0,0,0),(0,1,0),(0,2,0),(0,3,0),(0,4,0)]";
    let cases = [
        (
            format!("uniform token type = \"cubic\"\nuniform token basis = \"bezier\"\n{pts}"),
            "curve 0 has 5 points, which make no nonperiodic bezier curve: it needs 3k + 1 points",
        ),
        (
            format!("uniform token type = \"linear\"\nuniform token[] xformOpOrder = [\"xformOp:translate\"]\n{pts}"),
            "xformOpOrder names \"xformOp:translate\", which this prim does not set",
        ),
        (
            format!("uniform token type = \"cubic\"\nuniform token basis = \"bspline\"\n{pts}\nfloat[] widths = [1, 2, 3, 4] (interpolation = \"varying\")"),
            "`widths` has 4 values with interpolation \"varying\", which does not fit 1 curves of 5 points (3 segment ends)",
        ),
    ];
    for (i, (body, want)) in cases.iter().enumerate() {
        let text = tmp(&format!("badc{i}.usda"));
        std::fs::write(
            &text,
            format!("#usda 1.0\ndef Xform \"g\" {{\ndef BasisCurves \"c\" {{\n{body}\n}}\n}}\n"),
        )
        .unwrap();
        for ext in ["usdc", "usdz"] {
            let path = tmp(&format!("badc{i}.{ext}"));
            crate_of(&text, &path);
            let e = formats::read(&path)
                .err()
                .unwrap_or_else(|| panic!("case {i} ({ext}) was read"))
                .to_string();
            let place = format!("badc{i}.{ext}, prim /g/c: {want}");
            assert!(e.contains(&place), "case {i} ({ext}): {e}");
        }
    }
}

/// Damaged binary USD: a crate file cut short or garbled after its magic, a package that
/// is no zip, an empty one, one whose first file is no USD layer: errors naming the file,
/// never a panic.
#[test]
fn damaged_binary_usd_is_refused_with_the_file_named() {
    let path = tmp("whole.usdc");
    python("mixed", &path);
    let whole = std::fs::read(&path).unwrap();
    let mut garbled = whole.clone();
    for b in garbled[16..64].iter_mut() {
        *b = 0xff;
    }
    let zip_of = |name: &str, body: &[u8]| -> Vec<u8> {
        use std::io::Write;
        let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        if !name.is_empty() {
            w.start_file(
                name,
                zip::write::SimpleFileOptions::default()
                    .compression_method(zip::CompressionMethod::Stored),
            )
            .unwrap();
            w.write_all(body).unwrap();
        }
        w.finish().unwrap().into_inner()
    };
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("cut.usdc", whole[..whole.len() / 2].to_vec(), "cut.usdc"),
        ("garbled.usdc", garbled, "garbled.usdc"),
        (
            "text.usdc",
            b"#usda 1.0\n".to_vec(),
            "does not begin with `PXR-USDC`",
        ),
        (
            "notzip.usdz",
            b"not a zip at all".to_vec(),
            "not a USDZ package",
        ),
        ("empty.usdz", zip_of("", b""), "the package is empty"),
        (
            "png.usdz",
            zip_of("tex.png", b"\x89PNG"),
            "USDZ's root layer is a .usda, .usdc or .usd",
        ),
        (
            "cutinside.usdz",
            zip_of("a.usdc", &whole[..100]),
            "cutinside.usdz (a.usdc)",
        ),
        (
            "plain.usd",
            b"#usda 1.0\n".to_vec(),
            "no `def BasisCurves` prim",
        ),
    ];
    for (name, bytes, want) in cases {
        let e = formats::parse(name, &bytes)
            .err()
            .unwrap_or_else(|| panic!("{name} was read"))
            .to_string();
        assert!(e.starts_with(name) && e.contains(want), "{name}: {e}");
    }
}
