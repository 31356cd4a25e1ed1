//! Leave-one-out cross-validation in closed form, and tuning of the
//! bandwidth and metric by minimising it.

use rayon::prelude::*;

use crate::error::{LwrError, Result};
use crate::fit::Want;
use crate::model::LwrModel;
use crate::settings::LwrSettings;

/// Smallest relative decrease of the objective that counts as a move.
const MIN_IMPROVEMENT: f64 = 1e-9;

/// Smallest $1 - L_{ii}$ for which a leave-one-out residual is computed.
const MIN_ONE_MINUS_LEVERAGE: f64 = 1e-8;

/// Per point: fitted values, LOO residuals, leverage, undetermined, regularised.
type PointLoo = (Vec<f64>, Vec<f64>, f64, bool, bool);

/// Leave-one-out residuals over the whole database and their summaries.
///
/// For point $i$ the model is fitted at $q = x_i$ (point $i$ included, with
/// weight $K(0) = 1$); its own weight in that fit is
/// $L_{ii} = K(0)\, z_i^\top P(x_i) z_i = P_{00}(x_i)$ since $z_i = e_0$ at
/// its own input. Removing the point is a rank-one update, so exactly
/// $$e_{(-i)} = \frac{y_i - \hat y(x_i)}{1 - L_{ii}},$$
/// ridge included. When $1 - L_{ii} < 10^{-8}$ (the point alone
/// determines its fit, so leaving it out leaves no data) the residual is
/// taken as $y_i - \bar y$ against the database mean and the point is
/// counted in `n_undetermined`: isolating points is penalised, never
/// rewarded. Fits that needed the fallback ridge are cross-validated as
/// regularised fits (counted in `n_regularized`).
#[derive(Debug, Clone, PartialEq)]
pub struct LooResult {
    /// $e_{(-i)}$, $n \times o$ row-major.
    pub residuals: Vec<f64>,
    /// $\hat y(x_i)$ with the point included, $n \times o$ row-major.
    pub fitted: Vec<f64>,
    /// $L_{ii}$ per point.
    pub leverages: Vec<f64>,
    /// PRESS $= \sum_i e_{(-i)}^2$ per output.
    pub press: Vec<f64>,
    /// GCV $= n\,\mathrm{RSS} / (n - \operatorname{tr} L)^2$ per output.
    pub gcv: Vec<f64>,
    /// Mean over outputs of PRESS$/n$.
    pub mse: f64,
    /// Mean over outputs of PRESS$/(n \operatorname{var} y_o)$: the
    /// scale-free objective of [`LwrModel::tune`] (1 is as good as
    /// predicting the mean).
    pub normalized_mse: f64,
    /// Points whose leave-one-out fit had no data.
    pub n_undetermined: usize,
    /// Points whose fit used the fallback ridge.
    pub n_regularized: usize,
}

/// Settings of [`LwrModel::tune`].
///
/// | name | default | meaning |
/// |---|---|---|
/// | `tune_bandwidth` | true | search over $h$ |
/// | `tune_scales` | true | search over each $m_j$ |
/// | `try_zero` | true | also try $m_j = 0$ (drop input $j$ from the metric) |
/// | `zero_tolerance` | $10^{-6}$ | drop an input if that raises the objective by less than this, relatively |
/// | `initial_factor` | 4 | first multiplicative step |
/// | `min_factor` | 1.05 | stop when the step falls below this factor |
/// | `max_evals` | 300 | budget of leave-one-out evaluations |
#[derive(Debug, Clone, PartialEq)]
pub struct TuneSettings {
    /// Search over the bandwidth.
    pub tune_bandwidth: bool,
    /// Search over the metric scales.
    pub tune_scales: bool,
    /// Also try a zero scale for each input.
    pub try_zero: bool,
    /// Largest relative increase of the objective accepted for dropping an
    /// input (a simpler metric wins near-ties), $\ge 0$.
    pub zero_tolerance: f64,
    /// First multiplicative step, $> 1$.
    pub initial_factor: f64,
    /// Smallest multiplicative step, in $(1, $ `initial_factor` $]$.
    pub min_factor: f64,
    /// Largest number of objective evaluations.
    pub max_evals: usize,
}

