// One node of a drawn strand, as both hair rasterisers see it: the ribbons
// (anjyo/draw.wgsl) and the compute rasteriser for thin strands (anjyo/splat.wgsl) shade
// and size a node the same way. Shading is Anjyo's eqs 8-9 per node (the paper colours
// nodes and interpolates): I = I_a k_a C + I_s k_s (1 - (T.H)^2)^(n/2), with k_a per strand;
// or, per group, the physical mode of common/hair_bsdf.wgsl.
// The screen-space level of detail (src/systems/lod.rs) keeps every lod.y-th node (and the
// last) and widens the fewer strands drawn by lod.x.

// Twin of GpuMaterial (tests/it/gpu_twins.rs checks it) in src/systems/anjyo/gpu_data.rs.
struct Material {
    // rgb linear colour, w k_s
    color_ks: vec4<f32>,
    // x shininess n, y k_d, z root width (world), w tip width ratio
    params: vec4<f32>,
    // 1 where the node's own look (`looks`, a strand file's) replaces the above:
    // x colour, y width, z opacity.
    file: vec4<f32>,
    // The physical mode's parameters (common/hair_bsdf.wgsl); bsdf.sigma_a.w 1 when used.
    bsdf: HairBsdf,
    // Per-strand variation (common/strand_vary.wgsl): x melanin, y width, z tint.
    variation: vec4<f32>,
    // A physical group that varies: the sky's single backscattering (rgb) at absorption
    // factors e^x, x evenly from -span to span (the first w). hair_bsdf::varied_single.
    vary_single: array<vec4<f32>, VARY_TABLE>,
}

// The varied table's entries (hair_bsdf::VARY_TABLE; tests/it/gpu_twins.rs checks it), odd:
// the middle one is the group's own.
const VARY_TABLE: u32 = 17u;
const VARY_MIDDLE: u32 = VARY_TABLE / 2u;

@group(1) @binding(0) var<storage, read> strands: array<Strand>;
@group(1) @binding(1) var<storage, read> verts: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> materials: array<Material>;
// x: width factor, y: node step (StrandsPass::prepare).
@group(1) @binding(3) var<uniform> lod: vec4<f32>;
// Per node (as verts), from strand files: x sRGB colour and opacity (unpack4x8unorm),
// y width (f32 bits). Twin of GpuLook in src/systems/anjyo/gpu_data.rs. One
// placeholder entry when no group reads it.
@group(1) @binding(5) var<storage, read> looks: array<vec2<u32>>;

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
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

struct ShadedNode {
    pos: vec3<f32>,
    // Unit tangent (central difference over the drawn nodes).
    tangent: vec3<f32>,
    rgb: vec3<f32>,
    // World width, tapered root to tip (or the file's), times the level of detail's factors.
    width: f32,
    // Opacity (the file's, or 1).
    alpha: f32,
    // The physical mode's single scattering of the key light (already in rgb), by where on
    // the fibre's width it leaves: each bin's mean over its h-range (hair_radiance_bins;
    // 0 in Anjyo's mode). The ribbons shade a fragment with its own bin (anjyo/draw.wgsl).
    near: array<vec3<f32>, HAIR_BINS>,
    // The part of rgb those bins make up (their h-weighted mean).
    single: vec3<f32>,
}

// Half the h-width of bin k of hair_radiance_bins, the weight of its mean in S: bin k
// spans gamma from -pi/2 + k pi/6, so h from -1, -sqrt(3)/2, -1/2, 0, 1/2, sqrt(3)/2, 1.
fn hair_bin_weight(k: u32) -> f32 {
    let edge = array<f32, 7>(-1.0, -0.8660254, -0.5, 0.0, 0.5, 0.8660254, 1.0);
    return 0.5 * (edge[k + 1u] - edge[k]);
}

fn lod_step() -> u32 {
    return max(u32(lod.y), 1u);
}

// The last drawn node of a strand.
fn last_node(s: Strand) -> u32 {
    return u32(ceil(s.visible));
}

// Node n's width (world units, tapered root to tip or the file's, times the level of
// detail's factors) and opacity (the file's, or 1): what placing it on screen needs, without
// shading it (the binned compute rasteriser's bins).
fn node_width_alpha(s: Strand, n: u32) -> vec2<f32> {
    let mat = materials[s.group];
    let along = f32(n) / f32(max(s.segments, 1u));
    var width = mat.params.z * mix(1.0, mat.params.w, along);
    var alpha = 1.0;
    if any(mat.file.xyz > vec3<f32>(0.5)) {
        let look = looks[s.first_vertex + n];
        width = select(width, bitcast<f32>(look.y), mat.file.y > 0.5);
        alpha = select(1.0, unpack4x8unorm(look.x).a, mat.file.z > 0.5);
    }
    // Only a group that varies pays for it (a uniform branch per group).
    if mat.variation.y != 0.0 {
        width *= vary_width(s.rand, mat.variation);
    }
    // raster.z widens hair when only a share of it is drawn (level of detail).
    return vec2<f32>(width * frame.raster.z * lod.x, alpha);
}

