//! USD `BasisCurves` in text form (`.usda`). The writer makes one `BasisCurves` prim (cubic
//! with its basis and wrap when the groom is, linear otherwise) with vertex widths, and
//! `primvars:displayColor` / `primvars:displayOpacity` when the groom has them, in Kami's
//! centimetres with y up. The reader takes that and what Blender, Houdini and Maya export:
//!
//! - every `def BasisCurves` prim, at any depth, concatenated in file order (not those in a
//!   `class` or under `active = false`);
//! - linear and cubic curves (`bezier`, `bspline`, `catmullRom`; `wrap` nonperiodic,
//!   periodic or pinned), with USD's fallbacks (cubic, bezier, nonperiodic); a groom of one
//!   basis keeps its control points ([`Groom::into_linear`] evaluates them), prims of
//!   different bases become polylines;
//! - widths and the two primvars as constant, uniform, vertex or varying values (also
//!   indexed ones); an attribute missing from one prim is dropped from all;
//! - transforms: every `xformOp` kind (translate, scale, rotateX/Y/Z, the six three-axis
//!   rotations, orient, transform, `!invert!`, `!resetXformStack!`) in `xformOpOrder`, on
//!   the prim and its parents; the stage's `metersPerUnit` and `upAxis` (Kami is
//!   centimetres, y up); widths scale with the transform's mean scale;
//! - `timeSamples`: the first sample.
//!
//! Lost: normals, other primvars, variants, references, payloads and sublayers, and the
//! other time samples. Binary `.usd`/`.usdc` is not read.

use super::curves::{self, Basis, Wrap};
use super::{data_error, Groom, Values};
use crate::error::{KamiError, Result};
use glam::{DMat4, DVec3};
use std::fmt::Write;

/// usda text for a checked groom.
pub fn to_string(g: &Groom) -> String {
    let mut s = String::with_capacity(g.points.len() * 48);
    // Kami's units: centimetres, y up (what a reader scales and turns by).
    s.push_str("#usda 1.0\n(\n    defaultPrim = \"hair\"\n    doc = \"Kami strands (kami convert)\"\n    metersPerUnit = 0.01\n    upAxis = \"Y\"\n)\n\n");
    s.push_str("def BasisCurves \"hair\"\n{\n");
    if g.basis == Basis::Linear {
        s.push_str("    uniform token type = \"linear\"\n");
    } else {
        s.push_str("    uniform token type = \"cubic\"\n");
        let _ = writeln!(s, "    uniform token basis = \"{}\"", g.basis.token());
    }
    let _ = writeln!(s, "    uniform token wrap = \"{}\"", g.wrap.token());
    list(
        &mut s,
        "    int[] curveVertexCounts = ",
        &g.counts,
        |s, c| {
            let _ = write!(s, "{c}");
        },
    );
    s.push('\n');
    list(&mut s, "    point3f[] points = ", &g.points, |s, p| {
        let _ = write!(s, "({}, {}, {})", p[0], p[1], p[2]);
    });
    s.push('\n');
    let vertex = " (\n        interpolation = \"vertex\"\n    )\n";
    if let Some(w) = &g.widths {
        list(&mut s, "    float[] widths = ", w, |s, v| {
            let _ = write!(s, "{v}");
        });
        s.push_str(vertex);
    }
    if let Some(c) = &g.colors {
        list(
            &mut s,
            "    color3f[] primvars:displayColor = ",
            c,
            |s, p| {
                // USD's displayColor is linear; Kami's colours are sRGB.
                let p = p.map(|x| super::srgb_to_linear(x as f64) as f32);
                let _ = write!(s, "({}, {}, {})", p[0], p[1], p[2]);
            },
        );
        s.push_str(vertex);
    }
    if let Some(o) = &g.opacities {
        list(
            &mut s,
            "    float[] primvars:displayOpacity = ",
            o,
            |s, v| {
                let _ = write!(s, "{v}");
            },
        );
        s.push_str(vertex);
    }
    s.push_str("}\n");
    s
}

fn list<T>(s: &mut String, head: &str, items: &[T], mut each: impl FnMut(&mut String, &T)) {
    s.push_str(head);
    s.push('[');
    for (i, x) in items.iter().enumerate() {
        if i > 0 {
            s.push_str(", ");
        }
        each(s, x);
    }
    s.push(']');
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Word(String),
    Str(String),
    Punct(char),
}

struct Lexer<'a> {
    b: &'a [u8],
    at: usize,
    line: usize,
}

impl Lexer<'_> {
    /// The next token and its line; `None` at the end.
    fn next(&mut self, origin: &str) -> Result<Option<(Tok, usize)>> {
        let b = self.b;
        loop {
            while self.at < b.len() && b[self.at].is_ascii_whitespace() {
                if b[self.at] == b'\n' {
                    self.line += 1;
                }
                self.at += 1;
            }
            if self.at < b.len() && b[self.at] == b'#' {
                while self.at < b.len() && b[self.at] != b'\n' {
                    self.at += 1;
                }
                continue;
            }
            break;
        }
        if self.at >= b.len() {
            return Ok(None);
        }
        let line = self.line;
        let c = b[self.at];
        let quoted = |lx: &mut Self, open: &[u8], close: &[u8]| -> Result<Tok> {
            let start = lx.at + open.len();
            let mut i = start;
            while i + close.len() <= b.len() {
                if &b[i..i + close.len()] == close {
                    let s = String::from_utf8_lossy(&b[start..i]).into_owned();
                    lx.line += s.matches('\n').count();
                    lx.at = i + close.len();
                    return Ok(Tok::Str(s));
                }
                if b[i] == b'\\' && open.len() == 1 && close != b"@" {
                    i += 1;
                }
                i += 1;
            }
            Err(data_error(
                origin,
                Some(line),
                "a string or asset path is not closed".into(),
            ))
        };
        let tok = match c {
            b'"' | b'\'' => {
                let q = [c, c, c];
                if b[self.at..].starts_with(&q) {
                    quoted(self, &q, &q)?
                } else {
                    quoted(self, &[c], &[c])?
                }
            }
            b'@' => quoted(self, b"@", b"@")?,
            b'<' => quoted(self, b"<", b">")?,
            b'(' | b')' | b'[' | b']' | b'{' | b'}' | b'=' | b',' | b':' | b';' => {
                self.at += 1;
                Tok::Punct(c as char)
            }
            _ => {
                let start = self.at;
                let word = |c: u8| c.is_ascii_alphanumeric() || b"_.:+-".contains(&c);
                while self.at < b.len() && word(b[self.at]) {
                    self.at += 1;
                }
                // A trailing ':' separates a time sample from its value.
                while self.at > start + 1 && b[self.at - 1] == b':' {
                    self.at -= 1;
                }
                if self.at == start {
                    return Err(data_error(
                        origin,
                        Some(line),
                        format!("unexpected character {:?}", char::from(c)),
                    ));
                }
                if b[self.at..].starts_with(b"[]") {
                    self.at += 2;
                }
                Tok::Word(String::from_utf8_lossy(&b[start..self.at]).into_owned())
            }
        };
        Ok(Some((tok, line)))
    }
}

