//! What the crate's integration tests share: reading the golden JSON files
//! (`scripts/golden/*.py` writes them into `tests/data`).

use serde_json::Value;

/// The golden file `tests/data/<name>`.
pub(crate) fn golden(name: &str) -> Value {
    let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("golden data file {path}: {e}"));
    serde_json::from_str(&text).expect("valid golden json")
}

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
