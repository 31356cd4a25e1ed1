//! First steps: the paper's Eq. 3 planned three ways.
//!
//! The benchmark pendulum swing-up (`trajopt::problems::pendulum_swingup`:
//! a hand-held pendulum, 1 s at 60 Hz, states and controls as cubic
//! B-splines, the model a soft constraint of weight lambda) is solved by
//! Gauss-Newton (exact Jacobians), by the derivative-free least-squares mode
//! (residual values only, Jacobians differenced in column groups) and by
//! Powell, the paper's planner (cost values only). All three read through
//! one result shape (`solve::Outcome`), and each reports the task cost and
//! how far the plan departs from the model.
//!
//! `cargo run --release -p nprl-trajopt --example basic`

use solve::Outcome;
use trajopt::problems::pendulum_swingup;
use trajopt::{DerivativeFree, DerivativeFreeSettings, GaussNewton, GaussNewtonSettings, Powell, PowellSettings};

fn main() -> anyhow::Result<()> {
    let (problem, theta0) = pendulum_swingup(60, 10.0)?;
    let gn = GaussNewton::new(GaussNewtonSettings::default())?.solve(&problem, &theta0)?;
    let df = DerivativeFree::new(DerivativeFreeSettings::default())?.solve(&problem, &theta0)?;
    let powell = Powell::new(PowellSettings {
        max_evals: Some(2_000_000),
        principal_axes: 10,
        ..PowellSettings::default()
    })?
    .solve(&problem, &theta0)?;

    println!("solver           termination         cost          evaluations  time");
    for (name, summary, x) in [
        ("gauss-newton", gn.summary(), &gn.x),
        ("derivative-free", df.summary(), &df.x),
        ("powell", powell.summary(), &powell.x),
    ] {
        let parts = problem.cost_breakdown(x)?;
        println!(
            "{name:<16} {:<19} {:.6e}  {:>11}  {:.1} ms   (task {:.4e}, inconsistency {:.2e})",
            summary.termination.to_string(),
            summary.cost,
            summary.evals,
            summary.solve_time.unwrap_or_default().as_secs_f64() * 1e3,
            parts.task,
            parts.inconsistency,
        );
    }
    Ok(())
}
