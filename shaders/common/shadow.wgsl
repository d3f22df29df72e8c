// The light's shadow structure as every shading module sees it (the stage's shadow pass).
// Contract: `shadow_strands(p)` is the expected number of hair strands crossed on the way
// from world point p towards the key light (the sum of the strands' projected coverage
// along that ray), 0 where nothing is in the way or while shadows are off. Anjyo's shading
// attenuates by it; the physical mode's dual scattering reads it as the strand count n.
fn shadow_strands(p: vec3<f32>) -> f32 {
    return 0.0 * p.x;
}
