// Van Gelder & Wilhelms' fur, generated every frame from the root table: one invocation per
// drawn hair slot of a coat. The same steps as kami::systems::fur::setup::hair_points (read its header):
// find the slot's triangle and creation index (binary search over the culled prefix
// offsets), barycentrics from the 2048-entry table, root/normal/length from the (moving)
// mesh, weightless direction and end point, floppiness, then the style's control points.

// Twin of GpuFurCoat (tests/it/gpu_twins.rs checks it) in src/systems/fur/gpu_data.rs (one 256-byte slot per coat).
struct Coat {
    drawn: u32,
    segments: u32,
    style: u32,
    tri_count: u32,
    first_vertex: u32,
    first_strand: u32,
    seed: u32,
    // Where this coat's tables start in `first` (tri_count entries) and `offsets`
    // (tri_count + 1 entries).
    first_base: u32,
    offset_base: u32,
    rel_length: f32,
    floppiness: f32,
    end_rand: f32,
    dir_weight: f32,
    // Where the per-vertex (joints, weights) start in `mesh`; 0: not skinned.
    skin_base: u32,
    _p1: u32,
    _p2: u32,
    up: vec4<f32>,
    // x amplitude, y 2 pi / wavelength, z phase offset, w on
    motion: vec4<f32>,
    motion_axis: vec4<f32>,
    motion_dir: vec4<f32>,
}

// Passed by the Rust side (`setup::TABLE`, `gpu::WORKGROUP`).
override TABLE: u32;
override WORKGROUP: u32;
const LINE: u32 = 0u;
const POLYLINE: u32 = 1u;

@group(0) @binding(0) var<uniform> coat: Coat;
// Two entries per mesh vertex: (position, length), (normal, 0).
@group(0) @binding(1) var<storage, read> mesh: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> tris: array<vec4<u32>>;
// Per coat and triangle: creation index of the first hair.
@group(0) @binding(3) var<storage, read> first: array<u32>;
// Per coat: drawn-hair prefix offsets, tri_count + 1 entries.
@group(0) @binding(4) var<storage, read> offsets: array<u32>;
@group(0) @binding(5) var<storage, read> table: array<vec2<f32>>;
@group(0) @binding(6) var<storage, read_write> verts: array<vec4<f32>>;
// Two entries per strand: (skin normal, random), (hair-plane normal, 0).
@group(0) @binding(7) var<storage, read_write> info: array<vec4<f32>>;
// Per mesh vertex: the unit body-segment direction (the fur's or its region's).
@group(0) @binding(8) var<storage, read> dirs: array<vec4<f32>>;
// The skin's joint matrices this frame (G(joint) * inverse bind, fitted).
// MAX_JOINTS is kami::scene::skinned::MAX_JOINTS (tests/it/gpu_twins.rs checks it).
const MAX_JOINTS: u32 = 64u;
@group(0) @binding(9) var<uniform> joints: array<mat4x4<f32>, MAX_JOINTS>;

// Linear blend skinning of vertex v (kami::scene::skinned::Skin::skin_vertex): the mesh
// buffer holds, from skin_base, two vec4 per vertex: joint indices (as floats), weights.
fn skinned(v: u32, p: vec3<f32>, n: vec3<f32>) -> Deformed {
    if coat.skin_base == 0u {
        return Deformed(p, n);
    }
    let j = vec4<u32>(mesh[coat.skin_base + 2u * v]);
    let w = mesh[coat.skin_base + 2u * v + 1u];
    let m = joints[j.x] * w.x + joints[j.y] * w.y + joints[j.z] * w.z + joints[j.w] * w.w;
    let nn = (m * vec4<f32>(n, 0.0)).xyz;
    return Deformed((m * vec4<f32>(p, 1.0)).xyz, safe_normalize(nn, n));
}

fn hair_random(h: u32, which: u32) -> f32 {
    let x = pcg_hash(which ^ pcg_hash(h ^ pcg_hash(coat.seed)));
    return f32(x >> 8u) / 16777216.0;
}

