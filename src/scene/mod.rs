//! Scene files: what to show. A scene is a RON file (`assets/scenes/*.ron`) naming the head
//! (an ellipsoid or a mesh), the world's forces (`forces`: gravity, wind, the EFF, head
//! motion), each kind's hair (Anjyo's groups and dynamics, fur, wisps, strips), and the
//! camera and light. `load` parses it and `validate` checks every number before anything reaches the GPU,
//! so a bad file fails with the field, the value and the allowed range. Every struct and
//! struct variant denies unknown fields: a misspelt optional field is an error, not silently
//! its default.
//!
//! Coordinates follow Anjyo's Fig. 5(a): the face looks along +x, y is up, z is to the
//! head's left. Polar angles on an ellipsoid: the zenith `theta` is measured from +y (0 at
//! the crown, 180 under the chin), the azimuth `phi` in the zx plane from +x (the face)
//! towards +z, in degrees. Lengths are in centimetres by convention (any unit works: only
//! ratios matter to the bending).

pub mod bvh;
pub mod critter;
pub mod eff;
pub mod forces;
pub mod fur;
pub(crate) mod head;
pub mod hull;
pub mod mesh;
pub mod sdf;
pub mod skinned;
pub mod strips;
mod validate;
pub mod wisps;

pub use eff::Sampling;
pub use forces::{ForcesDesc, HeadKey, Interp, WindKey};
pub use head::Ellipsoid;
pub use validate::{validate, MAX_SEGMENTS, MAX_SIZE, MAX_STRANDS, MAX_STRIP_EDITS};

use crate::error::{KamiError, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A whole scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Seed of every random draw (pores, lengths, per-strand ambient).
    #[serde(default)]
    pub seed: u64,
    /// The head hull (a default head when absent: fur scenes need none).
    #[serde(default)]
    pub head: Head,
    /// The load Anjyo's groom is styled under: the hair's weight per unit length, in the
    /// units of `rigidity` (a setting of the groom, not a force of the world: hair in motion
    /// falls under `forces.gravity`).
    #[serde(default = "default_groom_load")]
    pub groom_load: [f64; 3],
    /// The world's forces, shared by every kind (`scene::forces`).
    #[serde(default)]
    pub forces: ForcesDesc,
    /// Anjyo's hair groups; empty when the scene shows only other kinds (fur, wisps, strips).
    #[serde(default)]
    pub groups: Vec<HairGroup>,
    #[serde(default)]
    pub camera: CameraDesc,
    #[serde(default)]
    pub light: Light,
    #[serde(default)]
    pub render: RenderSettings,
    /// Hair in motion (Anjyo section 3). Absent: the groom is static and no simulation
    /// buffers or passes are built.
    #[serde(default)]
    pub dynamics: Option<Dynamics>,
    /// Fur on a triangle mesh (Van Gelder & Wilhelms).
    #[serde(default)]
    pub fur: Option<fur::Fur>,
    /// Toon wisps (Sakai): skeletons drawn as a ray-marched blobby surface.
    #[serde(default)]
    pub wisps: Option<wisps::Wisps>,
    /// Directable strips (Kazama et al.): layered reed strips on damped angular springs.
    #[serde(default)]
    pub strips: Option<strips::Strips>,
}

fn default_groom_load() -> [f64; 3] {
    [0.0, -1.0, 0.0]
}

/// The head: the ellipsoidal hull of Anjyo's step [alpha]. Pores lie on it and hair collides
/// with it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Head {
    #[serde(default)]
    pub center: [f64; 3],
    #[serde(default = "default_radii")]
    pub radii: [f64; 3],
    /// Skin colour (sRGB, 0..1).
    #[serde(default = "default_skin")]
    pub color: [f32; 3],
    /// Draw the ellipsoid (the collision hull is used either way).
    #[serde(default = "yes")]
    pub visible: bool,
    /// A head that is a triangle mesh: pores lie on its scalp and hair collides with its
    /// signed distance field instead of the ellipsoid (`center` stays the point polar angles
    /// are measured about; `radii` only frame the camera).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<HeadMesh>,
}

/// A mesh head (`scene::hull`): where the mesh comes from, how it is placed in head
/// coordinates (face along +x, y up), which part grows hair and the SDF resolution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadMesh {
    /// An OBJ, OFF or PLY file (relative to the scene file) or a CGAL demo mesh.
    pub source: fur::MeshSource,
    /// Scale the file's coordinates by this (first).
    #[serde(default = "one_f64")]
    pub scale: f64,
    /// Then rotate: degrees about x, then y, then z.
    #[serde(default)]
    pub rotate: [f64; 3],
    /// Then translate.
    #[serde(default)]
    pub translate: [f64; 3],
    /// The scalp: triangles whose centroid is in every region listed (all when empty).
    #[serde(default)]
    pub scalp: Vec<ScalpRegion>,
    /// SDF cells along the grid's longest axis.
    #[serde(default = "default_sdf_resolution")]
    pub resolution: u32,
}

fn one_f64() -> f64 {
    1.0
}

fn default_sdf_resolution() -> u32 {
    64
}

/// One region the scalp lies in (placed head coordinates).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ScalpRegion {
    /// Polar angles (degrees, as for pores on the ellipsoid) of `p - head.center`: zenith
    /// from +y, azimuth from +x towards +z (may run past 180 to wrap).
    Polar { theta: (f64, f64), phi: (f64, f64) },
    /// Inside a sphere.
    Sphere { center: [f64; 3], radius: f64 },
    /// Points with `dot(normal, p) >= offset`.
    HalfSpace { normal: [f64; 3], offset: f64 },
}

