//! The CSV fit tool (feature `cli`): locally weighted regression on a CSV
//! file, with the metric tuned by cross-validation. The binary `lwr-fit`
//! runs it, and so does `swingup fit`.
//!
//! ```text
//! lwr-fit --train TRAIN.csv [--test TEST.csv] --target NAME [--target NAME ...]
//!         [--out PRED.csv] [--json] [--kernel K] [--degree D] [--bandwidth H]
//!         [--tune-evals N] [--tune-points N] [--tune-method lm|compass] [--level L]
//! ```
//!
//! The files are comma-separated numbers under a header row of column names,
//! read with the `csv` crate (fields may be quoted; blank lines are skipped). The inputs are every training column that is not a
//! target. Each input $j$ starts with the metric scale $m_j = 1 / s_j$, $s_j$
//! its standard deviation over the training rows, so that all inputs start
//! equally important; [`LwrModel::tune`] then tunes the bandwidth $h$
//! and every $m_j$ by minimising the leave-one-out error on the training
//! data (by default Levenberg-Marquardt on the leave-one-out residuals in
//! log space, [`TuneMethod::LevenbergMarquardt`](crate::TuneMethod::LevenbergMarquardt); `--tune-method compass`
//! the compass search; either can set $m_j = 0$).
//!
//! The summary ([`FitReport`], printed as text or with `--json` as JSON)
//! gives the leave-one-out normalised MSE
//! $\sum_i e_{(-i)}^2 / (n \operatorname{var} y)$ (1 is as good as predicting
//! the mean), the tuned scale of each input relative to its normalisation,
//! $m_j s_j$ (0: the weights ignore the input), the bandwidth, and, when the
//! test file has target columns, the test normalised MSE
//! $\sum_i (y_i - \hat y_i)^2 / (n \operatorname{var} y)$ with the variance
//! over the test rows.
//!
//! With `--out` it writes one row per test row with, for each target `NAME`,
//! the columns `NAME_pred,NAME_std,NAME_lo,NAME_hi`: the prediction, the
//! standard error of the mean $\sqrt{\sigma^2 |l|^2}$
//! ([`Prediction::std_error`]) and the prediction interval of a new
//! observation at level `--level` (95 % by default),
//! $\hat y \pm t \sqrt{\sigma^2 (1 + |l|^2)}$. A row the model cannot predict
//! (no training point carries weight there) gets `NaN` in every column and is
//! listed in the summary; a fit without degrees of freedom for a noise
//! estimate gets `NaN` standard errors and infinite (`-inf`, `inf`) bounds.
//!
//! Bad files (missing columns, non-numeric, empty or non-finite cells, rows of
//! the wrong length, no rows) give a [`FitError`] naming the file, the line,
//! the data row and the column; so do the arguments, and a model that
//! cannot be built or tuned from the data. The predictions file is written
//! through a temporary file and a rename, so a failed write leaves any old
//! file whole, and never over the training or test file.
//!
//! ```no_run
//! use lwr::csv_fit::{FitArgs, fit_report};
//!
//! let mut args = FitArgs::new("train.csv", &["y"]);
//! args.test = Some("test.csv".into());
//! args.out = Some("pred.csv".into());
//! let report = fit_report(&args)?;
//! print!("{report}");
//! # Ok::<(), lwr::csv_fit::FitError>(())
//! ```
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use estimate::{duration_words, estimate_loo_seconds, tuning_plan};

use crate::{Degree, Kernel, LwrError, LwrModel, LwrSettings, Prediction, TuneSettings, TuneStatus};

mod args;
mod error;
mod estimate;
mod report;
mod table;

pub use args::{DegreeArg, KernelArg, MethodArg};
pub use error::FitError;
pub use report::{FitReport, InputScale, TargetError, TestReport};
pub use table::{PROGRESS_ROWS, Table};

