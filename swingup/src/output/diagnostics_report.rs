//! The run report's "Plan against reality" section, from the diagnostics
//! each planned trial recorded ([`crate::diagnostics`]); the figure is
//! [`crate::output::plot::diagnostics`].

use std::fmt::Write as _;

use crate::diagnostics::{OUTSIDE_SUPPORT, SPLIT_ANGLE, median, outside, rms, split_sample};
use crate::format::num;
use crate::record::{RunRecord, TrialRecord};

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
        let plot = crate::output::plot::diagnostics(&run).expect("figure");
        let (r, g, b) = crate::output::plot::PALETTE[0];
        let trial_line = format!("stroke=\"#{r:02X}{g:02X}{b:02X}\"");
        let lines = plot
            .svg
            .lines()
            .filter(|l| l.starts_with("<polyline") && l.contains(&trial_line));
        assert_eq!(lines.count(), 3 + 1, "a line per panel, and the legend's");
        assert!(plot.svg.ends_with("</svg>\n"));
    }
}
