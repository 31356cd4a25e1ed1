//! The robust losses of [`trajopt::LeastSquares`] against scipy's own
//! (`tests/data/scipy_losses.json`, written by
//! `scripts/golden/scipy_losses_golden.py` from
//! `scipy.optimize.least_squares`): the same rho and rho' at every z, and
//! robust fits through gross outliers to scipy's optimum.

use serde_json::Value;
use trajopt::LeastSquares;
use trajopt::fit::Loss;

fn golden() -> Value {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/scipy_losses.json");
    serde_json::from_str(&std::fs::read_to_string(path).expect("golden file")).expect("json")
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

const LOSSES: [(&str, Loss); 5] = [
    ("linear", Loss::Linear),
    ("soft_l1", Loss::SoftL1),
    ("huber", Loss::Huber),
    ("cauchy", Loss::Cauchy),
    ("arctan", Loss::Arctan),
];

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1e-300) || (a - b).abs() <= 1e-300
}

#[test]
fn every_loss_is_scipys() {
    let g = golden();
    let z = floats(&g["z"]);
    for (name, loss) in LOSSES {
        let (rho, drho) = (floats(&g["rho"][name]["rho"]), floats(&g["rho"][name]["drho"]));
        for (k, &zk) in z.iter().enumerate() {
            let (r, d) = loss.rho(zk);
            // to scipy's rounding: its soft_l1, 2 (sqrt(1 + z) - 1), loses
            // digits to cancellation at small z (absolute error ~ 2 eps)
            let near = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs() + 4.0 * f64::EPSILON;
            assert!(near(r, rho[k]), "{name} rho({zk}) = {r}, scipy {}", rho[k]);
            assert!(near(d, drho[k]), "{name} rho'({zk}) = {d}, scipy {}", drho[k]);
        }
    }
    // ours keeps every digit there: rho = z - z^2 / 4 + z^3 / 8 - ...
    let z = 1e-8;
    let series = z - z * z / 4.0 + z * z * z / 8.0;
    assert!((Loss::SoftL1.rho(z).0 - series).abs() <= 1e-15 * series);
}

/// An exponential decay with three gross outliers, each loss at scale 0.1,
/// from scipy's start: scipy's parameters to 6 digits and its cost (ours is
/// the sum of C^2 rho, scipy's half of it).
#[test]
fn robust_fits_reach_scipys_optimum() {
    let g = golden();
    let (t, y) = (floats(&g["t"]), floats(&g["y"]));
    for (name, loss) in LOSSES {
        let want = floats(&g["fits"][name]["x"]);
        let cost = g["fits"][name]["cost"].as_f64().expect("cost");
        let fit = LeastSquares::new(t.len(), |b: &[f64], r: &mut [f64]| {
            for (i, ri) in r.iter_mut().enumerate() {
                *ri = y[i] - b[0] * (-b[1] * t[i]).exp();
            }
        })
        .loss(loss, 0.1)
        .solve(&[1.0, 0.1])
        .expect("solves");
        assert!(fit.status.is_converged(), "{name}: {:?}", fit.status);
        for (k, (got, want)) in fit.x.iter().zip(&want).enumerate() {
            assert!(close(*got, *want, 1e-6), "{name}: b{} = {got} vs scipy {want}", k + 1);
        }
        assert!(
            close(fit.cost, 2.0 * cost, 1e-9),
            "{name}: cost {} vs scipy 2 x {cost}",
            fit.cost
        );
    }
}
