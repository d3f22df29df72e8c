//! The ellipsoidal hull (Anjyo step [alpha]): pores are placed in its polar coordinates and
//! hair is kept out of it by the sign of its quadric form E(p) = sum((p - c)_a / r_a)^2 - 1.

use glam::DVec3;
use std::f64::consts::PI;

/// An axis-aligned ellipsoid in head coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipsoid {
    pub center: DVec3,
    pub radii: DVec3,
}

/// Nodes are pushed this far outside (in units of E, i.e. about `EPS_OUT/2` of a radius), so
/// a pushed node tests outside even after rounding.
pub const EPS_OUT: f64 = 2e-4;

impl Ellipsoid {
    pub fn new(center: [f64; 3], radii: [f64; 3]) -> Self {
        Ellipsoid {
            center: DVec3::from(center),
            radii: DVec3::from(radii),
        }
    }

    /// The quadric form: negative inside, zero on the surface.
    pub fn eval(&self, p: DVec3) -> f64 {
        let q = (p - self.center) / self.radii;
        q.length_squared() - 1.0
    }

    /// Gradient of `eval` (Anjyo's D_i direction in 3.2.2).
    pub fn gradient(&self, p: DVec3) -> DVec3 {
        2.0 * (p - self.center) / (self.radii * self.radii)
    }

    /// Point at zenith `theta` (from +y) and azimuth `phi` (from +x towards +z), radians.
    pub fn point(&self, theta: f64, phi: f64) -> DVec3 {
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        self.center + self.radii * DVec3::new(st * cp, ct, st * sp)
    }

    /// Outward unit normal at a surface point.
    pub fn normal(&self, p: DVec3) -> DVec3 {
        self.gradient(p).normalize_or(DVec3::Y)
    }

    /// Surface area element relative to the unit sphere's at (theta, phi): |p_t x p_p| / sin t.
    pub fn area_factor(&self, theta: f64, phi: f64) -> f64 {
        let (a, b, c) = (self.radii.x, self.radii.y, self.radii.z);
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        ((b * c * st * cp).powi(2) + (a * c * ct).powi(2) + (a * b * st * sp).powi(2)).sqrt()
    }

    /// Upper bound of `area_factor`, for rejection sampling.
    pub fn area_factor_max(&self) -> f64 {
        let (a, b, c) = (self.radii.x, self.radii.y, self.radii.z);
        (b * c).max(a * c).max(a * b)
    }

    /// Polar angles (theta, phi) of a point, radians, phi in (-pi, pi].
    pub fn polar(&self, p: DVec3) -> (f64, f64) {
        let q = (p - self.center) / self.radii;
        let l = q.length().max(1e-300);
        ((q.y / l).clamp(-1.0, 1.0).acos(), q.z.atan2(q.x))
    }

    /// Anjyo's collision response: if `p` is inside, move it to the nearest point outside on
    /// the circle of radius `d` about `pivot` in the plane spanned by the previous segment
    /// direction `a0` and `p` (the plane of p(i-2), p(i-1), p(i)). When that plane
    /// degenerates (`p` straight along `a0`), the plane of `a0` and the hull normal at `p`
    /// is used instead. Returns `p` unchanged when it is outside.
    pub fn push_out(&self, pivot: DVec3, a0: DVec3, p: DVec3, d: f64) -> DVec3 {
        push_out_implicit(
            &|q| self.eval(q),
            &|q| self.gradient(q),
            EPS_OUT,
            pivot,
            a0,
            p,
            d,
        )
    }
}

