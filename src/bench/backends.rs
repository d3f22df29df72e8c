//! `kami bench backends`: every shipped scene rendered on both software adapters (lavapipe
//! over Vulkan, llvmpipe over GL) and compared pixel by pixel. The snapshot tolerances are
//! set above what this measures, so one reference image serves both backends.

use super::{provenance, write_report, Report};
use crate::error::{KamiError, Result};
use crate::gpu::{Gpu, Preference};
use crate::systems::Scene;
use std::fmt::Write;
use std::path::Path;

/// Image size of the comparison (the snapshot tests' size).
pub const SIZE: (u32, u32) = (256, 256);
/// A channel difference above this counts as a pixel "off" (the snapshot threshold).
pub const THRESHOLD: u8 = 24;
/// The frame compared for scenes with dynamics, besides frame 0.
pub const MOTION_FRAME: u32 = 20;

/// (mean absolute difference over RGB, share of pixels with a channel off by more than
/// `THRESHOLD`, largest channel difference).
pub fn difference(a: &image::RgbaImage, b: &image::RgbaImage) -> (f64, f64, u8) {
    let (mut sum, mut over, mut worst) = (0u64, 0u64, 0u8);
    for (pa, pb) in a.pixels().zip(b.pixels()) {
        let d = (0..3).map(|c| pa[c].abs_diff(pb[c])).max().unwrap_or(0);
        sum += (0..3).map(|c| pa[c].abs_diff(pb[c]) as u64).sum::<u64>();
        over += u64::from(d > THRESHOLD);
        worst = worst.max(d);
    }
    let n = (a.width() * a.height()) as f64;
    (sum as f64 / (3.0 * n), over as f64 / n, worst)
}

fn frames_of(scene: &Scene) -> Vec<u32> {
    // Scenes in motion: any kind whose hair moves over frames (`Kind::moves`).
    if crate::systems::KINDS
        .iter()
        .any(|k| (k.in_scene)(scene) && (k.moves)(scene))
    {
        vec![0, MOTION_FRAME]
    } else {
        vec![0]
    }
}

fn render(gpu: &Gpu, scene: &Scene, frame: u32) -> Result<image::RgbaImage> {
    let mut img = None;
    crate::stage::render_animation(gpu, scene, SIZE, frame..=frame, |_, i| {
        img = Some(i);
        Ok(())
    })?;
    img.ok_or_else(|| KamiError::Gpu(format!("frame {frame} was not rendered")))
}

/// Compare every `*.ron` scene in `scenes` on the two software adapters; writes
/// `backends.md` and `backends.csv` to `out`.
pub fn run(scenes: &Path, out: &Path) -> Result<Report> {
    let vulkan = Gpu::headless_on(wgpu::Backends::VULKAN, Preference::Software)?;
    let gl = Gpu::headless_on(wgpu::Backends::GL, Preference::Software)?;
    for g in [&vulkan, &gl] {
        if g.info.device_type != wgpu::DeviceType::Cpu {
            return Err(KamiError::Device(format!(
                "bench backends compares the software adapters, but found {}",
                g.describe()
            )));
        }
    }
    let mut names: Vec<_> = std::fs::read_dir(scenes)
        .map_err(|source| KamiError::Io {
            path: scenes.to_path_buf(),
            source,
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    names.sort();
    let mut md = String::new();
    let mut csv = String::from("scene,frame,mean_abs_diff,share_over_threshold,max_diff\n");
    let _ = writeln!(md, "### `kami bench backends`\n");
    let _ = writeln!(
        md,
        "{}\n\nAdapters: {} against {}. Every shipped scene at {}x{} with its own anti-aliasing, frame 0 and, with dynamics, frame {MOTION_FRAME}. Differences in levels of 255 over RGB; *over {THRESHOLD}* is the share of pixels with a channel off by more than {THRESHOLD} (the snapshot tests' threshold).\n",
        provenance(),
        vulkan.describe(),
        gl.describe(),
        SIZE.0,
        SIZE.1
    );
    let _ = writeln!(
        md,
        "| scene | frame | mean difference | over {THRESHOLD} | largest |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---:|");
    let (mut worst_mean, mut worst_share, mut worst_px, mut images) = (0.0f64, 0.0f64, 0u8, 0);
    for path in &names {
        let scene = Scene::load(path)?;
        let name = path.file_stem().unwrap_or_default().to_string_lossy();
        for frame in frames_of(&scene) {
            let a = render(&vulkan, &scene, frame)?;
            let b = render(&gl, &scene, frame)?;
            let (mean, share, px) = difference(&a, &b);
            let _ = writeln!(
                md,
                "| {name} | {frame} | {mean:.4} | {:.4} % | {px} |",
                share * 100.0
            );
            let _ = writeln!(csv, "{name},{frame},{mean:.5},{share:.6},{px}");
            worst_mean = worst_mean.max(mean);
            worst_share = worst_share.max(share);
            worst_px = worst_px.max(px);
            images += 1;
        }
    }
    let _ = writeln!(
        md,
        "\n**Over all {images} images**: mean difference at most {worst_mean:.4}, at most {:.4} % of pixels over {THRESHOLD}, largest single difference {worst_px}.",
        worst_share * 100.0
    );
    write_report(out, "backends", &md, &csv)?;
    Ok(Report { markdown: md, csv })
}
