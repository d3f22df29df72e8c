//! The `kami` command line, one module per command: each gives its options and help (a
//! clap command) and what runs it. `kami --help` lists Kami's own commands with the kinds'
//! (`Kind::commands`, such as `fingers`) after `bench`, so the CLI names
//! no kind.

mod bench;
mod convert;
mod parse;
mod render;
mod view;

use anyhow::Result;
use clap::ArgMatches;
use kami::systems::KINDS;

/// One of Kami's own commands.
pub struct Cmd {
    /// Its options and help: a clap command named as the command.
    pub command: fn() -> clap::Command,
    /// Run it on what the command line gave.
    pub run: fn(&ArgMatches) -> Result<()>,
}

/// Kami's own commands listed before the kinds' (in `kami --help` order), and after.
const BEFORE: &[Cmd] = &[render::COMMAND, view::COMMAND, bench::COMMAND];
const AFTER: &[Cmd] = &[convert::COMMAND];

/// The whole command line.
pub fn command() -> clap::Command {
    let kami = clap::Command::new("kami")
        .version(env!("CARGO_PKG_VERSION"))
        .about("Kami (髪): GPU hair, fur and toon-hair viewer and simulator")
        .subcommand_required(true)
        .arg_required_else_help(true);
    let own = |c: &Cmd| (c.command)();
    let commands = (BEFORE.iter().map(own))
        .chain(KINDS.iter().flat_map(|k| k.commands).map(|k| (k.command)()))
        .chain(AFTER.iter().map(own));
    commands.fold(kami, |kami, c| kami.subcommand(c))
}

/// Run the command the command line names.
pub fn run(m: &ArgMatches) -> Result<()> {
    let (name, args) = m
        .subcommand()
        .ok_or_else(|| anyhow::anyhow!("kami: no command named"))?;
    let named = |c: fn() -> clap::Command| c().get_name() == name;
    if let Some(k) = KINDS
        .iter()
        .flat_map(|k| k.commands)
        .find(|k| named(k.command))
    {
        return Ok((k.run)(args)?);
    }
    let own = BEFORE.iter().chain(AFTER).find(|c| named(c.command));
    let own = own.ok_or_else(|| anyhow::anyhow!("kami: no command {name}"))?;
    (own.run)(args)
}
