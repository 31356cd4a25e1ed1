//! The typed errors of the CSV fit tool, each naming the file, line, row
//! and column.

use std::path::PathBuf;

use crate::LwrError;

/// A bad data file or bad arguments of the CSV fit tool (`lwr-fit`,
/// `swingup fit`), or a model that cannot be built from the data.
///
/// Lines count from 1 with the header on line 1 (blank lines are skipped but
/// counted); data rows count from 1 with the first row under the header;
/// columns count from 1.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FitError {
    /// The file could not be read.
    #[error("{file}: cannot read the file")]
    Io {
        /// The file.
        file: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file has no header row.
    #[error("{file}: the file is empty (expected a header row of column names, then rows of numbers)")]
    Empty {
        /// The file.
        file: PathBuf,
    },
    /// The file has a header but no data rows.
    #[error("{file}: no data rows under the header (line {line})")]
    NoRows {
        /// The file.
        file: PathBuf,
        /// Line of the header.
        line: usize,
    },
    /// An empty or repeated column name.
    #[error("{file}: header (line {line}), column {column}: {reason}")]
    BadHeader {
        /// The file.
        file: PathBuf,
        /// Line of the header.
        line: usize,
        /// Column number, from 1.
        column: usize,
        /// What is wrong.
        reason: String,
    },
    /// A row with more or fewer cells than the header has columns.
    #[error("{file}: line {line} (data row {row}) has {actual} cells but the header has {expected} columns ({detail})")]
    Ragged {
        /// The file.
        file: PathBuf,
        /// Line in the file.
        line: usize,
        /// Data row, from 1.
        row: usize,
        /// Number of columns of the header.
        expected: usize,
        /// Number of cells in the row.
        actual: usize,
        /// Which column is missing or extra.
        detail: String,
    },
    /// A cell that is not a number.
    #[error("{file}: line {line} (data row {row}), column {column} '{name}': {reason}")]
    BadCell {
        /// The file.
        file: PathBuf,
        /// Line in the file.
        line: usize,
        /// Data row, from 1.
        row: usize,
        /// Column number, from 1.
        column: usize,
        /// Column name.
        name: String,
        /// What is wrong with the cell.
        reason: String,
    },
    /// A column the command needs is not in the file.
    #[error("{file}: header (line {line}): no column '{name}' ({role}); the columns are {available}")]
    MissingColumn {
        /// The file.
        file: PathBuf,
        /// Line of the header.
        line: usize,
        /// The missing column.
        name: String,
        /// What the column is for ("target", "input").
        role: &'static str,
        /// The file's columns, comma-separated.
        available: String,
    },
    /// A test column that is neither an input nor a target of the training data.
    #[error("{file}: header (line {line}), column {column} '{name}': not a column of the training file {train}")]
    UnknownColumn {
        /// The test file.
        file: PathBuf,
        /// Line of the header.
        line: usize,
        /// Column number, from 1.
        column: usize,
        /// Column name.
        name: String,
        /// The training file.
        train: PathBuf,
    },
    /// An input that takes one value only: it cannot be normalised and the
    /// local fit could not use it.
    #[error(
        "{file}: column {column} '{name}' is constant ({value}) over all rows, to within round-off of its magnitude; remove it"
    )]
    ConstantInput {
        /// The file.
        file: PathBuf,
        /// Column number, from 1.
        column: usize,
        /// Column name.
        name: String,
        /// Its only value.
        value: f64,
    },
    /// Every training row is the same: nothing varies to regress on.
    #[error("{file}: all {rows} data rows are identical; a regression needs rows that differ")]
    IdenticalRows {
        /// The file.
        file: PathBuf,
        /// Its number of rows.
        rows: usize,
    },
    /// Fewer rows than the local polynomial has coefficients (plus one),
    /// or more coefficients than a local fit can hold.
    #[error(
        "{file}: a local {degree} fit in {inputs} inputs has {coefficients} coefficients; {reason}; \
         use a lower --degree or fewer input columns"
    )]
    ModelTooLarge {
        /// The training file.
        file: PathBuf,
        /// `constant`, `linear` or `quadratic`.
        degree: &'static str,
        /// Number of input columns.
        inputs: usize,
        /// Coefficients of one local fit.
        coefficients: usize,
        /// What does not fit: too few rows, or too many coefficients.
        reason: String,
    },
    /// A target that takes one value only: nothing to regress, and its
    /// normalised errors would divide by a zero variance.
    #[error(
        "{file}: the target column {column} '{name}' is {value} in every row (to within round-off of its magnitude); there is nothing to regress"
    )]
    ConstantTarget {
        /// The file.
        file: PathBuf,
        /// Column number, from 1.
        column: usize,
        /// Column name.
        name: String,
        /// Its only value.
        value: f64,
    },
    /// Every training column is a target.
    #[error("{file}: every column is a target; at least one input column is needed")]
    NoInputs {
        /// The file.
        file: PathBuf,
    },
    /// A file that the `csv` crate cannot read as CSV.
    #[error("{file}: line {line}: {reason}")]
    Csv {
        /// The file.
        file: PathBuf,
        /// Line in the file.
        line: usize,
        /// What the `csv` crate found wrong.
        reason: String,
    },
    /// The model could not be built, filled, tuned or cross-validated from
    /// the training data.
    #[error("{file}: {task}")]
    Model {
        /// The training file.
        file: PathBuf,
        /// What was being done: "building the model", "tuning the metric", ...
        task: &'static str,
        /// The cause.
        source: LwrError,
    },
    /// The predictions file could not be written (any old file is left whole).
    #[error("{file}: writing the predictions")]
    Write {
        /// The predictions file.
        file: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The fit's leave-one-out error came out infinite or NaN: the data's
    /// numbers overflow the fit's arithmetic (a number is never printed
    /// silently wrong).
    #[error(
        "{file}: the leave-one-out error of the fit is {value}, not a number: the data overflow the fit's \
         arithmetic ({hint})"
    )]
    NonFinite {
        /// The training file.
        file: PathBuf,
        /// The value.
        value: f64,
        /// What to try.
        hint: String,
    },
    /// Standard output is closed or full: the summary (or, with `--out -`,
    /// the predictions) could not be printed; the files were saved.
    #[error("printing on standard output (closed or full; any --out file was saved)")]
    Stdout(#[source] std::io::Error),
    /// The summary could not be written as JSON.
    #[error("cannot write the summary as JSON")]
    Json(#[from] serde_json::Error),
    /// An argument outside its range.
    #[error("invalid argument {name}: {reason}")]
    InvalidArgument {
        /// The argument.
        name: &'static str,
        /// Why.
        reason: String,
    },
}
