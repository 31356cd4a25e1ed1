//! Planning the swing-up with DDP (the `ddp` crate's iLQR) instead of Eq. 3,
//! for the planner-by-model comparison (claim C6).
//!
//! The task is the Eq. 3 planner's ([`crate::planning::eq3::build_problem`]):
//! minimise
//! $$J = \sum_{k<N} \Bigl[\sum_i q_i (s_{k,i} - s^d_{k,i})^2 + r (u_k - u^d_k)^2\Bigr] +
//!   \sum_i q^f_i (s_{N,i} - s^\star_i)^2$$
//! with $q$ = `state_weights`, $r$ = `control_weight`, $q^f$ =
//! `terminal_weights`, $s^d, u^d$ the demonstration and
//! $s^\star = (\pi, 0, 0, 0)$ upright at rest with the hand home, over
//! controls $|u_k| \le$ `u_max`, from hanging at rest, warm-started with the
//! demonstration's controls, plus the soft bounds on $|x|$ and $|u|$ of
//! [`crate::planning::cost`]. It is the very stage cost the Eq. 3 planner uses
//! ([`SwingupCost`], residual form $c_k = \lVert r_k \rVert^2$, so weights
//! enter as $w e^2$), wrapped as a `ddp` cost by [`ResidualCost`]: for a
//! trajectory consistent with the model $J$ equals the Eq. 3 task cost.
//! The control limits are also hard here (the box of `ddp`'s backward
//! pass), so the soft $|u|$ bound never acts.
//!
//! Unlike Eq. 3, DDP only ever holds trajectories rolled out through the
//! model: it cannot plan where the model is wrong without following the
//! model there. With a learned model the rollout can leave the data and blow
//! up (the paper's point 2); that is reported, not hidden: every
//! [`DdpStatus`] comes back in the [`PlanSummary`] (`status` is its `Debug`
//! text) and [`classify_ddp_failure`] names the failure mode. A rollout whose
//! $\lVert s \rVert_\infty$ exceeds [`MAX_STATE_NORM`] counts as blown up.

use std::cell::Cell;

use ddp::{Cost, CostDerivatives, Ddp, DdpProblem, DdpSettings, DdpStatus, ResidualCost};

use crate::planning::cost::SwingupCost;

use crate::config::Config;
use crate::models::{KnownHand, PendulumRegression};
use crate::plant::demo::Demonstration;
use crate::record::PlanSummary;

/// Largest $\lVert (\theta, \dot\theta, x, \dot x) \rVert_\infty$ a rollout
/// may reach before it counts as blown up. The true swing-ups stay below
/// about 15 (angular speed in rad/s; angles a few radians, the hand under a
/// metre and a few m/s), so 100 is far outside anything physical while
/// catching a learned model's runaway long before `ddp`'s default (1e8).
pub const MAX_STATE_NORM: f64 = 100.0;

/// The Eq. 3 task cost of the swing-up as a `ddp` cost: the same
/// [`SwingupCost`] (Eq. 5 tracking plus the soft bounds) that
/// [`crate::planning::eq3::build_problem`] builds, made the same way.
///
/// # Errors
/// A demonstration with inconsistent lengths or non-finite values, or
/// invalid weights or bounds.
pub fn task_cost(cfg: &Config, demo: &Demonstration) -> crate::Result<ResidualCost<SwingupCost>> {
    let stage = crate::planning::eq3::swingup_cost(&cfg.planner, cfg.start, demo)?;
    let n = demo.horizon();
    Ok(ResidualCost::new(stage, 4, 1, n))
}

