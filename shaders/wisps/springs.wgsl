// Sakai's mass springs (section 7), the f32 twin of src/systems/wisps/springs.rs (read its
// header for the lattice, eq 23 and our collision). One invocation per mass point; forces
// are gathered over each point's CSR list of springs (no atomics). One substep is four
// dispatches for RK4 (rk1..rk4, stage states ping-ponged between scratch regions A and B so
// no dispatch writes what its neighbours read) or two for semi-implicit Euler (kick, drift).
// Kinematic points (inverse mass 0) take the head pose of the stage time.
// The forces are the scene's shared ones, as accelerations: gravity and the keyed uniform
// wind per substep (the slot), the EFF sampled at the point (forces/eff.wgsl, eff_field,
// trilinear) times the gust scale of the stage's time. The head hull is the ellipsoid or a
// mesh head's SDF (common/sdf.wgsl; SDF_HEAD false compiles the SDF path out).

// Passed by the Rust side (`gpu::WORKGROUP`, `springs::NEWTON`).
override WORKGROUP: u32;
override NEWTON: u32;

// Twin of GpuSpringParams (tests/it/gpu_twins.rs checks it) in src/systems/wisps/springs_gpu.rs.
struct Params {
    count: u32,
    row_stride: u32,
    collide: u32,
    _p0: u32,
    // x step length (seconds), y c_damp
    step: vec4<f32>,
}

// One substep's slot (twin of GpuSubstep): indices into the world's samples (world_steps,
// common/world.wgsl). The head's pose at the substep's start, middle and end is
// world_steps[x + k].head (k = 0, 1, 2; the half-substep poses of the recording, so
// neighbouring substeps share an entry); gravity plus the keyed wind at the start, middle and
// end is world_steps[y + k].force.xyz, w the EFF's gust scale there.
struct Substep {
    sample: vec4<u32>,
}

// Twin of GpuMassPoint (tests/it/gpu_twins.rs checks it).
struct MassPoint {
    // xyz rest position (head rest frame), w inverse mass (0: kinematic)
    rest: vec4<f32>,
    // x first spring, y one past the last
    edges: vec4<u32>,
}

