//! One benchmark run from start to files: [`execute`] runs the chosen
//! solvers on the chosen set (or reuses saved runs), merges the outside
//! scripts' records, and writes the tables, profiles, figures, goals and
//! summary.
//!
//! | file | content |
//! |---|---|
//! | `OUT/runs.json` | our runs ([`RecordFile`]) |
//! | `OUT/outside/*.json` | the outside scripts' runs, merged when present |
//! | `OUT/table.csv` | one row per run (ours and outside) with its outcome at both $\tau$ |
//! | `OUT/profiles.json` | every profile at both $\tau$ |
//! | `OUT/perf_time_tau1e-7.{svg,png}`, `perf_evals_*`, `data_*` | the figures, at $\tau = 10^{-3}$ and $10^{-7}$ |
//! | `REPORT/benchmarks.md` | goals, summary, per-solver and per-problem tables |
//! | `REPORT/benchmarks.json` | the stamp, goals, summary and every run's outcome |
//! | `REPORT/benchmarks_summary.md` | the five-row summary alone |

use std::path::{Path, PathBuf};
use std::time::Duration;

use serde_json::json;

use crate::analysis::{Analysis, TAUS};
use crate::error::{BenchError, Result};
use crate::plot::ProfileFigure;
use crate::problems::{Budget, ProblemSet};
use crate::record::{RecordFile, RunRecord};
use crate::report::{self, Stamp};
use crate::solvers::Solver;

/// What [`execute`] does.
#[derive(Debug, Clone)]
pub struct RunnerSettings {
    /// The problem set.
    pub set: ProblemSet,
    /// Our solvers.
    pub solvers: Vec<Solver>,
    /// Only problems whose name contains this (all when `None`).
    pub filter: Option<String>,
    /// What one run may spend.
    pub budget: Budget,
    /// Times each solve is timed.
    pub repeats: u32,
    /// The directory of runs, table, profiles and figures.
    pub out: PathBuf,
    /// The directory of `benchmarks.md`, `.json` and `_summary.md`.
    pub report_dir: PathBuf,
    /// Outside record files besides `OUT/outside/*.json`.
    pub outside: Vec<PathBuf>,
    /// Reuse `OUT/runs.json` instead of running.
    pub reuse: bool,
}

impl RunnerSettings {
    /// Checks the numbers.
    ///
    /// # Errors
    /// [`BenchError::InvalidSetting`] naming the field.
    pub fn validate(&self) -> Result<()> {
        if self.budget.simplex_gradients == 0 {
            return Err(BenchError::InvalidSetting {
                name: "budget",
                reason: "must be at least 1 simplex gradient".into(),
            });
        }
        if self.budget.time.is_zero() {
            return Err(BenchError::InvalidSetting {
                name: "time_limit",
                reason: "must be positive".into(),
            });
        }
        if self.repeats == 0 {
            return Err(BenchError::InvalidSetting {
                name: "repeats",
                reason: "must be at least 1".into(),
            });
        }
        Ok(())
    }
}

/// Runs (or reuses) and writes every file; returns the analysis and the
/// stamp.
///
/// # Errors
/// Bad settings, an unreadable or malformed records file (naming it), or a
/// file that cannot be written.
pub fn execute(settings: &RunnerSettings) -> Result<(Analysis, Stamp)> {
    settings.validate()?;
    let load_before = Stamp::load();
    let runs_path = settings.out.join("runs.json");
    let started = std::time::Instant::now();
    let ours = if settings.reuse {
        RecordFile::load(&runs_path)?
    } else {
        let runs = run_all(settings)?;
        std::fs::create_dir_all(&settings.out).map_err(BenchError::io(&settings.out))?;
        let file = RecordFile::new(
            format!(
                "nprl-bench {} ({:.1} s for the runs)",
                env!("CARGO_PKG_VERSION"),
                started.elapsed().as_secs_f64()
            ),
            runs,
        );
        file.save(&runs_path)?;
        file
    };
    let elapsed_s = if settings.reuse {
        0.0
    } else {
        started.elapsed().as_secs_f64()
    };
    let mut sources = vec![ours.source.clone()];
    let mut all: Vec<RunRecord> = ours.runs;
    let repeats = all.first().map_or(settings.repeats, |r| r.repeats);
    for path in outside_files(&settings.out.join("outside"), &settings.outside)? {
        let file = RecordFile::load(&path)?;
        sources.push(format!("{} ({})", file.source, path.display()));
        all.extend(file.runs);
    }
    let our_names: Vec<String> = settings.solvers.iter().map(|s| s.name().to_string()).collect();
    let analysis = Analysis::new(all, &our_names);
    let (commit, dirty, date) = Stamp::git();
    let stamp = Stamp {
        commit,
        dirty,
        cores: std::thread::available_parallelism().map_or(1, usize::from),
        load_before,
        load_after: Stamp::load(),
        date,
        runs: analysis.runs.iter().flatten().flatten().count(),
        repeats,
        budget_simplex_gradients: settings.budget.simplex_gradients,
        budget_time_s: settings.budget.time.as_secs_f64(),
        sources,
        elapsed_s,
    };
    write_all(&analysis, &stamp, &settings.out, &settings.report_dir)?;
    Ok((analysis, stamp))
}

