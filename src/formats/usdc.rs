//! Binary USD: crate files (`.usdc`, and `.usd` files that begin with the crate magic), read
//! by the pure-Rust `openusd` crate, and `.usdz` packages (a zip archive whose first file is
//! the root layer, crate or text). Their prims and attributes become the same
//! [`Layer`](super::usd::Layer) the text reader makes, so every rule of `usd.rs` (bases,
//! wraps, interpolations, transforms, units, time samples) applies to all three encodings
//! alike, and errors name the file and the prim's path.
//!
//! Read from a crate file: the pseudo-root's `metersPerUnit`, `upAxis` and clock
//! (`timeCodesPerSecond`, `framesPerSecond`, `startTimeCode`, `endTimeCode`); prims reached
//! from it through `primChildren` in authored order (specifier, `typeName`, `active`);
//! their attributes through `propertyChildren` (`default`, `timeSamples`,
//! `interpolation`). `openusd` validates the file's tables before anything is read
//! (`CrateData::open(.., safe = true)`); on top of that the walk is bounded (depth, prims
//! visited once), and a panic inside the crate reader is turned into an error naming the
//! file (`tests/it/fuzz.rs` runs the mutation fuzzer over crate files).

use super::data_error;
use super::usd::{Layer, Prim, Stage, Value};
use crate::error::Result;
use openusd::sdf::{self, AbstractData, SpecType, Specifier};
use std::collections::HashSet;
use std::io::{Cursor, Read};
use std::panic::{self, AssertUnwindSafe};

mod bounds;

/// The first bytes of a crate file.
pub const MAGIC: &[u8] = b"PXR-USDC";

/// The first bytes of a zip archive (a `.usdz`).
pub const ZIP_MAGIC: &[u8] = b"PK\x03\x04";

/// Deepest prim nesting walked (as the text reader's bound).
const MAX_DEPTH: usize = 128;

/// Largest root layer taken out of a `.usdz` (the package's own size bounds it too: USDZ
/// stores its files uncompressed).
const MAX_LAYER: u64 = 1 << 32;

/// The pseudo-root's metadata Kami reads (`bounds` checks these fields too).
const STAGE_KEYS: [&str; 6] = [
    "metersPerUnit",
    "upAxis",
    "timeCodesPerSecond",
    "framesPerSecond",
    "startTimeCode",
    "endTimeCode",
];

/// Run `f`, turning a panic in the crate reader into an error naming `origin`.
fn guarded<T>(origin: &str, what: &str, f: impl FnOnce() -> Result<T>) -> Result<T> {
    panic::catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| {
        let why = p
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| p.downcast_ref::<&str>().copied())
            .unwrap_or("no message");
        Err(data_error(
            origin,
            None,
            format!("{what}: the crate reader failed ({why}); the file is damaged or not USD"),
        ))
    })
}

/// A crate file's prims as a [`Layer`].
pub fn layer(bytes: &[u8], origin: &str) -> Result<Layer> {
    if !bytes.starts_with(MAGIC) {
        return Err(data_error(
            origin,
            None,
            "this is not a USD crate file: it does not begin with `PXR-USDC`".into(),
        ));
    }
    guarded(origin, "reading the crate file", || {
        // openusd allocates the counts it reads before reading what they count: every
        // size Kami asks it to decode is checked against the file first.
        bounds::check(bytes).map_err(|m| data_error(origin, None, m))?;
        let data = openusd::usdc::CrateData::open(Cursor::new(bytes), true).map_err(|e| {
            data_error(
                origin,
                None,
                format!("the crate file cannot be read: {e:#}"),
            )
        })?;
        walk(&data, origin)
    })
}

