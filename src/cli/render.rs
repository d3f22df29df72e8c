//! `kami render`: a scene to a PNG, or its animation to numbered PNGs (and a GIF or APNG).

use super::parse::{parse_frames, parse_msaa, parse_size, parse_strands, preference};
use super::Cmd;
use crate::{anim, output};
use anyhow::{bail, Result};
use clap::{ArgMatches, CommandFactory, FromArgMatches, Parser};
use kami::gpu::Gpu;
use kami::Scene;
use std::path::{Path, PathBuf};

pub const COMMAND: Cmd = Cmd {
    command: Args::command,
    run,
};

/// Groom a scene on the GPU and render it to a PNG, or render its animation.
#[derive(Parser)]
#[command(name = "render")]
struct Args {
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
    /// How thin strands are rasterised: auto, ribbons or compute (default: the scene's
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
}

/// The scene to render (the flags and the frame-0 `--set` edits applied) and the scenes
/// the later edits make, by frame.
type Edited = (Scene, Vec<(u64, Scene)>);

fn run(m: &ArgMatches) -> Result<()> {
    let a = Args::from_arg_matches(m)?;
    let (s, edits) = edited_scene(&a)?;
    let size = a.size.unwrap_or(s.render.size);
    // Every output is checked before the GPU work, so a typo costs nothing.
    check_outputs(&a)?;
    let gpu = Gpu::headless(preference(a.software))?;
    let t = std::time::Instant::now();
    let (hairs, segs) = s.counts();
    // What each kind adds to the counts (toon wisps, strips), in `KINDS` order.
    let mut segs = format!("{segs} segments");
    for kind in kami::systems::KINDS {
        if let Some(more) = (kind.summary)(&s) {
            segs = format!("{segs}, {more}");
        }
    }
    let what = format!("{hairs} hairs, {segs}");
    let Some((first, last)) = a.frames else {
        let out = a.out.unwrap_or_else(|| PathBuf::from("kami.png"));
        let img = kami::stage::render_scene(&gpu, &s, size)?;
        output::save_png(&img, &out)?;
        println!(
            "{}: {what}, {}x{} on {} in {:.2} s",
            out.display(),
            size.0,
            size.1,
            gpu.describe(),
            t.elapsed().as_secs_f64()
        );
        return Ok(());
    };
    let dir = a.out.clone().unwrap_or_else(|| PathBuf::from("frames"));
    animation(&gpu, &a, (&s, &edits), size, &dir)?;
    println!(
        "{}: frames {first}..{last} ({what}, {}x{}) on {} in {:.2} s",
        dir.display(),
        size.0,
        size.1,
        gpu.describe(),
        t.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Load the scene, apply `--msaa`, `--strands` and `--supersample`, validate, and run the
/// `--set` edits through the viewer's code (`params::scripted`), their frames checked
/// against `--frames`.
fn edited_scene(a: &Args) -> Result<Edited> {
    let mut s = Scene::load(&a.scene)?;
    if let Some(m) = a.msaa {
        s.render.msaa = m;
    }
    if let Some(r) = a.strands {
        s.render.strands = r;
    }
    if let Some(f) = a.supersample {
        s.render.supersample = f;
    }
    kami::systems::validate(&s)?;
    let sets = a
        .set
        .iter()
        .map(|s| kami::app::params::parse_set(s))
        .collect::<kami::Result<Vec<_>>>()?;
    let (s, edits) = kami::app::params::scripted(s, &sets)?;
    if let Some((f, _)) = edits.first() {
        match a.frames {
            None => {
                bail!("--set {f}:...: a still is frame 0; a later frame needs --frames")
            }
            Some((_, last)) if edits.iter().any(|(f, _)| *f > u64::from(last)) => {
                bail!("--set: a frame after {last}, the last one rendered, is never drawn")
            }
            _ => {}
        }
    }
    Ok((s, edits))
}

/// Refuse outputs that cannot be written (and `--gif`/`--apng` without `--frames`).
fn check_outputs(a: &Args) -> Result<()> {
    if a.frames.is_none() {
        if a.gif.is_some() || a.apng.is_some() {
            bail!("--gif and --apng need --frames A..B");
        }
        let path = a.out.clone().unwrap_or_else(|| PathBuf::from("kami.png"));
        return output::check_file("--out", &path, &["png"]);
    }
    output::prepare_dir("--out", a.out.as_deref().unwrap_or("frames".as_ref()))?;
    if let Some(g) = &a.gif {
        output::check_file("--gif", g, &["gif"])?;
    }
    if let Some(p) = &a.apng {
        output::check_file("--apng", p, &["png", "apng"])?;
    }
    Ok(())
}

/// Render `--frames` into `dir` (and the GIF and APNG), with a progress line.
fn animation(
    gpu: &Gpu,
    a: &Args,
    (s, edits): (&Scene, &[(u64, Scene)]),
    size: (u32, u32),
    dir: &Path,
) -> Result<()> {
    let (first, last) = a.frames.unwrap_or_default();
    if !kami::systems::KINDS.iter().any(|k| (k.moves)(s)) {
        log::warn!(
            "{} has no dynamics: every frame is the same still",
            a.scene.display()
        );
    }
    let count = last - first + 1;
    let fps = a.fps.unwrap_or_else(|| {
        s.cache_fps()
            .map_or(10, |f| (f.round() as u32).clamp(1, 1000))
    });
    let mut sinks = anim::Sinks::new(a.gif.as_deref(), a.apng.as_deref(), size, count, fps)?;
    let mut progress = anim::Progress::new(count);
    let capped =
        kami::stage::render_animation_edited(gpu, s, edits, size, first..=last, |f, img| {
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
        })?;
    sinks.finish()?;
    progress.done();
    if capped > 0 {
        eprintln!(
            "warning: {capped} frame(s) needed more than dynamics.max_substeps substeps; the solver clamped \
             the angular step there (raise max_substeps or lower dt for accuracy)"
        );
    }
    Ok(())
}
