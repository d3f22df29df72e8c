// Toon shading of the wisps' surface (Sakai eqs 14-22) in the head frame, with the angel
// halo (the specular band). Included after `wisps/march.wgsl`, whose `draw` uniform holds the
// colours and thresholds. f64 reference: `shade` in `src/systems/wisps/field.rs`.

// Eqs 14-22 in the head frame (Kami's up, local +y, is the paper's Z).
fn toon(n_world: vec3<f32>) -> vec3<f32> {
    let rot = mat3x3<f32>(draw.head_x.xyz, draw.head_y.xyz, draw.head_z.xyz);
    let n = transpose(rot) * n_world;
    let l = transpose(rot) * normalize(frame.light_dir.xyz);
    // (E_x, E_y, E_z) = (local x, local z, local y)
    let n_lat = n.y;
    let l_lat = l.y;
    let n_lon = length(n.xz);
    let l_lon = length(l.xz);
    let i_spec = n_lat * l_lat + n_lon * l_lon;
    let i_lat = 0.5 * (n_lat + 1.0);
    var cross_term = 0.0;
    if (n_lon > 1e-6 && l_lon > 1e-6) {
        cross_term = dot(l.xz / l_lon, n.xz / n_lon);
    }
    let i_lon = 0.5 * (cross_term + 1.0);
    let i_diff = i_lat * i_lon;
    var c = draw.shade.rgb;
    if (i_diff > draw.diffuse.w) {
        c = draw.diffuse.rgb;
    } else if (draw.specular.w > 0.5 && i_diff <= draw.shade.w) {
        c = draw.dark.rgb;
    }
    if (i_spec > draw.dark.w) {
        c += draw.specular.rgb;
    }
    return min(c, vec3<f32>(1.0));
}
