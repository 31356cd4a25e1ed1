//! How accurate must a model be for an open-loop swing-up to work?
//!
//! The paper's robot executes each plan open loop (the hand follows the
//! planned hand path; nothing feeds the pendulum back until the balancing
//! controller catches it near upright). This experiment plans with the
//! *exact* dynamics of a plant that differs from the robot in one
//! parameter by a known factor (its pendulum length, its damping or
//! gravity), runs the plan on the real robot over several seeds of sensor
//! noise, and counts successes. The factors at which success stops bound
//! the model error an open-loop plan tolerates: whatever a learned model
//! gets wrong along the plan must stay inside them.
//!
//! The second half ([`learned_model_error`]) measures the other side of
//! the budget: the error of the pure LWR model, learned after 1, 2, 3
//! trials of ordinary learning runs, along the plan the exact model makes
//! (the swing-up that works), against the error a gravity off by 1 %
//! would make along the same plan.
//!
//! The third ([`with_successful_data`]) asks whether exploring the final
//! swing would be enough: the pure LWR is given the data of a swing-up
//! that works (the exact model's plan run on the robot, with its sensor
//! noise) besides the imitation's, and plans the next trial, from the
//! demonstration as the paper does and from the successful plan itself.
//!
//! `swingup sensitivity` runs all three and writes `sensitivity.json` and
//! `sensitivity.md`.

use std::fmt::Write as _;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::config::{Config, ModelKind};
use crate::diagnostics::median;
use crate::learn::{execute, run};
use crate::models::KnownHand;
use crate::models::PendulumRegression;
use crate::models::learned::learn_model;
use crate::models::truth::TrueRegression;
use crate::planning::eq3::plan;
use crate::plant::basin::Catch;
use crate::plant::demo::demonstration;
use crate::plant::{Plant, PlantParams};
use crate::record::TrialKind;

/// Which parameter of the planning model is off.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Parameter {
    /// The pendulum length $l$ (scales both $g / l$ and the hand's $1 / l$).
    Length,
    /// The viscous damping $b$.
    Damping,
    /// Gravity $g$ (scales $g / l$ alone).
    Gravity,
}

impl Parameter {
    /// The parameter's name in the configuration.
    pub fn name(self) -> &'static str {
        match self {
            Self::Length => "length",
            Self::Damping => "damping",
            Self::Gravity => "gravity",
        }
    }

    fn scale(self, p: &PlantParams, factor: f64) -> PlantParams {
        let mut q = *p;
        match self {
            Self::Length => q.length *= factor,
            Self::Damping => q.damping *= factor,
            Self::Gravity => q.gravity *= factor,
        }
        q
    }
}

/// One planning model: the robot with one parameter scaled, and what its
/// plan did on the real robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensitivityRow {
    /// The parameter scaled.
    pub parameter: Parameter,
    /// Its factor (1: the exact model).
    pub factor: f64,
    /// The plan's final cost in its own model (a plan that cannot reach
    /// upright even there shows here).
    #[serde(with = "crate::record::nullable")]
    pub plan_cost: f64,
    /// Seeds of sensor noise on which the plan succeeded.
    pub successes: usize,
    /// Seeds run.
    pub seeds: usize,
    /// Largest pendulum angle per seed (degrees).
    #[serde(with = "crate::record::nullable")]
    pub max_angles: Vec<f64>,
}

/// The factors of the committed table: each parameter from 0.9 to 1.1 by
/// small steps near 1, damping from 0 to 2 (its effect per sample is small).
pub fn default_perturbations() -> Vec<(Parameter, f64)> {
    let fine = [0.9, 0.95, 0.97, 0.98, 0.99, 1.0, 1.01, 1.02, 1.03, 1.05, 1.1];
    let mut out: Vec<(Parameter, f64)> = Vec::new();
    out.extend(fine.iter().map(|&f| (Parameter::Length, f)));
    out.extend(fine.iter().map(|&f| (Parameter::Gravity, f)));
    out.extend([0.0, 0.5, 0.8, 0.9, 1.0, 1.1, 1.25, 2.0].map(|f| (Parameter::Damping, f)));
    out
}

