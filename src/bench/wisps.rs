//! `kami bench wisps`: Sakai's toon wisps. The tiled ray march's cost per frame against
//! wisp count and image size beside the march before it (`wisps_before.csv`), with steps and
//! candidates per ray and µs per covered pixel, and at the viewer's 1280x720; the image
//! error of each march variant (step, bisections, distance method) against the f64
//! reference (`field::render_reference`); and the mass springs' work–precision table
//! (`springs::work_precision`). Writes wisps.md, wisps.csv, wisps_cost.png,
//! wisps_error.png and wisps_springs.png, keeping wisps.md's hand-written part.

pub mod springs;

use super::{provenance, time_mean, write_report, Report};
use crate::bench::plot::{self, Series};
use crate::error::Result;
use crate::gpu::timing::{PassTimes, Phase};
use crate::gpu::Gpu;
use crate::stage::{self, target, Quality, Stage};
use crate::systems::wisps::block::{Distance, MeshOn, Skeleton, WispDraw};
use crate::systems::wisps::tiles::MarchStats;
use crate::systems::wisps::WispsSystem;
use crate::systems::Scene;
use glam::{DQuat, DVec3};
use image::RgbaImage;
use std::fmt::Write;
use std::path::Path;

/// Image sides of the cost sweep (square images, one sample per pixel).
pub const SIDES: [u32; 3] = [96, 192, 384];

/// The viewer's default window: the size of the goal.
pub const VIEWER: (u32, u32) = (1280, 720);

/// Side of the error table's images (the f64 reference marches every segment per ray).
pub const ERROR_SIDE: u32 = 128;

/// The line that opens the hand-written part of `wisps.md`, kept when the bench writes the
/// report again.
pub const HAND_WRITTEN: &str = "<!-- hand-written below";

/// Wisp counts of the cost sweep, as multiples of the scene's own.
pub const COPIES: [usize; 3] = [1, 2, 4];

/// `copies` times the scene's wisps: each copy turned about the vertical by a few degrees and
/// thinned by 1/sqrt(copies), so the hairstyle keeps its volume with more, thinner wisps.
pub fn multiplied(scene: &Scene, copies: usize) -> Scene {
    let mut s = scene.clone();
    let Some(w) = s.wisps_mut().as_mut() else {
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

/// `count` wisps from the scene's own: `multiplied` by enough copies, then the first
/// `count` of them (the sweeps' 200 wisps from `toon.ron`'s 22).
pub fn with_count(scene: &Scene, count: usize) -> Scene {
    let own = scene
        .wisps()
        .as_ref()
        .map_or(0, |w| w.skeletons.len())
        .max(1);
    let mut s = multiplied(scene, count.div_ceil(own).max(1));
    if let Some(w) = s.wisps_mut().as_mut() {
        w.skeletons.truncate(count);
        w.bundles.clear();
    }
    s
}

struct Timed {
    /// Each frame steps the motion first (moving wisps).
    moving: bool,
    stage: Stage,
    out: target::Offscreen,
    size: (u32, u32),
    /// GPU times of the frames drawn since the last `take_times` (where the adapter has
    /// timestamps).
    times: Vec<PassTimes>,
}

impl Timed {
    fn new(gpu: &Gpu, scene: &Scene, size: (u32, u32)) -> Result<Timed> {
        stage::check_limits(gpu, scene, size)?;
        let quality = Quality::new(1, 1);
        let mut stage = Stage::new(gpu, scene, target::OUTPUT_FORMAT, quality)?;
        stage.enable_timing(gpu);
        Ok(Timed {
            moving: false,
            stage,
            out: target::Offscreen::new(gpu, size)?,
            size,
            times: Vec::new(),
        })
    }

    fn frame(&mut self, gpu: &Gpu) -> Result<()> {
        let look = self.stage.look();
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("bench wisps frame"),
            });
        if self.moving {
            self.stage.advance(gpu, &mut enc, 1)?;
        }
        self.stage
            .render(gpu, &mut enc, &self.out.view, self.size, &look)?;
        let Some(timer) = self.stage.timer() else {
            gpu.queue.submit([enc.finish()]);
            return gpu.wait();
        };
        timer.clear();
        timer.finish(&mut enc);
        gpu.queue.submit([enc.finish()]);
        timer.submitted();
        if let Some(t) = timer.wait(gpu)? {
            self.times.push(t);
        }
        Ok(())
    }

    /// The mean GPU milliseconds of the frames since the last call, per phase: generation
    /// (the curve kernels and the tile binning), draw (the march, and the scene pass with
    /// its composite), resolve, and the frame from first to last timestamp.
    fn take_times(&mut self) -> Option<[f64; 4]> {
        let times = std::mem::take(&mut self.times);
        if times.is_empty() {
            return None;
        }
        let n = times.len() as f64;
        let mean = |f: &dyn Fn(&PassTimes) -> Option<f64>| {
            times.iter().map(|t| f(t).unwrap_or(0.0)).sum::<f64>() / n
        };
        Some([
            mean(&|t| t.get(Phase::Generation)),
            mean(&|t| t.get(Phase::Draw)),
            mean(&|t| t.get(Phase::Resolve)),
            mean(&|t| t.frame),
        ])
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
    /// GPU milliseconds of the timed frames (`Timed::take_times`), where the adapter has
    /// timestamps: generation (binning), draw (march and composite), resolve, frame.
    pub gpu_ms: Option<[f64; 4]>,
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
    let mut t = Timed::new(gpu, &with_draw(scene, WispDraw::March), size)?;
    t.frame(gpu)?;
    t.take_times();
    let secs = time_mean(frames, || t.frame(gpu))?;
    let gpu_ms = t.take_times();
    let stats = t.counted(gpu)?;
    Ok(MarchFrame {
        ms: secs * 1e3,
        stats,
        gpu_ms,
    })
}

/// Wisp counts of the sweep (`with_count`: `toon.ron`'s 22 multiplied).
pub const COUNTS: [usize; 3] = [22, 88, 200];

/// Frame sizes of the sweep: 3840x2160 on a hardware GPU only (minutes a frame on two CPU
/// cores).
pub fn sweep_sizes(software: bool) -> &'static [(u32, u32)] {
    if software {
        &[(1280, 720), (1920, 1080)]
    } else {
        &[(1280, 720), (1920, 1080), (3840, 2160)]
    }
}

