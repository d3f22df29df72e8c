// The compute rasteriser for thin strands (issue 12, item 6; issue 33, item 3): on a software
// adapter the triangle setup of two triangles per segment dominates a frame of sub-pixel
// hair, so each strand is walked here instead, one invocation per strand, one step per
// sample column (or row) its segments cross. The f64 reference with the same semantics is
// src/systems/splat.rs; keep the two in step.
//
// Every kind with thin strands draws through this file (Anjyo's strands, fur's line,
// polyline and curve coats). A kind's module puts before it its strand table `strands`
// (group 1, binding 0), `drawn_strand` (common/strand_drawn.wgsl) and four functions:
//   splat_step(s) -> u32              the node step of its level of detail,
//   splat_last(s) -> u32              the last node drawn,
//   splat_node(si, s, n) -> SplatNode node n placed, sized and shaded as its ribbons shade it,
//   splat_placed(si, s, n) -> SplatNode  the same placed and sized, unshaded (binning).
//
// Coverage is analytic: a segment of width w samples covers, in the column it crosses over
// a length fx, the vertical band of thickness w * sqrt(1 + slope^2) about its centre line,
// and each sample's share of that band is its coverage a (so a strand's coverages add up to
// its length times its width, and segments meet without overlap). Nodes are interpolated
// along the segment.
//
// Occlusion by the opaque scene (head, skins) is a depth test against the scene pass's
// depth (sample 0 with MSAA). Among the hairs of a sample the result is order-independent:
// the sample keeps, in fixed point with u32 atomics,
//   [0..3] sum of rgb * a * wt,  [3] sum of a * wt,  [4] sum of -ln(1 - a),
// where wt favours the nearer hairs; the resolve (stage/downsample.wgsl) composites
//   hair = (sum rgb a wt / sum a wt) * (1 - T) + scene * T,  T = exp(-sum -ln(1 - a)) = prod(1 - a),
// the exact transmittance of independent coverages, as the ribbons' hashed sample masks
// estimate it with MSAA. Kinds add into the same accumulation.
//
// Binned (issue 33, item 3): the words are sums of integers, so any order of adding them
// gives the same accumulation. `bin_count` (one invocation per drawn segment) counts, per
// screen tile of TILE x TILE samples, the segments whose sample rectangle reaches it;
// `bin_scan` turns the counts into offsets in one list; `bin_scatter` writes each segment's
// reference under every tile it reaches; `bin_raster` (one workgroup per tile) walks its
// tile's segments clipped to the tile, adding into workgroup memory, and adds each sample's
// five words to the accumulation once. A tile whose list does not fit the list buffer is
// drawn by `bin_scatter` directly (global atomics, as `splat`), so nothing is ever dropped.


@group(2) @binding(0) var<storage, read_write> accum: array<atomic<u32>>;
@group(2) @binding(1) var scene_depth: SceneDepth;
// Per tile (T tiles): [0, T) segment counts, [T, 2T) offsets in `bin_refs` (NONE: the tile
// does not fit and is drawn directly), [2T, 3T) write cursors. `bin_raster` leaves the
// counts at 0 for the next binning.
@group(3) @binding(0) var<storage, read_write> bins: array<atomic<u32>>;
// Per (segment, tile) pair: the segment's reference, strand * 256 + segment.
@group(3) @binding(1) var<storage, read_write> bin_refs: array<u32>;

// Fixed-point scales of the accumulation, as in stage/downsample.wgsl and
// src/gpu/splat.rs (tests/it/gpu_twins.rs checks them).
const COLOR_SCALE: f32 = 16384.0;
const DEPTH_SCALE: f32 = 4096.0;
// Coverage is clamped below 1 in -ln(1 - a), so it stays finite.
const MAX_COVERAGE: f32 = 0.999;
// Depth bias of the test against the opaque depth (NDC), for hair lying on the scalp.
const DEPTH_BIAS: f32 = 1e-5;
// At most this many samples across a segment: wider strands belong to the ribbons.
const MAX_ACROSS: i32 = 16;
// Tile side in samples (src/gpu/splat.rs `TILE`; tests/it/gpu_twins.rs checks it).
const TILE: i32 = 16;
const NONE: u32 = 0xffffffffu;
// The tile's samples in workgroup memory, five words each (`bin_raster`).
const TILE_WORDS: u32 = 5u * u32(TILE * TILE);
var<workgroup> tile_accum: array<atomic<u32>, TILE_WORDS>;

