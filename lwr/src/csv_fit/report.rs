//! The summary of a fit ([`FitReport`]) and its text form.

use std::fmt::{self, Write as _};
use std::path::PathBuf;

use serde::Serialize;

use super::{DegreeArg, KernelArg};

/// One input's normalisation and tuned metric scale.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InputScale {
    /// Column name.
    pub name: String,
    /// Its standard deviation $s_j$ over the training rows (the normalisation).
    pub spread: f64,
    /// Tuned scale relative to the normalisation, $m_j s_j$ (1 before
    /// tuning; 0: the weights ignore this input).
    pub scale: f64,
    /// Tuned metric scale $m_j$ in the input's own units.
    pub metric_scale: f64,
}

impl InputScale {
    /// The kernel's bandwidth along this input in standard deviations,
    /// $h / (m_j s_j)$ (infinite for a zero scale).
    pub fn width(&self, bandwidth: f64) -> f64 {
        if self.scale > 0.0 {
            bandwidth / self.scale
        } else {
            f64::INFINITY
        }
    }
}

/// The error on the test rows for one target.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetError {
    /// Target name.
    pub name: String,
    /// $\sum_i (y_i - \hat y_i)^2 / (n \operatorname{var} y)$ over the
    /// predicted test rows (NaN if the target is constant there).
    pub nmse: f64,
    /// Root mean squared error.
    pub rmse: f64,
    /// Fraction of the predicted rows whose value lies in the prediction
    /// interval.
    pub coverage: f64,
}

/// The outcome on the test file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TestReport {
    /// The test file.
    pub file: PathBuf,
    /// Number of test rows.
    pub n_rows: usize,
    /// Number of rows predicted (the others had no training data nearby).
    pub n_predicted: usize,
    /// Predicted rows whose fit left no degrees of freedom for a noise
    /// estimate in some target (NaN standard error, infinite interval).
    pub n_without_interval: usize,
    /// Data rows (from 1) that could not be predicted, with the reason.
    pub unpredicted: Vec<(usize, String)>,
    /// Mean over the targets present in the test file of their normalised MSE
    /// (`None` if the test file has no target column or nothing was predicted).
    pub nmse: Option<f64>,
    /// Per target present in the test file.
    pub targets: Vec<TargetError>,
}

/// Everything the fit tool found, as printed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitReport {
    /// The training file.
    pub train_file: PathBuf,
    /// Number of training rows.
    pub n_train: usize,
    /// Target names, in the order given.
    pub targets: Vec<String>,
    /// Inputs in file order, with their tuned scales.
    pub inputs: Vec<InputScale>,
    /// Kernel.
    pub kernel: KernelArg,
    /// Degree of the local polynomial.
    pub degree: DegreeArg,
    /// Tuned bandwidth $h$ (in standard deviations of the inputs, for scale 1).
    pub bandwidth: f64,
    /// Leave-one-out normalised MSE before tuning (mean over targets).
    pub initial_loo_nmse: f64,
    /// Leave-one-out normalised MSE after tuning (mean over targets).
    pub loo_nmse: f64,
    /// Leave-one-out normalised MSE after tuning, per target.
    pub loo_nmse_per_target: Vec<f64>,
    /// Leave-one-out evaluations used by tuning (0 without tuning).
    pub tune_evals: usize,
    /// Whether tuning converged (`None` without tuning).
    pub tune_converged: Option<bool>,
    /// The results on the test file, if one was given.
    pub test: Option<TestReport>,
    /// The predictions file, if one was written.
    pub out_file: Option<PathBuf>,
    /// Level of the prediction intervals.
    pub level: f64,
    /// Training rows whose inputs repeat an earlier row's exactly: leaving
    /// one out keeps its copies, so the leave-one-out error is optimistic
    /// where there are many (reported, with a warning, when not 0).
    pub duplicate_inputs: usize,
}

fn fmt_num(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.4}")
    } else {
        format!("{v}")
    }
}

