//! What the crate's integration tests share: reading the golden JSON files
//! and the check of the query Jacobian against central differences. Each
//! test binary uses a part of it.
#![allow(dead_code)]

use lwr::strategies::{DataSet, check_jacobian};
use lwr::{FitStatus, Kernel, LwrModel, LwrSettings};
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};
use serde_json::Value;

/// A JSON array of numbers.
pub(crate) fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// A JSON array of arrays of numbers.
pub(crate) fn rows(v: &Value) -> Vec<Vec<f64>> {
    v.as_array().expect("array").iter().map(floats).collect()
}

/// The model of `data` under `settings` with the Gaussian untruncated (so
/// that its fit is smooth) has, at `q`, an analytic Jacobian within $10^{-5}$
/// of central differences. Checked where the fit is well conditioned
/// (condition below $10^6$, no fallback) and, for compact kernels, where
/// `away_from_edge` says no point sits at the edge of the support (where
/// the fit is not smooth).
pub(crate) fn jacobian_matches_differences(
    data: &DataSet,
    settings: LwrSettings,
    q: &[f64],
    away_from_edge: impl Fn(&LwrModel) -> bool,
) -> Result<(), TestCaseError> {
    let kernel = settings.kernel;
    let settings = LwrSettings {
        gaussian_cutoff: 40.0,
        ..settings
    };
    let m = data.to_model(settings).expect("valid");
    let Ok((p, jac)) = m.predict_with_jacobian(q) else {
        return Ok(());
    };
    prop_assume!(matches!(p.status, FitStatus::Ok | FitStatus::NoDegreesOfFreedom));
    prop_assume!(p.condition < 1e6);
    if kernel != Kernel::Gaussian {
        prop_assume!(away_from_edge(&m));
    }
    let c = check_jacobian(|q: &[f64]| m.predict_mean(q), q, &jac, 1e-3);
    prop_assert!(
        c.max_rel_error < 1e-5,
        "d y{} / d q{}: fd {} vs analytic {}",
        c.row,
        c.col,
        c.numeric,
        c.analytic
    );
    Ok(())
}

/// The value a strategy draws from a fixed seed: one reproducible sample.
pub(crate) fn sample<T: std::fmt::Debug>(s: impl Strategy<Value = T>, seed: u8) -> T {
    let mut runner = TestRunner::new_with_rng(Config::default(), TestRng::from_seed(RngAlgorithm::ChaCha, &[seed; 32]));
    s.new_tree(&mut runner).expect("strategy generates").current()
}
