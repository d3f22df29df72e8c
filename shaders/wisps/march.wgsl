// Toon wisps drawn by ray marching the blobby surface (Sakai section 5). One instance per
// Bézier segment rasterises the back faces of the segment's influence box (its control-point
// AABB grown by its largest radius): the rasteriser is the acceleration structure, so a pixel
// marches only the boxes that cover it, and each box only the segments in its neighbour list
// (every segment whose density can reach inside it). Sphere tracing with steps bounded by
// the field's Lipschitz constant, bisection on the hit, the analytic gradient for normals,
// depth written so wisps composite with the head, strands and fur. Toon shading in the head
// frame (eqs 14-22) with the angel halo, and a silhouette outline from a thin shell around
// the surface. f64 reference: `src/systems/wisps/field.rs` (same steps, all segments).

// Keep in sync with GpuWispDraw in src/systems/wisps/march.rs.
struct Draw {
    // The head's rotation (columns), for shading in its frame.
    head_x: vec4<f32>,
    head_y: vec4<f32>,
    head_z: vec4<f32>,
    // Linear toon colours; diffuse.w t_diffuse, shade.w t_dark, dark.w t_specular,
    // specular.w 1 for three tones
    diffuse: vec4<f32>,
    shade: vec4<f32>,
    dark: vec4<f32>,
    specular: vec4<f32>,
    // rgb outline colour, w outline width in output pixels
    outline: vec4<f32>,
    // x threshold, y step scale, z max steps, w refine steps
    march: vec4<f32>,
    // x distance method (0 Newton, 1 polyline), y polyline pieces, z neighbour slots,
    // w segments
    method: vec4<u32>,
    // Toon controls (shaders/wisps/toon.wgsl): feathers x lit/shade, y shade/dark, z halo
    // edge, w rim edge
    feather: vec4<f32>,
    // rgb linear rim colour, w rim width (0: no rim)
    rim: vec4<f32>,
    // x cos, y sin of the halo's latitude offset, z halo strength, w 1 when halo_shadow is
    // the halo's colour over the shadow tones
    halo: vec4<f32>,
    halo_shadow: vec4<f32>,
    // x outline taper (root to tip), yzw unused
    taper: vec4<f32>,
}

// Keep in sync with GpuSegment in src/systems/wisps/march.rs.
struct Segment {
    c0: vec4<f32>,
    c1: vec4<f32>,
    c2: vec4<f32>,
    c3: vec4<f32>,
    lo: vec4<f32>,
    hi: vec4<f32>,
}

@group(1) @binding(0) var<uniform> draw: Draw;
@group(1) @binding(1) var<storage, read> segments: array<Segment>;
@group(1) @binding(2) var<storage, read> neighbours: array<u32>;
@group(1) @binding(3) var<storage, read> neighbour_counts: array<u32>;

struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) @interpolate(flat) seg: u32,
}

fn box_lo(s: Segment) -> vec3<f32> {
    return s.lo.xyz - vec3<f32>(max(s.c0.w, s.c1.w));
}

fn box_hi(s: Segment) -> vec3<f32> {
    return s.hi.xyz + vec3<f32>(max(s.c0.w, s.c1.w));
}

// 36 vertices of a box's 12 triangles, outward-facing counter-clockwise.
fn box_corner(v: u32) -> vec3<f32> {
    var idx = array<u32, 36>(
        0u, 2u, 1u, 1u, 2u, 3u, // -z
        4u, 5u, 6u, 5u, 7u, 6u, // +z
        0u, 1u, 4u, 1u, 5u, 4u, // -y
        2u, 6u, 3u, 3u, 6u, 7u, // +y
        0u, 4u, 2u, 2u, 4u, 6u, // -x
        1u, 3u, 5u, 3u, 7u, 5u, // +x
    );
    let c = idx[v];
    return vec3<f32>(f32(c & 1u), f32((c >> 1u) & 1u), f32((c >> 2u) & 1u));
}

@vertex
fn vs(@builtin(vertex_index) v: u32, @builtin(instance_index) seg: u32) -> VOut {
    let s = segments[seg];
    let lo = box_lo(s);
    let hi = box_hi(s);
    let p = mix(lo, hi, box_corner(v));
    var out: VOut;
    out.pos = frame.view_proj * vec4<f32>(p, 1.0);
    out.world = p;
    out.seg = seg;
    return out;
}

