//! The cart-pole swing-up task: PILCO's target, a stage cost for Eq. 3,
//! and the success criterion.
//!
//! PILCO's cost (`loss_cp.m`, `settings_cp.m`) is saturating,
//! $c = 1 - \exp(-d^2 / (2 w^2))$ with $w = 0.25$ m and $d$ the distance of
//! the pole tip from the target, the tip upright above the origin
//! (`cost.target = [0 0 0 pi]`):
//! $d^2 = (x + l\sin\theta)^2 + (l + l\cos\theta)^2$. Eq. 3 is solved by
//! Gauss-Newton, which needs the cost as a sum of squares; the saturating
//! cost's square root has an infinite slope at the target, so the planner
//! minimises the squared tip distance itself, in residual form,
//! $$c_k = q_d\,[(x + l\sin\theta)^2 + (l + l\cos\theta)^2] + q_v \dot x^2 + q_\omega \dot\theta^2 + r f^2 + w_b (|f| - f_{max})_+^2,$$
//! its weights multiplied by `terminal_factor` at the window's last
//! sample, with the soft bound on the force of
//! [`crate::planning::cost`] (the plant clips the rest). Only the tip's
//! position enters through $\sin\theta$ and $\cos\theta$: whole turns of the
//! pole cost nothing, as in PILCO. The saturating cost is reported
//! ([`pilco_cost`]) for comparison.
//!
//! **Success.** Neither the PILCO paper (Deisenroth and Rasmussen, ICML
//! 2011) nor GP-MPC (Kamthe and Deisenroth, AISTATS 2018) states a
//! numerical criterion beside the cost; we define one and use it
//! throughout: a trial succeeds when the pole tip stays within
//! `success_distance` (default 0.1 m) of the target at every sample of the
//! episode's last `success_hold` seconds (default 1 s).

use serde::{Deserialize, Serialize};
use trajopt::ModelResult;
use trajopt::StageCost;

use crate::cartpole::plant::CartPolePlant;

/// PILCO's width of the saturating cost \[m\] (`settings_cp.m`: `cost.width = 0.25`).
pub const PILCO_COST_WIDTH: f64 = 0.25;

/// PILCO's saturating cost $1 - \exp(-d^2 / (2 w^2))$ of state `s`, with
/// $d$ the tip's distance from the target and $w$ = [`PILCO_COST_WIDTH`].
pub fn pilco_cost(plant: &CartPolePlant, s: &[f64; 4]) -> f64 {
    let d = plant.tip_distance(s);
    1.0 - (-0.5 * d * d / (PILCO_COST_WIDTH * PILCO_COST_WIDTH)).exp()
}

/// Weights of the planner's stage cost; see the [module docs](self).
///
/// | name | default |
/// |---|---|
/// | `tip` ($q_d$) | 1 |
/// | `cart_velocity` ($q_v$) | 0.1 |
/// | `angular_velocity` ($q_\omega$) | 0.01 |
/// | `force` ($r$) | 1e-4 |
/// | `terminal_factor` | 10 |
/// | `bound_weight` ($w_b$) | 10 |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskWeights {
    /// $q_d$ on the squared tip distance.
    pub tip: f64,
    /// $q_v$ on the cart's velocity squared.
    pub cart_velocity: f64,
    /// $q_\omega$ on the angular velocity squared.
    pub angular_velocity: f64,
    /// $r$ on the force squared.
    pub force: f64,
    /// Factor on every weight at the window's last sample.
    pub terminal_factor: f64,
    /// $w_b$ of the soft bound $|f| \le f_{max}$.
    pub bound_weight: f64,
}

impl Default for TaskWeights {
    fn default() -> Self {
        Self {
            tip: 1.0,
            cart_velocity: 0.1,
            angular_velocity: 0.01,
            force: 1e-4,
            terminal_factor: 10.0,
            bound_weight: 10.0,
        }
    }
}

impl TaskWeights {
    /// Checks every weight (finite, nonnegative; `terminal_factor` positive).
    pub fn validate(&self) -> crate::Result<()> {
        crate::error::ensure_nonnegative(
            "cartpole.task.",
            &[
                ("tip", self.tip),
                ("cart_velocity", self.cart_velocity),
                ("angular_velocity", self.angular_velocity),
                ("force", self.force),
                ("bound_weight", self.bound_weight),
            ],
        )?;
        crate::error::ensure_positive("cartpole.task.", &[("terminal_factor", self.terminal_factor)])
    }
}

/// The planner's stage cost; see the [module docs](self). Six residuals:
/// tip $x$ and $y$ errors, cart and angular velocity, force, force bound.
#[derive(Debug, Clone)]
pub struct SwingupTask {
    pole_length: f64,
    max_force: f64,
    /// Square roots of the weights: tip, v, omega, force, bound.
    sqrt_w: [f64; 5],
    sqrt_terminal: f64,
}

impl SwingupTask {
    /// The cost for a pole of length `pole_length` and force limit
    /// `max_force`, with `weights` (checked).
    pub fn new(pole_length: f64, max_force: f64, weights: &TaskWeights) -> crate::Result<Self> {
        weights.validate()?;
        crate::error::ensure_data!(
            pole_length > 0.0 && max_force > 0.0,
            "the pole length and force limit must be positive, got {pole_length} and {max_force}"
        );
        Ok(Self {
            pole_length,
            max_force,
            sqrt_w: [
                weights.tip.sqrt(),
                weights.cart_velocity.sqrt(),
                weights.angular_velocity.sqrt(),
                weights.force.sqrt(),
                weights.bound_weight.sqrt(),
            ],
            sqrt_terminal: weights.terminal_factor.sqrt(),
        })
    }
}

