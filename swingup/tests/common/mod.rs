//! What the program-level tests share.

/// A fresh, empty scratch directory `nprl-<tag>-<pid>-<n>`, removed when
/// dropped ([`store::ScratchDir`]).
pub(crate) fn scratch(tag: &str) -> store::ScratchDir {
    store::ScratchDir::new(tag).expect("scratch dir")
}

/// The smallest grid: three lambdas, one seed, one trial (the imitation).
/// (Not every test file that shares this module runs a grid.)
#[allow(dead_code)]
pub(crate) fn smallest_grid() -> swingup::experiments::ExperimentSettings {
    swingup::experiments::ExperimentSettings {
        seeds: 1,
        learning_seeds: 1,
        max_trials: 1,
        ..swingup::experiments::ExperimentSettings::quick()
    }
}
