// One strip and one ribbon vertex, as ribbon.wgsl writes them and draw.wgsl and cast.wgsl
// read them: one definition for the three (included before each).

// Twin of GpuStripInfo (tests/it/gpu_twins.rs checks it) in src/systems/strips/ribbon.rs.
struct StripInfo {
    // xyz side vector at rest (head rest frame), w root width
    side: vec4<f32>,
    // xyz outward head normal at the root (head rest frame), w tip width
    normal: vec4<f32>,
    // rgb linear layer colour
    color: vec4<f32>,
    // x control points, y layer
    counts: vec4<u32>,
    // The fibre-area index of the sky hidden from the strip at v = k / 7 (src/systems/strips/
    // sky.rs; strip_sky interpolates it): the physical mode's ambient reads it.
    sky: array<vec4<f32>, 2>,
}

// The strip's hidden-sky index at v (0 root .. 1 tip), linear between the baked points.
fn strip_sky(s: StripInfo, v: f32) -> f32 {
    let x = clamp(v, 0.0, 1.0) * 7.0;
    let k = min(u32(x), 6u);
    let f = x - f32(k);
    let a = s.sky[k / 4u][k % 4u];
    let b = s.sky[(k + 1u) / 4u][(k + 1u) % 4u];
    return mix(a, b, f);
}

// Twin of GpuRibbonVertex (tests/it/gpu_twins.rs checks it) in src/systems/strips/ribbon.rs.
struct RibbonVertex {
    // xyz world position, w u (0 or 1, across)
    position: vec4<f32>,
    // xyz unit tangent, w v (0 root to 1 tip)
    tangent: vec4<f32>,
}
