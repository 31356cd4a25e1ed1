//! `nprl-bench`: runs solvers on a problem set and writes tables, profiles
//! and figures (see `bench/README.md`).

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
#[command(name = "nprl-bench", version)]
struct Cli {
    /// Problem set: mgh (the Moré-Garbow-Hillstrom problems), nist (the
    /// NIST StRD nonlinear regression problems) or trajectory (the
    /// swing-ups in Eq. 3 and DDP form and the learned-LWR plan).
    #[arg(long, default_value = "mgh")]
    set: String,
    /// Solvers: `all` or a comma-separated list of gauss-newton, newton,
    /// adaptive, powell, dfo-ls, argmin-nelder-mead, argmin-lbfgs,
    /// ddp-ilqr, ddp-full (each runs where it applies).
    #[arg(long, default_value = "all")]
    solvers: String,
    /// Only problems whose name contains this (e.g. `penalty2`).
    #[arg(long)]
    filter: Option<String>,
    /// Evaluation budget per run, in simplex gradients (n + 1 evaluation
    /// equivalents each).
    #[arg(long, default_value_t = 2000)]
    budget: u64,
    /// Time budget per run, seconds.
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
    /// Directory of benchmarks.md, benchmarks.json, benchmarks_summary.md.
    #[arg(long, default_value = "results")]
    report_dir: PathBuf,
    /// More outside record files to merge.
    #[arg(long)]
    outside: Vec<PathBuf>,
    /// Do not run: reuse OUT/runs.json (to merge new outside records).
    #[arg(long)]
    reuse: bool,
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
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("nprl-bench: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> bench::Result<()> {
    if !(cli.time_limit.is_finite() && cli.time_limit > 0.0) {
        return Err(bench::BenchError::InvalidSetting {
            name: "time_limit",
            reason: format!("must be finite and > 0, got {}", cli.time_limit),
        });
    }
    let set = ProblemSet::parse(&cli.set)?;
    if cli.update_readme.is_some() && set != ProblemSet::Mgh {
        return Err(bench::BenchError::InvalidSetting {
            name: "update_readme",
            reason: "the README's summary is the mgh set's".into(),
        });
    }
    let settings = RunnerSettings {
        set,
        solvers: Solver::parse_list(&cli.solvers)?,
        filter: cli.filter,
        budget: Budget {
            simplex_gradients: cli.budget,
            time: Duration::from_secs_f64(cli.time_limit),
        },
        repeats: cli.repeats,
        out: cli.out.unwrap_or_else(|| set.default_out()),
        report_dir: cli.report_dir,
        outside: cli.outside,
        reuse: cli.reuse,
    };
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
        // whole or not at all; a symlinked README's target, its mode kept
        bench::report::write(path, &updated)?;
        println!("updated the benchmark summary in {}", path.display());
    }
    if settings.set == ProblemSet::Mgh {
        for goal in bench::report::goals(&analysis) {
            println!("{}: {}", goal.verdict, goal.goal);
        }
    }
    println!(
        "{} runs on {} instances at {}; wrote {} and {}",
        stamp.runs,
        analysis.instances.len(),
        stamp.commit,
        settings.out.display(),
        settings.report_dir.display()
    );
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
        &settings.solvers,
        records,
        &settings.out,
        &settings.outside,
    )?;
    let ours: Vec<String> = settings.solvers.iter().map(|s| s.name().to_string()).collect();
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
    println!("{md}");
    bench::report::write(&settings.out.join("compare.md"), &md)?;
    let json = serde_json::json!({"before": label, "after": now_label, "changes": changes});
    bench::report::write(
        &settings.out.join("compare.json"),
        &(serde_json::to_string_pretty(&json).unwrap_or_default() + "\n"),
    )
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
