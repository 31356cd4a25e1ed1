//! Proptest strategies for users who property-test code built on this crate
//! (enabled by the `proptest` feature). The crate's own property tests use them.
//!
//! Every strategy generates *valid* input: sorted knot vectors with a
//! nonempty domain, degrees the knot vector supports, sample times inside
//! the domain, and signals of any length (odd lengths included).

use proptest::collection::vec;
use proptest::prelude::*;

use crate::BSplineBasis;

/// A spline degree in `0..=max`.
pub fn degree(max: usize) -> impl Strategy<Value = usize> {
    0..=max
}

/// A valid knot vector for `degree` with `n_coeffs` functions on `[lo, hi]`:
/// clamped, uniform (unclamped), or clamped with random non-uniform interior
/// knots, some of them repeated up to `max_multiplicity` times (capped at
/// the degree, so the basis stays continuous).
pub fn knot_vector(
    degree: usize,
    n_coeffs: std::ops::Range<usize>,
    max_multiplicity: usize,
) -> impl Strategy<Value = Vec<f64>> {
    let lo_n = n_coeffs.start.max(degree + 1);
    let hi_n = n_coeffs.end.max(lo_n + 1);
    let max_mult = max_multiplicity.clamp(1, degree.max(1));
    (lo_n..hi_n, 0..3u8, -2.0..2.0f64, 0.1..5.0f64)
        .prop_flat_map(move |(n, kind, lo, width)| {
            let hi = lo + width;
            let n_interior = n - degree - 1;
            let interior = vec((0.001..0.999f64, 1..=max_mult), n_interior);
            (Just((n, kind, lo, hi)), interior).prop_map(move |((n, kind, lo, hi), interior)| {
                match kind {
                    0 => BSplineBasis::clamped_uniform(n, degree, lo, hi).map(|b| b.knots().to_vec()),
                    1 => BSplineBasis::uniform(n, degree, lo, hi).map(|b| b.knots().to_vec()),
                    _ => {
                        // interior knots with multiplicities, trimmed to n - p - 1 knots
                        let mut knots: Vec<f64> = Vec::with_capacity(n + degree + 1);
                        for (u, m) in interior {
                            knots.extend(std::iter::repeat_n(lo + u * (hi - lo), m));
                        }
                        knots.sort_by(f64::total_cmp);
                        knots.truncate(n - degree - 1);
                        let mut full = vec![lo; degree + 1];
                        full.extend(knots);
                        full.extend(std::iter::repeat_n(hi, degree + 1));
                        Ok(full)
                    }
                }
                .unwrap_or_else(|_| vec![])
            })
        })
        .prop_filter("valid knot vector", move |k| {
            BSplineBasis::new(k.clone(), degree).is_ok()
        })
}

/// A valid B-spline basis of degree `0..=max_degree` with `n_coeffs`
/// functions (see [`knot_vector`]).
pub fn bspline_basis(
    max_degree: usize,
    n_coeffs: std::ops::Range<usize>,
    max_multiplicity: usize,
) -> impl Strategy<Value = BSplineBasis> {
    degree(max_degree).prop_flat_map(move |p| {
        knot_vector(p, n_coeffs.clone(), max_multiplicity)
            .prop_filter_map("valid basis", move |k| BSplineBasis::new(k, p).ok())
    })
}

/// A finite signal of length in `len` (any length, odd ones included), with
/// values in `[-10, 10]`.
pub fn signal(len: std::ops::Range<usize>) -> impl Strategy<Value = Vec<f64>> {
    vec(-10.0..10.0f64, len)
}

/// `n` sample times drawn uniformly inside `[lo, hi]`, sorted, both ends
/// included with some probability (the right end is where off-by-one bugs live).
pub fn sample_times(lo: f64, hi: f64, n: std::ops::Range<usize>) -> impl Strategy<Value = Vec<f64>> {
    vec(prop_oneof![8 => 0.0..=1.0f64, 1 => Just(0.0), 1 => Just(1.0)], n).prop_map(move |mut u| {
        u.sort_by(f64::total_cmp);
        u.into_iter().map(|s| lo + s * (hi - lo)).collect()
    })
}
