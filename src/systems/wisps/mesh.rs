//! The wisps' meshed path (`block::WispDraw::Mesh`): the blobby surface of `field`
//! polygonised by surface nets (Gibson 1998) over the cells the segments' influence reaches,
//! each vertex then moved onto the surface by Newton steps on the exact field and given its
//! normal and outline scale there, so the toon tones come from the same normals as the
//! march's. The mesh is rasterised with the march's toon shading and an inverted hull for
//! the outline (`super::mesh_pass`).
//!
//! Where the work goes: the field is sampled only at the grid points of *bricks* (8³ cells)
//! some segment's influence box reaches, each point over its brick's segments only (as the
//! screen tiles list them for the march, `super::tiles`). A still hairstyle is meshed once,
//! in the head's frame, and posing or orbiting it costs only the raster; moving wisps are
//! meshed again when their nodes move. The work is split over the CPU's threads: on a
//! software adapter the CPU is the GPU, and this f64 code ran faster than the same field
//! sampled by llvmpipe (the march's own finding, `docs/wisps.md`).

use super::curve::{self, Segment};
use super::field::{fd, fd_prime, Density, WispMax};
use super::toon::outline_scale;
use crate::error::{KamiError, Result};
use crate::systems::wisps::block::Distance;
use glam::DVec3;

/// Cells per brick side.
pub const BRICK: usize = 8;
const BRICK3: usize = BRICK * BRICK * BRICK;

/// Most grid points along one axis.
pub const MAX_POINTS_PER_AXIS: usize = 1 << 20;
/// Most bricks over the wisps' bounds (a 4-byte slot each).
pub const MAX_BRICKS: u64 = 1 << 24;
/// Most grid points the bricks may hold (4 bytes each: 1 GiB).
pub const MAX_BRICK_POINTS: u64 = 1 << 28;

/// The grid's distance: each segment as `GRID_PIECES` chords (`curve::distance_polyline`,
/// its points computed once per meshing). The grid's values only say which cells the
/// surface crosses and where each vertex's Newton steps start; those use the scene's own
/// distance method.
pub const GRID_PIECES: usize = 4;

/// A segment's chords for the grid: the points B(k / GRID_PIECES).
type Chords = [DVec3; GRID_PIECES + 1];

fn chords(seg: &Segment) -> Chords {
    std::array::from_fn(|k| seg.point(k as f64 / GRID_PIECES as f64))
}

/// Σ_wisps ρ at `v` over `list` by the chords (the grid's values; no gradient).
fn grid_rho(input: &Input, chords: &[Vec<Chords>], list: &[(u32, u32)], v: DVec3) -> f64 {
    let mut sum = 0.0;
    let mut wisp = u32::MAX;
    let mut acc = WispMax::default();
    for &(wi, si) in list {
        if wi != wisp {
            sum += std::mem::take(&mut acc).finish().0.rho;
            wisp = wi;
        }
        let s = &input.wisps[wi as usize][si as usize];
        let rm = s.r_max();
        if s.box_distance(v) >= rm {
            continue;
        }
        let (d, t) = curve::polyline_distance(&chords[wi as usize][si as usize], v);
        if d >= rm {
            continue;
        }
        let (r, w) = (s.radius(t), s.weight(t));
        let x = d / r;
        let rho = if x > 1.0 { 0.0 } else { w * fd(x) };
        acc.push(
            si as usize,
            t,
            Density {
                rho,
                grad: DVec3::ZERO,
            },
            1.0,
        );
    }
    sum + acc.finish().0.rho
}

/// Newton steps that move a surface-nets vertex onto the surface.
pub const NEWTON: u32 = 1;