/// Plans the swing-up with DDP through `model` (see the [module docs](self)):
/// `cfg.planner.max_iters` iterations of iLQR with the `ddp` crate's default
/// settings otherwise and blow-up threshold [`MAX_STATE_NORM`].
///
/// The rollout is the model's own, so `inconsistency` and `max_mismatch`
/// are 0 and `task` equals `cost`. Any [`DdpStatus`] is returned in the
/// summary (`planner` `ddp`, `status` its `Debug` text), failures included;
/// when the warm start's rollout itself blows up
/// (`InitialRolloutDiverged { step }`), `states` holds the states before
/// the blow-up, `controls` the (clamped) warm start, and the costs are
/// infinite. `evaluations` counts rollouts (cost evaluations).
///
/// # Errors
/// Only invalid input: an inconsistent configuration or demonstration, or a
/// model whose sample period differs from the demonstration's.
pub fn plan_ddp<G: PendulumRegression>(
    cfg: &Config,
    demo: &Demonstration,
    model: &KnownHand<G>,
) -> crate::Result<PlanSummary> {
    cfg.validate()?;
    let u_max = cfg.planner.u_max;
    crate::error::ensure_data!(
        u_max.is_finite() && u_max > 0.0,
        "planner u_max must be finite and positive, got {u_max}"
    );
    crate::error::ensure_data!(
        (model.dt - demo.dt).abs() <= 1e-12 * demo.dt.abs(),
        "the model's sample period {} differs from the demonstration's {}",
        model.dt,
        demo.dt
    );
    let cost = Counted {
        inner: task_cost(cfg, demo)?,
        rollouts: Cell::new(0),
    };
    // a reference to `ddp` dynamics is `ddp` dynamics
    let problem = DdpProblem::new(model, cost, &[0.0; 4], demo.horizon())?
        .with_initial_controls(demo.controls.iter().map(|&u| vec![u]).collect())?
        .with_control_limits(&[-u_max], &[u_max])?;
    let solver = Ddp::new(DdpSettings {
        max_iterations: cfg.planner.max_iters,
        max_state_norm: MAX_STATE_NORM,
        ..DdpSettings::default()
    })?;
    let result = solver.solve(&problem)?;
    Ok(PlanSummary {
        planner: "ddp".into(),
        status: result.status.into(),
        cost: result.cost,
        initial_cost: result.initial_cost,
        task: result.cost,
        inconsistency: 0.0,
        max_mismatch: 0.0,
        iterations: result.iterations,
        evaluations: problem.cost().rollouts.get(),
        seconds: result.solve_time.as_secs_f64(),
        states: result
            .states
            .iter()
            .map(|s| std::array::from_fn(|i| s.get(i).copied().unwrap_or(f64::NAN)))
            .collect(),
        controls: result.controls.iter().map(|u| u[0]).collect(),
        gauss_newton_cost: None,
    })
}

/// A short name for how a DDP solve ended: `converged`, `max iterations`,
/// `rollout blow-up` (the warm start's rollout, or every line-search
/// rollout, blew up), `no descent`, `indefinite` ($Q_{uu}$ stayed
/// indefinite), `non-finite derivatives`, or `other`.
pub fn classify_ddp_status(status: DdpStatus) -> &'static str {
    match status {
        DdpStatus::Converged => "converged",
        DdpStatus::MaxIterations => "max iterations",
        DdpStatus::InitialRolloutDiverged { .. } | DdpStatus::RolloutDiverged => "rollout blow-up",
        DdpStatus::NoDescent => "no descent",
        DdpStatus::NotPositiveDefinite => "indefinite",
        DdpStatus::NonFiniteDerivatives => "non-finite derivatives",
        _ => "other",
    }
}

/// [`classify_ddp_status`] of a [`plan_ddp`] summary's status (typed,
/// so it also works on a record read back from a report:
/// [`PlanSummary::ddp_status`]); `rollout blow-up` too if any planned
/// state is not finite, and `not ddp` for another planner's summary.
pub fn classify_ddp_failure(summary: &PlanSummary) -> &'static str {
    let Some(status) = summary.ddp_status() else {
        return "not ddp";
    };
    if summary.states.iter().flatten().any(|v| !v.is_finite()) {
        return "rollout blow-up";
    }
    classify_ddp_status(status)
}

/// A cost that counts rollouts (each evaluates the terminal cost once).
struct Counted<C> {
    inner: C,
    rollouts: Cell<usize>,
}

impl<C: Cost> Cost for Counted<C> {
    fn running(&self, k: usize, x: &[f64], u: &[f64]) -> f64 {
        self.inner.running(k, x, u)
    }

    fn running_derivatives(&self, k: usize, x: &[f64], u: &[f64], d: &mut CostDerivatives) {
        self.inner.running_derivatives(k, x, u, d);
    }

    fn terminal(&self, x: &[f64]) -> f64 {
        self.rollouts.set(self.rollouts.get() + 1);
        self.inner.terminal(x)
    }

