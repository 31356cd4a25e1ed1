//! One model contract: a model and a stage cost written once, by a user,
//! against `systems::Dynamics` and `systems::StageCost`, planned by every
//! solver of the workspace: Gauss-Newton, the derivative-free mode and
//! Powell on Eq. 3 (`trajopt`), iLQR and full DDP (`ddp`).

use std::f64::consts::PI;
use std::time::Duration;

use ddp::{Ddp, DdpMethod, DdpProblem, DdpSettings, ResidualCost};
use solve::{Outcome, Status, Termination};
use splines::BSplineBasis;
use systems::{Dynamics, ModelResult, StageCost};
use trajopt::{
    DerivativeFree, DerivativeFreeSettings, Eq3Problem, GaussNewton, GaussNewtonSettings, Lambda, LeastSquaresProblem,
    Powell, PowellSettings,
};

const DT: f64 = 0.1;
const HORIZON: usize = 12;
const TARGET: f64 = 1.2;

/// A user's own model: a damped torque pendulum,
/// $\dot\omega = u - b\omega - a \sin\theta$, semi-implicit Euler, with its
/// Jacobians and its weighted second derivative (only $\partial^2 / \partial\theta^2$
/// is nonzero).
struct UserPendulum {
    a: f64,
    b: f64,
}

impl Dynamics for UserPendulum {
    fn state_dim(&self) -> usize {
        2
    }
    fn control_dim(&self) -> usize {
        1
    }
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        next[1] = x[1] + DT * (u[0] - self.b * x[1] - self.a * x[0].sin());
        next[0] = x[0] + DT * next[1];
        Ok(())
    }
    fn jacobians(&self, x: &[f64], _u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        let (dw_dth, dw_dw) = (-DT * self.a * x[0].cos(), 1.0 - DT * self.b);
        fx.copy_from_slice(&[1.0 + DT * dw_dth, DT * dw_dw, dw_dth, dw_dw]);
        fu.copy_from_slice(&[DT * DT, DT]);
        Ok(true)
    }
    fn weighted_hessian(&self, x: &[f64], _u: &[f64], w: &[f64], hess: &mut [f64]) -> ModelResult<bool> {
        hess.fill(0.0);
        hess[0] = (w[0] * DT * DT + w[1] * DT) * self.a * x[0].sin();
        Ok(true)
    }
}

/// A user's own task: reach $\theta = 1.2$ at rest, cheaply.
struct Reach;

impl StageCost for Reach {
    fn n_residuals(&self) -> usize {
        3
    }
    fn residuals(&self, _k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
        let w = if u.is_some() { 1.0 } else { 10.0 };
        r[0] = w * (x[0] - TARGET);
        r[1] = 0.3 * w * x[1];
        r[2] = u.map_or(0.0, |u| 0.2 * u[0]);
        Ok(())
    }
    fn jacobians(&self, _k: usize, _x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> ModelResult<()> {
        let w = if u.is_some() { 1.0 } else { 10.0 };
        jx.copy_from_slice(&[w, 0.0, 0.0, 0.3 * w, 0.0, 0.0]);
        if u.is_some() {
            ju.copy_from_slice(&[0.0, 0.0, 0.2]);
        }
        Ok(())
    }
}

fn eq3(model: &UserPendulum, lambda: f64) -> (Eq3Problem<&UserPendulum, Reach>, Vec<f64>) {
    let times: Vec<f64> = (0..=HORIZON).map(|k| k as f64 * DT).collect();
    let end = times[HORIZON];
    let state_basis = BSplineBasis::clamped_uniform(HORIZON + 1, 3, 0.0, end).expect("state basis");
    let control_basis = BSplineBasis::clamped_uniform(HORIZON, 3, 0.0, end).expect("control basis");
    let problem = Eq3Problem::new(
        model,
        Reach,
        &state_basis,
        &control_basis,
        &times,
        Lambda::Constant(lambda),
    )
    .expect("problem")
    .with_initial_state(&[0.0, 0.0], 1e4)
    .expect("initial state");
    let theta0 = vec![0.0; problem.n_params()];
    (problem, theta0)
}

/// The cost of `controls` replayed through the model from rest, as DDP
/// counts it.
fn rollout_cost(model: &UserPendulum, controls: &[f64]) -> f64 {
    let mut x = vec![0.0, 0.0];
    let mut next = vec![0.0; 2];
    let mut r = vec![0.0; 3];
    let mut total = 0.0;
    for (k, &u) in controls.iter().enumerate() {
        Reach.residuals(k, &x, Some(&[u]), &mut r).expect("residuals");
        total += r.iter().map(|v| v * v).sum::<f64>();
        model.step(&x, &[u], &mut next).expect("step");
        x.copy_from_slice(&next);
    }
    Reach.residuals(controls.len(), &x, None, &mut r).expect("residuals");
    total + r.iter().map(|v| v * v).sum::<f64>()
}

#[test]
fn one_user_model_is_planned_by_every_solver() {
    let model = UserPendulum { a: 9.81 / 0.5, b: 0.1 };
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-12);

