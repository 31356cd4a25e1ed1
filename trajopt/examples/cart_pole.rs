//! Your own model and cost, solved by the paper's Eq. 3: a cart-pole swing-up.
//!
//! A pole (mass `m`, half-length `l`) on a cart (mass `mc`) pushed by a
//! horizontal force `F`; the pole angle `th` is 0 upright and pi hanging:
//!
//! ```text
//! th'' = (g sin th - cos th (F + m l th'^2 sin th) / (mc + m)) / (l (4/3 - m cos^2 th / (mc + m)))
//! x''  = (F + m l (th'^2 sin th - th'' cos th)) / (mc + m)
//! ```
//!
//! stepped by semi-implicit Euler at 20 Hz. Eq. 3 plans the state and the
//! force trajectories together, both as cubic B-splines, with the dynamics
//! as a soft constraint weighted by lambda:
//!
//! ```text
//! min  sum_k c(x_k, u_k) + lambda |x_{k+1} - f(x_k, u_k)|^2 + c_N(x_N)
//! ```
//!
//! The model gives no Jacobians, so `trajopt` takes central differences of
//! `step`; the cost gives its own (they are constant). Copy this file to
//! start a problem of your own. (The workspace's cart-pole, with exact
//! Jacobians, a point-mass or uniform-rod pole and friction, is
//! `systems::CartPole`; this one is written here on purpose, as a user
//! writes theirs.)
//!
//! `cargo run --release -p nprl-trajopt --example cart_pole`

use std::f64::consts::PI;
use trajopt::ModelResult;

use splines::{BSplineBasis, FitSettings, fit_matrix};
use trajopt::faer::Mat;
use trajopt::{Dynamics, Eq3Problem, GaussNewton, GaussNewtonSettings, Lambda, StageCost};

const DT: f64 = 0.05;

/// The cart-pole; state (x, x', th, th'), control (F).
struct MyCartPole {
    cart_mass: f64,
    pole_mass: f64,
    half_length: f64,
    gravity: f64,
}

impl Dynamics for MyCartPole {
    fn state_dim(&self) -> usize {
        4
    }

    fn control_dim(&self) -> usize {
        1
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        let (m, l, g) = (self.pole_mass, self.half_length, self.gravity);
        let total = self.cart_mass + m;
        let (s, c) = x[2].sin_cos();
        let push = (u[0] + m * l * x[3] * x[3] * s) / total;
        let th_acc = (g * s - c * push) / (l * (4.0 / 3.0 - m * c * c / total));
        let x_acc = push - m * l * th_acc * c / total;
        // semi-implicit Euler: velocities first, positions with the new velocities
        next[1] = x[1] + DT * x_acc;
        next[3] = x[3] + DT * th_acc;
        next[0] = x[0] + DT * next[1];
        next[2] = x[2] + DT * next[3];
        Ok(())
    }
}

/// Quadratic cost toward upright at rest with the cart back at 0:
/// residuals sqrt(q_i) (x_i - goal_i) and sqrt(r) F per stage, and
/// sqrt(q_final_i) (x_i - goal_i) at the end.
struct ToUpright {
    q: [f64; 4],
    r: f64,
    q_final: [f64; 4],
}

impl StageCost for ToUpright {
    fn n_residuals(&self) -> usize {
        5
    }

    fn residuals(&self, _k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
        let q = if u.is_some() { self.q } else { self.q_final };
        for i in 0..4 {
            r[i] = q[i].sqrt() * x[i];
        }
        // the upright angle is 0, so the residual is the angle itself
        r[4] = u.map_or(0.0, |u| self.r.sqrt() * u[0]);
        Ok(())
    }

    fn jacobians(&self, _k: usize, _x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> ModelResult<()> {
        let q = if u.is_some() { self.q } else { self.q_final };
        jx.fill(0.0);
        for i in 0..4 {
            jx[i * 4 + i] = q[i].sqrt();
        }
        if u.is_some() {
            ju.fill(0.0);
            ju[4] = self.r.sqrt();
        }
        Ok(())
    }

    fn jacobian_structure(&self, jx: &mut [bool], ju: &mut [bool]) {
        jx.fill(false);
        for i in 0..4 {
            jx[i * 4 + i] = true;
        }
        ju.fill(false);
        ju[4] = true;
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let horizon = 60; // 3 s at 20 Hz
    let times: Vec<f64> = (0..=horizon).map(|k| k as f64 * DT).collect();
    let model = MyCartPole {
        cart_mass: 1.0,
        pole_mass: 0.1,
        half_length: 0.5,
        gravity: 9.81,
    };
    let cost = ToUpright {
        q: [0.1, 0.01, 0.1, 0.01],
        r: 1e-3,
        q_final: [10.0, 1.0, 100.0, 10.0],
    };
    // one state coefficient per step, so that the state trajectory can obey
    // the dynamics exactly: with a coarser state basis the plan stays
    // inconsistent (mismatch near 1e-2 per step whatever lambda), which an
    // unstable system replayed open loop magnifies into a miss
    let state_basis = BSplineBasis::clamped_uniform(horizon + 1, 3, 0.0, times[horizon])?;
    let control_basis = BSplineBasis::clamped_uniform(30, 3, 0.0, times[horizon])?;
    // the model's mismatch per step, |x_{k+1} - f(x_k, u_k)|^2, weighted by lambda
    // and the measured start, hanging at rest, as a heavily weighted residual
    let mut problem = Eq3Problem::new(model, cost, &state_basis, &control_basis, &times, Lambda::Constant(1e2))?
        .with_initial_state(&[0.0, 0.0, PI, 0.0], 1e6)?;

    // start: the angle going straight from hanging to upright, no force
    let guess = Mat::from_fn(horizon + 1, 4, |k, i| {
        if i == 2 {
            PI * (1.0 - k as f64 / horizon as f64)
        } else {
            0.0
        }
    });
    let state_coeffs = fit_matrix(&state_basis, &times, guess.as_ref(), &FitSettings::default())?;
    let theta0 = problem.pack(&state_coeffs, &Mat::zeros(problem.n_control_coeffs(), 1))?;
    // the paper's continuation: a soft model first (the plan may cut
    // corners), then ever stiffer, each solve warm-started from the last
    let solver = GaussNewton::new(GaussNewtonSettings {
        max_iterations: 500,
        ..Default::default()
    })?;
    let mut theta = theta0;
    for lambda in [1e2, 1e4, 1e6, 1e8] {
        problem.set_lambda(Lambda::Constant(lambda))?;
        let result = solver.solve(&problem, &theta)?;
        let parts = problem.cost_breakdown(&result.x)?;
        println!(
            "lambda {lambda:.0e}: {:?} after {} iterations, task cost {:.4}, worst mismatch per step {:.2e}",
            result.status, result.iterations, parts.task, parts.max_mismatch
        );
        theta = result.x;
    }

    // what the plan says, and what the model does with the plan's forces
    let (states, forces) = problem.trajectory(&theta)?;
    let mut x = [states[(0, 0)], states[(0, 1)], states[(0, 2)], states[(0, 3)]];
    let mut next = [0.0; 4];
    for k in 0..horizon {
        problem.model().step(&x, &[forces[(k, 0)]], &mut next)?;
        x = next;
    }
    println!(
        "planned end: angle {:.3} rad, cart {:.3} m; the forces replayed through the model end at angle {:.3} rad",
        states[(horizon, 2)],
        states[(horizon, 0)],
        x[2]
    );
    Ok(())
}
