//! What a solve returns: the trajectory, the local policy and value
//! function, the status and the statistics.

use std::time::Duration;

use faer::Mat;

use super::settings::DdpMethod;

/// How a solve ended. Only [`DdpStatus::Converged`] is a success; every
/// other status still comes with the last good (finite) iterate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum DdpStatus {
    /// The expected reduction or the feedforward step fell below tolerance.
    Converged,
    /// `max_iterations` reached.
    MaxIterations,
    /// The [`Watch`](solve::Watch)'s time limit passed (checked at every
    /// iteration and before every trial rollout).
    TimeLimit,
    /// An observer of the [`Watch`](solve::Watch) stopped the solve.
    Stopped,
    /// The initial rollout (warm start, open loop) left the finite region or
    /// exceeded `max_state_norm` at state `step`; the result holds the
    /// states before it and no policy.
    InitialRolloutDiverged {
        /// Index of the first bad state $x_{step}$.
        step: usize,
    },
    /// Every trial rollout of the line search blew up, and raising the
    /// regularisation to `reg_max` did not help.
    RolloutDiverged,
    /// $\tilde Q_{uu}$ stayed indefinite up to `reg_max`.
    NotPositiveDefinite,
    /// No step size reduced the cost, up to `reg_max`.
    NoDescent,
    /// The dynamics or cost returned non-finite derivatives at a finite
    /// trajectory, or [`Dynamics::jacobians`](crate::Dynamics::jacobians)
    /// returned an error.
    NonFiniteDerivatives,
}

impl DdpStatus {
    /// `true` for [`DdpStatus::Converged`].
    pub fn is_converged(&self) -> bool {
        matches!(self, Self::Converged)
    }

    /// `true` for the statuses saying the model or the local quadratic
    /// model failed (everything but `Converged`, `MaxIterations`,
    /// `TimeLimit` and `Stopped`).
    pub fn is_failure(&self) -> bool {
        !matches!(
            self,
            Self::Converged | Self::MaxIterations | Self::TimeLimit | Self::Stopped
        )
    }
}

solve::from_interrupt!(DdpStatus);

impl solve::Status for DdpStatus {
    fn termination(&self) -> solve::Termination {
        use solve::Termination as T;
        match self {
            Self::Converged => T::Converged,
            Self::MaxIterations => T::MaxIterations,
            Self::TimeLimit => T::TimeLimit,
            Self::Stopped => T::Stopped,
            Self::InitialRolloutDiverged { .. }
            | Self::RolloutDiverged
            | Self::NotPositiveDefinite
            | Self::NoDescent
            | Self::NonFiniteDerivatives => T::Failed,
        }
    }
}

/// The outcome of [`Ddp::solve`](crate::Ddp::solve): the trajectory, the local linear policy
/// (Eq. 2) and the local quadratic value function (Eq. 1) along it, and the
/// solver's history.
///
/// The policy and value terms come from a backward pass at the returned
/// trajectory (with regularisation `regularization`); they are empty when
/// that pass was impossible (statuses `InitialRolloutDiverged`,
/// `NotPositiveDefinite`, `NonFiniteDerivatives`).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DdpResult {
    /// States $x^*_0, \dots, x^*_N$ (fewer only with `InitialRolloutDiverged`).
    pub states: Vec<Vec<f64>>,
    /// Controls $u^*_0, \dots, u^*_{N-1}$.
    pub controls: Vec<Vec<f64>>,
    /// Feedforward terms $k_t$ of the last backward pass (near zero at convergence).
    pub feedforward: Vec<Vec<f64>>,
    /// Feedback gains $K_t$ ($m \times n$): $u = u^*_t + K_t (x - x^*_t)$.
    #[cfg_attr(feature = "serde", serde(with = "matrices"))]
    pub gains: Vec<Mat<f64>>,
    /// Cost-to-go $V_0(t) = \sum_{j \ge t} \ell(x^*_j, u^*_j, j) + \ell_f(x^*_N)$, $t = 0..N$.
    pub value: Vec<f64>,
    /// $V_x(t)$, $t = 0..N$.
    pub value_gradient: Vec<Vec<f64>>,
    /// $V_{xx}(t)$ ($n \times n$), $t = 0..N$.
    #[cfg_attr(feature = "serde", serde(with = "matrices"))]
    pub value_hessian: Vec<Mat<f64>>,
    /// Final cost $J$ (infinite only with `InitialRolloutDiverged`).
    pub cost: f64,
    /// Cost of the warm start.
    pub initial_cost: f64,
    /// Cost before the first iteration and after each iteration (length `iterations + 1`).
    pub cost_history: Vec<f64>,
    /// Regularisation $\mu$ used by each iteration's accepted backward pass.
    pub regularizations: Vec<f64>,
    /// Accepted step size of each iteration (0 when the line search failed).
    pub step_sizes: Vec<f64>,
    /// Regularisation of the backward pass that produced the policy.
    pub regularization: f64,
    /// Iterations performed.
    pub iterations: usize,
    /// The method that ran: [`DdpMethod::Ddp`] only if it was asked for and
    /// the dynamics provided second derivatives, else [`DdpMethod::Ilqr`].
    pub method: DdpMethod,
    /// Rollouts, each a cost evaluation of a whole trajectory: the warm
    /// start's and every line-search trial.
    pub evals: usize,
    /// Linearisations of the dynamics and the cost along a whole trajectory
    /// (each [`Dynamics::jacobians`](crate::Dynamics::jacobians) at every knot).
    pub jacobian_evals: usize,
    /// How the solve ended.
    pub status: DdpStatus,
    /// Wall-clock solve time.
    pub solve_time: Duration,
}

