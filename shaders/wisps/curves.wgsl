// Skeletons to Bézier segments (Sakai eqs 3-7, 11-13) and each segment's neighbour list.
// `spline`: one invocation per wisp solves the natural cubic spline with the uniform
// parameter of eq 4 (Thomas algorithm on the second derivatives) and writes each segment's
// Bézier control points, its control-point AABB and its Lipschitz bound.
// `neighbours`: one invocation per segment lists every segment whose influence box
// (the AABB grown by its largest radius) overlaps its own: exactly the segments that can add
// density inside its box, so the ray march of a box needs no other.
// f64 reference: `src/systems/wisps/curve.rs`.

// Keep in sync with GpuWispParams in src/systems/wisps/march.rs.
struct Params {
    // Applied to node positions (the head pose for still wisps; identity when the springs
    // already move the nodes in world space).
    model: mat4x4<f32>,
    // x wisps, y segments, z neighbour slots per segment, w nodes
    counts: vec4<u32>,
}

// Keep in sync with GpuSegment in src/systems/wisps/march.rs.
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

@group(0) @binding(0) var<uniform> params: Params;
// Node positions (xyz), the wisps' nodes one after the other.
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
// Per node: x radius r, y weight w.
@group(0) @binding(2) var<storage, read> node_rw: array<vec4<f32>>;
// Per wisp: x first node, y node count.
@group(0) @binding(3) var<storage, read> wisps: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read_write> segments: array<Segment>;
@group(0) @binding(5) var<storage, read_write> neighbours: array<u32>;
@group(0) @binding(6) var<storage, read_write> neighbour_counts: array<u32>;

const MAX_NODES: u32 = 64u;

fn node_pos(i: u32) -> vec3<f32> {
    return (params.model * vec4<f32>(positions[i].xyz, 1.0)).xyz;
}

@compute @workgroup_size(64)
fn spline(@builtin(global_invocation_id) gid: vec3<u32>) {
    let wi = gid.x;
    if (wi >= params.counts.x) {
        return;
    }
    let first = wisps[wi].x;
    let n = min(wisps[wi].y, MAX_NODES);
    // Natural spline, uniform parameter: M[i-1] + 4 M[i] + M[i+1] = 6 (P[i-1] - 2 P[i] + P[i+1])
    // for interior i, M = 0 at both ends. Thomas: forward sweep into cp/dp, back substitution.
    var m: array<vec3<f32>, 64>;
    var cp: array<f32, 64>;
    m[0] = vec3<f32>(0.0);
    m[n - 1u] = vec3<f32>(0.0);
    cp[0] = 0.0;
    for (var i = 1u; i + 1u < n; i++) {
        let rhs = 6.0 * (node_pos(first + i - 1u) - 2.0 * node_pos(first + i) + node_pos(first + i + 1u));
        let denom = 4.0 - cp[i - 1u];
        cp[i] = 1.0 / denom;
        m[i] = (rhs - m[i - 1u]) / denom;
    }
    if (n > 2u) {
        for (var i = n - 2u; i >= 1u; i--) {
            m[i] = m[i] - cp[i] * m[i + 1u];
            if (i == 1u) {
                break;
            }
        }
    }
    let seg0 = first - wi;
    for (var j = 0u; j + 1u < n; j++) {
        let p0 = node_pos(first + j);
        let p1 = node_pos(first + j + 1u);
        let a = (m[j + 1u] - m[j]) / 6.0;
        let b = m[j] * 0.5;
        let c = (p1 - p0) - (2.0 * m[j] + m[j + 1u]) / 6.0;
        let d = p0;
        // Bézier control points of a t^3 + b t^2 + c t + d (eq 13, derived: the printed one
        // has typos).
        let v0 = d;
        let v1 = d + c / 3.0;
        let v2 = d + (2.0 * c + b) / 3.0;
        let v3 = p1;
        let rw0 = node_rw[first + j].xy;
        let rw1 = node_rw[first + j + 1u].xy;
        let r_min = min(rw0.x, rw1.x);
        let w_max = max(rw0.y, rw1.y);
        let s = max(0.5 * length(v3 - v0), 1e-9);
        let lip = 2.0 * w_max / r_min * (1.0 + 2.0 * abs(rw1.x - rw0.x) / s) + 2.0 * abs(rw1.y - rw0.y) / s;
        var seg: Segment;
        seg.c0 = vec4<f32>(v0, rw0.x);
        seg.c1 = vec4<f32>(v1, rw1.x);
        seg.c2 = vec4<f32>(v2, rw0.y);
        seg.c3 = vec4<f32>(v3, rw1.y);
        seg.lo = vec4<f32>(min(min(v0, v1), min(v2, v3)), lip);
        seg.hi = vec4<f32>(max(max(v0, v1), max(v2, v3)), f32(wi));
        segments[seg0 + j] = seg;
    }
}

fn influence_lo(s: Segment) -> vec3<f32> {
    return s.lo.xyz - vec3<f32>(max(s.c0.w, s.c1.w));
}

fn influence_hi(s: Segment) -> vec3<f32> {
    return s.hi.xyz + vec3<f32>(max(s.c0.w, s.c1.w));
}

@compute @workgroup_size(64)
fn neighbours_of(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    let count = params.counts.y;
    if (i >= count) {
        return;
    }
    let slots = params.counts.z;
    let lo = influence_lo(segments[i]);
    let hi = influence_hi(segments[i]);
    var k = 0u;
    for (var j = 0u; j < count; j++) {
        let s = segments[j];
        if (all(influence_lo(s) <= hi) && all(lo <= influence_hi(s))) {
            if (k < slots) {
                neighbours[i * slots + k] = j;
            }
            k++;
        }
    }
    // More than `slots` is an overflow: the system reads the counts back in tests and warns.
    neighbour_counts[i] = k;
}