/// A parsed attribute value: numbers flattened (with the tuple size), or something else.
#[derive(Clone, Debug)]
pub(super) enum Value {
    Nums {
        v: Vec<f64>,
        arity: usize,
        array: bool,
    },
    Text(String),
    /// An array of strings or tokens (`xformOpOrder`).
    Strs(Vec<String>),
    /// `timeSamples`: (time code, value), in time order.
    Samples(Vec<(f64, Value)>),
    Other,
}

struct Parser<'a> {
    toks: Vec<(Tok, usize)>,
    at: usize,
    origin: &'a str,
    /// Nesting of prims and values now: bounded, so a hostile file is an error, not a
    /// stack overflow.
    depth: usize,
    stage: Stage,
}

/// Deepest nesting of prims or values read (real files nest a handful of levels).
const MAX_DEPTH: usize = 128;

/// A numeric attribute: name, values (flattened), tuple size, interpolation, line.
type Attr = (String, Vec<f64>, usize, Option<String>, usize);

impl Parser<'_> {
    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.at).map(|t| &t.0)
    }
    fn line(&self) -> usize {
        self.toks
            .get(self.at)
            .or(self.toks.last())
            .map_or(1, |t| t.1)
    }
    fn err(&self, m: String) -> crate::error::KamiError {
        data_error(self.origin, Some(self.line()), m)
    }
    fn bump(&mut self) -> Result<Tok> {
        match self.toks.get(self.at) {
            Some(t) => {
                self.at += 1;
                Ok(t.0.clone())
            }
            None => Err(self.err("the file ends in the middle of a statement".into())),
        }
    }
    fn expect(&mut self, c: char) -> Result<()> {
        match self.bump()? {
            Tok::Punct(p) if p == c => Ok(()),
            t => {
                self.at -= 1;
                Err(self.err(format!("expected `{c}`, found {}", show(&t))))
            }
        }
    }
    /// Skip a bracketed group starting at the current opening token; brackets must pair.
    fn skip_group(&mut self) -> Result<()> {
        let mut open: Vec<(char, usize)> = Vec::new();
        loop {
            let line = self.line();
            match self.bump()? {
                Tok::Punct(c @ ('(' | '[' | '{')) => open.push((c, line)),
                Tok::Punct(c @ (')' | ']' | '}')) => {
                    let (o, oline) = open.pop().unwrap_or(('?', line));
                    if !matches!((o, c), ('(', ')') | ('[', ']') | ('{', '}')) {
                        self.at -= 1;
                        return Err(
                            self.err(format!("`{c}` closes the `{o}` opened on line {oline}"))
                        );
                    }
                    if open.is_empty() {
                        return Ok(());
                    }
                }
                _ => {}
            }
        }
    }
    /// `( ... )` metadata: its `key = value` pairs whose value is one string or word
    /// (`interpolation`, `metersPerUnit`, `upAxis`, `active`), with their lines.
    fn metadata(&mut self) -> Result<Vec<(String, String, usize)>> {
        let start = self.at;
        self.skip_group()?;
        let mut pairs = Vec::new();
        let toks = &self.toks[start..self.at];
        for (i, w) in toks.windows(3).enumerate() {
            // Only `key = value` at the group's top level, followed by its end or a new key.
            let after = toks.get(i + 3).map(|t| &t.0);
            let ends = !matches!(after, Some(Tok::Punct('(' | '[' | '{')));
            if let (Tok::Word(k), Tok::Punct('='), Tok::Str(v) | Tok::Word(v)) =
                (&w[0].0, &w[1].0, &w[2].0)
            {
                if ends {
                    pairs.push((k.clone(), v.clone(), w[0].1));
                }
            }
        }
        Ok(pairs)
    }

    /// The `interpolation` of a property's metadata.
    fn interpolation(pairs: &[(String, String, usize)]) -> Option<String> {
        pairs
            .iter()
            .find(|p| p.0 == "interpolation")
            .map(|p| p.1.clone())
    }

    fn enter(&mut self) -> Result<()> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.err(format!("nesting deeper than {MAX_DEPTH} levels")));
        }
        Ok(())
    }

    fn value(&mut self) -> Result<Value> {
        self.enter()?;
        let v = self.value_in();
        self.depth -= 1;
        v
    }

    fn value_in(&mut self) -> Result<Value> {
        match self.bump()? {
            Tok::Str(t) => Ok(Value::Text(t)),
            Tok::Word(w) => Ok(match num(&w) {
                Some(x) => Value::Nums {
                    v: vec![x],
                    arity: 1,
                    array: false,
                },
                None => Value::Text(w),
            }),
            Tok::Punct('(') => {
                self.at -= 1;
                let Some(v) = self.tuple()? else {
                    return Ok(Value::Other);
                };
                let arity = v.len();
                Ok(Value::Nums {
                    v,
                    arity,
                    array: false,
                })
            }
            Tok::Punct('[') => {
                let start = self.at - 1;
                let mut v = Vec::new();
                let mut arity = None;
                if let Some(Tok::Str(_)) = self.peek() {
                    return self.strings(start);
                }
                loop {
                    match self.peek() {
                        Some(Tok::Punct(']')) => {
                            self.at += 1;
                            break;
                        }
                        Some(Tok::Punct(',')) => self.at += 1,
                        Some(Tok::Punct('(')) => {
                            let Some(t) = self.tuple()? else {
                                self.at = start;
                                self.skip_group()?;
                                return Ok(Value::Other);
                            };
                            if *arity.get_or_insert(t.len()) != t.len() {
                                return Err(
                                    self.err("tuples of different sizes in one array".into())
                                );
                            }
                            v.extend(t);
                        }
                        Some(Tok::Word(w)) if num(w).is_some() => {
                            if *arity.get_or_insert(1) != 1 {
                                return Err(
                                    self.err("numbers and tuples mixed in one array".into())
                                );
                            }
                            v.push(num(w).unwrap_or_default());
                            self.at += 1;
                        }
                        _ => {
                            self.at = start;
                            self.skip_group()?;
                            return Ok(Value::Other);
                        }
                    }
                }
                Ok(Value::Nums {
                    v,
                    arity: arity.unwrap_or(1),
                    array: true,
                })
            }
            Tok::Punct('{') => {
                // timeSamples: `{ time: value, ... }`.
                let start = self.at - 1;
                let is_samples = matches!(self.peek(), Some(Tok::Word(w)) if num(w).is_some())
                    && matches!(self.toks.get(self.at + 1), Some((Tok::Punct(':'), _)));
                if !is_samples {
                    self.at = start;
                    self.skip_group()?;
                    return Ok(Value::Other);
                }
                let mut samples: Vec<(f64, Value)> = Vec::new();
                loop {
                    match self.bump()? {
                        Tok::Punct('}') => break,
                        Tok::Punct(',') => {}
                        Tok::Word(w) => {
                            let Some(t) = num(&w).filter(|t| t.is_finite()) else {
                                return Err(self.err(format!(
                                    "expected a time code in timeSamples, found {w:?}"
                                )));
                            };
                            self.expect(':')?;
                            let v = self.value()?;
                            samples.push((t, v));
                        }
                        t => {
                            return Err(self.err(format!(
                                "expected a time code in timeSamples, found {}",
                                show(&t)
                            )))
                        }
                    }
                }
                Ok(Value::Samples(sorted_samples(samples)))
            }
            t => {
                self.at -= 1;
                Err(self.err(format!("expected a value, found {}", show(&t))))
            }
        }
    }

    /// A tuple of numbers, nested tuples flattened (the rows of a `matrix4d`); `None`
    /// (skipped) for anything else.
    fn tuple(&mut self) -> Result<Option<Vec<f64>>> {
        let start = self.at;
        self.expect('(')?;
        let mut v = Vec::new();
        let mut open = 1usize;
        loop {
            match self.bump()? {
                Tok::Punct(')') => {
                    open -= 1;
                    if open == 0 {
                        return Ok(Some(v));
                    }
                }
                // Real tuples nest once (matrix rows); deeper is not a tuple of numbers.
                Tok::Punct('(') if open < 2 => open += 1,
                Tok::Punct(',') => {}
                Tok::Word(w) if num(&w).is_some() => v.push(num(&w).unwrap_or_default()),
                _ => {
                    self.at = start;
                    self.skip_group()?;
                    return Ok(None);
                }
            }
        }
    }

    /// `[ "a", "b", ... ]` from its `[` at `start`; anything else in it makes it `Other`.
    fn strings(&mut self, start: usize) -> Result<Value> {
        let mut v = Vec::new();
        loop {
            match self.bump()? {
                Tok::Punct(']') => return Ok(Value::Strs(v)),
                Tok::Punct(',') => {}
                Tok::Str(t) => v.push(t),
                _ => {
                    self.at = start;
                    self.skip_group()?;
                    return Ok(Value::Other);
                }
            }
        }
    }

    /// Statements up to a closing `}` (or the end, at the top), collecting every prim
    /// (for its transform) and the BasisCurves' properties. `prim` is the prim whose body
    /// this is (an index into `out`).
    fn block(&mut self, prim: Option<usize>, out: &mut Vec<Prim>, top: bool) -> Result<()> {
        self.enter()?;
        let r = self.block_in(prim, out, top);
        self.depth -= 1;
        r
    }

    fn block_in(&mut self, prim: Option<usize>, out: &mut Vec<Prim>, top: bool) -> Result<()> {
        loop {
            let line = self.line();
            let Some(tok) = self.peek().cloned() else {
                if top {
                    return Ok(());
                }
                return Err(self.err("the file ends inside a prim: a `}` is missing".into()));
            };
            match tok {
                Tok::Punct('}') if !top => {
                    self.at += 1;
                    return Ok(());
                }
                Tok::Punct('(') if top => {
                    for (k, v, l) in self.metadata()? {
                        match k.as_str() {
                            "metersPerUnit" => self.stage.meters_per_unit = Some((v, l)),
                            "upAxis" => self.stage.up_axis = Some((v, l)),
                            "timeCodesPerSecond" | "framesPerSecond" | "startTimeCode"
                            | "endTimeCode" => self.stage.clock.push((k, v, l)),
                            _ => {}
                        }
                    }
                }
                Tok::Word(w) if w == "def" || w == "over" || w == "class" => {
                    self.at += 1;
                    let kind = match self.bump()? {
                        Tok::Word(k) => {
                            match self.bump()? {
                                Tok::Str(_) => {}
                                t => {
                                    return Err(self
                                        .err(format!("expected a prim name, found {}", show(&t))))
                                }
                            }
                            Some(k)
                        }
                        Tok::Str(_) => None,
                        t => {
                            return Err(self
                                .err(format!("expected a prim type or name, found {}", show(&t))))
                        }
                    };
                    let mut inactive = false;
                    if self.peek() == Some(&Tok::Punct('(')) {
                        inactive = self
                            .metadata()?
                            .iter()
                            .any(|(k, v, _)| k == "active" && (v == "false" || v == "0"));
                    }
                    self.expect('{')?;
                    // Class prims and what they hold are templates, and inactive prims are
                    // switched off: neither is drawn.
                    let hidden = w == "class" || inactive || prim.is_some_and(|p| out[p].hidden);
                    let idx = out.len();
                    out.push(Prim {
                        line,
                        parent: prim,
                        hidden,
                        curves: w == "def" && kind.as_deref() == Some("BasisCurves"),
                        ..Prim::default()
                    });
                    self.block(Some(idx), out, false)?;
                }
                Tok::Word(_) => {
                    // A property: words on one line (qualifiers, type, name), then an
                    // optional `= value` and `( metadata )`.
                    let mut words = Vec::new();
                    while let Some((Tok::Word(w), l)) = self.toks.get(self.at) {
                        if *l != line && !words.is_empty() {
                            break;
                        }
                        words.push(w.clone());
                        self.at += 1;
                    }
                    // `variantSet "name" = {...}` and the like: the string is part of it.
                    while let Some(Tok::Str(_)) = self.peek() {
                        self.at += 1;
                    }
                    let name = words.last().cloned().unwrap_or_default();
                    let mut value = None;
                    if self.peek() == Some(&Tok::Punct('=')) {
                        self.at += 1;
                        value = Some(self.value()?);
                    }
                    let interp = if self.peek() == Some(&Tok::Punct('(')) {
                        Self::interpolation(&self.metadata()?)
                    } else {
                        None
                    };
                    if let (Some(p), Some(v)) = (prim, value) {
                        out[p].set(&name, v, interp, line);
                    }
                }
                Tok::Punct(';') => self.at += 1,
                t => return Err(self.err(format!("unexpected {}", show(&t)))),
            }
        }
    }
}

