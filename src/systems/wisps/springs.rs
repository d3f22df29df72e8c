//! Sakai's mass springs (section 7), the f64 reference of `shaders/wisps/springs.wgsl`.
//!
//! **Lattice (Fig. 10).** Every skeleton node has a primary mass point at the node and 8 sub
//! mass points on a ring of radius r (the node's radius of influence) in the plane normal to
//! the skeleton's tangent (central differences; the ring's frame is parallel-transported
//! root to tip so rings do not twist). Springs join primary to primary along the chain, each
//! primary to its subs, each sub to its two ring neighbours and to the sub across, and each
//! sub to the primary and all 8 subs of the neighbouring nodes ("a connection between one
//! sub mass point and all neighbour points"). A bundle joins the primaries of its wisps
//! pairwise node to node below `release_from` (Fig. 10 bottom). The root node's 9 points
//! are kinematic: x = head(t) x_rest. Springs between two kinematic points are left out.
//!
//! **Layout.** All primaries first, in (skeleton, node) order (point `offsets[s] + i` is node
//! i of skeleton s), then the 8 subs of every node in the same order. The renderer reads the
//! primaries straight from the positions buffer.
//!
//! **Forces (eq 23, and the scene's shared fields).** f_p = sum_s k_s (l_s - l_s,natural)
//! d_s,p + (g + w(t) + e(x_p, t)) m_p - c_damp v_p, on primaries of mass `mass` and subs of
//! mass `mass * sub_mass`; time in seconds, one step is `frame_time / substeps`. g, w and e
//! are the scene's `Forces` (`crate::forces`), read as accelerations (world units / s²), as
//! the strips read them: g the shared gravity, w the keyed uniform wind (`forces::wind_at`)
//! and e the External Force Field sampled trilinearly at the point with its gust scale
//! (`Forces::eff_at`; `shaders/forces/eff.wgsl` on the GPU), all at the stage's time (RK4:
//! the step's start, middle, middle, end; semi-implicit Euler: its start). The paper has
//! gravity alone. Integrated by the paper's RK4 or by semi-implicit Euler (one force
//! evaluation a step); kinematic points take the head pose at each stage time, which is how
//! head motion acts (the lattice is integrated in world space).
//!
//! **Natural lengths (7.1, eq 24).** With `hold_shape`, sum_s k_s (l_s,init - l_s,nat) d_s,p
//! = -g m_p at every free point: 3 equations per point, one unknown per spring, fewer
//! equations than unknowns. The paper solves it with an SVD; we take the same minimum-norm
//! solution Delta = A^T (A A^T)^-1 b per connected component (bundles join components),
//! with a banded Cholesky of A A^T (points ordered by node index, so the band holds two node
//! layers: exact, and n bw^2 instead of the dense n^3) plus a tiny Tikhonov shift that lets
//! singular systems (a chain of primaries alone) factor, removed again by iterated
//! refinement. The residual is checked; natural lengths <= 0 are refused.
//!
//! **Ours, not the paper's:** the collision with the head (the paper lists it as future
//! work), against the scene's `HeadHull`: the ellipsoid, or a mesh head's signed distance
//! field (`scene::sdf`, `shaders/common/sdf.wgsl`). After each step a free point inside the
//! posed hull is moved back to the surface by Newton steps on the hull's implicit function
//! (quadric form or signed distance) along its gradient, to `1.5 eps_out` outside, and its
//! velocity into the surface (relative to the moving head) is removed. On a mesh head the
//! roots lie on its scalp (`wisps::block::on_mesh_head`, done by the caller).

use crate::error::{KamiError, Result};
use crate::forces::{wind_at, Forces};
use crate::scene::hull::{head_hull, HeadHull};
use crate::scene::Head;
use crate::scene::Sampling;
use crate::systems::wisps::block::{Integrator, Springs, Wisps};
use glam::{DMat4, DQuat, DVec3};
use std::collections::HashSet;

/// Sub mass points per node (Fig. 10).
pub const RING: usize = 8;
/// Newton steps of the collision push-out (the WGSL twin uses the same count).
pub const NEWTON: u32 = 8;
/// Eq 24 is refused when the relative residual stays above this.
pub const FIT_TOLERANCE: f64 = 1e-6;
/// How the springs sample the EFF (the GPU twin passes 1, trilinear, to `eff_field`).
pub const EFF_SAMPLING: Sampling = Sampling::Trilinear;

/// A mass point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Position in the head's rest frame (the drawn pose).
    pub rest: DVec3,
    pub mass: f64,
    /// Kinematic: follows the head instead of the forces.
    pub pinned: bool,
    /// Skeleton and node it belongs to (orders the eq 24 solve; names wisps in errors).
    pub skeleton: u32,
    pub node: u32,
}

/// A spring between points `a` and `b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spring {
    pub a: u32,
    pub b: u32,
    pub k: f64,
    /// Natural length l_natural.
    pub rest: f64,
}

