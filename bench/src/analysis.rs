//! Runs grouped by instance, judged by the convergence test
//! ([`crate::profiles`]) at each $\tau$: who solved what, with which time
//! and evaluations, and the profiles.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::profiles::{ConvergenceTest, Profile, data_profiles, f_low, performance_profiles};
use crate::record::RunRecord;

/// The two tolerances reported for the MGH set
/// ([`ConvergenceTest::MoreWild`]).
pub const TAUS: [f64; 2] = [1e-3, 1e-7];

/// How one run did at one $\tau$.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Outcome {
    /// Whether it solved its instance.
    pub solved: bool,
    /// Evaluation equivalents to the first point that passed the test.
    pub evals: Option<u64>,
    /// Wall time of the run, when solved.
    pub time_s: Option<f64>,
}

/// Every run, by instance and solver, with $f_L$ per instance.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// The solvers, ours first (in the order given), then the outside ones by name.
    pub solvers: Vec<String>,
    /// Which solvers use only $f$ (derivative-free): ours that say so, and
    /// outside solvers whose records have no Jacobian evaluations.
    pub derivative_free: Vec<bool>,
    /// The instances `(set, problem, scale)`, sorted.
    pub instances: Vec<(String, String, String)>,
    /// Parameters per instance.
    pub n: Vec<usize>,
    /// $f_L$ per instance.
    pub f_low: Vec<f64>,
    /// `runs[p][s]`: solver `s`'s run on instance `p`, if any.
    pub runs: Vec<Vec<Option<RunRecord>>>,
    /// The convergence test the runs are judged by.
    pub test: ConvergenceTest,
}

impl Analysis {
    /// Groups `runs`, judged by Moré and Wild's test; `ours` lists our solvers' names in order (any solver
    /// not in it is an outside one, listed after them).
    pub fn new(runs: Vec<RunRecord>, ours: &[String]) -> Self {
        let mut solvers: Vec<String> = ours.to_vec();
        let mut outside: Vec<String> = runs
            .iter()
            .map(|r| r.solver.clone())
            .filter(|s| !ours.contains(s))
            .collect();
        outside.sort();
        outside.dedup();
        solvers.extend(outside);
        let mut by_instance: BTreeMap<(String, String, String), Vec<Option<RunRecord>>> = BTreeMap::new();
        let mut seen_jac = vec![false; solvers.len()];
        for run in runs {
            let Some(s) = solvers.iter().position(|x| *x == run.solver) else {
                continue;
            };
            seen_jac[s] |= run.jac_evals > 0;
            let row = by_instance
                .entry(run.instance())
                .or_insert_with(|| vec![None; solvers.len()]);
            row[s] = Some(run);
        }
        let mut instances = Vec::new();
        let (mut n, mut lows, mut rows) = (Vec::new(), Vec::new(), Vec::new());
        for (key, row) in by_instance {
            let present = row.iter().flatten();
            let best = present.clone().map(|r| r.f).fold(f64::INFINITY, f64::min);
            let f_star = present.clone().find_map(|r| r.f_star);
            n.push(present.clone().map(|r| r.n).next().unwrap_or(1));
            lows.push(f_low(best, f_star));
            instances.push(key);
            rows.push(row);
        }
        let derivative_free = seen_jac.iter().map(|j| !j).collect();
        Self {
            solvers,
            derivative_free,
            instances,
            n,
            f_low: lows,
            runs: rows,
            test: ConvergenceTest::MoreWild,
        }
    }

    /// The same runs judged by `test`.
    pub fn with_test(mut self, test: ConvergenceTest) -> Self {
        self.test = test;
        self
    }

    /// The two tolerances reported, loose then strict.
    pub fn taus(&self) -> [f64; 2] {
        self.test.taus()
    }

    /// The strict tolerance: the tables' and the summary's.
    pub fn strict_tau(&self) -> f64 {
        self.taus()[1]
    }

    /// The solver's column, if it ran.
    pub fn column(&self, solver: &str) -> Option<usize> {
        self.solvers.iter().position(|s| s == solver)
    }

    /// How run `[p][s]` did at `tau` (`None`: no such run).
    pub fn outcome(&self, p: usize, s: usize, tau: f64) -> Option<Outcome> {
        let run = self.runs[p][s].as_ref()?;
        let limit = self.test.threshold(run.f0, self.f_low[p], tau);
        let solved = run.f <= limit;
        Some(Outcome {
            solved,
            evals: if solved { run.evals_to(limit) } else { None },
            time_s: solved.then_some(run.time_s),
        })
    }

