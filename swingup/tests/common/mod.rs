//! What the program-level tests share.

/// A fresh, empty scratch directory `nprl-<tag>-<pid>-<n>`, removed when
/// dropped ([`store::ScratchDir`]).
pub(crate) fn scratch(tag: &str) -> store::ScratchDir {
    store::ScratchDir::new(tag).expect("scratch dir")
}
