//! Fur on a triangle mesh (Van Gelder & Wilhelms): its scene block (`fur`), its checks
//! (`validate`) and its file (`read_files`). Roots are dispersed over the mesh by area with
//! random rounding, each coat (overcoat, undercoat) with its own share, length, stiffness,
//! randomness, style and material; hairs are generated on the GPU every frame from the root
//! table, so a moving mesh carries its fur.

use crate::error::Result;
use crate::scene::validate::*;
use crate::scene::MeshSource;
use crate::systems::scene::Scene;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The fur kind's block of the scene: its one field of the scene file (listed in the
/// registry's `kinds!`), read through `Scene::fur`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FurBlock {
    /// Fur on a triangle mesh (Van Gelder & Wilhelms); absent in scenes without it.
    pub fur: Option<Fur>,
}

impl Scene {
    /// The fur block (`None` in scenes without it).
    pub fn fur(&self) -> &Option<Fur> {
        &self.block::<FurBlock>().fur
    }
    pub fn fur_mut(&mut self) -> &mut Option<Fur> {
        &mut self.block_mut::<FurBlock>().fur
    }
}

/// Fur of one mesh.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fur {
    pub mesh: MeshSource,
    /// Scale and centre the mesh so its bounding sphere has this radius (meshes come in
    /// any unit); absent keeps the file's coordinates.
    #[serde(default)]
    pub size: Option<f64>,
    /// Hairs over the whole mesh at full density (N in the paper), summed over the coats.
    pub hairs: u32,
    /// Hair length (world units) before per-region and per-coat scaling.
    pub length: f64,
    /// Selected regions (spheres) with their own length scale and direction vector: the
    /// product of the length scales of the regions containing a vertex applies there, and
    /// the direction of the last one listed that has one; both are interpolated over
    /// triangles.
    #[serde(default)]
    pub regions: Vec<Region>,
    /// The body-segment direction vector (3.4) where no region sets one, blended with the
    /// skin normal by each coat's `direction_weight`.
    #[serde(default = "back")]
    pub direction: [f64; 3],
    /// Up, for gravity (3.5: the paper's Z).
    #[serde(default = "up")]
    pub up: [f64; 3],
    pub coats: Vec<Coat>,
    /// Distance-based culling (3.3).
    #[serde(default)]
    pub culling: Culling,
    /// A simple animated deformation of the mesh (the fur follows it).
    #[serde(default)]
    pub motion: Option<MeshMotion>,
    /// Skin colour (sRGB).
    #[serde(default = "skin")]
    pub skin: [f32; 3],
}

impl Fur {
    /// Whether the fur moves from frame to frame (a mesh motion or an animated glTF skin).
    pub fn moves(&self) -> bool {
        self.motion.is_some() || matches!(self.mesh, MeshSource::Gltf { .. })
    }
}

fn back() -> [f64; 3] {
    [-1.0, 0.0, 0.0]
}
fn up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn skin() -> [f32; 3] {
    [0.45, 0.33, 0.25]
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    pub center: [f64; 3],
    pub radius: f64,
    /// Hair length scale inside the region.
    #[serde(default = "one")]
    pub length_scale: f64,
    /// The body-segment direction inside the region (for instance down the legs).
    #[serde(default)]
    pub direction: Option<[f64; 3]>,
}

/// One coat (3.1): its share of the hairs and how they look.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Coat {
    #[serde(default)]
    pub name: String,
    /// Share of the hairs in this coat (the coats' shares are normalised).
    pub share: f64,
    /// Length relative to the fur length.
    #[serde(default = "one")]
    pub relative_length: f64,
    /// Stiffness in [0, 1]; floppiness = max(1 - stiffness, 0.02) (3.5).
    pub stiffness: f64,
    /// Random rotation of the shading normals about their segment, as a share of 180
    /// degrees (Figure 2's "Normal Randomize").
    #[serde(default)]
    pub normal_randomize: f64,
    /// Random displacement of the weightless end point, as a share of the length
    /// (Figure 2's "Hair End Randomize").
    #[serde(default)]
    pub end_randomize: f64,
    /// Weight of the body-segment direction against the skin normal (Figure 2's "Segment
    /// Direction Wt").
    #[serde(default)]
    pub direction_weight: f64,
    #[serde(default)]
    pub style: FurStyle,
    #[serde(default)]
    pub material: FurMaterial,
}

