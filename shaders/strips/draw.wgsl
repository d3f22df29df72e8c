// Strips drawn as textured reeds (Kazama et al. 2.1): one triangle strip per strip, two
// vertices per control point read from the ribbon buffer that shaders/strips/ribbon.wgsl
// wrote (2 triangles per stick: on a software rasterizer triangle setup is the cost).
//
// Colour: the layer colour times the strand texture's root-to-tip gradient (stored divided
// by `gain`), lit by Kajiya and Kay's model along the strip tangent T: diffuse sin(T, L),
// specular k_s sin(T, H)^n. It does not use a surface normal, so both faces are lit alike.
//
// Coverage: the texture's alpha is the share of a texel the fine hairs cover. Where a
// texel covers a sample or more (close up), the alpha test at `alpha_cutoff` is made
// smooth over one sample (alpha minus the cutoff over its screen derivative), so hair edges
// are crisp and anti-aliased; where several texels fall in a sample (far away, read from
// the alpha-averaged mips), the mean alpha is the coverage itself, so a far strip keeps its
// density instead of vanishing or turning solid (in the physical mode, closed further
// where the strip is seen obliquely: oblique_coverage). The two blend over one mip level. The
// coverage then goes through common/coverage.wgsl as every hair pass's does: blended
// without MSAA, a per-sample mask with it (per-sample discard on GL).

// Twin of GpuStripLook (tests/it/gpu_twins.rs checks it) in src/systems/strips/ribbon.rs.
struct StripLook {
    // x specular strength, y specular exponent, z alpha cutoff, w texture gain
    look: vec4<f32>,
    // x stride (control point slots per strip)
    counts: vec4<u32>,
    // The physical mode's parameters (common/hair_bsdf.wgsl); bsdf.sigma_a.w 1 when used.
    bsdf: HairBsdf,
}

@group(1) @binding(0) var<storage, read> verts: array<RibbonVertex>;
@group(1) @binding(1) var<storage, read> info: array<StripInfo>;
@group(1) @binding(2) var<uniform> strip_look: StripLook;
@group(1) @binding(3) var strand_tex: texture_2d<f32>;
@group(1) @binding(4) var strand_sampler: sampler;

struct VOut {
    @builtin(position) pos: vec4<f32>,
    // x: u times the ribbon width here, y: that width, z: v (u = x / y, see vs)
    @location(0) uvq: vec3<f32>,
    @location(1) world: vec3<f32>,
    @location(2) tangent: vec3<f32>,
    @location(3) @interpolate(flat) strip: u32,
    // The physical mode's light, per control point (zero in Anjyo's shading): the key light
    // (light colour x intensity x dual-scattered radiance factor) plus the ambient colour
    // times what reaches this point past the strips that hide its sky (hair_ambient_in_coat
    // of strip_sky) times I_a. One varying for both: a software rasteriser interpolates
    // each per fragment.
    @location(4) physical: vec3<f32>,
    // Hair shadows (common/shadow.wgsl): the share of the direct light that reaches this
    // control point. Per control point, as the other kinds shade per node: the structure's
    // cells are wider than a stick, and read per fragment the lookup cost a fifth of the
    // strips' frame on a software rasteriser.
    @location(5) lit: f32,
    // The physical mode's obliquity of the strip to the view, 1 / |cos| between its normal
    // and the view (1 in Anjyo's shading): see `oblique_coverage`.
    @location(6) oblique: f32,
}

// The coverage of a strip of fine hairs seen obliquely (the physical mode's). The texture's
// alpha a is the share of the strip's width its hairs cover, seen face on. Turned by theta
// about the hairs' direction, the strip's width across them shrinks by cos theta on screen
// but the hairs, round, keep theirs, so they overlap and close the gaps: with the hairs
// placed independently, what shows through is (1 - a)^(1 / cos theta), the form the
// strips' sky bake (src/systems/strips/sky.rs) gives a ray crossing a strip. Tilted along
// the hairs, the gaps keep their share. The path tracer draws the strip's hairs as curves
// and sees the same: a curtain of strips seen edge on is opaque.
fn oblique_coverage(a: f32, oblique: f32) -> f32 {
    return 1.0 - pow(max(1.0 - a, 0.0), oblique);
}

// Cosines below this are taken as this (a strip seen exactly edge on is opaque already).
const MIN_STRIP_COS: f32 = 0.05;

// How far towards the light a control point reads the shadow structure, in units of the
// layered strands' offset (`shadow_layered`): the structure smooths a strip over a cell, so
// read at the point it counts part of the strip's own layer. Chosen against the path tracer
// (docs/shadows.md, "Strips"): at 0 the side light's close-up got none of its direct light,
// at 1 the back light's rim came out too bright. The physical mode's only: Anjyo's strips
// keep the paper scenes' look (and read at the point).
const STRIP_SHADOW_OFFSET: f32 = 0.5;

