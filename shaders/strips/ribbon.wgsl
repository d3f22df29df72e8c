// Ribbons of the Hair Object Model from the strips' control points: the f32 twin of
// `ribbon_reference` in src/systems/strips/ribbon.rs (read its header for the side vector's
// parallel transport and the fallbacks). One invocation per strip walks its chain root to
// tip, because the side vector of point k is carried from point k - 1.

// Passed by the Rust side (`gpu::WORKGROUP` and the thresholds of ribbon.rs).
override WORKGROUP: u32;
override TINY2: f32;
override SIDE_MIN: f32;
override FOLD_COS: f32;

// Twin of GpuRibbonParams (tests/it/gpu_twins.rs checks it) in src/systems/strips/ribbon.rs.
struct Params {
    // Head pose (its rotation turns the rest side vectors and normals).
    head: mat4x4<f32>,
    // x strips, y stride (slots per strip), z invocations per dispatch row
    counts: vec4<u32>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> info: array<StripInfo>;
// The dynamics' control points: xyz world position, index strip * stride + k.
@group(0) @binding(2) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> verts: array<RibbonVertex>;

fn unit_or(v: vec3<f32>, min2: f32, fallback: vec3<f32>) -> vec3<f32> {
    let l2 = dot(v, v);
    if l2 > min2 {
        return v / sqrt(l2);
    }
    return fallback;
}

fn any_perpendicular(t: vec3<f32>) -> vec3<f32> {
    let other = select(vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(1.0, 0.0, 0.0), abs(t.x) < 0.9);
    return normalize(cross(t, other));
}

fn fallback_side(t: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return unit_or(cross(n, t), SIDE_MIN * SIDE_MIN, any_perpendicular(t));
}

// Unit direction of stick k (point k to k + 1), `prev` where the stick has no length.
fn stick(base: u32, k: u32, prev: vec3<f32>) -> vec3<f32> {
    return unit_or(points[base + k + 1u].xyz - points[base + k].xyz, TINY2, prev);
}

@compute @workgroup_size(WORKGROUP)
fn build(@builtin(global_invocation_id) id: vec3<u32>) {
    let s = id.x + id.y * params.counts.z;
    if s >= params.counts.x {
        return;
    }
    let stride = params.counts.y;
    let base = s * stride;
    let strip = info[s];
    let n = clamp(strip.counts.x, 1u, stride);
    let m = mat3x3<f32>(params.head[0].xyz, params.head[1].xyz, params.head[2].xyz);
    let normal = unit_or(m * strip.normal.xyz, TINY2, vec3<f32>(0.0, 1.0, 0.0));
    let ring = unit_or(m * strip.side.xyz, TINY2, vec3<f32>(1.0, 0.0, 0.0));

    // d_prev: the stick before point k; d_next: the stick after it (as the reference's dirs).
    var d_prev = normal;
    var d_next = normal;
    if n > 1u {
        d_next = stick(base, 0u, normal);
    }
    var t_prev = d_next;
    if n == 1u {
        t_prev = normal;
    }
    var side = unit_or(ring - dot(ring, t_prev) * t_prev, SIDE_MIN * SIDE_MIN, fallback_side(t_prev, normal));
    var t = t_prev;
    for (var k = 0u; k < stride; k++) {
        if k < n {
            // Tangent at point k.
            if n == 1u {
                t = normal;
            } else if k == 0u {
                t = d_next;
            } else if k == n - 1u {
                t = d_prev;
            } else {
                t = unit_or(d_prev + d_next, TINY2, d_next);
            }
            if k > 0u {
                let c = dot(t_prev, t);
                if c > FOLD_COS {
                    let v = cross(t_prev, t);
                    side = side * c + cross(v, side) + v * (dot(v, side) / (1.0 + c));
                }
                side = unit_or(side - dot(side, t) * t, SIDE_MIN * SIDE_MIN, fallback_side(t, normal));
                t_prev = t;
            }
        }
        let kk = min(k, n - 1u);
        var along = 0.0;
        if n > 1u {
            along = f32(kk) / f32(n - 1u);
        }
        let half = 0.5 * mix(strip.side.w, strip.normal.w, along);
        let c = points[base + kk].xyz;
        let out = 2u * (base + k);
        verts[out] = RibbonVertex(vec4<f32>(c - half * side, 0.0), vec4<f32>(t, along));
        verts[out + 1u] = RibbonVertex(vec4<f32>(c + half * side, 1.0), vec4<f32>(t, along));
        // Advance the sticks around the next point.
        if k + 1u < n {
            d_prev = d_next;
            if k + 2u < n {
                d_next = stick(base, k + 1u, d_prev);
            }
        }
    }
}
