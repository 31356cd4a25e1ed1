//! The one model contract: a discrete-time dynamics model ([`Dynamics`])
//! and a stage cost in residual form ([`StageCost`]), written once and
//! planned by every solver of the workspace (`trajopt`'s Gauss-Newton,
//! Powell and derivative-free modes on Eq. 3, `ddp`'s iLQR and full DDP).
//!
//! Matrices cross these traits as row-major slices: entry $(i, j)$ of an
//! $r \times c$ matrix is `a[i * c + j]`.

use std::fmt;

/// What a model or a stage cost reports when it cannot evaluate a point
/// (a learned model without data, a simulator that failed); the solvers
/// wrap it in their own error type (`TrajoptError::Model`,
/// `DdpError::Model`) or treat it as a blown-up trial point.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModelError(pub String);

impl ModelError {
    /// An error with this message.
    pub fn new(message: impl Into<String>) -> Self {
        Self(message.into())
    }
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ModelError {}

/// The result of a model's or a stage cost's evaluation.
pub type ModelResult<T> = Result<T, ModelError>;

/// A discrete-time dynamics model $x_{k+1} = f(x_k, u_k)$ with
/// $x \in \mathbb{R}^n$, $u \in \mathbb{R}^m$.
///
/// Only [`state_dim`](Self::state_dim), [`control_dim`](Self::control_dim)
/// and [`step`](Self::step) are required. Without
/// [`jacobians`](Self::jacobians) the solvers take central differences of
/// `step`; with [`weighted_hessian`](Self::weighted_hessian) Gauss-Newton
/// can take exact Newton steps and DDP is full DDP (the tensor terms
/// $V_x' \cdot f_{zz}$), otherwise iLQR.
///
/// Non-finite output is allowed (a learned model far from its data may
/// return anything): the solvers treat it as a blown-up trial point.
pub trait Dynamics {
    /// State dimension $n$.
    fn state_dim(&self) -> usize;

    /// Control dimension $m$.
    fn control_dim(&self) -> usize;

    /// Writes $f(x, u)$ into `next` (length $n$).
    ///
    /// # Errors
    /// Whatever the model reports when it cannot evaluate $(x, u)$.
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()>;

    /// Writes $\partial f / \partial x$ ($n \times n$) and
    /// $\partial f / \partial u$ ($n \times m$), row-major, and returns
    /// `true`; or returns `false` (the default) to have them computed by
    /// central differences of [`step`](Self::step) (see [`central_differences`]).
    ///
    /// # Errors
    /// Whatever the model reports.
    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        let _ = (x, u, fx, fu);
        Ok(false)
    }

    /// Which entries of $\partial f / \partial x$ and $\partial f / \partial u$
    /// (row-major, as in [`jacobians`](Self::jacobians)) can be nonzero; the
    /// default says all. A model that leaves structural zeros out shrinks a
    /// planner's Jacobian and normal equations; it must not leave out any
    /// entry that can be nonzero.
    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        fx.fill(true);
        fu.fill(true);
    }

    /// Writes the weighted second derivative $\sum_i w_i \nabla^2 f_i(z)$
    /// over $z = (x, u)$, an $(n+m) \times (n+m)$ symmetric matrix,
    /// row-major, and returns `true`; or returns `false` (the default) when
    /// the model has no second derivatives. Its nonzeros must lie where some
    /// row $i$ of the [Jacobian structure](Self::jacobian_structure) has
    /// both entries. DDP reads its blocks as $f_{xx}$, $f_{ux}$ and $f_{uu}$
    /// contracted with $V_x'$.
    ///
    /// # Errors
    /// Whatever the model reports.
    fn weighted_hessian(&self, x: &[f64], u: &[f64], w: &[f64], hess: &mut [f64]) -> ModelResult<bool> {
        let _ = (x, u, w, hess);
        Ok(false)
    }

    /// The model's confidence at $(x, u)$, if it has one (a learned model's
    /// support or inverse variance); `trajopt` weighs Eq. 3's consistency
    /// term by it (`Lambda::from_confidence`).
    fn confidence(&self, x: &[f64], u: &[f64]) -> Option<f64> {
        let _ = (x, u);
        None
    }

    /// [`step`](Self::step) at many points: `xs` ($K \times n$), `us`
    /// ($K \times m$) and `next` ($K \times n$), row-major. The default
    /// takes one point at a time; a model whose evaluation is expensive (a
    /// learned model's regression) may evaluate the points in parallel. The
    /// results must be those of `step`, point by point.
    ///
    /// # Errors
    /// The first point's error.
    fn step_batch(&self, xs: &[f64], us: &[f64], next: &mut [f64]) -> ModelResult<()> {
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
    ///
    /// # Errors
    /// The first point's error.
    fn jacobians_batch(&self, xs: &[f64], us: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
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
/// problems and solvers (a continuation, a comparison of planners).
impl<D: Dynamics + ?Sized> Dynamics for &D {
    fn state_dim(&self) -> usize {
        (**self).state_dim()
    }

    fn control_dim(&self) -> usize {
        (**self).control_dim()
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        (**self).step(x, u, next)
    }

    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        (**self).jacobians(x, u, fx, fu)
    }

    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        (**self).jacobian_structure(fx, fu)
    }

    fn weighted_hessian(&self, x: &[f64], u: &[f64], w: &[f64], hess: &mut [f64]) -> ModelResult<bool> {
        (**self).weighted_hessian(x, u, w, hess)
    }

    fn confidence(&self, x: &[f64], u: &[f64]) -> Option<f64> {
        (**self).confidence(x, u)
    }

    fn step_batch(&self, xs: &[f64], us: &[f64], next: &mut [f64]) -> ModelResult<()> {
        (**self).step_batch(xs, us, next)
    }

    fn jacobians_batch(&self, xs: &[f64], us: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        (**self).jacobians_batch(xs, us, fx, fu)
    }
}

