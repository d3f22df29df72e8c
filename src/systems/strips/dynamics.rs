//! The motion of Kazama's strips (eq 1, eq 2): the f64 reference of
//! `shaders/strips/dynamics.wgsl` (run by `dynamics_gpu`).
//!
//! **Chain.** A strip is a chain of rigid sticks between its control points; the root point
//! rides the head. Each joint (one per stick) has two angular degrees of freedom, the
//! spherical angles (θ, φ) of its stick in a reference frame F carried by the parent stick
//! (the first stick's by the head pose): the stick's direction is
//! `F (sin θ cos φ, sin θ sin φ, cos θ)` and its body frame `B = F Rz(φ) Ry(θ)` carries the
//! next joint's frame, `F' = B C'` with `C'` a constant fixed at rest. We choose F so that
//! the rest direction lies on F's equator: its pole is the normal of the rest bending plane
//! (the parent direction, for the first stick the head normal, crossed with the stick), so
//! the rest angles Φ0 (computed from the rest points: (π/2, 0) up to rounding) sit 90° from
//! the coordinate poles. Straight rest chains then have no singular joint; φ bends a stick in
//! its rest bending plane (where gravity mostly pulls, and it may wind freely), θ out of it
//! (a pole only at a 90° sideways bend of one joint).
//!
//! **Eq 1 per DOF:** `I1 Φ'' + I2 Φ' + τ (Φ − Φ0) = H`. Our reading of the coefficients:
//! control points carry equal point masses m; `I1_j = inertia · M_j / M_1` where `M_j` is
//! the joint's outboard moment Σ |x_k − x_joint|² at rest, so the root joint has I1 =
//! `motion.inertia` and the tip less (the diagonal of the chain's mass matrix, held
//! constant); I2 scales the same way (air resistance acts on every point's velocity as mass
//! does, so every joint loses energy at the same rate `damping / inertia`); τ =
//! `motion.stiffness` × the layer's multiplier, tapering linearly to `stiffness_tip` of that
//! at the tip joint. H is the generalized force of the point forces on the outboard control
//! points: `H = m Σ_k a_k · ∂x_k/∂Φ = m w · Σ_k (x_k − x_joint) × a_k`, w the DOF's rotation
//! axis (virtual work; exact for the chain, no division anywhere), with `m = inertia / M_1`.
//!
//! **Integrator: exponential midpoint.** Per DOF the spring–damper part is solved exactly
//! (`Propagator`, the closed-form damped oscillator over a step with H held constant), so
//! any τ, I2 and dt are stable in it: the stiff joints near the root and the light joints at
//! the tip (whose ω0 = √(τ/I1) is large) need no small step. H is taken at a predicted
//! midpoint (a half step with H at the start, then the full step from the start with H at
//! the middle), which makes the scheme second order for the coupling through H (the order
//! `bench::strips::precision` measures on `Setup::gust` is in docs/strips.md). H itself is
//! explicit, so a stiff force bounds the step: the collision force of strips lying on the
//! head allows ~1/30 s at κ = 1 (`bench::strips::precision::largest_stable_dt`), 1/240 s
//! at κ = 1000. Steps run at the fixed rate `motion.steps_per_second`, rounded to a whole
//! number of steps per rendered frame (`steps_per_frame`), whatever the frame rate.
//!
//! **Forces (eq 2), accelerations at each control point** (world units / s²): gravity
//! `Forces::gravity` (the scene's `forces.gravity`); the wind Ω of `Forces::wind_at_point`
//! (uniform keyed wind + EFF); the
//! head motion Ξ, the inertial force of the head's acceleration at the point (the head
//! frame's acceleration at that material point, a second difference of the keyed pose over
//! ±max(frame_time, dt): linear keys have velocity kinks whose impulse this spreads over a
//! frame; Coriolis is left out); the spring S, our reading of `−k (L0 − L)`: a goal spring
//! `−k (x − x_rest)` toward the point's rest position carried by the head (pulls the shape
//! back; k = `motion.spring`, 0 turns it off); the collision Ψ (`collision_accel`, our
//! reading of the printed κ exp(l²/(j−l)²) that divides by zero at j = l); the extra forces
//! of key-frame edits (`ExtraForce`). After each step a control point inside the head hull
//! is moved out by rotating its stick about the joint (Anjyo's circle search,
//! `HeadHull::push_out`) and the joint's rate into the head is removed.
//!
//! **The hull** is the scene's `HeadHull`: the ellipsoid, or on a mesh head its signed
//! distance field (`scene::sdf`: trilinear samples, the gradient of the interpolant), for Ψ
//! and the push-out alike; `shaders/strips/dynamics.wgsl` reads the same field
//! (`shaders/common/sdf.wgsl`).

use super::RestStrip;
use crate::error::{KamiError, Result};
use crate::forces::Forces;
use crate::scene::head::Ellipsoid;
use crate::scene::hull::{head_hull, HeadHull};
use crate::scene::{Head, HeadKey, Interp, WindKey};
use crate::systems::strips::block::{check_layer_stiffness, Motion, MAX_STEPS_PER_FRAME};
use glam::{DMat3, DMat4, DVec3, DVec4};
use std::f64::consts::{PI, TAU};

/// Most extra forces the GPU kernel takes (a uniform array; `dynamics_gpu` refuses more).
pub const MAX_EXTRA: usize = 16;
/// Ψ at the head's surface for κ = 1 (world units / s²): twice standard gravity in cm, so
/// κ = 1 holds a strip off the head against gravity within the band.
pub const COLLISION_ACCEL: f64 = 2000.0;
/// Width of the band outside the head where Ψ acts, as a share of the strip's mean stick.
pub const COLLISION_BAND: f64 = 0.5;

