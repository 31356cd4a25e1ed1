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
        sentinel.assert_unchanged(&before, format_args!("{name} -> {}", target.display()));
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
        sentinel.assert_unchanged(&before, format_args!("{name}"));
    }
}

/// A directory under a grid's runs file's name is named as one (it was
/// said to "hold finished runs"), with and without `--force`.
#[test]
fn a_directory_named_like_a_runs_file_is_named_as_a_directory() {
    let dir = scratch("swingup-runs-dir");
    std::fs::create_dir(dir.path().join("runs.jsonl")).expect("mkdir");
    for force in [false, true] {
        let mut args = vec!["experiments", "lambda", "--quick", "--out", path_str(dir.path())];
        if force {
            args.push("--force");
        }
        let o = swingup(&args);
        assert_no_panic(&o);
        assert!(!o.status.success());
        assert!(stderr(&o).contains("is a directory"), "{}", stderr(&o));
        assert!(!stderr(&o).contains("holds finished runs"), "{}", stderr(&o));
        assert!(dir.path().join("runs.jsonl").is_dir());
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
        ("planner", "state_weights", "[1e300, 1, 1, 1]"),
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
    sentinel.assert_unchanged(&before, "the run");
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

/// Small cart-pole settings (every trial run; about a second for six
/// trials in the test build, so that kills land inside trials), as a
/// `--cartpole-settings` file.
const QUICK_CARTPOLE: &str = r#"{"episode": 4.0, "success_hold": 0.5, "window": 15, "state_coeffs": 10,
  "control_coeffs": 8, "replan_iterations": 5, "cold_iterations": 5, "model": {"tune_evals": 40},
  "stop_at_success": false}"#;

/// Each `trial_NN.json` of `dir` as (trial, success, states, forces), in order.
fn cartpole_trials(dir: &Path) -> Vec<(u64, bool, String, String)> {
    (1..)
        .map(|i| dir.join(format!("trial_{i:02}.json")))
        .take_while(|p| p.exists())
        .map(|p| {
            let v: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&p).expect("trial")).expect("json");
            (
                v["trial"].as_u64().expect("trial"),
                v["success"].as_bool().expect("success"),
                v["states"].to_string(),
                v["forces"].to_string(),
            )
        })
        .collect()
}

