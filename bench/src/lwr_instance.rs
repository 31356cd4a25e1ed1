//! The learned-LWR instance (`pendulum-lwr`) as a saved file: the Eq. 3
//! problem of the swing-up planner with the pure LWR model learned from
//! two trials, defined here from its data alone, so that the benchmark
//! does not depend on the `swingup` program.
//!
//! **The problem.** The hand-held pendulum, state
//! $s = (\theta, \dot\theta, x, \dot x)$, command $u$ (the hand's
//! acceleration), sample period $\Delta t$. The learned model predicts the
//! change of the pendulum's angular velocity,
//! $g(z) = c_0 + \sum_j c_j z_j + \hat r(z_I)$ with $z = (s, u)$: a global
//! linear fit plus an LWR $\hat r$ of its residuals on the inputs $I$
//! ($\hat r = 0$ where no stored point has weight); the hand's kinematics
//! are known, and the angle follows by the trapezoid rule:
//! $$\dot\theta' = \dot\theta + g(z), \quad \theta' = \theta + \tfrac{\Delta t}{2}(\dot\theta + \dot\theta'), \quad
//! x' = x + \dot x \Delta t + u \Delta t^2 / 2, \quad \dot x' = \dot x + u \Delta t .$$
//! The stage cost is Eq. 5 tracking the demonstration
//! ([`trajopt::TrackingCost`]) plus hinge penalties
//! $\sqrt{w_b}\,(|x| - x_{max})_+$ and $\sqrt{w_b}\,(|u| - u_{max})_+$;
//! states and controls are clamped cubic B-splines over the window, the
//! consistency weight $\lambda$ in rate units (scale $1 / \Delta t$), with a
//! penalty on the initial state's distance from rest.
//!
//! **The file.** `bench/data/pendulum-lwr.json` ([`LwrInstanceFile`]),
//! compiled into the binary. It is written by
//! `cargo test --release -p integration-tests --test pendulum_lwr_instance -- --ignored`
//! from the swing-up program's own planner problem (seed 1, trials 1 and 2,
//! the default configuration), and the same test checks that the problem
//! defined here equals the program's (residuals and Jacobians) and that the
//! committed file is the one the program makes today.

use std::sync::Arc;

use faer::Mat;
use serde::{Deserialize, Serialize};
use splines::BSplineBasis;
use systems::hand_pendulum::SoftBounds;
use trajopt::{Dynamics, Eq3Problem, Lambda, ModelResult, StageCost, TrackingCost};

use crate::error::{BenchError, Result};

/// The saved file, compiled in.
const FILE: &str = include_str!("../data/pendulum-lwr.json");

/// Everything that defines the learned-LWR instance; see the [module
/// docs](self).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LwrInstanceFile {
    /// How the file was made (command, run, trials).
    pub source: String,
    /// Sample period $\Delta t$ (s).
    pub dt: f64,
    /// The linear prior $[c_0, c_1, \dots, c_5]$ of $g$.
    pub prior: [f64; 6],
    /// The inputs $I$ of the LWR (indices into $z$, increasing).
    pub inputs: Vec<usize>,
    /// The LWR of the prior's residuals, with its tuned metric.
    pub lwr: lwr::LwrModel,
    /// The tracked states, one per sample time ($N + 1$).
    pub state_reference: Vec<[f64; 4]>,
    /// The tracked commands ($N$).
    pub control_reference: Vec<f64>,
    /// Eq. 5's state weights.
    pub state_weights: [f64; 4],
    /// Eq. 5's command weight.
    pub control_weight: f64,
    /// Eq. 5's terminal weights.
    pub terminal_weights: [f64; 4],
    /// The hand's soft bound $x_{max}$ (m).
    pub x_max: f64,
    /// The command's soft bound $u_{max}$ (m/s²).
    pub u_max: f64,
    /// The bounds' weight $w_b$.
    pub bound_weight: f64,
    /// B-spline coefficients per state channel.
    pub state_coeffs: usize,
    /// B-spline coefficients of the command.
    pub control_coeffs: usize,
    /// The consistency weight $\lambda$.
    pub lambda: f64,
    /// The weight of the initial state's penalty (distance from rest).
    pub initial_state_weight: f64,
    /// The planner's start: the coefficients fitted to the demonstration.
    pub start: Vec<f64>,
}

/// Points per parallel task in the batch evaluations (a query costs
/// microseconds: smaller tasks would spend more on scheduling).
const BATCH_CHUNK: usize = 32;

