// The ellipsoidal head hull. Keep in step with src/scene/head.rs (Ellipsoid).

const PI: f32 = 3.14159265358979;
// Pushed nodes end this far outside, in units of the quadric form.
// How far outside the hull a pushed-out node lands (`scene::head::EPS_OUT`, passed by the
// Rust side as a pipeline-overridable constant).
override EPS_OUT: f32;

struct Hull {
    center: vec3<f32>,
    radii: vec3<f32>,
}

// Quadric form: negative inside.
fn hull_eval(h: Hull, p: vec3<f32>) -> f32 {
    let q = (p - h.center) / h.radii;
    return dot(q, q) - 1.0;
}

fn hull_gradient(h: Hull, p: vec3<f32>) -> vec3<f32> {
    return 2.0 * (p - h.center) / (h.radii * h.radii);
}

// Any unit vector orthogonal to unit v (Duff et al. 2017; glam's any_orthonormal_vector).
fn any_orthonormal(v: vec3<f32>) -> vec3<f32> {
    let sign = select(-1.0, 1.0, v.z >= 0.0);
    let a = -1.0 / (sign + v.z);
    let b = v.x * v.y * a;
    return vec3<f32>(b, sign + v.y * v.y * a, -v.y);
}

// Point at angle phi on the circle of radius d about the pivot in the plane (u, v).
// Normalised because GPU sin/cos may be off by 2^-11 (Vulkan's precision bound), which
// would otherwise change segment lengths.
fn circle_point(pivot: vec3<f32>, u: vec3<f32>, v: vec3<f32>, d: f32, phi: f32) -> vec3<f32> {
    return pivot + d * normalize(cos(phi) * u + sin(phi) * v);
}

// Anjyo's collision response: an inside node moves to the nearest outside point on the
// circle of radius d about the pivot, in the plane of the previous segment a0 and the node.
// The circle is scanned in steps of pi/32 both ways from the node, then the crossing is
// halved 20 times. Each halving takes the mid direction as normalize(lo + hi),
// the exact bisector of two unit vectors less than pi apart, instead of cos and sin of the
// mid angle, and works in the circle's plane (2D unit vectors, the quadric form expanded
// once per call). A SIMD adapter runs the 20 halvings for every lane of a group when one
// lane collides, so they dominated the collision's cost.
fn hull_push_out(h: Hull, pivot: vec3<f32>, a0: vec3<f32>, p: vec3<f32>, d: f32) -> vec3<f32> {
    if hull_eval(h, p) >= 0.0 {
        return p;
    }
    let w = p - pivot;
    var v = w - dot(w, a0) * a0;
    if length(v) <= 1e-6 * d {
        let g = hull_gradient(h, p);
        v = g - dot(g, a0) * a0;
        if length(v) <= 1e-7 * length(g) {
            v = any_orthonormal(a0);
        }
    }
    v = normalize(v);
    let phi0 = atan2(dot(w, v), dot(w, a0));
    // The circle in its plane: the point at (x, y) = (cos, sin) of an angle is
    // pivot + d (x a0 + y v), and its quadric form is |qa + x qb + y qc|^2 - 1.
    let qa = (pivot - h.center) / h.radii;
    let qb = d * a0 / h.radii;
    let qc = d * v / h.radii;
    let step = PI / 32.0;
    for (var n = 1u; n <= 32u; n++) {
        for (var k = 0u; k < 2u; k++) {
            let dir = select(-1.0, 1.0, k == 0u);
            let phi = phi0 + dir * f32(n) * step;
            var hi = normalize(vec2<f32>(cos(phi), sin(phi)));
            if circle_form(qa, qb, qc, hi) >= EPS_OUT {
                let phi_lo = phi - dir * step;
                var lo = normalize(vec2<f32>(cos(phi_lo), sin(phi_lo)));
                for (var b = 0u; b < 20u; b++) {
                    let mid = normalize(lo + hi);
                    if circle_form(qa, qb, qc, mid) >= EPS_OUT {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return pivot + d * normalize(hi.x * a0 + hi.y * v);
            }
        }
    }
    return pivot + d * normalize(hull_gradient(h, pivot));
}

fn circle_form(qa: vec3<f32>, qb: vec3<f32>, qc: vec3<f32>, u: vec2<f32>) -> f32 {
    let q = qa + u.x * qb + u.y * qc;
    return dot(q, q) - 1.0;
}
