//! A learning run's figures: `figure3`, `learning` and `diagnostics`.

use plotters::coord::Shift;
use plotters::prelude::{BLACK, Circle, Color, DrawingArea, DrawingBackend, EmptyElement, Rectangle, WHITE};
use plotters::style::text_anchor::{HPos, VPos};

use super::axis::{Axis, Panel, Swatch, colour, font, heading, legend, range, text};
use super::{Figure, Plot, Result, render};
use crate::diagnostics::OUTSIDE_SUPPORT;
use crate::record::{RunRecord, TrialDiagnostics, TrialRecord};

/// Seconds covered by `n_samples` states `dt` apart.
fn duration(n_samples: usize, dt: f64) -> f64 {
    n_samples.saturating_sub(1) as f64 * dt
}

/// The label of trial `t` in a legend, ticked if it succeeded.
fn trial_label(t: &TrialRecord) -> String {
    if t.success {
        format!("trial {} ✓", t.index)
    } else {
        format!("trial {}", t.index)
    }
}

/// The paper's Figure 3: hand position $x(t)$ (top) and pendulum angle
/// $\theta(t)$ in degrees (bottom) for every trial, the demonstration
/// dotted black, on a shared time axis covering the longest trial. Each
/// panel has one line per trial (in [`super::PALETTE`]'s colours, by
/// trial) and the dotted demonstration; the legend names them.
///
/// # Errors
/// [`super::PlotError`] if drawing fails; a run without trials draws
/// the demonstration alone.
pub fn figure3(run: &RunRecord) -> Result<Plot> {
    render(&Figure3(run))
}

struct Figure3<'a>(&'a RunRecord);

impl Figure for Figure3<'_> {
    fn size(&self) -> (u32, u32) {
        (800, 500)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let run = self.0;
        let demo = &run.demonstration;
        let t_end = run
            .trials
            .iter()
            .map(|t| duration(t.states.len(), t.dt))
            .chain(std::iter::once(duration(demo.states.len(), demo.dt)))
            .filter(|d| d.is_finite())
            .fold(0.0, f64::max);
        let t_end = if t_end > 0.0 { t_end } else { 1.0 };
        let all_states = || {
            run.trials
                .iter()
                .flat_map(|t| t.states.iter())
                .chain(demo.states.iter())
        };
        let hand = range(all_states().map(|s| s[2]), &[0.0], 0.05);
        let angle = range(all_states().map(|s| s[0].to_degrees()), &[0.0, 180.0], 0.05);
        let time = Axis::linear((0.0, t_end), 8);
        let top = Panel::new((75, 40, 570, 185), time.clone(), Axis::linear(hand, 5))
            .no_x_labels()
            .y_title("hand position x (m)");
        let bottom = Panel::new((75, 250, 570, 195), time, Axis::linear(angle, 5))
            .y_title("pendulum angle θ (°)")
            .x_title("time (s)");

        heading(
            root,
            top.centre(),
            "Hand and pendulum motion per trial (demonstration dotted)",
        )?;
        for (panel, channel, degrees) in [(&top, 2, false), (&bottom, 0, true)] {
            let mut chart = panel.draw(root)?;
            if degrees {
                panel.reference(root, &mut chart, 180.0, "upright")?;
                panel.reference(root, &mut chart, -180.0, "upright")?;
            }
            let value = |s: &[f64; 4]| if degrees { s[channel].to_degrees() } else { s[channel] };
            for (i, t) in run.trials.iter().enumerate() {
                let xy = t.states.iter().enumerate().map(|(k, s)| (k as f64 * t.dt, value(s)));
                panel.line(&mut chart, xy, colour(i).stroke_width(2))?;
            }
            let xy = demo
                .states
                .iter()
                .enumerate()
                .map(|(k, s)| (k as f64 * demo.dt, value(s)));
            panel.dotted(&mut chart, xy, BLACK.stroke_width(2))?;
        }
        let mut entries = vec![(Swatch::Dotted(BLACK, 2), "demonstration".to_string())];
        entries.extend(
            run.trials
                .iter()
                .enumerate()
                .map(|(i, t)| (Swatch::Line(colour(i), 2), trial_label(t))),
        );
        legend(root, (665, 50), &entries)
    }
}

