//! The full metric $d = |\operatorname{diag}(m) M (x - q)|$: equal to the
//! diagonal metric when $M$ is diagonal, to the diagonal metric on rotated
//! data when $M$ is a rotation, an exact Jacobian, tuning along $M$'s axes,
//! save and load, validation.

use faer::Mat;
use lwr::strategies::{degrees, kernels, metric_scales, smooth_data, uniform};
use lwr::{Degree, FitStatus, Kernel, LwrError, LwrModel, LwrSettings, Prediction, TuneSettings};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

mod common;
use common::jacobian_matches_differences;

/// A rotation of $\mathbb{R}^3$ from three angles (row-major).
fn rotation(a: f64, b: f64, c: f64) -> Vec<f64> {
    let rz = [[a.cos(), -a.sin(), 0.0], [a.sin(), a.cos(), 0.0], [0.0, 0.0, 1.0]];
    let ry = [[b.cos(), 0.0, b.sin()], [0.0, 1.0, 0.0], [-b.sin(), 0.0, b.cos()]];
    let rx = [[1.0, 0.0, 0.0], [0.0, c.cos(), -c.sin()], [0.0, c.sin(), c.cos()]];
    let mul = |p: [[f64; 3]; 3], q: [[f64; 3]; 3]| {
        let mut r = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = (0..3).map(|k| p[i][k] * q[k][j]).sum();
            }
        }
        r
    };
    mul(mul(rz, ry), rx).iter().flatten().copied().collect()
}

fn apply(m: &[f64], x: &[f64]) -> Vec<f64> {
    let d = x.len();
    (0..d).map(|r| (0..d).map(|c| m[r * d + c] * x[c]).sum()).collect()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs())) || (a.is_infinite() && a == b) || (a.is_nan() && b.is_nan())
}

/// The two predictions agree in every reported number but the condition
/// estimate (which depends on the coordinates).
fn same_prediction(a: &Prediction, b: &Prediction, tol: f64) -> Result<(), TestCaseError> {
    let pairs = [
        ("n_lwr", a.n_lwr, b.n_lwr),
        ("p_lwr", a.p_lwr, b.p_lwr),
        ("leverage", a.leverage, b.leverage),
    ];
    for (what, x, y) in pairs {
        if !close(x, y, tol) {
            return Err(TestCaseError::fail(format!("{what}: {x} vs {y}")));
        }
    }
    for o in 0..a.mean.len() {
        for (what, x, y) in [
            ("mean", a.mean[o], b.mean[o]),
            ("noise", a.noise_variance[o], b.noise_variance[o]),
            ("half width", a.confidence_half_width[o], b.confidence_half_width[o]),
        ] {
            if !close(x, y, tol) {
                return Err(TestCaseError::fail(format!("{what}[{o}]: {x} vs {y}")));
            }
        }
    }
    if a.n_neighbors != b.n_neighbors || a.status != b.status {
        return Err(TestCaseError::fail(format!(
            "{} / {:?} vs {} / {:?}",
            a.n_neighbors, a.status, b.n_neighbors, b.status
        )));
    }
    Ok(())
}

