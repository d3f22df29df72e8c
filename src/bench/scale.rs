//! `kami bench scale`: what each pass of a frame costs as the groom grows. The gust scene's
//! groups are scaled to each strand count and re-segmented to each segment count (the hair
//! length stays), and each point is simulated and drawn through the stage at the chosen
//! size. Times come from GPU timestamp queries around each phase (`gpu::timing`) where the
//! adapter has them; otherwise each phase is submitted alone and timed on the CPU around a
//! wait, and the report says so. The simulation's achieved memory bandwidth is set against a
//! buffer copy measured the same way (the practical peak of this device).

use super::{cpu_name, provenance, Report};
use crate::error::{KamiError, Result};
use crate::gpu::timing::{GpuTimer, PassTimes, Phase};
use crate::gpu::Gpu;
use crate::stage::{self, target, Quality, Stage};
use crate::systems::anjyo::AnjyoSystem;
use crate::systems::Scene;
use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

/// What to sweep.
#[derive(Clone, Debug)]
pub struct Sweep {
    pub strands: Vec<u32>,
    pub segments: Vec<u32>,
    pub size: (u32, u32),
    /// Timed frames per point (after two warm-up frames).
    pub frames: u32,
    /// Points with more segments than this are skipped (and listed as skipped).
    pub max_segments: u64,
    /// Time on the CPU around waits even where timestamps exist (to check them).
    pub cpu_clock: bool,
    /// Anti-aliasing instead of the scene's: (MSAA samples, supersampling per axis).
    pub msaa: Option<u32>,
    pub supersample: Option<u32>,
}

/// Bytes the projective kernel moves per simulated segment and substep: the angle state
/// (vec4, read and written) and the node (vec4, read for the field lookups and written).
pub const BYTES_PER_SEGMENT: u64 = 64;
/// Per strand and substep: its 48-byte record and the root node written.
pub const BYTES_PER_STRAND: u64 = 64;

/// One measured point.
struct Point {
    strands: u64,
    segments: u32,
    total_segments: u64,
    /// Strands and segments the solver moves.
    sim_strands: u64,
    sim_segments: u64,
    substeps: f64,
    /// Median milliseconds per phase.
    phases: [Option<f64>; 5],
    /// The simulation alone on the CPU clock (timed runs only).
    sim_alone_ms: Option<f64>,
    /// The simulation time the costs use: the timestamps, or the CPU clock where they
    /// missed the compute work.
    sim_cost: Option<f64>,
    /// Rendering alone (generation, ribbons, resolve) on the CPU clock.
    ribbons_ms: f64,
    /// Rendering alone with the other rasterisers.
    alt: Rasterisers,
    /// The compute walk over every segment (`bench::splat`).
    probe: Option<super::splat::Probe>,
    frame_ms: f64,
    cpu_ms: f64,
}

