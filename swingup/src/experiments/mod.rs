//! The experiments behind the paper's claims (C1-C8 of the project's
//! design): grids of learning runs, in parallel (rayon), each one
//! deterministic in its seed, summarised in `experiments.json` and
//! `experiments.md`.
//!
//! | experiment | runs | claims |
//! |---|---|---|
//! | `learning` | LWR + Eq. 3 by Gauss-Newton (B-splines, wavelets) and Powell (B-splines), over seeds | C1 (trial 1 of every run), C2, C7 (tuned metric per trial), C8 (rollouts of the models after trials 1-3) |
//! | `lambda` | Gauss-Newton with $\lambda \in \{0, 10, \dots, 10^8\}$ | C3, C4, C5 |
//! | `planners` | {DDP, Eq. 3 Gauss-Newton} x {LWR, parametric, true model} | C6 |
//! | `beyond` | per-point $\lambda$ from the LWR's support; a $\lambda$ schedule over trials; the semiparametric model; learning from scratch (no demonstration) with the LWR, the semiparametric and the true model | beyond the paper |
//! | `mpc` | open loop against model-predictive control ([`crate::planning::mpc`]) with the LWR, the semiparametric and the true model; PILCO's cart-pole learned from scratch with the LWR and MPC ([`crate::cartpole`], variant [`CARTPOLE_VARIANT`]) | beyond the paper |
//!
//! Every pendulum run is a [`crate::learn::run`] with a configuration that
//! differs from the defaults only where the table says; every cart-pole
//! run is a [`crate::cartpole::run`] with the grid's
//! [`ExperimentSettings::cartpole`].

pub mod basin;
pub mod sensitivity;

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::cartpole::CartPoleSettings;
use crate::config::{BasisKind, Config, Controller, LwrPrior, ModelKind, Solver, Start};
use crate::learn::run;
use crate::models::PendulumRegression;
use crate::models::learned::learn_model;
use crate::record::{RunRecord, TrialRecord, quantile};

pub mod claims;
use claims::claims;
pub use claims::demonstration_worth;
mod jobs;
use jobs::jobs;

mod summary;
pub(crate) use summary::summarise;
pub use summary::{
    BLOW_UP_NORM, CARTPOLE_VARIANT, Claim, ExperimentsReport, LEFT_DATA_SUPPORT, Rollout, RunSummary, TaskTime,
    VariantSummary, is_cartpole, median, task_of,
};

/// Which experiments to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Experiment {
    /// LWR + Eq. 3 over seeds, both solvers and both bases (C1, C2, C7, C8).
    Learning,
    /// The consistency weight sweep (C3-C5).
    Lambda,
    /// DDP and Eq. 3 with learned LWR, learned parametric and true models (C6).
    Planners,
    /// Per-point lambda from the model's confidence, a lambda schedule over
    /// trials, the semiparametric model, learning without a demonstration.
    Beyond,
    /// Open loop against model-predictive control, for the LWR, the
    /// semiparametric and the true model, and the cart-pole learned from
    /// scratch with MPC (not in the default grid: run it by name).
    Mpc,
}

/// The grid's size.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentSettings {
    /// Seeds per variant of the lambda, planners and beyond experiments (1, 2, ...).
    pub seeds: u64,
    /// Seeds of the main learning variant (Gauss-Newton, B-splines).
    pub learning_seeds: u64,
    /// Seeds of the wavelet variant (slower: one coefficient per sample).
    pub wavelet_seeds: u64,
    /// Seeds for the Powell variant (slow: derivative-free over 120 coefficients).
    pub powell_seeds: u64,
    /// Seeds for the derivative-free least-squares variant (settings saved
    /// before it existed read back with 0: the variant did not run).
    #[serde(default)]
    pub derivative_free_seeds: u64,
    /// Seeds for the paper-basis variants ([`PAPER_BASIS`]: Powell and
    /// Gauss-Newton on a smaller basis; 0 in the full grid, settings saved
    /// before they existed read back with 0, and 0 is not written, so the
    /// fingerprint of a grid without them is the one it had before).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub paper_basis_seeds: u64,
    /// Trial cap of every run.
    pub max_trials: usize,
    /// Powell's evaluation budget per plan.
    pub powell_evals: usize,
    /// Consistency weights of the sweep.
    pub lambdas: Vec<f64>,
    /// The model of the `learning` and `lambda` experiments.
    pub model: ModelKind,
    /// Seeds per variant of the `mpc` experiment (settings saved before it
    /// existed read back with 20).
    #[serde(default = "twenty")]
    pub mpc_seeds: u64,
    /// The cart-pole runs of the `mpc` experiment (seeds 1 to `mpc_seeds`;
    /// settings saved before it existed read back with the defaults,
    /// PILCO's).
    #[serde(default)]
    pub cartpole: CartPoleSettings,
}

