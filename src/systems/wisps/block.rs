//! Toon wisps (Sakai): the scene block (`wisps`) and its checks (`validate`, with the
//! shared forces and head the wisps live in). Each wisp is a skeleton, a chain of nodes with a
//! radius of influence r_e and an effective weight w_e (section 4.1); the hair surface is the
//! iso-surface of the blobby density summed over the wisps (eqs 8-9), ray-marched and
//! toon-shaded (section 5), and, when `springs` is present, animated by a mass-spring
//! lattice integrated with RK4 (section 7) whose natural lengths hold the drawn shape under
//! gravity (7.1).
//!
//! Coordinates are world units (the head's, centimetres in the shipped scenes); spring
//! time is seconds. The springs feel the scene's shared forces (`crate::forces::Forces`:
//! gravity, keyed wind, the EFF, head motion); they keep no gravity of their own.
//!
//! **On a mesh head** (`head.mesh`) every wisp is moved onto the scalp before anything is
//! built (`on_mesh_head`): its skeleton is translated so that its root lies on the mesh's
//! scalp, as Anjyo's pores do (the nearest point of the mesh, which must be a scalp
//! triangle, then onto the SDF's zero level set by Newton steps, the hull the springs
//! collide with). The drawn shape is kept.

use crate::error::{KamiError, Result};
use crate::scene::hull::{HeadMeshData, OffScalp};
use crate::scene::validate::*;
use crate::scene::Head;
use crate::systems::scene::Scene;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// The wisps kind's block of the scene: its one field of the scene file (listed in the
/// registry's `kinds!`), read through `Scene::wisps`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WispsBlock {
    /// Toon wisps (Sakai): skeletons drawn as a ray-marched blobby surface; absent in scenes without it.
    pub wisps: Option<Wisps>,
}

impl Scene {
    /// The wisps block (`None` in scenes without it).
    pub fn wisps(&self) -> &Option<Wisps> {
        &self.block::<WispsBlock>().wisps
    }
    pub fn wisps_mut(&mut self) -> &mut Option<Wisps> {
        &mut self.block_mut::<WispsBlock>().wisps
    }
}

/// Toon wisps of a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wisps {
    /// One skeleton per wisp; the first node of each is the root, fixed to the head.
    pub skeletons: Vec<Skeleton>,
    /// r_threshold of eq 8: the surface is where the summed density equals it.
    #[serde(default = "default_threshold")]
    pub threshold: f64,
    #[serde(default)]
    pub toon: Toon,
    #[serde(default)]
    pub march: March,
    /// Mass-spring motion (section 7); absent: the wisps stay as drawn (no buffers, no pass).
    #[serde(default)]
    pub springs: Option<Springs>,
    /// Wisps held together node to node (one thick wisp made of thin ones) until the
    /// connections are released (Fig. 10 bottom; Fig. 12).
    #[serde(default)]
    pub bundles: Vec<Bundle>,
    /// How the surface is drawn: ray marched, or meshed and rasterised (`WispDraw`).
    #[serde(default)]
    pub draw: WispDraw,
    /// The meshed path's grid (`mesh::polygonise`).
    #[serde(default)]
    pub mesh: MeshGrid,
}

/// How the wisps' surface is drawn (`kami bench wisps` measures both against the f64 truth).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum WispDraw {
    /// The mesh where `kami bench wisps` measured it cheaper than the march on this kind of
    /// adapter with its image error within the bound (`mesh_pass::auto_draws_mesh`), else
    /// the march.
    #[default]
    Auto,
    /// Every pixel ray marched (`march`): the surface exactly, at a cost per pixel.
    March,
    /// The surface polygonised by surface nets and rasterised (`mesh`, `mesh_pass`): meshed
    /// once while the wisps stand still, so a frame costs a raster pass.
    Mesh,
}

/// The meshed path's grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshGrid {
    /// Cell size in scene units; 0 (the default): `mesh::auto_cell` of the wisps' radii.
    #[serde(default)]
    pub cell: f64,
    /// Where the surface is polygonised (`MeshOn`).
    #[serde(default)]
    pub on: MeshOn,
}

