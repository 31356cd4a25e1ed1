//! The run directory: report, logs and plots written by `swingup::output::run_report`.

use std::fs;
use std::path::Path;

use swingup::output::run_report::{
    DEMONSTRATION_CSV_HEADER, TRIAL_CSV_HEADER, read_trials, trial_csv_name, trial_json_name, write_run, write_trial,
};
use swingup::plant::demo::Demonstration;
use swingup::record::{ModelSummary, PlanSummary, RunRecord, TrialDiagnostics, TrialKind, TrialRecord, TrialTiming};

mod common;
use common::scratch;

const DT: f64 = 1.0 / 60.0;

fn swing(n: usize, peak: f64, phase: f64) -> Vec<[f64; 4]> {
    (0..=n)
        .map(|k| {
            let t = k as f64 / n as f64;
            let x = 0.2 * (6.0 * t + phase).sin();
            [peak * t * t, 2.0 * peak * t, x, 1.2 * (6.0 * t + phase).cos()]
        })
        .collect()
}

fn demonstration() -> Demonstration {
    let states = swing(20, std::f64::consts::PI, 0.0);
    let controls = (0..20).map(|k| 10.0 * (k as f64 * 0.3).sin()).collect();
    Demonstration {
        dt: DT,
        states,
        controls,
    }
}

fn model(n_points: usize, loo_nmse: f64) -> ModelSummary {
    ModelSummary {
        kind: "lwr".into(),
        n_points,
        inputs: ["theta", "theta_dot", "x", "x_dot", "u"].map(String::from).to_vec(),
        scales: vec![1.0, 0.5, 0.0, 2.0, 1.5],
        bandwidth: 0.3,
        loo_nmse,
        lwr_vs_prior: 0.25,
        dropped: vec!["x".into()],
        selection_cv: vec![0.5, 0.4],
    }
}

fn plan(inconsistency: f64, max_mismatch: f64) -> PlanSummary {
    PlanSummary {
        planner: "gauss-newton".into(),
        status: trajopt::GaussNewtonStatus::ConvergedCost.into(),
        cost: 12.5 + inconsistency,
        initial_cost: 400.0,
        task: 12.5,
        inconsistency,
        max_mismatch,
        iterations: 17,
        evaluations: 40,
        seconds: 0.0123,
        states: swing(20, 3.1, 0.1),
        controls: vec![1.0; 20],
        gauss_newton_cost: None,
    }
}

fn trial(index: usize, kind: TrialKind, n: usize, peak: f64, caught_at: Option<usize>, success: bool) -> TrialRecord {
    let states = swing(n, peak, 0.3 * index as f64);
    let observed = states.iter().map(|s| s.map(|v| v + 0.001)).collect();
    let commands = (0..n).map(|k| (k as f64).cos()).collect();
    let planned = kind == TrialKind::Planned;
    TrialRecord {
        index,
        kind,
        dt: DT,
        states,
        observed,
        commands,
        caught_at,
        max_angle: peak,
        success,
        failure: if success { String::new() } else { "fell | over".into() },
        plan: planned.then(|| plan(if index == 2 { 0.0 } else { 3.0e-4 }, f64::NAN)),
        model: planned.then(|| model(20 * index, if index == 2 { f64::NAN } else { 0.05 })),
        diagnostics: planned.then(|| diagnostics(n, index)),
        timing: TrialTiming {
            tuning: 0.5,
            planning: 1.25 * index as f64,
            rollout: 0.125,
        },
        mpc: None,
    }
}

/// Diagnostics with a gap in each series (a model without a value there).
fn diagnostics(n: usize, index: usize) -> TrialDiagnostics {
    let series = |scale: f64| -> Vec<f64> {
        (0..n - 1)
            .map(|k| {
                if k == 3 {
                    f64::NAN
                } else {
                    scale * (1.0 + (k as f64 * 0.4 + index as f64).sin())
                }
            })
            .collect()
    };
    TrialDiagnostics {
        start_offset: vec![0.01 * index as f64, 0.0, 0.0, 0.0],
        plan_support: series(20.0),
        plan_std_error: series(0.01),
        plan_inconsistency: series(0.5),
        executed_support: series(10.0),
        executed_std_error: series(0.02),
        executed_error: series(0.03),
        angle_gap: (0..n).map(|k| 0.02 * k as f64).collect(),
    }
}

