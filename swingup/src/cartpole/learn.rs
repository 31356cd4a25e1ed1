//! Learning the cart-pole swing-up from scratch: one random trial, then
//! model-predictive control with the LWR model, every transition added to
//! the model at once.
//!
//! A run:
//! 1. **Trial 1, random** (PILCO's `J = 1` initial rollout): forces drawn
//!    uniformly in $[-f_{max}, f_{max}]$, one per control period, held.
//! 2. **Each later trial, MPC**: the model is refitted to all data and its
//!    metric retuned by leave-one-out ([`CartPoleModel::refit`]); then at
//!    every control period the controller replans Eq. 3 over a window of
//!    `window` steps from the measured state with the current model
//!    ([`crate::planning::mpc::replan`], warm-started from the previous plan
//!    shifted by one step, within `replan.max_iterations` Gauss-Newton
//!    iterations, keeping the previous plan when the solve fails) and
//!    applies the plan's first force; the observed transition is inserted
//!    into the model before the next replan, and every `refit_every`
//!    control periods the model is refitted and retuned on all data so far
//!    (the prior learns from the new region at once, not only the
//!    LWR's residuals).
//! 3. The run stops at the first successful trial
//!    ([`succeeded`]) or after `max_trials` MPC trials
//!    (15 by default, PILCO's `N = 15`).
//!
//! The first replan of a trial has no previous plan: it is solved from
//! each of three cold starts (the pole's angle interpolated linearly to
//! upright turning either way, and the measured state held) with a
//! continuation in $\lambda$ from 1, and the one of least criterion is kept.
//!
//! Every trial starts from $s_0 \sim \mathcal N(0, 0.1^2 I)$ (PILCO's `mu0`,
//! `S0`) and lasts `episode` seconds; the data counted are the trials'
//! control periods, random trial included.

use std::time::Instant;

use faer::Mat;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::cartpole::model::{CartPoleModel, CartPoleModelSettings, Transition};
use crate::cartpole::plant::{CartPoleParams, CartPolePlant};
use crate::cartpole::task::{SwingupTask, TaskWeights, pilco_cost, succeeded};
use crate::planning::mpc::{ReplanSettings, ReplanStatus, Window, WindowPlan, replan, shifted};
use crate::record::quantile;

/// Settings of a cart-pole run.
///
/// | name | default | source |
/// |---|---|---|
/// | `plant` | [`CartPoleParams::default`] | PILCO's `dynamics_cp.m`, `settings_cp.m` |
/// | `episode` | 4 s | `settings_cp.m`: `T = 4.0` |
/// | `initial_std` | 0.1 | `settings_cp.m`: `S0 = diag([0.1 0.1 0.1 0.1].^2)` |
/// | `max_trials` | 15 | `settings_cp.m`: `N = 15` controlled trials after the random one |
/// | `success_distance` | 0.1 m | ours (no published criterion) |
/// | `success_hold` | 1 s | ours |
/// | `window` | 15 steps (1.5 s) | ours |
/// | `state_coeffs`, `control_coeffs` | 16, 15 (one per sample: coarser force splines cannot balance at 10 Hz, even with the true model) | ours |
/// | `lambda` | 1e3 | consistency weight, rate units |
/// | `x0_weight` | 1e4 | penalty holding the measured state |
/// | `replan` | 10 iterations, no time budget | per replan |
/// | `cold_iterations` | 30 | per continuation stage of a trial's first replan |
/// | `refit_every` | 10 control periods (1 s) | the model refitted and retuned within a trial |
///
/// `refit_every` 10 against refits between trials only (0), both with the
/// control-affine prior, on seeds 1-80: every seed learned either way, the
/// median seconds of data fell or stayed on each range of 20 and the worst
/// seed's fell; 20 control periods helped less; without the control-affine
/// prior refits within a trial did not help (the figures are in the
/// session's report on issue 35).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CartPoleSettings {
    /// The plant.
    pub plant: CartPoleParams,
    /// Episode length \[s\].
    pub episode: f64,
    /// Standard deviation of each initial state's component.
    pub initial_std: f64,
    /// MPC trials after the random one.
    pub max_trials: usize,
    /// Stop at the first successful trial.
    pub stop_at_success: bool,
    /// Success: the tip within this distance \[m\] of the target ...
    pub success_distance: f64,
    /// ... over the episode's last this many seconds.
    pub success_hold: f64,
    /// The task cost's weights.
    pub weights: TaskWeights,
    /// The learned model's settings.
    pub model: CartPoleModelSettings,
    /// Steps in the planning window.
    pub window: usize,
    /// Cubic B-spline coefficients per state channel in the window.
    pub state_coeffs: usize,
    /// Cubic B-spline coefficients of the force in the window.
    pub control_coeffs: usize,
    /// Eq. 3's consistency weight $\lambda$ (mismatch in rate units).
    pub lambda: f64,
    /// Weight of the penalty holding the measured initial state.
    pub x0_weight: f64,
    /// Gauss-Newton iterations per replan.
    pub replan_iterations: usize,
    /// Relative cost-decrease tolerance of a replan.
    pub tol_cost: f64,
    /// Gauss-Newton iterations per continuation stage of a trial's first
    /// (cold) replan.
    pub cold_iterations: usize,
    /// Plan with the true plant instead of the learned model (a reference
    /// for the planner alone; nothing is learned).
    pub true_model: bool,
    /// Control periods between refits of the model within an MPC trial
    /// ([`CartPoleModel::refit`] with tuning, on all data so far); 0 refits
    /// between trials only (and settings saved before this field existed
    /// read back with 0, as they ran).
    #[serde(default)]
    pub refit_every: usize,
}

