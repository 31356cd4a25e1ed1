//! The paper's point 2: integrating a learned model forward can blow up.
//! The solver reports it as a status and never returns NaNs.

use ddp::{
    Cost, CostDerivatives, Ddp, DdpError, DdpProblem, DdpResult, DdpSettings, DdpStatus, Dynamics, ModelResult,
    QuadraticCost,
};

mod common;
use common::{solve, solve_with};

/// $x_{k+1} = a x_k + u_k$ in one dimension, optionally lying about its
/// derivatives or exploding outside $|x| < r$.
struct Scalar {
    a: f64,
    /// Reported $f_u$ (the true one is 1).
    reported_fu: f64,
    /// Outside this radius the "learned" model returns garbage growing like exp(x^2).
    radius: f64,
}

impl Dynamics for Scalar {
    fn state_dim(&self) -> usize {
        1
    }
    fn control_dim(&self) -> usize {
        1
    }
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        let out = (x[0].abs() - self.radius).max(0.0);
        next[0] = self.a * x[0] + u[0] + (out * 50.0).exp() - 1.0;
        Ok(())
    }
    fn jacobians(&self, x: &[f64], _u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        let out = (x[0].abs() - self.radius).max(0.0);
        fx[0] = self.a
            + if out > 0.0 {
                50.0 * (out * 50.0).exp() * x[0].signum()
            } else {
                0.0
            };
        fu[0] = self.reported_fu;
        Ok(true)
    }
}

/// $\tfrac12 (x - target)^2 + \tfrac{r}{2} u^2$ per step, $5 (x_N - target)^2$ at the end.
fn tracking(target: f64, r: f64) -> QuadraticCost {
    QuadraticCost::diagonal(&[0.5], &[0.5 * r], &[5.0])
        .expect("cost")
        .with_state_target(&[target])
        .expect("target")
}

fn assert_no_nans(r: &DdpResult) {
    let all = r
        .states
        .iter()
        .flatten()
        .chain(r.controls.iter().flatten())
        .chain(r.feedforward.iter().flatten())
        .chain(r.value_gradient.iter().flatten())
        .chain(&r.value)
        .chain(&r.cost_history);
    for v in all {
        assert!(!v.is_nan());
    }
    for g in r.gains.iter().chain(&r.value_hessian) {
        for j in 0..g.ncols() {
            for i in 0..g.nrows() {
                assert!(g[(i, j)].is_finite());
            }
        }
    }
}

#[test]
fn an_unstable_model_blows_up_the_initial_rollout() {
    let model = Scalar {
        a: 3.0,
        reported_fu: 1.0,
        radius: f64::INFINITY,
    };
    let problem = DdpProblem::new(model, tracking(0.0, 1e-8), &[1.0], 100).expect("problem");
    let r = solve(&problem);
    // 3^17 > 1e8 = max_state_norm
    assert_eq!(r.status, DdpStatus::InitialRolloutDiverged { step: 17 });
    assert!(r.status.is_failure());
    assert_eq!(r.states.len(), 17);
    assert!(r.gains.is_empty());
    assert_no_nans(&r);
    assert!(r.states.iter().flatten().all(|v| v.is_finite()));
}

#[test]
fn a_stabilising_warm_start_lets_ddp_control_the_unstable_model() {
    // the same model from a warm start that keeps it near zero (u = -3 x on the nominal path)
    let model = Scalar {
        a: 3.0,
        reported_fu: 1.0,
        radius: f64::INFINITY,
    };
    let mut controls = vec![vec![-3.0]];
    controls.extend(std::iter::repeat_n(vec![0.0], 99));
    let problem = DdpProblem::new(model, tracking(0.0, 1e-8), &[1.0], 100)
        .expect("problem")
        .with_initial_controls(controls)
        .expect("controls");
    let r = solve(&problem);
    assert_eq!(r.status, DdpStatus::Converged);
    assert!(r.cost < 1.0 + 1e-6);
    assert_no_nans(&r);
}

