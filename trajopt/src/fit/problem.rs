//! [`LeastSquares`] as a [`LeastSquaresProblem`]: its Jacobian's pattern
//! (dense, declared or probed), the differences by Curtis-Powell-Reid
//! groups of columns, and the rows scaled by the robust loss.

use std::cell::{Cell, RefCell};

use faer::sparse::SymbolicSparseRowMat;

use super::{LeastSquares, Loss, Sparsity};
use crate::derivative_free::{ColumnGroups, Difference};
use crate::error::{Result, TrajoptError};
use crate::least_squares::{LeastSquaresProblem, LinearBounds};

/// The pattern of a dense $m \times n$ Jacobian, row-major: every entry
/// (for [`LeastSquaresProblem::jacobian_pattern`] of a small dense problem).
pub fn dense_pattern(m: usize, n: usize) -> SymbolicSparseRowMat<usize> {
    let row_ptr = (0..=m).map(|i| i * n).collect();
    let col_idx = (0..m).flat_map(|_| 0..n).collect();
    SymbolicSparseRowMat::new_checked(m, n, row_ptr, None, col_idx)
}

impl LeastSquares<'_> {
    /// The pattern at `x0`: declared (checked), probed, or dense; and the
    /// residual evaluations the probing spent.
    fn resolve_pattern(&self, x0: &[f64]) -> Result<(SymbolicSparseRowMat<usize>, usize)> {
        let (m, n) = (self.m, x0.len());
        match &self.sparsity {
            Sparsity::Dense => Ok((dense_pattern(m, n), 0)),
            Sparsity::Declared(p) if p.nrows() == m && p.ncols() == n => Ok((p.clone(), 0)),
            Sparsity::Declared(p) => Err(TrajoptError::InvalidParameter {
                name: "pattern",
                reason: format!("is {} x {}, the problem is {m} x {n}", p.nrows(), p.ncols()),
            }),
            Sparsity::Detect => {
                let mut seen = vec![false; m * n];
                let (mut base, mut moved) = (vec![0.0; m], vec![0.0; m]);
                // the start, and a point near it off any symmetry of the start
                let near: Vec<f64> = x0
                    .iter()
                    .enumerate()
                    .map(|(k, &v)| v + 1e-3 * v.abs().max(1.0) * (0.37 + 0.11 * (k % 5) as f64))
                    .collect();
                for point in [x0, near.as_slice()] {
                    (self.residuals)(point, &mut base);
                    let mut p = point.to_vec();
                    for k in 0..n {
                        let h = f64::EPSILON.sqrt() * point[k].abs().max(1.0);
                        p[k] = point[k] + h;
                        (self.residuals)(&p, &mut moved);
                        p[k] = point[k];
                        for i in 0..m {
                            // a change, or a value that is not finite at one of the two
                            if moved[i] != base[i] || !moved[i].is_finite() {
                                seen[i * n + k] = true;
                            }
                        }
                    }
                }
                let row_ptr = std::iter::once(0)
                    .chain((0..m).scan(0, |acc, i| {
                        *acc += seen[i * n..(i + 1) * n].iter().filter(|&&b| b).count();
                        Some(*acc)
                    }))
                    .collect();
                let seen = &seen;
                let col_idx = (0..m).flat_map(|i| (0..n).filter(move |&k| seen[i * n + k])).collect();
                Ok((
                    SymbolicSparseRowMat::new_checked(m, n, row_ptr, None, col_idx),
                    2 * (n + 1),
                ))
            }
        }
    }
}

