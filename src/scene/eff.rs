//! The External Force Field as the scene describes it (`forces.eff`): the block, its checks,
//! the grid it spans and the EFF file it may name, read when the scene loads so that a bad
//! file fails then, naming its line. The field itself (the fill rules, sampling, the GPU
//! side) is built from these by `forces::eff`; the file format is described there.
//! These live in `scene` so that loading and checking a scene needs no solver.

use super::forces::Interp;
use crate::error::{KamiError, Result};
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::io::BufRead;
use std::path::Path;
use std::sync::Arc;

/// Most cells in one grid (128³): refused before anything is allocated.
pub const MAX_CELLS: u64 = 128 * 128 * 128;
/// The file format's version (first line `kami-eff 1`).
pub const FILE_VERSION: u32 = 1;
/// Largest EFF file read (a full 128³ grid is about 170 MB of text).
pub const MAX_FILE_BYTES: u64 = 512 << 20;
/// Largest coordinate or force magnitude accepted in a scene block or file.
const MAX_ABS: f64 = 1e9;

/// How a point reads the EFF's cells (each kind says which in its own block).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Sampling {
    /// The cell the point is in (the paper: "when a control point moves into a grid cube").
    Nearest,
    /// Trilinear between the eight cell centres around the point (smooth in space).
    #[default]
    Trilinear,
}

/// The scene's EFF block (`forces.eff`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffDesc {
    /// Centre of the grid (world units). Ignored (must stay unset) with `file`.
    #[serde(default)]
    pub center: [f64; 3],
    /// Edge length of the cubic grid (60 cm in the paper: most hair styles fit in it).
    #[serde(default = "default_extent")]
    pub extent: f64,
    /// Cells per axis (each >= 1, at most `MAX_CELLS` in all).
    #[serde(default = "default_resolution")]
    pub resolution: [u32; 3],
    /// Where the wind comes from: outside the grid it blows from here toward `head`.
    #[serde(default = "default_source")]
    pub source: [f64; 3],
    /// The head point of the fill rules and the point the outside force blows toward;
    /// the grid's centre when unset.
    #[serde(default)]
    pub head: Option<[f64; 3]>,
    /// Magnitude of the outside force (world units / s²); 0: still air outside.
    #[serde(default)]
    pub strength: f64,
    /// Point samples of the wind: each defines the cell it falls in (several in one cell
    /// are averaged). Must lie inside the grid.
    #[serde(default)]
    pub samples: Vec<EffSample>,
    /// Procedural jets that define the cells they cover (a gust without capture data).
    #[serde(default)]
    pub blowers: Vec<Blower>,
    /// An EFF file (see the module docs), relative to the scene file. Its header gives the
    /// grid, source, head and strength (leave those fields unset); samples and blowers
    /// override its cells, and then its filled (`i`) cells are filled again.
    #[serde(default)]
    pub file: Option<String>,
    /// Keys scaling the whole field over time (a gust); 1 without keys.
    #[serde(default)]
    pub gust: Vec<GustKey>,
    /// The file's grid, read by `resolve` at scene load (not part of the scene text).
    #[serde(skip)]
    pub loaded: Option<Loaded>,
}

fn default_extent() -> f64 {
    60.0
}
fn default_resolution() -> [u32; 3] {
    [12, 12, 12]
}
fn default_source() -> [f64; 3] {
    [0.0, 0.0, 100.0]
}

impl Default for EffDesc {
    fn default() -> Self {
        EffDesc {
            center: [0.0; 3],
            extent: default_extent(),
            resolution: default_resolution(),
            source: default_source(),
            head: None,
            strength: 0.0,
            samples: Vec::new(),
            blowers: Vec::new(),
            file: None,
            gust: Vec::new(),
            loaded: None,
        }
    }
}

/// One measured (or typed) wind sample.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffSample {
    /// Where (world units).
    pub at: [f64; 3],
    /// The force there (world units / s²).
    pub force: [f64; 3],
}

