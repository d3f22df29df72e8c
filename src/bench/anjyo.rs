//! The Anjyo kind's studies: groom throughput and bending accuracy against the exact elastica
//! (`groom`), the dynamics against the f64 reference and the pendulum (`dynamics`,
//! `pendulum_periods`), and the step-size convergence (`convergence`).

use super::{cpu_name, provenance, time_mean, write_report, Report};
use crate::error::Result;
use crate::gpu::Gpu;
use crate::stage::{target, Quality, Stage};
use crate::systems::anjyo::block::Bending;
use crate::systems::anjyo::cantilever::{self, Beam};
use crate::systems::anjyo::cantilever_gpu::CantileverPass;
use crate::systems::anjyo::elastica;
use crate::systems::anjyo::groom::prepare;
use crate::systems::Scene;
use glam::DVec3;
use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

/// The paper's hairstyle modelling time: "about 50 seconds" for about 20,000 hairs of at
/// most 20 segments (Anjyo et al. 1992, 4.2, SGI Iris Power Series).
pub const PAPER_GROOM_SECONDS: f64 = 50.0;
pub const PAPER_GROOM_HAIRS: f64 = 20_000.0;

/// Groom throughput (CPU reference, GPU kernel, both bending modes), what the converged mode
/// costs on this groom and how many of its strands fall back, render time per frame at
/// 1280x720, and the bending accuracy table against the exact elastica; writes `groom.md`
/// and `groom.csv` to `out`.
pub fn groom(gpu: &Gpu, scene_path: &Path, frames: u32, out: &Path) -> Result<Report> {
    let scene = Scene::load(scene_path)?;
    let mut md = String::new();
    let mut csv =
        String::from("table,G,k,mode,tip_drop,exact,rel_error,iterations,us_per_strand\n");
    let (hairs, segs) = scene.counts();
    let _ = writeln!(md, "### `kami bench groom` — {}\n", scene_path.display());
    let _ = writeln!(md, "{}\n", provenance());
    let _ = writeln!(
        md,
        "Adapter: {}; CPU: {} ({} threads available; the reference runs on one).\n",
        gpu.describe(),
        cpu_name(),
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    );
    let _ = writeln!(md, "Scene: {hairs} hairs, {segs} segments.\n");
    let _ = writeln!(
        md,
        "| bending | solver | time (ms) | strands/s | segments/s | vs paper's 50 s / 20k hairs |"
    );
    let _ = writeln!(md, "|---|---|---:|---:|---:|---:|");

    // (GPU seconds, CPU fallbacks, GPU fallbacks) per bending mode.
    let mut modes = Vec::new();
    for (label, converged) in [("paper", false), ("converged", true)] {
        modes.push(groom_mode(
            gpu, &scene, label, converged, &mut md, &mut csv,
        )?);
    }
    let (paper, conv) = (modes[0], modes[1]);
    let _ = writeln!(
        md,
        "\n**The converged mode on this groom** costs {:.0}x the paper mode on the GPU; {:.1} % of its strands (CPU reference; GPU {:.1} %) do not converge and keep the paper's shape.",
        conv.0 / paper.0,
        100.0 * conv.1 as f64 / hairs as f64,
        100.0 * conv.2 as f64 / hairs as f64
    );
    let _ = writeln!(
        csv,
        "converged_vs_paper,,,gpu time ratio {:.2} fallbacks cpu {} gpu {} of {hairs},,,,,",
        conv.0 / paper.0,
        conv.1,
        conv.2
    );
    groom_render(gpu, &scene, frames, &mut md, &mut csv)?;
    groom_accuracy(&mut md, &mut csv);
    groom_fewest_segments(&mut md);
    write_report(out, "groom", &md, &csv)?;
    Ok(Report { markdown: md, csv })
}