/// Plans with each perturbed exact model (configuration `cfg`, the robot
/// `cfg.robot`) and runs the plan on the robot with seeds `1..=seeds` of
/// sensor noise, in parallel.
///
/// # Errors
/// An invalid configuration, factor (not finite and positive, or negative
/// for the damping) or a planner failure.
pub fn open_loop_tolerance(
    cfg: &Config,
    perturbations: &[(Parameter, f64)],
    seeds: u64,
) -> crate::Result<Vec<SensitivityRow>> {
    cfg.validate()?;
    crate::error::ensure_data!(seeds >= 1, "sensitivity needs at least one seed");
    let demo = demonstration(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance)?;
    let lqr = Catch::design(&cfg.robot, cfg.catch_spec(), &cfg.balance_test())?;
    let robot = Plant::new(cfg.robot);
    perturbations
        .par_iter()
        .map(|&(parameter, factor)| {
            crate::error::ensure_data!(
                factor.is_finite() && (factor > 0.0 || (parameter == Parameter::Damping && factor == 0.0)),
                "the factor of {} must be finite and positive, got {factor}",
                parameter.name()
            );
            let model = KnownHand::new(TrueRegression::new(parameter.scale(&cfg.robot, factor))?, cfg.robot.dt);
            let p = plan(cfg, &demo, &model, None)?;
            let mut max_angles = Vec::new();
            let mut successes = 0;
            for seed in 1..=seeds {
                let c = Config { seed, ..cfg.clone() };
                let t = execute(&c, &robot, &lqr, &p.controls, &p.states, None, 2, TrialKind::Planned);
                successes += usize::from(t.success);
                max_angles.push(t.max_angle.to_degrees());
            }
            Ok(SensitivityRow {
                parameter,
                factor,
                plan_cost: p.cost,
                successes,
                seeds: seeds as usize,
                max_angles,
            })
        })
        .collect()
}

/// The learned model's error along the exact plan after some trials.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelErrorRow {
    /// Trials the model was learned from (the first imitates).
    pub trials: usize,
    /// Runs (seeds) that had that many trials.
    pub runs: usize,
    /// Root mean square of $g(s_k, u_k) - \Delta\dot\theta_{true}(s_k, u_k)$
    /// over the plan's samples with $|\theta| <$ [`SEEN_ANGLE`] (where the
    /// imitation trial has data), all runs pooled (rad/s per sample).
    #[serde(with = "crate::record::nullable")]
    pub rms_seen: f64,
    /// The same over the samples beyond [`SEEN_ANGLE`] (the final swing).
    #[serde(with = "crate::record::nullable")]
    pub rms_beyond: f64,
    /// The mean error over the samples beyond [`SEEN_ANGLE`].
    #[serde(with = "crate::record::nullable")]
    pub bias_beyond: f64,
}

/// The angle (rad) below which the imitation trial (which peaks at 87
/// degrees) has data.
pub const SEEN_ANGLE: f64 = 1.4;

/// Error budget and what the learned model achieves: the exact model's
/// plan, the rms error a gravity off by `gravity_error` (e.g. 0.01) makes
/// along it, and per number of trials the pure LWR's error along it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelErrorReport {
    /// The relative gravity error of the reference row.
    pub gravity_error: f64,
    /// The rms error that gravity error makes along the plan (rad/s per sample).
    pub gravity_rms: f64,
    /// The rms of the true $\Delta\dot\theta$ along the plan (the signal).
    pub signal_rms: f64,
    /// Per number of trials, the learned model's error.
    pub rows: Vec<ModelErrorRow>,
}

