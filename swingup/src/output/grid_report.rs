//! The grid's report, `experiments.md`: which code made the runs, the
//! claims table, the figures, one table per experiment and every run.

use crate::experiments::claims::describe;
use crate::experiments::{Claim, ExperimentsReport, VariantSummary, demonstration_worth};
use crate::output::plot::experiment_figure_stems;

/// Which code made the runs and how long the grid took: one line, for the
/// report and above the README's claims table. Runs of more than one code
/// version are named as such, with their counts.
pub fn provenance(report: &ExperimentsReport) -> String {
    let mut versions: Vec<(String, usize)> = Vec::new();
    for r in &report.runs {
        let v = if r.code_version.is_empty() {
            "an unrecorded commit".to_string()
        } else {
            r.code_version.clone()
        };
        match versions.iter_mut().find(|(name, _)| *name == v) {
            Some((_, n)) => *n += 1,
            None => versions.push((v, 1)),
        }
    }
    let code = match versions.as_slice() {
        [] => "no runs".to_string(),
        [(v, n)] => format!("{n} runs, all made at {v}"),
        _ => format!(
            "{} runs made by more than one code version ({}): regenerate the grid with --force before comparing them",
            report.runs.len(),
            versions
                .iter()
                .map(|(v, n)| format!("{n} at {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let wall = match report.ran {
        Some(0) => "written from saved runs (no wall time measured)".to_string(),
        None => format!(
            "{:.0} s of wall time on {} threads for the invocation that wrote the report (its share of the runs not recorded)",
            report.seconds, report.threads
        ),
        Some(n) if n == report.runs.len() => format!(
            "all run by one invocation in {:.0} s of wall time on {} threads",
            report.seconds, report.threads
        ),
        Some(n) => format!(
            "{n} of them run by the invocation that wrote this, in {:.0} s of wall time on {} threads",
            report.seconds, report.threads
        ),
    };
    format!(
        "{code}; {:.0} s of run time summed over the runs; {wall}.",
        report.runs.iter().map(|r| r.seconds).sum::<f64>()
    )
}

/// `experiments.md`: the claims table, then one table per experiment.
pub fn markdown(report: &ExperimentsReport) -> String {
    let mut md = String::from("# Experiments\n\n");
    md.push_str(&format!(
        "{} runs; seeds: {} for learning with Gauss-Newton and B-splines, {} with wavelets, {} with Powell, {} per variant elsewhere; at most {} trials each. Regenerate with `cargo run --release -p swingup -- experiments`.\n\n",
        report.runs.len(),
        report.settings.learning_seeds,
        report.settings.wavelet_seeds,
        report.settings.powell_seeds,
        report.settings.seeds,
        report.settings.max_trials,
    ));
    md.push_str(&format!("{}\n\n", provenance(report)));
    md.push_str(&claims_table(&report.claims));
    let figures = experiment_figure_stems(report);
    if !figures.is_empty() {
        md.push_str("\n## Figures\n\nEach figure is also written as a PNG image of the same name.\n\n");
        for stem in figures {
            md.push_str(&format!("![{stem}]({stem}.svg) ([PNG]({stem}.png))\n\n"));
        }
    }
    md.push_str("\n## Variants\n\n| experiment | variant | runs | successes | median trial of success | range | median robot seconds to success |\n|---|---|---|---|---|---|---|\n");
    for v in &report.variants {
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} |\n",
            v.experiment,
            v.variant,
            v.runs,
            v.successes,
            v.median_trials.map_or("-".into(), |m| format!("{m}")),
            v.trial_range.map_or("-".into(), |(a, b)| format!("{a}-{b}")),
            v.median_robot_seconds.map_or("-".into(), |m| format!("{m:.1}"))
        ));
    }
    let worth = demonstration_worth(&report.variants);
    if !worth.is_empty() {
        md.push_str("\n## The demonstration's worth (beyond the paper)\n\nLearning with the demonstration against learning from scratch (`start = \"scratch\"` in the configuration: a random exploration trial first, the cost tracking upright throughout, each plan starting from the previous trial). Robot seconds count every trial up to success, the demonstration itself not included; runs that never succeed are not in the medians.\n\n| model | with the demonstration | from scratch |\n|---|---|---|\n");
        for (model, with, without) in worth {
            md.push_str(&format!(
                "| {model} | {} | {} |\n",
                with_seconds(with),
                with_seconds(without)
            ));
        }
    }
    let mpc = mpc_table(report);
    if !mpc.is_empty() {
        md.push_str("\n## Model-predictive control (beyond the paper)\n\n");
        md.push_str(&mpc);
    }
    md.push_str("\n## Runs\n\n| experiment | variant | seed | success | max angle per trial (deg) | plan statuses |\n|---|---|---|---|---|---|\n");
    for r in &report.runs {
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            r.experiment,
            r.variant,
            r.seed,
            r.success_trial.map_or("no".into(), |t| format!("trial {t}")),
            r.max_angles
                .iter()
                .map(|a| format!("{:.0}", a.to_degrees()))
                .collect::<Vec<_>>()
                .join(" "),
            r.plan_statuses.join(" ")
        ));
    }
    md
}

