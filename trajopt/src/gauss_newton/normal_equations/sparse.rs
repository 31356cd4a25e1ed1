//! The general form of the normal equations: $J$ sparse, $J^\top J$ (+ $S$)
//! in a fixed sparse pattern formed column by column ([`GramProduct`]), and
//! a sparse Cholesky factorisation whose symbolic part (AMD ordering,
//! elimination tree) is computed once and reused ([`Factor`]). The only
//! form that handles bounds (the damped model minimised subject to them,
//! a QP: [`crate::gauss_newton::qp`]).

use faer::Side;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::linalg::matmul::sparse_sparse_matmul_symbolic;
use faer::sparse::{SparseColMat, SparseRowMat, SymbolicSparseColMat, SymbolicSparseRowMat};
use faer::{Conj, MatMut, Par};

use super::{Damping, NormalEquations};
use crate::error::{Result, TrajoptError};
use crate::least_squares::{LeastSquaresProblem, LinearBounds, Point, check_jacobian_pattern};

/// For each value of the problem's $S$, its index and its position in the
/// values of $H$; and $S$'s values.
type SecondOrderValues = (Vec<(usize, usize)>, Vec<f64>);

/// The general form: $J$ sparse, $J^\top J$ (+ $S$) in a fixed sparse
/// pattern, a sparse Cholesky factorisation with a reused symbolic part.
pub(crate) struct SparseSystem {
    jac: SparseRowMat<usize, f64>,
    nnz_problem: usize,
    /// $J^\top J$, $J^\top J + S$, and the damped matrix (upper triangles).
    h: SparseColMat<usize, f64>,
    h_full: SparseColMat<usize, f64>,
    h_damped: SparseColMat<usize, f64>,
    diag_pos: Vec<usize>,
    /// Where each value of $S$ goes in $H$, and $S$'s values.
    second_order: Option<SecondOrderValues>,
    normal: GramProduct,
    factor: Factor,
}

impl SparseSystem {
    pub(crate) fn new<P: LeastSquaresProblem + ?Sized>(
        problem: &P,
        n_r: usize,
        n_p: usize,
        second_order: bool,
    ) -> Result<Self> {
        // J is augmented with structurally present, zero-valued unit rows so that
        // the diagonal of J^T J is always in its pattern (a parameter that no
        // residual touches is then simply left alone by the damped step)
        let pattern = augment_with_diagonal(&problem.jacobian_pattern(), n_r, n_p)?;
        let nnz = pattern.col_idx().len();
        let jac = SparseRowMat::new(pattern, vec![0.0; nnz]);
        let jac_cols = jac.to_col_major().map_err(alloc_error)?;
        let (jtj_symbolic, _) = sparse_sparse_matmul_symbolic(jac.as_ref().transpose().symbolic(), jac_cols.symbolic())
            .map_err(alloc_error)?;
        // the second-order term, merged into the pattern of J^T J
        let pattern = second_order
            .then(|| problem.second_order().map(|so| so.pattern()))
            .flatten();
        let (h_symbolic, second_order) = match pattern {
            Some(pattern) => {
                if pattern.nrows() != n_p || pattern.ncols() != n_p {
                    return Err(TrajoptError::DimensionMismatch {
                        what: "second-order pattern size",
                        expected: n_p,
                        actual: if pattern.nrows() != n_p {
                            pattern.nrows()
                        } else {
                            pattern.ncols()
                        },
                    });
                }
                let union = upper_union(&jtj_symbolic, Some(&pattern));
                let positions = positions_in(&union, &pattern);
                let values = vec![0.0; pattern.row_idx().len()];
                (union, Some((positions, values)))
            }
            None => (upper_union(&jtj_symbolic, None), None),
        };
        let diag_pos = diagonal_positions(&h_symbolic)?;
        let h_nnz = h_symbolic.row_idx().len();
        let h = SparseColMat::new(h_symbolic, vec![0.0; h_nnz]);
        let factor = Factor::new(h.symbolic())?;
        let normal = GramProduct::new(&jac, jac_cols, &h.symbolic().to_owned().map_err(alloc_error)?)?;
        Ok(Self {
            jac,
            nnz_problem: nnz - n_p,
            h_full: h.clone(),
            h_damped: h.clone(),
            h,
            diag_pos,
            second_order,
            normal,
            factor,
        })
    }

