//! Anjyo's panels in the viewer: Stiffness (EI, bending mode, joint-angle stiffness and
//! inertia profiles), Pseudo-force, Hair look (per group) and Dynamics, and Anjyo's `--set`
//! keys. They edit the scene and `AnjyoUi` (the group the panels edit); the stage
//! classifies the edit with `super::classify` and applies it.

use crate::systems::anjyo::block::{AnjyoBlock, Bending, Dynamics, Fluctuation, PseudoForce};
use crate::systems::kind::Panel;
use crate::systems::scene::Scene;
use crate::systems::ui::{self, Host, KindUi, PanelCx};
use egui::{Color32, Slider, Ui};

pub const PANELS: &[Panel] = &[
    Panel {
        title: "Stiffness",
        open: |s| !s.groups().is_empty(),
        adds: false,
        show: stiffness,
    },
    Panel {
        title: "Pseudo-force",
        open: |_| false,
        adds: false,
        show: pseudo,
    },
    Panel {
        title: "Hair look",
        open: |_| false,
        adds: false,
        show: look,
    },
    Panel {
        title: "Cache",
        open: |s| s.groups().iter().any(plays),
        adds: false,
        show: cache,
    },
    Panel {
        title: "Dynamics",
        open: |s| s.dynamics().is_some() && !s.groups().is_empty(),
        adds: false,
        show: dynamics,
    },
];

/// Anjyo's state in the viewer: the hair group the per-group panels edit.
#[derive(Debug, Default)]
pub struct AnjyoUi {
    pub group: usize,
}

impl KindUi for AnjyoUi {
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }

    fn opened(&mut self) {
        self.group = 0;
    }

    /// Still hair groups start moving under a force set from the command line, as they did
    /// when the forces sat in their dynamics block.
    fn force_set(&mut self, scene: &mut Scene) {
        if !scene.groups().is_empty() {
            dynamics_of(scene);
        }
    }

    /// `color=r,g,b`, `width=w`, `ks=k`, `shininess=n`, `melanin=m`, `redness=r` (the
    /// physical mode's, `docs/shading.md`), `rigidity=EI` (every group),
    /// `file_colors=on|off`, `file_widths=on|off` (groups read from strand files),
    /// `stiffness=root,tip`, `damping=rate`, `pseudo=on|off`, `simulate_from_here` (groups
    /// playing a cache: the frame shown becomes their rest pose, simulated).
    fn set(
        &mut self,
        scene: &mut Scene,
        host: &mut Host,
        key: &str,
        value: Option<&str>,
    ) -> Option<Result<(), String>> {
        let groups = |f: &dyn Fn(&mut crate::systems::anjyo::block::HairGroup, f64),
                      scene: &mut Scene|
         -> Result<(), String> {
            let v = ui::nums(value, 1)?[0];
            scene.groups_mut().iter_mut().for_each(|g| f(g, v));
            Ok(())
        };
        Some(match key {
            "color" => ui::nums(value, 3).map(|c| {
                for g in scene.groups_mut() {
                    g.material.color = [c[0] as f32, c[1] as f32, c[2] as f32];
                }
            }),
            "width" => groups(&|g, v| g.material.width = v, scene),
            "ks" => groups(&|g, v| g.material.ks = v, scene),
            "shininess" => groups(&|g, v| g.material.shininess = v, scene),
            "melanin" => groups(&|g, v| g.material.physical.melanin = Some(v), scene),
            "redness" => groups(&|g, v| g.material.physical.redness = v, scene),
            "rigidity" => groups(&|g, v| g.rigidity = v, scene),
            "file_colors" | "file_widths" => ui::on(value).map(|on| {
                for f in scene
                    .groups_mut()
                    .iter_mut()
                    .filter_map(|g| g.file.as_mut())
                {
                    if key == "file_colors" {
                        f.colors = on;
                    } else {
                        f.widths = on;
                    }
                }
            }),
            "stiffness" => ui::nums(value, 2).map(|s| {
                let d = dynamics_of(scene);
                d.stiffness.root = s[0];
                d.stiffness.tip = s[1];
            }),
            "damping" => ui::nums(value, 1).map(|v| dynamics_of(scene).damping = v[0]),
            "pseudo" => ui::on(value).map(|on| {
                dynamics_of(scene).pseudo_force = on.then(default_pseudo_force);
            }),
            "simulate_from_here" => simulate_from_here(scene, host.frame),
            _ => return None,
        })
    }
}

