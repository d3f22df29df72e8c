//! Strand files both ways (`kami::formats`): exact round trips of `.hair`, OBJ and usda, a
//! `.hair` made byte by byte from the spec, the defaults of absent arrays, the OBJ and usda
//! forms other tools write, an error naming the file for every kind of broken input, and
//! Pixar's own USD (the `usd-core` wheel) reading what Kami writes. No GPU needed.

use kami::formats::{self, Groom};
use std::path::PathBuf;
use std::process::Command;

/// A fresh path in the temp dir, unique per test process and name.
fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kami-formats-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Three strands of different lengths with awkward f32 values (tiny, huge, negative zero,
/// a subnormal, values with no short decimal).
fn groom() -> Groom {
    let points = vec![
        [0.0, 1.0, 2.0],
        [0.1, -0.2, 0.3],
        [1e-7, 3.402_823e38, -0.0],
        [f32::MIN_POSITIVE / 4.0, 1.0 / 3.0, 2.0f32.sqrt()],
        [-5.5, 6.25, 7.125],
        [std::f32::consts::PI, -std::f32::consts::E, 123_456.79],
        [0.7, 0.8, 0.9],
        [8.0, 9.0, 10.0],
        [-1.0, -2.0, -3.0],
    ];
    let n = points.len();
    Groom {
        counts: vec![3, 2, 4],
        points,
        widths: Some((0..n).map(|i| 0.01 + i as f32 / 7.0).collect()),
        // 0.5 and up: 1 - (1 - o) is exact (the .hair writer stores transparency).
        opacities: Some((0..n).map(|i| 0.5 + i as f32 / 17.0).collect()),
        colors: Some(
            (0..n)
                .map(|i| [i as f32 / 9.0, 0.25, 1.0 / (i as f32 + 3.0)])
                .collect(),
        ),
        ..Groom::default()
    }
}

/// Equal bit for bit (so -0.0 and 0.0 differ).
fn assert_same(a: &Groom, b: &Groom) {
    let bits = |g: &Groom| {
        (
            g.counts.clone(),
            g.points
                .iter()
                .flatten()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>(),
            g.widths
                .as_ref()
                .map(|w| w.iter().map(|v| v.to_bits()).collect::<Vec<_>>()),
            g.opacities
                .as_ref()
                .map(|w| w.iter().map(|v| v.to_bits()).collect::<Vec<_>>()),
            g.colors
                .as_ref()
                .map(|w| w.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>()),
        )
    };
    assert_eq!(bits(a), bits(b));
    assert_eq!(a, b);
}

fn round_trip(name: &str, g: &Groom) -> Groom {
    let path = tmp(name);
    formats::write(&path, g).unwrap_or_else(|e| panic!("write {name}: {e}"));
    formats::read(&path).unwrap_or_else(|e| panic!("read {name}: {e}"))
}

#[test]
fn hair_round_trip_is_exact() {
    let g = groom();
    assert_same(&round_trip("all.hair", &g), &g);
    // Strands of one length use the default segment count, and no attributes at all.
    let bare = Groom {
        counts: vec![3, 3, 3],
        widths: None,
        opacities: None,
        colors: None,
        ..g.clone()
    };
    assert_same(&round_trip("bare.hair", &bare), &bare);
    // Only some attributes: the arrays that are there are read in the right slots.
    let some = Groom {
        widths: None,
        ..g.clone()
    };
    assert_same(&round_trip("some.hair", &some), &some);
    let bytes = std::fs::read(tmp("bare.hair")).unwrap();
    assert_eq!(
        bytes.len(),
        128 + 9 * 12,
        "no segments array for equal strands"
    );
}

#[test]
fn obj_round_trip_is_exact() {
    let g = groom();
    // OBJ keeps points (and colours on `v x y z r g b`), not widths or opacities.
    let kept = Groom {
        widths: None,
        opacities: None,
        ..g.clone()
    };
    assert_same(&round_trip("all.obj", &g), &kept);
    let bare = Groom {
        colors: None,
        ..kept.clone()
    };
    assert_same(&round_trip("bare.obj", &bare), &bare);
}

/// Equal bit for bit but the colours, which go through USD's linear `displayColor` and back
/// (sRGB in Kami): within 2 ulps of 1.
fn assert_same_but_colours(a: &Groom, b: &Groom) {
    let (ca, cb) = (a.colors.clone(), b.colors.clone());
    assert_eq!(ca.is_some(), cb.is_some());
    for (x, y) in ca.iter().flatten().zip(cb.iter().flatten()) {
        for k in 0..3 {
            assert!(
                (x[k] - y[k]).abs() <= 2.0 * f32::EPSILON,
                "colour {x:?} != {y:?}"
            );
        }
    }
    let strip = |g: &Groom| Groom {
        colors: None,
        ..g.clone()
    };
    assert_same(&strip(a), &strip(b));
}

#[test]
fn usda_round_trip_is_exact() {
    let g = groom();
    assert_same_but_colours(&round_trip("all.usda", &g), &g);
    let bare = Groom {
        widths: None,
        opacities: None,
        colors: None,
        ..g.clone()
    };
    assert_same(&round_trip("bare.usda", &bare), &bare);
}

/// A 128-byte header as the spec lays it out, field by field.
fn header(
    strands: u32,
    points: u32,
    flags: u32,
    segs: u32,
    thick: f32,
    transp: f32,
    rgb: [f32; 3],
) -> Vec<u8> {
    let mut b = b"HAIR".to_vec();
    b.extend(strands.to_le_bytes());
    b.extend(points.to_le_bytes());
    b.extend(flags.to_le_bytes());
    b.extend(segs.to_le_bytes());
    b.extend(thick.to_le_bytes());
    b.extend(transp.to_le_bytes());
    for c in rgb {
        b.extend(c.to_le_bytes());
    }
    let mut info = [0u8; 88];
    info[..10].copy_from_slice(b"hand-made ");
    b.extend(info);
    assert_eq!(b.len(), 128);
    b
}

fn f32s(b: &mut Vec<u8>, v: &[f32]) {
    for x in v {
        b.extend(x.to_le_bytes());
    }
}

#[test]
fn hair_written_by_hand_from_the_spec() {
    // Two strands (2 and 1 segments), arrays: segments, points, transparency; thickness and
    // colour come from the header's defaults.
    let mut b = header(2, 5, 0b01011, 9, 0.5, 0.9, [0.2, 0.3, 0.4]);
    b.extend(2u16.to_le_bytes());
    b.extend(1u16.to_le_bytes());
    let pts = [0., 0., 0., 0., 1., 0., 0., 2., 0., 5., 0., 0., 5., 1., 0.5];
    f32s(&mut b, &pts);
    f32s(&mut b, &[0.0, 0.25, 0.5, 0.75, 1.0]);
    let g = formats::parse("hand.hair", &b).unwrap();
    assert_eq!(g.counts, vec![3, 2]);
    assert_eq!(g.points[4], [5.0, 1.0, 0.5]);
    assert_eq!(g.widths, Some(vec![0.5; 5]));
    assert_eq!(g.opacities, Some(vec![1.0, 0.75, 0.5, 0.25, 0.0]));
    assert_eq!(g.colors, Some(vec![[0.2, 0.3, 0.4]; 5]));

    // No segments array: every strand has the default count; thickness and colour arrays.
    let mut b = header(2, 6, 0b10110, 2, 0.0, 0.0, [0.0; 3]);
    f32s(&mut b, &[1.0; 18]);
    f32s(&mut b, &[0.1, 0.2, 0.3, 0.4, 0.5, 0.6]);
    f32s(&mut b, &[0.5; 18]);
    let g = formats::parse("defaults.hair", &b).unwrap();
    assert_eq!(g.counts, vec![3, 3]);
    assert_eq!(g.widths.as_ref().unwrap()[5], 0.6);
    assert_eq!(g.opacities, None, "transparency 0 by default: opaque");
    assert_eq!(g.colors, Some(vec![[0.5; 3]; 6]));
}

/// The error for `bytes` read as `name`, as the user sees it.
fn error(name: &str, bytes: &[u8]) -> String {
    let path = tmp(name);
    std::fs::write(&path, bytes).unwrap();
    let e = formats::read(&path).expect_err(name).to_string();
    assert!(
        e.contains(&path.display().to_string()),
        "{name}: the error does not name the file: {e}"
    );
    e
}

fn expect(name: &str, bytes: &[u8], words: &str) {
    let e = error(name, bytes);
    assert!(e.contains(words), "{name}: expected {words:?} in {e:?}");
}

#[test]
fn broken_hair_files_are_refused() {
    let good = formats::parse("x.hair", &{
        let mut b = header(1, 2, 0b11, 0, 0.0, 0.0, [0.0; 3]);
        b.extend(1u16.to_le_bytes());
        f32s(&mut b, &[0.0; 6]);
        b
    });
    assert!(good.is_ok(), "{good:?}");
    expect("short.hair", b"HAIR", "too short");
    let mut bad_magic = header(1, 2, 2, 1, 0.0, 0.0, [0.0; 3]);
    bad_magic[0] = b'X';
    f32s(&mut bad_magic, &[0.0; 6]);
    expect("magic.hair", &bad_magic, "not a .hair file");
    // 4 billion points claimed in a 200-byte file: refused before any allocation.
    let mut huge = header(1, u32::MAX, 2, 1, 0.0, 0.0, [0.0; 3]);
    huge.resize(200, 0);
    expect("huge.hair", &huge, "truncated");
    let mut huge_strands = header(u32::MAX, 2, 3, 0, 0.0, 0.0, [0.0; 3]);
    huge_strands.resize(200, 0);
    expect("huge_strands.hair", &huge_strands, "truncated");
    let mut truncated = header(1, 2, 2, 1, 0.0, 0.0, [0.0; 3]);
    f32s(&mut truncated, &[0.0; 5]);
    expect(
        "truncated.hair",
        &truncated,
        "needs 152 bytes but the file has 148",
    );
    let mut trailing = header(1, 2, 2, 1, 0.0, 0.0, [0.0; 3]);
    f32s(&mut trailing, &[0.0; 7]);
    expect("trailing.hair", &trailing, "trailing");
    let mut sum = header(2, 4, 3, 0, 0.0, 0.0, [0.0; 3]);
    sum.extend(1u16.to_le_bytes());
    sum.extend(2u16.to_le_bytes());
    f32s(&mut sum, &[0.0; 12]);
    expect(
        "sum.hair",
        &sum,
        "adds up to 5 points but the header says 4",
    );
    let mut defaults = header(2, 5, 2, 1, 0.0, 0.0, [0.0; 3]);
    f32s(&mut defaults, &[0.0; 15]);
    expect(
        "default_count.hair",
        &defaults,
        "are 4 points, but the header says 5",
    );
    let mut nan = header(1, 2, 2, 1, 0.0, 0.0, [0.0; 3]);
    f32s(&mut nan, &[0.0, 0.0, 0.0, 0.0, f32::NAN, 0.0]);
    expect("nan.hair", &nan, "byte 144: point 1 is not finite");
    let mut inf = header(1, 2, 2, 1, 0.0, 0.0, [0.0; 3]);
    f32s(&mut inf, &[f32::INFINITY, 0.0, 0.0, 0.0, 0.0, 0.0]);
    expect("inf.hair", &inf, "point 0 is not finite");
    let mut no_points = header(1, 2, 1, 0, 0.0, 0.0, [0.0; 3]);
    no_points.extend(1u16.to_le_bytes());
    expect("no_points.hair", &no_points, "no points array");
    let mut zero = header(2, 3, 3, 0, 0.0, 0.0, [0.0; 3]);
    zero.extend(1u16.to_le_bytes());
    zero.extend(0u16.to_le_bytes());
    f32s(&mut zero, &[0.0; 9]);
    expect("zero_segments.hair", &zero, "strand 1 has 0 segments");
    let mut no_default = header(1, 2, 2, 0, 0.0, 0.0, [0.0; 3]);
    f32s(&mut no_default, &[0.0; 6]);
    expect("no_default.hair", &no_default, "default segment count is 0");
}

#[test]
fn obj_as_other_tools_write_it() {
    let text = "# a comment\nmtllib x.mtl\no hair\ng strands\nv 0 0 0\nv 1 0 0 # trailing\nv 2 0 0\nvt 0 0\n\
                v 0 1 0\nv 0 2 0\nf 1 2 3\nl 1/1 2/1 3/1\nl -2 -1\nv 5 5 5\nv 6 6 6\nl -2 \\\n -1\n";
    let g = formats::parse("tools.obj", text.as_bytes()).unwrap();
    assert_eq!(g.counts, vec![3, 2, 2]);
    assert_eq!(g.strand(1), &[[0.0, 1.0, 0.0], [0.0, 2.0, 0.0]]);
    assert_eq!(g.strand(2), &[[5.0, 5.0, 5.0], [6.0, 6.0, 6.0]]);
    assert_eq!(g.colors, None);
}

#[test]
fn broken_obj_files_are_refused() {
    expect(
        "zero.obj",
        b"v 0 0 0\nv 1 1 1\nl 0 1\n",
        ".obj:3: vertex index 0 is out of range",
    );
    expect(
        "range.obj",
        b"v 0 0 0\nv 1 1 1\nl 1 3\n",
        ":3: vertex index 3 is out of range: 2 vertices",
    );
    expect(
        "negative.obj",
        b"v 0 0 0\nv 1 1 1\nl -3 1\n",
        ":3: vertex index -3 is out of range",
    );
    expect(
        "word.obj",
        b"v 0 0 0\nv 1 1 1\nl 1 x\n",
        ":3: `x` is not a vertex index",
    );
    expect("number.obj", b"v 0 zero 0\n", ":1: `zero` is not a number");
    expect(
        "short_v.obj",
        b"v 0 0\n",
        ":1: a `v` record needs 3 coordinates",
    );
    expect(
        "nan.obj",
        b"v 0 0 0\nv nan 0 0\nl 1 2\n",
        ":2: vertex 2 is not finite",
    );
    expect(
        "inf.obj",
        b"v 0 0 0\nv 0 -inf 0\nl 1 2\n",
        ":2: vertex 2 is not finite",
    );
    expect(
        "one.obj",
        b"v 0 0 0\nl 1\n",
        ":2: an `l` record needs at least 2 vertices",
    );
    expect(
        "faces.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "no `l` records",
    );
    expect(
        "latin1.obj",
        b"v 0 0 0\n# caf\xe9\n",
        ":2: the text is not UTF-8",
    );
}

const CUBIC: &str = r#"#usda 1.0
(
    defaultPrim = "root"
    upAxis = "Y"
    metersPerUnit = 0.01
)

def Xform "root" (
    kind = "component"
)
{
    double3 xformOp:translate = (1, 2, 3)
    uniform token[] xformOpOrder = ["xformOp:translate"]

    def BasisCurves "curves" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {
        uniform token basis = "bspline"
        uniform token type = "cubic"
        uniform token wrap = "pinned"
        int[] curveVertexCounts = [4, 5]
        point3f[] points = [(0, 0, 0), (0, 1, 0), (0, 2, 0), (0, 3, 0),
            (1, 0, 0), (1, 1, 0), (1, 2, 0), (1, 3, 0), (1, 4, 0.5)]
        float[] widths = [0.02] (
            interpolation = "constant"
        )
        color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0)] (
            interpolation = "uniform"
        )
        float3[] extent = [(0, 0, 0), (1, 4, 0.5)]
        rel material:binding = </root/mat>
        custom string note = "a } in a string"
    }

    def "untyped" { }

    def BasisCurves "more"
    {
        matrix4d xformOp:transform = ( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (5, 5, 5, 1) )
        uniform token[] xformOpOrder = ["xformOp:transform"]
        texCoord2f[] primvars:st = [(0, 0), (1, 1)] (
            interpolation = "vertex"
        )
        normal3f[] normals
        uniform token type = "linear"
        int[] curveVertexCounts = [2]
        point3f[] points.timeSamples = {
            1: [(9, 9, 9), (9, 10, 9)],
            2: [(8, 8, 8), (8, 9, 8)],
        }
        float[] widths = [0.5, 0.25]
        color3f[] primvars:displayColor = [(0, 0, 1)]
        int[] primvars:displayColor:indices = [0, 0]
    }
}
"#;

