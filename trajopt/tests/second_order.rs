//! The exact second-order term of Eq. 3 and the Newton mode of the solver.

mod common;

use common::{
    Hooked, Unchecked, assert_iterations_close, assert_rel_close, assert_same_minimum, check_descent,
    forward_least_squares, solve_in, swingup_problem,
};
use faer::prelude::*;
use faer::sparse::{SparseColMat, SparseRowMat};
use faer::{Mat, Side};
use proptest::prelude::*;
use trajopt::linalg::{BandLayout, BandedSym};
use trajopt::problems::{HandPendulum, pendulum_swingup};
use trajopt::{
    BandForm, BandNormalEquations, Eq3Problem, GaussNewton, GaussNewtonSettings, LeastSquaresProblem, LinearSolver,
    Part, Point, Result, SecondOrder, StepModel, TrackingCost,
};

/// $g(\theta) = J^\top r$.
fn gradient<P: LeastSquaresProblem>(p: &P, theta: &[f64]) -> Vec<f64> {
    let mut r = vec![0.0; p.n_residuals()];
    p.residuals(theta, &mut r).expect("residuals");
    let pattern = p.jacobian_pattern();
    let mut values = vec![0.0; pattern.col_idx().len()];
    p.jacobian_values(theta, &mut values).expect("jacobian");
    let j = SparseRowMat::new(pattern, values).to_dense();
    (0..p.n_params())
        .map(|c| (0..p.n_residuals()).map(|i| j[(i, c)] * r[i]).sum())
        .collect()
}

fn dense_second_order<P: LeastSquaresProblem>(p: &P, theta: &[f64]) -> Mat<f64> {
    let mut r = vec![0.0; p.n_residuals()];
    p.residuals(theta, &mut r).expect("residuals");
    let so = p.second_order().expect("a second-order term");
    let pattern = so.pattern();
    let mut values = vec![0.0; pattern.row_idx().len()];
    assert!(so.values(theta, &r, &mut values).expect("second order"));
    SparseColMat::new(pattern, values).to_dense()
}

fn dense_gauss_newton<P: LeastSquaresProblem>(p: &P, theta: &[f64]) -> Mat<f64> {
    let pattern = p.jacobian_pattern();
    let mut values = vec![0.0; pattern.col_idx().len()];
    p.jacobian_values(theta, &mut values).expect("jacobian");
    let j = SparseRowMat::new(pattern, values).to_dense();
    j.transpose() * &j
}

/// A point away from the optimum, where the residuals (and so $S$) are large.
fn perturbed(theta0: &[f64], seed: f64) -> Vec<f64> {
    theta0
        .iter()
        .enumerate()
        .map(|(i, t)| t + 0.3 * ((i as f64 + seed) * 0.77).sin())
        .collect()
}

#[test]
fn second_order_term_equals_differences_of_the_gradient() -> Result<()> {
    // d(J^T r)/d theta = J^T J + S: central differences of the exact gradient
    let (p, theta0) = pendulum_swingup(60, 1e2)?;
    let p = p.with_initial_state(&[0.1, 0.0, 0.0, 0.0], 50.0)?;
    let theta = perturbed(&theta0, 1.0);
    let s = dense_second_order(&p, &theta);
    let jtj = dense_gauss_newton(&p, &theta);
    let n = p.n_params();
    let mut worst: f64 = 0.0;
    let mut largest: f64 = 0.0;
    for c in 0..n {
        let h = 1e-6 * theta[c].abs().max(1.0);
        let (mut tp, mut tm) = (theta.clone(), theta.clone());
        tp[c] += h;
        tm[c] -= h;
        let (gp, gm) = (gradient(&p, &tp), gradient(&p, &tm));
        for i in 0..n {
            let fd = (gp[i] - gm[i]) / (2.0 * h);
            let exact = jtj[(i, c)] + s[(i, c)];
            worst = worst.max((fd - exact).abs());
            largest = largest.max(exact.abs());
        }
    }
    assert!(worst <= 1e-6 * largest, "worst error {worst} of {largest}");
    // S is symmetric and not negligible here (else the test proves nothing)
    let mut s_max: f64 = 0.0;
    for i in 0..n {
        for c in 0..n {
            assert!((s[(i, c)] - s[(c, i)]).abs() <= 1e-12 * largest);
            s_max = s_max.max(s[(i, c)].abs());
        }
    }
    assert!(s_max > 1e-3 * largest, "S is {s_max} of {largest}");
    Ok(())
}

