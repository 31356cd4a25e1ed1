//! The Levenberg-Marquardt tuning (`TuneMethod::LevenbergMarquardt`) and the
//! fit/predict surface's extrapolation fallback.

mod common;

use common::sample;
use lwr::strategies::{irrelevant_input_data, smooth_data};
use lwr::{FitSettings, FitStatus, Kernel, LwrError, LwrModel, LwrSettings, TuneMethod, TuneSettings};
use proptest::prelude::*;

fn lm() -> TuneSettings {
    TuneSettings {
        method: TuneMethod::LevenbergMarquardt,
        ..TuneSettings::default()
    }
}

/// The normalised leave-one-out error of `model` at `settings`.
fn loo(model: &LwrModel, settings: &LwrSettings) -> f64 {
    model.loo_with(settings).expect("valid").normalized_mse
}

#[test]
fn lm_drops_an_irrelevant_input_in_fewer_evaluations_than_the_compass_search() {
    // y = sin(2 x0) + x1^2 + noise; x2 is pure noise
    let data = sample(irrelevant_input_data(2, 1, 300..301, 0.05), 7);
    let m = data
        .to_model(LwrSettings {
            bandwidth: 0.3,
            ..Default::default()
        })
        .expect("valid");
    let r = m.tune(&lm()).expect("valid");
    let compass = m.tune(&TuneSettings::default()).expect("valid");
    assert_eq!(
        r.settings.scales[2], 0.0,
        "the noise input kept: {:?}",
        r.settings.scales
    );
    assert!(
        r.settings.scales[0] > 0.0 && r.settings.scales[1] > 0.0,
        "{:?}",
        r.settings.scales
    );
    assert!(r.objective < r.initial_objective);
    // as low as the compass search's end, to 1 %, in fewer evaluations
    assert!(
        r.objective <= compass.objective * 1.01,
        "{} vs {}",
        r.objective,
        compass.objective
    );
    assert!(r.evals < compass.evals, "{} vs {}", r.evals, compass.evals);
    assert_eq!(r.status, lwr::TuneStatus::Converged);
}

#[test]
fn lm_refuses_a_full_metric() {
    let data = sample(smooth_data(2, 1, 30..31, false, 0.1), 1);
    let m = data
        .to_model(LwrSettings {
            metric: vec![1.0, 0.5, 0.0, 1.0],
            ..Default::default()
        })
        .expect("valid");
    let err = m.tune(&lm()).expect_err("a full metric");
    assert!(
        matches!(err, LwrError::InvalidParameter { name: "metric", .. }),
        "{err}"
    );
}

#[test]
fn lm_bandwidth_alone_reaches_the_minimum_of_a_fine_grid() {
    // one input, a smooth target: the objective in h is unimodal here
    let data = sample(smooth_data(1, 1, 150..151, false, 0.2), 4);
    let m = data
        .to_model(LwrSettings {
            bandwidth: 2.0,
            ..Default::default()
        })
        .expect("valid");
    let r = m
        .tune(&TuneSettings {
            tune_scales: false,
            ..lm()
        })
        .expect("valid");
    let grid = (0..200)
        .map(|k| {
            let h = 0.01 * 1.03f64.powi(k);
            loo(
                &m,
                &LwrSettings {
                    bandwidth: h,
                    ..m.settings().clone()
                },
            )
        })
        .fold(f64::INFINITY, f64::min);
    assert!(r.objective <= grid * (1.0 + 1e-4), "{} vs grid {grid}", r.objective);
    assert_eq!(r.settings.scales_for(1), m.settings().scales_for(1));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// The search never ends above its start; its objective is the
    /// leave-one-out error of the settings it returns (bitwise); the accepted
    /// objectives decrease; and, converged, its end is a minimum along every
    /// coordinate: no scale moved by 10 % either way lowers the objective
    /// (by more than the relative 1e-9 a move must gain).
    #[test]
    fn lm_ends_at_a_coordinate_minimum_below_its_start(
        data in smooth_data(3, 1, 40..80, true, 0.1),
        kernel in prop_oneof![Just(Kernel::Gaussian), Just(Kernel::Tricube)],
        bandwidth in 0.3..1.5f64,
    ) {
        let m = data
            .to_model(LwrSettings { kernel, bandwidth, ridge: 1e-6, ..Default::default() })
            .expect("valid");
        let r = m.tune(&lm()).expect("valid");
        prop_assert!(r.objective <= r.initial_objective);
        prop_assert_eq!(r.objective, loo(&m, &r.settings));
        prop_assert!(r.evals == r.history.len() && r.evals <= 300);
        let accepted: Vec<f64> = r.history.iter().filter(|h| h.accepted).map(|h| h.objective).collect();
        prop_assert!(accepted.windows(2).all(|w| w[1] <= w[0] * (1.0 + 1e-6)), "{:?}", accepted);
        if r.status == lwr::TuneStatus::Converged {
            for j in 0..3 {
                if r.settings.scales[j] == 0.0 {
                    continue;
                }
                for factor in [1.1, 1.0 / 1.1] {
                    let mut s = r.settings.clone();
                    s.scales[j] *= factor;
                    let f = loo(&m, &s);
                    prop_assert!(f >= r.objective * (1.0 - 1e-9), "input {}: {} at x{} vs {}", j, f, factor, r.objective);
                }
            }
        }
    }
}

#[test]
fn predict_many_extrapolates_where_predict_refuses() {
    let xs: Vec<[f64; 2]> = (0..60)
        .map(|i| [(i as f64 * 0.37).sin(), (i as f64 * 0.71).cos()])
        .collect();
    let y: Vec<f64> = xs.iter().map(|x| 2.0 * x[0] - x[1] + 0.5).collect();
    for kernel in [Kernel::Gaussian, Kernel::Tricube] {
        let settings = FitSettings {
            kernel,
            tune_evals: 0,
            ..FitSettings::default()
        };
        let ys: Vec<[f64; 1]> = y.iter().map(|&v| [v]).collect();
        let (model, _) = LwrModel::fit_multi(&xs, &ys, &settings).expect("valid");
        // 8 input units away: beyond the support, and for the Gaussian more
        // than 20 bandwidths from every point
        for far in [[3.0, 1.0], [9.0, -9.0]] {
            assert!(
                matches!(model.predict(&far), Err(LwrError::NoWeightedData { .. })),
                "{kernel:?}"
            );
            let p = &model.predict_many(&[[0.1, 0.2], far]).expect("every row")[..];
            assert_ne!(p[0].status, FitStatus::Extrapolated);
            assert_eq!(p[1].status, FitStatus::Extrapolated);
            // the data lie on a plane: the nearest points' local linear fit
            // extends it
            let plane = 2.0 * far[0] - far[1] + 0.5;
            assert!(
                (p[1].mean[0] - plane).abs() < 1e-6 * plane.abs().max(1.0),
                "{kernel:?} {far:?}: {} vs {plane}",
                p[1].mean[0]
            );
        }
    }
}
