//! A grid's directory: its parts (the grid, or each shard of it), each a
//! write-once manifest of the settings (`settings.json`, or
//! `settings-K-of-N.json` for shard K of N) and the runs made with them
//! (`runs.jsonl`, or `runs-K-of-N.jsonl`), kept by the storage layer
//! ([`store`]): a run is appended whole and synced, a torn last record is
//! moved aside and reported, the reports are replaced atomically.
//!
//! The rules:
//! - a fresh grid refuses a part that holds runs (before writing
//!   anything) unless `--force`;
//! - a resumed grid, or a report of saved runs, refuses a part whose
//!   settings differ from the command's, naming the file and the keys;
//!   every run carries a fingerprint of its settings
//!   ([`ExperimentSettings::digest`]), so a settings file edited by hand
//!   is refused too;
//! - only the declared parts are read: a `runs*.jsonl` file without its
//!   settings file (a backup, a copy) is never merged;
//! - a run that cannot be saved stops the grid at once, naming the file;
//! - a refused grid changes nothing: every check is made before the
//!   part's runs file is repaired or its settings file written (a fresh
//!   grid writes its settings file only when its runs file is empty).
//!
//! Directories saved before manifests (`settings.json` holding the bare
//! settings) are read as before: `runs.jsonl` and `runs-K-of-N.jsonl`.

use std::path::{Path, PathBuf};

use store::{AppendLog, Manifest};

use crate::experiments::{Experiment, ExperimentSettings, ExperimentsReport, RunSummary, Shard, run_experiments};

/// The file of an unsharded grid's settings (its manifest).
pub const SETTINGS_FILE: &str = "settings.json";

/// The program a grid's manifest records.
pub const PROGRAM: &str = "swingup experiments";

/// The task a grid's manifest records.
pub const TASK: &str = "experiments grid";

/// The settings file of a part: `settings.json`, or `settings-K-of-N.json`.
pub fn settings_file_name(shard: Option<Shard>) -> String {
    match shard {
        Some(s) => format!("settings-{}-of-{}.json", s.index, s.count),
        None => SETTINGS_FILE.into(),
    }
}

/// The runs file of a part: `runs.jsonl`, or `runs-K-of-N.jsonl`.
pub fn runs_file_name(shard: Option<Shard>) -> String {
    match shard {
        Some(s) => format!("runs-{}-of-{}.jsonl", s.index, s.count),
        None => "runs.jsonl".into(),
    }
}

/// The shard a part's file name (`settings-2-of-4.json`, `runs-2-of-4.jsonl`)
/// names, strictly: `Some(None)` for the unsharded files.
fn part_of(name: &str, stem: &str, ext: &str) -> Option<Option<Shard>> {
    let rest = name.strip_prefix(stem)?.strip_suffix(ext)?;
    if rest.is_empty() {
        return Some(None);
    }
    let (k, n) = rest.strip_prefix('-')?.split_once("-of-")?;
    let shard: Shard = format!("{k}/{n}").parse().ok()?;
    (format!("-{}-of-{}", shard.index, shard.count) == rest).then_some(Some(shard))
}

/// One part of a grid's directory.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// The shard, or `None` for the grid's own part.
    pub shard: Option<Shard>,
    /// Its settings file.
    pub settings: PathBuf,
    /// Its runs file.
    pub runs: PathBuf,
}

/// A grid's manifest of `settings`.
///
/// # Errors
/// The settings cannot be serialised.
pub fn grid_manifest(settings: &ExperimentSettings, path: &Path) -> crate::Result<Manifest> {
    Ok(Manifest::new(
        PROGRAM,
        TASK,
        settings,
        &crate::experiments::sensitivity::code_version(),
        path,
    )?)
}

