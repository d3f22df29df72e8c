//! The `kami` command line: render scenes to PNG and run the benchmarks.

use anyhow::{bail, Result};
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use kami::gpu::{Gpu, Preference};
use std::path::PathBuf;

mod anim;
mod output;

#[derive(Parser)]
#[command(
    name = "kami",
    version,
    about = "Kami (髪): GPU hair, fur and toon-hair viewer and simulator"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Groom a scene on the GPU and render it to a PNG, or render its animation.
    Render {
        /// Scene file (RON), e.g. assets/scenes/bob.ron.
        scene: PathBuf,
        /// Output: a PNG file for a still; a directory for `--frames` (numbered PNGs).
        #[arg(short, long)]
        out: Option<PathBuf>,
        /// Render an animation: frames A..B (inclusive; frame 0 is the groomed rest pose).
        /// Scenes without dynamics render the same still each frame.
        #[arg(long, value_parser = parse_frames)]
        frames: Option<(u32, u32)>,
        /// With --frames: also write an animated GIF here.
        #[arg(long)]
        gif: Option<PathBuf>,
        /// With --frames: also write an animated PNG (APNG) here.
        #[arg(long)]
        apng: Option<PathBuf>,
        /// Playback rate of --gif and --apng, frames per second (default: a played cache's
        /// own rate, else 10).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1000))]
        fps: Option<u32>,
        /// Image size as WIDTHxHEIGHT (default: the scene's render.size).
        #[arg(long, value_parser = parse_size)]
        size: Option<(u32, u32)>,
        /// MSAA samples, 1 or 4 (default: the scene's render.msaa).
        #[arg(long, value_parser = parse_msaa)]
        msaa: Option<u32>,
        /// Supersampling factor per axis, 1 to 4 (default: the scene's render.supersample).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4))]
        supersample: Option<u32>,
        /// How strand hair is rasterised: ribbons or compute (default: the scene's
        /// render.strands).
        #[arg(long, value_parser = parse_strands)]
        strands: Option<kami::scene::StrandRaster>,
        /// Change a setting as `kami view --set` does, through the same code: [N:]KEY=VALUE
        /// with the viewer's keys (see `kami view --help`), applied at frame N (default 0;
        /// N > 0 needs --frames) after the flags above. Keys that drive only the window (play,
        /// lod, seek, save, export, mouse.*) are refused. An edit that rebuilds a system
        /// restarts the motion from rest, as in the viewer. Repeatable.
        #[arg(long)]
        set: Vec<String>,
        /// Prefer a software adapter (llvmpipe/lavapipe) even when a GPU is present.
        #[arg(long)]
        software: bool,
    },
    /// Open the interactive viewer (default scene: the wind gust, hair in motion).
    View {
        /// Scene file (RON); without it, the built-in gust scene.
        scene: Option<PathBuf>,
        /// Window size (logical pixels) as WIDTHxHEIGHT.
        #[arg(long, value_parser = parse_size, default_value = "1280x720")]
        size: (u32, u32),
        /// Close the window after N frames (scripts and tests).
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
        exit_after_frames: Option<u64>,
        /// Write a PNG of the whole window (scene and panels) at the last frame (or frame 60
        /// without --exit-after-frames).
        #[arg(long)]
        screenshot: Option<PathBuf>,
        /// Write a PNG of the window at frame N: N:FILE (repeatable).
        #[arg(long, value_parser = parse_frame_path)]
        screenshot_at: Vec<(u64, PathBuf)>,
        /// Change a setting while running, through the panels' path: [N:]KEY=VALUE, applied
        /// at frame N (default 0). Keys: color=r,g,b width ks shininess rigidity wind=x,y,z
        /// gravity=x,y,z stiffness=root,tip damping pseudo=on|off msaa supersample
        /// strands=ribbons|compute play=on|off
        /// lod=share.
        #[arg(long)]
        set: Vec<String>,
        /// Prefer a software adapter even when a GPU is present.
        #[arg(long)]
        software: bool,
        /// Hide the panels: the scene fills the window (captures to compare with
        /// `kami render`; drawn frame N at the default time scale shows frame N).
        #[arg(long)]
        no_panels: bool,
        /// Start with live reload off: by default the viewer reloads the scene when its
        /// file, or a file it names (mesh, strand file, capture, EFF), is saved (the Files
        /// panel switches it).
        #[arg(long)]
        no_watch: bool,
        /// Reload the scene file from scratch every N frames (long-run leak checks; the
        /// built-in scene reloads from assets/scenes/gust.ron).
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
        reload_every: Option<u64>,
        /// Write resident memory every 50 frames to this CSV; the summary line at exit says
        /// how it moved.
        #[arg(long)]
        memory_log: Option<PathBuf>,
    },
    /// Benchmarks: print throughput and accuracy tables.
    Bench {
        #[command(subcommand)]
        which: Bench,
    },
    /// Draw a toon-wisp skeleton with two fingertips (Sakai section 6): track a depth
    /// sequence (depth_0000.png ... and camera.ron) and print the skeleton as RON.
    Fingers {
        /// Directory of the depth sequence, e.g. assets/depth/hand.
        #[arg(required_unless_present = "synthesize")]
        dir: Option<PathBuf>,
        /// Write the synthetic hand sequence into this directory instead of tracking.
        #[arg(long, conflicts_with_all = ["dir", "out"])]
        synthesize: Option<PathBuf>,
        /// Also write the skeleton to this file.
        #[arg(short, long)]
        out: Option<PathBuf>,
    },
    /// Convert a strand file: `.hair` (Cem Yuksel), `.obj` (polylines) or `.usda` (USD
    /// BasisCurves), either way, or `.abc` (Alembic curves) in (docs/formats.md says what
    /// each keeps); or write a scene's
    /// hair (a `.ron` input) at a frame: Anjyo strands, fur and strip centre lines.
    Convert {
        /// Strand file or scene (`.ron`) to read.
        input: PathBuf,
        /// Strand file to write; the extension picks the format.
        output: PathBuf,
        /// Multiply every point (and width) by this factor, e.g. 0.1 for mm to cm.
        #[arg(long, default_value_t = 1.0)]
        scale: f32,
        /// With a scene input: the frame whose hair is written (0 is the groomed rest pose;
        /// later frames are simulated first).
        #[arg(long, default_value_t = 0)]
        frame: u64,
        /// With a scene input: prefer a software adapter even when a GPU is present.
        #[arg(long)]
        software: bool,
        /// With an Alembic or USD input: the time in seconds whose sample is read (Alembic:
        /// the nearest one; USD: the value at that time); the first sample without it.
        #[arg(long)]
        time: Option<f64>,
    },
}

