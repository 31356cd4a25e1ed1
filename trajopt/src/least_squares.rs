//! Nonlinear least-squares problems with a sparse Jacobian of fixed pattern.

use std::ops::Range;

use faer::sparse::{SymbolicSparseColMat, SymbolicSparseRowMat};

use crate::banded::{BandLayout, BandedSym};
use crate::error::{Result, TrajoptError};

/// A problem $\min_\theta F(\theta) = \lVert r(\theta) \rVert^2$ whose Jacobian
/// $J = \partial r / \partial \theta$ is sparse with a pattern that does not
/// depend on $\theta$ (the structural nonzeros; some may be zero at a point).
///
/// This is what [`GaussNewton`](crate::GaussNewton) solves. The paper's Eq. 3
/// with a least-squares stage cost is one ([`Eq3Problem`](crate::Eq3Problem)).
pub trait LeastSquaresProblem {
    /// Number of parameters $\dim \theta$.
    fn n_params(&self) -> usize;

    /// Number of residuals $\dim r$.
    fn n_residuals(&self) -> usize;

    /// Writes $r(\theta)$ into `r` (length [`n_residuals`](Self::n_residuals)).
    fn residuals(&self, theta: &[f64], r: &mut [f64]) -> Result<()>;

    /// Part `part` of [`residuals`](Self::residuals) when the residuals are
    /// split into `parts` groups of consecutive rows: writes that group's
    /// rows of $r(\theta)$ into `r` (full length; the other rows are left
    /// as they are) and returns their range. The parts' ranges cover all
    /// rows once, and the parts can be evaluated at the same time on
    /// different threads
    /// ([`GaussNewton::solve_parallel`](crate::GaussNewton::solve_parallel)).
    ///
    /// The default evaluates every row in part 0 and none in the others.
    /// [`Eq3Problem`](crate::Eq3Problem) splits its time steps as in
    /// [`band_normal_equations_part`](Self::band_normal_equations_part).
    ///
    /// # Errors
    /// `part >= parts`, and the errors of [`residuals`](Self::residuals).
    fn residuals_part(&self, part: usize, parts: usize, theta: &[f64], r: &mut [f64]) -> Result<Range<usize>> {
        check_part(part, parts)?;
        if part > 0 {
            return Ok(0..0);
        }
        self.residuals(theta, r)?;
        Ok(0..self.n_residuals())
    }

    /// The sparsity pattern of $J$: compressed rows, sorted unique columns.
    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize>;

    /// Writes the values of $J(\theta)$ in the order of
    /// [`jacobian_pattern`](Self::jacobian_pattern).
    fn jacobian_values(&self, theta: &[f64], values: &mut [f64]) -> Result<()>;

    /// Linear bounds $\ell \le A \theta \le u$ the solution must satisfy
    /// (none by default).
    fn bounds(&self) -> Option<&LinearBounds> {
        None
    }

    /// The pattern (both triangles, compressed columns, sorted rows) of the
    /// second-order term $S(\theta) = \sum_i r_i \nabla^2 r_i$ of the Hessian
    /// $\nabla^2 F = 2 (J^\top J + S)$, if the problem can evaluate it (none
    /// by default: Gauss-Newton drops $S$).
    fn second_order_pattern(&self) -> Option<SymbolicSparseColMat<usize>> {
        None
    }

    /// Writes the values of $S(\theta)$ for the residuals `r` $= r(\theta)$
    /// in the order of [`second_order_pattern`](Self::second_order_pattern)
    /// and returns `true`, or returns `false` when it is not available at
    /// this point (the default).
    fn second_order_values(&self, theta: &[f64], r: &[f64], values: &mut [f64]) -> Result<bool> {
        let _ = (theta, r, values);
        Ok(false)
    }

    /// $\delta^\top S(\theta) \delta$ for the residuals `r` $= r(\theta)$, if the
    /// problem can evaluate it cheaply without forming $S$ (none by default).
    /// The [adaptive](crate::GaussNewtonSettings::adaptive) solver uses it to
    /// compare its two models; without it, it takes central differences of
    /// the residuals along $\delta$.
    ///
    /// # Errors
    /// Wrong sizes, or an error from evaluating the problem.
    fn second_order_form(&self, theta: &[f64], r: &[f64], delta: &[f64]) -> Result<Option<f64>> {
        let _ = (theta, r, delta);
        Ok(None)
    }

    /// A parameter order under which $J^\top J$ (and $S$) is banded, if the
    /// problem can form its normal equations in that band form itself
    /// ([`band_normal_equations`](Self::band_normal_equations)); none by
    /// default. [`GaussNewton`](crate::GaussNewton) then skips the sparse
    /// Jacobian and the sparse Cholesky factorisation and works on band
    /// matrices ([`crate::banded`]), which for trajectory problems is
    /// several times faster.
    fn band_layout(&self) -> Option<BandLayout> {
        None
    }

