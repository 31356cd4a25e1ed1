//! The torque-driven pendulum.

use crate::{Accelerations, MAX_INPUTS};

/// A torque-driven pendulum: a point mass $m$ on a massless rod of length
/// $l$, state $(\theta, \omega)$ with $\theta = 0$ hanging down, control
/// the torque $u$ at the pivot:
/// $$\dot\omega = \frac{u - b\,\omega}{m l^2} - \frac{g}{l} \sin\theta.$$
///
/// | field | default |
/// |---|---|
/// | `mass` | 1 kg |
/// | `length` | 1 m |
/// | `damping` | 0 N m s |
/// | `gravity` | 9.81 m/s² |
/// | `dt` | 0.01 s |
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pendulum {
    /// Point mass $m$.
    pub mass: f64,
    /// Rod length $l$.
    pub length: f64,
    /// Viscous damping $b$.
    pub damping: f64,
    /// Gravity $g$.
    pub gravity: f64,
    /// Time step $\Delta t$.
    pub dt: f64,
}

impl Default for Pendulum {
    fn default() -> Self {
        Self {
            mass: 1.0,
            length: 1.0,
            damping: 0.0,
            gravity: 9.81,
            dt: 0.01,
        }
    }
}

impl Pendulum {
    /// The total energy $\tfrac12 m l^2 \omega^2 - m g l \cos\theta$,
    /// conserved by the continuous dynamics without torque and damping.
    pub fn energy(&self, x: &[f64]) -> f64 {
        let ml = self.mass * self.length;
        0.5 * ml * self.length * x[1] * x[1] - ml * self.gravity * x[0].cos()
    }

    /// The second derivatives of the Euler step
    /// ([`Mechanics::euler_step`](crate::Mechanics::euler_step)) contracted with $v$:
    /// $\sum_i v_i\,\partial^2 x'_i / \partial\theta^2
    /// = (v_\omega \Delta t + v_\theta \Delta t^2)\,(g / l) \sin\theta$,
    /// the only entry of $\sum_i v_i\,\partial^2 x'_i / \partial z^2$ that
    /// is not zero.
    pub fn euler_curvature(&self, x: &[f64], v: &[f64]) -> f64 {
        let a_thth = self.gravity / self.length * x[0].sin();
        (v[1] * self.dt + v[0] * self.dt * self.dt) * a_thth
    }

    /// The accelerations and their derivatives
    /// ([`Mechanics::accelerations`](crate::Mechanics::accelerations)).
    #[inline]
    pub(crate) fn accelerations(&self, x: &[f64], u: &[f64]) -> Accelerations {
        let ml2 = self.mass * self.length * self.length;
        let (s, c) = x[0].sin_cos();
        let acc = (u[0] - self.damping * x[1]) / ml2 - self.gravity / self.length * s;
        let da = [
            -self.gravity / self.length * c,
            -self.damping / ml2,
            1.0 / ml2,
            0.0,
            0.0,
        ];
        ([acc, 0.0], [da, [0.0; MAX_INPUTS]])
    }
}
