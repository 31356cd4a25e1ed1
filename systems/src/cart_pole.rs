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
    /// ([`Mechanics::accelerations`](crate::Mechanics::accelerations)) over
    /// $z = (x, \theta, \dot x, \dot\theta, f)$.
    #[inline(always)]
    pub(crate) fn accelerations(&self, x: &[f64], u: &[f64]) -> Accelerations {
        if self.pole == Pole::PointMass && self.friction == 0.0 {
            self.point_mass_accelerations(x, u)
        } else {
            self.general_accelerations(x, u)
        }
    }

    /// The frictionless point mass's closed form and its derivatives (the
    /// fast path: friction's terms measurably slow the benchmark's DDP on
    /// the cart-pole, `cargo bench -p nprl-ddp --bench ddp -- cartpole`).
    #[inline(always)]
    fn point_mass_accelerations(&self, x: &[f64], u: &[f64]) -> Accelerations {
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

    /// The derivatives from the general form, for any pole: with
    /// $F = f - b\dot x$, $N = F + m_p l_c \sin\theta\,\dot\theta^2$,
    /// $G = m_p g l_c \sin\theta$ and $D = (m_c + m_p) J - (m_p l_c \cos\theta)^2$,
    /// $\ddot x = (J N + m_p l_c \cos\theta\, G) / D$ and
    /// $\ddot\theta = (-m_p l_c \cos\theta\, N - (m_c + m_p) G) / D$; the
    /// values are [`Self::acceleration`]'s.
    fn general_accelerations(&self, x: &[f64], u: &[f64]) -> Accelerations {
        let (v, w, f) = (x[2], x[3], u[0]);
        let values = self.acceleration(x[1], v, w, f);
        let (mt, g, b) = (self.cart_mass + self.pole_mass, self.gravity, self.friction);
        let (lc, j) = self.pole_inertia();
        let k = self.pole_mass * lc;
        let (s, c) = x[1].sin_cos();
        let d = mt * j - k * k * c * c;
        let d_th = 2.0 * k * k * c * s;
        let n = f - b * v + k * s * w * w;
        let gs = k * g * s;
        // N's derivatives in (theta, v, omega, f); G's in theta alone
        let n_d = [k * c * w * w, -b, 2.0 * k * s * w, 1.0];
        let gs_th = k * g * c;
        let num = [j * n + k * c * gs, -k * c * n - mt * gs];
        let num_th = [
            j * n_d[0] - k * s * gs + k * c * gs_th,
            k * s * n - k * c * n_d[0] - mt * gs_th,
        ];
        let num_rest = [j, -k * c];
        let mut rows = [[0.0; crate::MAX_INPUTS]; 2];
        for i in 0..2 {
            rows[i][1] = (num_th[i] - num[i] / d * d_th) / d;
            for q in 1..4 {
                rows[i][q + 1] = num_rest[i] * n_d[q] / d;
            }
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

    /// For both poles with friction, the values of the derivative path are
    /// the value path's and the Jacobians match central differences; the
    /// frictionless point mass's closed form equals the general form's to
    /// rounding.
    #[test]
    fn accelerations_and_derivatives_with_friction() {
        let point = CartPole {
            friction: 0.3,
            ..CartPole::default()
        };
        let (x, u) = ([0.3, 2.5, -0.8, 1.7], [2.0]);
        for c in [rod(), point] {
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
                        "{:?}: d acc {i} / d z {j}: {} vs {numeric}",
                        c.pole,
                        rows[i][j]
                    );
                }
            }
        }
        let frictionless = CartPole::default();
        let (fast, general) = (
            frictionless.point_mass_accelerations(&x, &u),
            frictionless.general_accelerations(&x, &u),
        );
        for i in 0..2 {
            assert!((fast.0[i] - general.0[i]).abs() < 1e-12 * (1.0 + fast.0[i].abs()));
            for j in 0..5 {
                assert!((fast.1[i][j] - general.1[i][j]).abs() < 1e-12 * (1.0 + fast.1[i][j].abs()));
            }
        }
        assert_eq!(frictionless.n_q(), 2);
    }
}
