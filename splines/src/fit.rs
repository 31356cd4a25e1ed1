//! Least-squares fits of basis coefficients to samples, and multi-channel
//! trajectories sharing one basis.
//!
//! A fit minimises
//! $$\sum_k w_k \lVert \Phi_{k\cdot} C - Y_{k\cdot} \rVert^2 + \rho \lVert D_r C \rVert_F^2$$
//! over the coefficient matrix $C$ (one column per channel), with $\Phi$ the
//! design matrix at the sample times, $w_k \ge 0$ sample weights, $\rho \ge 0$
//! the ridge weight and $D_r$ the $r$-th order difference operator on
//! coefficients ($r = 0$: plain ridge; $r = 2$: the P-spline smoothness
//! penalty of Eilers and Marx, 1996). The normal equations
//! $(\Phi^\top W \Phi + \rho D_r^\top D_r) C = \Phi^\top W Y$ are sparse
//! (banded for B-splines) and solved by faer's sparse Cholesky $LL^\top$,
//! one factorisation for all channels. This is the paper's Eqs. 6-7:
//! initialising a plan by fitting the demonstration.
//!
//! A basis function that no weighted sample touches makes the fit
//! singular; without ridge this is reported as [`SplineError::SingularFit`]
//! naming the coefficient, never answered with an arbitrary number.

use faer::prelude::*;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, MatRef, Side};

use crate::basis::TrajectoryBasis;
use crate::error::{Result, SplineError, check_finite, check_len};

/// Settings of a least-squares fit.
///
/// | field | default | range |
/// |---|---|---|
/// | `weights` | `None` (all 1) | one finite $w_k \ge 0$ per sample |
/// | `ridge` | 0 | finite, $\ge 0$ |
/// | `penalty_order` | 0 | $r <$ number of coefficients |
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FitSettings {
    /// Per-sample weights $w_k$ (`None`: all one).
    pub weights: Option<Vec<f64>>,
    /// Ridge weight $\rho$ on the penalty $\lVert D_r c \rVert^2$.
    pub ridge: f64,
    /// Order $r$ of the coefficient differences penalised by the ridge.
    pub penalty_order: usize,
}

impl FitSettings {
    /// Checks the settings against the number of samples and coefficients.
    pub fn validate(&self, n_samples: usize, n_coeffs: usize) -> Result<()> {
        if !(self.ridge.is_finite() && self.ridge >= 0.0) {
            return Err(SplineError::InvalidParameter {
                name: "ridge",
                reason: format!("must be finite and nonnegative, got {}", self.ridge),
            });
        }
        if self.penalty_order >= n_coeffs.max(1) {
            return Err(SplineError::InvalidParameter {
                name: "penalty_order",
                reason: format!(
                    "must be below the number of coefficients {n_coeffs}, got {}",
                    self.penalty_order
                ),
            });
        }
        if let Some(w) = &self.weights {
            check_len("weights", n_samples, w.len())?;
            check_finite("weights", w)?;
            if let Some(index) = w.iter().position(|&v| v < 0.0) {
                return Err(SplineError::InvalidParameter {
                    name: "weights",
                    reason: format!("weights[{index}] = {} is negative", w[index]),
                });
            }
        }
        Ok(())
    }
}

/// Fits one channel: the coefficients $c$ minimising the weighted,
/// penalised squared error to `values` sampled at `times`.
///
/// ```
/// use splines::{BSplineBasis, FitSettings, TrajectoryBasis, fit_channel};
/// let basis = BSplineBasis::clamped_uniform(8, 3, 0.0, 1.0)?;
/// let times: Vec<f64> = (0..50).map(|k| k as f64 / 49.0).collect();
/// let values: Vec<f64> = times.iter().map(|t| t * t).collect(); // in the spline space
/// let c = fit_channel(&basis, &times, &values, &FitSettings::default())?;
/// let y = basis.evaluate(&c, &[0.5], 0)?;
/// assert!((y[0] - 0.25).abs() < 1e-12);
/// # Ok::<(), splines::SplineError>(())
/// ```
pub fn fit_channel<B: TrajectoryBasis + ?Sized>(
    basis: &B,
    times: &[f64],
    values: &[f64],
    settings: &FitSettings,
) -> Result<Vec<f64>> {
    check_len("values", times.len(), values.len())?;
    let y = MatRef::from_column_major_slice(values, values.len(), 1);
    let c = fit_matrix(basis, times, y, settings)?;
    Ok(c.col(0).iter().copied().collect())
}

