//! B-spline bases of any degree on any nondecreasing knot vector.
//!
//! A degree-$p$ B-spline basis on knots $t_0 \le t_1 \le \dots \le t_{n+p}$
//! has $n$ functions, defined by the Cox-de Boor recursion
//! $$N_{i,0}(t) = [t_i \le t < t_{i+1}],\quad
//! N_{i,q}(t) = \frac{t - t_i}{t_{i+q} - t_i} N_{i,q-1}(t)
//!            + \frac{t_{i+q+1} - t}{t_{i+q+1} - t_{i+1}} N_{i+1,q-1}(t)$$
//! (a term with a zero denominator is zero). The domain is $[t_p, t_n]$; on
//! it the functions are nonnegative and sum to one, and at any $t$ at most
//! $p + 1$ of them, $N_{s-p}, \dots, N_s$ for the span $s$ with
//! $t_s \le t < t_{s+1}$, are nonzero. Only those are computed.
//!
//! Derivatives use
//! $N'_{i,q} = \frac{q}{t_{i+q} - t_i} N_{i,q-1} - \frac{q}{t_{i+q+1} - t_{i+1}} N_{i+1,q-1}$:
//! the order-$r$ derivative is
//! the degree-$(p-r)$ basis raised $r$ times by this rule. An order above
//! the degree gives zeros (the function is piecewise polynomial), not an error.
//!
//! At the right end $t = t_n$ the last nonempty span is used, so the basis
//! is continuous up to the end of the domain (as scipy's `BSpline`). Times
//! outside $[t_p, t_n]$ are refused ([`SplineError::OutsideDomain`]).
//!
//! Reference: C. de Boor, *A Practical Guide to Splines* (1978);
//! L. Piegl and W. Tiller, *The NURBS Book* (1997), algorithms A2.1-A2.3, A5.1.

use faer::sparse::{SparseRowMat, SymbolicSparseRowMat};

use crate::basis::{TrajectoryBasis, check_coeffs, check_time};
use crate::error::{Result, SplineError, check_finite};

/// A B-spline basis: a degree and a knot vector.
///
/// ```
/// use splines::{BSplineBasis, TrajectoryBasis};
/// // cubic, 6 coefficients, clamped on [0, 1]
/// let basis = BSplineBasis::clamped_uniform(6, 3, 0.0, 1.0)?;
/// assert_eq!(basis.knots().len(), 10);
/// // constant coefficients give a constant curve (partition of unity)
/// let y = basis.evaluate(&[2.0; 6], &[0.0, 0.3, 1.0], 0)?;
/// assert!(y.iter().all(|v| (v - 2.0).abs() < 1e-14));
/// # Ok::<(), splines::SplineError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct BSplineBasis {
    knots: Vec<f64>,
    degree: usize,
}

impl BSplineBasis {
    /// A basis of degree `degree` on `knots`.
    ///
    /// The knots must be finite and nondecreasing, at least `2 degree + 2` of
    /// them, no knot repeated more than `degree + 1` times, and the domain
    /// $[t_p, t_n]$ must have positive length.
    pub fn new(knots: Vec<f64>, degree: usize) -> Result<Self> {
        check_finite("knots", &knots)?;
        let required = 2 * degree + 2;
        if knots.len() < required {
            return Err(SplineError::TooFewKnots {
                degree,
                required,
                actual: knots.len(),
            });
        }
        if let Some(i) = (1..knots.len()).find(|&i| knots[i] < knots[i - 1]) {
            return Err(SplineError::UnsortedKnots {
                index: i,
                value: knots[i],
                previous: knots[i - 1],
            });
        }
        let mut run = 1;
        for i in 1..knots.len() {
            run = if knots[i] == knots[i - 1] { run + 1 } else { 1 };
            if run > degree + 1 {
                return Err(SplineError::DegreeTooHigh {
                    degree,
                    reason: "a knot is repeated more than degree + 1 times",
                });
            }
        }
        let n = knots.len() - degree - 1;
        if knots[degree] >= knots[n] {
            return Err(SplineError::DegreeTooHigh {
                degree,
                reason: "the domain [t_p, t_n] is empty",
            });
        }
        Ok(Self { knots, degree })
    }

    /// The clamped (open) basis with `n_coeffs` functions on `[lo, hi]` and
    /// uniformly spaced interior knots: `degree + 1` knots at each end, so
    /// the curve starts at the first coefficient and ends at the last.
    pub fn clamped_uniform(n_coeffs: usize, degree: usize, lo: f64, hi: f64) -> Result<Self> {
        let n_intervals = uniform_intervals(n_coeffs, degree, (lo, hi), "clamped basis")?;
        let breakpoints: Vec<f64> = (0..=n_intervals).map(|i| interpolate(lo, hi, i, n_intervals)).collect();
        Self::clamped(&breakpoints, degree)
    }

