//! Cross-crate integration tests of the workspace; the tests live in
//! `tests/tests/`. This library is empty.
#![warn(missing_docs)]
