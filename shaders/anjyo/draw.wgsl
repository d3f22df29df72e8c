// Hair as camera-facing ribbons, built in the vertex shader straight from the strand storage
// buffers (no CPU copy). Vertex 2i and 2i+1 are the two sides of node i; one instance per
// strand, drawn as a triangle strip. Shading is Anjyo's eqs 8-9 per node (the paper colours
// nodes and interpolates): I = I_a k_a C + I_s k_s (1 - (T.H)^2)^(n/2), with k_a per strand.
// A strand thinner than `frame.raster.y` samples is drawn that wide with alpha equal to its
// true coverage (common/coverage.wgsl), so sub-pixel hair is smooth and order-independent.
// The screen-space level of detail (src/systems/lod.rs) draws every lod.y-th node (and the
// last) and widens the fewer strands drawn by lod.x.

// Keep in sync with GpuMaterial in src/gpu/gpu_data.rs.
struct Material {
    // rgb linear colour, w k_s
    color_ks: vec4<f32>,
    // x shininess n, y k_d, z root width (world), w tip width ratio
    params: vec4<f32>,
}

@group(1) @binding(0) var<storage, read> strands: array<Strand>;
@group(1) @binding(1) var<storage, read> verts: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> materials: array<Material>;
// x: width factor, y: node step (StrandsPass::prepare).
@group(1) @binding(3) var<uniform> lod: vec4<f32>;

struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) @interpolate(flat) strand: u32,
}

// Node i of the drawn part of a strand; the last drawn node may be cut part-way.
fn node_pos(s: Strand, i: u32) -> vec3<f32> {
    let p = verts[s.first_vertex + i].xyz;
    let over = f32(i) - s.visible;
    if over > 0.0 && i > 0u {
        let q = verts[s.first_vertex + i - 1u].xyz;
        return mix(p, q, clamp(over, 0.0, 1.0));
    }
    return p;
}

@vertex
fn vs(@builtin(vertex_index) vi: u32, @builtin(instance_index) si: u32) -> VOut {
    var out: VOut;
    let s = strands[si];
    let last = u32(ceil(s.visible));
    // Every step-th node; nodes past the drawn length collapse onto the last one
    // (zero-area triangles).
    let step = max(u32(lod.y), 1u);
    let n = min((vi >> 1u) * step, last);
    let side = select(-1.0, 1.0, (vi & 1u) == 1u);
    let mat = materials[s.group];

    let p = node_pos(s, n);
    var t: vec3<f32>;
    if last == 0u {
        t = verts[s.first_vertex + 1u].xyz - p;
    } else if n == 0u {
        t = node_pos(s, min(step, last)) - p;
    } else if n == last {
        t = p - node_pos(s, ((n - 1u) / step) * step);
    } else {
        t = node_pos(s, min(n + step, last)) - node_pos(s, n - step);
    }
    let tl = length(t);
    t = select(vec3<f32>(0.0, -1.0, 0.0), t / tl, tl > 1e-20);

    // Screen-space direction of the tangent (exact derivative of the projection).
    let clip = frame.view_proj * vec4<f32>(p, 1.0);
    let ct = frame.view_proj * vec4<f32>(t, 0.0);
    var sdir = (ct.xy * clip.w - clip.xy * ct.w) * frame.viewport.xy;
    let sl = length(sdir);
    sdir = select(vec2<f32>(1.0, 0.0), sdir / sl, sl > 1e-20);
    let across = vec2<f32>(-sdir.y, sdir.x);

    // Width: world width tapered root to tip, in samples at this depth.
    let along = f32(n) / f32(max(s.segments, 1u));
    // raster.z widens hair when only a share of it is drawn (level of detail).
    let width = mat.params.z * mix(1.0, mat.params.w, along) * frame.raster.z * lod.x;
    let width_px = width * frame.raster.x / max(clip.w, 1e-6);
    let drawn_px = max(width_px, frame.raster.y);
    let coverage = width_px / drawn_px;
    let offset = across * (side * drawn_px) * frame.viewport.zw;
    out.pos = vec4<f32>(clip.xy + offset * clip.w, clip.z, clip.w);

    // Anjyo eq 8: specular from the tangent alone; eq 9 with a per-strand ambient.
    let l = frame.light_dir.xyz;
    let v = normalize(frame.eye.xyz - p);
    let h = normalize(l + v);
    let th = dot(t, h);
    let spec = mat.color_ks.w * pow(max(1.0 - th * th, 0.0), 0.5 * mat.params.x);
    let tdl = dot(t, l);
    let diffuse = mat.params.y * sqrt(max(1.0 - tdl * tdl, 0.0));
    let ambient = frame.light_color.w * s.ka;
    let intensity = frame.light_dir.w;
    var rgb = mat.color_ks.rgb * (ambient + intensity * diffuse) + frame.light_color.rgb * (intensity * spec);
    // The dynamics mark nodes whose segment felt the pseudo-force with w = 2.
    if frame.flags.x > 0.5 && verts[s.first_vertex + n].w > 1.5 {
        rgb = vec3<f32>(0.9, 0.1, 0.05);
    }
    out.color = vec4<f32>(rgb, coverage);
    out.strand = si;
    return out;
}

@fragment
fn fs(in: VOut) -> HairFragment {
    return hair_fragment(in.color, in.pos.xy, in.strand);
}

@fragment
fn fs_per_sample(in: VOut, @builtin(sample_index) sample: u32) -> @location(0) vec4<f32> {
    return hair_fragment_per_sample(in.color, in.pos.xy, in.strand, sample);
}