/// The most seeds a grid's variant may run ([`ExperimentSettings::validate`]).
pub const MAX_SEEDS: u64 = 10_000;

fn twenty() -> u64 {
    20
}

fn is_zero(n: &u64) -> bool {
    *n == 0
}

impl ExperimentSettings {
    /// Checks every size: seeds 1 to [`MAX_SEEDS`] per variant (0 for the
    /// optional variants), trials 1 to [`limits::MAX_TRIALS`](crate::config::limits::MAX_TRIALS),
    /// Powell's budget 1 to 10⁹, at least one finite nonnegative lambda,
    /// and the cart-pole's settings ([`CartPoleSettings::validate`]).
    ///
    /// # Errors
    /// [`Error::Config`](crate::Error::Config) naming the first setting
    /// out of its range, with its value.
    pub fn validate(&self) -> crate::Result<()> {
        use crate::error::ensure_config;
        for (key, n, least) in [
            ("seeds", self.seeds, 1),
            ("learning_seeds", self.learning_seeds, 1),
            ("wavelet_seeds", self.wavelet_seeds, 0),
            ("powell_seeds", self.powell_seeds, 0),
            ("derivative_free_seeds", self.derivative_free_seeds, 0),
            ("paper_basis_seeds", self.paper_basis_seeds, 0),
            ("mpc_seeds", self.mpc_seeds, 1),
        ] {
            ensure_config!(
                key,
                (least..=MAX_SEEDS).contains(&n),
                "{key} must be {least} to {MAX_SEEDS}, got {n}"
            );
        }
        let max_trials = crate::config::limits::MAX_TRIALS;
        ensure_config!(
            "max_trials",
            (1..=max_trials).contains(&self.max_trials),
            "max_trials must be 1 to {max_trials}, got {}",
            self.max_trials
        );
        ensure_config!(
            "powell_evals",
            (1..=1_000_000_000).contains(&self.powell_evals),
            "powell_evals must be 1 to 1e9, got {}",
            self.powell_evals
        );
        ensure_config!(
            "lambdas",
            !self.lambdas.is_empty() && self.lambdas.iter().all(|l| l.is_finite() && *l >= 0.0),
            "lambdas must hold at least one value, each finite and nonnegative, got {:?}",
            self.lambdas
        );
        self.cartpole.validate()
    }

    /// A fingerprint of the settings (16 hex digits, [`store::digest`] of
    /// their JSON), which every run made with them carries
    /// ([`RunSummary::settings_digest`]).
    pub fn digest(&self) -> String {
        store::digest(serde_json::to_string(self).unwrap_or_default().as_bytes())
    }

    /// The full grid: 20 seeds for each learning variant (C2) and each
    /// `mpc` variant, 6 for every other variant, 8 trials (the cart-pole:
    /// a random trial and up to 15 MPC trials, PILCO's) (the run time of the committed grid is in
    /// `results/experiments.md`).
    pub fn full() -> Self {
        Self {
            seeds: 6,
            learning_seeds: 20,
            wavelet_seeds: 20,
            powell_seeds: 20,
            derivative_free_seeds: 20,
            paper_basis_seeds: 0,
            max_trials: 8,
            powell_evals: 10_000,
            lambdas: vec![0.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e8],
            model: ModelKind::Lwr,
            mpc_seeds: 20,
            cartpole: CartPoleSettings::default(),
        }
    }

