// The wisps' surface polygonised on the GPU (`block::MeshOn::Gpu`): the same surface nets as
// the f64 mesher (`src/systems/wisps/mesh.rs`, `polygonise`, its reference), over the same
// bricks of 8³ cells, from the segments `wisps/curves.wgsl` wrote this frame, so moving wisps
// are meshed without their nodes leaving the GPU. Six kernels, recorded by
// `src/systems/wisps/mesh_gpu.rs`:
//   `bricks`  one invocation per brick of the grid: the segments whose influence box (grown
//             by three cells) reaches it, in order (wisp-major); a brick within a hit capsule
//             (grown by its half-diagonal and three cells) takes a slot and its list;
//   `slots`   the slot count into the dispatch arguments of the next three;
//   `sample`  one workgroup per slot: the density at its 512 points, each segment as
//             GRID_PIECES chords (the grid's values seed the crossings and the vertices only);
//   `cells`   each cell the surface crosses: a vertex at the mean of its edges' crossings,
//             moved onto the surface by Newton steps on the exact field (the scene's distance
//             method), with the normal, the densest wisp's outline scale and the shell
//             curvature κ there; vertices are appended by an atomic counter;
//   `quads`   a quad for each grid edge with one end inside, over the four cells round it,
//             wound from the inside end to the outside one, appended by an atomic counter;
//   `finish`  the index count into the indirect draw's arguments.
// Past a capacity nothing is written and the counters say by how much (`mesh_gpu::Counters`).

struct Mesher {
    // xyz the grid's first point, w the cell
    origin: vec4<f32>,
    // xyz points a side, w segments
    dims: vec4<u32>,
    // xyz bricks a side, w list capacity per brick
    bricks: vec4<u32>,
    // x slot capacity, y vertex capacity, z index capacity, w bricks in the grid
    caps: vec4<u32>,
    // offsets into `index`: x slot -> brick, y list counts, z lists, w cell -> vertex
    offs: vec4<u32>,
    // x threshold, y outline taper, z a brick's half-diagonal plus three cells' diagonal
    shape: vec4<f32>,
    // x distance method (0 Newton, 1 chords), y chords, z Newton steps, w workgroups a row
    // of `bricks`
    method: vec4<u32>,
}

@group(0) @binding(0) var<uniform> grid: Mesher;
@group(0) @binding(1) var<storage, read> segments: array<Segment>;
@group(0) @binding(2) var<storage, read> capsules: array<Capsule>;
// Per segment: outline scale, u at its start and end (`toon::segment_outlines`).
@group(0) @binding(3) var<storage, read> outlines: array<vec4<f32>>;
// Per brick its slot (NONE: not reached); then per slot its brick, its list's length, its
// list; then per slot and cell the cell's vertex (NONE: none).
@group(0) @binding(4) var<storage, read_write> index: array<u32>;
// Per slot and point: the grid density.
@group(0) @binding(5) var<storage, read_write> values: array<f32>;
// Positions (xyz, outline scale) then, from the vertex capacity on, normals (xyz, κ).
@group(0) @binding(6) var<storage, read_write> vertices: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> indices: array<u32>;
// `mesh_gpu::Counters`: 0 slots, 1 vertices, 2 indices, 3 bricks whose list was cut,
// 4 bricks past the slots, 5 vertices past the capacity, 6 quads past it, 7 the longest
// list; 8-12 the indirect draw, 13-15 the indirect dispatch over the slots.
@group(0) @binding(8) var<storage, read_write> counters: array<atomic<u32>, 16>;

const NONE: u32 = 0xffffffffu;
const BRICK: u32 = 8u;
const BRICK3: u32 = 512u;
const GRID_PIECES: u32 = 4u;
// Slots a row of the indirect dispatch (a dispatch is at most 65,535 workgroups a side).
const SLOT_ROW: u32 = 32768u;

fn outline_scale(o: vec4<f32>, t: f32) -> f32 {
    let u = o.y * (1.0 - t) + o.z * t;
    return o.x * (1.0 - grid.shape.y * u);
}

fn brick_linear(b: vec3<u32>) -> u32 {
    return (b.z * grid.bricks.y + b.y) * grid.bricks.x + b.x;
}

fn brick_coords(b: u32) -> vec3<u32> {
    return vec3<u32>(b % grid.bricks.x, (b / grid.bricks.x) % grid.bricks.y, b / (grid.bricks.x * grid.bricks.y));
}

fn local_coords(l: u32) -> vec3<u32> {
    return vec3<u32>(l % BRICK, (l / BRICK) % BRICK, l / (BRICK * BRICK));
}