/// Arguments of the fit tool (`lwr-fit`, `swingup fit`).
#[derive(Debug, Clone, clap::Args)]
pub struct FitArgs {
    /// Training data: CSV with a header row of column names.
    #[arg(long, value_name = "TRAIN.csv")]
    pub train: PathBuf,
    /// Test data: CSV with (at least) the input columns; where it also has
    /// the target columns the test error is reported.
    #[arg(long, value_name = "TEST.csv")]
    pub test: Option<PathBuf>,
    /// A column to predict (repeat for several); every other training column
    /// is an input.
    #[arg(long = "target", value_name = "NAME", required = true)]
    pub targets: Vec<String>,
    /// Write the predictions for the test rows here (`-`: standard output,
    /// the summary then going to standard error): per target
    /// `NAME_pred,NAME_std,NAME_lo,NAME_hi`. The file is replaced whole; a
    /// symbolic link, device, FIFO or directory there is refused.
    #[arg(long, value_name = "PRED.csv", requires = "test")]
    pub out: Option<PathBuf>,
    /// Delete a symbolic link at `--out` (never its target) before writing
    /// a regular file there.
    #[arg(long)]
    pub force: bool,
    /// Print the summary as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Weighting kernel.
    #[arg(long, value_enum, default_value_t = KernelArg::Gaussian)]
    pub kernel: KernelArg,
    /// Degree of the local polynomial.
    #[arg(long, value_enum, default_value_t = DegreeArg::Linear)]
    pub degree: DegreeArg,
    /// Initial bandwidth in units of the inputs' standard deviations
    /// (default 0.5 for the Gaussian, 1.5 for the compact kernels).
    #[arg(long, value_name = "H")]
    pub bandwidth: Option<f64>,
    /// Budget of leave-one-out evaluations for tuning the bandwidth and
    /// metric (0: no tuning, use the initial metric).
    #[arg(long, value_name = "N", default_value_t = 300)]
    pub tune_evals: usize,
    /// Compare metrics during the tuning by the leave-one-out errors of
    /// about N rows only (their fits still use every row), which makes each
    /// evaluation rows/N times cheaper; 0: every row. The time the tuning
    /// will take is estimated and printed before it starts, with this
    /// option named when it would take more than an hour.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub tune_points: usize,
    /// The tuning's search.
    #[arg(long, value_enum, default_value_t = MethodArg::Lm)]
    pub tune_method: MethodArg,
    /// Level of the prediction intervals written with `--out`.
    #[arg(long, value_name = "L", default_value_t = 0.95)]
    pub level: f64,
}

impl FitArgs {
    /// Arguments with the command line's defaults for a training file and
    /// targets.
    pub fn new(train: impl Into<PathBuf>, targets: &[&str]) -> Self {
        Self {
            train: train.into(),
            test: None,
            targets: targets.iter().map(|t| (*t).to_owned()).collect(),
            out: None,
            force: false,
            json: false,
            kernel: KernelArg::Gaussian,
            degree: DegreeArg::Linear,
            bandwidth: None,
            tune_evals: 300,
            tune_points: 0,
            tune_method: MethodArg::Lm,
            level: 0.95,
        }
    }
}

fn mean_var(values: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let n = values.clone().count() as f64;
    let mean = values.clone().sum::<f64>() / n;
    let var = values.map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
    (mean, var)
}

