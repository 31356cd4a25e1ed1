//! Sparse Gauss-Newton / Levenberg-Marquardt for [`LeastSquaresProblem`]s.
//!
//! Minimises $F(\theta) = \lVert r(\theta) \rVert^2$. Each iteration solves
//! the damped normal equations
//! $$(J^\top J + \mu D)\,\delta = -J^\top r, \qquad D = \operatorname{diag}(\max(J^\top J, d_{\min})),$$
//! by a sparse Cholesky factorisation $LL^\top$ (faer) whose symbolic part
//! (fill-reducing ordering, elimination tree) is computed once and reused;
//! $J^\top J$ is formed by a sparse product whose pattern is also computed
//! once. The step is accepted when the gain ratio
//! $\rho = (F(\theta) - F(\theta + \delta)) / (L(0) - L(\delta))$ is positive
//! ($L$ the local linear model), and $\mu$ follows Nielsen's rule:
//! $\mu \leftarrow \mu \max(1/3, 1 - (2\rho - 1)^3)$ on success,
//! $\mu \leftarrow \mu \nu$, $\nu \leftarrow 2 \nu$ on failure. With
//! `initial_damping = 0` the first step is the pure Gauss-Newton step (a
//! linear least-squares problem is solved in one iteration); damping is
//! switched on only if a step fails.
//!
//! With [bounds](LeastSquaresProblem::bounds) $\ell \le A\theta \le u$, the
//! step instead minimises the same damped model subject to
//! $\ell \le A(\theta + \delta) \le u$, a sparse convex QP solved by clarabel's
//! interior-point method; an infeasible start is first moved to the nearest
//! feasible point (the cost comparison starts there).
//!
//! For Eq. 3 ([`Eq3Problem`](crate::Eq3Problem)) every residual touches the
//! few coefficients whose basis functions overlap one time step, so $J^\top J$
//! is banded after ordering and an iteration costs time linear in the horizon.
//!
//! | setting | default | meaning |
//! |---|---|---|
//! | `max_iters` | 200 | iteration cap |
//! | `tol_grad` | 1e-10 | stop when $\lVert J^\top r \rVert_\infty \le$ `tol_grad` $\max(1, F)$ |
//! | `tol_step` | 1e-12 | stop when $\lVert \delta \rVert \le$ `tol_step` $(\lVert \theta \rVert + $ `tol_step`$)$ |
//! | `tol_cost` | 1e-14 | stop when an accepted step lowers $F$ by less than `tol_cost` $F$ |
//! | `initial_damping` | 1e-6 | $\mu_0 = $ `initial_damping` (relative to $D$) |
//!
//! References: K. Madsen, H. B. Nielsen, O. Tingleff, *Methods for Non-Linear
//! Least Squares Problems* (2004), §3.2; J. Nocedal, S. Wright, *Numerical
//! Optimization* (2006), ch. 10.

use std::time::{Duration, Instant};

use faer::prelude::*;
use faer::sparse::linalg::matmul::sparse_sparse_matmul_symbolic;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, SparseRowMat, SymbolicSparseColMat, SymbolicSparseRowMat};
use faer::{Mat, Side};

use crate::error::{Result, TrajoptError, check_finite};
use crate::least_squares::LeastSquaresProblem;

/// Settings of [`GaussNewton`]; see the [module docs](self) for the defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct GaussNewtonSettings {
    /// Iteration cap.
    pub max_iters: usize,
    /// Gradient tolerance, relative to $\max(1, F)$.
    pub tol_grad: f64,
    /// Step tolerance, relative to $\lVert \theta \rVert$.
    pub tol_step: f64,
    /// Relative cost-decrease tolerance.
    pub tol_cost: f64,
    /// Initial damping $\mu_0$ (0: start with pure Gauss-Newton steps).
    pub initial_damping: f64,
}