/// The settings recorded in a part's settings file: a manifest, or (a
/// directory saved before manifests) the bare settings, `legacy` then.
/// Read through the settings type, so a setting added since counts as
/// its default.
fn read_part_settings(path: &Path) -> crate::Result<Option<(ExperimentSettings, bool)>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(crate::Error::io("reading", path, e)),
    };
    if let Ok(m) = serde_json::from_str::<Manifest>(&text) {
        if (m.program.as_str(), m.task.as_str()) != (PROGRAM, TASK) {
            return Err(store::StoreError::TaskMismatch {
                path: path.to_path_buf(),
                saved_program: m.program,
                saved_task: m.task,
                program: PROGRAM.into(),
                task: TASK.into(),
            }
            .into());
        }
        let s = serde_json::from_value(m.settings)
            .map_err(|e| crate::Error::parse(path, None, format_args!("not a grid's settings: {e}")))?;
        return Ok(Some((s, false)));
    }
    let s = serde_json::from_str(&text)
        .map_err(|e| crate::Error::parse(path, Some(e.line()), format_args!("not a grid's settings: {e}")))?;
    Ok(Some((s, true)))
}

/// Refuses a part whose recorded settings differ from `settings`, naming
/// its file and the keys.
fn check_part(path: &Path, saved: &ExperimentSettings, settings: &ExperimentSettings) -> crate::Result<()> {
    let differ = store::differing_keys(&serde_json::to_value(saved)?, &serde_json::to_value(settings)?);
    crate::error::ensure_refused!(
        differ.is_empty(),
        "the runs saved with {} were made with other settings ({} differ{}); resume with the same options, \
         or start a fresh grid in another --out (or here with --force, losing those runs)",
        path.display(),
        differ.join(", "),
        if differ.len() == 1 { "s" } else { "" }
    );
    Ok(())
}

/// The parts a grid's directory declares: each settings file
/// (`settings.json`, `settings-K-of-N.json`) with its runs file, in name
/// order. A directory saved before manifests (its `settings.json` holds
/// the bare settings) declares `runs.jsonl` and every `runs-K-of-N.jsonl`.
///
/// # Errors
/// The directory cannot be listed, or its `settings.json` cannot be read.
pub fn declared_parts(dir: &Path) -> crate::Result<Vec<Part>> {
    let names: Vec<String> = match std::fs::read_dir(dir) {
        Ok(entries) => entries
            .filter_map(|e| e.ok())
            .filter_map(|e| e.file_name().to_str().map(String::from))
            .collect(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(vec![]),
        Err(e) => return Err(crate::Error::io("reading", dir, e)),
    };
    let part = |shard: Option<Shard>| Part {
        shard,
        settings: dir.join(settings_file_name(shard)),
        runs: dir.join(runs_file_name(shard)),
    };
    let legacy = matches!(read_part_settings(&dir.join(SETTINGS_FILE))?, Some((_, true)));
    let mut parts: Vec<Part> = names
        .iter()
        .filter_map(|n| {
            if legacy {
                part_of(n, "runs", ".jsonl")
            } else {
                part_of(n, "settings", ".json")
            }
        })
        .map(part)
        .collect();
    if legacy && !parts.iter().any(|p| p.shard.is_none()) {
        parts.push(part(None));
    }
    parts.sort_by(|a, b| a.runs.cmp(&b.runs));
    Ok(parts)
}

/// How a grid opens its directory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GridMode {
    /// A fresh grid: a part holding runs is refused unless `force` (which
    /// empties it).
    Fresh {
        /// Start over in a part that holds runs (they are lost).
        force: bool,
    },
    /// Continue a grid: the saved runs are read back, the missing ones run.
    Resume,
    /// Write the report of the saved runs only: nothing in the directory
    /// but the reports changes.
    ReportOnly,
}

/// A grid's directory, opened.
#[derive(Debug)]
pub struct OpenGrid {
    /// The part's runs file, open for appending (none for [`GridMode::ReportOnly`]).
    pub log: Option<AppendLog>,
    /// The runs saved in the declared parts, each once.
    pub previous: Vec<RunSummary>,
    /// What the user should know (a torn record moved aside, a part whose
    /// settings cannot be checked), one line each.
    pub warnings: Vec<String>,
}

