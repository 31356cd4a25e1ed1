//! Derivative-free least squares: Levenberg-Marquardt steps on a Jacobian
//! formed by grouped differences of the residuals, for problems whose
//! Jacobian has a known sparsity pattern but whose derivatives are not to be
//! trusted or not available (a learned model, the paper's reason for
//! planning with Powell's method).
//!
//! # Method
//!
//! Minimises $F(\theta) = \lVert r(\theta) \rVert^2$ for a
//! [`LeastSquaresProblem`] using only its residual values and its Jacobian's
//! *pattern* (never [`jacobian_values`](LeastSquaresProblem::jacobian_values)).
//!
//! 1. **Groups** (Curtis, Powell and Reid 1974). The columns of the pattern
//!    are split into groups of structurally orthogonal columns
//!    ([`ColumnGroups`]): no residual depends on two columns of one group.
//!    For Eq. 3 over cubic B-splines each residual touches the few
//!    coefficients whose basis functions overlap its time step, so the
//!    pendulum's 138 coefficients fall into 14 groups (a number that does
//!    not grow with the horizon), and an MGH problem with a dense Jacobian
//!    into $n$ groups (MINPACK's `lmdif`).
//! 2. **Jacobian.** One residual evaluation per group at
//!    $\theta + \sum_{j \in G} h_j e_j$, $h_j = s \max(|\theta_j|, 1)$,
//!    gives the group's columns by forward differences (the residuals at
//!    $\theta$ are those of the step just accepted, reused); central
//!    differences ([`Difference::Central`]) take two per group and are
//!    second-order accurate.
//! 3. **Step.** The damped Gauss-Newton step of
//!    [`GaussNewton`] on that Jacobian (Levenberg-Marquardt:
//!    a trust region in the scaled norm, accepted when the actual reduction
//!    is positive against the linear model's), with its sparse Cholesky
//!    factorisation, its bounds (through clarabel) and its tests.
//!
//! The per-point $\lambda$ of Eq. 3 is inside the residuals, so it is
//! unchanged. On a smooth problem the differenced Jacobian is within
//! $O(s)$ (forward) or $O(s^2)$ (central) of the exact one, so the method
//! reaches the Gauss-Newton optimum (the same stationarity condition
//! $J^\top r = 0$ up to that error), at $1 + $ (groups) residual evaluations
//! per iteration instead of the $O(n)$ line searches of a Powell sweep.
//!
//! # Which problems it suits
//!
//! Least-squares problems with a sparse, known Jacobian pattern (Eq. 3:
//! groups independent of the horizon), and small dense ones (MGH: $n$
//! evaluations per Jacobian, as `lmdif`). Not problems whose residuals are
//! noisy at the scale of the difference step $h_j$: a learned model whose
//! prediction is piecewise (a truncated kernel) gives differences of its
//! jumps; raise `relative_step` there. For a general $f$ that is not a sum
//! of squares, use [`Powell`](crate::Powell).
//!
//! # Counting and budget
//!
//! `evals` counts every residual evaluation, the differences'
//! included; `max_evals` caps it (the result is then the best point
//! evaluated, with [`GaussNewtonStatus::MaxEvaluations`]). The statuses are
//! [`GaussNewton`]'s, with its convergence tests on
//! the differenced gradient $J^\top r$, and one more check: a cost or step
//! test (the criterion stopped decreasing, the step became tiny) counts as
//! convergence only where MINPACK's stationarity measure
//! $\max_j |J_j^\top r| / (\lVert J_j \rVert \lVert r \rVert)$ is below
//! `tol_stationary`; elsewhere (a plateau where the residuals stop
//! depending on a parameter, a crawl along a curved valley) the status is
//! [`GaussNewtonStatus::Stalled`]. A converged status is a first-order
//! stationary point, a local minimum (or a plateau far out, where the
//! residuals stop depending on the parameters) that need not be the global
//! minimum: on the MGH set from 1, 10 and 100 times the standard starts,
//! every converged run is at a minimum the paper lists or has Dennis and
//! Schnabel's relative gradient $\max_j |g_j| \max(|x_j|, 1) / \max(f, 1)$
//! below $10^{-5}$ by the exact gradient; the test
//! (`tests/derivative_free.rs`) prints the ones at other stationary points
//! (Box 3-D, Osborne 1 and 2, Biggs EXP6, Meyer, Gulf, Gaussian and
//! Jennrich-Sampson from scaled starts).
//!
//! # Defaults
//!
//! | field | default | meaning |
//! |---|---|---|
//! | `gauss_newton` | [`GaussNewtonSettings::default()`] | the step, its tests and the iteration cap |
//! | `difference` | [`Difference::Forward`] | forward or central differences |
//! | `relative_step` | $\sqrt{\epsilon} \approx 1.5 \times 10^{-8}$ (forward), $\epsilon^{1/3} \approx 6 \times 10^{-6}$ (central) | $s$ in $h_j = s \max(\lvert\theta_j\rvert, 1)$; `None` picks by `difference` |
//! | `max_evals` | `None` (no cap but the iteration cap) | budget of residual evaluations |
//! | `tol_stationary` | $10^{-5}$ | largest cosine between $r$ and a Jacobian column at a point called converged by the cost or step test |
//!
//! # References
//!
//! - A. R. Curtis, M. J. D. Powell and J. K. Reid (1974), "On the
//!   estimation of sparse Jacobian matrices", *IMA J. Appl. Math.* 13, 117-119.
//! - J. J. Moré (1978), "The Levenberg-Marquardt algorithm: implementation
//!   and theory", *Numerical Analysis*, LNM 630 (MINPACK's `lmdif`).
//! - C. Cartis and L. Roberts (2019), "A derivative-free Gauss-Newton method",
//!   *Math. Prog. Comp.* 11, 631-674 (DFO-GN; interpolation models instead
//!   of differences: fewer evaluations on noisy residuals, not done here).
//!
//! # Example
//!
//! ```
//! use trajopt::derivative_free::{DerivativeFree, DerivativeFreeSettings};
//! use trajopt::problems::pendulum_swingup;
//! use trajopt::{GaussNewton, GaussNewtonSettings};
//!
//! // Eq. 3 for the pendulum swing-up over 60 steps, from its initial guess
//! let (problem, theta0) = pendulum_swingup(60, 100.0)?;
//! let dfo = DerivativeFree::new(DerivativeFreeSettings::default())?.solve(&problem, &theta0)?;
//! let gn = GaussNewton::new(GaussNewtonSettings::default())?.solve(&problem, &theta0)?;
//! assert!(dfo.status.is_converged());
//! assert!((dfo.cost - gn.cost).abs() <= 1e-6 * gn.cost);
//! // the Jacobian by 14 residual evaluations (at every horizon), not one per coefficient
//! assert_eq!(dfo.jacobian_groups, 14);
//! # Ok::<(), trajopt::TrajoptError>(())
//! ```

