//! The cart-pole.

use crate::Accelerations;

/// The pole's mass distribution.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Pole {
    /// All the mass at the tip, a massless rod (Tedrake, *Underactuated
    /// Robotics*, ch. 3).
    #[default]
    PointMass,
    /// A uniform rod: the centre of mass at half the length, the inertia
    /// about the pivot $m l^2 / 3$ (PILCO's cart-pole, `dynamics_cp.m`).
    UniformRod,
}

/// A cart-pole: state $(x, \theta, \dot x, \dot\theta)$ (cart position,
/// pole angle, then their rates) with $\theta = 0$ hanging down, control
/// the horizontal force $f$ on the cart, viscous friction $b$ on the cart.
///
/// With the pole's centre of mass at $l_c$ from the pivot and its inertia
/// $J$ about the pivot, Lagrange's equations are
/// $$(m_c + m_p)\ddot x + m_p l_c \cos\theta\,\ddot\theta = F + m_p l_c \sin\theta\,\dot\theta^2, \qquad
/// m_p l_c \cos\theta\,\ddot x + J \ddot\theta = -m_p g l_c \sin\theta,$$
/// $F = f - b\dot x$. For the point mass ([`Pole::PointMass`]: $l_c = l$,
/// $J = m_p l^2$), with $D = m_c + m_p \sin^2\theta$,
/// $$\ddot x = \frac{F + m_p \sin\theta\,(l \dot\theta^2 + g \cos\theta)}{D}, \qquad
/// \ddot\theta = \frac{-F \cos\theta - m_p l \dot\theta^2 \cos\theta \sin\theta - (m_c + m_p) g \sin\theta}{l D}.$$
/// For the uniform rod ([`Pole::UniformRod`]: $l_c = l/2$, $J = m_p l^2/3$),
/// with $D = 4(m_c + m_p) - 3 m_p \cos^2\theta$ (PILCO's `dynamics_cp.m`),
/// $$\ddot x = \frac{2 m_p l \dot\theta^2 \sin\theta + 3 m_p g \sin\theta \cos\theta + 4F}{D}, \qquad
/// \ddot\theta = \frac{-3 m_p l \dot\theta^2 \sin\theta\cos\theta - 6 (m_c + m_p) g \sin\theta - 6 F \cos\theta}{l D}.$$
///
/// | field | default |
/// |---|---|
/// | `cart_mass` | 1 kg |
/// | `pole_mass` | 0.1 kg |
/// | `length` | 0.5 m |
/// | `gravity` | 9.81 m/s² |
/// | `dt` | 0.01 s |
/// | `friction` | 0 N s/m |
/// | `pole` | [`Pole::PointMass`] |
///
/// The same physics serves the integrators of other crates through
/// [`CartPole::acceleration`] (values only); `swingup`'s PILCO cart-pole
/// integrates it by RK4 in its own state order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CartPole {
    /// Cart mass $m_c$.
    pub cart_mass: f64,
    /// Pole mass $m_p$.
    pub pole_mass: f64,
    /// Pole length $l$.
    pub length: f64,
    /// Gravity $g$.
    pub gravity: f64,
    /// Time step $\Delta t$.
    pub dt: f64,
    /// Viscous friction $b$ on the cart.
    pub friction: f64,
    /// The pole's mass distribution.
    pub pole: Pole,
}

impl Default for CartPole {
    fn default() -> Self {
        Self {
            cart_mass: 1.0,
            pole_mass: 0.1,
            length: 0.5,
            gravity: 9.81,
            dt: 0.01,
            friction: 0.0,
            pole: Pole::PointMass,
        }
    }
}

impl CartPole {
    /// The pole's centre-of-mass distance $l_c$ and inertia $J$ about the pivot.
    pub fn pole_inertia(&self) -> (f64, f64) {
        let (mp, l) = (self.pole_mass, self.length);
        match self.pole {
            Pole::PointMass => (l, mp * l * l),
            Pole::UniformRod => (0.5 * l, mp * l * l / 3.0),
        }
    }

    /// The total energy
    /// $\tfrac12 (m_c + m_p) \dot x^2 + m_p l_c \cos\theta\,\dot x \dot\theta + \tfrac12 J \dot\theta^2 - m_p g l_c \cos\theta$,
    /// conserved by the continuous dynamics without force and friction.
    pub fn energy(&self, x: &[f64]) -> f64 {
        let (mc, mp, g) = (self.cart_mass, self.pole_mass, self.gravity);
        let (lc, j) = self.pole_inertia();
        let (v, w, c) = (x[2], x[3], x[1].cos());
        0.5 * (mc + mp) * v * v + mp * lc * c * v * w + 0.5 * j * w * w - mp * g * lc * c
    }

    /// $(\ddot x, \ddot\theta)$ at angle `theta`, cart velocity `v`, angular
    /// velocity `w` and force `f` (the values of [`Mechanics::accelerations`](crate::Mechanics::accelerations)
    /// without the derivatives).
    #[inline]
    pub fn acceleration(&self, theta: f64, v: f64, w: f64, f: f64) -> [f64; 2] {
        let (mc, mp, l, g, b) = (self.cart_mass, self.pole_mass, self.length, self.gravity, self.friction);
        let (sn, cs) = theta.sin_cos();
        match self.pole {
            Pole::PointMass => {
                let force = f - b * v;
                let d = mc + mp * sn * sn;
                let n1 = force + mp * sn * (l * w * w + g * cs);
                let n2 = (-force * cs - mp * l * w * w * cs * sn - (mc + mp) * g * sn) / l;
                [n1 / d, n2 / d]
            }
            Pole::UniformRod => {
                // PILCO's `dynamics_cp.m`, term for term
                let den = 4.0 * (mc + mp) - 3.0 * mp * cs * cs;
                let acc = (2.0 * mp * l * w * w * sn + 3.0 * mp * g * sn * cs + 4.0 * f - 4.0 * b * v) / den;
                let ang =
                    (-3.0 * mp * l * w * w * sn * cs - 6.0 * (mc + mp) * g * sn - 6.0 * (f - b * v) * cs) / (l * den);
                [acc, ang]
            }
        }
    }

