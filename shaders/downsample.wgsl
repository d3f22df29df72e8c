// Supersampling resolve: each output pixel is the mean of its factor x factor block of the
// (already MSAA-resolved) scene texture, in linear colour. Anjyo's oversampling for hair
// thinner than a pixel.

struct Resolve {
    factor: u32,
    _p0: u32,
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
    return vec4<f32>((sum / f32(f * f)).rgb, 1.0);
}
