//! Which MSAA samples a sub-pixel hair fragment keeps: the CPU twin of
//! `shaders/common/coverage_mask.wgsl`, which every strand pass (Anjyo's ribbons, fur,
//! strips) runs through `common/coverage.wgsl`. The contract test (`tests/it/coverage.rs`)
//! compares the two case by case and checks the statistics the drawing relies on.
//!
//! A fragment of coverage `alpha` keeps a share alpha of the samples of its 2x2 block of
//! pixels, stratified (Enderton et al. 2010, "Stochastic Transparency"): the block's
//! `4 * samples` slots are ranked by a random affine permutation hashed from the block and the
//! strand, and the strand keeps the slots ranked below `alpha * slots`, the fraction by a
//! random offset. The slots are numbered sample-major, so the ranks of one pixel's samples
//! lie 4 apart under any odd multiplier: one layer covers a block to within a slot and each
//! of its pixels to within a sample (an independent coin per sample scattered binomial noise
//! over every pixel), distinct strands choose independently
//! (layers add up as real coverage, `1 - (1 - a)^n`), and one strand drawn twice over a
//! sample counts once.

use crate::rng::pcg_hash;

/// Whether sample `sample` of pixel `px` keeps a fragment of strand `strand` with coverage
/// `alpha`, among `samples` samples a pixel (a power of two, at most 32). Decides every case
/// as the shader does: both sides of its comparison are exact in f32.
pub fn sample_keeps(px: [u32; 2], strand: u32, sample: u32, samples: u32, alpha: f32) -> bool {
    let slots = 4 * samples;
    let h = pcg_hash(
        (px[0] >> 1)
            .wrapping_mul(1973)
            .wrapping_add((px[1] >> 1).wrapping_mul(9277))
            .wrapping_add(strand.wrapping_mul(26699)),
    );
    // Sample-major, so a pixel's ranks lie 4 apart and the pixel is stratified too.
    let slot = sample * 4 + (px[1] & 1) * 2 + (px[0] & 1);
    let rank = ((h >> 16) | 1).wrapping_mul(slot).wrapping_add(h & 0xffff) & (slots - 1);
    let offset = f64::from(pcg_hash(h) >> 8) / 16_777_216.0;
    offset < f64::from(alpha) * f64::from(slots) - f64::from(rank)
}

/// The sample mask of a fragment (bit i: sample i kept), as `hair_fragment` builds it.
pub fn mask(px: [u32; 2], strand: u32, samples: u32, alpha: f32) -> u32 {
    (0..samples.min(32))
        .filter(|&i| sample_keeps(px, strand, i, samples, alpha))
        .fold(0, |m, i| m | 1 << i)
}
