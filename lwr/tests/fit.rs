//! Local fits: exactness on polynomials, multi-output, conditioning,
//! confidence and the exact query Jacobian.

use lwr::strategies::{degrees, kernels, linear_data, metric_scales, smooth_data};
use lwr::{Degree, FitStatus, Kernel, LwrError, LwrModel, LwrSettings};
use proptest::prelude::*;

mod common;
use common::jacobian_matches_differences;

fn lcg(seed: &mut u64) -> f64 {
    *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Local linear and quadratic fits reproduce any linear function exactly
    /// (without ridge), whatever the kernel, bandwidth and metric.
    #[test]
    fn reproduces_linear_functions(
        data in linear_data(2, 2, 12..80, true),
        kernel in kernels(),
        quadratic in any::<bool>(),
        bandwidth in 0.6..3.0f64,
        q in proptest::collection::vec(-0.8..0.8f64, 2),
    ) {
        let degree = if quadratic { Degree::Quadratic } else { Degree::Linear };
        let settings = LwrSettings { kernel, bandwidth, degree, ..Default::default() };
        let m = data.to_model(settings).expect("valid");
        let Ok(p) = m.predict(&q) else { return Ok(()) };
        prop_assume!(p.status == FitStatus::Ok && p.condition < 1e8);
        // the truth from a linear least-squares fit through all points (exact data)
        let m_all = data
            .to_model(LwrSettings { bandwidth: 1e6, ..Default::default() })
            .expect("valid");
        let truth = m_all.predict_mean(&q).expect("global fit");
        for (got, want) in p.mean.iter().zip(&truth) {
            prop_assert!((got - want).abs() < 1e-8 * (1.0 + want.abs()), "{} vs {}", got, want);
        }
    }

    /// Fitting two outputs at once equals fitting each alone.
    #[test]
    fn multi_output_equals_single_outputs(data in smooth_data(2, 2, 15..60, true, 0.1)) {
        let settings = LwrSettings { bandwidth: 0.5, ridge: 1e-4, ..Default::default() };
        let both = data.to_model(settings.clone()).expect("valid");
        for o in 0..2 {
            let mut single = LwrModel::new(2, 1, settings.clone()).expect("valid");
            for (x, y) in data.inputs.iter().zip(&data.outputs) {
                single.insert(x, &[y[o]]).expect("valid");
            }
            for q in [[0.1, 0.2], [-0.5, 0.4]] {
                if let (Ok(a), Ok(b)) = (both.predict(&q), single.predict(&q)) {
                    prop_assert!((a.mean[o] - b.mean[0]).abs() < 1e-12 * (1.0 + b.mean[0].abs()));
                    prop_assert_eq!(a.leverage, b.leverage);
                    prop_assert_eq!(a.dof, b.dof);
                }
            }
        }
    }

    /// The analytic Jacobian equals central differences (Gaussian without
    /// truncation; compact kernels away from their support's edge).
    #[test]
    fn jacobian_matches_central_differences(
        data in smooth_data(2, 2, 15..70, true, 0.05),
        kernel in kernels(),
        degree in degrees(),
        bandwidth in 0.5..2.0f64,
        scales in metric_scales(2),
        ridge in prop_oneof![Just(0.0), 1e-3..1e-1f64],
        intercept_ridge in prop_oneof![Just(0.0), 1e-2..2.0f64],
        slope_ridge in prop_oneof![Just(0.0), 1e-2..2.0f64],
        q in proptest::collection::vec(-0.7..0.7f64, 2),
    ) {
        let settings = LwrSettings {
            kernel, degree, bandwidth, scales: scales.clone(), ridge, intercept_ridge, slope_ridge,
            ..Default::default()
        };
        jacobian_matches_differences(&data, settings, &q, |m| {
            // every point away from the edge of the support
            let near = m.database().within_radius(&q, &scales, 1.02 * bandwidth).expect("valid");
            near.iter().all(|n| (n.distance / bandwidth - 1.0).abs() > 0.02)
        })?;
    }
}

