// Rotation of v by the rotation vector w (axis * angle), Rodrigues' formula.
fn rotate_vec(w: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    let angle = length(w);
    if angle < 1e-30 {
        return v;
    }
    let k = w / angle;
    let c = cos(angle);
    let s = sin(angle);
    return v * c + cross(k, v) * s + k * dot(k, v) * (1.0 - c);
}
