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
//! | `REPORT/benchmarks_summary.md` | the six-row summary alone |
//!
//! The MGH set writes the three `REPORT` files above; another set writes
//! `REPORT/benchmarks_<set>.{md,json}` (stamp, per-solver and per-problem
//! tables, every run's outcome; no goals, no summary), and its `OUT` is
//! its own directory (`results/benchmarks/<set>` from the command line),
//! so that no set overwrites another's files.
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use serde_json::json;

use crate::analysis::{Analysis, Criterion};
use crate::error::{BenchError, Result};
use crate::minima::{self, Reference};
use crate::open::BenchSolver;
use crate::plot::ProfileFigure;
use crate::problems::{Budget, ProblemSet};
use crate::record::{MadeBy, RecordFile, RunKey, RunRecord};
use crate::report::{self, Stamp};
use crate::solvers::Solver;

pub(crate) mod jobs;

/// What [`execute`] does.
#[derive(Debug, Clone)]
pub struct RunnerSettings {
    /// The problem set.
    pub set: ProblemSet,
    /// The solvers that run: built-in ([`Solver::parse_entries`]) and any
    /// [`BenchSolver`] of yours ([`crate::open`]), each with its own
    /// column, time profile included.
    pub solvers: Vec<Arc<dyn BenchSolver>>,
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
    /// Replace a saved result set that this run would otherwise refuse to
    /// merge with (other code or budget; see [`merge_runs`]).
    pub force: bool,
}

impl RunnerSettings {
    /// Every built-in solver on `set`, into `out` (the reports there too),
    /// under [`default_budget`], timed once, merging `OUT/outside/*.json`.
    /// Push your own solvers onto [`solvers`](Self::solvers), or replace
    /// them.
    pub fn new(set: ProblemSet, out: impl Into<PathBuf>) -> Self {
        let out = out.into();
        Self {
            set,
            solvers: Solver::ALL
                .iter()
                .map(|s| Arc::new(*s) as Arc<dyn BenchSolver>)
                .collect(),
            filter: None,
            budget: default_budget(),
            repeats: 1,
            report_dir: out.clone(),
            out,
            outside: Vec::new(),
            reuse: false,
            force: false,
        }
    }

    /// The solvers' names, in the settings' order.
    pub fn solver_names(&self) -> Vec<String> {
        self.solvers.iter().map(|s| s.name().to_string()).collect()
    }

