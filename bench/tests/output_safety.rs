//! Issue 51, attacked from outside on the `nprl-bench` binary: nothing
//! outside `--out` is touched (links to a file, a device and a directory
//! planted among its files, device and FIFO targets), nothing inside is
//! lost (subset and empty runs, two concurrent writers, kill -9 at random
//! moments), and no number or closed pipe makes it panic. Each case checks
//! a sentinel tree outside `--out` ([`store::Sentinel`]) for changes.

use std::path::Path;
use std::process::{Command, Output};
use std::time::Duration;

use store::{ScratchDir, Sentinel, output_within};

/// A quick run: two problems (Rosenbrock and Powell's badly scaled one),
/// two solvers, one timing.
const QUICK: [&str; 8] = [
    "--filter",
    "rosenbrock",
    "--solvers",
    "gauss-newton,powell",
    "--repeats",
    "1",
    "--budget",
    "200",
];

fn bench(args: &[&str], out: &Path) -> Output {
    let (o, in_time) = output_within(
        Command::new(env!("CARGO_BIN_EXE_nprl-bench"))
            .args(args)
            .arg("--out")
            .arg(out),
        Duration::from_secs(300),
    )
    .expect("nprl-bench runs");
    assert!(in_time, "nprl-bench {args:?} did not finish in 300 s (blocked?)");
    o
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn assert_no_panic(o: &Output) {
    assert!(!stderr(o).contains("panicked"), "{}", stderr(o));
    assert!(o.status.code().is_some(), "killed by a signal: {:?}", o.status);
}

/// The runs of `out/runs.json` as (problem, scale, solver, f), sorted.
fn runs(out: &Path) -> Vec<(String, String, String, String)> {
    let file = bench::record::RecordFile::load(&out.join("runs.json")).expect("runs.json");
    let mut v: Vec<_> = file
        .runs
        .iter()
        .map(|r| {
            (
                r.problem.clone(),
                format!("{}", r.scale),
                r.solver.clone(),
                format!("{:e}", r.f),
            )
        })
        .collect();
    v.sort();
    v
}

/// Rows of `out/table.csv` (the header left out).
fn table_rows(out: &Path) -> usize {
    std::fs::read_to_string(out.join("table.csv"))
        .expect("table")
        .lines()
        .count()
        - 1
}

#[cfg(unix)]
#[test]
fn links_planted_in_out_are_refused_before_any_run_and_nothing_outside_changes() {
    let sentinel = Sentinel::new("bench-sentinel").expect("sentinel");
    let before = sentinel.snapshot();
    let mut targets = vec![sentinel.victim(), sentinel.path().join("dir")];
    if let Some((null, full)) = sentinel.devices() {
        targets.extend([null, full]);
    }
    for name in [
        "runs.json",
        "table.csv",
        "profiles.json",
        "benchmarks.md",
        "perf_evals_tau1e-3.svg",
    ] {
        for target in &targets {
            let out = ScratchDir::new("bench-link").expect("scratch");
            let link = out.path().join(name);
            std::os::unix::fs::symlink(target, &link).expect("plant a link");
            for force in [false, true] {
                let mut args = QUICK.to_vec();
                if force {
                    args.push("--force");
                }
                let o = bench(&args, out.path());
                assert_no_panic(&o);
                assert!(
                    !o.status.success(),
                    "{name} -> {}: wrote through the link",
                    target.display()
                );
                assert!(stderr(&o).contains("symbolic link"), "{}", stderr(&o));
                assert!(
                    std::fs::symlink_metadata(&link)
                        .expect("link kept")
                        .file_type()
                        .is_symlink()
                );
                // refused before any run: nothing but the lock file was written
                let written: Vec<_> = std::fs::read_dir(out.path())
                    .expect("list")
                    .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
                    .filter(|n| n != name && n != ".nprl-bench.lock")
                    .collect();
                assert!(written.is_empty(), "{written:?}");
            }
            sentinel.assert_unchanged(&before, format_args!("{name} -> {}", target.display()));
        }
    }
}

#[cfg(unix)]
#[test]
fn fifos_and_devices_in_out_are_refused_without_blocking() {
    let sentinel = Sentinel::new("bench-fifo-sentinel").expect("sentinel");
    let before = sentinel.snapshot();
    let out = ScratchDir::new("bench-fifo").expect("scratch");
    let fifo = out.path().join("table.csv");
    if !Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
        return; // no mkfifo on this machine
    }
    let o = bench(&QUICK, out.path());
    assert_no_panic(&o);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("FIFO"), "{}", stderr(&o));
    std::fs::remove_file(&fifo).expect("remove fifo");
    // a device under an output's name (as root only)
    let made = Command::new("mknod")
        .arg(out.path().join("runs.json"))
        .args(["c", "1", "3"])
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if made {
        let o = bench(&QUICK, out.path());
        assert!(!o.status.success());
        assert!(stderr(&o).contains("character device"), "{}", stderr(&o));
        let m = std::fs::symlink_metadata(out.path().join("runs.json")).expect("device kept");
        assert!(!m.is_file(), "the device was replaced by a file");
    }
    sentinel.assert_unchanged(&before, "the run");
}