/// How well eq 24 was met.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RestFit {
    /// max_p |sum_s k_s Delta_s d_s,p + g m_p| / max_p |g m_p|.
    pub residual: f64,
    /// Refinement passes used (largest over components).
    pub refinements: u32,
    /// Connected components solved.
    pub components: usize,
    /// Smallest l_natural / l_initial.
    pub min_ratio: f64,
    /// Largest l_natural / l_initial.
    pub max_ratio: f64,
}

/// The mass-spring lattice of a scene's wisps.
#[derive(Clone, Debug)]
pub struct Lattice {
    pub points: Vec<Point>,
    pub springs: Vec<Spring>,
    /// Prefix sums of node counts: primaries of skeleton s are `offsets[s]..offsets[s + 1]`.
    pub offsets: Vec<u32>,
    /// Wisp names for messages ("wisp 3 (`bang`)").
    pub names: Vec<String>,
    /// The eq 24 solve, when `hold_shape` ran.
    pub fit: Option<RestFit>,
    /// CSR adjacency: the neighbours of point p are `adj[adj_start[p]..adj_start[p + 1]]`,
    /// each (other point, spring). The GPU gathers over the same list.
    pub adj_start: Vec<u32>,
    pub adj: Vec<[u32; 2]>,
}

/// Positions and velocities of every point (world frame).
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    pub x: Vec<DVec3>,
    pub v: Vec<DVec3>,
}

impl State {
    /// The drawn pose, at rest.
    pub fn rest(lattice: &Lattice) -> State {
        State {
            x: lattice.points.iter().map(|p| p.rest).collect(),
            v: vec![DVec3::ZERO; lattice.points.len()],
        }
    }
}

/// Motion parameters (everything but the lattice and the forces): changing them needs no
/// new lattice. The forces (gravity, wind, EFF, head motion) are the scene's `Forces`,
/// passed to every step.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// c_damp.
    pub damping: f64,
    /// Seconds per frame.
    pub frame_time: f64,
    pub substeps: u32,
    pub integrator: Integrator,
    /// The head hull (ellipsoid or mesh SDF) when collision is on.
    pub hull: Option<HeadHull>,
}

impl Motion {
    /// The springs' settings on `head` (a mesh head's field is built, or taken from the
    /// cache, when collision is on).
    pub fn new(springs: &Springs, head: &Head) -> Result<Motion> {
        Ok(Motion {
            damping: springs.damping,
            frame_time: springs.frame_time,
            substeps: springs.substeps,
            integrator: springs.integrator,
            hull: if springs.collide {
                Some(head_hull(head)?)
            } else {
                None
            },
        })
    }
}

/// Tangents by central differences (one-sided at the ends).
fn tangents(p: &[DVec3]) -> Vec<DVec3> {
    let n = p.len();
    (0..n)
        .map(|i| {
            let a = p[i.saturating_sub(1)];
            let b = p[(i + 1).min(n - 1)];
            (b - a).normalize_or(DVec3::Y)
        })
        .collect()
}

/// Ring frames (u_i, v_i) normal to the tangents, u transported by the smallest rotation
/// from one tangent to the next so consecutive rings do not twist against each other.
fn ring_frames(t: &[DVec3]) -> Vec<(DVec3, DVec3)> {
    let mut out = Vec::with_capacity(t.len());
    let side = if t[0].cross(DVec3::Y).length() > 0.3 {
        DVec3::Y
    } else {
        DVec3::X
    };
    let mut u = side.cross(t[0]).normalize();
    for i in 0..t.len() {
        if i > 0 {
            u = DQuat::from_rotation_arc(t[i - 1], t[i]) * u;
            // Re-orthogonalise against rounding.
            u = (u - u.dot(t[i]) * t[i]).normalize();
        }
        out.push((u, t[i].cross(u)));
    }
    out
}

