//! The force fields every hair system samples, in one place: gravity, keyed uniform wind (a
//! step key is Anjyo's gust) and a keyed rigid head motion, from the scene's `forces` block
//! (`scene::forces`, where the units are). The stage builds one `Forces`
//! from the scene and hands it to every system each frame with the clock (`FrameCtx`); the
//! head pass and the systems' roots take the head pose from here, so everything in a frame
//! agrees on where the head is. Everything here is uniform in space and evaluated on the CPU
//! once per step; the per-root acceleration of a moving head is linear in the root's
//! head-local position, so one matrix carries it to the GPU. The one field that varies in
//! space is the External Force Field (`eff`): a grid of winds around the head, sampled per
//! point (`Forces::wind_at_point`, and the stage's `systems::world::WorldGpu` + `shaders/forces/eff.wgsl` on the GPU).

pub mod eff;

use crate::scene::{ForcesDesc, Head, HeadKey, Interp, WindKey};
use glam::{DMat4, DQuat, DVec3, EulerRot};

/// Wind force at `frame` (fractional).
pub fn wind_at(keys: &[WindKey], frame: f64) -> DVec3 {
    keyed(
        keys,
        frame,
        |k| k.frame,
        |k| k.interp,
        |k| DVec3::from(k.force),
        |a, b, t| a.lerp(b, t),
    )
    .unwrap_or(DVec3::ZERO)
}

/// Head pose at `frame`: rotation about `center` then translation. Identity without keys.
pub fn head_at(keys: &[HeadKey], center: DVec3, frame: f64) -> DMat4 {
    let pose = keyed(
        keys,
        frame,
        |k| k.frame,
        |k| k.interp,
        |k| (DVec3::from(k.rotate), DVec3::from(k.translate)),
        |a, b, t| (a.0.lerp(b.0, t), a.1.lerp(b.1, t)),
    );
    match pose {
        None => DMat4::IDENTITY,
        Some((rot, tr)) => {
            let r = rot * (std::f64::consts::PI / 180.0);
            let q = DQuat::from_euler(EulerRot::ZYX, r.z, r.y, r.x);
            DMat4::from_translation(center + tr)
                * DMat4::from_quat(q)
                * DMat4::from_translation(-center)
        }
    }
}

/// Piecewise evaluation of sorted keys; before the first key its value holds.
fn keyed<K, V: Copy>(
    keys: &[K],
    frame: f64,
    at: impl Fn(&K) -> f64,
    interp: impl Fn(&K) -> Interp,
    value: impl Fn(&K) -> V,
    lerp: impl Fn(V, V, f64) -> V,
) -> Option<V> {
    let first = keys.first()?;
    if frame <= at(first) {
        return Some(value(first));
    }
    let i = keys.partition_point(|k| at(k) <= frame) - 1;
    let k = &keys[i];
    match (interp(k), keys.get(i + 1)) {
        (Interp::Linear, Some(next)) => {
            let t = (frame - at(k)) / (at(next) - at(k));
            Some(lerp(value(k), value(next), t))
        }
        _ => Some(value(k)),
    }
}

/// The scene's shared force fields, evaluated from its `forces` block (`scene::forces`, which
/// also says how each kind reads these accelerations).
#[derive(Clone, Debug, PartialEq)]
pub struct Forces {
    pub gravity: DVec3,
    pub wind: Vec<WindKey>,
    pub head_motion: Vec<HeadKey>,
    /// The head's centre: keyed rotations turn about it.
    pub center: DVec3,
    /// The External Force Field (built once from the block's `eff`).
    pub eff: Option<std::sync::Arc<eff::Eff>>,
}

impl Forces {
    /// The world's forces of a scene's `forces` block, about its head (`head.center`, the
    /// point head motion turns about).
    pub fn new(f: &ForcesDesc, head: &Head) -> Forces {
        // Keyed head motion wins; else a head capture's keys (read when the scene loaded).
        let head_motion = match (&f.head_motion, &f.head_capture) {
            (keys, _) if !keys.is_empty() => keys.clone(),
            (_, Some(capture)) => capture.keys.clone(),
            _ => Vec::new(),
        };
        Forces {
            gravity: DVec3::from(f.gravity),
            wind: f.wind.clone(),
            head_motion,
            center: DVec3::from(head.center),
            eff: eff_of(f),
        }
    }

    /// Gravity plus wind at `frame` (fractional): uniform over space.
    pub fn uniform_at(&self, frame: f64) -> DVec3 {
        self.gravity + wind_at(&self.wind, frame)
    }

    /// The head pose at `frame` (fractional).
    pub fn head_at(&self, frame: f64) -> DMat4 {
        head_at(&self.head_motion, self.center, frame)
    }

    /// The wind at world point `p` at `frame`: the uniform keyed wind plus the EFF (scaled
    /// by its gust keys at `frame`).
    pub fn wind_at_point(&self, p: DVec3, frame: f64, sampling: crate::scene::Sampling) -> DVec3 {
        wind_at(&self.wind, frame) + self.eff_at(p, frame, sampling)
    }

    /// The EFF alone at `p` and `frame` (zero without one).
    pub fn eff_at(&self, p: DVec3, frame: f64, sampling: crate::scene::Sampling) -> DVec3 {
        self.eff
            .as_ref()
            .map_or(DVec3::ZERO, |e| e.sample_at(p, frame, sampling))
    }

    /// The EFF's gust scale at `frame` (0 without an EFF: kernels multiply the unscaled
    /// field by it).
    pub fn eff_scale(&self, frame: f64) -> f64 {
        self.eff.as_ref().map_or(0.0, |e| e.scale_at(frame))
    }

    /// Whether the head moves at all.
    pub fn head_moves(&self) -> bool {
        !self.head_motion.is_empty()
    }
}

/// The scene's EFF, built (its files were read and checked when the scene was loaded).
fn eff_of(f: &ForcesDesc) -> Option<std::sync::Arc<eff::Eff>> {
    let desc = f.eff.as_ref()?;
    match eff::Eff::build(desc) {
        Ok(e) => Some(std::sync::Arc::new(e)),
        Err(e) => {
            log::warn!("EFF not built: {e}");
            None
        }
    }
}
