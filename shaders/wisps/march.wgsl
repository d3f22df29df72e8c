// Toon wisps drawn by ray marching the blobby surface (Sakai section 5), each pixel once,
// over the screen tiles some segment's influence reaches (`shaders/wisps/tiles.wgsl` lists
// them): in compute (`march`, one workgroup per tile, colour and depth to images that
// `shaders/wisps/composite.wgsl` draws into the scene) or in fragments (`fs`, one quad per
// tile), `block::MarchOn`. A pixel takes the ray through its centre, keeps a window of the
// tile's segments whose influence capsule the ray crosses (their influence and shell
// intervals along it; `gather`), and
// marches front to back only inside shell intervals (hit capsules grown by the outline):
// outside them no point is inside the surface or its outline, so the ray jumps the gaps.
// At each sample the field sums only the candidates whose influence interval holds t, and a
// step never passes the next influence entry (Segment Tracing, Galin et al. 2020, with
// bounding capsules). Sphere tracing with steps bounded by the field's Lipschitz constant
// and the distance step, bisection on the hit, the analytic gradient for normals, depth
// written so wisps composite with the head, strands and fur. Toon shading in the head frame
// (eqs 14-22, `wisps/toon.wgsl`) with the angel halo, and a silhouette outline from a thin
// shell around the surface. f64 twin: `march_tiled` in `src/systems/wisps/field.rs`.

// `Draw` (the toon colours and march settings): shaders/wisps/draw.wgsl.
// `View`: shaders/wisps/view.wgsl.

@group(1) @binding(0) var<uniform> draw: Draw;
@group(1) @binding(1) var<storage, read> segments: array<Segment>;
@group(1) @binding(2) var<storage, read> capsules: array<Capsule>;
@group(1) @binding(3) var<storage, read> shells: array<f32>;
@group(1) @binding(4) var<storage, read> tile_counts: array<u32>;
@group(1) @binding(5) var<storage, read> tile_lists: array<u32>;
@group(1) @binding(6) var<uniform> view: View;
@group(1) @binding(7) var<storage, read_write> stats: array<atomic<u32>, 8>;
// Per segment PIECES + 1 curve points with each piece's chord deviation (w).
@group(1) @binding(8) var<storage, read> pieces: array<vec4<f32>>;
// Per segment: outline scale, u at its start and end (`toon::segment_outlines`).
@group(1) @binding(9) var<storage, read> outlines: array<vec4<f32>>;

const PIECES: u32 = 8u;

struct Sample {
    // f (density minus threshold)
    f: f32,
    grad: vec3<f32>,
    // The Lipschitz step (0 where no segment is near or f >= 0).
    step: f32,
    // The outline width multiplier of the densest wisp here (1 where none is near).
    outline: f32,
}

// Candidates of this pixel's ray, in segment order: the segment, its influence interval
// [c_in, c_out] and its shell interval [s_in, s_out] along the ray (empty: s_in > s_out).
// Set per scene (`field::ray_slots`): `march::march_source` replaces this line.
const RAY_SLOTS: u32 = 48u;
var<private> c_seg: array<u32, RAY_SLOTS>;
// x c_in, y c_out, z s_in, w s_out
var<private> c_iv: array<vec4<f32>, RAY_SLOTS>;
// The nearer of the influence and shell entries (which slot a full list gives up).
var<private> c_key: array<f32, RAY_SLOTS>;
var<private> n_cand: u32;

// Per wisp of the current sample: the pieces' density bound at distance 0.
var<private> wisp_bound: array<f32, RAY_SLOTS>;

// Piece k of candidate segment j at v: (distance at least, r at most, w at most).
fn piece_bound(j: u32, s: Segment, k: u32, v: vec3<f32>) -> vec3<f32> {
    let base = j * (PIECES + 1u);
    let pa = pieces[base + k];
    let pb = pieces[base + k + 1u];
    let d = max(chord_distance(v, pa.xyz, pb.xyz) - pa.w, 0.0);
    let h = 1.0 / f32(PIECES);
    let ta = f32(k) * h;
    let tb = f32(k + 1u) * h;
    let r = max(mix(s.c0.w, s.c1.w, ta), mix(s.c0.w, s.c1.w, tb));
    let w = max(mix(s.c2.w, s.c3.w, ta), mix(s.c2.w, s.c3.w, tb));
    return vec3<f32>(d, r, w);
}