impl Lattice {
    /// A lattice from its parts (tests build small ones by hand); fills the adjacency.
    pub fn new(
        points: Vec<Point>,
        springs: Vec<Spring>,
        offsets: Vec<u32>,
        names: Vec<String>,
    ) -> Lattice {
        let n = points.len();
        let mut count = vec![0u32; n + 1];
        for s in &springs {
            count[s.a as usize + 1] += 1;
            count[s.b as usize + 1] += 1;
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut adj = vec![[0u32; 2]; count[n] as usize];
        for (si, s) in springs.iter().enumerate() {
            for (p, o) in [(s.a, s.b), (s.b, s.a)] {
                adj[fill[p as usize] as usize] = [o, si as u32];
                fill[p as usize] += 1;
            }
        }
        Lattice {
            points,
            springs,
            offsets,
            names,
            fit: None,
            adj_start: count,
            adj,
        }
    }

    /// The lattice of Fig. 10 for `wisps`, with natural lengths solved by eq 24 under the
    /// shared gravity `forces.gravity` when `springs.hold_shape`. `head` is only used to warn
    /// about free points drawn inside it. On a mesh head, pass the wisps placed on its scalp
    /// (`wisps::block::on_mesh_head`).
    pub fn build(
        wisps: &Wisps,
        springs: &Springs,
        head: &Head,
        forces: &Forces,
    ) -> Result<Lattice> {
        let mut offsets = vec![0u32];
        for sk in &wisps.skeletons {
            offsets.push(offsets.last().unwrap() + sk.nodes.len() as u32);
        }
        let primaries = *offsets.last().unwrap() as usize;
        let sub = |node: usize, j: usize| (primaries + RING * node + j % RING) as u32;
        let mut points = Vec::with_capacity(primaries * (1 + RING));
        let mut subs = Vec::with_capacity(primaries * RING);
        for (si, sk) in wisps.skeletons.iter().enumerate() {
            let p: Vec<DVec3> = sk.nodes.iter().map(|n| DVec3::from(n.p)).collect();
            let frames = ring_frames(&tangents(&p));
            for (i, node) in sk.nodes.iter().enumerate() {
                let pinned = i == 0;
                let at = |rest, mass| Point {
                    rest,
                    mass,
                    pinned,
                    skeleton: si as u32,
                    node: i as u32,
                };
                points.push(at(p[i], springs.mass));
                let (u, v) = frames[i];
                for j in 0..RING {
                    let a = std::f64::consts::TAU * j as f64 / RING as f64;
                    let q = p[i] + springs.ring * node.r * (a.cos() * u + a.sin() * v);
                    subs.push(at(q, springs.mass * springs.sub_mass));
                }
            }
        }
        points.extend(subs);
        let k = springs.stiffness;
        let mut list = Vec::new();
        let mut add = |a: u32, b: u32| {
            if !(points[a as usize].pinned && points[b as usize].pinned) {
                let rest = (points[a as usize].rest - points[b as usize].rest).length();
                list.push(Spring { a, b, k, rest });
            }
        };
        for (si, sk) in wisps.skeletons.iter().enumerate() {
            let o = offsets[si] as usize;
            for i in 0..sk.nodes.len() {
                let n = o + i;
                for j in 0..RING {
                    add(n as u32, sub(n, j));
                    add(sub(n, j), sub(n, j + 1));
                    if j < RING / 2 {
                        add(sub(n, j), sub(n, j + RING / 2));
                    }
                }
                if i + 1 < sk.nodes.len() {
                    let m = n + 1;
                    add(n as u32, m as u32);
                    for j in 0..RING {
                        add(sub(n, j), m as u32);
                        add(n as u32, sub(m, j));
                        for l in 0..RING {
                            add(sub(n, j), sub(m, l));
                        }
                    }
                }
            }
        }
        let mut joined = HashSet::new();
        for b in &wisps.bundles {
            for (x, &wa) in b.wisps.iter().enumerate() {
                for &wb in &b.wisps[x + 1..] {
                    let len = wisps.skeletons[wa].nodes.len();
                    let len = len.min(wisps.skeletons[wb].nodes.len());
                    for i in 0..b.release_from.min(len) {
                        let pa = offsets[wa] + i as u32;
                        let pb = offsets[wb] + i as u32;
                        if pa != pb && joined.insert((pa.min(pb), pa.max(pb))) {
                            add(pa, pb);
                        }
                    }
                }
            }
        }
        let names = wisps
            .skeletons
            .iter()
            .enumerate()
            .map(|(i, s)| {
                if s.name.is_empty() {
                    format!("wisp {i}")
                } else {
                    format!("wisp {i} (`{}`)", s.name)
                }
            })
            .collect();
        let mut lattice = Lattice::new(points, list, offsets, names);
        if springs.collide {
            let hull = head_hull(head)?;
            let inside = lattice
                .points
                .iter()
                .filter(|p| !p.pinned && hull.eval(p.rest) < 0.0)
                .count();
            if inside > 0 {
                log::warn!(
                    "{inside} wisp mass points are drawn inside the head: the collision moves \
                     them out at the first step (draw the wisps further out or lower node radii)"
                );
            }
        }
        if springs.hold_shape {
            lattice.hold_shape(forces.gravity, springs.stiffness)?;
        }
        Ok(lattice)
    }

    /// Number of primary points (they come first).
    pub fn primaries(&self) -> u32 {
        *self.offsets.last().unwrap_or(&0)
    }

    /// Spring forces plus gravity on every free point (eq 23 without damping), for checks.
    pub fn static_forces(&self, x: &[DVec3], gravity: DVec3) -> Vec<DVec3> {
        let mut f = vec![DVec3::ZERO; x.len()];
        for (p, fp) in f.iter_mut().enumerate() {
            if !self.points[p].pinned {
                *fp = self.spring_force(p, x) + gravity * self.points[p].mass;
            }
        }
        f
    }

    fn spring_force(&self, p: usize, x: &[DVec3]) -> DVec3 {
        let mut f = DVec3::ZERO;
        let xp = x[p];
        for &[o, s] in &self.adj[self.adj_start[p] as usize..self.adj_start[p + 1] as usize] {
            let s = &self.springs[s as usize];
            let d = x[o as usize] - xp;
            let l = d.length();
            if l > 0.0 {
                f += d * (s.k * (l - s.rest) / l);
            }
        }
        f
    }

    /// Eq 24: natural lengths that hold the drawn pose under `gravity`, the minimum-norm
    /// change from the drawn lengths, per connected component. `stiffness` only names the
    /// value to raise in the refusal. Fills `fit`.
    pub fn hold_shape(&mut self, gravity: DVec3, stiffness: f64) -> Result<RestFit> {
        let n = self.points.len();
        // Components over skeletons, joined by springs between free points of two skeletons.
        let skeletons = self.names.len().max(
            self.points
                .iter()
                .map(|p| p.skeleton as usize + 1)
                .max()
                .unwrap_or(0),
        );
        let mut parent: Vec<usize> = (0..skeletons).collect();
        fn find(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for s in &self.springs {
            let (a, b) = (&self.points[s.a as usize], &self.points[s.b as usize]);
            if !a.pinned && !b.pinned {
                let (ra, rb) = (
                    find(&mut parent, a.skeleton as usize),
                    find(&mut parent, b.skeleton as usize),
                );
                parent[ra] = rb;
            }
        }
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); skeletons];
        for p in 0..n {
            if !self.points[p].pinned {
                let c = find(&mut parent, self.points[p].skeleton as usize);
                members[c].push(p);
            }
        }
        let mut springs_of: Vec<Vec<usize>> = vec![Vec::new(); skeletons];
        for (si, s) in self.springs.iter().enumerate() {
            let a = &self.points[s.a as usize];
            let b = &self.points[s.b as usize];
            let free = if !a.pinned { a } else { b };
            if !free.pinned {
                springs_of[find(&mut parent, free.skeleton as usize)].push(si);
            }
        }
        let weight = self
            .points
            .iter()
            .filter(|p| !p.pinned)
            .map(|p| (gravity * p.mass).abs().max_element())
            .fold(0.0, f64::max);
        let mut fit = RestFit {
            residual: 0.0,
            refinements: 0,
            components: 0,
            min_ratio: f64::INFINITY,
            max_ratio: 0.0,
        };
        let mut delta = vec![0.0; self.springs.len()];
        for c in 0..skeletons {
            if members[c].is_empty() {
                continue;
            }
            fit.components += 1;
            let (res, passes) =
                self.solve_component(&mut members[c], &springs_of[c], gravity, &mut delta);
            fit.refinements = fit.refinements.max(passes);
            let rel = if weight > 0.0 { res / weight } else { res };
            if rel > fit.residual {
                fit.residual = rel;
            }
            // NaN fails too.
            if rel.is_nan() || rel > FIT_TOLERANCE {
                let name = &self.names[self.points[members[c][0]].skeleton as usize];
                return Err(KamiError::Invalid {
                    file: String::new(),
                    field: "wisps.springs.hold_shape".into(),
                    value: "true".into(),
                    allowed: format!(
                        "{name}: the springs cannot balance gravity in the drawn shape \
                         (eq 24 residual {rel:.2e} of a point's weight): the lattice has a \
                         free motion; turn hold_shape off"
                    ),
                });
            }
        }
        // Natural lengths from the drawn ones, and the stiffness that would keep them all
        // positive (the change Delta scales as 1/k for a uniform k).
        let drawn: Vec<f64> = self
            .springs
            .iter()
            .map(|s| (self.points[s.b as usize].rest - self.points[s.a as usize].rest).length())
            .collect();
        let mut worst: Option<(usize, f64)> = None;
        let mut need: f64 = 0.0;
        for (si, &l) in drawn.iter().enumerate() {
            let nat = l - delta[si];
            need = need.max(delta[si] / l);
            if nat <= 0.0 && worst.is_none_or(|(_, w)| delta[si] / l > w) {
                worst = Some((si, delta[si] / l));
            }
            fit.min_ratio = fit.min_ratio.min(nat / l);
            fit.max_ratio = fit.max_ratio.max(nat / l);
        }
        if let Some((si, _)) = worst {
            let s = self.springs[si];
            let (a, b) = (self.points[s.a as usize], self.points[s.b as usize]);
            let name = &self.names[a.skeleton as usize];
            return Err(KamiError::Invalid {
                file: String::new(),
                field: "wisps.springs.stiffness".into(),
                value: format!("{stiffness}"),
                allowed: format!(
                    "{name} cannot hold its drawn shape under gravity: a spring {} would need \
                     natural length {:.3} (drawn {:.3}); raise the stiffness above {:.4e} (the \
                     holding stretch shrinks as 1/stiffness), lighten the wisps (mass) or set \
                     hold_shape: false",
                    if a.node == b.node {
                        format!("in node {}", a.node)
                    } else {
                        format!("between nodes {} and {}", a.node, b.node)
                    },
                    drawn[si] - delta[si],
                    drawn[si],
                    stiffness * need,
                ),
            });
        }
        for (si, s) in self.springs.iter_mut().enumerate() {
            s.rest = drawn[si] - delta[si];
        }
        self.fit = Some(fit);
        Ok(fit)
    }

