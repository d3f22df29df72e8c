// Mesh motion: a travelling wave u = A sin(k (p.axis) - 2 pi frame / period) along `dir`.
// Keep in step with kami::systems::fur::setup::deform. `motion`: x amplitude, y k = 2 pi / wavelength,
// z phase offset (2 pi frame / period), w 1 when on.
struct Deformed {
    p: vec3<f32>,
    n: vec3<f32>,
}

fn deform(motion: vec4<f32>, axis: vec3<f32>, dir: vec3<f32>, p: vec3<f32>, n: vec3<f32>) -> Deformed {
    if motion.w < 0.5 {
        return Deformed(p, n);
    }
    let phase = motion.y * dot(p, axis) - motion.z;
    let q = p + dir * (motion.x * sin(phase));
    let g = motion.x * motion.y * cos(phase);
    let nn = n - axis * (g * dot(dir, n) / (1.0 + g * dot(axis, dir)));
    let l = length(nn);
    return Deformed(q, select(n, nn / l, l > 1e-12));
}