/// The base scene with `strands` hairs over its groups (in their proportions) of `segments`
/// segments each.
pub fn scaled(base: &Scene, strands: u32, segments: u32) -> Result<Scene> {
    let mut s = base.clone();
    let total: u64 = s.groups().iter().map(|g| g.count as u64).sum();
    if total == 0 {
        return Err(KamiError::Invalid {
            file: String::new(),
            field: "groups".into(),
            value: "none".into(),
            allowed: "a scene with strand hair groups (e.g. assets/scenes/gust.ron)".into(),
        });
    }
    let n = s.groups().len() as u64;
    if (strands as u64) < n {
        return Err(KamiError::Invalid {
            file: String::new(),
            field: "--strands".into(),
            value: strands.to_string(),
            allowed: format!("at least {n}: one per hair group of the scene"),
        });
    }
    // Each group its share (at least one), the last group what is left.
    let mut left = strands as u64;
    for (i, g) in s.groups_mut().iter_mut().enumerate() {
        let after = n - i as u64 - 1;
        let c = if after == 0 {
            left
        } else {
            (strands as u64 * g.count as u64 / total).clamp(1, left - after)
        };
        g.count = c as u32;
        left -= c;
        g.segments = segments;
    }
    crate::systems::validate(&s)?;
    Ok(s)
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// Simulate and draw one point for the sweep's frames.
fn measure(gpu: &Gpu, scene: &Scene, sweep: &Sweep, timed: bool) -> Result<Point> {
    // The frame's phases with ribbons; the other rasterisers are timed after.
    let mut ribbon_scene = scene.clone();
    ribbon_scene.render.strands = crate::scene::StrandRaster::Ribbons;
    let scene = &ribbon_scene;
    let mut stage = Stage::new(gpu, scene, target::OUTPUT_FORMAT, Quality::of(scene))?;
    if timed {
        stage.enable_timing(gpu);
    }
    let out = target::Offscreen::new(gpu, sweep.size)?;
    let look = stage.look();
    let (strands, total_segments) = {
        let c = stage.stats();
        (c.strands, c.segments)
    };
    let (sim_strands, sim_segments) = stage
        .system::<AnjyoSystem>()
        .and_then(|a| a.sim.as_ref())
        .map_or((0, 0), |s| {
            (
                s.setup.strands.len() as u64,
                s.setup.strands.iter().map(|d| d.segments as u64).sum(),
            )
        });
    let mut samples: Vec<PassTimes> = Vec::new();
    let mut cpu = Vec::new();
    let mut substeps = 0u64;
    for f in 0..sweep.frames + 2 {
        let t = Instant::now();
        let mut times = PassTimes::default();
        if timed {
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            substeps += stage.advance(gpu, &mut enc, 1)?.substeps as u64 * u64::from(f >= 2);
            stage.render(gpu, &mut enc, &out.view, sweep.size, &look)?;
            let timer = stage.timer().expect("timing enabled");
            timer.clear();
            timer.finish(&mut enc);
            gpu.queue.submit([enc.finish()]);
            timer.submitted();
            if let Some(t) = timer.wait(gpu)? {
                times = t;
            }
        } else {
            // CPU-side fallback: each phase alone, timed around a wait.
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            substeps += stage.advance(gpu, &mut enc, 1)?.substeps as u64 * u64::from(f >= 2);
            gpu.queue.submit([enc.finish()]);
            gpu.wait()?;
            times.phases[Phase::Simulation as usize] = Some(t.elapsed().as_secs_f64() * 1e3);
            let t2 = Instant::now();
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            stage.render(gpu, &mut enc, &out.view, sweep.size, &look)?;
            gpu.queue.submit([enc.finish()]);
            gpu.wait()?;
            // Generation, draw and resolve together: without timestamps they are one wait.
            times.phases[Phase::Draw as usize] = Some(t2.elapsed().as_secs_f64() * 1e3);
            times.frame = Some(t.elapsed().as_secs_f64() * 1e3);
        }
        gpu.wait()?;
        if f >= 2 {
            cpu.push(t.elapsed().as_secs_f64() * 1e3);
            samples.push(times);
        }
    }
    // The simulation alone, timed on the CPU around a wait in its own submission: a check
    // on the timestamps (some software adapters write them before compute work finishes).
    let mut alone = Vec::new();
    if timed {
        for _ in 0..3 {
            alone.push(wall_ms(gpu, &mut stage, |stage, enc| {
                stage.advance(gpu, enc, 1).map(|_| ())
            })?);
        }
    }
    // How to draw: the ribbons alone (render only, CPU wall) beside the compute probe's
    // lower bound for a compute rasteriser (bench::splat).
    let mut ribbons = Vec::new();
    for _ in 0..3 {
        ribbons.push(wall_ms(gpu, &mut stage, |stage, enc| {
            stage.render(gpu, enc, &out.view, sweep.size, &look)
        })?);
    }
    let probe = super::splat::probe(gpu, &stage, sweep.size, 3)?;
    let alt = rasterisers_ms(gpu, &mut stage, scene, &out.view, sweep.size, &look)?;
    gpu.take_error()?;
    let mut phases = [None; 5];
    for p in Phase::ALL {
        phases[p as usize] = median(samples.iter().filter_map(|s| s.get(p)).collect());
    }
    Ok(Point {
        strands,
        segments: scene.groups().first().map_or(0, |g| g.segments),
        total_segments,
        sim_strands,
        sim_segments,
        substeps: substeps as f64 / sweep.frames.max(1) as f64,
        phases,
        sim_alone_ms: median(alone),
        sim_cost: None,
        ribbons_ms: median(ribbons).unwrap_or(f64::NAN),
        alt,
        probe,
        frame_ms: median(samples.iter().filter_map(|s| s.frame).collect()).unwrap_or(f64::NAN),
        cpu_ms: median(cpu).unwrap_or(f64::NAN),
    })
}

/// CPU wall milliseconds of what `record` records, submitted alone and waited for (the
/// stage's timer, if on, is finished so its marks do not leak into the next frame).
fn wall_ms(
    gpu: &Gpu,
    stage: &mut Stage,
    record: impl FnOnce(&mut Stage, &mut wgpu::CommandEncoder) -> Result<()>,
) -> Result<f64> {
    let t = Instant::now();
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    record(stage, &mut enc)?;
    if let Some(tm) = stage.timer() {
        tm.finish(&mut enc);
    }
    gpu.queue.submit([enc.finish()]);
    if let Some(tm) = stage.timer() {
        tm.submitted();
    }
    gpu.wait()?;
    Ok(t.elapsed().as_secs_f64() * 1e3)
}

/// The least milliseconds of `runs` submissions of what `record` records: between
/// timestamps where `timed`, else around a wait.
fn best_ms(
    gpu: &Gpu,
    timed: bool,
    runs: u32,
    record: impl Fn(&mut wgpu::CommandEncoder),
) -> Result<f64> {
    let mut timer = if timed { GpuTimer::new(gpu) } else { None };
    let mut best = f64::INFINITY;
    for _ in 0..runs {
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        let t = Instant::now();
        if let Some(tm) = timer.as_mut() {
            tm.clear();
            tm.begin(&mut enc, Phase::Simulation);
        }
        record(&mut enc);
        if let Some(tm) = timer.as_mut() {
            tm.end(&mut enc, Phase::Simulation);
            tm.finish(&mut enc);
        }
        gpu.queue.submit([enc.finish()]);
        let ms = match timer.as_mut() {
            Some(tm) => {
                tm.submitted();
                tm.wait(gpu)?
                    .and_then(|t| t.get(Phase::Simulation))
                    .unwrap_or(f64::NAN)
            }
            None => {
                gpu.wait()?;
                t.elapsed().as_secs_f64() * 1e3
            }
        };
        best = best.min(ms);
    }
    Ok(best)
}

/// Copy bandwidth of this device (bytes read + written per second): a large buffer copied
/// into another, timed the same way as the passes.
fn copy_bandwidth(gpu: &Gpu, timed: bool, bytes: u64) -> Result<f64> {
    let bytes = bytes.min(gpu.device.limits().max_buffer_size);
    let make = |usage| {
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("bandwidth probe"),
            size: bytes,
            usage,
            mapped_at_creation: false,
        })
    };
    let src = make(wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST);
    let dst = make(wgpu::BufferUsages::COPY_DST);
    // Touch the source once so the copy reads real pages.
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    enc.clear_buffer(&src, 0, None);
    gpu.queue.submit([enc.finish()]);
    gpu.wait()?;
    let ms = best_ms(gpu, timed, 5, |enc| {
        enc.copy_buffer_to_buffer(&src, 0, &dst, 0, bytes)
    })?;
    Ok(2.0 * bytes as f64 / (ms * 1e-3))
}

