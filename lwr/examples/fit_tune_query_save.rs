//! The life of an LWR model: fit, tune, query with intervals, save, load.
//!
//! Noisy samples of y = sin(3 x) + x/2 on [-2, 2] go into a local linear
//! model with a Gaussian kernel. Leave-one-out cross-validation tunes the
//! bandwidth; each query then returns the estimate, a 95 % confidence
//! interval for the mean and a 95 % prediction interval for a new
//! observation, and how many points effectively support it (which drops
//! outside the data: the intervals widen there). The model is saved as JSON
//! and loaded back. Copy this file to start with a data set of your own.
//!
//! `cargo run --release -p nprl-lwr --example fit_tune_query_save`

use lwr::{Kernel, LwrModel, LwrSettings, TuneSettings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // a small deterministic noise source, so the example needs no crate
    let mut seed = 7u64;
    let mut noise = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        0.1 * ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
    };
    let truth = |x: f64| (3.0 * x).sin() + 0.5 * x;

    // fit: one input, one output; the settings are a starting point
    let settings = LwrSettings {
        kernel: Kernel::Gaussian,
        bandwidth: 1.0,
        ..Default::default()
    };
    let mut model = LwrModel::new(1, 1, settings)?;
    for i in 0..200 {
        let x = -2.0 + 4.0 * i as f64 / 199.0;
        model.insert(&[x], &[truth(x) + noise()])?;
    }

    // tune the metric by leave-one-out cross-validation
    let before = model.loo()?.normalized_mse;
    let tuned = model.tune(&TuneSettings::default())?;
    model.set_settings(tuned.settings.clone())?;
    println!(
        "leave-one-out normalised MSE {before:.2e} -> {:.2e}; bandwidth {:.3}",
        tuned.objective, tuned.settings.bandwidth
    );

    // query inside and outside the data
    for q in [0.3, 2.0, 2.03, 3.0] {
        // far outside the data no point has weight: a typed error, not a guess
        let p = match model.predict(&[q]) {
            Ok(p) => p,
            Err(e) => {
                println!("x = {q:.2}: no prediction ({e})");
                continue;
            }
        };
        let (clo, chi) = p.confidence_interval(0).ok_or("no output 0")?;
        let (plo, phi) = p.prediction_interval(0).ok_or("no output 0")?;
        println!(
            "x = {q:.2}: {:.3} (truth {:.3}), mean in [{clo:.3}, {chi:.3}], new sample in [{plo:.3}, {phi:.3}], \
             {:.1} points of support, {:?}",
            p.mean[0],
            truth(q),
            p.n_lwr,
            p.status
        );
    }

    // save and load: the loaded model predicts exactly the same
    let path = std::env::temp_dir().join("lwr_example_model.json");
    model.save(std::fs::File::create(&path)?)?;
    let loaded = LwrModel::load(std::fs::File::open(&path)?)?;
    assert_eq!(loaded.predict(&[0.3])?.mean, model.predict(&[0.3])?.mean);
    println!("saved to and loaded from {}", path.display());
    std::fs::remove_file(&path)?;
    Ok(())
}