    /// The accelerations and their derivatives
    /// ([`Mechanics::accelerations`](crate::Mechanics::accelerations)).
    #[inline]
    pub(crate) fn accelerations(&self, x: &[f64], u: &[f64]) -> Accelerations {
        let (v, w, f) = (x[2], x[3], u[0]);
        let values = self.acceleration(x[1], v, w, f);
        // derivatives from the general form: with F = f - b v,
        // a = (J N1 + m lc c G) / D and alpha = (-m lc c N1 - (mc + mp) G) / D,
        // N1 = F + m lc s w^2, G = m g lc s, D = (mc + mp) J - (m lc c)^2
        let (mc, mp, g, b) = (self.cart_mass, self.pole_mass, self.gravity, self.friction);
        let (lc, j) = self.pole_inertia();
        let (s, c) = x[1].sin_cos();
        let k = mp * lc;
        let d = (mc + mp) * j - k * k * c * c;
        let d_th = 2.0 * k * k * c * s;
        let n1 = f - b * v + k * s * w * w;
        let gs = k * g * s;
        // derivatives of N1 and G in (theta, v, w, f)
        let n1_d = [k * c * w * w, -b, 2.0 * k * s * w, 1.0];
        let gs_d = [k * g * c, 0.0, 0.0, 0.0];
        let num_a = j * n1 + k * c * gs;
        let num_b = -k * c * n1 - (mc + mp) * gs;
        let mut rows = [[0.0; crate::MAX_INPUTS]; 2];
        for (i, (num, row)) in [num_a, num_b].into_iter().zip(rows.iter_mut()).enumerate() {
            let dn = |q: usize| match (i, q) {
                (0, 0) => j * n1_d[0] - k * s * gs + k * c * gs_d[0],
                (0, q) => j * n1_d[q] + k * c * gs_d[q],
                (_, 0) => k * s * n1 - k * c * n1_d[0] - (mc + mp) * gs_d[0],
                (_, q) => -k * c * n1_d[q] - (mc + mp) * gs_d[q],
            };
            // z = (x, theta, v, w, f)
            row[1] = (dn(0) - num / d * d_th) / d;
            row[2] = dn(1) / d;
            row[3] = dn(2) / d;
            row[4] = dn(3) / d;
        }
        (values, rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Mechanics;

    fn rod() -> CartPole {
        CartPole {
            cart_mass: 0.5,
            pole_mass: 0.5,
            length: 0.5,
            gravity: 9.82,
            friction: 0.1,
            pole: Pole::UniformRod,
            ..CartPole::default()
        }
    }

    /// The accelerations follow from the energy: along the motion its rate
    /// is the power of the force minus friction's,
    /// $\dot E = (f - b \dot x) \dot x$, for both poles (an independent
    /// check of the two closed forms against the Lagrangian's energy).
    #[test]
    fn energy_rate_is_the_power_in_for_both_poles() {
        let point = CartPole {
            friction: 0.3,
            ..CartPole::default()
        };
        for (c, x, f) in [
            (point, [0.2, 2.1, -0.5, 1.0], 3.0),
            (rod(), [0.2, -0.7, 1.3, 0.9], -4.0),
            (rod(), [1.0, 3.0, 0.4, -2.0], 0.0),
        ] {
            let [a, alpha] = c.acceleration(x[1], x[2], x[3], f);
            let rate_of = |h: f64| {
                let y = [x[0] + h * x[2], x[1] + h * x[3], x[2] + h * a, x[3] + h * alpha];
                c.energy(&y)
            };
            let h = 1e-6;
            let rate = (rate_of(h) - rate_of(-h)) / (2.0 * h);
            let power = (f - c.friction * x[2]) * x[2];
            assert!((rate - power).abs() < 1e-6, "{:?}: {rate} vs {power}", c.pole);
        }
    }

    /// The values of the derivative path are the value path's, and the
    /// rod's Jacobians (friction included) match central differences.
    #[test]
    fn rod_with_friction_accelerations_and_derivatives() {
        let c = rod();
        let (x, u) = ([0.3, 2.5, -0.8, 1.7], [2.0]);
        let (values, rows) = c.accelerations(&x, &u);
        assert_eq!(values, c.acceleration(x[1], x[2], x[3], u[0]));
        let h = 1e-6;
        for j in 0..5 {
            let at = |d: f64| {
                let mut z = [x[0], x[1], x[2], x[3], u[0]];
                z[j] += d;
                c.acceleration(z[1], z[2], z[3], z[4])
            };
            let (p, m) = (at(h), at(-h));
            for i in 0..2 {
                let numeric = (p[i] - m[i]) / (2.0 * h);
                assert!(
                    (rows[i][j] - numeric).abs() < 1e-6 * (1.0 + numeric.abs()),
                    "d acc {i} / d z {j}: {} vs {numeric}",
                    rows[i][j]
                );
            }
        }
        assert_eq!(c.n_q(), 2);
    }
}
