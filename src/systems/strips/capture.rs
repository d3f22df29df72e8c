//! Hair motion capture and the EFF fitted from it (Kazama et al. sections 3.1–3.3): markers
//! on the 27 strands of the layer model, read from and written to a CSV file, and eq 3,
//! which turns each marker's displacement from rest into the wind that moved it.
//!
//! The marker file is CSV with a header naming the columns `frame, strand, marker, x, y, z`
//! (any order), one row per marker per frame, positions in centimetres. Frames are
//! consecutive and ascending (the first may be any number); strands and markers are numbered
//! from 0 without gaps; every frame holds every marker of the first frame exactly once.
//! Blank lines and lines starting with `#` are skipped. A file that breaks any of this is
//! refused with the line where it broke, before anything large is reserved.

use crate::error::{KamiError, Result};
use glam::DVec3;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Most strands a marker file may hold (the paper has 27).
pub const MAX_STRANDS: usize = 1024;
/// Most markers on one strand (the paper has 4–10).
pub const MAX_MARKERS: usize = 256;
/// Most frames (an hour at 120 fps is 432 000).
pub const MAX_FRAMES: usize = 1_000_000;
/// Most marker positions in all (frames × markers): 480 MB of f64 triples.
pub const MAX_POSITIONS: usize = 20_000_000;
/// The largest marker file read.
const MAX_FILE_BYTES: u64 = 2 << 30;

/// The six columns of a marker file, in the order Kami writes them.
pub const COLUMNS: [&str; 6] = ["frame", "strand", "marker", "x", "y", "z"];

/// Marker trajectories: `strands[strand][marker][frame]`, centimetres.
#[derive(Clone, Debug, PartialEq)]
pub struct Capture {
    /// Frame number of the first frame in the file (frames are consecutive from it).
    pub start: u32,
    /// Frames held (>= 2).
    pub frames: usize,
    pub strands: Vec<Vec<Vec<DVec3>>>,
}

fn data(path: &str, line: Option<usize>, message: impl Into<String>) -> KamiError {
    KamiError::Data {
        path: path.to_string(),
        line,
        message: message.into(),
    }
}

impl Capture {
    /// Markers in all (over all strands).
    pub fn markers(&self) -> usize {
        self.strands.iter().map(Vec::len).sum()
    }

    /// Read a marker file.
    pub fn read(path: &Path) -> Result<Capture> {
        let io = |source| KamiError::Io {
            path: path.to_path_buf(),
            source,
        };
        let name = path.display().to_string();
        let len = std::fs::metadata(path).map_err(io)?.len();
        if len > MAX_FILE_BYTES {
            return Err(data(
                &name,
                None,
                format!("{len} bytes: larger than the {MAX_FILE_BYTES} a marker file may have"),
            ));
        }
        let text = std::fs::read_to_string(path).map_err(io)?;
        Capture::parse(&text, &name)
    }

