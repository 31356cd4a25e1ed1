//! Scenarios for `trajopt::powell`: the classic test functions, scipy golden
//! values (`tests/data/scipy_powell.json`, from
//! `scripts/golden/scipy_powell_golden.py`), bounds, non-finite regions, the
//! argmin integration, and the never-worse-than-the-start property.

use std::cell::{Cell, RefCell};

use argmin::core::{CostFunction, Executor, State, TerminationReason};
use proptest::prelude::*;
use trajopt::TrajoptError;
use trajopt::powell::{Objective, Powell, PowellArgmin, PowellSettings, PowellStatus};

use trajopt::problems::{powell_singular, rosenbrock};

/// Counts evaluations and records when the best value first reached a target.
struct Recorder<F> {
    f: F,
    evals: Cell<usize>,
    best: Cell<f64>,
    history: RefCell<Vec<f64>>,
}

impl<F: Fn(&[f64]) -> f64> Recorder<F> {
    fn new(f: F) -> Self {
        Self {
            f,
            evals: Cell::new(0),
            best: Cell::new(f64::INFINITY),
            history: RefCell::new(Vec::new()),
        }
    }

    /// Evaluations until the best value was at or below `target`.
    fn evals_to_reach(&self, target: f64) -> Option<usize> {
        self.history.borrow().iter().position(|&b| b <= target).map(|i| i + 1)
    }
}

impl<F: Fn(&[f64]) -> f64> Objective for Recorder<F> {
    fn cost(&self, x: &[f64]) -> trajopt::Result<f64> {
        let v = (self.f)(x);
        self.evals.set(self.evals.get() + 1);
        self.best.set(self.best.get().min(v));
        self.history.borrow_mut().push(self.best.get());
        Ok(v)
    }
}

fn default_powell() -> Powell {
    Powell::new(PowellSettings::default()).expect("default settings are valid")
}

struct Golden {
    x0: Vec<f64>,
    minimiser: Vec<f64>,
    x: Vec<f64>,
    cost: f64,
    nfev: usize,
    nfev_to_final: usize,
}

fn golden(name: &str) -> Golden {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/scipy_powell.json"))
        .expect("golden file");
    let json: serde_json::Value = serde_json::from_str(&text).expect("valid json");
    let problem = json["problems"]
        .as_array()
        .expect("problems")
        .iter()
        .find(|p| p["name"] == name)
        .expect("problem in the golden file");
    let vector = |key: &str| -> Vec<f64> {
        problem[key]
            .as_array()
            .expect("array")
            .iter()
            .map(|v| v.as_f64().expect("number"))
            .collect()
    };
    let count = |key: &str| problem[key].as_u64().expect("count") as usize;
    Golden {
        x0: vector("x0"),
        minimiser: vector("minimiser"),
        x: vector("x"),
        cost: problem["cost"].as_f64().expect("cost"),
        nfev: count("nfev"),
        nfev_to_final: count("nfev_to_final"),
    }
}

#[test]
fn rosenbrock_matches_scipy_with_fewer_evaluations() {
    let g = golden("rosenbrock");
    let f = Recorder::new(rosenbrock);
    let result = default_powell().solve(&f, &g.x0).expect("solve");
    assert!(result.status.is_converged(), "{:?}", result.status);
    for (ours, theirs) in result.x.iter().zip(&g.x) {
        assert!((ours - theirs).abs() < 1e-4, "{:?} vs scipy {:?}", result.x, g.x);
    }
    assert!((result.cost - g.cost).abs() < 1e-8, "{} vs {}", result.cost, g.cost);
    assert_eq!(result.evals, f.evals.get());
    // scipy: 607 evaluations; the target is no more than scipy's
    assert!(result.evals <= g.nfev, "{} evaluations, scipy {}", result.evals, g.nfev);
    assert!(result.cost <= result.initial_cost);
}

/// scipy stops on this degenerate (quartic) minimum when its direction set
/// has become linearly dependent (two of its final directions are parallel)
/// and a sweep no longer decreases f by the relative `ftol`, at f ≈ 1.7e-13
/// with x ≈ 2.6e-4 away from the minimiser. Our stopping rule is the same,
/// but our sweeps keep decreasing f, so it fires much lower (f ≈ 3e-19);
/// scipy's x is no reference at 1e-4.
#[test]
fn powell_singular_goes_lower_than_scipy_in_fewer_evaluations() {
    let g = golden("powell_singular");
    let f = Recorder::new(powell_singular);
    let result = default_powell().solve(&f, &g.x0).expect("solve");
    assert_eq!(result.status, PowellStatus::ConvergedCost);
    assert!(result.cost <= 1e-4 * g.cost, "{} vs scipy {}", result.cost, g.cost);
    for (ours, best) in result.x.iter().zip(&g.minimiser) {
        assert!((ours - best).abs() < 1e-4, "{:?}", result.x);
    }
    let reach = f.evals_to_reach(g.cost).expect("reaches scipy's cost");
    assert!(
        reach < g.nfev_to_final,
        "{reach} evaluations to reach scipy's cost, scipy {}",
        g.nfev_to_final
    );
}

