//! What a learning run records: one [`TrialRecord`] per trial, gathered in a
//! [`RunRecord`]. These are what the report, the CSV logs and the plots are
//! made from, and what `--resume` reads back.

use ddp::DdpStatus;
use serde::{Deserialize, Serialize};
use trajopt::{GaussNewtonStatus, PowellStatus};

use crate::plant::demo::Demonstration;

/// How a plan's solver stopped: its own status, typed
/// ([`solve::Status::termination`] gives the shared vocabulary).
///
/// Written by serde as the status's name (`"ConvergedCost"`,
/// `"MaxIterations"`; a DDP failure with data as
/// `{"InitialRolloutDiverged": {"step": 3}}`). Read back by name: the
/// names that several solvers share (`MaxIterations`, `MaxEvaluations`,
/// `TimeLimit`, `Stopped`) read as the first of Gauss-Newton, Powell and
/// DDP that has them, with the same termination
/// ([`PlanSummary::ddp_status`] reads a DDP plan's as DDP's); the
/// `InitialRolloutDiverged { step: 3 }` of older records is read too.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(untagged)]
pub enum PlanStatus {
    /// Gauss-Newton, the derivative-free mode.
    GaussNewton(GaussNewtonStatus),
    /// Powell.
    Powell(PowellStatus),
    /// DDP.
    Ddp(DdpStatus),
}

impl PlanStatus {
    /// Whether the solver's convergence test passed.
    pub fn is_converged(&self) -> bool {
        solve::Status::termination(self).is_converged()
    }

    /// The status from its record: a name, or DDP's failure with its data
    /// (as serde writes it, or as older records wrote it).
    fn from_record(value: &serde_json::Value) -> Option<Self> {
        let parse = |v: &serde_json::Value| {
            serde_json::from_value(v.clone())
                .map(Self::GaussNewton)
                .or_else(|_| serde_json::from_value(v.clone()).map(Self::Powell))
                .or_else(|_| serde_json::from_value(v.clone()).map(Self::Ddp))
                .ok()
        };
        parse(value).or_else(|| {
            let step = value
                .as_str()?
                .strip_prefix("InitialRolloutDiverged { step: ")?
                .strip_suffix(" }")?
                .parse()
                .ok()?;
            Some(Self::Ddp(DdpStatus::InitialRolloutDiverged { step }))
        })
    }
}

impl<'de> Deserialize<'de> for PlanStatus {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let value = serde_json::Value::deserialize(deserializer)?;
        Self::from_record(&value).ok_or_else(|| {
            serde::de::Error::custom(format!("unknown solver status {}", store::shorten(&value.to_string())))
        })
    }
}

impl solve::Status for PlanStatus {
    fn termination(&self) -> solve::Termination {
        match self {
            Self::GaussNewton(s) => s.termination(),
            Self::Powell(s) => s.termination(),
            Self::Ddp(s) => s.termination(),
        }
    }
}

impl From<GaussNewtonStatus> for PlanStatus {
    fn from(status: GaussNewtonStatus) -> Self {
        Self::GaussNewton(status)
    }
}

impl From<PowellStatus> for PlanStatus {
    fn from(status: PowellStatus) -> Self {
        Self::Powell(status)
    }
}

impl From<DdpStatus> for PlanStatus {
    fn from(status: DdpStatus) -> Self {
        Self::Ddp(status)
    }
}

/// The status's name, as in the records (a DDP failure with its data:
/// `InitialRolloutDiverged (step 3)`).
impl std::fmt::Display for PlanStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::GaussNewton(s) => s.fmt(f),
            Self::Powell(s) => s.fmt(f),
            Self::Ddp(DdpStatus::InitialRolloutDiverged { step }) => write!(f, "InitialRolloutDiverged (step {step})"),
            // DDP's other statuses are unit variants: serde writes their names
            Self::Ddp(s) => match serde_json::to_value(s) {
                Ok(serde_json::Value::String(name)) => f.write_str(&name),
                _ => f.write_str("unknown"),
            },
        }
    }
}

/// How a trial chose its commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TrialKind {
    /// Replaying the demonstration's commands (trial 1).
    Imitation,
    /// Executing a plan made with the learned model.
    Planned,
    /// Random smooth commands (trial 1 when learning without a
    /// demonstration, [`crate::config::Start::Scratch`]).
    Exploration,
}