/// The learned model of the pendulum with the hand's kinematics known.
#[derive(Debug)]
pub struct LearnedPendulum {
    dt: f64,
    prior: [f64; 6],
    inputs: Vec<usize>,
    lwr: lwr::LwrModel,
}

impl LearnedPendulum {
    /// $g(z)$ and, when asked, $\partial g / \partial z$.
    fn delta_omega(&self, z: &[f64; 5], jacobian: Option<&mut [f64; 5]>) -> f64 {
        let prior = self.prior[0] + (0..5).map(|j| self.prior[j + 1] * z[j]).sum::<f64>();
        // z on the LWR's inputs (selected on the stack: this runs at every
        // knot of every evaluation)
        let mut j_resid = [0.0; 5];
        let resid = self
            .lwr
            .predict_selected(z, &self.inputs, jacobian.is_some().then_some(&mut j_resid))
            .unwrap_or(f64::NAN);
        // no weighted data (or a failed fit): the prior alone
        let (resid, j_resid) = if resid.is_finite() && j_resid.iter().all(|v| v.is_finite()) {
            (resid, j_resid)
        } else {
            (0.0, [0.0; 5])
        };
        if let Some(jac) = jacobian {
            *jac = std::array::from_fn(|c| self.prior[c + 1] + j_resid[c]);
        }
        prior + resid
    }
}

impl Dynamics for LearnedPendulum {
    fn state_dim(&self) -> usize {
        4
    }

    fn control_dim(&self) -> usize {
        1
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        let g = self.delta_omega(&[x[0], x[1], x[2], x[3], u[0]], None);
        systems::hand_pendulum::step(self.dt, x, u[0], g, next);
        Ok(())
    }

    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        let mut grad = [0.0; 5];
        self.delta_omega(&[x[0], x[1], x[2], x[3], u[0]], Some(&mut grad));
        systems::hand_pendulum::jacobians(self.dt, &grad, fx, fu);
        Ok(true)
    }

    /// The points in parallel (rayon), each exactly as [`step`](Dynamics::step).
    fn step_batch(&self, xs: &[f64], us: &[f64], next: &mut [f64]) -> ModelResult<()> {
        use rayon::prelude::*;
        next.par_chunks_mut(4 * BATCH_CHUNK)
            .enumerate()
            .try_for_each(|(c, out)| {
                out.chunks_exact_mut(4).enumerate().try_for_each(|(i, o)| {
                    let k = c * BATCH_CHUNK + i;
                    self.step(&xs[4 * k..4 * k + 4], &us[k..=k], o)
                })
            })
    }

    /// The points in parallel (rayon), each exactly as [`jacobians`](Dynamics::jacobians).
    fn jacobians_batch(&self, xs: &[f64], us: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        use rayon::prelude::*;
        fx.par_chunks_mut(16 * BATCH_CHUNK)
            .zip(fu.par_chunks_mut(4 * BATCH_CHUNK))
            .enumerate()
            .try_for_each(|(c, (fx, fu))| {
                fx.chunks_exact_mut(16)
                    .zip(fu.chunks_exact_mut(4))
                    .enumerate()
                    .try_for_each(|(i, (fx, fu))| {
                        let k = c * BATCH_CHUNK + i;
                        self.jacobians(&xs[4 * k..4 * k + 4], &us[k..=k], fx, fu).map(|_| ())
                    })
            })?;
        Ok(true)
    }

    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        systems::hand_pendulum::jacobian_structure(fx, fu);
    }
}

/// Eq. 5 tracking plus hinge penalties on the hand and the command.
#[derive(Debug, Clone)]
pub struct BoundedTracking {
    tracking: TrackingCost,
    bounds: SoftBounds,
}

impl StageCost for BoundedTracking {
    fn n_residuals(&self) -> usize {
        7
    }

    fn residuals(&self, k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
        self.tracking.residuals(k, x, u, &mut r[..5])?;
        self.bounds.residuals(x, u, &mut r[5..]);
        Ok(())
    }

