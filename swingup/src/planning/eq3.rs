//! Planning a swing-up with the paper's Eq. 3: the task cost, the bases
//! of the state and control trajectories (fitted to the demonstration,
//! Eqs. 6-7), and the solve by Gauss-Newton or Powell with a continuation in
//! $\lambda$.

use std::sync::Arc;

use faer::Mat;
use faer::sparse::SparseRowMat;
use splines::wavelet::{Boundary, Wavelet, WaveletBasis};
use splines::{BSplineBasis, FitSettings, TrajectoryBasis};
use trajopt::derivative_free::Differenced;
use trajopt::powell::{BandTerms, Powell, PowellSettings};
use trajopt::{
    DerivativeFree, DerivativeFreeSettings, Difference, Eq3Problem, GaussNewton, GaussNewtonSettings, Lambda,
    TrackingCost,
};

use crate::config::{BasisKind, Config, DifferenceKind, Differences, PlannerConfig, Solver, Start};
use crate::error::ResultExt;
use crate::planning::cost::SwingupCost;
use crate::planning::support::DataSupport;
use crate::plant::demo::Demonstration;
use crate::record::PlanStatus;
use crate::record::PlanSummary;

/// The planner's stage cost: Eq. 5 tracking of the demonstration (with
/// [`Start::Scratch`]: of upright at rest over the whole window, $u^d = 0$),
/// a terminal target upright at rest with the hand home, and the soft bounds
/// (shared by every planner, so that their costs compare), with the
/// planner's weights and bounds.
pub fn swingup_cost(planner: &PlannerConfig, start: Start, demo: &Demonstration) -> crate::Result<SwingupCost> {
    let n = demo.horizon();
    crate::error::ensure_data!(n >= 1, "the demonstration has no controls");
    crate::error::ensure_data!(
        demo.states.len() == n + 1,
        "the demonstration has {} states for {n} controls (need {})",
        demo.states.len(),
        n + 1
    );
    window_cost(planner, start, demo, 0, n)
}

/// The stage cost of a window of `samples` steps from step `from` of the
/// swing-up (receding-horizon planning): the references of
/// [`swingup_cost`] (as `start` chooses them) over those steps, upright
/// at rest with $u^d = 0$ from the end of the demonstration on; the
/// terminal target is the reference at the window's end.
pub fn window_cost(
    p: &PlannerConfig,
    start: Start,
    demo: &Demonstration,
    from: usize,
    samples: usize,
) -> crate::Result<SwingupCost> {
    let n = demo.horizon();
    let upright = [std::f64::consts::PI, 0.0, 0.0, 0.0];
    let tracked = start == Start::Demonstration;
    // the demonstration's last state is replaced by upright at rest
    let state_ref = Mat::from_fn(samples + 1, 4, |k, i| match from + k {
        j if tracked && j < n => demo.states[j][i],
        _ => upright[i],
    });
    let control_ref = Mat::from_fn(samples, 1, |k, _| match from + k {
        j if tracked && j < n => demo.controls[j],
        _ => 0.0,
    });
    let tracking = TrackingCost::new(
        state_ref,
        control_ref,
        &p.state_weights,
        &[p.control_weight],
        &p.terminal_weights,
    )?;
    SwingupCost::new(tracking, p.x_max, p.u_max, p.bound_weight)
}

/// The bases of the state and control trajectories over the
/// demonstration's window.
fn bases(planner: &PlannerConfig, demo: &Demonstration) -> crate::Result<(PlanBasis, PlanBasis)> {
    let n = demo.horizon();
    let t_end = demo.dt * n as f64;
    Ok(match planner.basis {
        BasisKind::Bspline => (
            PlanBasis::Bspline(BSplineBasis::clamped_uniform(planner.state_coeffs, 3, 0.0, t_end)?),
            PlanBasis::Bspline(BSplineBasis::clamped_uniform(planner.control_coeffs, 3, 0.0, t_end)?),
        ),
        BasisKind::Wavelet => {
            let w = |samples| WaveletBasis::new(Wavelet::Db4, Boundary::Periodization, samples, None, 0.0, demo.dt);
            (
                PlanBasis::Wavelet(Box::new(w(n + 1)?)),
                PlanBasis::Wavelet(Box::new(w(n)?)),
            )
        }
    })
}

