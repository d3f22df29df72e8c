// Fur's shadow cast (src/stage/shadow.rs, common/shadow_cast.wgsl): one invocation per hair
// the generator wrote this frame deposits its drawn segments with the widths fur/draw.wgsl
// draws.

// GpuFurMaterial (src/systems/fur/gpu_data.rs, as fur/draw.wgsl's FurMaterial): the cast
// reads the draw's materials buffer, so its elements must stride as GpuFurMaterial does;
// the physical shading's parameters (`HairBsdf`, 7 vec4) are not read here.
// tests/it/gpu_twins.rs checks the layout.
struct CastMaterial {
    ambient: vec4<f32>,
    diffuse: vec4<f32>,
    specular: vec4<f32>,
    extra: vec4<f32>,
    bsdf: array<vec4<f32>, 7>,
}

@group(1) @binding(0) var<storage, read> strands: array<Strand>;
@group(1) @binding(1) var<storage, read> verts: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> materials: array<CastMaterial>;
// Per coat: first hair, one past the last drawn.
@group(1) @binding(3) var<storage, read> coats: array<vec2<u32>>;

@compute @workgroup_size(64)
fn cast_shadow(@builtin(global_invocation_id) id: vec3<u32>) {
    let si = id.x + id.y * 65535u * 64u;
    if si >= arrayLength(&strands) {
        return;
    }
    var drawn = false;
    for (var c = 0u; c < arrayLength(&coats); c++) {
        if si >= coats[c].x && si < coats[c].y {
            drawn = true;
        }
    }
    if !drawn {
        return;
    }
    let s = strands[si];
    let m = materials[s.group];
    let step = max(u32(m.extra.z), 1u);
    let k = max(s.segments, 1u);
    var a = verts[s.first_vertex].xyz;
    var n = 0u;
    loop {
        if n >= s.segments {
            break;
        }
        let next = min(n + step, s.segments);
        let b = verts[s.first_vertex + next].xyz;
        let along = 0.5 * f32(n + next) / f32(k);
        let width = m.ambient.w * mix(1.0, 0.5, along) * m.extra.y;
        deposit_segment(a, b, width, 1.0);
        a = b;
        n = next;
    }
}
