//! Criterion benchmarks of the trajectory bases over problem sizes.
//!
//! `cargo bench -p splines`: B-spline design-matrix assembly, evaluation
//! and least-squares fits for 10^2 to 10^5 samples at degrees 3 and 5, and
//! wavelet analysis and synthesis (db4, symmetric and periodization modes).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use splines::wavelet::{Boundary, Wavelet, WaveletBasis, WaveletTransform, wavedec};
use splines::{BSplineBasis, FitSettings, TrajectoryBasis, fit_channel};
use std::hint::black_box;

const SIZES: [usize; 4] = [100, 1_000, 10_000, 100_000];

/// Sorted sample times on [0, 1] with a deterministic jitter.
fn times(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| ((k as f64 + 0.5 + 0.3 * (1.7 * k as f64).sin()) / n as f64).clamp(0.0, 1.0))
        .collect()
}

fn signal(t: &[f64]) -> Vec<f64> {
    t.iter().map(|&x| (7.0 * x).sin() + 0.1 * (53.0 * x).cos()).collect()
}

/// One coefficient per ten samples, as a smoothing fit would use.
fn basis(n: usize, degree: usize) -> BSplineBasis {
    BSplineBasis::clamped_uniform((n / 10).max(degree + 1), degree, 0.0, 1.0).expect("valid basis")
}

fn bspline(c: &mut Criterion) {
    for degree in [3, 5] {
        let mut group = c.benchmark_group(format!("bspline_degree{degree}"));
        for n in SIZES {
            let t = times(n);
            let y = signal(&t);
            let b = basis(n, degree);
            let coeffs = fit_channel(&b, &t, &y, &FitSettings::default()).expect("fit");
            group.throughput(Throughput::Elements(n as u64));
            group.bench_with_input(BenchmarkId::new("design_matrix_rows", n), &t, |bench, t| {
                bench.iter(|| b.design_matrix_rows(black_box(t), 0).expect("inside"))
            });
            group.bench_with_input(BenchmarkId::new("design_matrix_csc", n), &t, |bench, t| {
                bench.iter(|| b.design_matrix(black_box(t), 0).expect("inside"))
            });
            group.bench_with_input(BenchmarkId::new("evaluate", n), &t, |bench, t| {
                bench.iter(|| b.evaluate(black_box(&coeffs), black_box(t), 0).expect("inside"))
            });
            group.bench_with_input(BenchmarkId::new("fit", n), &t, |bench, t| {
                bench.iter(|| fit_channel(&b, black_box(t), black_box(&y), &FitSettings::default()).expect("fit"))
            });
        }
        group.finish();
    }
}

fn wavelets(c: &mut Criterion) {
    for boundary in [Boundary::Symmetric, Boundary::Periodization] {
        let mut group = c.benchmark_group(format!("wavelet_db4_{}", boundary.name()));
        for n in SIZES {
            let x = signal(&times(n));
            let dec = wavedec(&x, Wavelet::Db4, boundary, None).expect("valid");
            let flat = dec.to_flat();
            let mut plan = WaveletTransform::new(Wavelet::Db4, boundary, n, Some(dec.level())).expect("valid");
            let mut coeffs = vec![0.0; plan.n_coeffs()];
            let mut out = vec![0.0; n];
            group.throughput(Throughput::Elements(n as u64));
            group.bench_with_input(BenchmarkId::new("wavedec", n), &x, |bench, x| {
                bench.iter(|| wavedec(black_box(x), Wavelet::Db4, boundary, None).expect("valid"))
            });
            group.bench_with_input(BenchmarkId::new("reconstruct", n), &dec, |bench, dec| {
                bench.iter(|| dec.reconstruct().expect("valid"))
            });
            group.bench_with_input(BenchmarkId::new("analyse_into", n), &x, |bench, x| {
                bench.iter(|| plan.analyse_into(black_box(x), &mut coeffs).expect("valid"))
            });
            group.bench_with_input(BenchmarkId::new("synthesise_into", n), &flat, |bench, flat| {
                bench.iter(|| plan.synthesise_into(black_box(flat), &mut out).expect("valid"))
            });
            if n <= 10_000 {
                group.bench_with_input(BenchmarkId::new("basis_new", n), &n, |bench, &n| {
                    bench.iter(|| WaveletBasis::new(Wavelet::Db4, boundary, n, None, 0.0, 1.0).expect("valid"))
                });
            }
        }
        group.finish();
    }
}

criterion_group!(benches, bspline, wavelets);
criterion_main!(benches);
