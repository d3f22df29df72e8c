//! Strand files: grooms made in other tools come in, Kami's hair goes out (`kami convert`,
//! the viewer's Files panel, and hair groups that name a file in the scene).
//!
//! Every reader returns the same [`Groom`]: polylines with optional per-point widths,
//! opacities and colours. Readers check counts against the body before allocating and
//! refuse NaN points, naming the file and the place (`KamiError::Data`).

use crate::error::{KamiError, Result};
use std::path::Path;

pub mod abc;
pub mod curves;
pub mod hair;
pub mod obj;
pub mod usd;
pub mod usdc;

pub use curves::{Basis, Wrap};

/// A groom as strand files carry it: curves, strand after strand. Usually polylines
/// (`basis` linear); a USD groom authored as cubic curves keeps its control points and
/// basis until [`Groom::into_linear`] evaluates it (so `kami convert` writes it back
/// cubic).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Groom {
    /// Points of each strand, in order (every strand has at least 2, and as many as its
    /// basis and wrap need: [`curves::segments`]).
    pub counts: Vec<u32>,
    /// All points, strand after strand (`counts` sums to its length), in Kami's units.
    /// Control points when `basis` is cubic.
    pub points: Vec<[f32; 3]>,
    /// Per-point width (diameter), when the file has one.
    pub widths: Option<Vec<f32>>,
    /// Per-point opacity in 0..1 (`.hair` stores transparency = 1 - opacity).
    pub opacities: Option<Vec<f32>>,
    /// Per-point RGB colour, sRGB-encoded, as Kami's materials are: `.hair`, OBJ and Alembic
    /// colours as the file stores them (their formats name no colour space), USD's linear
    /// `displayColor` converted on the way in and out.
    pub colors: Option<Vec<[f32; 3]>>,
    /// How the points make each curve (every strand the same).
    pub basis: Basis,
    /// Open, closed or pinned ends.
    pub wrap: Wrap,
    /// Per strand: its group (Unreal's `groom_group_id`; Kami opens one hair group per
    /// id), when the file has groups.
    pub group_ids: Option<Vec<i64>>,
    /// Per strand: a guide (Unreal's `groom_guide`): Kami simulates the guides and the
    /// other strands follow them.
    pub guides: Option<Vec<bool>>,
    /// Per strand: the root's UV on the scalp (Unreal's `groom_root_uv`); kept, not drawn.
    pub root_uvs: Option<Vec<[f32; 2]>>,
}

impl Groom {
    /// The points of strand `i`.
    pub fn strand(&self, i: usize) -> &[[f32; 3]] {
        let start: usize = self.counts[..i].iter().map(|&c| c as usize).sum();
        &self.points[start..start + self.counts[i] as usize]
    }

