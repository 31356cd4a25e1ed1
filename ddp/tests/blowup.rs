//! The paper's point 2: integrating a learned model forward can blow up.
//! The solver reports it as a status and never returns NaNs.

use ddp::{Cost, CostDerivatives, Ddp, DdpProblem, DdpResult, DdpSettings, DdpStatus, Dynamics, QuadraticCost};

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
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) {
        let out = (x[0].abs() - self.radius).max(0.0);
        next[0] = self.a * x[0] + u[0] + (out * 50.0).exp() - 1.0;
    }
    fn derivatives(&self, x: &[f64], _u: &[f64], fx: &mut [f64], fu: &mut [f64]) {
        let out = (x[0].abs() - self.radius).max(0.0);
        fx[0] = self.a
            + if out > 0.0 {
                50.0 * (out * 50.0).exp() * x[0].signum()
            } else {
                0.0
            };
        fu[0] = self.reported_fu;
    }
}

fn tracking(target: f64, r: f64) -> QuadraticCost {
    QuadraticCost::diagonal(&[1.0], &[r], &[10.0])
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
        .chain(&r.costs);
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
    let r = Ddp::new(DdpSettings::default())
        .expect("settings")
        .solve(&problem)
        .expect("solve");
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
    let r = Ddp::new(DdpSettings::default())
        .expect("settings")
        .solve(&problem)
        .expect("solve");
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
    let r = Ddp::new(DdpSettings::default())
        .expect("settings")
        .solve(&problem)
        .expect("solve");
    assert_no_nans(&r);
    assert!(r.costs.windows(2).all(|w| w[1] <= w[0]));
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
    let r = Ddp::new(DdpSettings::default())
        .expect("settings")
        .solve(&problem)
        .expect("solve");
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
    let cost = QuadraticCost::diagonal(&[1.0], &[-1e3], &[1.0]).expect("cost");
    let problem = DdpProblem::new(model, cost, &[1.0], 10).expect("problem");
    let settings = DdpSettings {
        reg_max: 1.0,
        ..DdpSettings::default()
    };
    let r = Ddp::new(settings).expect("settings").solve(&problem).expect("solve");
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
    let r = Ddp::new(DdpSettings::default())
        .expect("settings")
        .solve(&problem)
        .expect("solve");
    assert_eq!(r.status, DdpStatus::NonFiniteDerivatives);
    assert_eq!(r.iterations, 0);
    assert_no_nans(&r);
}

/// A "learned" model that only saw zero controls: any other control sends it
/// to infinity.
struct OnlyKnowsZero;

impl Dynamics for OnlyKnowsZero {
    fn state_dim(&self) -> usize {
        1
    }
    fn control_dim(&self) -> usize {
        1
    }
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) {
        next[0] = if u[0] == 0.0 { x[0] } else { f64::INFINITY };
    }
    fn derivatives(&self, _x: &[f64], _u: &[f64], fx: &mut [f64], fu: &mut [f64]) {
        fx[0] = 1.0;
        fu[0] = 1.0;
    }
}

#[test]
fn every_trial_rollout_blowing_up_is_rollout_diverged() {
    let problem = DdpProblem::new(OnlyKnowsZero, tracking(1.0, 1e-2), &[0.0], 20).expect("problem");
    let r = Ddp::new(DdpSettings::default())
        .expect("settings")
        .solve(&problem)
        .expect("solve");
    assert_eq!(r.status, DdpStatus::RolloutDiverged);
    assert_eq!(r.cost, r.initial_cost);
    assert!(r.states.iter().flatten().all(|x| *x == 0.0));
    assert_no_nans(&r);
}
