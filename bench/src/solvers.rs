//! The solvers the runner knows ([`Solver`]) and one run of one of them on
//! one instance ([`Solver::run`]).
//!
//! | name | solver | uses |
//! |---|---|---|
//! | `gauss-newton` | [`trajopt::GaussNewton`], [`StepModel::GaussNewton`] (Levenberg-Marquardt damping) | $r$, $J$ |
//! | `newton` | the same, [`StepModel::Newton`] | $r$, $J$, $S$ by central differences of $J$ ($2n$ Jacobians) |
//! | `adaptive` | the same, [`StepModel::Adaptive`] | as `newton`, $S$ only where the model choice asks for it |
//! | `powell` | [`trajopt::Powell`] | $f$ |
//! | `argmin-nelder-mead` | argmin's `NelderMead` (scipy's initial simplex: 5% of each coordinate, 0.00025 for a zero) | $f$ |
//! | `argmin-lbfgs` | argmin's `LBFGS`, memory 7, Moré-Thuente line search | $f$, $\nabla f = 2 J^\top r$ |
//!
//! Every solver runs with tight tolerances of its own and stops at the
//! [`Budget`] at the latest; the profiles read when each run first met the
//! convergence test from its trace, so how a solver decides to stop changes
//! its time but not its evaluations to a solution.

use std::time::Instant;

use argmin::core::{CostFunction, Executor, Gradient};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::neldermead::NelderMead;
use argmin::solver::quasinewton::LBFGS;
use trajopt::{DampingScale, GaussNewton, GaussNewtonSettings, Powell, PowellSettings, StepModel};

use crate::error::{BenchError, Result};
use crate::problems::{Budget, Counted, Instance};
use crate::record::{RunRecord, thin_trace};

/// A solver of the runner; see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Solver {
    /// trajopt's Gauss-Newton / Levenberg-Marquardt.
    GaussNewton,
    /// trajopt's least squares in Newton mode.
    Newton,
    /// trajopt's least squares in adaptive mode.
    Adaptive,
    /// trajopt's Powell.
    Powell,
    /// argmin's Nelder-Mead.
    NelderMead,
    /// argmin's L-BFGS.
    Lbfgs,
}

impl Solver {
    /// Every solver, in the tables' order.
    pub const ALL: [Self; 6] = [
        Self::GaussNewton,
        Self::Newton,
        Self::Adaptive,
        Self::Powell,
        Self::NelderMead,
        Self::Lbfgs,
    ];

