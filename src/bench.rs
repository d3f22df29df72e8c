//! Benchmarks behind `kami bench`. Speed is measured here, never in tests. Each report is
//! Markdown (for the README) plus CSV, and says which adapter and CPU produced it.

use crate::error::Result;
use crate::gpu::Gpu;
use crate::groom::cantilever::{self, Beam, CantileverPass};
use crate::groom::{elastica, prepare};
use crate::render::{self, target, FrameView, Quality, Renderer};
use crate::scene::{Bending, Scene};
use glam::DVec3;
use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

pub struct Report {
    pub markdown: String,
    pub csv: String,
}

/// The paper's hairstyle modelling time: "about 50 seconds" for about 20,000 hairs of at
/// most 20 segments (Anjyo et al. 1992, 4.2, SGI Iris Power Series).
pub const PAPER_GROOM_SECONDS: f64 = 50.0;
pub const PAPER_GROOM_HAIRS: f64 = 20_000.0;

fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

/// Time `f` `n` times after one warm-up run; mean seconds.
fn time_mean(n: u32, mut f: impl FnMut() -> Result<()>) -> Result<f64> {
    f()?;
    let t = Instant::now();
    for _ in 0..n {
        f()?;
    }
    Ok(t.elapsed().as_secs_f64() / n as f64)
}

/// Groom throughput (CPU reference, GPU kernel, both bending modes), render time per frame
/// at 1280x720, and the bending accuracy table against the exact elastica.
pub fn groom(gpu: &Gpu, scene_path: &Path, frames: u32) -> Result<Report> {
    let scene = Scene::load(scene_path)?;
    let mut md = String::new();
    let mut csv =
        String::from("table,G,k,mode,tip_drop,exact,rel_error,iterations,us_per_strand\n");
    let (hairs, segs) = scene.counts();
    let _ = writeln!(md, "### `kami bench groom` — {}\n", scene_path.display());
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

    for (label, converged) in [("paper", false), ("converged", true)] {
        let mut s = scene.clone();
        if converged {
            for g in &mut s.groups {
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

        let strands = crate::gpu::strands::StrandBuffers::new(gpu, &input)?;
        let pass = CantileverPass::new(gpu)?;
        let job = pass.prepare(gpu, &input, &strands)?;
        let runs = if converged { 2 } else { 5 };
        let gpu_t = time_mean(runs, || {
            let mut enc = gpu.device.create_command_encoder(&Default::default());
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
    }

    // Render time per frame at 1280x720.
    let size = (1280, 720);
    let input = prepare(&scene)?;
    let hair = cantilever::groom_gpu(gpu, &input)?;
    let _ = writeln!(md, "\n| render 1280x720 | ms/frame | fps |");
    let _ = writeln!(md, "|---|---:|---:|");
    for (msaa, ss) in [(1, 1), (4, 1), (4, 2)] {
        let mut r = Renderer::new(
            gpu,
            target::OUTPUT_FORMAT,
            Quality {
                msaa,
                supersample: ss,
            },
        )?;
        r.set_hair(gpu, &hair, &render::materials(&scene));
        let out = target::Offscreen::new(gpu, size)?;
        let view = FrameView::from_scene(&scene);
        let secs = time_mean(frames, || {
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            r.render(gpu, &mut enc, &out.view, size, &view)?;
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

    // Accuracy against the elastica.
    let _ = writeln!(md, "\n**Tip drop against the exact heavy cantilever** (clamped horizontally, G = wL^3/EI; relative error of the tip drop; the paper mode's own limit is an EI of 2EI, shown as `paper vs G/2`).\n");
    let _ = writeln!(md, "| G | exact drop/L | k | paper | paper vs G/2 | converged | iterations | CPU µs/strand (conv.) |");
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|");
    for g in [0.1, 1.0, 10.0, 100.0, 1000.0] {
        let exact = elastica::tip_drop(g);
        let half = elastica::tip_drop(g / 2.0);
        for k in [5u32, 10, 20, 40, 80, 160] {
            let load = move |_: DVec3, _: DVec3| DVec3::new(0.0, -g, 0.0);
            let beam = Beam {
                root: DVec3::ZERO,
                dir: DVec3::X,
                seg_len: 1.0 / k as f64,
                segments: k,
                rigidity: 1.0,
                load: &load,
                hull: None,
            };
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
    let _ = writeln!(md, "\nConverged mode, fewest segments for 1 % tip error:\n");
    let _ = writeln!(md, "| G | k | error |");
    let _ = writeln!(md, "|---:|---:|---:|");
    for g in [0.1, 1.0, 10.0, 100.0, 1000.0] {
        let exact = elastica::tip_drop(g);
        let mut found = None;
        for k in 1..=200u32 {
            let load = move |_: DVec3, _: DVec3| DVec3::new(0.0, -g, 0.0);
            let beam = Beam {
                root: DVec3::ZERO,
                dir: DVec3::X,
                seg_len: 1.0 / k as f64,
                segments: k,
                rigidity: 1.0,
                load: &load,
                hull: None,
            };
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
    Ok(Report { markdown: md, csv })
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
    use crate::sim::projective::{CpuSim, DynSetup, DynStrand};
    let params = crate::scene::Dynamics {
        dt,
        gravity: [0.0, -1.0, 0.0],
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
        params,
        // Far away: no contact.
        head: crate::scene::Ellipsoid::new([1e6, 0.0, 0.0], [1.0, 1.0, 1.0]),
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
