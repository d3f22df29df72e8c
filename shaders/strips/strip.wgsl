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
}

// Twin of GpuRibbonVertex (tests/it/gpu_twins.rs checks it) in src/systems/strips/ribbon.rs.
struct RibbonVertex {
    // xyz world position, w u (0 or 1, across)
    position: vec4<f32>,
    // xyz unit tangent, w v (0 root to 1 tip)
    tangent: vec4<f32>,
}
