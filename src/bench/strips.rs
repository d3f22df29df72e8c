//! `kami bench strips`: Kazama's strips. Strips per second on the adapter in use (the
//! dynamics kernel alone and a full frame, against strip count), the angular-spring
//! solver's work–precision table on `dynamics::Setup::gust()` (f64 CPU reference), and the
//! motion nearest and trilinear EFF sampling give the shipped scene (f64 CPU reference), and
//! the EFF fit (the capture round trip's report). Writes strips.md, strips.csv,
//! strips_speed.png, strips_precision.png, strips_sampling.csv, strips_sampling.png, and
//! capture.md/.csv/.png.

pub mod precision;

use super::{provenance, time_mean, write_report, Report};
use crate::bench::plot::{self, Series};
use crate::error::Result;
use crate::forces::Forces;
use crate::gpu::Gpu;
use crate::scene::Sampling;
use crate::stage::{self, target, Quality, Stage};
use crate::systems::strips::dynamics::{self, Setup};
use crate::systems::strips::hom;
use crate::systems::Scene;
use glam::DVec3;
use precision::PrecisionRow;
use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

/// Strip counts of the speed sweep (the shipped scene has 120).
pub const COUNTS: [u32; 4] = [30, 120, 480, 1920];

/// Image size of the full-frame timing (one sample per pixel).
pub const SIZE: (u32, u32) = (640, 480);

/// Rates of the work–precision table (steps per second; rounded to whole steps per frame,
/// at least one, so nothing below the frame rate: 15 steps/s ran as 30 and repeated its row).
pub const RATES: [f64; 6] = [30.0, 60.0, 120.0, 240.0, 480.0, 960.0];

/// Frames of `Setup::gust()` the precision table runs: 1.5 s at 30 fps covers the gust's
/// keys (to frame 36) and the head turn (to frame 42).
pub const PRECISION_FRAMES: u32 = 45;

/// Largest step the stability search tries (seconds).
pub const STABLE_CAP: f64 = 0.5;

/// The paper's figure (Kazama et al., Quadro FX4500): 120 strips at 15–20 fps.
pub const PAPER: &str = "120 strips at 15–20 fps on a Quadro FX4500";

/// The scene with its layers' counts scaled so they sum to `n` (largest remainder, at
/// least one strip per layer), the layers' shapes unchanged.
pub fn scaled(scene: &Scene, n: u32) -> Scene {
    let mut s = scene.clone();
    let Some(st) = s.strips_mut().as_mut() else {
        return s;
    };
    let total: u32 = st.layers.iter().map(|l| l.count).sum();
    if total == 0 {
        return s;
    }
    let want: Vec<f64> = st
        .layers
        .iter()
        .map(|l| l.count as f64 * n as f64 / total as f64)
        .collect();
    let mut got: Vec<u32> = want.iter().map(|w| (w.floor() as u32).max(1)).collect();
    let mut order: Vec<usize> = (0..want.len()).collect();
    order.sort_by(|&a, &b| (want[b] - want[b].floor()).total_cmp(&(want[a] - want[a].floor())));
    let mut k = 0;
    while got.iter().sum::<u32>() < n && !order.is_empty() {
        got[order[k % order.len()]] += 1;
        k += 1;
    }
    for (l, c) in st.layers.iter_mut().zip(got) {
        l.count = c;
    }
    s
}

/// One scene on the stage with an offscreen target.
struct Timed {
    stage: Stage,
    out: target::Offscreen,
}

impl Timed {
    fn new(gpu: &Gpu, scene: &Scene) -> Result<Timed> {
        stage::check_limits(gpu, scene, SIZE)?;
        let quality = Quality::new(1, 1);
        Ok(Timed {
            stage: Stage::new(gpu, scene, target::OUTPUT_FORMAT, quality)?,
            out: target::Offscreen::new(gpu, SIZE)?,
        })
    }

    /// One frame of motion only (the strips are the stage's only system), waited for.
    fn step(&mut self, gpu: &Gpu) -> Result<()> {
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("bench strips step"),
            });
        self.stage.advance(gpu, &mut enc, 1)?;
        gpu.queue.submit([enc.finish()]);
        gpu.wait()
    }

    /// One frame of motion and the render into the offscreen target, waited for.
    fn frame(&mut self, gpu: &Gpu) -> Result<()> {
        let look = self.stage.look();
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("bench strips frame"),
            });
        self.stage.advance(gpu, &mut enc, 1)?;
        self.stage
            .render(gpu, &mut enc, &self.out.view, SIZE, &look)?;
        gpu.queue.submit([enc.finish()]);
        gpu.wait()
    }
}

