// The head: the ellipsoid (a unit-sphere mesh scaled by the radii) or a mesh head (its own
// vertices and normals, in head coordinates), lit by the scene light with a soft wrap so the
// unlit side is not black.

// Twin of GpuHead (tests/it/gpu_twins.rs checks it) in src/gpu/gpu_data.rs.
struct Head {
    model: mat4x4<f32>,
    rotation: mat4x4<f32>,
    color: vec4<f32>,
    inv_radii2: vec4<f32>,
}

@group(1) @binding(0) var<uniform> head: Head;

struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

@vertex
fn vs(@location(0) unit: vec3<f32>, @location(1) normal: vec3<f32>) -> VOut {
    var out: VOut;
    let world = (head.model * vec4<f32>(unit, 1.0)).xyz;
    out.pos = frame.view_proj * vec4<f32>(world, 1.0);
    out.world = world;
    // Ellipsoid normal: gradient of the quadric, (p - c) / r^2 = unit / r (a mesh head's
    // radii are 1), turned by the pose.
    out.normal = (head.rotation * vec4<f32>(normal * sqrt(head.inv_radii2.xyz), 0.0)).xyz;
    return out;
}

@fragment
fn fs(in: VOut) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let l = frame.light_dir.xyz;
    let v = normalize(frame.eye.xyz - in.world);
    let wrap = max((dot(n, l) + 0.3) / 1.3, 0.0);
    let h = normalize(l + v);
    let spec = 0.08 * pow(max(dot(n, h), 0.0), 30.0);
    let ambient = 0.3 * frame.light_color.w;
    // The hair's shadow (common/shadow.wgsl) dims the direct light; the head's own
    // terminator stays the soft wrap.
    var direct: f32;
    if shadow_is_toon() {
        // A toon scene's head: the wisps' shadow is a step.
        direct = frame.light_dir.w * (1.0 - shadow_toon(in.world));
    } else {
        direct = frame.light_dir.w * shadow_absorbed(shadow_strands(in.world));
    }
    if head.color.w > 0.5 {
        // The physical mode: a Lambertian of the head's colour under the light and the even
        // ambient environment, as the path tracer's head (src/bench/look/mitsuba.rs).
        let lambert = ambient + direct * max(dot(n, l), 0.0);
        return vec4<f32>(head.color.rgb * frame.light_color.rgb * lambert, 1.0);
    }
    let rgb = head.color.rgb * (ambient + 0.8 * direct * wrap) + frame.light_color.rgb * spec * direct;
    return vec4<f32>(rgb, 1.0);
}
