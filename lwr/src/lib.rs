//! Locally weighted regression on a k-d tree (Atkeson, Moore & Schaal, 1997).
//!
//! **Not implemented yet** (issue "lwr: locally weighted regression on a k-d
//! tree"). The crate exists so that the workspace layout is final; it exports
//! nothing. See `DESIGN.md` section 2 for what it will hold: local
//! constant/linear/quadratic fits, kernels, ridge, confidence per query,
//! exact query derivatives and a metric tuned by leave-one-out
//! cross-validation.
#![warn(missing_docs)]