fn save(out: &Path, name: &str, img: image::RgbaImage) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|source| crate::KamiError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    let p = out.join(name);
    img.save(&p).map_err(|e| crate::KamiError::Io {
        path: p.clone(),
        source: std::io::Error::other(e),
    })
}

/// Run the whole bench on `scene_path` (the strips scene) and write the report into `out`.
pub fn run(gpu: &Gpu, scene_path: &Path, frames: u32, out: &Path) -> Result<Report> {
    let scene = Scene::load(scene_path)?;
    let Some(strips) = scene.strips().as_ref() else {
        return Err(crate::KamiError::Invalid {
            file: scene_path.display().to_string(),
            field: "strips".into(),
            value: "None".into(),
            allowed: "a scene with strips (assets/scenes/strips.ron)".into(),
        });
    };
    let steps = dynamics::steps_per_frame(&strips.motion);
    let mut md = String::new();
    let mut csv = String::from(
        "table,strips,steps_per_second,dt,ms_per_frame,fps,strips_per_second,tip_error,tip_error_rel,ns_per_strip_step,stable\n",
    );
    writeln!(
        md,
        "# Strips (Kazama, Sugisaki, Morishima)\n\n{}\n",
        provenance()
    )
    .ok();
    writeln!(md, "Adapter: {}.\n", gpu.describe()).ok();

    let speed_plot = speed_section(gpu, &scene, strips, scene_path, frames, &mut md, &mut csv)?;
    let precision_plot = precision_section(steps, &mut md, &mut csv)?;

    // 3. The motion nearest and trilinear EFF sampling give the scene.
    let (sampling_md, sampling_csv, sampling_plot) = sampling_section(&scene, scene_path)?;
    md.push_str(&sampling_md);

    quote_capture(out, &mut md)?;

    write_report(out, "strips", &md, &csv)?;
    save(out, "strips_speed.png", speed_plot)?;
    save(out, "strips_precision.png", precision_plot)?;
    save(out, "strips_sampling.png", sampling_plot)?;
    let p = out.join("strips_sampling.csv");
    std::fs::write(&p, sampling_csv).map_err(|source| crate::KamiError::Io { path: p, source })?;
    Ok(Report { markdown: md, csv })
}

