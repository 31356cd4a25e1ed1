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
//!   band matrices ([`linalg`]): the problem forms $J^\top J$ in band storage
//!   from its per-step local blocks, and a band Cholesky factorisation solves
//!   the steps. On any other sparse least-squares problem, $J^\top J$ and its
//!   symbolic Cholesky factorisation (faer) are structured once and reused.
//!   With [`StepModel::Newton`] and a model that gives its
//!   second derivatives ([`Model::weighted_hessian`]), it takes safeguarded
//!   Newton steps instead, which converge quadratically on Eq. 3's
//!   large-residual problems; with [`StepModel::Adaptive`], each iteration
//!   takes whichever model predicted the last step better. Which to use, from the benchmark pendulum at $N = 1000$: the
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
//! - [`LeastSquaresProblem`]: what Gauss-Newton solves: a plain problem
//!   implements sizes, residuals and the Jacobian's pattern and values;
//!   [`SecondOrder`] (the Newton modes) and [`BandForm`] (band assembly,
//!   in parts on several threads) are opt-in. [`check::check_jacobian`]
//!   compares an analytic Jacobian with central differences.
//!
//! Invalid input is a typed [`TrajoptError`]; a solver that stops without
//! converging returns its best point with a status. The solvers share one
//! vocabulary: settings with `max_iterations` and `tol_*` fields and
//! `validate()`; results with `x`, `cost`, `initial_cost`, `status`
//! (`is_converged()`), `iterations`, `*_evals` counts, `cost_history` and
//! `solve_time`.
//!
//! # Layout
//!
//! | concern | where |
//! |---|---|
//! | least-squares problem traits ([`LeastSquaresProblem`], [`SecondOrder`], [`BandForm`]), [`LinearBounds`], [`LinearLeastSquares`] | `least_squares.rs` |
//! | Gauss-Newton / Levenberg-Marquardt: the iteration | `gauss_newton/mod.rs` |
//! | its settings ([`StepModel`], [`LinearSolver`]), result and status | `gauss_newton/{settings,result}.rs` |
//! | damping and the Newton shift | `gauss_newton/damping.rs` |
//! | the normal equations: one trait, three back ends | `gauss_newton/normal_equations/{mod,sparse,band,split}.rs` |
//! | helper threads; the two-domain split of a band matrix; the band model matrix both keep ($J^\top J$ alone on demand); the bounded step (a QP) | `parallel.rs`, `split.rs`, `band_model.rs`, `qp.rs` |
//! | band matrices and their Cholesky factorisation | `linalg/band.rs` |
//! | every SIMD kernel and the fixed-shape dispatch table | `linalg/kernels.rs` |
//! | Eq. 3: the problem, residuals, cost breakdown | `eq3/mod.rs` |
//! | its [`Model`], [`StageCost`] / [`TrackingCost`], [`Lambda`] | `eq3/{model,stage_cost,lambda}.rs` |
//! | its Jacobian, second-order term and band assembly | `eq3/{jacobian,second_order,band_assembly}.rs` |
//! | Powell's method: settings and result; iteration; line search; argmin | `powell/{mod,engine,line_search,argmin}.rs` |
//! | [`LinearModel`]; benchmark problems; proptest strategies | `models.rs`, `problems.rs`, `strategies.rs` |
//! | Jacobian checks | `check.rs` |
//!
//! The modules' `use crate::...` lines (tests aside) point one way only,
//! so there is no import cycle: `error` ← `linalg` ← `least_squares` ←
//! {`check`, `qp`, `band_model` ← `split` ← `parallel`} ← `gauss_newton`; `powell` uses
//! `error` alone; `eq3` uses `error`, `linalg`, `least_squares` (to
//! implement the solvers' traits) and `powell` (to implement
//! [`powell::Objective`]), and nothing uses `eq3` but `models`,
//! `problems` and `strategies`.

mod band_model;
pub mod check;
pub mod eq3;
pub mod error;
pub mod gauss_newton;
pub mod least_squares;
pub mod linalg;
pub mod models;
mod parallel;
pub mod powell;
pub mod problems;
mod qp;
mod split;
#[cfg(feature = "proptest")]
pub mod strategies;

pub use check::{JacobianCheck, check_jacobian};
pub use eq3::{CostBreakdown, Eq3Problem, Lambda, Model, StageCost, TrackingCost};
pub use error::{Result, TrajoptError};
pub use gauss_newton::{
    GaussNewton, GaussNewtonResult, GaussNewtonSettings, GaussNewtonStatus, LinearSolver, MIN_PARALLEL_PARAMS,
    StepModel,
};
pub use least_squares::{
    BandForm, BandNormalEquations, LeastSquaresProblem, LinearBounds, LinearLeastSquares, Part, Point, SecondOrder,
};
pub use linalg::{BandLayout, BandedSym};
pub use models::LinearModel;
pub use powell::{Powell, PowellResult, PowellSettings, PowellStatus};
