//! Anjyo's scene block: the hair groups (`groups`: pores, lengths, bending, loads, cuts,
//! material, or strands read from a file), the load the groom is styled under
//! (`groom_load`) and the dynamics' solver settings (`dynamics`), with their checks and
//! the reading of the strand files the groups name. These three fields sit at the scene's
//! top level, as they did before there were other kinds.

use crate::error::{KamiError, Result};
use crate::scene::placement;
use crate::scene::validate::*;
use crate::systems::scene::Scene;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Anjyo's block of the scene: the three fields it adds to the scene file's top level
/// (listed in the registry's `kinds!`), read through `Scene::groups` and its siblings.
#[derive(Clone, Debug, PartialEq)]
pub struct AnjyoBlock {
    /// The load the groom is styled under: the hair's weight per unit length, in the units
    /// of `rigidity` (a setting of the groom, not a force of the world: hair in motion falls
    /// under `forces.gravity`).
    pub groom_load: [f64; 3],
    /// The hair groups; empty when the scene shows only other kinds.
    pub groups: Vec<HairGroup>,
    /// Hair in motion (Anjyo section 3). Absent: the groom is static and no simulation
    /// buffers or passes are built.
    pub dynamics: Option<Dynamics>,
}

impl Default for AnjyoBlock {
    fn default() -> Self {
        AnjyoBlock {
            groom_load: default_groom_load(),
            groups: Vec::new(),
            dynamics: None,
        }
    }
}

impl Scene {
    /// Anjyo's block.
    pub fn anjyo(&self) -> &AnjyoBlock {
        self.block()
    }
    pub fn anjyo_mut(&mut self) -> &mut AnjyoBlock {
        self.block_mut()
    }
    /// Anjyo's hair groups.
    pub fn groups(&self) -> &Vec<HairGroup> {
        &self.anjyo().groups
    }
    pub fn groups_mut(&mut self) -> &mut Vec<HairGroup> {
        &mut self.anjyo_mut().groups
    }
    /// Anjyo's dynamics (`None`: a static groom).
    pub fn dynamics(&self) -> &Option<Dynamics> {
        &self.anjyo().dynamics
    }
    pub fn dynamics_mut(&mut self) -> &mut Option<Dynamics> {
        &mut self.anjyo_mut().dynamics
    }
    /// The load Anjyo's groom is styled under.
    pub fn groom_load(&self) -> &[f64; 3] {
        &self.anjyo().groom_load
    }
    pub fn groom_load_mut(&mut self) -> &mut [f64; 3] {
        &mut self.anjyo_mut().groom_load
    }
}

/// The default `groom_load`: unit weight straight down.
pub fn default_groom_load() -> [f64; 3] {
    [0.0, -1.0, 0.0]
}

fn one_f64() -> f64 {
    1.0
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
    /// Draw the file's colours and opacities where it has them (false: the group's
    /// material colour, opaque).
    #[serde(default = "yes")]
    pub colors: bool,
    /// Draw the file's widths where it has them (false: the material's tapered width).
    #[serde(default = "yes")]
    pub widths: bool,
    /// For an Alembic archive or an animated USD file: the time in seconds whose sample
    /// is the groom (the nearest Alembic sample; USD's value at that time); the first
    /// sample without it. A file read at a time holds still.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time: Option<f64>,
    /// Play the file's frames when it has several (a simulation cache: USD time samples,
    /// Alembic samples), looping, at the file's rate; false holds the first (or `time`'s).
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub play: bool,
    /// Only the strands of this group id (Unreal's `groom_group_id`); all without it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub group_id: Option<i64>,
    /// The strands as read, placed (filled by `Scene::load` or [`resolve_strand_files`]).
    #[serde(skip)]
    pub groom: Option<std::sync::Arc<crate::formats::Groom>>,
    /// The file's frames when it plays them, the same strands as `groom`, placed.
    #[serde(skip)]
    pub frames: Option<std::sync::Arc<crate::formats::Frames>>,
}

fn is_true(b: &bool) -> bool {
    *b
}

impl StrandFile {
    /// The placement as a matrix: scale, then rotate x, y, z, then translate.
    pub fn transform(&self) -> glam::DMat4 {
        placement(self.scale, self.rotate, self.translate)
    }
}

