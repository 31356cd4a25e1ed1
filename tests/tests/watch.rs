//! Every iterative solver of the workspace under one [`solve::Watch`]: an
//! observer's stop ends the solve after the iteration it saw, with the
//! best point so far and a `Stopped` status; a time limit ends it inside
//! the solve, with no more evaluations after the limit than each solver's
//! documented granularity (Powell's: none; Gauss-Newton's: one Jacobian and
//! one trial step; the derivative-free mode's: one differenced Jacobian and
//! one trial step; DDP's: one rollout); and the statuses map onto the one
//! [`solve::Termination`].

use ddp::ModelResult;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use ddp::{Ddp, DdpProblem, DdpSettings, DdpStatus, Dynamics};
use faer::sparse::SymbolicSparseRowMat;
use lwr::{LwrModel, LwrSettings, TuneSettings, TuneStatus};
use solve::{Control, Progress, Status, Termination, Trace, Watch};
use trajopt::powell::{Powell, PowellSettings, PowellStatus};
use trajopt::problems::pendulum_swingup;
use trajopt::{
    DerivativeFree, DerivativeFreeSettings, GaussNewton, GaussNewtonSettings, GaussNewtonStatus, LeastSquaresProblem,
};

/// When each evaluation began, and a pause in each.
struct Clock {
    starts: Mutex<Vec<Instant>>,
    pause: Duration,
}

impl Clock {
    fn new(pause: Duration) -> Self {
        Self {
            starts: Mutex::new(Vec::new()),
            pause,
        }
    }

    fn tick(&self) {
        self.starts.lock().expect("clock").push(Instant::now());
        std::thread::sleep(self.pause);
    }

    /// Evaluations begun at or after `deadline`.
    fn after(&self, deadline: Instant) -> usize {
        self.starts
            .lock()
            .expect("clock")
            .iter()
            .filter(|&&t| t >= deadline)
            .count()
    }
}

/// A least-squares problem whose residuals and Jacobian take time.
struct Slow<'a, P> {
    inner: P,
    clock: &'a Clock,
}

impl<P: LeastSquaresProblem> LeastSquaresProblem for Slow<'_, P> {
    fn n_params(&self) -> usize {
        self.inner.n_params()
    }
    fn n_residuals(&self) -> usize {
        self.inner.n_residuals()
    }
    fn residuals(&self, theta: &[f64], r: &mut [f64]) -> trajopt::Result<()> {
        self.clock.tick();
        self.inner.residuals(theta, r)
    }
    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
        self.inner.jacobian_pattern()
    }
    fn jacobian_values(&self, theta: &[f64], values: &mut [f64]) -> trajopt::Result<()> {
        self.clock.tick();
        self.inner.jacobian_values(theta, values)
    }
}

/// Stops at iteration `at`, recording the costs it saw.
fn stop_at(at: usize, seen: &mut Vec<f64>) -> impl FnMut(&Progress<'_>) -> Control + '_ {
    move |p: &Progress<'_>| {
        seen.push(p.cost);
        if p.iteration >= at {
            Control::Stop
        } else {
            Control::Continue
        }
    }
}

#[test]
fn gauss_newton_stops_on_request_and_on_time() {
    let gn = GaussNewton::new(GaussNewtonSettings::default()).expect("settings");
    let (problem, theta0) = pendulum_swingup(60, 10.0).expect("problem");
    let free = gn.solve(&problem, &theta0).expect("solve");
    assert!(free.status.is_converged() && free.iterations > 3, "{free:?}");

    let mut seen = Vec::new();
    let mut trace = Trace::new();
    let r = {
        let mut stop = stop_at(2, &mut seen);
        let mut watch = Watch::new().with_observer(&mut trace).with_observer(&mut stop);
        gn.solve_watched(&problem, &theta0, &mut watch).expect("solve")
    };
    assert_eq!((r.status, r.iterations), (GaussNewtonStatus::Stopped, 2));
    assert_eq!(r.status.termination(), Termination::Stopped);
    // the observers saw the accepted costs, and the result is the last one
    assert_eq!(seen, r.cost_history);
    assert_eq!(trace.records.iter().map(|t| t.cost).collect::<Vec<_>>(), seen);
    assert_eq!(trace.records.last().map(|t| t.evaluations), Some(r.evals));
    assert_eq!(r.x, free_prefix(&gn, &problem, &theta0, 2));

    // a limit inside the solve: at most one Jacobian and one trial step after it
    let clock = Clock::new(Duration::from_millis(4));
    let slow = Slow {
        inner: pendulum_swingup(60, 10.0).expect("problem").0,
        clock: &clock,
    };
    let limit = Duration::from_millis(30);
    let mut watch = Watch::new().with_time_limit(limit);
    let deadline = Instant::now() + limit;
    let r = gn.solve_watched(&slow, &theta0, &mut watch).expect("solve");
    assert_eq!(r.status, GaussNewtonStatus::TimeLimit);
    assert_eq!(r.status.termination(), Termination::TimeLimit);
    assert!(r.iterations < free.iterations, "{} iterations", r.iterations);
    assert!(
        clock.after(deadline) <= 2,
        "{} evaluations after the limit",
        clock.after(deadline)
    );
    assert!(r.cost <= r.initial_cost);
}

