//! `kami bench shadows`: the hair shadows' two methods (`stage::shadow`: a light-aligned
//! density volume, deep opacity maps) on strand hair (the bob), fur and strips: ms per frame
//! without shadows and with each method, each method's error against the f64 reference of
//! `shadow_strands` at points on the hair, and the image difference between the renders.
//! Writes shadow_bench.md, shadow_bench.csv and shadow_bench.png (each scene's renders side by side: off,
//! volume, deep opacity).

use super::{provenance, write_report, Report};
use crate::error::Result;
use crate::gpu::Gpu;
use crate::scene::ShadowMethod;
use crate::stage::{self, shadow, target, Quality, Stage};
use crate::systems::Scene;
use glam::DVec3;
use image::RgbaImage;
use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

/// The image size of every render.
pub const SIZE: (u32, u32) = (400, 400);
/// Points on the hair where the error is measured (at most).
const POINTS: usize = 400;

/// Off, then each method.
const MODES: [Option<ShadowMethod>; 3] = [
    None,
    Some(ShadowMethod::Volume),
    Some(ShadowMethod::DeepOpacity),
];

fn name(m: Option<ShadowMethod>) -> &'static str {
    match m {
        None => "off",
        Some(ShadowMethod::Volume) => "volume",
        Some(ShadowMethod::DeepOpacity) => "deep opacity",
    }
}

/// One scene in one mode: median ms per frame, the image, and the error against the
/// reference (mean, largest |n - n_ref|, mean n_ref) where the hair is strands.
pub struct Row {
    pub scene: String,
    pub mode: Option<ShadowMethod>,
    pub ms: f64,
    pub image: RgbaImage,
    pub error: Option<(f64, f64, f64)>,
}

/// Render `scene` in every mode, `runs` rounds (after one warm-up), the modes taking
/// turns within each round so that a busy machine slows them alike; then each mode's
/// error against the reference.
pub fn measure(gpu: &Gpu, name: &str, scene: &Scene, runs: u32, strands: bool) -> Result<Vec<Row>> {
    let mut stages = Vec::new();
    for mode in MODES {
        let mut scene = scene.clone();
        scene.render.shadows.on = mode.is_some();
        if let Some(m) = mode {
            scene.render.shadows.method = m;
        }
        stage::check_limits(gpu, &scene, SIZE)?;
        stages.push(Stage::new(
            gpu,
            &scene,
            target::OUTPUT_FORMAT,
            Quality::of(&scene),
        )?);
    }
    let out = target::Offscreen::new(gpu, SIZE)?;
    let mut times = vec![Vec::new(); MODES.len()];
    for round in 0..=runs {
        for (i, stage) in stages.iter_mut().enumerate() {
            let look = stage.look();
            let t = Instant::now();
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            stage.render(gpu, &mut enc, &out.view, SIZE, &look)?;
            gpu.queue.submit([enc.finish()]);
            gpu.wait()?;
            if round > 0 {
                times[i].push(t.elapsed().as_secs_f64() * 1e3);
            }
        }
    }
    let mut rows = Vec::new();
    for ((mode, stage), mut t) in MODES.into_iter().zip(stages.iter_mut()).zip(times) {
        t.sort_by(f64::total_cmp);
        // The image and the structure the error is read from: this mode's last frame.
        let look = stage.look();
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        stage.render(gpu, &mut enc, &out.view, SIZE, &look)?;
        gpu.queue.submit([enc.finish()]);
        let image = out.read_rgba(gpu)?;
        let error = match (mode, strands) {
            (Some(_), true) => {
                let groom = stage.export(gpu)?;
                let segments = shadow::segments_of(&groom, 0.07);
                let every = (groom.points.len() / POINTS).max(1);
                let points: Vec<DVec3> = groom
                    .points
                    .iter()
                    .step_by(every)
                    .map(|p| DVec3::from(p.map(f64::from)))
                    .collect();
                let pairs = shadow::against_reference(gpu, stage, &segments, &points)?;
                let n = pairs.len().max(1) as f64;
                Some((
                    pairs.iter().map(|p| (p.0 - p.1).abs()).sum::<f64>() / n,
                    pairs.iter().map(|p| (p.0 - p.1).abs()).fold(0.0, f64::max),
                    pairs.iter().map(|p| p.1).sum::<f64>() / n,
                ))
            }
            _ => None,
        };
        rows.push(Row {
            scene: name.to_string(),
            mode,
            ms: t[t.len() / 2],
            image,
            error,
        });
    }
    gpu.take_error()?;
    Ok(rows)
}

/// Mean absolute difference of two images over RGB, of 255.
pub fn image_difference(a: &RgbaImage, b: &RgbaImage) -> f64 {
    let mut sum = 0.0;
    for (p, q) in a.pixels().zip(b.pixels()) {
        for c in 0..3 {
            sum += (p.0[c] as f64 - q.0[c] as f64).abs();
        }
    }
    sum / (3.0 * a.pixels().len().max(1) as f64)
}

