//! The learning loop: imitate, then learn a model and plan with Eq. 3
//! until the robot swings the pendulum up and balances it.
//!
//! 1. Trial 1 replays the demonstration's commands on the robot.
//! 2. After each trial, what the robot observed (noisy) joins the LWR
//!    database; its bandwidth and per-input metric are tuned by
//!    leave-one-out cross-validation.
//! 3. The planner minimises the paper's Eq. 3 with the Eq. 5 task cost,
//!    $\sum_k (s_k - s^d_k)^\top Q (s_k - s^d_k) + r (u_k - u^d_k)^2$, a terminal
//!    weight on reaching upright at rest, and the consistency term
//!    $\lambda \sum_k \lVert (s_{k+1} - f(s_k, u_k)) / \Delta t \rVert^2$ (the
//!    mismatch in rate units), over cubic B-spline coefficients initialised
//!    by fitting the demonstration (Eqs. 6-7). We penalise $u - u^d$ rather
//!    than the paper's $u^\top R u$, so that $\lambda = 0$ plans the
//!    demonstration itself.
//! 4. The robot executes the planned commands open loop; the LQR takes over
//!    when the pendulum comes near upright.
//! 5. Success: within `success_angle` of upright over the last
//!    `success_seconds`, the hand inside its workspace throughout.

use faer::Mat;
use lwr::{Kernel, LwrModel, LwrSettings, TuneSettings};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use splines::{BSplineBasis, FitSettings};
use trajopt::{Eq3Problem, GaussNewton, GaussNewtonSettings, Lambda, TrackingCost};

use crate::demo::{Demonstration, HumanSwingup, demonstrate, near_upright};
use crate::lqr::Lqr;
use crate::model::{INPUTS, LearnedModel};
use crate::plant::{Plant, PlantParams, PlantState, from_upright};
use crate::record::{ModelSummary, PlanSummary, RunRecord, TrialKind, TrialRecord};

/// Everything a learning run depends on. `swingup config` prints the
/// defaults as TOML; `--config FILE` reads one (missing fields keep their
/// defaults).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// Seed of the sensor noise (each trial draws from `seed` and its index).
    pub seed: u64,
    /// Trials before giving up (the first one imitates).
    pub max_trials: usize,
    /// The human who demonstrates.
    pub human: PlantParams,
    /// The robot that learns.
    pub robot: PlantParams,
    /// The human's swing-up strategy.
    pub human_swingup: HumanSwingup,
    /// Samples of the swing-up window (the demonstration and the plans).
    pub horizon: usize,
    /// Samples of balancing after the window.
    pub balance: usize,
    /// Standard deviations of the robot's sensor noise on $(\theta, \dot\theta, x, \dot x)$.
    pub sensor_noise: [f64; 4],
    /// Gains $(k_p, k_d)$ of the robot's hand servo, which adds
    /// $k_p (x^{plan} - x) + k_d (\dot x^{plan} - \dot x)$ to the planned
    /// acceleration so that the hand follows the planned hand trajectory
    /// (as a robot arm's own servo would); the pendulum is not fed back.
    pub hand_servo: [f64; 2],
    /// The LQR takes over within this angle of upright (rad)...
    pub catch_angle: f64,
    /// ...and below this angular speed (rad/s).
    pub catch_rate: f64,
    /// Success: within this angle of upright (rad)...
    pub success_angle: f64,
    /// ...over the last this many seconds.
    pub success_seconds: f64,
    /// The planner.
    pub planner: PlannerConfig,
    /// The learned model.
    pub model: ModelConfig,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            seed: 1,
            max_trials: 8,
            human: PlantParams::human(),
            robot: PlantParams::robot(),
            human_swingup: HumanSwingup::default(),
            horizon: 150,
            balance: 180,
            sensor_noise: [0.005, 0.02, 0.002, 0.01],
            hand_servo: [40.0, 10.0],
            catch_angle: 0.3,
            catch_rate: 2.0,
            success_angle: 0.2,
            success_seconds: 2.0,
            planner: PlannerConfig::default(),
            model: ModelConfig::default(),
        }
    }
}

/// The Eq. 3 planner's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlannerConfig {
    /// Consistency weight $\lambda$ (mismatch in rate units).
    pub lambda: f64,
    /// Cubic B-spline coefficients per state channel.
    pub state_coeffs: usize,
    /// Cubic B-spline coefficients for the control.
    pub control_coeffs: usize,
    /// Diagonal of $Q$ on $(\theta, \dot\theta, x, \dot x)$ (tracking the demonstration).
    pub state_weights: [f64; 4],
    /// Weight $r$ on $(u - u^d)^2$.
    pub control_weight: f64,
    /// Diagonal of the terminal weight on reaching upright at rest.
    pub terminal_weights: [f64; 4],
    /// Weight of the penalty fixing the initial state (hanging at rest).
    pub initial_state_weight: f64,
    /// Largest planned command (m/s²), below the actuator limit.
    pub u_max: f64,
    /// Largest planned hand excursion (m); infinite (the default) leaves the
    /// planned hand path free. With the bound the QP-bounded Gauss-Newton
    /// steps stalled far more often (3 of 6 seeds succeeded without it, 0
    /// of 6 with 0.65 m): see the project notes.
    pub x_max: f64,
    /// Gauss-Newton iteration cap.
    pub max_iters: usize,
}

