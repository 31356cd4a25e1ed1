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
//! 2. **Convergence.** Stop if
//!    $2 (f_0 - f_n) \le \mathrm{tol}_f (|f_0| + |f_n|) + 10^{-20}$
//!    (relative decrease, as scipy's `ftol`), or if the iteration moved every
//!    coordinate by at most $\mathrm{tol}_x (1 + |x_{n,j}|)$.
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
//! **Line search.** Each line minimisation first *brackets* a minimum of
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
//! From the classic starts at the default (scipy's) tolerances this takes
//! 313 evaluations on Rosenbrock's function (scipy 1.17: 607) and 778 on
//! Powell's singular function (scipy: 908), with final costs as low or
//! lower (`scripts/compare_powell.py`).
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
//! Rosenbrock in $[-2, 0.5] \times [-2, 2]$ this way). So when a convergence
//! test fires with some coordinate on a bound and a direction set changed
//! since the last reset, the set is reset to the coordinate directions and
//! the iterations go on; convergence is declared only from a stall of the
//! (fresh) coordinate set, i.e. when no single coordinate can improve.
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
//! | `tol_x` | $10^{-8}$ | relative step tolerance per iteration |
//! | `tol_f` | $10^{-4}$ | relative decrease tolerance per iteration (scipy's `ftol`) |
//! | `tol_line` | $10^{-2}$ | Brent's relative tolerance on $\alpha$ (scipy: `100 * xtol`) |
//! | `max_iters` | `None` = $1000 n$ | iterations (sweeps over the direction set) |
//! | `max_evals` | `None` = $1000 n$ | cost evaluations, start included |
//! | `initial_step` | 1 | length of the initial coordinate directions |
//! | `bounds` | `None` | box constraints |
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
//! assert!(result.status.converged());
//! assert!((result.x[0] - 1.0).abs() < 1e-6 && (result.x[1] - 1.0).abs() < 1e-6);
//! assert!(result.cost <= result.initial_cost);
//! # Ok::<(), trajopt::TrajoptError>(())
//! ```

use std::time::{Duration, Instant};

use argmin::core::{CostFunction, IterState, KV, Problem, Solver, State, TerminationReason, TerminationStatus};

use crate::error::{Result, TrajoptError, check_finite};

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
/// | `tol_x` | $10^{-8}$ | finite, $\ge 0$ |
/// | `tol_f` | $10^{-4}$ | finite, $\ge 0$ |
/// | `tol_line` | $10^{-2}$ | finite, $\ge 0$ |
/// | `max_iters` | `None` ($1000 n$) | $\ge 1$ |
/// | `max_evals` | `None` ($1000 n$) | $\ge 1$ |
/// | `initial_step` | 1 | finite, $> 0$ |
/// | `bounds` | `None` | `lower.len() == upper.len()`, no NaN, `lower <= upper` |
///
/// The defaults reproduce scipy's `minimize(method="Powell")` defaults
/// (`xtol = 1e-4`, `ftol = 1e-4`, `maxiter = maxfev = 1000 n`); scipy has no
/// step test, so `tol_x` is small by default.
#[derive(Debug, Clone, PartialEq)]
pub struct PowellSettings {
    /// Stop when an iteration moves every coordinate $j$ by at most
    /// $\mathrm{tol}_x (1 + |x_j|)$.
    pub tol_x: f64,
    /// Stop when an iteration's decrease satisfies
    /// $2 (f_0 - f_n) \le \mathrm{tol}_f (|f_0| + |f_n|) + 10^{-20}$.
    pub tol_f: f64,
    /// Relative tolerance of Brent's line search on the step length
    /// $\alpha$ (absolute floor $10^{-11}$).
    pub tol_line: f64,
    /// Maximum number of iterations (`None`: $1000 n$).
    pub max_iters: Option<usize>,
    /// Maximum number of cost evaluations, the start point's included
    /// (`None`: $1000 n$). Never exceeded.
    pub max_evals: Option<usize>,
    /// Length of the initial search directions $s e_i$: the first bracketing
    /// trial along direction $i$ moves coordinate $i$ by this much.
    pub initial_step: f64,
    /// Box constraints `(lower, upper)`, one entry per coordinate;
    /// infinite entries leave a side unbounded.
    pub bounds: Option<(Vec<f64>, Vec<f64>)>,
}

impl Default for PowellSettings {
    fn default() -> Self {
        Self {
            tol_x: 1e-8,
            tol_f: 1e-4,
            tol_line: 1e-2,
            max_iters: None,
            max_evals: None,
            initial_step: 1.0,
            bounds: None,
        }
    }
}

fn invalid(name: &'static str, reason: impl Into<String>) -> TrajoptError {
    TrajoptError::InvalidParameter {
        name,
        reason: reason.into(),
    }
}

