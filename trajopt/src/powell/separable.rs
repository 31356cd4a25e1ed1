//! Partially separable objectives: $f(x) = \sum_k f_k(x)$ where each term
//! depends on a few coordinates, so that a trial point that differs from
//! the best point so far in a few coordinates costs only the terms that
//! depend on them.

use std::cell::RefCell;

use faer::sparse::SymbolicSparseRowMat;

use super::Objective;
use crate::error::{Result, TrajoptError, expect_len};
use crate::least_squares::{BandForm, Part};

/// An [`Objective`] that is a sum of terms $f(x) = \sum_{k < K} f_k(x)$,
/// each depending on a few coordinates (opt-in: implement it to let
/// [`Powell::solve_separable`](super::Powell::solve_separable) evaluate
/// only the terms a trial point changes).
///
/// [`Objective::cost`] must equal the sum of the terms (up to rounding).
pub trait SeparableObjective: Objective {
    /// The number of terms $K$.
    fn n_terms(&self) -> usize;

    /// The terms that depend on coordinate `j`, each listed once.
    fn terms_of(&self, j: usize) -> &[usize];

    /// Writes $f_k(x)$ into `values[k]` for every `k` in `which` (the
    /// other entries of `values`, of length $K$, are left as they are).
    ///
    /// # Errors
    /// As [`Objective::cost`].
    fn terms(&self, x: &[f64], which: &[usize], values: &mut [f64]) -> Result<()>;
}

/// A [`BandForm`] least-squares problem, $f(\theta) = \lVert r(\theta) \rVert^2$,
/// as a [`SeparableObjective`]: term $k$ is the sum of squares of the
/// residual rows of [`Part`] $k$ of `n_parts` (for
/// [`Eq3Problem`](crate::Eq3Problem), a run of consecutive time steps;
/// with `n_parts` = horizon + 1, one step each), evaluated with
/// [`BandForm::residuals_part`]. Which parameters each term depends on
/// comes from [`LeastSquaresProblem::jacobian_pattern`](crate::LeastSquaresProblem::jacobian_pattern).
///
/// ```
/// use trajopt::powell::{BandTerms, Powell, PowellSettings, SeparableObjective};
/// use trajopt::problems::trajectory;
///
/// let (problem, theta0) = trajectory::by_name("pendulum-h50-lambda1e2")?.problem()?;
/// let terms = BandTerms::new(&problem, problem.horizon() + 1, &theta0)?;
/// assert_eq!(terms.n_terms(), 51);
/// // a coordinate touches a few of the 51 terms
/// assert!(terms.terms_of(0).len() <= 3);
/// let settings = PowellSettings { max_evals: Some(2000), ..PowellSettings::default() };
/// let result = Powell::new(settings)?.solve_separable(&terms, &theta0)?;
/// assert!(result.cost < result.initial_cost);
/// // most evaluations were partial
/// assert!(result.full_eval_equivalents < 0.5 * result.evals as f64);
/// # Ok::<(), trajopt::TrajoptError>(())
/// ```
pub struct BandTerms<'a, P: ?Sized> {
    problem: &'a P,
    n_parts: usize,
    /// `terms_of[j]`: the parts whose rows have a non-zero in column `j`.
    terms_of: Vec<Vec<usize>>,
    /// Each part's residual rows.
    rows: Vec<std::ops::Range<usize>>,
    residuals: RefCell<Vec<f64>>,
}

impl<P: ?Sized> std::fmt::Debug for BandTerms<'_, P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BandTerms")
            .field("n_parts", &self.n_parts)
            .field("rows", &self.rows)
            .finish_non_exhaustive()
    }
}

impl<'a, P: BandForm + ?Sized> BandTerms<'a, P> {
    /// The problem's residuals in `n_parts` parts; `theta` is any valid
    /// parameter vector (the parts' rows are found by evaluating there).
    ///
    /// # Errors
    /// `n_parts` of 0 ([`TrajoptError::InvalidParameter`]), a `theta` of
    /// the wrong length, an error evaluating the residuals, or parts whose
    /// rows do not cover the residuals once.
    pub fn new(problem: &'a P, n_parts: usize, theta: &[f64]) -> Result<Self> {
        if n_parts == 0 {
            return Err(super::invalid("n_parts", "need at least one part"));
        }
        expect_len("theta", problem.n_params(), theta.len())?;
        let m = problem.n_residuals();
        let mut r = vec![0.0; m];
        let mut rows = Vec::with_capacity(n_parts);
        let mut owner = vec![usize::MAX; m];
        for index in 0..n_parts {
            let range = problem.residuals_part(Part { index, count: n_parts }, theta, &mut r)?;
            for row in range.clone() {
                if owner[row] != usize::MAX {
                    return Err(super::invalid("n_parts", format!("row {row} is in two parts")));
                }
                owner[row] = index;
            }
            rows.push(range);
        }
        if let Some(row) = owner.iter().position(|&o| o == usize::MAX) {
            return Err(super::invalid("n_parts", format!("row {row} is in no part")));
        }
        let pattern: SymbolicSparseRowMat<usize> = problem.jacobian_pattern();
        let mut terms_of = vec![Vec::new(); problem.n_params()];
        for (row, &part) in owner.iter().enumerate() {
            for &j in pattern.col_idx_of_row_raw(row) {
                if terms_of[j].last() != Some(&part) && !terms_of[j].contains(&part) {
                    terms_of[j].push(part);
                }
            }
        }
        Ok(Self {
            problem,
            n_parts,
            terms_of,
            rows,
            residuals: RefCell::new(r),
        })
    }
}

