//! Receding-horizon Eq. 3 (model-predictive control): the generic core that
//! replans a window from the measured state, whatever the model and the
//! task cost.
//!
//! At each replan the window's trajectory is parametrised as in the
//! open-loop planner, by cubic B-splines over `samples` steps of `dt`
//! ([`Window`]), and Eq. 3,
//! $$\min_\theta \; \sum_k c_k(x_k, u_k) + \lambda \sum_k \lVert (x_{k+1} - f(x_k, u_k)) / \Delta t \rVert^2 +
//!   w_0 \lVert x_0 - \bar x_0 \rVert^2,$$
//! is solved by Gauss-Newton from a warm start, with $\bar x_0$ the
//! measured state. The warm start is the previous plan shifted by the steps
//! executed since ([`shifted`]), its last state and control repeated to
//! fill the window, its first state replaced by the measured one, and
//! fitted by the bases (least squares, through a fit operator computed once
//! per window).
//!
//! **The budget and its fallback** ([`ReplanSettings`]). A replan runs at
//! most `max_iterations` Gauss-Newton iterations and returns the best
//! iterate: never worse than the warm start in the criterion, since each
//! accepted step lowers it. A wall-time `budget` is a deadline inside the
//! solve (a [`solve::Watch`] started with the replan, so the warm start's
//! fit counts): Gauss-Newton checks it at every iteration and trial step
//! and returns its best iterate when it passes, late by at most one
//! Jacobian and one trial step. If no step was accepted by then, the replan
//! has nothing better than the warm start and the robot keeps executing
//! the previous plan, shifted ([`ReplanStatus::KeptPrevious`]); so it does
//! when the solve fails (a model that returns a non-finite value).
//! Iterations make runs reproducible bit for bit; a time budget makes them
//! depend on the machine, which is why it is off by default.

use std::time::{Duration, Instant};

use faer::Mat;
use solve::Watch;
use splines::{BSplineBasis, FitSettings};
use trajopt::{Eq3Problem, GaussNewton, GaussNewtonSettings, GaussNewtonStatus, Lambda, StageCost};

/// The bases and sample times of one window, the same at every replan
/// (each window is timed from 0), and the least-squares fit operators
/// from samples to coefficients.
#[derive(Debug, Clone)]
pub struct Window {
    state_basis: BSplineBasis,
    control_basis: BSplineBasis,
    times: Vec<f64>,
    /// `state_coeffs` $\times$ (`samples` + 1): coefficients from state samples.
    state_fit: Mat<f64>,
    /// `control_coeffs` $\times$ `samples`: coefficients from control samples.
    control_fit: Mat<f64>,
}

impl Window {
    /// A window of `samples` steps of `dt`, states and controls on clamped
    /// uniform cubic B-splines of `state_coeffs` and `control_coeffs`
    /// coefficients (at most `samples + 1` and `samples`).
    ///
    /// # Errors
    /// A window too short for its bases, or a non-positive `dt`.
    pub fn new(samples: usize, dt: f64, state_coeffs: usize, control_coeffs: usize) -> crate::Result<Self> {
        crate::error::ensure_data!(
            dt.is_finite() && dt > 0.0,
            "the window's time step must be finite and positive, got {dt}"
        );
        crate::error::ensure_data!(
            samples >= 4 && state_coeffs <= samples + 1 && control_coeffs <= samples && control_coeffs >= 4,
            "a window of {samples} samples cannot carry {state_coeffs} state and {control_coeffs} control \
             coefficients (need 4 <= control_coeffs <= samples, state_coeffs <= samples + 1)"
        );
        let t_end = dt * samples as f64;
        let state_basis = BSplineBasis::clamped_uniform(state_coeffs, 3, 0.0, t_end)?;
        let control_basis = BSplineBasis::clamped_uniform(control_coeffs, 3, 0.0, t_end)?;
        let times: Vec<f64> = (0..=samples).map(|k| k as f64 * dt).collect();
        // the fit is linear in the samples: fitting the identity gives its operator
        let fit = FitSettings::default();
        let state_fit = splines::fit_matrix(
            &state_basis,
            &times,
            Mat::<f64>::identity(samples + 1, samples + 1).as_ref(),
            &fit,
        )?;
        let control_fit = splines::fit_matrix(
            &control_basis,
            &times[..samples],
            Mat::<f64>::identity(samples, samples).as_ref(),
            &fit,
        )?;
        Ok(Self {
            state_basis,
            control_basis,
            times,
            state_fit,
            control_fit,
        })
    }

