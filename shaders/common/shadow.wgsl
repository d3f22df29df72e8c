// The light's shadow structure as every shading module sees it (the stage's shadow pass,
// src/stage/shadow.rs; docs/shadows.md).
// Contract for every module that includes this file:
// - `shadow_strands(p)`: the expected number of hair strands crossed on the way from world
//   point p towards the key light (the sum of the strands' projected coverage along that
//   ray); 0 where no hair is in the way or while shadows are off. Anjyo's shading attenuates
//   by it; the physical mode's dual scattering reads it as the strand count n.
// - `shadow_layered(p)`: the same for a point on a strand of hair lying in layers over a head
//   (Anjyo's strands), read `frame.shadow.layered.x` towards the light. The structure
//   smooths the strands over a cell or more, so read at the point itself it counts half
//   the layer the point lies in, and the outermost layer, which the light reaches
//   unhindered, comes out shadowed. Fur (standing off its skin), strips, and surfaces
//   under the hair read `shadow_strands`: there the offset skipped shadow that is there
//   (docs/shadows.md, measured against the path tracer).
// - `shadow_opaque(p)`: how much of the key light reaches p past opaque occluders (the head
//   ellipsoid, which stands for a mesh head, and a fur mesh's skin through the skin map):
//   1 lit, 0 in their shadow (the skin map answers per texel); 1 while shadows are off.
// - `shadow_absorbed(n)`: the share of the direct light left past n strands,
//   exp(-absorption * n); the factor on hair's direct (diffuse + specular) light is
//   shadow_absorbed(shadow_strands(p)) * shadow_opaque(p). A module reads each lookup once
//   and hands it to both shading modes: a software rasteriser runs both sides of a branch,
//   so a lookup repeated on each side is paid twice.


// The structure this pipeline reads, fixed when the pipeline is built
// (gpu::shadow::ShadowVariant): 0 none, 1 the volume, 2 deep opacity maps; plus 4 for toon
// steps; plus 8 for the skin map (only a scene with fur pays for its read). A pipeline constant, not a test of the frame uniform: a software rasteriser runs
// both sides of a branch under a mask, so only a lookup compiled out costs nothing.
override SHADOW_LOOKUP: u32 = 0u;

fn shadow_lookup() -> u32 {
    return SHADOW_LOOKUP % 4u;
}

// The resolved structure (src/stage/shadow.rs): volume, per cell the strands crossed up to
// its centre; deep opacity, per texel the first depth then the strands crossed at each
// layer's end.
// A texture, not a storage buffer: every shader stage may read it without counting against
// the storage buffers a stage may bind (the wisps' march binds many). Word i lies at
// (i % SHADOW_ROW, i / SHADOW_ROW); SHADOW_ROW is ROW in src/gpu/shadow.rs (gpu_twins checks).
@group(0) @binding(1) var shadow_map: texture_2d<f32>;

const SHADOW_ROW: u32 = 256u;

fn shadow_word(i: u32) -> f32 {
    return textureLoad(shadow_map, vec2<u32>(i % SHADOW_ROW, i / SHADOW_ROW), 0).x;
}

// Light-space coordinates of p: x, y in cells, z depth from the box's light side (world).
fn shadow_coords(p: vec3<f32>) -> vec3<f32> {
    let q = p - frame.shadow.center.xyz;
    let half = frame.shadow.axis_u.w;
    return vec3<f32>(
        (dot(q, frame.shadow.axis_u.xyz) / half * 0.5 + 0.5) * frame.shadow.dims.x,
        (dot(q, frame.shadow.axis_v.xyz) / half * 0.5 + 0.5) * frame.shadow.dims.y,
        half - dot(q, frame.shadow.axis_l.xyz),
    );
}

fn shadow_volume_at(x: i32, y: i32, z: i32) -> f32 {
    let nx = i32(frame.shadow.dims.x);
    let ny = i32(frame.shadow.dims.y);
    let nz = i32(frame.shadow.dims.z);
    let i = (clamp(z, 0, nz - 1) * ny + clamp(y, 0, ny - 1)) * nx + clamp(x, 0, nx - 1);
    return shadow_word(u32(i));
}

// Strands crossed at depth `t` behind texel (x, y)'s first depth.
fn shadow_deep_at(x: i32, y: i32, t: f32) -> f32 {
    let nx = i32(frame.shadow.dims.x);
    let ny = i32(frame.shadow.dims.y);
    let base = u32((clamp(y, 0, ny - 1) * nx + clamp(x, 0, nx - 1)) * 5);
    let off = t - shadow_word(base);
    var start = 0.0;
    var before = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let end = frame.shadow.layers[k];
        let after = shadow_word(base + 1u + k);
        if off < end {
            let f = clamp((off - start) / max(end - start, 1e-20), 0.0, 1.0);
            return mix(before, after, f);
        }
        start = end;
        before = after;
    }
    return before;
}