fn check_args(args: &FitArgs) -> Result<(), FitError> {
    if args.targets.is_empty() {
        return Err(FitError::InvalidArgument {
            name: "--target",
            reason: "give at least one target column".into(),
        });
    }
    for (i, t) in args.targets.iter().enumerate() {
        if args.targets[..i].contains(t) {
            return Err(FitError::InvalidArgument {
                name: "--target",
                reason: format!("'{t}' is given twice"),
            });
        }
    }
    if let Some(h) = args.bandwidth
        && !(h.is_finite() && h > 0.0)
    {
        return Err(FitError::InvalidArgument {
            name: "--bandwidth",
            reason: format!("must be finite and positive, got {h}"),
        });
    }
    if !(args.level > 0.0 && args.level < 1.0) {
        return Err(FitError::InvalidArgument {
            name: "--level",
            reason: format!("must be in (0, 1), got {}", args.level),
        });
    }
    if args.out.is_some() && args.test.is_none() {
        return Err(FitError::InvalidArgument {
            name: "--out",
            reason: "needs --test (the predictions are for the test rows)".into(),
        });
    }
    if let Some(out) = args.out.as_deref().filter(|o| !is_stdout(o)) {
        // refused before any work: a link, device, FIFO or directory at --out
        if let Err(e) = store::check_output(out) {
            let link = fs::symlink_metadata(out).is_ok_and(|m| m.file_type().is_symlink());
            if !(args.force && link) {
                return Err(FitError::InvalidArgument {
                    name: "--out",
                    reason: if link {
                        format!("{e} (or pass --force to delete the link)")
                    } else {
                        e.to_string()
                    },
                });
            }
        }
        for (flag, input) in [("--train", Some(&args.train)), ("--test", args.test.as_ref())] {
            if input.is_some_and(|input| same_file(out, input)) {
                return Err(FitError::InvalidArgument {
                    name: "--out",
                    reason: format!(
                        "{} is also the {flag} file; writing the predictions would destroy it",
                        out.display()
                    ),
                });
            }
        }
    }
    Ok(())
}

