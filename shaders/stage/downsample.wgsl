// Supersampling resolve: each output pixel is the mean of its factor x factor block of the
// (already MSAA-resolved) scene texture, in linear colour. Anjyo's oversampling for hair
// thinner than a pixel. Into a non-sRGB output (a window shared with egui) the sRGB
// encoding is done here.

struct Resolve {
    factor: u32,
    // 1: the output is not an sRGB format, so encode here.
    encode_srgb: u32,
    _p1: u32,
    _p2: u32,
}

@group(0) @binding(0) var scene: texture_2d<f32>;
@group(0) @binding(1) var<uniform> resolve: Resolve;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

@fragment
fn fs(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let f = i32(resolve.factor);
    let base = vec2<i32>(floor(p.xy)) * f;
    var sum = vec4<f32>(0.0);
    for (var y = 0; y < f; y++) {
        for (var x = 0; x < f; x++) {
            sum += textureLoad(scene, base + vec2<i32>(x, y), 0);
        }
    }
    let rgb = (sum / f32(f * f)).rgb;
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
