//! Per-strand variation (`anjyo::block::Variation`): the WGSL functions
//! (`shaders/common/strand_vary.wgsl`) against their f64 twin (`anjyo::vary`), the numbers'
//! spread, the draw and the export reading them, the reference binning them, and bad values
//! refused.

use crate::common;
use kami::gpu::bind;
use kami::systems::anjyo::block::Variation;
use kami::systems::anjyo::vary;

const ENTRY: &str = "
// Per element: x the strand's rand, yzw the variation (melanin, width, tint).
@group(0) @binding(0) var<storage, read> input: array<vec4<f32>>;
// xyz absorption, w width factor.
@group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&out) { return; }
    let p = input[i];
    let v = vec4<f32>(p.y, p.z, p.w, 0.0);
    out[i] = vec4<f32>(vary_absorption(p.x, v), vary_width(p.x, v));
}";

/// The GPU's per-strand factors against the f64 twin, over 4096 strands and three
/// variations (the largest allowed among them): the worst relative error is bounded.
#[test]
fn the_wgsl_variation_matches_the_f64_twin() {
    let gpu = common::gpu();
    let vars = [
        Variation {
            melanin: 0.2,
            width: 0.15,
            tint: 0.1,
        },
        Variation {
            melanin: 1.0,
            width: 1.0,
            tint: 1.0,
        },
        Variation {
            melanin: 0.0,
            width: 0.3,
            tint: 0.0,
        },
    ];
    let mut input: Vec<[f32; 4]> = Vec::new();
    let mut want: Vec<[f64; 4]> = Vec::new();
    for v in &vars {
        for i in 0..4096u32 {
            let rand = kami::rng::hash_unit(i ^ 0x5eed);
            input.push([rand, v.melanin as f32, v.width as f32, v.tint as f32]);
            let a = vary::absorption(rand, v);
            want.push([a[0], a[1], a[2], vary::width_factor(rand, v)]);
        }
    }
    let got = common::run_contract(
        gpu,
        "strand vary contract",
        &format!("{}\n{ENTRY}", kami::shaders::STRAND_VARY),
        &[(bytemuck::cast_slice(&input), bind::storage::<[f32; 4]>())],
        want.len(),
    );
    let mut worst = (0.0f64, 0);
    for (i, (w, g)) in want.iter().zip(&got).enumerate() {
        for c in 0..4 {
            let err = (f64::from(g[c]) - w[c]).abs() / w[c];
            if err > worst.0 || err.is_nan() {
                worst = (if err.is_finite() { err } else { f64::INFINITY }, i);
            }
        }
    }
    let (err, i) = worst;
    assert!(
        err < 1e-5,
        "worst relative error {err} at strand {i}: gpu {:?}, f64 {:?}",
        got[i],
        want[i]
    );
}