/// Fits every channel (column of `samples`, one row per time) at once:
/// returns the coefficient matrix $C$, `n_coeffs` rows by `samples.ncols()`.
pub fn fit_matrix<B: TrajectoryBasis + ?Sized>(
    basis: &B,
    times: &[f64],
    samples: MatRef<'_, f64>,
    settings: &FitSettings,
) -> Result<Mat<f64>> {
    if times.is_empty() {
        return Err(SplineError::Empty { what: "times" });
    }
    check_len("sample rows", times.len(), samples.nrows())?;
    for j in 0..samples.ncols() {
        if let Some((index, &value)) = samples.col(j).iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(SplineError::NotFinite {
                what: "samples",
                index,
                value,
            });
        }
    }
    let n = basis.n_coeffs();
    settings.validate(times.len(), n)?;
    let phi = basis.design_matrix_rows(times, 0)?;
    let weight = |k: usize| settings.weights.as_ref().map_or(1.0, |w| w[k]);

    // normal equations, lower triangle, and right-hand side
    let mut triplets = Vec::with_capacity(times.len() * basis.max_nonzeros() * (basis.max_nonzeros() + 1) / 2 + n);
    let mut diag = vec![0.0; n];
    let mut rhs = Mat::<f64>::zeros(n, samples.ncols());
    for k in 0..times.len() {
        let w = weight(k);
        if w == 0.0 {
            continue;
        }
        let cols = phi.symbolic().col_idx_of_row_raw(k);
        let vals = phi.val_of_row(k);
        for (a, (&ja, &va)) in cols.iter().zip(vals).enumerate() {
            diag[ja] += w * va * va;
            for (&jb, &vb) in cols[..=a].iter().zip(vals) {
                let (r, c) = if ja >= jb { (ja, jb) } else { (jb, ja) };
                triplets.push(Triplet::new(r, c, w * va * vb));
            }
            for ch in 0..samples.ncols() {
                rhs[(ja, ch)] += w * va * samples[(k, ch)];
            }
        }
    }
    if settings.ridge > 0.0 {
        push_difference_penalty(&mut triplets, n, settings.penalty_order, settings.ridge);
    } else if let Some(j) = diag.iter().position(|&d| d == 0.0) {
        return Err(SplineError::SingularFit {
            reason: format!("no weighted sample touches basis function {j}"),
        });
    }
    let a =
        SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &triplets).map_err(|e| SplineError::SingularFit {
            reason: format!("could not assemble the normal equations: {e:?}"),
        })?;
    let llt = a.sp_cholesky(Side::Lower).map_err(|e| SplineError::SingularFit {
        reason: format!("Cholesky factorisation failed: {e:?}"),
    })?;
    let c = llt.solve(&rhs);
    if let Some(v) = c.col_iter().flat_map(|col| col.iter()).find(|v| !v.is_finite()) {
        return Err(SplineError::SingularFit {
            reason: format!("the solution is not finite ({v})"),
        });
    }
    Ok(c)
}

/// Adds $\rho D_r^\top D_r$ (lower triangle) to the triplets.
fn push_difference_penalty(triplets: &mut Vec<Triplet<usize, usize, f64>>, n: usize, r: usize, rho: f64) {
    // row i of D_r: binomial coefficients (-1)^(r-m) C(r, m) at columns i..=i+r
    let mut stencil = vec![1.0];
    for _ in 0..r {
        let mut next = vec![0.0; stencil.len() + 1];
        for (m, &s) in stencil.iter().enumerate() {
            next[m] -= s;
            next[m + 1] += s;
        }
        stencil = next;
    }
    for i in 0..n - r {
        for (a, &sa) in stencil.iter().enumerate() {
            for (b, &sb) in stencil[..=a].iter().enumerate() {
                triplets.push(Triplet::new(i + a, i + b, rho * sa * sb));
            }
        }
    }
}

