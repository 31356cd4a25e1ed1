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
//! | `mpc` | open loop against model-predictive control ([`crate::planning::mpc`]) with the LWR, the semiparametric and the true model | beyond the paper |
//!
//! Every run is a [`crate::learn::run`] with a configuration that differs
//! from the defaults only where the table says.

pub mod sensitivity;

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::config::{BasisKind, Config, Controller, ModelKind, Solver, Start};
use crate::learn::run;
use crate::models::PendulumRegression;
use crate::models::learned::learn_model;
use crate::record::{RunRecord, TrialRecord};

pub mod claims;
use claims::claims;

/// Which experiments to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
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
    /// semiparametric and the true model (not in the default grid: run it
    /// by name).
    Mpc,
}

/// The grid's size.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExperimentSettings {
    /// Seeds per variant of the lambda, planners and beyond experiments (1, 2, ...).
    pub seeds: u64,
    /// Seeds of the main learning variant (Gauss-Newton, B-splines).
    pub learning_seeds: u64,
    /// Seeds of the wavelet variant (slower: one coefficient per sample).
    pub wavelet_seeds: u64,
    /// Seeds for the Powell variant (slow: derivative-free over 120 coefficients).
    pub powell_seeds: u64,
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
}

fn twenty() -> u64 {
    20
}

impl ExperimentSettings {
    /// The full grid: 20 seeds for each learning variant (C2), 6 for every
    /// other variant, 8 trials (the run time of the committed grid is in
    /// `results/experiments.md`).
    pub fn full() -> Self {
        Self {
            seeds: 6,
            learning_seeds: 20,
            wavelet_seeds: 20,
            powell_seeds: 20,
            max_trials: 8,
            powell_evals: 10_000,
            lambdas: vec![0.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e8],
            model: ModelKind::Lwr,
            mpc_seeds: 20,
        }
    }

    /// A reduced grid for a quick check: 2 seeds, 4 trials, three lambdas.
    pub fn quick() -> Self {
        Self {
            seeds: 2,
            learning_seeds: 2,
            wavelet_seeds: 1,
            powell_seeds: 1,
            max_trials: 4,
            powell_evals: 3_000,
            lambdas: vec![0.0, 1e3, 1e8],
            model: ModelKind::Lwr,
            mpc_seeds: 2,
        }
    }
}

/// How far forward integration of a model learned after `after_trial`
/// trials gets under the next trial's planned commands (C8).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Rollout {
    /// Trials the model was learned from.
    pub after_trial: usize,
    /// Samples integrated before a state became non-finite or left the
    /// data (support below [`LEFT_DATA_SUPPORT`]); `None`: never.
    pub left_data_at: Option<usize>,
    /// Samples integrated before a state became non-finite or exceeded
    /// [`BLOW_UP_NORM`] in some component; `None`: never.
    pub blew_up_at: Option<usize>,
    /// Largest angle error against what the robot did under the same commands (rad).
    #[serde(with = "crate::record::nullable")]
    pub max_angle_error: f64,
}

/// Support (effective number of data points) below which a state has left the data.
pub const LEFT_DATA_SUPPORT: f64 = 1e-3;

/// A state component beyond this has blown up.
pub const BLOW_UP_NORM: f64 = 100.0;

/// One learning run's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    /// Experiment name.
    pub experiment: String,
    /// Variant within it.
    pub variant: String,
    /// Seed.
    pub seed: u64,
    /// First successful trial.
    pub success_trial: Option<usize>,
    /// Trials run.
    pub trials: usize,
    /// Seconds of robot data up to success (or all).
    pub robot_seconds: f64,
    /// Largest pendulum angle per trial (rad).
    pub max_angles: Vec<f64>,
    /// Planner status per planned trial.
    pub plan_statuses: Vec<String>,
    /// Failure per trial (empty on success); DDP trials add the failure class.
    pub failures: Vec<String>,
    /// Tuned metric per planned trial (relative to each input's spread).
    pub scales: Vec<Vec<f64>>,
    /// Model rollouts (C8), `learning` GN/B-spline runs only.
    pub rollouts: Vec<Rollout>,
    /// Wall time (s).
    pub seconds: f64,
    /// Per trial run under model-predictive control: the median and the
    /// 99th percentile of its replan times (ms); empty otherwise.
    #[serde(default)]
    pub replan_ms: Vec<[f64; 2]>,
    /// The code that made the run (`git describe` of the working
    /// directory, see [`crate::experiments::sensitivity::code_version`]); empty for runs
    /// saved before it was recorded.
    #[serde(default)]
    pub code_version: String,
}

