// Anjyo's cantilever bending on the GPU, one invocation per strand. The same steps as the
// f64 reference in src/systems/anjyo/cantilever.rs (read its header for the equations):
//   paper mode      one root-to-tip pass, straight-beam lever arms (eqs 1-3);
//   converged mode  fixed point of true-lever-arm moments, relaxed with heavy-ball momentum;
//   both            the hull collision of each new node, then the cuts (drawn length).
// Reads roots/groups/loads/cuts, writes the strand's nodes and its drawn length.
//
// Three entry points, dispatched in order: `bend` (paper bend, and the converged mode's
// starting state), `iterate` (dispatched repeatedly, `params.chunk` iterations each) and
// `finish` (fallback of unconverged strands, cuts). The iteration is split across
// dispatches because Mesa's llvmpipe ends a shader's loops after 65,535 iterations in total
// per invocation, silently; short dispatches also keep real GPUs clear of watchdogs.

struct Params {
    strand_count: u32,
    total_vertices: u32,
    row_stride: u32,
    // Converged-mode iterations per `iterate` dispatch.
    chunk: u32,
}

struct Root {
    // xyz pore, w segment length
    pos: vec4<f32>,
    // xyz unloaded direction, w cut mask (bits)
    dir: vec4<f32>,
}

struct Group {
    segments: u32,
    mode: u32,
    max_iterations: u32,
    first_load: u32,
    load_count: u32,
    first_cut: u32,
    cut_count: u32,
    _pad0: u32,
    rigidity: f32,
    tolerance: f32,
    _pad1: vec2<f32>,
}

struct Cut {
    kind: u32,
    _p0: u32,
    _p1: u32,
    _p2: u32,
    a: vec4<f32>,
}

// Nodes this close outside the hull (units of the quadric) rest on it.
// Passed by the Rust side (`cantilever::CONTACT_BAND`, `gpu::WORKGROUP`).
override CONTACT_BAND: f32;
override WORKGROUP: u32;

// strands[].flags: bit 0 a converged-mode strand that fell back to the paper's shape, bit 1
// converged, bits 8.. iterations used.
const FLAG_NOT_CONVERGED: u32 = 1u;
const FLAG_DONE: u32 = 2u;

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> roots: array<Root>;
@group(0) @binding(2) var<storage, read> groups: array<Group>;
@group(0) @binding(3) var<storage, read> loads: array<Load>;
@group(0) @binding(4) var<storage, read> cuts: array<Cut>;
@group(0) @binding(5) var<storage, read_write> strands: array<Strand>;
@group(0) @binding(6) var<storage, read_write> verts: array<vec4<f32>>;
// Converged mode only: joint rotations [0, total) and their previous values [total, 2 total).
@group(0) @binding(7) var<storage, read_write> scratch: array<vec4<f32>>;

// The head's hull and field: the world at group 3 (common/world.wgsl).

fn hull() -> HeadHull {
    return world_hull();
}

fn group_load(g: Group, rest: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    return load_at(g.first_load, g.load_count, rest, p);
}

// Midpoint of segment m (1-based) on the straight, unloaded beam.
fn rest_mid(p0: vec3<f32>, dir: vec3<f32>, d: f32, m: u32) -> vec3<f32> {
    return p0 + dir * (d * (f32(m) - 0.5));
}

fn bend_paper(base: u32, g: Group, p0: vec3<f32>, dir: vec3<f32>, d: f32) {
    let k = g.segments;
    // W_m = W_{m+1} + S_{m+1} + g_m / 2, kept in the node slots until they are overwritten.
    var w = vec3<f32>(0.0);
    var s = vec3<f32>(0.0);
    for (var m = k; m >= 1u; m--) {
        let mid = rest_mid(p0, dir, d, m);
        let gm = group_load(g, mid, mid) * d;
        w = w + s + 0.5 * gm;
        s += gm;
        verts[base + m] = vec4<f32>(w, 0.0);
    }
    let scale = d * d * d / (2.0 * g.rigidity);
    let h = hull();
    verts[base] = vec4<f32>(p0, 1.0);
    var prev = p0;
    var a0 = dir;
    for (var i = 1u; i <= k; i++) {
        let wi = verts[base + i].xyz;
        let y = (wi - dot(wi, a0) * a0) * scale;
        let e = a0 * d + y;
        var p = prev + e * (d / length(e));
        p = head_push_out(h, prev, a0, p, d);
        a0 = normalize((p - prev) / d);
        verts[base + i] = vec4<f32>(p, 1.0);
        prev = p;
    }
}

