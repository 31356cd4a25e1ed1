//! What the crate's integration tests share.

use ddp::{Cost, Ddp, DdpProblem, DdpResult, DdpSettings, Dynamics};

/// Solves `problem` with `settings`, which must be valid, and a warm start
/// that must roll out.
pub(crate) fn solve_with<D: Dynamics, C: Cost>(settings: DdpSettings, problem: &DdpProblem<D, C>) -> DdpResult {
    Ddp::new(settings).expect("settings").solve(problem).expect("solve")
}

/// [`solve_with`] the default settings.
pub(crate) fn solve<D: Dynamics, C: Cost>(problem: &DdpProblem<D, C>) -> DdpResult {
    solve_with(DdpSettings::default(), problem)
}