/// The parameters after `k` iterations of an unwatched solve.
fn free_prefix<P: LeastSquaresProblem>(gn: &GaussNewton, problem: &P, theta0: &[f64], k: usize) -> Vec<f64> {
    let capped = GaussNewton::new(GaussNewtonSettings {
        max_iterations: k,
        ..gn.settings().clone()
    })
    .expect("settings");
    let r = capped.solve(problem, theta0).expect("solve");
    assert_eq!(r.status, GaussNewtonStatus::MaxIterations);
    r.x
}

#[test]
fn the_derivative_free_mode_stops_on_request_and_on_time() {
    let df = DerivativeFree::new(DerivativeFreeSettings::default()).expect("settings");
    let (problem, theta0) = pendulum_swingup(40, 10.0).expect("problem");
    let mut seen = Vec::new();
    let mut trace = Trace::new();
    let r = {
        let mut stop = stop_at(1, &mut seen);
        let mut watch = Watch::new().with_observer(&mut trace).with_observer(&mut stop);
        df.solve_watched(&problem, &theta0, &mut watch).expect("solve")
    };
    assert_eq!((r.status, r.iterations), (GaussNewtonStatus::Stopped, 1));
    // the observers count the differences' evaluations too
    assert_eq!(trace.records[0].evaluations, r.evals);
    assert!(r.evals > r.jacobian_groups);
    assert_eq!(seen, vec![r.cost]);

    let clock = Clock::new(Duration::from_millis(1));
    let slow = Slow {
        inner: pendulum_swingup(40, 10.0).expect("problem").0,
        clock: &clock,
    };
    let limit = Duration::from_millis(40);
    let mut watch = Watch::new().with_time_limit(limit);
    let deadline = Instant::now() + limit;
    let r = df.solve_watched(&slow, &theta0, &mut watch).expect("solve");
    assert_eq!(r.status, GaussNewtonStatus::TimeLimit);
    let after = clock.after(deadline);
    assert!(after <= r.jacobian_groups + 2, "{after} evaluations after the limit");
}

#[test]
fn powell_stops_on_request_and_evaluates_nothing_after_its_limit() {
    let rosenbrock = |x: &[f64]| -> trajopt::Result<f64> {
        Ok(x.windows(2)
            .map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2))
            .sum())
    };
    let powell = Powell::new(PowellSettings::default()).expect("settings");
    let x0 = [-1.2, 1.0, -0.5, 0.8];
    let free = powell.solve(&rosenbrock, &x0).expect("solve");
    assert!(free.iterations > 3);

    let mut seen = Vec::new();
    let r = {
        let mut stop = stop_at(3, &mut seen);
        let mut watch = Watch::new().with_observer(&mut stop);
        powell.solve_watched(&rosenbrock, &x0, &mut watch).expect("solve")
    };
    assert_eq!((r.status, r.iterations), (PowellStatus::Stopped, 3));
    assert_eq!(seen, r.cost_history);
    assert_eq!(&free.cost_history[..3], &r.cost_history[..]);
    assert_eq!(rosenbrock(&r.x).expect("cost"), r.cost);

    let clock = Clock::new(Duration::from_micros(500));
    let slow = |x: &[f64]| {
        clock.tick();
        rosenbrock(x)
    };
    let limit = Duration::from_millis(30);
    let mut watch = Watch::new().with_time_limit(limit);
    let deadline = Instant::now() + limit;
    let r = powell.solve_watched(&slow, &x0, &mut watch).expect("solve");
    assert_eq!(r.status, PowellStatus::TimeLimit);
    assert_eq!(r.status.termination(), Termination::TimeLimit);
    assert_eq!(clock.after(deadline), 0);
    // every evaluation counted was made, and the cost is the one at x
    assert_eq!(r.evals, clock.starts.lock().expect("clock").len());
    assert_eq!(rosenbrock(&r.x).expect("cost"), r.cost);
    assert_eq!(PowellStatus::ReachedStopCost.termination(), Termination::TargetReached);
}

