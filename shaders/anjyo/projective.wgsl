// Anjyo's projective dynamics, one substep per dispatch, one invocation per simulated
// strand. The same steps as the f64 reference in src/systems/anjyo/projective.rs (read its header for
// the equations and our additions): forces with the pseudo-force field, the theta plane from
// y and F near the poles, the recurrences (4)' and (5)' with damping and the angular clamp,
// the fluctuation kick, the joint-angle clamp, the hard collision; root to tip.
// `init` turns the groomed nodes into angles at rest (theta^0 = theta^-1). Each segment adds
// the External Force Field (shaders/forces/eff.wgsl, concatenated before this file) at its
// node, times the substep's gust scale.
//
// Memory layout, shaped for coalescing (neighbouring invocations = neighbouring strands):
// - the angle state is segment-major: segment i (1..=k) of strand column c lives at
//   state[(i - 1) * state_stride + c], so at each step of the root-to-tip loop the invocations
//   of a workgroup read and write consecutive vec4s;
// - the per-strand records are three columns (ids, root, extra; `load_strand`), so their one
//   read per substep is consecutive too;
// - the node positions `verts` keep the strand-major layout the draw passes, the groom and
//   the other systems share: neighbouring invocations touch addresses (segments + 1) * 16
//   bytes apart, one uncoalesced read and write per segment. Changing it would need every
//   reader of the strand buffers to change with it.

const TAU: f32 = 6.28318530717959;
// Passed by the Rust side (`projective::POLE_SIN`, `projective::MAX_TURN`, `gpu::WORKGROUP`).
override POLE_SIN: f32;
override MAX_TURN: f32;
override WORKGROUP: u32;
// Specialisations, passed per job by the Rust side (`projective_gpu::Variant`). Software
// adapters such as lavapipe run every branch of an `if` under a lane mask, so code that a
// uniform flag turns off still costs its full price unless the pipeline compiles it out.
// SDF_HEAD (common/sdf.wgsl) false: the head is the ellipsoid, the SDF path compiled out.
// false: the job has no External Force Field (eff_field would be zero), its lookup compiled out.
override EFF_FIELD: bool = true;

// Twin of GpuDynParams (tests/it/gpu_twins.rs checks it) in src/systems/anjyo/gpu_data.rs.
struct DynParams {
    strand_count: u32,
    row_stride: u32,
    collision: u32,
    pseudo: u32,
    density: f32,
    damping: f32,
    seed: u32,
    fluct_amp: f32,
    pseudo_alpha: f32,
    eps_pore: f32,
    eps_tip: f32,
    near: f32,
    sigma_root: f32,
    sigma_tip: f32,
    sigma_start: f32,
    inertia_root: f32,
    inertia_tip: f32,
    sigma_end: f32,
    state_stride: u32,
    _p2: f32,
}

// Twin of GpuStep (tests/it/gpu_twins.rs checks it) in src/systems/anjyo/gpu_data.rs (one
// 256-byte slot per substep).
struct Step {
    // x substep length h
    h: vec4<f32>,
    accel: mat4x4<f32>,
    // x: 1 when this substep kicks, y: kick bucket, z: 1 for the first step from rest
    kick: vec4<u32>,
    // the world's samples (world_steps): x at the substep's start (gravity + wind, the gust
    // scale), y at its end (the head's pose)
    samples: vec4<u32>,
}

