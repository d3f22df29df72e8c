//! Anjyo's cantilever-beam bending (1992, section 2.1, eqs 1-3 and Fig. 2), and a converged
//! variant with true lever arms.
//!
//! **Paper mode.** The distributed load is lumped per segment at its midpoint (the paper's
//! "segmentally averaged concentrated loads"); the bending moment on segment `s_i` is taken
//! constant, from straight-beam lever arms: `M_i = d * |sum_{m>=i} (m - i + 1/2) g_m|`,
//! which is exactly the paper's `|g| d (k-i+1)^2 / 2` for a uniform load. The node is
//! deflected off the previous segment's axis `a0` by `y_i = M_i d^2 / (2 EI)` (eq 3) in the
//! plane of `a0` and the load (`a1`; `a2` completes the frame and carries no deflection for a
//! single resultant), then renormalised to length `d`.
//!
//! Because each segment turns by the deflection of its end (`M d^2 / 2EI`, half of the
//! end slope `M d / EI`), the paper's beam is, in the limit d -> 0, an Euler–Bernoulli beam
//! of rigidity 2EI: small-load tip drop tends to G/16, not G/8 (see `tests/numerics.rs` and
//! the bend benchmark). Scenes are tuned with this EI, so the paper mode keeps it.
//!
//! **Converged mode.** Joint `j` (node p_j) turns the hair by the rotation vector
//! `omega_j = P(M_j) l_j / EI`, with `M_j = sum_{m>j} (c_m - p_j) x f_m` from the *deformed*
//! midpoints `c_m` (true lever arms), `P` dropping the twisting part, `l_0 = d/2` at the
//! clamp and `l_j = d` inside (midpoint rule, second order in d). The map from shape to
//! moments is iterated to a fixed point with under-relaxation and heavy-ball momentum, so it
//! converges for stiff loads (G up to 1000) where plain iteration oscillates. It converges to
//! the large-deflection elastica. Where the hull stops a joint the iteration is projected
//! (state reset to the rotation the joint really made, momentum dropped).
//!
//! **Loads** limited to a region (above the eyes, one half of the head) act on the segments
//! whose midpoints are in the region on the straight, unloaded beam, in both modes: a comb
//! selects hair by where it grows, and the selection cannot flicker as the hair moves.
//!
//! **Collision** (both modes): after each node is placed it is tested against the head by
//! the sign of the quadric and moved out in the plane of p(i-2), p(i-1), p(i)
//! (`Ellipsoid::push_out`).
//!
//! The WGSL kernel `shaders/cantilever.wgsl` implements the same steps in f32.

use super::{BendMode, GroomInput, GroupParams, StrandRoot};
use crate::error::Result;
use crate::scene::{CutRule, Ellipsoid};
use glam::{DQuat, DVec3};

/// One beam to bend.
pub struct Beam<'a> {
    pub root: DVec3,
    /// Clamped (unloaded) direction, unit.
    pub dir: DVec3,
    pub seg_len: f64,
    pub segments: u32,
    /// Flexural rigidity EI.
    pub rigidity: f64,
    /// Load per unit length on a segment, given its midpoint on the straight unloaded beam
    /// (which decides the regions it is in) and its current midpoint (where the field is
    /// evaluated).
    pub load: &'a dyn Fn(DVec3, DVec3) -> DVec3,
    pub hull: Option<&'a Ellipsoid>,
}

impl Beam<'_> {
    /// Midpoint of segment m (1-based) on the straight, unloaded beam.
    fn rest_mid(&self, m: usize) -> DVec3 {
        self.root + self.dir * (self.seg_len * (m as f64 - 0.5))
    }
}

/// How an iterated bend ended.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Convergence {
    pub iterations: u32,
    /// Estimated remaining error of the joint rotations, radians.
    pub residual: f64,
    pub converged: bool,
}

