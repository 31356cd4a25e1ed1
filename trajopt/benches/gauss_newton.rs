//! Criterion benchmarks of the sparse Gauss-Newton solver on the benchmark
//! pendulum swing-up (`trajopt::problems`) over horizons: one iteration (to
//! show linear growth with the horizon; it includes the symbolic setup) and
//! a full solve, Gauss-Newton, Newton (`StepModel::Newton`) and the adaptive
//! choice between the two (`StepModel::Adaptive`); and the Newton mode with the normal
//! equations formed on two threads (`solve_parallel`).
//!
//! `cargo bench -p trajopt --bench gauss_newton`

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use trajopt::problems::pendulum_swingup;
use trajopt::{GaussNewton, GaussNewtonSettings, StepModel};

fn gauss_newton(c: &mut Criterion) {
    let mut group = c.benchmark_group("gauss_newton_pendulum");
    group.sample_size(10);
    let one = GaussNewton::new(GaussNewtonSettings {
        max_iterations: 1,
        ..GaussNewtonSettings::default()
    })
    .expect("settings");
    let full = GaussNewton::new(GaussNewtonSettings::default()).expect("settings");
    let newton = GaussNewton::new(GaussNewtonSettings {
        step_model: StepModel::Newton,
        ..GaussNewtonSettings::default()
    })
    .expect("settings");
    let adaptive = GaussNewton::new(GaussNewtonSettings {
        step_model: StepModel::Adaptive,
        ..GaussNewtonSettings::default()
    })
    .expect("settings");
    for horizon in [50, 150, 500, 1000, 5000, 20000] {
        let (problem, theta0) = pendulum_swingup(horizon, 1e2).expect("problem");
        group.throughput(Throughput::Elements(horizon as u64));
        group.bench_with_input(BenchmarkId::new("one_iteration", horizon), &theta0, |b, t| {
            b.iter(|| one.solve(&problem, black_box(t)).expect("solve"))
        });
        if horizon <= 1000 {
            group.bench_with_input(BenchmarkId::new("solve", horizon), &theta0, |b, t| {
                b.iter(|| full.solve(&problem, black_box(t)).expect("solve"))
            });
        }
        if horizon <= 5000 {
            group.bench_with_input(BenchmarkId::new("solve_newton", horizon), &theta0, |b, t| {
                b.iter(|| newton.solve(&problem, black_box(t)).expect("solve"))
            });
            group.bench_with_input(BenchmarkId::new("solve_adaptive", horizon), &theta0, |b, t| {
                b.iter(|| adaptive.solve(&problem, black_box(t)).expect("solve"))
            });
            group.bench_with_input(BenchmarkId::new("solve_newton_2_threads", horizon), &theta0, |b, t| {
                b.iter(|| newton.solve_parallel(&problem, black_box(t), 2).expect("solve"))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, gauss_newton);
criterion_main!(benches);
