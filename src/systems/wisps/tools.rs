//! The wisps' state in the viewer and their mouse mode (Sakai, Fig. 9): the skeleton editor
//! (`edit::Editor`: selection, undo history) driven by the Skeletons panel, the mouse in the
//! 3D view and the keys, the skeleton overlay, and the wisps' `--set` keys. The viewer
//! hosts it as a `KindUi` and knows none of it.

use super::block::{MarchOn, MeshOn, WispDraw};
use super::edit::{self, Editor};
use super::panel;
use crate::error::Result;
use crate::systems::scene::Scene;
use crate::systems::system::FrameCtx;
use crate::systems::ui::{self, Host, Key, KindUi, Mods, Tool};
use glam::{DVec2, DVec3};
use std::time::Instant;

/// Two left presses closer than this in time and `DOUBLE_PX` on screen are a double click.
const DOUBLE_S: f64 = 0.4;
const DOUBLE_PX: f64 = 6.0;

/// The wisps' viewer state.
#[derive(Debug, Default)]
pub struct WispsUi {
    /// The skeleton editor; a scene opened afresh starts a new one.
    pub editor: Editor,
    /// The mouse mode: the mouse edits skeletons in the 3D view (a left click picks and
    /// drags a node, the wheel sets its radius, ...) and the skeletons are drawn over it.
    pub edit: bool,
    /// A skeleton node is being dragged.
    node_drag: bool,
    /// The last left press in the mouse mode (double clicks).
    last_click: Option<(Instant, DVec2)>,
}

