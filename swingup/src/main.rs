//! `swingup`: the pendulum swing-up learned from a demonstration
//! (Atkeson, "Nonparametric Model-Based Reinforcement Learning", section 4).
//!
//! `swingup` with no arguments runs `swingup learn` with the defaults.
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::{Parser, Subcommand};
use swingup::config::{BasisKind, Config, Controller, LwrPrior, ModelKind, Solver};
use swingup::experiments::{Experiment, ExperimentSettings};
use swingup::learn::run;
use swingup::output::console::stdout_failed;
use swingup::output::grid::{GridEvent, GridMode, GridOptions};
use swingup::output::run_report;
use swingup::record::TrialRecord;
use swingup::{note, say};

/// Where `swingup config` writes.
#[derive(Debug, clap::Args)]
struct ConfigArgs {
    /// Write the configuration to this file (replaced whole; a link, device
    /// or directory there is refused) instead of standard output.
    #[arg(long, value_name = "FILE.toml")]
    out: Option<PathBuf>,
}

/// Learn a pendulum swing-up from a human demonstration, as in Atkeson's
/// "Nonparametric Model-Based Reinforcement Learning" (simulated).
#[derive(Debug, Parser)]
#[command(version = store::program_version(env!("CARGO_PKG_VERSION")), about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Imitate the demonstration, then learn a model of the robot (locally
    /// weighted regression, by default on top of a learned parametric
    /// model) and plan with the paper's Eq. 3 until the robot balances the
    /// pendulum (or the trial cap). Writes a report, CSV logs and plots.
    Learn(LearnArgs),
    /// Print the default configuration as TOML (every parameter; edit it
    /// and pass it back with `learn --config FILE`).
    Config(ConfigArgs),
    /// Run the experiments behind the paper's claims (C1-C8): grids of
    /// learning runs over seeds, in parallel; writes experiments.json and
    /// experiments.md (the claims table first).
    Experiments(ExperimentsArgs),
    /// Fit a locally weighted regression model to a CSV file: tune its
    /// metric by leave-one-out cross-validation, report the tuned scale of
    /// each input and, with a test file, the test error and predictions.
    Fit(swingup::fit_cmd::FitArgs),
    /// How accurate must a model be for an open-loop swing-up? Plans with
    /// the exact dynamics of the robot with one parameter off by a factor,
    /// runs each plan on the real robot over seeds; measures the pure LWR
    /// against that budget, and how it plans once it has a successful
    /// swing-up's data; writes sensitivity.json and sensitivity.md.
    Sensitivity(SensitivityArgs),
    /// The balancing controller's region of attraction: calibrates the
    /// level of `catch = "basin"` by simulation on the robot, maps the basin
    /// around upright against the box rule; writes basin.json and basin.md.
    Basin(BasinArgs),
}

