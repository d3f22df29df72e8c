//! The f64 reference of the compute rasteriser for thin strands
//! (`shaders/anjyo/splat.wgsl` with `shaders/common/strand_shade.wgsl`): the same node shading,
//! the same column walk and coverage, the same accumulation, in f64 and without fixed
//! point. The contract test (`tests/it/splat.rs`) bounds the GPU's worst sample against it.

use super::gpu_data::{GpuLook, GpuMaterial};
use crate::gpu::gpu_data::{GpuFrame, GpuStrand};
use crate::systems::hair_bsdf;
use glam::{DMat4, DVec2, DVec3, DVec4};

/// Per sample: sum rgb a wt (3), sum a wt, sum -ln(1 - a); the GPU's words divided by
/// their fixed-point scales (`stage::splat`).
pub type Sample = [f64; 5];

/// Everything the kernel reads.
pub struct Input<'a> {
    pub frame: &'a GpuFrame,
    pub strands: &'a [GpuStrand],
    pub verts: &'a [[f32; 4]],
    pub materials: &'a [GpuMaterial],
    /// Per node, a strand file's own look (read where a material's `file` flags say).
    pub looks: &'a [GpuLook],
    /// x width factor, y node step (`StrandsPass::prepare`).
    pub lod: [f32; 4],
    /// Per range: first strand, one past the last drawn.
    pub drawn: &'a [[u32; 2]],
    /// The scene depth per sample (NDC), row-major; `None`: nothing opaque.
    pub depth: Option<&'a [f32]>,
}

/// As in the kernel.
const MAX_COVERAGE: f64 = 0.999;
const DEPTH_BIAS: f64 = 1e-5;
const MAX_ACROSS: i64 = 16;

struct Node {
    pos: DVec3,
    rgb: DVec3,
    width: f64,
    alpha: f64,
}

struct ScreenNode {
    p: DVec4,
    rgb: DVec3,
    width: f64,
    alpha: f64,
}

