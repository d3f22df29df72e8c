//! Triangle meshes for fur: OBJ (through `tobj`), PLY (through `ply-rs-bw`) and OFF (a few
//! lines of parsing). Vertex normals are taken from the file or computed (area-weighted);
//! degenerate triangles are kept (they get no hair: zero area), unreferenced vertices are
//! ignored, non-manifold edges are fine. A file that cannot be used is refused with the line
//! (or element) where it broke; a mesh whose every triangle has zero area is refused too.
//! Headers are checked against the size of the body before anything is reserved, so a
//! header that announces millions of vertices over a three-line body costs nothing.
//!
//! Winding: fur grows along the normals, so a closed mesh wound inside out would grow its fur
//! inside the body. Every closed component (each edge shared by exactly two triangles, after
//! welding vertices at bit-identical positions, so UV seams and OBJ groups do not open it) is
//! made consistent across its edges and turned so its signed volume is positive; a warning
//! says how many faces were reversed ([`Mesh::reoriented`]). Normals from the file are kept,
//! but on a closed component one that points against its oriented faces is negated. Open
//! meshes (with boundary edges), non-manifold and non-orientable components are left as the
//! file winds them: there is no inside to point away from.

use crate::error::{KamiError, Result};
use glam::DVec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// An indexed triangle mesh with per-vertex normals.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub positions: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Triangles that were reversed so closed components face outwards (0 when the file
    /// already wound them so).
    pub reoriented: usize,
    /// Every triangle lies on a closed, oriented component (a watertight skin: the side
    /// facing away from a light is hidden behind the side facing it).
    pub closed: bool,
}

/// The most vertices, faces or PLY elements Kami loads (its buffers are indexed by u32, and
/// a few GB of mesh is beyond a fur viewer).
const MAX_COUNT: usize = 50_000_000;

/// The largest mesh file read (50 million vertices and twice the faces as binary PLY fit).
const MAX_FILE_BYTES: u64 = 4 << 30;

/// Coordinates beyond this would overflow areas and normals (products of three).
const MAX_COORD: f64 = 1e100;

/// `v` as a unit vector, scaled by its largest component first so that neither 1e308 (whose
/// squared length overflows) nor 1e-200 (which underflows) loses its direction; None for a
/// zero or non-finite vector.
fn unit(v: DVec3) -> Option<DVec3> {
    let m = v.abs().max_element();
    (m.is_finite() && m > 0.0)
        .then(|| (v / m).normalize())
        .filter(|u| u.is_finite())
}

fn err(path: &str, line: Option<usize>, message: impl Into<String>) -> KamiError {
    KamiError::Mesh {
        path: path.to_string(),
        line,
        message: message.into(),
    }
}