mod elements;
mod groups;

use std::time::{Duration, Instant};

pub use elements::Differenced;
pub use groups::{ColumnGroups, GroupedDifferences};

use crate::error::{Result, TrajoptError};
use crate::gauss_newton::{EvalCount, GaussNewton, GaussNewtonRun, GaussNewtonSettings, GaussNewtonStatus};
use crate::least_squares::LeastSquaresProblem;
use solve::{Finish as _, Watch};

/// Which differences form the Jacobian.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum Difference {
    /// $(r(\theta + h) - r(\theta)) / h$: one evaluation per group.
    #[default]
    Forward,
    /// $(r(\theta + h) - r(\theta - h)) / 2h$: two per group, second-order accurate.
    Central,
}

/// Settings of [`DerivativeFree`]; see the [module docs](self) for the defaults.
///
/// | field | range |
/// |---|---|
/// | `gauss_newton` | as [`GaussNewtonSettings::validate`] |
/// | `relative_step` | `None`, or finite and $> 0$ |
/// | `max_evals` | `None`, or $\ge 1$ |
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DerivativeFreeSettings {
    /// The Levenberg-Marquardt step, its tests and iteration cap.
    pub gauss_newton: GaussNewtonSettings,
    /// Forward or central differences.
    pub difference: Difference,
    /// $s$ in the difference step $h_j = s \max(|\theta_j|, 1)$; `None`:
    /// $\sqrt{\epsilon}$ forward, $\epsilon^{1/3}$ central.
    pub relative_step: Option<f64>,
    /// Budget of residual evaluations, the differences' included (`None`:
    /// no cap but the iteration cap).
    pub max_evals: Option<usize>,
    /// When Gauss-Newton's cost or step test fires, the point is called
    /// converged only if MINPACK's stationarity measure there (the largest
    /// cosine between $r$ and a column of the differenced Jacobian) is at
    /// most this; otherwise the status is
    /// [`Stalled`](GaussNewtonStatus::Stalled) (a plateau or a crawl, not a
    /// minimum). The check costs one more differenced Jacobian.
    pub tol_stationary: f64,
}

