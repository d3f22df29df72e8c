//! How much of the even ambient light each strip sees, for the physical mode (docs/shading.md,
//! "The strips' sky"). A strip lies among the other layers of the Hair Object Model: those
//! over it and beside it hide part of the sky, and the light that comes through them has
//! crossed fibres. Kami's ambient colour is what a fibre on the open surface of a dense
//! volume of hair gets (`DualScattering::ambient`); a fur fibre deep in its coat gets
//! `hair_bsdf::ambient_in_coat` of the coat's fibre-area index above it. The strips have no
//! coat to count, so the index is found by casting rays: at `SKY_SAMPLES` points along each
//! strip, `SKY_RAYS` rays over the hemisphere facing away from the head (cosine-weighted, as
//! irradiance is) cross the other strips' ribbons, each crossing at cosine mu to that
//! ribbon's normal letting through e^(-c / mu) (c its texture's hair coverage there), and
//! stop at the head. The mean of what comes through, V, is what a coat of index A lets
//! through unscattered, 2 E_3(A) (`hair_bsdf::ambient_transmittance`'s first term); the
//! strip's index is the A that gives V, so an open strip has A = 0 and a strip under a
//! flat sheet of coverage c has A = c.
//!
//! Baked once from the rest strips (as hair cards bake their occlusion): the strips move
//! under the dynamics but keep their layers, so the index stands for the moving strips too.
//! Rays walk a uniform grid of the ribbons' triangles and stop where next to nothing comes
//! through, the strips split across the machine's threads: the shipped 120 strips take tens
//! of milliseconds, 1,920 about a second on 2 threads (`tests/it/strips_sky.rs` prints both).

use glam::{DMat4, DVec3};

use crate::scene::mesh::ray_triangle;
use crate::scene::Head;
use crate::systems::hair_bsdf::expint;
use crate::systems::strips::block::Look;
use crate::systems::strips::{ribbon, texture, RestStrip};

/// Points along each strip where the index is baked: v = k / (SKY_SAMPLES - 1), root to tip
/// (v counts control points, as the ribbon's v does). The draw shader interpolates them.
pub const SKY_SAMPLES: usize = 8;

/// Rays per point, over the hemisphere facing away from the head.
pub const SKY_RAYS: usize = 64;

/// The index given where (almost) nothing comes through: 2 E_3(20) is about 1e-10.
pub const SKY_MAX_AREA: f64 = 20.0;

/// 2 E_3(a): the share of even light a coat of fibre-area index `a` lets through
/// unscattered (1 at a = 0).
pub fn open_share(a: f64) -> f64 {
    2.0 * expint(3, a.max(0.0))
}