/// Ψ, our reading (head-local): with d the signed distance to the hull (first-order,
/// `E / |∇E|`, negative inside: for a mesh head's SDF the field's value over its gradient's
/// length, which is near 1) and δ the band, `u = (δ − d) / δ` and
/// `Ψ = κ · COLLISION_ACCEL · u² · n` for u > 0, else 0 (n the outward normal). Zero from
/// the band's edge out, growing smoothly (C¹) with depth, finite everywhere, at the surface
/// (where the printed formula divides by zero) κ · COLLISION_ACCEL. κ = 0 turns it off.
pub fn collision_accel(hull: &HeadHull, local: DVec3, band: f64, kappa: f64) -> DVec3 {
    if kappa <= 0.0 || band <= 0.0 {
        return DVec3::ZERO;
    }
    let g = hull.gradient(local);
    let gl = g.length();
    let (d, n) = match hull {
        HeadHull::Ellipsoid(e) => {
            let min_r = e.radii.min_element();
            if gl > 1e-12 / min_r {
                (e.eval(local) / gl, g / gl)
            } else {
                // The centre: deepest, any direction; up.
                (-min_r, DVec3::Y)
            }
        }
        HeadHull::Sdf(f) => {
            if gl > 1e-12 {
                (f.sample(local) / gl, g / gl)
            } else {
                // A flat spot of the field (cells of equal values): its value, up.
                (f.sample(local), DVec3::Y)
            }
        }
    };
    let u = (band - d) / band;
    if u <= 0.0 {
        return DVec3::ZERO;
    }
    n * (kappa * COLLISION_ACCEL * u * u)
}

/// An extra force of a key-frame edit (section 4, eq 4; the lead's solver sets `accel`). It
/// acts on the control points of every strip near `center` (world): `accel · s(|x − center|
/// / radius) · r(frame)` with s(u) = (1 − u²)³ for u < 1 else 0. In time it rises from the
/// first key to the second, r = sin²(π/2 · (f − from)/(to − from)), is whole at `to` (so
/// the strip is held at its target at the second key), and lets go over half the edit's
/// length after it, r = cos²(π/2 · (f − to)/release) with release = (to − from)/2. Both s
/// and r are smooth (r has zero slope at from, to and to + release), so the acceleration it
/// adds has no jump in space or time. `strip` names the edited strip (informational).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExtraForce {
    pub strip: u32,
    pub from: f64,
    pub to: f64,
    pub center: DVec3,
    pub radius: f64,
    pub accel: DVec3,
}

impl ExtraForce {
    /// Frames after `to` over which the force lets go.
    pub fn release(&self) -> f64 {
        0.5 * (self.to - self.from)
    }

    /// r(frame): 0 before `from`, rising to 1 at `to`, back to 0 at `to + release`.
    pub fn ramp(&self, frame: f64) -> f64 {
        let span = self.to - self.from;
        if span <= 0.0 || frame <= self.from {
            return 0.0;
        }
        let half_pi = 0.5 * PI;
        if frame <= self.to {
            let s = (half_pi * (frame - self.from) / span).sin();
            return s * s;
        }
        let t = (frame - self.to) / self.release();
        if t >= 1.0 {
            return 0.0;
        }
        let c = (half_pi * t).cos();
        c * c
    }

    /// s(|x − center| / radius).
    pub fn falloff(&self, x: DVec3) -> f64 {
        let positive = self.radius > 0.0;
        if !positive {
            return 0.0;
        }
        let u2 = (x - self.center).length_squared() / (self.radius * self.radius);
        if u2 >= 1.0 {
            return 0.0;
        }
        let w = 1.0 - u2;
        w * w * w
    }

    /// The acceleration it adds at world point `x` at `frame`.
    pub fn accel_at(&self, x: DVec3, frame: f64) -> DVec3 {
        let r = self.ramp(frame);
        if r == 0.0 {
            return DVec3::ZERO;
        }
        self.accel * (r * self.falloff(x))
    }
}

/// Extra forces must be finite with radius > 0 and to > from.
pub fn check_extra(extra: &[ExtraForce]) -> Result<()> {
    for (i, e) in extra.iter().enumerate() {
        let finite = e.from.is_finite()
            && e.to.is_finite()
            && e.center.is_finite()
            && e.radius.is_finite()
            && e.accel.is_finite();
        let bad = |value: String, allowed: &str| KamiError::Invalid {
            file: String::new(),
            field: format!("extra force {i} (strip {})", e.strip),
            value,
            allowed: allowed.into(),
        };
        if !finite {
            return Err(bad(format!("{e:?}"), "finite numbers"));
        }
        let positive = e.radius > 0.0;
        if !positive {
            return Err(bad(format!("radius {}", e.radius), "a radius > 0"));
        }
        let ordered = e.to > e.from;
        if !ordered {
            return Err(bad(
                format!("frames {}..{}", e.from, e.to),
                "a second key frame after the first",
            ));
        }
    }
    Ok(())
}

/// What a step reads besides the rig: the force fields, the clock, the head hull and the
/// forces' settings (`motion`'s gravity, spring, collision, sampling and frame time; the
/// joints' I1, I2 and τ were fixed by `Rig::new`: a new rig carries new ones).
#[derive(Clone, Copy)]
pub struct Env<'a> {
    pub forces: &'a Forces,
    /// Fractional frame at the step's start.
    pub frame: f64,
    /// The head's hull (`scene::hull::head_hull`): the ellipsoid or a mesh head's SDF.
    pub hull: &'a HeadHull,
    pub motion: &'a Motion,
    pub extra: &'a [ExtraForce],
}

/// The exact flow of `q'' + 2γ q' + ω² q = f` over a step h, f held constant:
/// `(q, v)(h) = m (q, v)(0) + (fq, fv) f`. Exact for every ω² >= 0 and γ >= 0 (under-,
/// critically and over-damped, τ = 0 too): the entries are computed without overflow or
/// cancellation (the over-damped modes through their roots, small arguments by series).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Propagator {
    pub m: [[f64; 2]; 2],
    pub fq: f64,
    pub fv: f64,
}

