//! The look measured on the hair's own pixels. The background fills half or more of most
//! frames and matches the reference exactly, so a mean over the whole image hides most of
//! the difference. The mask here is every pixel where either image differs from the
//! background by more than [`MASK_LEVELS`] 8-bit levels in some channel (hair or head). The
//! FLIP maps come from `scripts/look_reference.py` (`--maps`). Also here: how well the two
//! silhouettes agree, and the masks panel added to each image pair.

use crate::error::{KamiError, Result};
use image::{Rgb, RgbImage, RgbaImage};
use std::path::Path;

/// A pixel belongs to the hair (or head) where it differs from the background by more than
/// this many 8-bit levels in some channel. 2 covers the sRGB round trip of the background.
pub const MASK_LEVELS: u8 = 2;

/// The figures over the hair's pixels of one row.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HairStats {
    /// Mean FLIP of Kami against the reference over the union of both images' masks.
    pub flip_hair: f64,
    /// The same between the reference's two seeds, over the union of their masks.
    pub noise_hair: f64,
    /// Intersection over union of Kami's mask and the reference's (seed 0).
    pub overlap: f64,
    /// Share of the frame that the union of Kami's and the reference's masks covers.
    pub share: f64,
}

/// The background as an 8-bit sRGB pixel (`render.background` is sRGB in 0..1).
pub fn background8(bg: [f32; 3]) -> [u8; 3] {
    bg.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
}

/// The pixels of `img` that differ from `bg`.
pub fn mask(img: &RgbImage, bg: [u8; 3]) -> Vec<bool> {
    img.pixels()
        .map(|p| (0..3).any(|c| p[c].abs_diff(bg[c]) > MASK_LEVELS))
        .collect()
}

fn masked_mean(map: &[f32], m: &[bool]) -> f64 {
    let (mut s, mut n) = (0.0f64, 0usize);
    for (v, _) in map.iter().zip(m).filter(|(_, &k)| k) {
        s += f64::from(*v);
        n += 1;
    }
    if n == 0 {
        0.0
    } else {
        s / n as f64
    }
}

/// The hair figures of Kami's image against the reference's two seeds, given the FLIP maps
/// (Kami against seed 0, and seed 1 against seed 0). Fails if the sizes disagree or if
/// nothing differs from the background (no hair pixels to measure).
pub fn hair_stats(
    kami: &RgbImage,
    refs: [&RgbImage; 2],
    flip: &[f32],
    noise: &[f32],
    bg: [u8; 3],
) -> std::result::Result<HairStats, String> {
    let n = (kami.width() * kami.height()) as usize;
    for (what, (w, h)) in [
        ("seed 0", refs[0].dimensions()),
        ("seed 1", refs[1].dimensions()),
    ] {
        if (w, h) != kami.dimensions() {
            return Err(format!(
                "the reference's {what} is {w}x{h}, Kami's image {}x{}",
                kami.width(),
                kami.height()
            ));
        }
    }
    if flip.len() != n || noise.len() != n {
        return Err(format!(
            "the FLIP maps hold {} and {} values for {n} pixels",
            flip.len(),
            noise.len()
        ));
    }
    let (km, r0, r1) = (mask(kami, bg), mask(refs[0], bg), mask(refs[1], bg));
    let union: Vec<bool> = km.iter().zip(&r0).map(|(a, b)| *a || *b).collect();
    let both = km.iter().zip(&r0).filter(|(a, b)| **a && **b).count();
    let any = union.iter().filter(|&&k| k).count();
    if any == 0 {
        return Err("neither image differs from the background: no hair pixels to compare".into());
    }
    let refs_union: Vec<bool> = r0.iter().zip(&r1).map(|(a, b)| *a || *b).collect();
    Ok(HairStats {
        flip_hair: masked_mean(flip, &union),
        noise_hair: masked_mean(noise, &refs_union),
        overlap: both as f64 / any as f64,
        share: any as f64 / n as f64,
    })
}

/// Grey where both masks hold, red where only Kami's does, blue where only the reference's
/// does, black elsewhere.
pub fn masks_panel(kami: &RgbImage, reference: &RgbImage, bg: [u8; 3]) -> RgbImage {
    let (km, rm) = (mask(kami, bg), mask(reference, bg));
    let mut out = RgbImage::new(kami.width(), kami.height());
    for (i, p) in out.pixels_mut().enumerate() {
        *p = match (km[i], rm[i]) {
            (true, true) => Rgb([160, 160, 160]),
            (true, false) => Rgb([230, 60, 40]),
            (false, true) => Rgb([60, 110, 240]),
            (false, false) => Rgb([0, 0, 0]),
        };
    }
    out
}

fn bad(path: &Path, message: String) -> KamiError {
    KamiError::Data {
        path: path.display().to_string(),
        line: None,
        message,
    }
}

fn read_png(path: &Path) -> Result<RgbImage> {
    Ok(image::open(path)
        .map_err(|e| KamiError::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?
        .to_rgb8())
}

fn read_f32(path: &Path, n: usize) -> Result<Vec<f32>> {
    let bytes = std::fs::read(path).map_err(|source| KamiError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    if bytes.len() != 4 * n {
        return Err(bad(
            path,
            format!("{} bytes, but {n} pixels need {}", bytes.len(), 4 * n),
        ));
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}

/// Read what the script wrote into `maps`, measure the hair figures of `kami`, and add the
/// masks panel to the pair image at `pair` (Kami | Mitsuba | FLIP map | masks).
pub fn measure(kami: &RgbaImage, maps: &Path, pair: &Path, bg: [f32; 3]) -> Result<HairStats> {
    let kami = image::DynamicImage::ImageRgba8(kami.clone()).to_rgb8();
    let n = (kami.width() * kami.height()) as usize;
    let r0 = read_png(&maps.join("reference0.png"))?;
    let r1 = read_png(&maps.join("reference1.png"))?;
    let flip = read_f32(&maps.join("flip.f32"), n)?;
    let noise = read_f32(&maps.join("noise.f32"), n)?;
    let bg8 = background8(bg);
    let stats = hair_stats(&kami, [&r0, &r1], &flip, &noise, bg8).map_err(|m| bad(maps, m))?;
    let old = read_png(pair)?;
    let panel = masks_panel(&kami, &r0, bg8);
    let mut out =
        RgbImage::from_pixel(old.width() + 4 + panel.width(), old.height(), Rgb([255; 3]));
    image::imageops::replace(&mut out, &old, 0, 0);
    image::imageops::replace(&mut out, &panel, i64::from(old.width()) + 4, 0);
    out.save(pair).map_err(|e| KamiError::Image {
        path: pair.to_path_buf(),
        message: e.to_string(),
    })?;
    Ok(stats)
}
