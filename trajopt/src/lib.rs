#![doc = include_str!("../README.md")]
//! # Feature flags
#![doc = document_features::document_features!()]
pub mod check;
pub mod derivative_free;
pub mod eq3;
pub mod error;
pub mod fit;
pub mod gauss_newton;
pub mod least_squares;
pub mod linalg;
pub mod models;
#[cfg(feature = "nalgebra")]
pub mod nalgebra_convert;
pub mod powell;
pub mod problems;
#[cfg(feature = "proptest")]
pub mod strategies;

/// The faer version this crate's public signatures use (its `Mat`, `MatRef`,
/// sparse matrices), re-exported so callers need no matching dependency.
pub use faer;

pub use check::{JacobianCheck, check_jacobian, check_model_jacobians, check_stage_cost_jacobians};
pub use derivative_free::{
    DerivativeFree, DerivativeFreeResult, DerivativeFreeRun, DerivativeFreeSettings, Difference,
};
pub use eq3::{CostBreakdown, Eq3Problem, Lambda, StageCost, TrackingCost};
pub use error::{Result, TrajoptError};
pub use fit::{FitStatus, LeastSquares, LeastSquaresFit, Method, dense_pattern};
pub use gauss_newton::{
    DampingScale, GaussNewton, GaussNewtonResult, GaussNewtonRun, GaussNewtonSettings, GaussNewtonStatus, LinearSolver,
    MIN_PARALLEL_PARAMS, StepControl, StepModel,
};
pub use least_squares::{
    BandForm, BandNormalEquations, LeastSquaresProblem, LinearBounds, LinearLeastSquares, Part, Point, SecondOrder,
};
pub use linalg::{BandLayout, BandedSym};
pub use models::LinearModel;
pub use powell::{Powell, PowellResult, PowellSettings, PowellStatus};
pub use systems::{Dynamics, ModelError, ModelResult};
