//! The ranges of a configuration's keys and the size of the run it asks
//! for ([`Config::validate`], [`Config::workload`], [`limits`]).

use crate::error::ensure_config;

use super::{Config, Controller, LwrPrior, ModelKind};

/// Bytes in a GiB.
const GIB: f64 = (1u64 << 30) as f64;

/// The largest run a configuration may ask for ([`Config::validate`]):
/// sizes beyond these would not fit in memory or would not finish in a
/// day, and are refused before any work, with the estimate
/// ([`Config::workload`]). The defaults are far inside every one.
pub mod limits {
    /// Samples of the swing-up window (`horizon`, `mpc.window`), 167 s at 60 Hz.
    pub const HORIZON: usize = 10_000;
    /// Samples of balancing after the window (`balance`).
    pub const BALANCE: usize = 100_000;
    /// Trials of a run (`max_trials`).
    pub const MAX_TRIALS: usize = 1_000;
    /// Memory a run's data may take: its samples, each held by the trial
    /// records, the model's data and its k-d tree.
    pub const BYTES: f64 = 4.0 * super::GIB;
    /// The estimate of [`BYTES`]' bytes per sample (an upper bound for the
    /// LWR with all five inputs and the trial records).
    pub const BYTES_PER_SAMPLE: f64 = 1024.0;
    /// RK4 steps of the plants over a run (a minute or more of simulation
    /// alone, before any learning or planning).
    pub const PLANT_STEPS: f64 = 1e9;
    /// Samples linearised by the MPC's replans over a run (each one a
    /// model query with its Jacobian, microseconds to tens of them).
    pub const REPLAN_SAMPLES: f64 = 1e9;
    pub use crate::format::MAX_MAGNITUDE;
    /// Point pairs of the model's leave-one-out passes over a run
    /// ([`Workload::loo_pairs`](super::Workload::loo_pairs)) past which
    /// `learn` warns at its start: at the $10^7$ to $10^8$ pairs a second
    /// of a local linear fit, an hour or more.
    pub const LOO_PAIRS: f64 = 1e11;
    /// The longest MPC time budget per replan (`mpc.budget_ms`): a year,
    /// in milliseconds, far inside what a `Duration` holds.
    pub const MAX_BUDGET_MS: f64 = 365.0 * 24.0 * 3600.0 * 1e3;
}

/// The size of a run ([`Config::workload`]), all trials run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workload {
    /// Samples the robot records (the learned model's data at the end).
    pub data_points: f64,
    /// Memory of those samples, estimated at [`limits::BYTES_PER_SAMPLE`].
    pub bytes: f64,
    /// RK4 steps of the plants (the demonstration and every trial).
    pub plant_steps: f64,
    /// Samples linearised by model-predictive replanning (0 open loop).
    pub replan_samples: f64,
    /// An upper bound of the point pairs the model's leave-one-out passes
    /// visit over the run (every point's neighbourhood taken as all the
    /// data): after trial $t$ with $n_t$ points, `model.tune_evals`
    /// evaluations over $\min(p, n_t)$ points ($p$ = `model.tune_points`,
    /// 0: all) and two passes over all of them, each point against all
    /// $n_t$; 0 for models without leave-one-out.
    pub loo_pairs: f64,
}

impl Config {
    /// What a run of this configuration holds and computes at most (all
    /// `max_trials` trials run), the sizes [`validate`](Self::validate)
    /// bounds by [`limits`].
    pub fn workload(&self) -> Workload {
        // in floating point: no overflow, whatever the sizes
        let samples = self.horizon as f64 + self.balance as f64;
        let trials = self.max_trials as f64;
        let replans = match self.controller {
            Controller::OpenLoop => 0.0,
            Controller::Mpc => {
                trials * samples / self.mpc.every.max(1) as f64 * self.mpc.window as f64 * self.mpc.iterations as f64
            }
        };
        let m = &self.model;
        let loo_pairs = if matches!(m.kind, ModelKind::Lwr | ModelKind::LwrParametric) {
            (1..=self.max_trials)
                .map(|t| {
                    let n = samples * t as f64;
                    let points = if m.tune_points == 0 {
                        n
                    } else {
                        n.min(m.tune_points as f64)
                    };
                    (m.tune_evals as f64 * points + 2.0 * n) * n
                })
                .sum()
        } else {
            0.0
        };
        Workload {
            loo_pairs,
            data_points: samples * trials,
            bytes: samples * trials * limits::BYTES_PER_SAMPLE,
            plant_steps: samples * (trials * self.robot.substeps as f64 + self.human.substeps as f64),
            replan_samples: replans,
        }
    }