/// What to polygonise.
pub struct Input<'a> {
    /// Each wisp's segments, root to tip.
    pub wisps: &'a [Vec<Segment>],
    /// Per wisp and segment: `toon::segment_outlines` (empty: every scale 1).
    pub outlines: &'a [Vec<[f32; 4]>],
    pub taper: f64,
    pub threshold: f64,
    pub method: Distance,
    /// Grid cell size, scene units.
    pub cell: f64,
    /// The grid's first point and points a side; None: the wisps' influence bounds with two
    /// cells of margin. The GPU mesher's grid (`mesh_gpu::Plan::frame`) is given here when
    /// this mesher is its reference.
    pub frame: Option<GridFrame>,
}

/// Where a polygonisation's grid lies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridFrame {
    pub origin: DVec3,
    pub dims: [usize; 3],
}

/// A triangle mesh of the surface.
#[derive(Clone, Debug, Default)]
pub struct WispMesh {
    /// xyz, w the outline scale of the densest wisp there (as the march's `outline`).
    pub positions: Vec<[f32; 4]>,
    /// Outward unit normal of the exact field at the vertex (`field::normal`), w the shell
    /// curvature κ there (`shell_depth`).
    pub normals: Vec<[f32; 4]>,
    /// Triangles, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
    /// Grid points sampled (bricks reached × 512).
    pub points: u64,
    /// Grid points a side.
    pub dims: [usize; 3],
    /// Largest |f| / |∇f| left at a vertex after the Newton steps (scene units): how far the
    /// vertices may be from the surface.
    pub worst_offset: f64,
}

impl WispMesh {
    pub fn triangles(&self) -> usize {
        self.indices.len() / 3
    }
}

/// The brick grid of a polygonisation.
struct Grid {
    origin: DVec3,
    cell: f64,
    /// Points a side.
    dims: [usize; 3],
    /// Bricks a side.
    bricks: [usize; 3],
    /// Per brick: its index among the reached bricks, or u32::MAX.
    slot: Vec<u32>,
    /// The reached bricks (linear brick index), ascending.
    reached: Vec<usize>,
    /// Per reached brick: its segments as (wisp, segment), wisp-major in order.
    lists: Vec<Vec<(u32, u32)>>,
}

impl Grid {
    fn point(&self, i: [usize; 3]) -> DVec3 {
        self.origin + DVec3::new(i[0] as f64, i[1] as f64, i[2] as f64) * self.cell
    }

    fn brick_of(&self, i: [usize; 3]) -> usize {
        let b = [i[0] / BRICK, i[1] / BRICK, i[2] / BRICK];
        (b[2] * self.bricks[1] + b[1]) * self.bricks[0] + b[0]
    }

    fn local(i: [usize; 3]) -> usize {
        ((i[2] % BRICK) * BRICK + i[1] % BRICK) * BRICK + i[0] % BRICK
    }

    /// The reached brick holding a point, if any.
    fn slot_of(&self, i: [usize; 3]) -> Option<usize> {
        if (0..3).any(|a| i[a] >= self.dims[a]) {
            return None;
        }
        let s = self.slot[self.brick_of(i)];
        (s != u32::MAX).then_some(s as usize)
    }
}