/// Every wisp count at every sweep size, the march in fragments and in compute
/// (`block::MarchOn`): ms per frame, fps, steps and candidates per ray, the ray slots and
/// what overflowed. One timed frame each on the software adapter (seconds a frame), at most
/// three on a GPU.
fn sweep(gpu: &Gpu, scene: &Scene, frames: u32, md: &mut String, csv: &mut String) -> Result<()> {
    use crate::systems::wisps::block::MarchOn;
    let software = gpu.info.device_type == wgpu::DeviceType::Cpu;
    let frames = if software { 1 } else { frames.min(3) };
    writeln!(
        md,
        "\n## Wisp counts, sizes and where the march runs\n\n`toon.ron`'s wisps multiplied \
         (`bench::wisps::with_count`), one sample per pixel, mean of {frames} frame(s) after \
         a warm-up. Fragment: the march in a fragment shader over the screen tiles; compute: \
         one workgroup per tile writing colour and depth images, composited into the scene \
         by depth (`wisps.march.on`; Auto takes compute on a hardware GPU, fragments on a \
         software adapter). A frame is the tile binning, the march and its composite.\n"
    )
    .ok();
    writeln!(
        md,
        "| wisps | size | fragment ms | fps | compute ms | fps | compute / fragment | compute on the GPU: binning / march and composite / resolve / frame ms | steps per ray | candidates per ray | ray slots | overflows |"
    )
    .ok();
    writeln!(md, "|---|---|---|---|---|---|---|---|---|---|---|---|").ok();
    for &count in &COUNTS {
        let base = with_count(scene, count);
        for &size in sweep_sizes(software) {
            let mut ms = [0.0; 2];
            let mut counted = MarchFrame {
                ms: 0.0,
                stats: MarchStats::default(),
                gpu_ms: None,
            };
            for (i, on) in [MarchOn::Fragment, MarchOn::Compute]
                .into_iter()
                .enumerate()
            {
                let mut s = base.clone();
                if let Some(w) = s.wisps_mut().as_mut() {
                    w.march.on = on;
                }
                let f = march_frame(gpu, &s, size, frames)?;
                ms[i] = f.ms;
                counted = f;
                writeln!(
                    csv,
                    "sweep,{count},,{}x{},{},{:.3},,,{:.3},{:.3},{:.4},{},",
                    size.0,
                    size.1,
                    if i == 0 { "fragment" } else { "compute" },
                    f.ms,
                    f.steps_per_ray(),
                    f.candidates_per_ray(),
                    f.us_per_covered(),
                    f.stats.most_in_a_tile
                )
                .ok();
            }
            let st = counted.stats;
            // A software adapter's timestamps miss its compute work (`bench scale` found
            // the simulation's time in later phases): no split there.
            let split = match counted.gpu_ms {
                Some(g) if !software => {
                    format!("{:.2} / {:.2} / {:.2} / {:.2}", g[0], g[1], g[2], g[3])
                }
                Some(_) => "— (software adapter)".into(),
                None => "no timestamps".into(),
            };
            writeln!(
                md,
                "| {count} | {}x{} | {:.1} | {:.1} | {:.1} | {:.1} | {:.2} | {split} | {:.1} | {:.1} | {} | {} |",
                size.0,
                size.1,
                ms[0],
                1e3 / ms[0],
                ms[1],
                1e3 / ms[1],
                ms[1] / ms[0],
                counted.steps_per_ray(),
                counted.candidates_per_ray(),
                st.slots,
                st.ray_overflow + st.tile_overflow
            )
            .ok();
        }
    }
    Ok(())
}