/// Aggregate of one variant over its seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VariantSummary {
    /// Experiment name.
    pub experiment: String,
    /// Variant.
    pub variant: String,
    /// Runs.
    pub runs: usize,
    /// Runs that succeeded.
    pub successes: usize,
    /// Median trial of success over the successful runs.
    pub median_trials: Option<f64>,
    /// Smallest and largest trial of success.
    pub trial_range: Option<(usize, usize)>,
    /// Median seconds of robot data to success over the successful runs.
    pub median_robot_seconds: Option<f64>,
}

/// One row of the claims table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Claim {
    /// C1..C8.
    pub id: String,
    /// What the paper says.
    pub paper: String,
    /// What we found.
    pub ours: String,
    /// yes / no / partly / not run.
    pub reproduced: String,
}

/// Everything `swingup experiments` found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExperimentsReport {
    /// The grid.
    pub settings: ExperimentSettings,
    /// Experiments run.
    pub experiments: Vec<Experiment>,
    /// Every run.
    pub runs: Vec<RunSummary>,
    /// Per variant.
    pub variants: Vec<VariantSummary>,
    /// The claims table.
    pub claims: Vec<Claim>,
    /// Wall time of the invocation that wrote the report (s): with
    /// `--resume`, of its part of the grid only.
    pub seconds: f64,
    /// Worker threads of that invocation.
    #[serde(default)]
    pub threads: usize,
    /// Runs that invocation made (the others were read back from the runs
    /// file: `--resume`, `--report-only`); `None` in reports written
    /// before this was recorded, whose wall time is that of the invocation
    /// that wrote them, whatever part of the grid it ran.
    #[serde(default)]
    pub ran: Option<usize>,
}

impl ExperimentsReport {
    /// Carries the measured wall time (and its thread count) of `previous`
    /// over to this report when this one ran nothing itself (`--report-only`,
    /// or `--resume` with the grid complete) and both cover exactly the same
    /// runs: the same experiment, variant, seed and code version, each once.
    /// Regenerating a report from saved runs then keeps the grid's measured
    /// wall time instead of losing it. Returns whether it did.
    pub fn keep_wall_time_of(&mut self, previous: &ExperimentsReport) -> bool {
        let keys = |r: &ExperimentsReport| {
            let mut k: Vec<(String, String, u64, String)> = r
                .runs
                .iter()
                .map(|s| (s.experiment.clone(), s.variant.clone(), s.seed, s.code_version.clone()))
                .collect();
            k.sort();
            k
        };
        let same = self.ran == Some(0) && previous.ran != Some(0) && keys(self) == keys(previous);
        if same {
            self.seconds = previous.seconds;
            self.threads = previous.threads;
            self.ran = previous.ran;
        }
        same
    }
}

/// The learning-from-scratch variants of `beyond`: model and name.
const SCRATCH: [(ModelKind, &str); 3] = [
    (ModelKind::Lwr, "lwr"),
    (ModelKind::LwrParametric, "lwr-parametric"),
    (ModelKind::True, "true"),
];

/// Variant names of runs without a demonstration start with this.
const SCRATCH_PREFIX: &str = "scratch, ";

/// Whether a run's first trial imitated the demonstration.
fn imitates(r: &RunSummary) -> bool {
    !r.variant.starts_with(SCRATCH_PREFIX)
}

/// The learning experiment's main variant, the paper's method (the only
/// one whose runs keep their rollouts).
pub(crate) const MAIN_VARIANT: &str = "gauss-newton/bspline";

struct Job {
    experiment: &'static str,
    variant: String,
    cfg: Config,
    rollouts: bool,
}

/// A change to a run's configuration that makes a variant.
type Tweak = Box<dyn Fn(&mut Config)>;

