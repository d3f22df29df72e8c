// Fur's line, polyline and curve coats for the compute rasteriser (common/splat.wgsl, which
// says what a kind gives it): each node placed, sized and shaded as the coat's ribbons do
// (fur/shade.wgsl, fur/draw.wgsl's vs_ribbon), every node_step-th node and the last. Tube
// coats are never in the drawn ranges: they stay triangles.

fn splat_step(s: Strand) -> u32 {
    return node_step(materials[s.group]);
}

fn splat_last(s: Strand) -> u32 {
    return s.segments;
}

fn splat_node(si: u32, s: Strand, n: u32) -> SplatNode {
    let m = materials[s.group];
    let p = verts[s.first_vertex + n].xyz;
    let t = tangent(s, n);
    let rgb = shade_hair(m, shading_normal(si, s, m, n, t), t, p, s, n);
    return SplatNode(p, rgb, ribbon_width(s, m, n), 1.0);
}

fn splat_placed(si: u32, s: Strand, n: u32) -> SplatNode {
    let m = materials[s.group];
    return SplatNode(verts[s.first_vertex + n].xyz, vec3<f32>(0.0), ribbon_width(s, m, n), 1.0);
}
