//! The convergence test and the profiles built on it.
//!
//! **Convergence test** (Moré and Wild, "Benchmarking derivative-free
//! optimization algorithms", SIAM J. Optim. 20(1), 2009, eq. 2.2): a run
//! from $x_0$ has solved its problem once it found an $x$ with
//! $$f(x_0) - f(x) \ge (1 - \tau)\,(f(x_0) - f_L),$$
//! $f_L$ the smallest value known for the problem from that start
//! ([`f_low`]). The time of a solved run is its wall time; its evaluations,
//! the evaluation count at which its trace first met the test.
//!
//! **Performance profile** (Dolan and Moré, "Benchmarking optimization
//! software with performance profiles", Math. Program. 91, 2002): with
//! $t_{p,s}$ solver $s$'s cost on problem $p$ ($\infty$ when it did not
//! solve it), $r_{p,s} = t_{p,s} / \min_s t_{p,s}$ and
//! $\rho_s(\alpha) = |\{p : r_{p,s} \le \alpha\}| / |P|$. A problem no
//! solver solved stays in $|P|$ with every ratio infinite.
//!
//! **Data profile** (Moré and Wild): $d_s(\kappa) = |\{p : t_{p,s} / (n_p + 1)
//! \le \kappa\}| / |P|$, $t_{p,s}$ the evaluations to solve $p$ and $\kappa$
//! in simplex gradients.

use serde::{Deserialize, Serialize};

/// $f_L$ for runs from one start that reached `best` at best, on a problem
/// whose published optimal value is `f_star`: the smaller of the two,
/// except that a published value within $10^{-6}$ (relative) below `best`
/// counts as reached and `best` is used (the paper
/// prints six digits, some truncated, so its value may lie slightly below
/// the true minimum).
pub fn f_low(best: f64, f_star: Option<f64>) -> f64 {
    match f_star {
        Some(fs) if best > fs + 1e-6 * fs.abs() => fs,
        _ => best,
    }
}

/// The largest $f$ that passes the test: $f_L + \tau (f_0 - f_L)$.
pub fn threshold(f0: f64, f_low: f64, tau: f64) -> f64 {
    f_low + tau * (f0 - f_low)
}

/// Which convergence test a set's runs are judged by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ConvergenceTest {
    /// Moré and Wild's test ([`threshold`]) at $\tau = 10^{-3}$ and
    /// $10^{-7}$: the MGH set.
    MoreWild,
    /// Within a relative tolerance of the best value any solver found:
    /// $f \le f_L + \tau \lvert f_L \rvert$ at $\tau = 10^{-2}$ and
    /// $10^{-4}$ ([`relative_threshold`]): the trajectory set, whose
    /// figure of merit (a rolled-out task cost) is not the objective the
    /// solvers descend, so that a fraction of the descent from the start
    /// says little.
    RelativeToBest,
}

impl ConvergenceTest {
    /// The two tolerances reported, loose then strict.
    pub fn taus(self) -> [f64; 2] {
        match self {
            Self::MoreWild => [1e-3, 1e-7],
            Self::RelativeToBest => [1e-2, 1e-4],
        }
    }

    /// The largest $f$ that passes the test at `tau` for a run from `f0`
    /// on an instance with smallest known value `f_low`.
    pub fn threshold(self, f0: f64, f_low: f64, tau: f64) -> f64 {
        match self {
            Self::MoreWild => threshold(f0, f_low, tau),
            Self::RelativeToBest => relative_threshold(f_low, tau),
        }
    }
}

/// The largest $f$ within relative tolerance `tau` of `f_low`:
/// $f_L + \tau \lvert f_L \rvert$.
pub fn relative_threshold(f_low: f64, tau: f64) -> f64 {
    f_low + tau * f_low.abs()
}

/// One solver's profile: the finite values ($r_{p,s}$ or
/// $t_{p,s} / (n_p + 1)$), sorted, out of `problems` problems.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Profile {
    /// The solver's name.
    pub solver: String,
    /// The finite ratios (or budgets), ascending.
    pub values: Vec<f64>,
    /// $|P|$.
    pub problems: usize,
}

impl Profile {
    /// The profile at `x`: the share of problems with a value $\le x$.
    pub fn at(&self, x: f64) -> f64 {
        if self.problems == 0 {
            return 0.0;
        }
        self.values.partition_point(|&v| v <= x) as f64 / self.problems as f64
    }

    /// The profile's steps `(x, share)`, one per distinct value.
    pub fn steps(&self) -> Vec<(f64, f64)> {
        let mut out: Vec<(f64, f64)> = Vec::new();
        for (i, &v) in self.values.iter().enumerate() {
            let share = (i + 1) as f64 / self.problems as f64;
            match out.last_mut() {
                Some(last) if last.0 == v => last.1 = share,
                _ => out.push((v, share)),
            }
        }
        out
    }
}