fn run() -> RunRecord {
    RunRecord {
        config_toml: "seed = 1\n[planner]\nlambda = 1000.0\n".into(),
        demonstration: demonstration(),
        trials: vec![
            trial(1, TrialKind::Imitation, 24, 1.8, None, false),
            trial(2, TrialKind::Planned, 30, 2.9, Some(22), false),
            trial(3, TrialKind::Planned, 26, 3.2, Some(20), true),
        ],
        success_trial: Some(3),
        robot_seconds: 1.33,
    }
}

/// Equality in which NaN equals NaN.
fn same(a: f64, b: f64) -> bool {
    a == b || (a.is_nan() && b.is_nan())
}

fn same_trial(a: &TrialRecord, b: &TrialRecord) -> bool {
    let states = |x: &[[f64; 4]], y: &[[f64; 4]]| {
        x.len() == y.len() && x.iter().zip(y).all(|(p, q)| p.iter().zip(q).all(|(u, v)| same(*u, *v)))
    };
    let plans = match (&a.plan, &b.plan) {
        (None, None) => true,
        (Some(p), Some(q)) => {
            p.planner == q.planner
                && p.status == q.status
                && [
                    p.cost,
                    p.initial_cost,
                    p.task,
                    p.inconsistency,
                    p.max_mismatch,
                    p.seconds,
                ]
                .iter()
                .zip([
                    q.cost,
                    q.initial_cost,
                    q.task,
                    q.inconsistency,
                    q.max_mismatch,
                    q.seconds,
                ])
                .all(|(u, v)| same(*u, v))
                && p.iterations == q.iterations
                && p.evaluations == q.evaluations
                && states(&p.states, &q.states)
                && p.controls == q.controls
        }
        _ => false,
    };
    let models = match (&a.model, &b.model) {
        (None, None) => true,
        (Some(p), Some(q)) => {
            p.kind == q.kind
                && p.n_points == q.n_points
                && p.inputs == q.inputs
                && p.scales == q.scales
                && p.bandwidth == q.bandwidth
                && same(p.loo_nmse, q.loo_nmse)
        }
        _ => false,
    };
    a.index == b.index
        && a.kind == b.kind
        && a.dt == b.dt
        && states(&a.states, &b.states)
        && states(&a.observed, &b.observed)
        && a.commands == b.commands
        && a.caught_at == b.caught_at
        && same(a.max_angle, b.max_angle)
        && a.success == b.success
        && a.failure == b.failure
        && plans
        && models
}

fn read(dir: &Path, name: &str) -> Result<String, Box<dyn std::error::Error>> {
    fs::read_to_string(dir.join(name)).map_err(|e| format!("{name}: {e}").into())
}

#[test]
fn report_json_round_trips_with_nan() -> Result<(), Box<dyn std::error::Error>> {
    let dir = scratch("report-json");
    let run = run();
    write_run(dir.path(), &run)?;
    let back: RunRecord = serde_json::from_str(&read(dir.path(), "report.json")?)?;
    assert_eq!(back.config_toml, run.config_toml);
    assert_eq!(back.demonstration, run.demonstration);
    assert_eq!(back.success_trial, run.success_trial);
    assert_eq!(back.robot_seconds, run.robot_seconds);
    assert_eq!(back.trials.len(), run.trials.len());
    for (a, b) in back.trials.iter().zip(&run.trials) {
        assert!(same_trial(a, b), "trial {} differs after the round trip", b.index);
    }
    // NaN is written as null and read back as NaN
    let plan = back.trials[1].plan.as_ref().ok_or("no plan")?;
    assert!(plan.max_mismatch.is_nan());
    assert!(back.trials[1].model.as_ref().ok_or("no model")?.loo_nmse.is_nan());
    Ok(())
}

