//! A grid run as shards (N machines, a Slurm job array) and merged: each
//! shard writes only its own files, the merge reads the settings from the
//! shards, equals a one-process run in every field but timings, and
//! refuses, by name, what would make a wrong report.

use std::path::Path;

use swingup::experiments::{Experiment, ExperimentSettings, ExperimentsReport, RunSummary, Shard};
use swingup::output::grid::{GridEvent, GridMode, GridOptions, merge_grid, run_grid};

mod common;
use common::scratch;

/// The smallest grid ([`common::smallest_grid`]).
fn settings() -> ExperimentSettings {
    common::smallest_grid()
}

fn options(dir: &Path, shard: Option<Shard>) -> GridOptions {
    GridOptions {
        which: vec![Experiment::Lambda],
        settings: settings(),
        out: dir.to_path_buf(),
        mode: GridMode::Resume,
        shard,
        variants: vec![],
    }
}

fn quiet(_: GridEvent<'_>) {}

fn shard(index: usize, count: usize) -> Option<Shard> {
    Some(Shard { index, count })
}

/// The runs without what depends on the clock.
fn timeless(report: &ExperimentsReport) -> Vec<RunSummary> {
    report
        .runs
        .iter()
        .map(|r| RunSummary {
            seconds: 0.0,
            ..r.clone()
        })
        .collect()
}

fn refusal(dir: &Path) -> String {
    format!("{:#}", merge_grid(dir, &quiet).expect_err("the merge is refused"))
}

#[test]
fn shards_merged_equal_one_process_and_write_only_their_own_files() {
    let whole = scratch("shards-whole");
    let one = run_grid(&options(whole.path(), None), &quiet).expect("one process");
    let dir = scratch("shards");
    for k in 1..=2 {
        run_grid(&options(dir.path(), shard(k, 2)), &quiet).expect("shard");
    }
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .expect("list")
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| !n.starts_with('.'))
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "runs-1-of-2.jsonl",
            "runs-2-of-2.jsonl",
            "settings-1-of-2.json",
            "settings-2-of-2.json"
        ]
    );
    let merged = merge_grid(dir.path(), &quiet).expect("merge");
    assert_eq!(merged.runs.len(), 3);
    assert_eq!(timeless(&merged), timeless(&one));
    assert_eq!(format!("{:?}", merged.claims), format!("{:?}", one.claims));
    assert!(merged.missing.is_empty());
    let written: ExperimentsReport =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("experiments.json")).expect("report"))
            .expect("parse");
    assert_eq!(timeless(&written), timeless(&one));
    assert!(dir.path().join("experiments.md").is_file());
}

#[test]
fn a_missing_or_unfinished_shard_is_refused_by_its_index() {
    let dir = scratch("shards-missing");
    run_grid(&options(dir.path(), shard(1, 3)), &quiet).expect("shard 1");
    run_grid(&options(dir.path(), shard(3, 3)), &quiet).expect("shard 3");
    let e = refusal(dir.path());
    assert!(e.contains("shard 2 of 3 (settings-2-of-3.json absent)"), "{e}");
    assert!(!dir.path().join("experiments.json").exists());

    // shard 2 failed after its settings were written: no runs
    run_grid(&options(dir.path(), shard(2, 3)), &quiet).expect("shard 2");
    std::fs::write(dir.path().join("runs-2-of-3.jsonl"), "").expect("empty the runs");
    let e = refusal(dir.path());
    assert!(e.contains("shard 2/3") && e.contains("lacks 1 of its runs"), "{e}");
    assert!(!dir.path().join("experiments.json").exists());

    // resubmitted, it runs only its missing run, and the merge passes
    run_grid(&options(dir.path(), shard(2, 3)), &quiet).expect("shard 2 again");
    assert_eq!(merge_grid(dir.path(), &quiet).expect("merge").runs.len(), 3);
}

