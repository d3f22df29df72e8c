// The External Force Field, sampled on the GPU: the f32 twin of `Eff::sample` in
// src/forces/eff.rs (read its docs for the grid, the outside force and the blend band).
// The globals it reads, `eff: EffGrid` (uniform) and `eff_cells: array<vec4<f32>>` (storage,
// one force per cell, xyz; x fastest), are the world's (common/world.wgsl, group 3) in every
// simulation kernel, and the probe's own in `systems::world::EFF_MODULE`.
// eff_field(p, sampling), p in world units and sampling 0 (nearest) or 1 (trilinear), is
// the field without the gust: kernels scale it by their substep's gust (several frames
// recorded in one submission each see their own). eff_force(p, sampling) is the field times
// the scale in `outside.w` (1 in the world; the probe `sample_on_gpu` writes its own).

// Twin of GpuEffGrid (tests/it/gpu_twins.rs checks it) in src/forces/eff.rs.
struct EffGrid {
    // xyz: the grid's min corner (world), w: the blend band outside it, in cells.
    origin: vec4<f32>,
    // xyz: cell edge per axis, w: unused.
    cell: vec4<f32>,
    // xyz: cells per axis, w: 1 when a field is present, 0 for none (force zero).
    dims: vec4<u32>,
    // xyz: the force outside the grid (unscaled), w: the gust scale now.
    outside: vec4<f32>,
}

fn eff_cell(i: vec3<u32>) -> vec3<f32> {
    return eff_cells[i.x + eff.dims.x * (i.y + eff.dims.y * i.z)].xyz;
}

// The grid's value at p, clamped to the border cells outside.
fn eff_inside(p: vec3<f32>, sampling: u32) -> vec3<f32> {
    let top = vec3<i32>(eff.dims.xyz) - vec3<i32>(1);
    if sampling == 0u {
        let q = floor((p - eff.origin.xyz) / eff.cell.xyz);
        let i = clamp(vec3<i32>(max(q, vec3<f32>(-1.0))), vec3<i32>(0), top);
        return eff_cell(vec3<u32>(i));
    }
    let q = (p - eff.origin.xyz) / eff.cell.xyz - vec3<f32>(0.5);
    let f = clamp(floor(q), vec3<f32>(0.0), vec3<f32>(max(top - vec3<i32>(1), vec3<i32>(0))));
    let i0 = vec3<u32>(f);
    let i1 = vec3<u32>(min(vec3<i32>(f) + vec3<i32>(1), top));
    let t = clamp(q - f, vec3<f32>(0.0), vec3<f32>(1.0));
    let x00 = mix(eff_cell(vec3<u32>(i0.x, i0.y, i0.z)), eff_cell(vec3<u32>(i1.x, i0.y, i0.z)), t.x);
    let x10 = mix(eff_cell(vec3<u32>(i0.x, i1.y, i0.z)), eff_cell(vec3<u32>(i1.x, i1.y, i0.z)), t.x);
    let x01 = mix(eff_cell(vec3<u32>(i0.x, i0.y, i1.z)), eff_cell(vec3<u32>(i1.x, i0.y, i1.z)), t.x);
    let x11 = mix(eff_cell(vec3<u32>(i0.x, i1.y, i1.z)), eff_cell(vec3<u32>(i1.x, i1.y, i1.z)), t.x);
    return mix(mix(x00, x10, t.y), mix(x01, x11, t.y), t.z);
}

// The field at p without the gust scale: the grid inside, blending to the outside force
// over the band beyond its faces.
fn eff_field(p: vec3<f32>, sampling: u32) -> vec3<f32> {
    if eff.dims.w == 0u {
        return vec3<f32>(0.0);
    }
    let hi = eff.origin.xyz + eff.cell.xyz * vec3<f32>(eff.dims.xyz);
    let out = max(eff.origin.xyz - p, vec3<f32>(0.0)) + max(p - hi, vec3<f32>(0.0));
    let w = min(length(out / eff.cell.xyz / eff.origin.w), 1.0);
    if w >= 1.0 {
        return eff.outside.xyz;
    }
    return mix(eff_inside(p, sampling), eff.outside.xyz, w);
}

// The field at p with the gust scale of this frame.
fn eff_force(p: vec3<f32>, sampling: u32) -> vec3<f32> {
    return eff_field(p, sampling) * eff.outside.w;
}