/// Table 1, speed against strip count: dynamics and full-frame ms for each of `COUNTS`;
/// returns the plot.
fn speed_section(
    gpu: &Gpu,
    scene: &Scene,
    strips: &crate::systems::strips::block::Strips,
    scene_path: &Path,
    frames: u32,
    md: &mut String,
    csv: &mut String,
) -> Result<image::RgbaImage> {
    let steps = dynamics::steps_per_frame(&strips.motion);
    writeln!(md, "## Strips per second\n").ok();
    writeln!(
        md,
        "`{}` with its layers' counts scaled to N strips; {} steps per frame ({} steps/s, \
         frame time {:.4} s). Dynamics: `Stage::advance` of one frame (the strips are the \
         only system), submitted and waited for. Full frame: advance and render into a \
         {}x{} offscreen target, one sample per pixel. Mean of {frames} frames after one \
         warm-up. Strips per second = N x dynamics frames per second.\n",
        scene_path.display(),
        steps,
        strips.motion.steps_per_second,
        strips.motion.frame_time,
        SIZE.0,
        SIZE.1
    )
    .ok();
    writeln!(
        md,
        "| N | dynamics ms/frame | strips per second | full frame ms | full frame fps |"
    )
    .ok();
    writeln!(md, "|---:|---:|---:|---:|---:|").ok();
    let mut dyn_pts = Vec::new();
    let mut full_pts = Vec::new();
    let mut fps_120 = None;
    for &n in &COUNTS {
        let s = scaled(scene, n);
        let count: u32 = s
            .strips()
            .as_ref()
            .map(|st| st.layers.iter().map(|l| l.count).sum())
            .unwrap_or(0);
        let mut t = Timed::new(gpu, &s)?;
        let dyn_s = time_mean(frames, || t.step(gpu))?;
        let full_s = time_mean(frames, || t.frame(gpu))?;
        let sps = count as f64 / dyn_s;
        writeln!(
            md,
            "| {count} | {:.2} | {sps:.0} | {:.2} | {:.1} |",
            dyn_s * 1e3,
            full_s * 1e3,
            1.0 / full_s
        )
        .ok();
        writeln!(
            csv,
            "dynamics,{count},{},,{:.4},{:.3},{sps:.1},,,,",
            strips.motion.steps_per_second,
            dyn_s * 1e3,
            1.0 / dyn_s
        )
        .ok();
        writeln!(
            csv,
            "full_frame,{count},{},,{:.4},{:.3},,,,,",
            strips.motion.steps_per_second,
            full_s * 1e3,
            1.0 / full_s
        )
        .ok();
        if count == 120 {
            fps_120 = Some(1.0 / full_s);
        }
        dyn_pts.push((count as f64, dyn_s * 1e3));
        full_pts.push((count as f64, full_s * 1e3));
    }
    writeln!(
        md,
        "\nThe paper's figure, on different hardware: {PAPER} (a full frame, drawn). Here, \
         120 strips: {} fps for a full frame on the adapter above.\n",
        fps_120.map_or("-".into(), |f| format!("{f:.1}"))
    )
    .ok();
    let speed_plot = plot::loglog(
        "Strips: ms per frame against strip count",
        "strips",
        "ms per frame",
        &[
            Series {
                name: "dynamics".into(),
                color: plot::palette(0),
                points: dyn_pts,
            },
            Series {
                name: format!("full frame {}x{}", SIZE.0, SIZE.1),
                color: plot::palette(1),
                points: full_pts,
            },
        ],
        None,
    );
    Ok(speed_plot)
}

/// Table 2, work against precision of the angular-spring solver (f64 CPU reference), and
/// the notes under it; returns the plot.
fn precision_section(steps: u32, md: &mut String, csv: &mut String) -> Result<image::RgbaImage> {
    let setup = Setup::gust();
    let rows = precision::work_precision(&setup, &RATES, PRECISION_FRAMES)?;
    let seconds = PRECISION_FRAMES as f64 * setup.motion.frame_time;
    let order = precision::observed_order(&rows);
    let largest = precision::largest_stable_dt(&setup, seconds, STABLE_CAP)?;
    let to_one = precision::dt_for_error(&rows, 0.01);
    let reference = (16.0 * RATES.iter().copied().fold(0.0, f64::max)).max(3840.0);
    writeln!(
        md,
        "## Angular springs: work against precision\n\n`dynamics::Setup::gust()` ({} strips: \
         gravity, a gust, a head turn, a key-frame force), {PRECISION_FRAMES} frames ({seconds:.2} \
         s), f64 on the CPU. Tip error: the largest tip distance over every frame and strip \
         from the same solver at {reference:.0} steps/s; relative: to the strip's length. \
         Requested rates {:?} steps/s are rounded to whole steps per frame (the table shows \
         the effective rate). Cost: wall time of the f64 reference per strip and step, and per \
         strip and simulated second.\n",
        setup.rest.len(),
        RATES
    )
    .ok();
    writeln!(
        md,
        "| steps/s | dt (ms) | tip error (cm) | tip error / length | ns per strip-step | µs per strip-second | stable |"
    )
    .ok();
    writeln!(md, "|---:|---:|---:|---:|---:|---:|---|").ok();
    let pts = precision_rows(&setup, &rows, md, csv);
    let ns_mean = mean_ns(&rows);
    writeln!(md).ok();
    writeln!(
        md,
        "- Observed order (slope of log error against log dt, stable rows): {}.",
        order.map_or("- (fewer than two usable rows)".into(), |o| format!(
            "{o:.2}"
        ))
    )
    .ok();
    writeln!(
        md,
        "- Largest stable dt over {seconds:.2} s (rates within {}x the reference's, searched \
         up to {STABLE_CAP} s): {}.",
        precision::SPEED_LIMIT,
        if largest >= STABLE_CAP {
            format!("≥ {:.0} ms (the cap)", STABLE_CAP * 1e3)
        } else {
            format!("{:.2} ms", largest * 1e3)
        }
    )
    .ok();
    match to_one {
        Some(dt) => {
            let us = ns_mean * 1e-3 / dt;
            writeln!(
                md,
                "- Cost to 1 % tip error: dt = {:.2} ms ({:.0} steps/s), {us:.1} µs per strip \
                 per simulated second at the mean {ns_mean:.0} ns per strip-step (f64 CPU).",
                dt * 1e3,
                1.0 / dt
            )
            .ok();
            writeln!(
                csv,
                "to_one_percent,{},{},{dt},,,,,0.01,{ns_mean:.2},",
                setup.rest.len(),
                1.0 / dt
            )
            .ok();
        }
        None => {
            writeln!(
                md,
                "- Cost to 1 % tip error: no stable rows to interpolate."
            )
            .ok();
        }
    }
    writeln!(
        md,
        "- The f64 reference on the shipped scene's 120 strips at {} steps per frame would \
         cost about {:.2} ms per frame on one CPU thread ({ns_mean:.0} ns per strip-step).\n",
        steps,
        ns_mean * 120.0 * steps as f64 * 1e-6
    )
    .ok();
    let precision_plot = plot::loglog(
        "Strips: tip error against cost (f64 CPU)",
        "us per strip per simulated second",
        "tip error / strip length",
        &[Series {
            name: "30-960 steps/s".into(),
            color: plot::palette(2),
            points: pts,
        }],
        Some((0.01, "1 %")),
    );
    Ok(precision_plot)
}