    /// `h_damped` = the model matrix + `total` D.
    fn damp(&mut self, newton: bool, total: f64, scale: &[f64]) {
        let model = if newton { &self.h_full } else { &self.h };
        self.h_damped.val_mut().copy_from_slice(model.val());
        let vals = self.h_damped.val_mut();
        for (&p, &d) in self.diag_pos.iter().zip(scale) {
            vals[p] += total * d;
        }
    }

    /// The damped model minimised in the box $lo \le \delta \le hi$ by
    /// projected Newton steps ([`crate::gauss_newton::box_qp`]), each a
    /// factorisation in the unbounded step's pattern: `step` gets the
    /// step; false if a reduced matrix is not positive definite.
    pub(crate) fn box_step(
        &mut self,
        damping: Damping<'_>,
        grad: &[f64],
        lo: &[f64],
        hi: &[f64],
        step: &mut [f64],
    ) -> bool {
        self.damp(damping.newton, damping.total, damping.scale);
        let n = grad.len();
        let factor = &mut self.factor;
        crate::gauss_newton::box_qp::box_step(
            &self.h_damped,
            grad,
            lo,
            hi,
            &mut |m, rhs| factor.solve(m.as_ref(), MatMut::from_column_major_slice_mut(rhs, n, 1)),
            step,
        )
    }

    /// The damped model minimised subject to the bounds (a QP): `step`
    /// gets the step; false if the QP has no solution.
    pub(crate) fn bounded_step(
        &mut self,
        damping: Damping<'_>,
        grad: &[f64],
        bounds: &LinearBounds,
        theta: &[f64],
        step: &mut [f64],
    ) -> bool {
        self.damp(damping.newton, damping.total, damping.scale);
        match crate::gauss_newton::qp::bounded_step(&self.h_damped, grad, bounds, theta) {
            Some(d) => {
                step.copy_from_slice(&d);
                true
            }
            None => false,
        }
    }
}

impl<P: LeastSquaresProblem + ?Sized> NormalEquations<P> for SparseSystem {
    fn assemble(&mut self, problem: &P, at: Point<'_>, grad: &mut [f64], want_s: bool) -> Result<Option<bool>> {
        let Point { theta, r } = at;
        problem.jacobian_values(theta, &mut self.jac.val_mut()[..self.nnz_problem])?;
        if self.jac.val().iter().any(|v| !v.is_finite()) {
            return Ok(None);
        }
        self.normal.form(&self.jac, &mut self.h);
        let mut newton = false;
        if let Some((positions, values)) = self.second_order.as_mut().filter(|_| want_s)
            && problem
                .second_order()
                .map_or(Ok(false), |so| so.values(theta, r, values))?
        {
            let h_vals = self.h_full.val_mut();
            h_vals.copy_from_slice(self.h.val());
            for &(p, q) in positions.iter() {
                h_vals[q] += values[p];
            }
            newton = h_vals.iter().all(|v| v.is_finite());
        }
        // g = J^T r (the augmented rows have zero residual and contribute nothing)
        grad.fill(0.0);
        for (i, &ri) in r.iter().enumerate() {
            let cols = self.jac.symbolic().col_idx_of_row_raw(i);
            for (&c, &v) in cols.iter().zip(self.jac.val_of_row(i)) {
                grad[c] += v * ri;
            }
        }
        Ok(Some(newton))
    }

    fn jacobian_mul(&self, v: &[f64], out: &mut [f64]) -> bool {
        // the augmented rows past the residuals' are zero-valued and left out
        for (i, o) in out.iter_mut().enumerate() {
            let cols = self.jac.symbolic().col_idx_of_row_raw(i);
            *o = cols.iter().zip(self.jac.val_of_row(i)).map(|(&c, &x)| x * v[c]).sum();
        }
        true
    }

    fn jacobian_transpose_mul(&self, w: &[f64], out: &mut [f64]) -> bool {
        out.fill(0.0);
        for (i, &wi) in w.iter().enumerate() {
            let cols = self.jac.symbolic().col_idx_of_row_raw(i);
            for (&c, &x) in cols.iter().zip(self.jac.val_of_row(i)) {
                out[c] += x * wi;
            }
        }
        true
    }