    /// Parse marker CSV text; `path` names it in errors.
    pub fn parse(text: &str, path: &str) -> Result<Capture> {
        let err = |line: usize, m: String| data(path, Some(line), m);
        let mut rows = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
        let Some((hline, header)) = rows.next() else {
            return Err(data(path, None, "empty: no header line"));
        };
        let (at, ncol) = columns(header, path, hline)?;

        // The first frame fixes the layout: (strand, marker) → (position, line).
        let mut first: BTreeMap<(usize, usize), (DVec3, usize)> = BTreeMap::new();
        // After it: strand offsets into one frame's flat slots, and the slots being filled.
        let mut offsets: Vec<usize> = Vec::new();
        let mut total = 0usize;
        let mut current: Vec<Option<DVec3>> = Vec::new();
        let mut frames: Vec<Vec<DVec3>> = Vec::new();
        let mut start = None;
        let mut frame = 0u64;
        let mut last_line = hline;

        // Close a frame after the first: every slot filled.
        let close = |current: &mut Vec<Option<DVec3>>,
                     frames: &mut Vec<Vec<DVec3>>,
                     offsets: &[usize],
                     frame: u64,
                     line: usize|
         -> Result<()> {
            if let Some(k) = current.iter().position(Option::is_none) {
                let s = offsets.partition_point(|&o| o <= k) - 1;
                return Err(err(
                    line,
                    format!(
                        "frame {frame} lacks strand {s} marker {} (every frame holds every \
                         marker of the first)",
                        k - offsets[s]
                    ),
                ));
            }
            frames.push(current.drain(..).map(Option::unwrap).collect());
            current.resize(offsets.last().copied().unwrap_or(0), None);
            Ok(())
        };

        for (line, row) in rows {
            let fields: Vec<&str> = row.split(',').map(str::trim).collect();
            if fields.len() != ncol {
                return Err(err(
                    line,
                    format!("{} fields; the header has {ncol} columns", fields.len()),
                ));
            }
            let (f, s, m, p) = marker_row(&fields, &at, path, line)?;

            let start_f = *start.get_or_insert(f);
            if f < frame {
                return Err(err(
                    line,
                    format!("frames out of order: frame {f} after frame {frame}"),
                ));
            }
            if f > frame + 1 && f != start_f {
                return Err(err(
                    line,
                    format!(
                        "frame {} is missing: frame {f} follows frame {frame}",
                        frame + 1
                    ),
                ));
            }
            if f - start_f >= MAX_FRAMES as u64 {
                return Err(err(
                    line,
                    format!("more than the {MAX_FRAMES} frames Kami reads"),
                ));
            }
            if f == start_f {
                frame = f;
                if let Some((_, l)) = first.get(&(s, m)) {
                    return Err(err(
                        line,
                        format!("strand {s} marker {m} appears twice in frame {f} (line {l})"),
                    ));
                }
                first.insert((s, m), (p, line));
            } else {
                if f > frame {
                    if frame == start_f {
                        (offsets, total) = layout(path, &first, last_line)?;
                        current = vec![None; total];
                        frames.push(first.values().map(|(p, _)| *p).collect());
                    } else {
                        close(&mut current, &mut frames, &offsets, frame, last_line)?;
                    }
                    if (frames.len() + 1).saturating_mul(total) > MAX_POSITIONS {
                        return Err(err(
                            line,
                            format!("more than the {MAX_POSITIONS} marker positions Kami reads"),
                        ));
                    }
                    frame = f;
                }
                let slot = match offsets.get(s) {
                    Some(&o) if o + m < offsets[s + 1] => o + m,
                    _ => {
                        return Err(err(
                            line,
                            format!("strand {s} marker {m} is not in the first frame ({start_f})"),
                        ))
                    }
                };
                if current[slot].is_some() {
                    return Err(err(
                        line,
                        format!("strand {s} marker {m} appears twice in frame {f}"),
                    ));
                }
                current[slot] = Some(p);
            }
            last_line = line;
        }
        let Some(start) = start else {
            return Err(data(path, Some(hline), "no marker rows after the header"));
        };
        if frame == start {
            return Err(data(
                path,
                Some(last_line),
                "one frame: fitting the wind needs at least two",
            ));
        }
        close(&mut current, &mut frames, &offsets, frame, last_line)?;
        // Transpose frame-major slots into strand → marker → frame.
        let strands = (0..offsets.len() - 1)
            .map(|s| {
                (offsets[s]..offsets[s + 1])
                    .map(|k| frames.iter().map(|fr| fr[k]).collect())
                    .collect()
            })
            .collect();
        Ok(Capture {
            start: start as u32,
            frames: frames.len(),
            strands,
        })
    }

    /// The marker file's text: the header, then one row per frame, strand and marker, in
    /// that order; positions with 4 decimals (a micrometre).
    pub fn to_csv(&self) -> String {
        let mut out = String::with_capacity(40 * self.frames * self.markers() + 32);
        out.push_str(&COLUMNS.join(","));
        out.push('\n');
        for f in 0..self.frames {
            for (s, markers) in self.strands.iter().enumerate() {
                for (m, track) in markers.iter().enumerate() {
                    let p = track[f];
                    let _ = writeln!(
                        out,
                        "{},{s},{m},{:.4},{:.4},{:.4}",
                        self.start as usize + f,
                        p.x,
                        p.y,
                        p.z
                    );
                }
            }
        }
        out
    }

    /// Write the marker file.
    pub fn write(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_csv()).map_err(|source| KamiError::Io {
            path: path.to_path_buf(),
            source,
        })
    }
}