/// The work-precision table's rows; returns the plot's (µs per strip-second, relative tip
/// error) points of the stable rows.
fn precision_rows(
    setup: &Setup,
    rows: &[PrecisionRow],
    md: &mut String,
    csv: &mut String,
) -> Vec<(f64, f64)> {
    let mut pts = Vec::new();
    for r in rows {
        let us = r.ns_per_strip_step * r.steps_per_second * 1e-3;
        writeln!(
            md,
            "| {:.0} | {:.3} | {:.3e} | {:.3e} | {:.0} | {us:.1} | {} |",
            r.steps_per_second,
            r.dt * 1e3,
            r.tip_error,
            r.tip_error_rel,
            r.ns_per_strip_step,
            if r.stable { "yes" } else { "no" }
        )
        .ok();
        writeln!(
            csv,
            "precision,{},{},{},,,,{:.6e},{:.6e},{:.2},{}",
            setup.rest.len(),
            r.steps_per_second,
            r.dt,
            r.tip_error,
            r.tip_error_rel,
            r.ns_per_strip_step,
            r.stable
        )
        .ok();
        if r.stable && r.tip_error_rel > 0.0 && r.tip_error_rel.is_finite() {
            pts.push((us, r.tip_error_rel));
        }
    }
    pts
}

/// EFF fit: the capture round trip writes capture.md, capture.csv and capture.png into
/// `out`; its tables are quoted here (headings demoted) so strips.md stands alone.
fn quote_capture(out: &Path, md: &mut String) -> Result<()> {
    super::capture::write_report(out)?;
    let cap_path = out.join("capture.md");
    let cap = std::fs::read_to_string(&cap_path).map_err(|source| crate::KamiError::Io {
        path: cap_path.clone(),
        source,
    })?;
    writeln!(
        md,
        "## EFF fit\n\nFrom `bench::capture::write_report` (also written as \
         capture.md, capture.csv, capture.png).\n"
    )
    .ok();
    let mut quoted = String::new();
    for line in cap.lines() {
        if line.starts_with("# ") || line.starts_with("Written by") {
            continue;
        }
        let demote = if line.starts_with('#') { "#" } else { "" };
        writeln!(quoted, "{demote}{line}").ok();
    }
    md.push_str(quoted.trim_start());
    Ok(())
}

