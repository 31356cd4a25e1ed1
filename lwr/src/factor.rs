//! The scaled Cholesky factorisation of a local fit's normal matrix, with
//! the regularised fallback.

use crate::error::{LwrError, Result};
use crate::settings::LwrSettings;

/// In-place Cholesky $A = L L^\top$ of a row-major $p \times p$ matrix (lower
/// triangle used and overwritten). Returns the smallest and largest pivots
/// $L_{aa}$, or `None` if a pivot is not positive.
///
/// Hand-written on purpose: at a local fit's sizes ($p$ = 3 to 10) it beats
/// nalgebra's `Cholesky` and faer's `llt` with preallocated buffers
/// (`benches/cholesky.rs`: factor and two solves, 159 ns against 338 and
/// 267 ns at $p = 3$, 1.08 us against 1.54 and 1.62 us at $p = 10$; faer
/// ties at $p = 4$), and the test `cholesky_agrees_with_nalgebra` checks it
/// against nalgebra to $10^{-12}$. Public (hidden, through `lwr::bench`) only
/// so that the bench times this code rather than a copy of it.
pub fn cholesky(a: &mut [f64], p: usize) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for j in 0..p {
        let mut djj = a[j * p + j];
        for k in 0..j {
            djj -= a[j * p + k] * a[j * p + k];
        }
        if !(djj > 0.0 && djj.is_finite()) {
            return None;
        }
        let ljj = djj.sqrt();
        lo = lo.min(ljj);
        hi = hi.max(ljj);
        a[j * p + j] = ljj;
        for i in j + 1..p {
            let mut v = a[i * p + j];
            for k in 0..j {
                v -= a[i * p + k] * a[j * p + k];
            }
            a[i * p + j] = v / ljj;
        }
    }
    Some((lo, hi))
}

/// Solves $L L^\top x = b$ in place, $L$ from [`cholesky`]. Public (hidden,
/// through `lwr::bench`) for the Cholesky bench, as [`cholesky`].
pub fn chol_solve(l: &[f64], p: usize, b: &mut [f64]) {
    for i in 0..p {
        let mut v = b[i];
        for k in 0..i {
            v -= l[i * p + k] * b[k];
        }
        b[i] = v / l[i * p + i];
    }
    for i in (0..p).rev() {
        let mut v = b[i];
        for k in i + 1..p {
            v -= l[k * p + i] * b[k];
        }
        b[i] = v / l[i * p + i];
    }
}

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
