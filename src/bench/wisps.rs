//! `kami bench wisps`: Sakai's toon wisps. The ray march's cost per frame against wisp count
//! and image size; its image error against the step size and the distance method (against
//! the march at a quarter of the safe step with Newton's distance and 16 bisections); and
//! the mass springs' work–precision table (`springs::work_precision`). Writes wisps.md,
//! wisps.csv, wisps_cost.png, wisps_error.png and wisps_springs.png.

use super::{provenance, time_mean, write_report, Report};
use crate::error::Result;
use crate::gpu::Gpu;
use crate::plot::{self, Series};
use crate::scene::wisps::{Distance, Skeleton};
use crate::scene::Scene;
use crate::stage::{self, target, Quality, Stage};
use crate::systems::wisps::tiles::MarchStats;
use crate::systems::wisps::WispsSystem;
use glam::{DQuat, DVec3};
use image::RgbaImage;
use std::fmt::Write;
use std::path::Path;

/// Image sides of the cost sweep (square images, one sample per pixel).
pub const SIDES: [u32; 3] = [96, 192, 384];

/// Wisp counts of the cost sweep, as multiples of the scene's own.
pub const COPIES: [usize; 3] = [1, 2, 4];

/// `copies` times the scene's wisps: each copy turned about the vertical by a few degrees and
/// thinned by 1/sqrt(copies), so the hairstyle keeps its volume with more, thinner wisps.
pub fn multiplied(scene: &Scene, copies: usize) -> Scene {
    let mut s = scene.clone();
    let Some(w) = s.wisps.as_mut() else {
        return s;
    };
    let base: Vec<Skeleton> = w.skeletons.clone();
    let thin = 1.0 / (copies as f64).sqrt();
    w.skeletons.clear();
    for k in 0..copies {
        let angle = (k as f64 - (copies as f64 - 1.0) / 2.0) * 4.0_f64.to_radians();
        let q = DQuat::from_rotation_y(angle);
        for sk in &base {
            let mut sk = sk.clone();
            for n in &mut sk.nodes {
                n.p = (q * DVec3::from(n.p)).to_array();
                n.r *= thin.max(0.45);
            }
            w.skeletons.push(sk);
        }
    }
    s
}

struct Timed {
    stage: Stage,
    out: target::Offscreen,
    size: (u32, u32),
}

impl Timed {
    fn new(gpu: &Gpu, scene: &Scene, size: (u32, u32)) -> Result<Timed> {
        stage::check_limits(gpu, scene, size)?;
        let quality = Quality {
            msaa: 1,
            supersample: 1,
        };
        Ok(Timed {
            stage: Stage::new(gpu, scene, target::OUTPUT_FORMAT, quality)?,
            out: target::Offscreen::new(gpu, size)?,
            size,
        })
    }

    fn frame(&mut self, gpu: &Gpu) -> Result<()> {
        let look = self.stage.look();
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("bench wisps frame"),
            });
        self.stage
            .render(gpu, &mut enc, &self.out.view, self.size, &look)?;
        gpu.queue.submit([enc.finish()]);
        gpu.wait()
    }

    fn image(&mut self, gpu: &Gpu) -> Result<RgbaImage> {
        self.frame(gpu)?;
        self.out.read_rgba(gpu)
    }

    fn wisps(&mut self) -> Result<&mut WispsSystem> {
        self.stage
            .system_mut::<WispsSystem>()
            .ok_or_else(|| crate::KamiError::Gpu("no wisps in the scene".into()))
    }

    /// One frame with the march's counters on (their atomics are not in the timed frames).
    fn counted(&mut self, gpu: &Gpu) -> Result<MarchStats> {
        self.wisps()?.draw.counting = true;
        self.frame(gpu)?;
        let stats = self.wisps()?.draw.read_stats(gpu)?.unwrap_or_default();
        self.wisps()?.draw.counting = false;
        Ok(stats)
    }
}

/// One measured configuration of the march.
#[derive(Clone, Copy, Debug)]
pub struct MarchFrame {
    /// CPU wall milliseconds per drawn frame (submit to wait), mean after a warm-up.
    pub ms: f64,
    pub stats: MarchStats,
}

impl MarchFrame {
    /// Field samples per ray that has a candidate.
    pub fn steps_per_ray(&self) -> f64 {
        f64::from(self.stats.steps) / f64::from(self.stats.rays.max(1))
    }

    pub fn candidates_per_ray(&self) -> f64 {
        f64::from(self.stats.candidates) / f64::from(self.stats.rays.max(1))
    }

    /// Microseconds of the whole frame per pixel the wisps cover.
    pub fn us_per_covered(&self) -> f64 {
        self.ms * 1e3 / f64::from(self.stats.covered.max(1))
    }
}

