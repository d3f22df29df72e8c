//! The physical shading mode's WGSL hair BSDF (`shaders/common/hair_bsdf.wgsl`) against its
//! f64 reference (`kami::systems::hair_bsdf`): a small compute entry point evaluates the dual
//! scattered radiance factor over a grid of directions, tangents, strand counts and
//! materials on the test adapter, and the worst element (relative to the larger of the
//! value and a floor of 2 % of its material's largest value) is bounded.

use crate::common;
use kami::systems::hair_bsdf::{
    dual_radiance, Angles, Bsdf, DualScattering, GpuHairBsdf, HairParams,
};

const ENTRY: &str = "
@group(0) @binding(0) var<storage, read> mats: array<HairBsdf>;
// Per element: tangent (xyz, w strand count n), view (xyz, w material), light.
@group(0) @binding(1) var<storage, read> input: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> out: array<vec4<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&out) { return; }
    let t = input[3u * i];
    let v = input[3u * i + 1u];
    let l = input[3u * i + 2u];
    out[i] = vec4<f32>(hair_dual_radiance(mats[u32(v.w)], t.xyz, v.xyz, l.xyz, t.w), 0.0);
}";

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / n)
}

#[test]
fn wgsl_bsdf_matches_the_f64_reference() {
    let gpu = common::gpu();
    let params = [
        HairParams::default(),
        HairParams {
            eumelanin: 0.05,
            pheomelanin: 0.3,
            beta_m: 0.15,
            beta_n: 0.6,
            alpha: -3.0,
            eta: 1.4,
        },
        HairParams {
            eumelanin: 3.0,
            beta_m: 0.6,
            beta_n: 0.2,
            ..HairParams::default()
        },
    ];
    let refs: Vec<(Bsdf, DualScattering)> = params
        .iter()
        .map(|p| {
            let b = p.bsdf();
            (b, DualScattering::new(&b))
        })
        .collect();
    let mats: Vec<GpuHairBsdf> = params.iter().map(|p| GpuHairBsdf::new(p, true)).collect();
    let tangents = [
        [0.0, 1.0, 0.0],
        unit([0.3, -0.8, 0.5]),
        unit([1.0, 0.2, -0.1]),
    ];
    let mut dirs = Vec::new();
    for i in 0..7 {
        let th = -1.3 + 2.6 * i as f64 / 6.0;
        for j in 0..6 {
            let ph = std::f64::consts::PI * 2.0 * j as f64 / 6.0 + 0.1;
            dirs.push([th.cos() * ph.cos(), th.sin(), th.cos() * ph.sin()]);
        }
    }
    let mut input: Vec<[f32; 4]> = Vec::new();
    let mut want = Vec::new();
    let mut top = vec![0.0f64; params.len()];
    for (m, (b, d)) in refs.iter().enumerate() {
        for t in tangents {
            for (k, v) in dirs.iter().enumerate() {
                for (q, l) in dirs.iter().enumerate() {
                    if (k + q) % 3 != 0 {
                        continue;
                    }
                    let n = [0.0, 0.5, 3.0][(k + 2 * q) % 3];
                    let s = dual_radiance(b, d, &Angles::new(*v, *l, t), n);
                    top[m] = top[m].max(s[0]).max(s[1]).max(s[2]);
                    let f = |x: f64| x as f32;
                    input.push([f(t[0]), f(t[1]), f(t[2]), n as f32]);
                    input.push([f(v[0]), f(v[1]), f(v[2]), m as f32]);
                    input.push([f(l[0]), f(l[1]), f(l[2]), 0.0]);
                    want.push((m, s));
                }
            }
        }
    }
    use kami::gpu::bind;
    let got = common::run_contract(
        gpu,
        "hair bsdf contract",
        &format!("{}\n{ENTRY}", kami::shaders::HAIR_BSDF),
        &[
            (
                bytemuck::cast_slice(&mats),
                bind::storage::<kami::systems::hair_bsdf::GpuHairBsdf>(),
            ),
            (bytemuck::cast_slice(&input), bind::storage::<[f32; 4]>()),
        ],
        want.len(),
    );
    let mut worst = (0.0f64, 0);
    for (i, ((m, s), g)) in want.iter().zip(&got).enumerate() {
        for c in 0..3 {
            let err = (g[c] as f64 - s[c]).abs() / s[c].max(0.02 * top[*m]);
            if err > worst.0 || !g[c].is_finite() {
                worst = (if g[c].is_finite() { err } else { f64::INFINITY }, i);
            }
        }
    }
    let (err, i) = worst;
    assert!(
        err < 2e-3,
        "worst relative error {err} at element {i} of {}: gpu {:?}, f64 {:?}",
        want.len(),
        got[i],
        want[i].1
    );
}