    // Eq. 3: the same problem for the three trajopt solvers
    let (problem, theta0) = eq3(&model, 1e3);
    let gn = GaussNewton::new(GaussNewtonSettings::default())
        .expect("settings")
        .solve(&problem, &theta0)
        .expect("gauss-newton");
    assert!(gn.status.termination().is_converged(), "{:?}", gn.status);
    assert!(gn.cost < 0.5 * gn.initial_cost, "{} vs {}", gn.cost, gn.initial_cost);

    let df = DerivativeFree::new(DerivativeFreeSettings::default())
        .expect("settings")
        .solve(&problem, &theta0)
        .expect("derivative-free");
    assert!(df.status.termination().is_converged(), "{:?}", df.status);
    assert!(rel(df.cost, gn.cost) < 1e-6, "{} vs {}", df.cost, gn.cost);

    let powell = Powell::new(PowellSettings {
        max_evals: Some(400_000),
        max_iterations: Some(100_000),
        ..PowellSettings::default()
    })
    .expect("settings")
    .solve(&problem, &theta0)
    .expect("powell");
    assert!(powell.status.termination().is_converged(), "{:?}", powell.status);
    assert!(rel(powell.cost, gn.cost) < 1e-4, "{} vs {}", powell.cost, gn.cost);

    // DDP: the same model value and the same stage cost
    let ddp_problem =
        DdpProblem::new(&model, ResidualCost::new(Reach, 2, 1, HORIZON), &[0.0, 0.0], HORIZON).expect("ddp problem");
    let solve = |method| {
        Ddp::new(DdpSettings {
            method,
            ..DdpSettings::default()
        })
        .expect("settings")
        .solve(&ddp_problem)
        .expect("ddp")
    };
    let (ilqr, full) = (solve(DdpMethod::Ilqr), solve(DdpMethod::Ddp));
    assert!(ilqr.status.termination().is_converged(), "{:?}", ilqr.status);
    assert!(full.status.termination().is_converged(), "{:?}", full.status);
    // full DDP ran: the model's weighted Hessian reached the backward pass
    assert_eq!((ilqr.method, full.method), (DdpMethod::Ilqr, DdpMethod::Ddp));
    assert!(rel(full.cost, ilqr.cost) < 1e-6, "{} vs {}", full.cost, ilqr.cost);
    let controls: Vec<f64> = ilqr.controls.iter().map(|u| u[0]).collect();
    assert!(rel(rollout_cost(&model, &controls), ilqr.cost) < 1e-12);
    // the plan goes to the target: from hanging still (the zero warm start)
    // to past half the target angle, at a fraction of the cost
    let end = ilqr.states[HORIZON][0];
    assert!(end > 0.5 * TARGET && end < PI, "{end}");
    assert!(
        ilqr.cost < 0.5 * ilqr.initial_cost,
        "{} vs {}",
        ilqr.cost,
        ilqr.initial_cost
    );

    // Eq. 3's controls (a spline of HORIZON coefficients) replayed through
    // the model cost at least DDP's optimum over free per-step controls,
    // and with a stiff model term (and a state coefficient per step) within 1 %
    let (stiff, _) = eq3(&model, 1e6);
    let gn_stiff = GaussNewton::new(GaussNewtonSettings::default())
        .expect("settings")
        .solve(&stiff, &gn.x)
        .expect("gauss-newton");
    let (_, eq3_controls) = stiff.trajectory(&gn_stiff.x).expect("trajectory");
    let replayed: Vec<f64> = (0..HORIZON).map(|k| eq3_controls[(k, 0)]).collect();
    let replay_cost = rollout_cost(&model, &replayed);
    assert!(
        replay_cost >= ilqr.cost * (1.0 - 1e-9),
        "{replay_cost} vs {}",
        ilqr.cost
    );
    assert!(replay_cost <= 1.01 * ilqr.cost, "{replay_cost} vs {}", ilqr.cost);

