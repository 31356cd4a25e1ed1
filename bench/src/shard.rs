//! A benchmark split into shards ([`store::Shard`]: `--shard K/N`, or a
//! Slurm job array's task), and their merge.
//!
//! The runs of a benchmark have a fixed order: instance by instance, the
//! solvers in the command's order, those that apply ([`RunnerSettings`]).
//! Shard $K$ of $N$ makes the runs at positions $p \equiv K - 1 \pmod N$
//! and writes only its own files into `OUT`:
//!
//! | file | what it holds |
//! |---|---|
//! | `shard-K-of-N.json` | the benchmark's settings (set, solvers, filter, budget, repeats), the build that made the shard, and (its scope) the runs it plans and the wall time it spent |
//! | `runs-K-of-N.jsonl` | its runs, one JSON line each, appended whole and synced as each finishes |
//!
//! A shard started again with the same settings makes only its runs not
//! yet saved, so a task killed mid-run and resubmitted loses nothing and
//! duplicates nothing; other settings are refused, naming the keys.
//! [`merge`] checks every shard (the same settings and build, none
//! missing, each finished, no two different records of one run), orders
//! the runs as one process would, and writes `runs.json` and every table,
//! profile and report once, as a whole benchmark run would.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize};
use store::{AppendLog, Manifest, ManifestStatus, Shard};

use crate::analysis::Analysis;
use crate::error::{BenchError, Result};
use crate::problems::{Budget, ProblemSet};
use crate::record::{MadeBy, RecordFile, RunKey, RunRecord};
use crate::report::Stamp;
use crate::runner::jobs::{planned_runs, run_jobs};
use crate::runner::{RunnerSettings, execute_with};

/// The program a shard's manifest records.
pub const PROGRAM: &str = "nprl-bench";

/// The task a shard's manifest records.
pub const TASK: &str = "benchmark shard";

/// What every shard of one benchmark shares (a shard's manifest settings).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardSettings {
    /// The problem set (`mgh`, `nist`, `trajectory`).
    pub set: String,
    /// The solvers' names, in the command's order.
    pub solvers: Vec<String>,
    /// `--filter`.
    pub filter: Option<String>,
    /// The evaluation budget per run, in simplex gradients.
    pub budget_simplex_gradients: u64,
    /// The time budget per run, seconds.
    pub budget_time_s: f64,
    /// Times each solve is timed.
    pub repeats: u32,
}

impl ShardSettings {
    /// The shared settings of `settings`.
    pub fn of(settings: &RunnerSettings) -> Self {
        Self {
            set: settings.set.name().to_string(),
            solvers: settings.solver_names(),
            filter: settings.filter.clone(),
            budget_simplex_gradients: settings.budget.simplex_gradients,
            budget_time_s: settings.budget.time.as_secs_f64(),
            repeats: settings.repeats,
        }
    }
}

/// What a shard's manifest records beyond the settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardScope {
    /// The shard.
    pub shard: Shard,
    /// The keys of its runs, in the benchmark's order.
    pub planned: Vec<RunKey>,
    /// Wall time its invocations spent running, seconds (summed over
    /// resumptions).
    pub seconds: f64,
}

/// The manifest file of shard `shard`: `shard-K-of-N.json`.
pub fn manifest_file_name(shard: Shard) -> String {
    format!("shard{}.json", shard.file_suffix())
}

/// The runs file of shard `shard`: `runs-K-of-N.jsonl`.
pub fn runs_file_name(shard: Shard) -> String {
    format!("runs{}.jsonl", shard.file_suffix())
}

/// What [`run_shard`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct ShardOutcome {
    /// Runs made by this invocation.
    pub ran: usize,
    /// Runs found saved by an earlier invocation (not made again).
    pub resumed: usize,
    /// Runs the shard holds in all.
    pub planned: usize,
    /// The shard's runs file.
    pub runs_file: PathBuf,
}

fn shard_error(dir: &Path, reason: String) -> BenchError {
    BenchError::Shards {
        dir: dir.to_path_buf(),
        reason,
    }
}

