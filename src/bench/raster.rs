//! `kami bench raster`: the two ways of drawing strand hair, ribbons (two triangles per
//! segment, MSAA coverage) and the compute rasteriser for thin strands
//! (`shaders/common/splat.wgsl`), in time per drawn frame against the image error from a
//! reference drawn with 64 samples per pixel (ribbons, MSAA 4 x supersampling 4). Speed
//! against error, as the issue asks: a cheaper rasteriser only counts if its image is as
//! close to the reference as the one it replaces.

use super::fur::model_error;
use super::{provenance, write_report, Report};
use crate::bench::plot::{self, Series};
use crate::error::Result;
use crate::gpu::Gpu;
use crate::scene::StrandRaster;
use crate::stage::{self, target, Quality, Stage};
use crate::systems::anjyo::AnjyoSystem;
use crate::systems::Scene;
use image::RgbaImage;
use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

/// One way of drawing: the rasteriser, MSAA samples and supersampling factor.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    pub strands: StrandRaster,
    pub msaa: u32,
    pub supersample: u32,
    /// The compute rasteriser binned by tile rather than one walk per strand with global
    /// atomics (the default; the same accumulation; `AnjyoSystem::set_binned`).
    pub binned: bool,
}

impl Config {
    pub fn name(&self) -> String {
        let r = match (self.strands, self.binned) {
            (StrandRaster::Auto, _) => "auto",
            (StrandRaster::Ribbons, _) => "ribbons",
            (StrandRaster::Compute, true) => "compute (binned)",
            (StrandRaster::Compute, false) => "compute (per strand)",
        };
        format!("{r}, MSAA {} x supersample {}", self.msaa, self.supersample)
    }
}

/// What the bench compares: the viewer's default (ribbons, MSAA 4), ribbons without MSAA,
/// and the compute rasteriser over single-sampled and multisampled scene targets, walked one
/// invocation per strand (the default) and binned by tile (the same image).
pub const CONFIGS: [Config; 6] = [
    Config {
        strands: StrandRaster::Ribbons,
        msaa: 4,
        supersample: 1,
        binned: false,
    },
    Config {
        strands: StrandRaster::Ribbons,
        msaa: 1,
        supersample: 1,
        binned: false,
    },
    Config {
        strands: StrandRaster::Compute,
        msaa: 1,
        supersample: 1,
        binned: false,
    },
    Config {
        strands: StrandRaster::Compute,
        msaa: 4,
        supersample: 1,
        binned: false,
    },
    Config {
        strands: StrandRaster::Compute,
        msaa: 1,
        supersample: 1,
        binned: true,
    },
    Config {
        strands: StrandRaster::Compute,
        msaa: 4,
        supersample: 1,
        binned: true,
    },
];

/// The reference: 64 samples per pixel.
pub const REFERENCE: Config = Config {
    strands: StrandRaster::Ribbons,
    msaa: 4,
    supersample: 4,
    binned: false,
};

/// A drawn frame and the median CPU wall time of drawing it (record, submit, wait; the
/// simulation is not included).
pub struct Drawn {
    pub image: RgbaImage,
    pub ms: f64,
    /// The widest strand's width in samples as the hair saw it (`systems::raster`).
    pub width_samples: f64,
    /// Whether the hair was drawn by the compute rasteriser.
    pub compute: bool,
}

/// Draw `scene` at `frame` (simulated first) with `config`, `runs` timed times.
pub fn draw(
    gpu: &Gpu,
    scene: &Scene,
    config: Config,
    size: (u32, u32),
    frame: u64,
    runs: u32,
) -> Result<Drawn> {
    draw_share(gpu, scene, config, size, frame, runs, 1.0)
}

