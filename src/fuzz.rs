//! A mutation fuzzer for what users hand Kami: scene text (`Scene::from_bytes`, which
//! validates), OBJ, OFF and PLY meshes, and strand files (`.hair`, OBJ polylines, `.usda`,
//! Alembic `.abc`). cargo-fuzz needs nightly, so this one runs on
//! stable: a deterministic mutator (one seed, one run, on every machine) grows inputs from the
//! seed corpus in `tests/fuzz_corpus/`. There is no coverage feedback; an input whose outcome
//! is new (an error's words less what it echoes from the input, the field validation refused,
//! or success) joins the corpus instead.
//!
//! A finding is a panic, one allocation above `ALLOC_CAP` (only seen with `CappedAlloc` as
//! the global allocator), or an input accepted while breaking a promise: a scene holding a
//! non-finite number or not surviving `to_ron`, a mesh with non-finite positions, normals
//! that are not unit length, indices out of range, or bounds that overflow when fitted.
//! `tests/it/fuzz.rs` runs a short fixed-seed pass; `examples/fuzz.rs` the long one
//! (docs/fuzzing.md).

use crate::rng::Rng;
use crate::scene::mesh::Mesh;
use crate::systems::{Scene, KINDS};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::{Cell, RefCell};
use std::collections::HashSet;
use std::panic::{self, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;

/// What is fuzzed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Target {
    Scene,
    Obj,
    Off,
    Ply,
    /// Strand files (`crate::formats`).
    Hair,
    Lines,
    Usda,
    /// Binary USD crate files (`.usdc`) and packages (`.usdz`: the seeds' names say which).
    Usdc,
    Abc,
}

impl Target {
    pub const ALL: [Target; 9] = [
        Target::Scene,
        Target::Obj,
        Target::Off,
        Target::Ply,
        Target::Hair,
        Target::Lines,
        Target::Usda,
        Target::Usdc,
        Target::Abc,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Target::Scene => "scene",
            Target::Obj => "obj",
            Target::Off => "off",
            Target::Ply => "ply",
            Target::Hair => "hair",
            Target::Lines => "lines",
            Target::Usda => "usda",
            Target::Usdc => "usdc",
            Target::Abc => "abc",
        }
    }

    pub fn from_name(name: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The seed corpus of this target under the crate root.
    pub fn corpus_dir(self, root: &Path) -> PathBuf {
        root.join("tests/fuzz_corpus").join(self.name())
    }

    /// Tokens of the format, inserted whole: random bytes rarely spell `end_header`.
    fn dictionary(self) -> Vec<&'static str> {
        match self {
            Target::Scene => scene_words(),
            Target::Obj => OBJ_WORDS.to_vec(),
            Target::Off => OFF_WORDS.to_vec(),
            Target::Ply => PLY_WORDS.to_vec(),
            Target::Hair => HAIR_WORDS.to_vec(),
            Target::Lines => LINE_WORDS.to_vec(),
            Target::Usda => USDA_WORDS.to_vec(),
            Target::Usdc => USDC_WORDS.to_vec(),
            Target::Abc => ABC_WORDS.to_vec(),
        }
    }
}

/// The scene words every kind shares (head, camera, light, render settings, the forces,
/// RON's own tokens); each kind adds its block's words (`systems::Kind::fuzz_words`).
#[rustfmt::skip]
const SCENE_WORDS: &[&str] = &[
    "Scene(", "Head(", "EllipsoidDesc(", "CameraDesc(", "Light(", "RenderSettings(",
    "forces:", "ForcesDesc(", "WindKey(", "HeadKey(", "Some(", "None", "true", "false", "NaN", "inf", "-inf", "Step",
    "Linear", "File(\"x.obj\")", "seed:", "head:", "center:", "radii:", "color:", "visible:",
    "gravity:", "camera:", "light:", "render:", "name:", "length:", "direction:", "material:",
    "shininess:", "width:", "eye:", "target:", "up:", "fov_y:", "intensity:", "ambient:",
    "size:", "background:", "msaa:", "supersample:", "min_width:", "strands:", "wind:",
    "head_motion:", "frame:", "force:", "interp:", "rotate:", "translate:", "amplitude:",
    "period:", "mesh:", "radius:", "diffuse:", "specular:", "axis:", "#![enable(implicit_some)]",
    "#![enable(unwrap_newtypes)]", "#![enable(unwrap_variant_newtypes)]", "r#", "\"", "b\"",
    "'", "//", "/*", "*/", "0x", "(", ")", "[", "]", "{", "}", ",", ":",
];

/// The External Force Field's words (`scene::eff`): the `eff:` field of the scene's `forces` block.
#[rustfmt::skip]
const EFF_WORDS: &[&str] = &[
    "eff:", "EffDesc(", "EffSample(", "Blower(", "GustKey(", "extent:", "resolution:",
    "source:", "strength:", "samples:", "blowers:", "file:", "gust:", "at:", "toward:",
    "spread:", "scale:", "head_capture:",
];

/// Every scene word: the shared ones, the EFF's and each kind's, in `KINDS` order.
fn scene_words() -> Vec<&'static str> {
    let mut all = SCENE_WORDS.to_vec();
    all.extend_from_slice(EFF_WORDS);
    for kind in crate::systems::KINDS {
        all.extend_from_slice(kind.fuzz_words);
    }
    all
}