impl PowellSettings {
    /// Checks every field against its range (see the table above).
    pub fn validate(&self) -> Result<()> {
        for (name, value) in [
            ("tol_x", self.tol_x),
            ("tol_f", self.tol_f),
            ("tol_line", self.tol_line),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(invalid(name, format!("must be finite and >= 0, got {value}")));
            }
        }
        if self.max_iters == Some(0) {
            return Err(invalid("max_iters", "must be at least 1"));
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
#[non_exhaustive]
pub enum PowellStatus {
    /// The relative decrease over an iteration fell below `tol_f`.
    ConvergedCost,
    /// No coordinate moved by more than `tol_x` (relative) in an iteration.
    ConvergedStep,
    /// `max_iters` iterations were done.
    MaxIterations,
    /// The `max_evals` budget of cost evaluations was used up.
    MaxEvaluations,
}

impl PowellStatus {
    /// True for the converged statuses.
    pub fn converged(self) -> bool {
        matches!(self, Self::ConvergedCost | Self::ConvergedStep)
    }
}

/// The outcome of [`Powell::solve`].
#[derive(Debug, Clone, PartialEq)]
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
    pub cost_evals: usize,
    /// Wall time of the solve.
    pub elapsed: Duration,
}

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
        let start = Instant::now();
        let mut eval = |x: &Vec<f64>| f.cost(x);
        let mut engine = Engine::start(&self.settings, x0, &mut eval)?;
        let initial_cost = engine.fx;
        let status = loop {
            if let Some(status) = engine.iterate(&mut eval)? {
                break status;
            }
        };
        Ok(PowellResult {
            x: engine.x,
            cost: engine.fx,
            initial_cost,
            status,
            iterations: engine.iters,
            cost_evals: engine.evals,
            elapsed: start.elapsed(),
        })
    }
}

// ---------------------------------------------------------------------------
// The engine shared by `Powell::solve` and the argmin solver.

/// The golden ratio, growth factor of bracketing steps.
const GOLD: f64 = 1.618_033_988_749_895;
/// $(3 - \sqrt 5) / 2$, the golden-section fraction of Brent's method.
const CGOLD: f64 = 0.381_966_011_250_105;
/// Largest parabolic extrapolation during bracketing, in last steps.
const GROW_LIMIT: f64 = 110.0;
/// Absolute floor of Brent's tolerance.
const ZEPS: f64 = 1e-11;
/// Guards the parabolic extrapolation's denominator.
const TINY: f64 = 1e-21;
/// Iteration caps of the bracketing and of Brent's search.
const MAX_BRACKET: usize = 1000;
const MAX_BRENT: usize = 500;

#[derive(Debug, Clone)]
struct Engine {
    n: usize,
    x: Vec<f64>,
    fx: f64,
    /// Row-major $n \times n$: row $i$ is direction $u_i$.
    dirs: Vec<f64>,
    /// The first bracketing trial along each direction: the step length
    /// accepted by the last line search along it ($1$ at the start).
    steps: Vec<f64>,
    x_start: Vec<f64>,
    new_dir: Vec<f64>,
    trial: Vec<f64>,
    bounds: Option<(Vec<f64>, Vec<f64>)>,
    evals: usize,
    iters: usize,
    max_iters: usize,
    max_evals: usize,
    tol_x: f64,
    tol_f: f64,
    tol_line: f64,
    initial_step: f64,
    /// The direction set is the coordinate set (no replacement since the
    /// start or the last restart).
    fresh: bool,
    status: Option<PowellStatus>,
}

/// The objective along a line $x + \alpha u$, with the evaluation budget.
struct Line<'a, F> {
    origin: &'a [f64],
    dir: &'a [f64],
    bounds: Option<&'a (Vec<f64>, Vec<f64>)>,
    trial: &'a mut Vec<f64>,
    eval: &'a mut F,
    evals: &'a mut usize,
    max_evals: usize,
}

/// How a bracketing ended.
enum Bracket {
    /// $\phi(b) \le \phi(a), \phi(c)$ with $b$ between $a$ and $c$.
    Interior {
        a: f64,
        b: f64,
        c: f64,
        fa: f64,
        fb: f64,
        fc: f64,
    },
    /// $\phi$ does not increase from `far` to `near`, and `near` is an end of
    /// the feasible interval (or the budget ran out).
    Edge {
        far: f64,
        near: f64,
        f_far: f64,
        f_near: f64,
    },
}

fn fill_trial(trial: &mut [f64], origin: &[f64], dir: &[f64], alpha: f64, bounds: Option<&(Vec<f64>, Vec<f64>)>) {
    for ((t, &o), &d) in trial.iter_mut().zip(origin).zip(dir) {
        *t = o + alpha * d;
    }
    if let Some((lower, upper)) = bounds {
        for ((t, &l), &u) in trial.iter_mut().zip(lower).zip(upper) {
            *t = t.max(l).min(u);
        }
    }
}