/// One bending mode's throughput rows (CPU f64 reference and GPU kernel) and the largest
/// GPU-against-CPU node difference; returns (GPU seconds, CPU fallbacks, GPU fallbacks).
fn groom_mode(
    gpu: &Gpu,
    scene: &Scene,
    label: &str,
    converged: bool,
    md: &mut String,
    csv: &mut String,
) -> Result<(f64, usize, usize)> {
    let (hairs, segs) = scene.counts();
    let mut s = scene.clone();
    if converged {
        for g in s.groups_mut() {
            g.bending = Bending::Converged {
                max_iterations: 400,
                tolerance: 1e-5,
            };
        }
    }
    let input = prepare(&s)?;
    let t = Instant::now();
    let reference = cantilever::bend_all(&input);
    let cpu = t.elapsed().as_secs_f64();

    let strands = input.strand_buffers(gpu)?;
    let world = crate::systems::world::WorldGpu::of_scene(gpu, &s)?;
    let pass = CantileverPass::new(gpu, &world)?;
    let job = pass.prepare(gpu, &world, &input, &strands)?;
    let runs = if converged { 2 } else { 5 };
    let gpu_t = time_mean(runs, || {
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("bench groom"),
            });
        pass.dispatch(&mut enc, &job);
        gpu.queue.submit([enc.finish()]);
        gpu.wait()
    })?;
    // f32 GPU against f64 reference, relative to hair length.
    let verts = strands.read_vertices(gpu)?;
    let offsets = input.vertex_offsets();
    let mut worst = 0.0f64;
    for (i, r) in input.roots.iter().enumerate() {
        let len = r.seg_len * input.groups[r.group as usize].segments as f64;
        for (v, p) in verts
            .iter()
            .enumerate()
            .take(offsets[i + 1] as usize)
            .skip(offsets[i] as usize)
        {
            let g = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            worst = worst.max((g - reference.nodes[v]).length() / len);
        }
    }
    for (solver, secs) in [("CPU f64 reference", cpu), ("GPU kernel (f32)", gpu_t)] {
        let ratio = PAPER_GROOM_SECONDS * (hairs as f64 / PAPER_GROOM_HAIRS) / secs;
        let _ = writeln!(
            md,
            "| {label} | {solver} | {:.1} | {:.0} | {:.0} | {:.0}x faster |",
            secs * 1e3,
            hairs as f64 / secs,
            segs as f64 / secs,
            ratio
        );
        let _ = writeln!(
            csv,
            "throughput,,,{label} {solver},,,,,{:.3}",
            secs * 1e6 / hairs as f64
        );
    }
    let _ = writeln!(
        md,
        "| {label} | GPU vs CPU | max node difference {:.2e} of hair length | | | |",
        worst
    );
    let gpu_fallbacks = strands
        .read_strands(gpu)?
        .iter()
        .filter(|s| s.flags & 1 != 0)
        .count();
    Ok((gpu_t, reference.fallbacks as usize, gpu_fallbacks))
}

/// Render time per frame at 1280x720, one stage (one groom), the anti-aliasing switched as
/// the viewer does it.
fn groom_render(
    gpu: &Gpu,
    scene: &Scene,
    frames: u32,
    md: &mut String,
    csv: &mut String,
) -> Result<()> {
    let size = (1280, 720);
    let _ = writeln!(md, "\n| render 1280x720 | ms/frame | fps |");
    let _ = writeln!(md, "|---|---:|---:|");
    crate::stage::check_limits(gpu, scene, size)?;
    let mut stage = Stage::new(gpu, scene, target::OUTPUT_FORMAT, Quality::of(scene))?;
    let image = target::Offscreen::new(gpu, size)?;
    let look = stage.look();
    for (msaa, ss) in [(1, 1), (4, 1), (4, 2)] {
        stage.set_quality(gpu, Quality::new(msaa, ss));
        let secs = time_mean(frames, || {
            let mut enc = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("bench render"),
                });
            stage.render(gpu, &mut enc, &image.view, size, &look)?;
            gpu.queue.submit([enc.finish()]);
            gpu.wait()
        })?;
        let _ = writeln!(
            md,
            "| MSAA {msaa}, supersample {ss}x{ss} | {:.1} | {:.1} |",
            secs * 1e3,
            1.0 / secs
        );
        let _ = writeln!(csv, "render,,,msaa{msaa} ss{ss},,,,,{:.1}", secs * 1e6);
    }
    Ok(())
}

/// A unit-length beam clamped horizontally at the origin, of `k` segments, unit rigidity.
fn unit_beam(k: u32, load: &dyn Fn(DVec3, DVec3) -> DVec3) -> Beam<'_> {
    Beam {
        root: DVec3::ZERO,
        dir: DVec3::X,
        seg_len: 1.0 / k as f64,
        segments: k,
        rigidity: 1.0,
        load,
        hull: None,
    }
}