/// Two models' predictions with Jacobians at one query: both fail, or both
/// succeed and pass `check`.
fn both_or_neither(
    a: lwr::Result<(Prediction, Mat<f64>)>,
    b: lwr::Result<(Prediction, Mat<f64>)>,
    check: impl FnOnce((Prediction, Mat<f64>), (Prediction, Mat<f64>)) -> Result<(), TestCaseError>,
) -> Result<(), TestCaseError> {
    match (a, b) {
        (Ok(a), Ok(b)) => check(a, b),
        (Err(_), Err(_)) => Ok(()),
        (a, b) => Err(TestCaseError::fail(format!(
            "one failed: {:?} vs {:?}",
            a.map(|p| p.0.mean),
            b.map(|p| p.0.mean)
        ))),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// $M = \operatorname{diag}(c)$ with scales $m$ is the diagonal metric
    /// with scales $m_j c_j$: predictions, confidence, Jacobian and
    /// leave-one-out.
    #[test]
    fn diagonal_matrix_equals_diagonal_scales(
        data in smooth_data(3, 2, 10..80, true, 0.1),
        kernel in kernels(),
        degree in degrees(),
        bandwidth in 0.4..2.0f64,
        scales in metric_scales(3),
        diag in proptest::collection::vec(prop_oneof![Just(0.0), Just(1.0), -2.0..2.0f64], 3),
        ridge in prop_oneof![Just(0.0), 1e-3..1e-1f64],
        q in proptest::collection::vec(-0.8..0.8f64, 3),
    ) {
        let base = LwrSettings { kernel, degree, bandwidth, ridge, ..Default::default() };
        let metric = (0..9).map(|t| if t % 4 == 0 { diag[t / 4] } else { 0.0 }).collect();
        let full = data.to_model(LwrSettings { scales: scales.clone(), metric, ..base.clone() }).expect("valid");
        let product = scales.iter().zip(&diag).map(|(m, c)| (m * c).abs()).collect();
        let plain = data.to_model(LwrSettings { scales: product, ..base }).expect("valid");
        both_or_neither(full.predict_with_jacobian(&q), plain.predict_with_jacobian(&q), |(a, ja), (b, jb)| {
            prop_assume!(!a.mean[0].is_nan() && a.condition < 1e8 && b.condition < 1e8);
            same_prediction(&a, &b, 1e-8)?;
            for o in 0..2 {
                for j in 0..3 {
                    prop_assert!(close(ja[(o, j)], jb[(o, j)], 1e-7), "jac {} vs {}", ja[(o, j)], jb[(o, j)]);
                }
            }
            Ok(())
        })?;
        let (la, lb) = (full.loo().expect("nonempty"), plain.loo().expect("nonempty"));
        prop_assert_eq!(la.n_undetermined, lb.n_undetermined);
        prop_assert!(close(la.normalized_mse, lb.normalized_mse, 1e-6), "{} vs {}", la.normalized_mse, lb.normalized_mse);
    }

    /// $M = R$ a rotation, with scales $m$: the model on data $x$ equals the
    /// diagonal model with scales $m$ on the rotated data $R x$, queried at
    /// $R q$; its Jacobian is the rotated model's times $R$.
    #[test]
    fn rotated_metric_equals_diagonal_metric_on_rotated_data(
        data in smooth_data(3, 1, 15..80, true, 0.1),
        kernel in kernels(),
        degree in degrees(),
        bandwidth in 0.5..2.0f64,
        scales in metric_scales(3),
        angles in proptest::collection::vec(-3.2..3.2f64, 3),
        q in proptest::collection::vec(-0.8..0.8f64, 3),
    ) {
        let r = rotation(angles[0], angles[1], angles[2]);
        let base = LwrSettings { kernel, degree, bandwidth, ..Default::default() };
        let full = data.to_model(LwrSettings { scales: scales.clone(), metric: r.clone(), ..base.clone() }).expect("valid");
        let mut rotated = LwrModel::new(3, 1, LwrSettings { scales, ..base }).expect("valid");
        for (x, y) in data.inputs.iter().zip(&data.outputs) {
            rotated.insert(&apply(&r, x), y).expect("finite");
        }
        let rq = apply(&r, &q);
        both_or_neither(full.predict_with_jacobian(&q), rotated.predict_with_jacobian(&rq), |(a, ja), (b, jb)| {
            prop_assume!(a.status != FitStatus::Regularized && b.status != FitStatus::Regularized);
            prop_assume!(a.condition < 1e7 && b.condition < 1e7);
            same_prediction(&a, &b, 1e-7)?;
            for j in 0..3 {
                let want: f64 = (0..3).map(|k| jb[(0, k)] * r[k * 3 + j]).sum();
                prop_assert!(close(ja[(0, j)], want, 1e-6), "jac {j}: {} vs {want}", ja[(0, j)]);
            }
            Ok(())
        })?;
        let (la, lb) = (full.loo().expect("nonempty"), rotated.loo().expect("nonempty"));
        prop_assume!(la.n_regularized == 0 && lb.n_regularized == 0);
        prop_assert_eq!(la.n_undetermined, lb.n_undetermined);
        for (ea, eb) in la.residuals.iter().zip(&lb.residuals) {
            prop_assert!(close(*ea, *eb, 1e-5), "{} vs {}", ea, eb);
        }
    }

    /// The analytic Jacobian with a general (non-orthogonal, possibly
    /// singular) $M$ equals central differences.
    #[test]
    fn full_metric_jacobian_matches_central_differences(
        data in smooth_data(3, 1, 20..80, true, 0.05),
        kernel in kernels(),
        degree in degrees(),
        bandwidth in 0.5..2.0f64,
        matrix in proptest::collection::vec(prop_oneof![Just(0.0), -1.5..1.5f64], 9),
        ridge in prop_oneof![Just(0.0), 1e-3..1e-1f64],
        q in proptest::collection::vec(-0.7..0.7f64, 3),
    ) {
        let settings = LwrSettings { kernel, degree, bandwidth, ridge, metric: matrix.clone(), ..Default::default() };
        jacobian_matches_differences(&data, settings, &q, |_| {
            // every point away from the edge of the support
            data.inputs.iter().all(|x| {
                let v: Vec<f64> = x.iter().zip(&q).map(|(a, b)| a - b).collect();
                let u = apply(&matrix, &v).iter().map(|t| t * t).sum::<f64>().sqrt() / bandwidth;
                (u - 1.0).abs() > 0.02
            })
        })?;
    }
}

/// $y$ depends on $(x_0 + x_1) / \sqrt 2$ only: along the axes of the
/// 45-degree rotation, tuning drops the second axis, which no diagonal
/// metric can do.
#[test]
fn tuning_along_the_metric_axes_drops_an_irrelevant_direction() {
    let mut rand = uniform(17u64);
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let settings = LwrSettings {
        bandwidth: 0.3,
        metric: vec![s, s, -s, s],
        ..Default::default()
    };
    let mut m = LwrModel::new(2, 1, settings).expect("valid");
    for _ in 0..400 {
        let x = [rand(), rand()];
        let u = (x[0] + x[1]) * s;
        m.insert(&x, &[(3.0 * u).sin() + 0.02 * rand()]).expect("finite");
    }
    let tuned = m.tune(&TuneSettings::default()).expect("valid");
    let scales = &tuned.settings.scales;
    assert!(tuned.objective < tuned.initial_objective);
    assert!(scales[0] > 0.0 && scales[1] == 0.0, "scales {scales:?}");
    assert_eq!(tuned.settings.metric, m.settings().metric);
    // the tuned model predicts along the ridge direction far from nothing
    m.set_settings(tuned.settings).expect("valid");
    let p = m.predict(&[0.3, -0.1]).expect("weighted");
    assert!((p.mean[0] - (3.0 * 0.2 * s).sin()).abs() < 0.05, "{:?}", p.mean);
}

#[test]
fn full_metric_saves_loads_and_old_files_load() {
    let mut rand = uniform(5u64);
    let settings = LwrSettings {
        kernel: Kernel::Bisquare,
        bandwidth: 0.8,
        scales: vec![1.0, 0.5],
        metric: vec![1.0, 0.4, -0.2, 2.0],
        ..Default::default()
    };
    let mut m = LwrModel::new(2, 1, settings).expect("valid");
    for _ in 0..200 {
        let x = [rand(), rand()];
        m.insert(&x, &[x[0] * x[1]]).expect("finite");
    }
    let text = m.to_json().expect("serialises");
    let back = LwrModel::from_json(&text).expect("deserialises");
    assert_eq!(back.settings(), m.settings());
    let q = [0.2, -0.3];
    let (a, ja) = m.predict_with_jacobian(&q).expect("weighted");
    let (b, jb) = back.predict_with_jacobian(&q).expect("weighted");
    assert_eq!(format!("{a:?}"), format!("{b:?}"));
    assert_eq!(ja, jb);

    // a diagonal model writes no metric field, and a file without one loads
    let diag = LwrModel::new(2, 1, LwrSettings::default()).expect("valid");
    let text = diag.to_json().expect("serialises");
    assert!(!text.contains("metric"), "{text}");
    let old: LwrSettings = serde_json::from_str(
        r#"{"kernel":"Gaussian","bandwidth":1.0,"scales":[],"degree":"Linear","ridge":0.0,
            "gaussian_cutoff":5.0,"confidence_level":0.95,"max_condition":1e10,"fallback_ridge":1e-8}"#,
    )
    .expect("old settings load");
    assert!(old.metric.is_empty());
    assert_eq!(old, LwrSettings::default());
}