    /// Writes the normal equations at $\theta$ ($r = r(\theta)$) in the band
    /// form of `layout` (from [`band_layout`](Self::band_layout)): $J^\top r$
    /// into `grad` (in the parameter order) and $J^\top J$ into `h`; or,
    /// when `second_order` is given, $J^\top J + S$ into `h` and the
    /// diagonal of $S$ into `second_order` (parameter order), returning
    /// `true`. Returns `false` when $S$ was not asked for or is not
    /// available at this point (as for
    /// [`second_order_values`](Self::second_order_values)); `h` then holds
    /// $J^\top J$.
    ///
    /// # Errors
    /// Wrong sizes, or an error from evaluating the problem. The default
    /// (for problems without a band form) always fails.
    fn band_normal_equations(
        &self,
        theta: &[f64],
        r: &[f64],
        layout: &BandLayout,
        h: &mut BandedSym,
        grad: &mut [f64],
        second_order: Option<&mut [f64]>,
    ) -> Result<bool> {
        let _ = (theta, r, layout, h, grad, second_order);
        Err(TrajoptError::InvalidParameter {
            name: "problem",
            reason: "it has no band form of its normal equations".into(),
        })
    }

    /// The second-order term $S$ alone, in the band form of `layout`, from
    /// part `part` of `parts` of the residuals (as in
    /// [`band_normal_equations_part`](Self::band_normal_equations_part)):
    /// the $S$ that [`band_normal_equations`](Self::band_normal_equations)
    /// adds to $J^\top J$, written into `s`; false when $S$ is not available
    /// (`s` then holds nothing useful). When a Newton iteration of
    /// [`GaussNewton`](crate::GaussNewton) falls back to a Gauss-Newton
    /// step, it recovers $J^\top J = (J^\top J + S) - S$ from it, which
    /// costs less than forming $J^\top J$ again (about half, for
    /// [`Eq3Problem`](crate::Eq3Problem)). Not available by default.
    ///
    /// # Errors
    /// `part >= parts`, wrong sizes, or an error from evaluating the problem.
    #[allow(clippy::too_many_arguments)]
    fn band_second_order_part(
        &self,
        part: usize,
        parts: usize,
        theta: &[f64],
        r: &[f64],
        layout: &BandLayout,
        s: &mut BandedSym,
    ) -> Result<bool> {
        check_part(part, parts)?;
        let _ = (theta, r, layout, s);
        Ok(false)
    }

    /// Part `part` of [`band_normal_equations`](Self::band_normal_equations)
    /// when the residuals are split into `parts` groups: the same outputs,
    /// from one group's residuals only. The parts add up (`h`, `grad` and
    /// `second_order` each) to the whole, up to the rounding of that sum,
    /// and can be formed at the same time on different threads
    /// ([`GaussNewton::solve_parallel`](crate::GaussNewton::solve_parallel)).
    /// The returned flag means what it means there; a part without
    /// residuals returns whether `second_order` was given.
    ///
    /// The default forms everything in part 0 and nothing in the others:
    /// the right sum, without a speed-up. [`Eq3Problem`](crate::Eq3Problem)
    /// splits its time steps into `parts` consecutive runs.
    ///
    /// # Errors
    /// `part >= parts`, and the errors of
    /// [`band_normal_equations`](Self::band_normal_equations).
    #[allow(clippy::too_many_arguments)]
    fn band_normal_equations_part(
        &self,
        part: usize,
        parts: usize,
        theta: &[f64],
        r: &[f64],
        layout: &BandLayout,
        h: &mut BandedSym,
        grad: &mut [f64],
        second_order: Option<&mut [f64]>,
    ) -> Result<bool> {
        check_part(part, parts)?;
        if part == 0 {
            return self.band_normal_equations(theta, r, layout, h, grad, second_order);
        }
        h.clear();
        grad.fill(0.0);
        Ok(match second_order {
            Some(diag) => {
                diag.fill(0.0);
                true
            }
            None => false,
        })
    }
}

/// An error unless `part < parts`.
pub(crate) fn check_part(part: usize, parts: usize) -> Result<()> {
    if part < parts {
        return Ok(());
    }
    Err(TrajoptError::InvalidParameter {
        name: "part",
        reason: format!("part {part} of {parts} does not exist"),
    })
}

