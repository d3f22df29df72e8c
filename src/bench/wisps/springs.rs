//! The work–precision study of Sakai's mass springs (`systems::wisps::springs`, the f64
//! reference): RK4 and semi-implicit Euler against RK4 at a finer step, the observed order,
//! the cost per step and the largest stable step (found by bisection, and the linear bound
//! from the lattice's stiffest mode). `kami bench wisps` reports it in wisps.md; the solver
//! exposes what it needs (`step`, `run_frames`, `max_speed`, `bounded`, `reach`,
//! `omega_max_at`, `primary_error`).

use crate::error::{KamiError, Result};
use crate::forces::Forces;
use crate::scene::Head;
use crate::systems::wisps::block::{Integrator, Wisps};
use crate::systems::wisps::springs::{
    bounded, max_speed, omega_max, omega_max_at, primary_error, reach, run_frames, step, Lattice,
    Motion, State,
};
use std::time::Instant;

/// One line of the work-precision table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    pub integrator: Integrator,
    /// Steps per frame.
    pub substeps: u32,
    /// Step length, seconds.
    pub dt: f64,
    /// Largest primary position error against the reference after the run (world units);
    /// infinite when the run was unstable.
    pub error: f64,
    /// Observed order from the previous (coarser) row of the same integrator.
    pub order: Option<f64>,
    /// Finite, within `reach` and below `SPEED_LIMIT` times the reference's top speed all
    /// along the run.
    pub stable: bool,
    /// Wall time per step of this f64 reference, nanoseconds.
    pub ns_per_step: f64,
    /// Largest stable step (seconds): the smaller of `empirical_stable_dt` and
    /// `predicted_stable_dt`, less `STABLE_MARGIN`.
    pub largest_stable_dt: f64,
    /// Largest step found stable over the same run (bisection to 0.5%).
    pub empirical_stable_dt: f64,
    /// The linear bound: 2 sqrt 2 / omega_max (RK4) or 2 / omega_max (semi-implicit Euler),
    /// omega_max the largest over the rest pose and every frame of the reference.
    pub predicted_stable_dt: f64,
}

/// A run counts as stable while finite, every point within `reach` of its root and no point
/// faster than `speed`. Speed is the sharp test: an explicit step past its limit makes the
/// stiffest modes grow by a large factor per step, which the springs can keep within reach
/// (a tangled but finite lattice) but not slow down.
#[derive(Clone, Copy, Debug)]
struct Bounds {
    reach: f64,
    speed: f64,
}

/// Simulate `frames` frames with steps of about `dframes` frames (rounded to fit); the
/// state, the steps and the top speed, or Err(()) once out of `bounds`.
fn run_for(
    lattice: &Lattice,
    motion: &Motion,
    forces: &Forces,
    frames: f64,
    dframes: f64,
    bounds: Bounds,
) -> std::result::Result<(State, u64, f64), ()> {
    let mut st = State::rest(lattice);
    let steps = (frames / dframes).round().max(1.0) as u64;
    let dframes = frames / steps as f64;
    let mut top: f64 = 0.0;
    for i in 0..steps {
        step(
            lattice,
            motion,
            forces,
            &mut st,
            i as f64 * dframes,
            dframes,
        );
        let speed = max_speed(&st);
        top = top.max(speed);
        let fast = speed.is_nan() || speed > bounds.speed;
        if fast || (i % 16 == 15 && !bounded(lattice, &st, bounds.reach)) {
            return Err(());
        }
    }
    if !bounded(lattice, &st, bounds.reach) {
        return Err(());
    }
    Ok((st, steps, top))
}

/// Trial runs faster than this many times the reference's top speed count as blown up.
pub const SPEED_LIMIT: f64 = 4.0;
/// Share taken off the largest stable step the table reports: the stability edge is a cliff
/// (a 10 s run 0.1% past the 1 s edge blew up after 1.3 s in the stiff test).
pub const STABLE_MARGIN: f64 = 0.02;

