//! The three swing-up models as Eq. 3 [`Model`]s: the dynamics of `ddp`'s
//! `Pendulum`, `CartPole` and `Acrobot`, state for state and step for step
//! (`tests/tests/trajectory_problems.rs` checks that they agree).

use crate::eq3::Model;
use crate::error::Result;

/// Accelerations of a mechanical system with $n_q$ positions $q$, rates
/// $v$ (state $x = (q, v)$, $n = 2 n_q$) and controls $u$, and their
/// derivatives with respect to $z = (x, u)$.
trait Mechanics {
    /// $n_q$.
    fn n_q(&self) -> usize;

    /// $\Delta t$.
    fn dt(&self) -> f64;

    /// $\ddot q(x, u)$ (first $n_q$ entries) and $\partial \ddot q / \partial z$
    /// (row $i$, first $n + m$ entries).
    fn accelerations(&self, x: &[f64], u: &[f64]) -> ([f64; 2], [[f64; 5]; 2]);
}

/// Semi-implicit Euler: $v' = v + \Delta t\,\ddot q(x, u)$, then
/// $q' = q + \Delta t\,v'$.
fn euler_step(sys: &impl Mechanics, x: &[f64], u: &[f64], next: &mut [f64]) {
    let (nq, dt) = (sys.n_q(), sys.dt());
    let (acc, _) = sys.accelerations(x, u);
    for i in 0..nq {
        next[nq + i] = x[nq + i] + dt * acc[i];
        next[i] = x[i] + dt * next[nq + i];
    }
}

/// The Jacobians of [`euler_step`], row-major.
fn euler_jacobians(sys: &impl Mechanics, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) {
    let (nq, dt) = (sys.n_q(), sys.dt());
    let (n, m) = (2 * nq, u.len());
    let (_, da) = sys.accelerations(x, u);
    for (i, da_i) in da.iter().enumerate().take(nq) {
        let (rv, rq) = (nq + i, i);
        for j in 0..n {
            let v = dt * da_i[j] + if j == rv { 1.0 } else { 0.0 };
            fx[rv * n + j] = v;
            fx[rq * n + j] = dt * v + if j == rq { 1.0 } else { 0.0 };
        }
        for j in 0..m {
            fu[rv * m + j] = dt * da_i[n + j];
            fu[rq * m + j] = dt * fu[rv * m + j];
        }
    }
}

/// The torque-driven pendulum of `ddp::Pendulum`: state $(\theta, \omega)$,
/// $\theta = 0$ hanging down, control the torque $u$,
/// $\dot\omega = (u - b\omega) / (m l^2) - (g / l) \sin\theta$. (Not the
/// hand-driven [`problems::Pendulum`](crate::problems::Pendulum) of the
/// paper's task.)
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

impl Mechanics for Pendulum {
    fn n_q(&self) -> usize {
        1
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn accelerations(&self, x: &[f64], u: &[f64]) -> ([f64; 2], [[f64; 5]; 2]) {
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
        ([acc, 0.0], [da, [0.0; 5]])
    }
}

/// The cart-pole of `ddp::CartPole`: state $(x, \theta, \dot x, \dot\theta)$,
/// $\theta = 0$ hanging down, control the horizontal force $f$ on the cart,
/// massless rod with a point mass at its end, no friction; with
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

impl Mechanics for CartPole {
    fn n_q(&self) -> usize {
        2
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn accelerations(&self, x: &[f64], u: &[f64]) -> ([f64; 2], [[f64; 5]; 2]) {
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

/// The acrobot of `ddp::Acrobot` (Spong 1995): two links with point masses
/// at their ends, the torque $u$ at the elbow only; state
/// $(\theta_1, \theta_2, \dot\theta_1, \dot\theta_2)$, $\theta_1$ from
/// hanging down, $\theta_2$ relative to the first link;
/// $M(q) \ddot q + C(q, \dot q) \dot q = \tau_g(q) + (0, u)^\top$ with
/// $a = m_2 l_1 l_2$,
/// $M = \begin{pmatrix} (m_1 + m_2) l_1^2 + m_2 l_2^2 + 2 a c_2 & m_2 l_2^2 + a c_2 \\ m_2 l_2^2 + a c_2 & m_2 l_2^2 \end{pmatrix}$,
/// $C \dot q = a s_2 (-2 \dot\theta_1 \dot\theta_2 - \dot\theta_2^2, \dot\theta_1^2)$,
/// $\tau_g = -g ((m_1 + m_2) l_1 s_1 + m_2 l_2 s_{12}, m_2 l_2 s_{12})$.
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

    /// The total energy $\tfrac12 \dot q^\top M \dot q - g((m_1 + m_2) l_1 \cos\theta_1 + m_2 l_2 \cos(\theta_1 + \theta_2))$,
    /// conserved by the continuous dynamics without torque.
    pub fn energy(&self, x: &[f64]) -> f64 {
        let (m, _) = self.mass_matrix(x[1]);
        let (w1, w2) = (x[2], x[3]);
        let kinetic = 0.5 * (m[0] * w1 * w1 + 2.0 * m[1] * w1 * w2 + m[2] * w2 * w2);
        let (l1, l2) = (self.length1, self.length2);
        kinetic - self.gravity * ((self.mass1 + self.mass2) * l1 * x[0].cos() + self.mass2 * l2 * (x[0] + x[1]).cos())
    }
}

impl Mechanics for Acrobot {
    fn n_q(&self) -> usize {
        2
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn accelerations(&self, x: &[f64], u: &[f64]) -> ([f64; 2], [[f64; 5]; 2]) {
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
        let mut da = [[0.0; 5]; 2];
        for j in 0..5 {
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

/// One of the three swing-up models, so that every instance has the same
/// type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SwingUpModel {
    /// A [`Pendulum`].
    Pendulum(Pendulum),
    /// A [`CartPole`].
    CartPole(CartPole),
    /// An [`Acrobot`].
    Acrobot(Acrobot),
}

macro_rules! euler_model {
    ($($t:ty),*) => {$(
        /// Semi-implicit Euler (velocities first, then positions with the
        /// new velocities), with analytic Jacobians.
        impl Model for $t {
            fn state_dim(&self) -> usize {
                2 * Mechanics::n_q(self)
            }
            fn control_dim(&self) -> usize {
                1
            }
            fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> Result<()> {
                euler_step(self, x, u, next);
                Ok(())
            }
            fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<bool> {
                euler_jacobians(self, x, u, fx, fu);
                Ok(true)
            }
        }
    )*};
}

euler_model!(Pendulum, CartPole, Acrobot, SwingUpModel);

impl Mechanics for SwingUpModel {
    fn n_q(&self) -> usize {
        match self {
            SwingUpModel::Pendulum(_) => 1,
            SwingUpModel::CartPole(_) | SwingUpModel::Acrobot(_) => 2,
        }
    }
    fn dt(&self) -> f64 {
        match self {
            SwingUpModel::Pendulum(p) => p.dt,
            SwingUpModel::CartPole(c) => c.dt,
            SwingUpModel::Acrobot(a) => a.dt,
        }
    }
    fn accelerations(&self, x: &[f64], u: &[f64]) -> ([f64; 2], [[f64; 5]; 2]) {
        match self {
            SwingUpModel::Pendulum(p) => p.accelerations(x, u),
            SwingUpModel::CartPole(c) => c.accelerations(x, u),
            SwingUpModel::Acrobot(a) => a.accelerations(x, u),
        }
    }
}