/// (eˣ − 1) / x.
fn phi1(x: f64) -> f64 {
    if x.abs() < 1e-8 {
        1.0 + 0.5 * x
    } else {
        x.exp_m1() / x
    }
}

impl Propagator {
    /// For I1, I2, τ: `Propagator::new(tau / i1, i2 / i1, h)`.
    pub fn new(omega2: f64, two_gamma: f64, h: f64) -> Propagator {
        let g = 0.5 * two_gamma;
        let w2 = omega2;
        let disc = w2 - g * g;
        // e = e^{-γh} C(h), s = e^{-γh} S(h): C, S the cosine and sine-over-frequency of the
        // undamped part (cos/sin, 1/h, cosh/sinh).
        let mut fq = None;
        let (e, s) = if disc > 0.0 {
            let b = disc.sqrt();
            let bh = b * h;
            let decay = (-g * h).exp();
            let sinc = if bh < 1e-6 { h } else { bh.sin() / b };
            (decay * bh.cos(), decay * sinc)
        } else {
            let k = (-disc).sqrt();
            let kh = k * h;
            if kh < 1.0 {
                let decay = (-g * h).exp();
                let sinhc = if kh < 1e-6 { h } else { kh.sinh() / k };
                (decay * kh.cosh(), decay * sinhc)
            } else {
                // Over-damped: the two real roots, the slow one without cancellation.
                let r1 = -w2 / (g + k);
                let r2 = -(g + k);
                let (a, b) = ((r1 * h).exp(), (r2 * h).exp());
                fq = Some(h * (phi1(r1 * h) - phi1(r2 * h)) / (2.0 * k));
                (0.5 * (a + b), (a - b) / (2.0 * k))
            }
        };
        let m00 = e + g * s;
        let fq = fq.unwrap_or_else(|| {
            if w2 * h * h >= 1e-2 {
                (1.0 - m00) / w2
            } else {
                // Taylor series of the response to f = 1 from rest (2γh <= ~2 here).
                let (mut e0, mut e1) = (0.0, 0.5 * h * h);
                let mut sum = e1;
                for n in 1..80 {
                    let n = n as f64;
                    let next = (-2.0 * g * h * e1 - w2 * h * h * e0 / (n + 1.0)) / (n + 2.0);
                    sum += next;
                    if next.abs() <= 1e-18 * sum.abs() && e1.abs() <= 1e-18 * sum.abs() {
                        break;
                    }
                    e0 = e1;
                    e1 = next;
                }
                sum
            }
        });
        Propagator {
            m: [[m00, s], [-w2 * s, e - g * s]],
            fq,
            fv: s,
        }
    }

    /// Advance (q − q_rest, q') by the step with constant forcing `f` (= H / I1).
    pub fn advance(&self, y: [f64; 2], f: f64) -> [f64; 2] {
        [
            self.m[0][0] * y[0] + self.m[0][1] * y[1] + self.fq * f,
            self.m[1][0] * y[0] + self.m[1][1] * y[1] + self.fv * f,
        ]
    }
}

/// One joint (stick) of a strip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Joint {
    /// Reference frame in the parent stick's body frame (the first stick: head-local).
    pub c: DMat3,
    pub len: f64,
    /// Φ0 = (θ0, φ0).
    pub rest: [f64; 2],
    /// Outboard moment M_j (world units²).
    pub moment: f64,
    pub i1: f64,
    pub i2: f64,
    pub tau: f64,
}

/// Public view of a joint's constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointInfo {
    /// Stick length.
    pub length: f64,
    /// Rest angles Φ0 = (θ0, φ0), radians.
    pub rest: [f64; 2],
    pub i1: f64,
    pub i2: f64,
    pub tau: f64,
    /// Outboard moment M_j at rest (world units²); I1 = m M_j.
    pub moment: f64,
}

/// One strip's place in the rig.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct StripRig {
    /// Root, head-local.
    pub root: DVec3,
    /// First joint in `Rig::joints`.
    pub first: usize,
    pub sticks: usize,
    /// Ψ's band (world units).
    pub band: f64,
    /// Rest control points, head-local (the spring's targets).
    pub rest: Vec<DVec3>,
    /// Mass per control point, `inertia / M_1`.
    pub mass: f64,
}

/// Per-step work arrays of one strip (kept to avoid allocating in the loop).
#[derive(Clone, Debug, Default)]
struct Scratch {
    x: Vec<DVec3>,
    wt: Vec<DVec3>,
    wp: Vec<DVec3>,
    f: Vec<[f64; 2]>,
    q: Vec<[f64; 2]>,
}

/// The head at one instant: pose, and the map from a world point to the acceleration of the
/// head frame there.
#[derive(Clone, Copy, Debug)]
pub(crate) struct HeadFrame {
    pub pose: DMat4,
    pub inverse: DMat4,
    pub accel: DMat4,
    pub frame: f64,
}

impl HeadFrame {
    /// At `frame`; the second difference spans ±`width` frames.
    pub fn at(forces: &Forces, motion: &Motion, frame: f64, width: f64) -> HeadFrame {
        let pose = forces.head_at(frame);
        let inverse = pose.inverse();
        let accel = if forces.head_moves() {
            let a = forces.head_at(frame + width);
            let b = forces.head_at(frame - width);
            let h = width * motion.frame_time;
            (a - pose * 2.0 + b) * (1.0 / (h * h)) * inverse
        } else {
            DMat4::ZERO
        };
        HeadFrame {
            pose,
            inverse,
            accel,
            frame,
        }
    }
}

