//! Powell's conjugate-direction method: derivative-free minimisation of
//! $f : \mathbb{R}^n \to \mathbb{R}$, the paper's solver for Eq. 3
//! ("convenient but not particularly efficient").
//!
//! # Method
//!
//! The method keeps a set of $n$ search directions $u_1, \dots, u_n$, initially
//! the scaled coordinate directions $s\,e_i$ ($s$ = `initial_step`). One
//! iteration starting at $x_0$ with $f_0 = f(x_0)$:
//!
//! 1. **Line minimisations.** For $i = 1, \dots, n$:
//!    $x_i = x_{i-1} + \alpha_i u_i$ with
//!    $\alpha_i \approx \arg\min_\alpha f(x_{i-1} + \alpha u_i)$.
//!    Record the largest single decrease
//!    $\Delta = \max_i f(x_{i-1}) - f(x_i)$ and its direction $u_m$.
//! 2. **Convergence test.** With $d = f_0 - f_n$ the iteration's decrease
//!    and $r = \min(d / d_\text{prev}, 0.99)$ its ratio to the previous
//!    iteration's, the test holds if the decrease still to come on a
//!    geometric tail, $d / (1 - r)$, is small:
//!    $2 d / (1 - r) \le \mathrm{tol}_{cost} (|f_0| + |f_n|) + 10^{-20}$, or if
//!    the iteration moved every coordinate by at most
//!    $\mathrm{tol}_{step} (1 + |x_{n,j}|)$ (off by default). The first time it
//!    holds, the direction set is reset to the initial coordinate
//!    directions and the iterations go on; convergence is declared only
//!    if it holds again on the next iteration, over the fresh set (see
//!    *Stopping* below).
//! 3. **Direction replacement** (Powell 1964, in the form of Numerical
//!    Recipes' `powell`). Let $d = x_n - x_0$ and $f_e = f(x_n + d)$ (the
//!    extrapolated point $2x_n - x_0$). If $f_e < f_0$ and
//!    $$2 (f_0 - 2 f_n + f_e) (f_0 - f_n - \Delta)^2 < \Delta (f_0 - f_e)^2,$$
//!    minimise along $d$ too, and replace $u_m$ (the direction of largest
//!    decrease) by the step taken along $d$, moved to the end of the set.
//!    Otherwise keep the set: the test refuses new directions when the
//!    decrease along $u_m$ is a large part of the total, which would make
//!    the set (nearly) linearly dependent. If the set is kept although
//!    $f_e < f_n$, the iterate still moves to the extrapolated point (scipy
//!    and Numerical Recipes discard it; it costs nothing and on Powell's
//!    singular function saves a fifth of the evaluations).
//!
//! On a quadratic with exact line searches, $n$ iterations produce $n$
//! mutually conjugate directions and the exact minimiser.
//!
//! **Line search.** Along a direction searched before, with the curvature
//! $c = \phi''$ of the parabola that ended that search, a line
//! minimisation of $\phi(\alpha) = f(x + \alpha u)$ first tries two
//! evaluations (the second difference of Brent's PRAXIS): $\phi(\alpha_1)$
//! at the first trial $\alpha_1$ (below), then the vertex $\alpha_v$ of the
//! parabola through $(0, \phi(0))$ and $(\alpha_1, \phi(\alpha_1))$ with
//! curvature $c$. It takes $\alpha_v$ when $\phi(\alpha_v)$ is below both
//! and within the parabola's predicted decrease of its predicted value;
//! else the three points bracket a minimum (Brent's method from there) or
//! the search goes on as for a new direction. On the 104
//! Moré-Garbow-Hillstrom runs this cut the median number of evaluations
//! to within $10^{-8}$ of the best minimum known from 1165 to 672.
//!
//! Otherwise the line minimisation first *brackets* a minimum of
//! $\phi(\alpha) = f(x + \alpha u)$ from $\alpha = 0$ (known value) and a
//! first trial $\alpha_1$: the step length accepted by the last line search
//! along the same direction ($\alpha_1 = 1$ for a new direction, which is
//! itself the last step taken, and at the start); downhill steps grow by the
//! golden ratio $\varphi = 1.618\ldots$, accelerated by parabolic
//! extrapolation limited to $110\times$ the last step. Then Brent's method
//! (parabolic interpolation safeguarded by golden-section steps) shrinks the
//! bracket until
//! $|\alpha - \tfrac{a+b}{2}| \le 2\,\mathrm{tol} - \tfrac{b-a}{2}$ with
//! $\mathrm{tol} = \mathrm{tol}_\text{line} |\alpha| + 10^{-11}$ (scipy's
//! rule and tolerance). Savings over scipy's line search, each one an
//! evaluation or more per line minimisation: the known value at
//! $\alpha = 0$ is never evaluated again; the line search of step 3 reuses
//! $f_e$ as its first trial; Brent's method starts from all three bracket
//! points, so its first step is parabolic (the textbook start spends a
//! golden-section step); and near the minimum the remembered step length is
//! of the right size where $\alpha_1 = 1$ is orders of magnitude too long.
//! From the classic starts at the defaults (much tighter than scipy's)
//! this takes 281 evaluations on Rosenbrock's function (scipy 1.17 at its
//! defaults: 607) and 646 on Powell's singular function (scipy: 908), with
//! final costs as low or lower (`scripts/compare_powell.py`,
//! `tests/powell.rs`).
//!
//! # Objective
//!
//! Implement [`Objective`] (one method, `cost(&self, x) -> Result<f64>`); any
//! closure `Fn(&[f64]) -> Result<f64>` implements it. A NaN or infinite
//! value at a trial point is treated as $+\infty$ (the trial is rejected and
//! the search goes elsewhere); a non-finite value at the start point is
//! [`TrajoptError::NonFiniteStart`]. An `Err` from the objective stops the
//! solve and is returned unchanged.
//!
//! # Bounds
//!
//! With `bounds = Some((lower, upper))` ($-\infty$ / $+\infty$ allowed) the
//! start point is clipped into the box, and every line search is limited to
//! the interval $[\alpha_\text{lo}, \alpha_\text{hi}]$ of step lengths that
//! keep $x + \alpha u$ inside the box (scipy's approach since 1.5): the
//! bracketing steps are clamped to that interval, and when the function
//! still decreases at a clamped end, Brent's search runs on the last
//! interval with that end as its best point, so a minimiser on the bound is
//! found exactly. The extrapolated point of the replacement test is also
//! pulled back onto the box. Every evaluated point is inside the box.
//!
//! Once a coordinate sits on a bound, directions that mix it with free
//! coordinates can only move one way along the bound, and the sweeps stall
//! (scipy's bounded Powell stops far from the constrained minimum of
//! Rosenbrock in $[-2, 0.5] \times [-2, 2]$ this way). The confirmation
//! sweep over the coordinate directions of step 2 covers this case:
//! convergence is declared only from a stall of the fresh coordinate set,
//! i.e. when no single coordinate can improve either.
//!
//! # Stopping
//!
//! A small decrease over one sweep says that the sweep was slow, not that
//! the minimum is near: scipy's rule (stop when a sweep lowers $f$ by less
//! than $10^{-4}$ relative) stopped this method away from any minimum on
//! 33 of the 103 Moré-Garbow-Hillstrom runs that it declared converged (35
//! problems from $x_0$, $10 x_0$ and $100 x_0$), e.g. at $f = 2.46$ on
//! extended Rosenbrock ($n = 10$, $f^* = 0$). Three changes make a
//! converged status mean a minimum:
//!
//! - the default `tol_cost` is $10^{-10}$ (scipy: $10^{-4}$), and the step
//!   test is off by default (`tol_step = 0`): in a narrow valley one sweep
//!   moves every coordinate by less than $10^{-8}$ relative while $f$ is
//!   still far above its minimum;
//! - the test bounds the decrease still to come, not the last one: when
//!   the decreases shrink slowly (ratio $r$ near 1), the remaining decrease
//!   $d / (1 - r)$ is up to 100 times the last;
//! - the test must hold twice, the second time on a sweep over a fresh set
//!   of coordinate directions (as PRAXIS resets its directions to the
//!   principal axes): a set that has become (nearly) linearly dependent
//!   stalls in a subspace, and the fresh set leaves it.
//!
//! With the defaults, on the same runs (104: Jennrich and Sampson's
//! $100 x_0$ has no finite cost; `cargo run --release -p nprl-trajopt
//! --example powell_mgh`): 91 report convergence, 76 at the best minimum
//! known, 6 at another minimum the paper lists, 9 at another local minimum
//! (Gauss-Newton started there does not go lower), none elsewhere; the
//! other 13 stop at `MaxEvaluations` (Penalty I and II, Meyer, Beale from
//! $10 x_0$ and $100 x_0$: slow valleys). Not converging is reported as
//! such. The rule is not proof against every valley: before the line
//! search reused curvatures, Osborne 1 and Biggs EXP6 from $100 x_0$
//! stopped with `ConvergedCost` in deep, curved valleys where the
//! decrease per sweep vanishes (at $f = 8.0 \cdot 10^{-5}$ and $0.081$)
//! while Gauss-Newton, started there, goes on down (to $5.5 \cdot 10^{-5}$
//! and $5.7 \cdot 10^{-3}$), and Biggs EXP6 does again with an initial step
//! of $0.01 \max(|x_{0,j}|, 1)$.
//!
//! # Principal axes
//!
//! With `principal_axes = k > 0`, every $k$ iterations (after the
//! replacement step) the direction set becomes the principal axes of the
//! quadratic model it implies, as in Brent's PRAXIS: if the directions
//! $u_i$ are conjugate with curvatures $c_i = \phi_i''$ (known from their
//! last line searches), $H^{-1} = \sum_i u_i u_i^\top / c_i = M M^\top$ with
//! $M = [u_i / \sqrt{c_i}]$, and the singular value decomposition
//! $M = U S W^\top$ gives the new directions $s_i U_i$: orthogonal, so the
//! set cannot lose a dimension, and scaled so that the model's curvature
//! along each is 1, which the next line search's first parabola uses. The
//! set is kept while a curvature is unknown or not positive. The SVD costs
//! $O(n^3)$ per reset, nothing next to the evaluations of a sweep. Off by
//! default; the effort table of `powell_mgh` takes `--principal-axes=N`.
//!
//! # Which problems it suits
//!
//! Small problems (up to a few tens of parameters) whose cost is cheap and
//! has no derivatives. On the Moré-Garbow-Hillstrom set (35 problems, $n$
//! from 2 to 12, from $x_0$, $10 x_0$ and $100 x_0$; 104 runs with a
//! finite start), with `tol_cost = tol_step = 0` and a budget of $2000 (n + 1)$
//! evaluations, 81 runs reach $f_\text{best} + 10^{-8} (1 + |f_\text{best}|)$
//! ($f_\text{best}$ the best minimum known) with a median of 672
//! evaluations; before the line search reused curvatures, 75 with a
//! median of 1165 (`cargo run --release -p nprl-trajopt --example
//! powell_mgh -- effort --list` prints every run). Rosenbrock's function
//! takes 233 evaluations to that target, Powell's singular function 231.
//!
//! Not Eq. 3 at the paper's sizes: hundreds of coupled, badly scaled
//! coefficients. On `trajopt::problems::trajectory`'s pendulum (one
//! parameter per sample), to come within $10^{-3}$ (relative) of
//! Gauss-Newton's optimum, Powell needs 773,677 evaluations at horizon 50
//! and $\lambda = 1$ (152 parameters) and 1,476,363 at $\lambda = 100$; at
//! horizon 150 and $\lambda = 100$ (452 parameters) its default budget of
//! 452,000 evaluations lowers the cost from 500.9 to 491.6, where
//! Gauss-Newton reaches 2.77, and 20 times that budget only to 468.9
//! (`cargo run --release -p nprl-trajopt --example powell_separable --
//! 50 20000 1`, `-- 50 20000 100`, `-- 150 1000 100`, `-- 150 20000 100`). Use [`GaussNewton`](crate::GaussNewton) there;
//! Powell stays as the paper's baseline.
//!
//! # Partially separable objectives
//!
//! Eq. 3 is a sum of terms that each depend on a few coefficients: a
//! coordinate direction changes only the terms of its coordinate. A
//! [`SeparableObjective`] says so (the number of terms, the terms of each
//! coordinate, and the values of chosen terms); [`BandTerms`] makes one of
//! any [`BandForm`](crate::BandForm) problem, e.g. an
//! [`Eq3Problem`](crate::Eq3Problem), one term per part of its residuals.
//! [`Powell::solve_separable`] then keeps the terms' values at the best
//! point so far and evaluates, at each trial, only the terms of the
//! coordinates where it differs; [`PowellResult::full_eval_equivalents`]
//! counts each evaluation as the fraction of the terms it evaluated. The
//! gain is large while the direction set is mostly coordinate directions
//! and fades as Powell's replacements make it dense. Measured with the
//! commands above (one term per time step; wall times on a shared
//! two-core machine):
//!
//! | pendulum | `solve`: evaluations, time | `solve_separable`: evaluations, full-evaluation equivalents, time |
//! |---|---|---|
//! | horizon 50, $\lambda = 1$, to the target | 773,677, 3.28 s | 1,224,537, 478,041, 3.03 s |
//! | horizon 50, $\lambda = 100$, to the target | 1,476,363, 5.94 s | 1,985,730, 611,014, 4.05 s |
//! | horizon 150, $\lambda = 100$, the default budget | 452,000, 5.11 s | 452,000, 27,264, 0.97 s |
//! | horizon 150, $\lambda = 100$, 20 times that | 9,040,000 (cost 468.9), 245.6 s | 9,040,000 (cost 485.4), 663,808, 25.0 s |
//!
//! (The two solves take different paths: the sums round differently, and
//! the line searches' tolerance on the step turns that into different
//! steps.)
//!
//! # Guarantees
//!
//! The returned cost is never higher than the cost at the (clipped) start:
//! the point moves only to a strictly lower evaluated value (of a line
//! search or the extrapolated point).
//! No allocation happens per evaluation (one reused trial buffer).
//!
//! # Defaults
//!
//! | field | default | meaning |
//! |---|---|---|
//! | `tol_step` | 0 (off) | relative step tolerance per iteration |
//! | `tol_cost` | $10^{-10}$ | relative tolerance on the decrease still to come |
//! | `tol_line` | $10^{-2}$ | Brent's relative tolerance on $\alpha$ (scipy: `100 * xtol`) |
//! | `max_iterations` | `None` = $1000 n$ | iterations (sweeps over the direction set) |
//! | `max_evals` | `None` = $1000 n$ | cost evaluations, start included |
//! | `initial_step` | 1 | length of the initial coordinate directions |
//! | `bounds` | `None` | box constraints |
//! | `stop_cost` | `None` | stop at the first value at or below it |
//! | `principal_axes` | 0 (off) | iterations between resets to the principal axes |
//!
//! # Layout
//!
//! This file holds the settings, the result and [`Powell::solve`];
//! `engine.rs` the iteration (a sweep over the direction set, Powell's
//! replacement test and the stopping tests), `line_search.rs` the
//! bracketing and Brent's line search, `separable.rs` the partially
//! separable objectives, `argmin.rs` the argmin solver.
//!
//! # argmin
//!
//! [`PowellArgmin`] runs the same iterations under argmin's `Executor` (one
//! argmin iteration = one sweep over the direction set), for its observers
//! and time-outs.
//!
//! # References
//!
//! - M. J. D. Powell (1964), "An efficient method for finding the minimum of
//!   a function of several variables without calculating derivatives",
//!   *The Computer Journal* 7(2), 155–162.
//! - R. P. Brent (1973), *Algorithms for Minimization without Derivatives*,
//!   Prentice-Hall, ch. 5 (the line search).
//! - W. H. Press, S. A. Teukolsky, W. T. Vetterling, B. P. Flannery,
//!   *Numerical Recipes*, 3rd ed. (2007), §10.1 (bracketing), §10.3 (Brent),
//!   §10.7 (Powell's direction-set method and the replacement test).
//!
//! # Example
//!
//! ```
//! use trajopt::powell::{Powell, PowellSettings};
//!
//! let rosenbrock = |x: &[f64]| -> trajopt::Result<f64> {
//!     Ok(100.0 * (x[1] - x[0] * x[0]).powi(2) + (1.0 - x[0]).powi(2))
//! };
//! let powell = Powell::new(PowellSettings::default())?;
//! let result = powell.solve(&rosenbrock, &[-1.2, 1.0])?;
//! assert!(result.status.is_converged());
//! assert!((result.x[0] - 1.0).abs() < 1e-6 && (result.x[1] - 1.0).abs() < 1e-6);
//! assert!(result.cost <= result.initial_cost);
//! # Ok::<(), trajopt::TrajoptError>(())
//! ```

