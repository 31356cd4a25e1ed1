//! The three swing-up models of `nprl-systems`: they implement the one
//! model contract ([`systems::Dynamics`], re-exported as [`crate::Dynamics`])
//! themselves, so Eq. 3 plans the very types `ddp` steps
//! (`tests/tests/trajectory_problems.rs` checks that the two crates agree).

pub use systems::{Acrobot, CartPole, Pendulum, SwingUpModel};
