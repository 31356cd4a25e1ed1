//! The experiments' figures, written next to `experiments.json` by
//! `swingup experiments`: `variants`, `lambda` and `relevance`.

use plotters::coord::Shift;
use plotters::prelude::{Circle, Color, DrawingArea, DrawingBackend, EmptyElement, Rectangle};
use plotters::style::text_anchor::{HPos, VPos};

use super::axis::{Axis, Panel, Swatch, colour, font, heading, legend, range, text};
use super::{Figure, Plot, PlotError, Result, render};
use crate::experiments::{ExperimentsReport, RunSummary, VariantSummary};
use crate::models::INPUTS;

/// The file stems of the figures [`experiment_figures`] draws for
/// `report`, without drawing them: `variants`, `lambda`, `relevance`, for
/// the experiments that ran.
pub fn experiment_figure_stems(report: &ExperimentsReport) -> Vec<&'static str> {
    let mut out = Vec::new();
    if !report.variants.is_empty() {
        out.push("variants");
    }
    if !lambda_sweep(report).is_empty() {
        out.push("lambda");
    }
    if !relevance_means(&report.runs).is_empty() {
        out.push("relevance");
    }
    out
}

/// The figures of `report` for the experiments that ran, as (file stem,
/// plot), in the order of [`experiment_figure_stems`].
///
/// # Errors
/// [`PlotError`] if drawing fails.
pub fn experiment_figures(report: &ExperimentsReport) -> Result<Vec<(&'static str, Plot)>> {
    experiment_figure_stems(report)
        .into_iter()
        .map(|stem| {
            let plot = match stem {
                "variants" => variants(&report.variants),
                "lambda" => lambda(report),
                _ => relevance(&report.runs),
            };
            plot.map(|p| (stem, p))
        })
        .collect()
}

/// The share of `v`'s runs that succeeded (0 for no runs).
pub(crate) fn rate(v: &VariantSummary) -> f64 {
    if v.runs == 0 {
        0.0
    } else {
        v.successes as f64 / v.runs as f64
    }
}

/// One horizontal bar per variant, coloured by experiment: its success
/// rate, labelled with `successes/runs` and the median trial of success.
///
/// # Errors
/// [`PlotError::NoData`] for no variants.
pub fn variants(variants: &[VariantSummary]) -> Result<Plot> {
    if variants.is_empty() {
        return Err(PlotError::NoData("variants"));
    }
    render(&Variants(variants))
}

struct Variants<'a>(&'a [VariantSummary]);

/// Height of a variant's row in pixels.
const ROW: i32 = 20;

impl Figure for Variants<'_> {
    fn size(&self) -> (u32, u32) {
        (800, (50 + ROW * self.0.len() as i32 + 60) as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let n = self.0.len();
        let (left, top, width) = (330, 50, 330);
        let panel = Panel::new(
            (left, top, width, ROW * n as i32),
            Axis::linear((0.0, 1.0), 5),
            Axis::with_ticks((0.0, n as f64), vec![]),
        )
        .x_title("success rate");
        heading(root, 400, "Success rate per variant (successes/runs, median trial)")?;
        let mut chart = panel.draw(root)?;
        let mut experiment = "";
        let mut group = 0;
        let mut bars = Vec::with_capacity(n);
        for (i, v) in self.0.iter().enumerate() {
            if v.experiment != experiment {
                experiment = &v.experiment;
                group += 1;
            }
            // row i from the top: y from n - i - 1 to n - i, inset 3 pixels
            let y = (n - i) as f64;
            bars.push(Rectangle::new(
                [(0.0, y - 0.85), (rate(v), y - 0.15)],
                colour(group - 1).filled(),
            ));
            let row_y = top + ROW * i as i32 + ROW / 2;
            let name = format!("{}: {}", v.experiment, v.variant);
            text(root, &name, (left - 8, row_y), &font(12.0, HPos::Right, VPos::Center))?;
            let counts = format!(
                "{}/{}{}",
                v.successes,
                v.runs,
                v.median_trials.map_or(String::new(), |m| format!(", trial {m}"))
            );
            text(
                root,
                &counts,
                (left + width + 8, row_y),
                &font(12.0, HPos::Left, VPos::Center),
            )?;
        }
        chart.draw_series(bars)?;
        Ok(())
    }
}