/// What `swingup sensitivity` saves (`sensitivity.json`): the tolerance
/// rows, the learned model's error, and the code version that made them,
/// from which [`SensitivityReport::readme_summary`] rewrites the README's
/// block exactly.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensitivityReport {
    /// The code version, as [`code_version`] gives it (e.g. `commit f3b5b3e`).
    pub version: String,
    /// One row per perturbed planning model ([`open_loop_tolerance`]).
    pub tolerance: Vec<SensitivityRow>,
    /// The pure LWR's error along the exact plan ([`learned_model_error`]).
    pub learned_model_error: ModelErrorReport,
    /// The pure LWR planning with a successful swing-up's data
    /// ([`with_successful_data`]; empty in reports saved before it existed).
    #[serde(default)]
    pub successful_data: Vec<SuccessfulDataRow>,
}

impl SensitivityReport {
    /// The full report ([`markdown`]).
    pub fn markdown(&self) -> String {
        let mut md = markdown(&self.tolerance, Some(&self.learned_model_error), &self.version);
        md.push_str(&successful_data_markdown(&self.successful_data));
        md
    }

    /// The README's block ([`readme_summary`] and the successful-data rows).
    pub fn readme_summary(&self) -> String {
        let mut md = readme_tables(&self.tolerance, &self.learned_model_error);
        if !self.successful_data.is_empty() {
            md.push_str(&successful_data_summary(
                &self.successful_data,
                self.learned_model_error.gravity_rms,
            ));
        }
        md.push_str(&readme_stamp(&self.version));
        md
    }
}

/// Where the plan that follows a successful swing-up's data starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NextPlanStart {
    /// From the demonstration, with the lambda continuation (the paper's
    /// planner, as every learning run plans).
    Demonstration,
    /// From the successful plan itself, at the final lambda
    /// ([`PlannerConfig::warm_start`](crate::config::PlannerConfig::warm_start)).
    SuccessfulPlan,
}

/// The pure LWR given the data of a swing-up that works: per start of the
/// next plan, how often the next trial and the trials after it succeed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SuccessfulDataRow {
    /// Where the next plan starts.
    pub start: NextPlanStart,
    /// Runs (seeds) whose exact-model trial succeeded and so took part.
    pub runs: usize,
    /// Trials planned with the LWR after the successful one, at most.
    pub trials: usize,
    /// Runs whose first LWR trial succeeded.
    pub next_successes: usize,
    /// Runs that succeeded within `trials` LWR trials.
    pub successes: usize,
    /// Per run, the first LWR trial's largest angle (rad).
    pub next_max_angles: Vec<f64>,
    /// Per run, the largest $|\theta^{plan}_k - \theta^{success}_k|$ of the
    /// first LWR plan against the successful trial's observed angles (rad):
    /// how far the plan moves from the path whose data the model has.
    pub plan_departures: Vec<f64>,
    /// Per run, the root mean square of the error of the LWR learned from
    /// the imitation and the successful trial along the successful plan
    /// (rad/s per sample, as [`ModelErrorRow`]): the model where it has
    /// the data (the same for either start).
    #[serde(default)]
    pub path_errors: Vec<f64>,
}