solve::outcome!(DdpResult);

impl DdpResult {
    /// The local linear policy (Eq. 2) at step `t`:
    /// $u = u^*_t + K_t (x - x^*_t)$ (without feedforward). `None` when the
    /// result holds no policy or `t` is out of range.
    pub fn policy(&self, t: usize, x: &[f64]) -> Option<Vec<f64>> {
        let gain = self.gains.get(t)?;
        let (xs, us) = (self.states.get(t)?, self.controls.get(t)?);
        Some(
            (0..us.len())
                .map(|i| us[i] + (0..xs.len()).map(|j| gain[(i, j)] * (x[j] - xs[j])).sum::<f64>())
                .collect(),
        )
    }

    /// The local quadratic value model (Eq. 1) at step `t`:
    /// $V_0(t) + V_x(t)^\top \delta x + \tfrac12 \delta x^\top V_{xx}(t) \delta x$,
    /// $\delta x = x - x^*_t$. `None` when the result holds no value model or
    /// `t` is out of range.
    pub fn value_model(&self, t: usize, x: &[f64]) -> Option<f64> {
        let (v0, vx, vxx, xs) = (
            self.value.get(t)?,
            self.value_gradient.get(t)?,
            self.value_hessian.get(t)?,
            self.states.get(t)?,
        );
        let d: Vec<f64> = x.iter().zip(xs).map(|(a, b)| a - b).collect();
        let n = d.len();
        let mut v = *v0;
        for i in 0..n {
            v += vx[i] * d[i] + 0.5 * d[i] * (0..n).map(|j| vxx[(i, j)] * d[j]).sum::<f64>();
        }
        Some(v)
    }
}

/// faer matrices as lists of rows, for serde (feature `serde`).
#[cfg(feature = "serde")]
mod matrices {
    use faer::Mat;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub(super) fn serialize<S: Serializer>(mats: &[Mat<f64>], s: S) -> Result<S::Ok, S::Error> {
        let rows: Vec<Vec<Vec<f64>>> = mats
            .iter()
            .map(|m| {
                (0..m.nrows())
                    .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
                    .collect()
            })
            .collect();
        rows.serialize(s)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Mat<f64>>, D::Error> {
        let rows = Vec::<Vec<Vec<f64>>>::deserialize(d)?;
        rows.into_iter()
            .map(|m| {
                let ncols = m.first().map_or(0, Vec::len);
                if m.iter().any(|row| row.len() != ncols) {
                    return Err(serde::de::Error::custom("a matrix's rows differ in length"));
                }
                Ok(Mat::from_fn(m.len(), ncols, |i, j| m[i][j]))
            })
            .collect()
    }
}