#[test]
fn shards_of_other_settings_builds_or_records_are_refused_by_name() {
    let dir = scratch("shards-other");
    run_grid(&options(dir.path(), shard(1, 2)), &quiet).expect("shard 1");
    // run elsewhere and copied in (a resumed shard there is refused at once)
    let mut other = options(dir.path(), shard(2, 2));
    other.settings.powell_evals += 1;
    assert!(run_grid(&other, &quiet).is_err());
    other.mode = GridMode::Fresh { force: false };
    run_grid(&other, &quiet).expect("shard 2 of another grid");
    let e = refusal(dir.path());
    assert!(
        e.contains("settings-1-of-2.json") && e.contains("settings-2-of-2.json") && e.contains("powell_evals"),
        "{e}"
    );

    // the same settings, another build
    let dir = scratch("shards-build");
    for k in 1..=2 {
        run_grid(&options(dir.path(), shard(k, 2)), &quiet).expect("shard");
    }
    let path = dir.path().join("settings-2-of-2.json");
    let mut manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).expect("read")).expect("parse");
    manifest["created_by_commit"] = "0123456789ab".into();
    std::fs::write(&path, serde_json::to_string(&manifest).expect("json")).expect("write");
    let e = refusal(dir.path());
    assert!(e.contains("0123456789ab") && e.contains("one build"), "{e}");
    manifest["created_by_commit"] = serde_json::from_str::<serde_json::Value>(
        &std::fs::read_to_string(dir.path().join("settings-1-of-2.json")).expect("read"),
    )
    .expect("parse")["created_by_commit"]
        .clone();
    std::fs::write(&path, serde_json::to_string(&manifest).expect("json")).expect("write");

    // a run recorded twice, differently: both records are named
    let first = std::fs::read_to_string(dir.path().join("runs-1-of-2.jsonl")).expect("read");
    let mut record: serde_json::Value = serde_json::from_str(first.lines().next().expect("a run")).expect("parse");
    record["trials"] = (record["trials"].as_u64().expect("trials") + 1).into();
    let log = dir.path().join("runs-2-of-2.jsonl");
    let mut text = std::fs::read_to_string(&log).expect("read");
    text.push_str(&format!("{record}\n"));
    std::fs::write(&log, text).expect("write");
    let e = refusal(dir.path());
    assert!(e.contains("two different records of one run"), "{e}");
    assert!(!dir.path().join("experiments.json").exists());
}

/// The program as a Slurm job array runs it: no `--shard`, the part from
/// the array's variables, four tasks at once, then `experiments merge`.
#[test]
fn an_array_of_the_program_merges_to_the_one_process_report() {
    use std::process::Command;
    const GRID: [&str; 8] = [
        "experiments",
        "lambda",
        "--quick",
        "--seeds",
        "1",
        "--max-trials",
        "1",
        "--resume",
    ];
    fn run(dir: &Path, env: &[(&str, String)]) -> std::process::Output {
        Command::new(env!("CARGO_BIN_EXE_swingup"))
            .args(GRID)
            .arg("--out")
            .arg(dir)
            .envs(env.iter().map(|(k, v)| (*k, v.as_str())))
            .env("RAYON_NUM_THREADS", "1")
            .output()
            .expect("run")
    }
    let whole = scratch("shards-cli-whole");
    assert!(run(whole.path(), &[]).status.success());
    let dir = scratch("shards-cli");
    let array = |id: usize| {
        vec![
            ("SLURM_ARRAY_TASK_ID", (id + 10).to_string()),
            ("SLURM_ARRAY_TASK_MIN", "10".to_string()),
            ("SLURM_ARRAY_TASK_MAX", "13".to_string()),
            ("SLURM_ARRAY_TASK_COUNT", "4".to_string()),
        ]
    };
    let tasks: Vec<_> = (0..4)
        .map(|id| {
            let dir = dir.path().to_path_buf();
            let env = array(id);
            std::thread::spawn(move || run(&dir, &env))
        })
        .collect();
    for (id, t) in tasks.into_iter().enumerate() {
        let o = t.join().expect("task");
        assert!(o.status.success(), "task {id}: {}", String::from_utf8_lossy(&o.stderr));
        let said = String::from_utf8_lossy(&o.stdout);
        assert!(said.contains(&format!("shard {}/4", id + 1)), "{said}");
    }
    // shard 4 of 4 holds no run of a 3-run grid, and is still a part
    assert!(dir.path().join("settings-4-of-4.json").is_file());
    assert!(!dir.path().join("experiments.json").exists());
    let o = Command::new(env!("CARGO_BIN_EXE_swingup"))
        .args(["experiments", "merge"])
        .arg(dir.path())
        .output()
        .expect("merge");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let read = |d: &Path| -> Vec<serde_json::Value> {
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join("experiments.json")).expect("report")).expect("json");
        let mut runs = report["runs"].as_array().expect("runs").clone();
        for r in &mut runs {
            r["seconds"] = 0.into();
        }
        runs
    };
    assert_eq!(read(dir.path()), read(whole.path()));

    // a stepped array would leave runs to no task: refused, named
    let stepped = scratch("shards-cli-stepped");
    let mut env = array(0);
    env[3].1 = "2".into();
    let o = run(stepped.path(), &env);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("SLURM_ARRAY_TASK_COUNT"));
}
