//! Directable strips (Kazama, Sugisaki, Morishima): the scene block (`strips`) and its
//! checks (`validate`, `check`: the block's one set of bounds, which the runtime types run
//! too). The Hair Object Model is a set of reed-shaped strips (textured
//! ribbons tapering to the tip) arranged in layers around the head, as stylists' layer model
//! does. Each strip follows a chain of rigid sticks whose joints are damped angular springs
//! with two degrees of freedom (eq 1), driven by the scene's shared forces (gravity, the
//! wind of the External Force Field, the head's motion: `scene::forces`), a spring and the
//! collision with the head (eq 2). Key-frame edits (section 4) add extra forces to the
//! field.
//!
//! Coordinates are world units (centimetres in the shipped scenes, like the head); time is
//! seconds.

use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::scene::eff::Sampling;
use crate::scene::validate::*;
use crate::systems::scene::Scene;

/// The strips kind's block of the scene: its one field of the scene file (listed in the
/// registry's `kinds!`), read through `Scene::strips`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StripsBlock {
    /// Directable strips (Kazama et al.): layered reed strips on damped angular springs; absent in scenes without it.
    pub strips: Option<Strips>,
}

impl Scene {
    /// The strips block (`None` in scenes without it).
    pub fn strips(&self) -> &Option<Strips> {
        &self.block::<StripsBlock>().strips
    }
    pub fn strips_mut(&mut self) -> &mut Option<Strips> {
        &mut self.block_mut::<StripsBlock>().strips
    }
}

/// Strips of a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Strips {
    /// Layers of the layer model, inner (under) to outer (over); drawn in this order.
    pub layers: Vec<Layer>,
    #[serde(default)]
    pub motion: Motion,
    #[serde(default)]
    pub look: Look,
    /// Key-frame edits (section 4): each pulls one strip toward a target between two frames
    /// by an extra force that joins the EFF.
    #[serde(default)]
    pub edits: Vec<Edit>,
}

/// One layer of the layer model: `count` strips whose roots lie on a ring of the head at
/// polar angle `polar` (degrees from the crown), spread over an azimuth range. The ring is
/// on the head ellipsoid (`head.radii`); on a mesh head each root is then moved to the
/// nearest point of the mesh's scalp (`hom::roots_on_mesh`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Layer {
    #[serde(default)]
    pub name: String,
    /// Strips in this layer (>= 1; at most `MAX_STRIPS` in all layers).
    pub count: u32,
    /// Polar angle of the root ring from the crown (+y), degrees, in (0, 180).
    pub polar: f64,
    /// Azimuth range of the roots, degrees, as the head's `Ellipsoid::point` measures it:
    /// from +x (the face looks along +x) toward +z; 180 is the back. The strips are spread evenly over it (both ends included when the range is
    /// less than a full turn).
    #[serde(default = "full_turn")]
    pub azimuth: [f64; 2],
    /// Strip length (world units).
    pub length: f64,
    /// Rigid sticks per strip (the chain has `sticks + 1` control points), 1 to
    /// `MAX_STRIP_STICKS`.
    #[serde(default = "default_sticks")]
    pub sticks: u32,
    /// Ribbon width at the root and at the tip (world units; the reed tapers between).
    #[serde(default = "default_width")]
    pub width: [f64; 2],
    /// How the rest shape leaves the head: 0 along the head normal, 1 straight down.
    #[serde(default = "default_droop")]
    pub droop: f64,
    /// Extra bend at each joint of the rest shape toward the head (degrees per stick, at
    /// most `MAX_CURL` either way).
    #[serde(default)]
    pub curl: f64,
    /// Multiplies `motion.stiffness` for this layer (outer layers are often softer); in
    /// [0, `MAX_LAYER_STIFFNESS`].
    #[serde(default = "one")]
    pub stiffness: f64,
    /// Base colour (linear RGB, 0..1); the texture modulates it root to tip.
    #[serde(default = "default_color")]
    pub color: [f32; 3],
}

fn full_turn() -> [f64; 2] {
    [0.0, 360.0]
}
fn default_sticks() -> u32 {
    8
}
fn default_width() -> [f64; 2] {
    [3.0, 0.6]
}
fn default_droop() -> f64 {
    0.6
}
fn one() -> f64 {
    1.0
}
fn default_color() -> [f32; 3] {
    [0.16, 0.09, 0.05]
}