fn bez(s: Segment, t: f32) -> vec3<f32> {
    let u = 1.0 - t;
    return u * u * u * s.c0.xyz + 3.0 * u * u * t * s.c1.xyz + 3.0 * u * t * t * s.c2.xyz + t * t * t * s.c3.xyz;
}

fn bez_d1(s: Segment, t: f32) -> vec3<f32> {
    let u = 1.0 - t;
    return 3.0 * u * u * (s.c1.xyz - s.c0.xyz) + 6.0 * u * t * (s.c2.xyz - s.c1.xyz) + 3.0 * t * t * (s.c3.xyz - s.c2.xyz);
}

fn bez_d2(s: Segment, t: f32) -> vec3<f32> {
    let u = 1.0 - t;
    return 6.0 * u * (s.c2.xyz - 2.0 * s.c1.xyz + s.c0.xyz) + 6.0 * t * (s.c3.xyz - 2.0 * s.c2.xyz + s.c1.xyz);
}

fn dist2(s: Segment, v: vec3<f32>, t: f32) -> f32 {
    let d = bez(s, t) - v;
    return dot(d, d);
}

// Closest parameter on a segment by quadratic minimisation then Newton (Wang, Kearney &
// Atkinson), as in curve.rs.
fn closest_newton(s: Segment, v: vec3<f32>) -> f32 {
    var t = array<f32, 3>(0.0, 0.5, 1.0);
    var g = array<f32, 3>(dist2(s, v, 0.0), dist2(s, v, 0.5), dist2(s, v, 1.0));
    for (var it = 0; it < 4; it++) {
        let a = t[0];
        let b = t[1];
        let c = t[2];
        let ga = g[0];
        let gb = g[1];
        let gc = g[2];
        let num = (b * b - c * c) * ga + (c * c - a * a) * gb + (a * a - b * b) * gc;
        let den = (b - c) * ga + (c - a) * gb + (a - b) * gc;
        // Parabola curvature sign: den / ((a-b)(b-c)(c-a)) must be > 0 for a minimum.
        let prod = (a - b) * (b - c) * (c - a);
        if (abs(den) < 1e-20 || den * prod >= 0.0) {
            break;
        }
        let tn = clamp(0.5 * num / den, 0.0, 1.0);
        let gn = dist2(s, v, tn);
        // Replace the sample with the largest value.
        var worst = 0;
        if (g[1] > g[worst]) {
            worst = 1;
        }
        if (g[2] > g[worst]) {
            worst = 2;
        }
        t[worst] = tn;
        g[worst] = gn;
    }
    var best = 0;
    if (g[1] < g[best]) {
        best = 1;
    }
    if (g[2] < g[best]) {
        best = 2;
    }
    var tt = t[best];
    for (var it = 0; it < 3; it++) {
        let d = bez(s, tt) - v;
        let d1 = bez_d1(s, tt);
        let gp = 2.0 * dot(d, d1);
        let gpp = 2.0 * (dot(d1, d1) + dot(d, bez_d2(s, tt)));
        if (gpp <= 0.0) {
            break;
        }
        tt = clamp(tt - gp / gpp, 0.0, 1.0);
    }
    // The ends may be nearer than the interior minimum.
    var t_best = tt;
    var g_best = dist2(s, v, tt);
    let g0 = dist2(s, v, 0.0);
    if (g0 < g_best) {
        t_best = 0.0;
        g_best = g0;
    }
    let g1 = dist2(s, v, 1.0);
    if (g1 < g_best) {
        t_best = 1.0;
    }
    return t_best;
}

// Closest point on a segment taken as `pieces` chords (closed form per chord): xyz the point
// on the chord, w its parameter interpolated along the chord (for r and w).
fn closest_polyline(s: Segment, v: vec3<f32>, pieces: u32) -> vec4<f32> {
    var best_t = 0.0;
    var best_p = s.c0.xyz;
    var best_g = 1e30;
    var a = s.c0.xyz;
    for (var k = 0u; k < pieces; k++) {
        let t1 = f32(k + 1u) / f32(pieces);
        let b = bez(s, t1);
        let ab = b - a;
        let l2 = dot(ab, ab);
        var u = 0.0;
        if (l2 > 0.0) {
            u = clamp(dot(v - a, ab) / l2, 0.0, 1.0);
        }
        let d = a + u * ab - v;
        let g = dot(d, d);
        if (g < best_g) {
            best_g = g;
            best_t = (f32(k) + u) / f32(pieces);
            best_p = a + u * ab;
        }
        a = b;
    }
    return vec4<f32>(best_p, best_t);
}