impl Default for DerivativeFreeSettings {
    fn default() -> Self {
        Self {
            gauss_newton: GaussNewtonSettings::default(),
            difference: Difference::Forward,
            relative_step: None,
            max_evals: None,
            tol_stationary: 1e-5,
        }
    }
}

impl DerivativeFreeSettings {
    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        self.gauss_newton.validate()?;
        if let Some(s) = self.relative_step
            && !(s.is_finite() && s > 0.0)
        {
            return Err(TrajoptError::InvalidParameter {
                name: "relative_step",
                reason: format!("must be finite and > 0, got {s}"),
            });
        }
        if !(self.tol_stationary.is_finite() && self.tol_stationary >= 0.0) {
            return Err(TrajoptError::InvalidParameter {
                name: "tol_stationary",
                reason: format!("must be finite and >= 0, got {}", self.tol_stationary),
            });
        }
        if self.max_evals == Some(0) {
            return Err(TrajoptError::InvalidParameter {
                name: "max_evals",
                reason: "must be at least 1".into(),
            });
        }
        Ok(())
    }

    /// The difference step's $s$ these settings use.
    pub fn step(&self) -> f64 {
        self.relative_step.unwrap_or(match self.difference {
            Difference::Forward => f64::EPSILON.sqrt(),
            Difference::Central => f64::EPSILON.cbrt(),
        })
    }
}

/// What [`DerivativeFree::solve`] returns.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DerivativeFreeResult {
    /// The best parameters found.
    pub x: Vec<f64>,
    /// $F$ at `x`.
    pub cost: f64,
    /// $F$ at the start.
    pub initial_cost: f64,
    /// Why it stopped: [`GaussNewton`]'s statuses, or
    /// [`GaussNewtonStatus::MaxEvaluations`] at the budget.
    pub status: GaussNewtonStatus,
    /// Iterations (differenced Jacobians).
    pub iterations: usize,
    /// Residual evaluations, the differences' included.
    pub evals: usize,
    /// Column groups: residual evaluations per forward-difference Jacobian.
    pub jacobian_groups: usize,
    /// Accepted cost after each iteration (empty when the budget stopped
    /// the solve).
    pub cost_history: Vec<f64>,
    /// Wall time.
    pub solve_time: Duration,
}

solve::outcome!(DerivativeFreeResult);

/// The derivative-free least-squares solver (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct DerivativeFree {
    settings: DerivativeFreeSettings,
    gauss_newton: GaussNewton,
}

impl DerivativeFree {
    /// A solver with `settings`.
    ///
    /// # Errors
    /// Invalid settings.
    pub fn new(settings: DerivativeFreeSettings) -> Result<Self> {
        settings.validate()?;
        let gauss_newton = GaussNewton::new(settings.gauss_newton.clone())?;
        Ok(Self { settings, gauss_newton })
    }

    /// The settings.
    pub fn settings(&self) -> &DerivativeFreeSettings {
        &self.settings
    }

    /// Minimises $\lVert r(\theta) \rVert^2$ from `theta0` with residual
    /// values only.
    ///
    /// # Errors
    /// Wrong sizes, a non-finite start, an error from the residuals, or
    /// infeasible bounds; as [`GaussNewton::solve`].
    pub fn solve<P: LeastSquaresProblem + ?Sized>(&self, problem: &P, theta0: &[f64]) -> Result<DerivativeFreeResult> {
        self.solve_watched(problem, theta0, &mut Watch::new())
    }

    /// [`solve`](Self::solve) under a [`Watch`], as
    /// [`GaussNewton::solve_watched`] (the observers see every residual
    /// evaluation counted, the differences' included; the statuses
    /// [`GaussNewtonStatus::Stopped`] and [`GaussNewtonStatus::TimeLimit`]).
    ///
    /// # Errors
    /// As [`solve`](Self::solve).
    pub fn solve_watched<P: LeastSquaresProblem + ?Sized>(
        &self,
        problem: &P,
        theta0: &[f64],
        watch: &mut Watch<'_>,
    ) -> Result<DerivativeFreeResult> {
        let differences = self.differences(problem)?;
        let mut run = self.start(&differences, theta0)?;
        let status = solve::drive(&mut run, watch)?;
        run.finish(status)
    }