    /// Checks the numbers, and that no two solvers share a name.
    ///
    /// # Errors
    /// [`BenchError::InvalidSetting`] naming the field.
    pub fn validate(&self) -> Result<()> {
        let names = self.solver_names();
        if let Some((k, name)) = names.iter().enumerate().find(|(k, n)| names[..*k].contains(n)) {
            return Err(BenchError::InvalidSetting {
                name: "solvers",
                reason: format!("two solvers are named `{name}` (the second is solver {})", k + 1),
            });
        }
        if let Some(name) = names
            .iter()
            .find(|n| n.trim().is_empty() || n.contains(['\n', ',', '|']))
        {
            return Err(BenchError::InvalidSetting {
                name: "solvers",
                reason: format!("the solver name {name:?} is empty or holds a newline, comma or `|`"),
            });
        }
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
    execute_with(settings, None)
}

/// [`execute`], with the runs `given` (a merge of shards' records and
/// their wall time, seconds) in place of running the solvers.
pub(crate) fn execute_with(settings: &RunnerSettings, given: Option<(RecordFile, f64)>) -> Result<(Analysis, Stamp)> {
    settings.validate()?;
    // a filter that matches nothing is refused before anything is written
    // (issue 37, case 5: a typo replaced the saved runs by none)
    if let Some(filter) = &settings.filter
        && !settings.set.names()?.iter().any(|name| name.contains(filter.as_str()))
    {
        return Err(BenchError::NoInstance {
            filter: filter.clone(),
            set: settings.set.name(),
        });
    }
    let load_before = Stamp::load();
    let runs_path = settings.out.join("runs.json");
    // one writer per directory, for the whole run: a second one is refused
    // before it runs anything
    store::create_output_dir(&settings.out)?;
    let _lock = store::DirLock::acquire(&settings.out, LOCK_FILE, std::time::Duration::from_secs(2))?;
    store::remove_stale_temporaries(&settings.out)?;
    preflight(settings)?;
    let marker = settings.out.join(INCOMPLETE_MARKER);
    if store::check_output(&marker)?.is_some() {
        note(&format!(
            "{}: the last run into this directory was stopped while writing its files, so its tables, \
             profiles and reports may not be runs.json's; this run rewrites them",
            settings.out.display()
        ));
    }
    let started = std::time::Instant::now();
    let given_seconds = given.as_ref().map(|(_, s)| *s);
    let mut whole_set = true;
    let ours = if settings.reuse {
        if store::check_output(&runs_path)?.is_none() {
            return Err(BenchError::InvalidSetting {
                name: "reuse",
                reason: format!(
                    "{} holds no runs.json to reuse; run without --reuse",
                    settings.out.display()
                ),
            });
        }
        RecordFile::load(&runs_path)?
    } else {
        let runs = match &given {
            Some((file, _)) => file.runs.clone(),
            None => jobs::run_all(settings)?,
        };
        if runs.is_empty() {
            return Err(BenchError::NoRuns {
                solvers: settings.solver_names().join(", "),
                set: settings.set.name(),
                what: settings
                    .filter
                    .as_ref()
                    .map_or("any instance".into(), |f| format!("the instances matching `{f}`")),
            });
        }
        let file = match given {
            Some((file, _)) => file,
            None => {
                let mut file = RecordFile::new(
                    format!(
                        "nprl-bench {} ({:.1} s for the runs)",
                        env!("CARGO_PKG_VERSION"),
                        started.elapsed().as_secs_f64()
                    ),
                    runs,
                );
                file.made_by = Some(MadeBy {
                    code_version: store::code_version().to_string(),
                    budget_simplex_gradients: settings.budget.simplex_gradients,
                    budget_time_s: settings.budget.time.as_secs_f64(),
                });
                file
            }
        };
        let saved = match store::check_output(&runs_path)? {
            Some(_) => Some(RecordFile::load(&runs_path)?),
            None => None,
        };
        let merged = merge_runs(saved, file, &runs_path, settings.force)?;
        whole_set = !merged.kept_saved;
        if merged.kept_saved {
            note(&format!(
                "{}: {} runs of this run replaced or joined the saved ones; it holds {} runs",
                runs_path.display(),
                merged.new,
                merged.file.runs.len()
            ));
        }
        begin_generation(&marker)?;
        merged.file.save(&runs_path)?;
        merged.file
    };
    if settings.reuse {
        begin_generation(&marker)?;
    }
    // the code and budget that made the runs; for records saved before they
    // were recorded, this binary's and the command line's
    let made_by = ours.made_by.clone().unwrap_or_else(|| MadeBy {
        code_version: store::code_version().to_string(),
        budget_simplex_gradients: settings.budget.simplex_gradients,
        budget_time_s: settings.budget.time.as_secs_f64(),
    });
    let elapsed_s = if settings.reuse {
        0.0
    } else {
        given_seconds.unwrap_or_else(|| started.elapsed().as_secs_f64())
    };
    let repeats = ours.runs.first().map_or(settings.repeats, |r| r.repeats);
    // a subset merged into a saved set is judged with the whole set, every
    // solver of it in its column
    let (filter, solvers) = if whole_set {
        (settings.filter.as_deref(), settings.solver_names())
    } else {
        let mut names: Vec<String> = Solver::ALL.iter().map(|s| s.name().to_string()).collect();
        names.extend(
            settings
                .solver_names()
                .into_iter()
                .filter(|n| !names.contains(n))
                .collect::<Vec<_>>(),
        );
        (None, names)
    };
    let (analysis, sources) = analyse(settings.set, filter, &solvers, ours, &settings.out, &settings.outside)?;
    let (commit, dirty) = store::parse_code_version(&made_by.code_version);
    let stamp = Stamp {
        commit: commit.unwrap_or("unknown").to_string(),
        dirty,
        cores: std::thread::available_parallelism().map_or(1, usize::from),
        load_before,
        load_after: Stamp::load(),
        date: Stamp::date(),
        runs: analysis.runs.iter().flatten().flatten().count(),
        repeats,
        budget_simplex_gradients: made_by.budget_simplex_gradients,
        budget_time_s: made_by.budget_time_s,
        sources,
        elapsed_s,
    };
    write_all(&analysis, &stamp, settings)?;
    // every file of this generation is written: the marker goes last
    store::remove_output(&marker)?;
    Ok((analysis, stamp))
}

/// Refuses, before any run, an output directory holding a symbolic link,
/// a device, a FIFO or a socket (every file of `OUT` is the program's, and
/// none is written through a link), and report files that are not regular
/// files: a planted link is named, never followed, and no run's work is
/// lost to a refusal at the end.
///
/// # Errors
/// [`store::StoreError::NotRegular`] naming the entry.
fn preflight(settings: &RunnerSettings) -> Result<()> {
    let out = &settings.out;
    for entry in std::fs::read_dir(out).map_err(BenchError::io(out))? {
        let path = entry.map_err(BenchError::io(out))?.path();
        if !std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_dir()) {
            store::check_output(&path)?;
        }
    }
    let stem = settings.set.report_stem();
    for name in [
        format!("{stem}.md"),
        format!("{stem}.json"),
        "benchmarks_summary.md".into(),
    ] {
        store::check_output(&settings.report_dir.join(name))?;
    }
    Ok(())
}