/// Whether a group plays its file's frames.
fn plays(g: &crate::systems::anjyo::block::HairGroup) -> bool {
    g.file.as_ref().is_some_and(|f| f.frames.is_some())
}

/// The most frames of any playing group (the loop's length).
fn longest_cache(scene: &Scene) -> usize {
    scene
        .groups()
        .iter()
        .filter_map(|g| g.file.as_ref()?.frames.as_ref())
        .map(|f| f.points.len())
        .max()
        .unwrap_or(1)
}

/// The frame of a cache of `n` frames shown at Kami's `frame`, as `playback::Playback`
/// shows it: the loop runs over the longest cache, a shorter one holds its last frame.
fn shown(frame: u64, longest: usize, n: usize) -> usize {
    ((frame % longest.max(1) as u64) as usize).min(n.saturating_sub(1))
}

/// Every playing group's frame shown at Kami's `frame` becomes its rest pose: the file is
/// read at that time from now on (`time`, `play: false`, so a saved scene reopens the
/// same), the group is simulated (the scene gets dynamics if it had none). The stage
/// rebuilds the hair from the new rest pose.
pub fn simulate_from_here(scene: &mut Scene, frame: u64) -> Result<(), String> {
    let mut any = false;
    let longest = longest_cache(scene);
    for g in scene.groups_mut().iter_mut().filter(|g| plays(g)) {
        let Some(f) = g.file.as_mut() else { continue };
        let (Some(frames), Some(groom)) = (f.frames.take(), f.groom.as_ref()) else {
            continue;
        };
        let k = shown(frame, longest, frames.points.len());
        let mut rest = (**groom).clone();
        rest.points = frames.points[k].clone();
        f.groom = Some(std::sync::Arc::new(rest));
        f.time = Some(frames.times[k]);
        f.play = false;
        g.dynamic = true;
        any = true;
    }
    if !any {
        return Err("no hair group plays a cache".into());
    }
    dynamics_of(scene);
    Ok(())
}

/// The cache panel: which groups play which frames, a scrub over the file's frames, and
/// "simulate from here".
fn cache(ui: &mut Ui, cx: &mut PanelCx) {
    let frame = cx.host.frame;
    let longest = longest_cache(cx.scene);
    for g in cx.scene.groups().iter().filter(|g| plays(g)) {
        let Some(fr) = g.file.as_ref().and_then(|f| f.frames.as_ref()) else {
            continue;
        };
        let n = fr.points.len();
        let k = shown(frame, longest, n);
        ui.label(format!(
            "{}: {n} frames at {:.3} fps; file frame {} of {n} ({:.3} s)",
            g.name,
            fr.fps,
            k + 1,
            fr.times[k]
        ));
    }
    if longest > 1 {
        let mut k = (frame % longest as u64) as usize;
        // The timeline: the file's frames (Kami's clock loops over them).
        if ui
            .add(Slider::new(&mut k, 0..=longest - 1).text("file frame"))
            .changed()
        {
            cx.host.seek = Some(k as u64);
        }
    }
    if ui
        .button("simulate from here")
        .on_hover_text(
            "the frame shown becomes the rest pose and Kami's dynamics move the hair from it \
             (--set simulate_from_here)",
        )
        .clicked()
    {
        if let Err(e) = simulate_from_here(cx.scene, frame) {
            cx.host.error = Some(e);
        }
    }
}

