//! The acrobot: a double pendulum driven at the elbow only.

use crate::{Accelerations, MAX_INPUTS, MAX_POSITIONS};

/// An acrobot (Spong, "The swing up control problem for the acrobot", IEEE
/// Control Systems 15(1), 1995): two links with point masses at their ends,
/// a frictionless shoulder joint, and the torque $u$ at the elbow. State
/// $(\theta_1, \theta_2, \dot\theta_1, \dot\theta_2)$, $\theta_1$ the first
/// link's angle from hanging down, $\theta_2$ the second link's angle
/// relative to the first; the manipulator equation (Tedrake,
/// *Underactuated Robotics*, ch. 3, with the links' inertias those of point
/// masses at their ends)
/// $$M(q) \ddot q + C(q, \dot q) \dot q = \tau_g(q) + (0, u)^\top,$$
/// $a = m_2 l_1 l_2$, $c_i = \cos\theta_i$, $s_i = \sin\theta_i$, $s_{12} = \sin(\theta_1 + \theta_2)$:
/// $$M = \begin{pmatrix} (m_1 + m_2) l_1^2 + m_2 l_2^2 + 2 a c_2 & m_2 l_2^2 + a c_2 \\ m_2 l_2^2 + a c_2 & m_2 l_2^2 \end{pmatrix}, \quad
/// C \dot q = a s_2 \begin{pmatrix} -2 \dot\theta_1 \dot\theta_2 - \dot\theta_2^2 \\ \dot\theta_1^2 \end{pmatrix}, \quad
/// \tau_g = -g \begin{pmatrix} (m_1 + m_2) l_1 s_1 + m_2 l_2 s_{12} \\ m_2 l_2 s_{12} \end{pmatrix}.$$
/// Upright is $(\pi, 0, 0, 0)$, an equilibrium with $u = 0$, as is hanging
/// $(0, 0, 0, 0)$.
///
/// | field | default |
/// |---|---|
/// | `mass1`, `mass2` | 1 kg |
/// | `length1`, `length2` | 1 m |
/// | `gravity` | 9.81 m/s² |
/// | `dt` | 0.01 s |
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Acrobot {
    /// Point mass $m_1$ at the end of the first link.
    pub mass1: f64,
    /// Point mass $m_2$ at the end of the second link.
    pub mass2: f64,
    /// First link's length $l_1$.
    pub length1: f64,
    /// Second link's length $l_2$.
    pub length2: f64,
    /// Gravity $g$.
    pub gravity: f64,
    /// Time step $\Delta t$.
    pub dt: f64,
}

impl Default for Acrobot {
    fn default() -> Self {
        Self {
            mass1: 1.0,
            mass2: 1.0,
            length1: 1.0,
            length2: 1.0,
            gravity: 9.81,
            dt: 0.01,
        }
    }
}

impl Acrobot {
    /// $M(q)$ as $(M_{11}, M_{12}, M_{22})$ and its derivative in $\theta_2$.
    fn mass_matrix(&self, theta2: f64) -> ([f64; 3], [f64; 3]) {
        let (s2, c2) = theta2.sin_cos();
        let a = self.mass2 * self.length1 * self.length2;
        let i2 = self.mass2 * self.length2 * self.length2;
        let m11 = (self.mass1 + self.mass2) * self.length1 * self.length1 + i2;
        ([m11 + 2.0 * a * c2, i2 + a * c2, i2], [-2.0 * a * s2, -a * s2, 0.0])
    }

    /// The total energy $\tfrac12 \dot q^\top M(q) \dot q - g((m_1 + m_2) l_1 c_1 + m_2 l_2 \cos(\theta_1 + \theta_2))$,
    /// conserved by the continuous dynamics without torque.
    pub fn energy(&self, x: &[f64]) -> f64 {
        let (m, _) = self.mass_matrix(x[1]);
        let (w1, w2) = (x[2], x[3]);
        let kinetic = 0.5 * (m[0] * w1 * w1 + 2.0 * m[1] * w1 * w2 + m[2] * w2 * w2);
        let (l1, l2) = (self.length1, self.length2);
        kinetic - self.gravity * ((self.mass1 + self.mass2) * l1 * x[0].cos() + self.mass2 * l2 * (x[0] + x[1]).cos())
    }

    /// The accelerations and their derivatives
    /// ([`Mechanics::accelerations`](crate::Mechanics::accelerations)).
    #[inline]
    pub(crate) fn accelerations(&self, x: &[f64], u: &[f64]) -> Accelerations {
        let (m2, l1, l2, g) = (self.mass2, self.length1, self.length2, self.gravity);
        let (w1, w2) = (x[2], x[3]);
        let (s1, c1) = x[0].sin_cos();
        let (s2, c2) = x[1].sin_cos();
        let (s12, c12) = (x[0] + x[1]).sin_cos();
        let a = m2 * l1 * l2;
        let (m, dm) = self.mass_matrix(x[1]);
        let det = m[0] * m[2] - m[1] * m[1];
        let solve = |h: [f64; 2]| [(m[2] * h[0] - m[1] * h[1]) / det, (m[0] * h[1] - m[1] * h[0]) / det];
        let g1 = (self.mass1 + m2) * l1;
        // h = tau_g + (0, u) - C qdot, and dh/dz
        let h = [
            -g * (g1 * s1 + m2 * l2 * s12) + a * s2 * (2.0 * w1 + w2) * w2,
            -g * m2 * l2 * s12 + u[0] - a * s2 * w1 * w1,
        ];
        let acc = solve(h);
        let dh = [
            [
                -g * (g1 * c1 + m2 * l2 * c12),
                -g * m2 * l2 * c12 + a * c2 * (2.0 * w1 + w2) * w2,
                2.0 * a * s2 * w2,
                2.0 * a * s2 * (w1 + w2),
                0.0,
            ],
            [
                -g * m2 * l2 * c12,
                -g * m2 * l2 * c12 - a * c2 * w1 * w1,
                -2.0 * a * s2 * w1,
                0.0,
                1.0,
            ],
        ];
        // M dacc/dz = dh/dz - (dM/dz) acc, and only theta2 moves M
        let mut da = [[0.0; MAX_INPUTS]; MAX_POSITIONS];
        for j in 0..MAX_INPUTS {
            let mut rhs = [dh[0][j], dh[1][j]];
            if j == 1 {
                rhs[0] -= dm[0] * acc[0] + dm[1] * acc[1];
                rhs[1] -= dm[1] * acc[0] + dm[2] * acc[1];
            }
            let col = solve(rhs);
            (da[0][j], da[1][j]) = (col[0], col[1]);
        }
        (acc, da)
    }
}