    /// A reduced grid for a quick check: 2 seeds, 4 trials (the cart-pole: a
    /// random trial and up to 3 MPC trials), three lambdas.
    pub fn quick() -> Self {
        Self {
            seeds: 2,
            learning_seeds: 2,
            wavelet_seeds: 1,
            powell_seeds: 1,
            derivative_free_seeds: 1,
            paper_basis_seeds: 0,
            max_trials: 4,
            powell_evals: 3_000,
            lambdas: vec![0.0, 1e3, 1e8],
            model: ModelKind::Lwr,
            mpc_seeds: 2,
            cartpole: CartPoleSettings {
                max_trials: 3,
                ..CartPoleSettings::default()
            },
        }
    }
}

/// The learning-from-scratch variants of `beyond`: model and name.
const SCRATCH: [(ModelKind, &str); 3] = [
    (ModelKind::Lwr, "lwr"),
    (ModelKind::LwrParametric, "lwr-parametric"),
    (ModelKind::True, "true"),
];

/// The model name of the `mpc` experiment's variants with the pure LWR over
/// the control-affine prior ([`LwrPrior::ControlAffine`]).
const CONTROL_AFFINE: &str = "lwr-control-affine";

/// Variant names of runs without a demonstration start with this.
const SCRATCH_PREFIX: &str = "scratch, ";

/// Whether a run's first trial imitated the demonstration.
fn imitates(r: &RunSummary) -> bool {
    !r.variant.starts_with(SCRATCH_PREFIX)
}

/// The learning experiment's main variant, the paper's method (the only
/// one whose runs keep their rollouts).
pub(crate) const MAIN_VARIANT: &str = "gauss-newton/bspline";

/// The paper-basis variants' B-spline coefficients, per state channel and
/// for the control: 48 coefficients in all instead of the default 120
/// (the paper fitted its knot points to the demonstration, Eqs. 6-7, and
/// does not give their number). Powell's method needs about $n$ sweeps of
/// $n$ line searches to converge on a quadratic, so a smaller $n$ is the
/// paper's way to make it converge (issue 33).
pub const PAPER_BASIS: (usize, usize) = (10, 8);

/// Powell's evaluation budget per plan in the paper-basis variant (how
/// many of its plans converge within it: `results/derivative-free/paper-basis`).
pub const PAPER_BASIS_POWELL_EVALS: usize = 50_000;

/// The learning experiment's derivative-free least-squares variant.
pub(crate) const DERIVATIVE_FREE_VARIANT: &str = "derivative-free/bspline";

struct Job {
    experiment: &'static str,
    variant: String,
    seed: u64,
    task: JobTask,
}

/// What a job runs.
enum JobTask {
    /// A [`crate::learn::run`] (its configuration holds the seed), with the
    /// model rollouts of C8 or without.
    Pendulum { cfg: Box<Config>, rollouts: bool },
    /// A [`crate::cartpole::run`].
    Cartpole(Box<CartPoleSettings>),
}

impl Job {
    /// The pendulum run's configuration (`None` for a cart-pole job).
    #[cfg(test)]
    fn cfg(&self) -> Option<&Config> {
        match &self.task {
            JobTask::Pendulum { cfg, .. } => Some(cfg),
            JobTask::Cartpole(_) => None,
        }
    }
}

/// One part of a grid, for N machines or a Slurm job array: the contract
/// `swingup experiments` shares with `nprl-bench` ([`store::Shard`]).
pub use store::Shard;

/// The runs of the grid `settings` for the experiments `which`, in the
/// grid's fixed order (a run's index is its position, which
/// [`Shard::contains`] splits by): (experiment, variant, seed).
pub fn grid_runs(which: &[Experiment], settings: &ExperimentSettings) -> Vec<(String, String, u64)> {
    jobs(which, settings)
        .into_iter()
        .map(|j| (j.experiment.to_string(), j.variant, j.seed))
        .collect()
}

