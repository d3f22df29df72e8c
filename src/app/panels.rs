//! The viewer's egui panels, grouped the way an artist thinks: Files, Stiffness, Forces,
//! Pseudo-force, Look, Fur, Simulation, Stats (the hair panels open for a hair scene, Fur for
//! a fur scene). They only edit `ViewerState`; the window loop
//! classifies the edit (`params::Changes`) and applies it. Later features add their panels
//! here.

use super::params::{Request, ViewerState};
use crate::scene::{Bending, Dynamics, Fluctuation, Interp, PseudoForce, WindKey};
use egui::{Color32, Slider, Ui};

/// Shipped scenes offered by the Files panel.
pub const SHIPPED: &[&str] = &[
    "gust",
    "bob",
    "swept_back",
    "ponytail",
    "short_cut",
    "pseudo_force",
    "pseudo_force_off",
    "stiffness_smooth",
    "stiffness_free",
    "fur",
    "fur_fig9",
    "fur_line",
    "fur_polyline",
    "fur_curve",
    "fur_tube",
    "fur_lion_head",
];

/// Draw all panels in a right-hand side panel; returns the panel's left edge (points), where
/// the scene view ends.
pub fn show(ui: &mut Ui, s: &mut ViewerState) -> f32 {
    egui::Panel::right("kami panels")
        .default_size(340.0)
        .min_size(260.0)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.heading("Kami");
                if let Some(e) = &s.error {
                    ui.colored_label(Color32::from_rgb(255, 110, 90), e);
                }
                if let Some(m) = &s.message {
                    ui.label(m);
                }
                ui.collapsing("Files", |ui| files(ui, s));
                let hair = !s.scene.groups.is_empty();
                let fur_scene = s.scene.fur.is_some();
                egui::CollapsingHeader::new("Stiffness").default_open(hair).show(ui, |ui| stiffness(ui, s));
                ui.collapsing("Forces", |ui| forces(ui, s));
                ui.collapsing("Pseudo-force", |ui| pseudo(ui, s));
                ui.collapsing("Look", |ui| look(ui, s));
                egui::CollapsingHeader::new("Fur").default_open(fur_scene).show(ui, |ui| fur(ui, s));
                egui::CollapsingHeader::new("Simulation").default_open(true).show(ui, |ui| simulation(ui, s));
                egui::CollapsingHeader::new("Stats").default_open(true).show(ui, |ui| stats(ui, s));
                ui.separator();
                ui.small("Drag: orbit · right/middle or shift-drag: pan · wheel: zoom · F: frame · Space: play · N: step · R: reset · S: screenshot");
            });
        })
        .response
        .rect
        .left()
}

fn group_picker(ui: &mut Ui, s: &mut ViewerState) {
    if s.scene.groups.is_empty() {
        return;
    }
    s.group = s.group.min(s.scene.groups.len() - 1);
    let name = |i: usize, s: &ViewerState| {
        let n = &s.scene.groups[i].name;
        if n.is_empty() {
            format!("group {i}")
        } else {
            n.clone()
        }
    };
    let current = name(s.group, s);
    egui::ComboBox::from_label("group")
        .selected_text(current)
        .show_ui(ui, |ui| {
            for i in 0..s.scene.groups.len() {
                let n = name(i, s);
                ui.selectable_value(&mut s.group, i, n);
            }
        });
}