    fn jacobians(&self, k: usize, x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> ModelResult<()> {
        self.tracking.jacobians(k, x, u, &mut jx[..20], &mut ju[..5])?;
        self.bounds.jacobians(x, u, &mut jx[20..], &mut ju[5..]);
        Ok(())
    }

    fn jacobian_structure(&self, jx: &mut [bool], ju: &mut [bool]) {
        self.tracking.jacobian_structure(&mut jx[..20], &mut ju[..5]);
        SoftBounds::jacobian_structure(&mut jx[20..], &mut ju[5..]);
    }
}

/// The learned-LWR instance's Eq. 3 problem.
pub type LwrProblem = Eq3Problem<LearnedPendulum, BoundedTracking>;

fn invalid(reason: String) -> BenchError {
    BenchError::InvalidSetting {
        name: "pendulum-lwr instance",
        reason,
    }
}

impl LwrInstanceFile {
    /// The file compiled into the benchmark.
    ///
    /// # Errors
    /// [`BenchError::InvalidSetting`] if it does not parse (the message
    /// names the line and column).
    pub fn compiled_in() -> Result<Self> {
        Self::parse(FILE)
    }

    /// A file's contents.
    ///
    /// # Errors
    /// [`BenchError::InvalidSetting`] naming the line and column of what
    /// does not parse.
    pub fn parse(text: &str) -> Result<Self> {
        serde_json::from_str(text).map_err(|e| invalid(format!("bench/data/pendulum-lwr.json: {e}")))
    }

    /// The Eq. 3 problem the file defines, and its start.
    ///
    /// # Errors
    /// [`BenchError::InvalidSetting`] naming what is inconsistent (lengths,
    /// inputs, weights, bases).
    pub fn problem(&self) -> Result<(LwrProblem, Vec<f64>)> {
        let n = self.control_reference.len();
        if n == 0 || self.state_reference.len() != n + 1 {
            return Err(invalid(format!(
                "{} reference states for {n} commands (need commands, and one state more)",
                self.state_reference.len()
            )));
        }
        let increasing = self.inputs.windows(2).all(|w| w[0] < w[1]);
        if self.inputs.is_empty() || !increasing || self.inputs.iter().any(|&j| j >= 5) {
            return Err(invalid(format!(
                "inputs {:?}: need increasing indices below 5",
                self.inputs
            )));
        }
        if self.lwr.database().n_inputs() != self.inputs.len() {
            return Err(invalid(format!(
                "the LWR has {} inputs, `inputs` lists {}",
                self.lwr.database().n_inputs(),
                self.inputs.len()
            )));
        }
        let fail = |e: trajopt::TrajoptError| invalid(e.to_string());
        let tracking = TrackingCost::new(
            Mat::from_fn(n + 1, 4, |k, i| self.state_reference[k][i]),
            Mat::from_fn(n, 1, |k, _| self.control_reference[k]),
            &self.state_weights,
            &[self.control_weight],
            &self.terminal_weights,
        )
        .map_err(fail)?;
        let bounds_ok = self.x_max > 0.0 && self.u_max > 0.0 && self.bound_weight >= 0.0;
        if !bounds_ok || !self.bound_weight.is_finite() {
            return Err(invalid(format!(
                "x_max {}, u_max {}, bound_weight {}: need positive bounds and a finite nonnegative weight",
                self.x_max, self.u_max, self.bound_weight
            )));
        }
        let cost = BoundedTracking {
            tracking,
            bounds: SoftBounds {
                x_max: self.x_max,
                u_max: self.u_max,
                sqrt_weight: self.bound_weight.sqrt(),
            },
        };
        let model = LearnedPendulum {
            dt: self.dt,
            prior: self.prior,
            inputs: self.inputs.clone(),
            lwr: self.lwr.clone(),
        };
        let times: Vec<f64> = (0..=n).map(|k| k as f64 * self.dt).collect();
        let basis =
            |coeffs| BSplineBasis::clamped_uniform(coeffs, 3, 0.0, times[n]).map_err(|e| invalid(e.to_string()));
        let problem = Eq3Problem::new(
            model,
            cost,
            &basis(self.state_coeffs)?,
            &basis(self.control_coeffs)?,
            &times,
            Lambda::Constant(self.lambda),
        )
        .and_then(|p| p.with_consistency_scale(1.0 / self.dt))
        .and_then(|p| p.with_initial_state(&[0.0; 4], self.initial_state_weight))
        .map_err(fail)?;
        if self.start.len() != trajopt::LeastSquaresProblem::n_params(&problem) {
            return Err(invalid(format!(
                "a start of {} coefficients for a problem of {}",
                self.start.len(),
                trajopt::LeastSquaresProblem::n_params(&problem)
            )));
        }
        Ok((problem, self.start.clone()))
    }
}

/// The instance's problem as the benchmark shares it.
pub(crate) fn shared_problem() -> Result<(Arc<LwrProblem>, Vec<f64>)> {
    let (problem, start) = LwrInstanceFile::compiled_in()?.problem()?;
    Ok((Arc::new(problem), start))
}