fn one() -> f64 {
    1.0
}

/// How a hair is drawn (3.6-3.8).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum FurStyle {
    /// A straight line from root to end, shaded with the skin normal.
    Line,
    /// Eight control points in the hair plane, a shading normal per segment.
    #[default]
    Polyline,
    /// A cubic Bezier curve, tessellated on the GPU, shaded with the skin normal.
    Curve,
    /// A narrow tube around the curve, with surface normals.
    Tube,
}

impl FurStyle {
    /// Segments per hair.
    pub fn segments(self) -> u32 {
        match self {
            FurStyle::Line => 1,
            FurStyle::Polyline => 7,
            FurStyle::Curve | FurStyle::Tube => CURVE_SEGMENTS,
        }
    }
}

/// Tessellation of the Bezier styles.
pub const CURVE_SEGMENTS: u32 = 12;

/// Figure 2's material: ambient, diffuse and specular RGB and shininess, plus width.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FurMaterial {
    pub ambient: [f32; 3],
    pub diffuse: [f32; 3],
    pub specular: [f32; 3],
    pub shininess: f64,
    /// Hair width (world units) at the root; the tip is half as wide.
    #[serde(default = "width")]
    pub width: f64,
    /// This coat's shading; unset follows the scene's `render.shading`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shading: Option<crate::scene::Shading>,
    /// The physical mode's look (`docs/shading.md`); without melanin the pigments are fit
    /// to `diffuse`.
    #[serde(
        default,
        skip_serializing_if = "crate::systems::hair_bsdf::Physical::is_default"
    )]
    pub physical: crate::systems::hair_bsdf::Physical,
}

fn width() -> f64 {
    0.004
}

impl Default for FurMaterial {
    /// Figure 2, Figure 8 column.
    fn default() -> Self {
        FurMaterial {
            ambient: [0.3, 0.14, 0.0],
            diffuse: [0.3, 0.14, 0.0],
            specular: [0.6, 0.6, 0.6],
            shininess: 16.0,
            width: width(),
            shading: None,
            physical: Default::default(),
        }
    }
}

/// Distance-based culling (3.3): beyond `full_distance` (by default, the distance at which
/// the model fills the view) the hairs drawn per triangle fall as 1/distance, with random
/// rounding, taken in creation order; widths grow to keep the coat's coverage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Culling {
    #[serde(default = "yes")]
    pub enabled: bool,
    #[serde(default)]
    pub full_distance: Option<f64>,
}

fn yes() -> bool {
    true
}

impl Default for Culling {
    fn default() -> Self {
        Culling {
            enabled: true,
            full_distance: None,
        }
    }
}

/// A travelling wave along `axis`, displacing the mesh along `direction`: the fur rides it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshMotion {
    pub amplitude: f64,
    pub wavelength: f64,
    /// Frames per wave period.
    pub period: f64,
    #[serde(default = "x_axis")]
    pub axis: [f64; 3],
    #[serde(default = "up")]
    pub direction: [f64; 3],
}

fn x_axis() -> [f64; 3] {
    [1.0, 0.0, 0.0]
}

/// Hairs and segments of the fur at full density (its count is rounded per triangle when
/// groomed, so this is approximate).
pub fn counts(s: &Scene) -> (u64, u64) {
    let Some(f) = s.fur() else { return (0, 0) };
    let share: f64 = f.coats.iter().map(|c| c.share).sum();
    let segs: f64 = f
        .coats
        .iter()
        .map(|c| f.hairs as f64 * c.share / share * c.style.segments() as f64)
        .sum();
    (f.hairs as u64, segs.round() as u64)
}

/// Check the fur block, if the scene has one.
pub fn validate(s: &Scene) -> Result<()> {
    match s.fur() {
        Some(f) => validate_fur(f),
        None => Ok(()),
    }
}

/// The fur mesh's file, taken from the scene file's folder `dir` when relative.
pub fn read_files(s: &mut Scene, dir: &Path, _origin: &str) -> Result<()> {
    if let Some(m) = s.fur_mut().as_mut().and_then(|f| f.mesh.file_mut()) {
        crate::scene::relative_to(dir, m);
    }
    Ok(())
}

/// The fur mesh's file, as `read_files` resolved it.
pub fn files(s: &Scene, _dir: &Path) -> Vec<std::path::PathBuf> {
    s.fur()
        .iter()
        .filter_map(|f| f.mesh.file())
        .map(std::path::PathBuf::from)
        .collect()
}

