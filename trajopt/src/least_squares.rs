//! Nonlinear least-squares problems with a sparse Jacobian of fixed pattern,
//! and the opt-in capabilities a solver can use: the second-order term
//! ([`SecondOrder`]) and the band form of the normal equations ([`BandForm`]).

use std::ops::Range;

use faer::sparse::{SymbolicSparseColMat, SymbolicSparseRowMat};

use crate::error::{Result, TrajoptError};
use crate::linalg::{BandLayout, BandedSym};

/// A problem $\min_\theta F(\theta) = \lVert r(\theta) \rVert^2$ whose Jacobian
/// $J = \partial r / \partial \theta$ is sparse with a pattern that does not
/// depend on $\theta$ (the structural nonzeros; some may be zero at a point).
///
/// This is what [`GaussNewton`](crate::GaussNewton) solves. A plain problem
/// implements the five required methods (sizes, residuals, the Jacobian's
/// pattern and values); the rest is opt-in:
///
/// - [`bounds`](Self::bounds): linear bounds on $\theta$;
/// - [`second_order`](Self::second_order): the second-order term $S$ for
///   the Newton modes ([`SecondOrder`]);
/// - [`band_form`](Self::band_form): the normal equations formed in band
///   storage, in parts on several threads ([`BandForm`]).
///
/// The paper's Eq. 3 with a least-squares stage cost
/// ([`Eq3Problem`](crate::Eq3Problem)) has all three.
///
/// # Example
///
/// Fitting $y = a e^{b t}$ to four points: only the core methods.
///
/// ```
/// use faer::sparse::SymbolicSparseRowMat;
/// use trajopt::{GaussNewton, GaussNewtonSettings, LeastSquaresProblem};
///
/// struct ExpFit {
///     t: Vec<f64>,
///     y: Vec<f64>,
/// }
///
/// impl LeastSquaresProblem for ExpFit {
///     fn n_params(&self) -> usize {
///         2
///     }
///     fn n_residuals(&self) -> usize {
///         self.t.len()
///     }
///     fn residuals(&self, p: &[f64], r: &mut [f64]) -> trajopt::Result<()> {
///         for ((ri, &t), &y) in r.iter_mut().zip(&self.t).zip(&self.y) {
///             *ri = p[0] * (p[1] * t).exp() - y;
///         }
///         Ok(())
///     }
///     fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
///         // every residual depends on both parameters
///         let m = self.t.len();
///         let row_ptr = (0..=m).map(|i| 2 * i).collect();
///         let col_idx = (0..m).flat_map(|_| [0, 1]).collect();
///         SymbolicSparseRowMat::new_checked(m, 2, row_ptr, None, col_idx)
///     }
///     fn jacobian_values(&self, p: &[f64], values: &mut [f64]) -> trajopt::Result<()> {
///         for (row, &t) in values.chunks_exact_mut(2).zip(&self.t) {
///             let e = (p[1] * t).exp();
///             row.copy_from_slice(&[e, p[0] * t * e]);
///         }
///         Ok(())
///     }
/// }
///
/// let t = vec![0.0, 0.5, 1.0, 1.5];
/// let y = t.iter().map(|t: &f64| 2.0 * (-0.7 * t).exp()).collect();
/// let fit = GaussNewton::new(GaussNewtonSettings::default())?.solve(&ExpFit { t, y }, &[1.0, 0.0])?;
/// assert!(fit.status.is_converged());
/// assert!((fit.x[0] - 2.0).abs() < 1e-8 && (fit.x[1] + 0.7).abs() < 1e-8);
/// # Ok::<(), trajopt::TrajoptError>(())
/// ```
pub trait LeastSquaresProblem {
    /// Number of parameters $\dim \theta$.
    fn n_params(&self) -> usize;

    /// Number of residuals $\dim r$.
    fn n_residuals(&self) -> usize;

    /// Writes $r(\theta)$ into `r` (length [`n_residuals`](Self::n_residuals)).
    fn residuals(&self, theta: &[f64], r: &mut [f64]) -> Result<()>;

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