/// The grid of `input`: bounds, bricks and the segments reaching each (refused with the
/// numbers when the cell is not positive or the grid would pass the limits above).
fn grid(input: &Input) -> Result<Grid> {
    let bad = |value: String, allowed: String| KamiError::Invalid {
        file: String::new(),
        field: "wisps.mesh.cell".into(),
        value,
        allowed,
    };
    let cell = input.cell;
    if !(cell.is_finite() && cell > 0.0) {
        return Err(bad(
            format!("{cell}"),
            "a positive cell size (scene units)".into(),
        ));
    }
    let boxes: Vec<Vec<(DVec3, DVec3)>> = input
        .wisps
        .iter()
        .map(|w| w.iter().map(|s| s.influence_box()).collect())
        .collect();
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for b in boxes.iter().flatten() {
        lo = lo.min(b.0);
        hi = hi.max(b.1);
    }
    if !(lo.is_finite() && hi.is_finite()) && input.frame.is_none() {
        return Ok(Grid {
            origin: DVec3::ZERO,
            cell,
            dims: [0; 3],
            bricks: [0; 3],
            slot: Vec::new(),
            reached: Vec::new(),
            lists: Vec::new(),
        });
    }
    // Two cells of margin: the outermost points are outside every influence box.
    let (origin, dims_f) = match input.frame {
        Some(f) => (f.origin, f.dims.map(|d| d as f64)),
        None => {
            let span = (hi - lo) / cell + 4.0;
            (
                lo - DVec3::splat(2.0 * cell),
                [span.x.ceil(), span.y.ceil(), span.z.ceil()],
            )
        }
    };
    if dims_f.iter().any(|&d| d > MAX_POINTS_PER_AXIS as f64) {
        return Err(bad(
            format!("{cell}"),
            format!(
                "a cell the wisps' extent ({:.3} x {:.3} x {:.3}) spans in at most {} points a \
                 side; this one needs {} x {} x {}",
                hi.x - lo.x,
                hi.y - lo.y,
                hi.z - lo.z,
                MAX_POINTS_PER_AXIS,
                dims_f[0],
                dims_f[1],
                dims_f[2]
            ),
        ));
    }
    let dims = dims_f.map(|d| d as usize);
    let bricks = dims.map(|d| d.div_ceil(BRICK));
    let n_bricks = bricks[0] as u64 * bricks[1] as u64 * bricks[2] as u64;
    if n_bricks > MAX_BRICKS {
        return Err(bad(
            format!("{cell}"),
            format!(
                "a grid of at most {MAX_BRICKS} bricks of {BRICK}³ cells over the wisps' bounds; \
                 this cell needs {} x {} x {} points ({n_bricks} bricks)",
                dims[0], dims[1], dims[2]
            ),
        ));
    }
    // Each segment's influence box, grown by three cells (a vertex lies in a cell whose
    // corner is in its brick, and its Newton step moves it at most 1.5 cells), marks the
    // bricks it reaches.
    let brick_side = cell * BRICK as f64;
    let ranges: Vec<Vec<([usize; 3], [usize; 3])>> = boxes
        .iter()
        .map(|w| {
            w.iter()
                .map(|&(blo, bhi)| {
                    let a = ((blo - origin - 3.0 * cell) / brick_side)
                        .floor()
                        .max(DVec3::ZERO);
                    let b = ((bhi - origin + 3.0 * cell) / brick_side).floor();
                    let a = [a.x as usize, a.y as usize, a.z as usize];
                    let b = [
                        (b.x as usize).min(bricks[0] - 1),
                        (b.y as usize).min(bricks[1] - 1),
                        (b.z as usize).min(bricks[2] - 1),
                    ];
                    (a, b)
                })
                .collect()
        })
        .collect();
    let pairs: u64 = ranges
        .iter()
        .flatten()
        .map(|(a, b)| {
            (0..3)
                .map(|k| (b[k] + 1).saturating_sub(a[k]) as u64)
                .product::<u64>()
        })
        .sum();
    if pairs * BRICK3 as u64 > MAX_BRICK_POINTS * 16 {
        return Err(bad(
            format!("{cell}"),
            format!(
                "at most {} brick visits of {} points by the segments; this cell needs {} (a \
                 grid of {} x {} x {} points)",
                MAX_BRICK_POINTS * 16 / BRICK3 as u64,
                BRICK3,
                pairs,
                dims[0],
                dims[1],
                dims[2]
            ),
        ));
    }
    let (reached, lists) = reach(input, origin, cell, bricks, &ranges, pairs);
    if reached.len() as u64 * BRICK3 as u64 > MAX_BRICK_POINTS {
        return Err(bad(
            format!("{cell}"),
            format!(
                "at most {} grid points near the wisps; this cell needs {} ({} bricks of {})",
                MAX_BRICK_POINTS,
                reached.len() as u64 * BRICK3 as u64,
                reached.len(),
                BRICK3
            ),
        ));
    }
    let mut slot = vec![u32::MAX; n_bricks as usize];
    for (k, &b) in reached.iter().enumerate() {
        slot[b] = k as u32;
    }
    Ok(Grid {
        origin,
        cell,
        dims,
        bricks,
        slot,
        reached,
        lists,
    })
}

