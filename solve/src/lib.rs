#![doc = include_str!("../README.md")]
//! # Feature flags
#![doc = document_features::document_features!()]

use std::fmt;
use std::time::{Duration, Instant};

#[cfg(feature = "argmin")]
pub mod argmin;
mod check;
pub mod dense;
#[cfg(test)]
mod testing;
pub use check::JacobianCheck;

/// One iteration as a solver reports it to its observers.
#[derive(Debug, Clone, Copy)]
pub struct Progress<'a> {
    /// The solver's name (`"gauss-newton"`, `"powell"`, `"ddp"`, ...).
    pub solver: &'static str,
    /// Iterations completed (1 after the first).
    pub iteration: usize,
    /// Evaluations of the objective (cost, residuals or rollouts) so far.
    pub evaluations: usize,
    /// The best cost so far.
    pub cost: f64,
    /// The best point so far (the parameters; DDP's controls).
    pub x: &'a [f64],
    /// Time since the watch started.
    pub elapsed: Duration,
}

/// An observer's answer: go on, or stop the solve after this iteration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Control {
    /// Go on.
    Continue,
    /// Stop: the solver returns its best point with a `Stopped` status.
    Stop,
}

/// Sees every iteration of a watched solve and may stop it.
///
/// Closures `FnMut(&Progress) -> Control` are observers.
pub trait Observer {
    /// Called after each iteration, on the solver's thread.
    fn observe(&mut self, progress: &Progress<'_>) -> Control;
}

impl<F: FnMut(&Progress<'_>) -> Control> Observer for F {
    fn observe(&mut self, progress: &Progress<'_>) -> Control {
        self(progress)
    }
}

/// Why a [`Watch`] interrupted a solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Interrupt {
    /// The wall-time limit passed.
    TimeLimit,
    /// An observer returned [`Control::Stop`].
    Observer,
}

/// The run control of one solve: a wall-time limit and observers.
///
/// The clock starts when the watch is made, so a limit is a deadline for
/// everything done after that (a replan's set-up included). A watch with
/// neither limit nor observers ([`Watch::new`]) never interrupts; the
/// solvers' plain entry points use one.
pub struct Watch<'a> {
    start: Instant,
    time_limit: Option<Duration>,
    observers: Vec<&'a mut dyn Observer>,
}

impl fmt::Debug for Watch<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Watch")
            .field("time_limit", &self.time_limit)
            .field("observers", &self.observers.len())
            .finish()
    }
}

impl Default for Watch<'_> {
    fn default() -> Self {
        Self::new()
    }
}

impl<'a> Watch<'a> {
    /// A watch started now, without limit or observers.
    pub fn new() -> Self {
        Self {
            start: Instant::now(),
            time_limit: None,
            observers: Vec::new(),
        }
    }

    /// With a wall-time limit, counted from the watch's start.
    pub fn with_time_limit(mut self, limit: Duration) -> Self {
        self.time_limit = Some(limit);
        self
    }

    /// With one more observer (called in the order added; the first
    /// [`Control::Stop`] stops the solve, and later observers do not see
    /// that iteration).
    pub fn with_observer(mut self, observer: &'a mut dyn Observer) -> Self {
        self.observers.push(observer);
        self
    }

    /// The wall-time limit, if any.
    pub fn time_limit(&self) -> Option<Duration> {
        self.time_limit
    }

    /// Time since the watch started.
    pub fn elapsed(&self) -> Duration {
        self.start.elapsed()
    }

    /// Whether anything can interrupt (a limit or an observer): solvers
    /// skip building their [`Progress`] when nothing can.
    pub fn is_active(&self) -> bool {
        self.time_limit.is_some() || !self.observers.is_empty()
    }

    /// [`Interrupt::TimeLimit`] once the limit has passed; a solver polls
    /// this inside long iterations (between trial steps, line-search
    /// points, rollouts).
    #[inline]
    pub fn out_of_time(&self) -> Option<Interrupt> {
        match self.time_limit {
            Some(limit) => self.past(limit),
            None => None,
        }
    }

