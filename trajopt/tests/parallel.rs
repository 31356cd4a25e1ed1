//! `GaussNewton::solve_parallel`: the band normal equations formed in parts
//! on helper threads.

mod common;

use common::{
    Hooked, assert_iterations_close, assert_same_minimum, forward_band_form, forward_least_squares, swingup_problem,
};
use trajopt::problems::{HandPendulum, PENDULUM_DT, pendulum_swingup, swingup_reference};
use trajopt::{
    BandForm, Dynamics, Eq3Problem, GaussNewton, GaussNewtonResult, GaussNewtonSettings, LeastSquaresProblem, Part,
    Result, StepModel, TrackingCost, TrajoptError,
};

/// A horizon whose problem has at least `MIN_PARALLEL_PARAMS` parameters.
const HORIZON: usize = 700;

/// The solver in a mode; without the fallback to one thread, so that the
/// parallel path is what these tests test, however busy the machine.
fn solver(second_order: bool, adaptive: bool) -> GaussNewton {
    let step_model = match (second_order, adaptive) {
        (false, _) => StepModel::GaussNewton,
        (true, false) => StepModel::Newton,
        (true, true) => StepModel::Adaptive,
    };
    GaussNewton::new(GaussNewtonSettings {
        step_model,
        one_thread_fallback: false,
        ..GaussNewtonSettings::default()
    })
    .expect("settings")
}

fn assert_close(a: &GaussNewtonResult, b: &GaussNewtonResult, what: &str) {
    assert_same_minimum(a, b, 1e-10, what);
    // Gauss-Newton's slow tail meets the cost test at a rounding-dependent iteration
    assert_iterations_close(a, b, 3.max(b.iterations / 10), what);
    // the first steps are the same up to rounding
    for (x, y) in a.cost_history.iter().zip(&b.cost_history).take(5) {
        assert!((x - y).abs() <= 1e-9 * y, "{what}: {x} vs {y}");
    }
}

/// Each mode reaches the same minimum with two or three threads as with
/// one, in the same number of iterations to within rounding's effect on
/// the stopping tests (Gauss-Newton: 94 with two threads, 98 with one, at
/// this horizon); one thread is `solve` itself, and a given thread
/// count gives the same bits every time.
#[test]
fn parallel_solves_agree_with_the_sequential_one() -> Result<()> {
    // enough parameters for the helpers (below, solve_parallel is solve)
    let (p, theta0) = pendulum_swingup(HORIZON, 1e2)?;
    assert!(p.n_params() >= trajopt::MIN_PARALLEL_PARAMS);
    for (second_order, adaptive) in [(false, false), (true, false), (true, true)] {
        let s = solver(second_order, adaptive);
        let one = s.solve(&p, &theta0)?;
        let one_again = s.solve_parallel(&p, &theta0, 1)?;
        assert_eq!(one.x, one_again.x);
        // (capped at the machine's cores; the unit tests run three parts)
        for threads in [2, 3] {
            let par = s.solve_parallel(&p, &theta0, threads)?;
            assert_close(
                &par,
                &one,
                &format!("{threads} threads, newton {second_order}, adaptive {adaptive}"),
            );
            let again = s.solve_parallel(&p, &theta0, threads)?;
            assert_eq!(par.one_thread_from, None);
            assert_eq!(par.x, again.x, "{threads} threads are not deterministic");
        }
    }
    Ok(())
}

/// The pendulum, with Jacobians that fail beyond `max_angle`: only at the
/// last time steps of the swing-up, so in the last part of a split.
fn failing_late(max_angle: f64) -> Hooked<impl Fn(&[f64]) -> trajopt::ModelResult<()>, common::Unaltered> {
    Hooked::before_jacobians(move |xs: &[f64]| {
        if xs.chunks(4).any(|x| x[0] > max_angle) {
            return Err(trajopt::ModelError::new("state outside the model's range"));
        }
        Ok(())
    })
}

