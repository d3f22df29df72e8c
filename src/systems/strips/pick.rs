//! The mouse in the strips' editing mode (Kazama section 4: pick a strip, set a first key,
//! drag its target at the second key) and the key-frame timeline's geometry. Pure functions
//! of the projected view, so the viewer's gestures are tested without a window.

use crate::gpu::view::ScreenView as View;
use crate::systems::strips::block::Edit;
use glam::{DMat4, DVec2, DVec3};

/// How near (pixels) the cursor must come to a strip's centre line or a target marker.
pub const PICK_PX: f64 = 8.0;

/// Distance from `p` to the segment `a`–`b` (pixels) and where along it (0..1).
fn to_segment(p: DVec2, a: DVec2, b: DVec2) -> (f64, f64) {
    let d = b - a;
    let t = if d.length_squared() > 1e-18 {
        ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((a + d * t - p).length(), t)
}

/// The strip whose drawn centre line passes nearest `cursor`, within `radius_px`; among
/// strips within a pixel of the nearest distance the one nearest the eye wins (a strip in
/// front hides the ones behind). `strips` are world-space polylines as the GPU last posed
/// them; `view` projects world points.
pub fn pick_strip(
    strips: &[Vec<DVec3>],
    view: &View,
    cursor: DVec2,
    radius_px: f64,
) -> Option<usize> {
    let mut best: Option<(f64, f64, usize)> = None;
    for (i, pts) in strips.iter().enumerate() {
        let proj: Vec<Option<DVec3>> = pts.iter().map(|p| view.project(*p)).collect();
        for w in proj.windows(2) {
            let (Some(a), Some(b)) = (w[0], w[1]) else {
                continue;
            };
            let (d, t) = to_segment(cursor, a.truncate(), b.truncate());
            if d > radius_px {
                continue;
            }
            let depth = a.z + (b.z - a.z) * t;
            let better = match best {
                None => true,
                Some((bd, bz, _)) => d < bd - 1.0 || (d < bd + 1.0 && depth < bz),
            };
            if better {
                best = Some((d, depth, i));
            }
        }
    }
    best.map(|(_, _, i)| i)
}

/// Where a target marker is in the world: targets are kept in the head's rest frame and
/// carried by the head pose at the edit's second key.
pub fn target_world(e: &Edit, head_at_to: &DMat4) -> DVec3 {
    head_at_to.transform_point3(DVec3::from(e.target))
}

/// The edit whose target marker is nearest `cursor` within `radius_px` (`head_at` gives the
/// head pose at a frame).
pub fn pick_target(
    edits: &[Edit],
    head_at: &dyn Fn(u32) -> DMat4,
    view: &View,
    cursor: DVec2,
    radius_px: f64,
) -> Option<usize> {
    edits
        .iter()
        .enumerate()
        .filter_map(|(i, e)| {
            let q = view.project(target_world(e, &head_at(e.to)))?;
            let d = (q.truncate() - cursor).length();
            (d <= radius_px).then_some((d, i))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, i)| i)
}

/// The target under `cursor` at the depth the marker had when the drag began (`depth`, the
/// normalised device z from `View::project`): the marker moves in the plane facing the eye,
/// as a drag in a 3D view does. Returned in the head's rest frame at the second key.
pub fn drag_target(view: &View, head_at_to: &DMat4, depth: f64, cursor: DVec2) -> Option<DVec3> {
    let world = view.unproject(cursor, depth)?;
    let rest = head_at_to.inverse().transform_point3(world);
    rest.is_finite().then_some(rest)
}

/// The key-frame timeline's geometry: frames 0..=`frames` across `width` pixels from `left`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timeline {
    pub left: f64,
    pub width: f64,
    pub frames: u32,
}

/// What a press on the timeline takes hold of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimelineGrab {
    /// The clock: the press scrubs.
    Scrub,
    /// The first key of edit `.0`.
    From(usize),
    /// The second key of edit `.0`.
    To(usize),
}

impl Timeline {
    /// The frames a timeline shows: all keys and the current frame with room after them,
    /// at least four seconds at 30 fps.
    pub fn span(edits: &[Edit], frame: u64, clip: Option<u32>) -> u32 {
        let last_key = edits
            .iter()
            .map(|e| u64::from(e.to) + u64::from(e.to.saturating_sub(e.from)) / 2)
            .max();
        let want = [
            120,
            last_key.map_or(0, |k| k + 30),
            frame.saturating_add(30),
            u64::from(clip.unwrap_or(0)),
        ];
        want.into_iter()
            .max()
            .unwrap_or(120)
            .min(u64::from(u32::MAX)) as u32
    }

    pub fn x_of(&self, frame: f64) -> f64 {
        self.left + self.width * frame / f64::from(self.frames.max(1))
    }

    /// The whole frame nearest `x` (clamped to the timeline).
    pub fn frame_at(&self, x: f64) -> u32 {
        let f = (x - self.left) / self.width.max(1e-9) * f64::from(self.frames.max(1));
        f.round().clamp(0.0, f64::from(self.frames)) as u32
    }

    /// A press at `x` in the row of edit `row` (None: the frame ruler): a key handle within
    /// `radius_px` is taken (the nearer of the two), anything else scrubs.
    pub fn grab(&self, edits: &[Edit], row: Option<usize>, x: f64, radius_px: f64) -> TimelineGrab {
        let Some(e) = row.and_then(|r| edits.get(r).map(|e| (r, e))) else {
            return TimelineGrab::Scrub;
        };
        let (i, e) = e;
        let df = (self.x_of(f64::from(e.from)) - x).abs();
        let dt = (self.x_of(f64::from(e.to)) - x).abs();
        if df.min(dt) > radius_px {
            TimelineGrab::Scrub
        } else if dt <= df {
            TimelineGrab::To(i)
        } else {
            TimelineGrab::From(i)
        }
    }
}

/// Move a key of `e` to `frame`, keeping the first key before the second.
pub fn move_key(e: &mut Edit, grab: TimelineGrab, frame: u32) {
    match grab {
        TimelineGrab::From(_) => e.from = frame.min(e.to.saturating_sub(1)),
        TimelineGrab::To(_) => e.to = frame.max(e.from + 1),
        TimelineGrab::Scrub => {}
    }
}

/// The GPU's control points (`stride` slots per strip, `lens[i]` used by strip `i`) as one
/// world-space polyline per strip.
pub fn polylines(points: &[[f32; 4]], stride: usize, lens: &[usize]) -> Vec<Vec<DVec3>> {
    lens.iter()
        .enumerate()
        .map(|(i, &n)| {
            let start = i * stride;
            points
                .get(start..start + n.min(stride))
                .unwrap_or(&[])
                .iter()
                .map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_distance() {
        let (d, t) = to_segment(DVec2::new(1.0, 1.0), DVec2::ZERO, DVec2::new(2.0, 0.0));
        assert!((d - 1.0).abs() < 1e-12 && (t - 0.5).abs() < 1e-12);
        let (d, t) = to_segment(DVec2::new(-3.0, 4.0), DVec2::ZERO, DVec2::new(2.0, 0.0));
        assert!((d - 5.0).abs() < 1e-12 && t == 0.0);
    }
}