fn default_radii() -> [f64; 3] {
    [9.6, 11.5, 7.8]
}

impl Default for Head {
    fn default() -> Self {
        Head {
            center: [0.0; 3],
            radii: default_radii(),
            color: default_skin(),
            visible: true,
            mesh: None,
        }
    }
}

fn default_skin() -> [f32; 3] {
    [0.85, 0.66, 0.55]
}

fn yes() -> bool {
    true
}

/// One separately designed part of a hairstyle (Anjyo designs the bob as halves, bangs and
/// back; the ponytail as scalp hair plus tail).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HairGroup {
    #[serde(default)]
    pub name: String,
    /// Strands read from a file made in another tool instead of grown from pores: the file's
    /// shapes are the rest pose (no cantilever bending), resampled to `segments` equal
    /// segments each. `roots`, `length`, `rigidity`, `direction` and the jitters do not
    /// apply; `count` is the most strands taken (spread evenly over the file).
    #[serde(default)]
    pub file: Option<StrandFile>,
    /// Where the pores are (the whole upper head when absent).
    #[serde(default)]
    pub roots: Roots,
    /// Number of hairs.
    pub count: u32,
    /// Segments per hair (k in the paper).
    pub segments: u32,
    /// Hair length (k * d); required unless the group names a `file`.
    #[serde(default)]
    pub length: f64,
    /// Relative random variation of the length: each hair is `length * (1 + j*(2u-1))`.
    #[serde(default)]
    pub length_jitter: f64,
    /// Initial (unloaded) direction at the pore.
    #[serde(default)]
    pub direction: Direction,
    /// Random tilt of each hair's initial direction, degrees (uniform in a cone), so that
    /// neighbouring hairs are not exactly parallel.
    #[serde(default)]
    pub direction_jitter: f64,
    /// Flexural rigidity EI; required unless the group names a `file`.
    #[serde(default)]
    pub rigidity: f64,
    #[serde(default)]
    pub bending: Bending,
    /// Combing forces added to gravity, per unit length, each limited to a region.
    #[serde(default)]
    pub loads: Vec<Load>,
    /// Cutting: segments hidden after styling.
    #[serde(default)]
    pub cuts: Vec<Cut>,
    #[serde(default)]
    pub material: Material,
    /// Simulated when the scene has dynamics; `false` keeps the group still (its strands get
    /// no simulation state at all).
    #[serde(default = "yes")]
    pub dynamic: bool,
}

/// Pore region: a polar range on the head ellipsoid, or on another ellipsoid (a ponytail's
/// tie, say). Angles in degrees; `phi` may run past 180 to wrap round the back.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Roots {
    pub theta: (f64, f64),
    pub phi: (f64, f64),
    /// Pores on this ellipsoid instead of the head.
    #[serde(default)]
    pub on: Option<EllipsoidDesc>,
    /// A hairline: (phi, largest theta) pairs in degrees, phi increasing, joined linearly
    /// and wrapping round; pores below it (larger theta) are not grown. Lets one group follow
    /// the forehead, temples, ears and nape instead of a polar rectangle.
    #[serde(default)]
    pub hairline: Option<Vec<(f64, f64)>>,
}

impl Default for Roots {
    /// The upper half of the head, all round.
    fn default() -> Self {
        Roots {
            theta: (0.0, 90.0),
            phi: (-180.0, 180.0),
            on: None,
            hairline: None,
        }
    }
}

/// A strand file a hair group reads (`.hair`, OBJ polylines, `.usda` BasisCurves; see
/// `crate::formats`). The transform places the groom on Kami's head (face along +x, y up):
/// points are scaled, then rotated (degrees about x, then y, then z), then moved.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StrandFile {
    /// The file, relative to the scene file's folder or absolute.
    pub path: String,
    #[serde(default = "one_f64")]
    pub scale: f64,
    #[serde(default)]
    pub rotate: [f64; 3],
    #[serde(default)]
    pub translate: [f64; 3],
    /// The strands as read, placed (filled by `Scene::load` or [`resolve_strand_files`]).
    #[serde(skip)]
    pub groom: Option<std::sync::Arc<crate::formats::Groom>>,
}

impl StrandFile {
    /// The placement as a matrix: scale, then rotate x, y, z, then translate.
    pub fn transform(&self) -> glam::DMat4 {
        placement(self.scale, self.rotate, self.translate)
    }
}

/// How files made elsewhere are placed in Kami's head coordinates (strand files, head
/// meshes): scale, then rotate (degrees about x, then y, then z), then translate.
pub fn placement(scale: f64, rotate: [f64; 3], translate: [f64; 3]) -> glam::DMat4 {
    let [rx, ry, rz] = rotate.map(f64::to_radians);
    glam::DMat4::from_scale_rotation_translation(
        glam::DVec3::splat(scale),
        glam::DQuat::from_euler(glam::EulerRot::ZYX, rz, ry, rx),
        glam::DVec3::from(translate),
    )
}