/// The report of the march before the tiled march (the per-box march with 64-slot
/// neighbour lists), written by this bench at commit cf4fdeb and kept beside the report.
pub const BEFORE: &str = "wisps_before.csv";

/// Rows `cost,wisps,segments,side,...,ms_per_frame,...` of the report before.
fn before_costs(out: &Path) -> Vec<(usize, u32, f64)> {
    let Ok(text) = std::fs::read_to_string(out.join(BEFORE)) else {
        return Vec::new();
    };
    text.lines()
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            if f.len() < 6 || f[0] != "cost" {
                return None;
            }
            Some((f[1].parse().ok()?, f[3].parse().ok()?, f[5].parse().ok()?))
        })
        .collect()
}

/// The f64 truth (`field::render_reference`: every segment, every ray from the eye) of a
/// still scene at `size`, as an sRGB image.
pub fn truth_image(gpu: &Gpu, scene: &Scene, size: (u32, u32)) -> Result<RgbaImage> {
    use crate::systems::wisps::field;
    let stage = Stage::new(gpu, scene, target::OUTPUT_FORMAT, Quality::of(scene))?;
    let look = stage.look();
    let frame = stage::frame_uniform(scene, &look, stage.bounds(), size, 1);
    let vp = glam::DMat4::from_cols_array_2d(&frame.view_proj.map(|c| c.map(f64::from)));
    let Some(w) = scene.wisps().as_ref() else {
        return Err(crate::KamiError::Gpu("no wisps in the scene".into()));
    };
    let bg = field::linear(scene.render.background);
    let (colours, _) = field::render_reference(
        &crate::systems::wisps::curve::drawn_segments(w),
        w.threshold,
        &w.march,
        &w.toon,
        DVec3::from(scene.light.direction),
        glam::DMat3::IDENTITY,
        look.camera.eye,
        vp.inverse(),
        f64::from(frame.raster[0]),
        size,
        bg,
    );
    let srgb = |v: f64| {
        let v = v.clamp(0.0, 1.0);
        let s = if v <= 0.0031308 {
            12.92 * v
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0).round() as u8
    };
    Ok(RgbaImage::from_fn(size.0, size.1, |x, y| {
        let c = colours[(y * size.0 + x) as usize];
        image::Rgba([srgb(c.x), srgb(c.y), srgb(c.z), 255])
    }))
}

