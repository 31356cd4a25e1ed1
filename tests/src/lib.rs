//! Cross-crate integration tests of the workspace; the tests live in
//! `tests/tests/`. This library holds what several of them share.
#![warn(missing_docs)]

/// The root README, whose "Use a crate in your project" examples run as
/// doc tests here (`cargo test -p integration-tests --doc`), so that they
/// compile and hold as written.
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
pub struct RootReadme;

use std::path::{Path, PathBuf};

use faer::Mat;
use trajopt::{CostBreakdown, Dynamics, Eq3Problem, GaussNewton, GaussNewtonResult, GaussNewtonSettings, StageCost};

/// An Eq. 3 plan: Gauss-Newton's result on the problem, the cost breakdown
/// of its answer, and the answer's states and controls (one row per
/// sample).
pub struct Eq3Plan {
    /// The solver's result.
    pub result: GaussNewtonResult,
    /// [`Eq3Problem::cost_breakdown`] at the answer.
    pub parts: CostBreakdown,
    /// [`Eq3Problem::trajectory`] of the answer: the states.
    pub states: Mat<f64>,
    /// The controls.
    pub controls: Mat<f64>,
}

/// Gauss-Newton (default settings but at most `max_iterations`) on
/// `problem` from `theta0`; panics if the solver fails (a test's failure).
pub fn gauss_newton_plan<M: Dynamics, C: StageCost>(
    problem: &Eq3Problem<M, C>,
    theta0: &[f64],
    max_iterations: usize,
) -> Eq3Plan {
    let settings = GaussNewtonSettings {
        max_iterations,
        ..GaussNewtonSettings::default()
    };
    let result = GaussNewton::new(settings)
        .expect("settings")
        .solve(problem, theta0)
        .expect("solve");
    let parts = problem.cost_breakdown(&result.x).expect("cost");
    let (states, controls) = problem.trajectory(&result.x).expect("trajectory");
    Eq3Plan {
        result,
        parts,
        states,
        controls,
    }
}

/// The workspace's root (this crate is one of its members).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The text of the file at `relative` to the workspace's root (a saved
/// result, a README, a seed file); panics naming the file if it cannot be
/// read (a test's failure).
pub fn read_workspace_file(relative: &str) -> String {
    let path = workspace_root().join(relative);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()))
}
