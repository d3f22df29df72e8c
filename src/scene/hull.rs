//! The head hull that grooming and dynamics collide with: Anjyo's ellipsoid, or a triangle
//! mesh's signed distance field (`scene::sdf`). Both are implicit functions, negative
//! inside, with a gradient, and share Anjyo's push-out (`head::push_out_implicit`), so the
//! cantilever, the projective dynamics and the pseudo-force (D = the hull gradient) are
//! written once. Units differ: the ellipsoid's value is its quadric form, the SDF's a
//! distance; each variant carries its own push-out margin (`eps_out`).
//!
//! `shaders/common/sdf.wgsl` is the GPU twin (`HeadHull`, `head_eval`, `head_push_out`).

use super::head::{push_out_implicit, Ellipsoid, EPS_OUT};
use super::mesh::Mesh;
use super::sdf::{closest_point_triangle, Sdf, Triangles};
use super::{Head, HeadMesh, MeshSource, ScalpRegion};
use crate::error::{KamiError, Result};
use glam::{DMat4, DVec3};
use std::path::Path;
use std::sync::{Arc, Mutex};

/// Nodes pushed out of a mesh head land this far outside its zero level set (scene units,
/// cm by convention: 0.1 mm, well above f32 rounding of positions near 20 cm).
pub const SDF_EPS_OUT: f64 = 0.01;

#[derive(Clone, Debug, PartialEq)]
pub enum HeadHull {
    Ellipsoid(Ellipsoid),
    Sdf(Arc<Sdf>),
}

impl HeadHull {
    /// The hull of `head` whose mesh data (`head_mesh`) the caller already holds: the mesh's
    /// SDF, or the ellipsoid without a mesh (`head_hull` looks the mesh up itself).
    pub fn of(head: &Head, mesh: Option<&HeadMeshData>) -> HeadHull {
        match mesh {
            Some(m) => HeadHull::Sdf(m.sdf.clone()),
            None => HeadHull::Ellipsoid(Ellipsoid::new(head.center, head.radii)),
        }
    }

    /// Negative inside (quadric form or signed distance).
    pub fn eval(&self, p: DVec3) -> f64 {
        match self {
            HeadHull::Ellipsoid(e) => e.eval(p),
            HeadHull::Sdf(s) => s.sample(p),
        }
    }

    pub fn gradient(&self, p: DVec3) -> DVec3 {
        match self {
            HeadHull::Ellipsoid(e) => e.gradient(p),
            HeadHull::Sdf(s) => s.gradient(p),
        }
    }

    pub fn normal(&self, p: DVec3) -> DVec3 {
        self.gradient(p).normalize_or(DVec3::Y)
    }

    /// How far outside (in `eval`'s units) a pushed node lands.
    pub fn eps_out(&self) -> f64 {
        match self {
            HeadHull::Ellipsoid(_) => EPS_OUT,
            HeadHull::Sdf(_) => SDF_EPS_OUT,
        }
    }

    /// Anjyo's push-out (`Ellipsoid::push_out`) against this hull.
    pub fn push_out(&self, pivot: DVec3, a0: DVec3, p: DVec3, d: f64) -> DVec3 {
        match self {
            HeadHull::Ellipsoid(e) => e.push_out(pivot, a0, p, d),
            HeadHull::Sdf(s) => push_out_implicit(
                &|q| s.sample(q),
                &|q| s.gradient(q),
                SDF_EPS_OUT,
                pivot,
                a0,
                p,
                d,
            ),
        }
    }

    /// The ellipsoid's centre and radii for the GPU (placeholders for an SDF).
    pub fn ellipsoid(&self) -> Ellipsoid {
        match self {
            HeadHull::Ellipsoid(e) => *e,
            HeadHull::Sdf(_) => Ellipsoid::new([0.0; 3], [1.0; 3]),
        }
    }

    /// `head_center` and `head_radii` of the kernels' parameters: the ellipsoid, and in
    /// `head_center.w` 1 when the hull is the SDF bound beside them (`shaders/common/sdf.wgsl`).
    pub fn gpu_params(&self) -> ([f32; 4], [f32; 4]) {
        let e = self.ellipsoid();
        let flag = if self.sdf().is_some() { 1.0 } else { 0.0 };
        (
            [
                e.center.x as f32,
                e.center.y as f32,
                e.center.z as f32,
                flag,
            ],
            [e.radii.x as f32, e.radii.y as f32, e.radii.z as f32, 0.0],
        )
    }