/// One of the planner's bases.
#[derive(Debug, Clone)]
enum PlanBasis {
    Bspline(BSplineBasis),
    Wavelet(Box<WaveletBasis>),
}

impl TrajectoryBasis for PlanBasis {
    fn n_coeffs(&self) -> usize {
        match self {
            Self::Bspline(b) => b.n_coeffs(),
            Self::Wavelet(b) => b.n_coeffs(),
        }
    }

    fn domain(&self) -> (f64, f64) {
        match self {
            Self::Bspline(b) => b.domain(),
            Self::Wavelet(b) => b.domain(),
        }
    }

    fn max_nonzeros(&self) -> usize {
        match self {
            Self::Bspline(b) => b.max_nonzeros(),
            Self::Wavelet(b) => b.max_nonzeros(),
        }
    }

    fn basis_row(&self, t: f64, order: usize, row: &mut Vec<(usize, f64)>) -> splines::Result<()> {
        match self {
            Self::Bspline(b) => b.basis_row(t, order, row),
            Self::Wavelet(b) => b.basis_row(t, order, row),
        }
    }

    fn design_matrix_rows(&self, times: &[f64], order: usize) -> splines::Result<SparseRowMat<usize, f64>> {
        match self {
            Self::Bspline(b) => b.design_matrix_rows(times, order),
            Self::Wavelet(b) => b.design_matrix_rows(times, order),
        }
    }
}

/// The Eq. 3 problem of planning a swing-up with `model`, and its starting
/// point: the demonstration fitted by the bases (Eqs. 6-7).
pub fn build_problem<M: trajopt::Dynamics>(
    cfg: &Config,
    demo: &Demonstration,
    model: M,
    support: Option<Arc<DataSupport>>,
) -> crate::Result<(Eq3Problem<M, SwingupCost>, Vec<f64>)> {
    let p = &cfg.planner;
    let cost = swingup_cost(&cfg.planner, cfg.start, demo)?.with_support(support);
    let (state_basis, control_basis) = bases(&cfg.planner, demo)?;
    let problem = Eq3Problem::new(
        model,
        cost,
        &state_basis,
        &control_basis,
        &demo.times(),
        Lambda::Constant(p.lambda),
    )?
    .with_consistency_scale(1.0 / demo.dt)?
    .with_initial_state(&[0.0; 4], p.initial_state_weight)?;
    // Eqs. 6-7: the knot points fitted to the demonstration
    let theta0 = fit_coefficients(cfg, demo, &problem, &demo.states, &demo.controls)?;
    Ok((problem, theta0))
}

/// The coefficients of `problem` that best fit (least squares) a trajectory
/// of `horizon + 1` states and `horizon` controls at the sample times.
pub fn fit_coefficients<M: trajopt::Dynamics>(
    cfg: &Config,
    demo: &Demonstration,
    problem: &Eq3Problem<M, SwingupCost>,
    states: &[[f64; 4]],
    controls: &[f64],
) -> crate::Result<Vec<f64>> {
    let n = demo.horizon();
    crate::error::ensure_data!(
        states.len() == n + 1 && controls.len() == n,
        "a trajectory of {} states and {} controls does not fit a horizon of {n}",
        states.len(),
        controls.len()
    );
    let times = demo.times();
    let (state_basis, control_basis) = bases(&cfg.planner, demo)?;
    let xs = Mat::from_fn(n + 1, 4, |k, i| states[k][i]);
    let us = Mat::from_fn(n, 1, |k, _| controls[k]);
    // periodised wavelets on an odd number of samples have more coefficients
    // than samples: a tiny ridge picks the smallest fit
    let fit = FitSettings {
        ridge: if cfg.planner.basis == BasisKind::Wavelet {
            1e-10
        } else {
            0.0
        },
        ..FitSettings::default()
    };
    let cx = splines::fit_matrix(&state_basis, &times, xs.as_ref(), &fit)?;
    let cu = splines::fit_matrix(&control_basis, &times[..n], us.as_ref(), &fit)?;
    Ok(problem.pack(&cx, &cu)?)
}

