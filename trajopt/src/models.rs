//! Simple dynamics models: linear systems, for tests and as references.

use faer::Mat;

use crate::eq3::Dynamics;
use crate::error::{Result, TrajoptError, check_finite};
use systems::ModelResult;

/// The linear model $x_{k+1} = A x_k + B u_k$, with exact Jacobians.
#[derive(Debug, Clone)]
pub struct LinearModel {
    a: Mat<f64>,
    b: Mat<f64>,
}

impl LinearModel {
    /// The model for $A$ ($n \times n$) and $B$ ($n \times m$).
    pub fn new(a: Mat<f64>, b: Mat<f64>) -> Result<Self> {
        if a.nrows() != a.ncols() || b.nrows() != a.nrows() {
            return Err(TrajoptError::DimensionMismatch {
                what: "linear model (A square, B with A's rows)",
                expected: a.nrows(),
                actual: if a.nrows() != a.ncols() { a.ncols() } else { b.nrows() },
            });
        }
        for mat in [&a, &b] {
            for j in 0..mat.ncols() {
                let col: Vec<f64> = mat.col(j).iter().copied().collect();
                check_finite("linear model", &col)?;
            }
        }
        Ok(Self { a, b })
    }
}

impl Dynamics for LinearModel {
    fn state_dim(&self) -> usize {
        self.a.nrows()
    }

    fn control_dim(&self) -> usize {
        self.b.ncols()
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        for (i, ni) in next.iter_mut().enumerate() {
            *ni = (0..x.len()).map(|c| self.a[(i, c)] * x[c]).sum::<f64>()
                + (0..u.len()).map(|c| self.b[(i, c)] * u[c]).sum::<f64>();
        }
        Ok(())
    }

    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        let (n, m) = (self.a.nrows(), self.b.ncols());
        for i in 0..n {
            for c in 0..n {
                fx[i * n + c] = self.a[(i, c)] != 0.0;
            }
            for c in 0..m {
                fu[i * m + c] = self.b[(i, c)] != 0.0;
            }
        }
    }

    /// The model is linear: zero.
    fn weighted_hessian(&self, _x: &[f64], _u: &[f64], _w: &[f64], hess: &mut [f64]) -> ModelResult<bool> {
        hess.fill(0.0);
        Ok(true)
    }

    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        let (n, m) = (x.len(), u.len());
        for i in 0..n {
            for c in 0..n {
                fx[i * n + c] = self.a[(i, c)];
            }
            for c in 0..m {
                fu[i * m + c] = self.b[(i, c)];
            }
        }
        Ok(true)
    }
}
