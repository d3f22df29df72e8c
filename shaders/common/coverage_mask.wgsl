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
// binomial noise over every pixel: the strips' thin tips came out as salt and pepper
// (docs/look.md, "Coverage without the salt and pepper"). `samples` is a power of two
// (wgpu's sample counts), at most 32.
// One fragment's draw: what every sample's decision needs, hashed once per fragment.
struct CoverageDraw {
    // The affine permutation's odd multiplier and its shift, the pixel's place in its block.
    multiplier: u32,
    shift: u32,
    quad: u32,
    slots: u32,
    // alpha x slots, and the random offset of the fraction: a slot is kept where the offset is
    // below alpha x slots less its rank. Both sides of that are exact in f32 (a 24-bit
    // fraction; alpha x slots less an integer), so the twin decides every case as the GPU.
    budget: f32,
    offset: f32,
}

fn coverage_draw(pos: vec2<f32>, strand: u32, samples: u32, alpha: f32) -> CoverageDraw {
    let px = vec2<u32>(pos);
    let h = pcg_hash((px.x >> 1u) * 1973u + (px.y >> 1u) * 9277u + strand * 26699u);
    let offset = f32(pcg_hash(h) >> 8u) / 16777216.0;
    return CoverageDraw((h >> 16u) | 1u, h & 0xffffu, (px.y & 1u) * 2u + (px.x & 1u), 4u * samples,
        alpha * f32(4u * samples), offset);
}

fn coverage_keeps(d: CoverageDraw, sample: u32) -> bool {
    // Sample-major: a pixel's slots are 4 apart, so any odd multiplier spreads their ranks
    // 4 apart too, and each pixel is stratified as well as the block.
    let slot = sample * 4u + d.quad;
    let rank = (d.multiplier * slot + d.shift) & (d.slots - 1u);
    return d.offset < d.budget - f32(rank);
}

fn sample_keeps(pos: vec2<f32>, strand: u32, sample: u32, samples: u32, alpha: f32) -> bool {
    return coverage_keeps(coverage_draw(pos, strand, samples, alpha), sample);
}
