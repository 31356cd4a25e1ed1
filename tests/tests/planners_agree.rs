//! The two planners of the paper on the same problem: DDP (consistent with
//! the model by construction) and the Eq. 3 planner (model as a soft
//! penalty). As lambda grows, the Eq. 3 plan must become the DDP plan; for
//! a finite lambda it may buy task cost with inconsistency, never the
//! reverse.

use faer::Mat;
use integration_tests::gauss_newton_plan;
use splines::BSplineBasis;
use trajopt::{Eq3Problem, Lambda, LinearModel, TrackingCost};

const DT: f64 = 0.1;
const N: usize = 40;

fn matrices() -> (Mat<f64>, Mat<f64>) {
    // double integrator: position, velocity; control = acceleration
    let a = Mat::from_fn(2, 2, |i, j| [[1.0, DT], [0.0, 1.0]][i][j]);
    let b = Mat::from_fn(2, 1, |i, _| [0.5 * DT * DT, DT][i]);
    (a, b)
}

/// DDP's optimum: cost x'Qx + u'Ru summed, plus x_N' Qf x_N (no 1/2 in
/// either crate's quadratic cost).
fn ddp_plan() -> (f64, Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let (a, b) = matrices();
    let dynamics = ddp::models::LinearDynamics::new(&a, &b).expect("valid");
    let cost = ddp::models::QuadraticCost::diagonal(&[0.5, 0.05], &[0.005], &[5.0, 5.0]).expect("valid");
    let problem = ddp::DdpProblem::new(dynamics, cost, &[1.0, 0.0], N).expect("valid");
    let result = ddp::Ddp::new(ddp::DdpSettings::default())
        .expect("settings")
        .solve(&problem)
        .expect("solve");
    assert!(result.status.is_converged(), "{:?}", result.status);
    (result.cost, result.states, result.controls)
}

/// The Eq. 3 plan with the same costs (the same weights as DDP's), states
/// and controls one coefficient per sample.
fn eq3_plan(lambda: f64) -> (f64, f64, Mat<f64>) {
    let (a, b) = matrices();
    let times: Vec<f64> = (0..=N).map(|k| k as f64 * DT).collect();
    let xb = BSplineBasis::clamped(&times, 1).expect("basis");
    let ub = BSplineBasis::clamped(&times[..N], 1).expect("basis");
    let cost = TrackingCost::new(
        Mat::zeros(N + 1, 2),
        Mat::zeros(N, 1),
        &[0.5, 0.05],
        &[0.005],
        &[5.0, 5.0],
    )
    .expect("cost");
    let problem = Eq3Problem::new(
        LinearModel::new(a, b).expect("model"),
        cost,
        &xb,
        &ub,
        &times,
        Lambda::Constant(lambda),
    )
    .expect("problem")
    .with_initial_state(&[1.0, 0.0], 1e12)
    .expect("x0");
    let theta0 = vec![0.0; problem.n_state_coeffs() * 2 + problem.n_control_coeffs()];
    let plan = gauss_newton_plan(&problem, &theta0, 50);
    (plan.parts.task, plan.parts.max_mismatch, plan.states)
}

#[test]
fn eq3_becomes_ddp_as_lambda_grows() {
    let (ddp_cost, ddp_states, ddp_controls) = ddp_plan();
    assert_eq!(ddp_controls.len(), N);
    let (task, mismatch, states) = eq3_plan(1e10);
    assert!(mismatch < 1e-6, "consistent plan: mismatch {mismatch}");
    assert!(
        (task - ddp_cost).abs() <= 1e-5 * ddp_cost,
        "Eq. 3 task cost {task} vs DDP {ddp_cost}"
    );
    for k in 0..=N {
        for i in 0..2 {
            assert!((states[(k, i)] - ddp_states[k][i]).abs() < 1e-4, "state {k},{i}");
        }
    }
}

#[test]
fn a_finite_lambda_trades_consistency_for_task_cost() {
    let (ddp_cost, ..) = ddp_plan();
    let mut previous_task = 0.0;
    for lambda in [1e-2, 1.0, 1e2, 1e4] {
        let (task, mismatch, _) = eq3_plan(lambda);
        // cheaper than the consistent optimum, by being inconsistent
        assert!(task < ddp_cost, "lambda {lambda}: task {task} vs DDP {ddp_cost}");
        assert!(mismatch > 0.0);
        // and the more the model is trusted, the closer to DDP's cost
        assert!(task >= previous_task, "lambda {lambda}");
        previous_task = task;
    }
}
