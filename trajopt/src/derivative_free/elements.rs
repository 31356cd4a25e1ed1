//! Eq. 3's element structure: the model seen through its values only, its
//! Jacobians differenced per step in one batch.

use std::sync::atomic::{AtomicUsize, Ordering};

use super::Difference;
use crate::eq3::Dynamics;
use crate::error::{Result, TrajoptError};
use systems::ModelResult;

/// A [`Dynamics`] whose Jacobians are differences of its own values: `inner`'s
/// [`jacobians`](Dynamics::jacobians) are never called.
///
/// Eq. 3's consistency residual at step $k$,
/// $x_{k+1} - f(x_k, u_k)$, depends on the coefficients only through the
/// $n + m$ numbers $z_k = (x_k, u_k)$ (the other terms are linear in the
/// coefficients, with exact derivatives from the basis). Perturbing
/// coordinate $c$ of every $z_k$ at once is a Curtis-Powell-Reid group of
/// the problem written over the $z_k$ (each residual touches one $z_k$:
/// Griewank and Toint's partially separable form), so a whole Jacobian
/// costs $n + m$ evaluations of the model at every step (forward, with the
/// values at $z_k$ one more) or $2 (n + m)$ (central): 5 to 10 criterion
/// evaluations for the pendulum, where grouping the coefficients
/// ([`GroupedDifferences`](super::GroupedDifferences)) needs 14. All
/// the perturbed points go to the inner model in one
/// [`step_batch`](Dynamics::step_batch) call (a learned model may evaluate them
/// in parallel).
///
/// Step $h_c = s \max(|z_c|, 1)$, $s = \sqrt{\epsilon}$ (forward) or
/// $\epsilon^{1/3}$ (central) unless given.
///
/// ```
/// use trajopt::derivative_free::{Difference, Differenced};
/// use trajopt::{Dynamics, check_model_jacobians};
/// use trajopt::problems::HandPendulum;
///
/// let model = Differenced::new(HandPendulum::default(), Difference::Central, None)?;
/// // the differences agree with the pendulum's exact Jacobians
/// let (mut fx, mut fu) = (vec![0.0; 16], vec![0.0; 4]);
/// assert!(model.jacobians(&[0.7, -1.3, 0.2, 0.4], &[2.5], &mut fx, &mut fu)?);
/// let (mut ex, mut eu) = (vec![0.0; 16], vec![0.0; 4]);
/// HandPendulum::default().jacobians(&[0.7, -1.3, 0.2, 0.4], &[2.5], &mut ex, &mut eu)?;
/// for (a, b) in fx.iter().chain(&fu).zip(ex.iter().chain(&eu)) {
///     assert!((a - b).abs() < 1e-8 * (1.0 + b.abs()));
/// }
/// // one point, 2 (n + m) = 10 model evaluations
/// assert_eq!(model.difference_evals(), 10);
/// # Ok::<(), trajopt::TrajoptError>(())
/// ```
#[derive(Debug)]
pub struct Differenced<M> {
    inner: M,
    difference: Difference,
    relative_step: f64,
    /// Model evaluations spent on differences (points, not batches).
    evals: AtomicUsize,
}

impl<M: Dynamics> Differenced<M> {
    /// `inner` differenced with `difference`; `relative_step` `None` picks
    /// $s$ by the kind of difference.
    ///
    /// # Errors
    /// `relative_step` not finite and positive.
    pub fn new(inner: M, difference: Difference, relative_step: Option<f64>) -> Result<Self> {
        let relative_step = relative_step.unwrap_or(match difference {
            Difference::Forward => f64::EPSILON.sqrt(),
            Difference::Central => f64::EPSILON.cbrt(),
        });
        if !(relative_step.is_finite() && relative_step > 0.0) {
            return Err(TrajoptError::InvalidParameter {
                name: "relative_step",
                reason: format!("must be finite and > 0, got {relative_step}"),
            });
        }
        Ok(Self {
            inner,
            difference,
            relative_step,
            evals: AtomicUsize::new(0),
        })
    }

