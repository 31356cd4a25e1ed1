//! The plan against reality: what the model said along the plan, and how
//! it did along what the robot then did.
//!
//! For each planned trial, over the swing-up window ([`TrialDiagnostics`]):
//!
//! - along the plan $(s_k, u_k)$: the model's support (effective number of
//!   data points $n_{lwr} = \sum_i k_i$) and standard error of
//!   $\Delta\dot\theta$, and the plan's per-step inconsistency
//!   $\lVert s_{k+1} - f(s_k, u_k) \rVert / \Delta t$ with the model it was made with;
//! - along the observed trajectory $(o_k, u_k)$ ($u_k$ the command sent):
//!   the same support and standard error, and the model's error against
//!   the observed next state, $g(o_k, u_k) - (\dot\theta^{obs}_{k+1} -
//!   \dot\theta^{obs}_k)$, which the robot can measure (noise included);
//! - the planned minus the observed initial state, and the angle gap
//!   $|\theta^{obs}_k - \theta^{plan}_k|$, from which the sample where plan
//!   and robot split is read.
//!
//! [`crate::output::diagnostics_report`] turns them into the report's
//! "Plan against reality" section, [`crate::output::plot::diagnostics`]
//! into `diagnostics.svg` (and `.png`).

use crate::models::{KnownHand, PendulumRegression};
use crate::record::{PlanSummary, TrialDiagnostics, TrialRecord};

/// The angle gap (rad) beyond which plan and robot count as split.
pub const SPLIT_ANGLE: f64 = 0.2;

/// Support below which a sample counts as outside the data: less than one
/// data point's worth of kernel weight.
pub const OUTSIDE_SUPPORT: f64 = 1.0;

/// The diagnostics of `trial`, planned as `plan` with `model`, over the
/// first `horizon` samples (the swing-up window).
pub fn diagnose<G: PendulumRegression>(
    model: &KnownHand<G>,
    plan: &PlanSummary,
    trial: &TrialRecord,
    horizon: usize,
) -> TrialDiagnostics {
    let g = &model.regression;
    let uncertainty = |z: &[f64; 5]| g.uncertainty(z).unwrap_or((f64::NAN, f64::NAN));
    let n_plan = plan.controls.len().min(plan.states.len().saturating_sub(1));
    let (mut plan_support, mut plan_std_error, mut plan_inconsistency) = (vec![], vec![], vec![]);
    let mut next = [0.0; 4];
    for k in 0..n_plan {
        let (s, u) = (plan.states[k], plan.controls[k]);
        let (n, se) = uncertainty(&[s[0], s[1], s[2], s[3], u]);
        plan_support.push(n);
        plan_std_error.push(se);
        let mismatch = match trajopt::Dynamics::step(model, &s, &[u], &mut next) {
            Ok(()) => {
                (0..4)
                    .map(|i| (plan.states[k + 1][i] - next[i]).powi(2))
                    .sum::<f64>()
                    .sqrt()
                    / model.dt
            }
            Err(_) => f64::NAN,
        };
        plan_inconsistency.push(mismatch);
    }
    let n_exec = horizon
        .min(trial.commands.len())
        .min(trial.observed.len().saturating_sub(1));
    let (mut executed_support, mut executed_std_error, mut executed_error) = (vec![], vec![], vec![]);
    for k in 0..n_exec {
        let (o, o1, u) = (trial.observed[k], trial.observed[k + 1], trial.commands[k]);
        let z = [o[0], o[1], o[2], o[3], u];
        let (n, se) = uncertainty(&z);
        executed_support.push(n);
        executed_std_error.push(se);
        executed_error.push(g.delta_omega(&z, None) - (o1[1] - o[1]));
    }
    let angle_gap = trial
        .observed
        .iter()
        .zip(&plan.states)
        .take(horizon + 1)
        .map(|(o, p)| (o[0] - p[0]).abs())
        .collect();
    let start_offset = match (plan.states.first(), trial.observed.first()) {
        (Some(p), Some(o)) => (0..4).map(|i| p[i] - o[i]).collect(),
        _ => vec![f64::NAN; 4],
    };
    TrialDiagnostics {
        start_offset,
        plan_support,
        plan_std_error,
        plan_inconsistency,
        executed_support,
        executed_std_error,
        executed_error,
        angle_gap,
    }
}

/// The first sample where plan and robot are more than [`SPLIT_ANGLE`] apart.
pub fn split_sample(d: &TrialDiagnostics) -> Option<usize> {
    d.angle_gap.iter().position(|g| *g > SPLIT_ANGLE)
}

/// The [`median`](crate::record::median) of the finite `values`; NaN when
/// there are none.
pub(crate) fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    crate::record::median(&mut v).unwrap_or(f64::NAN)
}