/// Read the strand files the scene's hair groups name (relative paths from `dir`), place
/// them and keep at most `count` strands of each, spread evenly; `count` becomes the number
/// taken. `origin` names the scene in errors.
pub fn resolve_strand_files(scene: &mut Scene, dir: &Path, origin: &str) -> Result<()> {
    for (gi, g) in scene.groups.iter_mut().enumerate() {
        let Some(f) = g.file.as_mut() else { continue };
        let path = if Path::new(&f.path).is_relative() && !dir.as_os_str().is_empty() {
            dir.join(&f.path)
        } else {
            Path::new(&f.path).to_path_buf()
        };
        let mut read = crate::formats::read(&path)?;
        // Strands with no length (every point the same) cannot be hair: left out, said.
        let before = read.counts.len();
        drop_pointless_strands(&mut read);
        if read.counts.len() < before {
            log::warn!(
                "{}: {} of {before} strands have no length (all their points coincide) and are left out",
                path.display(),
                before - read.counts.len()
            );
        }
        // Absolute, so a scene saved elsewhere (the viewer's Save) still finds the file.
        if let Ok(abs) = std::fs::canonicalize(&path) {
            f.path = abs.display().to_string();
        }
        let n = read.counts.len();
        if n == 0 {
            return Err(KamiError::Invalid {
                file: origin.to_string(),
                field: format!("groups[{gi}].file.path"),
                value: format!("{:?}", f.path),
                allowed: "the file has no strands".into(),
            });
        }
        let take = (g.count as usize).min(n);
        let m = f.transform();
        let mut groom = crate::formats::Groom::default();
        let mut starts = Vec::with_capacity(n + 1);
        let mut acc = 0usize;
        for &c in &read.counts {
            starts.push(acc);
            acc += c as usize;
        }
        for j in 0..take {
            // Strand j of `take`, spread evenly over the file's order.
            let i = j * n / take;
            let range = starts[i]..starts[i] + read.counts[i] as usize;
            groom.counts.push(read.counts[i]);
            groom
                .points
                .extend(read.points[range.clone()].iter().map(|p| {
                    let q =
                        m.transform_point3(glam::DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
                    [q.x as f32, q.y as f32, q.z as f32]
                }));
            if let Some(w) = &read.widths {
                groom
                    .widths
                    .get_or_insert_with(Vec::new)
                    .extend(w[range.clone()].iter().map(|w| w * f.scale as f32));
            }
            if let Some(o) = &read.opacities {
                groom
                    .opacities
                    .get_or_insert_with(Vec::new)
                    .extend_from_slice(&o[range.clone()]);
            }
            if let Some(c) = &read.colors {
                groom
                    .colors
                    .get_or_insert_with(Vec::new)
                    .extend_from_slice(&c[range]);
            }
        }
        groom.check(&path.display().to_string())?;
        g.count = take as u32;
        f.groom = Some(std::sync::Arc::new(groom));
    }
    Ok(())
}

/// Remove the strands whose points all coincide, with their attributes.
fn drop_pointless_strands(g: &mut crate::formats::Groom) {
    let mut keep_point = Vec::with_capacity(g.points.len());
    let mut counts = Vec::with_capacity(g.counts.len());
    let mut at = 0usize;
    for &c in &g.counts {
        let pts = &g.points[at..at + c as usize];
        let keep = pts.iter().any(|p| *p != pts[0]);
        keep_point.extend(std::iter::repeat_n(keep, c as usize));
        if keep {
            counts.push(c);
        }
        at += c as usize;
    }
    if counts.len() == g.counts.len() {
        return;
    }
    fn filter<T: Copy>(v: &mut Vec<T>, keep: &[bool]) {
        let mut i = 0;
        v.retain(|_| {
            i += 1;
            keep[i - 1]
        });
    }
    filter(&mut g.points, &keep_point);
    if let Some(w) = g.widths.as_mut() {
        filter(w, &keep_point);
    }
    if let Some(o) = g.opacities.as_mut() {
        filter(o, &keep_point);
    }
    if let Some(c) = g.colors.as_mut() {
        filter(c, &keep_point);
    }
    g.counts = counts;
}

impl Roots {
    /// Largest zenith (degrees) allowed at azimuth `phi_deg` by the hairline, if any.
    pub fn hairline_theta(&self, phi_deg: f64) -> Option<f64> {
        let line = self.hairline.as_ref()?;
        let n = line.len();
        let start = line[0].0;
        let p = start + (phi_deg - start).rem_euclid(360.0);
        for i in 0..n {
            let (a, ta) = line[i];
            let (b, tb) = if i + 1 < n {
                line[i + 1]
            } else {
                (line[0].0 + 360.0, line[0].1)
            };
            if p >= a && p <= b {
                let t = if b > a { (p - a) / (b - a) } else { 0.0 };
                return Some(ta + t * (tb - ta));
            }
        }
        Some(line[n - 1].1)
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EllipsoidDesc {
    pub center: [f64; 3],
    pub radii: [f64; 3],
}

/// The unloaded hair direction at the pore.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Direction {
    /// Along the hull normal: hair "stands radially" (Anjyo Fig. 4a).
    #[default]
    Normal,
    /// The normal blended with a fixed direction: `normalize((1-w) n + w dir)`.
    Blend { dir: [f64; 3], weight: f64 },
}

/// How the cantilever is bent.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Bending {
    /// Anjyo's eqs 1-3: one root-to-tip pass, moments from straight-beam lever arms.
    #[default]
    Paper,
    /// True lever arms from the deformed shape, iterated to a fixed point; converges to the
    /// large-deflection elastica.
    Converged {
        #[serde(default = "default_iterations")]
        max_iterations: u32,
        #[serde(default = "default_tolerance")]
        tolerance: f64,
    },
}

fn default_iterations() -> u32 {
    400
}

fn default_tolerance() -> f64 {
    1e-5
}

/// A combing force per unit length, applied to segments inside all of its regions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Load {
    /// The same force everywhere in the region.
    Uniform {
        force: [f64; 3],
        #[serde(default)]
        region: Vec<Region>,
    },
    /// A force of magnitude `strength` pointing at `point` (tying hair up).
    Toward {
        point: [f64; 3],
        strength: f64,
        #[serde(default)]
        region: Vec<Region>,
    },
}

