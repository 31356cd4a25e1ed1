//! Times `trajopt::powell` on the test problems, one JSON line per problem:
//!
//! ```text
//! cargo run --release -p nprl-drivers --bin powell_timing -- [PROBLEM...]
//! {"problem":"rosenbrock","n":2,"seconds":...,"evals":...,"iterations":...,"cost":...,"status":"ConvergedCost","x":[...]}
//! ```
//!
//! Problems: `rosenbrock` (n = 2), `rosenbrock10`, `rosenbrock50` (extended
//! Rosenbrock from (-1.2, 1, -1.2, 1, ...)), `powell_singular` (n = 4, from
//! (3, -1, 0, 1)), `quadratic10`, and `trivial` (the overhead probe: a sum of
//! squares, 10-D). `seconds` is the median wall time of one solve. Used by
//! `scripts/compare_powell.py`.
//!
//! `--overhead` instead prints the solver's own time per evaluation
//! (`overhead_ns_per_eval`: solve time minus the time of as many calls of the
//! objective alone, over the evaluations) for `trivial` in n = 2, 5, 10, 20.

use std::time::Instant;

use trajopt::powell::{Powell, PowellSettings};

use trajopt::problems::{powell_singular, rosenbrock};

/// $\sum_i (i + 1) (x_i - c_i)^2 + \sum_i 0.5 (x_i - c_i)(x_{i+1} - c_{i+1})$, c_i = i / 10.
fn quadratic(x: &[f64]) -> f64 {
    let d = |i: usize| x[i] - i as f64 / 10.0;
    (0..x.len()).map(|i| (i + 1) as f64 * d(i) * d(i)).sum::<f64>()
        + (0..x.len() - 1).map(|i| 0.5 * d(i) * d(i + 1)).sum::<f64>()
}

fn trivial(x: &[f64]) -> f64 {
    x.iter().map(|v| (v - 1.0) * (v - 1.0)).sum()
}

type Problem = (&'static str, fn(&[f64]) -> f64, Vec<f64>);

fn problems() -> Vec<Problem> {
    let ext = |n: usize| (0..n).map(|i| if i % 2 == 0 { -1.2 } else { 1.0 }).collect();
    vec![
        ("rosenbrock", rosenbrock, vec![-1.2, 1.0]),
        ("powell_singular", powell_singular, vec![3.0, -1.0, 0.0, 1.0]),
        ("rosenbrock10", rosenbrock, ext(10)),
        ("rosenbrock50", rosenbrock, ext(50)),
        ("quadratic10", quadratic, vec![0.0; 10]),
        ("trivial", trivial, vec![0.0; 10]),
    ]
}

/// Median wall time of `run` over about 0.3 s (at least 5 runs).
fn median_seconds(mut run: impl FnMut() -> anyhow::Result<()>) -> anyhow::Result<f64> {
    let mut times = Vec::new();
    let budget = Instant::now();
    while times.len() < 5 || (budget.elapsed().as_secs_f64() < 0.3 && times.len() < 10_000) {
        let start = Instant::now();
        run()?;
        times.push(start.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    Ok(times[times.len() / 2])
}

/// The solver's own time per evaluation, `trivial` in n = 2..20 from
/// (-3, ..., -3): (time per solve - time of the same number of objective
/// calls) / evaluations, one JSON line per size.
fn overhead(powell: &Powell) -> anyhow::Result<()> {
    for n in [2, 5, 10, 20] {
        let objective = |x: &[f64]| -> trajopt::Result<f64> { Ok(trivial(x)) };
        let x0 = vec![-3.0; n];
        let result = powell.solve(&objective, &x0)?;
        let evals = result.evals;
        let solve = median_seconds(|| {
            std::hint::black_box(powell.solve(&objective, std::hint::black_box(&x0))?);
            Ok(())
        })?;
        // the objective alone, as many calls on points that change
        let mut point = x0.clone();
        let calls = median_seconds(|| {
            let mut sum = 0.0;
            for k in 0..evals {
                point[k % n] += 1e-3;
                sum += objective(std::hint::black_box(&point))?;
            }
            std::hint::black_box(sum);
            Ok(())
        })?;
        println!(
            "{{\"overhead\":\"trivial\",\"n\":{n},\"evals\":{evals},\"solve_seconds\":{solve:e},\"objective_seconds\":{calls:e},\"overhead_ns_per_eval\":{:.1}}}",
            (solve - calls) / evals as f64 * 1e9
        );
    }
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let wanted: Vec<String> = std::env::args().skip(1).collect();
    let powell = Powell::new(PowellSettings::default())?;
    if wanted.iter().any(|w| w == "--overhead") {
        return overhead(&powell);
    }
    for (name, f, x0) in problems() {
        if !wanted.is_empty() && !wanted.iter().any(|w| w == name) {
            continue;
        }
        let objective = |x: &[f64]| -> trajopt::Result<f64> { Ok(f(x)) };
        let result = powell.solve(&objective, &x0)?;
        let seconds = median_seconds(|| {
            std::hint::black_box(powell.solve(&objective, &x0)?);
            Ok(())
        })?;
        let x: Vec<String> = result.x.iter().map(|v| format!("{v:e}")).collect();
        println!(
            "{{\"problem\":\"{name}\",\"n\":{},\"seconds\":{seconds:e},\"evals\":{},\"iterations\":{},\"cost\":{:e},\"status\":\"{:?}\",\"x\":[{}]}}",
            x0.len(),
            result.evals,
            result.iterations,
            result.cost,
            result.status,
            x.join(",")
        );
    }
    Ok(())
}