/// Check the first frame's markers: strands 0.. without gaps, each with markers 0.. without
/// gaps, at least two. Returns each strand's offset into a frame's slots (plus the end).
fn layout(
    path: &str,
    first: &BTreeMap<(usize, usize), (DVec3, usize)>,
    end_line: usize,
) -> Result<(Vec<usize>, usize)> {
    // Markers per strand; the map is sorted by (strand, marker).
    let mut counts: Vec<usize> = Vec::new();
    for (&(s, m), &(_, line)) in first {
        if s > counts.len() {
            return Err(data(
                path,
                Some(line),
                format!(
                    "strand {} has no markers (strands are numbered from 0)",
                    counts.len()
                ),
            ));
        }
        if s == counts.len() {
            counts.push(0);
        }
        if m != counts[s] {
            return Err(data(
                path,
                Some(line),
                format!(
                    "strand {s} has no marker {} (markers are numbered from 0)",
                    counts[s]
                ),
            ));
        }
        counts[s] += 1;
    }
    if counts.is_empty() {
        return Err(data(path, Some(end_line), "no markers"));
    }
    if let Some(s) = counts.iter().position(|&c| c < 2) {
        return Err(one_marker(path, first, s));
    }
    let mut offsets = vec![0];
    for c in counts {
        offsets.push(offsets.last().unwrap() + c);
    }
    let total = *offsets.last().unwrap();
    Ok((offsets, total))
}

fn one_marker(path: &str, first: &BTreeMap<(usize, usize), (DVec3, usize)>, s: usize) -> KamiError {
    let line = first.get(&(s, 0)).map(|(_, l)| *l);
    data(
        path,
        line,
        format!("strand {s} has one marker: a strand needs at least two"),
    )
}

/// One wind sample of eq 3: the acceleration that moved a marker, and where.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub strand: usize,
    pub marker: usize,
    /// Where the marker was on average while it moved (see [`wind_samples`]).
    pub position: DVec3,
    /// The wind's acceleration (cm/s²).
    pub force: DVec3,
}

/// Eq 3, `Ω = 2 (X(s) − X(0)) / s² · E(Φ)`, per marker. Our reading:
///
/// - `s` is a time, `s = step · frame_time` seconds (the paper counts it in capture frames;
///   in frames Ω would change with the capture rate), so Ω is an acceleration in cm/s², the
///   unit of every force on strips.
/// - `2 (X(s) − X(0)) / s²` is the constant acceleration that carries a point from rest at
///   `X(0)` to `X(s)` in time `s` (`X(s) = X(0) + a s² / 2`): the hair hangs still when the
///   wind starts, and over a short `s` the wind's push dominates the springs that later pull
///   it back. `baseline` (a capture of the same strands without wind, or the rig's own
///   motion from rest) is subtracted first, so what gravity or a moving head do to the hair
///   is not taken for wind.
/// - `E(Φ)` (eq 2's 3×3 matrix of the joint angles) maps a Cartesian force into the two
///   angular degrees of freedom of the marker's stick. The dynamics applies it to every
///   force it samples, the EFF's included, so the field stores the Cartesian acceleration
///   and `E` is left to the rig: applying it here too would apply it twice.
/// - The sample is placed where the marker was on average over `[0, s]` under that
///   constant acceleration: `X(0) + (X(s) − X(0)) / 3` (the mean of `a t² / 2` over `t`).
pub fn wind_samples(
    capture: &Capture,
    baseline: Option<&Capture>,
    frame_time: f64,
    step: usize,
) -> Result<Vec<Sample>> {
    let bad = |field: &str, value: String, allowed: &str| KamiError::Invalid {
        file: String::new(),
        field: field.into(),
        value,
        allowed: allowed.into(),
    };
    if !(frame_time.is_finite() && frame_time > 0.0) {
        return Err(bad("frame_time", frame_time.to_string(), "seconds, > 0"));
    }
    if step == 0 || step >= capture.frames {
        return Err(bad(
            "step",
            step.to_string(),
            &format!("1 to {} (frames after the first)", capture.frames - 1),
        ));
    }
    if let Some(b) = baseline {
        let same = b.frames > step
            && b.strands.len() == capture.strands.len()
            && b.strands
                .iter()
                .zip(&capture.strands)
                .all(|(x, y)| x.len() == y.len());
        if !same {
            return Err(bad(
                "baseline",
                format!("{} strands, {} frames", b.strands.len(), b.frames),
                "the same strands and markers as the capture, and more than `step` frames",
            ));
        }
    }
    let s = step as f64 * frame_time;
    let mut out = Vec::with_capacity(capture.markers());
    for (i, markers) in capture.strands.iter().enumerate() {
        for (j, x) in markers.iter().enumerate() {
            let moved = x[step] - x[0];
            let still = baseline.map_or(DVec3::ZERO, |b| {
                let y = &b.strands[i][j];
                y[step] - y[0]
            });
            let d = moved - still;
            out.push(Sample {
                strand: i,
                marker: j,
                position: x[0] + moved / 3.0,
                force: 2.0 * d / (s * s),
            });
        }
    }
    Ok(out)
}

