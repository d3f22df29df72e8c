//! A signed distance field of a triangle mesh, built once on the CPU in f64, for heads that
//! are meshes (`scene::HeadMesh`): grooming and dynamics collide with its zero level set and
//! read its gradient as the hull direction D of Anjyo's pseudo-force (3.2.2).
//!
//! **Grid.** Values at the nodes of a regular grid of cubic cells around the mesh, grown by
//! a margin of 15 % of the mesh's largest extent on every side; `resolution` cells span the
//! longest axis. Between nodes the field is trilinear, and its gradient is the analytic
//! gradient of the trilinear interpolant (piecewise bilinear, discontinuous across cell
//! faces). Outside the grid the value at the nearest grid point plus the distance to it is
//! used (a lower bound of the true distance, always positive since the margin is outside).
//!
//! **Distance.** Exact Euclidean distance to the nearest triangle (Ericson's closest point
//! on a triangle). To keep the build affordable the grid is cut into blocks of 4³ nodes: the
//! distance from a block's centre c to every triangle gives d_c; a triangle farther than
//! d_c + 2 r from c (r the block's half-diagonal) cannot be the nearest one of any node in the
//! block, so nodes test only the remaining candidates. Exact, not an approximation.
//!
//! **Sign: generalized winding number** (Jacobson et al. 2013): w(p) = sum of the signed
//! solid angles of the triangles / 4 pi; inside where w > 1/2. It needs no closed,
//! manifold mesh: CGAL's `head.off` is open at the neck, and w falls smoothly from 1 to 0
//! across the opening instead of flipping whole regions the way ray parity or a distant
//! pseudo-normal can. Blocks farther than their half-diagonal from the surface take the sign
//! of w at their centre (w is continuous off the surface, so only a block that straddles the
//! neck opening's 1/2 level could be mis-signed there, far from any hair); in blocks that
//! touch the surface a node whose nearest point lies inside a face (the offset is along that
//! face's normal, to 1e-4) takes that face's side, and every other node (nearest point on an
//! edge or a vertex, where a face normal can lie) evaluates w. The orientation (outward or
//! inward winding) is the sign of the mesh's signed volume.
//!
//! The GPU copy (`to_gpu`, read by `shaders/common/sdf.wgsl`) is the same values in f32
//! with the same indexing and interpolation.

use glam::DVec3;
use std::f64::consts::PI;

/// Nodes per block edge of the build's candidate culling.
const BLOCK: usize = 4;

/// Words of the GPU header before the values: origin xyz, cell, nodes x y z, unused.
pub const GPU_HEADER: usize = 8;

#[derive(Clone, Debug, PartialEq)]
pub struct Sdf {
    /// Position of node (0, 0, 0).
    pub origin: DVec3,
    /// Cell edge.
    pub cell: f64,
    /// Nodes along x, y, z.
    pub dims: [usize; 3],
    /// Signed distances, x fastest, negative inside.
    pub values: Vec<f64>,
}

/// Closest point to `p` on triangle (a, b, c) (Ericson, Real-Time Collision Detection 5.1.5).
pub fn closest_point_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return a + v * ab;
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return a + w * ac;
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return b + w * (c - b);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    a + ab * v + ac * w
}

/// Signed solid angle of triangle (a, b, c) seen from `p` (Van Oosterom & Strackee 1983).
pub fn solid_angle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (a, b, c) = (a - p, b - p, c - p);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * num.atan2(den)
}

/// A triangle soup, as the build reads it.
pub struct Triangles<'a> {
    pub positions: &'a [DVec3],
    pub triangles: &'a [[u32; 3]],
}

impl Triangles<'_> {
    fn tri(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    /// +1 when the triangles are wound outwards (positive signed volume by the divergence
    /// theorem, which an open mesh approximates), -1 when inwards.
    pub fn orientation(&self) -> f64 {
        let v: f64 = (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.tri(t);
                a.dot(b.cross(c))
            })
            .sum();
        if v < 0.0 {
            -1.0
        } else {
            1.0
        }
    }

    /// Exact distance from `p` to the nearest triangle (brute force).
    pub fn distance(&self, p: DVec3) -> f64 {
        (0..self.triangles.len())
            .map(|t| self.tri_distance(p, t))
            .fold(f64::INFINITY, f64::min)
    }

    fn tri_distance(&self, p: DVec3, t: usize) -> f64 {
        let [a, b, c] = self.tri(t);
        (closest_point_triangle(p, a, b, c) - p).length()
    }

    /// Generalized winding number at `p` (1 inside a closed, outward-wound mesh, 0 outside).
    pub fn winding_number(&self, p: DVec3) -> f64 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.tri(t);
                solid_angle(p, a, b, c)
            })
            .sum::<f64>()
            / (4.0 * PI)
    }

    /// Exact signed distance (brute force; the reference the tests hold the grid to).
    pub fn signed_distance(&self, p: DVec3) -> f64 {
        let d = self.distance(p);
        if self.orientation() * self.winding_number(p) > 0.5 {
            -d
        } else {
            d
        }
    }
}