/// Eq 1, `I1 Φ'' + I2 Φ' + τ (Φ − Φ0) = H`, per joint, and the forces of eq 2: the solver's
/// settings only. Gravity g, the wind and the head's motion are the scene's `forces` block,
/// read as a force per unit mass of a stick (`scene::forces`: units).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Motion {
    /// Moment of inertia I1 of the root joint (> 0); joints toward the tip carry less.
    #[serde(default = "default_inertia")]
    pub inertia: f64,
    /// Air resistance I2 (>= 0).
    #[serde(default = "default_damping")]
    pub damping: f64,
    /// Stiffness τ of the root joint, in [0, `MAX_MOTION_STIFFNESS`].
    #[serde(default = "default_stiffness")]
    pub stiffness: f64,
    /// τ at the tip as a share of τ at the root (the strip softens toward the tip).
    #[serde(default = "default_stiffness_tip")]
    pub stiffness_tip: f64,
    /// Spring constant k of S (eq 2).
    #[serde(default)]
    pub spring: f64,
    /// Collision strength κ of Ψ (eq 2); 0 turns the collision force off.
    #[serde(default = "default_collision")]
    pub collision: f64,
    /// Seconds of motion per rendered frame.
    #[serde(default = "default_frame_time")]
    pub frame_time: f64,
    /// Integration steps per second of motion (the fixed simulation rate, independent of
    /// the frame rate).
    #[serde(default = "default_rate")]
    pub steps_per_second: f64,
    /// How control points read the EFF.
    #[serde(default)]
    pub sampling: Sampling,
    /// Gravity preloading: the rest angles Φ0 are set so that the groomed shape is the
    /// equilibrium under gravity (Φ0 = Φ − H_g(Φ)/τ), and the strips hold it in still air
    /// instead of sagging from frame 0 (off: Φ0 is the groomed shape, as in the paper).
    #[serde(default)]
    pub preload: bool,
}

fn default_inertia() -> f64 {
    1.0
}
fn default_damping() -> f64 {
    4.0
}
fn default_stiffness() -> f64 {
    400.0
}
fn default_stiffness_tip() -> f64 {
    0.25
}
fn default_collision() -> f64 {
    1.0
}
fn default_frame_time() -> f64 {
    1.0 / 30.0
}
fn default_rate() -> f64 {
    120.0
}

impl Default for Motion {
    fn default() -> Self {
        Motion {
            inertia: default_inertia(),
            damping: default_damping(),
            stiffness: default_stiffness(),
            stiffness_tip: default_stiffness_tip(),
            spring: 0.0,
            collision: default_collision(),
            frame_time: default_frame_time(),
            steps_per_second: default_rate(),
            sampling: Sampling::default(),
            preload: false,
        }
    }
}

/// How strips look.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Look {
    /// Fine hairs across a strip in the generated texture.
    #[serde(default = "default_hairs")]
    pub hairs: u32,
    /// Colour at the tip relative to the root (the root-to-tip gradient).
    #[serde(default = "default_tip")]
    pub tip_shade: f32,
    /// Alpha below which a texel is discarded (the hairs' gaps).
    #[serde(default = "default_cutoff")]
    pub alpha_cutoff: f32,
    /// Specular strength and exponent of the anisotropic highlight along the strip.
    #[serde(default = "default_specular")]
    pub specular: [f32; 2],
    /// The strips' shading; unset follows the scene's `render.shading`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shading: Option<crate::scene::Shading>,
    /// The physical mode's look (`docs/shading.md`); without melanin the pigments are fit
    /// to the layers' mean colour.
    #[serde(
        default,
        skip_serializing_if = "crate::systems::hair_bsdf::Physical::is_default"
    )]
    pub physical: crate::systems::hair_bsdf::Physical,
}

fn default_hairs() -> u32 {
    24
}
fn default_tip() -> f32 {
    1.6
}
fn default_cutoff() -> f32 {
    0.35
}
fn default_specular() -> [f32; 2] {
    [0.35, 40.0]
}

impl Default for Look {
    fn default() -> Self {
        Look {
            hairs: default_hairs(),
            tip_shade: default_tip(),
            alpha_cutoff: default_cutoff(),
            specular: default_specular(),
            shading: None,
            physical: Default::default(),
        }
    }
}