fn local_of(i: vec3<u32>) -> u32 {
    let l = i % BRICK;
    return (l.z * BRICK + l.y) * BRICK + l.x;
}

fn point(i: vec3<u32>) -> vec3<f32> {
    return grid.origin.xyz + vec3<f32>(i) * grid.origin.w;
}

// The slot of the reached brick holding grid point `i` (NONE: off the grid or not reached).
fn slot_of(i: vec3<i32>) -> u32 {
    if (any(i < vec3<i32>(0)) || any(vec3<u32>(i) >= grid.dims.xyz)) {
        return NONE;
    }
    return index[brick_linear(vec3<u32>(i) / BRICK)];
}

// The grid density at `i` (0 off the reached bricks, as the f64 mesher's `value`).
fn value(i: vec3<i32>) -> f32 {
    let s = slot_of(i);
    if (s == NONE) {
        return 0.0;
    }
    return values[s * BRICK3 + local_of(vec3<u32>(i))];
}

// The vertex of the cell whose lowest corner is `c` (NONE: none).
fn vertex_of(c: vec3<i32>) -> u32 {
    let s = slot_of(c);
    if (s == NONE) {
        return NONE;
    }
    return index[grid.offs.w + s * BRICK3 + local_of(vec3<u32>(c))];
}

fn slot_count() -> u32 {
    return min(atomicLoad(&counters[0]), grid.caps.x);
}

// Whether segment j's influence box grown by three cells reaches brick `b` (the f64
// mesher's brick ranges).
fn reaches(j: u32, b: vec3<f32>) -> bool {
    let s = segments[j];
    let r = vec3<f32>(max(s.c0.w, s.c1.w));
    let cell = grid.origin.w;
    let side = cell * f32(BRICK);
    let lo = max(floor((s.lo.xyz - r - grid.origin.xyz - 3.0 * cell) / side), vec3<f32>(0.0));
    let hi = floor((s.hi.xyz + r - grid.origin.xyz + 3.0 * cell) / side);
    return all(b >= lo) && all(b <= hi);
}

@compute @workgroup_size(64)
fn bricks(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let b = (wg.y * grid.method.w + wg.x) * 64u + li;
    if (b >= grid.caps.w) {
        return;
    }
    index[b] = NONE;
    let bc = brick_coords(b);
    let bf = vec3<f32>(bc);
    let centre = grid.origin.xyz + (bf + 0.5) * grid.origin.w * f32(BRICK);
    var n = 0u;
    var near = false;
    for (var j = 0u; j < grid.dims.w; j++) {
        if (!reaches(j, bf)) {
            continue;
        }
        n++;
        let c = capsules[j];
        if (c.b.w >= 0.0 && chord_distance(centre, c.a.xyz, c.b.xyz) <= c.b.w + grid.shape.z) {
            near = true;
        }
    }
    if (!near) {
        return;
    }
    let slot = atomicAdd(&counters[0], 1u);
    if (slot >= grid.caps.x) {
        atomicAdd(&counters[4], 1u);
        return;
    }
    index[b] = slot;
    index[grid.offs.x + slot] = b;
    let cap = grid.bricks.w;
    index[grid.offs.y + slot] = min(n, cap);
    atomicMax(&counters[7], n);
    if (n > cap) {
        atomicAdd(&counters[3], 1u);
    }
    var k = 0u;
    for (var j = 0u; j < grid.dims.w && k < cap; j++) {
        if (reaches(j, bf)) {
            index[grid.offs.z + slot * cap + k] = j;
            k++;
        }
    }
}

@compute @workgroup_size(1)
fn slots() {
    let n = slot_count();
    atomicStore(&counters[13], min(n, SLOT_ROW));
    atomicStore(&counters[14], (n + SLOT_ROW - 1u) / SLOT_ROW);
    atomicStore(&counters[15], 1u);
}