// The clear step at v (no point within it is inside the surface): each piece bounds its
// wisp's density at distance s by w fd(max(d - s, 0) / r); each wisp gets its bound at 0
// plus an equal share of the slack, and the step is the least s at which a piece reaches
// its wisp's share. 0 where the bounds reach the threshold, 1e30 without segments. As
// `field::clear_step`.
fn clear_step(t: f32, v: vec3<f32>) -> f32 {
    var n_w = 0u;
    var wisp = -1.0;
    for (var k = 0u; k < n_cand; k++) {
        if (c_iv[k].x > t || c_iv[k].y < t) {
            continue;
        }
        let j = c_seg[k];
        let s = segments[j];
        if (s.hi.w != wisp) {
            wisp = s.hi.w;
            wisp_bound[n_w] = 0.0;
            n_w++;
        }
        var m = wisp_bound[n_w - 1u];
        for (var p = 0u; p < PIECES; p++) {
            let b = piece_bound(j, s, p, v);
            m = max(m, b.z * fd(b.x / b.y));
        }
        wisp_bound[n_w - 1u] = m;
    }
    if (n_w == 0u) {
        return 1e30;
    }
    var total = 0.0;
    for (var i = 0u; i < n_w; i++) {
        total += wisp_bound[i];
    }
    let thr = draw.march.x;
    if (total >= thr) {
        return 0.0;
    }
    let slack = (thr - total) / f32(n_w);
    var step = 1e30;
    var wi = 0u;
    wisp = -1.0;
    for (var k = 0u; k < n_cand; k++) {
        if (c_iv[k].x > t || c_iv[k].y < t) {
            continue;
        }
        let j = c_seg[k];
        let s = segments[j];
        if (s.hi.w != wisp) {
            if (wisp >= 0.0) {
                wi++;
            }
            wisp = s.hi.w;
        }
        let share = wisp_bound[wi] + slack;
        for (var p = 0u; p < PIECES; p++) {
            let b = piece_bound(j, s, p, v);
            let y = share / b.z;
            if (y < 1.0) {
                step = min(step, b.x - b.y * fd_inverse(y));
            }
        }
    }
    return max(step, 0.0);
}

// The field at `v` = eye + t dir from the candidates whose influence interval holds t: per
// wisp the largest segment density over open joints (a wisp's segments are consecutive),
// summed over wisps; and the Lipschitz step: -f over the sum over wisps of each wisp's
// largest near bound, never past where a far segment's influence begins. As
// `field::exact_sample`.
fn field(t: f32, v: vec3<f32>) -> Sample {
    var out: Sample;
    var lip = 0.0;
    var far_gap = 1e30;
    var sum = 0.0;
    var grad = vec3<f32>(0.0);
    var wisp = -1.0;
    var acc = wisp_max_new();
    var wisp_lip = 0.0;
    var densest = 0.0;
    var densest_o = 1.0;
    for (var k = 0u; k < n_cand; k++) {
        if (c_iv[k].x > t || c_iv[k].y < t) {
            continue;
        }
        let j = c_seg[k];
        let s = segments[j];
        if (s.hi.w != wisp) {
            wisp_fold(&acc);
            sum += acc.best;
            grad += acc.best_grad;
            lip += wisp_lip;
            if (acc.best > densest) {
                densest = acc.best;
                densest_o = acc.best_o;
            }
            wisp = s.hi.w;
            acc = wisp_max_new();
            wisp_lip = 0.0;
        }
        let c = segment_density(s, v, draw.method.x, draw.method.y);
        if (c.gap > 0.0) {
            far_gap = min(far_gap, c.gap);
            continue;
        }
        wisp_lip = max(wisp_lip, s.lo.w);
        wisp_push(&acc, j, c.t, c.rho, c.grad, outline_scale(outlines[j], c.t));
    }
    wisp_fold(&acc);
    sum += acc.best;
    grad += acc.best_grad;
    lip += wisp_lip;
    if (acc.best > densest) {
        densest_o = acc.best_o;
    }
    out.f = sum - draw.march.x;
    out.grad = grad;
    out.outline = densest_o;
    out.step = 0.0;
    if (lip > 0.0 && out.f < 0.0) {
        out.step = min(-out.f / lip, far_gap);
    }
    return out;
}

