//! One level of analysis and synthesis.
//!
//! Both are written as sliding dot products over a buffer that already holds
//! the boundary extension, so the inner loops run over fixed-length arrays
//! (the filter length is a const generic) without bounds checks:
//!
//! - analysis: $a_o = \sum_k \bar h_k e_{2o+k}$ with $\bar h$ the reversed
//!   decomposition filter and $e$ the extended signal, starting `left` samples
//!   before $x_0$;
//! - synthesis: sample $p$ of the output, with $v = p + s$ ($s = F/2 - 1$ for
//!   periodization, else 0), is $\sum_{t<F/2} r^{(v \bmod 2)}_t c_{\lfloor v/2 \rfloor + t}$
//!   where $r^{(b)}_t = \mathrm{rec}_{2(F/2-1-t)+b}$ is a reversed polyphase
//!   component and $c$ is the coefficient vector (wrapped periodically
//!   for periodization).

use super::{Boundary, Wavelet};

/// Longest filter supported.
const MAX_F: usize = 16;

/// Reversed analysis filters and reversed polyphase synthesis filters of a wavelet.
#[derive(Debug, Clone, Copy)]
pub(super) struct Filters {
    wavelet: Wavelet,
    f: usize,
    lo_rev: [f64; MAX_F],
    hi_rev: [f64; MAX_F],
    /// `[lo even, lo odd, hi even, hi odd]` reversed polyphase synthesis filters.
    poly: [[f64; MAX_F / 2]; 4],
}

impl Filters {
    #[allow(clippy::needless_range_loop)] // taps indexed as in the formulas
    pub(super) fn new(wavelet: Wavelet) -> Self {
        let f = wavelet.filter_len();
        debug_assert!(f <= MAX_F && f.is_multiple_of(2));
        let h = f / 2;
        let mut lo_rev = [0.0; MAX_F];
        let mut hi_rev = [0.0; MAX_F];
        for k in 0..f {
            lo_rev[k] = wavelet.dec_lo()[f - 1 - k];
            hi_rev[k] = wavelet.dec_hi()[f - 1 - k];
        }
        let mut poly = [[0.0; MAX_F / 2]; 4];
        for t in 0..h {
            for b in 0..2 {
                poly[b][t] = wavelet.rec_lo()[2 * (h - 1 - t) + b];
                poly[2 + b][t] = wavelet.rec_hi()[2 * (h - 1 - t) + b];
            }
        }
        Filters {
            wavelet,
            f,
            lo_rev,
            hi_rev,
            poly,
        }
    }

    /// The synthesis taps of output sample `p` from `m` coefficients:
    /// `(coefficient index, weight on the approximation, weight on the detail)`.
    /// An index may repeat (periodization with fewer coefficients than taps).
    pub(super) fn synthesis_taps(
        &self,
        p: usize,
        m: usize,
        boundary: Boundary,
    ) -> impl Iterator<Item = (usize, f64, f64)> + '_ {
        let h = self.f / 2;
        let shift = synthesis_shift(boundary, self.f);
        let v = p + shift;
        let (a, b) = (v / 2, v % 2);
        (0..h).map(move |t| {
            let idx = if shift == 0 && boundary != Boundary::Periodization {
                a + t
            } else {
                (a + t + m * h - shift % m) % m
            };
            (idx, self.poly[b][t], self.poly[2 + b][t])
        })
    }
}

/// Offset $s$ between output samples and synthesis windows.
fn synthesis_shift(boundary: Boundary, f: usize) -> usize {
    match boundary {
        Boundary::Periodization => f / 2 - 1,
        _ => 0,
    }
}

/// Length of the extension buffer one analysis level giving `m` coefficients needs.
pub(super) fn analysis_ext_len(m: usize, wavelet: Wavelet) -> usize {
    // the even, then the odd samples of the extended signal
    2 * m + wavelet.filter_len() - 2
}

/// Length of the extension buffers one synthesis level from `m` coefficients needs.
pub(super) fn synthesis_ext_len(m: usize, wavelet: Wavelet) -> usize {
    m + wavelet.filter_len()
}

