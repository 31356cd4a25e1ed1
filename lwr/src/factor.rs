//! The scaled Cholesky factorisation of a local fit's normal matrix, with
//! the regularised fallback.

use crate::error::{LwrError, Result};
use crate::settings::LwrSettings;

/// The dense Cholesky kernels, shared with `ddp` ([`solve::dense`]: at a
/// local fit's sizes, $p$ = 3 to 10, they beat nalgebra's `Cholesky` and
/// faer's `llt` with preallocated buffers, `benches/cholesky.rs`; the test
/// `cholesky_agrees_with_nalgebra` checks them against nalgebra to
/// $10^{-12}$). Public (hidden, through `lwr::bench`) only so that the bench
/// times this code.
pub use solve::dense::{cholesky, cholesky_solve as chol_solve};

/// A factorised $P = (Z^\top K Z + \Lambda)^{-1}$: $P = D^{-1} (L L^\top)^{-1} D^{-1}$
/// with the diagonal scaling $D$.
#[derive(Debug, Default)]
pub(crate) struct Factor {
    p: usize,
    l: Vec<f64>,
    scale: Vec<f64>,
}

impl Factor {
    /// $x = P b$ in place.
    pub(crate) fn apply(&self, b: &mut [f64]) {
        for (v, s) in b.iter_mut().zip(&self.scale) {
            *v /= s;
        }
        chol_solve(&self.l, self.p, b);
        for (v, s) in b.iter_mut().zip(&self.scale) {
            *v /= s;
        }
    }
}

/// Factorises the normal matrix `a` ($p \times p$, full, symmetric) with
/// diagonal equilibration; adds the fallback ridge to the non-intercept
/// diagonal when the factorisation fails or the condition estimate exceeds
/// the limit. Writes the factor into `factor` (its buffers reused, `scaled`
/// a work buffer) and returns the condition estimate and whether the
/// fallback was used.
pub(crate) fn factorise(
    a: &[f64],
    p: usize,
    settings: &LwrSettings,
    factor: &mut Factor,
    scaled: &mut Vec<f64>,
) -> Result<(f64, bool)> {
    factor.p = p;
    let Factor { l, scale, .. } = factor;
    scale.clear();
    scale.extend((0..p).map(|i| {
        let v = a[i * p + i];
        if v > 0.0 && v.is_finite() { v.sqrt() } else { 1.0 }
    }));
    scaled.clear();
    scaled.resize(p * p, 0.0);
    for i in 0..p {
        for j in 0..p {
            scaled[i * p + j] = a[i * p + j] / (scale[i] * scale[j]);
        }
    }
    l.clear();
    l.extend_from_slice(scaled);
    let condition = match cholesky(l, p) {
        Some((lo, hi)) => (hi / lo) * (hi / lo),
        None => f64::INFINITY,
    };
    if condition <= settings.max_condition {
        return Ok((condition, false));
    }
    l.copy_from_slice(scaled);
    for i in 1..p {
        l[i * p + i] += settings.fallback_ridge;
    }
    match cholesky(l, p) {
        Some(_) => Ok((condition, true)),
        None => Err(LwrError::SingularFit {
            reason: format!(
                "not positive definite even with the fallback ridge {} (condition estimate {condition:e})",
                settings.fallback_ridge
            ),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_and_reports_pivots() {
        let mut a = vec![4.0, 2.0, 2.0, 3.0];
        let (lo, hi) = cholesky(&mut a, 2).expect("positive definite");
        assert!(lo > 0.0 && hi >= lo);
        let mut b = vec![2.0, 1.0];
        chol_solve(&a, 2, &mut b);
        // [4 2; 2 3] x = [2 1] -> x = [0.5, 0]
        assert!((b[0] - 0.5).abs() < 1e-15 && b[1].abs() < 1e-15);
        let mut singular = vec![1.0, 1.0, 1.0, 1.0];
        assert!(cholesky(&mut singular, 2).is_none());
    }

    /// The hand factorisation and solve equal nalgebra's on the local-fit
    /// sizes, to $10^{-12}$ relative.
    #[test]
    fn cholesky_agrees_with_nalgebra() {
        let mut rand = crate::strategies::uniform(9u64);
        for p in 1..=10 {
            for _ in 0..20 {
                // Z^T K Z + small ridge, as a local fit builds it
                let a = crate::strategies::normal_matrix(p, p + 3, (0.6, 0.4), 1e-3, &mut rand);
                let reference =
                    nalgebra::Cholesky::new(nalgebra::DMatrix::from_row_slice(p, p, &a)).expect("positive definite");
                let mut l = a.clone();
                let (lo, hi) = cholesky(&mut l, p).expect("positive definite");
                let lref = reference.l();
                let scale = lref.amax();
                for r in 0..p {
                    for c in 0..=r {
                        let (got, want) = (l[r * p + c], lref[(r, c)]);
                        assert!((got - want).abs() <= 1e-12 * scale, "p {p}: L[{r},{c}] {got} vs {want}");
                    }
                }
                let diag = lref.diagonal();
                assert!((lo - diag.min()).abs() <= 1e-12 * scale && (hi - diag.max()).abs() <= 1e-12 * scale);
                let b: Vec<f64> = (0..p).map(|_| rand()).collect();
                let mut x = b.clone();
                chol_solve(&l, p, &mut x);
                let xref = reference.solve(&nalgebra::DVector::from_column_slice(&b));
                let xscale = xref.amax();
                for (got, want) in x.iter().zip(xref.iter()) {
                    assert!((got - want).abs() <= 1e-12 * xscale, "p {p}: x {got} vs {want}");
                }
            }
        }
    }
}
