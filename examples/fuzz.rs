//! The long fuzz run (docs/fuzzing.md):
//! `cargo run --release --example fuzz -- --target scene|obj|off|ply|all --iters N --seed S`.
//! Prints what it tried and found; each distinct finding is minimised and written to
//! `target/fuzz_findings/` with a `.txt` beside it, and the tally to `summary.txt` there.
//! `--target T --replay FILE...` runs saved inputs once.

use anyhow::{Context, Result};
use clap::Parser;
use kami::fuzz::{self, Target};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Allocations above `fuzz::ALLOC_CAP` made by an input are findings.
#[global_allocator]
static ALLOC: fuzz::CappedAlloc = fuzz::CappedAlloc;

#[derive(Parser)]
struct Args {
    /// scene, obj, off, ply or all.
    #[arg(long, default_value = "all")]
    target: String,
    /// Mutated inputs per target (the seeds run first, on top).
    #[arg(long, default_value_t = 200_000)]
    iters: u64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Where findings and the summary go (emptied first).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Run these files once each (with one --target) and print what each gives, instead of
    /// fuzzing: to reproduce a finding.
    #[arg(long, num_args = 1..)]
    replay: Vec<PathBuf>,
    /// Write each input to `current.bin` in the output folder before running it (slow): if the
    /// process dies (a stack overflow, a signal), that file is the input that killed it.
    #[arg(long)]
    save_each: bool,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let targets: Vec<Target> = match args.target.as_str() {
        "all" => Target::ALL.to_vec(),
        name => vec![Target::from_name(name)
            .with_context(|| format!("--target {name}: use scene, obj, off, ply or all"))?],
    };
    if !args.replay.is_empty() {
        anyhow::ensure!(targets.len() == 1, "--replay needs one --target");
        for path in &args.replay {
            let bytes = std::fs::read(path).with_context(|| format!("{}", path.display()))?;
            match fuzz::run_one(targets[0], &bytes) {
                Ok(class) => println!("{}: no finding ({class})", path.display()),
                Err(f) => println!("{}: FINDING {}", path.display(), f.detail),
            }
        }
        return Ok(());
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| root.join("target/fuzz_findings"));
    if out.exists() {
        std::fs::remove_dir_all(&out).with_context(|| format!("emptying {}", out.display()))?;
    }
    std::fs::create_dir_all(&out)?;
    fuzz::set_abort_dir(out.clone());
    if args.save_each {
        fuzz::save_each_input(out.join("current.bin"));
    }
    anyhow::ensure!(fuzz::allocations_watched(), "CappedAlloc is not installed");

    let given: Vec<String> = std::env::args().skip(1).collect();
    let command = format!(
        "{}cargo run {}--example fuzz -- {}",
        std::env::var("CARGO_PROFILE_RELEASE_OVERFLOW_CHECKS")
            .map(|v| format!("CARGO_PROFILE_RELEASE_OVERFLOW_CHECKS={v} "))
            .unwrap_or_default(),
        if cfg!(debug_assertions) {
            ""
        } else {
            "--release "
        },
        given.join(" ")
    );
    let mut summary = format!(
        "command: {command}\nbuild: {}, overflow checks {}\nmachine: {}\n\n",
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
        if fuzz::overflow_checks() { "on" } else { "off" },
        machine()
    );
    print!("{summary}");
    let started = Instant::now();
    let (mut all_inputs, mut all_findings) = (0, 0);
    for target in targets {
        let dir = target.corpus_dir(root);
        let seeds: Vec<Vec<u8>> = fuzz::load_corpus(&dir)
            .with_context(|| format!("reading the corpus {}", dir.display()))?
            .into_iter()
            .map(|(_, b)| b)
            .collect();
        println!(
            "{}: {} seeds, {} inputs, seed {}",
            target.name(),
            seeds.len(),
            args.iters,
            args.seed
        );
        let t = Instant::now();
        let stats = fuzz::fuzz(target, &seeds, args.iters, args.seed, |f, input| {
            println!(
                "  new finding after {:.1} s: {}",
                t.elapsed().as_secs_f64(),
                f.detail
            );
            println!(
                "    input ({} bytes): b\"{}\"",
                input.len(),
                fuzz::escape(input)
            );
        });
        let secs = t.elapsed().as_secs_f64();
        let line = format!(
            "{}: {} inputs in {secs:.1} s ({:.0}/s), {} accepted, {} findings, {} distinct; {} outcome classes, corpus {} -> {}",
            target.name(),
            stats.inputs,
            stats.inputs as f64 / secs,
            stats.accepted,
            stats.findings,
            stats.distinct.len(),
            stats.classes,
            stats.corpus.0,
            stats.corpus.1
        );
        println!("{line}");
        writeln!(summary, "{line}")?;
        for (k, (f, input)) in stats.distinct.iter().enumerate() {
            let min = fuzz::minimize(target, input, &f.signature, 20_000);
            let stem = format!("{}-{k}", target.name());
            std::fs::write(out.join(format!("{stem}.bin")), &min)?;
            std::fs::write(out.join(format!("{stem}.orig.bin")), input)?;
            let text = format!(
                "{}\nminimised ({} bytes): b\"{}\"\noriginal ({} bytes): b\"{}\"\n",
                f.detail,
                min.len(),
                fuzz::escape(&min),
                input.len(),
                fuzz::escape(input)
            );
            std::fs::write(out.join(format!("{stem}.txt")), &text)?;
            println!(
                "  {stem}: {}\n    minimised: b\"{}\"",
                f.signature,
                fuzz::escape(&min)
            );
            writeln!(
                summary,
                "  {stem}: {}\n    minimised: b\"{}\"",
                f.signature,
                fuzz::escape(&min)
            )?;
        }
        all_inputs += stats.inputs;
        all_findings += stats.findings;
    }
    let total = format!(
        "total: {all_inputs} inputs, {all_findings} findings, {:.1} s",
        started.elapsed().as_secs_f64()
    );
    println!("{total}");
    writeln!(summary, "{total}")?;
    std::fs::write(out.join("summary.txt"), &summary)?;
    println!("summary: {}", out.join("summary.txt").display());
    Ok(())
}

/// CPU model and core count, for the summary.
fn machine() -> String {
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!("{}, {cores} cores available", kami::bench::cpu_name())
}
