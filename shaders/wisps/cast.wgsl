// The wisps' shadow cast (src/stage/shadow.rs, common/shadow_cast.wgsl): each Bézier
// segment of the skeleton, cut into CAST_PIECES chords, deposits a strip as wide as the
// wisp there, counted WISP_LAYERS times: a wisp is a solid surface, so a point behind one
// reads far over the toon threshold (common/shadow.wgsl's `shadow_toon`).

@group(1) @binding(0) var<storage, read> segments: array<Segment>;
// x: segments
@group(1) @binding(1) var<uniform> cast_count: vec4<u32>;

const CAST_PIECES: u32 = 6u;
const WISP_LAYERS: f32 = 4.0;

fn cast_bez(s: Segment, t: f32) -> vec3<f32> {
    let u = 1.0 - t;
    return u * u * u * s.c0.xyz + 3.0 * u * u * t * s.c1.xyz + 3.0 * u * t * t * s.c2.xyz
        + t * t * t * s.c3.xyz;
}

@compute @workgroup_size(64)
fn cast_shadow(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= cast_count.x {
        return;
    }
    let s = segments[id.x];
    var a = cast_bez(s, 0.0);
    for (var k = 1u; k <= CAST_PIECES; k++) {
        let t = f32(k) / f32(CAST_PIECES);
        let b = cast_bez(s, t);
        // The radius r0 at the segment's start, r1 at its end.
        let r = mix(s.c0.w, s.c1.w, t - 0.5 / f32(CAST_PIECES));
        deposit_segment(a, b, 2.0 * r, WISP_LAYERS);
        a = b;
    }
}