/// Streaming bandwidth of this device through the shader cores (bytes read + written per
/// second): `shaders/stage/bandwidth.wgsl` copies a large buffer one vec4 per invocation,
/// timed the same way as the passes. The simulation's kernels move their data this way; a
/// buffer-to-buffer copy may not reach it (on the H200 the copy read 850 GB/s while the
/// simulation moved 1.9 TB/s).
fn stream_bandwidth(gpu: &Gpu, timed: bool, bytes: u64) -> Result<f64> {
    let lim = gpu.device.limits();
    let bytes = (bytes
        .min(lim.max_buffer_size)
        .min(lim.max_storage_buffer_binding_size))
        / 16
        * 16;
    let device = &gpu.device;
    let make = |usage| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("bandwidth probe"),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE | usage,
            mapped_at_creation: false,
        })
    };
    let src = make(wgpu::BufferUsages::COPY_DST);
    let dst = make(wgpu::BufferUsages::empty());
    let layout = crate::gpu::bind::layout(
        device,
        "bandwidth probe",
        wgpu::ShaderStages::COMPUTE,
        &[
            crate::gpu::bind::storage::<[f32; 4]>(),
            crate::gpu::bind::storage_rw::<[f32; 4]>(),
        ],
    );
    let module = crate::gpu::shader_module(device, "stage/bandwidth", crate::shaders::BANDWIDTH)?;
    let [pipeline] =
        crate::gpu::compute_pipelines(device, "bandwidth probe", &layout, &module, ["stream"], &[]);
    let group = crate::gpu::bind::buffers(device, "bandwidth probe", &layout, &[&src, &dst]);
    let groups = (bytes / 16).div_ceil(256);
    let x = groups.min(65_535) as u32;
    let y = groups.div_ceil(u64::from(x)) as u32;
    let mut enc = device.create_command_encoder(&Default::default());
    enc.clear_buffer(&src, 0, None);
    gpu.queue.submit([enc.finish()]);
    gpu.wait()?;
    let best = best_ms(gpu, timed, 6, |enc| {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(x, y, 1);
    })?;
    Ok(2.0 * bytes as f64 / (best * 1e-3))
}