/// The swept $\lambda$ values that ran, in the sweep's order, with their variant.
pub(crate) fn lambda_sweep(report: &ExperimentsReport) -> Vec<(f64, &VariantSummary)> {
    report
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
        .collect()
}

/// The `lambda` experiment: success rate (top, one filled circle per
/// $\lambda$ that ran) and median trial of success (bottom) per
/// $\lambda$, equally spaced in the order of the sweep.
///
/// # Errors
/// [`PlotError::NoData`] if no swept $\lambda$ ran.
pub fn lambda(report: &ExperimentsReport) -> Result<Plot> {
    let sweep = lambda_sweep(report);
    if sweep.is_empty() {
        return Err(PlotError::NoData("lambda"));
    }
    render(&Lambda(sweep))
}

struct Lambda<'a>(Vec<(f64, &'a VariantSummary)>);

impl Figure for Lambda<'_> {
    fn size(&self) -> (u32, u32) {
        (800, 500)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let sweep = &self.0;
        let n = sweep.len();
        let labels: Vec<(f64, String)> = sweep
            .iter()
            .enumerate()
            .map(|(i, (l, _))| {
                let label = if *l == 0.0 {
                    "0".to_string()
                } else {
                    format!("1e{}", l.log10().round())
                };
                (i as f64, label)
            })
            .collect();
        let x = Axis::with_ticks((-0.5, n as f64 - 0.5), labels);
        let trials = range(sweep.iter().filter_map(|(_, v)| v.median_trials), &[1.0], 0.1);
        let top = Panel::new((75, 40, 600, 230), x.clone(), Axis::linear((0.0, 1.05), 5))
            .no_x_labels()
            .y_title("success rate");
        let bottom = Panel::new((75, 310, 600, 130), x, Axis::linear(trials, 4))
            .y_title("median trial")
            .x_title("λ");
        let runs = sweep.iter().map(|(_, v)| v.runs).max().unwrap_or(0);
        heading(
            root,
            top.centre(),
            &format!("Learning against the consistency weight λ ({runs} runs per λ)"),
        )?;
        let mut chart = top.draw(root)?;
        let rates: Vec<(f64, f64)> = sweep
            .iter()
            .enumerate()
            .map(|(i, (_, v))| (i as f64, rate(v)))
            .collect();
        top.line(&mut chart, rates.iter().copied(), colour(0).stroke_width(2))?;
        chart.draw_series(
            top.points(rates)
                .into_iter()
                .map(|p| Circle::new(p, 5, colour(0).filled())),
        )?;
        let mut chart = bottom.draw(root)?;
        let medians = sweep
            .iter()
            .enumerate()
            .filter_map(|(i, (_, v))| Some((i as f64, v.median_trials?)));
        chart.draw_series(
            bottom
                .points(medians)
                .into_iter()
                .map(|p| EmptyElement::at(p) + Rectangle::new([(-4, -4), (4, 4)], colour(1).filled())),
        )?;
        Ok(())
    }
}

/// Per number of trials a model was learned from: the mean tuned scale of
/// each input and the share of models that set it to 0.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Relevance {
    /// Trials the models were learned from.
    pub(crate) trials: f64,
    /// Mean scale per input ([`INPUTS`]).
    pub(crate) scale: [f64; 5],
    /// Share of the models with scale 0, per input.
    pub(crate) zero: [f64; 5],
    /// Models averaged.
    pub(crate) models: usize,
}

/// [`Relevance`] over the `learning` Gauss-Newton/B-spline runs; models
/// with a non-finite scale or the wrong number of inputs are left out.
pub(crate) fn relevance_means(runs: &[RunSummary]) -> Vec<Relevance> {
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
    sums.iter()
        .enumerate()
        .filter(|(_, (_, _, n))| *n > 0)
        .map(|(j, (s, z, n))| Relevance {
            trials: (j + 1) as f64,
            scale: s.map(|v| v / *n as f64),
            zero: z.map(|v| v as f64 / *n as f64),
            models: *n,
        })
        .collect()
}