    /// The clock read, out of line so that the solvers' loops stay as
    /// small as without a watch.
    #[cold]
    #[inline(never)]
    fn past(&self, limit: Duration) -> Option<Interrupt> {
        (self.elapsed() >= limit).then_some(Interrupt::TimeLimit)
    }

    /// Reports a completed iteration to the observers, then checks the
    /// time limit; returns why the solve must stop, if it must.
    #[inline]
    pub fn iteration(
        &mut self,
        solver: &'static str,
        iteration: usize,
        evaluations: usize,
        cost: f64,
        x: &[f64],
    ) -> Option<Interrupt> {
        if !self.is_active() {
            return None;
        }
        self.report(solver, iteration, evaluations, cost, x)
    }

    /// [`iteration`](Self::iteration)'s work when something can interrupt.
    #[cold]
    #[inline(never)]
    fn report(
        &mut self,
        solver: &'static str,
        iteration: usize,
        evaluations: usize,
        cost: f64,
        x: &[f64],
    ) -> Option<Interrupt> {
        let progress = Progress {
            solver,
            iteration,
            evaluations,
            cost,
            x,
            elapsed: self.elapsed(),
        };
        for observer in &mut self.observers {
            if observer.observe(&progress) == Control::Stop {
                return Some(Interrupt::Observer);
            }
        }
        self.out_of_time()
    }
}

/// Where an iterating solver stands after an iteration: what its
/// observers see ([`Progress`] without the name and the clock).
#[derive(Debug, Clone, Copy)]
pub struct Snapshot<'a> {
    /// Iterations completed.
    pub iteration: usize,
    /// Evaluations of the objective so far.
    pub evals: usize,
    /// The best cost so far.
    pub cost: f64,
    /// The best point so far.
    pub x: &'a [f64],
}

/// An iterative solver as a step function over its own iteration state,
/// run by the one driver, [`drive`] (the shape of argmin's `Solver`:
/// the state is made by the solver's entry point, `next_iter` is one
/// iteration, [`drive`] owns the loop).
///
/// Each solver keeps its own convergence tests and its iteration and
/// evaluation budgets inside `next_iter`, where they interleave with the
/// work (a budget can end a line search half-way); the driver owns the
/// loop, the observers and the wall-time limit between iterations, and
/// turns an interrupt into the solver's status. `next_iter` may poll
/// [`Watch::out_of_time`] inside a long iteration.
pub trait Iterate {
    /// The solver's status (says which test or budget ended the solve).
    type Status: From<Interrupt>;
    /// The solver's error.
    type Error;
    /// The solver's name, as observers see it ([`Progress::solver`]).
    const NAME: &'static str;

