// One quad per screen tile, for a draw over the tiles some segment reaches (the march in
// fragments, and the composite of the march in compute); reads the including module's
// `tile_counts` and `view` (`View`, shaders/wisps/view.wgsl).

struct VOut {
    @builtin(position) pos: vec4<f32>,
}

// An empty tile's quad is degenerate (nothing to rasterise).
@vertex
fn vs(@builtin(vertex_index) v: u32, @builtin(instance_index) tile: u32) -> VOut {
    var out: VOut;
    if (tile_counts[tile] == 0u) {
        out.pos = vec4<f32>(-2.0, -2.0, 0.0, 1.0);
        return out;
    }
    var quad = array<vec2<u32>, 6>(
        vec2<u32>(0u, 0u), vec2<u32>(1u, 0u), vec2<u32>(0u, 1u),
        vec2<u32>(0u, 1u), vec2<u32>(1u, 0u), vec2<u32>(1u, 1u),
    );
    let side = u32(view.size.z);
    let corner = (vec2<u32>(tile % view.tiles.x, tile / view.tiles.x) + quad[v]) * side;
    let px = min(vec2<f32>(corner), view.size.xy);
    out.pos = vec4<f32>(px.x / view.size.x * 2.0 - 1.0, 1.0 - px.y / view.size.y * 2.0, 0.0, 1.0);
    return out;
}

// A fragment's colour and the depth it writes.
struct FOut {
    @location(0) color: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}