#[test]
fn bad_metric_matrices_are_typed_errors() {
    let wrong_len = LwrSettings {
        metric: vec![1.0, 0.0, 0.0],
        ..Default::default()
    };
    assert!(matches!(
        LwrModel::new(2, 1, wrong_len.clone()),
        Err(LwrError::DimensionMismatch {
            expected: 4,
            actual: 3,
            ..
        })
    ));
    let nan = LwrSettings {
        metric: vec![1.0, f64::NAN, 0.0, 1.0],
        ..Default::default()
    };
    assert!(matches!(
        LwrModel::new(2, 1, nan.clone()),
        Err(LwrError::InvalidParameter { name: "metric", .. })
    ));
    let mut m = LwrModel::new(2, 1, LwrSettings::default()).expect("valid");
    m.insert(&[0.0, 0.0], &[1.0]).expect("finite");
    assert!(m.set_settings(nan.clone()).is_err());
    assert!(m.loo_with(&wrong_len).is_err());
    assert!(m.settings().metric.is_empty());
    // a zero matrix weighs every point fully: the global fit, no panic
    let zero = LwrSettings {
        metric: vec![0.0; 4],
        degree: Degree::Constant,
        ..Default::default()
    };
    m.set_settings(zero).expect("valid");
    m.insert(&[5.0, 5.0], &[3.0]).expect("finite");
    let p = m.predict(&[100.0, -100.0]).expect("weighted");
    assert!((p.mean[0] - 2.0).abs() < 1e-12);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Leave-one-out searches its candidates in a tree over the scaled
    /// coordinates ($m_j x_j$ or $A x$), whose differences round unlike
    /// the distances of a single query; the candidates are inflated against
    /// that, so each fit must still be bitwise the single query at $x_i$:
    /// diagonal and full metrics, zero and large scales, and inputs far from
    /// the origin against the support (where the rounding is largest).
    #[test]
    fn loo_fits_equal_single_queries_in_scaled_coordinates(
        (data, scales, matrix) in (1usize..=5).prop_flat_map(|d| (
            smooth_data(d, 1, 40..160, true, 0.1),
            proptest::collection::vec(prop_oneof![Just(0.0), Just(1.0), Just(30.0), 0.3..3.0f64], d),
            prop_oneof![Just(Vec::new()), proptest::collection::vec(-1.5..1.5f64, d * d)],
        )),
        offset in prop_oneof![Just(0.0), Just(1e3), Just(-3e6)],
        kernel in prop_oneof![Just(Kernel::Gaussian), Just(Kernel::Tricube), Just(Kernel::Epanechnikov)],
        degree in prop_oneof![Just(Degree::Constant), Just(Degree::Linear)],
        bandwidth in 0.2..1.5f64,
    ) {
        let d = data.n_inputs();
        let bandwidth = bandwidth * (d as f64).sqrt();
        let settings = LwrSettings { kernel, degree, bandwidth, scales, metric: matrix, ridge: 1e-6, ..Default::default() };
        let mut m = LwrModel::new(d, 1, settings).expect("valid");
        let shifted: Vec<Vec<f64>> = data.inputs.iter().map(|x| x.iter().map(|v| v + offset).collect()).collect();
        m.insert_many(&shifted, &data.outputs).expect("finite");
        let loo = m.loo().expect("nonempty");
        for (i, x) in shifted.iter().enumerate() {
            match m.predict_mean(x) {
                Ok(mean) => prop_assert_eq!(loo.fitted[i], mean[0], "point {}", i),
                Err(_) => prop_assert_eq!(loo.leverages[i], 1.0),
            }
        }
    }
}

/// Scales so large that the scaled coordinates overflow: leave-one-out
/// still equals the single queries (duplicates are at distance 0).
#[test]
fn loo_with_overflowing_scales_equals_single_queries() {
    let mut m = LwrModel::new(
        2,
        1,
        LwrSettings {
            scales: vec![1e307, 1.0],
            degree: Degree::Constant,
            ..Default::default()
        },
    )
    .expect("valid");
    for i in 0..60 {
        let x = [(i % 7) as f64 * 30.0, (i as f64 * 0.37).sin()];
        m.insert(&x, &[x[1] + (i % 7) as f64]).expect("finite");
    }
    let loo = m.loo().expect("nonempty");
    for i in 0..60 {
        let x = m.database().input(i).expect("stored").to_vec();
        match m.predict_mean(&x) {
            Ok(mean) => assert_eq!(loo.fitted[i], mean[0], "point {i}"),
            Err(_) => assert_eq!(loo.leverages[i], 1.0),
        }
    }
    assert!(loo.n_undetermined < 60);
}
