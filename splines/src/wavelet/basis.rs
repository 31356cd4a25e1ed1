//! [`WaveletBasis`]: samples on a uniform grid as the wavelet synthesis of the
//! coefficients, linearly interpolated between grid times.

use std::ops::Range;

use faer::sparse::{SparseColMat, SparseRowMat, SymbolicSparseColMat, SymbolicSparseRowMat};

use super::transform::WaveletTransform;
use super::{Boundary, Wavelet};
use crate::basis::{TrajectoryBasis, check_time};
use crate::error::{Result, SplineError};

/// A trajectory sampled at $t_k = t_0 + k\,\Delta t$, $k = 0, \dots, n-1$, whose
/// samples are the multilevel wavelet synthesis (`pywt.waverec`, truncated to
/// $n$) of its coefficients: $y(t_k) = (S c)_k$ with $S$ the
/// [`synthesis_matrix`](Self::synthesis_matrix), $n \times$
/// [`n_coeffs`](TrajectoryBasis::n_coeffs).
///
/// Between grid times the trajectory is the piecewise-linear interpolant of the
/// samples, $y(t) = (1-s)\,y(t_k) + s\,y(t_{k+1})$ with
/// $s = (t - t_k)/\Delta t$; a time within $10^{-9}$ grid steps (relative to
/// $\max(1, (t - t_0)/\Delta t)$) of a grid time gets exactly that row.
/// The first derivative is the slope of the interpolant on $[t_k, t_{k+1})$
/// (the last grid time uses the last segment; a single sample has slope 0);
/// derivatives of order 2 and above are zero (empty rows), as for a B-spline
/// above its degree: the interpolant is piecewise linear.
///
/// The coefficient vector is the flat `pywt.wavedec` vector
/// $[c_{A_L}, c_{D_L}, \dots, c_{D_1}]$, so [`TrajectoryBasis::n_coeffs`] $\ge n$:
/// equal, and $S$ orthogonal, only for [`Boundary::Periodization`] with $2^L$
/// dividing $n$; the other modes are redundant (several coefficient vectors
/// give the same samples; [`analyse`](Self::analyse) picks the wavelet
/// analysis). Each sample depends on $O(F L)$ coefficients; the rows of $S$
/// are composed level by level at construction.
///
/// ```
/// use splines::TrajectoryBasis;
/// use splines::wavelet::{Boundary, Wavelet, WaveletBasis};
/// let basis = WaveletBasis::new(Wavelet::Db2, Boundary::Symmetric, 50, None, 0.0, 0.1)?;
/// let x: Vec<f64> = (0..50).map(|k| (k as f64 * 0.1).cos()).collect();
/// let c = basis.analyse(&x)?;
/// let y = basis.evaluate(&c, &[0.0, 0.25, 4.9], 0)?;
/// assert!((y[0] - 1.0).abs() < 1e-12);
/// assert!((y[1] - 0.5 * (x[2] + x[3])).abs() < 1e-12);
/// # Ok::<(), splines::SplineError>(())
/// ```
#[derive(Debug, Clone)]
pub struct WaveletBasis {
    transform: WaveletTransform,
    t0: f64,
    dt: f64,
    /// Synthesis matrix in compressed rows, columns sorted within each row.
    row_ptr: Vec<usize>,
    col_idx: Vec<usize>,
    values: Vec<f64>,
    max_nonzeros: usize,
}

/// Relative tolerance for snapping a time onto the grid.
const GRID_TOL: f64 = 1e-9;