/// Read the strand files the scene's hair groups name (relative paths from `dir`), place
/// them and keep at most `count` strands of each, spread evenly; `count` becomes the number
/// taken. `origin` names the scene in errors.
pub fn resolve_strand_files(scene: &mut Scene, dir: &Path, origin: &str) -> Result<()> {
    for (gi, g) in scene.groups_mut().iter_mut().enumerate() {
        let Some(f) = g.file.as_mut() else { continue };
        let path = if Path::new(&f.path).is_relative() && !dir.as_os_str().is_empty() {
            dir.join(&f.path)
        } else {
            Path::new(&f.path).to_path_buf()
        };
        // Cubic curves become the polylines they describe; the group resamples those.
        let mut read = crate::formats::read_at(&path, f.time)?.into_linear();
        let mut frames = if f.play && f.time.is_none() {
            crate::formats::read_frames(&path, crate::formats::FRAMES_BUDGET)?
        } else {
            None
        };
        if let Some(fr) = frames.as_mut() {
            if fr.counts != read.counts {
                return Err(KamiError::Data {
                    path: path.display().to_string(),
                    line: None,
                    message: "the curves of the first frame differ from the groom's".into(),
                });
            }
            // The groom is the first frame (its looks stay the file's).
            read.points = fr.points[0].clone();
        }
        // Strands with no length (every point the same) cannot be hair: left out, said.
        let before = read.counts.len();
        if let Some(keep) = drop_pointless_strands(&mut read) {
            if let Some(fr) = frames.as_mut() {
                for pts in fr.points.iter_mut() {
                    let mut i = 0;
                    pts.retain(|_| {
                        i += 1;
                        keep[i - 1]
                    });
                }
                fr.counts = read.counts.clone();
            }
        }
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
        let selected =
            select_strands(&read, f.group_id, g.count as usize).map_err(|m| KamiError::Data {
                path: path.display().to_string(),
                line: None,
                message: m,
            })?;
        let take = selected.len();
        let m = f.transform();
        let mut groom = crate::formats::Groom::default();
        let mut starts = Vec::with_capacity(n + 1);
        let mut acc = 0usize;
        for &c in &read.counts {
            starts.push(acc);
            acc += c as usize;
        }
        fn pick<T: Copy>(v: &Option<Vec<T>>, selected: &[usize]) -> Option<Vec<T>> {
            v.as_ref().map(|v| selected.iter().map(|&i| v[i]).collect())
        }
        groom.group_ids = pick(&read.group_ids, &selected);
        groom.guides = pick(&read.guides, &selected);
        groom.root_uvs = pick(&read.root_uvs, &selected);
        for &i in &selected {
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
        // The frames: the same strands, placed the same way.
        f.frames = frames.map(|fr| {
            let points = fr
                .points
                .iter()
                .map(|pts| {
                    let mut out = Vec::with_capacity(groom.points.len());
                    for &i in &selected {
                        let range = starts[i]..starts[i] + read.counts[i] as usize;
                        out.extend(pts[range].iter().map(|p| {
                            let q = m.transform_point3(glam::DVec3::new(
                                p[0] as f64,
                                p[1] as f64,
                                p[2] as f64,
                            ));
                            [q.x as f32, q.y as f32, q.z as f32]
                        }));
                    }
                    out
                })
                .collect();
            std::sync::Arc::new(crate::formats::Frames {
                counts: groom.counts.clone(),
                points,
                ..fr
            })
        });
        g.count = take as u32;
        f.groom = Some(std::sync::Arc::new(groom));
    }
    Ok(())
}

/// Which strands of `read` a group takes: those of `group_id` (all without one), at most
/// `count` of them spread evenly over the file's order; every guide is kept (they are few
/// and the others follow them) and the count thins the rest. Indices in file order.
pub fn select_strands(
    read: &crate::formats::Groom,
    group_id: Option<i64>,
    count: usize,
) -> std::result::Result<Vec<usize>, String> {
    let n = read.counts.len();
    let ids: Vec<usize> = match (group_id, &read.group_ids) {
        (None, _) => (0..n).collect(),
        (Some(id), Some(g)) => (0..n).filter(|&i| g[i] == id).collect(),
        (Some(id), None) => {
            return Err(format!(
                "group_id {id}: the file has no group ids (Unreal's groom_group_id)"
            ))
        }
    };
    if ids.is_empty() {
        let known: std::collections::BTreeSet<i64> =
            read.group_ids.iter().flatten().copied().collect();
        return Err(format!(
            "no strand has group id {} (the file's ids: {known:?})",
            group_id.unwrap_or_default()
        ));
    }
    let guide = |i: usize| read.guides.as_ref().is_some_and(|g| g[i]);
    let (guides, others): (Vec<usize>, Vec<usize>) = ids.iter().partition(|&&i| guide(i));
    if others.is_empty() {
        return Err(format!(
            "every one of the {} strands{} is a guide (groom_guide = 1): nothing to draw",
            guides.len(),
            group_id.map_or(String::new(), |id| format!(" of group id {id}"))
        ));
    }
    let take = count.saturating_sub(guides.len()).clamp(1, others.len());
    let mut out = guides;
    out.extend((0..take).map(|j| others[j * others.len() / take]));
    out.sort_unstable();
    Ok(out)
}

/// Remove the strands whose points all coincide, with their attributes; the points kept
/// (a mask over the old points) when any went.
fn drop_pointless_strands(g: &mut crate::formats::Groom) -> Option<Vec<bool>> {
    let mut keep_point = Vec::with_capacity(g.points.len());
    let mut counts = Vec::with_capacity(g.counts.len());
    let mut keep_strand = Vec::with_capacity(g.counts.len());
    let mut at = 0usize;
    for &c in &g.counts {
        let pts = &g.points[at..at + c as usize];
        let keep = pts.iter().any(|p| *p != pts[0]);
        keep_strand.push(keep);
        keep_point.extend(std::iter::repeat_n(keep, c as usize));
        if keep {
            counts.push(c);
        }
        at += c as usize;
    }
    if counts.len() == g.counts.len() {
        return None;
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
    if let Some(v) = g.group_ids.as_mut() {
        filter(v, &keep_strand);
    }
    if let Some(v) = g.guides.as_mut() {
        filter(v, &keep_strand);
    }
    if let Some(v) = g.root_uvs.as_mut() {
        filter(v, &keep_strand);
    }
    g.counts = counts;
    Some(keep_point)
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
    /// This group's shading; unset follows the scene's `render.shading`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shading: Option<crate::scene::Shading>,
    /// The physical mode's look (melanin, roughness, ...; `docs/shading.md`).
    #[serde(
        default,
        skip_serializing_if = "crate::systems::hair_bsdf::Physical::is_default"
    )]
    pub physical: crate::systems::hair_bsdf::Physical,
    /// How strands differ from one another (`anjyo::vary`); none by default.
    #[serde(default, skip_serializing_if = "Variation::is_none")]
    pub variation: Variation,
}

