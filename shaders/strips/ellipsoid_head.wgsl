// The strips kernel's head on a scene without a mesh head: the ellipsoid only, and no field
// bound (such a scene uploads no SDF). The same functions as common/sdf.wgsl's HeadHull,
// which the mesh-head module (strips/sdf_head.wgsl) includes instead.

struct HeadHull {
    e: Hull,
    sdf: bool,
}

fn strips_head(center: vec3<f32>, radii: vec3<f32>) -> HeadHull {
    return HeadHull(Hull(center, radii), false);
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