    /// Checks every key against its documented range, and the run's size
    /// against [`limits`] (refused with the estimate, [`Config::workload`]).
    ///
    /// # Errors
    /// [`Error::Config`](crate::Error::Config) naming the first key out of
    /// its range, with its value.
    pub fn validate(&self) -> crate::Result<()> {
        for (key, plant) in [("human", &self.human), ("robot", &self.robot)] {
            plant
                .validate()
                .map_err(|e| crate::Error::config(key, format!("{key}.{e}")))?;
        }
        ensure_config!(
            "max_trials",
            (1..=limits::MAX_TRIALS).contains(&self.max_trials),
            "max_trials must be 1 to {}, got {}",
            limits::MAX_TRIALS,
            self.max_trials
        );
        let h = &self.human_swingup;
        for (key, v) in [
            ("human_swingup.energy_gain", h.energy_gain),
            ("human_swingup.centring", h.centring[0]),
            ("human_swingup.centring", h.centring[1]),
            ("human_swingup.smoothing", h.smoothing),
            ("human_swingup.push", h.push.abs()),
            ("human_swingup.max_command", h.max_command),
        ] {
            ensure_config!(
                key,
                (0.0..=1e4).contains(&v),
                "{key} must be in [0, 1e4] (push: in absolute value), got {v}"
            );
        }
        for (key, v) in [("catch_angle", self.catch_angle), ("success_angle", self.success_angle)] {
            ensure_config!(
                key,
                v < std::f64::consts::FRAC_PI_2,
                "{key} must be below pi/2 ({:.4} rad): a pendulum within it of upright is above the \
                 horizontal, got {v}",
                std::f64::consts::FRAC_PI_2
            );
        }
        if let Some(level) = self.catch_level {
            ensure_config!(
                "catch_level",
                level.is_finite() && level > 0.0,
                "catch_level must be finite and > 0, got {level}"
            );
        }
        ensure_config!(
            "sensor_noise",
            self.sensor_noise.iter().all(|x| *x <= 1.0),
            "sensor_noise must be at most 1 (rad, rad/s, m, m/s) per component, got {:?}",
            self.sensor_noise
        );
        for (key, v, max) in [
            ("horizon", self.horizon, limits::HORIZON),
            ("balance", self.balance, limits::BALANCE),
            ("mpc.window", self.mpc.window, limits::HORIZON),
            (
                "human_swingup.push_samples",
                self.human_swingup.push_samples,
                limits::HORIZON,
            ),
        ] {
            ensure_config!(key, v <= max, "{key} must be at most {max} samples, got {v}");
        }
        let w = self.workload();
        ensure_config!(
            "balance",
            w.bytes <= limits::BYTES,
            "horizon + balance = {} samples per trial over max_trials = {} trials is {:.3e} data points, \
             about {:.1} GiB of model data at {} bytes each; the limit is {:.0} GiB",
            self.horizon + self.balance,
            self.max_trials,
            w.data_points,
            w.bytes / GIB,
            limits::BYTES_PER_SAMPLE,
            limits::BYTES / GIB
        );
        ensure_config!(
            "robot.substeps",
            w.plant_steps <= limits::PLANT_STEPS,
            "horizon + balance = {} samples x (max_trials = {} x robot.substeps = {} + human.substeps = {}) \
             is {:.3e} RK4 steps of the plants; the limit is {:.0e}",
            self.horizon + self.balance,
            self.max_trials,
            self.robot.substeps,
            self.human.substeps,
            w.plant_steps,
            limits::PLANT_STEPS
        );
        ensure_config!(
            "mpc.window",
            w.replan_samples <= limits::REPLAN_SAMPLES,
            "max_trials = {} x (horizon + balance) / mpc.every = {:.0} replans x mpc.window = {} x \
             mpc.iterations = {} is {:.3e} linearised samples; the limit is {:.0e}",
            self.max_trials,
            (self.horizon + self.balance) as f64 / self.mpc.every.max(1) as f64,
            self.mpc.window,
            self.mpc.iterations,
            w.replan_samples,
            limits::REPLAN_SAMPLES
        );
        ensure_config!(
            "model.cv_blocks",
            !self.model.select_inputs || self.model.cv_blocks >= 2,
            "model.cv_blocks must be at least 2 when model.select_inputs is on"
        );
        ensure_config!(
            "model.prior",
            self.model.prior == LwrPrior::Linear || self.model.kind == ModelKind::Lwr,
            "model.prior = {:?} applies to the pure LWR (model.kind = lwr) only; model.kind is {:?}, \
             whose prior is fixed",
            self.model.prior,
            self.model.kind
        );
        ensure_config!("horizon", self.horizon >= 10, "horizon must be at least 10 samples");
        let p = &self.planner;
        ensure_config!(
            "horizon",
            self.horizon >= p.control_coeffs && self.horizon + 1 >= p.state_coeffs,
            "horizon ({}) must be at least planner.control_coeffs ({}) and planner.state_coeffs - 1 ({}): \
             the plan's B-splines are fitted to the horizon's samples",
            self.horizon,
            p.control_coeffs,
            p.state_coeffs.saturating_sub(1)
        );
        // every scalar setting that must be finite and positive, or nonnegative, by its key
        let positive = [
            ("catch_angle", self.catch_angle),
            ("catch_rate", self.catch_rate),
            ("success_angle", self.success_angle),
            ("success_seconds", self.success_seconds),
            ("planner.confidence_full", p.confidence_full),
            ("planner.tol_cost", p.tol_cost),
            ("planner.u_max", p.u_max),
            ("planner.x_max", p.x_max),
            ("model.cutoff", self.model.cutoff),
            ("model.bandwidth", self.model.bandwidth),
            ("planner.support_bandwidth", p.support_bandwidth),
            ("planner.support_full", p.support_full),
        ];
        crate::error::ensure_positive("", &positive)?;
        let nonnegative = [
            ("planner.lambda_start", p.lambda_start),
            ("planner.confidence_floor", p.confidence_floor),
            ("planner.control_weight", p.control_weight),
            ("planner.initial_state_weight", p.initial_state_weight),
            ("planner.bound_weight", p.bound_weight),
            ("model.ridge", self.model.ridge),
            ("model.slope_ridge", self.model.slope_ridge),
            ("model.prior_weight", self.model.prior_weight),
            ("planner.lambda", p.lambda),
            ("planner.support_weight", p.support_weight),
            ("exploration", self.exploration),
        ];
        crate::error::ensure_nonnegative("", &nonnegative)?;
        let arrays: [(&str, &[f64]); 5] = [
            ("sensor_noise", &self.sensor_noise),
            ("feedback", &self.feedback),
            ("hand_servo", &self.hand_servo),
            ("planner.state_weights", &p.state_weights),
            ("planner.terminal_weights", &p.terminal_weights),
        ];
        for (key, v) in arrays {
            ensure_config!(
                key,
                v.iter().all(|x| (0.0..=limits::MAX_MAGNITUDE).contains(x)),
                "{key} must be nonnegative and at most {:e}, got {v:?}",
                limits::MAX_MAGNITUDE
            );
        }
        ensure_config!(
            "planner.max_iters",
            p.max_iters >= 1 && p.powell_evals >= 1,
            "planner.max_iters and planner.powell_evals must be at least 1, got {} and {}",
            p.max_iters,
            p.powell_evals
        );
        ensure_config!(
            "balance",
            self.balance as f64 * self.robot.dt >= self.success_seconds,
            "balance ({} samples, {} s) must cover success_seconds ({} s): success is judged on the balancing",
            self.balance,
            self.balance as f64 * self.robot.dt,
            self.success_seconds
        );
        ensure_config!(
            "planner.lambda_growth",
            self.planner.lambda_growth.is_finite()
                && self.planner.lambda_growth > 0.0
                && self.planner.lambda * self.planner.lambda_growth.powi(self.max_trials as i32)
                    <= limits::MAX_MAGNITUDE,
            "planner.lambda_growth must be positive and keep lambda at most {:e} over max_trials",
            limits::MAX_MAGNITUDE
        );
        ensure_config!(
            "planner.state_coeffs",
            self.planner.state_coeffs >= 4 && self.planner.control_coeffs >= 4,
            "need at least 4 B-spline coefficients per channel"
        );
        let m = &self.mpc;
        ensure_config!(
            "mpc.window",
            m.control_coeffs >= 4
                && m.state_coeffs >= 4
                && m.window >= m.control_coeffs
                && m.window + 1 >= m.state_coeffs,
            "mpc.window ({}) must be at least mpc.control_coeffs ({}) and mpc.state_coeffs - 1 ({}), \
             and each at least 4",
            m.window,
            m.control_coeffs,
            m.state_coeffs.saturating_sub(1)
        );
        ensure_config!(
            "mpc.every",
            m.every >= 1 && m.iterations >= 1,
            "mpc.every and mpc.iterations must be at least 1, got {} and {}",
            m.every,
            m.iterations
        );
        ensure_config!(
            "mpc.budget_ms",
            m.budget_ms >= 0.0 && m.budget_ms <= limits::MAX_BUDGET_MS,
            "mpc.budget_ms must be from 0 to a year ({:e} ms), got {}",
            limits::MAX_BUDGET_MS,
            m.budget_ms
        );
        // metric scales: nonnegative, and at least one input in the distance
        for (key, v) in [
            ("model.input_scales", &self.model.input_scales),
            ("planner.support_scales", &p.support_scales),
        ] {
            ensure_config!(
                key,
                v.iter().all(|m| m.is_finite() && *m >= 0.0) && v.iter().any(|m| *m > 0.0),
                "{key} must be finite and nonnegative, and not all 0, got {v:?}"
            );
        }
        Ok(())
    }
}