    // one result shape: every solver's result read through the same fields
    let summaries = [
        ("gauss-newton", gn.summary()),
        ("derivative-free", df.summary()),
        ("powell", powell.summary()),
        ("ilqr", ilqr.summary()),
        ("ddp", full.summary()),
    ];
    for (name, s) in &summaries {
        assert_eq!(s.termination, Termination::Converged, "{name}");
        assert!(s.cost < 0.5 * s.initial_cost, "{name}: {s:?}");
        assert!(s.iterations >= 1 && s.evals > s.iterations / 2, "{name}: {s:?}");
        assert!(s.solve_time.is_some_and(|t| t > Duration::ZERO), "{name}: {s:?}");
    }
    // the same problem, the same start: the three Eq. 3 solvers start from one cost
    let eq3_starts: Vec<f64> = summaries[..3].iter().map(|(_, s)| s.initial_cost).collect();
    assert!(eq3_starts.iter().all(|&c| c == eq3_starts[0]), "{eq3_starts:?}");
    assert_eq!(summaries[2].1.evals, powell.evals);
}

/// Every solver is an argmin `Solver` too: under argmin's `Executor`
/// (`solve::argmin::Stepper` running the solvers' `start` states, and
/// `PowellArgmin` for Powell) each reaches its own loop's point with its
/// own status, argmin's state holds its best cost, argmin's `max_iters` is
/// a stop from outside, and the stepper's time limit holds inside DDP.
#[test]
fn every_solver_runs_under_argmins_executor() {
    use argmin::core::{Executor, State, TerminationReason};
    use ddp::DdpStatus;
    use lwr::{LwrModel, LwrSettings, TuneSettings};
    use solve::argmin::{Stepper, finish};
    use trajopt::GaussNewtonStatus;
    use trajopt::powell::PowellArgmin;

    let model = UserPendulum { a: 9.81 / 0.5, b: 0.1 };
    let converged = Some(&TerminationReason::SolverConverged);

    // Gauss-Newton on Eq. 3
    let (problem, theta0) = eq3(&model, 1e3);
    let gn = GaussNewton::new(GaussNewtonSettings::default()).expect("settings");
    let own = gn.solve(&problem, &theta0).expect("gauss-newton");
    let start = gn.start(&problem, &theta0).expect("start");
    let run = Executor::new(start, Stepper::new()).run().expect("argmin");
    assert_eq!(run.state.get_termination_reason(), converged);
    assert_eq!(run.state.get_best_cost(), own.cost);
    let r = finish(run).expect("finish");
    assert_eq!((&r.x, r.status, r.iterations), (&own.x, own.status, own.iterations));
    let start = gn.start(&problem, &theta0).expect("start");
    let run = Executor::new(start, Stepper::new())
        .configure(|s| s.max_iters(2))
        .run()
        .expect("argmin");
    let r = finish(run).expect("finish");
    assert_eq!((r.status, r.iterations), (GaussNewtonStatus::Stopped, 2));
    assert!(r.cost < r.initial_cost && r.cost > own.cost);

    // the derivative-free mode, on its differenced problem; and with a
    // budget that runs out, a status with the best point evaluated
    for max_evals in [None, Some(40)] {
        let df = DerivativeFree::new(DerivativeFreeSettings {
            max_evals,
            ..DerivativeFreeSettings::default()
        })
        .expect("settings");
        let own = df.solve(&problem, &theta0).expect("derivative-free");
        let differences = df.differences(&problem).expect("differences");
        let start = df.start(&differences, &theta0).expect("start");
        let run = Executor::new(start, Stepper::new()).run().expect("argmin");
        let r = finish(run).expect("finish").expect("stationarity");
        assert_eq!((&r.x, r.status, r.evals), (&own.x, own.status, own.evals));
        let budget = max_evals.is_some();
        assert_eq!(r.status == GaussNewtonStatus::MaxEvaluations, budget, "{:?}", r.status);
        assert_eq!(r.status.is_converged(), !budget, "{:?}", r.status);
    }

    // Powell on the same problem, through its cost
    let settings = PowellSettings {
        max_evals: Some(400_000),
        max_iterations: Some(100_000),
        ..PowellSettings::default()
    };
    let own = Powell::new(settings.clone())
        .expect("settings")
        .solve(&problem, &theta0)
        .expect("powell");
    let run = Executor::new(problem, PowellArgmin::new(settings).expect("settings"))
        .configure(|s| s.param(theta0.clone()).max_iters(100_000))
        .run()
        .expect("argmin");
    assert_eq!(run.state.get_termination_reason(), converged);
    assert_eq!(run.state.get_best_cost(), own.cost);

    // DDP on the same model and stage cost
    let ddp_problem =
        DdpProblem::new(&model, ResidualCost::new(Reach, 2, 1, HORIZON), &[0.0, 0.0], HORIZON).expect("ddp problem");
    let ddp = Ddp::new(DdpSettings::default()).expect("settings");
    let own = ddp.solve(&ddp_problem).expect("ddp");
    let run = Executor::new(ddp.start(&ddp_problem).expect("start"), Stepper::new())
        .run()
        .expect("argmin");
    assert_eq!(run.state.get_termination_reason(), converged);
    let r = finish(run).expect("finish");
    assert_eq!((&r.controls, r.status, r.cost), (&own.controls, own.status, own.cost));
    assert_eq!(r.gains.len(), HORIZON);
    // a limit already passed: one iteration, then the policy at its trajectory
    let stepper = Stepper::new().with_time_limit(Duration::ZERO);
    let run = Executor::new(ddp.start(&ddp_problem).expect("start"), stepper)
        .run()
        .expect("argmin");
    assert_eq!(run.state.get_termination_reason(), Some(&TerminationReason::Timeout));
    let r = finish(run).expect("finish");
    assert_eq!((r.status, r.gains.len()), (DdpStatus::TimeLimit, HORIZON));

    // the LWR's metric search, on the model's own transitions
    let mut learned = LwrModel::new(
        3,
        1,
        LwrSettings {
            bandwidth: 0.5,
            ..LwrSettings::default()
        },
    )
    .expect("model");
    let mut next = [0.0; 2];
    for i in 0..150 {
        let x = [
            (i as f64 * 0.618).fract() * 4.0 - 2.0,
            (i as f64 * 0.377).fract() * 6.0 - 3.0,
        ];
        let u = [(i as f64 * 0.271).fract() * 4.0 - 2.0];
        model.step(&x, &u, &mut next).expect("step");
        learned.insert(&[x[0], x[1], u[0]], &[next[1]]).expect("insert");
    }
    let tune = TuneSettings::default();
    let own = learned.tune(&tune).expect("tune");
    let run = Executor::new(learned.tune_start(&tune).expect("start"), Stepper::new())
        .run()
        .expect("argmin");
    assert_eq!(run.state.get_best_cost(), own.objective);
    let r = finish(run).expect("finish");
    assert_eq!(r, own);
    assert!(r.objective < r.initial_objective);
}