/// What `swingup experiments` does instead of running a grid.
#[derive(Debug, Clone, Subcommand)]
enum ExperimentsAction {
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

#[derive(Debug, Clone, clap::Args)]
struct BasinArgs {
    /// A configuration file (the robot, its noise, the balancing phase and
    /// the box rule's limits are read from it).
    #[arg(long)]
    config: Option<PathBuf>,
    /// States simulated per calibration round.
    #[arg(long, default_value_t = 2000)]
    samples: usize,
    /// Output directory.
    #[arg(long, default_value = "runs/basin")]
    out: PathBuf,
}

#[derive(Debug, Clone, clap::Args)]
struct SensitivityArgs {
    /// Seeds of sensor noise per plan.
    #[arg(long, default_value_t = 10)]
    seeds: u64,
    /// Learning runs (seeds) of the pure LWR whose models are measured.
    #[arg(long, default_value_t = 8)]
    model_seeds: u64,
    /// Trials of each of those runs (models after 1, 2, ... trials).
    #[arg(long, default_value_t = 3)]
    model_trials: usize,
    /// Runs (seeds) of the pure LWR given a successful swing-up's data.
    #[arg(long, default_value_t = 20)]
    success_seeds: u64,
    /// LWR trials of each of those runs after the successful one.
    #[arg(long, default_value_t = 3)]
    success_trials: usize,
    /// Output directory.
    #[arg(long, default_value = "runs/sensitivity")]
    out: PathBuf,
    /// Also write the short summary into this Markdown file (the README),
    /// between its `<!-- sensitivity:start -->` and
    /// `<!-- sensitivity:end -->` lines.
    #[arg(long)]
    update_readme: Option<PathBuf>,
}

#[derive(Debug, Clone, Default, clap::Args)]
struct LearnArgs {
    /// Seed of the robot's sensor noise (runs are deterministic in it).
    #[arg(long)]
    seed: Option<u64>,
    /// Consistency weight lambda of Eq. 3 (the model mismatch is measured
    /// in rate units, i.e. divided by the sample period).
    #[arg(long)]
    lambda: Option<f64>,
    /// Number of trials before giving up (the first one imitates).
    #[arg(long)]
    max_trials: Option<usize>,
    /// The planner: Eq. 3 by Gauss-Newton, by Powell's method (the
    /// paper's) or by derivative-free least squares, or differential
    /// dynamic programming through the model.
    #[arg(long, value_enum)]
    planner: Option<Solver>,
    /// The learned model: locally weighted regression (the paper's), least
    /// squares on the pendulum's physical features, LWR correcting that
    /// least-squares fit (the default), or the true dynamics.
    #[arg(long, value_enum)]
    model: Option<ModelKind>,
    /// The prior the pure LWR (`--model lwr`) corrects: a global linear
    /// fit (the default), the data's mean, or a control-affine fit on the
    /// angle's sine and cosine (`swingup::models::ControlAffineRegression`);
    /// refused with another model, whose prior is fixed.
    #[arg(long, value_enum)]
    prior: Option<LwrPrior>,
    /// The trajectory basis of the Eq. 3 planners: cubic B-splines or
    /// Daubechies-4 wavelets.
    #[arg(long, value_enum)]
    basis: Option<BasisKind>,
    /// How plans are executed: open loop (the paper's) or model-predictive
    /// control, replanning Eq. 3 from the measured state (settings under
    /// `[mpc]` in the configuration).
    #[arg(long, value_enum)]
    controller: Option<Controller>,
    /// The task: the pendulum swing-up from a demonstration (the paper's),
    /// or PILCO's cart-pole swing-up learned from scratch with the LWR and
    /// model-predictive control (`swingup::cartpole`; it takes `--seed`,
    /// `--max-trials`, `--out`, `--resume`, `--force` and
    /// `--cartpole-settings`, saves each trial as `trial_NN.json` as it
    /// ends, and writes `cartpole.json` at the end).
    #[arg(long, value_enum, default_value = "pendulum")]
    task: Task,
    /// TOML configuration file (see `swingup config`); command-line options override it.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Run directory for the report, logs and plots (default: a fresh
    /// `runs/swingup-NNN`, so no earlier run is overwritten).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Continue the run in `--out` (default: the latest `runs/swingup-NNN`):
    /// finished trials are read back from their `trial_NN.json` files and
    /// learning goes on after them.
    #[arg(long)]
    resume: bool,
    /// Start a fresh run in an `--out` that holds another run: that run's
    /// files (config.toml, report.*, trial_*, the plots) are deleted first;
    /// nothing else in the directory is touched.
    #[arg(long, conflicts_with = "resume")]
    force: bool,
    /// With `--task cartpole`: a JSON object of changes to the cart-pole's
    /// default settings (`{"episode": 1.5, "model": {"tune_evals": 10}}`;
    /// see `swingup::cartpole::CartPoleSettings`); a resumed run keeps the
    /// settings it was made with.
    #[arg(long, value_name = "FILE.json", conflicts_with = "resume")]
    cartpole_settings: Option<PathBuf>,
}

#[derive(Debug, Clone, clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
struct ExperimentsArgs {
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

/// Errors print as the program's message and its causes, one line each,
/// without a backtrace (even with `RUST_BACKTRACE` set), and exit with 1.
fn main() -> std::process::ExitCode {
    // the storage layer's fault injection, for this program's tests
    // (`NPRL_STORE_FAULT=op=write,nth=2,path=runs.jsonl`; see `store::fault`)
    let _faults = match store::fault::install_from_env("NPRL_STORE_FAULT") {
        Ok(guard) => guard,
        Err(e) => {
            note!("error: NPRL_STORE_FAULT: {e}");
            return std::process::ExitCode::FAILURE;
        }
    };
    match run_command() {
        Ok(()) if stdout_failed() => {
            note!(
                "error: standard output was closed or full, so some of the output above is missing (the files were saved)"
            );
            std::process::ExitCode::FAILURE
        }
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            note!("error: {e}");
            for cause in e.chain().skip(1) {
                note!("  caused by: {cause}");
            }
            std::process::ExitCode::FAILURE
        }
    }
}

fn run_command() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command.unwrap_or(Command::Learn(LearnArgs::default())) {
        Command::Config(args) => {
            let text = toml::to_string(&Config::default())?;
            match args.out {
                // whole or not at all; never through a link or over a device
                Some(path) => {
                    store::replace_file(&path, text.as_bytes())?;
                    note!("wrote {}", path.display());
                }
                None => say!("{}", text.trim_end()),
            }
            Ok(())
        }
        Command::Learn(args) => learn(&args),
        Command::Fit(args) => Ok(swingup::fit_cmd::fit_command(&args)?),
        Command::Experiments(args) => experiments(&args),
        Command::Sensitivity(args) => sensitivity(&args),
        Command::Basin(args) => basin(&args),
    }
}

