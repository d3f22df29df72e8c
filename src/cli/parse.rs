//! The value parsers the commands share (sizes, frame ranges, sample counts), and the
//! adapter preference behind every `--software`.

use kami::gpu::Preference;
use std::path::PathBuf;

pub fn parse_count(s: &str) -> Result<u32, String> {
    let n: u32 = s
        .trim()
        .replace('_', "")
        .parse()
        .map_err(|_| format!("strand count {s:?} is not a whole number"))?;
    if n == 0 || n as u64 > kami::scene::MAX_STRANDS {
        return Err(format!(
            "strand count {n} must be between 1 and {}",
            kami::scene::MAX_STRANDS
        ));
    }
    Ok(n)
}

pub fn parse_segments(s: &str) -> Result<u32, String> {
    let n: u32 = s
        .trim()
        .parse()
        .map_err(|_| format!("segment count {s:?} is not a whole number"))?;
    if n == 0 || n > kami::scene::MAX_SEGMENTS {
        return Err(format!(
            "segments per strand {n} must be between 1 and {}",
            kami::scene::MAX_SEGMENTS
        ));
    }
    Ok(n)
}

pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("size {s:?} must look like 1280x720"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in {s:?}"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in {s:?}"))?;
    if w == 0 || h == 0 || w > kami::scene::MAX_SIZE || h > kami::scene::MAX_SIZE {
        return Err(format!(
            "size {s:?} must be between 1x1 and {0}x{0}",
            kami::scene::MAX_SIZE
        ));
    }
    Ok((w, h))
}

/// "N:FILE".
pub fn parse_frame_path(s: &str) -> Result<(u64, PathBuf), String> {
    let (n, p) = s
        .split_once(':')
        .ok_or_else(|| format!("{s:?} must look like 30:shot.png"))?;
    let n: u64 = n
        .trim()
        .parse()
        .map_err(|_| format!("bad frame {n:?} in {s:?}: must look like 30:shot.png"))?;
    if p.trim().is_empty() {
        return Err(format!("no file name in {s:?}: must look like 30:shot.png"));
    }
    Ok((n, PathBuf::from(p)))
}

/// `ribbons` or `compute` (`render.strands`).
pub fn parse_strands(s: &str) -> Result<kami::scene::StrandRaster, String> {
    kami::scene::StrandRaster::parse(s)
}

/// 1 or 4: the sample counts every adapter Kami runs on supports.
pub fn parse_msaa(s: &str) -> Result<u32, String> {
    match s.trim() {
        "1" => Ok(1),
        "4" => Ok(4),
        _ => Err(format!("{s:?} is not a sample count Kami uses: use 1 or 4")),
    }
}

/// "A..B" (inclusive).
pub fn parse_frames(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("frames {s:?} must look like 0..40"))?;
    let a: u32 = a
        .trim()
        .parse()
        .map_err(|_| format!("bad first frame in {s:?}"))?;
    let b: u32 = b
        .trim()
        .trim_start_matches('=')
        .parse()
        .map_err(|_| format!("bad last frame in {s:?}"))?;
    if b < a || b > 1_000_000 {
        return Err(format!("frames {s:?}: need first <= last <= 1000000"));
    }
    Ok((a, b))
}

/// The adapter `--software` asks for.
pub fn preference(software: bool) -> Preference {
    if software {
        Preference::Software
    } else {
        Preference::Hardware
    }
}