/// Where the meshed path polygonises the surface.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum MeshOn {
    /// Still wisps on the CPU (meshed once, in f64); moving wisps where `kami bench wisps`
    /// measured them cheaper on this class of adapter (`mesh_pass::auto_meshes_on_gpu`).
    #[default]
    Auto,
    /// `mesh::polygonise` on the CPU's threads, in f64 (moving wisps' nodes read back each
    /// frame).
    Cpu,
    /// `shaders/wisps/mesher.wgsl` every frame, from the segments on the GPU: nothing read
    /// back, drawn indirectly.
    Gpu,
}

fn default_threshold() -> f64 {
    0.5
}

/// A hair skeleton: a chain of nodes, root first.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Skeleton {
    #[serde(default)]
    pub name: String,
    pub nodes: Vec<Node>,
    /// This wisp's outline width as a multiple of `toon.outline_width` (1: as every wisp;
    /// 0: none), before `toon.outline_taper` thins it toward the tip.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub outline: f64,
}

/// A skeleton node (Fig. 3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Node {
    /// Position, in the head's rest frame.
    pub p: [f64; 3],
    /// Radius of influence r_e (> 0).
    pub r: f64,
    /// Effective weight w_e (> 0): with the threshold, sets the wisp's width (radius
    /// `r * (1 - sqrt(threshold / (1.5 w)))` where `threshold/w > 1/6`).
    #[serde(default = "one")]
    pub w: f64,
}

fn one() -> f64 {
    1.0
}

fn is_one(v: &f64) -> bool {
    *v == 1.0
}

/// Distance from a ray point to a skeleton's spline (section 5.1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Distance {
    /// The paper's: minimise the sixth-degree |S(t) - v|^2 per segment by quadratic
    /// minimisation then Newton (Wang, Kearney & Atkinson).
    #[default]
    Newton,
    /// Cheaper: each segment as a polyline of `pieces` chords, closed-form distance to each.
    Polyline { pieces: u32 },
}

/// Ray marching (section 5).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct March {
    #[serde(default)]
    pub distance: Distance,
    /// Most sphere-tracing steps per ray and proxy (llvmpipe stops loops past 65,535).
    #[serde(default = "default_max_steps")]
    pub max_steps: u32,
    /// Bisection steps refining a hit.
    #[serde(default = "default_refine")]
    pub refine: u32,
    /// Fraction of the Lipschitz-safe step taken (1 = the full safe step; below 1 is slower
    /// and no more accurate, above 1 may skip thin wisps: for benches only).
    #[serde(default = "one")]
    pub step_scale: f64,
    /// Where the march runs (the same march and image either way).
    #[serde(default)]
    pub on: MarchOn,
}

/// Where the wisps' march runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum MarchOn {
    /// A compute pass on a hardware GPU (one workgroup per screen tile; a GPU gives compute
    /// far more of its chip than fragment work), fragments on a software adapter (whose
    /// compute dispatch ran on one of its threads: 1.6 times slower, `docs/wisps.md`).
    #[default]
    Auto,
    /// A compute pass writing colour and depth images, composited into the scene by depth.
    Compute,
    /// A fragment shader over the screen tiles, writing colour and depth in the scene pass.
    Fragment,
}

impl MarchOn {
    /// Whether the march runs in compute on an adapter of `device_type`.
    pub fn compute(self, device_type: wgpu::DeviceType) -> bool {
        match self {
            MarchOn::Auto => device_type != wgpu::DeviceType::Cpu,
            MarchOn::Compute => true,
            MarchOn::Fragment => false,
        }
    }
}

fn default_max_steps() -> u32 {
    256
}
fn default_refine() -> u32 {
    8
}

impl Default for March {
    fn default() -> Self {
        March {
            distance: Distance::Newton,
            max_steps: default_max_steps(),
            refine: default_refine(),
            step_scale: 1.0,
            on: MarchOn::Auto,
        }
    }
}

/// Two or three tones (eqs 20-22; three tones split the shade once more).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Tones {
    Two,
    #[default]
    Three,
}

