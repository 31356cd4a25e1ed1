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
use swingup::learn::run;
use swingup::output::console::stdout_failed;
use swingup::output::run_report;
use swingup::record::TrialRecord;
use swingup::{note, say};

/// The subcommands' own modules.
mod cli {
    pub(crate) mod experiments;
}

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
    Experiments(cli::experiments::ExperimentsArgs),
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
        Command::Experiments(args) => cli::experiments::experiments(&args),
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
