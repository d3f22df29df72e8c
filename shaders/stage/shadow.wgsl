// The shadow pass's own kernels (src/stage/shadow.rs), after common/shadow.wgsl: the resolve
// turns the cast coverage into strands crossed (per column of the light-space box), and the
// probe evaluates `shadow_strands` and `shadow_opaque` at given points (the contract tests
// and `kami bench shadows` compare it with the f64 reference, src/stage/shadow.rs).

// SHADOW_FIXED and SHADOW_DEPTH_SCALE of common/shadow_cast.wgsl, and src/gpu/shadow.rs
// (tests/it/gpu_twins.rs checks them).
const FIXED: f32 = 4096.0;
const DEPTH_SCALE: f32 = 16777215.0;

@group(1) @binding(0) var<storage, read> cast_in: array<u32>;
@group(1) @binding(1) var<storage, read_write> resolved: array<f32>;

// One invocation per column: the volume's slices summed along the light (each cell gets the
// strands before it and half of its own); deep opacity's first depth (world, past the box's
// light side; a texel no strand reached gets the box's far side) and cumulative layers.
// With a skin map, invocation c also turns texel c's nearest skin into a depth (world).
@compute @workgroup_size(64)
fn resolve(@builtin(global_invocation_id) id: vec3<u32>) {
    let columns = u32(frame.shadow.dims.x * frame.shadow.dims.y);
    let c = id.x;
    if frame.shadow.layered.y > 0.5 && c < SHADOW_SKIN * SHADOW_SKIN {
        let at = u32(frame.shadow.layered.z) + c;
        resolved[at] = (DEPTH_SCALE - f32(cast_in[at])) / DEPTH_SCALE * (2.0 * frame.shadow.axis_u.w);
    }
    if c >= columns {
        return;
    }
    if frame.shadow.axis_v.w < 0.5 {
        var sum = 0.0;
        let nz = u32(frame.shadow.dims.z);
        for (var z = 0u; z < nz; z++) {
            let n = f32(cast_in[z * columns + c]) / FIXED;
            resolved[z * columns + c] = sum + 0.5 * n;
            sum += n;
        }
        return;
    }
    let two_half = 2.0 * frame.shadow.axis_u.w;
    resolved[c * 5u] = (DEPTH_SCALE - f32(cast_in[c])) / DEPTH_SCALE * two_half;
    var sum = 0.0;
    for (var k = 0u; k < 4u; k++) {
        sum += f32(cast_in[columns * (1u + k) + c]) / FIXED;
        resolved[c * 5u + 1u + k] = sum;
    }
}

// The probe's own group 2 (group 1 is the resolve's: no two globals share a binding).
@group(2) @binding(0) var<storage, read> probe_points: array<vec4<f32>>;
@group(2) @binding(1) var<storage, read_write> probe_out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn probe(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&probe_points) {
        return;
    }
    let p = probe_points[id.x].xyz;
    probe_out[id.x] = vec4<f32>(shadow_strands(p), shadow_opaque(p), shadow_layered(p), 0.0);
}