/// Learning progress: the largest angle reached per trial (degrees; filled
/// markers for successes, open ones for failures, dashed lines at 90°,
/// halfway, and 180°, upright), and below it the inconsistency of each
/// planned trial's plan (log scale if the values span two decades or more;
/// zero and non-finite values are left out). One circle per trial with a
/// finite angle in the top panel, one line in each panel.
///
/// # Errors
/// [`super::PlotError`] if drawing fails; a run without trials draws
/// empty panels.
pub fn learning(run: &RunRecord) -> Result<Plot> {
    render(&Learning(run))
}

struct Learning<'a>(&'a RunRecord);

impl Figure for Learning<'_> {
    fn size(&self) -> (u32, u32) {
        (800, 500)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let run = self.0;
        let n = run.trials.len();
        let trial_x = |t: &TrialRecord| t.index as f64;
        let x_range = match (run.trials.first(), run.trials.last()) {
            (Some(a), Some(b)) if b.index > a.index => (a.index as f64 - 0.5, b.index as f64 + 0.5),
            (Some(a), _) => (a.index as f64 - 0.5, a.index as f64 + 0.5),
            _ => (0.5, 1.5),
        };
        let x_ticks: Vec<(f64, String)> = {
            let (a, b) = (x_range.0.ceil() as usize, x_range.1.floor() as usize);
            let every = (b.saturating_sub(a) / 15 + 1).max(1);
            (a..=b).step_by(every).map(|i| (i as f64, i.to_string())).collect()
        };
        let x = Axis::with_ticks(x_range, x_ticks);
        let angles = range(run.trials.iter().map(|t| t.max_angle.to_degrees()), &[0.0, 180.0], 0.05);
        let top = Panel::new((75, 40, 600, 260), x.clone(), Axis::linear(angles, 5)).y_title("max angle |θ| (°)");

        let incons: Vec<(f64, f64)> = run
            .trials
            .iter()
            .filter_map(|t| t.plan.as_ref().map(|p| (trial_x(t), p.inconsistency)))
            .collect();
        let finite: Vec<f64> = incons.iter().map(|p| p.1).filter(|v| v.is_finite()).collect();
        let positive: Vec<f64> = finite.iter().copied().filter(|v| *v > 0.0).collect();
        let (pmin, pmax) = positive
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
        let log_y = positive.len() >= 2 && pmax / pmin >= 100.0;
        let y = if log_y {
            Axis::log((10f64.powf(pmin.log10().floor()), 10f64.powf(pmax.log10().ceil())))
        } else {
            Axis::linear(range(finite.iter().copied(), &[0.0], 0.1), 4)
        };
        let bottom = Panel::new((75, 345, 600, 105), x, y)
            .y_title("inconsistency")
            .x_title("trial");

        heading(root, top.centre(), "Largest pendulum angle per trial")?;
        let mut chart = top.draw(root)?;
        top.reference(root, &mut chart, 90.0, "halfway")?;
        top.reference(root, &mut chart, 180.0, "upright")?;
        let angle = |t: &TrialRecord| (trial_x(t), t.max_angle.to_degrees());
        top.line(&mut chart, run.trials.iter().map(angle), colour(0).stroke_width(2))?;
        let markers = run.trials.iter().filter_map(|t| {
            let (x, y) = top.points([angle(t)]).pop()?;
            let style = if t.success {
                colour(0).filled()
            } else {
                colour(0).stroke_width(2)
            };
            Some(Circle::new((x, y), 5, style))
        });
        chart.draw_series(markers)?;

        let mut chart = bottom.draw(root)?;
        let note = format!("plan inconsistency{}", if log_y { " (log scale)" } else { "" });
        text(root, &note, (81, 339), &font(12.0, HPos::Left, VPos::Bottom))?;
        if incons.is_empty() {
            let style = font(12.0, HPos::Center, VPos::Center).color(&super::axis::NOTE);
            text(root, "no planned trials", (bottom.centre(), 397), &style)?;
        } else {
            bottom.line(&mut chart, incons.iter().copied(), colour(3).stroke_width(2))?;
            let squares = bottom
                .points(incons.iter().copied())
                .into_iter()
                .map(|p| EmptyElement::at(p) + Rectangle::new([(-3, -3), (3, 3)], colour(3).filled()));
            chart.draw_series(squares)?;
        }

        let entries = [
            (Swatch::Filled(colour(0)), "success".to_string()),
            (Swatch::Open(colour(0)), "failure".to_string()),
        ];
        legend(root, (690, 54), &entries)?;
        let count = format!("{n} trial{}", if n == 1 { "" } else { "s" });
        text(root, &count, (690, 94), &font(12.0, HPos::Left, VPos::Center))?;
        Ok(())
    }
}