fn basin(args: &BasinArgs) -> anyhow::Result<()> {
    use swingup::experiments::basin::basin_report;
    use swingup::plant::basin::BasinSettings;
    let cfg = args.config.as_deref().map(read_config).transpose()?.unwrap_or_default();
    cfg.validate()?;
    swingup::output::check_out_dir(&args.out)?;
    let settings = BasinSettings {
        samples: args.samples,
        ..BasinSettings::default()
    };
    say!("calibrating the catch over {} states per round ...", args.samples);
    let report = basin_report(&cfg, &settings)?;
    let md = report.markdown();
    write_atomic(&args.out.join("basin.json"), &serde_json::to_string_pretty(&report)?)?;
    write_atomic(&args.out.join("basin.md"), &md)?;
    say!("{}", md.trim_end());
    say!("written: {}", args.out.join("basin.md").display());
    Ok(())
}

fn sensitivity(args: &SensitivityArgs) -> anyhow::Result<()> {
    use swingup::experiments::sensitivity::{
        SensitivityReport, code_version, default_perturbations, learned_model_error, open_loop_tolerance,
        with_successful_data,
    };
    // every size and path is checked before the work, which takes minutes
    let most = swingup::experiments::MAX_SEEDS;
    for (name, n) in [
        ("--seeds", args.seeds),
        ("--model-seeds", args.model_seeds),
        ("--success-seeds", args.success_seeds),
    ] {
        anyhow::ensure!((1..=most).contains(&n), "{name} must be 1 to {most}, got {n}");
    }
    let trials = swingup::config::limits::MAX_TRIALS;
    for (name, n) in [
        ("--model-trials", args.model_trials),
        ("--success-trials", args.success_trials),
    ] {
        anyhow::ensure!((1..=trials).contains(&n), "{name} must be 1 to {trials}, got {n}");
    }
    swingup::output::check_out_dir(&args.out)?;
    if let Some(readme) = &args.update_readme {
        run_report::with_markers(readme, "<!-- sensitivity:start -->", "<!-- sensitivity:end -->", "")?;
    }
    let perturbations = default_perturbations();
    say!(
        "planning with {} perturbed exact models, each run on the robot over {} seeds",
        perturbations.len(),
        args.seeds
    );
    // the commit the binary was built from (see `code_version`)
    let version = code_version();
    let cfg = Config::default();
    let rows = open_loop_tolerance(&cfg, &perturbations, args.seeds)?;
    say!(
        "learning with the pure LWR over {} seeds, {} trials each, to measure its error along the exact plan",
        args.model_seeds,
        args.model_trials
    );
    let model_error = learned_model_error(&cfg, args.model_seeds, args.model_trials)?;
    say!(
        "learning with the pure LWR after a successful swing-up over {} seeds, up to {} trials each",
        args.success_seeds,
        args.success_trials
    );
    let successful_data = with_successful_data(&cfg, args.success_seeds, args.success_trials)?;
    let report = SensitivityReport {
        version,
        tolerance: rows,
        learned_model_error: model_error,
        successful_data,
    };
    let md = report.markdown();
    write_atomic(
        &args.out.join("sensitivity.json"),
        &serde_json::to_string_pretty(&report)?,
    )?;
    write_atomic(&args.out.join("sensitivity.md"), &md)?;
    say!("{}", md.trim_end());
    say!("written: {}", args.out.join("sensitivity.md").display());
    if let Some(readme) = &args.update_readme {
        run_report::update_between(
            readme,
            "<!-- sensitivity:start -->",
            "<!-- sensitivity:end -->",
            &report.readme_summary(),
        )?;
        say!("updated the sensitivity summary in {}", readme.display());
    }
    Ok(())
}

