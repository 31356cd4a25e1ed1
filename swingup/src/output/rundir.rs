//! The rules of a learning run's directory: a fresh run never writes over
//! another run's files, and a resumed run continues with the settings
//! that made it.
//!
//! - [`prepare_fresh`]: a directory holding a run's files ([`run_files`])
//!   is refused, naming the ways on (`--resume`, another `--out`,
//!   `--force`); with `force` only those files are deleted, nothing else
//!   in the directory.
//! - [`resume_config`]: the run's saved `config.toml` is the starting
//!   point of the resumed run's configuration; the caller's overrides may
//!   change the trial cap only, and any other difference is refused,
//!   naming the keys ([`config_differences`]).
//! - [`create_manifest`]: a fresh run records, once, the task and the
//!   settings that made it ([`MANIFEST_FILE`]); a resumed run never
//!   rewrites it nor `config.toml`, and [`resume_config`] refuses a
//!   `config.toml` edited since, or a run of another task.
//! - [`lock_dir`]: one program at a time in a run's (or a grid's)
//!   directory; a second one is refused at once instead of mixing its
//!   files with the first one's.

use std::path::{Path, PathBuf};

use crate::cartpole::{CartPoleSettings, CartPoleTrial};
use crate::config::Config;
use crate::error::ensure_refused;

/// Is `name` a file a learning run writes ([`crate::output::run_report`]), or the
/// temporary file of one (`report.tmp` while `report.json` is written)?
fn is_run_file(name: &str) -> bool {
    let (stem, ext) = name.split_once('.').unwrap_or((name, ""));
    let known = matches!(
        stem,
        "config" | "report" | "demonstration" | "figure3" | "learning" | "diagnostics" | "manifest" | "cartpole"
    ) || (stem.starts_with("trial_") && stem[6..].chars().all(|c| c.is_ascii_digit()));
    known
        && matches!(
            ext,
            "toml" | "json" | "md" | "csv" | "svg" | "png" | "tmp" | "json.tmp" | "svg.tmp" | "png.tmp"
        )
}

/// The files of a learning run in `dir` (none if it does not exist), sorted.
pub fn run_files(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok())
        // a link or a device under a run file's name counts too: a fresh run
        // refuses it, and `--force` deletes a link (never its target) and
        // refuses a device, instead of writing through either
        .filter(|e| e.file_type().is_ok_and(|t| !t.is_dir()))
        .map(|e| e.path())
        .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(is_run_file))
        .collect();
    files.sort();
    files
}

/// The numbered run directories `root/swingup-NNN` (`NNN` from 001):
/// with `latest`, the highest-numbered one that exists (the run `learn
/// --resume` continues when no `--out` is given); otherwise the first free
/// one after it (`root/swingup-001` when there is none), created here so
/// that two runs started at once never share a directory, and the newest
/// run is always the highest-numbered, whatever gaps older ones left.
///
/// # Errors
/// `latest` with no run in `root`, or `root` that exists but cannot be
/// listed, each naming it.
pub fn numbered_run_dir(root: &Path, latest: bool) -> crate::Result<PathBuf> {
    let highest = match std::fs::read_dir(root) {
        Ok(entries) => entries
            .filter_map(|e| e.ok())
            .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
            .filter_map(|e| {
                let name = e.file_name();
                let digits = name.to_str()?.strip_prefix("swingup-")?.to_owned();
                if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
                    return None;
                }
                digits.parse::<u64>().ok()
            })
            .max(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(crate::Error::io("listing", root, e)),
    };
    let dir = |n: u64| root.join(format!("swingup-{n:03}"));
    if latest {
        highest.map(dir).ok_or_else(|| {
            crate::Error::Refused(format!(
                "no run in {} to resume (no swingup-NNN directory); pass --out",
                root.display()
            ))
        })
    } else {
        // claimed by creating it: two runs started at once never share one
        // (the second finds it made and takes the next number)
        store::create_output_dir(root)?;
        let mut n = highest.map_or(1, |n| n.saturating_add(1));
        loop {
            match std::fs::create_dir(dir(n)) {
                Ok(()) => return Ok(dir(n)),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && n < u64::MAX => n += 1,
                Err(e) => return Err(crate::Error::io("creating", dir(n), e)),
            }
        }
    }
}