impl Default for CartPoleSettings {
    fn default() -> Self {
        Self {
            plant: CartPoleParams::default(),
            episode: 4.0,
            initial_std: 0.1,
            max_trials: 15,
            stop_at_success: true,
            success_distance: 0.1,
            success_hold: 1.0,
            weights: TaskWeights::default(),
            model: CartPoleModelSettings::default(),
            window: 15,
            state_coeffs: 16,
            control_coeffs: 15,
            lambda: 1e3,
            x0_weight: 1e4,
            replan_iterations: 10,
            tol_cost: 1e-6,
            cold_iterations: 30,
            true_model: false,
            refit_every: 10,
        }
    }
}

impl CartPoleSettings {
    /// A tiny cart-pole for tests and smoke runs: 1.5 s episodes, a 0.5 s
    /// hold, one learning trial, an 8-step window with few coefficients
    /// and iterations, and a short metric tuning. Not a benchmark setting.
    pub fn quick() -> Self {
        Self {
            episode: 1.5,
            success_hold: 0.5,
            max_trials: 1,
            window: 8,
            state_coeffs: 8,
            control_coeffs: 6,
            replan_iterations: 2,
            cold_iterations: 3,
            model: CartPoleModelSettings {
                tune_evals: 10,
                ..CartPoleModelSettings::default()
            },
            ..Self::default()
        }
    }

    /// Checks every field.
    pub fn validate(&self) -> crate::Result<()> {
        self.plant.validate()?;
        self.weights.validate()?;
        self.model.lwr.validate(crate::cartpole::model::N_INPUTS)?;
        crate::error::ensure_positive(
            "cartpole.",
            &[
                ("episode", self.episode),
                ("success_distance", self.success_distance),
                ("lambda", self.lambda),
                ("x0_weight", self.x0_weight),
            ],
        )?;
        crate::error::ensure_nonnegative(
            "cartpole.",
            &[
                ("initial_std", self.initial_std),
                ("success_hold", self.success_hold),
                ("tol_cost", self.tol_cost),
            ],
        )?;
        crate::error::ensure_config!(
            "cartpole.episode",
            self.steps() > self.hold_steps(),
            "cartpole.episode ({} s) must be longer than cartpole.success_hold ({} s)",
            self.episode,
            self.success_hold
        );
        crate::error::ensure_config!(
            "cartpole.max_trials",
            (1..=crate::config::limits::MAX_TRIALS).contains(&self.max_trials),
            "cartpole.max_trials must be 1 to {}, got {}",
            crate::config::limits::MAX_TRIALS,
            self.max_trials
        );
        crate::error::ensure_config!(
            "cartpole.episode",
            self.steps() <= crate::config::limits::BALANCE,
            "cartpole.episode ({} s) must be at most {} control periods ({} s)",
            self.episode,
            crate::config::limits::BALANCE,
            crate::config::limits::BALANCE as f64 * self.plant.dt
        );
        crate::error::ensure_config!(
            "cartpole.window",
            self.window <= crate::config::limits::HORIZON,
            "cartpole.window must be at most {} control periods, got {}",
            crate::config::limits::HORIZON,
            self.window
        );
        crate::error::ensure_config!(
            "cartpole.replan_iterations",
            self.replan_iterations >= 1 && self.cold_iterations >= 1,
            "cartpole.replan_iterations and cartpole.cold_iterations must be at least 1"
        );
        Ok(())
    }

