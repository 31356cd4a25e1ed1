//! `swingup experiments`: the claims grid (whole, a shard of it, or a
//! subset of its variants), and `swingup experiments merge DIR`.

use std::path::{Path, PathBuf};

use clap::Subcommand;
use swingup::config::ModelKind;
use swingup::experiments::{Experiment, ExperimentSettings};
use swingup::output::grid::{GridEvent, GridMode, GridOptions};
use swingup::output::run_report;
use swingup::{note, say};

#[derive(Debug, Clone, clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub(crate) struct ExperimentsArgs {
    /// Merge the shards of a grid (`merge DIR`) instead of running one.
    #[command(subcommand)]
    action: Option<ExperimentsAction>,
    /// Experiments to run (all when none is given).
    #[arg(value_enum)]
    which: Vec<Experiment>,
    /// The reduced grid (2 seeds, 4 trials, 3 lambdas): a quick check.
    #[arg(long)]
    quick: bool,
    /// Seeds per variant (overrides the grid's, Powell's included; caps the wavelet variant's seeds).
    #[arg(long)]
    seeds: Option<u64>,
    /// Seeds of the paper-basis variants (Powell and Gauss-Newton on 10
    /// state and 8 control coefficients), 0 by default.
    #[arg(long)]
    paper_basis_seeds: Option<u64>,
    /// Seeds of the derivative-free least-squares variant (overrides the
    /// grid's; 0 matches a grid saved before the variant existed).
    #[arg(long)]
    derivative_free_seeds: Option<u64>,
    /// Trial cap per pendulum run (overrides the grid's; the cart-pole
    /// keeps PILCO's 15 trials after the random one).
    #[arg(long)]
    max_trials: Option<usize>,
    /// The model of the learning and lambda experiments (the paper's: lwr).
    #[arg(long, value_enum)]
    model: Option<ModelKind>,
    /// Output directory.
    #[arg(long, default_value = "runs/experiments")]
    out: PathBuf,
    /// Keep the runs already saved in `--out` (runs.jsonl, one line per
    /// finished run) and run only the missing ones.
    #[arg(long)]
    resume: bool,
    /// With --resume: run nothing, write the report of the saved runs alone
    /// (of every part `--out` declares: `settings.json` with `runs.jsonl`,
    /// each shard's `settings-K-of-N.json` with `runs-K-of-N.jsonl`; merge
    /// shards run elsewhere by copying both files of each into one
    /// directory). Shards with other settings are refused.
    #[arg(long, requires = "resume")]
    report_only: bool,
    /// Run only part K of N of the grid (e.g. `--shard 2/4`), for N machines
    /// or a batch scheduler's job array. Without it, inside a Slurm job
    /// array (`sbatch --array=0-3`), the part is the task's:
    /// SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN + 1 of SLURM_ARRAY_TASK_COUNT.
    /// A part writes only its own files, `settings-K-of-N.json` and
    /// `runs-K-of-N.jsonl` (use --resume so a resubmitted task continues);
    /// `swingup experiments merge OUT` writes the reports once every part is
    /// done. Threads per task: RAYON_NUM_THREADS (the job's
    /// SLURM_CPUS_PER_TASK in scripts/slurm/experiments.sbatch).
    #[arg(long)]
    shard: Option<swingup::experiments::Shard>,
    /// Run only the variants whose name starts with this (repeatable; e.g.
    /// `experiments mpc --variant cartpole` runs the cart-pole part of
    /// `mpc` alone). With --resume the report still covers every saved run
    /// of the experiments, so one part can be added to a grid without
    /// running the others again.
    #[arg(long = "variant", value_name = "PREFIX")]
    variants: Vec<String>,
    /// Start the grid over in an `--out` whose runs file holds finished
    /// runs (they are lost); without it such a directory is refused.
    #[arg(long, conflicts_with = "resume")]
    force: bool,
    /// Also write the claims table into this Markdown file (the README),
    /// between its `<!-- claims:start -->` and `<!-- claims:end -->` lines
    /// (the `mpc` experiment's tables, pendulum and cart-pole, between
    /// `<!-- mpc:start -->` and `<!-- mpc:end -->`).
    #[arg(long)]
    update_readme: Option<PathBuf>,
}