/// A jet of air: from `at` along `toward`, a cylinder of `radius` widening by `spread`
/// degrees. Cells whose centre is inside it (downstream of `at`) are defined with
/// `strength · unit(toward) · (1 − (ρ/r)²)²`, ρ the centre's distance from the axis and r the
/// jet's radius there: full on the axis, smoothly nothing at the edge.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Blower {
    /// The nozzle (world units).
    pub at: [f64; 3],
    /// Direction of the jet (any length but zero).
    pub toward: [f64; 3],
    /// Force on the axis (world units / s²).
    pub strength: f64,
    /// Radius of the jet at the nozzle (> 0).
    pub radius: f64,
    /// Half-angle by which the jet widens (degrees, in [0, 80)).
    #[serde(default)]
    pub spread: f64,
}

/// The field's scale from `frame` on (like `WindKey`: held, or blended to the next key).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GustKey {
    pub frame: f64,
    pub scale: f64,
    #[serde(default)]
    pub interp: Interp,
}

/// An EFF file read at scene load (`resolve`): the grid it holds and where it came from.
#[derive(Clone, PartialEq)]
pub struct Loaded(pub Arc<EffFile>);

impl std::fmt::Debug for Loaded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Loaded({:?} cells)", self.0.grid.dims)
    }
}

/// An EFF file as read: its grid, outside force and cells (`d` lines defined, `i` filled).
#[derive(Clone, Debug, PartialEq)]
pub struct EffFile {
    /// The file as named when read (for the built field's block).
    pub path: String,
    pub grid: Grid,
    pub source: DVec3,
    pub head: DVec3,
    pub strength: f64,
    pub cells: Vec<DVec3>,
    pub defined: Vec<bool>,
}

impl EffFile {
    /// Read an EFF file (`forces::eff` module docs). Errors name the file and line: a bad
    /// header, a grid beyond `MAX_CELLS` (refused before allocating), a bad or non-finite
    /// number, a truncated line, and a file of the wrong size for its header.
    pub fn read(path: impl AsRef<Path>) -> Result<EffFile> {
        let path = path.as_ref();
        let name = path.display().to_string();
        let err = |line: usize, message: String| data_err(&name, line, message);
        let io = |source| KamiError::Io {
            path: path.to_path_buf(),
            source,
        };
        let meta = std::fs::metadata(path).map_err(io)?;
        if meta.is_dir() {
            return Err(err(0, "is a directory, not an EFF file".into()));
        }
        if meta.len() > MAX_FILE_BYTES {
            return Err(err(
                0,
                format!(
                    "{} bytes is more than an EFF file of at most {MAX_CELLS} cells needs \
                     ({MAX_FILE_BYTES} bytes at most)",
                    meta.len()
                ),
            ));
        }
        let mut reader = std::io::BufReader::new(std::fs::File::open(path).map_err(io)?);
        let mut lines = Lines {
            reader: &mut reader,
            number: 0,
            buf: String::new(),
        };
        version_line(&mut lines, &name)?;
        let Header {
            grid,
            source,
            head,
            strength,
        } = read_header(&mut lines, &name)?;
        let (cells, defined) = read_cells(&mut lines, &name, &grid)?;
        Ok(EffFile {
            path: name,
            grid,
            source,
            head,
            strength,
            cells,
            defined,
        })
    }
}

/// An error at `line` of the file `name` (0: the file as a whole).
fn data_err(name: &str, line: usize, message: String) -> KamiError {
    KamiError::Data {
        path: name.to_string(),
        line: if line == 0 { None } else { Some(line) },
        message,
    }
}

/// The version line, `kami-eff 1`.
fn version_line<R: BufRead>(lines: &mut Lines<'_, R>, name: &str) -> Result<()> {
    let err = |line: usize, message: String| data_err(name, line, message);
    let (n, first) = lines
        .next_content()
        .map_err(|m| err(lines.number, m))?
        .ok_or_else(|| err(0, "empty file: an EFF file starts with `kami-eff 1`".into()))?;
    let mut words = first.split_whitespace();
    if words.next() != Some("kami-eff") {
        return Err(err(
            n,
            format!("not an EFF file: the first line must be `kami-eff {FILE_VERSION}`"),
        ));
    }
    match words.next().map(str::parse::<u32>) {
        Some(Ok(FILE_VERSION)) if words.next().is_none() => Ok(()),
        _ => Err(err(
            n,
            format!(
                "unsupported version line `{first}`: this Kami reads `kami-eff \
                 {FILE_VERSION}`"
            ),
        )),
    }
}

