//! The solvers the runner knows ([`Solver`]) and one run of one of them on
//! one instance ([`BenchSolver::run`]).
//!
//! | name | solver | uses |
//! |---|---|---|
//! | `gauss-newton` | [`trajopt::GaussNewton`], [`StepModel::GaussNewton`] (Levenberg-Marquardt damping) | $r$, $J$ |
//! | `newton` | the same, [`StepModel::Newton`] | $r$, $J$, $S$ by central differences of $J$ ($2n$ Jacobians) |
//! | `adaptive` | the same, [`StepModel::Adaptive`] | as `newton`, $S$ only where the model choice asks for it |
//! | `powell` | [`trajopt::Powell`] | $f$ |
//! | `dfo-ls` | [`trajopt::DerivativeFree`]: Levenberg-Marquardt on a Jacobian forward-differenced by column groups of the residuals, settings as `gauss-newton`'s, the budget as its `max_evals` | $r$ (each evaluation counts 1, the differences' included) |
//! | `argmin-nelder-mead` | argmin's `NelderMead` (scipy's initial simplex: 5% of each coordinate, 0.00025 for a zero) | $f$ |
//! | `argmin-lbfgs` | argmin's `LBFGS`, memory 7, Moré-Thuente line search | $f$, $\nabla f = 2 J^\top r$ |
//! | `ddp-ilqr` | [`ddp::Ddp`], [`DdpMethod::Ilqr`], on the DDP form (trajectory set) | rollouts, linearisations |
//! | `ddp-full` | the same, [`DdpMethod::Ddp`] (second derivatives of the dynamics) | rollouts, linearisations with second derivatives |
//!
//! On the trajectory set Nelder-Mead does not run (hundreds to thousands
//! of parameters), the DDP solvers run only where the instance has a DDP
//! form, and every run on an instance with one is scored by the rolled-out
//! task cost of its final controls ([`crate::trajectory`]). A DDP rollout
//! counts as one evaluation, a linearisation along the trajectory as $n$
//! (the Eq. 3 form's parameter count: an Eq. 3 Jacobian holds the same
//! dynamics derivatives at every knot), $2n$ with second derivatives
//! (full DDP), as Newton's $J$ and $S$. DDP stops by its own tests or at
//! 1000 iterations; it does not see the budget.
//!
//! Every solver runs with tight tolerances of its own and stops at the
//! [`Budget`] at the latest; the profiles read when each run first met the
//! convergence test from its trace, so how a solver decides to stop changes
//! its time but not its evaluations to a solution.

use std::sync::Arc;
use std::time::Instant;

use argmin::core::{CostFunction, Executor, Gradient, TerminationReason, TerminationStatus};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::neldermead::NelderMead;
use argmin::solver::quasinewton::LBFGS;
use ddp::{Ddp, DdpMethod, DdpSettings};
use trajopt::{
    DampingScale, DerivativeFree, DerivativeFreeSettings, GaussNewton, GaussNewtonSettings, Powell, PowellSettings,
    StepControl, StepModel,
};

use crate::error::{BenchError, Result};
use crate::instance::TRAJECTORY_SET;
pub use crate::instance::{cost_at, start_cost};
pub use crate::open::end_trace;
use crate::open::{BenchSolver, End, Measured, Outcome, Problem, Stop, measure, record};
use crate::problems::{Budget, Counted, Instance};
use crate::record::RunRecord;

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
    /// trajopt's Levenberg-Marquardt with a trust region in the
    /// parameters' units (`StepControl::TrustRegion`, `DampingScale::Identity`:
    /// Moré's step, as scipy's `trf` and `lm` with `x_scale=1`).
    TrustRegion,
    /// [`TrustRegion`](Self::TrustRegion) with geodesic acceleration.
    TrustRegionGeodesic,
    /// trajopt's Powell.
    Powell,
    /// trajopt's derivative-free least squares (Levenberg-Marquardt on a
    /// differenced Jacobian).
    DfoLs,
    /// argmin's Nelder-Mead.
    NelderMead,
    /// argmin's L-BFGS.
    Lbfgs,
    /// `ddp`'s iLQR on the DDP form.
    Ilqr,
    /// `ddp`'s full DDP on the DDP form.
    FullDdp,
}

