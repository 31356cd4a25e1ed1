//! A benchmark split into shards (N machines, a Slurm job array) and
//! merged: each shard writes only its own files and resumes after a kill
//! without loss or duplicates; the merge equals a one-process run in
//! every field but timings, and refuses, by name, what would make a wrong
//! report.

use std::path::Path;
use std::sync::Arc;

use bench::open::BenchSolver;
use bench::problems::ProblemSet;
use bench::record::{RecordFile, RunRecord};
use bench::runner::{RunnerSettings, execute};
use bench::shard::{merge, run_shard};
use bench::solvers::Solver;
use store::{ScratchDir, Shard};

fn settings(out: &Path) -> RunnerSettings {
    let mut s = RunnerSettings::new(ProblemSet::Mgh, out);
    s.solvers = [Solver::GaussNewton, Solver::Powell]
        .into_iter()
        .map(|s| Arc::new(s) as Arc<dyn BenchSolver>)
        .collect();
    s.filter = Some("rosenbrock".into());
    s
}

fn shard(index: usize, count: usize) -> Shard {
    Shard { index, count }
}

/// The runs without what depends on the clock.
fn timeless(runs: &[RunRecord]) -> Vec<RunRecord> {
    runs.iter()
        .map(|r| RunRecord {
            time_s: 0.0,
            ..r.clone()
        })
        .collect()
}

fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("list")
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| !n.starts_with('.'))
        .collect();
    names.sort();
    names
}

fn refusal(dir: &Path) -> String {
    merge(dir, dir.to_path_buf(), vec![])
        .expect_err("the merge is refused")
        .to_string()
}

#[test]
fn shards_merged_equal_one_process_and_write_only_their_own_files() {
    let whole = ScratchDir::new("bench-shards-whole").expect("scratch");
    execute(&settings(whole.path())).expect("one process");
    let one = RecordFile::load(&whole.path().join("runs.json")).expect("runs");
    let dir = ScratchDir::new("bench-shards").expect("scratch");
    for k in 1..=3 {
        let outcome = run_shard(&settings(dir.path()), shard(k, 3)).expect("shard");
        assert_eq!(outcome.ran, outcome.planned);
    }
    assert_eq!(
        names(dir.path()),
        [
            "runs-1-of-3.jsonl",
            "runs-2-of-3.jsonl",
            "runs-3-of-3.jsonl",
            "shard-1-of-3.json",
            "shard-2-of-3.json",
            "shard-3-of-3.json"
        ]
    );
    let (_, stamp) = merge(dir.path(), dir.path().to_path_buf(), vec![]).expect("merge");
    let merged = RecordFile::load(&dir.path().join("runs.json")).expect("merged runs");
    assert_eq!(stamp.runs, one.runs.len());
    assert_eq!(timeless(&merged.runs), timeless(&one.runs));
    assert_eq!(merged.made_by.as_ref().map(|m| m.budget_simplex_gradients), Some(2000));
    for file in ["benchmarks.md", "benchmarks.json", "benchmarks_summary.md"] {
        assert!(dir.path().join(file).is_file(), "{file}");
    }
}

#[test]
fn a_killed_shard_resumes_without_loss_or_duplicates() {
    let dir = ScratchDir::new("bench-shards-resume").expect("scratch");
    let first = run_shard(&settings(dir.path()), shard(1, 2)).expect("shard");
    let log = dir.path().join("runs-1-of-2.jsonl");
    let text = std::fs::read_to_string(&log).expect("log");
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), first.planned);
    // killed after its first run, in the middle of writing the second
    std::fs::write(&log, format!("{}\n{}", lines[0], &lines[1][..lines[1].len() / 2])).expect("cut");
    let again = run_shard(&settings(dir.path()), shard(1, 2)).expect("resumed");
    assert_eq!((again.resumed, again.ran), (1, first.planned - 1));
    let after = std::fs::read_to_string(&log).expect("log");
    assert_eq!(after.lines().count(), first.planned);
    let keys: std::collections::BTreeSet<_> = after
        .lines()
        .map(|l| serde_json::from_str::<RunRecord>(l).expect("run").key())
        .collect();
    assert_eq!(keys.len(), first.planned, "a run recorded twice");

    // other settings in the same shard files: refused, naming the key
    let mut other = settings(dir.path());
    other.budget.simplex_gradients = 100;
    let e = run_shard(&other, shard(1, 2)).expect_err("refused").to_string();
    assert!(
        e.contains("budget_simplex_gradients") && e.contains("shard-1-of-2.json"),
        "{e}"
    );
}

#[test]
fn missing_unfinished_or_mismatched_shards_are_refused_by_name() {
    let dir = ScratchDir::new("bench-shards-missing").expect("scratch");
    run_shard(&settings(dir.path()), shard(1, 3)).expect("shard 1");
    run_shard(&settings(dir.path()), shard(3, 3)).expect("shard 3");
    let e = refusal(dir.path());
    assert!(e.contains("lacks shard 2 of 3 (shard-2-of-3.json absent)"), "{e}");

    run_shard(&settings(dir.path()), shard(2, 3)).expect("shard 2");
    let log = dir.path().join("runs-2-of-3.jsonl");
    let text = std::fs::read_to_string(&log).expect("log");
    let first_line = text.lines().next().expect("a run").to_string();
    std::fs::write(&log, format!("{first_line}\n")).expect("cut");
    let e = refusal(dir.path());
    assert!(e.contains("shard 2/3") && e.contains("lacks"), "{e}");

    // one run recorded twice, differently
    let mut twin: serde_json::Value = serde_json::from_str(&first_line).expect("json");
    twin["evals"] = (twin["evals"].as_u64().expect("evals") + 1).into();
    std::fs::write(&log, format!("{text}{twin}\n")).expect("twin");
    let e = refusal(dir.path());
    assert!(e.contains("two different records of one run"), "{e}");
    std::fs::write(&log, &text).expect("restore");
    merge(dir.path(), dir.path().to_path_buf(), vec![]).expect("merge once whole");

    // a shard of the same benchmark split another way
    let split = ScratchDir::new("bench-shards-split").expect("scratch");
    run_shard(&settings(split.path()), shard(1, 3)).expect("1 of 3");
    run_shard(&settings(split.path()), shard(2, 2)).expect("2 of 2");
    run_shard(&settings(split.path()), shard(2, 3)).expect("2 of 3");
    let e = refusal(split.path());
    assert!(e.contains("holds shards of 2 counts (of 2, of 3)"), "{e}");

    // a shard of another benchmark copied in
    let elsewhere = ScratchDir::new("bench-shards-other").expect("scratch");
    let mut other = settings(elsewhere.path());
    other.repeats = 2;
    run_shard(&other, shard(2, 3)).expect("other shard");
    for name in ["shard-2-of-3.json", "runs-2-of-3.jsonl"] {
        std::fs::copy(elsewhere.path().join(name), dir.path().join(name)).expect("copy");
    }
    let e = refusal(dir.path());
    assert!(
        e.contains("shard-1-of-3.json") && e.contains("shard-2-of-3.json") && e.contains("repeats"),
        "{e}"
    );
}