/// A model with only its step: its Jacobians, second derivatives and
/// confidence hidden, so that every solver takes [`central_differences`].
/// For checking a model's analytic derivatives against differences in a
/// whole solve, or planning a model whose derivatives are suspect.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepOnly<D>(pub D);

impl<D: Dynamics> Dynamics for StepOnly<D> {
    fn state_dim(&self) -> usize {
        self.0.state_dim()
    }

    fn control_dim(&self) -> usize {
        self.0.control_dim()
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        self.0.step(x, u, next)
    }

    fn step_batch(&self, xs: &[f64], us: &[f64], next: &mut [f64]) -> ModelResult<()> {
        self.0.step_batch(xs, us, next)
    }
}

/// The Jacobians of `model` at $(x, u)$: its own where it writes them
/// ([`Dynamics::jacobians`] returns `true`), else [`central_differences`].
/// Returns whether they are the model's own.
///
/// # Errors
/// A failed step or Jacobian evaluation.
pub fn jacobians_or_differences<D: Dynamics + ?Sized>(
    model: &D,
    x: &[f64],
    u: &[f64],
    fx: &mut [f64],
    fu: &mut [f64],
) -> ModelResult<bool> {
    if model.jacobians(x, u, fx, fu)? {
        return Ok(true);
    }
    central_differences(model, x, u, fx, fu)?;
    Ok(false)
}

/// Central differences of [`Dynamics::step`],
/// $(f(z + h e_j) - f(z - h e_j)) / 2h$ over $z = (x, u)$ with
/// $h = \epsilon^{1/3} \max(1, \lvert z_j \rvert)$: $2(n + m)$ steps,
/// accurate to about $10^{-10}$ relative for smooth dynamics. Writes `fx`
/// ($n \times n$) and `fu` ($n \times m$), row-major.
///
/// # Errors
/// A failed step.
pub fn central_differences<D: Dynamics + ?Sized>(
    model: &D,
    x: &[f64],
    u: &[f64],
    fx: &mut [f64],
    fu: &mut [f64],
) -> ModelResult<()> {
    differences(
        x.len(),
        x,
        Some(u),
        &mut |x, u, out| model.step(x, u.unwrap_or(&[]), out),
        fx,
        fu,
    )
}

/// A function of $(x, u)$ ($u$ absent at a terminal stage) writing its
/// values into the last argument.
type Evaluation<'a> = dyn FnMut(&[f64], Option<&[f64]>, &mut [f64]) -> ModelResult<()> + 'a;

/// Central differences of a function $g(x, u) \in \mathbb R^p$ over $z =
/// (x, u)$ ($x$ alone when `u` is `None`), with $h = \epsilon^{1/3}
/// \max(1, \lvert z_j \rvert)$; writes $\partial g / \partial x$ ($p
/// \times n$) into `gx` and $\partial g / \partial u$ ($p \times m$) into
/// `gu`, row-major.
fn differences(
    p: usize,
    x: &[f64],
    u: Option<&[f64]>,
    g: &mut Evaluation<'_>,
    gx: &mut [f64],
    gu: &mut [f64],
) -> ModelResult<()> {
    let n = x.len();
    let m = u.map_or(0, <[f64]>::len);
    let mut z: Vec<f64> = x.iter().chain(u.unwrap_or(&[])).copied().collect();
    let (mut plus, mut minus) = (vec![0.0; p], vec![0.0; p]);
    for j in 0..n + m {
        let z0 = z[j];
        let h = f64::EPSILON.cbrt() * z0.abs().max(1.0);
        z[j] = z0 + h;
        g(&z[..n], u.map(|_| &z[n..]), &mut plus)?;
        z[j] = z0 - h;
        g(&z[..n], u.map(|_| &z[n..]), &mut minus)?;
        z[j] = z0;
        for i in 0..p {
            let d = (plus[i] - minus[i]) / (2.0 * h);
            if j < n {
                gx[i * n + j] = d;
            } else {
                gu[i * m + (j - n)] = d;
            }
        }
    }
    Ok(())
}

