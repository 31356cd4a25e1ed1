//! Powell's method on Eq. 3 with and without the band structure: the
//! pendulum swing-up of `trajopt::problems::trajectory` at horizon 150 and
//! lambda = 100 (452 parameters), from its standard initial guess.
//!
//! [`Powell::solve`] evaluates the whole criterion at every trial point;
//! [`Powell::solve_separable`] on [`BandTerms`] (one term per time step,
//! 151 terms) evaluates only the terms of the coordinates where a trial
//! differs from the best point so far. Both run the same algorithm, but
//! the sums round differently, and the line searches' tolerance on the
//! step turns that into different paths. The target (`stop_cost`) is
//! Gauss-Newton's optimum (tight tolerances) within 1e-3 relative; each
//! run reports the evaluations to reach it (or the budget), its work in
//! full evaluations (a partial evaluation counts as the fraction of the
//! terms it evaluates) and its wall time.
//!
//! `cargo run --release -p nprl-trajopt --example powell_separable [horizon] [budget per parameter] [lambda]`
//! (defaults 150, 1000 (Powell's default budget $1000 n$) and 100)

use trajopt::powell::BandTerms;
use trajopt::problems::trajectory::System;
use trajopt::{GaussNewton, GaussNewtonSettings, Powell, PowellSettings};

fn main() -> anyhow::Result<()> {
    let horizon: usize = std::env::args().nth(1).map_or(Ok(150), |h| h.parse())?;
    let per_parameter: usize = std::env::args().nth(2).map_or(Ok(1000), |h| h.parse())?;
    let lambda: f64 = std::env::args().nth(3).map_or(Ok(100.0), |h| h.parse())?;
    let (problem, theta0) = System::Pendulum.problem(horizon, lambda)?;
    let n = theta0.len();
    let gn = GaussNewton::new(GaussNewtonSettings {
        max_iterations: 1000,
        tol_grad: 1e-14,
        tol_step: 1e-15,
        tol_cost: 1e-16,
        ..GaussNewtonSettings::default()
    })?
    .solve(&problem, &theta0)?;
    let target = gn.cost * (1.0 + 1e-3);
    println!(
        "pendulum, horizon {horizon}, lambda {lambda}: n = {n}, start {:.6e}, Gauss-Newton {:.6e} ({:?}), target {target:.6e}",
        gn.initial_cost, gn.cost, gn.status
    );
    let budget = per_parameter * n;
    let powell = Powell::new(PowellSettings {
        max_evals: Some(budget),
        stop_cost: Some(target),
        ..PowellSettings::default()
    })?;
    let plain = powell.solve(&problem, &theta0)?;
    let terms = BandTerms::new(&problem, problem.horizon() + 1, &theta0)?;
    let banded = powell.solve_separable(&terms, &theta0)?;
    println!("budget {budget} evaluations");
    println!("| solve | status | evaluations | full-evaluation equivalents | final cost | wall time |");
    println!("|---|---|---|---|---|---|");
    for (name, r) in [("solve", &plain), ("solve_separable", &banded)] {
        println!(
            "| {name} | {:?} | {} | {:.0} | {:.6e} | {:.2} s |",
            r.status,
            r.evals,
            r.full_eval_equivalents,
            r.cost,
            r.solve_time.as_secs_f64()
        );
    }
    Ok(())
}