/// Runs, for seeds `1..=seeds` in parallel, the exact model's learning run
/// (the imitation, then the exact plan on the robot, which swings up), then
/// continues it with the pure LWR (`cfg` with `model.kind = lwr`) for up to
/// `trials` more trials, once per [`NextPlanStart`]. The successful trial
/// is passed to the loop as a failed one, so that learning goes on with
/// its data; seeds whose exact-model trial failed are left out.
///
/// # Errors
/// An invalid configuration, `seeds` or `trials` of 0, or a failed run.
pub fn with_successful_data(cfg: &Config, seeds: u64, trials: usize) -> crate::Result<Vec<SuccessfulDataRow>> {
    cfg.validate()?;
    crate::error::ensure_data!(seeds >= 1 && trials >= 1, "need at least one seed and one trial");
    let starts = [NextPlanStart::Demonstration, NextPlanStart::SuccessfulPlan];
    let truth = TrueRegression::new(cfg.robot)?;
    // per seed: None (exact trial failed) or per start (success trial, max angle, departure, path error)
    type Outcome = Option<Vec<(Option<usize>, f64, f64, f64)>>;
    let per_seed: Vec<Outcome> = (1..=seeds)
        .into_par_iter()
        .map(|seed| -> crate::Result<Outcome> {
            let mut exact = Config {
                seed,
                max_trials: 2,
                ..cfg.clone()
            };
            exact.model.kind = ModelKind::True;
            let record = run(&exact, vec![], &mut |_: &crate::record::TrialRecord| {})?;
            if record.success_trial != Some(2) {
                return Ok(None);
            }
            let good = record.trials[1].observed.clone();
            let mut previous = record.trials;
            for t in &mut previous {
                t.success = false;
            }
            let mut lwr = Config { seed, ..cfg.clone() };
            lwr.model.kind = ModelKind::Lwr;
            let (model, _) = learn_model(&lwr.model, lwr.robot.dt, &previous)?;
            let path_error = previous[1].plan.as_ref().map_or(f64::NAN, |p| {
                let errors: Vec<f64> = p
                    .states
                    .iter()
                    .zip(&p.controls)
                    .map(|(s, u)| {
                        let z = [s[0], s[1], s[2], s[3], *u];
                        model.regression.delta_omega(&z, None) - truth.delta_omega(&z, None)
                    })
                    .collect();
                crate::diagnostics::rms(&errors)
            });
            starts
                .iter()
                .map(|start| {
                    let mut c = Config {
                        seed,
                        max_trials: 2 + trials,
                        ..cfg.clone()
                    };
                    c.model.kind = ModelKind::Lwr;
                    c.planner.warm_start = *start == NextPlanStart::SuccessfulPlan;
                    let r = run(&c, previous.clone(), &mut |_: &crate::record::TrialRecord| {})?;
                    let next = &r.trials[2];
                    let departure = next.plan.as_ref().map_or(f64::NAN, |p| {
                        p.states
                            .iter()
                            .zip(&good)
                            .map(|(a, b)| (a[0] - b[0]).abs())
                            .fold(0.0, f64::max)
                    });
                    Ok((r.success_trial.map(|t| t - 2), next.max_angle, departure, path_error))
                })
                .collect::<crate::Result<Vec<_>>>()
                .map(Some)
        })
        .collect::<crate::Result<_>>()?;
    Ok(starts
        .iter()
        .enumerate()
        .map(|(i, &start)| {
            let these: Vec<&(Option<usize>, f64, f64, f64)> = per_seed.iter().flatten().map(|v| &v[i]).collect();
            SuccessfulDataRow {
                start,
                runs: these.len(),
                trials,
                next_successes: these.iter().filter(|o| o.0 == Some(1)).count(),
                successes: these.iter().filter(|o| o.0.is_some()).count(),
                next_max_angles: these.iter().map(|o| o.1).collect(),
                plan_departures: these.iter().map(|o| o.2).collect(),
                path_errors: these.iter().map(|o| o.3).collect(),
            }
        })
        .collect())
}

impl NextPlanStart {
    fn describe(self) -> &'static str {
        match self {
            Self::Demonstration => "the demonstration (the paper's)",
            Self::SuccessfulPlan => "the successful plan (warm start)",
        }
    }
}

