// Kazama's strips in motion (eq 1, eq 2): the f32 twin of src/systems/strips/dynamics.rs
// (read its header for the chain, our reading of the coefficients and forces, and the
// exponential midpoint integrator). One invocation per strip; one dispatch per step, the
// step's record picked by the dynamic `slot`. The propagators (the exact damped-oscillator
// flow over a full and a half step) are computed in f64 on the CPU per joint and uploaded;
// the head poses, the head-acceleration maps, the uniform wind and the extra forces' ramps
// per step are too. Follows the world (common/world.wgsl at group 3: forces/eff.wgsl's
// eff_field, common/ellipsoid.wgsl and common/sdf.wgsl, the mesh head's field in `sdf_data`,
// trilinear, as Rig::step reads it through scene::hull::HeadHull; world.hull_center.w = 1
// selects it).
//
// Loops per invocation and dispatch stay far below llvmpipe's 65,535 (the Rust side refuses
// strips with too many sticks): 3 passes over the sticks, 2 force sums over the extras, and
// at most one hull push-out per stick.

override WORKGROUP: u32;

// Twin of GpuParams (tests/it/gpu_twins.rs checks it) in src/systems/strips/dynamics_gpu.rs.
struct Params {
    count: u32,
    stride: u32,
    row_stride: u32,
    extras: u32,
    // xyz 0 (gravity is in the world's samples), w spring k
    gravity: vec4<f32>,
    // x collision kappa, y Psi at the surface for kappa = 1 (the hull is the world's)
    collision: vec4<f32>,
    // x EFF sampling (0 nearest, 1 trilinear)
    flags: vec4<u32>,
    // xyz centre (world), w radius
    extra_center: array<vec4<f32>, 16>,
    // xyz acceleration
    extra_accel: array<vec4<f32>, 16>,
}

// One 256-byte slot per step of a recording: x is the step's index in `steps`.
struct Slot {
    index: vec4<u32>,
}

// Twin of GpuStep (tests/it/gpu_twins.rs checks it).
struct Step {
    // The map from a world point to the head frame's acceleration there, at the step's
    // start (0) and middle (1).
    k0: mat4x4<f32>,
    k1: mat4x4<f32>,
    // x: the world's sample (world_steps) at the step's start, x + 1 its middle, x + 2 its
    // end: the head's pose, gravity plus the keyed wind, the EFF's gust scale.
    samples: vec4<u32>,
    // r(frame) of every extra force at the start and the middle.
    ramp0: array<vec4<f32>, 4>,
    ramp1: array<vec4<f32>, 4>,
}

// Twin of GpuStrip (tests/it/gpu_twins.rs checks it).
struct Strip {
    // xyz root (head rest frame), w Psi's band
    root: vec4<f32>,
    // x first joint, y sticks
    info: vec4<u32>,
}