    /// [`from_changes`](Self::from_changes) with the JSON object in the
    /// file `path`.
    ///
    /// # Errors
    /// The file cannot be read or is not JSON (naming it), or as
    /// [`from_changes`](Self::from_changes), with the file named.
    pub fn from_changes_file(path: &std::path::Path) -> crate::Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| crate::Error::io("reading", path, e))?;
        let changes: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| crate::Error::parse(path, Some(e.line()), e))?;
        Self::from_changes(&changes).map_err(|e| e.context(path.display().to_string()))
    }

    /// The defaults with the fields of the JSON object `changes` replaced,
    /// nested objects merged field by field (`{"refit_every": 0}`,
    /// `{"model": {"control_affine": false}}`), then checked
    /// ([`validate`](Self::validate)).
    ///
    /// # Errors
    /// `changes` not an object, or a field unknown or of the wrong type (a
    /// configuration error naming its top-level key, `cartpole.<key>`), or
    /// settings that do not validate.
    pub fn from_changes(changes: &serde_json::Value) -> crate::Result<Self> {
        fn merge(base: &mut serde_json::Value, changes: &serde_json::Value) {
            match (base, changes) {
                (serde_json::Value::Object(b), serde_json::Value::Object(c)) => {
                    for (key, value) in c {
                        merge(b.entry(key.clone()).or_insert(serde_json::Value::Null), value);
                    }
                }
                (b, c) => *b = c.clone(),
            }
        }
        let Some(fields) = changes.as_object() else {
            return Err(crate::Error::config(
                "cartpole",
                "the cartpole changes must be a JSON object of settings",
            ));
        };
        let defaults = serde_json::to_value(Self::default())
            .map_err(|e| crate::Error::data(format!("the default cart-pole settings: {e}")))?;
        let with = |changes: &serde_json::Value| -> serde_json::Result<Self> {
            let mut merged = defaults.clone();
            merge(&mut merged, changes);
            serde_json::from_value(merged)
        };
        let settings = with(changes).map_err(|e| {
            // serde_json's value errors name no field: the key that fails alone
            let key = fields.iter().find_map(|(key, value)| {
                let alone = serde_json::Value::Object([(key.clone(), value.clone())].into_iter().collect());
                with(&alone).is_err().then(|| key.clone())
            });
            let key = key.map_or_else(|| "cartpole".to_string(), |k| format!("cartpole.{k}"));
            crate::Error::config(key.clone(), format!("{key}: {e}"))
        })?;
        settings.validate()?;
        Ok(settings)
    }

    /// Control periods per episode.
    pub fn steps(&self) -> usize {
        (self.episode / self.plant.dt).round() as usize
    }

    /// Control periods of the success criterion's hold.
    pub fn hold_steps(&self) -> usize {
        (self.success_hold / self.plant.dt).round() as usize
    }
}

/// What one trial saw. Numbers that are not finite (the random trial's
/// replan times) are written as JSON `null` and read back as NaN.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CartPoleTrial {
    /// 1 for the random trial, then 2, 3, ...
    pub trial: usize,
    /// `random` or `mpc`.
    pub controller: String,
    /// Whether the trial met the success criterion.
    pub success: bool,
    /// PILCO's saturating cost summed over the episode's states (after
    /// each control period).
    #[serde(deserialize_with = "crate::format::null_as_nan")]
    pub pilco_cost: f64,
    /// The tip's distance from the target at the end \[m\].
    #[serde(deserialize_with = "crate::format::null_as_nan")]
    pub final_distance: f64,
    /// Seconds of system data after this trial, all trials so far.
    #[serde(deserialize_with = "crate::format::null_as_nan")]
    pub data_seconds: f64,
    /// Median wall time of a replan \[ms\] ([`quantile`], NaN for the random trial).
    #[serde(deserialize_with = "crate::format::null_as_nan")]
    pub replan_median_ms: f64,
    /// 99th percentile of the replan wall time \[ms\].
    #[serde(deserialize_with = "crate::format::null_as_nan")]
    pub replan_p99_ms: f64,
    /// Mean Gauss-Newton iterations per replan.
    #[serde(deserialize_with = "crate::format::null_as_nan")]
    pub mean_iterations: f64,
    /// Replans whose solve failed (the previous plan kept).
    pub kept_previous: usize,
    /// Wall time of the model's refits and metric tunings, before the
    /// trial and within it (`refit_every`) \[s\]; not part of the replan
    /// times (on a robot they would run beside the controller).
    #[serde(deserialize_with = "crate::format::null_as_nan")]
    pub tune_seconds: f64,
    /// Refits of the model within the trial (`refit_every`).
    #[serde(default)]
    pub refits: usize,
    /// Wall time of each replan \[ms\], in order (empty for the random trial).
    #[serde(deserialize_with = "crate::format::nulls_as_nan")]
    pub replan_ms: Vec<f64>,
    /// The true states, one per control period, the initial one first.
    #[serde(deserialize_with = "crate::format::state_nulls_as_nan")]
    pub states: Vec<[f64; 4]>,
    /// The forces applied (clipped).
    #[serde(deserialize_with = "crate::format::nulls_as_nan")]
    pub forces: Vec<f64>,
}