#[test]
fn infinities_are_read_back_as_nan() -> Result<(), Box<dyn std::error::Error>> {
    let mut t = trial(2, TrialKind::Planned, 10, 2.0, None, false);
    t.max_angle = f64::INFINITY;
    t.states[3][1] = f64::NEG_INFINITY;
    let text = serde_json::to_string(&t)?;
    let back: TrialRecord = serde_json::from_str(&text)?;
    assert!(back.max_angle.is_nan());
    assert!(back.states[3][1].is_nan());
    assert_eq!(back.states[3][0], t.states[3][0]);
    Ok(())
}

#[test]
fn markdown_has_the_trial_table_and_the_result() -> Result<(), Box<dyn std::error::Error>> {
    let dir = scratch("report-md");
    let run = run();
    write_run(dir.path(), &run)?;
    let md = read(dir.path(), "report.md")?;
    assert!(
        md.contains("```toml\nseed = 1\n[planner]\nlambda = 1000.0\n```"),
        "{md}"
    );
    assert!(
        md.contains("**Result:** success at trial 3 after 1.330 s of robot data."),
        "{md}"
    );
    for t in &run.trials {
        let kind = if t.kind == TrialKind::Imitation {
            "imitation"
        } else {
            "planned"
        };
        assert!(
            md.contains(&format!("\n| {} | {kind} | ", t.index)),
            "no row for trial {}:\n{md}",
            t.index
        );
    }
    // the trial table: the max angle in degrees, caught at in seconds, the escaped failure text
    assert!(
        md.contains("| 1 | imitation | 103.1 | — | no | fell \\| over |"),
        "{md}"
    );
    assert!(
        md.contains("| 3 | planned | 183.3 | 0.3333 | yes | — | 12.50 |"),
        "{md}"
    );
    // the metric scales table: trial x input names
    assert!(
        md.contains("| trial | theta | theta_dot | x | x_dot | u | bandwidth |"),
        "{md}"
    );
    assert!(
        md.contains("| 2 | 1.000 | 0.5000 | 0 | 2.000 | 1.500 | 0.3000 | 0.2500 |"),
        "{md}"
    );
    // the plan against reality: one row per planned trial, the time split
    assert!(md.contains("## Plan against reality"), "{md}");
    assert!(
        md.contains("1.500 s fitting and tuning models, 7.500 s planning, 0.3750 s running the robot"),
        "{md}"
    );
    assert!(md.lines().any(|l| l.starts_with("| 2 | 0.02000 |")), "{md}");
    assert!(
        md.lines()
            .any(|l| l.starts_with("| 3 | 0.03000 |") && l.contains("| 11 |")),
        "{md}"
    );
    for link in [
        "figure3.svg",
        "figure3.png",
        "learning.svg",
        "diagnostics.svg",
        "diagnostics.png",
        "demonstration.csv",
        "trial_01.csv",
        "trial_03.json",
    ] {
        assert!(md.contains(&format!("]({link})")), "no link to {link}");
    }

    let mut failed = run.clone();
    failed.success_trial = None;
    write_run(dir.path(), &failed)?;
    let md = read(dir.path(), "report.md")?;
    assert!(
        md.contains("**Result:** no success within 3 trials (1.330 s of robot data)."),
        "{md}"
    );
    Ok(())
}

#[test]
fn csv_logs_have_the_header_and_one_row_per_sample() -> Result<(), Box<dyn std::error::Error>> {
    let dir = scratch("report-csv");
    let run = run();
    write_run(dir.path(), &run)?;
    for t in &run.trials {
        let csv = read(dir.path(), &trial_csv_name(t.index))?;
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], TRIAL_CSV_HEADER);
        assert_eq!(lines.len(), t.states.len() + 1);
        let columns = TRIAL_CSV_HEADER.split(',').count();
        assert!(lines[1..].iter().all(|l| l.split(',').count() == columns));
        // the last row has no command
        let last: Vec<&str> = lines[lines.len() - 1].split(',').collect();
        assert_eq!(last[10], "");
        assert!(!lines[1].split(',').nth(10).unwrap_or_default().is_empty());
        // phases
        let phases: Vec<&str> = lines[1..].iter().filter_map(|l| l.rsplit(',').next()).collect();
        match t.caught_at {
            None => assert!(phases.iter().all(|p| *p == "imitate")),
            Some(c) => {
                assert!(phases[..c].iter().all(|p| *p == "plan"), "{phases:?}");
                assert!(phases[c..].iter().all(|p| *p == "balance"), "{phases:?}");
            }
        }
        assert!(lines[2].starts_with(&format!("1,{},", DT)));
    }
    let csv = read(dir.path(), "demonstration.csv")?;
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], DEMONSTRATION_CSV_HEADER);
    assert_eq!(lines.len(), run.demonstration.states.len() + 1);
    assert!(lines[lines.len() - 1].ends_with(','));
    Ok(())
}