/// The variants of the experiments `which` on the grid `settings`, in the
/// grid's order, each once.
pub fn variant_names(which: &[Experiment], settings: &ExperimentSettings) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for j in jobs(which, settings) {
        if !names.contains(&j.variant) {
            names.push(j.variant);
        }
    }
    names
}

/// Runs the experiments `which` on the grid `settings`, calling `progress`
/// after each run with (runs done, runs in all, the run) so that the caller
/// can save it at once; when `progress` fails (the run could not be saved),
/// no further run starts and that error is returned. Runs in `previous` (an interrupted grid's, saved
/// that way) are kept and not run again; with `run_missing` false nothing
/// runs and the report covers `previous` alone (each variant says how many
/// runs it has). With a `shard`, only that part of the grid runs (the
/// report covers it and `previous`). With `variants` (prefixes of variant
/// names, e.g. `cartpole`), only the missing runs of the variants named so
/// run; the report still covers every run of `previous` in the grid.
pub fn run_experiments(
    which: &[Experiment],
    settings: &ExperimentSettings,
    previous: Vec<RunSummary>,
    run_missing: bool,
    shard: Option<Shard>,
    variants: &[String],
    progress: &(dyn Fn(usize, usize, &RunSummary) -> crate::Result<()> + Sync),
) -> crate::Result<ExperimentsReport> {
    let start = Instant::now();
    let version = crate::experiments::sensitivity::code_version();
    let digest = settings.digest();
    let all: Vec<Job> = jobs(which, settings)
        .into_iter()
        .enumerate()
        .filter(|(i, _)| shard.is_none_or(|s| s.contains(*i)))
        .map(|(_, j)| j)
        .collect();
    let key = |e: &str, v: &str, seed: u64| (e.to_string(), v.to_string(), seed);
    let wanted: Vec<_> = all.iter().map(|j| key(j.experiment, &j.variant, j.seed)).collect();
    let previous: Vec<RunSummary> = previous
        .into_iter()
        .filter(|r| wanted.contains(&key(&r.experiment, &r.variant, r.seed)))
        .collect();
    let selected = |j: &Job| variants.is_empty() || variants.iter().any(|v| j.variant.starts_with(v.as_str()));
    let jobs: Vec<&Job> = all
        .iter()
        .filter(|_| run_missing)
        .filter(|j| selected(j))
        .filter(|j| {
            !previous
                .iter()
                .any(|r| key(&r.experiment, &r.variant, r.seed) == key(j.experiment, &j.variant, j.seed))
        })
        .collect();
    let total = previous.len() + jobs.len();
    let done = AtomicUsize::new(previous.len());
    let errors = Mutex::new(Vec::new());
    // the first failure to save: no run starts after it
    let stopped: Mutex<Option<crate::Error>> = Mutex::new(None);
    let stop = std::sync::atomic::AtomicBool::new(false);
    let mut runs: Vec<RunSummary> = jobs
        .par_iter()
        .filter(|_| !stop.load(Ordering::SeqCst))
        .filter_map(|job| match run_one(job, &version) {
            Ok(mut r) => {
                r.settings_digest.clone_from(&digest);
                let n = done.fetch_add(1, Ordering::SeqCst) + 1;
                if let Err(e) = progress(n, total, &r) {
                    stop.store(true, Ordering::SeqCst);
                    if let Ok(mut first) = stopped.lock() {
                        first.get_or_insert(e);
                    }
                    return None;
                }
                Some(r)
            }
            Err(e) => {
                if let Ok(mut v) = errors.lock() {
                    v.push(format!("{} {} seed {}: {e:#}", job.experiment, job.variant, job.seed));
                }
                None
            }
        })
        .collect();
    if let Some(e) = stopped.into_inner().ok().flatten() {
        return Err(e);
    }
    let errors = errors.into_inner().unwrap_or_default();
    if !errors.is_empty() {
        return Err(crate::Error::RunsFailed(errors));
    }
    let ran = runs.len();
    let seconds = start.elapsed().as_secs_f64();
    let threads = rayon::current_num_threads();
    let mut task_times: Vec<TaskTime> = Vec::new();
    for r in &runs {
        match task_times.iter_mut().find(|p| p.task == task_of(r)) {
            Some(p) => p.ran = p.ran.map(|n| n + 1),
            None => task_times.push(TaskTime {
                task: task_of(r).to_string(),
                ran: Some(1),
                invocation_ran: Some(ran),
                seconds,
                threads,
            }),
        }
    }
    task_times.sort_by(|a, b| a.task.cmp(&b.task));
    runs.extend(previous);
    runs.sort_by(|a, b| (&a.experiment, &a.variant, a.seed).cmp(&(&b.experiment, &b.variant, b.seed)));
    let variants = summarise(&runs);
    let mut claims = claims(which, settings, &runs, &variants);
    // the grid's runs without a record (a shard, --variants, a grid still
    // running): named, and no claim judged on the part alone
    let have: std::collections::BTreeSet<_> = runs.iter().map(|r| key(&r.experiment, &r.variant, r.seed)).collect();
    let missing: Vec<String> = self::jobs(which, settings)
        .iter()
        .filter(|j| !have.contains(&key(j.experiment, &j.variant, j.seed)))
        .map(|j| format!("{} {} seed {}", j.experiment, j.variant, j.seed))
        .collect();
    if !missing.is_empty() {
        for c in &mut claims {
            c.reproduced = format!("incomplete ({} runs missing; was: {})", missing.len(), c.reproduced);
        }
    }
    Ok(ExperimentsReport {
        settings: settings.clone(),
        experiments: which.to_vec(),
        runs,
        variants,
        claims,
        seconds,
        threads,
        ran: Some(ran),
        task_times,
        missing,
    })
}