/// Accuracy against the elastica: the tip drop of both bending modes against the exact
/// heavy cantilever, over G and the segment count.
fn groom_accuracy(md: &mut String, csv: &mut String) {
    let _ = writeln!(md, "\n**Tip drop against the exact heavy cantilever** (clamped horizontally, G = wL^3/EI; relative error of the tip drop; the paper mode's own limit is an EI of 2EI, shown as `paper vs G/2`).\n");
    let _ = writeln!(md, "| G | exact drop/L | k | paper | paper vs G/2 | converged | iterations | CPU µs/strand (conv.) |");
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|");
    for g in [0.1, 1.0, 10.0, 100.0, 1000.0] {
        let exact = elastica::tip_drop(g);
        let half = elastica::tip_drop(g / 2.0);
        for k in [5u32, 10, 20, 40, 80, 160] {
            let load = move |_: DVec3, _: DVec3| DVec3::new(0.0, -g, 0.0);
            let beam = unit_beam(k, &load);
            let paper = -cantilever::bend_paper(&beam).last().unwrap().y;
            let t = Instant::now();
            let (nodes, info) = cantilever::bend_converged(&beam, 20_000, 1e-10);
            let us = t.elapsed().as_secs_f64() * 1e6;
            let conv = -nodes.last().unwrap().y;
            let e = |x: f64, r: f64| (x - r) / r;
            let _ = writeln!(
                md,
                "| {g} | {exact:.6} | {k} | {:+.2e} | {:+.2e} | {:+.2e} | {} | {us:.0} |",
                e(paper, exact),
                e(paper, half),
                e(conv, exact),
                info.iterations
            );
            let _ = writeln!(
                csv,
                "accuracy,{g},{k},paper,{paper},{exact},{},,",
                e(paper, exact)
            );
            let _ = writeln!(
                csv,
                "accuracy,{g},{k},converged,{conv},{exact},{},{},{us:.1}",
                e(conv, exact),
                info.iterations
            );
        }
    }
}

/// The converged mode's fewest segments for a 1 % tip error, per G.
fn groom_fewest_segments(md: &mut String) {
    let _ = writeln!(md, "\nConverged mode, fewest segments for 1 % tip error:\n");
    let _ = writeln!(md, "| G | k | error |");
    let _ = writeln!(md, "|---:|---:|---:|");
    for g in [0.1, 1.0, 10.0, 100.0, 1000.0] {
        let exact = elastica::tip_drop(g);
        let mut found = None;
        for k in 1..=200u32 {
            let load = move |_: DVec3, _: DVec3| DVec3::new(0.0, -g, 0.0);
            let beam = unit_beam(k, &load);
            let (nodes, _) = cantilever::bend_converged(&beam, 20_000, 1e-10);
            let err = (-nodes.last().unwrap().y - exact).abs() / exact;
            if err <= 0.01 {
                found = Some((k, err));
                break;
            }
        }
        match found {
            Some((k, err)) => {
                let _ = writeln!(md, "| {g} | {k} | {err:.2e} |");
            }
            None => {
                let _ = writeln!(md, "| {g} | >200 | |");
            }
        }
    }
}

/// Complete elliptic integral of the first kind K(m = k^2), by the arithmetic-geometric mean.
pub fn elliptic_k(k: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, (1.0 - k * k).sqrt());
    for _ in 0..60 {
        let (an, bn) = (0.5 * (a + b), (a * b).sqrt());
        a = an;
        b = bn;
        if (a - b).abs() < 1e-16 {
            break;
        }
    }
    std::f64::consts::PI / (2.0 * a)
}

