// Toon shading of the wisps' surface (Sakai eqs 14-22) in the head frame, with the angel
// halo (the specular band) and the toon controls: a feather on every step, the halo's
// latitude offset, strength and colour over the shadow tones, and the rim light. Included
// after `wisps/march.wgsl` or `wisps/mesh.wgsl`, whose `draw` uniform (`wisps/draw.wgsl`)
// holds the colours, thresholds and controls.
// f64 reference: `src/systems/wisps/toon.rs` (same steps, same order; `shade_at` is
// `toon_at`).

// 1 where the point shaded is in a toon shadow (common/shadow.wgsl's `shadow_toon`, set by
// the march before it shades): the lit tone gives way to the lower ones. 0 keeps the f64
// reference's colours (src/systems/wisps/toon.rs).
var<private> toon_shadow: f32 = 0.0;

// A feathered step: exactly 0 or 1 (x > t) for feather <= 0, else the smoothstep from
// t - feather/2 to t + feather/2 (`toon::step`).
fn toon_step(x: f32, t: f32, feather: f32) -> f32 {
    if (feather <= 0.0) {
        return select(0.0, 1.0, x > t);
    }
    let u = clamp((x - t) / feather + 0.5, 0.0, 1.0);
    return u * u * (3.0 - 2.0 * u);
}

// a (1 - w) + b w: exactly a at w = 0 and b at w = 1 (a fused multiply-add keeps that).
fn toon_blend(a: vec3<f32>, b: vec3<f32>, w: f32) -> vec3<f32> {
    return a * (1.0 - w) + b * w;
}

// The camera's viewing direction: the w row of the perspective view_proj (`camera_forward`).
fn camera_forward() -> vec3<f32> {
    let m = frame.view_proj;
    return normalize(vec3<f32>(m[0].w, m[1].w, m[2].w));
}

// Toon colour of a surface point with unit normal `n_world` seen along `v_world` (unit, from
// the point towards the eye).
fn toon_at(n_world: vec3<f32>, v_world: vec3<f32>) -> vec3<f32> {
    let rot = mat3x3<f32>(draw.head_x.xyz, draw.head_y.xyz, draw.head_z.xyz);
    let n = transpose(rot) * n_world;
    let l = transpose(rot) * normalize(frame.light_dir.xyz);
    // Eqs 14-19 with (E_x, E_y, E_z) = (local x, local z, local y).
    let n_lat = n.y;
    let l_lat = l.y;
    let n_lon = length(n.xz);
    let l_lon = length(l.xz);
    // The halo's light: latitude raised by the offset (cos, sin in draw.halo.xy).
    let s_lat = l_lat * draw.halo.x + l_lon * draw.halo.y;
    let s_lon = l_lon * draw.halo.x - l_lat * draw.halo.y;
    let i_spec = n_lat * s_lat + n_lon * s_lon;
    let i_lat = 0.5 * (n_lat + 1.0);
    var cross_term = 0.0;
    if (n_lon > 1e-6 && l_lon > 1e-6) {
        cross_term = dot(l.xz / l_lon, n.xz / n_lon);
    }
    let i_lon = 0.5 * (cross_term + 1.0);
    let i_diff = i_lat * i_lon;
    // Eqs 20-22: the tones by feathered steps (specular.w is 1 for three tones).
    let lit = toon_step(i_diff, draw.diffuse.w, draw.feather.x) * (1.0 - toon_shadow);
    var lower = draw.shade.rgb;
    if (draw.specular.w > 0.5) {
        lower = toon_blend(draw.dark.rgb, draw.shade.rgb, toon_step(i_diff, draw.shade.w, draw.feather.y));
    }
    var c = toon_blend(lower, draw.diffuse.rgb, lit);
    // The angel halo (t_specular in dark.w).
    let halo = toon_step(i_spec, draw.dark.w, draw.feather.z);
    if (halo > 0.0) {
        var colour = draw.specular.rgb;
        if (draw.halo.w > 0.5) {
            colour = toon_blend(draw.halo_shadow.rgb, draw.specular.rgb, lit);
        }
        c += colour * (draw.halo.z * halo);
    }
    // The rim: near the silhouette (N.V below the width), on the side away from the light.
    if (draw.rim.w > 0.0) {
        let rim = toon_step(draw.rim.w - dot(n_world, v_world), 0.0, draw.feather.w) * (1.0 - lit);
        if (rim > 0.0) {
            c += draw.rim.rgb * rim;
        }
    }
    return min(c, vec3<f32>(1.0));
}

// What the march calls: V along the camera's axis, not the pixel's ray, until the march
// passes its ray (`toon_at(n, -dir)`). Only the rim depends on V.
fn toon(n_world: vec3<f32>) -> vec3<f32> {
    return toon_at(n_world, -camera_forward());
}

// The outline width multiplier at parameter t of a segment whose per-segment outline data
// (`toon::segment_outlines`: scale, u at the start, u at the end) is `o`, with the taper in
// draw.taper.x (`toon::outline_scale`). For the march's silhouette shell.
fn outline_scale(o: vec4<f32>, t: f32) -> f32 {
    let u = o.y * (1.0 - t) + o.z * t;
    return o.x * (1.0 - draw.taper.x * u);
}
