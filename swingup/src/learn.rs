//! The learning loop: imitate, then learn a model and plan with Eq. 3
//! until the robot swings the pendulum up and balances it.
//!
//! 1. Trial 1 replays the demonstration's commands on the robot, its hand
//!    servoed to the demonstration's hand path.
//! 2. After each trial, what the robot observed (noisy) joins the model's
//!    data ([`ModelKind`]): the paper's LWR (bandwidth and per-input metric
//!    tuned by leave-one-out cross-validation, on top of a global linear
//!    fit, see [`crate::model`]), the parametric model, the LWR on top of the
//!    parametric model (the default, see below), or the true dynamics.
//! 3. The planner ([`Solver`]) minimises the paper's Eq. 3 with the Eq. 5
//!    task cost, $\sum_k (s_k - s^d_k)^\top Q (s_k - s^d_k) + r (u_k - u^d_k)^2$,
//!    a terminal weight on reaching upright at rest, soft bounds on the hand
//!    and the command ([`crate::cost`]), and the consistency term
//!    $\lambda \sum_k \lVert (s_{k+1} - f(s_k, u_k)) / \Delta t \rVert^2$ (the
//!    mismatch in rate units), over cubic B-spline (or wavelet)
//!    coefficients initialised by fitting the demonstration (Eqs. 6-7),
//!    with $\lambda$ raised tenfold per stage from `lambda_start` (a
//!    continuation). We penalise $u - u^d$ rather than the paper's
//!    $u^\top R u$, so that $\lambda = 0$ plans the demonstration itself.
//!    DDP plans through the model instead (no $\lambda$).
//! 4. The robot executes the planned commands with its hand servoed to the
//!    planned hand path (the pendulum open loop, as in the paper); the LQR
//!    takes over when the pendulum comes near upright.
//! 5. Success: within `success_angle` of upright over the last
//!    `success_seconds`, the hand inside its workspace throughout.
//!
//! Without a demonstration ([`Start::Scratch`], a baseline beyond the
//! paper) trial 1 explores with random smooth commands, the task cost
//! tracks upright at rest throughout, and each plan starts from the
//! previous trial's observed trajectory.
//!
//! **The default model is the LWR on top of the parametric model**, not the
//! paper's pure LWR: with the pure LWR the robot learned the swing-up
//! within 8 trials in 8 of 20 seeds (median trial 5.5; `swingup
//! experiments learning`), while the semiparametric model succeeds within
//! 3 trials in each of seeds 1 to 10 (at trial 2 in 9). `--model lwr` runs the paper's.

use std::sync::Arc;

use anyhow::Context;
use std::time::Instant;

use faer::Mat;
use faer::sparse::SparseRowMat;
use lwr::{LwrSettings, TuneSettings};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use splines::wavelet::{Boundary, Wavelet, WaveletBasis};
use splines::{BSplineBasis, FitSettings, TrajectoryBasis};
use trajopt::powell::{Powell, PowellSettings};
use trajopt::{Eq3Problem, GaussNewton, GaussNewtonSettings, Lambda, TrackingCost};

pub use crate::config::{BasisKind, Config, ModelConfig, ModelKind, PlannerConfig, Solver, Start};
use crate::cost::SwingupCost;
use crate::demo::{Demonstration, demonstrate, near_upright};
use crate::lqr::Lqr;
use crate::model::{INPUTS, KnownHand, LearnedModel, LwrRegression, PendulumRegression};
use crate::plant::{Plant, PlantState, from_upright};
use crate::record::{ModelSummary, PlanSummary, RunRecord, TrialKind, TrialRecord, TrialTiming};
use crate::support::DataSupport;
use crate::truth::TrueRegression;

/// Progress reports from [`run`].
pub trait Progress {
    /// A trial finished. An error (say, the trial could not be saved)
    /// stops the run at once: [`run`] returns it without running another
    /// trial.
    ///
    /// # Errors
    /// Whatever the caller could not do with the trial.
    fn trial(&mut self, trial: &TrialRecord) -> anyhow::Result<()>;