/// A run: its trials and when it succeeded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CartPoleRun {
    /// The seed of every random draw of the run.
    pub seed: u64,
    /// The settings.
    pub settings: CartPoleSettings,
    /// The trials, the random one first.
    pub trials: Vec<CartPoleTrial>,
    /// The first successful trial (1-based, the random one counted), if any.
    pub success_trial: Option<usize>,
    /// Seconds of system data up to and including that trial.
    pub seconds_to_success: Option<f64>,
}

/// A run's state after its saved trials: the plant, the generator and
/// the noise as the next trial starts with them, and the data so far.
struct Replayed {
    plant: CartPolePlant,
    rng: ChaCha8Rng,
    noise: Option<Normal<f64>>,
    data: Vec<Transition>,
}

/// The state of a run of `settings` and `seed` after the saved trials
/// `previous` ([`replay`] each).
fn replay_all(settings: &CartPoleSettings, seed: u64, previous: &[CartPoleTrial]) -> crate::Result<Replayed> {
    settings.validate()?;
    let plant = CartPolePlant::new(settings.plant.clone())?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = if settings.plant.sensor_noise > 0.0 {
        Some(Normal::new(0.0, settings.plant.sensor_noise).map_err(|e| crate::Error::data(format!("noise: {e}")))?)
    } else {
        None
    };
    crate::error::ensure_data!(
        previous.len() <= settings.max_trials + 1,
        "{} saved trials, more than the run's {} (one random, then max_trials)",
        previous.len(),
        settings.max_trials + 1
    );
    let mut data = Vec::new();
    for (k, saved) in previous.iter().enumerate() {
        replay(saved, k + 1, settings, &plant, &mut rng, &noise, &mut data)?;
    }
    Ok(Replayed {
        plant,
        rng,
        noise,
        data,
    })
}

/// Checks that `previous` are the first trials of a run of `settings` and
/// `seed`, as [`run_resumable`] does before it goes on (their draws and
/// states replayed), without running any new trial; returns the number of
/// transitions they hold.
///
/// # Errors
/// Invalid settings, or a trial that does not replay (named).
pub fn replay_trials(settings: &CartPoleSettings, seed: u64, previous: &[CartPoleTrial]) -> crate::Result<usize> {
    Ok(replay_all(settings, seed, previous)?.data.len())
}

/// Replays the saved trial `saved` (number `number`): draws what the run
/// drew for it from `rng` and steps its states through the plant from its
/// saved forces, appending its transitions to `data`; refuses a trial
/// whose draws or states differ from the saved ones.
fn replay(
    saved: &CartPoleTrial,
    number: usize,
    settings: &CartPoleSettings,
    plant: &CartPolePlant,
    rng: &mut ChaCha8Rng,
    noise: &Option<Normal<f64>>,
    data: &mut Vec<Transition>,
) -> crate::Result<()> {
    let random = number == 1;
    let differs = |what: String| {
        crate::Error::data(format!(
            "saved trial {number} does not replay: {what}; it was made with another seed or other settings, \
             or edited (start a fresh run with --force)"
        ))
    };
    if saved.trial != number || saved.forces.len() != settings.steps() || saved.states.len() != settings.steps() + 1 {
        return Err(differs(format!(
            "it is trial {} with {} forces and {} states, not trial {number} with {} and {}",
            saved.trial,
            saved.forces.len(),
            saved.states.len(),
            settings.steps(),
            settings.steps() + 1
        )));
    }
    let mut s = initial_state(rng, settings.initial_std)?;
    if s != saved.states[0] {
        return Err(differs("its initial state".into()));
    }
    let mut measured = measure(rng, noise, &s);
    let max_force = settings.plant.max_force;
    for (k, &f) in saved.forces.iter().enumerate() {
        if random {
            let u = rng.random_range(-max_force..=max_force);
            if plant.clip(u) != f {
                return Err(differs(format!("its random force {}", k + 1)));
            }
        }
        s = plant.step(&s, f);
        if s != saved.states[k + 1] {
            return Err(differs(format!("its state {}", k + 1)));
        }
        let next = measure(rng, noise, &s);
        data.push(Transition {
            state: measured,
            force: f,
            next,
        });
        measured = next;
    }
    Ok(())
}

