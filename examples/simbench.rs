//! The projective kernel's CPU wall time per simulated frame on the chosen adapter (software by
//! default), over the gust scene: `cargo run --release --example simbench -- [frames] [segments|0]
//! [state-out.bin]`. Segments 0 keeps the scene's own (12 and 18); the default 16 is what
//! `kami bench scale --strands 10000 --segments 16` simulates. Prints each frame's time and
//! the median over frames after the first two; writes the final angle state when asked.

use anyhow::Result;
use kami::gpu::{Gpu, Preference};
use kami::stage::{target, Quality, Stage};
use kami::systems::anjyo::AnjyoSystem;
use std::time::Instant;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let frames: u32 = args.next().map_or(Ok(12), |s| s.parse())?;
    let segments: u32 = args.next().map_or(Ok(16), |s| s.parse())?;
    let out = args.next();
    let base = kami::Scene::load("assets/scenes/gust.ron")?;
    let scene = if segments == 0 {
        base
    } else {
        kami::bench::scale::scaled(&base, 10000, segments)?
    };
    let gpu = Gpu::headless(Preference::Software)?;
    let mut stage = Stage::new(&gpu, &scene, target::OUTPUT_FORMAT, Quality::of(&scene))?;
    gpu.wait()?;
    let mut times = Vec::new();
    let mut cpu0 = 0.0;
    for f in 0..frames {
        if f == 2 {
            cpu0 = cpu_ms();
        }
        let t = Instant::now();
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        stage.advance(&gpu, &mut enc, 1)?;
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        print!("{ms:.1} ");
        if f >= 2 {
            times.push(ms);
        }
    }
    let cpu = (cpu_ms() - cpu0) / (frames - 2) as f64;
    times.sort_by(f64::total_cmp);
    println!(
        "\nmedian {:.2} ms, min {:.2} ms, process CPU {:.2} ms/frame ({})",
        times[times.len() / 2],
        times[0],
        cpu,
        gpu.describe()
    );
    if let Some(path) = out {
        let sim = stage
            .system::<AnjyoSystem>()
            .and_then(|a| a.sim.as_ref())
            .expect("gust simulates");
        let state = sim.read_state(&gpu)?;
        let bytes: Vec<u8> = state
            .iter()
            .flat_map(|v| v.iter().flat_map(|x| x.to_le_bytes()))
            .collect();
        std::fs::write(&path, bytes)?;
    }
    Ok(())
}

/// CPU time of every thread of this process (the software adapter's workers included), ms.
fn cpu_ms() -> f64 {
    let mut ns = 0u64;
    if let Ok(dir) = std::fs::read_dir("/proc/self/task") {
        for t in dir.flatten() {
            if let Ok(s) = std::fs::read_to_string(t.path().join("schedstat")) {
                ns += s
                    .split_whitespace()
                    .next()
                    .and_then(|x| x.parse().ok())
                    .unwrap_or(0);
            }
        }
    }
    ns as f64 * 1e-6
}
