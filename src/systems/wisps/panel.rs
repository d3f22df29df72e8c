//! The Toon panel (thresholds and colours of eqs 20-22, tones, outline, the ray march) and
//! the Wisps panel (skeletons: nodes' radius and weight, springs). They only edit
//! `ViewerState`; the stage classifies the edit with `super::classify` and applies it.

use crate::app::params::ViewerState;
use crate::scene::wisps::{Distance, Tones};
use crate::systems::Panel;
use egui::{Slider, Ui};

pub const PANELS: &[Panel] = &[Panel {
    title: "Toon",
    open: |s| s.wisps.is_some(),
    show: toon,
}];

fn colour(ui: &mut Ui, label: &str, c: &mut [f32; 3]) {
    ui.horizontal(|ui| {
        ui.color_edit_button_rgb(c);
        ui.label(label);
    });
}

fn toon(ui: &mut Ui, s: &mut ViewerState) {
    let Some(w) = s.scene.wisps.as_mut() else {
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
    colour(ui, "halo (c_specular)", &mut t.specular);
    ui.add(Slider::new(&mut t.t_diffuse, 0.0..=1.0).text("t_diffuse"));
    if t.tones == Tones::Three {
        ui.add(Slider::new(&mut t.t_dark, 0.0..=1.0).text("t_dark"));
    }
    ui.add(Slider::new(&mut t.t_specular, 0.5..=1.0).text("t_specular (halo width)"));
    colour(ui, "outline", &mut t.outline);
    ui.add(Slider::new(&mut t.outline_width, 0.0..=6.0).text("outline (pixels)"));
    ui.separator();
    ui.add(
        Slider::new(&mut w.threshold, 0.05..=1.4)
            .logarithmic(true)
            .text("threshold (eq 8)"),
    );
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