#[derive(Subcommand)]
enum Bench {
    /// Every shipped scene rendered on both software adapters (lavapipe over Vulkan, llvmpipe
    /// over GL) and compared pixel by pixel: the margin under the snapshot tolerances; writes
    /// backends.md and backends.csv.
    Backends {
        /// Folder holding the shipped scenes.
        #[arg(long, default_value_os_t = kami::scene::shipped("assets/scenes"))]
        scenes: PathBuf,
        /// Directory for the report files.
        #[arg(long, default_value = "bench_out")]
        out: PathBuf,
    },
    /// GPU time per pass (simulation, generation, draw, resolve, whole frame) over a sweep of
    /// strand counts and segments per strand, from timestamp queries (a labelled CPU-side
    /// fallback where the adapter has none), and the simulation's memory bandwidth against
    /// a buffer copy; writes scale.md, scale.csv and scale.png.
    Scale {
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
    },
    /// Hair shadows: ms per frame without shadows and with each method (volume, deep
    /// opacity) on the bob, a fur scene and strips, each method's error against the f64
    /// reference and the image difference between them; writes shadow_bench.md, shadow_bench.csv and
    /// shadow_bench.png.
    Shadows {
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
    },
    /// Screen-space level of detail of strand hair: image error against full detail and
    /// strands/segments drawn as the head gets smaller on screen; writes lod.md, lod.csv and
    /// lod.png.
    Lod {
        #[arg(long, default_value_os_t = kami::scene::shipped("assets/scenes/gust.ron"))]
        scene: PathBuf,
        /// Directory for the report files.
        #[arg(long, default_value = "bench_out")]
        out: PathBuf,
        #[arg(long)]
        software: bool,
    },
    /// Strand rasterisers: ribbons (MSAA 4 and 1) and the compute rasteriser for thin
    /// strands, ms per drawn frame against the image error from a 64-samples-per-pixel
    /// reference; writes raster.md, raster.csv, raster.png and each image.
    Raster {
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
    },
    /// Kami against a path tracer: shipped scenes in each shading mode with and without
    /// shadows, against Mitsuba 3 (its hair BSDF) rendering the same groom, camera, light and
    /// size; mean FLIP, ms per frame and the image pairs; writes look.md, look.csv and the
    /// pairs (docs/look.md). Needs `scripts/look-deps.sh` (Mitsuba, FLIP) first.
    Look {
        /// Scenes to compare, comma separated (default: bob, fur, strips).
        #[arg(long, value_delimiter = ',')]
        scenes: Vec<PathBuf>,
        /// Image size as WIDTHxHEIGHT (Kami's and Mitsuba's).
        #[arg(long, value_parser = parse_size, default_value = "256x256")]
        size: (u32, u32),
        /// Mitsuba's samples per pixel.
        #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=65536))]
        spp: u32,
        /// Timed frames per row (the mean is reported).
        #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=1000))]
        frames: u32,
        /// Python with Mitsuba and FLIP (scripts/look-deps.sh).
        #[arg(long, default_value = "python3")]
        python: PathBuf,
        /// Where reference renders are cached (by a hash of their inputs).
        #[arg(long, default_value = "bench_out/look-cache")]
        cache: PathBuf,
        /// Directory for the report files.
        #[arg(long, default_value = "bench_out")]
        out: PathBuf,
        #[arg(long)]
        software: bool,
    },
    /// The mesh head's signed distance field: build time and error against the exact
    /// signed distance at several grid resolutions; writes sdf.md, sdf.csv and sdf.png.
    Sdf {
        #[arg(long, default_value_os_t = kami::scene::shipped("assets/scenes/mesh_head.ron"))]
        scene: PathBuf,
        /// Directory for the report files.
        #[arg(long, default_value = "bench_out")]
        out: PathBuf,
    },
}

