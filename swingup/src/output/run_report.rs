//! The run directory: the report (JSON and Markdown), per-trial logs (CSV and
//! JSON), and plots like the paper's Figure 3, as SVG and PNG ([`crate::output::plot`]).
//!
//! | file | written by | content |
//! |---|---|---|
//! | `report.json` | [`write_run`] | the whole [`RunRecord`] |
//! | `report.md` | [`write_run`] | configuration, demonstration, a table of trials, tuned metric scales, the result |
//! | `trial_NN.json` | [`write_trial`] (and [`write_run`]) | one [`TrialRecord`]; [`read_trials`] reads them back to resume a run |
//! | `trial_NN.csv` | [`write_trial`] (and [`write_run`]) | states, observations, commands and phase per sample |
//! | `demonstration.csv` | [`write_run`] | the demonstration's states and commands |
//! | `figure3.svg`, `.png` | [`write_run`] | hand position and pendulum angle per trial, the demonstration dotted (the paper's Figure 3) |
//! | `learning.svg`, `.png` | [`write_run`] | largest angle per trial, and the plan's inconsistency |
//! | `diagnostics.svg`, `.png` | [`write_run`] | the plan against reality per trial ([`crate::diagnostics`]) |
//!
//! `NN` is the trial number ([`TrialRecord::index`], from 1), two digits.
//! Non-finite numbers are written as `null` in JSON and read back as NaN.

use std::fmt::Write as _;
use std::fs;
use std::io;
use std::path::Path;

use crate::cartpole::CartPoleTrial;
use crate::error::ResultExt as _;

use crate::format::num;
use crate::output::plot;
use crate::plant::demo::Demonstration;
use crate::record::{RunRecord, TrialKind, TrialRecord};

/// Header of a trial's CSV log.
pub const TRIAL_CSV_HEADER: &str = "k,t,theta,theta_dot,x,x_dot,obs_theta,obs_theta_dot,obs_x,obs_x_dot,command,phase";

/// Header of the demonstration's CSV log.
pub const DEMONSTRATION_CSV_HEADER: &str = "k,t,theta,theta_dot,x,x_dot,command";

/// The name of trial `index`'s JSON record, `trial_NN.json`.
pub fn trial_json_name(index: usize) -> String {
    format!("trial_{index:02}.json")
}

/// The name of trial `index`'s CSV log, `trial_NN.csv`.
pub fn trial_csv_name(index: usize) -> String {
    format!("trial_{index:02}.csv")
}

/// Writes the whole run into `dir` (created if needed): `report.json`,
/// `report.md`, `demonstration.csv`, the figures `figure3`, `learning` and
/// `diagnostics` (each as `.svg` and `.png`, [`plot`]), and for each trial
/// `trial_NN.json` and `trial_NN.csv` (as [`write_trial`]).
///
/// # Errors
/// A file cannot be written; the error names it.
pub fn write_run(dir: &Path, run: &RunRecord) -> crate::Result<()> {
    store::create_output_dir(dir)?;
    for trial in &run.trials {
        write_trial(dir, trial)?;
    }
    write_atomic(&dir.join("report.json"), &to_json(run)?)?;
    write_atomic(&dir.join("demonstration.csv"), &demonstration_csv(&run.demonstration))?;
    plot::figure3(run)?.write(dir, "figure3")?;
    plot::learning(run)?.write(dir, "learning")?;
    plot::diagnostics(run)?.write(dir, "diagnostics")?;
    write_atomic(&dir.join("report.md"), &markdown(run))?;
    Ok(())
}

/// Writes a finished cart-pole trial into `dir` as `trial_NN.json` (replaced
/// whole, [`write_atomic`]), which `learn --task cartpole --resume` reads
/// back ([`crate::output::rundir::cartpole_resume`]).
///
/// # Errors
/// The file cannot be written; the error names it.
pub fn write_cartpole_trial(dir: &Path, trial: &CartPoleTrial) -> crate::Result<()> {
    write_atomic(
        &dir.join(trial_json_name(trial.trial)),
        &serde_json::to_string_pretty(trial)?,
    )
}

/// A cart-pole trial's progress line: controller, success, the tip's last
/// distance, PILCO's cost, the data so far and, for MPC, the replan times.
pub fn cartpole_trial_line(t: &CartPoleTrial) -> String {
    let replans = if t.replan_ms.is_empty() {
        String::new()
    } else {
        format!(
            "; replans {:.1} ms median, {:.1} ms p99",
            t.replan_median_ms, t.replan_p99_ms
        )
    };
    format!(
        "trial {:>2}: {:<6} {}, tip {:.2} m from the target at the end, PILCO cost {:.1}, {:.0} s of data{replans}",
        t.trial,
        t.controller,
        if t.success { "SUCCESS" } else { "failed" },
        t.final_distance,
        t.pilco_cost,
        t.data_seconds,
    )
}