/// The stage's metadata Kami applies: its unit and up axis, and its clock (values and
/// lines; line 0 in a crate file).
#[derive(Clone, Default)]
pub(super) struct Stage {
    pub(super) meters_per_unit: Option<(String, usize)>,
    pub(super) up_axis: Option<(String, usize)>,
    /// `timeCodesPerSecond`, `framesPerSecond`, `startTimeCode`, `endTimeCode`.
    pub(super) clock: Vec<(String, String, usize)>,
}

#[derive(Clone, Default)]
pub(super) struct Prim {
    /// Its line in a text file; 0 in a crate file, where `path` names it.
    pub(super) line: usize,
    /// Its path (`/groom/hair`) in a crate file; empty in a text file, where `line` does.
    pub(super) path: String,
    /// The prim this one is defined in.
    pub(super) parent: Option<usize>,
    /// A class prim, an inactive one, or inside one of those.
    pub(super) hidden: bool,
    /// `def BasisCurves`.
    pub(super) curves: bool,
    counts: Option<(Vec<f64>, usize)>,
    points: Option<(Vec<f64>, usize)>,
    /// `type`, `basis` and `wrap` (value, line).
    tokens: Vec<(String, String, usize)>,
    /// `xformOpOrder` and its line.
    order: Option<(Vec<String>, usize)>,
    /// Numeric attributes, in file order: every one on a BasisCurves, the `xformOp:`s on
    /// the others.
    attrs: Vec<Attr>,
    /// Attributes with time samples: name, samples (time order), interpolation, line.
    timed: Vec<Timed>,
}