/// The lock file a learning run holds in its directory ([`lock_dir`]); a
/// grid holds one per runs file (`.runs.jsonl.lock`, and one per shard).
pub const LOCK_FILE: &str = ".swingup.lock";

/// An exclusive lock on a directory ([`store::DirLock`]), held until the
/// value is dropped (or the process ends, however it ends).
pub type DirLock = store::DirLock;

/// Creates `dir` if needed ([`store::create_output_dir`]), deletes the
/// temporary files a killed writer left there, and takes the exclusive
/// lock on its file `name` (e.g. [`LOCK_FILE`]), waiting at most
/// [`LOCK_PATIENCE`]: a lock is shared with a child process between its
/// fork and its exec, so a lock just released by a process that is
/// starting another program can stay held for a moment.
///
/// # Errors
/// Another process holds the lock (the error names the directory and the
/// ways on), or a file system error naming the path.
pub fn lock_dir(dir: &Path, name: &str) -> crate::Result<DirLock> {
    store::create_output_dir(dir)?;
    let lock = store::DirLock::acquire(dir, name, LOCK_PATIENCE).map_err(|e| match e {
        store::StoreError::Locked { dir, path } => crate::Error::Refused(format!(
            "another swingup program is working in {} (it holds {}); wait for it to finish, or choose another --out",
            dir.display(),
            path.display()
        )),
        e => e.into(),
    })?;
    // only once the lock is held: a live writer's temporaries are its own
    store::remove_stale_temporaries(dir)?;
    Ok(lock)
}

/// How long [`lock_dir`] waits for a held lock before it refuses.
pub const LOCK_PATIENCE: std::time::Duration = std::time::Duration::from_secs(2);

/// Makes `dir` ready for a fresh run: creates it, and refuses when it holds
/// another run's files, unless `force`, which deletes those files only.
///
/// # Errors
/// Another run's files without `force` (the error names the directory and
/// the ways on), or a file system error naming the path.
pub fn prepare_fresh(dir: &Path, force: bool) -> crate::Result<()> {
    store::create_output_dir(dir)?;
    let files = run_files(dir);
    if files.is_empty() {
        return Ok(());
    }
    // the task the directory records, so a run of the other one is told why
    let task = store::Manifest::read(&dir.join(MANIFEST_FILE))
        .ok()
        .flatten()
        .map(|m| m.task)
        .or_else(|| dir.join("cartpole.json").exists().then(|| "cartpole".to_string()));
    ensure_refused!(
        force,
        "{} holds another run{} ({} of its files, e.g. {}); continue it with --resume, choose another --out, \
         or pass --force to delete that run's files first",
        dir.display(),
        task.map_or(String::new(), |t| format!(", of the {t} task")),
        files.len(),
        files[0].file_name().and_then(|n| n.to_str()).unwrap_or("?")
    );
    for f in files {
        // a link is deleted, never followed; a device or FIFO is refused
        store::remove_output(&f)?;
    }
    Ok(())
}

/// The manifest of a learning run's directory ([`store::Manifest`]): the
/// program, the task (`pendulum` or `cartpole`) and the settings that
/// made the run, written once when the run starts.
pub const MANIFEST_FILE: &str = "manifest.json";

/// The program a learning run's manifest records.
pub const LEARN_PROGRAM: &str = "swingup learn";

/// Records, in a fresh run's directory `dir`, that `task` with `settings`
/// made it ([`MANIFEST_FILE`]; call after [`prepare_fresh`]).
///
/// # Errors
/// The manifest cannot be written; the error names it.
pub fn create_manifest(dir: &Path, task: &str, settings: &impl serde::Serialize) -> crate::Result<()> {
    let path = dir.join(MANIFEST_FILE);
    let m = store::Manifest::new(
        LEARN_PROGRAM,
        task,
        settings,
        &crate::experiments::sensitivity::code_version(),
        &path,
    )?;
    Ok(m.write(&path)?)
}

/// What a cart-pole run's manifest records ([`create_manifest`] with the
/// task `cartpole`): the settings and the seed of every draw, which a
/// resume ([`cartpole_resume`]) continues with.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CartPoleRunSettings {
    /// The run's settings.
    pub settings: CartPoleSettings,
    /// The seed of every random draw.
    pub seed: u64,
}

