//! Van Gelder & Wilhelms' interactive fur: roots, coats, shapes, styles, culling.
//!
//! **Roots (3.2).** Each coat allocates `floor(alpha N + u)` hairs to a triangle (alpha: its
//! share of the skin area, u uniform: random rounding, so small triangles do not go bald).
//! A hair is stored as nothing but its triangle and its creation index h: its barycentric
//! coordinates are entry `h mod 2048` of a seeded table of `b1 = 1 - sqrt(u1)`,
//! `b2 = (1 - b1) u2` — so hairs are regenerated every frame from the (possibly moving)
//! mesh, as the paper recommends.
//!
//! **Shape (3.4, 3.5).** Length and normal are interpolated from the vertices; the weightless
//! direction blends the skin normal with the body-segment direction; the weightless end
//! point may be perturbed; floppiness f = max(1 - stiffness, 0.02) subtracts f cos(theta)
//! from the up component of the direction (theta: between the weightless direction and the
//! skin normal), which gives the end point.
//!
//! **Styles (3.6-3.8).** Line: root to end. Polyline: 8 points of the template
//! (t, t^2) in the non-orthogonal frame (root -> weightless end, weightless end -> end), so
//! it leaves the root towards the weightless end and bends towards the end. Curve and tube:
//! a cubic Bezier in the same plane (leaving along the weightless direction, arriving along
//! the final one), tessellated into `CURVE_SEGMENTS` on the GPU.
//!
//! **Culling (3.3).** Beyond the distance where the model fills the view, a triangle draws
//! `floor(n c + v)` of its n hairs (c = full distance / distance, v a per-triangle uniform),
//! the first ones in creation order, so density stays uniform; widths grow as 1/c.
//!
//! `shaders/fur/generate.wgsl` (run by `generate.rs`) does the per-hair part on the GPU each frame; `hair_points` here is
//! its f64 reference.

use crate::error::{KamiError, Result};
use crate::rng::{pcg_hash, Rng};
use crate::scene::mesh::Mesh;
use crate::scene::skinned::{self, Skin};
use crate::scene::MeshSource;
use crate::systems::fur::block::{Coat, Fur, FurStyle, MeshMotion, CURVE_SEGMENTS};
use glam::{DMat4, DVec3};

/// Entries of the barycentric table (the paper's 2048).
pub const TABLE: usize = 2048;

/// One coat's allocation: per triangle the creation index of its first hair and its hair
/// count, plus the random number used to round its culled count.
#[derive(Clone, Debug)]
pub struct CoatAlloc {
    pub first: Vec<u32>,
    pub count: Vec<u32>,
    pub cull_u: Vec<f32>,
    pub total: u32,
    pub seed: u32,
}

/// Everything the fur generator reads: the mesh with per-vertex lengths, the table, and
/// each coat's allocation.
#[derive(Clone, Debug)]
pub struct FurSetup {
    pub fur: Fur,
    pub mesh: Mesh,
    /// Hair length at each vertex (fur length times the region scales).
    pub lengths: Vec<f64>,
    /// Unit body-segment direction at each vertex (the fur's, or its region's).
    pub directions: Vec<DVec3>,
    pub table: Vec<[f64; 2]>,
    pub coats: Vec<CoatAlloc>,
    /// The mesh's skin and animation (glTF meshes): vertices are skinned before the mesh
    /// motion, so the roots (fixed barycentric points) ride the skinned triangles.
    pub skin: Option<Skin>,
    /// Bounding sphere of the rest mesh grown by the longest hair: asked for every frame
    /// (culling, framing), so computed once.
    bounds: (DVec3, f64),
    /// The rest mesh's area: with a coat's hair count, its roots per unit of skin.
    skin_area: f64,
}

/// Uniform in [0, 1) from a hash of (seed, hair, which); the same function is in
/// `shaders/fur/generate.wgsl`.
pub fn hair_random(seed: u32, hair: u32, which: u32) -> f64 {
    let h = pcg_hash(which ^ pcg_hash(hair ^ pcg_hash(seed)));
    (h >> 8) as f64 / 16_777_216.0
}