/// An attribute's time samples: name, (time code, value) in time order, interpolation, line.
type Timed = (String, Vec<(f64, Value)>, Option<String>, usize);

/// Samples in time order, a time authored twice keeping its last value (as USD does).
fn sorted_samples(mut samples: Vec<(f64, Value)>) -> Vec<(f64, Value)> {
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out: Vec<(f64, Value)> = Vec::with_capacity(samples.len());
    for s in samples {
        match out.last_mut() {
            Some(l) if l.0 == s.0 => *l = s,
            _ => out.push(s),
        }
    }
    out
}

impl Prim {
    /// A prim of a crate file, named by its path.
    pub(super) fn new(path: String, parent: Option<usize>, hidden: bool, curves: bool) -> Prim {
        Prim {
            path,
            parent,
            hidden,
            curves,
            ..Prim::default()
        }
    }

    /// Set attribute `name` (a `.timeSamples` suffix is the same attribute): time samples
    /// are kept for [`Prim::at`], and their first value also stands as the attribute's
    /// value, so that a file read without a time shows its first sample.
    pub(super) fn set(&mut self, name: &str, v: Value, interp: Option<String>, line: usize) {
        let name = name.strip_suffix(".timeSamples").unwrap_or(name);
        if let Value::Samples(samples) = v {
            // In time order, whatever the file's (a crate file's are as written).
            let samples = sorted_samples(samples.into_iter().filter(|s| s.0.is_finite()).collect());
            let Some(first) = samples.first().map(|s| s.1.clone()) else {
                return;
            };
            self.set(name, first, interp.clone(), line);
            if name.starts_with("xformOp:") || self.curves {
                self.timed.push((name.to_string(), samples, interp, line));
            }
            return;
        }
        match (name, v) {
            ("xformOpOrder", Value::Strs(order)) => self.order = Some((order, line)),
            (_, Value::Nums { v, arity, .. }) if name.starts_with("xformOp:") => {
                self.attrs.push((name.to_string(), v, arity, interp, line))
            }
            _ if !self.curves => {}
            ("type" | "basis" | "wrap", Value::Text(t)) => {
                self.tokens.push((name.to_string(), t, line))
            }
            ("curveVertexCounts", Value::Nums { v, array: true, .. }) => {
                self.counts = Some((v, line))
            }
            (
                "points",
                Value::Nums {
                    v,
                    arity: 3,
                    array: true,
                },
            ) => self.points = Some((v, line)),
            (_, Value::Nums { v, arity, .. }) => {
                self.attrs.push((name.to_string(), v, arity, interp, line))
            }
            _ => {}
        }
    }

    /// This prim with every time-sampled attribute at time code `t` ([`value_at`]).
    pub(super) fn at(&self, t: f64) -> Prim {
        // Everything but the samples (a cache's samples are most of the file: cloning
        // them per frame would copy the whole cache per frame).
        let mut p = Prim {
            line: self.line,
            path: self.path.clone(),
            parent: self.parent,
            hidden: self.hidden,
            curves: self.curves,
            counts: self.counts.clone(),
            points: self.points.clone(),
            tokens: self.tokens.clone(),
            order: self.order.clone(),
            attrs: self.attrs.clone(),
            timed: Vec::new(),
        };
        for (name, samples, interp, line) in &self.timed {
            p.set(name, value_at(name, samples, t), interp.clone(), *line);
        }
        p
    }

