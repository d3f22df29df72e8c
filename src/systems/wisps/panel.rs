//! The Toon panel (thresholds and colours of eqs 20-22, tones, the toon controls: feathers,
//! the halo's width, offset, strength and shadow colour, the rim light, the outline and its
//! taper; how the surface is drawn, march or mesh, and the mesh cell; the ray march), its
//! `--set` keys (`set_key`), and
//! the Skeletons panel (the skeleton editor of Fig. 9: the skeletons and their nodes, the
//! selected node's radius, weight and position, adding and deleting nodes and skeletons,
//! undo and redo, and the mouse mode of the 3D view). They edit the scene and the wisps'
//! viewer state (`tools::WispsUi`: the Skeletons panel goes through its `edit::Editor`);
//! the stage classifies the edit with `super::classify` and applies it.

use super::edit::{Editor, Sel};
use super::tools::WispsUi;
use crate::systems::kind::Panel;
use crate::systems::ui::{self, Host, PanelCx};
use crate::systems::wisps::block::{Distance, MeshOn, Tones, WispDraw, Wisps};
use egui::{Button, Color32, DragValue, Slider, SliderClamping, Ui};
use glam::{DVec2, DVec3};

pub const PANELS: &[Panel] = &[
    Panel {
        title: "Toon",
        open: |s| s.wisps().is_some(),
        adds: false,
        show: toon,
    },
    Panel {
        title: "Skeletons",
        open: |s| s.wisps().is_some(),
        adds: false,
        show: skeletons,
    },
];

/// How the mouse edits skeletons in the 3D view while the mode is on.
pub const MOUSE_HELP: &str = "click a node: select · drag: move it (parallel to the screen) · \
    wheel over the selected node: radius (Shift: weight) · double-click: add a node at the \
    cursor after the selected one · Delete: delete the node · Esc: deselect · \
    Ctrl+Z / Ctrl+Shift+Z or Ctrl+Y: undo / redo · drag elsewhere: orbit as usual";

/// Show an editor outcome: what happened, or (red) why not.
pub fn outcome(ui: &mut Ui, ed: &Editor) {
    match &ed.last {
        Some(Ok(m)) => {
            ui.label(m);
        }
        Some(Err(e)) => {
            ui.colored_label(Color32::from_rgb(255, 110, 90), e);
        }
        None => {}
    }
}

/// Where a copy of a skeleton goes: `amount` along the screen's right (in the head's frame,
/// at `p`'s depth) in the last drawn view; along +z without one.
fn screen_right(host: &Host, p: DVec3, amount: f64) -> DVec3 {
    let right = host.head_view.and_then(|v| {
        let q = v.project(p)?;
        let a = v.unproject(q.truncate(), q.z)?;
        let b = v.unproject(q.truncate() + DVec2::X, q.z)?;
        (b - a).try_normalize()
    });
    right.unwrap_or(DVec3::Z) * amount
}

