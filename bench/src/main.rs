//! `nprl-bench`: runs solvers on a problem set and writes tables, profiles
//! and figures (see `bench/README.md`).
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use bench::problems::{Budget, ProblemSet};
use bench::runner::{RunnerSettings, execute};
use bench::solvers::Solver;
use clap::Parser;

/// Runs solvers on a problem set; writes per-problem tables, performance
/// and data profiles (JSON, CSV, SVG, PNG), the goals and the summary.
#[derive(Debug, Parser)]
#[command(name = "nprl-bench", version = store::program_version(env!("CARGO_PKG_VERSION")))]
#[command(args_conflicts_with_subcommands = true)]
struct Cli {
    /// Merge a benchmark's shards (`merge DIR`) instead of running.
    #[command(subcommand)]
    action: Option<Action>,
    /// Problem set: mgh (the Moré-Garbow-Hillstrom problems), nist (the
    /// NIST StRD nonlinear regression problems) or trajectory (the
    /// swing-ups in Eq. 3 and DDP form and the learned-LWR plan).
    #[arg(long, default_value = "mgh")]
    set: String,
    /// Built-in solvers: `all`, `none` or a comma-separated list of
    /// gauss-newton, newton, adaptive, trust-region, trust-region-geodesic,
    /// powell, dfo-ls, argmin-nelder-mead, argmin-lbfgs, ddp-ilqr, ddp-full
    /// (each runs where it applies).
    #[arg(long, default_value = "all")]
    solvers: String,
    /// A solver in another program (any language) that speaks the JSON-lines
    /// protocol of bench/README.md, beside the built-in ones; repeatable.
    /// The command is split on whitespace, e.g.
    /// "python3 scripts/bench/client_lm.py".
    #[arg(long, value_name = "COMMAND")]
    solver_cmd: Vec<String>,
    /// Only problems whose name contains this (e.g. `penalty2`).
    #[arg(long)]
    filter: Option<String>,
    /// Evaluation budget per run, in simplex gradients (n + 1 evaluation
    /// equivalents each).
    #[arg(long, default_value_t = 2000)]
    budget: u64,
    /// Time budget per run, seconds (above 0, at most a year).
    #[arg(long, default_value_t = 10.0)]
    time_limit: f64,
    /// Times each solve is timed (the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: u32,
    /// Directory of runs, table, profiles and figures (outside records are
    /// read from OUT/outside/*.json); default `results/benchmarks` for
    /// mgh, `results/benchmarks/<set>` for the others.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Directory of benchmarks.md, benchmarks.json, benchmarks_summary.md;
    /// default OUT when --out is given, `results` otherwise.
    #[arg(long)]
    report_dir: Option<PathBuf>,
    /// More outside record files to merge.
    #[arg(long)]
    outside: Vec<PathBuf>,
    /// Do not run: reuse OUT/runs.json (to merge new outside records, or to
    /// rewrite the tables and reports of a run stopped while writing them).
    #[arg(long)]
    reuse: bool,
    /// Replace the saved runs of OUT/runs.json by this run's even when this
    /// run makes only some of them with other code or another budget
    /// (refused otherwise: a result set never mixes them). A run of the
    /// same code and budget merges without it.
    #[arg(long)]
    force: bool,
    /// Compare our runs with those of REF: a directory holding runs.json,
    /// a records file, or a git revision whose committed OUT/runs.json is
    /// read; prints per-solver instances solved, gained, lost and median
    /// evaluations, and writes OUT/compare.{md,json}.
    #[arg(long, value_name = "REF")]
    compare_to: Option<String>,
    /// Also write the summary into this README, between its
    /// `<!-- benchmarks:start -->` and `<!-- benchmarks:end -->` lines.
    #[arg(long)]
    update_readme: Option<PathBuf>,
    /// Run only part K of N of the benchmark's runs (e.g. `--shard 2/4`),
    /// for N machines or a batch scheduler's job array. Without it, inside
    /// a Slurm job array (`sbatch --array=0-3`), the part is the task's:
    /// SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN + 1 of
    /// SLURM_ARRAY_TASK_COUNT. A part writes only OUT/shard-K-of-N.json and
    /// OUT/runs-K-of-N.jsonl (each run appended as it finishes; started
    /// again, it makes only its missing runs); `nprl-bench merge OUT` writes
    /// runs.json and the reports once every part is done.
    #[arg(long, conflicts_with_all = ["reuse", "compare_to", "update_readme"])]
    shard: Option<store::Shard>,
}

