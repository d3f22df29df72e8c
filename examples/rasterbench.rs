//! CPU wall time of one drawn frame (no simulation) of a scene at a size with a rasteriser
//! and a share of the hairs, median of the runs: `cargo run --release --example rasterbench
//! -- [ribbons|compute] [msaa[xsupersample]] [runs] [scene] [WxH] [share]`. A quick probe while changing a
//! rasteriser (no reference image, so seconds rather than minutes; share 0.0001 gives the
//! frame's floor without hair); `kami bench raster` is the report.

use anyhow::Result;
use kami::bench::raster::{draw_share, Config};
use kami::gpu::{Gpu, Preference};
use kami::scene::StrandRaster;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let strands = match args.next().as_deref() {
        Some("ribbons") => StrandRaster::Ribbons,
        _ => StrandRaster::Compute,
    };
    // MSAA samples, optionally times a supersampling factor: 4 or 4x2.
    let quality = args.next().unwrap_or_else(|| "1".into());
    let (msaa, supersample) = quality.split_once('x').unwrap_or((&quality, "1"));
    let (msaa, supersample): (u32, u32) = (msaa.parse()?, supersample.parse()?);
    let runs: u32 = args.next().map_or(Ok(5), |s| s.parse())?;
    let scene = args
        .next()
        .unwrap_or_else(|| "assets/scenes/gust.ron".into());
    let size = args.next().unwrap_or_else(|| "1280x720".into());
    let lod: f64 = args.next().map_or(Ok(1.0), |s| s.parse())?;
    let (w, h) = size
        .split_once('x')
        .ok_or_else(|| anyhow::anyhow!("size {size}: want WIDTHxHEIGHT"))?;
    let size = (w.parse()?, h.parse()?);
    let scene = kami::Scene::load(&scene)?;
    let gpu = Gpu::headless(Preference::Software)?;
    let config = Config {
        strands,
        msaa,
        supersample,
        binned: false,
    };
    let d = draw_share(&gpu, &scene, config, size, 15, runs, lod)?;
    println!("{}: {:.1} ms per frame", config.name(), d.ms);
    Ok(())
}