/// The bricks some point inside the surface can be near, ascending, and the segments
/// (wisp, segment) whose influence reaches each: `ranges` holds each segment's brick range.
fn reach(
    input: &Input,
    origin: DVec3,
    cell: f64,
    bricks: [usize; 3],
    ranges: &[Vec<([usize; 3], [usize; 3])>],
    pairs: u64,
) -> (Vec<usize>, Vec<Vec<(u32, u32)>>) {
    let brick_side = cell * BRICK as f64;
    // Only bricks some point inside the surface can be near are sampled: those within a
    // hit capsule (`curve::capsules`: every inside point lies in one) grown by the brick's
    // half-diagonal and three cells (a vertex's cell, its Newton steps). The others are
    // outside whole. Their lists hold every segment whose influence reaches them.
    let caps = curve::capsules(input.wisps, input.threshold);
    let half_diag = 0.5 * brick_side * 3f64.sqrt() + 3.0 * 3f64.sqrt() * cell;
    let mut marks: Vec<(usize, u32, u32, bool)> = Vec::with_capacity(pairs as usize);
    for (wi, w) in ranges.iter().enumerate() {
        for (si, (a, b)) in w.iter().enumerate() {
            let cap = &caps[wi][si];
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        let centre =
                            origin + (DVec3::new(x as f64, y as f64, z as f64) + 0.5) * brick_side;
                        let near = cap.hit >= 0.0
                            && curve::chord_distance(centre, cap.a, cap.b) <= cap.hit + half_diag;
                        let brick = (z * bricks[1] + y) * bricks[0] + x;
                        marks.push((brick, wi as u32, si as u32, near));
                    }
                }
            }
        }
    }
    // Stable: each brick's list stays wisp-major, in order.
    marks.sort_by_key(|m| m.0);
    let mut reached: Vec<usize> = Vec::new();
    let mut lists: Vec<Vec<(u32, u32)>> = Vec::new();
    let mut near = false;
    for (k, &(b, wi, si, hit)) in marks.iter().enumerate() {
        if reached.last() != Some(&b) {
            reached.push(b);
            lists.push(Vec::new());
            near = false;
        }
        lists.last_mut().expect("pushed above").push((wi, si));
        near |= hit;
        if marks.get(k + 1).is_none_or(|m| m.0 != b) && !near {
            reached.pop();
            lists.pop();
        }
    }
    (reached, lists)
}

/// ρ_e(v) = w(t)·fd(D/r(t)) and its gradient from a distance already found (as
/// `field::segment_density`).
fn density(seg: &Segment, v: DVec3, d: f64, t: f64, method: Distance) -> Density {
    let (r, w) = (seg.radius(t), seg.weight(t));
    let x = d / r;
    if x > 1.0 {
        return Density::default();
    }
    let grad = if d > 0.0 {
        (v - super::field::closest_point(seg, t, method)) * (w * fd_prime(x) / (r * d))
    } else {
        DVec3::ZERO
    };
    Density {
        rho: w * fd(x),
        grad,
    }
}