/// The number of residuals of a stage of `cost`: the terminal stage's
/// ([`StageCost::n_terminal_residuals`]) when `terminal`, else a running
/// stage's ([`StageCost::n_residuals`]).
pub fn residual_count<C: StageCost + ?Sized>(cost: &C, terminal: bool) -> usize {
    if terminal {
        cost.n_terminal_residuals()
    } else {
        cost.n_residuals()
    }
}

/// Central differences of [`StageCost::residuals`] at stage `k`, as
/// [`central_differences`] for a model: $\partial r_k / \partial x$
/// (the stage's [`residual_count`] $\times n$) into `jx` and, unless at the terminal stage
/// (`u` is `None`), $\partial r_k / \partial u$ into `ju`, row-major. The
/// default of [`StageCost::jacobians`].
///
/// # Errors
/// A failed residual evaluation.
pub fn stage_central_differences<C: StageCost + ?Sized>(
    cost: &C,
    k: usize,
    x: &[f64],
    u: Option<&[f64]>,
    jx: &mut [f64],
    ju: &mut [f64],
) -> ModelResult<()> {
    differences(
        residual_count(cost, u.is_none()),
        x,
        u,
        &mut |x, u, r| cost.residuals(k, x, u, r),
        jx,
        ju,
    )
}

/// A stage cost in residual form, $c_k(x, u) = \lVert r_k(x, u) \rVert^2$,
/// and at the terminal stage $k = N$ (no control) $c_N(x) = \lVert r_N(x) \rVert^2$.
/// Eq. 3 stacks the residuals; DDP takes the cost with its Gauss-Newton
/// Hessian $2 J^\top J$ (plus the residuals' own curvature when
/// [`weighted_hessian`](Self::weighted_hessian) gives it).
pub trait StageCost {
    /// Number of residuals of every running stage ($k < N$).
    fn n_residuals(&self) -> usize;

    /// Number of residuals of the terminal stage ($k = N$, `u` is `None`);
    /// by default [`n_residuals`](Self::n_residuals). A terminal cost of
    /// its own size (say, the state's error alone, heavily weighted, after
    /// running stages that also weigh the control) returns its count here;
    /// every solver sizes the terminal stage by it.
    fn n_terminal_residuals(&self) -> usize {
        self.n_residuals()
    }