/// The interval of $\alpha$ keeping $x + \alpha u$ in the box ($\ni 0$).
fn feasible_interval(x: &[f64], dir: &[f64], bounds: Option<&(Vec<f64>, Vec<f64>)>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    if let Some((lower, upper)) = bounds {
        for j in 0..x.len() {
            let d = dir[j];
            if d == 0.0 {
                continue;
            }
            let (s_lower, s_upper) = ((lower[j] - x[j]) / d, (upper[j] - x[j]) / d);
            let (s_lo, s_hi) = if d > 0.0 {
                (s_lower, s_upper)
            } else {
                (s_upper, s_lower)
            };
            lo = lo.max(s_lo);
            hi = hi.min(s_hi);
        }
    }
    (lo.min(0.0), hi.max(0.0))
}

impl<F, E> Line<'_, F>
where
    F: FnMut(&Vec<f64>) -> std::result::Result<f64, E>,
{
    fn exhausted(&self) -> bool {
        *self.evals >= self.max_evals
    }

    /// $\phi(\alpha)$, non-finite mapped to $+\infty$; $+\infty$ without an
    /// evaluation once the budget is spent.
    fn at(&mut self, alpha: f64) -> std::result::Result<f64, E> {
        if self.exhausted() || !alpha.is_finite() {
            return Ok(f64::INFINITY);
        }
        fill_trial(self.trial, self.origin, self.dir, alpha, self.bounds);
        *self.evals += 1;
        let value = (self.eval)(self.trial)?;
        Ok(if value.is_finite() { value } else { f64::INFINITY })
    }

    /// Approximately minimises $\phi$ over $[lo, hi] \ni 0$ given
    /// $\phi(0) = f_0$; the first trial is $\alpha = $ `step` (or $-$`step`
    /// when blocked that way, shortened to the interval); `known` is an
    /// already evaluated $(\alpha, \phi(\alpha))$ to reuse for the first
    /// trial. Returns the best $(\alpha, \phi(\alpha))$
    /// seen, $(0, f_0)$ if nothing was lower.
    fn minimise(
        &mut self,
        f0: f64,
        lo: f64,
        hi: f64,
        step: f64,
        known: Option<(f64, f64)>,
        tol: f64,
    ) -> std::result::Result<(f64, f64), E> {
        if hi <= 0.0 && lo >= 0.0 {
            return Ok((0.0, f0));
        }
        let bracket = self.bracket(f0, lo, hi, step, known)?;
        let (a, b, x, w, v) = match bracket {
            Bracket::Interior { a, b, c, fa, fb, fc } => {
                let (w, v) = if fa <= fc {
                    ((a, fa), (c, fc))
                } else {
                    ((c, fc), (a, fa))
                };
                (a.min(c), a.max(c), (b, fb), w, v)
            }
            Bracket::Edge {
                far,
                near,
                f_far,
                f_near,
            } => (far.min(near), far.max(near), (near, f_near), (far, f_far), (far, f_far)),
        };
        let (alpha, f) = self.brent(a, b, x, w, v, tol)?;
        Ok(if f < f0 { (alpha, f) } else { (0.0, f0) })
    }

    fn bracket(
        &mut self,
        f0: f64,
        lo: f64,
        hi: f64,
        step: f64,
        known: Option<(f64, f64)>,
    ) -> std::result::Result<Bracket, E> {
        let clamp = |u: f64| u.clamp(lo, hi);
        let (mut a, mut fa) = (0.0, f0);
        // the first trial: `step`, or its mirror image when blocked that way
        let mut b = if (step > 0.0 && hi > 0.0) || lo >= 0.0 {
            hi.min(step.abs())
        } else {
            lo.max(-step.abs())
        };
        let mut fb = match known {
            Some((alpha, value)) if alpha == b => value,
            _ => self.at(b)?,
        };
        if fb > fa {
            std::mem::swap(&mut a, &mut b);
            std::mem::swap(&mut fa, &mut fb);
        }
        let mut c = clamp(b + GOLD * (b - a));
        if c == b {
            return Ok(Bracket::Edge {
                far: a,
                near: b,
                f_far: fa,
                f_near: fb,
            });
        }
        let mut fc = self.at(c)?;
        let mut rounds = 0;
        while fc < fb {
            rounds += 1;
            if self.exhausted() || rounds > MAX_BRACKET {
                return Ok(Bracket::Edge {
                    far: b,
                    near: c,
                    f_far: fb,
                    f_near: fc,
                });
            }
            // vertex of the parabola through (a, fa), (b, fb), (c, fc)
            let r = (b - a) * (fb - fc);
            let q = (b - c) * (fb - fa);
            let diff = q - r;
            let denom = 2.0 * diff.abs().max(TINY).copysign(diff);
            let mut u = b - ((b - c) * q - (b - a) * r) / denom;
            let u_limit = clamp(b + GROW_LIMIT * (c - b));
            let mut fu;
            if (b - u) * (u - c) > 0.0 {
                // between b and c
                fu = self.at(u)?;
                if fu < fc {
                    return Ok(Bracket::Interior {
                        a: b,
                        b: u,
                        c,
                        fa: fb,
                        fb: fu,
                        fc,
                    });
                }
                if fu > fb {
                    return Ok(Bracket::Interior {
                        a,
                        b,
                        c: u,
                        fa,
                        fb,
                        fc: fu,
                    });
                }
                u = clamp(c + GOLD * (c - b));
                if u == c {
                    return Ok(Bracket::Edge {
                        far: b,
                        near: c,
                        f_far: fb,
                        f_near: fc,
                    });
                }
                fu = self.at(u)?;
            } else if (c - u) * (u - u_limit) > 0.0 {
                // between c and the growth limit
                fu = self.at(u)?;
                if fu < fc {
                    (b, fb, c, fc) = (c, fc, u, fu);
                    u = clamp(c + GOLD * (c - b));
                    if u == c {
                        return Ok(Bracket::Edge {
                            far: b,
                            near: c,
                            f_far: fb,
                            f_near: fc,
                        });
                    }
                    fu = self.at(u)?;
                }
            } else {
                u = if (u - u_limit) * (u_limit - c) >= 0.0 {
                    u_limit
                } else {
                    clamp(c + GOLD * (c - b))
                };
                if u == c {
                    return Ok(Bracket::Edge {
                        far: b,
                        near: c,
                        f_far: fb,
                        f_near: fc,
                    });
                }
                fu = self.at(u)?;
            }
            (a, fa, b, fb, c, fc) = (b, fb, c, fc, u, fu);
        }
        Ok(Bracket::Interior { a, b, c, fa, fb, fc })
    }

    /// Brent's method on $[a, b]$ from the best known point $x \in [a, b]$.
    ///
    /// `w` and `v` are the second and third best points known (the other
    /// bracket points): with them the first step can be parabolic, where
    /// the textbook start ($w = v = x$, $e = 0$) spends a golden-section step.
    fn brent(
        &mut self,
        mut a: f64,
        mut b: f64,
        (mut x, mut fx): (f64, f64),
        (mut w, mut fw): (f64, f64),
        (mut v, mut fv): (f64, f64),
        tol: f64,
    ) -> std::result::Result<(f64, f64), E> {
        // the bracket width as the last two steps lets the first parabolic
        // steps through the "under half the step before last" test
        let width = if w != x && v != x && v != w { b - a } else { 0.0 };
        let (mut d, mut e) = (width, width);
        for _ in 0..MAX_BRENT {
            let xm = 0.5 * (a + b);
            let tol1 = tol * x.abs() + ZEPS;
            let tol2 = 2.0 * tol1;
            if (x - xm).abs() <= tol2 - 0.5 * (b - a) || self.exhausted() {
                break;
            }
            let mut golden = true;
            if e.abs() > tol1 {
                // parabola through x, w, v
                let r = (x - w) * (fx - fv);
                let mut q = (x - v) * (fx - fw);
                let mut p = (x - v) * q - (x - w) * r;
                q = 2.0 * (q - r);
                if q > 0.0 {
                    p = -p;
                }
                q = q.abs();
                let e_prev = e;
                // accept only a step inside (a, b) and under half the step
                // before last (false for NaN)
                if p.abs() < (0.5 * q * e_prev).abs() && p > q * (a - x) && p < q * (b - x) {
                    golden = false;
                    e = d;
                    d = p / q;
                    let u = x + d;
                    if u - a < tol2 || b - u < tol2 {
                        d = tol1.copysign(xm - x);
                    }
                }
            }
            if golden {
                e = if x >= xm { a - x } else { b - x };
                d = CGOLD * e;
            }
            let u = if d.abs() >= tol1 { x + d } else { x + tol1.copysign(d) };
            let fu = self.at(u)?;
            if fu <= fx {
                if u >= x {
                    a = x;
                } else {
                    b = x;
                }
                (v, fv, w, fw, x, fx) = (w, fw, x, fx, u, fu);
            } else {
                if u < x {
                    a = u;
                } else {
                    b = u;
                }
                if fu <= fw || w == x {
                    (v, fv, w, fw) = (w, fw, u, fu);
                } else if fu <= fv || v == x || v == w {
                    (v, fv) = (u, fu);
                }
            }
        }
        Ok((x, fx))
    }
}