/// The benchmark swing-up of `horizon` steps with another pendulum model
/// (the same bases, cost and lambda), and the angle past which 95% of the
/// reference's steps lie: a model that misbehaves beyond it does so only
/// at the last steps, in the last part of a split.
fn swingup_with<M: Dynamics>(horizon: usize, model: impl FnOnce(f64) -> M) -> Result<Eq3Problem<M, TrackingCost>> {
    let max_angle = swingup_reference(horizon * 95 / 100)[0];
    let state_ref = faer::Mat::from_fn(horizon + 1, 4, |k, i| swingup_reference(k)[i]);
    let cost = TrackingCost::new(
        state_ref,
        faer::Mat::zeros(horizon, 1),
        &[1.0, 0.1, 1.0, 0.1],
        &[0.01],
        &[1000.0, 100.0, 1000.0, 100.0],
    )?;
    swingup_problem(horizon, model(max_angle), cost, 1e2)?.with_consistency_scale(1.0 / PENDULUM_DT)
}

/// An error in a helper's part is the solve's error, as without helpers.
#[test]
fn an_error_in_a_helper_part_is_returned() -> Result<()> {
    let horizon = HORIZON;
    let (p, theta0) = pendulum_swingup(horizon, 1e2)?;
    let failing = swingup_with(horizon, failing_late)?;
    assert_eq!(failing.n_params(), p.n_params());
    let s = solver(false, false);
    let sequential = s.solve(&failing, &theta0);
    let parallel = s.solve_parallel(&failing, &theta0, 2);
    assert!(matches!(
        sequential,
        Err(TrajoptError::Model(ref why)) if why == "state outside the model's range"
    ));
    assert_eq!(parallel.map(|r| r.cost), sequential.map(|r| r.cost));
    Ok(())
}

/// The pendulum with second derivatives that overflow beyond `max_angle`.
fn overflow_late(max_angle: f64) -> Hooked<common::Unchecked, impl Fn(&[f64], &mut [f64]) -> bool> {
    Hooked::hessian(move |x: &[f64], hess: &mut [f64]| {
        if x[0] > max_angle {
            for h in hess.iter_mut().filter(|h| **h != 0.0) {
                *h = f64::MAX;
            }
        }
        true
    })
}

/// $J^\top J + S$ overflows in the last steps only, so in the helper's
/// part only: the Newton mode takes Gauss-Newton steps there, with two
/// threads as with one.
#[test]
fn an_overflow_in_a_helper_part_gives_gauss_newton_steps() -> Result<()> {
    let horizon = HORIZON;
    let (_, theta0) = pendulum_swingup(horizon, 1e2)?;
    let p = swingup_with(horizon, overflow_late)?;
    for adaptive in [false, true] {
        let s = solver(true, adaptive);
        let one = s.solve(&p, &theta0)?;
        let two = s.solve_parallel(&p, &theta0, 2)?;
        assert_close(&two, &one, &format!("adaptive {adaptive}"));
    }
    Ok(())
}

/// A problem with a band form but no split of its own: the default
/// `BandForm::normal_equations_part` forms everything in part 0, so the
/// parallel solve is the sequential one, bit for bit.
struct Unsplit(Eq3Problem<HandPendulum, TrackingCost>);

impl LeastSquaresProblem for Unsplit {
    forward_least_squares!(0, band_form);
}

impl BandForm for Unsplit {
    forward_band_form!(0);
}

#[test]
fn the_default_split_changes_nothing() -> Result<()> {
    let (p, theta0) = pendulum_swingup(HORIZON, 1e2)?;
    let p = Unsplit(p);
    let s = solver(false, false);
    let one = s.solve(&p, &theta0)?;
    let two = s.solve_parallel(&p, &theta0, 2)?;
    assert!(one.status.is_converged());
    assert_eq!(one.x, two.x);
    assert_eq!(one.iterations, two.iterations);
    Ok(())
}