    /// Steps in the window.
    pub fn samples(&self) -> usize {
        self.times.len() - 1
    }

    /// The sample times $0, \Delta t, \dots$ of the window.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// The Eq. 3 problem of one replan: `model` and `cost` over the window,
    /// consistency weight `lambda` in rate units, and the measured state
    /// `x0` held by the weight `x0_weight`.
    ///
    /// # Errors
    /// Whatever [`Eq3Problem`] refuses (dimensions, non-finite values).
    pub fn problem<M: trajopt::Dynamics, C: StageCost>(
        &self,
        model: M,
        cost: C,
        lambda: f64,
        x0: &[f64],
        x0_weight: f64,
    ) -> crate::Result<Eq3Problem<M, C>> {
        let dt = self.times[1] - self.times[0];
        Ok(Eq3Problem::new(
            model,
            cost,
            &self.state_basis,
            &self.control_basis,
            &self.times,
            Lambda::Constant(lambda),
        )?
        .with_consistency_scale(1.0 / dt)?
        .with_initial_state(x0, x0_weight)?)
    }

    /// The coefficients of `problem` fitting `states` (`samples + 1` rows)
    /// and `controls` (`samples` rows) in the least-squares sense.
    ///
    /// # Errors
    /// Sizes that do not match the window or the problem.
    pub fn fit<M: trajopt::Dynamics, C: StageCost>(
        &self,
        problem: &Eq3Problem<M, C>,
        states: &Mat<f64>,
        controls: &Mat<f64>,
    ) -> crate::Result<Vec<f64>> {
        let n = self.samples();
        crate::error::ensure_data!(
            states.nrows() == n + 1 && controls.nrows() == n,
            "a trajectory of {} states and {} controls does not fit a window of {n} steps",
            states.nrows(),
            controls.nrows()
        );
        let cx = &self.state_fit * states;
        let cu = &self.control_fit * controls;
        Ok(problem.pack(&cx, &cu)?)
    }
}

/// `problem` with hard bounds at every sample of the window (issue 35):
/// the hand's position $x$ (state channel 2 of the pendulum's
/// $(\theta, \dot\theta, x, \dot x)$) within $\pm$`x_max` and the
/// command within $\pm$`u_max`, enforced by Gauss-Newton's bounded (QP)
/// step, so a replan never plans the hand out of its workspace whatever
/// the learned model predicts there.
///
/// # Errors
/// A problem that is not the pendulum's (4 states, 1 control), or limits
/// that are not finite and positive.
pub fn bounded<M: trajopt::Dynamics, C: StageCost>(
    problem: Eq3Problem<M, C>,
    x_max: f64,
    u_max: f64,
) -> crate::Result<Eq3Problem<M, C>> {
    crate::error::ensure_data!(
        x_max.is_finite() && x_max > 0.0 && u_max.is_finite() && u_max > 0.0,
        "the hard bounds must be finite and positive, got x_max = {x_max}, u_max = {u_max}"
    );
    let inf = f64::INFINITY;
    Ok(problem
        .with_state_bounds(&[-inf, -inf, -x_max, -inf], &[inf, inf, x_max, inf])?
        .with_control_bounds(&[-u_max], &[u_max])?)
}

/// A plan over the window: `samples + 1` states and `samples` controls,
/// one row per sample.
#[derive(Debug, Clone, PartialEq)]
pub struct WindowPlan {
    /// States, one row per sample.
    pub states: Mat<f64>,
    /// Controls, one row per sample.
    pub controls: Mat<f64>,
}

/// `plan` advanced by `steps`: its samples from `steps` on, the last state
/// and control repeated to keep the window's length.
pub fn shifted(plan: &WindowPlan, steps: usize) -> WindowPlan {
    let (ns, nc) = (plan.states.nrows(), plan.controls.nrows());
    WindowPlan {
        states: Mat::from_fn(ns, plan.states.ncols(), |k, i| {
            plan.states[((k + steps).min(ns - 1), i)]
        }),
        controls: Mat::from_fn(nc, plan.controls.ncols(), |k, j| {
            plan.controls[((k + steps).min(nc - 1), j)]
        }),
    }
}