impl Default for TuneSettings {
    fn default() -> Self {
        Self {
            tune_bandwidth: true,
            tune_scales: true,
            try_zero: true,
            zero_tolerance: 1e-6,
            initial_factor: 4.0,
            min_factor: 1.05,
            max_evals: 300,
        }
    }
}

impl TuneSettings {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        if !(self.initial_factor.is_finite() && self.initial_factor > 1.0) {
            return Err(LwrError::InvalidParameter {
                name: "initial_factor",
                reason: format!("must be finite and > 1, got {}", self.initial_factor),
            });
        }
        if !(self.min_factor > 1.0 && self.min_factor <= self.initial_factor) {
            return Err(LwrError::InvalidParameter {
                name: "min_factor",
                reason: format!(
                    "must be in (1, initial_factor = {}], got {}",
                    self.initial_factor, self.min_factor
                ),
            });
        }
        if !(self.zero_tolerance.is_finite() && self.zero_tolerance >= 0.0) {
            return Err(LwrError::InvalidParameter {
                name: "zero_tolerance",
                reason: format!("must be finite and >= 0, got {}", self.zero_tolerance),
            });
        }
        if self.max_evals == 0 {
            return Err(LwrError::InvalidParameter {
                name: "max_evals",
                reason: "must be at least 1".into(),
            });
        }
        Ok(())
    }
}

/// Why tuning stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum TuneStatus {
    /// The step fell below `min_factor` with no improving move.
    Converged,
    /// The evaluation budget ran out.
    MaxEvals,
}

/// One evaluated point of the search.
#[derive(Debug, Clone, PartialEq)]
pub struct TuneStep {
    /// Bandwidth tried.
    pub bandwidth: f64,
    /// Scales tried.
    pub scales: Vec<f64>,
    /// Its normalised leave-one-out MSE (infinite if the evaluation failed).
    pub objective: f64,
    /// Whether the search moved there.
    pub accepted: bool,
}

/// The outcome of [`LwrModel::tune`].
#[derive(Debug, Clone, PartialEq)]
pub struct TuneResult {
    /// The tuned settings (the input settings with `bandwidth` and `scales`
    /// replaced).
    pub settings: LwrSettings,
    /// Normalised leave-one-out MSE at the tuned settings.
    pub objective: f64,
    /// Normalised leave-one-out MSE at the initial settings.
    pub initial_objective: f64,
    /// Every evaluation, in order.
    pub history: Vec<TuneStep>,
    /// Number of evaluations.
    pub evals: usize,
    /// Why the search stopped.
    pub status: TuneStatus,
}

impl LwrModel {
    /// Leave-one-out cross-validation of the current settings over the
    /// whole database (parallel over points). See [`LooResult`].
    ///
    /// ```
    /// # use lwr::{LwrModel, LwrSettings};
    /// let mut m = LwrModel::new(1, 1, LwrSettings { bandwidth: 0.3, ..Default::default() })?;
    /// for i in 0..40 {
    ///     let x = i as f64 / 40.0;
    ///     m.insert(&[x], &[3.0 * x + 1.0])?;
    /// }
    /// let loo = m.loo()?;
    /// // a line is predicted exactly even without the point itself
    /// assert!(loo.press[0] < 1e-20);
    /// assert_eq!(loo.leverages.len(), 40);
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    pub fn loo(&self) -> Result<LooResult> {
        self.loo_with(self.settings())
    }

