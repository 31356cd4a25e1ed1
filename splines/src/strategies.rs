//! [proptest] strategies for users who property-test code built on this crate
//! (enabled by the `proptest` feature). The crate's own property tests use them.
//!
//! Every strategy generates *valid* input: sorted knot vectors with a
//! nonempty domain, degrees the knot vector supports, sample times inside
//! the domain, and signals of any length (odd lengths included).

use proptest::collection::vec;
use proptest::prelude::*;

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
