//! The f64 reference of the compute rasteriser for thin strands
//! (`shaders/common/splat.wgsl`): the same column walk and coverage, the same accumulation,
//! in f64 and without fixed point, over nodes a kind places, sizes and shades as its kernel
//! does (`Nodes`: Anjyo's in `anjyo/splat.rs`, fur's in `fur/splat.rs`). The contract tests
//! (`tests/it/splat.rs`, `tests/it/fur.rs`) bound the GPU's worst sample against it.

use crate::gpu::gpu_data::{GpuFrame, GpuStrand};
use glam::{DMat4, DVec2, DVec3, DVec4};

/// Per sample: sum rgb a wt (3), sum a wt, sum -ln(1 - a); the GPU's words divided by
/// their fixed-point scales (`gpu::splat`).
pub type Sample = [f64; 5];

/// A node as a kind gives it (`SplatNode` in the kernel): world position, linear colour,
/// world width with the level of detail's factors, opacity.
pub struct Node {
    pub pos: DVec3,
    pub rgb: DVec3,
    pub width: f64,
    pub alpha: f64,
}

/// What a kind gives the walk, as its WGSL gives `common/splat.wgsl`.
pub trait Nodes {
    fn strands(&self) -> &[GpuStrand];
    /// Per range: first strand, one past the last drawn.
    fn drawn(&self) -> &[[u32; 2]];
    /// The node step (`splat_step`).
    fn step(&self, s: &GpuStrand) -> u32;
    /// The last node drawn (`splat_last`).
    fn last(&self, s: &GpuStrand) -> u32;
    /// Node `n` of strand `si` (`splat_node`).
    fn node(&self, si: u32, s: &GpuStrand, n: u32) -> Node;
}

/// As in the kernel.
const MAX_COVERAGE: f64 = 0.999;
const DEPTH_BIAS: f64 = 1e-5;
const MAX_ACROSS: i64 = 16;

struct ScreenNode {
    p: DVec4,
    rgb: DVec3,
    width: f64,
    alpha: f64,
}

/// Node `n` on screen under frame `f`: samples, NDC depth, width in samples.
fn to_screen(f: &GpuFrame, n: &Node) -> ScreenNode {
    let vp = DMat4::from_cols_array_2d(&f.view_proj.map(|c| c.map(|x| x as f64)));
    let c = vp * n.pos.extend(1.0);
    let ok = c.w > 1e-6;
    let w = c.w.max(1e-6);
    let ndc = c.truncate() / w;
    ScreenNode {
        p: DVec4::new(
            (ndc.x * 0.5 + 0.5) * f.viewport[0] as f64,
            (0.5 - ndc.y * 0.5) * f.viewport[1] as f64,
            ndc.z,
            if ok { 1.0 } else { 0.0 },
        ),
        rgb: n.rgb,
        width: n.width * f.raster[0] as f64 / w,
        alpha: n.alpha,
    }
}

/// Weight of a hair at NDC depth z, as the kernel's `depth_weight`.
pub fn depth_weight(z: f64) -> f64 {
    let d = (1.0 - z).clamp(1.0 / 64.0, 1.0);
    d * d * d
}

struct Target<'a> {
    size: (i64, i64),
    depth: Option<&'a [f32]>,
    out: Vec<Sample>,
}

impl Target<'_> {
    fn add(&mut self, x: i64, y: i64, a: f64, z: f64, rgb: DVec3) {
        if x < 0 || y < 0 || x >= self.size.0 || y >= self.size.1 || a <= 0.0 {
            return;
        }
        let i = (y * self.size.0 + x) as usize;
        if let Some(d) = self.depth {
            if z > d[i] as f64 + DEPTH_BIAS {
                return;
            }
        }
        let aw = a * depth_weight(z);
        let s = &mut self.out[i];
        s[0] += rgb.x * aw;
        s[1] += rgb.y * aw;
        s[2] += rgb.z * aw;
        s[3] += aw;
        s[4] += -(1.0 - a.min(MAX_COVERAGE)).ln();
    }

    fn segment(&mut self, a: &ScreenNode, b: &ScreenNode) {
        if a.p.w < 0.5 || b.p.w < 0.5 {
            return;
        }
        let d = b.p.truncate().truncate() - a.p.truncate().truncate();
        let x_major = d.x.abs() >= d.y.abs();
        let major = |p: &DVec4| {
            if x_major {
                DVec2::new(p.x, p.y)
            } else {
                DVec2::new(p.y, p.x)
            }
        };
        let (mut a, mut b, mut pa, mut pb) = (a, b, major(&a.p), major(&b.p));
        if pa.x > pb.x {
            std::mem::swap(&mut a, &mut b);
            std::mem::swap(&mut pa, &mut pb);
        }
        let run = pb.x - pa.x;
        if run <= 1e-6 {
            return;
        }
        let slope = (pb.y - pa.y) / run;
        let sec = (1.0 + slope * slope).sqrt();
        let extent = if x_major { self.size.0 } else { self.size.1 };
        let first = (pa.x.floor() as i64).max(0);
        let last = (pb.x.floor() as i64).min(extent - 1);
        for col in first..=last {
            let lo = pa.x.max(col as f64);
            let hi = pb.x.min((col + 1) as f64);
            let fx = hi - lo;
            if fx <= 0.0 {
                continue;
            }
            let t = (0.5 * (lo + hi) - pa.x) / run;
            let yc = pa.y + (pb.y - pa.y) * t;
            let half_h = 0.5 * (a.width + (b.width - a.width) * t) * sec;
            let z = a.p.z + (b.p.z - a.p.z) * t;
            let rgb = a.rgb.lerp(b.rgb, t);
            let alpha = a.alpha + (b.alpha - a.alpha) * t;
            let (y0, y1) = (yc - half_h, yc + half_h);
            let r0 = y0.floor() as i64;
            let r1 = (y1.floor() as i64).min(r0 + MAX_ACROSS - 1);
            for row in r0..=r1 {
                let cover = fx * (y1.min((row + 1) as f64) - y0.max(row as f64)) * alpha;
                if x_major {
                    self.add(col, row, cover, z, rgb);
                } else {
                    self.add(row, col, cover, z, rgb);
                }
            }
        }
    }
}

/// The accumulation the kernel writes for `nodes` under `frame`, per sample, row-major;
/// `depth` is the scene depth per sample (NDC), `None` with nothing opaque.
pub fn splat(frame: &GpuFrame, depth: Option<&[f32]>, nodes: &impl Nodes) -> Vec<Sample> {
    let size = (frame.viewport[0] as i64, frame.viewport[1] as i64);
    let mut target = Target {
        size,
        depth,
        out: vec![[0.0; 5]; (size.0 * size.1).max(0) as usize],
    };
    for (si, s) in nodes.strands().iter().enumerate() {
        let si = si as u32;
        if !nodes.drawn().iter().any(|r| si >= r[0] && si < r[1]) {
            continue;
        }
        let (step, last) = (nodes.step(s).max(1), nodes.last(s));
        let mut a = to_screen(frame, &nodes.node(si, s, 0));
        let mut n = 0;
        while n < last {
            n = (n + step).min(last);
            let b = to_screen(frame, &nodes.node(si, s, n));
            target.segment(&a, &b);
            a = b;
        }
    }
    target.out
}

/// The resolve's composite of one sample over the scene colour (linear rgb).
pub fn composite(s: &Sample, scene: DVec3) -> DVec3 {
    if s[3] <= 0.0 {
        return scene;
    }
    let t = (-s[4]).exp();
    DVec3::new(s[0], s[1], s[2]) / s[3] * (1.0 - t) + scene * t
}