    /// Trial `index` starts a long phase (`"learning the model"`,
    /// `"planning"`), for a progress display; nothing by default.
    fn phase(&mut self, index: usize, phase: &str) {
        let _ = (index, phase);
    }
}

/// Any closure taking a trial reports progress and never fails.
impl<F: FnMut(&TrialRecord)> Progress for F {
    fn trial(&mut self, trial: &TrialRecord) -> anyhow::Result<()> {
        self(trial);
        Ok(())
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
        let started = Instant::now();
        let trial = if index == 1 && cfg.start == Start::Scratch {
            let commands = exploration_commands(cfg, &demo)?;
            let home = vec![[0.0; 4]; commands.len() + 1];
            let mut t = execute(cfg, &robot, &lqr, &commands, &home, None, index, TrialKind::Exploration);
            t.timing.rollout = started.elapsed().as_secs_f64();
            t
        } else if index == 1 {
            let mut t = execute(
                cfg,
                &robot,
                &lqr,
                &demo.controls,
                &demo.states,
                None,
                index,
                TrialKind::Imitation,
            );
            t.timing.rollout = started.elapsed().as_secs_f64();
            t
        } else {
            // without a demonstration the plan starts from the last trial
            let start = match cfg.start {
                Start::Demonstration => demo.clone(),
                Start::Scratch => observed_window(&trials[trials.len() - 1], demo.horizon())?,
            };
            let demo = &start;
            // the lambda schedule over trials: lambda * growth^(trial - 2)
            let mut scheduled = cfg.clone();
            scheduled.planner.lambda = cfg.planner.lambda * cfg.planner.lambda_growth.powi(index as i32 - 2);
            let cfg = &scheduled;
            let started = Instant::now();
            let support = data_support(cfg, &trials)?;
            let support_seconds = started.elapsed().as_secs_f64();
            let at = PlannedTrial {
                cfg,
                demo,
                robot: &robot,
                lqr: &lqr,
                support,
                support_seconds,
                index,
            };
            let (n_points, solver) = (
                trials.iter().map(|t| t.commands.len()).sum::<usize>(),
                cfg.planner.solver,
            );
            let planning = format!("planning ({solver:?}, {:?} basis)", cfg.planner.basis).to_lowercase();
            match cfg.model.kind {
                ModelKind::Lwr | ModelKind::LwrParametric => {
                    let started = Instant::now();
                    progress.phase(index, &format!("learning the model from {n_points} samples"));
                    let (model, summary) = learn_model(cfg, &trials)?;
                    progress.phase(index, &planning);
                    at.run(&model, summary, started.elapsed().as_secs_f64())?
                }
                ModelKind::Parametric => {
                    let started = Instant::now();
                    let (model, summary) = crate::parametric::learn_parametric(cfg, &trials)?;
                    progress.phase(index, &planning);
                    at.run(&model, summary, started.elapsed().as_secs_f64())?
                }
                ModelKind::True => {
                    let model = KnownHand::new(TrueRegression::new(cfg.robot)?, cfg.robot.dt);
                    progress.phase(index, &planning);
                    at.run(&model, true_model_summary(&trials), 0.0)?
                }
            }
        };
        progress
            .trial(&trial)
            .with_context(|| format!("after trial {index}; the run stopped there"))?;
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

/// The exploration trial's commands ([`Start::Scratch`]): a clamped
/// uniform cubic B-spline over the window with `control_coeffs`
/// coefficients drawn uniformly in $\pm$ `exploration`, seeded by the run's
/// seed, sampled at the demonstration's times.
pub fn exploration_commands(cfg: &Config, demo: &Demonstration) -> anyhow::Result<Vec<f64>> {
    let n = demo.horizon();
    let basis = BSplineBasis::clamped_uniform(cfg.planner.control_coeffs, 3, 0.0, demo.dt * n as f64)?;
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed.wrapping_mul(7_919).wrapping_add(17));
    let a = cfg.exploration;
    let coeffs: Vec<f64> = (0..basis.n_coeffs())
        .map(|_| {
            if a > 0.0 {
                rand::Rng::random_range(&mut rng, -a..=a)
            } else {
                0.0
            }
        })
        .collect();
    let times = demo.times();
    let design = basis.design_matrix_rows(&times[..n], 0)?;
    Ok((0..n)
        .map(|k| {
            design
                .as_ref()
                .col_idx_of_row(k)
                .zip(design.as_ref().val_of_row(k))
                .map(|(j, v)| v * coeffs[j])
                .sum()
        })
        .collect())
}

/// The first `horizon + 1` observed states and `horizon` commands of a
/// trial, as a trajectory for the planner to start from.
pub fn observed_window(trial: &TrialRecord, horizon: usize) -> anyhow::Result<Demonstration> {
    anyhow::ensure!(
        trial.observed.len() > horizon && trial.commands.len() >= horizon,
        "trial {} is shorter than the planning window of {horizon} samples",
        trial.index
    );
    Ok(Demonstration {
        dt: trial.dt,
        states: trial.observed[..=horizon].to_vec(),
        controls: trial.commands[..horizon].to_vec(),
    })
}

/// Runs one trial on the robot: over the swing-up window, `commands` plus
/// feedback on the deviation from `reference` (with `gains`, the full
/// state feedback $-K_k (s - s^*_k)$; without, the hand servo towards the
/// reference's hand positions and velocities, the pendulum open loop); the
/// LQR from the moment the observed state is near upright; after the
/// window, if it never is, the hand servo brings the hand back to the origin.
#[allow(clippy::too_many_arguments)]
pub fn execute(
    cfg: &Config,
    robot: &Plant,
    lqr: &Lqr,
    commands: &[f64],
    reference: &[[f64; 4]],
    gains: Option<&[[f64; 4]]>,
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
                (Some(&u), Some(r)) => match gains.and_then(|g| g.get(k)) {
                    Some(g) => u - (0..4).map(|i| g[i] * (obs[i] - r[i])).sum::<f64>(),
                    None => u + cfg.hand_servo[0] * (r[2] - obs[2]) + cfg.hand_servo[1] * (r[3] - obs[3]),
                },
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
        diagnostics: None,
        timing: TrialTiming::default(),
    }
}