/// The target: no more evaluations than scipy's Powell at its
/// default (matched) tolerances, on the classic problems of the golden file.
/// Deterministic; when written, the counts were 313 (scipy 607) and 778
/// (scipy 908). Not asserted exactly: `powi` may round differently between
/// optimisation levels, and a last-bit change moves the count a little.
#[test]
fn evaluation_counts_stay_at_or_below_scipys() {
    for (name, f) in [
        ("rosenbrock", rosenbrock as fn(&[f64]) -> f64),
        ("powell_singular", powell_singular),
    ] {
        let g = golden(name);
        let objective = |x: &[f64]| -> trajopt::Result<f64> { Ok(f(x)) };
        let result = default_powell().solve(&objective, &g.x0).expect("solve");
        assert!(result.status.is_converged(), "{name}: {:?}", result.status);
        assert!(
            result.evals <= g.nfev,
            "{name}: {} evaluations, scipy {}",
            result.evals,
            g.nfev
        );
        assert!(
            result.cost <= g.cost.max(1e-20),
            "{name}: {} vs scipy {}",
            result.cost,
            g.cost
        );
        assert_eq!(f(&result.x), result.cost, "{name}: the cost is the cost at x");
        // the argmin solver does the same iterations
        let solver = PowellArgmin::new(PowellSettings::default()).expect("settings");
        let run = Executor::new(Argmin(f), solver)
            .configure(|state| state.param(g.x0.clone()))
            .run()
            .expect("argmin run");
        assert_eq!(run.solver().evals(), result.evals, "{name}");
    }
}

#[test]
fn convex_quadratic_in_10d_reaches_its_minimiser() {
    // f(x) = sum_i (i + 1) d_i^2 + sum_i 0.5 d_i d_{i+1}, d = x - c: positive
    // definite (diagonally dominant), minimiser c
    let c: Vec<f64> = (0..10).map(|i| (i as f64 - 4.5) / 3.0).collect();
    let f = |x: &[f64]| -> trajopt::Result<f64> {
        let d: Vec<f64> = x.iter().zip(&c).map(|(x, c)| x - c).collect();
        Ok((0..10).map(|i| (i + 1) as f64 * d[i] * d[i]).sum::<f64>()
            + (0..9).map(|i| 0.5 * d[i] * d[i + 1]).sum::<f64>())
    };
    let result = default_powell().solve(&f, &[0.0; 10]).expect("solve");
    assert!(result.status.is_converged(), "{:?}", result.status);
    for (x, c) in result.x.iter().zip(&c) {
        assert!((x - c).abs() < 1e-6, "{:?}", result.x);
    }
    assert!(result.cost < 1e-12);
}

#[test]
fn bounded_minimiser_on_the_bound() {
    // Rosenbrock in [-2, 0.5] x [-2, 2]: the constrained minimiser is
    // (0.5, 0.25) with f = 0.25, on the bound x_0 = 0.5
    let settings = PowellSettings {
        bounds: Some((vec![-2.0, -2.0], vec![0.5, 2.0])),
        ..PowellSettings::default()
    };
    let f = |x: &[f64]| -> trajopt::Result<f64> { Ok(rosenbrock(x)) };
    // from inside, and from outside (clipped into the box)
    for x0 in [[-1.2, 1.0], [3.0, -5.0]] {
        let result = Powell::new(settings.clone())
            .expect("settings")
            .solve(&f, &x0)
            .expect("solve");
        assert!(result.status.is_converged(), "{:?}", result.status);
        assert!((result.x[0] - 0.5).abs() < 1e-9, "{:?}", result.x);
        assert!((result.x[1] - 0.25).abs() < 1e-5, "{:?}", result.x);
        assert!((result.cost - 0.25).abs() < 1e-9, "{}", result.cost);
        assert!(result.x[0] <= 0.5);
    }
}