fn opt(v: Option<f64>) -> String {
    v.map_or("—".into(), |x| format!("{x:.2}"))
}

/// Run the sweep over `base_path`'s scene; writes `scale.md`, `scale.csv` and `scale.png`.
pub fn run(gpu: &Gpu, base_path: &Path, sweep: &Sweep, out: &Path) -> Result<Report> {
    let base = load_base(base_path, sweep)?;
    let timed = !sweep.cpu_clock && GpuTimer::new(gpu).is_some();
    let software = gpu.info.device_type == wgpu::DeviceType::Cpu;
    let probe = if software { 64 << 20 } else { 1 << 30 };
    let copy = copy_bandwidth(gpu, timed, probe)?;
    let stream = stream_bandwidth(gpu, timed, probe)?;
    let peak = copy.max(stream);
    let clock = if timed {
        "GPU timestamp queries around each phase (`gpu::timing`); medians"
    } else {
        "**CPU-side** (no timestamp queries on this adapter, or `--cpu-clock`): each phase submitted alone and timed around a wait, so the figures include submission and wait overhead; generation, draw and resolve are one figure (in the draw column); medians"
    };
    let mut md = String::new();
    let mut csv = String::from("strands,segments_per_strand,total_segments,substeps_per_frame,simulation_ms,sim_alone_cpu_ms,generation_ms,draw_ms,resolve_ms,frame_ms,cpu_wall_ms,ns_per_segment_step,sim_gb_per_s,times_bandwidth_bound,clock\n");
    let _ = writeln!(md, "### `kami bench scale` — {}\n", base_path.display());
    let _ = writeln!(md, "{}\n", provenance());
    let _ = writeln!(
        md,
        "Adapter: **{}** ({:?}); CPU: {}. Image {}x{}, the scene's own anti-aliasing (MSAA {}, supersampling {}). Each point: 2 warm-up frames, then {} frames of one simulated frame plus one drawn frame each. Clock: {clock}.\n",
        gpu.describe(),
        gpu.info.device_type,
        cpu_name(),
        sweep.size.0,
        sweep.size.1,
        base.render.msaa,
        base.render.supersample,
        sweep.frames
    );
    let _ = writeln!(
        md,
        "Bandwidth of this device (bytes read + written, {} MiB buffers): a vec4 streaming kernel (`shaders/stage/bandwidth.wgsl`) **{:.1} GB/s**, a buffer-to-buffer copy {:.1} GB/s; the bound is the faster, **{:.1} GB/s**. The simulation moves {BYTES_PER_SEGMENT} bytes per segment and substep and {BYTES_PER_STRAND} per strand and substep; \"× bound\" is the simulation time over the time those bytes take at the bound (1 = memory-bound optimum; below 1 the probe is no bound, and the report says so under the table).\n",
        probe >> 20,
        stream * 1e-9,
        copy * 1e-9,
        peak * 1e-9
    );
    let _ = writeln!(md, "| strands | segments/strand | segments | substeps/frame | simulation ms | sim alone, CPU wall ms | generation ms | draw ms | resolve ms | frame ms (GPU) | frame ms (CPU wall) | ns/segment-step | sim GB/s | × bound |");
    let _ = writeln!(
        md,
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    let mut points = Vec::new();
    let mut skipped = Vec::new();
    let mut suspect = false;
    // Points whose simulation moved its bytes faster than the probe (× bound below 1).
    let mut beaten: Vec<String> = Vec::new();
    for &k in &sweep.segments {
        for &n in &sweep.strands {
            let total = n as u64 * k as u64;
            if total > sweep.max_segments {
                skipped.push(format!(
                    "{n} × {k} ({total} segments > --max-segments {})",
                    sweep.max_segments
                ));
                continue;
            }
            let scene = scaled(&base, n, k)?;
            if let Err(e) = stage::check_limits(gpu, &scene, sweep.size) {
                skipped.push(format!("{n} × {k}: {e}"));
                continue;
            }
            eprintln!("scale: {n} strands x {k} segments");
            let mut p = measure(gpu, &scene, sweep, timed)?;
            let (missed, gbs, bound) = point_row(&mut p, peak, timed, &mut md, &mut csv);
            suspect |= missed;
            if bound < 1.0 {
                beaten.push(format!("{n} × {k} ({gbs:.0} GB/s)"));
            }
            points.push(p);
        }
    }
    sweep_notes(&mut md, &beaten, suspect, &skipped);
    render_vs_walk(&mut md, &points);
    let series = scale_series(sweep, &points);
    super::write_report(out, "scale", &md, &csv)?;
    let plot = crate::bench::plot::loglog(
        "FRAME AND SIMULATION TIME VS STRANDS",
        "STRANDS",
        "MS PER FRAME",
        &series,
        None,
    );
    let png = out.join("scale.png");
    plot.save(&png).map_err(|e| KamiError::Image {
        path: png.clone(),
        message: e.to_string(),
    })?;
    Ok(Report { markdown: md, csv })
}

/// The base scene with the sweep's anti-aliasing, refused unless it has dynamic strand hair.
fn load_base(base_path: &Path, sweep: &Sweep) -> Result<Scene> {
    let mut base = Scene::load(base_path)?;
    if let Some(m) = sweep.msaa {
        base.render.msaa = m;
    }
    if let Some(f) = sweep.supersample {
        base.render.supersample = f;
    }
    crate::systems::validate(&base)?;
    if base.dynamics().is_none() || !base.groups().iter().any(|g| g.dynamic) {
        return Err(KamiError::Invalid {
            file: base_path.display().to_string(),
            field: "dynamics".into(),
            value: "none".into(),
            allowed: "a scene with dynamic strand hair (e.g. assets/scenes/gust.ron)".into(),
        });
    }
    Ok(base)
}

/// One point's table and CSV rows, its simulation costed by the timestamps or, where they
/// missed the compute work, by the CPU clock (into `p.sim_cost`); returns (whether the
/// timestamps missed, simulation GB/s, × bound).
fn point_row(
    p: &mut Point,
    peak: f64,
    timed: bool,
    md: &mut String,
    csv: &mut String,
) -> (bool, f64, f64) {
    let sim = p.phases[Phase::Simulation as usize];
    let bytes = (p.sim_segments * BYTES_PER_SEGMENT + p.sim_strands * BYTES_PER_STRAND) as f64;
    // Where the timestamps miss the compute work, cost the simulation by the CPU clock.
    let missed = matches!((sim, p.sim_alone_ms), (Some(ts), Some(cpu)) if cpu > 3.0 * ts + 1.0);
    let sim_cost = if missed { p.sim_alone_ms } else { sim };
    p.sim_cost = sim_cost;
    let (ns, gbs, bound) = match sim_cost {
        Some(ms) if p.substeps > 0.0 => {
            let per_sub = ms * 1e-3 / p.substeps;
            (
                per_sub * 1e9 / p.sim_segments.max(1) as f64,
                bytes / per_sub * 1e-9,
                per_sub / (bytes / peak),
            )
        }
        _ => (f64::NAN, f64::NAN, f64::NAN),
    };
    let ph = |q: Phase| p.phases[q as usize];
    let _ = writeln!(
        md,
        "| {} | {} | {} | {:.1} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {ns:.2} | {gbs:.1} | {bound:.1} |",
        p.strands,
        p.segments,
        p.total_segments,
        p.substeps,
        opt(sim),
        opt(p.sim_alone_ms),
        opt(ph(Phase::Generation)),
        opt(ph(Phase::Draw)),
        opt(ph(Phase::Resolve)),
        p.frame_ms,
        p.cpu_ms
    );
    let c = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:.4}"));
    let _ = writeln!(
        csv,
        "{},{},{},{:.2},{},{},{},{},{},{:.4},{:.4},{ns:.3},{gbs:.3},{bound:.3},{}",
        p.strands,
        p.segments,
        p.total_segments,
        p.substeps,
        c(sim),
        c(p.sim_alone_ms),
        c(ph(Phase::Generation)),
        c(ph(Phase::Draw)),
        c(ph(Phase::Resolve)),
        p.frame_ms,
        p.cpu_ms,
        if timed { "gpu-timestamps" } else { "cpu-wait" }
    );
    (missed, gbs, bound)
}

