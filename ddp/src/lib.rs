#![doc = include_str!("../README.md")]
//! # Feature flags
#![doc = document_features::document_features!()]
#![warn(missing_docs)]

#[cfg(any(test, feature = "proptest"))]
mod diff;
pub mod error;
mod linalg;
pub mod models;
#[cfg(feature = "nalgebra")]
pub mod nalgebra_convert;
pub mod problem;
pub mod problems;
mod residual;
mod shooting;
pub mod solver;
#[cfg(feature = "proptest")]
pub mod strategies;

/// The faer version this crate's public signatures use (its `Mat`, `MatRef`,
/// sparse matrices), re-exported so callers need no matching dependency.
pub use faer;

pub use error::{DdpError, Result};
pub use models::{Acrobot, CartPole, LinearDynamics, Pendulum, QuadraticCost};
pub use problem::{Cost, CostDerivatives, DdpProblem, Dynamics};
pub use residual::ResidualCost;
pub use solver::{Ddp, DdpMethod, DdpResult, DdpRun, DdpSettings, DdpStatus, Regularization};
pub use systems::{ModelError, ModelResult, StageCost};
