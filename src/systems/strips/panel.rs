//! The Strips panel (eq 1's stiffness τ, damping I2 and inertia I1, the forces of eq 2, the
//! simulation rate, the layers of the layer model and the look), the EFF panel and the Key
//! frames panel. They edit the scene and the strips' viewer state (`tools::StripsUi`); the
//! stage classifies the edit with `super::classify`: motion parameters act from the next
//! step, layers rebuild the strips, the look redraws.

use super::tools::StripsUi;
use crate::forces::eff::{Eff, EffDesc, EffSample, GustKey};
use crate::forces::Forces;
use crate::scene::Interp;
use crate::scene::Sampling;
use crate::systems::scene::Scene;
use crate::systems::strips::block::{
    Edit, Layer, Strips, StripsBlock, MAX_CURL, MAX_LAYER_STIFFNESS, MAX_STRIP_STICKS,
};
use crate::systems::ui::{self, PanelCx};
use egui::{Color32, ComboBox, DragValue, Slider, SliderClamping, Ui};
use glam::DVec3;

pub fn strips(ui: &mut Ui, cx: &mut PanelCx) {
    let Scene { render, blocks, .. } = &mut *cx.scene;
    let shading = &mut render.shading;
    let Some(st) = blocks.get_mut::<StripsBlock>().strips.as_mut() else {
        ui.label("this scene has no strips");
        return;
    };
    motion(ui, st);
    ui.separator();
    layers(ui, st);
    ui.separator();
    look(ui, st);
    let k = &mut st.look;
    crate::systems::hair_bsdf::panel(ui, shading, &mut k.shading, &mut k.physical);
}

