//! The External Force Field (Kazama, Sugisaki, Morishima, section 3.3): a voxel grid of wind
//! forces around the head, shared by every hair system (strips read it at their control
//! points, Anjyo's projective dynamics at every segment).
//!
//! # The field
//!
//! A box of `dims` cells starting at `origin`, each `cell` wide per axis (from the scene
//! block: a cube of edge `extent` centred on `center`, 60 cm in the paper). Every cell holds
//! one force (an acceleration, world units / s², like gravity). Outside the grid the force
//! is the **outside force** `O = strength · unit(head − source)`: one uniform direction,
//! from the wind's source toward the head (the paper: "the direction of the force from a
//! point where the wind is generated towards the head"). A per-point direction (from the
//! source through each point) was rejected: it is the same within a few degrees for a
//! source far from a 60 cm grid, and a uniform `O` keeps the fill rules below linear.
//!
//! # Defined cells and the two fill rules
//!
//! Cells are *defined* by the scene's point samples (a cell's value is the mean of the
//! samples in it), by its blowers (procedural jets: a gust without capture data), by an EFF
//! file, by `set_cell` or the brush. Every other cell is filled, each from the defined cells
//! only (never from another filled cell, so the order does not matter), by our reading of
//! the paper's two rules. Let `H` be the head point, `e` the empty cell's centre, `n1` the
//! nearest defined cell centre (Euclidean distance `d1`; ties go to the lower cell index),
//! `n2` the second nearest (`d2`):
//!
//! - **(a) between the two nearest defined cells**, when `e` is strictly nearer to the head
//!   than `n1` (`|e − H| < |n1 − H|`: the cell lies inside the measured shell):
//!   `f = (d2 f(n1) + d1 f(n2)) / (d1 + d2)`, linear interpolation along `n1 → n2` at
//!   `t = d1 / (d1 + d2)` (exact when `e` is on that segment). One defined cell: `f(n1)`.
//! - **(b) between the nearest defined cell and the outside force** otherwise (the cell lies
//!   outward of the measured cells): along the ray from `n1` through `e`, which leaves the
//!   grid at `X`, the force goes linearly from `f(n1)` at `n1` to `O` at `X`:
//!   `f = f(n1) + (O − f(n1)) · d1 / |X − n1|`.
//! - No defined cell at all: every cell is `O` (the only wind known).
//!
//! Ties matter on a lattice (cells mirror each other about a centred head), so distances
//! are computed from integer cell offsets, axes of equal cell size summed before scaling:
//! equal distances are bit-identical and "ties go to the lower index" and "strictly nearer"
//! hold exactly; the head point is snapped to 1/65536 of a cell for the same reason.
//!
//! # Sampling
//!
//! Nearest: the value of the cell containing `p` (the paper: "when a control point moves
//! into a grid cube"). Trilinear: between the eight cell centres around `p`, clamped to the
//! border cells' values between the outermost centres and the grid's faces. Beyond the
//! faces the field blends to `O` over a band of `BAND_CELLS` cells:
//! `f(p) = (1 − w) f_grid(clamp(p)) + w O` with `w = min(1, |δ|)`, `δ` the per-axis distance
//! outside the box in cells. So the trilinear field is continuous everywhere, including the
//! grid's surface, and equals `O` from one cell outside on.
//!
//! # Time
//!
//! Gust keys scale the whole field (grid and outside force) over time, like the scene's
//! keyed wind: `Eff::scale_at(frame)` (1 without keys). `sample` is the unscaled field,
//! `sample_at` includes the gust. On the GPU the world's grid stays at scale 1 and each kernel
//! multiplies `eff_field` by the gust of its own substep (`systems::world`).
//!
//! # EFF files
//!
//! A text file (`Eff::save`, `Eff::load`, or `file:` in the scene block, relative to the
//! scene file and read by `resolve` when the scene loads):
//!
//! ```text
//! kami-eff 1
//! # comments and blank lines are allowed anywhere
//! resolution 12 12 12
//! origin -30.0 -30.0 -30.0
//! cell 5.0 5.0 5.0
//! source 0.0 0.0 100.0
//! head 0.0 0.0 0.0
//! strength 300.0
//! cells
//! d 1.5 0.0 -200.0
//! i 1.25 0.0 -210.5
//! ...
//! ```
//!
//! The first line is the format and its version; then the six header keys, each once, in
//! any order; `cells` ends the header. Then exactly `rx · ry · rz` cell lines, x fastest,
//! then y, then z: `d` (a defined cell) or `i` (filled by the rules) and the force. Numbers
//! are written in Rust's shortest round-trip form (`{:?}`), so save → load is exact.
//! Errors name the file and the line (`KamiError::Data`).