/// Toon shading in the head's frame (eqs 14-22). Intensities are in [0, 1].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Toon {
    #[serde(default)]
    pub tones: Tones,
    /// c_diffuse: the lit tone (sRGB, 0..1).
    #[serde(default = "default_lit")]
    pub diffuse: [f32; 3],
    /// c_shade: the shaded tone.
    #[serde(default = "default_shade")]
    pub shade: [f32; 3],
    /// The darkest tone (three tones only).
    #[serde(default = "default_dark")]
    pub dark: [f32; 3],
    /// c_specular: added where the specular intensity passes its threshold (the angel halo).
    #[serde(default = "default_specular")]
    pub specular: [f32; 3],
    /// t_diffuse.
    #[serde(default = "default_t_diffuse")]
    pub t_diffuse: f64,
    /// Below this diffuse intensity the dark tone is used (three tones; < t_diffuse).
    #[serde(default = "default_t_dark")]
    pub t_dark: f64,
    /// t_specular: close to 1 gives a thin halo band.
    #[serde(default = "default_t_specular")]
    pub t_specular: f64,
    /// Silhouette outline colour.
    #[serde(default = "default_outline")]
    pub outline: [f32; 3],
    /// Outline width in pixels (0: none).
    #[serde(default = "default_outline_width")]
    pub outline_width: f64,
    /// How much the outline thins from root to tip along each wisp's drawn length: the
    /// width at arc-length fraction u is `outline_width * skeleton.outline * (1 - taper u)`
    /// (0: even, 1: nothing at the tip). Read by the ray march per segment
    /// (`systems::wisps::toon::segment_outlines`).
    #[serde(default)]
    pub outline_taper: f64,
    /// Feather of the lit/shade step: the width in I_diff over which the lit tone blends
    /// into the shade tone, centred on t_diffuse (0: the hard step of eq 20).
    #[serde(default)]
    pub diffuse_feather: f64,
    /// Feather of the shade/dark step (three tones), centred on t_dark.
    #[serde(default)]
    pub dark_feather: f64,
    /// Feather of the halo's edge: the width in I_spec over which it fades in, centred on
    /// t_specular (the halo's width).
    #[serde(default)]
    pub halo_feather: f64,
    /// Latitude shift of the halo band, degrees (positive: toward the crown): the band is
    /// where cos(latitude difference to the light - offset) > t_specular.
    #[serde(default)]
    pub halo_offset: f64,
    /// Multiplier of the halo colour added in the band (1: c_specular as is; 0: no halo).
    #[serde(default = "one")]
    pub halo_strength: f64,
    /// The halo's colour over the shade and dark tones (blended by the lit/shade step);
    /// `None`: c_specular everywhere.
    #[serde(default)]
    pub halo_shadow: Option<[f32; 3]>,
    /// Rim light colour, added near the silhouette on the shade and dark tones (the side
    /// facing away from the light).
    #[serde(default = "default_rim")]
    pub rim: [f32; 3],
    /// Rim width: the rim is where N·V < rim_width (V towards the eye; 0: no rim).
    #[serde(default)]
    pub rim_width: f64,
    /// Feather of the rim's inner edge, in N·V, centred on rim_width.
    #[serde(default)]
    pub rim_feather: f64,
}

fn default_lit() -> [f32; 3] {
    [0.36, 0.42, 0.78]
}
fn default_shade() -> [f32; 3] {
    [0.22, 0.25, 0.55]
}
fn default_dark() -> [f32; 3] {
    [0.13, 0.14, 0.34]
}
fn default_specular() -> [f32; 3] {
    [0.45, 0.45, 0.4]
}
fn default_t_diffuse() -> f64 {
    0.45
}
fn default_t_dark() -> f64 {
    0.2
}
fn default_t_specular() -> f64 {
    0.97
}
fn default_outline() -> [f32; 3] {
    [0.06, 0.05, 0.12]
}
fn default_outline_width() -> f64 {
    1.5
}
fn default_rim() -> [f32; 3] {
    [0.55, 0.62, 0.95]
}