impl FurSetup {
    /// Load or generate the mesh and allocate the roots of every coat.
    pub fn new(fur: &Fur, seed: u64) -> Result<FurSetup> {
        let mesh = match &fur.mesh {
            MeshSource::Critter => crate::scene::critter::critter(),
            MeshSource::File(path) => Mesh::load(path)?,
            MeshSource::CgalDemo(name) => {
                let dir = std::env::temp_dir().join("kami-cgal-data");
                Mesh::load(crate::scene::mesh::cgal_demo_mesh(name, &dir)?)?
            }
            MeshSource::Gltf {
                file,
                animation,
                fps,
            } => {
                let s = skinned::load(std::path::Path::new(file), animation.as_deref(), *fps)?;
                return FurSetup::with_skin(fur, s.mesh, Some(s.skin), seed);
            }
        };
        FurSetup::from_mesh(fur, mesh, seed)
    }

    /// Allocate the roots of every coat on `mesh` (in place of `fur.mesh`).
    pub fn from_mesh(fur: &Fur, mesh: Mesh, seed: u64) -> Result<FurSetup> {
        FurSetup::with_skin(fur, mesh, None, seed)
    }

    /// Allocate the roots of every coat on `mesh`, skinned by `skin` when given (the
    /// scene's `size` fits the rest mesh; the skin is conjugated by the same similarity).
    pub fn with_skin(
        fur: &Fur,
        mut mesh: Mesh,
        mut skin: Option<Skin>,
        seed: u64,
    ) -> Result<FurSetup> {
        if let Some(size) = fur.size {
            let (c, r) = mesh.bounds();
            mesh.fit(size);
            if let Some(sk) = skin.as_mut() {
                let s = if r > 0.0 { size / r } else { 1.0 };
                sk.fit = DMat4::from_scale(DVec3::splat(s)) * DMat4::from_translation(-c);
            }
        }
        let inside = |p: DVec3| {
            fur.regions
                .iter()
                .filter(move |r| (p - DVec3::from(r.center)).length() <= r.radius)
        };
        let lengths: Vec<f64> = mesh
            .positions
            .iter()
            .map(|p| fur.length * inside(*p).map(|r| r.length_scale).product::<f64>())
            .collect();
        let directions = mesh
            .positions
            .iter()
            .map(|p| {
                let d = inside(*p)
                    .filter_map(|r| r.direction)
                    .next_back()
                    .unwrap_or(fur.direction);
                DVec3::from(d).normalize()
            })
            .collect();
        let mut rng = Rng::new(seed, 0xF00D);
        let table = (0..TABLE)
            .map(|_| {
                let b1 = 1.0 - rng.uniform().sqrt();
                let b2 = (1.0 - b1) * rng.uniform();
                [b1, b2]
            })
            .collect();
        let areas: Vec<f64> = (0..mesh.triangles.len()).map(|t| mesh.area(t)).collect();
        let total_area: f64 = areas.iter().sum();
        if total_area.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return Err(KamiError::Mesh {
                path: format!("{:?}", fur.mesh),
                line: None,
                message: "the mesh has no area".into(),
            });
        }
        let share_sum: f64 = fur.coats.iter().map(|c| c.share).sum();
        let coats = fur
            .coats
            .iter()
            .enumerate()
            .map(|(ci, coat)| {
                let n = fur.hairs as f64 * coat.share / share_sum;
                let mut rng = Rng::new(seed, 0xC0A7 + ci as u64);
                let mut first = Vec::with_capacity(areas.len());
                let mut count = Vec::with_capacity(areas.len());
                let mut cull_u = Vec::with_capacity(areas.len());
                let mut total = 0u32;
                for a in &areas {
                    // Random rounding of alpha N.
                    let k = (a / total_area * n + rng.uniform()).floor() as u32;
                    first.push(total);
                    count.push(k);
                    cull_u.push(rng.uniform() as f32);
                    total += k;
                }
                CoatAlloc {
                    first,
                    count,
                    cull_u,
                    total,
                    seed: (rng.next_u32()) ^ ci as u32,
                }
            })
            .collect();
        let (c, mut r) = mesh.bounds();
        // A skinned mesh moves away from its rest pose: grow the sphere over 32 poses.
        if let Some(sk) = &skin {
            let span = sk.animation.as_ref().map_or(0.0, |a| a.duration) * sk.fps;
            for i in 0..32 {
                let mats = sk.joint_matrices(span * i as f64 / 32.0);
                for (v, (p, n)) in mesh.positions.iter().zip(&mesh.normals).enumerate() {
                    r = r.max((sk.skin_vertex(&mats, v, *p, *n).0 - c).length());
                }
            }
        }
        let longest = lengths.iter().cloned().fold(0.0, f64::max)
            * fur
                .coats
                .iter()
                .map(|c| c.relative_length)
                .fold(0.0, f64::max);
        Ok(FurSetup {
            fur: fur.clone(),
            mesh,
            lengths,
            directions,
            table,
            coats,
            skin,
            bounds: (c, r + longest),
            skin_area: total_area,
        })
    }

    /// Hairs drawn per triangle at culling factor `c` (1 = all): `floor(n c + v)`, capped at
    /// n. Returns the prefix offsets (one per triangle, then the total).
    pub fn culled_offsets(&self, coat: usize, c: f64) -> Vec<u32> {
        let a = &self.coats[coat];
        let mut off = Vec::with_capacity(a.count.len() + 1);
        let mut acc = 0u32;
        for (n, v) in a.count.iter().zip(&a.cull_u) {
            off.push(acc);
            let k = if c >= 1.0 {
                *n
            } else {
                ((*n as f64 * c + *v as f64).floor() as u32).min(*n)
            };
            acc += k;
        }
        off.push(acc);
        off
    }

    /// Every vertex's position and normal at `frame` ([`FurSetup::vertex_at`]): the skin as
    /// drawn, for the reference renderer and the skin map's f64 reference.
    pub fn posed_mesh(&self, frame: f64) -> (Vec<DVec3>, Vec<DVec3>) {
        let mats = self.joint_matrices(frame);
        (0..self.mesh.positions.len())
            .map(|v| self.vertex_at(v, frame, mats.as_deref()))
            .unzip()
    }

    /// The skin's triangles at `frame`.
    pub fn posed_triangles(&self, frame: f64) -> Vec<[DVec3; 3]> {
        let (p, _) = self.posed_mesh(frame);
        self.mesh
            .triangles
            .iter()
            .map(|t| t.map(|v| p[v as usize]))
            .collect()
    }

    /// A coat's fibre area per unit of skin and of hair length at the root: roots per unit
    /// of skin times the root width (culling draws fewer, wider hairs and keeps it). Times
    /// the tapered length above a point, it is the coat's fibre-area index there, which
    /// dims the physical mode's ambient (`hair_bsdf::ambient_transmittance`).
    pub fn coat_density(&self, coat: usize) -> f64 {
        self.coats[coat].total as f64 / self.skin_area * self.fur.coats[coat].material.width
    }

    /// Bounding sphere of the (rest) mesh grown by the longest hair.
    pub fn bounds(&self) -> (DVec3, f64) {
        self.bounds
    }

    /// The skin's joint matrices at `frame` (None for an unskinned mesh).
    pub fn joint_matrices(&self, frame: f64) -> Option<Vec<DMat4>> {
        self.skin.as_ref().map(|s| s.joint_matrices(frame))
    }

    /// Position and normal of vertex `v` at `frame`: skinned by `mats` (from
    /// [`FurSetup::joint_matrices`] at the same frame), then moved by the mesh motion.
    pub fn vertex_at(&self, v: usize, frame: f64, mats: Option<&[DMat4]>) -> (DVec3, DVec3) {
        let (p, n) = (self.mesh.positions[v], self.mesh.normals[v]);
        let (p, n) = match (&self.skin, mats) {
            (Some(sk), Some(m)) => sk.skin_vertex(m, v, p, n),
            _ => (p, n),
        };
        deform(self.fur.motion.as_ref(), p, n, frame)
    }
}