/// A `.usdz` package's root layer (its first file) as a [`Layer`], crate or text.
pub fn package(bytes: &[u8], origin: &str) -> Result<Layer> {
    let bad = |m: String| data_error(origin, None, m);
    let mut zip = zip::ZipArchive::new(Cursor::new(bytes))
        .map_err(|e| bad(format!("this is not a USDZ package (a zip archive): {e}")))?;
    if zip.is_empty() {
        return Err(bad("the package is empty: it holds no USD layer".into()));
    }
    let mut first = zip
        .by_index(0)
        .map_err(|e| bad(format!("the package's first file cannot be read: {e}")))?;
    let name = first.name().to_string();
    let inner = format!("{origin} ({name})");
    let size = first.size();
    if size > MAX_LAYER || size > 64 * bytes.len() as u64 + (1 << 20) {
        return Err(bad(format!(
            "the package's first file {name:?} claims {size} bytes, far more than the package"
        )));
    }
    let mut layer_bytes = Vec::with_capacity(size as usize);
    first.read_to_end(&mut layer_bytes).map_err(|e| {
        bad(format!(
            "the package's first file {name:?} cannot be read: {e}"
        ))
    })?;
    let lower = name.to_ascii_lowercase();
    if lower.ends_with(".usda") || (!layer_bytes.starts_with(MAGIC) && !lower.ends_with(".usdc")) {
        if !(lower.ends_with(".usda") || lower.ends_with(".usd")) {
            return Err(bad(format!(
                "the package's first file is {name:?}; USDZ's root layer is a .usda, .usdc or .usd"
            )));
        }
        let text = std::str::from_utf8(&layer_bytes)
            .map_err(|_| data_error(&inner, None, "the text is not UTF-8".into()))?;
        return super::usd::layer(text, &inner);
    }
    layer(&layer_bytes, &inner)
}

/// The prims reached from the pseudo-root, parents before children, in authored order.
fn walk(data: &dyn AbstractData, origin: &str) -> Result<Layer> {
    let root = sdf::Path::abs_root();
    let mut stage = Stage::default();
    let field = |path: &sdf::Path, name: &str| -> Result<Option<sdf::Value>> {
        data.try_field(path, name)
            .map(|v| v.map(|v| v.into_owned()))
            .map_err(|e| {
                data_error(
                    origin,
                    None,
                    format!("{path}: the field {name:?} cannot be read: {e}"),
                )
            })
    };
    for key in STAGE_KEYS {
        let Some(v) = field(&root, key)? else {
            continue;
        };
        let text = match v {
            sdf::Value::Double(x) => format!("{x}"),
            sdf::Value::Float(x) => format!("{x}"),
            sdf::Value::Int(x) => format!("{x}"),
            sdf::Value::Token(t) => t.as_str().to_string(),
            sdf::Value::String(t) => t,
            other => format!("{other:?}"),
        };
        match key {
            "metersPerUnit" => stage.meters_per_unit = Some((text, 0)),
            "upAxis" => stage.up_axis = Some((text, 0)),
            _ => stage.clock.push((key.to_string(), text, 0)),
        }
    }
    let mut prims: Vec<Prim> = Vec::new();
    let mut seen = HashSet::new();
    // (path, parent index, depth), depth first in authored order.
    let mut todo: Vec<(sdf::Path, Option<usize>, usize)> = children(data, &root, origin)?
        .into_iter()
        .rev()
        .map(|p| (p, None, 1))
        .collect();
    while let Some((path, parent, depth)) = todo.pop() {
        if depth > MAX_DEPTH {
            return Err(data_error(
                origin,
                None,
                format!("{path}: prims nest deeper than {MAX_DEPTH} levels"),
            ));
        }
        if !seen.insert(path.as_str().to_string()) {
            return Err(data_error(
                origin,
                None,
                format!("{path}: the prim is listed twice among its parent's children"),
            ));
        }
        if data.spec_type(&path) != Some(SpecType::Prim) {
            // A child the layer lists but does not define: nothing to read.
            continue;
        }
        let specifier = match field(&path, "specifier")? {
            Some(sdf::Value::Specifier(s)) => s,
            _ => Specifier::Over,
        };
        let type_name = match field(&path, "typeName")? {
            Some(sdf::Value::Token(t)) => t.as_str().to_string(),
            _ => String::new(),
        };
        let inactive = matches!(field(&path, "active")?, Some(sdf::Value::Bool(false)));
        let hidden = specifier == Specifier::Class
            || inactive
            || parent.is_some_and(|p: usize| prims[p].hidden);
        let curves = specifier == Specifier::Def && type_name == "BasisCurves";
        let mut prim = Prim::new(path.as_str().to_string(), parent, hidden, curves);
        let props = match field(&path, "propertyChildren")? {
            Some(sdf::Value::TokenVec(v)) => v,
            _ => Vec::new(),
        };
        for name in props {
            let name = name.as_str();
            let Ok(at) = path.append_property(name) else {
                continue;
            };
            if data.spec_type(&at) != Some(SpecType::Attribute) {
                continue;
            }
            let interp = match field(&at, "interpolation")? {
                Some(sdf::Value::Token(t)) => Some(t.as_str().to_string()),
                _ => None,
            };
            if let Some(v) = field(&at, "default")? {
                prim.set(name, value(v), interp.clone(), 0);
            }
            if let Some(sdf::Value::TimeSamples(samples)) = field(&at, "timeSamples")? {
                let samples: Vec<(f64, Value)> = samples
                    .into_iter()
                    .filter(|s| s.0.is_finite())
                    .map(|(t, v)| (t, value(v)))
                    .collect();
                prim.set(name, Value::Samples(samples), interp, 0);
            }
        }
        let index = prims.len();
        prims.push(prim);
        for child in children(data, &path, origin)?.into_iter().rev() {
            todo.push((child, Some(index), depth + 1));
        }
    }
    Ok(Layer::new(prims, stage))
}