/// The strips' chains and their state.
#[derive(Clone, Debug)]
pub struct Rig {
    pub(crate) strips: Vec<StripRig>,
    pub(crate) joints: Vec<Joint>,
    /// Angles per joint.
    pub(crate) q: Vec<[f64; 2]>,
    /// Angles of the groomed pose, where the state starts and resets (the rest angles Φ0
    /// unless gravity preloading moved those).
    pub(crate) start: Vec<[f64; 2]>,
    /// Angular rates per joint.
    pub(crate) v: Vec<[f64; 2]>,
    pub(crate) stride: usize,
    /// Head pose of the current state.
    pose: DMat4,
    /// Propagators (full, half step) per joint for the cached step length.
    props: Option<(f64, Vec<[Propagator; 2]>)>,
    scratch: Scratch,
}

fn invalid(field: String, value: String, allowed: &str) -> KamiError {
    KamiError::Invalid {
        file: String::new(),
        field,
        value,
        allowed: allowed.into(),
    }
}

/// The motion's numbers are checked by the strips block's one check (the scene validator's,
/// with its bounds and messages); `Rig::new` and the GPU pass run it on motions built in code.
pub use crate::systems::strips::block::check_motion;

/// Steps per rendered frame: the rate rounded to a whole number per frame (at least one),
/// so frames land on steps.
pub fn steps_per_frame(m: &Motion) -> u32 {
    (m.frame_time * m.steps_per_second)
        .round()
        .clamp(1.0, MAX_STEPS_PER_FRAME) as u32
}

/// The step length `Rig::step` takes for `m` (seconds).
pub fn step_length(m: &Motion) -> f64 {
    m.frame_time / steps_per_frame(m) as f64
}

/// Rz(φ) Ry(θ): maps e_z to (sin θ cos φ, sin θ sin φ, cos θ).
fn rot(theta: f64, phi: f64) -> DMat3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    DMat3::from_cols(
        DVec3::new(cp * ct, sp * ct, -st),
        DVec3::new(-sp, cp, 0.0),
        DVec3::new(cp * st, sp * st, ct),
    )
}

/// Angles of unit direction `d` in frame `f`.
fn angles_in(f: &DMat3, d: DVec3) -> [f64; 2] {
    [
        f.z_axis.dot(d).clamp(-1.0, 1.0).acos(),
        f.y_axis.dot(d).atan2(f.x_axis.dot(d)),
    ]
}

/// Of the two angle pairs naming direction (θa, φa) — (θa, φa) and (−θa, φa + π), modulo
/// 2π — the one nearest `old` (so the body frame, and the children, move continuously).
fn nearest_angles(a: [f64; 2], old: [f64; 2]) -> [f64; 2] {
    let wrap = |x: f64| x - TAU * (x / TAU).round();
    let mut best = old;
    let mut dist = f64::INFINITY;
    for (t, p) in [(a[0], a[1]), (-a[0], a[1] + PI)] {
        let c = [old[0] + wrap(t - old[0]), old[1] + wrap(p - old[1])];
        let d = (c[0] - old[0]).powi(2) + (c[1] - old[1]).powi(2);
        if d < dist {
            dist = d;
            best = c;
        }
    }
    best
}

fn mat3(m: &DMat4) -> DMat3 {
    DMat3::from_mat4(*m)
}

fn point(m: &DMat4, x: DVec3) -> DVec3 {
    (*m * DVec4::new(x.x, x.y, x.z, 1.0)).truncate()
}

impl Rig {
    /// Chains for `rest` (head rest frame) with the joints' constants from `motion`.
    pub fn new(rest: &[RestStrip], motion: &Motion) -> Result<Rig> {
        check_motion(motion)?;
        let mut strips = Vec::with_capacity(rest.len());
        let mut joints = Vec::new();
        let mut stride = 0;
        for (i, s) in rest.iter().enumerate() {
            let field = |what: &str| format!("rest strip {i} (layer {}) {what}", s.layer);
            if s.points.len() < 2 {
                return Err(invalid(
                    field("points"),
                    format!("{} points", s.points.len()),
                    "at least 2 control points (one stick)",
                ));
            }
            if let Some(k) = s.points.iter().position(|p| !p.is_finite()) {
                return Err(invalid(
                    field(&format!("point {k}")),
                    format!("{}", s.points[k]),
                    "finite coordinates",
                ));
            }
            // The layer's bound (a rest strip carries its layer's multiplier).
            check_layer_stiffness(&field("stiffness"), s.stiffness)?;
            let normal = s.normal.normalize_or_zero();
            if !s.normal.is_finite() || normal == DVec3::ZERO {
                return Err(invalid(
                    field("normal"),
                    format!("{}", s.normal),
                    "a finite non-zero head normal",
                ));
            }
            let scale = s
                .points
                .iter()
                .fold(1.0f64, |m, p| m.max(p.abs().max_element()));
            for k in 1..s.points.len() {
                if (s.points[k] - s.points[k - 1]).length() <= 1e-9 * scale {
                    return Err(invalid(
                        field(&format!("points {} and {k}", k - 1)),
                        format!("{}", s.points[k]),
                        "distinct consecutive control points (sticks of length > 0)",
                    ));
                }
            }
            let n = s.points.len() - 1;
            let first = joints.len();
            let p = &s.points;
            let moment = |j: usize| -> f64 {
                (j + 1..=n)
                    .map(|k| (p[k] - p[j]).length_squared())
                    .sum::<f64>()
            };
            let m1 = moment(0);
            let tau_root = motion.stiffness * s.stiffness;
            // Absolute rest frames: B_{j-1} of the parent (head rest frame for the root).
            let mut parent_b = DMat3::IDENTITY;
            let mut parent_dir = normal;
            let mut pole_prev: Option<DVec3> = None;
            let mut total = 0.0;
            for j in 0..n {
                let d = p[j + 1] - p[j];
                let len = d.length();
                total += len;
                let d = d / len;
                let cross = parent_dir.cross(d);
                let pole = if cross.length() > 1e-3 {
                    cross.normalize()
                } else {
                    pole_prev
                        .map(|c| c - c.dot(d) * d)
                        .filter(|c| c.length() > 1e-3)
                        .map(|c| c.normalize())
                        .unwrap_or_else(|| d.any_orthonormal_vector())
                };
                let f_abs = DMat3::from_cols(d, pole.cross(d), pole);
                let c = parent_b.transpose() * f_abs;
                let rest_angles = angles_in(&f_abs, d);
                let share = if n > 1 {
                    j as f64 / (n - 1) as f64
                } else {
                    0.0
                };
                let mj = moment(j);
                joints.push(Joint {
                    c,
                    len,
                    rest: rest_angles,
                    moment: mj,
                    i1: motion.inertia * mj / m1,
                    i2: motion.damping * mj / m1,
                    tau: tau_root * (1.0 - (1.0 - motion.stiffness_tip) * share),
                });
                parent_b = f_abs * rot(rest_angles[0], rest_angles[1]);
                parent_dir = d;
                pole_prev = Some(pole);
            }
            stride = stride.max(n + 1);
            strips.push(StripRig {
                root: p[0],
                first,
                sticks: n,
                band: COLLISION_BAND * total / n as f64,
                rest: p.clone(),
                mass: motion.inertia / m1,
            });
        }
        let q: Vec<[f64; 2]> = joints.iter().map(|j| j.rest).collect();
        let start = q.clone();
        let v = vec![[0.0; 2]; joints.len()];
        let scratch = Scratch {
            x: vec![DVec3::ZERO; stride],
            wt: vec![DVec3::ZERO; stride],
            wp: vec![DVec3::ZERO; stride],
            f: vec![[0.0; 2]; stride],
            q: vec![[0.0; 2]; stride],
        };
        Ok(Rig {
            strips,
            joints,
            q,
            start,
            v,
            stride,
            pose: DMat4::IDENTITY,
            props: None,
            scratch,
        })
    }

