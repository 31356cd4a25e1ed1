//! Times the parts of one Gauss-Newton / Newton iteration on the benchmark
//! pendulum (`trajopt::problems::pendulum_swingup`, lambda = 1e2): the
//! residuals, the band normal equations J^T J (and J^T J + S), and one band
//! Cholesky factorisation with its solve. Mean over repetitions, in
//! microseconds; the machine may be shared, so read ratios within one run.
//!
//! `cargo run --release -p nprl-drivers --bin eq3_parts -- [HORIZON]` (default 1000)

use std::time::Instant;

use trajopt::linalg::BandedSym;
use trajopt::problems::pendulum_swingup;
use trajopt::{BandForm, BandNormalEquations, LeastSquaresProblem, Point};

fn main() -> anyhow::Result<()> {
    let horizon: usize = std::env::args().nth(1).map_or(Ok(1000), |a| a.parse())?;
    let (problem, theta) = pendulum_swingup(horizon, 1e2)?;
    let n_p = problem.n_params();
    let layout = problem
        .band_form()
        .ok_or_else(|| anyhow::anyhow!("the problem has no band form"))?
        .layout();
    let mut r = vec![0.0; problem.n_residuals()];
    let mut h = BandedSym::zeros(n_p, layout.half_bandwidth);
    let (mut grad, mut diag_s) = (vec![0.0; n_p], vec![0.0; n_p]);
    let reps = 200;
    let time = |f: &mut dyn FnMut() -> anyhow::Result<()>| -> anyhow::Result<f64> {
        let start = Instant::now();
        for _ in 0..reps {
            f()?;
        }
        Ok(start.elapsed().as_secs_f64() * 1e6 / reps as f64)
    };
    let residuals = time(&mut || Ok(problem.residuals(&theta, &mut r)?))?;
    let jtj = time(&mut || {
        let out = BandNormalEquations {
            h: &mut h,
            grad: &mut grad,
            second_order_diagonal: None,
        };
        problem.normal_equations(Point { theta: &theta, r: &r }, &layout, out)?;
        Ok(())
    })?;
    // a positive definite matrix to factorise: J^T J with Marquardt damping
    let mut damped = h.clone();
    let damping: Vec<f64> = (0..n_p).map(|j| 1e-3 * h.diagonal(j).max(1e-12)).collect();
    damped.add_to_diagonal(&damping);
    let factor = time(&mut || {
        let chol = damped
            .clone()
            .cholesky_in_place()
            .map_err(|_| anyhow::anyhow!("not positive definite"))?;
        let mut x = grad.clone();
        chol.solve_in_place(&mut x);
        Ok(())
    })?;
    let full = time(&mut || {
        let out = BandNormalEquations {
            h: &mut h,
            grad: &mut grad,
            second_order_diagonal: Some(&mut diag_s),
        };
        problem.normal_equations(Point { theta: &theta, r: &r }, &layout, out)?;
        Ok(())
    })?;
    println!(
        "N = {horizon}: {n_p} parameters, half-bandwidth {}\nresiduals {residuals:.1} us\nJ^T J {jtj:.1} us\nJ^T J + S {full:.1} us\nband Cholesky + solve {factor:.1} us",
        layout.half_bandwidth
    );
    Ok(())
}
