//! The learning loop: imitate, then learn a model and plan with Eq. 3
//! until the robot swings the pendulum up and balances it.
//!
//! 1. Trial 1 replays the demonstration's commands on the robot, its hand
//!    servoed to the demonstration's hand path.
//! 2. After each trial, what the robot observed (noisy) joins the model's
//!    data ([`ModelKind`]): the paper's LWR (bandwidth and per-input metric
//!    tuned by leave-one-out cross-validation, on top of a global linear
//!    fit, see [`crate::models`]), the parametric model, the LWR on top of the
//!    parametric model (the default, see below), or the true dynamics.
//! 3. The planner ([`Solver`](crate::config::Solver)) minimises the paper's Eq. 3 with the Eq. 5
//!    task cost, $\sum_k (s_k - s^d_k)^\top Q (s_k - s^d_k) + r (u_k - u^d_k)^2$,
//!    a terminal weight on reaching upright at rest, soft bounds on the hand
//!    and the command ([`crate::planning::cost`]), and the consistency term
//!    $\lambda \sum_k \lVert (s_{k+1} - f(s_k, u_k)) / \Delta t \rVert^2$ (the
//!    mismatch in rate units), over cubic B-spline (or wavelet)
//!    coefficients initialised by fitting the demonstration (Eqs. 6-7),
//!    with $\lambda$ raised tenfold per stage from `lambda_start` (a
//!    continuation; with `planner.warm_start`, each plan after the first
//!    instead re-solves the previous trial's plan at the final $\lambda$). We penalise $u - u^d$ rather than the paper's
//!    $u^\top R u$, so that $\lambda = 0$ plans the demonstration itself.
//!    DDP plans through the model instead (no $\lambda$).
//! 4. The robot executes the planned commands with its hand servoed to the
//!    planned hand path (the pendulum open loop, as in the paper), or,
//!    with `controller = "mpc"`, replans from the measured state at every
//!    step (see `execute_mpc` and [`crate::planning::mpc`]); the LQR
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
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::error::ResultExt as _;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use splines::{BSplineBasis, TrajectoryBasis};

use crate::config::{Config, Controller, ModelKind, Start};
use crate::models::learned::{learn_model, true_model_summary};
use crate::models::truth::TrueRegression;
use crate::models::{KnownHand, PendulumRegression};
use crate::planning::eq3::{confidence_lambda, window_cost};
use crate::planning::mpc::{ReplanSettings, ReplanStatus, Window, WindowPlan, bounded, replan, shifted};
use crate::planning::plan_and_gains;
use crate::planning::support::{DataSupport, data_support};
use crate::plant::basin::Catch;
use crate::plant::demo::{Demonstration, demonstration};
use crate::plant::{Plant, PlantState, from_upright};
use crate::record::{ModelSummary, MpcTrace, PlanSummary, RunRecord, TrialKind, TrialRecord, TrialTiming};
use faer::Mat;

/// Progress reports from [`run`].
pub trait Progress {
    /// A trial finished. An error (say, the trial could not be saved)
    /// stops the run at once: [`run`] returns it without running another
    /// trial.
    ///
    /// # Errors
    /// Whatever the caller could not do with the trial.
    fn trial(&mut self, trial: &TrialRecord) -> crate::Result<()>;

    /// Trial `index` starts a long phase (`"learning the model"`,
    /// `"planning"`), for a progress display; nothing by default.
    fn phase(&mut self, index: usize, phase: &str) {
        let _ = (index, phase);
    }
}

/// Any closure taking a trial reports progress and never fails.
impl<F: FnMut(&TrialRecord)> Progress for F {
    fn trial(&mut self, trial: &TrialRecord) -> crate::Result<()> {
        self(trial);
        Ok(())
    }
}