/// The section of `sensitivity.md` on [`with_successful_data`] (empty
/// without rows).
pub fn successful_data_markdown(rows: &[SuccessfulDataRow]) -> String {
    let mut md = String::new();
    let Some(first) = rows.first() else {
        return md;
    };
    let _ = writeln!(
        md,
        "## The pure LWR with a successful swing-up's data
"
    );
    let _ = writeln!(
        md,
        "Would exploring the final swing be enough? Each run imitates, then runs the exact \
         model's plan on the robot (a swing-up that works, with the robot's sensor noise), \
         then learns on with the pure LWR (default settings) from both trials' data for up to \
         {} more trials. The next plan starts from the demonstration (as every learning run \
         plans) or from the successful plan. Departure: the largest angle between the first \
         LWR plan and the successful trial. Model error: the root mean square error of the LWR \
         learned from both trials along the successful plan, where it has the data (rad/s per \
         sample, as above).\n",
        first.trials
    );
    let _ = writeln!(
        md,
        "| next plan starts from | runs | next trial succeeds | succeeds within {} trials | next trial's max angle (deg), median | plan's departure from the successful path (rad), median, min-max | model error along it, median |",
        first.trials
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---|---:|");
    for r in rows {
        let (lo, hi) = r
            .plan_departures
            .iter()
            .filter(|d| d.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), d| (a.min(*d), b.max(*d)));
        let _ = writeln!(
            md,
            "| {} | {} | {}/{} | {}/{} | {:.0} | {:.2}, {lo:.2}-{hi:.2} | {} |",
            r.start.describe(),
            r.runs,
            r.next_successes,
            r.runs,
            r.successes,
            r.runs,
            median(&r.next_max_angles).to_degrees(),
            median(&r.plan_departures),
            crate::format::num(median(&r.path_errors)),
        );
    }
    md.push('\n');
    md
}

/// The README's rows of [`with_successful_data`], the model's error along
/// the successful path in units of `gravity_rms` (a 1 % gravity error's).
fn successful_data_summary(rows: &[SuccessfulDataRow], gravity_rms: f64) -> String {
    let mut md = String::from(
        "\n| pure LWR given a successful swing-up's data, next plan from | next trial succeeds | succeeds within | plan's median departure from the successful path | median model error along that path |\n|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {}/{} | {}/{} in {} trials | {:.2} rad | {:.0}x a 1 % gravity error |",
            r.start.describe(),
            r.next_successes,
            r.runs,
            r.successes,
            r.runs,
            r.trials,
            median(&r.plan_departures),
            median(&r.path_errors) / gravity_rms
        );
    }
    md
}