#[test]
fn usda_cubic_constant_width_and_two_prims() {
    let g = formats::parse("cubic.usda", CUBIC.as_bytes()).unwrap();
    // A pinned B-spline prim and a linear one: both become polylines (8 samples a cubic
    // segment, then the end; linear curves as they are).
    assert_eq!(
        (g.basis, g.wrap),
        (formats::Basis::Linear, formats::Wrap::Nonperiodic)
    );
    assert_eq!(g.counts, vec![3 * 8 + 1, 4 * 8 + 1, 2]);
    // Pinned: through the first and last control points, moved by the parent's translate.
    assert_eq!(g.points[0], [1.0, 2.0, 3.0]);
    assert_eq!(g.points[24], [1.0, 5.0, 3.0]);
    assert_eq!(g.points[57], [2.0, 6.0, 3.5]);
    // The first time sample, under the prim's transform and its parent's.
    assert_eq!(g.points[58], [15.0, 16.0, 17.0]);
    assert_eq!(g.points[59], [15.0, 17.0, 17.0]);
    let mut widths = vec![0.02; 58];
    widths.extend([0.5, 0.25]);
    assert_eq!(g.widths, Some(widths));
    let c = g.colors.as_ref().unwrap();
    assert_eq!(c[24], [1.0, 0.0, 0.0]);
    assert_eq!(c[25], [0.0, 1.0, 0.0]);
    assert_eq!(c[58], [0.0, 0.0, 1.0]);
    assert_eq!(g.opacities, None);
}