impl Mesh {
    /// Load by extension: `.obj`, `.off` or `.ply`.
    pub fn load(path: impl AsRef<Path>) -> Result<Mesh> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let io = |source| KamiError::Io {
            path: path.to_path_buf(),
            source,
        };
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .unwrap_or_default();
        if !matches!(ext.as_str(), "obj" | "off" | "ply") {
            return Err(err(
                &name,
                None,
                format!("unknown mesh format {ext:?}: use .obj, .off or .ply"),
            ));
        }
        // `read` on a directory fails with a bare OS error on some systems, and on a FIFO or
        // a device (`/dev/zero` behind a symlink) it blocks or never ends: say what it is.
        let meta = std::fs::metadata(path).map_err(io)?;
        if meta.is_dir() {
            return Err(err(
                &name,
                None,
                "is a directory, not a mesh file (.obj, .off or .ply)",
            ));
        }
        if !meta.is_file() {
            return Err(err(
                &name,
                None,
                "is not a regular file (a pipe, socket or device?)",
            ));
        }
        if meta.len() > MAX_FILE_BYTES {
            return Err(err(
                &name,
                None,
                format!(
                    "the file is {} bytes; Kami loads meshes up to {MAX_FILE_BYTES} bytes",
                    meta.len()
                ),
            ));
        }
        let bytes = std::fs::read(path).map_err(io)?;
        match ext.as_str() {
            "obj" => Mesh::from_obj(&String::from_utf8_lossy(&bytes), &name),
            "off" => Mesh::from_off(&String::from_utf8_lossy(&bytes), &name),
            "ply" => Mesh::from_ply(&bytes, &name),
            _ => Err(err(
                &name,
                None,
                format!("unknown mesh format {ext:?}: use .obj, .off or .ply"),
            )),
        }
    }

    /// Build from positions, triangles and optional normals: checks indices and values,
    /// refuses a mesh without area, orients closed components outwards and computes missing
    /// normals. Every loader ends here.
    pub fn new(
        positions: Vec<DVec3>,
        mut triangles: Vec<[u32; 3]>,
        normals: Option<Vec<DVec3>>,
        name: &str,
    ) -> Result<Mesh> {
        if positions.is_empty() || triangles.is_empty() {
            return Err(err(name, None, "the mesh has no triangles"));
        }
        if triangles.len() > u32::MAX as usize / 4 {
            return Err(err(
                name,
                None,
                format!("{} triangles is beyond what Kami loads", triangles.len()),
            ));
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(err(
                name,
                None,
                format!("vertex {i} is not finite: {:?}", positions[i]),
            ));
        }
        if let Some(i) = positions
            .iter()
            .position(|p| p.abs().max_element() > MAX_COORD)
        {
            return Err(err(
                name,
                None,
                format!(
                    "vertex {i} is {}: coordinates beyond 1e100 would overflow areas and normals",
                    positions[i]
                ),
            ));
        }
        for (ti, t) in triangles.iter().enumerate() {
            if let Some(&bad) = t.iter().find(|&&v| v as usize >= positions.len()) {
                return Err(err(
                    name,
                    None,
                    format!(
                        "triangle {ti} uses vertex {bad}, but there are {} vertices",
                        positions.len()
                    ),
                ));
            }
        }
        if !has_area(&positions, &triangles) {
            return Err(err(
                name,
                None,
                "every triangle has zero area: no surface to grow fur on",
            ));
        }
        let closed = orient(&positions, &mut triangles);
        let computed = vertex_normals(&positions, &triangles);
        let mut flipped_normals = 0;
        let normals = match normals {
            Some(n) if n.len() == positions.len() && n.iter().all(|v| unit(*v).is_some()) => {
                // The file's normals keep their smoothing, but on a closed component they
                // must agree with the outward faces, or the fur would grow inwards.
                n.into_iter()
                    .zip(&computed)
                    .zip(&closed.vertices)
                    .map(|((v, c), &on_closed)| {
                        let v = unit(v).unwrap_or(*c);
                        if on_closed && v.dot(*c) < 0.0 {
                            flipped_normals += 1;
                            -v
                        } else {
                            v
                        }
                    })
                    .collect()
            }
            _ => computed,
        };
        if closed.reversed > 0 || flipped_normals > 0 {
            log::warn!(
                "mesh {name}: {} of {} closed components wound inwards: reversed {} triangles \
                 and flipped {flipped_normals} normals from the file, so fur grows outwards",
                closed.components_reversed,
                closed.components,
                closed.reversed,
            );
        }
        if closed.non_orientable > 0 {
            log::warn!(
                "mesh {name}: {} closed components are not orientable (one-sided); their \
                 winding is left as the file has it",
                closed.non_orientable
            );
        }
        // Triangles without area (a sphere's poles) take no part in the components.
        let all_closed = triangles.iter().all(|t| {
            let p = t.map(|v| positions[v as usize]);
            (p[1] - p[0]).cross(p[2] - p[0]) == DVec3::ZERO
                || t.iter().all(|&v| closed.vertices[v as usize])
        });
        Ok(Mesh {
            positions,
            normals,
            triangles,
            reoriented: closed.reversed,
            closed: all_closed,
        })
    }

    pub fn from_obj(text: &str, name: &str) -> Result<Mesh> {
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            // `p` and `l` statements are not surfaces (tobj would make them zero-area
            // triangles).
            ignore_points: true,
            ignore_lines: true,
        };
        // tobj reads `l` like `f`, and `ignore_lines` drops only two-point lines: a polyline
        // of three or more points would become triangles and grow fur. Blank every `l` line
        // (line numbers stay for errors).
        let surfaces: String = text
            .lines()
            .map(|l| {
                let t = l.trim_start();
                if t.starts_with("l ") || t.starts_with("l\t") {
                    ""
                } else {
                    l
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        obj_indices_in_range(&surfaces, name)?;
        let (models, _) = tobj::load_obj_buf(&mut surfaces.as_bytes(), &opts, |_| {
            Err(tobj::LoadError::OpenFileFailed)
        })
        .map_err(|e| err(name, obj_error_line(text), format!("{e}")))?;
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut triangles = Vec::new();
        let mut has_normals = true;
        for m in models {
            let base = positions.len() as u32;
            let mesh = m.mesh;
            for p in mesh.positions.chunks_exact(3) {
                positions.push(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
            }
            if mesh.normals.len() == mesh.positions.len() {
                normals.extend(
                    mesh.normals
                        .chunks_exact(3)
                        .map(|n| DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64)),
                );
            } else {
                has_normals = false;
            }
            for t in mesh.indices.chunks_exact(3) {
                triangles.push([base + t[0], base + t[1], base + t[2]]);
            }
        }
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(err(
                name,
                obj_error_line(text),
                "a vertex coordinate is not a finite number",
            ));
        }
        Mesh::new(positions, triangles, has_normals.then_some(normals), name)
    }

    /// OFF: "OFF", counts "V F E", V vertex lines, F face lines "n i0 .. i(n-1)" (polygons
    /// are fanned into triangles). Comments start with '#'.
    pub fn from_off(text: &str, name: &str) -> Result<Mesh> {
        // Tokens with their line numbers, comments dropped.
        let mut tokens = text.lines().enumerate().flat_map(|(i, l)| {
            l.split('#')
                .next()
                .unwrap_or("")
                .split_whitespace()
                .map(move |t| (i + 1, t))
        });
        let (line, head) = tokens
            .next()
            .ok_or_else(|| err(name, Some(1), "empty file"))?;
        let mut pending: Option<(usize, &str)> = None;
        if head != "OFF" {
            if head.ends_with("OFF") && head.len() > 3 {
                return Err(err(name, Some(line), format!("{head} (colours, normals or higher dimensions) is not supported: plain OFF only")));
            }
            // Some files omit the keyword and start with the counts.
            if head.parse::<usize>().is_err() {
                return Err(err(
                    name,
                    Some(line),
                    format!("expected OFF, found {head:?}"),
                ));
            }
            pending = Some((line, head));
        }
        let mut next = |what: &str| -> Result<(usize, &str)> {
            if let Some(p) = pending.take() {
                return Ok(p);
            }
            tokens
                .next()
                .ok_or_else(|| err(name, None, format!("the file ends before {what}")))
        };
        let mut count = |what: &str| -> Result<(usize, usize)> {
            let (l, t) = next(what)?;
            let n = t
                .parse::<usize>()
                .map_err(|_| err(name, Some(l), format!("{what}: {t:?} is not a count")))?;
            Ok((l, n))
        };
        let (_, nv) = count("the vertex count")?;
        let (_, nf) = count("the face count")?;
        let (counts_line, _) = count("the edge count")?;
        if nv > MAX_COUNT || nf > MAX_COUNT {
            return Err(err(
                name,
                None,
                format!("{nv} vertices and {nf} faces is beyond what Kami loads (50 million)"),
            ));
        }
        // A vertex takes at least 3 tokens and a face 4, each a character and a separator:
        // a header that promises more than the file can hold is refused before anything is
        // reserved for it.
        let least = 6 * nv + 8 * nf;
        if least > text.len() + 1 {
            return Err(err(
                name,
                Some(counts_line),
                format!(
                    "the header announces {nv} vertices and {nf} faces, but the whole file is \
                     {} bytes (they need at least {least})",
                    text.len()
                ),
            ));
        }
        let mut positions = Vec::with_capacity(nv);
        for v in 0..nv {
            let mut c = [0.0; 3];
            for (k, x) in c.iter_mut().enumerate() {
                let (l, t) = next(&format!("vertex {v}"))?;
                *x = t
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        err(
                            name,
                            Some(l),
                            format!("vertex {v} coordinate {k}: {t:?} is not a finite number"),
                        )
                    })?;
            }
            positions.push(DVec3::from(c));
        }
        let mut triangles = Vec::with_capacity(nf);
        for f in 0..nf {
            let (l, t) = next(&format!("face {f}"))?;
            let n: usize = t.parse().map_err(|_| {
                err(
                    name,
                    Some(l),
                    format!("face {f}: {t:?} is not a vertex count"),
                )
            })?;
            if !(3..=1000).contains(&n) {
                return Err(err(name, Some(l), format!("face {f} has {n} vertices")));
            }
            let mut idx = Vec::with_capacity(n);
            for _ in 0..n {
                let (l, t) = next(&format!("face {f}"))?;
                let i: u32 = t.parse().map_err(|_| {
                    err(
                        name,
                        Some(l),
                        format!("face {f}: {t:?} is not a vertex index"),
                    )
                })?;
                if i as usize >= nv {
                    return Err(err(
                        name,
                        Some(l),
                        format!("face {f} uses vertex {i}, but there are {nv}"),
                    ));
                }
                idx.push(i);
            }
            // Colour values may follow on the same line: skipped by the token count.
            for k in 1..n - 1 {
                triangles.push([idx[0], idx[k], idx[k + 1]]);
            }
        }
        Mesh::new(positions, triangles, None, name)
    }

    /// PLY, ascii or binary of either byte order, faces fanned into triangles; extra
    /// properties and elements are read and ignored.
    pub fn from_ply(bytes: &[u8], name: &str) -> Result<Mesh> {
        use ply_rs_bw::{
            parser::Parser,
            ply::{DefaultElement, Property},
        };
        let bytes = &free_text_as_comments(bytes, name)[..];
        ply_header_fits(bytes, name)?;
        let parser = Parser::<DefaultElement>::new();
        let ply = parser
            .read_ply(&mut std::io::Cursor::new(bytes))
            .map_err(|e| ply_error(name, &e.to_string()))?;
        let num = |p: &Property| -> Option<f64> {
            match p {
                Property::Float(v) => Some(*v as f64),
                Property::Double(v) => Some(*v),
                Property::Int(v) => Some(*v as f64),
                Property::UInt(v) => Some(*v as f64),
                Property::Short(v) => Some(*v as f64),
                Property::UShort(v) => Some(*v as f64),
                Property::Char(v) => Some(*v as f64),
                Property::UChar(v) => Some(*v as f64),
                _ => None,
            }
        };
        let vertices = ply
            .payload
            .get("vertex")
            .ok_or_else(|| err(name, None, "no `vertex` element"))?;
        let mut positions = Vec::with_capacity(vertices.len());
        let mut normals = Vec::with_capacity(vertices.len());
        for (i, v) in vertices.iter().enumerate() {
            let get = |k: &str| v.get(k).and_then(num);
            let (x, y, z) = (get("x"), get("y"), get("z"));
            let (Some(x), Some(y), Some(z)) = (x, y, z) else {
                return Err(err(name, None, format!("vertex {i} lacks x, y or z")));
            };
            positions.push(DVec3::new(x, y, z));
            if let (Some(a), Some(b), Some(c)) = (get("nx"), get("ny"), get("nz")) {
                normals.push(DVec3::new(a, b, c));
            }
        }
        let faces = ply
            .payload
            .get("face")
            .ok_or_else(|| err(name, None, "no `face` element"))?;
        let mut triangles = Vec::with_capacity(faces.len());
        for (fi, f) in faces.iter().enumerate() {
            let list = f
                .get("vertex_indices")
                .or_else(|| f.get("vertex_index"))
                .ok_or_else(|| err(name, None, format!("face {fi} has no vertex_indices")))?;
            let idx: Vec<i64> = match list {
                Property::ListInt(v) => v.iter().map(|&x| x as i64).collect(),
                Property::ListUInt(v) => v.iter().map(|&x| x as i64).collect(),
                Property::ListShort(v) => v.iter().map(|&x| x as i64).collect(),
                Property::ListUShort(v) => v.iter().map(|&x| x as i64).collect(),
                Property::ListUChar(v) => v.iter().map(|&x| x as i64).collect(),
                Property::ListChar(v) => v.iter().map(|&x| x as i64).collect(),
                _ => {
                    return Err(err(
                        name,
                        None,
                        format!("face {fi}: vertex_indices is not an integer list"),
                    ))
                }
            };
            if idx.len() < 3 {
                return Err(err(
                    name,
                    None,
                    format!(
                        "face {fi} has {} vertices (at least 3 make a face)",
                        idx.len()
                    ),
                ));
            }
            if let Some(&i) = idx
                .iter()
                .find(|&&i| i < 0 || i as usize >= positions.len())
            {
                return Err(err(
                    name,
                    None,
                    format!(
                        "face {fi} uses vertex {i}, but there are {} vertices (0 to {})",
                        positions.len(),
                        positions.len() as i64 - 1
                    ),
                ));
            }
            for k in 1..idx.len() - 1 {
                triangles.push([idx[0] as u32, idx[k] as u32, idx[k + 1] as u32]);
            }
        }
        let normals = (normals.len() == positions.len()).then_some(normals);
        Mesh::new(positions, triangles, normals, name)
    }

    /// Area of triangle `t`.
    pub fn area(&self, t: usize) -> f64 {
        let [a, b, c] = self.triangles[t].map(|i| self.positions[i as usize]);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Bounding sphere (box centre, farthest referenced vertex).
    pub fn bounds(&self) -> (DVec3, f64) {
        let mut lo = DVec3::splat(f64::MAX);
        let mut hi = DVec3::splat(f64::MIN);
        for t in &self.triangles {
            for &i in t {
                lo = lo.min(self.positions[i as usize]);
                hi = hi.max(self.positions[i as usize]);
            }
        }
        let c = 0.5 * (lo + hi);
        let r = self
            .triangles
            .iter()
            .flatten()
            .map(|&i| (self.positions[i as usize] - c).length())
            .fold(0.0, f64::max);
        (c, r)
    }

    /// Scale and move so the bounding sphere is centred at the origin with radius `size`.
    pub fn fit(&mut self, size: f64) {
        let (c, r) = self.bounds();
        let s = if r > 0.0 { size / r } else { 1.0 };
        for p in &mut self.positions {
            *p = (*p - c) * s;
        }
    }
}