use crate::error::{KamiError, Result};
use crate::scene::eff::{bad, finite, finite3, sample_cells, Grid};
use crate::scene::Sampling;
use glam::DVec3;
use std::io::Write;
use std::path::Path;

// The scene's side of the field (its block, the grid it spans, the file reader) lives in
// `scene::eff`, so that loading a scene needs no solver; re-exported here where the field is.
pub use crate::scene::eff::{
    resolve, Blower, EffDesc, EffFile, EffSample, GustKey, Loaded, FILE_VERSION, MAX_CELLS,
    MAX_FILE_BYTES,
};

/// Width (in cells) of the band outside the grid over which the field blends to the outside
/// force.
pub const BAND_CELLS: f64 = 1.0;

/// A built grid: every cell has a force.
#[derive(Clone, PartialEq)]
pub struct Eff {
    /// The block it was built from (for a loaded file: the file, its grid in `center`,
    /// `extent` and `resolution` as nearly as a cubic block can say it).
    pub desc: EffDesc,
    grid: Grid,
    source: DVec3,
    head: DVec3,
    strength: f64,
    cells: Vec<DVec3>,
    defined: Vec<bool>,
    /// `max_force`: exact after a build, load or refill, an upper bound after edits.
    bound: f64,
}

impl std::fmt::Debug for Eff {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Eff")
            .field("origin", &self.grid.origin)
            .field("cell", &self.grid.cell)
            .field("dims", &self.grid.dims)
            .field("source", &self.source)
            .field("head", &self.head)
            .field("strength", &self.strength)
            .field("defined", &self.defined.iter().filter(|d| **d).count())
            .finish_non_exhaustive()
    }
}

impl Eff {
    /// Build the grid from the scene block: defined cells from the file, samples and
    /// blowers, the rest by the paper's two rules (module docs).
    pub fn build(desc: &EffDesc) -> Result<Eff> {
        Self::from_samples(desc, &[])
    }

    /// `build`, with extra point samples (position, force) defining cells too, such as the
    /// forces fitted from motion capture. Extra samples outside the grid are left out (hair
    /// leaves the grid); non-finite ones are refused.
    pub fn from_samples(desc: &EffDesc, extra: &[(DVec3, DVec3)]) -> Result<Eff> {
        desc.validate()?;
        let base = match (&desc.file, &desc.loaded) {
            (Some(file), None) => {
                return Err(bad(
                    "forces.eff.file",
                    file,
                    "was not read: load the scene with Scene::load (or call \
                     forces::eff::resolve) so the file is read relative to the scene",
                ))
            }
            (_, Some(Loaded(f))) => Some(Eff::from_file(f)),
            (None, None) => None,
        };
        let mut eff = match &base {
            Some(e) => Eff {
                desc: desc.clone(),
                ..e.clone()
            },
            None => {
                let grid = desc.grid();
                let n = grid.count();
                Eff {
                    desc: desc.clone(),
                    grid,
                    source: DVec3::from(desc.source),
                    head: desc.head.map_or(DVec3::from(desc.center), DVec3::from),
                    strength: desc.strength,
                    cells: vec![DVec3::ZERO; n],
                    defined: vec![false; n],
                    bound: 0.0,
                }
            }
        };
        // Accumulate the block's and the extra samples per cell.
        let mut sum: std::collections::BTreeMap<usize, (DVec3, u32)> = Default::default();
        let g = eff.grid;
        for (c, s) in sample_cells(desc, &g)?.into_iter().zip(&desc.samples) {
            let e = sum.entry(g.index(c)).or_default();
            e.0 += DVec3::from(s.force);
            e.1 += 1;
        }
        for (i, (at, force)) in extra.iter().enumerate() {
            if !at.is_finite() || !force.is_finite() {
                return Err(bad(
                    &format!("samples[{i}]"),
                    format!("{at} {force}"),
                    "must be finite",
                ));
            }
            if let Some(c) = g.cell_of(*at) {
                let e = sum.entry(g.index(c)).or_default();
                e.0 += *force;
                e.1 += 1;
            }
        }
        for b in &desc.blowers {
            for (index, value) in blower_cells(b, &g) {
                let e = sum.entry(index).or_default();
                e.0 += value;
                e.1 += 1;
            }
        }
        if base.is_some() && sum.is_empty() {
            // The file as it was: its filled cells stay as they were saved.
            return Ok(eff);
        }
        // New defined cells (over a file: its `i` cells are filled again from them).
        for (index, (s, n)) in sum {
            eff.cells[index] = s / n as f64;
            eff.defined[index] = true;
        }
        eff.refill();
        Ok(eff)
    }