impl Load {
    pub fn region(&self) -> &[Region] {
        match self {
            Load::Uniform { region, .. } | Load::Toward { region, .. } => region,
        }
    }
}

/// A half-space. `Above(y)` is the paper's "higher than the eyes"; `HalfSpace` the
/// "positive z region" (normal (0,0,1), offset 0).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Region {
    Above(f64),
    Below(f64),
    /// Points with `dot(normal, p) >= offset`.
    HalfSpace {
        normal: [f64; 3],
        offset: f64,
    },
}

impl Region {
    /// (unit normal, offset) with the region being `dot(n, p) >= offset`.
    pub fn plane(&self) -> ([f64; 3], f64) {
        match self {
            Region::Above(y) => ([0.0, 1.0, 0.0], *y),
            Region::Below(y) => ([0.0, -1.0, 0.0], -*y),
            Region::HalfSpace { normal, offset } => {
                let l =
                    (normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]).sqrt();
                ([normal[0] / l, normal[1] / l, normal[2] / l], offset / l)
            }
        }
    }
}

/// Cutting (Anjyo 2.2): for hairs whose pores are in the polar range, segments are hidden
/// from the first node that breaks the rule on (the drawn hair is a prefix of the bent one).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cut {
    /// Pore zenith range (degrees); all when absent.
    #[serde(default)]
    pub theta: Option<(f64, f64)>,
    /// Pore azimuth range (degrees); all when absent.
    #[serde(default)]
    pub phi: Option<(f64, f64)>,
    pub rule: CutRule,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum CutRule {
    /// Hide nodes lower than `y` (the paper's threshold along the vertical).
    Below(f64),
    /// Keep a number of segments that depends on the pore height (Fig. 6d): `low.1` segments
    /// for pores at height `low.0` or below, `high.1` at `high.0` or above, linear between.
    ByPoreHeight { low: (f64, u32), high: (f64, u32) },
    /// Hide nodes closer than `radius` to `center` (hair gathered into a tie).
    Near { center: [f64; 3], radius: f64 },
}

/// Look of a group: Anjyo's eqs 8-9 plus width.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Hair colour (sRGB, 0..1), scaled by the per-strand ambient coefficient.
    #[serde(default = "default_hair")]
    pub color: [f32; 3],
    /// Mean of the ambient coefficient k_a.
    #[serde(default = "one")]
    pub ka: f64,
    /// Standard deviation of k_a between strands (normal distribution, Anjyo 4.1).
    #[serde(default = "default_ka_spread")]
    pub ka_spread: f64,
    /// Specular coefficient k_s.
    #[serde(default = "default_ks")]
    pub ks: f64,
    /// Specular exponent n.
    #[serde(default = "default_shininess")]
    pub shininess: f64,
    /// Diffuse (Kajiya–Kay) coefficient; the paper neglects it (0).
    #[serde(default)]
    pub kd: f64,
    /// Strand width at the root, world units.
    #[serde(default = "default_width")]
    pub width: f64,
    /// Width at the tip relative to the root.
    #[serde(default = "default_tip")]
    pub tip_width: f64,
}

fn default_hair() -> [f32; 3] {
    [0.16, 0.09, 0.05]
}
fn one() -> f64 {
    1.0
}
fn default_ka_spread() -> f64 {
    0.15
}
fn default_ks() -> f64 {
    0.18
}
fn default_shininess() -> f64 {
    150.0
}
fn default_width() -> f64 {
    0.012
}
fn default_tip() -> f64 {
    0.6
}

impl Default for Material {
    fn default() -> Self {
        Material {
            color: default_hair(),
            ka: one(),
            ka_spread: default_ka_spread(),
            ks: default_ks(),
            shininess: default_shininess(),
            kd: 0.0,
            width: default_width(),
            tip_width: default_tip(),
        }
    }
}

/// A perspective camera.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub eye: [f64; 3],
    pub target: [f64; 3],
    #[serde(default = "up")]
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    #[serde(default = "default_fov")]
    pub fov_y: f64,
}

fn up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f64 {
    35.0
}

impl Default for CameraDesc {
    fn default() -> Self {
        CameraDesc {
            eye: [55.0, 12.0, 40.0],
            target: [0.0, 0.0, 0.0],
            up: up(),
            fov_y: default_fov(),
        }
    }
}

/// One directional light plus ambient (Anjyo eq 9: I = I_a k_a + I_s Phi_s).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Light {
    /// Direction towards the light.
    pub direction: [f64; 3],
    /// I_s.
    #[serde(default = "one")]
    pub intensity: f64,
    /// I_a.
    #[serde(default = "default_ambient")]
    pub ambient: f64,
    #[serde(default = "white")]
    pub color: [f32; 3],
}