    /// The model inside.
    pub fn inner(&self) -> &M {
        &self.inner
    }

    /// Model evaluations spent on differences so far (one per point, the
    /// forward differences' base points included).
    pub fn difference_evals(&self) -> usize {
        self.evals.load(Ordering::Relaxed)
    }

    /// Model evaluations per point of one Jacobian: $n + m + 1$ forward,
    /// $2 (n + m)$ central.
    pub fn evals_per_point(&self) -> usize {
        let nm = self.inner.state_dim() + self.inner.control_dim();
        match self.difference {
            Difference::Forward => nm + 1,
            Difference::Central => 2 * nm,
        }
    }
}

impl<M: Dynamics> Dynamics for Differenced<M> {
    fn state_dim(&self) -> usize {
        self.inner.state_dim()
    }

    fn control_dim(&self) -> usize {
        self.inner.control_dim()
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        self.inner.step(x, u, next)
    }

    fn step_batch(&self, xs: &[f64], us: &[f64], next: &mut [f64]) -> ModelResult<()> {
        self.inner.step_batch(xs, us, next)
    }

    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        self.jacobians_batch(x, u, fx, fu)
    }

    /// Every point's differences in one [`step_batch`](Dynamics::step_batch)
    /// call of the inner model.
    fn jacobians_batch(&self, xs: &[f64], us: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        let (n, m) = (self.inner.state_dim(), self.inner.control_dim());
        let nm = n + m;
        let points = xs.len() / n.max(1);
        let per = self.evals_per_point();
        // the perturbed points of every step, point after point
        let mut bx = Vec::with_capacity(points * per * n);
        let mut bu = Vec::with_capacity(points * per * m);
        let mut steps = vec![0.0; points * nm];
        for k in 0..points {
            let (x, u) = (&xs[k * n..(k + 1) * n], &us[k * m..(k + 1) * m]);
            for c in 0..nm {
                let z = if c < n { x[c] } else { u[c - n] };
                let h = self.relative_step * z.abs().max(1.0);
                let h = (z + h) - z;
                steps[k * nm + c] = h;
                let signs: &[f64] = match self.difference {
                    Difference::Forward => &[1.0],
                    Difference::Central => &[1.0, -1.0],
                };
                for &sign in signs {
                    bx.extend_from_slice(x);
                    bu.extend_from_slice(u);
                    let at = bx.len() - n;
                    let at_u = bu.len() - m;
                    if c < n {
                        bx[at + c] = z + sign * h;
                    } else {
                        bu[at_u + c - n] = z + sign * h;
                    }
                }
            }
            if self.difference == Difference::Forward {
                bx.extend_from_slice(x);
                bu.extend_from_slice(u);
            }
        }
        let mut values = vec![0.0; points * per * n];
        self.inner.step_batch(&bx, &bu, &mut values)?;
        self.evals.fetch_add(points * per, Ordering::Relaxed);
        for k in 0..points {
            let block = &values[k * per * n..(k + 1) * per * n];
            for c in 0..nm {
                let h = steps[k * nm + c];
                let (plus, lower, width) = match self.difference {
                    Difference::Forward => (&block[c * n..(c + 1) * n], &block[nm * n..(nm + 1) * n], 1.0),
                    Difference::Central => (
                        &block[2 * c * n..(2 * c + 1) * n],
                        &block[(2 * c + 1) * n..(2 * c + 2) * n],
                        2.0,
                    ),
                };
                for i in 0..n {
                    let g = (plus[i] - lower[i]) / (width * h);
                    if c < n {
                        fx[k * n * n + i * n + c] = g;
                    } else {
                        fu[k * n * m + i * m + c - n] = g;
                    }
                }
            }
        }
        Ok(true)
    }

    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        self.inner.jacobian_structure(fx, fu);
    }

    fn confidence(&self, x: &[f64], u: &[f64]) -> Option<f64> {
        self.inner.confidence(x, u)
    }
}
