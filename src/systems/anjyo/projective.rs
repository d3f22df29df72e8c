//! Anjyo's one-dimensional projective equations (1992, section 3).
//!
//! Every segment s_i of a hair has a zenith theta_i (from +y) and an azimuth phi_i (in the zx
//! plane, from +x towards +z) that follow
//!
//! ```text
//! theta_i'' = c_i u_i F_theta,   phi_i'' = c_i v_i F_phi                       (4), (5)
//! theta^{n+1} = theta^n + (theta^n - theta^{n-1}) + h^2 c_i u_i F_theta            (4)'
//! ```
//!
//! (starting at rest, theta^0 = theta^-1, with half the acceleration in the very first step
//! so the start is second order too), with u_i = d/2, v_i = (d/2) sin theta_i (half the segment's shadow on the phi plane),
//! F_theta = (F, V_theta), F_phi = (F, V_phi), V_theta and V_phi the unit vectors across the
//! segment in its theta plane (spanned by y and the segment) and in the phi plane (zx). When
//! a segment is almost parallel to y (|sin theta| < `POLE_SIN`) the theta plane is spanned by
//! y and the force instead, as the paper says: both time levels are re-expressed in that
//! plane, which also removes the azimuth's degeneracy (v_i -> 0) for hair hanging straight
//! down. Positions are rebuilt root to tip every step; the root follows the head.
//!
//! - **Inertia (3.2.1)**: I_i proportional to 1/i with I_k = I_S gives
//!   c_i = 3 i / (rho k^3 d^2) (so h^2 c_i u_i = 3 h^2 i / (2 k^3 rho d), the paper's closed
//!   form), scaled along the strand and across the scalp by `Inertia`.
//! - **Pseudo-force (3.2.2)**: within `near` of the head, a segment whose force points into
//!   the hull ((D, F) < alpha |D| |F|, D the hull gradient at its end node) feels
//!   epsilon_i F, epsilon rising from the pore to the tip.
//! - **Joint-angle stiffness (3.2.3)**: after each new node, the bend at the previous node is
//!   limited to sigma_i (we read the paper's joint angle as the turn between consecutive
//!   segments, 0 = straight, so sigma = 180 degrees leaves hair free and 10-15 degrees keeps
//!   it smooth); "gently blowing" random kicks are drawn once per `period` frames from a
//!   hash of (seed, strand, segment, period index), so runs repeat.
//! - **Our additions**, each a switch in the scene: velocity damping at a rate per unit time
//!   (the paper's recurrence never settles), discretised with a central velocity so the
//!   scheme stays second order, hard collision after the step (the grooming push-out), head motion as the
//!   roots' acceleration felt by the segments (-rho d a_root), inelastic corrections (a
//!   segment moved by the stiffness clamp or the collision loses its angular velocity, so
//!   constraints neither inject energy nor store a velocity into the head), and stability
//!   control:
//!   substeps so that h * omega <= `OMEGA_H` for the stiffest segment (omega^2 = c u |F|),
//!   and beyond `max_substeps` a clamp of the angular step to `MAX_TURN` with a warning.
//! - **The External Force Field** (Kazama et al., `crate::forces::eff`), when the scene has
//!   one: each segment adds the field, trilinear, at its end node from the previous substep
//!   (the point the pseudo-force test reads), times the gust scale at the substep's start.
//!   The substep schedule bounds |F| by the uniform force plus the field's largest value.
//!
//! `shaders/anjyo/projective.wgsl` implements the same step in f32.

use super::groom::GroomInput;
use crate::forces::Forces;
use crate::rng::pcg_hash;
use crate::scene::hull::HeadHull;
use crate::systems::anjyo::block::Dynamics;
use crate::systems::scene::Scene;
use glam::{DMat4, DVec3};
use std::f64::consts::{PI, TAU};

/// Below this |sin theta| the theta plane is spanned by y and the force.
pub const POLE_SIN: f64 = 0.05;
/// Largest angular step per substep (radians): the safety clamp.
pub const MAX_TURN: f64 = 0.5;
/// Substeps are chosen so that h * omega stays below this (Verlet is stable below 2).
pub const OMEGA_H: f64 = 0.5;