    /// Fill every cell that is not defined by the two rules (module docs), from the defined
    /// cells only. Deterministic: each cell depends on the defined cells alone.
    pub fn refill(&mut self) {
        let g = self.grid;
        let outside = self.outside();
        // The search runs in lattice units (cell (i, j, k) at (i, j, k)), so that equal
        // distances compare equal (module docs: ties).
        let lattice = |i: usize| {
            let [x, y, z] = g.ijk(i);
            DVec3::new(x as f64, y as f64, z as f64)
        };
        let metric = Metric::new(g.cell);
        let mut pts: Vec<(DVec3, u32)> = (0..self.cells.len())
            .filter(|&i| self.defined[i])
            .map(|i| (lattice(i), i as u32))
            .collect();
        if pts.is_empty() {
            self.cells.iter_mut().for_each(|c| *c = outside);
            self.bound = outside.length();
            return;
        }
        kd_build(&mut pts, 0);
        // The head in lattice units, snapped to 1/65536 cell so that a head on a centre,
        // face or corner is exactly there.
        let head = ((self.head - g.origin) / g.cell - 0.5) * 65536.0;
        let head = head.round() / 65536.0;
        let (lo, hi) = (g.origin, g.max());
        for i in 0..self.cells.len() {
            if self.defined[i] {
                continue;
            }
            let e = lattice(i);
            let mut best = [(f64::INFINITY, u32::MAX); 2];
            kd_nearest2(&pts, 0, e, &metric, &mut best);
            let (n1, n2) = (best[0].1 as usize, best[1].1);
            let f1 = self.cells[n1];
            let d1 = best[0].0.sqrt();
            self.cells[i] = if metric.d2(e - head) < metric.d2(lattice(n1) - head) {
                // (a) between the two nearest defined cells.
                if n2 == u32::MAX {
                    f1
                } else {
                    let d2 = best[1].0.sqrt();
                    (f1 * d2 + self.cells[n2 as usize] * d1) / (d1 + d2)
                }
            } else {
                // (b) from the nearest defined cell to the outside force at the grid's face,
                // along the ray from it through this cell (world units).
                let c1 = g.center(g.ijk(n1));
                let u = (g.center(g.ijk(i)) - c1).normalize();
                let mut t_exit = f64::INFINITY;
                for a in 0..3 {
                    if u[a] > 0.0 {
                        t_exit = t_exit.min((hi[a] - c1[a]) / u[a]);
                    } else if u[a] < 0.0 {
                        t_exit = t_exit.min((lo[a] - c1[a]) / u[a]);
                    }
                }
                f1 + (outside - f1) * (d1 / t_exit).min(1.0)
            };
        }
        self.bound = self.largest();
    }

    fn largest(&self) -> f64 {
        self.cells
            .iter()
            .map(|c| c.length())
            .fold(self.outside().length(), f64::max)
    }

    fn with_bound(mut self) -> Eff {
        self.bound = self.largest();
        self
    }

