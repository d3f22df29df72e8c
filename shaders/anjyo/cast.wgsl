// The strands' shadow cast (src/stage/shadow.rs, common/shadow_cast.wgsl): one invocation
// per drawn strand deposits each drawn segment (the same nodes, level of detail and widths
// as the ribbons and the compute rasteriser draw).

// Node n's world width, as shade_node (common/strand_shade.wgsl) sizes it.
fn cast_width(s: Strand, n: u32) -> f32 {
    let mat = materials[s.group];
    let along = f32(n) / f32(max(s.segments, 1u));
    var width = mat.params.z * mix(1.0, mat.params.w, along);
    if mat.file.y > 0.5 {
        width = bitcast<f32>(looks[s.first_vertex + n].y);
    }
    return width * frame.raster.z * lod.x;
}

@compute @workgroup_size(64)
fn cast_shadow(@builtin(global_invocation_id) id: vec3<u32>) {
    let si = drawn_strand(id);
    if si < 0 {
        return;
    }
    let s = strands[si];
    let step = lod_step();
    let last = last_node(s);
    var a = node_pos(s, 0u);
    var wa = cast_width(s, 0u);
    var n = 0u;
    loop {
        if n >= last {
            break;
        }
        n = min(n + step, last);
        let b = node_pos(s, n);
        let wb = cast_width(s, n);
        deposit_segment(a, b, 0.5 * (wa + wb), 1.0);
        a = b;
        wa = wb;
    }
}
