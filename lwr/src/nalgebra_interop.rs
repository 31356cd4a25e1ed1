//! Conversions from and to nalgebra's dynamic matrices (feature `nalgebra`):
//! a [`Database`] or an [`LwrModel`] from an $n \times d$ input matrix and an
//! $n \times o$ output matrix (one point per row), queries as [`DVector`]s,
//! and the query Jacobian as a [`DMatrix`].
//!
//! nalgebra stores matrices column by column and this crate row by row (one
//! point after another), so building from matrices copies the data once;
//! queries are read in place.

use ::nalgebra::{DMatrix, DVector};

use crate::database::Database;
use crate::error::{LwrError, Result};
use crate::model::{LwrModel, Prediction};
use crate::settings::LwrSettings;

/// The rows of `m`, one after another.
fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
    m.transpose().as_slice().to_vec()
}

impl Database {
    /// A database of the rows of `inputs` ($n \times d$) and `outputs`
    /// ($n \times o$), one point per row, with the tree built in one go.
    ///
    /// ```
    /// use nalgebra::DMatrix;
    /// // y = x0 + 2 x1 at three points
    /// let x = DMatrix::from_row_slice(3, 2, &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
    /// let y = DMatrix::from_row_slice(3, 1, &[0.0, 1.0, 2.0]);
    /// let db = lwr::Database::from_matrices(&x, &y)?;
    /// assert_eq!(db.input(2), Some(&[0.0, 1.0][..]));
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    ///
    /// # Errors
    /// [`LwrError::DimensionMismatch`] if the row counts differ or a matrix
    /// has no column, [`LwrError::NotFinite`] for a non-finite entry.
    pub fn from_matrices(inputs: &DMatrix<f64>, outputs: &DMatrix<f64>) -> Result<Self> {
        if outputs.nrows() != inputs.nrows() {
            return Err(LwrError::DimensionMismatch {
                what: "output rows (one per input row)",
                expected: inputs.nrows(),
                actual: outputs.nrows(),
            });
        }
        Self::from_flat(inputs.ncols(), outputs.ncols(), row_major(inputs), row_major(outputs))
    }
}

impl LwrModel {
    /// A model over [`Database::from_matrices`] with `settings`.
    ///
    /// # Errors
    /// As [`Database::from_matrices`] and [`LwrModel::from_database`].
    pub fn from_matrices(inputs: &DMatrix<f64>, outputs: &DMatrix<f64>, settings: LwrSettings) -> Result<Self> {
        Self::from_database(Database::from_matrices(inputs, outputs)?, settings)
    }

    /// [`predict_mean`](Self::predict_mean) at a [`DVector`] query.
    ///
    /// # Errors
    /// As [`predict_mean`](Self::predict_mean).
    pub fn predict_mean_dvector(&self, q: &DVector<f64>) -> Result<DVector<f64>> {
        Ok(DVector::from_vec(self.predict_mean(q.as_slice())?))
    }