#[test]
fn every_evaluation_stays_inside_the_box() {
    let lower = vec![-1.0, 0.2, -0.5];
    let upper = vec![0.3, 2.0, f64::INFINITY];
    let settings = PowellSettings {
        bounds: Some((lower.clone(), upper.clone())),
        ..PowellSettings::default()
    };
    let outside = Cell::new(0);
    let f = |x: &[f64]| -> trajopt::Result<f64> {
        if x.iter().zip(&lower).zip(&upper).any(|((x, l), u)| x < l || x > u) {
            outside.set(outside.get() + 1);
        }
        Ok(rosenbrock(&x[..2]) + (x[2] - 7.0).powi(2))
    };
    let result = Powell::new(settings)
        .expect("settings")
        .solve(&f, &[0.0, 1.0, 0.0])
        .expect("solve");
    assert_eq!(outside.get(), 0, "{result:?}");
    assert!((result.x[0] - 0.3).abs() < 1e-9, "{:?}", result.x);
    assert!((result.x[2] - 7.0).abs() < 1e-5, "{result:?}");
}

#[test]
fn survives_a_nan_region() {
    // NaN where x_0 > 1.5; the minimiser (2, 1) is inside the NaN region, so
    // the best point is on its edge
    let f = |x: &[f64]| -> trajopt::Result<f64> {
        Ok(if x[0] > 1.5 {
            f64::NAN
        } else {
            (x[0] - 2.0).powi(2) + (x[1] - 1.0).powi(2)
        })
    };
    let result = default_powell().solve(&f, &[0.0, 0.0]).expect("solve");
    assert!(result.cost.is_finite());
    assert!(result.cost <= result.initial_cost);
    assert!(result.x[0] <= 1.5 && result.x[0] > 1.49, "{:?}", result.x);
    assert!((result.x[1] - 1.0).abs() < 1e-6, "{:?}", result.x);

    // infinities and NaN around the Rosenbrock valley: the minimum is found
    let g = |x: &[f64]| -> trajopt::Result<f64> {
        Ok(if x[0] + x[1] > 3.0 {
            f64::INFINITY
        } else if x[0] < -2.0 {
            f64::NAN
        } else {
            rosenbrock(x)
        })
    };
    let result = default_powell().solve(&g, &[-1.2, 1.0]).expect("solve");
    assert!((result.x[0] - 1.0).abs() < 1e-6 && (result.x[1] - 1.0).abs() < 1e-6);
}

#[test]
fn input_errors() {
    let powell = default_powell();
    let f = |x: &[f64]| -> trajopt::Result<f64> { Ok(rosenbrock(x)) };
    assert!(matches!(
        powell.solve(&f, &[]),
        Err(TrajoptError::InvalidParameter { .. })
    ));
    assert!(matches!(
        powell.solve(&f, &[f64::INFINITY, 0.0]),
        Err(TrajoptError::NotFinite { index: 0, .. })
    ));
    let nan_at_start = |x: &[f64]| -> trajopt::Result<f64> { Ok(if x[0] == 0.0 { f64::NAN } else { 1.0 }) };
    assert!(matches!(
        powell.solve(&nan_at_start, &[0.0]),
        Err(TrajoptError::NonFiniteStart { .. })
    ));
}

struct ArgminRosenbrock;

/// Any test function as an argmin problem.
struct Argmin(fn(&[f64]) -> f64);

impl CostFunction for Argmin {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        Ok((self.0)(x))
    }
}

impl CostFunction for ArgminRosenbrock {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        Ok(rosenbrock(x))
    }
}

#[test]
fn argmin_executor_reaches_the_same_minimum() {
    let direct = default_powell()
        .solve(&|x: &[f64]| Ok(rosenbrock(x)), &[-1.2, 1.0])
        .expect("solve");
    let solver = PowellArgmin::new(PowellSettings::default()).expect("settings");
    let result = Executor::new(ArgminRosenbrock, solver)
        .configure(|state| state.param(vec![-1.2, 1.0]).max_iters(100).counting(true))
        .run()
        .expect("argmin run");
    let state = result.state();
    let best = state.get_best_param().expect("best point");
    // the same iterations: the same point, cost and evaluation count
    assert_eq!(best, &direct.x);
    assert_eq!(state.get_best_cost(), direct.cost);
    assert_eq!(state.get_iter() as usize, direct.iterations);
    assert_eq!(
        state.get_termination_reason(),
        Some(&TerminationReason::SolverConverged)
    );
    assert_eq!(state.get_func_counts()["cost_count"] as usize, direct.evals);
    assert_eq!(result.solver().evals(), direct.evals);
    assert_eq!(result.solver().status(), Some(direct.status));
}

