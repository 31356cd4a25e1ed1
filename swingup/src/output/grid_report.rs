//! The grid's report, `experiments.md`: which code made the runs, the
//! claims table, the figures, one table per experiment and every run.

use crate::experiments::claims::describe;
use crate::experiments::{
    Claim, Experiment, ExperimentsReport, RunSummary, TaskTime, VariantSummary, demonstration_worth, is_cartpole,
    task_of,
};
use crate::output::plot::experiment_figure_stems;
use crate::record::quantile;

/// Which code made the runs and how long the grid took: one line, for the
/// report and above the README's claims table. Runs of more than one code
/// version are named as such, with their counts.
pub fn provenance(report: &ExperimentsReport) -> String {
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
    provenance_line(&report.runs.iter().collect::<Vec<_>>(), &wall)
}

/// [`provenance`] of one task's runs alone (`pendulum` or `cartpole`, see
/// [`task_of`]), with the wall time of the invocation that made them
/// ([`ExperimentsReport::task_times`]).
pub fn task_provenance(report: &ExperimentsReport, task: &str) -> String {
    let runs: Vec<&RunSummary> = report.runs.iter().filter(|r| task_of(r) == task).collect();
    let wall = match report.task_time(task) {
        None => "written from saved runs (no wall time measured)".to_string(),
        Some(TaskTime {
            ran: None,
            seconds,
            threads,
            ..
        }) => format!(
            "{seconds:.0} s of wall time on {threads} threads for the invocation that wrote the report (its share of the runs not recorded)"
        ),
        Some(t) => {
            let ran = t.ran.unwrap_or(0);
            let others = t.invocation_ran.map_or(0, |n| n.saturating_sub(ran));
            format!(
                "{} in {:.0} s of wall time on {} threads{}",
                if ran == runs.len() {
                    "all run by one invocation".to_string()
                } else {
                    format!("{ran} of them run by one invocation")
                },
                t.seconds,
                t.threads,
                if others > 0 {
                    format!(" (which also made {others} other runs)")
                } else {
                    String::new()
                }
            )
        }
    };
    provenance_line(&runs, &wall)
}