enum Which {
    Row(usize),
    New,
}

impl Engine {
    fn start<F, E>(settings: &PowellSettings, x0: &[f64], eval: &mut F) -> std::result::Result<Self, E>
    where
        F: FnMut(&Vec<f64>) -> std::result::Result<f64, E>,
        E: From<TrajoptError>,
    {
        settings.validate()?;
        let n = x0.len();
        if n == 0 {
            return Err(invalid("x0", "the start point is empty").into());
        }
        check_finite("x0", x0)?;
        let mut x = x0.to_vec();
        if let Some((lower, upper)) = &settings.bounds {
            if lower.len() != n {
                return Err(TrajoptError::DimensionMismatch {
                    what: "bounds",
                    expected: n,
                    actual: lower.len(),
                }
                .into());
            }
            for ((t, &l), &u) in x.iter_mut().zip(lower).zip(upper) {
                *t = t.max(l).min(u);
            }
        }
        let fx = eval(&x)?;
        if !fx.is_finite() {
            return Err(TrajoptError::NonFiniteStart { value: fx }.into());
        }
        let mut dirs = vec![0.0; n * n];
        for i in 0..n {
            dirs[i * n + i] = settings.initial_step;
        }
        Ok(Self {
            n,
            trial: x.clone(),
            x_start: x.clone(),
            new_dir: vec![0.0; n],
            x,
            fx,
            dirs,
            steps: vec![1.0; n],
            bounds: settings.bounds.clone(),
            evals: 1,
            iters: 0,
            max_iters: settings.max_iters.unwrap_or(1000 * n),
            max_evals: settings.max_evals.unwrap_or(1000 * n),
            tol_x: settings.tol_x,
            tol_f: settings.tol_f,
            tol_line: settings.tol_line,
            initial_step: settings.initial_step,
            fresh: true,
            status: None,
        })
    }

