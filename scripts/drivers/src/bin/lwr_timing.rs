//! Timings and errors of `lwr` on a data set from `scripts/compare_lwr.py`,
//! for the side-by-side comparison with statsmodels' `KernelReg` and
//! scikit-learn's neighbour regressors.
//!
//! `cargo run --release -p nprl-drivers --bin lwr_timing -- DATA.json`
//!
//! `DATA.json` holds `train_x` ($n \times d$), `train_y` ($n$), `test_x`,
//! `test_y`. The model is local linear with the Gaussian kernel, starting
//! from the metric $m_j = 1 / s_j$ ($s_j$ the inputs' standard deviations)
//! and $h = 0.5$, and tuned with [`LwrModel::tune`] (bandwidth and every
//! scale, default [`TuneSettings`]). Prints one JSON object on one line:
//! build, tune, LOO and query timings (seconds), the number of tuning
//! evaluations (and how many of them stopped early), the tuned bandwidths in the
//! inputs' units ($h / m_j$, the analogue of `KernelReg`'s `bw`), and the
//! leave-one-out and test normalised MSE.

use std::time::Instant;

use lwr::{Kernel, LwrModel, LwrSettings, TuneSettings};

fn variance(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or("usage: compare_timing DATA.json")?;
    let data = nprl_drivers::RegressionData::read(&path)?;
    let d = data.train_x.first().map(Vec::len).ok_or("no training rows")?;
    let n = data.train_x.len();
    let spreads: Vec<f64> = (0..d)
        .map(|j| variance(&data.train_x.iter().map(|x| x[j]).collect::<Vec<_>>()).sqrt())
        .collect();
    let settings = LwrSettings {
        kernel: Kernel::Gaussian,
        bandwidth: 0.5,
        scales: spreads.iter().map(|s| 1.0 / s).collect(),
        ..Default::default()
    };
    let ys: Vec<[f64; 1]> = data.train_y.iter().map(|&y| [y]).collect();

    let t = Instant::now();
    let mut model = LwrModel::new(d, 1, settings)?;
    model.insert_many(&data.train_x, &ys)?;
    let build = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let tuned = model.tune(&TuneSettings::default())?;
    let tune = t.elapsed().as_secs_f64();
    let n_stopped = tuned.history.iter().filter(|s| !s.complete).count();
    model.set_settings(tuned.settings)?;

    let t = Instant::now();
    let loo = model.loo()?;
    let loo_time = t.elapsed().as_secs_f64();

    // one query at a time on one thread
    let t = Instant::now();
    let mut means = Vec::with_capacity(data.test_x.len());
    let mut n_failed = 0;
    for q in &data.test_x {
        match model.predict(q) {
            Ok(p) => means.push(p.mean[0]),
            Err(_) => {
                n_failed += 1;
                means.push(f64::NAN);
            }
        }
    }
    let query = t.elapsed().as_secs_f64() / data.test_x.len() as f64;
    // the same queries as a parallel batch
    let t = Instant::now();
    let batch = model.predict_batch(&data.test_x);
    let batch_query = t.elapsed().as_secs_f64() / data.test_x.len() as f64;
    debug_assert_eq!(batch.len(), means.len());

    let (sse, m) = means
        .iter()
        .zip(&data.test_y)
        .filter(|(p, _)| p.is_finite())
        .fold((0.0, 0usize), |(s, m), (p, y)| (s + (p - y) * (p - y), m + 1));
    let test_nmse = sse / (m as f64 * variance(&data.test_y));
    let s = model.settings();
    let bw: Vec<f64> = s
        .scales
        .iter()
        .map(|&m| if m > 0.0 { s.bandwidth / m } else { f64::INFINITY })
        .collect();
    let out = serde_json::json!({
        "n_train": n,
        "n_test": data.test_x.len(),
        "d": d,
        "build_s": build,
        "tune_s": tune,
        "tune_evals": tuned.evals,
        "tune_evals_stopped_early": n_stopped,
        "loo_s": loo_time,
        "query_s": query,
        "batch_query_s": batch_query,
        "threads": rayon::current_num_threads(),
        "loo_nmse": loo.normalized_mse,
        "test_nmse": test_nmse,
        "n_failed": n_failed,
        "bandwidths": bw.iter().map(|b| if b.is_finite() { serde_json::json!(b) } else { serde_json::Value::Null }).collect::<Vec<_>>(),
    });
    println!("{out}");
    Ok(())
}
