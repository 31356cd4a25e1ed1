//! The paper's Eq. 3 trajectory optimiser,
//! $C = \sum_k c(x_k, u_k) + \lambda_k \lVert x_{k+1} - f(x_k, u_k) \rVert^2$,
//! over the coefficients of [`splines`] bases (work in progress).
#![warn(missing_docs)]

pub mod error;
pub mod gauss_newton;
pub mod least_squares;
pub mod models;
pub mod powell;
pub mod problem;

pub use error::{Result, TrajoptError};
pub use gauss_newton::{GaussNewton, GaussNewtonResult, GaussNewtonSettings, GaussNewtonStatus};
pub use least_squares::{LeastSquaresProblem, LinearLeastSquares};
pub use models::LinearModel;
pub use problem::{CostBreakdown, Eq3Problem, Lambda, Model, StageCost, TrackingCost};