    /// The problem's second-order term, if it can evaluate it (none by
    /// default: the Newton modes then take Gauss-Newton steps).
    fn second_order(&self) -> Option<&dyn SecondOrder> {
        None
    }

    /// The problem's band form of the normal equations, if it has one
    /// (none by default: the general sparse path).
    fn band_form(&self) -> Option<&dyn BandForm> {
        None
    }
}

/// The second-order term $S(\theta) = \sum_i r_i \nabla^2 r_i$ of the Hessian
/// $\nabla^2 F = 2 (J^\top J + S)$ of a [`LeastSquaresProblem`], for the
/// Newton modes of [`GaussNewton`](crate::GaussNewton)
/// ([`StepModel::Newton`](crate::StepModel::Newton),
/// [`StepModel::Adaptive`](crate::StepModel::Adaptive)). Gauss-Newton drops it.
pub trait SecondOrder {
    /// The pattern of $S$: both triangles, compressed columns, sorted rows.
    fn pattern(&self) -> SymbolicSparseColMat<usize>;

    /// Writes the values of $S(\theta)$ for the residuals `r` $= r(\theta)$
    /// in the order of [`pattern`](Self::pattern) and returns `true`, or
    /// returns `false` when it is not available at this point.
    ///
    /// # Errors
    /// Wrong sizes, or an error from evaluating the problem.
    fn values(&self, theta: &[f64], r: &[f64], values: &mut [f64]) -> Result<bool>;

    /// $\delta^\top S(\theta) \delta$ for the residuals `r` $= r(\theta)$, if the
    /// problem can evaluate it cheaply without forming $S$ (none by default).
    /// The [adaptive](crate::StepModel::Adaptive) solver uses it to compare
    /// its two models; without it, it takes central differences of the
    /// residuals along $\delta$.
    ///
    /// # Errors
    /// Wrong sizes, or an error from evaluating the problem.
    fn form(&self, theta: &[f64], r: &[f64], delta: &[f64]) -> Result<Option<f64>> {
        let _ = (theta, r, delta);
        Ok(None)
    }
}

/// Part `index` of `count` groups of consecutive residual rows (time
/// steps, for Eq. 3), formed at the same time on different threads by
/// [`GaussNewton::solve_parallel`](crate::GaussNewton::solve_parallel).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Part {
    /// Which part, `0..count`.
    pub index: usize,
    /// How many parts.
    pub count: usize,
}

impl Part {
    /// The whole: part 0 of 1.
    pub const WHOLE: Self = Self { index: 0, count: 1 };

    /// An error unless `index < count`.
    pub fn check(self) -> Result<()> {
        check_part(self.index, self.count)
    }
}

/// A point of a [`LeastSquaresProblem`]: the parameters $\theta$ and the
/// residuals `r` $= r(\theta)$ already evaluated there.
#[derive(Debug, Clone, Copy)]
pub struct Point<'a> {
    /// The parameters $\theta$.
    pub theta: &'a [f64],
    /// The residuals $r(\theta)$.
    pub r: &'a [f64],
}

/// Where [`BandForm::normal_equations`] writes: $J^\top J$ (or
/// $J^\top J + S$) into `h`, $J^\top r$ into `grad` (parameter order), and,
/// when given, the diagonal of $S$ into `second_order_diagonal` (parameter
/// order); giving it asks for $S$.
#[derive(Debug)]
pub struct BandNormalEquations<'a> {
    /// The band matrix $J^\top J$, or $J^\top J + S$.
    pub h: &'a mut BandedSym,
    /// The gradient $J^\top r$.
    pub grad: &'a mut [f64],
    /// The diagonal of $S$; `Some` asks for $S$.
    pub second_order_diagonal: Option<&'a mut [f64]>,
}

/// A [`LeastSquaresProblem`] that forms its normal equations itself in
/// band storage ([`crate::linalg`]): [`GaussNewton`](crate::GaussNewton)
/// then skips the sparse Jacobian and the sparse Cholesky factorisation and
/// works on band matrices, which for trajectory problems is several times
/// faster. The parts ([`Part`]) let
/// [`GaussNewton::solve_parallel`](crate::GaussNewton::solve_parallel) form
/// them on several threads.
pub trait BandForm: LeastSquaresProblem {
    /// A parameter order under which $J^\top J$ (and $S$) is banded.
    fn layout(&self) -> BandLayout;