/// Everything a single step needs, uniform over the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepForces {
    /// Step length (dt / substeps).
    pub h: f64,
    /// Gravity plus wind.
    pub force: DVec3,
    /// Head pose at the end of the step (roots and hull follow it).
    pub head: DMat4,
    /// Root acceleration operator: a_root = accel * (root_local, 1).
    pub accel: DMat4,
    /// Fluctuation bucket to apply at this step, if this step starts one.
    pub kick: Option<u32>,
    /// The very first substep from rest: Verlet's first step from theta^0 = theta^-1 takes
    /// half the acceleration, which keeps the start second order (theta(h) = theta0 + a h^2/2).
    pub first: bool,
    /// The EFF's gust scale at the substep's start (0 without an EFF): each segment adds the
    /// field at its node times this.
    pub eff_scale: f64,
    /// The substep's start in frames: where `force` and `eff_scale` are taken (the GPU pass
    /// samples the world there).
    pub t: f64,
    /// Its end in frames: where `head` is taken.
    pub t_end: f64,
}

/// How segments read the EFF.
pub const EFF_SAMPLING: crate::scene::Sampling = crate::scene::Sampling::Trilinear;

/// Forces of step `n` (from t_n to t_n + dt) split into `substeps`, for substep `s`.
pub fn step_forces(forces: &Forces, dyn_: &Dynamics, n: u64, substeps: u32, s: u32) -> StepForces {
    let spf = dyn_.steps_per_frame as f64;
    let h = dyn_.dt / substeps as f64;
    // Time in frames at the start of this substep.
    let frame = (n as f64 + s as f64 / substeps as f64) / spf;
    let df = 1.0 / (spf * substeps as f64);
    let force = forces.uniform_at(frame);
    // Root acceleration at the start of the step (central difference), like the force.
    let before = forces.head_at(frame - df);
    let now = forces.head_at(frame);
    let head = forces.head_at(frame + df);
    let accel = DMat4::from_cols(
        (head.x_axis - 2.0 * now.x_axis + before.x_axis) / (h * h),
        (head.y_axis - 2.0 * now.y_axis + before.y_axis) / (h * h),
        (head.z_axis - 2.0 * now.z_axis + before.z_axis) / (h * h),
        (head.w_axis - 2.0 * now.w_axis + before.w_axis) / (h * h),
    );
    let kick = dyn_.fluctuation.as_ref().and_then(|f| {
        let first_step_of_frame = n % dyn_.steps_per_frame as u64 == 0 && s == 0;
        let f_index = n / dyn_.steps_per_frame as u64;
        (first_step_of_frame && f_index % f.period as u64 == 0)
            .then_some((f_index / f.period as u64) as u32)
    });
    StepForces {
        h,
        force,
        head,
        accel,
        kick,
        first: n == 0 && s == 0,
        eff_scale: forces.eff_scale(frame),
        t: frame,
        t_end: frame + df,
    }
}

/// One simulated hair.
#[derive(Clone, Debug, PartialEq)]
pub struct DynStrand {
    /// Index in the strand table.
    pub strand: u32,
    /// Its root node in the shared vertex array.
    pub first_vertex: u32,
    /// Its entries in the angle state (index 0 unused, segments 1..=k).
    pub state_offset: u32,
    /// Simulated segments: the drawn (cut) length, rounded up.
    pub segments: u32,
    pub seg_len: f64,
    /// Pore in head coordinates.
    pub root_local: DVec3,
    /// Scalp inertia factor (3.2.1's rough friction near the top).
    pub scalp: f64,
}

/// What the solver needs besides the state: strands, parameters, the head.
#[derive(Clone, Debug)]
pub struct DynSetup {
    pub params: Dynamics,
    /// The shared force fields (gravity, wind, head motion) the steps are scheduled from.
    pub forces: Forces,
    pub head: HeadHull,
    pub strands: Vec<DynStrand>,
    pub state_len: u32,
    /// Largest c_i u_i over all segments: omega^2 = max_cu |F| bounds the stiffest mode.
    pub max_cu: f64,
    pub seed: u32,
}

