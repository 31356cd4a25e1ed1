//! Trajectory benchmarks in Eq. 3 form: the swing-ups of a torque-driven
//! [`Pendulum`], a force-driven [`CartPole`] and an elbow-driven
//! [`Acrobot`], at several horizons and consistency weights $\lambda$, with
//! a registry of standard instances for comparing solvers
//! ([`standard_instances`]).
//!
//! `ddp::problems` defines the same three problems for DDP (dynamics as a
//! hard constraint): the same dynamics, time step, state order, cost
//! weights and target, and instance names that extend `ddp`'s. The
//! workspace's `tests/tests/trajectory_problems.rs` checks that the two
//! agree: the same state and control step to the same next state, the same
//! trajectory has the same task cost, and DDP's optimum is where Eq. 3's
//! optimum tends as $\lambda$ grows.
//!
//! # Conventions
//!
//! | | pendulum | cart-pole | acrobot |
//! |---|---|---|---|
//! | model | [`Pendulum`] (1 kg, 1 m, undamped) | [`CartPole`] (1 kg cart, 0.1 kg pole tip, 0.5 m) | [`Acrobot`] (1 kg, 1 m per link) |
//! | state | $(\theta, \omega)$ | $(x, \theta, \dot x, \dot\theta)$ | $(\theta_1, \theta_2, \dot\theta_1, \dot\theta_2)$ |
//! | control | shoulder torque (N m) | force on the cart (N) | elbow torque (N m) |
//! | start $\bar x_0$ | $(0, 0)$ | $(0, 0, 0, 0)$ | $(0, 0, 0, 0)$ |
//! | target $x^r$ | $(\pi, 0)$ | $(0, \pi, 0, 0)$ | $(\pi, 0, 0, 0)$ |
//!
//! Every state lists the positions first, then their rates; angles are
//! zero hanging down. Every model is stepped by semi-implicit Euler
//! (velocities first, then positions with the new velocities) with
//! $\Delta t$ = [`DT`] = 0.01 s. The task is the [`TrackingCost`] (no
//! $\tfrac12$)
//! $$\sum_{k=0}^{N-1} \Big[\sum_i q_i (x_{k,i} - x^r_i)^2 + r u_k^2\Big] + \sum_i q^f_i (x_{N,i} - x^r_i)^2,$$
//! $q_i = \tfrac12 \Delta t$ on positions and $0.05 \Delta t$ on rates,
//! $r = 0.005 \Delta t$, $q^f_i$ 50 on positions and 5 on rates
//! ([`System::weights`]). `ddp`'s `QuadraticCost` has no $\tfrac12$ either
//! and gets the same weights, so a trajectory's
//! [`CostBreakdown::task`](crate::CostBreakdown::task) here equals its cost
//! $J$ in `ddp` (factor 1).
//!
//! The Eq. 3 criterion adds the dynamics and the start as penalties,
//! measured in rate units (consistency scale $s = 1/\Delta t$):
//! $$C = \text{task} + \frac{\lambda}{\Delta t^2} \Big[\sum_{k=0}^{N-1} \lVert x_{k+1} - f(x_k, u_k) \rVert^2 + \lVert x_0 - \bar x_0 \rVert^2\Big],$$
//! so a dynamically consistent trajectory from $\bar x_0$ has $C$ equal to
//! its task cost, and as $\lambda \to \infty$ the minimum of $C$ rises to
//! DDP's optimum (from below: $C \le J$ at DDP's optimum).
//!
//! The parameters are the samples themselves: states and controls are
//! represented by linear B-splines with a knot at every sample time
//! ($N + 1$ state and $N$ control coefficients per channel, each equal to
//! its sample), so any trajectory, DDP's optimum included, is exactly
//! representable ([`parameters_of`]). The initial guess is DDP's warm
//! start: zero controls, and the states of their rollout (at rest hanging
//! down), where $C$ equals DDP's initial cost.
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
//! [`standard_instances`] lists each system at each of its standard
//! horizons ([`System::standard_horizons`], those of `ddp`) and each
//! $\lambda$ of [`STANDARD_LAMBDAS`], named
//! `"<system>-h<horizon>-lambda<lambda>"` (e.g. `"acrobot-h200-lambda1e2"`;
//! the part before `-lambda` is `ddp`'s name of the same problem,
//! [`Instance::ddp_name`]). [`Instance::problem`] builds one: an
//! [`Eq3Problem`] over [`SwingUpModel`] (one type for all three systems)
//! and its initial guess. Each is a
//! [`LeastSquaresProblem`](crate::LeastSquaresProblem) (for
//! [`GaussNewton`](crate::GaussNewton)), a [`powell::Objective`](crate::powell::Objective)
//! (for [`Powell`](crate::Powell)) and an argmin `CostFunction` and
//! `Gradient` ($2 J^\top r$, [`Eq3Problem::gradient`]).
//!
//! ```
//! use trajopt::problems::trajectory;
//! use trajopt::{GaussNewton, GaussNewtonSettings};
//!
//! let instance = trajectory::by_name("pendulum-h50-lambda1e2").expect("standard");
//! let (problem, theta0) = instance.problem()?;
//! let gn = GaussNewton::new(GaussNewtonSettings::default())?.solve(&problem, &theta0)?;
//! assert!(gn.status.is_converged());
//! let parts = problem.cost_breakdown(&gn.x)?;
//! assert!(parts.max_mismatch < 1e-2 && parts.task < gn.initial_cost);
//! # Ok::<(), trajopt::TrajoptError>(())
//! ```

mod models;

use faer::Mat;
use splines::BSplineBasis;