/// Whether `path` is `-`, standard output.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Whether `a` and `b` name one existing file (through links and `..`).
fn same_file(a: &Path, b: &Path) -> bool {
    match (fs::canonicalize(a), fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// The most coefficients a local fit may have: its normal matrix is
/// $p^2$ numbers per query (2000: 32 MB).
const MAX_COEFFICIENTS: usize = 2000;

/// Refuses training data a local fit of `degree` cannot be made from:
/// identical rows, fewer rows than coefficients plus one, or a local
/// polynomial too large to hold.
fn check_size(train: &Table, degree: DegreeArg, inputs: usize) -> Result<(), FitError> {
    let rows = train.rows.len();
    if rows > 1 && train.rows.windows(2).all(|w| w[0] == w[1]) {
        return Err(FitError::IdenticalRows {
            file: train.file.clone(),
            rows,
        });
    }
    let coefficients = Degree::from(degree).n_coeffs(inputs);
    let reason = if coefficients > MAX_COEFFICIENTS {
        format!("at most {MAX_COEFFICIENTS} are supported (a normal matrix of {coefficients}^2 numbers per query)")
    } else if rows <= coefficients {
        format!(
            "it needs at least {} training rows, and {} has {rows}",
            coefficients + 1,
            train.file.display()
        )
    } else {
        return Ok(());
    };
    Err(FitError::ModelTooLarge {
        file: train.file.clone(),
        degree: match degree {
            DegreeArg::Constant => "constant",
            DegreeArg::Linear => "linear",
            DegreeArg::Quadratic => "quadratic",
        },
        inputs,
        coefficients,
        reason,
    })
}

/// Fits, tunes and tests as the fit tool does, writes `--out` if given, and
/// returns the summary without printing it.
///
/// # Errors
/// A [`FitError`]: bad arguments or files, a model that cannot be built or
/// tuned ([`FitError::Model`]), or `--out` that cannot be written
/// ([`FitError::Write`]).
pub fn fit_report(args: &FitArgs) -> Result<FitReport, FitError> {
    fit_report_with(args, &mut |_: &str| {})
}

/// [`fit_report`], telling `progress` each long phase as it starts
/// (the command prints them on stderr).
///
/// # Errors
/// As [`fit_report`].
pub fn fit_report_with(args: &FitArgs, progress: &mut dyn FnMut(&str)) -> Result<FitReport, FitError> {
    check_args(args)?;
    let train = read_table(&args.train, progress)?;
    let target_cols = args
        .targets
        .iter()
        .map(|t| train.column(t, "target"))
        .collect::<Result<Vec<_>, _>>()?;
    let input_cols: Vec<usize> = (0..train.names.len()).filter(|j| !target_cols.contains(j)).collect();
    if input_cols.is_empty() {
        return Err(FitError::NoInputs {
            file: train.file.clone(),
        });
    }
    check_size(&train, args.degree, input_cols.len())?;
    // every column divided by a power of two near its largest magnitude
    // (exact in floating point): the fit sees numbers near 1 whatever the
    // data's units, so a column of 1e200 neither overflows nor looks constant
    let column_scale = |j: usize| power_of_two_scale(train.rows.iter().map(|r| r[j]));
    let in_scale: Vec<f64> = input_cols.iter().map(|&j| column_scale(j)).collect();
    let out_scale: Vec<f64> = target_cols.iter().map(|&j| column_scale(j)).collect();
    for (&j, &t) in target_cols.iter().zip(&out_scale) {
        let (_, var) = mean_var(train.rows.iter().map(|r| r[j] / t));
        if var.is_nan() || var.sqrt() <= CONSTANT_RELATIVE_SPREAD {
            return Err(FitError::ConstantTarget {
                file: train.file.clone(),
                column: j + 1,
                name: train.names[j].clone(),
                value: train.rows[0][j],
            });
        }
    }
    let xs: Vec<Vec<f64>> = train
        .rows
        .iter()
        .map(|r| input_cols.iter().zip(&in_scale).map(|(&j, s)| r[j] / s).collect())
        .collect();
    let ys: Vec<Vec<f64>> = train
        .rows
        .iter()
        .map(|r| target_cols.iter().zip(&out_scale).map(|(&j, t)| r[j] / t).collect())
        .collect();
    let duplicate_inputs = count_duplicates(&xs);

    // spreads of the scaled inputs (the model's units)
    let mut spreads = Vec::with_capacity(input_cols.len());
    for (i, &j) in input_cols.iter().enumerate() {
        let (_, var) = mean_var(xs.iter().map(|x| x[i]));
        let sd = var.sqrt();
        if !(sd > CONSTANT_RELATIVE_SPREAD && sd.is_finite()) {
            return Err(FitError::ConstantInput {
                file: train.file.clone(),
                column: j + 1,
                name: train.names[j].clone(),
                value: train.rows[0][j],
            });
        }
        spreads.push(sd);
    }

    let kernel = Kernel::from(args.kernel);
    let bandwidth = args.bandwidth.unwrap_or(match kernel {
        Kernel::Gaussian => 0.5,
        _ => 1.5,
    });
    let settings = LwrSettings {
        kernel,
        degree: args.degree.into(),
        bandwidth,
        scales: spreads.iter().map(|s| 1.0 / s).collect(),
        confidence_level: args.level,
        ..Default::default()
    };
    let model_error = |task: &'static str| {
        let file = train.file.clone();
        move |source: LwrError| FitError::Model { file, task, source }
    };
    let mut model =
        LwrModel::new(input_cols.len(), target_cols.len(), settings).map_err(model_error("building the model"))?;
    model
        .insert_many(&xs, &ys)
        .map_err(model_error("storing the training rows"))?;

    // leave-one-out costs up to n^2 kernel evaluations: the time is
    // estimated on a sample of the rows and said before any long pass
    let pass = estimate_loo_seconds(&model, &xs, &ys).map_err(model_error("estimating the tuning's time"))?;
    let (initial_loo_nmse, tune_evals, tune_converged) = if args.tune_evals > 0 {
        for line in tuning_plan(train.rows.len(), args.tune_points, args.tune_evals, pass) {
            progress(&line);
        }
        let tuned = model
            .tune(&TuneSettings {
                max_evals: args.tune_evals,
                search_points: args.tune_points,
                method: args.tune_method.into(),
                ..Default::default()
            })
            .map_err(model_error("tuning the metric"))?;
        let converged = tuned.status == TuneStatus::Converged;
        model
            .set_settings(tuned.settings)
            .map_err(model_error("tuning the metric"))?;
        (tuned.initial_objective, tuned.evals, Some(converged))
    } else {
        (f64::NAN, 0, None)
    };
    progress(&format!(
        "leave-one-out cross-validation of the final model (about {})",
        duration_words(pass)
    ));
    let loo = model.loo().map_err(model_error("leave-one-out cross-validation"))?;
    let n = train.rows.len() as f64;
    let loo_nmse_per_target: Vec<f64> = (0..target_cols.len())
        .map(|o| {
            let (_, var) = mean_var(ys.iter().map(|y| y[o]));
            loo.press[o] / (n * var)
        })
        .collect();
    if let Some(&value) = std::iter::once(&loo.normalized_mse)
        .chain(&loo_nmse_per_target)
        .find(|v| !v.is_finite())
    {
        return Err(FitError::NonFinite {
            file: train.file.clone(),
            value,
            hint: "look for extreme values among the rows, or fit with fewer inputs or a wider --bandwidth".into(),
        });
    }
    let initial_loo_nmse = if initial_loo_nmse.is_nan() {
        loo.normalized_mse
    } else {
        initial_loo_nmse
    };
    let tuned = model.settings();
    let scales = tuned.scales_for(input_cols.len());
    // back in each input's own units: spread s_j = sd * 2^k, metric m_j / 2^k
    let inputs = input_cols
        .iter()
        .zip(&spreads)
        .zip(&scales)
        .zip(&in_scale)
        .map(|(((&j, &spread), &m), &s)| InputScale {
            name: train.names[j].clone(),
            spread: spread * s,
            scale: m * spread,
            metric_scale: m / s,
        })
        .collect();

    let mut report = FitReport {
        train_file: train.file.clone(),
        n_train: train.rows.len(),
        targets: args.targets.clone(),
        inputs,
        kernel: args.kernel,
        degree: args.degree,
        bandwidth: tuned.bandwidth,
        initial_loo_nmse,
        loo_nmse: loo.normalized_mse,
        loo_nmse_per_target,
        tune_evals,
        tune_converged,
        test: None,
        out_file: None,
        level: args.level,
        duplicate_inputs,
    };

    if let Some(test_path) = &args.test {
        let test = read_table(test_path, progress)?;
        progress(&format!("predicting {} test rows", test.rows.len()));
        let scaled = Scaled {
            model: &model,
            inputs: &in_scale,
            targets: &out_scale,
        };
        let (report_test, predictions) = run_test(&scaled, &train, &input_cols, &args.targets, &test)?;
        if let Some(out) = &args.out {
            write_predictions(out, args.force, &args.targets, &predictions)?;
            report.out_file = Some(out.clone());
        }
        report.test = Some(report_test);
    }
    Ok(report)
}

type RowPrediction = Result<Prediction, String>;

/// The model fitted on scaled columns, with the scales that map its
/// inputs and outputs back to the file's units.
struct Scaled<'a> {
    model: &'a LwrModel,
    inputs: &'a [f64],
    targets: &'a [f64],
}

