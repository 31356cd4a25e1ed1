//! Powell's method: time per solve on the classic problems, and the solver's
//! overhead per cost evaluation (with a trivial objective, reported as
//! throughput in evaluations per second).
//!
//! `cargo bench -p trajopt --bench powell`

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use trajopt::powell::{Powell, PowellSettings};

fn rosenbrock(x: &[f64]) -> trajopt::Result<f64> {
    Ok(trajopt::problems::rosenbrock(x))
}

fn powell_singular(x: &[f64]) -> trajopt::Result<f64> {
    Ok(trajopt::problems::powell_singular(x))
}

/// A separable quadratic: as cheap as an objective gets.
fn trivial(x: &[f64]) -> trajopt::Result<f64> {
    Ok(x.iter().map(|v| (v - 1.0) * (v - 1.0)).sum())
}

fn extended_start(n: usize) -> Vec<f64> {
    (0..n).map(|i| if i % 2 == 0 { -1.2 } else { 1.0 }).collect()
}

fn solve_time(c: &mut Criterion) {
    let powell = Powell::new(PowellSettings::default()).expect("default settings");
    let mut group = c.benchmark_group("powell_solve");
    group.sample_size(20);
    for n in [2, 10, 50] {
        let x0 = extended_start(n);
        group.bench_with_input(BenchmarkId::new("rosenbrock", n), &x0, |b, x0| {
            b.iter(|| powell.solve(&rosenbrock, black_box(x0)).expect("solve"));
        });
    }
    let x0 = [3.0, -1.0, 0.0, 1.0];
    group.bench_with_input(BenchmarkId::new("powell_singular", 4), &x0, |b, x0| {
        b.iter(|| powell.solve(&powell_singular, black_box(x0)).expect("solve"));
    });
    group.finish();
}

fn overhead_per_evaluation(c: &mut Criterion) {
    let mut group = c.benchmark_group("powell_overhead_per_eval");
    for n in [2, 10, 50] {
        // deterministic: every solve does the same evaluations (two or
        // three sweeps), counted once for the throughput
        let powell = Powell::new(PowellSettings::default()).expect("settings");
        let x0 = vec![-3.0; n];
        let evals = powell.solve(&trivial, &x0).expect("solve").evals;
        group.throughput(Throughput::Elements(evals as u64));
        group.bench_with_input(BenchmarkId::new("trivial", n), &x0, |b, x0| {
            b.iter(|| powell.solve(&trivial, black_box(x0)).expect("solve"));
        });
    }
    group.finish();
}

criterion_group!(benches, solve_time, overhead_per_evaluation);
criterion_main!(benches);