/// An EFF file's header as read: the grid, the outside force's source, head and strength.
struct Header {
    grid: Grid,
    source: DVec3,
    head: DVec3,
    strength: f64,
}

/// The header, up to its `cells` line: each key once, every one of them given, and an
/// outside force with a direction.
fn read_header<R: BufRead>(lines: &mut Lines<'_, R>, name: &str) -> Result<Header> {
    let err = |line: usize, message: String| data_err(name, line, message);
    let mut resolution: Option<[u32; 3]> = None;
    let mut vecs: [Option<DVec3>; 4] = [None; 4];
    const VEC_KEYS: [&str; 4] = ["origin", "cell", "source", "head"];
    let mut strength: Option<f64> = None;
    let header_end = loop {
        let Some((n, line)) = lines.next_content().map_err(|m| err(lines.number, m))? else {
            return Err(err(
                lines.number,
                "truncated header: no `cells` line".into(),
            ));
        };
        let mut words = line.split_whitespace();
        let key = words.next().unwrap_or_default();
        let rest: Vec<&str> = words.collect();
        let dup = |k: &str| err(n, format!("`{k}` is given twice"));
        match key {
            "cells" => {
                if !rest.is_empty() {
                    return Err(err(n, "`cells` takes nothing after it".into()));
                }
                break n;
            }
            "resolution" => {
                if resolution.is_some() {
                    return Err(dup(key));
                }
                let r = parse_n::<u32, 3>(&rest).map_err(|m| err(n, format!("resolution: {m}")))?;
                cell_total("resolution", r)
                    .map_err(|(v, a)| err(n, format!("resolution {v}: {a}")))?;
                resolution = Some(r);
            }
            "strength" => {
                if strength.is_some() {
                    return Err(dup(key));
                }
                let [s] = parse_n::<f64, 1>(&rest).map_err(|m| err(n, format!("strength: {m}")))?;
                check_finite(&[s]).map_err(|m| err(n, format!("strength: {m}")))?;
                strength = Some(s);
            }
            k if VEC_KEYS.contains(&k) => {
                let slot = VEC_KEYS.iter().position(|v| *v == k).unwrap();
                if vecs[slot].is_some() {
                    return Err(dup(key));
                }
                let v = parse_n::<f64, 3>(&rest).map_err(|m| err(n, format!("{k}: {m}")))?;
                check_finite(&v).map_err(|m| err(n, format!("{k}: {m}")))?;
                if k == "cell" && v.iter().any(|c| *c <= 0.0) {
                    return Err(err(n, format!("cell: sizes must be > 0, found {v:?}")));
                }
                vecs[slot] = Some(DVec3::from(v));
            }
            other => {
                return Err(err(
                    n,
                    format!(
                        "unknown header key `{other}` (expected resolution, origin, cell, \
                         source, head, strength, then cells)"
                    ),
                ))
            }
        }
    };
    let missing = |k: &str| {
        err(
            header_end,
            format!("the header has no `{k}` line before `cells`"),
        )
    };
    let dims = resolution.ok_or_else(|| missing("resolution"))?;
    let [origin, cell, source, head] = [0, 1, 2, 3].map(|i| vecs[i]);
    let origin = origin.ok_or_else(|| missing("origin"))?;
    let cell = cell.ok_or_else(|| missing("cell"))?;
    let source = source.ok_or_else(|| missing("source"))?;
    let head = head.ok_or_else(|| missing("head"))?;
    let strength = strength.ok_or_else(|| missing("strength"))?;
    if strength != 0.0 && (head - source).length() < 1e-9 {
        return Err(err(
            header_end,
            "source and head coincide: the outside force has no direction".into(),
        ));
    }
    Ok(Header {
        grid: Grid { origin, cell, dims },
        source,
        head,
        strength,
    })
}