impl Default for PlannerConfig {
    fn default() -> Self {
        Self {
            lambda: 1e3,
            state_coeffs: 25,
            control_coeffs: 20,
            state_weights: [1.0, 0.1, 1.0, 0.1],
            control_weight: 0.01,
            terminal_weights: [1e4, 1e3, 1e3, 1e2],
            initial_state_weight: 1e4,
            u_max: 12.0,
            x_max: f64::INFINITY,
            max_iters: 200,
        }
    }
}

/// The learned model's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModelConfig {
    /// Initial bandwidth (inputs normalised by their spread).
    pub bandwidth: f64,
    /// Ridge of the local fits.
    pub ridge: f64,
    /// Evaluations of the cross-validated metric tuning per trial (0: no tuning).
    pub tune_evals: usize,
}

impl Default for ModelConfig {
    fn default() -> Self {
        Self {
            bandwidth: 0.5,
            ridge: 1e-6,
            tune_evals: 40,
        }
    }
}

impl Config {
    /// Checks the configuration.
    pub fn validate(&self) -> anyhow::Result<()> {
        self.human.validate().map_err(anyhow::Error::msg)?;
        self.robot.validate().map_err(anyhow::Error::msg)?;
        anyhow::ensure!(self.max_trials >= 1, "max_trials must be at least 1");
        anyhow::ensure!(self.horizon >= 10, "horizon must be at least 10 samples");
        anyhow::ensure!(
            self.sensor_noise.iter().all(|s| s.is_finite() && *s >= 0.0),
            "sensor noise must be finite and nonnegative"
        );
        anyhow::ensure!(
            self.planner.lambda.is_finite() && self.planner.lambda >= 0.0,
            "lambda must be finite and nonnegative"
        );
        anyhow::ensure!(
            self.planner.state_coeffs >= 4 && self.planner.control_coeffs >= 4,
            "need at least 4 B-spline coefficients per channel"
        );
        anyhow::ensure!(self.model.bandwidth > 0.0, "the bandwidth must be positive");
        Ok(())
    }
}

/// Progress reports from [`run`].
pub trait Progress {
    /// A trial finished.
    fn trial(&mut self, trial: &TrialRecord);
}

impl<F: FnMut(&TrialRecord)> Progress for F {
    fn trial(&mut self, trial: &TrialRecord) {
        self(trial)
    }
}

/// Runs the learning loop. `previous` are trials already done (resume):
/// they are kept as they are, their data rebuilds the model, and learning
/// continues after them. Each new trial is passed to `progress` as soon as
/// it is done (to be saved).
pub fn run(cfg: &Config, previous: Vec<TrialRecord>, progress: &mut dyn Progress) -> anyhow::Result<RunRecord> {
    cfg.validate()?;
    let (demo, _) = demonstrate(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance)
        .ok_or_else(|| anyhow::anyhow!("the human's balancing controller could not be designed"))?;
    let lqr = Lqr::design(&cfg.robot, [10.0, 1.0, 1.0, 1.0], 0.1)
        .ok_or_else(|| anyhow::anyhow!("the robot's balancing controller could not be designed"))?;
    let robot = Plant::new(cfg.robot);
    let mut trials = previous;
    anyhow::ensure!(
        trials.iter().enumerate().all(|(i, t)| t.index == i + 1),
        "resumed trials must be numbered 1, 2, ... in order"
    );
    while trials.len() < cfg.max_trials && !trials.iter().any(|t| t.success) {
        let index = trials.len() + 1;
        let trial = if index == 1 {
            execute(
                cfg,
                &robot,
                &lqr,
                &demo.controls,
                &demo.states,
                index,
                TrialKind::Imitation,
            )
        } else {
            let (model, model_summary) = learn_model(cfg, &trials)?;
            let plan = plan(cfg, &demo, model)?;
            let mut t = execute(
                cfg,
                &robot,
                &lqr,
                &plan.controls,
                &plan.states,
                index,
                TrialKind::Planned,
            );
            t.plan = Some(plan);
            t.model = Some(model_summary);
            t
        };
        progress.trial(&trial);
        trials.push(trial);
    }
    let success_trial = trials.iter().find(|t| t.success).map(|t| t.index);
    let used = success_trial.unwrap_or(trials.len());
    let robot_seconds = trials[..used].iter().map(|t| t.commands.len() as f64 * t.dt).sum();
    Ok(RunRecord {
        config_toml: toml::to_string(cfg)?,
        demonstration: demo,
        trials,
        success_trial,
        robot_seconds,
    })
}