/// Runs the learning loop. `previous` are trials already done (resume):
/// they are kept as they are, their data rebuilds the model, and learning
/// continues after them. Each new trial is passed to `progress` as soon as
/// it is done (to be saved).
pub fn run(cfg: &Config, previous: Vec<TrialRecord>, progress: &mut dyn Progress) -> crate::Result<RunRecord> {
    cfg.validate()?;
    let demo = demonstration(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance)?;
    let lqr = Catch::design(&cfg.robot, cfg.catch_spec(), &cfg.balance_test())?;
    let robot = Plant::new(cfg.robot);
    let mut trials = previous;
    crate::error::ensure_data!(
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
            let support = data_support(&cfg.planner, &trials)?;
            let support_seconds = started.elapsed().as_secs_f64();
            let at = PlannedTrial {
                cfg,
                demo,
                robot: &robot,
                lqr: &lqr,
                support,
                support_seconds,
                index,
                previous: trials.iter().rev().find_map(|t| t.plan.as_ref()),
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
                    let (model, summary) = learn_model(&cfg.model, cfg.robot.dt, &trials)?;
                    progress.phase(index, &planning);
                    at.run(model, summary, started.elapsed().as_secs_f64())?
                }
                ModelKind::Parametric => {
                    let started = Instant::now();
                    let (model, summary) = crate::models::parametric::learn_parametric(cfg, &trials)?;
                    progress.phase(index, &planning);
                    at.run(model, summary, started.elapsed().as_secs_f64())?
                }
                ModelKind::True => {
                    let model = KnownHand::new(TrueRegression::new(cfg.robot)?, cfg.robot.dt);
                    progress.phase(index, &planning);
                    at.run(model, true_model_summary(&trials), 0.0)?
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
pub fn exploration_commands(cfg: &Config, demo: &Demonstration) -> crate::Result<Vec<f64>> {
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
pub fn observed_window(trial: &TrialRecord, horizon: usize) -> crate::Result<Demonstration> {
    crate::error::ensure_data!(
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
    lqr: &Catch,
    commands: &[f64],
    reference: &[[f64; 4]],
    gains: Option<&[[f64; 4]]>,
    index: usize,
    kind: TrialKind,
) -> TrialRecord {
    let open_loop = |k: usize, observed: &[[f64; 4]], _: &[f64]| -> Result<f64, std::convert::Infallible> {
        let obs = observed[k];
        Ok(match (commands.get(k), reference.get(k)) {
            (Some(&u), Some(r)) => match gains.and_then(|g| g.get(k)) {
                Some(g) => u - (0..4).map(|i| g[i] * (obs[i] - r[i])).sum::<f64>(),
                None => u + servo(cfg.hand_servo, r, &obs),
            },
            (Some(&u), None) => u,
            // after the window, never caught: the hand brakes back home
            _ => servo(cfg.hand_servo, &[0.0; 4], &obs),
        })
    };
    let Ok(trial) = rollout(cfg, robot, lqr, index, kind, open_loop);
    trial
}

/// The hand servo's correction towards the hand position and velocity of `r`.
fn servo(gains: [f64; 2], r: &[f64; 4], obs: &[f64; 4]) -> f64 {
    gains[0] * (r[2] - obs[2]) + gains[1] * (r[3] - obs[3])
}

/// Runs one trial on the robot with `policy(k, observed[..=k],
/// sent[..k])` choosing the command at step $k$ until the observed state
/// is near upright, the LQR from then on; records it and judges success.
fn rollout<E>(
    cfg: &Config,
    robot: &Plant,
    lqr: &Catch,
    index: usize,
    kind: TrialKind,
    mut policy: impl FnMut(usize, &[[f64; 4]], &[f64]) -> Result<f64, E>,
) -> Result<TrialRecord, E> {
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
        if caught_at.is_none() && lqr.holds(&obs) {
            caught_at = Some(k);
        }
        let u = if caught_at.is_some() {
            lqr.control(&obs)
        } else {
            policy(k, &observed, &sent)?
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
    Ok(TrialRecord {
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
        mpc: None,
    })
}

/// Runs one trial under model-predictive control ([`Controller::Mpc`]):
/// step 0 executes `initial` (the trial's plan); then every
/// [`MpcConfig::every`](crate::config::MpcConfig::every) steps Eq. 3 is
/// replanned over the window from the measured state with `model`
/// ([`crate::planning::mpc`]), the task cost's references taken from
/// `reference` at the window's steps ([`window_cost`]); between replans
/// the robot executes the plan with the hand servo, as open loop. Each
/// observed transition joins the model at once when it learns online
/// ([`PendulumRegression::observe`]).
#[allow(clippy::too_many_arguments)]
fn execute_mpc<G: PendulumRegression>(
    cfg: &Config,
    robot: &Plant,
    lqr: &Catch,
    model: &mut KnownHand<G>,
    reference: &Demonstration,
    initial: &PlanSummary,
    support: Option<Arc<DataSupport>>,
    index: usize,
) -> crate::Result<TrialRecord> {
    let m = &cfg.mpc;
    let window = Window::new(m.window, cfg.robot.dt, m.state_coeffs, m.control_coeffs)?;
    let (ns, nc) = (initial.states.len(), initial.controls.len());
    crate::error::ensure_data!(ns >= 1 && nc >= 1, "the trial's first plan is empty");
    // the first plan on the window's samples, its last values repeated
    let mut plan = WindowPlan {
        states: Mat::from_fn(m.window + 1, 4, |k, i| initial.states[k.min(ns - 1)][i]),
        controls: Mat::from_fn(m.window, 1, |k, _| initial.controls[k.min(nc - 1)]),
    };
    let settings = ReplanSettings {
        max_iterations: m.iterations,
        tol_cost: cfg.planner.tol_cost,
        // bounded by Config::validate; a budget no Duration holds is no limit
        budget: (m.budget_ms > 0.0)
            .then(|| Duration::try_from_secs_f64(m.budget_ms / 1e3).ok())
            .flatten(),
    };
    let mut trace = MpcTrace::default();
    let mut planned_at = 0;
    let policy = |k: usize, observed: &[[f64; 4]], sent: &[f64]| -> crate::Result<f64> {
        if k > 0 && m.online {
            let (o, o1) = (observed[k - 1], observed[k]);
            if model
                .regression
                .observe(&[o[0], o[1], o[2], o[3], sent[k - 1]], o1[1] - o[1])?
            {
                trace.inserted += 1;
            }
        }
        let obs = observed[k];
        if k - planned_at >= m.every {
            let cost = window_cost(&cfg.planner, cfg.start, reference, k, m.window)?.with_support(support.clone());
            let problem = window.problem(
                &*model,
                cost,
                cfg.planner.lambda,
                &obs,
                cfg.planner.initial_state_weight,
            )?;
            let mut problem = if m.hard_bounds {
                bounded(problem, cfg.planner.x_max, cfg.planner.u_max)?
            } else {
                problem
            };
            let warm = shifted(&plan, k - planned_at);
            if cfg.planner.confidence_floor > 0.0 {
                // the model's confidence along the warm start, as the planner's
                let weights = confidence_lambda(
                    &cfg.planner,
                    problem.model(),
                    &warm.states,
                    &warm.controls,
                    cfg.planner.lambda,
                );
                problem.set_lambda(weights)?;
            }
            let r = replan(&window, &problem, &warm, &obs, &settings)?;
            trace.replans += 1;
            trace.iterations += r.iterations;
            trace.replan_ms.push(r.seconds * 1e3);
            trace.kept_previous += usize::from(matches!(r.status, ReplanStatus::KeptPrevious(_)));
            plan = r.plan;
            planned_at = k;
        }
        let j = k - planned_at;
        let r: [f64; 4] = std::array::from_fn(|i| plan.states[(j, i)]);
        Ok(plan.controls[(j, 0)] + servo(cfg.hand_servo, &r, &obs))
    };
    let mut t = rollout(cfg, robot, lqr, index, TrialKind::Planned, policy)?;
    t.mpc = Some(trace);
    Ok(t)
}

/// What a planned trial needs besides its model: plans, runs the plan on
/// the robot, and records the plan against reality and the time split.
struct PlannedTrial<'a> {
    cfg: &'a Config,
    demo: &'a Demonstration,
    robot: &'a Plant,
    lqr: &'a Catch,
    support: Option<Arc<DataSupport>>,
    support_seconds: f64,
    index: usize,
    /// The last planned trial's plan (the warm start).
    previous: Option<&'a PlanSummary>,
}

impl PlannedTrial<'_> {
    fn run<G: PendulumRegression>(
        self,
        mut model: KnownHand<G>,
        summary: ModelSummary,
        tuning: f64,
    ) -> crate::Result<TrialRecord> {
        let started = Instant::now();
        let (plan, gains) = plan_and_gains(self.cfg, self.demo, &model, self.support.clone(), self.previous)?;
        let planning = self.support_seconds + started.elapsed().as_secs_f64();
        let started = Instant::now();
        let mut t = match self.cfg.controller {
            Controller::OpenLoop => execute(
                self.cfg,
                self.robot,
                self.lqr,
                &plan.controls,
                &plan.states,
                gains.as_deref(),
                self.index,
                TrialKind::Planned,
            ),
            Controller::Mpc => execute_mpc(
                self.cfg,
                self.robot,
                self.lqr,
                &mut model,
                self.demo,
                &plan,
                self.support,
                self.index,
            )?,
        };
        let rollout = started.elapsed().as_secs_f64();
        t.diagnostics = Some(crate::diagnostics::diagnose(&model, &plan, &t, self.demo.horizon()));
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

#[cfg(test)]
mod tests {
    use super::*;

    fn demo(cfg: &Config) -> Demonstration {
        demonstration(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance).expect("demonstration")
    }

    /// The demonstration's commands run open loop on `robot` as trial 1.
    fn imitation(cfg: &Config, robot: &Plant, lqr: &Catch, d: &Demonstration) -> TrialRecord {
        execute(cfg, robot, lqr, &d.controls, &d.states, None, 1, TrialKind::Imitation)
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

    /// Under MPC with the true model the robot swings up at trial 2,
    /// replanning at every step after the first, the model learning
    /// nothing online (it knows everything).
    #[test]
    fn mpc_with_the_true_model_swings_up() {
        let mut cfg = Config {
            max_trials: 2,
            controller: Controller::Mpc,
            ..Config::default()
        };
        cfg.model.kind = ModelKind::True;
        let record = run(&cfg, vec![], &mut |_: &TrialRecord| {}).expect("run");
        assert_eq!(record.success_trial, Some(2), "{:?}", record.trials[1].failure);
        let t = &record.trials[1];
        let trace = t.mpc.as_ref().expect("an MPC trial records its trace");
        let steps = t.caught_at.expect("caught");
        assert_eq!(trace.replans, steps - 1);
        assert_eq!((trace.kept_previous, trace.inserted), (0, 0));
        assert_eq!(trace.replan_ms.len(), trace.replans);
        assert!(trace.replan_quantile(0.5) <= trace.replan_quantile(0.99));
        assert!(record.trials[0].mpc.is_none());
    }

    /// With a budget no replan can meet, every replan keeps the previous
    /// plan: the robot executes the trial's first plan exactly as open
    /// loop does, up to the catch.
    #[test]
    fn mpc_over_budget_executes_the_first_plan_as_open_loop() {
        let mut cfg = Config {
            controller: Controller::Mpc,
            ..Config::default()
        };
        cfg.model.kind = ModelKind::True;
        cfg.mpc.budget_ms = 1e-9;
        let robot = Plant::new(cfg.robot);
        let lqr = Catch::design(&cfg.robot, cfg.catch_spec(), &cfg.balance_test()).expect("lqr");
        let d = demo(&cfg);
        let imitation = imitation(&cfg, &robot, &lqr, &d);
        let mut model = KnownHand::new(TrueRegression::new(cfg.robot).expect("model"), cfg.robot.dt);
        let (plan, _) = plan_and_gains(&cfg, &d, &model, None, None).expect("plan");
        let open = execute(
            &cfg,
            &robot,
            &lqr,
            &plan.controls,
            &plan.states,
            None,
            2,
            TrialKind::Planned,
        );
        let mpc = execute_mpc(&cfg, &robot, &lqr, &mut model, &d, &plan, None, 2).expect("mpc");
        let trace = mpc.mpc.as_ref().expect("trace");
        assert!(trace.replans > 0 && trace.kept_previous == trace.replans, "{trace:?}");
        let until = open.caught_at.unwrap_or(d.horizon()).min(d.horizon());
        assert_eq!(open.commands[..until], mpc.commands[..until]);
        assert!(imitation.mpc.is_none());
    }

    /// A trial shorter than the planning window is refused.
    #[test]
    fn observed_window_needs_a_long_enough_trial() {
        let cfg = Config::default();
        let robot = Plant::new(cfg.robot);
        let lqr = Catch::design(&cfg.robot, cfg.catch_spec(), &cfg.balance_test()).expect("lqr");
        let d = demo(&cfg);
        let t = imitation(&cfg, &robot, &lqr, &d);
        let w = observed_window(&t, d.horizon()).expect("window");
        assert_eq!((w.states.len(), w.controls.len()), (d.horizon() + 1, d.horizon()));
        assert_eq!(w.states[..], t.observed[..=d.horizon()]);
        assert!(observed_window(&t, t.commands.len() + 1).is_err());
    }
}
