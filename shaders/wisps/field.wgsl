// The wisps' field, shared by the ray march (`wisps/march.wgsl`) and the GPU mesher
// (`wisps/mesher.wgsl`): Bézier points, a segment's closest point (Newton or chords), eq 9
// and the per-wisp maximum over open joints. f64 twins in `src/systems/wisps/curve.rs` and
// `field.rs`.

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

// The per-wisp maximum with open interior joints (`field::WispMax`): a segment's end cap at
// a joint counts only where its neighbour's closest point is that neighbour's end too; the
// pending segment is folded in once the next one has been seen.
struct WispMax {
    best: f32,
    best_grad: vec3<f32>,
    best_o: f32,
    // The last pushed segment (global index; 0xffffffff none) and its closest parameter.
    prev: u32,
    prev_t: f32,
    // The pending segment's density, gradient and outline scale (rho < 0: none).
    p_rho: f32,
    p_grad: vec3<f32>,
    p_o: f32,
}

fn wisp_max_new() -> WispMax {
    return WispMax(0.0, vec3<f32>(0.0), 1.0, 0xffffffffu, 0.0, -1.0, vec3<f32>(0.0), 1.0);
}

fn wisp_fold(m: ptr<function, WispMax>) {
    if ((*m).p_rho > (*m).best) {
        (*m).best = (*m).p_rho;
        (*m).best_grad = (*m).p_grad;
        (*m).best_o = (*m).p_o;
    }
    (*m).p_rho = -1.0;
}

fn wisp_push(m: ptr<function, WispMax>, j: u32, t: f32, rho: f32, grad: vec3<f32>, o: f32) {
    var drop_prev = false;
    var drop_cur = false;
    if ((*m).prev != 0xffffffffu && (*m).prev + 1u == j) {
        drop_prev = (*m).prev_t >= 1.0 && t > 0.0;
        drop_cur = t <= 0.0 && (*m).prev_t < 1.0;
    }
    if (!drop_prev) {
        wisp_fold(m);
    }
    (*m).p_rho = select(rho, -1.0, drop_cur);
    (*m).p_grad = grad;
    (*m).p_o = o;
    (*m).prev = j;
    (*m).prev_t = t;
}

// One segment's density at `v` (`field::segment_density`): its closest parameter t by the
// scene's distance method (0 Newton, 1 `pieces` chords), ρ = w(t) fd(D / r(t)) and ∇ρ; or,
// where `v` is as far as the segment's largest radius or farther (from its control-point box
// or its curve), how much farther in `gap` (> 0: nothing near).
struct SegmentDensity {
    gap: f32,
    t: f32,
    rho: f32,
    grad: vec3<f32>,
}

fn segment_density(s: Segment, v: vec3<f32>, method: u32, pieces: u32) -> SegmentDensity {
    var out = SegmentDensity(0.0, 0.0, 0.0, vec3<f32>(0.0));
    let r_max = max(s.c0.w, s.c1.w);
    let a = length(max(max(s.lo.xyz - v, v - s.hi.xyz), vec3<f32>(0.0)));
    if (a >= r_max) {
        // Past the radius by a; at least a tiny gap when exactly on it.
        out.gap = max(a - r_max, 1e-30);
        return out;
    }
    var cp = vec3<f32>(0.0);
    if (method == 0u) {
        out.t = closest_newton(s, v);
        cp = bez(s, out.t);
    } else {
        let c = closest_polyline(s, v, pieces);
        out.t = c.w;
        cp = c.xyz;
    }
    let off = v - cp;
    let d = length(off);
    if (d >= r_max) {
        out.gap = max(d - r_max, 1e-30);
        return out;
    }
    let r = mix(s.c0.w, s.c1.w, out.t);
    let w = mix(s.c2.w, s.c3.w, out.t);
    out.rho = w * fd(d / r);
    if (d > 0.0) {
        out.grad = w * fd_prime(d / r) / r * off / d;
    }
    return out;
}
