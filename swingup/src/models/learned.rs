//! Learning a model from the trials: the training pairs, the LWR fitted
//! and its metric tuned by leave-one-out cross-validation.

use lwr::{LwrSettings, TuneSettings};

use crate::config::{LwrPrior, ModelConfig, ModelKind};
use crate::models::nonparametric::ALL_INPUTS;
use crate::models::selection;
use crate::models::{
    ControlAffineRegression, INPUTS, KnownHand, LearnedModel, LinearRegression, LwrRegression, PendulumRegression,
};
use crate::record::{ModelSummary, TrialRecord, training_data};

/// Fits the LWR model of `settings` to all trials so far (sampled every
/// `dt` seconds) and tunes its metric by leave-one-out cross-validation.
pub fn learn_model(
    settings: &ModelConfig,
    dt: f64,
    trials: &[TrialRecord],
) -> crate::Result<(LearnedModel, ModelSummary)> {
    let m = settings;
    let (xs, ys) = training_data(trials);
    crate::error::ensure_data!(!xs.is_empty(), "no data to learn from");
    // initial metric: each input divided by its spread
    let spread: Vec<f64> = (0..5)
        .map(|c| {
            let mean = xs.iter().map(|x| x[c]).sum::<f64>() / xs.len() as f64;
            let var = xs.iter().map(|x| (x[c] - mean).powi(2)).sum::<f64>() / xs.len() as f64;
            var.sqrt().max(1e-6)
        })
        .collect();
    let base_scales: Vec<f64> = spread.iter().map(|s| 1.0 / s).collect();
    let settings = LwrSettings {
        kernel: m.kernel,
        degree: m.degree,
        bandwidth: m.bandwidth,
        scales: base_scales.iter().zip(&m.input_scales).map(|(b, r)| b * r).collect(),
        ridge: m.ridge,
        slope_ridge: m.slope_ridge,
        intercept_ridge: m.prior_weight,
        gaussian_cutoff: m.cutoff,
        ..LwrSettings::default()
    };
    let parametric = m.kind == ModelKind::LwrParametric;
    let prior_kind = m.prior;
    let fit_prior = |xs: &[[f64; 5]],
                     ys: &[[f64; 1]],
                     inputs: &[usize]|
     -> crate::Result<Box<dyn PendulumRegression + Send + Sync>> {
        Ok(if parametric {
            Box::new(crate::models::parametric::ParametricRegression::fit_midpoint(
                xs, ys, dt,
            )?)
        } else {
            match prior_kind {
                LwrPrior::Linear => Box::new(LinearRegression::fit_inputs(xs, ys, inputs)?),
                LwrPrior::Constant => Box::new(LinearRegression::fit_inputs(xs, ys, &[])?),
                LwrPrior::ControlAffine => Box::new(ControlAffineRegression::fit_inputs(xs, ys, inputs)?),
            }
        })
    };
    // validate() holds cv_blocks >= 2 when the selection is on
    let selection = if m.select_inputs && xs.len() >= 2 {
        let lengths: Vec<usize> = trials.iter().map(|t| t.commands.len()).collect();
        let groups = selection::trial_groups(&lengths, m.cv_blocks);
        selection::select_inputs(&xs, &ys, &groups, &settings, &fit_prior)?
    } else {
        Vec::new()
    };
    let inputs = selection.last().map_or(ALL_INPUTS.to_vec(), |s| s.inputs.clone());
    let settings = selection::restrict(&settings, &inputs);
    let prior = fit_prior(&xs, &ys, &inputs)?;
    let name = match (parametric, prior_kind) {
        (true, _) => "parametric",
        (false, LwrPrior::Linear) => "linear",
        (false, LwrPrior::Constant) => "constant",
        (false, LwrPrior::ControlAffine) => "control-affine",
    };
    let mut model = LwrRegression::fit_on(&xs, &ys, &inputs, settings, prior, name)?;
    let lwr = model.lwr_mut();
    let (settings, loo_nmse) = if m.tune_evals > 0 {
        let tuned = lwr.tune(&TuneSettings {
            max_evals: m.tune_evals,
            search_points: m.tune_points,
            ..TuneSettings::default()
        })?;
        (tuned.settings, tuned.objective)
    } else {
        let loo = lwr.loo()?;
        (lwr.settings().clone(), loo.normalized_mse)
    };
    lwr.set_settings(settings.clone())?;
    // the LWR part against its prior: LOO MSE of prior + LWR over the prior's MSE
    let resid: Vec<f64> = xs
        .iter()
        .zip(&ys)
        .map(|(x, y)| y[0] - model.prior().delta_omega(x, None))
        .collect();
    let n = resid.len() as f64;
    let mean = resid.iter().sum::<f64>() / n;
    let variance = resid.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n;
    let prior_mse = resid.iter().map(|r| r * r).sum::<f64>() / n;
    let lwr_vs_prior = if prior_mse > 0.0 {
        loo_nmse * variance / prior_mse
    } else {
        f64::NAN
    };
    let summary = ModelSummary {
        kind: if m.kind == ModelKind::LwrParametric {
            "lwr-parametric"
        } else {
            "lwr"
        }
        .into(),
        n_points: xs.len(),
        inputs: INPUTS.iter().map(|s| s.to_string()).collect(),
        // relative to the initial normalisation; 0 for the inputs left out
        scales: (0..5)
            .map(|j| {
                inputs
                    .iter()
                    .position(|&i| i == j)
                    .map_or(0.0, |c| settings.scales[c] / base_scales[j])
            })
            .collect(),
        bandwidth: settings.bandwidth,
        loo_nmse,
        lwr_vs_prior,
        dropped: (0..5)
            .filter(|j| !inputs.contains(j))
            .map(|j| INPUTS[j].to_string())
            .collect(),
        selection_cv: selection.iter().map(|s| s.cv_nmse).collect(),
    };
    Ok((KnownHand::new(model, dt), summary))
}

/// The summary of the true model (no data are fitted).
pub fn true_model_summary(trials: &[TrialRecord]) -> ModelSummary {
    ModelSummary {
        kind: "true".into(),
        n_points: trials.iter().map(|t| t.commands.len()).sum(),
        inputs: INPUTS.iter().map(|s| s.to_string()).collect(),
        scales: vec![],
        bandwidth: f64::NAN,
        loo_nmse: 0.0,
        lwr_vs_prior: f64::NAN,
        dropped: Vec::new(),
        selection_cv: Vec::new(),
    }
}