    fn terminal_derivatives(&self, x: &[f64], lx: &mut [f64], lxx: &mut [f64]) {
        self.inner.terminal_derivatives(x, lx, lxx);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::truth::TrueRegression;
    use crate::planning::eq3::build_problem;
    use crate::plant::demo::demonstrate;
    use crate::record::PlanStatus;
    use ddp::Dynamics;
    use faer::prelude::*;
    use splines::{BSplineBasis, TrajectoryBasis};

    fn setup(horizon: usize, max_iters: usize) -> (Config, Demonstration) {
        let mut cfg = Config {
            horizon,
            ..Config::default()
        };
        cfg.planner.max_iters = max_iters;
        let (demo, _) = demonstrate(&cfg.human, &cfg.human_swingup, cfg.horizon, 0).expect("demo");
        (cfg, demo)
    }

    fn true_model(cfg: &Config) -> KnownHand<TrueRegression> {
        KnownHand::new(TrueRegression::new(cfg.robot).expect("valid"), cfg.robot.dt)
    }

    /// With the true model, DDP lowers the cost from the warm start and
    /// returns a finite, consistent, control-limited plan.
    #[test]
    fn plans_with_the_true_model() {
        let (cfg, demo) = setup(90, 50);
        let model = true_model(&cfg);
        let plan = plan_ddp(&cfg, &demo, &model).expect("plan");
        eprintln!(
            "{} after {} iterations ({} rollouts, {:.3} s): cost {} from {}",
            plan.status, plan.iterations, plan.evaluations, plan.seconds, plan.cost, plan.initial_cost
        );
        assert_eq!(plan.planner, "ddp");
        assert!(matches!(classify_ddp_failure(&plan), "converged" | "max iterations"));
        assert!(
            plan.cost < 0.5 * plan.initial_cost,
            "{} vs {}",
            plan.cost,
            plan.initial_cost
        );
        assert_eq!(plan.states.len(), 91);
        assert_eq!(plan.controls.len(), 90);
        assert!(plan.controls.iter().all(|u| u.abs() <= cfg.planner.u_max));
        assert!(plan.evaluations > plan.iterations);
        // the states are the model's rollout of the controls
        let mut s = [0.0; 4];
        for (k, &u) in plan.controls.iter().enumerate() {
            let mut next = [0.0; 4];
            Dynamics::step(&model, &s, &[u], &mut next).expect("step");
            s = next;
            assert_eq!(s, plan.states[k + 1]);
        }
    }

    /// Sum of the `ddp` cost over a trajectory.
    fn ddp_cost(cost: &impl Cost, states: &[[f64; 4]], controls: &[f64]) -> f64 {
        let running: f64 = controls
            .iter()
            .enumerate()
            .map(|(k, &u)| cost.running(k, &states[k], &[u]))
            .sum();
        running + cost.terminal(&states[controls.len()])
    }

    /// The DDP cost is the Eq. 3 task cost. `plan.cost` is the `ddp` cost
    /// of the plan's own trajectory; and `build_problem`'s criterion, on a
    /// parameter vector whose states interpolate the plan's exactly (cubic
    /// B-splines with one coefficient per sample, from the square
    /// collocation system), gives the same task cost as the `ddp` cost of
    /// the same states and controls. (The controls cannot be the plan's
    /// exactly: no clamped B-spline basis on $[t_0, t_N]$ both interpolates
    /// $N$ arbitrary controls at $t_0, \dots, t_{N-1}$ stably and lets
    /// `build_problem` fit the demonstration with it; they are
    /// `build_problem`'s fit of the demonstration's controls, and the cost
    /// is a sum over samples, so this checks the same function.)
    #[test]
    fn cost_equals_the_eq3_task_cost() {
        let (mut cfg, demo) = setup(60, 5);
        let model = true_model(&cfg);
        let plan = plan_ddp(&cfg, &demo, &model).expect("plan");
        let cost = task_cost(&cfg, &demo).expect("cost");
        let own = ddp_cost(&cost, &plan.states, &plan.controls);
        assert!((own - plan.cost).abs() < 1e-12 * plan.cost, "{own} vs {}", plan.cost);

        let n = demo.horizon();
        cfg.planner.state_coeffs = n + 1;
        let (problem, theta0) = build_problem(&cfg, &demo, true_model(&cfg), None).expect("problem");
        let times = demo.times();
        let basis = BSplineBasis::clamped_uniform(n + 1, 3, 0.0, times[n]).expect("basis");
        let cx = basis
            .design_matrix_rows(&times, 0)
            .expect("collocation")
            .to_dense()
            .partial_piv_lu()
            .solve(Mat::from_fn(n + 1, 4, |k, i| plan.states[k][i]));
        let (_, cu) = problem.unpack(&theta0).expect("unpack");
        let theta = problem.pack(&cx, &cu).expect("pack");
        let (px, pu) = problem.trajectory(&theta).expect("trajectory");
        for k in 0..=n {
            for i in 0..4 {
                assert!((px[(k, i)] - plan.states[k][i]).abs() < 1e-12, "{k} {i}");
            }
        }
        let controls: Vec<f64> = (0..n).map(|k| pu[(k, 0)]).collect();
        let parts = problem.cost_breakdown(&theta).expect("cost");
        let ours = ddp_cost(&cost, &plan.states, &controls);
        eprintln!("ddp {ours} vs eq3 task {} ({parts:?})", parts.task);
        assert!((parts.task - ours).abs() < 1e-9 * ours, "{} vs {ours}", parts.task);
        assert!(parts.initial_state < 1e-12);
        // and on any trajectory, the soft bounds active included: the
        // demonstration's fit with the hand pushed out beyond x_max
        let (cx0, cu0) = problem.unpack(&theta0).expect("unpack");
        let pushed = Mat::from_fn(n + 1, 4, |j, i| cx0[(j, i)] + if i == 2 { 0.9 } else { 0.0 });
        let theta = problem.pack(&pushed, &cu0).expect("pack");
        let (px, pu) = problem.trajectory(&theta).expect("trajectory");
        let states: Vec<[f64; 4]> = (0..=n).map(|k| std::array::from_fn(|i| px[(k, i)])).collect();
        let controls: Vec<f64> = (0..n).map(|k| pu[(k, 0)]).collect();
        assert!(states.iter().any(|s| s[2].abs() > cfg.planner.x_max));
        let task = problem.cost_breakdown(&theta).expect("cost").task;
        let ours = ddp_cost(&cost, &states, &controls);
        assert!((task - ours).abs() < 1e-12 * ours, "{task} vs {ours}");
    }

    /// The `ddp` cost's gradient matches central differences, with a soft
    /// bound active, and its Hessian is the Gauss-Newton $2 J^\top J$.
    #[test]
    fn residual_cost_derivatives() {
        let (cfg, demo) = setup(30, 5);
        let cost = task_cost(&cfg, &demo).expect("cost");
        let (x, u) = ([0.4, -1.2, 0.8, 0.3], [13.0]);
        let mut d = CostDerivatives::zeros(4, 1);
        cost.running_derivatives(5, &x, &u, &mut d);
        let z: Vec<f64> = x.iter().chain(&u).copied().collect();
        let analytic: Vec<f64> = d.lx.iter().chain(&d.lu).copied().collect();
        let worst =
            ddp::strategies::check_jacobian(|z| vec![cost.running(5, &z[..4], &z[4..])], &z, &analytic).expect("check");
        assert!(worst.max_rel_error < 1e-5, "{worst:?}");
        // diagonal weights: 2 q_i on the diagonal, plus 2 w_b for the active hand bound
        let p = &cfg.planner;
        assert!((d.lxx[0] - 2.0 * p.state_weights[0]).abs() < 1e-12);
        assert!((d.lxx[2 * 4 + 2] - 2.0 * (p.state_weights[2] + p.bound_weight)).abs() < 1e-9);
        assert!((d.luu[0] - 2.0 * (p.control_weight + p.bound_weight)).abs() < 1e-9);
        assert!(d.lux.iter().all(|v| *v == 0.0));
        let (mut lx, mut lxx) = (vec![0.0; 4], vec![0.0; 16]);
        cost.terminal_derivatives(&x, &mut lx, &mut lxx);
        assert!((lxx[0] - 2.0 * p.terminal_weights[0]).abs() < 1e-9);
        assert!((lx[0] - 2.0 * p.terminal_weights[0] * (x[0] - std::f64::consts::PI)).abs() < 1e-9);
    }

    /// A model that runs away: the plan comes back (not an error) with the
    /// blow-up as its status.
    #[test]
    fn a_blown_up_rollout_is_a_status() {
        struct Runaway;
        impl PendulumRegression for Runaway {
            fn delta_omega(&self, z: &[f64; 5], jacobian: Option<&mut [f64; 5]>) -> f64 {
                if let Some(j) = jacobian {
                    *j = [0.0, 0.5, 0.0, 0.0, 0.1];
                }
                0.5 * z[1] + 0.1 * z[4]
            }
        }
        let (cfg, demo) = setup(60, 20);
        let plan = plan_ddp(&cfg, &demo, &KnownHand::new(Runaway, cfg.robot.dt)).expect("a status, not an error");
        assert!(
            matches!(plan.status, PlanStatus::Ddp(DdpStatus::InitialRolloutDiverged { .. })),
            "{}",
            plan.status
        );
        assert_eq!(classify_ddp_failure(&plan), "rollout blow-up");
        assert!(plan.states.len() < 61 && plan.states.iter().flatten().all(|v| v.is_finite()));
        assert_eq!(plan.cost, f64::INFINITY);

        struct NotANumber;
        impl PendulumRegression for NotANumber {
            fn delta_omega(&self, _z: &[f64; 5], jacobian: Option<&mut [f64; 5]>) -> f64 {
                if let Some(j) = jacobian {
                    *j = [f64::NAN; 5];
                }
                f64::NAN
            }
        }
        let plan = plan_ddp(&cfg, &demo, &KnownHand::new(NotANumber, cfg.robot.dt)).expect("status");
        assert_eq!(classify_ddp_failure(&plan), "rollout blow-up");
    }

    #[test]
    fn classifies_every_status_and_rejects_bad_input() {
        for (status, name) in [
            (DdpStatus::Converged, "converged"),
            (DdpStatus::MaxIterations, "max iterations"),
            (DdpStatus::InitialRolloutDiverged { step: 3 }, "rollout blow-up"),
            (DdpStatus::RolloutDiverged, "rollout blow-up"),
            (DdpStatus::NoDescent, "no descent"),
            (DdpStatus::NotPositiveDefinite, "indefinite"),
            (DdpStatus::NonFiniteDerivatives, "non-finite derivatives"),
        ] {
            assert_eq!(classify_ddp_status(status), name);
            let summary = PlanSummary::along("ddp", status.into(), vec![[0.0; 4]], vec![0.0]);
            assert_eq!(classify_ddp_failure(&summary), name);
            // and read back from its record, as a report reads it
            let json = serde_json::to_string(&summary).expect("json");
            let back: PlanSummary = serde_json::from_str(&json).expect("read back");
            assert_eq!(classify_ddp_failure(&back), name, "{json}");
            assert_eq!(back.ddp_status(), Some(status), "{json}");
        }
        // the status text of records written before statuses were typed
        for (text, status) in [
            (
                "\"InitialRolloutDiverged { step: 3 }\"",
                DdpStatus::InitialRolloutDiverged { step: 3 },
            ),
            ("\"MaxIterations\"", DdpStatus::MaxIterations),
            ("\"Converged\"", DdpStatus::Converged),
        ] {
            let read: PlanStatus = serde_json::from_str(text).expect(text);
            let mut summary = PlanSummary::along("ddp", read, vec![[0.0; 4]], vec![0.0]);
            assert_eq!(summary.ddp_status(), Some(status), "{text}");
            summary.planner = "gauss-newton".into();
            assert_eq!(summary.ddp_status(), None);
        }
        assert!(serde_json::from_str::<PlanStatus>("\"Convergd\"").is_err());
        let (cfg, demo) = setup(30, 5);
        // a model sampled at another rate
        assert!(plan_ddp(&cfg, &demo, &KnownHand::new(TrueRegression::robot(), 0.01)).is_err());
        let mut short = demo.clone();
        short.states.pop();
        assert!(plan_ddp(&cfg, &short, &true_model(&cfg)).is_err());
        let mut bad = cfg.clone();
        bad.planner.u_max = f64::NAN;
        assert!(plan_ddp(&bad, &demo, &true_model(&cfg)).is_err());
    }
}