/// Writes one trial into `dir` (created if needed): `trial_NN.json`, the
/// [`TrialRecord`] that [`read_trials`] reads back, and `trial_NN.csv`.
///
/// Each file is replaced atomically ([`write_atomic`]), so an interrupted
/// run never leaves a half-written record behind.
pub fn write_trial(dir: &Path, trial: &TrialRecord) -> crate::Result<()> {
    store::create_output_dir(dir)?;
    let saving = || format!("saving trial {}", trial.index);
    write_atomic(&dir.join(trial_csv_name(trial.index)), &trial_csv(trial)).with_context(saving)?;
    let json = to_json(trial).with_context(saving)?;
    write_atomic(&dir.join(trial_json_name(trial.index)), &json).with_context(saving)?;
    Ok(())
}

/// Replaces the text between the lines `start` and `end` of the file
/// `path` with `text` ([`store::with_block`]: each marker counts only as a
/// whole line of its own, so a marker quoted in prose is left alone).
///
/// # Errors
/// The file cannot be read or written, or lacks the marker lines.
pub fn update_between(path: &std::path::Path, start: &str, end: &str, text: &str) -> crate::Result<()> {
    let new = with_markers(path, start, end, text)?;
    write_atomic(path, &new)
}

/// The file `path` as [`update_between`] would write it, without writing:
/// checks the file before the work whose result goes into it.
///
/// # Errors
/// The file cannot be read, or lacks the marker lines.
pub fn with_markers(path: &std::path::Path, start: &str, end: &str, text: &str) -> crate::Result<String> {
    let old = std::fs::read_to_string(path).map_err(|e| crate::Error::io("reading", path, e))?;
    store::with_block(&old, start, end, text).ok_or_else(|| {
        crate::Error::data(format!(
            "{} has no line {start} followed by a line {end} (each on a line of its own)",
            path.display()
        ))
    })
}

/// Reads back the trials [`write_trial`] wrote into `dir`: `trial_01.json`,
/// `trial_02.json`, ... in order, stopping at the first one missing (none
/// at all, or no `dir`, gives an empty list).
///
/// # Errors
/// A file that cannot be read or parsed, or whose trial number is not the
/// one in its name; the error names the file.
pub fn read_trials(dir: &Path) -> crate::Result<Vec<TrialRecord>> {
    let mut trials = Vec::new();
    for index in 1.. {
        let path = dir.join(trial_json_name(index));
        let text = match fs::read_to_string(&path) {
            Ok(text) => text,
            Err(e) if e.kind() == io::ErrorKind::NotFound => break,
            Err(e) => return Err(crate::Error::io("reading", path, e)),
        };
        let trial: TrialRecord = serde_json::from_str(&text)
            .map_err(|e| crate::Error::parse(&path, Some(e.line()), format_args!("not a trial record: {e}")))?;
        crate::error::ensure_data!(
            trial.index == index,
            "trial record {} holds trial {}, expected {index}",
            path.display(),
            trial.index
        );
        trials.push(trial);
    }
    Ok(trials)
}

fn to_json<T: serde::Serialize>(value: &T) -> crate::Result<String> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    Ok(text)
}

/// Replaces `path` with `contents` atomically ([`store::replace_file`]): a
/// uniquely named temporary file in the same directory, synced and
/// renamed, so that `path` holds either its old or its new contents; a
/// symbolic link's target is replaced and an existing file keeps its
/// permissions.
///
/// # Errors
/// A file cannot be written, synced or renamed; the error names it.
pub fn write_atomic(path: &Path, contents: &str) -> crate::Result<()> {
    Ok(store::replace_file(path, contents.as_bytes())?)
}

// ---------------------------------------------------------------- CSV

fn csv_num(out: &mut String, x: Option<f64>) {
    if let Some(x) = x {
        let _ = write!(out, "{x}");
    }
}

/// The start of state sample `k`'s CSV row, shared by the trial and
/// demonstration logs: `k`, its time `k dt` and the state's values.
fn csv_state(out: &mut String, k: usize, dt: f64, state: &[f64]) {
    let _ = write!(out, "{k},{}", k as f64 * dt);
    for v in state {
        out.push(',');
        csv_num(out, Some(*v));
    }
}

/// The phase of sample `k` of a trial: `imitate`, `explore` or `plan` before the
/// balancing controller took over, `balance` from then on.
pub fn phase(trial: &TrialRecord, k: usize) -> &'static str {
    match trial.caught_at {
        Some(c) if k >= c => "balance",
        _ => match trial.kind {
            TrialKind::Imitation => "imitate",
            TrialKind::Exploration => "explore",
            TrialKind::Planned => "plan",
        },
    }
}

