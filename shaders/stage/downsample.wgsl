// Supersampling resolve: each output pixel is the mean of its factor x factor block of the
// (already MSAA-resolved) scene texture, in linear colour. Anjyo's oversampling for hair
// thinner than a pixel. Into a non-sRGB output (a window shared with egui) the sRGB
// encoding is done here. Thin strands drawn by the compute rasteriser
// (anjyo/splat.wgsl) are composited over each sample first, from their accumulation.

struct Resolve {
    factor: u32,
    // 1: the output is not an sRGB format, so encode here.
    encode_srgb: u32,
    // 1: composite the thin-strand accumulation (`accum`) over the scene.
    splat: u32,
    _p2: u32,
    // Scene pixels per output pixel per axis, below 1 when the scene is drawn at a lower
    // resolution (`fs_scaled`).
    scale: vec2<f32>,
    _p3: vec2<f32>,
}

@group(0) @binding(0) var scene: texture_2d<f32>;
@group(0) @binding(1) var<uniform> resolve: Resolve;
// Five words per scene sample: sum rgb a wt, sum a wt, sum -ln(1 - a) (anjyo/splat.wgsl).
@group(0) @binding(2) var<storage, read> accum: array<u32>;

// As in anjyo/splat.wgsl and src/gpu/splat.rs (tests/it/gpu_twins.rs checks them).
const COLOR_SCALE: f32 = 16384.0;
const DEPTH_SCALE: f32 = 4096.0;

// The thin strands over the scene at sample `px`: their weighted mean colour times their
// coverage 1 - T, over the scene times the transmittance T.
fn with_hair(px: vec2<i32>, scene_rgb: vec3<f32>) -> vec3<f32> {
    if resolve.splat == 0u {
        return scene_rgb;
    }
    let i = 5u * (u32(px.y) * textureDimensions(scene).x + u32(px.x));
    let aw = f32(accum[i + 3u]);
    if aw <= 0.0 {
        return scene_rgb;
    }
    let t = exp(-f32(accum[i + 4u]) / DEPTH_SCALE);
    let hair = vec3<f32>(f32(accum[i]), f32(accum[i + 1u]), f32(accum[i + 2u])) / aw;
    return hair * (1.0 - t) + scene_rgb * t;
}

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

// Without supersampling (the viewer's usual case): one load, no loop. On a software
// rasteriser this pass touches every output pixel, and the loop alone cost a third of it.
@fragment
fn fs_one(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let px = vec2<i32>(floor(p.xy));
    return encoded(with_hair(px, textureLoad(scene, px, 0).rgb));
}

@fragment
fn fs(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let f = i32(resolve.factor);
    let base = vec2<i32>(floor(p.xy)) * f;
    var sum = vec3<f32>(0.0);
    for (var y = 0; y < f; y++) {
        for (var x = 0; x < f; x++) {
            let px = base + vec2<i32>(x, y);
            sum += with_hair(px, textureLoad(scene, px, 0).rgb);
        }
    }
    return encoded(sum / f32(f * f));
}

// Below full resolution (the viewer's frame budget, as an artist's viewport lowers its
// resolution): each output pixel is the bilinear mix of the four scene pixels round its
// centre, each with its thin strands composited first.
@fragment
fn fs_scaled(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let q = p.xy * resolve.scale - 0.5;
    let base = vec2<i32>(floor(q));
    let f = q - floor(q);
    let c00 = scene_at(base);
    let c10 = scene_at(base + vec2<i32>(1, 0));
    let c01 = scene_at(base + vec2<i32>(0, 1));
    let c11 = scene_at(base + vec2<i32>(1, 1));
    return encoded(mix(mix(c00, c10, f.x), mix(c01, c11, f.x), f.y));
}

fn scene_at(px_in: vec2<i32>) -> vec3<f32> {
    let px = clamp(px_in, vec2<i32>(0), vec2<i32>(textureDimensions(scene)) - 1);
    return with_hair(px, textureLoad(scene, px, 0).rgb);
}

fn encoded(rgb: vec3<f32>) -> vec4<f32> {
    if resolve.encode_srgb != 0u {
        return vec4<f32>(linear_to_srgb(rgb), 1.0);
    }
    return vec4<f32>(rgb, 1.0);
}

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let lo = c * 12.92;
    let hi = 1.055 * pow(max(c, vec3<f32>(0.0)), vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}
