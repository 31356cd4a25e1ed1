//! The pendulum swing-up learned from a demonstration (Atkeson 1997,
//! section 4), simulated; the library behind the `swingup` program.
//!
//! A pendulum hangs from a hand that moves horizontally,
//! $\ddot\theta = -(g/l)\sin\theta - (a/l)\cos\theta - b\dot\theta$, $\ddot x = a$
//! ([`plant`]). A "human" plant demonstrates a swing-up ([`plant::demo`]);
//! the robot, a different plant with noisy sensors, imitates it, then
//! learns a locally weighted regression model of its own dynamics
//! ([`models`]) and plans with the paper's Eq. 3 and the Eq. 5 task cost
//! ([`planning`]) until an LQR ([`plant::lqr`]) can catch and balance the
//! pendulum ([`learn`]).
//!
//! # Layout
//!
//! The modules form layers; each imports only from the layers above it in
//! this list (checked by `tests/tests/layers.rs` of the workspace):
//!
//! | layer | modules | what |
//! |---|---|---|
//! | base | [`error`], [`format`](mod@format) | the library's error type; numbers as the reports print them |
//! | plant | [`plant`], [`plant::lqr`], [`plant::demo`] | the simulated pendulum on a hand, the LQR catch, the human's demonstration |
//! | config | [`config`] | every setting of a run, validated |
//! | records | [`record`] | what a trial and a run saw, and the training pairs drawn from it |
//! | models | [`models`] ([`models::nonparametric`], [`models::parametric`], [`models::truth`], [`models::learned`]) | the robot's models of its dynamics, and fitting them to the trials |
//! | planning | [`planning`] ([`planning::cost`], [`planning::support`], [`planning::eq3`], [`planning::ddp`]) | the task cost, the penalty on leaving the data, Eq. 3 by Gauss-Newton or Powell, and DDP |
//! | learning | [`learn`], [`diagnostics`], [`cartpole`] | the trial loop; each plan against what the robot then did; the cart-pole swing-up learned from scratch by MPC |
//! | experiments | [`experiments`] ([`experiments::claims`], [`experiments::sensitivity`]) | the grid behind the paper's claims, and how much model error an open-loop swing-up tolerates |
//! | output | [`output`] ([`output::run_report`], [`output::plot`], [`output::grid_report`], [`output::rundir`], [`output::grid`]) | what a run leaves on disk (figures as SVG and PNG), and the rules that keep runs from overwriting or mixing |
//! | program | `cli` of the `swingup` binary (`src/cli/`, beside `main.rs`) | the subcommands' arguments and handlers (`swingup experiments`, its shards and `merge`) |
//!
//! [`fit_cmd`] is the `swingup fit` subcommand (locally weighted regression
//! on a CSV file), an alias of `lwr`'s CSV fit tool [`lwr::csv_fit`] (also
//! the `lwr-fit` binary); it uses nothing else of this crate.
//!
//! # Example
//!
//! ```
//! use swingup::plant::demo::{HumanSwingup, demonstrate};
//! use swingup::plant::{Plant, PlantParams, PlantState, from_upright};
//!
//! // the human's demonstration: 150 samples of swing-up at 60 Hz, then balancing
//! let (demo, run) = demonstrate(&PlantParams::human(), &HumanSwingup::default(), 150, 120).expect("lqr");
//! assert_eq!(demo.controls.len(), 150);
//! assert!(from_upright(run.last().expect("states")[0]).abs() < 0.2);
//!
//! // replayed open loop on the robot, it does not get halfway up (claim C1)
//! let robot = Plant::new(PlantParams::robot());
//! let mut state = PlantState::hanging();
//! let mut highest: f64 = 0.0;
//! for &u in &demo.controls {
//!     state = robot.step(&state, u);
//!     highest = highest.max(state.s[0].abs());
//! }
//! assert!(highest < std::f64::consts::FRAC_PI_2);
//! ```
#![warn(missing_docs)]

pub mod cartpole;
pub mod config;
pub mod diagnostics;
pub mod error;
pub mod experiments;
pub mod fit_cmd;
pub mod format;
pub mod learn;
pub mod models;
pub mod output;
pub mod planning;
pub mod plant;
pub mod record;

pub use error::{Error, Result};
