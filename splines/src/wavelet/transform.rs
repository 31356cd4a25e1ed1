//! [`WaveletTransform`]: a planned multilevel transform with its own scratch.

use std::ops::Range;

use super::kernels::{self, Filters};
use super::{Boundary, Wavelet, dwt_coeff_len, dwt_max_level, max_level};
use crate::basis::check_coeffs;
use crate::error::{Result, SplineError, check_finite, check_len};

/// A multilevel wavelet transform planned for one signal length, wavelet,
/// boundary mode and level, holding its scratch buffers, so that
/// [`analyse_into`](Self::analyse_into) (`pywt.wavedec`) and
/// [`synthesise_into`](Self::synthesise_into) (`pywt.waverec`, truncated to the
/// signal length) allocate nothing.
///
/// Coefficients live in one flat vector in `pywt.wavedec`'s order
/// $[c_{A_L}, c_{D_L}, \dots, c_{D_1}]$; [`level_ranges`](Self::level_ranges)
/// says where each part is.
///
/// ```
/// use splines::wavelet::{Boundary, Wavelet, WaveletTransform};
/// let x: Vec<f64> = (0..100).map(|k| (k as f64 / 7.0).sin()).collect();
/// let mut t = WaveletTransform::new(Wavelet::Db4, Boundary::Symmetric, x.len(), None)?;
/// let mut c = vec![0.0; t.n_coeffs()];
/// t.analyse_into(&x, &mut c)?;
/// let mut y = vec![0.0; x.len()];
/// t.synthesise_into(&c, &mut y)?;
/// assert!(x.iter().zip(&y).all(|(a, b)| (a - b).abs() < 1e-12));
/// # Ok::<(), splines::SplineError>(())
/// ```
#[derive(Debug, Clone)]
pub struct WaveletTransform {
    wavelet: Wavelet,
    boundary: Boundary,
    filters: Filters,
    /// Input length of each analysis level, finest first: $n_0 = n, n_1, \dots, n_L$
    /// ($n_L$ is the length of the coarsest approximation).
    lens: Vec<usize>,
    /// Coarse to fine: $c_{A_L}, c_{D_L}, \dots, c_{D_1}$.
    ranges: Vec<Range<usize>>,
    n_coeffs: usize,
    ext_a: Vec<f64>,
    ext_d: Vec<f64>,
    /// Two buffers for intermediate approximations, one after the other.
    work: Vec<f64>,
}

impl WaveletTransform {
    /// Plans an `level`-level transform of signals of length `signal_len`
    /// (`None`: [`dwt_max_level`](super::dwt_max_level)).
    ///
    /// # Errors
    /// [`SplineError::Empty`] if `signal_len` is 0, [`SplineError::InvalidParameter`]
    /// if `level` exceeds [`max_level`](super::max_level)`(signal_len)`.
    pub fn new(wavelet: Wavelet, boundary: Boundary, signal_len: usize, level: Option<usize>) -> Result<Self> {
        if signal_len == 0 {
            return Err(SplineError::Empty { what: "signal" });
        }
        let level = level.unwrap_or_else(|| dwt_max_level(signal_len, wavelet));
        let max = max_level(signal_len);
        if level > max {
            return Err(SplineError::InvalidParameter {
                name: "level",
                reason: format!("level {level} exceeds floor(log2({signal_len})) = {max}"),
            });
        }
        let mut lens = vec![signal_len];
        for l in 0..level {
            lens.push(dwt_coeff_len(lens[l], wavelet, boundary));
        }
        let mut ranges = Vec::with_capacity(level + 1);
        let mut offset = lens[level];
        ranges.push(0..offset);
        for l in (1..=level).rev() {
            ranges.push(offset..offset + lens[l]);
            offset += lens[l];
        }
        let coeff_max = lens[1..].iter().copied().max().unwrap_or(0);
        let ext_len = kernels::analysis_ext_len(coeff_max, wavelet).max(kernels::synthesis_ext_len(coeff_max, wavelet));
        Ok(WaveletTransform {
            wavelet,
            boundary,
            filters: Filters::new(wavelet),
            work: vec![0.0; 2 * lens.iter().copied().max().unwrap_or(0)],
            lens,
            ranges,
            n_coeffs: offset,
            ext_a: vec![0.0; ext_len],
            ext_d: vec![0.0; ext_len],
        })
    }

    /// The wavelet.
    pub fn wavelet(&self) -> Wavelet {
        self.wavelet
    }

    /// The boundary mode.
    pub fn boundary(&self) -> Boundary {
        self.boundary
    }

    /// Number of levels $L$.
    pub fn level(&self) -> usize {
        self.lens.len() - 1
    }

    /// Signal length $n$.
    pub fn signal_len(&self) -> usize {
        self.lens[0]
    }

