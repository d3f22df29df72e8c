//! The scene's `forces` block: the world every kind of hair lives in — gravity, keyed wind,
//! the External Force Field, and head motion (keyed, or from a motion capture). One block at
//! the scene's top level; `crate::forces::Forces` evaluates it at the stage's clock and hands
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
    /// dynamics samples (`crate::forces::eff`).
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

#[cfg(test)]
mod tests {
    use crate::error::KamiError;
    use crate::scene::Scene;

    /// A small valid scene in the old form: `field` spliced in where it used to sit.
    fn old(top: &str, dynamics: &str, motion: &str) -> String {
        format!(
            "Scene(\n    head: Head(radii: (9.6, 11.5, 7.8)),\n{top}    strips: Some(Strips(\n        \
             layers: [Layer(count: 2, polar: 60.0, azimuth: (0.0, 90.0), length: 10.0, sticks: 4)],\n        \
             motion: Motion({motion}),\n    )),\n    dynamics: Some(Dynamics({dynamics})),\n)\n"
        )
    }

    /// Every field of the old format that held a force fails with a parse error that names
    /// the file and the line, the old field and where it is now.
    #[test]
    fn old_forms_name_the_moved_field_and_where_it_goes() {
        let cases = [
            (
                old("", "gravity: (0.0, -150.0, 0.0)", ""),
                7,
                "`dynamics.gravity` moved",
                "forces: ForcesDesc(gravity:",
            ),
            (
                old(
                    "",
                    "wind: [WindKey(frame: 0.0, force: (1.0, 0.0, 0.0))]",
                    "",
                ),
                7,
                "`dynamics.wind` moved",
                "forces: ForcesDesc(wind:",
            ),
            (
                old("", "head_motion: [HeadKey(frame: 0.0)]", ""),
                7,
                "`dynamics.head_motion` moved",
                "forces: ForcesDesc(head_motion:",
            ),
            (
                old("    eff: Some(EffDesc()),\n", "", ""),
                3,
                "the top-level `eff` moved",
                "forces: ForcesDesc(eff: Some(EffDesc(",
            ),
            (
                old(
                    "    head_capture: Some(HeadCapture(file: \"x.bvh\")),\n",
                    "",
                    "",
                ),
                3,
                "the top-level `head_capture` moved",
                "ForcesDesc(head_capture:",
            ),
            (
                old("    gravity: (0.0, -1.0, 0.0),\n", "", ""),
                3,
                "is now `groom_load`",
                "forces: ForcesDesc(gravity:",
            ),
            (
                old("", "", "gravity: (0.0, -980.0, 0.0)"),
                5,
                "`strips.motion.gravity` moved",
                "forces: ForcesDesc(gravity: (x, y, z))",
            ),
        ];
        for (text, want_line, what, where_now) in cases {
            match Scene::from_ron(&text, "old.ron") {
                Err(KamiError::Parse {
                    path,
                    line,
                    message,
                    ..
                }) => {
                    assert_eq!((path.as_str(), line), ("old.ron", want_line), "{message}");
                    assert!(
                        message.contains(what) && message.contains(where_now),
                        "expected {what:?} and {where_now:?} in: {message}\n{text}"
                    );
                }
                other => panic!("expected a parse error for\n{text}\ngot {other:?}"),
            }
        }
        // The same scene in the new form loads.
        let new = old(
            "    forces: ForcesDesc(gravity: (0.0, -980.0, 0.0)),\n",
            "",
            "",
        );
        let scene = Scene::from_ron(&new, "new.ron").unwrap();
        assert_eq!(scene.forces.gravity, super::EARTH_GRAVITY);
    }

    /// Every shipped scene is in the new form and loads (its files read, every value
    /// checked); the ones that move under the world's forces say so in their `forces` block.
    #[test]
    fn every_shipped_scene_loads() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
        let mut names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "ron"))
            .collect();
        names.sort();
        assert!(
            names.len() >= 26,
            "{} scenes in {}",
            names.len(),
            dir.display()
        );
        for p in &names {
            let scene = Scene::load(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            let f = &scene.forces;
            // Strips and wisps on springs fall under Earth's gravity in every shipped scene.
            let falls =
                scene.strips.is_some() || scene.wisps.as_ref().is_some_and(|w| w.springs.is_some());
            if falls {
                assert_eq!(f.gravity, super::EARTH_GRAVITY, "{}", p.display());
            }
            if let Some(hc) = &f.head_capture {
                assert!(!hc.keys.is_empty(), "{}: the capture was read", p.display());
            }
            if let Some(e) = &f.eff {
                assert_eq!(e.file.is_some(), e.loaded.is_some(), "{}", p.display());
            }
        }
    }
}