/// Where Debian's `libcgal-demo` puts the CGAL demo data (meshes in `data/meshes/`).
pub const CGAL_DATA: &str = "/usr/share/doc/libcgal-dev/data.tar.gz";

/// Real meshes for tests and examples come from a Debian package, never from the repository:
/// extract `data/meshes/{name}` of the CGAL demo data into `dir` (once) and return its path.
pub fn cgal_demo_mesh(name: &str, dir: &Path) -> Result<PathBuf> {
    let path = dir.join("data/meshes").join(name);
    if path.exists() {
        return Ok(path);
    }
    let missing = |why: String| {
        err(
            &path.display().to_string(),
            None,
            format!(
                "{why}; the CGAL demo meshes come with Debian's libcgal-demo: \
                 apt-get install --no-install-recommends libcgal-demo"
            ),
        )
    };
    if !Path::new(CGAL_DATA).exists() {
        return Err(missing(format!("{CGAL_DATA} is missing")));
    }
    // Extract beside the target and rename, so concurrent callers never read half a file.
    let tmp = dir.join(format!(
        ".extract-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    let io = |source| KamiError::Io {
        path: dir.to_path_buf(),
        source,
    };
    std::fs::create_dir_all(&tmp).map_err(io)?;
    std::fs::create_dir_all(path.parent().unwrap_or(dir)).map_err(io)?;
    let out = std::process::Command::new("tar")
        .arg("xzf")
        .arg(CGAL_DATA)
        .arg("-C")
        .arg(&tmp)
        .arg(format!("data/meshes/{name}"))
        .output()
        .map_err(|e| missing(format!("cannot run tar: {e}")))?;
    let extracted = tmp.join("data/meshes").join(name);
    let result = if out.status.success() && extracted.exists() {
        std::fs::rename(&extracted, &path).map_err(io)
    } else {
        let why = String::from_utf8_lossy(&out.stderr);
        Err(missing(format!(
            "{name} is not in {CGAL_DATA} ({})",
            why.lines().next().unwrap_or("tar failed")
        )))
    };
    std::fs::remove_dir_all(&tmp).ok();
    result.map(|_| path)
}

/// A PLY header line that is none of the header's keywords (old exporters, Blender 2.4x
/// among them, wrote a free-text "Created by ..." line; assimp reads such files) becomes a
/// `comment` line, with a warning naming it: nothing it says is data. Line numbers stay as
/// they were, so later errors still point into the file.
fn free_text_as_comments<'a>(bytes: &'a [u8], name: &str) -> std::borrow::Cow<'a, [u8]> {
    const KEYWORDS: [&str; 7] = [
        "ply",
        "format",
        "comment",
        "obj_info",
        "element",
        "property",
        "end_header",
    ];
    let mut free = Vec::new();
    let mut at = 0;
    let mut line_no = 0;
    let mut ended = false;
    while let Some(len) = bytes[at..].iter().position(|&b| b == b'\n') {
        let line = &bytes[at..at + len];
        line_no += 1;
        let first = line
            .split(|b| b.is_ascii_whitespace())
            .find(|w| !w.is_empty());
        match first {
            Some(b"end_header") => {
                ended = true;
                break;
            }
            // The first line is the magic `ply`: a file without it is no PLY.
            Some(w) if line_no > 1 && !KEYWORDS.iter().any(|k| k.as_bytes() == w) => {
                free.push((at, line_no))
            }
            _ => {}
        }
        at += len + 1;
    }
    // A header that never ends is refused as it stands, its own lines named.
    if free.is_empty() || !ended {
        return std::borrow::Cow::Borrowed(bytes);
    }
    let lines: Vec<String> = free.iter().map(|(_, n)| n.to_string()).collect();
    log::warn!(
        "{name}: header line{} {} {} not a PLY keyword: read as comment{}",
        if free.len() == 1 { "" } else { "s" },
        lines.join(", "),
        if free.len() == 1 { "is" } else { "are" },
        if free.len() == 1 { "" } else { "s" }
    );
    let mut out = Vec::with_capacity(bytes.len() + 8 * free.len());
    let mut from = 0;
    for (start, _) in free {
        out.extend_from_slice(&bytes[from..start]);
        out.extend_from_slice(b"comment ");
        from = start;
    }
    out.extend_from_slice(&bytes[from..]);
    std::borrow::Cow::Owned(out)
}

