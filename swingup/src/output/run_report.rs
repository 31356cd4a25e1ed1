//! The run directory: the report (JSON and Markdown), per-trial logs (CSV and
//! JSON), and plots like the paper's Figure 3, written as plain SVG.
//!
//! | file | written by | content |
//! |---|---|---|
//! | `report.json` | [`write_run`] | the whole [`RunRecord`] |
//! | `report.md` | [`write_run`] | configuration, demonstration, a table of trials, tuned metric scales, the result |
//! | `trial_NN.json` | [`write_trial`] (and [`write_run`]) | one [`TrialRecord`]; [`read_trials`] reads them back to resume a run |
//! | `trial_NN.csv` | [`write_trial`] (and [`write_run`]) | states, observations, commands and phase per sample |
//! | `demonstration.csv` | [`write_run`] | the demonstration's states and commands |
//! | `figure3.svg` | [`write_run`] | hand position and pendulum angle per trial, the demonstration dotted (the paper's Figure 3) |
//! | `learning.svg` | [`write_run`] | largest angle per trial, and the plan's inconsistency |
//! | `diagnostics.svg` | [`write_run`] | the plan against reality per trial ([`crate::diagnostics`]) |
//!
//! `NN` is the trial number ([`TrialRecord::index`], from 1), two digits.
//! Non-finite numbers are written as `null` in JSON and read back as NaN.

use std::fmt::Write as _;
use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use crate::error::ResultExt as _;

use crate::format::num;
use crate::output::svg::{Panel, colour, heading, legend_entry, nice_ticks, range, svg_open, xml};
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
/// `report.md`, `demonstration.csv`, `figure3.svg`, `learning.svg`, and for
/// `diagnostics.svg`, and for each trial `trial_NN.json` and
/// `trial_NN.csv` (as [`write_trial`]).
///
/// # Errors
/// A file cannot be written; the error names it.
pub fn write_run(dir: &Path, run: &RunRecord) -> crate::Result<()> {
    fs::create_dir_all(dir).map_err(|e| crate::Error::io("creating", dir, e))?;
    for trial in &run.trials {
        write_trial(dir, trial)?;
    }
    write_atomic(&dir.join("report.json"), &to_json(run)?)?;
    write_atomic(&dir.join("demonstration.csv"), &demonstration_csv(&run.demonstration))?;
    write_atomic(&dir.join("figure3.svg"), &figure3_svg(run))?;
    write_atomic(&dir.join("learning.svg"), &learning_svg(run))?;
    write_atomic(
        &dir.join("diagnostics.svg"),
        &crate::output::diagnostics_report::diagnostics_svg(run),
    )?;
    write_atomic(&dir.join("report.md"), &markdown(run))?;
    Ok(())
}

/// Writes one trial into `dir` (created if needed): `trial_NN.json`, the
/// [`TrialRecord`] that [`read_trials`] reads back, and `trial_NN.csv`.
///
/// Each file is written to a temporary name and then renamed, so an
/// interrupted run never leaves a half-written record behind.
pub fn write_trial(dir: &Path, trial: &TrialRecord) -> crate::Result<()> {
    fs::create_dir_all(dir).map_err(|e| crate::Error::io("creating", dir, e))?;
    let saving = || format!("saving trial {}", trial.index);
    write_atomic(&dir.join(trial_csv_name(trial.index)), &trial_csv(trial)).with_context(saving)?;
    let json = to_json(trial).with_context(saving)?;
    write_atomic(&dir.join(trial_json_name(trial.index)), &json).with_context(saving)?;
    Ok(())
}