/// Dynamics whose steps take time.
struct SlowDynamics<'a, D> {
    inner: D,
    clock: &'a Clock,
}

impl<D: Dynamics> Dynamics for SlowDynamics<'_, D> {
    fn state_dim(&self) -> usize {
        self.inner.state_dim()
    }
    fn control_dim(&self) -> usize {
        self.inner.control_dim()
    }
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        self.clock.tick();
        self.inner.step(x, u, next)
    }
    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        self.inner.jacobians(x, u, fx, fu)
    }
}

#[test]
fn ddp_stops_on_request_and_on_time_with_a_policy() {
    let solver = Ddp::new(DdpSettings::default()).expect("settings");
    let problem = ddp::problems::pendulum_swingup(50).expect("problem");
    let free = solver.solve(&problem).expect("solve");
    assert!(free.iterations > 3, "{:?}", free.status);

    let mut seen = Vec::new();
    let r = {
        let mut stop = stop_at(2, &mut seen);
        let mut watch = Watch::new().with_observer(&mut stop);
        solver.solve_watched(&problem, &mut watch).expect("solve")
    };
    assert_eq!((r.status, r.iterations), (DdpStatus::Stopped, 2));
    assert!(!r.status.is_failure());
    assert_eq!(seen, free.cost_history[1..3].to_vec());
    assert_eq!(r.gains.len(), 50);

    let clock = Clock::new(Duration::from_micros(200));
    let slow = DdpProblem::new(
        SlowDynamics {
            inner: *problem.dynamics(),
            clock: &clock,
        },
        problem.cost().clone(),
        problem.initial_state(),
        50,
    )
    .expect("problem");
    // each rollout sleeps at least 10 ms: the limit falls before the fourth iteration
    let limit = Duration::from_millis(25);
    let mut watch = Watch::new().with_time_limit(limit);
    let deadline = Instant::now() + limit;
    let r = solver.solve_watched(&slow, &mut watch).expect("solve");
    assert_eq!(r.status, DdpStatus::TimeLimit);
    assert_eq!(r.status.termination(), Termination::TimeLimit);
    assert!(r.iterations < free.iterations);
    // at most the rollout under way at the limit
    assert!(
        clock.after(deadline) <= 50,
        "{} steps after the limit",
        clock.after(deadline)
    );
    assert_eq!(r.gains.len(), 50);
}

#[test]
fn lwr_tuning_stops_on_request_and_on_time() {
    let mut m = LwrModel::new(
        2,
        1,
        LwrSettings {
            bandwidth: 0.5,
            ..Default::default()
        },
    )
    .expect("model");
    for i in 0..800 {
        let x0 = (i as f64 * 0.618).fract() * 2.0 - 1.0;
        let x1 = (i as f64 * 0.377).fract() * 2.0 - 1.0;
        m.insert(&[x0, x1], &[(3.0 * x0).sin() + 0.3 * x1]).expect("insert");
    }
    let tune = TuneSettings::default();
    let free = m.tune(&tune).expect("tune");
    assert_eq!(free.status, TuneStatus::Converged);

    let mut sweeps = 0;
    let mut one = |p: &Progress<'_>| {
        sweeps += 1;
        assert_eq!(p.solver, "lwr-tune");
        Control::Stop
    };
    let r = {
        let mut watch = Watch::new().with_observer(&mut one);
        m.tune_watched(&tune, &mut watch).expect("tune")
    };
    assert_eq!(sweeps, 1);
    assert_eq!(r.status, TuneStatus::Stopped);
    assert!(r.evals < free.evals && r.objective <= r.initial_objective);
    assert_eq!(&free.history[..r.evals], &r.history[..]);

    let mut watch = Watch::new().with_time_limit(Duration::ZERO);
    let r = m.tune_watched(&tune, &mut watch).expect("tune");
    // the start only: every later evaluation is behind the limit
    assert_eq!((r.status, r.evals), (TuneStatus::TimeLimit, 1));
    assert_eq!(r.status.termination(), Termination::TimeLimit);
    assert_eq!(r.settings.bandwidth, 0.5);
}