    /// [`predict_with_jacobian`](Self::predict_with_jacobian) at a
    /// [`DVector`] query, with the Jacobian
    /// $\partial \hat y / \partial q$ as an $o \times d$ [`DMatrix`].
    ///
    /// ```
    /// use nalgebra::{DMatrix, DVector};
    /// use lwr::{LwrModel, LwrSettings};
    /// // y = x0 + 2 x1 on a grid: a local linear fit is exact
    /// let mut x = Vec::new();
    /// let mut y = Vec::new();
    /// for i in 0..8 {
    ///     for j in 0..8 {
    ///         let (a, b) = (i as f64 / 7.0, j as f64 / 7.0);
    ///         x.extend([a, b]);
    ///         y.push(a + 2.0 * b);
    ///     }
    /// }
    /// let x = DMatrix::from_row_slice(64, 2, &x);
    /// let y = DMatrix::from_row_slice(64, 1, &y);
    /// let settings = LwrSettings { bandwidth: 0.3, ..Default::default() };
    /// let m = LwrModel::from_matrices(&x, &y, settings)?;
    /// let (p, jac) = m.predict_with_jacobian_dmatrix(&DVector::from_vec(vec![0.4, 0.5]))?;
    /// assert!((p.mean[0] - 1.4).abs() < 1e-10);
    /// assert_eq!(jac.shape(), (1, 2));
    /// assert!((jac[(0, 0)] - 1.0).abs() < 1e-8 && (jac[(0, 1)] - 2.0).abs() < 1e-8);
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    ///
    /// # Errors
    /// As [`predict_with_jacobian`](Self::predict_with_jacobian).
    pub fn predict_with_jacobian_dmatrix(&self, q: &DVector<f64>) -> Result<(Prediction, DMatrix<f64>)> {
        let (p, jac) = self.predict_with_jacobian(q.as_slice())?;
        let jac = DMatrix::from_fn(jac.nrows(), jac.ncols(), |o, j| jac[(o, j)]);
        Ok((p, jac))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data() -> (DMatrix<f64>, DMatrix<f64>) {
        let mut rand = crate::strategies::uniform(11u64);
        let x = DMatrix::from_fn(120, 3, |_, _| rand());
        let y = DMatrix::from_fn(120, 2, |i, o| {
            let r = x.row(i);
            if o == 0 {
                (2.0 * r[0]).sin() + r[1] * r[2]
            } else {
                r[0] - r[2]
            }
        });
        (x, y)
    }

    #[test]
    fn matrices_give_the_model_of_the_same_rows() {
        let (x, y) = data();
        let settings = LwrSettings {
            bandwidth: 0.5,
            ..Default::default()
        };
        let from = LwrModel::from_matrices(&x, &y, settings.clone()).expect("valid");
        let mut rows = LwrModel::new(3, 2, settings).expect("valid");
        for i in 0..x.nrows() {
            let xi: Vec<f64> = x.row(i).iter().copied().collect();
            let yi: Vec<f64> = y.row(i).iter().copied().collect();
            rows.insert(&xi, &yi).expect("finite");
        }
        assert_eq!(from.database().inputs(), rows.database().inputs());
        assert_eq!(from.database().outputs(), rows.database().outputs());
        let q = DVector::from_vec(vec![0.1, -0.2, 0.3]);
        let (p, jac) = from.predict_with_jacobian_dmatrix(&q).expect("weighted");
        let (want, want_jac) = rows.predict_with_jacobian(q.as_slice()).expect("weighted");
        assert_eq!(p.mean, want.mean);
        assert_eq!(jac.shape(), (2, 3));
        for o in 0..2 {
            for j in 0..3 {
                assert_eq!(jac[(o, j)], want_jac[(o, j)], "({o}, {j})");
            }
        }
        // the second output is linear: its Jacobian row is exact
        assert!((jac[(1, 0)] - 1.0).abs() < 1e-8 && jac[(1, 1)].abs() < 1e-8 && (jac[(1, 2)] + 1.0).abs() < 1e-8);
        assert_eq!(
            from.predict_mean_dvector(&q).expect("weighted").as_slice(),
            want.mean.as_slice()
        );
    }

    #[test]
    fn mismatched_or_non_finite_matrices_are_errors() {
        let (x, y) = data();
        let short = y.rows(0, 100).into_owned();
        assert!(matches!(
            Database::from_matrices(&x, &short),
            Err(LwrError::DimensionMismatch {
                expected: 120,
                actual: 100,
                ..
            })
        ));
        let mut bad = x.clone();
        bad[(5, 1)] = f64::NAN;
        assert!(matches!(
            Database::from_matrices(&bad, &y),
            Err(LwrError::NotFinite { .. })
        ));
        let m = LwrModel::from_matrices(&x, &y, LwrSettings::default()).expect("valid");
        let wrong = DVector::from_vec(vec![0.0, 0.0]);
        assert!(matches!(
            m.predict_with_jacobian_dmatrix(&wrong),
            Err(LwrError::DimensionMismatch { .. })
        ));
    }
}
