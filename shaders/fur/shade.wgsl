// Fur's shading (Van Gelder & Wilhelms 3.6-3.8), shared by its ribbons and tubes
// (fur/draw.wgsl) and its thin coats in the compute rasteriser (fur/splat.wgsl). Shading is
// the paper's GL lighting with its shading normals: lines and curves use the skin normal;
// polylines a normal per control point, perpendicular to the segment in the hair plane
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

@group(1) @binding(0) var<storage, read> strands: array<Strand>;
@group(1) @binding(1) var<storage, read> verts: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> info: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read> materials: array<FurMaterial>;

fn rotate_about(axis: vec3<f32>, v: vec3<f32>, angle: f32) -> vec3<f32> {
    let c = cos(angle);
    let s = sin(angle);
    return v * c + cross(axis, v) * s + axis * dot(axis, v) * (1.0 - c);
}

// Ambient + diffuse + specular (Phong-Blinn) with the coat's material; `lit` the hair
// shadows' factor on the direct light (common/shadow.wgsl's shadow_absorbed times shadow_opaque).
fn shade(m: FurMaterial, n_in: vec3<f32>, p: vec3<f32>, lit: f32) -> vec3<f32> {
    let l = frame.light_dir.xyz;
    let v = normalize(frame.eye.xyz - p);
    var n = n_in;
    if dot(n, v) < 0.0 {
        n = -n;
    }
    let h = normalize(l + v);
    let diff = max(dot(n, l), 0.0);
    let spec = pow(max(dot(n, h), 0.0), max(m.specular.w, 1.0));
    // Hair shadows dim the direct light only.
    return m.ambient.rgb * frame.light_color.w
        + lit * frame.light_dir.w * frame.light_color.rgb * (m.diffuse.rgb * diff + m.specular.rgb * spec);
}

// The coat's shading at node `node` of hair s: the paper's GL lighting, or the physical
// mode (docs/shading.md) from the hair's tangent t, with Kami's ambient times the colour a
// dense coat of this hair sends back, dimmed by the coat above the node.
// The shadow lookups are read once, before the branch: a software rasteriser runs both sides.
fn shade_hair(m: FurMaterial, n: vec3<f32>, t: vec3<f32>, p: vec3<f32>, s: Strand, node: u32) -> vec3<f32> {
    let crossed = shadow_strands(p);
    let opaque = shadow_opaque(p);
    if hair_physical(m.bsdf) {
        let v = normalize(frame.eye.xyz - p);
        let f = hair_dual_radiance(m.bsdf, t, v, frame.light_dir.xyz, crossed);
        // A fur fibre stands free in its coat: it weighs the sky by its cross-section.
        let above = coat_above(s, m, node);
        let through = hair_ambient_in_coat(m.bsdf, above, hair_fibre_sky(above));
        return frame.light_color.rgb * (hair_irradiance() * opaque) * f
            + m.bsdf.ambient.rgb * through * frame.light_color.w;
    }
    return shade(m, n, p, shadow_absorbed(crossed) * opaque);
}

// The coat's fibre-area index above node n (FurSetup::coat_density, src/systems/fur/setup.rs):
// its density times the hair's tapered length from the node to the tip (every segment,
// whatever the level of detail's node step; fur/generate.wgsl sums it into the node's w),
// as if its neighbours were like it.
fn coat_above(s: Strand, m: FurMaterial, n: u32) -> f32 {
    return m.extra.w * verts[s.first_vertex + n].w;
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

// A line, polyline or curve hair's world width at node n: the coat's root width tapered to
// half at the tip, times the width scale of culling and level of detail.
fn ribbon_width(s: Strand, m: FurMaterial, n: u32) -> f32 {
    let along = f32(n) / f32(max(s.segments, 1u));
    return m.ambient.w * mix(1.0, 0.5, along) * m.extra.y;
}

// The node step of the screen-space level of detail (every step-th node and the last).
fn node_step(m: FurMaterial) -> u32 {
    return max(u32(m.extra.z), 1u);
}
