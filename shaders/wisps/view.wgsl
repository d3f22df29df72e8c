// The wisps' per-frame view (tiles, march and composite). Twin of GpuMarchView in
// src/systems/wisps/tiles.rs.
struct View {
    view_proj: mat4x4<f32>,
    inv_view_proj: mat4x4<f32>,
    // xyz the eye, w the outline shell's half-width per unit distance (0: no outline)
    eye: vec4<f32>,
    // x width, y height (samples), z tile side (samples), w the largest outline scale of a
    // wisp (the outline shell is that much wider)
    size: vec4<f32>,
    // x tiles across, y tiles down, z list capacity per tile, w segments
    tiles: vec4<u32>,
    // x 1: count steps and candidates (benches); y, z, w unused
    flags: vec4<u32>,
}
