//! Render a scene to a PNG through the library API (what `kami render` does), choosing the
//! adapter yourself: `cargo run --release --example headless_render -- assets/scenes/bob.ron out.png`.

use anyhow::Result;
use kami::gpu::{Gpu, Preference};

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let scene = args
        .next()
        .unwrap_or_else(|| "assets/scenes/bob.ron".into());
    let out = args.next().unwrap_or_else(|| "headless.png".into());
    let scene = kami::Scene::load(&scene)?;
    let gpu = Gpu::headless(Preference::Software)?;
    let image = kami::stage::render_scene(&gpu, &scene, (640, 640))?;
    image.save(&out)?;
    println!("{out} ({})", gpu.describe());
    Ok(())
}