/// Anjyo's one-pass bend (eqs 1-3). Returns k + 1 nodes.
pub fn bend_paper(b: &Beam) -> Vec<DVec3> {
    let k = b.segments as usize;
    let d = b.seg_len;
    // Segment loads g_m (m = 1..k) on the straight beam, and W_i = sum_{m>=i} (m-i+1/2) g_m
    // by the recurrence W_i = W_{i+1} + S_{i+1} + g_i / 2 (S: suffix sum of g), which has
    // no cancellation in f32.
    let mut w = vec![DVec3::ZERO; k + 2];
    let mut s = DVec3::ZERO;
    for m in (1..=k).rev() {
        let mid = b.rest_mid(m);
        let g = (b.load)(mid, mid) * d;
        w[m] = w[m + 1] + s + 0.5 * g;
        s += g;
    }
    let scale = d * d * d / (2.0 * b.rigidity);
    let mut nodes = Vec::with_capacity(k + 1);
    nodes.push(b.root);
    let mut a0 = b.dir;
    for wi in &w[1..=k] {
        let prev = *nodes.last().unwrap();
        // Deflection y1 a1 + y2 a2: the load's part across a0.
        let y = (*wi - wi.dot(a0) * a0) * scale;
        let e = a0 * d + y;
        let mut p = prev + e * (d / e.length());
        if let Some(h) = b.hull {
            p = h.push_out(prev, a0, p, d);
        }
        a0 = ((p - prev) / d).normalize();
        nodes.push(p);
    }
    nodes
}

/// Rotate `v` by the rotation vector `w` (axis * angle).
pub fn rotate(w: DVec3, v: DVec3) -> DVec3 {
    let angle = w.length();
    if angle < 1e-300 {
        return v;
    }
    DQuat::from_axis_angle(w / angle, angle) * v
}

/// Rotation vector turning unit `a` into unit `b` (shortest arc).
fn turn(a: DVec3, b: DVec3) -> DVec3 {
    let axis = a.cross(b);
    let s = axis.length();
    if s > 1e-300 {
        axis / s * s.atan2(a.dot(b))
    } else {
        DVec3::ZERO
    }
}

/// Shape from joint rotations, root to tip, with collision. `realized[j]` receives the
/// rotation joint j really made (different from `omega[j]` where a node was pushed out of
/// the hull), `pushed[j]` whether node j + 1 was pushed.
fn rebuild(
    b: &Beam,
    omega: &[DVec3],
    nodes: &mut [DVec3],
    realized: &mut [DVec3],
    pushed: &mut [bool],
) {
    let d = b.seg_len;
    nodes[0] = b.root;
    let mut t = b.dir;
    for j in 0..omega.len() {
        let turned = rotate(omega[j], t);
        let free = nodes[j] + turned * d;
        let p = match b.hull {
            Some(h) => h.push_out(nodes[j], t, free, d),
            None => free,
        };
        pushed[j] = p != free;
        let nt = ((p - nodes[j]) / d).normalize();
        realized[j] = if pushed[j] { turn(t, nt) } else { omega[j] };
        t = nt;
        nodes[j + 1] = p;
    }
}

/// Target joint rotations from the moments of the current shape (true lever arms). Where
/// node j + 1 rests on the hull (`contact[j]`), the part of the step from the current
/// rotation `omega[j]` that would move the node into the hull is removed: the head supports
/// the hair there, so a fixed point exists with the hair lying on the head.
fn target_rotations(
    b: &Beam,
    nodes: &[DVec3],
    omega: &[DVec3],
    contact: &[bool],
    out: &mut [DVec3],
) {
    let k = out.len();
    let d = b.seg_len;
    // Moments about the root (lever arms relative to it keep f32 accurate far from the
    // origin): M_j = C_j - (p_j - root) x N_j with N, C suffix sums of f and (c - root) x f.
    let (mut n, mut c) = (DVec3::ZERO, DVec3::ZERO);
    for j in (0..k).rev() {
        let mid = 0.5 * (nodes[j] + nodes[j + 1]);
        let f = (b.load)(b.rest_mid(j + 1), mid) * d;
        n += f;
        c += (mid - b.root).cross(f);
        let m = c - (nodes[j] - b.root).cross(n);
        // Drop the twisting part: only bending about axes across the incoming segment.
        let t = if j == 0 {
            b.dir
        } else {
            ((nodes[j] - nodes[j - 1]) / d).normalize()
        };
        let m_perp = m - m.dot(t) * t;
        let l = if j == 0 { 0.5 * d } else { d };
        let mut target = m_perp * (l / b.rigidity);
        if contact[j] {
            if let Some(h) = b.hull {
                let n = h.normal(nodes[j + 1]);
                let step = (target - omega[j]).cross(t);
                let inward = step.dot(n).min(0.0);
                target = omega[j] + t.cross(step - inward * n);
            }
        }
        out[j] = target;
    }
}

