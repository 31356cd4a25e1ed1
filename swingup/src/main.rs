//! `swingup`: the pendulum swing-up learned from a demonstration
//! (Atkeson, "Nonparametric Model-Based Reinforcement Learning", section 4).
//!
//! `swingup` with no arguments runs `swingup learn` with the defaults.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::{Parser, Subcommand};
use swingup::learn::{Config, run};
use swingup::record::{TrialKind, TrialRecord};
use swingup::report;

/// Learn a pendulum swing-up from a human demonstration, as in Atkeson's
/// "Nonparametric Model-Based Reinforcement Learning" (simulated).
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Imitate the demonstration, then learn a locally weighted regression
    /// model and plan with the paper's Eq. 3 until the robot balances the
    /// pendulum (or the trial cap). Writes a report, CSV logs and plots.
    Learn(LearnArgs),
    /// Print the default configuration as TOML (every parameter; edit it
    /// and pass it back with `learn --config FILE`).
    Config,
    /// Fit a locally weighted regression model to a CSV file: tune its
    /// metric by leave-one-out cross-validation, report the tuned scale of
    /// each input and, with a test file, the test error and predictions.
    Fit(swingup::fit_cmd::FitArgs),
}

#[derive(Debug, Clone, clap::Args)]
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
    /// TOML configuration file (see `swingup config`); command-line options override it.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Run directory for the report, logs and plots.
    #[arg(long, default_value = "runs/swingup")]
    out: PathBuf,
    /// Continue the run in `--out`: finished trials are read back from their
    /// `trial_NN.json` files and learning goes on after them.
    #[arg(long)]
    resume: bool,
}

impl Default for LearnArgs {
    fn default() -> Self {
        Self {
            seed: None,
            lambda: None,
            max_trials: None,
            config: None,
            out: PathBuf::from("runs/swingup"),
            resume: false,
        }
    }
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command.unwrap_or(Command::Learn(LearnArgs::default())) {
        Command::Config => {
            print!("{}", toml::to_string(&Config::default())?);
            Ok(())
        }
        Command::Learn(args) => learn(&args),
        Command::Fit(args) => swingup::fit_cmd::fit_command(&args),
    }
}

fn load_config(args: &LearnArgs) -> anyhow::Result<Config> {
    let mut cfg = match &args.config {
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
            toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?
        }
        None => Config::default(),
    };
    if let Some(seed) = args.seed {
        cfg.seed = seed;
    }
    if let Some(lambda) = args.lambda {
        cfg.planner.lambda = lambda;
    }
    if let Some(n) = args.max_trials {
        cfg.max_trials = n;
    }
    cfg.validate()?;
    Ok(cfg)
}

fn learn(args: &LearnArgs) -> anyhow::Result<()> {
    let cfg = load_config(args)?;
    let out = &args.out;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let previous = if args.resume {
        let trials = report::read_trials(out)?;
        check_resume_config(out, &cfg)?;
        println!(
            "resuming {}: {} finished trial(s) read back",
            out.display(),
            trials.len()
        );
        trials
    } else {
        Vec::new()
    };
    std::fs::write(out.join("config.toml"), toml::to_string(&cfg)?)?;
    println!(
        "swingup: robot l = {} m, b = {} /s, hand lag {} s; human l = {} m; lambda = {:e}; up to {} trials; seed {}",
        cfg.robot.length,
        cfg.robot.damping,
        cfg.robot.lag,
        cfg.human.length,
        cfg.planner.lambda,
        cfg.max_trials,
        cfg.seed
    );
    println!("writing to {}", out.display());
    let start = std::time::Instant::now();
    let mut save_error = None;
    let mut progress = |t: &TrialRecord| {
        print_trial(t);
        // every finished trial is saved at once, so an interrupted run loses nothing
        if let Err(e) = report::write_trial(out, t) {
            save_error.get_or_insert(e);
        }
    };
    let record = run(&cfg, previous, &mut progress)?;
    if let Some(e) = save_error {
        return Err(e).context("saving a trial");
    }
    report::write_run(out, &record)?;
    println!("{}", report::result_line(&record));
    println!(
        "report: {}, plots: {}, {} ({:.1} s)",
        out.join("report.md").display(),
        out.join("figure3.svg").display(),
        out.join("learning.svg").display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// A resumed run must use the configuration its trials were made with.
fn check_resume_config(out: &Path, cfg: &Config) -> anyhow::Result<()> {
    let path = out.join("config.toml");
    if let Ok(text) = std::fs::read_to_string(&path) {
        let before: Config = toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
        let same_except_cap = Config {
            max_trials: cfg.max_trials,
            ..before
        } == *cfg;
        anyhow::ensure!(
            same_except_cap,
            "{} was made with another configuration; resume with the same one (only --max-trials may change)",
            out.display()
        );
    }
    Ok(())
}

fn print_trial(t: &TrialRecord) {
    let what = match t.kind {
        TrialKind::Imitation => "imitation".to_string(),
        TrialKind::Planned => match (&t.plan, &t.model) {
            (Some(p), Some(m)) => format!(
                "plan {} in {} it ({:.2} s), cost {:.3e} (task {:.3e}, inconsistency {:.3e}); model {} points, LOO nMSE {:.3}",
                p.status, p.iterations, p.seconds, p.cost, p.task, p.inconsistency, m.n_points, m.loo_nmse
            ),
            _ => "planned".to_string(),
        },
    };
    let outcome = if t.success {
        "SUCCESS".to_string()
    } else {
        format!("failed: {}", t.failure)
    };
    println!(
        "trial {:>2}: max angle {:>4.0} deg, {} | {}",
        t.index,
        t.max_angle.to_degrees(),
        outcome,
        what
    );
}