fn parse_count(s: &str) -> Result<u32, String> {
    let n: u32 = s
        .trim()
        .replace('_', "")
        .parse()
        .map_err(|_| format!("strand count {s:?} is not a whole number"))?;
    if n == 0 || n as u64 > kami::scene::MAX_STRANDS {
        return Err(format!(
            "strand count {n} must be between 1 and {}",
            kami::scene::MAX_STRANDS
        ));
    }
    Ok(n)
}

fn parse_segments(s: &str) -> Result<u32, String> {
    let n: u32 = s
        .trim()
        .parse()
        .map_err(|_| format!("segment count {s:?} is not a whole number"))?;
    if n == 0 || n > kami::scene::MAX_SEGMENTS {
        return Err(format!(
            "segments per strand {n} must be between 1 and {}",
            kami::scene::MAX_SEGMENTS
        ));
    }
    Ok(n)
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("size {s:?} must look like 1280x720"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in {s:?}"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in {s:?}"))?;
    if w == 0 || h == 0 || w > kami::scene::MAX_SIZE || h > kami::scene::MAX_SIZE {
        return Err(format!(
            "size {s:?} must be between 1x1 and {0}x{0}",
            kami::scene::MAX_SIZE
        ));
    }
    Ok((w, h))
}

/// "N:FILE".
fn parse_frame_path(s: &str) -> Result<(u64, PathBuf), String> {
    let (n, p) = s
        .split_once(':')
        .ok_or_else(|| format!("{s:?} must look like 30:shot.png"))?;
    let n: u64 = n
        .trim()
        .parse()
        .map_err(|_| format!("bad frame {n:?} in {s:?}: must look like 30:shot.png"))?;
    if p.trim().is_empty() {
        return Err(format!("no file name in {s:?}: must look like 30:shot.png"));
    }
    Ok((n, PathBuf::from(p)))
}

/// 1 or 4: the sample counts every adapter Kami runs on supports.
/// `ribbons` or `compute` (`render.strands`).
fn parse_strands(s: &str) -> Result<kami::scene::StrandRaster, String> {
    kami::scene::StrandRaster::parse(s)
}