#[cfg(test)]
mod words {
    /// The scene fuzzer knows every kind's block and the EFF (once, its words lacked the
    /// wisps, the strips and the EFF).
    #[test]
    fn scene_words_hold_every_kind_and_the_eff() {
        let words = super::scene_words();
        for w in [
            "Wisps(",
            "Strips(",
            "EffDesc(",
            "HairGroup(",
            "Fur(",
            "Scene(",
        ] {
            assert!(words.contains(&w), "no {w} among the scene words");
        }
        for kind in crate::systems::KINDS {
            assert!(
                !kind.fuzz_words.is_empty(),
                "{} has no fuzz words",
                kind.name
            );
        }
    }
}

#[rustfmt::skip]
const OBJ_WORDS: &[&str] = &[
    "v ", "vn ", "vt ", "vp ", "f ", "l 1 2\n", "p 1\n", "o x\n", "g x\n", "s off\n", "s 1\n",
    "mtllib x.mtl\n", "usemtl x\n", "f 1 2 3\n", "f -1 -2 -3\n", "f 1/1/1 2/2/2 3/3/3\n",
    "f 1//1 2//2 3//3\n", "f 1/1 2/2 3/3\n", "f 1 2 3 4\n", "f 0 0 0\n", "f 4294967295 1 2\n",
    "f -4294967295 1 2\n", "v 0 0 0\n", "v 1e39 0 0\n", "vn 0 0 0\n", "vn 1e38 1e38 1e38\n",
    "v 1 2 3 4 5 6\n", "\\\n", "#", "/", "\n", " ",
];

#[rustfmt::skip]
const OFF_WORDS: &[&str] = &[
    "OFF", "OFF\n", "COFF", "NOFF", "4OFF", "nOFF", "STOFF", "3 0 1 2\n", "4 0 1 2 3\n",
    "3 0 0 0\n", "1000 ", "1001 ", "2 0 1\n", "0 0 0\n", "#", "# comment\n", "\n", " ",
    "49999999", "50000001", "4294967295 ", "18446744073709551615 ",
];

#[rustfmt::skip]
const PLY_WORDS: &[&str] = &[
    "ply\n", "format ascii 1.0\n", "format binary_little_endian 1.0\n",
    "format binary_big_endian 1.0\n", "format ascii 2.0\n", "comment x\n", "obj_info x\n",
    "element vertex ", "element face ", "element edge 1\n", "element vertex 4294967295\n",
    "element face 4294967295\n", "element vertex 0\n", "property float x\n",
    "property float y\n", "property float z\n", "property double x\n", "property double nx\n",
    "property float ny\n", "property float nz\n", "property uchar red\n",
    "property list uchar int vertex_indices\n", "property list uchar uint vertex_indices\n",
    "property list uint uint vertex_indices\n", "property list int int vertex_index\n",
    "property list uchar float vertex_indices\n", "property list ushort short vertex_indices\n",
    "end_header\n", "char ", "uchar ", "short ", "ushort ", "int ", "uint ", "float ",
    "double ", "int8 ", "uint8 ", "int32 ", "uint32 ", "float32 ", "float64 ", "3 0 1 2\n",
    "255 ", "\n", "\r\n", " ",
];

#[rustfmt::skip]
const HAIR_WORDS: &[&str] = &[
    "HAIR", "\u{0}\u{0}\u{0}\u{0}", "\u{ff}\u{ff}\u{ff}\u{ff}", "\u{1f}\u{0}\u{0}\u{0}",
    "\u{2}\u{0}\u{0}\u{0}", "\u{0}\u{0}\u{c0}\u{7f}", "\u{0}\u{0}\u{80}\u{7f}",
    "\u{1}\u{0}", "\u{ff}\u{ff}",
];

#[rustfmt::skip]
const LINE_WORDS: &[&str] = &[
    "v ", "l ", "l 1 2\n", "l 1 2 3 4\n", "l -1 -2\n", "l 1/1 2/2\n", "l 0 1\n",
    "l 4294967295 1\n", "l 1\n", "v 0 0 0\n", "v 1 2 3 0.5 0.5 0.5\n", "v nan 0 0\n",
    "v 1e39 0 0\n", "g x\n", "o x\n", "#", "\\\n", "/", "\n", " ",
];

/// The crate file's magic, its section names and sizes that stress the reader.
#[rustfmt::skip]
const USDC_WORDS: &[&str] = &[
    "PXR-USDC", "TOKENS", "STRINGS", "FIELDS", "FIELDSETS", "PATHS", "SPECS", "PK\x03\x04",
    "\u{0}\u{0}\u{0}\u{0}", "\u{7f}\u{7f}\u{7f}\u{7f}", "\u{1}\u{0}\u{0}\u{0}",
    "points", "curveVertexCounts", "BasisCurves", "xformOpOrder", "timeSamples",
];