// Twin of GpuJoint (tests/it/gpu_twins.rs checks it).
struct Joint {
    // Columns of the joint's reference frame in the parent's body frame; c0.w stick length,
    // c1.w outboard moment M_j.
    c0: vec4<f32>,
    c1: vec4<f32>,
    c2: vec4<f32>,
    // xy rest angles
    rest: vec4<f32>,
    // xyz rest position of the stick's outer point (head rest frame): the spring's goal
    goal: vec4<f32>,
    // Propagator matrices (m00, m01, m10, m11) of the full and the half step.
    full_step: vec4<f32>,
    half_step: vec4<f32>,
    // (fq, fv) of the full step, then of the half step.
    forced: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<uniform> slot: Slot;
@group(0) @binding(2) var<storage, read> strips: array<Strip>;
@group(0) @binding(3) var<storage, read> joints: array<Joint>;
@group(0) @binding(4) var<storage, read> steps: array<Step>;
// Per joint: (theta, phi, theta', phi').
@group(0) @binding(5) var<storage, read_write> state: array<vec4<f32>>;
// Per joint, 3 entries: the DOFs' rotation axes, the half-step angles.
@group(0) @binding(6) var<storage, read_write> scratch: array<vec4<f32>>;
// World control points, strip * stride + k, w = 1 (the ribbons read them).
@group(0) @binding(7) var<storage, read_write> pos: array<vec4<f32>>;
// The EFF and the head's field: the world at group 3 (common/world.wgsl).

const TAU: f32 = 6.28318530717959;

// Rz(phi) Ry(theta): e_z to (sin t cos p, sin t sin p, cos t).
fn rot(theta: f32, phi: f32) -> mat3x3<f32> {
    let st = sin(theta);
    let ct = cos(theta);
    let sp = sin(phi);
    let cp = cos(phi);
    return mat3x3<f32>(
        vec3<f32>(cp * ct, sp * ct, -st),
        vec3<f32>(-sp, cp, 0.0),
        vec3<f32>(cp * st, sp * st, ct),
    );
}

fn frame_of(j: Joint) -> mat3x3<f32> {
    return mat3x3<f32>(j.c0.xyz, j.c1.xyz, j.c2.xyz);
}

fn rotation(m: mat4x4<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(m[0].xyz, m[1].xyz, m[2].xyz);
}

fn posed(m: mat4x4<f32>, x: vec3<f32>) -> vec3<f32> {
    return (m * vec4<f32>(x, 1.0)).xyz;
}

// Head-local point of a rigid pose.
fn unpose(m: mat4x4<f32>, x: vec3<f32>) -> vec3<f32> {
    return transpose(rotation(m)) * (x - m[3].xyz);
}

fn hull() -> HeadHull {
    return world_hull();
}

// Psi (see dynamics::collision_accel), head-local.
fn collision(local: vec3<f32>, band: f32) -> vec3<f32> {
    let kappa = params.collision.x;
    if kappa <= 0.0 || band <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = hull();
    let g = head_gradient(h, local);
    let gl = length(g);
    var d: f32;
    var n = vec3<f32>(0.0, 1.0, 0.0);
    if h.sdf {
        // The field's value over its gradient's length; at a flat spot the value, up.
        d = head_eval(h, local);
        if gl > 1e-12 {
            d /= gl;
            n = g / gl;
        }
    } else {
        let min_r = min(h.e.radii.x, min(h.e.radii.y, h.e.radii.z));
        d = -min_r;
        if gl > 1e-12 / min_r {
            d = head_eval(h, local) / gl;
            n = g / gl;
        }
    }
    let u = (band - d) / band;
    if u <= 0.0 {
        return vec3<f32>(0.0);
    }
    return n * (kappa * params.collision.y * u * u);
}

fn ramp(st: u32, e: u32, mid: bool) -> f32 {
    if mid {
        return steps[st].ramp1[e / 4u][e % 4u];
    }
    return steps[st].ramp0[e / 4u][e % 4u];
}

// Eq 2 at world x: gravity, wind (keyed + EFF), head motion, spring to `goal`, Psi, extras.
fn accel(x: vec3<f32>, goal: vec3<f32>, band: f32, st: u32, mid: bool) -> vec3<f32> {
    var k = steps[st].k0;
    if mid {
        k = steps[st].k1;
    }
    let w = world_steps[steps[st].samples.x + u32(mid)];
    let m = w.head;
    // force.w: the EFF's gust scale at this step's time (several frames may be recorded in
    // one submission, so the scale travels with the sample, not in the EFF's uniform).
    var a = w.force.xyz + eff_field(x, params.flags.x) * w.force.w;
    a -= (k * vec4<f32>(x, 1.0)).xyz;
    let spring = params.gravity.w;
    if spring > 0.0 {
        a -= spring * (x - posed(m, goal));
    }
    if params.collision.x > 0.0 {
        a += rotation(m) * collision(unpose(m, x), band);
    }
    for (var e = 0u; e < params.extras; e++) {
        let r = ramp(st, e, mid);
        let c = params.extra_center[e];
        let u2 = dot(x - c.xyz, x - c.xyz) / (c.w * c.w);
        if r > 0.0 && u2 < 1.0 {
            let w = 1.0 - u2;
            a += params.extra_accel[e].xyz * (r * w * w * w);
        }
    }
    return a;
}

// Forward kinematics of a strip under pose m from the state's angles (half = false) or the
// half-step angles: points into `pos`, rotation axes into `scratch`.
fn chain(first: u32, n: u32, base: u32, root: vec3<f32>, m: mat4x4<f32>, use_half: bool) {
    var parent = rotation(m);
    var x = posed(m, root);
    pos[base] = vec4<f32>(x, 1.0);
    for (var j = 0u; j < n; j++) {
        let jt = joints[first + j];
        let f = parent * frame_of(jt);
        var q = state[first + j].xy;
        if use_half {
            q = scratch[3u * (first + j) + 2u].xy;
        }
        let b = f * rot(q.x, q.y);
        x += jt.c0.w * b[2];
        pos[base + j + 1u] = vec4<f32>(x, 1.0);
        scratch[3u * (first + j)] = vec4<f32>(f * vec3<f32>(-sin(q.y), cos(q.y), 0.0), 0.0);
        scratch[3u * (first + j) + 1u] = vec4<f32>(f[2], 0.0);
        parent = b;
    }
}

// The exact flow: y = (q - rest, q'), forcing f.
fn advance(pm: vec4<f32>, fq: f32, fv: f32, y: vec2<f32>, f: f32) -> vec2<f32> {
    return vec2<f32>(pm.x * y.x + pm.y * y.y + fq * f, pm.z * y.x + pm.w * y.y + fv * f);
}

// Backward sum of the outboard torques; the half step (mid = false) writes the half-step
// angles, the full step (mid = true) the new state.
fn forces_and_step(first: u32, n: u32, base: u32, band: f32, st: u32, mid: bool) {
    var sum = vec3<f32>(0.0);
    var torque = vec3<f32>(0.0);
    for (var jj = 0u; jj < n; jj++) {
        let j = n - 1u - jj;
        let jt = joints[first + j];
        let x1 = pos[base + j + 1u].xyz;
        sum += accel(x1, jt.goal.xyz, band, st, mid);
        torque += cross(x1 - pos[base + j].xyz, sum);
        let f = vec2<f32>(
            dot(scratch[3u * (first + j)].xyz, torque),
            dot(scratch[3u * (first + j) + 1u].xyz, torque),
        ) / jt.c1.w;
        let s = state[first + j];
        let yt = vec2<f32>(s.x - jt.rest.x, s.z);
        let yp = vec2<f32>(s.y - jt.rest.y, s.w);
        if mid {
            let t = advance(jt.full_step, jt.forced.x, jt.forced.y, yt, f.x);
            let p = advance(jt.full_step, jt.forced.x, jt.forced.y, yp, f.y);
            state[first + j] = vec4<f32>(jt.rest.x + t.x, jt.rest.y + p.x, t.y, p.y);
        } else {
            let t = advance(jt.half_step, jt.forced.z, jt.forced.w, yt, f.x);
            let p = advance(jt.half_step, jt.forced.z, jt.forced.w, yp, f.y);
            scratch[3u * (first + j) + 2u] = vec4<f32>(jt.rest.x + t.x, jt.rest.y + p.x, 0.0, 0.0);
        }
    }
}

fn wrap(x: f32) -> f32 {
    return x - TAU * round(x / TAU);
}

// Of (a.x, a.y) and (-a.x, a.y + pi), modulo 2 pi, the pair nearest `old`.
fn nearest_angles(a: vec2<f32>, old: vec2<f32>) -> vec2<f32> {
    let c1 = vec2<f32>(old.x + wrap(a.x - old.x), old.y + wrap(a.y - old.y));
    let c2 = vec2<f32>(old.x + wrap(-a.x - old.x), old.y + wrap(a.y + PI - old.y));
    let d1 = dot(c1 - old, c1 - old);
    let d2 = dot(c2 - old, c2 - old);
    return select(c1, c2, d2 < d1);
}

// Keep the control points out of the head (see Rig::constrain) and write the final points.
fn constrain(first: u32, n: u32, base: u32, root: vec3<f32>, m: mat4x4<f32>) {
    let h = hull();
    let r = rotation(m);
    var parent = r;
    var x = posed(m, root);
    pos[base] = vec4<f32>(x, 1.0);
    var prev = vec3<f32>(0.0);
    for (var j = 0u; j < n; j++) {
        let jt = joints[first + j];
        let f = parent * frame_of(jt);
        var s = state[first + j];
        var b = f * rot(s.x, s.y);
        var next = x + jt.c0.w * b[2];
        let local = unpose(m, next);
        if head_eval(h, local) < 0.0 {
            let pivot = unpose(m, x);
            var a0 = head_normal(h, pivot);
            if j > 0u {
                a0 = transpose(r) * prev;
            }
            let out = head_push_out(h, pivot, a0, local, jt.c0.w);
            var d = r * (out - pivot);
            let dl = length(d);
            if dl > 0.0 {
                d /= dl;
            } else {
                d = b[2];
            }
            let ang = vec2<f32>(acos(clamp(dot(f[2], d), -1.0, 1.0)), atan2(dot(f[1], d), dot(f[0], d)));
            let q = nearest_angles(ang, s.xy);
            b = f * rot(q.x, q.y);
            next = x + jt.c0.w * b[2];
            let arm = next - x;
            let jt_ = cross(f * vec3<f32>(-sin(q.y), cos(q.y), 0.0), arm);
            let jp = cross(f[2], arm);
            let normal = r * head_normal(h, out);
            let g = vec2<f32>(dot(normal, jt_), dot(normal, jp));
            var v = s.zw;
            let vn = dot(g, v);
            let g2 = dot(g, g);
            if vn < 0.0 && g2 > 1e-30 {
                v -= vn * g / g2;
            }
            s = vec4<f32>(q, v);
            state[first + j] = s;
        }
        pos[base + j + 1u] = vec4<f32>(next, 1.0);
        prev = b[2];
        parent = b;
        x = next;
    }
    let tip = pos[base + n];
    for (var k = n + 1u; k < params.stride; k++) {
        pos[base + k] = tip;
    }
}

@compute @workgroup_size(WORKGROUP)
fn step(@builtin(global_invocation_id) id: vec3<u32>) {
    let s = id.x + id.y * params.row_stride;
    if s >= params.count {
        return;
    }
    let st = slot.index.x;
    let strip = strips[s];
    let first = strip.info.x;
    let n = strip.info.y;
    let base = s * params.stride;
    let root = strip.root.xyz;
    let band = strip.root.w;
    let w = steps[st].samples.x;
    chain(first, n, base, root, world_steps[w].head, false);
    forces_and_step(first, n, base, band, st, false);
    chain(first, n, base, root, world_steps[w + 1u].head, true);
    forces_and_step(first, n, base, band, st, true);
    constrain(first, n, base, root, world_steps[w + 2u].head);
}