impl Sdf {
    /// Build the field of `mesh` with `resolution` cells along the longest axis.
    pub fn build(mesh: &Triangles, resolution: usize) -> Sdf {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in mesh.triangles {
            for &i in t {
                lo = lo.min(mesh.positions[i as usize]);
                hi = hi.max(mesh.positions[i as usize]);
            }
        }
        let margin = 0.15 * (hi - lo).max_element();
        let (lo, hi) = (lo - DVec3::splat(margin), hi + DVec3::splat(margin));
        let cell = (hi - lo).max_element() / resolution.max(2) as f64;
        let dims = ((hi - lo) / cell)
            .ceil()
            .to_array()
            .map(|n| (n as usize).max(1) + 1);
        let origin = lo;
        let blocks = dims.map(|n| n.div_ceil(BLOCK));
        let block_count = blocks[0] * blocks[1] * blocks[2];
        let threads = std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
            .min(block_count);
        let node =
            |i: usize, j: usize, k: usize| origin + cell * DVec3::new(i as f64, j as f64, k as f64);
        let orient = mesh.orientation();
        let inside = |p: DVec3| orient * mesh.winding_number(p) > 0.5;
        // Each worker fills whole blocks; (index, value) pairs come back and are scattered.
        let results: Vec<Vec<(usize, f64)>> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..threads)
                .map(|w| {
                    s.spawn(move || {
                        let mut out = Vec::new();
                        let mut cand = Vec::new();
                        for b in (w..block_count).step_by(threads) {
                            let (bx, by, bz) = (
                                b % blocks[0],
                                (b / blocks[0]) % blocks[1],
                                b / (blocks[0] * blocks[1]),
                            );
                            let i0 = [bx * BLOCK, by * BLOCK, bz * BLOCK];
                            let i1 = [0, 1, 2].map(|a| (i0[a] + BLOCK).min(dims[a]));
                            let p0 = node(i0[0], i0[1], i0[2]);
                            let p1 = node(i1[0] - 1, i1[1] - 1, i1[2] - 1);
                            let c = 0.5 * (p0 + p1);
                            let r = 0.5 * (p1 - p0).length();
                            let dc: Vec<f64> = (0..mesh.triangles.len())
                                .map(|t| mesh.tri_distance(c, t))
                                .collect();
                            let dmin = dc.iter().cloned().fold(f64::INFINITY, f64::min);
                            cand.clear();
                            cand.extend((0..dc.len()).filter(|&t| dc[t] <= dmin + 2.0 * r + 1e-12));
                            let block_sign = (dmin > r).then(|| if inside(c) { -1.0 } else { 1.0 });
                            for k in i0[2]..i1[2] {
                                for j in i0[1]..i1[1] {
                                    for i in i0[0]..i1[0] {
                                        let p = node(i, j, k);
                                        let (mut d, mut q, mut best) = (f64::INFINITY, p, 0);
                                        for &t in &cand {
                                            let [a, b, c] = mesh.tri(t);
                                            let qt = closest_point_triangle(p, a, b, c);
                                            let dt = (qt - p).length();
                                            if dt < d {
                                                (d, q, best) = (dt, qt, t);
                                            }
                                        }
                                        let sign = block_sign.unwrap_or_else(|| {
                                            // Nearest point inside a face (p - q along its
                                            // normal): that face's side. Else (an edge or a
                                            // vertex is nearest) the winding number.
                                            let [a, b, c] = mesh.tri(best);
                                            let n =
                                                orient * (b - a).cross(c - a).normalize_or_zero();
                                            let s = n.dot(p - q);
                                            if d > 0.0 && s.abs() >= 0.9999 * d {
                                                s.signum()
                                            } else if inside(p) {
                                                -1.0
                                            } else {
                                                1.0
                                            }
                                        });
                                        out.push((i + dims[0] * (j + dims[1] * k), sign * d));
                                    }
                                }
                            }
                        }
                        out
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("SDF worker panicked"))
                .collect()
        });
        let mut values = vec![0.0; dims[0] * dims[1] * dims[2]];
        for (i, v) in results.into_iter().flatten() {
            values[i] = v;
        }
        Sdf {
            origin,
            cell,
            dims,
            values,
        }
    }

    fn at(&self, i: usize, j: usize, k: usize) -> f64 {
        self.values[i + self.dims[0] * (j + self.dims[1] * k)]
    }