/// The notes under the table: points that beat the bandwidth probe, timestamps that missed
/// compute work, skipped points.
fn sweep_notes(md: &mut String, beaten: &[String], suspect: bool, skipped: &[String]) {
    if beaten.is_empty() {
        let _ = writeln!(
            md,
            "\nEvery point's simulation moved its bytes no faster than the bound (× bound at least 1)."
        );
    } else {
        let _ = writeln!(
            md,
            "\n**The probe is no bound on {} point(s)**: {} moved bytes faster than it (their data partly stay in the GPU's caches between substeps).",
            beaten.len(),
            beaten.join(", ")
        );
    }
    if suspect {
        let _ = writeln!(md, "\n**The timestamps miss compute work on this adapter**: the simulation alone on the CPU clock took more than 3× (+1 ms) its timestamp pair on some point, so the simulation's time went into a later phase. On those points ns/segment-step, GB/s and × bound use the CPU column; the GPU frame total is still right.");
    }
    if !skipped.is_empty() {
        let _ = writeln!(md, "\nSkipped: {}.", skipped.join("; "));
    }
}

/// Rendering alone (CPU wall around a wait, median of 3 after one untimed) with the other
/// rasterisers; NaN where one cannot run over these targets.
struct Rasterisers {
    /// Ribbons without MSAA.
    ribbons_msaa1: f64,
    /// The compute rasteriser binned by tile, and walked per strand.
    compute: [f64; 2],
    /// `render.strands: Auto`, and whether it chose the compute rasteriser.
    auto: f64,
    auto_compute: bool,
}

