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
//! [`markdown_section`] and [`diagnostics_svg`] turn them into the
//! report's "Plan against reality" section and `diagnostics.svg`.

use std::fmt::Write as _;

use crate::model::{KnownHand, PendulumRegression};
use crate::record::{PlanSummary, RunRecord, TrialDiagnostics, TrialRecord};
use crate::svg::{Panel, colour, legend_entry, nice_ticks, num, range, svg_open_sized, xml};

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
        let mismatch = match trajopt::Model::step(model, &s, &[u], &mut next) {
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

fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

fn rms(values: &[f64]) -> f64 {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// Samples with support below [`OUTSIDE_SUPPORT`], or NaN without a support.
fn outside(support: &[f64]) -> f64 {
    if support.iter().all(|n| n.is_nan()) {
        return f64::NAN;
    }
    support.iter().filter(|n| **n < OUTSIDE_SUPPORT).count() as f64
}

/// A count, `—` when there is none.
fn count(v: f64) -> String {
    if v.is_finite() { format!("{v:.0}") } else { "—".into() }
}

/// The report's "Plan against reality" section and the run's time split:
/// one row per planned trial (Markdown).
pub fn markdown_section(run: &RunRecord) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "## Plan against reality\n");
    let (tuning, planning, rollout) = run.trials.iter().fold((0.0, 0.0, 0.0), |(a, b, c), t| {
        (a + t.timing.tuning, b + t.timing.planning, c + t.timing.rollout)
    });
    let _ = writeln!(
        md,
        "Wall time of the trials: {} s fitting and tuning models, {} s planning, {} s running the robot.\n",
        num(tuning),
        num(planning),
        num(rollout)
    );
    let rows: Vec<&TrialRecord> = run.trials.iter().filter(|t| t.diagnostics.is_some()).collect();
    if rows.is_empty() {
        let _ = writeln!(md, "No planned trial.\n");
        return md;
    }
    let _ = writeln!(
        md,
        "Over the swing-up window of each planned trial: along the plan, the model's support \
         (effective number of data points; \"outside\" counts samples below {OUTSIDE_SUPPORT}), \
         its standard error of Δθ̇ and the plan's inconsistency with it (rate units, as Eq. 3 \
         weighs it); along what the robot then did, the model's error against the observed \
         next angular velocity (rad/s per sample); the planned minus the observed initial angle; \
         and the first sample where plan and robot are more than {SPLIT_ANGLE} rad apart. \
         The figure is [diagnostics.svg](diagnostics.svg).\n"
    );
    let _ = writeln!(
        md,
        "| trial | start offset θ (rad) | plan: median support | plan: samples outside | \
         plan: median std. error | plan: rms inconsistency | robot: median support | \
         robot: rms model error | split at sample | tuning (s) | planning (s) | rollout (s) |"
    );
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for t in rows {
        let Some(d) = &t.diagnostics else { continue };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            t.index,
            num(d.start_offset.first().copied().unwrap_or(f64::NAN)),
            num(median(&d.plan_support)),
            count(outside(&d.plan_support)),
            num(median(&d.plan_std_error)),
            num(rms(&d.plan_inconsistency)),
            num(median(&d.executed_support)),
            num(rms(&d.executed_error)),
            split_sample(d).map_or("—".to_string(), |k| k.to_string()),
            num(t.timing.tuning),
            num(t.timing.planning),
            num(t.timing.rollout),
        );
    }
    md.push('\n');
    md
}

