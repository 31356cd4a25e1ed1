//! Eq. 3 and the sparse Gauss-Newton / Levenberg-Marquardt solver.

mod common;

use common::{assert_iterations_close, assert_rel_close, assert_same_minimum, check_descent};
use faer::Mat;
use faer::prelude::*;
use faer::sparse::{SparseRowMat, SymbolicSparseRowMat};
use proptest::prelude::*;
use splines::{BSplineBasis, TrajectoryBasis};
use trajopt::ModelResult;
use trajopt::{
    Dynamics, Eq3Problem, GaussNewton, GaussNewtonSettings, Lambda, LeastSquaresProblem, LinearLeastSquares,
    LinearModel, LinearSolver, Result, StepModel, TrackingCost, TrajoptError,
};

const DT: f64 = 1.0 / 60.0;

/// A damped pendulum on a moving pivot, semi-implicit Euler, with exact
/// Jacobians (or none, to exercise the finite-difference path).
struct Pendulum {
    analytic: bool,
}

impl Dynamics for Pendulum {
    fn state_dim(&self) -> usize {
        2
    }
    fn control_dim(&self) -> usize {
        1
    }
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        let acc = -(9.81 / 0.5) * x[0].sin() - (u[0] / 0.5) * x[0].cos() - 0.1 * x[1];
        next[1] = x[1] + DT * acc;
        next[0] = x[0] + DT * next[1];
        Ok(())
    }
    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        if !self.analytic {
            return Ok(false);
        }
        let da_dth = -(9.81 / 0.5) * x[0].cos() + (u[0] / 0.5) * x[0].sin();
        let da_du = -x[0].cos() / 0.5;
        // next[1] = x1 + dt acc; next[0] = x0 + dt next[1]
        let (v_th, v_om, v_u) = (DT * da_dth, 1.0 - 0.1 * DT, DT * da_du);
        fx.copy_from_slice(&[1.0 + DT * v_th, DT * v_om, v_th, v_om]);
        fu.copy_from_slice(&[DT * v_u, v_u]);
        Ok(true)
    }
}

/// Tracking a reference from hanging to upright over `horizon` steps.
fn plain_cost(horizon: usize) -> TrackingCost {
    let t_end = horizon as f64 * DT;
    let state_ref = Mat::from_fn(horizon + 1, 2, |k, i| {
        let s = k as f64 / horizon as f64;
        if i == 0 {
            std::f64::consts::PI * s * s
        } else {
            2.0 * std::f64::consts::PI * s / t_end
        }
    });
    let control_ref = Mat::zeros(horizon, 1);
    TrackingCost::new(state_ref, control_ref, &[1.0, 0.1], &[0.01], &[100.0, 10.0]).expect("valid cost")
}

/// A swing-up-like problem: track a reference from hanging to upright.
fn pendulum_problem(
    horizon: usize,
    lambda: Lambda,
    analytic: bool,
) -> (Eq3Problem<Pendulum, TrackingCost>, BSplineBasis, BSplineBasis, Vec<f64>) {
    let times: Vec<f64> = (0..=horizon).map(|k| k as f64 * DT).collect();
    let t_end = times[horizon];
    let cost = plain_cost(horizon);
    let xb = BSplineBasis::clamped_uniform(12, 3, 0.0, t_end).expect("basis");
    let ub = BSplineBasis::clamped_uniform(10, 3, 0.0, t_end).expect("basis");
    let problem = Eq3Problem::new(Pendulum { analytic }, cost, &xb, &ub, &times, lambda).expect("valid problem");
    (problem, xb, ub, times)
}

fn theta_guess(p: &Eq3Problem<Pendulum, TrackingCost>) -> Vec<f64> {
    (0..p.n_params()).map(|i| 0.1 * ((i as f64) * 0.7).sin()).collect()
}

#[test]
fn jacobian_equals_finite_differences() {
    for analytic in [true, false] {
        let (p, ..) = pendulum_problem(30, Lambda::Constant(50.0), analytic);
        let p = p.with_consistency_scale(1.0 / DT).expect("scale");
        let theta = theta_guess(&p);
        let worst = trajopt::check_jacobian(&p, &theta).expect("check");
        assert!(worst.max_rel_error < 1e-5, "analytic={analytic}: {worst:?}");
    }
}