/// Time `render.strands` set to each rasteriser on `stage` in place (a redraw: the groom
/// and its motion stay), then back to `scene`.
fn rasterisers_ms(
    gpu: &Gpu,
    stage: &mut Stage,
    scene: &Scene,
    view: &wgpu::TextureView,
    size: (u32, u32),
    look: &crate::stage::Look,
) -> Result<Rasterisers> {
    use crate::scene::StrandRaster;
    let render_ms = |stage: &mut Stage| -> Result<f64> {
        let mut runs = Vec::new();
        for _ in 0..4 {
            runs.push(wall_ms(gpu, stage, |stage, enc| {
                stage.render(gpu, enc, view, size, look)
            })?);
        }
        // The first run makes the pipelines and targets.
        runs.remove(0);
        Ok(median(runs).unwrap_or(f64::NAN))
    };
    let with = |strands| {
        let mut s = scene.clone();
        s.render.strands = strands;
        s
    };
    let quality = stage.quality;
    stage.set_quality(gpu, Quality { msaa: 1, ..quality });
    let ribbons_msaa1 = render_ms(stage)?;
    stage.set_quality(gpu, quality);
    stage.apply(gpu, &with(StrandRaster::Compute))?;
    let mut compute = [f64::NAN; 2];
    if stage.systems().iter().any(|s| s.splats()) {
        for (i, binned) in [true, false].into_iter().enumerate() {
            if let Some(a) = stage.system_mut::<AnjyoSystem>() {
                a.set_binned(binned);
            }
            compute[i] = render_ms(stage)?;
        }
    }
    stage.apply(gpu, &with(StrandRaster::Auto))?;
    let auto = render_ms(stage)?;
    let auto_compute = stage.systems().iter().any(|s| s.splats());
    stage.apply(gpu, scene)?;
    Ok(Rasterisers {
        ribbons_msaa1,
        compute,
        auto,
        auto_compute,
    })
}