fn count(text: &str, pattern: &str) -> usize {
    text.matches(pattern).count()
}

/// The text content of every `<text>` element, trimmed.
fn texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|s| s.split_once('>').and_then(|(_, rest)| rest.split_once("</text>")))
        .map(|(t, _)| t.trim().to_string())
        .collect()
}

/// The elements `<tag .../>` (one per line) whose attributes include `attr`.
fn elements<'a>(svg: &'a str, tag: &str, attr: &str) -> Vec<&'a str> {
    svg.lines()
        .filter(|l| l.starts_with(&format!("<{tag} ")) && l.contains(attr))
        .collect()
}

/// The stroke attribute of series colour `i`.
fn stroke(i: usize) -> String {
    let (r, g, b) = swingup::output::plot::PALETTE[i];
    format!("stroke=\"#{r:02X}{g:02X}{b:02X}\"")
}

/// The y coordinates of a polyline's points.
fn ys(polyline: &str) -> Vec<f64> {
    polyline
        .split("points=\"")
        .nth(1)
        .and_then(|p| p.split('"').next())
        .unwrap_or_default()
        .split_whitespace()
        .filter_map(|p| p.split(',').nth(1)?.parse().ok())
        .collect()
}

/// The width and height in a PNG file's header, if it is one.
fn png_size(png: &[u8]) -> Option<(u32, u32)> {
    let be = |i: usize| Some(u32::from_be_bytes(png.get(i..i + 4)?.try_into().ok()?));
    (png.starts_with(b"\x89PNG\r\n\x1a\n") && png.get(12..16) == Some(b"IHDR")).then_some((be(16)?, be(20)?))
}

#[test]
fn plots_are_svg_and_png_with_a_line_per_trial() -> Result<(), Box<dyn std::error::Error>> {
    let dir = scratch("report-svg");
    let mut run = run();
    run.trials[0].failure = "x < 0 & \"lost\"".into();
    write_run(dir.path(), &run)?;
    let n = run.trials.len();
    for (name, size) in [
        ("figure3", (800, 500)),
        ("learning", (800, 500)),
        ("diagnostics", (820, 645)),
    ] {
        let svg = read(dir.path(), &format!("{name}.svg"))?;
        assert!(svg.starts_with("<svg"), "{name}");
        assert!(svg.trim_end().ends_with("</svg>"), "{name}");
        assert_eq!(count(&svg, "<"), count(&svg, ">"), "{name}: unbalanced brackets");
        assert!(
            !svg.contains("NaN") && !svg.contains("inf"),
            "{name}: non-finite coordinates"
        );
        assert!(
            !svg.contains("href") && !svg.contains("url("),
            "{name}: external resource"
        );
        let png = fs::read(dir.path().join(format!("{name}.png")))?;
        assert_eq!(png_size(&png), Some(size), "{name}.png");
    }
    let fig = read(dir.path(), "figure3.svg")?;
    // two panels, each with a line per trial, and the legend's
    for i in 0..n {
        assert_eq!(elements(&fig, "polyline", &stroke(i)).len(), 3, "trial {}", i + 1);
    }
    // the demonstration dotted (many short black dashes) in both panels
    // (the top one ends at y = 225) and the legend (right of x = 645)
    let dots = elements(&fig, "polyline", "stroke=\"#000000\"");
    assert!(dots.len() > 10, "{} dashes", dots.len());
    let dot_ys: Vec<f64> = dots.iter().flat_map(|d| ys(d)).collect();
    assert!(dot_ys.iter().any(|y| *y < 225.0) && dot_ys.iter().any(|y| *y > 250.0));
    assert!(dots.iter().any(|d| d.contains("points=\"665,")), "dotted legend entry");
    let labels = texts(&fig);
    for t in &run.trials {
        assert!(
            labels.iter().any(|l| l.starts_with(&format!("trial {}", t.index))),
            "no legend for trial {}",
            t.index
        );
    }
    assert!(labels.iter().any(|l| l == "upright"));
    let learning = read(dir.path(), "learning.svg")?;
    // a marker per trial, and the legend's success and failure
    assert_eq!(elements(&learning, "circle", "r=\"5\"").len(), n + 2);
    let labels = texts(&learning);
    assert!(labels.iter().any(|l| l == "halfway") && labels.iter().any(|l| l == "upright"));
    // max angle and inconsistency: one line each
    assert_eq!(elements(&learning, "polyline", &stroke(0)).len(), 1);
    assert_eq!(elements(&learning, "polyline", &stroke(3)).len(), 1);
    // 0 and 3e-4: not spanning decades among the positive values, linear
    assert!(!learning.contains("log scale"));
    Ok(())
}

