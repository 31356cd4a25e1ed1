//! Trajectories from and to nalgebra matrices (feature `nalgebra`), for
//! callers whose samples and coefficients live in nalgebra's `DMatrix`
//! (rows = sample times or coefficients, columns = channels, as in
//! [`Trajectory`]).
//!
//! The crate computes in faer; these copies happen once at the boundary
//! (fitting a demonstration, reading a plan), never in a basis evaluation.
//!
//! ```
//! use nalgebra::DMatrix;
//! use splines::{BSplineBasis, FitSettings, Trajectory};
//!
//! let basis = BSplineBasis::clamped_uniform(6, 3, 0.0, 1.0)?;
//! let times: Vec<f64> = (0..40).map(|k| k as f64 / 39.0).collect();
//! // two channels, a line and a parabola: cubic B-splines reproduce both
//! let samples = DMatrix::from_fn(40, 2, |k, c| if c == 0 { times[k] } else { times[k] * times[k] });
//! let fit = Trajectory::fit_nalgebra(basis, &times, &samples, &FitSettings::default())?;
//! let values: DMatrix<f64> = fit.evaluate_nalgebra(&[0.5], 0)?;
//! assert!((values[(0, 1)] - 0.25).abs() < 1e-10);
//! assert_eq!(fit.coeffs_nalgebra().shape(), (6, 2));
//! # Ok::<(), splines::SplineError>(())
//! ```

use faer::Mat;
use nalgebra::DMatrix;

use crate::basis::TrajectoryBasis;
use crate::error::Result;
use crate::fit::{FitSettings, Trajectory};

fn to_faer(a: &DMatrix<f64>) -> Mat<f64> {
    Mat::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)])
}

fn to_nalgebra(a: faer::MatRef<'_, f64>) -> DMatrix<f64> {
    DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)])
}

impl<B: TrajectoryBasis> Trajectory<B> {
    /// [`Trajectory::new`] with the coefficient matrix as a `DMatrix`.
    ///
    /// # Errors
    /// As [`Trajectory::new`].
    pub fn from_nalgebra(basis: B, coeffs: &DMatrix<f64>) -> Result<Self> {
        Self::new(basis, to_faer(coeffs))
    }

    /// [`Trajectory::fit`] of samples given as a `DMatrix` (rows = times).
    ///
    /// # Errors
    /// As [`Trajectory::fit`].
    pub fn fit_nalgebra(basis: B, times: &[f64], samples: &DMatrix<f64>, settings: &FitSettings) -> Result<Self> {
        Self::fit(basis, times, to_faer(samples).as_ref(), settings)
    }

    /// The coefficient matrix as a `DMatrix`.
    pub fn coeffs_nalgebra(&self) -> DMatrix<f64> {
        to_nalgebra(self.coeffs())
    }

    /// [`Trajectory::evaluate`] as a `DMatrix` (rows = times).
    ///
    /// # Errors
    /// As [`Trajectory::evaluate`].
    pub fn evaluate_nalgebra(&self, times: &[f64], order: usize) -> Result<DMatrix<f64>> {
        Ok(to_nalgebra(self.evaluate(times, order)?.as_ref()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BSplineBasis;

    /// The nalgebra paths give exactly what the faer ones give, and a
    /// coefficient matrix of the wrong height is an error.
    #[test]
    fn nalgebra_paths_equal_the_faer_paths() {
        let basis = BSplineBasis::clamped_uniform(5, 3, 0.0, 2.0).expect("basis");
        let coeffs = DMatrix::from_fn(5, 3, |i, c| (i as f64 * 0.7 + c as f64).sin());
        let ours = Trajectory::from_nalgebra(&basis, &coeffs).expect("trajectory");
        let theirs = Trajectory::new(&basis, to_faer(&coeffs)).expect("trajectory");
        assert_eq!(ours.coeffs_nalgebra(), coeffs);
        let times = [0.0, 0.3, 1.1, 2.0];
        for order in 0..3 {
            let a = ours.evaluate_nalgebra(&times, order).expect("evaluate");
            let b = theirs.evaluate(&times, order).expect("evaluate");
            assert_eq!(a, to_nalgebra(b.as_ref()));
        }
        assert!(Trajectory::from_nalgebra(&basis, &DMatrix::zeros(4, 3)).is_err());
    }
}
