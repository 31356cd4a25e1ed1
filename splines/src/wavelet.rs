//! Discrete wavelet transforms (Haar and Daubechies db2–db8) and the
//! [`WaveletBasis`]: trajectories whose samples are the inverse wavelet
//! transform of their coefficients.
//!
//! # Transform
//!
//! One level of **analysis** convolves the signal $x$ (length $n$), extended
//! beyond its ends according to a [`Boundary`] mode, with the decomposition
//! filters $h$ (low pass, [`Wavelet::dec_lo`]) and $g$ (high pass,
//! [`Wavelet::dec_hi`]) of length $F$, and keeps every second sample:
//! $$a_o = \sum_{j=0}^{F-1} h_j\, \tilde x_{2o+1-j}, \qquad d_o = \sum_{j=0}^{F-1} g_j\, \tilde x_{2o+1-j},$$
//! $o = 0, \dots, \lfloor (n+F-1)/2 \rfloor - 1$, where $\tilde x$ is the extended signal
//! ([`Boundary::Periodization`] instead uses $\tilde x_{2o + F/2 - j}$ with a
//! periodic extension and $\lceil n/2 \rceil$ outputs).
//! One level of **synthesis** upsamples $a$ and $d$ by 2 (zeros between the
//! samples) and convolves them with the reconstruction filters
//! ([`Wavelet::rec_lo`], [`Wavelet::rec_hi`]), keeping the part of the full
//! convolution that every filter tap overlaps. A multilevel transform
//! ([`wavedec`]) analyses the approximation $a$ again, `level` times.
//!
//! All index conventions and output lengths are those of PyWavelets:
//! [`dwt`], [`idwt`] and [`wavedec`] equal `pywt.dwt`, `pywt.idwt` and
//! `pywt.wavedec` (checked against golden data to $10^{-12}$), and
//! [`Decomposition::reconstruct`] equals `pywt.waverec` truncated to the
//! signal length.
//!
//! # Boundary modes
//!
//! | [`Boundary`] | PyWavelets mode | extension of `x0 x1 … xn-1` | coefficients per level |
//! |---|---|---|---|
//! | `Periodization` | `'periodization'` | periodic, odd lengths first padded with `xn-1` | $\lceil n/2 \rceil$ |
//! | `Symmetric` | `'symmetric'` | `… x1 x0 \| x0 x1 … xn-1 \| xn-1 xn-2 …` | $\lfloor (n+F-1)/2 \rfloor$ |
//! | `Reflect` | `'reflect'` | `… x2 x1 \| x0 x1 … xn-1 \| xn-2 xn-3 …` | $\lfloor (n+F-1)/2 \rfloor$ |
//! | `Zero` | `'zero'` | `… 0 0 \| x0 x1 … xn-1 \| 0 0 …` | $\lfloor (n+F-1)/2 \rfloor$ |
//! | `ConstantEdge` | `'constant'` | `… x0 x0 \| x0 x1 … xn-1 \| xn-1 xn-1 …` | $\lfloor (n+F-1)/2 \rfloor$ |
//! | `Periodic` | `'periodic'` | `… xn-2 xn-1 \| x0 x1 … xn-1 \| x0 x1 …` | $\lfloor (n+F-1)/2 \rfloor$ |
//! | `Smooth` | `'smooth'` | `… x0+2(x0-x1) x0+(x0-x1) \| x0 x1 … xn-1 \| xn-1+(xn-1-xn-2) xn-1+2(xn-1-xn-2) …` | $\lfloor (n+F-1)/2 \rfloor$ |
//! | `Antisymmetric` | `'antisymmetric'` | `… -x1 -x0 \| x0 x1 … xn-1 \| -xn-1 -xn-2 …` | $\lfloor (n+F-1)/2 \rfloor$ |
//! | `Antireflect` | `'antireflect'` | `… 2x0-x2 2x0-x1 \| x0 x1 … xn-1 \| 2xn-1-xn-2 2xn-1-xn-3 …` | $\lfloor (n+F-1)/2 \rfloor$ |
//!
//! Where the extension is longer than the signal (signals shorter than the
//! filter), it continues as in PyWavelets: `Symmetric` and `Antisymmetric`
//! mirror back and forth (period $2n$; the antisymmetric mirror images carry a
//! minus sign), `Reflect` likewise without repeating the edge samples (period
//! $2n - 2$), `Antireflect` keeps reflecting through the edge value it reached
//! (`-1 1 0 -1 | 1 3 2 | 1 3 5 4`: each period of $2n - 2$ samples is shifted
//! by $2(x_{n-1} - x_0)$), and `Smooth` continues the straight line through the
//! two edge samples (a single sample is extended as a constant, as in
//! PyWavelets).
//!
//! The one difference from PyWavelets: `'reflect'` and `'antireflect'` refuse
//! signals of length 1; here [`Boundary::Reflect`] and [`Boundary::Antireflect`]
//! extend a single sample as a constant (what their formulas give for it:
//! $x_0$ and $2x_0 - x_0$).
//!
//! # Redundancy
//!
//! Only [`Boundary::Periodization`] is non-redundant: at signal lengths divisible
//! by $2^{\text{level}}$ it has exactly $n$ coefficients and the synthesis is
//! orthogonal (each odd length on the way adds one coefficient). The other
//! modes add $F - 2$ coefficients per level ($F - 1$ where that level's input
//! length is odd), so a signal has many coefficient vectors: the analysis picks
//! one of them, and synthesis maps all of them onto signals.
//!
//! # Lengths and levels
//!
//! Every level's input length is kept (like MATLAB's bookkeeping vector), so
//! synthesis returns exactly the signal's length, odd or even, at every level
//! (`pywt.waverec` returns one extra sample for odd lengths). Without an
//! explicit level, [`wavedec`] uses PyWavelets' [`dwt_max_level`]. Any level up
//! to [`max_level`] $= \lfloor \log_2 n \rfloor$ is accepted (PyWavelets warns
//! above `dwt_max_level` but continues; so do we, silently): reconstruction stays
//! perfect, only the coarse coefficients are dominated by the boundary.
//!
//! # Reference
//!
//! I. Daubechies, *Ten Lectures on Wavelets*, SIAM, 1992 (filters: table 6.1).
//! G. R. Lee, R. Gommers, F. Wasilewski, K. Wohlfahrt, A. O'Leary,
//! *PyWavelets: A Python package for wavelet analysis*, JOSS 4(36), 1237, 2019.

