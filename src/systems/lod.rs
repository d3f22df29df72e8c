//! Level of detail by screen-space size, shared by strand hair (Anjyo) and fur.
//!
//! From an object's bounding sphere, the eye, the vertical field of view and the target's
//! height in pixels:
//!
//! - **Strand share** `a = min(1, d_full / d)`, `d_full = r / sin(fov / 2)` the distance at
//!   which the sphere fills the frame's height (Van Gelder & Wilhelms' distance culling, 3.3,
//!   which the fur used alone before). Drawn strands are widened by `1 / a`: the summed
//!   area of the drawn ribbons, hence the expected coverage of each pixel (with stochastic
//!   coverage, `1 - exp(-n w)` for n strands of coverage w), stays that of full detail,
//!   and a drawn strand keeps the width in pixels it had when the object filled the frame.
//!   At the scene's own camera, where the head fills the frame, `a = 1`: nothing changes.
//! - **Segment step** `k`: every k-th node is drawn (and the last). A polyline of k
//!   segments of length `l` that turns by at most `theta` per node departs from its chord
//!   by at most its sagitta, about `k^2 l theta / 8`; `k` is the largest step whose sagitta,
//!   in pixels at the sphere's nearest point, stays under the tolerance
//!   (`render.lod_tolerance_px`, 0.5 px by default; 0 turns the screen-space level of detail
//!   off). The turn per node is not known for moving hair: [`NOMINAL_TURN`] is assumed.
//!
//! The viewer's frame-budget share (`View::lod`) multiplies on top of the strand share.

use glam::DVec3;

/// The turn per node (radians) the segment step assumes: 20 degrees. Groomed and simulated
/// strands bend less than this at most nodes; where they bend more, the chord error grows in
/// proportion (twice the tolerance at 40 degrees).
pub const NOMINAL_TURN: f64 = 0.35;

/// The largest segment step (a strand is never drawn with fewer nodes than this allows).
pub const MAX_STEP: u32 = 8;

/// The smallest strand share (a far object keeps a few strands).
pub const MIN_SHARE: f64 = 1e-3;

/// What an object draws at its size on screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenLod {
    /// Share of the strands drawn (before the viewer's budget): 0..=1.
    pub share: f64,
    /// Width factor of the drawn strands: `1 / share`.
    pub width_scale: f64,
    /// Every `step`-th node is drawn.
    pub step: u32,
}

impl ScreenLod {
    /// Full detail.
    pub const FULL: ScreenLod = ScreenLod {
        share: 1.0,
        width_scale: 1.0,
        step: 1,
    };
}

/// How an object is seen: its bounding sphere, the camera and the target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Seen {
    pub center: DVec3,
    pub radius: f64,
    pub eye: DVec3,
    /// Vertical field of view, radians.
    pub fov_y: f64,
    /// Height of the target in pixels.
    pub height_px: f64,
}

impl Seen {
    fn distance(&self) -> f64 {
        (self.eye - self.center).length()
    }

    /// Pixels per world unit at the sphere's nearest point (infinite with the eye inside).
    pub fn px_per_unit(&self) -> f64 {
        let near = self.distance() - self.radius;
        if near <= 0.0 {
            return f64::INFINITY;
        }
        self.height_px / (2.0 * (0.5 * self.fov_y).tan() * near)
    }
}

/// The strand share at `distance` from a sphere of `radius`: 1 up to `full` (by default the
/// distance at which it fills the frame's height), then `full / distance`.
pub fn strand_share(radius: f64, distance: f64, fov_y: f64, full: Option<f64>) -> f64 {
    let full = full.unwrap_or_else(|| radius / (0.5 * fov_y).sin());
    (full / distance.max(1e-9)).clamp(MIN_SHARE, 1.0)
}

/// The largest node step whose chord error (sagitta `k^2 l theta / 8`, in pixels at
/// `px_per_unit`) stays under `tolerance_px`; 1 (every node) when `tolerance_px` is 0.
pub fn segment_step(seg_len: f64, turn: f64, px_per_unit: f64, tolerance_px: f64) -> u32 {
    let per_k2 = seg_len * turn * px_per_unit / 8.0;
    if tolerance_px <= 0.0 || !per_k2.is_finite() {
        return 1;
    }
    if per_k2 <= 0.0 {
        return MAX_STEP;
    }
    ((tolerance_px / per_k2).sqrt().floor() as u32).clamp(1, MAX_STEP)
}

/// Strand share, width compensation and segment step for an object `seen` so, with strands'
/// longest segment `seg_len`; full detail when `tolerance_px` is 0.
pub fn screen_lod(seen: &Seen, seg_len: f64, tolerance_px: f64) -> ScreenLod {
    if tolerance_px <= 0.0 {
        return ScreenLod::FULL;
    }
    let share = strand_share(seen.radius, seen.distance(), seen.fov_y, None);
    ScreenLod {
        share,
        width_scale: 1.0 / share,
        step: segment_step(seg_len, NOMINAL_TURN, seen.px_per_unit(), tolerance_px),
    }
}

/// Nodes drawn of a strand of `segments` segments at `step` (the root, every step-th node
/// and the last).
pub fn drawn_nodes(segments: u32, step: u32) -> u32 {
    segments.div_ceil(step.max(1)) + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seen(distance: f64) -> Seen {
        Seen {
            center: DVec3::ZERO,
            radius: 1.0,
            eye: DVec3::new(0.0, 0.0, distance),
            fov_y: 0.6,
            height_px: 800.0,
        }
    }

    #[test]
    fn full_detail_while_the_sphere_fills_the_frame() {
        let full = 1.0 / 0.3f64.sin();
        let l = screen_lod(&seen(full * 0.99), 0.05, 0.5);
        assert_eq!(l.share, 1.0);
        assert_eq!(l.step, 1);
        assert_eq!(screen_lod(&seen(50.0), 0.05, 0.0), ScreenLod::FULL);
    }

    #[test]
    fn share_falls_with_distance_and_widths_compensate() {
        let full = 1.0 / 0.3f64.sin();
        let l = screen_lod(&seen(4.0 * full), 0.05, 0.5);
        assert!((l.share - 0.25).abs() < 1e-12);
        assert!((l.width_scale * l.share - 1.0).abs() < 1e-12);
    }

    #[test]
    fn step_keeps_the_sagitta_under_the_tolerance() {
        for d in [5.0, 20.0, 80.0, 300.0] {
            let s = seen(d);
            let k = segment_step(0.1, NOMINAL_TURN, s.px_per_unit(), 0.5) as f64;
            let sag = |k: f64| k * k * 0.1 * NOMINAL_TURN / 8.0 * s.px_per_unit();
            assert!(k == 1.0 || sag(k) <= 0.5, "{d}: {k}");
            assert!(k == MAX_STEP as f64 || sag(k + 1.0) > 0.5, "{d}: {k}");
        }
        assert_eq!(drawn_nodes(18, 4), 6);
        assert_eq!(drawn_nodes(18, 1), 19);
    }
}