    /// The force at world point `p`, without the gust scale (outside the grid: the outside
    /// force, blended over `BAND_CELLS` beyond the faces).
    pub fn sample(&self, p: DVec3, sampling: Sampling) -> DVec3 {
        let g = &self.grid;
        let below = (g.origin - p).max(DVec3::ZERO);
        let above = (p - g.max()).max(DVec3::ZERO);
        let w = ((below + above) / g.cell / BAND_CELLS).length().min(1.0);
        if w >= 1.0 {
            return self.outside();
        }
        let inside = match sampling {
            Sampling::Nearest => {
                let q = (p - g.origin) / g.cell;
                let i = [0, 1, 2].map(|a| (q[a].floor().max(0.0) as u32).min(g.dims[a] - 1));
                self.cells[g.index(i)]
            }
            Sampling::Trilinear => self.trilinear(p),
        };
        if w > 0.0 {
            inside * (1.0 - w) + self.outside() * w
        } else {
            inside
        }
    }

    fn trilinear(&self, p: DVec3) -> DVec3 {
        let g = &self.grid;
        let q = (p - g.origin) / g.cell - 0.5;
        let mut i0 = [0u32; 3];
        let mut i1 = [0u32; 3];
        let mut t = DVec3::ZERO;
        for a in 0..3 {
            let hi = g.dims[a].saturating_sub(2) as f64;
            let f = q[a].floor().clamp(0.0, hi);
            i0[a] = f as u32;
            i1[a] = (i0[a] + 1).min(g.dims[a] - 1);
            t[a] = (q[a] - f).clamp(0.0, 1.0);
        }
        let c = |x: u32, y: u32, z: u32| self.cells[g.index([x, y, z])];
        let x00 = c(i0[0], i0[1], i0[2]).lerp(c(i1[0], i0[1], i0[2]), t.x);
        let x10 = c(i0[0], i1[1], i0[2]).lerp(c(i1[0], i1[1], i0[2]), t.x);
        let x01 = c(i0[0], i0[1], i1[2]).lerp(c(i1[0], i0[1], i1[2]), t.x);
        let x11 = c(i0[0], i1[1], i1[2]).lerp(c(i1[0], i1[1], i1[2]), t.x);
        x00.lerp(x10, t.y).lerp(x01.lerp(x11, t.y), t.z)
    }

    /// The force at `p` at `frame` (fractional): `sample` times the gust scale.
    pub fn sample_at(&self, p: DVec3, frame: f64, sampling: Sampling) -> DVec3 {
        self.sample(p, sampling) * self.scale_at(frame)
    }

    /// The gust scale at `frame` (1 without gust keys).
    pub fn scale_at(&self, frame: f64) -> f64 {
        super::keyed(
            &self.desc.gust,
            frame,
            |k| k.frame,
            |k| k.interp,
            |k| k.scale,
            |a, b, t| a + (b - a) * t,
        )
        .unwrap_or(1.0)
    }

    /// The force outside the grid (unscaled): `strength` from the source toward the head.
    pub fn outside(&self) -> DVec3 {
        if self.strength == 0.0 {
            return DVec3::ZERO;
        }
        (self.head - self.source).normalize_or_zero() * self.strength
    }

    /// The largest force magnitude the field can give (unscaled; every sample is a convex
    /// mix of cells and the outside force): exact after a build, load or `refill`, an upper
    /// bound after `set_cell`, `paint` or `set_outside`. Solvers size their steps with it.
    pub fn max_force(&self) -> f64 {
        self.bound
    }

