//! The work–precision study of Kazama's angular springs (`systems::strips::dynamics`, the
//! f64 reference) on `dynamics::Setup::gust()`: the tip error of each rate against the same
//! solver at a much finer one, the observed order, the cost, and the largest stable step.
//! `kami bench strips` reports it in strips.md; the solver exposes what it needs (`Rig`:
//! pose, run frames or single steps, read points and joint rates).

use crate::error::Result;
use crate::systems::strips::block::Motion;
use crate::systems::strips::dynamics::{
    check_extra, check_motion, step_length, steps_per_frame, Env, Rig, Setup,
};
use glam::DVec3;
use std::time::Instant;

/// One line of the solver's work–precision table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrecisionRow {
    /// Effective rate (a whole number of steps per frame).
    pub steps_per_second: f64,
    /// Step length, seconds.
    pub dt: f64,
    /// Largest tip distance from the fine reference over every frame and strip (world units).
    pub tip_error: f64,
    /// The same relative to the strip's length (largest over strips).
    pub tip_error_rel: f64,
    /// Wall time of the f64 reference per strip and step, nanoseconds.
    pub ns_per_strip_step: f64,
    /// Finite with rates below `SPEED_LIMIT` × the reference's all along.
    pub stable: bool,
}

/// Trial runs whose rates pass this many times the reference's top rate count as unstable.
pub const SPEED_LIMIT: f64 = 4.0;

/// Tips of every strip at every frame (index frame × strips + strip) and the top rate.
fn tips(setup: &Setup, motion: &Motion, frames: u32) -> Result<(Vec<DVec3>, f64, u64)> {
    let mut rig = Rig::posed(&setup.rest, motion, &setup.head, setup.forces.gravity)?;
    rig.set_pose(setup.forces.head_at(0.0));
    let hull = crate::scene::hull::head_hull(&setup.head)?;
    let mut out = Vec::new();
    let mut top: f64 = 0.0;
    let stride = rig.stride();
    for f in 0..frames as u64 {
        rig.run_frames(&setup.forces, &hull, motion, &setup.extra, f, 1);
        let r = rig.max_rate();
        top = if r.is_nan() || top.is_nan() {
            f64::NAN
        } else {
            top.max(r)
        };
        let p = rig.points();
        out.extend((0..rig.strip_count()).map(|s| p[s * stride + stride - 1]));
    }
    let steps = frames as u64 * steps_per_frame(motion) as u64;
    Ok((out, top, steps))
}

/// Work against precision of the solver on `setup` over `frames` frames: for each rate in
/// `rates` (steps per second), the largest tip error against the f64 reference at 16× the
/// finest rate (at least 3840 steps/s), and the f64 cost per strip and step.
pub fn work_precision(setup: &Setup, rates: &[f64], frames: u32) -> Result<Vec<PrecisionRow>> {
    check_extra(&setup.extra)?;
    let finest = rates.iter().copied().fold(0.0, f64::max);
    let fine = Motion {
        steps_per_second: (16.0 * finest).max(3840.0),
        ..setup.motion.clone()
    };
    let (reference, top, _) = tips(setup, &fine, frames)?;
    let rig = Rig::new(&setup.rest, &setup.motion)?;
    let lengths: Vec<f64> = (0..rig.strip_count()).map(|s| rig.length(s)).collect();
    let mut rows = Vec::new();
    for &rate in rates {
        let m = Motion {
            steps_per_second: rate,
            ..setup.motion.clone()
        };
        check_motion(&m)?;
        let t = Instant::now();
        let (got, rate_top, steps) = tips(setup, &m, frames)?;
        let ns = t.elapsed().as_nanos() as f64;
        let (mut abs, mut rel) = (0.0f64, 0.0f64);
        for (i, (a, b)) in got.iter().zip(&reference).enumerate() {
            let e = (*a - *b).length();
            let e = if e.is_finite() { e } else { f64::INFINITY };
            abs = abs.max(e);
            rel = rel.max(e / lengths[i % lengths.len().max(1)]);
        }
        let stable = rate_top.is_finite() && rate_top <= SPEED_LIMIT * top && abs.is_finite();
        rows.push(PrecisionRow {
            steps_per_second: steps_per_frame(&m) as f64 / m.frame_time,
            dt: step_length(&m),
            tip_error: abs,
            tip_error_rel: rel,
            ns_per_strip_step: ns / (steps.max(1) as f64 * lengths.len().max(1) as f64),
            stable,
        });
    }
    Ok(rows)
}

