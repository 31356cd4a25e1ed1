#![doc = include_str!("../README.md")]
//! # Feature flags
#![doc = document_features::document_features!()]
#![warn(missing_docs)]

pub mod basis;
pub mod bspline;
pub mod error;
pub mod fit;
#[cfg(feature = "nalgebra")]
pub mod nalgebra_convert;
#[cfg(feature = "proptest")]
pub mod strategies;
pub mod wavelet;

/// The faer version this crate's public signatures use (its `Mat`, `MatRef`,
/// sparse matrices), re-exported so callers need no matching dependency.
pub use faer;

pub use basis::TrajectoryBasis;
pub use bspline::BSplineBasis;
pub use error::{Result, SplineError};
pub use fit::{FitSettings, Trajectory, fit_channel, fit_matrix};
