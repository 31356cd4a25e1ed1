//! Regression against another commit (`nprl-bench --compare-to REF`):
//! the same set judged from two sets of our records, per solver, the
//! instances solved before and after, which were gained and lost, and the
//! median evaluations over the instances solved both times.
//!
//! The reference records are a saved `runs.json`: a directory holding
//! one, the file itself, or a git revision whose committed
//! `OUT/runs.json` is read with `git show` ([`load_reference`]). Both
//! sides are judged by this commit's code ([`crate::runner::analyse`]),
//! with the same outside records, so that only our solvers' runs differ.
//!
//! ```
//! use bench::compare::{SolverChange, changes};
//! use bench::analysis::Analysis;
//! # use bench::record::RunRecord;
//! # fn run(solver: &str, problem: &str, f: f64) -> RunRecord {
//! #     RunRecord { solver: solver.into(), set: "s".into(), problem: problem.into(), n: 2, m: 2,
//! #         scale: 1.0, status: "done".into(), converged: true, f0: 10.0, f, f_star: Some(0.0),
//! #         objective: None, f_evals: 9, jac_evals: 0, evals: 9, time_s: 0.1, repeats: 1,
//! #         trace: vec![(1, 10.0), (9, f)], x0: None, x: None, termination: None }
//! # }
//! let before = Analysis::new(vec![run("a", "p", 0.0), run("a", "q", 1.0)], &["a".into()]);
//! let after = Analysis::new(vec![run("a", "p", 1.0), run("a", "q", 0.0)], &["a".into()]);
//! let c: Vec<SolverChange> = changes(&before, &after, &["a".into()]);
//! assert_eq!((c[0].before, c[0].after), (1, 1));
//! assert_eq!((c[0].gained.clone(), c[0].lost.clone()), (vec!["q x1".to_string()], vec!["p x1".to_string()]));
//! ```

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde::Serialize;

use crate::analysis::Analysis;
use crate::error::{BenchError, Result};
use crate::record::RecordFile;
use crate::report::median;

/// What changed for one solver between two sets of records.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SolverChange {
    /// The solver.
    pub solver: String,
    /// Instances solved (headline criterion) in the reference records,
    /// among the instances both sides ran.
    pub before: usize,
    /// Instances solved now, among the same.
    pub after: usize,
    /// Instances (`problem xscale`) solved now and not before.
    pub gained: Vec<String>,
    /// Instances solved before and not now.
    pub lost: Vec<String>,
    /// Instances solved both times.
    pub both: usize,
    /// Median evaluations to solve over the instances solved both times,
    /// before and now.
    pub median_evals: [Option<f64>; 2],
    /// Instances the solver ran on both sides (non-degenerate).
    pub instances: usize,
}

/// Per solver of `solvers`, what changed from `before` to `after` (both
/// judged by their headline criterion, on the non-degenerate instances
/// both ran). A solver missing from either side gets no entry.
pub fn changes(before: &Analysis, after: &Analysis, solvers: &[String]) -> Vec<SolverChange> {
    let mut out = Vec::new();
    for name in solvers {
        let (Some(sb), Some(sa)) = (before.column(name), after.column(name)) else {
            continue;
        };
        let mut c = SolverChange {
            solver: name.clone(),
            before: 0,
            after: 0,
            gained: Vec::new(),
            lost: Vec::new(),
            both: 0,
            median_evals: [None, None],
            instances: 0,
        };
        let (mut evals_before, mut evals_after) = (Vec::new(), Vec::new());
        for (pa, key) in after.instances.iter().enumerate() {
            let Some(pb) = before.instances.iter().position(|k| k == key) else {
                continue;
            };
            if after.degenerate(pa).is_some() || before.degenerate(pb).is_some() {
                continue;
            }
            let (Some(ob), Some(oa)) = (
                before.judge(pb, sb, before.headline()),
                after.judge(pa, sa, after.headline()),
            ) else {
                continue;
            };
            c.instances += 1;
            c.before += usize::from(ob.solved);
            c.after += usize::from(oa.solved);
            let label = format!("{} x{}", key.1, key.2);
            match (ob.solved, oa.solved) {
                (false, true) => c.gained.push(label),
                (true, false) => c.lost.push(label),
                (true, true) => {
                    c.both += 1;
                    evals_before.extend(ob.evals.map(|e| e as f64));
                    evals_after.extend(oa.evals.map(|e| e as f64));
                }
                (false, false) => {}
            }
        }
        c.median_evals = [median(evals_before), median(evals_after)];
        out.push(c);
    }
    out
}