impl WaveletBasis {
    /// A basis for `n_samples` samples at $t_0 + k\,\Delta t$ with a `level`-level
    /// transform (`None`: [`dwt_max_level`](super::dwt_max_level)).
    ///
    /// # Errors
    /// [`SplineError::Empty`] if `n_samples` is 0; [`SplineError::InvalidParameter`]
    /// for a level above [`max_level`](super::max_level), a non-finite `t0`, a
    /// `dt` that is not finite and positive, or a non-finite end time.
    pub fn new(
        wavelet: Wavelet,
        boundary: Boundary,
        n_samples: usize,
        level: Option<usize>,
        t0: f64,
        dt: f64,
    ) -> Result<Self> {
        if !t0.is_finite() {
            return Err(SplineError::InvalidParameter {
                name: "t0",
                reason: format!("must be finite, got {t0}"),
            });
        }
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SplineError::InvalidParameter {
                name: "dt",
                reason: format!("must be finite and positive, got {dt}"),
            });
        }
        let transform = WaveletTransform::new(wavelet, boundary, n_samples, level)?;
        let t_end = t0 + (n_samples - 1) as f64 * dt;
        if !t_end.is_finite() {
            return Err(SplineError::InvalidParameter {
                name: "dt",
                reason: format!("the end time t0 + (n_samples - 1) dt is not finite ({t_end})"),
            });
        }
        let (row_ptr, col_idx, values) = synthesis_rows(&transform);
        let mut basis = WaveletBasis {
            transform,
            t0,
            dt,
            row_ptr,
            col_idx,
            values,
            max_nonzeros: 0,
        };
        basis.max_nonzeros = if n_samples == 1 {
            basis.row(0).0.len()
        } else {
            (0..n_samples - 1)
                .map(|k| union_len(basis.row(k).0, basis.row(k + 1).0))
                .max()
                .unwrap_or(0)
        };
        Ok(basis)
    }

    /// Number of grid samples $n$.
    pub fn n_samples(&self) -> usize {
        self.transform.signal_len()
    }

    /// First grid time $t_0$.
    pub fn t0(&self) -> f64 {
        self.t0
    }

    /// Grid step $\Delta t$.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The grid times $t_k = t_0 + k\,\Delta t$.
    pub fn sample_times(&self) -> Vec<f64> {
        (0..self.n_samples()).map(|k| self.t0 + k as f64 * self.dt).collect()
    }

    /// The wavelet.
    pub fn wavelet(&self) -> Wavelet {
        self.transform.wavelet()
    }

    /// The boundary mode.
    pub fn boundary(&self) -> Boundary {
        self.transform.boundary()
    }

    /// Number of levels $L$.
    pub fn level(&self) -> usize {
        self.transform.level()
    }

    /// Index ranges of $c_{A_L}, c_{D_L}, \dots, c_{D_1}$ in the coefficient vector.
    pub fn level_ranges(&self) -> &[Range<usize>] {
        self.transform.level_ranges()
    }

    /// A transform planned like this basis, for allocation-free analysis and
    /// synthesis of many signals.
    pub fn transform(&self) -> WaveletTransform {
        self.transform.clone()
    }

    /// Coefficients whose synthesis is `signal` (the wavelet analysis,
    /// `pywt.wavedec` flattened).
    ///
    /// # Errors
    /// [`SplineError::LengthMismatch`] unless `signal` has
    /// [`n_samples`](Self::n_samples) values, [`SplineError::NotFinite`] for NaN
    /// or infinite samples.
    pub fn analyse(&self, signal: &[f64]) -> Result<Vec<f64>> {
        let mut t = self.transform.clone();
        let mut coeffs = vec![0.0; t.n_coeffs()];
        t.analyse_into(signal, &mut coeffs)?;
        Ok(coeffs)
    }

    /// The samples $S c$ at the grid times (fast synthesis, no matrix).
    ///
    /// # Errors
    /// [`SplineError::LengthMismatch`] or [`SplineError::NotFinite`] for a bad
    /// coefficient vector.
    pub fn synthesise(&self, coeffs: &[f64]) -> Result<Vec<f64>> {
        let mut t = self.transform.clone();
        let mut signal = vec![0.0; t.signal_len()];
        t.synthesise_into(coeffs, &mut signal)?;
        Ok(signal)
    }

    /// The synthesis matrix $S$ ($n \times$ `n_coeffs`) in compressed rows.
    pub fn synthesis_matrix_rows(&self) -> SparseRowMat<usize, f64> {
        let symbolic = SymbolicSparseRowMat::new_checked(
            self.n_samples(),
            self.transform.n_coeffs(),
            self.row_ptr.clone(),
            None,
            self.col_idx.clone(),
        );
        SparseRowMat::new(symbolic, self.values.clone())
    }

    /// The synthesis matrix $S$ ($n \times$ `n_coeffs`) in compressed columns.
    pub fn synthesis_matrix(&self) -> SparseColMat<usize, f64> {
        let (n_rows, n_cols) = (self.n_samples(), self.transform.n_coeffs());
        let mut col_ptr = vec![0usize; n_cols + 1];
        for &j in &self.col_idx {
            col_ptr[j + 1] += 1;
        }
        for j in 0..n_cols {
            col_ptr[j + 1] += col_ptr[j];
        }
        let mut next = col_ptr.clone();
        let mut row_idx = vec![0usize; self.col_idx.len()];
        let mut values = vec![0.0; self.col_idx.len()];
        for i in 0..n_rows {
            let (cols, vals) = self.row(i);
            for (&j, &v) in cols.iter().zip(vals) {
                row_idx[next[j]] = i;
                values[next[j]] = v;
                next[j] += 1;
            }
        }
        let symbolic = SymbolicSparseColMat::new_checked(n_rows, n_cols, col_ptr, None, row_idx);
        SparseColMat::new(symbolic, values)
    }

    fn row(&self, k: usize) -> (&[usize], &[f64]) {
        let r = self.row_ptr[k]..self.row_ptr[k + 1];
        (&self.col_idx[r.clone()], &self.values[r])
    }

    /// Writes $w_0 S_{k} + w_1 S_{k+1}$ into `out`, columns increasing.
    fn combine_rows(&self, k: usize, w0: f64, w1: f64, out: &mut Vec<(usize, f64)>) {
        let (c0, v0) = self.row(k);
        let (c1, v1) = self.row(k + 1);
        let (mut i, mut j) = (0, 0);
        while i < c0.len() || j < c1.len() {
            let take0 = j == c1.len() || (i < c0.len() && c0[i] <= c1[j]);
            let take1 = i == c0.len() || (j < c1.len() && c1[j] <= c0[i]);
            match (take0, take1) {
                (true, true) => {
                    out.push((c0[i], w0 * v0[i] + w1 * v1[j]));
                    i += 1;
                    j += 1;
                }
                (true, false) => {
                    out.push((c0[i], w0 * v0[i]));
                    i += 1;
                }
                _ => {
                    out.push((c1[j], w1 * v1[j]));
                    j += 1;
                }
            }
        }
    }
}