/// Plans a swing-up with Eq. 3 and `model` by Gauss-Newton, Powell or the
/// derivative-free least-squares mode (as
/// [`PlannerConfig::solver`](crate::config::PlannerConfig::solver) says; DDP is [`crate::planning::ddp::plan_ddp`]),
/// starting from the demonstration fitted by the bases (Eqs. 6-7), with a
/// continuation in $\lambda$ ([`PlannerConfig::lambda_start`](crate::config::PlannerConfig::lambda_start)).
pub fn plan<M: trajopt::Dynamics>(
    cfg: &Config,
    demo: &Demonstration,
    model: M,
    support: Option<Arc<DataSupport>>,
) -> crate::Result<PlanSummary> {
    plan_from(cfg, demo, model, support, None)
}

/// [`plan`], warm-started from `start` when given: the plan starts from
/// `start`'s trajectory fitted by the bases and is solved at the final
/// $\lambda$ directly, without the continuation (see
/// [`PlannerConfig::warm_start`](crate::config::PlannerConfig::warm_start)).
/// `start` must span the demonstration's horizon.
pub fn plan_from<M: trajopt::Dynamics>(
    cfg: &Config,
    demo: &Demonstration,
    model: M,
    support: Option<Arc<DataSupport>>,
    start: Option<&PlanSummary>,
) -> crate::Result<PlanSummary> {
    let solver = cfg.planner.solver;
    let reference = if cfg.planner.compare_gauss_newton && matches!(solver, Solver::Powell | Solver::DerivativeFree) {
        Some(solve(cfg, demo, &model, support.clone(), start, Method::GaussNewton)?.cost)
    } else {
        None
    };
    let mut plan = match (solver, cfg.planner.differences) {
        (Solver::Powell, _) => solve(cfg, demo, model, support, start, Method::Powell)?,
        (Solver::DerivativeFree, Differences::Groups) => solve(cfg, demo, model, support, start, Method::Groups)?,
        (Solver::DerivativeFree, Differences::Elements) => {
            // Gauss-Newton on the model's values alone: its Jacobians by
            // forward differences of each step's inputs, in one batch
            let model = Differenced::new(model, difference_of(&cfg.planner), None)?;
            let mut plan = solve(cfg, demo, &model, support, start, Method::GaussNewton)?;
            // in criterion evaluations: one model evaluation at every step is one
            plan.evaluations += model.difference_evals().div_ceil(demo.horizon().max(1));
            plan.planner = "derivative-free".into();
            plan
        }
        _ => solve(cfg, demo, model, support, start, Method::GaussNewton)?,
    };
    plan.gauss_newton_cost = reference;
    Ok(plan)
}

/// The per-point consistency weight of
/// [`PlannerConfig::confidence_floor`](crate::config::PlannerConfig::confidence_floor)
/// along `states` and `controls`: $\lambda_k = \lambda \max(\epsilon,
/// \min(1, n_k / n_{full}))$, with $n_k$ the model's support at step $k$
/// ($\lambda$ where the model has none).
pub fn confidence_lambda<M: trajopt::Dynamics>(
    p: &crate::config::PlannerConfig,
    model: &M,
    states: &Mat<f64>,
    controls: &Mat<f64>,
    lambda: f64,
) -> Lambda {
    let full = p.confidence_full;
    let floor = p.confidence_floor.min(1.0);
    Lambda::from_confidence(model, states, controls, lambda, |n| {
        lambda * (n / full).clamp(floor, 1.0)
    })
}