/// The cell lines after the header, exactly one per cell of `grid`: each cell's force and
/// whether it was defined (`d`) or filled (`i`).
fn read_cells<R: BufRead>(
    lines: &mut Lines<'_, R>,
    name: &str,
    grid: &Grid,
) -> Result<(Vec<DVec3>, Vec<bool>)> {
    let err = |line: usize, message: String| data_err(name, line, message);
    let dims = grid.dims;
    let count = grid.count();
    let wrong_size = |line: usize, found: String| {
        err(
            line,
            format!(
                "an EFF file of the wrong size: the header's resolution {dims:?} needs \
                 {count} cell lines, {found}"
            ),
        )
    };
    let mut cells = Vec::with_capacity(count);
    let mut defined = Vec::with_capacity(count);
    while let Some((n, line)) = lines.next_content().map_err(|m| err(lines.number, m))? {
        if cells.len() == count {
            return Err(wrong_size(n, "and there is more".into()));
        }
        let ijk = grid.ijk(cells.len());
        let mut words = line.split_whitespace();
        let flag = match words.next() {
            Some("d") => true,
            Some("i") => false,
            other => {
                return Err(err(
                    n,
                    format!(
                        "cell {ijk:?}: a cell line starts with `d` (defined) or `i` \
                         (filled), found `{}`",
                        other.unwrap_or_default()
                    ),
                ))
            }
        };
        let rest: Vec<&str> = words.collect();
        let v = parse_n::<f64, 3>(&rest).map_err(|m| err(n, format!("cell {ijk:?}: {m}")))?;
        check_finite(&v).map_err(|m| err(n, format!("cell {ijk:?}: {m}")))?;
        cells.push(DVec3::from(v));
        defined.push(flag);
    }
    if cells.len() < count {
        return Err(wrong_size(
            lines.number,
            format!("the file ends after {}", cells.len()),
        ));
    }
    Ok((cells, defined))
}

pub(crate) fn bad(field: &str, value: impl std::fmt::Display, allowed: &str) -> KamiError {
    KamiError::Invalid {
        file: String::new(),
        field: field.to_string(),
        value: value.to_string(),
        allowed: allowed.to_string(),
    }
}

pub(crate) fn finite(field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v.abs() <= MAX_ABS {
        Ok(())
    } else {
        Err(bad(
            field,
            v,
            &format!("must be a finite number of magnitude at most {MAX_ABS:e}"),
        ))
    }
}

pub(crate) fn finite3(field: &str, v: [f64; 3]) -> Result<()> {
    for (i, c) in v.iter().enumerate() {
        finite(&format!("{field}[{i}]"), *c)?;
    }
    Ok(())
}

/// Cells in a grid of `dims`, refused (naming `field`) when zero along an axis or beyond
/// `MAX_CELLS`, computed without overflow and before anything is allocated.
pub(crate) fn cell_total(
    field: &str,
    dims: [u32; 3],
) -> std::result::Result<u64, (String, String)> {
    if dims.contains(&0) {
        return Err((
            format!("{dims:?}"),
            "every axis needs at least one cell".into(),
        ));
    }
    // u128: three u32 axes cannot overflow it.
    let n = dims.iter().map(|&d| d as u128).product::<u128>();
    if n > MAX_CELLS as u128 {
        return Err((
            format!("{dims:?} ({n} cells)"),
            format!("{field}: at most {MAX_CELLS} cells (128³) in all"),
        ));
    }
    Ok(n as u64)
}