/// Mean f64 cost per strip-step over the stable rows (the cost hardly depends on dt).
fn mean_ns(rows: &[PrecisionRow]) -> f64 {
    let v: Vec<f64> = rows
        .iter()
        .filter(|r| r.stable && r.ns_per_strip_step.is_finite())
        .map(|r| r.ns_per_strip_step)
        .collect();
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Frames of the sampling comparison: 2 s at 30 fps covers the shipped scene's gust keys
/// (to frame 60).
pub const SAMPLING_FRAMES: u32 = 60;

/// Frames before the jerk is measured: the strips first settle from their rest shape under
/// gravity (the same under both samplings), a jerk that would swamp the wind's.
pub const SETTLE_FRAMES: u32 = 20;

/// One strip's tip under nearest and trilinear EFF sampling. Index 0 of the pairs is
/// nearest, 1 trilinear.
#[derive(Clone, Debug, PartialEq)]
pub struct SamplingStrip {
    /// The strip's layer (index into the scene's layers).
    pub layer: usize,
    /// The strip's length (world units, cm).
    pub length: f64,
    /// Distance between the two motions' tips: rms and largest over the clip's frames (cm).
    pub rms: f64,
    pub max: f64,
    /// The tip's jerk (third difference of its position over frames / frame time³, cm/s³):
    /// rms and largest over the frames from `SETTLE_FRAMES` on. A force that jumps as a point crosses a cell face
    /// jumps the acceleration, which the jerk shows as a spike.
    pub jerk_rms: [f64; 2],
    pub jerk_max: [f64; 2],
}

/// The motion nearest and trilinear sampling give one scene (f64 CPU reference).
#[derive(Clone, Debug)]
pub struct SamplingReport {
    pub strips: Vec<SamplingStrip>,
    pub frames: u32,
    pub frame_time: f64,
    /// Per frame from frame 3 (the first with a third difference): (time in s, rms over
    /// strips of the tip jerk under [nearest, trilinear]).
    pub jerk_per_frame: Vec<(f64, [f64; 2])>,
    /// Wall time of `dynamics::simulate` per strip and step (ns), [nearest, trilinear].
    pub ns_per_strip_step: [f64; 2],
    /// Wall time of one `Eff::sample` at the clip's control points (ns), [nearest, trilinear].
    pub ns_per_sample: [f64; 2],
}

impl SamplingReport {
    /// (rms over strips of the per-strip value, largest) of `f` over `strips`.
    pub fn summary<'a>(
        strips: impl IntoIterator<Item = &'a SamplingStrip>,
        f: impl Fn(&SamplingStrip) -> (f64, f64),
    ) -> (f64, f64) {
        let (mut sq, mut max, mut n) = (0.0, 0.0f64, 0usize);
        for s in strips {
            let (r, m) = f(s);
            sq += r * r;
            max = max.max(m);
            n += 1;
        }
        ((sq / n.max(1) as f64).sqrt(), max)
    }

    /// rms over every strip of the tip jerk, [nearest, trilinear] (cm/s³).
    pub fn jerk_rms(&self) -> [f64; 2] {
        [0, 1].map(|i| Self::summary(&self.strips, |s| (s.jerk_rms[i], s.jerk_max[i])).0)
    }
}