fn run_one(job: &Job, version: &str) -> crate::Result<RunSummary> {
    let (cfg, rollouts_wanted) = match &job.task {
        JobTask::Pendulum { cfg, rollouts } => (cfg, *rollouts),
        JobTask::Cartpole(settings) => return run_cartpole(job, settings, version),
    };
    let start = Instant::now();
    let record = run(cfg, vec![], &mut |_: &TrialRecord| {})?;
    let rollouts = if rollouts_wanted {
        rollouts(cfg, &record)?
    } else {
        vec![]
    };
    let planned = || record.trials.iter().filter_map(|t| t.plan.as_ref());
    Ok(RunSummary {
        experiment: job.experiment.into(),
        variant: job.variant.clone(),
        seed: job.seed,
        success_trial: record.success_trial,
        trials: record.trials.len(),
        robot_seconds: record.robot_seconds,
        max_angles: record.trials.iter().map(|t| t.max_angle).collect(),
        plan_statuses: planned().map(|p| p.status).collect(),
        plan_costs: planned().map(|p| p.cost).collect(),
        plan_gauss_newton_costs: planned().map(|p| p.gauss_newton_cost).collect(),
        failures: record
            .trials
            .iter()
            .map(|t| match &t.plan {
                Some(p) if p.planner == "ddp" => {
                    format!("{} [ddp: {}]", t.failure, crate::planning::ddp::classify_ddp_failure(p))
                }
                _ => t.failure.clone(),
            })
            .collect(),
        scales: record
            .trials
            .iter()
            .filter_map(|t| t.model.as_ref())
            .map(|m| m.scales.clone())
            .collect(),
        rollouts,
        seconds: start.elapsed().as_secs_f64(),
        replan_ms: record
            .trials
            .iter()
            .filter_map(|t| t.mpc.as_ref())
            .map(|m| [m.replan_quantile(0.5), m.replan_quantile(0.99)])
            .collect(),
        first_plan_ms: vec![],
        trial_success: record.trials.iter().map(|t| t.success).collect(),
        code_version: version.to_string(),
        settings_digest: String::new(),
    })
}