/// Opens the part `shard` of the grid in `dir` (created if needed) for
/// `settings`, by the rules of this module; nothing is written when the
/// grid is refused.
///
/// # Errors
/// A refusal (runs there for a fresh grid; other settings, a task other
/// than a grid's, a run made with other settings; no saved runs for a
/// report), or a file that cannot be read or written, named.
pub fn open_grid(
    dir: &Path,
    settings: &ExperimentSettings,
    shard: Option<Shard>,
    mode: GridMode,
) -> crate::Result<OpenGrid> {
    store::create_output_dir(dir)?;
    let own_settings = dir.join(settings_file_name(shard));
    let own_runs = dir.join(runs_file_name(shard));
    let manifest = grid_manifest(settings, &own_settings)?;
    let mut warnings = Vec::new();
    if let GridMode::Fresh { force } = mode {
        // refused before anything is written; --force deletes a link under
        // the grid's names instead of writing through it, and a device, a
        // FIFO or a directory there is refused, named
        let report_files = [dir.join("experiments.json"), dir.join("experiments.md")];
        for path in [&own_runs, &own_settings].into_iter().chain(&report_files) {
            if force && std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
                store::remove_output(path)?;
            }
            store::check_output(path)?;
        }
        let saved = store::check_output(&own_runs)?.map_or(0, |m| m.len());
        crate::error::ensure_refused!(
            saved == 0 || force,
            "{} holds finished runs; continue that grid with --resume, choose another --out, or pass --force \
             to start over (its runs are then lost)",
            own_runs.display()
        );
        // the runs go first: a kill between the two leaves an empty part
        // under the old settings, never old runs under new settings
        let log = AppendLog::create(&own_runs)?;
        match read_part_settings(&own_settings) {
            Ok(Some((saved, false))) if check_part(&own_settings, &saved, settings).is_ok() => {}
            _ => manifest.write(&own_settings)?,
        }
        return Ok(OpenGrid {
            log: Some(log),
            previous: vec![],
            warnings,
        });
    }
    let report_only = mode == GridMode::ReportOnly;
    let mut parts = declared_parts(dir)?;
    let own_declared = parts.iter().any(|p| p.shard == shard);
    // written once every check passed
    let mut create_own_settings = false;
    if !own_declared && !report_only {
        if store::check_output(&own_runs)?.is_some_and(|m| m.len() > 0) {
            warnings.push(format!(
                "{} has no {}: its saved runs cannot be checked against this grid's settings",
                own_runs.display(),
                own_settings.display()
            ));
        } else {
            create_own_settings = true;
        }
        parts.push(Part {
            shard,
            settings: own_settings.clone(),
            runs: own_runs.clone(),
        });
    }
    crate::error::ensure_refused!(
        !parts.is_empty(),
        "{} holds no saved runs of a grid (no {} or settings-K-of-N.json); run the grid first",
        dir.display(),
        SETTINGS_FILE
    );
    let digest = settings.digest();
    let mut log = None;
    let mut previous: Vec<RunSummary> = Vec::new();
    // where each of `previous` was read: its runs file and record number
    let mut sources: Vec<(PathBuf, usize)> = Vec::new();
    for part in &parts {
        match read_part_settings(&part.settings)? {
            Some((saved, _)) => check_part(&part.settings, &saved, settings)?,
            None if part.shard == shard => {}
            None => warnings.push(format!(
                "{} has no {}: its runs cannot be checked against this grid's settings",
                part.runs.display(),
                part.settings.display()
            )),
        }
        // read only: the part's own log is repaired once every check passed
        let contents = store::read_log::<RunSummary>(&part.runs)?;
        let own = part.shard == shard && !report_only;
        if let Some(torn) = contents.torn.as_ref().filter(|_| !own) {
            warnings.push(format!("{torn}; that run will run again"));
        }
        for (i, run) in contents.records.into_iter().enumerate() {
            crate::error::ensure_refused!(
                run.settings_digest.is_empty() || run.settings_digest == digest,
                "{} record {} ({} {} seed {}) was made with other settings than {} records now (it was \
                 edited, or the runs were copied from another grid); resume with the settings of its runs, \
                 or start a fresh grid in another --out",
                part.runs.display(),
                i + 1,
                run.experiment,
                run.variant,
                run.seed,
                part.settings.display()
            );
            let same =
                |r: &RunSummary| (&r.experiment, &r.variant, r.seed) == (&run.experiment, &run.variant, run.seed);
            // one run recorded twice (a shard beside an unsharded grid, a
            // copied file): the same record is kept once, two different
            // ones are refused, naming both
            match previous.iter().position(same) {
                None => {
                    previous.push(run);
                    sources.push((part.runs.clone(), i + 1));
                }
                Some(k) => {
                    crate::error::ensure_refused!(
                        previous[k] == run,
                        "{} record {} and {} record {} are two different records of one run ({} {} seed {}); \
                     remove the one that is not wanted",
                        sources[k].0.display(),
                        sources[k].1,
                        part.runs.display(),
                        i + 1,
                        run.experiment,
                        run.variant,
                        run.seed
                    );
                }
            }
        }
    }
    if create_own_settings {
        manifest.write(&own_settings)?;
    }
    if !report_only {
        let (opened, contents) = AppendLog::open::<RunSummary>(&own_runs)?;
        if let Some(torn) = &contents.torn {
            warnings.push(format!("{torn}; that run will run again"));
        }
        log = Some(opened);
    }
    Ok(OpenGrid {
        log,
        previous,
        warnings,
    })
}

