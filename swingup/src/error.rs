//! The library's error type: what went wrong, with the key, file or line
//! it concerns.
//!
//! Every fallible function of the library returns [`Result`]; the
//! `swingup` program prints an error and its chain of causes
//! ([`std::error::Error::source`]). Errors of the toolkit's crates pass
//! through unchanged ([`Error::Lwr`], [`Error::Trajopt`], ...), so that a
//! caller can match on them; [`Error::Context`] says what the library was
//! doing when one occurred (for example "saving trial 3").

use std::path::PathBuf;

/// The errors of the `swingup` library.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A configuration value out of its range; `key` is its name in
    /// `config.toml` (e.g. `planner.lambda`).
    #[error("{message}")]
    Config {
        /// The key, as written in `config.toml`.
        key: String,
        /// What is wrong with it, naming the key.
        message: String,
    },
    /// Data the library was given cannot be used (too few samples,
    /// mismatched lengths, a trial too short for the planning window, ...).
    #[error("{0}")]
    Data(String),
    /// The LQR of a plant could not be designed (the Riccati iteration did
    /// not converge).
    #[error("the {plant}'s balancing controller could not be designed")]
    Controller {
        /// `human` or `robot`.
        plant: &'static str,
    },
    /// Reading, writing, renaming or deleting a file or directory failed.
    #[error("{action} {}: {error}", path.display())]
    Io {
        /// What was being done: `reading`, `writing`, `creating`, ...
        action: &'static str,
        /// The file or directory.
        path: PathBuf,
        /// The operating system's error (in the message, so not a separate
        /// cause in the chain).
        error: std::io::Error,
    },
    /// A file's contents could not be parsed.
    #[error("{}{}: {message}", path.display(), line.map_or(String::new(), |l| format!(" line {l}")))]
    Parse {
        /// The file.
        path: PathBuf,
        /// The line (1-based), where known.
        line: Option<usize>,
        /// The parser's message.
        message: String,
    },
    /// A run or grid directory is refused: locked by another program,
    /// holding another run, or saved with other settings. The message says
    /// what to do instead.
    #[error("{0}")]
    Refused(String),
    /// Runs of an experiments grid failed; one line per run.
    #[error("runs failed:\n{}", .0.join("\n"))]
    RunsFailed(Vec<String>),
    /// A record could not be written as JSON or TOML.
    #[error("serialising a record: {0}")]
    Serialize(String),
    /// From the `lwr` crate.
    #[error(transparent)]
    Lwr(#[from] lwr::LwrError),
    /// From the `trajopt` crate.
    #[error(transparent)]
    Trajopt(#[from] trajopt::TrajoptError),
    /// From the `ddp` crate.
    #[error(transparent)]
    Ddp(#[from] ddp::DdpError),
    /// From the `splines` crate.
    #[error(transparent)]
    Splines(#[from] splines::SplineError),
    /// The parametric model could not be fitted.
    #[error(transparent)]
    Parametric(#[from] ParametricError),
    /// A figure could not be drawn or written ([`crate::output::plot`]).
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// From the storage layer ([`store`]): a results file that cannot be
    /// read or written, or a directory reopened with another task or other
    /// settings; the error names the file.
    #[error(transparent)]
    Store(#[from] store::StoreError),
    /// What the library was doing when `source` occurred.
    #[error("{context}")]
    Context {
        /// What was being done, e.g. "saving trial 3".
        context: String,
        /// The error itself.
        #[source]
        source: Box<Error>,
    },
}

/// Why a parametric fit was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParametricError {
    /// Fewer data points than coefficients.
    #[error("need at least {needed} data points for {needed} coefficients, got {actual}")]
    TooFewPoints {
        /// Points needed.
        needed: usize,
        /// Points given.
        actual: usize,
    },
    /// Inputs and outputs of different lengths.
    #[error("{inputs} inputs but {outputs} outputs")]
    LengthMismatch {
        /// Number of inputs.
        inputs: usize,
        /// Number of outputs.
        outputs: usize,
    },
    /// A NaN or infinite value in the data.
    #[error("{what}[{index}] is not finite ({value})")]
    NotFinite {
        /// `inputs` or `outputs`.
        what: &'static str,
        /// Index of the data point.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// The features do not vary independently in the data (for example the
    /// pendulum never moved, or the hand never accelerated).
    #[error("the features are (nearly) linearly dependent in the data: singular value ratio {ratio:e}")]
    RankDeficient {
        /// Smallest over largest singular value of the column-normalised design matrix.
        ratio: f64,
    },
    /// Invalid sample period or angle lead.
    #[error("invalid {name}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// The linear algebra failed (should not happen after the rank check).
    #[error("least-squares solve failed: {0}")]
    Solve(String),
}

impl From<serde_json::Error> for Error {
    fn from(e: serde_json::Error) -> Self {
        Self::Serialize(e.to_string())
    }
}

impl From<toml::ser::Error> for Error {
    fn from(e: toml::ser::Error) -> Self {
        Self::Serialize(e.to_string())
    }
}

/// `Result` with the library's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// An [`Error::Data`] from a message.
    pub fn data(message: impl Into<String>) -> Self {
        Self::Data(message.into())
    }

    /// An [`Error::Config`] for `key`.
    pub fn config(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Config {
            key: key.into(),
            message: message.into(),
        }
    }

    /// An [`Error::Io`]: `action` (e.g. "reading") on `path` failed.
    pub fn io(action: &'static str, path: impl Into<PathBuf>, error: std::io::Error) -> Self {
        Self::Io {
            action,
            path: path.into(),
            error,
        }
    }

    /// An [`Error::Parse`] of `path`, at `line` if known.
    pub fn parse(path: impl Into<PathBuf>, line: Option<usize>, message: impl std::fmt::Display) -> Self {
        // a parser's message quotes the input: a 200 KB line is cut
        Self::Parse {
            path: path.into(),
            line,
            message: message
                .to_string()
                .lines()
                .map(store::shorten)
                .collect::<Vec<_>>()
                .join("\n"),
        }
    }

    /// This error, said to have happened while doing `context`.
    pub fn context(self, context: impl Into<String>) -> Self {
        Self::Context {
            context: context.into(),
            source: Box::new(self),
        }
    }

    /// The innermost error under any [`Error::Context`] layers.
    pub fn root(&self) -> &Error {
        match self {
            Self::Context { source, .. } => source.root(),
            e => e,
        }
    }
}

/// Adds context to the errors of a [`Result`], as in "saving trial 3".
pub trait ResultExt<T> {
    /// On error, wraps it in an [`Error::Context`] saying what was being done.
    fn context(self, context: impl Into<String>) -> Result<T>;
    /// As [`ResultExt::context`], with the text built only on error.
    fn with_context<S: Into<String>>(self, context: impl FnOnce() -> S) -> Result<T>;
}

impl<T, E: Into<Error>> ResultExt<T> for std::result::Result<T, E> {
    fn context(self, context: impl Into<String>) -> Result<T> {
        self.map_err(|e| e.into().context(context))
    }

    fn with_context<S: Into<String>>(self, context: impl FnOnce() -> S) -> Result<T> {
        self.map_err(|e| e.into().context(context()))
    }
}

/// Returns an [`Error::Data`] with the formatted message unless `cond` holds.
macro_rules! ensure_data {
    ($cond:expr, $($fmt:tt)+) => {
        let holds: bool = $cond;
        if !holds {
            return Err($crate::error::Error::data(format!($($fmt)+)));
        }
    };
}
pub(crate) use ensure_data;

/// Returns an [`Error::Config`] for `key` with the formatted message unless
/// `cond` holds.
macro_rules! ensure_config {
    ($key:expr, $cond:expr, $($fmt:tt)+) => {
        let holds: bool = $cond;
        if !holds {
            return Err($crate::error::Error::config($key, format!($($fmt)+)));
        }
    };
}
pub(crate) use ensure_config;

/// Checks that each setting `(key, value)` is positive and at most
/// [`MAX_MAGNITUDE`](crate::format::MAX_MAGNITUDE); the
/// [`Error::Config`] names the first that is not, as `prefix` then its key.
pub(crate) fn ensure_positive(prefix: &str, settings: &[(&str, f64)]) -> Result<()> {
    ensure_each(prefix, settings, "positive", |v| v > 0.0)
}

/// Checks that each setting `(key, value)` is nonnegative and at most
/// [`MAX_MAGNITUDE`](crate::format::MAX_MAGNITUDE); the
/// [`Error::Config`] names the first that is not, as `prefix` then its key.
pub(crate) fn ensure_nonnegative(prefix: &str, settings: &[(&str, f64)]) -> Result<()> {
    ensure_each(prefix, settings, "nonnegative", |v| v >= 0.0)
}

/// Checks that each setting `holds` (what `sign` says in the error) and is
/// at most [`MAX_MAGNITUDE`](crate::format::MAX_MAGNITUDE) (so
/// finite, and a criterion built from it stays finite).
fn ensure_each(prefix: &str, settings: &[(&str, f64)], sign: &str, holds: impl Fn(f64) -> bool) -> Result<()> {
    let max = crate::format::MAX_MAGNITUDE;
    for &(key, v) in settings {
        ensure_config!(
            format!("{prefix}{key}"),
            v <= max && holds(v),
            "{prefix}{key} must be {sign} and at most {max:e}, got {v}"
        );
    }
    Ok(())
}

/// Returns an [`Error::Refused`] with the formatted message unless `cond`
/// holds.
macro_rules! ensure_refused {
    ($cond:expr, $($fmt:tt)+) => {
        let holds: bool = $cond;
        if !holds {
            return Err($crate::error::Error::Refused(format!($($fmt)+)));
        }
    };
}
pub(crate) use ensure_refused;

/// Why a figure was not drawn or written ([`crate::output::plot`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// The embedded font did not load.
    #[error("the embedded font does not load")]
    Font,
    /// The figure has nothing to show (its experiment did not run).
    #[error("{0}: nothing to plot")]
    NoData(&'static str),
    /// `plotters` failed to draw.
    #[error("drawing: {0}")]
    Draw(String),
    /// The PNG encoder failed.
    #[error("encoding PNG: {0}")]
    Png(String),
    /// A figure's file could not be written.
    #[error("writing {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        source: std::io::Error,
    },
    /// A figure's file could not be replaced (the error names it).
    #[error(transparent)]
    Store(Box<store::StoreError>),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn context_chains_and_root() {
        let e = Error::io(
            "reading",
            "/nowhere/x.json",
            std::io::Error::from(std::io::ErrorKind::NotFound),
        )
        .context("loading trial 2");
        assert_eq!(e.to_string(), "loading trial 2");
        let cause = std::error::Error::source(&e).expect("a cause");
        assert!(cause.to_string().starts_with("reading /nowhere/x.json: "), "{cause}");
        assert!(matches!(e.root(), Error::Io { action: "reading", .. }));
    }

    #[test]
    fn parse_errors_name_file_and_line() {
        assert_eq!(
            Error::parse("runs.jsonl", Some(3), "expected value").to_string(),
            "runs.jsonl line 3: expected value"
        );
        assert_eq!(Error::parse("c.toml", None, "bad").to_string(), "c.toml: bad");
    }

    #[test]
    fn result_ext_wraps_other_crates_errors() {
        let r: std::result::Result<(), lwr::LwrError> = Err(lwr::LwrError::EmptyDatabase);
        let e = r.context("fitting the model").expect_err("an error");
        assert!(matches!(e.root(), Error::Lwr(_)));
    }
}