/// Markers on each strand, as control point indices: 4 on the shortest strand to 10 on the
/// longest (the paper: "4-10 reflective markers ... depending on its length"), evenly spread
/// by index from the first joint after the root to the tip. The root never moves, so a
/// marker there would only say the wind is zero at the scalp.
pub fn marker_points(rest: &[super::RestStrip]) -> Vec<Vec<usize>> {
    let length =
        |s: &super::RestStrip| -> f64 { s.points.windows(2).map(|w| (w[1] - w[0]).length()).sum() };
    let lens: Vec<f64> = rest.iter().map(length).collect();
    let lo = lens.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = lens.iter().copied().fold(0.0, f64::max);
    rest.iter()
        .zip(&lens)
        .map(|(s, &l)| {
            let sticks = s.points.len().saturating_sub(1);
            let share = if hi > lo { (l - lo) / (hi - lo) } else { 1.0 };
            let n = ((4.0 + 6.0 * share).round() as usize).min(sticks);
            (1..=n)
                .map(|i| ((i * sticks) as f64 / n as f64).round() as usize)
                .collect()
        })
        .collect()
}

/// The markers' trajectories in simulated frames: `frames[f][strip * stride + k]` (the
/// dynamics' layout) at the control points `markers[strip]`.
pub fn capture_of(frames: &[Vec<DVec3>], stride: usize, markers: &[Vec<usize>]) -> Capture {
    let strands = markers
        .iter()
        .enumerate()
        .map(|(s, ks)| {
            ks.iter()
                .map(|&k| frames.iter().map(|fr| fr[s * stride + k]).collect())
                .collect()
        })
        .collect();
    Capture {
        start: 0,
        frames: frames.len(),
        strands,
    }
}

/// How far a fitted field is from the true one over a set of places.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FieldError {
    /// Places compared.
    pub count: usize,
    /// Root mean square of |fit − true| (cm/s²).
    pub rms: f64,
    /// That over the root mean square of |true|: 0 is exact, 1 is as wrong as no field.
    pub relative: f64,
    /// Mean and largest angle between fit and true (degrees; places where either is zero
    /// are left out of the angles).
    pub angle_mean: f64,
    pub angle_max: f64,
    /// Median of |fit| / |true| (1 is the right strength).
    pub ratio_median: f64,
}

/// Compare `(fit, true)` pairs.
pub fn field_error(pairs: &[(DVec3, DVec3)]) -> FieldError {
    if pairs.is_empty() {
        return FieldError::default();
    }
    let n = pairs.len() as f64;
    let err2: f64 = pairs.iter().map(|(f, t)| (*f - *t).length_squared()).sum();
    let true2: f64 = pairs.iter().map(|(_, t)| t.length_squared()).sum();
    let mut angles = Vec::new();
    let mut ratios = Vec::new();
    for (f, t) in pairs {
        if f.length() > 0.0 && t.length() > 0.0 {
            angles.push(f.angle_between(*t).to_degrees());
        }
        if t.length() > 0.0 {
            ratios.push(f.length() / t.length());
        }
    }
    ratios.sort_by(f64::total_cmp);
    let median = match ratios.len() {
        0 => f64::NAN,
        k if k % 2 == 1 => ratios[k / 2],
        k => 0.5 * (ratios[k / 2 - 1] + ratios[k / 2]),
    };
    FieldError {
        count: pairs.len(),
        rms: (err2 / n).sqrt(),
        relative: if true2 > 0.0 {
            (err2 / true2).sqrt()
        } else {
            f64::NAN
        },
        angle_mean: angles.iter().sum::<f64>() / angles.len().max(1) as f64,
        angle_max: angles.iter().copied().fold(0.0, f64::max),
        ratio_median: median,
    }
}

