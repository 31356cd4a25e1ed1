#![doc = include_str!("../README.md")]
//! # Feature flags
#![doc = document_features::document_features!()]
#![warn(missing_docs)]

#[cfg(feature = "cli")]
pub mod csv_fit;
mod database;
mod error;
mod factor;
mod fit;
mod kdtree;
mod loo;
mod metric;
mod model;
#[cfg(feature = "nalgebra")]
mod nalgebra_interop;
pub mod regressor;
mod scale_grad;
mod scaled;
mod settings;
#[cfg(feature = "proptest")]
pub mod strategies;
mod tune;

/// The faer version this crate's public signatures use (its `Mat`, `MatRef`,
/// sparse matrices), re-exported so callers need no matching dependency.
pub use faer;

/// The local fits' hand-written Cholesky factorisation and solve, public only
/// so that `benches/cholesky.rs` times the crate's own code against nalgebra
/// and faer (instead of a copy that could drift); not part of the API.
#[doc(hidden)]
pub mod bench {
    pub use crate::factor::{chol_solve, cholesky};
}

pub use database::{Database, Neighbor};
pub use error::{LwrError, Result};
pub use loo::LooResult;
pub use model::{FitStatus, LwrModel, Prediction, t_quantile};
pub use regressor::FitSettings;
pub use settings::{Degree, Kernel, LwrSettings};
pub use tune::{TuneMethod, TuneResult, TuneRun, TuneSettings, TuneStatus, TuneStep};