mod basis;
mod filters;
mod kernels;
mod transform;

use std::fmt;
use std::str::FromStr;

pub use basis::WaveletBasis;
pub use transform::WaveletTransform;

use crate::error::{Result, SplineError, check_finite, check_len};

/// An orthogonal wavelet: Haar or a Daubechies wavelet with $N$ vanishing
/// moments (`DbN`, filter length $2N$).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Wavelet {
    /// Haar wavelet (= db1), filter length 2.
    Haar,
    /// Daubechies, 2 vanishing moments, filter length 4.
    Db2,
    /// Daubechies, 3 vanishing moments, filter length 6.
    Db3,
    /// Daubechies, 4 vanishing moments, filter length 8.
    Db4,
    /// Daubechies, 5 vanishing moments, filter length 10.
    Db5,
    /// Daubechies, 6 vanishing moments, filter length 12.
    Db6,
    /// Daubechies, 7 vanishing moments, filter length 14.
    Db7,
    /// Daubechies, 8 vanishing moments, filter length 16.
    Db8,
}

impl Wavelet {
    /// Every wavelet, shortest filter first.
    pub const ALL: [Wavelet; 8] = [
        Wavelet::Haar,
        Wavelet::Db2,
        Wavelet::Db3,
        Wavelet::Db4,
        Wavelet::Db5,
        Wavelet::Db6,
        Wavelet::Db7,
        Wavelet::Db8,
    ];