/// Most fur regions: each vertex is tested against every region.
const MAX_FUR_REGIONS: usize = 64;

fn validate_fur(f: &Fur) -> Result<()> {
    mesh_source("fur.mesh", &f.mesh, "lion-head.off")?;
    if let Some(size) = f.size {
        positive("fur.size", size, BIG)?;
    }
    // Above the scene's strand cap the total check would blame the hair groups instead.
    if f.hairs == 0 || u64::from(f.hairs) > MAX_STRANDS {
        return Err(bad(
            "fur.hairs",
            f.hairs,
            &format!("must be in [1, {MAX_STRANDS}]"),
        ));
    }
    positive("fur.length", f.length, BIG)?;
    if f.regions.len() > MAX_FUR_REGIONS {
        return Err(bad(
            "fur.regions",
            f.regions.len(),
            &format!("at most {MAX_FUR_REGIONS} regions"),
        ));
    }
    for (i, r) in f.regions.iter().enumerate() {
        vec3(&format!("fur.regions[{i}].center"), r.center, BIG)?;
        positive(&format!("fur.regions[{i}].radius"), r.radius, BIG)?;
        within(
            &format!("fur.regions[{i}].length_scale"),
            r.length_scale,
            0.0,
            100.0,
        )?;
        if let Some(d) = r.direction {
            nonzero(&format!("fur.regions[{i}].direction"), d)?;
        }
    }
    nonzero("fur.direction", f.direction)?;
    nonzero("fur.up", f.up)?;
    if f.coats.is_empty() || f.coats.len() > 4 {
        return Err(bad("fur.coats", f.coats.len(), "needs 1 to 4 coats"));
    }
    for (i, c) in f.coats.iter().enumerate() {
        let p = format!("fur.coats[{i}]");
        positive(&format!("{p}.share"), c.share, 1e6)?;
        positive(&format!("{p}.relative_length"), c.relative_length, 100.0)?;
        within(&format!("{p}.stiffness"), c.stiffness, 0.0, 1.0)?;
        within(
            &format!("{p}.normal_randomize"),
            c.normal_randomize,
            0.0,
            1.0,
        )?;
        within(&format!("{p}.end_randomize"), c.end_randomize, 0.0, 2.0)?;
        within(
            &format!("{p}.direction_weight"),
            c.direction_weight,
            0.0,
            1.0,
        )?;
        let m = &c.material;
        color(&format!("{p}.material.ambient"), m.ambient, 10.0)?;
        color(&format!("{p}.material.diffuse"), m.diffuse, 10.0)?;
        color(&format!("{p}.material.specular"), m.specular, 10.0)?;
        within(
            &format!("{p}.material.shininess"),
            m.shininess,
            0.0,
            10000.0,
        )?;
        positive(&format!("{p}.material.width"), m.width, BIG)?;
        m.physical.validate(&format!("{p}.material.physical"))?;
    }
    // Overlapping regions multiply their length scales: bound the longest hair that can
    // result, or it overflows f32 on the GPU (64 regions of scale 100 alone give 1e128).
    let grow: f64 = f.regions.iter().map(|r| r.length_scale.max(1.0)).product();
    let coat_len = f
        .coats
        .iter()
        .map(|c| c.relative_length)
        .fold(0.0, f64::max);
    let longest = f.length * grow * coat_len;
    if longest > BIG {
        return Err(bad(
            "fur.regions",
            format!("a longest hair of {longest:e}"),
            &format!(
                "fur.length x the regions' length_scale (multiplied where they overlap) x the \
                 largest coat relative_length must be at most {BIG:e}"
            ),
        ));
    }
    if let Some(d) = f.culling.full_distance {
        positive("fur.culling.full_distance", d, BIG)?;
    }
    if let Some(m) = &f.motion {
        within("fur.motion.amplitude", m.amplitude, -BIG, BIG)?;
        // The GPU gets 2 pi / wavelength as f32: below ~1e-38 that is infinite.
        within("fur.motion.wavelength", m.wavelength, 1e-6, BIG)?;
        positive("fur.motion.period", m.period, 1e9)?;
        nonzero("fur.motion.axis", m.axis)?;
        nonzero("fur.motion.direction", m.direction)?;
    }
    color("fur.skin", f.skin, 1.0)?;
    Ok(())
}