/// The initial state of a trial, $\mathcal N(0, \sigma^2 I)$.
fn initial_state(rng: &mut ChaCha8Rng, std: f64) -> crate::Result<[f64; 4]> {
    let normal = Normal::new(0.0, std).map_err(|e| crate::Error::data(format!("initial state: {e}")))?;
    Ok(std::array::from_fn(|_| normal.sample(rng)))
}

fn measure(rng: &mut ChaCha8Rng, noise: &Option<Normal<f64>>, s: &[f64; 4]) -> [f64; 4] {
    match noise {
        Some(n) => std::array::from_fn(|i| s[i] + n.sample(rng)),
        None => *s,
    }
}

/// A cold start for the window from `x0`: the angle interpolated linearly
/// to the nearest upright in direction `direction` (+1, -1), or with
/// `direction` 0 the state held; cart at rest, no force.
fn cold_start(x0: &[f64; 4], samples: usize, direction: i32, dt: f64) -> WindowPlan {
    use std::f64::consts::PI;
    let th0 = x0[3];
    // uprights are pi + 2 pi k; the nearest one strictly above (below) th0
    let target = match direction {
        0 => th0,
        d if d > 0 => PI + 2.0 * PI * ((th0 - PI) / (2.0 * PI)).floor() + 2.0 * PI,
        _ => PI + 2.0 * PI * ((th0 - PI) / (2.0 * PI)).ceil() - 2.0 * PI,
    };
    let target = if direction > 0 && target - th0 > 2.0 * PI {
        target - 2.0 * PI
    } else if direction < 0 && th0 - target > 2.0 * PI {
        target + 2.0 * PI
    } else {
        target
    };
    let rate = (target - th0) / (samples as f64 * dt);
    WindowPlan {
        states: Mat::from_fn(samples + 1, 4, |k, i| match i {
            3 => th0 + (target - th0) * k as f64 / samples as f64,
            2 if direction != 0 => rate,
            _ if k == 0 => x0[i],
            _ => 0.0,
        }),
        controls: Mat::zeros(samples, 1),
    }
}

/// The controller's state within one trial.
struct Mpc<'a> {
    settings: &'a CartPoleSettings,
    window: Window,
    task: SwingupTask,
    plan: Option<WindowPlan>,
}

impl Mpc<'_> {
    /// Replans from the measured state `x0` with `model`; returns the force
    /// to apply, the wall time, the iterations and whether the previous
    /// plan was kept.
    fn step<M: trajopt::Dynamics>(&mut self, model: &M, x0: &[f64; 4]) -> crate::Result<(f64, f64, usize, bool)> {
        let s = self.settings;
        let started = Instant::now();
        let (plan, iterations, kept) = match self.plan.take() {
            Some(previous) => {
                let problem = self
                    .window
                    .problem(model, self.task.clone(), s.lambda, x0, s.x0_weight)?;
                let warm = shifted(&previous, 1);
                let r = replan(
                    &self.window,
                    &problem,
                    &warm,
                    x0,
                    &ReplanSettings {
                        max_iterations: s.replan_iterations,
                        tol_cost: s.tol_cost,
                        budget: None,
                    },
                )?;
                let kept = matches!(r.status, ReplanStatus::KeptPrevious(_));
                (r.plan, r.iterations, kept)
            }
            None => {
                let (plan, iterations) = self.cold(model, x0)?;
                (plan, iterations, false)
            }
        };
        let force = plan.controls[(0, 0)];
        self.plan = Some(plan);
        Ok((force, started.elapsed().as_secs_f64(), iterations, kept))
    }

    /// The first replan of a trial: three cold starts, a continuation in
    /// lambda from 1 for each, the least criterion kept.
    fn cold<M: trajopt::Dynamics>(&self, model: &M, x0: &[f64; 4]) -> crate::Result<(WindowPlan, usize)> {
        let s = self.settings;
        let mut best: Option<(f64, WindowPlan)> = None;
        let mut iterations = 0;
        for direction in [1, -1, 0] {
            let mut plan = cold_start(x0, s.window, direction, s.plant.dt);
            let mut lambda = 1.0f64.min(s.lambda);
            let cost = loop {
                let problem = self.window.problem(model, self.task.clone(), lambda, x0, s.x0_weight)?;
                let r = replan(
                    &self.window,
                    &problem,
                    &plan,
                    x0,
                    &ReplanSettings {
                        max_iterations: s.cold_iterations,
                        tol_cost: s.tol_cost,
                        budget: None,
                    },
                )?;
                iterations += r.iterations;
                plan = r.plan;
                if lambda >= s.lambda {
                    break r.costs.1;
                }
                lambda = (lambda * 10.0).min(s.lambda);
            };
            if cost.is_finite() && best.as_ref().is_none_or(|(c, _)| cost < *c) {
                best = Some((cost, plan));
            }
        }
        let plan = best.map_or_else(|| cold_start(x0, s.window, 0, s.plant.dt), |(_, p)| p);
        Ok((plan, iterations))
    }
}

