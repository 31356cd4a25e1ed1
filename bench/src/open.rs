//! The open benchmark: any solver, yours included, runs on any set and
//! lands in the same records, tables, performance profiles (evaluations
//! and time) and data profiles as the built-in ones.
//!
//! A solver is a [`BenchSolver`]: a name and a `solve` that takes a
//! [`Problem`] (sizes, the start, and residuals and a dense Jacobian whose
//! every call is counted against the run's budget) and says how it
//! stopped ([`Stop`]). The runner keeps the best point the solver
//! evaluated, its trace, counts and time, exactly as for a built-in
//! solver; the solver need not return its answer. A closure is a solver
//! through [`from_fn`]; a program in another language is one through
//! [`crate::process::ProcessSolver`].
//!
//! ```no_run
//! use std::sync::Arc;
//! use bench::open::{Problem, Stop, from_fn};
//! use bench::problems::ProblemSet;
//! use bench::runner::{RunnerSettings, execute};
//!
//! // steepest descent with a fixed step, as a closure
//! let descent = from_fn("my-descent", |p: &Problem<'_>| {
//!     let (mut x, mut r) = (p.x0().to_vec(), vec![0.0; p.m()]);
//!     let mut jac = vec![0.0; p.m() * p.n()];
//!     for _ in 0..100 {
//!         p.residuals(&x, &mut r).map_err(|e| e.to_string())?;
//!         p.jacobian(&x, &mut jac).map_err(|e| e.to_string())?;
//!         for j in 0..p.n() {
//!             x[j] -= 1e-3 * (0..p.m()).map(|i| jac[i * p.n() + j] * r[i]).sum::<f64>();
//!         }
//!     }
//!     Ok(Stop::stopped("max-iterations"))
//! });
//! let mut settings = RunnerSettings::new(ProblemSet::Mgh, "target/my-bench");
//! settings.solvers.push(Arc::new(descent));
//! let (analysis, _) = execute(&settings)?;
//! # Ok::<(), bench::BenchError>(())
//! ```

use std::fmt;
use std::time::Instant;

use solve::Termination;

use trajopt::LeastSquaresProblem;

use crate::error::{BenchError, Result};
use crate::instance::{finite, rollout_cost, start_cost};
use crate::problems::{Budget, Counted, Instance};
use crate::record::{RunRecord, thin_trace};

/// A solver the runner can run: yours, a closure ([`from_fn`]), a program
/// speaking the process protocol ([`crate::process::ProcessSolver`]), or a
/// built-in ([`crate::solvers::Solver`]).
pub trait BenchSolver: Send + Sync {
    /// The name in the records, tables and profiles; unique among a run's
    /// solvers.
    fn name(&self) -> &str;

    /// Whether it runs on `instance`. By default on every instance with a
    /// start (every instance of the MGH, NIST and trajectory sets; on the
    /// trajectory set it sees the Eq. 3 form and is scored by its rollout).
    fn applies_to(&self, instance: &Instance) -> bool {
        !instance.start.is_empty()
    }

    /// Solves `problem` from [`Problem::x0`]. `Ok` says how the solver
    /// stopped by itself; `Err` is a failure, recorded as the run's status
    /// (`error: MESSAGE`). Either way the run's answer is the best point
    /// the solver evaluated. An evaluation past the budget is an
    /// [`EvalError`] whose [`budget_spent`](EvalError::budget_spent) is
    /// true: return then (the run is recorded as `budget`).
    ///
    /// # Errors
    /// The solver's own failure, as a message.
    fn solve(&self, problem: &Problem<'_>) -> std::result::Result<Stop, String>;

    /// One recorded run of the solver on `instance` under `budget`, timed
    /// `repeats` times (the counts are the first run's, the time the
    /// median). The default runs [`solve`](Self::solve) on the
    /// least-squares form; the built-in DDP solvers override it.
    ///
    /// # Errors
    /// Only a setting the solver refuses; a failed solve is a record.
    fn run(&self, instance: &Instance, budget: &Budget, repeats: u32) -> Result<RunRecord> {
        record(self.name(), instance, repeats, || {
            measure(instance, budget, |counted| {
                Ok(match self.solve(&Problem { counted, instance }) {
                    Ok(stop) => Outcome::Stopped {
                        status: stop.status,
                        converged: stop.converged,
                        termination: stop.termination,
                    },
                    Err(message) => Outcome::Failed(message),
                })
            })
        })
    }
}

impl fmt::Debug for dyn BenchSolver {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "BenchSolver({})", self.name())
    }
}

