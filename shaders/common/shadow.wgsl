// The light's shadow structure as every shading module sees it (the stage's shadow pass).
// Contract for every module that includes this file:
// - `shadow_strands(p)`: the expected number of hair strands crossed on the way from world
//   point p towards the key light (the sum of the strands' projected coverage along that
//   ray); 0 where no hair is in the way or while shadows are off. Anjyo's shading attenuates
//   by it; the physical mode's dual scattering reads it as the strand count n.
// - `shadow_opaque(p)`: how much of the key light reaches p past opaque occluders (the head,
//   a mesh head, a fur skin): 1 lit, 0 in their shadow; 1 while shadows are off.
fn shadow_strands(p: vec3<f32>) -> f32 {
    return 0.0 * p.x;
}

fn shadow_opaque(p: vec3<f32>) -> f32 {
    return 1.0 + 0.0 * p.x;
}
