//! The weighted least-squares fit at one query: weights, normal equations,
//! a scaled Cholesky factorisation with a regularised fallback, confidence
//! sums and the exact query Jacobian.

use crate::database::Database;
use crate::error::{LwrError, Result};
use crate::settings::{Degree, LwrSettings};

/// What to compute beyond the coefficients.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Want {
    pub(crate) confidence: bool,
    pub(crate) jacobian: bool,
}

/// Everything a local fit produces; the public [`Prediction`](crate::Prediction)
/// is built from it.
#[derive(Debug, Clone)]
pub(crate) struct LocalFit {
    /// Number of coefficients $p$.
    pub(crate) p: usize,
    /// Coefficients, $p \times o$ row-major.
    pub(crate) beta: Vec<f64>,
    /// $s = P e_0$.
    pub(crate) s: Vec<f64>,
    /// Points with positive weight.
    pub(crate) n_neighbors: usize,
    /// $n_{lwr} = \sum_i k_i$.
    pub(crate) sum_w: f64,
    /// Condition estimate of the scaled normal matrix (before any fallback).
    pub(crate) condition: f64,
    /// Whether the fallback ridge was added.
    pub(crate) regularized: bool,
    /// $p_{lwr} = \sum_i k_i^2 z_i^\top P z_i$ (confidence only).
    pub(crate) p_lwr: f64,
    /// $|l|^2 = \sum_i k_i^2 (z_i^\top P e_0)^2$ (confidence only).
    pub(crate) l_norm2: f64,
    /// $\sum_i k_i r_i^2$ per output (confidence only).
    pub(crate) wrss: Vec<f64>,
    /// Jacobian, $o \times d$ row-major (jacobian only).
    pub(crate) jacobian: Vec<f64>,
}

/// Writes the design row $z$ for input `x` at query `q`.
fn design_row(degree: Degree, x: &[f64], q: &[f64], z: &mut [f64]) {
    z[0] = 1.0;
    if degree == Degree::Constant {
        return;
    }
    let d = q.len();
    for j in 0..d {
        z[1 + j] = x[j] - q[j];
    }
    if degree == Degree::Quadratic {
        let mut t = 1 + d;
        for a in 0..d {
            for b in a..d {
                z[t] = z[1 + a] * z[1 + b];
                t += 1;
            }
        }
    }
}

/// $v^\top \partial z / \partial q_j$ for a row with offsets `delta = x - q`,
/// reading `v` with stride `stride` (coefficient `a` at `v[a * stride]`).
fn dz_dot(degree: Degree, delta: &[f64], j: usize, v: &[f64], stride: usize) -> f64 {
    if degree == Degree::Constant {
        return 0.0;
    }
    let d = delta.len();
    let mut s = -v[(1 + j) * stride];
    if degree == Degree::Quadratic {
        let mut t = 1 + d;
        for a in 0..d {
            for b in a..d {
                let mut g = 0.0;
                if a == j {
                    g -= delta[b];
                }
                if b == j {
                    g -= delta[a];
                }
                s += g * v[t * stride];
                t += 1;
            }
        }
    }
    s
}