#[test]
fn a_model_exploding_outside_its_data_is_never_exploited_into_nans() {
    // the target lies outside the region where the "learned" model is sane
    let model = Scalar {
        a: 1.0,
        reported_fu: 1.0,
        radius: 1.0,
    };
    let problem = DdpProblem::new(model, tracking(5.0, 1e-3), &[0.0], 30).expect("problem");
    let r = solve(&problem);
    assert_no_nans(&r);
    assert!(r.cost_history.windows(2).all(|w| w[1] <= w[0]));
    assert!(r.cost < r.initial_cost);
    assert!(r.states.iter().flatten().all(|x| x.abs() < 2.0), "{:?}", r.states);
    // the optimiser keeps pushing towards the target; every trial rollout beyond the region blows up
    assert_eq!(r.status, DdpStatus::RolloutDiverged);
}

#[test]
fn wrong_model_derivatives_end_in_no_descent() {
    let model = Scalar {
        a: 1.0,
        reported_fu: -1.0,
        radius: f64::INFINITY,
    };
    let problem = DdpProblem::new(model, tracking(1.0, 1e-2), &[0.0], 20).expect("problem");
    let r = solve(&problem);
    assert_eq!(r.status, DdpStatus::NoDescent);
    assert_eq!(r.cost, r.initial_cost);
    assert_no_nans(&r);
}

#[test]
fn an_indefinite_cost_ends_in_not_positive_definite() {
    let model = Scalar {
        a: 1.0,
        reported_fu: 1.0,
        radius: f64::INFINITY,
    };
    // concave in u, and the regularisation may not exceed 1
    let cost = QuadraticCost::diagonal(&[0.5], &[-0.5e3], &[0.5]).expect("cost");
    let problem = DdpProblem::new(model, cost, &[1.0], 10).expect("problem");
    let settings = DdpSettings {
        reg_max: 1.0,
        ..DdpSettings::default()
    };
    let r = solve_with(settings, &problem);
    assert_eq!(r.status, DdpStatus::NotPositiveDefinite);
    assert!(r.gains.is_empty());
    assert_no_nans(&r);
}

/// A cost that returns NaN derivatives away from the origin.
struct NanCost;

impl Cost for NanCost {
    fn running(&self, _k: usize, x: &[f64], u: &[f64]) -> f64 {
        x[0] * x[0] + u[0] * u[0]
    }
    fn running_derivatives(&self, _k: usize, x: &[f64], u: &[f64], d: &mut CostDerivatives) {
        d.lx[0] = if x[0] > 0.5 { f64::NAN } else { 2.0 * x[0] };
        d.lu[0] = 2.0 * u[0];
        d.lxx[0] = 2.0;
        d.luu[0] = 2.0;
    }
    fn terminal(&self, x: &[f64]) -> f64 {
        x[0] * x[0]
    }
    fn terminal_derivatives(&self, x: &[f64], lx: &mut [f64], lxx: &mut [f64]) {
        lx[0] = 2.0 * x[0];
        lxx[0] = 2.0;
    }
}

#[test]
fn non_finite_derivatives_are_a_status() {
    let model = Scalar {
        a: 1.0,
        reported_fu: 1.0,
        radius: f64::INFINITY,
    };
    let problem = DdpProblem::new(model, NanCost, &[1.0], 10).expect("problem");
    let r = solve(&problem);
    assert_eq!(r.status, DdpStatus::NonFiniteDerivatives);
    assert_eq!(r.iterations, 0);
    assert_no_nans(&r);
}

/// A "learned" model that only saw zero controls: any other control sends it
/// to infinity.
fn only_knows_zero(x: f64, u: f64) -> ModelResult<f64> {
    Ok(if u == 0.0 { x } else { f64::INFINITY })
}