impl<P: BandForm + ?Sized> Objective for BandTerms<'_, P> {
    fn cost(&self, x: &[f64]) -> Result<f64> {
        let mut r = self.residuals.borrow_mut();
        self.problem.residuals(x, &mut r)?;
        Ok(r.iter().map(|v| v * v).sum())
    }
}

impl<P: BandForm + ?Sized> SeparableObjective for BandTerms<'_, P> {
    fn n_terms(&self) -> usize {
        self.n_parts
    }

    fn terms_of(&self, j: usize) -> &[usize] {
        &self.terms_of[j]
    }

    fn terms(&self, x: &[f64], which: &[usize], values: &mut [f64]) -> Result<()> {
        let mut r = self.residuals.borrow_mut();
        if which.len() * DENSE_FRACTION >= self.n_parts {
            // many parts: one call for all the residuals costs less than
            // one call per part (each call has a cost of its own)
            self.problem.residuals(x, &mut r)?;
            for &k in which {
                values[k] = r[self.rows[k].clone()].iter().map(|v| v * v).sum();
            }
            return Ok(());
        }
        for &k in which {
            let range = self.problem.residuals_part(
                Part {
                    index: k,
                    count: self.n_parts,
                },
                x,
                &mut r,
            )?;
            debug_assert_eq!(range, self.rows[k]);
            values[k] = r[range].iter().map(|v| v * v).sum();
        }
        Ok(())
    }
}

/// [`BandTerms`] evaluates all the residuals at once when at least one
/// part in this many is asked for.
const DENSE_FRACTION: usize = 8;

/// The term values at the best point evaluated so far, so that a trial
/// point costs only the terms of the coordinates where it differs.
#[derive(Debug)]
pub(super) struct TermCache {
    best_x: Vec<f64>,
    best_terms: Vec<f64>,
    best_f: f64,
    trial_terms: Vec<f64>,
    touched: Vec<usize>,
    marked: Vec<bool>,
    started: bool,
    /// Evaluations in full-evaluation equivalents (terms evaluated / $K$).
    pub(super) work: f64,
}

impl TermCache {
    pub(super) fn new(n_terms: usize) -> Self {
        Self {
            best_x: Vec::new(),
            best_terms: vec![0.0; n_terms],
            best_f: f64::INFINITY,
            trial_terms: vec![0.0; n_terms],
            touched: Vec::new(),
            marked: vec![false; n_terms],
            started: false,
            work: 0.0,
        }
    }

    /// $f(x)$ from the terms that differ from the best point's.
    pub(super) fn eval(&mut self, f: &(impl SeparableObjective + ?Sized), x: &[f64]) -> Result<f64> {
        let k_all = self.best_terms.len();
        if !self.started {
            let all: Vec<usize> = (0..k_all).collect();
            f.terms(x, &all, &mut self.best_terms)?;
            self.best_x = x.to_vec();
            self.best_f = self.best_terms.iter().sum();
            self.started = true;
            self.work += 1.0;
            return Ok(self.best_f);
        }
        if self.best_x.len() != x.len() {
            return Err(TrajoptError::DimensionMismatch {
                what: "point",
                expected: self.best_x.len(),
                actual: x.len(),
            });
        }
        for (j, (&xj, &bj)) in x.iter().zip(&self.best_x).enumerate() {
            if xj != bj {
                for &k in f.terms_of(j) {
                    if !self.marked[k] {
                        self.marked[k] = true;
                        self.touched.push(k);
                    }
                }
            }
        }
        let result = f.terms(x, &self.touched, &mut self.trial_terms);
        self.work += self.touched.len() as f64 / k_all.max(1) as f64;
        let total = result.map(|()| {
            (0..k_all)
                .map(|k| {
                    if self.marked[k] {
                        self.trial_terms[k]
                    } else {
                        self.best_terms[k]
                    }
                })
                .sum::<f64>()
        });
        if let Ok(total) = total
            && total < self.best_f
        {
            for &k in &self.touched {
                self.best_terms[k] = self.trial_terms[k];
            }
            self.best_x.copy_from_slice(x);
            self.best_f = total;
        }
        for &k in &self.touched {
            self.marked[k] = false;
        }
        self.touched.clear();
        total
    }
}
