//! What a grid found: one [`RunSummary`] per run, aggregated per variant
//! ([`VariantSummary`]), with the claims table ([`Claim`]) and the wall
//! times in one [`ExperimentsReport`].

use serde::{Deserialize, Serialize};

pub use crate::record::median;

use super::{Experiment, ExperimentSettings};

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

/// One learning run's outcome. `Default` is an empty run (for fixtures;
/// the grid fills every field).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
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
    pub plan_statuses: Vec<crate::record::PlanStatus>,
    /// Final Eq. 3 criterion per planned trial (empty for runs saved
    /// before it was recorded).
    #[serde(default)]
    pub plan_costs: Vec<f64>,
    /// Per planned trial, the criterion Gauss-Newton reaches on the same
    /// problem, where the run compared it
    /// ([`PlannerConfig::compare_gauss_newton`](crate::config::PlannerConfig::compare_gauss_newton)).
    #[serde(default)]
    pub plan_gauss_newton_costs: Vec<Option<f64>>,
    /// Failure per trial (empty on success); DDP trials add the failure class.
    pub failures: Vec<String>,
    /// Tuned metric per planned trial (relative to each input's spread).
    pub scales: Vec<Vec<f64>>,
    /// Model rollouts (C8), `learning` GN/B-spline runs only.
    pub rollouts: Vec<Rollout>,
    /// Wall time (s).
    pub seconds: f64,
    /// Per trial run under model-predictive control: the median and the
    /// 99th percentile of its replan times (ms, [`quantile`](crate::record::quantile)); empty otherwise.
    #[serde(default)]
    pub replan_ms: Vec<[f64; 2]>,
    /// Per cart-pole MPC trial: the wall time of its first plan (ms), a
    /// cold start not counted in `replan_ms`; empty for the pendulum,
    /// whose first plan is timed with the trial's planning.
    #[serde(default)]
    pub first_plan_ms: Vec<f64>,
    /// Whether each trial succeeded, in order (empty for runs saved before
    /// it was recorded).
    #[serde(default)]
    pub trial_success: Vec<bool>,
    /// The code that made the run (`git describe` of the working
    /// directory, see [`crate::experiments::sensitivity::code_version`]); empty for runs
    /// saved before it was recorded.
    #[serde(default)]
    pub code_version: String,
    /// The fingerprint of the grid's settings the run was made with
    /// ([`ExperimentSettings::digest`]), so that a run is never read back
    /// under other settings; empty for runs saved before it was recorded.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub settings_digest: String,
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
    /// The wall time of each task's runs ([`task_of`]): of the invocation
    /// that made them, kept across reports written from saved runs while
    /// the task's runs stay the same (empty in
    /// reports written before it was recorded: see
    /// [`ExperimentsReport::task_times_or_legacy`]).
    #[serde(default)]
    pub task_times: Vec<TaskTime>,
    /// The grid's runs that have no record (`experiment variant seed`
    /// each): a report of a partial grid names them, and its claims say
    /// `incomplete` instead of a verdict.
    #[serde(default)]
    pub missing: Vec<String>,
}

/// The wall time of the invocation that made (some of) one task's runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TaskTime {
    /// The task ([`task_of`]).
    pub task: String,
    /// Runs of the task that invocation made; `None`: not recorded (a
    /// report written before this was, whatever part of the grid its
    /// invocation ran).
    pub ran: Option<usize>,
    /// Runs that invocation made in all (of this task and others).
    pub invocation_ran: Option<usize>,
    /// Its wall time (s).
    pub seconds: f64,
    /// Its worker threads.
    pub threads: usize,
}

/// The variant of the `mpc` experiment's cart-pole runs: PILCO's
/// cart-pole learned from scratch with the pure LWR and MPC.
pub const CARTPOLE_VARIANT: &str = "cartpole/mpc/lwr";

/// Whether a run is a cart-pole run ([`CARTPOLE_VARIANT`] and any later
/// cart-pole variant).
pub fn is_cartpole(r: &RunSummary) -> bool {
    r.variant.starts_with("cartpole/")
}

/// The task of a run, `pendulum` or `cartpole`: the parts of a grid whose
/// provenance (which code made the runs, in how much wall time) is
/// reported, and timed, apart.
pub fn task_of(r: &RunSummary) -> &'static str {
    if is_cartpole(r) { "cartpole" } else { "pendulum" }
}

/// The (experiment, variant, seed, code version) of each run of `part`, sorted.
fn task_keys(runs: &[RunSummary], part: &str) -> Vec<(String, String, u64, String)> {
    let mut k: Vec<_> = runs
        .iter()
        .filter(|r| task_of(r) == part)
        .map(|r| (r.experiment.clone(), r.variant.clone(), r.seed, r.code_version.clone()))
        .collect();
    k.sort();
    k
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

    /// The task times of this report, or for a report written before they
    /// were recorded, the ones its whole-report wall time implies: each
    /// task it holds timed by the invocation that wrote it (with its
    /// share of the task's runs when recorded, `ran`).
    pub fn task_times_or_legacy(&self) -> Vec<TaskTime> {
        if !self.task_times.is_empty() || self.ran == Some(0) {
            return self.task_times.clone();
        }
        let mut parts: Vec<&str> = self.runs.iter().map(task_of).collect();
        parts.sort_unstable();
        parts.dedup();
        parts
            .into_iter()
            .map(|part| TaskTime {
                task: part.to_string(),
                // a legacy report that ran every one of its runs ran each task's
                ran: self
                    .ran
                    .filter(|&n| n == self.runs.len())
                    .map(|_| self.runs.iter().filter(|r| task_of(r) == part).count()),
                invocation_ran: self.ran,
                seconds: self.seconds,
                threads: self.threads,
            })
            .collect()
    }

    /// Carries over from `previous` (the report this one replaces) the
    /// wall time of every task this report's invocation ran nothing of,
    /// when that task's runs (experiment, variant, seed and code version)
    /// are exactly the ones `previous` held. A task run again, or whose
    /// runs changed, keeps no old wall time. Returns the tasks carried over.
    pub fn keep_task_times_of(&mut self, previous: &ExperimentsReport) -> Vec<String> {
        let mut kept = Vec::new();
        for old in previous.task_times_or_legacy() {
            let mine = self.task_times.iter().any(|p| p.task == old.task);
            let here = self.runs.iter().any(|r| task_of(r) == old.task);
            if !mine && here && task_keys(&self.runs, &old.task) == task_keys(&previous.runs, &old.task) {
                kept.push(old.task.clone());
                self.task_times.push(old);
            }
        }
        self.task_times.sort_by(|a, b| a.task.cmp(&b.task));
        kept
    }

    /// The wall time of `task`'s runs, if measured.
    pub fn task_time(&self, task: &str) -> Option<&TaskTime> {
        self.task_times.iter().find(|p| p.task == task)
    }
}

/// One [`VariantSummary`] per (experiment, variant) of `runs`, in their order.
pub(crate) fn summarise(runs: &[RunSummary]) -> Vec<VariantSummary> {
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