    /// The PyWavelets name: `"haar"`, `"db2"`, …, `"db8"`.
    pub fn name(self) -> &'static str {
        match self {
            Wavelet::Haar => "haar",
            Wavelet::Db2 => "db2",
            Wavelet::Db3 => "db3",
            Wavelet::Db4 => "db4",
            Wavelet::Db5 => "db5",
            Wavelet::Db6 => "db6",
            Wavelet::Db7 => "db7",
            Wavelet::Db8 => "db8",
        }
    }

    /// Filter length $F$ (twice the number of vanishing moments).
    pub fn filter_len(self) -> usize {
        self.dec_lo().len()
    }

    /// The four filters `[dec_lo, dec_hi, rec_lo, rec_hi]`, as
    /// `pywt.Wavelet(name).filter_bank`.
    pub fn filter_bank(self) -> [&'static [f64]; 4] {
        use filters::*;
        match self {
            Wavelet::Haar => [&HAAR_DEC_LO, &HAAR_DEC_HI, &HAAR_REC_LO, &HAAR_REC_HI],
            Wavelet::Db2 => [&DB2_DEC_LO, &DB2_DEC_HI, &DB2_REC_LO, &DB2_REC_HI],
            Wavelet::Db3 => [&DB3_DEC_LO, &DB3_DEC_HI, &DB3_REC_LO, &DB3_REC_HI],
            Wavelet::Db4 => [&DB4_DEC_LO, &DB4_DEC_HI, &DB4_REC_LO, &DB4_REC_HI],
            Wavelet::Db5 => [&DB5_DEC_LO, &DB5_DEC_HI, &DB5_REC_LO, &DB5_REC_HI],
            Wavelet::Db6 => [&DB6_DEC_LO, &DB6_DEC_HI, &DB6_REC_LO, &DB6_REC_HI],
            Wavelet::Db7 => [&DB7_DEC_LO, &DB7_DEC_HI, &DB7_REC_LO, &DB7_REC_HI],
            Wavelet::Db8 => [&DB8_DEC_LO, &DB8_DEC_HI, &DB8_REC_LO, &DB8_REC_HI],
        }
    }

    /// Low-pass decomposition (analysis) filter $h$.
    pub fn dec_lo(self) -> &'static [f64] {
        self.filter_bank()[0]
    }

    /// High-pass decomposition (analysis) filter $g_k = (-1)^{k+1} h_{F-1-k}$.
    pub fn dec_hi(self) -> &'static [f64] {
        self.filter_bank()[1]
    }

    /// Low-pass reconstruction (synthesis) filter, $h$ reversed.
    pub fn rec_lo(self) -> &'static [f64] {
        self.filter_bank()[2]
    }

    /// High-pass reconstruction (synthesis) filter, $g$ reversed.
    pub fn rec_hi(self) -> &'static [f64] {
        self.filter_bank()[3]
    }
}

impl fmt::Display for Wavelet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Wavelet {
    type Err = SplineError;

    /// Parses a PyWavelets name (`"haar"`, `"db1"` = Haar, `"db2"`, …, `"db8"`),
    /// ignoring ASCII case.
    fn from_str(s: &str) -> Result<Self> {
        let lower = s.to_ascii_lowercase();
        if lower == "db1" {
            return Ok(Wavelet::Haar);
        }
        Wavelet::ALL
            .into_iter()
            .find(|w| w.name() == lower)
            .ok_or_else(|| SplineError::InvalidParameter {
                name: "wavelet",
                reason: format!("unknown wavelet {s:?}; expected haar, db1, …, db8"),
            })
    }
}

/// How a signal is extended beyond its ends (PyWavelets' signal extension
/// modes; see the [module docs](self) for the table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Boundary {
    /// `'periodization'`: periodic extension (odd lengths padded with the last
    /// sample), $\lceil n/2 \rceil$ coefficients per level; orthogonal.
    Periodization,
    /// `'symmetric'`: half-sample symmetric, the edge sample repeated.
    Symmetric,
    /// `'reflect'`: whole-sample symmetric, mirrored about the edge sample.
    Reflect,
    /// `'zero'`: zeros outside the signal.
    Zero,
    /// `'constant'`: the edge sample repeated.
    ConstantEdge,
    /// `'periodic'`: periodic with period $n$ (redundant, unlike `Periodization`).
    Periodic,
    /// `'smooth'`: linear extrapolation with the slope of the two edge samples
    /// (first-derivative extension; a single sample is extended as a constant).
    Smooth,
    /// `'antisymmetric'`: half-sample anti-symmetric, the edge sample repeated
    /// with its sign flipped (`… -x1 -x0 | x0 x1 …`).
    Antisymmetric,
    /// `'antireflect'`: whole-sample anti-symmetric, the signal reflected
    /// through the edge value (`… 2x0-x2 2x0-x1 | x0 x1 …`).
    Antireflect,
}

impl Boundary {
    /// Every mode.
    pub const ALL: [Boundary; 9] = [
        Boundary::Periodization,
        Boundary::Symmetric,
        Boundary::Reflect,
        Boundary::Zero,
        Boundary::ConstantEdge,
        Boundary::Periodic,
        Boundary::Smooth,
        Boundary::Antisymmetric,
        Boundary::Antireflect,
    ];

