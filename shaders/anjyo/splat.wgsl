// Anjyo's strands for the compute rasteriser (common/splat.wgsl, which says what a kind
// gives it): nodes placed, sized and shaded by the ribbons' own code
// (common/strand_shade.wgsl), every lod_step-th node and the last drawn.

fn splat_step(s: Strand) -> u32 {
    return lod_step();
}

fn splat_last(s: Strand) -> u32 {
    return last_node(s);
}

fn splat_node(si: u32, s: Strand, n: u32) -> SplatNode {
    let h = shade_node(s, n);
    return SplatNode(h.pos, h.rgb, h.width, h.alpha);
}

fn splat_placed(si: u32, s: Strand, n: u32) -> SplatNode {
    let wa = node_width_alpha(s, n);
    return SplatNode(node_pos(s, n), vec3<f32>(0.0), wa.x, wa.y);
}
