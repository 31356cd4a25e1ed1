//! Curtis-Powell-Reid column groups of a sparse Jacobian pattern, and the
//! problem wrapper whose Jacobian is differenced group by group.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use faer::sparse::SymbolicSparseRowMat;

use super::Difference;
use crate::error::{Result, TrajoptError};
use crate::least_squares::{LeastSquaresProblem, LinearBounds};

/// A partition of the columns of a sparse pattern into groups of
/// *structurally orthogonal* columns: no two columns of a group have a
/// nonzero in the same row (Curtis, Powell and Reid 1974).
///
/// Perturbing every column of a group at once changes each residual through
/// at most one of them, so one residual evaluation per group gives the whole
/// group's columns of the Jacobian by differences. The groups come from the
/// greedy sequential colouring of the column intersection graph (columns in
/// index order, each given the smallest group none of its row-neighbours
/// has), which is CPR's own rule; for a banded pattern of half-bandwidth
/// $k$ it needs at most $2k + 1$ groups, however many columns there are.
///
/// ```
/// use faer::sparse::SymbolicSparseRowMat;
/// use trajopt::derivative_free::ColumnGroups;
///
/// // a tridiagonal 5 x 5 pattern: columns j and j + 3 never share a row
/// let (mut row_ptr, mut cols) = (vec![0], Vec::new());
/// for i in 0..5usize {
///     cols.extend(i.saturating_sub(1)..(i + 2).min(5));
///     row_ptr.push(cols.len());
/// }
/// let pattern = SymbolicSparseRowMat::new_checked(5, 5, row_ptr, None, cols);
/// let groups = ColumnGroups::new(pattern.as_ref());
/// assert_eq!(groups.n_groups(), 3);
/// assert_eq!(groups.group_of(), &[0, 1, 2, 0, 1]);
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ColumnGroups {
    /// Group of each column.
    group_of: Vec<usize>,
    /// Columns of each group, in increasing order.
    members: Vec<Vec<usize>>,
}

impl ColumnGroups {
    /// The greedy CPR grouping of `pattern`'s columns.
    pub fn new(pattern: faer::sparse::SymbolicSparseRowMatRef<'_, usize>) -> Self {
        let (n_rows, n_cols) = (pattern.nrows(), pattern.ncols());
        // the rows of each column (the pattern transposed)
        let mut rows_of: Vec<Vec<usize>> = vec![Vec::new(); n_cols];
        for i in 0..n_rows {
            for &j in pattern.col_idx_of_row_raw(i) {
                rows_of[j].push(i);
            }
        }
        // the groups already present in each row
        let mut row_groups: Vec<Vec<usize>> = vec![Vec::new(); n_rows];
        let mut group_of = vec![0; n_cols];
        let mut taken: Vec<bool> = Vec::new();
        let mut members: Vec<Vec<usize>> = Vec::new();
        for (j, rows) in rows_of.iter().enumerate() {
            taken.clear();
            taken.resize(members.len() + 1, false);
            for &i in rows {
                for &g in &row_groups[i] {
                    taken[g] = true;
                }
            }
            let g = taken.iter().position(|&t| !t).unwrap_or(members.len());
            if g == members.len() {
                members.push(Vec::new());
            }
            members[g].push(j);
            group_of[j] = g;
            for &i in rows {
                row_groups[i].push(g);
            }
        }
        Self { group_of, members }
    }

    /// Number of groups: residual evaluations per forward-difference Jacobian.
    pub fn n_groups(&self) -> usize {
        self.members.len()
    }

    /// The group of each column.
    pub fn group_of(&self) -> &[usize] {
        &self.group_of
    }

    /// The columns of each group, in increasing order.
    pub fn members(&self) -> &[Vec<usize>] {
        &self.members
    }
}

/// Residual evaluations remembered for reuse as the base point of a
/// difference (the solver evaluates the point it accepts just before it
/// asks for the Jacobian there).
const REMEMBERED: usize = 3;