use crate::eq3::{Dynamics, Eq3Problem, Lambda, TrackingCost};
use crate::error::{Result, TrajoptError, expect_len};

pub use models::{Acrobot, CartPole, Pendulum, SwingUpModel};
pub use systems::{DT, STANDARD_LAMBDAS, SwingUpWeights};

systems::system_enum!();

/// An Eq. 3 swing-up: see the [module docs](self).
pub type SwingUpProblem = Eq3Problem<SwingUpModel, TrackingCost>;

impl System {
    /// The swing-up over `horizon` steps with consistency weight `lambda`,
    /// and its initial guess; see the [module docs](self).
    ///
    /// # Errors
    /// [`TrajoptError::InvalidParameter`] for a horizon below 2 or a
    /// `lambda` that is not finite and positive.
    pub fn problem(self, horizon: usize, lambda: f64) -> Result<(SwingUpProblem, Vec<f64>)> {
        if horizon < 2 {
            return Err(TrajoptError::InvalidParameter {
                name: "horizon",
                reason: format!("need at least 2 steps, got {horizon}"),
            });
        }
        if !(lambda.is_finite() && lambda > 0.0) {
            return Err(TrajoptError::InvalidParameter {
                name: "lambda",
                reason: format!("must be finite and positive, got {lambda}"),
            });
        }
        let w = self.weights();
        let n = w.target.len();
        let times: Vec<f64> = (0..=horizon).map(|k| k as f64 * DT).collect();
        let cost = TrackingCost::new(
            Mat::from_fn(horizon + 1, n, |_, i| w.target[i]),
            Mat::zeros(horizon, 1),
            &w.state,
            &w.control,
            &w.terminal,
        )?;
        // linear B-splines with a knot at every sample: coefficients = samples
        let state_basis = BSplineBasis::clamped(&times, 1)?;
        let control_basis = BSplineBasis::clamped(&times[..horizon], 1)?;
        let problem = Eq3Problem::new(
            self.model(),
            cost,
            &state_basis,
            &control_basis,
            &times,
            Lambda::Constant(lambda),
        )?
        .with_consistency_scale(1.0 / DT)?
        .with_initial_state(&w.initial_state, lambda / (DT * DT))?;
        // DDP's warm start: zero controls, at rest where the system starts
        let states = vec![w.initial_state; horizon + 1];
        let theta0 = parameters_of(&problem, &states, &vec![vec![0.0]; horizon])?;
        Ok((problem, theta0))
    }
}

/// The parameter vector of the trajectory with states $x_0, \dots, x_N$ and
/// controls $u_0, \dots, u_{N-1}$ (the parameters are the samples; see
/// the [module docs](self)), e.g. to start from DDP's solution.
///
/// # Errors
/// [`TrajoptError::DimensionMismatch`] for wrong lengths,
/// [`TrajoptError::NotFinite`] for non-finite values.
pub fn parameters_of(problem: &SwingUpProblem, states: &[Vec<f64>], controls: &[Vec<f64>]) -> Result<Vec<f64>> {
    let (n, m) = (problem.model().state_dim(), 1);
    expect_len("states", problem.horizon() + 1, states.len())?;
    expect_len("controls", problem.horizon(), controls.len())?;
    for x in states {
        expect_len("state", n, x.len())?;
    }
    for u in controls {
        expect_len("control", m, u.len())?;
    }
    let cx = Mat::from_fn(states.len(), n, |k, i| states[k][i]);
    let cu = Mat::from_fn(controls.len(), m, |k, j| controls[k][j]);
    problem.pack(&cx, &cu)
}

/// One standard instance: a system at a horizon and a consistency weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Instance {
    /// The system.
    pub system: System,
    /// The horizon $N$ (steps of [`DT`]).
    pub horizon: usize,
    /// The consistency weight $\lambda$.
    pub lambda: f64,
}

impl Instance {
    /// `"<system>-h<horizon>-lambda<lambda>"`, $\lambda$ in Rust's `{:e}`
    /// form, e.g. `"pendulum-h100-lambda1e2"`.
    pub fn name(&self) -> String {
        format!("{}-lambda{:e}", self.ddp_name(), self.lambda)
    }

    /// `ddp`'s name of the same system and horizon, `"<system>-h<horizon>"`.
    pub fn ddp_name(&self) -> String {
        self.system.spec().instance_name(self.horizon)
    }

    /// The problem and its initial guess ([`System::problem`]).
    ///
    /// # Errors
    /// As [`System::problem`].
    pub fn problem(&self) -> Result<(SwingUpProblem, Vec<f64>)> {
        self.system.problem(self.horizon, self.lambda)
    }
}

/// Every system at each of its [standard horizons](System::standard_horizons)
/// and each of the [`STANDARD_LAMBDAS`]: systems in the order of
/// [`System::ALL`], then horizons, then $\lambda$ increasing.
pub fn standard_instances() -> Vec<Instance> {
    let mut out = Vec::new();
    for system in System::ALL {
        for &horizon in system.standard_horizons() {
            for lambda in STANDARD_LAMBDAS {
                out.push(Instance {
                    system,
                    horizon,
                    lambda,
                });
            }
        }
    }
    out
}

/// The standard instance named `name` (see [`Instance::name`]).
///
/// # Errors
/// [`TrajoptError::InvalidParameter`] naming `name` when no standard
/// instance has it.
pub fn by_name(name: &str) -> Result<Instance> {
    systems::find_instance(standard_instances(), name, Instance::name, "pendulum-h50-lambda1e2").map_err(|reason| {
        TrajoptError::InvalidParameter {
            name: "instance name",
            reason,
        }
    })
}

#[cfg(test)]
mod tests;
