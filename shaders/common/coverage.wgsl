// Sub-pixel hair as coverage. A strand thinner than `frame.raster.y` samples is drawn that
// wide with alpha equal to its true coverage. Without MSAA the alpha is blended. With MSAA,
// sample i of a pixel keeps the fragment when a hash of (pixel, strand, i) falls below alpha:
// unlike alpha to coverage, whose mask is a fixed function of alpha (so a hundred hairs of
// alpha 0.1 all light the same sample and a dense thin coat stays a quarter covered),
// independent samples add up as real coverage does, 1 - (1 - a)^n, in any order.
//
// Two entry points make the same decisions: `fs` writes them as a sample mask (one
// invocation per pixel); `fs_per_sample` runs per sample and discards, for the GL backend,
// where naga's GLSL for a written sample mask does not compile (gfx-rs/wgpu#6085).
// raster.w: MSAA samples, 1 without.

fn sample_keeps(pos: vec2<f32>, strand: u32, sample: u32, alpha: f32) -> bool {
    let px = vec2<u32>(pos);
    let h = pcg_hash(px.x * 1973u + px.y * 9277u + strand * 26699u + sample * 7919u);
    return f32(h >> 8u) / 16777216.0 < alpha;
}

struct HairFragment {
    @location(0) color: vec4<f32>,
    @builtin(sample_mask) mask: u32,
}

fn hair_fragment(color: vec4<f32>, pos: vec2<f32>, strand: u32) -> HairFragment {
    var out: HairFragment;
    let samples = u32(frame.raster.w + 0.5);
    if samples <= 1u {
        out.color = color;
        out.mask = 0xffffffffu;
        return out;
    }
    var mask = 0u;
    for (var i = 0u; i < min(samples, 32u); i++) {
        if sample_keeps(pos, strand, i, color.a) {
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
    if !sample_keeps(pos, strand, sample, color.a) {
        discard;
    }
    return vec4<f32>(color.rgb, 1.0);
}