/// Relaxation for the fixed-point iteration, from an estimate of the load parameter
/// G = |w| L^3 / EI: the linearised shape-to-moment map has eigenvalues of size up to about
/// G/3 and opposite sign, so a step `alpha = 1/(1 + G/3)` is stable; the heavy-ball term
/// recovers the speed lost on the smooth modes.
pub fn relaxation(g_est: f64) -> (f64, f64) {
    let lam = g_est / 3.0;
    let alpha = 1.0 / (1.0 + lam);
    let r = ((lam.sqrt() - 1.0) / (lam.sqrt() + 1.0)).clamp(0.0, 0.9);
    (alpha, r * r)
}

/// Nodes within this band outside the hull (in units of the quadric) count as resting on it.
pub const CONTACT_BAND: f64 = 4.0 * crate::scene::head::EPS_OUT;

/// The converged bend: fixed point of (shape -> true moments -> joint rotations), started
/// from the paper's shape and relaxed with heavy-ball momentum. Where the hull stops a joint
/// the iteration is projected: the state becomes the rotation the joint really made (with
/// no momentum), and nodes resting on the hull are not stepped inwards (`target_rotations`). Converged when the largest change of a joint rotation in one
/// iteration, divided by the step size, is below `tolerance` (radians; for a contraction
/// this estimates the remaining error).
pub fn bend_converged(b: &Beam, max_iterations: u32, tolerance: f64) -> (Vec<DVec3>, Convergence) {
    let k = b.segments as usize;
    let d = b.seg_len;
    let mut nodes = bend_paper(b);
    let mut omega = vec![DVec3::ZERO; k];
    let mut contact = vec![false; k];
    let mut t = b.dir;
    for j in 0..k {
        let nt = ((nodes[j + 1] - nodes[j]) / d).normalize();
        omega[j] = turn(t, nt);
        contact[j] = b.hull.is_some_and(|h| h.eval(nodes[j + 1]) < CONTACT_BAND);
        t = nt;
    }
    let g_est = {
        let len = d * k as f64;
        let wmax = (1..=k)
            .map(|m| (b.load)(b.rest_mid(m), b.rest_mid(m)).length())
            .fold(0.0, f64::max);
        wmax * len * len * len / b.rigidity
    };
    let (alpha, beta) = relaxation(g_est);
    let mut prev = omega.clone();
    let mut target = vec![DVec3::ZERO; k];
    let mut trial = vec![DVec3::ZERO; k];
    let mut realized = vec![DVec3::ZERO; k];
    let mut pushed = vec![false; k];
    let mut info = Convergence::default();
    for it in 1..=max_iterations {
        target_rotations(b, &nodes, &omega, &contact, &mut target);
        for j in 0..k {
            trial[j] = omega[j] + alpha * (target[j] - omega[j]) + beta * (omega[j] - prev[j]);
        }
        rebuild(b, &trial, &mut nodes, &mut realized, &mut pushed);
        let mut change = 0.0f64;
        for j in 0..k {
            change = change.max((realized[j] - omega[j]).length());
            prev[j] = if pushed[j] { realized[j] } else { omega[j] };
            omega[j] = realized[j];
            // Pushed nodes end inside the band, so this covers them too.
            contact[j] = b.hull.is_some_and(|h| h.eval(nodes[j + 1]) < CONTACT_BAND);
        }
        let residual = change / alpha;
        info = Convergence {
            iterations: it,
            residual,
            converged: residual <= tolerance,
        };
        if info.converged {
            break;
        }
    }
    (nodes, info)
}

