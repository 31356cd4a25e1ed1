//! `LwrModel::fit` on a data set from `scripts/lwr_diabetes.py`, for the
//! side-by-side comparison with scikit-learn's `KNeighborsRegressor` (k by
//! `GridSearchCV`) and statsmodels' `KernelReg`: the library's front door
//! exactly as a user calls it (`lwr::regressor`).
//!
//! `cargo run --release -p nprl-drivers --bin lwr_fit_timing -- DATA.json [TUNE_EVALS [TUNE_POINTS [lm|compass]]]`
//! (defaults: `FitSettings::default()`, i.e. `LwrModel::fit`)
//!
//! `DATA.json` holds `train_x` ($n \times d$), `train_y` ($n$), `test_x`,
//! `test_y`. Prints one JSON object on one line: the seconds of `fit`
//! (scales from the data, the metric tuned by leave-one-out) and of
//! `predict_many` over the test rows, the test RMSE, the tuning's
//! evaluations and leave-one-out objective, and the share of test
//! targets inside their 95 % prediction intervals.

use std::time::Instant;

use lwr::{FitSettings, LwrModel};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: lwr_fit_timing DATA.json")?;
    let data = nprl_drivers::RegressionData::read(&path)?;

    // optional: the tuning's evaluations and points (FitSettings), for the
    // directions the script's --tune-evals and --tune-points measure
    let arg = |i: usize| std::env::args().nth(i).map(|a| a.parse::<usize>()).transpose();
    let settings = FitSettings {
        tune_evals: arg(2)?.unwrap_or(FitSettings::default().tune_evals),
        tune_points: arg(3)?.unwrap_or(0),
        tune_method: match std::env::args().nth(4).as_deref() {
            None => FitSettings::default().tune_method,
            Some("compass") => lwr::TuneMethod::Compass,
            Some("lm") => lwr::TuneMethod::LevenbergMarquardt,
            Some(other) => return Err(format!("unknown tuning method {other:?}: compass or lm").into()),
        },
        ..FitSettings::default()
    };
    let ys: Vec<[f64; 1]> = data.train_y.iter().map(|&y| [y]).collect();
    let t = Instant::now();
    let (model, tuned) = LwrModel::fit_multi(&data.train_x, &ys, &settings)?;
    let fit_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let predictions = model.predict_many(&data.test_x)?;
    let predict_s = t.elapsed().as_secs_f64();

    let m = data.test_y.len() as f64;
    let rmse = (predictions
        .iter()
        .zip(&data.test_y)
        .map(|(p, y)| (p.mean[0] - y).powi(2))
        .sum::<f64>()
        / m)
        .sqrt();
    let inside = predictions
        .iter()
        .zip(&data.test_y)
        .filter(|(p, y)| p.prediction_interval(0).is_some_and(|(lo, hi)| lo <= **y && **y <= hi))
        .count();
    println!(
        "{}",
        serde_json::json!({
            "fit_s": fit_s,
            "predict_s": predict_s,
            "rmse": rmse,
            "coverage": inside as f64 / m,
            "r2": model.score(&data.test_x, &data.test_y)?,
            "bandwidth": model.settings().bandwidth,
            "scales": model.settings().scales,
            "tune_evals": tuned.as_ref().map(|t| t.evals),
            "loo": tuned.as_ref().map(|t| t.objective),
        })
    );
    Ok(())
}