/// The lock file `nprl-bench` holds in its output directory for a run.
pub const LOCK_FILE: &str = ".nprl-bench.lock";

/// The file that says a run's files are being written: present from just
/// before `runs.json` is replaced until every table, profile and report of
/// the same run is written, so that a run stopped in between is detected
/// (and repaired) by the next one, or by `--reuse`.
pub const INCOMPLETE_MARKER: &str = ".nprl-bench.incomplete";

/// Writes the generation marker ([`INCOMPLETE_MARKER`]).
fn begin_generation(marker: &Path) -> Result<()> {
    let text = format!(
        "nprl-bench (pid {}) is writing runs.json, its tables, profiles and reports; if this file outlives it, \
         rerun with --reuse to rewrite them from runs.json\n",
        std::process::id()
    );
    Ok(store::replace_file(marker, text.as_bytes())?)
}

/// Says `text` on standard error; a closed stderr loses the line, never
/// the work.
pub(crate) fn note(text: &str) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stderr(), "nprl-bench: {text}");
}

/// What [`merge_runs`] made.
#[derive(Debug, Clone)]
pub struct Merged {
    /// The records to save.
    pub file: RecordFile,
    /// Whether saved runs that this run did not make again were kept.
    pub kept_saved: bool,
    /// How many runs this run made.
    pub new: usize,
}

/// Merges this run's records `new` into the result set `saved` (read from
/// `path`), keyed by [`RunRecord::key`]:
/// - no saved set, or a run that made every saved run again: `new` alone;
/// - a subset made by the same code with the same budget: the saved runs
///   with this run's replacing those of the same key, new keys added;
/// - a subset made otherwise: refused ([`BenchError::WouldMix`]: one
///   result set never mixes code versions or budgets), unless `force`,
///   which replaces the saved set by `new`.
///
/// # Errors
/// [`BenchError::WouldMix`]; [`BenchError::BadField`] when `new` holds
/// two runs of one key.
pub fn merge_runs(saved: Option<RecordFile>, new: RecordFile, path: &Path, force: bool) -> Result<Merged> {
    let mut keys = std::collections::BTreeSet::new();
    for (index, run) in new.runs.iter().enumerate() {
        if !keys.insert(run.key()) {
            return Err(BenchError::BadField {
                path: path.to_path_buf(),
                index,
                field: "solver",
                reason: format!(
                    "a second run of {} on {} at scale {}",
                    run.solver, run.problem, run.scale
                ),
            });
        }
    }
    let n_new = new.runs.len();
    let whole = |file| Merged {
        file,
        kept_saved: false,
        new: n_new,
    };
    let Some(saved) = saved.filter(|s| !s.runs.is_empty()) else {
        return Ok(whole(new));
    };
    if saved.runs.iter().all(|r| keys.contains(&r.key())) {
        return Ok(whole(new));
    }
    let same_maker = saved.made_by.is_some()
        && saved.made_by == new.made_by
        && saved.runs.first().map(|r| r.repeats) == new.runs.first().map(|r| r.repeats);
    if !same_maker {
        if force {
            return Ok(whole(new));
        }
        let by = |f: &RecordFile| {
            f.made_by
                .as_ref()
                .map_or("code that did not record itself".into(), |m| {
                    format!(
                        "{} at {} simplex gradients and {} s per run, {} repeats",
                        m.code_version,
                        m.budget_simplex_gradients,
                        m.budget_time_s,
                        f.runs.first().map_or(0, |r| r.repeats)
                    )
                })
        };
        return Err(BenchError::WouldMix {
            path: path.to_path_buf(),
            saved: saved.runs.len(),
            saved_by: by(&saved),
            new: n_new,
            new_by: by(&new),
        });
    }
    let mut fresh: BTreeMap<RunKey, RunRecord> = new.runs.into_iter().map(|r| (r.key(), r)).collect();
    let mut runs: Vec<RunRecord> = saved
        .runs
        .into_iter()
        .map(|r| fresh.remove(&r.key()).unwrap_or(r))
        .collect();
    let mut added: Vec<RunRecord> = fresh.into_values().collect();
    runs.append(&mut added);
    let file = RecordFile {
        runs,
        source: new.source,
        ..saved
    };
    Ok(Merged {
        file,
        kept_saved: true,
        new: n_new,
    })
}