#[test]
fn linear_least_squares_in_one_step() {
    // a random-ish sparse tall matrix
    let (m, n) = (40, 12);
    let mut row_ptr = vec![0];
    let mut cols = Vec::new();
    let mut vals = Vec::new();
    for i in 0..m {
        let mut row: Vec<usize> = vec![i % n, (3 * i + 1) % n, (7 * i + 5) % n];
        row.sort_unstable();
        row.dedup();
        for &c in &row {
            cols.push(c);
            vals.push(1.0 + ((i * 31 + c * 17) % 13) as f64 / 7.0);
        }
        row_ptr.push(cols.len());
    }
    let a = SparseRowMat::new(SymbolicSparseRowMat::new_checked(m, n, row_ptr, None, cols), vals);
    let b: Vec<f64> = (0..m).map(|i| ((i * 7) % 11) as f64 - 5.0).collect();
    let dense = a.to_dense();
    let problem = LinearLeastSquares::new(a, b.clone()).expect("valid");
    // closed form: A^T A x = A^T b
    let ata = dense.transpose() * &dense;
    let atb = dense.transpose() * Mat::from_fn(m, 1, |i, _| b[i]);
    let x = ata.llt(faer::Side::Lower).expect("spd").solve(&atb);
    let settings = GaussNewtonSettings {
        initial_damping: 0.0,
        ..GaussNewtonSettings::default()
    };
    let res = GaussNewton::new(settings)
        .expect("settings")
        .solve(&problem, &vec![3.0; n])
        .expect("solve");
    assert!(res.status.is_converged(), "{:?}", res.status);
    assert!(res.iterations <= 2, "took {} iterations", res.iterations);
    let mut r = vec![0.0; m];
    problem.residuals(&res.x, &mut r).expect("r");
    let optimal: f64 = r.iter().map(|v| v * v).sum();
    assert!(
        (res.cost_history[0] - optimal).abs() <= 1e-10 * optimal.max(1.0),
        "first step is the GN step"
    );
    for j in 0..n {
        assert!((res.x[j] - x[(j, 0)]).abs() < 1e-9);
    }
}

#[test]
fn large_lambda_enforces_dynamics_and_zero_lambda_ignores_them() {
    let solver = GaussNewton::new(GaussNewtonSettings::default()).expect("settings");
    let mut mismatches = Vec::new();
    for lambda in [1e2, 1e4, 1e6] {
        let (p, ..) = pendulum_problem(60, Lambda::Constant(lambda), true);
        let res = solver.solve(&p, &theta_guess(&p)).expect("solve");
        assert!(res.cost <= res.initial_cost);
        let parts = p.cost_breakdown(&res.x).expect("cost");
        mismatches.push(parts.max_mismatch);
    }
    // each 100x in lambda cuts the largest mismatch at least 5x
    assert!(mismatches.windows(2).all(|w| w[1] < 0.2 * w[0]), "{mismatches:?}");
    assert!(mismatches[2] < 2e-3, "{mismatches:?}");

    // lambda = 0: the plan is the task cost's own minimiser (reference fit)
    let (p, xb, ..) = pendulum_problem(60, Lambda::Constant(0.0), true);
    let res = solver.solve(&p, &theta_guess(&p)).expect("solve");
    let parts = p.cost_breakdown(&res.x).expect("cost");
    assert_eq!(parts.inconsistency, 0.0);
    // the same optimum as minimising the task cost alone: controls go to their
    // reference (zero) and the states to a weighted fit of the reference
    let (x, u) = p.trajectory(&res.x).expect("traj");
    assert!((0..u.nrows()).all(|k| u[(k, 0)].abs() < 1e-6));
    assert!(parts.task < 1e-2, "task {}", parts.task);
    assert_eq!(xb.n_coeffs(), p.n_state_coeffs());
    assert!((x[(60, 0)] - std::f64::consts::PI).abs() < 0.05);
}