/// Runs learning with the pure LWR (`cfg` with `model.kind = lwr`) for
/// seeds `1..=seeds` and up to `max_trials` trials, refits its model after
/// each trial, and measures the model's error along the exact model's
/// plan (see [`ModelErrorReport`]); runs in parallel.
///
/// # Errors
/// An invalid configuration or a failed run.
pub fn learned_model_error(cfg: &Config, seeds: u64, max_trials: usize) -> crate::Result<ModelErrorReport> {
    cfg.validate()?;
    crate::error::ensure_data!(seeds >= 1 && max_trials >= 1, "need at least one seed and one trial");
    let demo = demonstration(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance)?;
    let truth = TrueRegression::new(cfg.robot)?;
    let exact = plan(cfg, &demo, KnownHand::new(truth, cfg.robot.dt), None)?;
    let points: Vec<[f64; 5]> = exact
        .controls
        .iter()
        .zip(&exact.states)
        .map(|(u, s)| [s[0], s[1], s[2], s[3], *u])
        .collect();
    let gravity_error = 0.01;
    let off = TrueRegression::new(Parameter::Gravity.scale(&cfg.robot, 1.0 + gravity_error))?;
    let rms = |v: &[f64]| (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt();
    let gravity_rms = rms(&points
        .iter()
        .map(|z| off.delta_omega(z, None) - truth.delta_omega(z, None))
        .collect::<Vec<_>>());
    let signal_rms = rms(&points.iter().map(|z| truth.delta_omega(z, None)).collect::<Vec<_>>());
    let lwr = Config {
        max_trials,
        model: crate::config::ModelConfig {
            kind: ModelKind::Lwr,
            ..cfg.model.clone()
        },
        ..cfg.clone()
    };
    // per seed, per number of trials: the errors at the seen and the beyond points
    type Errors = Vec<(usize, Vec<f64>, Vec<f64>)>;
    let per_seed: Vec<Errors> = (1..=seeds)
        .into_par_iter()
        .map(|seed| -> crate::Result<Errors> {
            let c = Config { seed, ..lwr.clone() };
            let record = run(&c, vec![], &mut |_: &crate::record::TrialRecord| {})?;
            (1..=record.trials.len())
                .map(|n| {
                    let (model, _) = learn_model(&c.model, c.robot.dt, &record.trials[..n])?;
                    let (mut seen, mut beyond) = (vec![], vec![]);
                    for z in &points {
                        let e = model.regression.delta_omega(z, None) - truth.delta_omega(z, None);
                        if z[0].abs() < SEEN_ANGLE {
                            seen.push(e);
                        } else {
                            beyond.push(e);
                        }
                    }
                    Ok((n, seen, beyond))
                })
                .collect()
        })
        .collect::<crate::Result<_>>()?;
    let rows = (1..=max_trials)
        .map(|n| {
            let these: Vec<&(usize, Vec<f64>, Vec<f64>)> = per_seed.iter().flatten().filter(|e| e.0 == n).collect();
            let seen: Vec<f64> = these.iter().flat_map(|e| e.1.iter().copied()).collect();
            let beyond: Vec<f64> = these.iter().flat_map(|e| e.2.iter().copied()).collect();
            ModelErrorRow {
                trials: n,
                runs: these.len(),
                rms_seen: if seen.is_empty() { f64::NAN } else { rms(&seen) },
                rms_beyond: if beyond.is_empty() { f64::NAN } else { rms(&beyond) },
                bias_beyond: if beyond.is_empty() {
                    f64::NAN
                } else {
                    beyond.iter().sum::<f64>() / beyond.len() as f64
                },
            }
        })
        .filter(|r| r.runs > 0)
        .collect();
    Ok(ModelErrorReport {
        gravity_error,
        gravity_rms,
        signal_rms,
        rows,
    })
}

/// `sensitivity.md`: one table per parameter, and the learned model's
/// error against the budget when given, stamped with `version`.
pub fn markdown(rows: &[SensitivityRow], model_error: Option<&ModelErrorReport>, version: &str) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# Open-loop tolerance to model error\n");
    let _ = writeln!(
        md,
        "Each row plans the swing-up with the exact dynamics of the robot with one parameter \
         scaled by the factor, then runs that plan open loop on the real robot (as the paper's \
         trials are run) over {} seeds of sensor noise. Made by `swingup sensitivity` at {version}.\n",
        rows.first().map_or(0, |r| r.seeds)
    );
    for parameter in [Parameter::Length, Parameter::Gravity, Parameter::Damping] {
        let these: Vec<&SensitivityRow> = rows.iter().filter(|r| r.parameter == parameter).collect();
        if these.is_empty() {
            continue;
        }
        let _ = writeln!(md, "## {}\n", parameter.name());
        let _ = writeln!(md, "| factor | successes | max angle (deg), min-max | plan cost |");
        let _ = writeln!(md, "|---:|---:|---|---:|");
        for r in these {
            let finite: Vec<f64> = r.max_angles.iter().copied().filter(|a| a.is_finite()).collect();
            let (lo, hi) = finite
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
            let angles = if finite.is_empty() {
                "—".to_string()
            } else {
                format!("{lo:.0}-{hi:.0}")
            };
            let _ = writeln!(
                md,
                "| {} | {}/{} | {angles} | {} |",
                r.factor,
                r.successes,
                r.seeds,
                crate::format::num(r.plan_cost)
            );
        }
        md.push('\n');
    }
    if let Some(m) = model_error {
        let _ = writeln!(md, "## The pure LWR against that budget\n");
        let _ = writeln!(
            md,
            "The pure LWR model (`--model lwr`, default settings) learned after each trial of \
             ordinary learning runs, evaluated along the exact model's plan (the swing-up that \
             works): root mean square of its error in the per-sample change of angular velocity \
             (rad/s), where the imitation trial has data (|θ| < {SEEN_ANGLE} rad) and beyond (the \
             final swing). Along the same plan the true change has rms {}, and a gravity off by \
             {} % (which fails most trials above) makes an error of rms {}.\n",
            crate::format::num(m.signal_rms),
            m.gravity_error * 100.0,
            crate::format::num(m.gravity_rms)
        );
        let _ = writeln!(
            md,
            "| trials learned from | runs | rms error, seen | rms error, beyond | mean error, beyond |"
        );
        let _ = writeln!(md, "|---:|---:|---:|---:|---:|");
        for r in &m.rows {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} |",
                r.trials,
                r.runs,
                crate::format::num(r.rms_seen),
                crate::format::num(r.rms_beyond),
                crate::format::num(r.bias_beyond)
            );
        }
        md.push('\n');
    }
    md
}