/// A slider over a handy part of a value's range (the block's bounds are wider): it never
/// rewrites a value the scene file set outside that part (egui's default clamps what it
/// shows), and the scene validator checks whatever is typed.
fn part(slider: Slider<'_>) -> Slider<'_> {
    slider.clamping(SliderClamping::Edits)
}

fn motion(ui: &mut Ui, st: &mut Strips) {
    let m = &mut st.motion;
    ui.label("joints: I1 Φ'' + I2 Φ' + τ (Φ − Φ0) = H");
    ui.add(part(
        Slider::new(&mut m.stiffness, 0.0..=20000.0)
            .logarithmic(true)
            .text("stiffness τ (root)"),
    ));
    ui.add(Slider::new(&mut m.stiffness_tip, 0.0..=1.0).text("τ at the tip (share)"));
    ui.add(part(
        Slider::new(&mut m.damping, 0.0..=200.0)
            .logarithmic(true)
            .text("air resistance I2"),
    ));
    ui.add(part(
        Slider::new(&mut m.inertia, 0.01..=100.0)
            .logarithmic(true)
            .text("inertia I1 (root)"),
    ));
    // The oscillation a joint would have alone: what τ, I1 and I2 mean to an animator.
    let w0 = (m.stiffness / m.inertia).sqrt();
    let zeta = m.damping / (2.0 * (m.stiffness * m.inertia).sqrt()).max(1e-12);
    ui.small(format!(
        "root joint alone: {:.2} Hz, damping ratio ζ = {:.2}{}",
        w0 / std::f64::consts::TAU,
        zeta,
        if zeta >= 1.0 { " (no overshoot)" } else { "" }
    ));
    ui.add(part(
        Slider::new(&mut m.spring, 0.0..=2000.0)
            .logarithmic(true)
            .text("spring k (S)"),
    ));
    ui.add(part(
        Slider::new(&mut m.collision, 0.0..=100.0)
            .logarithmic(true)
            .text("collision κ (Ψ)"),
    ));
    ui.label("gravity, wind and head motion: the Forces panel");
    ui.add(part(
        Slider::new(&mut m.steps_per_second, 15.0..=2000.0)
            .logarithmic(true)
            .text("steps per second"),
    ));
    ui.checkbox(
        &mut m.preload,
        "hold the groomed shape under gravity (preload)",
    )
    .on_hover_text(
        "rest angles set so the groom is the equilibrium under gravity: no sag at the start",
    );
    ComboBox::from_label("EFF sampling")
        .selected_text(match m.sampling {
            Sampling::Nearest => "nearest cell",
            Sampling::Trilinear => "trilinear",
        })
        .show_ui(ui, |ui| {
            ui.selectable_value(&mut m.sampling, Sampling::Nearest, "nearest cell");
            ui.selectable_value(&mut m.sampling, Sampling::Trilinear, "trilinear");
        });
}

fn layers(ui: &mut Ui, st: &mut Strips) {
    ui.label("layers (inner to outer)");
    let mut remove = None;
    let n = st.layers.len();
    for (i, l) in st.layers.iter_mut().enumerate() {
        let title = if l.name.is_empty() {
            format!("layer {i}")
        } else {
            format!("layer {i}: {}", l.name)
        };
        egui::CollapsingHeader::new(title)
            .id_salt(("strip layer", i))
            .show(ui, |ui| {
                layer(ui, l);
                if n > 1 && ui.small_button("remove this layer").clicked() {
                    remove = Some(i);
                }
            });
    }
    if let Some(i) = remove {
        st.layers.remove(i);
    }
    if ui.small_button("add a layer (copy of the last)").clicked() {
        if let Some(last) = st.layers.last().cloned() {
            st.layers.push(Layer {
                name: format!("{} copy", last.name),
                ..last
            });
        }
    }
}

fn layer(ui: &mut Ui, l: &mut Layer) {
    ui.add(part(Slider::new(&mut l.count, 1..=120).text("strips")));
    ui.add(part(
        Slider::new(&mut l.polar, 1.0..=179.0).text("ring (degrees from the crown)"),
    ));
    ui.horizontal(|ui| {
        ui.label("azimuth");
        ui.add(DragValue::new(&mut l.azimuth[0]).range(-360.0..=360.0));
        ui.add(DragValue::new(&mut l.azimuth[1]).range(-360.0..=360.0));
    });
    if l.azimuth[1] < l.azimuth[0] {
        l.azimuth[1] = l.azimuth[0];
    }
    if l.azimuth[1] - l.azimuth[0] > 360.0 {
        l.azimuth[1] = l.azimuth[0] + 360.0;
    }
    ui.add(part(Slider::new(&mut l.length, 1.0..=80.0).text("length")));
    // The block's bounds where they make a usable slider.
    ui.add(Slider::new(&mut l.sticks, 1..=MAX_STRIP_STICKS).text("sticks"));
    ui.add(part(
        Slider::new(&mut l.width[0], 0.1..=10.0).text("width at the root"),
    ));
    ui.add(part(
        Slider::new(&mut l.width[1], 0.1..=10.0).text("width at the tip"),
    ));
    ui.add(Slider::new(&mut l.droop, 0.0..=1.0).text("droop"));
    ui.add(Slider::new(&mut l.curl, -MAX_CURL..=MAX_CURL).text("curl (degrees per stick)"));
    ui.add(
        Slider::new(&mut l.stiffness, 0.0..=MAX_LAYER_STIFFNESS)
            .logarithmic(true)
            .smallest_positive(0.01)
            .text("stiffness × "),
    );
    ui.horizontal(|ui| {
        ui.label("colour");
        ui.color_edit_button_rgb(&mut l.color);
    });
}

fn look(ui: &mut Ui, st: &mut Strips) {
    let k = &mut st.look;
    ui.label("look (the strand texture is generated at start-up)");
    ui.add(part(
        Slider::new(&mut k.hairs, 4..=64).text("hairs across a strip"),
    ));
    ui.add(part(
        Slider::new(&mut k.tip_shade, 0.2..=3.0).text("tip shade"),
    ));
    ui.add(part(
        Slider::new(&mut k.alpha_cutoff, 0.0..=0.95).text("alpha cut-off"),
    ));
    ui.add(part(
        Slider::new(&mut k.specular[0], 0.0..=2.0).text("specular"),
    ));
    ui.add(part(
        Slider::new(&mut k.specular[1], 2.0..=400.0)
            .logarithmic(true)
            .text("specular exponent"),
    ));
}

/// The brush of the EFF panel (kept between frames).
#[derive(Clone, Debug, PartialEq)]
pub struct Brush {
    pub center: [f64; 3],
    pub radius: f64,
    pub direction: [f64; 3],
    pub strength: f64,
    /// File for Load and Save.
    pub path: String,
    /// The field last built for the panel and the overlay, with the block it was built
    /// from: building runs the fill rules, too much work to repeat every UI frame.
    pub cache: Option<(EffDesc, std::sync::Arc<Eff>)>,
}

impl Default for Brush {
    fn default() -> Self {
        Brush {
            center: [0.0, -15.0, -12.0],
            radius: 10.0,
            direction: [0.0, 0.0, 1.0],
            strength: 600.0,
            path: "eff.eff".into(),
            cache: None,
        }
    }
}

/// Paint `force` into the cells within `radius` of `center` of `field` (the scene's field
/// as built), as point samples of the scene's EFF block at the cells' centres so the fill
/// rules work around them and the scene saves them. A painted cell's earlier samples are
/// replaced, not averaged with the new one: repeated strokes converge to the brush's force.
/// Returns the cells painted.
pub fn paint_into(
    desc: &mut EffDesc,
    field: &Eff,
    center: DVec3,
    radius: f64,
    force: DVec3,
) -> usize {
    let mut painted = field.clone();
    painted.paint(center, radius, force, 1.0);
    let changed: Vec<usize> = painted
        .cells()
        .iter()
        .zip(field.cells())
        .enumerate()
        .filter(|(_, (new, old))| (**new - **old).length() > 1e-9)
        .map(|(i, _)| i)
        .collect();
    let cell_of = |at: [f64; 3]| {
        let q = (DVec3::from(at) - field.origin()) / field.cell_size();
        let d = field.dims();
        (q.min_element() >= 0.0
            && (q.x as u32) < d[0]
            && (q.y as u32) < d[1]
            && (q.z as u32) < d[2])
            .then(|| field.index([q.x as u32, q.y as u32, q.z as u32]))
    };
    desc.samples
        .retain(|smp| cell_of(smp.at).is_none_or(|c| changed.binary_search(&c).is_err()));
    for &i in &changed {
        desc.samples.push(EffSample {
            at: painted.cell_center(i).to_array(),
            force: painted.cells()[i].to_array(),
        });
    }
    changed.len()
}

/// The field as the scene builds it (files read, fill rules applied), built again only
/// when the scene's EFF block changed.
pub fn built(
    scene: &Scene,
    cache: &mut Option<(EffDesc, std::sync::Arc<Eff>)>,
) -> Option<std::sync::Arc<Eff>> {
    let desc = scene.forces.eff.as_ref()?;
    if let Some((d, e)) = cache.as_ref() {
        if d == desc {
            return Some(e.clone());
        }
    }
    let e = Forces::new(&scene.forces, &scene.head).eff?;
    *cache = Some((desc.clone(), e.clone()));
    Some(e)
}

/// The EFF panel: the grid, the outside force, the gust keys, arrows in the view, a brush
/// that paints direction and strength into the cells, and load/save of EFF files.
pub fn eff(ui: &mut Ui, cx: &mut PanelCx) {
    let Some(s) = ui::state::<StripsUi>(cx.state) else {
        return;
    };
    let (scene, host) = (&mut *cx.scene, &mut *cx.host);
    if scene.forces.eff.is_none() {
        ui.label("this scene has no External Force Field");
        if ui.button("add one (a gust from the front-left)").clicked() {
            scene.forces.eff = Some(crate::forces::eff::front_left_gust());
        }
        return;
    }
    let field = built(scene, &mut s.brush.cache);
    if let Some(e) = &field {
        let d = e.dims();
        ui.label(format!(
            "{}×{}×{} cells of {:.1} cm; {} defined, the rest filled by the two rules; \
             strongest {:.0} cm/s²",
            d[0],
            d[1],
            d[2],
            e.cell_size().x,
            e.defined().iter().filter(|d| **d).count(),
            e.max_force()
        ));
    }
    ui.checkbox(&mut s.eff_arrows, "draw the cells as arrows in the view");
    let Some(desc) = scene.forces.eff.as_mut() else {
        return;
    };
    if let Some(f) = &desc.file {
        ui.label(format!("cells from {f}"));
    } else {
        ui.add(Slider::new(&mut desc.extent, 10.0..=200.0).text("extent (cm)"));
        ui.horizontal(|ui| {
            ui.label("cells per axis");
            for r in &mut desc.resolution {
                ui.add(DragValue::new(r).range(1..=64));
            }
        });
        ui.horizontal(|ui| {
            ui.label("wind source");
            for c in &mut desc.source {
                ui.add(DragValue::new(c).speed(1.0));
            }
        });
        ui.add(
            Slider::new(&mut desc.strength, 0.0..=3000.0)
                .logarithmic(true)
                .text("outside force (toward the head)"),
        );
    }
    ui.separator();
    gust_keys(ui, &mut desc.gust);
    ui.separator();
    ui.label("brush: paint a force into the cells around a point");
    let b = &mut s.brush;
    ui.horizontal(|ui| {
        ui.label("at");
        for c in &mut b.center {
            ui.add(DragValue::new(c).speed(0.5));
        }
    });
    ui.add(Slider::new(&mut b.radius, 1.0..=40.0).text("radius"));
    ui.horizontal(|ui| {
        ui.label("direction");
        for c in &mut b.direction {
            ui.add(DragValue::new(c).speed(0.05).range(-1.0..=1.0));
        }
    });
    ui.add(
        Slider::new(&mut b.strength, 0.0..=5000.0)
            .logarithmic(true)
            .text("strength (cm/s²)"),
    );
    ui.horizontal(|ui| {
        if ui.button("paint").clicked() {
            if let Some(e) = &field {
                let dir = DVec3::from(b.direction).normalize_or_zero();
                let n = paint_into(desc, e, DVec3::from(b.center), b.radius, dir * b.strength);
                host.message = Some(format!("painted {n} cells"));
            }
        }
        let mut mouse = s.paint_eff;
        if ui
            .checkbox(&mut mouse, "paint with the mouse")
            .on_hover_text(
                "a left drag in the view paints the drag's direction, at this radius and \
                 strength, into the cells under the cursor (in the plane through the head's \
                 centre facing you)",
            )
            .changed()
        {
            s.paint_eff = mouse;
            s.edit_strips &= !mouse;
        }
    });
    ui.separator();
    ui.horizontal(|ui| {
        ui.label("file");
        ui.text_edit_singleline(&mut b.path);
    });
    ui.horizontal(|ui| {
        if ui.button("save the field").clicked() {
            match field.as_ref().map(|e| e.save(&b.path)) {
                Some(Ok(())) => host.message = Some(format!("saved {}", b.path)),
                Some(Err(e)) => host.error = Some(e.to_string()),
                None => {}
            }
        }
        if ui.button("load a field").clicked() {
            let mut next = EffDesc {
                file: Some(b.path.clone()),
                gust: desc.gust.clone(),
                ..EffDesc::default()
            };
            match crate::forces::eff::resolve(&mut next, std::path::Path::new("")) {
                Ok(()) => *desc = next,
                Err(e) => host.error = Some(e.to_string()),
            }
        }
    });
}

/// The EFF's gust keys (frame, scale, blend), kept in frame order.
fn gust_keys(ui: &mut Ui, gust: &mut Vec<GustKey>) {
    ui.label("gust: the field's scale over time (frame, scale)");
    let mut remove = None;
    for (i, k) in gust.iter_mut().enumerate() {
        ui.horizontal(|ui| {
            ui.add(
                DragValue::new(&mut k.frame)
                    .range(0.0..=100_000.0)
                    .speed(1.0),
            );
            ui.add(DragValue::new(&mut k.scale).range(0.0..=100.0).speed(0.05));
            let mut linear = k.interp == Interp::Linear;
            ui.checkbox(&mut linear, "blend");
            k.interp = if linear { Interp::Linear } else { Interp::Step };
            if ui.small_button("x").clicked() {
                remove = Some(i);
            }
        });
    }
    if let Some(i) = remove {
        gust.remove(i);
    }
    if ui.small_button("add a gust key").clicked() {
        let frame = gust.last().map_or(0.0, |k| k.frame + 10.0);
        gust.push(GustKey {
            frame,
            scale: 1.0,
            interp: Interp::Linear,
        });
    }
    // Keys stay in frame order (the validator requires it).
    gust.sort_by(|a, b| a.frame.total_cmp(&b.frame));
}

/// The key-frame timeline (section 4): each edit pulls one strip toward a target between
/// two key frames; the clip re-simulates as soon as an edit changes.
pub fn keyframes(ui: &mut Ui, cx: &mut PanelCx) {
    let Some(s) = ui::state::<StripsUi>(cx.state) else {
        return;
    };
    let (scene, host) = (&mut *cx.scene, &mut *cx.host);
    let frame = host.frame;
    let Some(st) = scene.strips().as_ref() else {
        ui.label("this scene has no strips");
        return;
    };
    let strips: u32 = st.layers.iter().map(|l| l.count).sum();
    ui.horizontal(|ui| {
        ui.label(format!("frame {frame}"));
        ui.checkbox(&mut host.playing, "play");
    });
    timeline(ui, scene, host, s);
    let mut mouse = s.edit_strips;
    if ui
        .checkbox(&mut mouse, "pick strips and drag targets with the mouse")
        .on_hover_text(
            "left click a strip to pick it, K sets a first key at this frame; drag a pink \
             target marker to move the strip's pose at the second key",
        )
        .changed()
    {
        s.edit_strips = mouse;
        s.paint_eff &= !mouse;
    }
    ui.add(Slider::new(&mut s.key_strip, 0..=strips.saturating_sub(1)).text("strip"));
    ui.add(Slider::new(&mut s.key_span, 2..=120).text("frames to the second key"));
    if ui
        .button("add an edit: first key now, the strip swung 5 cm out (K)")
        .on_hover_text("the clip then shows the second key: drag the target there")
        .clicked()
    {
        if let Err(e) = s.add_edit(scene, host) {
            host.error = Some(e.to_string());
        }
    }
    ui.checkbox(&mut s.eff_arrows, "show targets and the field in the view");
    let Some(st) = scene.strips_mut().as_mut() else {
        return;
    };
    let mut remove = None;
    for (i, e) in st.edits.iter_mut().enumerate() {
        egui::CollapsingHeader::new(format!(
            "edit {i}: strip {}, frames {}..{}",
            e.strip, e.from, e.to
        ))
        .id_salt(("strip edit", i))
        .default_open(true)
        .show(ui, |ui| {
            ui.horizontal(|ui| {
                ui.label("keys");
                ui.add(DragValue::new(&mut e.from).range(0..=100_000));
                ui.add(DragValue::new(&mut e.to).range(1..=100_000));
            });
            if e.to <= e.from {
                e.to = e.from + 1;
            }
            ui.horizontal(|ui| {
                ui.label("target");
                for c in &mut e.target {
                    ui.add(DragValue::new(c).speed(0.1));
                }
            });
            ui.add(Slider::new(&mut e.radius, 1.0..=30.0).text("falloff radius"));
            if ui.small_button("remove").clicked() {
                remove = Some(i);
            }
        });
    }
    if let Some(i) = remove {
        st.edits.remove(i);
    }
}

/// The key-frame timeline: a frame ruler with the clock, and a row per edit with its two
/// keys and the release after them. A press on the ruler or between keys scrubs (the clip
/// is simulated again to that frame); a press on a key drags it.
fn timeline(ui: &mut Ui, scene: &mut Scene, host: &mut crate::systems::ui::Host, s: &mut StripsUi) {
    use super::pick::{move_key, Timeline, TimelineGrab};
    use egui::{pos2, vec2, Align2, FontId, Rect, Sense, Stroke};
    let Some(st) = scene.strips().as_ref() else {
        return;
    };
    const RULER: f32 = 18.0;
    const ROW: f32 = 14.0;
    let clip = scene
        .forces
        .head_capture
        .as_ref()
        .map(|h| h.keys.len() as u32);
    // While a key or the clock is held the timeline keeps its length: it would otherwise
    // grow under the pointer as the key (or the clock) moves right.
    let frames = s
        .timeline_grab
        .map_or_else(|| Timeline::span(&st.edits, host.frame, clip), |(_, f)| f);
    let height = RULER + ROW * st.edits.len().max(1) as f32 + 4.0;
    let (rect, resp) =
        ui.allocate_exact_size(vec2(ui.available_width(), height), Sense::click_and_drag());
    let tl = Timeline {
        left: f64::from(rect.left() + 6.0),
        width: f64::from(rect.width() - 12.0),
        frames,
    };
    let x = |f: f64| tl.x_of(f) as f32;
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 3.0, Color32::from_gray(28));
    // Ruler: a tick every 10 frames, a label every 30.
    for f in (0..=frames).step_by(10) {
        let tall = f % 30 == 0;
        let top = rect.top() + if tall { 2.0 } else { 9.0 };
        painter.line_segment(
            [
                pos2(x(f64::from(f)), top),
                pos2(x(f64::from(f)), rect.top() + RULER),
            ],
            Stroke::new(1.0, Color32::from_gray(110)),
        );
        if tall {
            // The last labels end at their tick, inside the timeline.
            let end = x(f64::from(f)) + 24.0 > rect.right();
            painter.text(
                pos2(
                    x(f64::from(f)) + if end { -2.0 } else { 2.0 },
                    rect.top() + 1.0,
                ),
                if end {
                    Align2::RIGHT_TOP
                } else {
                    Align2::LEFT_TOP
                },
                f.to_string(),
                FontId::proportional(10.0),
                Color32::from_gray(170),
            );
        }
    }
    let row_y = |r: usize| rect.top() + RULER + ROW * r as f32;
    for (r, e) in st.edits.iter().enumerate() {
        let y0 = row_y(r) + 2.0;
        let (a, b) = (x(f64::from(e.from)), x(f64::from(e.to)));
        let release = x(f64::from(e.to) + f64::from(e.to - e.from) / 2.0);
        let picked = e.strip == s.key_strip;
        let col = if picked {
            Color32::from_rgb(255, 80, 160)
        } else {
            Color32::from_rgb(170, 90, 130)
        };
        painter.rect_filled(
            Rect::from_min_max(pos2(a, y0 + 3.0), pos2(b, y0 + ROW - 5.0)),
            2.0,
            col.gamma_multiply(0.6),
        );
        painter.line_segment(
            [
                pos2(b, y0 + ROW / 2.0 - 1.0),
                pos2(release, y0 + ROW / 2.0 - 1.0),
            ],
            Stroke::new(1.0, col),
        );
        for k in [a, b] {
            painter.circle_filled(pos2(k, y0 + ROW / 2.0 - 1.0), 4.0, col);
        }
        painter.text(
            pos2(release + 4.0, y0 + ROW / 2.0 - 1.0),
            Align2::LEFT_CENTER,
            format!("strip {}", e.strip),
            FontId::proportional(10.0),
            Color32::from_gray(200),
        );
    }
    let now = x(host.frame as f64);
    painter.line_segment(
        [pos2(now, rect.top()), pos2(now, rect.bottom())],
        Stroke::new(2.0, Color32::from_rgb(255, 210, 90)),
    );
    if !resp.is_pointer_button_down_on() && !resp.drag_stopped() {
        s.timeline_grab = None;
    }
    let Some(p) = resp.interact_pointer_pos() else {
        return;
    };
    let at = tl.frame_at(f64::from(p.x));
    if resp.clicked() {
        // A click scrubs; only a drag moves keys.
        s.timeline_grab = None;
        if u64::from(at) != host.frame {
            host.seek = Some(u64::from(at));
            host.playing = false;
        }
        return;
    }
    if resp.drag_started() {
        // What was under the press, not where the pointer is once the drag is recognised.
        let o = ui.input(|i| i.pointer.press_origin()).unwrap_or(p);
        let row = (o.y >= rect.top() + RULER)
            .then(|| ((o.y - rect.top() - RULER) / ROW) as usize)
            .filter(|r| *r < st.edits.len());
        s.timeline_grab = Some((tl.grab(&st.edits, row, f64::from(o.x), 6.0), frames));
    }
    match s.timeline_grab.map(|(g, _)| g) {
        Some(g @ (TimelineGrab::From(i) | TimelineGrab::To(i))) => {
            if let Some(e) = scene
                .strips_mut()
                .as_mut()
                .and_then(|st| st.edits.get_mut(i))
            {
                move_key(e, g, at);
                s.key_strip = e.strip;
                let shown = if matches!(g, TimelineGrab::To(_)) {
                    e.to
                } else {
                    e.from
                };
                host.seek = Some(u64::from(shown));
                host.playing = false;
            }
        }
        Some(TimelineGrab::Scrub) if u64::from(at) != host.frame => {
            host.seek = Some(u64::from(at));
            host.playing = false;
        }
        _ => {}
    }
    if resp.drag_stopped() {
        s.timeline_grab = None;
    }
}

