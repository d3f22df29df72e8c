//! Fur's line, polyline and curve coats for the f64 reference of the compute rasteriser
//! (`systems::splat`): nodes placed, sized and shaded as `shaders/fur/splat.wgsl` gives
//! them (`shaders/fur/shade.wgsl`: the paper's GL lighting with its shading normals, or the
//! physical mode), with shadows off (the shadows' contract is `tests/it/shadows.rs`).

use super::gpu_data::GpuFurMaterial;
use crate::gpu::gpu_data::{GpuFrame, GpuStrand};
use crate::rng::pcg_hash;
use crate::systems::hair_bsdf;
use crate::systems::splat::{Node, Nodes, Sample};
use glam::DVec3;

/// Everything fur's kernel reads.
pub struct Input<'a> {
    pub frame: &'a GpuFrame,
    pub strands: &'a [GpuStrand],
    pub verts: &'a [[f32; 4]],
    /// Per hair: the skin normal (w: the hair's seed bits) and the hair plane's normal.
    pub info: &'a [[f32; 4]],
    pub materials: &'a [GpuFurMaterial],
    /// Per coat: first hair, one past the last drawn (tube coats empty).
    pub drawn: &'a [[u32; 2]],
    /// The scene depth per sample (NDC), row-major; `None`: nothing opaque.
    pub depth: Option<&'a [f32]>,
}

/// The accumulation fur's kernel writes for `input`, per sample, row-major.
pub fn splat(input: &Input) -> Vec<Sample> {
    crate::systems::splat::splat(input.frame, input.depth, input)
}

/// As `shaders/fur/shade.wgsl`.
const STYLE_POLYLINE: u32 = 1;

fn v3(v: [f32; 4]) -> DVec3 {
    DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

fn rotate_about(axis: DVec3, v: DVec3, angle: f64) -> DVec3 {
    let (s, c) = angle.sin_cos();
    v * c + axis.cross(v) * s + axis * axis.dot(v) * (1.0 - c)
}

impl Input<'_> {
    fn vert(&self, s: &GpuStrand, n: u32) -> DVec3 {
        v3(self.verts[(s.first_vertex + n) as usize])
    }

    fn tangent(&self, s: &GpuStrand, n: u32) -> DVec3 {
        let a = self.vert(s, if n == 0 { 0 } else { n - 1 });
        let b = self.vert(s, (n + 1).min(s.segments));
        let t = b - a;
        let l = t.length();
        if l > 1e-20 {
            t / l
        } else {
            DVec3::Y
        }
    }

    fn shading_normal(&self, si: u32, m: &GpuFurMaterial, n: u32, t: DVec3) -> DVec3 {
        let skin = self.info[2 * si as usize];
        if m.diffuse[3] as u32 != STYLE_POLYLINE {
            return v3(skin);
        }
        // In the hair plane, perpendicular to the segment, rotated by a random angle.
        let nn = v3(self.info[2 * si as usize + 1]).cross(t);
        let l = nn.length();
        let nn = if l > 1e-12 { nn / l } else { v3(skin) };
        let u = (pcg_hash(skin[3].to_bits() ^ n.wrapping_mul(2654435761)) >> 8) as f64 / 16777216.0;
        rotate_about(
            t,
            nn,
            (2.0 * u - 1.0) * std::f64::consts::PI * m.extra[0] as f64,
        )
    }

    /// `coat_above`: the coat's density times the hair's tapered length above node n.
    fn coat_above(&self, s: &GpuStrand, m: &GpuFurMaterial, n: u32) -> f64 {
        let k = s.segments;
        let area: f64 = (n..k)
            .map(|j| {
                let along = (j as f64 + 0.5) / k.max(1) as f64;
                (self.vert(s, j + 1) - self.vert(s, j)).length()
                    * (1.0 + (super::TIP_WIDTH - 1.0) * along)
            })
            .sum();
        m.extra[3] as f64 * area
    }

    /// `shade_hair` at node n of hair s with no strands or head between the hair and the
    /// light.
    fn shade(
        &self,
        m: &GpuFurMaterial,
        normal: DVec3,
        t: DVec3,
        p: DVec3,
        s: &GpuStrand,
        node: u32,
    ) -> DVec3 {
        let f = self.frame;
        let l = v3(f.light_dir);
        let v = (v3(f.eye) - p).normalize();
        let intensity = f.light_dir[3] as f64;
        let ambient = f.light_color[3] as f64;
        if m.bsdf.physical() {
            let (b, d) = m.bsdf.reference();
            let a = hair_bsdf::Angles::new(v.to_array(), l.to_array(), t.to_array());
            let rad = hair_bsdf::dual_radiance(&b, &d, &a, 0.0);
            let amb = m.bsdf.ambient;
            let through = DVec3::from_array(hair_bsdf::ambient_in_coat(
                d.a_f,
                self.coat_above(s, m, node),
                hair_bsdf::SkyWeight::Fibre,
            ));
            return v3(f.light_color) * (std::f64::consts::PI * intensity) * DVec3::from_array(rad)
                + DVec3::new(amb[0] as f64, amb[1] as f64, amb[2] as f64) * through * ambient;
        }
        let n = if normal.dot(v) < 0.0 { -normal } else { normal };
        let h = (l + v).normalize();
        let diff = n.dot(l).max(0.0);
        let spec = n.dot(h).max(0.0).powf((m.specular[3] as f64).max(1.0));
        v3(m.ambient) * ambient
            + v3(f.light_color) * intensity * (v3(m.diffuse) * diff + v3(m.specular) * spec)
    }
}

impl Nodes for Input<'_> {
    fn strands(&self) -> &[GpuStrand] {
        self.strands
    }

    fn drawn(&self) -> &[[u32; 2]] {
        self.drawn
    }

    fn step(&self, s: &GpuStrand) -> u32 {
        (self.materials[s.group as usize].extra[2] as u32).max(1)
    }

    fn last(&self, s: &GpuStrand) -> u32 {
        s.segments
    }

    fn node(&self, si: u32, s: &GpuStrand, n: u32) -> Node {
        let m = &self.materials[s.group as usize];
        let p = self.vert(s, n);
        let t = self.tangent(s, n);
        Node {
            pos: p,
            rgb: self.shade(m, self.shading_normal(si, m, n, t), t, p, s, n),
            // The export's taper: this twin's contract binds it to `ribbon_width`.
            width: super::drawn_width(
                m.ambient[3] as f64 * m.extra[1] as f64,
                n as usize,
                s.segments as usize + 1,
            ),
            alpha: 1.0,
        }
    }
}