/// The configuration file of `--config`, if given.
fn config_file(args: &LearnArgs) -> anyhow::Result<Option<Config>> {
    args.config.as_deref().map(read_config).transpose()
}

/// A configuration file, parsed (missing keys keep their defaults).
fn read_config(path: &Path) -> anyhow::Result<Config> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    // the parser's message quotes the line: cut when long (Error::parse)
    Ok(toml::from_str(&text).map_err(|e| swingup::Error::parse(path, None, e))?)
}

/// The command-line options over `cfg` (a `--config` file replaces it first).
fn apply_options(args: &LearnArgs, file: Option<&Config>, cfg: &mut Config) {
    if let Some(file) = file {
        *cfg = file.clone();
    }
    if let Some(seed) = args.seed {
        cfg.seed = seed;
    }
    if let Some(lambda) = args.lambda {
        cfg.planner.lambda = lambda;
    }
    if let Some(n) = args.max_trials {
        cfg.max_trials = n;
    }
    if let Some(solver) = args.planner {
        cfg.planner.solver = solver;
    }
    if let Some(kind) = args.model {
        cfg.model.kind = kind;
    }
    if let Some(prior) = args.prior {
        cfg.model.prior = prior;
    }
    if let Some(basis) = args.basis {
        cfg.planner.basis = basis;
    }
    if let Some(controller) = args.controller {
        cfg.controller = controller;
    }
}
/// Where `learn` numbers its run directories when no `--out` is given.
const RUNS_ROOT: &str = "runs";

/// Which task `learn` runs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, clap::ValueEnum)]
enum Task {
    /// The pendulum swing-up learned from a demonstration (the paper's).
    #[default]
    Pendulum,
    /// PILCO's cart-pole swing-up, from scratch, with MPC.
    Cartpole,
}

