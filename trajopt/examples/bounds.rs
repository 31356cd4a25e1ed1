//! Limits: the swing-up with the hand's acceleration (the control) held in
//! [-8, 8] m/s^2 and the hand's position in [-0.5, 0.5] m.
//!
//! `Eq3Problem::with_control_bounds` and `with_state_bounds` put one linear
//! row per channel and sample time on the coefficients (a B-spline sample is
//! a fixed combination of its coefficients); Gauss-Newton then takes each
//! step as a sparse QP (clarabel) and never leaves the bounds. The plan is
//! compared with the unbounded one: a higher cost, and every sample inside.
//!
//! `cargo run --release -p nprl-trajopt --example bounds`

use trajopt::problems::pendulum_swingup;
use trajopt::{GaussNewton, GaussNewtonSettings};

const U_MAX: f64 = 8.0;
const X_MAX: f64 = 0.5;

fn main() -> anyhow::Result<()> {
    let (free, theta0) = pendulum_swingup(120, 10.0)?;
    let solver = GaussNewton::new(GaussNewtonSettings::default())?;
    let unbounded = solver.solve(&free, &theta0)?;
    let (x, u) = free.trajectory(&unbounded.x)?;
    let peak = |m: &faer::Mat<f64>, col: usize| (0..m.nrows()).map(|k| m[(k, col)].abs()).fold(0.0, f64::max);
    println!(
        "unbounded: {:?}, cost {:.6e}, peak |u| {:.1}, peak |x| {:.3}",
        unbounded.status,
        unbounded.cost,
        peak(&u, 0),
        peak(&x, 0)
    );

    let inf = f64::INFINITY;
    let bounded_problem = free
        .with_control_bounds(&[-U_MAX], &[U_MAX])?
        .with_state_bounds(&[-X_MAX, -inf, -inf, -inf], &[X_MAX, inf, inf, inf])?;
    let bounded = solver.solve(&bounded_problem, &theta0)?;
    let (x, u) = bounded_problem.trajectory(&bounded.x)?;
    println!(
        "bounded:   {:?}, cost {:.6e}, peak |u| {:.1} (limit {U_MAX}), peak |x| {:.3} (limit {X_MAX})",
        bounded.status,
        bounded.cost,
        peak(&u, 0),
        peak(&x, 0)
    );
    anyhow::ensure!(peak(&u, 0) <= U_MAX * (1.0 + 1e-6) && peak(&x, 0) <= X_MAX * (1.0 + 1e-6));
    Ok(())
}
