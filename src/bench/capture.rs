//! The EFF fitted from motion capture, measured (issue 10 item 5; Kazama et al. section
//! 3.2): no hair capture is public, so simulate marker strands under a known wind, fit the
//! EFF from the markers alone (`systems::strips::capture::fit`), and measure what came
//! back. `kami bench strips` writes the report (capture.md, capture.csv, capture.png) and
//! quotes it in strips.md.

use crate::bench::plot::{self, Series};
use crate::error::{KamiError, Result};
use crate::systems::strips::capture::{
    field_error, fit, motion_error, simulate_markers, Capture, FieldError, FIT_STEP,
};
use crate::systems::strips::hom;
use glam::DVec3;
use std::fmt::Write as _;
use std::path::Path;

/// Rendered frames simulated for the round trip (one second at 30 fps).
pub const ROUND_TRIP_FRAMES: u32 = 30;

/// The strands of the round trip: the paper's 27 motion strands as three layers of the
/// layer model (under, middle, crown) of different lengths, so that they carry 4 to 10
/// markers, on Kami's default head.
pub fn round_trip_strips() -> crate::systems::strips::block::Strips {
    use crate::systems::strips::block::{Layer, Motion, Strips};
    let layer = |name: &str, polar: f64, azimuth: [f64; 2], length: f64, droop: f64| Layer {
        name: name.into(),
        count: 9,
        polar,
        azimuth,
        length,
        sticks: 10,
        width: [3.2, 0.8],
        droop,
        curl: 5.0,
        stiffness: 1.0,
        color: [0.06, 0.034, 0.02],
    };
    Strips {
        layers: vec![
            layer("under", 82.0, [50.0, 310.0], 16.0, 0.94),
            layer("middle", 55.0, [35.0, 325.0], 22.0, 0.92),
            layer("crown", 24.0, [40.0, 320.0], 28.0, 0.9),
        ],
        motion: Motion {
            stiffness: 150.0,
            damping: 3.0,
            ..Motion::default()
        },
        look: Default::default(),
        edits: Vec::new(),
    }
}

/// The known wind of the round trip: a jet from the front-left aimed past the face, a
/// weaker low stream, and the outside force from the source toward the head (the
/// `front_left_gust` recipe of the EFF tests, 12³ cells over 60 cm).
pub fn round_trip_wind() -> crate::forces::eff::EffDesc {
    crate::forces::eff::front_left_gust()
}
/// The captures of the round trip: the markers in the known wind, and the same strands in
/// still air (the baseline eq 3 subtracts).
pub fn round_trip_captures() -> Result<(Capture, Capture)> {
    let strips = round_trip_strips();
    let truth = std::sync::Arc::new(crate::forces::eff::Eff::build(&round_trip_wind())?);
    let wind = simulate_markers(&strips, Some(truth), DVec3::ZERO, ROUND_TRIP_FRAMES)?;
    let still = simulate_markers(&strips, None, DVec3::ZERO, ROUND_TRIP_FRAMES)?;
    Ok((wind, still))
}

/// Marker error of one frame (cm): against the captured markers, re-simulated in the
/// fitted field and in still air.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameError {
    pub frame: usize,
    pub rms_fit: f64,
    pub max_fit: f64,
    pub rms_none: f64,
    pub max_none: f64,
}

/// What the round trip recovered.
#[derive(Clone, Debug)]
pub struct RoundTrip {
    pub strands: usize,
    pub markers: usize,
    pub frames: usize,
    /// Mean strand length (cm): the motion errors are also given relative to it.
    pub length: f64,
    /// Eq 3 samples, and the cells they defined.
    pub samples: usize,
    pub cells_passed: usize,
    /// The fitted outside strength (cm/s²) against the true one.
    pub strength_fit: f64,
    pub strength_true: f64,
    /// Fitted against true cell values, over the cells markers passed and over all cells.
    pub field_passed: FieldError,
    pub field_all: FieldError,
    /// Markers re-simulated in the fitted field / in still air against the captured ones:
    /// (rms, max) in cm over every marker and frame.
    pub motion_fit: (f64, f64),
    pub motion_none: (f64, f64),
    pub per_frame: Vec<FrameError>,
    /// The fitted field (what `assets/eff/capture.eff` holds).
    pub fitted: crate::forces::eff::Eff,
    /// The captured markers (what `assets/capture/markers.csv` holds).
    pub captured: Capture,
}

/// Per-frame (rms, max) distance between two captures of the same markers (cm).
fn frame_errors(a: &Capture, b: &Capture) -> Vec<(f64, f64)> {
    (0..a.frames.min(b.frames))
        .map(|f| {
            let (mut sum, mut max, mut n) = (0.0, 0.0f64, 0usize);
            for (sa, sb) in a.strands.iter().zip(&b.strands) {
                for (ta, tb) in sa.iter().zip(sb) {
                    let d = (ta[f] - tb[f]).length();
                    sum += d * d;
                    max = max.max(d);
                    n += 1;
                }
            }
            ((sum / n.max(1) as f64).sqrt(), max)
        })
        .collect()
}

