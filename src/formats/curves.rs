//! Cubic curves as USD defines them (`UsdGeomBasisCurves`): Bézier, B-spline and
//! Catmull-Rom bases with nonperiodic, periodic and pinned wrap, evaluated into the
//! polylines Kami simulates and draws. Kami's strands are polylines of equal segments; a
//! groom authored as cubic curves (Houdini's and Blender's usual output) is evaluated here
//! and then resampled by the hair group that names it.
//!
//! Everything is f64 and a pure function of the control points, so the same evaluation is
//! the reference the tests compare against.

use glam::DVec3;

/// How a strand's points make a curve: USD's `type` (linear or cubic) and `basis`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Basis {
    /// Straight pieces between the points (USD `type = "linear"`).
    #[default]
    Linear,
    /// Cubic Bézier: every third point is on the curve (vstep 3).
    Bezier,
    /// Uniform cubic B-spline: smooth, through none of its points (vstep 1).
    Bspline,
    /// Catmull-Rom: through every inner point (vstep 1).
    CatmullRom,
}

/// What happens at a curve's ends (USD `wrap`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// Open: a cubic curve spans its inner segments only.
    #[default]
    Nonperiodic,
    /// Closed: the last point joins the first.
    Periodic,
    /// Open, through the first and last points (phantom points `2 P0 - P1` at each end);
    /// USD defines it for B-spline and Catmull-Rom, and reads it as nonperiodic otherwise.
    Pinned,
}

impl Basis {
    /// The USD token (`basis`, or `linear` for the type).
    pub fn token(self) -> &'static str {
        match self {
            Basis::Linear => "linear",
            Basis::Bezier => "bezier",
            Basis::Bspline => "bspline",
            Basis::CatmullRom => "catmullRom",
        }
    }

    /// The four weights of a segment's control points at `t` in 0..1.
    pub fn weights(self, t: f64) -> [f64; 4] {
        let (t2, t3) = (t * t, t * t * t);
        let s = 1.0 - t;
        match self {
            Basis::Linear => [s, t, 0.0, 0.0],
            Basis::Bezier => [s * s * s, 3.0 * t * s * s, 3.0 * t2 * s, t3],
            Basis::Bspline => [
                s * s * s / 6.0,
                (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
                (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
                t3 / 6.0,
            ],
            Basis::CatmullRom => [
                0.5 * (-t3 + 2.0 * t2 - t),
                0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
                0.5 * (-3.0 * t3 + 4.0 * t2 + t),
                0.5 * (t3 - t2),
            ],
        }
    }
}

impl Wrap {
    /// The USD token.
    pub fn token(self) -> &'static str {
        match self {
            Wrap::Nonperiodic => "nonperiodic",
            Wrap::Periodic => "periodic",
            Wrap::Pinned => "pinned",
        }
    }
}

/// The wrap a basis really gets: pinned means nothing to linear and Bézier curves.
fn effective(basis: Basis, wrap: Wrap) -> Wrap {
    match (basis, wrap) {
        (Basis::Linear | Basis::Bezier, Wrap::Pinned) => Wrap::Nonperiodic,
        _ => wrap,
    }
}

/// Segments of a curve of `n` points, or `None` when `n` does not make one (USD's rules:
/// Bézier needs `3k + 1` points open and `3k` closed, the other cubics 4 open, 3 closed
/// and 2 pinned; linear curves 2).
pub fn segments(basis: Basis, wrap: Wrap, n: usize) -> Option<usize> {
    let wrap = effective(basis, wrap);
    match (basis, wrap) {
        (Basis::Linear, Wrap::Periodic) => (n >= 3).then_some(n),
        (Basis::Linear, _) => (n >= 2).then(|| n - 1),
        (Basis::Bezier, Wrap::Periodic) => (n >= 3 && n % 3 == 0).then_some(n / 3),
        (Basis::Bezier, _) => (n >= 4 && (n - 1) % 3 == 0).then(|| (n - 1) / 3),
        (_, Wrap::Periodic) if n >= 3 => Some(n),
        (_, Wrap::Pinned) if n >= 2 => Some(n - 1),
        (_, Wrap::Nonperiodic) if n >= 4 => Some(n - 3),
        _ => None,
    }
}

/// What `segments` asks of the point count, for messages.
pub fn rule(basis: Basis, wrap: Wrap) -> &'static str {
    match (basis, effective(basis, wrap)) {
        (Basis::Linear, Wrap::Periodic) => "3 or more points",
        (Basis::Linear, _) => "2 or more points",
        (Basis::Bezier, Wrap::Periodic) => "a multiple of 3 points (3 or more)",
        (Basis::Bezier, _) => "3k + 1 points (4, 7, 10, ...)",
        (_, Wrap::Periodic) => "3 or more points",
        (_, Wrap::Pinned) => "2 or more points",
        (_, Wrap::Nonperiodic) => "4 or more points",
    }
}