/// The planner's account of the plan a trial executed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanSummary {
    /// Planner name (`gauss-newton`, `powell`).
    pub planner: String,
    /// How the solver stopped.
    pub status: PlanStatus,
    /// Final criterion (Eq. 3).
    #[serde(with = "nullable")]
    pub cost: f64,
    /// Criterion at the start (the demonstration fitted by the bases).
    #[serde(with = "nullable")]
    pub initial_cost: f64,
    /// Task part of the final criterion.
    #[serde(with = "nullable")]
    pub task: f64,
    /// Inconsistency part, $\sum_k \lambda_k s^2 \lVert x_{k+1} - f(x_k, u_k) \rVert^2$.
    #[serde(with = "nullable")]
    pub inconsistency: f64,
    /// Largest per-step mismatch between the plan and the learned model.
    #[serde(with = "nullable")]
    pub max_mismatch: f64,
    /// Solver iterations.
    pub iterations: usize,
    /// Criterion evaluations.
    pub evaluations: usize,
    /// Wall time of the solve (s).
    pub seconds: f64,
    /// The planned states $(\theta, \dot\theta, x, \dot x)$ at the sample times.
    #[serde(with = "nullable")]
    pub states: Vec<[f64; 4]>,
    /// The planned commands.
    #[serde(with = "nullable")]
    pub controls: Vec<f64>,
    /// With [`PlannerConfig::compare_gauss_newton`](crate::config::PlannerConfig::compare_gauss_newton)
    /// on a derivative-free or Powell plan: the criterion Gauss-Newton
    /// reaches on the same problem (model, start, lambda continuation), for
    /// comparison; its time is not in `seconds`. `None` otherwise.
    #[serde(default)]
    pub gauss_newton_cost: Option<f64>,
}

impl PlanSummary {
    /// A DDP plan's status as DDP's (a name DDP shares with the other
    /// solvers, read back from a record, is DDP's here); `None` for
    /// another planner's plan.
    pub fn ddp_status(&self) -> Option<DdpStatus> {
        if self.planner != "ddp" {
            return None;
        }
        Some(match self.status {
            PlanStatus::Ddp(s) => s,
            other => match solve::Status::termination(&other) {
                solve::Termination::Converged => DdpStatus::Converged,
                solve::Termination::TimeLimit => DdpStatus::TimeLimit,
                solve::Termination::Stopped => DdpStatus::Stopped,
                _ => DdpStatus::MaxIterations,
            },
        })
    }
}

#[cfg(test)]
impl PlanSummary {
    /// A converged plan along `states` and `controls`, for tests of code
    /// that reads plans (costs 1 from 2, one iteration).
    pub(crate) fn along(planner: &str, status: PlanStatus, states: Vec<[f64; 4]>, controls: Vec<f64>) -> Self {
        Self {
            planner: planner.into(),
            status,
            cost: 1.0,
            initial_cost: 2.0,
            task: 1.0,
            inconsistency: 0.0,
            max_mismatch: 0.0,
            iterations: 1,
            evaluations: 1,
            seconds: 0.0,
            states,
            controls,
            gauss_newton_cost: None,
        }
    }
}

/// The learned model a trial's plan was made with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelSummary {
    /// Model kind (`lwr`, `parametric`).
    pub kind: String,
    /// Data points in the model.
    pub n_points: usize,
    /// Names of the inputs, in order.
    pub inputs: Vec<String>,
    /// Tuned per-input scales $m_j$ of the distance metric (LWR), relative to
    /// the initial normalisation; 0 means the input was found irrelevant.
    #[serde(with = "nullable")]
    pub scales: Vec<f64>,
    /// Tuned bandwidth $h$ (LWR).
    #[serde(with = "nullable")]
    pub bandwidth: f64,
    /// Leave-one-out normalised mean squared error after tuning.
    #[serde(with = "nullable")]
    pub loo_nmse: f64,
    /// How much the nonparametric part changed the predictions: the
    /// leave-one-out mean squared error of the model (prior plus LWR)
    /// divided by the mean squared error of its prior alone on the same
    /// data. 1: the LWR changes nothing; 0.1: it removes 90 % of the
    /// prior's error. NaN for models without an LWR part (and in records
    /// saved before it existed).
    #[serde(default = "nan", with = "nullable")]
    pub lwr_vs_prior: f64,
    /// Inputs left out of the LWR by the grouped cross-validation
    /// ([`crate::models::selection`]); empty when none was (or in records
    /// saved before the selection existed).
    #[serde(default)]
    pub dropped: Vec<String>,
    /// The grouped cross-validation error of each step of the input
    /// selection, the chosen inputs' last (empty without a selection).
    #[serde(default, with = "nullable")]
    pub selection_cv: Vec<f64>,
}

fn nan() -> f64 {
    f64::NAN
}

