//! Differential dynamic programming (Jacobson & Mayne, 1970), the paper's
//! consistent local planner (Eqs. 1-2).
//!
//! **Not implemented yet** (issue "ddp: differential dynamic programming").
//! The crate exists so that the workspace layout is final; it exports nothing.
#![warn(missing_docs)]