fn smoothstep(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl DynSetup {
    /// Simulation set-up for the dynamic groups of a groomed scene (`visible`: drawn segments
    /// per strand from the groom): every strand, or only the guides when the scene sets
    /// `dynamics.guides` (`follow`). `None` when the scene has no dynamics or no dynamic group.
    pub fn new(scene: &Scene, input: &GroomInput, visible: &[f64]) -> Option<DynSetup> {
        let params = scene.dynamics().clone()?;
        let offsets = input.vertex_offsets();
        let mut strands = Vec::new();
        let mut state_len = 0u32;
        let inr = &params.inertia;
        // Every strand of a dynamic group, or only its guides (`follow::guide_mask`).
        let simulated = super::follow::guide_mask(scene, input);
        for (i, r) in input.roots.iter().enumerate() {
            if !simulated[i] {
                continue;
            }
            let k = input.groups[r.group as usize].segments;
            let segments = (visible[i].ceil() as u32).clamp(1, k);
            let scalp = 1.0
                + (inr.top - 1.0)
                    * smoothstep(inr.top_height - inr.top_blend, inr.top_height, r.pos.y);
            strands.push(DynStrand {
                strand: i as u32,
                first_vertex: offsets[i],
                state_offset: state_len,
                segments,
                seg_len: r.seg_len,
                root_local: r.pos,
                scalp,
            });
            state_len += segments + 1;
        }
        if strands.is_empty() {
            return None;
        }
        let mut setup = DynSetup {
            seed: (scene.seed ^ (scene.seed >> 32)) as u32,
            params,
            forces: Forces::new(&scene.forces, &scene.head),
            head: input.head.clone(),
            strands,
            state_len,
            max_cu: 0.0,
        };
        setup.update_max_cu();
        Some(setup)
    }

    /// Recompute the stiffest mode after the inertia parameters changed.
    pub fn update_max_cu(&mut self) {
        self.max_cu = self
            .strands
            .iter()
            .flat_map(|s| (1..=s.segments).map(move |i| (s, i)))
            .map(|(s, i)| self.c(s, i) * 0.5 * s.seg_len)
            .fold(0.0, f64::max);
    }

    /// c_i = 1 / I_i with the inertia profile.
    pub fn c(&self, s: &DynStrand, i: u32) -> f64 {
        let k = s.segments as f64;
        let d = s.seg_len;
        let inr = &self.params.inertia;
        let t = if s.segments > 1 {
            (i as f64 - 1.0) / (k - 1.0)
        } else {
            1.0
        };
        let along = inr.root + (inr.tip - inr.root) * t;
        3.0 * i as f64 / (self.params.density * k * k * k * d * d) * along * s.scalp
    }

    /// Largest bend (radians) at node i (between segments i and i + 1).
    pub fn sigma(&self, s: &DynStrand, i: u32) -> f64 {
        self.params
            .stiffness
            .sigma_at(i as f64 / s.segments as f64)
            .to_radians()
    }

    /// Pseudo-force factor of segment i.
    pub fn epsilon(&self, s: &DynStrand, i: u32) -> f64 {
        match &self.params.pseudo_force {
            Some(p) => {
                let t = if s.segments > 1 {
                    (i as f64 - 1.0) / (s.segments as f64 - 1.0)
                } else {
                    1.0
                };
                p.epsilon_pore + (p.epsilon_tip - p.epsilon_pore) * t
            }
            None => 1.0,
        }
    }

    /// Largest force a segment can feel in step `n` of this many substeps: gravity + wind
    /// + the EFF's largest value plus the inertial force of the fastest-accelerating root.
    fn force_bound(&self, f: &StepForces) -> f64 {
        let uniform = f.force.length()
            + self
                .forces
                .eff
                .as_ref()
                .map_or(0.0, |e| e.max_force() * f.eff_scale.abs());
        if f.accel == DMat4::ZERO {
            // A still head (the common case): no pass over the strands every step.
            return uniform;
        }
        let rho = self.params.density;
        let accel = self
            .strands
            .iter()
            .map(|s| rho * s.seg_len * f.accel.transform_point3(s.root_local).length())
            .fold(0.0, f64::max);
        uniform + accel
    }

    /// The substeps of step `n`: as many as stability needs (h omega <= OMEGA_H), at most
    /// `max_substeps`. Returns the forces of each substep and whether the cap was hit (the
    /// solver then relies on its angular clamp: say so).
    pub fn schedule(&self, n: u64) -> (Vec<StepForces>, bool) {
        let p = &self.params;
        let probe = step_forces(&self.forces, p, n, 1, 0);
        let omega = (self.max_cu * self.force_bound(&probe)).sqrt();
        let need = (p.dt * omega / OMEGA_H).ceil().max(1.0);
        let capped = need > p.max_substeps as f64;
        let sub = (need as u32).min(p.max_substeps);
        (
            (0..sub)
                .map(|s| step_forces(&self.forces, p, n, sub, s))
                .collect(),
            capped,
        )
    }
}

/// Direction of (theta, phi).
pub fn direction(theta: f64, phi: f64) -> DVec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    DVec3::new(st * cp, ct, st * sp)
}

