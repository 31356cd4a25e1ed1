//! `swingup fit`: a thin alias of the CSV fit tool [`lwr::csv_fit`] (the
//! same options, output and errors as the `lwr-fit` binary): locally
//! weighted regression on a CSV file, with the metric tuned by
//! leave-one-out cross-validation.
//!
//! ```text
//! swingup fit --train TRAIN.csv [--test TEST.csv] --target NAME [--target NAME ...]
//!             [--out PRED.csv] [--json] [--kernel K] [--degree D] [--bandwidth H]
//!             [--tune-evals N] [--level L]
//! ```
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub use lwr::csv_fit::{
    DegreeArg, FitArgs, FitError, FitReport, InputScale, KernelArg, Table, TargetError, TestReport, fit_report,
    fit_report_with,
};

/// Runs `swingup fit`: [`lwr::csv_fit::fit_command`], the phases on stderr
/// and the summary on stdout.
///
/// # Errors
/// A [`FitError`] for bad arguments or files, a model that cannot be
/// built, or `--out` that cannot be written.
pub fn fit_command(args: &FitArgs) -> Result<(), FitError> {
    lwr::csv_fit::fit_command(args)
}