fn skeletons(ui: &mut Ui, cx: &mut PanelCx) {
    let Some(st) = ui::state::<WispsUi>(cx.state) else {
        return;
    };
    let Some(w) = cx.scene.wisps().as_ref() else {
        ui.label("this scene has no toon wisps");
        return;
    };
    // A copy goes beside the original (by its largest radius, to the screen's right); a new
    // skeleton hangs from the top of the head.
    let shift = match st.editor.selected(w) {
        Some(sel) => {
            let sk = &w.skeletons[sel.skeleton];
            let r = sk.nodes.iter().map(|n| n.r).fold(0.0, f64::max);
            screen_right(cx.host, DVec3::from(sk.nodes[0].p), 1.5 * r)
        }
        None => DVec3::ZERO,
    };
    let head = &cx.scene.head;
    let top = DVec3::from(head.center) + DVec3::new(0.0, head.radii[1], 0.0);
    ui.checkbox(&mut st.edit, "edit skeletons with the mouse")
        .on_hover_text(MOUSE_HELP);
    if st.edit {
        ui.small(MOUSE_HELP);
    }
    let Some(w) = cx.scene.wisps_mut().as_mut() else {
        return;
    };
    let ed = &mut st.editor;
    ui.horizontal(|ui| {
        if ui
            .add_enabled(ed.can_undo(), Button::new("Undo"))
            .on_hover_text("Ctrl+Z")
            .clicked()
        {
            let _ = ed.undo(w);
        }
        if ui
            .add_enabled(ed.can_redo(), Button::new("Redo"))
            .on_hover_text("Ctrl+Shift+Z or Ctrl+Y")
            .clicked()
        {
            let _ = ed.redo(w);
        }
        ui.label(format!("{} undo / {} redo", ed.undo_len(), ed.redo_len()));
    });
    outcome(ui, ed);
    ui.separator();
    skeleton_list(ui, w, ed);
    ui.separator();
    match ed.selected(w) {
        Some(sel) => node_fields(ui, w, ed, sel),
        None => {
            ui.label("no node selected");
        }
    }
    let has = ed.selected(w).is_some();
    ui.horizontal_wrapped(|ui| {
        if ui
            .add_enabled(has, Button::new("Add node after"))
            .on_hover_text("past the tip: along the last segment, radius tapered")
            .clicked()
        {
            let _ = ed.add_after(w);
        }
        if ui
            .add_enabled(has, Button::new("Insert between"))
            .on_hover_text("halfway to the next node (the previous one at the tip)")
            .clicked()
        {
            let _ = ed.insert_between(w);
        }
        if ui
            .add_enabled(has, Button::new("Delete node"))
            .on_hover_text("Delete")
            .clicked()
        {
            let _ = ed.delete_node(w);
        }
    });
    ui.horizontal_wrapped(|ui| {
        let add = if has { "Copy skeleton" } else { "Add skeleton" };
        if ui
            .button(add)
            .on_hover_text(
                "a copy of the selected skeleton beside it, or a new wisp on top of the head",
            )
            .clicked()
        {
            let _ = ed.add_skeleton(w, shift, top);
        }
        if ui
            .add_enabled(has && w.skeletons.len() > 1, Button::new("Delete skeleton"))
            .clicked()
        {
            let _ = ed.delete_skeleton(w);
        }
        if ui.add_enabled(has, Button::new("Deselect")).clicked() {
            let _ = ed.select(w, None);
        }
    });
    ui.small("Save (Files) writes the skeletons into the scene file.");
}

/// The skeletons (a scrolled list; clicking one selects its tip) and the selected one's
/// nodes (clicking one selects it).
fn skeleton_list(ui: &mut Ui, w: &Wisps, ed: &mut Editor) {
    let sel = ed.selected(w);
    let mut pick = None;
    let row = ui.text_style_height(&egui::TextStyle::Body) + ui.spacing().item_spacing.y;
    ui.label(format!("{} skeletons", w.skeletons.len()));
    egui::ScrollArea::vertical()
        .id_salt("wisp skeleton list")
        .max_height(150.0)
        .auto_shrink([false, true])
        .show_rows(ui, row, w.skeletons.len(), |ui, rows| {
            for i in rows {
                let sk = &w.skeletons[i];
                let name = if sk.name.is_empty() { "-" } else { &sk.name };
                let text = format!("{i}: {name} ({} nodes)", sk.nodes.len());
                let on = sel.is_some_and(|x| x.skeleton == i);
                if ui.selectable_label(on, text).clicked() {
                    pick = Some(Sel {
                        skeleton: i,
                        node: sk.nodes.len().saturating_sub(1),
                    });
                }
            }
        });
    if let Some(sel) = sel {
        ui.horizontal_wrapped(|ui| {
            ui.label("nodes:");
            for (i, n) in w.skeletons[sel.skeleton].nodes.iter().enumerate() {
                if ui
                    .selectable_label(sel.node == i, i.to_string())
                    .on_hover_text(format!(
                        "p ({:.3}, {:.3}, {:.3}), r {:.3}, w {:.3}",
                        n.p[0], n.p[1], n.p[2], n.r, n.w
                    ))
                    .clicked()
                {
                    pick = Some(Sel {
                        skeleton: sel.skeleton,
                        node: i,
                    });
                }
            }
        });
    }
    if let Some(p) = pick {
        let _ = ed.select(w, Some(p));
    }
}