    /// The clamped basis on the given nondecreasing breakpoints (the domain
    /// is `[breakpoints[0], breakpoints[last]]`, interior breakpoints become
    /// knots, possibly non-uniform or repeated).
    pub fn clamped(breakpoints: &[f64], degree: usize) -> Result<Self> {
        if breakpoints.len() < 2 {
            return Err(SplineError::TooFewKnots {
                degree,
                required: 2,
                actual: breakpoints.len(),
            });
        }
        check_finite("breakpoints", breakpoints)?;
        let (lo, hi) = (breakpoints[0], breakpoints[breakpoints.len() - 1]);
        let mut knots = Vec::with_capacity(breakpoints.len() + 2 * degree);
        knots.extend(std::iter::repeat_n(lo, degree));
        knots.extend_from_slice(breakpoints);
        knots.extend(std::iter::repeat_n(hi, degree));
        Self::new(knots, degree)
    }

    /// The uniform (unclamped, periodic-style) basis with `n_coeffs`
    /// functions whose domain $[t_p, t_n]$ is `[lo, hi]`: all knots equally
    /// spaced, extending `degree` spacings beyond each end.
    pub fn uniform(n_coeffs: usize, degree: usize, lo: f64, hi: f64) -> Result<Self> {
        let n_intervals = uniform_intervals(n_coeffs, degree, (lo, hi), "basis")?;
        let h = (hi - lo) / n_intervals as f64;
        let knots = (0..n_coeffs + degree + 1)
            .map(|i| {
                let k = i as isize - degree as isize;
                if k >= 0 && k as usize <= n_intervals {
                    interpolate(lo, hi, k as usize, n_intervals)
                } else {
                    lo + k as f64 * h
                }
            })
            .collect();
        Self::new(knots, degree)
    }

    /// The knot vector.
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// The degree $p$ (3 for cubic splines).
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// The span $s$ with $t_s \le t < t_{s+1}$, $p \le s < n$; at $t = t_n$
    /// the last nonempty span. `t` must be inside the domain.
    fn span(&self, t: f64) -> usize {
        let p = self.degree;
        let n = self.knots.len() - p - 1;
        // number of knots t_{p+1..n-1} that are <= t
        let count = self.knots[p + 1..n].partition_point(|&k| k <= t);
        let mut s = p + count;
        while s > p && self.knots[s] == self.knots[s + 1] {
            s -= 1;
        }
        s
    }

    /// [`span`](Self::span), starting from the span of the previous time:
    /// for sorted times it steps forward a few knots instead of searching.
    #[inline]
    fn span_from(&self, t: f64, prev: Option<(f64, usize)>) -> usize {
        if let Some((t_prev, mut s)) = prev
            && t >= t_prev
        {
            let last = self.knots.len() - self.degree - 2;
            for _ in 0..4 {
                if t < self.knots[s + 1] {
                    return s;
                }
                if s == last {
                    break;
                }
                s += 1;
            }
        }
        self.span(t)
    }

    /// Values of the `order`-th derivative of the $p + 1$ functions
    /// $N_{s-p}, \dots, N_s$ nonzero on span `s`, written to `out[..=p]`.
    /// `scratch` holds at least `2 (p + 1)` values.
    fn nonzero_funs(&self, s: usize, t: f64, order: usize, out: &mut [f64], scratch: &mut [f64]) {
        let p = self.degree;
        let knots = &self.knots;
        if order > p {
            out[..=p].fill(0.0);
            return;
        }
        let q = p - order;
        // Cox-de Boor for degree q (Piegl & Tiller A2.2), values in out[..=q];
        // unrolled for the common low degrees
        match q {
            0 => out[0] = 1.0,
            1 => cox_de_boor_fixed::<1>(knots, s, t, out),
            2 => cox_de_boor_fixed::<2>(knots, s, t, out),
            3 => cox_de_boor_fixed::<3>(knots, s, t, out),
            4 => cox_de_boor_fixed::<4>(knots, s, t, out),
            5 => cox_de_boor_fixed::<5>(knots, s, t, out),
            _ => {
                let (left, right) = scratch.split_at_mut(p + 1);
                cox_de_boor(&knots[s + 1 - q..=s + q], q, t, left, right, out);
            }
        }
        // raise degree d-1 -> d by the derivative rule, in place from the top
        for d in q + 1..=p {
            let df = d as f64;
            // new[i] for function f = s - d + i, i = 0..=d; old[i'] for function s-d+1+i'
            let mut i = d;
            loop {
                let f = s + i - d;
                let a = if i >= 1 {
                    let den = knots[f + d] - knots[f];
                    if den > 0.0 { out[i - 1] / den } else { 0.0 }
                } else {
                    0.0
                };
                let b = if i < d {
                    let den = knots[f + d + 1] - knots[f + 1];
                    if den > 0.0 { out[i] / den } else { 0.0 }
                } else {
                    0.0
                };
                out[i] = df * (a - b);
                if i == 0 {
                    break;
                }
                i -= 1;
            }
        }
    }