/// Distance between two captures of the same markers: root mean square and largest over
/// every marker and frame (cm).
pub fn motion_error(a: &Capture, b: &Capture) -> (f64, f64) {
    let mut sum = 0.0;
    let mut max = 0.0f64;
    let mut n = 0usize;
    for (sa, sb) in a.strands.iter().zip(&b.strands) {
        for (ta, tb) in sa.iter().zip(sb) {
            for (p, q) in ta.iter().zip(tb) {
                let d = (*p - *q).length();
                sum += d * d;
                max = max.max(d);
                n += 1;
            }
        }
    }
    ((sum / n.max(1) as f64).sqrt(), max)
}

// ---------------------------------------------------------------------------------------
// The fit (section 3.2). The round trip that measures it (`bench::capture`) simulates
// marker strands under a known wind with `simulate_markers` and fits them with `fit`.

/// Frames over which eq 3 measures each marker's push (`s = 1 frame`): the shortest span
/// the capture offers, where the wind dominates the springs that later pull the hair back.
pub const FIT_STEP: usize = 1;

/// Markers of `strips` simulated for `frames` frames in the EFF `eff` (still air without
/// one) plus a uniform wind `uniform`, under Earth's gravity on a still default head, passed through the marker
/// file's text (4 decimals) so that what is fitted is exactly what a file would hold.
pub fn simulate_markers(
    strips: &crate::systems::strips::block::Strips,
    eff: Option<std::sync::Arc<crate::forces::eff::Eff>>,
    uniform: DVec3,
    frames: u32,
) -> Result<Capture> {
    let head = crate::scene::Head::default();
    let rest = super::hom::build(strips, &head)?;
    let forces = crate::forces::Forces {
        // The capture studio is on Earth (the strips' gravity before it joined the forces).
        gravity: DVec3::from(crate::scene::forces::EARTH_GRAVITY),
        wind: vec![crate::scene::WindKey {
            frame: 0.0,
            force: uniform.to_array(),
            interp: crate::scene::Interp::Step,
        }],
        head_motion: Vec::new(),
        center: DVec3::from(head.center),
        eff,
    };
    let clip = super::dynamics::simulate(&rest, &strips.motion, &forces, &head, &[], frames)?;
    let stride = super::dynamics::Rig::new(&rest, &strips.motion)?.stride();
    let c = capture_of(&clip, stride, &marker_points(&rest));
    Capture::parse(&c.to_csv(), "<simulated markers>")
}

/// The uniform acceleration (cm/s²) of the calibration runs of [`fit`].
const PROBE: f64 = 100.0;

/// Fit an EFF from markers alone (section 3.2). Eq 3 per marker (`FIT_STEP` frames, minus
/// the still-air baseline) gives the acceleration the marker showed; our reading of `E(Φ)`
/// maps it back to the wind. A marker on a chain of sticks does not move as a free point
/// would: the sticks do not stretch (the wind along the hair is invisible) and every joint
/// above it turns too (a tip marker moves several times as far as its wind alone would
/// carry it). So the map is measured on the strands' own model (`strips`, what a capture
/// assumes of the hair): three runs in a uniform wind of `PROBE` along x, y and z give each
/// marker's 3×3 response `A` (shown acceleration per unit wind), and the wind is the
/// regularised solution of `A f = a` closest to the outside force `f0` (what the source
/// says the wind is where the markers cannot tell): `f = f0 + Aᵀ (A Aᵀ + λ I)⁻¹ (a − A f0)`.
/// These samples define the cells the markers passed through, the paper's fill rules the
/// rest. The grid, source and head are given (`desc`: where the capture volume and the fan
/// stood, which markers cannot tell); the outside strength is the median magnitude of the
/// samples solved without `f0` (a marker knows its wind, not the wind far away).
pub fn fit(
    desc: &crate::forces::eff::EffDesc,
    capture: &Capture,
    baseline: &Capture,
    strips: &crate::systems::strips::block::Strips,
) -> Result<crate::forces::eff::Eff> {
    // The strands' model is a strips block: its own check first (the motion's frame time
    // is eq 3's time unit here, under the block's bound).
    super::block::check_motion(&strips.motion)?;
    let frame_time = strips.motion.frame_time;
    let shown = wind_samples(capture, Some(baseline), frame_time, FIT_STEP)?;
    let frames = FIT_STEP as u32;
    let still = simulate_markers(strips, None, DVec3::ZERO, frames)?;
    let mut response = Vec::new();
    for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
        let moved = simulate_markers(strips, None, axis * PROBE, frames)?;
        response.push(wind_samples(&moved, Some(&still), frame_time, FIT_STEP)?);
    }
    if response.iter().any(|r| r.len() != shown.len()) {
        return Err(KamiError::Invalid {
            file: String::new(),
            field: "capture".into(),
            value: format!("{} markers", shown.len()),
            allowed: "the markers of the strands' model (marker_points)".into(),
        });
    }
    let solve = |k: usize, f0: DVec3| -> DVec3 {
        let a = glam::DMat3::from_cols(
            response[0][k].force / PROBE,
            response[1][k].force / PROBE,
            response[2][k].force / PROBE,
        );
        let aat = a * a.transpose();
        let lambda = 1e-2 * (aat.x_axis.x + aat.y_axis.y + aat.z_axis.z) / 3.0 + 1e-12;
        let m = aat + glam::DMat3::from_diagonal(DVec3::splat(lambda));
        f0 + a.transpose() * (m.inverse() * (shown[k].force - a * f0))
    };
    let mut mags: Vec<f64> = (0..shown.len())
        .map(|k| solve(k, DVec3::ZERO).length())
        .collect();
    mags.sort_by(f64::total_cmp);
    let strength = mags.get(mags.len() / 2).copied().unwrap_or(0.0);
    let fitted = crate::forces::eff::EffDesc {
        strength,
        samples: Vec::new(),
        blowers: Vec::new(),
        gust: Vec::new(),
        file: None,
        loaded: None,
        ..desc.clone()
    };
    let head = fitted.head.map_or(DVec3::from(fitted.center), DVec3::from);
    let f0 = (head - DVec3::from(fitted.source)).normalize_or_zero() * strength;
    let pairs: Vec<(DVec3, DVec3)> = (0..shown.len())
        .map(|k| (shown[k].position, solve(k, f0)))
        .collect();
    crate::forces::eff::Eff::from_samples(&fitted, &pairs)
}

