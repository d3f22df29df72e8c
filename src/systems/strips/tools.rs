//! The strips' state in the viewer and their mouse modes (Kazama section 4 and the EFF
//! brush): pick a strip, drag a key-frame target, paint the EFF with a stroke; the targets,
//! the picked strip and the field's arrows over the view; the key `K`; and the strips'
//! `--set` keys. The real mouse and the scripted `--set mouse.*` events both come here. The
//! viewer hosts it as a `KindUi` and knows none of it.

use super::panel::{self, Brush};
use super::pick::{self, TimelineGrab};
use super::StripsSystem;
use crate::error::{KamiError, Result};
use crate::gpu::Gpu;
use crate::systems::scene::Scene;
use crate::systems::system::{FrameCtx, HairSystem};
use crate::systems::ui::{self, Host, Key, KindUi, Mods, Tool};
use glam::{DVec2, DVec3};

/// Pixels the cursor moves between two dabs of a paint stroke (the stroke's direction is
/// measured over this distance).
pub const DAB_PX: f64 = 12.0;

/// How the strips' mouse mode is used, under the panels while it is on.
pub const MOUSE_HELP: &str =
    "Strips: click a strip to pick it · K: first key now · drag a pink marker: move its target";

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

/// The strips' viewer state.
#[derive(Clone, Debug, PartialEq)]
pub struct StripsUi {
    /// The EFF panel's brush and file path.
    pub brush: Brush,
    /// The Key frames panel's strip and edit length.
    pub key_strip: u32,
    pub key_span: u32,
    /// What the timeline's pointer holds, and the timeline's length (frames) when it took
    /// hold.
    pub timeline_grab: Option<(TimelineGrab, u32)>,
    /// The strips as last read back for the mouse mode: (frame, world polylines).
    pub pose: Option<(u64, Vec<Vec<DVec3>>)>,
    /// The mouse mode of the Key frames panel: a left press on a target marker drags it,
    /// on a strip picks it; `K` sets a first key for the picked strip.
    pub edit_strips: bool,
    /// The EFF brush's mouse mode (EFF panel): a left drag paints the drag's direction into
    /// the cells under the cursor.
    pub paint_eff: bool,
    /// Draw the EFF's cells as arrows and the key-frame targets over the view.
    pub eff_arrows: bool,
    /// What the press held.
    pub gesture: Gesture,
}

impl Default for StripsUi {
    fn default() -> Self {
        StripsUi {
            brush: Brush::default(),
            key_strip: 0,
            key_span: 20,
            timeline_grab: None,
            pose: None,
            edit_strips: false,
            paint_eff: false,
            eff_arrows: false,
            gesture: Gesture::default(),
        }
    }
}

impl StripsUi {
    /// A key-frame edit of the picked strip (`key_strip`) whose first key is the current
    /// frame and second `key_span` frames later; the clip is shown at the second key,
    /// paused, so its target can be dragged at once.
    pub fn add_edit(&mut self, scene: &mut Scene, host: &mut Host) -> Result<()> {
        use crate::systems::strips::block::MAX_STRIP_EDITS;
        let count = scene.strips().as_ref().map_or(0, |st| st.edits.len());
        if count >= MAX_STRIP_EDITS {
            return Err(KamiError::Option(format!(
                "a scene holds at most {MAX_STRIP_EDITS} key-frame edits"
            )));
        }
        let frame = u32::try_from(host.frame).unwrap_or(u32::MAX - 1_000);
        let e = panel::new_edit(scene, self.key_strip, frame, self.key_span)?;
        host.seek = Some(u64::from(e.to));
        host.playing = false;
        if let Some(st) = scene.strips_mut().as_mut() {
            st.edits.push(e);
        }
        Ok(())
    }

    /// The strips as the stage poses them now (read back once per frame at most).
    pub fn pose(
        &mut self,
        gpu: &Gpu,
        system: Option<&dyn HairSystem>,
        frame: u64,
    ) -> Result<&[Vec<DVec3>]> {
        if self.pose.as_ref().is_none_or(|(f, _)| *f != frame) {
            let sys = system.and_then(|s| s.as_any().downcast_ref::<StripsSystem>());
            let pose = match sys {
                Some(sys) => sys.pose(gpu)?,
                None => Vec::new(),
            };
            self.pose = Some((frame, pose));
        }
        Ok(self.pose.as_ref().map_or(&[], |(_, p)| p.as_slice()))
    }
}