impl TrajectoryBasis for WaveletBasis {
    fn n_coeffs(&self) -> usize {
        self.transform.n_coeffs()
    }

    fn domain(&self) -> (f64, f64) {
        (self.t0, self.t0 + (self.n_samples() - 1) as f64 * self.dt)
    }

    fn max_nonzeros(&self) -> usize {
        self.max_nonzeros
    }

    fn basis_row(&self, t: f64, order: usize, row: &mut Vec<(usize, f64)>) -> Result<()> {
        check_time(t, self.domain())?;
        row.clear();
        let n = self.n_samples();
        if order >= 2 || (order == 1 && n == 1) {
            return Ok(());
        }
        let u = (t - self.t0) / self.dt;
        let nearest = u.round();
        let on_grid = (u - nearest).abs() <= GRID_TOL * u.abs().max(1.0);
        if order == 0 && on_grid {
            let k = (nearest.max(0.0) as usize).min(n - 1);
            let (cols, vals) = self.row(k);
            row.extend(cols.iter().copied().zip(vals.iter().copied()));
            return Ok(());
        }
        // n >= 2 here: with one sample every time in the domain is on the grid
        let base = if on_grid { nearest } else { u.floor() };
        let k = (base.max(0.0) as usize).min(n - 2);
        if order == 0 {
            let s = u - k as f64;
            self.combine_rows(k, 1.0 - s, s, row);
        } else {
            self.combine_rows(k, -1.0 / self.dt, 1.0 / self.dt, row);
        }
        Ok(())
    }
}

/// Number of distinct entries in the union of two sorted index lists.
fn union_len(a: &[usize], b: &[usize]) -> usize {
    let (mut i, mut j, mut count) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
            }
        }
        count += 1;
    }
    count + (a.len() - i) + (b.len() - j)
}