    /// Every strand's points, in order.
    pub fn strands(&self) -> impl Iterator<Item = &[[f32; 3]]> + '_ {
        let mut start = 0usize;
        self.counts.iter().map(move |&c| {
            let s = &self.points[start..start + c as usize];
            start += c as usize;
            s
        })
    }

    /// Whether these are open polylines already (nothing for `into_linear` to do).
    pub fn is_linear(&self) -> bool {
        self.basis == Basis::Linear && self.wrap != Wrap::Periodic
    }

    /// The curves as open polylines: cubic curves evaluated with their basis
    /// ([`curves::PER_SEGMENT`] samples a segment), closed curves ending where they began,
    /// per-point values evaluated like the points (widths and colours kept non-negative,
    /// opacities in 0..1, as a Catmull-Rom curve may overshoot its values). Call
    /// [`Groom::check`] first: counts that make no curve are left out.
    pub fn into_linear(self) -> Groom {
        if self.is_linear() {
            return self;
        }
        let per_point = |v: Option<Vec<f64>>| v.map(|v| (v, false));
        let wide = |v: &Option<Vec<f32>>| {
            per_point(v.as_ref().map(|v| v.iter().map(|&x| x as f64).collect()))
        };
        let widths = wide(&self.widths);
        let opacities = wide(&self.opacities);
        let colors = per_point(
            self.colors
                .as_ref()
                .map(|c| c.iter().flatten().map(|&x| x as f64).collect()),
        );
        evaluate(&self, &[(&widths, 1), (&opacities, 1), (&colors, 3)])
    }

    /// Put `other`'s strands after these. A per-point array only one side has is filled on
    /// the other side with a neutral value (width 0.01, opacity 1, white). Grooms of
    /// different bases or wraps both become polylines first.
    pub fn append(&mut self, mut other: Groom) {
        if (self.basis, self.wrap) != (other.basis, other.wrap) {
            if self.counts.is_empty() {
                (self.basis, self.wrap) = (other.basis, other.wrap);
            } else {
                *self = std::mem::take(self).into_linear();
                other = other.into_linear();
            }
        }
        let (na, nb) = (self.points.len(), other.points.len());
        join_filled(&mut self.widths, na, other.widths, nb, 0.01);
        join_filled(&mut self.opacities, na, other.opacities, nb, 1.0);
        join_filled(&mut self.colors, na, other.colors, nb, [1.0; 3]);
        // Per strand: group 0, not a guide, UV (0, 0) where one side has none.
        let (sa, sb) = (self.counts.len(), other.counts.len());
        join_filled(&mut self.group_ids, sa, other.group_ids, sb, 0);
        join_filled(&mut self.guides, sa, other.guides, sb, false);
        join_filled(&mut self.root_uvs, sa, other.root_uvs, sb, [0.0; 2]);
        self.counts.extend(other.counts);
        self.points.extend(other.points);
    }

    /// Check the invariants every reader guarantees; `origin` names the file in errors.
    pub fn check(&self, origin: &str) -> Result<()> {
        let bad = |message: String| KamiError::Data {
            path: origin.to_string(),
            line: None,
            message,
        };
        let total: u64 = self.counts.iter().map(|&c| c as u64).sum();
        if total != self.points.len() as u64 {
            return Err(bad(format!(
                "the strand counts add up to {total} points but there are {}",
                self.points.len()
            )));
        }
        for (name, len) in [
            ("group ids", self.group_ids.as_ref().map(Vec::len)),
            ("guide flags", self.guides.as_ref().map(Vec::len)),
            ("root UVs", self.root_uvs.as_ref().map(Vec::len)),
        ] {
            if let Some(n) = len.filter(|&n| n != self.counts.len()) {
                return Err(bad(format!("{n} {name} for {} strands", self.counts.len())));
            }
        }
        if let Some(i) = self.counts.iter().position(|&c| c < 2) {
            return Err(bad(format!(
                "strand {i} has {} point(s); at least 2 are needed",
                self.counts[i]
            )));
        }
        if let Some(i) = self
            .counts
            .iter()
            .position(|&c| curves::segments(self.basis, self.wrap, c as usize).is_none())
        {
            return Err(bad(format!(
                "strand {i} has {} points, which make no {} {} curve: it needs {}",
                self.counts[i],
                self.wrap.token(),
                self.basis.token(),
                curves::rule(self.basis, self.wrap)
            )));
        }
        if let Some(i) = self
            .points
            .iter()
            .position(|p| p.iter().any(|v| !v.is_finite()))
        {
            return Err(bad(format!(
                "point {i} is not finite: {:?}",
                self.points[i]
            )));
        }
        // Attributes Kami draws or writes must be numbers too (a colour of 1e308 in an OBJ
        // is infinite as f32).
        let attr = |name: &str, i: Option<usize>| match i {
            Some(i) => Err(bad(format!(
                "the {name} of point {i} is not a finite number"
            ))),
            None => Ok(()),
        };
        attr(
            "width",
            self.widths
                .as_ref()
                .and_then(|w| w.iter().position(|v| !v.is_finite())),
        )?;
        attr(
            "opacity",
            self.opacities
                .as_ref()
                .and_then(|o| o.iter().position(|v| !v.is_finite())),
        )?;
        if let Some(i) = self
            .widths
            .as_ref()
            .and_then(|w| w.iter().position(|&v| v < 0.0))
        {
            return Err(bad(format!("the width of point {i} is negative")));
        }
        if let Some(i) = self
            .opacities
            .as_ref()
            .and_then(|o| o.iter().position(|&v| !(0.0..=1.0).contains(&v)))
        {
            return Err(bad(format!(
                "the opacity of point {i} is {}, outside 0..1",
                self.opacities.as_ref().unwrap()[i]
            )));
        }
        attr(
            "colour",
            self.colors
                .as_ref()
                .and_then(|c| c.iter().position(|v| v.iter().any(|x| !x.is_finite()))),
        )?;
        let n = self.points.len();
        for (name, len) in [
            ("widths", self.widths.as_ref().map(Vec::len)),
            ("opacities", self.opacities.as_ref().map(Vec::len)),
            ("colors", self.colors.as_ref().map(Vec::len)),
        ] {
            if let Some(len) = len {
                if len != n {
                    return Err(bad(format!("{len} {name} for {n} points")));
                }
            }
        }
        Ok(())
    }
}

