// Fur (Van Gelder & Wilhelms 3.6-3.8), drawn from the strands the generator wrote this
// frame, shaded by fur/shade.wgsl. Line, polyline and curve hairs are camera-facing ribbons
// (like Anjyo's hair, sub-pixel width becomes coverage); tube hairs are narrow 6-sided tubes
// around the curve.

const TUBE_SIDES: u32 = 6u;

struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) @interpolate(flat) strand: u32,
}

@vertex
fn vs_ribbon(@builtin(vertex_index) vi: u32, @builtin(instance_index) si: u32) -> VOut {
    var out: VOut;
    let s = strands[si];
    let m = materials[s.group];
    // Every step-th node and the last (the screen-space level of detail).
    let n = min((vi >> 1u) * node_step(m), s.segments);
    let side = select(-1.0, 1.0, (vi & 1u) == 1u);
    let p = verts[s.first_vertex + n].xyz;
    let t = tangent(s, n);
    let clip = frame.view_proj * vec4<f32>(p, 1.0);
    let ct = frame.view_proj * vec4<f32>(t, 0.0);
    var sdir = (ct.xy * clip.w - clip.xy * ct.w) * frame.viewport.xy;
    let sl = length(sdir);
    sdir = select(vec2<f32>(1.0, 0.0), sdir / sl, sl > 1e-20);
    let across = vec2<f32>(-sdir.y, sdir.x);
    let width = ribbon_width(s, m, n);
    let width_px = width * frame.raster.x / max(clip.w, 1e-6);
    let drawn_px = max(width_px, frame.raster.y);
    let offset = across * (side * drawn_px) * frame.viewport.zw;
    out.pos = vec4<f32>(clip.xy + offset * clip.w, clip.z, clip.w);
    out.color = vec4<f32>(shade_hair(m, shading_normal(si, s, m, n, t), t, p, s, n), width_px / drawn_px);
    out.strand = si;
    return out;
}

// Six sides of two triangles per segment: 36 vertices per segment.
@vertex
fn vs_tube(@builtin(vertex_index) vi: u32, @builtin(instance_index) si: u32) -> VOut {
    var out: VOut;
    let s = strands[si];
    let m = materials[s.group];
    let seg = vi / 36u;
    let r = vi % 36u;
    let side = r / 6u;
    let corner = r % 6u;
    // Quad corners (around, along): (0,0) (1,0) (0,1) (1,0) (1,1) (0,1)
    let du = select(0u, 1u, corner == 1u || corner == 3u || corner == 4u);
    let dv = select(0u, 1u, corner == 2u || corner == 4u || corner == 5u);
    let n = min(seg + dv, s.segments);
    let p = verts[s.first_vertex + n].xyz;
    let t = tangent(s, n);
    var b = cross(t, info[2u * si + 1u].xyz);
    let bl = length(b);
    b = select(any_perpendicular(t), b / bl, bl > 1e-12);
    let c = cross(t, b);
    let phi = 6.28318530717959 * f32(side + du) / f32(TUBE_SIDES);
    let radial = cos(phi) * b + sin(phi) * c;
    let along = f32(n) / f32(max(s.segments, 1u));
    let radius = 0.5 * m.ambient.w * mix(1.0, 0.5, along) * m.extra.y;
    let q = p + radial * radius;
    out.pos = frame.view_proj * vec4<f32>(q, 1.0);
    out.color = vec4<f32>(shade_hair(m, radial, t, q, s, n), 1.0);
    out.strand = si;
    return out;
}

fn any_perpendicular(v: vec3<f32>) -> vec3<f32> {
    let a = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(v.x) > 0.9);
    return normalize(cross(v, a));
}

// Sub-pixel coverage as for Anjyo's hair (common/coverage.wgsl); tubes are opaque.
@fragment
fn fs(in: VOut) -> HairFragment {
    return hair_fragment(in.color, in.pos.xy, in.strand);
}

@fragment
fn fs_per_sample(in: VOut, @builtin(sample_index) sample: u32) -> @location(0) vec4<f32> {
    return hair_fragment_per_sample(in.color, in.pos.xy, in.strand, sample);
}
