//! Benchmark runner: runs optimisers on problem sets and writes
//! per-problem tables, Dolan-Moré performance profiles (time and
//! evaluations) and Moré-Wild data profiles, as JSON, CSV and figures;
//! merges the runs of outside solvers that the scripts in `scripts/bench/`
//! record in the same format. See `bench/README.md` for the command.
//!
//! ```no_run
//! use bench::problems::ProblemSet;
//! use bench::solvers::Solver;
//! use bench::runner::{RunnerSettings, default_budget, execute};
//!
//! let settings = RunnerSettings {
//!     set: ProblemSet::Mgh,
//!     solvers: Solver::parse_entries("gauss-newton,powell")?,
//!     filter: Some("rosenbrock".into()),
//!     budget: default_budget(),
//!     repeats: 1,
//!     out: "target/bench-example".into(),
//!     report_dir: "target/bench-example".into(),
//!     outside: vec![],
//!     reuse: false,
//!     force: false,
//! };
//! let (analysis, stamp) = execute(&settings)?;
//! println!("{} runs at {}", stamp.runs, stamp.commit);
//! # Ok::<(), bench::BenchError>(())
//! ```

pub mod analysis;
pub mod compare;
pub mod error;
pub mod files;
pub mod instance;
pub mod lwr_instance;
pub mod minima;
pub mod nist;
pub mod open;
pub mod plot;
pub mod problems;
pub mod process;
pub mod profiles;
pub mod record;
pub mod report;
pub mod runner;
pub mod shard;
pub mod solvers;
pub mod trajectory;

pub use error::{BenchError, Result};