/// A cart-pole run as a grid's run: its trials' successes, the seconds of
/// system data to success (all trials' when it never succeeds, the random
/// one counted), the replan time quantiles of each MPC trial (the warm
/// replans; the cold first plan's time apart), and per failed trial how
/// far the tip ended from the target.
fn run_cartpole(job: &Job, settings: &CartPoleSettings, version: &str) -> crate::Result<RunSummary> {
    let start = Instant::now();
    let r = crate::cartpole::run(settings, job.seed)?;
    let all_data = r.trials.last().map_or(0.0, |t| t.data_seconds);
    let mpc_trials = || r.trials.iter().filter(|t| !t.replan_ms.is_empty());
    Ok(RunSummary {
        experiment: job.experiment.into(),
        variant: job.variant.clone(),
        seed: job.seed,
        success_trial: r.success_trial,
        trials: r.trials.len(),
        robot_seconds: r.seconds_to_success.unwrap_or(all_data),
        max_angles: vec![],
        plan_statuses: vec![],
        plan_costs: vec![],
        plan_gauss_newton_costs: vec![],
        failures: r
            .trials
            .iter()
            .map(|t| {
                if t.success {
                    String::new()
                } else {
                    format!(
                        "{}: tip {:.2} m from the target at the end",
                        t.controller, t.final_distance
                    )
                }
            })
            .collect(),
        scales: vec![],
        rollouts: vec![],
        seconds: start.elapsed().as_secs_f64(),
        // as the pendulum's MPC trace, the trial's first (cold) plan is
        // not a replan: its time is recorded apart
        replan_ms: mpc_trials()
            .map(|t| [quantile(&t.replan_ms[1..], 0.5), quantile(&t.replan_ms[1..], 0.99)])
            .collect(),
        first_plan_ms: mpc_trials().map(|t| t.replan_ms[0]).collect(),
        trial_success: r.trials.iter().map(|t| t.success).collect(),
        code_version: version.to_string(),
        settings_digest: String::new(),
    })
}