#[test]
fn broken_usda_files_are_refused() {
    let curves = |body: &str| format!("#usda 1.0\ndef BasisCurves \"c\"\n{{\n{body}\n}}\n");
    expect(
        "binary.usda",
        b"PXR-USDC\0\0",
        ":1: the first line is not `#usda 1.0`",
    );
    expect(
        "empty.usda",
        b"#usda 1.0\ndef Xform \"x\" {}\n",
        "no `def BasisCurves` prim",
    );
    expect(
        "no_counts.usda",
        curves("point3f[] points = [(0,0,0),(1,1,1)]").as_bytes(),
        ":2: this BasisCurves has no `curveVertexCounts`",
    );
    expect(
        "no_points.usda",
        curves("int[] curveVertexCounts = [2]").as_bytes(),
        ":2: this BasisCurves has no `point3f[] points`",
    );
    expect(
        "sum.usda",
        curves("int[] curveVertexCounts = [3]\npoint3f[] points = [(0,0,0),(1,1,1)]").as_bytes(),
        ":4: the curve vertex counts add up to 3 points but `points` (line 5) has 2",
    );
    expect(
        "one.usda",
        curves("int[] curveVertexCounts = [1, 1]\npoint3f[] points = [(0,0,0),(1,1,1)]").as_bytes(),
        ":4: curve vertex count 1 is not a whole number of 2 or more",
    );
    expect(
        "nan.usda",
        curves("int[] curveVertexCounts = [2]\npoint3f[] points = [(0,0,0),(nan,1,1)]").as_bytes(),
        ":5: point 1 is not finite",
    );
    expect(
        "inf.usda",
        curves("int[] curveVertexCounts = [2]\npoint3f[] points = [(0,0,0),(1,-inf,1)]").as_bytes(),
        ":5: point 1 is not finite",
    );
    expect(
        "widths.usda",
        curves("int[] curveVertexCounts = [2]\npoint3f[] points = [(0,0,0),(1,1,1)]\nfloat[] widths = [1, 2, 3] (interpolation = \"vertex\")")
            .as_bytes(),
        ":6: `widths` has 3 values with interpolation \"vertex\"",
    );
    expect(
        "tuples.usda",
        curves("int[] curveVertexCounts = [2]\npoint3f[] points = [(0,0,0),(1,1)]").as_bytes(),
        ":5: tuples of different sizes",
    );
    expect(
        "open.usda",
        b"#usda 1.0\ndef BasisCurves \"c\"\n{\nint[] curveVertexCounts = [2]\n",
        "a `}` is missing",
    );
    expect(
        "string.usda",
        b"#usda 1.0\ndef Xform \"c\n",
        ":2: a string or asset path is not closed",
    );
    expect(
        "array.usda",
        curves("int[] curveVertexCounts = [2").as_bytes(),
        ":5: `}` closes the `[` opened on line 4",
    );
    expect(
        "ends.usda",
        b"#usda 1.0\ndef BasisCurves \"c\" {\nint[] curveVertexCounts = [2,",
        "the file ends in the middle",
    );
}

