//! Solver behaviour: swing-ups converge, accepted iterations never increase
//! the cost, control limits hold, iLQR and DDP agree.

use ddp::problems::{cartpole_swingup, pendulum_swingup};
use ddp::strategies::lq_problem;
use ddp::{Ddp, DdpMethod, DdpProblem, DdpSettings, DdpStatus, Pendulum, QuadraticCost, Regularization};
use proptest::prelude::*;

mod common;
use common::{solve, solve_with};

fn assert_finite(r: &ddp::DdpResult) {
    assert!(
        r.states
            .iter()
            .flatten()
            .chain(r.controls.iter().flatten())
            .all(|v| v.is_finite())
    );
}

#[test]
fn pendulum_swingup_converges_with_ddp_and_ilqr_to_the_same_optimum() {
    let problem = pendulum_swingup(300).expect("problem");
    let mut costs = Vec::new();
    for method in [DdpMethod::Ddp, DdpMethod::Ilqr] {
        for regularization in [Regularization::State, Regularization::Control] {
            let settings = DdpSettings {
                method,
                regularization,
                ..DdpSettings::default()
            };
            let r = solve_with(settings, &problem);
            assert_eq!(r.status, DdpStatus::Converged, "{method:?} {regularization:?}");
            assert_eq!(r.method, method);
            let last = &r.states[300];
            assert!(
                (last[0] - std::f64::consts::PI).abs() < 1e-2 && last[1].abs() < 1e-2,
                "{last:?}"
            );
            assert_eq!(r.cost_history.len(), r.iterations + 1);
            // one linearisation at the warm start and one after each accepted step
            let accepted = r.step_sizes.iter().filter(|&&a| a > 0.0).count();
            assert_eq!(r.jacobian_evals, accepted + 1);
            assert!(r.evals > r.iterations, "{} rollouts", r.evals);
            assert_eq!(r.step_sizes.len(), r.iterations);
            assert_eq!(r.regularizations.len(), r.iterations);
            assert_eq!(r.gains.len(), 300);
            assert_eq!(r.value.len(), 301);
            assert!((r.value[0] - r.cost).abs() <= 1e-12 * r.cost);
            costs.push(r.cost);
        }
    }
    for c in &costs {
        assert!((c - costs[0]).abs() <= 1e-7 * costs[0], "{costs:?}");
    }
}

#[test]
fn cartpole_swingup_decreases_the_cost_monotonically() {
    let settings = DdpSettings {
        max_iterations: 100,
        ..DdpSettings::default()
    };
    let r = solve_with(settings, &cartpole_swingup(100).expect("problem"));
    assert_eq!(r.status, DdpStatus::Converged);
    assert!(r.cost_history.windows(2).all(|w| w[1] <= w[0]));
    assert!(r.cost < 0.02 * r.initial_cost);
}

#[test]
fn value_model_predicts_the_cost_of_nearby_starts() {
    // Eq. 1: V(x0 + dx) ~ V0 + Vx dx + dx Vxx dx / 2, checked against re-solving from x0 + dx
    let problem = pendulum_swingup(200).expect("problem");
    let solver = Ddp::new(DdpSettings::default()).expect("settings");
    let r = solver.solve(&problem).expect("solve");
    let dx = [1e-3, -2e-3];
    let x = [r.states[0][0] + dx[0], r.states[0][1] + dx[1]];
    let moved = problem
        .clone()
        .with_initial_state(&x)
        .expect("state")
        .with_initial_controls(r.controls.clone())
        .expect("controls");
    let r2 = solver.solve(&moved).expect("solve");
    assert_eq!(r2.status, DdpStatus::Converged);
    let predicted = r.value_model(0, &x).expect("value model");
    assert!(
        (predicted - r2.cost).abs() < 1e-7 * r2.cost,
        "predicted {predicted}, actual {}",
        r2.cost
    );
    // the gains are the sensitivity of the optimal control to the state
    let u_pred = r.policy(0, &x).expect("policy")[0];
    assert!((u_pred - r2.controls[0][0]).abs() < 1e-4 * (1.0 + u_pred.abs()));
}