    /// Runs one iteration; `Some(status)` when the solve has ended.
    ///
    /// # Errors
    /// The solver's own failures (a model that fails to evaluate, ...).
    fn next_iter(&mut self, watch: &Watch<'_>) -> Result<Option<Self::Status>, Self::Error>;

    /// The state after the last iteration, as the observers see it.
    fn snapshot(&self) -> Snapshot<'_>;
}

/// The one driver of every iterative solver in the workspace: runs
/// [`Iterate::next_iter`] until it returns a status, reporting each
/// completed iteration to the watch ([`Watch::iteration`]); an observer's
/// stop or a passed time limit ends the solve with the solver's status
/// for that interrupt.
///
/// # Errors
/// The first error of [`Iterate::next_iter`].
///
/// ```
/// use solve::{drive, Interrupt, Iterate, Snapshot, Watch};
///
/// #[derive(Debug, PartialEq)]
/// enum Status { Converged, Interrupted(Interrupt) }
/// impl From<Interrupt> for Status {
///     fn from(why: Interrupt) -> Self { Status::Interrupted(why) }
/// }
///
/// // Newton's iteration for sqrt(2)
/// struct Sqrt2 { x: [f64; 1], it: usize }
/// impl Iterate for Sqrt2 {
///     type Status = Status;
///     type Error = std::convert::Infallible;
///     const NAME: &'static str = "sqrt2";
///     fn next_iter(&mut self, _: &Watch<'_>) -> Result<Option<Status>, Self::Error> {
///         let x = self.x[0];
///         self.x[0] = 0.5 * (x + 2.0 / x);
///         self.it += 1;
///         Ok(((self.x[0] - x).abs() < 1e-15).then_some(Status::Converged))
///     }
///     fn snapshot(&self) -> Snapshot<'_> {
///         let c = self.x[0] * self.x[0] - 2.0;
///         Snapshot { iteration: self.it, evals: self.it, cost: c * c, x: &self.x }
///     }
/// }
///
/// let mut s = Sqrt2 { x: [1.0], it: 0 };
/// assert_eq!(drive(&mut s, &mut Watch::new()), Ok(Status::Converged));
/// assert!((s.x[0] - 2f64.sqrt()).abs() < 1e-15 && s.it < 10);
/// ```
pub fn drive<I: Iterate>(solver: &mut I, watch: &mut Watch<'_>) -> Result<I::Status, I::Error> {
    loop {
        if let Some(status) = solver.next_iter(watch)? {
            return Ok(status);
        }
        let at = solver.snapshot();
        if let Some(why) = watch.iteration(I::NAME, at.iteration, at.evals, at.cost, at.x) {
            return Ok(why.into());
        }
    }
}

/// An iteration state that becomes the solver's result once the solve has
/// ended: what each solver's entry point does after [`drive`], as a method,
/// so that a solve can also be run by another loop (argmin's `Executor`
/// through `argmin::Stepper` with the feature `argmin`, or the caller's own).
///
/// Each solver makes its state with a `start` method (Gauss-Newton's
/// `GaussNewton::start`, the derivative-free mode's
/// `DerivativeFree::start`, DDP's `Ddp::start`, the LWR's
/// `LwrModel::tune_start`), and `start`, [`drive`], [`finish`](Self::finish)
/// is the solver's watched entry point.
pub trait Finish: Iterate {
    /// The solver's result.
    type Output;

    /// The result at the state reached, ended with `status` (the status
    /// [`drive`] returned, or one made from an [`Interrupt`] by the loop
    /// that stopped the solve).
    fn finish(self, status: Self::Status) -> Self::Output;
}

/// One recorded iteration of a [`Trace`].
#[derive(Debug, Clone, PartialEq)]
pub struct TraceRecord {
    /// As [`Progress::iteration`].
    pub iteration: usize,
    /// As [`Progress::evaluations`].
    pub evaluations: usize,
    /// As [`Progress::cost`].
    pub cost: f64,
    /// As [`Progress::elapsed`].
    pub elapsed: Duration,
    /// The point, when the trace keeps points ([`Trace::with_points`]).
    pub x: Option<Vec<f64>>,
}

/// An observer recording every iteration (never stops the solve).
#[derive(Debug, Clone, Default)]
pub struct Trace {
    /// The iterations seen, in order.
    pub records: Vec<TraceRecord>,
    keep_points: bool,
}

impl Trace {
    /// A trace of costs and counts only.
    pub fn new() -> Self {
        Self::default()
    }