/// Linear bounds $\ell \le A \theta \le u$ on the parameters, $A$ sparse;
/// an infinite entry of $\ell$ or $u$ leaves that side free. For a
/// trajectory, each row of $A$ is a basis row at one sample time, so the
/// bounds hold at the sample times.
#[derive(Debug, Clone)]
pub struct LinearBounds {
    /// $A$, one row per bounded quantity.
    pub a: faer::sparse::SparseRowMat<usize, f64>,
    /// Lower bounds $\ell$ (may be $-\infty$).
    pub lower: Vec<f64>,
    /// Upper bounds $u$ (may be $+\infty$).
    pub upper: Vec<f64>,
}

impl LinearBounds {
    /// Checks the sizes and that $\ell \le u$ with no NaN.
    pub fn validate(&self) -> Result<()> {
        for (what, v) in [("lower bounds", &self.lower), ("upper bounds", &self.upper)] {
            if v.len() != self.a.nrows() {
                return Err(crate::TrajoptError::DimensionMismatch {
                    what,
                    expected: self.a.nrows(),
                    actual: v.len(),
                });
            }
        }
        for (i, (&l, &u)) in self.lower.iter().zip(&self.upper).enumerate() {
            if l.is_nan() || u.is_nan() || l > u || l == f64::INFINITY || u == f64::NEG_INFINITY {
                return Err(crate::TrajoptError::InvalidParameter {
                    name: "bounds",
                    reason: format!("bound {i} is empty: [{l}, {u}]"),
                });
            }
        }
        crate::error::check_finite("bound matrix", self.a.val())
    }

    /// $A\theta$.
    pub fn apply(&self, theta: &[f64]) -> Vec<f64> {
        (0..self.a.nrows())
            .map(|i| {
                let cols = self.a.symbolic().col_idx_of_row_raw(i);
                cols.iter().zip(self.a.val_of_row(i)).map(|(&c, &v)| v * theta[c]).sum()
            })
            .collect()
    }

    /// The largest violation $\max_i \max(\ell_i - (A\theta)_i, (A\theta)_i - u_i, 0)$.
    pub fn violation(&self, theta: &[f64]) -> f64 {
        self.apply(theta)
            .iter()
            .zip(self.lower.iter().zip(&self.upper))
            .map(|(&v, (&l, &u))| (l - v).max(v - u).max(0.0))
            .fold(0.0, f64::max)
    }
}

/// The linear least-squares problem $\min_\theta \lVert A \theta - b \rVert^2$
/// with a sparse $A$: the simplest [`LeastSquaresProblem`], whose solution
/// the normal equations give in closed form (Gauss-Newton solves it in one
/// step). Useful to test solvers.
#[derive(Debug, Clone)]
pub struct LinearLeastSquares {
    a: faer::sparse::SparseRowMat<usize, f64>,
    b: Vec<f64>,
}

impl LinearLeastSquares {
    /// The problem for `a` ($m \times n$, compressed rows with sorted
    /// columns) and `b` (length $m$).
    pub fn new(a: faer::sparse::SparseRowMat<usize, f64>, b: Vec<f64>) -> Result<Self> {
        if a.nrows() != b.len() {
            return Err(crate::TrajoptError::DimensionMismatch {
                what: "right-hand side",
                expected: a.nrows(),
                actual: b.len(),
            });
        }
        crate::error::check_finite("A", a.val())?;
        crate::error::check_finite("b", &b)?;
        Ok(Self { a, b })
    }

    /// The matrix $A$.
    pub fn a(&self) -> &faer::sparse::SparseRowMat<usize, f64> {
        &self.a
    }

    /// The right-hand side $b$.
    pub fn b(&self) -> &[f64] {
        &self.b
    }
}

impl LeastSquaresProblem for LinearLeastSquares {
    fn n_params(&self) -> usize {
        self.a.ncols()
    }

    fn n_residuals(&self) -> usize {
        self.a.nrows()
    }

    fn residuals(&self, theta: &[f64], r: &mut [f64]) -> Result<()> {
        for (i, ri) in r.iter_mut().enumerate() {
            let cols = self.a.symbolic().col_idx_of_row_raw(i);
            *ri = cols
                .iter()
                .zip(self.a.val_of_row(i))
                .map(|(&c, &v)| v * theta[c])
                .sum::<f64>()
                - self.b[i];
        }
        Ok(())
    }

    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
        self.a.symbolic().to_owned().unwrap_or_else(|_| {
            SymbolicSparseRowMat::new_checked(
                self.a.nrows(),
                self.a.ncols(),
                vec![0; self.a.nrows() + 1],
                None,
                vec![],
            )
        })
    }

    fn jacobian_values(&self, _theta: &[f64], values: &mut [f64]) -> Result<()> {
        values.copy_from_slice(self.a.val());
        Ok(())
    }
}
