// The head hull of every simulation kernel: the ellipsoid (common/ellipsoid.wgsl) or a mesh head's
// signed distance field. Keep in step with src/scene/hull.rs (HeadHull) and
// src/scene/sdf.rs (Sdf::sample, Sdf::gradient, Sdf::to_gpu).
//
// The field is read from `sdf_data`, the world's (common/world.wgsl, group 3):
// words 0..8 are origin.xyz, cell, node counts x y z (as f32), unused; the values follow,
// x fastest. Trilinear between nodes, the analytic gradient of the trilinear interpolant;
// outside the grid the value at the nearest grid point plus the distance to it.

// How far outside the zero level set a pushed node lands (`hull::SDF_EPS_OUT`, scene units).
override SDF_EPS_OUT: f32;

struct HeadHull {
    e: Hull,
    sdf: bool,
}

// false: the kernel's heads are ellipsoids, the SDF path compiled out. Software adapters such
// as lavapipe run every branch of an `if` under a lane mask, so code a uniform flag turns off
// still costs its full price unless the pipeline removes it (`projective_gpu::Variant`,
// `follow_gpu::FollowPass`).
override SDF_HEAD: bool = true;

// From the world's hull (`world_hull`, common/world.wgsl): center.w = 1 selects the SDF.
fn head_hull(center: vec4<f32>, radii: vec4<f32>) -> HeadHull {
    return HeadHull(Hull(center.xyz, radii.xyz), SDF_HEAD && center.w > 0.5);
}

struct SdfCell {
    base: vec3<u32>,
    t: vec3<f32>,
    outside: f32,
}

fn sdf_dims() -> vec3<u32> {
    return vec3<u32>(u32(sdf_data[4]), u32(sdf_data[5]), u32(sdf_data[6]));
}

fn sdf_locate(p: vec3<f32>) -> SdfCell {
    let origin = vec3<f32>(sdf_data[0], sdf_data[1], sdf_data[2]);
    let cell = sdf_data[3];
    let n = sdf_dims();
    let top = vec3<f32>(n - vec3<u32>(1u));
    let u = (p - origin) / cell;
    let uc = clamp(u, vec3<f32>(0.0), top);
    let i = min(vec3<u32>(floor(uc)), max(n, vec3<u32>(2u)) - vec3<u32>(2u));
    var out: SdfCell;
    out.base = i;
    out.t = uc - vec3<f32>(i);
    out.outside = length((u - uc) * cell);
    return out;
}

fn sdf_at(i: u32, j: u32, k: u32) -> f32 {
    let n = sdf_dims();
    let ii = min(i, n.x - 1u);
    let jj = min(j, n.y - 1u);
    let kk = min(k, n.z - 1u);
    return sdf_data[8u + ii + n.x * (jj + n.y * kk)];
}

fn sdf_sample(p: vec3<f32>) -> f32 {
    let c = sdf_locate(p);
    let b = c.base;
    let t = c.t;
    let c000 = sdf_at(b.x, b.y, b.z);
    let c100 = sdf_at(b.x + 1u, b.y, b.z);
    let c010 = sdf_at(b.x, b.y + 1u, b.z);
    let c110 = sdf_at(b.x + 1u, b.y + 1u, b.z);
    let c001 = sdf_at(b.x, b.y, b.z + 1u);
    let c101 = sdf_at(b.x + 1u, b.y, b.z + 1u);
    let c011 = sdf_at(b.x, b.y + 1u, b.z + 1u);
    let c111 = sdf_at(b.x + 1u, b.y + 1u, b.z + 1u);
    let x00 = c000 + (c100 - c000) * t.x;
    let x10 = c010 + (c110 - c010) * t.x;
    let x01 = c001 + (c101 - c001) * t.x;
    let x11 = c011 + (c111 - c011) * t.x;
    let y0 = x00 + (x10 - x00) * t.y;
    let y1 = x01 + (x11 - x01) * t.y;
    return y0 + (y1 - y0) * t.z + c.outside;
}

