//! Alembic (`.abc`) curves, read only: the `ICurves` objects of an Ogawa archive (the
//! container every Alembic writer since 1.5 uses; the older HDF5 one is refused).
//!
//! A focused reader written from the Alembic sources (`lib/Alembic/Ogawa` and
//! `lib/Alembic/AbcCoreOgawa`): the `ogawa-rs` crate (0.4.0) allocates sizes read from the
//! file before checking them, panics on some property types (`todo!`, `assert!`), maps
//! sample indices of animated properties off by one, and reads indexed widths as an error.
//!
//! Read: every `ICurves` object at any depth, its positions (`P`), vertex counts, type,
//! wrap and basis (reported per object in [`CurvesObject`]; [`Curves::into_groom`] gives
//! cubic Bézier, B-spline and Catmull-Rom curves their basis, others are polylines), `width` and a colour and opacity from `.arbGeomParams` (constant,
//! uniform, varying or vertex, also indexed), at the first or a chosen sample, with the
//! transforms of the `IXform` objects above it applied.
//!
//! Every offset and size is checked against the file before use, nesting is bounded and no
//! object group is visited twice, and the points and transform values read are bounded by
//! the file's size, so a hostile file costs at most a few times its size.

use super::{data_error, Groom};
use crate::error::{KamiError, Result};
use std::collections::HashSet;
use std::ops::Range;

/// Which sample of animated properties to read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sample {
    /// The sample with this index, clamped to each property's last sample (index 0 is the
    /// first, which is what `formats::read` takes).
    Index(u32),
    /// The sample nearest this time in seconds, by each property's own time sampling (as
    /// Alembic's `ISampleSelector(time)` chooses).
    Time(f64),
}

/// How to read an archive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    pub sample: Sample,
    /// Apply the `IXform` transforms above each curves object (points in world space), as
    /// other tools show the groom. Off: points in each object's own space.
    pub transforms: bool,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            sample: Sample::Index(0),
            transforms: true,
        }
    }
}

/// Alembic's curve type (`CurveType`): `Linear` curves are the polylines; `Cubic` ones are
/// described by [`Basis`]; `VariableOrder` ones (NURBS) by per-curve orders and knots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveType {
    Cubic,
    Linear,
    VariableOrder,
}

/// Alembic's curve basis (`BasisType`), meaningful for cubic curves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Basis {
    NoBasis,
    Bezier,
    Bspline,
    CatmullRom,
    Hermite,
    Power,
}

/// Alembic's curve wrap (`CurvePeriodicity`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    NonPeriodic,
    Periodic,
}

/// One `ICurves` object as read: where its strands are in the groom, and how its control
/// points are meant to be evaluated ([`Curves::into_groom`] maps them to Kami's curves).
#[derive(Clone, Debug, PartialEq)]
pub struct CurvesObject {
    /// Full Alembic path, e.g. `/groom/hair/hairShape`.
    pub path: String,
    /// The strands of this object in [`Curves::groom`] (`groom.counts[strands]`).
    pub strands: Range<usize>,
    pub curve_type: CurveType,
    pub basis: Basis,
    pub wrap: Wrap,
    /// Index and time (seconds) of the positions sample read.
    pub sample: u32,
    pub time: f64,
    /// Samples of the positions in the file (1 for a still object).
    pub samples: u32,
}

/// What an archive holds: every curves object's strands, concatenated in file order, and
/// per object its basis.
#[derive(Clone, Debug, PartialEq)]
pub struct Curves {
    pub groom: Groom,
    pub objects: Vec<CurvesObject>,
}

/// The groom at the first sample, with transforms, its curves as Kami evaluates them
/// ([`Curves::into_groom`]): what `formats::read` returns.
pub fn parse(b: &[u8], origin: &str) -> Result<Groom> {
    Ok(parse_with(b, origin, &Options::default())?.into_groom(origin))
}

impl Curves {
    /// One groom with each object's curves as Kami evaluates them: cubic Bézier, B-spline
    /// and Catmull-Rom keep their control points and basis when every object shares one
    /// (`Groom::into_linear` evaluates them as USD does), and become polylines otherwise;
    /// linear, Hermite, power and NURBS curves are polylines through their points. An
    /// object whose counts its basis cannot use is read through its points, with a warning.
    pub fn into_groom(self, origin: &str) -> Groom {
        let kinds: Vec<(super::Basis, super::Wrap)> = self
            .objects
            .iter()
            .map(|o| {
                let k = kami_curve(o.curve_type, o.basis, o.wrap);
                let ok = self.groom.counts[o.strands.clone()]
                    .iter()
                    .all(|&c| super::curves::segments(k.0, k.1, c as usize).is_some());
                if ok {
                    k
                } else {
                    log::warn!(
                        "{origin}: object {}: its vertex counts make no {} {} curves; read \
                         through its control points",
                        o.path,
                        k.1.token(),
                        k.0.token()
                    );
                    (super::Basis::Linear, super::Wrap::Nonperiodic)
                }
            })
            .collect();
        let mut g = self.groom;
        if kinds.windows(2).all(|w| w[0] == w[1]) {
            if let Some(&(basis, wrap)) = kinds.first() {
                (g.basis, g.wrap) = (basis, wrap);
            }
            return g;
        }
        // Objects of different bases: each evaluated on its own, then joined.
        let mut out = Groom {
            group_ids: g.group_ids.clone(),
            guides: g.guides.clone(),
            root_uvs: g.root_uvs.clone(),
            ..Groom::default()
        };
        let mut at = 0usize;
        for (o, &(basis, wrap)) in self.objects.iter().zip(&kinds) {
            let counts = g.counts[o.strands.clone()].to_vec();
            let n: usize = counts.iter().map(|&c| c as usize).sum();
            let r = at..at + n;
            at += n;
            // Every count makes a curve of its kind (`kinds` fell back to linear where
            // not), so each strand stays one strand: the per-strand values stay as read.
            let part = Groom {
                counts,
                points: g.points[r.clone()].to_vec(),
                widths: g.widths.as_ref().map(|v| v[r.clone()].to_vec()),
                opacities: g.opacities.as_ref().map(|v| v[r.clone()].to_vec()),
                colors: g.colors.as_ref().map(|v| v[r.clone()].to_vec()),
                basis,
                wrap,
                ..Groom::default()
            }
            .into_linear();
            out.counts.extend(part.counts);
            out.points.extend(part.points);
            for (a, b) in [
                (&mut out.widths, part.widths),
                (&mut out.opacities, part.opacities),
            ] {
                if let Some(b) = b {
                    a.get_or_insert_with(Vec::new).extend(b);
                }
            }
            if let Some(c) = part.colors {
                out.colors.get_or_insert_with(Vec::new).extend(c);
            }
        }
        out
    }
}