/// Run the whole bench on `scene_path` (the toon scene) and write the report into `out`.
pub fn run(gpu: &Gpu, scene_path: &Path, frames: u32, out: &Path) -> Result<Report> {
    let mut scene = Scene::load(scene_path)?;
    if scene.wisps().is_none() {
        return Err(crate::KamiError::Invalid {
            file: scene_path.display().to_string(),
            field: "wisps".into(),
            value: "None".into(),
            allowed: "a scene with toon wisps (assets/scenes/toon.ron)".into(),
        });
    }
    // The truth reference draws no head: neither do the images compared with it.
    scene.head.visible = false;
    let mut md = String::new();
    let mut csv = String::from(
        "table,wisps,segments,side,variant,ms_per_frame,mean_error,share_over_24,steps_per_ray,candidates_per_ray,us_per_covered_pixel,most_in_a_tile,before_ms\n",
    );
    writeln!(md, "# Toon wisps (Sakai)\n\n{}\n", provenance()).ok();
    writeln!(
        md,
        "Adapter: {}. One sample per pixel, the scene's camera, no head; mean of {frames} \
         frames after one warm-up, then one more frame with the march's counters on (its \
         atomics are not in the timed frames). Still wisps: the spline kernels run once, so a \
         frame is the tile binning and the ray march.\n",
        gpu.describe()
    )
    .ok();

    // `Auto`'s file is read before any work: one that does not parse fails now, not after
    // the sweeps.
    let draw_path = out.join(DRAW_FILE);
    let mut choices = match std::fs::read_to_string(&draw_path) {
        Ok(text) => crate::systems::wisps::mesh_pass::parse_choices(&text).map_err(|e| {
            crate::KamiError::Invalid {
                file: draw_path.display().to_string(),
                field: "the measured choices".into(),
                value: e,
                allowed: "the file `kami bench wisps` writes (or none)".into(),
            }
        })?,
        Err(_) => Default::default(),
    };
    let shake_path = scene_path.with_file_name("toon_shake.ron");
    let mut shake = Scene::load(&shake_path)?;
    shake.head.visible = false;

    // The march's own tables draw with the march whatever `Auto` picks here.
    let marched = with_draw(&scene, WispDraw::March);
    let cost_plot = cost_section(gpu, &marched, frames, out, &mut md, &mut csv)?;
    let error_plot = error_section(gpu, &marched, frames, &mut md, &mut csv)?;
    let measured = paths_section(gpu, &scene, &shake, frames, &mut md, &mut csv)?;
    springs_section(scene_path, out, &mut md, &mut csv)?;

    // The hand-written sections after the measured tables are kept from the report this
    // one replaces.
    if let Ok(old) = std::fs::read_to_string(out.join("wisps.md")) {
        if let Some(at) = old.find(HAND_WRITTEN) {
            md.push('\n');
            md.push_str(&old[at..]);
        }
    }
    write_report(out, "wisps", &md, &csv)?;
    write_choices(&draw_path, &mut choices, &measured, gpu)?;
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

/// Table 1, cost against wisp count and image size, before and after, the viewer's size
/// and the sweep; returns the plot.
fn cost_section(
    gpu: &Gpu,
    scene: &Scene,
    frames: u32,
    out: &Path,
    md: &mut String,
    csv: &mut String,
) -> Result<RgbaImage> {
    let before = before_costs(out);
    writeln!(
        md,
        "## Ray march cost per frame\n\nBefore: the per-box march with 64-slot neighbour \
         lists (`{BEFORE}`, written by this bench at commit cf4fdeb on the same kind of \
         machine). After: the tiled march (one quad per screen tile, each pixel marched once \
         over its tile's candidates, clear steps from the pieces' bound). Steps: field \
         samples per ray that has a candidate; candidates: segments whose influence capsule \
         the ray crosses; µs per covered pixel: the whole frame over the pixels the wisps \
         draw.\n"
    )
    .ok();
    writeln!(
        md,
        "| wisps | segments | side | before ms | after ms | speed-up | steps per ray | candidates per ray | µs per covered pixel | most segments in a tile | overflows |"
    )
    .ok();
    writeln!(md, "|---|---|---|---|---|---|---|---|---|---|---|").ok();
    let cost_series = cost_rows(gpu, scene, frames, &before, md, csv)?;
    viewer_cost(gpu, scene, frames, md, csv)?;
    sweep(gpu, scene, frames, md, csv)?;
    Ok(plot::loglog(
        "Toon wisps: ray march per frame",
        "pixels",
        "ms per frame",
        &cost_series,
        None,
    ))
}

/// The cost table's rows: each of `COPIES` times the scene at each of `SIDES`, next to the
/// recorded cost before the tiled march; returns the plot's series.
fn cost_rows(
    gpu: &Gpu,
    scene: &Scene,
    frames: u32,
    before: &[(usize, u32, f64)],
    md: &mut String,
    csv: &mut String,
) -> Result<Vec<Series>> {
    let mut cost_series = Vec::new();
    for (i, &copies) in COPIES.iter().enumerate() {
        let s = multiplied(scene, copies);
        let w = s.wisps().as_ref().map(|w| w.skeletons.len()).unwrap_or(0);
        let segs = s
            .wisps()
            .as_ref()
            .map(crate::systems::wisps::march::segment_count)
            .unwrap_or(0);
        let mut pts = Vec::new();
        let mut pts_before = Vec::new();
        for &side in &SIDES {
            let f = march_frame(gpu, &s, (side, side), frames)?;
            let was = before.iter().find(|b| b.0 == w && b.1 == side).map(|b| b.2);
            let was_text = was.map_or("-".into(), |b| format!("{b:.1}"));
            let gain = was.map_or("-".into(), |b| format!("{:.1}x", b / f.ms));
            writeln!(
                md,
                "| {w} | {segs} | {side}² | {was_text} | {:.1} | {gain} | {:.1} | {:.1} | {:.2} | {} | {} |",
                f.ms,
                f.steps_per_ray(),
                f.candidates_per_ray(),
                f.us_per_covered(),
                f.stats.most_in_a_tile,
                f.stats.ray_overflow + f.stats.tile_overflow
            )
            .ok();
            writeln!(
                csv,
                "cost,{w},{segs},{side},tiled,{:.3},,,{:.3},{:.3},{:.4},{},{}",
                f.ms,
                f.steps_per_ray(),
                f.candidates_per_ray(),
                f.us_per_covered(),
                f.stats.most_in_a_tile,
                was.map_or(String::new(), |b| format!("{b:.3}"))
            )
            .ok();
            pts.push(((side * side) as f64, f.ms));
            if let Some(b) = was {
                pts_before.push(((side * side) as f64, b));
            }
        }
        cost_series.push(Series {
            name: format!("{w} wisps, tiled"),
            color: plot::palette(i),
            points: pts,
        });
        if !pts_before.is_empty() {
            cost_series.push(Series {
                name: format!("{w} wisps, before"),
                color: plot::palette(i + 3),
                points: pts_before,
            });
        }
    }
    Ok(cost_series)
}

/// The viewer's default size, the goal (10 fps there).
fn viewer_cost(
    gpu: &Gpu,
    scene: &Scene,
    frames: u32,
    md: &mut String,
    csv: &mut String,
) -> Result<()> {
    let view = march_frame(gpu, scene, VIEWER, frames)?;
    writeln!(
        md,
        "\nAt the viewer's size, {}x{} (22 wisps): **{:.1} ms per frame** ({:.2} fps for the \
         march alone), {:.1} steps and {:.1} candidates per ray, {:.2} µs per covered pixel, \
         {} pixels covered.\n",
        VIEWER.0,
        VIEWER.1,
        view.ms,
        1e3 / view.ms,
        view.steps_per_ray(),
        view.candidates_per_ray(),
        view.us_per_covered(),
        view.stats.covered
    )
    .ok();
    writeln!(
        csv,
        "cost,22,,{}x{},tiled,{:.3},,,{:.3},{:.3},{:.4},{},",
        VIEWER.0,
        VIEWER.1,
        view.ms,
        view.steps_per_ray(),
        view.candidates_per_ray(),
        view.us_per_covered(),
        view.stats.most_in_a_tile
    )
    .ok();
    Ok(())
}

/// Table 2, image error of each variant against the f64 truth; returns the plot.
fn error_section(
    gpu: &Gpu,
    scene: &Scene,
    frames: u32,
    md: &mut String,
    csv: &mut String,
) -> Result<RgbaImage> {
    let size = (ERROR_SIDE, ERROR_SIDE);
    let truth = truth_image(gpu, scene, size)?;
    writeln!(
        md,
        "## Ray march error against the f64 reference ({ERROR_SIDE}², against \
         `field::render_reference`: every segment for every ray from the eye, in f64, with the \
         scene's march settings)\n"
    )
    .ok();
    writeln!(
        md,
        "| variant | ms per frame | steps per ray | mean error (of 255) | pixels off by > 24 |"
    )
    .ok();
    writeln!(md, "|---|---|---|---|---|").ok();
    let mut newton_pts = Vec::new();
    let mut poly_pts = Vec::new();
    for (name, distance, step, refine) in error_variants() {
        let mut s = scene.clone();
        if let Some(w) = s.wisps_mut().as_mut() {
            w.march.distance = distance;
            w.march.step_scale = step;
            w.march.refine = refine;
        }
        let mut t = Timed::new(gpu, &s, size)?;
        let img = t.image(gpu)?;
        let ms = time_mean(frames, || t.frame(gpu))? * 1e3;
        let counted = t.counted(gpu)?;
        let steps = f64::from(counted.steps) / f64::from(counted.rays.max(1));
        let (mean, over, _) = super::backends::difference(&truth, &img);
        writeln!(
            md,
            "| {name} | {ms:.1} | {steps:.1} | {mean:.3} | {:.3} % |",
            over * 100.0
        )
        .ok();
        writeln!(
            csv,
            "error,,,{ERROR_SIDE},{name},{ms:.3},{mean:.5},{over:.6},{steps:.3},,,,"
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
                name: "Newton, step 0.5-4, 4-16 bisections".into(),
                color: plot::palette(0),
                points: newton_pts,
            },
            Series {
                name: "polyline 1-8".into(),
                color: plot::palette(1),
                points: poly_pts,
            },
        ],
        None,
    );
    writeln!(
        md,
        "\nSteps above 1 leave the safe bound and may skip thin wisps; they are here to show \
         what the bound buys.\n"
    )
    .ok();
    Ok(error_plot)
}

