//! The fit/predict surface: a model from rows of data in one call, its
//! metric tuned by leave-one-out cross-validation starting from scales the
//! data suggest, and its predictions scored.
//!
//! [`LwrModel::fit`] takes the inputs as rows $x_i \in \mathbb R^d$ and
//! one target $y_i$ per row ([`LwrModel::fit_multi`]: several), sets each
//! input's scale to $1 / \mathrm{sd}(x_{\cdot j})$ (so the initial
//! bandwidth is in standard deviations, whatever the inputs' units: the
//! diabetes data's inputs have sd 0.048), inserts the rows and tunes the
//! bandwidth and the scales ([`LwrModel::tune`]) over at most
//! [`FitSettings::tune_evals`] leave-one-out evaluations.
//! [`LwrModel::predict_many`] predicts rows (with
//! [`Prediction::prediction_interval`] and
//! [`Prediction::confidence_interval`] per output), and
//! [`LwrModel::score`] gives $R^2$ as scikit-learn's `score` does. The
//! incremental API ([`LwrModel::new`], [`LwrModel::insert`]) stays for
//! online use.
//!
//! | setting | default | meaning |
//! |---|---|---|
//! | `kernel` | [`Kernel::Gaussian`] | the weighting kernel |
//! | `degree` | [`Degree::Linear`] | the local polynomial |
//! | `bandwidth` | 0.5 (Gaussian), 1.5 (compact kernels) | the initial bandwidth, in standard deviations |
//! | `tune_evals` | 300 | leave-one-out evaluations of the tuning (0: none) |
//! | `tune_points` | 0 (all) | points cross-validated per evaluation ([`TuneSettings::search_points`]) |
//! | `confidence_level` | 0.95 | the level of the intervals |
//!
//! ```
//! // y = sin(3 a) + b / 2, c irrelevant
//! let rows: Vec<[f64; 3]> = (0..200).map(|i| {
//!     let t = i as f64;
//!     [(t * 0.37).sin(), (t * 0.71).cos(), (t * 1.13).sin()]
//! }).collect();
//! let y: Vec<f64> = rows.iter().map(|x| (3.0 * x[0]).sin() + 0.5 * x[1]).collect();
//! let model = lwr::LwrModel::fit(&rows[..150], &y[..150])?;
//! let r2 = model.score(&rows[150..], &y[150..])?;
//! assert!(r2 > 0.95, "R^2 = {r2}");
//! # Ok::<(), lwr::LwrError>(())
//! ```

use serde::{Deserialize, Serialize};

use crate::error::{LwrError, Result};
use crate::model::{LwrModel, Prediction};
use crate::settings::{Degree, Kernel, LwrSettings};
use crate::tune::{TuneMethod, TuneResult, TuneSettings};

/// How [`LwrModel::fit_multi`] fits (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitSettings {
    /// The weighting kernel.
    pub kernel: Kernel,
    /// The local polynomial.
    pub degree: Degree,
    /// The initial bandwidth in standard deviations of the inputs; `None`:
    /// 0.5 for the Gaussian, 1.5 for the compact kernels.
    pub bandwidth: Option<f64>,
    /// Leave-one-out evaluations of the tuning (0: no tuning).
    pub tune_evals: usize,
    /// Points cross-validated per evaluation (0: all;
    /// [`TuneSettings::search_points`]).
    pub tune_points: usize,
    /// The tuning's search ([`TuneSettings::method`]).
    pub tune_method: TuneMethod,
    /// The level of the confidence and prediction intervals.
    pub confidence_level: f64,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            kernel: Kernel::Gaussian,
            degree: Degree::Linear,
            bandwidth: None,
            tune_evals: 300,
            tune_points: 0,
            tune_method: TuneMethod::LevenbergMarquardt,
            confidence_level: 0.95,
        }
    }
}

impl LwrModel {
    /// A model of the target `y` (one per row of `xs`), its metric tuned by
    /// leave-one-out cross-validation from the scales the data suggest
    /// ([`FitSettings::default`]; see the [module docs](crate::regressor)).
    ///
    /// # Errors
    /// As [`fit_multi`](Self::fit_multi).
    pub fn fit<X: AsRef<[f64]>>(xs: &[X], y: &[f64]) -> Result<Self> {
        let ys: Vec<[f64; 1]> = y.iter().map(|&v| [v]).collect();
        if ys.len() != xs.len() {
            return Err(LwrError::DimensionMismatch {
                what: "targets",
                expected: xs.len(),
                actual: ys.len(),
            });
        }
        Ok(Self::fit_multi(xs, &ys, &FitSettings::default())?.0)
    }

