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
    let strands = 1700u32;
    let points = 16usize;
    let mut groom = kami::formats::Groom::default();
    let mut widths = Vec::new();
    for i in 0..strands {
        // Roots: uniform in cos(theta) over the crown, the sides and the back.
        let t0 = (1.0 - 1.15 * hash(i, 1)).acos();
        let p0 = PI * (2.0 * hash(i, 2) - 1.0);
        // A hairline: none on the forehead below 40 degrees or the temples below 65.
        if p0.cos() > 0.0 && t0 > (40f64.to_radians() + 25f64.to_radians() * (1.0 - p0.cos())) {
            continue;
        }
        let length = 30.0 + 6.0 * (hash(i, 3) - 0.5);
        let phase = 2.0 * PI * hash(i, 4);
        // Over the scalp from the root to an exit below the ears, parted in the middle and
        // combed back: the exit azimuth moves towards the back, more for roots at the front.
        let side = if p0 >= 0.0 { 1.0 } else { -1.0 };
        let pe = p0 + (side * PI - p0) * (0.08 + 0.4 * p0.cos().max(0.0));
        let te = 1.95;
        let (r0, re) = (surface(t0, p0), surface(te, pe));
        let run = 1.15 * (re - r0).length();
        let mut pts: Vec<DVec3> = Vec::with_capacity(points);
        for j in 0..points {
            let s = j as f64 / (points - 1) as f64 * length;
            let q = if s <= run {
                let u = s / run;
                let (t, p) = (t0 + (te - t0) * u, p0 + (pe - p0) * u);
                let base = surface(t, p);
                let n = (base / (RADII * RADII)).normalize();
                base + n * (0.15 + 0.6 * u)
            } else {
                // Below the scalp run, fall straight down in waves across the fall.
                let down = s - run;
                let n = (re / (RADII * RADII)).normalize();
                let out = DVec3::new(n.x, 0.0, n.z).normalize_or_zero();
                let across = DVec3::Y.cross(out);
                let wave = 1.1 * (down / 10.0).min(1.0) * (2.0 * PI * down / 8.0 + phase).sin();
                re + n * 0.75 + DVec3::new(0.0, -down, 0.0) + across * wave + out * (0.1 * down)
            };
            pts.push(q);
        }
        groom.counts.push(points as u32);
        for (j, q) in pts.iter().enumerate() {
            groom.points.push([q.x as f32, q.y as f32, q.z as f32]);
            let along = j as f32 / (points - 1) as f32;
            widths.push(0.09 * (1.0 - 0.6 * along));
        }
    }
    groom.widths = Some(widths);
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
