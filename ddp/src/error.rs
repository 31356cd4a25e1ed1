//! The crate's error type.

/// Invalid input or invalid settings, or a user model that fails where no
/// usable answer is left (a step of the warm start's rollout). A solver that
/// stops without converging, or whose model blows up, is not an error: it
/// returns its last good iterate with a [`DdpStatus`](crate::DdpStatus).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DdpError {
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
        /// Position of the value (flattened, row-major for matrices).
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
    /// A user-supplied model failed ([`Dynamics::step`](crate::Dynamics::step)
    /// or [`Dynamics::jacobians`](crate::Dynamics::jacobians) returned it).
    #[error("the model failed: {0}")]
    Model(String),
}

/// A model's error is [`DdpError::Model`].
impl From<systems::ModelError> for DdpError {
    fn from(e: systems::ModelError) -> Self {
        Self::Model(e.0)
    }
}

/// The crate's result type.
pub type Result<T, E = DdpError> = std::result::Result<T, E>;

solve::input_checks!(DdpError, check_len);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finite_and_length_checks() {
        assert!(check_finite("x", &[1.0, 2.0]).is_ok());
        assert_eq!(
            check_finite("x", &[1.0, f64::NAN]).map_err(|e| matches!(e, DdpError::NotFinite { index: 1, .. })),
            Err(true)
        );
        assert!(check_len("u", 2, 2).is_ok());
        let e = check_len("u", 2, 3).expect_err("mismatch");
        assert_eq!(e.to_string(), "u: expected 2, got 3");
    }
}