/// The intercept ridge is a prior mean of 0 with the weight of
/// `intercept_ridge` points: a local constant fit of data all equal to $c$
/// predicts $c \sum_i k_i / (\sum_i k_i + \lambda_0)$, which goes to 0
/// where the data thin out and to $c$ where they are dense.
#[test]
fn intercept_ridge_shrinks_towards_zero_by_the_total_weight() {
    let lambda0 = 0.7;
    let settings = LwrSettings {
        degree: Degree::Constant,
        kernel: Kernel::Gaussian,
        bandwidth: 0.3,
        gaussian_cutoff: 40.0,
        intercept_ridge: lambda0,
        ..Default::default()
    };
    let mut m = LwrModel::new(1, 1, settings).expect("valid");
    let c = 5.0;
    for i in 0..20 {
        m.insert(&[i as f64 * 0.05], &[c]).expect("valid");
    }
    let mut previous = f64::INFINITY;
    for q in [0.5, 1.2, 1.6, 2.0, 3.0] {
        let p = m.predict(&[q]).expect("weighted");
        let want = c * p.n_lwr / (p.n_lwr + lambda0);
        assert!((p.mean[0] - want).abs() < 1e-12 * c, "at {q}: {} vs {want}", p.mean[0]);
        assert!(p.mean[0] < previous, "the shrinkage grows away from the data");
        previous = p.mean[0];
    }
    assert!(m.predict(&[0.5]).expect("dense").mean[0] > 0.9 * c);
    assert!(m.predict(&[3.0]).expect("far").mean[0] < 0.01 * c);
    // a negative intercept ridge is refused
    let bad = LwrSettings {
        intercept_ridge: -1.0,
        ..Default::default()
    };
    assert!(LwrModel::new(1, 1, bad).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// With a slope ridge, an input the metric ignores ($m_j = 0$) leaves
    /// the local polynomial: the model predicts exactly what a model of the
    /// other inputs alone predicts, intervals included.
    #[test]
    fn slope_ridge_drops_the_inputs_the_metric_ignores(
        data in smooth_data(2, 1, 15..60, true, 0.05),
        quadratic in any::<bool>(),
        bandwidth in 0.3..2.0f64,
        slope_ridge in 1e-3..2.0f64,
        q in proptest::collection::vec(-0.7..0.7f64, 2),
    ) {
        let degree = if quadratic { Degree::Quadratic } else { Degree::Linear };
        let settings = |scales: Vec<f64>| LwrSettings {
            degree, bandwidth, scales, slope_ridge, ..Default::default()
        };
        let both = data.to_model(settings(vec![1.3, 0.0])).expect("valid");
        let mut alone = LwrModel::new(1, 1, settings(vec![1.3])).expect("valid");
        for (x, y) in data.inputs.iter().zip(&data.outputs) {
            alone.insert(&x[..1], y).expect("valid");
        }
        let (Ok(a), Ok(b)) = (both.predict(&q), alone.predict(&q[..1])) else { return Ok(()) };
        prop_assume!(a.status == FitStatus::Ok && b.status == FitStatus::Ok);
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * (1.0 + y.abs());
        prop_assert!(close(a.mean[0], b.mean[0]), "{} vs {}", a.mean[0], b.mean[0]);
        prop_assert!(close(a.leverage, b.leverage), "{} vs {}", a.leverage, b.leverage);
        prop_assert!(close(a.dof, b.dof), "{} vs {}", a.dof, b.dof);
        prop_assert!(close(a.std_error[0], b.std_error[0]));
        let (_, jac) = both.predict_with_jacobian(&q).expect("weighted");
        prop_assert_eq!(jac[(0, 1)], 0.0);
    }

    /// The slope ridge is per bandwidth unit: measuring input 0 in other
    /// units ($x_0 \to c x_0$, its scale $m_0 \to m_0 / c$) changes no
    /// prediction, where the plain `ridge` (per raw unit) does.
    #[test]
    fn slope_ridge_does_not_depend_on_the_inputs_units(
        data in smooth_data(2, 1, 15..60, true, 0.05),
        quadratic in any::<bool>(),
        c in prop_oneof![0.01..0.2f64, 5.0..100.0f64],
        q in proptest::collection::vec(-0.7..0.7f64, 2),
    ) {
        let degree = if quadratic { Degree::Quadratic } else { Degree::Linear };
        let model = |c: f64, slope_ridge: f64, ridge: f64| {
            let settings = LwrSettings {
                degree, bandwidth: 0.8, scales: vec![1.0 / c, 1.0], slope_ridge, ridge,
                ..Default::default()
            };
            let mut m = LwrModel::new(2, 1, settings).expect("valid");
            for (x, y) in data.inputs.iter().zip(&data.outputs) {
                m.insert(&[c * x[0], x[1]], y).expect("valid");
            }
            m.predict(&[c * q[0], q[1]])
        };
        let (Ok(a), Ok(b)) = (model(1.0, 0.5, 0.0), model(c, 0.5, 0.0)) else { return Ok(()) };
        prop_assume!(a.status == FitStatus::Ok && b.status == FitStatus::Ok);
        prop_assert!((a.mean[0] - b.mean[0]).abs() <= 1e-8 * (1.0 + a.mean[0].abs()),
            "{} vs {}", a.mean[0], b.mean[0]);
        // the raw ridge sees the units: the same check fails for it
        let (Ok(a), Ok(b)) = (model(1.0, 0.0, 0.5), model(c, 0.0, 0.5)) else { return Ok(()) };
        prop_assume!(a.status == FitStatus::Ok && b.status == FitStatus::Ok);
        prop_assume!(a.condition < 1e8 && b.condition < 1e8);
        let raw_shift = (a.mean[0] - b.mean[0]).abs();
        let a0 = model(1.0, 0.0, 0.0).expect("weighted").mean[0];
        // only meaningful where the ridge moves the prediction at all
        prop_assume!((a.mean[0] - a0).abs() > 1e-6);
        prop_assert!(raw_shift > 1e-9, "raw ridge unchanged by units: {}", raw_shift);
    }
}

/// A local linear fit in one input with the slope ridge solves the
/// penalised normal equations
/// $\begin{pmatrix} \sum k & \sum k\delta \\ \sum k\delta & \sum k\delta^2 + \lambda_s (h/m)^2 \end{pmatrix} \beta = \begin{pmatrix} \sum k y \\ \sum k \delta y \end{pmatrix}$,
/// $\delta = x - q$, written out here by Cramer's rule.
#[test]
fn slope_ridge_solves_the_penalised_normal_equations() {
    let (h, m, lambda) = (0.4, 2.5, 0.3);
    let settings = LwrSettings {
        bandwidth: h,
        scales: vec![m],
        slope_ridge: lambda,
        gaussian_cutoff: 40.0,
        ..Default::default()
    };
    let mut model = LwrModel::new(1, 1, settings).expect("valid");
    let mut seed = 11;
    let data: Vec<(f64, f64)> = (0..25)
        .map(|_| {
            let x = lcg(&mut seed) - 0.5;
            (x, (3.0 * x).sin() + 0.1 * lcg(&mut seed))
        })
        .collect();
    for (x, y) in &data {
        model.insert(&[*x], &[*y]).expect("valid");
    }
    for q in [-0.3, 0.0, 0.2] {
        let (mut s0, mut s1, mut s2, mut t0, mut t1) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (x, y) in &data {
            let delta = x - q;
            let k = (-0.5 * (m * delta / h).powi(2)).exp();
            s0 += k;
            s1 += k * delta;
            s2 += k * delta * delta;
            t0 += k * y;
            t1 += k * delta * y;
        }
        let s2 = s2 + lambda * (h / m).powi(2);
        let intercept = (t0 * s2 - s1 * t1) / (s0 * s2 - s1 * s1);
        let got = model.predict_mean(&[q]).expect("weighted")[0];
        assert!((got - intercept).abs() < 1e-12, "at {q}: {got} vs {intercept}");
        // and it differs from the fit without the ridge
        let plain = (t0 * (s2 - lambda * (h / m).powi(2)) - s1 * t1) / (s0 * (s2 - lambda * (h / m).powi(2)) - s1 * s1);
        assert!((plain - intercept).abs() > 1e-6, "the ridge has no effect at {q}");
    }
    let bad = LwrSettings {
        slope_ridge: f64::NAN,
        ..Default::default()
    };
    let e = LwrModel::new(1, 1, bad).expect_err("nan").to_string();
    assert!(e.contains("slope_ridge"), "{e}");
}

#[test]
fn quadratic_fit_reproduces_quadratics() {
    let settings = LwrSettings {
        degree: Degree::Quadratic,
        kernel: Kernel::Tricube,
        bandwidth: 0.8,
        ..Default::default()
    };
    let mut m = LwrModel::new(2, 1, settings).expect("valid");
    let f = |x: &[f64]| 1.0 + 2.0 * x[0] - x[1] + 3.0 * x[0] * x[1] - 0.5 * x[1] * x[1];
    let mut seed = 3;
    for _ in 0..200 {
        let x = [2.0 * lcg(&mut seed) - 1.0, 2.0 * lcg(&mut seed) - 1.0];
        m.insert(&x, &[f(&x)]).expect("valid");
    }
    let q = [0.2, -0.3];
    let (p, jac) = m.predict_with_jacobian(&q).expect("weighted");
    assert_eq!(p.status, FitStatus::Ok);
    assert!((p.mean[0] - f(&q)).abs() < 1e-10);
    // exact fit: zero residuals, so the Jacobian is the true gradient
    assert!((jac[(0, 0)] - (2.0 + 3.0 * q[1])).abs() < 1e-9);
    assert!((jac[(0, 1)] - (-1.0 + 3.0 * q[0] - q[1])).abs() < 1e-9);
    assert!(p.noise_variance[0] < 1e-20);
}

#[test]
fn ridge_leaves_the_intercept_free() {
    // a constant is reproduced exactly however large the ridge
    let settings = LwrSettings {
        ridge: 1e6,
        bandwidth: 0.5,
        ..Default::default()
    };
    let mut m = LwrModel::new(1, 1, settings).expect("valid");
    for i in 0..30 {
        m.insert(&[i as f64 / 30.0], &[4.25]).expect("valid");
    }
    let p = m.predict(&[0.3]).expect("weighted");
    assert!((p.mean[0] - 4.25).abs() < 1e-12);
}

#[test]
fn collinear_neighbourhood_is_reported_not_garbage() {
    // every point on the line x1 = 2 x0: the slope across the line is not
    // determined; the fit must say so and stay sensible
    let mut m = LwrModel::new(2, 1, LwrSettings::default()).expect("valid");
    for i in 0..40 {
        let t = i as f64 / 40.0;
        m.insert(&[t, 2.0 * t], &[t + 1.0]).expect("valid");
    }
    let p = m.predict(&[0.5, 1.0]).expect("weighted");
    assert_eq!(p.status, FitStatus::Regularized);
    assert!(p.condition > 1e12);
    assert!((p.mean[0] - 1.5).abs() < 1e-6, "{}", p.mean[0]);
    // off the line: extrapolating across it, still finite and flagged
    let p = m.predict(&[0.5, 0.0]).expect("weighted");
    assert_eq!(p.status, FitStatus::Regularized);
    assert!(p.mean.iter().all(|v| v.is_finite()));
}

#[test]
fn intervals_cover_the_truth() {
    // y = 1 + 2 x + N-ish noise (sum of uniforms), local linear is unbiased
    let settings = LwrSettings {
        bandwidth: 0.15,
        ..Default::default()
    };
    let mut m = LwrModel::new(1, 1, settings).expect("valid");
    let mut seed = 11;
    let sigma = 0.1;
    for _ in 0..2000 {
        let x = lcg(&mut seed);
        let noise: f64 = (0..12).map(|_| lcg(&mut seed)).sum::<f64>() - 6.0;
        m.insert(&[x], &[1.0 + 2.0 * x + sigma * noise]).expect("valid");
    }
    let mut covered = 0;
    let n_q = 200;
    for k in 0..n_q {
        let q = 0.1 + 0.8 * k as f64 / n_q as f64;
        let p = m.predict(&[q]).expect("weighted");
        assert_eq!(p.status, FitStatus::Ok);
        assert!((p.noise_variance[0] / (sigma * sigma) - 1.0).abs() < 0.25);
        if (p.mean[0] - (1.0 + 2.0 * q)).abs() <= p.confidence_half_width[0] {
            covered += 1;
        }
        assert!(p.prediction_half_width[0] > p.confidence_half_width[0]);
    }
    // nearby queries share data, so the coverage is noisy: loose bounds
    assert!(covered >= 150, "covered {covered} of {n_q}");
}

#[test]
fn far_queries_are_refused_and_edges_flagged() {
    let settings = LwrSettings {
        kernel: Kernel::Tricube,
        bandwidth: 0.3,
        ..Default::default()
    };
    let mut m = LwrModel::new(1, 1, settings).expect("valid");
    for i in 0..50 {
        let x = i as f64 / 50.0;
        m.insert(&[x], &[x * x]).expect("valid");
    }
    assert!(matches!(m.predict(&[2.0]), Err(LwrError::NoWeightedData { .. })));
    let inside = m.predict(&[0.5]).expect("weighted");
    let edge = m.predict(&[1.2]).expect("weighted");
    // extrapolating past the last point: fewer effective points, larger leverage
    assert!(edge.n_lwr < inside.n_lwr / 3.0);
    assert!(edge.leverage > 5.0 * inside.leverage);
}

#[test]
fn settings_are_validated_on_use() {
    let mut m = LwrModel::new(2, 1, LwrSettings::default()).expect("valid");
    let bad = LwrSettings {
        scales: vec![1.0],
        ..Default::default()
    };
    assert!(m.set_settings(bad).is_err());
    assert!(
        LwrModel::new(
            2,
            1,
            LwrSettings {
                bandwidth: -1.0,
                ..Default::default()
            }
        )
        .is_err()
    );
}

fn any_settings() -> impl Strategy<Value = LwrSettings> {
    (
        kernels(),
        degrees(),
        prop_oneof![Just(1e-9), Just(1e6), 1e-3..10.0f64],
        proptest::collection::vec(prop_oneof![Just(0.0), Just(1e-12), Just(1e8), 0.0..5.0f64], 3),
        prop_oneof![Just(0.0), Just(1e12), 0.0..1.0f64],
        0.5..10.0f64,
    )
        .prop_map(
            |(kernel, degree, bandwidth, scales, ridge, gaussian_cutoff)| LwrSettings {
                kernel,
                degree,
                bandwidth,
                scales,
                ridge,
                gaussian_cutoff,
                ..Default::default()
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Whatever the settings and data (duplicates, degenerate metrics,
    /// extreme bandwidths and ridges), a prediction is either a typed error
    /// or finite numbers with a status; never a panic or a silent NaN.
    #[test]
    fn never_panics_never_silent_garbage(
        data in smooth_data(3, 1, 1..40, true, 0.1),
        settings in any_settings(),
        q in proptest::collection::vec(-3.0..3.0f64, 3),
    ) {
        let m = data.to_model(settings).expect("valid");
        match m.predict_with_jacobian(&q) {
            Ok((p, jac)) => {
                prop_assert!(p.mean.iter().all(|v| v.is_finite()), "{:?}", p);
                prop_assert!(p.n_lwr > 0.0 && p.n_neighbors > 0);
                if p.status == FitStatus::Ok {
                    prop_assert!(p.noise_variance.iter().all(|v| v.is_finite() && *v >= 0.0));
                    prop_assert!(p.confidence_half_width.iter().all(|v| v.is_finite()));
                    prop_assert!(p.dof >= 0.5);
                } else {
                    // weak fits say so: either no interval, or a reported fallback
                    prop_assert!(
                        p.confidence_half_width.iter().all(|v| v.is_infinite())
                            || p.status == FitStatus::Regularized
                    );
                }
                prop_assert!(jac.nrows() == 1 && jac.ncols() == 3);
                prop_assert!((0..3).all(|j| jac[(0, j)].is_finite()));
            }
            Err(LwrError::NoWeightedData { nearest_distance, support }) => {
                prop_assert!(nearest_distance >= support);
            }
            Err(LwrError::SingularFit { .. }) => {}
            Err(e) => prop_assert!(false, "unexpected error {e:?}"),
        }
        if let Ok(loo) = m.loo() {
            prop_assert!(loo.normalized_mse.is_finite());
        }
    }
}
