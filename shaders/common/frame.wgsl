// Per-frame view and light. Twin of GpuFrame in src/gpu/gpu_data.rs.
struct Frame {
    view_proj: mat4x4<f32>,
    eye: vec4<f32>,
    // xyz towards the light, w intensity I_s
    light_dir: vec4<f32>,
    // rgb light colour, w ambient intensity I_a
    light_color: vec4<f32>,
    // width, height (samples), 1/width, 1/height
    viewport: vec4<f32>,
    // x focal length in samples, y narrowest strand (samples), z width scale (level of
    // detail), w MSAA samples (1 without)
    raster: vec4<f32>,
    // x: 1 to show the segments the pseudo-force acted on; y: samples per output pixel
    flags: vec4<f32>,
    // The hair shadows' light-space box (common/shadow.wgsl, src/stage/shadow.rs).
    shadow: ShadowParams,
}

// Twin of GpuShadow (tests/it/gpu_twins.rs checks it) in src/gpu/shadow.rs.
struct ShadowParams {
    // xyz centre of the light-space box; w 1 while shadows are on
    center: vec4<f32>,
    // xyz unit axis across the light; w half the box's size (world)
    axis_u: vec4<f32>,
    // xyz the other axis across; w method (0 volume, 1 deep opacity)
    axis_v: vec4<f32>,
    // xyz unit towards the light; w absorption per strand
    axis_l: vec4<f32>,
    // x, y cells across; z slices (volume) or layers (deep opacity); w 1 with a head
    dims: vec4<f32>,
    // deep opacity: where each layer ends, world distance behind the first depth
    layers: vec4<f32>,
    // x how far towards the light a point on a layered strand reads the structure
    // (shadow_layered), world; y 1 with a skin map, z its first word, w its depth bias
    // (world; shadow_skin)
    layered: vec4<f32>,
    // world to the head ellipsoid's unit sphere (shadow_opaque)
    head_inv: mat4x4<f32>,
}


@group(0) @binding(0) var<uniform> frame: Frame;

// The key light's irradiance on a plane facing it, for the physical mode (docs/shading.md):
// Kami's light unit is the radiance a white Lambertian facing it reflects (the head's
// shading), so E = pi I_s; Mitsuba's reference light in `kami bench look` has the same.
fn hair_irradiance() -> f32 {
    return 3.14159265358979 * frame.light_dir.w;
}
