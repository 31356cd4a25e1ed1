#![doc = include_str!("../README.md")]

mod acrobot;
mod cart_pole;
pub mod hand_pendulum;
pub mod model;
mod pendulum;
mod registry;

pub use acrobot::Acrobot;
pub use cart_pole::{CartPole, Pole};
pub use model::{
    Dynamics, ModelError, ModelResult, StageCost, StepOnly, central_differences, jacobians_or_differences,
    residual_count, stage_central_differences,
};
pub use pendulum::Pendulum;
pub use registry::{DT, STANDARD_LAMBDAS, SwingUpModel, SwingUpWeights, System, find_instance};

/// Most positions $n_q$ a [`Mechanics`] may have.
pub const MAX_POSITIONS: usize = 2;

/// Length of a row of [`Mechanics::accelerations`]' derivatives: the
/// largest $n + m = 2 n_q + 1$.
pub const MAX_INPUTS: usize = 2 * MAX_POSITIONS + 1;

/// $\ddot q$ (the first $n_q$ entries) and $\partial \ddot q_i / \partial z_j$
/// for $z = (x, u)$ (row $i$, the first $n + m$ entries); see
/// [`Mechanics::accelerations`].
pub type Accelerations = ([f64; MAX_POSITIONS], [[f64; MAX_INPUTS]; MAX_POSITIONS]);

/// A mechanical system with $n_q \le 2$ positions $q$, their rates $v$
/// (state $x = (q, v)$, $n = 2 n_q$, positions first) and one control $u$
/// ($m = 1$), stepped by semi-implicit Euler with time step $\Delta t$.
///
/// An implementation gives the accelerations $\ddot q(x, u)$ and their
/// derivatives; the step ([`euler_step`](Self::euler_step)) and its exact
/// Jacobians ([`euler_jacobians`](Self::euler_jacobians)) follow.
pub trait Mechanics {
    /// The number of positions $n_q$ (1 or 2).
    fn n_q(&self) -> usize;

    /// The time step $\Delta t$ (s).
    fn dt(&self) -> f64;

    /// $\ddot q(x, u)$ (the first $n_q$ entries; the rest are zero) and
    /// $\partial \ddot q_i / \partial z_j$ for $z = (x, u)$ (row $i$, the
    /// first $n + m$ entries; the rest are zero). `x` has length $n$, `u`
    /// length 1.
    fn accelerations(&self, x: &[f64], u: &[f64]) -> Accelerations;

    /// The state dimension $n = 2 n_q$.
    fn n_x(&self) -> usize {
        2 * self.n_q()
    }

    /// The control dimension $m = 1$.
    fn n_u(&self) -> usize {
        1
    }

    /// Semi-implicit Euler, velocities first, then positions with the new
    /// velocities: $v' = v + \Delta t\,\ddot q(x, u)$, $q' = q + \Delta t\,v'$;
    /// writes $x' = (q', v')$ into `next` (length $n$).
    fn euler_step(&self, x: &[f64], u: &[f64], next: &mut [f64]) {
        let (nq, dt) = (self.n_q(), self.dt());
        let (acc, _) = self.accelerations(x, u);
        for i in 0..nq {
            next[nq + i] = x[nq + i] + dt * acc[i];
            next[i] = x[i] + dt * next[nq + i];
        }
    }

    /// The exact Jacobians of [`euler_step`](Self::euler_step), row-major:
    /// `fx` ($n \times n$) $= \partial x' / \partial x$ and `fu`
    /// ($n \times 1$) $= \partial x' / \partial u$. Every entry is written.
    fn euler_jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) {
        let (nq, dt) = (self.n_q(), self.dt());
        let (n, m) = (2 * nq, u.len());
        let (_, da) = self.accelerations(x, u);
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
}

macro_rules! mechanics {
    ($($t:ty: $n_q:literal),*) => {$(
        /// The system's own accelerations, stepped with its `dt`.
        impl Mechanics for $t {
            fn n_q(&self) -> usize {
                $n_q
            }
            fn dt(&self) -> f64 {
                self.dt
            }
            #[inline]
            fn accelerations(&self, x: &[f64], u: &[f64]) -> Accelerations {
                <$t>::accelerations(self, x, u)
            }
        }
    )*};
}

mechanics!(Pendulum: 1, CartPole: 2, Acrobot: 2);
