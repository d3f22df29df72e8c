//! The `kami` command line: render scenes to PNG, open the viewer, run the benchmarks and
//! convert strand files. Each command is a module of `cli`; here the line is parsed, the
//! command run, and a user's mistake printed.

mod anim;
mod cli;
mod output;

/// A user's mistake prints one clear message (the error and its causes, `{:#}`) and exits
/// with status 1: returning the error from `main` would print anyhow's captured backtrace
/// too whenever `RUST_BACKTRACE` is set.
fn main() -> std::process::ExitCode {
    env_logger::Builder::from_env(
        env_logger::Env::default().default_filter_or("warn,wgpu_hal::gles::egl=off"),
    )
    .init();
    let matches = cli::command().get_matches();
    match cli::run(&matches) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
