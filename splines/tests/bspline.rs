//! B-spline tests: scipy golden values and properties.

use faer::Mat;
use proptest::prelude::*;
use serde_json::Value;
use splines::strategies::{bspline_basis, sample_times, signal};
use splines::{BSplineBasis, FitSettings, SplineError, Trajectory, TrajectoryBasis, fit_channel};

mod common;
use common::{floats, golden, rows};

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * b.abs().max(1.0)
}

/// The scipy cases under `key`, each with its name and basis.
fn cases(key: &str) -> Vec<(String, BSplineBasis, Value)> {
    let g = golden("scipy_bspline.json");
    let cases = g[key].as_array().expect(key);
    cases
        .iter()
        .map(|case| {
            let name = case["name"].as_str().expect("name").to_owned();
            let degree = case["degree"].as_u64().expect("degree") as usize;
            let basis = BSplineBasis::new(floats(&case["knots"]), degree).expect("golden knots are valid");
            (name, basis, case.clone())
        })
        .collect()
}

fn dense_design(basis: &BSplineBasis, times: &[f64], order: usize) -> Vec<Vec<f64>> {
    let m = basis.design_matrix(times, order).expect("inside domain").to_dense();
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}

#[test]
fn design_matrices_match_scipy() {
    let cases = cases("bases");
    assert!(cases.len() >= 6);
    for (name, basis, case) in cases {
        let times = floats(&case["times"]);
        let mut expected = vec![(0usize, rows(&case["design"]))];
        for (order, m) in case["derivatives"].as_object().expect("derivatives") {
            expected.push((order.parse().expect("order"), rows(m)));
        }
        for (order, want) in expected {
            // both the CSR fast path and the generic row-by-row path
            let got = dense_design(&basis, &times, order);
            let mut row = Vec::new();
            for (k, (g_row, w_row)) in got.iter().zip(&want).enumerate() {
                basis.basis_row(times[k], order, &mut row).expect("inside");
                let mut generic = vec![0.0; basis.n_coeffs()];
                for &(j, v) in &row {
                    generic[j] = v;
                }
                for j in 0..w_row.len() {
                    assert!(
                        close(g_row[j], w_row[j], 1e-12),
                        "{name} order {order} t={} column {j}: {} vs scipy {}",
                        times[k],
                        g_row[j],
                        w_row[j]
                    );
                    assert!(close(generic[j], w_row[j], 1e-12), "{name} basis_row order {order}");
                }
            }
        }
    }
}

#[test]
fn least_squares_fits_match_scipy() {
    for (name, basis, case) in cases("fits") {
        let settings = FitSettings {
            weights: Some(floats(&case["weights"])),
            ..FitSettings::default()
        };
        // scipy's make_lsq_spline minimises sum (w_k (y_k - s(x_k)))^2: weights squared
        let settings = FitSettings {
            weights: settings.weights.map(|w| w.iter().map(|x| x * x).collect()),
            ..settings
        };
        let c = fit_channel(&basis, &floats(&case["times"]), &floats(&case["values"]), &settings).expect("fit");
        for (j, (a, b)) in c.iter().zip(floats(&case["coeffs"])).enumerate() {
            assert!(close(*a, b, 1e-9), "{name} coefficient {j}: {a} vs scipy {b}");
        }
    }
}

#[test]
fn knot_insertion_matches_scipy() {
    for (name, basis, case) in cases("inserts") {
        let at = case["at"].as_f64().expect("at");
        let (refined, c) = basis.insert_knot(at, &floats(&case["coeffs"])).expect("insert");
        for (a, b) in refined.knots().iter().zip(floats(&case["new_knots"])) {
            assert_eq!(*a, b, "{name} knots");
        }
        let want = floats(&case["new_coeffs"]);
        assert_eq!(c.len(), want.len(), "{name}");
        for (a, b) in c.iter().zip(want) {
            assert!(close(*a, b, 1e-12), "{name}: {a} vs scipy {b}");
        }
    }
}

#[test]
fn derivative_above_degree_is_zero_not_error() {
    let basis = BSplineBasis::clamped_uniform(7, 3, 0.0, 1.0).expect("valid");
    let y = basis
        .evaluate(&[1.0, -2.0, 3.0, 0.5, 2.0, 1.0, 0.0], &[0.1, 0.5, 1.0], 4)
        .expect("order 4 of a cubic");
    assert_eq!(y, vec![0.0; 3]);
}

#[test]
fn trajectory_knot_insertion_keeps_values() {
    let basis = BSplineBasis::clamped_uniform(6, 3, 0.0, 1.0).expect("valid");
    let coeffs = Mat::from_fn(6, 2, |i, j| (i as f64 - 2.0) * (j as f64 + 1.0));
    let traj = Trajectory::new(&basis, coeffs).expect("shape");
    let refined = traj.insert_knot(0.37).expect("inside");
    assert_eq!(refined.coeffs().nrows(), 7);
    let times: Vec<f64> = (0..=20).map(|k| k as f64 / 20.0).collect();
    let (a, b) = (
        traj.evaluate(&times, 1).expect("ok"),
        refined.evaluate(&times, 1).expect("ok"),
    );
    for k in 0..times.len() {
        for ch in 0..2 {
            assert!((a[(k, ch)] - b[(k, ch)]).abs() < 1e-12);
        }
    }
    assert!(matches!(
        traj.insert_knot(1.0),
        Err(SplineError::InvalidParameter { .. })
    ));
}

