//! The crate's error type.

/// Everything that can go wrong when building a basis, evaluating it or fitting
/// coefficients. Not converging is never an error here: all routines are direct.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SplineError {
    /// A knot vector must be nondecreasing.
    #[error("knots must be nondecreasing: knot {index} ({value}) is smaller than knot {} ({previous})", index - 1)]
    UnsortedKnots {
        /// Index of the first knot that breaks the order.
        index: usize,
        /// Its value.
        value: f64,
        /// The value of the knot before it.
        previous: f64,
    },
    /// A knot vector of a degree-`p` spline needs at least `2p + 2` knots
    /// (one coefficient more than the degree).
    #[error("a degree-{degree} B-spline needs at least {required} knots, got {actual}")]
    TooFewKnots {
        /// Spline degree.
        degree: usize,
        /// Minimum number of knots.
        required: usize,
        /// Knots given.
        actual: usize,
    },
    /// A knot has multiplicity larger than `degree + 1`, or the domain
    /// `[t_p, t_n]` is empty, so the degree is too high for the knot vector.
    #[error("degree {degree} is too high for this knot vector: {reason}")]
    DegreeTooHigh {
        /// Spline degree.
        degree: usize,
        /// What is wrong with the knots.
        reason: &'static str,
    },
    /// An evaluation time outside the basis' domain. Bases refuse to
    /// extrapolate; they never clamp silently.
    #[error("time {t} is outside the domain [{lo}, {hi}]")]
    OutsideDomain {
        /// The offending time.
        t: f64,
        /// Lower end of the domain.
        lo: f64,
        /// Upper end of the domain.
        hi: f64,
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
    /// An input that must not be empty is empty.
    #[error("{what} is empty")]
    Empty {
        /// Which input.
        what: &'static str,
    },
    /// Two inputs whose lengths must agree do not.
    #[error("{what}: expected length {expected}, got {actual}")]
    LengthMismatch {
        /// Which input.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        actual: usize,
    },
    /// A parameter outside its valid range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// The least-squares normal equations are singular: the samples do not
    /// determine every coefficient. Add ridge smoothing or more samples.
    #[error(
        "the least-squares fit is singular ({reason}); add ridge smoothing or samples that cover every basis function"
    )]
    SingularFit {
        /// Detail from the factorisation.
        reason: String,
    },
}

/// The crate's result type.
pub type Result<T, E = SplineError> = std::result::Result<T, E>;

/// Checks that every value is finite.
pub(crate) fn check_finite(what: &'static str, values: &[f64]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(SplineError::NotFinite {
            what,
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

/// Checks that an input (`what`) has the length it must have.
pub(crate) fn check_len(what: &'static str, expected: usize, actual: usize) -> Result<()> {
    if expected == actual {
        Ok(())
    } else {
        Err(SplineError::LengthMismatch { what, expected, actual })
    }
}
