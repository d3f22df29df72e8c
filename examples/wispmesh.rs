//! The meshed wisp path against the f64 truth at a few cell sizes (0: automatic):
//! `cargo run --release --example wispmesh -- [scene] [side] [cells...]`.

use anyhow::Result;
use kami::systems::wisps::block::WispDraw;

/// `time SCENE CELLS...`: the cost of `mesh::polygonise` alone.
fn time(mut args: impl Iterator<Item = String>) -> Result<()> {
    use kami::systems::wisps::{curve, mesh};
    let scene = kami::Scene::load(
        args.next()
            .unwrap_or_else(|| "assets/scenes/toon.ron".into()),
    )?;
    let w = scene.wisps().as_ref().expect("a scene with wisps");
    let segs = curve::drawn_segments(w);
    let outlines = mesh::wisp_outlines(w, &segs);
    for cell in args {
        let cell: f64 = cell.parse()?;
        let t = std::time::Instant::now();
        let n = 5;
        let mut m = Default::default();
        for _ in 0..n {
            m = mesh::polygonise(&mesh::Input {
                wisps: &segs,
                outlines: &outlines,
                taper: w.toon.outline_taper,
                threshold: w.threshold,
                method: w.march.distance,
                cell,
            })?;
        }
        let m: mesh::WispMesh = m;
        println!(
            "cell {cell}: {:.1} ms, {} points, {} triangles",
            t.elapsed().as_secs_f64() * 1e3 / n as f64,
            m.points,
            m.triangles()
        );
    }
    Ok(())
}

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1).peekable();
    if args.peek().map(String::as_str) == Some("time") {
        args.next();
        return time(args);
    }
    let path = args
        .next()
        .unwrap_or_else(|| "assets/scenes/toon.ron".into());
    let side: u32 = args.next().map_or(Ok(128), |s| s.parse())?;
    let cells: Vec<f64> = args.map(|a| a.parse()).collect::<Result<_, _>>()?;
    let mut scene = kami::Scene::load(&path)?;
    scene.head.visible = false;
    scene.render.supersample = 1;
    scene.render.msaa = 1;
    if let (Ok(v), Some(w)) = (std::env::var("OUTLINE"), scene.wisps_mut().as_mut()) {
        w.toon.outline_width = v.parse()?;
    }
    if std::env::var("NO_SHADOWS").is_ok() {
        scene.render.shadows.on = false;
    }
    let gpu = kami::gpu::Gpu::headless(kami::gpu::Preference::Software)?;
    let size = (side, side);
    let t = std::time::Instant::now();
    let mut deep = scene.clone();
    if let (Ok(n), Some(w)) = (std::env::var("TRUTH_STEPS"), deep.wisps_mut().as_mut()) {
        w.march.max_steps = n.parse()?;
    }
    let truth = kami::bench::wisps::truth_image(&gpu, &deep, size)?;
    println!("truth {:.1} s", t.elapsed().as_secs_f64());
    truth.save("/tmp/ex/truth.png")?;
    let mut draws = vec![(WispDraw::March, 0.0)];
    draws.extend(cells.iter().map(|&c| (WispDraw::Mesh, c)));
    for (draw, cell) in draws {
        let mut s = scene.clone();
        if let Some(w) = s.wisps_mut().as_mut() {
            w.draw = draw;
            w.mesh.cell = cell;
        }
        let t = std::time::Instant::now();
        let img = kami::stage::render_scene(&gpu, &s, size)?;
        let (mean, over, worst) = kami::bench::backends::difference(&truth, &img);
        println!(
            "{draw:?} cell {cell}: {:.0} ms, mean {mean:.3}, > 24 {:.3} %, worst {worst}",
            t.elapsed().as_secs_f64() * 1e3,
            over * 100.0
        );
        img.save(format!("/tmp/ex/{draw:?}_{cell}.png"))?;
        let dark =
            |i: &image::RgbaImage| i.pixels().filter(|p| p[0].max(p[1]).max(p[2]) < 70).count();
        println!("  dark pixels: truth {}, this {}", dark(&truth), dark(&img));
        let k = 4;
        let panel = image::RgbaImage::from_fn(side * 3 * k, side * k, |x, y| {
            let (p, x) = (x / (side * k), (x % (side * k)) / k);
            let y = y / k;
            let (a, b) = (truth.get_pixel(x, y), img.get_pixel(x, y));
            match p {
                0 => *a,
                1 => *b,
                _ => {
                    let d = (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0);
                    let v = if d > 24 { 255 } else { d * 8 };
                    image::Rgba([
                        v,
                        if d > 24 { 0 } else { v },
                        if d > 24 { 0 } else { v },
                        255,
                    ])
                }
            }
        });
        panel.save(format!("/tmp/ex/panel_{draw:?}_{cell}.png"))?;
    }
    Ok(())
}
