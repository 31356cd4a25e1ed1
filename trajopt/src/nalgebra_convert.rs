//! Conversions between nalgebra's `DMatrix` / `DVector` and the crate's
//! matrices (faer's `Mat<f64>`) and vectors (`&[f64]`), for callers whose
//! algebra is in nalgebra (feature `nalgebra`).
//!
//! The solvers compute on slices and faer; these copies happen once at the
//! boundary (building a model or a cost, reading a trajectory), never in a
//! solver's loop. A `DVector` is already a slice (`theta.as_slice()` for
//! [`GaussNewton::solve`](crate::GaussNewton::solve)).
//!
//! ```
//! use nalgebra::DMatrix;
//! use trajopt::nalgebra_convert::dmatrix;
//! use trajopt::{GaussNewton, GaussNewtonSettings, problems};
//!
//! let (problem, theta0) = problems::pendulum_swingup(60, 1e3)?;
//! let result = GaussNewton::new(GaussNewtonSettings::default())?.solve(&problem, &theta0)?;
//! let (states, controls) = problem.trajectory(&result.x)?;
//! let states: DMatrix<f64> = dmatrix(&states); // one row per time step
//! assert_eq!(states.shape(), (61, 4));
//! assert_eq!(dmatrix(&controls).shape(), (60, 1));
//! # Ok::<(), trajopt::TrajoptError>(())
//! ```

use faer::Mat;
use nalgebra::{DMatrix, DVector};

use crate::eq3::TrackingCost;
use crate::error::Result;
use crate::models::LinearModel;

/// A faer matrix as a nalgebra `DMatrix` (same shape and entries).
pub fn dmatrix(a: &Mat<f64>) -> DMatrix<f64> {
    DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)])
}

/// A nalgebra `DMatrix` as a faer matrix (same shape and entries).
pub fn faer_mat(a: &DMatrix<f64>) -> Mat<f64> {
    Mat::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)])
}

/// A slice (a parameter vector, a state) as a nalgebra `DVector`.
pub fn dvector(x: &[f64]) -> DVector<f64> {
    DVector::from_column_slice(x)
}

impl LinearModel {
    /// [`LinearModel::new`] from nalgebra's $A$ ($n \times n$) and $B$
    /// ($n \times m$).
    ///
    /// # Errors
    /// As [`LinearModel::new`].
    pub fn from_nalgebra(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Result<Self> {
        Self::new(faer_mat(a), faer_mat(b))
    }
}

impl TrackingCost {
    /// [`TrackingCost::new`] from nalgebra references: `state_ref` is
    /// $(N+1) \times n$, `control_ref` is $N \times m$ (one row per step).
    ///
    /// # Errors
    /// As [`TrackingCost::new`].
    pub fn from_nalgebra(
        state_ref: &DMatrix<f64>,
        control_ref: &DMatrix<f64>,
        q: &[f64],
        r: &[f64],
        q_final: &[f64],
    ) -> Result<Self> {
        Self::new(faer_mat(state_ref), faer_mat(control_ref), q, r, q_final)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eq3::{Dynamics, StageCost};

    #[test]
    fn conversions_round_trip_and_keep_row_major_meaning() {
        let a = DMatrix::from_row_slice(2, 3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let f = faer_mat(&a);
        assert_eq!((f.nrows(), f.ncols()), (2, 3));
        assert_eq!(f[(0, 2)], 3.0);
        assert_eq!(f[(1, 0)], 4.0);
        assert_eq!(dmatrix(&f), a);
        assert_eq!(dvector(&[1.0, 2.0]).as_slice(), &[1.0, 2.0]);
    }

    #[test]
    fn models_and_costs_from_nalgebra_equal_those_from_faer() -> Result<()> {
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 0.1, -0.2, 0.9]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 0.1]);
        let ours = LinearModel::from_nalgebra(&a, &b)?;
        let theirs = LinearModel::new(faer_mat(&a), faer_mat(&b))?;
        let (x, u) = ([0.3, -1.0], [2.0]);
        let (mut y1, mut y2) = ([0.0; 2], [0.0; 2]);
        ours.step(&x, &u, &mut y1)?;
        theirs.step(&x, &u, &mut y2)?;
        assert_eq!(y1, y2);
        // x+ = A x + B u, computed by hand from the row-major entries
        assert!((y1[0] - (0.3 - 0.1)).abs() < 1e-15);
        assert!((y1[1] - (-0.06 - 0.9 + 0.2)).abs() < 1e-15);

        let xr = DMatrix::from_row_slice(3, 2, &[0.0, 0.0, 1.0, 0.0, 2.0, 0.0]);
        let ur = DMatrix::zeros(2, 1);
        let cost = TrackingCost::from_nalgebra(&xr, &ur, &[1.0, 1.0], &[0.5], &[10.0, 10.0])?;
        // at step 1 the reference is (1, 0): the state (1, 0) costs nothing
        let mut r = vec![0.0; cost.n_residuals()];
        cost.residuals(1, &[1.0, 0.0], Some(&[0.0]), &mut r)?;
        assert!(r.iter().all(|&v| v == 0.0));
        // and the state (2, 0) costs sqrt(q) * 1 in the first residual
        cost.residuals(1, &[2.0, 0.0], Some(&[0.0]), &mut r)?;
        assert!((r[0] - 1.0).abs() < 1e-15);
        Ok(())
    }
}