/// The (theta, phi) of unit `dir` continuing a previous (theta, phi). A direction has two
/// families of representations, (t, p) and (-t, p + pi) (each up to 2 pi); the one whose
/// azimuth is closest to the previous one is taken, so hair passing over a pole keeps its
/// azimuth and lets theta leave [0, pi], and no spurious azimuthal velocity appears.
pub fn angles_near(dir: DVec3, theta_ref: f64, phi_ref: f64) -> (f64, f64) {
    let tc = dir.y.clamp(-1.0, 1.0).acos();
    let horizontal = (dir.x * dir.x + dir.z * dir.z).sqrt();
    let unwrap = |a: f64, r: f64| a + TAU * ((r - a) / TAU).round();
    if horizontal <= 1e-6 {
        // On a pole: the azimuth is free, keep it.
        let a = unwrap(tc, theta_ref);
        let b = unwrap(-tc, theta_ref);
        let t = if (a - theta_ref).abs() <= (b - theta_ref).abs() {
            a
        } else {
            b
        };
        return (t, phi_ref);
    }
    let pc = dir.z.atan2(dir.x);
    let pa = unwrap(pc, phi_ref);
    let pb = unwrap(pc + PI, phi_ref);
    if (pa - phi_ref).abs() <= (pb - phi_ref).abs() {
        (unwrap(tc, theta_ref), pa)
    } else {
        (unwrap(-tc, theta_ref), pb)
    }
}

/// A reproducible uniform number in [-1, 1) for the fluctuation kicks; the same hash runs in
/// `shaders/anjyo/projective.wgsl`.
pub fn kick_unit(seed: u32, strand: u32, segment: u32, bucket: u32, which: u32) -> f64 {
    let h = pcg_hash(
        bucket.wrapping_mul(2).wrapping_add(which)
            ^ pcg_hash(segment ^ pcg_hash(strand ^ pcg_hash(seed))),
    );
    ((h >> 8) as f64 / 16_777_216.0) * 2.0 - 1.0
}

/// Statistics of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// Sum over segments of u^2 (theta'^2 + sin^2 theta phi'^2): the kinetic measure.
    pub kinetic: f64,
    /// Angular steps clamped to MAX_TURN.
    pub clamped: u64,
}

/// The f64 reference solver: angle state and node positions.
pub struct CpuSim {
    pub setup: DynSetup,
    /// (theta^n, phi^n, theta^{n-1}, phi^{n-1}) per segment.
    pub angles: Vec<[f64; 4]>,
    /// All nodes, in the groom's vertex order (static strands are left as they are).
    pub nodes: Vec<DVec3>,
    /// Steps taken.
    pub steps: u64,
    /// Segment-substeps computed (cost accounting for the benchmark).
    pub segment_substeps: u64,
}