impl KindUi for WispsUi {
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }

    /// `wisps.edit=on|off` (the mouse mode and overlay), `wisps.max_steps=N` (the ray
    /// march's step budget: cheap previews), `wisps.march_on=auto|compute|fragment` (where
    /// the march runs, `block::MarchOn`), `wisps.draw=auto|march|mesh` (`block::WispDraw`),
    /// `wisps.mesh.cell=C` (the meshed path's cell, 0 automatic), `wisps.mesh.on=auto|cpu|gpu`
    /// (where it polygonises, `block::MeshOn`), the Toon panel's controls
    /// `wisps.toon.NAME=VALUE` and the outline scales `wisps.outline[.N]=S`
    /// (`panel::set_key`).
    fn set(
        &mut self,
        scene: &mut Scene,
        _host: &mut Host,
        key: &str,
        value: Option<&str>,
    ) -> Option<std::result::Result<(), String>> {
        let none = || "the scene has no wisps".to_string();
        Some(match key {
            "wisps.max_steps" => ui::int(value).and_then(|n| {
                scene.wisps_mut().as_mut().ok_or_else(none)?.march.max_steps = n;
                Ok(())
            }),
            "wisps.march_on" => {
                let on = match value.map(str::trim) {
                    Some("auto") => Ok(MarchOn::Auto),
                    Some("compute") => Ok(MarchOn::Compute),
                    Some("fragment") => Ok(MarchOn::Fragment),
                    v => Err(format!("expected auto, compute or fragment, not {v:?}")),
                };
                on.and_then(|on| {
                    scene.wisps_mut().as_mut().ok_or_else(none)?.march.on = on;
                    Ok(())
                })
            }
            "wisps.draw" => parse_draw(value).and_then(|d| {
                scene.wisps_mut().as_mut().ok_or_else(none)?.draw = d;
                Ok(())
            }),
            "wisps.mesh.cell" => ui::nums(value, 1).and_then(|c| {
                let c = c[0];
                if !(c.is_finite() && c >= 0.0) {
                    return Err(format!("expected a cell size >= 0 (0: automatic), not {c}"));
                }
                scene.wisps_mut().as_mut().ok_or_else(none)?.mesh.cell = c;
                Ok(())
            }),
            "wisps.mesh.on" => parse_mesh_on(value).and_then(|on| {
                scene.wisps_mut().as_mut().ok_or_else(none)?.mesh.on = on;
                Ok(())
            }),
            k if k.starts_with("wisps.toon.") || k.starts_with("wisps.outline") => {
                let w = scene.wisps_mut().as_mut().ok_or_else(none);
                w.and_then(|w| panel::set_key(w, key, value.ok_or("expected KEY=VALUE")?))
            }
            "wisps.edit" => ui::on(value).and_then(|edit| {
                if edit && scene.wisps().is_none() {
                    return Err(none());
                }
                self.edit = edit;
                Ok(())
            }),
            _ => return None,
        })
    }

    fn opened(&mut self) {
        self.editor = Editor::default();
    }

    fn mouse_mode(&self, scene: &Scene, host: &Host) -> bool {
        self.edit && scene.wisps().is_some() && host.head_view.is_some()
    }

    /// A double click away from the nodes adds a node at the cursor after the selected
    /// one; a press on a node selects it and starts dragging it.
    fn press(
        &mut self,
        scene: &mut Scene,
        host: &mut Host,
        _tool: &Tool,
        cursor: DVec2,
    ) -> Result<bool> {
        let Some(view) = host.head_view else {
            return Ok(false);
        };
        if cursor.x > view.size.x || cursor.y > view.size.y {
            return Ok(false);
        }
        let Some(w) = scene.wisps_mut().as_mut() else {
            return Ok(false);
        };
        let now = Instant::now();
        let double = self.last_click.is_some_and(|(t, q)| {
            now.duration_since(t).as_secs_f64() < DOUBLE_S && (q - cursor).length() < DOUBLE_PX
        });
        let hit = edit::pick(&w.skeletons, &view, cursor, edit::PICK_PX);
        if double && hit.is_none() {
            self.last_click = None;
            let _ = self.editor.add_at(w, &view, cursor);
            return Ok(true);
        }
        self.last_click = Some((now, cursor));
        if hit.is_some() && self.editor.select_at(w, &view, cursor).is_some() {
            self.node_drag = self.editor.begin_drag(w, &view, cursor).is_ok();
            return Ok(true);
        }
        Ok(false)
    }

    fn holding(&self) -> bool {
        self.node_drag
    }

    fn drag(&mut self, scene: &mut Scene, host: &mut Host, _tool: &Tool, cursor: DVec2) {
        // (An undo during the drag ends it: then the cursor moves nothing.)
        if let (true, Some(view), Some(w)) = (
            self.editor.dragging(),
            host.head_view,
            scene.wisps_mut().as_mut(),
        ) {
            let _ = self.editor.drag_to(w, &view, cursor);
        }
    }

    fn release(&mut self) {
        if self.node_drag {
            self.node_drag = false;
            self.editor.end_drag();
        }
    }

    fn input(&mut self) {
        if !self.editor.dragging() {
            self.editor.end_gesture();
        }
    }

    /// Over the selected node the wheel scales the node's radius (Shift: its weight).
    fn wheel(
        &mut self,
        scene: &mut Scene,
        host: &Host,
        cursor: DVec2,
        steps: f64,
        mods: Mods,
    ) -> bool {
        if !self.mouse_mode(scene, host) {
            return false;
        }
        let (Some(view), Some(w)) = (host.head_view, scene.wisps_mut().as_mut()) else {
            return false;
        };
        let Some(sel) = self.editor.selected(w) else {
            return false;
        };
        let n = w.skeletons[sel.skeleton].nodes[sel.node];
        let node = DVec3::from(n.p);
        let (Some(q), Some(r)) = (view.project(node), view.radius_px(node, n.r)) else {
            return false;
        };
        if (q.truncate() - cursor).length() > r.max(edit::PICK_PX) {
            return false;
        }
        let factor = (0.1 * steps).exp();
        let _ = if mods.shift {
            self.editor.scale_weight(w, factor)
        } else {
            self.editor.scale_radius(w, factor)
        };
        true
    }

    /// Undo and redo whenever the scene has wisps; Delete and Escape in the mouse mode.
    fn key(&mut self, scene: &mut Scene, host: &mut Host, key: Key, mods: Mods) -> bool {
        let editing = self.mouse_mode(scene, host);
        let Some(w) = scene.wisps_mut().as_mut() else {
            return false;
        };
        match key {
            Key::Char(c) if mods.ctrl && matches!(c.to_ascii_lowercase().as_str(), "z" | "y") => {
                let redo = c.eq_ignore_ascii_case("y") || mods.shift;
                let _ = if redo {
                    self.editor.redo(w)
                } else {
                    self.editor.undo(w)
                };
                true
            }
            Key::Delete if editing => {
                let _ = self.editor.delete_node(w);
                true
            }
            Key::Escape if editing => {
                let _ = self.editor.select(w, None);
                true
            }
            _ => false,
        }
    }

    fn overlay(
        &mut self,
        ctx: &egui::Context,
        scene: &Scene,
        host: &Host,
        _frame: &FrameCtx,
        ppp: f32,
    ) {
        if let (true, Some(w), Some(view)) = (self.edit, scene.wisps(), host.head_view) {
            panel::overlay(ctx, w, &self.editor, &view, ppp);
        }
    }
}

/// `auto`, `cpu` or `gpu` (`block::MeshOn`).
pub fn parse_mesh_on(value: Option<&str>) -> std::result::Result<MeshOn, String> {
    match value.map(str::trim) {
        Some("auto") => Ok(MeshOn::Auto),
        Some("cpu") => Ok(MeshOn::Cpu),
        Some("gpu") => Ok(MeshOn::Gpu),
        v => Err(format!("expected auto, cpu or gpu, not {v:?}")),
    }
}

/// `auto`, `march` or `mesh` (`block::WispDraw`).
pub fn parse_draw(value: Option<&str>) -> std::result::Result<WispDraw, String> {
    match value.map(str::trim) {
        Some("auto") => Ok(WispDraw::Auto),
        Some("march") => Ok(WispDraw::March),
        Some("mesh") => Ok(WispDraw::Mesh),
        v => Err(format!("expected auto, march or mesh, not {v:?}")),
    }
}
