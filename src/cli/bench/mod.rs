//! `kami bench`: one subcommand per entry of one list, the renderer's benches (`renderer`,
//! their options derived there) then each kind's (`kami::bench::kinds::KIND_BENCHES`, their
//! options built from the entry, so the CLI names no kind). Every bench runs the same way:
//! its report printed as Markdown, then the files it wrote.

mod renderer;

use super::parse::preference;
use super::Cmd;
use anyhow::Result;
use clap::{ArgMatches, Parser};
use kami::bench::kinds::{KindBench, KIND_BENCHES};
use kami::bench::Report;
use kami::gpu::Gpu;
use std::path::PathBuf;

pub const COMMAND: Cmd = Cmd { command, run };

/// One `kami bench` subcommand.
#[derive(Clone, Copy)]
enum Entry {
    /// One of the renderer's (`renderer::BENCHES`): its options and help derived from a
    /// [`Study`], and what runs it.
    Renderer {
        command: fn() -> clap::Command,
        run: fn(&ArgMatches) -> Result<Ran>,
    },
    /// A kind's, from its table entry.
    Kind(&'static KindBench),
}

/// A renderer bench: its options and help (a derived clap command named as the bench) and
/// how it runs.
trait Study: Parser {
    /// The files it writes under `--out`, as the closing line names them.
    const FILES: &'static [&'static str];
    /// What more it writes, named after the files ("the image pairs").
    const ALSO: Option<&'static str> = None;
    /// Run it: its report and the folder it wrote to.
    fn run(self) -> Result<(Report, PathBuf)>;
}

/// What a bench did: its report, and where and what it wrote.
struct Ran {
    report: Report,
    out: PathBuf,
    files: &'static [&'static str],
    also: Option<&'static str>,
}

/// The entry of a renderer bench.
const fn study<T: Study>() -> Entry {
    Entry::Renderer {
        command: T::command,
        run: run_study::<T>,
    }
}

fn run_study<T: Study>(m: &ArgMatches) -> Result<Ran> {
    let (report, out) = T::from_arg_matches(m)?.run()?;
    Ok(Ran {
        report,
        out,
        files: T::FILES,
        also: T::ALSO,
    })
}

/// Every bench, in the order `kami bench --help` lists them.
fn entries() -> impl Iterator<Item = Entry> {
    let kinds = KIND_BENCHES.iter().map(Entry::Kind);
    renderer::BENCHES.iter().copied().chain(kinds)
}

impl Entry {
    fn command(self) -> clap::Command {
        match self {
            Entry::Renderer { command, .. } => command(),
            Entry::Kind(k) => kind_bench_command(k),
        }
    }

    fn is(self, name: &str) -> bool {
        match self {
            Entry::Renderer { command, .. } => command().get_name() == name,
            Entry::Kind(k) => k.name == name,
        }
    }

    fn run(self, m: &ArgMatches) -> Result<Ran> {
        match self {
            Entry::Renderer { run, .. } => run(m),
            Entry::Kind(k) => run_kind_bench(k, m),
        }
    }
}

/// `kami bench` with one subcommand per entry.
fn command() -> clap::Command {
    let bench = clap::Command::new("bench")
        .about("Benchmarks: print throughput and accuracy tables")
        .subcommand_required(true)
        .arg_required_else_help(true);
    entries().fold(bench, |b, e| b.subcommand(e.command()))
}

/// Run the bench the command line names; print its report and the files it wrote.
fn run(m: &ArgMatches) -> Result<()> {
    let (name, args) = m
        .subcommand()
        .ok_or_else(|| anyhow::anyhow!("kami bench: no bench named"))?;
    let entry = entries()
        .find(|e| e.is(name))
        .ok_or_else(|| anyhow::anyhow!("kami bench: no bench {name}"))?;
    let ran = entry.run(args)?;
    println!("{}", ran.report.markdown);
    let files: Vec<String> = ran
        .files
        .iter()
        .map(|f| format!("{}/{f}", ran.out.display()))
        .collect();
    let also = ran.also.map_or(String::new(), |a| format!(" and {a}"));
    println!("wrote {}{also}", files.join(", "));
    Ok(())
}

/// `kami bench <name>` for one kind's bench: its input, `--frames` where it takes one,
/// `--out` and `--software`.
fn kind_bench_command(k: &KindBench) -> clap::Command {
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

fn run_kind_bench(k: &'static KindBench, m: &ArgMatches) -> Result<Ran> {
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
    Ok(Ran {
        report,
        out,
        files: k.files,
        also: None,
    })
}