impl Default for Toon {
    fn default() -> Self {
        Toon {
            tones: Tones::Three,
            diffuse: default_lit(),
            shade: default_shade(),
            dark: default_dark(),
            specular: default_specular(),
            t_diffuse: default_t_diffuse(),
            t_dark: default_t_dark(),
            t_specular: default_t_specular(),
            outline: default_outline(),
            outline_width: default_outline_width(),
            outline_taper: 0.0,
            diffuse_feather: 0.0,
            dark_feather: 0.0,
            halo_feather: 0.0,
            halo_offset: 0.0,
            halo_strength: 1.0,
            halo_shadow: None,
            rim: default_rim(),
            rim_width: 0.0,
            rim_feather: 0.0,
        }
    }
}

/// Time integration of the mass springs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Integrator {
    /// The paper's classical fourth-order Runge-Kutta.
    #[default]
    Rk4,
    /// Semi-implicit (symplectic) Euler: one force evaluation per step, first order.
    SemiImplicitEuler,
}

/// Mass springs (section 7): one primary and eight sub mass points per node.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Springs {
    /// Mass of a primary point; each sub point has `sub_mass` of it.
    #[serde(default = "one")]
    pub mass: f64,
    #[serde(default = "default_sub_mass")]
    pub sub_mass: f64,
    /// Radius of the ring of 8 sub points round each node, as a fraction of its radius of
    /// influence r ("distanced according to the blob radius"). Below 1 keeps the ring inside
    /// the visible surface (0.67 r at weight 2.5, threshold 0.5), so wisps drawn lying on the
    /// head do not start with sub points inside the scalp.
    #[serde(default = "one")]
    pub ring: f64,
    /// Spring constant k_s of every spring (force per unit stretch).
    #[serde(default = "default_stiffness")]
    pub stiffness: f64,
    /// c_damp of eq 23 (force per unit velocity).
    #[serde(default = "default_damping")]
    pub damping: f64,
    /// No longer read: the springs fall under the scene's shared gravity
    /// (`forces.gravity`, read by `forces::Forces`) like Anjyo's strands. Kept so
    /// that old scene files get a clear word: equal to the shared gravity it is accepted with
    /// a warning, anything else is refused naming the file and the field
    /// (`systems::validate`). Never written back.
    #[serde(default, deserialize_with = "old_gravity", skip_serializing)]
    pub gravity: Option<[f64; 3]>,
    /// Seconds per rendered frame.
    #[serde(default = "default_frame_time")]
    pub frame_time: f64,
    /// Integration steps per frame.
    #[serde(default = "default_substeps")]
    pub substeps: u32,
    #[serde(default)]
    pub integrator: Integrator,
    /// Solve the natural lengths so the drawn shape holds under gravity (7.1, eq 24);
    /// `false` uses the drawn lengths (the wisps sag).
    #[serde(default = "yes")]
    pub hold_shape: bool,
    /// Push mass points out of the head after each step (not in the paper, whose future work
    /// asks for it): the ellipsoid, or a mesh head's signed distance field.
    #[serde(default = "yes")]
    pub collide: bool,
}

/// The old field as old files wrote it (a bare vector, not `Some(..)`).
fn old_gravity<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<[f64; 3]>, D::Error> {
    <[f64; 3]>::deserialize(d).map(Some)
}

fn default_sub_mass() -> f64 {
    0.25
}
fn default_stiffness() -> f64 {
    400.0
}
fn default_damping() -> f64 {
    0.6
}
fn default_frame_time() -> f64 {
    1.0 / 30.0
}
fn default_substeps() -> u32 {
    8
}
fn yes() -> bool {
    true
}

impl Default for Springs {
    fn default() -> Self {
        Springs {
            mass: 1.0,
            sub_mass: default_sub_mass(),
            ring: 1.0,
            stiffness: default_stiffness(),
            damping: default_damping(),
            gravity: None,
            frame_time: default_frame_time(),
            substeps: default_substeps(),
            integrator: Integrator::Rk4,
            hold_shape: true,
            collide: true,
        }
    }
}

/// Wisps joined node to node by springs (primary to primary) from the root up to, not
/// including, node `release_from`; past it they move apart (the wisp divides).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bundle {
    /// Indices into `skeletons`.
    pub wisps: Vec<usize>,
    pub release_from: usize,
}

