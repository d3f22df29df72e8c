// Guides and followers: one invocation per follower, after a frame's projective substeps.
// The f32 twin of src/systems/anjyo/follow.rs (read its header): each segment of a follower
// is its own rest segment turned by the Shepard blend of its guides' shortest-arc rotations
// of the same segment from rest to now (a guide past its simulated end lends its last
// one), at the follower's own length, root to tip from the pore ridden by the head pose;
// with collision, a node inside the head is pushed out as the projective kernel does
// (common/sdf.wgsl head_push_out). `rest` is the groom, copied when the job was prepared.
// Guides and followers are disjoint strands, so reading the one and writing the other in
// the same dispatch is safe.

override WORKGROUP: u32;

// Twin of GpuFollowParams (tests/it/gpu_twins.rs checks it) in src/systems/anjyo/follow_gpu.rs.
struct FollowParams {
    follower_count: u32,
    row_stride: u32,
    collision: u32,
    // The world sample (world_steps) of the head's pose at the end of the frame.
    sample: u32,
}

// Twin of GpuFollower (tests/it/gpu_twins.rs checks it) in src/systems/anjyo/follow_gpu.rs.
struct Follower {
    // first vertex, moved segments, guide count, unused
    ids: vec4<u32>,
    // xyz pore in head coordinates, w segment length
    root: vec4<f32>,
    // the guides' first vertices
    guide_first: vec4<u32>,
    // the guides' simulated segments
    guide_segs: vec4<u32>,
    // Shepard weight w_j per guide
    weight: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: FollowParams;
@group(0) @binding(1) var<storage, read> followers: array<Follower>;
@group(0) @binding(2) var<storage, read_write> verts: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> rest: array<vec4<f32>>;
// The head's hull and field: the world at group 3 (common/world.wgsl).

fn xform_point(m: mat4x4<f32>, p: vec3<f32>) -> vec3<f32> {
    return (m * vec4<f32>(p, 1.0)).xyz;
}

fn xform_vector(m: mat4x4<f32>, v: vec3<f32>) -> vec3<f32> {
    return (m * vec4<f32>(v, 0.0)).xyz;
}

fn unit_or_zero(v: vec3<f32>) -> vec3<f32> {
    let l = length(v);
    return select(vec3<f32>(0.0), v / l, l > 0.0);
}

// The shortest-arc rotation taking unit a to unit b, applied to v (follow::rotate_arc).
fn rotate_arc(a: vec3<f32>, b: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    let c = dot(a, b);
    if 1.0 + c < 1e-6 {
        let k = any_orthonormal(a);
        return 2.0 * dot(k, v) * k - v;
    }
    let x = cross(a, b);
    return c * v + cross(x, v) + dot(x, v) / (1.0 + c) * x;
}

@compute @workgroup_size(WORKGROUP)
fn follow(@builtin(global_invocation_id) id: vec3<u32>) {
    let fi = id.x + id.y * params.row_stride;
    if fi >= params.follower_count {
        return;
    }
    let f = followers[fi];
    let base = f.ids.x;
    let k = f.ids.y;
    let n = f.ids.z;
    let d = f.root.w;
    let hl = world_hull();
    let pose = world_steps[params.sample];
    let root = xform_point(pose.head, f.root.xyz);
    verts[base] = vec4<f32>(root, 1.0);
    var prev_p = root;
    var prev_dir = normalize(xform_vector(pose.head, head_gradient(hl, f.root.xyz)));
    for (var i = 1u; i <= k; i++) {
        let v = base + i;
        let own = unit_or_zero(xform_vector(pose.head, rest[v].xyz - rest[v - 1u].xyz));
        var blend = vec3<f32>(0.0);
        for (var j = 0u; j < n; j++) {
            // Segment i of the guide, its last simulated one past its end.
            let g = f.guide_first[j] + min(i, f.guide_segs[j]);
            let a = unit_or_zero(xform_vector(pose.head, rest[g].xyz - rest[g - 1u].xyz));
            let b = unit_or_zero(verts[g].xyz - verts[g - 1u].xyz);
            blend += f.weight[j] * rotate_arc(a, b, own);
        }
        let len = length(blend);
        var dir = prev_dir;
        if len > 1e-6 {
            dir = blend / len;
        }
        var pn = prev_p + dir * d;
        if params.collision != 0u {
            let local = xform_point(pose.head_inv, pn);
            if head_eval(hl, local) < 0.0 {
                let lp = xform_point(pose.head_inv, prev_p);
                let la = normalize(xform_vector(pose.head_inv, prev_dir));
                let q = head_push_out(hl, lp, la, local, d);
                dir = normalize(xform_point(pose.head, q) - prev_p);
                pn = prev_p + dir * d;
            }
        }
        verts[base + i] = vec4<f32>(pn, 1.0);
        prev_p = pn;
        prev_dir = dir;
    }
}
