//! `kami bench fur`: Van Gelder & Wilhelms' fur, timed the way the paper reports it (hairs
//! per second of generation plus drawing at 900x900, per style, and the Figure 9 image of
//! 500,000 hairs), and distance-based culling measured as image error against the
//! full-density render versus hairs drawn and time.

use super::{cpu_name, time_mean, Report};
use crate::error::Result;
use crate::gpu::Gpu;
use crate::stage::{self, target, Look, Quality, Stage};
use crate::systems::fur::block::FurStyle;
use crate::systems::fur::FurSystem;
use crate::systems::Scene;
use crate::systems::{FrameCtx, HairSystem, View};
use glam::DVec3;
use image::RgbaImage;
use std::fmt::Write;
use std::path::Path;

/// The paper's rates on a 150 MHz SGI Reality Engine II (sections 3.6-3.8).
pub const PAPER_HAIRS_PER_SECOND: [(FurStyle, &str, f64); 4] = [
    (FurStyle::Line, "line", 35_000.0),
    (FurStyle::Polyline, "polyline", 15_000.0),
    (FurStyle::Curve, "curve", 12_500.0),
    (FurStyle::Tube, "tube", 3_200.0),
];

/// Figure 9: 500,000 hairs of polyline overcoat and undercoat, the whole 900x900 image in
/// 39.4 CPU seconds.
pub const PAPER_FIG9_HAIRS: u32 = 500_000;
pub const PAPER_FIG9_SECONDS: f64 = 39.4;

/// The paper's image size.
pub const SIZE: (u32, u32) = (900, 900);

/// Distances, in multiples of the distance at which the model fills the view.
pub const DISTANCES: [f64; 6] = [1.0, 1.5, 2.0, 3.0, 4.0, 6.0];

/// A fur scene set up for timing: its stage, an offscreen target and the scene's look.
struct Timed {
    stage: Stage,
    out: target::Offscreen,
    look: Look,
}

impl Timed {
    fn new(gpu: &Gpu, scene: &Scene, quality: Quality) -> Result<Timed> {
        stage::check_limits(gpu, scene, SIZE)?;
        let stage = Stage::new(gpu, scene, target::OUTPUT_FORMAT, quality)?;
        let look = stage.look();
        Ok(Timed {
            stage,
            out: target::Offscreen::new(gpu, SIZE)?,
            look,
        })
    }

    fn fur(&mut self) -> Result<&mut FurSystem> {
        self.stage
            .system_mut::<FurSystem>()
            .ok_or_else(|| crate::KamiError::Invalid {
                file: String::new(),
                field: "fur".into(),
                value: "None".into(),
                allowed: "a fur scene".into(),
            })
    }

    /// Generate and draw one frame; `compensate: false` keeps the culled hairs' width (to
    /// show what the compensation buys). Returns the hairs drawn.
    fn frame(&mut self, gpu: &Gpu, compensate: bool) -> Result<u64> {
        let fur = self.fur()?;
        fur.compensate_width = compensate;
        // The paper's rate is generation plus drawing: generate every timed frame.
        fur.invalidate();
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("bench fur frame"),
            });
        self.stage
            .render(gpu, &mut enc, &self.out.view, SIZE, &self.look)?;
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        Ok(self.fur()?.drawn.iter().map(|&d| d as u64).sum())
    }

    /// Generation alone, for the cost of regenerating every frame.
    fn generate(&mut self, gpu: &Gpu) -> Result<()> {
        // The stage's clock, owned here so the fur can be borrowed mutably beside it.
        let (frame, forces, head) = {
            let c = self.stage.ctx();
            (c.frame, c.forces.clone(), c.head)
        };
        let ctx = FrameCtx {
            frame,
            forces: &forces,
            head,
        };
        let view = View {
            eye: self.look.camera.eye,
            fov_y: self.look.camera.fov_y,
            lod: 1.0,
            height_px: SIZE.1 as f64,
            lod_tolerance_px: self.stage.scene().render.lod_tolerance_px,
            overlay: false,
            // Fur generation works in world space: no projection needed.
            view_proj: glam::DMat4::IDENTITY,
            samples: SIZE,
            samples_per_px: 1.0,
            focal_samples: 1.0,
        };
        let mut enc = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("bench fur generation"),
            });
        let fur = self.fur()?;
        // Timing generation: the fur would otherwise keep a still mesh's hairs.
        fur.invalidate();
        fur.prepare(gpu, &mut enc, &ctx, &view)?;
        gpu.queue.submit([enc.finish()]);
        gpu.wait()
    }
}

