//! Criterion benchmarks of the LWR model over database sizes.
//!
//! `cargo bench -p lwr`: single queries (with confidence, with the
//! Jacobian, and under a full metric), parallel batches, inserts,
//! leave-one-out and tuning (with and without stopping hopeless evaluations
//! early; the default search on $10^4$ points in 5-D in `tune_large`), for
//! $10^3$ to $10^5$ uniform points in 2 and 5 dimensions. The tricube
//! bandwidth is chosen so that about 50 points carry weight at every size,
//! so a query should grow like $\log n$ (tree descent) plus a constant fit.
//! And `query_wide`: a path of 50 queries with their Jacobians under a
//! bandwidth whose support holds a large part of the data (a near-global
//! tuned fit), where a query costs its many neighbours.

use std::hint::black_box;

use criterion::{BatchSize, BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use lwr::{Kernel, LwrModel, LwrSettings, TuneSettings};

mod common;
use common::new_group;

const SIZES: [usize; 3] = [1_000, 10_000, 100_000];
const DIMS: [usize; 2] = [2, 5];
/// Expected number of points inside the kernel's support.
const NEIGHBOURS: f64 = 50.0;

struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn points(n: usize, d: usize, seed: u64) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let mut r = Lcg(seed);
    let xs: Vec<Vec<f64>> = (0..n).map(|_| (0..d).map(|_| r.next()).collect()).collect();
    let ys = xs
        .iter()
        .map(|x| vec![(6.0 * x[0]).sin() + x[1] * x[1] + 0.05 * r.next()])
        .collect();
    (xs, ys)
}

/// Tricube bandwidth with about `NEIGHBOURS` points in the unit ball of radius h.
fn bandwidth(n: usize, d: usize) -> f64 {
    let unit_ball = match d {
        2 => std::f64::consts::PI,
        5 => 8.0 * std::f64::consts::PI.powi(2) / 15.0,
        _ => 1.0,
    };
    (NEIGHBOURS / (n as f64 * unit_ball)).powf(1.0 / d as f64)
}

fn model(n: usize, d: usize) -> LwrModel {
    let settings = LwrSettings {
        kernel: Kernel::Tricube,
        bandwidth: bandwidth(n, d),
        ..Default::default()
    };
    let (xs, ys) = points(n, d, 42);
    let mut m = LwrModel::new(d, 1, settings).expect("valid settings");
    m.insert_many(&xs, &ys).expect("finite data");
    m
}

fn queries(c: &mut Criterion) {
    let mut group = new_group(c, "query", 20, 300, 1);
    for d in DIMS {
        for n in SIZES {
            let m = model(n, d);
            let q = vec![0.5; d];
            let id = format!("d{d}");
            group.bench_with_input(BenchmarkId::new(format!("predict_{id}"), n), &q, |b, q| {
                b.iter(|| m.predict(black_box(q)).expect("weighted"))
            });
            group.bench_with_input(BenchmarkId::new(format!("jacobian_{id}"), n), &q, |b, q| {
                b.iter(|| m.predict_with_jacobian(black_box(q)).expect("weighted"))
            });
            // the same support under a full metric: a rotation in the plane
            // of the first two inputs
            let mut full = m.clone();
            let (c, s) = (0.6, 0.8);
            let mut matrix = vec![0.0; d * d];
            for j in 0..d {
                matrix[j * d + j] = 1.0;
            }
            matrix[..2].copy_from_slice(&[c, -s]);
            matrix[d..d + 2].copy_from_slice(&[s, c]);
            full.set_settings(LwrSettings {
                metric: matrix,
                ..m.settings().clone()
            })
            .expect("valid");
            group.bench_with_input(BenchmarkId::new(format!("predict_full_metric_{id}"), n), &q, |b, q| {
                b.iter(|| full.predict(black_box(q)).expect("weighted"))
            });
        }
    }
    group.finish();

    // a wide support, as a tuned metric can make it (the pendulum's late
    // models: near-global fits): a tricube bandwidth whose support holds
    // about three quarters of the data (printed), queried along a path as
    // a planner queries (each query's support alike the last one's)
    let mut group = new_group(c, "query_wide", 20, 300, 1);
    for n in [1_000, 10_000] {
        let d = 5;
        let mut m = model(n, d);
        let settings = LwrSettings {
            bandwidth: 0.9,
            ..m.settings().clone()
        };
        m.set_settings(settings).expect("valid");
        let path: Vec<Vec<f64>> = (0..50)
            .map(|k| {
                (0..d)
                    .map(|j| 0.3 + 0.4 * (k as f64 / 49.0) * (1.0 - 0.1 * j as f64))
                    .collect()
            })
            .collect();
        let found = m.predict(&path[0]).expect("weighted").n_neighbors;
        eprintln!("query_wide: n = {n}, {found} neighbours at the path's start");
        group.throughput(Throughput::Elements(path.len() as u64));
        group.bench_with_input(BenchmarkId::new("jacobian_path_of_50_d5", n), &path, |b, path| {
            b.iter(|| {
                for q in path {
                    black_box(m.predict_mean_with_jacobian(black_box(q)).expect("weighted"));
                }
            })
        });
    }
    group.finish();

    let mut group = new_group(c, "batch", 10, 300, 1);
    for d in DIMS {
        for n in SIZES {
            let m = model(n, d);
            let (qs, _) = points(1000, d, 7);
            let qs: Vec<Vec<f64>> = qs
                .into_iter()
                .map(|q| q.iter().map(|v| 0.1 + 0.8 * v).collect())
                .collect();
            group.throughput(Throughput::Elements(qs.len() as u64));
            group.bench_with_input(BenchmarkId::new(format!("predict_1000_d{d}"), n), &qs, |b, qs| {
                b.iter(|| m.predict_batch(black_box(qs)))
            });
        }
    }
    group.finish();
}