/// `diagnostics`: per planned trial (one colour each), the model's support
/// along the plan (top, log scale, with the support below which a sample
/// counts as outside the data), the model's error against the observed
/// next angular velocity along what the robot did (middle), and the plan's
/// per-step inconsistency (bottom), against the sample index. One line per
/// trial and panel.
///
/// # Errors
/// [`super::PlotError`] if drawing fails; a run without diagnosed trials
/// draws empty panels.
pub fn diagnostics(run: &RunRecord) -> Result<Plot> {
    render(&Diagnostics(run))
}

struct Diagnostics<'a>(&'a RunRecord);

/// Panels' height and the gap between them in the diagnostics figure.
const DIAG_PANEL: (i32, i32) = (150, 45);

impl Figure for Diagnostics<'_> {
    fn size(&self) -> (u32, u32) {
        (820, (40 + 3 * (DIAG_PANEL.0 + DIAG_PANEL.1) + 20) as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let trials: Vec<(&TrialRecord, &TrialDiagnostics)> = self
            .0
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
        let supports: Vec<f64> = trials
            .iter()
            .flat_map(|(_, d)| d.plan_support.iter().copied())
            .filter(|x| x.is_finite() && *x > 0.0)
            .collect();
        let support_y = if supports.is_empty() {
            (0.1, 10.0)
        } else {
            let (smin, smax) = supports
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
            (
                10f64.powf(smin.max(1e-3).log10().floor()),
                10f64.powf(smax.max(10.0).log10().ceil()),
            )
        };
        let (height, gap) = DIAG_PANEL;
        let (left, width) = (80, 620);
        let x = Axis::linear((0.0, n as f64), 8);
        let linear = |f: fn(&TrialDiagnostics) -> &Vec<f64>| {
            Axis::linear(
                range(trials.iter().flat_map(|(_, d)| f(d).iter().copied()), &[0.0], 0.05),
                4,
            )
        };
        let panels = [
            Panel::new((left, 40, width, height), x.clone(), Axis::log(support_y)),
            Panel::new(
                (left, 40 + height + gap, width, height),
                x.clone(),
                linear(|d| &d.executed_error),
            ),
            Panel::new(
                (left, 40 + 2 * (height + gap), width, height),
                x,
                linear(|d| &d.plan_inconsistency),
            ),
        ];
        let titles = [
            "model support along the plan (points)",
            "model error along the robot's trajectory (rad/s per sample)",
            "plan inconsistency per step (rate units)",
        ];
        root.fill(&WHITE)?;
        for (k, (p, title)) in panels.iter().zip(titles).enumerate() {
            let mut chart = p.draw(root)?;
            text(
                root,
                title,
                (p.centre(), p.rect.1 - 8),
                &font(13.0, HPos::Center, VPos::Bottom),
            )?;
            if k == 0 {
                p.reference(root, &mut chart, OUTSIDE_SUPPORT, "outside")?;
            }
            for (i, (_, d)) in trials.iter().enumerate() {
                let v: &[f64] = match k {
                    0 => &d.plan_support,
                    1 => &d.executed_error,
                    _ => &d.plan_inconsistency,
                };
                let xy = v.iter().enumerate().map(|(k, y)| (k as f64, *y));
                p.line(&mut chart, xy, colour(i).stroke_width(2))?;
            }
        }
        let entries: Vec<(Swatch, String)> = trials
            .iter()
            .enumerate()
            .map(|(i, (t, _))| (Swatch::Line(colour(i), 2), format!("trial {}", t.index)))
            .collect();
        legend(root, (left + width + 15, 50), &entries)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::plot::testing::{assert_plot, attr, elements, texts};
    use crate::plant::demo::Demonstration;
    use crate::record::{PlanSummary, TrialKind, TrialTiming};

    fn stroke(i: usize) -> String {
        let (r, g, b) = crate::output::plot::PALETTE[i];
        format!("stroke=\"#{r:02X}{g:02X}{b:02X}\"")
    }

    fn diagnostics_of(n: usize, scale: f64) -> TrialDiagnostics {
        let v = |f: fn(usize) -> f64| (0..n).map(|k| scale * f(k)).collect::<Vec<_>>();
        TrialDiagnostics {
            start_offset: vec![0.0; 4],
            plan_support: v(|k| 0.2 + k as f64),
            plan_std_error: v(|_| 0.1),
            plan_inconsistency: v(|k| 0.01 * k as f64),
            executed_support: v(|_| 2.0),
            executed_std_error: v(|_| 0.1),
            executed_error: v(|k| 0.1 - 0.02 * k as f64),
            angle_gap: v(|_| 0.0),
        }
    }

    fn trial(index: usize, max_angle: f64, inconsistency: Option<f64>) -> TrialRecord {
        let states: Vec<[f64; 4]> = (0..30).map(|k| [0.1 * k as f64, 0.0, 0.01 * k as f64, 0.0]).collect();
        TrialRecord {
            index,
            kind: if inconsistency.is_some() {
                TrialKind::Planned
            } else {
                TrialKind::Imitation
            },
            dt: 0.1,
            observed: states.clone(),
            states,
            commands: vec![0.0; 29],
            caught_at: None,
            max_angle,
            success: max_angle > 3.0,
            failure: String::new(),
            plan: inconsistency.map(|inconsistency| PlanSummary {
                planner: "gauss-newton".into(),
                status: trajopt::GaussNewtonStatus::ConvergedCost.into(),
                cost: 1.0,
                initial_cost: 2.0,
                task: 1.0,
                inconsistency,
                max_mismatch: 0.0,
                iterations: 1,
                evaluations: 1,
                seconds: 0.0,
                states: vec![],
                controls: vec![],
                gauss_newton_cost: None,
            }),
            model: None,
            diagnostics: inconsistency.map(|_| diagnostics_of(20, index as f64)),
            timing: TrialTiming::default(),
            mpc: None,
        }
    }

    fn run(trials: Vec<TrialRecord>) -> RunRecord {
        RunRecord {
            config_toml: String::new(),
            demonstration: Demonstration {
                dt: 0.1,
                states: (0..40).map(|k| [0.08 * k as f64, 0.0, 0.0, 0.0]).collect(),
                controls: vec![0.0; 40],
            },
            trials,
            success_trial: None,
            robot_seconds: 1.0,
        }
    }

    fn three() -> RunRecord {
        run(vec![
            trial(1, 1.0, None),
            trial(2, 2.0, Some(1e-3)),
            trial(3, 3.1, Some(2e-3)),
        ])
    }

    /// Figure 3: its titles, a line per trial in each panel and in the
    /// legend, the demonstration dotted (many short dashes).
    #[test]
    fn figure3_has_a_line_per_trial_and_panel() {
        let plot = figure3(&three()).expect("figure");
        assert_plot(
            &plot,
            &[
                "Hand and pendulum motion per trial (demonstration dotted)",
                "hand position x (m)",
                "pendulum angle θ (°)",
                "time (s)",
                "demonstration",
                "trial 1",
                "trial 3 ✓",
                "upright",
            ],
        );
        assert_eq!(plot.size, (800, 500));
        for i in 0..3 {
            assert_eq!(elements(&plot.svg, "polyline", &stroke(i)).len(), 3, "trial {}", i + 1);
        }
        assert!(elements(&plot.svg, "polyline", "stroke=\"#000000\"").len() > 20);
    }

    /// The learning figure: one marker per trial, filled for a success,
    /// the reference lines, and the inconsistency on a linear scale unless
    /// it spans two decades.
    #[test]
    fn learning_marks_each_trial() {
        let mut r = three();
        let plot = learning(&r).expect("figure");
        assert_plot(
            &plot,
            &[
                "Largest pendulum angle per trial",
                "halfway",
                "upright",
                "3 trials",
                "trial",
            ],
        );
        let circles = elements(&plot.svg, "circle", "r=\"5\"");
        // three trials and two legend entries; one success and its legend
        assert_eq!(circles.len(), 5);
        assert_eq!(circles.iter().filter(|c| c.contains("stroke=\"none\"")).count(), 2);
        assert!(texts(&plot.svg).contains(&"plan inconsistency".to_string()));
        // higher angle, higher marker
        let cy: Vec<f64> = circles.iter().take(3).map(|c| attr(c, "cy")).collect();
        assert!(cy[0] > cy[1] && cy[1] > cy[2], "{cy:?}");

        if let Some(p) = r.trials[2].plan.as_mut() {
            p.inconsistency = 5.0;
        }
        let plot = learning(&r).expect("figure");
        let t = texts(&plot.svg);
        assert!(t.contains(&"plan inconsistency (log scale)".to_string()), "{t:?}");
        assert!(
            t.contains(&"1e-3".to_string()) && t.contains(&"1e1".to_string()),
            "{t:?}"
        );
    }

    /// The diagnostics figure: a line per diagnosed trial in each of the
    /// three panels, and the support's log axis.
    #[test]
    fn diagnostics_has_a_line_per_trial_and_panel() {
        let plot = diagnostics(&three()).expect("figure");
        assert_plot(
            &plot,
            &[
                "model support along the plan (points)",
                "plan inconsistency per step (rate units)",
                "trial 2",
                "trial 3",
                "outside",
                "1e0",
            ],
        );
        assert_eq!(plot.size, (820, 645));
        for i in 0..2 {
            assert_eq!(elements(&plot.svg, "polyline", &stroke(i)).len(), 4);
        }
    }

    /// No trials, or nothing but NaN: empty panels, no error, no NaN in
    /// the SVG.
    #[test]
    fn empty_and_nan_runs_draw_empty_panels() {
        let empty = run(vec![]);
        let mut nan = three();
        for t in &mut nan.trials {
            t.max_angle = f64::NAN;
            t.states.iter_mut().for_each(|s| *s = [f64::NAN; 4]);
            if let Some(p) = t.plan.as_mut() {
                p.inconsistency = f64::NAN;
            }
            if let Some(d) = t.diagnostics.as_mut() {
                *d = diagnostics_of(5, f64::NAN);
            }
        }
        nan.demonstration.states.clear();
        for r in [&empty, &nan] {
            assert_plot(&figure3(r).expect("figure3"), &["time (s)"]);
            assert_plot(&learning(r).expect("learning"), &["trial"]);
            assert_plot(&diagnostics(r).expect("diagnostics"), &["outside"]);
        }
        assert_plot(&learning(&empty).expect("learning"), &["no planned trials", "0 trials"]);
        assert!(elements(&learning(&nan).expect("learning").svg, "circle", "r=\"5\"").len() == 2);
    }
}