impl Default for GaussNewtonSettings {
    fn default() -> Self {
        Self {
            max_iters: 200,
            tol_grad: 1e-10,
            tol_step: 1e-12,
            tol_cost: 1e-14,
            initial_damping: 1e-6,
        }
    }
}

impl GaussNewtonSettings {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("tol_grad", self.tol_grad),
            ("tol_step", self.tol_step),
            ("tol_cost", self.tol_cost),
            ("initial_damping", self.initial_damping),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(TrajoptError::InvalidParameter {
                    name,
                    reason: format!("must be finite and nonnegative, got {v}"),
                });
            }
        }
        Ok(())
    }
}

/// Why [`GaussNewton`] stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GaussNewtonStatus {
    /// The gradient $J^\top r$ is below tolerance.
    ConvergedGradient,
    /// The step is below tolerance.
    ConvergedStep,
    /// The cost no longer decreases.
    ConvergedCost,
    /// The iteration cap was reached.
    MaxIterations,
    /// Steps kept failing until the damping made them negligible, while the
    /// gradient is not small: the residuals are not smooth enough here for
    /// their linearisation to predict them (a rough learned model, or a
    /// Jacobian that does not match the residuals). Not a converged point.
    Stalled,
    /// The residuals or Jacobian became non-finite at every trial step, or
    /// the normal equations could not be factorised even with damping.
    NumericalError,
}

impl GaussNewtonStatus {
    /// Whether this is one of the converged statuses.
    pub fn converged(self) -> bool {
        matches!(
            self,
            Self::ConvergedGradient | Self::ConvergedStep | Self::ConvergedCost
        )
    }
}

/// What [`GaussNewton::solve`] returns.
#[derive(Debug, Clone)]
pub struct GaussNewtonResult {
    /// The best parameters found.
    pub theta: Vec<f64>,
    /// $F$ at `theta`.
    pub cost: f64,
    /// $F$ at the start.
    pub initial_cost: f64,
    /// Why it stopped.
    pub status: GaussNewtonStatus,
    /// Iterations (Jacobian evaluations).
    pub iterations: usize,
    /// Residual evaluations.
    pub residual_evals: usize,
    /// Jacobian evaluations.
    pub jacobian_evals: usize,
    /// Accepted cost after each iteration.
    pub cost_history: Vec<f64>,
    /// Wall time.
    pub elapsed: Duration,
}

/// Sparse Gauss-Newton / Levenberg-Marquardt; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct GaussNewton {
    settings: GaussNewtonSettings,
}

impl GaussNewton {
    /// A solver with validated settings.
    pub fn new(settings: GaussNewtonSettings) -> Result<Self> {
        settings.validate()?;
        Ok(Self { settings })
    }

    /// The settings.
    pub fn settings(&self) -> &GaussNewtonSettings {
        &self.settings
    }