/// Every solver on every instance, one at a time (so that the timings do
/// not share the cores), with progress on stderr.
fn run_all(settings: &RunnerSettings) -> Result<Vec<RunRecord>> {
    let instances: Vec<_> = settings
        .set
        .instances()
        .into_iter()
        .filter(|i| settings.filter.as_ref().is_none_or(|f| i.problem.contains(f.as_str())))
        .collect();
    let mut runs = Vec::new();
    for (k, instance) in instances.iter().enumerate() {
        for solver in &settings.solvers {
            if !solver.applies_to(instance) {
                continue;
            }
            let run = solver.run(instance, &settings.budget, settings.repeats)?;
            eprintln!(
                "[{}/{}] {:?} {:<20} f = {:.6e} evals = {:>7} {:.2e} s {}",
                k + 1,
                instances.len(),
                instance,
                run.solver,
                run.f,
                run.evals,
                run.time_s,
                run.status
            );
            runs.push(run);
        }
    }
    Ok(runs)
}

/// `dir/*.json` in name order (none if `dir` does not exist), then `extra`.
fn outside_files(dir: &Path, extra: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    if dir.is_dir() {
        for entry in std::fs::read_dir(dir).map_err(BenchError::io(dir))? {
            let path = entry.map_err(BenchError::io(dir))?.path();
            if path.extension().is_some_and(|e| e == "json") {
                files.push(path);
            }
        }
        files.sort();
    }
    files.extend(extra.iter().cloned());
    Ok(files)
}

fn tau_tag(tau: f64) -> String {
    format!("tau{tau:e}")
}

/// Writes the table, profiles, figures and reports.
fn write_all(a: &Analysis, stamp: &Stamp, out: &Path, report_dir: &Path) -> Result<()> {
    report::write(&out.join("table.csv"), &report::runs_csv(a)?)?;
    let all: Vec<usize> = (0..a.solvers.len()).collect();
    let free: Vec<usize> = all.iter().copied().filter(|&s| a.derivative_free[s]).collect();
    let mut profiles = serde_json::Map::new();
    for tau in TAUS {
        let (time, evals) = a.performance(tau, &all);
        let data = a.data(tau, &free);
        let tag = tau_tag(tau);
        let rows = a.common_rows(&all).len();
        ProfileFigure {
            title: format!("Performance profile, time, tau = {tau:e} ({rows} MGH instances)"),
            x_label: "ratio to the fastest (alpha)",
            x_min: 1.0,
            profiles: &time,
        }
        .write(out, &format!("perf_time_{tag}"))?;
        ProfileFigure {
            title: format!("Performance profile, evaluations, tau = {tau:e} ({rows} MGH instances)"),
            x_label: "ratio to the fewest evaluation equivalents (alpha)",
            x_min: 1.0,
            profiles: &evals,
        }
        .write(out, &format!("perf_evals_{tag}"))?;
        ProfileFigure {
            title: format!(
                "Data profile, derivative-free, tau = {tau:e} ({} MGH instances)",
                a.common_rows(&free).len()
            ),
            x_label: "budget in simplex gradients, evaluations / (n + 1) (kappa)",
            x_min: 0.1,
            profiles: &data,
        }
        .write(out, &format!("data_{tag}"))?;
        profiles.insert(tag, json!({"tau": tau, "time": time, "evals": evals, "data": data}));
    }
    let profiles_text = serde_json::to_string(&profiles).unwrap_or_default();
    report::write(&out.join("profiles.json"), &(profiles_text + "\n"))?;

    let goals = report::goals(a);
    let summary = report::summary(a);
    let summary_md = report::summary_markdown(&summary, stamp);
    report::write(&report_dir.join("benchmarks_summary.md"), &summary_md)?;
    let outcomes: Vec<_> = a
        .instances
        .iter()
        .enumerate()
        .flat_map(|(p, key)| {
            a.runs[p].iter().enumerate().filter_map(move |(s, r)| {
                let r = r.as_ref()?;
                Some(json!({
                    "set": key.0, "problem": key.1, "scale": r.scale, "n": r.n, "solver": r.solver,
                    "status": r.status, "converged": r.converged, "f0": r.f0, "f": r.f, "f_low": a.f_low[p],
                    "f_star": r.f_star, "f_evals": r.f_evals, "jac_evals": r.jac_evals, "evals": r.evals,
                    "time_s": r.time_s,
                    "outcomes": TAUS.iter().map(|&t| json!({"tau": t, "outcome": a.outcome(p, s, t)})).collect::<Vec<_>>(),
                }))
            })
        })
        .collect();
    let report_json = json!({
        "stamp": stamp, "goals": goals, "summary": summary, "solvers": a.solvers, "runs": outcomes,
    });
    report::write(
        &report_dir.join("benchmarks.json"),
        &(serde_json::to_string_pretty(&report_json).unwrap_or_default() + "\n"),
    )?;
    report::write(
        &report_dir.join("benchmarks.md"),
        &markdown(a, stamp, &goals, &summary_md, out, report_dir),
    )
}