/// The selected node's radius, weight and position, edited through the editor (one undo
/// entry per slider drag).
fn node_fields(ui: &mut Ui, w: &mut Wisps, ed: &mut Editor, sel: Sel) {
    let n = w.skeletons[sel.skeleton].nodes[sel.node];
    ui.label(format!(
        "node {} of skeleton {}{}",
        sel.node,
        sel.skeleton,
        if sel.node == 0 { " (root)" } else { "" }
    ));
    let mut r = n.r;
    if ui
        .add(
            Slider::new(&mut r, 0.01..=20.0)
                .logarithmic(true)
                .clamping(SliderClamping::Never)
                .text("radius r_e"),
        )
        .changed()
        && r != n.r
    {
        let _ = ed.set_radius(w, r);
    }
    let mut wt = n.w;
    if ui
        .add(
            Slider::new(&mut wt, 0.05..=20.0)
                .logarithmic(true)
                .clamping(SliderClamping::Never)
                .text("weight w_e"),
        )
        .changed()
        && wt != n.w
    {
        let _ = ed.set_weight(w, wt);
    }
    let mut p = n.p;
    let mut moved = false;
    ui.horizontal(|ui| {
        ui.label("position");
        for c in p.iter_mut() {
            moved |= ui.add(DragValue::new(c).speed(0.02)).changed();
        }
    });
    if moved && p != n.p {
        let _ = ed.set_position(w, p);
    }
    let before = w.skeletons[sel.skeleton].outline;
    let mut o = before;
    if ui
        .add(Slider::new(&mut o, 0.0..=4.0).text("outline × (this wisp)"))
        .on_hover_text("this wisp's outline width as a multiple of the Toon panel's")
        .changed()
        && o != before
    {
        let _ = ed.set_outline(w, o);
    }
}

fn colour(ui: &mut Ui, label: &str, c: &mut [f32; 3]) {
    ui.horizontal(|ui| {
        ui.color_edit_button_rgb(c);
        ui.label(label);
    });
}

fn toon(ui: &mut Ui, cx: &mut PanelCx) {
    let Some(w) = cx.scene.wisps_mut().as_mut() else {
        ui.label("this scene has no toon wisps");
        return;
    };
    let t = &mut w.toon;
    ui.horizontal(|ui| {
        ui.selectable_value(&mut t.tones, Tones::Two, "two tones");
        ui.selectable_value(&mut t.tones, Tones::Three, "three tones");
    });
    colour(ui, "lit (c_diffuse)", &mut t.diffuse);
    colour(ui, "shade (c_shade)", &mut t.shade);
    if t.tones == Tones::Three {
        colour(ui, "dark", &mut t.dark);
    }
    ui.add(Slider::new(&mut t.t_diffuse, 0.0..=1.0).text("t_diffuse"));
    ui.add(Slider::new(&mut t.diffuse_feather, 0.0..=0.5).text("lit/shade feather"))
        .on_hover_text("0: a hard step; else the width in I_diff of a smooth blend");
    if t.tones == Tones::Three {
        ui.add(Slider::new(&mut t.t_dark, 0.0..=1.0).text("t_dark"));
        ui.add(Slider::new(&mut t.dark_feather, 0.0..=0.5).text("shade/dark feather"));
    }
    ui.separator();
    colour(ui, "halo (c_specular)", &mut t.specular);
    ui.add(Slider::new(&mut t.t_specular, 0.5..=1.0).text("t_specular (halo width)"))
        .on_hover_text("close to 1: a thin band");
    ui.add(Slider::new(&mut t.halo_feather, 0.0..=0.2).text("halo feather"));
    ui.add(Slider::new(&mut t.halo_offset, -45.0..=45.0).text("halo offset (° latitude)"))
        .on_hover_text("moves the band up (toward the crown) or down");
    ui.add(Slider::new(&mut t.halo_strength, 0.0..=2.0).text("halo strength"));
    let mut own = t.halo_shadow.is_some();
    ui.checkbox(&mut own, "halo colour of its own over the shade tones");
    match (own, t.halo_shadow.as_mut()) {
        (true, Some(c)) => colour(ui, "halo over shade", c),
        (true, None) => t.halo_shadow = Some(t.specular),
        (false, _) => t.halo_shadow = None,
    }
    ui.separator();
    colour(ui, "rim light", &mut t.rim);
    ui.add(Slider::new(&mut t.rim_width, 0.0..=1.0).text("rim width (N·V)"))
        .on_hover_text("0: no rim; the rim lights the shadow side where N·V is below this");
    ui.add(Slider::new(&mut t.rim_feather, 0.0..=0.5).text("rim feather"));
    ui.separator();
    colour(ui, "outline", &mut t.outline);
    ui.add(Slider::new(&mut t.outline_width, 0.0..=6.0).text("outline (pixels)"));
    ui.add(Slider::new(&mut t.outline_taper, 0.0..=1.0).text("outline taper (to the tip)"))
        .on_hover_text("1: the outline thins to nothing at each wisp's tip");
    ui.separator();
    ui.add(
        Slider::new(&mut w.threshold, 0.05..=1.4)
            .logarithmic(true)
            .text("threshold (eq 8)"),
    );
    ui.horizontal(|ui| {
        ui.label("draw");
        ui.selectable_value(&mut w.draw, WispDraw::Auto, "auto")
            .on_hover_text("what kami bench wisps measured best on this kind of adapter");
        ui.selectable_value(&mut w.draw, WispDraw::March, "march")
            .on_hover_text("every pixel ray marched: the exact surface");
        ui.selectable_value(&mut w.draw, WispDraw::Mesh, "mesh")
            .on_hover_text("meshed once while still, then rasterised: far cheaper");
    });
    if w.draw != WispDraw::March {
        ui.add(
            DragValue::new(&mut w.mesh.cell)
                .range(0.0..=10.0)
                .speed(0.01)
                .prefix("mesh cell "),
        )
        .on_hover_text("the mesh's grid cell, scene units; 0: automatic");
        ui.horizontal(|ui| {
            ui.label("mesh on");
            ui.selectable_value(&mut w.mesh.on, MeshOn::Auto, "auto")
                .on_hover_text("still wisps on the CPU once; moving ones where measured cheaper");
            ui.selectable_value(&mut w.mesh.on, MeshOn::Cpu, "cpu")
                .on_hover_text("f64 surface nets on the CPU's threads");
            ui.selectable_value(&mut w.mesh.on, MeshOn::Gpu, "gpu")
                .on_hover_text("the same surface nets in compute, every frame, nothing read back");
        });
    }
    let m = &mut w.march;
    let mut polyline = matches!(m.distance, Distance::Polyline { .. });
    ui.horizontal(|ui| {
        ui.label("distance");
        ui.selectable_value(&mut polyline, false, "Newton (paper)");
        ui.selectable_value(&mut polyline, true, "polyline");
    });
    m.distance = match (polyline, m.distance) {
        (false, _) => Distance::Newton,
        (true, Distance::Polyline { pieces }) => Distance::Polyline { pieces },
        (true, Distance::Newton) => Distance::Polyline { pieces: 4 },
    };
    if let Distance::Polyline { pieces } = &mut m.distance {
        ui.add(Slider::new(pieces, 1..=16).text("chords per segment"));
    }
    ui.add(Slider::new(&mut m.max_steps, 16..=1024).text("max steps"));
    ui.add(Slider::new(&mut m.refine, 0..=16).text("bisection steps"));
}