/// Read `path` (an `.abc` file) with `options`.
pub fn read(path: &std::path::Path, options: &Options) -> Result<Curves> {
    let bytes = std::fs::read(path).map_err(|source| KamiError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let origin = path.display().to_string();
    let curves = parse_with(&bytes, &origin, options)?;
    curves.groom.check(&origin)?;
    Ok(curves)
}

/// Read an archive already in memory; `origin` names it in errors.
pub fn parse_with(b: &[u8], origin: &str, options: &Options) -> Result<Curves> {
    if let Sample::Time(t) = options.sample {
        if !t.is_finite() {
            return Err(data_error(
                origin,
                None,
                format!("the time {t} is not a number"),
            ));
        }
    }
    let archive = Archive::open(b, origin)?;
    let mut reader = Reader {
        a: &archive,
        options: *options,
        visited: HashSet::new(),
        groom: Parts::default(),
        objects: Vec::new(),
        budget: b.len() as u64 + 1024,
        found: 0,
    };
    let top = archive.top_group()?;
    reader.object(top, "", IDENTITY, 0)?;
    if reader.found == 0 {
        return Err(archive.err(
            "there are no curves (ICurves objects) in this archive; Kami reads only curves from Alembic".into(),
        ));
    }
    let groom = reader.groom.finish();
    if groom.counts.is_empty() {
        return Err(archive.err(format!(
            "the {} curves object(s) hold no curves at the sample read: no strands in this file",
            reader.found
        )));
    }
    if groom.guides.as_ref().is_some_and(|g| g.iter().all(|&x| x)) {
        return Err(archive.err(format!(
            "every one of its {} curves is a guide (groom_guide = 1): there are no strands to \
             draw; export the render strands with the guides",
            groom.counts.len()
        )));
    }
    Ok(Curves {
        groom,
        objects: reader.objects,
    })
}

/// Deepest object nesting followed (real files nest a handful of levels).
const MAX_DEPTH: usize = 128;
/// Ogawa marks a child offset as data (not a group) with the top bit.
const DATA_BIT: u64 = 1 << 63;
/// Alembic's "acyclic" time per cycle.
const ACYCLIC: f64 = f64::MAX / 32.0;

/// Plain old data types, numbered as Alembic's `PlainOldDataType`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pod {
    Bool,
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    U64,
    I64,
    F16,
    F32,
    F64,
    Str,
    WStr,
}

impl Pod {
    fn from_bits(v: u32) -> Option<Pod> {
        use Pod::*;
        [
            Bool, U8, I8, U16, I16, U32, I32, U64, I64, F16, F32, F64, Str, WStr,
        ]
        .get(v as usize)
        .copied()
    }

    /// Bytes per value; strings have no fixed size.
    fn size(self) -> Option<usize> {
        use Pod::*;
        match self {
            Bool | U8 | I8 => Some(1),
            U16 | I16 | F16 => Some(2),
            U32 | I32 | F32 => Some(4),
            U64 | I64 | F64 => Some(8),
            Str | WStr => None,
        }
    }

    fn is_float(self) -> bool {
        matches!(self, Pod::F16 | Pod::F32 | Pod::F64)
    }

    /// Value `i` of `b` (little-endian, `self.size()` bytes each) as f64.
    fn get(self, b: &[u8], i: usize) -> f64 {
        let at = |n: usize| &b[i * n..i * n + n];
        use Pod::*;
        match self {
            Bool | U8 => b[i] as f64,
            I8 => b[i] as i8 as f64,
            U16 => u16::from_le_bytes(at(2).try_into().unwrap()) as f64,
            I16 => i16::from_le_bytes(at(2).try_into().unwrap()) as f64,
            F16 => f16_to_f64(u16::from_le_bytes(at(2).try_into().unwrap())),
            U32 => u32::from_le_bytes(at(4).try_into().unwrap()) as f64,
            I32 => i32::from_le_bytes(at(4).try_into().unwrap()) as f64,
            F32 => f32::from_le_bytes(at(4).try_into().unwrap()) as f64,
            U64 => u64::from_le_bytes(at(8).try_into().unwrap()) as f64,
            I64 => i64::from_le_bytes(at(8).try_into().unwrap()) as f64,
            F64 => f64::from_le_bytes(at(8).try_into().unwrap()),
            Str | WStr => f64::NAN,
        }
    }
}

/// IEEE half to f64 (Houdini writes half colours).
fn f16_to_f64(h: u16) -> f64 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = ((h >> 10) & 0x1f) as i32;
    let frac = (h & 0x3ff) as f64;
    sign * match exp {
        0 => frac * 2f64.powi(-24),
        31 if frac == 0.0 => f64::INFINITY,
        31 => f64::NAN,
        e => (1.0 + frac / 1024.0) * 2f64.powi(e - 15),
    }
}

/// One time sampling of the archive.
#[derive(Clone, Debug)]
struct TimeSampling {
    time_per_cycle: f64,
    times: Vec<f64>,
}

impl TimeSampling {
    /// The time of sample `i`.
    fn time(&self, i: u32) -> f64 {
        let n = self.times.len();
        if self.time_per_cycle == ACYCLIC {
            self.times[(i as usize).min(n - 1)]
        } else {
            let (cycle, within) = (i as usize / n, i as usize % n);
            self.times[within] + cycle as f64 * self.time_per_cycle
        }
    }

    /// The sample of `count` nearest `t` (the earlier one on a tie). Only a few candidates
    /// are looked at, so a property claiming billions of samples costs nothing.
    fn nearest(&self, t: f64, count: u32) -> u32 {
        let n = self.times.len() as u64;
        let last = count.saturating_sub(1) as u64;
        let mut candidates: Vec<u64> = vec![0, last];
        if self.time_per_cycle == ACYCLIC {
            candidates.extend(0..n.min(last + 1));
        } else if self.time_per_cycle > 0.0 {
            let c = ((t - self.times[0]) / self.time_per_cycle).floor();
            let c = c.clamp(0.0, (last / n) as f64) as u64;
            for cycle in c.saturating_sub(1)..=c + 1 {
                candidates.extend((0..n).map(|k| cycle * n + k));
            }
        }
        let mut best = (f64::INFINITY, 0u32);
        for i in candidates.into_iter().filter(|&i| i <= last) {
            let d = (self.time(i as u32) - t).abs();
            if d < best.0 || (d == best.0 && (i as u32) < best.1) {
                best = (d, i as u32);
            }
        }
        best.1
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Compound,
    Scalar,
    Array,
}

/// A property header (`ReadPropertyHeaders` in AbcCoreOgawa).
#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: Kind,
    pod: Pod,
    extent: u32,
    /// Samples written (`nextSampleIndex`); repeats at the ends are stored once.
    count: u32,
    first_changed: u32,
    last_changed: u32,
    time_sampling: usize,
    meta: String,
    /// The property's group offset (in its compound's child list).
    group: u64,
}

/// A value of Alembic's `key=value;key=value` meta data.
fn meta_get<'m>(meta: &'m str, key: &str) -> Option<&'m str> {
    meta.split(';').find_map(|kv| {
        let (k, v) = kv.split_once('=')?;
        (k == key).then_some(v)
    })
}

/// The Ogawa container: groups (a count and child offsets) and data (a size and bytes).
struct Archive<'a> {
    b: &'a [u8],
    origin: &'a str,
    root: Vec<u64>,
    time_samplings: Vec<TimeSampling>,
    /// Meta data strings shared by index; 0 is the empty one.
    indexed_meta: Vec<String>,
    /// Bytes of group lists and headers parsed so far: blocks shared by many groups cannot
    /// make the reading time grow with the square of the file.
    work: std::cell::Cell<u64>,
}

impl<'a> Archive<'a> {
    fn err(&self, message: String) -> KamiError {
        data_error(self.origin, None, message)
    }

    /// Count `bytes` more parsed; past 16 times the file (real files parse each block
    /// about once) the file is refused.
    fn charge(&self, bytes: u64, what: &str) -> Result<()> {
        let work = self.work.get() + bytes;
        self.work.set(work);
        if work > 16 * self.b.len() as u64 + 4096 {
            return Err(self.err(format!(
                "{what}: the archive's groups and headers are read more than 16 times over (blocks shared in a loop)"
            )));
        }
        Ok(())
    }

    fn u64_at(&self, at: u64, what: &str) -> Result<u64> {
        match at.checked_add(8) {
            Some(end) if end <= self.b.len() as u64 => {
                let at = at as usize;
                Ok(u64::from_le_bytes(self.b[at..at + 8].try_into().unwrap()))
            }
            _ => Err(self.err(format!(
                "{what}: offset {at} is past the end of the file ({} bytes; truncated?)",
                self.b.len()
            ))),
        }
    }

