//! Watching a solve: every solver of the workspace takes a `solve::Watch`
//! with observers, which see each iteration and may stop it, and a
//! wall-time limit checked inside it.
//!
//! Here Gauss-Newton plans the pendulum swing-up (Eq. 3) with one observer
//! printing a progress line per iteration and recording a trace, and a
//! second one stopping early once an iteration gains less than 1 % of the
//! cost; then Powell gets the same problem for 50 ms.
//!
//! `cargo run --release -p nprl-trajopt --example observer`

use std::time::Duration;

use solve::{Control, Progress, Status, Trace, Watch};
use trajopt::problems::pendulum_swingup;
use trajopt::{GaussNewton, GaussNewtonSettings, Powell, PowellSettings};

fn main() -> anyhow::Result<()> {
    let (problem, theta0) = pendulum_swingup(200, 10.0)?;

    // progress lines, a trace, and an early stop at < 1 % gain per iteration
    let mut trace = Trace::new();
    let mut last = f64::INFINITY;
    let mut enough = |p: &Progress<'_>| {
        println!(
            "{} iteration {:>3}: cost {:.6e} after {} evaluations, {:.1} ms",
            p.solver,
            p.iteration,
            p.cost,
            p.evaluations,
            p.elapsed.as_secs_f64() * 1e3
        );
        let gain = (last - p.cost) / p.cost;
        last = p.cost;
        if gain < 0.01 { Control::Stop } else { Control::Continue }
    };
    let mut watch = Watch::new().with_observer(&mut trace).with_observer(&mut enough);
    let gn = GaussNewton::new(GaussNewtonSettings::default())?.solve_watched(&problem, &theta0, &mut watch)?;
    drop(watch);
    println!(
        "Gauss-Newton: {:?} ({}) at cost {:.6e}; the trace holds {} iterations",
        gn.status,
        gn.status.termination(),
        gn.cost,
        trace.records.len()
    );

    // the paper's planner, derivative-free, for 50 ms of wall time
    let mut watch = Watch::new().with_time_limit(Duration::from_millis(50));
    let powell = Powell::new(PowellSettings::default())?.solve_watched(&problem, &theta0, &mut watch)?;
    println!(
        "Powell: {:?} ({}) at cost {:.6e} after {} evaluations in {:.1} ms",
        powell.status,
        powell.status.termination(),
        powell.cost,
        powell.evals,
        powell.solve_time.as_secs_f64() * 1e3
    );
    Ok(())
}