    /// An error about this prim: at `line` of a text file, by the prim's path in a crate.
    pub(super) fn error(&self, origin: &str, line: usize, m: String) -> KamiError {
        if self.path.is_empty() {
            data_error(origin, Some(line), m)
        } else {
            data_error(&format!("{origin}, prim {}", self.path), None, m)
        }
    }

    fn attr(&self, name: &str) -> Option<&Attr> {
        self.attrs.iter().rev().find(|a| a.0 == name)
    }

    fn token(&self, name: &str) -> Option<(&str, usize)> {
        self.tokens
            .iter()
            .rev()
            .find(|t| t.0 == name)
            .map(|t| (t.1.as_str(), t.2))
    }

    /// This prim's own transform (column vectors: the ops of `xformOpOrder` multiplied in
    /// their order, so the last is applied to points first), and whether it resets the
    /// parents' (`!resetXformStack!`).
    fn local(&self, origin: &str) -> Result<(DMat4, bool)> {
        let Some((order, oline)) = &self.order else {
            // Ops not listed in an order do not apply (USD's rule).
            return Ok((DMat4::IDENTITY, false));
        };
        let mut m = DMat4::IDENTITY;
        let mut reset = false;
        for op in order {
            if op == "!resetXformStack!" {
                reset = true;
                m = DMat4::IDENTITY;
                continue;
            }
            let (invert, name) = match op.strip_prefix("!invert!") {
                Some(n) => (true, n),
                None => (false, op.as_str()),
            };
            let Some((_, v, arity, _, line)) = self.attr(name) else {
                return Err(self.error(
                    origin,
                    *oline,
                    format!("xformOpOrder names {name:?}, which this prim does not set"),
                ));
            };
            let op = xform_op(name, v, *arity).map_err(|m| self.error(origin, *line, m))?;
            let op = if invert {
                if op.determinant().abs() < 1e-300 {
                    return Err(self.error(
                        origin,
                        *line,
                        format!("{name} cannot be inverted (`!invert!` in xformOpOrder): it is singular"),
                    ));
                }
                op.inverse()
            } else {
                op
            };
            m *= op;
        }
        Ok((m, reset))
    }
}

/// An attribute's value at time code `t` from its samples (time order): between two samples
/// of floating-point numbers of one shape, linearly interpolated (USD's default for them);
/// integers (vertex counts, indices), quaternions (`orient`, which USD would slerp), tokens
/// and samples of different shapes held from the earlier sample; before the first sample
/// or after the last, that sample.
fn value_at(name: &str, samples: &[(f64, Value)], t: f64) -> Value {
    let i = samples.partition_point(|s| s.0 <= t);
    if i == 0 {
        return samples[0].1.clone();
    }
    let (t0, a) = (samples[i - 1].0, &samples[i - 1].1);
    let Some((t1, b)) = samples.get(i).map(|s| (s.0, &s.1)) else {
        return a.clone();
    };
    let blend = !(name == "curveVertexCounts"
        || name.ends_with(":indices")
        || name.starts_with("xformOp:orient"));
    match (a, b) {
        (
            Value::Nums { v, arity, array },
            Value::Nums {
                v: w, arity: aw, ..
            },
        ) if blend && t > t0 && arity == aw && v.len() == w.len() => {
            let u = (t - t0) / (t1 - t0);
            Value::Nums {
                v: v.iter().zip(w).map(|(x, y)| x + (y - x) * u).collect(),
                arity: *arity,
                array: *array,
            }
        }
        _ => a.clone(),
    }
}

/// The matrix of one `xformOp` (column vectors), from its name's kind and its values:
/// translate, scale, rotateX/Y/Z, the six three-axis rotations (degrees, the first axis
/// applied first), orient (a quaternion, real part first as usda writes it) and transform
/// (a 4x4 matrix, rows as usda writes them for row vectors).
fn xform_op(name: &str, v: &[f64], arity: usize) -> std::result::Result<DMat4, String> {
    let kind = name.split(':').nth(1).unwrap_or("");
    let want = |n: usize| -> std::result::Result<(), String> {
        if v.len() == n && (arity == n || n == 1) {
            Ok(())
        } else {
            Err(format!("{name} has {} values; a {kind} takes {n}", v.len()))
        }
    };
    if v.iter().any(|x| !x.is_finite()) {
        return Err(format!("{name} is not finite"));
    }
    let axis = |c: char, deg: f64| match c {
        'X' => DMat4::from_rotation_x(deg.to_radians()),
        'Y' => DMat4::from_rotation_y(deg.to_radians()),
        _ => DMat4::from_rotation_z(deg.to_radians()),
    };
    Ok(match kind {
        "translate" => {
            want(3)?;
            DMat4::from_translation(DVec3::new(v[0], v[1], v[2]))
        }
        "scale" => {
            want(3)?;
            DMat4::from_scale(DVec3::new(v[0], v[1], v[2]))
        }
        "rotateX" | "rotateY" | "rotateZ" => {
            want(1)?;
            axis(kind.as_bytes()[6] as char, v[0])
        }
        "rotateXYZ" | "rotateXZY" | "rotateYXZ" | "rotateYZX" | "rotateZXY" | "rotateZYX" => {
            want(3)?;
            let axes: Vec<char> = kind[6..].chars().collect();
            // Values are per named axis (x, y, z angles), applied in the name's order.
            let angle = |c: char| v[(c as u8 - b'X') as usize];
            axis(axes[2], angle(axes[2]))
                * axis(axes[1], angle(axes[1]))
                * axis(axes[0], angle(axes[0]))
        }
        "orient" => {
            want(4)?;
            let q = glam::DQuat::from_xyzw(v[1], v[2], v[3], v[0]);
            if q.length() < 1e-12 {
                return Err(format!("{name} is a zero quaternion"));
            }
            DMat4::from_quat(q.normalize())
        }
        "transform" => {
            want(16)?;
            // usda's rows are for row vectors (p' = p M): as columns they are M transposed,
            // the same matrix for column vectors.
            DMat4::from_cols_array(&v.try_into().map_err(|_| format!("{name} is not 4x4"))?)
        }
        _ => return Err(format!("{name}: Kami does not know the xformOp {kind:?}")),
    })
}

