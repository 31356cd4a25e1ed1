//! What the crate's benches share.

use std::time::Duration;

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion};

/// A benchmark group of `samples` samples, warmed up for `warm_up_ms`
/// milliseconds and measured for `measurement_s` seconds.
pub(crate) fn new_group<'a>(
    c: &'a mut Criterion,
    name: &str,
    samples: usize,
    warm_up_ms: u64,
    measurement_s: u64,
) -> BenchmarkGroup<'a, WallTime> {
    let mut group = c.benchmark_group(name);
    group
        .sample_size(samples)
        .warm_up_time(Duration::from_millis(warm_up_ms))
        .measurement_time(Duration::from_secs(measurement_s));
    group
}