/// A multi-channel trajectory $Y(t) = \Phi(t) C$: one basis, shared by all
/// channels, and a coefficient matrix $C$ (`n_coeffs` rows, one column per
/// channel).
///
/// `B` may be a basis, a reference `&B` or an `Arc<B>`, so several
/// trajectories can share one basis without copying it.
///
/// ```
/// use std::sync::Arc;
/// use splines::{BSplineBasis, Trajectory};
/// let basis = Arc::new(BSplineBasis::clamped_uniform(5, 3, 0.0, 2.0)?);
/// let x = Trajectory::zeros(basis.clone(), 4); // 4 state channels
/// let u = Trajectory::zeros(basis, 1); // 1 control channel, same basis
/// assert_eq!(x.evaluate(&[0.0, 1.0], 0)?.ncols(), 4);
/// assert_eq!(u.n_channels(), 1);
/// # Ok::<(), splines::SplineError>(())
/// ```
#[derive(Debug, Clone)]
pub struct Trajectory<B> {
    basis: B,
    coeffs: Mat<f64>,
}

impl<B: TrajectoryBasis> Trajectory<B> {
    /// A trajectory from its basis and coefficient matrix.
    pub fn new(basis: B, coeffs: Mat<f64>) -> Result<Self> {
        check_len("coefficient rows", basis.n_coeffs(), coeffs.nrows())?;
        Ok(Self { basis, coeffs })
    }

    /// The zero trajectory with `n_channels` channels.
    pub fn zeros(basis: B, n_channels: usize) -> Self {
        let coeffs = Mat::zeros(basis.n_coeffs(), n_channels);
        Self { basis, coeffs }
    }

    /// Least-squares fit of every channel of `samples` (rows = times), see
    /// [`fit_matrix`].
    pub fn fit(basis: B, times: &[f64], samples: MatRef<'_, f64>, settings: &FitSettings) -> Result<Self> {
        let coeffs = fit_matrix(&basis, times, samples, settings)?;
        Ok(Self { basis, coeffs })
    }

    /// The shared basis.
    pub fn basis(&self) -> &B {
        &self.basis
    }

    /// The coefficient matrix $C$.
    pub fn coeffs(&self) -> MatRef<'_, f64> {
        self.coeffs.as_ref()
    }

    /// The coefficient matrix, mutable (an optimiser's parameters).
    pub fn coeffs_mut(&mut self) -> faer::MatMut<'_, f64> {
        self.coeffs.as_mut()
    }

    /// Number of channels (columns of $C$).
    pub fn n_channels(&self) -> usize {
        self.coeffs.ncols()
    }

    /// The `order`-th time derivative of every channel at every time: a
    /// matrix with one row per time and one column per channel.
    pub fn evaluate(&self, times: &[f64], order: usize) -> Result<Mat<f64>> {
        check_finite("times", times)?;
        let mut out = Mat::zeros(times.len(), self.n_channels());
        let mut row = Vec::with_capacity(self.basis.max_nonzeros());
        for (k, &t) in times.iter().enumerate() {
            self.basis.basis_row(t, order, &mut row)?;
            for ch in 0..self.n_channels() {
                out[(k, ch)] = row.iter().map(|&(j, v)| v * self.coeffs[(j, ch)]).sum();
            }
        }
        Ok(out)
    }
}