/// What a planned trial needs besides its model: plans, runs the plan on
/// the robot, and records the plan against reality and the time split.
struct PlannedTrial<'a> {
    cfg: &'a Config,
    demo: &'a Demonstration,
    robot: &'a Plant,
    lqr: &'a Lqr,
    support: Option<Arc<DataSupport>>,
    support_seconds: f64,
    index: usize,
}

impl PlannedTrial<'_> {
    fn run<G: PendulumRegression>(
        self,
        model: &KnownHand<G>,
        summary: ModelSummary,
        tuning: f64,
    ) -> anyhow::Result<TrialRecord> {
        let started = Instant::now();
        let (plan, gains) = plan_and_gains(self.cfg, self.demo, model, self.support)?;
        let planning = self.support_seconds + started.elapsed().as_secs_f64();
        let started = Instant::now();
        let mut t = execute(
            self.cfg,
            self.robot,
            self.lqr,
            &plan.controls,
            &plan.states,
            gains.as_deref(),
            self.index,
            TrialKind::Planned,
        );
        let rollout = started.elapsed().as_secs_f64();
        t.diagnostics = Some(crate::diagnostics::diagnose(model, &plan, &t, self.demo.horizon()));
        t.plan = Some(plan);
        t.model = Some(summary);
        t.timing = TrialTiming {
            tuning,
            planning,
            rollout,
        };
        Ok(t)
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

/// The support of the data of `trials` for the planner's penalty on
/// leaving them ([`PlannerConfig::support_weight`]); `None` when it is off.
pub fn data_support(cfg: &Config, trials: &[TrialRecord]) -> anyhow::Result<Option<Arc<DataSupport>>> {
    let p = &cfg.planner;
    if p.support_weight == 0.0 {
        return Ok(None);
    }
    let (xs, _) = training_data(trials);
    Ok(Some(Arc::new(DataSupport::new(
        &xs,
        &p.support_scales,
        p.support_bandwidth,
        p.support_full,
        p.support_weight,
    )?)))
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
        kernel: cfg.model.kernel,
        bandwidth: cfg.model.bandwidth,
        scales: base_scales
            .iter()
            .zip(&cfg.model.input_scales)
            .map(|(b, r)| b * r)
            .collect(),
        ridge: cfg.model.ridge,
        slope_ridge: cfg.model.slope_ridge,
        intercept_ridge: cfg.model.prior_weight,
        gaussian_cutoff: cfg.model.cutoff,
        ..LwrSettings::default()
    };
    let mut model = if cfg.model.kind == ModelKind::LwrParametric {
        let prior = crate::parametric::ParametricRegression::fit_midpoint(&xs, &ys, cfg.robot.dt)?;
        LwrRegression::fit_with_prior(&xs, &ys, settings, Box::new(prior), "parametric")?
    } else {
        LwrRegression::fit(&xs, &ys, settings)?
    };
    let lwr = model.lwr_mut();
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
    // the LWR part against its prior: LOO MSE of prior + LWR over the prior's MSE
    let resid: Vec<f64> = xs
        .iter()
        .zip(&ys)
        .map(|(x, y)| y[0] - model.prior().delta_omega(x, None))
        .collect();
    let n = resid.len() as f64;
    let mean = resid.iter().sum::<f64>() / n;
    let variance = resid.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n;
    let prior_mse = resid.iter().map(|r| r * r).sum::<f64>() / n;
    let lwr_vs_prior = if prior_mse > 0.0 {
        loo_nmse * variance / prior_mse
    } else {
        f64::NAN
    };
    let summary = ModelSummary {
        kind: if cfg.model.kind == ModelKind::LwrParametric {
            "lwr-parametric"
        } else {
            "lwr"
        }
        .into(),
        n_points: xs.len(),
        inputs: INPUTS.iter().map(|s| s.to_string()).collect(),
        scales: settings.scales.iter().zip(&base_scales).map(|(s, b)| s / b).collect(),
        bandwidth: settings.bandwidth,
        loo_nmse,
        lwr_vs_prior,
    };
    Ok((KnownHand::new(model, cfg.robot.dt), summary))
}