    /// [`loo`](Self::loo) for other settings (validated), without changing
    /// the model.
    pub fn loo_with(&self, settings: &LwrSettings) -> Result<LooResult> {
        let db = self.database();
        settings.validate(db.n_inputs())?;
        if db.is_empty() {
            return Err(LwrError::EmptyDatabase);
        }
        let scales = settings.scales_for(db.n_inputs());
        let n = db.len();
        let o = db.n_outputs();
        let mut mean = vec![0.0; o];
        for i in 0..n {
            for (m, y) in mean.iter_mut().zip(&db.outputs()[i * o..(i + 1) * o]) {
                *m += y / n as f64;
            }
        }
        let mut var = vec![0.0; o];
        for i in 0..n {
            for ((v, y), m) in var.iter_mut().zip(&db.outputs()[i * o..(i + 1) * o]).zip(&mean) {
                *v += (y - m) * (y - m) / n as f64;
            }
        }

        // per point: (fitted, residuals, leverage, undetermined, regularized)
        let per_point: Vec<PointLoo> = (0..n)
            .into_par_iter()
            .map(|i| {
                let x = &db.inputs()[i * db.n_inputs()..(i + 1) * db.n_inputs()];
                let y = &db.outputs()[i * o..(i + 1) * o];
                match self.fit_with(settings, &scales, x, Want::default()) {
                    Ok(fit) => {
                        let lii = fit.s[0];
                        let fitted = fit.beta[..o].to_vec();
                        let one_minus = 1.0 - lii;
                        if one_minus >= MIN_ONE_MINUS_LEVERAGE {
                            let e = y.iter().zip(&fitted).map(|(y, f)| (y - f) / one_minus).collect();
                            (fitted, e, lii, false, fit.regularized)
                        } else {
                            let e = y.iter().zip(&mean).map(|(y, m)| y - m).collect();
                            (fitted, e, lii, true, fit.regularized)
                        }
                    }
                    Err(_) => {
                        let e = y.iter().zip(&mean).map(|(y, m)| y - m).collect();
                        (mean.clone(), e, 1.0, true, false)
                    }
                }
            })
            .collect();

        let mut res = LooResult {
            residuals: Vec::with_capacity(n * o),
            fitted: Vec::with_capacity(n * o),
            leverages: Vec::with_capacity(n),
            press: vec![0.0; o],
            gcv: vec![0.0; o],
            mse: 0.0,
            normalized_mse: 0.0,
            n_undetermined: 0,
            n_regularized: 0,
        };
        let mut rss = vec![0.0; o];
        let mut trace = 0.0;
        for (i, (fitted, e, lii, undetermined, regularized)) in per_point.into_iter().enumerate() {
            let y = &db.outputs()[i * o..(i + 1) * o];
            for oo in 0..o {
                res.press[oo] += e[oo] * e[oo];
                rss[oo] += (y[oo] - fitted[oo]).powi(2);
            }
            trace += lii;
            res.n_undetermined += usize::from(undetermined);
            res.n_regularized += usize::from(regularized);
            res.residuals.extend(e);
            res.fitted.extend(fitted);
            res.leverages.push(lii);
        }
        let nf = n as f64;
        for oo in 0..o {
            res.gcv[oo] = nf * rss[oo] / (nf - trace).powi(2);
            res.mse += res.press[oo] / nf / o as f64;
            let v = if var[oo] > 0.0 { var[oo] } else { 1.0 };
            res.normalized_mse += res.press[oo] / (nf * v) / o as f64;
        }
        Ok(res)
    }