impl Solver {
    /// Every solver, in the tables' order.
    pub const ALL: [Self; 11] = [
        Self::GaussNewton,
        Self::Newton,
        Self::Adaptive,
        Self::TrustRegion,
        Self::TrustRegionGeodesic,
        Self::Powell,
        Self::DfoLs,
        Self::NelderMead,
        Self::Lbfgs,
        Self::Ilqr,
        Self::FullDdp,
    ];

    /// The solver's name on the command line and in the records.
    pub fn name(self) -> &'static str {
        match self {
            Self::GaussNewton => "gauss-newton",
            Self::Newton => "newton",
            Self::Adaptive => "adaptive",
            Self::TrustRegion => "trust-region",
            Self::TrustRegionGeodesic => "trust-region-geodesic",
            Self::Powell => "powell",
            Self::DfoLs => "dfo-ls",
            Self::NelderMead => "argmin-nelder-mead",
            Self::Lbfgs => "argmin-lbfgs",
            Self::Ilqr => "ddp-ilqr",
            Self::FullDdp => "ddp-full",
        }
    }

    /// Whether it uses only $f$ (the data profiles' solvers).
    pub fn derivative_free(self) -> bool {
        matches!(self, Self::Powell | Self::DfoLs | Self::NelderMead)
    }

    /// Whether it runs on `instance`: the DDP solvers where it has a DDP
    /// form, Nelder-Mead and `trust-region-geodesic` off the trajectory
    /// set, the others everywhere.
    pub fn applies_to(self, instance: &Instance) -> bool {
        match self {
            Self::Ilqr | Self::FullDdp => instance.rollout.is_some(),
            // the trajectory set's Eq. 3 problems are solved on their band
            // form, which holds no Jacobian to accelerate with: the same
            // iterates as `trust-region`
            Self::NelderMead | Self::TrustRegionGeodesic => instance.set != TRAJECTORY_SET,
            _ => !instance.start.is_empty(),
        }
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

    /// The built-in solvers named in `list` (`all`, or names separated by
    /// commas), as the runner's solver entries.
    ///
    /// # Errors
    /// As [`parse_list`](Self::parse_list).
    pub fn parse_entries(list: &str) -> Result<Vec<Arc<dyn BenchSolver>>> {
        Ok(Self::parse_list(list)?
            .into_iter()
            .map(|s| Arc::new(s) as Arc<dyn BenchSolver>)
            .collect())
    }

    /// The error of a solver refusing its input.
    fn refused(self, instance: &Instance, reason: String) -> BenchError {
        BenchError::Solver {
            solver: self.name().into(),
            problem: instance.problem.clone(),
            reason,
        }
    }

    /// One timed DDP solve of the instance's DDP form.
    fn ddp_once(self, instance: &Instance) -> Result<(f64, Measured)> {
        let forms = instance
            .rollout
            .as_ref()
            .ok_or_else(|| self.refused(instance, "the instance has no DDP form".into()))?;
        let method = if self == Self::FullDdp {
            DdpMethod::Ddp
        } else {
            DdpMethod::Ilqr
        };
        let solver = Ddp::new(DdpSettings {
            max_iterations: 1000,
            method,
            ..DdpSettings::default()
        })
        .map_err(|e| self.refused(instance, e.to_string()))?;
        let start = Instant::now();
        let result = solver.solve(&forms.ddp);
        let time = start.elapsed().as_secs_f64();
        let n = instance.n() as u64;
        let measured = match result {
            Ok(r) => {
                let jac_evals = (1 + u64::from(r.method == DdpMethod::Ddp)) * r.jacobian_evals as u64;
                let f_evals = r.evals as u64;
                let stop = Stop::typed(&r.status);
                Measured {
                    status: stop.status,
                    converged: stop.converged,
                    termination: stop.termination,
                    counts: [f_evals, jac_evals, f_evals + n * jac_evals],
                    objective: r.cost,
                    end: End::Controls(r.controls),
                }
            }
            Err(e) => Measured {
                status: format!("error: {e}"),
                converged: false,
                termination: Some(solve::Termination::Failed),
                counts: [0; 3],
                objective: f64::INFINITY,
                end: End::Controls(forms.ddp.initial_controls().to_vec()),
            },
        };
        Ok((time, measured))
    }

    /// One solve; `Err` only for refused settings.
    fn solve_counted(self, counted: &Counted<'_>, instance: &Instance) -> Result<Outcome> {
        let refused = |e: String| self.refused(instance, e);
        let x0 = instance.start.as_slice();
        Ok(match self {
            Self::GaussNewton | Self::Newton | Self::Adaptive | Self::TrustRegion | Self::TrustRegionGeodesic => {
                let step_model = match self {
                    Self::Newton => StepModel::Newton,
                    Self::Adaptive => StepModel::Adaptive,
                    _ => StepModel::GaussNewton,
                };
                let mut settings = gauss_newton_settings(step_model);
                if matches!(self, Self::TrustRegion | Self::TrustRegionGeodesic) {
                    settings.step_control = StepControl::TrustRegion;
                    settings.geodesic_acceleration = self == Self::TrustRegionGeodesic;
                    // the region in the parameters' units, as scipy's trf and lm
                    settings.damping_scale = DampingScale::Identity;
                }
                let solver = GaussNewton::new(settings).map_err(|e| refused(e.to_string()))?;
                match solver.solve(counted, x0) {
                    Ok(r) => Outcome::typed(&r.status),
                    Err(e) => Outcome::Failed(e.to_string()),
                }
            }
            Self::Powell => {
                let solver = Powell::new(PowellSettings {
                    tol_cost: 1e-14,
                    tol_step: 1e-12,
                    max_iterations: Some(usize::MAX),
                    max_evals: Some(usize::MAX),
                    ..PowellSettings::default()
                })
                .map_err(|e| refused(e.to_string()))?;
                match solver.solve(&|x: &[f64]| counted.cost(x), x0) {
                    Ok(r) => Outcome::typed(&r.status),
                    Err(e) => Outcome::Failed(e.to_string()),
                }
            }
            Self::DfoLs => {
                let budget = usize::try_from(counted.max_evals()).unwrap_or(usize::MAX);
                let solver = DerivativeFree::new(DerivativeFreeSettings {
                    gauss_newton: gauss_newton_settings(StepModel::GaussNewton),
                    max_evals: Some(budget.max(1)),
                    ..DerivativeFreeSettings::default()
                })
                .map_err(|e| refused(e.to_string()))?;
                match solver.solve(counted, x0) {
                    Ok(r) => Outcome::typed(&r.status),
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
                from_argmin(run.map(|r| r.state.termination_status))
            }
            Self::Lbfgs => {
                let solver = LBFGS::new(MoreThuenteLineSearch::new(), 7)
                    .with_tolerance_grad(1e-12)
                    .and_then(|s| s.with_tolerance_cost(1e-16))
                    .map_err(|e| refused(e.to_string()))?;
                let run = Executor::new(ArgminView(counted), solver)
                    .configure(|s| s.param(x0.to_vec()).max_iters(u64::MAX))
                    .run();
                from_argmin(run.map(|r| r.state.termination_status))
            }
            Self::Ilqr | Self::FullDdp => return Err(refused("runs on the DDP form only".into())),
        })
    }
}

impl BenchSolver for Solver {
    fn name(&self) -> &str {
        Solver::name(*self)
    }

    fn applies_to(&self, instance: &Instance) -> bool {
        Solver::applies_to(*self, instance)
    }

    fn solve(&self, problem: &Problem<'_>) -> std::result::Result<Stop, String> {
        match self.solve_counted(problem.counted, problem.instance) {
            Ok(Outcome::Stopped {
                status,
                converged,
                termination,
            }) => Ok(Stop {
                status,
                converged,
                termination,
            }),
            Ok(Outcome::Failed(message)) => Err(message),
            Err(e) => Err(e.to_string()),
        }
    }

    /// The least-squares solvers on the counted problem; the DDP solvers
    /// on the instance's DDP form.
    fn run(&self, instance: &Instance, budget: &Budget, repeats: u32) -> Result<RunRecord> {
        let solver = *self;
        record(solver.name(), instance, repeats, || match solver {
            Self::Ilqr | Self::FullDdp => solver.ddp_once(instance),
            _ => measure(instance, budget, |counted| solver.solve_counted(counted, instance)),
        })
    }
}

/// The settings of `gauss-newton`, `newton`, `adaptive` (by `step_model`)
/// and of `dfo-ls`'s step: no iteration cap (the budget stops a run) and
/// MINPACK's scaling (the library default stalls on Penalty II).
fn gauss_newton_settings(step_model: StepModel) -> GaussNewtonSettings {
    GaussNewtonSettings {
        max_iterations: usize::MAX,
        step_model,
        damping_scale: DampingScale::RunningMax,
        ..GaussNewtonSettings::default()
    }
}

/// argmin's termination status, classified by its reason (not by its
/// text): converged only when the solver's own test passed.
fn from_argmin(run: std::result::Result<TerminationStatus, argmin::core::Error>) -> Outcome {
    match run {
        Ok(status) => {
            let converged = matches!(
                status,
                TerminationStatus::Terminated(TerminationReason::SolverConverged)
            );
            Outcome::Stopped {
                status: status.to_string(),
                converged,
                termination: Some(match status {
                    TerminationStatus::NotTerminated => solve::Termination::Stopped,
                    TerminationStatus::Terminated(reason) => match reason {
                        TerminationReason::SolverConverged => solve::Termination::Converged,
                        TerminationReason::MaxItersReached => solve::Termination::MaxIterations,
                        TerminationReason::TargetCostReached => solve::Termination::TargetReached,
                        TerminationReason::Timeout => solve::Termination::TimeLimit,
                        TerminationReason::Interrupt => solve::Termination::Stopped,
                        TerminationReason::SolverExit(_) => solve::Termination::Failed,
                    },
                }),
            }
        }
        Err(e) => Outcome::Failed(e.to_string()),
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
    use super::*;

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
        let (inst, budget) = crate::problems::tests::rosenbrock(5000);
        let inst = &inst;
        for solver in Solver::ALL.into_iter().filter(|s| s.applies_to(inst)) {
            let rec = solver.run(inst, &budget, 1).expect("runs");
            assert_eq!((rec.solver.as_str(), rec.n, rec.m), (solver.name(), 2, 2));
            assert!((rec.f0 - 24.2).abs() < 1e-12);
            assert!(rec.f < 1e-8, "{}: {rec:?}", solver.name());
            assert_eq!(rec.evals, rec.f_evals + 2 * rec.jac_evals);
            assert!(rec.trace.last().is_some_and(|p| p.1 == rec.f && p.0 <= rec.evals));
            assert_eq!(solver.derivative_free(), rec.jac_evals == 0, "{}", solver.name());
            // the status typed beside the solver's own word, which serde
            // writes as the variant's name (the records' text is unchanged)
            let termination = rec.termination.expect("typed");
            assert_eq!(rec.converged, termination.is_converged(), "{}: {rec:?}", solver.name());
            assert!(!rec.status.contains(['{', '(', '"']), "{}", rec.status);
        }
        let rec = Solver::GaussNewton.run(inst, &budget, 1).expect("runs");
        assert!(
            ["ConvergedGradient", "ConvergedStep", "ConvergedCost"].contains(&rec.status.as_str()),
            "{}",
            rec.status
        );
    }

    #[test]
    fn a_spent_budget_is_a_status_with_the_best_point() {
        let (inst, budget) = crate::problems::tests::rosenbrock(10);
        let inst = &inst;
        let rec = Solver::Powell.run(inst, &budget, 1).expect("runs");
        assert_eq!(rec.status, "budget");
        assert!(!rec.converged && rec.evals <= 30 && rec.f < rec.f0);
    }

    /// Every run stores its start and final point, and its f is f at that
    /// point; f0 is the start's own, even where it overflows (the old
    /// records took the first finite value a solver met instead).
    #[test]
    fn runs_store_their_points_and_the_start_cost() {
        let (inst, budget) = crate::problems::tests::rosenbrock(50);
        for solver in [
            Solver::GaussNewton,
            Solver::Powell,
            Solver::DfoLs,
            Solver::NelderMead,
            Solver::Lbfgs,
        ] {
            let rec = solver.run(&inst, &budget, 1).expect("runs");
            assert_eq!(rec.x0.as_deref(), Some(inst.start.as_slice()));
            let x = rec.x.as_deref().expect("x stored");
            assert_eq!(cost_at(&inst, x), Some(rec.f), "{}", solver.name());
        }
        let js = crate::problems::ProblemSet::Mgh
            .instances(Some("jennrich"))
            .expect("mgh")
            .into_iter()
            .find(|i| i.scale == 100.0)
            .expect("x100");
        assert_eq!(cost_at(&js, &js.start), Some(f64::INFINITY));
        for solver in [Solver::Powell, Solver::Lbfgs, Solver::GaussNewton] {
            let rec = solver.run(&js, &budget, 1).expect("runs");
            assert!(rec.f0.is_nan(), "{rec:?}");
        }
    }
}