/// Σ_wisps ρ at `v` over `list` (wisp-major, in order) and the outline scale of the densest
/// wisp (1 where none is near): the field of `field::field` over those segments.
fn sample(input: &Input, list: &[(u32, u32)], v: DVec3) -> (Density, f64) {
    let method = input.method;
    let mut sum = Density::default();
    let (mut densest, mut tag) = (0.0, 1.0);
    let mut wisp = u32::MAX;
    let mut acc = WispMax::default();
    let mut fold = |acc: WispMax, sum: &mut Density| {
        let (d, t) = acc.finish();
        sum.rho += d.rho;
        sum.grad += d.grad;
        if d.rho > densest {
            densest = d.rho;
            tag = t;
        }
    };
    for &(wi, si) in list {
        if wi != wisp {
            fold(std::mem::take(&mut acc), &mut sum);
            wisp = wi;
        }
        let s = &input.wisps[wi as usize][si as usize];
        let rm = s.r_max();
        if s.box_distance(v) >= rm {
            continue;
        }
        let (d, t) = curve::distance(s, v, method);
        if d >= rm {
            continue;
        }
        let o = input
            .outlines
            .get(wi as usize)
            .and_then(|w| w.get(si as usize))
            .map_or(1.0, |&o| outline_scale(o, t, input.taper));
        acc.push(si as usize, t, density(s, v, d, t, method), o);
    }
    fold(acc, &mut sum);
    (sum, tag)
}

/// Runs `f` over `items` on the machine's threads, in order.
fn parallel<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(items.len().max(1));
    if threads <= 1 {
        return items.iter().map(f).collect();
    }
    let chunk = items.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = items
            .chunks(chunk)
            .map(|c| {
                let f = &f;
                scope.spawn(move || c.iter().map(f).collect::<Vec<R>>())
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("a meshing thread panicked"))
            .collect()
    })
}

/// How many bricks `polygonise` samples for `input` (the GPU mesher sizes its slots by it).
pub fn reached_bricks(input: &Input) -> Result<usize> {
    Ok(grid(input)?.reached.len())
}

/// The surface of `input` as a triangle mesh (see the module's notes).
pub fn polygonise(input: &Input) -> Result<WispMesh> {
    let g = grid(input)?;
    let values = sample_grid(input, &g);
    let slots: Vec<usize> = (0..g.reached.len()).collect();
    let crossed = parallel(&slots, |&s| crossings(input.threshold, &g, &values, s));
    // Vertices numbered brick by brick, each brick's cells in order.
    let mut cell_vertex = vec![[u32::MAX; BRICK3]; g.reached.len()];
    let mut start = Vec::new();
    for (s, cells) in crossed.iter().enumerate() {
        for &(l, p0) in cells {
            cell_vertex[s][l as usize] = start.len() as u32;
            start.push(p0);
        }
    }
    let placed = parallel(&start, |&p0| place(input, &g, p0));
    let mut mesh = WispMesh {
        points: g.reached.len() as u64 * BRICK3 as u64,
        dims: g.dims,
        ..Default::default()
    };
    for &(p, n, o, off, kappa) in &placed {
        mesh.positions
            .push([p.x as f32, p.y as f32, p.z as f32, o as f32]);
        mesh.normals
            .push([n.x as f32, n.y as f32, n.z as f32, kappa as f32]);
        mesh.worst_offset = mesh.worst_offset.max(off);
    }
    let quads = parallel(&slots, |&s| {
        quads(input.threshold, &g, &values, &cell_vertex, s)
    });
    mesh.indices = quads.concat();
    Ok(mesh)
}

/// The grid indices of point `l` of brick `b`.
fn brick_point(g: &Grid, b: usize, l: usize) -> [usize; 3] {
    let bz = b / (g.bricks[0] * g.bricks[1]);
    let by = (b / g.bricks[0]) % g.bricks[1];
    let bx = b % g.bricks[0];
    [
        bx * BRICK + l % BRICK,
        by * BRICK + (l / BRICK) % BRICK,
        bz * BRICK + l / (BRICK * BRICK),
    ]
}

