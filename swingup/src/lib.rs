//! The pendulum swing-up learned from a demonstration (Atkeson 1997, section 4), simulated.
#![warn(missing_docs)]

pub mod demo;
pub mod fit_cmd;
pub mod learn;
pub mod lqr;
pub mod model;
pub mod plant;
pub mod record;
pub mod report;