fn files(ui: &mut Ui, s: &mut ViewerState) {
    ui.horizontal(|ui| {
        ui.label("scene");
        ui.text_edit_singleline(&mut s.path);
    });
    ui.horizontal(|ui| {
        if ui.button("Open").clicked() {
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
    ui.label("shipped scenes:");
    ui.horizontal_wrapped(|ui| {
        for name in SHIPPED {
            if ui.small_button(*name).clicked() {
                s.path = format!("assets/scenes/{name}.ron");
                s.requests.push(Request::Open(s.path.clone()));
            }
        }
    });
}

fn stiffness(ui: &mut Ui, s: &mut ViewerState) {
    if s.scene.groups.is_empty() {
        ui.label("no hair groups (fur stiffness: see Fur)");
        return;
    }
    group_picker(ui, s);
    let g = &mut s.scene.groups[s.group];
    ui.add(
        Slider::new(&mut g.rigidity, 1.0..=5000.0)
            .logarithmic(true)
            .text("EI (flexural rigidity)"),
    );
    let mut converged = matches!(g.bending, Bending::Converged { .. });
    ui.horizontal(|ui| {
        ui.label("bending");
        ui.radio_value(&mut converged, false, "paper");
        ui.radio_value(&mut converged, true, "converged");
    });
    match (&g.bending, converged) {
        (Bending::Paper, true) => {
            g.bending = Bending::Converged {
                max_iterations: 400,
                tolerance: 1e-5,
            }
        }
        (Bending::Converged { .. }, false) => g.bending = Bending::Paper,
        _ => {}
    }
    if ui.small_button("use this EI for every group").clicked() {
        let e = g.rigidity;
        s.scene.groups.iter_mut().for_each(|g| g.rigidity = e);
    }
    let Some(d) = s.scene.dynamics.as_mut() else {
        ui.label("joint-angle stiffness and inertia act in dynamics (Simulation panel)");
        return;
    };
    ui.separator();
    ui.label("joint-angle stiffness σ (degrees; 180 = free)");
    ui.add(Slider::new(&mut d.stiffness.root, 0.0..=180.0).text("σ at the root"));
    ui.add(Slider::new(&mut d.stiffness.tip, 0.0..=180.0).text("σ at the tip"));
    ui.add(Slider::new(&mut d.stiffness.start, 0.0..=0.95).text("falls from (fraction)"));
    ui.add(Slider::new(&mut d.stiffness.end, 0.05..=1.0).text("reaches the tip value at"));
    // Keep the ramp non-empty while either end is dragged past the other.
    if d.stiffness.end <= d.stiffness.start {
        d.stiffness.end = (d.stiffness.start + 0.05).min(1.0);
    }
    profile_plot(
        ui,
        |t| d.stiffness.sigma_at(t) / 180.0,
        "σ along the strand (0..180°)",
    );
    ui.separator();
    ui.label("inertia profile (c_i scale)");
    ui.add(
        Slider::new(&mut d.inertia.root, 0.05..=5.0)
            .logarithmic(true)
            .text("root"),
    );
    ui.add(
        Slider::new(&mut d.inertia.tip, 0.05..=5.0)
            .logarithmic(true)
            .text("tip"),
    );
    ui.add(
        Slider::new(&mut d.inertia.top, 0.05..=5.0)
            .logarithmic(true)
            .text("top of head"),
    );
    ui.add(Slider::new(&mut d.inertia.top_height, -12.0..=12.0).text("top from height"));
    let (r, t) = (d.inertia.root, d.inertia.tip);
    let most = r.max(t).max(1e-9);
    profile_plot(
        ui,
        |x| (r + (t - r) * x) / most,
        "inertia factor along the strand",
    );
}

/// A small plot of `f(t)` in [0, 1] for t in [0, 1].
fn profile_plot(ui: &mut Ui, f: impl Fn(f64) -> f64, label: &str) {
    let (rect, painter) = ui.allocate_painter(
        egui::vec2(ui.available_width().min(300.0), 60.0),
        egui::Sense::hover(),
    );
    let r = rect.rect;
    painter.rect_filled(r, 2.0, Color32::from_gray(30));
    let pts: Vec<egui::Pos2> = (0..=40)
        .map(|i| {
            let t = i as f64 / 40.0;
            let v = f(t).clamp(0.0, 1.0);
            egui::pos2(
                r.left() + t as f32 * r.width(),
                r.bottom() - 4.0 - v as f32 * (r.height() - 8.0),
            )
        })
        .collect();
    painter.add(egui::Shape::line(
        pts,
        egui::Stroke::new(2.0, Color32::from_rgb(120, 200, 255)),
    ));
    painter.text(
        r.left_top() + egui::vec2(4.0, 2.0),
        egui::Align2::LEFT_TOP,
        label,
        egui::FontId::proportional(11.0),
        Color32::GRAY,
    );
}

fn need_dynamics(ui: &mut Ui, s: &mut ViewerState) -> bool {
    if s.scene.dynamics.is_none() {
        ui.label("this scene is static");
        if ui.button("Enable dynamics").clicked() {
            s.scene.dynamics = Some(Dynamics {
                gravity: [0.0, -150.0, 0.0],
                damping: 0.5,
                ..Default::default()
            });
        }
        return false;
    }
    true
}

fn vec3_edit(ui: &mut Ui, label: &str, v: &mut [f64; 3], speed: f64) {
    ui.horizontal(|ui| {
        ui.label(label);
        for c in v.iter_mut() {
            ui.add(egui::DragValue::new(c).speed(speed));
        }
    });
}

fn forces(ui: &mut Ui, s: &mut ViewerState) {
    if !need_dynamics(ui, s) {
        return;
    }
    let d = s.scene.dynamics.as_mut().unwrap();
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

fn pseudo(ui: &mut Ui, s: &mut ViewerState) {
    if !need_dynamics(ui, s) {
        return;
    }
    let d = s.scene.dynamics.as_mut().unwrap();
    let mut on = d.pseudo_force.is_some();
    ui.checkbox(&mut on, "pseudo-force field (Anjyo 3.2.2)");
    match (on, d.pseudo_force.is_some()) {
        (true, false) => {
            d.pseudo_force = Some(PseudoForce {
                alpha: -0.75,
                epsilon_pore: 0.1,
                epsilon_tip: 1.0,
                near: 1.5,
            })
        }
        (false, true) => d.pseudo_force = None,
        _ => {}
    }
    if let Some(p) = d.pseudo_force.as_mut() {
        ui.add(Slider::new(&mut p.alpha, -1.0..=1.0).text("α (facing threshold)"));
        ui.add(Slider::new(&mut p.epsilon_pore, 0.0..=1.0).text("ε near the pore"));
        ui.add(Slider::new(&mut p.epsilon_tip, 0.0..=1.0).text("ε at the tip"));
        ui.add(Slider::new(&mut p.near, 0.0..=10.0).text("near the head (distance)"));
    }
    ui.checkbox(&mut s.view.show_pseudo, "show affected segments (red)");
}

fn look(ui: &mut Ui, s: &mut ViewerState) {
    if s.scene.groups.is_empty() {
        ui.label("no hair groups (see Fur)");
        look_common(ui, s);
        return;
    }
    group_picker(ui, s);
    let m = &mut s.scene.groups[s.group].material;
    ui.horizontal(|ui| {
        ui.label("hair colour");
        ui.color_edit_button_rgb(&mut m.color);
    });
    ui.add(
        Slider::new(&mut m.width, 0.005..=0.5)
            .logarithmic(true)
            .text("width"),
    );
    ui.add(Slider::new(&mut m.tip_width, 0.0..=1.0).text("tip width (× root)"));
    ui.add(Slider::new(&mut m.ks, 0.0..=1.0).text("k_s (specular)"));
    ui.add(
        Slider::new(&mut m.shininess, 1.0..=1000.0)
            .logarithmic(true)
            .text("n (shininess)"),
    );
    ui.add(Slider::new(&mut m.kd, 0.0..=1.0).text("k_d (diffuse)"));
    ui.add(Slider::new(&mut m.ka, 0.0..=3.0).text("k_a mean"));
    ui.add(Slider::new(&mut m.ka_spread, 0.0..=1.0).text("k_a spread (per strand)"));
    if ui.small_button("use this look for every group").clicked() {
        let m = m.clone();
        s.scene
            .groups
            .iter_mut()
            .for_each(|g| g.material = m.clone());
    }
    look_common(ui, s);
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

fn simulation(ui: &mut Ui, s: &mut ViewerState) {
    if !need_dynamics(ui, s) {
        return;
    }
    ui.horizontal(|ui| {
        let label = if s.view.playing { "Pause" } else { "Play" };
        if ui.button(label).clicked() {
            s.view.playing = !s.view.playing;
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
    let d = s.scene.dynamics.as_mut().unwrap();
    ui.add(
        Slider::new(&mut d.dt, 0.005..=2.0)
            .logarithmic(true)
            .text("dt"),
    );
    ui.add(Slider::new(&mut d.steps_per_frame, 1..=20).text("steps per frame"));
    ui.add(
        Slider::new(&mut d.max_substeps, 1..=256)
            .logarithmic(true)
            .text("max substeps"),
    );
    ui.add(Slider::new(&mut d.damping, 0.0..=10.0).text("damping (per time)"));
    ui.add(
        Slider::new(&mut d.density, 0.05..=20.0)
            .logarithmic(true)
            .text("density ρ"),
    );
    ui.checkbox(&mut d.collision, "hard collision with the head");
    let mut fl = d.fluctuation.is_some();
    ui.checkbox(&mut fl, "gently blowing (random kicks)");
    match (fl, d.fluctuation.is_some()) {
        (true, false) => {
            d.fluctuation = Some(Fluctuation {
                amplitude: 5.0,
                period: 10,
            })
        }
        (false, true) => d.fluctuation = None,
        _ => {}
    }
    if let Some(f) = d.fluctuation.as_mut() {
        ui.add(Slider::new(&mut f.amplitude, 0.0..=45.0).text("kick amplitude (°)"));
        ui.add(Slider::new(&mut f.period, 1..=60).text("every (frames)"));
    }
    if ui.small_button("Disable dynamics").clicked() {
        s.scene.dynamics = None;
    }
}

fn stats(ui: &mut Ui, s: &ViewerState) {
    let st = &s.stats;
    egui::Grid::new("stats").num_columns(2).show(ui, |ui| {
        ui.label("fps");
        ui.label(format!("{:.1}", st.fps));
        ui.end_row();
        ui.label("sim / scene");
        ui.label(format!("{:.1} / {:.1} ms", st.sim_ms, st.render_ms));
        ui.end_row();
        ui.label("panels / present");
        ui.label(format!("{:.1} / {:.1} ms", st.ui_ms, st.present_ms));
        ui.end_row();
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
        ui.label("hairs drawn");
        let msaa = if s.view.msaa_dropped {
            " (MSAA off to keep up)"
        } else {
            ""
        };
        ui.label(format!("{:.0} %{msaa}", s.view.hair_fraction * 100.0));
        ui.end_row();
        ui.label("image");
        ui.label(format!("{}x{}", st.size.0, st.size.1));
        ui.end_row();
        ui.label("adapter");
        ui.label(&st.adapter);
        ui.end_row();
    });
}

/// Three drag values for a direction vector (normalised where it is used).
fn vector(ui: &mut Ui, label: &str, v: &mut [f64; 3]) {
    ui.horizontal(|ui| {
        ui.label(label);
        for (c, axis) in v.iter_mut().zip(["x", "y", "z"]) {
            ui.add(
                egui::DragValue::new(c)
                    .speed(0.02)
                    .range(-1.0..=1.0)
                    .prefix(format!("{axis} ")),
            );
        }
    });
}

/// The body-segment direction and the regions with their own length and direction.
fn fur_regions(ui: &mut Ui, f: &mut crate::scene::fur::Fur) {
    vector(ui, "direction", &mut f.direction);
    let mut remove = None;
    for (i, r) in f.regions.iter_mut().enumerate() {
        ui.separator();
        ui.horizontal(|ui| {
            ui.label(format!("region {i} centre"));
            for c in r.center.iter_mut() {
                ui.add(egui::DragValue::new(c).speed(0.02));
            }
            if ui.small_button("remove").clicked() {
                remove = Some(i);
            }
        });
        ui.add(
            Slider::new(&mut r.radius, 0.01..=5.0)
                .logarithmic(true)
                .text("radius"),
        );
        ui.add(
            Slider::new(&mut r.length_scale, 0.05..=5.0)
                .logarithmic(true)
                .text("length scale"),
        );
        let mut own = r.direction.is_some();
        ui.checkbox(&mut own, "own direction");
        match (own, r.direction.is_some()) {
            (true, false) => r.direction = Some(f.direction),
            (false, true) => r.direction = None,
            _ => {}
        }
        if let Some(d) = r.direction.as_mut() {
            vector(ui, "direction", d);
        }
    }
    if let Some(i) = remove {
        f.regions.remove(i);
    }
    if ui.small_button("add a region").clicked() {
        f.regions.push(crate::scene::fur::Region {
            center: [0.0; 3],
            radius: 0.5,
            length_scale: 1.0,
            direction: None,
        });
    }
}

fn fur(ui: &mut Ui, s: &mut ViewerState) {
    use crate::scene::fur::{Coat, FurMaterial, FurStyle};
    let Some(f) = s.scene.fur.as_mut() else {
        ui.label("this scene has no fur");
        if ui.button("Add fur on the critter").clicked() {
            s.path = "assets/scenes/fur.ron".into();
            s.requests.push(Request::Open(s.path.clone()));
        }
        return;
    };
    ui.add(
        Slider::new(&mut f.hairs, 1000..=500_000)
            .logarithmic(true)
            .text("hairs (full density)"),
    );
    ui.add(
        Slider::new(&mut f.length, 0.01..=2.0)
            .logarithmic(true)
            .text("length"),
    );
    ui.checkbox(&mut f.culling.enabled, "distance-based culling");
    egui::CollapsingHeader::new(format!("direction and regions ({})", f.regions.len()))
        .id_salt("fur regions")
        .show(ui, |ui| fur_regions(ui, f));
    let mut moving = f.motion.is_some();
    ui.checkbox(&mut moving, "animated body wave");
    match (moving, f.motion.is_some()) {
        (true, false) => {
            f.motion = Some(crate::scene::fur::MeshMotion {
                amplitude: 0.18,
                wavelength: 4.0,
                period: 24.0,
                axis: [1.0, 0.0, 0.0],
                direction: [0.0, 1.0, 0.0],
            })
        }
        (false, true) => f.motion = None,
        _ => {}
    }
    if let Some(m) = f.motion.as_mut() {
        ui.add(Slider::new(&mut m.amplitude, 0.0..=1.0).text("wave amplitude"));
        ui.add(Slider::new(&mut m.period, 4.0..=120.0).text("wave period (frames)"));
    }
    let mut remove = None;
    let n = f.coats.len();
    for (i, c) in f.coats.iter_mut().enumerate() {
        let title = if c.name.is_empty() {
            format!("coat {i}")
        } else {
            c.name.clone()
        };
        egui::CollapsingHeader::new(title)
            .id_salt(("coat", i))
            .default_open(i == 0)
            .show(ui, |ui| {
                ui.add(Slider::new(&mut c.share, 0.01..=1.0).text("share"));
                ui.add(Slider::new(&mut c.relative_length, 0.05..=3.0).text("relative length"));
                ui.add(Slider::new(&mut c.stiffness, 0.0..=1.0).text("stiffness"));
                ui.add(Slider::new(&mut c.normal_randomize, 0.0..=1.0).text("normal randomize"));
                ui.add(Slider::new(&mut c.end_randomize, 0.0..=1.0).text("hair end randomize"));
                ui.add(
                    Slider::new(&mut c.direction_weight, 0.0..=1.0)
                        .text("segment direction weight"),
                );
                ui.horizontal(|ui| {
                    ui.label("style");
                    for (st, name) in [
                        (FurStyle::Line, "line"),
                        (FurStyle::Polyline, "polyline"),
                        (FurStyle::Curve, "curve"),
                        (FurStyle::Tube, "tube"),
                    ] {
                        ui.radio_value(&mut c.style, st, name);
                    }
                });
                let m = &mut c.material;
                ui.horizontal(|ui| {
                    ui.label("ambient");
                    ui.color_edit_button_rgb(&mut m.ambient);
                    ui.label("diffuse");
                    ui.color_edit_button_rgb(&mut m.diffuse);
                    ui.label("specular");
                    ui.color_edit_button_rgb(&mut m.specular);
                });
                ui.add(
                    Slider::new(&mut m.shininess, 1.0..=200.0)
                        .logarithmic(true)
                        .text("shininess"),
                );
                ui.add(
                    Slider::new(&mut m.width, 0.0005..=0.05)
                        .logarithmic(true)
                        .text("width"),
                );
                if n > 1 && ui.small_button("remove coat").clicked() {
                    remove = Some(i);
                }
            });
    }
    if let Some(i) = remove {
        f.coats.remove(i);
    }
    if f.coats.len() < 4 && ui.small_button("add an undercoat").clicked() {
        f.coats.push(Coat {
            name: "undercoat".into(),
            share: 0.4,
            relative_length: 0.3,
            stiffness: 0.8,
            normal_randomize: 0.3,
            end_randomize: 0.05,
            direction_weight: 0.1,
            style: FurStyle::Polyline,
            material: FurMaterial::default(),
        });
    }
    ui.label("looks of Figure 2:");
    ui.horizontal(|ui| {
        if ui.small_button("Figure 8").clicked() {
            for c in &mut f.coats {
                c.stiffness = 0.2;
                c.normal_randomize = 0.0;
                c.end_randomize = 0.2;
                c.direction_weight = 0.2;
                c.material.ambient = [0.3, 0.14, 0.0];
                c.material.shininess = 16.0;
            }
        }
        if ui.small_button("Figure 9").clicked() {
            for c in &mut f.coats {
                c.stiffness = 0.2;
                c.normal_randomize = 0.5;
                c.end_randomize = 0.1;
                c.direction_weight = 0.3;
                c.material.ambient = [0.15, 0.07, 0.0];
                c.material.shininess = 50.0;
            }
        }
    });
}