#[cfg(feature = "argmin")]
mod argmin;
mod engine;
mod line_search;
mod separable;

use std::time::{Duration, Instant};

use crate::error::{Result, TrajoptError, check_nonnegative};
use engine::Engine;
use solve::{Interrupt, Termination, Watch};

/// The solver's name in [`solve::Progress`].
const NAME: &str = "powell";

#[cfg(feature = "argmin")]
pub use argmin::PowellArgmin;
use separable::TermCache;
pub use separable::{BandTerms, SeparableObjective};

/// A cost function $f(x)$ to minimise.
///
/// Implemented for every closure `Fn(&[f64]) -> Result<f64>`.
pub trait Objective {
    /// The cost at `x`. A non-finite value counts as $+\infty$ at trial
    /// points; an `Err` aborts the solve.
    fn cost(&self, x: &[f64]) -> Result<f64>;
}

impl<F> Objective for F
where
    F: Fn(&[f64]) -> Result<f64>,
{
    fn cost(&self, x: &[f64]) -> Result<f64> {
        self(x)
    }
}

/// Settings of [`Powell`] (and [`PowellArgmin`]).
///
/// | field | default | range |
/// |---|---|---|
/// | `tol_step` | 0 | finite, $\ge 0$ |
/// | `tol_cost` | $10^{-10}$ | finite, $\ge 0$ |
/// | `tol_line` | $10^{-2}$ | finite, $\ge 0$ |
/// | `max_iterations` | `None` ($1000 n$) | $\ge 1$ |
/// | `max_evals` | `None` ($1000 n$) | $\ge 1$ |
/// | `initial_step` | 1 | finite, $> 0$ |
/// | `bounds` | `None` | `lower.len() == upper.len()`, no NaN, `lower <= upper` |
/// | `stop_cost` | `None` | not NaN |
/// | `principal_axes` | 0 (off) | any |
///
/// The budgets are scipy's `minimize(method="Powell")` defaults
/// (`maxiter = maxfev = 1000 n`); the tolerances are much tighter than
/// scipy's `ftol = 1e-4`, which declares convergence far from the minimum
/// (see the [module docs](self#stopping)). `tol_cost = 1e-4, tol_step = 1e-8`
/// come close to scipy's stopping rule, but the convergence test still
/// has to hold on a confirming sweep.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PowellSettings {
    /// The convergence test holds when an iteration moves every coordinate
    /// $j$ by at most $\mathrm{tol}_{step} (1 + |x_j|)$ (0: never).
    pub tol_step: f64,
    /// The convergence test holds when an iteration's decrease $d$ and its
    /// ratio $r \le 0.99$ to the previous one satisfy
    /// $2 d / (1 - r) \le \mathrm{tol}_{cost} (|f_0| + |f_n|) + 10^{-20}$.
    /// Either test must hold on two consecutive iterations, the second
    /// over a fresh coordinate set, to stop.
    pub tol_cost: f64,
    /// Relative tolerance of Brent's line search on the step length
    /// $\alpha$ (absolute floor $10^{-11}$).
    pub tol_line: f64,
    /// Maximum number of iterations (`None`: $1000 n$).
    pub max_iterations: Option<usize>,
    /// Maximum number of cost evaluations, the start point's included
    /// (`None`: $1000 n$). Never exceeded.
    pub max_evals: Option<usize>,
    /// Length of the initial search directions $s e_i$: the first bracketing
    /// trial along direction $i$ moves coordinate $i$ by this much.
    pub initial_step: f64,
    /// Box constraints `(lower, upper)`, one entry per coordinate;
    /// infinite entries leave a side unbounded.
    pub bounds: Option<(Vec<f64>, Vec<f64>)>,
    /// Stop as soon as an evaluation returns a value at or below this
    /// (NLopt's `stopval`), with [`PowellStatus::ReachedStopCost`]: for
    /// measuring the evaluations needed to reach a known optimum.
    pub stop_cost: Option<f64>,
    /// Every this many iterations, replace the direction set by the
    /// principal axes of the quadratic model it implies, as Brent's PRAXIS
    /// does (see the [module docs](self#principal-axes)); 0 never.
    pub principal_axes: usize,
}