/// Bend one strand of a prepared groom with its group's mode. A converged-mode strand that
/// does not converge within its iterations falls back to the paper's shape (and says so:
/// `converged == false`).
pub fn bend_strand(
    head: &Ellipsoid,
    group: &GroupParams,
    root: &StrandRoot,
) -> (Vec<DVec3>, Convergence) {
    let load = |rest: DVec3, at: DVec3| group.load_at(rest, at);
    let beam = Beam {
        root: root.pos,
        dir: root.dir,
        seg_len: root.seg_len,
        segments: group.segments,
        rigidity: group.rigidity,
        load: &load,
        hull: Some(head),
    };
    match group.mode {
        BendMode::Paper => (
            bend_paper(&beam),
            Convergence {
                converged: true,
                ..Default::default()
            },
        ),
        BendMode::Converged {
            max_iterations,
            tolerance,
        } => {
            let (nodes, info) = bend_converged(&beam, max_iterations, tolerance);
            if info.converged {
                (nodes, info)
            } else {
                // Contact can leave the iteration chattering, or a singular field (hair
                // passing through a `Toward` point) can leave it without a fixed point: keep
                // the paper's shape rather than a half-converged one.
                (bend_paper(&beam), info)
            }
        }
    }
}

/// Number of drawn segments (fractional: the last drawn segment may be cut part-way) after
/// the group's cuts that apply to this pore. Every rule hides the hair from the first node
/// that breaks it, so a cut is a prefix of the bent hair.
pub fn visible_segments(nodes: &[DVec3], cuts: &[CutRule], mask: u32) -> f64 {
    let k = (nodes.len() - 1) as f64;
    let mut vis = k;
    for (ci, rule) in cuts.iter().enumerate() {
        if mask & (1 << ci) == 0 {
            continue;
        }
        let v = match rule {
            CutRule::Below(y) => first_crossing(nodes, |p| p.y - y),
            CutRule::Near { center, radius } => {
                let c = DVec3::from(*center);
                first_crossing(nodes, |p| (p - c).length() - radius)
            }
            CutRule::ByPoreHeight { low, high } => {
                let t = ((nodes[0].y - low.0) / (high.0 - low.0)).clamp(0.0, 1.0);
                low.1 as f64 + t * (high.1 as f64 - low.1 as f64)
            }
        };
        vis = vis.min(v);
    }
    vis.max(0.0)
}

/// Arc position (in segments) where `f` first turns negative along the hair, or k.
fn first_crossing(nodes: &[DVec3], f: impl Fn(DVec3) -> f64) -> f64 {
    let mut fa = f(nodes[0]);
    if fa < 0.0 {
        return 0.0;
    }
    for (i, node) in nodes.iter().enumerate().skip(1) {
        let fb = f(*node);
        if fb < 0.0 {
            return (i - 1) as f64 + fa / (fa - fb);
        }
        fa = fb;
    }
    (nodes.len() - 1) as f64
}

/// The reference groom of a whole scene: all nodes (strands contiguous, `vertex_offsets`
/// order), the drawn segment count of each strand, and the worst convergence.
pub struct GroomOutput {
    pub nodes: Vec<DVec3>,
    pub visible: Vec<f64>,
    /// Converged-mode strands that did not converge and kept the paper's shape.
    pub fallbacks: u32,
    /// Most iterations any strand used.
    pub max_iterations: u32,
}

/// Bend every strand on the CPU in f64 (the reference for the GPU kernel).
pub fn bend_all(input: &GroomInput) -> GroomOutput {
    let mut nodes = Vec::with_capacity(input.total_vertices() as usize);
    let mut visible = Vec::with_capacity(input.roots.len());
    let mut fallbacks = 0;
    let mut max_iterations = 0;
    for r in &input.roots {
        let g = &input.groups[r.group as usize];
        let (n, c) = bend_strand(&input.head, g, r);
        visible.push(visible_segments(&n, &g.cuts, r.cut_mask));
        fallbacks += u32::from(!c.converged);
        max_iterations = max_iterations.max(c.iterations);
        nodes.extend(n);
    }
    GroomOutput {
        nodes,
        visible,
        fallbacks,
        max_iterations,
    }
}

// ---------------------------------------------------------------------------------------
// GPU pass

use super::LoadField;
use crate::gpu::gpu_data::{GpuCut, GpuGroomGroup, GpuGroomParams, GpuLoad, GpuRoot};
use crate::gpu::strands::StrandBuffers;
use crate::gpu::{self, Gpu};
use wgpu::util::DeviceExt;

const WORKGROUP: u32 = 64;