/// Refuse a PLY header whose element counts the body cannot hold (each binary record takes
/// at least its fixed-size properties and its lists' counts, each ascii record a line), or
/// that are beyond [`MAX_COUNT`], naming the element's header line. ply-rs-bw caps what it
/// reserves itself; this gives the error its place and keeps a huge count from being read
/// element by element. A header this cannot follow is left to ply-rs-bw to report.
fn ply_header_fits(bytes: &[u8], name: &str) -> Result<()> {
    let size = |t: &str| match t {
        "char" | "uchar" | "int8" | "uint8" => Some(1u128),
        "short" | "ushort" | "int16" | "uint16" => Some(2),
        "int" | "uint" | "int32" | "uint32" | "float" | "float32" => Some(4),
        "double" | "float64" => Some(8),
        _ => None,
    };
    let mut binary = None;
    // (name, count, header line, least bytes per record)
    let mut elements: Vec<(String, u128, usize, u128)> = Vec::new();
    let mut at = 0;
    let mut line_no = 0;
    loop {
        let Some(len) = bytes[at..].iter().position(|&b| b == b'\n') else {
            return Ok(());
        };
        let line = String::from_utf8_lossy(&bytes[at..at + len]);
        at += len + 1;
        line_no += 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["end_header"] => break,
            ["format", f, ..] => binary = Some(*f != "ascii"),
            ["element", e, n] => match n.parse::<u128>() {
                Ok(n) => elements.push((e.to_string(), n, line_no, 0)),
                Err(_) => return Ok(()),
            },
            ["property", "list", c, _, _] => match (size(c), elements.last_mut()) {
                (Some(c), Some(e)) => e.3 += c,
                _ => return Ok(()),
            },
            ["property", t, _] => match (size(t), elements.last_mut()) {
                (Some(t), Some(e)) => e.3 += t,
                _ => return Ok(()),
            },
            _ => {}
        }
    }
    let Some(binary) = binary else { return Ok(()) };
    let body = &bytes[at..];
    let room = if binary {
        body.len() as u128
    } else {
        // Every line, blank or not: ply-rs-bw reads a line per record.
        (body.iter().filter(|&&b| b == b'\n').count() + usize::from(!body.ends_with(b"\n"))) as u128
    };
    let mut need = 0u128;
    for (element, count, line, least) in elements {
        // A binary record without properties takes no bytes, so no body can bound its count,
        // and ply-rs-bw still builds one map per record.
        if binary && least == 0 && count > 0 {
            return Err(err(
                name,
                Some(line),
                format!("element {element} announces {count} records but has no properties"),
            ));
        }
        if count > MAX_COUNT as u128 {
            return Err(err(
                name,
                Some(line),
                format!("element {element} {count}: beyond what Kami loads (50 million)"),
            ));
        }
        need += count * if binary { least } else { 1 };
        if need > room {
            let unit = if binary { "bytes" } else { "lines" };
            return Err(err(
                name,
                Some(line),
                format!(
                    "the header announces {count} {element} elements, but only {room} {unit} \
                     follow the header (they and the elements before them need at least {need})"
                ),
            ));
        }
    }
    Ok(())
}