/// Runs the learning loop of the [module docs](self) with `settings`, every
/// random draw from `seed`.
///
/// # Errors
/// Invalid settings, or a model or planner failure.
pub fn run(settings: &CartPoleSettings, seed: u64) -> crate::Result<CartPoleRun> {
    run_resumable(settings, seed, Vec::new(), &mut |_| Ok(()))
}

/// [`run`], continued after the trials `previous` (the first
/// `previous.len()` trials of a run of the same settings and seed, as
/// saved by an interrupted run), calling `on_trial` with each new trial as
/// it ends (to save it before the next one starts).
///
/// The saved trials are replayed, not rerun: their initial states, random
/// forces and sensor noise are drawn again from `seed` and their states
/// stepped again through the plant from the saved forces, which rebuilds
/// the data and the random generator exactly (the model is refitted from
/// the data alone at each trial's start), so the run goes on as the
/// uninterrupted one would have and ends with the same trials.
///
/// # Errors
/// A saved trial that does not replay (another seed or settings, an edited
/// file: the error names the trial and what differs), or as [`run`].
pub fn run_resumable(
    settings: &CartPoleSettings,
    seed: u64,
    previous: Vec<CartPoleTrial>,
    on_trial: &mut dyn FnMut(&CartPoleTrial) -> crate::Result<()>,
) -> crate::Result<CartPoleRun> {
    let Replayed {
        plant,
        mut rng,
        noise,
        mut data,
    } = replay_all(settings, seed, &previous)?;
    let steps = settings.steps();
    let dt = settings.plant.dt;
    let max_force = settings.plant.max_force;
    let mut trials = Vec::new();
    let mut model: Option<CartPoleModel> = None;
    let task = SwingupTask::new(settings.plant.pole_length, max_force, &settings.weights)?;
    let window = Window::new(settings.window, dt, settings.state_coeffs, settings.control_coeffs)?;
    let replayed = previous.len();
    trials.extend(previous);
    let finished = trials.last().is_some_and(|t| t.success) && settings.stop_at_success;
    let first_new = if finished {
        settings.max_trials + 2
    } else {
        replayed + 1
    };
    for trial in first_new..=settings.max_trials + 1 {
        let random = trial == 1;
        let mut tune_seconds = 0.0;
        if !random {
            let started = Instant::now();
            match model.as_mut() {
                Some(m) => m.refit(true)?,
                None => model = Some(CartPoleModel::fit(&data, settings.model.clone(), true)?),
            }
            tune_seconds = started.elapsed().as_secs_f64();
        }
        let mut mpc = Mpc {
            settings,
            window: window.clone(),
            task: task.clone(),
            plan: None,
        };
        let mut s = initial_state(&mut rng, settings.initial_std)?;
        let mut measured = measure(&mut rng, &noise, &s);
        let mut states = vec![s];
        let mut forces = Vec::with_capacity(steps);
        let (mut times, mut iterations, mut kept, mut refits) = (Vec::new(), 0usize, 0usize, 0usize);
        for _ in 0..steps {
            let planned = match (random, model.as_ref()) {
                (true, _) => None,
                (false, _) if settings.true_model => Some(mpc.step(&plant, &measured)?),
                (false, Some(m)) => Some(mpc.step(m, &measured)?),
                (false, None) => None,
            };
            let u = match planned {
                Some((u, seconds, iters, was_kept)) => {
                    times.push(seconds * 1e3);
                    iterations += iters;
                    kept += usize::from(was_kept);
                    u
                }
                None => rng.random_range(-max_force..=max_force),
            };
            let f = plant.clip(u);
            s = plant.step(&s, f);
            let next = measure(&mut rng, &noise, &s);
            let t = Transition {
                state: measured,
                force: f,
                next,
            };
            data.push(t);
            if let Some(m) = model.as_mut() {
                m.insert(t)?;
                let done = forces.len() + 1;
                if !random && settings.refit_every > 0 && done % settings.refit_every == 0 && done < steps {
                    let started = Instant::now();
                    m.refit(true)?;
                    tune_seconds += started.elapsed().as_secs_f64();
                    refits += 1;
                }
            }
            measured = next;
            states.push(s);
            forces.push(f);
        }
        let success = succeeded(&plant, &states, settings.success_distance, settings.hold_steps());
        let record = CartPoleTrial {
            trial,
            controller: if random { "random" } else { "mpc" }.into(),
            success,
            pilco_cost: states[1..].iter().map(|x| pilco_cost(&plant, x)).sum(),
            final_distance: plant.tip_distance(&s),
            data_seconds: data.len() as f64 * dt,
            replan_median_ms: quantile(&times, 0.5),
            replan_p99_ms: quantile(&times, 0.99),
            mean_iterations: if times.is_empty() {
                f64::NAN
            } else {
                iterations as f64 / times.len() as f64
            },
            kept_previous: kept,
            tune_seconds,
            refits,
            replan_ms: times,
            states,
            forces,
        };
        on_trial(&record)?;
        trials.push(record);
        if success && settings.stop_at_success {
            break;
        }
    }
    let first = trials.iter().find(|t| t.success);
    Ok(CartPoleRun {
        seed,
        settings: settings.clone(),
        success_trial: first.map(|t| t.trial),
        seconds_to_success: first.map(|t| t.data_seconds),
        trials,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Changes replace the named fields only, nested ones field by field;
    /// unknown or ill-typed fields and non-objects are refused by key.
    #[test]
    fn settings_from_changes() {
        let s = CartPoleSettings::from_changes(&serde_json::json!({
            "refit_every": 0,
            "model": {"control_affine": false}
        }))
        .expect("valid changes");
        let d = CartPoleSettings::default();
        assert_eq!((s.refit_every, s.model.control_affine), (0, false));
        assert_eq!(
            (s.model.tune_evals, s.window, &s.plant),
            (d.model.tune_evals, d.window, &d.plant)
        );
        assert_eq!(CartPoleSettings::from_changes(&serde_json::json!({})).expect("none"), d);
        for (changes, key) in [
            (
                serde_json::json!({"window": 12, "refit_evry": 0}),
                "cartpole.refit_evry",
            ),
            (serde_json::json!({"model": {"tune_evals": "x"}}), "cartpole.model"),
            (serde_json::json!([1, 2]), "cartpole"),
        ] {
            let e = CartPoleSettings::from_changes(&changes).expect_err("refused");
            assert!(e.to_string().contains(key), "{e} should name {key}");
        }
        let e = CartPoleSettings::from_changes(&serde_json::json!({"episode": -1.0})).expect_err("invalid");
        assert!(e.to_string().contains("cartpole.episode"), "{e}");
    }

    /// The cold starts turn towards upright either way, or hold.
    #[test]
    fn cold_starts_reach_upright() {
        use std::f64::consts::PI;
        for th0 in [0.05, -0.05, 3.0, -7.0] {
            let x0 = [0.0, 0.0, 0.0, th0];
            let up = cold_start(&x0, 10, 1, 0.1);
            let down = cold_start(&x0, 10, -1, 0.1);
            let (a, b) = (up.states[(10, 3)], down.states[(10, 3)]);
            assert!(a > th0 && a - th0 <= 2.0 * PI + 1e-12 && ((a - PI) / (2.0 * PI)).fract().abs() < 1e-9);
            assert!(b < th0 && th0 - b <= 2.0 * PI + 1e-12 && ((b - PI) / (2.0 * PI)).fract().abs() < 1e-9);
            assert_eq!(cold_start(&x0, 10, 0, 0.1).states[(10, 3)], th0);
        }
    }

    /// A tiny run goes end to end: a random trial, then MPC trials with the
    /// learned model, data counted trial by trial.
    #[test]
    fn tiny_run_goes_end_to_end() {
        let settings = CartPoleSettings {
            max_trials: 2,
            stop_at_success: false,
            ..CartPoleSettings::quick()
        };
        let r = run(&settings, 7).expect("run");
        assert_eq!(r.trials.len(), 3);
        assert_eq!(r.trials[0].controller, "random");
        assert!(
            r.trials[1..]
                .iter()
                .all(|t| t.controller == "mpc" && t.replan_median_ms.is_finite())
        );
        for (j, t) in r.trials.iter().enumerate() {
            assert!((t.data_seconds - 1.5 * (j + 1) as f64).abs() < 1e-9);
            assert_eq!(t.states.len(), 16);
            assert!(t.forces.iter().all(|f| f.abs() <= 10.0));
        }
        // the same seed, the same run
        assert_eq!(run(&settings, 7).expect("run").trials[2].forces, r.trials[2].forces);
    }

    /// A run resumed after any number of saved trials (read back from
    /// JSON, as from an interrupted run's files) ends with the trials of the
    /// uninterrupted run (wall times aside); a saved trial of another seed
    /// or an edited one is refused, naming the trial.
    #[test]
    fn a_resumed_run_ends_as_the_uninterrupted_one() {
        let settings = CartPoleSettings {
            max_trials: 2,
            stop_at_success: false,
            refit_every: 5,
            ..CartPoleSettings::quick()
        };
        let whole = run(&settings, 11).expect("run");
        let key = |t: &CartPoleTrial| (t.trial, t.success, t.states.clone(), t.forces.clone(), t.refits);
        for k in 0..=whole.trials.len() {
            let saved: Vec<CartPoleTrial> = whole.trials[..k]
                .iter()
                .map(|t| serde_json::from_str(&serde_json::to_string(t).expect("json")).expect("parse"))
                .collect();
            let mut new = Vec::new();
            let resumed = run_resumable(&settings, 11, saved, &mut |t| {
                new.push(t.trial);
                Ok(())
            })
            .expect("resumed");
            assert_eq!(
                resumed.trials.iter().map(key).collect::<Vec<_>>(),
                whole.trials.iter().map(key).collect::<Vec<_>>(),
                "resumed after {k} trials"
            );
            assert_eq!(new, (k + 1..=whole.trials.len()).collect::<Vec<_>>());
        }
        let e = run_resumable(&settings, 12, whole.trials[..1].to_vec(), &mut |_| Ok(())).expect_err("other seed");
        assert!(e.to_string().contains("saved trial 1 does not replay"), "{e}");
        let mut edited = whole.trials[..2].to_vec();
        edited[1].forces[3] += 1e-9;
        let e = run_resumable(&settings, 11, edited, &mut |_| Ok(())).expect_err("edited");
        assert!(
            e.to_string().contains("saved trial 2 does not replay: its state 4"),
            "{e}"
        );
    }

    /// Within an MPC trial the model is refitted every `refit_every`
    /// control periods (not after the last one, which the next trial's
    /// refit follows), never in the random trial, and not at all with 0.
    #[test]
    fn mpc_trials_refit_the_model_on_schedule() {
        let settings = CartPoleSettings {
            max_trials: 1,
            stop_at_success: false,
            refit_every: 5,
            ..CartPoleSettings::quick()
        };
        // 15 control periods: refits after the 5th and the 10th
        let r = run(&settings, 3).expect("run");
        assert_eq!(r.trials.iter().map(|t| t.refits).collect::<Vec<_>>(), [0, 2]);
        let never = run(
            &CartPoleSettings {
                refit_every: 0,
                ..settings.clone()
            },
            3,
        )
        .expect("run");
        assert_eq!(never.trials[1].refits, 0);
        // the same data before the first refit, different forces after it
        assert_eq!(never.trials[1].forces[..5], r.trials[1].forces[..5]);
        assert_ne!(never.trials[1].forces, r.trials[1].forces);
    }

    /// Bad settings are refused.
    #[test]
    fn validate_refuses_bad_settings() {
        let bad = [
            CartPoleSettings {
                episode: 0.5,
                success_hold: 1.0,
                ..CartPoleSettings::default()
            },
            CartPoleSettings {
                lambda: 0.0,
                ..CartPoleSettings::default()
            },
            CartPoleSettings {
                replan_iterations: 0,
                ..CartPoleSettings::default()
            },
        ];
        for s in bad {
            assert!(run(&s, 1).is_err());
        }
    }
}