#[test]
fn unknown_extensions_list_the_formats() {
    let e = formats::write(&tmp("x.abc"), &groom())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("x.abc") && e.contains(".hair") && e.contains(".obj") && e.contains(".usda"),
        "{e}"
    );
    // Binary USD is read, not written; an unknown extension lists what is.
    let e = formats::write(&tmp("x.usdz"), &groom())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("x.usdz") && e.contains("writes USD as text"),
        "{e}"
    );
    let e = formats::read(&tmp("x.fbx")).unwrap_err().to_string();
    assert!(
        e.contains("`.fbx` is not a strand format") && e.contains(".usdc"),
        "{e}"
    );
}

#[test]
fn writers_refuse_what_they_cannot_store() {
    let mut g = groom();
    g.points[2][1] = f32::NAN;
    let e = formats::write(&tmp("nan.usda"), &g)
        .unwrap_err()
        .to_string();
    assert!(e.contains("nan.usda") && e.contains("not finite"), "{e}");
    let long = Groom {
        counts: vec![70_000],
        points: vec![[0.0; 3]; 70_000],
        ..Groom::default()
    };
    let e = formats::write(&tmp("long.hair"), &long)
        .unwrap_err()
        .to_string();
    assert!(e.contains("at most 65536"), "{e}");
    let e = formats::write(&tmp("empty.obj"), &Groom::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("empty.obj") && e.contains("no strands"), "{e}");
}

