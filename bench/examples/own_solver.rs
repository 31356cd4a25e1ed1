//! Your own least-squares solver in `nprl-bench`, beside the built-in
//! ones: a textbook Levenberg-Marquardt of 50 lines, and 8 lines of
//! glue that run it and `gauss-newton` on a set and write the same
//! records, tables, performance profiles (evaluations and time) and data
//! profiles as `nprl-bench` does.
//!
//! ```text
//! cargo run --release -p nprl-bench --example own_solver -- mgh
//! cargo run --release -p nprl-bench --example own_solver -- nist
//! ```
//!
//! The reports land in `target/own-solver-SET/benchmarks.md`.

use bench::open::{Problem, Stop};
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

/// Levenberg-Marquardt with Marquardt's diagonal scaling: the step solves
/// $(J^\top J + \mu\,\mathrm{diag}(J^\top J))\,\delta = -J^\top r$; $\mu$
/// halves after a step that lowers the cost and grows fourfold otherwise.
#[allow(unreachable_pub)] // public in the example, private where the test includes it
pub fn levenberg_marquardt(p: &Problem<'_>) -> Result<Stop, String> {
    let (n, m) = (p.n(), p.m());
    let (mut x, mut r, mut jac) = (p.x0().to_vec(), vec![0.0; m], vec![0.0; m * n]);
    p.residuals(&x, &mut r).map_err(|e| e.to_string())?;
    let (mut f, mut mu) = (r.iter().map(|v| v * v).sum::<f64>(), 1e-3);
    let mut trial_r = vec![0.0; m];
    for _ in 0..10_000 {
        if let Err(e) = p.jacobian(&x, &mut jac) {
            return if e.budget_spent() {
                Ok(Stop::stopped("budget"))
            } else {
                Err(e.to_string())
            };
        }
        let jtj = Mat::from_fn(n, n, |a, b| {
            (0..m).map(|i| jac[i * n + a] * jac[i * n + b]).sum::<f64>()
        });
        let g = Mat::from_fn(n, 1, |a, _| -(0..m).map(|i| jac[i * n + a] * r[i]).sum::<f64>());
        if (0..n).all(|a| g[(a, 0)].abs() <= 1e-15 * (1.0 + f)) {
            return Ok(Stop::converged("gradient"));
        }
        loop {
            let damped = Mat::from_fn(n, n, |a, b| {
                jtj[(a, b)] + if a == b { mu * jtj[(a, a)].max(1e-12) } else { 0.0 }
            });
            let step = damped.llt(Side::Lower).map_err(|e| format!("{e:?}"))?.solve(&g);
            let trial: Vec<f64> = (0..n).map(|a| x[a] + step[(a, 0)]).collect();
            match p.residuals(&trial, &mut trial_r) {
                Err(e) if e.budget_spent() => return Ok(Stop::stopped("budget")),
                Err(e) => return Err(e.to_string()),
                Ok(()) => {}
            }
            let ft: f64 = trial_r.iter().map(|v| v * v).sum();
            if ft < f {
                let small = f - ft <= 1e-15 * f;
                (x, f, mu) = (trial, ft, (mu / 2.0).max(1e-12));
                r.copy_from_slice(&trial_r);
                if small {
                    return Ok(Stop::converged("small decrease"));
                }
                break;
            }
            mu *= 4.0;
            if mu > 1e16 {
                return Ok(Stop::stopped("damping"));
            }
        }
    }
    Ok(Stop::stopped("iterations"))
}

#[allow(dead_code)] // bench/tests/open_benchmark.rs includes this file for the solver alone
fn main() -> Result<(), bench::BenchError> {
    let set = bench::problems::ProblemSet::parse(&std::env::args().nth(1).unwrap_or_else(|| "mgh".into()))?;
    // the glue: the set, the solvers beside yours, and a run
    let mut settings = bench::runner::RunnerSettings::new(set, format!("target/own-solver-{}", set.name()));
    settings.solvers = bench::solvers::Solver::parse_entries("gauss-newton")?;
    settings
        .solvers
        .push(std::sync::Arc::new(bench::open::from_fn("my-lm", levenberg_marquardt)));
    settings.filter = std::env::args().nth(2);
    let (analysis, stamp) = bench::runner::execute(&settings)?;
    let report = settings.report_dir.join(set.report_stem() + ".md");
    println!(
        "{} runs on {} instances: see {}",
        stamp.runs,
        analysis.instances.len(),
        report.display()
    );
    Ok(())
}