#[test]
fn inconsistency_spanning_decades_is_on_a_log_scale() -> Result<(), Box<dyn std::error::Error>> {
    let dir = scratch("report-log");
    let mut run = run();
    if let Some(p) = run.trials[1].plan.as_mut() {
        p.inconsistency = 5.0;
    }
    if let Some(p) = run.trials[2].plan.as_mut() {
        p.inconsistency = 2e-3;
    }
    write_run(dir.path(), &run)?;
    let learning = read(dir.path(), "learning.svg")?;
    assert!(learning.contains("log scale"));
    let labels = texts(&learning);
    assert!(
        labels.iter().any(|l| l == "1e-3") && labels.iter().any(|l| l == "1e1"),
        "{labels:?}"
    );
    Ok(())
}

#[test]
fn trials_are_read_back_in_order_until_the_first_gap() -> Result<(), Box<dyn std::error::Error>> {
    let root = scratch("report-trials");
    let dir = root.path().join("run");
    assert!(read_trials(&dir)?.is_empty(), "no directory: no trials");
    let run = run();
    // written out of order
    for i in [1, 0, 2] {
        write_trial(&dir, &run.trials[i])?;
    }
    assert!(dir.join(trial_csv_name(2)).exists());
    let back = read_trials(&dir)?;
    assert_eq!(back.len(), 3);
    for (a, b) in back.iter().zip(&run.trials) {
        assert!(same_trial(a, b), "trial {} differs", b.index);
    }
    // a gap: trial 5 without trial 4 is not read
    let mut five = run.trials[2].clone();
    five.index = 5;
    write_trial(&dir, &five)?;
    assert_eq!(read_trials(&dir)?.len(), 3);
    assert!(!dir.join("trial_03.json.tmp").exists());
    Ok(())
}

#[test]
fn a_corrupt_trial_file_is_an_error_naming_it() -> Result<(), Box<dyn std::error::Error>> {
    let dir = scratch("report-corrupt");
    let run = run();
    write_trial(dir.path(), &run.trials[0])?;
    write_trial(dir.path(), &run.trials[1])?;
    fs::write(dir.path().join(trial_json_name(2)), "{\"index\": 2, \"kind\": ")?;
    let err = match read_trials(dir.path()) {
        Ok(_) => return Err("a corrupt file was read".into()),
        Err(e) => format!("{e:#}"),
    };
    assert!(err.contains("trial_02.json"), "{err}");

    // a record whose number is not the one in its name
    fs::write(
        dir.path().join(trial_json_name(2)),
        serde_json::to_string(&run.trials[2])?,
    )?;
    let err = match read_trials(dir.path()) {
        Ok(_) => return Err("a misnumbered file was read".into()),
        Err(e) => format!("{e:#}"),
    };
    assert!(err.contains("trial_02.json") && err.contains("expected 2"), "{err}");
    Ok(())
}