#[test]
fn newton_reaches_the_gauss_newton_optimum_in_far_fewer_iterations() -> Result<()> {
    let (p, theta0) = pendulum_swingup(150, 1e2)?;
    let gn = solve_in(StepModel::GaussNewton, &p, &theta0)?;
    let newton = solve_in(StepModel::Newton, &p, &theta0)?;
    assert_same_minimum(&newton, &gn, 1e-9, "Newton vs Gauss-Newton");
    // (4x: the shift of an indefinite J^T J + S shrinks fast after
    // well-predicted steps; with the plain IPOPT decrease it was 3.6x)
    assert!(
        4 * newton.iterations < gn.iterations,
        "{} Newton vs {} Gauss-Newton iterations",
        newton.iterations,
        gn.iterations
    );
    // quadratic convergence: the last accepted decreases collapse
    let h = &newton.cost_history;
    let d: Vec<f64> = h.windows(2).map(|w| w[0] - w[1]).collect();
    let tail = &d[d.len() - 4..d.len() - 1];
    assert!(tail[2] < 1e-3 * tail[0], "decreases {tail:?}");
    // the solution solves the exact optimality condition J^T r = 0, to
    // 1e-10 of the start's gradient (about 1e5 here; the solve stops once
    // the predicted gain is below tol_cost F, with the gradient near 1e-11
    // of the start's)
    let inf = |g: Vec<f64>| g.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let (g0, g) = (inf(gradient(&p, &theta0)), inf(gradient(&p, &newton.x)));
    assert!(g < 1e-10 * g0, "gradient {g:e}, at the start {g0:e}");
    Ok(())
}

/// Without second derivatives the Newton and the adaptive modes can only
/// take Gauss-Newton steps, at Gauss-Newton's cost.
#[test]
fn without_second_derivatives_newton_and_adaptive_modes_are_gauss_newton() -> Result<()> {
    let (p, theta) = altered_problem(90, 2.0, |_: &[f64], _: &mut [f64]| false)?;
    let gn = solve_in(StepModel::GaussNewton, &p, &theta)?;
    for step_model in [StepModel::Newton, StepModel::Adaptive] {
        let other = solve_in(step_model, &p, &theta)?;
        assert_eq!(gn.iterations, other.iterations, "{step_model:?}");
        assert_eq!(gn.x, other.x, "{step_model:?}");
        if step_model == StepModel::Adaptive {
            // and no curvature probes: without S they could not change the choice
            assert_eq!(other.evals, gn.evals);
        }
    }
    Ok(())
}