// The interval of eye + t dir (|dir| = 1) inside the capsule round a-b of radius r (x > y:
// none): the union of the end spheres' and the clipped cylinder's intervals. As
// `curve::ray_capsule`.
fn ray_capsule(o: vec3<f32>, d: vec3<f32>, a: vec3<f32>, b: vec3<f32>, r: f32) -> vec2<f32> {
    var lo = 1e30;
    var hi = -1e30;
    if (r <= 0.0) {
        return vec2<f32>(lo, hi);
    }
    let oa = o - a;
    let ob = o - b;
    let ba_ = dot(oa, d);
    let disc_a = ba_ * ba_ - (dot(oa, oa) - r * r);
    if (disc_a >= 0.0) {
        let q = sqrt(disc_a);
        lo = min(lo, -ba_ - q);
        hi = max(hi, -ba_ + q);
    }
    let bb_ = dot(ob, d);
    let disc_b = bb_ * bb_ - (dot(ob, ob) - r * r);
    if (disc_b >= 0.0) {
        let q = sqrt(disc_b);
        lo = min(lo, -bb_ - q);
        hi = max(hi, -bb_ + q);
    }
    let ba = b - a;
    let baba = dot(ba, ba);
    if (baba > 0.0) {
        let bd = dot(ba, d);
        let bo = dot(ba, oa);
        let dp = d - ba * (bd / baba);
        let op = oa - ba * (bo / baba);
        let qa = dot(dp, dp);
        let qb = dot(op, dp);
        let qc = dot(op, op) - r * r;
        var c0 = 1e30;
        var c1 = -1e30;
        if (qa > 1e-12) {
            let disc = qb * qb - qa * qc;
            if (disc >= 0.0) {
                let q = sqrt(disc);
                c0 = (-qb - q) / qa;
                c1 = (-qb + q) / qa;
            }
        } else if (qc <= 0.0) {
            c0 = -1e30;
            c1 = 1e30;
        }
        var s0 = 1e30;
        var s1 = -1e30;
        if (abs(bd) > 1e-12) {
            let u = -bo / bd;
            let w = (baba - bo) / bd;
            s0 = min(u, w);
            s1 = max(u, w);
        } else if (bo >= 0.0 && bo <= baba) {
            s0 = -1e30;
            s1 = 1e30;
        }
        let x0 = max(c0, s0);
        let x1 = min(c1, s1);
        if (x0 <= x1) {
            lo = min(lo, x0);
            hi = max(hi, x1);
        }
    }
    return vec2<f32>(lo, hi);
}

// A pixel's march: its colour and depth (depth < 0: no wisp there).
struct PixelOut {
    color: vec4<f32>,
    depth: f32,
}

fn depth_of(p: vec3<f32>) -> f32 {
    let clip = frame.view_proj * vec4<f32>(p, 1.0);
    return clip.z / clip.w;
}

// Candidates that passed the ray test in the last `gather` (kept or not), and those of them
// that begin by its `t_at` (the slots a window there needs).
var<private> n_pass: u32;
var<private> n_live: u32;

// Gathers the tile's segments whose influence capsule this ray crosses and that still matter
// from `t_from` on (influence or shell interval reaching past it). A full list keeps those of
// nearest entry (the nearer of the influence and shell entries) and returns where the first
// dropped one begins, t_drop (1e30: none dropped): no dropped candidate touches the ray
// before it, so the march over the list is exact up to t_drop and gathers again there. The
// list ends in segment order (the per-wisp maximum needs a wisp's segments together). As
// `field::keep_nearest`.
fn gather(tile: u32, eye: vec3<f32>, dir: vec3<f32>, t_far: f32, t_from: f32, t_at: f32) -> f32 {
    n_cand = 0u;
    n_pass = 0u;
    n_live = 0u;
    var t_drop = 1e30;
    let count = tile_counts[tile];
    let base = tile * view.tiles.z;
    for (var k = 0u; k < count; k++) {
        let j = tile_lists[base + k];
        let c = capsules[j];
        let sh = shells[j];
        // A bounding sphere first: most of a tile's segments miss most of its rays.
        let mid = 0.5 * (c.a.xyz + c.b.xyz);
        let rad = 0.5 * length(c.b.xyz - c.a.xyz) + max(c.a.w, sh);
        let oc = eye - mid;
        let bq = dot(oc, dir);
        let disc = bq * bq - (dot(oc, oc) - rad * rad);
        if (disc < 0.0 || -bq + sqrt(disc) < t_from) {
            continue;
        }
        let iv = ray_capsule(eye, dir, c.a.xyz, c.b.xyz, c.a.w);
        if (iv.x > iv.y || iv.y < 0.0 || iv.x > t_far) {
            continue;
        }
        // The shell lies inside the influence capsule unless the outline is wider than the
        // gap between them.
        var sv = vec2<f32>(1e30, -1e30);
        var key = iv.x;
        var reach = iv.y;
        if (sh > c.a.w) {
            sv = ray_capsule(eye, dir, c.a.xyz, c.b.xyz, sh);
            key = min(key, sv.x);
            reach = max(reach, sv.y);
        }
        if (reach < t_from) {
            continue;
        }
        n_pass++;
        if (key <= t_at) {
            n_live++;
        }
        var slot = n_cand;
        if (n_cand >= RAY_SLOTS) {
            // Full: replace the farthest entry if this one begins nearer.
            slot = 0u;
            for (var q = 1u; q < RAY_SLOTS; q++) {
                if (c_key[q] > c_key[slot]) {
                    slot = q;
                }
            }
            if (key >= c_key[slot]) {
                t_drop = min(t_drop, key);
                continue;
            }
            t_drop = min(t_drop, c_key[slot]);
        } else {
            n_cand++;
        }
        if (sh <= c.a.w) {
            sv = ray_capsule(eye, dir, c.a.xyz, c.b.xyz, sh);
        }
        c_seg[slot] = j;
        c_iv[slot] = vec4<f32>(iv, sv);
        c_key[slot] = key;
    }
    if (t_drop < 1e30) {
        // Back into segment order.
        for (var a = 1u; a < n_cand; a++) {
            var b = a;
            while (b > 0u && c_seg[b - 1u] > c_seg[b]) {
                let sg = c_seg[b];
                c_seg[b] = c_seg[b - 1u];
                c_seg[b - 1u] = sg;
                let iv = c_iv[b];
                c_iv[b] = c_iv[b - 1u];
                c_iv[b - 1u] = iv;
                let ky = c_key[b];
                c_key[b] = c_key[b - 1u];
                c_key[b - 1u] = ky;
                b--;
            }
        }
    }
    return t_drop;
}