    /// The solver's name on the command line and in the records.
    pub fn name(self) -> &'static str {
        match self {
            Self::GaussNewton => "gauss-newton",
            Self::Newton => "newton",
            Self::Adaptive => "adaptive",
            Self::Powell => "powell",
            Self::NelderMead => "argmin-nelder-mead",
            Self::Lbfgs => "argmin-lbfgs",
        }
    }

    /// Whether it uses only $f$ (the data profiles' solvers).
    pub fn derivative_free(self) -> bool {
        matches!(self, Self::Powell | Self::NelderMead)
    }

    /// Whether it runs on `instance` (every solver runs on every
    /// least-squares instance; a set with other forms says so here).
    pub fn applies_to(self, instance: &Instance) -> bool {
        !instance.start.is_empty()
    }

    /// The solvers named in `list`: `all`, or names separated by commas.
    ///
    /// # Errors
    /// [`BenchError::UnknownSolver`] naming the first unknown name.
    pub fn parse_list(list: &str) -> Result<Vec<Self>> {
        if list.trim() == "all" {
            return Ok(Self::ALL.to_vec());
        }
        let mut out = Vec::new();
        for name in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let solver = Self::ALL
                .into_iter()
                .find(|s| s.name() == name)
                .ok_or_else(|| BenchError::UnknownSolver {
                    name: name.into(),
                    known: Self::ALL.map(Self::name).join(", "),
                })?;
            if !out.contains(&solver) {
                out.push(solver);
            }
        }
        if out.is_empty() {
            return Err(BenchError::InvalidSetting {
                name: "solvers",
                reason: "no solver named".into(),
            });
        }
        Ok(out)
    }

    /// Runs the solver on `instance` within `budget`, `repeats` times
    /// (the counts are the first run's, the time the median).
    ///
    /// # Errors
    /// [`BenchError::Solver`] if the solver refuses its settings; a run that
    /// fails or spends its budget is a record with that status.
    pub fn run(self, instance: &Instance, budget: &Budget, repeats: u32) -> Result<RunRecord> {
        let mut times = Vec::new();
        let mut first = None;
        for _ in 0..repeats.max(1) {
            let counted = Counted::new(instance, budget);
            let start = Instant::now();
            let outcome = self.solve(&counted, instance);
            times.push(start.elapsed().as_secs_f64());
            if first.is_none() {
                first = Some((
                    outcome?,
                    counted.f_evals(),
                    counted.jac_evals(),
                    counted.evals(),
                    counted.spent(),
                    counted.best(),
                    counted.trace(),
                ));
            }
        }
        let (outcome, f_evals, jac_evals, evals, spent, best, trace) =
            first.ok_or_else(|| BenchError::InvalidSetting {
                name: "repeats",
                reason: "no run".into(),
            })?;
        times.sort_by(f64::total_cmp);
        let (status, converged) = match outcome {
            _ if spent => ("budget".to_string(), false),
            Outcome::Stopped { status, converged } => (status, converged),
            Outcome::Failed(e) => (format!("error: {e}"), false),
        };
        let f0 = trace.first().map_or(f64::NAN, |p| p.1);
        Ok(RunRecord {
            solver: self.name().into(),
            set: instance.set.into(),
            problem: instance.problem.clone(),
            n: instance.n(),
            m: instance.residuals,
            scale: instance.scale,
            status,
            converged,
            f0,
            f: best,
            f_star: instance.f_star,
            f_evals,
            jac_evals,
            evals,
            time_s: times[times.len() / 2],
            repeats: repeats.max(1),
            trace: thin_trace(&trace),
        })
    }

    /// One solve; `Err` only for refused settings.
    fn solve(self, counted: &Counted<'_>, instance: &Instance) -> Result<Outcome> {
        let refused = |e: String| BenchError::Solver {
            solver: self.name().into(),
            problem: instance.problem.clone(),
            reason: e,
        };
        let x0 = instance.start.as_slice();
        Ok(match self {
            Self::GaussNewton | Self::Newton | Self::Adaptive => {
                let step_model = match self {
                    Self::Newton => StepModel::Newton,
                    Self::Adaptive => StepModel::Adaptive,
                    _ => StepModel::GaussNewton,
                };
                let solver = GaussNewton::new(GaussNewtonSettings {
                    max_iterations: usize::MAX,
                    step_model,
                    // MINPACK's scaling (the default stalls on Penalty II)
                    damping_scale: DampingScale::RunningMax,
                    ..GaussNewtonSettings::default()
                })
                .map_err(|e| refused(e.to_string()))?;
                match solver.solve(counted, x0) {
                    Ok(r) => Outcome::stopped(format!("{:?}", r.status), r.status.is_converged()),
                    Err(e) => Outcome::Failed(e.to_string()),
                }
            }
            Self::Powell => {
                let solver = Powell::new(PowellSettings {
                    tol_f: 1e-14,
                    tol_x: 1e-12,
                    max_iterations: Some(usize::MAX),
                    max_cost_evals: Some(usize::MAX),
                    ..PowellSettings::default()
                })
                .map_err(|e| refused(e.to_string()))?;
                match solver.solve(&|x: &[f64]| counted.cost(x), x0) {
                    Ok(r) => Outcome::stopped(format!("{:?}", r.status), r.status.is_converged()),
                    Err(e) => Outcome::Failed(e.to_string()),
                }
            }
            Self::NelderMead => {
                let mut simplex = vec![x0.to_vec()];
                for j in 0..x0.len() {
                    let mut v = x0.to_vec();
                    v[j] = if v[j] == 0.0 { 0.00025 } else { 1.05 * v[j] };
                    simplex.push(v);
                }
                let solver = NelderMead::new(simplex)
                    .with_sd_tolerance(1e-14)
                    .map_err(|e| refused(e.to_string()))?;
                let run = Executor::new(ArgminView(counted), solver)
                    .configure(|s| s.max_iters(u64::MAX))
                    .run();
                Outcome::from_argmin(run.map(|r| r.state.termination_status.to_string()))
            }
            Self::Lbfgs => {
                let solver = LBFGS::new(MoreThuenteLineSearch::new(), 7)
                    .with_tolerance_grad(1e-12)
                    .and_then(|s| s.with_tolerance_cost(1e-16))
                    .map_err(|e| refused(e.to_string()))?;
                let run = Executor::new(ArgminView(counted), solver)
                    .configure(|s| s.param(x0.to_vec()).max_iters(u64::MAX))
                    .run();
                Outcome::from_argmin(run.map(|r| r.state.termination_status.to_string()))
            }
        })
    }
}

