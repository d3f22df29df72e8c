//! The renderer's benches (no kind's): each one's options and help, derived, and how it runs.
//! `BENCHES` lists them in the order `kami bench --help` shows.

use super::{study, Entry, Study};
use crate::cli::parse::{parse_count, parse_msaa, parse_segments, parse_size, preference};
use anyhow::Result;
use clap::Parser;
use kami::bench::Report;
use kami::gpu::Gpu;
use std::path::PathBuf;

pub const BENCHES: &[Entry] = &[
    study::<Backends>(),
    study::<Scale>(),
    study::<Shadows>(),
    study::<Lod>(),
    study::<Raster>(),
    study::<Look>(),
    study::<Sdf>(),
];

/// Every shipped scene rendered on both software adapters (lavapipe over Vulkan, llvmpipe
/// over GL) and compared pixel by pixel: the margin under the snapshot tolerances; writes
/// backends.md and backends.csv.
#[derive(Parser)]
#[command(name = "backends")]
struct Backends {
    /// Folder holding the shipped scenes.
    #[arg(long, default_value_os_t = kami::scene::shipped("assets/scenes"))]
    scenes: PathBuf,
    /// Directory for the report files.
    #[arg(long, default_value = "bench_out")]
    out: PathBuf,
}

impl Study for Backends {
    const FILES: &'static [&'static str] = &["backends.md", "backends.csv"];
    fn run(self) -> Result<(Report, PathBuf)> {
        Ok((
            kami::bench::backends::run(&self.scenes, &self.out)?,
            self.out,
        ))
    }
}

/// GPU time per pass (simulation, generation, draw, resolve, whole frame) over a sweep of
/// strand counts and segments per strand, from timestamp queries (a labelled CPU-side
/// fallback where the adapter has none), and the simulation's memory bandwidth against
/// a buffer copy; writes scale.md, scale.csv and scale.png.
#[derive(Parser)]
#[command(name = "scale")]
struct Scale {
    #[arg(long, default_value_os_t = kami::scene::shipped("assets/scenes/gust.ron"))]
    scene: PathBuf,
    /// Strand counts, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "1000,10000,100000,1000000", value_parser = parse_count)]
    strands: Vec<u32>,
    /// Segments per strand, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "8,16,32,64", value_parser = parse_segments)]
    segments: Vec<u32>,
    /// Image size.
    #[arg(long, default_value = "1920x1080", value_parser = parse_size)]
    size: (u32, u32),
    /// Timed frames per point.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// Skip points with more segments than this (default: 2,000,000 on a software
    /// adapter, 64,000,000 on a GPU).
    #[arg(long)]
    max_segments: Option<u64>,
    /// Time each phase on the CPU around a wait even where the adapter has timestamp
    /// queries (to check one clock against the other).
    #[arg(long)]
    cpu_clock: bool,
    /// MSAA samples (1 or 4) instead of the scene's.
    #[arg(long, value_parser = parse_msaa)]
    msaa: Option<u32>,
    /// Supersampling per axis (1..=4) instead of the scene's.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4))]
    supersample: Option<u32>,
    /// Directory for the report files.
    #[arg(long, default_value = "bench_out")]
    out: PathBuf,
    #[arg(long)]
    software: bool,
}

impl Study for Scale {
    const FILES: &'static [&'static str] = &["scale.md", "scale.csv", "scale.png"];
    fn run(self) -> Result<(Report, PathBuf)> {
        let gpu = Gpu::headless(preference(self.software))?;
        let soft = gpu.info.device_type == wgpu::DeviceType::Cpu;
        let sweep = kami::bench::scale::Sweep {
            strands: self.strands,
            segments: self.segments,
            size: self.size,
            frames: self.frames,
            max_segments: self
                .max_segments
                .unwrap_or(if soft { 2_000_000 } else { 64_000_000 }),
            cpu_clock: self.cpu_clock,
            msaa: self.msaa,
            supersample: self.supersample,
        };
        let report = kami::bench::scale::run(&gpu, &self.scene, &sweep, &self.out)?;
        Ok((report, self.out))
    }
}