    /// Length of the flat coefficient vector (at least the signal length; equal
    /// for [`Boundary::Periodization`] when $2^L$ divides $n$).
    pub fn n_coeffs(&self) -> usize {
        self.n_coeffs
    }

    /// Index ranges in the flat vector, coarse to fine:
    /// $c_{A_L}, c_{D_L}, c_{D_{L-1}}, \dots, c_{D_1}$ ($L + 1$ ranges).
    pub fn level_ranges(&self) -> &[Range<usize>] {
        &self.ranges
    }

    /// Multilevel analysis (`pywt.wavedec`) of `signal` into `coeffs`.
    ///
    /// # Errors
    /// [`SplineError::LengthMismatch`] for a signal or coefficient buffer of
    /// the wrong length, [`SplineError::NotFinite`] for NaN or infinite samples.
    pub fn analyse_into(&mut self, signal: &[f64], coeffs: &mut [f64]) -> Result<()> {
        check_len("signal", self.signal_len(), signal.len())?;
        check_len("coefficients", self.n_coeffs, coeffs.len())?;
        if !all_finite(signal) {
            check_finite("signal", signal)?;
        }
        let level = self.level();
        let Some((mut src, mut dst)) = halves_or_copy(&mut self.work, level, signal, coeffs) else {
            return Ok(());
        };
        for l in 1..=level {
            let (n_in, m) = (self.lens[l - 1], self.lens[l]);
            let input: &[f64] = if l == 1 { signal } else { &src[..n_in] };
            if l == level {
                // coarsest level: approximation and detail are adjacent in `coeffs`
                let (a, rest) = coeffs.split_at_mut(m);
                kernels::analyse_level(input, self.boundary, &self.filters, &mut self.ext_a, a, &mut rest[..m]);
            } else {
                let d = &mut coeffs[self.ranges[level + 1 - l].clone()];
                kernels::analyse_level(input, self.boundary, &self.filters, &mut self.ext_a, &mut dst[..m], d);
                std::mem::swap(&mut src, &mut dst);
            }
        }
        Ok(())
    }

    /// Multilevel synthesis (`pywt.waverec`) of `coeffs` into `signal`, exactly
    /// [`signal_len`](Self::signal_len) samples.
    ///
    /// # Errors
    /// [`SplineError::LengthMismatch`] for a coefficient or signal buffer of
    /// the wrong length, [`SplineError::NotFinite`] for NaN or infinite coefficients.
    pub fn synthesise_into(&mut self, coeffs: &[f64], signal: &mut [f64]) -> Result<()> {
        check_len("coefficients", self.n_coeffs, coeffs.len())?;
        if !all_finite(coeffs) {
            check_coeffs(self.n_coeffs, coeffs)?;
        }
        check_len("signal", self.signal_len(), signal.len())?;
        let level = self.level();
        let Some((mut src, mut dst)) = halves_or_copy(&mut self.work, level, coeffs, signal) else {
            return Ok(());
        };
        for l in (1..=level).rev() {
            let (m, n_out) = (self.lens[l], self.lens[l - 1]);
            let a: &[f64] = if l == level { &coeffs[..m] } else { &src[..m] };
            let d = &coeffs[self.ranges[level + 1 - l].clone()];
            let out: &mut [f64] = if l == 1 { &mut *signal } else { &mut dst[..n_out] };
            kernels::synthesise_level(
                a,
                d,
                self.boundary,
                &self.filters,
                &mut self.ext_a,
                &mut self.ext_d,
                out,
            );
            std::mem::swap(&mut src, &mut dst);
        }
        Ok(())
    }

    /// Input length of each level, finest first ($n_0 = n, \dots, n_L$).
    pub(super) fn lens(&self) -> &[usize] {
        &self.lens
    }

    pub(super) fn filters(&self) -> &Filters {
        &self.filters
    }
}

/// The two halves of the work buffer, between which the levels of a
/// multilevel transform pass their intermediate results; `None`, with
/// `from` copied into `to` (the whole transform), when there is no level.
fn halves_or_copy<'w>(
    work: &'w mut [f64],
    level: usize,
    from: &[f64],
    to: &mut [f64],
) -> Option<(&'w mut [f64], &'w mut [f64])> {
    if level == 0 {
        to.copy_from_slice(from);
        return None;
    }
    let half = work.len() / 2;
    Some(work.split_at_mut(half))
}

/// Whether every value is finite, in one vectorisable pass ($0 \cdot v$ is 0 for
/// finite $v$, NaN otherwise); [`check_finite`] then finds the culprit.
fn all_finite(values: &[f64]) -> bool {
    let mut acc = [0.0f64; 8];
    let chunks = values.chunks_exact(8);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (a, v) in acc.iter_mut().zip(chunk) {
            *a += v * 0.0;
        }
    }
    for v in rest {
        acc[0] += v * 0.0;
    }
    acc.iter().sum::<f64>() == 0.0
}