fn default_ambient() -> f64 {
    0.9
}
fn white() -> [f32; 3] {
    [1.0, 1.0, 1.0]
}

impl Default for Light {
    fn default() -> Self {
        Light {
            direction: [0.6, 0.8, 0.5],
            intensity: one(),
            ambient: default_ambient(),
            color: white(),
        }
    }
}

/// Image settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderSettings {
    /// Default image size (the CLI's `--size` overrides it).
    #[serde(default = "default_size")]
    pub size: (u32, u32),
    /// Background colour (sRGB, 0..1).
    #[serde(default = "default_background")]
    pub background: [f32; 3],
    /// Hardware multisampling: 1 or 4 samples.
    #[serde(default = "default_msaa")]
    pub msaa: u32,
    /// Supersampling factor per axis (1..=4): Anjyo's oversampling, on top of MSAA.
    #[serde(default = "default_supersample")]
    pub supersample: u32,
    /// Narrowest strand drawn, in samples: thinner strands are widened to this and made
    /// transparent in proportion (coverage), so sub-pixel hair stays smooth.
    #[serde(default = "default_min_width")]
    pub min_width: f64,
    /// Screen-space level of detail (`systems::lod`): the chord error allowed, in pixels,
    /// when segments are skipped on a small object; 0 draws every strand and segment at any
    /// size.
    #[serde(default = "default_lod_tolerance_px")]
    pub lod_tolerance_px: f64,
    /// How strand hair (the Anjyo groups) is rasterised.
    #[serde(default)]
    pub strands: StrandRaster,
}

/// How strand hair is rasterised.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum StrandRaster {
    /// Camera-facing ribbons, two triangles per segment, coverage by MSAA sample masks.
    #[default]
    Ribbons,
    /// The compute rasteriser for thin strands (`shaders/anjyo/splat.wgsl`): one step per
    /// sample a segment crosses, analytic coverage, order-independent compositing. Much
    /// cheaper where triangle setup dominates (software adapters); meant for strands at
    /// most a few samples wide.
    Compute,
}

impl StrandRaster {
    /// From its name on a command line (`ribbons` or `compute`).
    pub fn parse(s: &str) -> std::result::Result<StrandRaster, String> {
        match s {
            "ribbons" => Ok(StrandRaster::Ribbons),
            "compute" => Ok(StrandRaster::Compute),
            _ => Err(format!("strands must be ribbons or compute, not {s:?}")),
        }
    }
}

fn default_size() -> (u32, u32) {
    (800, 800)
}
fn default_background() -> [f32; 3] {
    [0.93, 0.93, 0.91]
}
fn default_msaa() -> u32 {
    4
}
fn default_supersample() -> u32 {
    2
}
fn default_min_width() -> f64 {
    1.0
}
fn default_lod_tolerance_px() -> f64 {
    0.5
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            size: default_size(),
            background: default_background(),
            msaa: default_msaa(),
            supersample: default_supersample(),
            min_width: default_min_width(),
            lod_tolerance_px: default_lod_tolerance_px(),
            strands: StrandRaster::default(),
        }
    }
}

impl Scene {
    /// Parse and validate a scene from RON text; `origin` names it in errors.
    pub fn from_ron(text: &str, origin: &str) -> Result<Scene> {
        let scene: Scene = ron_options()
            .from_str(text)
            .map_err(|e| parse_error(e, origin))?;
        validate(&scene).map_err(|e| match e {
            KamiError::Invalid {
                field,
                value,
                allowed,
                ..
            } => KamiError::Invalid {
                file: origin.to_string(),
                field,
                value,
                allowed,
            },
            other => other,
        })?;
        Ok(scene)
    }

    /// `from_ron` on raw bytes: text that is not UTF-8 is refused with the place of the first
    /// bad byte.
    pub fn from_bytes(bytes: &[u8], origin: &str) -> Result<Scene> {
        let text = std::str::from_utf8(bytes).map_err(|e| utf8_error(bytes, e, origin))?;
        Scene::from_ron(text, origin)
    }