/// A one-segment strand is a rigid pendulum: with F = (0, -1, 0), d = rho = 1 its angle from
/// the vertical follows psi'' = -c u sin psi, c u = 3/2. Released at rest from `amplitude`
/// (radians), returns (the period measured from the simulation with step `dt`, the exact
/// period 4 K(sin(amplitude/2)) / omega0).
pub fn pendulum_periods(amplitude: f64, dt: f64) -> (f64, f64) {
    use crate::systems::anjyo::projective::{CpuSim, DynSetup, DynStrand};
    let params = crate::systems::anjyo::block::Dynamics {
        dt,
        collision: false,
        ..Default::default()
    };
    let strand = DynStrand {
        strand: 0,
        first_vertex: 0,
        state_offset: 0,
        segments: 1,
        seg_len: 1.0,
        root_local: DVec3::ZERO,
        scalp: 1.0,
    };
    let mut setup = DynSetup {
        forces: crate::forces::Forces {
            gravity: DVec3::new(0.0, -1.0, 0.0),
            wind: Vec::new(),
            head_motion: Vec::new(),
            center: DVec3::ZERO,
            eff: None,
        },
        params,
        // Far away: no contact.
        head: crate::scene::hull::HeadHull::Ellipsoid(crate::scene::Ellipsoid::new(
            [1e6, 0.0, 0.0],
            [1.0, 1.0, 1.0],
        )),
        strands: vec![strand],
        state_len: 2,
        max_cu: 0.0,
        seed: 0,
    };
    setup.update_max_cu();
    let omega0 = setup.max_cu.sqrt();
    let theta0 = std::f64::consts::PI - amplitude;
    let nodes = vec![DVec3::ZERO, DVec3::new(theta0.sin(), theta0.cos(), 0.0)];
    let mut sim = CpuSim::new(setup, nodes);
    // Angle from the downward vertical, signed.
    let psi = |sim: &CpuSim| sim.nodes[1].x.atan2(-sim.nodes[1].y);
    let mut crossings = Vec::new();
    let mut prev = psi(&sim);
    let mut t = 0.0;
    let exact = 4.0 * elliptic_k((0.5 * amplitude).sin()) / omega0;
    while crossings.len() < 3 && t < 20.0 * exact {
        sim.step();
        t += dt;
        let now = psi(&sim);
        if prev > 0.0 && now <= 0.0 {
            crossings.push(t - dt * now / (now - prev));
        }
        prev = now;
    }
    let measured = if crossings.len() >= 3 {
        crossings[2] - crossings[1]
    } else {
        f64::NAN
    };
    (measured, exact)
}

// ---------------------------------------------------------------------------------------
// Dynamics: speed against error

use crate::scene::{HeadKey, Interp, WindKey};
use crate::systems::anjyo::block::Roots;
use crate::systems::anjyo::projective::{step_forces, CpuSim, DynSetup};
use crate::systems::anjyo::AnjyoSystem;

/// Simulated time of every run, and the frame length the sweep is built on.
const T_END: f64 = 3.2;
const FRAME_TIME: f64 = 0.4;
/// Reference: steps per frame of the f64 run taken as the truth (dt = 0.4/256 = 0.1/64).
const REF_SPF: u32 = 256;
const SWEEP_SPF: [u32; 6] = [1, 2, 4, 8, 16, 32];

/// Re-time a scene written for 0.1-long frames to `FRAME_TIME` frames of `spf` steps: keys
/// keep their simulated time.
fn retime(scene: &Scene, spf: u32, frame_time: f64) -> Scene {
    let mut s = scene.clone();
    let d = s.dynamics().as_ref().expect("a dynamic scene");
    let old = d.dt * d.steps_per_frame as f64;
    let k = old / frame_time;
    for w in &mut s.forces.wind {
        w.frame *= k;
    }
    for h in &mut s.forces.head_motion {
        h.frame *= k;
    }
    let d = s.dynamics_mut().as_mut().expect("a dynamic scene");
    d.steps_per_frame = spf;
    d.dt = frame_time / spf as f64;
    s
}

