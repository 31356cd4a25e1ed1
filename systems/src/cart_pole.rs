//! The cart-pole.

use crate::Accelerations;

/// A cart-pole: state $(x, \theta, \dot x, \dot\theta)$ (cart position,
/// pole angle, then their rates) with $\theta = 0$ hanging down, control
/// the horizontal force $f$ on the cart; a massless rod with a point mass
/// at its end, no friction (Tedrake, *Underactuated Robotics*, ch. 3). With
/// $D = m_c + m_p \sin^2\theta$,
/// $$\ddot x = \frac{f + m_p \sin\theta\,(l \dot\theta^2 + g \cos\theta)}{D}, \qquad
/// \ddot\theta = \frac{-f \cos\theta - m_p l \dot\theta^2 \cos\theta \sin\theta - (m_c + m_p) g \sin\theta}{l D}.$$
///
/// | field | default |
/// |---|---|
/// | `cart_mass` | 1 kg |
/// | `pole_mass` | 0.1 kg |
/// | `length` | 0.5 m |
/// | `gravity` | 9.81 m/s² |
/// | `dt` | 0.01 s |
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CartPole {
    /// Cart mass $m_c$.
    pub cart_mass: f64,
    /// Pole (tip) mass $m_p$.
    pub pole_mass: f64,
    /// Pole length $l$.
    pub length: f64,
    /// Gravity $g$.
    pub gravity: f64,
    /// Time step $\Delta t$.
    pub dt: f64,
}

impl Default for CartPole {
    fn default() -> Self {
        Self {
            cart_mass: 1.0,
            pole_mass: 0.1,
            length: 0.5,
            gravity: 9.81,
            dt: 0.01,
        }
    }
}

impl CartPole {
    /// The total energy
    /// $\tfrac12 (m_c + m_p) \dot x^2 + m_p l \cos\theta\,\dot x \dot\theta + \tfrac12 m_p l^2 \dot\theta^2 - m_p g l \cos\theta$,
    /// conserved by the continuous dynamics without force.
    pub fn energy(&self, x: &[f64]) -> f64 {
        let (mc, mp, l, g) = (self.cart_mass, self.pole_mass, self.length, self.gravity);
        let (v, w, c) = (x[2], x[3], x[1].cos());
        0.5 * (mc + mp) * v * v + mp * l * c * v * w + 0.5 * mp * l * l * w * w - mp * g * l * c
    }

    /// The accelerations and their derivatives
    /// ([`Mechanics::accelerations`](crate::Mechanics::accelerations)).
    #[inline]
    pub(crate) fn accelerations(&self, x: &[f64], u: &[f64]) -> Accelerations {
        let (mc, mp, l, g) = (self.cart_mass, self.pole_mass, self.length, self.gravity);
        let (w, f) = (x[3], u[0]);
        let (s, c) = x[1].sin_cos();
        let d = mc + mp * s * s;
        let d_th = 2.0 * mp * s * c;
        // numerators and their derivatives in (theta, omega, f)
        let n1 = f + mp * s * (l * w * w + g * c);
        let n1_d = [mp * (c * l * w * w + g * (c * c - s * s)), 2.0 * mp * s * l * w, 1.0];
        let n2 = (-f * c - mp * l * w * w * c * s - (mc + mp) * g * s) / l;
        let n2_d = [
            (f * s - mp * l * w * w * (c * c - s * s) - (mc + mp) * g * c) / l,
            -2.0 * mp * w * c * s,
            -c / l,
        ];
        let row = |nv: f64, nd: [f64; 3]| [0.0, (nd[0] - nv / d * d_th) / d, 0.0, nd[1] / d, nd[2] / d];
        ([n1 / d, n2 / d], [row(n1, n1_d), row(n2, n2_d)])
    }
}