    /// The children of the group at `child` (an entry of a parent's list).
    fn group(&self, child: u64, what: &str) -> Result<Vec<u64>> {
        if child & DATA_BIT != 0 {
            return Err(self.err(format!("{what}: expected a group, found data")));
        }
        if child == 0 {
            return Ok(Vec::new());
        }
        let n = self.u64_at(child, what)?;
        let room = (self.b.len() as u64 - child - 8) / 8;
        if n > room {
            return Err(self.err(format!(
                "{what}: the group at byte {child} claims {n} children; only {room} fit in the file"
            )));
        }
        self.charge(8 * n, what)?;
        (0..n)
            .map(|i| self.u64_at(child + 8 + 8 * i, what))
            .collect()
    }

    /// The bytes of the data at `child` (an entry of a parent's list).
    fn data(&self, child: u64, what: &str) -> Result<&'a [u8]> {
        if child & DATA_BIT == 0 {
            return Err(self.err(format!("{what}: expected data, found a group")));
        }
        let pos = child & !DATA_BIT;
        if pos == 0 {
            return Ok(&[]);
        }
        let size = self.u64_at(pos, what)?;
        let room = self.b.len() as u64 - pos - 8;
        if size > room {
            return Err(self.err(format!(
                "{what}: the data at byte {pos} claims {size} bytes; only {room} are left in the file"
            )));
        }
        let start = (pos + 8) as usize;
        Ok(&self.b[start..start + size as usize])
    }

    fn open(b: &'a [u8], origin: &'a str) -> Result<Archive<'a>> {
        let mut a = Archive {
            b,
            origin,
            root: Vec::new(),
            time_samplings: Vec::new(),
            indexed_meta: vec![String::new()],
            work: std::cell::Cell::new(0),
        };
        if b.len() < 16 {
            return Err(a.err(format!(
                "{} bytes is too short for the 16-byte Ogawa header",
                b.len()
            )));
        }
        if &b[..5] != b"Ogawa" {
            let hdf5 = &b[..4] == b"\x89HDF";
            return Err(a.err(format!(
                "byte 0: the magic is {:?}, not \"Ogawa\"; {}",
                String::from_utf8_lossy(&b[..5]),
                if hdf5 {
                    "this is an old HDF5 Alembic file: re-export it as Ogawa (the default since Alembic 1.5)"
                } else {
                    "this is not an Alembic (Ogawa) file"
                }
            )));
        }
        if b[5] != 0xff {
            return Err(a.err(
                "byte 5: the archive was not closed cleanly (its writer stopped while writing)"
                    .into(),
            ));
        }
        let root_pos = a.u64_at(8, "the header's root group")?;
        a.root = a.group(root_pos, "the root group")?;
        let r = &a.root;
        let is_data = |i: usize| r[i] & DATA_BIT != 0;
        if r.len() < 6 || !is_data(0) || !is_data(1) || is_data(2) || !(3..6).all(is_data) {
            return Err(a.err(
                "the root group is not laid out as an Alembic archive (version, library version, top object, meta data, time samplings, indexed meta data)".into(),
            ));
        }
        let version = a.data(r[0], "the archive version")?;
        if version.len() != 4 || i32::from_le_bytes(version.try_into().unwrap()) > 1 {
            return Err(a.err(format!(
                "the Alembic archive version is {version:?}; Kami reads version 0 and 1"
            )));
        }
        a.time_samplings = a.read_time_samplings(a.data(r[4], "the time samplings")?)?;
        a.indexed_meta = a.read_indexed_meta(a.data(r[5], "the indexed meta data")?)?;
        Ok(a)
    }

    fn top_group(&self) -> Result<Vec<u64>> {
        self.group(self.root[2], "the top object")
    }

    fn read_time_samplings(&self, d: &[u8]) -> Result<Vec<TimeSampling>> {
        let mut c = Cursor::new(self, d, "the time samplings");
        let mut out = Vec::new();
        while !c.done() {
            let _max_sample = c.u32()?;
            let time_per_cycle = c.f64()?;
            let n = c.u32()? as usize;
            if n == 0 {
                return Err(c.err(format!("time sampling {} has no sample times", out.len())));
            }
            let bytes = c.take(n.saturating_mul(8))?;
            let times: Vec<f64> = (0..n).map(|i| Pod::F64.get(bytes, i)).collect();
            if !time_per_cycle.is_finite() || times.iter().any(|t| !t.is_finite()) {
                return Err(c.err(format!("time sampling {} is not finite", out.len())));
            }
            out.push(TimeSampling {
                time_per_cycle,
                times,
            });
        }
        if out.is_empty() {
            // Alembic always writes the identity sampling; a writer that left it out means it.
            out.push(TimeSampling {
                time_per_cycle: 1.0,
                times: vec![0.0],
            });
        }
        Ok(out)
    }

    fn read_indexed_meta(&self, d: &[u8]) -> Result<Vec<String>> {
        let mut c = Cursor::new(self, d, "the indexed meta data");
        let mut out = vec![String::new()];
        while !c.done() {
            let n = c.u8()? as usize;
            out.push(String::from_utf8_lossy(c.take(n)?).into_owned());
        }
        Ok(out)
    }

    /// The headers of an object's children (the last data of its group), with their groups.
    fn object_headers(&self, group: &[u64], path: &str) -> Result<Vec<(String, String, u64)>> {
        let what = format!("object {}", display(path));
        let Some(&last) = group.last() else {
            return Ok(Vec::new());
        };
        if last & DATA_BIT == 0 {
            return Ok(Vec::new());
        }
        let d = self.data(last, &what)?;
        // The last 32 bytes are hashes.
        if d.len() <= 32 {
            return Ok(Vec::new());
        }
        self.charge(d.len() as u64, &what)?;
        let what = format!("the children of {what}");
        let mut c = Cursor::new(self, &d[..d.len() - 32], &what);
        let mut out = Vec::new();
        while !c.done() {
            let n = c.u32()? as usize;
            if n == 0 {
                return Err(c.err("a child has an empty name".into()));
            }
            let name = String::from_utf8_lossy(c.take(n)?).into_owned();
            let index = c.u8()?;
            let meta = if index == 0xff {
                let n = c.u32()? as usize;
                String::from_utf8_lossy(c.take(n)?).into_owned()
            } else {
                self.indexed(index as usize, &what)?
            };
            // Children are the groups after the properties (child 0) and before the headers.
            let slot = out.len() + 1;
            if slot + 1 >= group.len() {
                return Err(self.err(format!(
                    "{what}: child {name:?} has no group ({} children are named, the group holds {})",
                    out.len() + 1,
                    group.len()
                )));
            }
            out.push((name, meta, group[slot]));
        }
        Ok(out)
    }

    fn indexed(&self, index: usize, what: &str) -> Result<String> {
        self.indexed_meta.get(index).cloned().ok_or_else(|| {
            self.err(format!(
                "{what}: meta data index {index}, but the archive has {}",
                self.indexed_meta.len()
            ))
        })
    }

    /// The property headers of the compound property whose group has children `group`.
    fn properties(&self, group: &[u64], what: &str) -> Result<Vec<Property>> {
        let Some(&last) = group.last() else {
            return Ok(Vec::new());
        };
        if last & DATA_BIT == 0 {
            return Ok(Vec::new());
        }
        let d = self.data(last, what)?;
        self.charge(d.len() as u64, what)?;
        let mut c = Cursor::new(self, d, what);
        let mut out = Vec::new();
        while !c.done() {
            let info = c.u32()?;
            let kind = match info & 3 {
                0 => Kind::Compound,
                1 => Kind::Scalar,
                _ => Kind::Array,
            };
            let hint = (info >> 2) & 3;
            let mut p = Property {
                name: String::new(),
                kind,
                pod: Pod::U8,
                extent: 0,
                count: 0,
                first_changed: 0,
                last_changed: 0,
                time_sampling: 0,
                meta: String::new(),
                group: 0,
            };
            if kind != Kind::Compound {
                let bits = (info >> 4) & 0xf;
                p.pod = Pod::from_bits(bits).ok_or_else(|| {
                    c.err(format!(
                        "property {}: data type {bits} is not one Alembic knows",
                        out.len()
                    ))
                })?;
                p.extent = (info >> 12) & 0xff;
                p.count = c.hinted(hint)?;
                if info & 0x200 != 0 {
                    p.first_changed = c.hinted(hint)?;
                    p.last_changed = c.hinted(hint)?;
                } else if info & 0x800 != 0 {
                    (p.first_changed, p.last_changed) = (0, 0);
                } else {
                    (p.first_changed, p.last_changed) = (1, p.count.saturating_sub(1));
                }
                if info & 0x100 != 0 {
                    p.time_sampling = c.hinted(hint)? as usize;
                    if p.time_sampling >= self.time_samplings.len() {
                        return Err(c.err(format!(
                            "property {}: time sampling {}, but the archive has {}",
                            out.len(),
                            p.time_sampling,
                            self.time_samplings.len()
                        )));
                    }
                }
            }
            let n = c.hinted(hint)? as usize;
            if n == 0 {
                return Err(c.err(format!("property {} has an empty name", out.len())));
            }
            p.name = String::from_utf8_lossy(c.take(n)?).into_owned();
            let index = (info >> 20) & 0xff;
            p.meta = if index == 0xff {
                let n = c.hinted(hint)? as usize;
                String::from_utf8_lossy(c.take(n)?).into_owned()
            } else {
                self.indexed(index as usize, what)?
            };
            let slot = out.len();
            if slot + 1 >= group.len() {
                return Err(self.err(format!(
                    "{what}: property {:?} has no group ({} properties are named, the group holds {})",
                    p.name,
                    slot + 1,
                    group.len()
                )));
            }
            p.group = group[slot];
            out.push(p);
        }
        Ok(out)
    }

    /// The stored sample (0-based among those written) that sample `i` of `p` is
    /// (`verifyIndex` in AbcCoreOgawa: repeats at the ends are stored once).
    fn stored(p: &Property, i: u32) -> u64 {
        let (i, first, last) = (i as u64, p.first_changed as u64, p.last_changed as u64);
        if i < first || (first == last && first == 0) {
            0
        } else if i >= last {
            last.saturating_sub(first) + 1
        } else {
            i - first + 1
        }
    }

    /// The index `sample` chooses for `p` (clamped to its samples).
    fn index(&self, p: &Property, sample: Sample) -> u32 {
        match sample {
            Sample::Index(i) => i.min(p.count.saturating_sub(1)),
            Sample::Time(t) => self.time_samplings[p.time_sampling].nearest(t, p.count),
        }
    }

    /// The raw bytes (after the 16-byte key) of sample `i` of a scalar or array property.
    fn sample_bytes(&self, p: &Property, i: u32, what: &str) -> Result<&'a [u8]> {
        let group = self.group(p.group, what)?;
        let k = Self::stored(p, i);
        let slot = if p.kind == Kind::Array { 2 * k } else { k };
        let child = *group.get(slot as usize).ok_or_else(|| {
            self.err(format!(
                "{what}: sample {i} is stored as number {k}, but the property holds {} data",
                group.len()
            ))
        })?;
        let d = self.data(child, what)?;
        match d.len() {
            0 => Ok(&[]),
            1..=15 => Err(self.err(format!(
                "{what}: sample {i} is {} bytes, shorter than its 16-byte key",
                d.len()
            ))),
            _ => Ok(&d[16..]),
        }
    }

    /// Sample `i` of a numeric property, read in place (`extent` values per element).
    fn numbers(&self, p: &Property, i: u32, what: &str) -> Result<Values<'a>> {
        let Some(size) = p.pod.size() else {
            return Err(self.err(format!("{what}: a string, not numbers")));
        };
        let d = self.sample_bytes(p, i, what)?;
        let element = size * p.extent.max(1) as usize;
        if d.len() % element != 0 {
            return Err(self.err(format!(
                "{what}: sample {i} is {} bytes, not a whole number of {element}-byte values",
                d.len()
            )));
        }
        if p.kind == Kind::Scalar && d.len() != element {
            return Err(self.err(format!(
                "{what}: sample {i} is {} bytes; the scalar takes {element}",
                d.len()
            )));
        }
        Ok(Values {
            pod: p.pod,
            b: d,
            size,
        })
    }
}