#[test]
fn argmin_executor_limits() {
    let solver = PowellArgmin::new(PowellSettings::default()).expect("settings");
    let result = Executor::new(ArgminRosenbrock, solver)
        .configure(|state| state.param(vec![-1.2, 1.0]).max_iters(3))
        .run()
        .expect("argmin run");
    assert_eq!(result.state().get_iter(), 3);
    assert_eq!(
        result.state().get_termination_reason(),
        Some(&TerminationReason::MaxItersReached)
    );

    let solver = PowellArgmin::new(PowellSettings {
        max_evals: Some(50),
        ..PowellSettings::default()
    })
    .expect("settings");
    let result = Executor::new(ArgminRosenbrock, solver)
        .configure(|state| state.param(vec![-1.2, 1.0]))
        .run()
        .expect("argmin run");
    assert!(result.solver().evals() <= 50);
    assert_eq!(result.solver().status(), Some(PowellStatus::MaxEvaluations));
    assert!(matches!(
        result.state().get_termination_reason(),
        Some(TerminationReason::SolverExit(_))
    ));

    // no start point: an error, not a panic
    let solver = PowellArgmin::new(PowellSettings::default()).expect("settings");
    assert!(Executor::new(ArgminRosenbrock, solver).run().is_err());
}

/// A random convex quadratic $\tfrac12 (x - c)^\top A (x - c)$, $A = B^\top B + 0.01 I$.
fn quadratic_problem() -> impl Strategy<Value = (Vec<f64>, Vec<f64>, Vec<f64>)> {
    (1usize..8).prop_flat_map(|n| {
        (
            prop::collection::vec(-3.0..3.0f64, n * n),
            prop::collection::vec(-5.0..5.0f64, n),
            prop::collection::vec(-5.0..5.0f64, n),
        )
    })
}

fn quadratic(b: &[f64], c: &[f64], x: &[f64]) -> f64 {
    let n = c.len();
    let d: Vec<f64> = x.iter().zip(c).map(|(x, c)| x - c).collect();
    let bd: f64 = (0..n)
        .map(|i| (0..n).map(|j| b[i * n + j] * d[j]).sum::<f64>().powi(2))
        .sum();
    0.5 * bd + 0.005 * d.iter().map(|v| v * v).sum::<f64>()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, rng_seed: proptest::test_runner::RngSeed::Fixed(0x9e11), ..ProptestConfig::default() })]

    #[test]
    fn never_worse_than_the_start((b, c, x0) in quadratic_problem()) {
        let f = |x: &[f64]| -> trajopt::Result<f64> { Ok(quadratic(&b, &c, x)) };
        let result = default_powell().solve(&f, &x0).expect("solve");
        let start = quadratic(&b, &c, &x0);
        prop_assert_eq!(result.initial_cost, start);
        prop_assert!(result.cost <= start);
        prop_assert_eq!(quadratic(&b, &c, &result.x), result.cost);
    }

    #[test]
    fn never_worse_than_the_start_with_bounds_and_budgets(
        (b, c, x0) in quadratic_problem(),
        half_width in 0.0..4.0f64,
        max_evals in 1usize..200,
    ) {
        let n = c.len();
        let settings = PowellSettings {
            bounds: Some((vec![-half_width; n], vec![half_width; n])),
            max_evals: Some(max_evals),
            ..PowellSettings::default()
        };
        let f = |x: &[f64]| -> trajopt::Result<f64> { Ok(quadratic(&b, &c, x)) };
        let result = Powell::new(settings).expect("settings").solve(&f, &x0).expect("solve");
        let clipped: Vec<f64> = x0.iter().map(|v| v.clamp(-half_width, half_width)).collect();
        prop_assert!(result.cost <= quadratic(&b, &c, &clipped));
        prop_assert!(result.evals <= max_evals);
        prop_assert!(result.x.iter().all(|v| v.abs() <= half_width));
    }

    /// With the principal-axes resets (every 1 to 5 iterations), a
    /// converged status on a random convex quadratic means its minimum: the
    /// minimum value is 0 at c, and the status must say converged.
    #[test]
    fn principal_axes_converge_at_the_minimum((b, c, x0) in quadratic_problem(), every in 1usize..6) {
        let settings = PowellSettings { principal_axes: every, ..PowellSettings::default() };
        let f = |x: &[f64]| -> trajopt::Result<f64> { Ok(quadratic(&b, &c, x)) };
        let result = Powell::new(settings).expect("settings").solve(&f, &x0).expect("solve");
        prop_assert!(result.status.is_converged(), "{:?} at {}", result.status, result.cost);
        let start = quadratic(&b, &c, &x0);
        prop_assert!(result.cost <= 1e-8 * (1.0 + start), "{} from {}", result.cost, start);
    }

    #[test]
    fn nan_regions_are_survived((b, c, x0) in quadratic_problem(), cut in -5.0..5.0f64) {
        // NaN on one side of a random hyperplane through the cut
        let f = |x: &[f64]| -> trajopt::Result<f64> {
            Ok(if x[0] > cut.max(x0[0]) { f64::NAN } else { quadratic(&b, &c, x) })
        };
        let result = default_powell().solve(&f, &x0).expect("solve");
        prop_assert!(result.cost.is_finite());
        prop_assert!(result.cost <= quadratic(&b, &c, &x0));
    }
}