// Eq 9 and its derivative.
fn fd(x: f32) -> f32 {
    if (x > 1.0) {
        return 0.0;
    }
    if (x > 1.0 / 3.0) {
        return 1.5 * (1.0 - x) * (1.0 - x);
    }
    return 1.0 - 3.0 * x * x;
}

fn fd_prime(x: f32) -> f32 {
    if (x > 1.0) {
        return 0.0;
    }
    if (x > 1.0 / 3.0) {
        return -3.0 * (1.0 - x);
    }
    return -6.0 * x;
}

struct Sample {
    // f (density minus threshold)
    f: f32,
    grad: vec3<f32>,
    // A step along any direction that cannot reach the surface (see `safe_step`).
    step: f32,
}

// Near segments of one sample: x distance D, y largest radius, z largest weight, w wisp.
const NEAR_MAX: u32 = 64u;

// The largest s such that no point within s of the sample can be inside, from the near
// segments' distances: a segment's density there is at most w_max fd(max(D - s, 0) / r_max)
// (D shrinks by at most s; fd falls with distance; r and w are at most their largest along
// the segment), so the field is below the threshold while the sum over wisps of the largest
// such bound is. Bisection keeps the lower end, which is always safe.
fn distance_step(near: ptr<function, array<vec4<f32>, 64>>, n: u32, s_hi: f32) -> f32 {
    var lo = 0.0;
    var hi = s_hi;
    for (var it = 0; it < 6; it++) {
        let s = 0.5 * (lo + hi);
        var sum = 0.0;
        var wisp = -1.0;
        var wisp_max = 0.0;
        for (var k = 0u; k < n; k++) {
            let e = (*near)[k];
            if (e.w != wisp) {
                sum += wisp_max;
                wisp = e.w;
                wisp_max = 0.0;
            }
            wisp_max = max(wisp_max, e.z * fd(max(e.x - s, 0.0) / e.y));
        }
        sum += wisp_max;
        if (sum < draw.march.x) {
            lo = s;
        } else {
            hi = s;
        }
    }
    return lo;
}

// The field at `v` from the segments in `list` (the neighbours of the box being marched that
// the ray passes near): per wisp the largest segment density
// (the wisp's segments are consecutive in the list), summed over wisps; and a safe step:
// the larger of the Lipschitz step (-f / sum of the near segments' bounds) and the distance
// step, never past where a far segment's influence begins.
fn field(list: ptr<function, array<u32, 64>>, count: u32, v: vec3<f32>, with_step: bool) -> Sample {
    var out: Sample;
    var lip = 0.0;
    var far_gap = 1e30;
    var near: array<vec4<f32>, 64>;
    var n_near = 0u;
    var s_hi = 1e30;
    var sum = 0.0;
    var grad = vec3<f32>(0.0);
    var wisp = -1.0;
    var wisp_max = 0.0;
    var wisp_grad = vec3<f32>(0.0);
    for (var k = 0u; k < count; k++) {
        let s = segments[(*list)[k]];
        if (s.hi.w != wisp) {
            sum += wisp_max;
            grad += wisp_grad;
            wisp = s.hi.w;
            wisp_max = 0.0;
            wisp_grad = vec3<f32>(0.0);
        }
        let r_max = max(s.c0.w, s.c1.w);
        let a = length(max(max(s.lo.xyz - v, v - s.hi.xyz), vec3<f32>(0.0)));
        if (a >= r_max) {
            far_gap = min(far_gap, a - r_max);
            continue;
        }
        var t = 0.0;
        var cp = vec3<f32>(0.0);
        if (draw.method.x == 0u) {
            t = closest_newton(s, v);
            cp = bez(s, t);
        } else {
            let c = closest_polyline(s, v, draw.method.y);
            t = c.w;
            cp = c.xyz;
        }
        let off = v - cp;
        let d = length(off);
        if (d >= r_max) {
            far_gap = min(far_gap, d - r_max);
            continue;
        }
        lip += s.lo.w;
        if (n_near < NEAR_MAX) {
            near[n_near] = vec4<f32>(d, r_max, max(s.c2.w, s.c3.w), s.hi.w);
            n_near++;
        }
        s_hi = min(s_hi, d);
        let r = mix(s.c0.w, s.c1.w, t);
        let w = mix(s.c2.w, s.c3.w, t);
        let rho = w * fd(d / r);
        if (rho > wisp_max) {
            wisp_max = rho;
            if (d > 0.0) {
                wisp_grad = w * fd_prime(d / r) / r * off / d;
            } else {
                wisp_grad = vec3<f32>(0.0);
            }
        }
    }
    sum += wisp_max;
    grad += wisp_grad;
    out.f = sum - draw.march.x;
    out.grad = grad;
    var step = far_gap;
    // Bisection and the normal need only f and its gradient, not a step.
    if (with_step && n_near > 0u && out.f < 0.0) {
        let s_lip = -out.f / lip;
        let s_dist = distance_step(&near, n_near, min(s_hi, far_gap));
        step = min(max(s_lip, s_dist), far_gap);
    }
    out.step = step;
    return out;
}

