//! Forces over time: gravity, keyed uniform wind (a step key is the paper's gust), and a
//! keyed rigid head motion. Everything here is uniform in space and evaluated on the CPU once
//! per step; the per-root acceleration of a moving head is linear in the root's head-local
//! position, so one matrix carries it to the GPU.

use crate::scene::{Dynamics, HeadKey, Interp, WindKey};
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

/// Everything a single step needs, uniform over the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepForces {
    /// Step length (dt / substeps).
    pub h: f64,
    /// Gravity plus wind.
    pub force: DVec3,
    /// Head pose at the end of the step (roots and hull follow it).
    pub head: DMat4,
    /// Root acceleration operator: a_root = accel * (root_local, 1).
    pub accel: DMat4,
    /// Fluctuation bucket to apply at this step, if this step starts one.
    pub kick: Option<u32>,
    /// The very first substep from rest: Verlet's first step from theta^0 = theta^-1 takes
    /// half the acceleration, which keeps the start second order (theta(h) = theta0 + a h^2/2).
    pub first: bool,
}

/// Forces of step `n` (from t_n to t_n + dt) split into `substeps`, for substep `s`.
pub fn step_forces(dyn_: &Dynamics, center: DVec3, n: u64, substeps: u32, s: u32) -> StepForces {
    let spf = dyn_.steps_per_frame as f64;
    let h = dyn_.dt / substeps as f64;
    // Time in frames at the start of this substep.
    let frame = (n as f64 + s as f64 / substeps as f64) / spf;
    let df = 1.0 / (spf * substeps as f64);
    let force = DVec3::from(dyn_.gravity) + wind_at(&dyn_.wind, frame);
    // Root acceleration at the start of the step (central difference), like the force.
    let before = head_at(&dyn_.head_motion, center, frame - df);
    let now = head_at(&dyn_.head_motion, center, frame);
    let head = head_at(&dyn_.head_motion, center, frame + df);
    let accel = DMat4::from_cols(
        (head.x_axis - 2.0 * now.x_axis + before.x_axis) / (h * h),
        (head.y_axis - 2.0 * now.y_axis + before.y_axis) / (h * h),
        (head.z_axis - 2.0 * now.z_axis + before.z_axis) / (h * h),
        (head.w_axis - 2.0 * now.w_axis + before.w_axis) / (h * h),
    );
    let kick = dyn_.fluctuation.as_ref().and_then(|f| {
        let first_step_of_frame = n % dyn_.steps_per_frame as u64 == 0 && s == 0;
        let f_index = n / dyn_.steps_per_frame as u64;
        (first_step_of_frame && f_index % f.period as u64 == 0)
            .then_some((f_index / f.period as u64) as u32)
    });
    StepForces {
        h,
        force,
        head,
        accel,
        kick,
        first: n == 0 && s == 0,
    }
}