/// The changes as Markdown: one row per solver, then the instances
/// gained and lost.
pub fn markdown(changes: &[SolverChange], before: &str, after: &str) -> String {
    let mut s = format!(
        "Our solvers' runs at {before} (before) and {after} (after), both judged by this commit's code with the same outside records; counts over the non-degenerate instances both ran, medians over those solved both times.\n\n| solver | instances | solved before | solved after | change | gained | lost | median evals before | after |\n|---|---|---|---|---|---|---|---|---|\n"
    );
    let num = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.0}"));
    for c in changes {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:+} | {} | {} | {} | {} |",
            c.solver,
            c.instances,
            c.before,
            c.after,
            c.after as i64 - c.before as i64,
            c.gained.len(),
            c.lost.len(),
            num(c.median_evals[0]),
            num(c.median_evals[1])
        );
    }
    for c in changes.iter().filter(|c| !c.gained.is_empty() || !c.lost.is_empty()) {
        let _ = writeln!(
            s,
            "\n- {}: gained {}; lost {}",
            c.solver,
            if c.gained.is_empty() {
                "none".into()
            } else {
                c.gained.join(", ")
            },
            if c.lost.is_empty() {
                "none".into()
            } else {
                c.lost.join(", ")
            }
        );
    }
    s
}

/// The reference records named by `spec`: a directory holding
/// `runs.json`, a records file, or else a git revision whose committed
/// `out/runs.json` is read (`out` relative to the working directory, as
/// on the command line). Returns the records and a label for the tables.
///
/// # Errors
/// [`BenchError::CompareTo`] when `spec` is none of these, or git cannot
/// show the file at that revision; a malformed records file as
/// [`RecordFile::parse`].
pub fn load_reference(spec: &str, out: &Path) -> Result<(RecordFile, String)> {
    let path = PathBuf::from(spec);
    if path.is_dir() {
        let file = path.join("runs.json");
        return Ok((RecordFile::load(&file)?, file.display().to_string()));
    }
    if path.is_file() {
        return Ok((RecordFile::load(&path)?, path.display().to_string()));
    }
    let refused = |reason: String| BenchError::CompareTo {
        spec: spec.into(),
        reason,
    };
    let runs = out.join("runs.json");
    let relative = if runs.is_absolute() {
        let top = git(&["rev-parse", "--show-toplevel"]).map_err(&refused)?;
        runs.strip_prefix(top.trim())
            .map_err(|_| refused(format!("{} is outside the repository {}", runs.display(), top.trim())))?
            .to_path_buf()
    } else {
        Path::new(".").join(&runs)
    };
    let object = format!("{spec}:{}", relative.display());
    let commit = git(&["rev-parse", "--short=12", &format!("{spec}^{{commit}}")])
        .map_err(|e| refused(format!("not a directory, a file or a git revision ({e})")))?;
    let text = git(&["show", &object]).map_err(|e| refused(format!("no saved records at {object} ({e})")))?;
    let file = RecordFile::parse(&text, Path::new(&object))?;
    Ok((file, format!("{} ({})", spec, commit.trim())))
}

/// `git args`' standard output, or its error message.
fn git(args: &[&str]) -> std::result::Result<String, String> {
    let output = Command::new("git").args(args).output().map_err(|e| e.to_string())?;
    if output.status.success() {
        Ok(String::from_utf8_lossy(&output.stdout).into_owned())
    } else {
        Err(String::from_utf8_lossy(&output.stderr).trim().to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::tests::run;

    #[test]
    fn gained_lost_and_medians_over_the_instances_solved_both_times() {
        // f0 = 10, f* = 0 (run's defaults): solved at tau 1e-7 when f <= 1e-6
        let before = Analysis::new(
            vec![
                run("a", "p", 0.0, 10),
                run("a", "q", 0.0, 20),
                run("a", "r", 1.0, 5),
                run("b", "p", 0.0, 7),
            ],
            &["a".into(), "b".into()],
        );
        let after = Analysis::new(
            vec![
                run("a", "p", 0.0, 30),
                run("a", "q", 1.0, 20),
                run("a", "r", 0.0, 5),
                // an instance the reference did not run is not counted
                run("a", "s", 0.0, 5),
            ],
            &["a".into()],
        );
        let c = changes(&before, &after, &["a".into(), "b".into()]);
        // b ran only before: no entry
        assert_eq!(c.len(), 1);
        let a = &c[0];
        assert_eq!((a.instances, a.before, a.after, a.both), (3, 2, 2, 1));
        assert_eq!(a.gained, vec!["r x1".to_string()]);
        assert_eq!(a.lost, vec!["q x1".to_string()]);
        assert_eq!(a.median_evals, [Some(10.0), Some(30.0)]);
        let md = markdown(&c, "old", "new");
        assert!(md.contains("| a | 3 | 2 | 2 | +0 | 1 | 1 | 10 | 30 |"), "{md}");
        assert!(md.contains("- a: gained r x1; lost q x1"), "{md}");
    }

    #[test]
    fn a_reference_that_is_nothing_is_refused_with_its_name() {
        let err = load_reference("no-such-revision-or-dir", Path::new("results/benchmarks"))
            .expect_err("refused")
            .to_string();
        assert!(err.contains("no-such-revision-or-dir"), "{err}");
    }
}