/// The cantilever kernel (`shaders/cantilever.wgsl`): long-lived pipelines and layout.
pub struct CantileverPass {
    bend: wgpu::ComputePipeline,
    iterate: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

/// One groom's uploaded inputs and bind group, ready to dispatch.
pub struct CantileverJob {
    bind_group: wgpu::BindGroup,
    dims: (u32, u32),
    /// `iterate` dispatches needed (0 when no group uses the converged mode).
    iterate_dispatches: u32,
}

/// Converged-mode iterations per dispatch: llvmpipe ends a shader's loops after 65,535
/// iterations in total per invocation, so one dispatch must stay well below that. The loop
/// count of one iteration is about k (2 + 2 L + 84): target and rebuild passes over the
/// segments, L load-and-plane loops per load evaluation, 84 for a hull push-out.
pub fn iterations_per_dispatch(segments: u32, load_loops: u32) -> u32 {
    const BUDGET: u32 = 40_000;
    let per_iteration = segments.max(1) * (2 + 2 * load_loops + 84);
    (BUDGET / per_iteration).clamp(1, 64)
}

impl CantileverPass {
    pub fn new(gpu: &Gpu) -> Result<CantileverPass> {
        let device = &gpu.device;
        let module = gpu::shader_module(device, "cantilever", crate::shaders::CANTILEVER)?;
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cantilever"),
            entries: &[
                gpu::uniform_entry(0, cs),
                gpu::storage_entry(1, cs, true),
                gpu::storage_entry(2, cs, true),
                gpu::storage_entry(3, cs, true),
                gpu::storage_entry(4, cs, true),
                gpu::storage_entry(5, cs, false),
                gpu::storage_entry(6, cs, false),
                gpu::storage_entry(7, cs, false),
            ],
        });
        let [bend, iterate, finish] = gpu::compute_pipelines(
            device,
            "cantilever",
            &layout,
            &module,
            ["bend", "iterate", "finish"],
        );
        Ok(CantileverPass {
            bend,
            iterate,
            finish,
            layout,
        })
    }

    /// Upload a prepared groom's roots and parameters. The scratch buffer of the converged
    /// mode is only allocated when a group uses it.
    pub fn prepare(
        &self,
        gpu: &Gpu,
        input: &GroomInput,
        strands: &StrandBuffers,
    ) -> Result<CantileverJob> {
        let device = &gpu.device;
        let roots: Vec<GpuRoot> = input
            .roots
            .iter()
            .map(|r| GpuRoot {
                pos: [
                    r.pos.x as f32,
                    r.pos.y as f32,
                    r.pos.z as f32,
                    r.seg_len as f32,
                ],
                dir: [
                    r.dir.x as f32,
                    r.dir.y as f32,
                    r.dir.z as f32,
                    f32::from_bits(r.cut_mask),
                ],
            })
            .collect();
        let mut groups = Vec::new();
        let mut loads = Vec::new();
        let mut cuts = Vec::new();
        for g in &input.groups {
            let (mode, max_iterations, tolerance) = match g.mode {
                BendMode::Paper => (0, 0, 0.0),
                BendMode::Converged {
                    max_iterations,
                    tolerance,
                } => (1, max_iterations, tolerance as f32),
            };
            groups.push(GpuGroomGroup {
                segments: g.segments,
                mode,
                max_iterations,
                first_load: loads.len() as u32,
                load_count: g.loads.len() as u32,
                first_cut: cuts.len() as u32,
                cut_count: g.cuts.len() as u32,
                rigidity: g.rigidity as f32,
                tolerance,
                ..Default::default()
            });
            loads.extend(g.loads.iter().map(gpu_load));
            cuts.extend(g.cuts.iter().map(gpu_cut));
        }
        let converged = input
            .groups
            .iter()
            .any(|g| matches!(g.mode, BendMode::Converged { .. }));
        let scratch_bytes = if converged {
            strands.vertex_count as u64 * 32
        } else {
            16
        };
        gpu.check_storage_size("the converged-bending scratch buffer", scratch_bytes)?;
        let dims = gpu.dispatch_dims(strands.strand_count, WORKGROUP)?;
        let (mut chunk, mut most) = (64u32, 0u32);
        for g in &input.groups {
            if let BendMode::Converged { max_iterations, .. } = g.mode {
                let load_loops: u32 = g.loads.iter().map(|l| 1 + l.planes.len() as u32).sum();
                chunk = chunk.min(iterations_per_dispatch(g.segments, load_loops));
                most = most.max(max_iterations);
            }
        }
        let params = GpuGroomParams {
            strand_count: strands.strand_count,
            total_vertices: strands.vertex_count,
            row_stride: dims.0 * WORKGROUP,
            chunk,
            head_center: [
                input.head.center.x as f32,
                input.head.center.y as f32,
                input.head.center.z as f32,
                0.0,
            ],
            head_radii: [
                input.head.radii.x as f32,
                input.head.radii.y as f32,
                input.head.radii.z as f32,
                0.0,
            ],
        };
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cantilever params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let none = wgpu::BufferUsages::empty();
        let roots = gpu::storage_buffer(
            device,
            "cantilever roots",
            bytemuck::cast_slice(&roots),
            none,
        );
        let groups = gpu::storage_buffer(
            device,
            "cantilever groups",
            bytemuck::cast_slice(&groups),
            none,
        );
        let loads = gpu::storage_buffer(
            device,
            "cantilever loads",
            bytemuck::cast_slice(&loads),
            none,
        );
        let cuts =
            gpu::storage_buffer(device, "cantilever cuts", bytemuck::cast_slice(&cuts), none);
        let scratch = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cantilever scratch"),
            size: scratch_bytes,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("cantilever"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: roots.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: groups.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: loads.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: cuts.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: strands.strands.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: strands.vertices.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 7,
                    resource: scratch.as_entire_binding(),
                },
            ],
        });
        Ok(CantileverJob {
            bind_group,
            dims,
            iterate_dispatches: most.div_ceil(chunk),
        })
    }

    /// Record the bend of every strand.
    pub fn dispatch(&self, enc: &mut wgpu::CommandEncoder, job: &CantileverJob) {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("cantilever"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &job.bind_group, &[]);
        pass.set_pipeline(&self.bend);
        pass.dispatch_workgroups(job.dims.0, job.dims.1, 1);
        if job.iterate_dispatches > 0 {
            pass.set_pipeline(&self.iterate);
            for _ in 0..job.iterate_dispatches {
                pass.dispatch_workgroups(job.dims.0, job.dims.1, 1);
            }
        }
        pass.set_pipeline(&self.finish);
        pass.dispatch_workgroups(job.dims.0, job.dims.1, 1);
    }
}

