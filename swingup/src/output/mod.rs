//! What a run leaves on disk: the run directory's rules (locks, no
//! overwriting), the grid's files, the run report and the figures
//! ([`plot`], as SVG and PNG).

pub mod diagnostics_report;
pub mod grid;
pub mod grid_report;
pub mod plot;
pub mod run_report;
pub mod rundir;