/// Runs one trial on the robot: over the swing-up window, `commands` plus
/// the hand servo towards the hand positions and velocities of `reference`
/// (the pendulum open loop); the LQR from the moment the observed state is
/// near upright; after the window, if it never is, the hand servo brings
/// the hand back to the origin.
pub fn execute(
    cfg: &Config,
    robot: &Plant,
    lqr: &Lqr,
    commands: &[f64],
    reference: &[[f64; 4]],
    index: usize,
    kind: TrialKind,
) -> TrialRecord {
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed.wrapping_mul(1_000_003).wrapping_add(index as u64));
    let noise: Vec<Option<Normal<f64>>> = cfg
        .sensor_noise
        .iter()
        .map(|&s| if s > 0.0 { Normal::new(0.0, s).ok() } else { None })
        .collect();
    let mut observe = |s: &[f64; 4]| -> [f64; 4] {
        std::array::from_fn(|i| s[i] + noise[i].as_ref().map_or(0.0, |n| n.sample(&mut rng)))
    };
    let mut st = PlantState::hanging();
    let mut states = vec![st.s];
    let mut observed = vec![observe(&st.s)];
    let mut sent = Vec::new();
    let mut caught_at = None;
    for k in 0..cfg.horizon + cfg.balance {
        let obs = observed[k];
        if caught_at.is_none() && near_upright(&obs, cfg.catch_angle, cfg.catch_rate) {
            caught_at = Some(k);
        }
        let u = if caught_at.is_some() {
            lqr.control(&obs)
        } else {
            match (commands.get(k), reference.get(k)) {
                (Some(&u), Some(r)) => u + cfg.hand_servo[0] * (r[2] - obs[2]) + cfg.hand_servo[1] * (r[3] - obs[3]),
                (Some(&u), None) => u,
                // after the window, never caught: the hand brakes back home
                _ => -cfg.hand_servo[0] * obs[2] - cfg.hand_servo[1] * obs[3],
            }
        };
        let u = u.clamp(-robot.params.u_limit, robot.params.u_limit);
        st = robot.step(&st, u);
        sent.push(u);
        states.push(st.s);
        observed.push(observe(&st.s));
    }
    let max_angle = states.iter().map(|s| s[0].abs()).fold(0.0, f64::max);
    let tail = ((cfg.success_seconds / cfg.robot.dt).round() as usize).min(states.len());
    let balanced = states[states.len() - tail..]
        .iter()
        .all(|s| from_upright(s[0]).abs() < cfg.success_angle);
    let inside = states.iter().all(|s| s[2].abs() <= cfg.robot.x_limit);
    let failure = match (balanced, inside) {
        (true, true) => String::new(),
        (_, false) => "the hand left its workspace".into(),
        (false, true) if caught_at.is_none() => {
            format!("never came near upright (max angle {:.0} deg)", max_angle.to_degrees())
        }
        (false, true) => "caught but not balanced".into(),
    };
    TrialRecord {
        index,
        kind,
        dt: cfg.robot.dt,
        states,
        observed,
        commands: sent,
        caught_at,
        max_angle,
        success: balanced && inside,
        failure,
        plan: None,
        model: None,
    }
}

/// Training pairs from the trials: inputs $(\theta, \dot\theta, x, \dot x, u)$
/// observed at $k$, outputs the observed changes of $\dot\theta$ and $\dot x$.
pub fn training_data(trials: &[TrialRecord]) -> (Vec<[f64; 5]>, Vec<[f64; 2]>) {
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for t in trials {
        for (k, &u) in t.commands.iter().enumerate() {
            let (o, o1) = (t.observed[k], t.observed[k + 1]);
            xs.push([o[0], o[1], o[2], o[3], u]);
            ys.push([o1[1] - o[1], o1[3] - o[3]]);
        }
    }
    (xs, ys)
}