fn safe_normalize(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let l = length(v);
    return select(fallback, v / l, l > 1e-20);
}

@compute @workgroup_size(WORKGROUP)
fn generate(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let slot = id.x + id.y * groups.x * WORKGROUP;
    if slot >= coat.drawn {
        return;
    }
    // Largest triangle t with offsets[t] <= slot.
    let ob = coat.offset_base;
    var lo = 0u;
    var hi = coat.tri_count;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if offsets[ob + mid] <= slot {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let t = lo;
    let h = first[coat.first_base + t] + (slot - offsets[ob + t]);
    let bb = table[h % TABLE];
    let b = vec3<f32>(bb.x, bb.y, 1.0 - bb.x - bb.y);
    let tri = tris[t];
    var root = vec3<f32>(0.0);
    var normal = vec3<f32>(0.0);
    var len = 0.0;
    var body = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        let v = tri[k];
        let sk = skinned(v, mesh[2u * v].xyz, mesh[2u * v + 1u].xyz);
        let d = deform(coat.motion, coat.motion_axis.xyz, coat.motion_dir.xyz, sk.p, sk.n);
        root += b[k] * d.p;
        normal += b[k] * d.n;
        len += b[k] * mesh[2u * v].w;
        body += b[k] * dirs[v].xyz;
    }
    let n = safe_normalize(normal, vec3<f32>(0.0, 1.0, 0.0));
    len *= coat.rel_length;
    let wdir0 = safe_normalize((1.0 - coat.dir_weight) * n + coat.dir_weight * safe_normalize(body, n), n);
    let z = 2.0 * hair_random(h, 0u) - 1.0;
    let az = 6.28318530717959 * hair_random(h, 1u);
    let rho = sqrt(max(1.0 - z * z, 0.0));
    let jitter = vec3<f32>(rho * cos(az), z, rho * sin(az)) * (coat.end_rand * hair_random(h, 2u));
    let wdir = safe_normalize(wdir0 + jitter, wdir0);
    let wend = root + len * wdir;
    let dir = safe_normalize(wdir - coat.up.xyz * (coat.floppiness * dot(wdir, n)), wdir);
    let end = root + len * dir;
    let pl = cross(wdir, dir);
    var plane = any_orthonormal(wdir);
    if length(pl) > 1e-6 {
        plane = normalize(pl);
    }
    let strand = coat.first_strand + slot;
    info[2u * strand] = vec4<f32>(n, hair_random(h, 3u));
    info[2u * strand + 1u] = vec4<f32>(plane, 0.0);
    let base = coat.first_vertex + slot * (coat.segments + 1u);
    if coat.style == LINE {
        verts[base] = vec4<f32>(root, 1.0);
        verts[base + 1u] = vec4<f32>(end, 1.0);
    } else if coat.style == POLYLINE {
        for (var i = 0u; i < 8u; i++) {
            let s = f32(i) / 7.0;
            verts[base + i] = vec4<f32>(root + s * (wend - root) + s * s * (end - wend), 1.0);
        }
    } else {
        let p1 = root + wdir * (len / 3.0);
        let p2 = end - dir * (len / 3.0);
        for (var i = 0u; i <= coat.segments; i++) {
            let s = f32(i) / f32(coat.segments);
            let u = 1.0 - s;
            verts[base + i] = vec4<f32>(root * (u * u * u) + p1 * (3.0 * u * u * s) + p2 * (3.0 * u * s * s) + end * (s * s * s), 1.0);
        }
    }
    // w: the hair's tapered length from each node to the tip (fur/shade.wgsl's coat_above
    // times the coat's density), summed once here rather than per shaded vertex.
    let k = coat.segments;
    var above = 0.0;
    verts[base + k].w = 0.0;
    for (var j = k; j > 0u; j--) {
        let seg = length(verts[base + j].xyz - verts[base + j - 1u].xyz);
        above += seg * mix(1.0, 0.5, (f32(j - 1u) + 0.5) / f32(k));
        verts[base + j - 1u].w = above;
    }
}