    /// `new`, then gravity preloading on `head` under the scene's `gravity`
    /// (`Forces::gravity`) when `motion.preload` asks for it: the rig every simulation of a
    /// scene uses (CPU reference and GPU alike).
    pub fn posed(rest: &[RestStrip], motion: &Motion, head: &Head, gravity: DVec3) -> Result<Rig> {
        let mut rig = Rig::new(rest, motion)?;
        if motion.preload {
            rig.preload(motion, &head_hull(head)?, gravity);
        }
        Ok(rig)
    }

    /// Gravity preloading (`Motion::preload`): move each joint's rest angles Φ0 so that
    /// τ (Φg − Φ0) = H(Φg), the generalized force in the groomed pose Φg of gravity and of
    /// the hull's penalty band (groomed points lie outside the hull, but may lie in the
    /// band) on a still head in still air; the strips then hold Φg (the state starts and
    /// resets there). Wind, the EFF and head motion are what move them. The spring is zero
    /// at Φg. Joints with τ = 0 cannot hold a shape and keep Φ0 = Φg. H is taken with the
    /// head at its rest pose: head keys whose first pose is turned (not a capture, which
    /// starts at rest) see gravity from another side and swing from frame 0. Called on a
    /// fresh rig (state at Φg) by `posed`.
    fn preload(&mut self, motion: &Motion, hull: &HeadHull, gravity: DVec3) {
        let still = Forces {
            gravity,
            wind: Vec::new(),
            head_motion: Vec::new(),
            center: DVec3::ZERO,
            eff: None,
        };
        let still_motion = Motion {
            spring: 0.0,
            ..motion.clone()
        };
        let env = Env {
            forces: &still,
            frame: 0.0,
            hull,
            motion: &still_motion,
            extra: &[],
        };
        for s in 0..self.strips.len() {
            let h = self.generalized_forces(&env, s);
            let first = self.strips[s].first;
            for (j, hj) in h.iter().enumerate() {
                let jt = &mut self.joints[first + j];
                if jt.tau > 1e-12 && hj.iter().all(|x| x.is_finite()) {
                    jt.rest = [jt.rest[0] - hj[0] / jt.tau, jt.rest[1] - hj[1] / jt.tau];
                }
            }
        }
    }

    /// Points per strip in `points()` (the longest strip's control points).
    pub fn stride(&self) -> usize {
        self.stride
    }

    pub fn strip_count(&self) -> usize {
        self.strips.len()
    }

    /// Sticks (joints) of strip `s`.
    pub fn sticks(&self, s: usize) -> usize {
        self.strips[s].sticks
    }

    /// Back to the groomed pose (the start angles, which differ from the rest angles Φ0
    /// under gravity preloading), no motion, head at its rest pose.
    pub fn reset(&mut self) {
        self.q.clone_from(&self.start);
        self.v.iter_mut().for_each(|v| *v = [0.0; 2]);
        self.pose = DMat4::IDENTITY;
    }

    /// Place the head (the roots ride it) without moving the angles: `simulate` puts the
    /// head at its frame-0 pose before the first step.
    pub fn set_pose(&mut self, pose: DMat4) {
        self.pose = pose;
    }

    /// Head pose of the current state.
    pub fn pose(&self) -> DMat4 {
        self.pose
    }

    /// Angles (θ, φ) of strip `s`'s joints, root first.
    pub fn angles(&self, s: usize) -> &[[f64; 2]] {
        let st = &self.strips[s];
        &self.q[st.first..st.first + st.sticks]
    }

    /// Angular rates of strip `s`'s joints.
    pub fn rates(&self, s: usize) -> &[[f64; 2]] {
        let st = &self.strips[s];
        &self.v[st.first..st.first + st.sticks]
    }

