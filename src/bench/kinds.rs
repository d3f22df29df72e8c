//! The kinds' benches in one table, so the CLI names no kind: `kami bench <name>` is built
//! from each `KIND_BENCHES` entry (its options, help and dispatch, in `src/cli/bench`), so a
//! kind's bench is its report file under `bench/` plus one entry here. (A kind's own
//! commands, such as `kami fingers`, are `Kind::commands`.) Every bench takes an input path,
//! an output folder, optionally a frame count, and writes the files it lists.

use super::Report;
use crate::error::Result;
use crate::gpu::Gpu;
use std::path::Path;

/// One kind's bench.
pub struct KindBench {
    pub name: &'static str,
    /// What it measures and writes (`kami bench --help`).
    pub about: &'static str,
    /// The input option's name (`scene` or `scenes`), its value's name in the help
    /// (`SCENE`), its default and its help.
    pub input: (
        &'static str,
        &'static str,
        &'static str,
        Option<&'static str>,
    ),
    /// `--frames`: its default and help; None where the bench takes no frame count.
    pub frames: Option<(&'static str, &'static str)>,
    /// Help of `--out`.
    pub out: &'static str,
    /// Run it: (adapter, input, frames, output folder).
    pub run: fn(&Gpu, &Path, u32, &Path) -> Result<Report>,
    /// The files it writes under `--out`.
    pub files: &'static [&'static str],
}

/// Help of `--out` where a bench says nothing more.
const OUT: &str = "Directory for the report files.";

/// Every kind's bench, in the order `kami bench --help` lists them.
pub const KIND_BENCHES: &[KindBench] = &[
    KindBench {
        name: "groom",
        about: "Cantilever grooming: CPU reference and GPU kernel throughput on the largest \
                scene, render time per frame, and tip-drop error against the exact elastica \
                for both bending modes.",
        input: (
            "scene",
            "SCENE",
            "assets/scenes/bob.ron",
            Some("Scene to time (default: the largest shipped scene)."),
        ),
        frames: Some(("10", "Frames to time for the render figure.")),
        out: "Directory for the report files (groom.md, groom.csv).",
        run: super::groom,
        files: &["groom.md", "groom.csv"],
    },
    KindBench {
        name: "dynamics",
        about: "Projective dynamics: error against cost over a sweep of dt and segment counts \
                on the gust scene and the hard cases, GPU and CPU cost at the paper's size, \
                and the rigid pendulum's period; writes dynamics.md, dynamics.csv and \
                dynamics.png.",
        input: ("scene", "SCENE", "assets/scenes/gust.ron", None),
        frames: None,
        out: OUT,
        run: |gpu, scene, _, out| super::dynamics(gpu, scene, out),
        files: &["dynamics.md", "dynamics.csv", "dynamics.png"],
    },
    KindBench {
        name: "guides",
        about: "Guides and followers: simulation time per frame and the followers' position \
                error against simulating every strand, for guide shares 1 .. 0.05 at frames \
                10, 20 and 30 of the gust; writes guides.md, guides.csv and guides.png.",
        input: ("scene", "SCENE", "assets/scenes/gust.ron", None),
        frames: None,
        out: OUT,
        run: |gpu, scene, _, out| super::guides::run(gpu, scene, out),
        files: &["guides.md", "guides.csv", "guides.png"],
    },
    KindBench {
        name: "fur",
        about: "Van Gelder & Wilhelms' fur: hairs/s per style at 900x900 against the paper's \
                rates, the Figure 9 image at 500,000 hairs, and distance-based culling (image \
                error against the full-density render versus hairs drawn and time); writes \
                fur.md, fur.csv and fur_culling.png.",
        input: (
            "scenes",
            "SCENES",
            "assets/scenes",
            Some("Folder holding the shipped fur scenes (fur_line.ron ... fur_fig9.ron)."),
        ),
        frames: Some(("5", "Frames to time per figure.")),
        out: OUT,
        run: |gpu, scenes, frames, out| super::fur::run(gpu, scenes, out, frames),
        files: &["fur.md", "fur.csv", "fur_culling.png"],
    },
    KindBench {
        name: "wisps",
        about: "Sakai's toon wisps: ray-march ms per frame against wisp count and image size, \
                image error against step size and distance method, the march and the mesh \
                side by side (error against the f64 truth, ms per frame, what Auto draws), \
                and the mass springs' work-precision table; writes wisps.md, wisps.csv, \
                three plots (cost, error, springs) and wisps_draw.ron.",
        input: ("scene", "SCENE", "assets/scenes/toon.ron", None),
        frames: Some(("3", "Frames to time per figure.")),
        out: OUT,
        run: super::wisps::run,
        files: &[
            "wisps.md",
            "wisps.csv",
            "wisps_cost.png",
            "wisps_error.png",
            "wisps_springs.png",
            "wisps_draw.ron",
        ],
    },
    KindBench {
        name: "strips",
        about: "Kazama's strips: dynamics and full-frame ms against strip count (strips per \
                second), the angular-spring solver's work-precision table, and the EFF fit; \
                writes strips.md, strips.csv, strips_speed.png, strips_precision.png and \
                capture.md/.csv/.png.",
        input: ("scene", "SCENE", "assets/scenes/strips.ron", None),
        frames: Some(("3", "Frames to time per figure.")),
        out: OUT,
        run: super::strips::run,
        files: &[
            "strips.md",
            "strips.csv",
            "strips_speed.png",
            "strips_precision.png",
            "strips_sampling.csv",
            "strips_sampling.png",
            "capture.md",
            "capture.csv",
            "capture.png",
        ],
    },
];