/// The numbers have zero mean and unit variance, stay within +-sqrt(3), and the three a
/// strand draws are uncorrelated; with no variation every factor is 1.
#[test]
fn the_strand_numbers_have_the_stated_spread() {
    let n = 20_000u32;
    let us: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let r = kami::rng::hash_unit(i);
            [vary::unit(r, 0), vary::unit(r, 1), vary::unit(r, 2)]
        })
        .collect();
    for k in 0..3 {
        let mean = us.iter().map(|u| u[k]).sum::<f64>() / n as f64;
        let var = us.iter().map(|u| (u[k] - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(
            mean.abs() < 0.03 && (var - 1.0).abs() < 0.03,
            "{k}: {mean} {var}"
        );
        assert!(us.iter().all(|u| u[k].abs() <= 3f64.sqrt()));
        let corr = us.iter().map(|u| u[k] * u[(k + 1) % 3]).sum::<f64>() / n as f64;
        assert!(corr.abs() < 0.03, "{k}: correlation {corr}");
    }
    let none = Variation::default();
    assert_eq!(vary::absorption(0.37, &none), [1.0; 3]);
    assert_eq!(vary::width_factor(0.37, &none), 1.0);
}

/// A varied physical strand's sky: the group's table of single backscattering
/// (`hair_bsdf::gpu_varied_single` over the widest spread, on its coarser grid, read as the
/// shader reads it) against a_b integrated afresh on the full grid at each strand's own
/// absorption, for 48 strands of the shipped spread and of the largest allowed (factors
/// from e^-3.5 to e^3.5). Bounded: the relative error of the value, and the error of what
/// the shader adds to the group's ambient (the strand's value less the table's middle)
/// against the exact difference, relative to the group's single part. The table's middle
/// is the group's own single part to within the coarser grid's error.
#[test]
fn a_varied_strands_sky_table_matches_its_own_backscattering() {
    use kami::systems::hair_bsdf::{self, DualScattering, VARY_SPAN, VARY_TABLE};
    let scene = common::scene("bob");
    let m = &scene.groups()[0].material;
    let p = m.physical.hair(m.color);
    let group = hair_bsdf::sky_single(&DualScattering::new(&p.bsdf()));
    let table = hair_bsdf::gpu_varied_single(&p, VARY_SPAN);
    let mid = table[VARY_TABLE / 2];
    for c in 0..3 {
        let err = (f64::from(mid[c]) - group[c]).abs() / group[c];
        assert!(err < 5e-2, "middle {mid:?} against the group's {group:?}");
    }
    for (v, bound) in [
        (
            Variation {
                melanin: 0.3,
                width: 0.0,
                tint: 0.1,
            },
            [5e-2, 1e-2],
        ),
        (
            Variation {
                melanin: 1.0,
                width: 0.0,
                tint: 1.0,
            },
            [5e-2, 2e-2],
        ),
    ] {
        let mut worst = [(0.0f64, 0u32); 2];
        for i in 0..48u32 {
            let rand = kami::rng::hash_unit(i ^ 0xab5);
            let a = vary::absorption(rand, &v);
            let got = hair_bsdf::varied_single_at(&table, a.map(f64::ln));
            let mut b = p.bsdf();
            b.sigma_a = std::array::from_fn(|c| b.sigma_a[c] * a[c]);
            let want = hair_bsdf::sky_single(&DualScattering::new(&b));
            for c in 0..3 {
                let value = (got[c] - want[c]).abs() / want[c];
                let added = ((got[c] - f64::from(mid[c])) - (want[c] - group[c])).abs() / group[c];
                for (k, err) in [value, added].into_iter().enumerate() {
                    if err > worst[k].0 || err.is_nan() {
                        worst[k] = (if err.is_finite() { err } else { f64::INFINITY }, i);
                    }
                }
            }
        }
        println!(
            "{v:?}: worst relative error of the value {:.2e}, of what is added {:.2e}",
            worst[0].0, worst[1].0
        );
        for k in 0..2 {
            assert!(
                worst[k].0 < bound[k],
                "{v:?}: worst relative error {} (of {}) at strand {}",
                worst[k].0,
                ["the value", "what is added"][k],
                worst[k].1
            );
        }
    }
}

fn bob_with(v: Variation) -> kami::Scene {
    let mut scene = common::scene("bob");
    for g in scene.groups_mut() {
        g.material.variation = v;
    }
    scene
}

/// With variation the bob draws strands of their own shades and widths (the image changes,
/// and the exported widths spread as exp(width z) says), and the drawn export hands each
/// strand's absorption to the reference; without it, every factor is 1.
#[test]
fn varied_strands_are_drawn_exported_and_binned() {
    let gpu = common::gpu();
    let v = Variation {
        melanin: 0.3,
        width: 0.2,
        tint: 0.1,
    };
    let plain = bob_with(Variation::default());
    let varied = bob_with(v);
    let a = kami::stage::render_scene(gpu, &plain, (96, 96)).unwrap();
    let b = kami::stage::render_scene(gpu, &varied, (96, 96)).unwrap();
    let differ = a
        .pixels()
        .zip(b.pixels())
        .filter(|(p, q)| (0..3).any(|c| p[c].abs_diff(q[c]) > 4))
        .count();
    assert!(
        differ > 200,
        "{differ} pixels differ by more than 4 levels with variation"
    );
    let drawn = kami::bench::look::drawn_hair(gpu, &varied, (64, 64)).unwrap();
    let flat = kami::bench::look::drawn_hair(gpu, &plain, (64, 64)).unwrap();
    let (ga, gb) = (&flat.groom, &drawn.groom);
    assert_eq!(ga.counts, gb.counts);
    let abs = drawn.absorption.as_ref().unwrap();
    assert_eq!(abs.len(), gb.counts.len());
    assert!(flat
        .absorption
        .as_ref()
        .unwrap()
        .iter()
        .all(|a| *a == [1.0; 3]));
    // Root widths: the log of the ratio has the variation's spread.
    let mut at = 0usize;
    let mut logs = Vec::new();
    for (i, &c) in gb.counts.iter().enumerate() {
        let r = gb.widths.as_ref().unwrap()[at] / ga.widths.as_ref().unwrap()[at];
        logs.push(f64::from(r).ln());
        // The absorption's middle channel is exp(melanin z): within its bound.
        let m = f64::from(abs[i][1]).ln();
        assert!(m.abs() <= v.melanin * 3f64.sqrt() + 1e-6, "{i}: {m}");
        at += c as usize;
    }
    let n = logs.len() as f64;
    let mean = logs.iter().sum::<f64>() / n;
    let sd = (logs.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / n).sqrt();
    assert!(
        mean.abs() < 0.02 && (sd - v.width).abs() < 0.02,
        "log width ratio: mean {mean}, sd {sd}"
    );
    // The reference: more than one hair BSDF, each strand in one, given as sigma_a.
    let dir = common::scratch("varied_reference");
    let shapes = kami::bench::look::write_shapes(&dir, &varied, gb, Some(abs), "bob").unwrap();
    let bsdfs = shapes.matches("<bsdf type=\"hair\">").count();
    assert!(bsdfs > 10, "{bsdfs} hair BSDFs for varied strands");
    assert!(shapes.contains("name=\"sigma_a\""));
    let plain_shapes =
        kami::bench::look::write_shapes(&dir, &plain, ga, flat.absorption.as_deref(), "bob");
    assert_eq!(
        plain_shapes
            .unwrap()
            .matches("<bsdf type=\"hair\">")
            .count(),
        1
    );
}

/// A spread outside 0..1 is refused, naming the field.
#[test]
fn a_variation_out_of_range_is_refused() {
    let text = std::fs::read_to_string(common::root().join("assets/scenes/bob.ron")).unwrap();
    let bad = text.replacen(
        "Material(",
        "Material(variation: Variation(melanin: 1.5), ",
        1,
    );
    assert_ne!(bad, text, "bob.ron has a Material");
    let (field, value, _) = common::invalid(&bad);
    assert!(field.ends_with("material.variation.melanin"), "{field}");
    assert_eq!(value, "1.5");
}