/// The budget of one replan; see the [module docs](self).
///
/// | field | default |
/// |---|---|
/// | `max_iterations` | 1 |
/// | `tol_cost` | 1e-6 |
/// | `budget` | none |
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReplanSettings {
    /// Gauss-Newton iterations per replan (at least 1).
    pub max_iterations: usize,
    /// Relative cost-decrease tolerance of the solve.
    pub tol_cost: f64,
    /// Deadline of a replan, from its start: the solve stops there with its
    /// best iterate, or the previous plan is kept if no step was accepted
    /// by then; `None`: no time limit.
    pub budget: Option<Duration>,
}

impl Default for ReplanSettings {
    fn default() -> Self {
        Self {
            max_iterations: 1,
            tol_cost: 1e-6,
            budget: None,
        }
    }
}

/// How a replan ended.
#[derive(Debug, Clone, PartialEq)]
pub enum ReplanStatus {
    /// The solve's result is the new plan, with the solver's status.
    Solved(GaussNewtonStatus),
    /// The previous plan, shifted, stays: the budget ran out before a step
    /// was accepted, or the solve failed (the reason, as text).
    KeptPrevious(String),
}

/// One replan: the new plan and what it cost.
#[derive(Debug, Clone)]
pub struct Replan {
    /// The plan the robot executes from now.
    pub plan: WindowPlan,
    /// How it ended.
    pub status: ReplanStatus,
    /// The criterion at the warm start and at the result.
    pub costs: (f64, f64),
    /// Gauss-Newton iterations.
    pub iterations: usize,
    /// Wall time of the replan, the warm start's fit included.
    pub seconds: f64,
}

