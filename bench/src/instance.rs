//! One benchmark instance (a problem and a starting point, with the
//! trajectory set's exact forms) and how a point of it is scored: its own
//! $f = \lVert r \rVert^2$ ([`cost_at`]) or, for a trajectory swing-up,
//! the task cost of its controls rolled out through the exact dynamics
//! ([`rollout_cost`]). The lowest layer of the crate above its error type:
//! the problem sets, the solvers, the trajectory set and the minima all
//! build on it.

use std::sync::Arc;

use ddp::problems as ddp_problems;
use ddp::{DdpProblem, models::QuadraticCost};
use trajopt::LeastSquaresProblem;
use trajopt::problems::trajectory::SwingUpProblem;

use crate::error::{BenchError, Result};

/// The trajectory set's name in the records.
pub const TRAJECTORY_SET: &str = "trajectory";

/// A problem for the runner: a least-squares problem any solver here can use.
pub type SharedProblem = Arc<dyn LeastSquaresProblem + Send + Sync>;

/// One problem from one starting point.
#[derive(Clone)]
pub struct Instance {
    /// The set's name.
    pub set: &'static str,
    /// The problem's name within the set (`24_penalty2`).
    pub problem: String,
    /// The start's scale.
    pub scale: f64,
    /// The starting point.
    pub start: Vec<f64>,
    /// The published optimal value, if any.
    pub f_star: Option<f64>,
    /// Number of residuals.
    pub residuals: usize,
    /// The problem.
    pub least_squares: SharedProblem,
    /// The trajectory set's two forms of the problem, by which its runs
    /// are scored ([`rollout_cost`]) and on which the
    /// DDP solvers run; `None` when runs are scored by the problem's own
    /// $f$.
    pub rollout: Option<Arc<Forms>>,
}

impl std::fmt::Debug for Instance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{} x{}", self.set, self.problem, self.scale)
    }
}

impl Instance {
    /// Number of parameters.
    pub fn n(&self) -> usize {
        self.start.len()
    }
}

/// The DDP form of a registry swing-up.
pub type DdpSwingUp = DdpProblem<ddp_problems::SwingUpModel, QuadraticCost>;

/// The two forms of one registry instance: the Eq. 3 problem (to read the
/// controls of a point) and the DDP problem (to roll them out, and for the
/// DDP solvers).
#[derive(Debug)]
pub struct Forms {
    /// The Eq. 3 form.
    pub eq3: Arc<SwingUpProblem>,
    /// The DDP form (exact dynamics, task cost).
    pub ddp: DdpSwingUp,
}

/// The task cost of the controls of `theta` (a point of `forms.eq3`)
/// rolled out from the start through the exact dynamics: the DDP form's
/// stage and terminal costs, infinite when the rollout is not finite. The
/// states of `theta` are ignored.
///
/// # Errors
/// A `theta` of the wrong length or not finite, or a failed step.
pub fn rollout_cost(forms: &Forms, theta: &[f64]) -> Result<f64> {
    let (_, controls) = forms.eq3.trajectory(theta).map_err(|e| rollout_error(e.to_string()))?;
    let controls: Vec<Vec<f64>> = (0..controls.nrows())
        .map(|k| (0..controls.ncols()).map(|j| controls[(k, j)]).collect())
        .collect();
    forms
        .ddp
        .rollout_cost(&controls)
        .map_err(|e| rollout_error(e.to_string()))
}

/// $f(x_0) = \lVert r(x_0) \rVert^2$ of the instance's own problem,
/// uncounted; NaN where it cannot be evaluated or overflows (the records
/// hold finite values or NaN).
pub fn start_cost(instance: &Instance) -> f64 {
    cost_at(instance, &instance.start)
        .filter(|f| f.is_finite())
        .unwrap_or(f64::NAN)
}

/// $f(x) = \lVert r(x) \rVert^2$ of the instance's own problem, uncounted
/// (`None`: `x` of the wrong length, or the residuals failed); may be
/// infinite.
pub fn cost_at(instance: &Instance, x: &[f64]) -> Option<f64> {
    let problem = instance.least_squares.as_ref();
    if x.len() != problem.n_params() {
        return None;
    }
    let mut r = vec![0.0; problem.n_residuals()];
    problem.residuals(x, &mut r).ok()?;
    Some(r.iter().map(|v| v * v).sum())
}

/// A figure of merit for the records, which hold finite values: a
/// rollout that blew up (infinite cost) is recorded as `f64::MAX`.
pub fn finite(f: f64) -> f64 {
    if f.is_finite() { f } else { f64::MAX }
}

fn rollout_error(reason: String) -> BenchError {
    BenchError::InvalidSetting {
        name: "trajectory instance",
        reason,
    }
}
