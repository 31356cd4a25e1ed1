//! Timing drivers for the side-by-side comparison scripts in `scripts/`
//! (`compare_splines.py`, `compare_lwr.py`, `compare_trajopt.py`,
//! `compare_powell.py`, `compare_ddp.py`). Each binary times one library
//! operation on inputs the script gives and prints what the script parses;
//! they are not examples to learn from (those are in each crate's
//! `examples/`). Run one with
//! `cargo run --release -p nprl-drivers --bin NAME -- ARGS`.

/// A regression data set as the LWR comparison scripts write it
/// (`compare_lwr.py`, `lwr_diabetes.py`): training and test rows and their
/// targets.
#[derive(Debug, serde::Deserialize)]
pub struct RegressionData {
    /// Training inputs, one row each.
    pub train_x: Vec<Vec<f64>>,
    /// Training targets.
    pub train_y: Vec<f64>,
    /// Test inputs.
    pub test_x: Vec<Vec<f64>>,
    /// Test targets.
    pub test_y: Vec<f64>,
}

impl RegressionData {
    /// Reads the JSON file `path`.
    ///
    /// # Errors
    /// The file cannot be read or is not such a data set.
    pub fn read(path: &str) -> Result<Self, Box<dyn std::error::Error>> {
        Ok(serde_json::from_str(&std::fs::read_to_string(path)?)?)
    }
}
