//! The `kami` command line: render scenes to PNG and run the benchmarks.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use kami::gpu::{Gpu, Preference};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "kami",
    version,
    about = "Kami (髪): GPU hair, fur and toon-hair viewer and simulator"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Groom a scene on the GPU and render it to a PNG.
    Render {
        /// Scene file (RON), e.g. assets/scenes/bob.ron.
        scene: PathBuf,
        /// Output PNG.
        #[arg(short, long, default_value = "kami.png")]
        out: PathBuf,
        /// Image size as WIDTHxHEIGHT (default: the scene's render.size).
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        /// MSAA samples, 1 or 4 (default: the scene's render.msaa).
        #[arg(long)]
        msaa: Option<u32>,
        /// Supersampling factor per axis, 1 to 4 (default: the scene's render.supersample).
        #[arg(long)]
        supersample: Option<u32>,
        /// Prefer a software adapter (llvmpipe/lavapipe) even when a GPU is present.
        #[arg(long)]
        software: bool,
    },
    /// Benchmarks: print throughput and accuracy tables.
    Bench {
        #[command(subcommand)]
        which: Bench,
    },
}

#[derive(Subcommand)]
enum Bench {
    /// Cantilever grooming: CPU reference and GPU kernel throughput on the largest scene,
    /// render time per frame, and tip-drop error against the exact elastica for both
    /// bending modes.
    Groom {
        /// Scene to time (default: the largest shipped scene).
        #[arg(long, default_value = "assets/scenes/bob.ron")]
        scene: PathBuf,
        /// Frames to time for the render figure.
        #[arg(long, default_value_t = 10)]
        frames: u32,
        /// Also write the accuracy table as CSV here.
        #[arg(long)]
        csv: Option<PathBuf>,
        #[arg(long)]
        software: bool,
    },
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("size {s:?} must look like 1280x720"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in {s:?}"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in {s:?}"))?;
    if w == 0 || h == 0 || w > kami::scene::MAX_SIZE || h > kami::scene::MAX_SIZE {
        return Err(format!(
            "size {s:?} must be between 1x1 and {0}x{0}",
            kami::scene::MAX_SIZE
        ));
    }
    Ok((w, h))
}

fn preference(software: bool) -> Preference {
    if software {
        Preference::Software
    } else {
        Preference::Hardware
    }
}

fn main() -> Result<()> {
    env_logger::Builder::from_env(
        env_logger::Env::default().default_filter_or("warn,wgpu_hal::gles::egl=off"),
    )
    .init();
    let cli = Cli::parse();
    match cli.command {
        Command::Render {
            scene,
            out,
            size,
            msaa,
            supersample,
            software,
        } => {
            let mut s = kami::Scene::load(&scene)?;
            if let Some(m) = msaa {
                s.render.msaa = m;
            }
            if let Some(f) = supersample {
                s.render.supersample = f;
            }
            kami::scene::validate(&s)?;
            let size = size.unwrap_or(s.render.size);
            let gpu = Gpu::headless(preference(software))?;
            let t = std::time::Instant::now();
            let img = kami::render::render_scene(&gpu, &s, size)?;
            img.save(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            let (hairs, segs) = s.counts();
            println!(
                "{}: {hairs} hairs, {segs} segments, {}x{} on {} in {:.2} s",
                out.display(),
                size.0,
                size.1,
                gpu.describe(),
                t.elapsed().as_secs_f64()
            );
        }
        Command::Bench { which } => match which {
            Bench::Groom {
                scene,
                frames,
                csv,
                software,
            } => {
                if frames == 0 {
                    bail!("--frames must be at least 1");
                }
                let gpu = Gpu::headless(preference(software))?;
                let report = kami::bench::groom(&gpu, &scene, frames)?;
                println!("{}", report.markdown);
                if let Some(p) = csv {
                    std::fs::write(&p, &report.csv)
                        .with_context(|| format!("writing {}", p.display()))?;
                }
            }
        },
    }
    Ok(())
}