    /// A scene showing one strand file (`.hair`, `.obj` polylines, `.usda`): the strands as
    /// one static hair group, over a head ellipsoid fitted under their roots (the file
    /// carries no head; name one in a scene file for collisions that matter), the width
    /// from the file's root widths or 0.4 % of the mean strand length, and a camera that
    /// frames it all. What `kami view groom.hair` and the Files panel open.
    pub fn from_strand_file(path: &Path) -> Result<Scene> {
        let groom = crate::formats::read(path)?;
        let origin = path.display().to_string();
        if groom.counts.is_empty() {
            return Err(KamiError::Data {
                path: origin,
                line: None,
                message: "the file has no strands".into(),
            });
        }
        let n = groom.counts.len();
        let mut roots = Vec::with_capacity(n);
        let mut lengths = Vec::with_capacity(n);
        let mut root_widths = Vec::new();
        let mut at = 0usize;
        for &c in &groom.counts {
            let pts = &groom.points[at..at + c as usize];
            roots.push(glam::DVec3::from(pts[0].map(f64::from)));
            lengths.push(
                pts.windows(2)
                    .map(|w| {
                        (glam::DVec3::from(w[1].map(f64::from))
                            - glam::DVec3::from(w[0].map(f64::from)))
                        .length()
                    })
                    .sum::<f64>(),
            );
            if let Some(w) = &groom.widths {
                root_widths.push(w[at] as f64);
            }
            at += c as usize;
        }
        let mean_len = lengths.iter().sum::<f64>() / n as f64;
        let (lo, hi) = roots.iter().fold(
            (glam::DVec3::splat(f64::MAX), glam::DVec3::splat(f64::MIN)),
            |(lo, hi), r| (lo.min(*r), hi.max(*r)),
        );
        // Roots cover the scalp: the crown at the top, the nape at the bottom. The ellipsoid
        // has its centre at the lowest root's height and sits inside every root.
        let mid = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo)).max(glam::DVec3::splat(1e-3 * mean_len.max(1e-9)));
        let r0 = glam::DVec3::new(half.x, (hi.y - lo.y).max(half.y), half.z);
        let center = [mid.x, lo.y, mid.z];
        // Shrunk until every root is outside it, with a 2 % margin.
        let c0 = glam::DVec3::from(center);
        let k = roots
            .iter()
            .map(|r| ((*r - c0) / r0).length())
            .fold(f64::MAX, f64::min)
            .clamp(1e-3, 1.0);
        let radii = (r0 * 0.98 * k).to_array();
        let mut segs: Vec<u32> = groom.counts.iter().map(|&c| c - 1).collect();
        segs.sort_unstable();
        let segments = segs[segs.len() / 2].clamp(4, MAX_SEGMENTS.min(64));
        let width = if root_widths.is_empty() {
            0.004 * mean_len
        } else {
            root_widths.iter().sum::<f64>() / root_widths.len() as f64
        };
        let reach = roots
            .iter()
            .zip(&lengths)
            .map(|(r, l)| (*r - glam::DVec3::from(center)).length() + l)
            .fold(0.0, f64::max)
            .max(1e-6);
        let c = glam::DVec3::from(center);
        let eye = c + glam::DVec3::new(2.6, 0.6, 1.9).normalize() * reach * 2.3;
        let name = path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut scene = Scene {
            seed: 0,
            head: Head {
                center,
                radii,
                ..Default::default()
            },
            groom_load: default_groom_load(),
            forces: ForcesDesc::default(),
            groups: vec![HairGroup {
                name,
                file: Some(StrandFile {
                    path: origin.clone(),
                    scale: 1.0,
                    rotate: [0.0; 3],
                    translate: [0.0; 3],
                    groom: None,
                }),
                roots: Roots::default(),
                count: (n as u64).min(MAX_STRANDS) as u32,
                segments,
                length: 0.0,
                length_jitter: 0.0,
                direction: Direction::default(),
                direction_jitter: 0.0,
                rigidity: 0.0,
                bending: Bending::default(),
                loads: vec![],
                cuts: vec![],
                material: Material {
                    width,
                    ..Default::default()
                },
                dynamic: true,
            }],
            camera: CameraDesc {
                eye: eye.to_array(),
                target: [c.x, c.y, c.z],
                ..Default::default()
            },
            light: Light::default(),
            render: RenderSettings::default(),
            dynamics: None,
            fur: None,
            wisps: None,
            strips: None,
        };
        validate(&scene).map_err(|e| match e {
            KamiError::Invalid {
                field,
                value,
                allowed,
                ..
            } => KamiError::Invalid {
                file: origin.clone(),
                field,
                value,
                allowed,
            },
            other => other,
        })?;
        // The file is read again through the group, as a scene file naming it would.
        resolve_strand_files(&mut scene, Path::new(""), &origin)?;
        Ok(scene)
    }

    /// Read, parse and validate a scene file; a strand file (`.hair`, `.obj`, `.usda`)
    /// opens as a scene of its own ([`Scene::from_strand_file`]).
    pub fn load(path: impl AsRef<Path>) -> Result<Scene> {
        let path = path.as_ref();
        if crate::formats::Format::of(path).is_some() {
            return Scene::from_strand_file(path);
        }
        let io = |source| KamiError::Io {
            path: path.to_path_buf(),
            source,
        };
        // Reading a directory fails only at the first read, as a bare "Is a directory".
        if std::fs::metadata(path).is_ok_and(|m| m.is_dir()) {
            return Err(io(std::io::Error::new(
                std::io::ErrorKind::IsADirectory,
                "it is a directory, not a scene file",
            )));
        }
        let bytes = std::fs::read(path).map_err(io)?;
        let mut scene = Scene::from_bytes(&bytes, &path.display().to_string())?;
        // The head capture, read now so that errors name its file.
        if let Some(hc) = scene.forces.head_capture.as_mut() {
            bvh::resolve(hc, path.parent().unwrap_or(Path::new(""))).map_err(|e| match e {
                KamiError::Invalid {
                    field,
                    value,
                    allowed,
                    ..
                } => KamiError::Invalid {
                    file: path.display().to_string(),
                    field,
                    value,
                    allowed,
                },
                other => other,
            })?;
        }
        // Strand files the hair groups name, read now so that errors name them.
        resolve_strand_files(
            &mut scene,
            path.parent().unwrap_or(Path::new("")),
            &path.display().to_string(),
        )?;
        // Files the EFF names, read now so that errors name them.
        if let Some(eff) = scene.forces.eff.as_mut() {
            eff::resolve(eff, path.parent().unwrap_or(Path::new("")))?;
        }
        // A head mesh named relative to the scene file.
        if let Some(m) = scene.head.mesh.as_mut().and_then(|h| h.source.file_mut()) {
            let dir = path.parent().unwrap_or(Path::new(""));
            if Path::new(m.as_str()).is_relative() && !dir.as_os_str().is_empty() {
                *m = dir.join(m.as_str()).display().to_string();
            }
        }
        // A fur mesh named relative to the scene file.
        if let Some(m) = scene.fur.as_mut().and_then(|f| f.mesh.file_mut()) {
            let dir = path.parent().unwrap_or(Path::new(""));
            if Path::new(m.as_str()).is_relative() && !dir.as_os_str().is_empty() {
                *m = dir.join(m.as_str()).display().to_string();
            }
        }
        Ok(scene)
    }

    /// Pretty RON, for saving a tuned scene.
    pub fn to_ron(&self) -> String {
        let cfg = ron::ser::PrettyConfig::new()
            .depth_limit(6)
            .struct_names(true);
        ron::ser::to_string_pretty(self, cfg).expect("scene types always serialise")
    }

    /// The head hull as an ellipsoid.
    pub fn head_ellipsoid(&self) -> Ellipsoid {
        Ellipsoid::new(self.head.center, self.head.radii)
    }

    /// Total hairs and segments over all groups, plus the fur at full density (its count is
    /// rounded per triangle when groomed, so it is approximate).
    pub fn counts(&self) -> (u64, u64) {
        let hair = self.groups.iter().fold((0, 0), |(h, s), g| {
            (h + g.count as u64, s + g.count as u64 * g.segments as u64)
        });
        match &self.fur {
            None => hair,
            Some(f) => {
                let share: f64 = f.coats.iter().map(|c| c.share).sum();
                let segs: f64 = f
                    .coats
                    .iter()
                    .map(|c| f.hairs as f64 * c.share / share * c.style.segments() as f64)
                    .sum();
                (hair.0 + f.hairs as u64, hair.1 + segs.round() as u64)
            }
        }
    }
}

