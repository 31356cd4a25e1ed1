//! Your own dynamics and cost, solved by DDP: parking a unicycle.
//!
//! A unicycle at position (px, py) with heading h drives with speed v and
//! turns with rate w, stepped at 10 Hz:
//!
//! ```text
//! px' = px + dt v cos h,   py' = py + dt v sin h,   h' = h + dt w
//! ```
//!
//! It starts at the origin facing +x and must end at (0, 1) facing +x: a
//! sideways move it cannot make directly, so the plan has to manoeuvre.
//! The cost is quadratic, 1/2 (x - goal)^T Q (x - goal) + 1/2 u^T R u per
//! step and a heavier terminal term; the dynamics give their Jacobians
//! analytically (leave `jacobians` out and `ddp` takes central
//! differences instead). Copy this file to start a problem of your own.
//!
//! `cargo run --release -p nprl-ddp --example unicycle_parking`

use ddp::ModelResult;
use ddp::{Cost, CostDerivatives, Ddp, DdpProblem, DdpSettings, Dynamics};

const DT: f64 = 0.1;
const GOAL: [f64; 3] = [0.0, 1.0, 0.0];

/// The unicycle; state (px, py, h), control (v, w).
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
        next[0] = x[0] + DT * u[0] * c;
        next[1] = x[1] + DT * u[0] * s;
        next[2] = x[2] + DT * u[1];
        Ok(())
    }

    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        let (s, c) = x[2].sin_cos();
        // fx: 3 x 3, row-major
        fx.copy_from_slice(&[1.0, 0.0, -DT * u[0] * s, 0.0, 1.0, DT * u[0] * c, 0.0, 0.0, 1.0]);
        // fu: 3 x 2, row-major
        fu.copy_from_slice(&[DT * c, 0.0, DT * s, 0.0, 0.0, DT]);
        Ok(true)
    }
}

/// 1/2 (x - goal)^T diag(q) (x - goal) + 1/2 u^T diag(r) u, and
/// 1/2 (x - goal)^T diag(q_final) (x - goal) at the end.
struct Parking {
    q: [f64; 3],
    r: [f64; 2],
    q_final: [f64; 3],
}

fn quadratic(weights: &[f64], v: &[f64], target: &[f64]) -> f64 {
    weights
        .iter()
        .zip(v)
        .zip(target)
        .map(|((w, a), b)| 0.5 * w * (a - b) * (a - b))
        .sum()
}

impl Cost for Parking {
    fn running(&self, _k: usize, x: &[f64], u: &[f64]) -> f64 {
        quadratic(&self.q, x, &GOAL) + quadratic(&self.r, u, &[0.0, 0.0])
    }

    fn running_derivatives(&self, _k: usize, x: &[f64], u: &[f64], d: &mut CostDerivatives) {
        for i in 0..3 {
            d.lx[i] = self.q[i] * (x[i] - GOAL[i]);
            d.lxx[i * 3 + i] = self.q[i];
        }
        for (j, (&r, &uj)) in self.r.iter().zip(u).enumerate() {
            d.lu[j] = r * uj;
            d.luu[j * 2 + j] = r;
        }
    }

    fn terminal(&self, x: &[f64]) -> f64 {
        quadratic(&self.q_final, x, &GOAL)
    }

    fn terminal_derivatives(&self, x: &[f64], lx: &mut [f64], lxx: &mut [f64]) {
        for i in 0..3 {
            lx[i] = self.q_final[i] * (x[i] - GOAL[i]);
            lxx[i * 3 + i] = self.q_final[i];
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let horizon = 60; // 6 s
    let cost = Parking {
        q: [0.0, 0.0, 0.0],
        r: [0.1, 0.1],
        q_final: [100.0, 100.0, 100.0],
    };
    // from the origin; control limits on speed and turn rate; the warm
    // start creeps forward turning left (from zero controls the sideways
    // goal gives no gradient: a unicycle at rest cannot feel it)
    let warm = vec![vec![0.1, 0.1]; horizon];
    let problem = DdpProblem::new(Unicycle, cost, &[0.0, 0.0, 0.0], horizon)?
        .with_initial_controls(warm)?
        .with_control_limits(&[-1.0, -2.0], &[1.0, 2.0])?;
    let result = Ddp::new(DdpSettings::default())?.solve(&problem)?;
    let end = &result.states[horizon];
    println!(
        "{:?} after {} iterations: cost {:.4} (from {:.4}); ends at ({:.3}, {:.3}) heading {:.3}",
        result.status, result.iterations, result.cost, result.initial_cost, end[0], end[1], end[2]
    );

    // Eq. 2: the feedback policy around the plan corrects a disturbed start
    let disturbed = [0.05, -0.05, 0.1];
    let u0 = result.policy(0, &disturbed).ok_or("no policy at step 0")?;
    println!("first command from the disturbed start: v {:.3}, w {:.3}", u0[0], u0[1]);
    Ok(())
}