fn parse_msaa(s: &str) -> Result<u32, String> {
    match s.trim() {
        "1" => Ok(1),
        "4" => Ok(4),
        _ => Err(format!("{s:?} is not a sample count Kami uses: use 1 or 4")),
    }
}

/// "A..B" (inclusive).
fn parse_frames(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("frames {s:?} must look like 0..40"))?;
    let a: u32 = a
        .trim()
        .parse()
        .map_err(|_| format!("bad first frame in {s:?}"))?;
    let b: u32 = b
        .trim()
        .trim_start_matches('=')
        .parse()
        .map_err(|_| format!("bad last frame in {s:?}"))?;
    if b < a || b > 1_000_000 {
        return Err(format!("frames {s:?}: need first <= last <= 1000000"));
    }
    Ok((a, b))
}

fn preference(software: bool) -> Preference {
    if software {
        Preference::Software
    } else {
        Preference::Hardware
    }
}

/// A user's mistake prints one clear message (the error and its causes, `{:#}`) and exits
/// with status 1: returning the error from `main` would print anyhow's captured backtrace
/// too whenever `RUST_BACKTRACE` is set.
fn main() -> std::process::ExitCode {
    env_logger::Builder::from_env(
        env_logger::Env::default().default_filter_or("warn,wgpu_hal::gles::egl=off"),
    )
    .init();
    let matches = cli().get_matches();
    let done = match kind_bench(&matches) {
        Some((bench, args)) => run_kind_bench(bench, args),
        None => run(Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())),
    };
    match done {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// The command line: the derived commands, and under `bench` one subcommand per entry of
/// the kinds' bench table (`kami::bench::kinds::KIND_BENCHES`), so the CLI names no kind.
fn cli() -> clap::Command {
    use kami::bench::kinds::KIND_BENCHES;
    Cli::command().mut_subcommand("bench", |b| {
        KIND_BENCHES
            .iter()
            .fold(b, |b, k| b.subcommand(kind_bench_command(k)))
    })
}

/// `kami bench <name>` for one kind's bench: its input, `--frames` where it takes one,
/// `--out` and `--software`.
fn kind_bench_command(k: &kami::bench::kinds::KindBench) -> clap::Command {
    use clap::{value_parser, Arg, ArgAction};
    let (input, value, default, help) = k.input;
    let mut c = clap::Command::new(k.name).about(k.about).arg(
        Arg::new("input")
            .long(input)
            .value_name(value)
            // The shipped default found from any directory (`scene::shipped`); leaked once,
            // as clap keeps a default for the program's life.
            .default_value(&*Box::leak(
                kami::scene::shipped(default)
                    .into_os_string()
                    .into_boxed_os_str(),
            ))
            .value_parser(value_parser!(PathBuf))
            .help(help),
    );
    if let Some((frames, help)) = k.frames {
        c = c.arg(
            Arg::new("frames")
                .long("frames")
                .value_name("FRAMES")
                .default_value(frames)
                .value_parser(value_parser!(u32).range(1..=1000))
                .help(help),
        );
    }
    c.arg(
        Arg::new("out")
            .long("out")
            .value_name("OUT")
            .default_value("bench_out")
            .value_parser(value_parser!(PathBuf))
            .help(k.out),
    )
    .arg(
        Arg::new("software")
            .long("software")
            .action(ArgAction::SetTrue),
    )
}

/// The kind's bench the command line asks for, if it does.
fn kind_bench(
    m: &clap::ArgMatches,
) -> Option<(&'static kami::bench::kinds::KindBench, &clap::ArgMatches)> {
    let ("bench", b) = m.subcommand()? else {
        return None;
    };
    let (name, args) = b.subcommand()?;
    let bench = kami::bench::kinds::KIND_BENCHES
        .iter()
        .find(|k| k.name == name)?;
    Some((bench, args))
}

fn run_kind_bench(k: &kami::bench::kinds::KindBench, m: &clap::ArgMatches) -> Result<()> {
    let path = |id: &str| {
        m.get_one::<PathBuf>(id)
            .cloned()
            .ok_or_else(|| anyhow::anyhow!("kami bench {}: no --{id}", k.name))
    };
    let (input, out) = (path("input")?, path("out")?);
    // Benches without `--frames` get 1 (unused by them).
    let frames = m.try_get_one::<u32>("frames").ok().flatten().copied();
    let frames = frames.unwrap_or(1);
    let gpu = Gpu::headless(preference(m.get_flag("software")))?;
    let report = (k.run)(&gpu, &input, frames, &out)?;
    println!("{}", report.markdown);
    let files: Vec<String> = k
        .files
        .iter()
        .map(|f| format!("{}/{f}", out.display()))
        .collect();
    println!("wrote {}", files.join(", "));
    Ok(())
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render {
            scene,
            out,
            frames,
            gif,
            apng,
            fps,
            size,
            msaa,
            supersample,
            strands,
            set,
            software,
        } => {
            let mut s = kami::Scene::load(&scene)?;
            if let Some(m) = msaa {
                s.render.msaa = m;
            }
            if let Some(r) = strands {
                s.render.strands = r;
            }
            if let Some(f) = supersample {
                s.render.supersample = f;
            }
            kami::systems::scene::validate(&s)?;
            let sets = set
                .iter()
                .map(|s| kami::app::params::parse_set(s))
                .collect::<kami::Result<Vec<_>>>()?;
            let (s, edits) = kami::app::params::scripted(s, &sets)?;
            if let Some((f, _)) = edits.first() {
                match frames {
                    None => {
                        bail!("--set {f}:...: a still is frame 0; a later frame needs --frames")
                    }
                    Some((_, last)) if edits.iter().any(|(f, _)| *f > u64::from(last)) => {
                        bail!("--set: a frame after {last}, the last one rendered, is never drawn")
                    }
                    _ => {}
                }
            }
            let size = size.unwrap_or(s.render.size);
            // Every output is checked before the GPU work, so a typo costs nothing.
            match frames {
                None => {
                    if gif.is_some() || apng.is_some() {
                        bail!("--gif and --apng need --frames A..B");
                    }
                    let path = out.clone().unwrap_or_else(|| PathBuf::from("kami.png"));
                    output::check_file("--out", &path, &["png"])?;
                }
                Some(_) => {
                    output::prepare_dir("--out", out.as_deref().unwrap_or("frames".as_ref()))?;
                    if let Some(g) = &gif {
                        output::check_file("--gif", g, &["gif"])?;
                    }
                    if let Some(a) = &apng {
                        output::check_file("--apng", a, &["png", "apng"])?;
                    }
                }
            }
            let gpu = Gpu::headless(preference(software))?;
            let t = std::time::Instant::now();
            let (hairs, segs) = s.counts();
            // What each kind adds to the counts (toon wisps, strips), in `KINDS` order.
            let mut segs = format!("{segs} segments");
            for kind in kami::systems::KINDS {
                if let Some(more) = (kind.summary)(&s) {
                    segs = format!("{segs}, {more}");
                }
            }
            match frames {
                None => {
                    let out = out.unwrap_or_else(|| PathBuf::from("kami.png"));
                    let img = kami::stage::render_scene(&gpu, &s, size)?;
                    output::save_png(&img, &out)?;
                    println!(
                        "{}: {hairs} hairs, {segs}, {}x{} on {} in {:.2} s",
                        out.display(),
                        size.0,
                        size.1,
                        gpu.describe(),
                        t.elapsed().as_secs_f64()
                    );
                }
                Some((first, last)) => {
                    let moves = kami::systems::KINDS.iter().any(|k| (k.moves)(&s));
                    if !moves {
                        log::warn!(
                            "{} has no dynamics: every frame is the same still",
                            scene.display()
                        );
                    }
                    let dir = out.unwrap_or_else(|| PathBuf::from("frames"));
                    let count = last - first + 1;
                    let fps = fps.unwrap_or_else(|| {
                        s.cache_fps()
                            .map_or(10, |f| (f.round() as u32).clamp(1, 1000))
                    });
                    let mut sinks =
                        anim::Sinks::new(gif.as_deref(), apng.as_deref(), size, count, fps)?;
                    let mut progress = anim::Progress::new(count);
                    let capped = kami::stage::render_animation_edited(
                        &gpu,
                        &s,
                        &edits,
                        size,
                        first..=last,
                        |f, img| {
                            let path = dir.join(format!("frame_{f:04}.png"));
                            output::save_png(&img, &path).map_err(|e| kami::KamiError::Image {
                                path: path.clone(),
                                message: format!("{e:#}"),
                            })?;
                            sinks.push(&img).map_err(|e| kami::KamiError::Image {
                                path: path.clone(),
                                message: e.to_string(),
                            })?;
                            progress.tick();
                            Ok(())
                        },
                    )?;
                    sinks.finish()?;
                    progress.done();
                    if capped > 0 {
                        eprintln!(
                            "warning: {capped} frame(s) needed more than dynamics.max_substeps substeps; the solver clamped \
                             the angular step there (raise max_substeps or lower dt for accuracy)"
                        );
                    }
                    println!(
                        "{}: frames {first}..{last} ({hairs} hairs, {segs}, {}x{}) on {} in {:.2} s",
                        dir.display(),
                        size.0,
                        size.1,
                        gpu.describe(),
                        t.elapsed().as_secs_f64()
                    );
                }
            }
        }
        Command::View {
            scene,
            size,
            exit_after_frames,
            screenshot,
            screenshot_at,
            set,
            software,
            no_panels,
            no_watch,
            reload_every,
            memory_log,
        } => {
            let mut screenshots = screenshot_at;
            if let Some(p) = screenshot {
                screenshots.push((exit_after_frames.map_or(60, |n| n.saturating_sub(1)), p));
            }
            if let Some(p) = &memory_log {
                output::check_file("--memory-log", p, &["csv"])?;
            }
            for (frame, path) in &screenshots {
                output::check_file("--screenshot", path, &["png"])?;
                if let Some(n) = exit_after_frames.filter(|&n| *frame >= n) {
                    bail!(
                        "--screenshot-at {frame}:{}: the window closes after {n} frames \
                         (--exit-after-frames), so frame {frame} is never drawn",
                        path.display()
                    );
                }
            }
            let sets = set
                .iter()
                .map(|s| kami::app::params::parse_set(s))
                .collect::<kami::Result<Vec<_>>>()?;
            kami::app::run(kami::app::ViewerOptions {
                scene,
                size,
                software,
                exit_after_frames,
                screenshots,
                sets,
                no_panels,
                reload_every,
                memory_log,
                no_watch,
            })?;
        }
        Command::Bench { which } => match which {
            Bench::Backends { scenes, out } => {
                let report = kami::bench::backends::run(&scenes, &out)?;
                println!("{}", report.markdown);
                println!("wrote {0}/backends.md, {0}/backends.csv", out.display());
            }
            Bench::Scale {
                scene,
                strands,
                segments,
                size,
                frames,
                max_segments,
                cpu_clock,
                msaa,
                supersample,
                out,
                software,
            } => {
                let gpu = Gpu::headless(preference(software))?;
                let soft = gpu.info.device_type == wgpu::DeviceType::Cpu;
                let sweep = kami::bench::scale::Sweep {
                    strands,
                    segments,
                    size,
                    frames,
                    max_segments: max_segments.unwrap_or(if soft { 2_000_000 } else { 64_000_000 }),
                    cpu_clock,
                    msaa,
                    supersample,
                };
                let report = kami::bench::scale::run(&gpu, &scene, &sweep, &out)?;
                println!("{}", report.markdown);
                println!(
                    "wrote {0}/scale.md, {0}/scale.csv, {0}/scale.png",
                    out.display()
                );
            }
            Bench::Look {
                scenes,
                size,
                spp,
                frames,
                python,
                cache,
                out,
                software,
            } => {
                let scenes = if scenes.is_empty() {
                    kami::bench::look::SCENES
                        .iter()
                        .map(|s| kami::scene::shipped(s))
                        .collect()
                } else {
                    scenes
                };
                // Mitsuba and FLIP are checked before the GPU is opened: a missing one costs
                // nothing.
                kami::bench::look::check_deps(&python)?;
                let gpu = Gpu::headless(preference(software))?;
                let o = kami::bench::look::Options {
                    scenes,
                    size,
                    spp,
                    frames,
                    python,
                    cache,
                };
                let report = kami::bench::look::run(&gpu, &o, &out)?;
                println!("{}", report.markdown);
                println!(
                    "wrote {0}/look.md, {0}/look.csv, {0}/look_offsets.md, {0}/look_offsets.csv and the image pairs",
                    out.display()
                );
            }
            Bench::Shadows {
                scenes,
                runs,
                out,
                software,
            } => {
                let gpu = Gpu::headless(preference(software))?;
                let report = kami::bench::shadows::run(&gpu, &scenes, runs, &out)?;
                println!("{}", report.markdown);
                println!(
                    "wrote {0}/shadow_bench.md, {0}/shadow_bench.csv, {0}/shadow_bench.png",
                    out.display()
                );
            }
            Bench::Lod {
                scene,
                out,
                software,
            } => {
                let gpu = Gpu::headless(preference(software))?;
                let report = kami::bench::lod::run(&gpu, &scene, &out)?;
                println!("{}", report.markdown);
                println!("wrote {0}/lod.md, {0}/lod.csv, {0}/lod.png", out.display());
            }
            Bench::Raster {
                scene,
                size,
                frame,
                runs,
                out,
                software,
            } => {
                let gpu = Gpu::headless(preference(software))?;
                let report = kami::bench::raster::run(&gpu, &scene, &out, size, frame, runs)?;
                println!("{}", report.markdown);
                println!(
                    "wrote {0}/raster.md, {0}/raster.csv, {0}/raster.png",
                    out.display()
                );
            }
            Bench::Sdf { scene, out } => {
                let report = kami::bench::sdf::run(&scene, &out)?;
                println!("{}", report.markdown);
                println!("wrote {0}/sdf.md, {0}/sdf.csv, {0}/sdf.png", out.display());
            }
        },
        Command::Fingers {
            dir,
            synthesize,
            out,
        } => {
            use kami::systems::wisps::fingers;
            if let Some(to) = synthesize {
                let frames = fingers::synthesize(&fingers::HandSpec::default());
                fingers::write_sequence(&to, &frames)?;
                println!(
                    "wrote {} depth frames and camera.ron to {}",
                    frames.len(),
                    to.display()
                );
            } else if let Some(dir) = dir {
                let (skeleton, found, frames) = fingers::skeleton_from_dir(&dir)?;
                let ron = fingers::skeleton_ron(&skeleton);
                eprintln!(
                    "two fingertips in {found} of {frames} frames: {} nodes",
                    skeleton.nodes.len()
                );
                println!("{ron}");
                if let Some(out) = out {
                    std::fs::write(&out, format!("{ron}\n"))
                        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", out.display()))?;
                }
            }
        }
        Command::Convert {
            input,
            output,
            scale,
            frame,
            software,
            time,
        } => {
            if !scale.is_finite() || scale <= 0.0 {
                bail!("--scale {scale}: use a positive number");
            }
            match kami::formats::Format::of(&output) {
                None => bail!(
                    "{}: not a strand format Kami writes; use {}",
                    output.display(),
                    kami::formats::EXTENSIONS
                ),
                Some(f) => {
                    if let Some(why) = f.read_only() {
                        bail!("{}: {why}", output.display());
                    }
                }
            }
            let is_scene = input
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("ron"));
            if is_scene && time.is_some() {
                bail!("--time is for an Alembic or USD input; a scene's frame is --frame");
            }
            if !is_scene && frame != 0 {
                bail!("--frame is for a scene input (.ron); a strand file has no frames");
            }
            let mut groom = if is_scene {
                let scene = kami::Scene::load(&input)?;
                let gpu = Gpu::headless(preference(software))?;
                kami::stage::export_scene(&gpu, &scene, frame)?
            } else {
                kami::formats::read_at(&input, time)?
            };
            if groom.counts.is_empty() {
                bail!(
                    "{}: nothing to write (toon wisps are surfaces, not strands)",
                    input.display()
                );
            }
            if scale != 1.0 {
                for p in &mut groom.points {
                    *p = p.map(|v| v * scale);
                }
                for w in groom.widths.iter_mut().flatten() {
                    *w *= scale;
                }
            }
            kami::formats::write(&output, &groom)?;
            println!(
                "{} strands, {} points: {} -> {}",
                groom.counts.len(),
                groom.points.len(),
                input.display(),
                output.display()
            );
        }
    }
    Ok(())
}