    /// Cells per axis.
    pub fn dims(&self) -> [u32; 3] {
        self.grid.dims
    }
    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }
    /// Linear index of cell (i, j, k): x fastest (the file's and the GPU's order).
    pub fn index(&self, ijk: [u32; 3]) -> usize {
        self.grid.index(ijk)
    }
    /// (i, j, k) of a linear index.
    pub fn ijk(&self, index: usize) -> [u32; 3] {
        self.grid.ijk(index)
    }
    /// Centre of cell `index` (world).
    pub fn cell_center(&self, index: usize) -> DVec3 {
        self.grid.center(self.grid.ijk(index))
    }
    /// The cell containing `p`, if inside the grid.
    pub fn cell_of(&self, p: DVec3) -> Option<usize> {
        self.grid.cell_of(p).map(|c| self.grid.index(c))
    }
    /// The grid's min corner (world).
    pub fn origin(&self) -> DVec3 {
        self.grid.origin
    }
    /// Cell edge lengths per axis.
    pub fn cell_size(&self) -> DVec3 {
        self.grid.cell
    }
    /// The wind's source, the head point and the outside strength.
    pub fn source(&self) -> DVec3 {
        self.source
    }
    pub fn head(&self) -> DVec3 {
        self.head
    }
    pub fn strength(&self) -> f64 {
        self.strength
    }
    /// Every cell's force, index order.
    pub fn cells(&self) -> &[DVec3] {
        &self.cells
    }
    /// Which cells are defined (the rest were filled by the rules).
    pub fn defined(&self) -> &[bool] {
        &self.defined
    }

    /// Set one cell's force and mark it defined (call `refill` to re-fill the others).
    pub fn set_cell(&mut self, index: usize, force: DVec3) {
        self.cells[index] = force;
        self.defined[index] = true;
        self.bound = self.bound.max(force.length());
    }

    /// Change the outside force (call `refill` to re-fill the empty cells with it).
    pub fn set_outside(&mut self, source: DVec3, head: DVec3, strength: f64) -> Result<()> {
        finite3("forces.eff.source", source.to_array())?;
        finite3("forces.eff.head", head.to_array())?;
        finite("forces.eff.strength", strength)?;
        if strength != 0.0 && (head - source).length() < 1e-9 {
            return Err(bad(
                "forces.eff.source",
                format!("{source}"),
                "must differ from the head point",
            ));
        }
        (self.source, self.head, self.strength) = (source, head, strength);
        self.bound = self.bound.max(strength.abs());
        Ok(())
    }

    /// The brush: every cell whose centre is within `radius` of `center` moves toward
    /// `force` by `strength · (1 − (d/radius)²)²` (strength clamped to [0, 1]: 1 sets the
    /// centre cell to `force`, repeated strokes converge to it) and becomes defined.
    /// Returns the cells touched.
    pub fn paint(&mut self, center: DVec3, radius: f64, force: DVec3, strength: f64) -> usize {
        if radius.is_nan()
            || radius <= 0.0
            || !center.is_finite()
            || !force.is_finite()
            || !strength.is_finite()
        {
            return 0;
        }
        let s = strength.clamp(0.0, 1.0);
        let g = self.grid;
        // Only the cells of the brush's bounding box.
        let lo = ((center - radius - g.origin) / g.cell).floor();
        let hi = ((center + radius - g.origin) / g.cell).floor();
        let range = |a: usize| {
            let top = g.dims[a] as f64 - 1.0;
            (lo[a].clamp(0.0, top) as u32)..=(hi[a].clamp(0.0, top) as u32)
        };
        if (0..3).any(|a| hi[a] < 0.0 || lo[a] > g.dims[a] as f64 - 1.0) {
            return 0;
        }
        let mut touched = 0;
        for k in range(2) {
            for j in range(1) {
                for i in range(0) {
                    let c = g.center([i, j, k]);
                    let d = (c - center).length() / radius;
                    if d >= 1.0 {
                        continue;
                    }
                    let w = s * (1.0 - d * d).powi(2);
                    if w <= 0.0 {
                        continue;
                    }
                    let idx = g.index([i, j, k]);
                    let old = self.cells[idx];
                    self.cells[idx] = old + (force - old) * w;
                    self.bound = self.bound.max(self.cells[idx].length());
                    self.defined[idx] = true;
                    touched += 1;
                }
            }
        }
        touched
    }

    /// Read an EFF file (module docs; `EffFile::read` says what is refused).
    pub fn load(path: impl AsRef<Path>) -> Result<Eff> {
        EffFile::read(path).map(|f| Eff::from_file(&f))
    }

    /// The field an EFF file holds, as saved (its filled cells as they were written).
    pub fn from_file(f: &EffFile) -> Eff {
        let (dims, cell, origin) = (f.grid.dims, f.grid.cell, f.grid.origin);
        let extent = cell * DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64);
        let desc = EffDesc {
            center: (origin + 0.5 * extent).to_array(),
            extent: extent.max_element(),
            resolution: dims,
            source: f.source.to_array(),
            head: Some(f.head.to_array()),
            strength: f.strength,
            file: Some(f.path.clone()),
            ..EffDesc::default()
        };
        Eff {
            desc,
            grid: f.grid,
            source: f.source,
            head: f.head,
            strength: f.strength,
            bound: 0.0,
            cells: f.cells.clone(),
            defined: f.defined.clone(),
        }
        .with_bound()
    }

    /// Write the grid as an EFF file (module docs); exact on `load`.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let io = |source| KamiError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::create(path).map_err(io)?;
        let mut w = std::io::BufWriter::new(file);
        let v = |v: DVec3| format!("{:?} {:?} {:?}", v.x, v.y, v.z);
        let [rx, ry, rz] = self.grid.dims;
        let mut head = format!(
            "kami-eff {FILE_VERSION}\n\
             # An External Force Field (Kazama et al. 3.3), written by Kami: forces in world\n\
             # units / s². One line per cell after `cells`, x fastest, then y, then z;\n\
             # d: a defined cell, i: filled by the interpolation rules.\n\
             resolution {rx} {ry} {rz}\n"
        );
        head += &format!("origin {}\n", v(self.grid.origin));
        head += &format!("cell {}\n", v(self.grid.cell));
        head += &format!("source {}\n", v(self.source));
        head += &format!("head {}\n", v(self.head));
        head += &format!("strength {:?}\ncells\n", self.strength);
        w.write_all(head.as_bytes()).map_err(io)?;
        for (c, d) in self.cells.iter().zip(&self.defined) {
            writeln!(w, "{} {}", if *d { "d" } else { "i" }, v(*c)).map_err(io)?;
        }
        w.flush().map_err(io)
    }
}