    /// One line minimisation along a stored direction from the current point;
    /// moves there if the cost went down. Returns the step length.
    fn line_search<F, E>(
        &mut self,
        which: Which,
        known: Option<(f64, f64)>,
        eval: &mut F,
    ) -> std::result::Result<f64, E>
    where
        F: FnMut(&Vec<f64>) -> std::result::Result<f64, E>,
    {
        let n = self.n;
        let (dir, step) = match which {
            Which::Row(i) => (&self.dirs[i * n..(i + 1) * n], self.steps[i]),
            Which::New => (&self.new_dir[..], 1.0),
        };
        let bounds = self.bounds.as_ref();
        let (lo, hi) = feasible_interval(&self.x, dir, bounds);
        let mut line = Line {
            origin: &self.x,
            dir,
            bounds,
            trial: &mut self.trial,
            eval,
            evals: &mut self.evals,
            max_evals: self.max_evals,
        };
        let (alpha, f) = line.minimise(self.fx, lo, hi, step, known, self.tol_line)?;
        if alpha != 0.0 && f < self.fx {
            if let Which::Row(i) = which {
                self.steps[i] = alpha;
            }
            // the same arithmetic as the evaluated trial: bit-identical point
            fill_trial(&mut self.trial, &self.x, dir, alpha, bounds);
            self.x.copy_from_slice(&self.trial);
            self.fx = f;
            Ok(alpha)
        } else {
            Ok(0.0)
        }
    }

    /// One iteration; returns the status once finished.
    fn iterate<F, E>(&mut self, eval: &mut F) -> std::result::Result<Option<PowellStatus>, E>
    where
        F: FnMut(&Vec<f64>) -> std::result::Result<f64, E>,
    {
        if let Some(status) = self.status {
            return Ok(Some(status));
        }
        let n = self.n;
        let f_start = self.fx;
        self.x_start.copy_from_slice(&self.x);
        let (mut biggest, mut delta) = (0, 0.0);
        for i in 0..n {
            let f_before = self.fx;
            self.line_search(Which::Row(i), None, eval)?;
            if f_before - self.fx > delta {
                delta = f_before - self.fx;
                biggest = i;
            }
        }
        self.iters += 1;
        if let Some(status) = self.check(f_start) {
            if !(status.converged() && self.restart_on_bound()) {
                self.status = Some(status);
                return Ok(Some(status));
            }
        } else {
            self.replace_direction(f_start, delta, biggest, eval)?;
        }
        let status = if self.evals >= self.max_evals {
            Some(PowellStatus::MaxEvaluations)
        } else if self.iters >= self.max_iters {
            Some(PowellStatus::MaxIterations)
        } else {
            None
        };
        self.status = status;
        Ok(status)
    }

