//! Fur on a triangle mesh (Van Gelder & Wilhelms): the scene part. Roots are dispersed over
//! the mesh by area with random rounding, each coat (overcoat, undercoat) with its own share,
//! length, stiffness, randomness, style and material; hairs are generated on the GPU every
//! frame from the root table, so a moving mesh carries its fur.

use serde::{Deserialize, Serialize};

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
pub enum MeshSource {
    /// Kami's own furry critter (no download needed).
    Critter,
    /// An OBJ, OFF or PLY file; a relative path is taken from the scene file's folder.
    File(String),
    /// A mesh of the CGAL demo data in Debian's `libcgal-demo` (e.g. "lion-head.off"),
    /// extracted on first use into the system's temporary folder.
    CgalDemo(String),
    /// A skinned, animated glTF 2.0 mesh (`.gltf` or `.glb`; relative to the scene file's
    /// folder): the first node with a mesh and a skin, posed by `animation` (by name; absent:
    /// the file's first one) with linear blend skinning, looping. Scene frames are
    /// converted to seconds by `fps`. See docs/fur_skinned.md.
    Gltf {
        file: String,
        #[serde(default)]
        animation: Option<String>,
        #[serde(default = "fps")]
        fps: f64,
    },
}

fn fps() -> f64 {
    24.0
}

impl MeshSource {
    /// The file named relative to the scene file, if the source is a file.
    pub fn file_mut(&mut self) -> Option<&mut String> {
        match self {
            MeshSource::File(f) | MeshSource::Gltf { file: f, .. } => Some(f),
            _ => None,
        }
    }
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