/// Deepest bracket nesting a scene may use (the deepest real one is about 8).
pub const MAX_NESTING: usize = 64;

/// ron as scenes are read. The nesting limit is set here, not left to ron's default, because
/// deep nesting must stay an error and never become a stack overflow (tests/it/bad_input.rs nests
/// 100,000 deep on a small stack).
fn ron_options() -> ron::Options {
    ron::Options::default().with_recursion_limit(MAX_NESTING)
}

/// A ron error with its place; ron's advice on its recursion limit is for programmers.
fn parse_error(e: ron::error::SpannedError, origin: &str) -> KamiError {
    KamiError::Parse {
        path: origin.to_string(),
        line: e.span.start.line,
        col: e.span.start.col,
        message: match e.code {
            ron::Error::ExceededRecursionLimit => {
                format!("brackets nested deeper than {MAX_NESTING} levels")
            }
            // A field of the old scene format that moved to the `forces` block: say where.
            ron::Error::NoSuchStructField {
                ref found,
                outer: Some(ref outer),
                ..
            } if forces::MOVED
                .iter()
                .any(|(o, f, _)| o == outer && f == found) =>
            {
                let (_, _, why) = forces::MOVED
                    .iter()
                    .find(|(o, f, _)| o == outer && f == found)
                    .expect("just matched");
                why.to_string()
            }
            code => code.to_string(),
        },
    }
}

/// A scene that is not UTF-8: the place of the first bad byte (std says only "stream did not
/// contain valid UTF-8"). Columns count characters, as ron's do.
fn utf8_error(bytes: &[u8], e: std::str::Utf8Error, origin: &str) -> KamiError {
    let at = e.valid_up_to();
    // The prefix is valid by definition.
    let before = std::str::from_utf8(&bytes[..at]).unwrap_or_default();
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    KamiError::Parse {
        path: origin.to_string(),
        line: before.matches('\n').count() + 1,
        col: before[line_start..].chars().count() + 1,
        message: format!(
            "byte 0x{:02x} at byte offset {at} is not valid UTF-8: scene files are UTF-8 text",
            bytes[at]
        ),
    }
}

/// Anjyo's projective dynamics (section 3): each segment's zenith and azimuth follow
/// `theta'' = c_i u_i F_theta`, `phi'' = c_i v_i F_phi`, integrated by the recurrences
/// (4)' and (5)'. Forces are per segment, in the paper's units (Fig. 10 uses |F| = 200 with
/// dt = 0.1, d = rho = 1, k = 18); they come from the scene's `forces` block (gravity, wind,
/// the EFF, head motion), read as `F` = the acceleration (`scene::forces`: units). This
/// block holds only the solver's settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Dynamics {
    /// Time step Delta t of the recurrences.
    #[serde(default = "default_dt")]
    pub dt: f64,
    /// Steps per rendered frame.
    #[serde(default = "one_u32")]
    pub steps_per_frame: u32,
    /// Line density rho (mass per unit length); inertia I_i = rho k^3 d^2 / (3 i).
    #[serde(default = "one")]
    pub density: f64,
    /// Velocity damping rate per unit time: each step keeps exp(-damping h) of the angular
    /// velocity (0 is the paper's undamped recurrence). A rate, so results do not depend on
    /// the step size beyond discretisation error.
    #[serde(default)]
    pub damping: f64,
    #[serde(default)]
    pub inertia: Inertia,
    /// The pseudo-force field (3.2.2); absent means off.
    #[serde(default)]
    pub pseudo_force: Option<PseudoForce>,
    #[serde(default)]
    pub stiffness: Stiffness,
    /// Random fluctuation of "gently blowing" hair (3.2.3); absent means off.
    #[serde(default)]
    pub fluctuation: Option<Fluctuation>,
    /// Hard collision: after each step a node inside the head is moved out as in grooming.
    /// Our addition to the paper (whose pseudo-force only discourages penetration).
    #[serde(default = "yes")]
    pub collision: bool,
    /// Most substeps per step the solver may take to stay stable; beyond that it clamps the
    /// angular velocity and warns.
    #[serde(default = "default_max_substeps")]
    pub max_substeps: u32,
    /// Guides and followers: the share in (0, 1] of each dynamic group's strands that the
    /// projective solver simulates (the guides, spread over the scalp); every other strand
    /// follows its nearest guides (`systems::anjyo::follow`). Absent: every strand simulated.
    #[serde(default)]
    pub guides: Option<f64>,
}