/// The short form for the README: per parameter, the range of factors
/// around 1 within which every seed succeeded; and the LWR's error beyond
/// the imitation's data after each number of trials, in units of the error
/// a 1 % gravity mistake makes. Stamped with `version`.
pub fn readme_summary(rows: &[SensitivityRow], model_error: &ModelErrorReport, version: &str) -> String {
    readme_tables(rows, model_error) + &readme_stamp(version)
}

/// The line under the README's tables naming the command and `version`.
fn readme_stamp(version: &str) -> String {
    format!("\n(`swingup sensitivity --out results --update-readme swingup/README.md` at {version}.)\n")
}

/// [`readme_summary`]'s tables, without the stamp.
fn readme_tables(rows: &[SensitivityRow], model_error: &ModelErrorReport) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "| planning model | every seed succeeded for factors | half or more succeeded | checked factors |\n\
         |---|---|---|---|"
    );
    for parameter in [Parameter::Length, Parameter::Gravity, Parameter::Damping] {
        let mut these: Vec<&SensitivityRow> = rows.iter().filter(|r| r.parameter == parameter).collect();
        these.sort_by(|a, b| a.factor.total_cmp(&b.factor));
        let Some(one) = these.iter().position(|r| r.factor == 1.0) else {
            continue;
        };
        // the widest range of factors around 1 in which every row passes `ok`
        let around = |ok: &dyn Fn(&SensitivityRow) -> bool| -> String {
            let lo = these[..=one]
                .iter()
                .rev()
                .take_while(|r| ok(r))
                .last()
                .map(|r| r.factor);
            let hi = these[one..].iter().take_while(|r| ok(r)).last().map(|r| r.factor);
            match (lo, hi) {
                (Some(lo), Some(hi)) if lo == hi => format!("{lo} only"),
                (Some(lo), Some(hi)) => format!("{lo} to {hi}"),
                _ => "none".into(),
            }
        };
        let every = around(&|r| r.successes == r.seeds);
        let half = around(&|r| 2 * r.successes >= r.seeds);
        let checked: Vec<String> = these.iter().map(|r| r.factor.to_string()).collect();
        let _ = writeln!(
            md,
            "| {} x factor | {every} | {half} | {} |",
            parameter.name(),
            checked.join(", ")
        );
    }
    let _ = writeln!(
        md,
        "\n| pure LWR learned from | rms error where the imitation has data | rms error beyond it (final swing) |\n|---|---|---|"
    );
    for r in &model_error.rows {
        let _ = writeln!(
            md,
            "| {} trial{} ({} runs) | {:.0}x a 1 % gravity error | {:.0}x |",
            r.trials,
            if r.trials == 1 { "" } else { "s" },
            r.runs,
            r.rms_seen / model_error.gravity_rms,
            r.rms_beyond / model_error.gravity_rms
        );
    }
    md
}