    /// A trace that also copies each iteration's point.
    pub fn with_points() -> Self {
        Self {
            records: Vec::new(),
            keep_points: true,
        }
    }
}

impl Observer for Trace {
    fn observe(&mut self, progress: &Progress<'_>) -> Control {
        self.records.push(TraceRecord {
            iteration: progress.iteration,
            evaluations: progress.evaluations,
            cost: progress.cost,
            elapsed: progress.elapsed,
            x: self.keep_points.then(|| progress.x.to_vec()),
        });
        Control::Continue
    }
}

/// Why a solver stopped, in the one vocabulary all the workspace's solvers
/// share (each solver's own status says more; [`Status::termination`]
/// maps it here).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum Termination {
    /// A convergence test passed: the point is a (local) optimum to the
    /// solver's tolerances.
    Converged,
    /// A target cost given by the caller was reached (not a convergence
    /// test: the optimum may lie lower).
    TargetReached,
    /// The iteration budget was used up.
    MaxIterations,
    /// The evaluation budget was used up.
    MaxEvaluations,
    /// The wall-time limit of the [`Watch`] passed.
    TimeLimit,
    /// An [`Observer`] stopped the solve.
    Stopped,
    /// The solver could not go on (a numerical failure, a diverged rollout,
    /// no descent): the point is not an optimum.
    Failed,
}

impl Termination {
    /// The termination a watch's interrupt stands for.
    pub fn from_interrupt(interrupt: Interrupt) -> Self {
        match interrupt {
            Interrupt::TimeLimit => Self::TimeLimit,
            Interrupt::Observer => Self::Stopped,
        }
    }

    /// Whether a convergence test passed.
    pub fn is_converged(self) -> bool {
        self == Self::Converged
    }

    /// Whether a budget (iterations, evaluations, wall time) stopped the
    /// solve.
    pub fn is_budget(self) -> bool {
        matches!(self, Self::MaxIterations | Self::MaxEvaluations | Self::TimeLimit)
    }
}

impl From<Interrupt> for Termination {
    fn from(why: Interrupt) -> Self {
        Self::from_interrupt(why)
    }
}

impl fmt::Display for Termination {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Converged => "converged",
            Self::TargetReached => "target reached",
            Self::MaxIterations => "iteration budget",
            Self::MaxEvaluations => "evaluation budget",
            Self::TimeLimit => "time limit",
            Self::Stopped => "stopped by an observer",
            Self::Failed => "failed",
        })
    }
}

/// A solver's status, classified.
pub trait Status {
    /// The status in the shared vocabulary.
    fn termination(&self) -> Termination;
}

impl Status for Termination {
    fn termination(&self) -> Termination {
        *self
    }
}

/// What every solver's result says, under one name each: the one result
/// shape of the workspace. Each result type keeps its own extra fields
/// (DDP's gains, Gauss-Newton's factorisations, the LWR tuning's history)
/// and gives this view through [`Outcome::summary`].
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// The cost at the returned point (the solver's own objective: a sum
    /// of squares, a cost function, a trajectory cost, a cross-validation
    /// error).
    pub cost: f64,
    /// The cost at the start.
    pub initial_cost: f64,
    /// Iterations made.
    pub iterations: usize,
    /// Evaluations of the objective (residual vectors, costs, rollouts or
    /// cross-validation passes), counted as the solver's `max_evals`
    /// budget counts them.
    pub evals: usize,
    /// Why the solver stopped.
    pub termination: Termination,
    /// The solve's wall time, where the solver measures it.
    pub solve_time: Option<Duration>,
}

/// A solver's result, seen through the one shape ([`Summary`]).
pub trait Outcome {
    /// The fields all results share.
    fn summary(&self) -> Summary;
}

/// Implements [`Outcome`] for result types with the workspace's common
/// fields (`cost`, `initial_cost`, `iterations`, `evals`, a `status`
/// implementing [`Status`], and `solve_time: Duration`), so that each
/// solver crate states its results' shape once.
///
/// ```
/// use std::time::Duration;
/// use solve::{Outcome, Termination};
///
/// struct MyResult {
///     cost: f64,
///     initial_cost: f64,
///     iterations: usize,
///     evals: usize,
///     status: Termination,
///     solve_time: Duration,
/// }
/// solve::outcome!(MyResult);
///
/// let r = MyResult { cost: 1.0, initial_cost: 4.0, iterations: 3, evals: 7, status: Termination::Converged, solve_time: Duration::from_millis(2) };
/// let s = r.summary();
/// assert_eq!((s.cost, s.evals, s.termination), (1.0, 7, Termination::Converged));
/// assert_eq!(s.solve_time, Some(Duration::from_millis(2)));
/// ```
#[macro_export]
macro_rules! outcome {
    ($($result:ty),+ $(,)?) => {$(
        impl $crate::Outcome for $result {
            fn summary(&self) -> $crate::Summary {
                $crate::Summary {
                    cost: self.cost,
                    initial_cost: self.initial_cost,
                    iterations: self.iterations,
                    evals: self.evals,
                    termination: $crate::Status::termination(&self.status),
                    solve_time: Some(self.solve_time),
                }
            }
        }
    )+};
}