/// The culling factor at camera distance `distance` from the model: 1 up to the full
/// distance, then full / distance: the strand share of the screen-space level of detail
/// shared with strand hair (`systems::lod::strand_share`), with the coat's own full distance
/// when it sets one.
pub fn culling_factor(fur: &Fur, bounds: (DVec3, f64), fov_y: f64, distance: f64) -> f64 {
    if !fur.culling.enabled {
        return 1.0;
    }
    crate::systems::lod::strand_share(bounds.1, distance, fov_y, fur.culling.full_distance)
}

/// Position and normal of a mesh point after the mesh motion at `frame` (a travelling wave
/// u = A sin(k (p.axis) - w t) along `direction`; normals by the inverse transpose of its
/// Jacobian). The same function is in `shaders/common/deform.wgsl`.
pub fn deform(m: Option<&MeshMotion>, p: DVec3, n: DVec3, frame: f64) -> (DVec3, DVec3) {
    let Some(m) = m else { return (p, n) };
    let a = DVec3::from(m.axis).normalize();
    let d = DVec3::from(m.direction).normalize();
    let k = std::f64::consts::TAU / m.wavelength;
    let phase = k * p.dot(a) - std::f64::consts::TAU * frame / m.period;
    let q = p + d * (m.amplitude * phase.sin());
    // J = I + A k cos(phase) d a^T; J^-T n = n - (A k cos / (1 + A k cos a.d)) a (d.n)
    let g = m.amplitude * k * phase.cos();
    let nn = n - a * (g * d.dot(n) / (1.0 + g * a.dot(d)));
    (q, nn.try_normalize().unwrap_or(n))
}

