//! What a run leaves on disk: the run directory's rules (locks, no
//! overwriting), the grid's files, the run report and the figures
//! ([`plot`], as SVG and PNG).
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod console;
pub mod diagnostics_report;
pub mod grid;
pub mod grid_report;
pub mod plot;
pub mod run_report;
pub mod rundir;

/// Checks that `dir` can take a program's output before its work starts:
/// creates it if needed and writes and removes a probe file of its own.
///
/// # Errors
/// [`Error::Io`](crate::Error::Io) naming the directory or the probe file.
pub fn check_out_dir(dir: &std::path::Path) -> crate::Result<()> {
    store::create_output_dir(dir)?;
    let probe = dir.join(format!(".swingup-probe-{}", std::process::id()));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .map_err(|e| crate::Error::io("writing a file into", dir, e))?;
    std::fs::remove_file(&probe).map_err(|e| crate::Error::io("removing", &probe, e))
}