/// Numbers read in place from a sample, so nothing is allocated per value read.
#[derive(Clone, Copy)]
struct Values<'a> {
    pod: Pod,
    b: &'a [u8],
    size: usize,
}

impl Values<'_> {
    fn len(&self) -> usize {
        self.b.len() / self.size
    }
    fn get(&self, i: usize) -> f64 {
        self.pod.get(self.b, i)
    }
    fn iter(&self) -> impl Iterator<Item = f64> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }
}

/// Reads little-endian values from one data block, naming it in errors.
struct Cursor<'c> {
    a: &'c Archive<'c>,
    d: &'c [u8],
    at: usize,
    what: &'c str,
}

impl<'c> Cursor<'c> {
    fn new(a: &'c Archive<'c>, d: &'c [u8], what: &'c str) -> Cursor<'c> {
        Cursor { a, d, at: 0, what }
    }
    fn err(&self, message: String) -> KamiError {
        self.a.err(format!("{}: {message}", self.what))
    }
    fn done(&self) -> bool {
        self.at >= self.d.len()
    }
    fn take(&mut self, n: usize) -> Result<&'c [u8]> {
        if n > self.d.len() - self.at {
            return Err(self.err(format!(
                "byte {} of {}: {n} bytes are needed but only {} are left (truncated)",
                self.at,
                self.d.len(),
                self.d.len() - self.at
            )));
        }
        self.at += n;
        Ok(&self.d[self.at - n..self.at])
    }
    fn u8(&mut self) -> Result<u8> {
        Ok(self.take(1)?[0])
    }
    fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }
    fn f64(&mut self) -> Result<f64> {
        Ok(f64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    /// A count stored in 1, 2 or 4 bytes as the header's size hint says.
    fn hinted(&mut self, hint: u32) -> Result<u32> {
        match hint {
            0 => Ok(self.u8()? as u32),
            1 => Ok(u16::from_le_bytes(self.take(2)?.try_into().unwrap()) as u32),
            2 => self.u32(),
            _ => Err(self.err("a property header has size hint 3".into())),
        }
    }
}

fn display(path: &str) -> &str {
    if path.is_empty() {
        "/"
    } else {
        path
    }
}

/// A 4x4 matrix in Imath's row-vector convention (`p' = p * M`, translation in row 3).
type M44 = [[f64; 4]; 4];

const IDENTITY: M44 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

fn mul(a: &M44, b: &M44) -> M44 {
    let mut m = [[0.0; 4]; 4];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// Imath's `setAxisAngle` (row-vector convention), angle in degrees.
fn rotation(axis: [f64; 3], degrees: f64) -> M44 {
    let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    if len == 0.0 || !len.is_finite() {
        return IDENTITY;
    }
    let [x, y, z] = axis.map(|v| v / len);
    let (s, c) = degrees.to_radians().sin_cos();
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y + z * s, t * x * z - y * s, 0.0],
        [t * x * y - z * s, t * y * y + c, t * y * z + x * s, 0.0],
        [t * x * z + y * s, t * y * z - x * s, t * z * z + c, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// Per-point attribute arrays while objects are joined; an attribute one object lacks is
/// dropped from all (as the usda reader does), so no value is made up. One exception: an
/// object of guides only (Unreal's `groom_guide`, which Unreal does not draw) that lacks a
/// look the strand objects all have takes their mean (and root UVs of (0, 0)), so that
/// guides exported without colours do not cost the groom its colours.
#[derive(Default)]
struct Parts {
    parts: Vec<Groom>,
}

impl Parts {
    fn push(&mut self, g: Groom) {
        self.parts.push(g);
    }

    fn finish(mut self) -> Groom {
        let guides_only = |g: &Groom| {
            g.guides
                .as_ref()
                .is_some_and(|v| !v.is_empty() && v.iter().all(|&x| x))
        };
        fn mean<const N: usize>(v: &[[f32; N]]) -> [f32; N] {
            let mut m = [0.0f64; N];
            for x in v {
                for k in 0..N {
                    m[k] += x[k] as f64;
                }
            }
            m.map(|x| (x / v.len().max(1) as f64) as f32)
        }
        let strands: Vec<&Groom> = self.parts.iter().filter(|g| !guides_only(g)).collect();
        let all = |f: fn(&Groom) -> bool| !strands.is_empty() && strands.iter().all(|g| f(g));
        let fill_w = all(|g| g.widths.is_some()).then(|| {
            let v: Vec<[f32; 1]> = strands
                .iter()
                .flat_map(|g| g.widths.iter().flatten().map(|&w| [w]))
                .collect();
            mean(&v)[0]
        });
        let fill_o = all(|g| g.opacities.is_some()).then(|| {
            let v: Vec<[f32; 1]> = strands
                .iter()
                .flat_map(|g| g.opacities.iter().flatten().map(|&w| [w]))
                .collect();
            mean(&v)[0]
        });
        let fill_c = all(|g| g.colors.is_some()).then(|| {
            let v: Vec<[f32; 3]> = strands
                .iter()
                .flat_map(|g| g.colors.iter().flatten().copied())
                .collect();
            mean(&v)
        });
        let uvs = all(|g| g.root_uvs.is_some());
        for g in self.parts.iter_mut().filter(|g| guides_only(g)) {
            let n = g.points.len();
            if g.root_uvs.is_none() && uvs {
                g.root_uvs = Some(vec![[0.0; 2]; g.counts.len()]);
            }
            if let (None, Some(w)) = (&g.widths, fill_w) {
                g.widths = Some(vec![w; n]);
            }
            if let (None, Some(o)) = (&g.opacities, fill_o) {
                g.opacities = Some(vec![o; n]);
            }
            if let (None, Some(c)) = (&g.colors, fill_c) {
                g.colors = Some(vec![c; n]);
            }
        }
        let mut base = Groom::default();
        for (i, g) in self.parts.into_iter().enumerate() {
            let first = i == 0;
            fn join<T>(first: bool, a: &mut Option<Vec<T>>, b: Option<Vec<T>>) {
                match (first, a.as_mut(), b) {
                    (true, _, b) => *a = b,
                    (false, Some(a), Some(b)) => a.extend(b),
                    _ => *a = None,
                }
            }
            join(first, &mut base.widths, g.widths);
            join(first, &mut base.opacities, g.opacities);
            join(first, &mut base.colors, g.colors);
            // Unreal's per-strand values: an object without them is group 0 and no guide
            // (as Unreal's importer reads it); root UVs are dropped unless every object has
            // them.
            let (na, nb) = (base.counts.len(), g.counts.len());
            super::join_filled(&mut base.group_ids, na, g.group_ids, nb, 0);
            super::join_filled(&mut base.guides, na, g.guides, nb, false);
            join(first, &mut base.root_uvs, g.root_uvs);
            base.counts.extend(g.counts);
            base.points.extend(g.points);
        }
        base
    }
}

/// Walks the object tree.
struct Reader<'r> {
    a: &'r Archive<'r>,
    options: Options,
    visited: HashSet<u64>,
    groom: Parts,
    objects: Vec<CurvesObject>,
    /// Points left to read, one per byte of the file: a sample shared by many objects (Alembic
    /// stores identical samples once) cannot blow up the output.
    budget: u64,
    found: usize,
}

impl Reader<'_> {
    fn object(&mut self, group: Vec<u64>, path: &str, world: M44, depth: usize) -> Result<()> {
        if depth > MAX_DEPTH {
            return Err(self.a.err(format!(
                "object {}: nesting deeper than {MAX_DEPTH} levels",
                display(path)
            )));
        }
        for (name, meta, child) in self.a.object_headers(&group, path)? {
            let child_path = format!("{path}/{name}");
            if !self.visited.insert(child) {
                return Err(self.a.err(format!(
                    "object {child_path}: its group (byte {child}) is reached twice (a loop in the file)"
                )));
            }
            let what = format!("object {child_path}");
            let g = self.a.group(child, &what)?;
            let schema = meta_get(&meta, "schema").unwrap_or("");
            let mut m = world;
            if schema.starts_with("AbcGeom_Xform_v") && self.options.transforms {
                let (local, inherits) = self.xform(&g, &child_path)?;
                m = if inherits { mul(&local, &world) } else { local };
            } else if schema.starts_with("AbcGeom_Curve_v") {
                self.found += 1;
                self.curves(&g, &child_path, &world)?;
            }
            self.object(g, &child_path, m, depth + 1)?;
        }
        Ok(())
    }

    /// The schema compound (`.geom`, `.xform`) of an object, as its properties.
    fn schema(&self, g: &[u64], path: &str, name: &str) -> Result<Option<Vec<Property>>> {
        let what = format!("object {path}");
        let Some(&first) = g.first() else {
            return Ok(None);
        };
        if first & DATA_BIT != 0 {
            return Ok(None);
        }
        let top = self.a.properties(&self.a.group(first, &what)?, &what)?;
        match top.iter().find(|p| p.name == name) {
            Some(p) if p.kind == Kind::Compound => {
                let what = format!("{what}, {name}");
                Ok(Some(
                    self.a.properties(&self.a.group(p.group, &what)?, &what)?,
                ))
            }
            Some(_) => Err(self
                .a
                .err(format!("{what}: {name} is not a compound property"))),
            None => Ok(None),
        }
    }

    /// The local matrix of an `IXform` at the chosen sample, and whether it inherits its
    /// parent's (`XformSample::getMatrix`: the ops in order, the last applied first).
    fn xform(&mut self, g: &[u64], path: &str) -> Result<(M44, bool)> {
        let Some(props) = self.schema(g, path, ".xform")? else {
            return Ok((IDENTITY, true));
        };
        let find = |n: &str| props.iter().find(|p| p.name == n && p.count > 0);
        let what = |n: &str| format!("object {path}, .xform/{n}");
        let mut inherits = true;
        if let Some(p) = find(".inherits") {
            let v = self
                .a
                .numbers(p, self.a.index(p, self.options.sample), &what(".inherits"))?;
            inherits = v.len() == 0 || v.get(0) != 0.0;
        }
        let Some(ops) = find(".ops") else {
            return Ok((IDENTITY, inherits));
        };
        let ops = self.a.numbers(ops, 0, &what(".ops"))?;
        let vals: Vec<f64> = match find(".vals") {
            Some(p) => self
                .a
                .numbers(p, self.a.index(p, self.options.sample), &what(".vals"))?
                .iter()
                .collect(),
            None => Vec::new(),
        };
        // Operations and values walked count against the same budget as points: many
        // transforms sharing one large stored sample cannot make the read quadratic.
        let work = (ops.len() + vals.len()) as u64;
        if work > self.budget {
            return Err(self.a.err(format!(
                "object {path}: {work} more transform values would pass one per byte of the file \
                 (transforms sharing one sample many times over)"
            )));
        }
        self.budget -= work;
        let mut m = IDENTITY;
        let mut at = 0usize;
        for (k, op) in ops.iter().enumerate() {
            let op = op as u32 >> 4;
            let channels = match op {
                0 | 1 => 3,
                2 => 4,
                3 => 16,
                4..=6 => 1,
                _ => {
                    return Err(self.a.err(format!(
                        "{}: operation {k} has type {op}, not one Alembic knows",
                        what(".ops")
                    )))
                }
            };
            // Missing channels keep their defaults (Alembic stops reading there too).
            let default = |c: usize| match (op, c) {
                (0, _) => 1.0,
                (3, c) if c % 5 == 0 => 1.0,
                _ => 0.0,
            };
            let v: Vec<f64> = (0..channels)
                .map(|c| vals.get(at + c).copied().unwrap_or(default(c)))
                .collect();
            at += channels;
            if let Some(bad) = v.iter().find(|v| !v.is_finite()) {
                return Err(self.a.err(format!(
                    "{}: operation {k} has the value {bad}",
                    what(".vals")
                )));
            }
            let local = match op {
                0 => {
                    let mut s = IDENTITY;
                    (0..3).for_each(|i| s[i][i] = v[i]);
                    s
                }
                1 => {
                    let mut t = IDENTITY;
                    t[3][..3].copy_from_slice(&v[..3]);
                    t
                }
                2 => rotation([v[0], v[1], v[2]], v[3]),
                3 => std::array::from_fn(|r| std::array::from_fn(|c| v[4 * r + c])),
                4 => rotation([1.0, 0.0, 0.0], v[0]),
                5 => rotation([0.0, 1.0, 0.0], v[0]),
                _ => rotation([0.0, 0.0, 1.0], v[0]),
            };
            m = mul(&local, &m);
        }
        Ok((m, inherits))
    }

    fn curves(&mut self, g: &[u64], path: &str, world: &M44) -> Result<()> {
        let a = self.a;
        let err = |m: String| a.err(format!("object {path}: {m}"));
        let props = self
            .schema(g, path, ".geom")?
            .ok_or_else(|| err("the curves have no .geom properties".into()))?;
        let find = |n: &str| props.iter().find(|p| p.name == n);
        let what = |n: &str| format!("object {path}, .geom/{n}");
        let sample = self.options.sample;

        let p = find("P").ok_or_else(|| err("the curves have no positions (P)".into()))?;
        if p.kind != Kind::Array || !matches!(p.pod, Pod::F32 | Pod::F64) || p.extent != 3 {
            return Err(err(format!(
                "P is a {:?} {:?} x {} property, not an array of 3D points",
                p.kind, p.pod, p.extent
            )));
        }
        if p.count == 0 {
            // Written but never sampled: no curves.
            return Ok(());
        }
        let index = a.index(p, sample);
        let time = a.time_samplings[p.time_sampling].time(index);
        let pos = a.numbers(p, index, &what("P"))?;
        let n = pos.len() / 3;
        if n as u64 > self.budget {
            return Err(err(format!(
                "{n} more points would pass one per byte of the file (objects sharing one sample many times over)"
            )));
        }
        self.budget -= n as u64;

        let nv = find("nVertices").ok_or_else(|| err("the curves have no nVertices".into()))?;
        let counts = self.vertex_counts(nv, path, n)?;
        let (curve_type, wrap, basis) = match find("curveBasisAndType") {
            Some(bt) if bt.count > 0 => self.basis_and_type(bt, path)?,
            _ => return Err(err("the curves have no curveBasisAndType".into())),
        };
        let shape = Shape {
            counts: &counts,
            curve_type,
            basis,
            wrap,
        };

        // Widths: the schema's `width` geom param.
        let mut attrs = Attrs {
            widths: match find("width") {
                Some(w) => self.param(w, path, ".geom", 1, &shape)?,
                None => None,
            },
            ..Attrs::default()
        };
        // Colour and opacity from the arbitrary geom params, by the names tools use.
        if let Some(arb) = find(".arbGeomParams").filter(|p| p.kind == Kind::Compound) {
            self.arb_geom_params(arb, path, &shape, &mut attrs)?;
        }
        let Attrs {
            widths,
            colors,
            opacities,
            group_ids,
            guides,
            root_uvs,
        } = attrs;

        // World space: points through the matrix, widths by its mean scale.
        let identity = *world == IDENTITY;
        let scale = mean_scale(world);
        let points = world_points(&pos, n, world);
        if let Some(i) = points.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
            return Err(err(format!(
                "point {i} is not finite{}: {:?}",
                if identity {
                    ""
                } else {
                    " after the transforms"
                },
                points[i]
            )));
        }
        let widths = widths.map(|w| {
            if identity {
                w
            } else {
                w.into_iter().map(|v| (v as f64 * scale) as f32).collect()
            }
        });
        let first: usize = self.groom.parts.iter().map(|g| g.counts.len()).sum();
        let strands = first..first + counts.len();
        self.groom.push(Groom {
            counts,
            points,
            widths,
            opacities,
            colors,
            group_ids,
            guides,
            root_uvs,
            ..Groom::default()
        });
        self.objects.push(CurvesObject {
            path: path.to_string(),
            strands,
            curve_type,
            basis,
            wrap,
            sample: index,
            time,
            samples: p.count,
        });
        Ok(())
    }

    /// The points per curve (`nVertices`): integers, each at least 2, adding up to the
    /// object's `n` points.
    fn vertex_counts(&self, nv: &Property, path: &str, n: usize) -> Result<Vec<u32>> {
        let a = self.a;
        let err = |m: String| a.err(format!("object {path}: {m}"));
        if nv.kind != Kind::Array || nv.pod.is_float() || nv.pod.size().is_none() {
            return Err(err("nVertices is not an array of integers".into()));
        }
        let raw = a.numbers(
            nv,
            a.index(nv, self.options.sample),
            &format!("object {path}, .geom/nVertices"),
        )?;
        let mut counts = Vec::with_capacity(raw.len());
        let mut total = 0u64;
        for (i, c) in raw.iter().enumerate() {
            if !(2.0..=u32::MAX as f64).contains(&c) {
                return Err(err(format!(
                    "curve {i} has {c} vertices; Kami needs at least 2"
                )));
            }
            total += c as u64;
            counts.push(c as u32);
        }
        if total != n as u64 {
            return Err(err(format!(
                "nVertices adds up to {total} points but P has {n}"
            )));
        }
        Ok(counts)
    }

    /// The curves' type, wrap and basis from a sampled `curveBasisAndType`.
    fn basis_and_type(&self, bt: &Property, path: &str) -> Result<(CurveType, Wrap, Basis)> {
        let a = self.a;
        let err = |m: String| a.err(format!("object {path}: {m}"));
        let v = a.numbers(
            bt,
            a.index(bt, self.options.sample),
            &format!("object {path}, .geom/curveBasisAndType"),
        )?;
        if v.len() < 3 {
            return Err(err(format!(
                "curveBasisAndType has {} values, not 4",
                v.len()
            )));
        }
        let t = match v.get(0) as u32 {
            0 => CurveType::Cubic,
            1 => CurveType::Linear,
            2 => CurveType::VariableOrder,
            t => return Err(err(format!("curve type {t} is not one Alembic knows"))),
        };
        let w = if v.get(1) == 0.0 {
            Wrap::NonPeriodic
        } else {
            Wrap::Periodic
        };
        let b = match v.get(2) as u32 {
            0 => Basis::NoBasis,
            1 => Basis::Bezier,
            2 => Basis::Bspline,
            3 => Basis::CatmullRom,
            4 => Basis::Hermite,
            5 => Basis::Power,
            b => return Err(err(format!("curve basis {b} is not one Alembic knows"))),
        };
        Ok((t, w, b))
    }

    /// Colour, opacity and Unreal's groom attributes from the arbitrary geom params
    /// (`.arbGeomParams`), by the names tools use, into `attrs`.
    fn arb_geom_params(
        &self,
        arb: &Property,
        path: &str,
        shape: &Shape,
        attrs: &mut Attrs,
    ) -> Result<()> {
        let a = self.a;
        let counts = shape.counts;
        let where_ = format!("object {path}, .geom/.arbGeomParams");
        let arb_props = a.properties(&a.group(arb.group, &where_)?, &where_)?;
        let param = |names: &[&str], extents: &[u32]| -> Option<&Property> {
            names.iter().find_map(|n| {
                arb_props.iter().find(|p| {
                    p.name == *n && param_extent(p, a).is_some_and(|e| extents.contains(&e))
                })
            })
        };
        const COLOR: &[&str] = &["Cs", "Cd", "color", "displayColor", "primvars:displayColor"];
        const OPACITY: &[&str] = &[
            "opacity",
            "Alpha",
            "displayOpacity",
            "primvars:displayOpacity",
        ];
        if let Some(c) = param(COLOR, &[3, 4]) {
            let extent = param_extent(c, a).unwrap_or(3);
            if let Some(v) = self.param(c, path, ".geom/.arbGeomParams", extent, shape)? {
                let e = extent as usize;
                attrs.colors = Some(
                    v.chunks_exact(e)
                        .map(|c| [c[0], c[1], c[2]])
                        .collect::<Vec<[f32; 3]>>(),
                );
                if e == 4 {
                    attrs.opacities = Some(v.chunks_exact(4).map(|c| c[3]).collect());
                }
            }
        }
        if let Some(o) = param(OPACITY, &[1]) {
            attrs.opacities = self.param(o, path, ".geom/.arbGeomParams", 1, shape)?;
        }
        // Unreal's groom schema ("Alembic for Grooms"): its width and colour win over
        // the others; group ids, guide flags and root UVs are per curve.
        let arb_where = ".geom/.arbGeomParams";
        if let Some(w) = param(&["groom_width"], &[1]) {
            if let Some(v) = self.param(w, path, arb_where, 1, shape)? {
                attrs.widths = Some(v);
            }
        }
        if let Some(c) = param(&["groom_color"], &[3, 4]) {
            let e = param_extent(c, a).unwrap_or(3) as usize;
            if let Some(v) = self.param(c, path, arb_where, e as u32, shape)? {
                attrs.colors = Some(v.chunks_exact(e).map(|c| [c[0], c[1], c[2]]).collect());
            }
        }
        let named = |n: &str| arb_props.iter().find(|p| p.name == n);
        if let Some(p) = named("groom_group_id") {
            attrs.group_ids = Some(
                self.per_curve(p, path, counts)?
                    .into_iter()
                    .map(|v| v as i64)
                    .collect(),
            );
        }
        if let Some(p) = named("groom_guide") {
            attrs.guides = Some(
                self.per_curve(p, path, counts)?
                    .into_iter()
                    .map(|v| v != 0.0)
                    .collect(),
            );
        }
        if let Some(p) = param(&["groom_root_uv"], &[2]) {
            if let Some(v) = self.param(p, path, arb_where, 2, shape)? {
                // Per point as expanded: each curve's value at its root.
                let mut at = 0usize;
                let mut uvs = Vec::with_capacity(counts.len());
                for &c in counts {
                    uvs.push([v[2 * at], v[2 * at + 1]]);
                    at += c as usize;
                }
                attrs.root_uvs = Some(uvs);
            }
        }
        if let Some(p) = named("groom_version_major") {
            let v = self.per_curve(p, path, counts)?;
            if v.first().is_some_and(|&m| m > 1.0) {
                log::warn!(
                    "{}: object {path} follows Unreal's groom schema {}; Kami reads version 1",
                    a.origin,
                    v[0]
                );
            }
        }
        Ok(())
    }

    /// A per-curve number (Unreal's `groom_group_id`, `groom_guide`, any integer or float
    /// type): one value for the object (constant), one per curve (uniform), or one per
    /// point (vertex: each curve's root value).
    fn per_curve(&self, p: &Property, path: &str, counts: &[u32]) -> Result<Vec<f64>> {
        let a = self.a;
        let what = format!("object {path}, .geom/.arbGeomParams/{}", p.name);
        if p.kind == Kind::Compound || p.extent.max(1) != 1 || p.pod.size().is_none() {
            return Err(a.err(format!("{what}: not one number per curve")));
        }
        if p.count == 0 {
            return Ok(vec![0.0; counts.len()]);
        }
        let v = a.numbers(p, a.index(p, self.options.sample), &what)?;
        let points: usize = counts.iter().map(|&c| c as usize).sum();
        match v.len() {
            1 => Ok(vec![v.get(0); counts.len()]),
            n if n == counts.len() => Ok(v.iter().collect()),
            n if n == points => {
                let mut at = 0usize;
                Ok(counts
                    .iter()
                    .map(|&c| {
                        let x = v.get(at);
                        at += c as usize;
                        x
                    })
                    .collect())
            }
            n => Err(a.err(format!(
                "{what}: {n} values fit neither the object, its {} curves nor its {points} points",
                counts.len()
            ))),
        }
    }

    /// A geom param (`width`, a colour) expanded to one `extent`-tuple per point, flat; an
    /// indexed one is a compound of `.vals` and `.indices`.
    fn param(
        &self,
        p: &Property,
        path: &str,
        parent: &str,
        extent: u32,
        shape: &Shape,
    ) -> Result<Option<Vec<f32>>> {
        let a = self.a;
        let what = format!("object {path}, {parent}/{}", p.name);
        let (vals_p, indices_p, inner);
        if p.kind == Kind::Compound {
            inner = a.properties(&a.group(p.group, &what)?, &what)?;
            vals_p = inner
                .iter()
                .find(|q| q.name == ".vals")
                .ok_or_else(|| a.err(format!("{what}: an indexed param without .vals")))?;
            indices_p = inner.iter().find(|q| q.name == ".indices");
        } else {
            vals_p = p;
            indices_p = None;
        }
        // 8-bit colours (`C3c`) are read as value / 255.
        let bytes = vals_p.pod == Pod::U8 && extent >= 3;
        if vals_p.kind != Kind::Array
            || !(vals_p.pod.is_float() || bytes)
            || vals_p.extent.max(1) != extent
        {
            return Err(a.err(format!(
                "{what}: a {:?} {:?} x {} property, not an array of {extent}-float values",
                vals_p.kind, vals_p.pod, vals_p.extent
            )));
        }
        if vals_p.count == 0 {
            return Ok(None);
        }
        let e = extent as usize;
        let unit = if bytes { 1.0 / 255.0 } else { 1.0 };
        let vals = a.numbers(
            vals_p,
            a.index(vals_p, self.options.sample),
            &format!("{what}/.vals"),
        )?;
        let vals: Vec<f32> = match indices_p.filter(|q| q.count > 0) {
            Some(ip) => {
                // Alembic writes uint32 indices; other types are not indices.
                if ip.kind != Kind::Array || !matches!(ip.pod, Pod::U32 | Pod::I32) {
                    return Err(a.err(format!("{what}/.indices: not an array of 32-bit integers")));
                }
                let idx = a.numbers(
                    ip,
                    a.index(ip, self.options.sample),
                    &format!("{what}/.indices"),
                )?;
                let n = vals.len() / e;
                let mut out = Vec::with_capacity(idx.len() * e);
                for (k, i) in idx.iter().enumerate() {
                    if !(0.0..n as f64).contains(&i) {
                        return Err(a.err(format!(
                            "{what}/.indices: index {k} is {i}, outside the {n} values"
                        )));
                    }
                    out.extend(
                        (i as usize * e..i as usize * e + e).map(|j| (vals.get(j) * unit) as f32),
                    );
                }
                out
            }
            None => vals.iter().map(|v| (v * unit) as f32).collect(),
        };
        // An empty sample (a writer that made the param but gave it nothing) is no values.
        if vals.is_empty() {
            return Ok(None);
        }
        let scope = meta_get(&p.meta, "geoScope").unwrap_or("con");
        shape
            .per_point(&vals, e)
            .map(Some)
            .ok_or_else(|| {
                let points: usize = shape.counts.iter().map(|&c| c as usize).sum();
                a.err(format!(
                    "{what}: {} values (scope {scope:?}) fit neither the {points} points, the {} curves, their varying count nor one constant",
                    vals.len() / e,
                    shape.counts.len()
                ))
            })
    }
}