/// The extensions `read` and `write` know, for error messages.
pub const EXTENSIONS: &str = "`.hair` (Cem Yuksel), `.obj` (polylines), `.usda`, `.usdc`, `.usdz` or `.usd` (USD BasisCurves: text, binary crate, package), `.abc` (Alembic curves, read only)";

/// The strand formats, told apart by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Hair,
    Obj,
    /// USD text.
    Usda,
    /// USD binary crate (`.usdc`; a `.usd` that begins with the crate magic).
    Usdc,
    /// A USD package (a zip whose first file is the root layer).
    Usdz,
    /// `.usd`: crate or text, told apart by the first bytes (written as a crate, USD's
    /// default).
    Usd,
    /// Alembic (Ogawa) curves, read only.
    Abc,
}

impl Format {
    /// The format of `path` by its extension (case-insensitive), if it is a strand file.
    pub fn of(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "hair" => Some(Format::Hair),
            "obj" => Some(Format::Obj),
            "usda" => Some(Format::Usda),
            "usdc" => Some(Format::Usdc),
            "usdz" => Some(Format::Usdz),
            "usd" => Some(Format::Usd),
            "abc" => Some(Format::Abc),
            _ => None,
        }
    }

    /// Why Kami does not write this format, for one it reads only.
    pub fn read_only(self) -> Option<&'static str> {
        match self {
            // No maintained Rust crate writes Alembic (docs/formats.md).
            Format::Abc => {
                Some("Kami reads Alembic but does not write it; write `.usda`, `.hair` or `.obj`")
            }
            // openusd 0.6's crate writer makes files Pixar's USD opens without their prims
            // (tried: `usd-core` 26.11 sees an empty stage).
            Format::Usdc | Format::Usdz | Format::Usd => Some(
                "Kami reads binary USD but writes USD as text: write `.usda` (Pixar's \
                 `usdcat in.usda -o out.usdc` makes a crate file of it)",
            ),
            _ => None,
        }
    }
}

fn format_of(path: &Path) -> Result<Format> {
    Format::of(path).ok_or_else(|| {
        let ext = path.extension().and_then(|e| e.to_str());
        KamiError::Data {
            path: path.display().to_string(),
            line: None,
            message: format!(
                "{} is not a strand format Kami knows; use {EXTENSIONS}",
                ext.map_or("no extension".to_string(), |e| format!("`.{e}`")),
            ),
        }
    })
}