/// What a part of a grid runs, beyond its settings: recorded in the
/// part's manifest ([`store::Manifest::scope`]) so that a merge needs no
/// options repeated.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PartScope {
    /// The experiments the part runs.
    pub experiments: Vec<Experiment>,
    /// The variant prefixes it is limited to (`--variant`; empty: all).
    #[serde(default)]
    pub variants: Vec<String>,
    /// Its shard, `None` for the grid's own part.
    pub shard: Option<Shard>,
}

impl PartScope {
    /// Whether the run `(experiment, variant)` at `position` of the grid is
    /// this part's to run.
    fn covers(&self, position: usize, variant: &str) -> bool {
        self.shard.is_none_or(|s| s.contains(position))
            && (self.variants.is_empty() || self.variants.iter().any(|v| variant.starts_with(v.as_str())))
    }
}

/// Records `scope` in the part manifest `path` (written by [`open_grid`]
/// just before), replacing it only when it changes.
fn record_scope(path: &Path, scope: &PartScope) -> crate::Result<()> {
    let value = serde_json::to_value(scope)?;
    // a directory saved before manifests keeps its bare settings
    let Ok(Some(mut manifest)) = Manifest::read(path) else {
        return Ok(());
    };
    if manifest.scope.as_ref() != Some(&value) {
        manifest.scope = Some(value);
        manifest.write(path)?;
    }
    Ok(())
}

