//! The Fur panel: hairs, length, culling, regions, the body wave, and each coat's shape,
//! style and material, with Figure 2's two looks, and fur's `--set` keys. It only edits
//! the scene; the stage classifies the edit with `super::classify` and applies it.

use crate::systems::fur::block::FurBlock;
use crate::systems::kind::Panel;
use crate::systems::scene::Scene;
use crate::systems::ui::{self, Host, KindUi, PanelCx};
use egui::{Slider, Ui};

pub const PANELS: &[Panel] = &[Panel {
    title: "Fur",
    open: |s| s.fur().is_some(),
    // On a scene without fur it offers the critter's.
    adds: true,
    show: fur,
}];

/// Fur's state in the viewer: none, only its `--set` keys.
#[derive(Debug, Default)]
pub struct FurUi;

impl KindUi for FurUi {
    fn as_any_mut(&mut self) -> &mut dyn std::any::Any {
        self
    }

    /// `fur.hairs=N`, `fur.stiffness=s` (every coat), `fur.culling=on|off`.
    fn set(
        &mut self,
        scene: &mut Scene,
        _host: &mut Host,
        key: &str,
        value: Option<&str>,
    ) -> Option<Result<(), String>> {
        if !matches!(key, "fur.hairs" | "fur.stiffness" | "fur.culling") {
            return None;
        }
        let Some(f) = scene.fur_mut().as_mut() else {
            return Some(Err("the scene has no fur".into()));
        };
        Some(match key {
            "fur.hairs" => ui::int(value).map(|n| f.hairs = n),
            "fur.stiffness" => {
                ui::nums(value, 1).map(|v| f.coats.iter_mut().for_each(|c| c.stiffness = v[0]))
            }
            _ => ui::on(value).map(|on| f.culling.enabled = on),
        })
    }
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
fn fur_regions(ui: &mut Ui, f: &mut crate::systems::fur::block::Fur) {
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
        f.regions.push(crate::systems::fur::block::Region {
            center: [0.0; 3],
            radius: 0.5,
            length_scale: 1.0,
            direction: None,
        });
    }
}

fn fur(ui: &mut Ui, cx: &mut PanelCx) {
    use crate::systems::fur::block::{Coat, FurMaterial, FurStyle};
    let Scene { render, blocks, .. } = &mut *cx.scene;
    let scene_shading = &mut render.shading;
    let Some(f) = blocks.get_mut::<FurBlock>().fur.as_mut() else {
        ui.label("this scene has no fur");
        if ui.button("Add fur on the critter").clicked() {
            cx.host.open = Some("assets/scenes/fur.ron".into());
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
            f.motion = Some(crate::systems::fur::block::MeshMotion {
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
                crate::systems::hair_bsdf::panel(
                    ui,
                    scene_shading,
                    &mut m.shading,
                    &mut m.physical,
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