/// Replans `problem` (made by [`Window::problem`] with the measured state)
/// from `warm` (the previous plan already [`shifted`]); its first state is
/// replaced by `x0`, the measured state, before the fit. See the [module
/// docs](self) for the budget.
///
/// # Errors
/// Only sizes that do not match: a failed solve keeps the previous plan.
pub fn replan<M: trajopt::Dynamics, C: StageCost>(
    window: &Window,
    problem: &Eq3Problem<M, C>,
    warm: &WindowPlan,
    x0: &[f64],
    settings: &ReplanSettings,
) -> crate::Result<Replan> {
    let started = Instant::now();
    let mut watch = Watch::new();
    if let Some(budget) = settings.budget {
        watch = watch.with_time_limit(budget);
    }
    crate::error::ensure_data!(
        x0.len() == warm.states.ncols(),
        "the measured state has {} entries, the plan's states {}",
        x0.len(),
        warm.states.ncols()
    );
    let mut start = warm.clone();
    for (i, &v) in x0.iter().enumerate() {
        start.states[(0, i)] = v;
    }
    let theta = window.fit(problem, &start.states, &start.controls)?;
    let keep = |reason: String, costs: (f64, f64), iterations: usize| Replan {
        plan: warm.clone(),
        status: ReplanStatus::KeptPrevious(reason),
        costs,
        iterations,
        seconds: started.elapsed().as_secs_f64(),
    };
    let solver = GaussNewton::new(GaussNewtonSettings {
        max_iterations: settings.max_iterations.max(1),
        tol_cost: settings.tol_cost,
        ..GaussNewtonSettings::default()
    })?;
    let result = match solver.solve_watched(problem, &theta, &mut watch) {
        Ok(r) if r.cost.is_finite() => r,
        Ok(r) => {
            return Ok(keep(
                format!(
                    "the solve ended at a non-finite criterion ({})",
                    crate::record::PlanStatus::from(r.status)
                ),
                (r.initial_cost, r.cost),
                r.iterations,
            ));
        }
        Err(e) => return Ok(keep(format!("the solve failed: {e}"), (f64::NAN, f64::NAN), 0)),
    };
    let costs = (result.initial_cost, result.cost);
    if result.status == GaussNewtonStatus::TimeLimit && result.cost_history.is_empty() {
        let budget = settings.budget.unwrap_or_default();
        return Ok(keep(
            format!(
                "the budget of {:.1} ms ran out before a step was accepted",
                budget.as_secs_f64() * 1e3
            ),
            costs,
            result.iterations,
        ));
    }
    let (states, controls) = problem.trajectory(&result.x)?;
    Ok(Replan {
        plan: WindowPlan { states, controls },
        status: ReplanStatus::Solved(result.status),
        costs,
        iterations: result.iterations,
        seconds: started.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use trajopt::{LinearModel, TrackingCost};

    /// A warm start over 30 steps that the model does not follow (a ramp
    /// in the first state at a constant rate of 2): a replan has work to do.
    fn inconsistent_warm_start() -> WindowPlan {
        WindowPlan {
            states: Mat::from_fn(31, 2, |k, i| if i == 0 { k as f64 / 30.0 } else { 2.0 }),
            controls: Mat::zeros(30, 1),
        }
    }

    /// A double integrator at 60 Hz and a cost driving it to 1 at rest.
    fn setup(samples: usize) -> (Window, LinearModel, TrackingCost) {
        let dt = 1.0 / 60.0;
        let a = Mat::from_fn(2, 2, |i, j| match (i, j) {
            (0, 0) | (1, 1) => 1.0,
            (0, 1) => dt,
            _ => 0.0,
        });
        let b = Mat::from_fn(2, 1, |i, _| if i == 0 { 0.5 * dt * dt } else { dt });
        let model = LinearModel::new(a, b).expect("model");
        let cost = TrackingCost::new(
            Mat::from_fn(samples + 1, 2, |_, i| if i == 0 { 1.0 } else { 0.0 }),
            Mat::zeros(samples, 1),
            &[1.0, 0.1],
            &[1e-3],
            &[1e3, 1e2],
        )
        .expect("cost");
        (Window::new(samples, dt, 12, 10).expect("window"), model, cost)
    }

    #[test]
    fn shifting_drops_the_executed_steps_and_repeats_the_last() {
        let plan = WindowPlan {
            states: Mat::from_fn(4, 2, |k, i| (10 * k + i) as f64),
            controls: Mat::from_fn(3, 1, |k, _| k as f64),
        };
        let s = shifted(&plan, 2);
        assert_eq!(s.states[(0, 1)], 21.0);
        assert_eq!(s.states[(1, 0)], 30.0);
        assert_eq!(s.states[(3, 0)], 30.0);
        assert_eq!((s.controls[(0, 0)], s.controls[(2, 0)]), (2.0, 2.0));
        assert_eq!(shifted(&plan, 0), plan);
    }

    /// The fit operator reproduces what the bases can represent: a cubic in
    /// time is fitted exactly, so the fitted trajectory equals it.
    #[test]
    fn the_fit_operator_reproduces_a_cubic() {
        let (window, model, cost) = setup(40);
        let problem = window.problem(&model, cost, 1e3, &[0.0, 0.0], 1e4).expect("problem");
        let t = window.times().to_vec();
        let states = Mat::from_fn(41, 2, |k, i| {
            let t = t[k];
            if i == 0 { t * t * t - t } else { 3.0 * t * t - 1.0 }
        });
        let controls = Mat::from_fn(40, 1, |k, _| 6.0 * t[k]);
        let theta = window.fit(&problem, &states, &controls).expect("fit");
        let (xs, us) = problem.trajectory(&theta).expect("trajectory");
        assert!((&xs - &states).norm_max() < 1e-10, "{}", (&xs - &states).norm_max());
        assert!((&us - &controls).norm_max() < 1e-10);
        let short = Mat::<f64>::zeros(40, 2);
        assert!(window.fit(&problem, &short, &controls).is_err());
    }

    /// A replan never ends above its warm start and starts at the measured
    /// state; a converged plan shifted by one step starts the next replan
    /// far closer to its optimum than a cold start.
    #[test]
    fn replans_improve_on_the_warm_start_and_start_at_the_measured_state() {
        let (window, model, cost) = setup(60);
        let x0 = [0.2, -0.5];
        let problem = window.problem(&model, cost.clone(), 1e3, &x0, 1e4).expect("problem");
        let cold = WindowPlan {
            states: Mat::zeros(61, 2),
            controls: Mat::zeros(60, 1),
        };
        let settings = ReplanSettings {
            max_iterations: 50,
            ..ReplanSettings::default()
        };
        let first = replan(&window, &problem, &cold, &x0, &settings).expect("replan");
        assert!(matches!(first.status, ReplanStatus::Solved(_)), "{:?}", first.status);
        assert!(first.costs.1 <= first.costs.0, "{:?}", first.costs);
        assert!(
            (first.plan.states[(0, 0)] - x0[0]).abs() < 1e-2,
            "{}",
            first.plan.states[(0, 0)]
        );
        // one step later, from where the plan said the system would be
        let x1 = [first.plan.states[(1, 0)], first.plan.states[(1, 1)]];
        let problem = window.problem(&model, cost, 1e3, &x1, 1e4).expect("problem");
        let again = replan(&window, &problem, &shifted(&first.plan, 1), &x1, &settings).expect("replan");
        assert!(again.costs.1 <= again.costs.0);
        assert!(
            again.costs.0 < 0.1 * first.costs.0,
            "the shifted plan is no warm start: {:?} against {:?}",
            again.costs,
            first.costs
        );
    }

    /// With [`bounded`], a replan keeps the hand within `x_max` and the
    /// command within `u_max` at every sample, though the cost pulls the
    /// hand to twice `x_max` (which the same replan without bounds plans).
    #[test]
    fn bounded_replans_never_leave_the_bounds() {
        let dt = 1.0 / 60.0;
        let samples = 60;
        // (theta, theta_dot, x, x_dot) with the hand's acceleration u
        // driving x and, reversed, theta
        let a = Mat::from_fn(4, 4, |i, j| match (i, j) {
            (0, 0) | (1, 1) | (2, 2) | (3, 3) => 1.0,
            (0, 1) | (2, 3) => dt,
            _ => 0.0,
        });
        let b = Mat::from_fn(4, 1, |i, _| match i {
            0 => -0.5 * dt * dt,
            1 => -dt,
            2 => 0.5 * dt * dt,
            _ => dt,
        });
        let model = LinearModel::new(a, b).expect("model");
        let (x_max, u_max) = (0.7, 12.0);
        let cost = TrackingCost::new(
            Mat::from_fn(samples + 1, 4, |_, i| if i == 2 { 2.0 * x_max } else { 0.0 }),
            Mat::zeros(samples, 1),
            &[0.0, 0.0, 1.0, 0.1],
            &[1e-6],
            &[0.0, 0.0, 1e3, 1e2],
        )
        .expect("cost");
        let window = Window::new(samples, dt, 12, 10).expect("window");
        let x0 = [0.0; 4];
        let settings = ReplanSettings {
            max_iterations: 50,
            ..ReplanSettings::default()
        };
        let cold = WindowPlan {
            states: Mat::zeros(samples + 1, 4),
            controls: Mat::zeros(samples, 1),
        };
        let free = window.problem(&model, cost.clone(), 1e3, &x0, 1e4).expect("problem");
        let r = replan(&window, &free, &cold, &x0, &settings).expect("replan");
        let reach = (0..=samples).map(|k| r.plan.states[(k, 2)]).fold(0.0, f64::max);
        assert!(reach > 1.2 * x_max, "the unbounded replan stays inside anyway: {reach}");
        let problem = bounded(
            window.problem(&model, cost, 1e3, &x0, 1e4).expect("problem"),
            x_max,
            u_max,
        )
        .expect("bounds");
        let r = replan(&window, &problem, &cold, &x0, &settings).expect("replan");
        assert!(matches!(r.status, ReplanStatus::Solved(_)), "{:?}", r.status);
        for k in 0..=samples {
            assert!(
                r.plan.states[(k, 2)].abs() <= x_max + 1e-6,
                "x at {k}: {}",
                r.plan.states[(k, 2)]
            );
        }
        for k in 0..samples {
            assert!(
                r.plan.controls[(k, 0)].abs() <= u_max + 1e-6,
                "u at {k}: {}",
                r.plan.controls[(k, 0)]
            );
        }
        let reach = (0..=samples).map(|k| r.plan.states[(k, 2)]).fold(0.0, f64::max);
        assert!(
            reach > 0.9 * x_max,
            "the bounded replan does not go to its bound: {reach}"
        );
        // limits that cannot bound anything are refused
        let again = window
            .problem(
                &model,
                TrackingCost::new(
                    Mat::zeros(samples + 1, 4),
                    Mat::zeros(samples, 1),
                    &[1.0; 4],
                    &[1.0],
                    &[1.0; 4],
                )
                .expect("cost"),
                1e3,
                &x0,
                1e4,
            )
            .expect("problem");
        assert!(bounded(again, f64::NAN, u_max).is_err());
    }

    /// A budget that runs out before a step is accepted keeps the previous
    /// plan, exactly (a deadline passing inside the solve is Gauss-Newton's
    /// time limit, tested in `tests/tests/watch.rs`).
    #[test]
    fn over_budget_keeps_the_previous_plan() {
        let (window, model, cost) = setup(30);
        let x0 = [0.0, 0.0];
        let problem = window.problem(&model, cost, 1e3, &x0, 1e4).expect("problem");
        let warm = inconsistent_warm_start();
        let settings = ReplanSettings {
            budget: Some(Duration::ZERO),
            ..ReplanSettings::default()
        };
        let r = replan(&window, &problem, &warm, &x0, &settings).expect("replan");
        assert!(matches!(r.status, ReplanStatus::KeptPrevious(_)), "{:?}", r.status);
        assert_eq!(r.plan, warm);
        assert!(replan(&window, &problem, &warm, &[0.0], &settings).is_err());
    }

    /// The linear model, whose Jacobians take `delay` from their second
    /// evaluation on (a learned model that slows down as the solve goes).
    struct SlowLater {
        inner: LinearModel,
        delay: Duration,
        calls: std::sync::atomic::AtomicUsize,
    }

    impl SlowLater {
        fn wait(&self) {
            if self.calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed) > 0 {
                std::thread::sleep(self.delay);
            }
        }
    }

    impl trajopt::Dynamics for SlowLater {
        fn state_dim(&self) -> usize {
            self.inner.state_dim()
        }
        fn control_dim(&self) -> usize {
            self.inner.control_dim()
        }
        fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> trajopt::ModelResult<()> {
            self.inner.step(x, u, next)
        }
        fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> trajopt::ModelResult<bool> {
            self.wait();
            self.inner.jacobians(x, u, fx, fu)
        }
        fn jacobians_batch(
            &self,
            xs: &[f64],
            us: &[f64],
            fx: &mut [f64],
            fu: &mut [f64],
        ) -> trajopt::ModelResult<bool> {
            self.wait();
            self.inner.jacobians_batch(xs, us, fx, fu)
        }
    }

    /// A deadline that passes after a step was accepted stops the solve
    /// inside it, and the replan keeps the improved plan.
    #[test]
    fn a_deadline_after_an_accepted_step_keeps_the_solves_best_plan() {
        let (window, inner, cost) = setup(30);
        let model = SlowLater {
            inner,
            delay: Duration::from_millis(1500),
            calls: Default::default(),
        };
        let x0 = [0.0, 0.0];
        let problem = window.problem(&model, cost, 1e3, &x0, 1e4).expect("problem");
        let warm = inconsistent_warm_start();
        let settings = ReplanSettings {
            max_iterations: 50,
            tol_cost: 0.0,
            budget: Some(Duration::from_millis(500)),
        };
        let started = Instant::now();
        let r = replan(&window, &problem, &warm, &x0, &settings).expect("replan");
        let took = started.elapsed();
        match &r.status {
            ReplanStatus::Solved(status) => assert_eq!(*status, GaussNewtonStatus::TimeLimit),
            other => panic!("{other:?}"),
        }
        assert!(r.costs.1 < r.costs.0, "{:?}", r.costs);
        assert_ne!(r.plan, warm);
        // stopped after the slow Jacobian, not after the iteration budget
        assert!(took < Duration::from_millis(1500) * 3, "{took:?}");
    }
}
