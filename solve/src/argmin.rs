//! Any workspace solver as an argmin [`Solver`]: [`Stepper`] runs an
//! [`Iterate`] state under argmin's `Executor` (its observers, its
//! `max_iters`, its timeout), and [`finish`] turns the executor's result
//! into the solver's own.
//!
//! The argmin problem is the solver's iteration state itself (made by the
//! solver's `start` method, which borrows the real problem), so the
//! executor's `Problem` wrapper owns the state between iterations and
//! [`finish`] takes it back. One argmin iteration is one
//! [`Iterate::next_iter`]; after it the argmin state holds the solver's
//! best point and cost, and the problem's counts hold the solver's
//! evaluations under `"evals"`.
//!
//! How a solve ends:
//! - the solver ends it (a convergence test, its own budgets, a failure):
//!   argmin's termination reason follows [`Status::termination`]
//!   (`Converged` is `SolverConverged`, `MaxIterations` is
//!   `MaxItersReached`, `TimeLimit` is `Timeout`, `Stopped` is
//!   `Interrupt`, the rest `SolverExit` with the status's name), and
//!   [`finish`] gives the solver's status;
//! - argmin ends it (its `max_iters`, target cost, timeout, an observer or
//!   Ctrl-C): the solver's status is the one for a passed time limit
//!   ([`Interrupt::TimeLimit`]) after argmin's `Timeout`, and for a stop
//!   from outside ([`Interrupt::Observer`], the solvers' `Stopped`) after
//!   the others; argmin's state keeps the exact reason.
//!
//! argmin's timeout is checked between iterations only;
//! [`Stepper::with_time_limit`] is a deadline inside the iterations too,
//! where each solver polls its clock (the crate README's table).
//!
//! ```
//! use argmin::core::{Executor, State, TerminationReason, TerminationStatus};
//! use solve::argmin::{finish, Stepper};
//! use solve::{Finish, Iterate, Snapshot, Termination, Watch};
//!
//! // Newton's iteration for sqrt(2), with a result type of its own
//! struct Sqrt2 { x: [f64; 1], it: usize }
//! impl Iterate for Sqrt2 {
//!     type Status = Termination;
//!     type Error = std::convert::Infallible;
//!     const NAME: &'static str = "sqrt2";
//!     fn next_iter(&mut self, _: &Watch<'_>) -> Result<Option<Termination>, Self::Error> {
//!         let x = self.x[0];
//!         self.x[0] = 0.5 * (x + 2.0 / x);
//!         self.it += 1;
//!         Ok(((self.x[0] - x).abs() < 1e-15).then_some(Termination::Converged))
//!     }
//!     fn snapshot(&self) -> Snapshot<'_> {
//!         let c = self.x[0] * self.x[0] - 2.0;
//!         Snapshot { iteration: self.it, evals: self.it, cost: c * c, x: &self.x }
//!     }
//! }
//! impl Finish for Sqrt2 {
//!     type Output = (f64, Termination);
//!     fn finish(self, status: Termination) -> (f64, Termination) { (self.x[0], status) }
//! }
//!
//! let run = Executor::new(Sqrt2 { x: [1.0], it: 0 }, Stepper::new()).run()?;
//! assert_eq!(
//!     run.state.get_termination_status(),
//!     &TerminationStatus::Terminated(TerminationReason::SolverConverged)
//! );
//! let (x, status) = finish(run)?;
//! assert_eq!(status, Termination::Converged);
//! assert!((x - 2f64.sqrt()).abs() < 1e-15);
//!
//! // argmin's own iteration budget: a stop from outside the solver
//! let run = Executor::new(Sqrt2 { x: [1.0], it: 0 }, Stepper::new())
//!     .configure(|s| s.max_iters(2))
//!     .run()?;
//! assert_eq!((run.state.get_iter(), finish(run)?.1), (2, Termination::Stopped));
//! # Ok::<(), argmin::core::Error>(())
//! ```

use std::fmt;
use std::time::Duration;

use argmin::core::{
    Error, IterState, KV, OptimizationResult, Problem, Solver, State, TerminationReason, TerminationStatus,
};

use crate::{Finish, Interrupt, Iterate, Status, Termination, Watch};