/// The fibre-area index A with 2 E_3(A) = `v` (bisection; 0 for v >= 1 or NaN,
/// [`SKY_MAX_AREA`] for v at or below its share).
pub fn area_for_share(v: f64) -> f64 {
    if v.is_nan() || v >= 1.0 {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0f64, SKY_MAX_AREA);
    if v <= open_share(hi) {
        return hi;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if open_share(mid) > v {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The mean hair coverage (texture alpha, 0..1) of each texel row of `look`'s strand
/// texture, root (row 0) to tip.
pub fn row_coverage(look: &Look) -> Vec<f64> {
    let (w, h) = texture::texture_size(look);
    let tex = texture::strand_texture(look, w, h);
    tex.chunks(w as usize)
        .map(|row| row.iter().map(|t| t[3] as f64 / 255.0).sum::<f64>() / w as f64)
        .collect()
}

/// The rest ribbons of `rest` (`ribbon::ribbon_reference` at the head's rest pose): their
/// triangles, the ribbon vertices and the stride.
fn ribbons(rest: &[RestStrip]) -> (Vec<Tri>, Vec<ribbon::RibbonVertex>, usize) {
    let stride = rest
        .iter()
        .map(|s| s.points.len())
        .max()
        .unwrap_or(1)
        .max(1);
    let mut points = Vec::with_capacity(rest.len() * stride);
    for s in rest {
        let last = s.points.last().copied().unwrap_or(DVec3::ZERO);
        points.extend(s.points.iter().copied());
        points.extend(std::iter::repeat_n(last, stride - s.points.len()));
    }
    let info = ribbon::strip_info(rest);
    let verts = ribbon::ribbon_reference(&points, stride, &info, &DMat4::IDENTITY);
    let mut tris = Vec::new();
    for (s, strip) in rest.iter().enumerate() {
        let at = |k: usize, side: usize| verts[2 * (s * stride + k) + side];
        for k in 0..strip.points.len().saturating_sub(1) {
            let [a0, a1, b0, b1] = [at(k, 0), at(k, 1), at(k + 1, 0), at(k + 1, 1)];
            tris.push(Tri {
                p: [a0.position, a1.position, b0.position],
                v: [a0.v, a1.v, b0.v],
                strip: s,
            });
            tris.push(Tri {
                p: [a1.position, b1.position, b0.position],
                v: [a1.v, b1.v, b0.v],
                strip: s,
            });
        }
    }
    (tris, verts, stride)
}

/// The hit's barycentrics (of corners 1 and 2) where the ray o + t d, t > 0, meets `p`
/// (either face).
fn hit_triangle(o: DVec3, d: DVec3, p: &[DVec3; 3]) -> Option<(f64, f64)> {
    ray_triangle(o, d, p).and_then(|(t, b1, b2)| (t > 0.0).then_some((b1, b2)))
}

/// Whether the ray o + t d (t > 0) meets the ellipsoid (`center`, `radii`).
fn hits_ellipsoid(o: DVec3, d: DVec3, center: DVec3, radii: DVec3) -> bool {
    let oo = (o - center) / radii;
    let dd = d / radii;
    let a = dd.dot(dd);
    let b = oo.dot(dd);
    let c = oo.dot(oo) - 1.0;
    let disc = b * b - a * c;
    a > 0.0 && disc >= 0.0 && -b + disc.sqrt() > 0.0
}

/// `rays` cosine-weighted directions about +z (a Fibonacci spiral: even, and the same on
/// every run).
fn directions(rays: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..rays)
        .map(|i| {
            let mu = ((i as f64 + 0.5) / rays as f64).sqrt();
            let r = (1.0 - mu * mu).max(0.0).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), mu)
        })
        .collect()
}

/// Coverage at `v` (0 root .. 1 tip) from the rows of [`row_coverage`].
fn coverage_at(rows: &[f64], v: f64) -> f64 {
    if rows.is_empty() {
        return 0.0;
    }
    let i = ((v.clamp(0.0, 1.0) * rows.len() as f64) as usize).min(rows.len() - 1);
    rows[i]
}

/// The fibre-area index of the sky hidden from each strip at its [`SKY_SAMPLES`] points
/// (module docs). `head`'s ellipsoid stops rays (a mesh head is stood for by its scene
/// ellipsoid, as in the shadows).
pub fn bake(rest: &[RestStrip], head: &Head, look: &Look) -> Vec<[f32; SKY_SAMPLES]> {
    bake_rays(rest, head, look, SKY_RAYS)
}

/// [`bake`] with `rays` rays per point (at least 1): how the bake's error falls with its
/// rays (`tests/it/strips_sky.rs`). Rays walk a uniform grid of the ribbons' triangles.
pub fn bake_rays(
    rest: &[RestStrip],
    head: &Head,
    look: &Look,
    rays: usize,
) -> Vec<[f32; SKY_SAMPLES]> {
    bake_with(rest, head, look, rays, true)
}

/// [`bake_rays`] testing every ray against every ribbon (no grid): the reference the grid's
/// walk is tested against. Its cost grows with the square of the strips.
pub fn bake_exhaustive(
    rest: &[RestStrip],
    head: &Head,
    look: &Look,
    rays: usize,
) -> Vec<[f32; SKY_SAMPLES]> {
    bake_with(rest, head, look, rays, false)
}

/// The triangles of every ribbon: corners, their v, and the strip they belong to.
struct Tri {
    p: [DVec3; 3],
    v: [f64; 3],
    strip: usize,
}

/// A uniform grid over the triangles' boxes: each cell lists the triangles whose box meets
/// it. About 2 triangles per cell, at most 64 cells a side.
struct Grid {
    lo: DVec3,
    cell: DVec3,
    dims: [usize; 3],
    cells: Vec<Vec<u32>>,
}