fn jobs(which: &[Experiment], s: &ExperimentSettings) -> Vec<Job> {
    let base = |seed: u64| {
        let mut c = Config {
            seed,
            max_trials: s.max_trials,
            ..Config::default()
        };
        c.model.kind = s.model;
        c.planner.powell_evals = s.powell_evals;
        c
    };
    let job = |experiment: &'static str, variant: String, seed: u64, rollouts: bool, tweak: &dyn Fn(&mut Config)| {
        let mut cfg = base(seed);
        tweak(&mut cfg);
        Job {
            experiment,
            variant,
            cfg,
            rollouts,
        }
    };
    // one variant over seeds 1..=seeds; only the main learning variant
    // keeps its rollouts (for the figures)
    let over_seeds = |out: &mut Vec<Job>, experiment, variant: String, seeds: u64, tweak: &dyn Fn(&mut Config)| {
        let rollouts = variant == MAIN_VARIANT;
        out.extend((1..=seeds).map(|seed| job(experiment, variant.clone(), seed, rollouts, tweak)));
    };
    let mut out = Vec::new();
    for &e in which {
        match e {
            Experiment::Learning => {
                over_seeds(&mut out, "learning", MAIN_VARIANT.into(), s.learning_seeds, &|_| {});
                over_seeds(
                    &mut out,
                    "learning",
                    "gauss-newton/wavelet".into(),
                    s.wavelet_seeds,
                    &|c| {
                        c.planner.basis = BasisKind::Wavelet;
                    },
                );
                // Powell: one stage at the final lambda, within its budget
                over_seeds(&mut out, "learning", "powell/bspline".into(), s.powell_seeds, &|c| {
                    c.planner.solver = Solver::Powell;
                    c.planner.lambda_start = 0.0;
                });
            }
            Experiment::Lambda => {
                for &lambda in &s.lambdas {
                    over_seeds(&mut out, "lambda", format!("lambda={lambda:e}"), s.seeds, &|c| {
                        c.planner.lambda = lambda;
                    });
                }
            }
            Experiment::Planners => {
                for (solver, sname) in [(Solver::Ddp, "ddp"), (Solver::GaussNewton, "eq3")] {
                    for (kind, mname) in [
                        (ModelKind::Lwr, "lwr"),
                        (ModelKind::Parametric, "parametric"),
                        (ModelKind::True, "true"),
                    ] {
                        over_seeds(&mut out, "planners", format!("{sname}/{mname}"), s.seeds, &|c| {
                            c.planner.solver = solver;
                            c.model.kind = kind;
                        });
                    }
                }
            }
            Experiment::Beyond => {
                // every variant of a seed before the next seed
                let mut variants: Vec<(String, Tweak)> = vec![
                    (
                        "lwr, confidence lambda".into(),
                        Box::new(|c| {
                            c.model.kind = ModelKind::Lwr;
                            c.planner.confidence_floor = 0.01;
                        }),
                    ),
                    (
                        "lwr, lambda 1e2 x10 per trial".into(),
                        Box::new(|c| {
                            c.model.kind = ModelKind::Lwr;
                            c.planner.lambda = 1e2;
                            c.planner.lambda_growth = 10.0;
                        }),
                    ),
                    (
                        "lwr-parametric".into(),
                        Box::new(|c| c.model.kind = ModelKind::LwrParametric),
                    ),
                ];
                for (kind, name) in SCRATCH {
                    variants.push((
                        format!("{SCRATCH_PREFIX}{name}"),
                        Box::new(move |c| {
                            c.model.kind = kind;
                            c.start = Start::Scratch;
                        }),
                    ));
                }
                for seed in 1..=s.seeds {
                    for (name, tweak) in &variants {
                        out.push(job("beyond", name.clone(), seed, false, tweak.as_ref()));
                    }
                }
            }
            Experiment::Mpc => {
                for seed in 1..=s.mpc_seeds {
                    for (controller, cname) in [(Controller::OpenLoop, "open-loop"), (Controller::Mpc, "mpc")] {
                        for (kind, mname) in SCRATCH {
                            out.push(job("mpc", format!("{cname}/{mname}"), seed, false, &|c| {
                                c.controller = controller;
                                c.model.kind = kind;
                            }));
                        }
                    }
                }
            }
        }
    }
    out
}