    /// Min-norm solve of one component; writes Delta of its springs, returns (max residual
    /// force, refinement passes).
    fn solve_component(
        &self,
        pts: &mut [usize],
        springs: &[usize],
        gravity: DVec3,
        delta: &mut [f64],
    ) -> (f64, u32) {
        // Order by node layer so a spring spans at most two layers of the band.
        pts.sort_by_key(|&p| (self.points[p].node, self.points[p].skeleton, p));
        let mut rank = vec![u32::MAX; self.points.len()];
        for (r, &p) in pts.iter().enumerate() {
            rank[p] = r as u32;
        }
        let n = 3 * pts.len();
        // Column s of A is k d (at a) and -k d (at b), d the unit vector from a to b.
        let cols: Vec<(usize, DVec3)> = springs
            .iter()
            .map(|&si| {
                let s = &self.springs[si];
                let d = self.points[s.b as usize].rest - self.points[s.a as usize].rest;
                (si, d / d.length() * s.k)
            })
            .collect();
        let mut bw = 2;
        for &(si, _) in &cols {
            let s = &self.springs[si];
            let (ra, rb) = (rank[s.a as usize], rank[s.b as usize]);
            if ra != u32::MAX && rb != u32::MAX {
                bw = bw.max(3 * ra.abs_diff(rb) as usize + 2);
            }
        }
        let w = bw + 1;
        // M = A A^T in lower band storage: m[i * w + (i - j)] for j <= i.
        let mut m = vec![0.0; n * w];
        for &(si, kd) in &cols {
            let s = &self.springs[si];
            let ends = [(rank[s.a as usize], 1.0), (rank[s.b as usize], -1.0)];
            for &(ri, si_) in &ends {
                if ri == u32::MAX {
                    continue;
                }
                for &(rj, sj) in &ends {
                    if rj == u32::MAX || rj > ri {
                        continue;
                    }
                    for x in 0..3 {
                        for y in 0..3 {
                            let (i, j) = (3 * ri as usize + x, 3 * rj as usize + y);
                            if j <= i {
                                m[i * w + (i - j)] += si_ * sj * kd[x] * kd[y];
                            }
                        }
                    }
                }
            }
        }
        let diag = (0..n).map(|i| m[i * w]).fold(0.0, f64::max);
        let eps = 1e-12 * diag.max(1e-300);
        let mut chol = m.clone();
        for i in 0..n {
            chol[i * w] += eps;
        }
        band_cholesky(&mut chol, n, bw);
        let mut b = vec![0.0; n];
        for (r, &p) in pts.iter().enumerate() {
            let g = -gravity * self.points[p].mass;
            b[3 * r..3 * r + 3].copy_from_slice(&g.to_array());
        }
        let apply_at = |y: &[f64]| -> Vec<f64> {
            // Delta = A^T y (per column).
            cols.iter()
                .map(|&(si, kd)| {
                    let s = &self.springs[si];
                    let mut v = 0.0;
                    for (r, sign) in [(rank[s.a as usize], 1.0), (rank[s.b as usize], -1.0)] {
                        if r != u32::MAX {
                            let r = 3 * r as usize;
                            v += sign * kd.dot(DVec3::new(y[r], y[r + 1], y[r + 2]));
                        }
                    }
                    v
                })
                .collect()
        };
        let apply_a = |d: &[f64]| -> Vec<f64> {
            let mut out = vec![0.0; n];
            for (c, &(si, kd)) in cols.iter().enumerate() {
                let s = &self.springs[si];
                for (r, sign) in [(rank[s.a as usize], 1.0), (rank[s.b as usize], -1.0)] {
                    if r != u32::MAX {
                        let r = 3 * r as usize;
                        for x in 0..3 {
                            out[r + x] += sign * kd[x] * d[c];
                        }
                    }
                }
            }
            out
        };
        let mut y = vec![0.0; n];
        let mut r = b.clone();
        let mut passes = 0;
        let target = 1e-12 * b.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let mut best = (f64::INFINITY, vec![0.0; cols.len()]);
        for pass in 1..=30 {
            passes = pass;
            let dy = band_solve(&chol, n, bw, &r);
            for i in 0..n {
                y[i] += dy[i];
            }
            let d = apply_at(&y);
            let ad = apply_a(&d);
            for i in 0..n {
                r[i] = b[i] - ad[i];
            }
            let res = r.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            // Stop at the target or once rounding stalls the refinement.
            let stalled = res > 0.5 * best.0;
            if res < best.0 {
                best = (res, d);
            }
            if res <= target || (stalled && best.0 <= 1e3 * target) {
                break;
            }
        }
        for (c, &(si, _)) in cols.iter().enumerate() {
            delta[si] = best.1[c];
        }
        (best.0, passes)
    }
}