fn shadow_strands(p: vec3<f32>) -> f32 {
    if shadow_lookup() == 0u || frame.shadow.center.w < 0.5 {
        return 0.0;
    }
    let c = shadow_coords(p);
    if c.x < 0.0 || c.y < 0.0 || c.x > frame.shadow.dims.x || c.y > frame.shadow.dims.y {
        return 0.0;
    }
    let g = c.xy - 0.5;
    let i = vec2<i32>(floor(g));
    let f = g - floor(g);
    if shadow_lookup() == 1u {
        let gz = c.z / (2.0 * frame.shadow.axis_u.w) * frame.shadow.dims.z - 0.5;
        let iz = i32(floor(gz));
        let fz = gz - floor(gz);
        var s = array<f32, 2>(0.0, 0.0);
        for (var k = 0; k < 2; k++) {
            let a = mix(shadow_volume_at(i.x, i.y, iz + k), shadow_volume_at(i.x + 1, i.y, iz + k), f.x);
            let b = mix(shadow_volume_at(i.x, i.y + 1, iz + k), shadow_volume_at(i.x + 1, i.y + 1, iz + k), f.x);
            s[k] = mix(a, b, f.y);
        }
        return mix(s[0], s[1], fz);
    }
    let a = mix(shadow_deep_at(i.x, i.y, c.z), shadow_deep_at(i.x + 1, i.y, c.z), f.x);
    let b = mix(shadow_deep_at(i.x, i.y + 1, c.z), shadow_deep_at(i.x + 1, i.y + 1, c.z), f.x);
    return mix(a, b, f.y);
}

// The skin map (src/stage/shadow.rs, `SKIN_TEXELS`; present while `layered.y` is 1): per
// texel of a SHADOW_SKIN^2 grid across the box, the depth (world, from the box's light
// side) of the nearest skin triangle towards the light, the box's far side where none; its
// words start at `layered.z`. A fur mesh's skin casts it (`deposit_triangle`).
const SHADOW_SKIN: u32 = 256u;

// 0 where `depth` lies more than the bias (`layered.w`, two texels: a surface's own depth
// varies across a texel) behind texel (x, y)'s skin; 1 otherwise and off the map.
fn shadow_skin_at(x: i32, y: i32, depth: f32) -> f32 {
    let n = i32(SHADOW_SKIN);
    if x < 0 || y < 0 || x >= n || y >= n {
        return 1.0;
    }
    let d = shadow_word(u32(frame.shadow.layered.z) + u32(y * n + x));
    return select(1.0, 0.0, depth > d + frame.shadow.layered.w);
}

// The nearest texel's answer: one load. Blending the four nearest (percentage-closer
// filtering, a soft edge) cost the software viewer several times more of fur's frame, read
// at every hair vertex (docs/shadows.md).
fn shadow_skin(p: vec3<f32>) -> f32 {
    let c = shadow_coords(p);
    let i = vec2<i32>(floor(c.xy * (f32(SHADOW_SKIN) / frame.shadow.dims.x)));
    return shadow_skin_at(i.x, i.y, c.z);
}

// The skin map's answer times the ray from p towards the light against the head ellipsoid
// (drawn 2 % smaller, so roots on the scalp's lit side do not shadow themselves). A mesh
// head is stood for by its scene ellipsoid.
fn shadow_opaque(p: vec3<f32>) -> f32 {
    if shadow_lookup() == 0u || frame.shadow.center.w < 0.5 {
        return 1.0;
    }
    var lit = 1.0;
    if (SHADOW_LOOKUP & 8u) != 0u && frame.shadow.layered.y > 0.5 {
        lit = shadow_skin(p);
    }
    if frame.shadow.dims.w < 0.5 {
        return lit;
    }
    let o = (frame.shadow.head_inv * vec4<f32>(p, 1.0)).xyz;
    let d = (frame.shadow.head_inv * vec4<f32>(frame.shadow.axis_l.xyz, 0.0)).xyz;
    // |o + s d|^2 = r^2 with r = 0.98, for some s > 0.
    let a = dot(d, d);
    let b = dot(o, d);
    let c = dot(o, o) - 0.98 * 0.98;
    let disc = b * b - a * c;
    if disc < 0.0 || a <= 0.0 {
        return lit;
    }
    let far = (-b + sqrt(disc)) / a;
    return select(lit, 0.0, far > 0.0);
}

fn shadow_layered(p: vec3<f32>) -> f32 {
    return shadow_strands(p + frame.shadow.axis_l.xyz * frame.shadow.layered.x);
}

// The share of the direct light left after `crossed` strands (the absorption per strand).
fn shadow_absorbed(crossed: f32) -> f32 {
    return exp(-frame.shadow.axis_l.w * crossed);
}


// Toon shadows (the wisps, and the head in a toon scene): a step, not a gradient. 1 where
// more than TOON_STRANDS strands lie towards the light, or the head does; read 1.5 cells
// towards the light, so a surface does not shadow itself (the wisps' own toon shading
// darkens the side away from the light).
const TOON_STRANDS: f32 = 0.5;

fn shadow_toon(p: vec3<f32>) -> f32 {
    if (SHADOW_LOOKUP & 4u) == 0u || frame.shadow.center.w < 0.5 {
        return 0.0;
    }
    let bias = 3.0 * frame.shadow.axis_u.w / frame.shadow.dims.x;
    let q = p + frame.shadow.axis_l.xyz * bias;
    return select(0.0, 1.0, shadow_strands(q) > TOON_STRANDS || shadow_opaque(q) < 0.5);
}

// Whether the scene's shadows are toon steps (a scene with wisps; center.w is 2 too).
fn shadow_is_toon() -> bool {
    return (SHADOW_LOOKUP & 4u) != 0u;
}