/// [`LeastSquares`] as a [`LeastSquaresProblem`] of `n` parameters, its
/// residuals transformed by its loss.
pub(super) struct Closures<'s, 'a> {
    spec: &'s LeastSquares<'a>,
    n: usize,
    bounds: Option<LinearBounds>,
    /// Calls of the user's residual function: the probing's, the solver's,
    /// the differences' and the answer's (a call the cache answers is none).
    pub(super) residual_calls: Cell<usize>,
    /// Calls of the user's Jacobian.
    pub(super) jacobian_calls: Cell<usize>,
    /// The last raw residuals the solver asked for, and their point: the
    /// forward differences' base, the loss's weights and the answer's
    /// residuals are usually at that point, and cost no call.
    last_residuals: RefCell<Option<(Vec<f64>, Vec<f64>)>>,
    /// The last Jacobian (the pattern's values, raw) and its point: the
    /// answer's Jacobian is usually the last iteration's.
    last_jacobian: RefCell<Option<(Vec<f64>, Vec<f64>)>>,
    /// The Jacobian's pattern (dense unless declared or probed).
    pattern: SymbolicSparseRowMat<usize>,
    /// Its columns in structurally orthogonal groups.
    groups: ColumnGroups,
    /// Each column's entries: (row, index in the pattern's values).
    entries_of: Vec<Vec<(usize, usize)>>,
}

impl<'s, 'a> Closures<'s, 'a> {
    /// `spec`'s problem at the start `x0` (its size $n$), with the bounds
    /// `spec` checked; its pattern resolved (declared, probed or dense),
    /// the probing's evaluations counted from the start.
    pub(super) fn new(spec: &'s LeastSquares<'a>, x0: &[f64], bounds: Option<LinearBounds>) -> Result<Self> {
        let (pattern, probing) = spec.resolve_pattern(x0)?;
        let groups = ColumnGroups::new(pattern.as_ref());
        let mut entries_of = vec![Vec::new(); x0.len()];
        let mut e = 0;
        for i in 0..spec.m {
            for &k in pattern.col_idx_of_row_raw(i) {
                entries_of[k].push((i, e));
                e += 1;
            }
        }
        Ok(Self {
            spec,
            n: x0.len(),
            bounds,
            residual_calls: Cell::new(probing),
            jacobian_calls: Cell::new(0),
            last_residuals: RefCell::new(None),
            last_jacobian: RefCell::new(None),
            pattern,
            groups,
            entries_of,
        })
    }

    /// $J = \partial r / \partial x$ at `x` in the pattern's order
    /// (row-major over its entries): the user's (read at the pattern's
    /// entries), or differences of the residuals, a group of structurally
    /// orthogonal columns per evaluation (central: steps $h_k =
    /// \epsilon^{1/3} \max(1, |x_k|)$, two evaluations per group; forward:
    /// $h_k = \epsilon^{1/2} \max(1, |x_k|)$, one, and one at `x`),
    /// scipy's steps.
    fn sparse_jacobian(&self, x: &[f64]) -> Vec<f64> {
        if let Some((_, values)) = self
            .last_jacobian
            .borrow()
            .as_ref()
            .filter(|(at, _)| at.as_slice() == x)
        {
            return values.clone();
        }
        let values = self.sparse_jacobian_uncached(x);
        *self.last_jacobian.borrow_mut() = Some((x.to_vec(), values.clone()));
        values
    }

    /// The user's raw residuals at `x` into `r`: the last ones asked for
    /// if they were at `x`, else a call (counted and remembered).
    pub(super) fn raw_residuals(&self, x: &[f64], r: &mut [f64]) {
        if let Some((_, last)) = self
            .last_residuals
            .borrow()
            .as_ref()
            .filter(|(at, _)| at.as_slice() == x)
        {
            r.copy_from_slice(last);
            return;
        }
        self.call(x, r);
        // the buffers of the first call are reused: no allocation per evaluation
        let mut last = self.last_residuals.borrow_mut();
        if let Some((at, values)) = last.as_mut() {
            at.copy_from_slice(x);
            values.copy_from_slice(r);
        } else {
            *last = Some((x.to_vec(), r.to_vec()));
        }
    }

