//! Shared benchmark problems: the swing-ups of a [`Pendulum`], a
//! [`CartPole`] and an [`Acrobot`] (used by the tests, the benches, the
//! crate example and the Crocoddyl cross-check in
//! `scripts/golden/crocoddyl_golden.py`, which must stay in step with the
//! definitions here), and a registry of standard instances for comparing
//! solvers ([`standard_instances`]).
//!
//! `trajopt::problems::trajectory` defines the same three problems in the
//! form of the paper's Eq. 3 (dynamics as a soft constraint), with the same
//! dynamics, time step, state order, cost weights and instance names; the
//! workspace's `tests/tests/trajectory_problems.rs` checks that the two
//! agree.
//!
//! # Conventions
//!
//! | | pendulum | cart-pole | acrobot |
//! |---|---|---|---|
//! | model | [`Pendulum`] (1 kg, 1 m, undamped) | [`CartPole`] (1 kg cart, 0.1 kg pole tip, 0.5 m) | [`Acrobot`] (1 kg, 1 m per link) |
//! | state | $(\theta, \omega)$ | $(x, \theta, \dot x, \dot\theta)$ | $(\theta_1, \theta_2, \dot\theta_1, \dot\theta_2)$ |
//! | control | shoulder torque (N m) | force on the cart (N) | elbow torque (N m) |
//! | start $x_0$ | $(0, 0)$ | $(0, 0, 0, 0)$ | $(0, 0, 0, 0)$ |
//! | target $x^r$ | $(\pi, 0)$ | $(0, \pi, 0, 0)$ | $(\pi, 0, 0, 0)$ |
//!
//! Every state lists the positions first, then their rates; angles are
//! zero hanging down. Every model is stepped by semi-implicit Euler with
//! $\Delta t$ = [`DT`] = 0.01 s. The cost is the [`QuadraticCost`]
//! (no $\tfrac12$)
//! $$J = \sum_{k=0}^{N-1} \Big[\sum_i q_i (x_{k,i} - x^r_i)^2 + r u_k^2\Big] + \sum_i q^f_i (x_{N,i} - x^r_i)^2$$
//! with $q = \Delta t\,(\tfrac12, \dots, \tfrac{0.1}{2}, \dots)$ ($\tfrac12 \Delta t$
//! on positions, $0.05 \Delta t$ on rates), $r = 0.005 \Delta t$ and $q^f$ 50
//! on positions, 5 on rates ([`System::weights`]): Crocoddyl's
//! $\tfrac12$-weighted quadratic with weights $\Delta t\,(1, 0.1, 0.01)$ and
//! $(100, 10)$. `trajopt`'s `TrackingCost` has no $\tfrac12$ either, so the
//! same weights give the same task cost of a trajectory in both crates.
//!
//! # Physical parameters and their sources
//!
//! - Pendulum: a point mass of 1 kg on a massless 1 m rod, undamped,
//!   $g = 9.81$ m/s², $\ddot\theta = u / (m l^2) - (g / l) \sin\theta$: the
//!   pendulum of `ddp`'s cross-check against Crocoddyl
//!   (`scripts/golden/crocoddyl_golden.py`: a Pinocchio revolute joint with
//!   a 1 kg point mass 1 m below it).
//! - Cart-pole: cart 1 kg, pole 0.1 kg, length 0.5 m, the numbers of Barto,
//!   Sutton & Anderson, "Neuronlike adaptive elements that can solve
//!   difficult learning control problems", IEEE Trans. SMC 13(5), 1983
//!   (and of Gym's `CartPole`), but with the pole a point mass at the end of
//!   a massless rod of length $l$ (their pole is a uniform rod of
//!   half-length 0.5 m), no friction; the equations of motion are those of
//!   Tedrake, *Underactuated Robotics*, ch. 3 (with $\theta = 0$ hanging
//!   down), given at [`CartPole`].
//! - Acrobot: two links of 1 m with 1 kg point masses at their ends,
//!   driven at the elbow only (Spong, "The swing up control problem for the
//!   acrobot", IEEE Control Systems 15(1), 1995; manipulator equation as in
//!   Tedrake, ch. 3). Sutton & Barto's acrobot (*Reinforcement Learning*,
//!   1998, §11.3) has the same masses and lengths but links with centres of
//!   mass at 0.5 m and moments of inertia 1 kg m²; here all the mass is at
//!   the link ends. Equations at [`Acrobot`].
//!
//! # Registry
//!
//! [`standard_instances`] lists each system at its standard horizons
//! ([`System::standard_horizons`]), named `"<system>-h<horizon>"` (e.g.
//! `"acrobot-h200"`); [`Instance::problem`] builds one, as a
//! [`DdpProblem`] over [`SwingUpModel`] (one type for all three systems),
//! warm-started with zero controls. Every [`DdpProblem`] is also an argmin
//! `CostFunction` and `Gradient` over its stacked controls (single
//! shooting, see [`DdpProblem::shooting_cost`]).