    /// The PyWavelets mode name.
    pub fn name(self) -> &'static str {
        match self {
            Boundary::Periodization => "periodization",
            Boundary::Symmetric => "symmetric",
            Boundary::Reflect => "reflect",
            Boundary::Zero => "zero",
            Boundary::ConstantEdge => "constant",
            Boundary::Periodic => "periodic",
            Boundary::Smooth => "smooth",
            Boundary::Antisymmetric => "antisymmetric",
            Boundary::Antireflect => "antireflect",
        }
    }
}

impl fmt::Display for Boundary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Boundary {
    type Err = SplineError;

    /// Parses a PyWavelets mode name (`"periodization"`, `"symmetric"`,
    /// `"reflect"`, `"zero"`, `"constant"`, `"periodic"`, `"smooth"`,
    /// `"antisymmetric"`, `"antireflect"`), ignoring ASCII case.
    fn from_str(s: &str) -> Result<Self> {
        let lower = s.to_ascii_lowercase();
        Boundary::ALL
            .into_iter()
            .find(|b| b.name() == lower)
            .ok_or_else(|| SplineError::InvalidParameter {
                name: "boundary",
                reason: format!(
                    "unknown mode {s:?}; expected one of {}",
                    Boundary::ALL.map(Boundary::name).join(", ")
                ),
            })
    }
}

/// Number of coefficients one analysis level makes from `input_len` samples
/// (PyWavelets' `dwt_coeff_len`): $\lceil n/2 \rceil$ for
/// [`Boundary::Periodization`], $\lfloor (n+F-1)/2 \rfloor$ otherwise.
pub fn dwt_coeff_len(input_len: usize, wavelet: Wavelet, boundary: Boundary) -> usize {
    match boundary {
        Boundary::Periodization => input_len.div_ceil(2),
        _ => (input_len + wavelet.filter_len() - 1) / 2,
    }
}

/// Number of samples one synthesis level makes from `coeff_len` coefficients
/// (PyWavelets' `idwt_buffer_length`): $2m$ for [`Boundary::Periodization`],
/// $2m - F + 2$ otherwise (`None` if $2m < F - 2$).
pub fn idwt_len(coeff_len: usize, wavelet: Wavelet, boundary: Boundary) -> Option<usize> {
    match boundary {
        Boundary::Periodization => Some(2 * coeff_len),
        _ => (2 * coeff_len + 2).checked_sub(wavelet.filter_len()),
    }
}

/// PyWavelets' default level, $\lfloor \log_2 (n / (F-1)) \rfloor$, or 0 if
/// $n < F - 1$: the deepest level at which some coefficient is free of
/// boundary effects.
pub fn dwt_max_level(signal_len: usize, wavelet: Wavelet) -> usize {
    let f1 = wavelet.filter_len() - 1;
    if signal_len < f1 {
        return 0;
    }
    (signal_len / f1).ilog2() as usize
}

/// The deepest level accepted here, $\lfloor \log_2 n \rfloor$ (0 for $n \le 1$):
/// the level at which a Haar approximation has a single coefficient.
pub fn max_level(signal_len: usize) -> usize {
    signal_len.checked_ilog2().unwrap_or(0) as usize
}

/// Single-level analysis, as `pywt.dwt(signal, wavelet, mode)`: returns the
/// approximation and detail coefficients, each [`dwt_coeff_len`] long.
///
/// # Errors
/// [`SplineError::Empty`] for an empty signal, [`SplineError::NotFinite`] for
/// NaN or infinite samples.
pub fn dwt(signal: &[f64], wavelet: Wavelet, boundary: Boundary) -> Result<(Vec<f64>, Vec<f64>)> {
    if signal.is_empty() {
        return Err(SplineError::Empty { what: "signal" });
    }
    check_finite("signal", signal)?;
    let m = dwt_coeff_len(signal.len(), wavelet, boundary);
    let filters = kernels::Filters::new(wavelet);
    let mut ext = vec![0.0; kernels::analysis_ext_len(m, wavelet)];
    let mut a = vec![0.0; m];
    let mut d = vec![0.0; m];
    kernels::analyse_level(signal, boundary, &filters, &mut ext, &mut a, &mut d);
    Ok((a, d))
}