#[test]
fn a_subset_run_updates_its_rows_and_keeps_the_rest_and_an_empty_run_writes_nothing() {
    let out = ScratchDir::new("bench-subset").expect("scratch");
    let o = bench(&QUICK, out.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let full = runs(out.path());
    assert!(full.iter().any(|r| r.2 == "gauss-newton") && full.iter().any(|r| r.2 == "powell"));
    // reports under --out when no --report-dir is given
    assert!(out.path().join("benchmarks.md").is_file());
    // a subset by solver: its rows replaced, the others kept
    let mut subset = QUICK.to_vec();
    subset[3] = "powell";
    let o = bench(&subset, out.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("replaced or joined the saved ones"),
        "{}",
        stderr(&o)
    );
    assert_eq!(runs(out.path()), full, "the subset changed the set");
    assert_eq!(table_rows(out.path()), full.len());
    // a subset by problem likewise
    let mut one = QUICK.to_vec();
    one[1] = "01_rosenbrock";
    let o = bench(&one, out.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(runs(out.path()), full);
    // a run in which no solver applies writes nothing and says why
    let saved = std::fs::read(out.path().join("runs.json")).expect("runs");
    let mut none = QUICK.to_vec();
    none[3] = "ddp-full";
    let o = bench(&none, out.path());
    assert_no_panic(&o);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("nothing was written"), "{}", stderr(&o));
    assert_eq!(std::fs::read(out.path().join("runs.json")).expect("runs"), saved);
}

#[test]
fn a_subset_made_by_other_code_or_budget_is_refused_unless_forced() {
    let out = ScratchDir::new("bench-mix").expect("scratch");
    assert!(bench(&QUICK, out.path()).status.success());
    let saved = std::fs::read(out.path().join("runs.json")).expect("runs");
    let mut other = QUICK.to_vec();
    other[3] = "powell";
    other[7] = "100";
    let o = bench(&other, out.path());
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("would mix") || stderr(&o).contains("merging would mix"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(out.path().join("runs.json")).expect("runs"), saved);
    other.push("--force");
    let o = bench(&other, out.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(runs(out.path()).iter().all(|r| r.2 == "powell"));
}

#[test]
fn two_concurrent_writers_never_mix_their_files() {
    let out = ScratchDir::new("bench-concurrent").expect("scratch");
    let spawn = || {
        Command::new(env!("CARGO_BIN_EXE_nprl-bench"))
            .args(QUICK)
            .arg("--out")
            .arg(out.path())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("spawn")
    };
    let (a, b) = (spawn(), spawn());
    let (a, b) = (a.wait_with_output().expect("a"), b.wait_with_output().expect("b"));
    let ok = [&a, &b].iter().filter(|o| o.status.success()).count();
    assert!(ok >= 1, "{} / {}", stderr(&a), stderr(&b));
    for o in [&a, &b] {
        assert_no_panic(o);
        if !o.status.success() {
            assert!(stderr(o).contains("another program is writing into"), "{}", stderr(o));
        }
    }
    // one generation: the table holds runs.json's runs, and no marker is left
    assert_eq!(table_rows(out.path()), runs(out.path()).len());
    assert!(!out.path().join(".nprl-bench.incomplete").exists());
}

#[cfg(unix)]
#[test]
fn a_kill_at_any_moment_leaves_the_old_set_or_a_marker_that_the_next_run_repairs() {
    let reference = ScratchDir::new("bench-kill-ref").expect("scratch");
    let started = std::time::Instant::now();
    assert!(bench(&QUICK, reference.path()).status.success());
    let took = started.elapsed();
    let want = runs(reference.path());
    // moments across a run's life, from start-up to the last report, as
    // fractions of an uninterrupted run's time (fixed: no seed to tune)
    for fraction in [0.02, 0.1, 0.25, 0.4, 0.55, 0.7, 0.8, 0.9, 0.97] {
        let delay_ms = (took.as_secs_f64() * fraction * 1e3) as u64;
        let out = ScratchDir::new("bench-kill").expect("scratch");
        let mut child = Command::new(env!("CARGO_BIN_EXE_nprl-bench"))
            .args(QUICK)
            .arg("--out")
            .arg(out.path())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("spawn");
        std::thread::sleep(Duration::from_millis(delay_ms));
        let _ = child.kill(); // SIGKILL
        let _ = child.wait();
        let marker = out.path().join(".nprl-bench.incomplete");
        if marker.exists() && !out.path().join("runs.json").exists() {
            // stopped before the first runs.json: nothing to reuse, said so
            let o = bench(&[&QUICK[..], &["--reuse"]].concat(), out.path());
            assert!(!o.status.success());
            assert!(stderr(&o).contains("no runs.json to reuse"), "{}", stderr(&o));
        } else if marker.exists() {
            // the next run names the interruption and rewrites every file
            let o = bench(&[&QUICK[..], &["--reuse"]].concat(), out.path());
            assert!(o.status.success(), "{}", stderr(&o));
            assert!(
                stderr(&o).contains("was stopped while writing its files"),
                "{}",
                stderr(&o)
            );
        } else if out.path().join("runs.json").exists() {
            // not interrupted while writing: the files are one whole set
            assert_eq!(table_rows(out.path()), runs(out.path()).len(), "after {delay_ms} ms");
        }
        // a full rerun after any kill gives the uninterrupted run's results
        let o = bench(&QUICK, out.path());
        assert!(o.status.success(), "after {delay_ms} ms: {}", stderr(&o));
        assert_eq!(runs(out.path()), want, "after {delay_ms} ms");
        assert!(!marker.exists());
        let names: Vec<String> = std::fs::read_dir(out.path())
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        assert!(!names.iter().any(|n| store::is_temporary(n)), "{names:?}");
    }
}

#[test]
fn huge_tiny_and_bad_numbers_are_refused_by_name_without_panic() {
    let out = ScratchDir::new("bench-numbers").expect("scratch");
    for (flag, value) in [
        ("--time-limit", "1e308"),
        ("--time-limit", "1.8e19"),
        ("--time-limit", "inf"),
        ("--time-limit", "NaN"),
        ("--time-limit", "0"),
        ("--time-limit", "-1"),
        ("--budget", "0"),
        ("--repeats", "0"),
        ("--budget", "99999999999999999999999"),
    ] {
        let arg = format!("{flag}={value}");
        let o = bench(&[&QUICK[..], &[arg.as_str()]].concat(), out.path());
        assert_no_panic(&o);
        assert!(!o.status.success(), "{flag} {value} accepted");
        let key = flag.trim_start_matches("--").replace('-', "_");
        let e = stderr(&o);
        assert!(e.contains(&key) || e.contains(flag), "{flag} {value}: {e}");
        assert!(!out.path().join("runs.json").exists(), "{flag} {value} wrote runs");
    }
}

#[cfg(unix)]
#[test]
fn a_closed_or_full_stdout_saves_the_files_then_fails_with_a_message() {
    let out = ScratchDir::new("bench-pipe").expect("scratch");
    // a closed pipe: the reader gone before the first line
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    let o = Command::new(env!("CARGO_BIN_EXE_nprl-bench"))
        .args(QUICK)
        .arg("--out")
        .arg(out.path())
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .expect("run");
    assert_no_panic(&o);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("standard output"), "{}", stderr(&o));
    assert!(out.path().join("runs.json").is_file() && out.path().join("benchmarks.md").is_file());
    // a full device as stdout
    if let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") {
        let out = ScratchDir::new("bench-full").expect("scratch");
        let o = Command::new(env!("CARGO_BIN_EXE_nprl-bench"))
            .args(QUICK)
            .arg("--out")
            .arg(out.path())
            .stdout(full)
            .stderr(std::process::Stdio::piped())
            .output()
            .expect("run");
        assert_no_panic(&o);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(out.path().join("runs.json").is_file());
    }
}

