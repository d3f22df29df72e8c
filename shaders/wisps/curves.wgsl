// Skeletons to Bézier segments (Sakai eqs 3-7, 11-13) and each segment's bounds for the
// tiled ray march.
// `spline`: one invocation per wisp solves the natural cubic spline with the uniform
// parameter of eq 4 (Thomas algorithm on the second derivatives) and writes each segment's
// Bézier control points, its control-point AABB, its Lipschitz bound and its capsule: the
// chord c0-c3 grown by the control points' largest distance from it (the curve lies in their
// convex hull) plus r_max holds the segment's whole influence.
// `overlaps`: one invocation per segment counts K, the wisps with a segment whose influence
// box overlaps its own, and writes the hit radius: where the field reaches the threshold,
// the wisp of largest density has density >= threshold / K there (at most K wisps add
// density at a point of this segment's box), so its arg-max segment is within
// r_max fd^-1(threshold / (K w_max)) of its curve. No point outside every segment's hit
// capsule can be inside the surface: the march samples only inside them.
// f64 reference: `src/systems/wisps/curve.rs` (`segments`, `capsules`).

// Twin of GpuWispParams (tests/it/gpu_twins.rs checks it) in src/systems/wisps/march.rs.
struct Params {
    // Applied to node positions (the head pose for still wisps; identity when the springs
    // already move the nodes in world space).
    model: mat4x4<f32>,
    // x wisps, y segments, z unused, w nodes
    counts: vec4<u32>,
    // x the surface threshold
    shape: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: Params;
// Node positions (xyz), the wisps' nodes one after the other.
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
// Per node: x radius r, y weight w.
@group(0) @binding(2) var<storage, read> node_rw: array<vec4<f32>>;
// Per wisp: x first node, y node count.
@group(0) @binding(3) var<storage, read> wisps: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read_write> segments: array<Segment>;
// Per segment: a = (c0, influence radius), b = (c3, hit radius; -1 where the segment can
// never be the arg-max of an inside point). `spline` leaves the capsule's curve margin in b.w
// for `overlaps`.
@group(0) @binding(5) var<storage, read_write> capsules: array<Capsule>;
// Per segment: K, the wisps whose influence box overlaps its own (itself included).
@group(0) @binding(6) var<storage, read_write> overlap_counts: array<u32>;
// Per segment PIECES + 1 entries: xyz the curve at t = k / PIECES, w the deviation of piece k
// from its chord (the march's distance bound; `curve::pieces`).
@group(0) @binding(7) var<storage, read_write> pieces: array<vec4<f32>>;

const PIECES: u32 = 8u;

fn bez_at(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, v3: vec3<f32>, t: f32) -> vec3<f32> {
    let u = 1.0 - t;
    return u * u * u * v0 + 3.0 * u * u * t * v1 + 3.0 * u * t * t * v2 + t * t * t * v3;
}

fn bez_d1_at(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, v3: vec3<f32>, t: f32) -> vec3<f32> {
    let u = 1.0 - t;
    return 3.0 * u * u * (v1 - v0) + 6.0 * u * t * (v2 - v1) + 3.0 * t * t * (v3 - v2);
}

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
        let margin = max(chord_distance(v1, v0, v3), chord_distance(v2, v0, v3));
        let h = 1.0 / f32(PIECES);
        let first_piece = (seg0 + j) * (PIECES + 1u);
        var pa = v0;
        for (var k = 0u; k < PIECES; k++) {
            let ta = f32(k) * h;
            let tb = f32(k + 1u) * h;
            let pb = bez_at(v0, v1, v2, v3, tb);
            let q1 = pa + bez_d1_at(v0, v1, v2, v3, ta) * (h / 3.0);
            let q2 = pb - bez_d1_at(v0, v1, v2, v3, tb) * (h / 3.0);
            let dev = max(chord_distance(q1, pa, pb), chord_distance(q2, pa, pb));
            pieces[first_piece + k] = vec4<f32>(pa, dev);
            pa = pb;
        }
        pieces[first_piece + PIECES] = vec4<f32>(v3, 0.0);
        capsules[seg0 + j] = Capsule(vec4<f32>(v0, margin + max(rw0.x, rw1.x)), vec4<f32>(v3, margin));
    }
}

fn influence_lo(s: Segment) -> vec3<f32> {
    return s.lo.xyz - vec3<f32>(max(s.c0.w, s.c1.w));
}

fn influence_hi(s: Segment) -> vec3<f32> {
    return s.hi.xyz + vec3<f32>(max(s.c0.w, s.c1.w));
}

@compute @workgroup_size(64)
fn overlaps(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    let count = params.counts.y;
    if (i >= count) {
        return;
    }
    let me = segments[i];
    let lo = influence_lo(me);
    let hi = influence_hi(me);
    // Segments are stored wisp by wisp: count the wisps, not the segments.
    var k = 0u;
    var last = -1.0;
    for (var j = 0u; j < count; j++) {
        let s = segments[j];
        if (s.hi.w != last && all(influence_lo(s) <= hi) && all(lo <= influence_hi(s))) {
            k++;
            last = s.hi.w;
        }
    }
    overlap_counts[i] = k;
    let r_max = max(me.c0.w, me.c1.w);
    let w_max = max(me.c2.w, me.c3.w);
    let y = params.shape.x / (f32(max(k, 1u)) * w_max);
    var hit = -1.0;
    if (y <= 1.0) {
        // 1e-4 r_max: the f32 and f64 radii may differ in the last bits; stay conservative.
        hit = r_max * (fd_inverse(y) + 1e-4) + capsules[i].b.w;
    }
    capsules[i].b.w = hit;
}