/// Work against precision of RK4 and semi-implicit Euler for `wisps` (with their springs
/// settings) under `forces` (a head shake, say): for each number of substeps per frame in
/// `ladder`, the largest primary error after `seconds` against RK4 at 4x the finest ladder
/// entry, the observed order, whether it stayed bounded, the time per step, and the largest
/// stable step of each integrator found by bisection (plus the linear prediction).
pub fn work_precision(
    wisps: &Wisps,
    head: &Head,
    forces: &Forces,
    seconds: f64,
    ladder: &[u32],
) -> Result<Vec<Row>> {
    let springs = wisps.springs.clone().unwrap_or_default();
    let lattice = Lattice::build(wisps, &springs, head, forces)?;
    let base = Motion::new(&springs, head)?;
    let frames = (seconds / springs.frame_time).round().max(1.0);
    let mut bounds = Bounds {
        reach: reach(&lattice),
        speed: f64::INFINITY,
    };
    let finest = ladder.iter().copied().max().unwrap_or(1) * 4;
    // The reference, frame by frame: its top speed bounds the trials, and the lattice's
    // stiffest frequency along it (stretched springs stiffen) gives the linear bound.
    let m = Motion {
        integrator: Integrator::Rk4,
        substeps: finest,
        ..base.clone()
    };
    let mut reference = State::rest(&lattice);
    let mut omega = omega_max(&lattice);
    let mut top: f64 = 0.0;
    for f in 0..frames as u64 {
        run_frames(&lattice, &m, forces, &mut reference, f, 1);
        top = top.max(max_speed(&reference));
        if !(top.is_finite() && bounded(&lattice, &reference, bounds.reach)) {
            return Err(KamiError::Invalid {
                file: String::new(),
                field: "wisps.springs.stiffness".into(),
                value: format!("{}", springs.stiffness),
                allowed: format!(
                    "the RK4 reference at {finest} substeps per frame blows up; use softer springs"
                ),
            });
        }
        omega = omega.max(omega_max_at(&lattice, &reference.x));
    }
    bounds.speed = SPEED_LIMIT * top.max(1e-300);
    let mut rows = Vec::new();
    for integrator in [Integrator::Rk4, Integrator::SemiImplicitEuler] {
        let m = Motion {
            integrator,
            ..base.clone()
        };
        let stable_at = |dt: f64| {
            run_for(
                &lattice,
                &m,
                forces,
                frames,
                dt / springs.frame_time,
                bounds,
            )
            .is_ok()
        };
        let start = rows.len();
        let mut ladder = ladder.to_vec();
        ladder.sort_unstable();
        for &s in &ladder {
            let dframes = 1.0 / s as f64;
            let t = Instant::now();
            let run = run_for(&lattice, &m, forces, frames, dframes, bounds);
            let ns = t.elapsed().as_nanos() as f64;
            let (error, stable, steps) = match &run {
                Ok((st, steps, _)) => (primary_error(&lattice, st, &reference), true, *steps),
                Err(()) => (f64::INFINITY, false, 1),
            };
            rows.push(Row {
                integrator,
                substeps: s,
                dt: springs.frame_time / s as f64,
                error,
                order: None,
                stable,
                ns_per_step: if stable { ns / steps as f64 } else { f64::NAN },
                largest_stable_dt: 0.0,
                empirical_stable_dt: 0.0,
                predicted_stable_dt: if integrator == Integrator::Rk4 {
                    2.0 * std::f64::consts::SQRT_2 / omega
                } else {
                    2.0 / omega
                },
            });
        }
        for i in start + 1..rows.len() {
            let (a, b) = (rows[i - 1], rows[i]);
            if a.stable && b.stable && a.error > 0.0 && b.error > 0.0 {
                rows[i].order = Some((a.error / b.error).ln() / (a.dt / b.dt).ln());
            }
        }
        // Bracket then bisect the largest stable step.
        let mut lo = rows[start..]
            .iter()
            .filter(|r| r.stable)
            .map(|r| r.dt)
            .fold(0.0, f64::max);
        if lo == 0.0 {
            lo = springs.frame_time / finest as f64;
            while lo > 1e-9 && !stable_at(lo) {
                lo *= 0.5;
            }
        }
        let mut hi = lo * 2.0;
        while hi < 4.0 * springs.frame_time && stable_at(hi) {
            lo = hi;
            hi *= 2.0;
        }
        while hi / lo > 1.005 {
            let mid = (lo * hi).sqrt();
            if stable_at(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        // Past the linear bound the stiffest mode grows, slowly enough near it to pass a
        // short trial, and the bound itself moves as the lattice deforms: report the smaller
        // of the two less `STABLE_MARGIN`.
        let predicted = rows[start].predicted_stable_dt;
        for r in &mut rows[start..] {
            r.largest_stable_dt = (1.0 - STABLE_MARGIN) * lo.min(predicted);
            r.empirical_stable_dt = lo;
        }
    }
    Ok(rows)
}
