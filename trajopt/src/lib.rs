#![doc = include_str!("../README.md")]
//! # Feature flags
#![doc = document_features::document_features!()]
mod band_model;
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
mod parallel;
pub mod powell;
pub mod problems;
#[cfg(feature = "bounds")]
mod qp;
/// Without the `bounds` feature there is no QP solver: Gauss-Newton refuses
/// a bounded problem before its first step, so these are never reached.
#[cfg(not(feature = "bounds"))]
mod qp {
    use faer::sparse::SparseColMat;

    use crate::least_squares::LinearBounds;

    pub(crate) fn bounded_step(
        _: &SparseColMat<usize, f64>,
        _: &[f64],
        _: &LinearBounds,
        _: &[f64],
    ) -> Option<Vec<f64>> {
        None
    }

    pub(crate) fn projection(_: &LinearBounds, _: &[f64]) -> Option<Vec<f64>> {
        None
    }
}
mod split;
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
    MIN_PARALLEL_PARAMS, StepModel,
};
pub use least_squares::{
    BandForm, BandNormalEquations, LeastSquaresProblem, LinearBounds, LinearLeastSquares, Part, Point, SecondOrder,
};
pub use linalg::{BandLayout, BandedSym};
pub use models::LinearModel;
pub use powell::{Powell, PowellResult, PowellSettings, PowellStatus};
pub use systems::{Dynamics, ModelError, ModelResult};
