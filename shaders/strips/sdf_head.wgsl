// The strips kernel's head on a mesh-head scene: the head's signed distance field
// (common/sdf.wgsl, included before this file), bound at 10. The module for scenes without
// a mesh head includes strips/ellipsoid_head.wgsl instead and binds no field.

@group(0) @binding(10) var<storage, read> sdf_data: array<f32>;

fn strips_head(center: vec3<f32>, radii: vec3<f32>) -> HeadHull {
    return HeadHull(Hull(center, radii), true);
}

// The field's outward unit normal; up where its gradient vanishes (Vec3::normalize_or).
fn head_normal(h: HeadHull, p: vec3<f32>) -> vec3<f32> {
    let g = head_gradient(h, p);
    let l = length(g);
    if l > 0.0 {
        return g / l;
    }
    return vec3<f32>(0.0, 1.0, 0.0);
}
