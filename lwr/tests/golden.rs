//! Comparison with a plain numpy/scipy reference
//! (`scripts/golden/lwr_golden.py`, data in `tests/data/lwr_golden.json`):
//! predictions, confidence and leave-one-out residuals (the reference
//! refits without each point) to 1e-10 relative.

use lwr::{Degree, FitStatus, Kernel, LwrModel, LwrSettings};
use serde_json::Value;

mod common;
use common::{floats, rows};

fn close(what: &str, got: f64, want: f64) {
    assert!(
        (got - want).abs() <= 1e-10 * want.abs().max(1e-3),
        "{what}: got {got}, want {want}"
    );
}

fn settings(case: &Value) -> LwrSettings {
    let kernel = match case["kernel"].as_str().expect("kernel") {
        "Gaussian" => Kernel::Gaussian,
        "Tricube" => Kernel::Tricube,
        "Epanechnikov" => Kernel::Epanechnikov,
        "Bisquare" => Kernel::Bisquare,
        other => panic!("unknown kernel {other}"),
    };
    let degree = match case["degree"].as_str().expect("degree") {
        "Constant" => Degree::Constant,
        "Linear" => Degree::Linear,
        "Quadratic" => Degree::Quadratic,
        other => panic!("unknown degree {other}"),
    };
    LwrSettings {
        kernel,
        degree,
        bandwidth: case["bandwidth"].as_f64().expect("bandwidth"),
        scales: floats(&case["scales"]),
        ridge: case["ridge"].as_f64().expect("ridge"),
        gaussian_cutoff: case["gaussian_cutoff"].as_f64().expect("cutoff"),
        confidence_level: case["confidence_level"].as_f64().expect("level"),
        ..Default::default()
    }
}

#[test]
fn matches_numpy_reference() {
    let golden: Value = serde_json::from_str(include_str!("data/lwr_golden.json")).expect("valid golden json");
    let cases = golden["cases"].as_array().expect("cases");
    assert_eq!(cases.len(), 5);
    let mut n_loo = 0;
    for case in cases {
        let name = case["name"].as_str().expect("name");
        let xs = rows(&case["inputs"]);
        let ys = rows(&case["outputs"]);
        let mut m = LwrModel::new(xs[0].len(), ys[0].len(), settings(case)).expect("valid");
        m.insert_many(&xs, &ys).expect("finite");
        let queries = rows(&case["queries"]);
        for (q, want) in queries.iter().zip(case["predictions"].as_array().expect("predictions")) {
            let p = m.predict(q).expect("weighted");
            assert_eq!(p.status, FitStatus::Ok, "{name}");
            assert_eq!(p.n_neighbors as u64, want["n_neighbors"].as_u64().expect("count"));
            for field in [
                "mean",
                "noise_variance",
                "std_error",
                "confidence_half_width",
                "prediction_half_width",
            ] {
                let got = match field {
                    "mean" => &p.mean,
                    "noise_variance" => &p.noise_variance,
                    "std_error" => &p.std_error,
                    "confidence_half_width" => &p.confidence_half_width,
                    _ => &p.prediction_half_width,
                };
                for (g, w) in got.iter().zip(floats(&want[field])) {
                    close(&format!("{name} {field}"), *g, w);
                }
            }
            for (field, got) in [
                ("t_quantile", p.t_quantile),
                ("n_lwr", p.n_lwr),
                ("p_lwr", p.p_lwr),
                ("leverage", p.leverage),
            ] {
                close(&format!("{name} {field}"), got, want[field].as_f64().expect("number"));
            }
        }
        if let Some(want) = case.get("loo") {
            n_loo += 1;
            let loo = m.loo().expect("nonempty");
            assert_eq!(loo.n_undetermined, 0);
            let o = ys[0].len();
            for (i, row) in rows(&want["residuals"]).iter().enumerate() {
                for (k, w) in row.iter().enumerate() {
                    // residuals are differences: compare on the scale of y
                    let g = loo.residuals[i * o + k];
                    assert!(
                        (g - w).abs() <= 1e-10 * (1.0 + ys[i][k].abs()),
                        "{name} LOO {i}: {g} vs {w}"
                    );
                }
            }
            for (g, w) in loo.leverages.iter().zip(floats(&want["leverages"])) {
                close(&format!("{name} L_ii"), *g, w);
            }
            for (g, w) in loo.press.iter().zip(floats(&want["press"])) {
                close(&format!("{name} PRESS"), *g, w);
            }
            for (g, w) in loo.gcv.iter().zip(floats(&want["gcv"])) {
                close(&format!("{name} GCV"), *g, w);
            }
        }
    }
    assert_eq!(n_loo, 3);
}
