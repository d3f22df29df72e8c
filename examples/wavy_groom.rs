//! Writes `assets/grooms/wavy.hair`, the groom `assets/scenes/imported_groom.ron` reads: long
//! wavy hair made outside Kami's cantilever groomer, as a groom from another tool would be.
//! Each strand starts on Kami's default head ellipsoid, follows the scalp down and back a
//! little above it, leaves it below the ears and falls in waves. Deterministic (a fixed
//! hash), so running it again writes the same file:
//!
//! ```text
//! cargo run --release --example wavy_groom
//! ```

use glam::DVec3;
use std::f64::consts::PI;

/// Kami's default head (`scene::Head::default`).
const RADII: DVec3 = DVec3::new(9.6, 11.5, 7.8);

fn hash(i: u32, k: u32) -> f64 {
    let mut x = i.wrapping_mul(0x9E37_79B9) ^ k.wrapping_mul(0x85EB_CA6B);
    x ^= x >> 16;
    x = x.wrapping_mul(0x7FEB_352D);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846C_A68B);
    x ^= x >> 16;
    x as f64 / u32::MAX as f64
}

/// The head surface at zenith `t` (from +y) and azimuth `p` (from +x towards +z).
fn surface(t: f64, p: f64) -> DVec3 {
    DVec3::new(t.sin() * p.cos(), t.cos(), t.sin() * p.sin()) * RADII
}

fn main() -> anyhow::Result<()> {
    let strands = 1500u32;
    let points = 40usize;
    let mut groom = kami::formats::Groom::default();
    let mut widths = Vec::new();
    let mut colors = Vec::new();
    for i in 0..strands {
        // Roots: uniform in cos(theta) on the crown and the back, none on the face.
        let t0 = (1.0 - 0.75 * hash(i, 1)).acos().min(1.6);
        let p0 = 2.0 * PI * hash(i, 2);
        let front = p0.cos();
        if front > 0.35 && t0 > 0.75 {
            continue;
        }
        let length = 30.0 + 6.0 * (hash(i, 3) - 0.5);
        let phase = 2.0 * PI * hash(i, 4);
        let tone = 0.85 + 0.3 * hash(i, 5);
        let mut pts: Vec<DVec3> = Vec::with_capacity(points);
        for j in 0..points {
            let s = j as f64 / (points - 1) as f64 * length;
            // Over the scalp: the zenith grows with the arc run, the azimuth swept back.
            let t = (t0 + s / 11.0).min(1.95);
            let sweep = (s / 14.0).min(1.0) * 0.55 * front.max(0.0);
            let p = p0 + sweep * if p0.sin() >= 0.0 { 1.0 } else { -1.0 };
            let lift = 0.15 + 0.03 * s;
            let base = surface(t, p);
            let n = (base / (RADII * RADII)).normalize();
            let over = base + n * lift;
            // Below the scalp run, fall straight down in waves across the fall.
            let run = (1.95 - t0) * 11.0;
            let q = if s > run {
                let down = s - run;
                let side = DVec3::new(n.x, 0.0, n.z).normalize_or_zero();
                let wave = 0.9 * (down / 18.0).min(1.0) * (2.0 * PI * down / 7.0 + phase).sin();
                let end = surface(1.95, p) + n * (0.15 + 0.03 * run);
                end + DVec3::new(0.0, -down, 0.0) + side * (wave + 0.08 * down)
            } else {
                over
            };
            pts.push(q);
        }
        groom.counts.push(points as u32);
        for (j, q) in pts.iter().enumerate() {
            groom.points.push([q.x as f32, q.y as f32, q.z as f32]);
            let along = j as f32 / (points - 1) as f32;
            widths.push(0.08 * (1.0 - 0.7 * along));
            colors.push([0.36 * tone as f32, 0.22 * tone as f32, 0.12 * tone as f32]);
        }
    }
    groom.widths = Some(widths);
    groom.colors = Some(colors);
    let out = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/grooms/wavy.hair");
    std::fs::create_dir_all(out.parent().unwrap())?;
    kami::formats::write(&out, &groom)?;
    println!(
        "{}: {} strands, {} points",
        out.display(),
        groom.counts.len(),
        groom.points.len()
    );
    Ok(())
}
