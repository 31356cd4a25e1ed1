//! Powell's method on Eq. 3 with and without the band structure: the
//! pendulum swing-up of `trajopt::problems::trajectory` at horizon 150 and
//! lambda = 100 (452 parameters), from its standard initial guess.
//!
//! [`Powell::solve`] evaluates the whole criterion at every trial point;
//! [`Powell::solve_separable`] on [`BandTerms`] (one term per time step,
//! 151 terms) evaluates only the terms of the coordinates where a trial
//! differs from the best point so far. Both do the same iterations (up to
//! the rounding of the sums). The target is Gauss-Newton's optimum (tight
//! tolerances) within 1e-3 relative: the evaluations the plain solve needs
//! to reach it are the budget of both runs, which then report their cost,
//! their work in full evaluations (a partial evaluation counts as the
//! fraction of the terms it evaluates) and their wall time.
//!
//! `cargo run --release -p nprl-trajopt --example powell_separable [horizon] [budget per parameter]`
//! (defaults 150 and 1000, Powell's default budget $1000 n$)

use std::cell::Cell;

use trajopt::powell::{BandTerms, Objective};
use trajopt::problems::trajectory::System;
use trajopt::{GaussNewton, GaussNewtonSettings, Powell, PowellSettings, TrajoptError};

/// Stops the solve (an `Err`) at the first value at or below `target`.
struct Reach<'a, O> {
    f: &'a O,
    target: f64,
    evals: Cell<usize>,
}

impl<O: Objective> Objective for Reach<'_, O> {
    fn cost(&self, x: &[f64]) -> trajopt::Result<f64> {
        let v = self.f.cost(x)?;
        self.evals.set(self.evals.get() + 1);
        if v <= self.target {
            return Err(TrajoptError::Model("target reached".into()));
        }
        Ok(v)
    }
}

fn main() -> anyhow::Result<()> {
    let horizon: usize = std::env::args().nth(1).map_or(Ok(150), |h| h.parse())?;
    let per_parameter: usize = std::env::args().nth(2).map_or(Ok(1000), |h| h.parse())?;
    let (problem, theta0) = System::Pendulum.problem(horizon, 100.0)?;
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
        "pendulum, horizon {horizon}, lambda 100: n = {n}, start {:.6e}, Gauss-Newton {:.6e} ({:?}), target {target:.6e}",
        gn.initial_cost, gn.cost, gn.status
    );
    let budget = per_parameter * n;
    let reach = Reach {
        f: &problem,
        target,
        evals: Cell::new(0),
    };
    let reached = match Powell::new(PowellSettings {
        max_cost_evals: Some(budget),
        ..PowellSettings::default()
    })?
    .solve(&reach, &theta0)
    {
        Err(TrajoptError::Model(_)) => true,
        Ok(_) => false,
        Err(e) => return Err(e.into()),
    };
    let evals = reach.evals.get();
    println!(
        "plain Powell {} the target after {evals} evaluations (budget {budget})",
        if reached { "reaches" } else { "does not reach" }
    );
    let powell = Powell::new(PowellSettings {
        max_cost_evals: Some(evals),
        ..PowellSettings::default()
    })?;
    let plain = powell.solve(&problem, &theta0)?;
    let terms = BandTerms::new(&problem, problem.horizon() + 1, &theta0)?;
    let banded = powell.solve_separable(&terms, &theta0)?;
    println!("| solve | evaluations | full-evaluation equivalents | final cost | reached | wall time |");
    println!("|---|---|---|---|---|---|");
    for (name, r) in [("solve", &plain), ("solve_separable", &banded)] {
        println!(
            "| {name} | {} | {:.0} | {:.6e} | {} | {:.2} s |",
            r.cost_evals,
            r.full_eval_equivalents,
            r.cost,
            r.cost <= target,
            r.solve_time.as_secs_f64()
        );
    }
    Ok(())
}
