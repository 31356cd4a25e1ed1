//! The paper's Eq. 3: trajectory optimisation with the learned dynamics as a
//! soft constraint,
//! $$C = \sum_k c(x_k, u_k) + \lambda_k \lVert x_{k+1} - f(x_k, u_k) \rVert^2,$$
//! over the coefficients of [`splines`] bases, states and controls
//! represented separately (Atkeson 1997: "a planner should not obey a freshly
//! learned model exactly"; $\lambda = 0$ ignores the model, $\lambda \to \infty$
//! obeys it).
//!
//! - [`Eq3Problem`]: the criterion over basis coefficients, with a [`Model`]
//!   (value, Jacobians when it has them, optional confidence), a
//!   [`StageCost`] in residual form ([`TrackingCost`] is the paper's Eq. 5),
//!   per-step consistency weights ([`Lambda`]) and the cost split into task
//!   and inconsistency ([`CostBreakdown`]).
//! - [`GaussNewton`]: Gauss-Newton / Levenberg-Marquardt. On Eq. 3 it works on
//!   band matrices ([`banded`]): the problem forms $J^\top J$ in band storage
//!   from its per-step local blocks, and a band Cholesky factorisation solves
//!   the steps. On any other sparse least-squares problem, $J^\top J$ and its
//!   symbolic Cholesky factorisation (faer) are structured once and reused.
//!   With [`GaussNewtonSettings::second_order`] and a model that gives its
//!   second derivatives ([`Model::weighted_hessian`]), it takes safeguarded
//!   Newton steps instead, which converge quadratically on Eq. 3's
//!   large-residual problems; with [`GaussNewtonSettings::adaptive`] as
//!   well, each iteration takes whichever model predicted the last step
//!   better. Which to use, from the benchmark pendulum at $N = 1000$: the
//!   Newton mode where the residuals stay large at the solution (small
//!   $\lambda$: 17 iterations against Gauss-Newton's 113 at $\lambda = 10^2$),
//!   Gauss-Newton where the dynamics are nearly enforced (it converges at
//!   $\lambda = 10^4$, the Newton mode does not), and the adaptive mode when
//!   unsure (44 / 175 / 446 iterations at $\lambda = 10^2 / 10^3 / 10^4$
//!   against Gauss-Newton's 113 / 358 / 446). Any mode runs on more cores
//!   with [`GaussNewton::solve_parallel`], which forms the normal
//!   equations (most of an iteration) in parts on helper threads; on two
//!   threads it also factorises them in two parts (a two-domain
//!   decomposition of the band matrix: each thread eliminates the
//!   coefficients only its part touches).
//! - [`powell`]: Powell's derivative-free method, the paper's solver, also an
//!   argmin `Solver`.
//! - [`problems`]: a shared benchmark set (the soft-dynamics pendulum swing-up
//!   at any horizon, Rosenbrock, Powell's singular function).
//!
//! Invalid input is a typed [`TrajoptError`]; a solver that stops without
//! converging returns its best point with a status.
//!
//! # Example
//!
//! ```
//! use faer::Mat;
//! use splines::BSplineBasis;
//! use trajopt::powell::{Powell, PowellSettings};
//! use trajopt::{Eq3Problem, GaussNewton, GaussNewtonSettings, Lambda, LinearModel, TrackingCost};
//!
//! // a double integrator (position, velocity) driven by an acceleration, 50 steps of 0.02 s
//! let dt = 0.02;
//! let model = LinearModel::new(
//!     Mat::from_fn(2, 2, |i, j| [[1.0, dt], [0.0, 1.0]][i][j]),
//!     Mat::from_fn(2, 1, |i, _| [0.5 * dt * dt, dt][i]),
//! )?;
//! let times: Vec<f64> = (0..=50).map(|k| k as f64 * dt).collect();
//! // track a reference that jumps from 0 to 1 (not feasible for the dynamics)
//! let state_ref = Mat::from_fn(51, 2, |k, i| if i == 0 && k > 25 { 1.0 } else { 0.0 });
//! let cost = TrackingCost::new(state_ref, Mat::zeros(50, 1), &[1.0, 0.0], &[1e-4], &[10.0, 10.0])?;
//! let state_basis = BSplineBasis::clamped_uniform(15, 3, 0.0, 1.0)?;
//! let control_basis = BSplineBasis::clamped_uniform(12, 3, 0.0, 1.0)?;
//! let solver = GaussNewton::new(GaussNewtonSettings::default())?;
//!
//! let mut mismatch = Vec::new();
//! for lambda in [0.0, 1e2, 1e6] {
//!     let problem = Eq3Problem::new(model.clone(), cost.clone(), &state_basis, &control_basis, &times, Lambda::Constant(lambda))?
//!         .with_consistency_scale(1.0 / dt)?;
//!     let theta0 = vec![0.0; problem.n_state_coeffs() * 2 + problem.n_control_coeffs()];
//!     let result = solver.solve(&problem, &theta0)?;
//!     assert!(result.cost <= result.initial_cost);
//!     let parts = problem.cost_breakdown(&result.theta)?;
//!     mismatch.push(parts.max_mismatch);
//! }
//! // the more the model is trusted, the more consistent the plan
//! assert!(mismatch[0] > mismatch[1] && mismatch[1] > mismatch[2]);
//!
//! // the same problem by Powell's derivative-free method, the paper's solver:
//! // at its default tolerances it lowers the cost, but stops well above
//! // Gauss-Newton's minimum
//! let problem = Eq3Problem::new(model, cost, &state_basis, &control_basis, &times, Lambda::Constant(1e2))?
//!     .with_consistency_scale(1.0 / dt)?;
//! let theta0 = vec![0.0; problem.n_state_coeffs() * 2 + problem.n_control_coeffs()];
//! let gauss_newton = solver.solve(&problem, &theta0)?;
//! let powell = Powell::new(PowellSettings::default())?.solve(&problem, &theta0)?;
//! assert!(powell.cost < 0.5 * powell.initial_cost);
//! assert!(gauss_newton.cost <= powell.cost);
//! # Ok::<(), trajopt::TrajoptError>(())
//! ```
#![warn(missing_docs)]

pub mod banded;
pub mod error;
pub mod gauss_newton;
pub mod least_squares;
pub mod models;
mod parallel;
pub mod powell;
pub mod problem;
pub mod problems;
mod qp;
mod split;
#[cfg(feature = "proptest")]
pub mod strategies;

pub use error::{Result, TrajoptError};
pub use gauss_newton::{GaussNewton, GaussNewtonResult, GaussNewtonSettings, GaussNewtonStatus, MIN_PARALLEL_PARAMS};
pub use least_squares::{LeastSquaresProblem, LinearBounds, LinearLeastSquares};
pub use models::LinearModel;
pub use problem::{CostBreakdown, Eq3Problem, Lambda, Model, StageCost, TrackingCost};