/// [`Reach`] with a terminal stage of its own size (two residuals, the
/// state's error alone) instead of a zero-padded third, and no Jacobians:
/// the solvers size the terminal stage by `n_terminal_residuals` and
/// difference the residuals.
struct ReachOwnTerminal;

impl StageCost for ReachOwnTerminal {
    fn n_residuals(&self) -> usize {
        3
    }
    fn n_terminal_residuals(&self) -> usize {
        2
    }
    fn residuals(&self, _k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
        let w = if u.is_some() { 1.0 } else { 10.0 };
        r[0] = w * (x[0] - TARGET);
        r[1] = 0.3 * w * x[1];
        if let Some(u) = u {
            r[2] = 0.2 * u[0];
        }
        Ok(())
    }
}

/// A running cost on the control alone, a terminal cost on the state:
/// the terminal stage has more residuals than the running ones.
struct EffortThenReach;

impl StageCost for EffortThenReach {
    fn n_residuals(&self) -> usize {
        1
    }
    fn n_terminal_residuals(&self) -> usize {
        2
    }
    fn residuals(&self, _k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
        match u {
            Some(u) => r[0] = 0.2 * u[0],
            None => r.copy_from_slice(&[10.0 * (x[0] - TARGET), 3.0 * x[1]]),
        }
        Ok(())
    }
}

/// The workaround a user wrote before `n_terminal_residuals`: every stage
/// padded with zeros to the larger count.
struct Padded<C>(C);