pub use crate::scene::hull::{ROOT_NEWTON, ROOT_TOLERANCE};

/// Where a wisp's root goes on a mesh head, and how far it moved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placed {
    /// On the SDF's zero level set, over a scalp triangle.
    pub root: DVec3,
    /// The scalp triangle nearest the drawn root.
    pub triangle: u32,
    /// `root` minus the drawn root: the whole skeleton moves by it.
    pub offset: DVec3,
}

/// The farthest a drawn root may lie from the mesh (`hull::root_reach` with the root node's
/// radius of influence).
pub fn root_reach(node: &Node, head: &Head) -> f64 {
    crate::scene::hull::root_reach(node.r, head)
}

/// Place skeleton `si`'s root on the scalp of `mesh` (`HeadMeshData::place_on_scalp`, see
/// the module doc). Refused, naming the wisp and the field, when the root is far from the
/// mesh, nearest a triangle off the scalp, or where the field cannot follow the mesh
/// (features thinner than a cell).
pub fn place_root(wisps: &Wisps, si: usize, head: &Head, mesh: &HeadMeshData) -> Result<Placed> {
    let sk = &wisps.skeletons[si];
    let field = format!("wisps.skeletons[{si}].nodes[0].p");
    let name = if sk.name.is_empty() {
        format!("wisp {si}")
    } else {
        format!("wisp {si} (`{}`)", sk.name)
    };
    let node = sk.nodes.first().ok_or_else(|| KamiError::Invalid {
        file: String::new(),
        field: format!("wisps.skeletons[{si}].nodes"),
        value: "[]".into(),
        allowed: "a skeleton has at least two nodes".into(),
    })?;
    let drawn = DVec3::from(node.p);
    let refuse = |allowed: String| KamiError::Invalid {
        file: String::new(),
        field: field.clone(),
        value: format!("{:?}", node.p),
        allowed,
    };
    match mesh.place_on_scalp(drawn, root_reach(node, head)) {
        Ok(p) => Ok(Placed {
            root: p.root,
            triangle: p.triangle,
            offset: p.root - drawn,
        }),
        Err(OffScalp::Far { dist, reach }) => Err(refuse(format!(
            "{name}: its root is {dist:.3} from the head mesh; a root on a mesh head must be \
             drawn within {reach:.3} of it (the root's radius or a quarter of the head's \
             smallest radius), where it is moved onto the scalp"
        ))),
        Err(OffScalp::NotScalp { triangle }) => Err(refuse(format!(
            "{name}: its root is nearest triangle {triangle} of the head mesh, which is not \
             scalp (head.mesh.scalp): draw the root over the scalp or widen the scalp regions"
        ))),
        Err(OffScalp::Unfollowed { cell }) => Err(refuse(format!(
            "{name}: the head's signed distance field cannot follow the mesh under its root \
             (a feature thinner than a cell of {cell:.3}): draw the root elsewhere or raise \
             head.mesh.resolution"
        ))),
    }
}

/// The wisps with every skeleton translated so its root lies on the scalp of the mesh head
/// (`place_root`); unchanged on an ellipsoid head.
pub fn on_mesh_head(wisps: &Wisps, head: &Head) -> Result<Wisps> {
    let Some(mesh) = crate::scene::hull::head_mesh(head)? else {
        return Ok(wisps.clone());
    };
    let mut out = wisps.clone();
    for si in 0..wisps.skeletons.len() {
        let placed = place_root(wisps, si, head, &mesh)?;
        for n in &mut out.skeletons[si].nodes {
            n.p = (DVec3::from(n.p) + placed.offset).to_array();
        }
    }
    Ok(out)
}

/// Check the wisps block, if the scene has one, with the shared forces and head it lives in.
pub fn validate(s: &Scene) -> Result<()> {
    if let Some(w) = s.wisps() {
        validate_wisps(w)?;
        wisps_on_shared_forces(s, w)?;
    }
    Ok(())
}