/// A trial's CSV log: [`TRIAL_CSV_HEADER`] and one row per state sample; a
/// missing command (the last sample) or observation is left empty.
pub fn trial_csv(trial: &TrialRecord) -> String {
    let mut out = String::with_capacity(128 * (trial.states.len() + 1));
    out.push_str(TRIAL_CSV_HEADER);
    out.push('\n');
    for (k, s) in trial.states.iter().enumerate() {
        csv_state(&mut out, k, trial.dt, s);
        let obs = trial.observed.get(k);
        for j in 0..4 {
            out.push(',');
            csv_num(&mut out, obs.map(|o| o[j]));
        }
        out.push(',');
        csv_num(&mut out, trial.commands.get(k).copied());
        let _ = writeln!(out, ",{}", phase(trial, k));
    }
    out
}

/// The demonstration's CSV log: [`DEMONSTRATION_CSV_HEADER`] and one row per
/// state sample; the last row has no command.
pub fn demonstration_csv(demo: &Demonstration) -> String {
    let mut out = String::with_capacity(96 * (demo.states.len() + 1));
    out.push_str(DEMONSTRATION_CSV_HEADER);
    out.push('\n');
    for (k, s) in demo.states.iter().enumerate() {
        csv_state(&mut out, k, demo.dt, s);
        out.push(',');
        csv_num(&mut out, demo.controls.get(k).copied());
        out.push('\n');
    }
    out
}

// ---------------------------------------------------------------- Markdown

/// Text for a Markdown table cell: no `|` or line breaks.
fn cell(text: &str) -> String {
    text.replace('|', "\\|").replace(['\n', '\r'], " ")
}

fn max_abs(values: impl Iterator<Item = f64>) -> f64 {
    values.filter(|v| v.is_finite()).fold(0.0, |m, v| m.max(v.abs()))
}

fn duration(n_samples: usize, dt: f64) -> f64 {
    n_samples.saturating_sub(1) as f64 * dt
}

/// The result line of the report: the first success and the robot data it
/// took, or no success within the trials run.
pub fn result_line(run: &RunRecord) -> String {
    match run.success_trial {
        Some(n) => format!(
            "**Result:** success at trial {n} after {} s of robot data.",
            num(run.robot_seconds)
        ),
        None => format!(
            "**Result:** no success within {} trial{} ({} s of robot data).",
            run.trials.len(),
            if run.trials.len() == 1 { "" } else { "s" },
            num(run.robot_seconds)
        ),
    }
}

