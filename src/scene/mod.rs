//! What every scene shares, whatever hair it shows: the head (an ellipsoid or a mesh), the
//! world's forces (`forces`: gravity, wind, the EFF, head motion), the camera, the light and
//! the render settings, with their checks (`validate`) and the reading of RON text (`parse`)
//! and of the files those blocks name (`read_shared_files`). Each kind of hair keeps its own
//! block and its checks in its folder (`systems/<kind>/block.rs`); `systems::Scene` composes
//! the file from these shared parts and the kinds' blocks. This module imports no solver, no
//! GPU and no kind (`tests/it/layers.rs`).
//!
//! Every struct and struct variant denies unknown fields: a misspelt optional field is an
//! error, not silently its default. Checks name the field (`head.radii[1]`), the value and
//! what is allowed; the scene's loader adds the file.
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
pub(crate) mod head;
pub mod hull;
pub mod mesh;
pub mod sdf;
pub mod skinned;
pub mod validate;

pub use eff::Sampling;
pub use forces::{ForcesDesc, HeadKey, Interp, WindKey};
pub use head::Ellipsoid;
pub use mesh::MeshSource;
pub use validate::{MAX_SEGMENTS, MAX_SIZE, MAX_STRANDS};

use crate::error::{KamiError, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

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
    pub source: MeshSource,
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
    #[serde(default = "one_f64")]
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
            intensity: one_f64(),
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
    /// How thin strands (Anjyo's groups, fur's line, polyline and curve coats) are
    /// rasterised.
    #[serde(default)]
    pub strands: StrandRaster,
    /// How hair is shaded where a group does not choose (`docs/shading.md`).
    #[serde(default, skip_serializing_if = "Shading::is_anjyo")]
    pub shading: Shading,
    /// Hair shadows from the key light (`stage::shadow`, docs/shadows.md).
    #[serde(default)]
    pub shadows: Shadows,
}

/// How hair is shaded: per scene (`render.shading`), per group (each kind's look).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Shading {
    /// Anjyo et al. 1992's eqs 8-9 (the paper scenes' look).
    #[default]
    Anjyo,
    /// Chiang et al. 2016's hair BSDF with dual scattering (`systems::hair_bsdf`).
    Physical,
}

impl Shading {
    /// From its name on a command line (`anjyo` or `physical`).
    pub fn parse(s: &str) -> std::result::Result<Shading, String> {
        match s {
            "anjyo" => Ok(Shading::Anjyo),
            "physical" => Ok(Shading::Physical),
            _ => Err(format!("shading must be anjyo or physical, not {s:?}")),
        }
    }

    pub fn is_anjyo(&self) -> bool {
        *self == Shading::Anjyo
    }
}

/// Hair shadows: every system's strands cast into one light-space structure each frame;
/// hair, the head and fur skins read from it how many strands lie between them and the
/// light (docs/shadows.md).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Shadows {
    #[serde(default = "yes")]
    pub on: bool,
    #[serde(default)]
    pub method: ShadowMethod,
    /// Extinction per strand crossed: the direct light is scaled by exp(-absorption * n),
    /// n the expected number of strands between a point and the light (0 lets every strand
    /// through, 0.5 passes about 61 % per strand, as a light-coloured strand does).
    #[serde(default = "default_absorption")]
    pub absorption: f64,
    /// How far towards the light, in volume cells (the box's size / 64), a point on a strand
    /// of layered hair (Anjyo's strands) reads the structure; None: the method's own
    /// (`stage::shadow::layered_offset`: 2 for the volume, 1 for deep opacity, chosen
    /// against the path tracer). 0 reads at the point, and the lit outer layer comes out
    /// shadowed by its own smoothing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layered_offset: Option<f64>,
}

fn default_absorption() -> f64 {
    0.5
}

impl Default for Shadows {
    fn default() -> Self {
        Shadows {
            on: true,
            method: ShadowMethod::default(),
            absorption: default_absorption(),
            layered_offset: None,
        }
    }
}

/// How the strands' shadow is stored (both measured by `kami bench shadows`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum ShadowMethod {
    /// A light-aligned density volume (64^3): strands voxelised, then summed along the
    /// light (as Unreal's groom and Unity's hair do).
    #[default]
    Volume,
    /// Deep opacity maps (Yuksel & Keyser 2008): a light-space first-depth map (256^2),
    /// then 4 opacity layers behind that depth.
    DeepOpacity,
}

impl ShadowMethod {
    /// From its name on a command line (`volume` or `deep`).
    pub fn parse(s: &str) -> std::result::Result<ShadowMethod, String> {
        match s {
            "volume" => Ok(ShadowMethod::Volume),
            "deep" | "deep_opacity" => Ok(ShadowMethod::DeepOpacity),
            _ => Err(format!("shadow method must be volume or deep, not {s:?}")),
        }
    }
}

/// How strand hair is rasterised.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum StrandRaster {
    /// Each kind picks every frame by its strands' width on screen: the compute rasteriser
    /// up to the width `kami bench raster` measured it to be faster and no less accurate,
    /// ribbons past it (`systems::raster`, `docs/raster_switch.ron`).
    #[default]
    Auto,
    /// Camera-facing ribbons, two triangles per segment, coverage by MSAA sample masks.
    Ribbons,
    /// The compute rasteriser for thin strands (`shaders/common/splat.wgsl`): one step per
    /// sample a segment crosses, analytic coverage, order-independent compositing. Much
    /// cheaper where triangle setup dominates (software adapters); meant for strands at
    /// most a few samples wide.
    Compute,
}

