// The External Force Field, sampled on the GPU. STUB: the EFF helper fills it.
// Contract: a kernel that samples the EFF concatenates this file and declares
//   var<uniform> eff: EffGrid;                       (any group/binding it likes)
//   var<storage, read> eff_cells: array<vec4<f32>>;  (one force per cell, xyz)
// and calls eff_force(p, sampling) with p in world units and sampling 0 (nearest) or 1
// (trilinear). The force already carries the field's strength at this frame.

struct EffGrid {
    // xyz: the grid's min corner (world), w: cell edge length.
    origin: vec4<f32>,
    // xyz: cells per axis, w: 1 when a field is present, 0 for none (force zero).
    dims: vec4<u32>,
    // xyz: where the wind comes from, w: strength of the force outside the grid.
    source: vec4<f32>,
    // xyz: the point the outside force blows toward (the head), w: strength scale now.
    target_scale: vec4<f32>,
}

fn eff_force(p: vec3<f32>, sampling: u32) -> vec3<f32> {
    return vec3<f32>(0.0);
}
