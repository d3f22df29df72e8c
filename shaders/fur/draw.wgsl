// Fur (Van Gelder & Wilhelms 3.6-3.8), drawn from the strands the generator wrote this
// frame. Line, polyline and curve hairs are camera-facing ribbons (like Anjyo's hair,
// sub-pixel width becomes coverage); tube hairs are narrow 6-sided tubes around the curve.
// Shading is the paper's GL lighting with its shading normals: lines and curves use the skin
// normal; polylines a normal per control point, perpendicular to the segment in the hair plane
// and rotated about it by a random angle (normal randomize); tubes their surface normal.

// Twin of GpuFurMaterial (tests/it/gpu_twins.rs checks it) in src/systems/fur/gpu_data.rs.
struct FurMaterial {
    // rgb ambient, w root width
    ambient: vec4<f32>,
    // rgb diffuse, w style
    diffuse: vec4<f32>,
    // rgb specular, w shininess
    specular: vec4<f32>,
    // x normal randomize, y width scale, z node step (ribbons; src/systems/lod.rs)
    extra: vec4<f32>,
    // The physical mode's parameters (common/hair_bsdf.wgsl); bsdf.sigma_a.w 1 when used.
    bsdf: HairBsdf,
}

const STYLE_POLYLINE: u32 = 1u;
const TUBE_SIDES: u32 = 6u;

@group(1) @binding(0) var<storage, read> strands: array<Strand>;
@group(1) @binding(1) var<storage, read> verts: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> info: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read> materials: array<FurMaterial>;

struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) @interpolate(flat) strand: u32,
}

fn rotate_about(axis: vec3<f32>, v: vec3<f32>, angle: f32) -> vec3<f32> {
    let c = cos(angle);
    let s = sin(angle);
    return v * c + cross(axis, v) * s + axis * dot(axis, v) * (1.0 - c);
}

// Ambient + diffuse + specular (Phong-Blinn) with the coat's material.
fn shade(m: FurMaterial, n_in: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    let l = frame.light_dir.xyz;
    let v = normalize(frame.eye.xyz - p);
    var n = n_in;
    if dot(n, v) < 0.0 {
        n = -n;
    }
    let h = normalize(l + v);
    let diff = max(dot(n, l), 0.0);
    let spec = pow(max(dot(n, h), 0.0), max(m.specular.w, 1.0));
    // Hair shadows (common/shadow.wgsl) dim the direct light only.
    let lit = shadow_direct(p);
    return m.ambient.rgb * frame.light_color.w
        + lit * frame.light_dir.w * frame.light_color.rgb * (m.diffuse.rgb * diff + m.specular.rgb * spec);
}

// The coat's shading at a vertex: the paper's GL lighting, or the physical mode
// (docs/shading.md) from the hair's tangent t, with Kami's ambient times the colour a dense
// coat of this hair sends back.
fn shade_hair(m: FurMaterial, n: vec3<f32>, t: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    if hair_physical(m.bsdf) {
        let v = normalize(frame.eye.xyz - p);
        let f = hair_dual_radiance(m.bsdf, t, v, frame.light_dir.xyz, shadow_strands(p));
        return frame.light_color.rgb * (hair_irradiance() * shadow_opaque(p)) * f
            + m.bsdf.ambient.rgb * frame.light_color.w;
    }
    return shade(m, n, p);
}

fn tangent(s: Strand, n: u32) -> vec3<f32> {
    let k = s.segments;
    let a = verts[s.first_vertex + select(n - 1u, 0u, n == 0u)].xyz;
    let b = verts[s.first_vertex + min(n + 1u, k)].xyz;
    let t = b - a;
    let l = length(t);
    return select(vec3<f32>(0.0, 1.0, 0.0), t / l, l > 1e-20);
}

fn shading_normal(si: u32, s: Strand, m: FurMaterial, n: u32, t: vec3<f32>) -> vec3<f32> {
    if u32(m.diffuse.w) == STYLE_POLYLINE {
        // In the hair plane, perpendicular to the segment, rotated by a random angle.
        var nn = cross(info[2u * si + 1u].xyz, t);
        let l = length(nn);
        nn = select(info[2u * si].xyz, nn / l, l > 1e-12);
        let u = f32(pcg_hash(bitcast<u32>(info[2u * si].w) ^ (n * 2654435761u)) >> 8u) / 16777216.0;
        return rotate_about(t, nn, (2.0 * u - 1.0) * 3.14159265 * m.extra.x);
    }
    return info[2u * si].xyz;
}

@vertex
fn vs_ribbon(@builtin(vertex_index) vi: u32, @builtin(instance_index) si: u32) -> VOut {
    var out: VOut;
    let s = strands[si];
    let m = materials[s.group];
    // Every step-th node and the last (the screen-space level of detail).
    let n = min((vi >> 1u) * max(u32(m.extra.z), 1u), s.segments);
    let side = select(-1.0, 1.0, (vi & 1u) == 1u);
    let p = verts[s.first_vertex + n].xyz;
    let t = tangent(s, n);
    let clip = frame.view_proj * vec4<f32>(p, 1.0);
    let ct = frame.view_proj * vec4<f32>(t, 0.0);
    var sdir = (ct.xy * clip.w - clip.xy * ct.w) * frame.viewport.xy;
    let sl = length(sdir);
    sdir = select(vec2<f32>(1.0, 0.0), sdir / sl, sl > 1e-20);
    let across = vec2<f32>(-sdir.y, sdir.x);
    let along = f32(n) / f32(max(s.segments, 1u));
    let width = m.ambient.w * mix(1.0, 0.5, along) * m.extra.y;
    let width_px = width * frame.raster.x / max(clip.w, 1e-6);
    let drawn_px = max(width_px, frame.raster.y);
    let offset = across * (side * drawn_px) * frame.viewport.zw;
    out.pos = vec4<f32>(clip.xy + offset * clip.w, clip.z, clip.w);
    out.color = vec4<f32>(shade_hair(m, shading_normal(si, s, m, n, t), t, p), width_px / drawn_px);
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
    out.color = vec4<f32>(shade_hair(m, radial, t, q), 1.0);
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
