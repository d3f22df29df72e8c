//! Cem Yuksel's `.hair` (http://www.cemyuksel.com/research/hairmodels/): a 128-byte
//! little-endian header, then the arrays its flags name, in a fixed order.
//!
//! An absent array takes the header's default. Zero defaults mean "not given" (a thickness
//! of 0 is no hair, a transparency of 0 is opaque, and writers that zero the header leave
//! black): they read as `None`, which is what Kami writes for an attribute a groom lacks,
//! so a file Kami wrote reads back equal. The cost: a file whose only colour is a black
//! default reads with no colour.

use super::{data_error, Groom};
use crate::error::Result;

const HEADER: usize = 128;
const SEGMENTS: u32 = 1;
const POINTS: u32 = 2;
const THICKNESS: u32 = 4;
const TRANSPARENCY: u32 = 8;
const COLOR: u32 = 16;
/// What Kami writes in the 88-byte info field.
const INFO: &[u8] = b"written by Kami (kami convert)";

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

/// Parse a whole `.hair` file. Sizes are checked against the file's length before anything
/// is allocated, so a header that lies costs nothing.
pub fn parse(b: &[u8], origin: &str) -> Result<Groom> {
    let err = |message: String| data_error(origin, None, message);
    if b.len() < HEADER {
        return Err(err(format!(
            "{} bytes is too short for the 128-byte .hair header",
            b.len()
        )));
    }
    if &b[0..4] != b"HAIR" {
        return Err(err(format!(
            "byte 0: the magic is {:?}, not \"HAIR\"; this is not a .hair file",
            String::from_utf8_lossy(&b[0..4])
        )));
    }
    let strands = u32_at(b, 4) as u64;
    let total = u32_at(b, 8) as u64;
    let flags = u32_at(b, 12);
    let default_segments = u32_at(b, 16) as u64;
    let d_thickness = f32_at(b, 20);
    let d_transparency = f32_at(b, 24);
    let d_color = [f32_at(b, 28), f32_at(b, 32), f32_at(b, 36)];
    if flags & POINTS == 0 {
        return Err(err(
            "byte 12: the flags say there is no points array; Kami needs points".into(),
        ));
    }
    if strands == 0 {
        return Err(err("byte 4: the header says there are no strands".into()));
    }
    let has = |bit: u32| flags & bit != 0;
    // Sizes in u64: a header claiming 4 billion points cannot overflow.
    let sizes = [
        (SEGMENTS, "segments", strands * 2),
        (POINTS, "points", total * 12),
        (THICKNESS, "thickness", total * 4),
        (TRANSPARENCY, "transparency", total * 4),
        (COLOR, "colour", total * 12),
    ];
    let needed: u64 = HEADER as u64 + sizes.iter().filter(|s| has(s.0)).map(|s| s.2).sum::<u64>();
    if needed != b.len() as u64 {
        let arrays: Vec<&str> = sizes.iter().filter(|s| has(s.0)).map(|s| s.1).collect();
        return Err(err(format!(
            "the header ({strands} strands, {total} points, arrays: {}) needs {needed} bytes but the file has {}{}",
            arrays.join(", "),
            b.len(),
            if needed > b.len() as u64 { " (truncated)" } else { " (trailing bytes)" }
        )));
    }
    let mut at = HEADER;
    let counts: Vec<u32> = if has(SEGMENTS) {
        let c: Vec<u32> = (0..strands as usize)
            .map(|i| u16::from_le_bytes([b[at + 2 * i], b[at + 2 * i + 1]]) as u32 + 1)
            .collect();
        at += strands as usize * 2;
        let sum: u64 = c.iter().map(|&n| n as u64).sum();
        if sum != total {
            return Err(err(format!(
                "bytes {HEADER}..{at}: the segments array adds up to {sum} points but the header says {total}"
            )));
        }
        c
    } else {
        if default_segments == 0 || default_segments > u16::MAX as u64 {
            return Err(err(format!(
                "byte 16: there is no segments array and the default segment count is {default_segments}"
            )));
        }
        if strands * (default_segments + 1) != total {
            return Err(err(format!(
                "byte 8: {strands} strands of {default_segments} segments (the default) are {} points, but the header says {total}",
                strands * (default_segments + 1)
            )));
        }
        vec![default_segments as u32 + 1; strands as usize]
    };
    if let Some(i) = counts.iter().position(|&c| c < 2) {
        return Err(err(format!(
            "byte {}: strand {i} has 0 segments; Kami needs at least one",
            HEADER + 2 * i
        )));
    }
    let n = total as usize;
    let mut points = Vec::with_capacity(n);
    for i in 0..n {
        let o = at + 12 * i;
        let p = [f32_at(b, o), f32_at(b, o + 4), f32_at(b, o + 8)];
        if let Some(k) = p.iter().position(|v| !v.is_finite()) {
            return Err(err(format!(
                "byte {}: point {i} is not finite: {p:?}",
                o + 4 * k
            )));
        }
        points.push(p);
    }
    at += 12 * n;
    let mut floats = |bit: u32, default: f32, map: fn(f32) -> f32| -> Option<Vec<f32>> {
        if has(bit) {
            let v = (0..n).map(|i| map(f32_at(b, at + 4 * i))).collect();
            at += 4 * n;
            Some(v)
        } else if default != 0.0 {
            Some(vec![map(default); n])
        } else {
            None
        }
    };
    let widths = floats(THICKNESS, d_thickness, |t| t);
    let opacities = floats(TRANSPARENCY, d_transparency, |t| 1.0 - t);
    let colors = if has(COLOR) {
        Some(
            (0..n)
                .map(|i| {
                    let o = at + 12 * i;
                    [f32_at(b, o), f32_at(b, o + 4), f32_at(b, o + 8)]
                })
                .collect(),
        )
    } else if d_color != [0.0; 3] {
        Some(vec![d_color; n])
    } else {
        None
    };
    Ok(Groom {
        counts,
        points,
        widths,
        opacities,
        colors,
        ..Groom::default()
    })
}