/// Linear to sRGB encoding (the inverse of [`srgb_to_linear`]; values above 1 stay above).
pub fn linear_to_srgb(c: f64) -> f64 {
    if c <= 0.0031308 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB encoding to linear.
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A `KamiError::Data` for `origin`.
pub(crate) fn data_error(origin: &str, line: Option<usize>, message: String) -> KamiError {
    KamiError::Data {
        path: origin.to_string(),
        line,
        message,
    }
}

/// Read a strand file at `time` seconds: an Alembic archive's sample nearest that time
/// (`abc::Sample::Time`), a USD file's groom at that time (time code = seconds times its
/// `timeCodesPerSecond`, samples interpolated as USD does); the other formats hold one pose
/// and refuse a time. `None` reads the first sample, as [`read`] does.
pub fn read_at(path: &Path, time: Option<f64>) -> Result<Groom> {
    let Some(t) = time else { return read(path) };
    let origin = path.display().to_string();
    let format = format_of(path)?;
    let groom = match format {
        Format::Abc => {
            let options = abc::Options {
                sample: abc::Sample::Time(t),
                ..abc::Options::default()
            };
            abc::read(path, &options)?.into_groom(&origin)
        }
        Format::Usda | Format::Usdc | Format::Usdz | Format::Usd => {
            let bytes = std::fs::read(path).map_err(|source| KamiError::Io {
                path: path.to_path_buf(),
                source,
            })?;
            let layer = usd_layer(&origin, &bytes, path)?;
            let tc = t * layer.time_codes_per_second(&origin)?;
            layer.groom(&origin, Some(tc))?
        }
        _ => {
            return Err(data_error(
                &origin,
                None,
                format!("a time ({t} s) is for Alembic and USD files; this file holds one pose"),
            ))
        }
    };
    groom.check(&origin)?;
    Ok(groom)
}

/// Read a strand file; the format is chosen by the extension (`.hair`, `.obj`, `.usda`, `.abc`).
pub fn read(path: &Path) -> Result<Groom> {
    format_of(path)?;
    let bytes = std::fs::read(path).map_err(|source| KamiError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read_bytes(&path.display().to_string(), &bytes, path)
}

fn read_bytes(origin: &str, bytes: &[u8], path: &Path) -> Result<Groom> {
    let groom = match format_of(path)? {
        Format::Hair => hair::parse(bytes, origin)?,
        Format::Obj => obj::parse(text(bytes, origin)?, origin)?,
        Format::Usda | Format::Usdc | Format::Usdz | Format::Usd => {
            usd_layer(origin, bytes, path)?.groom(origin, None)?
        }
        Format::Abc => abc::parse(bytes, origin)?,
    };
    groom.check(origin)?;
    Ok(groom)
}

/// Parse a strand file already in memory; `name`'s extension chooses the format and `name`
/// is what errors call the file (used by the fuzz harness and tests).
pub fn parse(name: &str, bytes: &[u8]) -> Result<Groom> {
    read_bytes(name, bytes, Path::new(name))
}

/// A USD file's layer, whichever its encoding: the extension says which, and a `.usd`'s
/// first bytes (a crate file begins with `PXR-USDC`).
pub fn usd_layer(origin: &str, bytes: &[u8], path: &Path) -> Result<usd::Layer> {
    match format_of(path)? {
        Format::Usdc => usdc::layer(bytes, origin),
        Format::Usdz => usdc::package(bytes, origin),
        Format::Usd if bytes.starts_with(usdc::MAGIC) => usdc::layer(bytes, origin),
        Format::Usda | Format::Usd => usd::layer(text(bytes, origin)?, origin),
        _ => Err(data_error(origin, None, "this is not a USD file".into())),
    }
}

fn text<'a>(bytes: &'a [u8], origin: &str) -> Result<&'a str> {
    std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        data_error(origin, Some(line), "the text is not UTF-8".into())
    })
}