// A node as a kind gives it: world position, linear colour, world width (with the level of
// detail's factors), opacity (scales coverage).
struct SplatNode {
    pos: vec3<f32>,
    rgb: vec3<f32>,
    width: f32,
    alpha: f32,
}

// A node on screen: x, y in samples, z NDC depth, w 1 when in front of the camera.
struct ScreenNode {
    p: vec4<f32>,
    rgb: vec3<f32>,
    // Width in samples.
    width: f32,
    // Opacity (scales coverage).
    alpha: f32,
}

fn to_screen(n: SplatNode) -> ScreenNode {
    var out: ScreenNode;
    let c = frame.view_proj * vec4<f32>(n.pos, 1.0);
    let ok = c.w > 1e-6;
    let w = max(c.w, 1e-6);
    let ndc = c.xyz / w;
    out.p = vec4<f32>(
        (ndc.x * 0.5 + 0.5) * frame.viewport.x,
        (0.5 - ndc.y * 0.5) * frame.viewport.y,
        ndc.z,
        select(0.0, 1.0, ok),
    );
    out.rgb = n.rgb;
    out.width = n.width * frame.raster.x / w;
    out.alpha = n.alpha;
    return out;
}

// Weight of a hair at NDC depth z: the nearer, the more its colour counts.
fn depth_weight(z: f32) -> f32 {
    let d = clamp(1.0 - z, 1.0 / 64.0, 1.0);
    return d * d * d;
}

// The five words hair of coverage a at depth z adds to sample (x, y), in fixed point;
// `rest.y` is 0 when it adds nothing (off screen, no coverage, behind the opaque scene).
struct Words {
    rgbw: vec4<u32>,
    // x optical depth, y 1 when the sample gets the words.
    rest: vec2<u32>,
}

fn sample_words(x: i32, y: i32, a: f32, z: f32, rgb: vec3<f32>) -> Words {
    var out: Words;
    let size = vec2<i32>(frame.viewport.xy);
    if x < 0 || y < 0 || x >= size.x || y >= size.y || a <= 0.0 {
        return out;
    }
    if z > textureLoad(scene_depth, vec2<i32>(x, y), 0).x + DEPTH_BIAS {
        return out;
    }
    let aw = a * depth_weight(z);
    let c = rgb * aw * COLOR_SCALE + 0.5;
    out.rgbw = vec4<u32>(u32(c.r), u32(c.g), u32(c.b), u32(aw * COLOR_SCALE + 0.5));
    out.rest = vec2<u32>(u32(-log(1.0 - min(a, MAX_COVERAGE)) * DEPTH_SCALE + 0.5), 1u);
    return out;
}

// Add to the accumulation (tile = false) or to the tile's workgroup copy, whose top-left
// sample is clip.xy (tile = true).
fn add_sample(x: i32, y: i32, a: f32, z: f32, rgb: vec3<f32>, clip: vec4<i32>, tile: bool) {
    let w = sample_words(x, y, a, z, rgb);
    if w.rest.y == 0u {
        return;
    }
    if tile {
        let i = 5u * u32((y - clip.y) * TILE + (x - clip.x));
        atomicAdd(&tile_accum[i], w.rgbw.x);
        atomicAdd(&tile_accum[i + 1u], w.rgbw.y);
        atomicAdd(&tile_accum[i + 2u], w.rgbw.z);
        atomicAdd(&tile_accum[i + 3u], w.rgbw.w);
        atomicAdd(&tile_accum[i + 4u], w.rest.x);
        return;
    }
    let i = 5u * (u32(y) * u32(frame.viewport.x) + u32(x));
    atomicAdd(&accum[i], w.rgbw.x);
    atomicAdd(&accum[i + 1u], w.rgbw.y);
    atomicAdd(&accum[i + 2u], w.rgbw.z);
    atomicAdd(&accum[i + 3u], w.rgbw.w);
    atomicAdd(&accum[i + 4u], w.rest.x);
}

