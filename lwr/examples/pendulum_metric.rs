//! Claim C7 in miniature: cross-validation finds that the hand's position and
//! velocity do not matter for the pendulum's next angular velocity.
//!
//! Inputs: angle, angular velocity, hand position, hand velocity, hand
//! acceleration; output: angular velocity one step later. The hand position
//! and velocity enter the data (they vary) but not the dynamics. Tuning the
//! metric by leave-one-out cross-validation drives their scales to zero.
//!
//! A zero scale means "needs no locality", which is not quite "irrelevant":
//! the angular velocity enters the dynamics linearly, so the local linear
//! model fits it globally and its scale goes to zero too. Irrelevance proper
//! shows in the fitted slope (near zero for the hand inputs), or by tuning a
//! local constant model.
//!
//! `cargo run --release -p nprl-lwr --example pendulum_metric`

use lwr::{Kernel, LwrModel, LwrSettings, TuneSettings};

fn main() -> Result<(), lwr::LwrError> {
    let (g, l, dt, damping) = (9.81, 0.5, 0.02, 0.1);
    let names = [
        "angle",
        "ang. velocity",
        "hand position",
        "hand velocity",
        "hand accel.",
    ];
    let mut seed = 2024u64;
    let mut uniform = move |lo: f64, hi: f64| {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        lo + (hi - lo) * (seed >> 11) as f64 / (1u64 << 53) as f64
    };

    // scales in the inputs' own units: one over each input's range
    let ranges = [(-3.0, 3.0), (-6.0, 6.0), (-0.4, 0.4), (-1.5, 1.5), (-8.0, 8.0)];
    let settings = LwrSettings {
        kernel: Kernel::Gaussian,
        bandwidth: 0.3,
        scales: ranges.iter().map(|(lo, hi)| 1.0 / (hi - lo)).collect(),
        ..Default::default()
    };
    let mut model = LwrModel::new(5, 1, settings)?;
    for _ in 0..800 {
        let x: Vec<f64> = ranges.iter().map(|&(lo, hi)| uniform(lo, hi)).collect();
        let (theta, omega, accel) = (x[0], x[1], x[4]);
        let omega_dot = -(g / l) * theta.sin() - (accel / l) * theta.cos() - damping * omega;
        let next = omega + dt * omega_dot + 0.002 * uniform(-1.0, 1.0);
        model.insert(&x, &[next])?;
    }

    let before = model.loo()?;
    let tuned = model.tune(&TuneSettings::default())?;
    println!(
        "LOO normalised MSE {:.2e} -> {:.2e} ({} evaluations, {:?})",
        before.normalized_mse, tuned.objective, tuned.evals, tuned.status
    );
    let s = &tuned.settings;
    for ((name, m), (lo, hi)) in names.iter().zip(&s.scales).zip(ranges) {
        // scale times range over bandwidth: how many bandwidths the input spans
        println!(
            "  {name:>14}: m = {m:.3e}, spans {:.2} bandwidths",
            m * (hi - lo) / s.bandwidth
        );
    }
    model.set_settings(tuned.settings.clone())?;
    let p = model.predict(&[0.5, 1.0, 0.0, 0.0, 2.0])?;
    println!(
        "prediction {:.4} +- {:.4} (95 % CI), n_lwr {:.1}, status {:?}",
        p.mean[0], p.confidence_half_width[0], p.n_lwr, p.status
    );
    Ok(())
}