/// One trial on the robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialRecord {
    /// Trial number, from 1.
    pub index: usize,
    /// Imitation or planned.
    pub kind: TrialKind,
    /// Sample period (s).
    pub dt: f64,
    /// True states at every sample of the trial (swing-up window and balancing).
    #[serde(with = "nullable")]
    pub states: Vec<[f64; 4]>,
    /// What the robot's sensors reported (the data it learns from).
    #[serde(with = "nullable")]
    pub observed: Vec<[f64; 4]>,
    /// Commands sent, one per sample.
    #[serde(with = "nullable")]
    pub commands: Vec<f64>,
    /// Sample at which the balancing controller took over, if it did.
    pub caught_at: Option<usize>,
    /// Largest $|\theta|$ reached (rad).
    #[serde(with = "nullable")]
    pub max_angle: f64,
    /// Whether the trial succeeded (balanced upright at the end, hand in its workspace).
    pub success: bool,
    /// Why it failed, in words (empty on success).
    pub failure: String,
    /// The plan executed (planned trials).
    pub plan: Option<PlanSummary>,
    /// The model the plan was made with (planned trials).
    pub model: Option<ModelSummary>,
    /// The plan against what the robot then did (planned trials with a
    /// learned or known model; see [`crate::diagnostics`]). Records saved
    /// before it existed read back without it.
    #[serde(default)]
    pub diagnostics: Option<TrialDiagnostics>,
    /// Where the trial's wall time went. Records saved before it existed
    /// read back with zeros.
    #[serde(default)]
    pub timing: TrialTiming,
    /// What the receding-horizon controller did (trials run with
    /// [`Controller::Mpc`](crate::config::Controller::Mpc)).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mpc: Option<MpcTrace>,
}

/// What the receding-horizon controller did during one trial.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MpcTrace {
    /// Replans made (the trial's first plan not counted).
    pub replans: usize,
    /// Replans whose result was discarded, the previous plan kept (over
    /// the time budget, or a failed solve).
    pub kept_previous: usize,
    /// Gauss-Newton iterations over all replans.
    pub iterations: usize,
    /// Wall time of each replan (ms), in order.
    #[serde(with = "nullable")]
    pub replan_ms: Vec<f64>,
    /// Observed transitions inserted into the model during the trial.
    pub inserted: usize,
}

impl MpcTrace {
    /// The `q`-quantile ($0 \le q \le 1$, nearest rank) of the replan
    /// times (ms); NaN without replans.
    pub fn replan_quantile(&self, q: f64) -> f64 {
        quantile(&self.replan_ms, q)
    }
}

/// The `q`-quantile ($0 \le q \le 1$) of `values` by nearest rank: the
/// smallest value with at least a fraction `q` of the values at or below
/// it (the $\lceil q n \rceil$-th smallest, the smallest for $q = 0$); NaN
/// for no values. The one definition of a quantile of the replan times,
/// for both tasks.
pub fn quantile(values: &[f64], q: f64) -> f64 {
    let mut t = values.to_vec();
    t.sort_by(f64::total_cmp);
    match t.len() {
        0 => f64::NAN,
        n => t[((q.clamp(0.0, 1.0) * n as f64).ceil() as usize).clamp(1, n) - 1],
    }
}

/// The median of `v` (sorted in place; the mean of the middle two for an
/// even count), the one the experiments' tables and the diagnostics
/// report; `None` when it is empty.
pub fn median(v: &mut [f64]) -> Option<f64> {
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

/// Where a trial's wall time went (s).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TrialTiming {
    /// Fitting the model and tuning its metric by cross-validation.
    pub tuning: f64,
    /// Planning (with the data support, gains and diagnostics).
    pub planning: f64,
    /// Running the trial on the (simulated) robot.
    pub rollout: f64,
}

/// The plan against reality, sample by sample over the swing-up window
/// (see [`crate::diagnostics`] for how each is computed). Values a model
/// cannot give (the support of a parametric model) are NaN.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialDiagnostics {
    /// Planned minus observed initial state, $(\theta, \dot\theta, x, \dot x)$.
    #[serde(with = "nullable")]
    pub start_offset: Vec<f64>,
    /// The model's support (effective number of data points, $n_{lwr}$) at
    /// each planned $(s_k, u_k)$.
    #[serde(with = "nullable")]
    pub plan_support: Vec<f64>,
    /// The model's standard error of $\Delta\dot\theta$ at each planned $(s_k, u_k)$.
    #[serde(with = "nullable")]
    pub plan_std_error: Vec<f64>,
    /// The plan's per-step inconsistency with the model, $\lVert s_{k+1} -
    /// f(s_k, u_k) \rVert / \Delta t$ (rate units, as Eq. 3 weighs it).
    #[serde(with = "nullable")]
    pub plan_inconsistency: Vec<f64>,
    /// The model's support at each observed $(s_k, u_k)$ of the trial.
    #[serde(with = "nullable")]
    pub executed_support: Vec<f64>,
    /// The model's standard error at each observed $(s_k, u_k)$.
    #[serde(with = "nullable")]
    pub executed_std_error: Vec<f64>,
    /// The model's $\Delta\dot\theta$ minus the observed one at each observed
    /// $(s_k, u_k)$ (rad/s per sample).
    #[serde(with = "nullable")]
    pub executed_error: Vec<f64>,
    /// $|\theta^{obs}_k - \theta^{plan}_k|$ (rad).
    #[serde(with = "nullable")]
    pub angle_gap: Vec<f64>,
}