/// C7: over the `learning` Gauss-Newton/B-spline runs, against the number
/// of trials the model was learned from, the mean tuned scale of each input
/// relative to its spread (top) and the fraction of models that set it to
/// 0, i.e. found the input irrelevant (bottom); one line per input in each
/// panel (`relevance_means`).
///
/// # Errors
/// [`PlotError::NoData`] if no such run has a model.
pub fn relevance(runs: &[RunSummary]) -> Result<Plot> {
    let means = relevance_means(runs);
    if means.is_empty() {
        return Err(PlotError::NoData("relevance"));
    }
    render(&RelevanceFigure(means))
}

struct RelevanceFigure(Vec<Relevance>);

impl Figure for RelevanceFigure {
    fn size(&self) -> (u32, u32) {
        (800, 500)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()> {
        let means = &self.0;
        let last = means.last().map_or(1.0, |m| m.trials);
        let ticks = means.iter().map(|m| (m.trials, format!("{}", m.trials))).collect();
        let x = Axis::with_ticks((0.5, last + 0.5), ticks);
        let scales = range(means.iter().flat_map(|m| m.scale), &[0.0], 0.05);
        let top = Panel::new((75, 40, 560, 250), x.clone(), Axis::linear(scales, 5))
            .no_x_labels()
            .y_title("scale × spread");
        let models = means.iter().map(|m| m.models.to_string()).collect::<Vec<_>>();
        let bottom = Panel::new((75, 320, 560, 120), x, Axis::linear((0.0, 1.0), 4))
            .y_title("share at 0")
            .x_title(&format!(
                "trials the model was learned from (models averaged: {})",
                models.join(", ")
            ));
        heading(
            root,
            top.centre(),
            "Tuned metric scale per input (mean over runs; 0 = irrelevant)",
        )?;
        let mut upper = top.draw(root)?;
        let mut lower = bottom.draw(root)?;
        for i in 0..INPUTS.len() {
            let style = colour(i).stroke_width(2);
            top.line(&mut upper, means.iter().map(|m| (m.trials, m.scale[i])), style)?;
            bottom.line(&mut lower, means.iter().map(|m| (m.trials, m.zero[i])), style)?;
        }
        let entries: Vec<(Swatch, String)> = INPUTS
            .iter()
            .enumerate()
            .map(|(i, name)| (Swatch::Line(colour(i), 2), name.to_string()))
            .collect();
        legend(root, (655, 54), &entries)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiments::ExperimentSettings;
    use crate::output::plot::testing::{assert_plot, attr, elements};

    fn fill(i: usize) -> String {
        let (r, g, b) = crate::output::plot::PALETTE[i];
        format!("fill=\"#{r:02X}{g:02X}{b:02X}\"")
    }

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
            scales,
            code_version: "commit test".into(),
            ..Default::default()
        }
    }

    fn report(variants: Vec<VariantSummary>) -> ExperimentsReport {
        let mut settings = ExperimentSettings::quick();
        settings.lambdas = vec![0.0, 1e3, 1e8];
        ExperimentsReport {
            settings,
            experiments: vec![],
            runs: vec![],
            variants,
            claims: vec![],
            seconds: 0.0,
            threads: 1,
            ran: Some(0),
            task_times: vec![],
            missing: vec![],
        }
    }

    /// Bar widths are the success rates, on the panel's 330-pixel scale;
    /// each bar is labelled with its variant and counts.
    #[test]
    fn bars_are_success_rates() {
        let vs = vec![
            variant("lambda", "lambda=0e0", 4, 0),
            variant("lambda", "lambda=1e3", 4, 3),
            variant("planner", "ddp", 0, 0),
        ];
        let plot = variants(&vs).expect("figure");
        assert_plot(
            &plot,
            &[
                "Success rate per variant (successes/runs, median trial)",
                "success rate",
                "lambda: lambda=0e0",
                "0/4",
                "3/4, trial 3",
                "planner: ddp",
            ],
        );
        assert_eq!(plot.size, (800, 50 + 3 * 20 + 60));
        let widths: Vec<f64> = elements(&plot.svg, "rect", &fill(0))
            .iter()
            .map(|r| attr(r, "width"))
            .collect();
        assert_eq!(widths.len(), 2, "one bar per variant of the first experiment");
        assert!(widths[0].abs() <= 1.0, "{widths:?}");
        assert!((widths[1] - 0.75 * 330.0).abs() <= 1.0, "{widths:?}");
        // the second experiment has the next colour; no runs is a rate of 0
        assert_eq!(elements(&plot.svg, "rect", &fill(1)).len(), 1);
        assert!(matches!(variants(&[]), Err(PlotError::NoData("variants"))));
    }

