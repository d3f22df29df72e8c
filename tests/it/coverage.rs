//! The MSAA coverage mask of sub-pixel hair (`shaders/common/coverage_mask.wgsl`): the WGSL
//! against its twin (`kami::systems::coverage`) case by case, and the statistics the drawing
//! relies on: one layer covers its 2x2 block of pixels to within a slot and each pixel to
//! within a sample, distinct strands add up as real coverage does, a strand drawn twice
//! counts once.

use crate::common;
use kami::gpu::bind;
use kami::systems::coverage::{mask, sample_keeps};

const ENTRY: &str = "
// Per element: x, y the pixel, z the strand, w the sample plus 256 times the samples.
@group(0) @binding(0) var<storage, read> cases: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read> alphas: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> out: array<vec4<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&out) { return; }
    let c = cases[i];
    let pos = vec2<f32>(f32(c.x) + 0.5, f32(c.y) + 0.5);
    var r = vec4<f32>(0.0);
    for (var k = 0; k < 4; k++) {
        r[k] = select(0.0, 1.0, sample_keeps(pos, c.z, c.w & 255u, c.w >> 8u, alphas[i][k]));
    }
    out[i] = r;
}";

/// Every decision of the GPU's mask equals the twin's, over 8192 cases: pixels, strands,
/// samples of 2, 4 and 8 MSAA, coverage at random and exactly on the slot boundaries.
#[test]
fn the_wgsl_mask_matches_its_twin() {
    let gpu = common::gpu();
    let mut cases: Vec<[u32; 4]> = Vec::new();
    let mut alphas: Vec<[f32; 4]> = Vec::new();
    for i in 0..8192u32 {
        let h = |k: u32| kami::rng::pcg_hash(i.wrapping_mul(4).wrapping_add(k) ^ 0xc0fe);
        let samples = [2, 4, 8][(h(0) % 3) as usize];
        let slots = 4 * samples;
        cases.push([
            h(1) % 4096,
            h(2) % 4096,
            h(3),
            (h(0) >> 8) % samples + 256 * samples,
        ]);
        let on_slot = ((h(1) >> 12) % (slots + 1)) as f32 / slots as f32;
        alphas.push([
            kami::rng::hash_unit(h(2)),
            on_slot,
            kami::rng::hash_unit(h(3)) * 0.1,
            [0.0, 1.0][(h(3) >> 31) as usize],
        ]);
    }
    let got = common::run_contract(
        gpu,
        "coverage mask contract",
        &format!("{}\n{ENTRY}", kami::shaders::COVERAGE_MASK),
        &[
            (bytemuck::cast_slice(&cases), bind::storage::<[u32; 4]>()),
            (bytemuck::cast_slice(&alphas), bind::storage::<[f32; 4]>()),
        ],
        cases.len(),
    );
    let mut wrong = Vec::new();
    for (i, (c, g)) in cases.iter().zip(&got).enumerate() {
        for k in 0..4 {
            let want = sample_keeps([c[0], c[1]], c[2], c[3] & 255, c[3] >> 8, alphas[i][k]);
            if (g[k] > 0.5) != want {
                wrong.push((i, k));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "{} of {} decisions differ, first at case {:?}: {:?} alpha {}",
        wrong.len(),
        4 * cases.len(),
        wrong[0],
        cases[wrong[0].0],
        alphas[wrong[0].0][wrong[0].1]
    );
}

/// Slots of the 2x2 block at `(bx, by)` that strand `strand` keeps.
fn block_mask(bx: u32, by: u32, strand: u32, samples: u32, alpha: f32) -> u128 {
    let mut m = 0u128;
    for q in 0..4u32 {
        let px = [2 * bx + (q & 1), 2 * by + (q >> 1)];
        m |= (mask(px, strand, samples, alpha) as u128) << (q * samples);
    }
    m
}

/// One layer covers each 2x2 block with the floor or the ceiling of alpha times its slots,
/// and each pixel of it with the floor or the ceiling of alpha times its samples (an
/// independent coin per sample would be off by about sqrt(samples alpha (1 - alpha)); a hair
/// a pixel wide crosses one pixel of a block), and on average exactly alpha; 0 keeps nothing
/// and 1 everything.
#[test]
fn one_layer_covers_its_block_and_each_pixel_to_within_a_sample() {
    for samples in [2u32, 4, 8] {
        let slots = 4 * samples;
        for alpha in [0.03f32, 0.3, 0.5, 0.77, 0.999] {
            let (mut sum, n) = (0u64, 4000u32);
            for i in 0..n {
                let (bx, by, strand) = (i % 61, i / 61, i * 7 + 3);
                for q in 0..4 {
                    let px = [2 * bx + (q & 1), 2 * by + (q >> 1)];
                    let kept = mask(px, strand, samples, alpha).count_ones();
                    assert!(
                        (kept as f64 - alpha as f64 * samples as f64).abs() < 1.0,
                        "{samples} samples, alpha {alpha}: pixel {px:?} keeps {kept}"
                    );
                }
                let kept = block_mask(bx, by, strand, samples, alpha).count_ones();
                let want = alpha as f64 * slots as f64;
                assert!(
                    (kept as f64 - want).abs() < 1.0,
                    "{samples} samples, alpha {alpha}: block {i} keeps {kept} of {slots}"
                );
                sum += kept as u64;
            }
            let mean = sum as f64 / (n * slots) as f64;
            assert!(
                (mean - alpha as f64).abs() < 0.01,
                "{samples} samples, alpha {alpha}: mean coverage {mean}"
            );
        }
        for i in 0..100 {
            assert_eq!(block_mask(i, 0, i, samples, 0.0), 0);
            assert_eq!(block_mask(i, 0, i, samples, 1.0).count_ones(), slots);
        }
    }
}

/// n distinct strands of coverage a over a block cover 1 - (1 - a)^n of it on average, as
/// independent layers of real hair do (alpha to coverage's fixed masks would stay at a); the
/// same strand drawn n times covers a.
#[test]
fn layers_add_up_as_coverage_does() {
    let samples = 4u32;
    let slots = 4 * samples;
    for (a, layers) in [(0.1f32, 10u32), (0.3, 3), (0.5, 2), (0.25, 6)] {
        let (mut distinct, mut same, blocks) = (0u64, 0u64, 3000u32);
        for b in 0..blocks {
            let (bx, by) = (b % 53, b / 53);
            let union = (0..layers).fold(0u128, |m, l| {
                m | block_mask(bx, by, 1000 * b + l, samples, a)
            });
            distinct += union.count_ones() as u64;
            let again =
                (0..layers).fold(0u128, |m, _| m | block_mask(bx, by, 1000 * b, samples, a));
            same += again.count_ones() as u64;
        }
        let (got, want) = (
            distinct as f64 / (blocks * slots) as f64,
            1.0 - (1.0 - a as f64).powi(layers as i32),
        );
        println!("{layers} layers of {a}: covered {got:.4}, 1 - (1 - a)^n = {want:.4}");
        assert!(
            (got - want).abs() < 0.015,
            "{layers} layers of {a}: {got} against {want}"
        );
        let once = same as f64 / (blocks * slots) as f64;
        assert!(
            (once - a as f64).abs() < 0.02,
            "one strand {layers} times: {once} against {a}"
        );
    }
}
