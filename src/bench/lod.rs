//! `kami bench lod`: the screen-space level of detail (`systems::lod`) measured as image
//! error against full detail as the head gets smaller on screen: the camera of a strand-hair
//! scene backs away along its line of sight to k times the distance at which the hair's
//! bounding sphere fills the frame, and the same frame is rendered with every strand and
//! segment (`render.lod_tolerance_px = 0`) and with the level of detail (the scene's
//! tolerance). Errors as `kami bench fur` measures culling (`fur::model_error`), with the
//! floor of full detail drawn from another seed. `tests/it/lod.rs` asserts on the same
//! measurement.

use super::fur::model_error;
use super::{provenance, write_report, Report};
use crate::bench::plot::{self, Series};
use crate::error::Result;
use crate::stage::{self, target, Quality, Stage};
use crate::systems::anjyo::{scene_bounds, AnjyoSystem};
use crate::systems::Scene;
use glam::DVec3;
use image::RgbaImage;
use std::fmt::Write;
use std::path::Path;

/// Distances, in multiples of the distance at which the hair's sphere fills the frame.
pub const DISTANCES: [f64; 4] = [1.0, 2.0, 4.0, 8.0];

/// The image size of the report.
pub const SIZE: (u32, u32) = (400, 400);

/// `scene` with its camera moved along its line of sight to `k` times the distance at which
/// the hair's bounding sphere fills the frame's height, looking at the sphere's centre.
pub fn at_distance(scene: &Scene, k: f64) -> Scene {
    let mut s = scene.clone();
    let (centre, r) = scene_bounds(scene);
    let full = r / (0.5 * s.camera.fov_y.to_radians()).sin();
    let eye = DVec3::from(s.camera.eye);
    let dir = (eye - centre).try_normalize().unwrap_or(DVec3::Z);
    s.camera.eye = (centre + dir * (k * full)).to_array();
    s.camera.target = centre.to_array();
    s
}

/// One render of a strand-hair scene at its first frame: the image and the strands and
/// segments the hair drew.
pub struct LodRender {
    pub image: RgbaImage,
    pub strands: u64,
    pub segments: u64,
}

/// Render frame 0 of `scene` at `size` with the screen-space tolerance `tolerance_px`
/// (0: full detail), with ribbons: full detail's thinner strands would otherwise go to the
/// compute rasteriser under `render.strands: Auto`, and the error would be the two
/// rasterisers' difference, not the level of detail's (`kami bench raster` measures that).
pub fn render(
    gpu: &crate::gpu::Gpu,
    scene: &Scene,
    size: (u32, u32),
    tolerance_px: f64,
) -> Result<LodRender> {
    let mut scene = scene.clone();
    scene.render.lod_tolerance_px = tolerance_px;
    scene.render.strands = crate::scene::StrandRaster::Ribbons;
    stage::check_limits(gpu, &scene, size)?;
    let mut stage = Stage::new(gpu, &scene, target::OUTPUT_FORMAT, Quality::of(&scene))?;
    let out = target::Offscreen::new(gpu, size)?;
    let look = stage.look();
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("bench lod"),
        });
    stage.render(gpu, &mut enc, &out.view, size, &look)?;
    gpu.queue.submit([enc.finish()]);
    let image = out.read_rgba(gpu)?;
    let (strands, segments) = stage.system::<AnjyoSystem>().map_or((0, 0), |a| a.drawn());
    Ok(LodRender {
        image,
        strands,
        segments,
    })
}

/// One distance: full detail, full detail with another seed (the floor) and the level of
/// detail, with (tile, pixel) errors of the last two against the first.
pub struct LodPoint {
    pub k: f64,
    pub full: LodRender,
    pub lod: LodRender,
    pub lod_error: (f64, f64),
    pub floor_error: (f64, f64),
}

/// Measure the level of detail of `scene` at distance `k` (see [`at_distance`]).
pub fn measure(gpu: &crate::gpu::Gpu, scene: &Scene, k: f64, size: (u32, u32)) -> Result<LodPoint> {
    let s = at_distance(scene, k);
    let tol = scene.render.lod_tolerance_px;
    let full = render(gpu, &s, size, 0.0)?;
    let mut other = s.clone();
    other.seed += 1;
    let floor = render(gpu, &other, size, 0.0)?;
    let lod = render(gpu, &s, size, tol)?;
    Ok(LodPoint {
        k,
        lod_error: model_error(&lod.image, &full.image),
        floor_error: model_error(&floor.image, &full.image),
        full,
        lod,
    })
}

