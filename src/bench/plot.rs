//! Log–log line plots as PNG for the benchmark reports, with a built-in 5x7 bitmap font:
//! a plotting crate would bring a font stack and a rasteriser for one chart.

use image::{Rgba, RgbaImage};

/// One line of a plot.
pub struct Series {
    pub name: String,
    pub color: [u8; 3],
    pub points: Vec<(f64, f64)>,
}

/// A distinct colour per series index.
pub fn palette(i: usize) -> [u8; 3] {
    const P: [[u8; 3]; 10] = [
        [31, 119, 180],
        [255, 127, 14],
        [44, 160, 44],
        [214, 39, 40],
        [148, 103, 189],
        [140, 86, 75],
        [227, 119, 194],
        [23, 190, 207],
        [188, 189, 34],
        [60, 60, 60],
    ];
    P[i % P.len()]
}

const W: u32 = 960;
const H: u32 = 640;
const LEFT: i32 = 110;
const RIGHT: i32 = 300;
const TOP: i32 = 64;
const BOTTOM: i32 = 70;
const SCALE: i32 = 2;

/// Plot `series` with logarithmic axes; `hline` draws a dashed reference line (y, label).
pub fn loglog(
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
    hline: Option<(f64, &str)>,
) -> RgbaImage {
    let mut img = RgbaImage::from_pixel(W, H, Rgba([255, 255, 255, 255]));
    let pts: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().cloned())
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .collect();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in &pts {
        x0 = x0.min(x.log10());
        x1 = x1.max(x.log10());
        y0 = y0.min(y.log10());
        y1 = y1.max(y.log10());
    }
    if let Some((y, _)) = hline {
        y0 = y0.min(y.log10());
        y1 = y1.max(y.log10());
    }
    if pts.is_empty() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let (x0, x1) = (x0.floor(), x1.ceil().max(x0.floor() + 1.0));
    let (y0, y1) = (y0.floor(), y1.ceil().max(y0.floor() + 1.0));
    let (pw, ph) = (W as i32 - LEFT - RIGHT, H as i32 - TOP - BOTTOM);
    let map = |x: f64, y: f64| -> (i32, i32) {
        let px = LEFT + ((x.log10() - x0) / (x1 - x0) * pw as f64).round() as i32;
        let py = TOP + ph - ((y.log10() - y0) / (y1 - y0) * ph as f64).round() as i32;
        (px, py)
    };
    let grey = Rgba([225, 225, 225, 255]);
    let black = Rgba([30, 30, 30, 255]);
    // Decade grid and labels.
    for d in x0 as i32..=x1 as i32 {
        let (px, _) = map(10f64.powi(d), 1.0);
        line(&mut img, (px, TOP), (px, TOP + ph), grey, 1);
        let label = format!("1E{d}");
        text(
            &mut img,
            px - text_width(&label) / 2,
            TOP + ph + 10,
            &label,
            black,
        );
    }
    for d in y0 as i32..=y1 as i32 {
        let (_, py) = map(1.0, 10f64.powi(d));
        line(&mut img, (LEFT, py), (LEFT + pw, py), grey, 1);
        let label = format!("1E{d}");
        text(
            &mut img,
            LEFT - 10 - text_width(&label),
            py - 7,
            &label,
            black,
        );
    }
    line(&mut img, (LEFT, TOP), (LEFT, TOP + ph), black, 1);
    line(&mut img, (LEFT, TOP + ph), (LEFT + pw, TOP + ph), black, 1);
    text(
        &mut img,
        LEFT + pw / 2 - text_width(title) / 2,
        8,
        title,
        black,
    );
    text(
        &mut img,
        LEFT + pw / 2 - text_width(xlabel) / 2,
        TOP + ph + 40,
        xlabel,
        black,
    );
    text(&mut img, 8, TOP - 26, ylabel, black);
    if let Some((y, label)) = hline {
        let (_, py) = map(1.0, y);
        let mut x = LEFT;
        while x < LEFT + pw {
            line(
                &mut img,
                (x, py),
                ((x + 8).min(LEFT + pw), py),
                Rgba([120, 120, 120, 255]),
                1,
            );
            x += 14;
        }
        text(
            &mut img,
            LEFT + pw - text_width(label) - 4,
            py - 18,
            label,
            Rgba([90, 90, 90, 255]),
        );
    }
    for (i, s) in series.iter().enumerate() {
        let c = Rgba([s.color[0], s.color[1], s.color[2], 255]);
        let p: Vec<(i32, i32)> = s
            .points
            .iter()
            .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
            .map(|(x, y)| map(*x, *y))
            .collect();
        for w in p.windows(2) {
            line(&mut img, w[0], w[1], c, 2);
        }
        for q in &p {
            fill(&mut img, q.0 - 3, q.1 - 3, 7, 7, c);
        }
        let ly = TOP + 10 + i as i32 * 24;
        let lx = LEFT + pw + 20;
        line(&mut img, (lx, ly + 7), (lx + 24, ly + 7), c, 3);
        text(&mut img, lx + 32, ly, &s.name, black);
    }
    img
}

fn put(img: &mut RgbaImage, x: i32, y: i32, c: Rgba<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

fn fill(img: &mut RgbaImage, x: i32, y: i32, w: i32, h: i32, c: Rgba<u8>) {
    for j in y..y + h {
        for i in x..x + w {
            put(img, i, j, c);
        }
    }
}

/// Bresenham line of thickness `t`.
fn line(img: &mut RgbaImage, a: (i32, i32), b: (i32, i32), c: Rgba<u8>, t: i32) {
    let (mut x, mut y) = a;
    let (dx, dy) = ((b.0 - a.0).abs(), -(b.1 - a.1).abs());
    let (sx, sy) = (
        if a.0 < b.0 { 1 } else { -1 },
        if a.1 < b.1 { 1 } else { -1 },
    );
    let mut err = dx + dy;
    loop {
        fill(img, x - t / 2, y - t / 2, t, t, c);
        if (x, y) == b {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

fn text_width(s: &str) -> i32 {
    s.chars().count() as i32 * 6 * SCALE
}

/// Draw `s` with its top-left at (x, y), 5x7 glyphs at `SCALE`.
fn text(img: &mut RgbaImage, x: i32, y: i32, s: &str, c: Rgba<u8>) {
    for (i, ch) in s.chars().enumerate() {
        let rows = glyph(ch);
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..5 {
                if bits & (0x10 >> col) != 0 {
                    fill(
                        img,
                        x + (i as i32 * 6 + col) * SCALE,
                        y + r as i32 * SCALE,
                        SCALE,
                        SCALE,
                        c,
                    );
                }
            }
        }
    }
}

fn glyph(c: char) -> [u8; 7] {
    match c.to_ascii_uppercase() {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'A' => [0x0E, 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11],
        'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' | 'Μ' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
        'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
        '.' => [0, 0, 0, 0, 0, 0x0C, 0x0C],
        '-' => [0, 0, 0, 0x1F, 0, 0, 0],
        '+' => [0, 0x04, 0x04, 0x1F, 0x04, 0x04, 0],
        '/' => [0, 0x01, 0x02, 0x04, 0x08, 0x10, 0],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        ':' => [0, 0x0C, 0x0C, 0, 0x0C, 0x0C, 0],
        ',' => [0, 0, 0, 0, 0x0C, 0x04, 0x08],
        '=' => [0, 0, 0x1F, 0, 0x1F, 0, 0],
        '_' => [0, 0, 0, 0, 0, 0, 0x1F],
        '^' => [0x04, 0x0A, 0x11, 0, 0, 0, 0],
        _ => [0; 7],
    }
}