/// Runs shard `shard` of the benchmark `settings` into `settings.out`
/// (the module's files), making only the runs not saved there yet; each
/// run is appended to the shard's runs file as it finishes.
///
/// # Errors
/// Bad settings; a shard file there made with other settings (naming
/// the keys) or by another program; a file that cannot be read or
/// written (named); a solver's refusal.
pub fn run_shard(settings: &RunnerSettings, shard: Shard) -> Result<ShardOutcome> {
    settings.validate()?;
    if settings.reuse {
        return Err(BenchError::InvalidSetting {
            name: "reuse",
            reason: "a shard runs; `nprl-bench merge OUT` writes the reports of the shards' runs".into(),
        });
    }
    if let Some(filter) = &settings.filter
        && !settings.set.names()?.iter().any(|name| name.contains(filter.as_str()))
    {
        return Err(BenchError::NoInstance {
            filter: filter.clone(),
            set: settings.set.name(),
        });
    }
    let out = &settings.out;
    store::create_output_dir(out)?;
    // one writer per shard; the shards of one benchmark share the directory
    let lock_name = format!(".nprl-bench{}.lock", shard.file_suffix());
    let _lock = store::DirLock::acquire(out, &lock_name, std::time::Duration::from_secs(2))?;
    let manifest_path = out.join(manifest_file_name(shard));
    let runs_path = out.join(runs_file_name(shard));
    let planned: Vec<RunKey> = planned_runs(settings)?
        .into_iter()
        .enumerate()
        .filter(|(p, _)| shard.contains(*p))
        .map(|(_, k)| k)
        .collect();
    let mut manifest = Manifest::new(
        PROGRAM,
        TASK,
        &ShardSettings::of(settings),
        store::code_version(),
        &manifest_path,
    )?;
    // refused before anything is written when the saved shard differs
    let saved_scope = match Manifest::read(&manifest_path)? {
        Some(saved) => {
            manifest.check_against(&saved, &manifest_path)?;
            if saved.created_by_commit != manifest.created_by_commit {
                return Err(shard_error(
                    out,
                    format!(
                        "{} was started by {} and this is {}: one benchmark's shards are run by one build \
                         (start it over in another --out)",
                        manifest_path.display(),
                        saved.created_by_commit,
                        manifest.created_by_commit
                    ),
                ));
            }
            saved.scope.and_then(|v| serde_json::from_value::<ShardScope>(v).ok())
        }
        None => None,
    };
    let (mut log, contents) = AppendLog::open::<RunRecord>(&runs_path)?;
    if let Some(torn) = &contents.torn {
        crate::runner::note(&format!("{torn}; that run will run again"));
    }
    let mut done: std::collections::BTreeSet<RunKey> = std::collections::BTreeSet::new();
    for (index, run) in contents.records.iter().enumerate() {
        if !planned.contains(&run.key()) || !done.insert(run.key()) {
            return Err(BenchError::BadField {
                path: runs_path.clone(),
                index,
                field: "solver",
                reason: format!(
                    "{} on {} at scale {} is not a run of this shard, or is recorded twice",
                    run.solver, run.problem, run.scale
                ),
            });
        }
    }
    let mut scope = ShardScope {
        shard,
        planned: planned.clone(),
        seconds: saved_scope.map_or(0.0, |s| s.seconds),
    };
    manifest.scope = Some(serde_json::to_value(&scope).map_err(|e| shard_error(out, e.to_string()))?);
    if manifest.create_or_check(&manifest_path)? == ManifestStatus::Matches {
        manifest.write(&manifest_path)?;
    }
    let started = std::time::Instant::now();
    let mut ran = 0;
    let result = run_jobs(
        settings,
        &|position, key| shard.contains(position) && !done.contains(key),
        &mut |run| {
            log.append(&run)?;
            ran += 1;
            Ok(())
        },
    );
    // the wall time is kept even when a run failed
    scope.seconds += started.elapsed().as_secs_f64();
    manifest.scope = Some(serde_json::to_value(&scope).map_err(|e| shard_error(out, e.to_string()))?);
    manifest.write(&manifest_path)?;
    result?;
    Ok(ShardOutcome {
        ran,
        resumed: done.len(),
        planned: planned.len(),
        runs_file: runs_path,
    })
}

/// One shard found in a directory.
struct Found {
    shard: Shard,
    manifest_path: PathBuf,
    manifest: Manifest,
    scope: ShardScope,
}

