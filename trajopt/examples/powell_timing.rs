//! Times `trajopt::powell` on the test problems, one JSON line per problem:
//!
//! ```text
//! cargo run --release -p trajopt --example powell_timing [PROBLEM...]
//! {"problem":"rosenbrock","n":2,"seconds":...,"evals":...,"iterations":...,"cost":...,"status":"ConvergedCost","x":[...]}
//! ```
//!
//! Problems: `rosenbrock` (n = 2), `rosenbrock10`, `rosenbrock50` (extended
//! Rosenbrock from (-1.2, 1, -1.2, 1, ...)), `powell_singular` (n = 4, from
//! (3, -1, 0, 1)), `quadratic10`, and `trivial` (the overhead probe: a sum of
//! squares, 10-D). `seconds` is the median wall time of one solve. Used by
//! `scripts/compare_powell.py`.

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

fn main() -> anyhow::Result<()> {
    let wanted: Vec<String> = std::env::args().skip(1).collect();
    let powell = Powell::new(PowellSettings::default())?;
    for (name, f, x0) in problems() {
        if !wanted.is_empty() && !wanted.iter().any(|w| w == name) {
            continue;
        }
        let objective = |x: &[f64]| -> trajopt::Result<f64> { Ok(f(x)) };
        let result = powell.solve(&objective, &x0)?;
        // repeat for about 0.3 s, at least 5 times, and take the median
        let mut times = Vec::new();
        let budget = Instant::now();
        while times.len() < 5 || (budget.elapsed().as_secs_f64() < 0.3 && times.len() < 10_000) {
            let start = Instant::now();
            let r = powell.solve(&objective, &x0)?;
            times.push(start.elapsed().as_secs_f64());
            std::hint::black_box(r);
        }
        times.sort_by(f64::total_cmp);
        let seconds = times[times.len() / 2];
        let x: Vec<String> = result.x.iter().map(|v| format!("{v:e}")).collect();
        println!(
            "{{\"problem\":\"{name}\",\"n\":{},\"seconds\":{seconds:e},\"evals\":{},\"iterations\":{},\"cost\":{:e},\"status\":\"{:?}\",\"x\":[{}]}}",
            x0.len(),
            result.cost_evals,
            result.iterations,
            result.cost,
            result.status,
            x.join(",")
        );
    }
    Ok(())
}