    fn jtj_diagonal(&self, out: &mut [f64]) {
        for (o, &p) in out.iter_mut().zip(&self.diag_pos) {
            *o = self.h.val()[p];
        }
    }

    fn damped_step(&mut self, damping: Damping<'_>, step: &mut [f64]) -> bool {
        self.damp(damping.newton, damping.total, damping.scale);
        let n = step.len();
        let rhs = MatMut::from_column_major_slice_mut(step, n, 1);
        self.factor.solve(self.h_damped.as_ref(), rhs)
    }

    fn as_sparse(&mut self) -> Option<&mut SparseSystem> {
        Some(self)
    }

    fn model_mul(&mut self, newton: bool, step: &[f64], out: &mut [f64]) {
        sym_mat_vec(if newton { &self.h_full } else { &self.h }, step, out);
    }
}

/// Sparse Cholesky factorisation $H = LL^\top$ of the upper triangle, its
/// symbolic part (AMD ordering, elimination tree) computed once, the
/// numerical values and the workspace reused across factorisations.
struct Factor {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
    buffer: MemBuffer,
}

impl Factor {
    fn new(h: faer::sparse::SymbolicSparseColMatRef<'_, usize>) -> Result<Self> {
        let symbolic = factorize_symbolic_cholesky(
            h,
            Side::Upper,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(alloc_error)?;
        let scratch = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        let buffer = MemBuffer::try_new(scratch).map_err(alloc_error)?;
        let values = vec![0.0; symbolic.len_val()];
        Ok(Self {
            symbolic,
            values,
            buffer,
        })
    }

    /// Factorises `h` (upper triangle) and solves $H x = $ `rhs` in place;
    /// false if `h` is not numerically positive definite.
    fn solve(&mut self, h: SparseColMatRef<'_, usize, f64>, rhs: MatMut<'_, f64>) -> bool {
        let stack = MemStack::new(&mut self.buffer);
        match self.symbolic.factorize_numeric_llt::<f64>(
            &mut self.values,
            h,
            Side::Upper,
            LltRegularization::default(),
            Par::Seq,
            stack,
            Default::default(),
        ) {
            Ok(llt) => {
                let stack = MemStack::new(&mut self.buffer);
                llt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, stack);
                true
            }
            Err(_) => false,
        }
    }
}

fn alloc_error(e: impl std::fmt::Debug) -> TrajoptError {
    TrajoptError::InvalidParameter {
        name: "problem size",
        reason: format!("sparse structure could not be built: {e:?}"),
    }
}

/// The pattern of $[J; I]$: the problem's rows, then one row per parameter.
fn augment_with_diagonal(
    pattern: &SymbolicSparseRowMat<usize>,
    n_residuals: usize,
    n_params: usize,
) -> Result<SymbolicSparseRowMat<usize>> {
    check_jacobian_pattern(pattern, n_residuals, n_params)?;
    let mut row_ptr = pattern.row_ptr().to_vec();
    let mut col_idx = pattern.col_idx().to_vec();
    for j in 0..n_params {
        col_idx.push(j);
        row_ptr.push(col_idx.len());
    }
    Ok(SymbolicSparseRowMat::new_checked(
        n_residuals + n_params,
        n_params,
        row_ptr,
        None,
        col_idx,
    ))
}

/// `out` $= H d$ for a symmetric CSC matrix stored as its upper triangle.
fn sym_mat_vec(h: &SparseColMat<usize, f64>, d: &[f64], out: &mut [f64]) {
    out.fill(0.0);
    for j in 0..h.ncols() {
        let dj = d[j];
        let mut acc = 0.0;
        for (&i, &v) in h.symbolic().row_idx_of_col_raw(j).iter().zip(h.val_of_col(j)) {
            out[i] += v * dj;
            if i != j {
                acc += v * d[i];
            }
        }
        out[j] += acc;
    }
}

/// The upper triangle of the union of two square CSC patterns (sorted rows).
fn upper_union(
    a: &SymbolicSparseColMat<usize>,
    b: Option<&SymbolicSparseColMat<usize>>,
) -> SymbolicSparseColMat<usize> {
    let mut col_ptr = Vec::with_capacity(a.ncols() + 1);
    col_ptr.push(0);
    let mut row_idx = Vec::with_capacity(a.row_idx().len() / 2 + a.ncols());
    let mut column = Vec::new();
    for j in 0..a.ncols() {
        column.clear();
        column.extend(a.row_idx_of_col_raw(j).iter().filter(|&&i| i <= j));
        if let Some(b) = b {
            column.extend(b.row_idx_of_col_raw(j).iter().filter(|&&i| i <= j));
        }
        column.sort_unstable();
        column.dedup();
        row_idx.extend_from_slice(&column);
        col_ptr.push(row_idx.len());
    }
    SymbolicSparseColMat::new_checked(a.nrows(), a.ncols(), col_ptr, None, row_idx)
}