/// `runs`' code versions (with their counts when more than one), their
/// summed run time and `wall`, in one sentence.
fn provenance_line(runs: &[&RunSummary], wall: &str) -> String {
    let mut versions: Vec<(String, usize)> = Vec::new();
    for r in runs {
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
            runs.len(),
            versions
                .iter()
                .map(|(v, n)| format!("{n} at {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    format!(
        "{code}; {:.0} s of run time summed over the runs; {wall}.",
        runs.iter().map(|r| r.seconds).sum::<f64>()
    )
}

/// The tasks of `report`'s runs, pendulum first.
fn tasks(report: &ExperimentsReport) -> Vec<&'static str> {
    ["pendulum", "cartpole"]
        .into_iter()
        .filter(|t| report.runs.iter().any(|r| task_of(r) == *t))
        .collect()
}

/// `experiments.md`: the claims table, then one table per experiment.
pub fn markdown(report: &ExperimentsReport) -> String {
    let mut md = String::from("# Experiments\n\n");
    let s = &report.settings;
    if report.experiments == [Experiment::Mpc] {
        md.push_str(&format!(
            "{} runs; {} seeds per variant; at most {} trials per pendulum run, a random trial and at most {} MPC trials per cart-pole run. Regenerate with `cargo run --release -p swingup -- experiments mpc`.\n\n",
            report.runs.len(),
            s.mpc_seeds,
            s.max_trials,
            s.cartpole.max_trials,
        ));
    } else {
        let paper_basis = if s.paper_basis_seeds > 0 {
            format!(", {} on the paper's basis", s.paper_basis_seeds)
        } else {
            String::new()
        };
        md.push_str(&format!(
            "{} runs; seeds: {} for learning with Gauss-Newton and B-splines, {} with wavelets, {} with Powell{paper_basis}, {} per variant elsewhere; at most {} trials each. Regenerate with `cargo run --release -p swingup -- experiments`.\n\n",
            report.runs.len(),
            s.learning_seeds,
            s.wavelet_seeds,
            s.powell_seeds,
            s.seeds,
            s.max_trials,
        ));
    }
    match tasks(report).as_slice() {
        [_, _, ..] => {
            for task in tasks(report) {
                md.push_str(&format!("- {task}: {}\n", task_provenance(report, task)));
            }
            md.push('\n');
        }
        _ => md.push_str(&format!("{}\n\n", provenance(report))),
    }
    if !report.missing.is_empty() {
        const SHOWN: usize = 50;
        md.push_str(&format!(
            "**Incomplete:** {} of the grid's runs have no record, so no claim is judged: {}{}.\n\n",
            report.missing.len(),
            report
                .missing
                .iter()
                .take(SHOWN)
                .cloned()
                .collect::<Vec<_>>()
                .join(", "),
            if report.missing.len() > SHOWN { ", ..." } else { "" }
        ));
    }
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
    let cartpole = cartpole_table(report);
    if !cartpole.is_empty() {
        md.push_str("\n## PILCO's cart-pole from scratch (beyond the paper)\n\n");
        md.push_str(&cartpole);
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
            r.plan_statuses
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(" ")
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
        .filter(|v| v.experiment == "mpc" && !v.variant.starts_with("cartpole/"))
        .filter_map(|v| v.variant.split_once('/').map(|(_, m)| m))
        .collect();
    models.sort_unstable();
    models.dedup();
    if models.is_empty() {
        return String::new();
    }
    let mut md = String::from(
        "Open loop (the paper's) against model-predictive control (`--controller mpc`: Eq. 3 replanned from the measured state at every 60 Hz step, one Gauss-Newton iteration per replan, the 150-step window warm-started from the previous plan, each observed transition added to the LWR at once). Seconds of robot data count every trial up to success; runs that never succeed are not in the medians. Replan times are wall times during the grid's runs (two runs in parallel on 2 cores), not a benchmark.\nThe models: `lwr` is the paper's pure LWR, over a global linear prior; `lwr-control-affine` the same LWR over a control-affine prior on the angle's sine and cosine and the other inputs (`--prior control-affine`), whose twelve regressors include the three features of the parametric model; `lwr-parametric` the LWR correcting the parametric model; `true` the robot's own dynamics.\n\n| model | open loop | MPC | MPC replan (ms): median, worst trial's 99th percentile |\n|---|---|---|---|\n",
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
        let times = replan_cell(&replans);
        md.push_str(&format!(
            "| {model} | {} | {} | {times} |\n",
            cell(find(&format!("open-loop/{model}"))),
            cell(find(&format!("mpc/{model}")))
        ));
    }
    md
}

/// The replan times of some MPC trials, each its (median, 99th
/// percentile): the median over trials of the trials' medians and the
/// largest 99th percentile of a trial (ms, [`quantile`]); `-` for none.
fn replan_cell(replans: &[[f64; 2]]) -> String {
    if replans.is_empty() {
        return "-".to_string();
    }
    let medians: Vec<f64> = replans.iter().map(|t| t[0]).collect();
    let worst = replans.iter().map(|t| t[1]).fold(f64::NEG_INFINITY, f64::max);
    format!("{:.1}, {:.1}", quantile(&medians, 0.5), worst)
}

/// The published figures the cart-pole is compared with: (method, seconds
/// of system data to learn the swing-up, source).
pub const CARTPOLE_PUBLISHED: [(&str, f64, &str); 2] = [
    (
        "PILCO",
        17.5,
        "Deisenroth and Rasmussen, \"PILCO: A Model-Based and Data-Efficient Approach to Policy Search\", ICML 2011",
    ),
    (
        "GP-MPC",
        9.0,
        "Kamthe and Deisenroth, \"Data-Efficient Reinforcement Learning with Probabilistic Model Predictive Control\", AISTATS 2018",
    ),
];

/// Of `runs`, how many had succeeded by each trial $1, \dots,$ `trials`
/// (the random trial counted): entry $j$ counts the runs whose first
/// success came at trial $j + 1$ or earlier.
pub fn successes_by_trial(runs: &[&RunSummary], trials: usize) -> Vec<usize> {
    (1..=trials)
        .map(|j| runs.iter().filter(|r| r.success_trial.is_some_and(|t| t <= j)).count())
        .collect()
}

/// The cart-pole table of the `mpc` experiment (also copied into the
/// README): the provenance of its runs, the task and our success
/// criterion, the success rate after each trial, and the seconds of
/// system data to success (median over the runs that succeeded) beside
/// PILCO's and GP-MPC's published figures ([`CARTPOLE_PUBLISHED`]), with
/// the replan times; empty without cart-pole runs.
pub fn cartpole_table(report: &ExperimentsReport) -> String {
    let runs: Vec<&RunSummary> = report.runs.iter().filter(|r| is_cartpole(r)).collect();
    if runs.is_empty() {
        return String::new();
    }
    let s = &report.settings.cartpole;
    let trials = s.max_trials + 1;
    let n = runs.len();
    let mut md = format!("{}\n\n", task_provenance(report, "cartpole"));
    md.push_str(&format!(
        "PILCO's cart-pole swing-up (the masses, pole length, friction, {} N force limit, {} s control period and {} s episodes of its MATLAB code; `swingup::cartpole`), learned from scratch with the pure LWR:\none random trial, then up to {} trials of model-predictive control (Eq. 3 replanned from the measured state at every control period over a {}-step window, each observed transition added to the LWR at once, each replan warm-started from the previous plan;\nthe trial's first plan starts cold, from three initial guesses, and is timed apart).\nThe model: the LWR of the change of state over a {} prior, refitted and its metric retuned {}.\n**Success** is our criterion (neither published figure below comes with a numerical one): the pole's tip within {} m of the target, upright over the origin, over the episode's last {} s.\nSeconds of system data count every trial up to success, the random one included; runs that never succeed are not in the median.\nReplan times are wall times during the grid's runs, not a benchmark.\n\n",
        s.plant.max_force,
        s.plant.dt,
        s.episode,
        s.max_trials,
        s.window,
        if s.model.control_affine {
            "control-affine (the force's gain linear in the state's features)"
        } else {
            "linear"
        },
        if s.refit_every > 0 {
            format!("between trials and every {} s within one", s.refit_every as f64 * s.plant.dt)
        } else {
            "between trials".to_string()
        },
        s.success_distance,
        s.success_hold,
    ));
    let by_trial = successes_by_trial(&runs, trials);
    md.push_str("| after trial |");
    for j in 1..=trials {
        md.push_str(&format!(" {j} |"));
    }
    md.push_str("\n|---|");
    md.push_str(&"---|".repeat(trials));
    md.push_str(&format!("\n| succeeded (of {n}) |"));
    for k in &by_trial {
        md.push_str(&format!(" {k} |"));
    }
    md.push_str("\n| success rate |");
    for k in &by_trial {
        md.push_str(&format!(" {:.0} % |", 100.0 * *k as f64 / n as f64));
    }
    let variant = report.variants.iter().find(|v| v.variant == runs[0].variant);
    let ok: Vec<&&RunSummary> = runs.iter().filter(|r| r.success_trial.is_some()).collect();
    let seconds = match variant.and_then(|v| v.median_robot_seconds) {
        Some(m) => {
            let lo = ok.iter().map(|r| r.robot_seconds).fold(f64::INFINITY, f64::min);
            let hi = ok.iter().map(|r| r.robot_seconds).fold(f64::NEG_INFINITY, f64::max);
            format!("median {m:.1} s (range {lo:.1}-{hi:.1} s)")
        }
        None => "no success".to_string(),
    };
    let replans: Vec<[f64; 2]> = runs
        .iter()
        .flat_map(|r| r.replan_ms.iter().copied())
        .filter(|t| t.iter().all(|v| v.is_finite()))
        .collect();
    let firsts: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.first_plan_ms.iter().copied())
        .filter(|t| t.is_finite())
        .collect();
    let first = if firsts.is_empty() {
        "-".to_string()
    } else {
        format!(
            "{:.1}, {:.1}",
            quantile(&firsts, 0.5),
            firsts.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        )
    };
    md.push_str("\n\n| method | seconds of system data to success | runs that succeeded | replan (ms): median, worst trial's 99th percentile | first plan of a trial (ms): median, largest | source |\n|---|---|---|---|---|---|\n");
    md.push_str(&format!(
        "| LWR + MPC (ours) | {seconds} | {}/{n} within {trials} trials | {} | {first} | this table |\n",
        ok.len(),
        replan_cell(&replans)
    ));
    for (method, secs, source) in CARTPOLE_PUBLISHED {
        md.push_str(&format!(
            "| {method} | {secs} s | no numerical criterion published | - | - | {source} |\n"
        ));
    }
    md
}

/// The README's `mpc` block: the pendulum's provenance and MPC table,
/// then the cart-pole's ([`cartpole_table`]) when it ran.
pub fn mpc_readme_block(report: &ExperimentsReport) -> String {
    let mut block = format!("{}\n\n{}", task_provenance(report, "pendulum"), mpc_table(report));
    let cartpole = cartpole_table(report);
    if !cartpole.is_empty() {
        block.push('\n');
        block.push_str(&cartpole);
    }
    block
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
    use crate::experiments::ExperimentSettings;
    use crate::experiments::tests::summary;

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
            task_times: vec![],
            missing: vec![],
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
    /// The cart-pole table on hand-made runs: the success rate after each
    /// trial counts the runs whose first success came by then; the median
    /// seconds of data are over the successful runs only; the published
    /// figures stand beside ours with their sources; our criterion is
    /// stated; the pendulum table leaves the cart-pole runs out.
    #[test]
    fn the_cartpole_table_counts_successes_by_trial_and_medians_successes_only() {
        use crate::experiments::{CARTPOLE_VARIANT, TaskTime, summarise};
        let cart = |seed, success: Option<usize>| {
            let mut r = summary("mpc", CARTPOLE_VARIANT, seed, success, 0.0);
            // 4 s per trial; a failed run counts all 16 of its trials
            r.trials = success.unwrap_or(16);
            r.robot_seconds = 4.0 * r.trials as f64;
            r.replan_ms = vec![[8.0, 200.0]; r.trials - 1];
            r.replan_ms[0] = [6.0, 300.0];
            r.first_plan_ms = vec![500.0; r.trials - 1];
            r.first_plan_ms[0] = 900.0;
            r.code_version = "commit cart".into();
            r
        };
        let mut runs = vec![
            cart(1, Some(3)),
            cart(2, Some(5)),
            cart(3, None),
            cart(4, Some(3)),
            summary("mpc", "mpc/lwr", 1, Some(2), 1.0),
        ];
        runs[4].replan_ms = vec![[20.0, 40.0]];
        let variants = summarise(&runs);
        let report = ExperimentsReport {
            settings: ExperimentSettings::full(),
            experiments: vec![Experiment::Mpc],
            runs,
            variants,
            claims: vec![],
            seconds: 50.0,
            threads: 2,
            ran: Some(4),
            task_times: vec![TaskTime {
                task: "cartpole".into(),
                ran: Some(4),
                invocation_ran: Some(4),
                seconds: 50.0,
                threads: 2,
            }],
            missing: vec![],
        };
        let cart_runs: Vec<&RunSummary> = report.runs.iter().filter(|r| is_cartpole(r)).collect();
        let by_trial = successes_by_trial(&cart_runs, 16);
        assert_eq!(&by_trial[..6], &[0, 0, 2, 2, 3, 3]);
        assert_eq!(by_trial[15], 3);
        let t = cartpole_table(&report);
        assert!(
            t.starts_with("4 runs, all made at commit cart; ")
                && t.contains("all run by one invocation in 50 s of wall time on 2 threads"),
            "{t}"
        );
        assert!(t.contains("| succeeded (of 4) | 0 | 0 | 2 | 2 | 3 | 3 |"), "{t}");
        assert!(t.contains("| success rate | 0 % | 0 % | 50 % | 50 % | 75 % |"), "{t}");
        // successes at 12, 12 and 20 s: median 12, the failure's 64 s left out
        assert!(
            t.contains("| LWR + MPC (ours) | median 12.0 s (range 12.0-20.0 s) | 3/4 within 16 trials | 8.0, 300.0 | 500.0, 900.0 |"),
            "{t}"
        );
        assert!(t.contains("| PILCO | 17.5 s |") && t.contains("ICML 2011"), "{t}");
        assert!(t.contains("| GP-MPC | 9 s |") && t.contains("AISTATS 2018"), "{t}");
        assert!(
            t.contains("within 0.1 m of the target") && t.contains("last 1 s") && t.contains("our criterion"),
            "{t}"
        );
        // the pendulum table and its provenance leave the cart-pole out
        let mpc = mpc_table(&report);
        assert!(
            mpc.contains("| lwr |") && !mpc.contains("cartpole") && !mpc.contains("| mpc/lwr |"),
            "{mpc}"
        );
        let block = mpc_readme_block(&report);
        assert!(block.starts_with("1 runs, all made at commit test; "), "{block}");
        assert!(
            block.contains("written from saved runs (no wall time measured)"),
            "{block}"
        );
        assert!(block.ends_with(&t));
        // the report's header names each task's provenance apart
        let md = markdown(&report);
        assert!(
            md.contains("- pendulum: 1 runs") && md.contains("- cartpole: 4 runs"),
            "{md}"
        );
        assert!(md.contains("## PILCO's cart-pole from scratch"), "{md}");
        // no cart-pole runs, no table
        let pendulum_only = ExperimentsReport {
            runs: report.runs[4..].to_vec(),
            ..report.clone()
        };
        assert!(cartpole_table(&pendulum_only).is_empty());
    }

    /// A task's wall time survives a report rewritten from saved runs while
    /// its runs stay the same; the task run anew gets its own; a legacy
    /// report (no task times) that ran all its runs times each task.
    #[test]
    fn task_times_are_kept_while_their_runs_stay_the_same() {
        use crate::experiments::{CARTPOLE_VARIANT, TaskTime};
        let pendulum = vec![
            summary("mpc", "mpc/lwr", 1, Some(2), 1.0),
            summary("mpc", "open-loop/lwr", 1, None, 1.0),
        ];
        let legacy = ExperimentsReport {
            settings: ExperimentSettings::full(),
            experiments: vec![Experiment::Mpc],
            runs: pendulum.clone(),
            variants: vec![],
            claims: vec![],
            seconds: 2975.0,
            threads: 2,
            ran: Some(2),
            task_times: vec![],
            missing: vec![],
        };
        let mut runs = pendulum.clone();
        runs.push(summary("mpc", CARTPOLE_VARIANT, 1, Some(3), 0.0));
        let cart_time = TaskTime {
            task: "cartpole".into(),
            ran: Some(1),
            invocation_ran: Some(1),
            seconds: 30.0,
            threads: 2,
        };
        let mut now = ExperimentsReport {
            runs: runs.clone(),
            seconds: 30.0,
            ran: Some(1),
            task_times: vec![cart_time.clone()],
            ..legacy.clone()
        };
        assert_eq!(now.keep_task_times_of(&legacy), vec!["pendulum".to_string()]);
        let p = task_provenance(&now, "pendulum");
        assert_eq!(
            p,
            "2 runs, all made at commit test; 0 s of run time summed over the runs; all run by one invocation in 2975 s of wall time on 2 threads."
        );
        assert!(task_provenance(&now, "cartpole").contains("all run by one invocation in 30 s"));
        // rewritten from the saved runs: both kept
        let mut rewritten = ExperimentsReport {
            ran: Some(0),
            seconds: 0.1,
            task_times: vec![],
            ..now.clone()
        };
        assert_eq!(rewritten.keep_task_times_of(&now).len(), 2);
        assert_eq!(rewritten.task_times, now.task_times);
        // a pendulum run made by other code: its old time is not kept
        let mut changed = rewritten.clone();
        changed.task_times.clear();
        changed.runs[0].code_version = "commit other".into();
        assert_eq!(changed.keep_task_times_of(&now), vec!["cartpole".to_string()]);
        assert!(task_provenance(&changed, "pendulum").contains("no wall time measured"));
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
            task_times: vec![],
            missing: vec![],
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