/// The child prims a prim (or the pseudo-root) lists, as paths.
fn children(data: &dyn AbstractData, path: &sdf::Path, origin: &str) -> Result<Vec<sdf::Path>> {
    let names = match data.try_field(path, "primChildren") {
        Ok(Some(v)) => match v.into_owned() {
            sdf::Value::TokenVec(v) => v,
            _ => return Ok(Vec::new()),
        },
        Ok(None) => return Ok(Vec::new()),
        Err(e) => {
            return Err(data_error(
                origin,
                None,
                format!("{path}: its children cannot be read: {e}"),
            ))
        }
    };
    let base = path.as_str().trim_end_matches('/');
    let mut out = Vec::with_capacity(names.len());
    for n in names {
        let p = sdf::Path::new(&format!("{base}/{}", n.as_str())).map_err(|e| {
            data_error(
                origin,
                None,
                format!("{path}: the child name {:?} makes no path: {e}", n.as_str()),
            )
        })?;
        out.push(p);
    }
    Ok(out)
}

/// An attribute value as the text reader would have parsed it: numbers flattened with
/// their tuple size (quaternions real part first and matrices row by row, as usda writes
/// them), tokens and strings as text.
fn value(v: sdf::Value) -> Value {
    use sdf::Value as V;
    fn nums(v: Vec<f64>, arity: usize, array: bool) -> Value {
        Value::Nums { v, arity, array }
    }
    fn flat<const N: usize, T: Copy + Into<f64>>(items: &[[T; N]]) -> Vec<f64> {
        items.iter().flatten().map(|&x| x.into()).collect()
    }
    match v {
        V::Bool(b) => nums(vec![b as u8 as f64], 1, false),
        V::Uchar(x) => nums(vec![x as f64], 1, false),
        V::Int(x) => nums(vec![x as f64], 1, false),
        V::Uint(x) => nums(vec![x as f64], 1, false),
        V::Int64(x) => nums(vec![x as f64], 1, false),
        V::Uint64(x) => nums(vec![x as f64], 1, false),
        V::Half(x) => nums(vec![f64::from(x)], 1, false),
        V::Float(x) => nums(vec![x as f64], 1, false),
        V::Double(x) => nums(vec![x], 1, false),
        V::UcharVec(v) => nums(v.into_iter().map(f64::from).collect(), 1, true),
        V::IntVec(v) => nums(v.into_iter().map(f64::from).collect(), 1, true),
        V::UintVec(v) => nums(v.into_iter().map(f64::from).collect(), 1, true),
        V::Int64Vec(v) => nums(v.into_iter().map(|x| x as f64).collect(), 1, true),
        V::Uint64Vec(v) => nums(v.into_iter().map(|x| x as f64).collect(), 1, true),
        V::HalfVec(v) => nums(v.into_iter().map(f64::from).collect(), 1, true),
        V::FloatVec(v) => nums(v.into_iter().map(f64::from).collect(), 1, true),
        V::DoubleVec(v) => nums(v, 1, true),
        V::Vec2f(a) => nums(flat(&[[a.x, a.y]]), 2, false),
        V::Vec2d(a) => nums(flat(&[[a.x, a.y]]), 2, false),
        V::Vec3h(a) => nums(
            vec![f64::from(a.x), f64::from(a.y), f64::from(a.z)],
            3,
            false,
        ),
        V::Vec3f(a) => nums(flat(&[[a.x, a.y, a.z]]), 3, false),
        V::Vec3d(a) => nums(flat(&[[a.x, a.y, a.z]]), 3, false),
        V::Vec4f(a) => nums(flat(&[[a.x, a.y, a.z, a.w]]), 4, false),
        V::Vec4d(a) => nums(flat(&[[a.x, a.y, a.z, a.w]]), 4, false),
        V::Vec2fVec(v) => nums(
            flat(&v.iter().map(|a| [a.x, a.y]).collect::<Vec<_>>()),
            2,
            true,
        ),
        V::Vec2dVec(v) => nums(
            flat(&v.iter().map(|a| [a.x, a.y]).collect::<Vec<_>>()),
            2,
            true,
        ),
        V::Vec3hVec(v) => nums(
            v.iter()
                .flat_map(|a| [f64::from(a.x), f64::from(a.y), f64::from(a.z)])
                .collect(),
            3,
            true,
        ),
        V::Vec3fVec(v) => nums(
            flat(&v.iter().map(|a| [a.x, a.y, a.z]).collect::<Vec<_>>()),
            3,
            true,
        ),
        V::Vec3dVec(v) => nums(
            flat(&v.iter().map(|a| [a.x, a.y, a.z]).collect::<Vec<_>>()),
            3,
            true,
        ),
        V::Vec4fVec(v) => nums(
            flat(&v.iter().map(|a| [a.x, a.y, a.z, a.w]).collect::<Vec<_>>()),
            4,
            true,
        ),
        V::Vec4dVec(v) => nums(
            flat(&v.iter().map(|a| [a.x, a.y, a.z, a.w]).collect::<Vec<_>>()),
            4,
            true,
        ),
        V::Quath(q) => nums(
            vec![
                f64::from(q.w),
                f64::from(q.x),
                f64::from(q.y),
                f64::from(q.z),
            ],
            4,
            false,
        ),
        V::Quatf(q) => nums(flat(&[[q.w, q.x, q.y, q.z]]), 4, false),
        V::Quatd(q) => nums(flat(&[[q.w, q.x, q.y, q.z]]), 4, false),
        V::Matrix4d(m) => nums(m.0.to_vec(), 16, false),
        V::Token(t) => Value::Text(t.as_str().to_string()),
        V::String(t) => Value::Text(t),
        V::TokenVec(v) => Value::Strs(v.iter().map(|t| t.as_str().to_string()).collect()),
        V::StringVec(v) => Value::Strs(v),
        _ => Value::Other,
    }
}