use crate::error::{DdpError, Result};
pub use crate::models::SwingUpModel;
use crate::models::{Acrobot, CartPole, Pendulum, QuadraticCost};
use crate::problem::{DdpProblem, Dynamics};

pub use systems::{DT, SwingUpWeights};

systems::system_enum!();

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
    build(
        System::Pendulum,
        Pendulum {
            dt: DT,
            ..Pendulum::default()
        },
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
    build(
        System::CartPole,
        CartPole {
            dt: DT,
            ..CartPole::default()
        },
        horizon,
    )
}

/// Acrobot swing-up over `horizon` steps of [`DT`] from rest hanging down,
/// zero warm start, to both links upright $(\pi, 0, 0, 0)$, with the
/// weights of [`cartpole_swingup`] (positions, rates, torque) and the
/// [`Acrobot`] defaults; only the elbow is driven.
///
/// # Errors
/// A zero horizon.
pub fn acrobot_swingup(horizon: usize) -> Result<DdpProblem<Acrobot, QuadraticCost>> {
    build(
        System::Acrobot,
        Acrobot {
            dt: DT,
            ..Acrobot::default()
        },
        horizon,
    )
}

impl System {
    /// The swing-up over `horizon` steps with the [`SwingUpModel`].
    ///
    /// # Errors
    /// A zero horizon.
    pub fn problem(self, horizon: usize) -> Result<DdpProblem<SwingUpModel, QuadraticCost>> {
        build(self, self.model(), horizon)
    }
}

fn build<D: Dynamics>(system: System, model: D, horizon: usize) -> Result<DdpProblem<D, QuadraticCost>> {
    let w = system.weights();
    let cost = QuadraticCost::diagonal(&w.state, &w.control, &w.terminal)?.with_state_target(&w.target)?;
    DdpProblem::new(model, cost, &w.initial_state, horizon)
}

/// One standard instance: a system at a horizon.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Instance {
    /// The system.
    pub system: System,
    /// The horizon $N$ (steps of [`DT`]).
    pub horizon: usize,
}

impl Instance {
    /// `"<system>-h<horizon>"`, e.g. `"pendulum-h100"`.
    pub fn name(&self) -> String {
        self.system.spec().instance_name(self.horizon)
    }

    /// The problem, warm-started with zero controls.
    ///
    /// # Errors
    /// A zero horizon.
    pub fn problem(&self) -> Result<DdpProblem<SwingUpModel, QuadraticCost>> {
        self.system.problem(self.horizon)
    }
}

/// Every system at each of its [standard horizons](System::standard_horizons),
/// systems in the order of [`System::ALL`], horizons increasing.
pub fn standard_instances() -> Vec<Instance> {
    System::ALL
        .into_iter()
        .flat_map(|system| {
            system
                .standard_horizons()
                .iter()
                .map(move |&horizon| Instance { system, horizon })
        })
        .collect()
}

/// The standard instance named `name` (see [`Instance::name`]).
///
/// # Errors
/// [`DdpError::InvalidParameter`] naming `name` when no standard instance
/// has it.
pub fn by_name(name: &str) -> Result<Instance> {
    systems::find_instance(standard_instances(), name, Instance::name, "pendulum-h100").map_err(|reason| {
        DdpError::InvalidParameter {
            name: "instance name",
            reason,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registry_names_are_unique_and_found() {
        let all = standard_instances();
        assert_eq!(all.len(), 8);
        for i in &all {
            assert_eq!(by_name(&i.name()).ok(), Some(*i));
            let p = i.problem().expect("problem");
            assert_eq!(p.horizon(), i.horizon);
            assert_eq!(p.initial_state(), i.system.weights().initial_state.as_slice());
        }
        assert_eq!(by_name("acrobot-h200").map(|i| i.horizon).ok(), Some(200));
        assert!(matches!(
            by_name("acrobot-h201"),
            Err(DdpError::InvalidParameter {
                name: "instance name",
                ..
            })
        ));
    }

    #[test]
    fn registry_problems_are_the_named_constructors() {
        // the same cost of the same controls, bit for bit
        let controls: Vec<Vec<f64>> = (0..60).map(|k| vec![(0.1 * k as f64).sin()]).collect();
        let pairs = [
            (
                pendulum_swingup(60).expect("p").rollout_cost(&controls),
                System::Pendulum.problem(60).expect("p").rollout_cost(&controls),
            ),
            (
                cartpole_swingup(60).expect("p").rollout_cost(&controls),
                System::CartPole.problem(60).expect("p").rollout_cost(&controls),
            ),
            (
                acrobot_swingup(60).expect("p").rollout_cost(&controls),
                System::Acrobot.problem(60).expect("p").rollout_cost(&controls),
            ),
        ];
        for (a, b) in pairs {
            assert_eq!(a.expect("cost"), b.expect("cost"));
        }
    }
}