/// A key-frame edit (section 4): between `from` and `to` (frames) the strip `strip` is
/// pulled toward `target` (its tip position at frame `to`, in the head's rest frame) by the
/// extra force of eq 4, which falls off over `radius` around the strip.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Edit {
    /// Index of the strip, counting layers in order.
    pub strip: u32,
    /// First key frame.
    pub from: u32,
    /// Second key frame (> from).
    pub to: u32,
    /// Where the strip's tip should be at `to`.
    pub target: [f64; 3],
    /// Falloff radius of the extra force around the strip (world units, > 0).
    #[serde(default = "default_radius")]
    pub radius: f64,
}

fn default_radius() -> f64 {
    6.0
}

/// Check the strips block, if the scene has one, with the head it lives on.
pub fn validate(s: &Scene) -> Result<()> {
    let Some(st) = s.strips() else {
        return Ok(());
    };
    check(st)?;
    // Roots on a mesh head, checked here when the mesh can be read now, so that a root off
    // the scalp names the scene file; a mesh that cannot be read yet (a path relative to the
    // scene file is resolved after validation) is placed, and refused, when the strips are
    // built (`hom::build`), and its own errors name the mesh file.
    if s.head.mesh.is_some() {
        if let Ok(Some(mesh)) = crate::scene::hull::head_mesh(&s.head) {
            super::hom::roots_on_mesh(st, &s.head, &mesh)?;
        }
    }
    Ok(())
}

// The bounds of the strips block: one set. The scene validator checks them (`check`, with
// the file named by the loader); the runtime types run the same checks, not checks of their
// own, on blocks built in code (`hom::build`: `check_layers`; `dynamics::Rig::new` and the
// GPU pass: `check_motion`, `check_layer_stiffness`; `keyframe::solve`: `check_edits`); the
// Strips panel's sliders read them. docs/strips.md lists them.

/// Most strips in a scene (the paper's 120 with a wide margin; one GPU invocation each).
pub const MAX_STRIPS: u64 = 65_536;
/// Most sticks per strip (the GPU walks a chain in one invocation).
pub const MAX_STRIP_STICKS: u32 = 64;
/// Most key-frame edits (the GPU reads them all for every control point).
pub const MAX_STRIP_EDITS: usize = 16;
/// Most simulation steps per rendered frame.
pub const MAX_STEPS_PER_FRAME: f64 = 4096.0;
/// Largest `curl`, degrees per stick either way: a right angle. Past it each stick folds
/// back over its parent (the rest shape coils inside a stick's length), and at 180° a stick
/// lies on its parent, where the ribbon's tangent (the sum of the two sticks' directions)
/// and the joint's rest frame (the two directions' cross product) vanish.
pub const MAX_CURL: f64 = 90.0;
/// Largest layer `stiffness` (a multiplier of `motion.stiffness`).
pub const MAX_LAYER_STIFFNESS: f64 = 1e6;
/// Largest `motion.stiffness` τ, `spring` k and `collision` κ (the exact propagator takes
/// any τ; the bound keeps τ/I1 and the forces finite in f32 on the GPU).
pub const MAX_MOTION_STIFFNESS: f64 = 1e9;
/// Longest `motion.frame_time`, seconds.
pub const MAX_FRAME_TIME: f64 = 10.0;
/// Highest `motion.steps_per_second`.
pub const MAX_STEPS_PER_SECOND: f64 = 1e6;

/// Check every number of a strips block (the head's mesh placement aside: `validate`).
pub fn check(st: &Strips) -> Result<()> {
    let total = check_layers(&st.layers)?;
    check_motion(&st.motion)?;
    check_look(&st.look)?;
    check_edits(&st.edits, total)
}

/// Check the layers; the number of strips they make.
pub fn check_layers(layers: &[Layer]) -> Result<u64> {
    if layers.is_empty() {
        return Err(bad("strips.layers", "[]", "needs at least one layer"));
    }
    let mut total = 0u64;
    for (i, l) in layers.iter().enumerate() {
        check_layer(i, l)?;
        total += l.count as u64;
    }
    if total > MAX_STRIPS {
        return Err(bad(
            "strips.layers[..].count",
            total,
            &format!("the total must be at most {MAX_STRIPS} strips"),
        ));
    }
    Ok(total)
}

