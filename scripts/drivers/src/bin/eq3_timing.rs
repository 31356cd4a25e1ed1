//! Solves the benchmark pendulum swing-up (`trajopt::problems`) with
//! Gauss-Newton, with Newton steps (`second_order`) and with the adaptive
//! choice between the two (`adaptive`) at several horizons
//! and prints one JSON object per line and mode: horizon, seconds,
//! iterations, evaluations, factorisations, final cost and its parts.
//! `scripts/compare_trajopt.py` runs it beside scipy on the same problem.
//!
//! `cargo run --release -p nprl-drivers --bin eq3_timing -- [--max-iters K] [LAMBDA] [HORIZONS...]`
//! (`--max-iters` replaces the solver's default iteration cap of 200: at
//! lambda >= 1e3 the swing-up needs a few hundred iterations to converge).

use std::time::Instant;

use trajopt::problems::pendulum_swingup;
use trajopt::{GaussNewton, GaussNewtonSettings, LeastSquaresProblem, StepModel};

fn main() -> anyhow::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let max_iterations = match args.iter().position(|a| a == "--max-iters") {
        Some(i) => {
            let value = args
                .get(i + 1)
                .ok_or_else(|| anyhow::anyhow!("--max-iters needs a value"))?
                .parse::<usize>()?;
            args.drain(i..i + 2);
            value
        }
        None => GaussNewtonSettings::default().max_iterations,
    };
    let lambda: f64 = args.first().map_or(Ok(1e3), |a| a.parse())?;
    let horizons: Vec<usize> = args.iter().skip(1).map(|a| a.parse()).collect::<Result<_, _>>()?;
    let horizons = if horizons.is_empty() {
        vec![50, 150, 500, 1000, 5000]
    } else {
        horizons
    };
    for horizon in horizons {
        for (mode, step_model, threads) in [
            ("gauss_newton", StepModel::GaussNewton, 1),
            ("newton", StepModel::Newton, 1),
            ("adaptive", StepModel::Adaptive, 1),
            ("gauss_newton_2t", StepModel::GaussNewton, 2),
            ("newton_2t", StepModel::Newton, 2),
            ("adaptive_2t", StepModel::Adaptive, 2),
        ] {
            run(horizon, lambda, max_iterations, mode, step_model, threads)?;
        }
    }
    Ok(())
}

fn run(
    horizon: usize,
    lambda: f64,
    max_iterations: usize,
    mode: &str,
    step_model: StepModel,
    threads: usize,
) -> anyhow::Result<()> {
    let solver = GaussNewton::new(GaussNewtonSettings {
        step_model,
        max_iterations,
        ..GaussNewtonSettings::default()
    })?;
    let (problem, theta0) = pendulum_swingup(horizon, lambda)?;
    // best of 5 (the machine may be shared)
    let mut best = f64::INFINITY;
    let mut result = None;
    for _ in 0..5 {
        let start = Instant::now();
        let r = solver.solve_parallel(&problem, &theta0, threads)?;
        best = best.min(start.elapsed().as_secs_f64());
        result = Some(r);
    }
    let r = result.ok_or_else(|| anyhow::anyhow!("no run"))?;
    let parts = problem.cost_breakdown(&r.x)?;
    println!(
        "{{\"horizon\": {horizon}, \"mode\": \"{mode}\", \"lambda\": {lambda:e}, \"params\": {}, \"residuals\": {}, \"seconds\": {best:e}, \"iterations\": {}, \"residual_evals\": {}, \"factorizations\": {}, \"status\": \"{:?}\", \"cost\": {:e}, \"initial_cost\": {:e}, \"task\": {:e}, \"inconsistency\": {:e}, \"max_mismatch\": {:e}}}",
        problem.n_params(),
        problem.n_residuals(),
        r.iterations,
        r.evals,
        r.factorizations,
        r.status,
        r.cost,
        r.initial_cost,
        parts.task,
        parts.inconsistency,
        parts.max_mismatch
    );
    Ok(())
}