/// How a solver stopped by itself.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Stop {
    /// The solver's own word for it (`converged`, `max-iterations`,
    /// `small-step`, ...), written to the records as it is.
    pub status: String,
    /// Whether the solver's own convergence test passed. The benchmark
    /// judges every run by its own test at the best point; this is
    /// recorded beside it.
    pub converged: bool,
    /// The stop in the workspace's vocabulary, when the solver knows it
    /// ([`RunRecord::termination`]).
    pub termination: Option<Termination>,
}

impl Stop {
    /// Stopped by its convergence test.
    pub fn converged(status: impl Into<String>) -> Self {
        Self {
            status: status.into(),
            converged: true,
            termination: Some(Termination::Converged),
        }
    }

    /// Stopped otherwise (an iteration cap, no progress, ...).
    pub fn stopped(status: impl Into<String>) -> Self {
        Self {
            status: status.into(),
            converged: false,
            termination: None,
        }
    }

    /// A typed status (any workspace solver's, or one of yours that
    /// implements [`solve::Status`] and `Serialize`): its name as serde
    /// writes it, and its termination.
    pub fn typed<S: solve::Status + serde::Serialize>(status: &S) -> Self {
        let termination = status.termination();
        Self {
            status: status_text(status),
            converged: termination.is_converged(),
            termination: Some(termination),
        }
    }
}

/// A status's name as serde writes it: a unit variant's name
/// (`ConvergedGradient`), a variant with data as its JSON.
pub fn status_text<S: serde::Serialize>(status: &S) -> String {
    match serde_json::to_value(status) {
        Ok(serde_json::Value::String(name)) => name,
        Ok(other) => other.to_string(),
        Err(e) => format!("unprintable status ({e})"),
    }
}

/// An evaluation the runner refused or that failed: the budget is spent,
/// the point has the wrong length, or the problem could not be evaluated
/// there.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EvalError {
    message: String,
    spent: bool,
}

impl EvalError {
    /// Whether the run's budget (evaluations or time) is spent: the solver
    /// should return.
    pub fn budget_spent(&self) -> bool {
        self.spent
    }
}

impl fmt::Display for EvalError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for EvalError {}

/// One benchmark instance as a solver sees it: $\min_x \lVert r(x)
/// \rVert^2$, $r: \mathbb{R}^n \to \mathbb{R}^m$, from [`x0`](Self::x0).
/// A residual evaluation counts 1 against the budget, a Jacobian $n$.
pub struct Problem<'a> {
    pub(crate) counted: &'a Counted<'a>,
    pub(crate) instance: &'a Instance,
}

impl Problem<'_> {
    /// The set (`mgh`, `nist`, `trajectory`).
    pub fn set(&self) -> &str {
        self.instance.set
    }

    /// The problem's name in its set.
    pub fn name(&self) -> &str {
        &self.instance.problem
    }

    /// The start's scale (MGH: 1, 10, 100; NIST: start 1 or 2).
    pub fn scale(&self) -> f64 {
        self.instance.scale
    }

    /// The number of parameters $n$.
    pub fn n(&self) -> usize {
        self.instance.n()
    }

    /// The number of residuals $m$.
    pub fn m(&self) -> usize {
        self.counted.n_residuals()
    }

    /// The start.
    pub fn x0(&self) -> &[f64] {
        &self.instance.start
    }

    /// The evaluation equivalents this run may spend.
    pub fn max_evals(&self) -> u64 {
        self.counted.max_evals()
    }

    /// The evaluation equivalents spent so far.
    pub fn evals(&self) -> u64 {
        self.counted.evals()
    }

    /// When the run's time is up: evaluations after it are refused.
    pub fn deadline(&self) -> Instant {
        self.counted.deadline()
    }

    /// Checks the lengths of a point and an output.
    fn check(&self, x: &[f64], out: usize, want: usize, what: &str) -> std::result::Result<(), EvalError> {
        if x.len() != self.n() || out != want {
            return Err(EvalError {
                message: format!(
                    "{}: x has {} entries (n = {}), the {what} buffer {out} (needs {want})",
                    self.name(),
                    x.len(),
                    self.n()
                ),
                spent: false,
            });
        }
        Ok(())
    }

    /// The residuals $r(x)$ into `r` (length $m$); counts 1.
    ///
    /// # Errors
    /// [`EvalError`]: the budget spent, a length wrong, or the problem
    /// failing at `x`.
    pub fn residuals(&self, x: &[f64], r: &mut [f64]) -> std::result::Result<(), EvalError> {
        self.check(x, r.len(), self.m(), "residual")?;
        self.counted.residuals(x, r).map_err(|e| self.eval_error(&e))
    }

    /// The cost $\lVert r(x) \rVert^2$; counts 1.
    ///
    /// # Errors
    /// As [`residuals`](Self::residuals).
    pub fn cost(&self, x: &[f64]) -> std::result::Result<f64, EvalError> {
        let mut r = vec![0.0; self.m()];
        self.residuals(x, &mut r)?;
        Ok(r.iter().map(|v| v * v).sum())
    }

    /// The Jacobian $J_{ij} = \partial r_i / \partial x_j$ into `jac`,
    /// dense and row-major ($m \times n$); counts $n$.
    ///
    /// # Errors
    /// As [`residuals`](Self::residuals).
    pub fn jacobian(&self, x: &[f64], jac: &mut [f64]) -> std::result::Result<(), EvalError> {
        self.check(x, jac.len(), self.m() * self.n(), "Jacobian")?;
        let dense = self.counted.dense_jacobian(x).map_err(|e| self.eval_error(&e))?;
        jac.copy_from_slice(&dense);
        Ok(())
    }

    fn eval_error(&self, e: &trajopt::TrajoptError) -> EvalError {
        EvalError {
            message: e.to_string(),
            // the counter marks itself spent when it refuses an evaluation
            spent: self.counted.spent(),
        }
    }
}