#[rustfmt::skip]
const USDA_WORDS: &[&str] = &[
    "#usda 1.0\n", "def BasisCurves \"c\" {\n", "def Xform \"x\" {\n", "}\n", "(", ")", "[", "]",
    "{", "}", "\"", "uniform token type = \"linear\"\n", "uniform token type = \"cubic\"\n",
    "uniform token basis = \"bspline\"\n", "uniform token basis = \"bezier\"\n",
    "uniform token basis = \"catmullRom\"\n", "int[] curveVertexCounts = [", "point3f[] points = [",
    "float[] widths = [", "color3f[] primvars:displayColor = [",
    "float[] primvars:displayOpacity = [", "(interpolation = \"vertex\")",
    "(interpolation = \"constant\")", "(interpolation = \"uniform\")",
    "(interpolation = \"varying\")", "int[] primvars:displayColor:indices = [",
    "point3f[] points.timeSamples = {", "1: [", "(0, 0, 0)", "(1, 2, 3)", "(nan, 0, 0)",
    "double3 xformOp:translate = (1, 2, 3)\n", "matrix4d xformOp:transform = ( (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1) )\n",
    "uniform token wrap = \"periodic\"\n", "uniform token wrap = \"pinned\"\n",
    "uniform token[] xformOpOrder = [\"xformOp:translate\", \"!invert!xformOp:scale\"]\n",
    "uniform token[] xformOpOrder = [\"!resetXformStack!\", \"xformOp:transform\"]\n",
    "float3 xformOp:scale = (0, 1e30, 1)\n", "float3 xformOp:rotateZYX = (90, 1e39, 0)\n",
    "quatf xformOp:orient = (0, 0, 0, 0)\n", "(\n    metersPerUnit = 1e-40\n    upAxis = \"Z\"\n)\n",
    "class \"k\" {\n", "(active = false)",
    "2, ", "4294967295, ", ", ", "\n", " ",
];

/// Alembic's names and meta data, and Ogawa's empty-data marker. (The data bit, a byte
/// 0x80, cannot be a word of this UTF-8 list: `\u{80}` is two bytes.)
#[rustfmt::skip]
const ABC_WORDS: &[&str] = &[
    "Ogawa", ".geom", ".xform", ".ops", ".vals", ".inherits", ".indices", ".arbGeomParams", "P",
    "nVertices", "curveBasisAndType", "width", "Cs", "displayColor", "opacity",
    "schema=AbcGeom_Curve_v2", "schema=AbcGeom_Xform_v3", "geoScope=vtx", "geoScope=uni",
    "geoScope=var", "geoScope=con",
    "\u{0}\u{0}\u{0}\u{0}\u{0}\u{0}\u{0}\u{0}", "\u{10}\u{0}\u{0}\u{0}",
    "\u{1}\u{0}\u{0}\u{0}", "\u{2}\u{0}\u{0}\u{0}", "\u{3}\u{0}\u{0}\u{0}",
];

#[rustfmt::skip]
const NUMBERS: &[&str] = &[
    "0", "-0", "1", "-1", "2", "3", "NaN", "nan", "inf", "-inf", "infinity", "1e308", "-1e308",
    "1.7976931348623157e308", "1e309", "1e-320", "5e-324", "1e999999999", "1e-999999999", "255",
    "256", "65535", "65536", "2147483647", "-2147483648", "4294967295", "4294967296",
    "49999999", "50000001", "9223372036854775807", "18446744073709551615",
    "99999999999999999999999", "0.0000001", "1e6", "1e7", "1e9", "1e10", "1e38", "1e39", "0x10",
    "1_000",
];

#[rustfmt::skip]
const BYTES: &[u8] = &[
   
    0, 0xff, 0x7f, 0x80, 0xc3, b'(', b')', b'[', b']', b'{', b'}', b',', b':', b'\n', b'\r', b' ',
    b'"', b'\'', b'-', b'+', b'.', b'e', b'#', b'/', b'\\', b'0', b'9',
];

/// Inputs grow no larger than this (the seeds are under 5 KiB).
pub const MAX_INPUT: usize = 16 * 1024;
/// The corpus stops growing here.
const MAX_CORPUS: usize = 4096;

/// One problem found: `signature` leaves out the input's values so that the same bug found
/// twice is counted once; `detail` is the whole story.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Finding {
    pub signature: String,
    pub detail: String,
}

impl Finding {
    fn new(signature: impl Into<String>, detail: impl Into<String>) -> Finding {
        Finding {
            signature: signature.into(),
            detail: detail.into(),
        }
    }
}

/// Run one input of `target`: `Ok` with a short class of the outcome (used to grow the
/// corpus), or the finding.
pub fn run_one(target: Target, input: &[u8]) -> Result<String, Finding> {
    if let Some(path) = SAVE_EACH.get() {
        // Best effort: this is only for finding an input that kills the process.
        let _ = std::fs::write(path, input);
    }
    run_guarded(input, || check(target, input))
}

/// Run `f` on `input` under `catch_unwind`, counting a panic or an allocation above
/// `ALLOC_CAP` (made on this thread) as a finding.
pub fn run_guarded(
    input: &[u8],
    f: impl FnOnce() -> Result<String, Finding>,
) -> Result<String, Finding> {
    install_panic_hook();
    PANIC.with(|p| p.borrow_mut().take());
    INPUT.with(|i| i.set((input.as_ptr(), input.len())));
    BIGGEST.with(|b| b.set(0));
    ARMED.with(|a| a.set(true));
    let result = panic::catch_unwind(AssertUnwindSafe(f));
    ARMED.with(|a| a.set(false));
    INPUT.with(|i| i.set((std::ptr::null(), 0)));
    let biggest = BIGGEST.with(Cell::get);
    match result {
        Err(_) => {
            let (place, message) = PANIC
                .with(|p| p.borrow_mut().take())
                .unwrap_or_else(|| ("an unknown place".into(), "no message".into()));
            Err(Finding::new(
                format!("panic at {place}"),
                format!("panic at {place}: {message}"),
            ))
        }
        // A panic caught inside is a finding too (the input reached code that should have
        // refused it), except one contained where Kami calls a crate that indexes without
        // checking (openusd's crate reader, `formats::usdc::guarded`): an outcome of its
        // own, so that the run shows how often it happens.
        Ok(_) if PANIC.with(|p| p.borrow().is_some()) => {
            let (place, message) = PANIC
                .with(|p| p.borrow_mut().take())
                .unwrap_or_else(|| ("an unknown place".into(), "no message".into()));
            if place.contains("/openusd-") {
                return Ok(format!("contained panic in openusd at {place}"));
            }
            Err(Finding::new(
                format!("caught panic at {place}"),
                format!("a panic at {place}, caught and turned into an error: {message}"),
            ))
        }
        Ok(_) if biggest > ALLOC_CAP => Err(Finding::new(
            "allocation above the cap",
            format!(
                "one allocation of {biggest} bytes ({} MiB), above the {} MiB cap",
                biggest >> 20,
                ALLOC_CAP >> 20
            ),
        )),
        Ok(r) => r,
    }
}