/// Most wisps in a scene and nodes per skeleton (the GPU keeps a wisp's spline solve in one
/// invocation's registers).
pub const MAX_WISPS: usize = 4096;
pub const MAX_WISP_NODES: usize = 64;

/// The wisps in the scene's shared forces: a gravity of their own (`wisps.springs.gravity`,
/// read before the springs fell under the shared one) is accepted with a warning when it
/// equals the shared gravity (`forces.gravity`, what `forces::Forces::new` reads;
/// zero without the block) and refused otherwise; on a mesh head every root must lie over
/// the scalp (`wisps::place_root`, refused naming the skeleton's root).
fn wisps_on_shared_forces(s: &Scene, w: &Wisps) -> Result<()> {
    if let Some(g) = w.springs.as_ref().and_then(|sp| sp.gravity) {
        vec3("wisps.springs.gravity", g, 1e9)?;
        let shared = s.forces.gravity;
        if g == shared {
            log::warn!(
                "`wisps.springs.gravity` = {g:?} is no longer read (the wisps fall under the \
                 scene's shared gravity, `forces.gravity`, which equals it): remove it"
            );
        } else {
            return Err(bad(
                "wisps.springs.gravity",
                format!("{g:?}"),
                &format!(
                    "the wisps no longer keep a gravity of their own: they fall under the \
                     scene's shared gravity, `forces.gravity` (now {shared:?}, world units/s²); \
                     move the value there (forces: ForcesDesc(gravity: ({:?}, {:?}, {:?}))) and \
                     remove it here",
                    g[0], g[1], g[2]
                ),
            ));
        }
    }
    // Roots on a mesh head, checked here when the mesh can be read now, so that a root off
    // the scalp names the scene file; a mesh that cannot be read yet (a path relative to the
    // scene file is resolved after validation) is placed, and refused, when the wisps are
    // built, and its own errors name the mesh file.
    if s.head.mesh.is_some() {
        if let Ok(Some(mesh)) = crate::scene::hull::head_mesh(&s.head) {
            for si in 0..w.skeletons.len() {
                place_root(w, si, &s.head, &mesh)?;
            }
        }
    }
    Ok(())
}