/// Run the fur benchmark with the shipped scenes in `scenes` (a folder), timing `frames`
/// frames per figure; writes `fur.md`, `fur.csv` and `fur_culling.png` to `out`.
pub fn run(gpu: &Gpu, scenes: &Path, out: &Path, frames: u32) -> Result<Report> {
    std::fs::create_dir_all(out).map_err(|source| crate::KamiError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    let mut md = String::new();
    let mut csv = String::from("table,case,quality,hairs_drawn,ms_per_frame,hairs_per_s,ratio_to_paper,gen_ms,tile_error,pixel_error\n");
    let _ = writeln!(md, "### `kami bench fur`\n");
    let _ = writeln!(md, "{}\n", super::provenance());
    let _ = writeln!(
        md,
        "Adapter: {}; CPU: {}. Image {}x{}; each figure is the mean of {frames} frames after one warm-up, generation + drawing + wait, image left on the GPU.\n",
        gpu.describe(),
        cpu_name(),
        SIZE.0,
        SIZE.1
    );
    fur_styles(gpu, scenes, frames, &mut md, &mut csv)?;
    fur_fig9(gpu, scenes, frames, &mut md, &mut csv)?;
    fur_culling(gpu, scenes, out, frames, &mut md, &mut csv)?;
    let write = |name: &str, text: &str| {
        std::fs::write(out.join(name), text).map_err(|source| crate::KamiError::Io {
            path: out.join(name),
            source,
        })
    };
    write("fur.md", &md)?;
    write("fur.csv", &csv)?;
    Ok(Report { markdown: md, csv })
}

/// Table 1: hairs per second by style, against the paper's rates.
fn fur_styles(
    gpu: &Gpu,
    scenes: &Path,
    frames: u32,
    md: &mut String,
    csv: &mut String,
) -> Result<()> {
    let _ = writeln!(md, "**Hairs per second by style** (the `fur_<style>.ron` scenes, one coat, Figure 2's Figure 8 look; paper: 150 MHz SGI RE-II, CPU time):\n");
    let _ = writeln!(
        md,
        "| style | hairs | quality | ms/frame | generation ms | hairs/s | paper hairs/s | ratio |"
    );
    let _ = writeln!(md, "|---|---:|---|---:|---:|---:|---:|---:|");
    for (style, name, paper) in PAPER_HAIRS_PER_SECOND {
        let scene = Scene::load(scenes.join(format!("fur_{name}.ron")))?;
        debug_assert!(scene
            .fur()
            .as_ref()
            .is_some_and(|f| f.coats.iter().all(|c| c.style == style)));
        for (label, quality) in qualities(&scene) {
            let mut stage = Timed::new(gpu, &scene, quality)?;
            let mut drawn = 0;
            let secs = time_mean(frames, || {
                drawn = stage.frame(gpu, true)?;
                Ok(())
            })?;
            let gen = time_mean(frames, || stage.generate(gpu))?;
            let rate = drawn as f64 / secs;
            let _ = writeln!(
                md,
                "| {name} | {drawn} | {label} | {:.0} | {:.1} | {:.0} | {paper:.0} | {:.1}x |",
                secs * 1e3,
                gen * 1e3,
                rate,
                rate / paper
            );
            let _ = writeln!(
                csv,
                "style,{name},{label},{drawn},{:.2},{rate:.0},{:.3},{:.2},,",
                secs * 1e3,
                rate / paper,
                gen * 1e3
            );
        }
    }
    Ok(())
}

/// Table 2: Figure 9 at the paper's 500,000 hairs.
fn fur_fig9(
    gpu: &Gpu,
    scenes: &Path,
    frames: u32,
    md: &mut String,
    csv: &mut String,
) -> Result<()> {
    let mut fig9 = Scene::load(scenes.join("fur_fig9.ron"))?;
    if let Some(f) = fig9.fur_mut().as_mut() {
        f.hairs = PAPER_FIG9_HAIRS;
    }
    let _ = writeln!(md, "\n**Figure 9** (`fur_fig9.ron` at {PAPER_FIG9_HAIRS} hairs, polyline overcoat and undercoat, whole image; paper: {PAPER_FIG9_SECONDS} CPU s):\n");
    let _ = writeln!(md, "| quality | hairs | s/frame | fps | vs paper |");
    let _ = writeln!(md, "|---|---:|---:|---:|---:|");
    for (label, quality) in qualities(&fig9) {
        let mut stage = Timed::new(gpu, &fig9, quality)?;
        let mut drawn = 0;
        let secs = time_mean(frames.min(3), || {
            drawn = stage.frame(gpu, true)?;
            Ok(())
        })?;
        let _ = writeln!(
            md,
            "| {label} | {drawn} | {secs:.2} | {:.1} | {:.0}x faster |",
            1.0 / secs,
            PAPER_FIG9_SECONDS / secs
        );
        let _ = writeln!(
            csv,
            "fig9,fur_fig9,{label},{drawn},{:.2},{:.0},{:.3},,,",
            secs * 1e3,
            drawn as f64 / secs,
            PAPER_FIG9_SECONDS / secs
        );
    }
    Ok(())
}

/// Table 3, distance-based culling: image error against the full-density render versus hairs
/// drawn and time, and the contact sheet `fur_culling.png`.
fn fur_culling(
    gpu: &Gpu,
    scenes: &Path,
    out: &Path,
    frames: u32,
    md: &mut String,
    csv: &mut String,
) -> Result<()> {
    let base = Scene::load(scenes.join("fur_fig9.ron"))?;
    let quality = Quality::new(base.render.msaa, base.render.supersample);
    let _ = writeln!(md, "\n**Distance-based culling** (`fur_fig9.ron`, {} hairs, MSAA {} x supersample {}): the camera backs away along its line of sight to k times the distance at which the model fills the view. Error against the full-density render at the same distance, in levels of 255: *tile* = mean over the model of the difference of 8x8-pixel block means (the look), *pixel* = mean per-pixel difference over the model (dominated by which hairs land where). The floor is the full-density render with another seed (the same look, other hairs).\n",
        base.fur().as_ref().map_or(0, |f| f.hairs), quality.msaa, quality.supersample);
    let _ = writeln!(
        md,
        "| k | variant | hairs drawn | share | ms/frame | tile error | pixel error |"
    );
    let _ = writeln!(md, "|---:|---|---:|---:|---:|---:|---:|");
    let mut strip: Vec<Vec<RgbaImage>> = vec![Vec::new(); 3];
    for k in DISTANCES {
        let at = |mut s: Scene, culling: bool, seed: u64| -> Result<Scene> {
            let own_seed = s.seed;
            let fur = s.fur_mut().as_mut().expect("a fur scene");
            fur.culling.enabled = culling;
            let setup = crate::systems::fur::setup::FurSetup::new(fur, own_seed)?;
            let (centre, r) = setup.bounds();
            let full = r / (0.5 * s.camera.fov_y.to_radians()).sin();
            let eye = DVec3::from(s.camera.eye);
            let dir = (eye - centre).try_normalize().unwrap_or(DVec3::Z);
            s.camera.eye = (centre + dir * (k * full)).to_array();
            s.camera.target = centre.to_array();
            s.seed = seed;
            Ok(s)
        };
        let measure = |scene: Scene, compensate: bool| -> Result<(u64, f64, RgbaImage)> {
            let mut stage = Timed::new(gpu, &scene, quality)?;
            let mut drawn = 0;
            let secs = time_mean(frames.min(3), || {
                drawn = stage.frame(gpu, compensate)?;
                Ok(())
            })?;
            Ok((drawn, secs, stage.out.read_rgba(gpu)?))
        };
        let (all_n, all_t, all) = measure(at(base.clone(), false, base.seed)?, true)?;
        let (_, _, other) = measure(at(base.clone(), false, base.seed + 1)?, true)?;
        let (c_n, c_t, culled) = measure(at(base.clone(), true, base.seed)?, true)?;
        let (n_n, n_t, naive) = measure(at(base.clone(), true, base.seed)?, false)?;
        let rows: [(&str, u64, f64, Option<&RgbaImage>); 4] = [
            ("all hairs", all_n, all_t, None),
            ("all hairs, other seed (floor)", all_n, all_t, Some(&other)),
            ("culled", c_n, c_t, Some(&culled)),
            ("culled, widths not compensated", n_n, n_t, Some(&naive)),
        ];
        for (label, n, t, img) in rows {
            let (tile, pixel) = img.map_or((0.0, 0.0), |i| model_error(i, &all));
            let _ = writeln!(
                md,
                "| {k} | {label} | {n} | {:.0}% | {:.0} | {tile:.2} | {pixel:.1} |",
                100.0 * n as f64 / all_n.max(1) as f64,
                t * 1e3
            );
            let _ = writeln!(
                csv,
                "culling,k={k},{label},{n},{:.2},,,,{tile:.3},{pixel:.3}",
                t * 1e3
            );
        }
        for (row, img) in [&all, &culled, &naive].into_iter().enumerate() {
            strip[row].push(zoom(img, k));
        }
    }
    let sheet = contact_sheet(&strip);
    let png = out.join("fur_culling.png");
    sheet.save(&png).map_err(|e| crate::KamiError::Image {
        path: png.clone(),
        message: e.to_string(),
    })?;
    let _ = writeln!(md, "\n`fur_culling.png`: rows all hairs / culled / culled without width compensation; columns k = {DISTANCES:?}, each magnified so the model is the same size (nearest-neighbour, so the pixels the viewer would see are visible).");
    Ok(())
}

/// The scene's own quality, MSAA without supersampling, and no MSAA (the paper's GL drew
/// aliased lines).
fn qualities(scene: &Scene) -> Vec<(String, Quality)> {
    let mut q: Vec<(String, Quality)> = Vec::new();
    for (msaa, supersample) in [
        (scene.render.msaa, scene.render.supersample),
        (4, 1),
        (1, 1),
    ] {
        let quality = Quality::new(msaa, supersample);
        if q.iter().all(|(_, x)| *x != quality) {
            let label = match (msaa, supersample) {
                (1, 1) => "no MSAA".to_string(),
                (m, 1) => format!("MSAA {m}"),
                (m, s) => format!("MSAA {m} x SS {s}"),
            };
            q.push((label, quality));
        }
    }
    q
}

/// (tile error, pixel error) of `img` against `reference` over the tiles where the reference
/// is not plain background: mean absolute difference of 8x8 block means, and of pixels.
pub fn model_error(img: &RgbaImage, reference: &RgbaImage) -> (f64, f64) {
    const T: u32 = 8;
    let bg = reference.get_pixel(0, 0);
    let (mut tile_sum, mut pixel_sum, mut tiles, mut pixels) = (0.0, 0.0, 0usize, 0usize);
    for ty in 0..reference.height() / T {
        for tx in 0..reference.width() / T {
            let (mut a, mut b, mut off_bg, mut pix) = ([0.0; 3], [0.0; 3], false, 0.0);
            for y in ty * T..(ty + 1) * T {
                for x in tx * T..(tx + 1) * T {
                    let (p, q) = (img.get_pixel(x, y), reference.get_pixel(x, y));
                    for c in 0..3 {
                        a[c] += p[c] as f64;
                        b[c] += q[c] as f64;
                        pix += (p[c] as f64 - q[c] as f64).abs() / 3.0;
                        off_bg |= q[c].abs_diff(bg[c]) > 2;
                    }
                }
            }
            if off_bg {
                let n = (T * T) as f64;
                tile_sum += (0..3).map(|c| (a[c] - b[c]).abs() / n).sum::<f64>() / 3.0;
                pixel_sum += pix;
                tiles += 1;
                pixels += (T * T) as usize;
            }
        }
    }
    (
        tile_sum / tiles.max(1) as f64,
        pixel_sum / pixels.max(1) as f64,
    )
}

/// The middle 1/k of the image (where the model is at distance k), scaled to 300 pixels.
fn zoom(img: &RgbaImage, k: f64) -> RgbaImage {
    let side = ((img.width().min(img.height()) as f64 / k).round() as u32).max(8);
    let x = (img.width() - side.min(img.width())) / 2;
    let y = (img.height() - side.min(img.height())) / 2;
    let crop = image::imageops::crop_imm(img, x, y, side, side).to_image();
    image::imageops::resize(&crop, 300, 300, image::imageops::FilterType::Nearest)
}

fn contact_sheet(rows: &[Vec<RgbaImage>]) -> RgbaImage {
    let cols = rows.iter().map(|r| r.len()).max().unwrap_or(0) as u32;
    let mut sheet = RgbaImage::from_pixel(
        cols * 302,
        rows.len() as u32 * 302,
        image::Rgba([255, 255, 255, 255]),
    );
    for (r, row) in rows.iter().enumerate() {
        for (c, img) in row.iter().enumerate() {
            image::imageops::overlay(&mut sheet, img, c as i64 * 302, r as i64 * 302);
        }
    }
    sheet
}