struct FOut {
    @location(0) color: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

fn depth_of(p: vec3<f32>) -> f32 {
    let clip = frame.view_proj * vec4<f32>(p, 1.0);
    return clip.z / clip.w;
}

@fragment
fn fs(in: VOut) -> FOut {
    let home = in.seg;
    let s = segments[home];
    let eye = frame.eye.xyz;
    let to = in.world - eye;
    let t_back = length(to);
    let dir = to / t_back;
    // Entry into the box (slab test); 0 when the eye is inside.
    let inv = 1.0 / dir;
    let ta = (box_lo(s) - eye) * inv;
    let tb = (box_hi(s) - eye) * inv;
    let t_enter = max(max(max(min(ta.x, tb.x), min(ta.y, tb.y)), min(ta.z, tb.z)), 0.0);
    // Of the box's neighbours, only those whose influence box the ray crosses between
    // t_enter and t_back can add density on the way: test each once here, not every step.
    var list: array<u32, 64>;
    var count = 0u;
    let slots = draw.method.z;
    let n_nbr = min(neighbour_counts[home], slots);
    for (var k = 0u; k < n_nbr; k++) {
        let j = neighbours[home * slots + k];
        let sj = segments[j];
        let ja = (box_lo(sj) - eye) * inv;
        let jb = (box_hi(sj) - eye) * inv;
        let j_in = max(max(min(ja.x, jb.x), min(ja.y, jb.y)), min(ja.z, jb.z));
        let j_out = min(min(max(ja.x, jb.x), max(ja.y, jb.y)), max(ja.z, jb.z));
        if (j_in <= min(j_out, t_back) && j_out >= t_enter) {
            list[count] = j;
            count++;
        }
    }
    // Outline shell thickness per unit distance: outline pixels at the focal length in
    // samples, times samples per output pixel.
    let eps_per_t = draw.outline.w * max(frame.flags.y, 1.0) / frame.raster.x;
    let max_steps = u32(draw.march.z);
    var t = t_enter;
    var t_prev = t_enter;
    var shell_t = -1.0;
    var hit = false;
    var left_shell = false;
    for (var i = 0u; i < max_steps; i++) {
        let p = eye + t * dir;
        let smp = field(&list, count, p, true);
        if (smp.f >= 0.0) {
            hit = true;
            break;
        }
        let eps = eps_per_t * t;
        let in_shell = smp.f + length(smp.grad) * eps >= 0.0;
        if (in_shell && shell_t < 0.0) {
            shell_t = t;
        }
        if (!in_shell && shell_t >= 0.0) {
            left_shell = true;
            break;
        }
        var step = smp.step * draw.march.y;
        if (in_shell) {
            step = max(step, 0.25 * eps);
        }
        if (step >= 1e29) {
            break;
        }
        step = max(step, 1e-6 * (1.0 + t));
        t_prev = t;
        t += step;
        if (t > t_back) {
            break;
        }
    }
    var out: FOut;
    if (hit) {
        // Bisection between the last outside sample and the first inside one.
        var a = t_prev;
        var b = t;
        for (var i = 0u; i < u32(draw.march.w); i++) {
            let m = 0.5 * (a + b);
            if (field(&list, count, eye + m * dir, false).f >= 0.0) {
                b = m;
            } else {
                a = m;
            }
        }
        let th = 0.5 * (a + b);
        let p = eye + th * dir;
        let g = field(&list, count, p, false).grad;
        var n = -dir;
        if (dot(g, g) > 0.0) {
            n = -normalize(g);
        }
        out.color = vec4<f32>(toon(n), 1.0);
        out.depth = depth_of(p);
        return out;
    }
    // Only a ray that left the shell without touching the surface is on a silhouette; one
    // still in the shell where this box ends is finished by the next box it enters.
    if (left_shell && draw.outline.w > 0.0) {
        out.color = vec4<f32>(draw.outline.rgb, 1.0);
        out.depth = depth_of(eye + shell_t * dir);
        return out;
    }
    discard;
}