/// The planner's stage cost: Eq. 5 tracking of the demonstration (with
/// [`Start::Scratch`]: of upright at rest over the whole window, $u^d = 0$),
/// a terminal target upright at rest with the hand home, and the soft bounds
/// (shared by every planner, so that their costs compare).
pub fn swingup_cost(cfg: &Config, demo: &Demonstration) -> anyhow::Result<SwingupCost> {
    let p = &cfg.planner;
    let n = demo.horizon();
    anyhow::ensure!(n >= 1, "the demonstration has no controls");
    anyhow::ensure!(
        demo.states.len() == n + 1,
        "the demonstration has {} states for {n} controls (need {})",
        demo.states.len(),
        n + 1
    );
    let upright = [std::f64::consts::PI, 0.0, 0.0, 0.0];
    let (state_ref, control_ref) = match cfg.start {
        Start::Demonstration => {
            let mut state_ref = Mat::from_fn(n + 1, 4, |k, i| demo.states[k][i]);
            for (i, v) in upright.into_iter().enumerate() {
                state_ref[(n, i)] = v;
            }
            (state_ref, Mat::from_fn(n, 1, |k, _| demo.controls[k]))
        }
        Start::Scratch => (Mat::from_fn(n + 1, 4, |_, i| upright[i]), Mat::zeros(n, 1)),
    };
    let tracking = TrackingCost::new(
        state_ref,
        control_ref,
        &p.state_weights,
        &[p.control_weight],
        &p.terminal_weights,
    )?;
    SwingupCost::new(tracking, p.x_max, p.u_max, p.bound_weight)
}

