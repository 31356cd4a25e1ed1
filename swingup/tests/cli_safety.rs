//! The `swingup` program never loses what a user ran: a fresh learning run
//! or grid refuses a directory holding another one (and `--force` removes
//! only that run's files), a resume keeps the run's settings, and errors
//! print as one message without a backtrace.

use std::path::Path;
use std::process::{Command, Output};

use swingup::config::Config;
use swingup::output::rundir;

mod common;
use common::scratch;

fn swingup(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_swingup"))
        .args(args)
        .arg("--out")
        .arg(dir)
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("the swingup program runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_fresh_grid_never_empties_finished_runs() {
    let dir = scratch("cli-grid");
    let saved = "{\"not\": \"checked before the refusal\"}\n";
    std::fs::write(dir.path().join("runs.jsonl"), saved).expect("write");
    let o = swingup(&["experiments", "lambda", "--quick"], dir.path());
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("holds finished runs") && e.contains("--resume") && e.contains("--force"),
        "{e}"
    );
    assert!(!e.contains("stack backtrace") && !e.contains("Stack backtrace"), "{e}");
    assert_eq!(
        std::fs::read_to_string(dir.path().join("runs.jsonl")).expect("kept"),
        saved
    );
}

#[test]
fn a_resumed_grid_refuses_other_settings() {
    let dir = scratch("cli-grid-settings");
    let o = swingup(&["experiments", "lambda", "--quick", "--max-trials", "1"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let runs = std::fs::read_to_string(dir.path().join("runs.jsonl")).expect("runs");
    // resumed with the grid's default trial cap: refused, naming it; nothing runs
    let o = swingup(&["experiments", "lambda", "--quick", "--resume"], dir.path());
    assert!(!o.status.success());
    assert!(stderr(&o).contains("max_trials differs"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("runs.jsonl")).expect("runs"),
        runs
    );
    // with the same settings it resumes (and runs nothing new)
    let o = swingup(
        &["experiments", "lambda", "--quick", "--max-trials", "1", "--resume"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("runs.jsonl")).expect("runs"),
        runs
    );
}

#[test]
fn a_fresh_learning_run_never_overwrites_another() {
    let dir = scratch("cli-learn");
    let trial = "{\"a trial\": 3}";
    std::fs::write(dir.path().join("trial_03.json"), trial).expect("write");
    std::fs::write(dir.path().join("notes.txt"), "mine").expect("write");
    let o = swingup(&["learn", "--max-trials", "1"], dir.path());
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("holds another run") && e.contains("--force"), "{e}");
    assert_eq!(
        std::fs::read_to_string(dir.path().join("trial_03.json")).expect("kept"),
        trial
    );
    // --force deletes that run's files only, then runs
    let o = swingup(&["learn", "--max-trials", "1", "--force"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!dir.path().join("trial_03.json").exists());
    assert!(dir.path().join("trial_01.json").exists());
    assert_eq!(
        std::fs::read_to_string(dir.path().join("notes.txt")).expect("kept"),
        "mine"
    );
    // resuming keeps the saved settings: the cap may change, the seed not
    let o = swingup(&["learn", "--resume", "--seed", "5"], dir.path());
    assert!(!o.status.success());
    assert!(stderr(&o).contains("seed differs"), "{}", stderr(&o));
    let o = swingup(&["learn", "--resume", "--max-trials", "1"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A fresh run refuses a directory with another run's files, and with
/// `force` deletes those files and nothing else.
#[test]
fn prepare_fresh_refuses_another_run_and_force_deletes_its_files_only() {
    let dir = scratch("cli-fresh");
    rundir::prepare_fresh(dir.path(), false).expect("empty is fine");
    std::fs::write(dir.path().join("notes.txt"), "mine").expect("write");
    rundir::prepare_fresh(dir.path(), false).expect("other files are fine");
    for f in [
        "trial_03.json",
        "trial_03.csv",
        "report.md",
        "config.toml",
        "report.tmp",
    ] {
        std::fs::write(dir.path().join(f), "run").expect("write");
    }
    let e = rundir::prepare_fresh(dir.path(), false)
        .expect_err("a run is there")
        .to_string();
    assert!(
        e.contains("--resume") && e.contains("--force") && e.contains("5 of its files"),
        "{e}"
    );
    rundir::prepare_fresh(dir.path(), true).expect("force");
    assert!(rundir::run_files(dir.path()).is_empty());
    assert_eq!(
        std::fs::read_to_string(dir.path().join("notes.txt")).expect("kept"),
        "mine"
    );
}

/// Resuming starts from the saved configuration; changing the cap is
/// allowed, changing anything else is refused naming the keys; without
/// a saved configuration there is nothing to resume.
#[test]
fn resume_config_starts_from_the_saved_settings() {
    let dir = scratch("cli-resume");
    let e = rundir::resume_config(dir.path(), |_| {})
        .expect_err("no config")
        .to_string();
    assert!(e.contains("config.toml") && e.contains("fresh run"), "{e}");
    let mut saved = Config {
        seed: 3,
        max_trials: 2,
        ..Config::default()
    };
    saved.planner.lambda = 100.0;
    std::fs::write(dir.path().join("config.toml"), toml::to_string(&saved).expect("toml")).expect("write");
    // without the manifest recording the settings the run was made with,
    // an edited config.toml could not be caught: refused (issue 51)
    let e = rundir::resume_config(dir.path(), |_| {})
        .expect_err("no manifest")
        .to_string();
    assert!(e.contains("manifest.json is missing"), "{e}");
    rundir::create_manifest(dir.path(), "pendulum", &saved).expect("manifest");
    let cfg = rundir::resume_config(dir.path(), |c| c.max_trials = 3).expect("cap may change");
    assert_eq!((cfg.seed, cfg.max_trials, cfg.planner.lambda), (3, 3, 100.0));
    let e = rundir::resume_config(dir.path(), |c| {
        c.seed = 1;
        c.planner.lambda = 1e3;
    })
    .expect_err("seed and lambda changed")
    .to_string();
    assert!(e.contains("planner.lambda, seed differ"), "{e}");
    assert_eq!(rundir::config_differences(&saved, &saved, false), Vec::<String>::new());
}

/// A second program in a directory another one is working in is refused
/// before it writes anything; once the first is gone, it runs.
#[test]
fn a_second_program_in_a_busy_directory_is_refused() {
    let dir = scratch("cli-lock");
    let held = rundir::lock_dir(dir.path(), rundir::LOCK_FILE).expect("lock");
    let o = swingup(&["learn", "--model", "true", "--max-trials", "1"], dir.path());
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("another swingup program is working in"), "{e}");
    assert!(
        rundir::run_files(dir.path()).is_empty(),
        "wrote {:?}",
        rundir::run_files(dir.path())
    );
    // a grid in the same directory has a lock of its own per runs file
    let grid = rundir::lock_dir(dir.path(), ".runs.jsonl.lock").expect("grid lock");
    let o = swingup(&["experiments", "lambda", "--quick"], dir.path());
    assert!(stderr(&o).contains("another swingup program"), "{}", stderr(&o));
    assert!(!dir.path().join("runs.jsonl").exists());
    drop((held, grid));
    let o = swingup(&["learn", "--model", "true", "--max-trials", "1"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.path().join("trial_01.json").exists());
}

/// A trial that cannot be saved (a full disk, injected through the
/// storage layer's fault hook) stops the run at once, with an error naming
/// the file, and leaves no temporary file behind.
#[test]
fn a_run_that_cannot_save_stops_at_once_and_names_the_file() {
    let dir = scratch("cli-full");
    let o = Command::new(env!("CARGO_BIN_EXE_swingup"))
        .args(["learn", "--model", "true", "--max-trials", "3", "--out"])
        .arg(dir.path())
        .env("NPRL_STORE_FAULT", "op=write,persist,path=trial_01.csv")
        .output()
        .expect("the swingup program runs");
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("trial_01.csv") && e.contains("saving trial 1"), "{e}");
    assert!(e.contains("the run stopped there"), "{e}");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(!out.contains("trial  2:"), "ran on after the failed save:\n{out}");
    let left: Vec<String> = std::fs::read_dir(dir.path())
        .expect("dir")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| store::is_temporary(n))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
    assert!(!dir.path().join("trial_01.csv").exists());
}

/// A learning run shows each trial's long phases as they start, so a slow
/// planner (Powell's takes minutes) never runs without a line.
#[test]
fn a_learning_run_shows_its_phases() {
    let dir = scratch("cli-phases");
    let o = swingup(&["learn", "--model", "lwr", "--max-trials", "2"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let learning = out.find("trial  2: learning the model from 330 samples ...");
    let planning = out.find("trial  2: planning (gaussnewton, bspline basis) ...");
    let done = out.find("trial  2: max angle");
    assert!(learning.is_some() && planning.is_some() && done.is_some(), "{out}");
    assert!(learning < planning && planning < done, "{out}");
}

/// `--prior` reaches the pure LWR: the run's saved settings name it, and
/// over the control-affine prior the model of the imitation trial learns
/// the swing-up under MPC at the first planned trial (seed 1).
#[test]
fn the_prior_option_reaches_the_model() {
    let dir = scratch("cli-prior");
    let o = swingup(
        &[
            "learn",
            "--model",
            "lwr",
            "--prior",
            "control-affine",
            "--controller",
            "mpc",
            "--max-trials",
            "2",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let saved: Config =
        toml::from_str(&std::fs::read_to_string(dir.path().join("config.toml")).expect("config.toml")).expect("toml");
    assert_eq!(saved.model.prior, swingup::config::LwrPrior::ControlAffine);
    assert_eq!(saved.model.kind, swingup::config::ModelKind::Lwr);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("success at trial 2"), "{out}");
}

#[test]
fn a_prior_for_a_model_without_one_is_refused_before_any_work() {
    let dir = scratch("cli-prior-refused");
    let o = swingup(&["learn", "--model", "true", "--prior", "control-affine"], dir.path());
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("model.prior") && e.contains("pure LWR"), "{e}");
    assert!(
        rundir::run_files(dir.path()).is_empty(),
        "a refused run wrote {:?}",
        rundir::run_files(dir.path())
    );
}