/// A number token. Fractions parse straight to f32 (through f64 they could round twice and
/// miss the f32 the writer printed); whole numbers parse exactly (vertex counts, indices).
fn num(w: &str) -> Option<f64> {
    let c = w.as_bytes().first()?;
    let lower = w.to_ascii_lowercase();
    let special = ["inf", "-inf", "+inf", "nan", "-nan"].contains(&lower.as_str());
    if !(c.is_ascii_digit() || b"+-.".contains(c) || special) {
        return None;
    }
    match w.parse::<i64>() {
        // `-0` is negative zero, as the writer printed it.
        Ok(0) if w.starts_with('-') => Some(-0.0),
        Ok(i) => Some(i as f64),
        Err(_) => w.parse::<f32>().ok().map(f64::from),
    }
}

fn show(t: &Tok) -> String {
    match t {
        Tok::Word(w) => format!("`{w}`"),
        Tok::Str(s) => format!("{s:?}"),
        Tok::Punct(c) => format!("`{c}`"),
    }
}

/// Parse usda text into a groom (see the module doc for what is kept).
pub fn parse(text: &str, origin: &str) -> Result<Groom> {
    layer(text, origin)?.groom(origin, None)
}

/// A text layer's prims and stage metadata.
pub(super) fn layer(text: &str, origin: &str) -> Result<Layer> {
    let first = text.lines().next().unwrap_or("");
    if !first.starts_with("#usda ") {
        return Err(data_error(
            origin,
            Some(1),
            "the first line is not `#usda 1.0`: this is not a text USD file".into(),
        ));
    }
    let mut lx = Lexer {
        b: text.as_bytes(),
        at: 0,
        line: 1,
    };
    let mut toks = Vec::new();
    while let Some(t) = lx.next(origin)? {
        toks.push(t);
    }
    let mut p = Parser {
        toks,
        at: 0,
        origin,
        depth: 0,
        stage: Stage::default(),
    };
    let mut prims = Vec::new();
    p.block(None, &mut prims, true)?;
    Ok(Layer {
        prims,
        stage: p.stage,
    })
}

/// A USD layer as Kami reads it, text or crate: its prims in file order (parents before
/// children) and the stage's metadata.
pub struct Layer {
    pub(super) prims: Vec<Prim>,
    pub(super) stage: Stage,
}

impl Layer {
    pub(super) fn new(prims: Vec<Prim>, stage: Stage) -> Layer {
        Layer { prims, stage }
    }

    /// The time codes at which the drawn curves, or the transforms above them, have
    /// samples, in order (empty for a still groom).
    pub fn times(&self) -> Vec<f64> {
        let mut t: Vec<f64> = Vec::new();
        for prim in self.prims.iter().filter(|p| p.curves && !p.hidden) {
            let mut at = Some(prim);
            while let Some(q) = at {
                t.extend(q.timed.iter().flat_map(|s| s.1.iter().map(|x| x.0)));
                at = q.parent.map(|i| &self.prims[i]);
            }
        }
        t.sort_by(f64::total_cmp);
        t.dedup();
        t
    }

    /// Time codes per second: the stage's `timeCodesPerSecond`, else its
    /// `framesPerSecond`, else USD's fallback of 24.
    pub fn time_codes_per_second(&self, origin: &str) -> Result<f64> {
        for key in ["timeCodesPerSecond", "framesPerSecond"] {
            if let Some((_, v, line)) = self.stage.clock.iter().rev().find(|c| c.0 == key) {
                return match v.parse::<f64>() {
                    Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
                    _ => Err(data_error(
                        origin,
                        (*line > 0).then_some(*line),
                        format!("{key} is {v}; it must be a positive number"),
                    )),
                };
            }
        }
        Ok(24.0)
    }

    /// The stage's `startTimeCode` and `endTimeCode`, where authored.
    pub fn range(&self) -> (Option<f64>, Option<f64>) {
        let get = |key: &str| {
            self.stage
                .clock
                .iter()
                .rev()
                .find(|c| c.0 == key)
                .and_then(|c| c.1.parse::<f64>().ok())
                .filter(|x| x.is_finite())
        };
        (get("startTimeCode"), get("endTimeCode"))
    }

    /// The groom at time code `time` (samples interpolated as [`value_at`] says), or with
    /// each attribute's first sample (`None`).
    pub fn groom(&self, origin: &str, time: Option<f64>) -> Result<Groom> {
        let prims: Vec<Prim>;
        let prims = match time {
            Some(t) => {
                prims = self.prims.iter().map(|p| p.at(t)).collect();
                &prims
            }
            None => &self.prims,
        };
        let curves: Vec<&Prim> = prims.iter().filter(|p| p.curves && !p.hidden).collect();
        if curves.is_empty() {
            return Err(data_error(
                origin,
                None,
                "no `def BasisCurves` prim: no strands in this file".into(),
            ));
        }
        let stage = stage_transform(&self.stage, origin)?;
        let mut parts = Vec::with_capacity(curves.len());
        for prim in curves {
            // The prim's transform and its parents', up to a reset, then the stage's.
            let mut world = DMat4::IDENTITY;
            let mut at = Some(prim);
            while let Some(q) = at {
                let (local, reset) = q.local(origin)?;
                world = local * world;
                if reset {
                    break;
                }
                at = q.parent.map(|i| &prims[i]);
            }
            parts.push(curve_prim(prim, stage * world, origin)?);
        }
        join_parts(parts)
    }
}