/// The extended signal's value at index `i` (0 = `x[0]`), `x` nonempty; as
/// PyWavelets' `downsampling_convolution` extends it, also where the
/// extension is longer than the signal.
fn extended(x: &[f64], boundary: Boundary, i: isize) -> f64 {
    let n = x.len() as isize;
    let idx = match boundary {
        Boundary::Smooth => {
            // the line through the two edge samples (pywt: a constant for n < 2)
            let last = x.len() - 1;
            return if n < 2 || (0..n).contains(&i) {
                x[i.clamp(0, n - 1) as usize]
            } else if i < 0 {
                x[0] + i.unsigned_abs() as f64 * (x[0] - x[1])
            } else {
                x[last] + (i - n + 1) as f64 * (x[last] - x[last - 1])
            };
        }
        Boundary::Antisymmetric => {
            // period 2n: x, then x reversed with the sign flipped
            let r = i.rem_euclid(2 * n);
            return if r < n {
                x[r as usize]
            } else {
                -x[(2 * n - 1 - r) as usize]
            };
        }
        Boundary::Antireflect => {
            // point reflections through the edge values, again and again: the
            // whole-sample antisymmetric pattern of period p = 2n - 2, shifted by
            // 2 (x[n-1] - x[0]) per period (pywt refuses n = 1; a constant here)
            if n == 1 {
                return x[0];
            }
            let p = 2 * n - 2;
            let (q, r) = (i.div_euclid(p), i.rem_euclid(p));
            let last = x[x.len() - 1];
            let base = if r < n {
                x[r as usize]
            } else {
                last - (x[(p - r) as usize] - last)
            };
            return base + q as f64 * (2.0 * (last - x[0]));
        }
        Boundary::Zero => {
            if (0..n).contains(&i) {
                i
            } else {
                return 0.0;
            }
        }
        Boundary::ConstantEdge => i.clamp(0, n - 1),
        Boundary::Periodic => i.rem_euclid(n),
        Boundary::Symmetric => {
            let r = i.rem_euclid(2 * n);
            if r < n { r } else { 2 * n - 1 - r }
        }
        Boundary::Reflect => {
            if n == 1 {
                0
            } else {
                let r = i.rem_euclid(2 * n - 2);
                if r < n { r } else { 2 * n - 2 - r }
            }
        }
        Boundary::Periodization => {
            // odd lengths are padded with the last sample first
            let padded = n + n % 2;
            i.rem_euclid(padded).min(n - 1)
        }
    };
    x[idx as usize]
}

/// Fills `out[t]` with the extended signal at index `t - left`.
fn extend(x: &[f64], boundary: Boundary, left: usize, out: &mut [f64]) {
    debug_assert!(!x.is_empty());
    let start = left.min(out.len());
    let end = (left + x.len()).min(out.len());
    out[start..end].copy_from_slice(&x[..end - start]);
    for t in (0..start).chain(end..out.len()) {
        out[t] = extended(x, boundary, t as isize - left as isize);
    }
}

/// [`extend`] split by parity in one pass: with $e_t$ the extended signal at
/// index `t - left`, `even[i]` $= e_{2i}$ and `odd[i]` $= e_{2i+1}$ (same lengths).
fn extend_polyphase(x: &[f64], boundary: Boundary, left: usize, even: &mut [f64], odd: &mut [f64]) {
    debug_assert!(!x.is_empty() && even.len() == odd.len());
    let total = 2 * even.len();
    let n = x.len();
    // interior: x[2k] lands in the buffer of parity `left`, x[2k + 1] in the other
    {
        let (first, second) = if left.is_multiple_of(2) {
            (&mut *even, &mut *odd)
        } else {
            (&mut *odd, &mut *even)
        };
        let (p0, p1) = (left / 2, left.div_ceil(2));
        if let (Some(f), Some(s)) = (first.get_mut(p0..), second.get_mut(p1..)) {
            for ((pair, u), v) in x.chunks_exact(2).zip(f.iter_mut()).zip(s.iter_mut()) {
                *u = pair[0];
                *v = pair[1];
            }
        }
        if n % 2 == 1
            && let Some(u) = first.get_mut(p0 + n / 2)
        {
            *u = x[n - 1];
        }
    }
    let end = (left + n).min(total);
    for t in (0..left.min(total)).chain(end..total) {
        let v = extended(x, boundary, t as isize - left as isize);
        if t % 2 == 0 {
            even[t / 2] = v;
        } else {
            odd[t / 2] = v;
        }
    }
}

