//! The [`TrajectoryBasis`] trait: trajectories linear in their coefficients.

use faer::sparse::{SparseColMat, SparseRowMat, SymbolicSparseRowMat};

use crate::error::{Result, SplineError, check_finite, check_len};

/// A set of functions $\phi_j(t)$, $j = 0, \dots, n-1$, on a domain
/// $[t_{\min}, t_{\max}]$, such that a trajectory is $y(t) = \sum_j c_j \phi_j(t)$.
///
/// Each basis function has local support, so the design matrix
/// $\Phi_{kj} = \phi_j^{(r)}(t_k)$ (row = sample time, column = coefficient,
/// $r$ = derivative order) is sparse, and samples are $\Phi c$.
/// Planners get exact, sparse Jacobians from it.
///
/// Implementors provide [`n_coeffs`](Self::n_coeffs), [`domain`](Self::domain),
/// [`max_nonzeros`](Self::max_nonzeros) and [`basis_row`](Self::basis_row);
/// the design matrices and evaluation are provided on top of them.
///
/// Times outside the domain are refused with [`SplineError::OutsideDomain`]
/// (no basis clamps or extrapolates), NaN times with [`SplineError::NotFinite`].
pub trait TrajectoryBasis {
    /// Number of coefficients $n$.
    fn n_coeffs(&self) -> usize;

    /// The closed interval $[t_{\min}, t_{\max}]$ on which the basis is defined.
    fn domain(&self) -> (f64, f64);

    /// Upper bound on the number of basis functions nonzero at any one time
    /// (for a B-spline of degree $p$, $p + 1$).
    fn max_nonzeros(&self) -> usize;

    /// Writes the row of the design matrix at time `t` for derivative order
    /// `order`: `row` is cleared, then receives `(column, value)` pairs in
    /// increasing column order. Entries may be structurally present with value 0.
    fn basis_row(&self, t: f64, order: usize, row: &mut Vec<(usize, f64)>) -> Result<()>;

    /// The design matrix in compressed sparse row form: `times.len()` rows,
    /// [`n_coeffs`](Self::n_coeffs) columns, row $k$ holding
    /// $\phi_j^{(r)}(t_k)$. Rows are what an optimiser assembles residual
    /// Jacobians from.
    fn design_matrix_rows(&self, times: &[f64], order: usize) -> Result<SparseRowMat<usize, f64>> {
        check_finite("times", times)?;
        let nnz_hint = times.len() * self.max_nonzeros();
        let mut row_ptr = Vec::with_capacity(times.len() + 1);
        let mut col_idx = Vec::with_capacity(nnz_hint);
        let mut val = Vec::with_capacity(nnz_hint);
        let mut row = Vec::with_capacity(self.max_nonzeros());
        row_ptr.push(0);
        for &t in times {
            self.basis_row(t, order, &mut row)?;
            for &(j, v) in &row {
                col_idx.push(j);
                val.push(v);
            }
            row_ptr.push(col_idx.len());
        }
        let symbolic = SymbolicSparseRowMat::new_checked(times.len(), self.n_coeffs(), row_ptr, None, col_idx);
        Ok(SparseRowMat::new(symbolic, val))
    }

    /// The design matrix in compressed sparse column form (what faer's sparse
    /// factorisations take); same entries as
    /// [`design_matrix_rows`](Self::design_matrix_rows).
    fn design_matrix(&self, times: &[f64], order: usize) -> Result<SparseColMat<usize, f64>> {
        let rows = self.design_matrix_rows(times, order)?;
        rows.to_col_major().map_err(|e| SplineError::InvalidParameter {
            name: "times",
            reason: format!("design matrix too large to allocate: {e:?}"),
        })
    }

    /// Evaluates the `order`-th derivative of $y(t) = \sum_j c_j \phi_j(t)$
    /// at each time.
    fn evaluate(&self, coeffs: &[f64], times: &[f64], order: usize) -> Result<Vec<f64>> {
        check_coeffs(self.n_coeffs(), coeffs)?;
        check_finite("times", times)?;
        let mut row = Vec::with_capacity(self.max_nonzeros());
        times
            .iter()
            .map(|&t| {
                self.basis_row(t, order, &mut row)?;
                Ok(row.iter().map(|&(j, v)| coeffs[j] * v).sum())
            })
            .collect()
    }
}

/// Checks a coefficient vector's length and values.
pub(crate) fn check_coeffs(n_coeffs: usize, coeffs: &[f64]) -> Result<()> {
    check_len("coefficients", n_coeffs, coeffs.len())?;
    check_finite("coefficients", coeffs)
}

/// Checks that `t` is finite and inside `[lo, hi]`.
pub(crate) fn check_time(t: f64, (lo, hi): (f64, f64)) -> Result<()> {
    if !t.is_finite() {
        return Err(SplineError::NotFinite {
            what: "time",
            index: 0,
            value: t,
        });
    }
    if t < lo || t > hi {
        return Err(SplineError::OutsideDomain { t, lo, hi });
    }
    Ok(())
}

/// Implements [`TrajectoryBasis`] for pointers to a basis (`$ptr` naming
/// the pointee `B`), every method forwarding to the pointee, so that one
/// basis can serve several fits. A macro since the impls differ only in
/// the pointer type.
macro_rules! forward_trajectory_basis {
    ($($ptr:ty),*) => {$(
        impl<B: TrajectoryBasis + ?Sized> TrajectoryBasis for $ptr {
            fn n_coeffs(&self) -> usize {
                (**self).n_coeffs()
            }
            fn domain(&self) -> (f64, f64) {
                (**self).domain()
            }
            fn max_nonzeros(&self) -> usize {
                (**self).max_nonzeros()
            }
            fn basis_row(&self, t: f64, order: usize, row: &mut Vec<(usize, f64)>) -> Result<()> {
                (**self).basis_row(t, order, row)
            }
            fn design_matrix_rows(&self, times: &[f64], order: usize) -> Result<SparseRowMat<usize, f64>> {
                (**self).design_matrix_rows(times, order)
            }
            fn evaluate(&self, coeffs: &[f64], times: &[f64], order: usize) -> Result<Vec<f64>> {
                (**self).evaluate(coeffs, times, order)
            }
        }
    )*};
}

forward_trajectory_basis!(&B, std::sync::Arc<B>);
