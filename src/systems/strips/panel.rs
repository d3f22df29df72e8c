//! The Strips panel (eq 1's stiffness τ, damping I2 and inertia I1, the forces of eq 2, the
//! simulation rate, the layers of the layer model and the look). It only edits
//! `ViewerState`; the stage classifies the edit with `super::classify`: motion parameters
//! act from the next step, layers rebuild the strips, the look redraws.

use crate::app::params::ViewerState;
use crate::scene::strips::{Layer, Sampling, Strips};
use egui::{ComboBox, DragValue, Slider, Ui};

pub fn strips(ui: &mut Ui, s: &mut ViewerState) {
    let Some(st) = s.scene.strips.as_mut() else {
        ui.label("this scene has no strips");
        return;
    };
    motion(ui, st);
    ui.separator();
    layers(ui, st);
    ui.separator();
    look(ui, st);
}

fn motion(ui: &mut Ui, st: &mut Strips) {
    let m = &mut st.motion;
    ui.label("joints: I1 Φ'' + I2 Φ' + τ (Φ − Φ0) = H");
    ui.add(
        Slider::new(&mut m.stiffness, 0.0..=20000.0)
            .logarithmic(true)
            .text("stiffness τ (root)"),
    );
    ui.add(Slider::new(&mut m.stiffness_tip, 0.0..=1.0).text("τ at the tip (share)"));
    ui.add(
        Slider::new(&mut m.damping, 0.0..=200.0)
            .logarithmic(true)
            .text("air resistance I2"),
    );
    ui.add(
        Slider::new(&mut m.inertia, 0.01..=100.0)
            .logarithmic(true)
            .text("inertia I1 (root)"),
    );
    // The oscillation a joint would have alone: what τ, I1 and I2 mean to an animator.
    let w0 = (m.stiffness / m.inertia).sqrt();
    let zeta = m.damping / (2.0 * (m.stiffness * m.inertia).sqrt()).max(1e-12);
    ui.small(format!(
        "root joint alone: {:.2} Hz, damping ratio ζ = {:.2}{}",
        w0 / std::f64::consts::TAU,
        zeta,
        if zeta >= 1.0 { " (no overshoot)" } else { "" }
    ));
    ui.add(
        Slider::new(&mut m.spring, 0.0..=2000.0)
            .logarithmic(true)
            .text("spring k (S)"),
    );
    ui.add(
        Slider::new(&mut m.collision, 0.0..=100.0)
            .logarithmic(true)
            .text("collision κ (Ψ)"),
    );
    ui.horizontal(|ui| {
        ui.label("gravity");
        for c in &mut m.gravity {
            ui.add(DragValue::new(c).speed(10.0).range(-1e5..=1e5));
        }
    });
    ui.add(
        Slider::new(&mut m.steps_per_second, 15.0..=2000.0)
            .logarithmic(true)
            .text("steps per second"),
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
    ui.add(Slider::new(&mut l.count, 1..=120).text("strips"));
    ui.add(Slider::new(&mut l.polar, 1.0..=179.0).text("ring (degrees from the crown)"));
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
    ui.add(Slider::new(&mut l.length, 1.0..=80.0).text("length"));
    ui.add(Slider::new(&mut l.sticks, 1..=32).text("sticks"));
    ui.add(Slider::new(&mut l.width[0], 0.1..=10.0).text("width at the root"));
    ui.add(Slider::new(&mut l.width[1], 0.1..=10.0).text("width at the tip"));
    ui.add(Slider::new(&mut l.droop, 0.0..=1.0).text("droop"));
    ui.add(Slider::new(&mut l.curl, -30.0..=30.0).text("curl (degrees per stick)"));
    ui.add(
        Slider::new(&mut l.stiffness, 0.05..=20.0)
            .logarithmic(true)
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
    ui.add(Slider::new(&mut k.hairs, 4..=64).text("hairs across a strip"));
    ui.add(Slider::new(&mut k.tip_shade, 0.2..=3.0).text("tip shade"));
    ui.add(Slider::new(&mut k.alpha_cutoff, 0.0..=0.95).text("alpha cut-off"));
    ui.add(Slider::new(&mut k.specular[0], 0.0..=2.0).text("specular"));
    ui.add(
        Slider::new(&mut k.specular[1], 2.0..=400.0)
            .logarithmic(true)
            .text("specular exponent"),
    );
}

/// The EFF panel: the field's grid, its outside force and gust, arrows in the view, the
/// brush, and load/save.
pub fn eff(ui: &mut Ui, _s: &mut ViewerState) {
    ui.label("EFF");
}

/// The key-frame timeline: pick a strip, set the first key, drag the target at the second.
pub fn keyframes(ui: &mut Ui, _s: &mut ViewerState) {
    ui.label("key frames");
}