/// Per-strand variation, as real grooms have it: each strand draws its own pigment amount,
/// width and tint from its seeded random number (`GpuStrand::rand`), so the same scene
/// varies the same way on every run and in the reference the bench hands a path tracer.
/// Each is the standard deviation of the log of a multiplier (0: every strand the group's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Variation {
    /// The strand's absorption (melanin) times exp(melanin z): darker and lighter strands.
    pub melanin: f64,
    /// The strand's width times exp(width z).
    pub width: f64,
    /// The strand's absorption times exp(tint z (-1, 0, 1)): warmer (redder) or cooler.
    pub tint: f64,
}

impl Variation {
    pub fn is_none(&self) -> bool {
        *self == Variation::default()
    }
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
            shading: None,
            physical: Default::default(),
            variation: Variation::default(),
        }
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

/// Read the strand files the hair groups name (`resolve_strand_files`), from the scene
/// file's folder `dir`.
pub fn read_files(s: &mut Scene, dir: &Path, origin: &str) -> Result<()> {
    resolve_strand_files(s, dir, origin)
}

/// The strand files the hair groups read, as `resolve_strand_files` left their paths
/// (absolute when the file was found; else taken from `dir` when relative).
pub fn files(s: &Scene, dir: &Path) -> Vec<std::path::PathBuf> {
    s.groups()
        .iter()
        .filter_map(|g| g.file.as_ref())
        .map(|f| crate::scene::from_dir(dir, &f.path))
        .collect()
}