impl StrandRaster {
    /// From its name on a command line (`auto`, `ribbons` or `compute`).
    pub fn parse(s: &str) -> std::result::Result<StrandRaster, String> {
        match s {
            "auto" => Ok(StrandRaster::Auto),
            "ribbons" => Ok(StrandRaster::Ribbons),
            "compute" => Ok(StrandRaster::Compute),
            _ => Err(format!(
                "strands must be auto, ribbons or compute, not {s:?}"
            )),
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
            shading: Shading::default(),
            shadows: Shadows::default(),
        }
    }
}

/// Read a scene file's bytes; a directory is refused by name (reading one fails only at the
/// first read, as a bare "Is a directory").
pub fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    let io = |source| KamiError::Io {
        path: path.to_path_buf(),
        source,
    };
    if std::fs::metadata(path).is_ok_and(|m| m.is_dir()) {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::IsADirectory,
            "it is a directory, not a scene file",
        )));
    }
    std::fs::read(path).map_err(io)
}

/// Parse RON bytes as scenes are read (UTF-8 checked with the place of the first bad byte,
/// nesting bounded, moved fields named); `origin` names the file in errors.
pub fn parse<T: serde::de::DeserializeOwned>(bytes: &[u8], origin: &str) -> Result<T> {
    let text = std::str::from_utf8(bytes).map_err(|e| utf8_error(bytes, e, origin))?;
    parse_str(text, origin)
}

/// [`parse`] of text already known to be UTF-8.
pub fn parse_str<T: serde::de::DeserializeOwned>(text: &str, origin: &str) -> Result<T> {
    ron_options()
        .from_str(text)
        .map_err(|e| parse_error(e, origin))
}

/// A check's error, now naming the file it came from (checks name only the field).
pub fn in_file(e: KamiError, origin: &str) -> KamiError {
    match e {
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
    }
}

/// A path a scene names, taken from the scene file's folder `dir` when relative.
pub fn relative_to(dir: &Path, path: &mut String) {
    if Path::new(path.as_str()).is_relative() && !dir.as_os_str().is_empty() {
        *path = dir.join(path.as_str()).display().to_string();
    }
}

/// Read the files the shared blocks name (the head capture, the EFF's files) and resolve
/// the head mesh's path, relative to the scene file's folder `dir`, so that errors name
/// them when the scene loads; `origin` names the scene.
pub fn read_shared_files(
    head: &mut Head,
    forces: &mut ForcesDesc,
    dir: &Path,
    origin: &str,
) -> Result<()> {
    if let Some(hc) = forces.head_capture.as_mut() {
        bvh::resolve(hc, dir).map_err(|e| in_file(e, origin))?;
    }
    if let Some(eff) = forces.eff.as_mut() {
        eff::resolve(eff, dir)?;
    }
    if let Some(m) = head.mesh.as_mut().and_then(|h| h.source.file_mut()) {
        relative_to(dir, m);
    }
    Ok(())
}

/// The files the shared blocks name, as [`read_shared_files`] read them from `dir`: the
/// head capture, the EFF file, the head mesh's file (already resolved there). A system
/// mesh (`CgalDemo`) is not the user's file and is left out.
pub fn shared_files(head: &Head, forces: &ForcesDesc, dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Some(hc) = &forces.head_capture {
        out.push(dir.join(&hc.file));
    }
    if let Some(f) = forces.eff.as_ref().and_then(|e| e.file.as_ref()) {
        out.push(from_dir(dir, f));
    }
    if let Some(m) = head.mesh.as_ref().and_then(|h| h.source.file()) {
        out.push(PathBuf::from(m));
    }
    out
}

/// `path` as a scene file in `dir` names it: taken from `dir` when relative.
pub fn from_dir(dir: &Path, path: &str) -> PathBuf {
    if Path::new(path).is_relative() {
        dir.join(path)
    } else {
        PathBuf::from(path)
    }
}

/// A shipped scene or the folder of them (a bench's default input, the file behind the
/// viewer's built-in scene), named by its path in the repository, e.g.
/// `assets/scenes/gust.ron`: that path when it exists from the working directory (run from
/// a checkout: the reports name it as before), else the same path
/// under the folder Kami was built from (a `kami` installed with `cargo install --path`,
/// run from anywhere; `--help` shows the path in use). Nothing is embedded, unlike the
/// viewer's default scene: the scenes name their EFF, mesh and capture files relative to
/// themselves, and `bench backends` and `bench fur` read a whole folder, so they are read
/// where they lie. A path given on the command line is the user's and is never searched
/// for: only defaults go through here.
pub fn shipped(path: &str) -> PathBuf {
    shipped_from(Path::new(""), path)
}

/// `shipped` seen from the working directory `cwd`: a relative answer is relative to it.
pub fn shipped_from(cwd: &Path, path: &str) -> PathBuf {
    if cwd.join(path).exists() {
        PathBuf::from(path)
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
    }
}

/// Deepest bracket nesting a scene may use (the deepest real one is about 8).
pub const MAX_NESTING: usize = 64;

/// ron as scenes are read. The nesting limit is set here, not left to ron's default, because
/// deep nesting must stay an error and never become a stack overflow (tests/it/bad_input.rs nests
/// 100,000 deep on a small stack).
pub fn ron_options() -> ron::Options {
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