/// The checks for one input, without the guards.
fn check(target: Target, input: &[u8]) -> Result<String, Finding> {
    let loaded = match target {
        Target::Scene => {
            return match Scene::from_bytes(input, "fuzz.ron") {
                Ok(scene) => check_scene(&scene).map(|_| "ok".into()),
                // Reaching a new field's check is progress.
                Err(crate::KamiError::Invalid { field, .. }) => {
                    Ok(field.replace(|c: char| c.is_ascii_digit(), ""))
                }
                Err(crate::KamiError::Parse { message, .. }) => Ok(class(&message, input)),
                Err(e) => Ok(class(&e.to_string(), input)),
            };
        }
        Target::Hair | Target::Lines | Target::Usda | Target::Usdc | Target::Abc => {
            let name = match target {
                Target::Hair => "fuzz.hair",
                Target::Lines => "fuzz.obj",
                Target::Abc => "fuzz.abc",
                // A package begins with the zip magic; a crate file with its own.
                Target::Usdc if input.starts_with(b"PK") => "fuzz.usdz",
                Target::Usdc => "fuzz.usdc",
                _ => "fuzz.usda",
            };
            return match crate::formats::parse(name, input) {
                Ok(groom) => check_groom(&groom).map(|_| "ok".into()),
                Err(crate::KamiError::Data { message, .. }) => Ok(class(&message, input)),
                Err(e) => Ok(class(&e.to_string(), input)),
            };
        }
        Target::Obj => Mesh::from_obj(&String::from_utf8_lossy(input), "fuzz.obj"),
        Target::Off => Mesh::from_off(&String::from_utf8_lossy(input), "fuzz.off"),
        Target::Ply => Mesh::from_ply(input, "fuzz.ply"),
    };
    match loaded {
        Ok(mesh) => check_mesh(&mesh).map(|_| "ok".into()),
        Err(crate::KamiError::Mesh { message, .. }) => Ok(class(&message, input)),
        Err(e) => Ok(class(&e.to_string(), input)),
    }
}

/// An outcome class: the first words of the message (lowercased, three letters or more, no
/// digit) that do not occur in the input, so that values and echoed tokens do not make every
/// error new (or the corpus fills with junk and the run slows).
fn class(message: &str, input: &[u8]) -> String {
    let input = input.to_ascii_lowercase();
    // Debug-escaped characters (`\u{fdee}`) are echoed input too.
    let mut bare = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(at) = rest.find("\\u{") {
        bare.push_str(&rest[..at]);
        bare.push(' ');
        rest = rest[at..].split_once('}').map_or("", |(_, r)| r);
    }
    bare.push_str(rest);
    bare.split(|c: char| !c.is_ascii_alphanumeric())
        .map(str::to_ascii_lowercase)
        .filter(|w| (3..=24).contains(&w.len()) && !w.bytes().any(|c| c.is_ascii_digit()))
        .filter(|w| !input.windows(w.len()).any(|x| x == w.as_bytes()))
        .take(4)
        .collect::<Vec<_>>()
        .join(" ")
}

/// What an accepted strand file promises: the groom's invariants (`Groom::check`: counts
/// that add up, two points or more per strand, finite points, one attribute per point),
/// finite attributes, curves that evaluate to polylines keeping all that (cubic USD), and
/// that it writes and reads back as `.hair` with its points equal
/// (unless it has more strands or points than a `.hair` file can count).
pub fn check_groom(g: &crate::formats::Groom) -> Result<(), Finding> {
    if let Err(e) = g.check("fuzz") {
        return Err(Finding::new(
            "accepted groom breaks its invariants",
            format!("accepted groom breaks its invariants: {e}"),
        ));
    }
    // Cubic curves are drawn as the polylines they evaluate to: those must hold too.
    let linear = g.clone().into_linear();
    if let Err(e) = linear.check("fuzz") {
        return Err(Finding::new(
            "evaluated curves break the invariants",
            format!(
                "an accepted groom's curves evaluate to polylines that break its invariants: {e}"
            ),
        ));
    }
    let g = &linear;
    let finite = g.widths.iter().flatten().all(|w| w.is_finite())
        && g.opacities.iter().flatten().all(|o| o.is_finite())
        && g.colors.iter().flatten().flatten().all(|c| c.is_finite());
    if !finite {
        return Err(Finding::new(
            "accepted groom has a non-finite attribute",
            "accepted groom has a non-finite width, opacity or colour",
        ));
    }
    // `.hair` counts strands and points in u32 and a strand's points in u16 (plus one): a
    // groom beyond that is the only one it may refuse to write.
    let fits = u32::try_from(g.counts.len()).is_ok()
        && u32::try_from(g.points.len()).is_ok()
        && g.counts.iter().all(|&c| c <= u16::MAX as u32 + 1);
    let bytes = match crate::formats::hair::to_bytes(g, "fuzz") {
        Ok(bytes) => bytes,
        Err(_) if !fits => return Ok(()),
        Err(e) => {
            return Err(Finding::new(
                "groom is not written as .hair",
                format!("an accepted groom that fits a .hair file is not written: {e}"),
            ))
        }
    };
    match crate::formats::parse("again.hair", &bytes) {
        Ok(back) if back.points == g.points && back.counts == g.counts => Ok(()),
        Ok(_) => Err(Finding::new(
            "groom changes through .hair",
            "an accepted groom written as .hair reads back with other points",
        )),
        Err(e) => Err(Finding::new(
            "groom does not read back",
            format!("an accepted groom written as .hair does not read back: {e}"),
        )),
    }
}