    /// [`fit`](Self::fit) with several targets per row (`ys[i]` the
    /// targets of row `i`) and [`FitSettings`] of the caller's; returns the
    /// model and the tuning's result (`None` without tuning).
    ///
    /// # Errors
    /// No rows, rows or targets of different lengths, numbers that are not
    /// finite, an input constant over the rows (it has no scale; drop it),
    /// invalid settings, or a failure of the tuning.
    pub fn fit_multi<X: AsRef<[f64]>, Y: AsRef<[f64]>>(
        xs: &[X],
        ys: &[Y],
        settings: &FitSettings,
    ) -> Result<(Self, Option<TuneResult>)> {
        let n = xs.len();
        if n == 0 {
            return Err(LwrError::EmptyDatabase);
        }
        if ys.len() != n {
            return Err(LwrError::DimensionMismatch {
                what: "target rows",
                expected: n,
                actual: ys.len(),
            });
        }
        let (d, o) = (xs[0].as_ref().len(), ys[0].as_ref().len());
        let mut scales = Vec::with_capacity(d);
        for j in 0..d {
            let column = || xs.iter().map(|x| x.as_ref().get(j).copied().unwrap_or(f64::NAN));
            let mean = column().sum::<f64>() / n as f64;
            let sd = (column().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
            if !(sd > 0.0 && sd.is_finite()) {
                return Err(LwrError::InvalidParameter {
                    name: "inputs",
                    reason: format!(
                        "input {j} has standard deviation {sd} over the rows: a constant (or non-finite) input has \
                         no scale; drop it"
                    ),
                });
            }
            scales.push(1.0 / sd);
        }
        let bandwidth = settings.bandwidth.unwrap_or(match settings.kernel {
            Kernel::Gaussian => 0.5,
            _ => 1.5,
        });
        let lwr = LwrSettings {
            kernel: settings.kernel,
            degree: settings.degree,
            bandwidth,
            scales,
            confidence_level: settings.confidence_level,
            ..LwrSettings::default()
        };
        let mut model = Self::new(d, o, lwr)?;
        model.insert_many(xs, ys)?;
        let tuned = if settings.tune_evals > 0 {
            let tuned = model.tune(&TuneSettings {
                max_evals: settings.tune_evals,
                search_points: settings.tune_points,
                method: settings.tune_method,
                ..TuneSettings::default()
            })?;
            model.set_settings(tuned.settings.clone())?;
            Some(tuned)
        } else {
            None
        };
        Ok((model, tuned))
    }

    /// The predictions at the rows `xs` (in parallel), each with its
    /// intervals. A row outside the kernel's support around every stored
    /// point (which [`predict`](Self::predict) refuses) is fitted with the
    /// support widened to twice the distance of its nearest point, and its
    /// prediction has the status [`FitStatus::Extrapolated`](crate::FitStatus::Extrapolated):
    /// a regressor predicts every row.
    ///
    /// # Errors
    /// The first row that cannot be predicted (a row of the wrong length or
    /// not finite, a singular fit), naming its index.
    pub fn predict_many<X: AsRef<[f64]> + Sync>(&self, xs: &[X]) -> Result<Vec<Prediction>> {
        use rayon::prelude::*;
        let predictions: Vec<Result<Prediction>> = xs.par_iter().map(|q| self.predict_or_widen(q.as_ref())).collect();
        predictions
            .into_iter()
            .enumerate()
            .map(|(i, p)| {
                p.map_err(|e| LwrError::InvalidParameter {
                    name: "query",
                    reason: format!("row {i}: {e}"),
                })
            })
            .collect()
    }

    /// The coefficient of determination $R^2 = 1 - \sum (y - \hat y)^2 /
    /// \sum (y - \bar y)^2$ of the predictions at `xs` against the targets
    /// `y` (the first output), as scikit-learn's `score`.
    ///
    /// # Errors
    /// Rows and targets of different lengths, or a row that cannot be
    /// predicted ([`predict_many`](Self::predict_many)).
    pub fn score<X: AsRef<[f64]> + Sync>(&self, xs: &[X], y: &[f64]) -> Result<f64> {
        if y.len() != xs.len() {
            return Err(LwrError::DimensionMismatch {
                what: "targets",
                expected: xs.len(),
                actual: y.len(),
            });
        }
        let predictions = self.predict_many(xs)?;
        let mean = y.iter().sum::<f64>() / y.len() as f64;
        let ss_res: f64 = predictions.iter().zip(y).map(|(p, y)| (y - p.mean[0]).powi(2)).sum();
        let ss_tot: f64 = y.iter().map(|y| (y - mean).powi(2)).sum();
        Ok(1.0 - ss_res / ss_tot)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` rows of `d` inputs in [-1, 1] (xorshift from `seed`), each input
    /// multiplied by its `units`.
    fn rows(n: usize, units: &[f64], seed: u64) -> Vec<Vec<f64>> {
        let mut s = seed | 1;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s % 20_001) as f64 / 10_000.0 - 1.0
        };
        (0..n).map(|_| units.iter().map(|u| u * next()).collect()).collect()
    }

    /// A linear function is reproduced exactly by the local linear fits
    /// (R^2 = 1 on new rows), whatever the inputs' units.
    #[test]
    fn a_linear_function_is_fitted_exactly_in_any_units() {
        for units in [[1.0, 1.0], [0.048, 0.048], [1e6, 1e-3]] {
            let xs = rows(60, &units, 3);
            let f = |x: &[f64]| 2.0 + 3.0 * x[0] / units[0] - x[1] / units[1];
            let y: Vec<f64> = xs.iter().map(|x| f(x)).collect();
            let model = LwrModel::fit(&xs, &y).expect("fits");
            let test = rows(20, &units, 4);
            let yt: Vec<f64> = test.iter().map(|x| f(x)).collect();
            let r2 = model.score(&test, &yt).expect("scores");
            assert!((r2 - 1.0).abs() < 1e-9, "{units:?}: R^2 = {r2}");
            // the scales start at 1 / sd: the initial bandwidth is in standard deviations
            let sd0 = (xs.iter().map(|x| x[0] * x[0]).sum::<f64>() / 60.0
                - (xs.iter().map(|x| x[0]).sum::<f64>() / 60.0).powi(2))
            .sqrt();
            let untuned = LwrModel::fit_multi(
                &xs,
                &y.iter().map(|&v| [v]).collect::<Vec<_>>(),
                &FitSettings {
                    tune_evals: 0,
                    ..FitSettings::default()
                },
            )
            .expect("fits")
            .0;
            assert!((untuned.settings().scales[0] * sd0 - 1.0).abs() < 1e-9);
        }
    }

    /// Bad data are errors naming the input or the lengths.
    #[test]
    fn bad_data_are_refused() {
        let xs = vec![vec![1.0, 5.0], vec![2.0, 5.0], vec![3.0, 5.0]];
        let e = LwrModel::fit(&xs, &[1.0, 2.0, 3.0])
            .expect_err("constant input")
            .to_string();
        assert!(e.contains("input 1 has standard deviation 0"), "{e}");
        assert!(LwrModel::fit(&xs[..2], &[1.0]).is_err());
        assert!(LwrModel::fit::<Vec<f64>>(&[], &[]).is_err());
        let model = LwrModel::fit(&rows(30, &[1.0], 5), &vec![1.0; 30]).expect("fits a constant");
        assert!(model.score(&rows(3, &[1.0], 6), &[1.0, 1.0]).is_err());
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(12))]

        /// The front door reaches the model configured by hand: the same
        /// scales, insertion and tuning give the same predictions, bit for bit.
        #[test]
        fn fit_equals_the_model_configured_by_hand(
            seed in proptest::prelude::any::<u64>(),
            evals in 0usize..20,
            unit in 1e-3f64..1e3,
        ) {
            let xs = rows(40, &[unit, 1.0], seed);
            let ys: Vec<[f64; 1]> = xs.iter().map(|x| [(x[0] / unit).sin() + x[1] * x[1]]).collect();
            let settings = FitSettings { tune_evals: evals, ..FitSettings::default() };
            let (model, _) = LwrModel::fit_multi(&xs, &ys, &settings).expect("fits");
            let sd = |j: usize| {
                let m = xs.iter().map(|x| x[j]).sum::<f64>() / 40.0;
                (xs.iter().map(|x| (x[j] - m).powi(2)).sum::<f64>() / 40.0).sqrt()
            };
            let mut by_hand = LwrModel::new(2, 1, LwrSettings {
                bandwidth: 0.5,
                scales: vec![1.0 / sd(0), 1.0 / sd(1)],
                ..LwrSettings::default()
            }).expect("model");
            by_hand.insert_many(&xs, &ys).expect("rows");
            if evals > 0 {
                let tune = TuneSettings { max_evals: evals, method: TuneMethod::LevenbergMarquardt, ..TuneSettings::default() };
                let tuned = by_hand.tune(&tune).expect("tunes");
                by_hand.set_settings(tuned.settings).expect("settings");
            }
            for q in rows(5, &[unit, 1.0], seed ^ 7) {
                let (a, b) = (model.predict_mean(&q), by_hand.predict_mean(&q));
                proptest::prop_assert_eq!(a.is_ok(), b.is_ok());
                if let (Ok(a), Ok(b)) = (a, b) {
                    proptest::prop_assert_eq!(a, b);
                }
            }
        }
    }
}