    /// Inserts the knot `t` once (Boehm's algorithm), returning the refined
    /// basis and the coefficients that represent the same curve on it.
    ///
    /// `t` must lie strictly inside the domain and not already have
    /// multiplicity `degree + 1`.
    pub fn insert_knot(&self, t: f64, coeffs: &[f64]) -> Result<(Self, Vec<f64>)> {
        check_coeffs(self.n_coeffs(), coeffs)?;
        let (refined, mut out) = self.insert_knot_multi(t, &[coeffs])?;
        Ok((refined, out.pop().unwrap_or_default()))
    }

    /// [`insert_knot`](Self::insert_knot) for several coefficient vectors
    /// (channels) sharing this basis.
    pub fn insert_knot_multi(&self, t: f64, channels: &[&[f64]]) -> Result<(Self, Vec<Vec<f64>>)> {
        let (lo, hi) = self.domain();
        check_time(t, (lo, hi))?;
        if t == lo || t == hi {
            return Err(SplineError::InvalidParameter {
                name: "t",
                reason: format!("knot insertion needs a time strictly inside the domain ({lo}, {hi}), got {t}"),
            });
        }
        let p = self.degree;
        let multiplicity = self.knots.iter().filter(|&&k| k == t).count();
        if multiplicity > p {
            return Err(SplineError::InvalidParameter {
                name: "t",
                reason: format!("knot {t} already has the maximal multiplicity {}", p + 1),
            });
        }
        for c in channels {
            check_coeffs(self.n_coeffs(), c)?;
        }
        // span k with t_k <= t < t_{k+1}
        let k = p + self.knots[p + 1..self.knots.len() - p - 1].partition_point(|&x| x <= t);
        let mut knots = Vec::with_capacity(self.knots.len() + 1);
        knots.extend_from_slice(&self.knots[..=k]);
        knots.push(t);
        knots.extend_from_slice(&self.knots[k + 1..]);
        let n = self.n_coeffs();
        let new_channels = channels
            .iter()
            .map(|c| {
                (0..=n)
                    .map(|i| {
                        if i + p <= k {
                            c[i]
                        } else if i > k {
                            c[i - 1]
                        } else {
                            let a = (t - self.knots[i]) / (self.knots[i + p] - self.knots[i]);
                            (1.0 - a) * c[i - 1] + a * c[i]
                        }
                    })
                    .collect()
            })
            .collect();
        Ok((Self { knots, degree: p }, new_channels))
    }
}

impl TrajectoryBasis for BSplineBasis {
    fn n_coeffs(&self) -> usize {
        self.knots.len() - self.degree - 1
    }

    fn domain(&self) -> (f64, f64) {
        (self.knots[self.degree], self.knots[self.n_coeffs()])
    }

    fn max_nonzeros(&self) -> usize {
        self.degree + 1
    }

    fn basis_row(&self, t: f64, order: usize, row: &mut Vec<(usize, f64)>) -> Result<()> {
        check_time(t, self.domain())?;
        let p = self.degree;
        let s = self.span(t);
        // degree <= 15 on the stack, higher on the heap
        let mut stack = [0.0; 48];
        let mut heap = Vec::new();
        let vals: &mut [f64] = if 3 * (p + 1) <= stack.len() {
            &mut stack
        } else {
            heap.resize(3 * (p + 1), 0.0);
            &mut heap
        };
        let (out, scratch) = vals.split_at_mut(p + 1);
        self.nonzero_funs(s, t, order, &mut out[..=p], scratch);
        row.clear();
        row.extend(out.iter().enumerate().map(|(i, &v)| (s - p + i, v)));
        Ok(())
    }

