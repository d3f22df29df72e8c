//! USD `BasisCurves` in text form (`.usda`). The writer makes one linear `BasisCurves` prim
//! with vertex widths, and `primvars:displayColor` / `primvars:displayOpacity` when the groom
//! has them. The reader takes that and what Blender and Houdini usually export:
//!
//! - every `def BasisCurves` prim, at any depth, concatenated in file order;
//! - linear and cubic curves; cubic (bezier, bspline, catmullRom) keep their control points
//!   as the polyline, which is not the curve the basis describes;
//! - widths and the two primvars as constant, uniform or vertex values (also indexed ones),
//!   expanded per point; an attribute missing from one prim is dropped from all;
//! - `timeSamples`: the first sample.
//!
//! Lost: transforms (`xformOp:*` on the prim or its parents), periodic wrap (read open),
//! normals, other primvars, variants, references and sublayers. Binary `.usd`/`.usdc` is not
//! read.

use super::{data_error, Groom};
use crate::error::Result;
use std::fmt::Write;

/// usda text for a checked groom.
pub fn to_string(g: &Groom) -> String {
    let mut s = String::with_capacity(g.points.len() * 48);
    s.push_str("#usda 1.0\n(\n    defaultPrim = \"hair\"\n    doc = \"Kami strands (kami convert)\"\n)\n\n");
    s.push_str("def BasisCurves \"hair\"\n{\n");
    s.push_str("    uniform token type = \"linear\"\n");
    s.push_str("    uniform token wrap = \"nonperiodic\"\n");
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
#[derive(Debug)]
enum Value {
    Nums {
        v: Vec<f64>,
        arity: usize,
        array: bool,
    },
    Text,
    Other,
}

struct Parser<'a> {
    toks: Vec<(Tok, usize)>,
    at: usize,
    origin: &'a str,
    /// Nesting of prims and values now: bounded, so a hostile file is an error, not a
    /// stack overflow.
    depth: usize,
}

/// Deepest nesting of prims or values read (real files nest a handful of levels).
const MAX_DEPTH: usize = 128;

/// A numeric attribute: name, values (flattened), tuple size, interpolation, line.
type Attr = (String, Vec<f64>, usize, Option<String>, usize);

#[derive(Default)]
struct Prim {
    line: usize,
    counts: Option<(Vec<f64>, usize)>,
    points: Option<(Vec<f64>, usize)>,
    /// Every other numeric attribute, in file order.
    attrs: Vec<Attr>,
}

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
    /// `( ... )` metadata: returns its `interpolation`, if any.
    fn metadata(&mut self) -> Result<Option<String>> {
        let start = self.at;
        self.skip_group()?;
        let mut interp = None;
        for w in self.toks[start..self.at].windows(3) {
            if let (Tok::Word(k), Tok::Punct('='), Tok::Str(v)) = (&w[0].0, &w[1].0, &w[2].0) {
                if k == "interpolation" {
                    interp = Some(v.clone());
                }
            }
        }
        Ok(interp)
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
            Tok::Str(_) => Ok(Value::Text),
            Tok::Word(w) => Ok(match num(&w) {
                Some(x) => Value::Nums {
                    v: vec![x],
                    arity: 1,
                    array: false,
                },
                None => Value::Text,
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
                // timeSamples: `{ time: value, ... }`; the first sample stands for all.
                let start = self.at - 1;
                let is_samples = matches!(self.peek(), Some(Tok::Word(w)) if num(w).is_some())
                    && matches!(self.toks.get(self.at + 1), Some((Tok::Punct(':'), _)));
                if is_samples {
                    self.at += 2;
                    let first = self.value()?;
                    self.at = start;
                    self.skip_group()?;
                    return Ok(first);
                }
                self.at = start;
                self.skip_group()?;
                Ok(Value::Other)
            }
            t => {
                self.at -= 1;
                Err(self.err(format!("expected a value, found {}", show(&t))))
            }
        }
    }

    /// A tuple of numbers; `None` (skipped) for anything else, such as the rows of a
    /// `matrix4d xformOp:transform`, which Kami does not use.
    fn tuple(&mut self) -> Result<Option<Vec<f64>>> {
        let start = self.at;
        self.expect('(')?;
        let mut v = Vec::new();
        loop {
            match self.bump()? {
                Tok::Punct(')') => return Ok(Some(v)),
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

    /// Statements up to a closing `}` (or the end, at the top), collecting BasisCurves.
    fn block(
        &mut self,
        prim: &mut Option<&mut Prim>,
        out: &mut Vec<Prim>,
        top: bool,
    ) -> Result<()> {
        self.enter()?;
        let r = self.block_in(prim, out, top);
        self.depth -= 1;
        r
    }

    fn block_in(
        &mut self,
        prim: &mut Option<&mut Prim>,
        out: &mut Vec<Prim>,
        top: bool,
    ) -> Result<()> {
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
                    self.metadata()?;
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
                    if self.peek() == Some(&Tok::Punct('(')) {
                        self.metadata()?;
                    }
                    self.expect('{')?;
                    let curves = w == "def" && kind.as_deref() == Some("BasisCurves");
                    let mut p = Prim {
                        line,
                        ..Prim::default()
                    };
                    if curves {
                        self.block(&mut Some(&mut p), out, false)?;
                        out.push(p);
                    } else {
                        self.block(&mut None, out, false)?;
                    }
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
                        self.metadata()?
                    } else {
                        None
                    };
                    if let (Some(p), Some(v)) = (prim.as_deref_mut(), value) {
                        p.set(&name, v, interp, line);
                    }
                }
                Tok::Punct(';') => self.at += 1,
                t => return Err(self.err(format!("unexpected {}", show(&t)))),
            }
        }
    }
}