impl Scaled<'_> {
    /// Predictions at `queries` (in the file's units), in the file's units.
    fn predict_batch(&self, queries: &[Vec<f64>]) -> Vec<Result<Prediction, LwrError>> {
        let scaled: Vec<Vec<f64>> = queries
            .iter()
            .map(|q| q.iter().zip(self.inputs).map(|(x, s)| x / s).collect())
            .collect();
        let mut out = self.model.predict_batch(&scaled);
        for p in out.iter_mut().flatten() {
            for (o, &t) in self.targets.iter().enumerate() {
                p.mean[o] *= t;
                p.noise_variance[o] *= t * t;
                p.std_error[o] *= t;
                p.confidence_half_width[o] *= t;
                p.prediction_half_width[o] *= t;
            }
        }
        out
    }
}

/// The table, with progress on large files.
fn read_table(path: &Path, progress: &mut dyn FnMut(&str)) -> Result<Table, FitError> {
    if let Ok(meta) = fs::metadata(path)
        && meta.len() > 8 << 20
    {
        progress(&format!(
            "reading {} ({:.0} MB)",
            path.display(),
            meta.len() as f64 / (1 << 20) as f64
        ));
    }
    Table::read_with(path, &mut |rows| progress(&format!("  {rows} rows read")))
}

/// A column whose standard deviation is at most this fraction of its
/// largest magnitude is constant: its values differ by round-off only.
const CONSTANT_RELATIVE_SPREAD: f64 = 64.0 * f64::EPSILON;