/// What an accepted scene promises: every number finite (validate checks them all), and
/// saving it gives a file that loads as the same scene.
pub fn check_scene(s: &Scene) -> Result<(), Finding> {
    if let Err(e) = crate::systems::validate(s) {
        return Err(Finding::new(
            "accepted scene fails validate",
            format!("accepted scene fails validate: {e}"),
        ));
    }
    let text = s.to_ron();
    if let Some(line) = non_finite_line(&text) {
        return Err(Finding::new(
            "accepted scene holds a non-finite number",
            format!("accepted scene holds a non-finite number: {}", line.trim()),
        ));
    }
    match Scene::from_ron(&text, "saved.ron") {
        Ok(back) if back == *s => {}
        Ok(_) => {
            return Err(Finding::new(
                "saved scene loads differently",
                format!("saved scene loads differently:\n{text}"),
            ))
        }
        Err(e) => {
            return Err(Finding::new(
                "saved scene does not load",
                format!("saved scene does not load: {e}\n{text}"),
            ))
        }
    }
    let _ = s.counts();
    for k in KINDS {
        (k.invariants)(s).map_err(|(signature, detail)| Finding::new(signature, detail))?;
    }
    Ok(())
}

/// The line of RON text holding `NaN` or `inf` outside a string, if any.
fn non_finite_line(text: &str) -> Option<&str> {
    text.lines().find(|line| {
        let mut in_string = false;
        let mut escaped = false;
        let mut word = String::new();
        for c in line.chars().chain([' ']) {
            if in_string {
                match (escaped, c) {
                    (true, _) => escaped = false,
                    (false, '\\') => escaped = true,
                    (false, '"') => in_string = false,
                    _ => {}
                }
            } else if c == '"' {
                in_string = true;
            } else if c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '+' | '-') {
                word.push(c);
            } else {
                let w = word.trim_start_matches(['+', '-']);
                if w == "inf" || w.contains("NaN") {
                    return true;
                }
                word.clear();
            }
        }
        false
    })
}

/// What a loaded mesh promises: finite positions, unit normals (one per vertex), indices in
/// range, and a bounding sphere that `fit` can use.
pub fn check_mesh(m: &Mesh) -> Result<(), Finding> {
    let fail = |sig: &str, detail: String| Err(Finding::new(sig, format!("{sig}: {detail}")));
    if m.positions.is_empty() || m.triangles.is_empty() {
        return fail("loaded mesh is empty", format!("{m:?}"));
    }
    if m.normals.len() != m.positions.len() {
        return fail(
            "loaded mesh has a normal count unlike its vertex count",
            format!(
                "{} normals, {} vertices",
                m.normals.len(),
                m.positions.len()
            ),
        );
    }
    if let Some(i) = m.positions.iter().position(|p| !p.is_finite()) {
        return fail(
            "loaded mesh has a non-finite position",
            format!("vertex {i} at {:?}", m.positions[i]),
        );
    }
    if let Some(i) = m
        .normals
        .iter()
        .position(|n| !n.is_finite() || (n.length() - 1.0).abs() > 1e-6)
    {
        return fail(
            "loaded mesh has a non-finite or non-unit normal",
            format!("normal {i} is {:?}", m.normals[i]),
        );
    }
    let n = m.positions.len();
    if let Some(t) = m
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= n))
    {
        return fail(
            "loaded mesh has an index out of range",
            format!("triangle {t:?} with {n} vertices"),
        );
    }
    let mut fitted = m.clone();
    fitted.fit(1.0);
    if let Some(i) = fitted.positions.iter().position(|p| !p.is_finite()) {
        return fail(
            "loaded mesh overflows when fitted",
            format!(
                "vertex {i} at {:?} becomes {:?} after fit(1.0) (bounds {:?})",
                m.positions[i],
                fitted.positions[i],
                m.bounds()
            ),
        );
    }
    Ok(())
}

/// The deterministic mutator.
pub struct Mutator {
    rng: Rng,
    dict: Vec<&'static str>,
}

impl Mutator {
    pub fn new(target: Target, seed: u64) -> Mutator {
        Mutator {
            rng: Rng::new(seed, 0xF022 + target as u64),
            dict: target.dictionary(),
        }
    }