#[derive(Debug, Default)]
struct Memory {
    /// The last few evaluated points and their residuals, newest last.
    recent: Vec<(Vec<f64>, Vec<f64>)>,
    /// The evaluated point of lowest $\lVert r \rVert^2$ and its value.
    best: Option<(Vec<f64>, f64)>,
    /// $\lVert r \rVert^2$ at the first point evaluated (the start).
    first: Option<f64>,
}

/// `inner` seen through residual values only: its Jacobian is formed by
/// grouped differences ([`ColumnGroups`]) of its residuals, and the inner
/// problem's own Jacobian is never called. Every residual evaluation is
/// counted, the differences' included, and stops with
/// [`TrajoptError::BudgetExhausted`] once `max_evals` have been made.
///
/// Neither the inner problem's [band form](LeastSquaresProblem::band_form)
/// nor its [second-order term](LeastSquaresProblem::second_order) is
/// exposed (both need its derivatives); its [bounds](LeastSquaresProblem::bounds) are. A
/// difference step may leave the bounds by its (tiny) length.
#[derive(Debug)]
pub struct GroupedDifferences<'a, P: ?Sized> {
    inner: &'a P,
    pattern: SymbolicSparseRowMat<usize>,
    groups: ColumnGroups,
    /// For each column, `(row, position of (row, column) in the row pattern's values)`.
    entries_of: Vec<Vec<(usize, usize)>>,
    difference: Difference,
    relative_step: f64,
    max_evals: usize,
    evals: AtomicUsize,
    jacobians: AtomicUsize,
    memory: Mutex<Memory>,
}