#[test]
fn zero_lambda_at_one_step_frees_only_that_step() {
    // degree-1 B-splines with a knot at every sample: x_k is its own coefficient
    let n_steps = 20;
    let times: Vec<f64> = (0..=n_steps).map(|k| k as f64 * 0.1).collect();
    let basis_x = BSplineBasis::clamped(&times, 1).expect("basis");
    let basis_u = BSplineBasis::clamped(&times, 1).expect("basis");
    // integrator x+ = x + 0.1 u, reference asks for a jump the controls cannot make cheaply
    let model = LinearModel::new(Mat::from_fn(1, 1, |_, _| 1.0), Mat::from_fn(1, 1, |_, _| 0.1)).expect("model");
    let state_ref = Mat::from_fn(n_steps + 1, 1, |k, _| if k > 10 { 1.0 } else { 0.0 });
    let cost = TrackingCost::new(state_ref, Mat::zeros(n_steps, 1), &[1.0], &[1.0], &[1.0]).expect("cost");
    let mut lambda = vec![1e8; n_steps];
    lambda[10] = 0.0;
    let p = Eq3Problem::new(model.clone(), cost, &basis_x, &basis_u, &times, Lambda::PerStep(lambda)).expect("p");
    let res = GaussNewton::new(GaussNewtonSettings::default())
        .expect("settings")
        .solve(&p, &vec![0.0; p.n_params()])
        .expect("solve");
    let (x, u) = p.trajectory(&res.x).expect("traj");
    let mut next = [0.0];
    for k in 0..n_steps {
        model.step(&[x[(k, 0)]], &[u[(k, 0)]], &mut next).expect("step");
        let mismatch = (x[(k + 1, 0)] - next[0]).abs();
        if k == 10 {
            assert!(mismatch > 0.5, "the freed step jumps: {mismatch}");
        } else {
            assert!(mismatch < 1e-3, "step {k} mismatch {mismatch}");
        }
    }
}

#[test]
fn bad_input_gives_errors() {
    let (p, xb, ub, times) = pendulum_problem(10, Lambda::Constant(1.0), true);
    assert!(matches!(
        GaussNewton::new(GaussNewtonSettings::default())
            .expect("ok")
            .solve(&p, &[0.0; 3]),
        Err(TrajoptError::DimensionMismatch { .. })
    ));
    let mut nan = theta_guess(&p);
    nan[0] = f64::NAN;
    assert!(matches!(
        GaussNewton::new(GaussNewtonSettings::default())
            .expect("ok")
            .solve(&p, &nan),
        Err(TrajoptError::NotFinite { .. })
    ));
    let bad_ref = Mat::from_fn(11, 2, |k, _| if k == 3 { f64::NAN } else { 0.0 });
    assert!(matches!(
        TrackingCost::new(bad_ref, Mat::zeros(10, 1), &[1.0, 1.0], &[1.0], &[1.0, 1.0]),
        Err(TrajoptError::NotFinite { .. })
    ));
    let cost = TrackingCost::new(Mat::zeros(11, 2), Mat::zeros(10, 1), &[1.0, 1.0], &[1.0], &[1.0, 1.0]).expect("ok");
    let with_lambda = |lambda| Eq3Problem::new(Pendulum { analytic: true }, cost.clone(), &xb, &ub, &times, lambda);
    assert!(matches!(
        with_lambda(Lambda::Constant(-1.0)),
        Err(TrajoptError::InvalidParameter { name: "lambda", .. })
    ));
    assert!(matches!(
        with_lambda(Lambda::PerStep(vec![1.0; 3])),
        Err(TrajoptError::DimensionMismatch { .. })
    ));
    assert!(matches!(
        GaussNewton::new(GaussNewtonSettings {
            tol_grad: f64::NAN,
            ..GaussNewtonSettings::default()
        }),
        Err(TrajoptError::InvalidParameter { .. })
    ));

    /// A model that returns NaN beyond |theta| > 1: the solver must not step there.
    struct Cliff;
    impl Dynamics for Cliff {
        fn state_dim(&self) -> usize {
            2
        }
        fn control_dim(&self) -> usize {
            1
        }
        fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
            next[0] = if x[0].abs() > 1.0 { f64::NAN } else { x[0] + DT * x[1] };
            next[1] = x[1] + DT * u[0];
            Ok(())
        }
    }
    let state_ref = Mat::from_fn(11, 2, |k, i| if i == 0 { 3.0 * k as f64 / 10.0 } else { 0.0 });
    let cost = TrackingCost::new(state_ref, Mat::zeros(10, 1), &[1.0, 1.0], &[1.0], &[1.0, 1.0]).expect("ok");
    let p = Eq3Problem::new(Cliff, cost, &xb, &ub, &times, Lambda::Constant(10.0)).expect("p");
    let res = GaussNewton::new(GaussNewtonSettings::default())
        .expect("ok")
        .solve(&p, &vec![0.0; p.n_params()])
        .expect("a status, not an error");
    assert!(res.cost.is_finite() && res.cost <= res.initial_cost);
    // starting in the NaN region is an error: nothing to improve on
    let start: Vec<f64> = vec![2.0; p.n_params()];
    assert!(matches!(
        GaussNewton::new(GaussNewtonSettings::default())
            .expect("ok")
            .solve(&p, &start),
        Err(TrajoptError::NonFiniteStart { .. })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn gauss_newton_never_increases_the_cost(
        lambda in prop_oneof![Just(0.0), 1e-2..1e6f64],
        seed in 0u32..1000,
        horizon in 5usize..40,
    ) {
        let (p, ..) = pendulum_problem(horizon, Lambda::Constant(lambda), seed % 2 == 0);
        let theta: Vec<f64> = (0..p.n_params()).map(|i| ((i as f64 + seed as f64) * 1.3).sin()).collect();
        check_descent(&p, &theta, StepModel::GaussNewton)?;
    }
}

mod known_solutions {
    use super::*;
    use trajopt::strategies::{linear_least_squares, linear_soft_dynamics};

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn gauss_newton_solves_linear_least_squares_in_one_step((problem, solution) in linear_least_squares(12)) {
            let settings = GaussNewtonSettings { initial_damping: 0.0, ..GaussNewtonSettings::default() };
            let res = GaussNewton::new(settings).expect("settings").solve(&problem, &vec![0.0; problem.n_params()]).expect("solve");
            prop_assert!(res.status.is_converged(), "{:?}", res.status);
            prop_assert!(res.cost_history.len() <= 2, "{} accepted steps", res.cost_history.len());
            for (a, b) in res.x.iter().zip(&solution) {
                prop_assert!((a - b).abs() <= 1e-8 * b.abs().max(1.0), "{a} vs {b}");
            }
        }

        #[test]
        fn gauss_newton_finds_the_consistent_optimum((problem, optimum) in linear_soft_dynamics()) {
            // zero task cost and zero inconsistency at the known optimum
            let parts = problem.cost_breakdown(&optimum).expect("cost");
            prop_assert!(parts.total < 1e-20, "{parts:?}");
            let res = GaussNewton::new(GaussNewtonSettings::default())
                .expect("settings")
                .solve(&problem, &vec![0.0; problem.n_params()])
                .expect("solve");
            prop_assert!(res.cost < 1e-12 * res.initial_cost.max(1.0), "cost {} from {}", res.cost, res.initial_cost);
            let (x, _) = problem.trajectory(&res.x).expect("trajectory");
            let (xs, _) = problem.trajectory(&optimum).expect("trajectory");
            for k in 0..x.nrows() {
                for i in 0..x.ncols() {
                    prop_assert!((x[(k, i)] - xs[(k, i)]).abs() < 1e-5);
                }
            }
        }
    }
}