/// `learn --task cartpole`: one run of `swingup::cartpole`, each trial
/// saved as `trial_NN.json` as it ends and then shown, the whole run
/// written to `cartpole.json` at the end; `--resume` continues an
/// interrupted run from its saved trials (replayed, so that it ends as the
/// uninterrupted run would have).
fn learn_cartpole(args: &LearnArgs) -> anyhow::Result<()> {
    use swingup::output::rundir;
    anyhow::ensure!(
        args.controller.is_none_or(|c| c == Controller::Mpc),
        "the cart-pole is learned from scratch with --controller mpc only (there is no demonstration to run open loop)"
    );
    anyhow::ensure!(
        args.config.is_none()
            && args.model.is_none()
            && args.prior.is_none()
            && args.planner.is_none()
            && args.basis.is_none()
            && args.lambda.is_none(),
        "--task cartpole takes --seed, --max-trials, --out, --resume, --force and --cartpole-settings only (its settings are PILCO's, see swingup::cartpole)"
    );
    let mut settings = match &args.cartpole_settings {
        Some(path) => swingup::cartpole::CartPoleSettings::from_changes_file(path)?,
        None => swingup::cartpole::CartPoleSettings::default(),
    };
    if let Some(n) = args.max_trials {
        settings.max_trials = n;
    }
    // refused before any directory is touched
    settings.validate()?;
    let out = &match &args.out {
        Some(out) => out.clone(),
        None => rundir::numbered_run_dir(Path::new(RUNS_ROOT), args.resume)?,
    };
    let _lock = rundir::lock_dir(out, rundir::LOCK_FILE)?;
    let file = out.join("cartpole.json");
    let (rundir::CartPoleRunSettings { settings, seed }, previous) = if args.resume {
        rundir::cartpole_resume(out, args.seed, args.max_trials)?
    } else {
        let run = rundir::CartPoleRunSettings {
            settings,
            seed: args.seed.unwrap_or(1),
        };
        // a directory holding a run (of either task) is refused unless
        // --force, which deletes that run's files only; the run records its task
        rundir::prepare_fresh(out, args.force)?;
        rundir::create_manifest(out, "cartpole", &run)?;
        (run, Vec::new())
    };
    say!(
        "cartpole (PILCO's): one random trial, then MPC with the LWR; up to {} MPC trials of {} s; seed {seed}; writing to {}",
        settings.max_trials,
        settings.episode,
        out.display()
    );
    if !previous.is_empty() {
        say!("resuming {}: {} saved trial(s) replayed", out.display(), previous.len());
    }
    let start = std::time::Instant::now();
    let record = swingup::cartpole::run_resumable(&settings, seed, previous, &mut |t| {
        // saved before it is shown: a closed stdout never loses a trial
        run_report::write_cartpole_trial(out, t)?;
        say!("{}", run_report::cartpole_trial_line(t));
        Ok(())
    })?;
    write_atomic(&file, &serde_json::to_string_pretty(&record)?)?;
    match (record.success_trial, record.seconds_to_success) {
        (Some(t), Some(s)) => say!("**Result:** success at trial {t} after {s:.1} s of system data."),
        _ => say!("**Result:** no success within {} trials.", record.trials.len()),
    }
    say!("wrote {} ({:.1} s)", file.display(), start.elapsed().as_secs_f64());
    Ok(())
}