    /// Writes the normal equations at `at` in the band form of `layout`
    /// (from [`layout`](Self::layout)) into `out` ([`BandNormalEquations`]),
    /// returning `true` when $S$ was asked for and is included, `false`
    /// when it was not asked for or is not available at this point (`h`
    /// then holds $J^\top J$).
    ///
    /// # Errors
    /// Wrong sizes, or an error from evaluating the problem.
    fn normal_equations(&self, at: Point<'_>, layout: &BandLayout, out: BandNormalEquations<'_>) -> Result<bool>;

    /// Part `part` of [`normal_equations`](Self::normal_equations): the
    /// same outputs, from one group's residuals only. The parts add up
    /// (`h`, `grad` and the diagonal each) to the whole, up to the rounding
    /// of that sum. The returned flag means what it means there; a part
    /// without residuals returns whether $S$ was asked for.
    ///
    /// The default forms everything in part 0 and nothing in the others:
    /// the right sum, without a speed-up. [`Eq3Problem`](crate::Eq3Problem)
    /// splits its time steps into consecutive runs.
    ///
    /// # Errors
    /// A part that does not exist, and the errors of
    /// [`normal_equations`](Self::normal_equations).
    fn normal_equations_part(
        &self,
        part: Part,
        at: Point<'_>,
        layout: &BandLayout,
        out: BandNormalEquations<'_>,
    ) -> Result<bool> {
        part.check()?;
        if part.index == 0 {
            return self.normal_equations(at, layout, out);
        }
        out.h.clear();
        out.grad.fill(0.0);
        Ok(match out.second_order_diagonal {
            Some(diag) => {
                diag.fill(0.0);
                true
            }
            None => false,
        })
    }

    /// Part `part` of the residuals: writes that group's rows of
    /// $r(\theta)$ into `r` (full length; the other rows are left as they
    /// are) and returns their range. The parts' ranges cover all rows once.
    ///
    /// The default evaluates every row in part 0 and none in the others.
    ///
    /// # Errors
    /// A part that does not exist, and the errors of
    /// [`residuals`](LeastSquaresProblem::residuals).
    fn residuals_part(&self, part: Part, theta: &[f64], r: &mut [f64]) -> Result<Range<usize>> {
        part.check()?;
        if part.index > 0 {
            return Ok(0..0);
        }
        self.residuals(theta, r)?;
        Ok(0..self.n_residuals())
    }

    /// The second-order term $S$ alone, in the band form of `layout`, from
    /// part `part` of the residuals: the $S$ that
    /// [`normal_equations`](Self::normal_equations) adds to $J^\top J$,
    /// written into `s`; false when $S$ is not available (`s` then holds
    /// nothing useful). When a Newton iteration falls back to a
    /// Gauss-Newton step, the solver recovers $J^\top J = (J^\top J + S) - S$
    /// from it, which costs less than forming $J^\top J$ again (about half,
    /// for [`Eq3Problem`](crate::Eq3Problem)). Not available by default.
    ///
    /// # Errors
    /// A part that does not exist, wrong sizes, or an error from evaluating
    /// the problem.
    fn second_order_part(&self, part: Part, at: Point<'_>, layout: &BandLayout, s: &mut BandedSym) -> Result<bool> {
        part.check()?;
        let _ = (at, layout, s);
        Ok(false)
    }
}