/// Observed order: the least-squares slope of log error against log dt over the stable rows
/// with an error above rounding (None with fewer than two).
pub fn observed_order(rows: &[PrecisionRow]) -> Option<f64> {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.stable && r.tip_error_rel > 1e-12 && r.tip_error_rel.is_finite())
        .map(|r| (r.dt.ln(), r.tip_error_rel.ln()))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The step giving relative tip error `target` (0.01 for 1 %): log-log interpolation
/// between the rows that bracket it, else extrapolation along the observed order from the
/// nearest row. None without stable rows.
pub fn dt_for_error(rows: &[PrecisionRow], target: f64) -> Option<f64> {
    let mut r: Vec<&PrecisionRow> = rows
        .iter()
        .filter(|r| r.stable && r.tip_error_rel > 0.0 && r.tip_error_rel.is_finite())
        .collect();
    r.sort_by(|a, b| a.dt.total_cmp(&b.dt));
    for w in r.windows(2) {
        let (a, b) = (w[0], w[1]);
        if (a.tip_error_rel - target) * (b.tip_error_rel - target) <= 0.0
            && a.tip_error_rel != b.tip_error_rel
        {
            let t = (target.ln() - a.tip_error_rel.ln())
                / (b.tip_error_rel.ln() - a.tip_error_rel.ln());
            return Some((a.dt.ln() + t * (b.dt.ln() - a.dt.ln())).exp());
        }
    }
    let order = observed_order(rows)?.max(0.5);
    let near = r.iter().min_by(|a, b| {
        (a.tip_error_rel.ln() - target.ln())
            .abs()
            .total_cmp(&(b.tip_error_rel.ln() - target.ln()).abs())
    })?;
    Some(near.dt * (target / near.tip_error_rel).powf(1.0 / order))
}

/// Largest step (seconds, to 1 %) at which `setup` stays stable over `seconds` of motion,
/// stepping `Rig::step` directly (not tied to frames); searched up to `cap` seconds, which
/// it returns when every step up to it is stable.
pub fn largest_stable_dt(setup: &Setup, seconds: f64, cap: f64) -> Result<f64> {
    check_extra(&setup.extra)?;
    let fine = Motion {
        steps_per_second: 3840.0,
        ..setup.motion.clone()
    };
    let frames = (seconds / fine.frame_time).ceil().max(1.0) as u32;
    let (_, top, _) = tips(setup, &fine, frames)?;
    let limit = SPEED_LIMIT * top.max(1e-9);
    let ft = setup.motion.frame_time;
    let hull = crate::scene::hull::head_hull(&setup.head)?;
    let stable_at = |dt: f64| -> Result<bool> {
        let mut rig = Rig::posed(
            &setup.rest,
            &setup.motion,
            &setup.head,
            setup.forces.gravity,
        )?;
        rig.set_pose(setup.forces.head_at(0.0));
        let steps = (seconds / dt).ceil() as u64;
        for i in 0..steps {
            let env = Env {
                forces: &setup.forces,
                frame: i as f64 * dt / ft,
                hull: &hull,
                motion: &setup.motion,
                extra: &setup.extra,
            };
            rig.step(&env, dt);
            let r = rig.max_rate();
            let calm = r <= limit;
            if !calm {
                return Ok(false);
            }
        }
        Ok(true)
    };
    let mut lo = ft / 8.0;
    while !stable_at(lo)? {
        lo *= 0.5;
        if lo < 1e-7 {
            return Ok(0.0);
        }
    }
    let mut hi = lo * 2.0;
    while hi <= cap {
        if !stable_at(hi)? {
            break;
        }
        lo = hi;
        hi *= 2.0;
    }
    if hi > cap {
        return Ok(if stable_at(cap)? { cap } else { lo });
    }
    while hi / lo > 1.01 {
        let mid = (lo * hi).sqrt();
        if stable_at(mid)? {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(lo)
}
