//! Leave-one-out cross-validation, metric tuning, save and load.

mod common;

use common::sample;
use lwr::strategies::{irrelevant_input_data, smooth_data};
use lwr::{Degree, Kernel, LwrModel, LwrSettings, TuneSettings};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// The closed form $e_{(-i)} = (y_i - \hat y(x_i)) / (1 - L_{ii})$ equals
    /// refitting at $x_i$ without point $i$.
    #[test]
    fn loo_closed_form_equals_refit(
        data in smooth_data(2, 2, 8..40, true, 0.1),
        kernel in prop_oneof![Just(Kernel::Gaussian), Just(Kernel::Tricube), Just(Kernel::Bisquare)],
        degree in prop_oneof![Just(Degree::Constant), Just(Degree::Linear), Just(Degree::Quadratic)],
        bandwidth in 0.5..2.0f64,
        ridge in prop_oneof![Just(0.0), 1e-3..1.0f64],
    ) {
        let settings = LwrSettings { kernel, degree, bandwidth, ridge, ..Default::default() };
        let m = data.to_model(settings.clone()).expect("valid");
        let loo = m.loo().expect("nonempty");
        prop_assert_eq!(loo.residuals.len(), data.inputs.len() * 2);
        let n = data.inputs.len();
        for i in 0..n {
            let mut rest = LwrModel::new(2, 2, settings.clone()).expect("valid");
            for k in (0..n).filter(|&k| k != i) {
                rest.insert(&data.inputs[k], &data.outputs[k]).expect("valid");
            }
            let Ok(p) = rest.predict(&data.inputs[i]) else { continue };
            // the identity is exact for the same fit; skip regularised ones
            let Ok(full) = m.predict(&data.inputs[i]) else { continue };
            if p.status != lwr::FitStatus::Ok || full.status != lwr::FitStatus::Ok
                || p.condition > 1e8 || full.condition > 1e8 || 1.0 - loo.leverages[i] < 1e-6 {
                continue;
            }
            for o in 0..2 {
                let closed = data.outputs[i][o] - loo.residuals[i * 2 + o];
                prop_assert!((closed - p.mean[o]).abs() < 1e-7 * (1.0 + p.mean[o].abs()),
                    "point {i} output {o}: closed form {closed} vs refit {}", p.mean[o]);
            }
        }
        // PRESS is the sum of squared LOO residuals
        let press0: f64 = (0..n).map(|i| loo.residuals[i * 2].powi(2)).sum();
        prop_assert!((press0 - loo.press[0]).abs() <= 1e-12 * press0.max(1.0));
        prop_assert!(loo.gcv.iter().all(|g| *g >= 0.0));
    }
}

#[test]
fn tuning_drops_an_irrelevant_input() {
    // y = sin(2 x0) + x1^2 + noise; x2 is pure noise
    let data = sample(irrelevant_input_data(2, 1, 300..301, 0.05), 7);
    let settings = LwrSettings {
        bandwidth: 0.3,
        ..Default::default()
    };
    let m = data.to_model(settings).expect("valid");
    let result = m.tune(&TuneSettings::default()).expect("valid");
    let s = &result.settings;
    let eff: Vec<f64> = s.scales.iter().map(|m| m / s.bandwidth).collect();
    println!(
        "tuned h {:.3} scales {:?} (m/h {eff:?}), LOO nMSE {:.4} -> {:.4} in {} evals ({:?})",
        s.bandwidth, s.scales, result.initial_objective, result.objective, result.evals, result.status
    );
    assert!(result.objective < result.initial_objective);
    assert!(
        eff[2] <= 0.05 * eff[0].min(eff[1]),
        "irrelevant scale {} not dropped against {eff:?}",
        eff[2]
    );
    assert!(eff[0] > 0.0 && eff[1] > 0.0, "a relevant input was dropped: {eff:?}");
    assert_eq!(result.history.len(), result.evals);
    assert!(result.history.iter().any(|h| h.accepted));
}

#[test]
fn loo_of_isolated_points_is_penalised_not_rewarded() {
    // a tiny bandwidth isolates every point: LOO must not report zero error
    let data = sample(smooth_data(1, 1, 50..51, false, 0.0), 3);
    let m = data
        .to_model(LwrSettings {
            bandwidth: 1e-6,
            kernel: Kernel::Tricube,
            ..Default::default()
        })
        .expect("valid");
    let loo = m.loo().expect("nonempty");
    assert_eq!(loo.n_undetermined, 50);
    assert!((loo.normalized_mse - 1.0).abs() < 1e-9);
}