    /// The SDF's words for the kernels' `sdf_data` binding (a placeholder header for an
    /// ellipsoid, never read).
    pub fn gpu_sdf(&self) -> Vec<f32> {
        match self {
            HeadHull::Sdf(s) => s.to_gpu(),
            HeadHull::Ellipsoid(_) => vec![0.0; super::sdf::GPU_HEADER + 8],
        }
    }

    pub fn sdf(&self) -> Option<&Sdf> {
        match self {
            HeadHull::Sdf(s) => Some(s),
            HeadHull::Ellipsoid(_) => None,
        }
    }
}

/// A loaded mesh head: the placed mesh, its field and its scalp.
#[derive(Debug)]
pub struct HeadMeshData {
    /// In head coordinates (placed by the scene's scale, rotation and translation).
    pub mesh: Mesh,
    pub sdf: Arc<Sdf>,
    /// Scalp triangles and their cumulative areas (for area-uniform pores).
    pub scalp: Vec<u32>,
    pub scalp_cdf: Vec<f64>,
    /// Each triangle's bounding sphere (centroid, radius): `place_on_scalp` skips the
    /// triangles that cannot be nearest a root.
    pub spheres: Vec<(DVec3, f64)>,
    /// Seconds the SDF took to build.
    pub build_seconds: f64,
}

/// Placement of the head mesh: scale, rotate (x then y then z, degrees), translate.
pub fn placement(m: &HeadMesh) -> DMat4 {
    super::placement(m.scale, m.rotate, m.translate)
}

/// Polar angles (degrees) of `p` about `center`: zenith from +y, azimuth from +x to +z.
pub fn polar_deg(p: DVec3, center: DVec3) -> (f64, f64) {
    let q = p - center;
    let l = q.length().max(1e-300);
    (
        (q.y / l).clamp(-1.0, 1.0).acos().to_degrees(),
        q.z.atan2(q.x).to_degrees(),
    )
}

/// Is `p` in every scalp region?
pub fn in_scalp(regions: &[ScalpRegion], center: DVec3, p: DVec3) -> bool {
    regions.iter().all(|r| match r {
        ScalpRegion::Polar { theta, phi } => {
            let (t, f) = polar_deg(p, center);
            t >= theta.0 && t <= theta.1 && super::head::phi_in_range(f, *phi)
        }
        ScalpRegion::Sphere { center, radius } => (p - DVec3::from(*center)).length() <= *radius,
        ScalpRegion::HalfSpace { normal, offset } => DVec3::from(*normal).dot(p) >= *offset,
    })
}

/// Read the mesh file a source names.
pub fn load_source(source: &MeshSource) -> Result<Mesh> {
    match source {
        MeshSource::Critter => Ok(super::critter::critter()),
        MeshSource::File(path) => Mesh::load(path),
        MeshSource::CgalDemo(name) => {
            let dir = std::env::temp_dir().join("kami-cgal-data");
            Mesh::load(super::mesh::cgal_demo_mesh(name, &dir)?)
        }
        // A skinned glTF's mesh in its bind pose (the head does not follow the skin).
        MeshSource::Gltf {
            file,
            animation,
            fps,
        } => Ok(super::skinned::load(Path::new(file), animation.as_deref(), *fps)?.mesh),
    }
}