/// The benchmark's configurations: the gust at four segment counts and the hard cases.
fn dynamic_cases(gust: &Scene) -> Vec<(String, Scene)> {
    let mut base = gust.clone();
    for g in base.groups_mut() {
        g.count = (g.count / 50).max(8);
    }
    let d = base.dynamics_mut().as_mut().unwrap();
    d.fluctuation = None;
    d.damping = 0.5;
    let mut cases = Vec::new();
    for k in [9u32, 18, 36, 72] {
        let mut s = base.clone();
        for g in s.groups_mut() {
            g.segments = (k * g.segments / 18).max(2);
        }
        cases.push((format!("GUST K={k}"), s));
    }
    let single = |theta: (f64, f64), wind: Vec<WindKey>, gravity: [f64; 3]| {
        let mut s = base.clone();
        s.groups_mut().truncate(1);
        let g = &mut s.groups_mut()[0];
        g.roots = Roots {
            theta,
            phi: (0.0, 360.0),
            on: None,
            hairline: None,
        };
        g.count = 150;
        g.segments = 18;
        g.length = 18.0;
        g.direction = crate::systems::anjyo::block::Direction::Normal;
        g.loads.clear();
        g.cuts.clear();
        s.forces.wind = wind;
        s.forces.gravity = gravity;
        s
    };
    let key = |frame: f64, force: [f64; 3]| WindKey {
        frame,
        force,
        interp: Interp::Step,
    };
    // Smooth: no contact, no clamps, no pole crossings, so the scheme's own order shows.
    let mut free = single(
        (60.0, 120.0),
        vec![key(0.0, [-60.0, 0.0, 40.0])],
        [0.0, -100.0, 0.0],
    );
    {
        let d = free.dynamics_mut().as_mut().unwrap();
        d.collision = false;
        d.pseudo_force = None;
        free.groups_mut()[0].roots.on = Some(crate::systems::anjyo::block::EllipsoidDesc {
            center: [0.0, 40.0, 0.0],
            radii: [2.0, 2.0, 2.0],
        });
        // Stiff groom: straight radial hair on the side the force leans to (azimuth 146
        // degrees), so no hair swings over a pole of the angle chart on its way.
        free.groups_mut()[0].rigidity = 1e6;
        free.groups_mut()[0].roots.phi = (121.0, 171.0);
    }
    cases.insert(0, ("FREE (NO CONTACT)".into(), free));
    cases.push((
        "HANGING".into(),
        single(
            (170.0, 180.0),
            vec![key(0.0, [0.0; 3]), key(8.0, [-150.0, 0.0, 80.0])],
            [0.0, -150.0, 0.0],
        ),
    ));
    cases.push((
        "CROWN".into(),
        single((0.0, 8.0), vec![key(0.0, [-200.0, 0.0, 0.0])], [0.0; 3]),
    ));
    let mut whip = base.clone();
    whip.forces.wind.clear();
    whip.forces.gravity = [0.0, -150.0, 0.0];
    whip.forces.head_motion = vec![
        HeadKey {
            frame: 0.0,
            rotate: [0.0; 3],
            translate: [0.0; 3],
            interp: Interp::Linear,
        },
        HeadKey {
            frame: 4.0,
            rotate: [0.0, 60.0, 0.0],
            translate: [0.0; 3],
            interp: Interp::Linear,
        },
        HeadKey {
            frame: 8.0,
            rotate: [0.0; 3],
            translate: [0.0; 3],
            interp: Interp::Linear,
        },
    ];
    cases.push(("HEAD WHIP".into(), whip));
    let mut steps = base.clone();
    steps.forces.wind = vec![
        key(0.0, [0.0, -100.0, 0.0]),
        key(5.0, [1e4, 0.0, 0.0]),
        key(15.0, [-1e4, -2e3, 0.0]),
    ];
    cases.push(("FORCE STEPS 1E4".into(), steps));
    cases
}

struct DynRun {
    nodes: Vec<DVec3>,
    tips: Vec<usize>,
    lengths: Vec<f64>,
    seconds: f64,
    segment_substeps: u64,
    strands: usize,
    clamped: u64,
}

fn run_cpu(scene: &Scene, frames: u32) -> Result<DynRun> {
    let input = prepare(scene)?;
    let groomed = cantilever::bend_all(&input);
    let setup = DynSetup::new(scene, &input, &groomed.visible).expect("dynamic scene");
    let tips = setup
        .strands
        .iter()
        .map(|s| (s.first_vertex + s.segments) as usize)
        .collect();
    let lengths = setup
        .strands
        .iter()
        .map(|s| s.seg_len * s.segments as f64)
        .collect();
    let strands = setup.strands.len();
    let mut sim = CpuSim::new(setup, groomed.nodes);
    let t = Instant::now();
    let mut clamped = 0;
    for _ in 0..frames {
        for _ in 0..sim.setup.params.steps_per_frame {
            clamped += sim.step().0.clamped;
        }
    }
    let seconds = t.elapsed().as_secs_f64();
    Ok(DynRun {
        nodes: sim.nodes,
        tips,
        lengths,
        seconds,
        segment_substeps: sim.segment_substeps,
        strands,
        clamped,
    })
}

