// The head hull of a kernel built for scenes without a mesh head: the ellipsoid only, the
// same functions as common/sdf.wgsl's HeadHull (which a kernel built for a mesh head
// includes instead), so the kernel's text serves both and such a scene binds no field.

struct HeadHull {
    e: Hull,
    sdf: bool,
}

fn head_hull(center: vec4<f32>, radii: vec4<f32>) -> HeadHull {
    return HeadHull(Hull(center.xyz, radii.xyz), false);
}

fn head_eval(h: HeadHull, p: vec3<f32>) -> f32 {
    return hull_eval(h.e, p);
}

fn head_gradient(h: HeadHull, p: vec3<f32>) -> vec3<f32> {
    return hull_gradient(h.e, p);
}

fn head_normal(h: HeadHull, p: vec3<f32>) -> vec3<f32> {
    return normalize(hull_gradient(h.e, p));
}

fn head_push_out(h: HeadHull, pivot: vec3<f32>, a0: vec3<f32>, p: vec3<f32>, d: f32) -> vec3<f32> {
    return hull_push_out(h.e, pivot, a0, p, d);
}