/// The scene's dynamics, created with defaults if absent.
fn dynamics_of(scene: &mut Scene) -> &mut Dynamics {
    scene.dynamics_mut().get_or_insert_with(Dynamics::default)
}

/// The pseudo-force field as switched on by the panel and `--set pseudo=on`.
fn default_pseudo_force() -> PseudoForce {
    PseudoForce {
        alpha: -0.75,
        epsilon_pore: 0.1,
        epsilon_tip: 1.0,
        near: 1.5,
    }
}

/// Anjyo's motion needs the scene's dynamics: without them, say so and offer to add them.
fn need_dynamics(ui: &mut Ui, scene: &mut Scene) -> bool {
    if scene.dynamics().is_none() {
        ui.label("this scene is static");
        if ui.button("Enable dynamics").clicked() {
            *scene.dynamics_mut() = Some(Dynamics {
                damping: 0.5,
                ..Default::default()
            });
            // Hair set moving falls: a weightless world gets a gentle gravity (Forces panel).
            if scene.forces.gravity == [0.0; 3] {
                scene.forces.gravity = [0.0, -150.0, 0.0];
            }
        }
        return false;
    }
    true
}

/// Pick the group the per-group panels edit; returns it (None without groups).
fn group_picker(ui: &mut Ui, cx: &mut PanelCx) -> Option<usize> {
    let st = ui::state::<AnjyoUi>(cx.state)?;
    let groups = cx.scene.groups();
    if groups.is_empty() {
        return None;
    }
    st.group = st.group.min(groups.len() - 1);
    let name = |i: usize| {
        let n = &groups[i].name;
        if n.is_empty() {
            format!("group {i}")
        } else {
            n.clone()
        }
    };
    egui::ComboBox::from_label("group")
        .selected_text(name(st.group))
        .show_ui(ui, |ui| {
            for i in 0..groups.len() {
                ui.selectable_value(&mut st.group, i, name(i));
            }
        });
    Some(st.group)
}