/// For each upper-triangle entry of the pattern `sub`, its index in `sub`'s
/// values and its position in the values of `upper` (an upper-triangular
/// pattern containing it).
fn positions_in(upper: &SymbolicSparseColMat<usize>, sub: &SymbolicSparseColMat<usize>) -> Vec<(usize, usize)> {
    let mut out = Vec::with_capacity(sub.row_idx().len() / 2 + sub.ncols());
    for j in 0..sub.ncols() {
        let rows = upper.row_idx_of_col_raw(j);
        let start = upper.col_ptr()[j];
        let sub_start = sub.col_ptr()[j];
        for (p, i) in sub.row_idx_of_col_raw(j).iter().enumerate() {
            if let Ok(q) = rows.binary_search(i) {
                out.push((sub_start + p, start + q));
            }
        }
    }
    out
}

/// Positions of the diagonal entries in the values of a CSC matrix.
fn diagonal_positions(h: &SymbolicSparseColMat<usize>) -> Result<Vec<usize>> {
    (0..h.ncols())
        .map(|j| {
            let rows = h.row_idx_of_col_raw(j);
            let start = h.col_ptr()[j];
            rows.iter()
                .position(|&i| i == j)
                .map(|p| start + p)
                .ok_or_else(|| TrajoptError::InvalidParameter {
                    name: "problem",
                    reason: format!("parameter {j} does not appear in any residual"),
                })
        })
        .collect()
}

/// Forms the upper triangle of $H = J^\top J$ into a fixed pattern, column by column (Gustavson):
/// $H_{:,j} = \sum_{i : J_{ij} \ne 0} J_{ij} J_{i,:}$, accumulated in a dense
/// vector that is cleared entry by entry through the pattern of $H_{:,j}$, so
/// the cost is $\sum_i \mathrm{nnz}(J_{i,:})^2$, linear in the horizon (a
/// general sparse product clears its whole accumulator per column, which is
/// quadratic in the number of parameters).
struct GramProduct {
    /// The pattern of $J$ by columns.
    cols: SymbolicSparseColMat<usize>,
    /// Position in $J$'s rows of each entry of `cols`.
    col_to_row: Vec<usize>,
    /// The order in which the columns are formed: by their first row, so
    /// that columns sharing rows are formed together (the rows stay in
    /// cache; in the parameter order, the channels of one time step are far
    /// apart).
    order: Vec<usize>,
    /// The pattern of $H$ (column pointers and row indices).
    h_col_ptr: Vec<usize>,
    h_row_idx: Vec<usize>,
    work: Vec<f64>,
}

impl GramProduct {
    fn new(
        rows: &SparseRowMat<usize, f64>,
        cols: SparseColMat<usize, f64>,
        h: &SymbolicSparseColMat<usize>,
    ) -> Result<Self> {
        // entries of a column are sorted by row, so walking the rows in order
        // meets each column's entries in storage order
        let mut next: Vec<usize> = cols.symbolic().col_ptr()[..cols.ncols()].to_vec();
        let row_to_col: Vec<usize> = rows
            .symbolic()
            .col_idx()
            .iter()
            .map(|&c| {
                let p = next[c];
                next[c] += 1;
                p
            })
            .collect();
        let mut col_to_row = vec![0; row_to_col.len()];
        for (q, &p) in row_to_col.iter().enumerate() {
            col_to_row[p] = q;
        }
        let work = vec![0.0; cols.ncols()];
        let cols = cols.symbolic().to_owned().map_err(alloc_error)?;
        let mut order: Vec<usize> = (0..cols.ncols()).collect();
        order.sort_by_key(|&j| cols.row_idx_of_col_raw(j).first().copied().unwrap_or(usize::MAX));
        Ok(Self {
            cols,
            col_to_row,
            order,
            h_col_ptr: h.col_ptr().to_vec(),
            h_row_idx: h.row_idx().to_vec(),
            work,
        })
    }