impl Default for PowellSettings {
    fn default() -> Self {
        Self {
            tol_step: 0.0,
            tol_cost: 1e-10,
            tol_line: 1e-2,
            max_iterations: None,
            max_evals: None,
            initial_step: 1.0,
            bounds: None,
            stop_cost: None,
            principal_axes: 0,
        }
    }
}

pub(super) fn invalid(name: &'static str, reason: impl Into<String>) -> TrajoptError {
    TrajoptError::InvalidParameter {
        name,
        reason: reason.into(),
    }
}

impl PowellSettings {
    /// Checks every field against its range (see the table above).
    pub fn validate(&self) -> Result<()> {
        check_nonnegative([
            ("tol_step", self.tol_step),
            ("tol_cost", self.tol_cost),
            ("tol_line", self.tol_line),
        ])?;
        if self.stop_cost.is_some_and(f64::is_nan) {
            return Err(invalid("stop_cost", "must not be NaN"));
        }
        if self.max_iterations == Some(0) {
            return Err(invalid("max_iterations", "must be at least 1"));
        }
        if self.max_evals == Some(0) {
            return Err(invalid("max_evals", "must be at least 1"));
        }
        if !(self.initial_step.is_finite() && self.initial_step > 0.0) {
            return Err(invalid(
                "initial_step",
                format!("must be finite and > 0, got {}", self.initial_step),
            ));
        }
        if let Some((lower, upper)) = &self.bounds {
            if lower.len() != upper.len() {
                return Err(TrajoptError::DimensionMismatch {
                    what: "upper bounds",
                    expected: lower.len(),
                    actual: upper.len(),
                });
            }
            for (j, (&l, &u)) in lower.iter().zip(upper).enumerate() {
                if l.is_nan() || u.is_nan() || l > u || l == f64::INFINITY || u == f64::NEG_INFINITY {
                    return Err(invalid(
                        "bounds",
                        format!("need lower <= upper without NaN at {j}, got [{l}, {u}]"),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Why [`Powell::solve`] stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum PowellStatus {
    /// The decrease still to come fell below `tol_cost` (relative), also on a
    /// confirming sweep over a fresh coordinate set.
    ConvergedCost,
    /// No coordinate moved by more than `tol_step` (relative) in an iteration,
    /// also on a confirming sweep over a fresh coordinate set.
    ConvergedStep,
    /// `max_iterations` iterations were done.
    MaxIterations,
    /// The `max_evals` budget of cost evaluations was used up.
    MaxEvaluations,
    /// The [`Watch`]'s time limit passed (checked before every evaluation
    /// when a limit is set).
    TimeLimit,
    /// An observer of the [`Watch`] stopped the solve (after an iteration).
    Stopped,
    /// An evaluation reached `stop_cost`; `evals` counts the
    /// evaluations up to that one.
    ReachedStopCost,
}

/// The variant's name (`ConvergedCost`), as serde writes it.
impl std::fmt::Display for PowellStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::ConvergedCost => "ConvergedCost",
            Self::ConvergedStep => "ConvergedStep",
            Self::MaxIterations => "MaxIterations",
            Self::MaxEvaluations => "MaxEvaluations",
            Self::TimeLimit => "TimeLimit",
            Self::Stopped => "Stopped",
            Self::ReachedStopCost => "ReachedStopCost",
        })
    }
}

impl PowellStatus {
    /// True for the converged statuses.
    pub fn is_converged(self) -> bool {
        matches!(self, Self::ConvergedCost | Self::ConvergedStep)
    }
}

solve::from_interrupt!(PowellStatus);

impl solve::Status for PowellStatus {
    fn termination(&self) -> Termination {
        match self {
            Self::ConvergedCost | Self::ConvergedStep => Termination::Converged,
            Self::MaxIterations => Termination::MaxIterations,
            Self::MaxEvaluations => Termination::MaxEvaluations,
            Self::TimeLimit => Termination::TimeLimit,
            Self::Stopped => Termination::Stopped,
            Self::ReachedStopCost => Termination::TargetReached,
        }
    }
}

/// Why an evaluation inside an iteration did not return a cost.
enum Halt {
    Error(TrajoptError),
    Interrupt(Interrupt),
}

/// The outcome of [`Powell::solve`].
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PowellResult {
    /// The best point found (inside the bounds, if any).
    pub x: Vec<f64>,
    /// $f(x)$; never above `initial_cost`.
    pub cost: f64,
    /// The cost at the (clipped) start point.
    pub initial_cost: f64,
    /// Why the solver stopped.
    pub status: PowellStatus,
    /// Iterations (sweeps over the direction set) done.
    pub iterations: usize,
    /// Cost evaluations, the start point's included.
    pub evals: usize,
    /// The evaluations' work in full evaluations: `evals` for
    /// [`Powell::solve`]; for [`Powell::solve_separable`] each evaluation
    /// counts as the fraction of the terms it evaluated.
    pub full_eval_equivalents: f64,
    /// The cost after each iteration (one entry per iteration).
    pub cost_history: Vec<f64>,
    /// Wall time of the solve.
    pub solve_time: Duration,
}

solve::outcome!(PowellResult);

/// Powell's conjugate-direction method (see the [module docs](self)).
///
/// ```
/// use trajopt::powell::{Powell, PowellSettings};
///
/// // a bounded problem: the minimiser (2, 0.5) is outside the box [0, 1]^2
/// let settings = PowellSettings {
///     bounds: Some((vec![0.0, 0.0], vec![1.0, 1.0])),
///     ..PowellSettings::default()
/// };
/// let f = |x: &[f64]| -> trajopt::Result<f64> { Ok((x[0] - 2.0).powi(2) + (x[1] - 0.5).powi(2)) };
/// let result = Powell::new(settings)?.solve(&f, &[0.5, 0.5])?;
/// assert!((result.x[0] - 1.0).abs() < 1e-12 && (result.x[1] - 0.5).abs() < 1e-6);
/// # Ok::<(), trajopt::TrajoptError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Powell {
    settings: PowellSettings,
}

impl Powell {
    /// A solver with checked settings.
    pub fn new(settings: PowellSettings) -> Result<Self> {
        settings.validate()?;
        Ok(Self { settings })
    }

    /// The settings.
    pub fn settings(&self) -> &PowellSettings {
        &self.settings
    }

    /// Minimises `f` from `x0`.
    ///
    /// Errors: empty `x0` ([`TrajoptError::InvalidParameter`]), a NaN or
    /// infinity in `x0` ([`TrajoptError::NotFinite`]), bounds of the wrong
    /// length ([`TrajoptError::DimensionMismatch`]), a non-finite cost at the
    /// start ([`TrajoptError::NonFiniteStart`]), or an `Err` returned by `f`.
    /// Not converging is a [`PowellStatus`], not an error.
    pub fn solve(&self, f: &impl Objective, x0: &[f64]) -> Result<PowellResult> {
        self.solve_watched(f, x0, &mut Watch::new())
    }

    /// [`solve`](Self::solve) under a [`Watch`]: its observers see every
    /// iteration (one sweep over the direction set) and may stop the
    /// solve ([`PowellStatus::Stopped`]); its time limit is checked before
    /// every cost evaluation ([`PowellStatus::TimeLimit`]: a sweep on many
    /// coordinates can be long). Either way the result holds the best
    /// point so far.
    ///
    /// ```
    /// use std::time::Duration;
    /// use solve::Watch;
    /// use trajopt::powell::{Powell, PowellSettings, PowellStatus};
    ///
    /// let f = |x: &[f64]| -> trajopt::Result<f64> { Ok(x.iter().map(|v| (v - 1.0).powi(4)).sum()) };
    /// // a limit already passed: the start only
    /// let mut watch = Watch::new().with_time_limit(Duration::ZERO);
    /// let r = Powell::new(PowellSettings::default())?.solve_watched(&f, &[0.0; 10], &mut watch)?;
    /// assert_eq!((r.status, r.evals, r.cost), (PowellStatus::TimeLimit, 1, 10.0));
    /// # Ok::<(), trajopt::TrajoptError>(())
    /// ```
    ///
    /// # Errors
    /// As [`solve`](Self::solve).
    pub fn solve_watched(&self, f: &impl Objective, x0: &[f64], watch: &mut Watch<'_>) -> Result<PowellResult> {
        let mut eval = |x: &Vec<f64>| f.cost(x);
        let mut result = self.run(x0, &mut eval, watch)?;
        result.full_eval_equivalents = result.evals as f64;
        Ok(result)
    }

    /// Minimises a [`SeparableObjective`] from `x0`: the iterations of
    /// [`solve`](Self::solve) (the sums round differently, so the paths
    /// can differ within the line searches' tolerance), but each trial point evaluates only the terms that depend on
    /// the coordinates where it differs from the best point so far. A line
    /// search along a coordinate direction evaluates the few terms of that
    /// coordinate; along a dense direction, all of them.
    /// [`PowellResult::full_eval_equivalents`] counts each evaluation as
    /// the fraction of the terms it evaluated; the budget `max_evals`
    /// counts evaluations, partial or not.
    ///
    /// # Errors
    /// As [`solve`](Self::solve).
    pub fn solve_separable(&self, f: &impl SeparableObjective, x0: &[f64]) -> Result<PowellResult> {
        let mut cache = TermCache::new(f.n_terms());
        let mut eval = |x: &Vec<f64>| cache.eval(f, x);
        let mut result = self.run(x0, &mut eval, &mut Watch::new())?;
        result.full_eval_equivalents = cache.work;
        Ok(result)
    }

    fn run(
        &self,
        x0: &[f64],
        eval: &mut impl FnMut(&Vec<f64>) -> Result<f64>,
        watch: &mut Watch<'_>,
    ) -> Result<PowellResult> {
        let start = Instant::now();
        let engine = Engine::start(&self.settings, x0, &mut *eval)?;
        let initial_cost = engine.fx;
        let mut run = Run {
            engine,
            eval,
            cost_history: Vec::new(),
        };
        let status = solve::drive(&mut run, watch)?;
        let Run {
            engine, cost_history, ..
        } = run;
        Ok(PowellResult {
            x: engine.x,
            cost: engine.fx,
            initial_cost,
            status,
            iterations: engine.iters,
            evals: engine.evals,
            full_eval_equivalents: engine.evals as f64,
            cost_history,
            solve_time: start.elapsed(),
        })
    }
}

/// One Powell solve as the driver runs it: the engine, its objective and
/// the costs after each iteration.
struct Run<'e, F> {
    engine: Engine,
    eval: &'e mut F,
    cost_history: Vec<f64>,
}

impl<F: FnMut(&Vec<f64>) -> Result<f64>> solve::Iterate for Run<'_, F> {
    type Status = PowellStatus;
    type Error = TrajoptError;
    const NAME: &'static str = NAME;

