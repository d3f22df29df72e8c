// The wisps' meshed path (`block::WispDraw::Mesh`): the surface polygonised on the CPU
// (`src/systems/wisps/mesh.rs`: surface nets, each vertex moved onto the exact surface with
// its normal there) drawn as opaque triangles with the march's toon shading (`toon_at`,
// shaders/wisps/toon.wgsl: tones, halo, rim, toon shadows), and the outline as an inverted
// hull: the same mesh pushed out along its normals by the march's outline shell
// (`eps_per_t` times the distance from the eye times the vertex's outline scale) with its
// front faces culled, so only its rim shows round the silhouettes, in the outline colour.

struct MeshUniform {
    // The mesh's frame to world: the head's pose for still wisps (meshed once in the head's
    // frame), identity for moving ones (meshed in world space).
    model: mat4x4<f32>,
    // x outline half-width per unit distance from the eye (the march's `eps_per_t`), yzw
    // unused
    outline: vec4<f32>,
}

@group(1) @binding(0) var<uniform> draw: Draw;
@group(1) @binding(1) var<uniform> mesh: MeshUniform;

struct VIn {
    // xyz, w the outline scale of the densest wisp at the vertex
    @location(0) pos: vec4<f32>,
    // the exact field's outward normal, w the shell curvature (`mesh::shell_depth`)
    @location(1) normal: vec4<f32>,
}

struct VOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

fn placed(v: VIn) -> VOut {
    var out: VOut;
    out.world = (mesh.model * vec4<f32>(v.pos.xyz, 1.0)).xyz;
    out.normal = normalize((mesh.model * vec4<f32>(v.normal.xyz, 0.0)).xyz);
    out.clip = frame.view_proj * vec4<f32>(out.world, 1.0);
    return out;
}

@vertex
fn vs(v: VIn) -> VOut {
    return placed(v);
}

// Toon colour seen along the pixel's ray, as the march shades its hit (`toon_at(n, -dir)`).
@fragment
fn fs(in: VOut) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let v = normalize(frame.eye.xyz - in.world);
    toon_shadow = shadow_toon(in.world);
    return vec4<f32>(toon_at(n, v), 1.0);
}

// How far outside the surface the march's shell reaches for a half-width `eps`, with the
// field's curvature over its gradient `kappa` along the normal (`mesh::shell_depth`).
fn shell_depth(eps: f32, kappa: f32) -> f32 {
    let a = kappa * eps;
    if (a < 1e-4) {
        return eps;
    }
    let b = 1.0 + a;
    return eps * (b - sqrt(max(b * b - 2.0 * a, 0.0))) / a;
}

// The outline hull: each vertex out along its normal to the edge of the march's shell.
@vertex
fn vs_outline(v: VIn) -> VOut {
    var out = placed(v);
    let eps = mesh.outline.x * length(out.world - frame.eye.xyz) * v.pos.w;
    out.world += out.normal * shell_depth(eps, v.normal.w);
    out.clip = frame.view_proj * vec4<f32>(out.world, 1.0);
    return out;
}

@fragment
fn fs_outline(in: VOut) -> @location(0) vec4<f32> {
    return vec4<f32>(draw.outline.rgb, 1.0);
}