/// Write a strand file; the format is chosen by the extension (`.hair`, `.obj`, `.usda`).
pub fn write(path: &Path, groom: &Groom) -> Result<()> {
    let format = format_of(path)?;
    let origin = path.display().to_string();
    if let Some(why) = format.read_only() {
        return Err(data_error(&origin, None, why.into()));
    }
    groom.check(&origin)?;
    if groom.counts.is_empty() {
        return Err(data_error(
            &origin,
            None,
            "the groom has no strands to write".into(),
        ));
    }
    // Only usda keeps cubic curves; the others get the polylines they evaluate to.
    let linear;
    let groom = if format == Format::Usda || groom.is_linear() {
        groom
    } else {
        linear = groom.clone().into_linear();
        &linear
    };
    let bytes = match format {
        Format::Hair => hair::to_bytes(groom, &origin)?,
        Format::Obj => obj::to_string(groom).into_bytes(),
        // Read-only formats were refused above.
        _ => usd::to_string(groom).into_bytes(),
    };
    std::fs::write(path, bytes).map_err(|source| KamiError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// `b` (`nb` values) after `a` (`na` values), where only one side has values: the other
/// side's are `fill` (a neutral value, or Unreal's group 0 and "not a guide").
pub(crate) fn join_filled<T: Clone>(
    a: &mut Option<Vec<T>>,
    na: usize,
    b: Option<Vec<T>>,
    nb: usize,
    fill: T,
) {
    match (a.as_mut(), b) {
        (None, None) => {}
        (Some(a), Some(b)) => a.extend(b),
        (Some(a), None) => a.extend(std::iter::repeat_n(fill, nb)),
        (None, Some(b)) => {
            let mut v = vec![fill; na];
            v.extend(b);
            *a = Some(v);
        }
    }
}

/// A prim's values of one attribute, and whether they are per segment end (`varying`).
pub(crate) type Values = (Vec<f64>, bool);

/// The polylines of `g`'s curves with the values `attrs` (widths, opacities, colours and
/// their arities) per point or per segment end (`varying`), all evaluated along each
/// curve; widths and colours kept non-negative, opacities in 0..1 (a Catmull-Rom curve
/// may overshoot its values).
pub(crate) fn evaluate(g: &Groom, attrs: &[(&Option<Values>, usize); 3]) -> Groom {
    let total: usize = g
        .counts
        .iter()
        .filter_map(|&c| curves::segments(g.basis, g.wrap, c as usize))
        .sum();
    let per = curves::per_segment_for(g.basis, total);
    let points: Vec<f64> = g.points.iter().flatten().map(|&x| x as f64).collect();
    let mut out: [Option<Vec<f64>>; 3] =
        std::array::from_fn(|i| attrs[i].0.as_ref().map(|_| Vec::new()));
    let mut lin = Groom::default();
    let (mut at, mut vat) = (0usize, 0usize);
    // Per-strand values follow their strands.
    let kept: Vec<bool> = g
        .counts
        .iter()
        .map(|&c| curves::segments(g.basis, g.wrap, c as usize).is_some())
        .collect();
    fn per_strand<T: Copy>(v: &Option<Vec<T>>, kept: &[bool]) -> Option<Vec<T>> {
        v.as_ref().map(|v| {
            v.iter()
                .zip(kept)
                .filter(|(_, &k)| k)
                .map(|(x, _)| *x)
                .collect()
        })
    }
    lin.group_ids = per_strand(&g.group_ids, &kept);
    lin.guides = per_strand(&g.guides, &kept);
    lin.root_uvs = per_strand(&g.root_uvs, &kept);
    for &c in &g.counts {
        let n = c as usize;
        // Counts that make no curve (`check` refuses them) are left out.
        let Some(segs) = curves::segments(g.basis, g.wrap, n) else {
            at += n;
            continue;
        };
        let nv = curves::varying_count(g.wrap, g.basis, segs);
        let mut chans = vec![curves::Channel {
            values: &points[at * 3..(at + n) * 3],
            arity: 3,
            varying: false,
        }];
        for (a, arity) in attrs.iter() {
            if let Some((v, varying)) = a {
                let (s, len) = if *varying { (vat, nv) } else { (at, n) };
                chans.push(curves::Channel {
                    values: &v[s * arity..(s + len) * arity],
                    arity: *arity,
                    varying: *varying,
                });
            }
        }
        let mut samples = vec![Vec::new(); chans.len()];
        curves::tessellate(g.basis, g.wrap, n, &chans, per, &mut samples);
        let mut it = samples.into_iter();
        let pts = it.next().unwrap_or_default();
        lin.counts.push((pts.len() / 3) as u32);
        lin.points.extend(
            pts.chunks_exact(3)
                .map(|p| [p[0] as f32, p[1] as f32, p[2] as f32]),
        );
        for o in out.iter_mut().flatten() {
            o.extend(it.next().unwrap_or_default());
        }
        at += n;
        vat += nv;
    }
    let [w, o, c] = out;
    lin.widths = w.map(|w| w.iter().map(|&x| x.max(0.0) as f32).collect());
    lin.opacities = o.map(|o| o.iter().map(|&x| x.clamp(0.0, 1.0) as f32).collect());
    lin.colors = c.map(|c| {
        c.chunks_exact(3)
            .map(|c| {
                [
                    c[0].max(0.0) as f32,
                    c[1].max(0.0) as f32,
                    c[2].max(0.0) as f32,
                ]
            })
            .collect()
    });
    lin
}

/// Most bytes of points an animated file may hold in memory as frames (`read_frames`):
/// 2 GiB, about 180 frames of a million-point groom.
pub const FRAMES_BUDGET: u64 = 2 << 30;

/// Most frames a cache may play (an hour at 24 fps is 86,400).
pub const MAX_FRAMES: usize = 100_000;

/// A groom's motion as its file holds it (a simulation cache): every frame's points, in
/// Kami's units, with the curve counts of the groom read at the first frame. Curves are
/// polylines (cubic ones evaluated per frame).
#[derive(Clone, Debug, PartialEq)]
pub struct Frames {
    /// Frames per second the file plays at (USD: `timeCodesPerSecond`; Alembic: the
    /// positions' time sampling).
    pub fps: f64,
    /// File time of each frame, seconds.
    pub times: Vec<f64>,
    /// Curve counts, the same at every frame.
    pub counts: Vec<u32>,
    /// Points of each frame (`counts` sums to each one's length).
    pub points: Vec<Vec<[f32; 3]>>,
}

impl Frames {
    /// Frame `i` as a groom (the counts and these points; no looks).
    pub fn groom(&self, i: usize) -> Groom {
        Groom {
            counts: self.counts.clone(),
            points: self.points[i].clone(),
            ..Groom::default()
        }
    }
}

/// The frames of an animated strand file: USD time samples (one frame per time code from
/// `startTimeCode` to `endTimeCode`, else from the first sample to the last) or Alembic
/// samples (one frame per positions sample). `None` for a still file (no samples, or one).
/// Refused when the frames would hold more than `budget` bytes of points, or when the
/// curve counts change between frames (topology that changes is not played).
pub fn read_frames(path: &Path, budget: u64) -> Result<Option<Frames>> {
    let origin = path.display().to_string();
    let format = format_of(path)?;
    let bytes = std::fs::read(path).map_err(|source| KamiError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let sampled = match format {
        Format::Usda | Format::Usdc | Format::Usdz | Format::Usd => {
            usd_frames(&origin, &bytes, path, budget)?
        }
        Format::Abc => abc_frames(&origin, &bytes, budget)?,
        _ => return Ok(None),
    };
    let Some(Sampled {
        fps,
        times,
        grooms: frames,
    }) = sampled
    else {
        return Ok(None);
    };
    let counts = frames[0].counts.clone();
    let mut points = Vec::with_capacity(frames.len());
    for (i, f) in frames.into_iter().enumerate() {
        f.check(&origin)?;
        if f.counts != counts {
            return Err(data_error(
                &origin,
                None,
                format!(
                    "frame {i} (time {:.4} s) has {} curves of {} points, frame 0 {} of {}: \
                     Kami plays caches whose curves keep their point counts",
                    times.get(i).copied().unwrap_or(f64::NAN),
                    f.counts.len(),
                    f.points.len(),
                    counts.len(),
                    counts.iter().map(|&c| c as u64).sum::<u64>()
                ),
            ));
        }
        points.push(f.points);
    }
    Ok(Some(Frames {
        fps,
        times,
        counts,
        points,
    }))
}

/// A cache's frames as read, before their counts are checked against each other.
struct Sampled {
    fps: f64,
    times: Vec<f64>,
    grooms: Vec<Groom>,
}

/// Bytes of points `n` frames of `first` take, refused beyond the budget before anything
/// is read (and a first frame without points, or more than `MAX_FRAMES` frames).
fn check_frames(origin: &str, first: &Groom, n: usize, budget: u64) -> Result<()> {
    if first.points.is_empty() {
        return Err(data_error(
            origin,
            None,
            "the first frame has no points".into(),
        ));
    }
    if n > MAX_FRAMES {
        return Err(data_error(
            origin,
            None,
            format!("{n} frames: Kami plays at most {MAX_FRAMES} frames of a cache"),
        ));
    }
    let need = (first.points.len() as u64)
        .saturating_mul(12)
        .saturating_mul(n as u64);
    if need > budget {
        return Err(data_error(
            origin,
            None,
            format!(
                "{n} frames of {} points take {:.2} GiB, over Kami's {:.2} GiB for a groom's \
                 frames: play fewer frames (trim the cache in the tool that wrote it) or open \
                 one frame (`time:` in the scene)",
                first.points.len(),
                need as f64 / (1u64 << 30) as f64,
                budget as f64 / (1u64 << 30) as f64
            ),
        ));
    }
    Ok(())
}

/// A USD layer's frames: one per time code from `startTimeCode` to `endTimeCode`, else
/// from the first sample to the last; `None` with fewer than two samples.
fn usd_frames(origin: &str, bytes: &[u8], path: &Path, budget: u64) -> Result<Option<Sampled>> {
    let layer = usd_layer(origin, bytes, path)?;
    let samples = layer.times();
    if samples.len() < 2 {
        return Ok(None);
    }
    let tcps = layer.time_codes_per_second(origin)?;
    let (start, end) = layer.range();
    let start = start.unwrap_or(samples[0]);
    let end = end.unwrap_or(samples[samples.len() - 1]);
    if end < start {
        return Err(data_error(
            origin,
            None,
            format!("endTimeCode {end} is before startTimeCode {start}"),
        ));
    }
    if end - start >= MAX_FRAMES as f64 {
        return Err(data_error(
            origin,
            None,
            format!(
                "time codes {start} to {end}: Kami plays at most {MAX_FRAMES} frames of a cache"
            ),
        ));
    }
    let n = (end - start).floor() as usize + 1;
    // An error at a frame says which time code it is at.
    let at = |tc: f64| {
        layer.groom(origin, Some(tc)).map_err(|e| match e {
            KamiError::Data {
                path,
                line,
                message,
            } => KamiError::Data {
                path,
                line,
                message: format!("at time code {tc}: {message}"),
            },
            e => e,
        })
    };
    let first = at(start)?.into_linear();
    check_frames(origin, &first, n, budget)?;
    let times = (0..n).map(|i| (start + i as f64) / tcps).collect();
    let mut grooms = vec![first];
    for i in 1..n {
        grooms.push(at(start + i as f64)?.into_linear());
    }
    Ok(Some(Sampled {
        fps: tcps,
        times,
        grooms,
    }))
}

/// An Alembic archive's frames: one per sample of its most-sampled object; `None` with
/// fewer than two.
fn abc_frames(origin: &str, bytes: &[u8], budget: u64) -> Result<Option<Sampled>> {
    let first = abc::parse_with(bytes, origin, &abc::Options::default())?;
    let Some(most) = first.objects.iter().max_by_key(|o| o.samples) else {
        return Ok(None);
    };
    let n = most.samples as usize;
    if n < 2 {
        return Ok(None);
    }
    let path_of_most = most.path.clone();
    let g0 = first.into_groom(origin).into_linear();
    check_frames(origin, &g0, n, budget)?;
    // Frame i is the most-sampled object's sample i; every object and transform is read at
    // that sample's time (objects of other time samplings stay in step, and `time:` reads
    // the same pose).
    let mut grooms = Vec::new();
    let mut t = Vec::with_capacity(n);
    for i in 0..n {
        let by_index = abc::Options {
            sample: abc::Sample::Index(i as u32),
            ..abc::Options::default()
        };
        let c = abc::parse_with(bytes, origin, &by_index)?;
        let ti = c
            .objects
            .iter()
            .find(|o| o.path == path_of_most)
            .map_or(0.0, |o| o.time);
        t.push(ti);
        if i == 0 {
            grooms.push(g0.clone());
            continue;
        }
        let by_time = abc::Options {
            sample: abc::Sample::Time(ti),
            ..abc::Options::default()
        };
        grooms.push(
            abc::parse_with(bytes, origin, &by_time)?
                .into_groom(origin)
                .into_linear(),
        );
    }
    let fps = match t.as_slice() {
        [a, b, ..] if b > a => 1.0 / (b - a),
        _ => 24.0,
    };
    Ok(Some(Sampled {
        fps,
        times: t,
        grooms,
    }))
}