    /// Powell's replacement step after a sweep from `x_start` (cost
    /// `f_start`) whose largest single decrease `delta` was along direction
    /// `biggest`.
    fn replace_direction<F, E>(
        &mut self,
        f_start: f64,
        delta: f64,
        biggest: usize,
        eval: &mut F,
    ) -> std::result::Result<(), E>
    where
        F: FnMut(&Vec<f64>) -> std::result::Result<f64, E>,
    {
        let n = self.n;
        // the extrapolated point x_n + d, d = x_n - x_0, pulled back into the box
        for ((d, &x), &x0) in self.new_dir.iter_mut().zip(&self.x).zip(&self.x_start) {
            *d = x - x0;
        }
        let (_, hi) = feasible_interval(&self.x, &self.new_dir, self.bounds.as_ref());
        let reach = hi.min(1.0);
        if reach <= 0.0 || self.evals >= self.max_evals {
            return Ok(());
        }
        fill_trial(&mut self.trial, &self.x, &self.new_dir, reach, self.bounds.as_ref());
        self.evals += 1;
        let fe = eval(&self.trial)?;
        let fe = if fe.is_finite() { fe } else { f64::INFINITY };
        let fx = self.fx;
        if fe >= f_start {
            return Ok(());
        }
        let t = 2.0 * (f_start - 2.0 * fx + fe) * (f_start - fx - delta).powi(2) - delta * (f_start - fe).powi(2);
        if t >= 0.0 {
            if fe < fx {
                // keep the set, but not a better point already paid for
                self.x.copy_from_slice(&self.trial);
                self.fx = fe;
            }
            return Ok(());
        }
        let alpha = self.line_search(Which::New, Some((reach, fe)), eval)?;
        if alpha != 0.0 {
            for d in &mut self.new_dir {
                *d *= alpha;
            }
            // u_m <- u_n, u_n <- alpha d
            self.dirs.copy_within((n - 1) * n..n * n, biggest * n);
            self.dirs[(n - 1) * n..].copy_from_slice(&self.new_dir);
            self.steps[biggest] = self.steps[n - 1];
            self.steps[n - 1] = 1.0;
            self.fresh = false;
        }
        Ok(())
    }

    /// On a stall with some coordinate on a bound and a direction set that
    /// has changed since the start (or the last restart): resets the set to
    /// the coordinate directions and returns true.
    fn restart_on_bound(&mut self) -> bool {
        let Some((lower, upper)) = &self.bounds else {
            return false;
        };
        let on_bound = self
            .x
            .iter()
            .zip(lower.iter().zip(upper))
            .any(|(&x, (&l, &u))| x == l || x == u);
        if self.fresh || !on_bound {
            return false;
        }
        let n = self.n;
        self.dirs.fill(0.0);
        for i in 0..n {
            self.dirs[i * n + i] = self.initial_step;
        }
        self.steps.fill(1.0);
        self.fresh = true;
        true
    }

    /// The tests after the direction sweep.
    fn check(&self, f_start: f64) -> Option<PowellStatus> {
        let fx = self.fx;
        if self.evals >= self.max_evals {
            // the sweep may have been cut short: not a convergence
            return Some(PowellStatus::MaxEvaluations);
        }
        if 2.0 * (f_start - fx) <= self.tol_f * (f_start.abs() + fx.abs()) + 1e-20 {
            return Some(PowellStatus::ConvergedCost);
        }
        let small_step = self
            .x
            .iter()
            .zip(&self.x_start)
            .all(|(&x, &x0)| (x - x0).abs() <= self.tol_x * (1.0 + x.abs()));
        small_step.then_some(PowellStatus::ConvergedStep)
    }
}

// ---------------------------------------------------------------------------
// argmin

/// Powell's method as an argmin [`Solver`]: one argmin iteration is one
/// sweep over the direction set (plus the replacement step); the direction
/// set lives in the solver.
///
/// The problem must implement argmin's
/// `CostFunction<Param = Vec<f64>, Output = f64>`; the start point comes
/// from the executor's state (`configure(|s| s.param(x0))`). The executor's
/// `max_iters` applies in addition to the settings' limits; convergence ends
/// the run with `SolverConverged`, an exhausted `max_evals` with
/// `SolverExit`. Cost evaluations are reported under argmin's
/// `"cost_count"`. Each iteration's key-value log holds `evals` and
/// `decrease`.
///
/// ```
/// use argmin::core::{CostFunction, Error, Executor, State};
/// use trajopt::powell::{PowellArgmin, PowellSettings};
///
/// struct Rosenbrock;
/// impl CostFunction for Rosenbrock {
///     type Param = Vec<f64>;
///     type Output = f64;
///     fn cost(&self, x: &Vec<f64>) -> Result<f64, Error> {
///         Ok(100.0 * (x[1] - x[0] * x[0]).powi(2) + (1.0 - x[0]).powi(2))
///     }
/// }
///
/// let solver = PowellArgmin::new(PowellSettings::default())?;
/// let result = Executor::new(Rosenbrock, solver)
///     .configure(|state| state.param(vec![-1.2, 1.0]).max_iters(100))
///     .run()?;
/// let best = result.state().get_best_param().expect("a best point");
/// assert!((best[0] - 1.0).abs() < 1e-6 && (best[1] - 1.0).abs() < 1e-6);
/// # Ok::<(), Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct PowellArgmin {
    settings: PowellSettings,
    engine: Option<Engine>,
}