/// Hair shadows: ms per frame without shadows and with each method (volume, deep
/// opacity) on the bob, a fur scene and strips, each method's error against the f64
/// reference and the image difference between them; writes shadow_bench.md, shadow_bench.csv and
/// shadow_bench.png.
#[derive(Parser)]
#[command(name = "shadows")]
struct Shadows {
    /// The folder holding bob.ron, fur_creature.ron and strips.ron.
    #[arg(long, default_value_os_t = kami::scene::shipped("assets/scenes"))]
    scenes: PathBuf,
    /// Timed frames per row (the median is reported).
    #[arg(long, default_value_t = 7, value_parser = clap::value_parser!(u32).range(1..=100))]
    runs: u32,
    /// Directory for the report files.
    #[arg(long, default_value = "bench_out")]
    out: PathBuf,
    #[arg(long)]
    software: bool,
}

impl Study for Shadows {
    const FILES: &'static [&'static str] =
        &["shadow_bench.md", "shadow_bench.csv", "shadow_bench.png"];
    fn run(self) -> Result<(Report, PathBuf)> {
        let gpu = Gpu::headless(preference(self.software))?;
        let report = kami::bench::shadows::run(&gpu, &self.scenes, self.runs, &self.out)?;
        Ok((report, self.out))
    }
}

/// Screen-space level of detail of strand hair: image error against full detail and
/// strands/segments drawn as the head gets smaller on screen; writes lod.md, lod.csv and
/// lod.png.
#[derive(Parser)]
#[command(name = "lod")]
struct Lod {
    #[arg(long, default_value_os_t = kami::scene::shipped("assets/scenes/gust.ron"))]
    scene: PathBuf,
    /// Directory for the report files.
    #[arg(long, default_value = "bench_out")]
    out: PathBuf,
    #[arg(long)]
    software: bool,
}

impl Study for Lod {
    const FILES: &'static [&'static str] = &["lod.md", "lod.csv", "lod.png"];
    fn run(self) -> Result<(Report, PathBuf)> {
        let gpu = Gpu::headless(preference(self.software))?;
        let report = kami::bench::lod::run(&gpu, &self.scene, &self.out)?;
        Ok((report, self.out))
    }
}

/// Strand rasterisers: ribbons (MSAA 4 and 1) and the compute rasteriser for thin
/// strands, ms per drawn frame against the image error from a 64-samples-per-pixel
/// reference, and the width sweep that sets `render.strands: Auto`'s switch point; writes
/// raster.md, raster.csv, raster.png, raster_sweep.png, raster_switch.ron and each image.
#[derive(Parser)]
#[command(name = "raster")]
struct Raster {
    #[arg(long, default_value_os_t = kami::scene::shipped("assets/scenes/gust.ron"))]
    scene: PathBuf,
    /// Image size as WIDTHxHEIGHT.
    #[arg(long, value_parser = parse_size, default_value = "1280x720")]
    size: (u32, u32),
    /// The frame drawn (simulated first).
    #[arg(long, default_value_t = 15)]
    frame: u64,
    /// Timed frames per rasteriser (the median is reported).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    runs: u32,
    /// Directory for the report files.
    #[arg(long, default_value = "bench_out")]
    out: PathBuf,
    #[arg(long)]
    software: bool,
}

impl Study for Raster {
    const FILES: &'static [&'static str] = &[
        "raster.md",
        "raster.csv",
        "raster.png",
        "raster_sweep.png",
        "raster_switch.ron",
    ];
    fn run(self) -> Result<(Report, PathBuf)> {
        let gpu = Gpu::headless(preference(self.software))?;
        let (scene, out) = (&self.scene, &self.out);
        let report = kami::bench::raster::run(&gpu, scene, out, self.size, self.frame, self.runs)?;
        Ok((report, self.out))
    }
}

