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
//! `swingup sensitivity` runs it and writes `sensitivity.json` and
//! `sensitivity.md`.

use std::fmt::Write as _;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::demo::demonstrate;
use crate::learn::{Config, execute, plan};
use crate::lqr::Lqr;
use crate::model::KnownHand;
use crate::plant::{Plant, PlantParams};
use crate::record::TrialKind;
use crate::truth::TrueRegression;

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
) -> anyhow::Result<Vec<SensitivityRow>> {
    cfg.validate()?;
    anyhow::ensure!(seeds >= 1, "sensitivity needs at least one seed");
    let (demo, _) = demonstrate(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance)
        .ok_or_else(|| anyhow::anyhow!("the human's balancing controller could not be designed"))?;
    let lqr = Lqr::design(&cfg.robot, [10.0, 1.0, 1.0, 1.0], 0.1)
        .ok_or_else(|| anyhow::anyhow!("the robot's balancing controller could not be designed"))?;
    let robot = Plant::new(cfg.robot);
    perturbations
        .par_iter()
        .map(|&(parameter, factor)| {
            anyhow::ensure!(
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

/// `sensitivity.md`: one table per parameter, stamped with `version`.
pub fn markdown(rows: &[SensitivityRow], version: &str) -> String {
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
                crate::svg::num(r.plan_cost)
            );
        }
        md.push('\n');
    }
    md
}

/// The code version for stamping generated results: `git describe
/// --always --dirty` of the working directory, or `unknown`.
pub fn code_version() -> String {
    std::process::Command::new("git")
        .args(["describe", "--always", "--dirty", "--abbrev=7"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| format!("commit {}", s.trim()))
        .unwrap_or_else(|| "an unknown commit".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact model's plan succeeds on every seed; a model whose
    /// pendulum is 10 % longer fails on every seed (its plan pumps too much
    /// energy); a bad factor is an error naming the parameter.
    #[test]
    fn exact_model_works_and_a_ten_percent_error_does_not() {
        let cfg = Config::default();
        let rows =
            open_loop_tolerance(&cfg, &[(Parameter::Length, 1.0), (Parameter::Length, 1.1)], 2).expect("tolerance");
        assert_eq!(rows[0].successes, 2, "{:?}", rows[0]);
        assert_eq!(rows[1].successes, 0, "{:?}", rows[1]);
        assert!(rows[1].max_angles.iter().all(|a| *a > 200.0), "{:?}", rows[1]);
        let md = markdown(&rows, "commit test");
        assert!(md.contains("| 1 | 2/2 |") && md.contains("| 1.1 | 0/2 |"), "{md}");
        let e = open_loop_tolerance(&cfg, &[(Parameter::Gravity, -1.0)], 1)
            .expect_err("negative")
            .to_string();
        assert!(e.contains("gravity"), "{e}");
    }
}
