//! Support shared by the integration tests: wrappers that forward a
//! problem's traits, the benchmark pendulum with hooks, the benchmark's
//! sampling and bases around any model, and checks of solves.

// each test binary uses a part of this module
#![allow(dead_code)]

use proptest::prelude::*;
use splines::BSplineBasis;
use trajopt::ModelResult;
use trajopt::problems::{HandPendulum, PENDULUM_DT};
use trajopt::{
    Dynamics, Eq3Problem, GaussNewton, GaussNewtonResult, GaussNewtonSettings, Lambda, LeastSquaresProblem, Result,
    StageCost, StepModel, TrackingCost,
};

/// The required methods of [`LeastSquaresProblem`], forwarded to the
/// field `$inner` (in an `impl LeastSquaresProblem` block, whose other
/// methods are the wrapper's own); with `band_form`, also the wrapper's
/// own band form.
#[allow(unused_macros)]
macro_rules! forward_least_squares {
    ($inner:tt) => {
        fn n_params(&self) -> usize {
            self.$inner.n_params()
        }
        fn n_residuals(&self) -> usize {
            self.$inner.n_residuals()
        }
        fn residuals(&self, theta: &[f64], r: &mut [f64]) -> trajopt::Result<()> {
            self.$inner.residuals(theta, r)
        }
        fn jacobian_pattern(&self) -> faer::sparse::SymbolicSparseRowMat<usize> {
            self.$inner.jacobian_pattern()
        }
        fn jacobian_values(&self, theta: &[f64], values: &mut [f64]) -> trajopt::Result<()> {
            self.$inner.jacobian_values(theta, values)
        }
    };
    ($inner:tt, band_form) => {
        forward_least_squares!($inner);
        fn band_form(&self) -> Option<&dyn trajopt::BandForm> {
            Some(self)
        }
    };
}
#[allow(unused_imports)]
pub(crate) use forward_least_squares;

/// The required methods of [`trajopt::BandForm`], forwarded to the field
/// `$inner` (in an `impl BandForm` block).
#[allow(unused_macros)]
macro_rules! forward_band_form {
    ($inner:tt) => {
        fn layout(&self) -> trajopt::linalg::BandLayout {
            self.$inner.layout()
        }
        fn normal_equations(
            &self,
            at: trajopt::Point<'_>,
            layout: &trajopt::linalg::BandLayout,
            out: trajopt::BandNormalEquations<'_>,
        ) -> trajopt::Result<bool> {
            self.$inner.normal_equations(at, layout, out)
        }
    };
}
#[allow(unused_imports)]
pub(crate) use forward_band_form;

/// The benchmark pendulum with hooks: `before_jacobians` sees the states
/// of each call for Jacobians (one state, or a batch, row-major) before
/// they are evaluated, and its error is the model's; `hessian` alters the
/// weighted second derivatives at a state and says whether the model has
/// them.
pub(crate) struct Hooked<J, H> {
    pub(crate) inner: HandPendulum,
    pub(crate) before_jacobians: J,
    pub(crate) hessian: H,
}

/// No hook before the Jacobians.
pub(crate) type Unchecked = fn(&[f64]) -> ModelResult<()>;

/// A hook that leaves the second derivatives as they are.
pub(crate) type Unaltered = fn(&[f64], &mut [f64]) -> bool;

impl<J: Fn(&[f64]) -> ModelResult<()>> Hooked<J, Unaltered> {
    /// The pendulum with a hook before its Jacobians.
    pub(crate) fn before_jacobians(before_jacobians: J) -> Self {
        Self {
            inner: HandPendulum::default(),
            before_jacobians,
            hessian: |_, _| true,
        }
    }
}

impl<H: Fn(&[f64], &mut [f64]) -> bool> Hooked<Unchecked, H> {
    /// The pendulum with its second derivatives altered by `hessian`.
    pub(crate) fn hessian(hessian: H) -> Self {
        Self {
            inner: HandPendulum::default(),
            before_jacobians: |_| Ok(()),
            hessian,
        }
    }
}