fn learn(args: &LearnArgs) -> anyhow::Result<()> {
    if args.task == Task::Cartpole {
        return learn_cartpole(args);
    }
    anyhow::ensure!(
        args.cartpole_settings.is_none(),
        "--cartpole-settings is for --task cartpole (the pendulum's settings come from --config)"
    );
    let file = config_file(args)?;
    // a fresh run's settings are checked before any directory is touched
    let fresh = if args.resume {
        None
    } else {
        let mut cfg = Config::default();
        apply_options(args, file.as_ref(), &mut cfg);
        cfg.validate()?;
        Some(cfg)
    };
    let out = &match &args.out {
        Some(out) => out.clone(),
        None => swingup::output::rundir::numbered_run_dir(Path::new(RUNS_ROOT), args.resume)?,
    };
    // one program at a time in a run's directory
    let _lock = swingup::output::rundir::lock_dir(out, swingup::output::rundir::LOCK_FILE)?;
    // a resumed run continues with the settings that made it; a fresh one
    // never writes over another run's files
    let cfg = if let Some(cfg) = fresh {
        swingup::output::rundir::prepare_fresh(out, args.force)?;
        // written once: the task and settings that made the run, and the
        // configuration, never rewritten by a resume
        swingup::output::rundir::create_manifest(out, "pendulum", &cfg)?;
        write_atomic(&out.join("config.toml"), &toml::to_string(&cfg)?)?;
        cfg
    } else {
        swingup::output::rundir::resume_config(out, |c| apply_options(args, file.as_ref(), c))?
    };
    let previous = if args.resume {
        let trials = run_report::read_trials(out)?;
        // a cap below the trials made would report them under a cap they broke
        anyhow::ensure!(
            cfg.max_trials >= trials.len(),
            "{} holds {} finished trials; --max-trials {} would report them under a smaller cap; resume with \
             --max-trials {} or more (or without it)",
            out.display(),
            trials.len(),
            cfg.max_trials,
            trials.len()
        );
        say!(
            "resuming {}: {} finished trial(s) read back",
            out.display(),
            trials.len()
        );
        trials
    } else {
        Vec::new()
    };
    say!(
        "swingup: robot l = {} m, b = {} /s, hand lag {} s; human l = {} m; model {}, planner {}, basis {}, lambda = {:e}; up to {} trials; seed {}",
        cfg.robot.length,
        cfg.robot.damping,
        cfg.robot.lag,
        cfg.human.length,
        value_name(cfg.model.kind),
        value_name(cfg.planner.solver),
        value_name(cfg.planner.basis),
        cfg.planner.lambda,
        cfg.max_trials,
        cfg.seed
    );
    say!("writing to {}", out.display());
    let loo_pairs = cfg.workload().loo_pairs;
    if loo_pairs > swingup::config::limits::LOO_PAIRS {
        note!(
            "warning: the model's leave-one-out passes may visit up to {loo_pairs:.1e} point pairs over this run \
             (hours at 1e7 to 1e8 a second); [model] tune_points = 2000 makes each tuning evaluation cheaper, \
             tune_evals or max_trials make fewer"
        );
    }
    let start = std::time::Instant::now();
    let record = run(&cfg, previous, &mut SaveAndShow { out })?;
    run_report::write_run(out, &record).with_context(|| format!("writing the report into {}", out.display()))?;
    say!("{}", run_report::result_line(&record));
    say!(
        "report: {}, plots: {}, {} (and .png) ({:.1} s)",
        out.join("report.md").display(),
        out.join("figure3.svg").display(),
        out.join("learning.svg").display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// A learning run's progress: each phase and trial shown as it happens,
/// each finished trial saved at once, before it is shown (so an interrupted run loses nothing,
/// and a run that cannot save stops at once).
struct SaveAndShow<'a> {
    out: &'a Path,
}

impl swingup::learn::Progress for SaveAndShow<'_> {
    fn trial(&mut self, trial: &TrialRecord) -> swingup::Result<()> {
        // saved before it is shown: a closed stdout never loses a trial
        run_report::write_trial(self.out, trial)?;
        print_trial(trial);
        Ok(())
    }

    fn phase(&mut self, index: usize, phase: &str) {
        say!("trial {index:>2}: {phase} ...");
    }
}

fn experiments(args: &ExperimentsArgs) -> anyhow::Result<()> {
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

fn write_atomic(path: &Path, text: &str) -> anyhow::Result<()> {
    Ok(run_report::write_atomic(path, text)?)
}

/// The command-line spelling of an option's value.
fn value_name(v: impl clap::ValueEnum) -> String {
    v.to_possible_value()
        .map_or_else(String::new, |p| p.get_name().to_string())
}

fn print_trial(t: &TrialRecord) {
    say!("{}", run_report::trial_line(t));
}
