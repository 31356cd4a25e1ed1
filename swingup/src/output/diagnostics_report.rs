//! The run report's "Plan against reality" section and the diagnostics
//! figure, from the diagnostics each planned trial recorded
//! ([`crate::diagnostics`]).

use std::fmt::Write as _;

use crate::diagnostics::{OUTSIDE_SUPPORT, SPLIT_ANGLE, median, outside, rms, split_sample};
use crate::format::num;
use crate::output::svg::{Panel, colour, legend_entry, nice_ticks, range, svg_open_sized, xml};
use crate::record::{RunRecord, TrialDiagnostics, TrialRecord};

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
    use crate::diagnostics::diagnose;
    use crate::diagnostics::tests::{linear_model, plan_of, trial_of};
    use crate::record::TrialTiming;

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
            demonstration: crate::plant::demo::Demonstration {
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