/// Simulate `scene`'s strips for `frames` frames with the f64 reference under nearest and
/// under trilinear EFF sampling (the scene's forces, no key-frame edits) and compare the
/// tips' motion and smoothness; also time both samplings.
pub fn sampling_motion(scene: &Scene, frames: u32) -> Result<SamplingReport> {
    let Some(st) = scene.strips().as_ref() else {
        return Err(crate::KamiError::Invalid {
            file: String::new(),
            field: "strips".into(),
            value: "None".into(),
            allowed: "a scene with strips".into(),
        });
    };
    let forces = Forces::new(&scene.forces, &scene.head);
    let rest = hom::build(st, &scene.head)?;
    let samplings = [Sampling::Nearest, Sampling::Trilinear];
    let mut clips = Vec::new();
    let mut ns_per_strip_step = [0.0; 2];
    let spf = dynamics::steps_per_frame(&st.motion);
    for (i, &sampling) in samplings.iter().enumerate() {
        let motion = crate::systems::strips::block::Motion {
            sampling,
            ..st.motion.clone()
        };
        let t = Instant::now();
        let clip = dynamics::simulate(&rest, &motion, &forces, &scene.head, &[], frames)?;
        let steps = (frames as u64 * spf as u64 * rest.len().max(1) as u64).max(1);
        ns_per_strip_step[i] = t.elapsed().as_nanos() as f64 / steps as f64;
        clips.push(clip);
    }
    let rig = dynamics::Rig::new(&rest, &st.motion)?;
    let stride = rig.stride();
    let ft = st.motion.frame_time;
    let tip = |c: usize, s: usize| -> Vec<DVec3> {
        clips[c]
            .iter()
            .map(|p| p[s * stride + stride - 1])
            .collect()
    };
    // Third difference per frame from frame 3, cm/s³.
    let jerk = |x: &[DVec3]| -> Vec<f64> {
        x.windows(4)
            .map(|w| ((w[3] - 3.0 * w[2] + 3.0 * w[1] - w[0]) / ft.powi(3)).length())
            .collect()
    };
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let mut strips = Vec::new();
    let mut jerks: [Vec<Vec<f64>>; 2] = [Vec::new(), Vec::new()];
    for (s, r) in rest.iter().enumerate() {
        let (a, b) = (tip(0, s), tip(1, s));
        let d: Vec<f64> = a.iter().zip(&b).map(|(p, q)| (*p - *q).length()).collect();
        let j = [jerk(&a), jerk(&b)];
        let settled =
            |v: &[f64]| v[(SETTLE_FRAMES as usize).saturating_sub(3).min(v.len())..].to_vec();
        let js = [settled(&j[0]), settled(&j[1])];
        strips.push(SamplingStrip {
            layer: r.layer as usize,
            length: rig.length(s),
            rms: rms(&d),
            max: max(&d),
            jerk_rms: [rms(&js[0]), rms(&js[1])],
            jerk_max: [max(&js[0]), max(&js[1])],
        });
        let [j0, j1] = j;
        jerks[0].push(j0);
        jerks[1].push(j1);
    }
    let jerk_per_frame = (0..frames.saturating_sub(2) as usize)
        .map(|f| {
            let at = |i: usize| rms(&jerks[i].iter().map(|j| j[f]).collect::<Vec<_>>());
            ((f + 3) as f64 * ft, [at(0), at(1)])
        })
        .collect();
    // Sampling cost alone: every control point of the clip, several passes.
    let mut ns_per_sample = [0.0; 2];
    if let Some(eff) = forces.eff.as_ref() {
        let points: Vec<DVec3> = clips[0].iter().flatten().copied().collect();
        for (i, &sampling) in samplings.iter().enumerate() {
            let passes = 5;
            let t = Instant::now();
            let mut sum = DVec3::ZERO;
            for _ in 0..passes {
                for &p in &points {
                    sum += eff.sample(std::hint::black_box(p), sampling);
                }
            }
            std::hint::black_box(sum);
            ns_per_sample[i] =
                t.elapsed().as_nanos() as f64 / (passes * points.len()).max(1) as f64;
        }
    }
    Ok(SamplingReport {
        strips,
        frames,
        frame_time: ft,
        jerk_per_frame,
        ns_per_strip_step,
        ns_per_sample,
    })
}

