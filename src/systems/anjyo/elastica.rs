//! The exact large-deflection heavy cantilever, the "truth" for the bending modes: a beam
//! clamped horizontally at s = 0, free at s = 1 (lengths in units of L), under its own
//! weight, satisfies the elastica
//!
//! ```text
//! theta''(s) = -G (1 - s) cos theta(s),   theta(0) = 0,  theta'(1) = 0,   G = w L^3 / EI
//! ```
//!
//! with theta the angle of the tangent below the horizontal (positive: drooping). It is solved by
//! second-order finite differences with Newton's method (tridiagonal), continued in G from
//! the linear regime so the stable, hanging branch is followed, and Richardson-extrapolated
//! over two grids. `shoot_tip_angle` solves the same problem independently by shooting from
//! the tip, so tests can check one against the other. For small G the tip drop tends to the
//! Euler–Bernoulli value G/8.

/// A solved elastica on a uniform grid.
#[derive(Clone, Debug)]
pub struct Elastica {
    pub g: f64,
    /// theta at s = i/n, i = 0..=n.
    pub theta: Vec<f64>,
    /// Cartesian shape, same grid: x along the clamp, `drop` downwards.
    pub x: Vec<f64>,
    pub drop: Vec<f64>,
}

impl Elastica {
    /// Solve on `n` intervals.
    pub fn solve_grid(g: f64, n: usize) -> Elastica {
        assert!(g >= 0.0 && g.is_finite() && n >= 8);
        let h = 1.0 / n as f64;
        let mut theta = vec![0.0; n + 1];
        // Continuation in G: geometric steps from the linear regime up to g.
        let mut gs = vec![g];
        let mut gc = g;
        while gc > 0.05 {
            gc /= 1.6;
            gs.push(gc);
        }
        gs.reverse();
        for &gk in &gs {
            newton(&mut theta, gk, h);
        }
        let (x, drop) = integrate_shape(&theta, h);
        Elastica { g, theta, x, drop }
    }

    /// Tip drop (positive down), in units of L.
    pub fn tip_drop(&self) -> f64 {
        *self.drop.last().unwrap()
    }

    /// Position at arc length `s` in [0, 1] (linear interpolation on the grid).
    pub fn at(&self, s: f64) -> (f64, f64) {
        let n = self.theta.len() - 1;
        let f = (s.clamp(0.0, 1.0) * n as f64).min(n as f64 - 1e-12);
        let i = f.floor() as usize;
        let t = f - i as f64;
        (
            self.x[i] + t * (self.x[i + 1] - self.x[i]),
            self.drop[i] + t * (self.drop[i + 1] - self.drop[i]),
        )
    }
}

/// Tip drop extrapolated from grids of n and 2n intervals (error ~1e-9 for n = 2000).
pub fn tip_drop(g: f64) -> f64 {
    let a = Elastica::solve_grid(g, 2000).tip_drop();
    let b = Elastica::solve_grid(g, 4000).tip_drop();
    (4.0 * b - a) / 3.0
}

fn newton(theta: &mut [f64], g: f64, h: f64) {
    let n = theta.len() - 1;
    let ih2 = 1.0 / (h * h);
    for _ in 0..100 {
        // Residual F_i for i = 1..=n (theta_0 = 0 fixed); ghost node theta_{n+1} = theta_{n-1}.
        let mut rhs = vec![0.0; n + 1];
        let mut sub = vec![0.0; n + 1];
        let mut dia = vec![0.0; n + 1];
        let mut sup = vec![0.0; n + 1];
        for i in 1..=n {
            let s = i as f64 * h;
            let (left, right) = if i == n {
                (theta[n - 1], theta[n - 1])
            } else {
                (theta[i - 1], theta[i + 1])
            };
            rhs[i] = -((left - 2.0 * theta[i] + right) * ih2 + g * (1.0 - s) * theta[i].cos());
            dia[i] = -2.0 * ih2 - g * (1.0 - s) * theta[i].sin();
            sub[i] = if i == n { 2.0 * ih2 } else { ih2 };
            sup[i] = if i == n { 0.0 } else { ih2 };
        }
        sub[1] = 0.0; // theta_0 is fixed
        let delta = thomas(&sub[1..], &dia[1..], &sup[1..], &rhs[1..]);
        let mut m = 0.0f64;
        for (i, dx) in delta.iter().enumerate() {
            theta[i + 1] += dx;
            m = m.max(dx.abs());
        }
        if m < 1e-14 {
            return;
        }
    }
}

/// Tridiagonal solve (Thomas algorithm).
fn thomas(a: &[f64], b: &[f64], c: &[f64], d: &[f64]) -> Vec<f64> {
    let n = b.len();
    let mut cp = vec![0.0; n];
    let mut dp = vec![0.0; n];
    cp[0] = c[0] / b[0];
    dp[0] = d[0] / b[0];
    for i in 1..n {
        let m = b[i] - a[i] * cp[i - 1];
        cp[i] = c[i] / m;
        dp[i] = (d[i] - a[i] * dp[i - 1]) / m;
    }
    let mut x = vec![0.0; n];
    x[n - 1] = dp[n - 1];
    for i in (0..n - 1).rev() {
        x[i] = dp[i] - cp[i] * x[i + 1];
    }
    x
}

/// x and the drop by the trapezoid rule on cos/sin theta.
fn integrate_shape(theta: &[f64], h: f64) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; theta.len()];
    let mut y = vec![0.0; theta.len()];
    for i in 1..theta.len() {
        x[i] = x[i - 1] + 0.5 * h * (theta[i - 1].cos() + theta[i].cos());
        y[i] = y[i - 1] + 0.5 * h * (theta[i - 1].sin() + theta[i].sin());
    }
    (x, y)
}

/// Independent check: shoot from the tip (theta(1) = tip, theta'(1) = 0) back to the clamp
/// with RK4 on `steps` steps and bisect on the tip angle in `bracket` until theta(0) = 0.
/// Returns (tip angle, tip drop).
pub fn shoot_tip_angle(g: f64, bracket: (f64, f64), steps: usize) -> Option<(f64, f64)> {
    let run = |tip: f64| -> (f64, f64) {
        // State (theta, theta', drop) integrated from s = 1 down to 0, the drop counted from
        // the tip, so at s = 0 it is minus the tip drop.
        let h = -1.0 / steps as f64;
        let f = |s: f64, st: [f64; 3]| [st[1], -g * (1.0 - s) * st[0].cos(), st[0].sin()];
        let mut st = [tip, 0.0, 0.0];
        let mut s = 1.0;
        for _ in 0..steps {
            let k1 = f(s, st);
            let a = |k: [f64; 3], c: f64| [st[0] + c * k[0], st[1] + c * k[1], st[2] + c * k[2]];
            let k2 = f(s + 0.5 * h, a(k1, 0.5 * h));
            let k3 = f(s + 0.5 * h, a(k2, 0.5 * h));
            let k4 = f(s + h, a(k3, h));
            for i in 0..3 {
                st[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            s += h;
        }
        (st[0], st[2])
    };
    let (mut lo, mut hi) = bracket;
    let (flo, _) = run(lo);
    let (fhi, _) = run(hi);
    if flo.signum() == fhi.signum() {
        return None;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        let (fm, _) = run(mid);
        if fm.signum() == flo.signum() {
            lo = mid;
        } else {
            hi = mid;
        }
        if (hi - lo).abs() < 1e-15 {
            break;
        }
    }
    let tip = 0.5 * (lo + hi);
    let (_, drop) = run(tip);
    Some((tip, -drop))
}
