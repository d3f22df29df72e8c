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
//! of rigidity 2EI: small-load tip drop tends to G/16, not G/8 (see `tests/it/numerics.rs` and
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
//! The WGSL kernel `shaders/anjyo/cantilever.wgsl` implements the same steps in f32.

use super::groom::{BendMode, GroomInput, GroupParams, StrandRoot};
use crate::scene::hull::HeadHull;
use crate::systems::anjyo::block::CutRule;
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
    pub hull: Option<&'a HeadHull>,
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

/// The contact band of a hull in its own units (`CONTACT_BAND` for the ellipsoid).
pub fn contact_band(h: &HeadHull) -> f64 {
    4.0 * h.eps_out()
}

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
        contact[j] = b
            .hull
            .is_some_and(|h| h.eval(nodes[j + 1]) < contact_band(h));
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
            contact[j] = b
                .hull
                .is_some_and(|h| h.eval(nodes[j + 1]) < contact_band(h));
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
    head: &HeadHull,
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
    for (i, r) in input.roots.iter().enumerate() {
        let g = &input.groups[r.group as usize];
        if let Some(shapes) = &g.shapes {
            // Read from a file, not bent (`super::imported`).
            let k = g.segments as usize + 1;
            let j = i - g.first_strand as usize;
            nodes.extend_from_slice(&shapes[j * k..(j + 1) * k]);
            visible.push(g.segments as f64);
            continue;
        }
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