/// Prims' grooms as one: of one basis, or all polylines.
fn join_parts(mut parts: Vec<Groom>) -> Result<Groom> {
    // One basis for the whole groom: prims of different bases all become polylines.
    let same = parts
        .iter()
        .all(|g| (g.basis, g.wrap) == (parts[0].basis, parts[0].wrap));
    if !same {
        parts = parts.into_iter().map(Groom::into_linear).collect();
    }
    let mut g = Groom {
        basis: parts[0].basis,
        wrap: parts[0].wrap,
        widths: Some(Vec::new()),
        colors: Some(Vec::new()),
        opacities: Some(Vec::new()),
        ..Groom::default()
    };
    // An attribute missing from one prim is dropped from all (a neutral fill would draw
    // what no file said).
    fn join<T>(acc: &mut Option<Vec<T>>, v: Option<Vec<T>>) {
        match (acc.as_mut(), v) {
            (Some(a), Some(v)) => a.extend(v),
            _ => *acc = None,
        }
    }
    for part in parts {
        g.counts.extend(part.counts);
        g.points.extend(part.points);
        join(&mut g.widths, part.widths);
        join(&mut g.opacities, part.opacities);
        join(&mut g.colors, part.colors);
    }
    Ok(g)
}

/// Kami's units are centimetres with y up: a stage's `metersPerUnit` (USD's fallback is
/// 0.01, centimetres) scales it, and `upAxis = "Z"` turns z up into y up.
fn stage_transform(stage: &Stage, origin: &str) -> Result<DMat4> {
    let mut m = DMat4::IDENTITY;
    if let Some((v, line)) = &stage.meters_per_unit {
        // In f64: 0.01 must come out as exactly no scale.
        match v.parse::<f64>() {
            Ok(x) if x.is_finite() && x > 0.0 => m = DMat4::from_scale(DVec3::splat(x / 0.01)),
            _ => {
                return Err(data_error(
                    origin,
                    (*line > 0).then_some(*line),
                    format!("metersPerUnit is {v}; it must be a positive number"),
                ))
            }
        }
    }
    match stage.up_axis.as_ref().map(|(v, l)| (v.as_str(), *l)) {
        None | Some(("Y", _)) => {}
        // (x, y, z) -> (x, z, -y): a quarter turn about x.
        Some(("Z", _)) => m *= DMat4::from_rotation_x(-std::f64::consts::FRAC_PI_2),
        Some((v, line)) => {
            return Err(data_error(
                origin,
                (line > 0).then_some(line),
                format!("upAxis is {v:?}; USD allows \"Y\" or \"Z\""),
            ))
        }
    }
    Ok(m)
}

/// One BasisCurves prim as a groom in Kami's space (`to_kami`: its transform, its
/// parents' and the stage's). Widths scale with the transform's mean scale. A cubic prim
/// with `varying` values (one per segment end) is evaluated here, as a groom keeps values
/// per control point only.
fn curve_prim(prim: &Prim, to_kami: DMat4, origin: &str) -> Result<Groom> {
    let err = |line: usize, m: String| prim.error(origin, line, m);
    let (basis, wrap) = basis_and_wrap(prim, origin)?;
    let (counts, cline) = prim.counts.as_ref().ok_or_else(|| {
        err(
            prim.line,
            "this BasisCurves has no `curveVertexCounts`".into(),
        )
    })?;
    let (pts, pline) = prim.points.as_ref().ok_or_else(|| {
        err(
            prim.line,
            "this BasisCurves has no `point3f[] points`".into(),
        )
    })?;
    let npts = pts.len() / 3;
    let mut g = Groom {
        basis,
        wrap,
        ..Groom::default()
    };
    let (sum, varying_total) = vertex_counts(prim, origin, counts, *cline, &mut g)?;
    if sum != npts as u64 {
        return Err(err(*cline, format!("the curve vertex counts add up to {sum} points but `points` (line {pline}) has {npts}")));
    }
    // Without a transform the file's numbers are kept bit for bit (-0 stays -0).
    let moved = to_kami != DMat4::IDENTITY;
    for (i, p) in pts.chunks_exact(3).enumerate() {
        let q = if moved {
            to_kami.transform_point3(DVec3::new(p[0], p[1], p[2]))
        } else {
            DVec3::new(p[0], p[1], p[2])
        };
        let q = [q.x as f32, q.y as f32, q.z as f32];
        if q.iter().any(|v| !v.is_finite()) {
            return Err(err(*pline, format!("point {i} is not finite: {q:?}")));
        }
        g.points.push(q);
    }
    let counts = g.counts.clone();
    let fit = Fit {
        prim,
        origin,
        counts: &counts,
        npts,
        varying: varying_total as usize,
        cubic: basis != Basis::Linear,
    };
    // Widths are lengths: they scale with the transform (its mean scale).
    let scale = to_kami.determinant().abs().cbrt();
    let widths = fit
        .expand("widths", 1)?
        .map(|(w, v): Values| (w.into_iter().map(|x| x * scale).collect(), v));
    // displayColor is linear (USD's rule without a `colorSpace`); Kami's colours are sRGB.
    let colors = fit
        .expand("primvars:displayColor", 3)?
        .map(|(c, v): Values| (c.into_iter().map(super::linear_to_srgb).collect(), v));
    let opacities = fit.expand("primvars:displayOpacity", 1)?;
    let attrs = [(&widths, 1), (&opacities, 1), (&colors, 3)];
    if attrs.iter().any(|(a, _)| a.as_ref().is_some_and(|a| a.1)) {
        return Ok(super::evaluate(&g, &attrs));
    }
    let f32s = |a: &Option<(Vec<f64>, bool)>| {
        a.as_ref()
            .map(|a| a.0.iter().map(|&x| x as f32).collect::<Vec<f32>>())
    };
    g.widths = f32s(&widths);
    g.opacities = f32s(&opacities);
    g.colors = f32s(&colors).map(|c| c.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect());
    Ok(g)
}

