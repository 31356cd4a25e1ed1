//! How the planner will use the trajectory bases: a demonstration sampled at
//! 60 Hz is fitted by a shared cubic B-spline basis (the paper's Eqs. 6-7),
//! and the fitted trajectory's derivatives are consistent with the data.

use std::sync::Arc;

use faer::Mat;
use splines::{BSplineBasis, FitSettings, Trajectory, TrajectoryBasis};

/// A smooth swing-like motion and its exact time derivative.
fn motion(t: f64) -> (f64, f64) {
    let w = 2.0 * std::f64::consts::PI / 1.3;
    let a = 1.0 + t; // growing amplitude
    (a * (w * t).sin(), (w * t).sin() + a * w * (w * t).cos())
}

#[test]
fn fitted_demonstration_has_consistent_derivatives() {
    let dt = 1.0 / 60.0;
    let times: Vec<f64> = (0..=150).map(|k| k as f64 * dt).collect();
    let horizon = *times.last().expect("nonempty");
    let samples = Mat::from_fn(times.len(), 2, |k, ch| {
        let (x, v) = motion(times[k]);
        if ch == 0 { x } else { v }
    });
    let basis = Arc::new(BSplineBasis::clamped_uniform(25, 3, 0.0, horizon).expect("valid basis"));
    let traj = Trajectory::fit(basis.clone(), &times, samples.as_ref(), &FitSettings::default()).expect("fit");
    assert_eq!(Arc::strong_count(&basis), 2, "the trajectory shares the basis");

    let mid: Vec<f64> = times.iter().map(|t| t + 0.5 * dt).filter(|&t| t <= horizon).collect();
    let pos = traj.evaluate(&mid, 0).expect("inside");
    let vel = traj.evaluate(&mid, 1).expect("inside");
    for (k, &t) in mid.iter().enumerate() {
        let (x, v) = motion(t);
        // 25 cubic pieces over 2.5 s resolve this motion to well under 1 %
        assert!((pos[(k, 0)] - x).abs() < 1e-2, "position at {t}");
        assert!((pos[(k, 1)] - v).abs() < 5e-2, "velocity channel at {t}");
        // the derivative of the fitted position agrees with the fitted velocity
        if (0.2..horizon - 0.2).contains(&t) {
            assert!(
                (vel[(k, 0)] - pos[(k, 1)]).abs() < 0.1,
                "d/dt position vs velocity at {t}"
            );
        }
    }
    assert_eq!(basis.n_coeffs(), traj.coeffs().nrows());
}