    /// Performance profiles at `tau` by time and by evaluations, over the
    /// `solvers` (columns) and the instances every one of them ran on.
    pub fn performance(&self, tau: f64, solvers: &[usize]) -> (Vec<Profile>, Vec<Profile>) {
        let rows = self.common_rows(solvers);
        let names: Vec<String> = solvers.iter().map(|&s| self.solvers[s].clone()).collect();
        let cost = |by_time: bool| -> Vec<Vec<Option<f64>>> {
            rows.iter()
                .map(|&p| {
                    solvers
                        .iter()
                        .map(|&s| {
                            let o = self.outcome(p, s, tau)?;
                            if by_time { o.time_s } else { o.evals.map(|e| e as f64) }
                        })
                        .collect()
                })
                .collect()
        };
        (
            performance_profiles(&cost(true), &names),
            performance_profiles(&cost(false), &names),
        )
    }

    /// Data profiles at `tau` over the `solvers` (columns).
    pub fn data(&self, tau: f64, solvers: &[usize]) -> Vec<Profile> {
        let rows = self.common_rows(solvers);
        let names: Vec<String> = solvers.iter().map(|&s| self.solvers[s].clone()).collect();
        let evals: Vec<Vec<Option<u64>>> = rows
            .iter()
            .map(|&p| {
                solvers
                    .iter()
                    .map(|&s| self.outcome(p, s, tau).and_then(|o| o.evals))
                    .collect()
            })
            .collect();
        let n: Vec<usize> = rows.iter().map(|&p| self.n[p]).collect();
        data_profiles(&evals, &n, &names)
    }

    /// The instances on which every one of `solvers` ran.
    pub fn common_rows(&self, solvers: &[usize]) -> Vec<usize> {
        (0..self.instances.len())
            .filter(|&p| solvers.iter().all(|&s| self.runs[p][s].is_some()))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::tests::run;

    #[test]
    fn relative_to_best_classifies_by_the_best_value_found() {
        // best 40: at tau 1e-2 the limit is 40.4, at 1e-4 40.004, whatever f0
        let runs = [("a", 40.0), ("b", 40.3), ("c", 40.5), ("d", 40.003)]
            .map(|(s, f)| {
                let mut r = run(s, "p", f, 10);
                r.f0 = 500.0;
                r.f_star = None;
                r.trace = vec![(1, 500.0), (10, f)];
                r
            })
            .to_vec();
        let an = Analysis::new(runs, &["a".into(), "b".into(), "c".into(), "d".into()])
            .with_test(ConvergenceTest::RelativeToBest);
        assert_eq!(an.taus(), [1e-2, 1e-4]);
        assert_eq!(an.f_low, vec![40.0]);
        let solved = |tau: f64| {
            (0..4)
                .map(|s| an.outcome(0, s, tau).expect("ran").solved)
                .collect::<Vec<_>>()
        };
        assert_eq!(solved(1e-2), vec![true, true, false, true]);
        assert_eq!(solved(1e-4), vec![true, false, false, true]);
        // a solved run's evaluations are those of its trace's point that passed
        assert_eq!(an.outcome(0, 1, 1e-2).and_then(|o| o.evals), Some(10));
        // the same runs under Moré and Wild's test from f0 = 500: the limit at
        // 1e-3 is 40.46, so 40.3 passes and 40.5 does not
        let mw = an.clone().with_test(ConvergenceTest::MoreWild);
        assert!(mw.outcome(0, 1, 1e-3).expect("ran").solved);
        assert!(!mw.outcome(0, 2, 1e-3).expect("ran").solved);
    }

    #[test]
    fn outcomes_follow_the_convergence_test() {
        // f0 = 10, f* = 0: tau = 1e-3 needs f <= 0.01
        let mut a = run("ours", "p", 0.005, 40);
        a.trace = vec![(1, 10.0), (20, 0.009), (40, 0.005)];
        let b = run("theirs", "p", 0.5, 10);
        let c = run("ours", "q", 0.0, 30);
        let an = Analysis::new(vec![a, b, c], &["ours".into()]);
        assert_eq!(an.solvers, vec!["ours".to_string(), "theirs".to_string()]);
        assert_eq!(an.instances.len(), 2);
        assert_eq!(an.f_low, vec![0.0, 0.0]);
        let o = an.outcome(0, 0, 1e-3).expect("ran");
        assert!(o.solved && o.evals == Some(20) && o.time_s == Some(0.5));
        assert!(!an.outcome(0, 1, 1e-3).expect("ran").solved);
        assert_eq!(an.outcome(1, 1, 1e-3), None);
        assert_eq!(an.common_rows(&[0, 1]), vec![0]);
        let (time, evals) = an.performance(1e-3, &[0, 1]);
        assert_eq!((time[0].values.clone(), time[1].values.clone()), (vec![1.0], vec![]));
        assert_eq!(evals[0].problems, 1);
        assert_eq!(
            an.data(1e-3, &[0]).first().map(|p| p.values.clone()),
            Some(vec![20.0 / 3.0, 10.0])
        );
    }
}