    /// The problem a solve works on: `problem`'s residuals with their
    /// Jacobian formed by grouped differences, under the settings' budget
    /// of evaluations; [`start`](Self::start) borrows it.
    ///
    /// # Errors
    /// A difference step that is not finite and positive.
    pub fn differences<'a, P: LeastSquaresProblem + ?Sized>(
        &self,
        problem: &'a P,
    ) -> Result<GroupedDifferences<'a, P>> {
        let s = &self.settings;
        GroupedDifferences::new(problem, s.difference, s.step(), s.max_evals.unwrap_or(usize::MAX))
    }

    /// The solve's state before its first iteration, on `differences`
    /// (made by [`differences`](Self::differences), fresh for each solve:
    /// it counts the evaluations), for a loop other than
    /// [`solve_watched`](Self::solve_watched)'s: argmin's `Executor`
    /// through `solve::argmin::Stepper` (feature `argmin`), or the caller's
    /// own, calling [`solve::Iterate::next_iter`] until it returns a status
    /// and then [`solve::Finish::finish`]. A used-up budget is the status
    /// [`GaussNewtonStatus::MaxEvaluations`], with the best point
    /// evaluated.
    ///
    /// ```
    /// use solve::{Finish, Iterate, Watch};
    /// use trajopt::{DerivativeFree, DerivativeFreeSettings};
    /// use trajopt::problems::pendulum_swingup;
    ///
    /// let (problem, theta0) = pendulum_swingup(40, 10.0)?;
    /// let df = DerivativeFree::new(DerivativeFreeSettings::default())?;
    /// let differences = df.differences(&problem)?;
    /// let mut run = df.start(&differences, &theta0)?;
    /// let status = loop {
    ///     if let Some(status) = run.next_iter(&Watch::new())? {
    ///         break status;
    ///     }
    /// };
    /// let r = run.finish(status)?;
    /// assert!(r.status.is_converged());
    /// assert_eq!(r.x, df.solve(&problem, &theta0)?.x);
    /// # Ok::<(), trajopt::TrajoptError>(())
    /// ```
    ///
    /// # Errors
    /// As [`solve`](Self::solve), for the start.
    pub fn start<'a, P: LeastSquaresProblem + ?Sized>(
        &'a self,
        differences: &'a GroupedDifferences<'a, P>,
        theta0: &[f64],
    ) -> Result<DerivativeFreeRun<'a, P>> {
        let started = Instant::now();
        let stage = match self.gauss_newton.start_counted(differences, theta0, differences) {
            Ok(run) => Stage::Iterating(Box::new(run)),
            // the budget ran out at the start (a move into the bounds)
            Err(TrajoptError::BudgetExhausted { .. }) => match differences.best() {
                Some((x, cost)) => Stage::OutOfBudget { x, cost },
                None => {
                    return Err(TrajoptError::InvalidParameter {
                        name: "max_evals",
                        reason: "the budget ran out before the start was evaluated".into(),
                    });
                }
            },
            Err(e) => return Err(e),
        };
        Ok(DerivativeFreeRun {
            settings: &self.settings,
            differences,
            stage,
            started,
        })
    }
}

impl<P: LeastSquaresProblem + ?Sized> EvalCount for GroupedDifferences<'_, P> {
    fn evals(&self) -> usize {
        GroupedDifferences::evals(self)
    }
}

/// A derivative-free solve between iterations ([`DerivativeFree::start`]):
/// a [`solve::Iterate`] state, and a [`solve::Finish`] one whose result is
/// the [`DerivativeFreeResult`] (or the error of the final stationarity
/// check).
pub struct DerivativeFreeRun<'a, P: LeastSquaresProblem + ?Sized> {
    settings: &'a DerivativeFreeSettings,
    differences: &'a GroupedDifferences<'a, P>,
    stage: Stage<'a, P>,
    started: Instant,
}