/// `draw` with a `share` of each group's hairs (the viewer's level of detail): 0.0001 gives
/// the frame's floor without hair (`examples/rasterbench`).
pub fn draw_share(
    gpu: &Gpu,
    scene: &Scene,
    config: Config,
    size: (u32, u32),
    frame: u64,
    runs: u32,
    share: f64,
) -> Result<Drawn> {
    let mut scene = scene.clone();
    scene.render.strands = config.strands;
    scene.render.msaa = config.msaa;
    scene.render.supersample = config.supersample;
    stage::check_limits(gpu, &scene, size)?;
    let quality = Quality::of(&scene);
    let mut stage = Stage::new(gpu, &scene, target::OUTPUT_FORMAT, quality)?;
    if let Some(a) = stage.system_mut::<AnjyoSystem>() {
        a.set_binned(config.binned);
    }
    stage.seek(gpu, frame)?;
    let out = target::Offscreen::new(gpu, size)?;
    let mut look = stage.look();
    look.lod = share;
    let mut times = Vec::new();
    // One untimed frame first: pipelines and targets are made on the first.
    for _ in 0..=runs {
        let t = Instant::now();
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        stage.render(gpu, &mut enc, &out.view, size, &look)?;
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.remove(0);
    times.sort_by(f64::total_cmp);
    let image = out.read_rgba(gpu)?;
    gpu.take_error()?;
    // The kinds with thin strands say how wide they were and what drew them.
    let (width_samples, compute) = stage
        .systems()
        .iter()
        .filter_map(|s| s.stats().raster)
        .fold((0.0f64, false), |(w, c), r| {
            (w.max(r.width_samples), c || r.compute)
        });
    Ok(Drawn {
        image,
        ms: times[times.len() / 2],
        width_samples,
        compute,
    })
}

/// Sweep each kind's scene (`SWEEP_SCENES`) over strand widths, write the table into `md`,
/// the switch points into `raster_switch.ron` and the plot into `raster_sweep.png`.
fn sweep_section(
    gpu: &Gpu,
    switches: crate::systems::raster::Switches,
    out: &Path,
    size: (u32, u32),
    frame: u64,
    runs: u32,
    md: &mut String,
) -> Result<()> {
    let software = gpu.info.device_type == wgpu::DeviceType::Cpu;
    let switch = out.join("raster_switch.ron");
    let _ = writeln!(
        md,
        "\n#### Ribbons or compute by strand width (`render.strands: Auto`)\n\nOne scene of each kind with thin strands, its strands made thinner (width factor) and its camera zoomed in (zoom: the field of view narrowed, a close-up), each drawn at the scene's MSAA x supersample 1 by both rasterisers and by the reference. *Width* is the widest strand's width in samples at the hair's nearest point, as `Auto` measures it (`src/systems/raster.rs`). The compute rasteriser *wins* a point when it is faster and neither error is larger than the ribbons'.\n"
    );
    let _ = writeln!(
        md,
        "| kind (scene) | width factor | zoom | width (samples) | ribbons ms | compute ms | ribbons tile / pixel error | compute tile / pixel error | compute wins |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|---:|---:|:---:|");
    // This class's points so far: a kind whose compute rasteriser could not run here keeps
    // its previous point rather than being reset to "never".
    let previous = if software {
        &switches.software
    } else {
        &switches.hardware
    };
    let mut up_to = previous
        .as_ref()
        .map(|p| p.compute_up_to.clone())
        .unwrap_or_default();
    let mut unmeasured = Vec::new();
    let mut series = Vec::new();
    for (k, (kind, path)) in SWEEP_SCENES.iter().enumerate() {
        let scene = Scene::load(crate::scene::shipped(path))?;
        let measured = sweep(gpu, &scene, size, frame, runs)?;
        for m in &measured {
            let _ = writeln!(
                md,
                "| {kind} ({path}) | {} | {} | {:.2} | {:.1} | {:.1} | {:.2} / {:.2} | {:.2} / {:.2} | {} |",
                m.point.width,
                m.point.zoom,
                m.width_samples,
                m.ribbons.0,
                m.compute.0,
                m.ribbons.1 .0,
                m.ribbons.1 .1,
                m.compute.1 .0,
                m.compute.1 .1,
                if m.compute_wins() { "yes" } else { "no" }
            );
        }
        if measured.iter().any(|m| m.compute.0.is_finite()) {
            up_to.insert(kind.to_string(), switch_point(&measured));
        } else {
            unmeasured.push(*kind);
        }
        let w = |m: &Measured| m.width_samples.max(0.01);
        for (i, (what, pick)) in [
            (
                "ribbons ms",
                (|m: &Measured| m.ribbons.0) as fn(&Measured) -> f64,
            ),
            ("compute ms", |m: &Measured| m.compute.0),
            ("ribbons error", |m: &Measured| m.ribbons.1 .1.max(0.01)),
            ("compute error", |m: &Measured| m.compute.1 .1.max(0.01)),
        ]
        .into_iter()
        .enumerate()
        {
            series.push(Series {
                name: format!("{kind} {what}"),
                color: plot::palette(4 * k + i),
                points: measured.iter().map(|m| (w(m), pick(m))).collect(),
            });
        }
    }
    let class = if software { "software" } else { "hardware" };
    let points: Vec<String> = up_to
        .iter()
        .map(|(k, w)| {
            if *w == 0.0 {
                format!("{k}: never (it wins at no width measured: ribbons)")
            } else {
                format!("{k}: up to {w:.3} samples wide")
            }
        })
        .collect();
    let _ = writeln!(
        md,
        "\n**Switch points on this adapter class ({class}), the compute rasteriser for** {}. Written to `raster_switch.ron` beside this report; `docs/raster_switch.ron` is compiled into Kami (`src/systems/raster.rs`), with 10 % hysteresis either side.\n",
        points.join("; ")
    );
    if !unmeasured.is_empty() {
        let _ = writeln!(
            md,
            "The compute rasteriser could not draw over these targets for {} (GL with MSAA): their points are kept from the file, not measured here.\n",
            unmeasured.join(", ")
        );
    }
    // Nothing measured here: the points still name the adapter that measured them.
    let adapter = match previous.as_ref() {
        Some(p) if unmeasured.len() == SWEEP_SCENES.len() => p.adapter.clone(),
        _ => gpu.describe(),
    };
    let text = switch_file(
        switches,
        software,
        crate::systems::raster::SwitchPoint {
            adapter,
            compute_up_to: up_to,
        },
    );
    std::fs::write(&switch, text).map_err(|source| crate::KamiError::Io {
        path: switch.clone(),
        source,
    })?;
    let img = plot::loglog(
        "Ribbons and compute by strand width",
        "widest strand (samples)",
        "ms per drawn frame; pixel error (levels of 255)",
        &series,
        None,
    );
    let p = out.join("raster_sweep.png");
    img.save(&p).map_err(|e| crate::KamiError::Image {
        path: p.clone(),
        message: e.to_string(),
    })
}

const CONCLUSION: &str = "
**How the compute rasteriser draws** (`shaders/common/splat.wgsl`, f64 reference in \
`src/systems/splat.rs` with each kind's node shading). By default one invocation per strand walks its segments, \
adding to the accumulation with global atomics. *Binned* (not the default until a hardware \
GPU shows it faster): one invocation per drawn segment counts the 16x16-sample tiles its \
sample rectangle reaches, a scan turns the counts into list offsets, the segments are listed \
under their tiles, and one workgroup per tile walks its list clipped to the tile into \
workgroup memory, then adds each sample's words to the accumulation once (a tile whose list \
does not fit is drawn directly, never dropped). The words are integer sums, so the binned \
image is the per-strand walk's word for word (`tests/it/splat.rs`); on a software adapter, \
where atomics are cheap, binning costs more (each segment's nodes are shaded again in every \
tile it reaches). A segment is walked one sample column (or row) at a time; in each column a segment of width w samples covers the vertical band of \
thickness `w sqrt(1 + slope^2)` about its centre line, and each sample gets its exact share of \
that band as coverage `a` (a strand's coverages add up to its length times its width). Nodes are \
shaded and sized by the same WGSL as the kind's ribbons. A sample keeps, \
with u32 atomics in fixed point, the depth-weighted sums of colour and coverage and the sum of \
`-ln(1 - a)`; the resolve composites the weighted mean colour with coverage `1 - prod(1 - a)` \
over the scene. Occlusion by the head is a depth test against the scene pass's depth.

**What it does not do.** Hairs of one sample are blended by a depth weight, not sorted: the \
nearest hair dominates less than it would opaque. Strands wider than 16 samples are cut to 16 \
(ribbons suit close-ups). Anjyo's strands and fur's line, polyline and curve coats have it; \
fur's tubes, the strips and the wisps draw as before, and hair drawn as triangles in front of \
splatted hair is composited under it.
";

/// A point of the width sweep: strands drawn `width` times their own width, through a
/// camera zoomed `zoom` times (the field of view narrowed: a close-up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepPoint {
    pub width: f64,
    pub zoom: f64,
}

/// Thin hair (the scene's strands made thinner) up to close-ups (the camera zoomed in).
pub const SWEEP: [SweepPoint; 7] = [
    SweepPoint {
        width: 0.25,
        zoom: 1.0,
    },
    SweepPoint {
        width: 0.5,
        zoom: 1.0,
    },
    SweepPoint {
        width: 1.0,
        zoom: 1.0,
    },
    SweepPoint {
        width: 1.0,
        zoom: 2.0,
    },
    SweepPoint {
        width: 1.0,
        zoom: 4.0,
    },
    SweepPoint {
        width: 1.0,
        zoom: 8.0,
    },
    SweepPoint {
        width: 1.0,
        zoom: 16.0,
    },
];

impl SweepPoint {
    /// `scene` with its strands (Anjyo's groups, fur's coats) widened and its camera zoomed.
    pub fn apply(&self, scene: &Scene) -> Scene {
        let mut s = scene.clone();
        for g in s.groups_mut() {
            g.material.width *= self.width;
        }
        if let Some(f) = s.fur_mut().as_mut() {
            f.coats
                .iter_mut()
                .for_each(|c| c.material.width *= self.width);
        }
        let half = (0.5 * s.camera.fov_y).to_radians();
        s.camera.fov_y = 2.0 * (half.tan() / self.zoom).atan().to_degrees();
        s
    }
}

/// One sweep point measured: the strands' width in samples (as `Auto` sees it), and each
/// rasteriser's ms and (tile, pixel) error against the reference.
#[derive(Clone, Copy, Debug)]
pub struct Measured {
    pub point: SweepPoint,
    pub width_samples: f64,
    pub ribbons: (f64, (f64, f64)),
    pub compute: (f64, (f64, f64)),
}

impl Measured {
    /// The compute rasteriser is faster and no less accurate (tile and pixel error) than the
    /// ribbons.
    pub fn compute_wins(&self) -> bool {
        let (r, c) = (self.ribbons, self.compute);
        c.0 < r.0 && c.1 .0 <= r.1 .0 && c.1 .1 <= r.1 .1
    }
}

/// `Auto`'s switch point from a sweep: the widest width in samples up to which the compute
/// rasteriser wins at every point measured (0 when it loses at the thinnest).
pub fn switch_point(measured: &[Measured]) -> f64 {
    let mut m: Vec<&Measured> = measured
        .iter()
        .filter(|m| m.width_samples.is_finite())
        .collect();
    m.sort_by(|a, b| a.width_samples.total_cmp(&b.width_samples));
    let mut up_to = 0.0;
    for p in m {
        if !p.compute_wins() {
            break;
        }
        up_to = p.width_samples;
    }
    up_to
}

/// The kinds' sweep scenes: one of each kind with thin strands.
pub const SWEEP_SCENES: [(&str, &str); 2] = [
    ("anjyo", "assets/scenes/gust.ron"),
    ("fur", "assets/scenes/fur.ron"),
];

/// The switch points at `path` (none when there is no file yet), read before a sweep so a
/// file that does not parse fails before the work, not after.
pub fn read_switches(path: &Path) -> Result<crate::systems::raster::Switches> {
    match std::fs::read_to_string(path) {
        Ok(text) => ron::from_str(&text).map_err(|e| crate::KamiError::Parse {
            path: path.display().to_string(),
            line: e.span.start.line,
            col: e.span.start.col,
            message: format!(
                "{} (a switch-point file from `kami bench raster`; remove it to start afresh)",
                e.code
            ),
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            Ok(crate::systems::raster::Switches {
                software: None,
                hardware: None,
            })
        }
        Err(source) => Err(crate::KamiError::Io {
            path: path.to_path_buf(),
            source,
        }),
    }
}

/// `s` with this adapter class's switch points replaced by `point` (the other class's
/// kept), as RON.
pub fn switch_file(
    mut s: crate::systems::raster::Switches,
    software: bool,
    point: crate::systems::raster::SwitchPoint,
) -> String {
    use crate::systems::raster::SwitchPoint;
    if software {
        s.software = Some(point);
    } else {
        s.hardware = Some(point);
    }
    let entry = |p: &Option<SwitchPoint>| match p {
        Some(p) => {
            let kinds: Vec<String> = p
                .compute_up_to
                .iter()
                .map(|(k, w)| format!("{k:?}: {w:.3}"))
                .collect();
            format!(
                "Some((\n        adapter: {:?},\n        compute_up_to: {{{}}},\n    ))",
                p.adapter,
                kinds.join(", ")
            )
        }
        None => "None".into(),
    };
    format!(
        "// Written by `kami bench raster`: per adapter class and kind, the widest strand, in\n\
         // samples, that `render.strands: Auto` draws with the compute rasteriser\n\
         // (src/systems/raster.rs).\n\
         (\n    software: {},\n    hardware: {},\n)\n",
        entry(&s.software),
        entry(&s.hardware)
    )
}

/// Measure every sweep point of `scene` at `size`: the reference, then the ribbons and the
/// compute rasteriser at the scene's MSAA.
pub fn sweep(
    gpu: &Gpu,
    scene: &Scene,
    size: (u32, u32),
    frame: u64,
    runs: u32,
) -> Result<Vec<Measured>> {
    let msaa = scene.render.msaa;
    let with = |strands| Config {
        strands,
        msaa,
        supersample: 1,
        binned: false,
    };
    SWEEP
        .iter()
        .map(|p| {
            let s = p.apply(scene);
            let reference = draw(gpu, &s, REFERENCE, size, frame, 1)?;
            let r = draw(gpu, &s, with(StrandRaster::Ribbons), size, frame, runs)?;
            let c = draw(gpu, &s, with(StrandRaster::Compute), size, frame, runs)?;
            Ok(Measured {
                point: *p,
                width_samples: c.width_samples,
                ribbons: (r.ms, model_error(&r.image, &reference.image)),
                // Where the adapter cannot splat over these targets (GL with MSAA) the
                // ribbons drew: no compute figures, and compute wins nowhere.
                compute: if c.compute {
                    (c.ms, model_error(&c.image, &reference.image))
                } else {
                    (f64::NAN, (f64::NAN, f64::NAN))
                },
            })
        })
        .collect()
}

pub fn run(
    gpu: &Gpu,
    scene_path: &Path,
    out: &Path,
    size: (u32, u32),
    frame: u64,
    runs: u32,
) -> Result<Report> {
    let scene = Scene::load(scene_path)?;
    // Before any work: a switch-point file that does not parse fails now.
    let switches = read_switches(&out.join("raster_switch.ron"))?;
    let reference = draw(gpu, &scene, REFERENCE, size, frame, 1)?;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "### `kami bench raster` — {}\n\n{}\n\nAdapter: **{}**. Frame {frame} (simulated first), {}x{} pixels. Time: CPU wall of one drawn frame (record, submit, wait for the GPU; no simulation), median of {runs}. Error against the reference ({}, {:.0} ms) in levels of 255 over the hair's 8x8 tiles, as `kami bench lod`: *tile* = mean difference of tile means (the look), *pixel* = mean per-pixel difference.\n",
        scene_path.display(),
        provenance(),
        gpu.describe(),
        size.0,
        size.1,
        REFERENCE.name(),
        reference.ms,
    );
    let _ = writeln!(
        md,
        "| rasteriser | ms per frame | tile error | pixel error |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|");
    let mut csv = String::from("strands,binned,msaa,supersample,ms,tile_error,pixel_error\n");
    let mut series = Vec::new();
    for (i, c) in CONFIGS.iter().enumerate() {
        let d = draw(gpu, &scene, *c, size, frame, runs)?;
        let (tile, pixel) = model_error(&d.image, &reference.image);
        let _ = writeln!(
            md,
            "| {} | {:.1} | {:.2} | {:.2} |",
            c.name(),
            d.ms,
            tile,
            pixel
        );
        let _ = writeln!(
            csv,
            "{:?},{},{},{},{:.3},{:.4},{:.4}",
            c.strands, c.binned, c.msaa, c.supersample, d.ms, tile, pixel
        );
        series.push(Series {
            name: c.name(),
            color: plot::palette(i),
            points: vec![(d.ms, pixel.max(0.01))],
        });
        let p = out.join(format!("raster_{i}.png"));
        std::fs::create_dir_all(out).map_err(|source| crate::KamiError::Io {
            path: out.to_path_buf(),
            source,
        })?;
        d.image.save(&p).map_err(|e| crate::KamiError::Image {
            path: p.clone(),
            message: e.to_string(),
        })?;
    }
    sweep_section(gpu, switches, out, size, frame, runs, &mut md)?;
    md.push_str(CONCLUSION);
    write_report(out, "raster", &md, &csv)?;
    let img = plot::loglog(
        "Strand rasterisers: time against image error",
        "ms per drawn frame",
        "pixel error against 64 samples/pixel (levels of 255)",
        &series,
        None,
    );
    let p = out.join("raster.png");
    img.save(&p).map_err(|e| crate::KamiError::Image {
        path: p.clone(),
        message: e.to_string(),
    })?;
    Ok(Report { markdown: md, csv })
}