    /// Set strip `s`'s angles and rates (tests start from a displaced state).
    pub fn set_state(&mut self, s: usize, angles: &[[f64; 2]], rates: &[[f64; 2]]) -> Result<()> {
        let st = self.strips.get(s).ok_or_else(|| {
            invalid(
                "strip".into(),
                s.to_string(),
                &format!("an index below {}", self.strips.len()),
            )
        })?;
        if angles.len() != st.sticks || rates.len() != st.sticks {
            return Err(invalid(
                format!("strip {s} state"),
                format!("{} angles, {} rates", angles.len(), rates.len()),
                &format!("{} of each", st.sticks),
            ));
        }
        if !angles.iter().chain(rates).flatten().all(|x| x.is_finite()) {
            return Err(invalid(
                format!("strip {s} state"),
                "non-finite".into(),
                "finite angles and rates",
            ));
        }
        let r = st.first..st.first + st.sticks;
        self.q[r.clone()].copy_from_slice(angles);
        self.v[r].copy_from_slice(rates);
        Ok(())
    }

    /// Constants of joint `j` of strip `s`.
    pub fn joint(&self, s: usize, j: usize) -> JointInfo {
        let jt = &self.joints[self.strips[s].first + j];
        JointInfo {
            length: jt.len,
            rest: jt.rest,
            i1: jt.i1,
            i2: jt.i2,
            tau: jt.tau,
            moment: jt.moment,
        }
    }

    /// Mass of one control point of strip `s` (`inertia / M_1`).
    pub fn mass(&self, s: usize) -> f64 {
        self.strips[s].mass
    }

    /// Length of strip `s` (sum of its sticks).
    pub fn length(&self, s: usize) -> f64 {
        let st = &self.strips[s];
        self.joints[st.first..st.first + st.sticks]
            .iter()
            .map(|j| j.len)
            .sum()
    }

    /// Forward kinematics of strip `s` with angles `q` under `pose`: points into `x`
    /// (`sticks + 1`), the DOFs' rotation axes into `wt`, `wp`.
    fn chain(
        &self,
        s: usize,
        q: &[[f64; 2]],
        pose: &DMat4,
        x: &mut [DVec3],
        wt: &mut [DVec3],
        wp: &mut [DVec3],
    ) {
        let st = &self.strips[s];
        let mut parent = mat3(pose);
        x[0] = point(pose, st.root);
        for j in 0..st.sticks {
            let jt = &self.joints[st.first + j];
            let f = parent * jt.c;
            let [theta, phi] = q[j];
            let (sp, cp) = phi.sin_cos();
            let b = f * rot(theta, phi);
            x[j + 1] = x[j] + jt.len * b.z_axis;
            wt[j] = f * DVec3::new(-sp, cp, 0.0);
            wp[j] = f.z_axis;
            parent = b;
        }
    }

    /// Acceleration (eq 2) at control point `k` (>= 1) of strip `s` at world `x`.
    fn accel(&self, env: &Env, hf: &HeadFrame, s: usize, k: usize, x: DVec3) -> DVec3 {
        let m = env.motion;
        let st = &self.strips[s];
        let mut a = env.forces.gravity;
        a += env.forces.wind_at_point(x, hf.frame, m.sampling);
        a -= (hf.accel * DVec4::new(x.x, x.y, x.z, 1.0)).truncate();
        if m.spring > 0.0 {
            a -= m.spring * (x - point(&hf.pose, st.rest[k]));
        }
        if m.collision > 0.0 {
            let local = point(&hf.inverse, x);
            let psi = collision_accel(env.hull, local, st.band, m.collision);
            a += mat3(&hf.pose) * psi;
        }
        for e in env.extra {
            a += e.accel_at(x, hf.frame);
        }
        a
    }

    /// f = H / I1 per DOF of strip `s` for the points `x` and axes in the scratch.
    fn forcing(&self, env: &Env, hf: &HeadFrame, s: usize, sc: &mut Scratch) {
        let st = &self.strips[s];
        let mut sum = DVec3::ZERO;
        let mut torque = DVec3::ZERO;
        for j in (0..st.sticks).rev() {
            sum += self.accel(env, hf, s, j + 1, sc.x[j + 1]);
            torque += (sc.x[j + 1] - sc.x[j]).cross(sum);
            let mj = self.joints[st.first + j].moment;
            sc.f[j] = [sc.wt[j].dot(torque) / mj, sc.wp[j].dot(torque) / mj];
        }
    }

    fn propagators(&mut self, dt: f64) {
        if matches!(&self.props, Some((h, _)) if *h == dt) {
            return;
        }
        self.props = Some((dt, self.propagator_table(dt)));
    }

    /// (full step, half step) propagators of every joint for step `dt`.
    pub(crate) fn propagator_table(&self, dt: f64) -> Vec<[Propagator; 2]> {
        self.joints
            .iter()
            .map(|j| {
                let (w2, g2) = (j.tau / j.i1, j.i2 / j.i1);
                [
                    Propagator::new(w2, g2, dt),
                    Propagator::new(w2, g2, 0.5 * dt),
                ]
            })
            .collect()
    }

    /// The generalized forces H (eq 1 units) on every DOF of strip `s` in the current
    /// state at `env.frame` (tests check equilibria with it).
    pub fn generalized_forces(&self, env: &Env, s: usize) -> Vec<[f64; 2]> {
        let st = &self.strips[s];
        let width = 1.0;
        let hf = HeadFrame::at(env.forces, env.motion, env.frame, width);
        let mut sc = self.scratch.clone();
        let q = &self.q[st.first..st.first + st.sticks];
        self.chain(s, q, &self.pose, &mut sc.x, &mut sc.wt, &mut sc.wp);
        self.forcing(env, &hf, s, &mut sc);
        (0..st.sticks)
            .map(|j| {
                let i1 = self.joints[st.first + j].i1;
                [sc.f[j][0] * i1, sc.f[j][1] * i1]
            })
            .collect()
    }