/// Every face index (vertex, texture, normal) refers to an element that exists: tobj 4.0.5
/// multiplies huge or far-relative texture and normal indices before checking them, which
/// panics on overflow (debug builds) or reads the wrong element. Relative (negative) indices
/// count back from the elements defined so far; absolute ones may point anywhere in the file.
fn obj_indices_in_range(text: &str, name: &str) -> Result<()> {
    let mut totals = [0i64; 3];
    for line in text.lines() {
        match line.split_whitespace().next() {
            Some("v") => totals[0] += 1,
            Some("vt") => totals[1] += 1,
            Some("vn") => totals[2] += 1,
            _ => {}
        }
    }
    let mut seen = [0i64; 3];
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => seen[0] += 1,
            Some("vt") => seen[1] += 1,
            Some("vn") => seen[2] += 1,
            Some("f") => {
                for corner in words {
                    for (k, part) in corner.split('/').enumerate().take(3) {
                        let Ok(idx) = part.parse::<i64>() else {
                            continue; // empty (v//vn) or malformed: tobj names those
                        };
                        if k > 0 && totals[k] == 0 {
                            continue; // tobj ignores texture and normal indices then
                        }
                        let ok = if idx < 0 {
                            idx.checked_neg().is_some_and(|b| b <= seen[k])
                        } else {
                            idx >= 1 && idx <= totals[k]
                        };
                        if !ok {
                            let what = ["vertex", "texture coordinate", "normal"][k];
                            return Err(err(
                                name,
                                Some(i + 1),
                                format!(
                                    "face corner {corner:?}: {what} index {idx} refers to no {what} \
                                     ({} defined before this line, {} in the file)",
                                    seen[k], totals[k]
                                ),
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// ply-rs reports "Line N: what. String: 'text' Error: (parser dump)": keep the line as the
/// error's place and the first two parts as its message.
fn ply_error(name: &str, text: &str) -> KamiError {
    let flat = text.split_whitespace().collect::<Vec<_>>().join(" ");
    let (line, rest) = match flat.strip_prefix("Line ").and_then(|r| r.split_once(": ")) {
        Some((n, rest)) => (n.parse().ok(), rest),
        None => (None, flat.as_str()),
    };
    let short = rest.split(" Error: ").next().unwrap_or(rest);
    let short: String = short.chars().take(200).collect();
    err(name, line, short)
}

/// Möller–Trumbore, both faces: where the ray o + t d meets triangle `p`, as (t, b1, b2)
/// with b1, b2 the barycentrics of corners 1 and 2 (t of any sign; None when it misses or
/// runs parallel to the triangle).
pub fn ray_triangle(o: DVec3, d: DVec3, p: &[DVec3; 3]) -> Option<(f64, f64, f64)> {
    let e1 = p[1] - p[0];
    let e2 = p[2] - p[0];
    let h = d.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-18 {
        return None;
    }
    let s = o - p[0];
    let b1 = s.dot(h) / det;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let q = s.cross(e1);
    let b2 = d.dot(q) / det;
    if b2 < 0.0 || b1 + b2 > 1.0 {
        return None;
    }
    Some((e2.dot(q) / det, b1, b2))
}

/// Area-weighted vertex normals; vertices no triangle gives a normal point up (never NaN).
/// Computed on the mesh scaled to a unit box, so tiny or huge meshes neither underflow nor
/// overflow.
pub fn vertex_normals(positions: &[DVec3], triangles: &[[u32; 3]]) -> Vec<DVec3> {
    let origin = triangles
        .first()
        .map_or(DVec3::ZERO, |t| positions[t[0] as usize]);
    let extent = triangles
        .iter()
        .flatten()
        .map(|&i| (positions[i as usize] - origin).abs().max_element())
        .fold(0.0, f64::max);
    let scale = if extent > 0.0 && extent.is_finite() {
        1.0 / extent
    } else {
        1.0
    };
    let mut n = vec![DVec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| (positions[i as usize] - origin) * scale);
        // The cross product's length is twice the area: area weighting for free.
        let f = (b - a).cross(c - a);
        for &i in t {
            n[i as usize] += f;
        }
    }
    n.into_iter()
        .map(|v| v.try_normalize().unwrap_or(DVec3::Y))
        .collect()
}

/// Whether some triangle has area. Measured by its shape (height over longest edge), so
/// that neither tiny nor huge coordinates fool it, and with room for the f32 rounding OBJ
/// files go through: points on a line in the file stay "on a line" (height ~1e-7).
fn has_area(positions: &[DVec3], triangles: &[[u32; 3]]) -> bool {
    triangles.iter().any(|t| {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let long = (b - a).length().max((c - a).length()).max((c - b).length());
        long > 0.0 && ((b - a) / long).cross((c - a) / long).length() > 1e-6
    })
}

/// What [`orient`] found and did.
struct Closed {
    /// Closed, orientable components (the ones that can be turned outwards).
    components: usize,
    components_reversed: usize,
    /// Closed components with no consistent orientation (a Klein bottle), left as they are.
    non_orientable: usize,
    /// Triangles reversed.
    reversed: usize,
    /// Per vertex: on a closed, oriented component.
    vertices: Vec<bool>,
}

/// Make every closed manifold component consistently wound across its edges (breadth-first,
/// flipping neighbours) with positive signed volume, reversing triangles (`[a, c, b]`) in
/// place. Connectivity is by edges between vertices welded at bit-identical positions;
/// triangles with a repeated (welded) vertex have no area and take no part.
fn orient(positions: &[DVec3], triangles: &mut [[u32; 3]]) -> Closed {
    let mut closed = Closed {
        components: 0,
        components_reversed: 0,
        non_orientable: 0,
        reversed: 0,
        vertices: vec![false; positions.len()],
    };
    let weld = weld(positions, triangles.len());
    let (edges, runs) = edge_runs(triangles, &weld);
    let mut adj = Adjacency::new(triangles.len(), &edges, &runs);
    // Breadth-first over each closed component: flip[t] says whether t is reversed.
    let mut flip: Vec<Option<bool>> = vec![None; triangles.len()];
    let mut queue = std::collections::VecDeque::new();
    let mut members = Vec::new();
    for seed in 0..triangles.len() {
        let root = find_root(&mut adj.parent, seed as u32) as usize;
        if !adj.in_edges[seed] || adj.open[root] || flip[seed].is_some() {
            continue;
        }
        members.clear();
        if !adj.spread(seed, &mut flip, &mut queue, &mut members) {
            closed.non_orientable += 1;
            continue;
        }
        turn_outwards(positions, triangles, &members, &flip, &mut closed);
    }
    closed
}

/// Weld: the first vertex at each position stands for all (-0.0 counts as 0.0).
fn weld(positions: &[DVec3], triangles: usize) -> Vec<u32> {
    let mut first = HashMap::with_capacity(positions.len().min(triangles * 3));
    (0..positions.len())
        .map(|i| {
            let key = (positions[i] + DVec3::ZERO).to_array().map(f64::to_bits);
            *first.entry(key).or_insert(i as u32)
        })
        .collect()
}

/// An edge of a triangle: (undirected key, triangle, whether the triangle runs from low to
/// high).
type Edge = (u64, u32, bool);

/// The edges of the triangles with area (between welded vertices), sorted by key, and the
/// runs of equal keys (the undirected edges) as ranges into them.
fn edge_runs(triangles: &[[u32; 3]], weld: &[u32]) -> (Vec<Edge>, Vec<(usize, usize)>) {
    let mut edges: Vec<Edge> = Vec::with_capacity(triangles.len() * 3);
    for (t, tri) in triangles.iter().enumerate() {
        let w = tri.map(|i| weld[i as usize]);
        if w[0] == w[1] || w[1] == w[2] || w[2] == w[0] {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (w[k], w[(k + 1) % 3]);
            let key = (a.min(b) as u64) << 32 | a.max(b) as u64;
            edges.push((key, t as u32, a < b));
        }
    }
    edges.sort_unstable_by_key(|e| e.0);
    let mut runs = Vec::new();
    let mut s = 0;
    while s < edges.len() {
        let mut e = s + 1;
        while e < edges.len() && edges[e].0 == edges[s].0 {
            e += 1;
        }
        runs.push((s, e));
        s = e;
    }
    (edges, runs)
}

/// The root of `x` in a union-find forest, halving the path on the way.
fn find_root(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        parent[x as usize] = parent[parent[x as usize] as usize];
        x = parent[x as usize];
    }
    x
}

/// How the triangles meet across their edges.
struct Adjacency {
    /// Union-find parents: triangles that share an edge share a root (a component).
    parent: Vec<u32>,
    /// Per root: the component has an edge used once (boundary) or thrice (non-manifold).
    open: Vec<bool>,
    /// Per triangle: it has edges (it has area).
    in_edges: Vec<bool>,
    /// Per triangle, the other triangle across each of its edges, with their directions.
    across: Vec<[(u32, bool, bool); 3]>,
    /// Per triangle, how many of `across` are filled.
    slot: Vec<u8>,
}

impl Adjacency {
    /// Unions the triangles of each run, then marks open components and records, for each
    /// edge shared by exactly two triangles, each one's neighbour across it.
    fn new(triangles: usize, edges: &[Edge], runs: &[(usize, usize)]) -> Adjacency {
        let mut parent: Vec<u32> = (0..triangles as u32).collect();
        for &(s, e) in runs {
            let a = find_root(&mut parent, edges[s].1);
            for edge in &edges[s + 1..e] {
                let b = find_root(&mut parent, edge.1);
                parent[b as usize] = a;
            }
        }
        let mut open = vec![false; triangles];
        let mut in_edges = vec![false; triangles];
        let mut across: Vec<[(u32, bool, bool); 3]> =
            vec![[(u32::MAX, false, false); 3]; triangles];
        let mut slot = vec![0u8; triangles];
        for &(s, e) in runs {
            let root = find_root(&mut parent, edges[s].1);
            for edge in &edges[s..e] {
                in_edges[edge.1 as usize] = true;
            }
            if e - s != 2 {
                open[root as usize] = true;
                continue;
            }
            let (x, y) = (edges[s], edges[s + 1]);
            for (me, other) in [(x, y), (y, x)] {
                let t = me.1 as usize;
                across[t][slot[t] as usize] = (other.1, me.2, other.2);
                slot[t] += 1;
            }
        }
        Adjacency {
            parent,
            open,
            in_edges,
            across,
            slot,
        }
    }

    /// Breadth-first from `seed` (kept as it is) over its closed component, setting each
    /// member's `flip` and listing it in `members`; false when no consistent orientation
    /// exists.
    fn spread(
        &self,
        seed: usize,
        flip: &mut [Option<bool>],
        queue: &mut std::collections::VecDeque<usize>,
        members: &mut Vec<usize>,
    ) -> bool {
        flip[seed] = Some(false);
        queue.push_back(seed);
        let mut orientable = true;
        while let Some(t) = queue.pop_front() {
            members.push(t);
            let ft = flip[t].unwrap_or(false);
            for &(u, mine, theirs) in &self.across[t][..self.slot[t] as usize] {
                // Consistent neighbours run a shared edge in opposite directions.
                let want = !(theirs ^ mine ^ ft);
                match flip[u as usize] {
                    None => {
                        flip[u as usize] = Some(want);
                        queue.push_back(u as usize);
                    }
                    Some(f) if f != want => orientable = false,
                    Some(_) => {}
                }
            }
        }
        orientable
    }
}

/// A triangle as it is, or reversed (`[a, c, b]`).
fn wound([a, b, c]: [u32; 3], f: bool) -> [u32; 3] {
    if f {
        [a, c, b]
    } else {
        [a, b, c]
    }
}

/// Turn one consistently wound closed component (`members`, the first its seed) to a
/// positive signed volume, counting it into `closed`; a flat one (a double-sided sheet)
/// has no inside to choose and is left as it is.
fn turn_outwards(
    positions: &[DVec3],
    triangles: &mut [[u32; 3]],
    members: &[usize],
    flip: &[Option<bool>],
    closed: &mut Closed,
) {
    // Signed volume (sum of p0 . (p1 x p2) / 6) about a vertex of the component.
    let o = positions[triangles[members[0]][0] as usize];
    let extent = members
        .iter()
        .flat_map(|&t| triangles[t])
        .map(|i| (positions[i as usize] - o).abs().max_element())
        .fold(0.0, f64::max);
    let volume: f64 = members
        .iter()
        .map(|&t| {
            let [a, b, c] =
                wound(triangles[t], flip[t] == Some(true)).map(|i| positions[i as usize] - o);
            a.dot(b.cross(c))
        })
        .sum::<f64>()
        / 6.0;
    if volume.abs() <= 1e-12 * extent.powi(3) {
        return;
    }
    closed.components += 1;
    let outward_flips = volume < 0.0;
    let mut reversed = 0;
    for &t in members {
        let f = (flip[t] == Some(true)) ^ outward_flips;
        if f {
            triangles[t] = wound(triangles[t], true);
            reversed += 1;
        }
        for &v in &triangles[t] {
            closed.vertices[v as usize] = true;
        }
    }
    if reversed > 0 {
        closed.components_reversed += 1;
        closed.reversed += reversed;
    }
}

/// The line of the first OBJ statement that cannot be parsed or that points past the
/// vertices (tobj reports no lines).
fn obj_error_line(text: &str) -> Option<usize> {
    let total = text
        .lines()
        .filter(|l| l.split_whitespace().next() == Some("v"))
        .count() as i64;
    let mut seen = 0i64;
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let nums = |n: usize, words: std::str::SplitWhitespace| {
            let v: Vec<&str> = words.collect();
            v.len() < n
                || v.iter()
                    .take(n)
                    .any(|w| w.parse::<f64>().map_or(true, |x| !x.is_finite()))
        };
        // Positive indices count from the file's first vertex, negative ones back from the
        // last vertex read so far.
        let bad_index = |w: &str| {
            w.split('/')
                .next()
                .and_then(|i| i.parse::<i64>().ok())
                .is_none_or(|i| i == 0 || i > total || i < -seen)
        };
        let bad = match key {
            "v" => {
                seen += 1;
                nums(3, words)
            }
            "vn" => nums(3, words),
            "vt" => nums(1, words),
            "f" => {
                let v: Vec<&str> = words.collect();
                v.len() < 3 || v.iter().any(|w| bad_index(w))
            }
            _ => false,
        };
        if bad {
            return Some(i + 1);
        }
    }
    None
}

/// Where a mesh comes from: a fur block's body or a mesh head.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum MeshSource {
    /// Kami's own furry critter (no download needed).
    Critter,
    /// An OBJ, OFF or PLY file; a relative path is taken from the scene file's folder.
    File(String),
    /// A mesh of the CGAL demo data in Debian's `libcgal-demo` (e.g. "lion-head.off"),
    /// extracted on first use into the system's temporary folder.
    CgalDemo(String),
    /// A skinned, animated glTF 2.0 mesh (`.gltf` or `.glb`; relative to the scene file's
    /// folder): the first node with a mesh and a skin, posed by `animation` (by name; absent:
    /// the file's first one) with linear blend skinning, looping. Scene frames are
    /// converted to seconds by `fps`. See docs/fur_skinned.md.
    Gltf {
        file: String,
        #[serde(default)]
        animation: Option<String>,
        #[serde(default = "fps")]
        fps: f64,
    },
}

fn fps() -> f64 {
    24.0
}

impl MeshSource {
    /// The file the source reads, if it is a file (after `Scene::load`: resolved).
    pub fn file(&self) -> Option<&str> {
        match self {
            MeshSource::File(f) | MeshSource::Gltf { file: f, .. } => Some(f),
            _ => None,
        }
    }

    /// The file named relative to the scene file, if the source is a file.
    pub fn file_mut(&mut self) -> Option<&mut String> {
        match self {
            MeshSource::File(f) | MeshSource::Gltf { file: f, .. } => Some(f),
            _ => None,
        }
    }
}