/// In-place Cholesky of a symmetric positive definite band matrix (lower band storage,
/// half-bandwidth `bw`).
fn band_cholesky(m: &mut [f64], n: usize, bw: usize) {
    let w = bw + 1;
    for i in 0..n {
        for j in i.saturating_sub(bw)..=i {
            let mut s = m[i * w + (i - j)];
            for k in i.saturating_sub(bw).max(j.saturating_sub(bw))..j {
                s -= m[i * w + (i - k)] * m[j * w + (j - k)];
            }
            if i == j {
                m[i * w] = s.max(1e-300).sqrt();
            } else {
                m[i * w + (i - j)] = s / m[j * w];
            }
        }
    }
}

/// Solve L L^T x = b with the factor from `band_cholesky`.
fn band_solve(l: &[f64], n: usize, bw: usize, b: &[f64]) -> Vec<f64> {
    let w = bw + 1;
    let mut x = b.to_vec();
    for i in 0..n {
        let mut s = x[i];
        for k in i.saturating_sub(bw)..i {
            s -= l[i * w + (i - k)] * x[k];
        }
        x[i] = s / l[i * w];
    }
    for i in (0..n).rev() {
        let mut s = x[i];
        for k in i + 1..(i + bw + 1).min(n) {
            s -= l[k * w + (k - i)] * x[k];
        }
        x[i] = s / l[i * w];
    }
    x
}

