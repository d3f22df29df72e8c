// Shared by the wisps' curve kernels and ray march: chord distances and eq 9 inverted.
// f64 twins: `curve::chord_distance` and `curve::fd_inverse`.

// Distance from p to the chord a-b.
fn chord_distance(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>) -> f32 {
    let ab = b - a;
    let l2 = dot(ab, ab);
    var u = 0.0;
    if (l2 > 0.0) {
        u = clamp(dot(p - a, ab) / l2, 0.0, 1.0);
    }
    return length(a + u * ab - p);
}

// x with fd(x) = y for y in (0, 1] (eq 9 inverted; fd falls from 1 at 0 to 0 at 1).
fn fd_inverse(y: f32) -> f32 {
    if (y <= 2.0 / 3.0) {
        return 1.0 - sqrt(y / 1.5);
    }
    return sqrt((1.0 - y) / 3.0);
}