/// Check layer `i`.
pub fn check_layer(i: usize, l: &Layer) -> Result<()> {
    let f = |name: &str| format!("strips.layers[{i}].{name}");
    if l.count == 0 {
        return Err(bad(&f("count"), 0, "a layer needs at least one strip"));
    }
    within(&f("polar"), l.polar, 0.0, 180.0)?;
    if l.polar <= 0.0 || l.polar >= 180.0 {
        return Err(bad(
            &f("polar"),
            l.polar,
            "must be strictly between 0 and 180 degrees",
        ));
    }
    for (k, a) in l.azimuth.iter().enumerate() {
        within(&f(&format!("azimuth[{k}]")), *a, -720.0, 720.0)?;
    }
    if l.azimuth[1] < l.azimuth[0] || l.azimuth[1] - l.azimuth[0] > 360.0 {
        return Err(bad(
            &f("azimuth"),
            format!("{:?}", l.azimuth),
            "must be [from, to] with from <= to <= from + 360",
        ));
    }
    positive(&f("length"), l.length, BIG)?;
    if l.sticks == 0 || l.sticks > MAX_STRIP_STICKS {
        return Err(bad(
            &f("sticks"),
            l.sticks,
            &format!("must be in 1..={MAX_STRIP_STICKS}"),
        ));
    }
    positive(&f("width[0]"), l.width[0], BIG)?;
    positive(&f("width[1]"), l.width[1], BIG)?;
    within(&f("droop"), l.droop, 0.0, 1.0)?;
    within(&f("curl"), l.curl, -MAX_CURL, MAX_CURL)?;
    check_layer_stiffness(&f("stiffness"), l.stiffness)?;
    color(&f("color"), l.color, 1.0)
}

/// A layer's stiffness multiplier, wherever it travels (`RestStrip::stiffness` too).
pub fn check_layer_stiffness(field: &str, v: f64) -> Result<()> {
    within(field, v, 0.0, MAX_LAYER_STIFFNESS)
}

/// Check the motion (eq 1's I1, I2, τ, eq 2's k and κ, the clock).
pub fn check_motion(m: &Motion) -> Result<()> {
    positive("strips.motion.inertia", m.inertia, BIG)?;
    within("strips.motion.damping", m.damping, 0.0, BIG)?;
    within(
        "strips.motion.stiffness",
        m.stiffness,
        0.0,
        MAX_MOTION_STIFFNESS,
    )?;
    within("strips.motion.stiffness_tip", m.stiffness_tip, 0.0, 1.0)?;
    within("strips.motion.spring", m.spring, 0.0, MAX_MOTION_STIFFNESS)?;
    within(
        "strips.motion.collision",
        m.collision,
        0.0,
        MAX_MOTION_STIFFNESS,
    )?;
    positive("strips.motion.frame_time", m.frame_time, MAX_FRAME_TIME)?;
    positive(
        "strips.motion.steps_per_second",
        m.steps_per_second,
        MAX_STEPS_PER_SECOND,
    )?;
    let steps = m.frame_time * m.steps_per_second;
    if steps > MAX_STEPS_PER_FRAME {
        return Err(bad(
            "strips.motion.steps_per_second",
            m.steps_per_second,
            &format!("frame_time x steps_per_second must be at most {MAX_STEPS_PER_FRAME} steps per frame"),
        ));
    }
    Ok(())
}

fn check_look(l: &Look) -> Result<()> {
    if l.hairs == 0 || l.hairs > 256 {
        return Err(bad("strips.look.hairs", l.hairs, "must be in 1..=256"));
    }
    within("strips.look.tip_shade", l.tip_shade as f64, 0.0, 10.0)?;
    within("strips.look.alpha_cutoff", l.alpha_cutoff as f64, 0.0, 1.0)?;
    within("strips.look.specular[0]", l.specular[0] as f64, 0.0, 10.0)?;
    within("strips.look.specular[1]", l.specular[1] as f64, 1.0, 4096.0)?;
    l.physical.validate("strips.look.physical")
}

/// Check the key-frame edits of a block whose layers make `strips` strips.
pub fn check_edits(edits: &[Edit], strips: u64) -> Result<()> {
    if edits.len() > MAX_STRIP_EDITS {
        return Err(bad(
            "strips.edits",
            edits.len(),
            &format!("at most {MAX_STRIP_EDITS} key-frame edits"),
        ));
    }
    for (i, e) in edits.iter().enumerate() {
        let f = |name: &str| format!("strips.edits[{i}].{name}");
        if e.strip as u64 >= strips {
            return Err(bad(
                &f("strip"),
                e.strip,
                &format!("names no strip: the layers have {strips}"),
            ));
        }
        if e.to <= e.from {
            return Err(bad(
                &f("to"),
                e.to,
                "the second key frame must come after `from`",
            ));
        }
        vec3(&f("target"), e.target, BIG)?;
        positive(&f("radius"), e.radius, BIG)?;
    }
    Ok(())
}
