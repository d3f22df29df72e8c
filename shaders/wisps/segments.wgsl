// The wisps' curve segments and their capsules, as curves.wgsl writes them and tiles.wgsl,
// march.wgsl and cast.wgsl read them: one definition for all four (included before each).

// Twin of GpuSegment (tests/it/gpu_twins.rs checks it) in src/systems/wisps/march.rs.
struct Segment {
    // xyz control point; c0.w r0, c1.w r1, c2.w w0, c3.w w1
    c0: vec4<f32>,
    c1: vec4<f32>,
    c2: vec4<f32>,
    c3: vec4<f32>,
    // AABB of the control points; lo.w the Lipschitz bound, hi.w the wisp (as f32)
    lo: vec4<f32>,
    hi: vec4<f32>,
}

// Twin of GpuCapsule (tests/it/gpu_twins.rs checks it) in src/systems/wisps/march.rs.
struct Capsule {
    // xyz c0, w the influence radius
    a: vec4<f32>,
    // xyz c3, w the hit radius (< 0: never holds a hit)
    b: vec4<f32>,
}