/// Single-level synthesis, as `pywt.idwt(approx, detail, wavelet, mode)`
/// truncated to `out_len` samples.
///
/// # Errors
/// [`SplineError::Empty`] or [`SplineError::LengthMismatch`] unless both
/// coefficient vectors have the same nonzero length;
/// [`SplineError::InvalidParameter`] if they are shorter than $F/2$ (except for
/// [`Boundary::Periodization`]), or if `out_len` is neither the synthesis length
/// [`idwt_len`] nor one less; [`SplineError::NotFinite`] for NaN or infinite
/// coefficients.
pub fn idwt(approx: &[f64], detail: &[f64], wavelet: Wavelet, boundary: Boundary, out_len: usize) -> Result<Vec<f64>> {
    if approx.is_empty() {
        return Err(SplineError::Empty { what: "approximation" });
    }
    check_len("detail coefficients", approx.len(), detail.len())?;
    check_finite("approximation", approx)?;
    check_finite("detail", detail)?;
    let m = approx.len();
    let half = wavelet.filter_len() / 2;
    if boundary != Boundary::Periodization && m < half {
        return Err(SplineError::InvalidParameter {
            name: "approx",
            reason: format!("{wavelet} needs at least {half} coefficients in mode {boundary}, got {m}"),
        });
    }
    let full = idwt_len(m, wavelet, boundary).unwrap_or(0);
    if out_len > full || out_len + 1 < full || out_len == 0 {
        return Err(SplineError::InvalidParameter {
            name: "out_len",
            reason: format!(
                "synthesis of {m} coefficients gives {full} samples; out_len must be {full} or one less, got {out_len}"
            ),
        });
    }
    let filters = kernels::Filters::new(wavelet);
    let mut ext_a = vec![0.0; kernels::synthesis_ext_len(m, wavelet)];
    let mut ext_d = vec![0.0; kernels::synthesis_ext_len(m, wavelet)];
    let mut out = vec![0.0; out_len];
    kernels::synthesise_level(approx, detail, boundary, &filters, &mut ext_a, &mut ext_d, &mut out);
    Ok(out)
}

/// A multilevel wavelet decomposition, as `pywt.wavedec`, that remembers every
/// level's length so [`reconstruct`](Self::reconstruct) returns exactly the
/// signal's length.
#[derive(Debug, Clone, PartialEq)]
pub struct Decomposition {
    approx: Vec<f64>,
    details: Vec<Vec<f64>>,
    signal_len: usize,
    wavelet: Wavelet,
    boundary: Boundary,
}

impl Decomposition {
    /// Coarsest approximation coefficients $c_{A_L}$ (the signal itself at level 0).
    pub fn approx(&self) -> &[f64] {
        &self.approx
    }

    /// Detail coefficients, coarsest level first: `[cD_L, …, cD_1]`, the order
    /// of `pywt.wavedec`'s list after its first entry.
    pub fn details(&self) -> &[Vec<f64>] {
        &self.details
    }

    /// Number of levels $L$.
    pub fn level(&self) -> usize {
        self.details.len()
    }

    /// Length of the analysed signal.
    pub fn signal_len(&self) -> usize {
        self.signal_len
    }

    /// The wavelet.
    pub fn wavelet(&self) -> Wavelet {
        self.wavelet
    }

    /// The boundary mode.
    pub fn boundary(&self) -> Boundary {
        self.boundary
    }

    /// MATLAB-style bookkeeping: `[len(cA_L), len(cD_L), …, len(cD_1), signal_len]`.
    pub fn lengths(&self) -> Vec<usize> {
        std::iter::once(self.approx.len())
            .chain(self.details.iter().map(Vec::len))
            .chain(std::iter::once(self.signal_len))
            .collect()
    }

    /// All coefficients in `pywt.wavedec`'s order, concatenated:
    /// `[cA_L, cD_L, …, cD_1]`.
    pub fn to_flat(&self) -> Vec<f64> {
        let mut flat = Vec::with_capacity(self.approx.len() + self.details.iter().map(Vec::len).sum::<usize>());
        flat.extend_from_slice(&self.approx);
        for d in &self.details {
            flat.extend_from_slice(d);
        }
        flat
    }