    /// Direct assembly: spans found incrementally when `times` are sorted
    /// (by binary search otherwise), values written straight into the
    /// matrix storage.
    fn design_matrix_rows(&self, times: &[f64], order: usize) -> Result<SparseRowMat<usize, f64>> {
        check_finite("times", times)?;
        let domain = self.domain();
        let p = self.degree;
        let w = p + 1;
        let n = self.n_coeffs();
        let mut col_idx = Vec::with_capacity(times.len() * w);
        let mut val = Vec::with_capacity(times.len() * w);
        let mut buf = vec![0.0; 3 * w];
        let (row, scratch) = buf.split_at_mut(w);
        let mut prev: Option<(f64, usize)> = None;
        for &t in times {
            check_time(t, domain)?;
            let s = self.span_from(t, prev);
            prev = Some((t, s));
            self.nonzero_funs(s, t, order, row, scratch);
            val.extend_from_slice(row);
            col_idx.extend(s - p..=s);
        }
        let row_ptr = (0..=times.len()).map(|k| k * w).collect();
        let symbolic = SymbolicSparseRowMat::new_checked(times.len(), n, row_ptr, None, col_idx);
        Ok(SparseRowMat::new(symbolic, val))
    }

    fn evaluate(&self, coeffs: &[f64], times: &[f64], order: usize) -> Result<Vec<f64>> {
        check_coeffs(self.n_coeffs(), coeffs)?;
        check_finite("times", times)?;
        let domain = self.domain();
        let p = self.degree;
        let mut vals = vec![0.0; 3 * (p + 1)];
        let (out, scratch) = vals.split_at_mut(p + 1);
        let mut prev = None;
        times
            .iter()
            .map(|&t| {
                check_time(t, domain)?;
                let s = self.span_from(t, prev);
                prev = Some((t, s));
                self.nonzero_funs(s, t, order, out, scratch);
                Ok(out.iter().zip(&coeffs[s - p..=s]).map(|(v, c)| v * c).sum())
            })
            .collect()
    }
}

/// Cox-de Boor for a degree `Q` known at compile time (loops unrolled).
#[inline(always)]
fn cox_de_boor_fixed<const Q: usize>(knots: &[f64], s: usize, t: f64, out: &mut [f64]) {
    let mut left = [0.0; 6];
    let mut right = [0.0; 6];
    let mut n = [0.0; 6];
    cox_de_boor(&knots[s + 1 - Q..=s + Q], Q, t, &mut left, &mut right, &mut n);
    out[..=Q].copy_from_slice(&n[..=Q]);
}