#[test]
fn save_and_load_round_trip() {
    let data = sample(smooth_data(3, 2, 100..101, true, 0.1), 5);
    let settings = LwrSettings {
        kernel: Kernel::Bisquare,
        bandwidth: 0.9,
        scales: vec![1.0, 0.5, 0.0],
        degree: Degree::Quadratic,
        ridge: 1e-3,
        ..Default::default()
    };
    let m = data.to_model(settings).expect("valid");
    let mut buf = Vec::new();
    m.save(&mut buf).expect("serialises");
    let back = LwrModel::load(buf.as_slice()).expect("deserialises");
    assert_eq!(back.settings(), m.settings());
    assert_eq!(back.database().inputs(), m.database().inputs());
    for q in [[0.0, 0.0, 0.0], [0.3, -0.2, 0.9]] {
        let (a, ja) = m.predict_with_jacobian(&q).expect("weighted");
        let (b, jb) = back.predict_with_jacobian(&q).expect("weighted");
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        assert_eq!(ja, jb);
    }
    // corrupted input is a typed error, not a panic
    assert!(LwrModel::from_json("{\"settings\": 3}").is_err());
    let text = m
        .to_json()
        .expect("serialises")
        .replace("\"bandwidth\":0.9", "\"bandwidth\":-1.0");
    assert!(matches!(
        LwrModel::from_json(&text),
        Err(lwr::LwrError::InvalidParameter { name: "bandwidth", .. })
    ));
}

#[test]
fn loading_bad_points_gives_typed_errors() {
    let text = r#"{"settings":{"kernel":"Gaussian","bandwidth":1.0,"scales":[],"degree":"Linear","ridge":0.0,"gaussian_cutoff":5.0,"confidence_level":0.95,"max_condition":1e12,"fallback_ridge":1e-8},
        "database":{"n_inputs":2,"n_outputs":1,"inputs":[0.0,1.0,2.0],"outputs":[1.0]}}"#;
    assert!(matches!(
        LwrModel::from_json(text),
        Err(lwr::LwrError::DimensionMismatch { .. })
    ));
    let ok = text.replace("[0.0,1.0,2.0]", "[0.0,1.0]");
    let m = LwrModel::from_json(&ok).expect("valid model");
    assert_eq!(m.len(), 1);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(8))]

    /// Tuning never ends worse than it started, and its history is consistent.
    #[test]
    fn tuning_never_increases_the_objective(data in smooth_data(2, 1, 20..40, true, 0.1)) {
        let m = data
            .to_model(LwrSettings { bandwidth: 0.5, ridge: 1e-6, ..Default::default() })
            .expect("valid");
        let r = m.tune(&TuneSettings { max_evals: 25, ..Default::default() }).expect("valid");
        prop_assert!(r.objective <= r.initial_objective);
        prop_assert!(r.evals <= 25 && r.evals == r.history.len());
        let best_accepted = r
            .history
            .iter()
            .rev()
            .find(|h| h.accepted)
            .map(|h| h.objective)
            .expect("the start is accepted");
        prop_assert_eq!(best_accepted, r.objective);
        prop_assert!(r.settings.validate(2).is_ok());
    }
}