/// The bases of the state and control trajectories over the
/// demonstration's window.
fn bases(cfg: &Config, demo: &Demonstration) -> anyhow::Result<(PlanBasis, PlanBasis)> {
    let n = demo.horizon();
    let t_end = demo.dt * n as f64;
    Ok(match cfg.planner.basis {
        BasisKind::Bspline => (
            PlanBasis::Bspline(BSplineBasis::clamped_uniform(cfg.planner.state_coeffs, 3, 0.0, t_end)?),
            PlanBasis::Bspline(BSplineBasis::clamped_uniform(
                cfg.planner.control_coeffs,
                3,
                0.0,
                t_end,
            )?),
        ),
        BasisKind::Wavelet => {
            let w = |samples| WaveletBasis::new(Wavelet::Db4, Boundary::Periodization, samples, None, 0.0, demo.dt);
            (
                PlanBasis::Wavelet(Box::new(w(n + 1)?)),
                PlanBasis::Wavelet(Box::new(w(n)?)),
            )
        }
    })
}

/// One of the planner's bases.
#[derive(Debug, Clone)]
enum PlanBasis {
    Bspline(BSplineBasis),
    Wavelet(Box<WaveletBasis>),
}

impl TrajectoryBasis for PlanBasis {
    fn n_coeffs(&self) -> usize {
        match self {
            Self::Bspline(b) => b.n_coeffs(),
            Self::Wavelet(b) => b.n_coeffs(),
        }
    }

    fn domain(&self) -> (f64, f64) {
        match self {
            Self::Bspline(b) => b.domain(),
            Self::Wavelet(b) => b.domain(),
        }
    }

    fn max_nonzeros(&self) -> usize {
        match self {
            Self::Bspline(b) => b.max_nonzeros(),
            Self::Wavelet(b) => b.max_nonzeros(),
        }
    }

    fn basis_row(&self, t: f64, order: usize, row: &mut Vec<(usize, f64)>) -> splines::Result<()> {
        match self {
            Self::Bspline(b) => b.basis_row(t, order, row),
            Self::Wavelet(b) => b.basis_row(t, order, row),
        }
    }

    fn design_matrix_rows(&self, times: &[f64], order: usize) -> splines::Result<SparseRowMat<usize, f64>> {
        match self {
            Self::Bspline(b) => b.design_matrix_rows(times, order),
            Self::Wavelet(b) => b.design_matrix_rows(times, order),
        }
    }
}

/// The Eq. 3 problem of planning a swing-up with `model`, and its starting
/// point: the demonstration fitted by the bases (Eqs. 6-7).
pub fn build_problem<M: trajopt::Model>(
    cfg: &Config,
    demo: &Demonstration,
    model: M,
    support: Option<Arc<DataSupport>>,
) -> anyhow::Result<(Eq3Problem<M, SwingupCost>, Vec<f64>)> {
    let p = &cfg.planner;
    let cost = swingup_cost(cfg, demo)?.with_support(support);
    let (state_basis, control_basis) = bases(cfg, demo)?;
    let problem = Eq3Problem::new(
        model,
        cost,
        &state_basis,
        &control_basis,
        &demo.times(),
        Lambda::Constant(p.lambda),
    )?
    .with_consistency_scale(1.0 / demo.dt)?
    .with_initial_state(&[0.0; 4], p.initial_state_weight)?;
    // Eqs. 6-7: the knot points fitted to the demonstration
    let theta0 = fit_coefficients(cfg, demo, &problem, &demo.states, &demo.controls)?;
    Ok((problem, theta0))
}

