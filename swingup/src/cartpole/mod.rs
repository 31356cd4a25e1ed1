//! Beyond the paper: the field's standard benchmark, PILCO's cart-pole
//! swing-up, learned from scratch with the LWR and model-predictive control
//! (issue 22).
//!
//! | module | what |
//! |---|---|
//! | [`plant`] | PILCO's cart-pole (`dynamics_cp.m`, as [`systems::CartPole`] with a uniform rod and friction), RK4 under zero-order hold, force clipped, sensor noise |
//! | [`model`] | the learned model: LWR of the state's change on $[x, \dot x, \dot\theta, \sin\theta, \cos\theta, f]$ over a global linear fit |
//! | [`task`] | the target, the planner's stage cost, PILCO's saturating cost and the success criterion |
//! | [`learn`] | the learning loop: one random trial, then MPC with Eq. 3 replanned at every control period |
//!
//! # PILCO's cart-pole, and where each number comes from
//!
//! The PILCO MATLAB package (Deisenroth, McHutchon, Hall and Rasmussen,
//! `UCL-SML/pilco-matlab`, `scenarios/cartPole/`):
//!
//! | quantity | value | source |
//! |---|---|---|
//! | cart mass $M$ | 0.5 kg | `dynamics_cp.m` |
//! | pole mass $m$ (uniform rod) | 0.5 kg | `dynamics_cp.m` |
//! | pole length $l$ | 0.5 m | `dynamics_cp.m` (the ICML 2011 paper's text says 0.6 m; we follow the code, whose cost also uses `cost.p = 0.5`) |
//! | friction $b$ | 0.1 N s/m | `dynamics_cp.m` |
//! | $g$ | 9.82 m/s² | `dynamics_cp.m` |
//! | force limit | 10 N | `settings_cp.m`: `policy.maxU = 10` |
//! | control period | 0.1 s, zero-order hold | `settings_cp.m`: `dt = 0.10`, `plant.ctrl = @zoh` |
//! | episode length $T$ | 4 s (40 steps) | `settings_cp.m`: `T = 4.0` |
//! | initial state | $\mathcal N(0, 0.1^2 I)$, hanging at rest | `settings_cp.m`: `mu0`, `S0` |
//! | measurement noise | std 0.01 per state | `settings_cp.m`: `plant.noise` |
//! | target | tip upright over the origin, `[0 0 0 pi]` | `settings_cp.m`: `cost.target` |
//! | cost | $1 - \exp(-d^2/(2 \cdot 0.25^2))$, $d$ the tip's distance from the target | `loss_cp.m`, `cost.width = 0.25` |
//! | random trials, controlled trials | $J = 1$, $N = 15$ | `settings_cp.m` |
//! | GP inputs | $x, \dot x, \dot\theta, \sin\theta, \cos\theta$ and the force; targets the state differences | `settings_cp.m`: `dyni`, `difi` |
//!
//! The dynamics, with the uniform rod's 4/3 factors, are in [`plant`].
//! Success: no numerical criterion is published with the PILCO (17.5 s of
//! data) or GP-MPC (9 s, Kamthe and Deisenroth, AISTATS 2018) figures; we
//! define one ([`task`]): the tip within 0.1 m of the target over the
//! episode's last second.
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod learn;
pub mod model;
pub mod plant;
pub mod task;

pub use learn::{CartPoleRun, CartPoleSettings, CartPoleTrial, replay_trials, run, run_resumable};
