//! [`BenchError`], the one error type of the crate.

use std::path::PathBuf;

/// What can go wrong in a benchmark run or while reading its inputs.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BenchError {
    /// A solver name that is not one of [`crate::solvers::Solver::ALL`]'s.
    #[error("unknown solver `{name}` (known: {known})")]
    UnknownSolver {
        /// The name given.
        name: String,
        /// The names accepted, comma-separated.
        known: String,
    },
    /// A problem set name that is not one of [`crate::problems::ProblemSet`]'s.
    #[error("unknown problem set `{name}` (known: {known})")]
    UnknownSet {
        /// The name given.
        name: String,
        /// The names accepted, comma-separated.
        known: String,
    },
    /// A setting out of range.
    #[error("invalid {name}: {reason}")]
    InvalidSetting {
        /// The setting's name.
        name: &'static str,
        /// Why it is refused.
        reason: String,
    },
    /// A records file that is not valid JSON of the expected shape.
    #[error("{path}: malformed records file: {source}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// serde_json's message (with line and column).
        source: serde_json::Error,
    },
    /// A records file whose content is valid JSON but wrong: a field
    /// out of range.
    #[error("{path}: run {index}: field `{field}`: {reason}")]
    BadField {
        /// The file.
        path: PathBuf,
        /// Which run (0-based) in the file's `runs`.
        index: usize,
        /// The field's name.
        field: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// A file or directory that could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// A solver refused its input (settings or starting point).
    #[error("solver {solver} on {problem}: {reason}")]
    Solver {
        /// The solver's name.
        solver: String,
        /// The problem's name.
        problem: String,
        /// The solver's message.
        reason: String,
    },
    /// A README without the lines that delimit its generated benchmark
    /// summary (`<!-- benchmarks:start -->` and `<!-- benchmarks:end -->`,
    /// in that order).
    #[error("{path}: no `<!-- benchmarks:start -->` line followed by a `<!-- benchmarks:end -->` line")]
    NoReadmeSection {
        /// The README.
        path: PathBuf,
    },
    /// A NIST StRD data file that does not parse.
    #[error("{file}{}: {reason}", .line.map_or(String::new(), |l| format!(": line {l}")))]
    NistData {
        /// The file's name (`Misra1a.dat`).
        file: String,
        /// The line (1-based), or `None` for the file as a whole.
        line: Option<usize>,
        /// What is wrong.
        reason: String,
    },
    /// A `--compare-to` reference that names no records.
    #[error("--compare-to {spec}: {reason}")]
    CompareTo {
        /// The reference as given.
        spec: String,
        /// Why it cannot be read.
        reason: String,
    },
    /// A file that could not be replaced whole (the storage layer names it).
    #[error(transparent)]
    Store(#[from] store::StoreError),
    /// Shards of a benchmark that cannot be run or merged as they are.
    #[error("{}: {reason}", dir.display())]
    Shards {
        /// The benchmark's directory.
        dir: std::path::PathBuf,
        /// What is wrong, naming the shards, files or runs.
        reason: String,
    },
    /// A `--filter` that matches no instance of the set (refused before
    /// any run, so that no saved runs are replaced by none).
    #[error("--filter `{filter}` matches no instance of the {set} set")]
    NoInstance {
        /// The filter given.
        filter: String,
        /// The set's name.
        set: &'static str,
    },
    /// A run in which no chosen solver applies to any chosen instance
    /// (refused before anything is written).
    #[error(
        "none of the solvers {solvers} applies to {what} of the {set} set: there are no runs to save, \
         and nothing was written"
    )]
    NoRuns {
        /// The solvers asked for.
        solvers: String,
        /// The set's name.
        set: &'static str,
        /// `any instance`, or the instances a filter chose.
        what: String,
    },
    /// A run that would replace only part of a saved result set made by
    /// other code or with another budget (refused before anything is
    /// written, unless `--force`).
    #[error(
        "{}: holds {saved} runs made by {saved_by}; this run made {new} of them again with {new_by}, \
         and merging would mix the two in one result set; rerun the whole set, choose another --out, \
         or pass --force to replace the saved runs by this run's {new}",
        path.display()
    )]
    WouldMix {
        /// The saved records file (`OUT/runs.json`).
        path: PathBuf,
        /// How many runs it holds.
        saved: usize,
        /// The code and budget that made them.
        saved_by: String,
        /// How many runs this run made.
        new: usize,
        /// The code and budget of this run.
        new_by: String,
    },
    /// Standard output closed or full: the files were saved, but the
    /// summary could not be printed.
    #[error("standard output: {0} (the files were written)")]
    Stdout(std::io::Error),
    /// Drawing a figure failed.
    #[error("figure {figure}: {reason}")]
    Plot {
        /// The figure's file stem.
        figure: String,
        /// What failed.
        reason: String,
    },
}

/// `Result` with [`BenchError`].
pub type Result<T, E = BenchError> = std::result::Result<T, E>;

impl BenchError {
    /// An [`BenchError::Io`] for `path`.
    pub(crate) fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.into();
        move |source| Self::Io { path, source }
    }
}