/// Dolan-Moré profiles of `costs[p][s]` (`None`: not solved) for the
/// `solvers` (names, in the columns' order).
pub fn performance_profiles(costs: &[Vec<Option<f64>>], solvers: &[String]) -> Vec<Profile> {
    let mut values = vec![Vec::new(); solvers.len()];
    for row in costs {
        let best = row.iter().flatten().copied().fold(f64::INFINITY, f64::min);
        if !best.is_finite() {
            continue;
        }
        for (s, t) in row.iter().enumerate() {
            if let Some(t) = t {
                // a zero cost (nothing spent) ties with the best at ratio 1
                values[s].push(if *t <= best { 1.0 } else { t / best });
            }
        }
    }
    finish(values, solvers, costs.len())
}

/// Moré-Wild data profiles of `evals[p][s]` (`None`: not solved) for
/// problems with `n[p]` parameters.
pub fn data_profiles(evals: &[Vec<Option<u64>>], n: &[usize], solvers: &[String]) -> Vec<Profile> {
    let mut values = vec![Vec::new(); solvers.len()];
    for (row, &n) in evals.iter().zip(n) {
        for (s, e) in row.iter().enumerate() {
            if let Some(e) = e {
                values[s].push(*e as f64 / (n as f64 + 1.0));
            }
        }
    }
    finish(values, solvers, evals.len())
}

fn finish(values: Vec<Vec<f64>>, solvers: &[String], problems: usize) -> Vec<Profile> {
    values
        .into_iter()
        .zip(solvers)
        .map(|(mut v, name)| {
            v.sort_by(f64::total_cmp);
            Profile {
                solver: name.clone(),
                values: v,
                problems,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(k: usize) -> Vec<String> {
        (0..k).map(|i| format!("s{i}")).collect()
    }

    #[test]
    fn performance_ratios_ties_and_failures_by_hand() {
        // p0: s0 = 2, s1 = 4 -> ratios 1, 2
        // p1: s0 = 3, s1 = 3 (a tie) -> 1, 1
        // p2: s0 fails, s1 = 5 -> inf, 1
        // p3: both fail -> inf, inf (still counted)
        let costs = vec![
            vec![Some(2.0), Some(4.0)],
            vec![Some(3.0), Some(3.0)],
            vec![None, Some(5.0)],
            vec![None, None],
        ];
        let p = performance_profiles(&costs, &names(2));
        assert_eq!(p[0].values, vec![1.0, 1.0]);
        assert_eq!(p[1].values, vec![1.0, 1.0, 2.0]);
        assert_eq!(p[0].problems, 4);
        assert_eq!(p[0].at(1.0), 0.5);
        assert_eq!(p[0].at(1e300), 0.5);
        assert_eq!(p[1].at(1.0), 0.5);
        assert_eq!(p[1].at(1.999), 0.5);
        assert_eq!(p[1].at(2.0), 0.75);
        assert_eq!(p[1].at(0.5), 0.0);
        assert_eq!(p[1].steps(), vec![(1.0, 0.5), (2.0, 0.75)]);
    }

    #[test]
    fn data_profiles_count_simplex_gradients() {
        // n = 2 -> units of 3 evaluations; n = 4 -> units of 5
        let evals = vec![vec![Some(3), Some(30)], vec![Some(50), None]];
        let p = data_profiles(&evals, &[2, 4], &names(2));
        assert_eq!(p[0].values, vec![1.0, 10.0]);
        assert_eq!(p[1].values, vec![10.0]);
        assert_eq!(p[0].at(9.99), 0.5);
        assert_eq!(p[0].at(10.0), 1.0);
        assert_eq!(p[1].at(1e9), 0.5);
    }

    #[test]
    fn the_convergence_test_by_hand() {
        // f0 = 101, fL = 1: tau = 1e-3 accepts f <= 1.1
        assert!((threshold(101.0, 1.0, 1e-3) - 1.1).abs() < 1e-15);
        // relative to the best: f_L = 40, tau = 1e-2 -> 40.4, whatever f0
        assert_eq!(relative_threshold(40.0, 1e-2), 40.4);
        let rel = ConvergenceTest::RelativeToBest;
        assert_eq!(rel.threshold(1e6, 40.0, 1e-2), rel.threshold(41.0, 40.0, 1e-2));
        assert_eq!(rel.threshold(1e6, -2.0, 0.5), -1.0);
        assert_eq!(
            ConvergenceTest::MoreWild.threshold(101.0, 1.0, 1e-3),
            threshold(101.0, 1.0, 1e-3)
        );
        // the published value is used when no run came near it
        assert_eq!(f_low(48.98, Some(0.0)), 0.0);
        assert_eq!(f_low(1e-20, Some(0.0)), 0.0);
        // a run below it, or within its printed precision, gives fL itself
        assert_eq!(f_low(87.945855, Some(87.9458)), 87.945855);
        assert_eq!(f_low(2.5, Some(3.0)), 2.5);
        assert_eq!(f_low(5.2, Some(2.9366e-4)), 2.9366e-4);
        assert_eq!(f_low(3.0, None), 3.0);
    }
}