impl Default for Dynamics {
    fn default() -> Self {
        Dynamics {
            dt: default_dt(),
            steps_per_frame: 1,
            density: 1.0,
            damping: 0.0,
            inertia: Inertia::default(),
            pseudo_force: None,
            stiffness: Stiffness::default(),
            fluctuation: None,
            collision: true,
            max_substeps: default_max_substeps(),
            guides: None,
        }
    }
}

fn default_dt() -> f64 {
    0.1
}
fn one_u32() -> u32 {
    1
}
fn default_max_substeps() -> u32 {
    64
}

/// Inertia arrangement (3.2.1): c_i = 1/I_i scaled along the strand (`root` at the pore to
/// `tip`, linear) and across the scalp (`top` for pores at `top_height` and above, 1 below
/// `top_height - top_blend`: the paper's rough friction near the top of the head).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Inertia {
    #[serde(default = "one")]
    pub root: f64,
    #[serde(default = "one")]
    pub tip: f64,
    #[serde(default = "one")]
    pub top: f64,
    #[serde(default)]
    pub top_height: f64,
    #[serde(default = "default_top_blend")]
    pub top_blend: f64,
}

fn default_top_blend() -> f64 {
    4.0
}

impl Default for Inertia {
    fn default() -> Self {
        Inertia {
            root: 1.0,
            tip: 1.0,
            top: 1.0,
            top_height: 0.0,
            top_blend: default_top_blend(),
        }
    }
}

/// Pseudo-force (3.2.2): a segment within `near` of the head whose force points into it
/// (`(D, F) < alpha |D| |F|`, D the hull gradient) feels `epsilon_i F`, epsilon rising
/// linearly from `epsilon_pore` at the root to `epsilon_tip` at the tip.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PseudoForce {
    pub alpha: f64,
    pub epsilon_pore: f64,
    #[serde(default = "one")]
    pub epsilon_tip: f64,
    /// Distance from the head (world units) under which a segment is "near the head".
    pub near: f64,
}

/// Joint-angle stiffness (3.2.3): the bend at node i is limited to sigma_i degrees
/// (180 = free). sigma is `root` up to `start` (fraction of the strand), falls linearly to
/// `tip` at `end`, and stays there: the paper keeps 180 degrees near the pore and 10-15
/// degrees "for the nodes far from a pore", so the small value must hold over most of the
/// strand, not only at its tip.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stiffness {
    #[serde(default = "free_angle")]
    pub root: f64,
    #[serde(default = "free_angle")]
    pub tip: f64,
    #[serde(default)]
    pub start: f64,
    /// Where sigma reaches `tip` (fraction; default 1, the tip).
    #[serde(default = "one")]
    pub end: f64,
}

fn free_angle() -> f64 {
    180.0
}

impl Default for Stiffness {
    fn default() -> Self {
        Stiffness {
            root: 180.0,
            tip: 180.0,
            start: 0.0,
            end: 1.0,
        }
    }
}

impl Stiffness {
    /// sigma (degrees) at fraction `t` along the strand.
    pub fn sigma_at(&self, t: f64) -> f64 {
        if t <= self.start {
            self.root
        } else {
            let u = ((t - self.start) / (self.end - self.start).max(1e-9)).clamp(0.0, 1.0);
            self.root + (self.tip - self.root) * u
        }
    }
}

/// "Gently blowing" fluctuation (3.2.3): every `period` frames each strand's segment angles
/// get a uniform random kick of up to `amplitude` degrees (scaled by position along the
/// strand), seeded from the scene seed so runs repeat.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fluctuation {
    pub amplitude: f64,
    #[serde(default = "ten")]
    pub period: u32,
}

fn ten() -> u32 {
    10
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scene types bound their own nesting, so ron's limit is reached only through
    /// untyped values: parse one to see the limit hold and the message name it.
    #[test]
    fn the_nesting_limit_is_a_parse_error_with_a_plain_message() {
        let deep = "[".repeat(100_000);
        let e = ron_options().from_str::<ron::Value>(&deep).unwrap_err();
        match parse_error(e, "deep.ron") {
            KamiError::Parse {
                path,
                line,
                col,
                message,
            } => {
                assert_eq!((path.as_str(), line), ("deep.ron", 1));
                assert!(col > 1 && col <= MAX_NESTING + 2, "{col}: {message}");
                assert!(message.contains("nested deeper than 64"), "{message}");
            }
            other => panic!("expected a parse error, got {other:?}"),
        }
    }
}