/// A closure as a [`BenchSolver`] (see [`from_fn`]).
pub struct FnSolver<F> {
    name: String,
    solve: F,
}

/// The closure `solve` as a solver named `name`.
pub fn from_fn<F>(name: impl Into<String>, solve: F) -> FnSolver<F>
where
    F: Fn(&Problem<'_>) -> std::result::Result<Stop, String> + Send + Sync,
{
    FnSolver {
        name: name.into(),
        solve,
    }
}

impl<F> BenchSolver for FnSolver<F>
where
    F: Fn(&Problem<'_>) -> std::result::Result<Stop, String> + Send + Sync,
{
    fn name(&self) -> &str {
        &self.name
    }

    fn solve(&self, problem: &Problem<'_>) -> std::result::Result<Stop, String> {
        (self.solve)(problem)
    }
}

/// What one solve measured, besides its time.
pub(crate) struct Measured {
    pub(crate) status: String,
    pub(crate) converged: bool,
    pub(crate) termination: Option<Termination>,
    /// Residual (cost) evaluations, Jacobian evaluations, evaluation equivalents.
    pub(crate) counts: [u64; 3],
    /// The solver's best objective value.
    pub(crate) objective: f64,
    pub(crate) end: End,
}

/// Where a solve ended, for its figure of merit.
pub(crate) enum End {
    /// The trace of the best objective (scored by the objective) and the
    /// point of the best.
    Trace(Vec<(u64, f64)>, Vec<f64>),
    /// The best point of the Eq. 3 form (scored by its rollout).
    Point(Vec<f64>),
    /// DDP's controls (scored by their rollout).
    Controls(Vec<Vec<f64>>),
}

/// How a solve ended.
pub(crate) enum Outcome {
    /// The solver stopped by itself with this status.
    Stopped {
        status: String,
        converged: bool,
        termination: Option<Termination>,
    },
    /// The solve returned an error (the budget, or a failed evaluation).
    Failed(String),
}

impl Outcome {
    /// A typed status ([`Stop::typed`]).
    pub(crate) fn typed<S: solve::Status + serde::Serialize>(status: &S) -> Self {
        let stop = Stop::typed(status);
        Self::Stopped {
            status: stop.status,
            converged: stop.converged,
            termination: stop.termination,
        }
    }
}

/// One timed solve of `instance`'s least-squares form under `budget`:
/// `solve` gets the counted problem; `Err` only for refused settings.
pub(crate) fn measure(
    instance: &Instance,
    budget: &Budget,
    solve: impl FnOnce(&Counted<'_>) -> Result<Outcome>,
) -> Result<(f64, Measured)> {
    let counted = Counted::new(instance, budget);
    let start = Instant::now();
    let outcome = solve(&counted)?;
    let time = start.elapsed().as_secs_f64();
    let (status, converged, termination) = match outcome {
        _ if counted.spent() => {
            let limit = if Instant::now() > counted.deadline() {
                Termination::TimeLimit
            } else {
                Termination::MaxEvaluations
            };
            ("budget".to_string(), false, Some(limit))
        }
        Outcome::Stopped {
            status,
            converged,
            termination,
        } => (status, converged, termination),
        Outcome::Failed(e) => (format!("error: {e}"), false, Some(Termination::Failed)),
    };
    let end = match instance.rollout {
        Some(_) => End::Point(counted.best_point()),
        None => End::Trace(counted.trace(), counted.best_point()),
    };
    let counts = [counted.f_evals(), counted.jac_evals(), counted.evals()];
    Ok((
        time,
        Measured {
            status,
            converged,
            termination,
            counts,
            objective: counted.best(),
            end,
        },
    ))
}

/// The record of `repeats` runs of the solver `name` on `instance`, each
/// measured by `once` (the counts are the first run's, the time the
/// median).
pub(crate) fn record(
    name: &str,
    instance: &Instance,
    repeats: u32,
    mut once: impl FnMut() -> Result<(f64, Measured)>,
) -> Result<RunRecord> {
    let mut times = Vec::new();
    let mut first = None;
    for _ in 0..repeats.max(1) {
        let (time, measured) = once()?;
        times.push(time);
        first.get_or_insert(measured);
    }
    let m = first.ok_or_else(|| BenchError::InvalidSetting {
        name: "repeats",
        reason: "no run".into(),
    })?;
    let refused = |reason: String| BenchError::Solver {
        solver: name.into(),
        problem: instance.problem.clone(),
        reason,
    };
    let [f_evals, jac_evals, evals] = m.counts;
    let (f0, f, objective, trace, x) = match (&instance.rollout, m.end) {
        (None, End::Trace(trace, x)) => {
            // from the start itself, not the trace: an f(x0) that
            // overflows is not in the trace, whose first point is then
            // a later one
            let f0 = start_cost(instance);
            let (mut f, mut trace) = (m.objective, thin_trace(&trace));
            if trace.is_empty() && f0.is_finite() {
                // a solver that evaluated nothing (it failed at once):
                // its answer is the start, reached with no evaluation
                (f, trace) = (f0, vec![(0, f0)]);
            }
            // an f that overflowed everywhere is recorded as null, as f0
            (f0, if f.is_finite() { f } else { f64::NAN }, None, trace, x)
        }
        (Some(forms), end) => {
            let f0 = finite(rollout_cost(forms, &instance.start)?);
            let (f, x) = match end {
                End::Point(theta) => (rollout_cost(forms, &theta)?, theta),
                End::Controls(u) => (
                    forms.ddp.rollout_cost(&u).map_err(|e| refused(e.to_string()))?,
                    u.concat(),
                ),
                End::Trace(_, x) => (f0, x),
            };
            let f = finite(f);
            (f0, f, Some(m.objective), end_trace(f0, f, evals), x)
        }
        (None, _) => return Err(refused("the instance has no DDP form".into())),
    };
    Ok(RunRecord {
        solver: name.into(),
        set: instance.set.into(),
        problem: instance.problem.clone(),
        n: instance.n(),
        m: instance.residuals,
        scale: instance.scale,
        status: m.status,
        converged: m.converged,
        f0,
        f,
        f_star: instance.f_star,
        objective,
        f_evals,
        jac_evals,
        evals,
        time_s: median_time(times),
        repeats: repeats.max(1),
        trace,
        // the start and the final point, from which the runner recomputes
        // f0 and f (a rolled-out run: its Eq. 3 coefficients, or DDP's
        // controls, stacked)
        x0: Some(instance.start.clone()),
        x: x.iter().all(|v| v.is_finite()).then_some(x),
        termination: m.termination,
    })
}

/// The median of the timings (0 when there are none).
fn median_time(mut times: Vec<f64>) -> f64 {
    times.sort_by(f64::total_cmp);
    times.get(times.len() / 2).copied().unwrap_or(0.0)
}

/// The trace of a run whose figure of merit is known only at its end
/// (the trajectory set): the start's value at the first evaluation and,
/// when lower, the final value at the run's last evaluation, so that a
/// solved run's evaluations to solve are all it spent.
pub fn end_trace(f0: f64, f: f64, evals: u64) -> Vec<(u64, f64)> {
    let mut trace = vec![(1, f0)];
    if f < f0 {
        trace.push((evals.max(1), f));
    }
    trace
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A refused evaluation says whether the budget is spent (the cue a
    /// solver stops on); a wrong length is refused without spending it.
    #[test]
    fn evaluations_past_the_budget_say_so() {
        // one simplex gradient: n + 1 = 3 evaluation equivalents
        let (inst, budget) = crate::problems::tests::rosenbrock(1);
        let counted = Counted::new(&inst, &budget);
        let problem = Problem {
            counted: &counted,
            instance: &inst,
        };
        let mut r = vec![0.0; problem.m()];
        let e = problem.residuals(&[1.0], &mut r).expect_err("wrong length");
        assert!(!e.budget_spent() && e.to_string().contains("x has 1 entries"), "{e}");
        let mut jac = vec![0.0; problem.m() * problem.n()];
        problem.residuals(problem.x0(), &mut r).expect("1 of 3");
        problem.jacobian(problem.x0(), &mut jac).expect("3 of 3");
        let e = problem.residuals(problem.x0(), &mut r).expect_err("past the budget");
        assert!(e.budget_spent(), "{e}");
        assert_eq!(problem.evals(), 3);
    }
}
