// The fur mesh's skin: its triangles read from storage (the same buffers the fur generator
// reads), moved by the same deformation, lit like the head, shadowed by the hair and by
// itself; and cast into the shadow structure's skin map (`cast_skin`, groups 0 and 2 of
// common/shadow_cast.wgsl bound as for every caster).

// Twin of GpuSkin (tests/it/gpu_twins.rs checks it) in src/systems/fur/gpu_data.rs.
struct Skin {
    color: vec4<f32>,
    motion: vec4<f32>,
    motion_axis: vec4<f32>,
    motion_dir: vec4<f32>,
    // x: where the per-vertex (joints, weights) start in `mesh`, 0: not skinned; y: 1 for a
    // closed mesh (cast_skin may skip its far side).
    skin: vec4<u32>,
    // The physical coats over the skin: rgb their a_f, w their fibre-area index per unit of
    // the mesh's hair length (0: none; src/systems/fur/draw.rs `skin_coat`).
    coat: vec4<f32>,
}

@group(1) @binding(0) var<uniform> skin: Skin;
@group(1) @binding(1) var<storage, read> mesh: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> tris: array<vec4<u32>>;
// MAX_JOINTS is kami::scene::skinned::MAX_JOINTS (tests/it/gpu_twins.rs checks it).
const MAX_JOINTS: u32 = 64u;
@group(1) @binding(3) var<uniform> joints: array<mat4x4<f32>, MAX_JOINTS>;

// Linear blend skinning, as in shaders/fur/generate.wgsl.
fn skinned(v: u32, p: vec3<f32>, n: vec3<f32>) -> Deformed {
    let base = skin.skin.x;
    if base == 0u {
        return Deformed(p, n);
    }
    let j = vec4<u32>(mesh[base + 2u * v]);
    let w = mesh[base + 2u * v + 1u];
    let m = joints[j.x] * w.x + joints[j.y] * w.y + joints[j.z] * w.z + joints[j.w] * w.w;
    let nn = (m * vec4<f32>(n, 0.0)).xyz;
    let l = length(nn);
    return Deformed((m * vec4<f32>(p, 1.0)).xyz, select(n, nn / l, l > 1e-20));
}

struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    // The skin map's answer (shadow_opaque) at the vertex, read off the surface along the
    // normal by the map's bias so a lit face does not shadow itself: per vertex, as the
    // hair is shaded: per pixel it cost the software viewer more of fur's frame than the
    // whole map costs now (docs/shadows.md).
    @location(2) lit: f32,
    // The share of the even ambient light that reaches the skin through the coat above it
    // (common/hair_bsdf.wgsl), per vertex: the coat's fibre area over the vertex is its
    // hair length (the mesh's w) times the coats' index.
    @location(3) ambient: vec3<f32>,
}

// Vertex v of the skin this frame: skinned, then moved by the mesh motion.
fn skin_vertex(v: u32) -> Deformed {
    let sk = skinned(v, mesh[2u * v].xyz, mesh[2u * v + 1u].xyz);
    return deform(skin.motion, skin.motion_axis.xyz, skin.motion_dir.xyz, sk.p, sk.n);
}

@vertex
fn vs(@builtin(vertex_index) vi: u32) -> VOut {
    var out: VOut;
    let v = tris[vi / 3u][vi % 3u];
    let d = skin_vertex(v);
    out.ambient = hair_ambient_through_af(skin.coat.rgb, mesh[2u * v].w * skin.coat.w);
    out.pos = frame.view_proj * vec4<f32>(d.p, 1.0);
    out.world = d.p;
    out.normal = d.n;
    out.lit = shadow_opaque(d.p + d.n * frame.shadow.layered.w);
    return out;
}

@fragment
fn fs(in: VOut) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let l = frame.light_dir.xyz;
    let wrap = max((dot(n, l) + 0.3) / 1.3, 0.0);
    // The fur's shadow (common/shadow.wgsl) dims the direct light, and so does the skin
    // where more skin lies towards the light.
    let direct = frame.light_dir.w * shadow_absorbed(shadow_strands(in.world)) * in.lit;
    let rgb = skin.color.rgb * (0.3 * frame.light_color.w * in.ambient + 0.8 * direct * wrap);
    return vec4<f32>(rgb, 1.0);
}

// One invocation per skin triangle, posed as `vs` poses it, into the skin map. On a closed
// mesh a triangle whose three vertex normals all face well away from the light is skipped:
// the nearest surface towards the light faces it, so the far side (half the work) adds
// nothing; near the silhouette, where normals turn, every triangle is kept. An open mesh's
// back may be what the light meets first, so there every triangle is cast.
@compute @workgroup_size(64)
fn cast_skin(@builtin(global_invocation_id) id: vec3<u32>) {
    let t = id.x + id.y * 65535u * 64u;
    // Deep opacity runs every caster twice; the map is cast in phase 1 only, so phase 0
    // poses nothing.
    if t >= arrayLength(&tris) || shadow_phase.x != 1u {
        return;
    }
    let i = tris[t];
    let a = skin_vertex(i.x);
    let b = skin_vertex(i.y);
    let c = skin_vertex(i.z);
    let l = frame.shadow.axis_l.xyz;
    if skin.skin.y != 0u && max(max(dot(a.n, l), dot(b.n, l)), dot(c.n, l)) < -0.2 {
        return;
    }
    deposit_triangle(a.p, b.p, c.p);
}