    /// Writes $r_k(x_k, u_k)$; `u` is `None` at the terminal stage $k = N$.
    ///
    /// # Errors
    /// Whatever the cost reports when it cannot evaluate the point.
    fn residuals(&self, k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()>;

    /// Writes $\partial r_k / \partial x$ ([`residual_count`] $\times n$) and
    /// $\partial r_k / \partial u$ ([`residual_count`] $\times m$), row-major;
    /// at the terminal stage `ju` is ignored. The default differences
    /// [`residuals`](Self::residuals) ([`stage_central_differences`],
    /// $2(n + m)$ evaluations): a cost that leaves it out still works with
    /// every solver, and one that writes it is faster and exact.
    ///
    /// # Errors
    /// Whatever the cost reports.
    fn jacobians(&self, k: usize, x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> ModelResult<()> {
        stage_central_differences(self, k, x, u, jx, ju)
    }

    /// Which entries of the residual Jacobians can be nonzero at any stage
    /// (row-major, as in [`jacobians`](Self::jacobians)); the default says
    /// all. Must not leave out any entry that can be nonzero.
    fn jacobian_structure(&self, jx: &mut [bool], ju: &mut [bool]) {
        jx.fill(true);
        ju.fill(true);
    }

    /// Writes $\sum_a w_a \nabla^2 r_{k,a}$ over $z = (x, u)$ (at the
    /// terminal stage over $x$ alone), row-major, and returns `true`; or
    /// returns `false` (the default) when the cost has no second
    /// derivatives (the solvers then keep to Gauss-Newton curvature).
    /// Nonzeros only where some residual's
    /// [Jacobian structure](Self::jacobian_structure) has both entries.
    ///
    /// # Errors
    /// Whatever the cost reports.
    fn weighted_hessian(
        &self,
        k: usize,
        x: &[f64],
        u: Option<&[f64]>,
        w: &[f64],
        hess: &mut [f64],
    ) -> ModelResult<bool> {
        let _ = (k, x, u, w, hess);
        Ok(false)
    }
}

/// A reference to a stage cost is a stage cost.
impl<C: StageCost + ?Sized> StageCost for &C {
    fn n_residuals(&self) -> usize {
        (**self).n_residuals()
    }

    fn n_terminal_residuals(&self) -> usize {
        (**self).n_terminal_residuals()
    }

    fn residuals(&self, k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
        (**self).residuals(k, x, u, r)
    }

    fn jacobians(&self, k: usize, x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> ModelResult<()> {
        (**self).jacobians(k, x, u, jx, ju)
    }

    fn jacobian_structure(&self, jx: &mut [bool], ju: &mut [bool]) {
        (**self).jacobian_structure(jx, ju)
    }

    fn weighted_hessian(
        &self,
        k: usize,
        x: &[f64],
        u: Option<&[f64]>,
        w: &[f64],
        hess: &mut [f64],
    ) -> ModelResult<bool> {
        (**self).weighted_hessian(k, x, u, w, hess)
    }
}

macro_rules! euler_dynamics {
    ($($t:ty),*) => {$(
        /// Semi-implicit Euler ([`Mechanics::euler_step`](crate::Mechanics::euler_step))
        /// with its analytic Jacobians
        /// ([`Mechanics::euler_jacobians`](crate::Mechanics::euler_jacobians)).
        impl Dynamics for $t {
            fn state_dim(&self) -> usize {
                crate::Mechanics::n_x(self)
            }
            fn control_dim(&self) -> usize {
                crate::Mechanics::n_u(self)
            }
            fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
                crate::Mechanics::euler_step(self, x, u, next);
                Ok(())
            }
            fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
                crate::Mechanics::euler_jacobians(self, x, u, fx, fu);
                Ok(true)
            }
            fn weighted_hessian(&self, x: &[f64], u: &[f64], w: &[f64], hess: &mut [f64]) -> ModelResult<bool> {
                Ok(second_derivative(self.pendulum(), x, u, w, hess))
            }
        }
    )*};
}

euler_dynamics!(crate::Pendulum, crate::CartPole, crate::Acrobot, crate::SwingUpModel);

/// The torque pendulum's weighted second derivative (only
/// $\partial^2 / \partial\theta^2$ is nonzero: the torque enters linearly);
/// `false` for the systems without second derivatives.
fn second_derivative(pendulum: Option<&crate::Pendulum>, x: &[f64], u: &[f64], w: &[f64], hess: &mut [f64]) -> bool {
    let Some(p) = pendulum else { return false };
    let z = x.len() + u.len();
    hess[..z * z].fill(0.0);
    hess[0] = p.euler_curvature(x, w);
    true
}

/// The torque pendulum inside a system, the one whose step has second
/// derivatives here.
trait InnerPendulum {
    fn pendulum(&self) -> Option<&crate::Pendulum> {
        None
    }
}

impl InnerPendulum for crate::Pendulum {
    fn pendulum(&self) -> Option<&crate::Pendulum> {
        Some(self)
    }
}

impl InnerPendulum for crate::CartPole {}

impl InnerPendulum for crate::Acrobot {}

impl InnerPendulum for crate::SwingUpModel {
    fn pendulum(&self) -> Option<&crate::Pendulum> {
        match self {
            crate::SwingUpModel::Pendulum(p) => Some(p),
            crate::SwingUpModel::CartPole(_) | crate::SwingUpModel::Acrobot(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stage cost with its Jacobians written out, and the same cost
    /// without them ([`StageCost::jacobians`]'s default differences).
    struct Written;
    struct ResidualsOnly;

    fn r(x: &[f64], u: Option<&[f64]>, out: &mut [f64]) {
        out[0] = x[0] * x[0] - u.map_or(0.0, |u| 3.0 * u[0]);
        out[1] = x[1].sin() * x[0];
        out[2] = u.map_or(x[1], |u| u[0].exp() - x[1]);
    }

    impl StageCost for Written {
        fn n_residuals(&self) -> usize {
            3
        }
        fn residuals(&self, _: usize, x: &[f64], u: Option<&[f64]>, out: &mut [f64]) -> ModelResult<()> {
            r(x, u, out);
            Ok(())
        }
        fn jacobians(&self, _: usize, x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> ModelResult<()> {
            jx.copy_from_slice(&[
                2.0 * x[0],
                0.0,
                x[1].sin(),
                x[1].cos() * x[0],
                0.0,
                if u.is_some() { -1.0 } else { 1.0 },
            ]);
            if let Some(u) = u {
                ju.copy_from_slice(&[-3.0, 0.0, u[0].exp()]);
            }
            Ok(())
        }
    }

    impl StageCost for ResidualsOnly {
        fn n_residuals(&self) -> usize {
            3
        }
        fn residuals(&self, _: usize, x: &[f64], u: Option<&[f64]>, out: &mut [f64]) -> ModelResult<()> {
            r(x, u, out);
            Ok(())
        }
    }

    proptest::proptest! {
        /// A cost without Jacobians gets its residuals' central
        /// differences: the written Jacobians to 1e-8, at running and
        /// terminal stages (where `ju` is left alone).
        #[test]
        fn a_stage_cost_without_jacobians_is_differenced(
            x0 in -2.0f64..2.0, x1 in -2.0f64..2.0, u0 in -1.0f64..1.0, terminal in proptest::prelude::any::<bool>(),
        ) {
            let (x, u) = ([x0, x1], [u0]);
            let u = (!terminal).then_some(&u[..]);
            let (mut jx, mut ju, mut dx, mut du) = ([0.0; 6], [7.0; 3], [0.0; 6], [7.0; 3]);
            Written.jacobians(0, &x, u, &mut jx, &mut ju).expect("written");
            ResidualsOnly.jacobians(0, &x, u, &mut dx, &mut du).expect("differenced");
            for (a, b) in jx.iter().zip(&dx).chain(ju.iter().zip(&du)) {
                proptest::prop_assert!((a - b).abs() < 1e-8 * (1.0 + a.abs()), "{jx:?} {ju:?} vs {dx:?} {du:?}");
            }
        }
    }
    use crate::{Acrobot, CartPole, Mechanics, Pendulum};

    fn check_differences<D: Dynamics>(model: D, x: &[f64], u: &[f64]) {
        let (n, m) = (model.state_dim(), model.control_dim());
        let (mut fx, mut fu) = (vec![0.0; n * n], vec![0.0; n * m]);
        assert!(jacobians_or_differences(&model, x, u, &mut fx, &mut fu).expect("own"));
        let (mut dx, mut du) = (vec![f64::NAN; n * n], vec![f64::NAN; n * m]);
        assert!(!jacobians_or_differences(&StepOnly(&model), x, u, &mut dx, &mut du).expect("differenced"));
        for (a, b) in fx.iter().chain(&fu).zip(dx.iter().chain(&du)) {
            assert!((a - b).abs() < 1e-7 * (1.0 + a.abs()), "{a} vs {b}");
        }
    }

    #[test]
    fn central_differences_match_every_systems_exact_jacobians() {
        check_differences(Pendulum::default(), &[0.7, -1.3], &[0.4]);
        check_differences(CartPole::default(), &[0.2, 2.1, -0.5, 1.0], &[3.0]);
        check_differences(Acrobot::default(), &[0.3, -0.8, 1.1, 0.2], &[-2.0]);
    }

    /// The pendulum's weighted Hessian is the second difference of
    /// $w \cdot f$ along $\theta$.
    #[test]
    fn pendulum_weighted_hessian_matches_second_differences() {
        let p = Pendulum::default();
        let (x, u, w) = ([0.9, 0.4], [0.3], [0.7, -1.9]);
        let mut hess = [f64::NAN; 9];
        assert!(p.weighted_hessian(&x, &u, &w, &mut hess).expect("hessian"));
        let f = |th: f64| {
            let mut next = [0.0; 2];
            p.euler_step(&[th, x[1]], &u, &mut next);
            w[0] * next[0] + w[1] * next[1]
        };
        let h = 1e-4;
        let second = (f(x[0] + h) - 2.0 * f(x[0]) + f(x[0] - h)) / (h * h);
        assert!(
            (hess[0] - second).abs() < 1e-5 * (1.0 + second.abs()),
            "{} vs {second}",
            hess[0]
        );
        assert!(hess[1..].iter().all(|&v| v == 0.0));
        assert!(
            !CartPole::default()
                .weighted_hessian(&[0.0; 4], &[0.0], &[1.0; 4], &mut [0.0; 25])
                .expect("ok")
        );
    }

    #[test]
    fn model_errors_carry_their_message() {
        let e = ModelError::new("no data near (0.1, 0.2)");
        assert_eq!(e.to_string(), "no data near (0.1, 0.2)");
    }
}