impl<J: Fn(&[f64]) -> ModelResult<()>, H: Fn(&[f64], &mut [f64]) -> bool> Dynamics for Hooked<J, H> {
    fn state_dim(&self) -> usize {
        4
    }
    fn control_dim(&self) -> usize {
        1
    }
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        self.inner.step(x, u, next)
    }
    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        (self.before_jacobians)(x)?;
        self.inner.jacobians(x, u, fx, fu)
    }
    fn jacobians_batch(&self, xs: &[f64], us: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        (self.before_jacobians)(xs)?;
        self.inner.jacobians_batch(xs, us, fx, fu)
    }
    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        self.inner.jacobian_structure(fx, fu)
    }
    fn weighted_hessian(&self, x: &[f64], u: &[f64], w: &[f64], hess: &mut [f64]) -> ModelResult<bool> {
        self.inner.weighted_hessian(x, u, w, hess)?;
        Ok((self.hessian)(x, hess))
    }
}

/// Eq. 3 with `model` on the benchmark swing-up's sampling and bases
/// (`horizon` steps at 60 Hz, cubic clamped B-splines with `horizon / 6 + 4`
/// state and `horizon / 8 + 4` control coefficients per channel), the
/// task `cost` and a constant `lambda`.
pub(crate) fn swingup_problem<M: Dynamics>(
    horizon: usize,
    model: M,
    cost: TrackingCost,
    lambda: f64,
) -> Result<Eq3Problem<M, TrackingCost>> {
    let times: Vec<f64> = (0..=horizon).map(|k| k as f64 * PENDULUM_DT).collect();
    let state_basis = BSplineBasis::clamped_uniform(horizon / 6 + 4, 3, 0.0, times[horizon])?;
    let control_basis = BSplineBasis::clamped_uniform(horizon / 8 + 4, 3, 0.0, times[horizon])?;
    Eq3Problem::new(
        model,
        cost,
        &state_basis,
        &control_basis,
        &times,
        Lambda::Constant(lambda),
    )
}

/// Solves `p` from `theta` with the default settings but `step_model`.
pub(crate) fn solve_in<P: LeastSquaresProblem + ?Sized>(
    step_model: StepModel,
    p: &P,
    theta: &[f64],
) -> Result<GaussNewtonResult> {
    GaussNewton::new(GaussNewtonSettings {
        step_model,
        ..GaussNewtonSettings::default()
    })?
    .solve(p, theta)
}

/// Solves `p` from `theta` in `step_model`, 30 iterations at most, and
/// checks the solve: no accepted step raised the cost, and the cost
/// reported is the problem's at the point reported.
pub(crate) fn check_descent<M: Dynamics, C: StageCost>(
    p: &Eq3Problem<M, C>,
    theta: &[f64],
    step_model: StepModel,
) -> std::result::Result<(), TestCaseError> {
    let settings = GaussNewtonSettings {
        max_iterations: 30,
        step_model,
        ..GaussNewtonSettings::default()
    };
    let res = GaussNewton::new(settings)
        .expect("settings")
        .solve(p, theta)
        .expect("solve");
    prop_assert!(res.cost <= res.initial_cost);
    prop_assert!(res.cost_history.windows(2).all(|w| w[1] <= w[0]));
    prop_assert!((p.cost(&res.x).expect("cost") - res.cost).abs() <= 1e-9 * res.cost.max(1.0));
    Ok(())
}

/// Asserts that `a` and `b` both converged, to costs within `rel` of `b`'s.
#[track_caller]
pub(crate) fn assert_same_minimum(a: &GaussNewtonResult, b: &GaussNewtonResult, rel: f64, what: &str) {
    assert!(
        a.status.is_converged() && b.status.is_converged(),
        "{what}: {:?} {:?}",
        a.status,
        b.status
    );
    assert_rel_close(a.cost, b.cost, rel, what);
}

/// Asserts that `a` is within `rel` of `b` (relative to `b`).
#[track_caller]
pub(crate) fn assert_rel_close(a: f64, b: f64, rel: f64, what: &str) {
    assert!((a - b).abs() <= rel * b, "{what}: {a} vs {b}");
}

/// Asserts that `a` and `b` took numbers of iterations at most `max_diff`
/// apart.
#[track_caller]
pub(crate) fn assert_iterations_close(a: &GaussNewtonResult, b: &GaussNewtonResult, max_diff: usize, what: &str) {
    assert!(
        a.iterations.abs_diff(b.iterations) <= max_diff,
        "{what}: {} vs {} iterations",
        a.iterations,
        b.iterations
    );
}
