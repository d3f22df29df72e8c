//! The viewer's egui panels. The shell draws the stage's own panels — Files, Forces (the
//! shared force fields), Look (light, background, anti-aliasing, level of detail),
//! Simulation (the clock: play, step, reset, time scale) and Stats — around the panels each
//! kind in the scene brings (`systems::Kind::panels`, in `KINDS` order; `visible`). Every
//! panel only edits `ViewerState` (a kind's panels its scene, `Host` and the kind's own
//! state); the window loop hands the edited scene to the stage, which classifies the edit
//! per system (`systems::Change`) and applies it.

use super::params::{Request, ViewerState};
use crate::scene::{Interp, WindKey};
use crate::systems::ui::PanelCx;
use crate::systems::Scene;
use crate::systems::{Panel, KINDS};
use egui::{Color32, Slider, Ui};

/// Shipped scenes offered by the Files panel: every kind's, in `KINDS` order.
pub fn shipped() -> Vec<&'static str> {
    let mut all: Vec<&'static str> = Vec::new();
    for kind in KINDS {
        for name in kind.scenes {
            if !all.contains(name) {
                all.push(name);
            }
        }
    }
    all
}

/// The kinds' panels shown for `scene`, as (index in `KINDS`, panel): every panel of each
/// kind the scene has, and on scenes without a kind only the panels that offer to add it
/// (`Panel::adds`).
pub fn visible(scene: &Scene) -> Vec<(usize, &'static Panel)> {
    let mut shown = Vec::new();
    for (i, kind) in KINDS.iter().enumerate() {
        let here = (kind.in_scene)(scene);
        shown.extend(
            kind.panels
                .iter()
                .filter(|p| here || p.adds)
                .map(|p| (i, p)),
        );
    }
    shown
}

/// Draw all panels in a right-hand side panel; returns the panel's left edge (points), where
/// the scene view ends.
pub fn show(ui: &mut Ui, s: &mut ViewerState) -> f32 {
    egui::Panel::right("kami panels")
        .default_size(340.0)
        .min_size(260.0)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.heading("Kami");
                if let Some(e) = &s.host.error {
                    ui.colored_label(Color32::from_rgb(255, 110, 90), e);
                }
                if let Some(m) = &s.host.message {
                    ui.label(m);
                }
                ui.collapsing("Files", |ui| files(ui, s));
                for (i, panel) in visible(&s.scene) {
                    let open = (panel.open)(&s.scene);
                    egui::CollapsingHeader::new(panel.title)
                        .id_salt((KINDS[i].name, panel.title))
                        .default_open(open)
                        .show(ui, |ui| {
                            let mut cx = PanelCx {
                                scene: &mut s.scene,
                                host: &mut s.host,
                                state: s.kinds[i].as_mut(),
                            };
                            (panel.show)(ui, &mut cx)
                        });
                }
                // A panel asked for a scene file (the Fur panel's example).
                if let Some(path) = s.host.open.take() {
                    s.path = path;
                    s.requests.push(Request::Open(s.path.clone()));
                }
                ui.collapsing("Forces", |ui| forces(ui, s));
                ui.collapsing("Look", |ui| look_common(ui, s));
                egui::CollapsingHeader::new("Simulation").default_open(true).show(ui, |ui| playback(ui, s));
                egui::CollapsingHeader::new("Stats").default_open(true).show(ui, |ui| stats(ui, s));
                ui.separator();
                ui.small("Drag: orbit · right/middle or shift-drag: pan · wheel: zoom · F: frame · Space: play · N: step · R: reset · S: screenshot");
                for help in s.kinds.iter().filter_map(|k| k.help()) {
                    ui.small(help);
                }
            });
        })
        .response
        .rect
        .left()
}

/// The clock: play, step and reset every system together, and how many frames pass per
/// drawn frame.
fn playback(ui: &mut Ui, s: &mut ViewerState) {
    ui.horizontal(|ui| {
        let label = if s.host.playing { "Pause" } else { "Play" };
        if ui.button(label).clicked() {
            s.host.playing = !s.host.playing;
        }
        if ui.button("Step").clicked() {
            s.requests.push(Request::Step);
        }
        if ui.button("Reset").clicked() {
            s.requests.push(Request::Reset);
        }
    });
    ui.add(
        Slider::new(&mut s.view.time_scale, 0.05..=4.0)
            .logarithmic(true)
            .text("time scale (frames per draw)"),
    );
    ui.label(format!("frame {}", s.stats.frame));
}