/// Merges the shards in `dir` (every `shard-K-of-N.json` with its
/// `runs-K-of-N.jsonl`) and writes `dir/runs.json` and every table,
/// profile and report, as [`crate::runner::execute`] does, the reports
/// into `report_dir` (with the outside records of `dir/outside/*.json`
/// and `outside`). The settings are read from the shards.
///
/// # Errors
/// [`BenchError::Shards`] naming the files, shards or runs, before
/// anything is written: no shard; shards of other settings or builds; a
/// shard missing (by index) or unfinished (by index, with its missing
/// runs); two different records of one run. Any error of the reports.
pub fn merge(dir: &Path, report_dir: PathBuf, outside: Vec<PathBuf>) -> Result<(Analysis, Stamp)> {
    let mut found: Vec<Found> = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(BenchError::io(dir))? {
        let name = entry.map_err(BenchError::io(dir))?.file_name();
        let Some(shard) = name
            .to_str()
            .and_then(|n| n.strip_prefix("shard")?.strip_suffix(".json"))
            .and_then(Shard::from_file_suffix)
        else {
            continue;
        };
        let manifest_path = dir.join(&name);
        let manifest = Manifest::read(&manifest_path)?
            .ok_or_else(|| shard_error(dir, format!("{} vanished", manifest_path.display())))?;
        if (manifest.program.as_str(), manifest.task.as_str()) != (PROGRAM, TASK) {
            return Err(store::StoreError::TaskMismatch {
                path: manifest_path,
                saved_program: manifest.program,
                saved_task: manifest.task,
                program: PROGRAM.into(),
                task: TASK.into(),
            }
            .into());
        }
        let scope: ShardScope = manifest
            .scope
            .clone()
            .and_then(|v| serde_json::from_value(v).ok())
            .filter(|s: &ShardScope| s.shard == shard)
            .ok_or_else(|| {
                shard_error(
                    dir,
                    format!("{} records no runs of shard {shard}", manifest_path.display()),
                )
            })?;
        found.push(Found {
            shard,
            manifest_path,
            manifest,
            scope,
        });
    }
    found.sort_by_key(|f| f.shard);
    let Some(first) = found.first() else {
        return Err(shard_error(
            dir,
            "holds no shard (no shard-K-of-N.json); run the shards into it first (nprl-bench --shard K/N \
             --out DIR, or a Slurm job array)"
                .into(),
        ));
    };
    for f in &found[1..] {
        let keys = store::differing_keys(&first.manifest.settings, &f.manifest.settings);
        if !keys.is_empty() {
            return Err(shard_error(
                dir,
                format!(
                    "{} and {} record other settings ({}): shards of two different benchmarks",
                    first.manifest_path.display(),
                    f.manifest_path.display(),
                    keys.join(", ")
                ),
            ));
        }
        if f.manifest.created_by_commit != first.manifest.created_by_commit {
            return Err(shard_error(
                dir,
                format!(
                    "{} was made by {} and {} by {}: one benchmark's shards are run by one build",
                    first.manifest_path.display(),
                    first.manifest.created_by_commit,
                    f.manifest_path.display(),
                    f.manifest.created_by_commit
                ),
            ));
        }
    }
    let counts: Vec<usize> = {
        let mut c: Vec<usize> = found.iter().map(|f| f.shard.count).collect();
        c.sort_unstable();
        c.dedup();
        c
    };
    if counts.len() > 1 {
        return Err(shard_error(
            dir,
            format!(
                "holds shards of {} counts ({}): one benchmark is split one way; move the others out",
                counts.len(),
                counts.iter().map(|n| format!("of {n}")).collect::<Vec<_>>().join(", ")
            ),
        ));
    }
    let shards: Vec<Shard> = found.iter().map(|f| f.shard).collect();
    if let Some((n, absent)) = Shard::missing(&shards).into_iter().next() {
        return Err(shard_error(
            dir,
            format!(
                "lacks shard{} {} of {n} ({} absent); run them into it, then merge again",
                if absent.len() == 1 { "" } else { "s" },
                absent.iter().map(ToString::to_string).collect::<Vec<_>>().join(", "),
                absent
                    .iter()
                    .map(|&k| manifest_file_name(Shard { index: k, count: n }))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    let settings: ShardSettings = serde_json::from_value(first.manifest.settings.clone()).map_err(|e| {
        shard_error(
            dir,
            format!("{}: not a benchmark's settings: {e}", first.manifest_path.display()),
        )
    })?;
    // every shard's runs, each once, in the order one process makes them
    let n = first.shard.count;
    let mut runs: Vec<(usize, RunRecord)> = Vec::new();
    let mut source_of: std::collections::BTreeMap<RunKey, (PathBuf, usize)> = std::collections::BTreeMap::new();
    let mut unfinished: Vec<String> = Vec::new();
    for f in &found {
        let path = dir.join(runs_file_name(f.shard));
        let contents = store::read_log::<RunRecord>(&path)?;
        for (index, run) in contents.records.into_iter().enumerate() {
            let key = run.key();
            let Some(j) = f.scope.planned.iter().position(|k| *k == key) else {
                return Err(shard_error(
                    dir,
                    format!(
                        "{} record {}: {} on {} at scale {} is not a run shard {} planned",
                        path.display(),
                        index + 1,
                        run.solver,
                        run.problem,
                        run.scale,
                        f.shard
                    ),
                ));
            };
            if let Some((other, at)) = source_of.get(&key) {
                let same = runs.iter().any(|(_, r)| r.key() == key && *r == run);
                if !same {
                    return Err(shard_error(
                        dir,
                        format!(
                            "{} record {} and {} record {} are two different records of one run ({} on {} \
                             at scale {}); remove the one that is not wanted",
                            other.display(),
                            at,
                            path.display(),
                            index + 1,
                            run.solver,
                            run.problem,
                            run.scale
                        ),
                    ));
                }
                continue;
            }
            source_of.insert(key, (path.clone(), index + 1));
            runs.push((f.shard.index - 1 + j * n, run));
        }
        let lacking: Vec<&RunKey> = f.scope.planned.iter().filter(|k| !source_of.contains_key(*k)).collect();
        if let Some((_, problem, scale, solver)) = lacking.first() {
            unfinished.push(format!(
                "shard {} ({}) lacks {} of its {} runs, {solver} on {problem} at scale {}{}",
                f.shard,
                path.display(),
                lacking.len(),
                f.scope.planned.len(),
                f64::from_bits(*scale),
                if lacking.len() > 1 { " and more" } else { "" }
            ));
        }
    }
    if !unfinished.is_empty() {
        return Err(shard_error(
            dir,
            format!(
                "the benchmark is not finished: {}; run those shards again (each makes only its missing runs)",
                unfinished.join("; ")
            ),
        ));
    }
    runs.sort_by_key(|(p, _)| *p);
    let seconds: f64 = found.iter().map(|f| f.scope.seconds).sum();
    let mut file = RecordFile::new(
        format!(
            "nprl-bench {} ({:.1} s for the runs, summed over {n} shards)",
            env!("CARGO_PKG_VERSION"),
            seconds
        ),
        runs.into_iter().map(|(_, r)| r).collect(),
    );
    file.made_by = Some(MadeBy {
        code_version: first.manifest.created_by_commit.clone(),
        budget_simplex_gradients: settings.budget_simplex_gradients,
        budget_time_s: settings.budget_time_s,
    });
    let set = ProblemSet::parse(&settings.set)?;
    let runner = RunnerSettings {
        set,
        // names only: the merge runs nothing
        solvers: settings
            .solvers
            .iter()
            .map(|name| {
                Arc::new(crate::open::from_fn(name.clone(), |_| {
                    Err("a merge runs no solver".to_string())
                })) as Arc<dyn crate::open::BenchSolver>
            })
            .collect(),
        filter: settings.filter.clone(),
        budget: Budget {
            simplex_gradients: settings.budget_simplex_gradients,
            time: std::time::Duration::try_from_secs_f64(settings.budget_time_s)
                .map_err(|e| shard_error(dir, format!("{}: budget_time_s: {e}", first.manifest_path.display())))?,
        },
        repeats: settings.repeats,
        out: dir.to_path_buf(),
        report_dir,
        outside,
        reuse: false,
        force: false,
    };
    execute_with(&runner, Some((file, seconds)))
}