/// A full disk (a 64 KB tmpfs as `--out`, as root): the error names the
/// file that could not be written, nothing panics, and the generation
/// marker says the set is incomplete; the same run with room gives the
/// uninterrupted run's results.
#[test]
fn a_full_disk_names_the_file_and_leaves_a_repairable_set() {
    let Some(disk) = store::SmallDisk::mount("bench-full-disk", 64 * 1024) else {
        return; // not root here: no tmpfs to fill
    };
    let o = bench(&QUICK, disk.path());
    assert_no_panic(&o);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains(&disk.path().display().to_string()), "{e}");
    assert!(e.contains("No space left on device") || e.contains("space"), "{e}");
    let names: Vec<String> = std::fs::read_dir(disk.path())
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!names.iter().any(|n| store::is_temporary(n)), "{names:?}");
    if disk.path().join("runs.json").exists() {
        assert!(disk.path().join(".nprl-bench.incomplete").exists(), "{names:?}");
    }
}

/// The help a person reads (issue 50, item 7): no rustdoc link syntax, no
/// LaTeX, no internal issue numbers; `--version` names the commit.
#[test]
fn help_is_plain_text_and_the_version_names_the_commit() {
    let o = Command::new(env!("CARGO_BIN_EXE_nprl-bench"))
        .arg("--help")
        .output()
        .expect("runs");
    let help = String::from_utf8_lossy(&o.stdout);
    for bad in ["[`", "`]", "$", "issue 3", "issue 4", "issue 5", "crate::"] {
        assert!(!help.contains(bad), "--help holds {bad:?}:\n{help}");
    }
    let o = Command::new(env!("CARGO_BIN_EXE_nprl-bench"))
        .arg("--version")
        .output()
        .expect("runs");
    let v = String::from_utf8_lossy(&o.stdout);
    assert!(v.contains("commit") && v.starts_with("nprl-bench 0."), "{v}");
}