/// The cells a blower defines, with their forces.
fn blower_cells(b: &Blower, g: &Grid) -> Vec<(usize, DVec3)> {
    let at = DVec3::from(b.at);
    let dir = DVec3::from(b.toward).normalize();
    let widen = b.spread.to_radians().tan();
    let mut out = Vec::new();
    for index in 0..g.count() {
        let c = g.center(g.ijk(index));
        let t = (c - at).dot(dir);
        if t < 0.0 {
            continue;
        }
        let rho = (c - at - dir * t).length();
        let r = b.radius + t * widen;
        if rho >= r {
            continue;
        }
        let q = rho / r;
        out.push((index, dir * b.strength * (1.0 - q * q).powi(2)));
    }
    out
}

/// Squared world distance of a lattice offset, exact for ties: axes whose cells have the
/// same size add their squared offsets first (integers, exact) and multiply once, so
/// mirror-image and permuted offsets give bit-identical distances.
struct Metric {
    c2: DVec3,
}

impl Metric {
    fn new(cell: DVec3) -> Metric {
        Metric { c2: cell * cell }
    }
    fn d2(&self, d: DVec3) -> f64 {
        let (s, c) = (d * d, self.c2);
        if c.x == c.y && c.y == c.z {
            (s.x + s.y + s.z) * c.x
        } else if c.x == c.y {
            (s.x + s.y) * c.x + s.z * c.z
        } else if c.y == c.z {
            s.x * c.x + (s.y + s.z) * c.y
        } else if c.x == c.z {
            (s.x + s.z) * c.x + s.y * c.y
        } else {
            s.x * c.x + s.y * c.y + s.z * c.z
        }
    }
}

/// A static k-d tree in place: the median of each range splits it on axis `depth % 3`.
fn kd_build(pts: &mut [(DVec3, u32)], depth: usize) {
    if pts.len() <= 1 {
        return;
    }
    let axis = depth % 3;
    let mid = pts.len() / 2;
    pts.select_nth_unstable_by(mid, |a, b| {
        a.0[axis].total_cmp(&b.0[axis]).then(a.1.cmp(&b.1))
    });
    let (left, right) = pts.split_at_mut(mid);
    kd_build(left, depth + 1);
    kd_build(&mut right[1..], depth + 1);
}

