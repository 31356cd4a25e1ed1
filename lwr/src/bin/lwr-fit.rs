//! `lwr-fit`: fit a locally weighted regression model to a CSV file, tune
//! its metric by leave-one-out cross-validation, report the tuned scale of
//! each input and, with a test file, the test error and predictions (see
//! [`lwr::csv_fit`]).
//!
//! ```text
//! cargo run -p lwr --features cli --bin lwr-fit -- --train train.csv --target y
//! ```
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::process::ExitCode;

use clap::Parser;
use lwr::csv_fit::{FitArgs, error_chain, fit_command};

/// Fit a locally weighted regression model to a CSV file: tune its metric
/// by leave-one-out cross-validation, report the tuned scale of each input
/// and, with a test file, the test error and predictions.
#[derive(Debug, Parser)]
#[command(name = "lwr-fit", version = store::program_version(env!("CARGO_PKG_VERSION")))]
struct Cli {
    #[command(flatten)]
    fit: FitArgs,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match fit_command(&cli.fit) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            use std::io::Write as _;
            let _ = writeln!(std::io::stderr(), "error: {}", error_chain(&e));
            ExitCode::FAILURE
        }
    }
}