/// Load, place and build the field of a mesh head (no cache).
pub fn build_head_mesh(head: &Head, m: &HeadMesh) -> Result<HeadMeshData> {
    let mut mesh = load_source(&m.source)?;
    let xf = placement(m);
    for p in &mut mesh.positions {
        *p = xf.transform_point3(*p);
    }
    let nx = xf.inverse().transpose();
    for n in &mut mesh.normals {
        *n = nx.transform_vector3(*n).normalize_or(DVec3::Y);
    }
    // Wind outwards (an open mesh is left as its file winds it by `Mesh::new`; CGAL's
    // head.off is wound inwards): the head pass culls back faces and lights by the normals.
    let tris = Triangles {
        positions: &mesh.positions,
        triangles: &mesh.triangles,
    };
    if tris.orientation() < 0.0 {
        for t in &mut mesh.triangles {
            t.swap(1, 2);
        }
        for n in &mut mesh.normals {
            *n = -*n;
        }
    }
    let start = std::time::Instant::now();
    let sdf = Sdf::build(
        &Triangles {
            positions: &mesh.positions,
            triangles: &mesh.triangles,
        },
        m.resolution as usize,
    );
    let build_seconds = start.elapsed().as_secs_f64();
    let center = DVec3::from(head.center);
    let mut scalp = Vec::new();
    let mut scalp_cdf = Vec::new();
    let mut acc = 0.0;
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let c = tri
            .iter()
            .map(|&i| mesh.positions[i as usize])
            .sum::<DVec3>()
            / 3.0;
        let a = mesh.area(t);
        if a > 0.0 && in_scalp(&m.scalp, center, c) {
            acc += a;
            scalp.push(t as u32);
            scalp_cdf.push(acc);
        }
    }
    if scalp.is_empty() {
        return Err(KamiError::Invalid {
            file: String::new(),
            field: "head.mesh.scalp".into(),
            value: format!("{:?}", m.scalp),
            allowed: "regions that contain at least one triangle of the mesh".into(),
        });
    }
    let spheres = mesh
        .triangles
        .iter()
        .map(|tri| {
            let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
            let m = (a + b + c) / 3.0;
            let r = (a - m).length().max((b - m).length()).max((c - m).length());
            (m, r)
        })
        .collect();
    Ok(HeadMeshData {
        mesh,
        spheres,
        sdf: Arc::new(sdf),
        scalp,
        scalp_cdf,
        build_seconds,
    })
}

/// Keyed by what the mesh head depends on (its description and the centre polar scalp
/// regions are measured about, and the file's size and time), so editing the skin colour
/// rebuilds nothing.
type Key = ([f64; 3], HeadMesh, Option<(u64, std::time::SystemTime)>);
type Cache = Option<(Key, Arc<HeadMeshData>)>;
static CACHE: Mutex<Cache> = Mutex::new(None);

/// The mesh head of a scene, built once per distinct head (re-grooms and the head pass share
/// it); `None` for an ellipsoid head.
pub fn head_mesh(head: &Head) -> Result<Option<Arc<HeadMeshData>>> {
    let Some(m) = &head.mesh else {
        return Ok(None);
    };
    // The file's size and modification time are part of the key: a mesh replaced on disk
    // and opened again is read again.
    let key = (head.center, m.clone(), stamp(&m.source));
    if let Ok(c) = CACHE.lock() {
        if let Some((k, v)) = c.as_ref() {
            if *k == key {
                return Ok(Some(v.clone()));
            }
        }
    }
    let data = Arc::new(build_head_mesh(head, m)?);
    if let Ok(mut c) = CACHE.lock() {
        *c = Some((key, data.clone()));
    }
    Ok(Some(data))
}

/// Size and modification time of the file a mesh source reads (None for built-in and
/// packaged meshes, or when the file cannot be stat'ed: the load reports that).
fn stamp(source: &MeshSource) -> Option<(u64, std::time::SystemTime)> {
    let path = match source {
        MeshSource::File(f) | MeshSource::Gltf { file: f, .. } => f,
        _ => return None,
    };
    let meta = std::fs::metadata(path).ok()?;
    Some((meta.len(), meta.modified().ok()?))
}

/// Newton steps that move a root onto the SDF's zero level set.
pub const ROOT_NEWTON: u32 = 8;
/// A root lies on the field's zero level set within this (scene units).
pub const ROOT_TOLERANCE: f64 = 1e-4;

/// The farthest a drawn root may lie from a mesh head: `own` (the root's own size: a wisp's
/// radius, a strip's width) or a quarter of the head's smallest radius, whichever is larger.
/// Farther, the hair was not drawn for this head, and moving it would only hide the mistake.
pub fn root_reach(own: f64, head: &Head) -> f64 {
    let r = head.radii.iter().copied().fold(f64::INFINITY, f64::min);
    own.max(0.25 * r)
}

/// A root placed on a mesh head's scalp (`HeadMeshData::place_on_scalp`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalpPoint {
    /// On the SDF's zero level set, over a scalp triangle.
    pub root: DVec3,
    /// The scalp triangle nearest the drawn root.
    pub triangle: u32,
}

