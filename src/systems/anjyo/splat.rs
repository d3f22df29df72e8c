//! Anjyo's strands for the f64 reference of the compute rasteriser (`systems::splat`):
//! nodes placed, sized and shaded as `shaders/anjyo/splat.wgsl` gives them
//! (`shaders/common/strand_shade.wgsl`, with `common/strand_vary.wgsl`'s per-strand
//! variation through its f64 twin `anjyo::vary`).

use super::gpu_data::{GpuLook, GpuMaterial};
use crate::gpu::gpu_data::{GpuFrame, GpuStrand};
use crate::systems::hair_bsdf;
pub use crate::systems::splat::{composite, Sample};
use crate::systems::splat::{Node, Nodes};
use glam::DVec3;

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

/// The accumulation the kernel writes for `input`, per sample, row-major.
pub fn splat(input: &Input) -> Vec<Sample> {
    crate::systems::splat::splat(input.frame, input.depth, input)
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
    fn lod_step(&self) -> u32 {
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

    fn last_node(s: &GpuStrand) -> u32 {
        (s.visible as f64).ceil() as u32
    }

    fn shade(&self, s: &GpuStrand, n: u32) -> Node {
        let f = self.frame;
        let step = self.lod_step();
        let last = Self::last_node(s);
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
        // Per-strand variation (`vary`), only for a group that varies, as the shader.
        let vary = super::block::Variation {
            melanin: mat.variation[0] as f64,
            width: mat.variation[1] as f64,
            tint: mat.variation[2] as f64,
        };
        if mat.variation[1] != 0.0 {
            width *= super::vary::width_factor(s.rand, &vary);
        }
        let varies = mat.variation[0] != 0.0 || mat.variation[2] != 0.0;
        let absorb = if varies {
            super::vary::absorption(s.rand, &vary)
        } else {
            [1.0; 3]
        };
        if varies {
            base = DVec3::from_array(super::vary::color(base.to_array(), s.rand, &vary));
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
            // A varied strand's own absorption; of the ambient colour, the sky it
            // scatters once is its own, the volume's light the group's (dual scattering's
            // averages stay the group's).
            let (mut b, d) = mat.bsdf.reference();
            b.sigma_a = std::array::from_fn(|c| b.sigma_a[c] * absorb[c]);
            let a = hair_bsdf::Angles::new(v.to_array(), l.to_array(), t.to_array());
            let s = hair_bsdf::dual_radiance(&b, &d, &a, 0.0);
            let mut around: [f64; 3] = std::array::from_fn(|c| mat.bsdf.ambient[c] as f64);
            if varies {
                let own = hair_bsdf::varied_single_at(&mat.vary_single, absorb.map(f64::ln));
                let mid = mat.vary_single[hair_bsdf::VARY_TABLE / 2];
                for c in 0..3 {
                    around[c] += own[c] - mid[c] as f64;
                }
            }
            rgb = v3(f.light_color) * (std::f64::consts::PI * intensity) * DVec3::from_array(s)
                + DVec3::from_array(around) * ambient;
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
}

impl Nodes for Input<'_> {
    fn strands(&self) -> &[GpuStrand] {
        self.strands
    }

    fn drawn(&self) -> &[[u32; 2]] {
        self.drawn
    }

    fn step(&self, _s: &GpuStrand) -> u32 {
        self.lod_step()
    }

    fn last(&self, s: &GpuStrand) -> u32 {
        Input::last_node(s)
    }

    fn node(&self, _si: u32, s: &GpuStrand, n: u32) -> Node {
        self.shade(s, n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::systems::splat::depth_weight;
    use glam::DVec2;

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
            variation: [0.0; 4],
            vary_single: Default::default(),
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