/// The optional attributes of one curves object as read: per point (widths, colours,
/// opacities) and per curve (Unreal's group ids, guide flags, root UVs).
#[derive(Default)]
struct Attrs {
    widths: Option<Vec<f32>>,
    colors: Option<Vec<[f32; 3]>>,
    opacities: Option<Vec<f32>>,
    group_ids: Option<Vec<i64>>,
    guides: Option<Vec<bool>>,
    root_uvs: Option<Vec<[f32; 2]>>,
}

/// The mean scale of a transform (the cube root of its 3x3 determinant), for widths.
fn mean_scale(m: &M44) -> f64 {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    det.abs().cbrt()
}

/// The `n` points of `pos` through the matrix `world` (row vectors, Imath's order),
/// divided by w; untouched under the identity.
fn world_points(pos: &Values, n: usize, world: &M44) -> Vec<[f32; 3]> {
    let identity = *world == IDENTITY;
    (0..n)
        .map(|i| [pos.get(3 * i), pos.get(3 * i + 1), pos.get(3 * i + 2)])
        .map(|p| {
            if identity {
                [p[0] as f32, p[1] as f32, p[2] as f32]
            } else {
                let m = world;
                let w = p[0] * m[0][3] + p[1] * m[1][3] + p[2] * m[2][3] + m[3][3];
                let w = if w == 0.0 { 1.0 } else { w };
                std::array::from_fn(|j| {
                    ((p[0] * m[0][j] + p[1] * m[1][j] + p[2] * m[2][j] + m[3][j]) / w) as f32
                })
            }
        })
        .collect()
}

