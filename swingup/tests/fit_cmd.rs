//! `swingup fit` is the CSV fit tool of `lwr::csv_fit` (tested there, in
//! `lwr/tests/csv_fit.rs`): the subcommand parses the tool's options and
//! prints the tool's summary, and its errors are the tool's typed ones.

use std::path::PathBuf;
use std::process::Command;

use swingup::fit_cmd::{FitArgs, FitError, fit_report};

fn demo_csv() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../lwr/tests/data/fit_demo.csv")
}

#[test]
fn swingup_fit_prints_the_tools_summary() {
    let train = demo_csv();
    let out = Command::new(env!("CARGO_BIN_EXE_swingup"))
        .args(["fit", "--train"])
        .arg(&train)
        .args(["--target", "y", "--tune-evals", "20"])
        .output()
        .expect("runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mut args = FitArgs::new(&train, &["y"]);
    args.tune_evals = 20;
    let report = fit_report(&args).expect("fit");
    assert_eq!(String::from_utf8_lossy(&out.stdout), report.to_string());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("tuning the metric: up to 20 leave-one-out evaluations over 200 of 200 rows, each about"),
        "{stderr}"
    );
}

#[test]
fn swingup_fit_reports_the_tools_errors() {
    let missing = FitArgs::new(demo_csv(), &["nope"]);
    assert!(matches!(fit_report(&missing), Err(FitError::MissingColumn { .. })));
    let out = Command::new(env!("CARGO_BIN_EXE_swingup"))
        .args(["fit", "--train"])
        .arg(demo_csv())
        .args(["--target", "nope"])
        .output()
        .expect("runs");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("fit_demo.csv: header (line 1): no column 'nope' (target)"),
        "{stderr}"
    );
    // --out needs --test, as in lwr-fit
    let out = Command::new(env!("CARGO_BIN_EXE_swingup"))
        .args(["fit", "--train", "t.csv", "--target", "y", "--out", "p.csv"])
        .output()
        .expect("runs");
    assert!(!out.status.success());
}