/// The Markdown summary of a run, as written to `report.md`.
pub fn markdown(run: &RunRecord) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# Swing-up learned from a demonstration\n");
    let _ = writeln!(md, "{}\n", result_line(run));

    let _ = writeln!(md, "## Configuration\n");
    let _ = writeln!(md, "```toml\n{}\n```\n", run.config_toml.trim_end());

    let demo = &run.demonstration;
    let _ = writeln!(md, "## Demonstration\n");
    let _ = writeln!(
        md,
        "- duration: {} s ({} steps of {} s)",
        num(duration(demo.states.len(), demo.dt)),
        demo.controls.len(),
        num(demo.dt)
    );
    let _ = writeln!(
        md,
        "- largest hand excursion |x|: {} m",
        num(max_abs(demo.states.iter().map(|s| s[2])))
    );
    let _ = writeln!(
        md,
        "- largest command |u|: {} m/s²",
        num(max_abs(demo.controls.iter().copied()))
    );
    let _ = writeln!(
        md,
        "- largest angle |θ|: {}°",
        num(max_abs(demo.states.iter().map(|s| s[0])).to_degrees())
    );
    let _ = writeln!(md, "- log: [demonstration.csv](demonstration.csv)\n");

    let _ = writeln!(md, "## Trials\n");
    let _ = writeln!(
        md,
        "| trial | kind | max angle (°) | caught at (s) | success | failure | plan cost | task | inconsistency | \
         max mismatch | planner iterations | planner time (s) | model points | LOO nMSE | log |"
    );
    let _ = writeln!(
        md,
        "|---:|---|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"
    );
    for t in &run.trials {
        let kind = match t.kind {
            TrialKind::Imitation => "imitation",
            TrialKind::Exploration => "exploration",
            TrialKind::Planned => "planned",
        };
        let caught = t.caught_at.map_or("—".to_string(), |c| num(c as f64 * t.dt));
        let plan = t.plan.as_ref().map_or_else(
            || vec!["—".to_string(); 6],
            |p| {
                vec![
                    num(p.cost),
                    num(p.task),
                    num(p.inconsistency),
                    num(p.max_mismatch),
                    p.iterations.to_string(),
                    num(p.seconds),
                ]
            },
        );
        let model = t.model.as_ref().map_or_else(
            || vec!["—".to_string(); 2],
            |m| vec![m.n_points.to_string(), num(m.loo_nmse)],
        );
        let failure = if t.failure.is_empty() {
            "—".to_string()
        } else {
            cell(&t.failure)
        };
        let csv = trial_csv_name(t.index);
        let _ = writeln!(
            md,
            "| {} | {kind} | {} | {caught} | {} | {failure} | {} | {} | [{csv}]({csv}) |",
            t.index,
            num(t.max_angle.to_degrees()),
            if t.success { "yes" } else { "no" },
            plan.join(" | "),
            model.join(" | "),
        );
    }
    md.push('\n');

    let _ = writeln!(md, "## Tuned metric scales\n");
    let mut inputs: Vec<&str> = Vec::new();
    for m in run.trials.iter().filter_map(|t| t.model.as_ref()) {
        for name in &m.inputs {
            if !inputs.contains(&name.as_str()) {
                inputs.push(name);
            }
        }
    }
    if inputs.is_empty() {
        let _ = writeln!(md, "No model was fitted.\n");
    } else {
        let _ = writeln!(
            md,
            "Per-input scales of the distance metric after tuning, relative to the initial \
             normalisation (0: input found irrelevant), with the bandwidth; and how much the \
             nonparametric part changed the predictions: the model's leave-one-out mean squared \
             error over its prior's alone (1: the LWR changes nothing, 0.1: it removes 90 % of the \
             prior's error).\n"
        );
        let names: Vec<String> = inputs.iter().map(|n| cell(n)).collect();
        let _ = writeln!(md, "| trial | {} | bandwidth | LWR / prior error |", names.join(" | "));
        let _ = writeln!(md, "|---:|{}---:|---:|", "---:|".repeat(inputs.len()));
        for t in &run.trials {
            let Some(m) = &t.model else { continue };
            let values: Vec<String> = inputs
                .iter()
                .map(|name| {
                    m.inputs
                        .iter()
                        .position(|n| n == name)
                        .and_then(|j| m.scales.get(j))
                        .map_or("—".to_string(), |s| num(*s))
                })
                .collect();
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} |",
                t.index,
                values.join(" | "),
                num(m.bandwidth),
                num(m.lwr_vs_prior)
            );
        }
        md.push('\n');
    }

    md.push_str(&crate::output::diagnostics_report::markdown_section(run));

    let _ = writeln!(md, "## Plots and files\n");
    let _ = writeln!(
        md,
        "- [figure3.svg](figure3.svg) ([PNG](figure3.png)): hand position and pendulum angle per trial, \
         the demonstration dotted"
    );
    let _ = writeln!(
        md,
        "- [learning.svg](learning.svg) ([PNG](learning.png)): largest angle per trial and the plan's \
         inconsistency"
    );
    let _ = writeln!(
        md,
        "- [diagnostics.svg](diagnostics.svg) ([PNG](diagnostics.png)): the model's support along each \
         plan, its error along \
         what the robot did, and the plan's inconsistency per step"
    );
    let _ = writeln!(md, "- [report.json](report.json): the whole run record");
    let _ = writeln!(md, "- [demonstration.csv](demonstration.csv)");
    for t in &run.trials {
        let csv = trial_csv_name(t.index);
        let json = trial_json_name(t.index);
        let _ = writeln!(md, "- [{csv}]({csv}), [{json}]({json})");
    }
    let _ = writeln!(md, "\n![Figure 3](figure3.svg)\n\n![Learning](learning.svg)");
    md
}

/// One line of progress for a finished trial: its index, largest angle,
/// outcome and, for a planned trial, the plan's and the model's summary.
pub fn trial_line(t: &TrialRecord) -> String {
    let what = match t.kind {
        TrialKind::Imitation => "imitation".to_string(),
        TrialKind::Exploration => "exploration".to_string(),
        TrialKind::Planned => match (&t.plan, &t.model) {
            (Some(p), Some(m)) => format!(
                "plan {} in {} it ({:.2} s), cost {:.3e} (task {:.3e}, inconsistency {:.3e}); model {} points, LOO nMSE {:.3}{}{}",
                p.status,
                p.iterations,
                p.seconds,
                p.cost,
                p.task,
                p.inconsistency,
                m.n_points,
                m.loo_nmse,
                if m.lwr_vs_prior.is_finite() {
                    format!(", LWR/prior error {:.3}", m.lwr_vs_prior)
                } else {
                    String::new()
                },
                if m.dropped.is_empty() {
                    String::new()
                } else {
                    format!(", inputs left out: {}", m.dropped.join(", "))
                }
            ),
            _ => "planned".to_string(),
        },
    };
    let outcome = if t.success {
        "SUCCESS".to_string()
    } else {
        format!("failed: {}", t.failure)
    };
    format!(
        "trial {:>2}: max angle {:>4.0} deg, {} | {}",
        t.index,
        t.max_angle.to_degrees(),
        outcome,
        what
    )
}