/// An error unless the Jacobian pattern is `n_residuals` by `n_params`.
pub(crate) fn check_jacobian_pattern(
    pattern: &SymbolicSparseRowMat<usize>,
    n_residuals: usize,
    n_params: usize,
) -> Result<()> {
    if pattern.nrows() != n_residuals || pattern.ncols() != n_params {
        return Err(TrajoptError::DimensionMismatch {
            what: "jacobian pattern rows",
            expected: n_residuals,
            actual: pattern.nrows(),
        });
    }
    Ok(())
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

    /// The bounds as a box on the parameters, $lo_k \le \theta_k \le hi_k$
    /// (infinite where a parameter is unbounded), when they are one:
    /// every row of $A$ a single positive entry, each parameter in at
    /// most one row. `n` is the number of parameters. A box is kept by
    /// Gauss-Newton's projected Newton steps ([`crate::gauss_newton`]),
    /// without a QP solver.
    pub fn as_box(&self, n: usize) -> Option<(Vec<f64>, Vec<f64>)> {
        if self.a.ncols() != n {
            return None;
        }
        let (mut lo, mut hi) = (vec![f64::NEG_INFINITY; n], vec![f64::INFINITY; n]);
        let mut seen = vec![false; n];
        for i in 0..self.a.nrows() {
            let (cols, vals) = (self.a.symbolic().col_idx_of_row_raw(i), self.a.val_of_row(i));
            let [(&k, &v)] = cols.iter().zip(vals).collect::<Vec<_>>()[..] else {
                return None;
            };
            if !(v > 0.0 && v.is_finite()) || std::mem::replace(&mut seen[k], true) {
                return None;
            }
            (lo[k], hi[k]) = (self.lower[i] / v, self.upper[i] / v);
        }
        Some((lo, hi))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{GaussNewton, GaussNewtonSettings, LinearSolver, StepModel};

    /// $y = a e^{b t}$ through exact data: a problem with the core methods
    /// only (no bounds, no second-order term, no band form).
    struct ExpFit {
        t: Vec<f64>,
        y: Vec<f64>,
    }

    impl LeastSquaresProblem for ExpFit {
        fn n_params(&self) -> usize {
            2
        }
        fn n_residuals(&self) -> usize {
            self.t.len()
        }
        fn residuals(&self, p: &[f64], r: &mut [f64]) -> Result<()> {
            for ((ri, &t), &y) in r.iter_mut().zip(&self.t).zip(&self.y) {
                *ri = p[0] * (p[1] * t).exp() - y;
            }
            Ok(())
        }
        fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
            let m = self.t.len();
            SymbolicSparseRowMat::new_checked(m, 2, (0..=m).map(|i| 2 * i).collect(), None, [0, 1].repeat(m))
        }
        fn jacobian_values(&self, p: &[f64], values: &mut [f64]) -> Result<()> {
            for (row, &t) in values.chunks_exact_mut(2).zip(&self.t) {
                let e = (p[1] * t).exp();
                row.copy_from_slice(&[e, p[0] * t * e]);
            }
            Ok(())
        }
    }

    #[test]
    fn a_plain_curve_fit_needs_only_the_core_methods() {
        let t: Vec<f64> = (0..8).map(|i| 0.25 * i as f64).collect();
        let y = t.iter().map(|t| 2.0 * (-0.7 * t).exp()).collect();
        let fit = ExpFit { t, y };
        assert!(fit.second_order().is_none() && fit.band_form().is_none());
        assert!(crate::check_jacobian(&fit, &[1.3, 0.2]).expect("check").max_rel_error < 1e-8);
        // every step model and linear solver runs it (the Newton modes take
        // Gauss-Newton steps without S): the same fit
        for step_model in [StepModel::GaussNewton, StepModel::Newton, StepModel::Adaptive] {
            for linear_solver in [LinearSolver::Auto, LinearSolver::Sparse] {
                let settings = GaussNewtonSettings {
                    step_model,
                    linear_solver,
                    ..GaussNewtonSettings::default()
                };
                let r = GaussNewton::new(settings)
                    .expect("settings")
                    .solve(&fit, &[1.0, 0.0])
                    .expect("solve");
                assert!(
                    r.status.is_converged(),
                    "{step_model:?} {linear_solver:?}: {:?}",
                    r.status
                );
                assert!((r.x[0] - 2.0).abs() < 1e-8 && (r.x[1] + 0.7).abs() < 1e-8, "{:?}", r.x);
                assert!(r.cost < 1e-20 && r.cost_history.windows(2).all(|w| w[1] <= w[0]));
            }
        }
    }
}
