//! A grid's directory: the runs saved in its `runs*.jsonl` files (one per
//! grid, or one per shard) and the settings they were made with, so that
//! a resumed grid never mixes runs made with other settings.

use crate::experiments::{ExperimentSettings, RunSummary};

/// The file in a grid's directory that holds the settings its runs were made with.
pub const SETTINGS_FILE: &str = "settings.json";

/// Checks that a grid resumed in `dir` uses the settings its saved runs
/// were made with ([`SETTINGS_FILE`]), and records them for a fresh grid
/// (`resume` false). Settings saved before a field existed count as that
/// field's default. Returns a warning when a resumed directory has no
/// settings file (a grid saved before it existed: its runs cannot be checked).
///
/// # Errors
/// Different settings (the error names the keys and the ways on), or a
/// file that cannot be read, parsed or written.
pub fn check_grid_settings(
    dir: &std::path::Path,
    settings: &ExperimentSettings,
    resume: bool,
) -> crate::Result<Option<String>> {
    let path = dir.join(SETTINGS_FILE);
    if !resume {
        // a temporary name of this process's own: the shards of a job
        // array may start in one directory at once
        let tmp = dir.join(format!("settings.{}.tmp", std::process::id()));
        std::fs::write(&tmp, serde_json::to_string_pretty(settings)?)
            .map_err(|e| crate::Error::io("writing", &tmp, e))?;
        std::fs::rename(&tmp, &path).map_err(|e| crate::Error::io("renaming to", &path, e))?;
        return Ok(None);
    }
    let Ok(text) = std::fs::read_to_string(&path) else {
        return Ok(Some(format!(
            "{} has no {SETTINGS_FILE}: the saved runs cannot be checked against this grid's settings",
            dir.display()
        )));
    };
    // read back through the settings type, so that a setting added since
    // (with its default) is compared as that default, not as missing
    let saved: ExperimentSettings =
        serde_json::from_str(&text).map_err(|e| crate::Error::parse(&path, Some(e.line()), e))?;
    let saved = serde_json::to_value(saved)?;
    let now = serde_json::to_value(settings)?;
    let mut differ = Vec::new();
    differing_keys("", &saved, &now, &mut differ);
    crate::error::ensure_refused!(
        differ.is_empty(),
        "the runs saved in {} were made with other settings ({} differ{}); resume with the same options, \
         or start a fresh grid in another --out (or here with --force, losing those runs)",
        dir.display(),
        differ.join(", "),
        if differ.len() == 1 { "s" } else { "" }
    );
    Ok(None)
}

/// The dotted keys (`cartpole.max_trials`) whose values differ between
/// `a` and `b`, into `out`; `prefix` names the objects' own key ("" at the
/// top, where two non-objects differ as `(all)`).
fn differing_keys(prefix: &str, a: &serde_json::Value, b: &serde_json::Value, out: &mut Vec<String>) {
    match (a.as_object(), b.as_object()) {
        (Some(a), Some(b)) => {
            let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                let name = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                match (a.get(k), b.get(k)) {
                    (Some(x), Some(y)) => differing_keys(&name, x, y, out),
                    _ => out.push(name),
                }
            }
        }
        _ if a != b => out.push(if prefix.is_empty() {
            "(all)".into()
        } else {
            prefix.into()
        }),
        _ => {}
    }
}

/// The runs saved in every `runs*.jsonl` file of `dir` (a grid's file, or
/// its shards' files), in file-name order; a run saved twice counts once.
/// A last line without its newline (a write cut short by a kill) is
/// skipped, with a warning naming the file and line; any other line that
/// does not parse is an error naming them.
///
/// # Errors
/// `dir` or a file cannot be read, or a complete line does not parse.
pub fn read_saved_runs(dir: &std::path::Path) -> crate::Result<(Vec<RunSummary>, Vec<String>)> {
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| crate::Error::io("reading", dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("runs") && n.ends_with(".jsonl"))
        })
        .collect();
    files.sort();
    let mut runs: Vec<RunSummary> = Vec::new();
    let mut warnings = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(&file).map_err(|e| crate::Error::io("reading", &file, e))?;
        let lines: Vec<&str> = text.split('\n').collect();
        for (i, line) in lines.iter().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
            let run: RunSummary = match serde_json::from_str(line) {
                Ok(run) => run,
                // the last piece has no newline after it: a torn write
                Err(e) if i + 1 == lines.len() => {
                    warnings.push(format!(
                        "{} line {}: skipped an incomplete last record ({e}); that run will run again",
                        file.display(),
                        i + 1
                    ));
                    continue;
                }
                Err(e) => {
                    return Err(crate::Error::parse(
                        &file,
                        Some(i + 1),
                        format_args!("not a saved run: {e}"),
                    ));
                }
            };
            let same =
                |r: &RunSummary| (&r.experiment, &r.variant, r.seed) == (&run.experiment, &run.variant, run.seed);
            if !runs.iter().any(same) {
                runs.push(run);
            }
        }
    }
    Ok((runs, warnings))
}