/// The extent of a geom param's values (its own, or its `.vals`' when indexed).
/// `None` when they are not values Kami reads (floats, or 8-bit colours), so that an
/// arbitrary param of another type under a colour's name is passed over, not an error.
fn param_extent(p: &Property, a: &Archive) -> Option<u32> {
    let inner;
    let values = if p.kind == Kind::Compound {
        let what = format!("property {}", p.name);
        inner = a.properties(&a.group(p.group, &what).ok()?, &what).ok()?;
        inner.iter().find(|q| q.name == ".vals")?
    } else {
        p
    };
    let readable = values.pod.is_float() || (values.pod == Pod::U8 && values.extent >= 3);
    (values.kind == Kind::Array && readable).then_some(values.extent)
}

/// Kami's curve for an Alembic one: cubic Bézier, B-spline and Catmull-Rom keep their
/// basis; linear, Hermite, power and NURBS (variable order) curves are polylines through
/// their points.
fn kami_curve(t: CurveType, b: Basis, w: Wrap) -> (super::Basis, super::Wrap) {
    let wrap = match w {
        Wrap::Periodic => super::Wrap::Periodic,
        Wrap::NonPeriodic => super::Wrap::Nonperiodic,
    };
    let basis = match (t, b) {
        (CurveType::Cubic, Basis::Bezier) => super::Basis::Bezier,
        (CurveType::Cubic, Basis::Bspline) => super::Basis::Bspline,
        (CurveType::Cubic, Basis::CatmullRom) => super::Basis::CatmullRom,
        _ => super::Basis::Linear,
    };
    (basis, wrap)
}