/// (RMS node error, RMS tip error), relative to the mean hair length.
fn errors(run: &DynRun, reference: &DynRun) -> (f64, f64) {
    let len = run.lengths.iter().sum::<f64>() / run.lengths.len() as f64;
    let mut sum = 0.0;
    let mut n = 0usize;
    for (a, b) in run.nodes.iter().zip(&reference.nodes) {
        sum += (*a - *b).length_squared();
        n += 1;
    }
    let tip = run
        .tips
        .iter()
        .map(|&i| (run.nodes[i] - reference.nodes[i]).length_squared())
        .sum::<f64>();
    (
        (sum / n as f64).sqrt() / len,
        (tip / run.tips.len() as f64).sqrt() / len,
    )
}

/// Speed against error for the projective dynamics; writes `dynamics.md`, `dynamics.csv`
/// and `dynamics.png` into `out`.
pub fn dynamics(gpu: &Gpu, gust_path: &Path, out: &Path) -> Result<Report> {
    let gust = Scene::load(gust_path)?;
    require_dynamics(&gust, gust_path)?;
    let frames = (T_END / FRAME_TIME).round() as u32;
    let mut md = String::new();
    let mut csv = String::from("config,dt,steps,rms_error,tip_error,cpu_seconds,us_per_strand_per_time,ns_per_segment_step,clamped\n");
    let _ = writeln!(md, "### `kami bench dynamics` — {}\n", gust_path.display());
    let _ = writeln!(md, "{}\n", provenance());
    let _ = writeln!(
        md,
        "CPU: {} (one thread); adapter: {}.\n",
        cpu_name(),
        gpu.describe()
    );
    let _ = writeln!(md, "Error: RMS node-position error at t = {T_END} against the f64 solver at dt = {:.5} (0.1/64), relative to the hair length. Cost: CPU time per strand per unit of simulated time. Substeps for stability are included in the cost.\n", FRAME_TIME / REF_SPF as f64);
    let _ = writeln!(
        md,
        "| configuration | dt | RMS error | tip error | µs/strand/time | ns/segment-step |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|");
    let mut series = Vec::new();
    let mut summary = String::new();
    let _ = writeln!(summary, "\n| configuration | observed order in dt | largest dt without substeps (no clamp, error < 50 %) | Verlet limit 2/omega | cost to 1 % tip error |");
    let _ = writeln!(summary, "|---|---:|---:|---:|---:|");
    for (ci, (name, scene)) in dynamic_cases(&gust).into_iter().enumerate() {
        let reference = run_cpu(&retime(&scene, REF_SPF, FRAME_TIME), frames)?;
        let rows = dt_sweep(&name, &scene, &reference, frames, &mut md, &mut csv)?;
        let points = rows.iter().map(|r| (r.3, r.1)).collect();
        let order = observed_order(&rows);
        let largest = largest_stable_dt(&scene, &reference)?;
        let theory = verlet_limit(&scene)?;
        let to_one = rows
            .iter()
            .filter(|r| r.2 <= 0.01)
            .map(|r| r.3)
            .fold(f64::INFINITY, f64::min);
        let _ = writeln!(
            summary,
            "| {name} | {order:.2} | {} | {theory:.3} | {} |",
            largest.map_or("< 0.025".into(), |d| format!("{d}")),
            if to_one.is_finite() {
                format!("{to_one:.1} µs/strand/time")
            } else {
                "not reached".into()
            }
        );
        series.push(crate::bench::plot::Series {
            name: name.clone(),
            color: crate::bench::plot::palette(ci),
            points,
        });
    }
    md.push_str(&summary);
    dynamics_at_paper_size(gpu, &gust, gust_path, &mut md, &mut csv)?;
    pendulum_table(&mut md, &mut csv);
    write_dynamics(out, &md, &csv, &series)?;
    Ok(Report { markdown: md, csv })
}

/// One configuration's table rows over `SWEEP_SPF`, against its reference run.
fn dt_sweep(
    name: &str,
    scene: &Scene,
    reference: &DynRun,
    frames: u32,
    md: &mut String,
    csv: &mut String,
) -> Result<Vec<SweepRow>> {
    let mut rows = Vec::new();
    for spf in SWEEP_SPF {
        let s = retime(scene, spf, FRAME_TIME);
        let run = run_cpu(&s, frames)?;
        let (err, tip) = errors(&run, reference);
        let dt = FRAME_TIME / spf as f64;
        let cost = run.seconds * 1e6 / run.strands as f64 / T_END;
        let ns = run.seconds * 1e9 / run.segment_substeps as f64;
        let _ = writeln!(
            md,
            "| {name} | {dt:.4} | {err:.2e} | {tip:.2e} | {cost:.1} | {ns:.1} |"
        );
        let _ = writeln!(
            csv,
            "{name},{dt},{},{err:.4e},{tip:.4e},{:.4},{cost:.3},{ns:.2},{}",
            spf * frames,
            run.seconds,
            run.clamped
        );
        rows.push((dt, err, tip, cost));
    }
    Ok(rows)
}