impl<C: StageCost> StageCost for Padded<C> {
    fn n_residuals(&self) -> usize {
        self.0.n_residuals().max(self.0.n_terminal_residuals())
    }
    fn residuals(&self, k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
        r.fill(0.0);
        let own = systems::residual_count(&self.0, u.is_none());
        self.0.residuals(k, x, u, &mut r[..own])
    }
}

/// Issue 50: a terminal cost of its own size plans to the padded one's
/// optimum, by Eq. 3 (Gauss-Newton) and by DDP; a residual buffer of the
/// wrong size would panic or shift the stages' rows.
#[test]
fn a_terminal_cost_of_its_own_size_plans_as_the_padded_one() {
    let model = UserPendulum { a: 9.81 / 0.5, b: 0.1 };
    let times: Vec<f64> = (0..=HORIZON).map(|k| k as f64 * DT).collect();
    let state_basis = BSplineBasis::clamped_uniform(HORIZON + 1, 3, 0.0, times[HORIZON]).expect("basis");
    let control_basis = BSplineBasis::clamped_uniform(HORIZON, 3, 0.0, times[HORIZON]).expect("basis");
    let own_costs: [&dyn StageCost; 2] = [&ReachOwnTerminal, &EffortThenReach];
    let padded_costs: [&dyn StageCost; 2] = [&Padded(ReachOwnTerminal), &Padded(EffortThenReach)];
    for (own_cost, padded_cost) in own_costs.into_iter().zip(padded_costs) {
        let build = |cost: &'static dyn StageCost| {
            Eq3Problem::new(
                &model,
                cost,
                &state_basis,
                &control_basis,
                &times,
                Lambda::Constant(1e3),
            )
            .expect("problem")
            .with_initial_state(&[0.0, 0.0], 1e4)
            .expect("initial state")
        };
        let (own, padded) = (build(own_cost), build(padded_cost));
        // Eq. 3 gives every stage the larger count (zeros below a stage's
        // own rows): the same rows, the same cost at any point
        assert_eq!(own.n_residuals(), padded.n_residuals());
        let theta0 = vec![0.0; own.n_params()];
        let probe: Vec<f64> = (0..theta0.len()).map(|i| 0.1 * (i as f64).sin()).collect();
        let mut r = vec![0.0; own.n_residuals()];
        own.residuals(&probe, &mut r).expect("residuals");
        let c_own: f64 = r.iter().map(|v| v * v).sum();
        padded.residuals(&probe, &mut r).expect("residuals");
        let c_pad: f64 = r.iter().map(|v| v * v).sum();
        assert!((c_own - c_pad).abs() <= 1e-12 * c_pad, "{c_own} vs {c_pad}");
        let settings = GaussNewtonSettings::default();
        let a = GaussNewton::new(settings.clone())
            .expect("settings")
            .solve(&own, &theta0)
            .expect("own");
        let b = GaussNewton::new(settings)
            .expect("settings")
            .solve(&padded, &theta0)
            .expect("padded");
        assert!(a.status.termination().is_converged(), "{:?}", a.status);
        assert!((a.cost - b.cost).abs() <= 1e-6 * b.cost, "{} vs {}", a.cost, b.cost);

        let plan = |cost: &'static dyn StageCost| {
            let problem =
                DdpProblem::new(&model, ResidualCost::new(cost, 2, 1, HORIZON), &[0.0, 0.0], HORIZON).expect("problem");
            Ddp::new(DdpSettings::default())
                .expect("settings")
                .solve(&problem)
                .expect("ddp")
        };
        let (a, b) = (plan(own_cost), plan(padded_cost));
        assert!(a.status.is_converged(), "{:?}", a.status);
        assert!((a.cost - b.cost).abs() <= 1e-6 * b.cost, "{} vs {}", a.cost, b.cost);
    }
    // and the DDP cost is the rollout's, terminal included
    let problem = DdpProblem::new(
        &model,
        ResidualCost::new(ReachOwnTerminal, 2, 1, HORIZON),
        &[0.0, 0.0],
        HORIZON,
    )
    .expect("problem");
    let plan = Ddp::new(DdpSettings::default())
        .expect("settings")
        .solve(&problem)
        .expect("ddp");
    assert!((plan.cost - rollout_cost(&model, &plan.controls.concat())).abs() <= 1e-9 * plan.cost);
}