/// Implements `From<Interrupt>` for solver statuses with the workspace's
/// two interrupt variants, `TimeLimit` and `Stopped` (an observer's stop),
/// so that each solver states the mapping once.
///
/// ```
/// #[derive(Debug, PartialEq)]
/// enum MyStatus { Converged, TimeLimit, Stopped }
/// solve::from_interrupt!(MyStatus);
///
/// assert_eq!(MyStatus::from(solve::Interrupt::TimeLimit), MyStatus::TimeLimit);
/// assert_eq!(MyStatus::from(solve::Interrupt::Observer), MyStatus::Stopped);
/// ```
#[macro_export]
macro_rules! from_interrupt {
    ($($status:ty),+ $(,)?) => {$(
        impl From<$crate::Interrupt> for $status {
            fn from(why: $crate::Interrupt) -> Self {
                match why {
                    $crate::Interrupt::TimeLimit => Self::TimeLimit,
                    $crate::Interrupt::Observer => Self::Stopped,
                }
            }
        }
    )+};
}

/// Defines a crate's two input checks over its own error type, so that the
/// solver crates share one definition: `check_finite(what, values)` fails
/// with `$error::NotFinite { what, index, value }` at the first non-finite
/// value, and `$len(what, expected, actual)` with
/// `$error::DimensionMismatch { what, expected, actual }`. Both return the
/// crate's `Result<()>`, which must be in scope.
///
/// ```
/// #[derive(Debug, PartialEq)]
/// enum MyError {
///     NotFinite { what: &'static str, index: usize, value: f64 },
///     DimensionMismatch { what: &'static str, expected: usize, actual: usize },
/// }
/// type Result<T> = std::result::Result<T, MyError>;
/// solve::input_checks!(MyError, check_len);
///
/// assert!(check_finite("x", &[1.0, 2.0]).is_ok());
/// assert_eq!(
///     check_finite("x", &[1.0, f64::NAN]).map_err(|e| matches!(e, MyError::NotFinite { index: 1, .. })),
///     Err(true)
/// );
/// assert_eq!(
///     check_len("u", 2, 3),
///     Err(MyError::DimensionMismatch { what: "u", expected: 2, actual: 3 })
/// );
/// ```
#[macro_export]
macro_rules! input_checks {
    ($error:ident, $len:ident) => {
        /// Checks that every value is finite.
        #[allow(dead_code)]
        pub(crate) fn check_finite(what: &'static str, values: &[f64]) -> Result<()> {
            match values.iter().position(|v| !v.is_finite()) {
                Some(index) => Err($error::NotFinite {
                    what,
                    index,
                    value: values[index],
                }),
                None => Ok(()),
            }
        }

        /// Checks that a size (`what`) is the expected one.
        #[allow(dead_code)]
        pub(crate) fn $len(what: &'static str, expected: usize, actual: usize) -> Result<()> {
            if expected == actual {
                Ok(())
            } else {
                Err($error::DimensionMismatch {
                    what,
                    expected,
                    actual,
                })
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Halving, Negative};

    #[test]
    fn an_idle_watch_never_interrupts_and_builds_no_progress() {
        let mut watch = Watch::new();
        assert!(!watch.is_active());
        for it in 0..1000 {
            assert_eq!(watch.iteration("t", it, it, 1.0, &[0.0]), None);
        }
        assert_eq!(watch.out_of_time(), None);
    }

    #[test]
    fn a_passed_limit_interrupts_and_an_unpassed_one_does_not() {
        let mut late = Watch::new().with_time_limit(Duration::ZERO);
        assert_eq!(late.out_of_time(), Some(Interrupt::TimeLimit));
        assert_eq!(late.iteration("t", 1, 1, 0.0, &[]), Some(Interrupt::TimeLimit));
        let mut early = Watch::new().with_time_limit(Duration::from_secs(3600));
        assert_eq!(early.iteration("t", 1, 1, 0.0, &[]), None);
    }

    #[test]
    fn the_first_stopping_observer_wins_and_later_ones_do_not_see_it() {
        let mut seen_first = 0;
        let mut first = |p: &Progress<'_>| {
            seen_first += 1;
            if p.iteration == 3 {
                Control::Stop
            } else {
                Control::Continue
            }
        };
        let mut second = Trace::with_points();
        {
            let mut watch = Watch::new().with_observer(&mut first).with_observer(&mut second);
            for it in 1..=5 {
                let x = [it as f64];
                if let Some(why) = watch.iteration("t", it, 2 * it, 1.0 / it as f64, &x) {
                    assert_eq!(why, Interrupt::Observer);
                    assert_eq!(it, 3);
                    break;
                }
            }
        }
        assert_eq!(seen_first, 3);
        assert_eq!(second.records.len(), 2);
        assert_eq!(second.records[1].evaluations, 4);
        assert_eq!(second.records[1].x.as_deref(), Some(&[2.0][..]));
    }

    #[test]
    fn the_driver_reports_every_iteration_and_ends_on_the_first_stop() {
        // the solver's own end
        let mut s = Halving::new(1.0, 7, Termination::MaxIterations);
        let mut trace = Trace::new();
        let mut watch = Watch::new().with_observer(&mut trace);
        assert_eq!(drive(&mut s, &mut watch), Ok(Termination::MaxIterations));
        drop(watch);
        assert_eq!(trace.records.len(), 7);
        assert_eq!(trace.records[6].evaluations, 14);
        assert_eq!(trace.records[2].cost, 0.125);
        // an observer's stop after the iteration it saw
        let mut s = Halving::new(1.0, 100, Termination::MaxIterations);
        let mut stop = |p: &Progress<'_>| {
            if p.iteration == 4 {
                Control::Stop
            } else {
                Control::Continue
            }
        };
        let mut watch = Watch::new().with_observer(&mut stop);
        assert_eq!(drive(&mut s, &mut watch), Ok(Termination::Stopped));
        assert_eq!(s.it, 4);
        // a passed time limit, from inside the step or after it
        let mut s = Halving::new(1.0, 100, Termination::MaxIterations);
        let mut watch = Watch::new().with_time_limit(Duration::ZERO);
        assert_eq!(drive(&mut s, &mut watch), Ok(Termination::TimeLimit));
        assert_eq!(s.it, 0);
        // an error ends the drive
        let mut s = Halving::new(-1.0, 100, Termination::MaxIterations);
        assert_eq!(drive(&mut s, &mut Watch::new()), Err(Negative));
    }

    #[test]
    fn terminations_classify() {
        assert!(Termination::Converged.is_converged());
        assert!(!Termination::TargetReached.is_converged());
        for t in [
            Termination::MaxIterations,
            Termination::MaxEvaluations,
            Termination::TimeLimit,
        ] {
            assert!(t.is_budget());
        }
        assert!(!Termination::Stopped.is_budget());
        assert_eq!(Termination::from_interrupt(Interrupt::Observer), Termination::Stopped);
        assert_eq!(
            Termination::from_interrupt(Interrupt::TimeLimit).to_string(),
            "time limit"
        );
    }
}