    /// One step of `dt` seconds from `env.frame` (exponential midpoint, then the hull
    /// constraint). A step that is not finite and positive does nothing.
    pub fn step(&mut self, env: &Env, dt: f64) {
        if !(dt > 0.0 && dt.is_finite()) {
            return;
        }
        self.propagators(dt);
        let ft = env.motion.frame_time;
        let width = (dt / ft).max(1.0);
        let f0 = env.frame;
        let h0 = HeadFrame::at(env.forces, env.motion, f0, width);
        let hm = HeadFrame::at(env.forces, env.motion, f0 + 0.5 * dt / ft, width);
        let end = env.forces.head_at(f0 + dt / ft);
        let hull = env.hull;
        let mut sc = std::mem::take(&mut self.scratch);
        let (_, props) = self.props.take().expect("propagators were just made");
        for s in 0..self.strips.len() {
            let (first, n) = (self.strips[s].first, self.strips[s].sticks);
            // H at the start, half step.
            let q0 = &self.q[first..first + n];
            self.chain(s, q0, &h0.pose, &mut sc.x, &mut sc.wt, &mut sc.wp);
            self.forcing(env, &h0, s, &mut sc);
            for j in 0..n {
                let (jt, p) = (&self.joints[first + j], &props[first + j][1]);
                let (q, v) = (self.q[first + j], self.v[first + j]);
                for d in 0..2 {
                    sc.q[j][d] = jt.rest[d] + p.advance([q[d] - jt.rest[d], v[d]], sc.f[j][d])[0];
                }
            }
            // H at the predicted middle, full step from the start.
            let qm = std::mem::take(&mut sc.q);
            self.chain(s, &qm, &hm.pose, &mut sc.x, &mut sc.wt, &mut sc.wp);
            sc.q = qm;
            self.forcing(env, &hm, s, &mut sc);
            for j in 0..n {
                let (jt, p) = (&self.joints[first + j], &props[first + j][0]);
                let (q, v) = (&mut self.q[first + j], &mut self.v[first + j]);
                for d in 0..2 {
                    let y = p.advance([q[d] - jt.rest[d], v[d]], sc.f[j][d]);
                    q[d] = jt.rest[d] + y[0];
                    v[d] = y[1];
                }
            }
            self.constrain(s, &end, hull);
        }
        self.props = Some((dt, props));
        self.scratch = sc;
        self.pose = end;
    }

    /// Keep strip `s`'s control points out of the head: root to tip, a point inside the
    /// posed hull swings about its joint to the nearest outside point on its circle
    /// (`HeadHull::push_out`, in the plane of the previous stick, for the first stick of
    /// the hull normal), the angles follow, and the joint's rate into the head is removed.
    fn constrain(&mut self, s: usize, pose: &DMat4, hull: &HeadHull) {
        let st = &self.strips[s];
        let (first, n) = (st.first, st.sticks);
        let r = mat3(pose);
        let inv = pose.inverse();
        let mut parent = r;
        let mut x = point(pose, st.root);
        let mut prev_dir: Option<DVec3> = None;
        for j in 0..n {
            let jt = self.joints[first + j];
            let f = parent * jt.c;
            let mut b = f * rot(self.q[first + j][0], self.q[first + j][1]);
            let mut next = x + jt.len * b.z_axis;
            let local = point(&inv, next);
            if hull.eval(local) < 0.0 {
                let pivot = point(&inv, x);
                let a0 = match prev_dir {
                    Some(d) => r.transpose() * d,
                    None => hull.normal(pivot),
                };
                let out = hull.push_out(pivot, a0, local, jt.len);
                let d = (r * (out - pivot)).normalize_or(b.z_axis);
                let q = nearest_angles(angles_in(&f, d), self.q[first + j]);
                self.q[first + j] = q;
                b = f * rot(q[0], q[1]);
                next = x + jt.len * b.z_axis;
                // No rate into the head at the new point.
                let arm = next - x;
                let (sp, cp) = q[1].sin_cos();
                let jt_ = (f * DVec3::new(-sp, cp, 0.0)).cross(arm);
                let jp = f.z_axis.cross(arm);
                let normal = r * hull.normal(out);
                let g = [normal.dot(jt_), normal.dot(jp)];
                let v = &mut self.v[first + j];
                let vn = g[0] * v[0] + g[1] * v[1];
                let g2 = g[0] * g[0] + g[1] * g[1];
                if vn < 0.0 && g2 > 1e-300 {
                    v[0] -= vn * g[0] / g2;
                    v[1] -= vn * g[1] / g2;
                }
            }
            prev_dir = Some(b.z_axis);
            parent = b;
            x = next;
        }
    }

    /// World positions of every control point, strip-major with `stride()` per strip;
    /// shorter strips repeat their tip in the unused slots.
    pub fn points(&self) -> Vec<DVec3> {
        let mut out = Vec::with_capacity(self.strips.len() * self.stride);
        let mut sc = self.scratch.clone();
        for (s, st) in self.strips.iter().enumerate() {
            let q = &self.q[st.first..st.first + st.sticks];
            self.chain(s, q, &self.pose, &mut sc.x, &mut sc.wt, &mut sc.wp);
            out.extend_from_slice(&sc.x[..=st.sticks]);
            let tip = sc.x[st.sticks];
            out.extend(std::iter::repeat_n(tip, self.stride - st.sticks - 1));
        }
        out
    }

    /// Largest angular rate of any DOF (NaN when any is not finite).
    pub fn max_rate(&self) -> f64 {
        self.v.iter().flatten().fold(0.0, |m: f64, r| {
            if r.is_finite() && m.is_finite() {
                m.max(r.abs())
            } else {
                f64::NAN
            }
        })
    }

