//! The saved MGH and NIST results (`results/benchmarks/runs.json`,
//! `results/benchmarks/nist/runs.json` and the outside scripts'
//! `outside/*.json` beside them) against the problems themselves: for a sample of the records, $f$ at the stored final $x$
//! and $f$ at the stored start, computed here, equal what the record says,
//! and the start is the instance's. A record whose numbers a solver (or a
//! script, with its own implementation of the residuals) got wrong, or
//! that came from another start, fails here.

use std::path::Path;

use bench::problems::{Instance, ProblemSet};
use bench::record::RecordFile;
use bench::report::{self, Stamp, summary_markdown};
use bench::runner::analyse;
use bench::solvers::{Solver, cost_at};

/// Agreement to 1e-7 relative (1e-20 absolute near 0): the outside
/// scripts' residuals are another implementation, which rounds otherwise
/// where the residuals cancel (`scipy-lm` on Beale from $100 x_0$ ends at
/// $x_1 = -4.5 \cdot 10^6$, $1 - x_2 = 2.2 \cdot 10^{-7}$: the two agree to
/// 1.5e-9). A record from another point or of another problem is off by
/// far more.
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-7 * a.abs().max(b.abs()) + 1e-20
}

#[test]
fn f_at_the_stored_points_of_a_sample_of_saved_records_is_what_they_say() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../results/benchmarks");
    // ours (8 solvers' worth of the MGH set, 7 of the NIST set) and the outside files
    for (set, dir, at_least) in [
        (ProblemSet::Mgh, root.clone(), 100),
        (ProblemSet::Nist, root.join("nist"), 50),
    ] {
        let checked = check_a_sample(set, &dir);
        assert!(checked >= at_least, "{}: only {checked} records checked", set.name());
    }
}

/// The saved trajectory records (ours and the outside script's) against
/// the rollout of their stored final points: the figure of merit each
/// records is that of its controls (every 3rd record of the registry
/// instances; the learned-LWR one would need a learning run here).
#[test]
fn the_trajectory_records_figure_of_merit_is_the_rollout_of_their_stored_point() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../results/benchmarks/trajectory");
    // every registry name holds "-h"; "pendulum-lwr" does not
    let instances = bench::trajectory::instances(Some("-h")).expect("the registry instances");
    let mut checked = 0;
    for path in record_files(&dir) {
        let file = RecordFile::load(&path).expect("a saved record file");
        for r in file
            .runs
            .iter()
            .filter(|r| r.problem != bench::trajectory::LWR_INSTANCE)
            .step_by(3)
        {
            let what = format!("{} {} {}", path.display(), r.solver, r.problem);
            let inst = instances
                .iter()
                .find(|i| i.problem == r.problem)
                .unwrap_or_else(|| panic!("{what}: no instance"));
            let x = r.x.as_deref().unwrap_or_else(|| panic!("{what}: no x"));
            let f = bench::trajectory::figure_of_merit(inst, x).unwrap_or_else(|| panic!("{what}: x of no form"));
            assert!(close(f, r.f), "{what}: f = {} recorded, {f} by rollout", r.f);
            checked += 1;
        }
    }
    assert!(checked >= 40, "only {checked} records checked");
}

/// `dir/runs.json` and `dir/outside/*.json`.
fn record_files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files = vec![dir.join("runs.json")];
    if let Ok(entries) = std::fs::read_dir(dir.join("outside")) {
        for entry in entries {
            let path = entry.expect("entry").path();
            if path.extension().is_some_and(|e| e == "json") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// Checks every 7th record of `dir`'s files; returns how many.
fn check_a_sample(set: ProblemSet, dir: &Path) -> usize {
    let files = record_files(dir);
    let instances: Vec<Instance> = set.instances(None).expect("the set's instances");
    let mut checked = 0;
    for path in &files {
        let file = RecordFile::load(path).expect("a saved record file");
        // every 7th record, all solvers and starts in turn
        for r in file.runs.iter().step_by(7) {
            let inst = instances
                .iter()
                .find(|i| i.problem == r.problem && i.scale == r.scale)
                .unwrap_or_else(|| panic!("{}: no instance {} x{}", path.display(), r.problem, r.scale));
            let what = format!("{} {} {} x{}", path.display(), r.solver, r.problem, r.scale);
            let x0 = r.x0.as_deref().unwrap_or_else(|| panic!("{what}: no x0"));
            assert_eq!(x0, inst.start.as_slice(), "{what}");
            let x = r.x.as_deref().unwrap_or_else(|| panic!("{what}: no x"));
            let f = cost_at(inst, x).expect("n entries");
            // a final point where f overflows (a solver that stopped at an
            // overflowing start) is recorded as null
            assert!(
                close(f, r.f) || (!f.is_finite() && r.f.is_nan()),
                "{what}: f = {} recorded, {f} at its x",
                r.f
            );
            let f0 = cost_at(inst, x0).expect("n entries");
            assert!(
                close(f0, r.f0) || (!f0.is_finite() && r.f0.is_nan()),
                "{what}: f0 = {} recorded, {f0} at the start",
                r.f0
            );
            checked += 1;
        }
    }
    checked
}

/// The README's benchmark block, `results/benchmarks_summary.md` and the
/// summary in `results/benchmarks.md` are what the runner makes of the
/// saved records today: the records judged again with this commit's code,
/// stamped with the stamp saved beside them. A README edited by hand, a
/// summary left from other records, or a change to how runs are judged
/// without regenerating `results/` fails here (regenerate with the
/// commands of `bench/README.md`, then `--reuse --update-readme README.md`).
#[test]
fn the_readme_benchmark_block_is_the_summary_of_the_saved_records() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = root.join("results/benchmarks");
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("results/benchmarks.json")).expect("benchmarks.json"))
            .expect("json");
    let stamp: Stamp = serde_json::from_value(saved["stamp"].clone()).expect("a stamp");
    let ours = RecordFile::load(&out.join("runs.json")).expect("runs.json");
    let (analysis, _) = analyse(
        ProblemSet::Mgh,
        None,
        &Solver::ALL.map(|s| s.name().to_string()),
        ours,
        &out,
        &[],
    )
    .expect("analysis");
    assert_eq!(
        analysis.runs.iter().flatten().flatten().count(),
        stamp.runs,
        "runs judged now and when the report was written"
    );
    let summary = summary_markdown(&report::summary(&analysis), &stamp);
    let readme = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    let start = readme.find(report::README_START).expect("the start marker") + report::README_START.len();
    let end = start + readme[start..].find(report::README_END).expect("the end marker");
    assert_eq!(&readme[start..end], summary, "README.md's benchmark block is stale");
    let saved_summary = std::fs::read_to_string(root.join("results/benchmarks_summary.md")).expect("summary");
    assert_eq!(saved_summary, summary, "results/benchmarks_summary.md is stale");
    let md = std::fs::read_to_string(root.join("results/benchmarks.md")).expect("benchmarks.md");
    assert!(md.contains(&summary), "results/benchmarks.md's summary is stale");
}