// Σ_wisps ρ at `v` over slot's list by GRID_PIECES chords (the f64 mesher's `grid_rho`).
fn grid_rho(slot: u32, v: vec3<f32>) -> f32 {
    let n = index[grid.offs.y + slot];
    let base = grid.offs.z + slot * grid.bricks.w;
    var sum = 0.0;
    var wisp = -1.0;
    var acc = wisp_max_new();
    for (var k = 0u; k < n; k++) {
        let j = index[base + k];
        let s = segments[j];
        if (s.hi.w != wisp) {
            wisp_fold(&acc);
            sum += acc.best;
            wisp = s.hi.w;
            acc = wisp_max_new();
        }
        let rm = max(s.c0.w, s.c1.w);
        if (length(max(max(s.lo.xyz - v, v - s.hi.xyz), vec3<f32>(0.0))) >= rm) {
            continue;
        }
        let c = closest_polyline(s, v, GRID_PIECES);
        let d = length(v - c.xyz);
        if (d >= rm) {
            continue;
        }
        let r = mix(s.c0.w, s.c1.w, c.w);
        let w = mix(s.c2.w, s.c3.w, c.w);
        wisp_push(&acc, j, c.w, w * fd(d / r), vec3<f32>(0.0), 1.0);
    }
    wisp_fold(&acc);
    return sum + acc.best;
}

@compute @workgroup_size(64)
fn sample(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let slot = wg.y * SLOT_ROW + wg.x;
    if (slot >= slot_count()) {
        return;
    }
    let base = brick_coords(index[grid.offs.x + slot]) * BRICK;
    for (var k = 0u; k < 8u; k++) {
        let l = li + 64u * k;
        let i = base + local_coords(l);
        var rho = 0.0;
        if (all(i < grid.dims.xyz)) {
            rho = grid_rho(slot, point(i));
        }
        values[slot * BRICK3 + l] = rho;
    }
}

struct Exact {
    rho: f32,
    grad: vec3<f32>,
    // The densest wisp's outline scale (1 where none is near).
    tag: f32,
}

// Σ_wisps ρ and its gradient at `v` over slot's list with the scene's distance method, and
// the densest wisp's outline scale (the f64 mesher's `sample`, `field::field`).
fn exact(slot: u32, v: vec3<f32>) -> Exact {
    let n = index[grid.offs.y + slot];
    let base = grid.offs.z + slot * grid.bricks.w;
    var out = Exact(0.0, vec3<f32>(0.0), 1.0);
    var densest = 0.0;
    var wisp = -1.0;
    var acc = wisp_max_new();
    for (var k = 0u; k < n; k++) {
        let j = index[base + k];
        let s = segments[j];
        if (s.hi.w != wisp) {
            wisp_fold(&acc);
            out.rho += acc.best;
            out.grad += acc.best_grad;
            if (acc.best > densest) {
                densest = acc.best;
                out.tag = acc.best_o;
            }
            wisp = s.hi.w;
            acc = wisp_max_new();
        }
        let c = segment_density(s, v, grid.method.x, grid.method.y);
        if (c.gap > 0.0) {
            continue;
        }
        wisp_push(&acc, j, c.t, c.rho, c.grad, outline_scale(outlines[j], c.t));
    }
    wisp_fold(&acc);
    out.rho += acc.best;
    out.grad += acc.best_grad;
    if (acc.best > densest) {
        out.tag = acc.best_o;
    }
    return out;
}

// The grid edges of a cell as (corner a, corner b), corners numbered x + 2y + 4z (the f64
// mesher's EDGES, in its order).
const EDGE_A = array<u32, 12>(0u, 2u, 4u, 6u, 0u, 1u, 4u, 5u, 0u, 1u, 2u, 3u);
const EDGE_B = array<u32, 12>(1u, 3u, 5u, 7u, 2u, 3u, 6u, 7u, 4u, 5u, 6u, 7u);

fn corner(k: u32) -> vec3<u32> {
    return vec3<u32>(k & 1u, (k >> 1u) & 1u, (k >> 2u) & 1u);
}

