//! Differential dynamic programming (Jacobson and Mayne, 1970), the paper's
//! consistent local planner.
//!
//! Around a trajectory $(x^*_t, u^*_t)$, $t = 0..N$, DDP returns the paper's
//! two local models:
//!
//! - **Eq. 1, a local quadratic value function**
//!   $$V_t(x) \approx V_0(t) + V_x(t)^\top (x - x^*_t) + \tfrac12 (x - x^*_t)^\top V_{xx}(t) (x - x^*_t),$$
//!   ([`DdpResult::value`], [`DdpResult::value_gradient`],
//!   [`DdpResult::value_hessian`], evaluated by [`DdpResult::value_model`]);
//! - **Eq. 2, a local linear policy**
//!   $$u_t(x) = u^*_t + K_t (x - x^*_t)$$
//!   ([`DdpResult::controls`], [`DdpResult::gains`], evaluated by
//!   [`DdpResult::policy`]).
//!
//! They come from the backward pass over the second-order expansion of
//! $Q_t(\delta x, \delta u) = \ell(x, u, t) + V_{t+1}(f(x, u))$ (see [`Ddp`]
//! for the recursion), with a forward line search, Tassa's adaptive
//! regularisation and box control limits (projected Newton).
//!
//! - [`Dynamics`]: $x_{k+1} = f(x_k, u_k)$ (a fallible `step`, as
//!   `trajopt`'s `Model`) with $f_x, f_u$ (by default central differences);
//!   with second derivatives and [`DdpMethod::Ddp`] the solver is full DDP,
//!   otherwise iLQR ([`DdpMethod::Ilqr`], the default).
//! - [`Cost`]: running and terminal costs with gradients and Hessians;
//!   [`QuadraticCost`] is a built-in tracking cost, scaled as `trajopt`'s
//!   `TrackingCost` (no $\tfrac12$).
//! - [`DdpProblem`]: dynamics, cost, horizon, $x_0$, warm start, optional
//!   control limits.
//! - [`Ddp`] / [`DdpSettings`] / [`DdpResult`] / [`DdpStatus`]: the solver,
//!   in the vocabulary of `trajopt`'s solvers (`max_iterations`, `tol_*`,
//!   `cost`, `initial_cost`, `status`, `iterations`, `cost_evals`,
//!   `jacobian_evals`, `solve_time`, `cost_history`). Not converging, a
//!   rollout that blows up (the paper's point 2: a learned model integrated
//!   forward), an indefinite $Q_{uu}$ or no descent are [`DdpStatus`] values
//!   returned with the last good, finite iterate; `Err` ([`DdpError`]) only
//!   reports invalid input, or a model whose warm-start rollout fails.
//! - [`models`]: [`LinearDynamics`], [`Pendulum`], [`CartPole`];
//!   [`problems`]: the swing-up benchmarks; `strategies` (feature
//!   `proptest`): random linear-quadratic problems with their Riccati
//!   solution, and `check_jacobian` (analytic derivatives against central
//!   differences); `nalgebra_convert` (feature `nalgebra`): conversions
//!   from and to nalgebra's `DVector` / `DMatrix`.
//!
//! # Layout
//!
//! `problem.rs` holds the traits and [`DdpProblem`], `models.rs` the
//! built-in dynamics and cost, `problems.rs` the benchmarks; the solver is
//! the folder `solver/`: `mod.rs` ([`Ddp`] and its outer loop),
//! `settings.rs`, `result.rs`, `work.rs` (the buffers of one solve),
//! `forward.rs` (rollouts), `backward.rs` (linearisation and backward pass)
//! and `regularization.rs` ([`Regularization`] and Tassa's schedule).
//! `linalg.rs` has the dense kernels of the backward pass (a hand-written
//! Cholesky: at these sizes, $m \le 2$, it beats faer's and nalgebra's,
//! see `benches/cholesky.rs`) and the box QP; `diff.rs` central
//! differences; `nalgebra_convert.rs` (feature `nalgebra`) the
//! conversions; `error.rs` the error type. Modules depend downwards only:
//! `solver` on `problem`, `linalg` and `error`; `problem` on `diff` and
//! `error`.
//!
//! # Example: pendulum swing-up, then the policy and the value function
//!
//! ```
//! use ddp::{Ddp, DdpProblem, DdpSettings, DdpStatus, Pendulum, QuadraticCost};
//!
//! let dt = 0.01;
//! let pendulum = Pendulum { dt, ..Pendulum::default() }; // theta = 0 hangs down
//! // reach (pi, 0): small running cost, large terminal cost
//! let cost = QuadraticCost::diagonal(&[0.5 * dt, 0.05 * dt], &[0.005 * dt], &[50.0, 5.0])?
//!     .with_state_target(&[std::f64::consts::PI, 0.0])?;
//! // 4 s from rest, zero warm start, torque below m g l: it has to pump
//! let problem = DdpProblem::new(pendulum, cost, &[0.0, 0.0], 400)?
//!     .with_control_limits(&[-3.0], &[3.0])?;
//!
//! let result = Ddp::new(DdpSettings::default())?.solve(&problem)?;
//! assert_eq!(result.status, DdpStatus::Converged);
//! assert!(result.controls.iter().all(|u| u[0].abs() <= 3.0));
//! let end = &result.states[400];
//! assert!((end[0] - std::f64::consts::PI).abs() < 0.05);
//!
//! // Eq. 2: feedback around the plan, u = u*_t + K_t (x - x*_t)
//! let x = [0.01, 0.0]; // disturbed initial state
//! let u = result.policy(0, &x).expect("policy");
//! assert!(u[0].is_finite());
//! // Eq. 1: the quadratic value model, exact at the plan
//! let v0 = result.value_model(0, &result.states[0]).expect("value");
//! assert!((v0 - result.cost).abs() < 1e-9 * result.cost);
//! // and predicts the optimal cost from the disturbed state (see tests/solver.rs)
//! let v = result.value_model(0, &x).expect("value");
//! assert!(v.is_finite());
//! // the value function terms along the whole trajectory
//! assert_eq!(result.value_hessian.len(), 401);
//! assert_eq!(result.gains[0].nrows(), 1);
//! # Ok::<(), ddp::DdpError>(())
//! ```
//!
//! References: D. H. Jacobson and D. Q. Mayne, *Differential Dynamic
//! Programming*, Elsevier, 1970; Y. Tassa, T. Erez and E. Todorov, IROS
//! 2012; Y. Tassa, N. Mansard and E. Todorov, ICRA 2014; W. Li and E.
//! Todorov, ICINCO 2004 (iLQR).
#![warn(missing_docs)]

mod diff;
pub mod error;
mod linalg;
pub mod models;
#[cfg(feature = "nalgebra")]
pub mod nalgebra_convert;
pub mod problem;
pub mod problems;
pub mod solver;
#[cfg(feature = "proptest")]
pub mod strategies;

pub use error::{DdpError, Result};
pub use models::{CartPole, LinearDynamics, Pendulum, QuadraticCost};
pub use problem::{Cost, CostDerivatives, DdpProblem, Dynamics};
pub use solver::{Ddp, DdpMethod, DdpResult, DdpSettings, DdpStatus, Regularization};