/// Cox-de Boor (Piegl & Tiller A2.2): the values at `t` of the `q + 1`
/// degree-`q` functions nonzero on span $s$, into `n[..=q]`, from the knots
/// around it, `lo` $= t_{s+1-q}, \dots, t_{s+q}$; `left` and `right` are
/// scratch of `q + 1` values. Inlined, so that [`cox_de_boor_fixed`]'s
/// constant degree unrolls the loops.
#[inline(always)]
fn cox_de_boor(lo: &[f64], q: usize, t: f64, left: &mut [f64], right: &mut [f64], n: &mut [f64]) {
    n[0] = 1.0;
    for j in 1..=q {
        left[j] = t - lo[q - j];
        right[j] = lo[q + j - 1] - t;
        let mut saved = 0.0;
        for r in 0..j {
            let temp = n[r] / (right[r + 1] + left[j - r]);
            n[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        n[j] = saved;
    }
}

/// Checks the arguments of a uniform basis (`what`, for the message) of
/// `n_coeffs` functions of degree `degree` on `[lo, hi]`, and returns its
/// number of knot intervals inside the domain.
fn uniform_intervals(n_coeffs: usize, degree: usize, (lo, hi): (f64, f64), what: &str) -> Result<usize> {
    check_interval(lo, hi)?;
    if n_coeffs < degree + 1 {
        return Err(SplineError::InvalidParameter {
            name: "n_coeffs",
            reason: format!(
                "a degree-{degree} {what} needs at least {} coefficients, got {n_coeffs}",
                degree + 1
            ),
        });
    }
    Ok(n_coeffs - degree)
}

fn check_interval(lo: f64, hi: f64) -> Result<()> {
    check_finite("interval", &[lo, hi])?;
    if lo >= hi {
        return Err(SplineError::InvalidParameter {
            name: "interval",
            reason: format!("need lo < hi, got [{lo}, {hi}]"),
        });
    }
    Ok(())
}

/// `lo + i (hi - lo) / n`, exact at both ends.
fn interpolate(lo: f64, hi: f64, i: usize, n: usize) -> f64 {
    if i == n {
        hi
    } else {
        lo + (hi - lo) * (i as f64 / n as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dense(basis: &BSplineBasis, t: f64, order: usize) -> Vec<f64> {
        let mut row = Vec::new();
        basis.basis_row(t, order, &mut row).expect("inside domain");
        let mut out = vec![0.0; basis.n_coeffs()];
        for (j, v) in row {
            out[j] = v;
        }
        out
    }

    #[test]
    fn linear_basis_is_hat_functions() {
        // degree 1 on knots 0,0,1,2,2: hats at 0, 1, 2
        let b = BSplineBasis::new(vec![0.0, 0.0, 1.0, 2.0, 2.0], 1).expect("valid");
        assert_eq!(dense(&b, 0.5, 0), vec![0.5, 0.5, 0.0]);
        assert_eq!(dense(&b, 1.5, 0), vec![0.0, 0.5, 0.5]);
        assert_eq!(dense(&b, 2.0, 0), vec![0.0, 0.0, 1.0]);
        assert_eq!(dense(&b, 1.5, 1), vec![0.0, -1.0, 1.0]);
        assert_eq!(dense(&b, 1.5, 2), vec![0.0, 0.0, 0.0]);
    }

    #[test]
    fn cubic_bezier_is_bernstein() {
        // clamped cubic with one interval = Bernstein polynomials
        let b = BSplineBasis::clamped_uniform(4, 3, 0.0, 1.0).expect("valid");
        let t: f64 = 0.3;
        let s = 1.0 - t;
        let expect = [s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t];
        let got = dense(&b, t, 0);
        for (g, e) in got.iter().zip(expect) {
            assert!((g - e).abs() < 1e-15, "{got:?}");
        }
        // derivatives of Bernstein: 3 [B_{i-1,2} - B_{i,2}]
        let d = [
            -3.0 * s * s,
            3.0 * (s * s - 2.0 * t * s),
            3.0 * (2.0 * t * s - t * t),
            3.0 * t * t,
        ];
        for (g, e) in dense(&b, t, 1).iter().zip(d) {
            assert!((g - e).abs() < 1e-14);
        }
        // third derivative of t^3 is 6
        assert!((dense(&b, t, 3)[3] - 6.0).abs() < 1e-12);
    }

    #[test]
    fn rejects_bad_knots() {
        assert!(matches!(
            BSplineBasis::new(vec![0.0, 1.0, 0.5, 2.0], 1),
            Err(SplineError::UnsortedKnots { index: 2, .. })
        ));
        assert!(matches!(
            BSplineBasis::new(vec![0.0, 1.0, 2.0], 1),
            Err(SplineError::TooFewKnots { .. })
        ));
        assert!(matches!(
            BSplineBasis::new(vec![0.0, 1.0, 1.0, 1.0, 2.0, 3.0], 1),
            Err(SplineError::DegreeTooHigh { .. })
        ));
        assert!(matches!(
            BSplineBasis::new(vec![0.0, f64::NAN, 1.0, 2.0], 1),
            Err(SplineError::NotFinite { .. })
        ));
        assert!(matches!(
            BSplineBasis::clamped_uniform(3, 3, 0.0, 1.0),
            Err(SplineError::InvalidParameter { .. })
        ));
    }

    #[test]
    fn refuses_outside_domain() {
        let b = BSplineBasis::clamped_uniform(6, 3, 0.0, 1.0).expect("valid");
        assert!(matches!(
            b.evaluate(&[0.0; 6], &[1.0 + 1e-12], 0),
            Err(SplineError::OutsideDomain { .. })
        ));
        assert!(matches!(
            b.design_matrix(&[-0.1], 0),
            Err(SplineError::OutsideDomain { .. })
        ));
        assert!(matches!(
            b.evaluate(&[0.0; 6], &[f64::NAN], 0),
            Err(SplineError::NotFinite { .. })
        ));
        assert!(matches!(
            b.evaluate(&[0.0; 5], &[0.5], 0),
            Err(SplineError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn uniform_basis_domain() {
        let b = BSplineBasis::uniform(7, 3, 0.0, 2.0).expect("valid");
        assert_eq!(b.domain(), (0.0, 2.0));
        assert_eq!(b.knots().len(), 11);
        // uniform cubic B-spline at a knot: 1/6, 4/6, 1/6
        let row = dense(&b, 0.5, 0);
        let nz: Vec<f64> = row.into_iter().filter(|v| *v != 0.0).collect();
        assert_eq!(nz.len(), 3);
        assert!((nz[1] - 4.0 / 6.0).abs() < 1e-15);
    }
}