impl fmt::Display for FitReport {
    /// The text summary the fit tool prints.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut s = String::new();
        writeln!(
            s,
            "training: {} rows from {}; {} input(s), target(s) {}",
            self.n_train,
            self.train_file.display(),
            self.inputs.len(),
            self.targets.join(", ")
        )?;
        let tuning = match self.tune_converged {
            Some(true) => format!(
                "metric tuned by leave-one-out cross-validation ({} evaluations, converged)",
                self.tune_evals
            ),
            Some(false) => format!(
                "metric tuned by leave-one-out cross-validation ({} evaluations, budget exhausted: raise --tune-evals)",
                self.tune_evals
            ),
            None => "metric not tuned (--tune-evals 0)".to_owned(),
        };
        writeln!(s, "kernel {:?}, degree {:?}; {tuning}", self.kernel, self.degree)?;
        writeln!(
            s,
            "LOO normalised MSE: {} (untuned {})",
            fmt_num(self.loo_nmse),
            fmt_num(self.initial_loo_nmse)
        )?;
        if self.duplicate_inputs > 0 {
            writeln!(
                s,
                "warning: {} of {} training rows repeat an earlier row's inputs exactly; leaving one out keeps \
                 its copies, so the leave-one-out error is optimistic (check it on a test file)",
                self.duplicate_inputs, self.n_train
            )?;
        }
        if self.targets.len() > 1 {
            for (t, e) in self.targets.iter().zip(&self.loo_nmse_per_target) {
                writeln!(s, "  {t}: {}", fmt_num(*e))?;
            }
        }
        writeln!(
            s,
            "bandwidth h = {} (in standard deviations at scale 1)",
            fmt_num(self.bandwidth)
        )?;
        let w = self.inputs.iter().map(|i| i.name.len()).max().unwrap_or(5).max(5);
        writeln!(
            s,
            "  {:<w$}  {:>12}  {:>10}  {:>12}",
            "input", "spread (sd)", "scale", "width (sd)"
        )?;
        for i in &self.inputs {
            let note = if i.scale == 0.0 {
                "  (ignored by the weights)"
            } else {
                ""
            };
            writeln!(
                s,
                "  {:<w$}  {:>12.4e}  {:>10.4}  {:>12}{note}",
                i.name,
                i.spread,
                i.scale,
                fmt_num(i.width(self.bandwidth))
            )?;
        }
        if let Some(t) = &self.test {
            writeln!(
                s,
                "test: {} rows from {}, {} predicted",
                t.n_rows,
                t.file.display(),
                t.n_predicted
            )?;
            if t.n_without_interval > 0 {
                writeln!(
                    s,
                    "  {} predicted rows have too few local degrees of freedom for an interval (NaN std, infinite bounds)",
                    t.n_without_interval
                )?;
            }
            for (row, why) in t.unpredicted.iter().take(5) {
                writeln!(s, "  data row {row} not predicted: {why}")?;
            }
            if t.unpredicted.len() > 5 {
                writeln!(s, "  ... and {} more rows not predicted", t.unpredicted.len() - 5)?;
            }
            match t.nmse {
                Some(e) => writeln!(s, "test normalised MSE: {}", fmt_num(e))?,
                None if t.n_predicted == 0 => writeln!(
                    s,
                    "test normalised MSE: - (no test row could be predicted: none has training data within the kernel's reach)"
                )?,
                None => writeln!(s, "test normalised MSE: - (no target column in the test file)")?,
            }
            for e in &t.targets {
                writeln!(
                    s,
                    "  {}: nMSE {}, RMSE {}, {:.0} % prediction interval covers {:.1} %",
                    e.name,
                    fmt_num(e.nmse),
                    fmt_num(e.rmse),
                    100.0 * self.level,
                    100.0 * e.coverage
                )?;
            }
        }
        if let Some(out) = &self.out_file {
            writeln!(s, "predictions written to {}", out.display())?;
        }
        f.write_str(&s)
    }
}