/// One of `count` parts of a grid (`index` from 1 to `count`): the runs
/// whose position in the grid's fixed order is `index - 1` modulo `count`,
/// so that `count` machines (or a batch scheduler's job array) can share a
/// grid, each part about equally long.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// This part, from 1.
    pub index: usize,
    /// Number of parts.
    pub count: usize,
}

impl Shard {
    /// Whether the run at `position` of the grid's order belongs to this part.
    pub fn contains(&self, position: usize) -> bool {
        position % self.count == self.index - 1
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `K/N` with $1 \le K \le N$.
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let bad = || format!("a shard is K/N with 1 <= K <= N (e.g. 2/4), got {text:?}");
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let (index, count): (usize, usize) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if index == 0 || index > count {
            return Err(bad());
        }
        Ok(Self { index, count })
    }
}

/// Runs the experiments `which` on the grid `settings`, calling `progress`
/// after each run with (runs done, runs in all, the run) so that the caller
/// can save it at once. Runs in `previous` (an interrupted grid's, saved
/// that way) are kept and not run again; with `run_missing` false nothing
/// runs and the report covers `previous` alone (each variant says how many
/// runs it has). With a `shard`, only that part of the grid runs (the
/// report covers it and `previous`).
pub fn run_experiments(
    which: &[Experiment],
    settings: &ExperimentSettings,
    previous: Vec<RunSummary>,
    run_missing: bool,
    shard: Option<Shard>,
    progress: &(dyn Fn(usize, usize, &RunSummary) + Sync),
) -> crate::Result<ExperimentsReport> {
    let start = Instant::now();
    let version = crate::experiments::sensitivity::code_version();
    let all: Vec<Job> = jobs(which, settings)
        .into_iter()
        .enumerate()
        .filter(|(i, _)| shard.is_none_or(|s| s.contains(*i)))
        .map(|(_, j)| j)
        .collect();
    let total = all.len();
    let key = |e: &str, v: &str, seed: u64| (e.to_string(), v.to_string(), seed);
    let wanted: Vec<_> = all.iter().map(|j| key(j.experiment, &j.variant, j.cfg.seed)).collect();
    let previous: Vec<RunSummary> = previous
        .into_iter()
        .filter(|r| wanted.contains(&key(&r.experiment, &r.variant, r.seed)))
        .collect();
    let jobs: Vec<&Job> = all
        .iter()
        .filter(|_| run_missing)
        .filter(|j| {
            !previous
                .iter()
                .any(|r| key(&r.experiment, &r.variant, r.seed) == key(j.experiment, &j.variant, j.cfg.seed))
        })
        .collect();
    let done = AtomicUsize::new(previous.len());
    let errors = Mutex::new(Vec::new());
    let mut runs: Vec<RunSummary> = jobs
        .par_iter()
        .filter_map(|job| match run_one(job, &version) {
            Ok(r) => {
                let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(n, total, &r);
                Some(r)
            }
            Err(e) => {
                if let Ok(mut v) = errors.lock() {
                    v.push(format!(
                        "{} {} seed {}: {e:#}",
                        job.experiment, job.variant, job.cfg.seed
                    ));
                }
                None
            }
        })
        .collect();
    let errors = errors.into_inner().unwrap_or_default();
    if !errors.is_empty() {
        return Err(crate::Error::RunsFailed(errors));
    }
    let ran = runs.len();
    runs.extend(previous);
    runs.sort_by(|a, b| (&a.experiment, &a.variant, a.seed).cmp(&(&b.experiment, &b.variant, b.seed)));
    let variants = summarise(&runs);
    let claims = claims(which, settings, &runs, &variants);
    Ok(ExperimentsReport {
        settings: settings.clone(),
        experiments: which.to_vec(),
        runs,
        variants,
        claims,
        seconds: start.elapsed().as_secs_f64(),
        threads: rayon::current_num_threads(),
        ran: Some(ran),
    })
}

