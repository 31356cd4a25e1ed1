//! Linear algebra on the hot path: symmetric band matrices and their
//! Cholesky factorisation ([`band`]), and the crate's SIMD kernels with the
//! table of the fixed shapes compiled with their sizes known
//! (`kernels.rs`).

pub mod band;
pub(crate) mod kernels;

pub use band::{BandCholesky, BandLayout, BandedSym};
