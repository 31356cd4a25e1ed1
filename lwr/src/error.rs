//! The crate's error type.

/// Everything that can go wrong when building a database, fitting at a query,
/// cross-validating or tuning.
///
/// A fit that works but is weak (few effective points, too few degrees of
/// freedom for a noise estimate, a regularised solve) is never an error: it is
/// a [`FitStatus`](crate::FitStatus) in the [`Prediction`](crate::Prediction).
/// An `Err` means there is no usable answer.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LwrError {
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
    /// An input or output vector of the wrong length.
    #[error("{what}: expected length {expected}, got {actual}")]
    DimensionMismatch {
        /// Which input.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        actual: usize,
    },
    /// The database holds no points.
    #[error("the database is empty")]
    EmptyDatabase,
    /// No stored point has positive weight at the query: the query is outside
    /// the kernel's support around every point. The model refuses to
    /// extrapolate.
    #[error(
        "no data carries weight at the query (nearest point at scaled distance {nearest_distance}, kernel support {support})"
    )]
    NoWeightedData {
        /// Scaled distance $d$ from the query to its nearest stored point.
        nearest_distance: f64,
        /// Largest distance that carries weight, $c h$.
        support: f64,
    },
    /// The weighted normal equations could not be solved even with the
    /// regularised fallback.
    #[error("the local fit is singular: {reason}")]
    SingularFit {
        /// Detail from the factorisation.
        reason: String,
    },
    /// A parameter outside its valid range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// Saving or loading a model failed.
    #[error("serialisation failed: {0}")]
    Serde(String),
}

/// The crate's result type.
pub type Result<T, E = LwrError> = std::result::Result<T, E>;

solve::input_checks!(LwrError, check_len);