/// Run the round trip: capture under `round_trip_wind`, fit from the markers, compare the
/// field cell by cell and the motion re-simulated in the fitted field.
pub fn round_trip() -> Result<RoundTrip> {
    let strips = round_trip_strips();
    let desc = round_trip_wind();
    let truth = crate::forces::eff::Eff::build(&desc)?;
    let (captured, baseline) = round_trip_captures()?;
    let fitted = fit(&desc, &captured, &baseline, &strips)?;
    let samples = captured.markers();

    let passed: Vec<usize> = (0..fitted.cell_count())
        .filter(|&i| fitted.defined()[i])
        .collect();
    let pair = |i: usize| (fitted.cells()[i], truth.cells()[i]);
    let field_passed = field_error(&passed.iter().map(|&i| pair(i)).collect::<Vec<_>>());
    let field_all = field_error(&(0..truth.cell_count()).map(pair).collect::<Vec<_>>());

    let again = simulate_markers(
        &strips,
        Some(std::sync::Arc::new(fitted.clone())),
        DVec3::ZERO,
        ROUND_TRIP_FRAMES,
    )?;
    let motion_fit = motion_error(&again, &captured);
    let motion_none = motion_error(&baseline, &captured);
    let per_frame = frame_errors(&again, &captured)
        .into_iter()
        .zip(frame_errors(&baseline, &captured))
        .enumerate()
        .map(
            |(frame, ((rms_fit, max_fit), (rms_none, max_none)))| FrameError {
                frame,
                rms_fit,
                max_fit,
                rms_none,
                max_none,
            },
        )
        .collect();
    let head = crate::scene::Head::default();
    let rest = hom::build(&strips, &head)?;
    let length = rest
        .iter()
        .map(|s| {
            s.points
                .windows(2)
                .map(|w| (w[1] - w[0]).length())
                .sum::<f64>()
        })
        .sum::<f64>()
        / rest.len().max(1) as f64;
    Ok(RoundTrip {
        strands: captured.strands.len(),
        markers: captured.markers(),
        frames: captured.frames,
        length,
        samples,
        cells_passed: passed.len(),
        strength_fit: fitted.strength(),
        strength_true: truth.strength(),
        field_passed,
        field_all,
        motion_fit,
        motion_none,
        per_frame,
        fitted,
        captured,
    })
}

/// Write the round trip's report into `out`: `capture.md` (the numbers), `capture.csv`
/// (marker error per frame) and `capture.png` (that error against the frame, fitted field
/// and still air). `kami bench strips` calls it.
pub fn write_report(out: &Path) -> Result<()> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| KamiError::Io { path, source }
    };
    std::fs::create_dir_all(out).map_err(io(out))?;
    let r = round_trip()?;
    let f = |e: &FieldError| {
        format!(
            "| {} | {:.1} | {:.3} | {:.1} | {:.1} | {:.2} |",
            e.count, e.rms, e.relative, e.angle_mean, e.angle_max, e.ratio_median
        )
    };
    let mut md = String::new();
    let _ = writeln!(md, "# Strips: the EFF fitted from motion capture\n");
    let _ = writeln!(md, "{}\n", super::provenance());
    let _ = writeln!(
        md,
        "The round trip of section 3.2 (no hair capture is public): {} strands of the layer \
         model ({} markers, mean strand length {:.1} cm) simulated for {} frames in a known \
         wind (`capture::round_trip_wind`: two jets from the front-left and the outside \
         force) and in still air; the EFF fitted from the markers alone (eq 3 over {} frame, \
         minus the still-air baseline; {} samples defining {} cells; the source and head \
         given, the wind through the rig's measured response (`capture::fit`), the outside strength the samples' median magnitude: {:.1} cm/s², true {:.1}).\n",
        r.strands,
        r.markers,
        r.length,
        r.frames - 1,
        FIT_STEP,
        r.samples,
        r.cells_passed,
        r.strength_fit,
        r.strength_true
    );
    let _ = writeln!(md, "## Field: fitted against true cells\n");
    let _ = writeln!(
        md,
        "| where | cells | rms (cm/s²) | relative | mean angle (°) | max angle (°) | median fit/true magnitude |\n|---|---|---|---|---|---|---|"
    );
    let _ = writeln!(md, "| markers passed {}", f(&r.field_passed));
    let _ = writeln!(md, "| all {}\n", f(&r.field_all));
    let _ = writeln!(
        md,
        "## Motion: markers re-simulated against the captured ones\n"
    );
    let _ = writeln!(
        md,
        "| field | rms (cm) | max (cm) | rms / length | max / length |\n|---|---|---|---|---|"
    );
    for (name, (rms, max)) in [
        ("fitted", r.motion_fit),
        ("none (still air)", r.motion_none),
    ] {
        let _ = writeln!(
            md,
            "| {name} | {rms:.3} | {max:.3} | {:.4} | {:.4} |",
            rms / r.length,
            max / r.length
        );
    }
    let _ = writeln!(md, "\nPer frame: `capture.csv`; plotted in `capture.png`.");
    let mut csv = String::from("frame,rms_fit_cm,max_fit_cm,rms_none_cm,max_none_cm\n");
    for e in &r.per_frame {
        let _ = writeln!(
            csv,
            "{},{:.5},{:.5},{:.5},{:.5}",
            e.frame, e.rms_fit, e.max_fit, e.rms_none, e.max_none
        );
    }
    let md_path = out.join("capture.md");
    std::fs::write(&md_path, md).map_err(io(&md_path))?;
    let csv_path = out.join("capture.csv");
    std::fs::write(&csv_path, csv).map_err(io(&csv_path))?;
    let series = |name: &str, i: usize, g: &dyn Fn(&FrameError) -> f64| Series {
        name: name.into(),
        color: plot::palette(i),
        points: r.per_frame.iter().map(|e| (e.frame as f64, g(e))).collect(),
    };
    let img = plot::loglog(
        "Markers re-simulated vs captured",
        "frame",
        "marker error (cm)",
        &[
            series("fitted rms", 0, &|e| e.rms_fit),
            series("fitted max", 1, &|e| e.max_fit),
            series("no wind rms", 2, &|e| e.rms_none),
            series("no wind max", 3, &|e| e.max_none),
        ],
        None,
    );
    let png = out.join("capture.png");
    img.save(&png).map_err(|e| KamiError::Image {
        path: png.clone(),
        message: e.to_string(),
    })
}