/// Calls `$kernel::<H>($args)` monomorphised for `$wavelet`'s number of
/// polyphase taps $H = F/2$ (1 for Haar, $N$ for db$N$): the one map from
/// the runtime wavelet to the const-generic kernels. A macro because a
/// function cannot take a kernel generic over `H` as an argument.
macro_rules! with_taps {
    ($wavelet:expr, $kernel:ident($($arg:expr),* $(,)?)) => {
        match $wavelet {
            Wavelet::Haar => $kernel::<1>($($arg),*),
            Wavelet::Db2 => $kernel::<2>($($arg),*),
            Wavelet::Db3 => $kernel::<3>($($arg),*),
            Wavelet::Db4 => $kernel::<4>($($arg),*),
            Wavelet::Db5 => $kernel::<5>($($arg),*),
            Wavelet::Db6 => $kernel::<6>($($arg),*),
            Wavelet::Db7 => $kernel::<7>($($arg),*),
            Wavelet::Db8 => $kernel::<8>($($arg),*),
        }
    };
}

/// One analysis level: `a` and `d` (same length, [`super::dwt_coeff_len`]) from
/// the nonempty signal `x`; `ext` is scratch of at least [`analysis_ext_len`].
pub(super) fn analyse_level(
    x: &[f64],
    boundary: Boundary,
    filters: &Filters,
    ext: &mut [f64],
    a: &mut [f64],
    d: &mut [f64],
) {
    let f = filters.f;
    let left = match boundary {
        Boundary::Periodization => f / 2 - 1,
        _ => f - 2,
    };
    let half_len = a.len() + f / 2 - 1;
    let (even, rest) = ext.split_at_mut(half_len);
    let odd = &mut rest[..half_len];
    extend_polyphase(x, boundary, left, even, odd);
    let (even, odd) = (&*even, &*odd);
    let (lo, hi) = (&filters.lo_rev, &filters.hi_rev);
    with_taps!(filters.wavelet, analyse_fixed(even, odd, lo, hi, a, d));
}

/// Outputs computed together: independent accumulators the compiler keeps in
/// vector registers.
const BLOCK: usize = 4;

#[inline(always)]
fn dot<const N: usize>(f: &[f64; N], w: &[f64; N]) -> f64 {
    let mut s = 0.0;
    for (a, b) in f.iter().zip(w) {
        s += a * b;
    }
    s
}

/// One block of outputs of a two-input, two-output filter bank:
/// $u_i = \sum_t p_t x_{s+i+t} + q_t y_{s+i+t}$ and
/// $v_i = \sum_t r_t x_{s+i+t} + s_t y_{s+i+t}$ for $i <$ [`BLOCK`], from
/// `start` $= s$ and the filters `[p, q, r, s]` (both analysis and synthesis
/// are this, with their taps in different places); `None` if `x` or `y` ends
/// before $s + $ `BLOCK` $+ H - 1$.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // index loops over fixed-size arrays vectorise predictably
fn block<const H: usize>(
    x: &[f64],
    y: &[f64],
    start: usize,
    [p, q, r, s]: [&[f64; H]; 4],
) -> Option<([f64; BLOCK], [f64; BLOCK])> {
    let xw = x.get(start..start + BLOCK + H - 1)?;
    let yw = y.get(start..start + BLOCK + H - 1)?;
    let mut u = [0.0; BLOCK];
    let mut v = [0.0; BLOCK];
    for t in 0..H {
        let (xs, ys) = (xw[t..].first_chunk::<BLOCK>()?, yw[t..].first_chunk::<BLOCK>()?);
        for i in 0..BLOCK {
            u[i] += p[t] * xs[i] + q[t] * ys[i];
            v[i] += r[t] * xs[i] + s[t] * ys[i];
        }
    }
    Some((u, v))
}

