//! `Powell::solve_separable`: the same iterations as `Powell::solve` with
//! fewer term evaluations, on a chained Rosenbrock function and on Eq. 3
//! through `BandTerms`.

use trajopt::powell::{BandTerms, Objective, SeparableObjective};
use trajopt::problems::trajectory::{self, SwingUpProblem};
use trajopt::{Powell, PowellSettings};

/// $\sum_{k < n-1} 100 (x_{k+1} - x_k^2)^2 + (1 - x_k)^2$, one term per $k$.
struct ChainedRosenbrock {
    terms_of: Vec<Vec<usize>>,
}

impl ChainedRosenbrock {
    fn new(n: usize) -> Self {
        let terms_of = (0..n)
            .map(|j| {
                [j.checked_sub(1), (j + 1 < n).then_some(j)]
                    .into_iter()
                    .flatten()
                    .collect()
            })
            .collect();
        Self { terms_of }
    }

    fn term(x: &[f64], k: usize) -> f64 {
        100.0 * (x[k + 1] - x[k] * x[k]).powi(2) + (1.0 - x[k]).powi(2)
    }
}

impl Objective for ChainedRosenbrock {
    fn cost(&self, x: &[f64]) -> trajopt::Result<f64> {
        Ok((0..x.len() - 1).map(|k| Self::term(x, k)).sum())
    }
}

impl SeparableObjective for ChainedRosenbrock {
    fn n_terms(&self) -> usize {
        self.terms_of.len() - 1
    }

    fn terms_of(&self, j: usize) -> &[usize] {
        &self.terms_of[j]
    }

    fn terms(&self, x: &[f64], which: &[usize], values: &mut [f64]) -> trajopt::Result<()> {
        for &k in which {
            values[k] = Self::term(x, k);
        }
        Ok(())
    }
}

#[test]
fn separable_solve_follows_the_plain_solve() {
    let f = ChainedRosenbrock::new(8);
    let x0: Vec<f64> = (0..8).map(|i| if i % 2 == 0 { -1.2 } else { 1.0 }).collect();
    let powell = Powell::new(PowellSettings::default()).expect("defaults");
    let plain = powell.solve(&f, &x0).expect("solve");
    let banded = powell.solve_separable(&f, &x0).expect("solve_separable");
    assert!(plain.status.is_converged() && banded.status.is_converged());
    assert!(
        plain.cost < 1e-12 && banded.cost < 1e-12,
        "{} {}",
        plain.cost,
        banded.cost
    );
    for (a, b) in plain.x.iter().zip(&banded.x) {
        assert!((a - b).abs() < 1e-6, "{:?} vs {:?}", plain.x, banded.x);
    }
    // the same iterations: about as many evaluations, far less work
    let ratio = banded.evals as f64 / plain.evals as f64;
    assert!((0.8..1.25).contains(&ratio), "{} vs {}", banded.evals, plain.evals);
    assert_eq!(plain.full_eval_equivalents, plain.evals as f64);
    assert!(banded.full_eval_equivalents < 0.8 * banded.evals as f64, "{banded:?}");
    assert!((f.cost(&banded.x).expect("cost") - banded.cost).abs() <= 1e-12);
}

/// The standard pendulum instance (horizon 50, lambda 1e2) and its start.
fn pendulum() -> (SwingUpProblem, Vec<f64>) {
    trajectory::by_name("pendulum-h50-lambda1e2")
        .expect("standard")
        .problem()
        .expect("problem")
}

#[test]
fn band_terms_sum_to_the_eq3_criterion() {
    let (problem, theta0) = pendulum();
    let terms = BandTerms::new(&problem, problem.horizon() + 1, &theta0).expect("terms");
    let k = terms.n_terms();
    let all: Vec<usize> = (0..k).collect();
    let theta: Vec<f64> = theta0
        .iter()
        .enumerate()
        .map(|(i, v)| v + 0.1 * (i as f64).sin())
        .collect();
    let mut values = vec![0.0; k];
    terms.terms(&theta, &all, &mut values).expect("terms");
    let sum: f64 = values.iter().sum();
    let cost = problem.cost(&theta).expect("cost");
    assert!((sum - cost).abs() <= 1e-10 * cost, "{sum} vs {cost}");
    assert!((terms.cost(&theta).expect("cost") - cost).abs() <= 1e-10 * cost);
    // changing one parameter changes exactly the terms listed for it
    for j in [0, 1, 37, theta.len() - 1] {
        let mut moved = theta.clone();
        moved[j] += 0.5;
        let mut after = vec![0.0; k];
        terms.terms(&moved, &all, &mut after).expect("terms");
        let changed: Vec<usize> = (0..k).filter(|&t| after[t] != values[t]).collect();
        for t in &changed {
            assert!(
                terms.terms_of(j).contains(t),
                "parameter {j} changes term {t}, not listed"
            );
        }
        assert!(terms.terms_of(j).len() <= 3, "{:?}", terms.terms_of(j));
    }
}

#[test]
fn separable_solve_on_eq3_matches_the_plain_solve_early_on() {
    let (problem, theta0) = pendulum();
    let terms = BandTerms::new(&problem, problem.horizon() + 1, &theta0).expect("terms");
    let powell = Powell::new(PowellSettings {
        max_evals: Some(3000),
        ..PowellSettings::default()
    })
    .expect("settings");
    let plain = powell.solve(&problem, &theta0).expect("solve");
    let banded = powell.solve_separable(&terms, &theta0).expect("solve_separable");
    assert!(banded.cost < banded.initial_cost);
    // the sums round differently, and Brent's 1e-2 relative tolerance on
    // the step lets that choose slightly different steps: the paths differ
    // a little, the progress does not
    assert!(
        (plain.cost - banded.cost).abs() <= 1e-3 * plain.cost,
        "{} vs {}",
        plain.cost,
        banded.cost
    );
    assert!(banded.full_eval_equivalents < 0.1 * plain.full_eval_equivalents);
}