/// The settings, seed and saved trials of the cart-pole run in `dir`, for
/// `learn --task cartpole --resume`: the settings and seed its manifest
/// records (a `seed` or `max_trials` given other than those is refused),
/// and its `trial_NN.json` files from 1 on.
///
/// # Errors
/// No manifest, a manifest of another task or program, settings or a
/// seed that differ from it (each a refusal naming the way on), or a
/// trial file that cannot be read (naming it).
pub fn cartpole_resume(
    dir: &Path,
    seed: Option<u64>,
    max_trials: Option<usize>,
) -> crate::Result<(CartPoleRunSettings, Vec<CartPoleTrial>)> {
    let manifest_path = dir.join(MANIFEST_FILE);
    let Some(m) = store::Manifest::read(&manifest_path)? else {
        return Err(crate::Error::Refused(format!(
            "cannot resume {}: it has no {} recording the run's settings and seed (start a fresh run instead)",
            dir.display(),
            manifest_path.display()
        )));
    };
    ensure_refused!(
        m.program == LEARN_PROGRAM && m.task == "cartpole",
        "cannot resume {} as a cartpole run: {} records a {} run of {}; choose another --out",
        dir.display(),
        manifest_path.display(),
        m.task,
        m.program
    );
    let recorded: CartPoleRunSettings = serde_json::from_value(m.settings).map_err(|e| {
        crate::Error::parse(
            &manifest_path,
            None,
            format_args!("not a cart-pole run's settings: {e}"),
        )
    })?;
    if let Some(seed) = seed {
        ensure_refused!(
            seed == recorded.seed,
            "{} was made with seed {}, not {seed}; resume without --seed, or start a fresh run in another --out",
            dir.display(),
            recorded.seed
        );
    }
    if let Some(n) = max_trials {
        ensure_refused!(
            n == recorded.settings.max_trials,
            "{} was made with --max-trials {}, not {n}; resume without --max-trials, or start a fresh run in \
             another --out",
            dir.display(),
            recorded.settings.max_trials
        );
    }
    recorded.settings.validate()?;
    let mut trials = Vec::new();
    for index in 1.. {
        let path = dir.join(crate::output::run_report::trial_json_name(index));
        if store::check_output(&path)?.is_none() {
            break;
        }
        let text = std::fs::read_to_string(&path).map_err(|e| crate::Error::io("reading", &path, e))?;
        let trial: CartPoleTrial = serde_json::from_str(&text)
            .map_err(|e| crate::Error::parse(&path, Some(e.line()), format_args!("not a cart-pole trial: {e}")))?;
        trials.push(trial);
    }
    Ok((recorded, trials))
}

/// The dotted keys (`planner.lambda`, `seed`) whose values differ between
/// two configurations, in alphabetical order; `max_trials` is left out
/// when `ignore_cap`.
pub fn config_differences(a: &Config, b: &Config, ignore_cap: bool) -> Vec<String> {
    fn walk(prefix: &str, a: &toml::Value, b: Option<&toml::Value>, out: &mut Vec<String>) {
        match (a, b) {
            (toml::Value::Table(ta), Some(toml::Value::Table(tb))) => {
                for (k, va) in ta {
                    let key = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    walk(&key, va, tb.get(k), out);
                }
            }
            (va, Some(vb)) if va == vb => {}
            _ => out.push(prefix.to_string()),
        }
    }
    let (Ok(va), Ok(vb)) = (toml::Value::try_from(a), toml::Value::try_from(b)) else {
        return vec!["(the configuration could not be compared)".into()];
    };
    let mut out = Vec::new();
    walk("", &va, Some(&vb), &mut out);
    out.retain(|k| !(ignore_cap && k == "max_trials"));
    out
}

