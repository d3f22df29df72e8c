// The compute rasteriser for thin strands (issue 12, item 6): on a software adapter the
// triangle setup of two triangles per segment dominates a frame of sub-pixel hair, so each
// strand is walked here instead, one invocation per strand, one step per sample column (or
// row) its segments cross. The f64 reference with the same semantics is
// src/systems/anjyo/splat.rs; keep the two in step.
//
// Coverage is analytic: a segment of width w samples covers, in the column it crosses over
// a length fx, the vertical band of thickness w * sqrt(1 + slope^2) about its centre line,
// and each sample's share of that band is its coverage a (so a strand's coverages add up to
// its length times its width, and segments meet without overlap). Nodes are shaded as the
// ribbons shade them (common/strand_shade.wgsl) and interpolated along the segment.
//
// Occlusion by the opaque scene (head, skins) is a depth test against the scene pass's
// depth (sample 0 with MSAA). Among the hairs of a sample the result is order-independent:
// the sample keeps, in fixed point with u32 atomics,
//   [0..3] sum of rgb * a * wt,  [3] sum of a * wt,  [4] sum of -ln(1 - a),
// where wt favours the nearer hairs; the resolve (stage/downsample.wgsl) composites
//   hair = (sum rgb a wt / sum a wt) * (1 - T) + scene * T,  T = exp(-sum -ln(1 - a)) = prod(1 - a),
// the exact transmittance of independent coverages, as the ribbons' hashed sample masks
// estimate it with MSAA.


@group(2) @binding(0) var<storage, read_write> accum: array<atomic<u32>>;
@group(2) @binding(1) var scene_depth: SceneDepth;

// Fixed-point scales of the accumulation, as in stage/downsample.wgsl and
// src/gpu/splat.rs (tests/it/gpu_twins.rs checks them).
const COLOR_SCALE: f32 = 16384.0;
const DEPTH_SCALE: f32 = 4096.0;
// Coverage is clamped below 1 in -ln(1 - a), so it stays finite.
const MAX_COVERAGE: f32 = 0.999;
// Depth bias of the test against the opaque depth (NDC), for hair lying on the scalp.
const DEPTH_BIAS: f32 = 1e-5;
// At most this many samples across a segment: wider strands belong to the ribbons.
const MAX_ACROSS: i32 = 16;

// A node on screen: x, y in samples, z NDC depth, w 1 when in front of the camera.
struct ScreenNode {
    p: vec4<f32>,
    rgb: vec3<f32>,
    // Width in samples.
    width: f32,
    // Opacity (scales coverage).
    alpha: f32,
}

fn to_screen(n: ShadedNode) -> ScreenNode {
    var out: ScreenNode;
    let c = frame.view_proj * vec4<f32>(n.pos, 1.0);
    let ok = c.w > 1e-6;
    let w = max(c.w, 1e-6);
    let ndc = c.xyz / w;
    out.p = vec4<f32>(
        (ndc.x * 0.5 + 0.5) * frame.viewport.x,
        (0.5 - ndc.y * 0.5) * frame.viewport.y,
        ndc.z,
        select(0.0, 1.0, ok),
    );
    out.rgb = n.rgb;
    out.width = n.width * frame.raster.x / w;
    out.alpha = n.alpha;
    return out;
}

// Weight of a hair at NDC depth z: the nearer, the more its colour counts.
fn depth_weight(z: f32) -> f32 {
    let d = clamp(1.0 - z, 1.0 / 64.0, 1.0);
    return d * d * d;
}

fn add_sample(x: i32, y: i32, a: f32, z: f32, rgb: vec3<f32>) {
    let size = vec2<i32>(frame.viewport.xy);
    if x < 0 || y < 0 || x >= size.x || y >= size.y || a <= 0.0 {
        return;
    }
    if z > textureLoad(scene_depth, vec2<i32>(x, y), 0).x + DEPTH_BIAS {
        return;
    }
    let aw = a * depth_weight(z);
    let i = 5u * (u32(y) * u32(size.x) + u32(x));
    let c = rgb * aw * COLOR_SCALE + 0.5;
    atomicAdd(&accum[i], u32(c.r));
    atomicAdd(&accum[i + 1u], u32(c.g));
    atomicAdd(&accum[i + 2u], u32(c.b));
    atomicAdd(&accum[i + 3u], u32(aw * COLOR_SCALE + 0.5));
    atomicAdd(&accum[i + 4u], u32(-log(1.0 - min(a, MAX_COVERAGE)) * DEPTH_SCALE + 0.5));
}

// One segment from a to b: step along its major axis one sample column at a time.
fn splat_segment(a_in: ScreenNode, b_in: ScreenNode) {
    if a_in.p.w < 0.5 || b_in.p.w < 0.5 {
        return;
    }
    var a = a_in;
    var b = b_in;
    let d = b.p.xy - a.p.xy;
    let x_major = abs(d.x) >= abs(d.y);
    // (major, minor) coordinates.
    var pa = select(a.p.yx, a.p.xy, x_major);
    var pb = select(b.p.yx, b.p.xy, x_major);
    if pa.x > pb.x {
        let t = a;
        a = b;
        b = t;
        let q = pa;
        pa = pb;
        pb = q;
    }
    let run = pb.x - pa.x;
    if run <= 1e-6 {
        return;
    }
    let slope = (pb.y - pa.y) / run;
    let sec = sqrt(1.0 + slope * slope);
    let size = vec2<i32>(frame.viewport.xy);
    let extent = select(size.y, size.x, x_major);
    let first = max(i32(floor(pa.x)), 0);
    let last = min(i32(floor(pb.x)), extent - 1);
    for (var col = first; col <= last; col++) {
        let lo = max(pa.x, f32(col));
        let hi = min(pb.x, f32(col + 1));
        let fx = hi - lo;
        if fx <= 0.0 {
            continue;
        }
        let t = (0.5 * (lo + hi) - pa.x) / run;
        let yc = mix(pa.y, pb.y, t);
        let half_h = 0.5 * mix(a.width, b.width, t) * sec;
        let z = mix(a.p.z, b.p.z, t);
        let rgb = mix(a.rgb, b.rgb, t);
        let alpha = mix(a.alpha, b.alpha, t);
        let y0 = yc - half_h;
        let y1 = yc + half_h;
        let r0 = i32(floor(y0));
        let r1 = min(i32(floor(y1)), r0 + MAX_ACROSS - 1);
        for (var row = r0; row <= r1; row++) {
            let cover = fx * (min(y1, f32(row + 1)) - max(y0, f32(row))) * alpha;
            if x_major {
                add_sample(col, row, cover, z, rgb);
            } else {
                add_sample(row, col, cover, z, rgb);
            }
        }
    }
}

@compute @workgroup_size(64)
fn splat(@builtin(global_invocation_id) id: vec3<u32>) {
    // Drawn at this level of detail (common/strand_drawn.wgsl).
    let si = drawn_strand(id);
    if si < 0 {
        return;
    }
    let s = strands[si];
    let step = lod_step();
    let last = last_node(s);
    var a = to_screen(shade_node(s, 0u));
    var n = 0u;
    loop {
        if n >= last {
            break;
        }
        n = min(n + step, last);
        let b = to_screen(shade_node(s, n));
        splat_segment(a, b);
        a = b;
    }
}