#[test]
fn control_limits_are_respected_on_the_swingup() {
    let limit = 3.0; // below m g l: the pendulum must pump
    let problem = pendulum_swingup(400)
        .expect("problem")
        .with_control_limits(&[-limit], &[limit])
        .expect("limits");
    let r = solve(&problem);
    assert_eq!(r.status, DdpStatus::Converged);
    assert!(r.controls.iter().all(|u| u[0].abs() <= limit));
    assert!(
        r.controls.iter().any(|u| u[0].abs() == limit),
        "the limit should be active"
    );
    assert!(r.cost_history.windows(2).all(|w| w[1] <= w[0]));
    let last = &r.states[400];
    assert!((last[0] - std::f64::consts::PI).abs() < 0.05, "{last:?}");
    // controls clamped by the box QP get no feedback (Tassa et al. 2014)
    let clamped_without_feedback = r
        .controls
        .iter()
        .zip(&r.gains)
        .filter(|(u, g)| u[0].abs() == limit && g[(0, 0)] == 0.0 && g[(0, 1)] == 0.0)
        .count();
    assert!(clamped_without_feedback > 0);
}

#[test]
fn a_warm_start_outside_the_limits_is_clamped() {
    let problem = pendulum_swingup(50)
        .expect("problem")
        .with_initial_controls(vec![vec![10.0]; 50])
        .expect("controls")
        .with_control_limits(&[-1.0], &[1.0])
        .expect("limits");
    let r = solve(&problem);
    assert!(r.controls.iter().all(|u| u[0].abs() <= 1.0));
    assert_finite(&r);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// The cost never increases over accepted iterations (random pendulum problems).
    #[test]
    fn cost_never_increases(theta0 in -3.0..3.0f64, omega0 in -3.0..3.0f64, horizon in 20..200usize,
                            r in 1e-4..1e-1f64, damping in 0.0..0.5f64, full_ddp: bool) {
        let cost = QuadraticCost::diagonal(&[0.005, 0.0005], &[r * 0.005], &[25.0, 2.5])
            .expect("cost")
            .with_state_target(&[std::f64::consts::PI, 0.0])
            .expect("target");
        let dynamics = Pendulum { damping, ..Pendulum::default() };
        let problem = DdpProblem::new(dynamics, cost, &[theta0, omega0], horizon).expect("problem");
        let method = if full_ddp { DdpMethod::Ddp } else { DdpMethod::Ilqr };
        let settings = DdpSettings { method, max_iterations: 50, ..DdpSettings::default() };
        let res = solve_with(settings, &problem);
        prop_assert!(res.cost_history.windows(2).all(|w| w[1] <= w[0]), "{:?}", res.cost_history);
        prop_assert!(res.cost <= res.initial_cost);
        let recomputed = problem.rollout_cost(&res.controls).expect("rollout");
        prop_assert!((recomputed - res.cost).abs() <= 1e-9 * res.cost.max(1.0));
        prop_assert!(!res.status.is_failure(), "{:?}", res.status);
    }

    /// With limits on a linear-quadratic problem, every control is inside the
    /// box, the cost is at least the unconstrained optimum, and the solution
    /// is optimal against random feasible perturbations of single controls.
    #[test]
    fn control_limits_are_respected_on_lq_problems(lq in lq_problem(3, 2, 15), frac in 0.1..0.9f64) {
        let umax = lq.riccati.controls.iter().flatten().fold(0.0f64, |a, u| a.max(u.abs()));
        prop_assume!(umax > 1e-3);
        let m = lq.b.ncols();
        let lim = frac * umax;
        let problem = lq.to_ddp_problem().with_control_limits(&vec![-lim; m], &vec![lim; m]).expect("limits");
        let res = solve(&problem);
        prop_assert_eq!(res.status, DdpStatus::Converged);
        prop_assert!(res.controls.iter().flatten().all(|u| u.abs() <= lim));
        prop_assert!(res.cost >= lq.riccati.cost * (1.0 - 1e-12));
        for k in 0..lq.horizon {
            for i in 0..m {
                for delta in [-1e-3, 1e-3] {
                    let mut us = res.controls.clone();
                    us[k][i] = (us[k][i] + delta).clamp(-lim, lim);
                    let c = problem.rollout_cost(&us).expect("rollout");
                    prop_assert!(c >= res.cost - 1e-9 * (1.0 + res.cost), "k={k} i={i}: {c} < {}", res.cost);
                }
            }
        }
    }
}
