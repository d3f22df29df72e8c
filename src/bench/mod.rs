//! Benchmarks behind `kami bench`. Speed is measured here, never in tests. Each report is
//! Markdown (for the README) plus CSV, and says which adapter and CPU produced it.

pub mod anjyo;
pub mod backends;
pub mod capture;
pub mod fur;
pub mod guides;
pub mod kinds;
pub mod lod;
pub mod look;
pub mod plot;
pub mod raster;
pub mod scale;
pub mod sdf;
pub mod shadows;
pub mod splat;
pub mod strips;
pub mod wisps;

pub use anjyo::{convergence, dynamics, elliptic_k, groom, pendulum_periods};
pub use anjyo::{PAPER_GROOM_HAIRS, PAPER_GROOM_SECONDS};

use crate::error::Result;
use std::path::Path;
use std::time::Instant;

pub struct Report {
    pub markdown: String,
    pub csv: String,
}

/// The CPU model, for reports.
pub fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

/// The first line of every report: the command line and the machine that wrote it, so a
/// figure quoted from the file carries its device.
pub fn provenance() -> String {
    let args: Vec<String> = std::env::args().skip(1).collect();
    format!(
        "Written by `kami {}` on {} ({} threads).",
        args.join(" "),
        cpu_name(),
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    )
}

/// Write `<stem>.md` and `<stem>.csv` into `out` (created if missing).
pub fn write_report(out: &Path, stem: &str, md: &str, csv: &str) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|source| crate::KamiError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    for (ext, text) in [("md", md), ("csv", csv)] {
        let p = out.join(format!("{stem}.{ext}"));
        std::fs::write(&p, text).map_err(|source| crate::KamiError::Io { path: p, source })?;
    }
    Ok(())
}

/// Time `f` `n` times after one warm-up run; mean seconds.
fn time_mean(n: u32, mut f: impl FnMut() -> Result<()>) -> Result<f64> {
    f()?;
    let t = Instant::now();
    for _ in 0..n {
        f()?;
    }
    Ok(t.elapsed().as_secs_f64() / n as f64)
}