fn inserts(c: &mut Criterion) {
    let mut group = new_group(c, "insert", 10, 300, 1);
    for d in DIMS {
        for n in SIZES {
            let m = model(n, d);
            let (xs, ys) = points(1000, d, 9);
            group.throughput(Throughput::Elements(1000));
            group.bench_function(BenchmarkId::new(format!("1000_into_d{d}"), n), |b| {
                b.iter_batched(
                    || m.clone(),
                    |mut m| {
                        for (x, y) in xs.iter().zip(&ys) {
                            m.insert(x, y).expect("finite");
                        }
                        m
                    },
                    BatchSize::LargeInput,
                )
            });
        }
    }
    group.finish();
}

fn cross_validation(c: &mut Criterion) {
    let mut group = new_group(c, "loo", 10, 300, 2);
    for d in DIMS {
        for n in [1_000, 10_000] {
            let m = model(n, d);
            group.throughput(Throughput::Elements(n as u64));
            group.bench_function(BenchmarkId::new(format!("d{d}"), n), |b| {
                b.iter(|| m.loo().expect("nonempty"))
            });
        }
    }
    group.finish();

    let mut group = new_group(c, "tune", 10, 300, 3);
    let m = model(500, 2);
    let tune = TuneSettings {
        max_evals: 30,
        ..Default::default()
    };
    group.bench_function("n500_d2_30evals", |b| b.iter(|| m.tune(&tune).expect("valid")));
    // the same search with and without stopping hopeless evaluations early
    // (same result either way)
    for n in [500, 2_000] {
        let m = model(n, 2);
        for stop_early in [true, false] {
            let tune = TuneSettings {
                max_evals: 30,
                stop_early,
                ..Default::default()
            };
            let name = if stop_early {
                "d2_30evals_stop_early"
            } else {
                "d2_30evals_full"
            };
            group.bench_with_input(BenchmarkId::new(name, n), &tune, |b, tune| {
                b.iter(|| m.tune(tune).expect("valid"))
            });
        }
    }
    group.finish();

    // the default search on 10^4 points in 5 dimensions (the query benches'
    // data), and the same search cross-validating 2000 of the points
    let mut group = new_group(c, "tune_large", 10, 100, 30);
    let m = model(10_000, 5);
    group.bench_function("n10000_d5_default", |b| {
        b.iter(|| m.tune(&TuneSettings::default()).expect("valid"))
    });
    // the search over 2000 of the points, then the start and the result
    // over all of them
    let tune = TuneSettings {
        search_points: 2_000,
        ..Default::default()
    };
    group.bench_function("n10000_d5_search_points_2000", |b| {
        b.iter(|| m.tune(&tune).expect("valid"))
    });
    group.finish();
}

criterion_group!(benches, queries, inserts, cross_validation);
criterion_main!(benches);