impl KindUi for StripsUi {
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }

    /// `strips.edit=on|off` and `eff.paint=on|off` (the strips' and the EFF brush's mouse
    /// modes), `strips.key` (a first key now for the picked strip).
    fn set(
        &mut self,
        scene: &mut Scene,
        host: &mut Host,
        key: &str,
        value: Option<&str>,
    ) -> Option<std::result::Result<(), String>> {
        Some(match key {
            "strips.edit" | "eff.paint" => ui::on(value).and_then(|on| {
                if on && scene.strips().is_none() {
                    return Err("the scene has no strips".into());
                }
                if on && key == "eff.paint" && scene.forces.eff.is_none() {
                    return Err("the scene has no EFF".into());
                }
                if key == "strips.edit" {
                    self.edit_strips = on;
                    self.paint_eff &= !on;
                } else {
                    self.paint_eff = on;
                    self.edit_strips &= !on;
                }
                Ok(())
            }),
            "strips.key" => self.add_edit(scene, host).map_err(|e| e.to_string()),
            _ => return None,
        })
    }

    fn mouse_mode(&self, scene: &Scene, host: &Host) -> bool {
        (self.edit_strips || self.paint_eff)
            && scene.strips().is_some()
            && host.world_view.is_some()
    }

    fn press(
        &mut self,
        scene: &mut Scene,
        host: &mut Host,
        tool: &Tool,
        cursor: DVec2,
    ) -> Result<bool> {
        let Some(view) = host.world_view else {
            return Ok(false);
        };
        if !self.mouse_mode(scene, host) || cursor.x > view.size.x || cursor.y > view.size.y {
            return Ok(false);
        }
        if self.paint_eff {
            if scene.forces.eff.is_none() {
                return Ok(false);
            }
            self.gesture.paint = Some(cursor);
            return Ok(true);
        }
        let forces = tool.ctx.forces;
        let head_at = |f: u32| forces.head_at(f64::from(f));
        let edits = scene.strips().as_ref().map_or(&[][..], |st| &st.edits[..]);
        if let Some(i) = pick::pick_target(edits, &head_at, &view, cursor, pick::PICK_PX) {
            let e = &edits[i];
            let depth = view
                .project(pick::target_world(e, &head_at(e.to)))
                .map_or(0.5, |q| q.z);
            self.gesture.target = Some((i, depth));
            self.key_strip = e.strip;
            // Show the clip at the second key, where the target holds the strip.
            host.playing = false;
            if tool.ctx.frame != u64::from(e.to) {
                host.seek = Some(u64::from(e.to));
            }
            return Ok(true);
        }
        let hit = pick::pick_strip(
            self.pose(tool.gpu, tool.system, tool.ctx.frame)?,
            &view,
            cursor,
            pick::PICK_PX,
        );
        if let Some(i) = hit {
            self.key_strip = i as u32;
            host.message = Some(format!(
                "strip {i} picked: K (or the Key frames panel) sets a first key at this frame"
            ));
            return Ok(true);
        }
        Ok(false)
    }

    fn holding(&self) -> bool {
        self.gesture.active()
    }

    fn drag(&mut self, scene: &mut Scene, host: &mut Host, tool: &Tool, cursor: DVec2) {
        let Some(view) = host.world_view else {
            return;
        };
        if let Some((i, depth)) = self.gesture.target {
            let Some(e) = scene
                .strips_mut()
                .as_mut()
                .and_then(|st| st.edits.get_mut(i))
            else {
                self.gesture.target = None;
                return;
            };
            let head = tool.ctx.forces.head_at(f64::from(e.to));
            if let Some(t) = pick::drag_target(&view, &head, depth, cursor) {
                e.target = t.to_array();
                host.seek = Some(u64::from(e.to));
            }
        }
        if let Some(last) = self.gesture.paint {
            if (cursor - last).length() < DAB_PX {
                return;
            }
            // The stroke lies in the plane through the head's centre (where the head is
            // now) facing the eye.
            let centre = tool
                .ctx
                .head
                .transform_point3(DVec3::from(scene.head.center));
            let depth = view.project(centre).map_or(0.5, |q| q.z);
            let (Some(a), Some(b)) = (view.unproject(last, depth), view.unproject(cursor, depth))
            else {
                return;
            };
            let field = panel::built(scene, &mut self.brush.cache);
            if let (Some(field), Some(desc)) = (field, scene.forces.eff.as_mut()) {
                let dir = (b - a).normalize_or_zero();
                let b_ = &self.brush;
                let n = panel::paint_into(desc, &field, b, b_.radius, dir * b_.strength);
                host.message = Some(format!("painted {n} cells"));
            }
            self.gesture.paint = Some(cursor);
        }
    }

    fn release(&mut self) {
        self.gesture = Gesture::default();
    }

    /// `K` in the mouse mode: a first key now for the picked strip.
    fn key(&mut self, scene: &mut Scene, host: &mut Host, key: Key, _mods: Mods) -> bool {
        match key {
            Key::Char(c) if self.edit_strips && c.eq_ignore_ascii_case("k") => {
                if let Err(e) = self.add_edit(scene, host) {
                    host.error = Some(e.to_string());
                }
                true
            }
            _ => false,
        }
    }

    /// The picked strip's outline follows it (one read-back a frame, in the mouse mode
    /// only).
    fn frame(&mut self, scene: &Scene, tool: &Tool) -> Result<()> {
        if self.edit_strips && scene.strips().is_some() {
            self.pose(tool.gpu, tool.system, tool.ctx.frame)?;
        }
        Ok(())
    }

    fn stale(&mut self) {
        self.pose = None;
    }

    /// A key-frame edit changes the clip from its first key on.
    fn replays(&self, old: &Scene, new: &Scene) -> bool {
        let edits = |sc: &Scene| sc.strips().as_ref().map(|st| st.edits.clone());
        edits(old) != edits(new)
    }

    fn overlay(
        &mut self,
        ctx: &egui::Context,
        scene: &Scene,
        host: &Host,
        frame: &FrameCtx,
        ppp: f32,
    ) {
        let Some(world) = host.world_view else {
            return;
        };
        let strips_mode = self.edit_strips || self.paint_eff;
        if self.eff_arrows || (strips_mode && scene.strips().is_some()) {
            let picked = self
                .pose
                .as_ref()
                .filter(|_| self.edit_strips)
                .and_then(|(_, p)| p.get(self.key_strip as usize));
            panel::overlay(
                ctx,
                scene,
                &mut self.brush.cache,
                &world,
                ppp,
                panel::Show {
                    arrows: self.eff_arrows || self.paint_eff,
                    targets: self.eff_arrows || self.edit_strips,
                    picked: picked.map(|p| p.as_slice()),
                    forces: Some(frame.forces),
                },
            );
        }
    }

    fn help(&self) -> Option<&'static str> {
        self.edit_strips.then_some(MOUSE_HELP)
    }
}