/// An edit of strip `strip` from `from` to `from + span`: its target is where the tip would
/// be at the second key, swung 5 cm out from the head about the root (in the head's rest
/// frame).
pub fn new_edit(scene: &Scene, strip: u32, from: u32, span: u32) -> crate::Result<Edit> {
    let st = scene
        .strips()
        .as_ref()
        .ok_or_else(|| crate::KamiError::Option("the scene has no strips".into()))?;
    let rest = super::hom::build(st, &scene.head)?;
    let r = rest
        .get(strip as usize)
        .ok_or_else(|| crate::KamiError::Option(format!("no strip {strip}")))?;
    let forces = Forces::new(&scene.forces, &scene.head);
    let to = from + span.max(1);
    let clip = super::dynamics::simulate(
        std::slice::from_ref(r),
        &st.motion,
        &forces,
        &scene.head,
        &[],
        to,
    )?;
    let last = clip.last().cloned().unwrap_or_default();
    let head = forces.head_at(f64::from(to)).inverse();
    let tip = head.transform_point3(last.last().copied().unwrap_or(DVec3::ZERO));
    let root = head.transform_point3(last.first().copied().unwrap_or(DVec3::ZERO));
    // Swing the strip out from the head about its root until the tip has moved 5 cm (a
    // force along a hanging strip cannot shorten it: targets lie on the sphere it reaches).
    let arm = tip - root;
    let out = (tip - DVec3::from(scene.head.center))
        .with_y(0.0)
        .normalize_or(DVec3::X);
    let axis = arm.cross(out).normalize_or(DVec3::Z);
    let angle = 2.0 * (2.5 / arm.length().max(2.5)).asin();
    let target = root + glam::DQuat::from_axis_angle(axis, angle) * arm;
    Ok(Edit {
        strip,
        from,
        to,
        target: target.to_array(),
        radius: 6.0,
    })
}