impl EffDesc {
    /// Check every value (field names as in the scene: `forces.eff.extent`). Files are checked when
    /// read (`resolve`); `build` also checks the samples against the grid.
    pub fn validate(&self) -> Result<()> {
        let with_file = self.file.is_some();
        if with_file {
            let d = EffDesc::default();
            let unset: [(&str, bool); 5] = [
                ("forces.eff.center", self.center == d.center),
                ("forces.eff.extent", self.extent == d.extent),
                ("forces.eff.resolution", self.resolution == d.resolution),
                ("forces.eff.source", self.source == d.source),
                ("forces.eff.strength", self.strength == d.strength),
            ];
            for (field, is_unset) in unset {
                if !is_unset {
                    return Err(bad(
                        field,
                        "set",
                        "the grid, source and strength come from forces.eff.file: set them in the \
                         file or drop the file",
                    ));
                }
            }
            if self.head.is_some() {
                return Err(bad(
                    "forces.eff.head",
                    "set",
                    "the head point comes from forces.eff.file: set it in the file or drop the file",
                ));
            }
            if self.file.as_deref().is_some_and(|f| f.trim().is_empty()) {
                return Err(bad("forces.eff.file", "\"\"", "must name a file"));
            }
        }
        finite3("forces.eff.center", self.center)?;
        finite("forces.eff.extent", self.extent)?;
        if self.extent <= 0.0 {
            return Err(bad("forces.eff.extent", self.extent, "must be > 0"));
        }
        cell_total("forces.eff.resolution", self.resolution)
            .map_err(|(v, a)| bad("forces.eff.resolution", v, &a))?;
        finite3("forces.eff.source", self.source)?;
        if let Some(h) = self.head {
            finite3("forces.eff.head", h)?;
        }
        finite("forces.eff.strength", self.strength)?;
        if self.strength != 0.0 && !with_file {
            let h = self.head.map_or(DVec3::from(self.center), DVec3::from);
            if (h - DVec3::from(self.source)).length() < 1e-9 {
                return Err(bad(
                    "forces.eff.source",
                    format!("{:?}", self.source),
                    "must differ from the head point (the outside force blows from the \
                     source toward the head)",
                ));
            }
        }
        for (i, s) in self.samples.iter().enumerate() {
            finite3(&format!("forces.eff.samples[{i}].at"), s.at)?;
            finite3(&format!("forces.eff.samples[{i}].force"), s.force)?;
        }
        for (i, b) in self.blowers.iter().enumerate() {
            let f = |n: &str| format!("forces.eff.blowers[{i}].{n}");
            finite3(&f("at"), b.at)?;
            finite3(&f("toward"), b.toward)?;
            if DVec3::from(b.toward).length() < 1e-12 {
                return Err(bad(
                    &f("toward"),
                    format!("{:?}", b.toward),
                    "must be a non-zero direction",
                ));
            }
            finite(&f("strength"), b.strength)?;
            finite(&f("radius"), b.radius)?;
            if b.radius <= 0.0 {
                return Err(bad(&f("radius"), b.radius, "must be > 0"));
            }
            finite(&f("spread"), b.spread)?;
            if !(0.0..80.0).contains(&b.spread) {
                return Err(bad(&f("spread"), b.spread, "must be in [0, 80) degrees"));
            }
        }
        for (i, k) in self.gust.iter().enumerate() {
            finite(&format!("forces.eff.gust[{i}].frame"), k.frame)?;
            finite(&format!("forces.eff.gust[{i}].scale"), k.scale)?;
            if i > 0 && k.frame < self.gust[i - 1].frame {
                return Err(bad(
                    &format!("forces.eff.gust[{i}].frame"),
                    k.frame,
                    "gust keys must be in frame order",
                ));
            }
        }
        Ok(())
    }

    /// The grid this block describes (without a file).
    pub fn grid(&self) -> Grid {
        let extent = DVec3::splat(self.extent);
        let dims = self.resolution;
        Grid {
            origin: DVec3::from(self.center) - 0.5 * extent,
            cell: extent / DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64),
            dims,
        }
    }
}

/// Where the cells are: `dims` cells from `origin`, each `cell` wide per axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub origin: DVec3,
    pub cell: DVec3,
    pub dims: [u32; 3],
}

impl Grid {
    pub fn count(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }
    pub fn index(&self, i: [u32; 3]) -> usize {
        i[0] as usize
            + self.dims[0] as usize * (i[1] as usize + self.dims[1] as usize * i[2] as usize)
    }
    pub fn ijk(&self, index: usize) -> [u32; 3] {
        let (x, y) = (self.dims[0] as usize, self.dims[1] as usize);
        [
            (index % x) as u32,
            (index / x % y) as u32,
            (index / (x * y)) as u32,
        ]
    }
    pub fn center(&self, i: [u32; 3]) -> DVec3 {
        self.origin + self.cell * (DVec3::new(i[0] as f64, i[1] as f64, i[2] as f64) + 0.5)
    }
    pub fn max(&self) -> DVec3 {
        self.origin
            + self.cell
                * DVec3::new(
                    self.dims[0] as f64,
                    self.dims[1] as f64,
                    self.dims[2] as f64,
                )
    }
    /// The cell containing `p`, if inside (faces belong to the cell above, the top faces to
    /// the last cell).
    pub fn cell_of(&self, p: DVec3) -> Option<[u32; 3]> {
        let g = (p - self.origin) / self.cell;
        let mut out = [0; 3];
        for a in 0..3 {
            if !(g[a] >= 0.0 && g[a] <= self.dims[a] as f64) {
                return None;
            }
            out[a] = (g[a].floor() as u32).min(self.dims[a] - 1);
        }
        Some(out)
    }
}