/// What attribute counts mean for one curves object.
struct Shape<'s> {
    counts: &'s [u32],
    curve_type: CurveType,
    basis: Basis,
    wrap: Wrap,
}

impl Shape<'_> {
    /// Varying values of a curve of `n` control points (one per segment end): the points
    /// for linear curves; for cubic ones as RenderMan and USD count them.
    fn varying(&self, n: u32) -> Option<u32> {
        let periodic = self.wrap == Wrap::Periodic;
        match (self.curve_type, self.basis) {
            (CurveType::Linear, _) => Some(n),
            (CurveType::Cubic, Basis::Bezier) if periodic => Some(n / 3),
            (CurveType::Cubic, Basis::Bezier) => Some((n.saturating_sub(1)) / 3 + 1),
            (CurveType::Cubic, Basis::Bspline | Basis::CatmullRom) if periodic => Some(n),
            (CurveType::Cubic, Basis::Bspline | Basis::CatmullRom) => Some(n.saturating_sub(2)),
            _ => None,
        }
    }

    /// `vals` (`e` floats per value) as one value per point: by count, per point, per
    /// curve, varying (spread linearly over the curve's control points) or constant.
    fn per_point(&self, vals: &[f32], e: usize) -> Option<Vec<f32>> {
        let n = vals.len() / e;
        let points: u64 = self.counts.iter().map(|&c| c as u64).sum();
        let value = |i: usize| &vals[i * e..i * e + e];
        let mut out = Vec::with_capacity(points as usize * e);
        if n as u64 == points {
            return Some(vals.to_vec());
        }
        if n == self.counts.len() {
            for (i, &c) in self.counts.iter().enumerate() {
                for _ in 0..c {
                    out.extend_from_slice(value(i));
                }
            }
            return Some(out);
        }
        if n == 1 {
            for _ in 0..points {
                out.extend_from_slice(value(0));
            }
            return Some(out);
        }
        let varying: Option<Vec<u32>> = self.counts.iter().map(|&c| self.varying(c)).collect();
        let varying = varying.filter(|v| v.iter().all(|&k| k >= 1))?;
        if varying.iter().map(|&k| k as u64).sum::<u64>() != n as u64 {
            return None;
        }
        let mut start = 0usize;
        for (&c, &k) in self.counts.iter().zip(&varying) {
            for j in 0..c {
                // Point j sits at varying parameter j/(c-1) * (k-1).
                let u = j as f64 / (c - 1).max(1) as f64 * (k - 1) as f64;
                let lo = (u.floor() as usize).min(k as usize - 1);
                let hi = (lo + 1).min(k as usize - 1);
                let f = (u - lo as f64) as f32;
                for d in 0..e {
                    let (a, b) = (value(start + lo)[d], value(start + hi)[d]);
                    out.push(a + (b - a) * f);
                }
            }
            start += k as usize;
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_convert() {
        assert_eq!(f16_to_f64(0x3c00), 1.0);
        assert_eq!(f16_to_f64(0xc000), -2.0);
        assert_eq!(f16_to_f64(0x3555), 0.333251953125);
        assert_eq!(f16_to_f64(0x0001), 2f64.powi(-24));
        assert!(f16_to_f64(0x7c00).is_infinite());
    }

    #[test]
    fn rotation_follows_imath() {
        // Imath: V3d(1,0,0) * setAxisAngle(z, 90deg) = (0,1,0).
        let m = rotation([0.0, 0.0, 1.0], 90.0);
        let p = [1.0, 0.0, 0.0];
        let q: Vec<f64> = (0..3)
            .map(|j| p[0] * m[0][j] + p[1] * m[1][j] + p[2] * m[2][j])
            .collect();
        assert!((q[0]).abs() < 1e-12 && (q[1] - 1.0).abs() < 1e-12, "{q:?}");
    }

    #[test]
    fn nearest_sample_by_time() {
        let uniform = TimeSampling {
            time_per_cycle: 0.5,
            times: vec![1.0],
        };
        assert_eq!(uniform.nearest(0.0, 10), 0);
        assert_eq!(uniform.nearest(2.1, 10), 2);
        assert_eq!(uniform.nearest(1e9, 10), 9);
        assert_eq!(uniform.nearest(1e9, u32::MAX), 1_999_999_998);
        assert_eq!(uniform.nearest(1e10, u32::MAX), u32::MAX - 1);
        let acyclic = TimeSampling {
            time_per_cycle: ACYCLIC,
            times: vec![0.0, 0.1, 5.0],
        };
        assert_eq!(acyclic.nearest(3.0, 3), 2);
        assert_eq!(acyclic.nearest(0.06, 3), 1);
    }
}