/// Merges the parts of a grid run as shards (on N machines, or as a Slurm
/// job array, each writing `settings-K-of-N.json` and `runs-K-of-N.jsonl`
/// into `dir`) and writes the grid's reports once ([`run_grid`]'s files),
/// reading the settings and the experiments from the parts themselves.
///
/// Refused, naming the files, shards or runs, before anything is written:
/// parts of other settings or made by other code (commits), a shard
/// missing (`settings-K-of-N.json` absent, by index), a shard that did not
/// finish (its runs missing, by shard and run), two different records of
/// one run, a part written before parts recorded their experiments.
///
/// # Errors
/// A refusal as above, or a file that cannot be read or written.
pub fn merge_grid(dir: &Path, show: &(dyn Fn(GridEvent<'_>) + Sync)) -> crate::Result<ExperimentsReport> {
    let parts = declared_parts(dir)?;
    crate::error::ensure_refused!(
        !parts.is_empty(),
        "{} holds no part of a grid (no {} or settings-K-of-N.json); run the grid's shards into it first",
        dir.display(),
        SETTINGS_FILE
    );
    // the first part is the reference every other is checked against
    let mut reference: Option<(PathBuf, Manifest)> = None;
    let mut scopes: Vec<(&Part, PartScope)> = Vec::new();
    for part in &parts {
        let manifest = Manifest::read(&part.settings)?.ok_or_else(|| {
            crate::Error::Refused(format!(
                "{} has no {}: its runs cannot be checked against the grid's settings",
                part.runs.display(),
                part.settings.display()
            ))
        })?;
        if (manifest.program.as_str(), manifest.task.as_str()) != (PROGRAM, TASK) {
            return Err(store::StoreError::TaskMismatch {
                path: part.settings.clone(),
                saved_program: manifest.program,
                saved_task: manifest.task,
                program: PROGRAM.into(),
                task: TASK.into(),
            }
            .into());
        }
        let scope: PartScope = match &manifest.scope {
            Some(v) => serde_json::from_value(v.clone())
                .map_err(|e| crate::Error::parse(&part.settings, None, format_args!("not a part's scope: {e}")))?,
            None => {
                return Err(crate::Error::Refused(format!(
                    "{} records no experiments (it was written before shards recorded them); write the report \
                     with `swingup experiments --resume --report-only` and the grid's options instead",
                    part.settings.display()
                )));
            }
        };
        if let Some((first_path, first)) = &reference {
            let differ = store::differing_keys(&first.settings, &manifest.settings);
            crate::error::ensure_refused!(
                differ.is_empty(),
                "{} and {} record other settings ({} differ{}): they are parts of two different grids",
                first_path.display(),
                part.settings.display(),
                differ.join(", "),
                if differ.len() == 1 { "s" } else { "" }
            );
            crate::error::ensure_refused!(
                first.created_by_commit == manifest.created_by_commit,
                "{} was made by {} and {} by {}: one grid's parts are run by one build",
                first_path.display(),
                first.created_by_commit,
                part.settings.display(),
                manifest.created_by_commit
            );
        } else {
            reference = Some((part.settings.clone(), manifest.clone()));
        }
        scopes.push((part, scope));
    }
    let Some((first_path, first)) = reference else {
        return Err(crate::Error::Refused(format!(
            "{} holds no part of a grid",
            dir.display()
        )));
    };
    let settings: ExperimentSettings = serde_json::from_value(first.settings)
        .map_err(|e| crate::Error::parse(&first_path, None, format_args!("not a grid's settings: {e}")))?;
    // every shard of each count is there
    let shards: Vec<Shard> = parts.iter().filter_map(|p| p.shard).collect();
    let missing_shards: Vec<String> = Shard::missing(&shards)
        .into_iter()
        .map(|(n, ks)| {
            let names: Vec<String> = ks
                .iter()
                .map(|&k| settings_file_name(Some(Shard { index: k, count: n })))
                .collect();
            format!(
                "shard{} {} of {n} ({} absent)",
                if ks.len() == 1 { "" } else { "s" },
                ks.iter().map(ToString::to_string).collect::<Vec<_>>().join(", "),
                names.join(", ")
            )
        })
        .collect();
    crate::error::ensure_refused!(
        missing_shards.is_empty(),
        "{} lacks {}: run the missing shards into it (the same command with --shard K/N, or the array's \
         tasks), then merge again",
        dir.display(),
        missing_shards.join("; ")
    );
    // every run each part was to make is saved in some part
    let mut which: Vec<Experiment> = scopes.iter().flat_map(|(_, s)| s.experiments.clone()).collect();
    which.sort_unstable();
    which.dedup();
    let mut saved = std::collections::BTreeSet::new();
    for part in &parts {
        for r in store::read_log::<RunSummary>(&part.runs)?.records {
            saved.insert((r.experiment, r.variant, r.seed));
        }
    }
    let mut unfinished: Vec<String> = Vec::new();
    for (part, scope) in &scopes {
        let lacking: Vec<String> = crate::experiments::grid_runs(&scope.experiments, &settings)
            .into_iter()
            .enumerate()
            .filter(|(p, (_, v, _))| scope.covers(*p, v))
            .filter(|(_, run)| !saved.contains(run))
            .map(|(_, (e, v, seed))| format!("{e} {v} seed {seed}"))
            .collect();
        if let Some(first_missing) = lacking.first() {
            unfinished.push(format!(
                "{} ({}) lacks {} of its runs, {}{}",
                part.shard
                    .map_or("the unsharded part".to_string(), |s| format!("shard {s}")),
                part.runs.display(),
                lacking.len(),
                first_missing,
                if lacking.len() > 1 { " and more" } else { "" }
            ));
        }
    }
    crate::error::ensure_refused!(
        unfinished.is_empty(),
        "the grid in {} is not finished: {}; rerun those shards (with --resume they run only their missing \
         runs), or write a report of the saved runs alone with --resume --report-only",
        dir.display(),
        unfinished.join("; ")
    );
    // the runs, each once (two different records of one run are refused)
    let grid = open_grid(dir, &settings, None, GridMode::ReportOnly)?;
    for w in &grid.warnings {
        show(GridEvent::Warning(w));
    }
    let report = run_experiments(&which, &settings, grid.previous, false, None, &[], &|_, _, _| Ok(()))?;
    write_reports(dir, report, show)
}

/// A grid to run ([`run_grid`]), as `swingup experiments` takes it.
#[derive(Debug, Clone)]
pub struct GridOptions {
    /// The experiments.
    pub which: Vec<Experiment>,
    /// The grid's settings.
    pub settings: ExperimentSettings,
    /// Its directory.
    pub out: PathBuf,
    /// How the directory is opened.
    pub mode: GridMode,
    /// Run only this part of the grid.
    pub shard: Option<Shard>,
    /// Run only the variants whose names start with one of these.
    pub variants: Vec<String>,
}

/// What [`run_grid`] tells its caller as it goes.
#[derive(Debug)]
pub enum GridEvent<'a> {
    /// Something the user should know (a torn record moved aside, ...).
    Warning(&'a str),
    /// The runs read back from the directory.
    Resumed(usize),
    /// A run finished and was saved: (runs done, runs in all, the run).
    Saved(usize, usize, &'a RunSummary),
    /// The wall time of the saved runs was kept (`None`: of the whole
    /// grid; `Some(task)`: of that task).
    KeptWallTime(Option<&'a str>, f64),
}

/// Runs a grid in its directory and writes its reports there: opens the
/// directory ([`open_grid`]), runs the missing runs (none for
/// [`GridMode::ReportOnly`]), appending each to the part's runs file
/// before it is shown (`show`), and replaces `experiments.json`,
/// `experiments.md` and the figures. The directory is locked for the
/// part's runs file. A run that cannot be saved stops the grid at once.
///
/// # Errors
/// A refusal or a file error of [`open_grid`], a run that failed, or a
/// file that cannot be written (named).
pub fn run_grid(opts: &GridOptions, show: &(dyn Fn(GridEvent<'_>) + Sync)) -> crate::Result<ExperimentsReport> {
    // refused before the directory is touched
    opts.settings.validate()?;
    let out = &opts.out;
    let log_name = runs_file_name(opts.shard);
    // one program at a time per runs file (shards of one grid may share the directory)
    let _lock = crate::output::rundir::lock_dir(out, &format!(".{log_name}.lock"))?;
    let grid = open_grid(out, &opts.settings, opts.shard, opts.mode)?;
    if opts.mode != GridMode::ReportOnly {
        let scope = PartScope {
            experiments: opts.which.clone(),
            variants: opts.variants.clone(),
            shard: opts.shard,
        };
        record_scope(&out.join(settings_file_name(opts.shard)), &scope)?;
    }
    for w in &grid.warnings {
        show(GridEvent::Warning(w));
    }
    // the saved runs of this part (a shard reads its siblings' too)
    let own: usize = match opts.shard {
        None => grid.previous.len(),
        Some(s) => {
            let mine: std::collections::BTreeSet<(String, String, u64)> =
                crate::experiments::grid_runs(&opts.which, &opts.settings)
                    .into_iter()
                    .enumerate()
                    .filter(|(p, _)| s.contains(*p))
                    .map(|(_, run)| run)
                    .collect();
            grid.previous
                .iter()
                .filter(|r| mine.contains(&(r.experiment.clone(), r.variant.clone(), r.seed)))
                .count()
        }
    };
    if own > 0 {
        show(GridEvent::Resumed(own));
    }
    let log = std::sync::Mutex::new(grid.log);
    let saved = std::sync::atomic::AtomicUsize::new(0);
    let report = run_experiments(
        &opts.which,
        &opts.settings,
        grid.previous,
        opts.mode != GridMode::ReportOnly,
        opts.shard,
        &opts.variants,
        &|done, total, r| {
            let mut log = log
                .lock()
                .map_err(|_| crate::Error::data("a worker panicked while saving a run"))?;
            if let Some(log) = log.as_mut() {
                log.append(r).map_err(|e| crate::Error::Context {
                    context: format!(
                        "saving the run {} {} seed {} failed; the grid stopped there ({} run(s) of this \
                         invocation saved; continue with --resume)",
                        r.experiment,
                        r.variant,
                        r.seed,
                        saved.load(std::sync::atomic::Ordering::SeqCst)
                    ),
                    source: Box::new(crate::Error::from(e)),
                })?;
            }
            saved.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            drop(log);
            show(GridEvent::Saved(done, total, r));
            Ok(())
        },
    )?;
    // a shard writes only its own files: the reports are the merge's
    // (`swingup experiments merge`), written once from every shard
    if opts.shard.is_some() && opts.mode != GridMode::ReportOnly {
        return Ok(report);
    }
    write_reports(out, report, show)
}

/// Writes a grid's reports into `out`: `experiments.json`,
/// `experiments.md` and the figures, each replaced atomically. A report
/// rewritten from saved runs keeps the grid's measured wall time.
fn write_reports(
    out: &Path,
    report: ExperimentsReport,
    show: &(dyn Fn(GridEvent<'_>) + Sync),
) -> crate::Result<ExperimentsReport> {
    let mut report = report;
    // a report rewritten from saved runs keeps the grid's measured wall
    // time, and each task whose runs it did not change keeps its own
    if let Some(previous) = std::fs::read_to_string(out.join("experiments.json"))
        .ok()
        .and_then(|text| serde_json::from_str::<ExperimentsReport>(&text).ok())
    {
        if report.keep_wall_time_of(&previous) {
            show(GridEvent::KeptWallTime(None, report.seconds));
        }
        for task in report.keep_task_times_of(&previous) {
            show(GridEvent::KeptWallTime(Some(task.as_str()), report.seconds));
        }
    }
    let json = serde_json::to_string_pretty(&report)?;
    store::replace_file(&out.join("experiments.json"), json.as_bytes())?;
    store::replace_file(
        &out.join("experiments.md"),
        crate::output::grid_report::markdown(&report).as_bytes(),
    )?;
    for (stem, plot) in &crate::output::plot::experiment_figures(&report)? {
        plot.write(out, stem)?;
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn part_names_are_read_strictly() {
        let s = |k, n| Some(Some(Shard { index: k, count: n }));
        assert_eq!(part_of("runs.jsonl", "runs", ".jsonl"), Some(None));
        assert_eq!(part_of("runs-2-of-4.jsonl", "runs", ".jsonl"), s(2, 4));
        assert_eq!(part_of("settings-1-of-2.json", "settings", ".json"), s(1, 2));
        for bad in [
            "runs-backup.jsonl",
            "runs-02-of-4.jsonl",
            "runs-5-of-4.jsonl",
            "runs-0-of-4.jsonl",
            "runs.jsonl.torn-1-2",
        ] {
            assert_eq!(part_of(bad, "runs", ".jsonl"), None, "{bad}");
        }
    }
}