/// Step 1: the density at every point of the reached bricks (f32: only its sign and the
/// crossings are read), by the chords.
fn sample_grid(input: &Input, g: &Grid) -> Vec<[f32; BRICK3]> {
    let chords: Vec<Vec<Chords>> = input
        .wisps
        .iter()
        .map(|w| w.iter().map(chords).collect())
        .collect();
    let indexed: Vec<(usize, usize)> = g.reached.iter().copied().enumerate().collect();
    parallel(&indexed, |&(k, b)| {
        // Only the segments whose influence box reaches the brick's own points (its list
        // holds those within three cells, for the vertices' Newton steps): the others add
        // nothing at any of them, so the values are the same.
        let lo = g.point(brick_point(g, b, 0));
        let hi = g.point(brick_point(g, b, BRICK3 - 1));
        let list: Vec<(u32, u32)> = g.lists[k]
            .iter()
            .copied()
            .filter(|&(wi, si)| {
                let (blo, bhi) = input.wisps[wi as usize][si as usize].influence_box();
                blo.cmple(hi).all() && lo.cmple(bhi).all()
            })
            .collect();
        let list = &list;
        let mut out = [0.0f32; BRICK3];
        for (l, o) in out.iter_mut().enumerate() {
            let i = brick_point(g, b, l);
            if i.iter().zip(&g.dims).any(|(a, d)| a >= d) {
                continue;
            }
            *o = grid_rho(input, &chords, list, g.point(i)) as f32;
        }
        out
    })
}

fn value(g: &Grid, values: &[[f32; BRICK3]], i: [usize; 3]) -> f64 {
    g.slot_of(i)
        .map_or(0.0, |s| values[s][Grid::local(i)] as f64)
}

/// A cell's grid edges as (corner a, corner b), corners numbered x + 2y + 4z.
const EDGES: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

fn corner(k: usize) -> [usize; 3] {
    [k & 1, (k >> 1) & 1, (k >> 2) & 1]
}

/// Step 2, for reached brick `s`: its cells (by their lowest corner) the surface crosses,
/// with their vertex's start, the mean of their edges' crossings. Every crossed cell has an
/// inside corner, so lies in a reached brick.
fn crossings(thr: f64, g: &Grid, values: &[[f32; BRICK3]], s: usize) -> Vec<(u16, DVec3)> {
    let b = g.reached[s];
    let mut out = Vec::new();
    for l in 0..BRICK3 {
        let c = brick_point(g, b, l);
        if (0..3).any(|a| c[a] + 1 >= g.dims[a]) {
            continue;
        }
        // Corners inside the brick are read from it directly.
        let inner = (0..3).all(|a| c[a] % BRICK + 1 < BRICK);
        let f: [f64; 8] = std::array::from_fn(|k| {
            let o = corner(k);
            let i = [c[0] + o[0], c[1] + o[1], c[2] + o[2]];
            let v = if inner {
                values[s][Grid::local(i)] as f64
            } else {
                value(g, values, i)
            };
            v - thr
        });
        let inside = f.iter().filter(|&&x| x >= 0.0).count();
        if inside == 0 || inside == 8 {
            continue;
        }
        let (mut sum, mut n) = (DVec3::ZERO, 0.0);
        for (a, bb) in EDGES {
            let (ra, rb) = (f[a], f[bb]);
            if (ra >= 0.0) == (rb >= 0.0) {
                continue;
            }
            let t = ra / (ra - rb);
            let (oa, ob) = (corner(a), corner(bb));
            let pa = g.point([c[0] + oa[0], c[1] + oa[1], c[2] + oa[2]]);
            let pb = g.point([c[0] + ob[0], c[1] + ob[1], c[2] + ob[2]]);
            sum += pa.lerp(pb, t);
            n += 1.0;
        }
        out.push((l as u16, sum / n));
    }
    out
}