fn stiffness(ui: &mut Ui, cx: &mut PanelCx) {
    if cx.scene.groups().is_empty() {
        ui.label("no hair groups (fur stiffness: see Fur)");
        return;
    }
    let Some(group) = group_picker(ui, cx) else {
        return;
    };
    let s = &mut *cx.scene;
    let g = &mut s.groups_mut()[group];
    if let Some(f) = &g.file {
        // Imported strands are not bent: their rest pose is the file's.
        ui.label(format!(
            "read from {}: {} strands of {} segments, rest pose from the file (not bent)",
            f.path, g.count, g.segments
        ));
    } else {
        bending(ui, s, group);
    }
    let Some(d) = s.dynamics_mut().as_mut() else {
        ui.label("joint-angle stiffness and inertia act in dynamics (Dynamics panel)");
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
/// The cantilever's rigidity and bending mode of the picked (grown) group.
fn bending(ui: &mut Ui, s: &mut Scene, group: usize) {
    let g = &mut s.groups_mut()[group];
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
        s.groups_mut()
            .iter_mut()
            .filter(|g| g.file.is_none())
            .for_each(|g| g.rigidity = e);
    }
}

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

fn pseudo(ui: &mut Ui, cx: &mut PanelCx) {
    if !need_dynamics(ui, cx.scene) {
        return;
    }
    let Some(d) = cx.scene.dynamics_mut().as_mut() else {
        return;
    };
    let mut on = d.pseudo_force.is_some();
    ui.checkbox(&mut on, "pseudo-force field (Anjyo 3.2.2)");
    match (on, d.pseudo_force.is_some()) {
        (true, false) => d.pseudo_force = Some(default_pseudo_force()),
        (false, true) => d.pseudo_force = None,
        _ => {}
    }
    if let Some(p) = d.pseudo_force.as_mut() {
        ui.add(Slider::new(&mut p.alpha, -1.0..=1.0).text("α (facing threshold)"));
        ui.add(Slider::new(&mut p.epsilon_pore, 0.0..=1.0).text("ε near the pore"));
        ui.add(Slider::new(&mut p.epsilon_tip, 0.0..=1.0).text("ε at the tip"));
        ui.add(Slider::new(&mut p.near, 0.0..=10.0).text("near the head (distance)"));
    }
    ui.checkbox(&mut cx.host.overlay, "show affected segments (red)");
}

fn look(ui: &mut Ui, cx: &mut PanelCx) {
    let Some(group) = group_picker(ui, cx) else {
        return;
    };
    let Scene { render, blocks, .. } = &mut *cx.scene;
    let g = &mut blocks.get_mut::<AnjyoBlock>().groups[group];
    file_look(ui, g);
    let m = &mut g.material;
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
    // Per-strand variation (anjyo::vary): spreads of the log of each strand's multiplier.
    ui.add(Slider::new(&mut m.variation.melanin, 0.0..=1.0).text("melanin spread (per strand)"));
    ui.add(Slider::new(&mut m.variation.width, 0.0..=1.0).text("width spread (per strand)"));
    ui.add(Slider::new(&mut m.variation.tint, 0.0..=1.0).text("tint spread (per strand)"));
    crate::systems::hair_bsdf::panel(ui, &mut render.shading, &mut m.shading, &mut m.physical);
    if ui.small_button("use this look for every group").clicked() {
        let m = m.clone();
        cx.scene
            .groups_mut()
            .iter_mut()
            .for_each(|g| g.material = m.clone());
    }
}

/// For a group read from a strand file: where its colours, opacities and widths come
/// from (the file's, per point, or the material below), and the switches.
fn file_look(ui: &mut Ui, g: &mut crate::systems::anjyo::block::HairGroup) {
    let Some(f) = g.file.as_mut() else { return };
    let (has_c, has_o, has_w) = f.groom.as_ref().map_or((false, false, false), |gr| {
        (
            gr.colors.is_some(),
            gr.opacities.is_some(),
            gr.widths.is_some(),
        )
    });
    let name = std::path::Path::new(&f.path)
        .file_name()
        .map_or(f.path.clone(), |n| n.to_string_lossy().into_owned());
    ui.label(format!("strands from {name}"));
    let source = |has: bool, on: bool| match (has, on) {
        (false, _) => "the material (the file has none)",
        (true, true) => "the file, per point",
        (true, false) => "the material (the file's are off)",
    };
    ui.add_enabled_ui(has_c || has_o, |ui| {
        ui.checkbox(&mut f.colors, "draw the file's colours and opacities")
    });
    ui.label(format!("colour: {}", source(has_c, f.colors)));
    if has_o {
        ui.label(format!("opacity: {}", source(true, f.colors)));
    }
    ui.add_enabled_ui(has_w, |ui| {
        ui.checkbox(&mut f.widths, "draw the file's widths")
    });
    ui.label(format!("width: {}", source(has_w, f.widths)));
    ui.separator();
}

fn dynamics(ui: &mut Ui, cx: &mut PanelCx) {
    if !need_dynamics(ui, cx.scene) {
        return;
    }
    let s = &mut *cx.scene;
    let Some(d) = s.dynamics_mut().as_mut() else {
        return;
    };
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
    // Guides and followers (`follow`): a new share rebuilds the system (`classify`).
    let mut guided = d.guides.is_some();
    ui.checkbox(&mut guided, "guides and followers (simulate a share)")
        .on_hover_text(
            "simulate only a share of the strands; the others follow their 3 nearest guides",
        );
    match (guided, d.guides.is_some()) {
        (true, false) => d.guides = Some(0.25),
        (false, true) => d.guides = None,
        _ => {}
    }
    if let Some(g) = d.guides.as_mut() {
        ui.add(
            Slider::new(g, 0.01..=1.0)
                .logarithmic(true)
                .text("share simulated (guides)"),
        );
    }
    if ui.small_button("Disable dynamics").clicked() {
        *s.dynamics_mut() = None;
    }
}