/// A BasisCurves prim's basis and wrap from its `type`, `basis` and `wrap` tokens. USD's
/// fallbacks: cubic Bézier, open. A prim that names no type and whose counts make no
/// Bézier curves is read as linear, with a warning (the points are all there).
fn basis_and_wrap(prim: &Prim, origin: &str) -> Result<(Basis, Wrap)> {
    let err = |line: usize, m: String| prim.error(origin, line, m);
    let untyped_linear = prim.token("type").is_none()
        && prim.token("basis").is_none()
        && prim.counts.as_ref().is_some_and(|(c, _)| {
            c.iter().any(|&n| {
                n.fract() != 0.0
                    || !(0.0..=u32::MAX as f64).contains(&n)
                    || curves::segments(Basis::Bezier, Wrap::Nonperiodic, n as usize).is_none()
            })
        });
    if untyped_linear {
        log::warn!(
            "{origin}:{}: this BasisCurves names no `type` (USD's fallback is cubic Bézier) and \
             its vertex counts make no Bézier curves: read as linear",
            prim.line
        );
    }
    let fallback = if untyped_linear { "linear" } else { "cubic" };
    let (ty, tline) = prim.token("type").unwrap_or((fallback, prim.line));
    let (basis_tok, bline) = prim.token("basis").unwrap_or(("bezier", prim.line));
    let (wrap_tok, wline) = prim.token("wrap").unwrap_or(("nonperiodic", prim.line));
    let basis = match ty {
        "linear" => Basis::Linear,
        "cubic" => match basis_tok {
            "bezier" => Basis::Bezier,
            "bspline" => Basis::Bspline,
            "catmullRom" => Basis::CatmullRom,
            other => {
                return Err(err(
                    bline,
                    format!(
                        "basis {other:?} is not one Kami evaluates (bezier, bspline, catmullRom)"
                    ),
                ))
            }
        },
        other => return Err(err(tline, format!("type {other:?} is not linear or cubic"))),
    };
    let wrap = match wrap_tok {
        "nonperiodic" => Wrap::Nonperiodic,
        "periodic" => Wrap::Periodic,
        "pinned" => Wrap::Pinned,
        other => {
            return Err(err(
                wline,
                format!("wrap {other:?} is not nonperiodic, periodic or pinned"),
            ))
        }
    };
    Ok((basis, wrap))
}

/// The curve vertex counts into `g.counts`, each a whole number of 2 or more that makes a
/// curve of `g`'s basis and wrap; returns their sum and the number of segment ends (the
/// count of `varying` values).
fn vertex_counts(
    prim: &Prim,
    origin: &str,
    counts: &[f64],
    cline: usize,
    g: &mut Groom,
) -> Result<(u64, u64)> {
    let err = |line: usize, m: String| prim.error(origin, line, m);
    let (basis, wrap) = (g.basis, g.wrap);
    let mut sum = 0u64;
    let mut varying_total = 0u64;
    for (i, &c) in counts.iter().enumerate() {
        if c.fract() != 0.0 || !(2.0..=u32::MAX as f64).contains(&c) {
            return Err(err(
                cline,
                format!("curve vertex count {c} is not a whole number of 2 or more"),
            ));
        }
        let Some(segs) = curves::segments(basis, wrap, c as usize) else {
            return Err(err(
                cline,
                format!(
                    "curve {i} has {c} points, which make no {} {} curve: it needs {}",
                    wrap.token(),
                    basis.token(),
                    curves::rule(basis, wrap)
                ),
            ));
        };
        sum += c as u64;
        varying_total += curves::varying_count(wrap, basis, segs) as u64;
        g.counts.push(c as u32);
    }
    Ok((sum, varying_total))
}

/// What a curve prim's values are expanded against: its curves, its points and its
/// segment ends.
struct Fit<'a> {
    prim: &'a Prim,
    origin: &'a str,
    counts: &'a [u32],
    npts: usize,
    /// Segment ends over all curves (the count of `varying` values on cubic curves).
    varying: usize,
    cubic: bool,
}

impl Fit<'_> {
    /// Attribute `name` (tuples of `arity`, indexed through `name:indices` when there is
    /// one) per point, or per segment end (`varying` on cubic curves: the flag is set).
    fn expand(&self, name: &str, arity: usize) -> Result<Option<Values>> {
        let (prim, npts, varying, counts) = (self.prim, self.npts, self.varying, self.counts);
        let err = |line: usize, m: String| prim.error(self.origin, line, m);
        let Some((_, vals, ar, interp, line)) = prim.attr(name) else {
            return Ok(None);
        };
        let mut vals = vals.clone();
        if let Some((_, idx, 1, _, iline)) = prim.attr(&format!("{name}:indices")) {
            let n = vals.len() / arity.max(1);
            let mut out = Vec::with_capacity(idx.len().min(vals.len().max(1) * 64) * arity);
            for &k in idx {
                if k.is_nan() || k < 0.0 || k.fract() != 0.0 || k as usize >= n {
                    return Err(err(
                        *iline,
                        format!(
                            "index {k} is not a whole number in 0..{n} (the values of `{name}`)"
                        ),
                    ));
                }
                out.extend_from_slice(&vals[k as usize * arity..(k as usize + 1) * arity]);
            }
            vals = out;
        }
        if *ar != arity {
            return Err(err(
                *line,
                format!("`{name}` has tuples of {ar}, Kami expects {arity}"),
            ));
        }
        let n = vals.len() / arity;
        let mode = match interp.as_deref() {
            Some(m) => m,
            None if n == 1 => "constant",
            None if n == counts.len() => "uniform",
            None if n == npts => "vertex",
            None => "varying",
        };
        let cubic = self.cubic;
        Ok(Some(match mode {
            "constant" if n == 1 => (vals.iter().cycle().take(npts * arity).copied().collect(), false),
            "uniform" if n == counts.len() => (
                counts
                    .iter()
                    .zip(vals.chunks_exact(arity))
                    .flat_map(|(&c, v)| std::iter::repeat_n(v, c as usize).flatten().copied())
                    .collect(),
                false,
            ),
            "vertex" if n == npts => (vals, false),
            "varying" | "faceVarying" if !cubic && n == npts => (vals, false),
            "varying" | "faceVarying" if cubic && n == varying => (vals, true),
            _ => {
                return Err(err(*line, format!(
                    "`{name}` has {n} values with interpolation {mode:?}, which does not fit {} curves of {npts} points \
                     ({varying} segment ends); Kami reads constant, uniform, vertex and varying values",
                    counts.len()
                )))
            }
        }))
    }
}