impl<B: std::borrow::Borrow<crate::BSplineBasis>> Trajectory<B> {
    /// Inserts the knot `t` in the B-spline basis (Boehm's algorithm): the
    /// returned trajectory has one more coefficient per channel and the same
    /// values everywhere.
    pub fn insert_knot(&self, t: f64) -> Result<Trajectory<crate::BSplineBasis>> {
        let channels: Vec<Vec<f64>> = (0..self.coeffs.ncols())
            .map(|j| self.coeffs.col(j).iter().copied().collect())
            .collect();
        let refs: Vec<&[f64]> = channels.iter().map(Vec::as_slice).collect();
        let (basis, new) = self.basis.borrow().insert_knot_multi(t, &refs)?;
        let coeffs = Mat::from_fn(basis.knots().len() - basis.degree() - 1, new.len(), |i, j| new[j][i]);
        Ok(Trajectory { basis, coeffs })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BSplineBasis;

    #[test]
    fn singular_fit_is_reported() {
        let basis = BSplineBasis::clamped_uniform(10, 3, 0.0, 1.0).expect("valid");
        // all samples in the first half: the last basis functions are untouched
        let times: Vec<f64> = (0..20).map(|k| 0.4 * k as f64 / 19.0).collect();
        let values = vec![1.0; 20];
        let err = fit_channel(&basis, &times, &values, &FitSettings::default());
        assert!(matches!(err, Err(SplineError::SingularFit { .. })), "{err:?}");
        // with ridge smoothing the fit exists and still matches the data
        let settings = FitSettings {
            ridge: 1e-8,
            penalty_order: 2,
            ..FitSettings::default()
        };
        let c = fit_channel(&basis, &times, &values, &settings).expect("regularised fit");
        let y = basis.evaluate(&c, &times, 0).expect("inside");
        assert!(y.iter().all(|v| (v - 1.0).abs() < 1e-6));
    }

    #[test]
    fn ridge_order_two_leaves_lines_alone() {
        // on uniform knots a line has equally spaced coefficients (the Greville
        // abscissae are uniform), so a second-difference penalty leaves it alone
        // and an exact line is reproduced whatever the ridge weight
        let basis = BSplineBasis::uniform(12, 3, 0.0, 1.0).expect("valid");
        let times: Vec<f64> = (0..40).map(|k| k as f64 / 39.0).collect();
        let values: Vec<f64> = times.iter().map(|t| 3.0 * t - 1.0).collect();
        let settings = FitSettings {
            ridge: 1e6,
            penalty_order: 2,
            ..FitSettings::default()
        };
        let c = fit_channel(&basis, &times, &values, &settings).expect("fit");
        let y = basis.evaluate(&c, &times, 0).expect("inside");
        for (a, b) in y.iter().zip(&values) {
            assert!((a - b).abs() < 1e-8, "{a} vs {b}");
        }
        // while plain ridge shrinks it
        let shrunk = fit_channel(
            &basis,
            &times,
            &values,
            &FitSettings {
                ridge: 1e6,
                penalty_order: 0,
                ..FitSettings::default()
            },
        )
        .expect("fit");
        assert!(shrunk.iter().all(|v| v.abs() < 1e-2));
    }

    #[test]
    fn rejects_bad_input() {
        let basis = BSplineBasis::clamped_uniform(6, 3, 0.0, 1.0).expect("valid");
        let t = [0.0, 0.5, 1.0];
        let bad = |v: &[f64], s: &FitSettings| fit_channel(&basis, &t, v, s);
        assert!(matches!(
            bad(&[1.0, 2.0], &FitSettings::default()),
            Err(SplineError::LengthMismatch { .. })
        ));
        assert!(matches!(
            bad(&[1.0, f64::NAN, 2.0], &FitSettings::default()),
            Err(SplineError::NotFinite { .. })
        ));
        let neg = FitSettings {
            ridge: -1.0,
            ..FitSettings::default()
        };
        assert!(matches!(
            bad(&[1.0; 3], &neg),
            Err(SplineError::InvalidParameter { .. })
        ));
        assert!(matches!(
            fit_channel(&basis, &[], &[], &FitSettings::default()),
            Err(SplineError::Empty { .. })
        ));
    }
}
