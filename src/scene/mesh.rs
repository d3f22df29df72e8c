//! Triangle meshes for fur: OBJ (through `tobj`), PLY (through `ply-rs-bw`) and OFF (a few
//! lines of parsing). Vertex normals are taken from the file or computed (area-weighted);
//! degenerate triangles are kept (they get no hair: zero area), unreferenced vertices are
//! ignored, non-manifold edges are fine. A file that cannot be used is refused with the line
//! where it broke.

use crate::error::{KamiError, Result};
use glam::DVec3;
use std::path::{Path, PathBuf};

/// An indexed triangle mesh with per-vertex normals.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub positions: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
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
        let bytes = std::fs::read(path).map_err(|source| KamiError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .unwrap_or_default();
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
    /// computes missing normals.
    pub fn new(
        positions: Vec<DVec3>,
        triangles: Vec<[u32; 3]>,
        normals: Option<Vec<DVec3>>,
        name: &str,
    ) -> Result<Mesh> {
        if positions.is_empty() || triangles.is_empty() {
            return Err(err(name, None, "the mesh has no triangles"));
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(err(
                name,
                None,
                format!("vertex {i} is not finite: {:?}", positions[i]),
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
        let normals = match normals {
            Some(n)
                if n.len() == positions.len()
                    && n.iter().all(|v| v.is_finite() && v.length() > 1e-12) =>
            {
                n.into_iter().map(|v| v.normalize()).collect()
            }
            _ => vertex_normals(&positions, &triangles),
        };
        Ok(Mesh {
            positions,
            normals,
            triangles,
        })
    }

    pub fn from_obj(text: &str, name: &str) -> Result<Mesh> {
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ..Default::default()
        };
        let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| {
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
        let mut count = |what: &str| -> Result<usize> {
            let (l, t) = next(what)?;
            t.parse::<usize>()
                .map_err(|_| err(name, Some(l), format!("{what}: {t:?} is not a count")))
        };
        let nv = count("the vertex count")?;
        let nf = count("the face count")?;
        let _ne = count("the edge count")?;
        if nv > 50_000_000 || nf > 50_000_000 {
            return Err(err(
                name,
                None,
                format!("{nv} vertices and {nf} faces is beyond what Kami loads (50 million)"),
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

    pub fn from_ply(bytes: &[u8], name: &str) -> Result<Mesh> {
        use ply_rs_bw::{
            parser::Parser,
            ply::{DefaultElement, Property},
        };
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
            if idx.len() < 3 || idx.iter().any(|&i| i < 0) {
                return Err(err(
                    name,
                    None,
                    format!("face {fi} has {} vertices or a negative index", idx.len()),
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

/// Area-weighted vertex normals; vertices no triangle gives a normal point up.
pub fn vertex_normals(positions: &[DVec3], triangles: &[[u32; 3]]) -> Vec<DVec3> {
    let mut n = vec![DVec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
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