#[test]
fn database_from_flat_equals_inserts() {
    let data = sample(smooth_data(2, 1, 200..201, true, 0.1), 9);
    let flat_x: Vec<f64> = data.inputs.concat();
    let flat_y: Vec<f64> = data.outputs.concat();
    let db = lwr::Database::from_flat(2, 1, flat_x.clone(), flat_y).expect("valid");
    let m_flat = LwrModel::from_database(db, LwrSettings::default()).expect("valid");
    let m_ins = data.to_model(LwrSettings::default()).expect("valid");
    assert_eq!(m_flat.predict(&[0.1, 0.2]), m_ins.predict(&[0.1, 0.2]));
    assert!(lwr::Database::from_flat(2, 1, flat_x[..3].to_vec(), vec![0.0]).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Leave-one-out fits all the points of a tree leaf from one shared
    /// candidate list; each fit must be bitwise the single query at $x_i$
    /// (the same neighbours, summed in the same order). Sizes above one
    /// leaf, 1 to 9 inputs (the compile-time-sized paths and the general
    /// one), duplicates, zero scales and compact kernels (points exactly at
    /// the support's edge) included.
    #[test]
    fn loo_fits_equal_single_queries(
        (data, scales) in (1usize..=9).prop_flat_map(|d| (
            smooth_data(d, 2, 40..160, true, 0.1),
            proptest::collection::vec(prop_oneof![Just(0.0), Just(1.0), 0.3..3.0f64], d),
        )),
        kernel in prop_oneof![Just(Kernel::Gaussian), Just(Kernel::Tricube), Just(Kernel::Epanechnikov)],
        degree in prop_oneof![Just(Degree::Constant), Just(Degree::Linear), Just(Degree::Quadratic)],
        bandwidth in 0.2..1.5f64,
    ) {
        let bandwidth = bandwidth * (data.n_inputs() as f64).sqrt();
        let settings = LwrSettings { kernel, degree, bandwidth, scales, ridge: 1e-6, ..Default::default() };
        let m = data.to_model(settings).expect("valid");
        let loo = m.loo().expect("nonempty");
        for (i, x) in data.inputs.iter().enumerate() {
            match m.predict_mean(x) {
                Ok(mean) => prop_assert_eq!(&loo.fitted[i * 2..i * 2 + 2], &mean[..], "point {}", i),
                Err(_) => prop_assert_eq!(loo.leverages[i], 1.0),
            }
        }
    }
}

/// Stopping hopeless evaluations early changes neither the path nor the
/// result of the search: the same settings, objective and accepted steps;
/// every completed evaluation has bitwise the same objective, and every
/// stopped one a lower bound on the full objective that already exceeds
/// what the search would have accepted.
#[test]
fn stopping_early_leaves_tuning_unchanged() {
    for (seed, n) in [(3u8, 400), (5, 250)] {
        let data = sample(irrelevant_input_data(2, 1, n..n + 1, 0.05), seed);
        let m = data
            .to_model(LwrSettings {
                bandwidth: 0.3,
                ..Default::default()
            })
            .expect("valid");
        let tune = TuneSettings {
            max_evals: 120,
            ..Default::default()
        };
        let fast = m.tune(&tune).expect("valid");
        let full = m
            .tune(&TuneSettings {
                stop_early: false,
                ..tune.clone()
            })
            .expect("valid");
        assert_eq!(fast.settings, full.settings);
        assert_eq!(fast.objective, full.objective);
        assert_eq!(fast.initial_objective, full.initial_objective);
        assert_eq!((fast.evals, fast.status), (full.evals, full.status));
        assert!(full.history.iter().all(|s| s.complete));
        let mut n_stopped = 0;
        for (a, b) in fast.history.iter().zip(&full.history) {
            assert_eq!(
                (a.bandwidth, &a.scales, a.accepted),
                (b.bandwidth, &b.scales, b.accepted)
            );
            if a.complete {
                assert_eq!(a.objective, b.objective);
            } else {
                n_stopped += 1;
                assert!(!a.accepted);
                assert!(
                    a.objective <= b.objective * (1.0 + 1e-12),
                    "{} > {}",
                    a.objective,
                    b.objective
                );
            }
        }
        // the test would be empty if nothing stopped early
        assert!(n_stopped > 0, "no evaluation stopped early");
        // every objective, including the revisited settings answered from
        // the search's cache, is that of a fresh leave-one-out pass
        let mut seen = std::collections::HashSet::new();
        let mut n_revisits = 0;
        for step in &full.history {
            let s = LwrSettings {
                bandwidth: step.bandwidth,
                scales: step.scales.clone(),
                ..m.settings().clone()
            };
            let key: Vec<u64> = s.scales.iter().chain([&s.bandwidth]).map(|v| v.to_bits()).collect();
            n_revisits += usize::from(!seen.insert(key));
            assert_eq!(step.objective, m.loo_with(&s).expect("valid").normalized_mse);
        }
        assert!(n_revisits > 0, "no setting was revisited");
        println!(
            "n {n}: {n_stopped} of {} evaluations stopped early, {n_revisits} revisits",
            fast.evals
        );
    }
}

/// Searching over a subset of the leave-one-out points: the exact search
/// when the subset is everything; otherwise the reported objectives are the
/// full leave-one-out MSE at the start and at the result, never worse at
/// the result, and the irrelevant input is still dropped.
#[test]
fn subset_search_reports_exact_objectives() {
    let data = sample(irrelevant_input_data(2, 1, 800..801, 0.05), 11);
    let m = data
        .to_model(LwrSettings {
            bandwidth: 0.3,
            ..Default::default()
        })
        .expect("valid");
    let tune = TuneSettings::default();
    let exact = m.tune(&tune).expect("valid");
    for all in [800, 5000] {
        let same = m
            .tune(&TuneSettings {
                search_points: all,
                ..tune.clone()
            })
            .expect("valid");
        assert_eq!(same, exact);
    }
    let sub = m
        .tune(&TuneSettings {
            search_points: 200,
            ..tune.clone()
        })
        .expect("valid");
    let full_at = |s: &LwrSettings| m.loo_with(s).expect("valid").normalized_mse;
    assert_eq!(sub.initial_objective, exact.initial_objective);
    assert_eq!(sub.objective, full_at(&sub.settings));
    assert!(sub.objective < sub.initial_objective);
    // the subset's objectives are not the full ones
    assert_ne!(sub.history[0].objective, sub.initial_objective);
    let s = &sub.settings;
    let eff: Vec<f64> = s.scales.iter().map(|m| m / s.bandwidth).collect();
    assert!(eff[2] <= 0.05 * eff[0].min(eff[1]), "irrelevant scale kept: {eff:?}");
    println!(
        "exact search {:.5} in {} evals, subset search {:.5} in {} evals",
        exact.objective, exact.evals, sub.objective, sub.evals
    );
}