fn with_seconds(v: &VariantSummary) -> String {
    format!(
        "{}{}",
        describe(Some(v)),
        v.median_robot_seconds
            .map_or(String::new(), |s| format!(", median {s:.1} s of robot data"))
    )
}

/// The `mpc` experiment's table (also copied into the README): per model,
/// open loop against MPC, and the replan times of the MPC runs (the median
/// over trials of each trial's median replan, and the largest 99th
/// percentile of a trial); empty without `mpc` runs.
pub fn mpc_table(report: &ExperimentsReport) -> String {
    let find = |v: &str| report.variants.iter().find(|x| x.experiment == "mpc" && x.variant == v);
    let mut models: Vec<&str> = report
        .variants
        .iter()
        .filter(|v| v.experiment == "mpc")
        .filter_map(|v| v.variant.split_once('/').map(|(_, m)| m))
        .collect();
    models.sort_unstable();
    models.dedup();
    if models.is_empty() {
        return String::new();
    }
    let mut md = String::from(
        "Open loop (the paper's) against model-predictive control (`--controller mpc`: Eq. 3 replanned from the measured state at every 60 Hz step, one Gauss-Newton iteration per replan, the 150-step window warm-started from the previous plan, each observed transition added to the LWR at once). Seconds of robot data count every trial up to success; runs that never succeed are not in the medians. Replan times are wall times during the grid's runs (two runs in parallel on 2 cores), not a benchmark.\n\n| model | open loop | MPC | MPC replan (ms): median, worst trial's 99th percentile |\n|---|---|---|---|\n",
    );
    for model in models {
        let cell = |v: Option<&VariantSummary>| v.map_or("not run".to_string(), with_seconds);
        let replans: Vec<[f64; 2]> = report
            .runs
            .iter()
            .filter(|r| r.experiment == "mpc" && r.variant == format!("mpc/{model}"))
            .flat_map(|r| r.replan_ms.iter().copied())
            .filter(|t| t.iter().all(|v| v.is_finite()))
            .collect();
        let times = if replans.is_empty() {
            "-".to_string()
        } else {
            let mut medians: Vec<f64> = replans.iter().map(|t| t[0]).collect();
            medians.sort_by(f64::total_cmp);
            let worst = replans.iter().map(|t| t[1]).fold(f64::NEG_INFINITY, f64::max);
            format!("{:.1}, {:.1}", medians[medians.len() / 2], worst)
        };
        md.push_str(&format!(
            "| {model} | {} | {} | {times} |\n",
            cell(find(&format!("open-loop/{model}"))),
            cell(find(&format!("mpc/{model}")))
        ));
    }
    md
}