/// Rows of the synthesis matrix (compressed rows, sorted columns), composed
/// level by level from coarse to fine: the rows of the coarsest approximation
/// are unit vectors, and each synthesis level combines $F/2$ rows of the level
/// above with $F/2$ detail coefficients (a sparse accumulator merges them).
fn synthesis_rows(transform: &WaveletTransform) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let level = transform.level();
    let lens = transform.lens();
    let ranges = transform.level_ranges();
    let boundary = transform.boundary();
    let filters = transform.filters();
    let n_coeffs = transform.n_coeffs();
    let m_top = lens[level];
    let mut ptr: Vec<usize> = (0..=m_top).collect();
    let mut cols: Vec<usize> = (0..m_top).collect();
    let mut vals = vec![1.0; m_top];
    let mut acc = vec![0.0; n_coeffs];
    let mut stamp = vec![usize::MAX; n_coeffs];
    let mut touched: Vec<usize> = Vec::new();
    let mut row_id = 0usize;
    for l in (1..=level).rev() {
        let (m, n_out) = (lens[l], lens[l - 1]);
        let d_offset = ranges[level + 1 - l].start;
        let prev_nnz = cols.len() / m.max(1);
        let mut next_ptr = Vec::with_capacity(n_out + 1);
        let mut next_cols = Vec::with_capacity(n_out * (prev_nnz + 2));
        let mut next_vals = Vec::with_capacity(n_out * (prev_nnz + 2));
        next_ptr.push(0);
        for p in 0..n_out {
            touched.clear();
            let mut add = |c: usize, v: f64, touched: &mut Vec<usize>| {
                if stamp[c] == row_id {
                    acc[c] += v;
                } else {
                    stamp[c] = row_id;
                    acc[c] = v;
                    touched.push(c);
                }
            };
            for (idx, wa, wd) in filters.synthesis_taps(p, m, boundary) {
                for e in ptr[idx]..ptr[idx + 1] {
                    add(cols[e], wa * vals[e], &mut touched);
                }
                add(d_offset + idx, wd, &mut touched);
            }
            touched.sort_unstable();
            for &c in &touched {
                next_cols.push(c);
                next_vals.push(acc[c]);
            }
            next_ptr.push(next_cols.len());
            row_id += 1;
        }
        ptr = next_ptr;
        cols = next_cols;
        vals = next_vals;
    }
    debug_assert_eq!(ptr.len(), lens[0] + 1);
    (ptr, cols, vals)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_between_grid_times_interpolate() -> Result<()> {
        let b = WaveletBasis::new(Wavelet::Haar, Boundary::Periodization, 4, Some(2), 1.0, 0.5)?;
        // coefficients: approximation only -> constant samples
        let c = b.analyse(&[1.0, 2.0, 3.0, 4.0])?;
        let y = b.evaluate(&c, &[1.0, 1.25, 2.5], 0)?;
        assert!((y[0] - 1.0).abs() < 1e-14);
        assert!((y[1] - 1.5).abs() < 1e-14);
        assert!((y[2] - 4.0).abs() < 1e-14);
        let dy = b.evaluate(&c, &[1.0, 1.7, 2.5], 1)?;
        for v in dy {
            assert!((v - 2.0).abs() < 1e-13);
        }
        assert_eq!(b.evaluate(&c, &[1.3], 2)?, vec![0.0]);
        assert!(matches!(
            b.evaluate(&c, &[2.6], 0),
            Err(SplineError::OutsideDomain { .. })
        ));
        assert!(matches!(
            b.evaluate(&c, &[f64::NAN], 0),
            Err(SplineError::NotFinite { .. })
        ));
        Ok(())
    }

    #[test]
    fn single_sample() -> Result<()> {
        let b = WaveletBasis::new(Wavelet::Db2, Boundary::Zero, 1, None, 2.0, 1.0)?;
        assert_eq!(b.n_coeffs(), 1);
        assert_eq!(b.domain(), (2.0, 2.0));
        assert_eq!(b.evaluate(&[3.0], &[2.0], 0)?, vec![3.0]);
        assert_eq!(b.evaluate(&[3.0], &[2.0], 1)?, vec![0.0]);
        Ok(())
    }

    #[test]
    fn bad_parameters() {
        let new = |n, dt| WaveletBasis::new(Wavelet::Db2, Boundary::Zero, n, None, 0.0, dt);
        assert!(matches!(new(0, 1.0), Err(SplineError::Empty { .. })));
        assert!(new(4, 0.0).is_err());
        assert!(new(4, f64::NAN).is_err());
        assert!(new(4, f64::MAX).is_err());
        assert!(WaveletBasis::new(Wavelet::Db2, Boundary::Zero, 4, Some(3), 0.0, 1.0).is_err());
    }

    #[test]
    fn union_len_counts_distinct() {
        assert_eq!(union_len(&[1, 3, 5], &[2, 3, 6, 7]), 6);
        assert_eq!(union_len(&[], &[2]), 1);
    }
}