    /// Uniform in [0, n) (0 when n is 0).
    fn below(&mut self, n: usize) -> usize {
        ((self.rng.next_u32() as u64 * n as u64) >> 32) as usize
    }

    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }

    /// A random range within `0..len`, at most `max` long.
    fn range(&mut self, len: usize, max: usize) -> std::ops::Range<usize> {
        let start = self.below(len + 1);
        let end = start + self.below((len - start).min(max) + 1);
        start..end
    }

    /// A new input: `base` with one to eight mutations, `corpus` giving splice material.
    pub fn mutate(&mut self, base: &[u8], corpus: &[Vec<u8>]) -> Vec<u8> {
        let mut d = base.to_vec();
        if self.below(4) == 0 {
            // One number changed and nothing else: the input stays well formed, so the
            // change reaches validation and the loaders' checks.
            self.replace_number(&mut d);
        } else {
            for _ in 0..1 << self.below(4) {
                self.once(&mut d, corpus);
            }
        }
        d.truncate(MAX_INPUT);
        d
    }

    fn once(&mut self, d: &mut Vec<u8>, corpus: &[Vec<u8>]) {
        let len = d.len();
        match self.below(12) {
            0 if len > 0 => {
                let i = self.below(len);
                d[i] ^= 1 << self.below(8);
            }
            1 if len > 0 => {
                let i = self.below(len);
                d[i] = *self.pick(BYTES);
            }
            2 => {
                let r = self.range(len, 64);
                d.drain(r);
            }
            3 => {
                let at = self.below(len + 1);
                let n = 1 + self.below(8);
                let bytes: Vec<u8> = (0..n)
                    .map(|_| match self.below(2) {
                        0 => *self.pick(BYTES),
                        _ => self.below(256) as u8,
                    })
                    .collect();
                d.splice(at..at, bytes);
            }
            4 => {
                // Repeats build deep nesting and long lists.
                let r = self.range(len, 32);
                let piece = d[r].to_vec();
                let most = if self.below(8) == 0 { 512 } else { 4 };
                let times = 1 + self.below(most);
                let at = self.below(len + 1);
                let grown: Vec<u8> = piece
                    .iter()
                    .copied()
                    .cycle()
                    .take(piece.len() * times)
                    .collect();
                d.splice(at..at, grown);
            }
            5 if !corpus.is_empty() => {
                let other = self.pick(corpus);
                let r = self.range(other.len(), 256);
                let piece = other[r].to_vec();
                if self.below(2) == 0 {
                    let at = self.below(len + 1);
                    d.splice(at..at, piece);
                } else {
                    let cut = self.below(len + 1);
                    let from = self.below(other.len() + 1);
                    d.truncate(cut);
                    d.extend_from_slice(&other[from..]);
                }
            }
            6 | 7 => self.replace_number(d),
            8 | 9 => {
                let i = self.below(self.dict.len());
                let word: &'static str = self.dict[i];
                let word = word.as_bytes();
                // At a token boundary half the time, so the word stays a word.
                let mut at = self.below(len + 1);
                if self.below(2) == 0 {
                    while at < len && !matches!(d[at], b' ' | b'\n' | b',' | b'(' | b'[') {
                        at += 1;
                    }
                }
                if self.below(4) == 0 && at < len {
                    let end = (at + 1 + self.below(16)).min(len);
                    d.splice(at..end, word.iter().copied());
                } else {
                    d.splice(at..at, word.iter().copied());
                }
            }
            10 if len > 0 => {
                let v = self.binary_value();
                let at = self.below(len);
                let end = (at + v.len()).min(len);
                d.splice(at..end, v);
            }
            11 => {
                let keep = self.below(len + 1);
                d.truncate(keep);
            }
            _ => {
                let at = self.below(len + 1);
                d.insert(at, self.below(256) as u8);
            }
        }
    }

    /// Replace one number of the text with an interesting one or a nudged copy.
    fn replace_number(&mut self, d: &mut Vec<u8>) {
        let numeric = |c: u8| c.is_ascii_digit() || matches!(c, b'.' | b'e' | b'E' | b'+' | b'-');
        let mut spans = Vec::new();
        let mut i = 0;
        while i < d.len() {
            if numeric(d[i]) {
                let start = i;
                while i < d.len() && numeric(d[i]) {
                    i += 1;
                }
                if d[start..i].iter().any(u8::is_ascii_digit) {
                    spans.push(start..i);
                }
            } else {
                i += 1;
            }
        }
        if spans.is_empty() {
            let at = self.below(d.len() + 1);
            let n = self.pick(NUMBERS).as_bytes();
            d.splice(at..at, n.iter().copied());
            return;
        }
        let span = self.pick(&spans).clone();
        let new = match self.below(4) {
            0 => {
                let old = String::from_utf8_lossy(&d[span.clone()]).to_string();
                match (old.parse::<i64>(), self.below(4)) {
                    (Ok(v), 0) => v.wrapping_add(1).to_string(),
                    (Ok(v), 1) => v.wrapping_sub(1).to_string(),
                    (Ok(v), 2) => v.wrapping_mul(-1).to_string(),
                    _ => format!("{old}{}", self.pick(&["0", "00000", "e300", ".5"])),
                }
            }
            _ => self.pick(NUMBERS).to_string(),
        };
        d.splice(span, new.into_bytes());
    }

    /// Bytes of an interesting binary value, little or big endian (for binary PLY).
    fn binary_value(&mut self) -> Vec<u8> {
        let v: Vec<u8> = match self.below(5) {
            0 => vec![*self.pick(&[0u8, 1, 2, 3, 0x7f, 0x80, 0xff])],
            1 => self
                .pick(&[0u16, 3, 0x7fff, 0x8000, 0xffff])
                .to_le_bytes()
                .to_vec(),
            2 => self
                .pick(&[
                    0u32,
                    3,
                    65536,
                    49_999_999,
                    0x7fff_ffff,
                    0x8000_0000,
                    u32::MAX,
                ])
                .to_le_bytes()
                .to_vec(),
            3 => self
                .pick(&[
                    f32::NAN,
                    f32::INFINITY,
                    -f32::INFINITY,
                    f32::MAX,
                    1e-45,
                    -0.0,
                ])
                .to_le_bytes()
                .to_vec(),
            _ => self
                .pick(&[f64::NAN, f64::INFINITY, f64::MAX, -f64::MAX, 1e300, 5e-324])
                .to_le_bytes()
                .to_vec(),
        };
        if self.below(2) == 0 {
            v.into_iter().rev().collect()
        } else {
            v
        }
    }
}