#[test]
fn bounds_on_controls_and_states_hold_at_the_samples() {
    use trajopt::problems::pendulum_swingup;
    let solver = GaussNewton::new(GaussNewtonSettings {
        max_iterations: 60,
        ..GaussNewtonSettings::default()
    })
    .expect("settings");
    let (free, theta0) = pendulum_swingup(90, 1e3).expect("problem");
    let unbounded = solver.solve(&free, &theta0).expect("solve");
    let (x_free, u_free) = free.trajectory(&unbounded.x).expect("traj");
    let u_max = (0..u_free.nrows()).map(|k| u_free[(k, 0)].abs()).fold(0.0, f64::max);
    let x_max = (0..x_free.nrows()).map(|k| x_free[(k, 2)].abs()).fold(0.0, f64::max);
    assert!(
        u_max > 1.0 && x_max > 0.05,
        "the free plan uses the hand: |u| {u_max}, |x| {x_max}"
    );

    let (u_lim, x_lim) = (0.6 * u_max, 0.5 * x_max);
    let (bounded, _) = pendulum_swingup(90, 1e3).expect("problem");
    let inf = f64::INFINITY;
    let bounded = bounded
        .with_control_bounds(&[-u_lim], &[u_lim])
        .expect("bounds")
        .with_state_bounds(&[-inf, -inf, -x_lim, -inf], &[inf, inf, x_lim, inf])
        .expect("bounds");
    // the start (zero controls, hand at rest) is feasible
    let res = solver.solve(&bounded, &theta0).expect("solve");
    assert!(res.cost <= res.initial_cost);
    let (x, u) = bounded.trajectory(&res.x).expect("traj");
    for k in 0..u.nrows() {
        assert!(
            u[(k, 0)].abs() <= u_lim * (1.0 + 1e-6),
            "u[{k}] = {} beyond {u_lim}",
            u[(k, 0)]
        );
    }
    for k in 0..x.nrows() {
        assert!(
            x[(k, 2)].abs() <= x_lim * (1.0 + 1e-6) + 1e-9,
            "x[{k}] = {} beyond {x_lim}",
            x[(k, 2)]
        );
    }
    // the limits cost something
    assert!(res.cost > unbounded.cost, "{} vs {}", res.cost, unbounded.cost);

    // an infeasible start is projected first, then improved
    let res2 = solver.solve(&bounded, &unbounded.x).expect("solve");
    let (_, u2) = bounded.trajectory(&res2.x).expect("traj");
    assert!((0..u2.nrows()).all(|k| u2[(k, 0)].abs() <= u_lim * (1.0 + 1e-6)));
    assert!(res2.cost <= res2.initial_cost);

    // empty bounds are refused
    let (p, _) = pendulum_swingup(20, 1e3).expect("problem");
    assert!(matches!(
        p.with_control_bounds(&[1.0], &[-1.0]),
        Err(TrajoptError::InvalidParameter { .. })
    ));
}