/// Anjyo's collision response against any implicit hull `eval` (negative inside, gradient
/// `gradient`), nodes landing at least `eps` outside: the ellipsoid's quadric form, or a
/// mesh head's signed distance (`scene::hull::HeadHull`). See `Ellipsoid::push_out`.
pub fn push_out_implicit(
    eval: &dyn Fn(DVec3) -> f64,
    gradient: &dyn Fn(DVec3) -> DVec3,
    eps: f64,
    pivot: DVec3,
    a0: DVec3,
    p: DVec3,
    d: f64,
) -> DVec3 {
    {
        if eval(p) >= 0.0 {
            return p;
        }
        let w = p - pivot;
        let mut v = w - w.dot(a0) * a0;
        if v.length() <= 1e-9 * d {
            let g = gradient(p);
            v = g - g.dot(a0) * a0;
            if v.length() <= 1e-12 * g.length().max(1e-300) {
                v = a0.any_orthonormal_vector();
            }
        }
        let v = v.normalize();
        let phi0 = w.dot(v).atan2(w.dot(a0));
        let at = |phi: f64| pivot + d * (phi.cos() * a0 + phi.sin() * v);
        let outside = |phi: f64| eval(at(phi)) >= eps;
        // Coarse search then bisection; the WGSL twin uses the same steps (and fewer
        // bisections, f32). Loop counts matter on llvmpipe (see shaders/anjyo/cantilever.wgsl).
        const STEPS: u32 = 32;
        let step = PI / STEPS as f64;
        for n in 1..=STEPS {
            for dir in [1.0, -1.0] {
                let phi = phi0 + dir * n as f64 * step;
                if outside(phi) {
                    // Bisect between the last inside angle and this outside one.
                    let (mut lo, mut hi) = (phi - dir * step, phi);
                    for _ in 0..40 {
                        let mid = 0.5 * (lo + hi);
                        if outside(mid) {
                            hi = mid;
                        } else {
                            lo = mid;
                        }
                    }
                    return at(hi);
                }
            }
        }
        // The whole circle is inside (only when d exceeds the hull's size near the pivot):
        // go straight out along the normal.
        pivot + d * gradient(pivot).normalize_or(DVec3::Y)
    }
}

/// Is `phi` (degrees) inside the azimuth range `[a, b]`, allowing ranges that wrap past 180.
pub fn phi_in_range(phi_deg: f64, range: (f64, f64)) -> bool {
    let (a, b) = range;
    if b - a >= 360.0 {
        return true;
    }
    let t = (phi_deg - a).rem_euclid(360.0);
    t <= (b - a) + 1e-9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_is_on_surface_and_polar_round_trips() {
        let e = Ellipsoid::new([1.0, 2.0, 3.0], [9.0, 11.0, 7.5]);
        for &(t, p) in &[(0.3, 0.2), (1.2, -2.0), (2.5, 3.0)] {
            let x = e.point(t, p);
            assert!(e.eval(x).abs() < 1e-12);
            let (t2, p2) = e.polar(x);
            assert!((t - t2).abs() < 1e-9 && (p - p2).abs() < 1e-9);
        }
    }

    #[test]
    fn push_out_keeps_length_and_leaves_hull() {
        let e = Ellipsoid::new([0.0; 3], [5.0, 6.0, 4.0]);
        let pivot = e.point(1.3, 0.4) + e.normal(e.point(1.3, 0.4)) * 0.01;
        // A node aimed into the head, and one straight along a0 into it (degenerate plane).
        for (a0, p) in [
            (
                DVec3::new(0.0, -1.0, 0.0),
                pivot + DVec3::new(-0.5, -0.2, -0.3),
            ),
            (-e.normal(pivot), pivot - e.normal(pivot) * 0.6),
        ] {
            let d = (p - pivot).length();
            let q = e.push_out(pivot, a0, p, d);
            assert!(e.eval(q) >= 0.0, "still inside: {}", e.eval(q));
            assert!(((q - pivot).length() - d).abs() < 1e-12);
        }
    }

    #[test]
    fn phi_ranges_wrap() {
        assert!(phi_in_range(170.0, (150.0, 210.0)));
        assert!(phi_in_range(-170.0, (150.0, 210.0)));
        assert!(!phi_in_range(0.0, (150.0, 210.0)));
        assert!(phi_in_range(-10.0, (-90.0, 90.0)));
        assert!(phi_in_range(123.0, (-180.0, 180.0)));
    }
}