/// The configuration of a run resumed in `dir`: its saved `config.toml`
/// with `overrides` applied (the caller's command-line options). Only the
/// trial cap may change.
///
/// # Errors
/// No or an unreadable `config.toml` (the run cannot be continued as it
/// was made), or overrides that change anything but `max_trials` (the
/// error names the keys and the way on).
pub fn resume_config(dir: &Path, overrides: impl FnOnce(&mut Config)) -> crate::Result<Config> {
    let path = dir.join("config.toml");
    let text = std::fs::read_to_string(&path).map_err(|e| {
        crate::Error::Refused(format!(
            "cannot resume {}: its configuration {} cannot be read ({e}); without it the run cannot be \
             continued as it was made (start a fresh run instead)",
            dir.display(),
            path.display()
        ))
    })?;
    let saved: Config = toml::from_str(&text).map_err(|e| crate::Error::parse(&path, None, e))?;
    // the settings recorded when the run was made: a config.toml edited
    // since would report its trials under settings they were not made with
    let manifest_path = dir.join(MANIFEST_FILE);
    // without the manifest, an edited config.toml could not be told from
    // the one the trials were made with: no resume
    let manifest = store::Manifest::read(&manifest_path)?;
    ensure_refused!(
        manifest.is_some(),
        "cannot resume {}: {} is missing, so {} cannot be checked against the settings its trials were made \
         with; restore it, or start a fresh run in another --out",
        dir.display(),
        manifest_path.display(),
        path.display()
    );
    if let Some(m) = manifest {
        ensure_refused!(
            m.program == LEARN_PROGRAM && m.task == "pendulum",
            "cannot resume {} as a pendulum run: {} records a {} run of {}; choose another --out",
            dir.display(),
            manifest_path.display(),
            m.task,
            m.program
        );
        let recorded: Config = serde_json::from_value(m.settings)
            .map_err(|e| crate::Error::parse(&manifest_path, None, format_args!("not a run's settings: {e}")))?;
        let edited = config_differences(&recorded, &saved, false);
        ensure_refused!(
            edited.is_empty(),
            "{} was changed after the run was made: {} differ{} from the settings recorded in {} (its trials              were made with those); restore it, or start a fresh run in another --out",
            path.display(),
            edited.join(", "),
            if edited.len() == 1 { "s" } else { "" },
            manifest_path.display()
        );
    }
    let mut cfg = saved.clone();
    overrides(&mut cfg);
    let changed = config_differences(&saved, &cfg, true);
    ensure_refused!(
        changed.is_empty(),
        "{} was made with other settings: {} differ{} from its config.toml; resume without changing them \
         (only --max-trials may change), or start a fresh run in another --out",
        dir.display(),
        changed.join(", "),
        if changed.len() == 1 { "s" } else { "" }
    );
    cfg.validate()?;
    Ok(cfg)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `learn` without `--out` numbers runs after the highest existing one
    /// and resumes that one, whatever gaps lie below it (issue 37).
    #[test]
    fn numbered_runs_resume_the_highest_and_skip_past_gaps() {
        let scratch = store::ScratchDir::new("swingup-numbered").expect("scratch dir");
        let root = scratch.path().join("runs");
        let e = numbered_run_dir(&root, true)
            .expect_err("nothing to resume")
            .to_string();
        assert!(e.contains("no run") && e.contains("--out"), "{e}");
        // a fresh run claims its directory: the next one, started at once,
        // gets the next number (issue 51: two runs collided on one)
        assert_eq!(numbered_run_dir(&root, false).expect("fresh"), root.join("swingup-001"));
        assert!(root.join("swingup-001").is_dir());
        assert_eq!(numbered_run_dir(&root, false).expect("fresh"), root.join("swingup-002"));
        std::fs::remove_dir(root.join("swingup-002")).expect("rmdir");
        for n in ["swingup-001", "swingup-003", "swingup-x", "other-009"] {
            std::fs::create_dir_all(root.join(n)).expect("mkdir");
        }
        // a file with a run's name is not a run
        std::fs::write(root.join("swingup-007"), "").expect("file");
        assert_eq!(numbered_run_dir(&root, true).expect("latest"), root.join("swingup-003"));
        assert_eq!(numbered_run_dir(&root, false).expect("next"), root.join("swingup-004"));
        std::fs::create_dir_all(root.join("swingup-1000")).expect("mkdir");
        assert_eq!(
            numbered_run_dir(&root, true).expect("latest"),
            root.join("swingup-1000")
        );
    }
}