/// The argmin state a [`Stepper`] runs with: the point as `Vec<f64>` and a
/// scalar cost, no gradient, Hessian or Jacobian kept by argmin.
pub type StepperState = IterState<Vec<f64>, (), (), (), (), f64>;

/// The key of the solver's evaluations in argmin's function counts.
pub const EVALS: &str = "evals";

/// Runs an [`Iterate`] state as an argmin [`Solver`] (the [module
/// docs](self)).
pub struct Stepper<I: Iterate> {
    time_limit: Option<Duration>,
    watch: Option<Watch<'static>>,
    status: Option<I::Status>,
}

impl<I: Iterate> fmt::Debug for Stepper<I>
where
    I::Status: fmt::Debug,
{
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Stepper")
            .field("time_limit", &self.time_limit)
            .field("status", &self.status)
            .finish()
    }
}

impl<I: Iterate> Default for Stepper<I> {
    fn default() -> Self {
        Self::new()
    }
}

impl<I: Iterate> Stepper<I> {
    /// A stepper without a time limit of its own (argmin's timeout still
    /// applies between iterations).
    pub fn new() -> Self {
        Self {
            time_limit: None,
            watch: None,
            status: None,
        }
    }

    /// With a wall-time limit counted from argmin's `init`, polled by the
    /// solver inside its iterations as under [`Watch::with_time_limit`];
    /// a passed limit ends the solve with the solver's `TimeLimit` status.
    pub fn with_time_limit(mut self, limit: Duration) -> Self {
        self.time_limit = Some(limit);
        self
    }

    /// The solver's own status, once the solver has ended the solve
    /// (`None` while it runs, and when argmin stopped it).
    pub fn status(&self) -> Option<&I::Status> {
        self.status.as_ref()
    }

    /// The watch given to the solver's iterations, started at the first
    /// call.
    fn watch(&mut self) -> &Watch<'static> {
        let limit = self.time_limit;
        self.watch.get_or_insert_with(|| match limit {
            Some(limit) => Watch::new().with_time_limit(limit),
            None => Watch::new(),
        })
    }
}

/// The argmin state after an iteration: the solver's best point and cost,
/// and its evaluations in the problem's counts.
fn observed<I: Iterate>(problem: &mut Problem<I>, state: StepperState) -> Result<StepperState, Error> {
    let it = problem
        .problem
        .as_ref()
        .ok_or_else(|| Error::msg("the solver's state was taken from argmin's problem"))?;
    let at = it.snapshot();
    problem.counts.insert(EVALS, at.evals as u64);
    Ok(state.param(at.x.to_vec()).cost(at.cost))
}

impl<I> Solver<I, StepperState> for Stepper<I>
where
    I: Iterate,
    I::Status: Status + fmt::Debug,
    I::Error: std::error::Error + Send + Sync + 'static,
{
    fn name(&self) -> &str {
        I::NAME
    }

    fn init(&mut self, problem: &mut Problem<I>, state: StepperState) -> Result<(StepperState, Option<KV>), Error> {
        self.watch();
        Ok((observed(problem, state)?, None))
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<I>,
        state: StepperState,
    ) -> Result<(StepperState, Option<KV>), Error> {
        if self.status.is_some() {
            return Ok((state, None));
        }
        let it = problem
            .problem
            .as_mut()
            .ok_or_else(|| Error::msg("the solver's state was taken from argmin's problem"))?;
        let watch = self.watch();
        let status = match it.next_iter(watch)? {
            Some(status) => Some(status),
            None => watch.out_of_time().map(I::Status::from),
        };
        self.status = status;
        let state = observed(problem, state)?;
        let kv = argmin::kv!(EVALS => problem.counts.get(EVALS).copied().unwrap_or(0););
        Ok((state, Some(kv)))
    }

    fn terminate(&mut self, _state: &StepperState) -> TerminationStatus {
        let Some(status) = &self.status else {
            return TerminationStatus::NotTerminated;
        };
        TerminationStatus::Terminated(match status.termination() {
            Termination::Converged => TerminationReason::SolverConverged,
            Termination::TargetReached => TerminationReason::TargetCostReached,
            Termination::MaxIterations => TerminationReason::MaxItersReached,
            Termination::TimeLimit => TerminationReason::Timeout,
            Termination::Stopped => TerminationReason::Interrupt,
            Termination::MaxEvaluations | Termination::Failed => TerminationReason::SolverExit(format!("{status:?}")),
        })
    }
}

