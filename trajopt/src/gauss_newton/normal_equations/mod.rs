//! The normal equations of one Gauss-Newton iteration, formed and solved
//! in one of three ways behind one trait ([`NormalEquations`]):
//!
//! - [`SparseSystem`] (`sparse.rs`): the general form: a sparse Jacobian,
//!   $J^\top J$ by a sparse product, a sparse Cholesky factorisation with
//!   its symbolic part reused; the only one that handles bounds;
//! - [`BandSystem`] (`band.rs`): the band form of problems that have one
//!   ([`BandForm`](crate::BandForm)), a band Cholesky factorisation; with
//!   helper threads, the normal equations formed in parts;
//! - [`SplitSystem`] (`split.rs`): the band form on two threads, kept and
//!   factorised in two parts ([`crate::gauss_newton::split`]).
//!
//! The solver holds one as a `Box<dyn NormalEquations<P>>`: a handful of
//! calls per iteration, each doing $O(N)$ work, so the dynamic dispatch
//! costs nothing measurable.

mod band;
mod sparse;
mod split;

pub(super) use band::BandSystem;
pub(super) use sparse::SparseSystem;
pub(super) use split::SplitSystem;

use crate::error::Result;
use crate::least_squares::{LeastSquaresProblem, Point};

/// The widest band worth factorising as a band: beyond it the sparse
/// factorisation with a fill-reducing ordering wins.
pub(super) const MAX_HALF_BANDWIDTH: usize = 96;

/// The damping of one trial step: the model matrix $H$ (the Newton matrix
/// $J^\top J + S$ if `newton`, else $J^\top J$) plus `total` $\cdot D$,
/// $D = $ `scale` (the damping scale, parameter order).
#[derive(Debug, Clone, Copy)]
pub(super) struct Damping<'a> {
    pub(super) newton: bool,
    pub(super) total: f64,
    pub(super) scale: &'a [f64],
}

/// One way of forming and solving the normal equations of `P`; see the
/// [module docs](self).
pub(super) trait NormalEquations<P: LeastSquaresProblem + ?Sized> {
    /// Whether this system's helper threads answered late often enough
    /// that one thread would be faster
    /// ([`Helpers::degraded`](crate::gauss_newton::parallel::Helpers::degraded)).
    fn helpers_degraded(&mut self) -> bool {
        false
    }

    /// Forms $J^\top J$ (and $J^\top J + S$ when asked and available) and
    /// $g = J^\top r$ at $\theta$. `None` if the Jacobian is not finite;
    /// otherwise whether the Newton matrix $J^\top J + S$ is ready.
    fn assemble(&mut self, problem: &P, at: Point<'_>, grad: &mut [f64], want_s: bool) -> Result<Option<bool>>;

    /// $r(\theta)$, split over the helper threads if there are any.
    fn residuals(&mut self, problem: &P, theta: &[f64], r: &mut [f64]) -> Result<()> {
        problem.residuals(theta, r)
    }

    /// The diagonal of $J^\top J$, in the parameter order.
    fn jtj_diagonal(&self, out: &mut [f64]);

    /// Solves $(H + \text{total}\, D)\,\delta = -g$; `step` holds $-g$ on
    /// entry and $\delta$ on success. False if the matrix is not
    /// numerically positive definite.
    fn damped_step(&mut self, damping: Damping<'_>, step: &mut [f64]) -> bool;

    /// Makes the Gauss-Newton matrix $J^\top J$ available at this iterate
    /// (the band form may hold only $J^\top J + S$); false if it is not
    /// finite.
    fn ensure_gauss_newton(&mut self, problem: &P, at: Point<'_>) -> Result<bool> {
        let _ = (problem, at);
        Ok(true)
    }

    /// The sparse form, the only one that handles bounds
    /// ([`SparseSystem::bounded_step`]); `None` by default.
    fn as_sparse(&mut self) -> Option<&mut SparseSystem> {
        None
    }

    /// $H \delta$ with the undamped model matrix.
    fn model_mul(&mut self, newton: bool, step: &[f64], out: &mut [f64]);

    /// $J v$ into `out` (one entry per residual) and true, when this form
    /// holds the Jacobian itself; false by default (the band forms hold
    /// only $J^\top J$).
    fn jacobian_mul(&self, v: &[f64], out: &mut [f64]) -> bool {
        let _ = (v, out);
        false
    }

    /// $J^\top w$ into `out` and true, when this form holds the Jacobian
    /// itself; false by default.
    fn jacobian_transpose_mul(&self, w: &[f64], out: &mut [f64]) -> bool {
        let _ = (w, out);
        false
    }
}

/// $\lVert v \rVert^2$.
pub(super) fn sum_sq(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum()
}