// Relaxation (alpha, beta) from G = |w| L^3 / EI; see cantilever::relaxation.
fn relaxation(g_est: f32) -> vec2<f32> {
    let lam = g_est / 3.0;
    let alpha = 1.0 / (1.0 + lam);
    let r = clamp((sqrt(lam) - 1.0) / (sqrt(lam) + 1.0), 0.0, 0.9);
    return vec2<f32>(alpha, r * r);
}

// Rotation vector turning unit a into unit b.
fn turn(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    let axis = cross(a, b);
    let s = length(axis);
    if s > 1e-30 {
        return axis / s * atan2(s, dot(a, b));
    }
    return vec3<f32>(0.0);
}

// Rebuild the nodes from the trial rotations in scratch[base + j], with collision. Where a
// node is pushed out, the joint's state and its previous value become the rotation it really
// made (projection, no momentum). Returns the largest change of a realized rotation from the
// previous iterate (kept in the `prev` slots).
fn rebuild_projected(base: u32, k: u32, p0: vec3<f32>, dir: vec3<f32>, d: f32) -> f32 {
    let h = hull();
    let po = params.total_vertices;
    verts[base] = vec4<f32>(p0, 1.0);
    var p = p0;
    var t = dir;
    var change = 0.0;
    for (var j = 0u; j < k; j++) {
        let om = scratch[base + j].xyz;
        // Normalised: GPU sin/cos are only accurate to about 2^-11.
        let free = p + normalize(rotate_vec(om, t)) * d;
        let q = head_push_out(h, p, t, free, d);
        let nt = normalize((q - p) / d);
        var real = om;
        let old = scratch[po + base + j].xyz;
        if any(q != free) {
            real = turn(t, nt);
            scratch[base + j] = vec4<f32>(real, 0.0);
            scratch[po + base + j] = vec4<f32>(real, 0.0);
        }
        change = max(change, length(real - old));
        t = nt;
        verts[base + j + 1u] = vec4<f32>(q, 1.0);
        p = q;
    }
    return change;
}

// The converged mode's starting state: the rotations that reproduce the paper's shape.
fn converged_init(base: u32, k: u32, dir: vec3<f32>, d: f32) {
    let po = params.total_vertices;
    var t = dir;
    for (var j = 0u; j < k; j++) {
        let nt = normalize((verts[base + j + 1u].xyz - verts[base + j].xyz) / d);
        let om = turn(t, nt);
        scratch[base + j] = vec4<f32>(om, 0.0);
        scratch[po + base + j] = vec4<f32>(om, 0.0);
        t = nt;
    }
}

// Step (alpha, beta) of a strand, from its largest load on the rest beam.
fn strand_relaxation(g: Group, p0: vec3<f32>, dir: vec3<f32>, d: f32) -> vec2<f32> {
    let k = g.segments;
    var wmax = 0.0;
    for (var m = 1u; m <= k; m++) {
        let rm = rest_mid(p0, dir, d, m);
        wmax = max(wmax, length(group_load(g, rm, rm)));
    }
    let len = d * f32(k);
    return relaxation(wmax * len * len * len / g.rigidity);
}

// Up to `iterations` steps of the converged bend (see cantilever::bend_converged); returns
// how many it took to converge, or `iterations` + 1 if it did not.
fn converged_steps(base: u32, g: Group, p0: vec3<f32>, dir: vec3<f32>, d: f32, iterations: u32) -> u32 {
    let k = g.segments;
    let po = params.total_vertices;
    let ab = strand_relaxation(g, p0, dir, d);
    let h = hull();
    for (var it = 1u; it <= iterations; it++) {
        // Target rotations from true lever arms (moments about the root), then the relaxed
        // trial step; the old state moves to the `prev` slot.
        var n = vec3<f32>(0.0);
        var c = vec3<f32>(0.0);
        for (var jj = k; jj >= 1u; jj--) {
            let j = jj - 1u;
            let pj = verts[base + j].xyz;
            let mid = 0.5 * (pj + verts[base + j + 1u].xyz);
            let f = group_load(g, rest_mid(p0, dir, d, jj), mid) * d;
            n += f;
            c += cross(mid - p0, f);
            let m = c - cross(pj - p0, n);
            var t_in = dir;
            if j > 0u {
                t_in = normalize((pj - verts[base + j - 1u].xyz) / d);
            }
            let m_perp = m - dot(m, t_in) * t_in;
            let l = select(d, 0.5 * d, j == 0u);
            var tgt = m_perp * (l / g.rigidity);
            let om = scratch[base + j].xyz;
            // A node resting on the hull is not stepped inwards.
            let node = verts[base + j + 1u].xyz;
            if head_eval(h, node) < select(CONTACT_BAND, 4.0 * SDF_EPS_OUT, h.sdf) {
                let nrm = normalize(head_gradient(h, node));
                let stp = cross(tgt - om, t_in);
                let inward = min(dot(stp, nrm), 0.0);
                tgt = om + cross(t_in, stp - inward * nrm);
            }
            let pr = scratch[po + base + j].xyz;
            scratch[po + base + j] = vec4<f32>(om, 0.0);
            scratch[base + j] = vec4<f32>(om + ab.x * (tgt - om) + ab.y * (om - pr), 0.0);
        }
        let change = rebuild_projected(base, k, p0, dir, d);
        if change / ab.x <= g.tolerance {
            return it;
        }
    }
    return iterations + 1u;
}

