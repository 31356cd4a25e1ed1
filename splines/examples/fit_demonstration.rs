//! A demonstrated trajectory as a few basis coefficients: B-splines and
//! wavelets, behind the same `TrajectoryBasis` trait.
//!
//! A "demonstration" of two channels (an angle and a command, sampled at
//! 60 Hz for 2.5 s with measurement noise) is fitted by least squares with a
//! small ridge over 20 cubic B-splines, then evaluated and differentiated
//! anywhere in the domain; and the angle is analysed by Daubechies-4
//! wavelets, of which 20 coefficients are kept.
//! This is how the planner in `trajopt` represents its state and command
//! trajectories. Copy this file to start with a trajectory of your own.
//!
//! `cargo run --release -p nprl-splines --example fit_demonstration`

use splines::faer::Mat;
use splines::wavelet::{Boundary, Wavelet, WaveletBasis};
use splines::{BSplineBasis, FitSettings, Trajectory, TrajectoryBasis};

fn main() -> Result<(), splines::SplineError> {
    let n = 150;
    let times: Vec<f64> = (0..n).map(|k| k as f64 / 60.0).collect();
    let mut seed = 11u64;
    let mut noise = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        0.02 * ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
    };
    // channel 0: a swing growing in amplitude; channel 1: the command driving it
    let samples = Mat::from_fn(n, 2, |k, c| {
        let t = times[k];
        let clean = if c == 0 {
            0.6 * t * (4.0 * t).sin()
        } else {
            2.0 * (4.0 * t).cos()
        };
        clean + noise()
    });
    let settings = FitSettings {
        ridge: 1e-8,
        ..Default::default()
    };

    // B-splines: a least-squares fit of both channels over 20 cubic B-splines
    let bspline = BSplineBasis::clamped_uniform(20, 3, 0.0, times[n - 1])?;
    let by_bspline = Trajectory::fit(&bspline, &times, samples.as_ref(), &settings)?;
    let fitted = by_bspline.evaluate(&times, 0)?;
    println!(
        "cubic B-splines: {} coefficients per channel, rms residual of the angle {:.4}",
        bspline.n_coeffs(),
        rms(n, |k| fitted[(k, 0)] - samples[(k, 0)])
    );

    // wavelets: the Daubechies-4 analysis of the angle, then only its 20
    // largest coefficients kept (a smooth signal is sparse in wavelets)
    let wavelet = WaveletBasis::new(Wavelet::Db4, Boundary::Periodization, n, None, 0.0, 1.0 / 60.0)?;
    let angle: Vec<f64> = (0..n).map(|k| samples[(k, 0)]).collect();
    let mut coeffs = wavelet.analyse(&angle)?;
    let mut order: Vec<usize> = (0..coeffs.len()).collect();
    order.sort_by(|&a, &b| coeffs[b].abs().total_cmp(&coeffs[a].abs()));
    for &i in &order[20..] {
        coeffs[i] = 0.0;
    }
    let compressed = wavelet.synthesise(&coeffs)?;
    println!(
        "Daubechies-4 wavelets: 20 of {} coefficients kept, rms residual of the angle {:.4}",
        wavelet.n_coeffs(),
        rms(n, |k| compressed[k] - angle[k])
    );
    // the same basis fits by least squares like any other (here exactly: it spans every signal)
    let by_wavelet = Trajectory::fit(&wavelet, &times, samples.as_ref(), &settings)?;
    println!(
        "Daubechies-4 least-squares fit: rms residual {:.2e}",
        rms(n, |k| by_wavelet
            .evaluate(&times[k..=k], 0)
            .map_or(f64::NAN, |v| v[(0, 0)] - angle[k]))
    );

    // evaluate the smooth fit between samples, with its derivative
    let t = [1.2345];
    let value = by_bspline.evaluate(&t, 0)?;
    let rate = by_bspline.evaluate(&t, 1)?;
    println!(
        "at t = {}: angle {:.4}, angular velocity {:.4}",
        t[0],
        value[(0, 0)],
        rate[(0, 0)]
    );
    Ok(())
}

/// The root mean square of `f(0), ..., f(n - 1)`.
fn rms(n: usize, f: impl Fn(usize) -> f64) -> f64 {
    ((0..n).map(|k| f(k).powi(2)).sum::<f64>() / n as f64).sqrt()
}