/// C8: the models learned after trials 1, 2, 3 integrated forward from
/// hanging at rest under the commands the robot sent in the next trial,
/// against what the robot did.
pub fn rollouts(cfg: &Config, record: &RunRecord) -> crate::Result<Vec<Rollout>> {
    let mut out = Vec::new();
    for after in 1..=3usize {
        let Some(next) = record.trials.get(after) else { break };
        let (model, _) = learn_model(&cfg.model, cfg.robot.dt, &record.trials[..after])?;
        let mut s = [0.0; 4];
        let (mut left, mut blew, mut err) = (None, None, 0.0f64);
        let mut next_state = [0.0; 4];
        for (k, &u) in next.commands.iter().enumerate().take(cfg.horizon) {
            let z = [s[0], s[1], s[2], s[3], u];
            let support = model.regression.support(&z).unwrap_or(0.0);
            if left.is_none() && (support < LEFT_DATA_SUPPORT || !s.iter().all(|v| v.is_finite())) {
                left = Some(k);
            }
            if !s.iter().all(|v| v.is_finite() && v.abs() <= BLOW_UP_NORM) {
                blew = Some(k);
                break;
            }
            trajopt::Dynamics::step(&model, &s, &[u], &mut next_state).map_err(trajopt::TrajoptError::from)?;
            s = next_state;
            err = err.max((s[0] - next.states[k + 1][0]).abs());
        }
        out.push(Rollout {
            after_trial: after,
            left_data_at: left,
            blew_up_at: blew,
            max_angle_error: if blew.is_some() { f64::NAN } else { err },
        });
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn summary(
        experiment: &str,
        variant: &str,
        seed: u64,
        success: Option<usize>,
        first_angle: f64,
    ) -> RunSummary {
        RunSummary {
            experiment: experiment.into(),
            variant: variant.into(),
            seed,
            success_trial: success,
            trials: success.unwrap_or(8),
            robot_seconds: 5.5 * success.unwrap_or(8) as f64,
            max_angles: vec![first_angle],
            code_version: "commit test".into(),
            ..Default::default()
        }
    }

    /// The beyond grid has the three learning-from-scratch variants, each
    /// without a demonstration and otherwise as its model's default.
    #[test]
    fn shards_split_the_grid_and_parse_strictly() {
        let shards: Vec<Shard> = (1..=3).map(|k| format!("{k}/3").parse().expect("shard")).collect();
        for position in 0..20 {
            assert_eq!(shards.iter().filter(|s| s.contains(position)).count(), 1);
        }
        assert!(shards[1].contains(1) && shards[1].contains(4) && !shards[1].contains(2));
        for bad in ["0/3", "4/3", "3", "a/b", "1/0", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    /// The mpc grid holds one cart-pole job per seed, with the grid's
    /// cart-pole settings, beside the eight pendulum variants.
    #[test]
    fn mpc_has_one_cartpole_run_per_seed() {
        let settings = ExperimentSettings::quick();
        let all = jobs(&[Experiment::Mpc], &settings);
        let cart: Vec<&Job> = all.iter().filter(|j| j.variant == CARTPOLE_VARIANT).collect();
        assert_eq!(cart.len(), settings.mpc_seeds as usize);
        assert!(
            cart.iter()
                .all(|j| matches!(&j.task, JobTask::Cartpole(c) if **c == settings.cartpole))
        );
        assert_eq!(all.len(), 9 * settings.mpc_seeds as usize);
        // the control-affine prior's runs are the pure LWR over it, open loop and MPC
        let affine: Vec<&Job> = all.iter().filter(|j| j.variant.ends_with(CONTROL_AFFINE)).collect();
        assert_eq!(affine.len(), 2 * settings.mpc_seeds as usize);
        assert!(affine.iter().all(|j| matches!(&j.task, JobTask::Pendulum { cfg, .. }
            if cfg.model.kind == ModelKind::Lwr && cfg.model.prior == LwrPrior::ControlAffine)));
        assert_eq!(
            cart.iter().map(|j| j.seed).collect::<Vec<_>>(),
            (1..=settings.mpc_seeds).collect::<Vec<_>>()
        );
        let names = variant_names(&[Experiment::Mpc], &settings);
        assert_eq!(names.len(), 9);
        assert!(names.iter().any(|n| n == CARTPOLE_VARIANT));
    }

    #[test]
    fn beyond_learns_from_scratch_for_each_model() {
        let settings = ExperimentSettings::quick();
        let all = jobs(&[Experiment::Beyond], &settings);
        let scratch: Vec<&Job> = all
            .iter()
            .filter(|j| j.cfg().is_some_and(|c| c.start == Start::Scratch))
            .collect();
        assert_eq!(scratch.len(), 3 * settings.seeds as usize);
        for (kind, name) in SCRATCH {
            let v = format!("{SCRATCH_PREFIX}{name}");
            assert!(
                scratch
                    .iter()
                    .any(|j| j.variant == v && j.cfg().is_some_and(|c| c.model.kind == kind)),
                "{v}"
            );
        }
        assert!(
            all.iter()
                .filter(|j| j.cfg().is_some_and(|c| c.start != Start::Scratch))
                .all(|j| !j.variant.starts_with(SCRATCH_PREFIX))
        );
    }

    /// C1 reads the imitation trials only: an exploration trial that swings
    /// high does not count against it; the demonstration's worth pairs each
    /// model's runs with and without the demonstration.
    #[test]
    fn imitation_claim_ignores_scratch_runs_and_worth_pairs_variants() {
        let runs = vec![
            summary("beyond", "lwr-parametric", 1, Some(2), 1.5),
            summary("beyond", "scratch, lwr-parametric", 1, Some(4), 3.0),
            summary("beyond", "scratch, lwr-parametric", 2, None, 3.0),
        ];
        let variants = summarise(&runs);
        let c = claims(&[Experiment::Beyond], &ExperimentSettings::quick(), &runs, &variants);
        assert_eq!(c[0].id, "C1");
        assert_eq!(c[0].reproduced, "yes", "{}", c[0].ours);
        assert!(c[0].ours.contains("over 1 runs"), "{}", c[0].ours);
        let worth = demonstration_worth(&variants);
        assert_eq!(worth.len(), 1);
        let (model, with, without) = worth[0];
        assert_eq!(model, "lwr-parametric");
        assert_eq!((with.successes, with.runs), (1, 1));
        assert_eq!((without.successes, without.runs), (1, 2));
        assert_eq!(without.median_robot_seconds, Some(22.0));
    }

    /// Issue 37: a grid's settings with a key this code does not know, an
    /// array element too many, or a size beyond its bound are refused,
    /// naming it; the committed grid's settings are accepted.
    #[test]
    fn settings_refuse_unknown_keys_extra_elements_and_sizes() {
        for s in [ExperimentSettings::full(), ExperimentSettings::quick()] {
            s.validate().expect("the grid's own settings");
        }
        let committed = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../results/settings.json"))
            .expect("results/settings.json");
        let value: serde_json::Value = serde_json::from_str(&committed).expect("json");
        // a manifest holds the settings under a key; older files are bare
        let bare = value.get("settings").cloned().unwrap_or(value);
        let saved: ExperimentSettings = serde_json::from_value(bare.clone()).expect("committed settings read back");
        saved.validate().expect("committed settings valid");
        let text = serde_json::to_string(&ExperimentSettings::full()).expect("json");
        for (from, to, word) in [
            ("\"seeds\":6", "\"seeds\":6,\"seedz\":1", "seedz"),
            ("\"episode\":", "\"episodes\":4.0,\"episode\":", "episodes"),
            ("\"bandwidth\":", "\"bandwith\":1.0,\"bandwidth\":", "bandwith"),
        ] {
            assert!(text.contains(from), "{from}");
            let edited = text.replacen(from, to, 1);
            let e = serde_json::from_str::<ExperimentSettings>(&edited)
                .expect_err(word)
                .to_string();
            assert!(e.contains(word), "{word}: {e}");
        }
        // every fixed-length array of the settings refuses an extra element
        let mut value: serde_json::Value = serde_json::from_str(&text).expect("json");
        let mut arrays = Vec::new();
        fn walk(v: &serde_json::Value, path: String, out: &mut Vec<String>) {
            match v {
                serde_json::Value::Object(m) => m.iter().for_each(|(k, v)| walk(v, format!("{path}/{k}"), out)),
                serde_json::Value::Array(_) => out.push(path),
                _ => {}
            }
        }
        walk(&value, String::new(), &mut arrays);
        assert!(arrays.len() >= 2, "{arrays:?}");
        for path in arrays
            .iter()
            .filter(|p| !p.ends_with("/lambdas") && !p.ends_with("/scales"))
        {
            let original = value.pointer(path).cloned().expect("array");
            if let Some(a) = value.pointer_mut(path).and_then(|v| v.as_array_mut()) {
                a.push(serde_json::json!(1.0));
            }
            assert!(
                serde_json::from_value::<ExperimentSettings>(value.clone()).is_err(),
                "an extra element of {path} was accepted"
            );
            *value.pointer_mut(path).expect("array") = original;
        }
        let mut big = ExperimentSettings::quick();
        big.seeds = 1_000_000_000;
        assert!(big.validate().expect_err("seeds").to_string().contains("seeds"));
        let mut big = ExperimentSettings::quick();
        big.cartpole.max_trials = 1_000_000;
        assert!(
            big.validate()
                .expect_err("cartpole")
                .to_string()
                .contains("cartpole.max_trials")
        );
        let mut none = ExperimentSettings::quick();
        none.lambdas.clear();
        assert!(none.validate().expect_err("lambdas").to_string().contains("lambdas"));
    }
}