impl Prim {
    fn set(&mut self, name: &str, v: Value, interp: Option<String>, line: usize) {
        let name = name.strip_suffix(".timeSamples").unwrap_or(name);
        match (name, v) {
            ("type" | "basis" | "wrap", Value::Text) => {}
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

    fn attr(&self, name: &str) -> Option<&Attr> {
        self.attrs.iter().rev().find(|a| a.0 == name)
    }
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
    let first = text.lines().next().unwrap_or("");
    if !first.starts_with("#usda ") {
        return Err(data_error(
            origin,
            Some(1),
            "the first line is not `#usda 1.0`; Kami reads text USD (.usda) only".into(),
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
    };
    let mut prims = Vec::new();
    p.block(&mut None, &mut prims, true)?;
    if prims.is_empty() {
        return Err(data_error(
            origin,
            None,
            "no `def BasisCurves` prim: no strands in this file".into(),
        ));
    }
    let mut g = Groom::default();
    let mut widths = Some(Vec::new());
    let mut colors = Some(Vec::new());
    let mut opacities = Some(Vec::new());
    for prim in &prims {
        let err = |line: usize, m: String| data_error(origin, Some(line), m);
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
        let mut sum = 0u64;
        let first = g.counts.len();
        for &c in counts {
            if c.fract() != 0.0 || !(2.0..=u32::MAX as f64).contains(&c) {
                return Err(err(
                    *cline,
                    format!("curve vertex count {c} is not a whole number of 2 or more"),
                ));
            }
            sum += c as u64;
            g.counts.push(c as u32);
        }
        if sum != npts as u64 {
            return Err(err(*cline, format!("the curve vertex counts add up to {sum} points but `points` (line {pline}) has {npts}")));
        }
        for (i, p) in pts.chunks_exact(3).enumerate() {
            let q = [p[0] as f32, p[1] as f32, p[2] as f32];
            if q.iter().any(|v| !v.is_finite()) {
                return Err(err(*pline, format!("point {i} is not finite: {q:?}")));
            }
            g.points.push(q);
        }
        let counts = &g.counts[first..];
        let expand = |name: &str, arity: usize| -> Result<Option<Vec<f32>>> {
            let Some((_, vals, ar, interp, line)) = prim.attr(name) else {
                return Ok(None);
            };
            let mut vals = vals.clone();
            if let Some((_, idx, 1, _, iline)) = prim.attr(&format!("{name}:indices")) {
                let n = vals.len() / arity.max(1);
                let mut out = Vec::with_capacity(idx.len() * arity);
                for &k in idx {
                    if k.is_nan() || k < 0.0 || k.fract() != 0.0 || k as usize >= n {
                        return Err(err(
                            *iline,
                            format!("index {k} is not a whole number in 0..{n} (the values of `{name}`)"),
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
                None => "vertex",
            };
            let per_point: Vec<f64> = match mode {
                "constant" if n == 1 => vals.iter().cycle().take(npts * arity).copied().collect(),
                "uniform" if n == counts.len() => counts
                    .iter()
                    .zip(vals.chunks_exact(arity))
                    .flat_map(|(&c, v)| std::iter::repeat_n(v, c as usize).flatten().copied())
                    .collect(),
                "vertex" | "varying" | "faceVarying" if n == npts => vals,
                _ => {
                    return Err(err(*line, format!(
                        "`{name}` has {n} values with interpolation {mode:?}, which does not fit {} curves of {npts} points \
                         (Kami reads constant, uniform and per-point values)",
                        counts.len()
                    )))
                }
            };
            Ok(Some(per_point.into_iter().map(|x| x as f32).collect()))
        };
        let w = expand("widths", 1)?;
        let c = expand("primvars:displayColor", 3)?;
        let o = expand("primvars:displayOpacity", 1)?;
        let join = |acc: &mut Option<Vec<f32>>, v: Option<Vec<f32>>| match (acc.as_mut(), v) {
            (Some(a), Some(v)) => a.extend(v),
            _ => *acc = None,
        };
        join(&mut widths, w);
        join(&mut opacities, o);
        let mut flat = colors
            .take()
            .map(|c: Vec<[f32; 3]>| c.into_iter().flatten().collect::<Vec<f32>>());
        join(&mut flat, c);
        colors = flat.map(|f| f.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect());
    }
    g.widths = widths;
    g.opacities = opacities;
    g.colors = colors;
    Ok(g)
}
