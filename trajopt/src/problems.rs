//! A shared benchmark problem set, so that users compare solvers on the same
//! work: the soft-dynamics pendulum swing-up with the true model at any
//! horizon, and the classic test functions for derivative-free solvers;
//! [`mgh`], the Moré-Garbow-Hillstrom test set; [`trajectory`], the
//! torque-driven pendulum, cart-pole and acrobot swing-ups that
//! `ddp::problems` defines for DDP, here in Eq. 3 form.
//!
//! The pendulum hangs from a hand that moves horizontally; state
//! $(\theta, \dot\theta, x, \dot x)$ with $\theta = 0$ hanging down, control
//! the hand acceleration $u$, and
//! $\ddot\theta = -(g/l)\sin\theta - (u/l)\cos\theta - b\dot\theta$, $\ddot x = u$,
//! stepped by semi-implicit Euler at 60 Hz (velocities first, then
//! positions), $g = 9.81$, $l = 0.5$, $b = 0.05$. The task (Eq. 5) tracks a
//! reference that swings from hanging to upright over the first 2 s and then
//! holds upright with the hand back at the origin, with a heavy final-state
//! weight. `scripts/compare_trajopt.py` rebuilds exactly this problem in
//! Python.

/// The Moré-Garbow-Hillstrom test set (1981): 35 least-squares problems with Jacobians, starts and minima.
pub mod mgh;

pub mod trajectory;

use faer::Mat;
use splines::BSplineBasis;

use crate::eq3::{Dynamics, Eq3Problem, Lambda, TrackingCost};
use crate::error::Result;
use systems::ModelResult;

/// Sample period of the pendulum problems, 60 Hz as in the paper.
pub const PENDULUM_DT: f64 = 1.0 / 60.0;

/// The hand-driven pendulum; see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandPendulum {
    /// Gravity $g$.
    pub gravity: f64,
    /// Length $l$.
    pub length: f64,
    /// Damping $b$.
    pub damping: f64,
    /// Step $\Delta t$.
    pub dt: f64,
}

impl Default for HandPendulum {
    fn default() -> Self {
        Self {
            gravity: 9.81,
            length: 0.5,
            damping: 0.05,
            dt: PENDULUM_DT,
        }
    }
}

impl Dynamics for HandPendulum {
    fn state_dim(&self) -> usize {
        4
    }

    fn control_dim(&self) -> usize {
        1
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        let (g, l, b, dt) = (self.gravity, self.length, self.damping, self.dt);
        let (s, c) = x[0].sin_cos();
        let acc = -(g / l) * s - (u[0] / l) * c - b * x[1];
        next[1] = x[1] + dt * acc;
        next[0] = x[0] + dt * next[1];
        next[3] = x[3] + dt * u[0];
        next[2] = x[2] + dt * next[3];
        Ok(())
    }

    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        // the pendulum (theta, omega) and the hand (x, v) couple only through u
        fx.fill(false);
        for (i, c) in [(0, 0), (0, 1), (1, 0), (1, 1), (2, 2), (2, 3), (3, 3)] {
            fx[i * 4 + c] = true;
        }
        fu.fill(true);
    }

    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        let (g, l, b, dt) = (self.gravity, self.length, self.damping, self.dt);
        let (s, c) = x[0].sin_cos();
        let da_dth = -(g / l) * c + (u[0] / l) * s;
        let da_du = -c / l;
        // rows: theta', omega', x', v'
        let (w_th, w_om, w_u) = (dt * da_dth, 1.0 - dt * b, dt * da_du);
        fx.fill(0.0);
        fx[0] = 1.0 + dt * w_th;
        fx[1] = dt * w_om;
        fx[4] = w_th;
        fx[5] = w_om;
        fx[10] = 1.0;
        fx[11] = dt;
        fx[15] = 1.0;
        fu[0] = dt * w_u;
        fu[1] = w_u;
        fu[2] = dt * dt;
        fu[3] = dt;
        Ok(true)
    }

    /// Only the pendulum's acceleration is nonlinear, in $\theta$ and $u$:
    /// $f_1 = \omega + \Delta t\,a$, $f_0 = \theta + \Delta t f_1$, so the
    /// weighted second derivative is $(w_0 \Delta t^2 + w_1 \Delta t) \nabla^2 a$
    /// with $a_{\theta\theta} = (g/l)\sin\theta + (u/l)\cos\theta$,
    /// $a_{\theta u} = \sin\theta / l$.
    fn weighted_hessian(&self, x: &[f64], u: &[f64], w: &[f64], hess: &mut [f64]) -> ModelResult<bool> {
        let (g, l, dt) = (self.gravity, self.length, self.dt);
        let c = w[0] * dt * dt + w[1] * dt;
        let (s, co) = x[0].sin_cos();
        hess.fill(0.0);
        // z = (theta, omega, x, v, u), 5 x 5 row-major
        hess[0] = c * ((g / l) * s + (u[0] / l) * co);
        hess[4] = c * s / l;
        hess[20] = hess[4];
        Ok(true)
    }
}

/// The reference of the swing-up task at step `k` of `horizon`: $\theta$
/// rises smoothly from 0 to $\pi$ over the first 2 s, the hand stays at 0.
pub fn swingup_reference(k: usize) -> [f64; 4] {
    let t = k as f64 * PENDULUM_DT;
    let s = (t / 2.0).min(1.0);
    // smoothstep 3s^2 - 2s^3 and its time derivative
    let theta = std::f64::consts::PI * s * s * (3.0 - 2.0 * s);
    let omega = if t < 2.0 {
        std::f64::consts::PI * 6.0 * s * (1.0 - s) / 2.0
    } else {
        0.0
    };
    [theta, omega, 0.0, 0.0]
}

