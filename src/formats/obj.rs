//! Wavefront OBJ polylines: `v x y z` records and one strand per `l` record. Only points
//! travel (widths and opacities are lost); colours ride on the common `v x y z r g b`
//! extension. Faces, normals, groups and materials are skipped, so a head mesh in the same
//! file does no harm. Written by hand because tobj triangulates and drops lines.

use super::{data_error, Groom};
use crate::error::Result;
use std::fmt::Write;

/// Parse OBJ text: `l` indices are 1-based, negative ones count back from the last `v`,
/// and `v/vt` forms keep the vertex. Errors name the line.
pub fn parse(text: &str, origin: &str) -> Result<Groom> {
    let mut verts: Vec<[f32; 3]> = Vec::new();
    let mut rgb: Vec<Option<[f32; 3]>> = Vec::new();
    let mut counts = Vec::new();
    let mut points = Vec::new();
    let mut colors: Vec<Option<[f32; 3]>> = Vec::new();
    let mut lines = text.lines().enumerate();
    while let Some((i, first)) = lines.next() {
        let line = i + 1;
        let err = |m: String| data_error(origin, Some(line), m);
        // A trailing backslash continues the record on the next line.
        let mut record = first.to_string();
        while record.trim_end().ends_with('\\') {
            let t = record.trim_end().len() - 1;
            record.truncate(t);
            match lines.next() {
                Some((_, next)) => {
                    record.push(' ');
                    record.push_str(next);
                }
                None => break,
            }
        }
        let record = record.split('#').next().unwrap_or("");
        let mut words = record.split_whitespace();
        match words.next() {
            Some("v") => {
                let nums: Vec<f32> = words
                    .map(|w| {
                        w.parse::<f32>()
                            .map_err(|_| err(format!("`{w}` is not a number")))
                    })
                    .collect::<Result<_>>()?;
                if nums.len() < 3 {
                    return Err(err(format!(
                        "a `v` record needs 3 coordinates, this one has {}",
                        nums.len()
                    )));
                }
                let p = [nums[0], nums[1], nums[2]];
                if p.iter().any(|v| !v.is_finite()) {
                    return Err(err(format!(
                        "vertex {} is not finite: {p:?}",
                        verts.len() + 1
                    )));
                }
                verts.push(p);
                rgb.push((nums.len() == 6).then(|| [nums[3], nums[4], nums[5]]));
            }
            Some("l") => {
                let start = points.len();
                for w in words {
                    let idx = w.split('/').next().unwrap_or("");
                    let k: i64 = idx
                        .parse()
                        .map_err(|_| err(format!("`{w}` is not a vertex index")))?;
                    let n = verts.len() as i64;
                    let at = if k > 0 { k - 1 } else { n + k };
                    if k == 0 || at < 0 || at >= n {
                        return Err(err(format!(
                            "vertex index {k} is out of range: {n} vertices so far"
                        )));
                    }
                    points.push(verts[at as usize]);
                    colors.push(rgb[at as usize]);
                }
                let c = points.len() - start;
                if c < 2 {
                    return Err(err(format!(
                        "an `l` record needs at least 2 vertices, this one has {c}"
                    )));
                }
                counts.push(c as u32);
            }
            _ => {}
        }
    }
    if counts.is_empty() {
        return Err(data_error(
            origin,
            None,
            "no `l` records: Kami reads strands from OBJ polylines".into(),
        ));
    }
    let colors = colors
        .iter()
        .all(Option::is_some)
        .then(|| colors.into_iter().flatten().collect());
    Ok(Groom {
        counts,
        points,
        widths: None,
        opacities: None,
        colors,
        ..Groom::default()
    })
}

/// OBJ text for a checked groom: every point once, one `l` per strand. `{}` prints the
/// shortest decimal that reads back to the same f32, so points survive exactly.
pub fn to_string(g: &Groom) -> String {
    let mut s = String::with_capacity(g.points.len() * 32);
    let _ = writeln!(
        s,
        "# Kami strands: {} strands, {} points (kami convert)",
        g.counts.len(),
        g.points.len()
    );
    for (i, p) in g.points.iter().enumerate() {
        let _ = write!(s, "v {} {} {}", p[0], p[1], p[2]);
        if let Some(c) = &g.colors {
            let _ = write!(s, " {} {} {}", c[i][0], c[i][1], c[i][2]);
        }
        s.push('\n');
    }
    let mut next = 1usize;
    for &c in &g.counts {
        s.push('l');
        for k in next..next + c as usize {
            let _ = write!(s, " {k}");
        }
        s.push('\n');
        next += c as usize;
    }
    s
}