/// Judges saved records: `ours` (a `runs.json`) with the outside records
/// of `out/outside/*.json` and `outside`, on the instances of `set`
/// whose names contain `filter`. On the MGH and NIST sets $f(x_0)$ and
/// $f$ are recomputed from the instances ([`minima::recompute`]) and the
/// runs judged at the minimum. Returns the analysis and the records'
/// sources; writes nothing. `solvers` names our solvers (the ones with
/// time profiles) and orders their columns (a solver without records gets
/// none).
///
/// # Errors
/// An outside records file that cannot be read or is malformed (naming
/// it), or a set whose instances cannot be built.
pub fn analyse(
    set: ProblemSet,
    filter: Option<&str>,
    solvers: &[String],
    ours: RecordFile,
    out: &Path,
    outside: &[PathBuf],
) -> Result<(Analysis, Vec<String>)> {
    let mut sources = vec![ours.source.clone()];
    let mut all: Vec<RunRecord> = ours.runs;
    for path in outside_files(&out.join("outside"), outside)? {
        let file = RecordFile::load(&path)?;
        sources.push(format!("{} ({})", file.source, path.display()));
        all.extend(file.runs);
    }
    // the MGH and NIST sets are judged at the minimum, by numbers computed
    // here: f(x0) of every record from its instance's start, f at its
    // stored x
    let mut references = BTreeMap::new();
    let mut discrepancies = Vec::new();
    if matches!(set, ProblemSet::Mgh | ProblemSet::Nist) {
        let instances = set.instances(filter)?;
        // records of instances not in this run's set (a filter) are left out
        all.retain(|r| {
            instances
                .iter()
                .any(|i| i.set == r.set && i.problem == r.problem && i.scale == r.scale)
        });
        discrepancies = minima::recompute(&mut all, &instances);
        for i in &instances {
            if let Some(r) = Reference::of(i) {
                references.insert((i.set.to_string(), i.problem.clone(), format!("{}", i.scale)), r);
            }
        }
    } else if set == ProblemSet::Trajectory {
        // the trajectory set is judged relative to the best run, on the
        // figure of merit recomputed here from each record's final point
        let instances = set.instances(filter)?;
        all.retain(|r| instances.iter().any(|i| i.problem == r.problem && i.scale == r.scale));
        discrepancies = crate::trajectory::recompute(&mut all, &instances);
    }
    // a solver that applies to none of the instances gets no column
    let our_names: Vec<String> = solvers
        .iter()
        .filter(|name| all.iter().any(|r| r.solver == **name))
        .cloned()
        .collect();
    let mut analysis = Analysis::new(all, &our_names)
        .with_test(set.test())
        .with_references(|key| references.get(key).cloned());
    analysis.discrepancies = discrepancies;
    Ok((analysis, sources))
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
fn write_all(a: &Analysis, stamp: &Stamp, settings: &RunnerSettings) -> Result<()> {
    let (out, report_dir) = (settings.out.as_path(), settings.report_dir.as_path());
    let set = settings.set;
    report::write(&out.join("table.csv"), &report::runs_csv(a)?)?;
    let all: Vec<usize> = (0..a.solvers.len()).collect();
    let free: Vec<usize> = all.iter().copied().filter(|&s| a.derivative_free[s]).collect();
    let label = set.name().to_uppercase();
    let mut profiles = serde_json::Map::new();
    for tau in a.taus() {
        // times only among our (compiled) solvers: the outside ones run from Python
        let ours = a.our_columns();
        let (time, _) = a.performance(tau, &ours);
        let (_, evals) = a.performance(tau, &all);
        let data = a.data(tau, &free);
        let tag = tau_tag(tau);
        let rows = a.common_rows(&all).len();
        let figures = [
            (
                "perf_time",
                format!(
                    "Performance profile, time, ours only, tau = {tau:e} ({} {label} instances)",
                    a.common_rows(&ours).len()
                ),
                "ratio to the fastest (alpha)",
                1.0,
                &time,
            ),
            (
                "perf_evals",
                format!("Performance profile, evaluations, tau = {tau:e} ({rows} {label} instances)"),
                "ratio to the fewest evaluation equivalents (alpha)",
                1.0,
                &evals,
            ),
            (
                "data",
                format!(
                    "Data profile, derivative-free, tau = {tau:e} ({} {label} instances)",
                    a.common_rows(&free).len()
                ),
                "budget in simplex gradients, evaluations / (n + 1) (kappa)",
                0.1,
                &data,
            ),
        ];
        for (stem, title, x_label, x_min, profiles) in figures {
            ProfileFigure {
                title,
                x_label,
                x_min,
                profiles,
            }
            .write(out, &format!("{stem}_{tag}"))?;
        }
        profiles.insert(tag, json!({"tau": tau, "time": time, "evals": evals, "data": data}));
    }
    let profiles_text = serde_json::to_string(&profiles).unwrap_or_default();
    report::write(&out.join("profiles.json"), &(profiles_text + "\n"))?;

    // the goals and the summary are the MGH set's
    let mgh = set == ProblemSet::Mgh;
    let goals = if mgh { report::goals(a) } else { Vec::new() };
    let summary = if mgh { report::summary(a) } else { Vec::new() };
    let summary_md = report::summary_markdown(&summary, stamp);
    if mgh {
        report::write(&report_dir.join("benchmarks_summary.md"), &summary_md)?;
    }
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
                    "objective": r.objective,
                    "degenerate": a.degenerate(p), "at_minimum": a.at_minimum(p, s), "lre": a.lre(p, s),
                    "outcomes": a.taus().iter().map(|&t| json!({"tau": t, "outcome": a.outcome(p, s, t)})).collect::<Vec<_>>(),
                }))
            })
        })
        .collect();
    let references: Vec<_> = a
        .instances
        .iter()
        .zip(&a.references)
        .filter_map(|(key, r)| {
            let r = r.as_ref()?;
            Some(json!({"problem": key.1, "scale": key.2, "f0": r.f0, "f_star": r.f_star, "source": r.source, "degenerate": r.degenerate}))
        })
        .collect();
    let report_json = json!({
        "stamp": stamp, "goals": goals, "summary": summary, "solvers": a.solvers,
        "criterion": match set {
            ProblemSet::Nist => Some(json!({"at_minimum": "LRE of the parameters >= digits", "digits": crate::nist::HEADLINE_DIGITS, "reported": crate::nist::DIGITS})),
            _ => a.has_references().then(|| json!({"at_minimum": "f <= f* + tol_rel (1 + |f*|)", "tol_rel": minima::TOL_REL})),
        },
        "references": references, "discrepancies": a.discrepancies, "runs": outcomes,
    });
    let stem = set.report_stem();
    report::write(
        &report_dir.join(format!("{stem}.json")),
        &(serde_json::to_string_pretty(&report_json).unwrap_or_default() + "\n"),
    )?;
    let summary_md = mgh.then_some(summary_md);
    report::write(
        &report_dir.join(format!("{stem}.md")),
        &markdown(a, stamp, &goals, summary_md.as_deref(), set, out, report_dir),
    )
}