/// Step 3: a vertex from `p0` onto the surface by Newton steps on the exact field (each
/// at most a cell): its position, normal, outline scale, distance left to the surface and
/// shell curvature κ (`shell_depth`).
fn place(input: &Input, g: &Grid, p0: DVec3) -> (DVec3, DVec3, f64, f64, f64) {
    let (cell, thr) = (g.cell, input.threshold);
    let i = ((p0 - g.origin) / cell).floor().max(DVec3::ZERO).as_uvec3();
    let Some(s) = g.slot_of([i.x as usize, i.y as usize, i.z as usize]) else {
        return (p0, DVec3::Y, 1.0, 0.0, 0.0);
    };
    let list = &g.lists[s];
    let mut p = p0;
    let mut smp = sample(input, list, p);
    for _ in 0..NEWTON {
        let gg = smp.0.grad.length_squared();
        if gg <= 0.0 {
            break;
        }
        let mut step = smp.0.grad * ((smp.0.rho - thr) / gg);
        if step.length() > cell {
            step = step.normalize() * cell;
        }
        // ρ grows inward: inside (ρ > thr) moves out, against ∇ρ.
        let q = p - step;
        if (q - p0).length() > 1.5 * cell {
            break;
        }
        p = q;
        smp = sample(input, list, p);
    }
    let glen = smp.0.grad.length();
    if glen <= 0.0 {
        return (p, DVec3::Y, smp.1, cell, 0.0);
    }
    let n = -smp.0.grad / glen;
    let f0 = smp.0.rho - thr;
    // The field's curvature along the normal from f half a cell out: f(h) ≈ f0 − g h + k h²/2.
    let h = 0.5 * cell;
    let k = 2.0 * (sample(input, list, p + n * h).0.rho - thr - f0 + glen * h) / (h * h);
    (p, n, smp.1, (f0 / glen).abs(), (k / glen).max(0.0))
}

/// Step 4, for reached brick `s`: a quad for each grid edge from one of its inside points to
/// an outside one, over the four cells round the edge, facing from the inside end to the
/// outside one (`cell_vertex`: per slot and cell its vertex, u32::MAX none).
fn quads(
    thr: f64,
    g: &Grid,
    values: &[[f32; BRICK3]],
    cell_vertex: &[[u32; BRICK3]],
    s: usize,
) -> Vec<u32> {
    let vertex = |c: [usize; 3]| {
        g.slot_of(c)
            .map(|s| cell_vertex[s][Grid::local(c)])
            .filter(|&v| v != u32::MAX)
    };
    let b = g.reached[s];
    let mut indices = Vec::new();
    for l in 0..BRICK3 {
        let i = brick_point(g, b, l);
        if (0..3).any(|a| i[a] >= g.dims[a]) || (values[s][l] as f64) < thr {
            continue;
        }
        for axis in 0..3 {
            let (bx, cx) = ((axis + 1) % 3, (axis + 2) % 3);
            for dir in [1isize, -1] {
                let mut q = i;
                let qa = i[axis] as isize + dir;
                if qa < 0 || qa as usize >= g.dims[axis] {
                    continue;
                }
                q[axis] = qa as usize;
                if value(g, values, q) >= thr {
                    continue;
                }
                // The edge's lower end; the cells round it lie below it on the other axes.
                let m = if dir > 0 { i } else { q };
                if m[bx] == 0 || m[cx] == 0 {
                    continue;
                }
                let cell_at = |db: usize, dc: usize| {
                    let mut x = m;
                    x[bx] -= db;
                    x[cx] -= dc;
                    vertex(x)
                };
                let (Some(v00), Some(v10), Some(v11), Some(v01)) =
                    (cell_at(1, 1), cell_at(0, 1), cell_at(0, 0), cell_at(1, 0))
                else {
                    continue;
                };
                // (v00, v10, v11, v01) winds about +axis (e_b × e_c = e_axis).
                let quad = if dir > 0 {
                    [v00, v10, v11, v00, v11, v01]
                } else {
                    [v00, v11, v10, v00, v01, v11]
                };
                indices.extend_from_slice(&quad);
            }
        }
    }
    indices
}