/// What [`overlay`] draws.
#[derive(Clone, Copy, Debug, Default)]
pub struct Show<'a> {
    /// The EFF's cells as arrows.
    pub arrows: bool,
    /// The key-frame targets.
    pub targets: bool,
    /// The picked strip's centre line, as last posed (world points).
    pub picked: Option<&'a [DVec3]>,
    /// The forces the stage runs (the head pose at a target's key); None: the scene's.
    pub forces: Option<&'a Forces>,
}

/// The colour of the key-frame targets and the picked strip.
pub const TARGET: Color32 = Color32::from_rgb(255, 80, 160);

/// Arrows for the EFF's cells (every other cell on each axis past 8 per axis), the
/// key-frame targets and the picked strip, over the 3D view. `view` projects world points.
pub fn overlay(
    ctx: &egui::Context,
    scene: &Scene,
    cache: &mut Option<(EffDesc, std::sync::Arc<Eff>)>,
    view: &crate::gpu::view::ScreenView,
    ppp: f32,
    show: Show<'_>,
) {
    use egui::{pos2, vec2, Id, LayerId, Order, Rect, Stroke};
    let ppp = ppp.max(1e-3);
    let clip = Rect::from_min_size(
        egui::Pos2::ZERO,
        vec2(view.size.x as f32 / ppp, view.size.y as f32 / ppp),
    );
    let painter = ctx
        .layer_painter(LayerId::new(Order::Middle, Id::unique("strips overlay")))
        .with_clip_rect(clip);
    let at = |q: DVec3| pos2(q.x as f32 / ppp, q.y as f32 / ppp);
    if let Some(line) = show.picked {
        let pts: Vec<egui::Pos2> = line
            .iter()
            .filter_map(|p| view.project(*p))
            .map(at)
            .collect();
        painter.add(egui::Shape::line(pts, Stroke::new(2.5, TARGET)));
    }
    if let Some(e) = show.arrows.then(|| built(scene, cache)).flatten() {
        let d = e.dims();
        let step = |n: u32| if n > 8 { 2 } else { 1 };
        let biggest = e.max_force().max(1e-9);
        let len = e.cell_size().min_element() * 0.9;
        for k in (0..d[2]).step_by(step(d[2])) {
            for j in (0..d[1]).step_by(step(d[1])) {
                for i in (0..d[0]).step_by(step(d[0])) {
                    let idx = e.index([i, j, k]);
                    let c = e.cell_center(idx);
                    let f = e.cells()[idx];
                    let m = f.length() / biggest;
                    if m < 0.05 {
                        continue;
                    }
                    let tip = c + f / f.length() * len * m;
                    if let (Some(a), Some(b)) = (view.project(c), view.project(tip)) {
                        let col = if e.defined()[idx] {
                            Color32::from_rgb(255, 200, 80)
                        } else {
                            Color32::from_rgb(110, 190, 255)
                        };
                        painter.arrow(at(a), at(b) - at(a), Stroke::new(1.2, col));
                    }
                }
            }
        }
    }
    if let Some(st) = scene.strips().as_ref().filter(|_| show.targets) {
        let own;
        let forces = match show.forces {
            Some(f) => f,
            None => {
                own = Forces::new(&scene.forces, &scene.head);
                &own
            }
        };
        for e in &st.edits {
            let p = forces
                .head_at(f64::from(e.to))
                .transform_point3(DVec3::from(e.target));
            if let Some(q) = view.project(p) {
                painter.circle_stroke(at(q), 6.0, Stroke::new(2.0, TARGET));
                painter.text(
                    at(q) + vec2(8.0, -8.0),
                    egui::Align2::LEFT_BOTTOM,
                    format!("strip {} @ {}", e.strip, e.to),
                    egui::FontId::proportional(12.0),
                    Color32::WHITE,
                );
            }
        }
    }
}