// The sky's single backscattering by a strand of group g whose log absorption factor is x
// (per channel): the group's table, its log linear between entries, held at its ends (the
// f64 twin is hair_bsdf::varied_single_at).
fn varied_single(g: u32, x: vec3<f32>) -> vec3<f32> {
    // VARY_TABLE entries: VARY_TABLE - 1 intervals, the middle at VARY_MIDDLE.
    let span = materials[g].vary_single[0].w;
    if span <= 0.0 {
        return materials[g].vary_single[VARY_MIDDLE].rgb;
    }
    let last = f32(VARY_TABLE - 1u);
    let u = clamp((x / (2.0 * span) + 0.5) * last, vec3<f32>(0.0), vec3<f32>(last));
    var out = vec3<f32>(0.0);
    for (var c = 0u; c < 3u; c++) {
        let i = min(u32(u[c]), VARY_TABLE - 2u);
        let a = log(max(materials[g].vary_single[i][c], 1e-30));
        let b = log(max(materials[g].vary_single[i + 1u][c], 1e-30));
        out[c] = exp(mix(a, b, u[c] - f32(i)));
    }
    return out;
}

// Node n (a multiple of the step, or the last) of strand s.
fn shade_node(s: Strand, n: u32) -> ShadedNode {
    var out: ShadedNode;
    let step = lod_step();
    let last = last_node(s);
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

    let wa = node_width_alpha(s, n);
    out.width = wa.x;
    out.alpha = wa.y;
    var base = mat.color_ks.rgb;
    if mat.file.x > 0.5 {
        base = srgb_to_linear(unpack4x8unorm(looks[s.first_vertex + n].x).rgb);
    }
    // The strand's own pigment: its absorption scaled (vary.rs), its colour c^a; only a
    // group that varies pays for it.
    let varies = mat.variation.x != 0.0 || mat.variation.z != 0.0;
    var absorb = vec3<f32>(1.0);
    if varies {
        absorb = vary_absorption(s.rand, mat.variation);
        base = pow(max(base, vec3<f32>(0.0)), absorb);
    }

    // Anjyo eq 8: specular from the tangent alone; eq 9 with a per-strand ambient.
    let l = frame.light_dir.xyz;
    let v = normalize(frame.eye.xyz - p);
    let h = normalize(l + v);
    let th = dot(t, h);
    let spec = mat.color_ks.w * pow(max(1.0 - th * th, 0.0), 0.5 * mat.params.x);
    let tdl = dot(t, l);
    let diffuse = mat.params.y * sqrt(max(1.0 - tdl * tdl, 0.0));
    let ambient = frame.light_color.w * s.ka;
    // Hair shadows (common/shadow.wgsl) dim the direct light only; each lookup read once.
    let crossed = shadow_layered(p);
    let opaque = shadow_opaque(p);
    let intensity = frame.light_dir.w * shadow_absorbed(crossed) * opaque;
    var rgb = base * (ambient + intensity * diffuse) + frame.light_color.rgb * (intensity * spec);
    // The physical mode (docs/shading.md): the key light dual-scattered through the strands
    // the shadow structure counts, past opaque occluders, plus Kami's ambient (I_a k_a) times
    // the colour a dense volume of this hair sends back. A strand file's colours are not
    // read (the group's pigments are).
    // A strand's own scattering reads its own absorption; the light the strands around it
    // send (dual scattering's averages, the ambient's multiple part) stays the group's.
    if hair_physical(mat.bsdf) {
        var b = mat.bsdf;
        var around = mat.bsdf.ambient.rgb;
        if varies {
            b.sigma_a = vec4<f32>(b.sigma_a.rgb * absorb, b.sigma_a.w);
            // The sky it scatters once is its own pigment's (the table's middle is the
            // group's).
            around += varied_single(s.group, log(absorb)) - mat.vary_single[VARY_MIDDLE].rgb;
        }
        let d = hair_dual_parts(b, t, v, l, crossed);
        let key = frame.light_color.rgb * (hair_irradiance() * opaque);
        out.single = key * hair_bins_sum(d.single);
        for (var k = 0u; k < HAIR_BINS; k++) {
            out.near[k] = key * d.single[k] / hair_bin_weight(k);
        }
        rgb = out.single + key * d.back + around * ambient;
    }
    // The dynamics mark nodes whose segment felt the pseudo-force with w = 2.
    if frame.flags.x > 0.5 && verts[s.first_vertex + n].w > 1.5 {
        rgb = vec3<f32>(0.9, 0.1, 0.05);
    }
    out.pos = p;
    out.tangent = t;
    out.rgb = rgb;
    return out;
}
