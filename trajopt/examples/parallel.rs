//! One plan on two threads: `GaussNewton::solve_parallel` forms the normal
//! equations (most of an iteration) in parts on helper threads and, on two
//! threads, also factorises them in two parts. The answer is the same as
//! one thread's to rounding; the time is what changes, from a horizon of a
//! few hundred steps on (on a busy machine the helpers may wait for cores,
//! and the solve goes on with one thread: `one_thread_from` says when).
//!
//! `cargo run --release -p nprl-trajopt --example parallel`

use std::time::Instant;

use trajopt::problems::pendulum_swingup;
use trajopt::{GaussNewton, GaussNewtonSettings};

fn main() -> anyhow::Result<()> {
    let solver = GaussNewton::new(GaussNewtonSettings::default())?;
    for horizon in [200, 1000, 5000] {
        let (problem, theta0) = pendulum_swingup(horizon, 10.0)?;
        let start = Instant::now();
        let one = solver.solve(&problem, &theta0)?;
        let t_one = start.elapsed();
        let start = Instant::now();
        let two = solver.solve_parallel(&problem, &theta0, 2)?;
        let t_two = start.elapsed();
        println!(
            "horizon {horizon:>4}: one thread {:.1} ms, two threads {:.1} ms ({:.2}x); costs {:.9e} and {:.9e}, \
             {} and {} iterations{}",
            t_one.as_secs_f64() * 1e3,
            t_two.as_secs_f64() * 1e3,
            t_one.as_secs_f64() / t_two.as_secs_f64(),
            one.cost,
            two.cost,
            one.iterations,
            two.iterations,
            two.one_thread_from
                .map_or(String::new(), |k| format!(" (one thread from iteration {k})"))
        );
    }
    Ok(())
}
