//! Issue 51, attacked from outside on the `swingup` binary: links to a
//! file, a device and a directory planted among a run's files (with and
//! without `--force`), a dangling `--out`, FIFOs, huge numbers in budgets
//! and weights, `swingup config` into a link or a full disk, and the
//! cart-pole killed and resumed. Each case checks that a sentinel tree
//! outside `--out` ([`store::Sentinel`]) did not change.

use std::path::Path;
use std::process::{Command, Output};
use std::time::Duration;

use store::{Sentinel, output_within};

mod common;
use common::scratch;

fn swingup(args: &[&str]) -> Output {
    let (o, in_time) = output_within(
        Command::new(env!("CARGO_BIN_EXE_swingup")).args(args),
        Duration::from_secs(600),
    )
    .expect("swingup runs");
    assert!(in_time, "swingup {args:?} did not finish in 600 s (blocked?)");
    o
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn assert_no_panic(o: &Output) {
    assert!(!stderr(o).contains("panicked"), "{}", stderr(o));
    assert!(o.status.code().is_some(), "killed by a signal: {:?}", o.status);
}

fn path_str(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// The targets a test plants links to: a file, a directory and (as root)
/// two devices, all in the sentinel tree.
fn targets(sentinel: &Sentinel) -> Vec<std::path::PathBuf> {
    let mut t = vec![sentinel.victim(), sentinel.path().join("dir")];
    if let Some((null, full)) = sentinel.devices() {
        t.extend([null, full]);
    }
    t
}

#[cfg(unix)]
#[test]
fn links_among_a_runs_files_are_refused_and_force_deletes_them_never_their_targets() {
    let sentinel = Sentinel::new("swingup-sentinel").expect("sentinel");
    let before = sentinel.snapshot();
    let names = ["trial_01.json", "report.md", "figure3.svg", "manifest.json"];
    for (name, target) in names.iter().zip(targets(&sentinel).iter().cycle()) {
        let dir = scratch("swingup-link");
        let link = dir.path().join(name);
        std::os::unix::fs::symlink(target, &link).expect("plant a link");
        let args = [
            "learn",
            "--model",
            "true",
            "--max-trials",
            "1",
            "--out",
            path_str(dir.path()),
        ];
        let o = swingup(&args);
        assert_no_panic(&o);
        assert!(!o.status.success(), "{name}: ran over a planted link");
        assert!(stderr(&o).contains("holds another run"), "{}", stderr(&o));
        assert!(std::fs::symlink_metadata(&link).expect("kept").file_type().is_symlink());
        let o = swingup(&[&args[..], &["--force"]].concat());
        assert!(o.status.success(), "{name} -> {}: {}", target.display(), stderr(&o));
        // the link itself was deleted, and the run wrote a regular file
        let m = std::fs::symlink_metadata(dir.path().join(name)).expect("written");
        assert!(m.is_file(), "{name} is not a regular file");
        assert_eq!(
            sentinel.changes(&before),
            Vec::<String>::new(),
            "{name} -> {}",
            target.display()
        );
    }
}

#[cfg(unix)]
#[test]
fn a_grids_planted_links_are_refused_and_force_deletes_them() {
    let sentinel = Sentinel::new("swingup-grid-sentinel").expect("sentinel");
    let before = sentinel.snapshot();
    for name in ["runs.jsonl", "experiments.md"] {
        let dir = scratch("swingup-grid-link");
        let link = dir.path().join(name);
        std::os::unix::fs::symlink(sentinel.victim(), &link).expect("plant a link");
        let args = [
            "experiments",
            "lambda",
            "--quick",
            "--max-trials",
            "1",
            "--out",
            path_str(dir.path()),
        ];
        let o = swingup(&args);
        assert_no_panic(&o);
        assert!(!o.status.success(), "{name}: wrote through a link");
        assert!(stderr(&o).contains("symbolic link"), "{}", stderr(&o));
        assert!(
            !dir.path().join("settings.json").exists(),
            "{name}: wrote before refusing"
        );
        let o = swingup(&[&args[..], &["--force"]].concat());
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert!(std::fs::symlink_metadata(&link).expect("written").is_file());
        assert_eq!(sentinel.changes(&before), Vec::<String>::new(), "{name}");
    }
}

#[cfg(unix)]
#[test]
fn a_dangling_out_link_and_a_fifo_are_named_and_nothing_blocks() {
    let dir = scratch("swingup-dangling");
    let out = dir.path().join("out");
    std::os::unix::fs::symlink(dir.path().join("missing"), &out).expect("link");
    let o = swingup(&["learn", "--model", "true", "--max-trials", "1", "--out", path_str(&out)]);
    assert_no_panic(&o);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("does not exist"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("File exists"), "{}", stderr(&o));
    assert!(!dir.path().join("missing").exists(), "created through the link");

    let run = scratch("swingup-fifo");
    let fifo = run.path().join("trial_01.json");
    if !Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
        return;
    }
    let args = [
        "learn",
        "--model",
        "true",
        "--max-trials",
        "1",
        "--out",
        path_str(run.path()),
    ];
    for force in [false, true] {
        let o = swingup(&[&args[..], if force { &["--force"][..] } else { &[][..] }].concat());
        assert_no_panic(&o);
        assert!(!o.status.success(), "force {force}: ran over a FIFO");
        assert!(
            stderr(&o).contains("FIFO") || stderr(&o).contains("holds another run"),
            "{}",
            stderr(&o)
        );
        assert!(!std::fs::symlink_metadata(&fifo).expect("kept").is_file());
    }
}

#[test]
fn huge_numbers_in_budgets_and_weights_are_refused_by_key_before_anything_is_written() {
    let dir = scratch("swingup-numbers");
    for (section, key, value) in [
        ("mpc", "budget_ms", "1e300"),
        ("mpc", "budget_ms", "1e12"),
        ("planner", "lambda", "1e308"),
        ("planner", "control_weight", "1e200"),
        ("planner", "state_weights", "[1e300, 1, 1]"),
        ("planner", "lambda_growth", "1e30"),
        ("model", "bandwidth", "1e300"),
    ] {
        let config = dir.path().join("config.toml");
        std::fs::write(&config, format!("[{section}]\n{key} = {value}\n")).expect("config");
        let out = dir.path().join("run");
        let o = swingup(&[
            "learn",
            "--config",
            path_str(&config),
            "--max-trials",
            "1",
            "--out",
            path_str(&out),
        ]);
        assert_no_panic(&o);
        assert!(!o.status.success(), "{section}.{key} = {value} accepted");
        assert!(
            stderr(&o).contains(&format!("{section}.{key}")),
            "{section}.{key}: {}",
            stderr(&o)
        );
        assert!(!out.join("trial_01.json").exists(), "{section}.{key}: a trial ran");
    }
    let out = dir.path().join("flag");
    let o = swingup(&["learn", "--lambda", "1e308", "--out", path_str(&out)]);
    assert_no_panic(&o);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("planner.lambda"), "{}", stderr(&o));
}

