// The wisps' march (`shaders/wisps/march.wgsl`, a compute pass) drawn into the scene: one
// quad per screen tile some segment reaches (`vs`, shaders/wisps/tile_quad.wgsl), each pixel its march's colour at its march's
// depth (depth-tested, so wisps composite with the head, strands and fur by depth as any
// draw does); pixels the march left empty are discarded.

// `View`: shaders/wisps/view.wgsl.
@group(1) @binding(0) var<storage, read> tile_counts: array<u32>;
@group(1) @binding(1) var<uniform> view: View;
@group(1) @binding(2) var march_color: texture_2d<f32>;
@group(1) @binding(3) var march_depth: texture_2d<f32>;

// Every scene draw takes the shadow lookup's constant (`gpu::pipeline::Variant`); the
// composite reads no shadow.
override SHADOW_LOOKUP: u32 = 0u;

@fragment
fn fs(in: VOut) -> FOut {
    let pix = vec2<u32>(in.pos.xy);
    let d = textureLoad(march_depth, pix, 0).x;
    if (d < 0.0) {
        discard;
    }
    var out: FOut;
    out.color = textureLoad(march_color, pix, 0);
    out.depth = d;
    return out;
}