/// Even and odd taps of a length-`2H` filter stored in a `MAX_F` array.
#[inline(always)]
fn polyphase<const H: usize>(f: &[f64; MAX_F]) -> ([f64; H], [f64; H]) {
    let mut even = [0.0; H];
    let mut odd = [0.0; H];
    for t in 0..H {
        even[t] = f[2 * t];
        odd[t] = f[2 * t + 1];
    }
    (even, odd)
}

/// $a_o = \sum_t \bar h_{2t} e_{o+t} + \bar h_{2t+1} o_{o+t}$, likewise $d$.
#[allow(clippy::needless_range_loop)] // index loops over fixed-size arrays vectorise predictably
fn analyse_fixed<const H: usize>(
    even: &[f64],
    odd: &[f64],
    lo: &[f64; MAX_F],
    hi: &[f64; MAX_F],
    a: &mut [f64],
    d: &mut [f64],
) {
    let (le, lo) = polyphase::<H>(lo);
    let (he, ho) = polyphase::<H>(hi);
    let m = a.len().min(d.len());
    let n_blocks = m / BLOCK;
    for ((blk, ab), db) in a.chunks_exact_mut(BLOCK).enumerate().zip(d.chunks_exact_mut(BLOCK)) {
        let Some((sa, sd)) = block::<H>(even, odd, blk * BLOCK, [&le, &lo, &he, &ho]) else {
            debug_assert!(false, "analysis buffer too short");
            return;
        };
        ab.copy_from_slice(&sa);
        db.copy_from_slice(&sd);
    }
    for o in n_blocks * BLOCK..m {
        let (Some(x), Some(y)) = (
            even.get(o..).and_then(<[f64]>::first_chunk::<H>),
            odd.get(o..).and_then(<[f64]>::first_chunk::<H>),
        ) else {
            debug_assert!(false, "analysis buffer too short");
            return;
        };
        a[o] = dot(&le, x) + dot(&lo, y);
        d[o] = dot(&he, x) + dot(&ho, y);
    }
}

/// One synthesis level: `out` (at most [`super::idwt_len`] long) from the
/// approximation `a` and detail `d` (same nonzero length; at least $F/2$ unless
/// periodization); `ext_a` and `ext_d` are scratch of at least [`synthesis_ext_len`].
pub(super) fn synthesise_level(
    a: &[f64],
    d: &[f64],
    boundary: Boundary,
    filters: &Filters,
    ext_a: &mut [f64],
    ext_d: &mut [f64],
    out: &mut [f64],
) {
    let m = a.len();
    let shift = synthesis_shift(boundary, filters.f);
    let (ae, de): (&[f64], &[f64]) = if boundary == Boundary::Periodization {
        // wrap the coefficients periodically
        let len = m + filters.f;
        let (ext_a, ext_d) = (&mut ext_a[..len], &mut ext_d[..len]);
        extend(a, Boundary::Periodic, shift, ext_a);
        extend(d, Boundary::Periodic, shift, ext_d);
        (ext_a, ext_d)
    } else {
        (a, d)
    };
    let p = &filters.poly;
    with_taps!(filters.wavelet, synthesise_fixed(ae, de, p, shift, out));
}