/// Content lines of a text file with their 1-based numbers, skipping blanks and `#`
/// comments; a line longer than 4 KiB is refused rather than read whole.
struct Lines<'a, R: BufRead> {
    reader: &'a mut R,
    number: usize,
    buf: String,
}

impl<R: BufRead> Lines<'_, R> {
    fn next_content(&mut self) -> std::result::Result<Option<(usize, String)>, String> {
        use std::io::Read;
        const LONGEST: u64 = 4096;
        loop {
            self.buf.clear();
            let got = (&mut *self.reader)
                .take(LONGEST)
                .read_line(&mut self.buf)
                .map_err(|e| {
                    self.number += 1;
                    format!("cannot read: {e}")
                })?;
            if got == 0 {
                return Ok(None);
            }
            self.number += 1;
            if got as u64 == LONGEST && !self.buf.ends_with('\n') {
                return Err(format!("line longer than {LONGEST} bytes"));
            }
            let t = self.buf.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            return Ok(Some((self.number, t.to_string())));
        }
    }
}

fn parse_n<T: std::str::FromStr, const N: usize>(
    words: &[&str],
) -> std::result::Result<[T; N], String> {
    if words.len() != N {
        return Err(format!(
            "needs {N} number{}, found {}{}",
            if N == 1 { "" } else { "s" },
            words.len(),
            if words.len() < N { " (truncated?)" } else { "" }
        ));
    }
    let mut out = Vec::with_capacity(N);
    for w in words {
        out.push(
            w.parse::<T>()
                .map_err(|_| format!("`{w}` is not a number"))?,
        );
    }
    out.try_into().map_err(|_| "unreachable".to_string())
}

fn check_finite(v: &[f64]) -> std::result::Result<(), String> {
    match v.iter().find(|c| !c.is_finite() || c.abs() > MAX_ABS) {
        Some(c) => Err(format!(
            "{c} is not a finite number of magnitude at most {MAX_ABS:e}"
        )),
        None => Ok(()),
    }
}

/// The cell of each of the block's samples, refused (naming the sample) outside the grid.
pub(crate) fn sample_cells(desc: &EffDesc, g: &Grid) -> Result<Vec<[u32; 3]>> {
    desc.samples
        .iter()
        .enumerate()
        .map(|(i, s)| {
            g.cell_of(DVec3::from(s.at)).ok_or_else(|| {
                bad(
                    &format!("forces.eff.samples[{i}].at"),
                    format!("{:?}", s.at),
                    &format!(
                        "must lie inside the grid, from {:?} to {:?}",
                        g.origin.to_array(),
                        g.max().to_array()
                    ),
                )
            })
        })
        .collect()
}

/// Read the file the block names (relative to `dir`, the scene file's folder) so that
/// building the grid cannot fail later on it; errors name the file and line. Also checks
/// the block (so a bad EFF block fails at load, naming the field).
pub fn resolve(desc: &mut EffDesc, dir: &Path) -> Result<()> {
    desc.validate()?;
    if let Some(file) = &desc.file {
        let path = if Path::new(file).is_relative() {
            dir.join(file)
        } else {
            Path::new(file).to_path_buf()
        };
        desc.loaded = Some(Loaded(Arc::new(EffFile::read(&path)?)));
    }
    // Samples outside the grid: fail now, not when the stage builds it (after this,
    // `Eff::build` cannot fail on this block).
    let grid = match &desc.loaded {
        Some(Loaded(e)) => e.grid,
        None => desc.grid(),
    };
    sample_cells(desc, &grid)?;
    Ok(())
}