/// The scenes measured (file stem under `scenes`, whether its hair is strands the
/// reference can sum).
pub const SCENES: [(&str, bool); 3] = [("bob", true), ("fur_creature", true), ("strips", false)];

pub fn run(gpu: &Gpu, scenes: &Path, runs: u32, out: &Path) -> Result<Report> {
    let mut rows = Vec::new();
    for (stem, strands) in SCENES {
        let scene = Scene::load(scenes.join(format!("{stem}.ron")))?;
        rows.extend(measure(gpu, stem, &scene, runs, strands)?);
    }
    let mut md = String::new();
    let mut csv = String::from(
        "scene,shadows,ms_per_frame,shadow_share,mean_error,max_error,mean_n,image_diff_vs_off,image_diff_vs_other_method\n",
    );
    writeln!(md, "{}", provenance()).ok();
    writeln!(md, "Adapter: {}; {}x{} pixels; median of {runs} frames per row, wall clock (submit to wait), the three rows of a scene taking turns frame by frame.", gpu.describe(), SIZE.0, SIZE.1).ok();
    writeln!(md).ok();
    writeln!(
        md,
        "| scene | shadows | ms per frame | share of the frame | mean error (strands) | largest error | mean n | image diff vs off | vs the other method |"
    )
    .ok();
    writeln!(md, "|---|---|---|---|---|---|---|---|---|").ok();
    for chunk in rows.chunks(3) {
        let off = &chunk[0];
        for (i, r) in chunk.iter().enumerate() {
            let share = if r.mode.is_some() {
                format!("{:.0} %", 100.0 * (r.ms - off.ms).max(0.0) / r.ms)
            } else {
                "-".into()
            };
            let other = match i {
                1 => Some(image_difference(&r.image, &chunk[2].image)),
                2 => Some(image_difference(&r.image, &chunk[1].image)),
                _ => None,
            };
            let vs_off = (i > 0).then(|| image_difference(&r.image, &off.image));
            let f = |v: Option<f64>, d: usize| v.map_or("-".into(), |v| format!("{v:.d$}"));
            let (me, mx, mn) = match r.error {
                Some((a, b, c)) => (Some(a), Some(b), Some(c)),
                None => (None, None, None),
            };
            writeln!(
                md,
                "| {} | {} | {:.0} | {} | {} | {} | {} | {} | {} |",
                r.scene,
                name(r.mode),
                r.ms,
                share,
                f(me, 3),
                f(mx, 2),
                f(mn, 2),
                f(vs_off, 2),
                f(other, 2)
            )
            .ok();
            writeln!(
                csv,
                "{},{},{:.2},{},{},{},{},{},{}",
                r.scene,
                name(r.mode),
                r.ms,
                if r.mode.is_some() {
                    format!("{:.3}", (r.ms - off.ms).max(0.0) / r.ms)
                } else {
                    String::new()
                },
                f(me, 4),
                f(mx, 4),
                f(mn, 4),
                f(vs_off, 3),
                f(other, 3)
            )
            .ok();
        }
    }
    writeln!(md).ok();
    // One line for the README: each method's share of each scene's frame.
    let share = |m: ShadowMethod| {
        rows.chunks(3)
            .map(|c| {
                let r = c.iter().find(|r| r.mode == Some(m)).unwrap_or(&c[0]);
                format!(
                    "{:.0} % of the {}'s frame",
                    100.0 * (r.ms - c[0].ms).max(0.0) / r.ms,
                    r.scene
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    writeln!(
        md,
        "**Cost.** On {}, volume shadows took {}; deep opacity maps took {}.",
        gpu.describe(),
        share(ShadowMethod::Volume),
        share(ShadowMethod::DeepOpacity)
    )
    .ok();
    writeln!(md).ok();
    writeln!(
        md,
        "**Error** is |n - n_ref| in strands crossed, at up to {POINTS} points on the hair, against the f64 brute force over every segment smoothed as each method smooths (`stage::shadow::reference_strands`); strips are sheets, which the strand reference does not model. **Image diff** is the mean absolute difference over RGB, of 255."
    )
    .ok();
    write_report(out, "shadow_bench", &md, &csv)?;
    // Each scene's renders side by side: off, volume, deep opacity.
    let mut img = RgbaImage::new(SIZE.0 * 3, SIZE.1 * (rows.len() / 3) as u32);
    for (i, r) in rows.iter().enumerate() {
        let (x, y) = (
            (i % 3) as i64 * SIZE.0 as i64,
            (i / 3) as i64 * SIZE.1 as i64,
        );
        image::imageops::overlay(&mut img, &r.image, x, y);
    }
    let p = out.join("shadow_bench.png");
    img.save(&p).map_err(|e| crate::KamiError::Image {
        path: p.clone(),
        message: e.to_string(),
    })?;
    Ok(Report { markdown: md, csv })
}