/// A whole learning run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The configuration, as TOML text.
    pub config_toml: String,
    /// The demonstration.
    pub demonstration: Demonstration,
    /// Trials in order.
    pub trials: Vec<TrialRecord>,
    /// The first successful trial, if any.
    pub success_trial: Option<usize>,
    /// Seconds of robot data used up to and including the first success (or all trials).
    pub robot_seconds: f64,
}

/// Serde helpers for numbers that may be non-finite (a diverged plan, an
/// undefined error): they are written as `null` (as `serde_json` does anyway)
/// and `null` is read back as NaN, so a record with NaN in it round-trips.
pub(crate) mod nullable {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// A value made of `f64`s with a stand-in in which each may be `null`.
    pub(crate) trait Nullable: Sized {
        /// The stand-in, with `Option<f64>` for each number.
        type Repr: Serialize + for<'de> Deserialize<'de>;
        /// Non-finite numbers become `None`.
        fn to_repr(&self) -> Self::Repr;
        /// `None` becomes NaN.
        fn from_repr(r: Self::Repr) -> Self;
    }

    fn some(x: f64) -> Option<f64> {
        x.is_finite().then_some(x)
    }

    fn value(x: Option<f64>) -> f64 {
        x.unwrap_or(f64::NAN)
    }

    impl Nullable for f64 {
        type Repr = Option<f64>;
        fn to_repr(&self) -> Self::Repr {
            some(*self)
        }
        fn from_repr(r: Self::Repr) -> Self {
            value(r)
        }
    }

    impl Nullable for Vec<f64> {
        type Repr = Vec<Option<f64>>;
        fn to_repr(&self) -> Self::Repr {
            self.iter().copied().map(some).collect()
        }
        fn from_repr(r: Self::Repr) -> Self {
            r.into_iter().map(value).collect()
        }
    }

    impl Nullable for Vec<[f64; 4]> {
        type Repr = Vec<[Option<f64>; 4]>;
        fn to_repr(&self) -> Self::Repr {
            self.iter().map(|s| s.map(some)).collect()
        }
        fn from_repr(r: Self::Repr) -> Self {
            r.into_iter().map(|s| s.map(value)).collect()
        }
    }

    pub(crate) fn serialize<T: Nullable, S: Serializer>(v: &T, s: S) -> Result<S::Ok, S::Error> {
        v.to_repr().serialize(s)
    }

    pub(crate) fn deserialize<'de, T: Nullable, D: Deserializer<'de>>(d: D) -> Result<T, D::Error> {
        T::Repr::deserialize(d).map(T::from_repr)
    }
}

/// Training pairs from the trials: inputs $(\theta, \dot\theta, x, \dot x, u)$
/// observed at $k$, output the observed change of $\dot\theta$.
pub fn training_data(trials: &[TrialRecord]) -> (Vec<[f64; 5]>, Vec<[f64; 1]>) {
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for t in trials {
        for (k, &u) in t.commands.iter().enumerate() {
            let (o, o1) = (t.observed[k], t.observed[k + 1]);
            xs.push([o[0], o[1], o[2], o[3], u]);
            ys.push([o1[1] - o[1]]);
        }
    }
    (xs, ys)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nearest rank: the median of 1..=4 is 2, of 1..=5 is 3; the 99th
    /// percentile of 40 values is the largest, of 200 the 198th; no values
    /// give NaN, the order of the input does not matter.
    #[test]
    fn quantile_is_the_nearest_rank() {
        assert_eq!(quantile(&[4.0, 1.0, 3.0, 2.0], 0.5), 2.0);
        assert_eq!(quantile(&[5.0, 4.0, 1.0, 3.0, 2.0], 0.5), 3.0);
        assert_eq!(quantile(&[5.0, 4.0, 1.0, 3.0, 2.0], 0.0), 1.0);
        let forty: Vec<f64> = (1..=40).rev().map(f64::from).collect();
        assert_eq!(quantile(&forty, 0.99), 40.0);
        let two_hundred: Vec<f64> = (1..=200).map(f64::from).collect();
        assert_eq!(quantile(&two_hundred, 0.99), 198.0);
        assert!(quantile(&[], 0.5).is_nan());
        let trace = MpcTrace {
            replan_ms: vec![3.0, 1.0, 2.0],
            ..MpcTrace::default()
        };
        assert_eq!(trace.replan_quantile(0.5), 2.0);
    }
}