    /// Tunes the bandwidth $h$ and the metric scales $m_j$ by minimising the
    /// normalised leave-one-out MSE ([`LooResult::normalized_mse`]).
    ///
    /// Method: a compass (coordinate pattern) search in log space. Each
    /// sweep visits $h, m_1, \dots, m_d$; a coordinate is multiplied and
    /// divided by the current factor and keeps moving while that improves;
    /// with `try_zero` a nonzero scale is also tried at 0 (the input dropped
    /// from the metric; accepted if the objective rises by less than
    /// `zero_tolerance`, relatively), and a zero scale is tried back at its
    /// last nonzero value (accepted only if better by more than
    /// `zero_tolerance`, so the search cannot cycle). Moves must lower the
    /// objective by a relative $10^{-9}$ at least. A sweep with no improvement takes the
    /// square root of the factor; the search stops below `min_factor` or
    /// after `max_evals` evaluations. Deterministic; finds a local minimum
    /// along the coordinates.
    ///
    /// Only $m_j / h$ matters, so the result is one of a family of equivalent
    /// settings. Returns the tuned settings and the history; the model is not
    /// changed (apply with [`set_settings`](Self::set_settings)).
    ///
    /// ```
    /// # use lwr::{LwrModel, LwrSettings, TuneSettings};
    /// // y depends on x0 only; x1 is a pure-noise input
    /// let mut m = LwrModel::new(2, 1, LwrSettings { bandwidth: 0.3, ..Default::default() })?;
    /// for i in 0..200 {
    ///     let x0 = (i as f64 * 0.618).fract() * 2.0 - 1.0;
    ///     let x1 = (i as f64 * 0.377).fract() * 2.0 - 1.0;
    ///     m.insert(&[x0, x1], &[(3.0 * x0).sin()])?;
    /// }
    /// let tuned = m.tune(&TuneSettings::default())?;
    /// assert_eq!(tuned.settings.scales[1], 0.0); // x1 dropped from the metric
    /// assert!(tuned.settings.scales[0] > 0.0);
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    pub fn tune(&self, tune: &TuneSettings) -> Result<TuneResult> {
        tune.validate()?;
        let d = self.database().n_inputs();
        let base = self.settings().clone();
        let mut x: Vec<f64> = std::iter::once(base.bandwidth).chain(base.scales_for(d)).collect();
        let mut last_nonzero: Vec<f64> = x.iter().map(|&v| if v > 0.0 { v } else { 1.0 }).collect();
        let mut history = Vec::new();
        let eval = |x: &[f64], history: &mut Vec<TuneStep>| -> f64 {
            let s = LwrSettings {
                bandwidth: x[0],
                scales: x[1..].to_vec(),
                ..base.clone()
            };
            let f = self.loo_with(&s).map_or(f64::INFINITY, |r| r.normalized_mse);
            let f = if f.is_nan() { f64::INFINITY } else { f };
            history.push(TuneStep {
                bandwidth: x[0],
                scales: x[1..].to_vec(),
                objective: f,
                accepted: false,
            });
            f
        };
        let mut f = eval(&x, &mut history);
        if let Some(h) = history.last_mut() {
            h.accepted = true;
        }
        let initial = f;
        let mut coords = Vec::new();
        if tune.tune_bandwidth {
            coords.push(0);
        }
        if tune.tune_scales {
            coords.extend(1..=d);
        }
        let mut factor = tune.initial_factor;
        let mut status = TuneStatus::Converged;
        let budget_left = |history: &Vec<TuneStep>| history.len() < tune.max_evals;
        'search: while factor >= tune.min_factor {
            let mut improved = false;
            for &c in &coords {
                if !budget_left(&history) {
                    status = TuneStatus::MaxEvals;
                    break 'search;
                }
                if x[c] == 0.0 {
                    // try turning a dropped input back on
                    let mut y = x.clone();
                    y[c] = last_nonzero[c];
                    let fy = eval(&y, &mut history);
                    if fy < f * (1.0 - tune.zero_tolerance) {
                        x = y;
                        f = fy;
                        improved = true;
                        if let Some(h) = history.last_mut() {
                            h.accepted = true;
                        }
                    }
                    continue;
                }
                let mut moved = false;
                for dir in [factor, 1.0 / factor] {
                    loop {
                        if !budget_left(&history) {
                            status = TuneStatus::MaxEvals;
                            break 'search;
                        }
                        let mut y = x.clone();
                        y[c] *= dir;
                        let fy = eval(&y, &mut history);
                        if fy < f * (1.0 - MIN_IMPROVEMENT) {
                            x = y;
                            f = fy;
                            moved = true;
                            if let Some(h) = history.last_mut() {
                                h.accepted = true;
                            }
                        } else {
                            break;
                        }
                    }
                    if moved {
                        break;
                    }
                }
                improved |= moved;
                if c > 0 && tune.try_zero {
                    if !budget_left(&history) {
                        status = TuneStatus::MaxEvals;
                        break 'search;
                    }
                    let mut y = x.clone();
                    y[c] = 0.0;
                    let fy = eval(&y, &mut history);
                    if fy <= f * (1.0 + tune.zero_tolerance) {
                        last_nonzero[c] = x[c];
                        x = y;
                        improved |= fy < f * (1.0 - MIN_IMPROVEMENT);
                        f = fy;
                        if let Some(h) = history.last_mut() {
                            h.accepted = true;
                        }
                    }
                }
            }
            if !improved {
                factor = factor.sqrt();
            }
        }
        let evals = history.len();
        Ok(TuneResult {
            settings: LwrSettings {
                bandwidth: x[0],
                scales: x[1..].to_vec(),
                ..base
            },
            objective: f,
            initial_objective: initial,
            history,
            evals,
            status,
        })
    }
}