#[test]
fn upper_triangular_storage_gives_the_symmetric_product() {
    // the factorisation reads only the upper triangle: a Newton step on a
    // linear least-squares problem (S = 0) is the exact solution
    let a = Mat::from_fn(7, 4, |i, j| {
        ((i * 4 + j) as f64 * 0.37).sin() + if i == j { 2.0 } else { 0.0 }
    });
    let b: Vec<f64> = (0..7).map(|i| (i as f64).cos()).collect();
    let triplets: Vec<_> = (0..7)
        .flat_map(|i| (0..4).map(move |j| (i, j)))
        .map(|(i, j)| faer::sparse::Triplet::new(i, j, a[(i, j)]))
        .collect();
    let sparse = SparseRowMat::try_new_from_triplets(7, 4, &triplets).expect("matrix");
    let problem = trajopt::LinearLeastSquares::new(sparse, b.clone()).expect("problem");
    let res = GaussNewton::new(GaussNewtonSettings {
        initial_damping: 0.0,
        step_model: StepModel::Newton,
        ..GaussNewtonSettings::default()
    })
    .expect("settings")
    .solve(&problem, &[0.0; 4])
    .expect("solve");
    let ata = a.transpose() * &a;
    let atb = a.transpose() * Mat::from_fn(7, 1, |i, _| b[i]);
    let x = ata.llt(Side::Lower).expect("spd").solve(&atb);
    for j in 0..4 {
        assert!((res.x[j] - x[(j, 0)]).abs() < 1e-10, "{} vs {}", res.x[j], x[(j, 0)]);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Newton steps, and the adaptive choice between Newton and
    /// Gauss-Newton steps.
    #[test]
    fn newton_never_increases_the_cost(
        lambda in prop_oneof![Just(0.0), 1e-2..1e5f64],
        seed in 0u32..1000,
        horizon in 12usize..80,
    ) {
        let (p, theta0) = pendulum_swingup(horizon, lambda).expect("problem");
        let theta = perturbed(&theta0, seed as f64);
        for step_model in [StepModel::Newton, StepModel::Adaptive] {
            check_descent(&p, &theta, step_model)?;
        }
    }
}

type AlteredProblem<F> = Eq3Problem<Hooked<Unchecked, F>, TrackingCost>;

/// A swing-up of `horizon` steps with the pendulum's second derivatives
/// altered by `alter` (which says whether the model has them at all),
/// tracking the benchmark's start (lambda 10), and a start away from it
/// (`seed`).
fn altered_problem<F: Fn(&[f64], &mut [f64]) -> bool>(
    horizon: usize,
    seed: f64,
    alter: F,
) -> Result<(AlteredProblem<F>, Vec<f64>)> {
    let (reference, theta0) = pendulum_swingup(horizon, 1e2)?;
    let (x, _) = reference.trajectory(&theta0)?;
    let cost = TrackingCost::new(x, Mat::zeros(horizon, 1), &[1.0; 4], &[0.1], &[10.0; 4])?;
    let p = swingup_problem(horizon, Hooked::hessian(alter), cost, 10.0)?;
    Ok((p, perturbed(&theta0, seed)))
}

#[test]
fn a_second_derivative_outside_the_structure_is_an_error_not_a_panic() -> Result<()> {
    // theta and the hand position never meet in one row of the structure
    let (p, start) = altered_problem(30, 3.0, |_: &[f64], hess: &mut [f64]| {
        hess[2] = 1.0;
        hess[10] = 1.0;
        true
    })?;
    for band in [true, false] {
        let solver = GaussNewton::new(GaussNewtonSettings {
            step_model: StepModel::Newton,
            linear_solver: if band { LinearSolver::Auto } else { LinearSolver::Sparse },
            ..GaussNewtonSettings::default()
        })?;
        assert!(matches!(
            solver.solve(&p, &start),
            Err(trajopt::TrajoptError::InvalidParameter { name: "model", .. })
        ));
    }
    Ok(())
}

/// Second derivatives so large that $J^\top J + S$ overflows: the Newton
/// mode must fall back to Gauss-Newton steps, not fail, in both forms of the
/// normal equations.
#[test]
fn an_overflowing_second_order_term_gives_gauss_newton_steps() -> Result<()> {
    let (p, start) = altered_problem(30, 3.0, |_: &[f64], hess: &mut [f64]| {
        for h in hess.iter_mut().filter(|h| **h != 0.0) {
            *h = f64::MAX;
        }
        true
    })?;
    let solve = |second_order: bool, band: bool| {
        GaussNewton::new(GaussNewtonSettings {
            step_model: if second_order {
                StepModel::Newton
            } else {
                StepModel::GaussNewton
            },
            linear_solver: if band { LinearSolver::Auto } else { LinearSolver::Sparse },
            max_iterations: 30,
            ..GaussNewtonSettings::default()
        })?
        .solve(&p, &start)
    };
    let gauss_newton = solve(false, true)?;
    for band in [true, false] {
        let newton = solve(true, band)?;
        assert_eq!(newton.status, gauss_newton.status, "band {band}");
        assert_eq!(newton.iterations, gauss_newton.iterations, "band {band}");
        assert!((newton.cost - gauss_newton.cost).abs() <= 1e-10 * gauss_newton.cost);
    }
    Ok(())
}

/// The adaptive model choice (NL2SOL's switch between the Gauss-Newton and
/// the Newton model) reaches the Gauss-Newton optimum where the residuals
/// are large and Newton steps pay (lambda = 1e2: far fewer iterations), and
/// where the dynamics are stiff and they do not (lambda = 1e4: about as many
/// as Gauss-Newton); the band and the sparse forms take the same steps.
#[test]
fn adaptive_model_choice_takes_newton_steps_where_they_pay() -> Result<()> {
    for (lambda, max_ratio) in [(1e2, 0.5), (1e4, 1.3)] {
        let (p, theta0) = pendulum_swingup(150, lambda)?;
        let settings = GaussNewtonSettings {
            max_iterations: 1000,
            ..GaussNewtonSettings::default()
        };
        let gn = GaussNewton::new(settings.clone())?.solve(&p, &theta0)?;
        let adaptive = |band| {
            GaussNewton::new(GaussNewtonSettings {
                step_model: StepModel::Adaptive,
                linear_solver: if band { LinearSolver::Auto } else { LinearSolver::Sparse },
                ..settings.clone()
            })?
            .solve(&p, &theta0)
        };
        let (a, sparse) = (adaptive(true)?, adaptive(false)?);
        assert_same_minimum(&a, &gn, 1e-9, &format!("lambda {lambda}"));
        assert!(
            (a.iterations as f64) < max_ratio * gn.iterations as f64,
            "lambda {lambda}: {} adaptive vs {} Gauss-Newton iterations",
            a.iterations,
            gn.iterations
        );
        // never a higher cost than the last
        assert!(a.cost_history.windows(2).all(|w| w[1] <= w[0]));
        assert_rel_close(sparse.cost, a.cost, 1e-10, "sparse vs band");
        // rounding differences grow over hundreds of stiff iterations
        assert_iterations_close(&a, &sparse, 2 + a.iterations / 20, "band vs sparse");
    }
    Ok(())
}

/// Eq. 3's exact $\delta^\top S \delta$ (per step, without forming $S$)
/// equals the quadratic form of the assembled $S$, with a zero lambda at one
/// step and a fixed initial state; a model without second derivatives has
/// none.
#[test]
fn second_order_form_is_the_quadratic_form_of_s() -> Result<()> {
    let (p, theta0) = pendulum_swingup(60, 1e2)?;
    let mut lambda = vec![1e2; 60];
    lambda[5] = 0.0;
    lambda[6] = 4e3;
    let mut p = p.with_initial_state(&[0.1, 0.0, 0.0, 0.0], 3.0)?;
    p.set_lambda(trajopt::Lambda::PerStep(lambda))?;
    let theta = perturbed(&theta0, 3.0);
    let mut r = vec![0.0; p.n_residuals()];
    p.residuals(&theta, &mut r)?;
    let pattern = SecondOrder::pattern(&p);
    let mut values = vec![0.0; pattern.row_idx().len()];
    assert!(SecondOrder::values(&p, &theta, &r, &mut values)?);
    for seed in 0..3 {
        let delta: Vec<f64> = (0..p.n_params())
            .map(|i| ((i * 7 + seed * 13) as f64 * 0.61).sin())
            .collect();
        let mut expected = 0.0;
        for j in 0..p.n_params() {
            for (q, &i) in pattern.row_idx_of_col_raw(j).iter().enumerate() {
                expected += values[pattern.col_ptr()[j] + q] * delta[i] * delta[j];
            }
        }
        let form = SecondOrder::form(&p, &theta, &r, &delta)?.expect("form");
        assert!(
            (form - expected).abs() <= 1e-10 * expected.abs().max(1.0),
            "{form} vs {expected}"
        );
        assert!(expected.abs() > 1e-6, "S is negligible: {expected}");
    }
    // wrong sizes are errors; no second derivatives, no form
    assert!(SecondOrder::form(&p, &theta, &r, &theta[1..]).is_err());
    let (q, theta) = altered_problem(30, 2.0, |_: &[f64], _: &mut [f64]| false)?;
    let mut r = vec![0.0; q.n_residuals()];
    q.residuals(&theta, &mut r)?;
    assert_eq!(SecondOrder::form(&q, &theta, &r, &theta)?, None);
    Ok(())
}

/// A least-squares problem that forwards everything to Eq. 3 but its exact
/// $\delta^\top S \delta$ (sparse path: no band form either).
struct WithoutForm<P>(P);

impl<P: LeastSquaresProblem> LeastSquaresProblem for WithoutForm<P> {
    forward_least_squares!(0);

    fn second_order(&self) -> Option<&dyn SecondOrder> {
        Some(self)
    }
}

impl<P: LeastSquaresProblem> SecondOrder for WithoutForm<P> {
    fn pattern(&self) -> faer::sparse::SymbolicSparseColMat<usize> {
        self.0.second_order().expect("the inner problem has S").pattern()
    }

    fn values(&self, theta: &[f64], r: &[f64], values: &mut [f64]) -> Result<bool> {
        self.0
            .second_order()
            .map_or(Ok(false), |so| so.values(theta, r, values))
    }
}

/// Without the problem's exact $\delta^\top S \delta$ the adaptive mode
/// takes it from central differences of the residuals (two more residual
/// evaluations per step) and makes the same choices to within a few
/// iterations.
#[test]
fn adaptive_mode_without_an_exact_form_probes_the_residuals() -> Result<()> {
    let (p, theta0) = pendulum_swingup(150, 1e2)?;
    let exact = solve_in(StepModel::Adaptive, &p, &theta0)?;
    let probed = solve_in(StepModel::Adaptive, &WithoutForm(p), &theta0)?;
    assert_same_minimum(&probed, &exact, 1e-9, "probed vs exact");
    assert_iterations_close(&probed, &exact, 3, "probed vs exact");
    // the probes: two residual evaluations per trial step
    assert!(probed.evals >= exact.evals + 2 * (probed.iterations - 1));
    Ok(())
}

/// The benchmark pendulum with call counters, and with or without its
/// second-order term alone in band form (`BandForm::second_order_part`).
struct Counting {
    inner: Eq3Problem<HandPendulum, TrackingCost>,
    forward_s: bool,
    normal_equations: std::sync::atomic::AtomicUsize,
    second_order_alone: std::sync::atomic::AtomicUsize,
}

impl LeastSquaresProblem for Counting {
    forward_least_squares!(inner, band_form);
    fn second_order(&self) -> Option<&dyn SecondOrder> {
        self.inner.second_order()
    }
}

impl BandForm for Counting {
    fn layout(&self) -> BandLayout {
        self.inner.layout()
    }
    fn normal_equations(&self, at: Point<'_>, layout: &BandLayout, out: BandNormalEquations<'_>) -> Result<bool> {
        self.normal_equations.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.inner.normal_equations(at, layout, out)
    }
    fn second_order_part(&self, part: Part, at: Point<'_>, layout: &BandLayout, s: &mut BandedSym) -> Result<bool> {
        if !self.forward_s {
            return Ok(false);
        }
        self.second_order_alone
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.inner.second_order_part(part, at, layout, s)
    }
}

/// When a Newton iteration falls back to a Gauss-Newton step, the solver
/// takes $J^\top J = (J^\top J + S) - S$ from the problem's $S$ alone
/// instead of forming $J^\top J$ again, and reaches the same minimum in the
/// same number of iterations (to rounding) as when it forms it again.
#[test]
fn gauss_newton_fallbacks_subtract_the_second_order_term() -> Result<()> {
    use std::sync::atomic::Ordering::Relaxed;
    let run = |forward_s: bool| -> Result<(trajopt::GaussNewtonResult, usize, usize)> {
        let (inner, theta0) = pendulum_swingup(150, 1e2)?;
        let counting = Counting {
            inner,
            forward_s,
            normal_equations: 0.into(),
            second_order_alone: 0.into(),
        };
        let result = solve_in(StepModel::Newton, &counting, &theta0)?;
        Ok((
            result,
            counting.normal_equations.load(Relaxed),
            counting.second_order_alone.load(Relaxed),
        ))
    };
    let (formed_again, calls_again, _) = run(false)?;
    let (subtracted, calls, s_calls) = run(true)?;
    // the benchmark falls back a few times at the start
    assert!(
        calls_again > formed_again.iterations,
        "{calls_again} calls, {} iterations",
        formed_again.iterations
    );
    assert_eq!(calls, subtracted.iterations);
    assert_eq!(s_calls, calls_again - formed_again.iterations);
    assert_same_minimum(&subtracted, &formed_again, 1e-10, "subtracted vs formed again");
    assert_iterations_close(&subtracted, &formed_again, 2, "subtracted vs formed again");
    Ok(())
}
