//! Per-strand variation (`block::Variation`): the f64 twin of `shaders/common/strand_vary.wgsl`.
//! A strand's numbers come from its seeded uniform number (`GpuStrand::rand`, drawn with the
//! groom) through the PCG hash, so the GPU, the exporter and the reference the bench hands a
//! path tracer all see the same strands vary the same way.

use super::block::Variation;
use crate::rng::hash_unit;

/// sqrt(12): a uniform number on (-1/2, 1/2) times this has unit variance.
const UNIT: f64 = 3.464_101_615_137_754_6;

/// The strand's `k`-th number of zero mean and unit variance (uniform, so bounded by
/// +-sqrt(3): no strand strays far).
pub fn unit(rand: f32, k: u32) -> f64 {
    (f64::from(hash_unit(rand.to_bits().wrapping_add(k))) - 0.5) * UNIT
}

/// What the strand's width is multiplied by.
pub fn width_factor(rand: f32, v: &Variation) -> f64 {
    (v.width * unit(rand, 1)).exp()
}

/// What the strand's absorption (sigma_a, per channel) is multiplied by: its melanin and
/// its tint (towards red for a negative tint number).
pub fn absorption(rand: f32, v: &Variation) -> [f64; 3] {
    let (m, t) = (v.melanin * unit(rand, 0), v.tint * unit(rand, 2));
    [(m - t).exp(), m.exp(), (m + t).exp()]
}

/// The Anjyo mode's colour of the strand: each linear channel c to the power of its
/// absorption factor (what scaling a fibre's absorption does to the light it sends back).
pub fn color(linear: [f64; 3], rand: f32, v: &Variation) -> [f64; 3] {
    let a = absorption(rand, v);
    std::array::from_fn(|i| linear[i].max(0.0).powf(a[i]))
}