/// The residuals' parts cover every row once and equal the whole, bit for
/// bit, with the initial-state rows and with more parts than time steps.
#[test]
fn residual_parts_make_up_the_residuals() -> Result<()> {
    let (p, theta0) = pendulum_swingup(40, 1e2)?;
    let p = p.with_initial_state(&[0.1, 0.0, 0.0, 0.0], 7.0)?;
    let theta: Vec<f64> = theta0
        .iter()
        .enumerate()
        .map(|(i, t)| t + 0.1 * (i as f64).sin())
        .collect();
    let mut whole = vec![0.0; p.n_residuals()];
    p.residuals(&theta, &mut whole)?;
    for parts in [1, 2, 3, 7, 100] {
        let mut r = vec![f64::NAN; p.n_residuals()];
        let mut covered = vec![0; p.n_residuals()];
        for part in 0..parts {
            let mut scratch = vec![f64::NAN; p.n_residuals()];
            let rows = p.residuals_part(
                Part {
                    index: part,
                    count: parts,
                },
                &theta,
                &mut scratch,
            )?;
            for i in rows {
                covered[i] += 1;
                r[i] = scratch[i];
            }
        }
        assert!(covered.iter().all(|&c| c == 1), "{parts} parts: {covered:?}");
        assert_eq!(r, whole, "{parts} parts");
    }
    assert!(
        p.residuals_part(Part { index: 3, count: 3 }, &theta, &mut whole)
            .is_err()
    );
    Ok(())
}

/// A problem whose residual parts miss rows is an error of the parallel
/// solve, not a solve on stale residuals.
struct MissingRows(Eq3Problem<HandPendulum, TrackingCost>);

impl LeastSquaresProblem for MissingRows {
    forward_least_squares!(0, band_form);
}

impl BandForm for MissingRows {
    forward_band_form!(0);
    fn residuals_part(&self, part: Part, theta: &[f64], r: &mut [f64]) -> Result<std::ops::Range<usize>> {
        let rows = self.0.residuals_part(part, theta, r)?;
        // the last row of the last part is left out
        Ok(if rows.end == self.n_residuals() {
            rows.start..rows.end - 1
        } else {
            rows
        })
    }
}

#[test]
fn residual_parts_that_miss_rows_are_an_error() -> Result<()> {
    let (p, theta0) = pendulum_swingup(HORIZON, 1e2)?;
    let p = MissingRows(p);
    let s = solver(false, false);
    assert!(s.solve(&p, &theta0)?.status.is_converged());
    let err = s.solve_parallel(&p, &theta0, 2).expect_err("rows are missing");
    assert!(
        matches!(
            err,
            TrajoptError::InvalidParameter {
                name: "residual parts",
                ..
            }
        ),
        "{err}"
    );
    Ok(())
}

/// A helper that answers late (here: its part is slow; on a busy machine:
/// it waits for a core) makes the solve go on with one thread from the next
/// iteration, instead of waiting for it at every hand-over; the result is
/// the one-thread solve's to rounding.
#[test]
fn a_late_helper_makes_the_solve_go_on_with_one_thread() -> Result<()> {
    let (_, theta0) = pendulum_swingup(HORIZON, 1e2)?;
    let solver_thread = std::thread::current().id();
    // the pendulum, whose Jacobians take 50 ms beyond an angle (the last
    // steps, the helper's part) when a helper evaluates them, counting the
    // calls made off the thread that solves
    let helper_calls = std::sync::atomic::AtomicUsize::new(0);
    let slow_late = |max_angle: f64| {
        let helper_calls = &helper_calls;
        Hooked::before_jacobians(move |xs: &[f64]| {
            if std::thread::current().id() == solver_thread {
                return Ok(());
            }
            helper_calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            if xs.chunks(4).any(|x| x[0] > max_angle) {
                // far later than the solver's own part, however busy the machine
                std::thread::sleep(std::time::Duration::from_millis(50));
            }
            Ok(())
        })
    };
    let p = swingup_with(HORIZON, slow_late)?;
    let s = GaussNewton::new(GaussNewtonSettings::default())?;
    let one = s.solve(&p, &theta0)?;
    let two = s.solve_parallel(&p, &theta0, 2)?;
    assert_close(&two, &one, "late helper");
    // (on a busy machine the helper may not even start in time: then it never runs)
    let helper_calls = helper_calls.load(std::sync::atomic::Ordering::Relaxed);
    // (without the fallback: at every one of the iterations)
    assert!(
        4 * helper_calls < two.iterations,
        "the helper formed parts {helper_calls} times in {} iterations",
        two.iterations
    );
    assert!(two.one_thread_from.is_some_and(|k| k <= 3), "{:?}", two.one_thread_from);
    assert_eq!(one.one_thread_from, None);
    Ok(())
}