/// The coefficients of `problem` that best fit (least squares) a trajectory
/// of `horizon + 1` states and `horizon` controls at the sample times.
pub fn fit_coefficients<M: trajopt::Model>(
    cfg: &Config,
    demo: &Demonstration,
    problem: &Eq3Problem<M, SwingupCost>,
    states: &[[f64; 4]],
    controls: &[f64],
) -> anyhow::Result<Vec<f64>> {
    let n = demo.horizon();
    anyhow::ensure!(
        states.len() == n + 1 && controls.len() == n,
        "a trajectory of {} states and {} controls does not fit a horizon of {n}",
        states.len(),
        controls.len()
    );
    let times = demo.times();
    let (state_basis, control_basis) = bases(cfg, demo)?;
    let xs = Mat::from_fn(n + 1, 4, |k, i| states[k][i]);
    let us = Mat::from_fn(n, 1, |k, _| controls[k]);
    // periodised wavelets on an odd number of samples have more coefficients
    // than samples: a tiny ridge picks the smallest fit
    let fit = FitSettings {
        ridge: if cfg.planner.basis == BasisKind::Wavelet {
            1e-10
        } else {
            0.0
        },
        ..FitSettings::default()
    };
    let cx = splines::fit_matrix(&state_basis, &times, xs.as_ref(), &fit)?;
    let cu = splines::fit_matrix(&control_basis, &times[..n], us.as_ref(), &fit)?;
    Ok(problem.pack(&cx, &cu)?)
}

/// Plans with the configured planner, and with
/// [`Config::feedback`] the time-varying LQR gains along the plan (from
/// the same model).
pub fn plan_and_gains<G: PendulumRegression>(
    cfg: &Config,
    demo: &Demonstration,
    model: &KnownHand<G>,
    support: Option<Arc<DataSupport>>,
) -> anyhow::Result<(PlanSummary, Option<Vec<[f64; 4]>>)> {
    let plan = plan_with(cfg, demo, model, support)?;
    let gains = match cfg.feedback {
        [q0, q1, q2, q3, r]
            if [q0, q1, q2, q3].iter().any(|&q| q > 0.0) && plan.states.len() == plan.controls.len() + 1 =>
        {
            crate::lqr::tracking_gains(model, &plan.states, &plan.controls, [q0, q1, q2, q3], r)
        }
        _ => None,
    };
    Ok((plan, gains))
}

/// Plans with the configured planner ([`PlannerConfig::solver`]); the
/// Eq. 3 planners with the penalty on leaving `support` (DDP without).
pub fn plan_with<G: PendulumRegression>(
    cfg: &Config,
    demo: &Demonstration,
    model: &KnownHand<G>,
    support: Option<Arc<DataSupport>>,
) -> anyhow::Result<PlanSummary> {
    match cfg.planner.solver {
        Solver::GaussNewton | Solver::Powell => plan(cfg, demo, model, support),
        Solver::Ddp => crate::ddp_plan::plan_ddp(cfg, demo, model),
    }
}

/// The summary of the true model (no data are fitted).
fn true_model_summary(trials: &[TrialRecord]) -> ModelSummary {
    ModelSummary {
        kind: "true".into(),
        n_points: trials.iter().map(|t| t.commands.len()).sum(),
        inputs: INPUTS.iter().map(|s| s.to_string()).collect(),
        scales: vec![],
        bandwidth: f64::NAN,
        loo_nmse: 0.0,
        lwr_vs_prior: f64::NAN,
    }
}