// Twin of GpuEdge (tests/it/gpu_twins.rs checks it).
struct Edge {
    other: u32,
    rest: f32,
    k: f32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<uniform> substep: Substep;
@group(0) @binding(2) var<storage, read> points: array<MassPoint>;
@group(0) @binding(3) var<storage, read> edges: array<Edge>;
// xyz world position; primaries first (the renderer reads them).
@group(0) @binding(4) var<storage, read_write> pos: array<vec4<f32>>;
// Regions of `count` entries: 0 velocity, 1 A.x, 2 A.v, 3 B.x, 4 B.v, 5 sum of k_x,
// 6 sum of k_v.
@group(0) @binding(5) var<storage, read_write> scratch: array<vec4<f32>>;
// The scene's EFF, the head's field and the samples of the world: group 3 (common/world.wgsl).

const VEL: u32 = 0u;
const AX: u32 = 1u;
const AV: u32 = 2u;
const BX: u32 = 3u;
const BV: u32 = 4u;
const SX: u32 = 5u;
const SV: u32 = 6u;

fn at(region: u32, p: u32) -> u32 {
    return region * params.count + p;
}

fn head(k: u32) -> mat4x4<f32> {
    return world_steps[substep.sample.x + k].head;
}

fn point_index(id: vec3<u32>) -> u32 {
    return id.x + id.y * params.row_stride;
}

fn posed(p: u32, m: mat4x4<f32>) -> vec4<f32> {
    return vec4<f32>((m * vec4<f32>(points[p].rest.xyz, 1.0)).xyz, 1.0);
}

// Neighbours' positions come from `pos` (src 0) or a scratch region.
fn neighbour(src: u32, o: u32) -> vec3<f32> {
    if src == 0u {
        return pos[o].xyz;
    }
    return scratch[at(src, o)].xyz;
}

// The shared fields at world x at stage time k (0 start, 1 middle, 2 end): gravity, the
// keyed wind and the EFF (springs::field_accel).
fn field_accel(x: vec3<f32>, k: u32) -> vec3<f32> {
    let f = world_steps[substep.sample.y + k].force;
    return f.xyz + eff_field(x, 1u) * f.w;
}

// Eq 23 over the mass: spring forces, damping, and the shared fields at stage time k.
fn accel(p: u32, xp: vec3<f32>, vp: vec3<f32>, src: u32, k: u32) -> vec3<f32> {
    let pt = points[p];
    var f = vec3<f32>(0.0);
    for (var e = pt.edges.x; e < pt.edges.y; e++) {
        let ed = edges[e];
        let d = neighbour(src, ed.other) - xp;
        let l = length(d);
        if l > 0.0 {
            f += d * (ed.k * (l - ed.rest) / l);
        }
    }
    return (f - params.step.y * vp) * pt.rest.w + field_accel(xp, k);
}

// Head-local point of a rigid pose.
fn unpose(m: mat4x4<f32>, x: vec3<f32>) -> vec3<f32> {
    let r = mat3x3<f32>(m[0].xyz, m[1].xyz, m[2].xyz);
    return transpose(r) * (x - m[3].xyz);
}

// Ours (see springs::push_out and springs::collide): out of the posed hull (ellipsoid or
// SDF) by Newton steps along the gradient, without velocity into the surface relative to
// the moving head.
fn collide(x: ptr<function, vec3<f32>>, v: ptr<function, vec3<f32>>) {
    if params.collide == 0u {
        return;
    }
    let h0 = head(0u);
    let h1 = head(2u);
    let hl = world_hull();
    var q = unpose(h1, *x);
    if head_eval(hl, q) >= 0.0 {
        return;
    }
    let eps = head_eps(hl);
    let goal = 1.5 * eps;
    for (var i = 0u; i < NEWTON; i++) {
        let e = head_eval(hl, q);
        if e >= eps && e <= 2.0 * eps {
            break;
        }
        let g = head_gradient(hl, q);
        let g2 = dot(g, g);
        if g2 < 1e-24 {
            if hl.sdf {
                q += vec3<f32>(0.0, goal - e, 0.0);
            } else {
                q = hl.e.center + vec3<f32>(0.0, hl.e.radii.y, 0.0);
            }
            continue;
        }
        q -= g * ((e - goal) / g2);
    }
    if !hl.sdf {
        let e = hull_eval(hl.e, q);
        if e < EPS_OUT {
            q = hl.e.center + (q - hl.e.center) * sqrt((1.0 + goal) / max(e + 1.0, 1e-12));
        }
    }
    *x = (h1 * vec4<f32>(q, 1.0)).xyz;
    let n = normalize((h1 * vec4<f32>(head_gradient(hl, q), 0.0)).xyz);
    let surface = ((h1 - h0) * vec4<f32>(q, 1.0)).xyz / params.step.x;
    let into = dot(*v - surface, n);
    if into < 0.0 {
        *v -= into * n;
    }
}

// Kinematic points to the pose at the start of the recording's first substep.
@compute @workgroup_size(WORKGROUP)
fn pin(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = point_index(id);
    if p >= params.count || points[p].rest.w != 0.0 {
        return;
    }
    pos[p] = posed(p, head(0u));
}

@compute @workgroup_size(WORKGROUP)
fn rk1(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = point_index(id);
    if p >= params.count {
        return;
    }
    if points[p].rest.w == 0.0 {
        scratch[at(AX, p)] = posed(p, head(1u));
        return;
    }
    let h = params.step.x;
    let x0 = pos[p].xyz;
    let v0 = scratch[at(VEL, p)].xyz;
    let a = accel(p, x0, v0, 0u, 0u);
    scratch[at(SX, p)] = vec4<f32>(v0, 0.0);
    scratch[at(SV, p)] = vec4<f32>(a, 0.0);
    scratch[at(AX, p)] = vec4<f32>(x0 + 0.5 * h * v0, 1.0);
    scratch[at(AV, p)] = vec4<f32>(v0 + 0.5 * h * a, 0.0);
}

@compute @workgroup_size(WORKGROUP)
fn rk2(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = point_index(id);
    if p >= params.count {
        return;
    }
    if points[p].rest.w == 0.0 {
        scratch[at(BX, p)] = posed(p, head(1u));
        return;
    }
    let h = params.step.x;
    let vs = scratch[at(AV, p)].xyz;
    let a = accel(p, scratch[at(AX, p)].xyz, vs, AX, 1u);
    scratch[at(SX, p)] += vec4<f32>(2.0 * vs, 0.0);
    scratch[at(SV, p)] += vec4<f32>(2.0 * a, 0.0);
    scratch[at(BX, p)] = vec4<f32>(pos[p].xyz + 0.5 * h * vs, 1.0);
    scratch[at(BV, p)] = vec4<f32>(scratch[at(VEL, p)].xyz + 0.5 * h * a, 0.0);
}

@compute @workgroup_size(WORKGROUP)
fn rk3(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = point_index(id);
    if p >= params.count {
        return;
    }
    if points[p].rest.w == 0.0 {
        scratch[at(AX, p)] = posed(p, head(2u));
        return;
    }
    let h = params.step.x;
    let vs = scratch[at(BV, p)].xyz;
    let a = accel(p, scratch[at(BX, p)].xyz, vs, BX, 1u);
    scratch[at(SX, p)] += vec4<f32>(2.0 * vs, 0.0);
    scratch[at(SV, p)] += vec4<f32>(2.0 * a, 0.0);
    scratch[at(AX, p)] = vec4<f32>(pos[p].xyz + h * vs, 1.0);
    scratch[at(AV, p)] = vec4<f32>(scratch[at(VEL, p)].xyz + h * a, 0.0);
}

@compute @workgroup_size(WORKGROUP)
fn rk4(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = point_index(id);
    if p >= params.count {
        return;
    }
    if points[p].rest.w == 0.0 {
        pos[p] = posed(p, head(2u));
        return;
    }
    let h = params.step.x;
    let vs = scratch[at(AV, p)].xyz;
    let a = accel(p, scratch[at(AX, p)].xyz, vs, AX, 2u);
    var x = pos[p].xyz + h / 6.0 * (scratch[at(SX, p)].xyz + vs);
    var v = scratch[at(VEL, p)].xyz + h / 6.0 * (scratch[at(SV, p)].xyz + a);
    collide(&x, &v);
    pos[p] = vec4<f32>(x, 1.0);
    scratch[at(VEL, p)] = vec4<f32>(v, 0.0);
}

// Semi-implicit Euler, first half: new velocities from the forces at the step start.
@compute @workgroup_size(WORKGROUP)
fn kick(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = point_index(id);
    if p >= params.count || points[p].rest.w == 0.0 {
        return;
    }
    let v0 = scratch[at(VEL, p)].xyz;
    let a = accel(p, pos[p].xyz, v0, 0u, 0u);
    scratch[at(VEL, p)] = vec4<f32>(v0 + params.step.x * a, 0.0);
}

// Second half: positions with the new velocities, then the collision.
@compute @workgroup_size(WORKGROUP)
fn drift(@builtin(global_invocation_id) id: vec3<u32>) {
    let p = point_index(id);
    if p >= params.count {
        return;
    }
    if points[p].rest.w == 0.0 {
        pos[p] = posed(p, head(2u));
        return;
    }
    var v = scratch[at(VEL, p)].xyz;
    var x = pos[p].xyz + params.step.x * v;
    collide(&x, &v);
    pos[p] = vec4<f32>(x, 1.0);
    scratch[at(VEL, p)] = vec4<f32>(v, 0.0);
}
