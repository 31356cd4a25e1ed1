//! The crate's error type.

/// Invalid input, invalid settings, or a failure that leaves no usable
/// answer. A solver that stops without converging is not an error: it
/// returns its best point with a status.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TrajoptError {
    /// An error from the trajectory bases.
    #[error(transparent)]
    Basis(#[from] splines::SplineError),
    /// Two sizes that must agree do not.
    #[error("{what}: expected {expected}, got {actual}")]
    DimensionMismatch {
        /// What was measured.
        what: &'static str,
        /// Expected size.
        expected: usize,
        /// Actual size.
        actual: usize,
    },
    /// A NaN or infinite value in the input.
    #[error("{what}[{index}] is not finite ({value})")]
    NotFinite {
        /// Which input.
        what: &'static str,
        /// Position of the value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// A setting or parameter outside its valid range.
    #[error("invalid {name}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// The objective (or the model inside it) returned a non-finite value
    /// at the starting point, so there is nothing to improve on.
    #[error("the objective is not finite at the starting point ({value})")]
    NonFiniteStart {
        /// The value returned.
        value: f64,
    },
    /// The bounds admit no parameters (no point satisfies them all).
    #[error("the bounds are infeasible: no parameters satisfy them all")]
    InfeasibleBounds,
    /// A budget of evaluations ran out inside a problem wrapper
    /// ([`GroupedDifferences`](crate::derivative_free::GroupedDifferences));
    /// the solver that owns the budget turns it into a status, so a caller
    /// of a solver never sees it.
    #[error("the budget of {evaluations} evaluations is used up")]
    BudgetExhausted {
        /// Evaluations made.
        evaluations: usize,
    },
    /// A user-supplied model or cost failed.
    #[error("the model failed: {0}")]
    Model(String),
}

/// A model's or a stage cost's error is [`TrajoptError::Model`].
impl From<systems::ModelError> for TrajoptError {
    fn from(e: systems::ModelError) -> Self {
        Self::Model(e.0)
    }
}

/// The crate's result type.
pub type Result<T, E = TrajoptError> = std::result::Result<T, E>;

solve::input_checks!(TrajoptError, expect_len);

/// Checks that a point has `expected` entries, all finite.
pub(crate) fn check_point(what: &'static str, expected: usize, values: &[f64]) -> Result<()> {
    expect_len(what, expected, values.len())?;
    check_finite(what, values)
}

/// Checks that each named setting is finite and nonnegative; the error
/// names the first that is not.
pub(crate) fn check_nonnegative<const N: usize>(settings: [(&'static str, f64); N]) -> Result<()> {
    for (name, v) in settings {
        if !(v.is_finite() && v >= 0.0) {
            return Err(TrajoptError::InvalidParameter {
                name,
                reason: format!("must be finite and nonnegative, got {v}"),
            });
        }
    }
    Ok(())
}