impl Grid {
    fn new(tris: &[Tri]) -> Grid {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for t in tris {
            for q in t.p {
                lo = lo.min(q);
                hi = hi.max(q);
            }
        }
        if tris.is_empty() {
            (lo, hi) = (DVec3::ZERO, DVec3::ONE);
        }
        let pad = (hi - lo).max_element().max(1e-9) * 1e-6;
        let (lo, hi) = (lo - pad, hi + pad);
        let ext = hi - lo;
        let per_axis = ((tris.len() as f64 * 8.0).cbrt().ceil() as usize).clamp(1, 64);
        let step = ext.max_element() / per_axis as f64;
        let dims = [0, 1, 2].map(|a| ((ext[a] / step).ceil() as usize).clamp(1, 64));
        let cell = DVec3::new(
            ext.x / dims[0] as f64,
            ext.y / dims[1] as f64,
            ext.z / dims[2] as f64,
        );
        let mut cells = vec![Vec::new(); dims[0] * dims[1] * dims[2]];
        let index = |q: DVec3| -> [usize; 3] {
            let c = ((q - lo) / cell).floor();
            [0, 1, 2].map(|a| (c[a].max(0.0) as usize).min(dims[a] - 1))
        };
        for (i, t) in tris.iter().enumerate() {
            let a = index(t.p[0].min(t.p[1]).min(t.p[2]));
            let b = index(t.p[0].max(t.p[1]).max(t.p[2]));
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        cells[(z * dims[1] + y) * dims[0] + x].push(i as u32);
                    }
                }
            }
        }
        Grid {
            lo,
            cell,
            dims,
            cells,
        }
    }

    /// Calls `f` with each cell's triangles, cell by cell along the ray o + t d, t >= 0
    /// (Amanatides and Woo's walk), from where it enters the grid to where it leaves or `f`
    /// returns false.
    fn walk(&self, o: DVec3, d: DVec3, mut f: impl FnMut(&[u32]) -> bool) {
        let hi = self.lo
            + self.cell
                * DVec3::new(
                    self.dims[0] as f64,
                    self.dims[1] as f64,
                    self.dims[2] as f64,
                );
        let inv = d.recip();
        let t0 = (self.lo - o) * inv;
        let t1 = (hi - o) * inv;
        let enter = t0.min(t1).max_element().max(0.0);
        let leave = t0.max(t1).min_element();
        if leave.is_nan() || leave < enter {
            return;
        }
        let start = o + d * enter;
        let mut c = [0usize; 3];
        let mut step = [0i64; 3];
        let mut next = [f64::INFINITY; 3];
        let mut delta = [f64::INFINITY; 3];
        for a in 0..3 {
            let x = ((start[a] - self.lo[a]) / self.cell[a]).floor();
            c[a] = (x.max(0.0) as usize).min(self.dims[a] - 1);
            if d[a] > 0.0 {
                step[a] = 1;
                next[a] = (self.lo[a] + (c[a] + 1) as f64 * self.cell[a] - o[a]) * inv[a];
                delta[a] = self.cell[a] * inv[a];
            } else if d[a] < 0.0 {
                step[a] = -1;
                next[a] = (self.lo[a] + c[a] as f64 * self.cell[a] - o[a]) * inv[a];
                delta[a] = -self.cell[a] * inv[a];
            }
        }
        loop {
            if !f(&self.cells[(c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]]) {
                return;
            }
            let a = if next[0] <= next[1] && next[0] <= next[2] {
                0
            } else if next[1] <= next[2] {
                1
            } else {
                2
            };
            if next[a] > leave {
                return;
            }
            let moved = c[a] as i64 + step[a];
            if moved < 0 || moved >= self.dims[a] as i64 {
                return;
            }
            c[a] = moved as usize;
            next[a] += delta[a];
        }
    }
}

/// Past this optical depth a ray lets through under 1e-9 of its light: its walk stops.
const DEEP: f64 = 21.0;

fn bake_with(
    rest: &[RestStrip],
    head: &Head,
    look: &Look,
    rays: usize,
    grid: bool,
) -> Vec<[f32; SKY_SAMPLES]> {
    let rows = row_coverage(look);
    let (tris, verts, stride) = ribbons(rest);
    let (mut lo, mut hi) = (DVec3::ZERO, DVec3::ZERO);
    for (i, q) in tris.iter().flat_map(|t| t.p).enumerate() {
        (lo, hi) = if i == 0 {
            (q, q)
        } else {
            (lo.min(q), hi.max(q))
        };
    }
    let scene = Scene {
        rest,
        rows,
        verts,
        stride,
        all: (0..tris.len() as u32).collect(),
        grid: grid.then(|| Grid::new(&tris)),
        tris,
        dirs: directions(rays.max(1)),
        center: DVec3::from(head.center),
        // Drawn 2 % smaller, as the shadows' head, so a root on the scalp does not hide itself.
        radii: DVec3::from(head.radii) * 0.98,
        scale: (hi - lo).max_element().max(1e-9),
    };
    // The strips split across the machine's threads (each point's rays are independent).
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .clamp(1, 16)
        .min(rest.len().max(1));
    let chunk = rest.len().div_ceil(threads).max(1);
    let mut out = vec![[0.0f32; SKY_SAMPLES]; rest.len()];
    std::thread::scope(|sc| {
        for (c, part) in out.chunks_mut(chunk).enumerate() {
            let scene = &scene;
            sc.spawn(move || {
                let mut seen = vec![u32::MAX; scene.tris.len()];
                let mut ray_id = 0u32;
                for (k, slot) in part.iter_mut().enumerate() {
                    *slot = scene.strip(c * chunk + k, &mut seen, &mut ray_id);
                }
            });
        }
    });
    out
}

