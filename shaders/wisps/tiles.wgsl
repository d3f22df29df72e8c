// Screen tiles for the wisps' ray march (Kanamori et al. 2008's tile lists for metaballs,
// with each segment's capsule as its bound). Every frame, after the curve kernels:
// `bound`: one invocation per segment writes the screen rectangle (in tiles) that its
// influence capsule covers, and the radius of its shell capsule, where the march samples
// (the hit capsule grown by twice the outline's half-width at the segment's far side).
// `bin`: one invocation per tile lists, in segment order (a wisp's segments stay together,
// which the per-wisp maximum of the field needs), every segment whose rectangle holds the
// tile. A tile with more segments than its list holds keeps the first ones and is counted in
// `stats` (read back by the CLI, the viewer and the tests): never dropped silently.
// f64 reference: `tiles_reference` in `src/systems/wisps/tiles.rs`.

// `View`: shaders/wisps/view.wgsl.

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<storage, read> segments: array<Segment>;
@group(0) @binding(2) var<storage, read> capsules: array<Capsule>;
// Per segment: x0, y0, x1, y1 in tiles (x0 > x1: on no tile).
@group(0) @binding(3) var<storage, read_write> rects: array<vec4<i32>>;
@group(0) @binding(4) var<storage, read_write> shells: array<f32>;
@group(0) @binding(5) var<storage, read_write> tile_counts: array<u32>;
@group(0) @binding(6) var<storage, read_write> tile_lists: array<u32>;
// 0 candidates dropped by full ray lists, 1 tiles whose list overflowed, 2 most segments in
// one tile, 3 march steps, 4 candidates, 5 rays with a candidate, 6 pixels covered (3-6
// only when view.flags.x is 1), 7 the most candidates touching one ray at once where its
// list overflowed.
@group(0) @binding(7) var<storage, read_write> stats: array<atomic<u32>, 8>;

@compute @workgroup_size(64)
fn bound(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= view.tiles.w) {
        return;
    }
    let c = capsules[i];
    let s = segments[i];
    let a = c.a.xyz;
    let b = c.b.xyz;
    let infl = c.a.w;
    var shell = -1.0;
    if (c.b.w >= 0.0) {
        let far = length(view.eye.xyz - 0.5 * (a + b)) + 0.5 * length(b - a) + infl;
        shell = c.b.w + 2.0 * view.eye.w * view.size.w * far;
    }
    shells[i] = shell;
    // The influence capsule's box, cut by the influence box (both hold the influence).
    let r_max = max(s.c0.w, s.c1.w);
    let lo = max(min(a, b) - vec3<f32>(infl), s.lo.xyz - vec3<f32>(r_max));
    let hi = min(max(a, b) + vec3<f32>(infl), s.hi.xyz + vec3<f32>(r_max));
    let w = view.size.x;
    let h = view.size.y;
    var p_lo = vec2<f32>(1e30);
    var p_hi = vec2<f32>(-1e30);
    var behind = false;
    for (var k = 0u; k < 8u; k++) {
        let corner = vec3<f32>(
            select(lo.x, hi.x, (k & 1u) != 0u),
            select(lo.y, hi.y, (k & 2u) != 0u),
            select(lo.z, hi.z, (k & 4u) != 0u),
        );
        let clip = view.view_proj * vec4<f32>(corner, 1.0);
        if (clip.w <= 1e-6) {
            behind = true;
        }
        let ndc = clip.xy / clip.w;
        let px = vec2<f32>((ndc.x * 0.5 + 0.5) * w, (0.5 - 0.5 * ndc.y) * h);
        p_lo = min(p_lo, px);
        p_hi = max(p_hi, px);
    }
    let t = view.size.z;
    let last = vec2<i32>(i32(view.tiles.x) - 1, i32(view.tiles.y) - 1);
    var r = vec4<i32>(0, 0, last.x, last.y);
    if (!behind) {
        // One pixel of slack each side: pixel centres and f32 rounding.
        if (p_hi.x < -1.0 || p_hi.y < -1.0 || p_lo.x > w + 1.0 || p_lo.y > h + 1.0) {
            r = vec4<i32>(1, 1, 0, 0);
        } else {
            let q_lo = clamp(vec2<i32>(floor((p_lo - vec2<f32>(1.0)) / t)), vec2<i32>(0), last);
            let q_hi = clamp(vec2<i32>(floor((p_hi + vec2<f32>(1.0)) / t)), vec2<i32>(0), last);
            r = vec4<i32>(q_lo, q_hi);
        }
    }
    rects[i] = r;
}

@compute @workgroup_size(8, 8)
fn bin(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= view.tiles.x || gid.y >= view.tiles.y) {
        return;
    }
    let tile = gid.y * view.tiles.x + gid.x;
    let cap = view.tiles.z;
    let x = i32(gid.x);
    let y = i32(gid.y);
    var n = 0u;
    for (var j = 0u; j < view.tiles.w; j++) {
        let r = rects[j];
        if (x >= r.x && x <= r.z && y >= r.y && y <= r.w) {
            if (n < cap) {
                tile_lists[tile * cap + n] = j;
            }
            n++;
        }
    }
    tile_counts[tile] = min(n, cap);
    atomicMax(&stats[2], n);
    if (n > cap) {
        atomicAdd(&stats[1], 1u);
    }
}