pub(crate) fn rms(values: &[f64]) -> f64 {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// Samples with support below [`OUTSIDE_SUPPORT`], or NaN without a support.
pub(crate) fn outside(support: &[f64]) -> f64 {
    if support.iter().all(|n| n.is_nan()) {
        return f64::NAN;
    }
    support.iter().filter(|n| **n < OUTSIDE_SUPPORT).count() as f64
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::models::{KnownHand, LwrRegression};
    use crate::record::{PlanSummary, TrialKind, TrialTiming};

    pub(crate) fn plan_of(states: Vec<[f64; 4]>, controls: Vec<f64>) -> PlanSummary {
        PlanSummary::along(
            "gauss-newton",
            trajopt::GaussNewtonStatus::ConvergedCost.into(),
            states,
            controls,
        )
    }

    pub(crate) fn trial_of(observed: Vec<[f64; 4]>, commands: Vec<f64>) -> TrialRecord {
        TrialRecord {
            index: 2,
            kind: TrialKind::Planned,
            dt: 0.1,
            states: observed.clone(),
            observed,
            commands,
            caught_at: None,
            max_angle: 0.0,
            success: false,
            failure: String::new(),
            plan: None,
            model: None,
            diagnostics: None,
            timing: TrialTiming::default(),
            mpc: None,
        }
    }

    /// A model that knows its data exactly: $\Delta\dot\theta = -0.1 \theta + 0.02 u$.
    pub(crate) fn linear_model() -> KnownHand<LwrRegression> {
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for i in 0..200 {
            let t = i as f64 * 0.1;
            let z = [t.sin(), t.cos(), 0.0, 0.0, (1.3 * t).sin()];
            ys.push([-0.1 * z[0] + 0.02 * z[4]]);
            xs.push(z);
        }
        let settings = lwr::LwrSettings {
            kernel: lwr::Kernel::Tricube,
            bandwidth: 2.0,
            scales: vec![1.0, 1.0, 0.0, 0.0, 0.5],
            ..lwr::LwrSettings::default()
        };
        KnownHand::new(LwrRegression::fit(&xs, &ys, settings).expect("fit"), 0.1)
    }

    /// A plan that follows the model exactly is consistent; one that the
    /// robot follows with a start offset and a late split reports both;
    /// the model's error along the robot's trajectory is its error against
    /// the observed change of angular velocity.
    #[test]
    fn diagnostics_measure_what_they_say() {
        let model = linear_model();
        // roll the model out: a plan consistent with it
        let controls: Vec<f64> = (0..20).map(|k| (k as f64 * 0.3).sin()).collect();
        let mut states = vec![[0.2, 0.0, 0.0, 0.0]];
        for (k, &u) in controls.iter().enumerate() {
            let mut next = [0.0; 4];
            trajopt::Dynamics::step(&model, &states[k], &[u], &mut next).expect("step");
            states.push(next);
        }
        let plan = plan_of(states.clone(), controls.clone());
        // the robot starts 0.05 rad off and its angular velocity changes by
        // 0.01 more than the model says from sample 10, drifting apart
        let mut observed = states.clone();
        for (k, o) in observed.iter_mut().enumerate() {
            o[0] -= 0.05;
            if k > 10 {
                o[1] += 0.01 * (k - 10) as f64;
                o[0] -= 0.1 * (k - 10) as f64;
            }
        }
        let trial = trial_of(observed.clone(), controls.clone());
        let d = diagnose(&model, &plan, &trial, 20);
        assert!((d.start_offset[0] - 0.05).abs() < 1e-12);
        assert_eq!(d.plan_inconsistency.len(), 20);
        assert!(
            d.plan_inconsistency.iter().all(|m| *m < 1e-9),
            "{:?}",
            d.plan_inconsistency
        );
        assert_eq!(split_sample(&d), Some(12));
        for k in 0..20 {
            let o = observed[k];
            let z = [o[0], o[1], o[2], o[3], controls[k]];
            let expect = model.regression.delta_omega(&z, None) - (observed[k + 1][1] - o[1]);
            assert!((d.executed_error[k] - expect).abs() < 1e-12);
        }
        // the data cover the plan, not a far point
        assert!(median(&d.plan_support) > OUTSIDE_SUPPORT);
        let far = plan_of(vec![[9.0, 9.0, 0.0, 0.0]; 3], vec![9.0; 2]);
        let d_far = diagnose(&model, &far, &trial, 20);
        assert_eq!(outside(&d_far.plan_support), 2.0);
        // a plan that breaks the model's dynamics is inconsistent by as much
        let mut broken = states.clone();
        broken[5][1] += 0.3;
        let d_broken = diagnose(&model, &plan_of(broken, controls), &trial, 20);
        assert!(
            (d_broken.plan_inconsistency[4] - 0.3 / 0.1).abs() < 1e-9,
            "{}",
            d_broken.plan_inconsistency[4]
        );
    }
}