/// The overlay's colour: the skeletons' nodes and chains.
pub const OVERLAY: Color32 = Color32::from_rgb(40, 230, 110);
/// The selected node and its skeleton.
pub const SELECTED: Color32 = Color32::from_rgb(255, 140, 0);

/// Draw the skeletons over the 3D view with egui's painter (the skeleton editor's mouse
/// mode): each node as a circle of its radius of influence r_e in pixels with a dot at its
/// centre, the chains as lines, the selected node and its skeleton highlighted, and the
/// editor's last message at the bottom left. `view` is the scene region in window pixels
/// (`ppp` of them per egui point).
pub fn overlay(ctx: &egui::Context, w: &Wisps, ed: &Editor, view: &super::edit::View, ppp: f32) {
    use egui::{pos2, vec2, FontId, Id, LayerId, Order, Rect, Stroke};
    let ppp = ppp.max(1e-3);
    let clip = Rect::from_min_size(
        egui::Pos2::ZERO,
        vec2(view.size.x as f32 / ppp, view.size.y as f32 / ppp),
    );
    let painter = ctx
        .layer_painter(LayerId::new(
            Order::Middle,
            Id::unique("wisp skeleton overlay"),
        ))
        .with_clip_rect(clip);
    // The last message first: nodes drawn over it stay visible.
    let (text, col) = match &ed.last {
        Some(Ok(m)) => (m.as_str(), Color32::WHITE),
        Some(Err(e)) => (e.as_str(), Color32::from_rgb(255, 150, 130)),
        None => ("skeleton edit mode: click a node", Color32::WHITE),
    };
    let galley = painter.layout_no_wrap(text.to_string(), FontId::proportional(13.0), col);
    let corner = clip.left_bottom() + vec2(8.0, -8.0 - galley.size().y);
    painter.rect_filled(
        Rect::from_min_size(corner, galley.size()).expand(4.0),
        3.0,
        Color32::from_black_alpha(170),
    );
    painter.galley(corner, galley, col);
    let at = |q: DVec3| pos2(q.x as f32 / ppp, q.y as f32 / ppp);
    let sel = ed.selected(w);
    for (si, sk) in w.skeletons.iter().enumerate() {
        let chosen = sel.is_some_and(|s| s.skeleton == si);
        let colour = if chosen { SELECTED } else { OVERLAY };
        let pts: Vec<Option<(egui::Pos2, f32)>> = sk
            .nodes
            .iter()
            .map(|n| {
                let p = DVec3::from(n.p);
                let q = view.project(p)?;
                let r = view.radius_px(p, n.r)?;
                r.is_finite()
                    .then_some((at(q), (r as f32 / ppp).clamp(2.0, 4000.0)))
            })
            .collect();
        for pair in pts.windows(2) {
            if let [Some(a), Some(b)] = pair {
                painter.line_segment([a.0, b.0], Stroke::new(1.5, colour));
            }
        }
        for (ni, q) in pts.iter().enumerate() {
            let Some((c, r)) = *q else { continue };
            let this = sel
                == Some(Sel {
                    skeleton: si,
                    node: ni,
                });
            let (width, dot, col) = if this {
                (2.5, 5.0, SELECTED)
            } else {
                (1.0, 3.0, colour)
            };
            // The circles of influence are faint (they overlap a lot); the dots are solid.
            let ring = if this { col } else { col.gamma_multiply(0.55) };
            painter.circle_stroke(c, r, Stroke::new(width, ring));
            painter.circle_filled(c, dot, col);
        }
    }
}

