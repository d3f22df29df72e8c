// Hair as camera-facing ribbons, built in the vertex shader straight from the strand storage
// buffers (no CPU copy). Vertex 2i and 2i+1 are the two sides of node i; one instance per
// strand, drawn as a triangle strip. Nodes are shaded and sized by common/strand_shade.wgsl.
// A strand thinner than `frame.raster.y` samples is drawn that wide with alpha equal to its
// true coverage (common/coverage.wgsl), so sub-pixel hair is smooth and order-independent.

struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) @interpolate(flat) strand: u32,
}

@vertex
fn vs(@builtin(vertex_index) vi: u32, @builtin(instance_index) si: u32) -> VOut {
    var out: VOut;
    let s = strands[si];
    // Every step-th node; nodes past the drawn length collapse onto the last one
    // (zero-area triangles).
    let n = min((vi >> 1u) * lod_step(), last_node(s));
    let side = select(-1.0, 1.0, (vi & 1u) == 1u);
    let node = shade_node(s, n);

    // Screen-space direction of the tangent (exact derivative of the projection).
    let clip = frame.view_proj * vec4<f32>(node.pos, 1.0);
    let ct = frame.view_proj * vec4<f32>(node.tangent, 0.0);
    var sdir = (ct.xy * clip.w - clip.xy * ct.w) * frame.viewport.xy;
    let sl = length(sdir);
    sdir = select(vec2<f32>(1.0, 0.0), sdir / sl, sl > 1e-20);
    let across = vec2<f32>(-sdir.y, sdir.x);

    // Width in samples at this depth.
    let width_px = node.width * frame.raster.x / max(clip.w, 1e-6);
    let drawn_px = max(width_px, frame.raster.y);
    let coverage = width_px / drawn_px;
    let offset = across * (side * drawn_px) * frame.viewport.zw;
    out.pos = vec4<f32>(clip.xy + offset * clip.w, clip.z, clip.w);
    out.color = vec4<f32>(node.rgb, coverage * node.alpha);
    out.strand = si;
    return out;
}

@fragment
fn fs(in: VOut) -> HairFragment {
    return hair_fragment(in.color, in.pos.xy, in.strand);
}

@fragment
fn fs_per_sample(in: VOut, @builtin(sample_index) sample: u32) -> @location(0) vec4<f32> {
    return hair_fragment_per_sample(in.color, in.pos.xy, in.strand, sample);
}