/// The `.hair` bytes of a checked groom. Strands of one length use the default segment
/// count instead of a segments array; attributes the groom lacks are left out (zero
/// defaults). Opacities are stored as transparency `1 - o`: exact for opacities of 0.5 and
/// up (and any multiple of 2^-24), below that the round trip may move one in 2^24.
pub fn to_bytes(g: &Groom, origin: &str) -> Result<Vec<u8>> {
    let err = |message: String| data_error(origin, None, message);
    let strands = u32::try_from(g.counts.len()).map_err(|_| {
        err(format!(
            "{} strands do not fit a .hair file",
            g.counts.len()
        ))
    })?;
    let total = u32::try_from(g.points.len())
        .map_err(|_| err(format!("{} points do not fit a .hair file", g.points.len())))?;
    if let Some(i) = g.counts.iter().position(|&c| c > u16::MAX as u32 + 1) {
        return Err(err(format!(
            "strand {i} has {} points; .hair allows at most 65536",
            g.counts[i]
        )));
    }
    let uniform = g.counts.windows(2).all(|w| w[0] == w[1]) && !g.counts.is_empty();
    let mut flags = POINTS;
    if !uniform {
        flags |= SEGMENTS;
    }
    for (bit, on) in [
        (THICKNESS, g.widths.is_some()),
        (TRANSPARENCY, g.opacities.is_some()),
        (COLOR, g.colors.is_some()),
    ] {
        if on {
            flags |= bit;
        }
    }
    let mut b = Vec::with_capacity(HEADER + g.points.len() * 32);
    b.extend_from_slice(b"HAIR");
    for v in [
        strands,
        total,
        flags,
        if uniform { g.counts[0] - 1 } else { 0 },
    ] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for _ in 0..5 {
        b.extend_from_slice(&0f32.to_le_bytes());
    }
    let mut info = [0u8; 88];
    info[..INFO.len()].copy_from_slice(INFO);
    b.extend_from_slice(&info);
    debug_assert_eq!(b.len(), HEADER);
    if !uniform {
        for &c in &g.counts {
            b.extend_from_slice(&((c - 1) as u16).to_le_bytes());
        }
    }
    for p in &g.points {
        for v in p {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    for v in g.widths.iter().flatten() {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for v in g.opacities.iter().flatten() {
        b.extend_from_slice(&(1.0 - v).to_le_bytes());
    }
    for c in g.colors.iter().flatten() {
        for v in c {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(b)
}
