//! The pendulum swing-up learned from a demonstration (Atkeson 1997,
//! section 4), simulated; the library behind the `swingup` program.
//!
//! A pendulum hangs from a hand that moves horizontally,
//! $\ddot\theta = -(g/l)\sin\theta - (a/l)\cos\theta - b\dot\theta$, $\ddot x = a$
//! ([`plant`]). A "human" plant demonstrates a swing-up ([`demo`]); the robot,
//! a different plant with noisy sensors, imitates it, then learns a locally
//! weighted regression model of its own dynamics ([`model`]) and plans with
//! the paper's Eq. 3 and the Eq. 5 task cost ([`cost`], [`learn`]) until an
//! LQR ([`lqr`]) can catch and balance the pendulum. [`record`] and
//! [`report`] hold and write what a run saw; [`fit_cmd`] is the `swingup
//! fit` subcommand and [`experiments`] the `swingup experiments` one. For
//! the planner-by-model comparison (claim C6): a learned parametric model
//! ([`parametric`]), the true model ([`truth`]) and a DDP planner
//! ([`ddp_plan`]). [`diagnostics`] puts each plan against what the robot
//! then did, [`support`] is the planner's optional penalty on leaving the
//! data, [`sensitivity`] measures how much model error an open-loop
//! swing-up tolerates, and [`rundir`] and [`grid`] keep runs and grids
//! from overwriting or mixing with each other. [`config`] holds every
//! setting of a run.
//!
//! # Example
//!
//! ```
//! use swingup::demo::{HumanSwingup, demonstrate};
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

pub mod config;
pub mod cost;
pub mod ddp_plan;
pub mod demo;
pub mod diagnostics;
pub mod experiments;
pub mod figures;
pub mod fit_cmd;
pub mod grid;
pub mod learn;
pub mod lqr;
pub mod model;
pub mod parametric;
pub mod plant;
pub mod record;
pub mod report;
pub mod rundir;
pub mod sensitivity;
pub mod support;
mod svg;
pub mod truth;