/// What `swingup experiments` does instead of running a grid.
#[derive(Debug, Clone, Subcommand)]
pub(crate) enum ExperimentsAction {
    /// Merge a grid's shards (each `settings-K-of-N.json` with its
    /// `runs-K-of-N.jsonl`, gathered in DIR) and write the grid's reports
    /// (experiments.json, experiments.md, the figures). The settings and
    /// experiments are read from the shards. Refused, naming them, when
    /// shards are missing or unfinished, of other settings or another
    /// build, or hold two different records of one run.
    Merge {
        /// The directory holding every shard's files (the grid's --out).
        dir: PathBuf,
    },
}

pub(crate) fn experiments(args: &ExperimentsArgs) -> anyhow::Result<()> {
    if let Some(ExperimentsAction::Merge { dir }) = &args.action {
        return experiments_merge(dir);
    }
    let mut settings = if args.quick {
        ExperimentSettings::quick()
    } else {
        ExperimentSettings::full()
    };
    if let Some(n) = args.seeds {
        anyhow::ensure!(n >= 1, "--seeds must be at least 1");
        settings.seeds = n;
        settings.learning_seeds = n;
        settings.wavelet_seeds = settings.wavelet_seeds.min(n);
        // Powell over every seed too (term by term, a run takes about a
        // minute on one core): issue 33 reports it on seeds 1-20 and 21-40
        settings.powell_seeds = n;
        settings.derivative_free_seeds = n;
        settings.mpc_seeds = n;
    }
    if let Some(n) = args.paper_basis_seeds {
        settings.paper_basis_seeds = n;
    }
    if let Some(n) = args.derivative_free_seeds {
        settings.derivative_free_seeds = n;
    }
    if let Some(n) = args.max_trials {
        anyhow::ensure!(n >= 1, "--max-trials must be at least 1");
        settings.max_trials = n;
    }
    if let Some(m) = args.model {
        settings.model = m;
    }
    let which = if args.which.is_empty() {
        vec![
            Experiment::Learning,
            Experiment::Lambda,
            Experiment::Planners,
            Experiment::Beyond,
        ]
    } else {
        args.which.clone()
    };
    if !args.variants.is_empty() {
        let names = swingup::experiments::variant_names(&which, &settings);
        for v in &args.variants {
            anyhow::ensure!(
                names.iter().any(|n| n.starts_with(v.as_str())),
                "--variant {v:?} names no variant of {which:?}; they are: {}",
                names.join(", ")
            );
        }
    }
    // the README's markers are checked before the grid, which takes hours
    if let Some(readme) = &args.update_readme {
        if which.iter().any(|e| *e != Experiment::Mpc) {
            run_report::with_markers(readme, "<!-- claims:start -->", "<!-- claims:end -->", "")?;
        }
        if which.contains(&Experiment::Mpc) {
            run_report::with_markers(readme, "<!-- mpc:start -->", "<!-- mpc:end -->", "")?;
        }
    }
    // --shard, or the Slurm array task's part
    let shard = swingup::experiments::Shard::resolve(args.shard)?;
    if let (Some(s), None) = (shard, args.shard) {
        s.check_count_in(&args.out, "settings", ".json")?;
        say!("shard {s} of the grid, from the Slurm job array's SLURM_ARRAY_TASK_* variables");
    }
    anyhow::ensure!(
        shard.is_none() || args.update_readme.is_none() || args.report_only,
        "--update-readme takes a whole grid's claims: run it with `experiments merge` done,          as `--resume --report-only --update-readme FILE`, not in a shard"
    );
    let out = &args.out;
    let mode = match (args.resume, args.report_only) {
        (true, true) => GridMode::ReportOnly,
        (true, false) => GridMode::Resume,
        _ => GridMode::Fresh { force: args.force },
    };
    say!(
        "experiments {:?}{}: {}; on {} threads; writing to {}",
        which,
        if args.variants.is_empty() {
            String::new()
        } else {
            format!(" (variants {})", args.variants.join(", "))
        },
        settings.size_line(&which),
        rayon::current_num_threads(),
        out.display()
    );
    // a progress bar with the remaining time on a terminal (stderr); one
    // line per finished run on stdout either way, once it is saved
    let bar = indicatif::ProgressBar::new(0);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {elapsed} elapsed, ETA {eta}")
    {
        bar.set_style(style);
    }
    let options = GridOptions {
        which: which.clone(),
        settings,
        out: out.clone(),
        mode,
        shard,
        variants: args.variants.clone(),
    };
    let report = swingup::output::grid::run_grid(&options, &|event| match event {
        GridEvent::Warning(w) => note!("warning: {w}"),
        GridEvent::Resumed(n) => {
            bar.set_position(n as u64);
            bar.reset_eta();
            say!("resuming: {n} finished run(s) read back from {}", out.display());
        }
        GridEvent::Saved(done, total, r) => {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
            bar.suspend(|| {
                say!(
                    "[{done:>4}/{total}] {} {} seed {}: {} ({:.1} s)",
                    r.experiment,
                    r.variant,
                    r.seed,
                    r.success_trial
                        .map_or("no success".into(), |t| format!("success at trial {t}")),
                    r.seconds
                );
            });
        }
        GridEvent::KeptWallTime(None, s) => say!("kept the wall time measured when these runs were made ({s:.0} s)"),
        GridEvent::KeptWallTime(Some(task), _) => say!("kept the wall time measured when the {task} runs were made"),
    });
    bar.finish_and_clear();
    let report = report?;
    if let Some(s) = shard.filter(|_| mode != GridMode::ReportOnly) {
        say!(
            "shard {s}: its {} run(s) are saved in {}; once every shard is done, `swingup experiments merge {}` \
             writes the grid's reports",
            report.runs.len(),
            out.join(swingup::output::grid::runs_file_name(Some(s))).display(),
            out.display()
        );
        return Ok(());
    }
    let table = swingup::output::grid_report::claims_table(&report.claims);
    // the paper's claims come from its experiments; `mpc` has its own tables
    let paper = which.iter().any(|e| *e != Experiment::Mpc);
    if paper {
        say!("\n{table}");
    } else {
        say!("\n{}", swingup::output::grid_report::mpc_readme_block(&report));
    }
    if let Some(readme) = &args.update_readme {
        let provenance = swingup::output::grid_report::provenance(&report);
        if paper {
            let block = format!("{provenance}\n\n{table}");
            run_report::update_between(readme, "<!-- claims:start -->", "<!-- claims:end -->", &block)?;
            say!("updated the claims table in {}", readme.display());
        }
        if which.contains(&Experiment::Mpc) {
            let block = swingup::output::grid_report::mpc_readme_block(&report);
            run_report::update_between(readme, "<!-- mpc:start -->", "<!-- mpc:end -->", &block)?;
            say!("updated the MPC tables in {}", readme.display());
        }
    }
    say!(
        "wrote {}, {} and the figures (.svg and .png) ({:.0} s)",
        out.join("experiments.json").display(),
        out.join("experiments.md").display(),
        report.seconds
    );
    Ok(())
}

/// `swingup experiments merge DIR`.
fn experiments_merge(dir: &Path) -> anyhow::Result<()> {
    say!("merging the shards of the grid in {}", dir.display());
    let report = swingup::output::grid::merge_grid(dir, &|event| match event {
        GridEvent::Warning(w) => note!("warning: {w}"),
        GridEvent::KeptWallTime(None, s) => say!("kept the wall time measured when these runs were made ({s:.0} s)"),
        _ => {}
    })?;
    if report.experiments.iter().any(|e| *e != Experiment::Mpc) {
        say!("\n{}", swingup::output::grid_report::claims_table(&report.claims));
    } else {
        say!("\n{}", swingup::output::grid_report::mpc_readme_block(&report));
    }
    say!(
        "merged {} runs; wrote {}, {} and the figures (.svg and .png)",
        report.runs.len(),
        dir.join("experiments.json").display(),
        dir.join("experiments.md").display()
    );
    Ok(())
}