impl PowellArgmin {
    /// A solver with checked settings.
    pub fn new(settings: PowellSettings) -> Result<Self> {
        settings.validate()?;
        Ok(Self { settings, engine: None })
    }

    /// Why the solver stopped, once it has.
    pub fn status(&self) -> Option<PowellStatus> {
        self.engine.as_ref().and_then(|e| e.status)
    }

    /// Cost evaluations so far, the start point's included.
    pub fn cost_evals(&self) -> usize {
        self.engine.as_ref().map_or(0, |e| e.evals)
    }

    /// The current direction set, one direction per row (row-major
    /// $n \times n$), empty before `init`.
    pub fn directions(&self) -> &[f64] {
        self.engine.as_ref().map_or(&[], |e| &e.dirs)
    }
}

type ArgminState = IterState<Vec<f64>, (), (), (), (), f64>;

impl<O> Solver<O, ArgminState> for PowellArgmin
where
    O: CostFunction<Param = Vec<f64>, Output = f64>,
{
    fn name(&self) -> &str {
        "Powell"
    }

    fn init(
        &mut self,
        problem: &mut Problem<O>,
        state: ArgminState,
    ) -> std::result::Result<(ArgminState, Option<KV>), argmin::core::Error> {
        let x0 = state
            .get_param()
            .ok_or_else(|| invalid("param", "set the start point with `configure(|s| s.param(x0))`"))?;
        let settings = &self.settings;
        let engine = problem.problem("cost_count", |p| {
            Engine::start(settings, x0, &mut |x: &Vec<f64>| p.cost(x))
        })?;
        let (x, fx) = (engine.x.clone(), engine.fx);
        self.engine = Some(engine);
        Ok((state.param(x).cost(fx), None))
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        state: ArgminState,
    ) -> std::result::Result<(ArgminState, Option<KV>), argmin::core::Error> {
        let engine = self
            .engine
            .as_mut()
            .ok_or_else(|| invalid("state", "`init` was not called"))?;
        let (evals_before, f_before) = (engine.evals, engine.fx);
        // one counted call for the whole iteration, corrected below: keeps
        // argmin's hash-map bookkeeping out of the per-evaluation path
        let outcome = problem.problem("cost_count", |p| engine.iterate(&mut |x: &Vec<f64>| p.cost(x)));
        let done = engine.evals - evals_before;
        if let Some(count) = problem.counts.get_mut("cost_count") {
            *count = (*count + done as u64).saturating_sub(1);
        }
        outcome?;
        let kv = argmin::kv!(
            "evals" => engine.evals as u64;
            "decrease" => f_before - engine.fx;
        );
        Ok((state.param(engine.x.clone()).cost(engine.fx), Some(kv)))
    }

    fn terminate(&mut self, _state: &ArgminState) -> TerminationStatus {
        match self.status() {
            Some(PowellStatus::ConvergedCost | PowellStatus::ConvergedStep) => {
                TerminationStatus::Terminated(TerminationReason::SolverConverged)
            }
            Some(PowellStatus::MaxIterations) => TerminationStatus::Terminated(TerminationReason::MaxItersReached),
            Some(PowellStatus::MaxEvaluations) => TerminationStatus::Terminated(TerminationReason::SolverExit(
                "maximum number of cost evaluations".into(),
            )),
            None => TerminationStatus::NotTerminated,
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

    fn run(f: impl Fn(&[f64]) -> f64, lo: f64, hi: f64, first: Option<(f64, f64)>) -> (f64, f64, usize) {
        let origin = [0.0];
        let dir = [1.0];
        let mut trial = vec![0.0];
        let mut evals = 0;
        let mut eval = |x: &Vec<f64>| -> Result<f64> { Ok(f(x)) };
        let f0 = f(&[0.0]);
        let mut line = Line {
            origin: &origin,
            dir: &dir,
            bounds: None,
            trial: &mut trial,
            eval: &mut eval,
            evals: &mut evals,
            max_evals: 10_000,
        };
        let (alpha, value) = line.minimise(f0, lo, hi, 1.0, first, 1e-8).expect("line search");
        (alpha, value, evals)
    }

    #[test]
    fn line_search_finds_parabola_minimum() {
        let (alpha, value, evals) = run(|x| (x[0] - 3.7).powi(2) + 1.0, f64::NEG_INFINITY, f64::INFINITY, None);
        assert!((alpha - 3.7).abs() < 1e-6, "{alpha}");
        assert!((value - 1.0).abs() < 1e-12);
        // bracketing 3 (the third point is the vertex), Brent 3 (its first
        // step is parabolic, then the two tolerance-sized probes)
        assert!(evals <= 6, "{evals}");
        let (alpha, _, _) = run(|x| (x[0] + 12.0).powi(2), f64::NEG_INFINITY, f64::INFINITY, None);
        assert!((alpha + 12.0).abs() < 1e-6, "{alpha}");
    }

    #[test]
    fn first_trials_are_the_last_accepted_steps() {
        // separable: one sweep along the coordinates lands on c, with the
        // steps c_i; a second sweep then starts each search at c_i
        let c = [0.5, -2.0, 3.0];
        let mut eval = |x: &Vec<f64>| -> Result<f64> { Ok(x.iter().zip(&c).map(|(x, c)| (x - c).powi(2)).sum()) };
        let mut engine = Engine::start(&PowellSettings::default(), &[0.0; 3], &mut eval).expect("start");
        assert_eq!(engine.steps, vec![1.0; 3]);
        engine.iterate(&mut eval).expect("sweep");
        for (step, c) in engine.steps.iter().zip(&c) {
            assert!((step - c).abs() < 1e-6, "{:?}", engine.steps);
        }
    }

    #[test]
    fn line_search_stops_on_bounds() {
        let (alpha, value, _) = run(|x| (x[0] - 3.7).powi(2), -1.0, 2.0, None);
        assert_eq!(alpha, 2.0);
        assert!((value - 1.7_f64.powi(2)).abs() < 1e-12);
        let (alpha, _, _) = run(|x| (x[0] + 3.7).powi(2), -0.5, 2.0, None);
        assert_eq!(alpha, -0.5);
        // blocked on the downhill side
        let (alpha, value, _) = run(|x| x[0], 0.0, 2.0, None);
        assert_eq!((alpha, value), (0.0, 0.0));
        let (alpha, _, evals) = run(|x| x[0], 0.0, 0.0, None);
        assert_eq!((alpha, evals), (0.0, 0));
    }

    #[test]
    fn line_search_reuses_the_known_first_trial() {
        let f = |x: &[f64]| (x[0] - 0.3).powi(2);
        let (_, _, with) = run(f, f64::NEG_INFINITY, f64::INFINITY, Some((1.0, f(&[1.0]))));
        let (_, _, without) = run(f, f64::NEG_INFINITY, f64::INFINITY, None);
        assert_eq!(with + 1, without);
    }

    #[test]
    fn line_search_survives_non_finite_values() {
        let f = |x: &[f64]| if x[0] > 1.5 { f64::NAN } else { (x[0] - 1.4).powi(2) };
        let (alpha, _, _) = run(f, f64::NEG_INFINITY, f64::INFINITY, None);
        assert!((alpha - 1.4).abs() < 1e-6, "{alpha}");
    }

    #[test]
    fn settings_are_validated() {
        let bad = [
            PowellSettings {
                tol_f: -1.0,
                ..Default::default()
            },
            PowellSettings {
                tol_x: f64::NAN,
                ..Default::default()
            },
            PowellSettings {
                max_evals: Some(0),
                ..Default::default()
            },
            PowellSettings {
                max_iters: Some(0),
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
            let powell = Powell::new(PowellSettings {
                max_evals: Some(max_evals),
                ..Default::default()
            })
            .expect("settings");
            let result = powell.solve(&rosenbrock, &[-1.2, 1.0]).expect("solve");
            assert!(result.cost_evals <= max_evals, "{} > {max_evals}", result.cost_evals);
            assert_eq!(result.status, PowellStatus::MaxEvaluations);
            assert!(result.cost <= result.initial_cost);
        }
        let powell = Powell::new(PowellSettings {
            max_iters: Some(2),
            ..Default::default()
        })
        .expect("settings");
        let result = powell.solve(&rosenbrock, &[-1.2, 1.0]).expect("solve");
        assert_eq!((result.status, result.iterations), (PowellStatus::MaxIterations, 2));
    }

    #[test]
    fn returned_cost_is_the_cost_at_x() {
        let powell = Powell::new(PowellSettings::default()).expect("settings");
        let result = powell.solve(&rosenbrock, &[-1.2, 1.0, 0.5]).expect("solve");
        assert_eq!(rosenbrock(&result.x).expect("cost"), result.cost);
    }
}