fn sdf_gradient(p: vec3<f32>) -> vec3<f32> {
    let c = sdf_locate(p);
    let b = c.base;
    let t = c.t;
    let c000 = sdf_at(b.x, b.y, b.z);
    let c100 = sdf_at(b.x + 1u, b.y, b.z);
    let c010 = sdf_at(b.x, b.y + 1u, b.z);
    let c110 = sdf_at(b.x + 1u, b.y + 1u, b.z);
    let c001 = sdf_at(b.x, b.y, b.z + 1u);
    let c101 = sdf_at(b.x + 1u, b.y, b.z + 1u);
    let c011 = sdf_at(b.x, b.y + 1u, b.z + 1u);
    let c111 = sdf_at(b.x + 1u, b.y + 1u, b.z + 1u);
    let gx = mix(mix(c100 - c000, c110 - c010, t.y), mix(c101 - c001, c111 - c011, t.y), t.z);
    let gy = mix(mix(c010 - c000, c110 - c100, t.x), mix(c011 - c001, c111 - c101, t.x), t.z);
    let gz = mix(mix(c001 - c000, c101 - c100, t.x), mix(c011 - c010, c111 - c110, t.x), t.y);
    return vec3<f32>(gx, gy, gz) / sdf_data[3];
}

// Negative inside: the quadric form or the signed distance.
fn head_eval(h: HeadHull, p: vec3<f32>) -> f32 {
    if h.sdf {
        return sdf_sample(p);
    }
    return hull_eval(h.e, p);
}

fn head_gradient(h: HeadHull, p: vec3<f32>) -> vec3<f32> {
    if h.sdf {
        return sdf_gradient(p);
    }
    return hull_gradient(h.e, p);
}

// The outward unit normal: the ellipsoid's as `normalize`, the field's up where its
// gradient vanishes (`HeadHull::normal`).
fn head_normal(h: HeadHull, p: vec3<f32>) -> vec3<f32> {
    let g = head_gradient(h, p);
    if h.sdf {
        let l = length(g);
        if l > 0.0 {
            return g / l;
        }
        return vec3<f32>(0.0, 1.0, 0.0);
    }
    return normalize(g);
}

fn head_eps(h: HeadHull) -> f32 {
    return select(EPS_OUT, SDF_EPS_OUT, h.sdf);
}

// Anjyo's push-out against either hull: `hull_push_out` with `head_eval` and the hull's
// own margin (`scene::head::push_out_implicit`).
fn head_push_out(h: HeadHull, pivot: vec3<f32>, a0: vec3<f32>, p: vec3<f32>, d: f32) -> vec3<f32> {
    if !h.sdf {
        return hull_push_out(h.e, pivot, a0, p, d);
    }
    if head_eval(h, p) >= 0.0 {
        return p;
    }
    let eps = head_eps(h);
    let w = p - pivot;
    var v = w - dot(w, a0) * a0;
    if length(v) <= 1e-6 * d {
        let g = head_gradient(h, p);
        v = g - dot(g, a0) * a0;
        if length(v) <= 1e-7 * length(g) {
            v = any_orthonormal(a0);
        }
    }
    v = normalize(v);
    let phi0 = atan2(dot(w, v), dot(w, a0));
    let step = PI / 32.0;
    for (var n = 1u; n <= 32u; n++) {
        for (var k = 0u; k < 2u; k++) {
            let dir = select(-1.0, 1.0, k == 0u);
            let phi = phi0 + dir * f32(n) * step;
            if head_eval(h, circle_point(pivot, a0, v, d, phi)) >= eps {
                var lo = phi - dir * step;
                var hi = phi;
                for (var b = 0u; b < 20u; b++) {
                    let mid = 0.5 * (lo + hi);
                    if head_eval(h, circle_point(pivot, a0, v, d, mid)) >= eps {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return circle_point(pivot, a0, v, d, hi);
            }
        }
    }
    return pivot + d * normalize(head_gradient(h, pivot));
}