fn files(ui: &mut Ui, s: &mut ViewerState) {
    ui.horizontal(|ui| {
        ui.label("scene");
        ui.text_edit_singleline(&mut s.path);
    });
    ui.horizontal(|ui| {
        if ui
            .button("Open")
            .on_hover_text("load the file from scratch (also reloads an unchanged file)")
            .clicked()
        {
            s.requests.push(Request::Open(s.path.clone()));
        }
        if ui.button("Save").clicked() {
            s.requests.push(Request::Save(s.path.clone()));
        }
        if ui.button("Screenshot").clicked() {
            s.requests
                .push(Request::Screenshot("kami-screenshot.png".into()));
        }
    });
    ui.horizontal(|ui| {
        ui.label("hair file");
        ui.text_edit_singleline(&mut s.export_path)
            .on_hover_text(".hair, .obj (polylines) or .usda (BasisCurves)");
        if ui
            .button("Export")
            .on_hover_text("write the hair as it is now (this frame) to the file")
            .clicked()
        {
            s.requests.push(Request::Export(s.export_path.clone()));
        }
    });
    ui.checkbox(&mut s.view.watch, "reload on save")
        .on_hover_text(
        "reload the scene when its file, or a file it names (mesh, strand file, capture, EFF), \
         is saved; the camera, the clock and the panels stay, and what you set here that the \
         file did not change",
    );
    ui.label(
        "Open also takes a strand file (.hair, .obj, .usda, .abc): it opens as hair on a head",
    );
    ui.label("shipped scenes:");
    ui.horizontal_wrapped(|ui| {
        for name in shipped() {
            if ui.small_button(name).clicked() {
                s.path = format!("assets/scenes/{name}.ron");
                s.requests.push(Request::Open(s.path.clone()));
            }
        }
    });
}

fn vec3_edit(ui: &mut Ui, label: &str, v: &mut [f64; 3], speed: f64) {
    ui.horizontal(|ui| {
        ui.label(label);
        for c in v.iter_mut() {
            ui.add(egui::DragValue::new(c).speed(speed));
        }
    });
}

/// The world's forces (`scene.forces`), shared by every kind: no kind's dynamics needed.
fn forces(ui: &mut Ui, s: &mut ViewerState) {
    let d = &mut s.scene.forces;
    vec3_edit(ui, "gravity", &mut d.gravity, 1.0);
    ui.label("wind keys (frame, force, step/linear):");
    let mut remove = None;
    for (i, k) in d.wind.iter_mut().enumerate() {
        ui.horizontal(|ui| {
            ui.add(
                egui::DragValue::new(&mut k.frame)
                    .speed(0.5)
                    .range(0.0..=1e6),
            );
            for c in k.force.iter_mut() {
                ui.add(egui::DragValue::new(c).speed(1.0));
            }
            let mut linear = k.interp == Interp::Linear;
            ui.checkbox(&mut linear, "lin");
            k.interp = if linear { Interp::Linear } else { Interp::Step };
            if ui.small_button("x").clicked() {
                remove = Some(i);
            }
        });
    }
    if let Some(i) = remove {
        d.wind.remove(i);
    }
    if ui.small_button("add wind key").clicked() {
        let frame = d.wind.last().map_or(0.0, |k| k.frame + 10.0);
        d.wind.push(WindKey {
            frame,
            force: [-100.0, 0.0, 0.0],
            interp: Interp::Step,
        });
    }
    // Keys must stay in frame order for validation.
    d.wind.sort_by(|a, b| a.frame.total_cmp(&b.frame));
    d.wind.dedup_by(|a, b| a.frame == b.frame);
    let mut head = !d.head_motion.is_empty();
    let had = head;
    ui.checkbox(&mut head, "head motion");
    if head != had {
        if head {
            d.head_motion = std::mem::take(&mut s.parked_head_motion);
            if d.head_motion.is_empty() {
                d.head_motion = default_head_motion();
            }
        } else {
            s.parked_head_motion = std::mem::take(&mut d.head_motion);
        }
    }
}

/// A head turn back and forth, for scenes without their own motion.
fn default_head_motion() -> Vec<crate::scene::HeadKey> {
    use crate::scene::HeadKey;
    let key = |frame: f64, y: f64| HeadKey {
        frame,
        rotate: [0.0, y, 0.0],
        translate: [0.0; 3],
        interp: Interp::Linear,
    };
    vec![
        key(0.0, 0.0),
        key(8.0, 50.0),
        key(16.0, -50.0),
        key(24.0, 0.0),
    ]
}