// The segment from a to b in (major, minor) sample coordinates, its major axis the one it
// runs further along: pa its start and pb its end along that axis.
struct Run {
    pa: vec2<f32>,
    pb: vec2<f32>,
    // x: b comes first along the major axis (a and b swapped); y: the major axis is the
    // screen's x; z: it draws something (no node behind the camera, a run past 1e-6).
    flags: vec3<bool>,
}

fn segment_run(a: ScreenNode, b: ScreenNode) -> Run {
    var r: Run;
    if a.p.w < 0.5 || b.p.w < 0.5 {
        return r;
    }
    let d = b.p.xy - a.p.xy;
    let x_major = abs(d.x) >= abs(d.y);
    r.pa = select(a.p.yx, a.p.xy, x_major);
    r.pb = select(b.p.yx, b.p.xy, x_major);
    let swap = r.pa.x > r.pb.x;
    if swap {
        let q = r.pa;
        r.pa = r.pb;
        r.pb = q;
    }
    r.flags = vec3<bool>(swap, x_major, r.pb.x - r.pa.x > 1e-6);
    return r;
}

// The samples (x0, y0, x1, y1, inclusive) the segment may add to, on screen; x0 > x1 for
// none. Every column it crosses, and in the minor direction from the lowest start of a
// column's rows (centre line minus half-width, linear along the run, so lowest at an end)
// to the highest row `splat_segment` may reach (at most MAX_ACROSS rows past a start, and
// not past the band's top), with one sample of slack for rounding.
fn segment_rect(a_in: ScreenNode, b_in: ScreenNode) -> vec4<i32> {
    let r = segment_run(a_in, b_in);
    if !r.flags.z {
        return vec4<i32>(1, 1, 0, 0);
    }
    var wa = a_in.width;
    var wb = b_in.width;
    if r.flags.x {
        wa = b_in.width;
        wb = a_in.width;
    }
    let slope = (r.pb.y - r.pa.y) / (r.pb.x - r.pa.x);
    let sec = sqrt(1.0 + slope * slope);
    let start = vec2<f32>(r.pa.y - 0.5 * wa * sec, r.pb.y - 0.5 * wb * sec);
    let top = max(r.pa.y + 0.5 * wa * sec, r.pb.y + 0.5 * wb * sec);
    let minor_lo = min(start.x, start.y) - 1.0;
    let minor_hi = min(max(start.x, start.y) + f32(MAX_ACROSS), top) + 1.0;
    let lo = vec2<i32>(floor(vec2<f32>(r.pa.x, minor_lo)));
    let hi = vec2<i32>(floor(vec2<f32>(r.pb.x, minor_hi)));
    let size = vec2<i32>(frame.viewport.xy) - vec2<i32>(1);
    let x_lo = select(lo.yx, lo, r.flags.y);
    let x_hi = select(hi.yx, hi, r.flags.y);
    return vec4<i32>(max(x_lo, vec2<i32>(0)), min(x_hi, size));
}

// One segment from a to b: step along its major axis one sample column at a time, adding
// only to the samples inside clip (x0, y0, x1, y1, inclusive); into the tile at clip.xy
// when tile is true.
fn splat_segment(a_in: ScreenNode, b_in: ScreenNode, clip: vec4<i32>, tile: bool) {
    let r = segment_run(a_in, b_in);
    if !r.flags.z {
        return;
    }
    var a = a_in;
    var b = b_in;
    if r.flags.x {
        a = b_in;
        b = a_in;
    }
    let x_major = r.flags.y;
    let pa = r.pa;
    let pb = r.pb;
    let run = pb.x - pa.x;
    let slope = (pb.y - pa.y) / run;
    let sec = sqrt(1.0 + slope * slope);
    // The clip rectangle along (major, minor).
    let c_lo = select(clip.yx, clip.xy, x_major);
    let c_hi = select(clip.wz, clip.zw, x_major);
    let first = max(i32(floor(pa.x)), c_lo.x);
    let last = min(i32(floor(pb.x)), c_hi.x);
    for (var col = first; col <= last; col++) {
        let lo = max(pa.x, f32(col));
        let hi = min(pb.x, f32(col + 1));
        let fx = hi - lo;
        if fx <= 0.0 {
            continue;
        }
        let t = (0.5 * (lo + hi) - pa.x) / run;
        let yc = mix(pa.y, pb.y, t);
        let half_h = 0.5 * mix(a.width, b.width, t) * sec;
        let z = mix(a.p.z, b.p.z, t);
        let rgb = mix(a.rgb, b.rgb, t);
        let alpha = mix(a.alpha, b.alpha, t);
        let y0 = yc - half_h;
        let y1 = yc + half_h;
        let r0 = i32(floor(y0));
        let r1 = min(min(i32(floor(y1)), r0 + MAX_ACROSS - 1), c_hi.y);
        for (var row = max(r0, c_lo.y); row <= r1; row++) {
            let cover = fx * (min(y1, f32(row + 1)) - max(y0, f32(row))) * alpha;
            if x_major {
                add_sample(col, row, cover, z, rgb, clip, tile);
            } else {
                add_sample(row, col, cover, z, rgb, clip, tile);
            }
        }
    }
}