    /// Splits a flat coefficient vector (as [`to_flat`](Self::to_flat) makes it)
    /// of a `level`-level decomposition of a signal of length `signal_len`.
    ///
    /// # Errors
    /// As [`WaveletTransform::new`], and [`SplineError::LengthMismatch`] if
    /// `flat` has the wrong length, [`SplineError::NotFinite`] for NaN or
    /// infinite coefficients.
    pub fn from_flat(
        flat: &[f64],
        wavelet: Wavelet,
        boundary: Boundary,
        signal_len: usize,
        level: usize,
    ) -> Result<Self> {
        let t = WaveletTransform::new(wavelet, boundary, signal_len, Some(level))?;
        crate::basis::check_coeffs(t.n_coeffs(), flat)?;
        Ok(Self::split(flat, &t))
    }

    fn split(flat: &[f64], t: &WaveletTransform) -> Self {
        let ranges = t.level_ranges();
        Decomposition {
            approx: flat[ranges[0].clone()].to_vec(),
            details: ranges[1..].iter().map(|r| flat[r.clone()].to_vec()).collect(),
            signal_len: t.signal_len(),
            wavelet: t.wavelet(),
            boundary: t.boundary(),
        }
    }

    /// Synthesis (`pywt.waverec`), returning exactly [`signal_len`](Self::signal_len)
    /// samples: the analysed signal, up to rounding.
    ///
    /// # Errors
    /// None for a decomposition made by [`wavedec`] or [`from_flat`](Self::from_flat).
    pub fn reconstruct(&self) -> Result<Vec<f64>> {
        let mut t = WaveletTransform::new(self.wavelet, self.boundary, self.signal_len, Some(self.level()))?;
        let mut signal = vec![0.0; self.signal_len];
        t.synthesise_into(&self.to_flat(), &mut signal)?;
        Ok(signal)
    }
}