/// What every point's rays read.
struct Scene<'a> {
    rest: &'a [RestStrip],
    rows: Vec<f64>,
    verts: Vec<ribbon::RibbonVertex>,
    stride: usize,
    tris: Vec<Tri>,
    all: Vec<u32>,
    grid: Option<Grid>,
    dirs: Vec<DVec3>,
    center: DVec3,
    radii: DVec3,
    scale: f64,
}

impl Scene<'_> {
    /// Strip `s`'s index at its [`SKY_SAMPLES`] points. `seen` (one entry per triangle) and
    /// `ray_id` are the thread's: a triangle in several cells counts once per ray.
    fn strip(&self, s: usize, seen: &mut [u32], ray_id: &mut u32) -> [f32; SKY_SAMPLES] {
        let n_pts = self.rest[s].points.len();
        let mut baked = [0.0f32; SKY_SAMPLES];
        if n_pts < 2 {
            return baked;
        }
        let (verts, stride) = (&self.verts, self.stride);
        for (j, slot) in baked.iter_mut().enumerate() {
            // The centre line and the ribbon's normal at v = j / (SKY_SAMPLES - 1).
            let x = j as f64 / (SKY_SAMPLES - 1) as f64 * (n_pts - 1) as f64;
            let k = (x.floor() as usize).min(n_pts - 2);
            let f = x - k as f64;
            let at = |k: usize, side: usize| verts[2 * (s * stride + k) + side];
            let mid = |k: usize| 0.5 * (at(k, 0).position + at(k, 1).position);
            let p = mid(k).lerp(mid(k + 1), f);
            let side = (at(k, 1).position - at(k, 0).position)
                .lerp(at(k + 1, 1).position - at(k + 1, 0).position, f);
            let t = at(k, 0).tangent.lerp(at(k + 1, 0).tangent, f);
            let mut n = side
                .cross(t)
                .normalize_or(p - self.center)
                .normalize_or(DVec3::Y);
            if n.dot(p - self.center) < 0.0 {
                n = -n;
            }
            let (b1, b2) = n.any_orthonormal_pair();
            let o = p + n * (1e-7 * self.scale);
            let mut through = 0.0;
            for d0 in &self.dirs {
                let d = b1 * d0.x + b2 * d0.y + n * d0.z;
                if hits_ellipsoid(o, d, self.center, self.radii) {
                    continue;
                }
                *ray_id = ray_id.wrapping_add(1);
                if *ray_id == u32::MAX {
                    seen.fill(u32::MAX);
                    *ray_id = 0;
                }
                let id = *ray_id;
                let mut depth = 0.0;
                let mut test = |ids: &[u32]| {
                    for &i in ids {
                        let tri = &self.tris[i as usize];
                        if tri.strip == s || seen[i as usize] == id {
                            continue;
                        }
                        seen[i as usize] = id;
                        if let Some((u1, u2)) = hit_triangle(o, d, &tri.p) {
                            let v = &tri.v;
                            let vv = v[0] + u1 * (v[1] - v[0]) + u2 * (v[2] - v[0]);
                            let normal = (tri.p[1] - tri.p[0]).cross(tri.p[2] - tri.p[0]);
                            let mu = normal.normalize_or(n).dot(d).abs().max(1e-3);
                            depth += coverage_at(&self.rows, vv) / mu;
                        }
                    }
                    depth < DEEP
                };
                match &self.grid {
                    Some(g) => g.walk(o, d, &mut test),
                    None => {
                        test(&self.all);
                    }
                }
                through += (-depth).exp();
            }
            *slot = area_for_share(through / self.dirs.len() as f64) as f32;
        }
        baked
    }
}
