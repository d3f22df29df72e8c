// Casting into the shadow structure (src/stage/shadow.rs; included after shadow.wgsl by
// each kind's cast module). A caster calls `deposit_segment(a, b, width, opacity)` for each
// segment of its hair; the stage runs every caster once per phase: deep opacity first takes
// the first depth of every texel (phase 0, atomicMax of its complement), then the coverage (phase 1); the
// volume has one phase. Coverage is the strand's projected area (width times the length
// across the light) over the cell's area, in fixed point (SHADOW_FIXED, checked against
// src/gpu/shadow.rs by tests/it/gpu_twins.rs), spread bilinearly over the 4 nearest columns.

@group(2) @binding(0) var<storage, read_write> shadow_accum: array<atomic<u32>>;
// x: the phase (0 first depth, 1 coverage)
@group(2) @binding(1) var<uniform> shadow_phase: vec4<u32>;

const SHADOW_FIXED: f32 = 4096.0;
// Depth in the first-depth map: 24 bits over the box, stored as SCALE - depth so that the
// cleared map (0) is the far side and atomicMax keeps the nearest.
const SHADOW_DEPTH_SCALE: f32 = 16777215.0;
// At most this many points per segment (a segment longer than that many cells leaves gaps
// between its points, which the bilinear spread and the read's filter close).
const SHADOW_MAX_POINTS: u32 = 8u;

fn deposit_point(p: vec3<f32>, coverage: f32) {
    let c = shadow_coords(p);
    let nx = i32(frame.shadow.dims.x);
    let ny = i32(frame.shadow.dims.y);
    let g = c.xy - 0.5;
    let i = vec2<i32>(floor(g));
    let f = g - floor(g);
    let two_half = 2.0 * frame.shadow.axis_u.w;
    let deep = frame.shadow.axis_v.w > 0.5;
    let depth = u32(clamp(c.z / two_half, 0.0, 1.0) * SHADOW_DEPTH_SCALE);
    let iz = clamp(i32(c.z / two_half * frame.shadow.dims.z), 0, i32(frame.shadow.dims.z) - 1);
    for (var k = 0; k < 4; k++) {
        let dx = k & 1;
        let dy = k >> 1u;
        let x = i.x + dx;
        let y = i.y + dy;
        let w = select(1.0 - f.x, f.x, dx == 1) * select(1.0 - f.y, f.y, dy == 1);
        if x < 0 || y < 0 || x >= nx || y >= ny || w <= 0.0 {
            continue;
        }
        let texel = u32(y * nx + x);
        if !deep {
            atomicAdd(&shadow_accum[u32(iz * ny * nx) + texel], u32(coverage * w * SHADOW_FIXED + 0.5));
            continue;
        }
        if shadow_phase.x == 0u {
            atomicMax(&shadow_accum[texel], u32(SHADOW_DEPTH_SCALE) - depth);
            continue;
        }
        let first = (SHADOW_DEPTH_SCALE - f32(atomicLoad(&shadow_accum[texel]))) / SHADOW_DEPTH_SCALE * two_half;
        let off = c.z - first;
        var layer = 3u;
        for (var l = 0u; l < 3u; l++) {
            if off < frame.shadow.layers[l] {
                layer = l;
                break;
            }
        }
        let at = u32(nx * ny) * (1u + layer) + texel;
        atomicAdd(&shadow_accum[at], u32(coverage * w * SHADOW_FIXED + 0.5));
    }
}

// A segment a-b of world width `width` whose coverage counts `opacity` times.
fn deposit_segment(a: vec3<f32>, b: vec3<f32>, width: f32, opacity: f32) {
    if frame.shadow.center.w < 0.5 {
        return;
    }
    let d = b - a;
    let l = frame.shadow.axis_l.xyz;
    let across = length(d - dot(d, l) * l);
    let cell = 2.0 * frame.shadow.axis_u.w / frame.shadow.dims.x;
    let n = clamp(u32(ceil(across / cell)), 1u, SHADOW_MAX_POINTS);
    let coverage = width * across * opacity / (cell * cell) / f32(n);
    if coverage <= 0.0 && shadow_phase.x != 0u {
        return;
    }
    for (var k = 0u; k < n; k++) {
        deposit_point(a + d * ((f32(k) + 0.5) / f32(n)), coverage);
    }
}

// Edge function of q against the edge a-b (twice the signed area of a, b, q).
fn shadow_edge(a: vec2<f32>, b: vec2<f32>, q: vec2<f32>) -> f32 {
    return (b.x - a.x) * (q.y - a.y) - (b.y - a.y) * (q.x - a.x);
}

// An opaque triangle into the skin map, in phase 1 (the phase every method runs; nothing
// without a skin map): each texel whose centre the triangle covers (edges inclusive, so a
// closed mesh leaves no gaps) keeps the nearest depth, as the first depth does (atomicMax
// of its complement). The loops are bounded by the map's size.
fn deposit_triangle(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) {
    if frame.shadow.center.w < 0.5 || frame.shadow.layered.y < 0.5 || shadow_phase.x != 1u {
        return;
    }
    let s = f32(SHADOW_SKIN) / frame.shadow.dims.x;
    let pa = shadow_coords(a);
    let pb = shadow_coords(b);
    let pc = shadow_coords(c);
    let qa = pa.xy * s;
    let qb = pb.xy * s;
    let qc = pc.xy * s;
    let area = shadow_edge(qa, qb, qc);
    if !(abs(area) > 1e-12) {
        return;
    }
    let n = i32(SHADOW_SKIN);
    let lo = max(vec2<i32>(ceil(min(min(qa, qb), qc) - 0.5)), vec2<i32>(0));
    let hi = min(vec2<i32>(floor(max(max(qa, qb), qc) - 0.5)), vec2<i32>(n - 1));
    let two_half = 2.0 * frame.shadow.axis_u.w;
    let base = u32(frame.shadow.layered.z);
    let tol = -1e-6;
    for (var y = lo.y; y <= hi.y; y++) {
        for (var x = lo.x; x <= hi.x; x++) {
            let q = vec2<f32>(f32(x) + 0.5, f32(y) + 0.5);
            let wa = shadow_edge(qb, qc, q) / area;
            let wb = shadow_edge(qc, qa, q) / area;
            let wc = shadow_edge(qa, qb, q) / area;
            if wa < tol || wb < tol || wc < tol {
                continue;
            }
            let z = (wa * pa.z + wb * pb.z + wc * pc.z) / (wa + wb + wc);
            let depth = u32(clamp(z / two_half, 0.0, 1.0) * SHADOW_DEPTH_SCALE);
            atomicMax(&shadow_accum[base + u32(y * n + x)], u32(SHADOW_DEPTH_SCALE) - depth);
        }
    }
}