#[test]
fn every_trial_rollout_blowing_up_is_rollout_diverged() {
    let problem = DdpProblem::new(Unit(only_knows_zero), tracking(1.0, 1e-2), &[0.0], 20).expect("problem");
    let r = solve(&problem);
    assert_eq!(r.status, DdpStatus::RolloutDiverged);
    assert_eq!(r.cost, r.initial_cost);
    assert!(r.states.iter().flatten().all(|x| *x == 0.0));
    assert_no_nans(&r);
}

/// A model $x_{k+1} = x_k + u_k$ that refuses (returns an error) outside
/// $|x| \le 1$.
fn refuses(x: f64, u: f64) -> ModelResult<f64> {
    if x.abs() > 1.0 {
        return Err(ddp::ModelError::new(format!("no data at x = {x}")));
    }
    Ok(x + u)
}

/// A one-dimensional model $x_{k+1} = $ `step(x_k, u_k)` that reports the
/// Jacobians $f_x = f_u = 1$ (exact for [`refuses`] where it answers).
struct Unit<F>(F);

impl<F: Fn(f64, f64) -> ModelResult<f64>> Dynamics for Unit<F> {
    fn state_dim(&self) -> usize {
        1
    }
    fn control_dim(&self) -> usize {
        1
    }
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        next[0] = (self.0)(x[0], u[0])?;
        Ok(())
    }
    fn jacobians(&self, _x: &[f64], _u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        fx[0] = 1.0;
        fu[0] = 1.0;
        Ok(true)
    }
}

#[test]
fn a_failed_step_in_the_line_search_is_a_diverged_trial() {
    // the target lies outside the region where the model answers
    let problem = DdpProblem::new(Unit(refuses), tracking(5.0, 1e-3), &[0.0], 30).expect("problem");
    let r = Ddp::new(DdpSettings::default())
        .expect("settings")
        .solve(&problem)
        .expect("the warm start's rollout succeeds");
    assert_no_nans(&r);
    assert!(r.cost < r.initial_cost, "{} vs {}", r.cost, r.initial_cost);
    assert!(r.cost_history.windows(2).all(|w| w[1] <= w[0]));
    // every returned state is one the model answered for (it may step from
    // x = 1 to beyond it only at the last step)
    assert!(
        r.states[..30].iter().flatten().all(|x| x.abs() <= 1.0),
        "{:?}",
        r.states
    );
    assert_eq!(r.status, DdpStatus::RolloutDiverged);
}

#[test]
fn a_failed_step_in_the_warm_start_is_an_error() {
    let problem = DdpProblem::new(Unit(refuses), tracking(0.0, 1e-3), &[0.5], 10)
        .expect("problem")
        .with_initial_controls(vec![vec![1.0]; 10])
        .expect("controls");
    let e = Ddp::new(DdpSettings::default())
        .expect("settings")
        .solve(&problem)
        .expect_err("x leaves the model's region at step 1");
    assert!(matches!(e, DdpError::Model(ref m) if m.contains("x = 1.5")), "{e}");
    assert!(problem.rollout_cost(problem.initial_controls()).is_err());
}

#[test]
fn default_derivatives_let_ddp_solve_a_tracking_problem() {
    // inside the model's region the default (differenced) Jacobians are exact
    let problem = DdpProblem::new(systems::StepOnly(Unit(refuses)), tracking(0.8, 1e-2), &[0.0], 20).expect("problem");
    let r = solve(&problem);
    assert_eq!(r.status, DdpStatus::Converged);
    // a linear-quadratic problem: one Newton step, the same plan as with
    // the analytic Jacobians
    assert!(r.iterations <= 2, "{} iterations", r.iterations);
    let exact = DdpProblem::new(Unit(refuses), tracking(0.8, 1e-2), &[0.0], 20).expect("problem");
    let r_exact = solve(&exact);
    assert!((r.cost - r_exact.cost).abs() <= 1e-9 * r_exact.cost);
    for (a, b) in r.controls.iter().zip(&r_exact.controls) {
        assert!((a[0] - b[0]).abs() < 1e-7, "{a:?} vs {b:?}");
    }
}