/// Kami against a path tracer: shipped scenes in each shading mode with and without
/// shadows, against Mitsuba 3 (its hair BSDF) rendering the same groom, camera, light and
/// size; mean FLIP, ms per frame and the image pairs; writes look.md, look.csv and the
/// pairs (docs/look.md). Needs `scripts/look-deps.sh` (Mitsuba, FLIP) first.
#[derive(Parser)]
#[command(name = "look")]
struct Look {
    /// Scenes to compare, comma separated (default: bob, fur, strips).
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<PathBuf>,
    /// Image size as WIDTHxHEIGHT (Kami's and Mitsuba's).
    #[arg(long, value_parser = parse_size, default_value = "256x256")]
    size: (u32, u32),
    /// Mitsuba's samples per pixel to start from.
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=65536))]
    spp: u32,
    /// The most samples per pixel a reference is raised to (doubling from --spp) while its
    /// noise on the hair's pixels is above half the goal; --max-spp equal to --spp keeps it
    /// (below it is refused).
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=65536))]
    max_spp: u32,
    /// Timed frames per row (the mean is reported).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// Python with Mitsuba and FLIP (scripts/look-deps.sh).
    #[arg(long, default_value = "python3")]
    python: PathBuf,
    /// Where reference renders are cached (by a hash of their inputs).
    #[arg(long, default_value = "bench_out/look-cache")]
    cache: PathBuf,
    /// Cameras, comma separated: `scene` (the scene's own) and `close` (the close-up).
    #[arg(long, value_delimiter = ',', value_parser = parse_view, default_value = "scene,close")]
    views: Vec<kami::bench::look::View>,
    /// Key lights, comma separated: `key` (the scene's), `side`, `back`.
    #[arg(long, value_delimiter = ',', value_parser = parse_lighting, default_value = "key,side,back")]
    lights: Vec<kami::bench::look::Lighting>,
    /// Directory for the report files.
    #[arg(long, default_value = "bench_out")]
    out: PathBuf,
    #[arg(long)]
    software: bool,
}

impl Study for Look {
    const FILES: &'static [&'static str] =
        &["look.md", "look.csv", "look_offsets.md", "look_offsets.csv"];
    const ALSO: Option<&'static str> = Some("the image pairs");
    fn run(self) -> Result<(Report, PathBuf)> {
        if self.max_spp < self.spp {
            return Err(kami::KamiError::Option(format!(
                "--max-spp {} is below --spp {}: a reference is raised from --spp, never cut",
                self.max_spp, self.spp
            ))
            .into());
        }
        let scenes = if self.scenes.is_empty() {
            kami::bench::look::SCENES
                .iter()
                .map(|s| kami::scene::shipped(s))
                .collect()
        } else {
            self.scenes
        };
        // Mitsuba and FLIP are checked before the GPU is opened: a missing one costs nothing.
        kami::bench::look::check_deps(&self.python)?;
        let gpu = Gpu::headless(preference(self.software))?;
        let o = kami::bench::look::Options {
            scenes,
            size: self.size,
            spp: self.spp,
            max_spp: self.max_spp,
            frames: self.frames,
            python: self.python,
            cache: self.cache,
            views: self.views,
            lights: self.lights,
        };
        Ok((kami::bench::look::run(&gpu, &o, &self.out)?, self.out))
    }
}

fn parse_view(s: &str) -> std::result::Result<kami::bench::look::View, String> {
    kami::bench::look::View::parse(s).ok_or_else(|| format!("{s:?}: a view is scene or close"))
}

fn parse_lighting(s: &str) -> std::result::Result<kami::bench::look::Lighting, String> {
    kami::bench::look::Lighting::parse(s)
        .ok_or_else(|| format!("{s:?}: a light is key, side or back"))
}

/// The mesh head's signed distance field: build time and error against the exact
/// signed distance at several grid resolutions; writes sdf.md, sdf.csv and sdf.png.
#[derive(Parser)]
#[command(name = "sdf")]
struct Sdf {
    #[arg(long, default_value_os_t = kami::scene::shipped("assets/scenes/mesh_head.ron"))]
    scene: PathBuf,
    /// Directory for the report files.
    #[arg(long, default_value = "bench_out")]
    out: PathBuf,
}

impl Study for Sdf {
    const FILES: &'static [&'static str] = &["sdf.md", "sdf.csv", "sdf.png"];
    fn run(self) -> Result<(Report, PathBuf)> {
        Ok((kami::bench::sdf::run(&self.scene, &self.out)?, self.out))
    }
}