/// The error table's variants: (name, distance method, step scale, bisections).
fn error_variants() -> Vec<(String, Distance, f64, u32)> {
    let mut variants: Vec<(String, Distance, f64, u32)> = Vec::new();
    for step in [0.5, 1.0, 2.0, 4.0] {
        variants.push((format!("Newton, step {step}"), Distance::Newton, step, 8));
    }
    for refine in [4, 16] {
        variants.push((
            format!("Newton, {refine} bisections"),
            Distance::Newton,
            1.0,
            refine,
        ));
    }
    for pieces in [1, 2, 4, 8] {
        variants.push((
            format!("polyline {pieces}"),
            Distance::Polyline { pieces },
            1.0,
            8,
        ));
    }
    variants
}

/// Table 3, mass springs: work against precision (f64 reference, CPU) on three wisps of
/// `toon_shake.ron` beside the scene; writes `wisps_springs.png`.
fn springs_section(scene_path: &Path, out: &Path, md: &mut String, csv: &mut String) -> Result<()> {
    let shake_path = scene_path.with_file_name("toon_shake.ron");
    let shake = Scene::load(&shake_path)?;
    if let Some(w) = shake.wisps().as_ref() {
        // Three wisps (a bang, a side and a back wisp) keep the f64 runs short.
        let mut few = w.clone();
        let pick = [2usize, 8, 13];
        few.skeletons = pick
            .iter()
            .filter_map(|&i| w.skeletons.get(i).cloned())
            .collect();
        few.bundles.clear();
        let forces = crate::forces::Forces::new(&shake.forces, &shake.head);
        let ladder = [16, 32, 64, 128];
        let rows = springs::work_precision(&few, &shake.head, &forces, 0.5, &ladder)?;
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
            springs::STABLE_MARGIN * 100.0
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
    Ok(())
}

/// The file `Auto` reads (`mesh_pass::choices`), written beside the report.
pub const DRAW_FILE: &str = "wisps_draw.ron";

/// Steps per ray of the converged f64 truth (the march's own budget runs out on some rays).
pub const CONVERGED_STEPS: u32 = 4096;

/// One path's image at `size` (one sample per pixel, no head).
fn path_image(gpu: &Gpu, scene: &Scene, draw: WispDraw, size: (u32, u32)) -> Result<RgbaImage> {
    let mut t = Timed::new(gpu, &with_draw(scene, draw), size)?;
    t.image(gpu)
}

fn with_draw(scene: &Scene, draw: WispDraw) -> Scene {
    let mut s = scene.clone();
    if let Some(w) = s.wisps_mut().as_mut() {
        w.draw = draw;
    }
    s
}

fn meshed_on(scene: &Scene, on: MeshOn) -> Scene {
    let mut s = scene.clone();
    if let Some(w) = s.wisps_mut().as_mut() {
        w.mesh.on = on;
    }
    s
}

/// A path's frame: CPU wall ms per frame after a warm-up (which meshes a still scene), for
/// the mesh the last meshing (ms, cell, triangles), and the last frame's image.
fn path_frame(
    gpu: &Gpu,
    scene: &Scene,
    draw: WispDraw,
    size: (u32, u32),
    frames: u32,
    moving: bool,
) -> Result<(f64, Option<crate::systems::wisps::MeshInfo>, RgbaImage)> {
    let mut t = Timed::new(gpu, &with_draw(scene, draw), size)?;
    t.moving = moving;
    t.frame(gpu)?;
    let secs = time_mean(frames, || t.frame(gpu))?;
    let info = t.wisps()?.mesh.as_ref().map(|m| m.last);
    let img = t.out.read_rgba(gpu)?;
    Ok((secs * 1e3, info, img))
}

/// The "March and mesh" error table: both paths against both f64 truths at `ERROR_SIDE`²
/// for each wisp count. Returns whether the mesh was within the bound at every count.
fn paths_errors(gpu: &Gpu, scene: &Scene, md: &mut String, csv: &mut String) -> Result<bool> {
    use crate::systems::wisps::mesh_pass::MESH_ERROR_BOUND;
    let (bound_mean, bound_share) = MESH_ERROR_BOUND;
    writeln!(
        md,
        "| wisps | truth | march: mean error | > 24 | mesh: mean error | > 24 | mesh cell | mesh within the bound |"
    )
    .ok();
    writeln!(md, "|---|---|---|---|---|---|---|---|").ok();
    let size = (ERROR_SIDE, ERROR_SIDE);
    let mut within = true;
    for &count in &COUNTS {
        let s = with_count(scene, count);
        let march_img = path_image(gpu, &s, WispDraw::March, size)?;
        let mut t = Timed::new(gpu, &with_draw(&s, WispDraw::Mesh), size)?;
        let mesh_img = t.image(gpu)?;
        let cell = t.wisps()?.mesh.as_ref().map_or(0.0, |m| m.last.cell);
        let mut converged = s.clone();
        if let Some(w) = converged.wisps_mut().as_mut() {
            w.march.max_steps = CONVERGED_STEPS;
        }
        for (name, truth_scene) in [("scene's steps", &s), ("converged", &converged)] {
            let truth = truth_image(gpu, truth_scene, size)?;
            let (m_mean, m_over, _) = super::backends::difference(&truth, &march_img);
            let (x_mean, x_over, _) = super::backends::difference(&truth, &mesh_img);
            let judged = name == "converged";
            let ok = x_mean <= bound_mean && x_over <= bound_share;
            if judged {
                within &= ok;
            }
            writeln!(
                md,
                "| {count} | {name} | {m_mean:.3} | {:.3} % | {x_mean:.3} | {:.3} % | {cell:.3} | {} |",
                m_over * 100.0,
                x_over * 100.0,
                match (judged, ok) {
                    (false, _) => "-",
                    (true, true) => "yes",
                    (true, false) => "no",
                }
            )
            .ok();
            for (path, mean, over) in [("march", m_mean, m_over), ("mesh", x_mean, x_over)] {
                writeln!(
                    csv,
                    "paths_error,{count},,{ERROR_SIDE},{path} ({name}),,{mean:.5},{over:.6},,,,,"
                )
                .ok();
            }
        }
    }
    Ok(within)
}

/// What one measured adapter class says `Auto` draws (`docs/wisps_draw.ron`).
#[derive(Clone, Debug, PartialEq)]
pub struct Measured {
    pub adapter: String,
    /// Still wisps: the mesh was cheaper than the march at every count and size swept and
    /// within the error bound at every count.
    pub still_mesh: bool,
    /// Moving wisps (`toon_shake.ron`, meshed every frame): the same at the viewer's size.
    pub moving_mesh: bool,
    /// Where moving wisps were meshed cheaper: on the CPU (nodes read back) or the GPU.
    pub moving_on: MeshOn,
}

/// Table 4: the two ways to draw the surface (`block::WispDraw`) side by side: image error
/// against the f64 truth at `ERROR_SIDE`² for each wisp count, ms per frame at each count
/// and sweep size, and moving wisps (`toon_shake.ron`, meshed every frame). Returns what
/// `Auto` should draw on this adapter.
pub fn paths_section(
    gpu: &Gpu,
    scene: &Scene,
    shake: &Scene,
    frames: u32,
    md: &mut String,
    csv: &mut String,
) -> Result<Measured> {
    use crate::systems::wisps::mesh_pass::MESH_ERROR_BOUND;
    let software = gpu.info.device_type == wgpu::DeviceType::Cpu;
    let frames = if software {
        frames.clamp(1, 2)
    } else {
        frames.min(3)
    };
    let (bound_mean, bound_share) = MESH_ERROR_BOUND;
    writeln!(
        md,
        "\n## March and mesh\n\nThe two ways to draw the surface (`wisps.draw`): the ray \
         march (where `wisps.march.on` says, on this adapter) and the mesh (surface nets over \
         the bricks the wisps reach, each vertex moved onto the exact surface, rasterised with \
         the same toon shading and an inverted hull for the outline; `wisps.mesh.cell` 0, the \
         automatic cell). Error at {ERROR_SIDE}², mean of 255 and pixels off by more than \
         24, against two f64 truths: the scene's march settings (`field::render_reference`, \
         as the table above: its {} steps per ray run out on some rays that graze the crown \
         or pass between the bangs, which then show nothing) and the converged surface (the \
         same with {CONVERGED_STEPS} steps). The bound `Auto` holds the mesh to, against the \
         converged truth: {bound_mean} and {:.1} %, the march's own error before the mesh.\n",
        scene.wisps().as_ref().map_or(0, |w| w.march.max_steps),
        bound_share * 100.0
    )
    .ok();
    let within = paths_errors(gpu, scene, md, csv)?;
    writeln!(
        md,
        "\nStill wisps, mean of {frames} frame(s) after a warm-up (the warm-up meshes: a still \
         hairstyle is meshed once, and a frame is the raster). Mesh against march: the two \
         images at that size.\n"
    )
    .ok();
    writeln!(
        md,
        "| wisps | size | march ms | fps | mesh ms | fps | mesh / march | meshing ms (once) | cell | triangles | mesh against march: mean / > 24 |"
    )
    .ok();
    writeln!(md, "|---|---|---|---|---|---|---|---|---|---|---|").ok();
    let mut still_cheaper = true;
    for &count in &COUNTS {
        let s = with_count(scene, count);
        for &size in sweep_sizes(software) {
            let (march_ms, _, march_img) =
                path_frame(gpu, &s, WispDraw::March, size, frames, false)?;
            let (mesh_ms, info, mesh_img) =
                path_frame(gpu, &s, WispDraw::Mesh, size, frames, false)?;
            let info = info.unwrap_or_default();
            let (d_mean, d_over, _) = super::backends::difference(&march_img, &mesh_img);
            still_cheaper &= mesh_ms < march_ms;
            writeln!(
                md,
                "| {count} | {}x{} | {march_ms:.1} | {:.1} | {mesh_ms:.1} | {:.1} | {:.3} | {:.1} | {:.3} | {} | {d_mean:.2} / {:.2} % |",
                size.0,
                size.1,
                1e3 / march_ms,
                1e3 / mesh_ms,
                mesh_ms / march_ms,
                info.ms,
                info.cell,
                info.triangles,
                d_over * 100.0
            )
            .ok();
            writeln!(
                csv,
                "paths,{count},,{}x{},march,{march_ms:.3},,,,,,,",
                size.0, size.1
            )
            .ok();
            writeln!(
                csv,
                "paths,{count},,{}x{},mesh,{mesh_ms:.3},{d_mean:.5},{d_over:.6},,,,{},",
                size.0, size.1, info.triangles
            )
            .ok();
        }
    }
    let (moving_cheaper, moving_on) = paths_moving(gpu, shake, frames, md, csv)?;
    let measured = Measured {
        adapter: gpu.describe(),
        still_mesh: within && still_cheaper,
        moving_mesh: within && moving_cheaper,
        moving_on,
    };
    writeln!(
        md,
        "So `Auto` draws, on this kind of adapter: still wisps with the {}, moving wisps with \
         the {} (`{DRAW_FILE}`).\n",
        if measured.still_mesh { "mesh" } else { "march" },
        match (measured.moving_mesh, measured.moving_on) {
            (false, _) => "march",
            (true, MeshOn::Gpu) => "mesh, meshed on the GPU",
            (true, _) => "mesh, meshed on the CPU",
        },
    )
    .ok();
    Ok(measured)
}

/// The moving wisps' table (`toon_shake.ron` at the viewer's size, meshed every frame):
/// whether the mesh was cheaper than the march, and where it was meshed cheaper.
fn paths_moving(
    gpu: &Gpu,
    shake: &Scene,
    frames: u32,
    md: &mut String,
    csv: &mut String,
) -> Result<(bool, MeshOn)> {
    // Moving wisps: each frame steps the springs and meshes them again, on the CPU from
    // the nodes read back or on the GPU.
    let (march_ms, _, march_img) = path_frame(gpu, shake, WispDraw::March, VIEWER, frames, true)?;
    let (cpu_ms, info, _) = path_frame(
        gpu,
        &meshed_on(shake, MeshOn::Cpu),
        WispDraw::Mesh,
        VIEWER,
        frames,
        true,
    )?;
    let (gpu_ms, _, gpu_img) = path_frame(
        gpu,
        &meshed_on(shake, MeshOn::Gpu),
        WispDraw::Mesh,
        VIEWER,
        frames,
        true,
    )?;
    let (g_mean, g_over, _) = super::backends::difference(&march_img, &gpu_img);
    let info = info.unwrap_or_default();
    let mesh_ms = cpu_ms.min(gpu_ms);
    let moving_on = if gpu_ms < cpu_ms {
        MeshOn::Gpu
    } else {
        MeshOn::Cpu
    };
    let moving_cheaper = mesh_ms < march_ms;
    writeln!(
        md,
        "\nMoving wisps (`toon_shake.ron`, {}x{}, each frame a step of the springs and a new \
         mesh; mean of {frames} frame(s) after a warm-up):\n\n\
         | path | ms per frame | fps |\n|---|---|---|\n\
         | march | {march_ms:.1} | {:.1} |\n\
         | mesh, meshed on the CPU (nodes read back; meshing {:.1} ms, cell {:.3}, {} triangles) | {cpu_ms:.1} | {:.1} |\n\
         | mesh, meshed on the GPU (`shaders/wisps/mesher.wgsl`, nothing read back) | {gpu_ms:.1} | {:.1} |\n\n\
         The GPU-meshed frame against the march's of the same frame: mean {g_mean:.2}, \
         {:.2} % of pixels over 24.\n",
        VIEWER.0,
        VIEWER.1,
        1e3 / march_ms,
        info.ms,
        info.cell,
        info.triangles,
        1e3 / cpu_ms,
        1e3 / gpu_ms,
        g_over * 100.0
    )
    .ok();
    let n_shake = shake.wisps().as_ref().map_or(0, |w| w.skeletons.len());
    for (variant, ms) in [
        ("march", march_ms),
        ("mesh (CPU mesher)", cpu_ms),
        ("mesh (GPU mesher)", gpu_ms),
    ] {
        writeln!(
            csv,
            "paths_moving,{n_shake},,{}x{},{variant},{ms:.3},,,,,,,",
            VIEWER.0, VIEWER.1
        )
        .ok();
    }
    Ok((moving_cheaper, moving_on))
}

/// `Auto`'s file with this adapter class's entry replaced by `measured`.
fn write_choices(
    path: &Path,
    choices: &mut crate::systems::wisps::mesh_pass::DrawChoices,
    measured: &Measured,
    gpu: &Gpu,
) -> Result<()> {
    use crate::systems::wisps::mesh_pass::DrawChoice;
    let pick = |mesh: bool| {
        if mesh {
            WispDraw::Mesh
        } else {
            WispDraw::March
        }
    };
    let entry = Some(DrawChoice {
        adapter: measured.adapter.clone(),
        still: pick(measured.still_mesh),
        moving: pick(measured.moving_mesh),
        moving_on: Some(measured.moving_on),
    });
    if gpu.info.device_type == wgpu::DeviceType::Cpu {
        choices.software = entry;
    } else {
        choices.hardware = entry;
    }
    let body = ron::ser::to_string_pretty(choices, ron::ser::PrettyConfig::default())
        .map_err(|e| crate::KamiError::Gpu(format!("{DRAW_FILE}: {e}")))?;
    let text = format!(
        "// What `wisps.draw: Auto` draws on each kind of adapter: written by `kami bench wisps`\n\
         // (its \"March and mesh\" table in docs/wisps.md), compiled into Kami.\n{body}\n"
    );
    std::fs::write(path, text).map_err(|e| crate::KamiError::Io {
        path: path.to_path_buf(),
        source: e,
    })
}