// Twin of GpuDynStrand (tests/it/gpu_twins.rs checks it) in src/systems/anjyo/gpu_data.rs (stored as three columns).
struct DynStrand {
    // strand, first vertex, state column, simulated segments
    ids: vec4<u32>,
    // xyz pore in head coordinates, w segment length
    root: vec4<f32>,
    // x scalp inertia factor
    extra: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: DynParams;
@group(0) @binding(1) var<uniform> substep: Step;
// Three columns of state_stride words: ids, then root (f32 bits), then extra (f32 bits).
@group(0) @binding(2) var<storage, read> dyn_strands: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read_write> state: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> verts: array<vec4<f32>>;
// The EFF and the head's field: the world at group 3 (common/world.wgsl).

fn hull() -> HeadHull {
    return world_hull();
}

fn direction(theta: f32, phi: f32) -> vec3<f32> {
    return vec3<f32>(sin(theta) * cos(phi), cos(theta), sin(theta) * sin(phi));
}

fn unwrap_near(a: f32, r: f32) -> f32 {
    return a + TAU * round((r - a) / TAU);
}

// Continuing representation of unit dir (see projective::angles_near).
fn angles_near(dir: vec3<f32>, theta_ref: f32, phi_ref: f32) -> vec2<f32> {
    let tc = acos(clamp(dir.y, -1.0, 1.0));
    let horizontal = sqrt(dir.x * dir.x + dir.z * dir.z);
    if horizontal <= 1e-6 {
        let a = unwrap_near(tc, theta_ref);
        let b = unwrap_near(-tc, theta_ref);
        return vec2<f32>(select(b, a, abs(a - theta_ref) <= abs(b - theta_ref)), phi_ref);
    }
    let pc = atan2(dir.z, dir.x);
    let pa = unwrap_near(pc, phi_ref);
    let pb = unwrap_near(pc + PI, phi_ref);
    if abs(pa - phi_ref) <= abs(pb - phi_ref) {
        return vec2<f32>(unwrap_near(tc, theta_ref), pa);
    }
    return vec2<f32>(unwrap_near(-tc, theta_ref), pb);
}

fn kick_unit(strand: u32, segment: u32, bucket: u32, which: u32) -> f32 {
    let h = pcg_hash((bucket * 2u + which) ^ pcg_hash(segment ^ pcg_hash(strand ^ pcg_hash(params.seed))));
    return f32(h >> 8u) / 16777216.0 * 2.0 - 1.0;
}

fn along(s: DynStrand, i: u32) -> f32 {
    let k = s.ids.w;
    if k > 1u {
        return (f32(i) - 1.0) / (f32(k) - 1.0);
    }
    return 1.0;
}

fn c_of(s: DynStrand, i: u32) -> f32 {
    let k = f32(s.ids.w);
    let d = s.root.w;
    let prof = params.inertia_root + (params.inertia_tip - params.inertia_root) * along(s, i);
    return 3.0 * f32(i) / (params.density * k * k * k * d * d) * prof * s.extra.x;
}

fn sigma_at(t: f32) -> f32 {
    if t <= params.sigma_start {
        return params.sigma_root;
    }
    let u = clamp((t - params.sigma_start) / max(params.sigma_end - params.sigma_start, 1e-9), 0.0, 1.0);
    return params.sigma_root + (params.sigma_tip - params.sigma_root) * u;
}

fn xform_point(m: mat4x4<f32>, p: vec3<f32>) -> vec3<f32> {
    return (m * vec4<f32>(p, 1.0)).xyz;
}

fn xform_vector(m: mat4x4<f32>, v: vec3<f32>) -> vec3<f32> {
    return (m * vec4<f32>(v, 0.0)).xyz;
}

fn load_strand(si: u32) -> DynStrand {
    let n = params.state_stride;
    return DynStrand(
        dyn_strands[si],
        bitcast<vec4<f32>>(dyn_strands[n + si]),
        bitcast<vec4<f32>>(dyn_strands[2u * n + si]),
    );
}

// Segment i (1..=k) of the strand in state column c.
fn state_at(c: u32, i: u32) -> u32 {
    return (i - 1u) * params.state_stride + c;
}

fn strand_index(id: vec3<u32>) -> u32 {
    return id.x + id.y * params.row_stride;
}

@compute @workgroup_size(WORKGROUP)
fn init(@builtin(global_invocation_id) id: vec3<u32>) {
    let si = strand_index(id);
    if si >= params.strand_count {
        return;
    }
    let s = load_strand(si);
    let base = s.ids.y;
    let off = s.ids.z;
    for (var i = 1u; i <= s.ids.w; i++) {
        let dir = normalize(verts[base + i].xyz - verts[base + i - 1u].xyz);
        let a = angles_near(dir, 0.5 * PI, 0.0);
        state[state_at(off, i)] = vec4<f32>(a, a);
    }
}

@compute @workgroup_size(WORKGROUP)
fn advance(@builtin(global_invocation_id) id: vec3<u32>) {
    let si = strand_index(id);
    if si >= params.strand_count {
        return;
    }
    let s = load_strand(si);
    let k = s.ids.w;
    let base = s.ids.y;
    let off = s.ids.z;
    let d = s.root.w;
    let h = substep.h.x;
    let w0 = world_steps[substep.samples.x];
    let w1 = world_steps[substep.samples.y];
    let hl = hull();
    let root = xform_point(w1.head, s.root.xyz);
    let a_root = xform_point(substep.accel, s.root.xyz);
    let f_seg = w0.force.xyz - params.density * d * a_root;
    let g = 0.5 * params.damping * h;
    let keep = max((1.0 - g) / (1.0 + g), 0.0);
    // Half the acceleration in the very first step from rest (kick.z), as in the reference.
    let push = select(1.0, 0.5, substep.kick.z != 0u) / (1.0 + g);
    verts[base] = vec4<f32>(root, 1.0);
    var prev_p = root;
    var prev_dir = normalize(xform_vector(w1.head, head_gradient(hl, s.root.xyz)));
    for (var i = 1u; i <= k; i++) {
        let a = state[state_at(off, i)];
        var th = a.x;
        var ph = a.y;
        var thp = a.z;
        var php = a.w;
        let p_old = verts[base + i].xyz;
        var force = f_seg;
        if EFF_FIELD && w0.force.w != 0.0 {
            // Trilinear (projective::EFF_SAMPLING), at the gust scale of the substep's start.
            force += eff_field(p_old, 1u) * w0.force.w;
        }
        var marked = 1.0;
        if params.pseudo != 0u {
            let local = xform_point(w1.head_inv, p_old);
            let g = head_gradient(hl, local);
            let dist = head_eval(hl, local) / max(length(g), 1e-30);
            let dd = xform_vector(w1.head, g);
            if dist < params.near && dot(dd, force) < params.pseudo_alpha * length(dd) * length(force) {
                force *= params.eps_pore + (params.eps_tip - params.eps_pore) * along(s, i);
                marked = 2.0;
            }
        }
        // The trigonometry of the plane is taken from the vectors where the pole switch
        // picks it (sin and cos of an atan2 are its arguments over their length), so each
        // angle's sine and cosine is computed once.
        var sth = sin(th);
        var cth = cos(th);
        var sph = sin(ph);
        var cph = cos(ph);
        if abs(sth) < POLE_SIN {
            let fh = vec3<f32>(force.x, 0.0, force.z);
            if length(fh) > 1e-6 * length(force) && length(fh) > 0.0 {
                let pf = atan2(fh.z, fh.x);
                let e = fh / length(fh);
                let dn = vec3<f32>(sth * cph, cth, sth * sph);
                let dp = direction(thp, php);
                let yn = dot(dn, e);
                let tn = atan2(yn, dn.y);
                let tp = atan2(dot(dp, e), dp.y);
                th = tn;
                // tn + wrap(tp - tn) into [-pi, pi)
                let w = tp - tn + PI;
                thp = tn + (w - TAU * floor(w / TAU)) - PI;
                ph = pf;
                php = pf;
                let rn = length(vec2<f32>(yn, dn.y));
                sth = yn / rn;
                cth = dn.y / rn;
                sph = e.z;
                cph = e.x;
            }
        }
        let v_th = vec3<f32>(cth * cph, -sth, cth * sph);
        let v_ph = vec3<f32>(-sph, 0.0, cph);
        let cu = c_of(s, i) * 0.5 * d;
        var dth = keep * (th - thp) + push * h * h * cu * dot(force, v_th);
        var dph = keep * (ph - php) + push * h * h * cu * sth * dot(force, v_ph);
        if abs(dth) > MAX_TURN {
            dth = sign(dth) * MAX_TURN;
        }
        if abs(sth * dph) > MAX_TURN {
            dph = sign(dph) * MAX_TURN / abs(sth);
        }
        dph = clamp(dph, -PI, PI);
        var thn = th + dth;
        var phn = ph + dph;
        if substep.kick.x != 0u {
            let amp = params.fluct_amp * f32(i) / f32(k);
            thn += amp * kick_unit(s.ids.x, i, substep.kick.y, 0u);
            phn += amp * kick_unit(s.ids.x, i, substep.kick.y, 1u);
        }
        var dir = direction(thn, phn);
        var moved = false;
        if i >= 2u {
            let sigma = sigma_at(f32(i - 1u) / f32(k));
            // The bend acos(dot) exceeds sigma where the dot is below cos(sigma); the
            // rotation by sigma about the axis is rotate_vec's Rodrigues formula with the
            // same cosine (one cos and one sin per segment, no acos).
            let cs = cos(sigma);
            if clamp(dot(prev_dir, dir), -1.0, 1.0) < cs {
                var axis = cross(prev_dir, dir);
                if length(axis) > 1e-6 {
                    axis = normalize(axis);
                } else {
                    axis = any_orthonormal(prev_dir);
                }
                let r = prev_dir * cs + cross(axis, prev_dir) * sin(sigma) + axis * dot(axis, prev_dir) * (1.0 - cs);
                dir = normalize(r);
                moved = true;
            }
        }
        var pn = prev_p + dir * d;
        if params.collision != 0u {
            let local = xform_point(w1.head_inv, pn);
            if head_eval(hl, local) < 0.0 {
                let lp = xform_point(w1.head_inv, prev_p);
                let la = normalize(xform_vector(w1.head_inv, prev_dir));
                var q: vec3<f32>;
                if hl.sdf {
                    q = head_push_out(hl, lp, la, local, d);
                } else {
                    q = hull_push_out(hl.e, lp, la, local, d);
                }
                dir = normalize(xform_point(w1.head, q) - prev_p);
                pn = prev_p + dir * d;
                moved = true;
            }
        }
        // Corrections are inelastic: the corrected segment loses its angular velocity.
        var tho = th;
        var pho = ph;
        if moved {
            let c = angles_near(dir, thn, phn);
            thn = c.x;
            phn = c.y;
            tho = c.x;
            pho = c.y;
        }
        var out = vec4<f32>(thn, phn, tho, pho);
        if abs(out.x) > TAU {
            let shift = TAU * round(out.x / TAU);
            out.x -= shift;
            out.z -= shift;
        }
        if abs(out.y) > TAU {
            let shift = TAU * round(out.y / TAU);
            out.y -= shift;
            out.w -= shift;
        }
        state[state_at(off, i)] = out;
        // w = 2 marks a segment the pseudo-force acted on (the viewer can show them).
        verts[base + i] = vec4<f32>(pn, marked);
        prev_p = pn;
        prev_dir = dir;
    }
}