/// The sampling section of strips.md, strips_sampling.csv (a row per strip) and its plot.
fn sampling_section(
    scene: &Scene,
    scene_path: &Path,
) -> Result<(String, String, image::RgbaImage)> {
    let r = sampling_motion(scene, SAMPLING_FRAMES)?;
    let names: Vec<String> = scene
        .strips()
        .as_ref()
        .map(|st| st.layers.iter().map(|l| l.name.clone()).collect())
        .unwrap_or_default();
    let mut md = String::new();
    let mut csv = String::from(
        "strip,layer,length,tip_distance_rms,tip_distance_max,tip_distance_rms_rel,tip_distance_max_rel,jerk_rms_nearest,jerk_rms_trilinear,jerk_max_nearest,jerk_max_trilinear\n",
    );
    writeln!(
        md,
        "## EFF sampling: nearest against trilinear\n\n`{}` ({} strips, its EFF file and gust \
         keys, no key-frame edits), {} frames ({:.2} s), simulated twice with the f64 \
         reference: control points reading the EFF's cell (nearest) and between the eight \
         cell centres around them (trilinear). Tip distance: between the two motions' tips, \
         rms and largest over the frames, in cm and relative to the strip's length. Jerk: the \
         tip's third difference over frames divided by the frame time cubed (cm/s³), rms and \
         largest over frames {} to {} (before, the strips settle from their rest shape under \
         gravity alike in both); per layer, the rms over its strips of the per-strip rms and \
         the largest of the largest. Per strip: `strips_sampling.csv`; rms jerk per frame: \
         `strips_sampling.png`.\n",
        scene_path.display(),
        r.strips.len(),
        r.frames,
        r.frames as f64 * r.frame_time,
        SETTLE_FRAMES,
        r.frames
    )
    .ok();
    writeln!(
        md,
        "| layer | strips | tip distance rms (cm) | max (cm) | rms / length | max / length | jerk rms nearest | jerk rms trilinear | jerk max nearest | jerk max trilinear |"
    )
    .ok();
    writeln!(md, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|").ok();
    let row = |md: &mut String, name: &str, group: &[&SamplingStrip]| {
        let d = SamplingReport::summary(group.iter().copied(), |s| (s.rms, s.max));
        let rel = SamplingReport::summary(group.iter().copied(), |s| {
            (s.rms / s.length, s.max / s.length)
        });
        let j = [0, 1].map(|i| {
            SamplingReport::summary(group.iter().copied(), |s| (s.jerk_rms[i], s.jerk_max[i]))
        });
        writeln!(
            md,
            "| {name} | {} | {:.3} | {:.3} | {:.4} | {:.4} | {:.0} | {:.0} | {:.0} | {:.0} |",
            group.len(),
            d.0,
            d.1,
            rel.0,
            rel.1,
            j[0].0,
            j[1].0,
            j[0].1,
            j[1].1
        )
        .ok();
    };
    for (l, name) in names.iter().enumerate() {
        let group: Vec<&SamplingStrip> = r.strips.iter().filter(|s| s.layer == l).collect();
        if !group.is_empty() {
            row(&mut md, name, &group);
        }
    }
    let all: Vec<&SamplingStrip> = r.strips.iter().collect();
    row(&mut md, "all", &all);
    for (i, s) in r.strips.iter().enumerate() {
        writeln!(
            csv,
            "{i},{},{:.4},{:.6},{:.6},{:.6e},{:.6e},{:.3},{:.3},{:.3},{:.3}",
            names.get(s.layer).map_or("", |n| n.as_str()),
            s.length,
            s.rms,
            s.max,
            s.rms / s.length,
            s.max / s.length,
            s.jerk_rms[0],
            s.jerk_rms[1],
            s.jerk_max[0],
            s.jerk_max[1]
        )
        .ok();
    }
    let jr = r.jerk_rms();
    let smoother = r
        .strips
        .iter()
        .filter(|s| s.jerk_rms[1] < s.jerk_rms[0])
        .count();
    writeln!(md).ok();
    writeln!(
        md,
        "- Tip jerk, rms over every strip and the frames from {SETTLE_FRAMES}: trilinear {:.3} of nearest's; trilinear's \
         is the smaller on {smoother} of {} strips.",
        jr[1] / jr[0].max(1e-300),
        r.strips.len()
    )
    .ok();
    writeln!(
        md,
        "- Cost: {:.1} ns per EFF sample nearest, {:.1} ns trilinear (the clip's control \
         points, f64 CPU); the whole f64 step {:.0} ns per strip-step nearest, {:.0} ns \
         trilinear.",
        r.ns_per_sample[0], r.ns_per_sample[1], r.ns_per_strip_step[0], r.ns_per_strip_step[1]
    )
    .ok();
    writeln!(
        md,
        "\nThe tip distance is how far the choice of sampling moves the hair; the jerk is how \
         rough each motion is: nearest sampling makes the force jump as a control point \
         crosses a cell face, which jerks the tip, while trilinear's force changes \
         continuously with position.\n"
    )
    .ok();
    let plot = plot::loglog(
        "Strips: tip jerk against time, nearest and trilinear EFF",
        "time (s)",
        "tip jerk, rms over strips (cm/s^3)",
        &[
            Series {
                name: "nearest".into(),
                color: plot::palette(3),
                points: r.jerk_per_frame.iter().map(|(t, j)| (*t, j[0])).collect(),
            },
            Series {
                name: "trilinear".into(),
                color: plot::palette(0),
                points: r.jerk_per_frame.iter().map(|(t, j)| (*t, j[1])).collect(),
            },
        ],
        None,
    );
    Ok((md, csv, plot))
}
