//! [`PowellArgmin`]: Powell's method under argmin's `Executor`.

use argmin::core::{CostFunction, IterState, KV, Problem, Solver, State, TerminationReason, TerminationStatus};

use super::engine::Engine;
use super::{PowellSettings, PowellStatus, invalid};
use crate::error::Result;

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
    pub fn evals(&self) -> usize {
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
            Some(PowellStatus::ReachedStopCost) => TerminationStatus::Terminated(TerminationReason::TargetCostReached),
            // not made by the engine (argmin's executor has its own timeout and observers)
            Some(PowellStatus::TimeLimit) => TerminationStatus::Terminated(TerminationReason::Timeout),
            Some(PowellStatus::Stopped) => TerminationStatus::Terminated(TerminationReason::Interrupt),
            None => TerminationStatus::NotTerminated,
        }
    }
}
