//! What [`GaussNewton::solve`](crate::GaussNewton::solve) returns: the
//! [`GaussNewtonResult`] with its [`GaussNewtonStatus`].

use std::time::Duration;

/// Why [`GaussNewton`](crate::GaussNewton) stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum GaussNewtonStatus {
    /// The gradient $J^\top r$ is below tolerance.
    ConvergedGradient,
    /// The step is below tolerance.
    ConvergedStep,
    /// The cost no longer decreases.
    ConvergedCost,
    /// The iteration cap was reached.
    MaxIterations,
    /// A budget of residual evaluations was used up (the
    /// [derivative-free](crate::derivative_free) mode's; plain
    /// [`GaussNewton`](crate::GaussNewton) has no such budget).
    MaxEvaluations,
    /// Steps kept failing until the damping made them negligible, while the
    /// gradient is not small: the residuals are not smooth enough here for
    /// their linearisation to predict them (a rough learned model, or a
    /// Jacobian that does not match the residuals). Not a converged point.
    Stalled,
    /// The residuals or Jacobian became non-finite at every trial step, or
    /// the normal equations could not be factorised even with damping.
    NumericalError,
    /// The [`Watch`](solve::Watch)'s time limit passed (checked at every
    /// iteration and trial step).
    TimeLimit,
    /// An observer of the [`Watch`](solve::Watch) stopped the solve.
    Stopped,
}

solve::from_interrupt!(GaussNewtonStatus);

impl solve::Status for GaussNewtonStatus {
    fn termination(&self) -> solve::Termination {
        use solve::Termination as T;
        match self {
            Self::ConvergedGradient | Self::ConvergedStep | Self::ConvergedCost => T::Converged,
            Self::MaxIterations => T::MaxIterations,
            Self::MaxEvaluations => T::MaxEvaluations,
            Self::TimeLimit => T::TimeLimit,
            Self::Stopped => T::Stopped,
            Self::Stalled | Self::NumericalError => T::Failed,
        }
    }
}

/// The variant's name (`ConvergedGradient`), as serde writes it.
impl std::fmt::Display for GaussNewtonStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::ConvergedGradient => "ConvergedGradient",
            Self::ConvergedStep => "ConvergedStep",
            Self::ConvergedCost => "ConvergedCost",
            Self::MaxIterations => "MaxIterations",
            Self::MaxEvaluations => "MaxEvaluations",
            Self::Stalled => "Stalled",
            Self::NumericalError => "NumericalError",
            Self::TimeLimit => "TimeLimit",
            Self::Stopped => "Stopped",
        })
    }
}

impl GaussNewtonStatus {
    /// Whether this is one of the converged statuses.
    pub fn is_converged(self) -> bool {
        matches!(
            self,
            Self::ConvergedGradient | Self::ConvergedStep | Self::ConvergedCost
        )
    }
}

/// What [`GaussNewton::solve`](crate::GaussNewton::solve) returns.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct GaussNewtonResult {
    /// The best parameters found.
    pub x: Vec<f64>,
    /// $F$ at `x`.
    pub cost: f64,
    /// $F$ at the start.
    pub initial_cost: f64,
    /// Why it stopped.
    pub status: GaussNewtonStatus,
    /// Iterations (Jacobian evaluations).
    pub iterations: usize,
    /// Residual evaluations.
    pub evals: usize,
    /// Jacobian evaluations.
    pub jacobian_evals: usize,
    /// Numerical Cholesky factorisations (one per trial step, more when
    /// $J^\top J + S$ needs a shift, and with the trust region's search for
    /// its damping).
    pub factorizations: usize,
    /// Accepted cost after each iteration.
    pub cost_history: Vec<f64>,
    /// Wall time.
    pub solve_time: Duration,
    /// With [`GaussNewton::solve_parallel`](crate::GaussNewton::solve_parallel):
    /// the iteration from which the solve went on with one thread because
    /// its helpers answered late (a busy machine); `None` when it did not
    /// (and always without helpers).
    pub one_thread_from: Option<usize>,
}

solve::outcome!(GaussNewtonResult);