impl CpuSim {
    /// Start at rest in the groomed shape: theta^0 = theta^-1 (Anjyo 3.1).
    pub fn new(setup: DynSetup, nodes: Vec<DVec3>) -> CpuSim {
        let mut angles = vec![[0.0; 4]; setup.state_len as usize];
        for s in &setup.strands {
            let base = s.first_vertex as usize;
            for i in 1..=s.segments as usize {
                let dir = (nodes[base + i] - nodes[base + i - 1]).normalize();
                let (t, p) = angles_near(dir, 0.5 * PI, 0.0);
                angles[s.state_offset as usize + i] = [t, p, t, p];
            }
        }
        CpuSim {
            setup,
            angles,
            nodes,
            steps: 0,
            segment_substeps: 0,
        }
    }

    /// Advance one step (with its substeps). Returns the statistics of the last substep
    /// and whether the substep cap was hit.
    pub fn step(&mut self) -> (StepStats, bool) {
        let (subs, capped) = self.setup.schedule(self.steps);
        let mut stats = StepStats::default();
        let segments: u64 = self.setup.strands.iter().map(|s| s.segments as u64).sum();
        for f in &subs {
            stats = self.substep(f);
            self.segment_substeps += segments;
        }
        self.steps += 1;
        (stats, capped)
    }

    /// Advance one frame (`steps_per_frame` steps).
    pub fn frame(&mut self) -> (StepStats, bool) {
        let mut out = (StepStats::default(), false);
        for _ in 0..self.setup.params.steps_per_frame {
            let (s, c) = self.step();
            out = (s, out.1 || c);
        }
        out
    }

    /// One substep of every dynamic strand.
    pub fn substep(&mut self, f: &StepForces) -> StepStats {
        let head_inv = f.head.inverse();
        let mut total = StepStats::default();
        for si in 0..self.setup.strands.len() {
            let s = self.setup.strands[si].clone();
            let st = step_strand(
                &self.setup,
                &s,
                f,
                &head_inv,
                &mut self.angles,
                &mut self.nodes,
            );
            total.kinetic += st.kinetic;
            total.clamped += st.clamped;
        }
        total
    }
}

/// Keep angles small so f32 keeps its precision on long runs: shift both time levels by
/// the same multiple of 2 pi.
pub fn rewrap(a: &mut [f64; 4]) {
    for (x, xp) in [(0, 2), (1, 3)] {
        if a[x].abs() > TAU {
            let shift = TAU * (a[x] / TAU).round();
            a[x] -= shift;
            a[xp] -= shift;
        }
    }
}