/// The soft-dynamics pendulum swing-up with the true model: `horizon`
/// steps at 60 Hz, cubic clamped B-splines with `horizon / 6 + 4` state and
/// `horizon / 8 + 4` control coefficients per channel, consistency weight
/// `lambda` in rate units (scale $1/\Delta t$). Returns the problem and the
/// starting parameters: the reference fitted into the state basis, zero
/// controls.
pub fn pendulum_swingup(horizon: usize, lambda: f64) -> Result<(Eq3Problem<HandPendulum, TrackingCost>, Vec<f64>)> {
    let times: Vec<f64> = (0..=horizon).map(|k| k as f64 * PENDULUM_DT).collect();
    let t_end = times[horizon];
    let state_ref = Mat::from_fn(horizon + 1, 4, |k, i| swingup_reference(k)[i]);
    let cost = TrackingCost::new(
        state_ref.clone(),
        Mat::zeros(horizon, 1),
        &[1.0, 0.1, 1.0, 0.1],
        &[0.01],
        &[1000.0, 100.0, 1000.0, 100.0],
    )?;
    let state_basis = BSplineBasis::clamped_uniform(horizon / 6 + 4, 3, 0.0, t_end)?;
    let control_basis = BSplineBasis::clamped_uniform(horizon / 8 + 4, 3, 0.0, t_end)?;
    let problem = Eq3Problem::new(
        HandPendulum::default(),
        cost,
        &state_basis,
        &control_basis,
        &times,
        Lambda::Constant(lambda),
    )?
    .with_consistency_scale(1.0 / PENDULUM_DT)?;
    let cx = splines::fit_matrix(
        &state_basis,
        &times,
        state_ref.as_ref(),
        &splines::FitSettings::default(),
    )?;
    let cu = Mat::zeros(problem.n_control_coeffs(), 1);
    let theta0 = problem.pack(&cx, &cu)?;
    Ok((problem, theta0))
}

/// Rosenbrock's function $\sum_i 100 (x_{i+1} - x_i^2)^2 + (1 - x_i)^2$
/// (minimum 0 at all ones); the classic start is $(-1.2, 1, -1.2, 1, \dots)$.
pub fn rosenbrock(x: &[f64]) -> f64 {
    x.windows(2)
        .map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2))
        .sum()
}

/// Powell's singular function in 4 variables (minimum 0 at the origin, with
/// a singular Hessian there); the classic start is $(3, -1, 0, 1)$.
pub fn powell_singular(x: &[f64]) -> f64 {
    (x[0] + 10.0 * x[1]).powi(2)
        + 5.0 * (x[2] - x[3]).powi(2)
        + (x[1] - 2.0 * x[2]).powi(4)
        + 10.0 * (x[0] - x[3]).powi(4)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// $z = (x, u)$ with $h$ added to its coordinate `c`.
    fn shifted(mut x: [f64; 4], mut u: [f64; 1], c: usize, h: f64) -> ([f64; 4], [f64; 1]) {
        if c < 4 {
            x[c] += h;
        } else {
            u[0] += h;
        }
        (x, u)
    }

    #[test]
    fn pendulum_jacobians_match_central_differences() {
        let worst = crate::check_model_jacobians(&HandPendulum::default(), &[0.7, -1.3, 0.2, 0.4], &[2.5])
            .expect("check")
            .expect("analytic");
        assert!(worst.max_rel_error < 1e-7, "{worst:?}");
    }

    #[test]
    fn pendulum_weighted_hessian_matches_differences_of_the_jacobians() {
        let p = HandPendulum::default();
        let (x, u, w) = ([0.7, -1.3, 0.2, 0.4], [2.5], [0.3, -1.7, 0.9, 2.0]);
        let mut hess = vec![0.0; 25];
        assert!(p.weighted_hessian(&x, &u, &w, &mut hess).expect("ok"));
        // d/dz_c of sum_i w_i df_i/dz_a, by central differences of the exact Jacobians
        let h = 1e-6;
        let weighted_gradient = |x: &[f64; 4], u: &[f64; 1]| {
            let (mut fx, mut fu) = (vec![0.0; 16], vec![0.0; 4]);
            p.jacobians(x, u, &mut fx, &mut fu).expect("ok");
            let mut g = [0.0; 5];
            for i in 0..4 {
                for a in 0..4 {
                    g[a] += w[i] * fx[i * 4 + a];
                }
                g[4] += w[i] * fu[i];
            }
            g
        };
        for c in 0..5 {
            let ((xp, up), (xm, um)) = (shifted(x, u, c, h), shifted(x, u, c, -h));
            let (gp, gm) = (weighted_gradient(&xp, &up), weighted_gradient(&xm, &um));
            for a in 0..5 {
                let fd = (gp[a] - gm[a]) / (2.0 * h);
                let an = hess[a * 5 + c];
                assert!((fd - an).abs() < 1e-7, "d2 / dz{a} dz{c}: {an} vs {fd}");
            }
        }
        for a in 0..5 {
            for c in 0..5 {
                assert_eq!(hess[a * 5 + c], hess[c * 5 + a]);
            }
        }
    }

    #[test]
    fn test_functions_vanish_at_their_minima() {
        assert_eq!(rosenbrock(&[1.0; 5]), 0.0);
        assert_eq!(powell_singular(&[0.0; 4]), 0.0);
        assert!((rosenbrock(&[-1.2, 1.0]) - 24.2).abs() < 1e-12);
        assert!((powell_singular(&[3.0, -1.0, 0.0, 1.0]) - 215.0).abs() < 1e-12);
    }
}