/// The shared fields' acceleration at world point `x` at `frame` (fractional): gravity,
/// the keyed uniform wind and the EFF (trilinear, with its gust scale). What the kernel's
/// `field_accel` computes.
pub fn field_accel(forces: &Forces, x: DVec3, frame: f64) -> DVec3 {
    forces.gravity + wind_at(&forces.wind, frame) + forces.eff_at(x, frame, EFF_SAMPLING)
}

/// Accelerations of eq 23 (f_p / m_p) of the free points at `frame` (fractional), with the
/// scene's forces; kinematic points get zero.
pub fn accelerations(
    lattice: &Lattice,
    motion: &Motion,
    forces: &Forces,
    frame: f64,
    x: &[DVec3],
    v: &[DVec3],
) -> Vec<DVec3> {
    // The uniform part once; the EFF per point.
    let uniform = forces.gravity + wind_at(&forces.wind, frame);
    let eff = forces.eff.as_ref().map(|e| (e, e.scale_at(frame)));
    (0..x.len())
        .map(|p| {
            let pt = &lattice.points[p];
            if pt.pinned {
                DVec3::ZERO
            } else {
                let field = match eff {
                    Some((e, scale)) if scale != 0.0 => {
                        uniform + e.sample(x[p], EFF_SAMPLING) * scale
                    }
                    _ => uniform,
                };
                (lattice.spring_force(p, x) - motion.damping * v[p]) / pt.mass + field
            }
        })
        .collect()
}

fn pin(lattice: &Lattice, x: &mut [DVec3], head: DMat4) {
    for (xp, pt) in x.iter_mut().zip(&lattice.points) {
        if pt.pinned {
            *xp = head.transform_point3(pt.rest);
        }
    }
}

/// Move a head-local point that is inside the hull back onto it (to the implicit value
/// 1.5 `eps_out`: the quadric form, or the signed distance) by Newton steps along the
/// gradient. On the ellipsoid the first step from inside lands outside (the quadric is
/// convex) and the rest converge from outside; a signed distance has a unit gradient, so
/// one step lands on the level set up to the field's curvature within a cell.
pub fn push_out(hull: &HeadHull, q: DVec3) -> DVec3 {
    let eps = hull.eps_out();
    let target = 1.5 * eps;
    let mut q = q;
    for _ in 0..NEWTON {
        let e = hull.eval(q);
        if (eps..=2.0 * eps).contains(&e) {
            break;
        }
        let g = hull.gradient(q);
        let g2 = g.length_squared();
        if g2 < 1e-24 {
            // A flat spot (the ellipsoid's centre, a plateau of the field): any way out.
            q = match hull {
                HeadHull::Ellipsoid(h) => h.center + DVec3::Y * h.radii.y,
                HeadHull::Sdf(_) => q + DVec3::Y * (target - e),
            };
            continue;
        }
        q -= g * ((e - target) / g2);
    }
    if let HeadHull::Ellipsoid(h) = hull {
        let e = h.eval(q);
        if e < eps {
            // Not converged (never seen): scale out from the centre onto the quadric value.
            q = h.center + (q - h.center) * ((1.0 + target) / (e + 1.0).max(1e-12)).sqrt();
        }
    }
    q
}