impl StageCost for SwingupTask {
    fn n_residuals(&self) -> usize {
        6
    }

    fn residuals(&self, _k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
        let l = self.pole_length;
        let t = if u.is_none() { self.sqrt_terminal } else { 1.0 };
        let (sn, cs) = x[3].sin_cos();
        let w = &self.sqrt_w;
        r[0] = t * w[0] * (x[0] + l * sn);
        r[1] = t * w[0] * (l + l * cs);
        r[2] = t * w[1] * x[1];
        r[3] = t * w[2] * x[2];
        let f = u.map_or(0.0, |u| u[0]);
        r[4] = w[3] * f;
        r[5] = w[4] * (f.abs() - self.max_force).max(0.0);
        Ok(())
    }

    fn jacobians(&self, _k: usize, x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> ModelResult<()> {
        let l = self.pole_length;
        let t = if u.is_none() { self.sqrt_terminal } else { 1.0 };
        let (sn, cs) = x[3].sin_cos();
        let w = &self.sqrt_w;
        jx[..24].fill(0.0);
        jx[0] = t * w[0];
        jx[3] = t * w[0] * l * cs;
        jx[4 + 3] = -t * w[0] * l * sn;
        jx[2 * 4 + 1] = t * w[1];
        jx[3 * 4 + 2] = t * w[2];
        if let Some(u) = u {
            ju[..6].fill(0.0);
            ju[4] = w[3];
            if u[0].abs() > self.max_force {
                ju[5] = w[4] * u[0].signum();
            }
        }
        Ok(())
    }

    fn jacobian_structure(&self, jx: &mut [bool], ju: &mut [bool]) {
        jx[..24].fill(false);
        for e in [0, 3, 7, 9, 14] {
            jx[e] = true;
        }
        ju[..6].fill(false);
        ju[4] = true;
        ju[5] = true;
    }
}

/// The success criterion of the [module docs](self): the tip within
/// `distance` of the target at every one of the last `hold_steps + 1`
/// states of `states`.
pub fn succeeded(plant: &CartPolePlant, states: &[[f64; 4]], distance: f64, hold_steps: usize) -> bool {
    states.len() > hold_steps
        && states[states.len() - hold_steps - 1..]
            .iter()
            .all(|s| plant.tip_distance(s) <= distance)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cartpole::plant::CartPoleParams;

    fn task() -> SwingupTask {
        SwingupTask::new(0.5, 10.0, &TaskWeights::default()).expect("valid")
    }

    /// Upright at rest over the origin with no force costs nothing, at
    /// every stage, whatever the number of whole turns; hanging costs $4 l^2 q_d$.
    #[test]
    fn cost_is_zero_on_target_only() {
        let c = task();
        let mut r = [0.0; 6];
        for th in [std::f64::consts::PI, -std::f64::consts::PI, 3.0 * std::f64::consts::PI] {
            c.residuals(0, &[0.0, 0.0, 0.0, th], Some(&[0.0]), &mut r).expect("ok");
            assert!(r.iter().all(|v| v.abs() < 1e-12), "{r:?}");
        }
        c.residuals(0, &[0.0; 4], Some(&[0.0]), &mut r).expect("ok");
        let total: f64 = r.iter().map(|v| v * v).sum();
        assert!((total - 1.0).abs() < 1e-12);
        c.residuals(0, &[0.0; 4], None, &mut r).expect("ok");
        let terminal: f64 = r.iter().map(|v| v * v).sum();
        assert!((terminal - 10.0).abs() < 1e-12);
    }

    /// The Jacobians match central differences, inside and beyond the
    /// force bound, and respect the declared structure.
    #[test]
    fn jacobians_match_differences() {
        let c = task();
        for (x, u) in [
            ([0.3, -1.0, 0.9, 0.2], 4.0),
            ([0.3, -1.0, -0.8, 2.2], -12.5),
            ([0.0, 1.0, 3.0, -1.0], 11.0),
        ] {
            for terminal in [false, true] {
                let worst = trajopt::check_stage_cost_jacobians(&c, 1, &x, &[u], terminal).expect("check");
                assert!(worst.max_rel_error < 1e-6, "{worst:?}");
            }
            let (mut jx, mut ju) = ([0.0; 24], [0.0; 6]);
            c.jacobians(1, &x, Some(&[u]), &mut jx, &mut ju).expect("ok");
            let (mut sx, mut su) = ([false; 24], [false; 6]);
            c.jacobian_structure(&mut sx, &mut su);
            assert!(jx.iter().zip(&sx).all(|(v, keep)| *keep || *v == 0.0));
            assert!(ju.iter().zip(&su).all(|(v, keep)| *keep || *v == 0.0));
        }
    }

    /// The success criterion looks at the last states only.
    #[test]
    fn success_needs_the_last_second_near_the_target() {
        let plant = CartPolePlant::new(CartPoleParams::default()).expect("valid");
        let up = [0.0, 0.0, 0.0, std::f64::consts::PI];
        let mut states = vec![[0.0; 4]; 20];
        states.extend(std::iter::repeat_n(up, 11));
        assert!(succeeded(&plant, &states, 0.1, 10));
        assert!(!succeeded(&plant, &states, 0.1, 11));
        states.push([0.2, 0.0, 0.0, std::f64::consts::PI]);
        assert!(!succeeded(&plant, &states, 0.1, 10));
        assert!(pilco_cost(&plant, &up) < 1e-12 && pilco_cost(&plant, &[0.0; 4]) > 0.99);
    }
}
