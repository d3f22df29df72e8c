// Sub-pixel hair as coverage. A strand thinner than `frame.raster.y` samples is drawn that
// wide with alpha equal to its true coverage. Without MSAA the alpha is blended. With MSAA
// each sample keeps the fragment with probability alpha, by a hash of the pixel, the strand
// and the sample: unlike alpha to coverage, whose mask is a fixed function of alpha (so a
// hundred hairs of alpha 0.1 all light the same sample and a dense thin coat stays a quarter
// covered), independent samples add up as real coverage does, 1 - (1 - a)^n, in any order.
// (Writing @builtin(sample_mask) would do it once per pixel, but naga's GLSL output for it
// does not compile: gfx-rs/wgpu#6085.) raster.w: MSAA samples, 1 without.

fn hair_fragment(color: vec4<f32>, pos: vec2<f32>, strand: u32, sample: u32) -> vec4<f32> {
    if frame.raster.w < 1.5 {
        return color;
    }
    let px = vec2<u32>(pos);
    let h = pcg_hash(px.x * 1973u + px.y * 9277u + strand * 26699u + sample * 7919u);
    if f32(h >> 8u) / 16777216.0 >= color.a {
        discard;
    }
    return vec4<f32>(color.rgb, 1.0);
}
