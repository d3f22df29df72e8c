// The scene depth the compute rasteriser for thin strands reads, with MSAA (sample 0;
// bound as unfilterable float: GLSL cannot load from depth textures).
alias SceneDepth = texture_multisampled_2d<f32>;