/// What the generator produces for one hair: its nodes, skin normal, hair-plane normal and
/// the random number of its shading normals.
#[derive(Clone, Debug, PartialEq)]
pub struct HairPoints {
    pub nodes: Vec<DVec3>,
    pub skin_normal: DVec3,
    pub plane_normal: DVec3,
    pub rand: f64,
}

/// Generate hair `h` (creation index in `coat`) of triangle `t` at `frame` (f64 reference of
/// the GPU kernel).
pub fn hair_points(s: &FurSetup, coat: usize, t: usize, h: u32, frame: f64) -> HairPoints {
    let c: &Coat = &s.fur.coats[coat];
    let alloc = &s.coats[coat];
    let [b1, b2] = s.table[h as usize % TABLE];
    let b = [b1, b2, 1.0 - b1 - b2];
    let tri = s.mesh.triangles[t];
    let mats = s.joint_matrices(frame);
    let mut root = DVec3::ZERO;
    let mut normal = DVec3::ZERO;
    let mut len = 0.0;
    let mut body = DVec3::ZERO;
    for k in 0..3 {
        let v = tri[k] as usize;
        let (p, n) = s.vertex_at(v, frame, mats.as_deref());
        root += b[k] * p;
        normal += b[k] * n;
        len += b[k] * s.lengths[v];
        body += b[k] * s.directions[v];
    }
    let n = normal.try_normalize().unwrap_or(DVec3::Y);
    let len = len * c.relative_length;
    let body = body.try_normalize().unwrap_or(n);
    let wdir0 = ((1.0 - c.direction_weight) * n + c.direction_weight * body)
        .try_normalize()
        .unwrap_or(n);
    // Random end perturbation: a direction from the hash, scaled by end_randomize.
    let r = |which: u32| hair_random(alloc.seed, h, which);
    let z = 2.0 * r(0) - 1.0;
    let az = std::f64::consts::TAU * r(1);
    let rho = (1.0 - z * z).max(0.0).sqrt();
    let jitter = DVec3::new(rho * az.cos(), z, rho * az.sin()) * (c.end_randomize * r(2));
    let wend = root + len * (wdir0 + jitter);
    let wdir = (wend - root).try_normalize().unwrap_or(wdir0);
    let wend = root + len * wdir;
    // Floppiness pulls the end down along up by f cos(theta).
    let up = DVec3::from(s.fur.up).normalize();
    let f = (1.0 - c.stiffness).max(0.02);
    let cos_theta = wdir.dot(n);
    let dir = (wdir - up * (f * cos_theta))
        .try_normalize()
        .unwrap_or(wdir);
    let end = root + len * dir;
    let plane = wdir.cross(dir);
    let plane_normal = if plane.length() > 1e-9 {
        plane.normalize()
    } else {
        wdir.any_orthonormal_vector()
    };
    let nodes = match c.style {
        FurStyle::Line => vec![root, end],
        FurStyle::Polyline => (0..8)
            .map(|i| {
                let t = i as f64 / 7.0;
                root + t * (wend - root) + t * t * (end - wend)
            })
            .collect(),
        FurStyle::Curve | FurStyle::Tube => {
            let p1 = root + wdir * (len / 3.0);
            let p2 = end - dir * (len / 3.0);
            (0..=CURVE_SEGMENTS)
                .map(|i| {
                    let t = i as f64 / CURVE_SEGMENTS as f64;
                    let u = 1.0 - t;
                    root * (u * u * u)
                        + p1 * (3.0 * u * u * t)
                        + p2 * (3.0 * u * t * t)
                        + end * (t * t * t)
                })
                .collect()
        }
    };
    HairPoints {
        nodes,
        skin_normal: n,
        plane_normal,
        rand: r(3),
    }
}

/// The triangle and creation index of drawn slot `slot` given prefix `offsets` (binary
/// search, as the GPU does) and the coat's `first` table.
pub fn slot_hair(offsets: &[u32], first: &[u32], slot: u32) -> (usize, u32) {
    // Largest t with offsets[t] <= slot among triangles (offsets has T + 1 entries).
    let t = offsets[..offsets.len() - 1].partition_point(|&o| o <= slot) - 1;
    (t, first[t] + (slot - offsets[t]))
}
