//! Shared benchmark problems (used by the tests, the benches, the crate
//! example and the Crocoddyl cross-check in `scripts/golden/crocoddyl_golden.py`,
//! which must stay in step with the definitions here).

use std::f64::consts::PI;

use crate::error::Result;
use crate::models::{CartPole, Pendulum, QuadraticCost};
use crate::problem::DdpProblem;

/// Time step of the benchmark problems (s).
pub const DT: f64 = 0.01;

/// Pendulum swing-up over `horizon` steps of [`DT`] from rest hanging down,
/// zero warm start, to the upright $(\pi, 0)$:
/// $\ell = \Delta t\,[\tfrac12 (\theta - \pi)^2 + \tfrac{0.1}{2} \omega^2 + \tfrac{0.01}{2} u^2]$,
/// $\ell_f = \tfrac{100}{2} (\theta - \pi)^2 + \tfrac{10}{2} \omega^2$
/// (Crocoddyl's weighted quadratic with weights $\Delta t\,(1, 0.1, 0.01)$
/// and $(100, 10)$, so [`QuadraticCost`], which has no $\tfrac12$, gets
/// half of them), with the [`Pendulum`] defaults (1 kg, 1 m, no damping).
///
/// # Errors
/// A zero horizon.
pub fn pendulum_swingup(horizon: usize) -> Result<DdpProblem<Pendulum, QuadraticCost>> {
    let cost =
        QuadraticCost::diagonal(&[0.5 * DT, 0.05 * DT], &[0.005 * DT], &[50.0, 5.0])?.with_state_target(&[PI, 0.0])?;
    DdpProblem::new(
        Pendulum {
            dt: DT,
            ..Pendulum::default()
        },
        cost,
        &[0.0, 0.0],
        horizon,
    )
}

/// Cart-pole swing-up over `horizon` steps of [`DT`] from rest hanging down
/// at the origin, zero warm start, to the pole upright over the origin
/// $(0, \pi, 0, 0)$:
/// $\ell = \Delta t\,[\tfrac12 (x^2 + (\theta - \pi)^2) + \tfrac{0.1}{2}(\dot x^2 + \dot\theta^2) + \tfrac{0.01}{2} f^2]$,
/// $\ell_f = \tfrac{100}{2} (x^2 + (\theta - \pi)^2) + \tfrac{10}{2} (\dot x^2 + \dot\theta^2)$
/// (the [`QuadraticCost`] weights are half these factors), state
/// $(x, \theta, \dot x, \dot\theta)$, with the [`CartPole`] defaults.
///
/// # Errors
/// A zero horizon.
pub fn cartpole_swingup(horizon: usize) -> Result<DdpProblem<CartPole, QuadraticCost>> {
    let cost = QuadraticCost::diagonal(
        &[0.5 * DT, 0.5 * DT, 0.05 * DT, 0.05 * DT],
        &[0.005 * DT],
        &[50.0, 50.0, 5.0, 5.0],
    )?
    .with_state_target(&[0.0, PI, 0.0, 0.0])?;
    DdpProblem::new(
        CartPole {
            dt: DT,
            ..CartPole::default()
        },
        cost,
        &[0.0; 4],
        horizon,
    )
}
