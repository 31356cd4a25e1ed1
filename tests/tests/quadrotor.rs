//! Issue 50, item 3: a user's model and quadratic cost planned by DDP
//! (`ddp/examples/quadrotor.rs`) and, the same model and cost in residual
//! form (a terminal stage of its own size, no Jacobians written), by the
//! paper's Eq. 3 with Gauss-Newton: its controls, rolled out through the
//! model, cost within 1 % of DDP's plan. The recipe: one coefficient per
//! sample (linear B-splines, so that Eq. 3 is DDP's discrete problem with
//! the dynamics and the start as penalties) and lambda raised by
//! continuation, each solve warm-started from the last.

use ddp::{Ddp, DdpProblem, DdpSettings, QuadraticCost};
use splines::BSplineBasis;
use systems::{ModelResult, StageCost};
use trajopt::{Eq3Problem, GaussNewton, GaussNewtonSettings, Lambda, LeastSquaresProblem};

#[allow(unreachable_pub)] // public in the example
#[path = "../../ddp/examples/quadrotor.rs"]
mod quadrotor;
use quadrotor::{DT, G, MASS, Quadrotor};

const HORIZON: usize = 60;
const GOAL: [f64; 6] = [1.0, 1.0, 0.0, 0.0, 0.0, 0.0];
const Q: [f64; 6] = [1.0, 1.0, 0.1, 0.1, 0.1, 0.1];
const R: f64 = 0.01;
const QF: f64 = 100.0;
const HOVER: f64 = MASS * G / 2.0;

/// The example's `QuadraticCost` in residual form: 8 residuals per running
/// stage, 6 at the end.
struct HoverCost;

impl StageCost for HoverCost {
    fn n_residuals(&self) -> usize {
        8
    }
    fn n_terminal_residuals(&self) -> usize {
        6
    }
    fn residuals(&self, _k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
        for i in 0..6 {
            r[i] = u.map_or(QF, |_| Q[i]).sqrt() * (x[i] - GOAL[i]);
        }
        if let Some(u) = u {
            r[6] = R.sqrt() * (u[0] - HOVER);
            r[7] = R.sqrt() * (u[1] - HOVER);
        }
        Ok(())
    }
}

fn ddp_problem() -> DdpProblem<Quadrotor, QuadraticCost> {
    let cost = QuadraticCost::diagonal(&Q, &[R, R], &[QF; 6])
        .and_then(|c| c.with_state_target(&GOAL))
        .and_then(|c| c.with_control_reference(vec![vec![HOVER; 2]]))
        .expect("cost");
    DdpProblem::new(Quadrotor, cost, &[0.0; 6], HORIZON)
        .and_then(|p| p.with_initial_controls(vec![vec![HOVER; 2]; HORIZON]))
        .and_then(|p| p.with_control_limits(&[0.0, 0.0], &[8.0, 8.0]))
        .expect("problem")
}

#[test]
fn eq3_plans_the_quadrotor_to_ddps_cost() {
    let ddp = ddp_problem();
    let plan = Ddp::new(DdpSettings::default())
        .expect("settings")
        .solve(&ddp)
        .expect("ddp");
    assert!(plan.status.is_converged(), "{:?}", plan.status);

    // one coefficient per sample: linear B-splines with a knot at every
    // state sample (the Eq. 3 problem is then DDP's discrete one, the
    // dynamics a penalty), raised by continuation in lambda
    let times: Vec<f64> = (0..=HORIZON).map(|k| k as f64 * DT).collect();
    let end = times[HORIZON];
    let state_basis = BSplineBasis::clamped_uniform(HORIZON + 1, 1, 0.0, end).expect("basis");
    let control_basis = BSplineBasis::clamped_uniform(HORIZON, 1, 0.0, end).expect("basis");
    // the start, like the dynamics, is a penalty: raised with lambda
    let build = |lambda: f64| {
        Eq3Problem::new(
            Quadrotor,
            HoverCost,
            &state_basis,
            &control_basis,
            &times,
            Lambda::Constant(lambda),
        )
        .and_then(|p| p.with_initial_state(&[0.0; 6], lambda))
        .and_then(|p| p.with_control_bounds(&[0.0, 0.0], &[8.0, 8.0]))
        .expect("eq3")
    };
    // the start: at rest at the origin, hovering
    let mut problem = build(1e2);
    let mut theta = vec![0.0; problem.n_params()];
    theta[6 * (HORIZON + 1)..].fill(HOVER);
    let settings = GaussNewtonSettings {
        max_iterations: 500,
        ..GaussNewtonSettings::default()
    };
    for lambda in [1e2, 1e4, 1e6, 1e8] {
        // (at lambda >= 1e6 Gauss-Newton ends Stalled with the thrust
        // bounds, ConvergedCost without them: the bounded steps are QPs
        // solved to clarabel's tolerance; the point reaches DDP's optimum
        // all the same, checked below)
        problem = build(lambda);
        let r = GaussNewton::new(settings.clone())
            .expect("settings")
            .solve(&problem, &theta)
            .expect("eq3 solve");
        let parts = problem.cost_breakdown(&r.x).expect("breakdown");
        eprintln!(
            "lambda {lambda:e}: {:?} after {} iterations, cost {}, task {}, max mismatch {:e}, initial {:e}",
            r.status, r.iterations, r.cost, parts.task, parts.max_mismatch, parts.initial_state
        );
        theta = r.x;
    }
    let (_, controls) = problem.trajectory(&theta).expect("trajectory");
    let controls: Vec<Vec<f64>> = (0..HORIZON).map(|k| vec![controls[(k, 0)], controls[(k, 1)]]).collect();
    let eq3_cost = ddp.rollout_cost(&controls).expect("rollout");
    eprintln!(
        "DDP {} (in {} iterations), Eq. 3 rolled out {}",
        plan.cost, plan.iterations, eq3_cost
    );
    assert!(eq3_cost <= 1.01 * plan.cost, "Eq. 3 {eq3_cost} vs DDP {}", plan.cost);

    // the residual form is the quadratic cost: the same total on DDP's plan
    let mut total = 0.0;
    let mut r = [0.0; 8];
    for k in 0..=HORIZON {
        let u = (k < HORIZON).then(|| plan.controls[k].as_slice());
        let rows = systems::residual_count(&HoverCost, u.is_none());
        HoverCost
            .residuals(k, &plan.states[k], u, &mut r[..rows])
            .expect("residuals");
        total += r[..rows].iter().map(|v| v * v).sum::<f64>();
    }
    assert!(
        (total - plan.cost).abs() <= 1e-9 * plan.cost,
        "{total} vs {}",
        plan.cost
    );
}
