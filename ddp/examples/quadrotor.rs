//! A user's own model planned by DDP from the docs alone: a planar
//! quadrotor flies 1 m sideways and 1 m up to hover, its two rotor thrusts
//! limited to [0, 8] N (hover takes 4.9 N each). The dynamics give no
//! Jacobians (DDP differences the step); the cost is `QuadraticCost`.
//! 40 lines of code, comments and blank lines aside (Crocoddyl's
//! equivalent: 36). The same model and cost in residual form, planned by
//! Eq. 3, reach DDP's cost: `tests/tests/quadrotor.rs`.
//!
//! `cargo run --release -p nprl-ddp --example quadrotor`

use ddp::{Ddp, DdpProblem, DdpSettings, Dynamics, ModelResult, QuadraticCost};

/// Mass (kg); the arm is 0.2 m, the inertia 0.02 kg m^2.
pub const MASS: f64 = 1.0;
/// Gravity (m/s^2).
pub const G: f64 = 9.81;
/// Time step (s).
pub const DT: f64 = 0.05;

/// State (x, z, theta, vx, vz, omega); control: the two thrusts.
pub struct Quadrotor;

impl Dynamics for Quadrotor {
    fn state_dim(&self) -> usize {
        6
    }
    fn control_dim(&self) -> usize {
        2
    }
    fn step(&self, s: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        let (sin, cos) = s[2].sin_cos();
        let (thrust, torque) = (u[0] + u[1], 0.2 * (u[0] - u[1]));
        let acc = [-thrust * sin / MASS, thrust * cos / MASS - G, torque / 0.02];
        for i in 0..3 {
            next[i + 3] = s[i + 3] + DT * acc[i];
            next[i] = s[i] + DT * next[i + 3];
        }
        Ok(())
    }
}

#[allow(dead_code)] // tests/tests/quadrotor.rs includes this file for the model
fn main() -> Result<(), ddp::DdpError> {
    let (goal, hover) = ([1.0, 1.0, 0.0, 0.0, 0.0, 0.0], vec![MASS * G / 2.0; 2]);
    let cost = QuadraticCost::diagonal(&[1.0, 1.0, 0.1, 0.1, 0.1, 0.1], &[0.01, 0.01], &[100.0; 6])?
        .with_state_target(&goal)?
        .with_control_reference(vec![hover.clone()])?;
    let problem = DdpProblem::new(Quadrotor, cost, &[0.0; 6], 60)?
        .with_initial_controls(vec![hover; 60])?
        .with_control_limits(&[0.0, 0.0], &[8.0, 8.0])?;
    let plan = Ddp::new(DdpSettings::default())?.solve(&problem)?;
    println!(
        "{:?}, cost {:.6}, ends at {:.3?}",
        plan.status,
        plan.cost,
        &plan.states[60][..3]
    );
    Ok(())
}