/// A cart-pole run killed (SIGKILL) at moments across its life keeps every
/// trial it finished, and `--resume` ends it with the trials of the
/// uninterrupted run; nothing but its own files is left in the directory.
#[cfg(unix)]
#[test]
fn the_cartpole_killed_at_any_moment_resumes_to_the_uninterrupted_run() {
    let dir = scratch("cartpole-kill");
    let settings = dir.path().join("quick.json");
    std::fs::write(&settings, QUICK_CARTPOLE).expect("settings");
    let args = |out: &Path| {
        vec![
            "learn".to_string(),
            "--task".into(),
            "cartpole".into(),
            "--max-trials".into(),
            "5".into(),
            "--seed".into(),
            "5".into(),
            "--cartpole-settings".into(),
            path_str(&settings).into(),
            "--out".into(),
            path_str(out).into(),
        ]
    };
    let reference = dir.path().join("reference");
    let started = std::time::Instant::now();
    let o = swingup(&args(&reference).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    let took = started.elapsed();
    let want = cartpole_trials(&reference);
    assert_eq!(want.len(), 6, "a random trial and 5 MPC trials");
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("trial  6: mpc"),
        "a progress line per trial"
    );
    for (k, fraction) in [0.05, 0.3, 0.5, 0.7, 0.9].into_iter().enumerate() {
        let out = dir.path().join(format!("killed-{k}"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_swingup"))
            .args(args(&out))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("spawn");
        std::thread::sleep(took.mul_f64(fraction));
        let _ = child.kill();
        let _ = child.wait();
        // every trial saved so far is one of the uninterrupted run's
        let kept = cartpole_trials(&out);
        assert_eq!(kept[..], want[..kept.len()], "after {fraction} of the run");
        if !out.join("manifest.json").exists() {
            // killed before the run recorded its settings: nothing saved,
            // the resume says so, and a fresh run is the way on
            assert!(kept.is_empty());
            let o = swingup(&["learn", "--task", "cartpole", "--resume", "--out", path_str(&out)]);
            assert!(stderr(&o).contains("has no"), "{}", stderr(&o));
            let o = swingup(
                &[
                    &args(&out).iter().map(String::as_str).collect::<Vec<_>>()[..],
                    &["--force"],
                ]
                .concat(),
            );
            assert!(o.status.success(), "{}", stderr(&o));
            assert_eq!(cartpole_trials(&out), want);
            continue;
        }
        let o = swingup(&["learn", "--task", "cartpole", "--resume", "--out", path_str(&out)]);
        assert!(o.status.success(), "after {fraction} of the run: {}", stderr(&o));
        assert_eq!(cartpole_trials(&out), want, "resumed after {fraction} of the run");
        assert!(out.join("cartpole.json").is_file());
        let names: Vec<String> = std::fs::read_dir(&out)
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        assert!(!names.iter().any(|n| store::is_temporary(n)), "{names:?}");
    }
    // a resume with another seed is refused, naming it
    let o = swingup(&[
        "learn",
        "--task",
        "cartpole",
        "--resume",
        "--seed",
        "6",
        "--out",
        path_str(&reference),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("seed 5, not 6"), "{}", stderr(&o));
}

/// Issue 51: a 200 KB line of a configuration file is not echoed whole.
#[test]
fn a_huge_configuration_line_is_echoed_cut() {
    let dir = scratch("swingup-huge-line");
    let config = dir.path().join("config.toml");
    std::fs::write(&config, format!("seed = \"{}\n", "9".repeat(200_000))).expect("config");
    let o = swingup(&[
        "learn",
        "--config",
        path_str(&config),
        "--out",
        path_str(&dir.path().join("run")),
    ]);
    assert_no_panic(&o);
    assert!(!o.status.success());
    assert!(stderr(&o).len() < 2000, "{} bytes of stderr", stderr(&o).len());
    assert!(stderr(&o).contains("config.toml"), "{}", stderr(&o));
}

/// A full disk (a small tmpfs as `--out`, as root): the run stops at the
/// first file it cannot save, naming it, with no temporary file left and
/// no panic; the trials saved before it are whole.
#[test]
fn a_full_disk_stops_the_run_naming_the_file() {
    let Some(disk) = store::SmallDisk::mount("swingup-full-disk", 96 * 1024) else {
        return; // not root here: no tmpfs to fill
    };
    let o = swingup(&[
        "learn",
        "--model",
        "true",
        "--max-trials",
        "3",
        "--out",
        path_str(disk.path()),
    ]);
    assert_no_panic(&o);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains(&disk.path().display().to_string()),
        "{}",
        stderr(&o)
    );
    let names: Vec<String> = std::fs::read_dir(disk.path())
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!names.iter().any(|n| store::is_temporary(n)), "{names:?}");
    for n in names.iter().filter(|n| n.starts_with("trial_") && n.ends_with(".json")) {
        let text = std::fs::read_to_string(disk.path().join(n)).expect("trial");
        serde_json::from_str::<serde_json::Value>(&text).unwrap_or_else(|e| panic!("{n} is not whole: {e}"));
    }
}

/// A closed standard output (`| head -0`) ends `config` and `fit` with
/// status 1 and a message, without a panic (`learn` and `experiments`:
/// `issue37.rs`, case 6); every subcommand's status is decided in `main`.
#[cfg(unix)]
#[test]
fn a_closed_stdout_fails_every_subcommand_after_its_work() {
    let dir = scratch("swingup-closed");
    let train = dir.path().join("train.csv");
    let mut text = String::from("a,y\n");
    for i in 0..40 {
        let a = f64::from(i) / 40.0;
        text.push_str(&format!("{a},{}\n", (3.0 * a).sin()));
    }
    std::fs::write(&train, text).expect("train");
    for args in [
        vec!["config"],
        vec!["fit", "--train", path_str(&train), "--target", "y", "--tune-evals", "0"],
    ] {
        // a pipe whose reader is gone before the program starts
        let (reader, writer) = std::io::pipe().expect("pipe");
        drop(reader);
        let o = Command::new(env!("CARGO_BIN_EXE_swingup"))
            .args(&args)
            .stdout(writer)
            .stderr(std::process::Stdio::piped())
            .output()
            .expect("run");
        assert_no_panic(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("standard output"), "{args:?}: {}", stderr(&o));
    }
}

/// The help a person reads (issue 50, item 7): no rustdoc link syntax, no
/// LaTeX, no internal issue numbers, in the program's help and every
/// subcommand's; `--version` names the commit.
#[test]
fn help_is_plain_text_and_the_version_names_the_commit() {
    for sub in [
        None,
        Some("learn"),
        Some("config"),
        Some("experiments"),
        Some("fit"),
        Some("sensitivity"),
        Some("basin"),
    ] {
        let mut args: Vec<&str> = sub.into_iter().collect();
        args.push("--help");
        let o = swingup(&args);
        assert!(o.status.success(), "{args:?}");
        let help = String::from_utf8_lossy(&o.stdout);
        for bad in ["[`", "`]", "$", "issue 3", "issue 4", "issue 5", "crate::"] {
            assert!(!help.contains(bad), "{args:?} --help holds {bad:?}:\n{help}");
        }
    }
    let o = swingup(&["--version"]);
    let v = String::from_utf8_lossy(&o.stdout);
    assert!(v.contains("commit") && v.starts_with("swingup 0."), "{v}");
}
