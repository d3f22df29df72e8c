// The strips' shadow cast (src/stage/shadow.rs, common/shadow_cast.wgsl): one invocation
// per strip deposits its centre line, stick by stick, as wide as the ribbon there, counted
// STRIP_LAYERS times (a strip stands for a layer of hairs: src/systems/strips/ribbon.rs).

@group(1) @binding(0) var<storage, read> verts: array<RibbonVertex>;
@group(1) @binding(1) var<storage, read> info: array<StripInfo>;
// x stride (control point slots per strip), y strips, z strip layers (f32 bits)
@group(1) @binding(2) var<uniform> cast_counts: vec4<u32>;

@compute @workgroup_size(64)
fn cast_shadow(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) nw: vec3<u32>,
) {
    let si = id.x + id.y * nw.x * 64u;
    if si >= cast_counts.y {
        return;
    }
    let stride = cast_counts.x;
    let n = clamp(info[si].counts.x, 1u, stride);
    let layers = bitcast<f32>(cast_counts.z);
    let base = 2u * si * stride;
    var a = 0.5 * (verts[base].position.xyz + verts[base + 1u].position.xyz);
    var wa = length(verts[base].position.xyz - verts[base + 1u].position.xyz);
    for (var k = 1u; k < n; k++) {
        let l = verts[base + 2u * k].position.xyz;
        let r = verts[base + 2u * k + 1u].position.xyz;
        let b = 0.5 * (l + r);
        let wb = length(l - r);
        deposit_segment(a, b, 0.5 * (wa + wb), layers);
        a = b;
        wa = wb;
    }
}