    /// One counted call of the user's residual function.
    fn call(&self, x: &[f64], r: &mut [f64]) {
        self.residual_calls.set(self.residual_calls.get() + 1);
        (self.spec.residuals)(x, r);
    }

    fn sparse_jacobian_uncached(&self, x: &[f64]) -> Vec<f64> {
        let (m, n) = (self.spec.m, self.n);
        let pattern = &self.pattern;
        let mut values = vec![0.0; pattern.compute_nnz()];
        if let Some(jac) = &self.spec.jacobian {
            let mut j = vec![0.0; m * n];
            self.jacobian_calls.set(self.jacobian_calls.get() + 1);
            jac(x, &mut j);
            let mut e = 0;
            for i in 0..m {
                for &k in pattern.col_idx_of_row_raw(i) {
                    values[e] = j[i * n + k];
                    e += 1;
                }
            }
            return values;
        }
        let central = self.spec.difference == Difference::Central;
        let (mut plus, mut minus) = (vec![0.0; m], vec![0.0; m]);
        if !central {
            self.raw_residuals(x, &mut minus);
        }
        let step = |k: usize| {
            let scale = x[k].abs().max(1.0);
            if central {
                f64::EPSILON.cbrt() * scale
            } else {
                f64::EPSILON.sqrt() * scale
            }
        };
        let mut p = x.to_vec();
        for members in self.groups.members() {
            for &k in members {
                p[k] = x[k] + step(k);
            }
            self.call(&p, &mut plus);
            if central {
                for &k in members {
                    p[k] = x[k] - step(k);
                }
                self.call(&p, &mut minus);
            }
            for &k in members {
                p[k] = x[k];
            }
            // each row meets at most one column of the group
            for &k in members {
                let width = if central { 2.0 * step(k) } else { step(k) };
                for &(i, e) in &self.entries_of[k] {
                    values[e] = (plus[i] - minus[i]) / width;
                }
            }
        }
        values
    }

    /// [`sparse_jacobian`](Self::sparse_jacobian), dense ($m \times n$,
    /// row-major).
    pub(super) fn outer_jacobian(&self, x: &[f64]) -> Vec<f64> {
        let (m, n) = (self.spec.m, self.n);
        let values = self.sparse_jacobian(x);
        let mut j = vec![0.0; m * n];
        let mut e = 0;
        for i in 0..m {
            for &k in self.pattern.col_idx_of_row_raw(i) {
                j[i * n + k] = values[e];
                e += 1;
            }
        }
        j
    }
}

impl LeastSquaresProblem for Closures<'_, '_> {
    fn n_params(&self) -> usize {
        self.n
    }

    fn n_residuals(&self) -> usize {
        self.spec.m
    }

    fn residuals(&self, x: &[f64], r: &mut [f64]) -> Result<()> {
        self.raw_residuals(x, r);
        for ri in r.iter_mut() {
            *ri = self.spec.loss.transform(*ri, self.spec.scale).0;
        }
        Ok(())
    }

    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
        self.pattern.clone()
    }

    /// The user's Jacobian or the residuals' differences, its rows scaled
    /// by the loss's $d\tilde r_i / dr_i$ (the differences are of the
    /// smooth raw residuals, never of the transformed ones).
    fn jacobian_values(&self, x: &[f64], values: &mut [f64]) -> Result<()> {
        let m = self.spec.m;
        values.copy_from_slice(&self.sparse_jacobian(x));
        if self.spec.loss == Loss::Linear {
            return Ok(());
        }
        let mut r = vec![0.0; m];
        self.raw_residuals(x, &mut r);
        for (i, &ri) in r.iter().enumerate() {
            let w = self.spec.loss.transform(ri, self.spec.scale).1;
            for v in &mut values[self.pattern.row_range(i)] {
                *v *= w;
            }
        }
        Ok(())
    }

    fn bounds(&self) -> Option<&LinearBounds> {
        self.bounds.as_ref()
    }
}