    fn next_iter(&mut self, watch: &Watch<'_>) -> Result<Option<PowellStatus>> {
        let eval = &mut *self.eval;
        // with a time limit, every evaluation first checks the clock
        let step = if watch.time_limit().is_some() {
            let mut checked = |x: &Vec<f64>| match watch.out_of_time() {
                Some(why) => Err(Halt::Interrupt(why)),
                None => eval(x).map_err(Halt::Error),
            };
            self.engine.iterate(&mut checked)
        } else {
            self.engine.iterate(&mut |x: &Vec<f64>| eval(x).map_err(Halt::Error))
        };
        match step {
            Ok(status) => {
                self.cost_history.push(self.engine.fx);
                Ok(status)
            }
            Err(Halt::Error(e)) => Err(e),
            Err(Halt::Interrupt(why)) => {
                // the engine counts an evaluation before making it
                self.engine.evals -= 1;
                Ok(Some(why.into()))
            }
        }
    }

    fn snapshot(&self) -> solve::Snapshot<'_> {
        solve::Snapshot {
            iteration: self.engine.iters,
            evals: self.engine.evals,
            cost: self.engine.fx,
            x: &self.engine.x,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rosenbrock(x: &[f64]) -> Result<f64> {
        Ok(x.windows(2)
            .map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2))
            .sum())
    }

    /// Powell under `settings` on the two-dimensional Rosenbrock function
    /// from its standard start $(-1.2, 1)$.
    fn solve_rosenbrock(settings: PowellSettings) -> PowellResult {
        Powell::new(settings)
            .expect("settings")
            .solve(&rosenbrock, &[-1.2, 1.0])
            .expect("solve")
    }

    #[test]
    fn settings_are_validated() {
        let bad = [
            PowellSettings {
                tol_cost: -1.0,
                ..Default::default()
            },
            PowellSettings {
                tol_step: f64::NAN,
                ..Default::default()
            },
            PowellSettings {
                max_evals: Some(0),
                ..Default::default()
            },
            PowellSettings {
                max_iterations: Some(0),
                ..Default::default()
            },
            PowellSettings {
                initial_step: 0.0,
                ..Default::default()
            },
            PowellSettings {
                bounds: Some((vec![1.0], vec![0.0])),
                ..Default::default()
            },
            PowellSettings {
                bounds: Some((vec![0.0], vec![1.0, 2.0])),
                ..Default::default()
            },
            PowellSettings {
                stop_cost: Some(f64::NAN),
                ..Default::default()
            },
        ];
        for settings in bad {
            assert!(Powell::new(settings.clone()).is_err(), "{settings:?}");
        }
        assert!(Powell::new(PowellSettings::default()).is_ok());
    }

    #[test]
    fn bad_input_is_an_error() {
        let powell = Powell::new(PowellSettings::default()).expect("settings");
        assert!(matches!(
            powell.solve(&rosenbrock, &[]),
            Err(TrajoptError::InvalidParameter { .. })
        ));
        assert!(matches!(
            powell.solve(&rosenbrock, &[1.0, f64::NAN]),
            Err(TrajoptError::NotFinite { index: 1, .. })
        ));
        let nan = |_: &[f64]| -> Result<f64> { Ok(f64::NAN) };
        assert!(matches!(
            powell.solve(&nan, &[1.0]),
            Err(TrajoptError::NonFiniteStart { .. })
        ));
        let bounded = Powell::new(PowellSettings {
            bounds: Some((vec![0.0], vec![1.0])),
            ..Default::default()
        })
        .expect("settings");
        assert!(matches!(
            bounded.solve(&rosenbrock, &[0.5, 0.5]),
            Err(TrajoptError::DimensionMismatch {
                expected: 2,
                actual: 1,
                ..
            })
        ));
        let failing = |x: &[f64]| -> Result<f64> {
            if x[0] > 2.0 {
                Err(TrajoptError::Model("boom".into()))
            } else {
                Ok(-x[0])
            }
        };
        assert_eq!(powell.solve(&failing, &[0.0]), Err(TrajoptError::Model("boom".into())));
    }

    #[test]
    fn budget_is_never_exceeded() {
        for max_evals in [1, 2, 5, 17, 60] {
            let result = solve_rosenbrock(PowellSettings {
                max_evals: Some(max_evals),
                ..Default::default()
            });
            assert!(result.evals <= max_evals, "{} > {max_evals}", result.evals);
            assert_eq!(result.status, PowellStatus::MaxEvaluations);
            assert!(result.cost <= result.initial_cost);
        }
        let result = solve_rosenbrock(PowellSettings {
            max_iterations: Some(2),
            ..Default::default()
        });
        assert_eq!((result.status, result.iterations), (PowellStatus::MaxIterations, 2));
    }

    #[test]
    fn stop_cost_stops_at_the_first_value_below_it() {
        let full = solve_rosenbrock(PowellSettings::default());
        for stop in [1.0, 1e-3, 1e-10] {
            let calls = std::cell::Cell::new(0);
            let first_below = std::cell::Cell::new(None);
            let f = |x: &[f64]| -> Result<f64> {
                let v = rosenbrock(x)?;
                calls.set(calls.get() + 1);
                if v <= stop && first_below.get().is_none() {
                    first_below.set(Some(calls.get()));
                }
                Ok(v)
            };
            let result = Powell::new(PowellSettings {
                stop_cost: Some(stop),
                ..Default::default()
            })
            .expect("settings")
            .solve(&f, &[-1.2, 1.0])
            .expect("solve");
            assert_eq!(result.status, PowellStatus::ReachedStopCost);
            assert!(!result.status.is_converged());
            assert!(result.cost <= stop, "{stop}: {}", result.cost);
            assert_eq!(Some(result.evals), first_below.get(), "{stop}");
            assert_eq!(result.evals, calls.get());
            assert!(result.evals < full.evals);
        }
    }

    #[test]
    fn returned_cost_is_the_cost_at_x() {
        let powell = Powell::new(PowellSettings::default()).expect("settings");
        let result = powell.solve(&rosenbrock, &[-1.2, 1.0, 0.5]).expect("solve");
        assert_eq!(rosenbrock(&result.x).expect("cost"), result.cost);
    }

    #[test]
    fn cost_history_has_one_falling_entry_per_iteration() {
        let result = solve_rosenbrock(PowellSettings::default());
        assert_eq!(result.cost_history.len(), result.iterations);
        assert!(result.cost_history.windows(2).all(|w| w[1] <= w[0]));
        assert_eq!(result.cost_history.last(), Some(&result.cost));
        assert!(result.cost_history[0] < result.initial_cost);
    }
}
