// Per-strand variation (src/systems/anjyo/vary.rs is the f64 twin; block::Variation the
// scene's fields): numbers of zero mean and unit variance from the strand's seeded uniform
// number through the PCG hash (common/random.wgsl), bounded by +-sqrt(3).

fn vary_unit(rand: f32, k: u32) -> f32 {
    let u = f32(pcg_hash(bitcast<u32>(rand) + k) >> 8u) * (1.0 / 16777216.0);
    return (u - 0.5) * 3.4641016;
}

// x melanin, y width, z tint (Material.variation).
fn vary_width(rand: f32, v: vec4<f32>) -> f32 {
    return exp(v.y * vary_unit(rand, 1u));
}

// The strand's absorption multiplier per channel (melanin, and tint towards red for a
// negative number).
fn vary_absorption(rand: f32, v: vec4<f32>) -> vec3<f32> {
    let m = v.x * vary_unit(rand, 0u);
    let t = v.z * vary_unit(rand, 2u);
    return exp(vec3<f32>(m - t, m, m + t));
}