/// A basis with a random coefficient vector and times inside its domain.
fn basis_coeffs_times(
    max_degree: usize,
    max_multiplicity: usize,
) -> impl Strategy<Value = (BSplineBasis, Vec<f64>, Vec<f64>)> {
    bspline_basis(max_degree, 1..30, max_multiplicity).prop_flat_map(|b| {
        let (lo, hi) = b.domain();
        let n = b.n_coeffs();
        (Just(b), signal(n..n + 1), sample_times(lo, hi, 1..40))
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn bases_are_nonnegative_and_sum_to_one((b, _c, times) in basis_coeffs_times(6, 3)) {
        let mut row = Vec::new();
        for &t in &times {
            b.basis_row(t, 0, &mut row).expect("inside");
            prop_assert!(row.len() <= b.degree() + 1);
            prop_assert!(row.iter().all(|&(_, v)| v >= -1e-15), "negative at {t}: {row:?}");
            let sum: f64 = row.iter().map(|&(_, v)| v).sum();
            prop_assert!((sum - 1.0).abs() < 1e-12, "sum {sum} at {t}");
        }
    }

    #[test]
    fn design_matrix_times_coeffs_equals_evaluation((b, c, times) in basis_coeffs_times(6, 3), order in 0usize..4) {
        let phi = b.design_matrix(&times, order).expect("inside");
        let dense = phi.to_dense();
        let y = b.evaluate(&c, &times, order).expect("inside");
        for (k, yk) in y.iter().enumerate() {
            let prod: f64 = (0..c.len()).map(|j| dense[(k, j)] * c[j]).sum();
            prop_assert!((prod - yk).abs() <= 1e-9 * yk.abs().max(1.0), "{prod} vs {yk}");
        }
        // unsorted times go through the binary-search path and give the same rows
        let mut rev = times.clone();
        rev.reverse();
        let dense_rev = b.design_matrix(&rev, order).expect("inside").to_dense();
        for k in 0..times.len() {
            for j in 0..c.len() {
                prop_assert_eq!(dense_rev[(times.len() - 1 - k, j)], dense[(k, j)]);
            }
        }
    }

    #[test]
    fn derivatives_equal_central_differences((b, c, times) in basis_coeffs_times(5, 1), order in 1usize..3) {
        // away from knots (where derivatives of low-continuity splines jump)
        let (lo, hi) = b.domain();
        let width = hi - lo;
        let h = 1e-5 * width;
        for &t in &times {
            let near_knot = b.knots().iter().any(|&k| (k - t).abs() < 2.0 * h);
            if near_knot || t - h < lo || t + h > hi {
                continue;
            }
            let f = b.evaluate(&c, &[t - h, t, t + h], order - 1).expect("inside");
            let d = b.evaluate(&c, &[t], order).expect("inside")[0];
            let fd = (f[2] - f[0]) / (2.0 * h);
            // scale by the size of the (order-1)-th and order-th derivatives
            let scale = d.abs().max(f[1].abs() / width).max(1.0);
            // plus the central difference's own error: with no knot in
            // [t - h, t + h] the spline is a polynomial there, and the error
            // of g = f^(order-1) is h^2/6 g3 + h^4/120 g5 + ... exactly, with
            // gk its k-th derivative (huge where knots crowd: g3 grows like
            // 1/spacing^3)
            let g3 = b.evaluate(&c, &[t], order + 2).expect("inside")[0];
            let g5 = b.evaluate(&c, &[t], order + 4).expect("inside")[0];
            let truncation = h * h / 6.0 * g3.abs() + h.powi(4) / 120.0 * g5.abs();
            prop_assert!(
                (fd - d).abs() <= 1e-4 * scale + 1.01 * truncation,
                "t={t} order {order}: {d} vs central difference {fd}"
            );
        }
    }

    #[test]
    fn knot_insertion_leaves_values_unchanged((b, c, times) in basis_coeffs_times(5, 2), u in 0.01..0.99f64) {
        let (lo, hi) = b.domain();
        let t_new = lo + u * (hi - lo);
        match b.insert_knot(t_new, &c) {
            Ok((refined, c2)) => {
                prop_assert_eq!(c2.len(), c.len() + 1);
                let y1 = b.evaluate(&c, &times, 0).expect("inside");
                let y2 = refined.evaluate(&c2, &times, 0).expect("inside");
                for (a, z) in y1.iter().zip(&y2) {
                    prop_assert!((a - z).abs() <= 1e-10 * a.abs().max(1.0), "{a} vs {z}");
                }
            }
            // only allowed refusal: the knot already has full multiplicity
            Err(e) => {
                let full = b.knots().iter().filter(|&&k| k == t_new).count() > b.degree();
                let is_param = matches!(e, SplineError::InvalidParameter { .. });
                prop_assert!(full && is_param);
            }
        }
    }

    #[test]
    fn fit_recovers_a_spline_in_the_same_space((b, c, _t) in basis_coeffs_times(5, 2)) {
        // samples dense enough that every basis function is determined: three per knot span
        let (lo, hi) = b.domain();
        let mut times = Vec::new();
        for w in b.knots().windows(2) {
            if w[1] > w[0] && w[0] >= lo && w[1] <= hi {
                for s in 0..(b.degree() + 2) {
                    times.push(w[0] + (w[1] - w[0]) * (s as f64 + 0.5) / (b.degree() + 2) as f64);
                }
            }
        }
        let y = b.evaluate(&c, &times, 0).expect("inside");
        let fitted = fit_channel(&b, &times, &y, &FitSettings::default()).expect("well posed");
        let y2 = b.evaluate(&fitted, &times, 0).expect("inside");
        for (a, z) in y.iter().zip(&y2) {
            prop_assert!((a - z).abs() <= 1e-8 * a.abs().max(1.0));
        }
        for (a, z) in c.iter().zip(&fitted) {
            prop_assert!((a - z).abs() <= 1e-6 * a.abs().max(1.0), "coefficient {a} vs fitted {z}");
        }
    }
}