/// The column of each of `COLUMNS` in the marker file's `header` (line `hline` of `path`),
/// and how many columns it has.
fn columns(header: &str, path: &str, hline: usize) -> Result<([usize; 6], usize)> {
    let err = |line: usize, m: String| data(path, Some(line), m);
    // Column of each of COLUMNS in a row.
    let mut at = [usize::MAX; 6];
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    for (i, n) in names.iter().enumerate() {
        let n = n.to_ascii_lowercase();
        let Some(c) = COLUMNS.iter().position(|c| *c == n) else {
            return Err(err(
                hline,
                format!(
                    "unknown column `{n}`: the columns are {}",
                    COLUMNS.join(", ")
                ),
            ));
        };
        if at[c] != usize::MAX {
            return Err(err(hline, format!("column `{n}` appears twice")));
        }
        at[c] = i;
    }
    if let Some(c) = at.iter().position(|&i| i == usize::MAX) {
        return Err(err(
            hline,
            format!(
                "missing column `{}`: the header needs {}",
                COLUMNS[c],
                COLUMNS.join(", ")
            ),
        ));
    }
    Ok((at, names.len()))
}

/// One marker row's frame, strand, marker and position (line `line` of `path`).
fn marker_row(
    fields: &[&str],
    at: &[usize; 6],
    path: &str,
    line: usize,
) -> Result<(u64, usize, usize, DVec3)> {
    let err = |line: usize, m: String| data(path, Some(line), m);
    let int = |c: usize, cap: u64| -> Result<u64> {
        let t = fields[at[c]];
        let v: u64 = t.parse().map_err(|_| {
            err(
                line,
                format!("{}: `{t}` is not a whole number >= 0", COLUMNS[c]),
            )
        })?;
        if v >= cap {
            return Err(err(
                line,
                format!("{} {v}: Kami reads fewer than {cap}", COLUMNS[c]),
            ));
        }
        Ok(v)
    };
    let f = int(0, u32::MAX as u64)?;
    let s = int(1, MAX_STRANDS as u64)? as usize;
    let m = int(2, MAX_MARKERS as u64)? as usize;
    let mut p = [0.0f64; 3];
    for (k, v) in p.iter_mut().enumerate() {
        let t = fields[at[3 + k]];
        *v = t
            .parse()
            .map_err(|_| err(line, format!("{}: `{t}` is not a number", COLUMNS[3 + k])))?;
        if !v.is_finite() {
            return Err(err(
                line,
                format!("{}: `{t}` is not finite", COLUMNS[3 + k]),
            ));
        }
    }
    Ok((f, s, m, DVec3::from(p)))
}