/// How to draw thin strands: rendering alone beside the compute walk's lower bound.
fn render_vs_walk(md: &mut String, points: &[Point]) {
    let _ = writeln!(md, "\n**How to draw thin strands** (issue 12, item 6: measure before choosing). Rendering alone (generation, the triangle-strip ribbons, resolve; CPU wall around a wait) beside `bench::splat`: a compute pass that only walks every segment across the pixels it crosses and counts them (no depth, shading or coverage), the lower bound of a compute rasteriser at this size.\n");
    let _ = writeln!(md, "Beside them, rendering alone with the other rasterisers: ribbons without MSAA, the compute rasteriser (`render.strands: Compute`) binned by screen tile and walked one invocation per strand (the same image word for word), and `render.strands: Auto` (the default: compute up to the strand width `kami bench raster` measured it to win, ribbons past it; which one it chose in brackets). *× walk*: each against the walk.\n");
    let _ = writeln!(md, "| strands | segments/strand | ribbons ms (scene MSAA) | ribbons MSAA 1 ms | compute binned ms | compute per strand ms | Auto ms | compute walk ms | pixel steps | ribbons × walk | per strand × walk | Auto × walk |");
    let _ = writeln!(
        md,
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    );
    for p in points {
        if let Some(pr) = &p.probe {
            let a = &p.alt;
            let _ = writeln!(
                md,
                "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} ({}) | {:.2} | {} | {:.1} | {:.1} | {:.1} |",
                p.strands,
                p.segments,
                p.ribbons_ms,
                a.ribbons_msaa1,
                a.compute[0],
                a.compute[1],
                a.auto,
                if a.auto_compute { "compute" } else { "ribbons" },
                pr.ms,
                pr.pixel_steps,
                p.ribbons_ms / pr.ms,
                a.compute[1] / pr.ms,
                a.auto / pr.ms
            );
        }
    }
}

/// The plot's series: frame and simulation time against strands, per segment count.
fn scale_series(sweep: &Sweep, points: &[Point]) -> Vec<crate::bench::plot::Series> {
    let mut series = Vec::new();
    for (i, &k) in sweep.segments.iter().enumerate() {
        let pts: Vec<&Point> = points.iter().filter(|p| p.segments == k).collect();
        if pts.is_empty() {
            continue;
        }
        series.push(crate::bench::plot::Series {
            name: format!("FRAME K={k}"),
            color: crate::bench::plot::palette(i),
            points: pts.iter().map(|p| (p.strands as f64, p.frame_ms)).collect(),
        });
        series.push(crate::bench::plot::Series {
            name: format!("SIM K={k}"),
            color: crate::bench::plot::palette(i + 5),
            points: pts
                .iter()
                .filter_map(|p| p.sim_cost.map(|s| (p.strands as f64, s)))
                .collect(),
        });
    }
    series
}
