//! The experiments' figures, plain SVG written next to `experiments.json`
//! by `swingup experiments`.
//!
//! | file | content |
//! |---|---|
//! | `variants.svg` | success rate of every variant, with its successes and runs (C2, C6, beyond) |
//! | `lambda.svg` | success rate and median trial of success against $\lambda$ (C3-C5) |
//! | `relevance.svg` | mean cross-validated scale of each input by trial, relative to the input's spread, and the share of models that set it to 0 (C7) |
//!
//! A figure whose experiment did not run is not written.

use std::fmt::Write as _;

use crate::experiments::{ExperimentsReport, RunSummary, VariantSummary};
use crate::models::INPUTS;
use crate::output::svg::{Panel, WIDTH, colour, heading, legend_entry, nice_ticks, range, svg_open_sized, xml};

/// The figures of `report`: (file name, SVG text), for the experiments that ran.
pub fn figures(report: &ExperimentsReport) -> Vec<(&'static str, String)> {
    let mut out = Vec::new();
    if !report.variants.is_empty() {
        out.push(("variants.svg", variants_svg(&report.variants)));
    }
    if let Some(svg) = lambda_svg(report) {
        out.push(("lambda.svg", svg));
    }
    if let Some(svg) = relevance_svg(&report.runs) {
        out.push(("relevance.svg", svg));
    }
    out
}

fn rate(v: &VariantSummary) -> f64 {
    if v.runs == 0 {
        0.0
    } else {
        v.successes as f64 / v.runs as f64
    }
}

/// One horizontal bar per variant: its success rate, labelled with
/// `successes/runs` and the median trial of success. One `<rect
/// class="bar">` per variant.
pub fn variants_svg(variants: &[VariantSummary]) -> String {
    let row = 20.0;
    let (left, top, plot_w) = (330.0, 50.0, 330.0);
    let height = top + row * variants.len() as f64 + 60.0;
    let panel = Panel {
        left,
        top,
        width: plot_w,
        height: row * variants.len() as f64,
        x: (0.0, 1.0),
        y: (0.0, variants.len() as f64),
        log_y: false,
    };
    let mut svg = String::new();
    svg_open_sized(&mut svg, "Success rate per variant", WIDTH, height);
    heading(
        &mut svg,
        WIDTH / 2.0,
        "Success rate per variant (successes/runs, median trial)",
    );
    let (ticks, step) = nice_ticks(0.0, 1.0, 5);
    panel.x_axis(&mut svg, &ticks, step, true);
    let _ = writeln!(
        svg,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="13">success rate</text>"#,
        left + plot_w / 2.0,
        panel.bottom() + 36.0
    );
    let mut experiment = "";
    let mut group = 0;
    for (i, v) in variants.iter().enumerate() {
        if v.experiment != experiment {
            experiment = &v.experiment;
            group += 1;
        }
        let y = top + row * i as f64;
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="end" font-size="12">{}</text>"#,
            left - 8.0,
            y + row * 0.7,
            xml(&format!("{}: {}", v.experiment, v.variant))
        );
        let r = rate(v);
        let _ = writeln!(
            svg,
            r#"<rect class="bar" x="{left:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="{}"><title>{}</title></rect>"#,
            y + 3.0,
            r * plot_w,
            row - 6.0,
            colour(group - 1),
            xml(&format!("{}: {} of {} runs succeeded", v.variant, v.successes, v.runs))
        );
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{:.1}" font-size="12">{}</text>"#,
            left + plot_w + 8.0,
            y + row * 0.7,
            xml(&format!(
                "{}/{}{}",
                v.successes,
                v.runs,
                v.median_trials.map_or(String::new(), |m| format!(", trial {m}"))
            ))
        );
    }
    svg.push_str("</svg>\n");
    svg
}