/// In-place Cholesky $A = L L^\top$ of a row-major $p \times p$ matrix (lower
/// triangle used and overwritten). Returns the smallest and largest pivots
/// $L_{aa}$, or `None` if a pivot is not positive.
fn cholesky(a: &mut [f64], p: usize) -> Option<(f64, f64)> {
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

/// Solves $L L^\top x = b$ in place.
fn chol_solve(l: &[f64], p: usize, b: &mut [f64]) {
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
struct Factor {
    p: usize,
    l: Vec<f64>,
    scale: Vec<f64>,
}

impl Factor {
    /// $x = P b$ in place.
    fn apply(&self, b: &mut [f64]) {
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
/// the limit. Returns the factor, the condition estimate and whether the
/// fallback was used.
fn factorise(a: &[f64], p: usize, settings: &LwrSettings) -> Result<(Factor, f64, bool)> {
    let scale: Vec<f64> = (0..p)
        .map(|i| {
            let v = a[i * p + i];
            if v > 0.0 && v.is_finite() { v.sqrt() } else { 1.0 }
        })
        .collect();
    let mut scaled = vec![0.0; p * p];
    for i in 0..p {
        for j in 0..p {
            scaled[i * p + j] = a[i * p + j] / (scale[i] * scale[j]);
        }
    }
    let mut l = scaled.clone();
    let condition = match cholesky(&mut l, p) {
        Some((lo, hi)) => (hi / lo) * (hi / lo),
        None => f64::INFINITY,
    };
    if condition <= settings.max_condition {
        return Ok((Factor { p, l, scale }, condition, false));
    }
    l.copy_from_slice(&scaled);
    for i in 1..p {
        l[i * p + i] += settings.fallback_ridge;
    }
    match cholesky(&mut l, p) {
        Some(_) => Ok((Factor { p, l, scale }, condition, true)),
        None => Err(LwrError::SingularFit {
            reason: format!(
                "not positive definite even with the fallback ridge {} (condition estimate {condition:e})",
                settings.fallback_ridge
            ),
        }),
    }
}

/// Fits at `q`. The caller has validated `settings`, `scales` (length $d$)
/// and `q`.
pub(crate) fn local_fit(
    db: &Database,
    settings: &LwrSettings,
    scales: &[f64],
    q: &[f64],
    want: Want,
) -> Result<LocalFit> {
    if db.is_empty() {
        return Err(LwrError::EmptyDatabase);
    }
    let d = db.n_inputs();
    let o = db.n_outputs();
    let degree = settings.degree;
    let p = degree.n_coeffs(d);
    let h = settings.bandwidth;
    let kernel = settings.kernel;
    let radius = settings.support_radius();

    // neighbours and weights, in index order so that the sums do not depend
    // on the tree's shape
    let mut found = Vec::new();
    db.within_sq(q, scales, radius * radius, &mut found);
    found.sort_unstable_by_key(|&(i, _)| i);
    let mut nb: Vec<(usize, f64, f64)> = Vec::with_capacity(found.len());
    for (i, d2) in found {
        let u = d2.sqrt() / h;
        let k = kernel.value(u);
        if k > 0.0 {
            nb.push((i, k, u));
        }
    }
    if nb.is_empty() {
        let nearest = db
            .nearest_sq(q, scales, 1)
            .first()
            .map_or(f64::INFINITY, |&(_, d2)| d2.sqrt());
        return Err(LwrError::NoWeightedData {
            nearest_distance: nearest,
            support: radius,
        });
    }

    // normal equations
    let mut a = vec![0.0; p * p];
    let mut b = vec![0.0; p * o];
    let mut b2 = if want.confidence { vec![0.0; p * p] } else { Vec::new() };
    let mut zs = vec![0.0; nb.len() * p];
    let mut sum_w = 0.0;
    for (row, &(i, k, _)) in nb.iter().enumerate() {
        let x = &db.inputs()[i * d..(i + 1) * d];
        let y = &db.outputs()[i * o..(i + 1) * o];
        let z = &mut zs[row * p..(row + 1) * p];
        design_row(degree, x, q, z);
        sum_w += k;
        for r in 0..p {
            let kz = k * z[r];
            for c in 0..=r {
                a[r * p + c] += kz * z[c];
            }
            for (bo, yo) in b[r * o..(r + 1) * o].iter_mut().zip(y) {
                *bo += kz * yo;
            }
            if want.confidence {
                let kkz = k * kz;
                for c in 0..=r {
                    b2[r * p + c] += kkz * z[c];
                }
            }
        }
    }
    for r in 0..p {
        for c in 0..r {
            a[c * p + r] = a[r * p + c];
            if want.confidence {
                b2[c * p + r] = b2[r * p + c];
            }
        }
        if r > 0 {
            a[r * p + r] += settings.ridge;
        }
    }
    let (factor, condition, regularized) = factorise(&a, p, settings)?;

    // coefficients: one factorisation, o right-hand sides
    let mut beta = vec![0.0; p * o];
    let mut col = vec![0.0; p];
    for oo in 0..o {
        for r in 0..p {
            col[r] = b[r * o + oo];
        }
        factor.apply(&mut col);
        for r in 0..p {
            beta[r * o + oo] = col[r];
        }
    }
    let mut s = vec![0.0; p];
    s[0] = 1.0;
    factor.apply(&mut s);

    let mut fit = LocalFit {
        p,
        beta,
        s,
        n_neighbors: nb.len(),
        sum_w,
        condition,
        regularized,
        p_lwr: f64::NAN,
        l_norm2: f64::NAN,
        wrss: Vec::new(),
        jacobian: Vec::new(),
    };
    if !(want.confidence || want.jacobian) {
        return Ok(fit);
    }

    if want.confidence {
        // p_lwr = trace(P B2), with P column by column
        let mut p_lwr = 0.0;
        for c in 0..p {
            col.fill(0.0);
            col[c] = 1.0;
            factor.apply(&mut col);
            for r in 0..p {
                p_lwr += col[r] * b2[r * p + c];
            }
        }
        fit.p_lwr = p_lwr;
        fit.l_norm2 = 0.0;
        fit.wrss = vec![0.0; o];
    }
    if want.jacobian {
        fit.jacobian = vec![0.0; o * d];
    }
    let h2 = h * h;
    let mut resid = vec![0.0; o];
    let mut delta = vec![0.0; d];
    for (row, &(i, k, u)) in nb.iter().enumerate() {
        let z = &zs[row * p..(row + 1) * p];
        let y = &db.outputs()[i * o..(i + 1) * o];
        let zs_i: f64 = z.iter().zip(&fit.s).map(|(a, b)| a * b).sum();
        for (oo, (res, yo)) in resid.iter_mut().zip(y).enumerate() {
            let pred: f64 = z.iter().enumerate().map(|(r, zr)| zr * fit.beta[r * o + oo]).sum();
            *res = yo - pred;
        }
        if want.confidence {
            fit.l_norm2 += k * k * zs_i * zs_i;
            for (w, r) in fit.wrss.iter_mut().zip(&resid) {
                *w += k * r * r;
            }
        }
        if want.jacobian {
            let x = &db.inputs()[i * d..(i + 1) * d];
            for j in 0..d {
                delta[j] = x[j] - q[j];
            }
            let g = kernel.slope_over_u(u);
            for j in 0..d {
                // d k_i / d q_j
                let dk = -g * scales[j] * scales[j] * delta[j] / h2;
                let sdz = dz_dot(degree, &delta, j, &fit.s, 1);
                for (oo, res) in resid.iter().enumerate() {
                    let bdz = dz_dot(degree, &delta, j, &fit.beta[oo..], o);
                    fit.jacobian[oo * d + j] += (dk * zs_i + k * sdz) * res - k * zs_i * bdz;
                }
            }
        }
    }
    Ok(fit)
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

    #[test]
    fn quadratic_row_derivative_matches_differences() {
        let x = [0.3, -0.7, 1.1];
        let q = [0.1, 0.2, -0.4];
        let p = Degree::Quadratic.n_coeffs(3);
        let v: Vec<f64> = (0..p).map(|i| (i as f64 * 0.37).sin()).collect();
        let delta: Vec<f64> = x.iter().zip(&q).map(|(a, b)| a - b).collect();
        for j in 0..3 {
            let e = 1e-6;
            let mut qp = q;
            qp[j] += e;
            let mut qm = q;
            qm[j] -= e;
            let (mut zp, mut zm) = (vec![0.0; p], vec![0.0; p]);
            design_row(Degree::Quadratic, &x, &qp, &mut zp);
            design_row(Degree::Quadratic, &x, &qm, &mut zm);
            let fd: f64 = (0..p).map(|t| v[t] * (zp[t] - zm[t]) / (2.0 * e)).sum();
            let an = dz_dot(Degree::Quadratic, &delta, j, &v, 1);
            assert!((fd - an).abs() < 1e-8, "{fd} vs {an}");
        }
    }
}