/// The code version for stamping generated results: the commit this
/// binary's code was built from, `commit <hash>`, with `-dirty` when its code
/// differed from that commit, or `an unknown commit` (built outside this
/// workspace's git checkout); [`store::code_version`], set at build time,
/// so that neither the directory a run starts in nor a later commit
/// changes it.
pub fn code_version() -> String {
    store::code_version().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact model's plan succeeds on every seed; a model whose
    /// pendulum is 10 % longer fails on every seed (its plan pumps too much
    /// energy); a bad factor is an error naming the parameter.
    /// The budget row: a 1 % gravity error is about 1 % of the signal's
    /// gravity part; after one trial the LWR is far outside it beyond the
    /// imitation's data, and the table shows each row.
    #[test]
    fn learned_model_error_is_measured_against_the_budget() {
        let cfg = Config::default();
        let m = learned_model_error(&cfg, 1, 2).expect("model error");
        assert!(m.gravity_rms > 0.0 && m.gravity_rms < 0.02 * m.signal_rms, "{m:?}");
        assert_eq!(m.rows.len(), 2);
        assert!(m.rows.iter().all(|r| r.runs == 1 && r.rms_seen.is_finite()));
        assert!(m.rows[0].rms_beyond > 10.0 * m.gravity_rms, "{m:?}");
        let md = markdown(&[], Some(&m), "commit test");
        assert!(md.lines().any(|l| l.starts_with("| 1 | 1 |")), "{md}");
        let rows = [(0.98, 0), (0.99, 3), (1.0, 3), (1.01, 3), (1.02, 1)].map(|(factor, successes)| SensitivityRow {
            parameter: Parameter::Gravity,
            factor,
            plan_cost: 1.0,
            successes,
            seeds: 3,
            max_angles: vec![180.0; 3],
        });
        let short = readme_summary(&rows, &m, "commit test");
        assert!(
            short.contains("| gravity x factor | 0.99 to 1.01 | 0.99 to 1.01 | 0.98, 0.99, 1, 1.01, 1.02 |"),
            "{short}"
        );
        assert!(short.contains("| 1 trial (1 runs) |"), "{short}");
    }

    #[test]
    fn exact_model_works_and_a_ten_percent_error_does_not() {
        let cfg = Config::default();
        let rows =
            open_loop_tolerance(&cfg, &[(Parameter::Length, 1.0), (Parameter::Length, 1.1)], 2).expect("tolerance");
        assert_eq!(rows[0].successes, 2, "{:?}", rows[0]);
        assert_eq!(rows[1].successes, 0, "{:?}", rows[1]);
        assert!(rows[1].max_angles.iter().all(|a| *a > 200.0), "{:?}", rows[1]);
        let md = markdown(&rows, None, "commit test");
        assert!(md.contains("| 1 | 2/2 |") && md.contains("| 1.1 | 0/2 |"), "{md}");
        let e = open_loop_tolerance(&cfg, &[(Parameter::Gravity, -1.0)], 1)
            .expect_err("negative")
            .to_string();
        assert!(e.contains("gravity"), "{e}");
    }

    /// With a successful swing-up's data the runs go on with the LWR from
    /// trial 3; the warm start begins on the successful path (its plan is
    /// that trial's plan), so it departs from it far less than a plan from
    /// the demonstration; the markdown and the README rows show both.
    #[test]
    fn successful_data_runs_go_on_with_the_lwr() {
        let cfg = Config::default();
        let rows = with_successful_data(&cfg, 1, 1).expect("runs");
        assert_eq!(rows.len(), 2);
        assert!(rows.iter().all(|r| r.runs == 1 && r.trials == 1), "{rows:?}");
        assert!(
            rows.iter()
                .all(|r| r.next_max_angles.len() == 1 && r.plan_departures[0].is_finite())
        );
        assert!(rows.iter().all(|r| r.successes == r.next_successes));
        let (cold, warm) = (rows[0].plan_departures[0], rows[1].plan_departures[0]);
        assert!(warm < 0.5 * cold, "warm {warm}, cold {cold}");
        let md = successful_data_markdown(&rows);
        assert!(md.contains("| the demonstration (the paper's) | 1 |"), "{md}");
        assert!(rows.iter().all(|r| r.path_errors.len() == 1 && r.path_errors[0] > 0.0));
        assert_eq!(rows[0].path_errors, rows[1].path_errors);
        let short = successful_data_summary(&rows, rows[0].path_errors[0] / 10.0);
        assert!(short.contains("| the successful plan (warm start) |"), "{short}");
        assert!(short.contains("| 10x a 1 % gravity error |"), "{short}");
        assert!(with_successful_data(&cfg, 0, 1).is_err());
    }
}
