// Hair as camera-facing ribbons, built in the vertex shader straight from the strand storage
// buffers (no CPU copy). Vertex 2i and 2i+1 are the two sides of node i; one instance per
// strand, drawn as a triangle strip. Nodes are shaded and sized by common/strand_shade.wgsl.
// A strand thinner than `frame.raster.y` samples is drawn that wide with alpha equal to its
// true coverage (common/coverage.wgsl), so sub-pixel hair is smooth and order-independent.
//
// Two pairs of entry points: `vs`/`fs` (Anjyo's mode: the node's colour, interpolated) and
// `vs_near`/`fs_near` for a pass that shades physically (src/systems/anjyo/draw.rs picks
// them), where each fragment is shaded as the place on the fibre it stands for: its single
// scattering of the key light is the bin of the fibre's width under it (common/hair_bsdf.wgsl
// hair_radiance_bins), and its depth is the fibre's round surface there. Where strands lie
// over each other, the ribbons then hide the same parts of each other as the path tracer's
// cylinders, and the camera sees one side of most fibres, whose lobes are not the far
// field's mean (docs/shading.md, "The near field across a ribbon").

struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) @interpolate(flat) strand: u32,
}

struct VOutNear {
    @builtin(position) pos: vec4<f32>,
    // rgb: the node's colour less its single scattering of the key light (the bins).
    @location(0) color: vec4<f32>,
    @location(1) @interpolate(flat) strand: u32,
    // sin gamma of hair_radiance_bins at this place across the ribbon: -1 to 1.
    @location(2) h: f32,
    // The bins' means (ShadedNode.near).
    @location(3) near0: vec3<f32>,
    @location(4) near1: vec3<f32>,
    @location(5) near2: vec3<f32>,
    @location(6) near3: vec3<f32>,
    @location(7) near4: vec3<f32>,
    @location(8) near5: vec3<f32>,
    // How much nearer (depth) the fibre's surface is at its middle than at its edges.
    @location(9) bulge: f32,
}

// One ribbon vertex: what both vertex entry points share.
struct Ribbon {
    out: VOut,
    node: ShadedNode,
    clip: vec4<f32>,
    // Screen-space unit vector across the ribbon, and which side this vertex is (-1, 1).
    across: vec2<f32>,
    side: f32,
    // The strand's width over its drawn width (1 unless sub-sample).
    coverage: f32,
}

fn ribbon(vi: u32, si: u32) -> Ribbon {
    var r: Ribbon;
    let s = strands[si];
    // Every step-th node; nodes past the drawn length collapse onto the last one
    // (zero-area triangles).
    let n = min((vi >> 1u) * lod_step(), last_node(s));
    r.side = select(-1.0, 1.0, (vi & 1u) == 1u);
    r.node = shade_node(s, n);

    // Screen-space direction of the tangent (exact derivative of the projection).
    r.clip = frame.view_proj * vec4<f32>(r.node.pos, 1.0);
    let clip = r.clip;
    let ct = frame.view_proj * vec4<f32>(r.node.tangent, 0.0);
    var sdir = (ct.xy * clip.w - clip.xy * ct.w) * frame.viewport.xy;
    let sl = length(sdir);
    sdir = select(vec2<f32>(1.0, 0.0), sdir / sl, sl > 1e-20);
    r.across = vec2<f32>(-sdir.y, sdir.x);

    // Width in samples at this depth.
    let width_px = r.node.width * frame.raster.x / max(clip.w, 1e-6);
    let drawn_px = max(width_px, frame.raster.y);
    r.coverage = width_px / drawn_px;
    let offset = r.across * (r.side * drawn_px) * frame.viewport.zw;
    r.out.pos = vec4<f32>(clip.xy + offset * clip.w, clip.z, clip.w);
    r.out.color = vec4<f32>(r.node.rgb, r.coverage * r.node.alpha);
    r.out.strand = si;
    return r;
}

@vertex
fn vs(@builtin(vertex_index) vi: u32, @builtin(instance_index) si: u32) -> VOut {
    return ribbon(vi, si).out;
}

@vertex
fn vs_near(@builtin(vertex_index) vi: u32, @builtin(instance_index) si: u32) -> VOutNear {
    let r = ribbon(vi, si);
    let node = r.node;
    var out: VOutNear;
    out.pos = r.out.pos;
    out.color = vec4<f32>(node.rgb - node.single, r.out.color.a);
    out.strand = si;
    // Which way across the ribbon gamma runs: e (across the fibre, facing the eye) on
    // screen against `across`, and the side of the fibre the light is on. gamma is
    // measured with the azimuth from the view to the light positive, so the R lobe's
    // highlight (gamma = -phi / 2) lies on the light's side, as on a cylinder.
    let t = node.tangent;
    let v = normalize(frame.eye.xyz - node.pos);
    let e = cross(t, v - dot(v, t) * t);
    let ce = frame.view_proj * vec4<f32>(e, 0.0);
    let on_screen = dot((ce.xy * r.clip.w - r.clip.xy * ce.w) * frame.viewport.xy, r.across);
    let l = frame.light_dir.xyz;
    let light_side = dot(l - dot(l, t) * t, e);
    out.h = r.side * select(1.0, -1.0, on_screen < 0.0) * select(-1.0, 1.0, light_side < 0.0);
    out.near0 = node.near[0];
    out.near1 = node.near[1];
    out.near2 = node.near[2];
    out.near3 = node.near[3];
    out.near4 = node.near[4];
    out.near5 = node.near[5];
    // The depth of the fibre's surface half its width nearer the eye; a ribbon widened
    // past the strand (sub-sample coverage) bulges as much less.
    let front = frame.view_proj * vec4<f32>(node.pos + v * (0.5 * node.width), 1.0);
    out.bulge = max(r.clip.z / r.clip.w - front.z / front.w, 0.0) * r.coverage;
    return out;
}

// The fragment's colour: the node's, plus the bin of single scattering under it.
fn near_color(in: VOutNear) -> vec4<f32> {
    let h = in.h;
    var s = select(in.near0, in.near1, h > -0.8660254);
    s = select(s, in.near2, h > -0.5);
    s = select(s, in.near3, h > 0.0);
    s = select(s, in.near4, h > 0.5);
    s = select(s, in.near5, h > 0.8660254);
    return vec4<f32>(in.color.rgb + s, in.color.a);
}

// The depth of the fibre's round surface under the fragment.
fn near_depth(in: VOutNear) -> f32 {
    return in.pos.z - in.bulge * sqrt(max(1.0 - in.h * in.h, 0.0));
}

@fragment
fn fs(in: VOut) -> HairFragment {
    return hair_fragment(in.color, in.pos.xy, in.strand);
}

@fragment
fn fs_per_sample(in: VOut, @builtin(sample_index) sample: u32) -> @location(0) vec4<f32> {
    return hair_fragment_per_sample(in.color, in.pos.xy, in.strand, sample);
}

struct NearFragment {
    @location(0) color: vec4<f32>,
    @builtin(sample_mask) mask: u32,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_near(in: VOutNear) -> NearFragment {
    let f = hair_fragment(near_color(in), in.pos.xy, in.strand);
    return NearFragment(f.color, f.mask, near_depth(in));
}

struct NearSample {
    @location(0) color: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_near_per_sample(in: VOutNear, @builtin(sample_index) sample: u32) -> NearSample {
    let c = hair_fragment_per_sample(near_color(in), in.pos.xy, in.strand, sample);
    return NearSample(c, near_depth(in));
}