    /// Minimises $\lVert r(\theta) \rVert^2$ from `theta0`.
    ///
    /// # Errors
    /// Wrong dimensions, a non-finite `theta0`, a non-finite cost at
    /// `theta0` ([`TrajoptError::NonFiniteStart`]), or an error from the
    /// problem. Not converging is a status, not an error.
    pub fn solve<P: LeastSquaresProblem + ?Sized>(&self, problem: &P, theta0: &[f64]) -> Result<GaussNewtonResult> {
        let start = Instant::now();
        let (n_p, n_r) = (problem.n_params(), problem.n_residuals());
        if theta0.len() != n_p {
            return Err(TrajoptError::DimensionMismatch {
                what: "initial parameters",
                expected: n_p,
                actual: theta0.len(),
            });
        }
        check_finite("initial parameters", theta0)?;
        let s = &self.settings;

        let mut theta = theta0.to_vec();
        let mut r = vec![0.0; n_r];
        problem.residuals(&theta, &mut r)?;
        let mut cost = sum_sq(&r);
        if !cost.is_finite() {
            return Err(TrajoptError::NonFiniteStart { value: cost });
        }
        let mut residual_evals = 1;
        let bounds = problem.bounds();
        if let Some(b) = bounds {
            b.validate()?;
            if b.a.ncols() != n_p {
                return Err(TrajoptError::DimensionMismatch {
                    what: "bound matrix columns",
                    expected: n_p,
                    actual: b.a.ncols(),
                });
            }
            // an infeasible start is first moved to the nearest feasible point
            if b.violation(&theta) > 1e-9 {
                let delta = crate::qp::projection(b, &theta).ok_or(TrajoptError::InfeasibleBounds)?;
                for (t, d) in theta.iter_mut().zip(delta) {
                    *t += d;
                }
                problem.residuals(&theta, &mut r)?;
                residual_evals += 1;
                cost = sum_sq(&r);
                if !cost.is_finite() {
                    return Err(TrajoptError::NonFiniteStart { value: cost });
                }
            }
        }
        let initial_cost = cost;
        let mut jacobian_evals = 0;
        let mut cost_history = Vec::new();

        // fixed structures: J (rows), J^T J pattern, its diagonal, symbolic Cholesky
        // J is augmented with structurally present, zero-valued unit rows so that
        // the diagonal of J^T J is always in its pattern (a parameter that no
        // residual touches is then simply left alone by the damped step)
        let pattern = augment_with_diagonal(&problem.jacobian_pattern(), n_r, n_p)?;
        let nnz = pattern.col_idx().len();
        let nnz_problem = nnz - n_p;
        let mut jac = SparseRowMat::new(pattern, vec![0.0; nnz]);
        let jac_cols = jac.to_col_major().map_err(alloc_error)?;
        let (h_symbolic, _) = sparse_sparse_matmul_symbolic(jac.as_ref().transpose().symbolic(), jac_cols.symbolic())
            .map_err(alloc_error)?;
        let diag_pos = diagonal_positions(&h_symbolic)?;
        let h_nnz = h_symbolic.row_idx().len();
        let mut h = SparseColMat::new(h_symbolic, vec![0.0; h_nnz]);
        let llt_symbolic = SymbolicLlt::try_new(h.symbolic(), Side::Lower).map_err(alloc_error)?;
        let mut h_damped = h.clone();
        let mut normal = NormalEquations::new(&jac, jac_cols, &h.symbolic().to_owned().map_err(alloc_error)?);

        let mut grad = Mat::<f64>::zeros(n_p, 1);
        let mut trial = vec![0.0; n_p];
        let mut r_trial = vec![0.0; n_r];
        let mut mu = s.initial_damping;
        let mut nu = 2.0;
        let mut status = GaussNewtonStatus::MaxIterations;
        let mut iterations = 0;

        'outer: while iterations < s.max_iters {
            iterations += 1;
            problem.jacobian_values(&theta, &mut jac.val_mut()[..nnz_problem])?;
            jacobian_evals += 1;
            if jac.val().iter().any(|v| !v.is_finite()) {
                status = GaussNewtonStatus::NumericalError;
                break;
            }
            normal.form(&jac, &mut h);
            // g = J^T r
            for j in 0..n_p {
                grad[(j, 0)] = 0.0;
            }
            for (i, &ri) in r.iter().enumerate() {
                // (the augmented rows have zero residual and contribute nothing)
                let cols = jac.symbolic().col_idx_of_row_raw(i);
                for (&c, &v) in cols.iter().zip(jac.val_of_row(i)) {
                    grad[(c, 0)] += v * ri;
                }
            }
            let g_inf = (0..n_p).map(|j| grad[(j, 0)].abs()).fold(0.0, f64::max);
            if g_inf <= s.tol_grad * cost.max(1.0) {
                status = GaussNewtonStatus::ConvergedGradient;
                break;
            }
            let scale: Vec<f64> = diag_pos.iter().map(|&p| h.val()[p].max(1e-12)).collect();

            // inner loop: raise the damping until a step is accepted
            loop {
                h_damped.val_mut().copy_from_slice(h.val());
                for (&p, &d) in diag_pos.iter().zip(&scale) {
                    h_damped.val_mut()[p] += mu * d;
                }
                let step = match bounds {
                    // bounded: the damped model minimised subject to the bounds (a QP)
                    Some(b) => {
                        crate::qp::bounded_step(&h_damped, &grad, b, &theta).map(|d| Mat::from_fn(n_p, 1, |j, _| d[j]))
                    }
                    None => match Llt::try_new_with_symbolic(llt_symbolic.clone(), h_damped.as_ref(), Side::Lower) {
                        Ok(llt) => {
                            let mut rhs = grad.clone();
                            for j in 0..n_p {
                                rhs[(j, 0)] = -rhs[(j, 0)];
                            }
                            llt.solve_in_place(rhs.as_mut());
                            Some(rhs)
                        }
                        Err(_) => None,
                    },
                };
                let step = match step {
                    Some(st) if (0..n_p).all(|j| st[(j, 0)].is_finite()) => st,
                    _ => {
                        // not positive definite: more damping
                        if !raise_damping(&mut mu, &mut nu) {
                            status = GaussNewtonStatus::NumericalError;
                            break 'outer;
                        }
                        continue;
                    }
                };
                let step_norm = (0..n_p).map(|j| step[(j, 0)].powi(2)).sum::<f64>().sqrt();
                let theta_norm = sum_sq(&theta).sqrt();
                if step_norm <= s.tol_step * (theta_norm + s.tol_step) {
                    // a negligible step is convergence only if the damping did
                    // not force it: with mu >= 1 the damping term outweighs the
                    // curvature and the gradient is still large
                    status = if mu < 1.0 {
                        GaussNewtonStatus::ConvergedStep
                    } else {
                        GaussNewtonStatus::Stalled
                    };
                    break 'outer;
                }
                for j in 0..n_p {
                    trial[j] = theta[j] + step[(j, 0)];
                }
                problem.residuals(&trial, &mut r_trial)?;
                residual_evals += 1;
                let trial_cost = sum_sq(&r_trial);
                // L(d) = |r + J d|^2 = F + 2 g.d + d.H.d: predicted reduction L(0) - L(d)
                let h_step = sym_mat_vec(&h, &step);
                let predicted: f64 = -(0..n_p)
                    .map(|j| step[(j, 0)] * (2.0 * grad[(j, 0)] + h_step[j]))
                    .sum::<f64>();
                let rho = if predicted > 0.0 && trial_cost.is_finite() {
                    (cost - trial_cost) / predicted
                } else {
                    -1.0
                };
                if rho > 0.0 && trial_cost.is_finite() && trial_cost <= cost {
                    let decrease = cost - trial_cost;
                    std::mem::swap(&mut theta, &mut trial);
                    std::mem::swap(&mut r, &mut r_trial);
                    cost = trial_cost;
                    cost_history.push(cost);
                    mu *= (1.0 / 3.0f64).max(1.0 - (2.0 * rho - 1.0).powi(3));
                    nu = 2.0;
                    if decrease <= s.tol_cost * cost {
                        status = GaussNewtonStatus::ConvergedCost;
                        break 'outer;
                    }
                    break;
                }
                if !raise_damping(&mut mu, &mut nu) {
                    status = GaussNewtonStatus::NumericalError;
                    break 'outer;
                }
            }
        }
        Ok(GaussNewtonResult {
            theta,
            cost,
            initial_cost,
            status,
            iterations,
            residual_evals,
            jacobian_evals,
            cost_history,
            elapsed: start.elapsed(),
        })
    }
}

