//! The three swing-up models of `nprl-systems` as Eq. 3 [`Model`]s: the
//! very types `ddp` steps (`tests/tests/trajectory_problems.rs` checks that
//! the two crates agree).

use systems::Mechanics;

use crate::eq3::Model;
use crate::error::Result;

pub use systems::{Acrobot, CartPole, Pendulum, SwingUpModel};

macro_rules! euler_model {
    ($($t:ty),*) => {$(
        /// Semi-implicit Euler (velocities first, then positions with the
        /// new velocities), with the analytic Jacobians of
        /// [`Mechanics::euler_jacobians`].
        impl Model for $t {
            fn state_dim(&self) -> usize {
                self.n_x()
            }
            fn control_dim(&self) -> usize {
                self.n_u()
            }
            fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> Result<()> {
                self.euler_step(x, u, next);
                Ok(())
            }
            fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<bool> {
                self.euler_jacobians(x, u, fx, fu);
                Ok(true)
            }
        }
    )*};
}

euler_model!(Pendulum, CartPole, Acrobot, SwingUpModel);
