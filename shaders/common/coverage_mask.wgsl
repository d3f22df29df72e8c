// Which MSAA samples a hair fragment of coverage `alpha` keeps (common/coverage.wgsl; the
// CPU twin is `kami::systems::coverage::sample_keeps`, the contract test
// tests/it/coverage.rs). A fragment keeps a share alpha of the samples, chosen by a hash of
// (strand, 2x2 block of pixels): unlike alpha to coverage, whose mask is a fixed function of
// alpha (so a hundred hairs of alpha 0.1 all light the same sample and a dense thin coat
// stays a quarter covered), each strand's choice is its own, so layers add up as real
// coverage does, 1 - (1 - a)^n, in any order; a strand drawn twice over a sample counts once.
//
// Stratified (Enderton et al. 2010, "Stochastic Transparency"): the block's 4 x samples
// slots are ranked by a random affine permutation, and a strand keeps the slots ranked below
// alpha x slots, the fraction by a random offset. One layer then covers the block to within
// a slot and each pixel to within a sample, where a coin per sample (as before) scattered
// binomial noise over every pixel: the
// strips' thin tips came out as salt and pepper (docs/look.md, "Coverage without the salt
// and pepper"). `samples` is a power of two (wgpu's sample counts), at most 32.
fn sample_keeps(pos: vec2<f32>, strand: u32, sample: u32, samples: u32, alpha: f32) -> bool {
    let px = vec2<u32>(pos);
    let slots = 4u * samples;
    let h = pcg_hash((px.x >> 1u) * 1973u + (px.y >> 1u) * 9277u + strand * 26699u);
    // Sample-major: a pixel's slots are 4 apart, so any odd multiplier spreads their ranks
    // 4 apart too, and each pixel is stratified as well as the block.
    let slot = sample * 4u + (px.y & 1u) * 2u + (px.x & 1u);
    let rank = (((h >> 16u) | 1u) * slot + (h & 0xffffu)) & (slots - 1u);
    // Both sides exact in f32 (a 24-bit fraction; alpha x slots less an integer), so the
    // twin decides every case as the GPU does.
    let offset = f32(pcg_hash(h) >> 8u) / 16777216.0;
    return offset < alpha * f32(slots) - f32(rank);
}
