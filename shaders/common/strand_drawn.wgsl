// Which strands are drawn at this level of detail, for the modules that walk strands one
// invocation each (anjyo/splat.wgsl, the compute rasteriser; anjyo/cast.wgsl, the shadow
// cast), so both draw and cast the same strands.

// Per-strand ranges: x first strand of a group, y one past the last drawn one.
@group(1) @binding(4) var<storage, read> ranges: array<vec2<u32>>;

// The strand invocation `id` walks, or none (past the strands, or not drawn): the first
// strands of each group's range.
fn drawn_strand(id: vec3<u32>) -> i32 {
    let si = id.x + id.y * 65535u * 64u;
    if si >= arrayLength(&strands) {
        return -1;
    }
    for (var r = 0u; r < arrayLength(&ranges); r++) {
        let g = ranges[r];
        if si >= g.x && si < g.y {
            return i32(si);
        }
    }
    return -1;
}
