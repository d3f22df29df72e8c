//! `kami view`: the interactive viewer, with the options scripts and tests drive it by.

use super::parse::{parse_frame_path, parse_size};
use super::Cmd;
use crate::output;
use anyhow::{bail, Result};
use clap::{ArgMatches, CommandFactory, FromArgMatches, Parser};
use std::path::PathBuf;

pub const COMMAND: Cmd = Cmd {
    command: Args::command,
    run,
};

/// Open the interactive viewer (default scene: the wind gust, hair in motion).
#[derive(Parser)]
#[command(name = "view")]
struct Args {
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
}

fn run(m: &ArgMatches) -> Result<()> {
    let a = Args::from_arg_matches(m)?;
    let mut screenshots = a.screenshot_at;
    if let Some(p) = a.screenshot {
        screenshots.push((a.exit_after_frames.map_or(60, |n| n.saturating_sub(1)), p));
    }
    if let Some(p) = &a.memory_log {
        output::check_file("--memory-log", p, &["csv"])?;
    }
    for (frame, path) in &screenshots {
        output::check_file("--screenshot", path, &["png"])?;
        if let Some(n) = a.exit_after_frames.filter(|&n| *frame >= n) {
            bail!(
                "--screenshot-at {frame}:{}: the window closes after {n} frames \
                 (--exit-after-frames), so frame {frame} is never drawn",
                path.display()
            );
        }
    }
    let sets = a
        .set
        .iter()
        .map(|s| kami::app::params::parse_set(s))
        .collect::<kami::Result<Vec<_>>>()?;
    kami::app::run(kami::app::ViewerOptions {
        scene: a.scene,
        size: a.size,
        software: a.software,
        exit_after_frames: a.exit_after_frames,
        screenshots,
        sets,
        no_panels: a.no_panels,
        reload_every: a.reload_every,
        memory_log: a.memory_log,
        no_watch: a.no_watch,
    })?;
    Ok(())
}