    /// Far corner of the grid.
    pub fn max_corner(&self) -> DVec3 {
        self.origin
            + self.cell
                * DVec3::new(
                    (self.dims[0] - 1) as f64,
                    (self.dims[1] - 1) as f64,
                    (self.dims[2] - 1) as f64,
                )
    }

    /// Cell and fractions of a point clamped into the grid.
    fn locate(&self, p: DVec3) -> ([usize; 3], DVec3) {
        let u = (p - self.origin) / self.cell;
        let mut idx = [0usize; 3];
        let mut t = DVec3::ZERO;
        for a in 0..3 {
            let n = self.dims[a];
            let ua = u[a].clamp(0.0, (n - 1) as f64);
            let i = (ua.floor() as usize).min(n.saturating_sub(2));
            idx[a] = i;
            t[a] = ua - i as f64;
        }
        (idx, t)
    }

    fn corners(&self, idx: [usize; 3]) -> [f64; 8] {
        let [i, j, k] = idx;
        let (i1, j1, k1) = (
            (i + 1).min(self.dims[0] - 1),
            (j + 1).min(self.dims[1] - 1),
            (k + 1).min(self.dims[2] - 1),
        );
        [
            self.at(i, j, k),
            self.at(i1, j, k),
            self.at(i, j1, k),
            self.at(i1, j1, k),
            self.at(i, j, k1),
            self.at(i1, j, k1),
            self.at(i, j1, k1),
            self.at(i1, j1, k1),
        ]
    }

    /// Trilinear signed distance (plus the distance to the grid outside it).
    pub fn sample(&self, p: DVec3) -> f64 {
        let (idx, t) = self.locate(p);
        let c = self.corners(idx);
        let x00 = c[0] + (c[1] - c[0]) * t.x;
        let x10 = c[2] + (c[3] - c[2]) * t.x;
        let x01 = c[4] + (c[5] - c[4]) * t.x;
        let x11 = c[6] + (c[7] - c[6]) * t.x;
        let y0 = x00 + (x10 - x00) * t.y;
        let y1 = x01 + (x11 - x01) * t.y;
        let inside = y0 + (y1 - y0) * t.z;
        let clamped = p.clamp(self.origin, self.max_corner());
        inside + (p - clamped).length()
    }

    /// Analytic gradient of the trilinear field (at the nearest grid point outside it).
    pub fn gradient(&self, p: DVec3) -> DVec3 {
        let (idx, t) = self.locate(p);
        let c = self.corners(idx);
        let lerp = |a: f64, b: f64, s: f64| a + (b - a) * s;
        let gx = lerp(
            lerp(c[1] - c[0], c[3] - c[2], t.y),
            lerp(c[5] - c[4], c[7] - c[6], t.y),
            t.z,
        );
        let gy = lerp(
            lerp(c[2] - c[0], c[3] - c[1], t.x),
            lerp(c[6] - c[4], c[7] - c[5], t.x),
            t.z,
        );
        let gz = lerp(
            lerp(c[4] - c[0], c[5] - c[1], t.x),
            lerp(c[6] - c[2], c[7] - c[3], t.x),
            t.y,
        );
        DVec3::new(gx, gy, gz) / self.cell
    }

    /// The f32 copy for `shaders/common/sdf.wgsl`: `GPU_HEADER` words (origin, cell, node
    /// counts) then the values in the same order.
    pub fn to_gpu(&self) -> Vec<f32> {
        let mut out = Vec::with_capacity(GPU_HEADER + self.values.len());
        out.extend([
            self.origin.x as f32,
            self.origin.y as f32,
            self.origin.z as f32,
            self.cell as f32,
            self.dims[0] as f32,
            self.dims[1] as f32,
            self.dims[2] as f32,
            0.0,
        ]);
        out.extend(self.values.iter().map(|&v| v as f32));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let p: Vec<DVec3> = (0..8)
            .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        let t = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        (p, t)
    }

    #[test]
    fn cube_field_is_signed_and_close() {
        let (p, t) = cube();
        let m = Triangles {
            positions: &p,
            triangles: &t,
        };
        assert!((m.winding_number(DVec3::splat(0.5)) - 1.0).abs() < 1e-9);
        assert!(m.winding_number(DVec3::splat(2.0)).abs() < 1e-9);
        let sdf = Sdf::build(&m, 32);
        assert!((sdf.sample(DVec3::splat(0.5)) + 0.5).abs() < 0.05);
        assert!((sdf.sample(DVec3::new(0.5, 0.5, 1.2)) - 0.2).abs() < 0.05);
        let g = sdf.gradient(DVec3::new(0.5, 0.5, 1.1));
        assert!((g - DVec3::Z).length() < 0.05, "{g}");
    }
}