#[test]
fn powell_and_gauss_newton_agree_on_a_small_eq3_problem() {
    use argmin::core::Executor;
    use trajopt::powell::{Powell, PowellArgmin, PowellSettings};
    // a small problem Powell can finish: 20 steps, 6 + 5 coefficients per channel
    let (p, _, _, _) = pendulum_problem(20, Lambda::Constant(10.0), true);
    let theta0 = theta_guess(&p);
    let gn = GaussNewton::new(GaussNewtonSettings::default())
        .expect("settings")
        .solve(&p, &theta0)
        .expect("gn");
    let settings = PowellSettings {
        tol_cost: 1e-12,
        tol_step: 1e-10,
        max_evals: Some(200_000),
        ..PowellSettings::default()
    };
    let pw = Powell::new(settings.clone())
        .expect("settings")
        .solve(&p, &theta0)
        .expect("powell");
    assert!(pw.cost <= pw.initial_cost);
    assert_rel_close(pw.cost, gn.cost, 1e-4, "powell vs gauss-newton");
    assert!(
        pw.evals > 50 * gn.evals,
        "derivative-free costs many more evaluations: {} vs {}",
        pw.evals,
        gn.evals
    );
    // the same problem under argmin's executor
    let res = Executor::new(p, PowellArgmin::new(settings).expect("settings"))
        .configure(|s| s.param(theta0.clone()).max_iters(500))
        .run()
        .expect("argmin run");
    assert_rel_close(res.state().best_cost, gn.cost, 1e-3, "argmin powell vs gauss-newton");
}

#[test]
fn a_jacobian_that_contradicts_the_residuals_stalls_not_converges() {
    /// r(theta) = theta - 1, with a Jacobian of the wrong sign: every step is uphill.
    struct Lying;
    impl LeastSquaresProblem for Lying {
        fn n_params(&self) -> usize {
            1
        }
        fn n_residuals(&self) -> usize {
            1
        }
        fn residuals(&self, theta: &[f64], r: &mut [f64]) -> Result<()> {
            r[0] = theta[0] - 1.0;
            Ok(())
        }
        fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
            SymbolicSparseRowMat::new_checked(1, 1, vec![0, 1], None, vec![0])
        }
        fn jacobian_values(&self, _theta: &[f64], values: &mut [f64]) -> Result<()> {
            values[0] = -1.0;
            Ok(())
        }
    }
    let res = GaussNewton::new(GaussNewtonSettings::default())
        .expect("settings")
        .solve(&Lying, &[3.0])
        .expect("solve");
    assert_eq!(res.status, trajopt::GaussNewtonStatus::Stalled);
    assert!(!res.status.is_converged());
    assert_eq!(res.x, vec![3.0], "no step was accepted");
}