/// `diagnostics.svg`: per planned trial (one colour each), the model's
/// support along the plan (top, log scale), the model's error against the
/// observed next angular velocity along what the robot did (middle), and
/// the plan's per-step inconsistency (bottom), against the sample index.
pub fn diagnostics_svg(run: &RunRecord) -> String {
    let trials: Vec<(&TrialRecord, &TrialDiagnostics)> = run
        .trials
        .iter()
        .filter_map(|t| t.diagnostics.as_ref().map(|d| (t, d)))
        .collect();
    let n = trials
        .iter()
        .map(|(_, d)| d.plan_support.len().max(d.executed_error.len()))
        .max()
        .unwrap_or(1)
        .max(1);
    let (left, width, height) = (80.0, 620.0, 150.0);
    let x = (0.0, n as f64);
    let positive = |v: &[f64]| {
        v.iter()
            .copied()
            .filter(|x| x.is_finite() && *x > 0.0)
            .collect::<Vec<_>>()
    };
    let supports: Vec<f64> = trials.iter().flat_map(|(_, d)| positive(&d.plan_support)).collect();
    let (smin, smax) = supports
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
    let support_y = if supports.is_empty() {
        (0.1, 10.0)
    } else {
        (
            10f64.powf(smin.max(1e-3).log10().floor()),
            10f64.powf(smax.max(10.0).log10().ceil()),
        )
    };
    let panels = [
        Panel {
            left,
            top: 40.0,
            width,
            height,
            x,
            y: support_y,
            log_y: true,
        },
        Panel {
            left,
            top: 40.0 + height + 45.0,
            width,
            height,
            x,
            y: range(
                trials.iter().flat_map(|(_, d)| d.executed_error.iter().copied()),
                &[0.0],
                0.05,
            ),
            log_y: false,
        },
        Panel {
            left,
            top: 40.0 + 2.0 * (height + 45.0),
            width,
            height,
            x,
            y: range(
                trials.iter().flat_map(|(_, d)| d.plan_inconsistency.iter().copied()),
                &[0.0],
                0.05,
            ),
            log_y: false,
        },
    ];
    let (ticks, step) = nice_ticks(x.0, x.1, 8);
    let mut svg = String::new();
    svg_open_sized(
        &mut svg,
        "The plan against reality",
        820.0,
        40.0 + 3.0 * (height + 45.0) + 20.0,
    );
    let titles = [
        "model support along the plan (points)",
        "model error along the robot's trajectory (rad/s per sample)",
        "plan inconsistency per step (rate units)",
    ];
    for (p, title) in panels.iter().zip(titles) {
        p.axes(&mut svg, &ticks, step, true);
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{:.1}" font-size="13" text-anchor="middle">{}</text>"#,
            left + width / 2.0,
            p.top - 8.0,
            xml(title)
        );
    }
    panels[0].reference(&mut svg, OUTSIDE_SUPPORT, "outside");
    for (i, (t, d)) in trials.iter().enumerate() {
        let style = format!(r#"fill="none" stroke="{}" stroke-width="1.4""#, colour(i));
        let series: [&[f64]; 3] = [&d.plan_support, &d.executed_error, &d.plan_inconsistency];
        for (p, v) in panels.iter().zip(series) {
            let pts = p.points(
                v.iter()
                    .enumerate()
                    .filter(|(_, y)| y.is_finite() && (!p.log_y || **y > 0.0))
                    .map(|(k, y)| (k as f64, *y)),
            );
            let _ = writeln!(
                svg,
                r#"<polyline class="trial" {style} points="{pts}"><title>trial {}</title></polyline>"#,
                t.index
            );
        }
        legend_entry(
            &mut svg,
            left + width + 15.0,
            50.0 + 18.0 * i as f64,
            &style,
            &format!("trial {}", t.index),
        );
    }
    svg.push_str("</svg>\n");
    svg
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{KnownHand, LwrRegression};
    use crate::record::{PlanSummary, TrialKind, TrialTiming};

    fn plan_of(states: Vec<[f64; 4]>, controls: Vec<f64>) -> PlanSummary {
        PlanSummary {
            planner: "gauss-newton".into(),
            status: "ConvergedCost".into(),
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
        }
    }

    fn trial_of(observed: Vec<[f64; 4]>, commands: Vec<f64>) -> TrialRecord {
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
        }
    }

    /// A model that knows its data exactly: $\Delta\dot\theta = -0.1 \theta + 0.02 u$.
    fn linear_model() -> KnownHand<LwrRegression> {
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
            trajopt::Model::step(&model, &states[k], &[u], &mut next).expect("step");
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

    /// The section lists the planned trials with their time split, and the
    /// figure has one line per trial and panel.
    #[test]
    fn report_section_and_figure() {
        let model = linear_model();
        let controls = vec![0.1; 10];
        let states = vec![[0.1, 0.0, 0.0, 0.0]; 11];
        let mut trial = trial_of(states.clone(), controls.clone());
        trial.timing = TrialTiming {
            tuning: 1.5,
            planning: 2.5,
            rollout: 0.25,
        };
        trial.diagnostics = Some(diagnose(&model, &plan_of(states, controls), &trial, 10));
        let run = RunRecord {
            config_toml: String::new(),
            demonstration: crate::demo::Demonstration {
                dt: 0.1,
                states: vec![],
                controls: vec![],
            },
            trials: vec![trial],
            success_trial: None,
            robot_seconds: 1.0,
        };
        let md = markdown_section(&run);
        assert!(
            md.contains("1.500 s fitting and tuning models, 2.500 s planning, 0.2500 s running"),
            "{md}"
        );
        assert!(md.lines().any(|l| l.starts_with("| 2 |")), "{md}");
        let svg = diagnostics_svg(&run);
        assert_eq!(svg.matches(r#"<polyline class="trial""#).count(), 3);
        assert!(svg.ends_with("</svg>\n"));
    }
}