// The whole screen, as a clip rectangle.
fn screen_rect() -> vec4<i32> {
    return vec4<i32>(0, 0, i32(frame.viewport.x) - 1, i32(frame.viewport.y) - 1);
}

@compute @workgroup_size(64)
fn splat(@builtin(global_invocation_id) id: vec3<u32>) {
    // Drawn at this level of detail (common/strand_drawn.wgsl).
    let si = drawn_strand(id);
    if si < 0 {
        return;
    }
    let s = strands[si];
    let step = splat_step(s);
    let last = splat_last(s);
    var a = to_screen(splat_node(u32(si), s, 0u));
    var n = 0u;
    loop {
        if n >= last {
            break;
        }
        n = min(n + step, last);
        let b = to_screen(splat_node(u32(si), s, n));
        splat_segment(a, b, screen_rect(), false);
        a = b;
    }
}

// Tiles across and down the target.
fn tile_grid() -> vec2<u32> {
    return (vec2<u32>(frame.viewport.xy) + vec2<u32>(u32(TILE) - 1u)) / u32(TILE);
}

// The drawn segment invocation `id` bins (x, y its strand as `drawn_strand`, z its index
// along the strand at the level of detail's step): its strand * 256 + index and its two
// nodes on screen; NONE when there is no such segment.
struct Seg {
    id: u32,
    a: ScreenNode,
    b: ScreenNode,
}

fn binned_segment(si: i32, k: u32) -> Seg {
    var out: Seg;
    out.id = NONE;
    if si < 0 {
        return out;
    }
    let s = strands[si];
    let step = splat_step(s);
    let last = splat_last(s);
    let n0 = k * step;
    if n0 >= last {
        return out;
    }
    out.id = u32(si) * 256u + k;
    out.a = to_screen(splat_placed(u32(si), s, n0));
    out.b = to_screen(splat_placed(u32(si), s, min(n0 + step, last)));
    return out;
}

// Segment reference r (strand * 256 + index) with both nodes shaded, on screen.
fn shaded_segment(r: u32) -> Seg {
    var out: Seg;
    out.id = r;
    let si = r / 256u;
    let s = strands[si];
    let step = splat_step(s);
    let n0 = (r % 256u) * step;
    out.a = to_screen(splat_node(si, s, n0));
    out.b = to_screen(splat_node(si, s, min(n0 + step, splat_last(s))));
    return out;
}

// The segment invocation `id` bins (as `binned_segment`) and the tiles (x0, y0, x1, y1,
// inclusive) its sample rectangle reaches: none (x0 > x1) without a segment or a rectangle.
struct Binned {
    seg: Seg,
    tiles: vec4<i32>,
}

fn binned_tiles(id: vec3<u32>) -> Binned {
    var out: Binned;
    out.tiles = vec4<i32>(1, 1, 0, 0);
    out.seg = binned_segment(drawn_strand(id), id.z);
    if out.seg.id == NONE {
        return out;
    }
    let rect = segment_rect(out.seg.a, out.seg.b);
    if rect.x <= rect.z && rect.y <= rect.w {
        out.tiles = rect / TILE;
    }
    return out;
}