fn markdown(
    a: &Analysis,
    stamp: &Stamp,
    goals: &[report::Goal],
    summary_md: Option<&str>,
    set: ProblemSet,
    out: &Path,
    report_dir: &Path,
) -> String {
    let rel = relative_dir(report_dir, out);
    let title = match set {
        ProblemSet::Mgh => "Benchmarks",
        ProblemSet::Trajectory => "Benchmarks: the trajectory set",
        ProblemSet::Nist => "Benchmarks: the NIST StRD set",
    };
    let mut s = format!(
        "# {title}\n\nGenerated by `nprl-bench` (see `bench/README.md`); do not edit. Commit {}{}, {} cores, load {} before and {} after, {} runs (each of ours timed {} times, median), budget {} simplex gradients and {} s per run, {}; our runs took {:.1} s of wall time.\n\nSources: {}.\n\n",
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
    if let Some(summary_md) = summary_md {
        s.push_str(&format!(
            "## Criterion\n\nA run is solved when it ends **at the minimum**: its final f (computed here at its final x) satisfies f <= f* + {:e} (1 + |f*|), f* the best-known minimum below (the same from every start). Degenerate instances are left out of every count. Moré and Wild's test at tau (performance and data profiles, the tau columns) counts a run only if it also ends at the minimum; its evaluations are those at which its trace first met the test at tau. See `bench/README.md`.\n\n",
            minima::TOL_REL
        ));
        s.push_str("## Goals (issues 21 and 33)\n\n");
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
        s.push_str(&format!("\n## Summary (at the minimum)\n\n{summary_md}\n"));
    } else if set == ProblemSet::Nist {
        s.push_str(&format!(
            "## Criterion\n\nThe 27 NIST StRD nonlinear regression problems from both certified starts; f is the residual sum of squares (computed here at each run's final x). A run is solved when its final parameters agree with NIST's certified ones to at least {} significant digits: the log relative error, LRE = -log10(|b - c| / |c|), smallest over the parameters, capped at 11 (Ceres's convention and threshold); 6 digits are reported too. A solved run's evaluations are all it spent. Moré and Wild's test at tau (the profiles) counts a run only if it is also solved so. See `bench/README.md`.\n\n## Digits per solver\n\n{}\n",
            crate::nist::HEADLINE_DIGITS,
            report::nist_markdown(a)
        ));
    } else {
        s.push_str(
            "Figure of merit: the task cost of each run's final controls rolled out through the exact dynamics (`pendulum-lwr`: its Eq. 3 criterion); solved at tau when within tau (relative) of the best any solver found on the instance. Evaluations of a solved run: all it spent (`pendulum-lwr`: those at which its trace first passed, as on the MGH set). See `bench/README.md`.\n\n");
    }
    s.push_str(&format!("## Solvers\n\n{}\n", report::solvers_markdown(a)));
    s.push_str("## Figures\n\n");
    for tau in a.taus() {
        let tag = tau_tag(tau);
        s.push_str(&format!(
            "- tau = {tau:e}: [time]({rel}/perf_time_{tag}.svg), [evaluations]({rel}/perf_evals_{tag}.svg), [data profile]({rel}/data_{tag}.svg)\n"
        ));
    }
    if a.has_references() {
        s.push_str(&format!("\n## Best-known minima\n\n{}", report::references_markdown(a)));
    } else {
        s.push_str(&report::checks_markdown(a));
    }
    let criterion = match a.headline() {
        Criterion::AtMinimum if set == ProblemSet::Nist => format!(
            "agrees with the certified parameters to {} digits",
            crate::nist::HEADLINE_DIGITS
        ),
        Criterion::AtMinimum => "ended at the minimum".to_string(),
        Criterion::Tau(tau) => format!("solved its instance at tau = {tau:e}"),
    };
    s.push_str(&format!(
        "\n## Per problem\n\nFinal f per solver; **bold** where the run {criterion}, with its evaluation equivalents to get there in parentheses; otherwise the status in brackets. f* / f_L as in `bench/README.md`.\n\n{}",
        report::problems_markdown(a)
    ));
    s
}

/// The path from the directory `from` to the directory `to`, for links in
/// a report written in `from` to figures in `to`: `.` when they are the
/// same, `a/b` below, `../x` beside. Both are resolved first (links,
/// `..`); when either cannot be, `to` as given, made absolute.
fn relative_dir(from: &Path, to: &Path) -> String {
    let (Ok(from), Ok(to)) = (from.canonicalize(), to.canonicalize()) else {
        return std::path::absolute(to)
            .unwrap_or_else(|_| to.to_path_buf())
            .display()
            .to_string();
    };
    let (a, b): (Vec<_>, Vec<_>) = (from.components().collect(), to.components().collect());
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut rel = PathBuf::new();
    for _ in common..a.len() {
        rel.push("..");
    }
    for c in &b[common..] {
        rel.push(c);
    }
    if rel.as_os_str().is_empty() {
        ".".into()
    } else {
        rel.display().to_string()
    }
}

/// The default budget: 2000 simplex gradients and 10 s per run.
pub fn default_budget() -> Budget {
    Budget {
        simplex_gradients: 2000,
        time: Duration::from_secs(10),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Figure links in a report resolve from the report's directory,
    /// wherever the figures are (the same directory gave `/perf_...svg`).
    #[test]
    fn figure_links_are_relative_to_the_report() {
        let scratch = store::ScratchDir::new("bench-rel").expect("scratch dir");
        let root = scratch.path();
        for d in ["results/figs", "elsewhere/runs"] {
            std::fs::create_dir_all(root.join(d)).expect("dirs");
        }
        let results = root.join("results");
        assert_eq!(relative_dir(&results, &results), ".");
        assert_eq!(relative_dir(&results, &root.join("results/figs")), "figs");
        assert_eq!(relative_dir(&root.join("results/figs"), &results), "..");
        assert_eq!(
            relative_dir(&results, &root.join("elsewhere/runs")),
            "../elsewhere/runs"
        );
        assert_eq!(relative_dir(&root.join("results/./figs/.."), &results), ".");
        for (from, to) in [
            ("results", "elsewhere/runs"),
            ("results/figs", "results"),
            ("results", "results"),
        ] {
            let rel = relative_dir(&root.join(from), &root.join(to));
            let resolved = root.join(from).join(&rel).canonicalize().expect("resolves");
            assert_eq!(resolved, root.join(to).canonicalize().expect("exists"));
        }
    }

    /// Issue 37, case 5: `--filter rosenbrok` (a typo) used to replace the
    /// saved runs and reports with none and exit 0.
    #[test]
    fn a_filter_that_matches_nothing_is_refused_and_the_saved_runs_are_kept() {
        let scratch = store::ScratchDir::new("bench-typo").expect("scratch dir");
        let dir = scratch.path().to_path_buf();
        let runs = dir.join("runs.json");
        std::fs::write(&runs, "saved").expect("write");
        for set in [ProblemSet::Mgh, ProblemSet::Nist, ProblemSet::Trajectory] {
            let settings = RunnerSettings {
                set,
                solvers: vec![Arc::new(Solver::GaussNewton)],
                filter: Some("rosenbrok".into()),
                budget: default_budget(),
                repeats: 1,
                out: dir.clone(),
                report_dir: dir.clone(),
                outside: vec![],
                reuse: false,
                force: false,
            };
            let err = execute(&settings).expect_err("refused").to_string();
            assert!(err.contains("rosenbrok") && err.contains(set.name()), "{err}");
        }
        assert_eq!(std::fs::read_to_string(&runs).expect("kept"), "saved");
        assert_eq!(std::fs::read_dir(&dir).expect("dir").count(), 1, "nothing else written");
    }

    #[test]
    fn the_trajectory_set_runs_every_solver_on_a_tiny_instance_and_writes_its_own_files() {
        let scratch = store::ScratchDir::new("bench-smoke").expect("scratch dir");
        let dir = scratch.path().to_path_buf();
        let settings = RunnerSettings {
            set: ProblemSet::Trajectory,
            solvers: Solver::parse_entries("all").expect("all"),
            filter: Some("pendulum-h50-lambda1e2".into()),
            budget: Budget {
                simplex_gradients: 3,
                time: Duration::from_secs(5),
            },
            repeats: 1,
            out: dir.join("benchmarks/trajectory"),
            report_dir: dir.clone(),
            outside: vec![],
            reuse: false,
            force: false,
        };
        let (analysis, stamp) = execute(&settings).expect("runs");
        assert_eq!(analysis.instances.len(), 1);
        // every record stores its final point, and its f is that point's
        // rollout, recomputed by the runner
        assert!(analysis.runs[0].iter().flatten().all(|r| r.x.is_some()));
        assert!(analysis.discrepancies.is_empty(), "{:?}", analysis.discrepancies);
        // every solver but Nelder-Mead and the geodesic trust region (off the trajectory set) ran
        let ran: Vec<&str> = analysis.runs[0].iter().flatten().map(|r| r.solver.as_str()).collect();
        let expected: Vec<&str> = Solver::ALL
            .iter()
            .filter(|s| !matches!(s, Solver::NelderMead | Solver::TrustRegionGeodesic))
            .map(|s| s.name())
            .collect();
        assert_eq!(ran, expected);
        assert_eq!(stamp.runs, expected.len());
        for r in analysis.runs[0].iter().flatten() {
            // one start, one figure of merit: the rollout of zero controls
            assert_eq!(
                r.f0,
                analysis.runs[0][0].as_ref().expect("gauss-newton").f0,
                "{}",
                r.solver
            );
            assert!(r.objective.is_some() && r.f.is_finite(), "{r:?}");
        }
        // DDP converges on the pendulum: the best value, solved at both taus
        let ilqr = analysis.column("ddp-ilqr").expect("ran");
        assert!(analysis.outcome(0, ilqr, 1e-4).expect("ran").solved);
        for file in [
            "benchmarks/trajectory/runs.json",
            "benchmarks/trajectory/table.csv",
            "benchmarks/trajectory/profiles.json",
            "benchmarks/trajectory/perf_time_tau1e-4.svg",
            "benchmarks/trajectory/perf_evals_tau1e-2.png",
            "benchmarks/trajectory/data_tau1e-4.svg",
            "benchmarks_trajectory.md",
            "benchmarks_trajectory.json",
        ] {
            assert!(dir.join(file).is_file(), "{file} missing");
        }
        // the MGH set's files are not written
        for file in ["benchmarks.md", "benchmarks.json", "benchmarks_summary.md"] {
            assert!(!dir.join(file).exists(), "{file} written");
        }
        // issue 37: the runs record the binary's build and their budget, and
        // a report judged later from them (--reuse, another budget on the
        // command line, another binary) is stamped with those
        let runs_path = dir.join("benchmarks/trajectory/runs.json");
        let saved = RecordFile::load(&runs_path).expect("runs");
        let made_by = saved.made_by.clone().expect("made_by recorded");
        assert_eq!(made_by.code_version, store::code_version());
        assert_eq!(made_by.budget_simplex_gradients, 3);
        let (commit, dirty) = store::parse_code_version(store::code_version());
        assert_eq!(
            (stamp.commit.as_str(), stamp.dirty),
            (commit.unwrap_or("unknown"), dirty)
        );
        let mut other = saved;
        other.made_by = Some(MadeBy {
            code_version: "commit abcdef0".into(),
            ..made_by
        });
        other.save(&runs_path).expect("save");
        let reuse = RunnerSettings {
            reuse: true,
            force: false,
            budget: Budget {
                simplex_gradients: 99,
                time: Duration::from_secs(1),
            },
            ..settings
        };
        let (_, again) = execute(&reuse).expect("reused");
        assert_eq!((again.commit.as_str(), again.dirty), ("abcdef0", false));
        assert_eq!((again.budget_simplex_gradients, again.budget_time_s), (3, 5.0));
        let md = std::fs::read_to_string(dir.join("benchmarks_trajectory.md")).expect("md");
        assert!(
            md.contains("pendulum-h50-lambda1e2") && md.contains("rolled out"),
            "{md}"
        );
    }
}
