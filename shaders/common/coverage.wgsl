// Sub-pixel hair as coverage. A strand thinner than `frame.raster.y` samples is drawn that
// wide with alpha equal to its true coverage. Without MSAA the alpha is blended. With MSAA
// the fragment keeps a share alpha of the samples, stratified over a 2x2 block of pixels and
// chosen per strand (common/coverage_mask.wgsl, included before this file).
//
// Two entry points make the same decisions: `fs` writes them as a sample mask (one
// invocation per pixel); `fs_per_sample` runs per sample and discards, for the GL backend,
// where naga's GLSL for a written sample mask does not compile (gfx-rs/wgpu#6085).
// raster.w: MSAA samples, 1 without.

// MSAA samples a pixel (1 without), at most the 32 a sample mask holds.
fn coverage_samples() -> u32 {
    return min(u32(frame.raster.w + 0.5), 32u);
}

struct HairFragment {
    @location(0) color: vec4<f32>,
    @builtin(sample_mask) mask: u32,
}

fn hair_fragment(color: vec4<f32>, pos: vec2<f32>, strand: u32) -> HairFragment {
    var out: HairFragment;
    let samples = coverage_samples();
    if samples <= 1u {
        out.color = color;
        out.mask = 0xffffffffu;
        return out;
    }
    var mask = 0u;
    let draw = coverage_draw(pos, strand, samples, color.a);
    for (var i = 0u; i < samples; i++) {
        if coverage_keeps(draw, i) {
            mask |= 1u << i;
        }
    }
    out.color = vec4<f32>(color.rgb, 1.0);
    out.mask = mask;
    return out;
}

fn hair_fragment_per_sample(color: vec4<f32>, pos: vec2<f32>, strand: u32, sample: u32) -> vec4<f32> {
    if frame.raster.w < 1.5 {
        return color;
    }
    if !sample_keeps(pos, strand, sample, coverage_samples(), color.a) {
        discard;
    }
    return vec4<f32>(color.rgb, 1.0);
}