/// The tally of one run.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    /// Inputs run, the seeds included.
    pub inputs: u64,
    /// Inputs that gave a finding.
    pub findings: u64,
    /// Inputs accepted (a scene that validated, a mesh that loaded) without a finding.
    pub accepted: u64,
    /// The first input of each distinct finding (by signature).
    pub distinct: Vec<(Finding, Vec<u8>)>,
    /// Corpus size at the start and at the end.
    pub corpus: (usize, usize),
    /// Distinct outcome classes seen.
    pub classes: usize,
    /// Inputs refused through a panic contained in a third-party reader (see
    /// `run_guarded`): an error for the user, but a gap that crate's checks leave.
    pub contained: u64,
}

/// Run the seeds, then `iters` mutated inputs, for `target`. `on_new` sees each distinct
/// finding as it is found.
pub fn fuzz(
    target: Target,
    seeds: &[Vec<u8>],
    iters: u64,
    seed: u64,
    mut on_new: impl FnMut(&Finding, &[u8]),
) -> Stats {
    let mut corpus: Vec<Vec<u8>> = seeds.to_vec();
    if corpus.is_empty() {
        corpus.push(Vec::new());
    }
    let mut stats = Stats {
        corpus: (corpus.len(), 0),
        ..Stats::default()
    };
    let mut classes = HashSet::new();
    let mut signatures = HashSet::new();
    let mut record = |input: &[u8], r: Result<String, Finding>, corpus: &mut Vec<Vec<u8>>| {
        stats.inputs += 1;
        match r {
            Ok(c) => {
                stats.accepted += u64::from(c == "ok");
                stats.contained += u64::from(c.starts_with("contained panic"));
                if classes.insert(c) && corpus.len() < MAX_CORPUS {
                    corpus.push(input.to_vec());
                }
            }
            Err(f) => {
                stats.findings += 1;
                if signatures.insert(f.signature.clone()) {
                    on_new(&f, input);
                    stats.distinct.push((f, input.to_vec()));
                }
            }
        }
    };
    for s in seeds {
        let r = run_one(target, s);
        record(s, r, &mut Vec::new());
    }
    let mut m = Mutator::new(target, seed);
    for _ in 0..iters {
        // Half the time a seed: the well-formed files keep reaching the deepest checks.
        let pool = if m.below(2) == 0 {
            seeds.len().max(1)
        } else {
            corpus.len()
        };
        let base = m.below(pool);
        let input = m.mutate(&corpus[base], &corpus);
        let r = run_one(target, &input);
        record(&input, r, &mut corpus);
    }
    stats.classes = classes.len();
    stats.corpus.1 = corpus.len();
    stats
}

/// A smaller input with the same finding signature: chunks are removed while it holds,
/// trying at most `budget` inputs.
pub fn minimize(target: Target, input: &[u8], signature: &str, budget: usize) -> Vec<u8> {
    let mut best = input.to_vec();
    let mut tries = 0;
    let mut chunk = best.len().div_ceil(2).max(1);
    loop {
        let mut i = 0;
        while i < best.len() && tries < budget {
            let mut candidate = best.clone();
            candidate.drain(i..(i + chunk).min(best.len()));
            tries += 1;
            match run_one(target, &candidate) {
                Err(f) if f.signature == signature => best = candidate,
                _ => i += chunk,
            }
        }
        if chunk == 1 || tries >= budget {
            return best;
        }
        chunk /= 2;
    }
}

/// The files of a corpus folder, by name.
pub fn load_corpus(dir: &Path) -> std::io::Result<Vec<(PathBuf, Vec<u8>)>> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_file() {
            let bytes = std::fs::read(&path)?;
            files.push((path, bytes));
        }
    }
    files.sort();
    Ok(files)
}

/// Bytes as a Rust byte-string body: printable ASCII as is, the rest escaped.
pub fn escape(bytes: &[u8]) -> String {
    bytes
        .iter()
        .flat_map(|&b| std::ascii::escape_default(b))
        .map(char::from)
        .collect()
}

/// Bytes as hex, two digits each.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A finding with its input, for a test failure or a report.
pub fn describe(target: Target, f: &Finding, input: &[u8]) -> String {
    let min = minimize(target, input, &f.signature, 2000);
    format!(
        "{} input: {}\n  escaped: b\"{}\"\n  hex: {}\n  minimized ({} bytes): b\"{}\"",
        target.name(),
        f.detail,
        escape(input),
        hex(input),
        min.len(),
        escape(&min)
    )
}

/// Whether this build checks integer overflow (a debug build, or
/// `CARGO_PROFILE_RELEASE_OVERFLOW_CHECKS=true`): without, an overflow wraps silently.
pub fn overflow_checks() -> bool {
    run_guarded(b"", || {
        Ok((std::hint::black_box(u8::MAX) + std::hint::black_box(1u8)).to_string())
    })
    .is_err()
}