/// How a solve ended.
enum Outcome {
    /// The solver stopped by itself with this status.
    Stopped { status: String, converged: bool },
    /// The solve returned an error (the budget, or a failed evaluation).
    Failed(String),
}

impl Outcome {
    fn stopped(status: String, converged: bool) -> Self {
        Self::Stopped { status, converged }
    }

    /// argmin's termination status: converged unless it hit the iteration cap.
    fn from_argmin(run: std::result::Result<String, argmin::core::Error>) -> Self {
        match run {
            Ok(status) => {
                let converged = !status.contains("Maximum") && !status.contains("Not terminated");
                Self::stopped(status, converged)
            }
            Err(e) => Self::Failed(e.to_string()),
        }
    }
}

/// The counted problem as argmin's `CostFunction` and `Gradient`.
struct ArgminView<'a, 'b>(&'a Counted<'b>);

impl CostFunction for ArgminView<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, x: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        self.0.cost(x).map_err(argmin::core::Error::new)
    }
}

impl Gradient for ArgminView<'_, '_> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;

    fn gradient(&self, x: &Vec<f64>) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        self.0.gradient(x).map_err(argmin::core::Error::new)
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::problems::ProblemSet;

    #[test]
    fn solver_lists_parse_and_unknown_names_are_typed_errors() {
        assert_eq!(Solver::parse_list("all").expect("all").len(), Solver::ALL.len());
        assert_eq!(
            Solver::parse_list("powell, gauss-newton,powell").expect("two"),
            vec![Solver::Powell, Solver::GaussNewton]
        );
        match Solver::parse_list("powell,praxis") {
            Err(BenchError::UnknownSolver { name, known }) => {
                assert_eq!(name, "praxis");
                assert!(known.contains("argmin-lbfgs"));
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            Solver::parse_list(" , "),
            Err(BenchError::InvalidSetting { name: "solvers", .. })
        ));
    }

    #[test]
    fn every_solver_solves_rosenbrock_and_records_its_run() {
        let inst = &ProblemSet::Mgh.instances()[0];
        let budget = Budget {
            simplex_gradients: 5000,
            time: Duration::from_secs(30),
        };
        for solver in Solver::ALL {
            let rec = solver.run(inst, &budget, 1).expect("runs");
            assert_eq!((rec.solver.as_str(), rec.n, rec.m), (solver.name(), 2, 2));
            assert!((rec.f0 - 24.2).abs() < 1e-12);
            assert!(rec.f < 1e-8, "{}: {rec:?}", solver.name());
            assert_eq!(rec.evals, rec.f_evals + 2 * rec.jac_evals);
            assert!(rec.trace.last().is_some_and(|p| p.1 == rec.f && p.0 <= rec.evals));
            assert_eq!(solver.derivative_free(), rec.jac_evals == 0, "{}", solver.name());
        }
    }

    #[test]
    fn a_spent_budget_is_a_status_with_the_best_point() {
        let inst = &ProblemSet::Mgh.instances()[0];
        let budget = Budget {
            simplex_gradients: 10,
            time: Duration::from_secs(30),
        };
        let rec = Solver::Powell.run(inst, &budget, 1).expect("runs");
        assert_eq!(rec.status, "budget");
        assert!(!rec.converged && rec.evals <= 30 && rec.f < rec.f0);
    }
}