@compute @workgroup_size(64)
fn bin_count(@builtin(global_invocation_id) id: vec3<u32>) {
    let t = binned_tiles(id).tiles;
    let across = i32(tile_grid().x);
    for (var ty = t.y; ty <= t.w; ty++) {
        for (var tx = t.x; tx <= t.z; tx++) {
            atomicAdd(&bins[u32(ty * across + tx)], 1u);
        }
    }
}

// Partial sums of the scan, one per invocation.
var<workgroup> scan_sums: array<u32, 256>;

@compute @workgroup_size(256)
fn bin_scan(@builtin(local_invocation_index) li: u32) {
    let g = tile_grid();
    let tiles = g.x * g.y;
    let per = (tiles + 255u) / 256u;
    let lo = min(li * per, tiles);
    let hi = min(lo + per, tiles);
    var sum = 0u;
    for (var t = lo; t < hi; t++) {
        sum += atomicLoad(&bins[t]);
    }
    scan_sums[li] = sum;
    workgroupBarrier();
    // Inclusive scan of the 256 partial sums (Hillis and Steele).
    for (var d = 1u; d < 256u; d *= 2u) {
        let v = select(0u, scan_sums[max(li, d) - d], li >= d);
        workgroupBarrier();
        scan_sums[li] += v;
        workgroupBarrier();
    }
    var at = select(0u, scan_sums[max(li, 1u) - 1u], li > 0u);
    let cap = arrayLength(&bin_refs);
    for (var t = lo; t < hi; t++) {
        let c = atomicLoad(&bins[t]);
        // Sums past 2^32 refs cannot fit any list: compare without overflowing.
        let fits = at <= cap && c <= cap - at;
        atomicStore(&bins[tiles + t], select(NONE, at, fits));
        atomicStore(&bins[2u * tiles + t], 0u);
        at += c;
    }
}

@compute @workgroup_size(64)
fn bin_scatter(@builtin(global_invocation_id) id: vec3<u32>) {
    let b = binned_tiles(id);
    let seg = b.seg;
    let t = b.tiles;
    let g = tile_grid();
    let tiles = g.x * g.y;
    for (var ty = t.y; ty <= t.w; ty++) {
        for (var tx = t.x; tx <= t.z; tx++) {
            let tile = u32(ty) * g.x + u32(tx);
            let at = atomicLoad(&bins[tiles + tile]);
            if at == NONE {
                // The tile's list does not fit: draw the segment's part in it directly.
                let o = vec2<i32>(tx, ty) * TILE;
                let sh = shaded_segment(seg.id);
                splat_segment(sh.a, sh.b, vec4<i32>(o, o + vec2<i32>(TILE - 1)), false);
            } else {
                let i = atomicAdd(&bins[2u * tiles + tile], 1u);
                bin_refs[at + i] = seg.id;
            }
        }
    }
}

@compute @workgroup_size(64)
fn bin_raster(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
) {
    let g = tile_grid();
    let tiles = g.x * g.y;
    let tile = wg.y * g.x + wg.x;
    for (var i = li; i < TILE_WORDS; i += 64u) {
        atomicStore(&tile_accum[i], 0u);
    }
    workgroupBarrier();
    let count = atomicLoad(&bins[tile]);
    let at = atomicLoad(&bins[tiles + tile]);
    let o = vec2<i32>(wg.xy) * TILE;
    let clip = vec4<i32>(o, min(o + vec2<i32>(TILE - 1), vec2<i32>(frame.viewport.xy) - vec2<i32>(1)));
    if at != NONE {
        for (var i = li; i < count; i += 64u) {
            let seg = shaded_segment(bin_refs[at + i]);
            splat_segment(seg.a, seg.b, clip, true);
        }
    }
    workgroupBarrier();
    for (var i = li; i < TILE_WORDS; i += 64u) {
        let v = atomicLoad(&tile_accum[i]);
        let j = i / 5u;
        let x = clip.x + i32(j % u32(TILE));
        let y = clip.y + i32(j / u32(TILE));
        if v != 0u && x <= clip.z && y <= clip.w {
            atomicAdd(&accum[5u * (u32(y) * u32(frame.viewport.x) + u32(x)) + i % 5u], v);
        }
    }
    if li == 0u {
        atomicStore(&bins[tile], 0u);
    }
}