#[cfg(unix)]
#[test]
fn config_goes_to_a_file_whole_never_through_a_link_and_a_full_stdout_fails() {
    let sentinel = Sentinel::new("swingup-config-sentinel").expect("sentinel");
    let before = sentinel.snapshot();
    let dir = scratch("swingup-config");
    let file = dir.path().join("my.toml");
    let o = swingup(&["config", "--out", path_str(&file)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&file).expect("written");
    let parsed: swingup::config::Config = toml::from_str(&text).expect("a configuration");
    assert_eq!(parsed, swingup::config::Config::default());
    let link = dir.path().join("link.toml");
    std::os::unix::fs::symlink(sentinel.victim(), &link).expect("link");
    let o = swingup(&["config", "--out", path_str(&link)]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("symbolic link"), "{}", stderr(&o));
    assert_eq!(sentinel.changes(&before), Vec::<String>::new());
    if let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") {
        let o = Command::new(env!("CARGO_BIN_EXE_swingup"))
            .arg("config")
            .stdout(full)
            .stderr(std::process::Stdio::piped())
            .output()
            .expect("run");
        assert_no_panic(&o);
        assert_eq!(o.status.code(), Some(1), "config > /dev/full exited 0");
        assert!(stderr(&o).contains("standard output"), "{}", stderr(&o));
    }
}