/// Solves `p` from `theta0` with the band form or the sparse form.
fn solve_with<P: LeastSquaresProblem>(
    p: &P,
    theta0: &[f64],
    band: bool,
    second_order: bool,
    max_iterations: usize,
) -> trajopt::GaussNewtonResult {
    let settings = GaussNewtonSettings {
        linear_solver: if band { LinearSolver::Auto } else { LinearSolver::Sparse },
        step_model: if second_order {
            StepModel::Newton
        } else {
            StepModel::GaussNewton
        },
        max_iterations,
        ..GaussNewtonSettings::default()
    };
    GaussNewton::new(settings)
        .expect("settings")
        .solve(p, theta0)
        .expect("solve")
}

/// The band form of the normal equations (the default for Eq. 3) and the
/// general sparse form take the same steps: same iterations, same answer to
/// rounding, for Gauss-Newton and for Newton steps, with and without a
/// model Jacobian (the finite-difference path).
#[test]
fn band_and_sparse_normal_equations_take_the_same_steps() {
    for (second_order, analytic, lambda) in [(false, true, 1e2), (false, false, 1e4), (true, true, 1e2)] {
        let (p, ..) = pendulum_problem(90, Lambda::Constant(lambda), analytic);
        let theta0 = theta_guess(&p);
        let band = solve_with(&p, &theta0, true, second_order, 40);
        let sparse = solve_with(&p, &theta0, false, second_order, 40);
        assert!(
            band.cost < 0.5 * band.initial_cost,
            "{} from {}",
            band.cost,
            band.initial_cost
        );
        // the first iterations agree to rounding; rounding may shift a late stopping test
        let n = band.cost_history.len().min(sparse.cost_history.len()).min(10);
        for (a, b) in band.cost_history[..n].iter().zip(&sparse.cost_history[..n]) {
            assert!(
                (a - b).abs() <= 1e-9 * b,
                "{a} vs {b} (second order {second_order}, analytic {analytic})"
            );
        }
        assert_rel_close(band.cost, sparse.cost, 1e-8, "band vs sparse");
    }
    // Newton steps need the model's second derivatives: the benchmark pendulum has them
    let (p, theta0) = trajopt::problems::pendulum_swingup(150, 1e2).expect("problem");
    let band = solve_with(&p, &theta0, true, true, 200);
    let sparse = solve_with(&p, &theta0, false, true, 200);
    assert_same_minimum(&band, &sparse, 1e-10, "band vs sparse");
    assert_iterations_close(&band, &sparse, 2, "band vs sparse");
}

/// A model that evaluates its batches back to front and counts them: the
/// problem must use the batches, and get the same answer as point by point.
struct Batched(Pendulum, std::sync::atomic::AtomicUsize);

impl Dynamics for Batched {
    fn state_dim(&self) -> usize {
        2
    }
    fn control_dim(&self) -> usize {
        1
    }
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        self.0.step(x, u, next)
    }
    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        self.0.jacobians(x, u, fx, fu)
    }
    fn step_batch(&self, xs: &[f64], us: &[f64], next: &mut [f64]) -> ModelResult<()> {
        self.1.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        for k in (0..us.len()).rev() {
            self.0
                .step(&xs[2 * k..2 * k + 2], &us[k..k + 1], &mut next[2 * k..2 * k + 2])?;
        }
        Ok(())
    }
    fn jacobians_batch(&self, xs: &[f64], us: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        self.1.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        for k in (0..us.len()).rev() {
            self.0.jacobians(
                &xs[2 * k..2 * k + 2],
                &us[k..k + 1],
                &mut fx[4 * k..4 * k + 4],
                &mut fu[2 * k..2 * k + 2],
            )?;
        }
        Ok(true)
    }
}

#[test]
fn batched_model_evaluation_is_used_and_changes_nothing() {
    let (plain, xb, ub, times) = pendulum_problem(60, Lambda::Constant(1e3), true);
    let batched = Eq3Problem::new(
        Batched(Pendulum { analytic: true }, 0.into()),
        plain_cost(60),
        &xb,
        &ub,
        &times,
        Lambda::Constant(1e3),
    )
    .expect("problem");
    let theta0 = theta_guess(&plain);
    let a = solve_with(&plain, &theta0, true, false, 50);
    let b = solve_with(&batched, &theta0, true, false, 50);
    assert_eq!(a.cost_history, b.cost_history);
    assert_eq!(a.x, b.x);
    let calls = batched.model().1.load(std::sync::atomic::Ordering::Relaxed);
    assert!(calls >= b.evals + b.jacobian_evals, "{calls} batch calls");
}
