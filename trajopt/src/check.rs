//! Checking an analytic Jacobian against central differences.
//!
//! [`check_jacobian`] compares every entry of $J(\theta)$ that a
//! [`LeastSquaresProblem`] returns with the central difference
//! $(r(\theta + h e_j) - r(\theta - h e_j)) / 2h$, $h = \epsilon^{1/3}
//! \max(1, |\theta_j|)$ (truncation error $O(h^2)$, rounding
//! $O(\epsilon / h)$), and reports the worst relative error
//! $|J_{ij} - D_{ij}| / \max(1, |J_{ij}|, |D_{ij}|)$ and where it occurred.
//! Entries outside the Jacobian's pattern count as analytic zeros, so a
//! pattern that misses a dependence shows up too.
//!
//! ```
//! use trajopt::check::check_jacobian;
//! use trajopt::problems::pendulum_swingup;
//!
//! let (problem, theta) = pendulum_swingup(20, 1e2)?;
//! let worst = check_jacobian(&problem, &theta)?;
//! assert!(worst.error < 1e-6, "{worst:?}");
//! # Ok::<(), trajopt::TrajoptError>(())
//! ```

use crate::error::{Result, check_point};
use crate::least_squares::{LeastSquaresProblem, check_jacobian_pattern};

/// The worst disagreement found by [`check_jacobian`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JacobianCheck {
    /// The largest relative error
    /// $|J_{ij} - D_{ij}| / \max(1, |J_{ij}|, |D_{ij}|)$.
    pub error: f64,
    /// The residual (row) where it occurred.
    pub row: usize,
    /// The parameter (column) where it occurred.
    pub col: usize,
    /// The analytic entry $J_{ij}$ there (0 outside the pattern).
    pub analytic: f64,
    /// The central difference $D_{ij}$ there.
    pub numeric: f64,
}

/// Compares the problem's analytic Jacobian at `theta` with central
/// differences of its residuals; see the [module docs](self).
///
/// # Errors
/// Wrong sizes, a non-finite `theta`, a Jacobian pattern of the wrong
/// shape, or an error from evaluating the problem.
pub fn check_jacobian<P: LeastSquaresProblem + ?Sized>(problem: &P, theta: &[f64]) -> Result<JacobianCheck> {
    let (n_p, n_r) = (problem.n_params(), problem.n_residuals());
    check_point("parameters", n_p, theta)?;
    let pattern = problem.jacobian_pattern();
    check_jacobian_pattern(&pattern, n_r, n_p)?;
    let mut values = vec![0.0; pattern.col_idx().len()];
    problem.jacobian_values(theta, &mut values)?;
    // the analytic Jacobian dense, column-major
    let mut analytic = vec![0.0; n_r * n_p];
    for i in 0..n_r {
        let (start, end) = (pattern.row_ptr()[i], pattern.row_ptr()[i + 1]);
        for (&j, &v) in pattern.col_idx()[start..end].iter().zip(&values[start..end]) {
            analytic[j * n_r + i] += v;
        }
    }
    let mut worst = JacobianCheck {
        error: 0.0,
        row: 0,
        col: 0,
        analytic: 0.0,
        numeric: 0.0,
    };
    let (mut plus, mut minus) = (vec![0.0; n_r], vec![0.0; n_r]);
    let mut probe = theta.to_vec();
    for j in 0..n_p {
        let h = f64::EPSILON.cbrt() * theta[j].abs().max(1.0);
        probe[j] = theta[j] + h;
        problem.residuals(&probe, &mut plus)?;
        probe[j] = theta[j] - h;
        problem.residuals(&probe, &mut minus)?;
        probe[j] = theta[j];
        for i in 0..n_r {
            let numeric = (plus[i] - minus[i]) / (2.0 * h);
            let a = analytic[j * n_r + i];
            let error = (a - numeric).abs() / 1f64.max(a.abs()).max(numeric.abs());
            // a NaN counts as the worst error
            if error > worst.error || (error.is_nan() && !worst.error.is_nan()) {
                worst = JacobianCheck {
                    error,
                    row: i,
                    col: j,
                    analytic: a,
                    numeric,
                };
            }
        }
    }
    Ok(worst)
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::SymbolicSparseRowMat;

    /// $r = (\theta_0^2 - 1, \theta_0 \theta_1)$, its Jacobian right or
    /// with a wrong entry, and a pattern missing $\partial r_1 / \partial
    /// \theta_0$ when `drop`.
    struct Small {
        wrong: bool,
        drop: bool,
    }

    impl LeastSquaresProblem for Small {
        fn n_params(&self) -> usize {
            2
        }
        fn n_residuals(&self) -> usize {
            2
        }
        fn residuals(&self, t: &[f64], r: &mut [f64]) -> Result<()> {
            r[0] = t[0] * t[0] - 1.0;
            r[1] = t[0] * t[1];
            Ok(())
        }
        fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
            if self.drop {
                SymbolicSparseRowMat::new_checked(2, 2, vec![0, 1, 2], None, vec![0, 1])
            } else {
                SymbolicSparseRowMat::new_checked(2, 2, vec![0, 1, 3], None, vec![0, 0, 1])
            }
        }
        fn jacobian_values(&self, t: &[f64], v: &mut [f64]) -> Result<()> {
            if self.drop {
                v.copy_from_slice(&[2.0 * t[0], t[0]]);
            } else {
                let d00 = if self.wrong { 3.0 * t[0] } else { 2.0 * t[0] };
                v.copy_from_slice(&[d00, t[1], t[0]]);
            }
            Ok(())
        }
    }

    #[test]
    fn a_right_jacobian_passes_and_a_wrong_one_is_located() {
        let theta = [1.5, -2.0];
        let right = check_jacobian(
            &Small {
                wrong: false,
                drop: false,
            },
            &theta,
        )
        .expect("check");
        assert!(right.error < 1e-9, "{right:?}");
        let wrong = check_jacobian(
            &Small {
                wrong: true,
                drop: false,
            },
            &theta,
        )
        .expect("check");
        assert_eq!((wrong.row, wrong.col), (0, 0));
        assert!((wrong.analytic - 4.5).abs() < 1e-12 && (wrong.numeric - 3.0).abs() < 1e-6);
        assert!((wrong.error - 1.5 / 4.5).abs() < 1e-6);
        // a dependence missing from the pattern: d r_1 / d theta_0 = theta_1
        let dropped = check_jacobian(
            &Small {
                wrong: false,
                drop: true,
            },
            &theta,
        )
        .expect("check");
        assert_eq!((dropped.row, dropped.col, dropped.analytic), (1, 0, 0.0));
        assert!((dropped.numeric + 2.0).abs() < 1e-6);
    }

    #[test]
    fn bad_input_is_an_error() {
        let p = Small {
            wrong: false,
            drop: false,
        };
        assert!(check_jacobian(&p, &[1.0]).is_err());
        assert!(check_jacobian(&p, &[1.0, f64::NAN]).is_err());
    }
}