// The march of the ray through the centre `pos` of a pixel of `tile`.
fn march_pixel(pos: vec2<f32>, tile: u32) -> PixelOut {
    let ndc = vec2<f32>(pos.x / view.size.x * 2.0 - 1.0, 1.0 - pos.y / view.size.y * 2.0);
    let fw = view.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    let eye = view.eye.xyz;
    let to = fw.xyz / fw.w - eye;
    let t_far = length(to);
    let dir = to / t_far;
    // The ray's candidates, a window of them at a time: the march is exact before t_drop and
    // gathers again when it gets there. Only more than RAY_SLOTS candidates touching the ray
    // at once overflow: `over` is where, and a ray whose answer lies beyond it is counted.
    var t_drop = gather(tile, eye, dir, t_far, 0.0, 0.0);
    var over = 1e30;
    var first = 1e30;
    for (var k = 0u; k < n_cand; k++) {
        first = min(first, c_iv[k].z);
    }
    let counting = view.flags.x == 1u;
    if (counting && n_pass > 0u) {
        atomicAdd(&stats[4], n_pass);
        atomicAdd(&stats[5], 1u);
    }
    // Outline shell thickness per unit distance (outline pixels at the focal length).
    let eps_per_t = view.eye.w;
    let max_steps = u32(draw.march.z);
    // A dropped candidate's shell may begin before the kept ones' first shell.
    var t = max(min(first, t_drop), 0.0);
    var t_prev = -1.0;
    var shell_t = -1.0;
    var hit = false;
    var steps = 0u;
    loop {
        if (steps >= max_steps || t > t_far) {
            break;
        }
        if (t_drop < 1e30 && t >= t_drop) {
            // The window's end: gather again from the last sample (bisection may go back
            // there).
            var t_from = t;
            if (t_prev >= 0.0) {
                t_from = t_prev;
            }
            let nd = gather(tile, eye, dir, t_far, t_from, t);
            if (nd <= t) {
                // More candidates touch the ray here than the list holds: say how many.
                over = min(over, nd);
                atomicMax(&stats[7], n_live);
                t_drop = 1e30;
            } else {
                t_drop = nd;
            }
        }
        // In some shell interval? If not, jump to the next one (nothing between is inside
        // the surface or its outline) or to the window's end.
        var inside = false;
        var next_shell = t_drop;
        var next_in = t_drop;
        for (var k = 0u; k < n_cand; k++) {
            inside = inside || (c_iv[k].z <= t && t <= c_iv[k].w);
            if (c_iv[k].z > t) {
                next_shell = min(next_shell, c_iv[k].z);
            }
            if (c_iv[k].x > t) {
                next_in = min(next_in, c_iv[k].x);
            }
        }
        if (!inside) {
            if (shell_t >= 0.0) {
                break;
            }
            t = next_shell;
            t_prev = -1.0;
            continue;
        }
        steps++;
        let p = eye + t * dir;
        // The widest outline any wisp may draw (view.size.w, the largest outline scale)
        // decides whether a sample is off every outline.
        let eps = eps_per_t * t * view.size.w;
        let clear = clear_step(t, p);
        if (clear > 2.0 * eps) {
            // Outside, and off the outline: move by the clear step less the outline width.
            if (shell_t >= 0.0) {
                break;
            }
            t_prev = t;
            t += max(min((clear - eps) * draw.march.y, next_in - t), 1e-6 * (1.0 + t));
            continue;
        }
        let smp = field(t, p);
        if (smp.f >= 0.0) {
            hit = true;
            break;
        }
        let eps_here = eps_per_t * t * smp.outline;
        let in_shell = smp.f + length(smp.grad) * eps_here >= 0.0;
        if (in_shell && shell_t < 0.0) {
            shell_t = t;
        }
        if (!in_shell && shell_t >= 0.0) {
            break;
        }
        var step = min(max(smp.step, clear) * draw.march.y, next_in - t);
        if (in_shell) {
            step = max(step, 0.25 * eps_here);
        }
        step = max(step, 1e-6 * (1.0 + t));
        t_prev = t;
        t += step;
    }
    if (counting) {
        atomicAdd(&stats[3], steps);
    }
    // The answer lies beyond a dropped candidate (or there is none and one was dropped).
    var decided = 1e30;
    if (hit) {
        decided = t;
    } else if (shell_t >= 0.0 && eps_per_t > 0.0) {
        decided = shell_t;
    }
    if (over <= t_far && decided >= over) {
        atomicAdd(&stats[0], 1u);
    }
    var out: PixelOut;
    if (hit) {
        var th = t;
        if (t_prev >= 0.0) {
            // Bisection between the last outside sample and the first inside one.
            var a = t_prev;
            var b = t;
            for (var i = 0u; i < u32(draw.march.w); i++) {
                let m = 0.5 * (a + b);
                if (field(m, eye + m * dir).f >= 0.0) {
                    b = m;
                } else {
                    a = m;
                }
            }
            th = 0.5 * (a + b);
        }
        let p = eye + th * dir;
        let g = field(th, p).grad;
        var n = -dir;
        if (dot(g, g) > 0.0) {
            n = -normalize(g);
        }
        toon_shadow = shadow_toon(p);
        out.color = vec4<f32>(toon_at(n, -dir), 1.0);
        out.depth = depth_of(p);
        if (counting) {
            atomicAdd(&stats[6], 1u);
        }
        return out;
    }
    // A ray that left the shell (or ran out of steps or shells in it) without touching the
    // surface is on a silhouette.
    if (shell_t >= 0.0 && eps_per_t > 0.0) {
        out.color = vec4<f32>(draw.outline.rgb, 1.0);
        out.depth = depth_of(eye + shell_t * dir);
        if (counting) {
            atomicAdd(&stats[6], 1u);
        }
        return out;
    }
    out.color = vec4<f32>(0.0);
    out.depth = -1.0;
    return out;
}