/// The power of two at or below the largest magnitude of `values` (1 when
/// they are all 0): dividing by it is exact and brings them near 1.
fn power_of_two_scale(values: impl Iterator<Item = f64>) -> f64 {
    let largest = values.fold(0.0f64, |a, v| a.max(v.abs()));
    if largest > 0.0 && largest.is_finite() {
        2f64.powi(largest.log2().floor() as i32)
    } else {
        1.0
    }
}

/// Rows whose inputs repeat an earlier row's exactly (0 and -0 alike).
fn count_duplicates(xs: &[Vec<f64>]) -> usize {
    let mut seen = std::collections::HashSet::with_capacity(xs.len());
    xs.iter()
        .filter(|x| !seen.insert(x.iter().map(|v| (v + 0.0).to_bits()).collect::<Vec<u64>>()))
        .count()
}

fn run_test(
    model: &Scaled<'_>,
    train: &Table,
    input_cols: &[usize],
    targets: &[String],
    test: &Table,
) -> Result<(TestReport, Vec<RowPrediction>), FitError> {
    let test_inputs = input_cols
        .iter()
        .map(|&j| test.column(&train.names[j], "input"))
        .collect::<Result<Vec<_>, _>>()?;
    // target index in the model, column in the test file
    let test_targets: Vec<(usize, usize)> = targets
        .iter()
        .enumerate()
        .filter_map(|(o, t)| test.names.iter().position(|n| n == t).map(|j| (o, j)))
        .collect();
    for (j, name) in test.names.iter().enumerate() {
        if !test_inputs.contains(&j) && !test_targets.iter().any(|&(_, c)| c == j) {
            return Err(FitError::UnknownColumn {
                file: test.file.clone(),
                line: test.header_line,
                column: j + 1,
                name: name.clone(),
                train: train.file.clone(),
            });
        }
    }
    let queries: Vec<Vec<f64>> = test
        .rows
        .iter()
        .map(|r| test_inputs.iter().map(|&j| r[j]).collect())
        .collect();
    let predictions: Vec<RowPrediction> = model
        .predict_batch(&queries)
        .into_iter()
        .map(|p| p.map_err(|e| e.to_string()))
        .collect();
    let unpredicted: Vec<(usize, String)> = predictions
        .iter()
        .enumerate()
        .filter_map(|(i, p)| p.as_ref().err().map(|e| (i + 1, e.clone())))
        .collect();
    let predicted: Vec<(&Vec<f64>, &Prediction)> = test
        .rows
        .iter()
        .zip(&predictions)
        .filter_map(|(r, p)| p.as_ref().ok().map(|p| (r, p)))
        .collect();
    let mut errors = Vec::new();
    if !predicted.is_empty() {
        for &(o, j) in &test_targets {
            let (_, var) = mean_var(predicted.iter().map(|(r, _)| r[j]));
            let m = predicted.len() as f64;
            let sse: f64 = predicted.iter().map(|(r, p)| (r[j] - p.mean[o]).powi(2)).sum();
            let inside = predicted
                .iter()
                .filter(|(r, p)| {
                    p.prediction_interval(o)
                        .is_some_and(|(lo, hi)| lo <= r[j] && r[j] <= hi)
                })
                .count();
            errors.push(TargetError {
                name: targets[o].clone(),
                nmse: if var > 0.0 { sse / (m * var) } else { f64::NAN },
                rmse: (sse / m).sqrt(),
                coverage: inside as f64 / m,
            });
        }
    }
    let nmse = (!errors.is_empty()).then(|| errors.iter().map(|e| e.nmse).sum::<f64>() / errors.len() as f64);
    let report = TestReport {
        file: test.file.clone(),
        n_rows: test.rows.len(),
        n_predicted: predicted.len(),
        n_without_interval: predicted
            .iter()
            .filter(|(_, p)| p.prediction_half_width.iter().any(|w| !w.is_finite()))
            .count(),
        unpredicted,
        nmse,
        targets: errors,
    };
    Ok((report, predictions))
}