fn gpu_load(l: &super::ResolvedLoad) -> GpuLoad {
    let mut out = GpuLoad::default();
    match l.field {
        LoadField::Uniform(f) => out.field = [f.x as f32, f.y as f32, f.z as f32, 0.0],
        LoadField::Toward { point, strength } => {
            out.field = [point.x as f32, point.y as f32, point.z as f32, 1.0];
            out.params[0] = strength as f32;
        }
    }
    out.params[1] = l.planes.len() as f32;
    for (i, (n, o)) in l.planes.iter().enumerate() {
        out.planes[i] = [n.x as f32, n.y as f32, n.z as f32, *o as f32];
    }
    out
}

fn gpu_cut(c: &CutRule) -> GpuCut {
    match c {
        CutRule::Below(y) => GpuCut {
            kind: 0,
            a: [*y as f32, 0.0, 0.0, 0.0],
            ..Default::default()
        },
        CutRule::ByPoreHeight { low, high } => GpuCut {
            kind: 1,
            a: [low.0 as f32, low.1 as f32, high.0 as f32, high.1 as f32],
            ..Default::default()
        },
        CutRule::Near { center, radius } => GpuCut {
            kind: 2,
            a: [
                center[0] as f32,
                center[1] as f32,
                center[2] as f32,
                *radius as f32,
            ],
            ..Default::default()
        },
    }
}

/// Groom a whole scene on the GPU and wait: strand buffers holding the bent hair.
pub fn groom_gpu(gpu: &Gpu, input: &GroomInput) -> Result<StrandBuffers> {
    let strands = StrandBuffers::new(gpu, input)?;
    let pass = CantileverPass::new(gpu)?;
    let job = pass.prepare(gpu, input, &strands)?;
    let mut enc = gpu
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("groom"),
        });
    pass.dispatch(&mut enc, &job);
    gpu.queue.submit([enc.finish()]);
    gpu.wait()?;
    gpu.take_error()?;
    Ok(strands)
}