/// The derivative-free planner's kind of differences.
fn difference_of(planner: &PlannerConfig) -> Difference {
    match planner.difference_kind {
        DifferenceKind::Forward => Difference::Forward,
        DifferenceKind::Central => Difference::Central,
    }
}

/// How [`solve`] minimises Eq. 3.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Method {
    GaussNewton,
    Powell,
    /// Levenberg-Marquardt on a Jacobian by grouped differences of the residuals.
    Groups,
}

/// [`plan_from`] with `method`.
fn solve<M: trajopt::Dynamics>(
    cfg: &Config,
    demo: &Demonstration,
    model: M,
    support: Option<Arc<DataSupport>>,
    start: Option<&PlanSummary>,
    method: Method,
) -> crate::Result<PlanSummary> {
    let p = &cfg.planner;
    let (mut problem, theta0) = build_problem(cfg, demo, model, support)?;
    let theta0 = match start {
        Some(s) => fit_coefficients(cfg, demo, &problem, &s.states, &s.controls)
            .context("warm-starting from the previous plan")?,
        None => theta0,
    };
    let gauss_newton = GaussNewtonSettings {
        max_iterations: p.max_iters,
        tol_cost: p.tol_cost,
        ..GaussNewtonSettings::default()
    };
    let solver = GaussNewton::new(gauss_newton.clone())?;
    let derivative_free = DerivativeFree::new(DerivativeFreeSettings {
        gauss_newton,
        difference: difference_of(&cfg.planner),
        ..DerivativeFreeSettings::default()
    })?;
    let powell = Powell::new(PowellSettings {
        max_evals: Some(p.powell_evals),
        principal_axes: p.powell_principal_axes,
        ..PowellSettings::default()
    })?;
    let mut lambda = if start.is_none() && p.lambda_start > 0.0 && p.lambda_start < p.lambda {
        p.lambda_start
    } else {
        p.lambda
    };
    // the criterion at the start, with the final lambda
    let initial_cost = problem.cost(&theta0)?;
    let mut theta = theta0;
    let (mut iterations, mut evaluations, mut seconds) = (0, 0, 0.0);
    let (status, cost) = loop {
        let weights = if p.confidence_floor > 0.0 {
            let (xs, us) = problem.trajectory(&theta)?;
            confidence_lambda(p, problem.model(), &xs, &us, lambda)
        } else {
            Lambda::Constant(lambda)
        };
        problem.set_lambda(weights)?;
        // (status, cost, x, iterations, evaluations, time) in the solvers' shared vocabulary
        macro_rules! parts {
            ($result:expr) => {{
                let r = $result;
                (
                    PlanStatus::from(r.status),
                    r.cost,
                    r.x,
                    r.iterations,
                    r.evals,
                    r.solve_time,
                )
            }};
        }
        let (status, cost, x, iters, evals, time) = if method == Method::Powell {
            // Eq. 3 as a sum of one term per time step: a trial point
            // re-evaluates only the steps its changed coefficients touch
            // (the budget still counts every evaluation, partial or not)
            let terms = BandTerms::new(&problem, problem.horizon() + 1, &theta)?;
            parts!(powell.solve_separable(&terms, &theta)?)
        } else if method == Method::Groups {
            parts!(derivative_free.solve(&problem, &theta)?)
        } else {
            parts!(solver.solve(&problem, &theta)?)
        };
        iterations += iters;
        evaluations += evals;
        seconds += time.as_secs_f64();
        theta = x;
        if lambda >= p.lambda {
            break (status, cost);
        }
        lambda = (lambda * 10.0).min(p.lambda);
    };
    let parts = problem.cost_breakdown(&theta)?;
    let (xs, us) = problem.trajectory(&theta)?;
    Ok(PlanSummary {
        planner: match method {
            Method::Powell => "powell",
            Method::Groups => "derivative-free",
            Method::GaussNewton => "gauss-newton",
        }
        .into(),
        status,
        cost,
        initial_cost,
        task: parts.task,
        inconsistency: parts.inconsistency,
        max_mismatch: parts.max_mismatch,
        iterations,
        evaluations,
        seconds,
        states: (0..xs.nrows()).map(|k| std::array::from_fn(|i| xs[(k, i)])).collect(),
        controls: (0..us.nrows()).map(|k| us[(k, 0)]).collect(),
        gauss_newton_cost: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use trajopt::{GaussNewtonStatus, StageCost};

    use crate::models::KnownHand;
    use crate::models::truth::TrueRegression;

    fn demo(cfg: &Config) -> Demonstration {
        crate::plant::demo::demonstration(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance)
            .expect("demonstration")
    }

    /// The defaults changed by `change`, their demonstration, and the
    /// robot's true dynamics as the planner's model.
    fn setup(change: impl FnOnce(&mut Config)) -> (Config, Demonstration, KnownHand<TrueRegression>) {
        let mut cfg = Config::default();
        change(&mut cfg);
        let d = demo(&cfg);
        let model = KnownHand::new(TrueRegression::robot(), cfg.robot.dt);
        (cfg, d, model)
    }

    /// From scratch the task cost's tracking part is zero upright at rest
    /// with no command, at every step; with the demonstration it is zero
    /// on the demonstration (but its last state, where the target is
    /// upright) and not upright.
    #[test]
    fn scratch_cost_tracks_upright() {
        let cfg = Config {
            start: Start::Scratch,
            ..Config::default()
        };
        let d = demo(&cfg);
        let up = [std::f64::consts::PI, 0.0, 0.0, 0.0];
        let mut r = vec![0.0; 7];
        let scratch = swingup_cost(&cfg.planner, cfg.start, &d).expect("cost");
        for k in [0, 40, d.horizon() - 1] {
            scratch.residuals(k, &up, Some(&[0.0]), &mut r).expect("residuals");
            assert!(r.iter().all(|v| v.abs() < 1e-12), "step {k}: {r:?}");
        }
        let with_demo = swingup_cost(&Config::default().planner, Config::default().start, &d).expect("cost");
        let k = 40;
        with_demo
            .residuals(k, &d.states[k], Some(&[d.controls[k]]), &mut r)
            .expect("residuals");
        assert!(r.iter().all(|v| v.abs() < 1e-12), "{r:?}");
        with_demo.residuals(k, &up, Some(&[0.0]), &mut r).expect("residuals");
        assert!(r.iter().any(|v| v.abs() > 1e-3), "upright is not the demonstration");
    }

    /// `planner.tol_cost` reaches the solver: a loose tolerance ends every
    /// stage by `ConvergedCost` in fewer iterations than the tight one, at a
    /// criterion close to the tight one's.
    #[test]
    fn plans_stop_at_the_configured_cost_tolerance() {
        let (cfg, d, model) = setup(|c| c.planner.lambda_start = c.planner.lambda);
        let plan_at = |tol: f64| {
            let mut c = cfg.clone();
            c.planner.tol_cost = tol;
            plan(&c, &d, &model, None).expect("plan")
        };
        let (tight, loose) = (plan_at(1e-14), plan_at(1e-3));
        assert_eq!(loose.status, GaussNewtonStatus::ConvergedCost.into());
        assert!(
            loose.iterations < tight.iterations,
            "{} iterations at 1e-3, {} at 1e-14",
            loose.iterations,
            tight.iterations
        );
        assert!(loose.cost <= tight.cost * 1.05, "{} against {}", loose.cost, tight.cost);
    }

    /// Both derivative-free planners reach Gauss-Newton's plan on the same
    /// problem (the robot's true dynamics, the continuation in lambda): a
    /// converged status and a criterion within 1e-3 relative, with the
    /// evaluations of their differences counted.
    #[test]
    fn derivative_free_plans_reach_gauss_newtons() {
        let (cfg, d, model) = setup(|c| c.planner.tol_cost = 1e-10);
        let reference = plan(&cfg, &d, &model, None).expect("plan");
        for differences in [Differences::Elements, Differences::Groups] {
            let mut c = cfg.clone();
            c.planner.solver = Solver::DerivativeFree;
            c.planner.differences = differences;
            let p = plan(&c, &d, &model, None).expect("plan");
            assert_eq!(p.planner, "derivative-free");
            assert!(p.status.is_converged(), "{differences:?}: {}", p.status);
            assert!(
                (p.cost - reference.cost).abs() <= 1e-3 * reference.cost,
                "{differences:?}: {} against {}",
                p.cost,
                reference.cost
            );
            // each iteration pays for a differenced Jacobian
            assert!(
                p.evaluations > p.iterations * 5,
                "{differences:?}: {} evaluations",
                p.evaluations
            );
        }
    }

    /// Powell's planner evaluates Eq. 3 term by term (only the time steps a
    /// trial point changes): the criterion it reports is the criterion of
    /// the plan it returns, evaluated whole, and within a budget far below
    /// what it needs it says so (`MaxEvaluations`), having only descended.
    #[test]
    fn powell_plans_report_their_own_criterion() {
        let (cfg, d, model) = setup(|c| {
            c.planner.solver = Solver::Powell;
            c.planner.lambda_start = 0.0;
            c.planner.powell_evals = 3000;
        });
        let p = plan(&cfg, &d, &model, None).expect("plan");
        assert_eq!(p.planner, "powell");
        assert_eq!(p.status, trajopt::PowellStatus::MaxEvaluations.into());
        assert_eq!(p.evaluations, 3000);
        assert!(p.cost < p.initial_cost, "{} from {}", p.cost, p.initial_cost);
        // the bases reproduce their own samples: refit the plan and evaluate it whole
        let (problem, _) = build_problem(&cfg, &d, &model, None).expect("problem");
        let theta = fit_coefficients(&cfg, &d, &problem, &p.states, &p.controls).expect("refit");
        let whole = problem.cost(&theta).expect("cost");
        assert!((whole - p.cost).abs() <= 1e-9 * p.cost, "{whole} against {}", p.cost);
    }

    /// A warm start from a plan starts exactly there (the bases reproduce
    /// their own samples), skips the continuation and never ends above it;
    /// `plan_with` uses the previous plan only with `warm_start` on and a
    /// plan over the same horizon, and otherwise plans from the
    /// demonstration bit for bit as without one.
    #[test]
    fn warm_start_begins_at_the_previous_plan() {
        let (cfg, d, model) = setup(|c| c.planner.tol_cost = 1e-10);
        let cold = plan(&cfg, &d, &model, None).expect("plan");
        let warm = plan_from(&cfg, &d, &model, None, Some(&cold)).expect("warm plan");
        let rel = (warm.initial_cost - cold.cost).abs() / cold.cost;
        assert!(
            rel < 1e-9,
            "warm start at {} against the plan's {}",
            warm.initial_cost,
            cold.cost
        );
        assert!(
            warm.cost <= warm.initial_cost,
            "{} above {}",
            warm.cost,
            warm.initial_cost
        );
        assert!(
            warm.iterations * 4 < cold.iterations,
            "{} against {}",
            warm.iterations,
            cold.iterations
        );

        let with = |on: bool, previous: Option<&PlanSummary>| {
            let mut c = cfg.clone();
            c.planner.warm_start = on;
            crate::planning::plan_with(&c, &d, &model, None, previous).expect("plan")
        };
        let mut short = cold.clone();
        short.controls.pop();
        for ignored in [with(false, Some(&cold)), with(true, None), with(true, Some(&short))] {
            assert_eq!(ignored.controls, cold.controls);
            assert_eq!(ignored.iterations, cold.iterations);
        }
        assert_eq!(with(true, Some(&cold)).iterations, warm.iterations);
    }
}