/// Time `frames` frames of `scene` (one sample per pixel) at `size` after a warm-up, then
/// count one more.
pub fn march_frame(gpu: &Gpu, scene: &Scene, size: (u32, u32), frames: u32) -> Result<MarchFrame> {
    let mut t = Timed::new(gpu, scene, size)?;
    let secs = time_mean(frames, || t.frame(gpu))?;
    let stats = t.counted(gpu)?;
    Ok(MarchFrame {
        ms: secs * 1e3,
        stats,
    })
}

/// Run the whole bench on `scene_path` (the toon scene) and write the report into `out`.
pub fn run(gpu: &Gpu, scene_path: &Path, frames: u32, out: &Path) -> Result<Report> {
    let scene = Scene::load(scene_path)?;
    if scene.wisps.is_none() {
        return Err(crate::KamiError::Invalid {
            file: scene_path.display().to_string(),
            field: "wisps".into(),
            value: "None".into(),
            allowed: "a scene with toon wisps (assets/scenes/toon.ron)".into(),
        });
    }
    let mut md = String::new();
    let mut csv = String::from(
        "table,wisps,segments,side,variant,ms_per_frame,mean_error,share_over_24,most_neighbours\n",
    );
    writeln!(md, "# Toon wisps (Sakai)\n\n{}\n", provenance()).ok();
    writeln!(
        md,
        "Adapter: {}. One sample per pixel, the scene's camera; mean of {frames} frames after \
         one warm-up. Still wisps: the spline kernels run once, so a frame is the ray march.\n",
        gpu.describe()
    )
    .ok();

    // 1. Cost against wisp count and image size.
    writeln!(md, "## Ray march cost per frame\n").ok();
    writeln!(
        md,
        "| wisps | segments | most neighbours | {} |",
        SIDES.map(|s| format!("{s}² ms")).join(" | ")
    )
    .ok();
    writeln!(md, "|---|---|---|{}", "---|".repeat(SIDES.len())).ok();
    let mut cost_series = Vec::new();
    for (i, &copies) in COPIES.iter().enumerate() {
        let s = multiplied(&scene, copies);
        let w = s.wisps.as_ref().map(|w| w.skeletons.len()).unwrap_or(0);
        let segs = s
            .wisps
            .as_ref()
            .map(crate::systems::wisps::march::segment_count)
            .unwrap_or(0);
        let mut row = Vec::new();
        let mut pts = Vec::new();
        let mut most = 0;
        for &side in &SIDES {
            let mut t = Timed::new(gpu, &s, (side, side))?;
            let secs = time_mean(frames, || t.frame(gpu))?;
            most = t.counted(gpu)?.most_in_a_tile;
            row.push(format!("{:.1}", secs * 1e3));
            pts.push(((side * side) as f64, secs * 1e3));
            writeln!(
                csv,
                "cost,{w},{segs},{side},newton,{:.3},,,{most}",
                secs * 1e3
            )
            .ok();
        }
        writeln!(md, "| {w} | {segs} | {most} | {} |", row.join(" | ")).ok();
        cost_series.push(Series {
            name: format!("{w} wisps"),
            color: plot::palette(i),
            points: pts,
        });
    }
    let cost_plot = plot::loglog(
        "Toon wisps: ray march per frame",
        "pixels",
        "ms per frame",
        &cost_series,
        None,
    );

    // 2. Image error against step size and distance method, at 256x256.
    let side = 192;
    let mut fine = scene.clone();
    if let Some(w) = fine.wisps.as_mut() {
        w.march.step_scale = 0.25;
        w.march.refine = 16;
        w.march.max_steps = 2048;
        w.march.distance = Distance::Newton;
    }
    let mut t = Timed::new(gpu, &fine, (side, side))?;
    let reference = t.image(gpu)?;
    let ref_ms = time_mean(frames, || t.frame(gpu))? * 1e3;
    writeln!(
        md,
        "\n## Ray march error against step and distance ({side}², against the reference: \
         Newton distance, 0.25 of the safe step, 16 bisections, {ref_ms:.1} ms)\n"
    )
    .ok();
    writeln!(
        md,
        "| distance | step scale | ms per frame | mean error (of 255) | pixels off by > 24 |"
    )
    .ok();
    writeln!(md, "|---|---|---|---|---|").ok();
    let mut variants: Vec<(String, Distance, f64)> = Vec::new();
    for step in [0.5, 1.0, 2.0, 4.0] {
        variants.push(("Newton".into(), Distance::Newton, step));
    }
    for pieces in [1, 2, 4, 8] {
        variants.push((
            format!("polyline {pieces}"),
            Distance::Polyline { pieces },
            1.0,
        ));
    }
    let mut newton_pts = Vec::new();
    let mut poly_pts = Vec::new();
    for (name, distance, step) in variants {
        let mut s = scene.clone();
        if let Some(w) = s.wisps.as_mut() {
            w.march.distance = distance;
            w.march.step_scale = step;
        }
        let mut t = Timed::new(gpu, &s, (side, side))?;
        let img = t.image(gpu)?;
        let ms = time_mean(frames, || t.frame(gpu))? * 1e3;
        let (mean, over, _) = super::backends::difference(&reference, &img);
        writeln!(
            md,
            "| {name} | {step} | {ms:.1} | {mean:.3} | {:.3} % |",
            over * 100.0
        )
        .ok();
        writeln!(
            csv,
            "error,,,{side},{name} step {step},{ms:.3},{mean:.5},{over:.6},"
        )
        .ok();
        let p = (ms, mean.max(1e-4));
        if matches!(distance, Distance::Newton) {
            newton_pts.push(p);
        } else {
            poly_pts.push(p);
        }
    }
    let error_plot = plot::loglog(
        "Toon wisps: image error against cost",
        "ms per frame",
        "mean error (of 255)",
        &[
            Series {
                name: "Newton, step 0.5-4".into(),
                color: plot::palette(0),
                points: newton_pts,
            },
            Series {
                name: "polyline 1-8, step 1".into(),
                color: plot::palette(1),
                points: poly_pts,
            },
        ],
        None,
    );
    writeln!(
        md,
        "\nSteps above 1 leave the Lipschitz-safe bound and may skip thin wisps; they are \
         here to show what the bound buys.\n"
    )
    .ok();

    // 3. Mass springs: work against precision (f64 reference, CPU).
    let shake_path = scene_path.with_file_name("toon_shake.ron");
    let shake = Scene::load(&shake_path)?;
    if let Some(w) = shake.wisps.as_ref() {
        // Three wisps (a bang, a side and a back wisp) keep the f64 runs short.
        let mut few = w.clone();
        let pick = [2usize, 8, 13];
        few.skeletons = pick
            .iter()
            .filter_map(|&i| w.skeletons.get(i).cloned())
            .collect();
        few.bundles.clear();
        let forces = crate::forces::Forces::from_scene(&shake);
        let ladder = [16, 32, 64, 128];
        let rows = crate::systems::wisps::springs::work_precision(
            &few,
            &shake.head,
            &forces,
            0.5,
            &ladder,
        )?;
        let sp = few.springs.clone().unwrap_or_default();
        writeln!(
            md,
            "\n## Mass springs: error against cost\n\nThree wisps of `toon_shake.ron` \
             (stiffness {}, damping {}), the first 0.5 s of the head shake; error = the largest \
             node (primary) distance after 0.5 s from RK4 at 4x the finest step, f64 on the \
             CPU. Largest stable step: bisection over the run and the linear bound, the \
             smaller less {} %.\n",
            sp.stiffness,
            sp.damping,
            crate::systems::wisps::springs::STABLE_MARGIN * 100.0
        )
        .ok();
        writeln!(md, "| integrator | steps per frame | dt (ms) | error | order | stable | ns per step | largest stable dt (ms) |").ok();
        writeln!(md, "|---|---|---|---|---|---|---|---|").ok();
        let mut series: Vec<Series> = Vec::new();
        for r in &rows {
            let name = format!("{:?}", r.integrator);
            writeln!(
                md,
                "| {name} | {} | {:.3} | {:.2e} | {} | {} | {:.0} | {:.3} |",
                r.substeps,
                r.dt * 1e3,
                r.error,
                r.order.map_or("-".into(), |o| format!("{o:.2}")),
                if r.stable { "yes" } else { "no" },
                r.ns_per_step,
                r.largest_stable_dt * 1e3
            )
            .ok();
            writeln!(
                csv,
                "springs,{},,,{name} {} steps,{:.6},{:.6e},,",
                few.skeletons.len(),
                r.substeps,
                r.ns_per_step * 1e-6,
                r.error
            )
            .ok();
            let point = (r.ns_per_step * r.substeps as f64 * 1e-3, r.error.max(1e-16));
            match series.iter_mut().find(|s| s.name == name) {
                Some(s) => s.points.push(point),
                None => series.push(Series {
                    name,
                    color: plot::palette(series.len() + 2),
                    points: vec![point],
                }),
            }
        }
        let p = plot::loglog(
            "Wisp mass springs: error against cost",
            "us per frame (f64 CPU)",
            "node error after 0.5 s",
            &series,
            None,
        );
        let path = out.join("wisps_springs.png");
        std::fs::create_dir_all(out).ok();
        p.save(&path).map_err(|e| crate::KamiError::Io {
            path: path.clone(),
            source: std::io::Error::other(e),
        })?;
    }

    // The hand-written sections that follow the measured tables (from "## Toon controls" on)
    // are kept from the report this one replaces.
    if let Ok(old) = std::fs::read_to_string(out.join("wisps.md")) {
        if let Some(at) = old.find("\n## Toon controls") {
            md.push_str(&old[at..]);
        }
    }
    write_report(out, "wisps", &md, &csv)?;
    for (name, img) in [
        ("wisps_cost.png", cost_plot),
        ("wisps_error.png", error_plot),
    ] {
        let p = out.join(name);
        img.save(&p).map_err(|e| crate::KamiError::Io {
            path: p.clone(),
            source: std::io::Error::other(e),
        })?;
    }
    Ok(Report { markdown: md, csv })
}
