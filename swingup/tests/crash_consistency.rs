//! Crash consistency of a grid's directory, in the style of the storage
//! engines' own tests: a tiny grid (the lambda sweep, 1 seed, 1 trial: 3
//! runs) run with an injected failure at each write, sync and rename of
//! its directory in turn (once, as a full disk; and from then on with the
//! write cut in half, as a kill), then resumed. After each, every finished
//! run is kept exactly once, no record mixes settings, no torn record or
//! temporary file is left, and the report equals an uninterrupted run's.
//!
//! A learning run likewise, through the program's fault hook
//! (`NPRL_STORE_FAULT`). The plans are limited to each test's own
//! directory, so the tests run beside the others.

use std::path::Path;

use store::{FaultPlan, OpKind};
use swingup::experiments::{Experiment, ExperimentSettings, ExperimentsReport, RunSummary};
use swingup::output::grid::{GridEvent, GridMode, GridOptions, run_grid};

mod common;
use common::scratch;

/// The smallest grid ([`common::smallest_grid`]).
fn settings() -> ExperimentSettings {
    common::smallest_grid()
}

fn options(dir: &Path, mode: GridMode) -> GridOptions {
    GridOptions {
        which: vec![Experiment::Lambda],
        settings: settings(),
        out: dir.to_path_buf(),
        mode,
        shard: None,
        variants: vec![],
    }
}

fn quiet(_: GridEvent<'_>) {}

/// The report without what depends on the clock.
fn timeless(report: &ExperimentsReport) -> (Vec<RunSummary>, String, String) {
    let runs = report
        .runs
        .iter()
        .map(|r| RunSummary {
            seconds: 0.0,
            ..r.clone()
        })
        .collect();
    (runs, format!("{:?}", report.variants), format!("{:?}", report.claims))
}

/// The invariants of a grid's directory after it completed: the runs file
/// holds each run of the grid exactly once, made with the grid's settings,
/// whole; no temporary file is left.
fn check_directory(dir: &Path, context: &str) {
    let contents = store::read_log::<RunSummary>(&dir.join("runs.jsonl")).expect("runs file");
    assert!(contents.torn.is_none(), "{context}: torn record left");
    let mut keys: Vec<_> = contents
        .records
        .iter()
        .map(|r| (r.experiment.clone(), r.variant.clone(), r.seed))
        .collect();
    keys.sort();
    let n = keys.len();
    keys.dedup();
    assert_eq!(keys.len(), n, "{context}: a run saved twice");
    assert_eq!(n, 3, "{context}: runs kept {keys:?}");
    let digest = settings().digest();
    assert!(
        contents.records.iter().all(|r| r.settings_digest == digest),
        "{context}: a record made with other settings"
    );
    for entry in std::fs::read_dir(dir).expect("dir") {
        let name = entry.expect("entry").file_name().to_string_lossy().into_owned();
        assert!(!store::is_temporary(&name), "{context}: temporary file {name} left");
    }
}

/// Runs the grid under `plan(n)` for n = 1, 2, ... until it completes
/// without a fault, each time resuming afterwards; returns the number of
/// faults tried.
fn every_fault(tag: &str, baseline: &ExperimentsReport, plan: impl Fn(u64, &Path) -> FaultPlan) -> u64 {
    for n in 1.. {
        let dir = scratch(&format!("crash-{tag}-{n}"));
        let guard = store::fault::install(plan(n, dir.path()));
        let first = run_grid(&options(dir.path(), GridMode::Fresh { force: false }), &quiet);
        let fired = guard.fired();
        drop(guard);
        let context = format!("{tag}: fault at operation {n}");
        if fired == 0 {
            let report = first.unwrap_or_else(|e| panic!("{context}: no fault, yet {e}"));
            assert_eq!(timeless(&report), timeless(baseline), "{context}");
            check_directory(dir.path(), &context);
            return n - 1;
        }
        let e = format!(
            "{:#}",
            anyhow::Error::from(first.expect_err("an injected failure is an error"))
        );
        assert!(
            e.contains(&dir.path().display().to_string()),
            "{context}: the error names no file: {e}"
        );
        let resumed = run_grid(&options(dir.path(), GridMode::Resume), &quiet)
            .unwrap_or_else(|e| panic!("{context}: resume: {e}"));
        assert_eq!(timeless(&resumed), timeless(baseline), "{context}");
        check_directory(dir.path(), &context);
    }
    unreachable!()
}

#[test]
fn a_grid_survives_a_failure_at_every_write_sync_and_rename() {
    let base = scratch("crash-baseline");
    let baseline = run_grid(&options(base.path(), GridMode::Fresh { force: false }), &quiet).expect("baseline grid");
    check_directory(base.path(), "baseline");
    let kinds = [OpKind::Write, OpKind::Sync, OpKind::Rename];
    // a full disk, once
    let once = every_fault("once", &baseline, |n, dir| FaultPlan::fail_nth(n, &kinds).under(dir));
    assert!(once > 20, "only {once} operations counted");
    // a kill: the write cut in half, nothing written after it
    let kill_kinds = [OpKind::Write, OpKind::Sync, OpKind::Rename, OpKind::Truncate];
    let killed = every_fault("kill", &baseline, |n, dir| {
        FaultPlan::fail_nth(n, &kill_kinds).under(dir).persist().torn()
    });
    assert!(killed >= once, "{killed} < {once}");
}

/// Issue 37, case 2: a full disk during a grid stops it at the first run
/// that cannot be saved, naming the runs file; the runs saved before it
/// are kept, and a resume completes the grid.
#[test]
fn a_full_disk_stops_the_grid_at_once_naming_the_file() {
    let dir = scratch("crash-full-disk");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool");
    let saved = std::sync::atomic::AtomicUsize::new(0);
    let show = |e: GridEvent<'_>| {
        if let GridEvent::Saved(..) = e {
            saved.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        }
    };
    let guard = store::fault::install(
        FaultPlan::fail_nth(2, &[OpKind::Write])
            .under(&dir.path().join("runs.jsonl"))
            .persist(),
    );
    let result = pool.install(|| run_grid(&options(dir.path(), GridMode::Fresh { force: false }), &show));
    drop(guard);
    let e = format!("{:#}", anyhow::Error::from(result.expect_err("the disk is full")));
    assert!(e.contains("runs.jsonl") && e.contains("the grid stopped there"), "{e}");
    assert_eq!(
        saved.load(std::sync::atomic::Ordering::SeqCst),
        1,
        "ran on after the failed save"
    );
    let contents = store::read_log::<RunSummary>(&dir.path().join("runs.jsonl")).expect("runs");
    assert_eq!((contents.records.len(), contents.torn.is_none()), (1, true));
    assert!(
        !dir.path().join("experiments.json").exists(),
        "a report of a failed grid"
    );
    let report = run_grid(&options(dir.path(), GridMode::Resume), &quiet).expect("resume");
    assert_eq!(report.runs.len(), 3);
    check_directory(dir.path(), "after the full disk");
}