fn write_predictions(
    out: &Path,
    force: bool,
    targets: &[String],
    predictions: &[RowPrediction],
) -> Result<(), FitError> {
    let mut text = String::new();
    let header: Vec<String> = targets
        .iter()
        .map(|t| format!("{t}_pred,{t}_std,{t}_lo,{t}_hi"))
        .collect();
    text.push_str(&header.join(","));
    text.push('\n');
    for p in predictions {
        let cells: Vec<String> = (0..targets.len())
            .map(|o| match p {
                Ok(p) => {
                    let (mean, half) = (p.mean[o], p.prediction_half_width[o]);
                    format!("{mean},{},{},{}", p.std_error[o], mean - half, mean + half)
                }
                Err(_) => "NaN,NaN,NaN,NaN".to_owned(),
            })
            .collect();
        text.push_str(&cells.join(","));
        text.push('\n');
    }
    if is_stdout(out) {
        use std::io::Write as _;
        let mut stdout = io::stdout().lock();
        return stdout
            .write_all(text.as_bytes())
            .and_then(|()| stdout.flush())
            .map_err(FitError::Stdout);
    }
    let write = |source| FitError::Write {
        file: out.to_path_buf(),
        source,
    };
    if force && fs::symlink_metadata(out).is_ok_and(|m| m.file_type().is_symlink()) {
        // the link is deleted, never written through
        store::remove_output(out).map_err(|e| write(io::Error::other(e.to_string())))?;
    }
    // through a temporary file: a failed write leaves any old file whole
    write_atomic(out, &text).map_err(write)
}

/// Writes `contents` to `path` through a temporary file of its own in the
/// same directory and a rename ([`store::replace_file`]: the temporary is
/// created new, so it never replaces an existing file such as an input
/// named like a temporary file), so that `path` holds either its old or its
/// new contents; on failure the temporary file is removed and the error
/// names the file. A symbolic link, device, FIFO or directory at `path` is
/// refused and left as it is; an existing file keeps its mode.
///
/// # Errors
/// Something other than a regular file at `path`, or the temporary file
/// cannot be created, written or renamed.
pub fn write_atomic(path: &Path, contents: &str) -> io::Result<()> {
    store::replace_file(path, contents.as_bytes())
        .map_err(|e| io::Error::new(e.io_kind().unwrap_or(io::ErrorKind::Other), e.to_string()))
}

/// Runs the fit tool: [`fit_report_with`] with the phases on stderr, then
/// prints the summary on stdout as text or, with `--json`, as JSON
/// (non-finite numbers as `null`). The predictions file is written before
/// anything is printed: a closed or full stdout (`| head`, `> /dev/full`)
/// loses only the summary, and is then an error ([`FitError::Stdout`]); a
/// closed stderr loses the phases' lines only.
///
/// # Errors
/// As [`fit_report`].
pub fn fit_command(args: &FitArgs) -> Result<(), FitError> {
    use std::io::Write as _;
    let report = fit_report_with(args, &mut |phase: &str| {
        // a closed stderr loses the phase's line, never the work
        let _ = writeln!(io::stderr(), "{phase} ...");
    })?;
    let text = if args.json {
        serde_json::to_string_pretty(&report)? + "\n"
    } else {
        report.to_string()
    };
    if args.out.as_deref().is_some_and(is_stdout) {
        // the predictions took standard output
        let _ = io::stderr().write_all(text.as_bytes());
        return Ok(());
    }
    // a closed or full stdout: the files are saved, the summary is lost,
    // and the status says so
    let mut stdout = io::stdout().lock();
    stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
        .map_err(FitError::Stdout)
}

/// An error and its causes, joined by `": "` (what the `lwr-fit` binary
/// prints).
pub fn error_chain(error: &dyn std::error::Error) -> String {
    let mut text = error.to_string();
    let mut cause = error.source();
    while let Some(e) = cause {
        text.push_str(": ");
        text.push_str(&e.to_string());
        cause = e.source();
    }
    text
}
