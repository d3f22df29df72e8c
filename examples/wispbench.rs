//! A quick probe of the wisps' ray march while changing it: `cargo run --release --example
//! wispbench -- [scene] [WxH] [frames] [copies]` prints ms per frame, steps and candidates
//! per ray and µs per covered pixel (`kami bench wisps` is the report).

use anyhow::Result;
use kami::bench::wisps::{march_frame, multiplied};
use kami::gpu::{Gpu, Preference};

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let scene = args
        .next()
        .unwrap_or_else(|| "assets/scenes/toon.ron".into());
    let size = args.next().unwrap_or_else(|| "256x256".into());
    let frames: u32 = args.next().map_or(Ok(3), |s| s.parse())?;
    let copies: usize = args.next().map_or(Ok(1), |s| s.parse())?;
    let (w, h) = size
        .split_once('x')
        .ok_or_else(|| anyhow::anyhow!("size {size}: want WIDTHxHEIGHT"))?;
    let size = (w.parse()?, h.parse()?);
    let scene = multiplied(&kami::Scene::load(&scene)?, copies);
    let gpu = Gpu::headless(Preference::Software)?;
    let f = march_frame(&gpu, &scene, size, frames)?;
    println!(
        "{:.1} ms per frame, {:.1} steps and {:.1} candidates per ray, {:.2} us per covered pixel, {} covered, {:?}",
        f.ms,
        f.steps_per_ray(),
        f.candidates_per_ray(),
        f.us_per_covered(),
        f.stats.covered,
        f.stats
    );
    Ok(())
}