@vertex
fn vs(@builtin(vertex_index) vi: u32, @builtin(instance_index) si: u32) -> VOut {
    var out: VOut;
    let v = verts[2u * (si * strip_look.counts.x + (vi >> 1u)) + (vi & 1u)];
    out.pos = frame.view_proj * vec4<f32>(v.position.xyz, 1.0);
    // A tapered stick is a trapezoid cut into two triangles; u interpolated linearly would
    // kink along the diagonal (the hairs zigzag once per stick). u × width and the width are
    // both linear over the trapezoid, so their interpolated ratio is the true u.
    let info_s = info[si];
    let width = mix(info_s.side.w, info_s.normal.w, v.tangent.w);
    out.uvq = vec3<f32>(v.position.w * width, width, v.tangent.w);
    out.world = v.position.xyz;
    out.tangent = v.tangent.xyz;
    out.strip = si;
    out.physical = vec3<f32>(0.0);
    out.oblique = 1.0;
    // One lookup for both modes (a software rasteriser would pay one per branch).
    let offset = select(0.0, STRIP_SHADOW_OFFSET * frame.shadow.layered.x, hair_physical(strip_look.bsdf));
    let n = shadow_strands(v.position.xyz + frame.shadow.axis_l.xyz * offset);
    let opaque = shadow_opaque(v.position.xyz);
    out.lit = shadow_absorbed(n) * opaque;
    if hair_physical(strip_look.bsdf) {
        // Per vertex, as the other kinds shade per node (docs/shading.md).
        var t = v.tangent.xyz;
        let tl2 = dot(t, t);
        t = select(vec3<f32>(0.0, -1.0, 0.0), t * inverseSqrt(tl2), tl2 > 1e-20);
        let p = v.position.xyz;
        let view = normalize(frame.eye.xyz - p);
        let f = hair_dual_radiance(strip_look.bsdf, t, view, frame.light_dir.xyz, n);
        // A strip is a sheet of hairs: it weighs the sky as a surface does (hair_bsdf::SkyWeight).
        let index = strip_sky(info_s, v.tangent.w);
        let sky = hair_ambient_in_coat(strip_look.bsdf, index, hair_two_e3(index));
        out.physical = frame.light_color.rgb * (hair_irradiance() * opaque) * f
            + strip_look.bsdf.ambient.rgb * sky * frame.light_color.w;
        // The normal from the control point's other edge vertex. The hairs run along t, so
        // only the turn about t narrows the gaps: across the hairs' projection the strip's
        // width shrinks by |n . v| / sqrt(1 - (t . v)^2), 1 for a view in the plane of n and t.
        let other = verts[2u * (si * strip_look.counts.x + (vi >> 1u)) + ((vi & 1u) ^ 1u)];
        let nrm = cross(t, other.position.xyz - p);
        let nl2 = dot(nrm, nrm);
        let tv = dot(t, view);
        let across = inverseSqrt(max(1.0 - tv * tv, 1e-12));
        let c = select(1.0, min(abs(dot(nrm, view)) * inverseSqrt(nl2) * across, 1.0), nl2 > 1e-20);
        out.oblique = 1.0 / max(c, MIN_STRIP_COS);
    }
    return out;
}

// Shaded colour and coverage of a fragment.
fn strip_color(in: VOut) -> vec4<f32> {
    // Sampling and derivatives first, in uniform control flow.
    let u = select(0.5, in.uvq.x / in.uvq.y, in.uvq.y > 0.0);
    let uv = vec2<f32>(u, in.uvq.z);
    let tex = textureSample(strand_tex, strand_sampler, uv);
    let texels = uv * vec2<f32>(textureDimensions(strand_tex, 0));
    // Texels per sample across the strip: the hairs run along v, so their gaps are resolved
    // or not by the footprint in u alone.
    let footprint = length(vec2<f32>(dpdx(texels.x), dpdy(texels.x)));
    let edge = max(fwidth(tex.a), 1e-3);

    let cutoff = strip_look.look.z;
    // Nothing where no hair is (also with a cutoff of 0).
    let sharp = select(0.0, clamp((tex.a - cutoff) / edge + 0.5, 0.0, 1.0), tex.a > 0.0);
    let far = clamp(log2(max(footprint, 1e-6)), 0.0, 1.0);
    let alpha = mix(sharp, oblique_coverage(tex.a, in.oblique), far);

    var t = in.tangent;
    let tl2 = dot(t, t);
    t = select(vec3<f32>(0.0, -1.0, 0.0), t * inverseSqrt(tl2), tl2 > 1e-20);
    let l = frame.light_dir.xyz;
    let view = normalize(frame.eye.xyz - in.world);
    let h = normalize(l + view);
    let tdl = dot(t, l);
    let tdh = dot(t, h);
    let diffuse = sqrt(max(1.0 - tdl * tdl, 0.0));
    let spec = strip_look.look.x * pow(max(1.0 - tdh * tdh, 0.0), 0.5 * strip_look.look.y);
    let base = info[in.strip].color.rgb * tex.rgb * strip_look.look.w;
    // Hair shadows (common/shadow.wgsl) dim the direct light only.
    let intensity = frame.light_dir.w * in.lit;
    var rgb = base * (frame.light_color.w + intensity * diffuse) + frame.light_color.rgb * (intensity * spec);
    if hair_physical(strip_look.bsdf) {
        // The pigments' colour instead of the layer's; the texture's gradient kept.
        rgb = in.physical * tex.rgb
            * strip_look.look.w;
    }
    return vec4<f32>(rgb, alpha);
}

// Below this coverage a fragment is dropped (it would only write depth).
const MIN_COVERAGE: f32 = 0.004;

@fragment
fn fs(in: VOut) -> HairFragment {
    let c = strip_color(in);
    if c.a < MIN_COVERAGE {
        discard;
    }
    return hair_fragment(c, in.pos.xy, in.strip);
}

@fragment
fn fs_per_sample(in: VOut, @builtin(sample_index) sample: u32) -> @location(0) vec4<f32> {
    let c = strip_color(in);
    if c.a < MIN_COVERAGE {
        discard;
    }
    return hair_fragment_per_sample(c, in.pos.xy, in.strip, sample);
}