#[test]
fn kami_convert_goes_through_every_format() {
    let g = groom();
    let hair = tmp("cli.hair");
    formats::write(&hair, &g).unwrap();
    let usda = tmp("cli.usda");
    let run = |a: &PathBuf, b: &PathBuf, extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_kami"))
            .arg("convert")
            .arg(a)
            .arg(b)
            .args(extra)
            .output()
            .unwrap()
    };
    let out = run(&hair, &usda, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("3 strands, 9 points"));
    assert_same_but_colours(&formats::read(&usda).unwrap(), &g);
    let obj = tmp("cli.obj");
    let out = run(&usda, &obj, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(formats::read(&obj).unwrap().points, g.points);
    // 2 x 3.4e38 is not a float: refused, naming the file it would have written.
    let out = run(&obj, &tmp("cli2.hair"), &["--scale", "2"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("cli2.hair") && err.contains("not finite"),
        "{err}"
    );
    let out = run(&obj, &tmp("cli3.usda"), &["--scale", "0.5"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let half = formats::read(&tmp("cli3.usda")).unwrap();
    assert_eq!(half.points[7], [4.0, 4.5, 5.0]);
    assert_eq!(half.widths, None);
    let out = run(&usda, &tmp("cli.txt"), &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains(".hair") && err.contains(".usda"),
        "{err}"
    );
}

/// Pixar's USD (pip `usd-core`) opens Kami's usda and sees the same curves.
#[test]
fn pixar_usd_reads_kami_usda() {
    let g = groom();
    let path = tmp("pixar.usda");
    formats::write(&path, &g).unwrap();
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/usd_check.py");
    let out = Command::new("python3").arg(&script).arg(&path).output();
    let out = match out {
        Ok(o) => o,
        Err(e) => panic!("python3 could not be run ({e}): install Python 3 and `python3 -m pip install usd-core`"),
    };
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("No module named 'pxr'"),
        "Pixar's USD is not installed: run `python3 -m pip install usd-core` (.ci/run does)"
    );
    assert!(out.status.success(), "usd_check.py failed: {stderr}");
    let mut lines = std::str::from_utf8(&out.stdout).unwrap().lines();
    assert_eq!(lines.next(), Some("curves 1"));
    let counts: Vec<u32> = lines
        .next()
        .unwrap()
        .split(' ')
        .skip(1)
        .map(|c| c.parse().unwrap())
        .collect();
    assert_eq!(counts, g.counts);
    let points: Vec<f32> = lines
        .next()
        .unwrap()
        .split(' ')
        .skip(1)
        .map(|c| c.parse().unwrap())
        .collect();
    let ours: Vec<f32> = g.points.iter().flatten().copied().collect();
    assert_eq!(
        points.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        ours.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        "USD read other points"
    );
    let widths: Vec<f32> = lines
        .next()
        .unwrap()
        .split(' ')
        .skip(1)
        .map(|c| c.parse().unwrap())
        .collect();
    assert_eq!(Some(widths), g.widths);
    assert_eq!(lines.next(), Some("interpolation vertex"));
}

/// Found in review: attributes out of their range, hostile nesting and bad indices in usda
/// are errors naming the file, never a crash (a stack overflow aborts the process).
#[test]
fn attributes_nesting_and_indices_are_checked() {
    // Transparency 2.0 would be opacity -1; a negative thickness.
    let mut b = header(1, 2, 0b01011, 0, 0.0, 0.0, [0.0; 3]);
    b.extend(1u16.to_le_bytes());
    f32s(&mut b, &[0.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    f32s(&mut b, &[0.0, 2.0]);
    expect("transparency.hair", &b, "outside 0..1");
    let mut b = header(1, 2, 0b00111, 0, 0.0, 0.0, [0.0; 3]);
    b.extend(1u16.to_le_bytes());
    f32s(&mut b, &[0.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    f32s(&mut b, &[0.1, -0.1]);
    expect("thickness.hair", &b, "negative");
    // 100,000 nested prims, and 300,000 nested time-sample dictionaries.
    let deep = format!("#usda 1.0\n{}", "def \"a\" {\n".repeat(100_000));
    expect("deep.usda", deep.as_bytes(), "nesting deeper");
    let deep = format!("#usda 1.0\nfloat x = {}", "{0:".repeat(300_000));
    expect("deep_values.usda", deep.as_bytes(), "nesting deeper");
    let indexed = "#usda 1.0\ndef BasisCurves \"c\" {\n    int[] curveVertexCounts = [2]\n    point3f[] points = [(0, 0, 0), (0, 1, 0)]\n    color3f[] primvars:displayColor = [(1, 0, 0), (0, 1, 0)] (interpolation = \"vertex\")\n    int[] primvars:displayColor:indices = [0, 1.5]\n}\n";
    expect("fraction.usda", indexed.as_bytes(), "not a whole number");
}
