//! The acrobot: a double pendulum driven at the elbow only.

use crate::error::Result;
use crate::problem::Dynamics;

/// An acrobot (Spong, "The swing up control problem for the acrobot", IEEE
/// Control Systems 15(1), 1995): two links with point masses at their ends,
/// a frictionless shoulder joint, and the torque $u$ at the elbow. State
/// $(\theta_1, \theta_2, \dot\theta_1, \dot\theta_2)$ (positions first, as
/// every model of the workspace), $\theta_1$ the first link's angle from
/// hanging down, $\theta_2$ the second link's angle relative to the first;
/// the manipulator equation (Tedrake, *Underactuated Robotics*, ch. 3, with
/// the links' inertias those of point masses at their ends)
/// $$M(q) \ddot q + C(q, \dot q) \dot q = \tau_g(q) + (0, u)^\top,$$
/// $a = m_2 l_1 l_2$, $c_i = \cos\theta_i$, $s_i = \sin\theta_i$, $s_{12} = \sin(\theta_1 + \theta_2)$:
/// $$M = \begin{pmatrix} (m_1 + m_2) l_1^2 + m_2 l_2^2 + 2 a c_2 & m_2 l_2^2 + a c_2 \\ m_2 l_2^2 + a c_2 & m_2 l_2^2 \end{pmatrix}, \quad
/// C \dot q = a s_2 \begin{pmatrix} -2 \dot\theta_1 \dot\theta_2 - \dot\theta_2^2 \\ \dot\theta_1^2 \end{pmatrix}, \quad
/// \tau_g = -g \begin{pmatrix} (m_1 + m_2) l_1 s_1 + m_2 l_2 s_{12} \\ m_2 l_2 s_{12} \end{pmatrix},$$
/// discretised by semi-implicit Euler (velocities first, then positions
/// with the new velocities). Upright is $(\pi, 0, 0, 0)$, an equilibrium
/// with $u = 0$, as is hanging $(0, 0, 0, 0)$. First derivatives only (the
/// solver is iLQR on it).
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
    /// The accelerations $\ddot q = M^{-1}(\tau_g + (0, u) - C \dot q)$ and
    /// their derivatives with respect to $(\theta_1, \theta_2, \dot\theta_1,
    /// \dot\theta_2, u)$ (rows $\ddot\theta_1$, $\ddot\theta_2$).
    pub fn accelerations(&self, x: &[f64], u: f64) -> ([f64; 2], [[f64; 5]; 2]) {
        let (m1, m2, l1, l2, g) = (self.mass1, self.mass2, self.length1, self.length2, self.gravity);
        let (w1, w2) = (x[2], x[3]);
        let (s1, c1) = x[0].sin_cos();
        let (s2, c2) = x[1].sin_cos();
        let (s12, c12) = (x[0] + x[1]).sin_cos();
        let a = m2 * l1 * l2;
        let i2 = m2 * l2 * l2;
        let m = [(m1 + m2) * l1 * l1 + i2 + 2.0 * a * c2, i2 + a * c2, i2];
        let det = m[0] * m[2] - m[1] * m[1];
        let solve = |h: [f64; 2]| [(m[2] * h[0] - m[1] * h[1]) / det, (m[0] * h[1] - m[1] * h[0]) / det];
        let h = [
            -g * ((m1 + m2) * l1 * s1 + m2 * l2 * s12) + a * s2 * (2.0 * w1 * w2 + w2 * w2),
            -g * m2 * l2 * s12 + u - a * s2 * w1 * w1,
        ];
        let acc = solve(h);
        // dh/dz for z = (theta1, theta2, omega1, omega2, u)
        let dh = [
            [
                -g * ((m1 + m2) * l1 * c1 + m2 * l2 * c12),
                -g * m2 * l2 * c12 + a * c2 * (2.0 * w1 * w2 + w2 * w2),
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
        // d(M acc)/d theta2 = dM/d theta2 acc + M d acc/d theta2
        let dm = [-2.0 * a * s2, -a * s2, 0.0];
        let dm_acc = [dm[0] * acc[0] + dm[1] * acc[1], dm[1] * acc[0] + dm[2] * acc[1]];
        let mut dacc = [[0.0; 5]; 2];
        for j in 0..5 {
            let mut rhs = [dh[0][j], dh[1][j]];
            if j == 1 {
                rhs = [rhs[0] - dm_acc[0], rhs[1] - dm_acc[1]];
            }
            let col = solve(rhs);
            dacc[0][j] = col[0];
            dacc[1][j] = col[1];
        }
        (acc, dacc)
    }

    /// The total energy $\tfrac12 \dot q^\top M(q) \dot q - g((m_1 + m_2) l_1 c_1 + m_2 l_2 \cos(\theta_1 + \theta_2))$,
    /// conserved by the continuous dynamics without torque.
    pub fn energy(&self, x: &[f64]) -> f64 {
        let (m1, m2, l1, l2, g) = (self.mass1, self.mass2, self.length1, self.length2, self.gravity);
        let c2 = x[1].cos();
        let a = m2 * l1 * l2;
        let i2 = m2 * l2 * l2;
        let m = [(m1 + m2) * l1 * l1 + i2 + 2.0 * a * c2, i2 + a * c2, i2];
        let (w1, w2) = (x[2], x[3]);
        let kinetic = 0.5 * (m[0] * w1 * w1 + 2.0 * m[1] * w1 * w2 + m[2] * w2 * w2);
        kinetic - g * ((m1 + m2) * l1 * x[0].cos() + m2 * l2 * (x[0] + x[1]).cos())
    }
}

impl Dynamics for Acrobot {
    fn state_dim(&self) -> usize {
        4
    }
    fn control_dim(&self) -> usize {
        1
    }
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> Result<()> {
        let (acc, _) = self.accelerations(x, u[0]);
        next[2] = x[2] + self.dt * acc[0];
        next[3] = x[3] + self.dt * acc[1];
        next[0] = x[0] + self.dt * next[2];
        next[1] = x[1] + self.dt * next[3];
        Ok(())
    }
    fn derivatives(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<()> {
        let (_, da) = self.accelerations(x, u[0]);
        let dt = self.dt;
        for i in 0..2 {
            // velocity row 2 + i: v' = v + dt a(x, u); position row i: q' = q + dt v'
            for j in 0..4 {
                let v = dt * da[i][j] + if j == 2 + i { 1.0 } else { 0.0 };
                fx[(2 + i) * 4 + j] = v;
                fx[i * 4 + j] = dt * v + if j == i { 1.0 } else { 0.0 };
            }
            fu[2 + i] = dt * da[i][4];
            fu[i] = dt * fu[2 + i];
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The energy from the Cartesian positions and velocities of the two
    /// masses, independent of the mass matrix.
    fn cartesian_energy(p: &Acrobot, x: &[f64]) -> f64 {
        let (t1, t12) = (x[0], x[0] + x[1]);
        let (w1, w12) = (x[2], x[2] + x[3]);
        let (y1, vx1, vy1) = (
            -p.length1 * t1.cos(),
            p.length1 * t1.cos() * w1,
            p.length1 * t1.sin() * w1,
        );
        let y2 = y1 - p.length2 * t12.cos();
        let (vx2, vy2) = (vx1 + p.length2 * t12.cos() * w12, vy1 + p.length2 * t12.sin() * w12);
        0.5 * p.mass1 * (vx1 * vx1 + vy1 * vy1)
            + 0.5 * p.mass2 * (vx2 * vx2 + vy2 * vy2)
            + p.gravity * (p.mass1 * y1 + p.mass2 * y2)
    }

    #[test]
    fn acrobot_energy_matches_the_cartesian_energy() {
        let p = Acrobot {
            mass1: 0.7,
            length2: 1.3,
            ..Acrobot::default()
        };
        for x in [[0.3, -1.2, 2.0, -0.5], [2.9, 0.4, -1.0, 3.0], [0.0; 4]] {
            assert!((p.energy(&x) - cartesian_energy(&p, &x)).abs() < 1e-12);
        }
    }

    #[test]
    fn acrobot_without_torque_conserves_energy_as_dt_shrinks() {
        // semi-implicit Euler: the energy error shrinks with the step
        let x0 = [2.0, -0.7, 0.5, 1.0];
        let drift = |dt: f64| {
            let p = Acrobot {
                dt,
                ..Acrobot::default()
            };
            let (mut x, mut next) = (x0.to_vec(), vec![0.0; 4]);
            let e0 = p.energy(&x);
            let mut worst: f64 = 0.0;
            for _ in 0..(1.0 / dt).round() as usize {
                p.step(&x, &[0.0], &mut next).expect("step");
                std::mem::swap(&mut x, &mut next);
                worst = worst.max((p.energy(&x) - e0).abs());
            }
            worst / e0.abs()
        };
        let (coarse, fine) = (drift(1e-3), drift(1e-4));
        assert!(fine < 2e-3, "{fine}");
        assert!(fine < 0.2 * coarse, "{coarse} -> {fine}");
    }

    #[test]
    fn acrobot_equilibria_are_fixed_points() {
        let p = Acrobot::default();
        let mut next = [0.0; 4];
        for x in [[0.0; 4], [std::f64::consts::PI, 0.0, 0.0, 0.0]] {
            p.step(&x, &[0.0], &mut next).expect("step");
            for i in 0..4 {
                assert!((next[i] - x[i]).abs() < 1e-14, "{x:?} -> {next:?}");
            }
        }
        // elbow torque swings the second link one way and the first the other
        p.step(&[0.0; 4], &[1.0], &mut next).expect("step");
        assert!(next[3] > 0.0 && next[2] < 0.0, "{next:?}");
    }
}
