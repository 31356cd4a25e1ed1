//! Times whole solves of the pendulum and cart-pole swing-ups over horizons
//! 100 to 5000 (best of several runs) and prints one JSON object per line:
//! used by `scripts/compare_ddp.py`.
//!
//! `cargo run --release -p nprl-drivers --bin ddp_timing -- [repeats]`

use ddp::ModelResult;
use std::time::Duration;

use ddp::problems::{cartpole_swingup, pendulum_swingup};
use ddp::{Cost, Ddp, DdpMethod, DdpProblem, DdpResult, DdpSettings, Dynamics, QuadraticCost};

/// Crocoddyl's `ActionModelUnicycle`: $(x, y, \theta)$ driven by speed and
/// turn rate, explicit Euler with $\Delta t = 0.1$.
struct Unicycle;

impl Dynamics for Unicycle {
    fn state_dim(&self) -> usize {
        3
    }
    fn control_dim(&self) -> usize {
        2
    }
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        let (s, c) = x[2].sin_cos();
        next[0] = x[0] + c * u[0] * 0.1;
        next[1] = x[1] + s * u[0] * 0.1;
        next[2] = x[2] + u[1] * 0.1;
        Ok(())
    }
    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        let (s, c) = x[2].sin_cos();
        fx.copy_from_slice(&[1.0, 0.0, -s * u[0] * 0.1, 0.0, 1.0, c * u[0] * 0.1, 0.0, 0.0, 1.0]);
        fu.copy_from_slice(&[c * 0.1, 0.0, s * 0.1, 0.0, 0.0, 0.1]);
        Ok(true)
    }
}

/// Crocoddyl's unicycle benchmark: from (-1, -1, 1), cost
/// $\tfrac12 (100 \lVert x \rVert^2 + \lVert u \rVert^2)$ per step (not scaled by dt),
/// terminal $\tfrac12\,100 \lVert x \rVert^2$ ([`QuadraticCost`] has no
/// $\tfrac12$: its weights are half of Crocoddyl's).
fn unicycle(horizon: usize) -> anyhow::Result<DdpProblem<Unicycle, QuadraticCost>> {
    let cost = QuadraticCost::diagonal(&[50.0; 3], &[0.5; 2], &[50.0; 3])?;
    Ok(DdpProblem::new(Unicycle, cost, &[-1.0, -1.0, 1.0], horizon)?)
}

fn best<D: Dynamics, C: Cost>(
    solver: &Ddp,
    problem: &DdpProblem<D, C>,
    repeats: usize,
) -> anyhow::Result<(DdpResult, Duration)> {
    let mut result = solver.solve(problem)?;
    let mut fastest = result.solve_time;
    for _ in 1..repeats {
        result = solver.solve(problem)?;
        fastest = fastest.min(result.solve_time);
    }
    Ok((result, fastest))
}

fn report(system: &str, horizon: usize, r: &DdpResult, t: Duration) {
    let total_ms = t.as_secs_f64() * 1e3;
    println!(
        "{{\"system\": \"{system}\", \"horizon\": {horizon}, \"iterations\": {}, \"total_ms\": {total_ms}, \"per_iteration_ms\": {}, \"cost\": {}, \"status\": \"{:?}\", \"method\": \"{:?}\"}}",
        r.iterations,
        total_ms / r.iterations.max(1) as f64,
        r.cost,
        r.status,
        r.method
    );
}

fn main() -> anyhow::Result<()> {
    let repeats: usize = std::env::args().nth(1).map(|s| s.parse()).transpose()?.unwrap_or(5);
    for method in [DdpMethod::Ilqr, DdpMethod::Ddp] {
        let solver = Ddp::new(DdpSettings {
            method,
            ..DdpSettings::default()
        })?;
        let name = if method == DdpMethod::Ddp {
            "pendulum-ddp"
        } else {
            "pendulum"
        };
        for horizon in [100, 500, 1000, 5000] {
            let (r, t) = best(&solver, &pendulum_swingup(horizon)?, repeats)?;
            report(name, horizon, &r, t);
        }
    }
    let solver = Ddp::new(DdpSettings::default())?;
    for horizon in [20, 100, 1000] {
        let (r, t) = best(&solver, &unicycle(horizon)?, repeats)?;
        report("unicycle", horizon, &r, t);
    }
    for horizon in [100, 500, 1000, 5000] {
        let (r, t) = best(&solver, &cartpole_swingup(horizon)?, repeats.min(3))?;
        report("cartpole", horizon, &r, t);
    }
    Ok(())
}
