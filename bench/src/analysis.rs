//! Runs grouped by instance, judged by the convergence test
//! ([`crate::profiles`]) at each $\tau$ and, on the MGH set, at the
//! minimum ([`crate::minima`]): who solved what, with which time and
//! evaluations, and the profiles.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::minima::{self, Reference};
use crate::nist;
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

/// How the headline counts judge a run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Criterion {
    /// At the best-known minimum ([`minima::at_minimum`]): the MGH set.
    AtMinimum,
    /// The set's convergence test at this $\tau$ (on the MGH set, also at
    /// the minimum).
    Tau(f64),
}

impl Criterion {
    /// How the criterion reads in the tables.
    pub fn label(self) -> String {
        match self {
            Self::AtMinimum => "at the minimum".into(),
            Self::Tau(tau) => format!("tau = {tau:e}"),
        }
    }
}

/// Every run, by instance and solver, with $f_L$ per instance.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// The solvers, ours first (in the order given), then the outside ones by name.
    pub solvers: Vec<String>,
    /// How many of [`solvers`](Self::solvers) are ours (the first ones):
    /// compiled Rust, the only ones whose times are compared (the outside
    /// solvers run from Python).
    pub ours: usize,
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
    /// Per instance, what it is judged against at the minimum (the MGH
    /// set; `None` elsewhere): $f^*$ and whether it is degenerate.
    pub references: Vec<Option<Reference>>,
    /// What the runner did not reproduce from the records
    /// ([`minima::recompute`]).
    pub discrepancies: Vec<minima::Discrepancy>,
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
            ours: ours.len(),
            solvers,
            derivative_free,
            instances,
            n,
            f_low: lows,
            references: vec![None; rows.len()],
            discrepancies: Vec::new(),
            runs: rows,
            test: ConvergenceTest::MoreWild,
        }
    }

    /// The same runs judged at the minimum where `reference` gives an
    /// instance's [`Reference`] (by `(set, problem, scale)` key): its
    /// $f^*$ becomes $f_L$.
    pub fn with_references(mut self, reference: impl Fn(&(String, String, String)) -> Option<Reference>) -> Self {
        self.references = self.instances.iter().map(reference).collect();
        for (low, r) in self.f_low.iter_mut().zip(&self.references) {
            if let Some(r) = r {
                *low = r.f_star;
            }
        }
        self
    }

    /// Whether any instance is judged at the minimum (the MGH set).
    pub fn has_references(&self) -> bool {
        self.references.iter().any(Option::is_some)
    }

    /// Why instance `p` is left out of the counts, if it is.
    pub fn degenerate(&self, p: usize) -> Option<&str> {
        self.references[p].as_ref()?.degenerate.as_deref()
    }

    /// The criterion of the headline counts (the summary, the goals, the
    /// per-problem table): at the minimum where the instances have
    /// references, else the strict $\tau$.
    pub fn headline(&self) -> Criterion {
        if self.has_references() {
            Criterion::AtMinimum
        } else {
            Criterion::Tau(self.strict_tau())
        }
    }

    /// How run `[p][s]` did by `criterion` (`None`: no such run).
    pub fn judge(&self, p: usize, s: usize, criterion: Criterion) -> Option<Outcome> {
        match criterion {
            Criterion::AtMinimum => self.at_minimum(p, s),
            Criterion::Tau(tau) => self.outcome(p, s, tau),
        }
    }

    /// Whether run `[p][s]` ended at the minimum, and the evaluations at
    /// which its trace first got there (`None`: no such run, or no
    /// reference for the instance).
    ///
    /// On the NIST set (a reference with certified parameters) a run is
    /// solved when its final point's log relative error is at least
    /// [`nist::HEADLINE_DIGITS`] ([`Analysis::lre`]), and its evaluations
    /// are all it spent: its trace holds $f$, not the parameters.
    pub fn at_minimum(&self, p: usize, s: usize) -> Option<Outcome> {
        let run = self.runs[p][s].as_ref()?;
        let reference = self.references[p].as_ref()?;
        if reference.certified.is_some() {
            let solved = self.lre(p, s)? >= nist::HEADLINE_DIGITS;
            return Some(Outcome {
                solved,
                evals: solved.then_some(run.evals),
                time_s: solved.then_some(run.time_s),
            });
        }
        let f_star = reference.f_star;
        let solved = minima::at_minimum(run.f, f_star);
        Some(Outcome {
            solved,
            // the recomputed final f may pass where the solver's own last
            // traced value, rounded otherwise, did not: then all it spent
            evals: solved.then(|| run.evals_to(minima::limit(f_star)).unwrap_or(run.evals)),
            time_s: solved.then_some(run.time_s),
        })
    }

    /// The log relative error of run `[p][s]`'s final point against the
    /// certified parameters ([`nist::lre`]; 0 for a run that stored no
    /// point); `None` without certified parameters or without the run.
    pub fn lre(&self, p: usize, s: usize) -> Option<f64> {
        let run = self.runs[p][s].as_ref()?;
        let certified = self.references[p].as_ref()?.certified.as_ref()?;
        Some(run.x.as_ref().map_or(0.0, |x| nist::lre(x, certified)))
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

    /// The columns of our solvers.
    pub fn our_columns(&self) -> Vec<usize> {
        (0..self.ours).collect()
    }

    /// The solver's column, if it ran.
    pub fn column(&self, solver: &str) -> Option<usize> {
        self.solvers.iter().position(|s| s == solver)
    }

    /// How run `[p][s]` did at `tau` (`None`: no such run). On an
    /// instance with a reference (the MGH set) a run passes only if it
    /// also ended at the minimum: Moré and Wild's test from an enormous
    /// $f(x_0)$ passes far above $f^*$; its evaluations are still those at
    /// which its trace first met the test at `tau`.
    pub fn outcome(&self, p: usize, s: usize, tau: f64) -> Option<Outcome> {
        let run = self.runs[p][s].as_ref()?;
        let limit = self.test.threshold(run.f0, self.f_low[p], tau);
        let at_minimum = self.at_minimum(p, s).is_none_or(|o| o.solved);
        let solved = run.f <= limit && at_minimum;
        Some(Outcome {
            solved,
            evals: if solved {
                run.evals_to(limit).or(Some(run.evals))
            } else {
                None
            },
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

    /// The instances on which every one of `solvers` ran, degenerate
    /// ones left out.
    pub fn common_rows(&self, solvers: &[usize]) -> Vec<usize> {
        (0..self.instances.len())
            .filter(|&p| self.degenerate(p).is_none() && solvers.iter().all(|&s| self.runs[p][s].is_some()))
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

    /// Issue 34: from a start where f(x0) is 1e30, Moré and Wild's test at
    /// tau = 1e-7 passes at f = 1e22; at the minimum it does not, and
    /// neither does the test at any tau once it is gated by the minimum.
    #[test]
    fn at_the_minimum_a_huge_f0_does_not_make_a_run_solved() {
        let mut far = run("ours", "p", 1e22, 50);
        far.f0 = 1e30;
        far.trace = vec![(1, 1e30), (50, 1e22)];
        let mut near = run("theirs", "p", 2.0 + 1e-9, 80);
        near.f0 = 1e30;
        near.trace = vec![(1, 1e30), (30, 3.0), (60, 2.0 + 2e-8), (80, 2.0 + 1e-9)];
        // an instance whose start is already at the minimum
        let q = run("ours", "q", 0.0, 3);
        let reference = |key: &(String, String, String)| {
            Some(Reference {
                f0: 1e30,
                f_star: 2.0,
                source: "test".into(),
                degenerate: (key.1 == "q").then(|| "the start is at the minimum".to_string()),
                certified: None,
            })
        };
        let plain = Analysis::new(vec![far.clone(), near.clone(), q.clone()], &["ours".into()]);
        // the old reading: f_L = the best run, 2 + 1e-9; 1e22 passes at tau = 1e-7
        assert!(plain.outcome(0, 0, 1e-7).expect("ran").solved);
        let an = plain.with_references(reference);
        assert_eq!(an.f_low, vec![2.0, 2.0]);
        assert_eq!(an.headline(), Criterion::AtMinimum);
        for tau in [1e-3, 1e-7] {
            assert!(!an.outcome(0, 0, tau).expect("ran").solved);
        }
        assert!(!an.at_minimum(0, 0).expect("ran").solved);
        // 2 + 1e-9 is within 1e-8 (1 + 2) of 2; its trace first got within at 60
        let o = an.at_minimum(0, 1).expect("ran");
        assert_eq!((o.solved, o.evals), (true, Some(60)));
        // Moré-Wild's evaluations stay those of its own test (3 <= 2 + 1e-3 (1e30 - 2))
        assert_eq!(an.outcome(0, 1, 1e-3).and_then(|o| o.evals), Some(30));
        // the degenerate instance is in no common row
        assert_eq!(an.degenerate(1), Some("the start is at the minimum"));
        assert_eq!(an.common_rows(&[0]), vec![0]);
        assert_eq!(an.judge(0, 1, Criterion::AtMinimum), an.at_minimum(0, 1));
    }
}