/// Where a [`DerivativeFreeRun`] is.
enum Stage<'a, P: LeastSquaresProblem + ?Sized> {
    /// Gauss-Newton iterates on the differenced problem.
    /// (boxed: one allocation a solve, and a small stage when out of budget)
    Iterating(Box<GaussNewtonRun<'a, GroupedDifferences<'a, P>>>),
    /// The budget has run out: the best point evaluated and its cost.
    OutOfBudget { x: Vec<f64>, cost: f64 },
}

impl<P: LeastSquaresProblem + ?Sized> std::fmt::Debug for DerivativeFreeRun<'_, P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DerivativeFreeRun")
            .field("evals", &self.differences.evals())
            .field("stage", &self.stage)
            .finish_non_exhaustive()
    }
}

impl<P: LeastSquaresProblem + ?Sized> std::fmt::Debug for Stage<'_, P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Iterating(run) => f.debug_tuple("Iterating").field(run).finish(),
            Self::OutOfBudget { cost, .. } => f
                .debug_struct("OutOfBudget")
                .field("cost", cost)
                .finish_non_exhaustive(),
        }
    }
}

impl<P: LeastSquaresProblem + ?Sized> solve::Iterate for DerivativeFreeRun<'_, P> {
    type Status = GaussNewtonStatus;
    type Error = TrajoptError;
    const NAME: &'static str = "derivative-free";

    fn next_iter(&mut self, watch: &Watch<'_>) -> Result<Option<GaussNewtonStatus>> {
        let Stage::Iterating(run) = &mut self.stage else {
            return Ok(Some(GaussNewtonStatus::MaxEvaluations));
        };
        match run.next_iter(watch) {
            Err(TrajoptError::BudgetExhausted { .. }) => {
                // the best point evaluated (a trial's, maybe), else the last accepted
                let (x, cost) = self.differences.best().unwrap_or_else(|| {
                    let at = run.snapshot();
                    (at.x.to_vec(), at.cost)
                });
                self.stage = Stage::OutOfBudget { x, cost };
                Ok(Some(GaussNewtonStatus::MaxEvaluations))
            }
            outcome => outcome,
        }
    }

    fn snapshot(&self) -> solve::Snapshot<'_> {
        match &self.stage {
            Stage::Iterating(run) => run.snapshot(),
            Stage::OutOfBudget { x, cost } => solve::Snapshot {
                iteration: self.differences.jacobian_evals(),
                evals: self.differences.evals(),
                cost: *cost,
                x,
            },
        }
    }
}

impl<P: LeastSquaresProblem + ?Sized> solve::Finish for DerivativeFreeRun<'_, P> {
    type Output = Result<DerivativeFreeResult>;

    /// The result; a cost or step test is believed only at a stationary
    /// point (else the status is [`GaussNewtonStatus::Stalled`]).
    ///
    /// # Errors
    /// An error of the residuals in the stationarity check.
    fn finish(self, status: GaussNewtonStatus) -> Result<DerivativeFreeResult> {
        let wrapped = self.differences;
        let jacobian_groups = wrapped.groups().n_groups();
        let run = match self.stage {
            Stage::Iterating(run) => *run,
            Stage::OutOfBudget { x, cost } => {
                // the start is the first point evaluated (before any move into the bounds)
                let initial_cost = wrapped.first_cost().unwrap_or(cost);
                return Ok(DerivativeFreeResult {
                    x,
                    cost,
                    initial_cost,
                    status: GaussNewtonStatus::MaxEvaluations,
                    iterations: wrapped.jacobian_evals(),
                    evals: wrapped.evals(),
                    jacobian_groups,
                    cost_history: Vec::new(),
                    solve_time: self.started.elapsed(),
                });
            }
        };
        let mut r = run.finish(status);
        if matches!(
            r.status,
            GaussNewtonStatus::ConvergedCost | GaussNewtonStatus::ConvergedStep
        ) && wrapped.stationarity(&r.x)? > self.settings.tol_stationary
        {
            r.status = GaussNewtonStatus::Stalled;
        }
        Ok(DerivativeFreeResult {
            x: r.x,
            cost: r.cost,
            initial_cost: r.initial_cost,
            status: r.status,
            iterations: r.iterations,
            evals: wrapped.evals(),
            jacobian_groups,
            cost_history: r.cost_history,
            solve_time: self.started.elapsed(),
        })
    }
}