/// Largest single allocation that is not a finding.
pub const ALLOC_CAP: usize = 256 << 20;
/// Larger than this would likely fail and abort the process before it could be reported:
/// the input is printed (and saved in `set_abort_dir`'s folder) and the process aborts.
const ALLOC_ABORT: usize = 8 << 30;

thread_local! {
    static ARMED: Cell<bool> = const { Cell::new(false) };
    static BIGGEST: Cell<usize> = const { Cell::new(0) };
    static INPUT: Cell<(*const u8, usize)> = const { Cell::new((std::ptr::null(), 0)) };
    static PANIC: RefCell<Option<(String, String)>> = const { RefCell::new(None) };
}

static INSTALLED: AtomicBool = AtomicBool::new(false);
static ABORT_DIR: OnceLock<PathBuf> = OnceLock::new();
static SAVE_EACH: OnceLock<PathBuf> = OnceLock::new();

/// Write every input to `path` before running it (slow): a stack overflow or a signal kills
/// the process before it can report, and this file then holds the input that did it.
pub fn save_each_input(path: PathBuf) {
    let _ = SAVE_EACH.set(path);
}

/// Where an input that makes an allocation too large to survive is saved before the abort.
pub fn set_abort_dir(dir: PathBuf) {
    let _ = ABORT_DIR.set(dir);
}

/// Whether `CappedAlloc` is the global allocator (else allocations are not watched).
pub fn allocations_watched() -> bool {
    drop(Vec::<u8>::with_capacity(1));
    INSTALLED.load(Ordering::Relaxed)
}

/// `System`, watching the size of each allocation made while a fuzz input runs. Install it
/// in the binary that fuzzes: `#[global_allocator] static A: CappedAlloc = CappedAlloc;`.
pub struct CappedAlloc;

// SAFETY: every call is passed on to `System` unchanged; `note` allocates only through
// the panic-free paths of a thread-local `Cell`, or aborts.
unsafe impl GlobalAlloc for CappedAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: the caller's contract is System's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

fn note(size: usize) {
    if !INSTALLED.load(Ordering::Relaxed) {
        INSTALLED.store(true, Ordering::Relaxed);
    }
    if size <= ALLOC_CAP || !ARMED.try_with(Cell::get).unwrap_or(false) {
        return;
    }
    let _ = BIGGEST.try_with(|b| b.set(b.get().max(size)));
    if size > ALLOC_ABORT {
        too_big(size);
    }
}

/// An allocation so large that the system may refuse it, and a refusal aborts: report the
/// input first.
#[cold]
fn too_big(size: usize) -> ! {
    ARMED.with(|a| a.set(false));
    let (ptr, len) = INPUT.with(Cell::get);
    // SAFETY: `run_guarded` set these from a slice that outlives the armed call.
    let input = if ptr.is_null() {
        &[][..]
    } else {
        unsafe { std::slice::from_raw_parts(ptr, len) }
    };
    eprintln!(
        "fuzz: an allocation of {size} bytes; aborting. The input: b\"{}\"",
        escape(input)
    );
    if let Some(dir) = ABORT_DIR.get() {
        let path = dir.join("abort-input.bin");
        if std::fs::create_dir_all(dir).is_ok() && std::fs::write(&path, input).is_ok() {
            eprintln!("fuzz: the input is saved as {}", path.display());
        }
    }
    std::process::abort();
}

/// Panics inside a fuzz input are recorded quietly; others go to the previous hook.
fn install_panic_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if !ARMED.try_with(Cell::get).unwrap_or(false) {
                return previous(info);
            }
            let payload = info.payload();
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a non-string payload".into());
            let place = info
                .location()
                .map(|l| format!("{}:{}:{}", l.file(), l.line(), l.column()))
                .unwrap_or_else(|| "an unknown place".into());
            let _ = PANIC.try_with(|p| *p.borrow_mut() = Some((place, message)));
        }));
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mutator_repeats_for_a_seed_and_varies_its_output() {
        let corpus = vec![b"Scene(groups: [], seed: 12)".to_vec()];
        let run = |seed| {
            let mut m = Mutator::new(Target::Scene, seed);
            (0..200)
                .map(|_| m.mutate(&corpus[0], &corpus))
                .collect::<Vec<_>>()
        };
        let a = run(7);
        assert_eq!(a, run(7));
        assert_ne!(a, run(8));
        let distinct: HashSet<_> = a.iter().collect();
        assert!(distinct.len() > 150, "{} distinct of 200", distinct.len());
        assert!(a.iter().all(|d| d.len() <= MAX_INPUT));
    }

    #[test]
    fn non_finite_numbers_are_found_outside_strings_only() {
        assert!(non_finite_line("a: (1.0, inf, 2.0),").is_some());
        assert!(non_finite_line("a: -inf,").is_some());
        assert!(non_finite_line("a: NaN,").is_some());
        assert!(non_finite_line("name: \"inf NaN \\\" inf\", inertia: 1.0,").is_none());
        assert!(non_finite_line("a: 1e300, b: 5e-324,").is_none());
    }

    #[test]
    fn classes_drop_numbers_and_echoed_words() {
        let input = b"OFF\nbanana\"x 3 0";
        assert_eq!(
            class("x.off:2: expected a count, found \"banana\"x\" 4", input),
            class("x.off:12: expected a count, found banana 99", input)
        );
        assert_eq!(class("Couldn't parse 'zzz'", b"zzzz"), "couldn parse");
        assert_eq!(class("byte 0xff at 12", b""), class("byte 0xac at 3", b""));
        assert_eq!(class("found \"\\u{fdee}x\" face", b""), "found face");
    }
}
