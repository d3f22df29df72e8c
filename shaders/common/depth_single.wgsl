// The scene depth the compute rasteriser for thin strands reads, without MSAA (a depth
// texture bound as unfilterable float: GLSL cannot load from depth textures).
alias SceneDepth = texture_2d<f32>;
