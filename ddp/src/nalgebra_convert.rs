//! Conversions between nalgebra's `DVector` / `DMatrix` and the crate's
//! vectors (`&[f64]`, `Vec<f64>`) and matrices (faer's `Mat<f64>`), for
//! callers whose state-sized algebra is in nalgebra (feature `nalgebra`).
//!
//! The crate computes in row-major slices and faer; these copies happen
//! once at the boundary (building a problem, reading a result), never in
//! the solver's loops. A `DVector` is already a slice
//! (`x0.as_slice()` for [`DdpProblem::new`](crate::DdpProblem::new)).
//!
//! ```
//! use ddp::nalgebra_convert::{dmatrix, dvectors};
//! use ddp::{Ddp, DdpProblem, DdpSettings, LinearDynamics, QuadraticCost};
//! use nalgebra::{DMatrix, DVector};
//!
//! let a = DMatrix::from_row_slice(2, 2, &[1.0, 0.1, 0.0, 1.0]);
//! let b = DMatrix::from_row_slice(2, 1, &[0.005, 0.1]);
//! let q = DMatrix::<f64>::identity(2, 2);
//! let r = DMatrix::from_element(1, 1, 0.1);
//! let x0 = DVector::from_vec(vec![1.0, 0.0]);
//! let problem = DdpProblem::new(
//!     LinearDynamics::from_nalgebra(&a, &b)?,
//!     QuadraticCost::from_nalgebra(&q, &r, &q)?,
//!     x0.as_slice(),
//!     30,
//! )?;
//! let result = Ddp::new(DdpSettings::default())?.solve(&problem)?;
//! let gains: Vec<DMatrix<f64>> = result.gains.iter().map(dmatrix).collect();
//! assert_eq!(gains[0].shape(), (1, 2));
//! let states: Vec<DVector<f64>> = dvectors(&result.states);
//! assert_eq!(states.len(), 31);
//! # Ok::<(), ddp::DdpError>(())
//! ```

use faer::Mat;
use nalgebra::{DMatrix, DVector};

use crate::error::Result;
use crate::models::{LinearDynamics, QuadraticCost};

/// A faer matrix as a nalgebra `DMatrix` (same shape and entries).
pub fn dmatrix(a: &Mat<f64>) -> DMatrix<f64> {
    DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)])
}

/// A nalgebra `DMatrix` as a faer matrix (same shape and entries).
pub fn faer_mat(a: &DMatrix<f64>) -> Mat<f64> {
    Mat::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)])
}

/// A slice as a nalgebra `DVector`.
pub fn dvector(x: &[f64]) -> DVector<f64> {
    DVector::from_column_slice(x)
}

/// A sequence of vectors (states, controls, value gradients of a
/// [`DdpResult`](crate::DdpResult)) as `DVector`s.
pub fn dvectors(xs: &[Vec<f64>]) -> Vec<DVector<f64>> {
    xs.iter().map(|x| dvector(x)).collect()
}

impl LinearDynamics {
    /// [`LinearDynamics::new`] from nalgebra's $A$ ($n \times n$) and $B$
    /// ($n \times m$).
    ///
    /// # Errors
    /// As [`LinearDynamics::new`].
    pub fn from_nalgebra(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Result<Self> {
        Self::new(&faer_mat(a), &faer_mat(b))
    }
}

impl QuadraticCost {
    /// [`QuadraticCost::new`] from nalgebra's $Q$, $R$, $Q_f$.
    ///
    /// # Errors
    /// As [`QuadraticCost::new`].
    pub fn from_nalgebra(q: &DMatrix<f64>, r: &DMatrix<f64>, qf: &DMatrix<f64>) -> Result<Self> {
        Self::new(&faer_mat(q), &faer_mat(r), &faer_mat(qf))
    }
}

#[cfg(all(test, feature = "proptest"))]
mod tests {
    use super::*;
    use crate::strategies::lq_problem;
    use crate::{Ddp, DdpProblem, DdpSettings};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]

        /// A problem built from nalgebra matrices solves to the same plan as
        /// the one built from faer's, and the conversions round-trip.
        #[test]
        fn nalgebra_problem_equals_faer_problem(lq in lq_problem(3, 2, 10)) {
            let (a, b) = (dmatrix(&lq.a), dmatrix(&lq.b));
            prop_assert_eq!(faer_mat(&a), lq.a.clone());
            prop_assert_eq!(a.shape(), (lq.a.nrows(), lq.a.ncols()));
            let half = |w: &Mat<f64>| dmatrix(w) * 0.5;
            let from_na = DdpProblem::new(
                LinearDynamics::from_nalgebra(&a, &b).expect("valid"),
                QuadraticCost::from_nalgebra(&half(&lq.q), &half(&lq.r), &half(&lq.qf)).expect("valid"),
                dvector(&lq.x0).as_slice(),
                lq.horizon,
            )
            .expect("problem");
            let solver = Ddp::new(DdpSettings::default()).expect("settings");
            let r1 = solver.solve(&from_na).expect("solve");
            let r2 = solver.solve(&lq.to_ddp_problem()).expect("solve");
            prop_assert_eq!(r1.cost, r2.cost);
            prop_assert_eq!(&r1.controls, &r2.controls);
            for (g1, g2) in r1.gains.iter().zip(&r2.gains) {
                let g = dmatrix(g1);
                prop_assert_eq!(g.shape(), (g2.nrows(), g2.ncols()));
                prop_assert_eq!(faer_mat(&g), g2.clone());
            }
            let xs = dvectors(&r1.states);
            prop_assert_eq!(xs.len(), lq.horizon + 1);
            prop_assert_eq!(xs[0].as_slice(), lq.x0.as_slice());
        }
    }
}