/// The Toon panel's controls as `--set` keys: `wisps.toon.NAME=VALUE` for every field of
/// `wisps::block::Toon` (numbers; colours as `r,g,b`; `halo_shadow=r,g,b|none`;
/// `tones=two|three`), and each skeleton's outline scale: `wisps.outline=S` (every skeleton)
/// or `wisps.outline.N=S` (skeleton N). The caller validates the scene afterwards (ranges,
/// finiteness, with the field's name).
pub fn set_key(w: &mut Wisps, key: &str, value: &str) -> Result<(), String> {
    let num = || -> Result<f64, String> {
        value
            .trim()
            .parse::<f64>()
            .map_err(|_| format!("{value:?} is not a number"))
    };
    let rgb = || -> Result<[f32; 3], String> {
        let v: Vec<f32> = value
            .split(',')
            .map(|x| x.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("{value:?} is not r,g,b"))?;
        <[f32; 3]>::try_from(v).map_err(|_| format!("{value:?} is not r,g,b"))
    };
    if let Some(i) = key.strip_prefix("wisps.outline.") {
        let n = w.skeletons.len();
        let sk = i
            .parse::<usize>()
            .ok()
            .and_then(|i| w.skeletons.get_mut(i))
            .ok_or_else(|| format!("no skeleton {i:?} (the scene has {n})"))?;
        sk.outline = num()?;
        return Ok(());
    }
    if key == "wisps.outline" {
        let s = num()?;
        w.skeletons.iter_mut().for_each(|sk| sk.outline = s);
        return Ok(());
    }
    let name = key
        .strip_prefix("wisps.toon.")
        .ok_or_else(|| format!("unknown key {key:?}"))?;
    let t = &mut w.toon;
    match name {
        "tones" => {
            t.tones = match value.trim() {
                "two" | "2" => Tones::Two,
                "three" | "3" => Tones::Three,
                _ => return Err("expected two or three".into()),
            }
        }
        "halo_shadow" => {
            t.halo_shadow = match value.trim() {
                "none" => None,
                _ => Some(rgb()?),
            }
        }
        "diffuse" => t.diffuse = rgb()?,
        "shade" => t.shade = rgb()?,
        "dark" => t.dark = rgb()?,
        "specular" => t.specular = rgb()?,
        "outline" => t.outline = rgb()?,
        "rim" => t.rim = rgb()?,
        _ => {
            let field = match name {
                "t_diffuse" => &mut t.t_diffuse,
                "t_dark" => &mut t.t_dark,
                "t_specular" => &mut t.t_specular,
                "outline_width" => &mut t.outline_width,
                "outline_taper" => &mut t.outline_taper,
                "diffuse_feather" => &mut t.diffuse_feather,
                "dark_feather" => &mut t.dark_feather,
                "halo_feather" => &mut t.halo_feather,
                "halo_offset" => &mut t.halo_offset,
                "halo_strength" => &mut t.halo_strength,
                "rim_width" => &mut t.rim_width,
                "rim_feather" => &mut t.rim_feather,
                _ => return Err(format!("unknown key {key:?}")),
            };
            *field = num()?;
        }
    }
    Ok(())
}
