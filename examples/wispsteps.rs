//! Counters of the f64 tiled march (`field::render_reference_tiled`) on a scene at a size:
//! `cargo run --release --example wispsteps -- [scene] [side]`.

use anyhow::Result;
use glam::{DMat3, DMat4, DVec3};
use kami::systems::wisps::{curve, field};

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .unwrap_or_else(|| "assets/scenes/toon.ron".into());
    let side: u32 = args.next().map_or(Ok(64), |s| s.parse())?;
    let mut scene = kami::Scene::load(&path)?;
    scene.render.supersample = 1;
    scene.render.msaa = 1;
    let gpu = kami::gpu::Gpu::headless(kami::gpu::Preference::Software)?;
    let stage = kami::stage::Stage::new(
        &gpu,
        &scene,
        kami::stage::target::OUTPUT_FORMAT,
        kami::stage::Quality::of(&scene),
    )?;
    let look = stage.look();
    let size = (side, side);
    let frame = kami::stage::frame_uniform(&scene, &look, stage.bounds(), size, 1);
    let vp = DMat4::from_cols_array_2d(&frame.view_proj.map(|c| c.map(|v| v as f64)));
    let w = scene.wisps().as_ref().unwrap();
    let segs = curve::drawn_segments(w);
    let t = std::time::Instant::now();
    let (c, _, n) = field::render_reference_tiled(
        &segs,
        w.threshold,
        &w.march,
        &w.toon,
        DVec3::from(scene.light.direction),
        DMat3::IDENTITY,
        look.camera.eye,
        vp.inverse(),
        frame.raster[0] as f64,
        size,
        field::linear(scene.render.background),
        &[],
    );
    let bg = field::linear(scene.render.background);
    let covered = c.iter().filter(|x| (**x - bg).length() > 1e-3).count();
    println!(
        "{:.1} s: {covered} covered, {:?}; per covered pixel {:.1} steps, {:.1} exact",
        t.elapsed().as_secs_f64(),
        n,
        n.steps as f64 / covered as f64,
        n.exact as f64 / covered as f64
    );
    Ok(())
}