/// The collision (ours): a free point inside the head posed by `h1` is pushed out and loses
/// its velocity into the surface relative to the head moving from `h0` over `dt` seconds.
pub fn collide(
    hull: &HeadHull,
    h0: DMat4,
    h1: DMat4,
    h1_inv: DMat4,
    dt: f64,
    x: &mut DVec3,
    v: &mut DVec3,
) {
    let local = h1_inv.transform_point3(*x);
    if hull.eval(local) >= 0.0 {
        return;
    }
    let q = push_out(hull, local);
    *x = h1.transform_point3(q);
    let n = h1
        .transform_vector3(hull.gradient(q))
        .normalize_or(DVec3::Y);
    let surface = (h1.transform_point3(q) - h0.transform_point3(q)) / dt;
    let into = (*v - surface).dot(n);
    if into < 0.0 {
        *v -= into * n;
    }
}

/// One step of `dframes` frames from `frame` (fractional), with `motion.integrator`.
pub fn step(
    lattice: &Lattice,
    motion: &Motion,
    forces: &Forces,
    state: &mut State,
    frame: f64,
    dframes: f64,
) {
    let h = dframes * motion.frame_time;
    let h0 = forces.head_at(frame);
    let h1 = forces.head_at(frame + dframes);
    pin(lattice, &mut state.x, h0);
    let n = state.x.len();
    // Stage times (frames): the forces are read where the stages are.
    let (t0, tm, t1) = (frame, frame + 0.5 * dframes, frame + dframes);
    match motion.integrator {
        Integrator::SemiImplicitEuler => {
            let a = accelerations(lattice, motion, forces, t0, &state.x, &state.v);
            for (p, a) in a.iter().enumerate() {
                if !lattice.points[p].pinned {
                    state.v[p] += h * *a;
                    state.x[p] += h * state.v[p];
                }
            }
        }
        Integrator::Rk4 => {
            let hm = forces.head_at(tm);
            let (x0, v0) = (&state.x, &state.v);
            // x0 + c vs, v0 + c a; kinematic points at the stage's head pose.
            let stage = |vs: &[DVec3], a: &[DVec3], c: f64, head: DMat4| {
                let mut x = vec![DVec3::ZERO; n];
                let mut v = vec![DVec3::ZERO; n];
                for p in 0..n {
                    let pt = &lattice.points[p];
                    if pt.pinned {
                        x[p] = head.transform_point3(pt.rest);
                    } else {
                        x[p] = x0[p] + c * vs[p];
                        v[p] = v0[p] + c * a[p];
                    }
                }
                (x, v)
            };
            let a1 = accelerations(lattice, motion, forces, t0, x0, v0);
            let (x2, v2) = stage(v0, &a1, 0.5 * h, hm);
            let a2 = accelerations(lattice, motion, forces, tm, &x2, &v2);
            let (x3, v3) = stage(&v2, &a2, 0.5 * h, hm);
            let a3 = accelerations(lattice, motion, forces, tm, &x3, &v3);
            let (x4, v4) = stage(&v3, &a3, h, h1);
            let a4 = accelerations(lattice, motion, forces, t1, &x4, &v4);
            let dx: Vec<DVec3> = (0..n)
                .map(|p| v0[p] + 2.0 * v2[p] + 2.0 * v3[p] + v4[p])
                .collect();
            for p in 0..n {
                if !lattice.points[p].pinned {
                    let dv = a1[p] + 2.0 * a2[p] + 2.0 * a3[p] + a4[p];
                    state.x[p] += h / 6.0 * dx[p];
                    state.v[p] += h / 6.0 * dv;
                }
            }
        }
    }
    let h1_inv = h1.inverse();
    for p in 0..n {
        let pt = &lattice.points[p];
        if pt.pinned {
            let x = h1.transform_point3(pt.rest);
            state.v[p] = (x - state.x[p]) / h;
            state.x[p] = x;
        } else if let Some(hull) = &motion.hull {
            let (mut x, mut v) = (state.x[p], state.v[p]);
            collide(hull, h0, h1, h1_inv, h, &mut x, &mut v);
            state.x[p] = x;
            state.v[p] = v;
        }
    }
}

/// `frames` frames of `motion.substeps` steps each, from frame `from_frame`.
pub fn run_frames(
    lattice: &Lattice,
    motion: &Motion,
    forces: &Forces,
    state: &mut State,
    from_frame: u64,
    frames: u32,
) {
    let s = motion.substeps.max(1);
    for f in 0..frames as u64 {
        for k in 0..s {
            let frame = (from_frame + f) as f64 + k as f64 / s as f64;
            step(lattice, motion, forces, state, frame, 1.0 / s as f64);
        }
    }
}