    /// Run `frames` frames from the current state starting at `from` (frame index), with
    /// `steps_per_frame(motion)` steps each, against `hull` (`scene::hull::head_hull`).
    pub fn run_frames(
        &mut self,
        forces: &Forces,
        hull: &HeadHull,
        motion: &Motion,
        extra: &[ExtraForce],
        from: u64,
        frames: u32,
    ) {
        let spf = steps_per_frame(motion);
        let dt = motion.frame_time / spf as f64;
        for f in 0..frames as u64 {
            for i in 0..spf {
                let env = Env {
                    forces,
                    frame: (from + f) as f64 + i as f64 / spf as f64,
                    hull,
                    motion,
                    extra,
                };
                self.step(&env, dt);
            }
        }
    }
}

/// The clip: positions (as `Rig::points`) at frames 0..=frames (`frames + 1` entries; frame
/// 0 is the rest shape on the head's frame-0 pose), stepping at `motion.steps_per_second`.
/// What capture and key-frame editing use.
pub fn simulate(
    rest: &[RestStrip],
    motion: &Motion,
    forces: &Forces,
    head: &Head,
    extra: &[ExtraForce],
    frames: u32,
) -> Result<Vec<Vec<DVec3>>> {
    check_extra(extra)?;
    let hull = head_hull(head)?;
    let mut rig = Rig::posed(rest, motion, head, forces.gravity)?;
    rig.set_pose(forces.head_at(0.0));
    let mut out = Vec::with_capacity(frames as usize + 1);
    out.push(rig.points());
    for f in 0..frames as u64 {
        rig.run_frames(forces, &hull, motion, extra, f, 1);
        out.push(rig.points());
    }
    Ok(out)
}

/// A simple rest strip for tests and benches (`hom` builds the scene's): root on the head
/// ellipsoid at polar angle `polar` (degrees from the crown) and azimuth `azimuth` (degrees,
/// 0 the face +z, 90 the left +x), leaving along the normal and bending toward straight down
/// by `droop` (0..1) of the way, `sticks` sticks over `length`.
pub fn demo_strip(
    head: &Head,
    polar: f64,
    azimuth: f64,
    length: f64,
    sticks: u32,
    droop: f64,
) -> RestStrip {
    let hull = Ellipsoid::new(head.center, head.radii);
    let (t, a) = (polar.to_radians(), azimuth.to_radians());
    // Ellipsoid::point's azimuth runs from +x toward +z; ours from +z toward +x.
    let root = hull.point(t, PI / 2.0 - a);
    let normal = hull.normal(root);
    let n = sticks.max(1) as usize;
    let seg = length / n as f64;
    let mut points = vec![root];
    let mut p = root;
    for k in 0..n {
        let s = (k as f64 + 0.5) / n as f64;
        let w = (droop * (0.3 + 0.7 * s)).clamp(0.0, 1.0);
        let dir = (normal * (1.0 - w) + DVec3::NEG_Y * w).normalize_or(normal);
        p += dir * seg;
        // Keep the rest shape off the head (drooping strips follow its side).
        let out = hull.eval(p);
        if out < 0.02 {
            let q = (p - hull.center) / hull.radii;
            p = hull.center + q * ((1.02 / (out + 1.0)).sqrt()) * hull.radii;
        }
        points.push(p);
    }
    RestStrip {
        layer: 0,
        points,
        normal,
        width: [2.0, 0.5],
        stiffness: 1.0,
        color: [0.2, 0.1, 0.05],
    }
}

/// A representative scene for the solver's accuracy (tests, `bench::strips::precision`).
#[derive(Clone, Debug)]
pub struct Setup {
    pub rest: Vec<RestStrip>,
    pub motion: Motion,
    pub forces: Forces,
    pub head: Head,
    pub extra: Vec<ExtraForce>,
}

impl Setup {
    /// Six strips around the default head under gravity, a sideways gust (linear keys up
    /// and down), a head turn and a key-frame extra force: everything but the EFF moves
    /// them.
    pub fn gust() -> Setup {
        let head = Head::default();
        let rest = [
            (40.0, 0.0),
            (60.0, 90.0),
            (70.0, 180.0),
            (60.0, 270.0),
            (50.0, 45.0),
            (80.0, 135.0),
        ]
        .iter()
        .enumerate()
        .map(|(i, &(p, a))| demo_strip(&head, p, a, 18.0 + 2.0 * i as f64, 8, 0.6))
        .collect();
        let key = |frame: f64, force: [f64; 3]| WindKey {
            frame,
            force,
            interp: Interp::Linear,
        };
        let turn = |frame: f64, deg: f64| HeadKey {
            frame,
            rotate: [0.0, deg, 0.0],
            translate: [0.0; 3],
            interp: Interp::Linear,
        };
        let forces = Forces {
            gravity: DVec3::from(crate::scene::forces::EARTH_GRAVITY),
            wind: vec![
                key(0.0, [0.0; 3]),
                key(6.0, [600.0, 0.0, 300.0]),
                key(20.0, [200.0, 0.0, -200.0]),
                key(36.0, [0.0; 3]),
            ],
            head_motion: vec![
                turn(0.0, 0.0),
                turn(12.0, 25.0),
                turn(30.0, -10.0),
                turn(42.0, 0.0),
            ],
            center: DVec3::from(head.center),
            eff: None,
        };
        let extra = vec![ExtraForce {
            strip: 0,
            from: 10.0,
            to: 30.0,
            center: DVec3::new(0.0, 10.0, 20.0),
            radius: 15.0,
            accel: DVec3::new(0.0, 400.0, 200.0),
        }];
        Setup {
            rest,
            motion: Motion::default(),
            forces,
            head,
            extra,
        }
    }
}