/// The claims table alone (also copied into the README).
pub fn claims_table(claims: &[Claim]) -> String {
    let mut md = String::from("| claim | paper | ours | reproduced |\n|---|---|---|---|\n");
    for c in claims {
        md.push_str(&format!("| {} | {} | {} | {} |\n", c.id, c.paper, c.ours, c.reproduced));
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiments::tests::summary;
    use crate::experiments::{ExperimentSettings, RunSummary};

    /// The provenance line names the one code version of a uniform grid,
    /// and every version with its count in a mixed one (old runs without a
    /// version count as unrecorded).
    #[test]
    fn provenance_names_every_code_version() {
        let mut runs = vec![
            summary("lambda", "lambda=1e3", 1, Some(2), 1.0),
            summary("lambda", "lambda=1e3", 2, None, 1.0),
        ];
        let report = |runs: Vec<RunSummary>| ExperimentsReport {
            settings: ExperimentSettings::quick(),
            experiments: vec![],
            runs,
            variants: vec![],
            claims: vec![],
            seconds: 12.0,
            threads: 2,
            ran: Some(2),
        };
        let one = provenance(&report(runs.clone()));
        assert!(one.starts_with("2 runs, all made at commit test"), "{one}");
        assert!(
            one.contains("all run by one invocation in 12 s of wall time on 2 threads"),
            "{one}"
        );
        let saved = ExperimentsReport {
            ran: Some(0),
            ..report(runs.clone())
        };
        assert!(
            provenance(&saved).contains("no wall time measured"),
            "{}",
            provenance(&saved)
        );
        runs[1].code_version = String::new();
        let mixed = provenance(&report(runs));
        assert!(mixed.contains("more than one code version"), "{mixed}");
        assert!(
            mixed.contains("1 at commit test") && mixed.contains("1 at an unrecorded commit"),
            "{mixed}"
        );
    }
    /// A report rewritten from saved runs keeps the measured wall time of
    /// the report it replaces when the runs are the same, and only then.
    #[test]
    fn a_rewritten_report_keeps_the_measured_wall_time() {
        let runs = vec![
            summary("lambda", "lambda=1e3", 1, Some(2), 1.0),
            summary("lambda", "lambda=1e3", 2, None, 1.0),
        ];
        let report = |runs: Vec<RunSummary>, seconds, ran: usize| ExperimentsReport {
            settings: ExperimentSettings::quick(),
            experiments: vec![],
            runs,
            variants: vec![],
            claims: vec![],
            seconds,
            threads: 2,
            ran: Some(ran),
        };
        let measured = report(runs.clone(), 5576.0, 2);
        // the same runs read back in the other order
        let mut rewritten = report(runs.iter().rev().cloned().collect(), 0.1, 0);
        assert!(rewritten.keep_wall_time_of(&measured));
        assert!(provenance(&rewritten).contains("in 5576 s of wall time on 2 threads"));
        // another run set, or a report that ran something itself, keeps its own
        let mut fewer = report(runs[..1].to_vec(), 0.1, 0);
        assert!(!fewer.keep_wall_time_of(&measured));
        assert!(provenance(&fewer).contains("no wall time measured"));
        let mut other_code = report(runs.clone(), 0.1, 0);
        other_code.runs[0].code_version = "commit other".into();
        assert!(!other_code.keep_wall_time_of(&measured));
        // a report from before `ran` was recorded keeps its old meaning
        let legacy: ExperimentsReport = serde_json::from_str(
            &serde_json::to_string(&measured)
                .expect("json")
                .replace(",\"ran\":2", ""),
        )
        .expect("legacy report");
        assert_eq!(legacy.ran, None);
        let mut from_legacy = report(runs.clone(), 0.1, 0);
        assert!(from_legacy.keep_wall_time_of(&legacy));
        assert!(provenance(&from_legacy).contains("5576 s of wall time on 2 threads for the invocation"));
        let mut ran = report(runs, 30.0, 1);
        assert!(!ran.keep_wall_time_of(&measured) && ran.seconds == 30.0);
    }
}