/// The `lambda` experiment: success rate (top) and median trial of success
/// (bottom) per $\lambda$, equally spaced in the order of the sweep. One
/// `<circle class="rate">` per $\lambda$ that ran.
pub fn lambda_svg(report: &ExperimentsReport) -> Option<String> {
    let sweep: Vec<(f64, &VariantSummary)> = report
        .settings
        .lambdas
        .iter()
        .filter_map(|&l| {
            report
                .variants
                .iter()
                .find(|v| v.experiment == "lambda" && v.variant == format!("lambda={l:e}"))
                .map(|v| (l, v))
        })
        .collect();
    if sweep.is_empty() {
        return None;
    }
    let n = sweep.len();
    let (left, plot_w) = (75.0, 600.0);
    let x = (-0.5, n as f64 - 0.5);
    let top = Panel {
        left,
        top: 40.0,
        width: plot_w,
        height: 230.0,
        x,
        y: (0.0, 1.05),
        log_y: false,
    };
    let trials = range(sweep.iter().filter_map(|(_, v)| v.median_trials), &[1.0], 0.1);
    let bottom = Panel {
        left,
        top: 310.0,
        width: plot_w,
        height: 130.0,
        x,
        y: trials,
        log_y: false,
    };
    let ticks: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let mut svg = String::new();
    svg_open_sized(&mut svg, "Success against lambda", WIDTH, 500.0);
    let runs = sweep.iter().map(|(_, v)| v.runs).max().unwrap_or(0);
    heading(
        &mut svg,
        left + plot_w / 2.0,
        &format!("Learning against the consistency weight λ ({runs} runs per λ)"),
    );
    top.axes(&mut svg, &ticks, 1.0, false);
    top.y_title(&mut svg, "success rate");
    bottom.axes(&mut svg, &ticks, 1.0, false);
    bottom.y_title(&mut svg, "median trial");
    for (i, (l, _)) in sweep.iter().enumerate() {
        let label = if *l == 0.0 {
            "0".to_string()
        } else {
            format!("1e{}", l.log10().round())
        };
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="12">{}</text>"#,
            bottom.px(i as f64),
            bottom.bottom() + 16.0,
            xml(&label)
        );
    }
    let _ = writeln!(
        svg,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="13">λ</text>"#,
        left + plot_w / 2.0,
        bottom.bottom() + 36.0
    );
    let style = format!(r#"fill="none" stroke="{}" stroke-width="1.6""#, colour(0));
    let pts = top.points(sweep.iter().enumerate().map(|(i, (_, v))| (i as f64, rate(v))));
    let _ = writeln!(svg, r#"<polyline {style} points="{pts}"/>"#);
    for (i, (l, v)) in sweep.iter().enumerate() {
        let _ = writeln!(
            svg,
            r#"<circle class="rate" cx="{:.1}" cy="{:.1}" r="5" fill="{}"><title>{}</title></circle>"#,
            top.px(i as f64),
            top.py(rate(v)),
            colour(0),
            xml(&format!("λ = {l:e}: {} of {} succeeded", v.successes, v.runs))
        );
        if let Some(m) = v.median_trials {
            let _ = writeln!(
                svg,
                r#"<rect x="{:.1}" y="{:.1}" width="8" height="8" fill="{}"/>"#,
                bottom.px(i as f64) - 4.0,
                bottom.py(m) - 4.0,
                colour(1)
            );
        }
    }
    svg.push_str("</svg>\n");
    Some(svg)
}

/// C7: over the `learning` Gauss-Newton/B-spline runs, against the number
/// of trials the model was learned from, the mean tuned scale of each input
/// relative to its spread (top) and the fraction of models that set it to
/// 0, i.e. found the input irrelevant (bottom). One `<polyline
/// class="input">` per input in the top panel, one `<polyline
/// class="zero">` per input in the bottom one.
pub fn relevance_svg(runs: &[RunSummary]) -> Option<String> {
    // scales[j] of a run is the model learned before planned trial j + 2,
    // i.e. from j + 1 trials; per j: (sum of scales, models with scale 0, models)
    let mut sums: Vec<([f64; 5], [usize; 5], usize)> = Vec::new();
    for r in runs
        .iter()
        .filter(|r| r.experiment == "learning" && r.variant == "gauss-newton/bspline")
    {
        for (j, s) in r.scales.iter().enumerate() {
            if s.len() != 5 || s.iter().any(|v| !v.is_finite()) {
                continue;
            }
            if sums.len() <= j {
                sums.resize(j + 1, ([0.0; 5], [0; 5], 0));
            }
            for (i, v) in s.iter().enumerate() {
                sums[j].0[i] += v;
                sums[j].1[i] += usize::from(*v == 0.0);
            }
            sums[j].2 += 1;
        }
    }
    // (trials learned from, mean scale, fraction zero, models)
    let means: Vec<(f64, [f64; 5], [f64; 5], usize)> = sums
        .iter()
        .enumerate()
        .filter(|(_, (_, _, n))| *n > 0)
        .map(|(j, (s, z, n))| {
            (
                (j + 1) as f64,
                s.map(|v| v / *n as f64),
                z.map(|v| v as f64 / *n as f64),
                *n,
            )
        })
        .collect();
    if means.is_empty() {
        return None;
    }
    let (left, plot_w) = (75.0, 560.0);
    let last = means.last().map_or(1.0, |m| m.0);
    let x = (0.5, last + 0.5);
    let top = Panel {
        left,
        top: 40.0,
        width: plot_w,
        height: 250.0,
        x,
        y: range(means.iter().flat_map(|m| m.1), &[0.0], 0.05),
        log_y: false,
    };
    let bottom = Panel {
        left,
        top: 320.0,
        width: plot_w,
        height: 120.0,
        x,
        y: (0.0, 1.0),
        log_y: false,
    };
    let ticks: Vec<f64> = means.iter().map(|m| m.0).collect();
    let mut svg = String::new();
    svg_open_sized(&mut svg, "Cross-validated relevance of each input", WIDTH, 500.0);
    heading(
        &mut svg,
        left + plot_w / 2.0,
        "Tuned metric scale per input (mean over runs; 0 = irrelevant)",
    );
    top.axes(&mut svg, &ticks, 1.0, false);
    top.y_title(&mut svg, "scale × spread");
    bottom.axes(&mut svg, &ticks, 1.0, true);
    bottom.y_title(&mut svg, "share at 0");
    let _ = writeln!(
        svg,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" font-size="13">trials the model was learned from (models averaged: {})</text>"#,
        left + plot_w / 2.0,
        bottom.bottom() + 36.0,
        means.iter().map(|m| m.3.to_string()).collect::<Vec<_>>().join(", ")
    );
    for (i, name) in INPUTS.iter().enumerate() {
        let style = format!(r#"fill="none" stroke="{}" stroke-width="1.8""#, colour(i));
        let pts = top.points(means.iter().map(|m| (m.0, m.1[i])));
        let _ = writeln!(svg, r#"<polyline class="input" {style} points="{pts}"/>"#);
        let pts = bottom.points(means.iter().map(|m| (m.0, m.2[i])));
        let _ = writeln!(svg, r#"<polyline class="zero" {style} points="{pts}"/>"#);
        legend_entry(&mut svg, left + plot_w + 20.0, 54.0 + 18.0 * i as f64, &style, name);
    }
    svg.push_str("</svg>\n");
    Some(svg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiments::ExperimentSettings;

    fn variant(e: &str, v: &str, runs: usize, successes: usize) -> VariantSummary {
        VariantSummary {
            experiment: e.into(),
            variant: v.into(),
            runs,
            successes,
            median_trials: (successes > 0).then_some(3.0),
            trial_range: None,
            median_robot_seconds: None,
        }
    }

    fn run(scales: Vec<Vec<f64>>) -> RunSummary {
        RunSummary {
            experiment: "learning".into(),
            variant: "gauss-newton/bspline".into(),
            seed: 1,
            success_trial: None,
            trials: scales.len() + 1,
            robot_seconds: 0.0,
            max_angles: vec![],
            plan_statuses: vec![],
            failures: vec![],
            scales,
            rollouts: vec![],
            seconds: 0.0,
            code_version: "commit test".into(),
        }
    }

    /// Bar widths are the success rates, on the panel's scale.
    #[test]
    fn bars_are_success_rates() {
        let vs = vec![
            variant("lambda", "lambda=0e0", 4, 0),
            variant("lambda", "lambda=1e3", 4, 3),
        ];
        let svg = variants_svg(&vs);
        let widths: Vec<f64> = svg
            .lines()
            .filter(|l| l.contains(r#"class="bar""#))
            .map(|l| {
                let w = l
                    .split("width=\"")
                    .nth(1)
                    .and_then(|s| s.split('"').next())
                    .expect("width");
                w.parse().expect("number")
            })
            .collect();
        assert_eq!(widths.len(), 2);
        assert!(widths[0].abs() < 1e-9, "{widths:?}");
        assert!((widths[1] - 0.75 * 330.0).abs() < 0.1, "{widths:?}");
    }

    /// The lambda figure has one marker per swept lambda that ran, in the
    /// sweep's order, higher for the higher success rate.
    #[test]
    fn lambda_figure_follows_the_sweep() {
        let mut settings = ExperimentSettings::quick();
        settings.lambdas = vec![0.0, 1e3, 1e8];
        let report = ExperimentsReport {
            settings,
            experiments: vec![],
            runs: vec![],
            variants: vec![
                variant("lambda", "lambda=0e0", 2, 0),
                variant("lambda", "lambda=1e3", 2, 2),
            ],
            claims: vec![],
            seconds: 0.0,
            threads: 1,
            ran: 0,
        };
        let svg = lambda_svg(&report).expect("figure");
        let cy: Vec<f64> = svg
            .lines()
            .filter(|l| l.contains(r#"class="rate""#))
            .map(|l| {
                let v = l.split("cy=\"").nth(1).and_then(|s| s.split('"').next()).expect("cy");
                v.parse().expect("number")
            })
            .collect();
        assert_eq!(cy.len(), 2, "1e8 did not run");
        assert!(cy[1] < cy[0], "success plots higher: {cy:?}");
        let no_lambda = ExperimentsReport {
            variants: vec![],
            ..report
        };
        assert!(lambda_svg(&no_lambda).is_none());
    }

    /// The relevance lines average the runs per trial count.
    #[test]
    fn relevance_averages_runs() {
        let runs = vec![
            run(vec![vec![1.0, 1.0, 0.0, 0.0, 1.0], vec![2.0, 0.0, 0.0, 0.0, 1.0]]),
            run(vec![vec![3.0, 1.0, 2.0, 0.0, 1.0]]),
        ];
        let svg = relevance_svg(&runs).expect("figure");
        let lines: Vec<&str> = svg.lines().filter(|l| l.contains(r#"class="input""#)).collect();
        assert_eq!(lines.len(), 5);
        // theta: means 2 (after 1 trial) and 2 (after 2) -> a flat line
        let ys: Vec<f64> = lines[0]
            .split("points=\"")
            .nth(1)
            .expect("points")
            .trim_end_matches("\"/>")
            .split(' ')
            .map(|p| p.split(',').nth(1).expect("y").parse().expect("number"))
            .collect();
        assert_eq!(ys.len(), 2);
        assert!((ys[0] - ys[1]).abs() < 1e-9, "{ys:?}");
        // x: zero in 1 of 2 models after 1 trial, 1 of 1 after 2 -> 0.5 then 1
        let zero: Vec<f64> = svg
            .lines()
            .filter(|l| l.contains(r#"class="zero""#))
            .nth(2)
            .expect("x's line")
            .split("points=\"")
            .nth(1)
            .expect("points")
            .trim_end_matches("\"/>")
            .split(' ')
            .map(|p| p.split(',').nth(1).expect("y").parse().expect("number"))
            .collect();
        // panel 320..440 px for 0..1
        assert!(
            (zero[0] - 380.0).abs() < 0.1 && (zero[1] - 320.0).abs() < 0.1,
            "{zero:?}"
        );
        assert!(relevance_svg(&[]).is_none());
    }
}