    /// The lambda figure has one marker per swept lambda that ran, in the
    /// sweep's order, higher for the higher success rate.
    #[test]
    fn lambda_figure_follows_the_sweep() {
        let r = report(vec![
            variant("lambda", "lambda=0e0", 2, 0),
            variant("lambda", "lambda=1e3", 2, 2),
        ]);
        assert_eq!(lambda_sweep(&r).iter().map(|(l, _)| *l).collect::<Vec<_>>(), [0.0, 1e3]);
        let plot = lambda(&r).expect("figure");
        assert_plot(
            &plot,
            &[
                "Learning against the consistency weight λ (2 runs per λ)",
                "success rate",
                "median trial",
                "λ",
                "0",
                "1e3",
            ],
        );
        let cy: Vec<f64> = elements(&plot.svg, "circle", &fill(0))
            .iter()
            .map(|c| attr(c, "cy"))
            .collect();
        assert_eq!(cy.len(), 2, "1e8 did not run");
        assert!(cy[1] < cy[0], "success plots higher: {cy:?}");
        assert!(matches!(lambda(&report(vec![])), Err(PlotError::NoData("lambda"))));
    }

    /// The relevance lines average the runs per trial count; models with
    /// NaN scales are left out.
    #[test]
    fn relevance_averages_runs() {
        let runs = vec![
            run(vec![vec![1.0, 1.0, 0.0, 0.0, 1.0], vec![2.0, 0.0, 0.0, 0.0, 1.0]]),
            run(vec![vec![3.0, 1.0, 2.0, 0.0, 1.0]]),
            run(vec![vec![f64::NAN; 5]]),
        ];
        let means = relevance_means(&runs);
        assert_eq!(means.len(), 2);
        assert_eq!(means[0].models, 2);
        // theta: means 2 (after 1 trial) and 2 (after 2)
        assert_eq!((means[0].scale[0], means[1].scale[0]), (2.0, 2.0));
        // x: zero in 1 of 2 models after 1 trial, 1 of 1 after 2
        assert_eq!((means[0].zero[2], means[1].zero[2]), (0.5, 1.0));
        let plot = relevance(&runs).expect("figure");
        assert_plot(
            &plot,
            &[
                "Tuned metric scale per input (mean over runs; 0 = irrelevant)",
                "scale × spread",
                "share at 0",
                "trials the model was learned from (models averaged: 2, 1)",
                "theta",
                "x_dot",
            ],
        );
        // per input: a line in each panel and the legend's
        let stroke = |i: usize| fill(i).replace("fill", "stroke");
        for i in 0..5 {
            assert_eq!(elements(&plot.svg, "polyline", &stroke(i)).len(), 3, "input {i}");
        }
        // x's share at 0 on the bottom panel, 320..440 px for 1..0
        let line = elements(&plot.svg, "polyline", &stroke(2))[1];
        let ys: Vec<f64> = line
            .split("points=\"")
            .nth(1)
            .and_then(|p| p.split('"').next())
            .expect("points")
            .split_whitespace()
            .map(|p| p.split(',').nth(1).and_then(|y| y.parse().ok()).expect("y"))
            .collect();
        assert!((ys[0] - 380.0).abs() <= 1.0 && (ys[1] - 320.0).abs() <= 1.0, "{ys:?}");
        assert!(matches!(relevance(&[]), Err(PlotError::NoData("relevance"))));
    }

    /// Only the figures whose experiment ran are returned.
    #[test]
    fn experiment_figures_leave_out_what_did_not_run() {
        let r = report(vec![variant("lambda", "lambda=1e3", 2, 1)]);
        let stems: Vec<&str> = experiment_figures(&r).expect("figures").iter().map(|f| f.0).collect();
        assert_eq!(stems, ["variants", "lambda"]);
        assert_eq!(experiment_figure_stems(&r), stems);
        assert!(experiment_figures(&report(vec![])).expect("figures").is_empty());
    }
}