/// One step of a configuration's sweep: (dt, RMS error, tip error, cost).
type SweepRow = (f64, f64, f64, f64);

/// Observed order: least-squares slope of log error against log dt over the three finest
/// steps (well above the reference's own error).
fn observed_order(rows: &[SweepRow]) -> f64 {
    let fine = &rows[rows.len() - 3..];
    let (mx, my) = fine.iter().fold((0.0, 0.0), |a, r| {
        (a.0 + r.0.ln() / 3.0, a.1 + r.1.max(1e-300).ln() / 3.0)
    });
    let (sxy, sxx) = fine.iter().fold((0.0, 0.0), |a, r| {
        let dx = r.0.ln() - mx;
        (a.0 + dx * (r.1.max(1e-300).ln() - my), a.1 + dx * dx)
    });
    sxy / sxx
}

/// Largest stable dt without substeps: no angular clamp and bounded error.
fn largest_stable_dt(scene: &Scene, reference: &DynRun) -> Result<Option<f64>> {
    let mut largest = None;
    for dt in [0.025, 0.05, 0.1, 0.2, 0.4, 0.8, 1.6] {
        let mut s = retime(scene, 1, dt);
        s.dynamics_mut().as_mut().unwrap().max_substeps = 1;
        let run = run_cpu(&s, (T_END / dt).round() as u32)?;
        let (err, _) = errors(&run, reference);
        if run.clamped == 0 && err.is_finite() && err < 0.5 {
            largest = Some(dt);
        } else {
            break;
        }
    }
    Ok(largest)
}

/// The Verlet stability limit 2/omega at dt = 0.1 (omega from the setup's `max_cu` and the
/// largest force over the run).
fn verlet_limit(scene: &Scene) -> Result<f64> {
    let s = retime(scene, 1, 0.1);
    let input = prepare(&s)?;
    let groomed = cantilever::bend_all(&input);
    let setup = DynSetup::new(&s, &input, &groomed.visible).unwrap();
    let fmax = (0..(T_END / 0.1) as u64)
        .map(|n| {
            let f = step_forces(&setup.forces, &setup.params, n, 1, 0);
            f.force.length()
        })
        .fold(0.0, f64::max);
    Ok(2.0 / (setup.max_cu * fmax).sqrt())
}

/// GPU: the paper's size (the full gust, ~10,000 hairs), advanced through the stage, next
/// to the CPU f64 reference.
fn dynamics_at_paper_size(
    gpu: &Gpu,
    gust: &Scene,
    gust_path: &Path,
    md: &mut String,
    csv: &mut String,
) -> Result<()> {
    let mut stage = Stage::new(gpu, gust, target::OUTPUT_FORMAT, Quality::of(gust))?;
    let (strands, segments) = {
        let sim = stage
            .system::<AnjyoSystem>()
            .and_then(|a| a.sim.as_ref())
            .ok_or_else(|| no_dynamics(gust_path))?;
        (
            sim.setup.strands.len(),
            sim.setup
                .strands
                .iter()
                .map(|s| s.segments as u64)
                .sum::<u64>(),
        )
    };
    let mut substeps = 0u64;
    let n = 20;
    let secs = time_mean(n, || {
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("bench dynamics"),
            });
        substeps += stage.advance(gpu, &mut enc, 1)?.substeps as u64;
        gpu.queue.submit([enc.finish()]);
        gpu.wait()
    })?;
    let per_frame_substeps = substeps as f64 / (n + 1) as f64;
    let gpu_ns = secs * 1e9 / (segments as f64 * per_frame_substeps);
    let cpu = run_cpu(&retime(gust, 1, 0.1), 5)?;
    let cpu_ns = cpu.seconds * 1e9 / cpu.segment_substeps as f64;
    let _ = writeln!(md, "\n**At the paper's size** (gust scene, {} hairs, {} simulated segments, dt = 0.1): GPU {:.1} ms per frame ({gpu_ns:.1} ns per segment-step); CPU f64 reference {cpu_ns:.1} ns per segment-step ({:.0} ms per frame). The paper: about 40 s per frame for 20,000 hairs.", strands, segments, secs * 1e3, cpu_ns * segments as f64 * 1e-6);
    let _ = writeln!(csv, "gpu gust,0.1,,,,{secs:.5},,{gpu_ns:.2},");
    Ok(())
}