/// The trials of a learning run's report, without what depends on the clock.
fn trials_of(dir: &Path) -> Vec<(Vec<[f64; 4]>, Vec<f64>, bool)> {
    let text = std::fs::read_to_string(dir.join("report.json")).expect("report.json");
    let run: swingup::record::RunRecord = serde_json::from_str(&text).expect("a run record");
    run.trials
        .into_iter()
        .map(|t| (t.states, t.commands, t.success))
        .collect()
}

/// A learning run (the true model, two trials) under a failure at each
/// write and rename of its directory in turn (syncs left out to keep the
/// test short: the grid's test covers them), through the program's fault
/// hook; then resumed (or, when the failure came before its
/// configuration was saved, started over with `--force`). Its trials equal
/// an uninterrupted run's, and no temporary file is left.
#[test]
fn a_learning_run_survives_a_failure_at_every_write_and_rename() {
    let learn = |dir: &Path, extra: &[&str], fault: Option<String>| {
        let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_swingup"));
        c.args(["learn", "--model", "true", "--max-trials", "2"])
            .args(extra)
            .arg("--out")
            .arg(dir);
        if let Some(f) = fault {
            c.env("NPRL_STORE_FAULT", f);
        }
        c.output().expect("the swingup program runs")
    };
    let base = scratch("crash-learn-baseline");
    assert!(learn(base.path(), &[], None).status.success());
    let baseline = trials_of(base.path());
    assert_eq!(baseline.len(), 2);
    for n in 1.. {
        let dir = scratch(&format!("crash-learn-{n}"));
        let plan = format!("op=write+rename,nth={n},path={}", dir.path().display());
        let first = learn(dir.path(), &[], Some(plan));
        let context = format!("learn: fault at operation {n}");
        if first.status.success() {
            assert_eq!(trials_of(dir.path()), baseline, "{context}");
            assert!(n > 20, "only {n} operations counted");
            break;
        }
        let e = String::from_utf8_lossy(&first.stderr).into_owned();
        assert!(
            e.contains("injected fault") && !e.contains("panicked"),
            "{context}: {e}"
        );
        let again = if dir.path().join("config.toml").exists() {
            learn(dir.path(), &["--resume"], None)
        } else {
            learn(dir.path(), &["--force"], None)
        };
        assert!(
            again.status.success(),
            "{context}: {}",
            String::from_utf8_lossy(&again.stderr)
        );
        assert_eq!(trials_of(dir.path()), baseline, "{context}");
        for entry in std::fs::read_dir(dir.path()).expect("dir") {
            let name = entry.expect("entry").file_name().to_string_lossy().into_owned();
            assert!(!store::is_temporary(&name), "{context}: temporary file {name} left");
        }
    }
}
