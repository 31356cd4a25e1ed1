//! Geodesic acceleration of a trust-region step
//! ([`GaussNewtonSettings::geodesic_acceleration`](super::GaussNewtonSettings::geodesic_acceleration)):
//! Transtrum and Sethna's second-order correction.
//!
//! The Levenberg-Marquardt step $v$ is the first-order term of a geodesic
//! on the model manifold; the second-order term, the acceleration
//! $a = -(J^\top J + \lambda D)^{-1} J^\top r_{vv}$, bends the step along a
//! curved valley, with $r_{vv}$ the residuals' second directional
//! derivative along $v$, here by the finite difference
//! $r_{vv} \approx \frac{2}{h}\left(\frac{r(\theta + h v) - r(\theta)}{h} - J v\right)$,
//! $h = 0.1$: one residual evaluation and one factorisation per trial
//! step. The step taken is $v + a/2$; when $2\lVert a \rVert_D > \alpha \lVert v \rVert_D$,
//! $\alpha = 3/4$, the quadratic path is not trusted and the step is
//! rejected (the region shrinks). Both constants are the paper's.
//!
//! Reference: M. K. Transtrum, J. P. Sethna, "Improvements to the
//! Levenberg-Marquardt algorithm for nonlinear least-squares minimization",
//! arXiv:1201.5885 (2012); the same rule as GSL's `gsl_multifit_nlinear`
//! with `trs_lmaccel`.

use super::normal_equations::{Damping, NormalEquations};
use super::trust_region::TrustRegion;
use crate::error::Result;
use crate::least_squares::{LeastSquaresProblem, Point};

/// The finite-difference step along $v$ for $r_{vv}$.
const H: f64 = 0.1;
/// The largest accepted $2\lVert a \rVert / \lVert v \rVert$.
const ALPHA: f64 = 0.75;

/// What [`Geodesic::accelerate`] did to the step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Acceleration {
    /// The step is now $v + a/2$.
    Accelerated,
    /// The acceleration was too large: the step should be rejected.
    Rejected,
    /// No acceleration could be formed (the form holds no Jacobian, or a
    /// probe or a solve was not finite): the step is left as it was.
    Unavailable,
}

/// What an acceleration spent.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Spent {
    pub(super) residuals: usize,
    pub(super) factorizations: usize,
}

/// Buffers for the acceleration, reused across steps.
#[derive(Debug, Clone)]
pub(super) struct Geodesic {
    probe: Vec<f64>,
    r_probe: Vec<f64>,
    jv: Vec<f64>,
    acc: Vec<f64>,
}

impl Geodesic {
    pub(super) fn new(n_p: usize, n_r: usize) -> Self {
        Self {
            probe: vec![0.0; n_p],
            r_probe: vec![0.0; n_r],
            jv: vec![0.0; n_r],
            acc: vec![0.0; n_p],
        }
    }

    /// Adds half the acceleration to the step `v` (the solution of
    /// $(J^\top J + \lambda D) v = -g$) at `at`, or says why not.
    pub(super) fn accelerate<P: LeastSquaresProblem + ?Sized>(
        &mut self,
        system: &mut dyn NormalEquations<P>,
        problem: &P,
        at: Point<'_>,
        lambda: f64,
        scale: &[f64],
        v: &mut [f64],
    ) -> Result<(Acceleration, Spent)> {
        let mut spent = Spent::default();
        if !system.jacobian_mul(v, &mut self.jv) {
            return Ok((Acceleration::Unavailable, spent));
        }
        for ((p, t), d) in self.probe.iter_mut().zip(at.theta).zip(v.iter()) {
            *p = t + H * d;
        }
        system.residuals(problem, &self.probe, &mut self.r_probe)?;
        spent.residuals += 1;
        // r_vv into r_probe
        for ((rp, r), jv) in self.r_probe.iter_mut().zip(at.r).zip(&self.jv) {
            *rp = (2.0 / H) * ((*rp - r) / H - jv);
        }
        if !self.r_probe.iter().all(|x| x.is_finite()) || !system.jacobian_transpose_mul(&self.r_probe, &mut self.acc) {
            return Ok((Acceleration::Unavailable, spent));
        }
        for a in &mut self.acc {
            *a = -*a;
        }
        spent.factorizations += 1;
        let damping = Damping {
            newton: false,
            total: lambda,
            scale,
        };
        if !system.damped_step(damping, &mut self.acc) || !self.acc.iter().all(|x| x.is_finite()) {
            return Ok((Acceleration::Unavailable, spent));
        }
        if 2.0 * TrustRegion::length(&self.acc, scale) > ALPHA * TrustRegion::length(v, scale) {
            return Ok((Acceleration::Rejected, spent));
        }
        for (d, a) in v.iter_mut().zip(&self.acc) {
            *d += 0.5 * a;
        }
        Ok((Acceleration::Accelerated, spent))
    }
}
