//! The strips' mouse modes in the 3D view (Kazama section 4 and the EFF brush): pick a
//! strip, drag a key-frame target, paint the EFF with a stroke. The real mouse and the
//! scripted `--set mouse.*` events both come here.

use super::params::ViewerState;
use crate::error::Result;
use crate::gpu::Gpu;
use crate::stage::Stage;
use crate::systems::strips::{panel, pick, StripsSystem};
use glam::{DVec2, DVec3};

/// Pixels the cursor moves between two dabs of a paint stroke (the stroke's direction is
/// measured over this distance).
pub const DAB_PX: f64 = 12.0;

/// What a left press in a strips mouse mode took hold of.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gesture {
    /// Dragging the target of edit `.0`, in the plane at normalised depth `.1`.
    pub target: Option<(usize, f64)>,
    /// Painting: where the last dab was.
    pub paint: Option<DVec2>,
}

impl Gesture {
    pub fn active(&self) -> bool {
        self.target.is_some() || self.paint.is_some()
    }
}

/// Whether a strips mouse mode is on and has a view to work in.
pub fn on(s: &ViewerState) -> bool {
    (s.view.edit_strips || s.view.paint_eff) && s.scene.strips.is_some() && s.world_view.is_some()
}

/// The strips as the stage poses them now (read back once per frame at most).
pub fn pose<'a>(stage: &Stage, gpu: &Gpu, s: &'a mut ViewerState) -> Result<&'a [Vec<DVec3>]> {
    let frame = stage.frame();
    if s.strip_pose.as_ref().is_none_or(|(f, _)| *f != frame) {
        let pose = match stage.system::<StripsSystem>() {
            Some(sys) => sys.pose(gpu)?,
            None => Vec::new(),
        };
        s.strip_pose = Some((frame, pose));
    }
    Ok(s.strip_pose.as_ref().map_or(&[], |(_, p)| p.as_slice()))
}

/// A left press at `cursor` (window pixels). Returns whether the mode took it (else the
/// camera orbits).
pub fn press(
    stage: &Stage,
    gpu: &Gpu,
    g: &mut Gesture,
    s: &mut ViewerState,
    cursor: DVec2,
) -> Result<bool> {
    let Some(view) = s.world_view else {
        return Ok(false);
    };
    if !on(s) || cursor.x > view.size.x || cursor.y > view.size.y {
        return Ok(false);
    }
    if s.view.paint_eff {
        if s.scene.forces.eff.is_none() {
            return Ok(false);
        }
        g.paint = Some(cursor);
        return Ok(true);
    }
    let forces = stage.ctx().forces;
    let head_at = |f: u32| forces.head_at(f64::from(f));
    let edits = s.scene.strips.as_ref().map_or(&[][..], |st| &st.edits[..]);
    if let Some(i) = pick::pick_target(edits, &head_at, &view, cursor, pick::PICK_PX) {
        let e = &edits[i];
        let depth = view
            .project(pick::target_world(e, &head_at(e.to)))
            .map_or(0.5, |q| q.z);
        g.target = Some((i, depth));
        s.key_strip = e.strip;
        // Show the clip at the second key, where the target holds the strip.
        s.view.playing = false;
        if stage.frame() != u64::from(e.to) {
            s.seek = Some(u64::from(e.to));
        }
        return Ok(true);
    }
    let hit = pick::pick_strip(pose(stage, gpu, s)?, &view, cursor, pick::PICK_PX);
    if let Some(i) = hit {
        s.key_strip = i as u32;
        s.message = Some(format!(
            "strip {i} picked: K (or the Key frames panel) sets a first key at this frame"
        ));
        return Ok(true);
    }
    Ok(false)
}

/// The cursor moved to `cursor` with the press held.
pub fn drag(stage: &Stage, g: &mut Gesture, s: &mut ViewerState, cursor: DVec2) {
    let Some(view) = s.world_view else {
        return;
    };
    if let Some((i, depth)) = g.target {
        let forces = stage.ctx().forces;
        let Some(e) = s.scene.strips.as_mut().and_then(|st| st.edits.get_mut(i)) else {
            g.target = None;
            return;
        };
        let head = forces.head_at(f64::from(e.to));
        if let Some(t) = pick::drag_target(&view, &head, depth, cursor) {
            e.target = t.to_array();
            s.seek = Some(u64::from(e.to));
        }
    }
    if let Some(last) = g.paint {
        if (cursor - last).length() < DAB_PX {
            return;
        }
        // The stroke lies in the plane through the head's centre (where the head is now)
        // facing the eye.
        let centre = stage
            .ctx()
            .head
            .transform_point3(DVec3::from(s.scene.head.center));
        let depth = view.project(centre).map_or(0.5, |q| q.z);
        let (Some(a), Some(b)) = (view.unproject(last, depth), view.unproject(cursor, depth))
        else {
            return;
        };
        let field = panel::built(&s.scene, &mut s.brush.cache);
        if let (Some(field), Some(desc)) = (field, s.scene.forces.eff.as_mut()) {
            let dir = (b - a).normalize_or_zero();
            let n = panel::paint_into(desc, &field, b, s.brush.radius, dir * s.brush.strength);
            s.message = Some(format!("painted {n} cells"));
        }
        g.paint = Some(cursor);
    }
}

/// The left button went up.
pub fn release(g: &mut Gesture) {
    *g = Gesture::default();
}
