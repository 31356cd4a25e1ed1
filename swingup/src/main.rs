//! `swingup`: the pendulum swing-up learned from a demonstration
//! (Atkeson, "Nonparametric Model-Based Reinforcement Learning").
//!
//! The learning loop is not built yet: this program says what it will do and
//! which parts of the toolkit are ready, and produces no results.

use splines::{BSplineBasis, TrajectoryBasis};

fn main() {
    println!("swingup: learning a pendulum swing-up from a demonstration");
    println!();
    println!("What this program will do (the paper's section 4, simulated):");
    println!("  1. a 'human' plant produces a swing-up demonstration at 60 Hz;");
    println!("  2. the robot, a different plant with noisy sensors, imitates it (trial 1, expected to fail);");
    println!("  3. after each trial its data joins a locally weighted regression model (crate lwr),");
    println!("     whose metric is tuned by leave-one-out cross-validation;");
    println!("  4. the Eq. 3 planner (crate trajopt) replans from the demonstration over B-spline");
    println!("     coefficients (crate splines), trading task cost against model consistency (lambda);");
    println!("  5. the robot executes the plan, an LQR catches the pendulum upright;");
    println!("     repeat until it balances, then write the report and plots.");
    println!();
    println!("Status of the parts:");
    match BSplineBasis::clamped_uniform(25, 3, 0.0, 2.5) {
        Ok(basis) => println!(
            "  splines : ready (e.g. the planner's state basis: cubic, {} coefficients on [0, 2.5] s)",
            basis.n_coeffs()
        ),
        Err(e) => println!("  splines : error building the default basis: {e}"),
    }
    println!("  lwr     : not implemented yet");
    println!("  trajopt : not implemented yet");
    println!("  ddp     : not implemented yet");
    println!("  swingup : learning loop not implemented yet; no run was made and no report written.");
}