impl<'a, P: LeastSquaresProblem + ?Sized> GroupedDifferences<'a, P> {
    /// Wraps `inner`, with difference steps $h_j = s \max(|\theta_j|, 1)$
    /// ($s$ = `relative_step`) and a budget of `max_evals` residual
    /// evaluations.
    ///
    /// # Errors
    /// `relative_step` not finite and positive.
    pub fn new(inner: &'a P, difference: Difference, relative_step: f64, max_evals: usize) -> Result<Self> {
        if !(relative_step.is_finite() && relative_step > 0.0) {
            return Err(TrajoptError::InvalidParameter {
                name: "relative_step",
                reason: format!("must be finite and > 0, got {relative_step}"),
            });
        }
        let pattern = inner.jacobian_pattern();
        let n_cols = pattern.ncols();
        let mut entries_of: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n_cols];
        for (i, &first) in pattern.row_ptr()[..pattern.nrows()].iter().enumerate() {
            for (k, &j) in pattern.col_idx_of_row_raw(i).iter().enumerate() {
                entries_of[j].push((i, first + k));
            }
        }
        let groups = ColumnGroups::new(pattern.as_ref());
        Ok(Self {
            inner,
            pattern,
            groups,
            entries_of,
            difference,
            relative_step,
            max_evals,
            evals: AtomicUsize::new(0),
            jacobians: AtomicUsize::new(0),
            memory: Mutex::new(Memory::default()),
        })
    }

    /// The column groups of the inner problem's pattern.
    pub fn groups(&self) -> &ColumnGroups {
        &self.groups
    }

    /// Residual evaluations so far, the differences' included.
    pub fn evals(&self) -> usize {
        self.evals.load(Ordering::Relaxed)
    }

    /// Jacobians formed by differences so far.
    pub fn jacobian_evals(&self) -> usize {
        self.jacobians.load(Ordering::Relaxed)
    }

    /// The evaluated point of lowest $\lVert r \rVert^2$ so far, and that value.
    pub fn best(&self) -> Option<(Vec<f64>, f64)> {
        self.lock().best.clone()
    }

    /// MINPACK's scale-free stationarity measure at `theta` (residuals `r`):
    /// the largest cosine between $r$ and a column $J_j$ of the differenced
    /// Jacobian, $\max_j |J_j^\top r| / (\lVert J_j \rVert \lVert r \rVert)$ (0 for
    /// a zero column or $r = 0$). Costs one differenced Jacobian.
    ///
    /// # Errors
    /// An error from the residuals, or the budget.
    pub fn stationarity(&self, theta: &[f64]) -> Result<f64> {
        let r = self.base(theta)?;
        let mut values = vec![0.0; self.pattern.compute_nnz()];
        self.jacobian_values(theta, &mut values)?;
        let r_norm = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        if r_norm == 0.0 {
            return Ok(0.0);
        }
        let mut worst = 0.0f64;
        for entries in &self.entries_of {
            let (dot, sq) = entries.iter().fold((0.0, 0.0), |(d, s), &(i, at)| {
                (d + values[at] * r[i], s + values[at] * values[at])
            });
            if sq > 0.0 {
                worst = worst.max(dot.abs() / (sq.sqrt() * r_norm));
            }
        }
        Ok(worst)
    }

    /// $\lVert r \rVert^2$ at the first point evaluated.
    pub fn first_cost(&self) -> Option<f64> {
        self.lock().first
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Memory> {
        // a panic elsewhere cannot leave the memory half-written in a way
        // that matters: it is a cache
        self.memory.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// One counted evaluation of the inner residuals, remembered.
    fn evaluate(&self, theta: &[f64], r: &mut [f64]) -> Result<()> {
        let done = self.evals.load(Ordering::Relaxed);
        if done >= self.max_evals {
            return Err(TrajoptError::BudgetExhausted { evaluations: done });
        }
        self.evals.fetch_add(1, Ordering::Relaxed);
        self.inner.residuals(theta, r)?;
        let cost: f64 = r.iter().map(|v| v * v).sum();
        let mut memory = self.lock();
        memory.first.get_or_insert(cost);
        if cost.is_finite() && memory.best.as_ref().is_none_or(|(_, f)| cost < *f) {
            memory.best = Some((theta.to_vec(), cost));
        }
        // reuse the oldest entry's buffers once the memory is full
        if memory.recent.len() == REMEMBERED {
            let (mut t, mut v) = memory.recent.remove(0);
            t.copy_from_slice(theta);
            v.copy_from_slice(r);
            memory.recent.push((t, v));
        } else {
            memory.recent.push((theta.to_vec(), r.to_vec()));
        }
        Ok(())
    }

    /// The residuals at `theta`, from memory if it was evaluated lately.
    fn base(&self, theta: &[f64]) -> Result<Vec<f64>> {
        let found = self
            .lock()
            .recent
            .iter()
            .rev()
            .find(|(t, _)| t.as_slice() == theta)
            .map(|(_, r)| r.clone());
        match found {
            Some(r) => Ok(r),
            None => {
                let mut r = vec![0.0; self.inner.n_residuals()];
                self.evaluate(theta, &mut r)?;
                Ok(r)
            }
        }
    }
}

impl<P: LeastSquaresProblem + ?Sized> LeastSquaresProblem for GroupedDifferences<'_, P> {
    fn n_params(&self) -> usize {
        self.inner.n_params()
    }

    fn n_residuals(&self) -> usize {
        self.inner.n_residuals()
    }

    fn residuals(&self, theta: &[f64], r: &mut [f64]) -> Result<()> {
        self.evaluate(theta, r)
    }

    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
        self.pattern.clone()
    }

    /// The Jacobian by grouped differences: per group $G$, with
    /// $h_j = s \max(|\theta_j|, 1)$ and $h_G = \sum_{j \in G} h_j e_j$,
    /// forward $J_{ij} = (r_i(\theta + h_G) - r_i(\theta)) / h_j$ or central
    /// $J_{ij} = (r_i(\theta + h_G) - r_i(\theta - h_G)) / (2 h_j)$ for the
    /// one column $j \in G$ that row $i$ depends on.
    fn jacobian_values(&self, theta: &[f64], values: &mut [f64]) -> Result<()> {
        let n_r = self.inner.n_residuals();
        let base = match self.difference {
            Difference::Forward => Some(self.base(theta)?),
            Difference::Central => None,
        };
        let steps: Vec<f64> = theta
            .iter()
            .map(|t| {
                let h = self.relative_step * t.abs().max(1.0);
                // the step actually represented in floating point
                (t + h) - t
            })
            .collect();
        let mut point = theta.to_vec();
        let mut plus = vec![0.0; n_r];
        let mut minus = vec![0.0; n_r];
        for group in self.groups.members() {
            for &j in group {
                point[j] = theta[j] + steps[j];
            }
            self.evaluate(&point, &mut plus)?;
            let lower: &[f64] = match &base {
                Some(r) => r,
                None => {
                    for &j in group {
                        point[j] = theta[j] - steps[j];
                    }
                    self.evaluate(&point, &mut minus)?;
                    &minus
                }
            };
            let width = if base.is_some() { 1.0 } else { 2.0 };
            for &j in group {
                point[j] = theta[j];
                let h = width * steps[j];
                for &(i, at) in &self.entries_of[j] {
                    values[at] = (plus[i] - lower[i]) / h;
                }
            }
        }
        self.jacobians.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }

    fn bounds(&self) -> Option<&LinearBounds> {
        self.inner.bounds()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn pattern_of(n_rows: usize, n_cols: usize, rows: &[Vec<usize>]) -> SymbolicSparseRowMat<usize> {
        let mut row_ptr = vec![0];
        let mut cols = Vec::new();
        for r in rows {
            let mut r = r.clone();
            r.sort_unstable();
            r.dedup();
            cols.extend(r);
            row_ptr.push(cols.len());
        }
        SymbolicSparseRowMat::new_checked(n_rows, n_cols, row_ptr, None, cols)
    }

    proptest! {
        /// The groups partition the columns, no row meets a group twice, and
        /// there are never more groups than the largest row's degree in the
        /// column intersection graph plus one.
        #[test]
        fn groups_are_structurally_orthogonal(
            n_cols in 1usize..30,
            rows in proptest::collection::vec(proptest::collection::vec(0usize..30, 0..6), 1..40),
        ) {
            let rows: Vec<Vec<usize>> = rows.into_iter().map(|r| r.into_iter().map(|j| j % n_cols).collect()).collect();
            let pattern = pattern_of(rows.len(), n_cols, &rows);
            let groups = ColumnGroups::new(pattern.as_ref());
            let mut seen = vec![false; n_cols];
            for (g, members) in groups.members().iter().enumerate() {
                for &j in members {
                    prop_assert!(!seen[j]);
                    seen[j] = true;
                    prop_assert_eq!(groups.group_of()[j], g);
                }
            }
            prop_assert!(seen.iter().all(|&s| s));
            for i in 0..pattern.nrows() {
                let mut in_row: Vec<usize> = pattern.col_idx_of_row_raw(i).iter().map(|&j| groups.group_of()[j]).collect();
                let len = in_row.len();
                in_row.sort_unstable();
                in_row.dedup();
                prop_assert_eq!(in_row.len(), len, "row {} meets a group twice", i);
            }
            // greedy colouring: each column's group is below its number of neighbours + 1
            let mut neighbours = vec![std::collections::BTreeSet::new(); n_cols];
            for i in 0..pattern.nrows() {
                let cols = pattern.col_idx_of_row_raw(i);
                for &a in cols { for &b in cols { if a != b { neighbours[a].insert(b); } } }
            }
            for (g, near) in groups.group_of().iter().zip(&neighbours) {
                prop_assert!(*g <= near.len());
            }
        }
    }

    /// A banded pattern of half-bandwidth k needs exactly 2k + 1 groups.
    #[test]
    fn band_needs_bandwidth_groups() {
        for k in 0..4usize {
            let n: usize = 40;
            let rows: Vec<Vec<usize>> = (0..n)
                .map(|i| (i.saturating_sub(k)..(i + k + 1).min(n)).collect())
                .collect();
            let groups = ColumnGroups::new(pattern_of(n, n, &rows).as_ref());
            assert_eq!(groups.n_groups(), 2 * k + 1, "k = {k}");
        }
    }
}
