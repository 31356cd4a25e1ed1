//! DDP on the pendulum (n = 2) and cart-pole (n = 4) swing-ups over
//! horizons 100 to 5000: whole solves (default settings, to convergence or
//! the iteration cap) and runs capped at 3 iterations (both problems need
//! more, so all 3 are real descent iterations, line searches included),
//! whose throughput is knot-iterations per second.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use ddp::problems::{cartpole_swingup, pendulum_swingup};
use ddp::{Cost, Ddp, DdpProblem, DdpSettings, Dynamics};

const HORIZONS: [usize; 4] = [100, 500, 1000, 5000];
const FIXED_ITERATIONS: usize = 3;

fn bench_system<D: Dynamics, C: Cost>(c: &mut Criterion, name: &str, make: impl Fn(usize) -> DdpProblem<D, C>) {
    let solve = Ddp::new(DdpSettings::default()).expect("settings");
    let fixed = Ddp::new(DdpSettings {
        max_iterations: FIXED_ITERATIONS,
        ..DdpSettings::default()
    })
    .expect("settings");
    for horizon in HORIZONS {
        let r = fixed.solve(&make(horizon)).expect("solve");
        assert_eq!(r.iterations, FIXED_ITERATIONS, "{name} N={horizon} converged early");
    }
    let mut group = c.benchmark_group(format!("{name}/solve"));
    group.sample_size(10).measurement_time(Duration::from_secs(3));
    for horizon in HORIZONS {
        let problem = make(horizon);
        group.bench_with_input(BenchmarkId::from_parameter(horizon), &problem, |b, p| {
            b.iter(|| solve.solve(black_box(p)).expect("solve"))
        });
    }
    group.finish();
    let mut group = c.benchmark_group(format!("{name}/{FIXED_ITERATIONS}_iterations"));
    group.sample_size(10).measurement_time(Duration::from_secs(3));
    for horizon in HORIZONS {
        let problem = make(horizon);
        group.throughput(Throughput::Elements((horizon * FIXED_ITERATIONS) as u64));
        group.bench_with_input(BenchmarkId::from_parameter(horizon), &problem, |b, p| {
            b.iter(|| fixed.solve(black_box(p)).expect("solve"))
        });
    }
    group.finish();
}

fn benches(c: &mut Criterion) {
    bench_system(c, "pendulum", |h| pendulum_swingup(h).expect("problem"));
    bench_system(c, "cartpole", |h| cartpole_swingup(h).expect("problem"));
}

criterion_group!(ddp_benches, benches);
criterion_main!(ddp_benches);