/// Multilevel analysis, as `pywt.wavedec(signal, wavelet, mode, level)`.
/// `level = None` uses [`dwt_max_level`]; `Some(0)` returns the signal as the
/// approximation and no details.
///
/// # Errors
/// [`SplineError::Empty`] for an empty signal, [`SplineError::NotFinite`] for
/// NaN or infinite samples, [`SplineError::InvalidParameter`] for a level above
/// [`max_level`].
pub fn wavedec(signal: &[f64], wavelet: Wavelet, boundary: Boundary, level: Option<usize>) -> Result<Decomposition> {
    let mut t = WaveletTransform::new(wavelet, boundary, signal.len(), level)?;
    let mut flat = vec![0.0; t.n_coeffs()];
    t.analyse_into(signal, &mut flat)?;
    Ok(Decomposition::split(&flat, &t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() -> Result<()> {
        for w in Wavelet::ALL {
            assert_eq!(w.name().parse::<Wavelet>()?, w);
            assert_eq!(w.filter_len(), w.rec_hi().len());
        }
        for b in Boundary::ALL {
            assert_eq!(b.to_string().parse::<Boundary>()?, b);
        }
        assert_eq!("DB1".parse::<Wavelet>()?, Wavelet::Haar);
        assert!("db9".parse::<Wavelet>().is_err());
        assert_eq!("smooth".parse::<Boundary>()?, Boundary::Smooth);
        assert_eq!("AntiSymmetric".parse::<Boundary>()?, Boundary::Antisymmetric);
        assert_eq!("antireflect".parse::<Boundary>()?, Boundary::Antireflect);
        match "asymw".parse::<Boundary>() {
            Err(SplineError::InvalidParameter { reason, .. }) => {
                assert!(
                    reason.contains("unknown mode") && reason.contains("antireflect"),
                    "{reason}"
                );
            }
            other => panic!("{other:?}"),
        }
        Ok(())
    }

    #[test]
    fn filters_are_orthonormal() {
        for w in Wavelet::ALL {
            let h = w.dec_lo();
            let f = h.len();
            for shift in (0..f).step_by(2) {
                let dot: f64 = (0..f - shift).map(|k| h[k] * h[k + shift]).sum();
                let expected = if shift == 0 { 1.0 } else { 0.0 };
                assert!((dot - expected).abs() < 1e-14, "{w} shift {shift}: {dot}");
            }
            for k in 0..f {
                assert_eq!(w.rec_lo()[k], h[f - 1 - k]);
                assert_eq!(w.rec_hi()[k], w.dec_hi()[f - 1 - k]);
            }
        }
    }

    #[test]
    fn levels() {
        assert_eq!(dwt_max_level(1, Wavelet::Haar), 0);
        assert_eq!(dwt_max_level(8, Wavelet::Haar), 3);
        assert_eq!(dwt_max_level(6, Wavelet::Db4), 0);
        assert_eq!(dwt_max_level(7, Wavelet::Db4), 0);
        assert_eq!(dwt_max_level(14, Wavelet::Db4), 1);
        assert_eq!(max_level(0), 0);
        assert_eq!(max_level(1), 0);
        assert_eq!(max_level(7), 2);
    }

    #[test]
    fn haar_by_hand() -> Result<()> {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let (a, d) = dwt(&[1.0, 3.0, 5.0], Wavelet::Haar, Boundary::Periodization)?;
        // odd length: padded with the last sample
        let close = |u: &[f64], v: &[f64]| u.len() == v.len() && u.iter().zip(v).all(|(p, q)| (p - q).abs() < 1e-14);
        assert!(close(&a, &[4.0 * s, 10.0 * s]), "{a:?}");
        assert!(close(&d, &[-2.0 * s, 0.0]), "{d:?}");
        let x = idwt(&a, &d, Wavelet::Haar, Boundary::Periodization, 3)?;
        for (xi, ei) in x.iter().zip([1.0, 3.0, 5.0]) {
            assert!((xi - ei).abs() < 1e-14);
        }
        Ok(())
    }

    #[test]
    fn single_sample_dwt_matches_pywt_lengths() -> Result<()> {
        for w in Wavelet::ALL {
            for b in Boundary::ALL {
                let (a, d) = dwt(&[2.0], w, b)?;
                assert_eq!(a.len(), dwt_coeff_len(1, w, b));
                assert_eq!(d.len(), a.len());
                let x = idwt(&a, &d, w, b, 1)?;
                assert!((x[0] - 2.0).abs() < 1e-12, "{w} {b}: {x:?}");
            }
            // one sample: 'smooth' is 'constant' (as pywt); 'reflect' and
            // 'antireflect' (which pywt refuses) are too
            let constant = dwt(&[2.0], w, Boundary::ConstantEdge)?;
            for b in [Boundary::Smooth, Boundary::Reflect, Boundary::Antireflect] {
                assert_eq!(dwt(&[2.0], w, b)?, constant, "{w} {b}");
            }
        }
        Ok(())
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(matches!(
            dwt(&[], Wavelet::Db2, Boundary::Zero),
            Err(SplineError::Empty { .. })
        ));
        assert!(matches!(
            dwt(&[1.0, f64::NAN], Wavelet::Db2, Boundary::Zero),
            Err(SplineError::NotFinite { index: 1, .. })
        ));
        assert!(matches!(
            idwt(&[1.0, 2.0], &[1.0], Wavelet::Haar, Boundary::Zero, 2),
            Err(SplineError::LengthMismatch { .. })
        ));
        assert!(idwt(&[1.0], &[1.0], Wavelet::Db2, Boundary::Zero, 1).is_err());
        assert!(idwt(&[1.0, 2.0], &[1.0, 2.0], Wavelet::Haar, Boundary::Zero, 5).is_err());
        assert!(idwt(&[1.0, 2.0], &[1.0, 2.0], Wavelet::Haar, Boundary::Zero, 2).is_err());
        assert!(idwt(&[1.0, 2.0], &[1.0, 2.0], Wavelet::Haar, Boundary::Zero, 3).is_ok());
        assert!(wavedec(&[1.0; 7], Wavelet::Haar, Boundary::Zero, Some(3)).is_err());
        assert!(wavedec(&[1.0; 8], Wavelet::Haar, Boundary::Zero, Some(3)).is_ok());
    }

    #[test]
    fn flat_round_trip() -> Result<()> {
        let x: Vec<f64> = (0..37).map(|k| (k as f64 * 0.3).sin()).collect();
        let dec = wavedec(&x, Wavelet::Db3, Boundary::Symmetric, Some(2))?;
        let flat = dec.to_flat();
        let back = Decomposition::from_flat(&flat, Wavelet::Db3, Boundary::Symmetric, 37, 2)?;
        assert_eq!(back, dec);
        assert_eq!(dec.lengths(), vec![13, 13, 21, 37]);
        assert!(Decomposition::from_flat(&flat[1..], Wavelet::Db3, Boundary::Symmetric, 37, 2).is_err());
        Ok(())
    }
}
