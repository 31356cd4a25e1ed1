//! The dynamics model of Eq. 3's consistency term.

use crate::error::Result;

/// A discrete-time dynamics model $x_{k+1} = f(x_k, u_k)$.
pub trait Model {
    /// State dimension $n$.
    fn state_dim(&self) -> usize;

    /// Control dimension $m$.
    fn control_dim(&self) -> usize;

    /// Writes $f(x, u)$ into `next`.
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> Result<()>;

    /// Writes $\partial f / \partial x$ ($n \times n$) and $\partial f / \partial u$
    /// ($n \times m$), row-major, and returns `true`; or returns `false`
    /// (the default) to have them computed by central differences.
    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<bool> {
        let _ = (x, u, fx, fu);
        Ok(false)
    }

    /// Which entries of $\partial f / \partial x$ and $\partial f / \partial u$
    /// (row-major, as in [`jacobians`](Self::jacobians)) can be nonzero; the
    /// default says all. A model that leaves structural zeros out shrinks
    /// the planner's Jacobian and normal equations; it must not leave out
    /// any entry that can be nonzero.
    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        fx.fill(true);
        fu.fill(true);
    }

    /// Writes the weighted second derivative
    /// $\sum_i w_i \nabla^2 f_i(z)$ over $z = (x, u)$, an $(n+m) \times (n+m)$
    /// symmetric matrix, row-major, and returns `true`; or returns `false`
    /// (the default) when the model has no second derivatives. With them,
    /// [`GaussNewton`](crate::GaussNewton) can take exact Newton steps
    /// ([`GaussNewtonSettings::step_model`](crate::GaussNewtonSettings::step_model)).
    /// Its nonzeros must lie where some row $i$ of the
    /// [Jacobian structure](Self::jacobian_structure) has both entries.
    fn weighted_hessian(&self, x: &[f64], u: &[f64], w: &[f64], hess: &mut [f64]) -> Result<bool> {
        let _ = (x, u, w, hess);
        Ok(false)
    }

    /// The model's confidence at $(x, u)$, if it has one (a learned model's
    /// support or inverse variance); used by [`Lambda::from_confidence`](crate::Lambda::from_confidence).
    fn confidence(&self, x: &[f64], u: &[f64]) -> Option<f64> {
        let _ = (x, u);
        None
    }

    /// [`step`](Self::step) at many points: `xs` ($K \times n$), `us`
    /// ($K \times m$) and `next` ($K \times n$), row-major. The default
    /// takes one point at a time; a model whose evaluation is expensive (a
    /// learned model's regression) may evaluate the points in parallel.
    /// [`Eq3Problem`](crate::Eq3Problem) calls it once per residual evaluation. The results
    /// must be those of `step`, point by point.
    fn step_batch(&self, xs: &[f64], us: &[f64], next: &mut [f64]) -> Result<()> {
        let (n, m) = (self.state_dim(), self.control_dim());
        for k in 0..xs.len() / n.max(1) {
            self.step(
                &xs[k * n..(k + 1) * n],
                &us[k * m..(k + 1) * m],
                &mut next[k * n..(k + 1) * n],
            )?;
        }
        Ok(())
    }

    /// [`jacobians`](Self::jacobians) at many points: `fx` ($K \times n
    /// \times n$) and `fu` ($K \times n \times m$), row-major, point after
    /// point; returns `false` if the model has no Jacobians (then nothing is
    /// written). The default takes one point at a time (see
    /// [`step_batch`](Self::step_batch)).
    fn jacobians_batch(&self, xs: &[f64], us: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<bool> {
        let (n, m) = (self.state_dim(), self.control_dim());
        for k in 0..xs.len() / n.max(1) {
            let (x, u) = (&xs[k * n..(k + 1) * n], &us[k * m..(k + 1) * m]);
            if !self.jacobians(
                x,
                u,
                &mut fx[k * n * n..(k + 1) * n * n],
                &mut fu[k * n * m..(k + 1) * n * m],
            )? {
                return Ok(false);
            }
        }
        Ok(true)
    }
}

/// A reference to a model is a model, so that one model can serve several
/// problems (a continuation, a comparison of planners).
impl<M: Model + ?Sized> Model for &M {
    fn state_dim(&self) -> usize {
        (**self).state_dim()
    }

    fn control_dim(&self) -> usize {
        (**self).control_dim()
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> Result<()> {
        (**self).step(x, u, next)
    }

    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<bool> {
        (**self).jacobians(x, u, fx, fu)
    }

    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        (**self).jacobian_structure(fx, fu)
    }

    fn weighted_hessian(&self, x: &[f64], u: &[f64], w: &[f64], hess: &mut [f64]) -> Result<bool> {
        (**self).weighted_hessian(x, u, w, hess)
    }

    fn confidence(&self, x: &[f64], u: &[f64]) -> Option<f64> {
        (**self).confidence(x, u)
    }

    fn step_batch(&self, xs: &[f64], us: &[f64], next: &mut [f64]) -> Result<()> {
        (**self).step_batch(xs, us, next)
    }

    fn jacobians_batch(&self, xs: &[f64], us: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<bool> {
        (**self).jacobians_batch(xs, us, fx, fu)
    }
}