@compute @workgroup_size(64)
fn cells(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let slot = wg.y * SLOT_ROW + wg.x;
    if (slot >= slot_count()) {
        return;
    }
    let base = brick_coords(index[grid.offs.x + slot]) * BRICK;
    let thr = grid.shape.x;
    let cell = grid.origin.w;
    for (var k = 0u; k < 8u; k++) {
        let l = li + 64u * k;
        let c = base + local_coords(l);
        var vtx = NONE;
        if (all(c + 1u < grid.dims.xyz)) {
            var f: array<f32, 8>;
            for (var q = 0u; q < 8u; q++) {
                f[q] = value(vec3<i32>(c + corner(q))) - thr;
            }
            var ea = EDGE_A;
            var eb = EDGE_B;
            var sum = vec3<f32>(0.0);
            var m = 0.0;
            for (var e = 0u; e < 12u; e++) {
                let ra = f[ea[e]];
                let rb = f[eb[e]];
                if ((ra >= 0.0) == (rb >= 0.0)) {
                    continue;
                }
                let s = ra / (ra - rb);
                sum += mix(point(c + corner(ea[e])), point(c + corner(eb[e])), s);
                m += 1.0;
            }
            if (m > 0.0) {
                let p0 = sum / m;
                // Newton steps onto the surface, each at most a cell, never more than 1.5
                // cells from the start (the f64 mesher's `place`).
                var p = p0;
                var smp = exact(slot, p);
                for (var it = 0u; it < grid.method.z; it++) {
                    let gg = dot(smp.grad, smp.grad);
                    if (gg <= 0.0) {
                        break;
                    }
                    var step = smp.grad * ((smp.rho - thr) / gg);
                    if (length(step) > cell) {
                        step = normalize(step) * cell;
                    }
                    let q = p - step;
                    if (length(q - p0) > 1.5 * cell) {
                        break;
                    }
                    p = q;
                    smp = exact(slot, p);
                }
                let glen = length(smp.grad);
                var n = vec3<f32>(0.0, 1.0, 0.0);
                var kappa = 0.0;
                if (glen > 0.0) {
                    n = -smp.grad / glen;
                    let h = 0.5 * cell;
                    let f0 = smp.rho - thr;
                    let kk = 2.0 * (exact(slot, p + n * h).rho - thr - f0 + glen * h) / (h * h);
                    kappa = max(kk / glen, 0.0);
                }
                let v = atomicAdd(&counters[1], 1u);
                if (v < grid.caps.y) {
                    vertices[v] = vec4<f32>(p, smp.tag);
                    vertices[grid.caps.y + v] = vec4<f32>(n, kappa);
                    vtx = v;
                } else {
                    atomicAdd(&counters[5], 1u);
                }
            }
        }
        index[grid.offs.w + slot * BRICK3 + l] = vtx;
    }
}

@compute @workgroup_size(64)
fn quads(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let slot = wg.y * SLOT_ROW + wg.x;
    if (slot >= slot_count()) {
        return;
    }
    let base = brick_coords(index[grid.offs.x + slot]) * BRICK;
    let thr = grid.shape.x;
    for (var k = 0u; k < 8u; k++) {
        let l = li + 64u * k;
        let iu = base + local_coords(l);
        if (any(iu >= grid.dims.xyz) || values[slot * BRICK3 + l] < thr) {
            continue;
        }
        let i = vec3<i32>(iu);
        for (var axis = 0u; axis < 3u; axis++) {
            var ea = vec3<i32>(0);
            ea[axis] = 1;
            var eb = vec3<i32>(0);
            eb[(axis + 1u) % 3u] = 1;
            var ec = vec3<i32>(0);
            ec[(axis + 2u) % 3u] = 1;
            for (var side = 0u; side < 2u; side++) {
                let dir = select(-1, 1, side == 0u);
                let q = i + ea * dir;
                if (any(q < vec3<i32>(0)) || any(vec3<u32>(q) >= grid.dims.xyz)) {
                    continue;
                }
                if (value(q) >= thr) {
                    continue;
                }
                // The edge's lower end; the cells round it lie below it on the other axes.
                let m = select(q, i, dir > 0);
                if (dot(m, eb) == 0 || dot(m, ec) == 0) {
                    continue;
                }
                let v00 = vertex_of(m - eb - ec);
                let v10 = vertex_of(m - ec);
                let v11 = vertex_of(m);
                let v01 = vertex_of(m - eb);
                if (v00 == NONE || v10 == NONE || v11 == NONE || v01 == NONE) {
                    continue;
                }
                let at = atomicAdd(&counters[2], 6u);
                if (at + 6u > grid.caps.z) {
                    atomicAdd(&counters[6], 1u);
                    continue;
                }
                // (v00, v10, v11, v01) winds about +axis.
                if (dir > 0) {
                    indices[at] = v00;
                    indices[at + 1u] = v10;
                    indices[at + 2u] = v11;
                    indices[at + 3u] = v00;
                    indices[at + 4u] = v11;
                    indices[at + 5u] = v01;
                } else {
                    indices[at] = v00;
                    indices[at + 1u] = v11;
                    indices[at + 2u] = v10;
                    indices[at + 3u] = v00;
                    indices[at + 4u] = v01;
                    indices[at + 5u] = v11;
                }
            }
        }
    }
}

@compute @workgroup_size(1)
fn finish() {
    let cap = (grid.caps.z / 6u) * 6u;
    atomicStore(&counters[8], min(atomicLoad(&counters[2]), cap));
    atomicStore(&counters[9], 1u);
    atomicStore(&counters[10], 0u);
    atomicStore(&counters[11], 0u);
    atomicStore(&counters[12], 0u);
}