/// Why a drawn root cannot go on the scalp; each kind words the error with its own field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OffScalp {
    /// `dist` from the mesh (NaN or infinite for a bad point or a mesh without triangles),
    /// more than `reach`.
    Far { dist: f64, reach: f64 },
    /// Nearest a triangle that is not scalp.
    NotScalp { triangle: u32 },
    /// The field cannot follow the mesh there (a feature thinner than a cell of `cell`).
    Unfollowed { cell: f64 },
}

impl HeadMeshData {
    /// Place a root drawn at `drawn` on the scalp, as Anjyo's pores sit: the nearest point of
    /// the mesh, which must lie on a scalp triangle within `reach`, then onto the SDF's zero
    /// level set by Newton steps (the hull the hair collides with). Shared by the kinds whose
    /// roots are drawn rather than grown (toon wisps, strips).
    pub fn place_on_scalp(
        &self,
        drawn: DVec3,
        reach: f64,
    ) -> std::result::Result<ScalpPoint, OffScalp> {
        let m = &self.mesh;
        // The nearest triangle, as a search of every triangle in order finds it (the first of
        // equals), without measuring those whose bounding sphere lies farther than the
        // nearest centroid (a centroid is on its triangle, so the nearest triangle is at most
        // that far; the skipped ones can be neither nearer nor equal).
        let bound = self
            .spheres
            .iter()
            .map(|(c, _)| (drawn - *c).length())
            .fold(f64::INFINITY, f64::min);
        let mut best = (f64::INFINITY, DVec3::ZERO, 0u32);
        for (t, tri) in m.triangles.iter().enumerate() {
            let (c, r) = self.spheres[t];
            if (drawn - c).length() - r > bound {
                continue;
            }
            let [a, b, c] = tri.map(|i| m.positions[i as usize]);
            let q = closest_point_triangle(drawn, a, b, c);
            let d = (q - drawn).length_squared();
            if d < best.0 {
                best = (d, q, t as u32);
            }
        }
        let (d2, on_mesh, triangle) = best;
        let dist = d2.sqrt();
        // Also refuses a mesh without triangles (infinite) or a NaN.
        if dist.is_nan() || dist > reach {
            return Err(OffScalp::Far { dist, reach });
        }
        if self.scalp.binary_search(&triangle).is_err() {
            return Err(OffScalp::NotScalp { triangle });
        }
        let sdf = &self.sdf;
        let mut root = on_mesh;
        for _ in 0..ROOT_NEWTON {
            let s = sdf.sample(root);
            if s.abs() < ROOT_TOLERANCE {
                break;
            }
            let g = sdf.gradient(root);
            let l2 = g.length_squared();
            if l2 <= 1e-12 {
                break;
            }
            root -= s * g / l2;
        }
        let followed = (root - on_mesh).length() <= 0.25 * sdf.cell;
        if !(followed && sdf.sample(root).abs() < ROOT_TOLERANCE) {
            return Err(OffScalp::Unfollowed { cell: sdf.cell });
        }
        Ok(ScalpPoint { root, triangle })
    }
}

/// The scene's collision hull.
pub fn head_hull(head: &Head) -> Result<HeadHull> {
    Ok(HeadHull::of(head, head_mesh(head)?.as_deref()))
}

impl HeadMeshData {
    /// An area-uniform point on the scalp from two uniforms in [0,1) and a third for the
    /// triangle: (position, interpolated unit normal).
    pub fn sample(&self, u_tri: f64, u: f64, v: f64) -> (DVec3, DVec3) {
        let total = *self.scalp_cdf.last().unwrap_or(&0.0);
        let target = u_tri * total;
        let k = self
            .scalp_cdf
            .partition_point(|&c| c <= target)
            .min(self.scalp.len() - 1);
        let tri = self.mesh.triangles[self.scalp[k] as usize];
        let [a, b, c] = tri.map(|i| self.mesh.positions[i as usize]);
        let [na, nb, nc] = tri.map(|i| self.mesh.normals[i as usize]);
        let (mut s, mut t) = (u, v);
        if s + t > 1.0 {
            (s, t) = (1.0 - s, 1.0 - t);
        }
        let p = a + s * (b - a) + t * (c - a);
        let face = (b - a).cross(c - a).normalize_or(DVec3::Y);
        let n = ((1.0 - s - t) * na + s * nb + t * nc).normalize_or(face);
        (p, n)
    }
}