/// Plans a swing-up with Eq. 3 and `model` by Gauss-Newton or Powell (as
/// [`PlannerConfig::solver`] says; DDP is [`crate::ddp_plan::plan_ddp`]),
/// starting from the demonstration fitted by the bases (Eqs. 6-7), with a
/// continuation in $\lambda$ ([`PlannerConfig::lambda_start`]).
pub fn plan<M: trajopt::Model>(
    cfg: &Config,
    demo: &Demonstration,
    model: M,
    support: Option<Arc<DataSupport>>,
) -> anyhow::Result<PlanSummary> {
    let p = &cfg.planner;
    let (mut problem, theta0) = build_problem(cfg, demo, model, support)?;
    let solver = GaussNewton::new(GaussNewtonSettings {
        max_iters: p.max_iters,
        tol_cost: p.tol_cost,
        ..GaussNewtonSettings::default()
    })?;
    let powell = Powell::new(PowellSettings {
        max_evals: Some(p.powell_evals),
        ..PowellSettings::default()
    })?;
    let mut lambda = if p.lambda_start > 0.0 && p.lambda_start < p.lambda {
        p.lambda_start
    } else {
        p.lambda
    };
    // the criterion at the start, with the final lambda
    let initial_cost = problem.cost(&theta0)?;
    let mut theta = theta0;
    let (mut iterations, mut evaluations, mut seconds) = (0, 0, 0.0);
    let (status, cost) = loop {
        let weights = if p.confidence_floor > 0.0 {
            let (xs, us) = problem.trajectory(&theta)?;
            let full = p.confidence_full;
            let floor = p.confidence_floor.min(1.0);
            Lambda::from_confidence(problem.model(), &xs, &us, lambda, |n| {
                lambda * (n / full).clamp(floor, 1.0)
            })
        } else {
            Lambda::Constant(lambda)
        };
        problem.set_lambda(weights)?;
        let (status, cost) = if p.solver == Solver::Powell {
            let r = powell.solve(&problem, &theta)?;
            iterations += r.iterations;
            evaluations += r.cost_evals;
            seconds += r.elapsed.as_secs_f64();
            theta.clone_from(&r.x);
            (format!("{:?}", r.status), r.cost)
        } else {
            let r = solver.solve(&problem, &theta)?;
            iterations += r.iterations;
            evaluations += r.residual_evals;
            seconds += r.elapsed.as_secs_f64();
            theta.clone_from(&r.theta);
            (format!("{:?}", r.status), r.cost)
        };
        if lambda >= p.lambda {
            break (status, cost);
        }
        lambda = (lambda * 10.0).min(p.lambda);
    };
    let parts = problem.cost_breakdown(&theta)?;
    let (xs, us) = problem.trajectory(&theta)?;
    Ok(PlanSummary {
        planner: if p.solver == Solver::Powell {
            "powell"
        } else {
            "gauss-newton"
        }
        .into(),
        status,
        cost,
        initial_cost,
        task: parts.task,
        inconsistency: parts.inconsistency,
        max_mismatch: parts.max_mismatch,
        iterations,
        evaluations,
        seconds,
        states: (0..xs.nrows()).map(|k| std::array::from_fn(|i| xs[(k, i)])).collect(),
        controls: (0..us.nrows()).map(|k| us[(k, 0)]).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use trajopt::StageCost;

    fn demo(cfg: &Config) -> Demonstration {
        demonstrate(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance)
            .expect("lqr")
            .0
    }

    /// Exploration commands stay within the amplitude (a B-spline lies in
    /// the hull of its coefficients), move, and depend on the seed alone.
    #[test]
    fn exploration_is_bounded_seeded_and_nontrivial() {
        let cfg = Config::default();
        let d = demo(&cfg);
        let u = exploration_commands(&cfg, &d).expect("commands");
        assert_eq!(u.len(), d.horizon());
        assert!(
            u.iter().all(|v| v.abs() <= cfg.exploration + 1e-12),
            "beyond the amplitude"
        );
        let peak = u.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(peak > 0.3 * cfg.exploration, "hardly moves: peak {peak}");
        assert_eq!(u, exploration_commands(&cfg, &d).expect("again"));
        let other = Config { seed: 2, ..cfg.clone() };
        assert_ne!(u, exploration_commands(&other, &d).expect("seed 2"));
        let still = Config {
            exploration: 0.0,
            ..cfg.clone()
        };
        assert!(
            exploration_commands(&still, &d)
                .expect("zero")
                .iter()
                .all(|v| *v == 0.0)
        );
        let bad = Config {
            exploration: f64::NAN,
            ..cfg
        };
        assert!(bad.validate().is_err());
    }

    /// From scratch the task cost's tracking part is zero upright at rest
    /// with no command, at every step; with the demonstration it is zero
    /// on the demonstration (but its last state, where the target is
    /// upright) and not upright.
    #[test]
    fn scratch_cost_tracks_upright() {
        let cfg = Config {
            start: Start::Scratch,
            ..Config::default()
        };
        let d = demo(&cfg);
        let up = [std::f64::consts::PI, 0.0, 0.0, 0.0];
        let mut r = vec![0.0; 7];
        let scratch = swingup_cost(&cfg, &d).expect("cost");
        for k in [0, 40, d.horizon() - 1] {
            scratch.residuals(k, &up, Some(&[0.0]), &mut r).expect("residuals");
            assert!(r.iter().all(|v| v.abs() < 1e-12), "step {k}: {r:?}");
        }
        let with_demo = swingup_cost(&Config::default(), &d).expect("cost");
        let k = 40;
        with_demo
            .residuals(k, &d.states[k], Some(&[d.controls[k]]), &mut r)
            .expect("residuals");
        assert!(r.iter().all(|v| v.abs() < 1e-12), "{r:?}");
        with_demo.residuals(k, &up, Some(&[0.0]), &mut r).expect("residuals");
        assert!(r.iter().any(|v| v.abs() > 1e-3), "upright is not the demonstration");
    }

    /// `planner.tol_cost` reaches the solver: a loose tolerance ends every
    /// stage by `ConvergedCost` in fewer iterations than the tight one, at a
    /// criterion close to the tight one's.
    #[test]
    fn plans_stop_at_the_configured_cost_tolerance() {
        let mut cfg = Config::default();
        cfg.planner.lambda_start = cfg.planner.lambda;
        let d = demo(&cfg);
        let model = KnownHand::new(TrueRegression::robot(), cfg.robot.dt);
        let plan_at = |tol: f64| {
            let mut c = cfg.clone();
            c.planner.tol_cost = tol;
            plan(&c, &d, &model, None).expect("plan")
        };
        let (tight, loose) = (plan_at(1e-14), plan_at(1e-3));
        assert_eq!(loose.status, "ConvergedCost");
        assert!(
            loose.iterations < tight.iterations,
            "{} iterations at 1e-3, {} at 1e-14",
            loose.iterations,
            tight.iterations
        );
        assert!(loose.cost <= tight.cost * 1.05, "{} against {}", loose.cost, tight.cost);
    }

    /// A trial shorter than the planning window is refused.
    #[test]
    fn observed_window_needs_a_long_enough_trial() {
        let cfg = Config::default();
        let robot = Plant::new(cfg.robot);
        let lqr = Lqr::design(&cfg.robot, [10.0, 1.0, 1.0, 1.0], 0.1).expect("lqr");
        let d = demo(&cfg);
        let t = execute(
            &cfg,
            &robot,
            &lqr,
            &d.controls,
            &d.states,
            None,
            1,
            TrialKind::Imitation,
        );
        let w = observed_window(&t, d.horizon()).expect("window");
        assert_eq!((w.states.len(), w.controls.len()), (d.horizon() + 1, d.horizon()));
        assert_eq!(w.states[..], t.observed[..=d.horizon()]);
        assert!(observed_window(&t, t.commands.len() + 1).is_err());
    }
}
