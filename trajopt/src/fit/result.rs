//! What [`LeastSquares::solve`](super::LeastSquares::solve) returns: the
//! fit, and the covariance and standard errors of its estimate.

use std::time::Duration;

use super::FitStatus;
use crate::error::{Result, TrajoptError};

/// What [`LeastSquares::solve`](super::LeastSquares::solve) returns.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct LeastSquaresFit {
    /// The best point found.
    pub x: Vec<f64>,
    /// $F = \lVert r \rVert^2$ at `x`, or $\sum_i C^2 \rho(z_i)$ with a
    /// robust [`Loss`](super::Loss) (scipy's `cost` is half of it).
    pub cost: f64,
    /// $F$ at the start.
    pub initial_cost: f64,
    /// Why the iteration stopped ([`FitStatus::is_converged`](super::FitStatus::is_converged)).
    pub status: FitStatus,
    /// Iterations.
    pub iterations: usize,
    /// Calls of the user's residual function: the solve's (the
    /// differences' and a pattern probing's included) and those at the
    /// answer (its residuals, and its Jacobian's differences when there
    /// is no Jacobian).
    pub evals: usize,
    /// Calls of the user's Jacobian, the one at the answer included (0
    /// when differenced).
    pub jacobian_evals: usize,
    /// Wall time of the solve.
    pub solve_time: Duration,
    /// $r$ at `x`.
    pub residuals: Vec<f64>,
    /// $J = \partial r / \partial x$ at `x`, $m \times n$ row-major (the
    /// user's, or central differences).
    pub jacobian: Vec<f64>,
    /// $d\tilde r_i / dr_i$ of the loss at `x` (all 1 for the squared loss).
    pub(super) weights: Vec<f64>,
}

impl LeastSquaresFit {
    /// The covariance of the estimate, $\hat\sigma^2 (J^\top J)^{-1}$ with
    /// $\hat\sigma^2 = F / (m - n)$, $n \times n$ row-major (NIST's and
    /// scipy `curve_fit`'s definition); with a robust [`Loss`](super::Loss), $J$'s rows
    /// are scaled by $d\tilde r_i / dr_i$ (the weights of the last
    /// reweighted step). $J^\top J$ is factored with its columns scaled to
    /// unit norm, so that parameters of very different magnitudes lose no
    /// accuracy.
    ///
    /// # Errors
    /// No more residuals than parameters ($m \le n$), or $J$ of deficient
    /// rank at `x` ([`TrajoptError::InvalidParameter`] saying which).
    pub fn covariance(&self) -> Result<Vec<f64>> {
        let (m, n) = (self.residuals.len(), self.x.len());
        if m <= n {
            return Err(TrajoptError::InvalidParameter {
                name: "covariance",
                reason: format!("needs more residuals than parameters, got m = {m}, n = {n}"),
            });
        }
        let j: Vec<f64> = (0..m * n).map(|e| self.weights[e / n] * self.jacobian[e]).collect();
        let norms: Vec<f64> = (0..n)
            .map(|k| (0..m).map(|i| j[i * n + k].powi(2)).sum::<f64>().sqrt())
            .collect();
        let deficient = || TrajoptError::InvalidParameter {
            name: "covariance",
            reason: "the Jacobian at the solution does not have full column rank".into(),
        };
        if norms.iter().any(|&s| !(s > 0.0 && s.is_finite())) {
            return Err(deficient());
        }
        // D J^T J D with D = diag(1 / |J_k|)
        let mut a = vec![0.0; n * n];
        for p in 0..n {
            for q in 0..=p {
                let v = (0..m).map(|i| j[i * n + p] * j[i * n + q]).sum::<f64>() / (norms[p] * norms[q]);
                a[p * n + q] = v;
                a[q * n + p] = v;
            }
        }
        solve::dense::cholesky(&mut a, n).ok_or_else(deficient)?;
        let sigma2 = self.cost / (m - n) as f64;
        let mut cov = vec![0.0; n * n];
        let mut e = vec![0.0; n];
        for q in 0..n {
            e.fill(0.0);
            e[q] = 1.0;
            solve::dense::cholesky_solve(&a, n, &mut e);
            for p in 0..n {
                cov[p * n + q] = sigma2 * e[p] / (norms[p] * norms[q]);
            }
        }
        Ok(cov)
    }

    /// The standard errors of the estimate: the square roots of the
    /// [`covariance`](Self::covariance)'s diagonal.
    ///
    /// # Errors
    /// As [`covariance`](Self::covariance).
    pub fn standard_errors(&self) -> Result<Vec<f64>> {
        let n = self.x.len();
        let cov = self.covariance()?;
        Ok((0..n).map(|k| cov[k * n + k].sqrt()).collect())
    }
}