fn markdown(
    a: &Analysis,
    stamp: &Stamp,
    goals: &[report::Goal],
    summary_md: &str,
    out: &Path,
    report_dir: &Path,
) -> String {
    let rel = out.strip_prefix(report_dir).unwrap_or(out).display().to_string();
    let mut s = format!(
        "# Benchmarks\n\nGenerated by `nprl-bench` (see `bench/README.md`); do not edit. Commit {}{}, {} cores, load {} before and {} after, {} runs (each of ours timed {} times, median), budget {} simplex gradients and {} s per run, {}; our runs took {:.1} s of wall time.\n\nSources: {}.\n\n",
        stamp.commit,
        if stamp.dirty { " (dirty)" } else { "" },
        stamp.cores,
        stamp.load_before.map_or("?".into(), |l| format!("{l:.2}")),
        stamp.load_after.map_or("?".into(), |l| format!("{l:.2}")),
        stamp.runs,
        stamp.repeats,
        stamp.budget_simplex_gradients,
        stamp.budget_time_s,
        stamp.date,
        stamp.elapsed_s,
        stamp.sources.join("; "),
    );
    s.push_str("## Goals (issue 21)\n\n");
    for g in goals {
        s.push_str(&format!("- **{}**: {}\n", g.verdict, g.goal));
        for c in &g.evidence {
            s.push_str(&format!(
                "  - {}: {} {}, {} {}, ratio {} ({} runs)\n",
                c.task,
                c.ours,
                report::num(c.ours_value, &c.unit),
                c.reference,
                report::num(c.reference_value, &c.unit),
                report::ratio_text(c.ratio),
                c.runs
            ));
        }
    }
    s.push_str(&format!(
        "\n## Summary (tau = {:e})\n\n{summary_md}\n## Solvers\n\n{}\n",
        report::GOAL_TAU,
        report::solvers_markdown(a)
    ));
    s.push_str("## Figures\n\n");
    for tau in TAUS {
        let tag = tau_tag(tau);
        s.push_str(&format!(
            "- tau = {tau:e}: [time]({rel}/perf_time_{tag}.svg), [evaluations]({rel}/perf_evals_{tag}.svg), [data profile]({rel}/data_{tag}.svg)\n"
        ));
    }
    s.push_str(&format!(
        "\n## Per problem\n\nFinal f per solver; **bold** where the run solved its instance at tau = {:e}, with its evaluation equivalents to solve in parentheses; otherwise the status in brackets. f_L as in `bench/README.md`.\n\n{}",
        report::GOAL_TAU,
        report::problems_markdown(a)
    ));
    s
}

/// The default budget: 2000 simplex gradients and 10 s per run.
pub fn default_budget() -> Budget {
    Budget {
        simplex_gradients: 2000,
        time: Duration::from_secs(10),
    }
}