// The march's image, per sample of the target; the composite (`shaders/wisps/composite.wgsl`)
// draws it into the scene with its depth.
@group(1) @binding(10) var march_color: texture_storage_2d<rgba16float, write>;
@group(1) @binding(11) var march_depth: texture_storage_2d<r32float, write>;

// The march in fragments (`block::MarchOn`): one quad per tile some segment reaches (`vs`,
// shaders/wisps/tile_quad.wgsl), each pixel marched once, writing its colour and depth in
// the scene pass.
@fragment
fn fs(in: VOut) -> FOut {
    let pix = vec2<u32>(in.pos.xy);
    let side = u32(view.size.z);
    let r = march_pixel(in.pos.xy, (pix.y / side) * view.tiles.x + pix.x / side);
    if (r.depth < 0.0) {
        discard;
    }
    return FOut(r.color, r.depth);
}

// The march in compute: one workgroup per screen tile (TILE = 16 samples a side), one
// invocation per pixel; a tile no segment reaches is skipped whole (the composite does not
// read it).
@compute @workgroup_size(16, 16)
fn march(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let tile = wg.y * view.tiles.x + wg.x;
    if (tile_counts[tile] == 0u) {
        return;
    }
    let pix = wg.xy * 16u + lid.xy;
    if (f32(pix.x) >= view.size.x || f32(pix.y) >= view.size.y) {
        return;
    }
    let r = march_pixel(vec2<f32>(pix) + vec2<f32>(0.5), tile);
    textureStore(march_color, pix, r.color);
    textureStore(march_depth, pix, vec4<f32>(r.depth, 0.0, 0.0, 0.0));
}