/// The two nearest points to `q`, ordered by (squared distance, index): ties go to the
/// lower index whatever the tree's shape, so the fill is deterministic. The far side of a
/// split is skipped only when strictly farther than the second best (rounding is monotone,
/// so the axis term alone never exceeds the full distance).
fn kd_nearest2(
    pts: &[(DVec3, u32)],
    depth: usize,
    q: DVec3,
    metric: &Metric,
    best: &mut [(f64, u32); 2],
) {
    if pts.is_empty() {
        return;
    }
    let axis = depth % 3;
    let mid = pts.len() / 2;
    let (p, idx) = pts[mid];
    let cand = (metric.d2(p - q), idx);
    let less = |a: (f64, u32), b: (f64, u32)| a.0 < b.0 || (a.0 == b.0 && a.1 < b.1);
    if less(cand, best[1]) {
        if less(cand, best[0]) {
            best[1] = best[0];
            best[0] = cand;
        } else {
            best[1] = cand;
        }
    }
    let diff = q[axis] - p[axis];
    let (near, far) = if diff < 0.0 {
        (&pts[..mid], &pts[mid + 1..])
    } else {
        (&pts[mid + 1..], &pts[..mid])
    };
    kd_nearest2(near, depth + 1, q, metric, best);
    if diff * diff * metric.c2[axis] <= best[1].0 {
        kd_nearest2(far, depth + 1, q, metric, best);
    }
}

/// A gust from the front-left: a jet aimed past the face, a weaker low stream that lifts
/// the ends, and the outside force from the source toward the head (12³ cells over 60 cm).
/// `assets/eff/front_left_gust.eff` is this field built (`tests/it/eff.rs` keeps it current);
/// the capture round trip blows it, and the EFF panel starts a scene's field with it.
pub fn front_left_gust() -> EffDesc {
    EffDesc {
        center: [0.0, -6.0, 0.0],
        extent: 60.0,
        resolution: [12, 12, 12],
        source: [70.0, 10.0, 70.0],
        head: Some([0.0, 0.0, 0.0]),
        strength: 150.0,
        blowers: vec![
            Blower {
                at: [32.0, 6.0, 32.0],
                toward: [-1.0, -0.15, -1.0],
                strength: 450.0,
                radius: 9.0,
                spread: 12.0,
            },
            Blower {
                at: [30.0, -24.0, 22.0],
                toward: [-1.0, 0.35, -0.8],
                strength: 220.0,
                radius: 7.0,
                spread: 8.0,
            },
        ],
        ..EffDesc::default()
    }
}

/// The `EffGrid` uniform of `shaders/forces/eff.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuEffGrid {
    /// xyz: the grid's min corner; w: the blend band outside it, in cells.
    pub origin: [f32; 4],
    /// xyz: cell edge per axis.
    pub cell: [f32; 4],
    /// xyz: cells per axis; w: 1 when a field is present, 0 for none (force zero).
    pub dims: [u32; 4],
    /// xyz: the outside force (unscaled); w: the gust scale now.
    pub outside: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuEffGrid>() == 64);

impl GpuEffGrid {
    /// The uniform for `eff` at gust scale `scale`; `None`: no field.
    pub fn new(eff: Option<&Eff>, scale: f64) -> GpuEffGrid {
        let Some(e) = eff else {
            return GpuEffGrid {
                dims: [1, 1, 1, 0],
                cell: [1.0, 1.0, 1.0, 0.0],
                ..Default::default()
            };
        };
        let f = |v: DVec3, w: f32| [v.x as f32, v.y as f32, v.z as f32, w];
        GpuEffGrid {
            origin: f(e.grid.origin, BAND_CELLS as f32),
            cell: f(e.grid.cell, 0.0),
            dims: [e.grid.dims[0], e.grid.dims[1], e.grid.dims[2], 1],
            outside: f(e.outside(), scale as f32),
        }
    }
}

/// The cells as the GPU reads them: one `vec4<f32>` per cell (xyz the force); one zero cell
/// for no field, so kernels bind the same layout either way.
pub fn cell_data(eff: Option<&Eff>) -> Vec<[f32; 4]> {
    match eff {
        None => vec![[0.0; 4]],
        Some(e) => e
            .cells
            .iter()
            .map(|c| [c.x as f32, c.y as f32, c.z as f32, 0.0])
            .collect(),
    }
}