/// Primary positions per skeleton (the nodes the renderer draws).
pub fn primaries(lattice: &Lattice, state: &State) -> Vec<Vec<DVec3>> {
    lattice
        .offsets
        .windows(2)
        .map(|w| state.x[w[0] as usize..w[1] as usize].to_vec())
        .collect()
}

/// Largest |x - y| over the primaries.
pub fn primary_error(lattice: &Lattice, a: &State, b: &State) -> f64 {
    let n = lattice.primaries() as usize;
    (0..n)
        .map(|p| (a.x[p] - b.x[p]).length())
        .fold(
            0.0,
            |m: f64, e| if e.is_nan() { f64::NAN } else { m.max(e) },
        )
}

/// Stays finite and every point within `reach` of its root's primary.
pub fn bounded(lattice: &Lattice, state: &State, reach: f64) -> bool {
    lattice.points.iter().zip(&state.x).all(|(pt, x)| {
        let root = state.x[lattice.offsets[pt.skeleton as usize] as usize];
        x.is_finite() && (*x - root).length() <= reach
    })
}

/// Twice the longest wisp (chain length plus radius): the `bounded` limit the work-precision
/// table uses to call a run unstable.
pub fn reach(lattice: &Lattice) -> f64 {
    let mut best: f64 = 0.0;
    for w in lattice.offsets.windows(2) {
        let mut len = 0.0;
        for p in w[0] as usize + 1..w[1] as usize {
            len += (lattice.points[p].rest - lattice.points[p - 1].rest).length();
        }
        let r = (w[0] as usize..w[1] as usize)
            .map(|p| {
                let s = lattice.primaries() as usize + RING * p;
                lattice
                    .points
                    .get(s)
                    .map_or(0.0, |q| (q.rest - lattice.points[p].rest).length())
            })
            .fold(0.0, f64::max);
        best = best.max(len + r);
    }
    2.0 * best
}

/// Largest angular frequency of the free lattice linearised at its rest pose (power
/// iteration on M^-1/2 K M^-1/2): sets the stability limit of explicit steps.
pub fn omega_max(lattice: &Lattice) -> f64 {
    let x: Vec<DVec3> = lattice.points.iter().map(|p| p.rest).collect();
    omega_max_at(lattice, &x)
}

/// `omega_max` linearised at the positions `x`: stretched springs stiffen sideways.
pub fn omega_max_at(lattice: &Lattice, x: &[DVec3]) -> f64 {
    let n = lattice.points.len();
    let inv_sqrt_m: Vec<f64> = lattice
        .points
        .iter()
        .map(|p| if p.pinned { 0.0 } else { 1.0 / p.mass.sqrt() })
        .collect();
    let apply = |u: &[DVec3]| -> Vec<DVec3> {
        let mut out = vec![DVec3::ZERO; n];
        for s in &lattice.springs {
            let (a, b) = (s.a as usize, s.b as usize);
            let d = x[b] - x[a];
            let l = d.length();
            let e = d / l;
            let du = u[b] * inv_sqrt_m[b] - u[a] * inv_sqrt_m[a];
            let t = 1.0 - s.rest / l;
            let f = s.k * (e * e.dot(du) + t * (du - e * e.dot(du)));
            out[a] += f * inv_sqrt_m[a];
            out[b] -= f * inv_sqrt_m[b];
        }
        out
    };
    let mut u: Vec<DVec3> = (0..n)
        .map(|i| {
            let h = crate::rng::pcg_hash(i as u32) as f64 / u32::MAX as f64;
            DVec3::new(h - 0.5, (h * 7.0).fract() - 0.5, (h * 13.0).fract() - 0.5)
                * inv_sqrt_m[i].signum()
        })
        .collect();
    let mut lambda: f64 = 0.0;
    for _ in 0..300 {
        let w = apply(&u);
        let un = u.iter().map(|v| v.length_squared()).sum::<f64>();
        let norm = w.iter().map(|v| v.length_squared()).sum::<f64>().sqrt();
        if norm == 0.0 || un == 0.0 {
            return 0.0;
        }
        // Rayleigh quotient of the symmetric operator (`apply` gives -K u): converges twice
        // as fast as |Ku|/|u|.
        lambda = -u.iter().zip(&w).map(|(a, b)| a.dot(*b)).sum::<f64>() / un;
        u = w.iter().map(|v| *v / norm).collect();
    }
    lambda.sqrt()
}

/// Largest speed of any point (NaN when any is not finite).
pub fn max_speed(state: &State) -> f64 {
    state.v.iter().fold(0.0, |m: f64, v| {
        let s = v.length();
        if s.is_finite() {
            m.max(s)
        } else {
            f64::NAN
        }
    })
}