/// Rigid pendulum: large-swing period against the exact elliptic integral.
fn pendulum_table(md: &mut String, csv: &mut String) {
    let _ = writeln!(
        md,
        "\n**One-segment strand = rigid pendulum**: period against 4 K(sin(a/2))/omega0.\n"
    );
    let _ = writeln!(
        md,
        "| amplitude (rad) | dt | period | exact | relative error |"
    );
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|");
    for amp in [0.5, 1.5, 2.5, 3.0] {
        for dt in [0.1, 0.05, 0.01] {
            let (t, exact) = pendulum_periods(amp, dt);
            let _ = writeln!(
                md,
                "| {amp} | {dt} | {t:.5} | {exact:.5} | {:+.2e} |",
                t / exact - 1.0
            );
            let _ = writeln!(csv, "pendulum a={amp},{dt},,{:.4e},,,,,", t / exact - 1.0);
        }
    }
}

/// Writes `dynamics.png` (error against cost), `dynamics.md` and `dynamics.csv` into `out`.
fn write_dynamics(
    out: &Path,
    md: &str,
    csv: &str,
    series: &[crate::bench::plot::Series],
) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|source| crate::KamiError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    let plot = crate::bench::plot::loglog(
        "PROJECTIVE DYNAMICS: ERROR VS COST",
        "CPU US PER STRAND PER UNIT TIME",
        "RMS ERROR / HAIR LENGTH",
        series,
        Some((0.01, "1% ERROR")),
    );
    let png = out.join("dynamics.png");
    plot.save(&png).map_err(|e| crate::KamiError::Image {
        path: png.clone(),
        message: e.to_string(),
    })?;
    for (name, text) in [("dynamics.md", md), ("dynamics.csv", csv)] {
        let p = out.join(name);
        std::fs::write(&p, text).map_err(|source| crate::KamiError::Io {
            path: p.clone(),
            source,
        })?;
    }
    Ok(())
}
/// The error for a benchmark scene without a dynamic hair group.
fn no_dynamics(path: &Path) -> crate::KamiError {
    crate::KamiError::Invalid {
        file: String::new(),
        field: format!("{}: dynamics", path.display()),
        value: "none".into(),
        allowed: "a scene with a `dynamics: Some(Dynamics(...))` block and a dynamic hair group (e.g. assets/scenes/gust.ron)".into(),
    }
}

/// Refuse a scene the dynamics benchmark cannot run (no dynamics, no hair).
fn require_dynamics(scene: &Scene, path: &Path) -> Result<()> {
    if scene.dynamics().is_none() || !scene.groups().iter().any(|g| g.dynamic) {
        return Err(no_dynamics(path));
    }
    Ok(())
}

/// (dt, RMS error) of one benchmark configuration (by name, e.g. "FREE (NO CONTACT)") for
/// these steps per frame, against the dt/64 reference. Used by the convergence test.
pub fn convergence(gust_path: &Path, case: &str, spfs: &[u32]) -> Result<Vec<(f64, f64)>> {
    let gust = Scene::load(gust_path)?;
    require_dynamics(&gust, gust_path)?;
    let (_, scene) = dynamic_cases(&gust)
        .into_iter()
        .find(|(n, _)| n == case)
        .ok_or_else(|| crate::KamiError::Invalid {
            file: String::new(),
            field: "case".into(),
            value: case.into(),
            allowed: "a configuration of `kami bench dynamics`".into(),
        })?;
    let frames = (T_END / FRAME_TIME).round() as u32;
    let reference = run_cpu(&retime(&scene, REF_SPF, FRAME_TIME), frames)?;
    spfs.iter()
        .map(|&spf| {
            let run = run_cpu(&retime(&scene, spf, FRAME_TIME), frames)?;
            Ok((FRAME_TIME / spf as f64, errors(&run, &reference).0))
        })
        .collect()
}
