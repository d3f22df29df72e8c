//! The scene's `forces` block: the world every kind of hair lives in — gravity, keyed wind,
//! the External Force Field, and head motion (keyed, or from a motion capture). One block at
//! the scene's top level; `forces::Forces` evaluates it at the stage's clock and hands
//! it to every kind, and each kind's own block keeps only its solver settings.
//!
//! # Units: one acceleration, read by each kind through its own mass
//!
//! Gravity, wind and the EFF's cells are accelerations in world units per second squared
//! (cm/s² by the scene's convention). Each kind turns them into what its solver integrates:
//!
//! - strips (Kazama et al.): the angular springs' force per unit mass of a stick, the
//!   acceleration itself;
//! - wisps' mass–spring lattice (Sakai): `mass × acceleration` per point, from its own
//!   `springs.mass` and `springs.sub_mass`;
//! - Anjyo's projective dynamics: the force per segment `F` of the paper's recurrences, which
//!   takes every segment's mass as 1 (the paper's units, d = rho = 1), so `F` is the
//!   acceleration's number; `dynamics.density` scales only the inertia `I_i`.
//!
//! So one scene can hold several kinds under one gravity: -980 (Earth, in cm/s²) is what the
//! strips and the wisps fall under; Anjyo's paper scenes use none (their groom already holds
//! the shape), and its keyed gusts (|F| = 200) are that many cm/s² for a strip or a wisp.
//!
//! Anjyo's *groom load* (`groom_load`, the static weight the cantilever is styled under, in
//! the units of `rigidity`) is not a force of the world and stays a setting of the groom.

use serde::{Deserialize, Serialize};

/// Earth's gravity in the scene's units (cm/s²), for scenes and studies that want it.
pub const EARTH_GRAVITY: [f64; 3] = [0.0, -980.0, 0.0];

/// The world's forces (the scene's `forces` block). Every field is optional: without the
/// block there is no gravity, still air and a still head.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForcesDesc {
    /// Gravity, an acceleration (world units / s²; the module docs say how each kind reads it).
    #[serde(default)]
    pub gravity: [f64; 3],
    /// Uniform wind over time (an acceleration, like gravity); empty means none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub wind: Vec<WindKey>,
    /// Rigid head motion over time; empty means the head stays still (or follows
    /// `head_capture`). Roots follow the head, the collision hull moves with it, and hair
    /// feels the roots' acceleration.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub head_motion: Vec<HeadKey>,
    /// Head motion from a BVH motion capture (one joint's motion moves the head), read when
    /// the scene is loaded. When `head_motion` also has keys, those win.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head_capture: Option<super::bvh::HeadCapture>,
    /// The External Force Field: a grid of winds around the head that every kind with
    /// dynamics samples (`forces::eff`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eff: Option<super::eff::EffDesc>,
}

/// How a keyed value moves from this key to the next.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Interp {
    /// Hold this value until the next key (the paper's gust is a step).
    #[default]
    Step,
    /// Blend linearly towards the next key.
    Linear,
}

/// Wind from frame `frame` on (an acceleration, like gravity).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WindKey {
    pub frame: f64,
    pub force: [f64; 3],
    #[serde(default)]
    pub interp: Interp,
}

/// Head pose at frame `frame`: rotation (degrees about x, then y, then z, about the head's
/// center) and translation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadKey {
    pub frame: f64,
    #[serde(default)]
    pub rotate: [f64; 3],
    #[serde(default)]
    pub translate: [f64; 3],
    #[serde(default = "linear")]
    pub interp: Interp,
}

fn linear() -> Interp {
    Interp::Linear
}

/// Where each field of the old scene format that held a force went, for the error a file in
/// the old form gets (`scene::parse_error`): (struct the field sat in, field, the message).
pub(crate) const MOVED: &[(&str, &str, &str)] = &[
    (
        "Dynamics",
        "gravity",
        "`dynamics.gravity` moved to the scene's `forces` block: write `forces: ForcesDesc(gravity: \
         (x, y, z))` at the top level (the same numbers: an acceleration every kind reads)",
    ),
    (
        "Dynamics",
        "wind",
        "`dynamics.wind` moved to the scene's `forces` block: write `forces: ForcesDesc(wind: \
         [WindKey(...), ...])` at the top level (the same keys)",
    ),
    (
        "Dynamics",
        "head_motion",
        "`dynamics.head_motion` moved to the scene's `forces` block: write `forces: \
         ForcesDesc(head_motion: [HeadKey(...), ...])` at the top level (the same keys)",
    ),
    (
        "Scene",
        "eff",
        "the top-level `eff` moved into the scene's `forces` block: write `forces: \
         ForcesDesc(eff: Some(EffDesc(...)))` (the same block)",
    ),
    (
        "Scene",
        "head_capture",
        "the top-level `head_capture` moved into the scene's `forces` block: write `forces: \
         ForcesDesc(head_capture: Some(HeadCapture(...)))` (the same block)",
    ),
    (
        "Scene",
        "gravity",
        "the top-level `gravity` (the load Anjyo's groom is styled under, in the units of \
         `rigidity`) is now `groom_load` (the same numbers); the gravity hair in motion falls \
         under is `forces: ForcesDesc(gravity: ...)`",
    ),
    (
        "Motion",
        "gravity",
        "`strips.motion.gravity` moved to the scene's `forces` block: write `forces: \
         ForcesDesc(gravity: (x, y, z))` at the top level (the same numbers, cm/s²; the strips' \
         old default was (0.0, -980.0, 0.0), and without the block there is no gravity)",
    ),
];