/// Values at the segment ends of a curve with `segments` segments: USD's `varying`
/// interpolation (one per segment end open, one per segment closed).
pub fn varying_count(wrap: Wrap, basis: Basis, segments: usize) -> usize {
    if effective(basis, wrap) == Wrap::Periodic {
        segments
    } else {
        segments + 1
    }
}

/// One per-point value stream of a curve, `arity` numbers per value.
pub struct Channel<'a> {
    pub values: &'a [f64],
    pub arity: usize,
    /// USD `varying`: one value per segment end, linear along each segment. Otherwise one
    /// per control point, evaluated with the basis like the points.
    pub varying: bool,
}

/// Component `c` of channel `ch` at segment `s`, parameter `t` in 0..1, on a curve of `n`
/// points with `segs` segments.
#[allow(clippy::too_many_arguments)]
fn value(
    basis: Basis,
    wrap: Wrap,
    n: usize,
    segs: usize,
    ch: &Channel,
    s: usize,
    t: f64,
    c: usize,
) -> f64 {
    let a = ch.arity;
    let x = |i: usize| ch.values[i * a + c];
    if ch.varying {
        let vcount = varying_count(wrap, basis, segs);
        return x(s % vcount) * (1.0 - t) + x((s + 1) % vcount) * t;
    }
    let w = basis.weights(t);
    let taps = if basis == Basis::Linear { 2 } else { 4 };
    let mut acc = 0.0;
    for (k, wk) in w.iter().enumerate().take(taps) {
        let e = s + k;
        let v = match (basis, wrap) {
            (Basis::Linear, _) => x(e % n),
            (Basis::Bezier, _) => x((3 * s + k) % n),
            (_, Wrap::Periodic) => x(e % n),
            // The extended points [2 P0 - P1, P0 .. Pn-1, 2 Pn-1 - Pn-2]: segment s is
            // extended points s..s+4.
            (_, Wrap::Pinned) if e == 0 => 2.0 * x(0) - x(1),
            (_, Wrap::Pinned) if e == n + 1 => 2.0 * x(n - 1) - x(n - 2),
            (_, Wrap::Pinned) => x(e - 1),
            (_, Wrap::Nonperiodic) => x(e),
        };
        acc += wk * v;
    }
    acc
}

/// Sample one curve of `n` control points: `per_segment` samples in each segment
/// (t = k / per_segment), then the curve's end (a closed curve ends where it began).
/// `out[i]` receives channel i's samples. Nothing is written when `n` makes no curve
/// ([`segments`]); the caller checked varying channels' counts with [`varying_count`].
pub fn tessellate(
    basis: Basis,
    wrap: Wrap,
    n: usize,
    channels: &[Channel],
    per_segment: usize,
    out: &mut [Vec<f64>],
) {
    let wrap = effective(basis, wrap);
    let Some(segs) = segments(basis, wrap, n) else {
        return;
    };
    let per_segment = per_segment.max(1);
    let mut emit = |s: usize, t: f64| {
        for (ch, o) in channels.iter().zip(out.iter_mut()) {
            for c in 0..ch.arity {
                o.push(value(basis, wrap, n, segs, ch, s, t, c));
            }
        }
    };
    for s in 0..segs {
        for k in 0..per_segment {
            emit(s, k as f64 / per_segment as f64);
        }
    }
    emit(segs - 1, 1.0);
}

/// Samples per segment when cubic curves become polylines: a segment turning through a
/// quarter circle is then within 0.5 % of its radius (sagitta of a 1/8 arc), well under a
/// hair's width at the segment lengths of real grooms, and Kami resamples the result to
/// each group's own segments anyway.
pub const PER_SEGMENT: usize = 8;

/// Most points a file's curves may become, so a file of many tiny segments cannot ask
/// for an allocation far past its own size: fewer samples per segment beyond it.
pub const MAX_SAMPLES: usize = 1 << 23;

/// Samples per segment for `segments` segments of `basis` in all (at least 1; straight
/// pieces need no more).
pub fn per_segment_for(basis: Basis, segments: usize) -> usize {
    if basis == Basis::Linear {
        return 1;
    }
    (MAX_SAMPLES / segments.max(1)).clamp(1, PER_SEGMENT)
}

/// The point of a curve at parameter `u` in 0..segments (segment `floor(u)`, t the
/// fraction; `u = segments` is the end), or `None` when the points make no curve.
pub fn point_at(basis: Basis, wrap: Wrap, points: &[DVec3], u: f64) -> Option<DVec3> {
    let n = points.len();
    let wrap = effective(basis, wrap);
    let segs = segments(basis, wrap, n)?;
    let s = (u.max(0.0).floor() as usize).min(segs - 1);
    let t = u - s as f64;
    let flat: Vec<f64> = points.iter().flat_map(|p| p.to_array()).collect();
    let ch = Channel {
        values: &flat,
        arity: 3,
        varying: false,
    };
    let v = |c| value(basis, wrap, n, segs, &ch, s, t, c);
    Some(DVec3::new(v(0), v(1), v(2)))
}
