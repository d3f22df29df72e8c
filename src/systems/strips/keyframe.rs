//! Key-frame editing (Kazama et al. section 4, eq 4): an animator picks a strip, sets a
//! first key frame, and drags the strip's tip to where it should be at a second key frame.
//! The edit becomes an extra force that joins the EFF: an acceleration `a` acting, with a
//! smooth falloff in space (`(1 − u²)³` within a radius) and in time (rising as `sin²` from
//! the first key, whole at the second so the strip is held at its target there, let go as
//! `cos²` over half the edit's length after it; `dynamics::ExtraForce::ramp`), on the
//! control points near the strip — so neighbouring strips follow a little, and the motion
//! has no jump in acceleration at either key or at the release.
//!
//! Eq 4 gives the size of the force as the constant acceleration that moves a point by the
//! wanted offset in the edit's time, `2 Δ / s²`. With the springs pulling back and the
//! ramps, that is only a first guess: `solve` refines `a` by Levenberg-Marquardt on the f64
//! clip of that strip (each iteration simulates the strip from frame 0 to the second key,
//! with finite differences for the Jacobian) until the tip is within `TOLERANCE` of the
//! target. Later edits are solved with the earlier ones in place.

use super::dynamics::{self, ExtraForce};
use super::RestStrip;
use crate::error::Result;
use crate::forces::Forces;
use crate::scene::Head;
use crate::systems::strips::block::{check_edits, Edit, Motion};
use glam::DVec3;

/// How close (world units) the solved tip must come to the target.
pub const TOLERANCE: f64 = 0.05;
/// Levenberg-Marquardt iterations at most per edit.
const ITERATIONS: usize = 30;

/// What solving an edit did.
#[derive(Clone, Debug, PartialEq)]
pub struct Solved {
    pub extra: ExtraForce,
    /// Distance from the tip to the target at the second key, after solving.
    pub miss: f64,
    /// Iterations taken.
    pub iterations: usize,
}

/// The tip of strip `strip` at frame `to` under `extra` (the strip alone: strips interact
/// only through the forces, which do not depend on other strips).
fn tip_at(
    rest: &RestStrip,
    motion: &Motion,
    forces: &Forces,
    head: &Head,
    extra: &[ExtraForce],
    to: u32,
) -> Result<DVec3> {
    let clip = dynamics::simulate(std::slice::from_ref(rest), motion, forces, head, extra, to)?;
    // One strip: its stride is its own point count, and the last point is the tip.
    Ok(clip
        .last()
        .and_then(|f| f.last())
        .copied()
        .unwrap_or(DVec3::ZERO))
}

/// Solve every edit in order; each sees the extra forces of the ones before it.
pub fn solve(
    rest: &[RestStrip],
    motion: &Motion,
    forces: &Forces,
    head: &Head,
    edits: &[Edit],
) -> Result<Vec<Solved>> {
    // The block's own check of the edits (its bounds and messages), against these strips.
    check_edits(edits, rest.len() as u64)?;
    let mut out: Vec<Solved> = Vec::new();
    for e in edits {
        // In range: `check_edits` compared every index with `rest.len()`.
        let strip = &rest[e.strip as usize];
        let before: Vec<ExtraForce> = out.iter().map(|s| s.extra).collect();
        out.push(solve_one(strip, e, motion, forces, head, &before)?);
    }
    Ok(out)
}

fn solve_one(
    strip: &RestStrip,
    e: &Edit,
    motion: &Motion,
    forces: &Forces,
    head: &Head,
    before: &[ExtraForce],
) -> Result<Solved> {
    let target = forces
        .head_at(f64::from(e.to))
        .transform_point3(DVec3::from(e.target));
    let free = tip_at(strip, motion, forces, head, before, e.to)?;
    // The force acts around the way from the free tip to the target.
    let center = 0.5 * (free + target);
    // Wide enough that the force is nearly even along the way (0.82 of its peak at the ends).
    let radius = e.radius.max(2.0 * (target - free).length());
    let seconds = f64::from(e.to - e.from) * motion.frame_time;
    // Eq 4's size: the constant acceleration that moves a point by Δ in the edit's time.
    // The rising ramp averages one half over the edit, so twice that is the first guess.
    let mut a = 2.0 * 2.0 * (target - free) / (seconds * seconds);
    let with = |a: DVec3| {
        let mut all = before.to_vec();
        all.push(ExtraForce {
            strip: e.strip,
            from: f64::from(e.from),
            to: f64::from(e.to),
            center,
            radius,
            accel: a,
        });
        all
    };
    let miss_of = |a: DVec3| -> Result<DVec3> {
        Ok(tip_at(strip, motion, forces, head, &with(a), e.to)? - target)
    };
    let mut r = miss_of(a)?;
    let mut iterations = 0;
    while r.length() > TOLERANCE && iterations < ITERATIONS {
        iterations += 1;
        // Jacobian d tip / d a by forward differences, one column per axis.
        let h = (a.length() * 1e-3).max(1.0);
        let mut cols = [DVec3::ZERO; 3];
        for (k, col) in cols.iter_mut().enumerate() {
            let mut da = DVec3::ZERO;
            da[k] = h;
            *col = (miss_of(a + da)? - r) / h;
        }
        let j = glam::DMat3::from_cols(cols[0], cols[1], cols[2]);
        // Levenberg-Marquardt: a force along a hanging strip hardly moves it (no torque),
        // so J is near singular in that direction and a plain Newton step would run off
        // along it. Damping λ grows until a step reduces the miss; stop when none does.
        let jtj = j.transpose() * j;
        let g = j.transpose() * r;
        let mut lambda = 1e-3 * (jtj.x_axis.x + jtj.y_axis.y + jtj.z_axis.z) / 3.0;
        let mut better = None;
        for _ in 0..8 {
            let m = jtj + glam::DMat3::from_diagonal(DVec3::splat(lambda));
            if m.determinant().abs() < 1e-300 {
                break;
            }
            let next = a - m.inverse() * g;
            let rn = miss_of(next)?;
            if rn.length() < r.length() {
                better = Some((next, rn));
                break;
            }
            lambda *= 10.0;
        }
        match better {
            Some((next, rn)) => {
                a = next;
                r = rn;
            }
            None => break,
        }
    }
    Ok(Solved {
        extra: with(a).pop().expect("pushed"),
        miss: r.length(),
        iterations,
    })
}