fn validate_wisps(w: &Wisps) -> Result<()> {
    if w.skeletons.is_empty() {
        return Err(bad("wisps.skeletons", "[]", "needs at least one skeleton"));
    }
    if w.skeletons.len() > MAX_WISPS {
        return Err(bad(
            "wisps.skeletons",
            format!("{} skeletons", w.skeletons.len()),
            &format!("at most {MAX_WISPS}"),
        ));
    }
    positive("wisps.threshold", w.threshold, 1e3)?;
    for (si, sk) in w.skeletons.iter().enumerate() {
        let f = format!("wisps.skeletons[{si}].nodes");
        if sk.nodes.len() < 2 {
            return Err(bad(
                &f,
                format!("{} node(s)", sk.nodes.len()),
                "a skeleton needs at least 2 nodes (a root and a tip)",
            ));
        }
        if sk.nodes.len() > MAX_WISP_NODES {
            return Err(bad(
                &f,
                format!("{} nodes", sk.nodes.len()),
                &format!("at most {MAX_WISP_NODES}"),
            ));
        }
        within(
            &format!("wisps.skeletons[{si}].outline"),
            sk.outline,
            0.0,
            8.0,
        )?;
        for (ni, n) in sk.nodes.iter().enumerate() {
            vec3(&format!("{f}[{ni}].p"), n.p, BIG)?;
            positive(&format!("{f}[{ni}].r"), n.r, BIG)?;
            positive(&format!("{f}[{ni}].w"), n.w, BIG)?;
            if ni > 0 {
                let q = sk.nodes[ni - 1].p;
                let d2: f64 = (0..3).map(|k| (n.p[k] - q[k]).powi(2)).sum();
                let scale = n.r.min(sk.nodes[ni - 1].r);
                if d2.sqrt() <= 1e-6 * scale.max(1e-9) {
                    return Err(bad(
                        &format!("{f}[{ni}].p"),
                        format!("{:?}", n.p),
                        &format!(
                            "coincides with node {}: neighbouring nodes must differ",
                            ni - 1
                        ),
                    ));
                }
            }
        }
    }
    let t = &w.toon;
    for (name, c) in [
        ("diffuse", t.diffuse),
        ("shade", t.shade),
        ("dark", t.dark),
        ("specular", t.specular),
        ("outline", t.outline),
    ] {
        color(&format!("wisps.toon.{name}"), c, 1.0)?;
    }
    within("wisps.toon.t_diffuse", t.t_diffuse, 0.0, 1.0)?;
    within("wisps.toon.t_dark", t.t_dark, 0.0, 1.0)?;
    within("wisps.toon.t_specular", t.t_specular, -1.0, 1.0)?;
    within("wisps.toon.outline_width", t.outline_width, 0.0, 32.0)?;
    within("wisps.toon.outline_taper", t.outline_taper, 0.0, 1.0)?;
    within("wisps.toon.diffuse_feather", t.diffuse_feather, 0.0, 1.0)?;
    within("wisps.toon.dark_feather", t.dark_feather, 0.0, 1.0)?;
    within("wisps.toon.halo_feather", t.halo_feather, 0.0, 1.0)?;
    within("wisps.toon.halo_offset", t.halo_offset, -90.0, 90.0)?;
    within("wisps.toon.halo_strength", t.halo_strength, 0.0, 4.0)?;
    if let Some(c) = t.halo_shadow {
        color("wisps.toon.halo_shadow", c, 1.0)?;
    }
    color("wisps.toon.rim", t.rim, 1.0)?;
    within("wisps.toon.rim_width", t.rim_width, 0.0, 1.0)?;
    within("wisps.toon.rim_feather", t.rim_feather, 0.0, 1.0)?;
    let m = &w.march;
    if m.max_steps == 0 || m.max_steps > 4096 {
        return Err(bad(
            "wisps.march.max_steps",
            m.max_steps,
            "must be in [1, 4096]",
        ));
    }
    if m.refine > 32 {
        return Err(bad("wisps.march.refine", m.refine, "must be in [0, 32]"));
    }
    within("wisps.march.step_scale", m.step_scale, 0.05, 8.0)?;
    within("wisps.mesh.cell", w.mesh.cell, 0.0, BIG)?;
    if let Distance::Polyline { pieces } = m.distance {
        if pieces == 0 || pieces > 64 {
            return Err(bad(
                "wisps.march.distance.pieces",
                pieces,
                "must be in [1, 64]",
            ));
        }
    }
    if let Some(sp) = &w.springs {
        positive("wisps.springs.mass", sp.mass, BIG)?;
        positive("wisps.springs.sub_mass", sp.sub_mass, BIG)?;
        positive("wisps.springs.ring", sp.ring, 1.0)?;
        positive("wisps.springs.stiffness", sp.stiffness, 1e12)?;
        within("wisps.springs.damping", sp.damping, 0.0, 1e9)?;
        positive("wisps.springs.frame_time", sp.frame_time, 10.0)?;
        if sp.substeps == 0 || sp.substeps > 1000 {
            return Err(bad(
                "wisps.springs.substeps",
                sp.substeps,
                "must be in [1, 1000]",
            ));
        }
    }
    for (bi, b) in w.bundles.iter().enumerate() {
        if b.wisps.len() < 2 {
            return Err(bad(
                &format!("wisps.bundles[{bi}].wisps"),
                format!("{:?}", b.wisps),
                "a bundle joins at least 2 wisps",
            ));
        }
        for (k, &i) in b.wisps.iter().enumerate() {
            let Some(sk) = w.skeletons.get(i) else {
                return Err(bad(
                    &format!("wisps.bundles[{bi}].wisps[{k}]"),
                    i,
                    &format!("must name a skeleton (0..{})", w.skeletons.len()),
                ));
            };
            if b.release_from > sk.nodes.len() {
                return Err(bad(
                    &format!("wisps.bundles[{bi}].release_from"),
                    b.release_from,
                    &format!(
                        "must be at most the node count of skeleton {i} ({})",
                        sk.nodes.len()
                    ),
                ));
            }
        }
    }
    Ok(())
}
