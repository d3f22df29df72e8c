// Anjyo's cantilever bending on the GPU, one invocation per strand. The same steps as the
// f64 reference in src/groom/cantilever.rs (read its header for the equations):
//   paper mode      one root-to-tip pass, straight-beam lever arms (eqs 1-3);
//   converged mode  fixed point of true-lever-arm moments, relaxed with heavy-ball momentum;
//   both            the hull collision of each new node, then the cuts (drawn length).
// Reads roots/groups/loads/cuts, writes the strand's nodes and its drawn length.

struct Params {
    strand_count: u32,
    total_vertices: u32,
    row_stride: u32,
    _pad: u32,
    head_center: vec4<f32>,
    head_radii: vec4<f32>,
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

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> roots: array<Root>;
@group(0) @binding(2) var<storage, read> groups: array<Group>;
@group(0) @binding(3) var<storage, read> loads: array<Load>;
@group(0) @binding(4) var<storage, read> cuts: array<Cut>;
@group(0) @binding(5) var<storage, read_write> strands: array<Strand>;
@group(0) @binding(6) var<storage, read_write> verts: array<vec4<f32>>;
// Converged mode only: joint rotations [0, total) and their previous values [total, 2 total).
@group(0) @binding(7) var<storage, read_write> scratch: array<vec4<f32>>;

fn hull() -> Hull {
    return Hull(params.head_center.xyz, params.head_radii.xyz);
}

fn group_load(g: Group, p: vec3<f32>) -> vec3<f32> {
    return load_at(g.first_load, g.load_count, p);
}

fn bend_paper(base: u32, g: Group, p0: vec3<f32>, dir: vec3<f32>, d: f32) {
    let k = g.segments;
    // W_m = W_{m+1} + S_{m+1} + g_m / 2, kept in the node slots until they are overwritten.
    var w = vec3<f32>(0.0);
    var s = vec3<f32>(0.0);
    for (var m = k; m >= 1u; m--) {
        let mid = p0 + dir * (d * (f32(m) - 0.5));
        let gm = group_load(g, mid) * d;
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
        p = hull_push_out(h, prev, a0, p, d);
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

fn rebuild(base: u32, k: u32, p0: vec3<f32>, dir: vec3<f32>, d: f32) {
    let h = hull();
    verts[base] = vec4<f32>(p0, 1.0);
    var p = p0;
    var t = dir;
    for (var j = 0u; j < k; j++) {
        let turned = rotate_vec(scratch[base + j].xyz, t);
        var q = p + turned * d;
        q = hull_push_out(h, p, t, q, d);
        t = normalize((q - p) / d);
        verts[base + j + 1u] = vec4<f32>(q, 1.0);
        p = q;
    }
}

fn bend_converged(base: u32, g: Group, p0: vec3<f32>, dir: vec3<f32>, d: f32) {
    let k = g.segments;
    let prev_off = params.total_vertices;
    // Start from the rotations that reproduce the paper's shape.
    var t = dir;
    var wmax = length(group_load(g, p0));
    for (var j = 0u; j < k; j++) {
        let nt = normalize((verts[base + j + 1u].xyz - verts[base + j].xyz) / d);
        let axis = cross(t, nt);
        let s = length(axis);
        var om = vec3<f32>(0.0);
        if s > 1e-30 {
            om = axis / s * atan2(s, dot(t, nt));
        }
        scratch[base + j] = vec4<f32>(om, 0.0);
        scratch[prev_off + base + j] = vec4<f32>(om, 0.0);
        t = nt;
        wmax = max(wmax, length(group_load(g, verts[base + j + 1u].xyz)));
    }
    let len = d * f32(k);
    let ab = relaxation(wmax * len * len * len / g.rigidity);
    for (var it = 1u; it <= g.max_iterations; it++) {
        rebuild(base, k, p0, dir, d);
        var n = vec3<f32>(0.0);
        var c = vec3<f32>(0.0);
        var res = 0.0;
        for (var jj = k; jj >= 1u; jj--) {
            let j = jj - 1u;
            let pj = verts[base + j].xyz;
            let mid = 0.5 * (pj + verts[base + j + 1u].xyz);
            let f = group_load(g, mid) * d;
            n += f;
            c += cross(mid - p0, f);
            let m = c - cross(pj - p0, n);
            var t_in = dir;
            if j > 0u {
                t_in = normalize((pj - verts[base + j - 1u].xyz) / d);
            }
            let m_perp = m - dot(m, t_in) * t_in;
            let l = select(d, 0.5 * d, j == 0u);
            let tgt = m_perp * (l / g.rigidity);
            let om = scratch[base + j].xyz;
            let pr = scratch[prev_off + base + j].xyz;
            let dstep = tgt - om;
            res = max(res, length(dstep));
            scratch[prev_off + base + j] = vec4<f32>(om, 0.0);
            scratch[base + j] = vec4<f32>(om + ab.x * dstep + ab.y * (om - pr), 0.0);
        }
        if res <= g.tolerance {
            break;
        }
    }
    rebuild(base, k, p0, dir, d);
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

@compute @workgroup_size(64)
fn bend(@builtin(global_invocation_id) id: vec3<u32>) {
    let s = id.x + id.y * params.row_stride;
    if s >= params.strand_count {
        return;
    }
    let strand = strands[s];
    let root = roots[s];
    let g = groups[strand.group];
    let base = strand.first_vertex;
    let d = root.pos.w;
    bend_paper(base, g, root.pos.xyz, root.dir.xyz, d);
    if g.mode == 1u {
        bend_converged(base, g, root.pos.xyz, root.dir.xyz, d);
    }
    strands[s].visible = visible_segments(base, g, bitcast<u32>(root.dir.w));
}