/// What the table shows and what the level of detail does not do (written under it).
const CONCLUSION: &str = "
**How it works.** One function (`src/systems/lod.rs`) serves strand hair (Anjyo) and fur. \
From the hair's bounding sphere, the eye, the field of view and the target's height in pixels \
it gives a strand share `a = min(1, d_full / d)` (`d_full`: the distance at which the sphere \
fills the frame's height; Van Gelder & Wilhelms' distance culling, which the fur used alone \
before and now takes from here) and widens the drawn strands by `1 / a`, so the summed ribbon \
area, hence each pixel's expected coverage, is that of full detail, and a drawn strand keeps \
the width in pixels it had when the head filled the frame. Strand hair also skips nodes: every \
k-th node is drawn, k the largest step whose chord error (the sagitta `k^2 l theta / 8` of k \
segments of length l turning by theta per node, in pixels at the sphere's nearest point) stays \
under `render.lod_tolerance_px` (0.5 px by default; 0 turns the whole level of detail off). \
The bench and its tests draw both images with ribbons: full detail's thinner strands would \
otherwise go to the compute rasteriser under `render.strands: Auto`, and the error would be the \
two rasterisers' difference (`kami bench raster` measures that), not the level of detail's. \
The viewer's frame-budget share multiplies on top. Where the head fills the frame (k = 1, and \
the gust scene's own camera) nothing changes, bit for bit (`tests/it/lod.rs`); the snapshot tests of \
the shipped scenes pass unchanged except `hair_and_fur_06`, where the critter is small on screen and \
its polyline fur now skips nodes (re-accepted).

**What it does not do.** The turn per node is assumed (20 degrees, `lod::NOMINAL_TURN`), not \
measured on the moving hair: a strand bent more sharply shows up to proportionally more chord \
error. Fur's ribbon coats skip nodes by the same rule (k per coat, from its longest hair); its \
tubes keep all their segments. The share is linear in the on-screen size, not chosen from the image error: \
the error above stays a few levels of 255, of the order of the floor, but is not bounded by \
construction. Drawing fewer strands does not make the simulation cheaper: every dynamic strand \
is still simulated.
";

pub fn run(gpu: &crate::gpu::Gpu, scene_path: &Path, out: &Path) -> Result<Report> {
    let scene = Scene::load(scene_path)?;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "### `kami bench lod` — {}\n\n{}\n\nScreen-space level of detail (`src/systems/lod.rs`, tolerance {} px) against full detail, {}x{} pixels, MSAA {} x supersample {}, frame 0. The camera backs away along its line of sight to k times the distance at which the hair's bounding sphere fills the frame. Errors in levels of 255 over the hair's tiles, as `kami bench fur` measures culling: *tile* = mean difference of 8x8-pixel block means (the look), *pixel* = mean per-pixel difference. The floor is full detail with another seed (the same look, other hairs).\n",
        scene_path.display(),
        provenance(),
        scene.render.lod_tolerance_px,
        SIZE.0,
        SIZE.1,
        scene.render.msaa,
        scene.render.supersample,
    );
    let _ = writeln!(
        md,
        "| k | strands drawn | segments drawn | share of segments | tile error | pixel error | floor tile | floor pixel |"
    );
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut csv = String::from(
        "k,full_strands,full_segments,lod_strands,lod_segments,tile_error,pixel_error,floor_tile_error,floor_pixel_error\n",
    );
    let (mut err, mut floor, mut share) = (Vec::new(), Vec::new(), Vec::new());
    for k in DISTANCES {
        let p = measure(gpu, &scene, k, SIZE)?;
        let seg_share = p.lod.segments as f64 / p.full.segments.max(1) as f64;
        let _ = writeln!(
            md,
            "| {k} | {} of {} | {} of {} | {:.1}% | {:.2} | {:.1} | {:.2} | {:.1} |",
            p.lod.strands,
            p.full.strands,
            p.lod.segments,
            p.full.segments,
            100.0 * seg_share,
            p.lod_error.0,
            p.lod_error.1,
            p.floor_error.0,
            p.floor_error.1,
        );
        let _ = writeln!(
            csv,
            "{k},{},{},{},{},{:.3},{:.3},{:.3},{:.3}",
            p.full.strands,
            p.full.segments,
            p.lod.strands,
            p.lod.segments,
            p.lod_error.0,
            p.lod_error.1,
            p.floor_error.0,
            p.floor_error.1
        );
        // Zero errors cannot go on a log axis: floor them at 0.01 levels.
        err.push((k, p.lod_error.0.max(0.01)));
        floor.push((k, p.floor_error.0.max(0.01)));
        share.push((k, 100.0 * seg_share));
    }
    md.push_str(CONCLUSION);
    write_report(out, "lod", &md, &csv)?;
    let img = plot::loglog(
        "Screen-space LOD against distance",
        "distance / distance filling the frame",
        "tile error (levels of 255) | segments drawn (%)",
        &[
            Series {
                name: "LOD tile error".into(),
                color: plot::palette(0),
                points: err,
            },
            Series {
                name: "floor (other seed)".into(),
                color: plot::palette(1),
                points: floor,
            },
            Series {
                name: "segments drawn, %".into(),
                color: plot::palette(2),
                points: share,
            },
        ],
        None,
    );
    let p = out.join("lod.png");
    img.save(&p).map_err(|e| crate::KamiError::Image {
        path: p.clone(),
        message: e.to_string(),
    })?;
    Ok(Report { markdown: md, csv })
}
