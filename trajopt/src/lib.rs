//! The paper's Eq. 3 trajectory optimiser,
//! $C = \sum_k c(x_k, u_k) + \lambda_k \lVert x_{k+1} - f(x_k, u_k) \rVert^2$,
//! over the coefficients of [`splines`] bases.
//!
//! **Not implemented yet** (issue "trajopt: the paper's Eq. 3 planner"). The
//! crate exists so that the workspace layout is final; it exports nothing.
#![warn(missing_docs)]
