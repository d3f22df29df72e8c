//! `kami convert`: a strand file to another format, or a scene's hair at a frame to a
//! strand file.

use super::parse::preference;
use super::Cmd;
use anyhow::{bail, Result};
use clap::{ArgMatches, CommandFactory, FromArgMatches, Parser};
use kami::gpu::Gpu;
use std::path::PathBuf;

pub const COMMAND: Cmd = Cmd {
    command: Args::command,
    run,
};

/// Convert a strand file: `.hair` (Cem Yuksel), `.obj` (polylines) or `.usda` (USD
/// BasisCurves), either way, or `.abc` (Alembic curves) in (docs/formats.md says what
/// each keeps); or write a scene's
/// hair (a `.ron` input) at a frame: Anjyo strands, fur and strip centre lines.
#[derive(Parser)]
#[command(name = "convert")]
struct Args {
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
}

fn run(m: &ArgMatches) -> Result<()> {
    let a = Args::from_arg_matches(m)?;
    let (input, output, scale) = (&a.input, &a.output, a.scale);
    if !scale.is_finite() || scale <= 0.0 {
        bail!("--scale {scale}: use a positive number");
    }
    match kami::formats::Format::of(output) {
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
    if is_scene && a.time.is_some() {
        bail!("--time is for an Alembic or USD input; a scene's frame is --frame");
    }
    if !is_scene && a.frame != 0 {
        bail!("--frame is for a scene input (.ron); a strand file has no frames");
    }
    let mut groom = if is_scene {
        let scene = kami::Scene::load(input)?;
        let gpu = Gpu::headless(preference(a.software))?;
        kami::stage::export_scene(&gpu, &scene, a.frame)?
    } else {
        kami::formats::read_at(input, a.time)?
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
    kami::formats::write(output, &groom)?;
    println!(
        "{} strands, {} points: {} -> {}",
        groom.counts.len(),
        groom.points.len(),
        input.display(),
        output.display()
    );
    Ok(())
}