/// What validation promises of accepted hair groups beyond finite numbers: a hairline gives
/// a finite zenith at every azimuth (the fuzzer checks it, `Kind::invariants`).
pub fn invariants(s: &Scene) -> std::result::Result<(), (&'static str, String)> {
    for g in s.groups() {
        for phi in (-360..=360).step_by(30) {
            if let Some(t) = g.roots.hairline_theta(phi as f64) {
                if !t.is_finite() {
                    return Err((
                        "hairline gives a non-finite theta",
                        format!("hairline gives theta {t} at phi {phi}"),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Check Anjyo's blocks: the groom load, every hair group, the dynamics.
pub fn validate(s: &Scene) -> Result<()> {
    vec3("groom_load", *s.groom_load(), 1e9)?;
    for (gi, g) in s.groups().iter().enumerate() {
        validate_group(&format!("groups[{gi}]"), g)?;
    }
    if let Some(d) = s.dynamics() {
        validate_dynamics(d)?;
    }
    Ok(())
}

fn validate_dynamics(d: &Dynamics) -> Result<()> {
    positive("dynamics.dt", d.dt, 10.0)?;
    if d.steps_per_frame == 0 || d.steps_per_frame > 1000 {
        return Err(bad(
            "dynamics.steps_per_frame",
            d.steps_per_frame,
            "must be in [1, 1000]",
        ));
    }
    positive("dynamics.density", d.density, 1e6)?;
    within("dynamics.damping", d.damping, 0.0, 1e4)?;
    let inr = &d.inertia;
    positive("dynamics.inertia.root", inr.root, 1e6)?;
    positive("dynamics.inertia.tip", inr.tip, 1e6)?;
    positive("dynamics.inertia.top", inr.top, 1e6)?;
    within("dynamics.inertia.top_height", inr.top_height, -BIG, BIG)?;
    positive("dynamics.inertia.top_blend", inr.top_blend, BIG)?;
    if let Some(pf) = &d.pseudo_force {
        within("dynamics.pseudo_force.alpha", pf.alpha, -1.0, 1.0)?;
        within(
            "dynamics.pseudo_force.epsilon_pore",
            pf.epsilon_pore,
            0.0,
            1.0,
        )?;
        within(
            "dynamics.pseudo_force.epsilon_tip",
            pf.epsilon_tip,
            0.0,
            1.0,
        )?;
        within("dynamics.pseudo_force.near", pf.near, 0.0, BIG)?;
    }
    within("dynamics.stiffness.root", d.stiffness.root, 0.0, 180.0)?;
    within("dynamics.stiffness.tip", d.stiffness.tip, 0.0, 180.0)?;
    within("dynamics.stiffness.start", d.stiffness.start, 0.0, 0.99)?;
    within("dynamics.stiffness.end", d.stiffness.end, 0.01, 1.0)?;
    if d.stiffness.end <= d.stiffness.start {
        return Err(bad(
            "dynamics.stiffness.end",
            d.stiffness.end,
            &format!(
                "must be greater than dynamics.stiffness.start ({})",
                d.stiffness.start
            ),
        ));
    }
    if let Some(f) = &d.fluctuation {
        within("dynamics.fluctuation.amplitude", f.amplitude, 0.0, 90.0)?;
        if f.period == 0 || f.period > 100_000 {
            return Err(bad(
                "dynamics.fluctuation.period",
                f.period,
                "must be in [1, 100000] frames",
            ));
        }
    }
    if let Some(g) = d.guides {
        positive("dynamics.guides", g, 1.0)?;
    }
    if d.max_substeps == 0 || d.max_substeps > 4096 {
        return Err(bad(
            "dynamics.max_substeps",
            d.max_substeps,
            "must be in [1, 4096]",
        ));
    }
    Ok(())
}

/// A group read from a strand file: its placement; what only grown hair has is refused
/// rather than silently ignored.
fn validate_file_group(p: &str, g: &HairGroup, f: &StrandFile) -> Result<()> {
    if f.path.is_empty() {
        return Err(bad(
            &format!("{p}.file.path"),
            "\"\"",
            "names the strand file",
        ));
    }
    positive(&format!("{p}.file.scale"), f.scale, BIG)?;
    vec3(&format!("{p}.file.rotate"), f.rotate, 1e6)?;
    vec3(&format!("{p}.file.translate"), f.translate, BIG)?;
    if let Some(t) = f.time {
        finite(&format!("{p}.file.time"), t)?;
        use crate::formats::Format;
        let timed = matches!(
            Format::of(Path::new(&f.path)),
            Some(Format::Abc | Format::Usda | Format::Usdc | Format::Usdz | Format::Usd)
        );
        if !timed {
            return Err(bad(
                &format!("{p}.file.time"),
                t,
                "a time picks a sample of an Alembic archive or a USD file; this file holds one pose",
            ));
        }
    }
    if !g.cuts.is_empty() {
        return Err(bad(
            &format!("{p}.cuts"),
            g.cuts.len(),
            "a group read from a file keeps the file's lengths: cut it in the tool that made it",
        ));
    }
    if !g.loads.is_empty() {
        return Err(bad(
            &format!("{p}.loads"),
            g.loads.len(),
            "a group read from a file is not bent: its loads would do nothing",
        ));
    }
    material(&format!("{p}.material"), &g.material)
}

fn validate_group(p: &str, g: &HairGroup) -> Result<()> {
    if g.count == 0 {
        return Err(bad(&format!("{p}.count"), 0, "must be at least 1"));
    }
    if g.segments == 0 || g.segments > MAX_SEGMENTS {
        return Err(bad(
            &format!("{p}.segments"),
            g.segments,
            &format!("must be in [1, {MAX_SEGMENTS}]"),
        ));
    }
    if let Some(f) = &g.file {
        return validate_file_group(p, g, f);
    }
    positive(&format!("{p}.length"), g.length, BIG)?;
    within(&format!("{p}.length_jitter"), g.length_jitter, 0.0, 0.95)?;
    within(
        &format!("{p}.direction_jitter"),
        g.direction_jitter,
        0.0,
        90.0,
    )?;
    positive(&format!("{p}.rigidity"), g.rigidity, 1e15)?;

    theta_range(&format!("{p}.roots.theta"), g.roots.theta)?;
    phi_range(&format!("{p}.roots.phi"), g.roots.phi)?;
    if let Some(e) = &g.roots.on {
        vec3(&format!("{p}.roots.on.center"), e.center, BIG)?;
        for (i, r) in e.radii.iter().enumerate() {
            positive(&format!("{p}.roots.on.radii[{i}]"), *r, BIG)?;
        }
    }
    if let Some(line) = &g.roots.hairline {
        hairline(&format!("{p}.roots.hairline"), line)?;
    }
    if let Direction::Blend { dir, weight } = &g.direction {
        nonzero(&format!("{p}.direction.dir"), *dir)?;
        within(&format!("{p}.direction.weight"), *weight, 0.0, 1.0)?;
    }
    if let Bending::Converged {
        max_iterations,
        tolerance,
    } = &g.bending
    {
        if *max_iterations == 0 || *max_iterations > 100_000 {
            return Err(bad(
                &format!("{p}.bending.max_iterations"),
                max_iterations,
                "must be in [1, 100000]",
            ));
        }
        within(&format!("{p}.bending.tolerance"), *tolerance, 1e-12, 0.1)?;
    }
    validate_loads(p, g)?;
    validate_cuts(p, g)?;
    material(&format!("{p}.material"), &g.material)
}

/// A hairline: 2 to 64 (phi, theta) points in range, phi increasing over less than a turn.
fn hairline(hp: &str, line: &[(f64, f64)]) -> Result<()> {
    if line.len() < 2 || line.len() > 64 {
        return Err(bad(hp, line.len(), "needs 2 to 64 (phi, theta) points"));
    }
    for (i, (phi, theta)) in line.iter().enumerate() {
        within(&format!("{hp}[{i}].0"), *phi, -720.0, 720.0)?;
        within(&format!("{hp}[{i}].1"), *theta, 0.0, 180.0)?;
        if i > 0 && *phi <= line[i - 1].0 {
            return Err(bad(
                &format!("{hp}[{i}].0"),
                phi,
                "phi must increase along the hairline",
            ));
        }
    }
    if line[line.len() - 1].0 - line[0].0 >= 360.0 {
        return Err(bad(
            hp,
            format!("{:?}..{:?}", line[0].0, line[line.len() - 1].0),
            "must span less than 360 degrees of phi",
        ));
    }
    Ok(())
}

/// A group's loads: at most 8, each with finite parameters and at most 4 half-spaces.
fn validate_loads(p: &str, g: &HairGroup) -> Result<()> {
    if g.loads.len() > 8 {
        return Err(bad(
            &format!("{p}.loads"),
            g.loads.len(),
            "at most 8 loads per group",
        ));
    }
    for (li, l) in g.loads.iter().enumerate() {
        let lp = format!("{p}.loads[{li}]");
        match l {
            Load::Uniform { force, .. } => vec3(&format!("{lp}.force"), *force, 1e9)?,
            Load::Toward {
                point, strength, ..
            } => {
                vec3(&format!("{lp}.point"), *point, BIG)?;
                within(&format!("{lp}.strength"), *strength, -1e9, 1e9)?;
            }
        }
        if l.region().len() > 4 {
            return Err(bad(
                &format!("{lp}.region"),
                l.region().len(),
                "at most 4 half-spaces per load",
            ));
        }
        for (ri, r) in l.region().iter().enumerate() {
            let rp = format!("{lp}.region[{ri}]");
            match r {
                Region::Above(y) | Region::Below(y) => within(&rp, *y, -BIG, BIG)?,
                Region::HalfSpace { normal, offset } => {
                    nonzero(&format!("{rp}.normal"), *normal)?;
                    within(&format!("{rp}.offset"), *offset, -BIG, BIG)?;
                }
            }
        }
    }
    Ok(())
}

/// A group's cuts: at most 16, each with its ranges and rule in bounds.
fn validate_cuts(p: &str, g: &HairGroup) -> Result<()> {
    if g.cuts.len() > 16 {
        return Err(bad(
            &format!("{p}.cuts"),
            g.cuts.len(),
            "at most 16 cuts per group",
        ));
    }
    for (ci, c) in g.cuts.iter().enumerate() {
        let cp = format!("{p}.cuts[{ci}]");
        if let Some(t) = c.theta {
            theta_range(&format!("{cp}.theta"), t)?;
        }
        if let Some(f) = c.phi {
            phi_range(&format!("{cp}.phi"), f)?;
        }
        match &c.rule {
            CutRule::Below(y) => within(&format!("{cp}.rule"), *y, -BIG, BIG)?,
            CutRule::ByPoreHeight { low, high } => {
                within(&format!("{cp}.rule.low.0"), low.0, -BIG, BIG)?;
                within(&format!("{cp}.rule.high.0"), high.0, -BIG, BIG)?;
                if low.0 >= high.0 {
                    return Err(bad(
                        &format!("{cp}.rule"),
                        format!("{low:?}..{high:?}"),
                        "low height must be below high height",
                    ));
                }
                for (n, v) in [("low.1", low.1), ("high.1", high.1)] {
                    if v > g.segments {
                        return Err(bad(
                            &format!("{cp}.rule.{n}"),
                            v,
                            &format!("must be at most the group's {} segments", g.segments),
                        ));
                    }
                }
            }
            CutRule::Near { center, radius } => {
                vec3(&format!("{cp}.rule.center"), *center, BIG)?;
                positive(&format!("{cp}.rule.radius"), *radius, BIG)?;
            }
        }
    }
    Ok(())
}

/// A hair group's look.
fn material(mp: &str, m: &Material) -> Result<()> {
    color(&format!("{mp}.color"), m.color, 1.0)?;
    within(&format!("{mp}.ka"), m.ka, 0.0, 10.0)?;
    within(&format!("{mp}.ka_spread"), m.ka_spread, 0.0, 5.0)?;
    within(&format!("{mp}.ks"), m.ks, 0.0, 10.0)?;
    within(&format!("{mp}.shininess"), m.shininess, 0.0, 10000.0)?;
    within(&format!("{mp}.kd"), m.kd, 0.0, 10.0)?;
    positive(&format!("{mp}.width"), m.width, 1e3)?;
    within(&format!("{mp}.tip_width"), m.tip_width, 0.0, 1.0)?;
    m.physical.validate(&format!("{mp}.physical"))?;
    let v = &m.variation;
    within(&format!("{mp}.variation.melanin"), v.melanin, 0.0, 1.0)?;
    within(&format!("{mp}.variation.width"), v.width, 0.0, 1.0)?;
    within(&format!("{mp}.variation.tint"), v.tint, 0.0, 1.0)?;
    Ok(())
}

/// A reload's merge of the hair groups (`Kind::merge`): while the number of groups stays,
/// each group with its material apart (a colour set in the Hair look panel survives an edit
/// of the group's count in the file); otherwise the block-wise pick already in `out`.
pub fn merge_groups(base: &Scene, ours: &Scene, theirs: &Scene, out: &mut Scene) {
    use crate::systems::scene::pick;
    let (b, o, t) = (base.groups(), ours.groups(), theirs.groups());
    if b.len() != o.len() || b.len() != t.len() {
        return;
    }
    *out.groups_mut() = b
        .iter()
        .zip(o)
        .zip(t)
        .map(|((b, o), t)| {
            let material = pick(&b.material, &o.material, t.material.clone());
            // The rest of the group, compared with the material left out.
            let rest = |g: &HairGroup| HairGroup {
                material: b.material.clone(),
                ..g.clone()
            };
            HairGroup {
                material,
                ..pick(&rest(b), &rest(o), rest(t))
            }
        })
        .collect();
}