/// Replaces the text between the lines `start` and `end` of the file
/// `path` with `text`.
///
/// # Errors
/// The file cannot be read or written, or lacks the marker lines.
pub fn update_between(path: &std::path::Path, start: &str, end: &str, text: &str) -> crate::Result<()> {
    let old = std::fs::read_to_string(path).map_err(|e| crate::Error::io("reading", path, e))?;
    let (Some(a), Some(b)) = (old.find(start), old.find(end)) else {
        return Err(crate::Error::data(format!(
            "{} has no {start} ... {end} lines",
            path.display()
        )));
    };
    crate::error::ensure_data!(a < b, "{}: {end} comes before {start}", path.display());
    let new = format!("{}{start}\n{text}{}", &old[..a], &old[b..]);
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, new).map_err(|e| crate::Error::io("writing", &tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| crate::Error::io("renaming to", path, e))?;
    Ok(())
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

/// Writes `contents` to `path` through a temporary file and a rename.
/// Writes `contents` to `path` through `path.tmp` in the same directory
/// and a rename, so that `path` holds either its old or its new contents;
/// on failure the temporary file is removed and the error names the file.
///
/// # Errors
/// The temporary file cannot be written or renamed.
pub fn write_atomic(path: &Path, contents: &str) -> crate::Result<()> {
    let mut tmp: PathBuf = path.to_path_buf();
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    tmp.set_file_name(name);
    if let Err(e) = fs::write(&tmp, contents) {
        let _ = fs::remove_file(&tmp);
        return Err(crate::Error::io("writing", tmp, e));
    }
    fs::rename(&tmp, path).map_err(|e| {
        let _ = fs::remove_file(&tmp);
        crate::Error::io("renaming into place", path, e)
    })
}

// ---------------------------------------------------------------- CSV

fn csv_num(out: &mut String, x: Option<f64>) {
    if let Some(x) = x {
        let _ = write!(out, "{x}");
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
        let _ = write!(out, "{k},{}", k as f64 * trial.dt);
        for v in s {
            out.push(',');
            csv_num(&mut out, Some(*v));
        }
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
        let _ = write!(out, "{k},{}", k as f64 * demo.dt);
        for v in s {
            out.push(',');
            csv_num(&mut out, Some(*v));
        }
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
        "- [figure3.svg](figure3.svg): hand position and pendulum angle per trial, the demonstration dotted"
    );
    let _ = writeln!(
        md,
        "- [learning.svg](learning.svg): largest angle per trial and the plan's inconsistency"
    );
    let _ = writeln!(
        md,
        "- [diagnostics.svg](diagnostics.svg): the model's support along each plan, its error along \
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

// ---------------------------------------------------------------- SVG

fn trial_style(i: usize) -> String {
    format!(r#"fill="none" stroke="{}" stroke-width="1.6""#, colour(i))
}

const DEMO_STYLE: &str = r##"fill="none" stroke="#000" stroke-width="2" stroke-dasharray="2 3""##;

/// The paper's Figure 3: hand position $x(t)$ (top) and pendulum angle
/// $\theta(t)$ in degrees (bottom) for every trial, the demonstration dotted
/// black, on a shared time axis covering the longest trial. Each panel has
/// one `<polyline>` per trial and one for the demonstration.
pub fn figure3_svg(run: &RunRecord) -> String {
    let demo = &run.demonstration;
    let t_end = run
        .trials
        .iter()
        .map(|t| duration(t.states.len(), t.dt))
        .chain(std::iter::once(duration(demo.states.len(), demo.dt)))
        .filter(|d| d.is_finite())
        .fold(0.0, f64::max);
    let t_end = if t_end > 0.0 { t_end } else { 1.0 };
    let all_states = || {
        run.trials
            .iter()
            .flat_map(|t| t.states.iter())
            .chain(demo.states.iter())
    };
    let hand = range(all_states().map(|s| s[2]), &[0.0], 0.05);
    let angle = range(all_states().map(|s| s[0].to_degrees()), &[0.0, 180.0], 0.05);

    let (left, plot_w) = (75.0, 570.0);
    let top = Panel {
        left,
        top: 40.0,
        width: plot_w,
        height: 185.0,
        x: (0.0, t_end),
        y: hand,
        log_y: false,
    };
    let bottom = Panel {
        left,
        top: 250.0,
        width: plot_w,
        height: 195.0,
        x: (0.0, t_end),
        y: angle,
        log_y: false,
    };
    let (x_ticks, x_step) = nice_ticks(0.0, t_end, 8);

    let mut svg = String::new();
    svg_open(&mut svg, "Hand and pendulum motion per trial");
    heading(
        &mut svg,
        left + plot_w / 2.0,
        "Hand and pendulum motion per trial (demonstration dotted)",
    );
    top.axes(&mut svg, &x_ticks, x_step, false);
    top.y_title(&mut svg, "hand position x (m)");
    bottom.axes(&mut svg, &x_ticks, x_step, true);
    bottom.y_title(&mut svg, "pendulum angle θ (°)");
    bottom.reference(&mut svg, 180.0, "upright");
    bottom.reference(&mut svg, -180.0, "upright");
    let _ = writeln!(
        svg,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="13">time (s)</text>"#,
        left + plot_w / 2.0,
        bottom.bottom() + 38.0
    );

    for (panel, channel, degrees) in [(&top, 2, false), (&bottom, 0, true)] {
        let value = |s: &[f64; 4]| if degrees { s[channel].to_degrees() } else { s[channel] };
        for (i, t) in run.trials.iter().enumerate() {
            let pts = panel.points(t.states.iter().enumerate().map(|(k, s)| (k as f64 * t.dt, value(s))));
            let _ = writeln!(svg, r#"<polyline {} points="{pts}"/>"#, trial_style(i));
        }
        let pts = panel.points(
            demo.states
                .iter()
                .enumerate()
                .map(|(k, s)| (k as f64 * demo.dt, value(s))),
        );
        let _ = writeln!(svg, r#"<polyline {DEMO_STYLE} points="{pts}"/>"#);
    }

    let lx = left + plot_w + 20.0;
    let mut ly = 50.0;
    legend_entry(&mut svg, lx, ly, DEMO_STYLE, "demonstration");
    for (i, t) in run.trials.iter().enumerate() {
        ly += 18.0;
        let label = if t.success {
            format!("trial {} ✓", t.index)
        } else {
            format!("trial {}", t.index)
        };
        legend_entry(&mut svg, lx, ly, &trial_style(i), &label);
    }
    svg.push_str("</svg>\n");
    svg
}

/// Learning progress: the largest angle reached per trial (degrees; filled
/// markers for successes, dashed lines at 90°, halfway, and 180°, upright),
/// and below it the inconsistency of each planned trial's plan (log scale if
/// the values span two decades or more; zero and non-finite values are
/// left out). One `<circle>` per trial in the top panel.
pub fn learning_svg(run: &RunRecord) -> String {
    let n = run.trials.len();
    let trial_x = |t: &TrialRecord| t.index as f64;
    let x_range = match (run.trials.first(), run.trials.last()) {
        (Some(a), Some(b)) if b.index > a.index => (a.index as f64 - 0.5, b.index as f64 + 0.5),
        (Some(a), _) => (a.index as f64 - 0.5, a.index as f64 + 0.5),
        _ => (0.5, 1.5),
    };
    let angles = range(run.trials.iter().map(|t| t.max_angle.to_degrees()), &[0.0, 180.0], 0.05);
    let (left, plot_w) = (75.0, 600.0);
    let top = Panel {
        left,
        top: 40.0,
        width: plot_w,
        height: 260.0,
        x: x_range,
        y: angles,
        log_y: false,
    };

    let incons: Vec<(f64, f64)> = run
        .trials
        .iter()
        .filter_map(|t| t.plan.as_ref().map(|p| (trial_x(t), p.inconsistency)))
        .collect();
    let finite: Vec<f64> = incons.iter().map(|p| p.1).filter(|v| v.is_finite()).collect();
    let positive: Vec<f64> = finite.iter().copied().filter(|v| *v > 0.0).collect();
    let (pmin, pmax) = positive
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
    let log_y = positive.len() >= 2 && pmax / pmin >= 100.0;
    let y = if log_y {
        (10f64.powf(pmin.log10().floor()), 10f64.powf(pmax.log10().ceil()))
    } else {
        range(finite.iter().copied(), &[0.0], 0.1)
    };
    let bottom = Panel {
        left,
        top: 345.0,
        width: plot_w,
        height: 105.0,
        x: x_range,
        y,
        log_y,
    };

    let x_ticks: Vec<f64> = {
        let (a, b) = (x_range.0.ceil() as usize, x_range.1.floor() as usize);
        let every = (b.saturating_sub(a) / 15 + 1).max(1);
        (a..=b).step_by(every).map(|i| i as f64).collect()
    };

    let mut svg = String::new();
    svg_open(&mut svg, "Learning progress per trial");
    heading(&mut svg, left + plot_w / 2.0, "Largest pendulum angle per trial");
    top.axes(&mut svg, &x_ticks, 1.0, true);
    top.y_title(&mut svg, "max angle |θ| (°)");
    top.reference(&mut svg, 90.0, "halfway");
    top.reference(&mut svg, 180.0, "upright");
    let pts = top.points(run.trials.iter().map(|t| (trial_x(t), t.max_angle.to_degrees())));
    let _ = writeln!(svg, r#"<polyline {} points="{pts}"/>"#, trial_style(0));
    for t in &run.trials {
        let v = t.max_angle.to_degrees();
        if !v.is_finite() {
            continue;
        }
        let fill = if t.success { colour(0) } else { "white" };
        let _ = writeln!(
            svg,
            r#"<circle class="trial" cx="{:.1}" cy="{:.1}" r="5" fill="{fill}" stroke="{}" stroke-width="1.6"><title>{}</title></circle>"#,
            top.px(trial_x(t)),
            top.py(v),
            colour(0),
            xml(&format!(
                "trial {}: {:.1}°{}",
                t.index,
                v,
                if t.success { ", success" } else { "" }
            )),
        );
    }

    bottom.axes(&mut svg, &x_ticks, 1.0, true);
    bottom.y_title(&mut svg, "inconsistency");
    let _ = writeln!(
        svg,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="13">trial</text>"#,
        left + plot_w / 2.0,
        bottom.bottom() + 36.0
    );
    let _ = writeln!(
        svg,
        r#"<text x="{:.1}" y="{:.1}" font-size="12">plan inconsistency{}</text>"#,
        left + 6.0,
        bottom.top - 6.0,
        if log_y { " (log scale)" } else { "" }
    );
    if incons.is_empty() {
        let _ = writeln!(
            svg,
            r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="12" fill="#555">no planned trials</text>"##,
            left + plot_w / 2.0,
            bottom.top + bottom.height / 2.0
        );
    } else {
        let pts = bottom.points(incons.iter().copied());
        let _ = writeln!(svg, r#"<polyline {} points="{pts}"/>"#, trial_style(3));
        for &(x, v) in &incons {
            if v.is_finite() && (!log_y || v > 0.0) {
                let _ = writeln!(
                    svg,
                    r#"<rect x="{:.1}" y="{:.1}" width="6" height="6" fill="{}"/>"#,
                    bottom.px(x) - 3.0,
                    bottom.py(v) - 3.0,
                    colour(3)
                );
            }
        }
    }

    let lx = left + plot_w + 15.0;
    let _ = writeln!(
        svg,
        r#"<circle cx="{:.1}" cy="54" r="5" fill="{}" stroke="{}"/><text x="{:.1}" y="58" font-size="12">success</text>"#,
        lx + 6.0,
        colour(0),
        colour(0),
        lx + 16.0
    );
    let _ = writeln!(
        svg,
        r#"<circle cx="{:.1}" cy="74" r="5" fill="white" stroke="{}"/><text x="{:.1}" y="78" font-size="12">failure</text>"#,
        lx + 6.0,
        colour(0),
        lx + 16.0
    );
    let _ = writeln!(
        svg,
        r#"<text x="{:.1}" y="98" font-size="12">{n} trial{}</text>"#,
        lx,
        if n == 1 { "" } else { "s" }
    );
    svg.push_str("</svg>\n");
    svg
}