/// One substep of one strand, root to tip.
pub fn step_strand(
    setup: &DynSetup,
    s: &DynStrand,
    f: &StepForces,
    head_inv: &DMat4,
    angles: &mut [[f64; 4]],
    nodes: &mut [DVec3],
) -> StepStats {
    let p = &setup.params;
    let h = f.h;
    let d = s.seg_len;
    let base = s.first_vertex as usize;
    let off = s.state_offset as usize;
    let root = f.head.transform_point3(s.root_local);
    let a_root = f.accel.transform_point3(s.root_local);
    let f_seg = f.force - p.density * d * a_root;
    // Damped Verlet with a central velocity (second order): (1 + g) x' = 2x - (1 - g) x_ + h^2 a,
    // g = damping h / 2. Past g = 1 the motion is critically over-damped: keep no velocity.
    let g = 0.5 * p.damping * h;
    let keep = ((1.0 - g) / (1.0 + g)).max(0.0);
    let push = if f.first { 0.5 } else { 1.0 } / (1.0 + g);
    let mut stats = StepStats::default();
    nodes[base] = root;
    let mut prev_p = root;
    // The first segment's collision plane uses the hull normal at the root.
    let mut prev_dir = f.head.transform_vector3(setup.head.normal(s.root_local));
    for i in 1..=s.segments {
        let [mut th, mut ph, mut thp, mut php] = angles[off + i as usize];
        let p_old = nodes[base + i as usize];
        let mut force = f_seg;
        if let Some(eff) = &setup.forces.eff {
            if f.eff_scale != 0.0 {
                force += eff.sample(p_old, EFF_SAMPLING) * f.eff_scale;
            }
        }
        if let Some(pf) = &p.pseudo_force {
            let local = head_inv.transform_point3(p_old);
            let g = setup.head.gradient(local);
            let dist = setup.head.eval(local) / g.length().max(1e-300);
            let dd = f.head.transform_vector3(g);
            if dist < pf.near && dd.dot(force) < pf.alpha * dd.length() * force.length() {
                force *= setup.epsilon(s, i);
            }
        }
        // Theta plane from y and the force for segments almost parallel to y.
        if th.sin().abs() < POLE_SIN {
            let fh = DVec3::new(force.x, 0.0, force.z);
            if fh.length() > 1e-6 * force.length() && fh.length() > 0.0 {
                let pf = fh.z.atan2(fh.x);
                let e = DVec3::new(pf.cos(), 0.0, pf.sin());
                let (dn, dp) = (direction(th, ph), direction(thp, php));
                let tn = dn.dot(e).atan2(dn.y);
                let tp = dp.dot(e).atan2(dp.y);
                th = tn;
                thp = tn + (tp - tn + PI).rem_euclid(TAU) - PI;
                ph = pf;
                php = pf;
            }
        }
        let (sth, cth) = th.sin_cos();
        let (sph, cph) = ph.sin_cos();
        let v_th = DVec3::new(cth * cph, -sth, cth * sph);
        let v_ph = DVec3::new(-sph, 0.0, cph);
        let cu = setup.c(s, i) * 0.5 * d;
        let mut dth = keep * (th - thp) + push * h * h * cu * force.dot(v_th);
        let mut dph = keep * (ph - php) + push * h * h * cu * sth * force.dot(v_ph);
        if dth.abs() > MAX_TURN {
            dth = MAX_TURN.copysign(dth);
            stats.clamped += 1;
        }
        if (sth * dph).abs() > MAX_TURN {
            dph = (MAX_TURN / sth.abs()).copysign(dph);
            stats.clamped += 1;
        }
        dph = dph.clamp(-PI, PI);
        let mut thn = th + dth;
        let mut phn = ph + dph;
        if let (Some(bucket), Some(fl)) = (f.kick, &p.fluctuation) {
            let amp = fl.amplitude.to_radians() * i as f64 / s.segments as f64;
            thn += amp * kick_unit(setup.seed, s.strand, i, bucket, 0);
            phn += amp * kick_unit(setup.seed, s.strand, i, bucket, 1);
        }
        let mut dir = direction(thn, phn);
        let mut moved = false;
        if i >= 2 {
            let sigma = setup.sigma(s, i - 1);
            let bend = prev_dir.angle_between(dir);
            if bend > sigma {
                let axis = prev_dir.cross(dir);
                let axis = if axis.length() > 1e-12 {
                    axis.normalize()
                } else {
                    prev_dir.any_orthonormal_vector()
                };
                dir = super::cantilever::rotate(axis * sigma, prev_dir).normalize();
                moved = true;
            }
        }
        let mut pn = prev_p + dir * d;
        if p.collision {
            let local = head_inv.transform_point3(pn);
            if setup.head.eval(local) < 0.0 {
                let lp = head_inv.transform_point3(prev_p);
                let la = head_inv.transform_vector3(prev_dir).normalize();
                let q = setup.head.push_out(lp, la, local, d);
                pn = f.head.transform_point3(q);
                dir = ((pn - prev_p) / d).normalize();
                pn = prev_p + dir * d;
                moved = true;
            }
        }
        // A correction (stiffness clamp, collision) is inelastic: the segment keeps the
        // corrected direction and loses its angular velocity, so a constraint neither injects
        // energy nor stores a velocity into the head that never happens.
        let (mut tho, mut pho) = (th, ph);
        if moved {
            (thn, phn) = angles_near(dir, thn, phn);
            (tho, pho) = (thn, phn);
        }
        let u = 0.5 * d;
        stats.kinetic += u * u * ((thn - tho).powi(2) + sth * sth * (phn - pho).powi(2)) / (h * h);
        let mut a = [thn, phn, tho, pho];
        rewrap(&mut a);
        angles[off + i as usize] = a;
        nodes[base + i as usize] = pn;
        prev_p = pn;
        prev_dir = dir;
    }
    stats
}