/// Fits the LWR model to all trials so far and tunes its metric by
/// leave-one-out cross-validation.
pub fn learn_model(cfg: &Config, trials: &[TrialRecord]) -> anyhow::Result<(LearnedModel, ModelSummary)> {
    let (xs, ys) = training_data(trials);
    anyhow::ensure!(!xs.is_empty(), "no data to learn from");
    // initial metric: each input divided by its spread
    let spread: Vec<f64> = (0..5)
        .map(|c| {
            let mean = xs.iter().map(|x| x[c]).sum::<f64>() / xs.len() as f64;
            let var = xs.iter().map(|x| (x[c] - mean).powi(2)).sum::<f64>() / xs.len() as f64;
            var.sqrt().max(1e-6)
        })
        .collect();
    let base_scales: Vec<f64> = spread.iter().map(|s| 1.0 / s).collect();
    let settings = LwrSettings {
        kernel: Kernel::Gaussian,
        bandwidth: cfg.model.bandwidth,
        scales: base_scales.clone(),
        ridge: cfg.model.ridge,
        gaussian_cutoff: 5.0,
        ..LwrSettings::default()
    };
    let mut lwr = LwrModel::new(5, 2, settings)?;
    lwr.insert_many(&xs, &ys)?;
    let (settings, loo_nmse) = if cfg.model.tune_evals > 0 {
        let tuned = lwr.tune(&TuneSettings {
            max_evals: cfg.model.tune_evals,
            ..TuneSettings::default()
        })?;
        (tuned.settings, tuned.objective)
    } else {
        let loo = lwr.loo()?;
        (lwr.settings().clone(), loo.normalized_mse)
    };
    lwr.set_settings(settings.clone())?;
    let summary = ModelSummary {
        kind: "lwr".into(),
        n_points: xs.len(),
        inputs: INPUTS.iter().map(|s| s.to_string()).collect(),
        scales: settings.scales.iter().zip(&base_scales).map(|(s, b)| s / b).collect(),
        bandwidth: settings.bandwidth,
        loo_nmse,
    };
    Ok((LearnedModel::new(lwr, cfg.robot.dt)?, summary))
}

/// Plans a swing-up with Eq. 3 and the learned model, starting from the
/// demonstration fitted by the bases (Eqs. 6-7).
pub fn plan<M: trajopt::Model>(cfg: &Config, demo: &Demonstration, model: M) -> anyhow::Result<PlanSummary> {
    let p = &cfg.planner;
    let n = demo.horizon();
    let times = demo.times();
    let t_end = times[n];
    let mut state_ref = Mat::from_fn(n + 1, 4, |k, i| demo.states[k][i]);
    // the terminal target is upright at rest with the hand home
    for (i, v) in [std::f64::consts::PI, 0.0, 0.0, 0.0].into_iter().enumerate() {
        state_ref[(n, i)] = v;
    }
    let control_ref = Mat::from_fn(n, 1, |k, _| demo.controls[k]);
    let cost = TrackingCost::new(
        state_ref,
        control_ref.clone(),
        &p.state_weights,
        &[p.control_weight],
        &p.terminal_weights,
    )?;
    let state_basis = BSplineBasis::clamped_uniform(p.state_coeffs, 3, 0.0, t_end)?;
    let control_basis = BSplineBasis::clamped_uniform(p.control_coeffs, 3, 0.0, t_end)?;
    let inf = f64::INFINITY;
    let x_lim = p.x_max;
    let problem = Eq3Problem::new(
        model,
        cost,
        &state_basis,
        &control_basis,
        &times,
        Lambda::Constant(p.lambda),
    )?
    .with_consistency_scale(1.0 / demo.dt)?
    .with_initial_state(&[0.0; 4], p.initial_state_weight)?
    .with_state_bounds(&[-inf, -inf, -x_lim, -inf], &[inf, inf, x_lim, inf])?
    .with_control_bounds(&[-p.u_max], &[p.u_max])?;
    // Eqs. 6-7: the knot points fitted to the demonstration
    let demo_states = Mat::from_fn(n + 1, 4, |k, i| demo.states[k][i]);
    let cx = splines::fit_matrix(&state_basis, &times, demo_states.as_ref(), &FitSettings::default())?;
    let cu = splines::fit_matrix(
        &control_basis,
        &times[..n],
        control_ref.as_ref(),
        &FitSettings::default(),
    )?;
    let theta0 = problem.pack(&cx, &cu)?;
    let solver = GaussNewton::new(GaussNewtonSettings {
        max_iters: p.max_iters,
        ..GaussNewtonSettings::default()
    })?;
    let result = solver.solve(&problem, &theta0)?;
    let parts = problem.cost_breakdown(&result.theta)?;
    let (xs, us) = problem.trajectory(&result.theta)?;
    Ok(PlanSummary {
        planner: "gauss-newton".into(),
        status: format!("{:?}", result.status),
        cost: result.cost,
        initial_cost: result.initial_cost,
        task: parts.task,
        inconsistency: parts.inconsistency,
        max_mismatch: parts.max_mismatch,
        iterations: result.iterations,
        evaluations: result.residual_evals,
        seconds: result.elapsed.as_secs_f64(),
        states: (0..xs.nrows()).map(|k| std::array::from_fn(|i| xs[(k, i)])).collect(),
        controls: (0..us.nrows()).map(|k| us[(k, 0)]).collect(),
    })
}