    fn form(&mut self, rows: &SparseRowMat<usize, f64>, h: &mut SparseColMat<usize, f64>) {
        let row_ptr = rows.symbolic().row_ptr();
        let row_cols = rows.symbolic().col_idx();
        let row_vals = rows.val();
        let (col_ptr, h_rows) = (&self.h_col_ptr, &self.h_row_idx);
        let (j_col_ptr, j_rows) = (self.cols.col_ptr(), self.cols.row_idx());
        let h_vals = h.val_mut();
        let work = &mut self.work;
        for &j in &self.order {
            let (start, end) = (j_col_ptr[j], j_col_ptr[j + 1]);
            for (&i, &q_end) in j_rows[start..end].iter().zip(&self.col_to_row[start..end]) {
                let v = row_vals[q_end];
                // the upper triangle: the row's entries up to column j
                let q = row_ptr[i];
                for (&c, &w) in row_cols[q..=q_end].iter().zip(&row_vals[q..=q_end]) {
                    work[c] += v * w;
                }
            }
            let (h_start, h_end) = (col_ptr[j], col_ptr[j + 1]);
            for (&r, hv) in h_rows[h_start..h_end].iter().zip(&mut h_vals[h_start..h_end]) {
                *hv = work[r];
                work[r] = 0.0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// A random-looking sparse symmetric pattern with its diagonal, both triangles.
    fn symmetric_pattern(n: usize, seed: usize) -> SymbolicSparseColMat<usize> {
        let mut cols = vec![vec![]; n];
        for (j, col) in cols.iter_mut().enumerate() {
            for i in 0..n {
                if i == j || (i * 7 + j * 7 + seed).is_multiple_of(5) {
                    col.push(i);
                }
            }
        }
        let mut col_ptr = vec![0];
        let mut rows = vec![];
        for c in cols {
            rows.extend(c);
            col_ptr.push(rows.len());
        }
        SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows)
    }

    #[test]
    fn upper_union_holds_both_patterns_upper_triangles_and_nothing_else() {
        let (a, b) = (symmetric_pattern(9, 0), symmetric_pattern(9, 3));
        let u = upper_union(&a, Some(&b));
        for j in 0..9 {
            for i in 0..9 {
                let expected = i <= j && (a.row_idx_of_col_raw(j).contains(&i) || b.row_idx_of_col_raw(j).contains(&i));
                assert_eq!(u.row_idx_of_col_raw(j).contains(&i), expected, "({i}, {j})");
            }
            assert!(u.row_idx_of_col_raw(j).windows(2).all(|w| w[0] < w[1]));
        }
        // positions of b's upper entries point at the same (row, column) in u
        for (p, q) in positions_in(&u, &b) {
            let j = (0..9).find(|&j| b.col_ptr()[j + 1] > p).expect("column");
            let i = b.row_idx()[p];
            assert!(i <= j);
            let k = q - u.col_ptr()[j];
            assert_eq!(u.row_idx_of_col_raw(j)[k], i);
        }
    }

    #[test]
    fn symmetric_product_from_the_upper_triangle_equals_the_dense_product() {
        let n = 9;
        let u = upper_union(&symmetric_pattern(n, 1), None);
        let vals: Vec<f64> = (0..u.row_idx().len()).map(|p| ((p * 13 % 7) as f64) - 2.5).collect();
        let h = SparseColMat::new(u, vals);
        let mut dense = Mat::<f64>::zeros(n, n);
        for j in 0..n {
            for (&i, &v) in h.symbolic().row_idx_of_col_raw(j).iter().zip(h.val_of_col(j)) {
                dense[(i, j)] = v;
                dense[(j, i)] = v;
            }
        }
        let d = Mat::from_fn(n, 1, |i, _| (i as f64 * 0.9).cos());
        let expected = &dense * &d;
        let mut got = vec![0.0; n];
        sym_mat_vec(
            &h,
            d.col(0).try_as_col_major().expect("contiguous").as_slice(),
            &mut got,
        );
        for i in 0..n {
            assert!(
                (got[i] - expected[(i, 0)]).abs() < 1e-12,
                "{} vs {}",
                got[i],
                expected[(i, 0)]
            );
        }
    }
}