/// The solver's result from argmin's: the state the executor's problem
/// holds, finished with the solver's status, or with the status for
/// argmin's own stop (the [module docs](self)).
///
/// # Errors
/// When the executor's problem no longer holds the state (taken by the
/// caller).
pub fn finish<I: Finish>(run: OptimizationResult<I, Stepper<I>, StepperState>) -> Result<I::Output, Error> {
    let OptimizationResult {
        mut problem,
        solver,
        state,
    } = run;
    let it = problem
        .take_problem()
        .ok_or_else(|| Error::msg("the solver's state was taken from argmin's problem"))?;
    let status = match solver.status {
        Some(status) => status,
        None => I::Status::from(match state.get_termination_reason() {
            Some(TerminationReason::Timeout) => Interrupt::TimeLimit,
            _ => Interrupt::Observer,
        }),
    };
    Ok(it.finish(status))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::Halving;
    use argmin::core::Executor;

    #[test]
    fn the_solvers_own_end_and_counts_reach_argmin() {
        let run = Executor::new(Halving::new(1.0, 5, Termination::Failed), Stepper::new())
            .run()
            .expect("run");
        assert_eq!(
            run.state.get_termination_reason(),
            Some(&TerminationReason::SolverExit("Failed".into()))
        );
        assert_eq!(run.state.get_best_cost(), 1.0 / 32.0);
        assert_eq!(run.state.get_best_param(), Some(&vec![1.0 / 32.0]));
        assert_eq!(run.problem.counts.get(EVALS), Some(&10));
        assert_eq!(run.solver.status(), Some(&Termination::Failed));
        assert_eq!(finish(run).expect("finish"), (5, Termination::Failed));
    }

    #[test]
    fn a_passed_time_limit_ends_the_solve_inside_or_after_an_iteration() {
        let stepper = Stepper::new().with_time_limit(Duration::ZERO);
        let run = Executor::new(Halving::new(1.0, usize::MAX, Termination::MaxIterations), stepper)
            .run()
            .expect("run");
        assert_eq!(run.state.get_termination_reason(), Some(&TerminationReason::Timeout));
        // the solver saw the stepper's limit as its first iteration started
        assert_eq!(finish(run).expect("finish"), (0, Termination::TimeLimit));
        // a solver that does not poll: the stepper ends it after its iteration
        let stepper = Stepper::new().with_time_limit(Duration::ZERO);
        let halving = Halving::new(1.0, usize::MAX, Termination::MaxIterations).ignoring_the_clock();
        let run = Executor::new(halving, stepper)
            .configure(|s| s.max_iters(1000))
            .run()
            .expect("run");
        assert_eq!(run.state.get_termination_reason(), Some(&TerminationReason::Timeout));
        assert_eq!(finish(run).expect("finish"), (1, Termination::TimeLimit));
    }

    #[test]
    fn argmins_own_stops_are_stops_from_outside() {
        let run = Executor::new(
            Halving::new(1.0, usize::MAX, Termination::MaxIterations),
            Stepper::new(),
        )
        .configure(|s| s.target_cost(0.1))
        .run()
        .expect("run");
        assert_eq!(
            run.state.get_termination_reason(),
            Some(&TerminationReason::TargetCostReached)
        );
        assert_eq!(finish(run).expect("finish"), (4, Termination::Stopped));
        let run = Executor::new(
            Halving::new(1.0, usize::MAX, Termination::MaxIterations),
            Stepper::new(),
        )
        .timeout(Duration::ZERO)
        .run()
        .expect("run");
        assert_eq!(run.state.get_termination_reason(), Some(&TerminationReason::Timeout));
        assert_eq!(finish(run).expect("finish").1, Termination::TimeLimit);
    }

    #[test]
    fn the_solvers_error_is_argmins() {
        match Executor::new(
            Halving::new(-1.0, usize::MAX, Termination::MaxIterations),
            Stepper::new(),
        )
        .run()
        {
            Err(err) => assert_eq!(err.to_string(), "negative"),
            Ok(run) => panic!("ran to {:?}", run.state.get_termination_reason()),
        }
    }
}