/// Sample $p$ with $p + s = 2q + b$ is $\sum_t r^{(b)}_t a_{q+t} + \rho^{(b)}_t d_{q+t}$.
#[allow(clippy::needless_range_loop)] // index loops over fixed-size arrays vectorise predictably
fn synthesise_fixed<const H: usize>(
    ae: &[f64],
    de: &[f64],
    poly: &[[f64; MAX_F / 2]; 4],
    shift: usize,
    out: &mut [f64],
) {
    let (Some(le), Some(lo), Some(he), Some(ho)) = (
        poly[0].first_chunk::<H>(),
        poly[1].first_chunk::<H>(),
        poly[2].first_chunk::<H>(),
        poly[3].first_chunk::<H>(),
    ) else {
        return;
    };
    let window = |q: usize| -> Option<(&[f64; H], &[f64; H])> {
        let wa = ae.get(q..)?.first_chunk::<H>()?;
        let wd = de.get(q..)?.first_chunk::<H>()?;
        Some((wa, wd))
    };
    let mut q = shift / 2;
    let out = if shift % 2 == 1 {
        // the first sample is the odd phase of the first window
        let Some((first, rest)) = out.split_first_mut() else {
            return;
        };
        if let Some((wa, wd)) = window(q) {
            *first = dot(lo, wa) + dot(ho, wd);
        }
        q += 1;
        rest
    } else {
        out
    };
    // blocks of BLOCK (even, odd) pairs
    let n_blocks = out.len() / (2 * BLOCK);
    for (blk, chunk) in out.chunks_exact_mut(2 * BLOCK).enumerate() {
        let Some((ev, od)) = block::<H>(ae, de, q + blk * BLOCK, [le, he, lo, ho]) else {
            debug_assert!(false, "synthesis buffer too short");
            return;
        };
        for ((pair, e), o) in chunk.chunks_exact_mut(2).zip(ev).zip(od) {
            pair[0] = e;
            pair[1] = o;
        }
    }
    q += n_blocks * BLOCK;
    let mut pairs = out[n_blocks * 2 * BLOCK..].chunks_exact_mut(2);
    for pair in pairs.by_ref() {
        let (Some((wa, wd)), [even, odd]) = (window(q), pair) else {
            debug_assert!(false, "synthesis buffer too short");
            return;
        };
        *even = dot(le, wa) + dot(he, wd);
        *odd = dot(lo, wa) + dot(ho, wd);
        q += 1;
    }
    if let ([last], Some((wa, wd))) = (pairs.into_remainder(), window(q)) {
        *last = dot(le, wa) + dot(he, wd);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The extension of `x` at indices `from..to`.
    fn ext(x: &[f64], boundary: Boundary, from: isize, to: isize) -> Vec<f64> {
        (from..to).map(|i| extended(x, boundary, i)).collect()
    }

    #[test]
    fn new_modes_extend_as_pywt() {
        // pywt's test_dwt_short_input_allmodes signal, four samples either side
        // (as pywt.dwt extends it; the far left of its 'antireflect' pad differs)
        let x = [1.0, 3.0, 2.0];
        let cases = [
            (
                Boundary::Smooth,
                [-7.0, -5.0, -3.0, -1.0, 1.0, 3.0, 2.0, 1.0, 0.0, -1.0, -2.0],
            ),
            (
                Boundary::Antisymmetric,
                [2.0, -2.0, -3.0, -1.0, 1.0, 3.0, 2.0, -2.0, -3.0, -1.0, 1.0],
            ),
            (
                Boundary::Antireflect,
                [-1.0, 1.0, 0.0, -1.0, 1.0, 3.0, 2.0, 1.0, 3.0, 5.0, 4.0],
            ),
        ];
        for (b, expected) in cases {
            assert_eq!(ext(&x, b, -4, 7), expected, "{b}");
        }
        // a straight line continues as itself, over several periods
        // (pywt.dwt's values; the comment in pywt's C header draws the second
        // period differently)
        let line: Vec<f64> = (-5..8).map(|k| k as f64 + 1.0).collect();
        assert_eq!(ext(&[1.0, 2.0, 3.0], Boundary::Antireflect, -5, 8), line);
        assert_eq!(ext(&[1.0, 2.0, 3.0], Boundary::Smooth, -5, 8), line);
        // two samples: every other extension sample is an edge reflection
        assert_eq!(
            ext(&[1.0, 2.0], Boundary::Antireflect, -3, 5),
            [-2.0, -1.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
        );
        assert_eq!(
            ext(&[1.0, 2.0], Boundary::Antisymmetric, -3, 5),
            [2.0, -2.0, -1.0, 1.0, 2.0, -2.0, -1.0, 1.0]
        );
        // a single sample: constant for smooth (as pywt) and antireflect
        for b in [Boundary::Smooth, Boundary::Antireflect] {
            assert_eq!(ext(&[4.0], b, -3, 4), [4.0; 7], "{b}");
        }
        assert_eq!(ext(&[4.0], Boundary::Antisymmetric, -2, 3), [4.0, -4.0, 4.0, -4.0, 4.0]);
    }
}