/// Light, background and anti-aliasing: shared by hair and fur.
fn look_common(ui: &mut Ui, s: &mut ViewerState) {
    ui.separator();
    let l = &mut s.scene.light;
    let dir = glam::DVec3::from(l.direction).normalize();
    let mut azimuth = dir.z.atan2(dir.x).to_degrees();
    let mut elevation = dir.y.clamp(-1.0, 1.0).asin().to_degrees();
    let a = ui.add(Slider::new(&mut azimuth, -180.0..=180.0).text("light azimuth"));
    let e = ui.add(Slider::new(&mut elevation, -89.0..=89.0).text("light elevation"));
    if a.changed() || e.changed() {
        let (az, el) = (azimuth.to_radians(), elevation.to_radians());
        l.direction = [el.cos() * az.cos(), el.sin(), el.cos() * az.sin()];
    }
    ui.add(Slider::new(&mut l.intensity, 0.0..=3.0).text("I_s (light)"));
    ui.add(Slider::new(&mut l.ambient, 0.0..=3.0).text("I_a (ambient)"));
    let sh = &mut s.scene.render.shadows;
    ui.horizontal(|ui| {
        ui.checkbox(&mut sh.on, "shadows")
            .on_hover_text("hair shadows from the key light, on hair, the head and fur skin (docs/shadows.md; kami bench shadows)");
        ui.radio_value(&mut sh.method, crate::scene::ShadowMethod::Volume, "volume");
        ui.radio_value(&mut sh.method, crate::scene::ShadowMethod::DeepOpacity, "deep opacity");
    });
    ui.add(Slider::new(&mut sh.absorption, 0.0..=3.0).text("shadow absorption per strand"));
    ui.horizontal(|ui| {
        ui.label("background");
        ui.color_edit_button_rgb(&mut s.scene.render.background);
        ui.label("skin");
        ui.color_edit_button_rgb(&mut s.scene.head.color);
    });
    ui.separator();
    let r = &mut s.scene.render;
    ui.horizontal(|ui| {
        ui.label("MSAA");
        ui.radio_value(&mut r.msaa, 1, "off");
        ui.radio_value(&mut r.msaa, 4, "4x");
    });
    ui.horizontal(|ui| {
        ui.label("strands")
            .on_hover_text("auto: compute for thin strands, ribbons for close-ups, by the widest strand's width against the switch point kami bench raster measured (docs/raster_switch.ron); ribbons: two triangles per segment; compute: the compute rasteriser for thin strands (analytic coverage)");
        ui.radio_value(&mut r.strands, crate::scene::StrandRaster::Auto, "auto");
        ui.radio_value(&mut r.strands, crate::scene::StrandRaster::Ribbons, "ribbons");
        ui.radio_value(&mut r.strands, crate::scene::StrandRaster::Compute, "compute");
    });
    ui.add(Slider::new(&mut r.supersample, 1..=4).text("supersampling (renders)"));
    ui.checkbox(
        &mut s.view.full_supersampling,
        "supersample in the viewer too",
    );
    ui.add(Slider::new(&mut r.min_width, 0.25..=4.0).text("narrowest strand (samples)"));
    ui.checkbox(&mut s.view.adaptive_lod, "adaptive level of detail");
    if s.view.adaptive_lod {
        ui.add(
            Slider::new(&mut s.view.frame_budget_ms, 16.0..=500.0)
                .logarithmic(true)
                .text("frame budget (ms)"),
        );
    } else {
        ui.add(
            Slider::new(&mut s.view.hair_fraction, 0.01..=1.0)
                .logarithmic(true)
                .text("share of hairs drawn"),
        );
    }
}

fn stats(ui: &mut Ui, s: &ViewerState) {
    let st = &s.stats;
    egui::Grid::new("stats").num_columns(2).show(ui, |ui| {
        ui.label("fps");
        ui.label(format!("{:.1}", st.fps));
        ui.end_row();
        // Per-pass GPU times from timestamp queries (a few frames late; nothing waits).
        match (&st.gpu, st.timestamps) {
            (Some(t), _) => {
                for p in crate::gpu::timing::Phase::ALL {
                    if let Some(ms) = t.get(p) {
                        ui.label(format!("GPU {}", p.name()));
                        ui.label(format!("{ms:.2} ms"));
                        ui.end_row();
                    }
                }
                if let Some(ms) = t.frame {
                    ui.label("GPU frame");
                    ui.label(format!("{ms:.2} ms (busy {:.2})", t.busy()));
                    ui.end_row();
                }
            }
            (None, true) => {
                ui.label("GPU passes");
                ui.label("waiting for the first timings");
                ui.end_row();
            }
            (None, false) => {
                ui.label("GPU passes");
                ui.label("no timestamp queries on this adapter");
                ui.end_row();
            }
        }
        ui.label("CPU recording");
        ui.label(format!("{:.1} ms", st.record_ms));
        ui.end_row();
        for w in &st.warnings {
            ui.label("warning");
            ui.colored_label(egui::Color32::from_rgb(230, 120, 40), w);
            ui.end_row();
        }
        ui.label("last groom");
        ui.label(format!("{:.0} ms", st.groom_ms));
        ui.end_row();
        ui.label("hairs / segments");
        ui.label(format!("{} / {}", st.strands, st.segments));
        ui.end_row();
        ui.label("simulated hairs");
        ui.label(format!("{}", st.simulated));
        ui.end_row();
        ui.label("frame (substeps)");
        ui.label(format!("{} ({})", st.frame, st.substeps));
        ui.end_row();
        // What the frame budget drops now to keep up (the adaptive level of detail).
        ui.label("drawing");
        ui.label(s.view.dropping());
        ui.end_row();
        for (kind, c) in &st.systems {
            ui.label(*kind);
            ui.label(format!(
                "{} drawn of {} ({} simulated)",
                c.drawn, c.strands, c.simulated
            ));
            ui.end_row();
            // Which rasteriser drew its thin strands (`render.strands: Auto` picks by width).
            if let Some(r) = c.raster {
                ui.label("");
                ui.label(r.to_string());
                ui.end_row();
            }
        }
        ui.label("image");
        ui.label(format!("{}x{}", st.size.0, st.size.1));
        ui.end_row();
        ui.label("adapter");
        ui.label(&st.adapter);
        ui.end_row();
    });
}
