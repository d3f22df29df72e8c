//! Key-frame editing (Kazama et al. section 4, eq 4): an animator picks a strip, sets a
//! first key frame, and drags the strip's tip to where it should be at a second key frame.
//! The edit becomes an extra force that joins the EFF: an acceleration `a` acting, with a
//! smooth falloff in space (`(1 − u²)³` within a radius) and in time (`sin²` between the
//! two keys), on the control points near the strip — so neighbouring strips follow a
//! little, and the motion has no jump in acceleration at either key.
//!
//! Eq 4 gives the size of the force as the constant acceleration that moves a point by the
//! wanted offset in the edit's time, `2 Δ / s²`. With the springs pulling back and the
//! ramps, that is only a first guess: `solve` refines `a` by Newton's method on the f64
//! clip of that strip (each iteration simulates the strip from frame 0 to the second key,
//! with finite differences for the Jacobian) until the tip is within `TOLERANCE` of the
//! target. Later edits are solved with the earlier ones in place.

use super::dynamics::{self, ExtraForce};
use super::RestStrip;
use crate::error::{KamiError, Result};
use crate::forces::Forces;
use crate::scene::strips::{Edit, Motion};
use crate::scene::Head;
use glam::DVec3;

/// How close (world units) the solved tip must come to the target.
pub const TOLERANCE: f64 = 0.05;
/// Newton iterations at most per edit.
const ITERATIONS: usize = 12;

/// What solving an edit did.
#[derive(Clone, Debug, PartialEq)]
pub struct Solved {
    pub extra: ExtraForce,
    /// Distance from the tip to the target at the second key, after solving.
    pub miss: f64,
    /// Newton iterations taken.
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
    let mut out: Vec<Solved> = Vec::new();
    for (i, e) in edits.iter().enumerate() {
        let strip = rest
            .get(e.strip as usize)
            .ok_or_else(|| KamiError::Invalid {
                file: String::new(),
                field: format!("strips.edits[{i}].strip"),
                value: e.strip.to_string(),
                allowed: format!("names no strip: there are {}", rest.len()),
            })?;
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
    let radius = e.radius.max(0.75 * (target - free).length());
    let seconds = f64::from(e.to - e.from) * motion.frame_time;
    // Eq 4's size: the constant acceleration that moves a point by Δ in the edit's time.
    // The sin² ramp averages one half, so twice that is the first guess.
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
        if j.determinant().abs() < 1e-30 {
            break;
        }
        let step = j.inverse() * r;
        // Damped: halve the step while it does not reduce the miss.
        let mut t = 1.0;
        loop {
            let next = a - t * step;
            let rn = miss_of(next)?;
            if rn.length() < r.length() || t < 1e-3 {
                a = next;
                r = rn;
                break;
            }
            t *= 0.5;
        }
    }
    Ok(Solved {
        extra: with(a).pop().expect("pushed"),
        miss: r.length(),
        iterations,
    })
}
