// The wisps' draw uniform, read by the march (`wisps/march.wgsl`), the meshed path
// (`wisps/mesh.wgsl`) and the toon shading both share (`wisps/toon.wgsl`).

// Twin of GpuWispDraw (tests/it/gpu_twins.rs checks it) in src/systems/wisps/march.rs.
struct Draw {
    // The head's rotation (columns), for shading in its frame.
    head_x: vec4<f32>,
    head_y: vec4<f32>,
    head_z: vec4<f32>,
    // Linear toon colours; diffuse.w t_diffuse, shade.w t_dark, dark.w t_specular,
    // specular.w 1 for three tones
    diffuse: vec4<f32>,
    shade: vec4<f32>,
    dark: vec4<f32>,
    specular: vec4<f32>,
    // rgb outline colour, w outline width in output pixels
    outline: vec4<f32>,
    // x threshold, y step scale, z max steps, w refine steps
    march: vec4<f32>,
    // x distance method (0 Newton, 1 polyline), y polyline pieces, z unused, w segments
    method: vec4<u32>,
    // Toon controls (shaders/wisps/toon.wgsl): feathers x lit/shade, y shade/dark, z halo
    // edge, w rim edge
    feather: vec4<f32>,
    // rgb linear rim colour, w rim width (0: no rim)
    rim: vec4<f32>,
    // x cos, y sin of the halo's latitude offset, z halo strength, w 1 when halo_shadow is
    // the halo's colour over the shadow tones
    halo: vec4<f32>,
    halo_shadow: vec4<f32>,
    // x outline taper (root to tip), yzw unused
    taper: vec4<f32>,
}