/// sRGB to linear, as the shader's `srgb_to_linear`.
fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn v3(v: [f32; 4]) -> DVec3 {
    DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

impl Input<'_> {
    fn step(&self) -> u32 {
        (self.lod[1] as u32).max(1)
    }

    fn node_pos(&self, s: &GpuStrand, i: u32) -> DVec3 {
        let p = v3(self.verts[(s.first_vertex + i) as usize]);
        let over = i as f64 - s.visible as f64;
        if over > 0.0 && i > 0 {
            let q = v3(self.verts[(s.first_vertex + i - 1) as usize]);
            return p.lerp(q, over.clamp(0.0, 1.0));
        }
        p
    }

    fn last(s: &GpuStrand) -> u32 {
        (s.visible as f64).ceil() as u32
    }

    fn shade(&self, s: &GpuStrand, n: u32) -> Node {
        let f = self.frame;
        let step = self.step();
        let last = Self::last(s);
        let mat = &self.materials[s.group as usize];
        let p = self.node_pos(s, n);
        let t = if last == 0 {
            v3(self.verts[(s.first_vertex + 1) as usize]) - p
        } else if n == 0 {
            self.node_pos(s, step.min(last)) - p
        } else if n == last {
            p - self.node_pos(s, ((n - 1) / step) * step)
        } else {
            self.node_pos(s, (n + step).min(last)) - self.node_pos(s, n - step)
        };
        let tl = t.length();
        let t = if tl > 1e-20 { t / tl } else { DVec3::NEG_Y };
        let along = n as f64 / s.segments.max(1) as f64;
        let tip = mat.params[3] as f64;
        let mut width = mat.params[2] as f64 * (1.0 + (tip - 1.0) * along);
        let mut base = v3(mat.color_ks);
        let mut alpha = 1.0;
        if mat.file[..3].iter().any(|&x| x > 0.5) {
            let look = self.looks[(s.first_vertex + n) as usize];
            let c = look.rgba();
            if mat.file[0] > 0.5 {
                base = DVec3::new(
                    srgb_to_linear(c[0]),
                    srgb_to_linear(c[1]),
                    srgb_to_linear(c[2]),
                );
            }
            if mat.file[1] > 0.5 {
                width = f32::from_bits(look.width) as f64;
            }
            if mat.file[2] > 0.5 {
                alpha = c[3];
            }
        }
        let width = width * f.raster[2] as f64 * self.lod[0] as f64;
        let l = v3(f.light_dir);
        let v = (v3(f.eye) - p).normalize();
        let h = (l + v).normalize();
        let th = t.dot(h);
        let spec =
            mat.color_ks[3] as f64 * (1.0 - th * th).max(0.0).powf(0.5 * mat.params[0] as f64);
        let tdl = t.dot(l);
        let diffuse = mat.params[1] as f64 * (1.0 - tdl * tdl).max(0.0).sqrt();
        let ambient = f.light_color[3] as f64 * s.ka as f64;
        let intensity = f.light_dir[3] as f64;
        let mut rgb =
            base * (ambient + intensity * diffuse) + v3(f.light_color) * (intensity * spec);
        if mat.bsdf.physical() {
            // The physical mode, with the shadow structure's stub values (no strands in the
            // way, lit).
            let (b, d) = mat.bsdf.reference();
            let a = hair_bsdf::Angles::new(v.to_array(), l.to_array(), t.to_array());
            let s = hair_bsdf::dual_radiance(&b, &d, &a, 0.0);
            let amb = mat.bsdf.ambient;
            rgb = v3(f.light_color) * (std::f64::consts::PI * intensity) * DVec3::from_array(s)
                + DVec3::new(amb[0] as f64, amb[1] as f64, amb[2] as f64) * ambient;
        }
        if f.flags[0] > 0.5 && self.verts[(s.first_vertex + n) as usize][3] > 1.5 {
            rgb = DVec3::new(0.9, 0.1, 0.05);
        }
        Node {
            pos: p,
            rgb,
            width,
            alpha,
        }
    }

    fn to_screen(&self, n: &Node) -> ScreenNode {
        let f = self.frame;
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
}

fn depth_weight(z: f64) -> f64 {
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

/// The accumulation the kernel writes for `input`, per sample, row-major.
pub fn splat(input: &Input) -> Vec<Sample> {
    let size = (
        input.frame.viewport[0] as i64,
        input.frame.viewport[1] as i64,
    );
    let mut target = Target {
        size,
        depth: input.depth,
        out: vec![[0.0; 5]; (size.0 * size.1).max(0) as usize],
    };
    let step = input.step();
    for (si, s) in input.strands.iter().enumerate() {
        let si = si as u32;
        if !input.drawn.iter().any(|r| si >= r[0] && si < r[1]) {
            continue;
        }
        let last = Input::last(s);
        let mut a = input.to_screen(&input.shade(s, 0));
        let mut n = 0;
        while n < last {
            n = (n + step).min(last);
            let b = input.to_screen(&input.shade(s, n));
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

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(size: (f32, f32)) -> GpuFrame {
        // An orthographic-like view: clip = (x / 10, y / 10, 0.5, 1) maps [-10, 10]^2 to
        // the image.
        let mut f: GpuFrame = bytemuck::Zeroable::zeroed();
        f.view_proj = [
            [0.1, 0.0, 0.0, 0.0],
            [0.0, 0.1, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.5, 1.0],
        ];
        f.eye = [0.0, 0.0, 10.0, 1.0];
        f.light_dir = [0.0, 0.0, 1.0, 1.0];
        f.light_color = [1.0, 1.0, 1.0, 1.0];
        f.viewport = [size.0, size.1, 1.0 / size.0, 1.0 / size.1];
        // Focal length 1 sample per world unit at w = 1: widths are in samples * 1.
        f.raster = [1.0, 1.0, 1.0, 1.0];
        f
    }

    fn one_strand(
        from: [f32; 2],
        to: [f32; 2],
        width: f32,
    ) -> (GpuStrand, Vec<[f32; 4]>, GpuMaterial) {
        let mut s: GpuStrand = bytemuck::Zeroable::zeroed();
        s.segments = 1;
        s.visible = 1.0;
        s.ka = 1.0;
        let verts = vec![[from[0], from[1], 0.0, 1.0], [to[0], to[1], 0.0, 1.0]];
        let m = GpuMaterial {
            color_ks: [0.5, 0.25, 0.125, 0.0],
            params: [1.0, 0.0, width, 1.0],
            file: [0.0; 4],
            bsdf: Default::default(),
        };
        (s, verts, m)
    }

    /// A strand's coverages add up to its length times its width (in samples), whatever
    /// its slope, so thin hair keeps its density on screen.
    #[test]
    fn coverage_adds_up_to_length_times_width() {
        let f = frame((64.0, 64.0));
        for (from, to) in [
            ([-8.0, -1.3], [7.1, 2.9]),
            ([0.3, -8.0], [-2.2, 7.4]),
            ([-5.0, 0.5], [5.0, 0.5]),
        ] {
            for width in [0.3f32, 0.9, 2.5] {
                let (s, verts, m) = one_strand(from, to, width);
                let out = splat(&Input {
                    frame: &f,
                    strands: &[s],
                    verts: &verts,
                    materials: &[m],
                    looks: &[],
                    lod: [1.0, 1.0, 0.0, 0.0],
                    drawn: &[[0, 1]],
                    depth: None,
                });
                // World units to samples: 64 / 20 per unit.
                let k = 64.0 / 20.0;
                let len =
                    DVec2::new((to[0] - from[0]) as f64, (to[1] - from[1]) as f64).length() * k;
                let area: f64 = out.iter().map(|s| s[3]).sum::<f64>() / depth_weight(0.5);
                let want = len * width as f64;
                assert!(
                    (area - want).abs() < 1e-6 * want.max(1.0),
                    "{from:?}->{to:?} width {width}: covered {area}, want {want}"
                );
                // Colour is the node colour (k_a C with ambient 1, no diffuse or specular).
                let s = out.iter().find(|s| s[3] > 0.0).unwrap();
                assert!((s[0] / s[3] - 0.5).abs() < 1e-12 && (s[2] / s[3] - 0.125).abs() < 1e-12);
            }
        }
    }

    /// Samples behind the opaque depth get nothing.
    #[test]
    fn depth_hides_hair_behind() {
        let f = frame((32.0, 32.0));
        let (s, verts, m) = one_strand([-8.0, 0.2], [8.0, 0.3], 1.0);
        let mut depth = vec![1.0f32; 32 * 32];
        // An opaque block at depth 0.25 over the left half (the strand is at 0.5).
        for y in 0..32 {
            for x in 0..16 {
                depth[y * 32 + x] = 0.25;
            }
        }
        let input = |depth| Input {
            frame: &f,
            strands: std::slice::from_ref(&s),
            verts: &verts,
            materials: std::slice::from_ref(&m),
            looks: &[],
            lod: [1.0, 1.0, 0.0, 0.0],
            drawn: &[[0, 1]],
            depth,
        };
        let open = splat(&input(None));
        let hidden = splat(&input(Some(&depth)));
        let half = |o: &[Sample], left: bool| -> f64 {
            o.iter()
                .enumerate()
                .filter(|(i, _)| (i % 32 < 16) == left)
                .map(|(_, s)| s[3])
                .sum()
        };
        assert!(half(&open, true) > 1.0 && half(&open, false) > 1.0);
        assert_eq!(half(&hidden, true), 0.0);
        assert!((half(&hidden, false) - half(&open, false)).abs() < 1e-12);
    }

    /// Coverage composites as independent layers: n hairs of coverage a leave (1 - a)^n.
    #[test]
    fn transmittance_is_the_product_of_layers() {
        let a: f64 = 0.3;
        let n = 5;
        let s = [0.0, 0.0, 0.0, a * n as f64, -(1.0 - a).ln() * n as f64];
        let c = composite(&s, DVec3::ONE);
        assert!((c.x - (1.0 - a).powi(n)).abs() < 1e-12);
    }
}