/// How far outside the surface the march's outline shell reaches, for a shell half-width
/// `eps`, where the field along the outward normal is f(s) ≈ −g s + k s²/2 (g = |∇f| at the
/// surface, κ = k / g, from f half a cell out and the gradient): the march's shell is
/// where f + |∇f| eps ≥ 0, so its edge is the smaller root of k s²/2 − (g + k eps) s + g eps,
/// s = eps (b − sqrt(b² − 2a)) / a with a = κ eps, b = 1 + a (eps where κ eps is tiny). On a
/// blobby wisp the density flattens outward, so the shell is thinner than eps once eps is a
/// fair part of the wisp's radius (a lone wisp: 64 % of eps at 0.3 r). The hull in
/// `shaders/wisps/mesh.wgsl` (`shell_depth` there) does the same in f32.
pub fn shell_depth(eps: f64, kappa: f64) -> f64 {
    let a = kappa * eps;
    if a < 1e-4 {
        return eps;
    }
    let b = 1.0 + a;
    eps * (b - (b * b - 2.0 * a).max(0.0).sqrt()) / a
}

/// `toon::segment_outlines` of `wisps` split per wisp, as `Input::outlines` takes them
/// (`segs`: each wisp's segments).
pub fn wisp_outlines(
    wisps: &crate::systems::wisps::block::Wisps,
    segs: &[Vec<Segment>],
) -> Vec<Vec<[f32; 4]>> {
    let flat = super::toon::segment_outlines(wisps);
    let mut out = Vec::with_capacity(segs.len());
    let mut k = 0;
    for s in segs {
        let end = (k + s.len()).min(flat.len());
        out.push(flat[k..end].to_vec());
        k = end;
    }
    out
}

/// The cell `wisps.mesh.cell = 0` stands for: `AUTO_CELL_FRACTION` of the wisps' mean
/// surface radius over their nodes (`surface_radius`).
pub fn auto_cell(wisps: &crate::systems::wisps::block::Wisps) -> f64 {
    let (mut sum, mut n) = (0.0, 0.0);
    for sk in &wisps.skeletons {
        for nd in &sk.nodes {
            sum += surface_radius(nd.r, nd.w, wisps.threshold);
            n += 1.0;
        }
    }
    if n > 0.0 && sum > 0.0 {
        AUTO_CELL_FRACTION * sum / n
    } else {
        1.0
    }
}

/// Where a lone wisp of radius `r` and weight `w` meets the threshold: w fd(x) = threshold
/// (eq 9), x = 1 − sqrt(threshold / (1.5 w)) on the outer branch (threshold / w ≤ 2/3,
/// fd(1/3) = 2/3), sqrt((1 − threshold / w) / 3) on the inner; r/3 where the wisp alone
/// shows nothing.
pub fn surface_radius(r: f64, w: f64, threshold: f64) -> f64 {
    let y = threshold / w;
    if y >= 1.0 {
        r / 3.0
    } else if y > 2.0 / 3.0 {
        r * ((1.0 - y) / 3.0).sqrt()
    } else {
        r * (1.0 - (y / 1.5).sqrt())
    }
}

/// The automatic cell as a fraction of the mean surface radius (`auto_cell`).
pub const AUTO_CELL_FRACTION: f64 = 0.25;

/// The automatic cell is no finer than this many output pixels at the wisps' nearest point
/// (`WispsSystem::mesh_cell`): half a pixel resolves what a pixel shows (at a whole pixel,
/// 88 of toon.ron's wisps at 128² were 2.72 % of pixels off the converged truth, at half
/// 2.45 %).
pub const AUTO_CELL_PX: f64 = 0.5;

/// Moving wisps' automatic cell grows under the viewer's budget up to this factor
/// (`WispsSystem::mesh_cell`). On toon.ron at 128² against the converged truth, share of
/// pixels off by more than 24: 2.28 % at 1, 2.69 % at 1.3, 2.87 % at 1.5 (past the 2.7 % of
/// `mesh_pass::MESH_ERROR_BOUND`).
pub const MOVING_COARSEST: f64 = 1.3;

/// Moving wisps meshed on the CPU are meshed again only once a node has moved this share of
/// a cell since the last meshing (springs come to rest; the vertices then stand within it of
/// where a new meshing would put them).
pub const SETTLED: f64 = 0.01;

/// The automatic cell follows the view only once it is off by this factor.
pub const CELL_HYSTERESIS: f64 = 1.5;