fn strand_index(id: vec3<u32>) -> u32 {
    return id.x + id.y * params.row_stride;
}

@compute @workgroup_size(WORKGROUP)
fn bend(@builtin(global_invocation_id) id: vec3<u32>) {
    let s = strand_index(id);
    if s >= params.strand_count {
        return;
    }
    let strand = strands[s];
    let root = roots[s];
    let g = groups[strand.group];
    bend_paper(strand.first_vertex, g, root.pos.xyz, root.dir.xyz, root.pos.w);
    if g.mode == 1u {
        converged_init(strand.first_vertex, g.segments, root.dir.xyz, root.pos.w);
    }
    strands[s].flags = 0u;
}

@compute @workgroup_size(WORKGROUP)
fn iterate(@builtin(global_invocation_id) id: vec3<u32>) {
    let s = strand_index(id);
    if s >= params.strand_count {
        return;
    }
    let strand = strands[s];
    let g = groups[strand.group];
    let used = strand.flags >> 8u;
    if g.mode != 1u || (strand.flags & FLAG_DONE) != 0u || used >= g.max_iterations {
        return;
    }
    let root = roots[s];
    let budget = min(params.chunk, g.max_iterations - used);
    let took = converged_steps(strand.first_vertex, g, root.pos.xyz, root.dir.xyz, root.pos.w, budget);
    if took <= budget {
        strands[s].flags = ((used + took) << 8u) | FLAG_DONE;
    } else {
        strands[s].flags = (used + budget) << 8u;
    }
}

@compute @workgroup_size(WORKGROUP)
fn finish(@builtin(global_invocation_id) id: vec3<u32>) {
    let s = strand_index(id);
    if s >= params.strand_count {
        return;
    }
    let strand = strands[s];
    let root = roots[s];
    let g = groups[strand.group];
    let base = strand.first_vertex;
    if g.mode == 1u && (strand.flags & FLAG_DONE) == 0u {
        // Not converged: keep the paper's shape, and flag the strand.
        bend_paper(base, g, root.pos.xyz, root.dir.xyz, root.pos.w);
        strands[s].flags = strand.flags | FLAG_NOT_CONVERGED;
    }
    strands[s].visible = visible_segments(base, g, bitcast<u32>(root.dir.w));
}

// Where f turns negative along the hair, in segments (fractional), or k.
fn crossing_below(base: u32, k: u32, y: f32) -> f32 {
    var fa = verts[base].y - y;
    if fa < 0.0 {
        return 0.0;
    }
    for (var i = 1u; i <= k; i++) {
        let fb = verts[base + i].y - y;
        if fb < 0.0 {
            return f32(i - 1u) + fa / (fa - fb);
        }
        fa = fb;
    }
    return f32(k);
}

fn crossing_near(base: u32, k: u32, c: vec3<f32>, r: f32) -> f32 {
    var fa = length(verts[base].xyz - c) - r;
    if fa < 0.0 {
        return 0.0;
    }
    for (var i = 1u; i <= k; i++) {
        let fb = length(verts[base + i].xyz - c) - r;
        if fb < 0.0 {
            return f32(i - 1u) + fa / (fa - fb);
        }
        fa = fb;
    }
    return f32(k);
}

fn visible_segments(base: u32, g: Group, mask: u32) -> f32 {
    let k = g.segments;
    var vis = f32(k);
    for (var ci = 0u; ci < g.cut_count; ci++) {
        if (mask & (1u << ci)) == 0u {
            continue;
        }
        let cut = cuts[g.first_cut + ci];
        var v = f32(k);
        if cut.kind == 0u {
            v = crossing_below(base, k, cut.a.x);
        } else if cut.kind == 1u {
            let t = clamp((verts[base].y - cut.a.x) / (cut.a.z - cut.a.x), 0.0, 1.0);
            v = cut.a.y + t * (cut.a.w - cut.a.y);
        } else {
            v = crossing_near(base, k, cut.a.xyz, cut.a.w);
        }
        vis = min(vis, v);
    }
    return max(vis, 0.0);
}