fn run_one(job: &Job, version: &str) -> crate::Result<RunSummary> {
    let start = Instant::now();
    let record = run(&job.cfg, vec![], &mut |_: &TrialRecord| {})?;
    let rollouts = if job.rollouts {
        rollouts(&job.cfg, &record)?
    } else {
        vec![]
    };
    let planned = || record.trials.iter().filter_map(|t| t.plan.as_ref());
    Ok(RunSummary {
        experiment: job.experiment.into(),
        variant: job.variant.clone(),
        seed: job.cfg.seed,
        success_trial: record.success_trial,
        trials: record.trials.len(),
        robot_seconds: record.robot_seconds,
        max_angles: record.trials.iter().map(|t| t.max_angle).collect(),
        plan_statuses: planned().map(|p| p.status.clone()).collect(),
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
        code_version: version.to_string(),
    })
}

/// C8: the models learned after trials 1, 2, 3 integrated forward from
/// hanging at rest under the commands the robot sent in the next trial,
/// against what the robot did.
pub fn rollouts(cfg: &Config, record: &RunRecord) -> crate::Result<Vec<Rollout>> {
    let mut out = Vec::new();
    for after in 1..=3usize {
        let Some(next) = record.trials.get(after) else { break };
        let (model, _) = learn_model(cfg, &record.trials[..after])?;
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
            trajopt::Model::step(&model, &s, &[u], &mut next_state)?;
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

fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

fn summarise(runs: &[RunSummary]) -> Vec<VariantSummary> {
    let mut keys: Vec<(String, String)> = runs.iter().map(|r| (r.experiment.clone(), r.variant.clone())).collect();
    keys.dedup();
    keys.into_iter()
        .map(|(experiment, variant)| {
            let mine: Vec<&RunSummary> = runs
                .iter()
                .filter(|r| r.experiment == experiment && r.variant == variant)
                .collect();
            let ok: Vec<&RunSummary> = mine.iter().copied().filter(|r| r.success_trial.is_some()).collect();
            let mut trials: Vec<f64> = ok.iter().filter_map(|r| r.success_trial).map(|t| t as f64).collect();
            let mut secs: Vec<f64> = ok.iter().map(|r| r.robot_seconds).collect();
            let range = ok
                .iter()
                .filter_map(|r| r.success_trial)
                .fold(None, |acc: Option<(usize, usize)>, t| {
                    Some(acc.map_or((t, t), |(a, b)| (a.min(t), b.max(t))))
                });
            VariantSummary {
                experiment,
                variant,
                runs: mine.len(),
                successes: ok.len(),
                median_trials: median(&mut trials),
                trial_range: range,
                median_robot_seconds: median(&mut secs),
            }
        })
        .collect()
}

/// The pairs of variants that differ only in the demonstration: (model,
/// with it, without it), where both ran.
pub fn demonstration_worth(variants: &[VariantSummary]) -> Vec<(&'static str, &VariantSummary, &VariantSummary)> {
    let find = |e: &str, v: &str| variants.iter().find(|x| x.experiment == e && x.variant == v);
    [
        ("lwr", "learning", "gauss-newton/bspline"),
        ("lwr-parametric", "beyond", "lwr-parametric"),
        ("true", "planners", "eq3/true"),
    ]
    .into_iter()
    .filter_map(|(model, e, v)| Some((model, find(e, v)?, find("beyond", &format!("{SCRATCH_PREFIX}{model}"))?)))
    .collect()
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
            plan_statuses: vec![],
            failures: vec![],
            scales: vec![],
            rollouts: vec![],
            seconds: 0.0,
            replan_ms: vec![],
            code_version: "commit test".into(),
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

    #[test]
    fn beyond_learns_from_scratch_for_each_model() {
        let settings = ExperimentSettings::quick();
        let all = jobs(&[Experiment::Beyond], &settings);
        let scratch: Vec<&Job> = all.iter().filter(|j| j.cfg.start == Start::Scratch).collect();
        assert_eq!(scratch.len(), 3 * settings.seeds as usize);
        for (kind, name) in SCRATCH {
            let v = format!("{SCRATCH_PREFIX}{name}");
            assert!(
                scratch.iter().any(|j| j.variant == v && j.cfg.model.kind == kind),
                "{v}"
            );
        }
        assert!(
            all.iter()
                .filter(|j| j.cfg.start != Start::Scratch)
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
}