/// What `nprl-bench` does instead of running a benchmark.
#[derive(Debug, clap::Subcommand)]
enum Action {
    /// Merge a benchmark's shards (each shard-K-of-N.json with its
    /// runs-K-of-N.jsonl, gathered in DIR): writes DIR/runs.json, the
    /// tables, profiles and figures, and the reports, as one run would.
    /// The settings are read from the shards. Refused, naming them, when
    /// shards are missing or unfinished, of other settings or another
    /// build, or hold two different records of one run.
    Merge {
        /// The directory holding every shard's files (the shards' --out).
        dir: PathBuf,
        /// Directory of benchmarks.md, benchmarks.json,
        /// benchmarks_summary.md; default DIR.
        #[arg(long)]
        report_dir: Option<PathBuf>,
        /// More outside record files to merge.
        #[arg(long)]
        outside: Vec<PathBuf>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            use std::io::Write as _;
            let _ = writeln!(std::io::stderr(), "nprl-bench: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The longest `--time-limit` taken: a year.
const MAX_TIME_LIMIT_S: f64 = 365.0 * 24.0 * 3600.0;

/// Prints `text` and a newline on standard output; a closed or full
/// standard output is an error (after the files are saved), never a panic.
fn say(text: &str) -> bench::Result<()> {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    writeln!(out, "{text}")
        .and_then(|()| out.flush())
        .map_err(bench::BenchError::Stdout)
}

fn run(cli: Cli) -> bench::Result<()> {
    if let Some(Action::Merge {
        dir,
        report_dir,
        outside,
    }) = cli.action
    {
        let report_dir = report_dir.unwrap_or_else(|| dir.clone());
        let (analysis, stamp) = bench::shard::merge(&dir, report_dir.clone(), outside)?;
        return say(&format!(
            "merged {} runs on {} instances made at {}; wrote {} and {}",
            stamp.runs,
            analysis.instances.len(),
            stamp.commit,
            dir.display(),
            report_dir.display()
        ));
    }
    if !(cli.time_limit > 0.0 && cli.time_limit <= MAX_TIME_LIMIT_S) {
        return Err(bench::BenchError::InvalidSetting {
            name: "time_limit",
            reason: format!(
                "must be above 0 and at most a year ({MAX_TIME_LIMIT_S} s), got {}",
                cli.time_limit
            ),
        });
    }
    let set = ProblemSet::parse(&cli.set)?;
    if cli.update_readme.is_some() && set != ProblemSet::Mgh {
        return Err(bench::BenchError::InvalidSetting {
            name: "update_readme",
            reason: "the README's summary is the mgh set's".into(),
        });
    }
    let mut solvers = if cli.solvers.trim() == "none" {
        Vec::new()
    } else {
        Solver::parse_entries(&cli.solvers)?
    };
    for command in &cli.solver_cmd {
        solvers.push(std::sync::Arc::new(bench::process::ProcessSolver::start(command)?));
    }
    if solvers.is_empty() {
        return Err(bench::BenchError::InvalidSetting {
            name: "solvers",
            reason: "`--solvers none` needs at least one --solver-cmd".into(),
        });
    }
    let settings = RunnerSettings {
        set,
        solvers,
        filter: cli.filter,
        budget: Budget {
            simplex_gradients: cli.budget,
            time: Duration::try_from_secs_f64(cli.time_limit).map_err(|e| bench::BenchError::InvalidSetting {
                name: "time_limit",
                reason: e.to_string(),
            })?,
        },
        repeats: cli.repeats,
        report_dir: cli
            .report_dir
            .or_else(|| cli.out.clone())
            .unwrap_or_else(|| PathBuf::from("results")),
        out: cli.out.unwrap_or_else(|| set.default_out()),
        outside: cli.outside,
        reuse: cli.reuse,
        force: cli.force,
    };
    // --shard, or the Slurm array task's part
    let shard = store::Shard::resolve(cli.shard).map_err(|e| bench::BenchError::InvalidSetting {
        name: "shard",
        reason: e.to_string(),
    })?;
    if let Some(shard) = shard {
        if cli.shard.is_none() {
            shard
                .check_count_in(&settings.out, "shard", ".json")
                .map_err(|e| bench::BenchError::InvalidSetting {
                    name: "shard",
                    reason: e.to_string(),
                })?;
            say(&format!(
                "shard {shard} of the benchmark, from the Slurm job array's SLURM_ARRAY_TASK_* variables"
            ))?;
        }
        let outcome = bench::shard::run_shard(&settings, shard)?;
        return say(&format!(
            "shard {shard}: {} of its {} runs made now, {} found saved, in {}; once every shard is done, \
             `nprl-bench merge {}` writes runs.json and the reports",
            outcome.ran,
            outcome.planned,
            outcome.resumed,
            outcome.runs_file.display(),
            settings.out.display()
        ));
    }
    // a README without its markers, or a reference that names no records,
    // is refused before anything runs
    if let Some(path) = &cli.update_readme {
        readme_with_summary(path, "")?;
    }
    let reference = match &cli.compare_to {
        Some(spec) => Some(bench::compare::load_reference(spec, &settings.out)?),
        None => None,
    };
    let (analysis, stamp) = execute(&settings)?;
    if let Some((records, label)) = reference {
        compare(&settings, &analysis, records, &label, &stamp.commit)?;
    }
    if let Some(path) = &cli.update_readme {
        let summary_path = settings.report_dir.join("benchmarks_summary.md");
        let summary = std::fs::read_to_string(&summary_path).map_err(|source| bench::BenchError::Io {
            path: summary_path,
            source,
        })?;
        // read again: the README may have been edited during the runs
        let updated = readme_with_summary(path, &summary)?;
        // whole or not at all, its mode kept; a symbolic link there is refused
        bench::report::write(path, &updated)?;
        say(&format!("updated the benchmark summary in {}", path.display()))?;
    }
    if settings.set == ProblemSet::Mgh {
        for goal in bench::report::goals(&analysis) {
            say(&format!("{}: {}", goal.verdict, goal.goal))?;
        }
    }
    say(&format!(
        "{} runs on {} instances at {}; wrote {} and {}",
        stamp.runs,
        analysis.instances.len(),
        stamp.commit,
        settings.out.display(),
        settings.report_dir.display()
    ))?;
    Ok(())
}

/// Judges the reference records as this run's, prints what changed per
/// solver and writes it to `OUT/compare.{md,json}`.
fn compare(
    settings: &RunnerSettings,
    now: &bench::analysis::Analysis,
    records: bench::record::RecordFile,
    label: &str,
    commit: &str,
) -> bench::Result<()> {
    let (before, _) = bench::runner::analyse(
        settings.set,
        settings.filter.as_deref(),
        &settings.solver_names(),
        records,
        &settings.out,
        &settings.outside,
    )?;
    let ours = settings.solver_names();
    let changes = bench::compare::changes(&before, now, &ours);
    let now_label = format!("{} (this run)", commit.get(..12).unwrap_or(commit));
    let mut md = bench::compare::markdown(&changes, label, &now_label);
    let missing: Vec<&str> = ours
        .iter()
        .filter(|s| !changes.iter().any(|c| &c.solver == *s))
        .map(String::as_str)
        .collect();
    if !missing.is_empty() {
        md.push_str(&format!(
            "\nNot compared (no records on one side): {}.\n",
            missing.join(", ")
        ));
    }
    bench::report::write(&settings.out.join("compare.md"), &md)?;
    let json = serde_json::json!({"before": label, "after": now_label, "changes": changes});
    bench::report::write(
        &settings.out.join("compare.json"),
        &(serde_json::to_string_pretty(&json).unwrap_or_default() + "\n"),
    )?;
    say(&md)
}

/// The README at `path` with `summary` between its benchmark markers.
fn readme_with_summary(path: &std::path::Path, summary: &str) -> bench::Result<String> {
    let text = std::fs::read_to_string(path).map_err(|source| bench::BenchError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    bench::report::with_readme_summary(&text, summary).ok_or_else(|| bench::BenchError::NoReadmeSection {
        path: path.to_path_buf(),
    })
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    use super::Cli;

    /// `--solvers`' help names every built-in solver.
    #[test]
    fn the_help_names_every_solver() {
        let command = Cli::command();
        let help = command
            .get_arguments()
            .find(|a| a.get_id() == "solvers")
            .and_then(|a| a.get_help())
            .expect("--solvers has help")
            .to_string();
        for solver in bench::solvers::Solver::ALL {
            assert!(help.contains(solver.name()), "{} missing from: {help}", solver.name());
        }
    }
}