/// $\mu \leftarrow \max(\mu \nu, 10^{-12})$, $\nu \leftarrow 2\nu$; false once
/// the damping is hopelessly large.
fn raise_damping(mu: &mut f64, nu: &mut f64) -> bool {
    *mu = (*mu * *nu).max(1e-12);
    *nu *= 2.0;
    *mu < 1e16
}

fn sum_sq(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum()
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
    if pattern.nrows() != n_residuals || pattern.ncols() != n_params {
        return Err(TrajoptError::DimensionMismatch {
            what: "jacobian pattern rows",
            expected: n_residuals,
            actual: pattern.nrows(),
        });
    }
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

/// $H d$ for a CSC matrix holding both triangles.
fn sym_mat_vec(h: &SparseColMat<usize, f64>, d: &Mat<f64>) -> Vec<f64> {
    let mut out = vec![0.0; h.nrows()];
    for j in 0..h.ncols() {
        let dj = d[(j, 0)];
        for (&i, &v) in h.symbolic().row_idx_of_col_raw(j).iter().zip(h.val_of_col(j)) {
            out[i] += v * dj;
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

/// Forms $H = J^\top J$ into a fixed pattern, column by column (Gustavson):
/// $H_{:,j} = \sum_{i : J_{ij} \ne 0} J_{ij} J_{i,:}$, accumulated in a dense
/// vector that is cleared entry by entry through the pattern of $H_{:,j}$, so
/// the cost is $\sum_i \mathrm{nnz}(J_{i,:})^2$, linear in the horizon (a
/// general sparse product clears its whole accumulator per column, which is
/// quadratic in the number of parameters).
struct NormalEquations {
    /// $J$ by columns; its values are refreshed from the rows each time.
    cols: SparseColMat<usize, f64>,
    /// Position in `cols` of each entry of $J$'s rows.
    row_to_col: Vec<usize>,
    /// The pattern of $H$ (column pointers and row indices).
    h_col_ptr: Vec<usize>,
    h_row_idx: Vec<usize>,
    work: Vec<f64>,
}

impl NormalEquations {
    fn new(rows: &SparseRowMat<usize, f64>, cols: SparseColMat<usize, f64>, h: &SymbolicSparseColMat<usize>) -> Self {
        // entries of a column are sorted by row, so walking the rows in order
        // meets each column's entries in storage order
        let mut next: Vec<usize> = cols.symbolic().col_ptr()[..cols.ncols()].to_vec();
        let row_to_col = rows
            .symbolic()
            .col_idx()
            .iter()
            .map(|&c| {
                let p = next[c];
                next[c] += 1;
                p
            })
            .collect();
        let work = vec![0.0; cols.ncols()];
        Self {
            cols,
            row_to_col,
            h_col_ptr: h.col_ptr().to_vec(),
            h_row_idx: h.row_idx().to_vec(),
            work,
        }
    }

    fn form(&mut self, rows: &SparseRowMat<usize, f64>, h: &mut SparseColMat<usize, f64>) {
        {
            let vals = self.cols.val_mut();
            for (&p, &v) in self.row_to_col.iter().zip(rows.val()) {
                vals[p] = v;
            }
        }
        let row_ptr = rows.symbolic().row_ptr();
        let row_cols = rows.symbolic().col_idx();
        let row_vals = rows.val();
        let (col_ptr, h_rows) = (&self.h_col_ptr, &self.h_row_idx);
        let h_vals = h.val_mut();
        for j in 0..self.cols.ncols() {
            let (start, end) = (self.cols.symbolic().col_ptr()[j], self.cols.symbolic().col_ptr()[j + 1]);
            for p in start..end {
                let i = self.cols.symbolic().row_idx()[p];
                let v = self.cols.val()[p];
                for q in row_ptr[i]..row_ptr[i + 1] {
                    self.work[row_cols[q]] += v * row_vals[q];
                }
            }
            for p in col_ptr[j]..col_ptr[j + 1] {
                let r = h_rows[p];
                h_vals[p] = self.work[r];
                self.work[r] = 0.0;
            }
        }
    }
}
