//! The record of one run ([`RunRecord`]) and the file that holds a set of
//! them ([`RecordFile`]): the one format the runner writes and the outside
//! scripts (`scripts/bench/`) write too.
//!
//! ```json
//! {"format": "nprl-bench/1", "source": "scipy", "runs": [
//!   {"solver": "scipy-lm", "set": "mgh", "problem": "01_rosenbrock", "n": 2, "m": 2,
//!    "scale": 1.0, "status": "converged", "converged": true, "f0": 24.2, "f": 0.0,
//!    "f_star": 0.0, "f_evals": 40, "jac_evals": 0, "evals": 40, "time_s": 0.0012,
//!    "repeats": 3, "trace": [[1, 24.2], [4, 4.73], [40, 0.0]],
//!    "x0": [-1.2, 1.0], "x": [1.0, 1.0]}]}
//! ```
//!
//! `f0` and `f` are the solver's own account; the runner does not trust
//! them: it recomputes $f(x_0)$ from the instance's start for every record
//! and $f$ at the stored final `x` (see [`crate::minima`]). `x0` and `x`
//! may be absent in records written before they were stored; such a
//! record is judged by its own `f`.
//!
//! `evals` counts evaluation equivalents: residual (or cost) evaluations
//! plus $n$ per Jacobian (or gradient) evaluation, what a forward-difference
//! Jacobian costs, so that solvers with and without derivatives compare on
//! one scale. `trace` lists `[evals, f]` where the best $f$ so far fell,
//! thinned by [`thin_trace`].
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{BenchError, Result};

/// The `format` tag of a [`RecordFile`].
pub const FORMAT: &str = "nprl-bench/1";

/// One solver run from one starting point of one problem.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The solver's name (`gauss-newton`, `scipy-lm`, ...).
    pub solver: String,
    /// The problem set (`mgh`).
    pub set: String,
    /// The problem's name within the set (`24_penalty2`).
    pub problem: String,
    /// Number of parameters.
    pub n: usize,
    /// Number of residuals (0 for a problem given by its cost alone).
    pub m: usize,
    /// The start's scale (the MGH set starts at 1, 10 and 100 $x_0$).
    pub scale: f64,
    /// Why the solver stopped, in its own words (`converged`,
    /// `max-iterations`, `budget`, `error: ...`).
    pub status: String,
    /// Whether the solver claims convergence.
    pub converged: bool,
    /// $f$ at the start (not finite, e.g. an overflow at a far start:
    /// written as `null`, read back as NaN).
    #[serde(deserialize_with = "null_as_nan")]
    pub f0: f64,
    /// The best $f$ found (not finite: written as `null`, read back as NaN).
    #[serde(deserialize_with = "null_as_nan")]
    pub f: f64,
    /// The problem's published optimal value, if known.
    pub f_star: Option<f64>,
    /// The solver's own final objective when `f` is another figure of
    /// merit (the trajectory set: `f` is the task cost of the final
    /// controls rolled out through the exact dynamics, this the Eq. 3
    /// criterion or DDP's cost); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objective: Option<f64>,
    /// Residual (or cost) evaluations.
    pub f_evals: u64,
    /// Jacobian (or gradient) evaluations.
    pub jac_evals: u64,
    /// Evaluation equivalents: `f_evals + n * jac_evals`.
    pub evals: u64,
    /// Wall time of the solve in seconds (the median over `repeats`).
    pub time_s: f64,
    /// How many times the solve was timed.
    pub repeats: u32,
    /// `[evals, f]` where the best $f$ so far fell (see [`thin_trace`]).
    pub trace: Vec<(u64, f64)>,
    /// The starting point, when the writer stored it (the runner checks
    /// it against the instance's start).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x0: Option<Vec<f64>>,
    /// The final point: the one of the best $f$ evaluated, which is what
    /// each solver returns; on the trajectory set the Eq. 3 coefficients,
    /// or DDP's controls stacked, whose rollout the runner scores
    /// ([`crate::trajectory::figure_of_merit`]). Absent in older records.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<Vec<f64>>,
    /// Why the run stopped, in the workspace's one vocabulary (typed; the
    /// solver's own word is [`status`](Self::status)): every built-in
    /// solver's, a user's solver's when it gives one. Absent in the
    /// outside solvers' records and in older ones.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub termination: Option<solve::Termination>,
}

/// An `f64` that JSON holds as `null` when it was not finite (serde_json
/// writes NaN and infinities so) comes back as NaN.
fn null_as_nan<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    Ok(<Option<f64> as serde::Deserialize>::deserialize(d)?.unwrap_or(f64::NAN))
}

impl RunRecord {
    /// The key that pairs runs of different solvers: set, problem, scale.
    pub fn instance(&self) -> (String, String, String) {
        (self.set.clone(), self.problem.clone(), format!("{}", self.scale))
    }

    /// The first evaluation count at which the best $f$ was at most
    /// `threshold`, if it ever was.
    pub fn evals_to(&self, threshold: f64) -> Option<u64> {
        self.trace.iter().find(|(_, f)| *f <= threshold).map(|(e, _)| *e)
    }

    /// Checks every field a file can get wrong; the error names it.
    fn validate(&self, path: &Path, index: usize) -> Result<()> {
        let bad = |field: &'static str, reason: String| BenchError::BadField {
            path: path.to_path_buf(),
            index,
            field,
            reason,
        };
        for (field, v) in [("solver", &self.solver), ("set", &self.set), ("problem", &self.problem)] {
            if v.trim().is_empty() {
                return Err(bad(field, "must not be empty".into()));
            }
        }
        if self.n == 0 {
            return Err(bad("n", "must be at least 1".into()));
        }
        // f0 and f may be NaN: a start where the problem overflows is a
        // record (of a run that solves nothing), written as null
        if !self.scale.is_finite() {
            return Err(bad("scale", format!("must be finite, got {}", self.scale)));
        }
        for (field, v) in [("f0", self.f0), ("f", self.f)] {
            if v.is_infinite() {
                return Err(bad(field, format!("must be finite or null, got {v}")));
            }
        }
        if self.f_star.is_some_and(|v| !v.is_finite()) {
            return Err(bad("f_star", "must be finite or null".into()));
        }
        if !(self.time_s.is_finite() && self.time_s >= 0.0) {
            return Err(bad("time_s", format!("must be finite and >= 0, got {}", self.time_s)));
        }
        if self.trace.is_empty() && self.f0.is_finite() {
            return Err(bad(
                "trace",
                "must hold at least the start (empty only when f0 is null)".into(),
            ));
        }
        if self.trace.windows(2).any(|w| w[1].0 < w[0].0 || w[1].1 > w[0].1) {
            return Err(bad("trace", "evals must not decrease nor f increase".into()));
        }
        if self.trace.iter().any(|(_, f)| !f.is_finite()) {
            return Err(bad("trace", "values must be finite".into()));
        }
        for (field, point) in [("x0", &self.x0), ("x", &self.x)] {
            if point.as_ref().is_some_and(|p| p.iter().any(|v| !v.is_finite())) {
                return Err(bad(field, "entries must be finite".into()));
            }
        }
        if let Some(x0) = self.x0.as_ref().filter(|x0| x0.len() != self.n) {
            return Err(bad("x0", format!("must have n = {} entries, got {}", self.n, x0.len())));
        }
        Ok(())
    }
}

/// A file of runs: what `nprl-bench` writes as `runs.json` and the outside
/// scripts write as `*.json` for it to merge.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecordFile {
    /// Always [`FORMAT`].
    pub format: String,
    /// Who wrote it (`nprl-bench`, `scipy`, `nlopt`), with versions.
    pub source: String,
    /// The runs.
    pub runs: Vec<RunRecord>,
    /// The code and budget that made the runs, for `nprl-bench`'s own
    /// files (`None` in the outside scripts' files and in files written
    /// before it was recorded): a report judged later from the saved runs
    /// (`--reuse`) is stamped with these, not with the judging binary's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub made_by: Option<MadeBy>,
}

/// What made a file of runs ([`RecordFile::made_by`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MadeBy {
    /// The code version of the binary that ran them ([`store::code_version`]).
    pub code_version: String,
    /// Its evaluation budget per run, in simplex gradients ($n + 1$).
    pub budget_simplex_gradients: u64,
    /// Its time budget per run, seconds.
    pub budget_time_s: f64,
}

/// What identifies one run in a result set: its set, problem, start
/// scale and solver ([`RunRecord::key`]).
pub type RunKey = (String, String, u64, String);

impl RunRecord {
    /// The run's key: a result set holds at most one run per key, and a
    /// run of a subset replaces the saved run of the same key.
    pub fn key(&self) -> RunKey {
        (
            self.set.clone(),
            self.problem.clone(),
            self.scale.to_bits(),
            self.solver.clone(),
        )
    }
}

impl RecordFile {
    /// A file of `runs` from `source`.
    pub fn new(source: impl Into<String>, runs: Vec<RunRecord>) -> Self {
        Self {
            format: FORMAT.into(),
            source: source.into(),
            runs,
            made_by: None,
        }
    }

    /// Parses and checks `text`, read from `path` (for the errors).
    ///
    /// # Errors
    /// [`BenchError::Malformed`] for JSON of the wrong shape (with line and
    /// column), [`BenchError::BadField`] naming the run and field out of range.
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let file: Self = serde_json::from_str(text).map_err(|source| BenchError::Malformed {
            path: path.to_path_buf(),
            source,
        })?;
        if file.format != FORMAT {
            return Err(BenchError::BadField {
                path: path.to_path_buf(),
                index: 0,
                field: "format",
                reason: format!("expected `{FORMAT}`, got `{}`", file.format),
            });
        }
        for (index, run) in file.runs.iter().enumerate() {
            run.validate(path, index)?;
        }
        Ok(file)
    }

    /// Reads and checks the file at `path`.
    ///
    /// # Errors
    /// [`BenchError::Io`] if it cannot be read; as [`parse`](Self::parse).
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(BenchError::io(path))?;
        Self::parse(&text, path)
    }

    /// Writes the file to `path` as pretty JSON, after checking every run
    /// as [`load`](Self::load) would.
    ///
    /// # Errors
    /// [`BenchError::BadField`] naming the run and field the loader would
    /// refuse (nothing is written), or [`BenchError::Io`] naming the file.
    pub fn save(&self, path: &Path) -> Result<()> {
        // a record the loader would refuse is never written: the error
        // names it, and the file on disk stays as it was
        for (index, run) in self.runs.iter().enumerate() {
            run.validate(path, index)?;
        }
        let text = serde_json::to_string(self).map_err(|e| BenchError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::other(e),
        })?;
        crate::files::write(path, &(text + "\n"))
    }
}

/// Keeps the points of an improvement trace `[evals, f]` (best $f$ so far,
/// in order) at which $f - f_\text{end}$ fell to 90% or less of its value
/// at the last point kept, plus the first and the last: at most a few
/// hundred points however long the run, and the first evaluation count at
/// which $f \le f_L + \tau (f_0 - f_L)$ read from the thinned trace is that
/// of the full trace for a $\tau$ at most 10% larger. The outside scripts
/// thin by the same rule.
pub fn thin_trace(trace: &[(u64, f64)]) -> Vec<(u64, f64)> {
    let Some(&(_, f_end)) = trace.last() else {
        return Vec::new();
    };
    let mut kept: Vec<(u64, f64)> = Vec::new();
    for (i, &(e, f)) in trace.iter().enumerate() {
        let keep = match kept.last() {
            None => true,
            Some(&(_, f_kept)) => i + 1 == trace.len() || f - f_end <= 0.9 * (f_kept - f_end),
        };
        if keep {
            kept.push((e, f));
        }
    }
    kept
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn run(solver: &str, problem: &str, f: f64, evals: u64) -> RunRecord {
        RunRecord {
            solver: solver.into(),
            set: "mgh".into(),
            problem: problem.into(),
            n: 2,
            m: 2,
            scale: 1.0,
            status: "converged".into(),
            converged: true,
            f0: 10.0,
            f,
            f_star: Some(0.0),
            objective: None,
            f_evals: evals,
            jac_evals: 0,
            evals,
            time_s: 0.5,
            repeats: 1,
            trace: vec![(1, 10.0), (evals, f)],
            x0: None,
            x: None,
            termination: None,
        }
    }

    #[test]
    fn a_record_file_round_trips_through_json() {
        let mut with_points = run("b", "q", 0.1 + 0.2, 9);
        with_points.x0 = Some(vec![-1.2, 1.0]);
        with_points.x = Some(vec![1.0, 0.1 + 0.2]);
        let file = RecordFile::new("test", vec![run("a", "p", 1e-300, 7), with_points]);
        let text = serde_json::to_string(&file).expect("serialises");
        let back = RecordFile::parse(&text, Path::new("x.json")).expect("parses");
        assert_eq!(back, file);
    }

    /// A run whose start overflowed (f0 and f infinite or NaN) is written
    /// with nulls and read back, as NaN, instead of refusing the file.
    #[test]
    fn a_run_that_overflowed_reads_back() {
        let mut r = run("a", "p", 1.0, 7);
        r.f0 = f64::INFINITY;
        r.f = f64::NAN;
        r.trace.clear();
        let text = serde_json::to_string(&RecordFile::new("test", vec![r])).expect("serialises");
        assert!(text.contains("\"f0\":null"), "{text}");
        let back = RecordFile::parse(&text, Path::new("runs.json")).expect("reads back");
        assert!(back.runs[0].f0.is_nan() && back.runs[0].f.is_nan());
    }

    #[test]
    fn malformed_files_name_the_file_and_the_field() {
        let path = Path::new("outside/scipy.json");
        match RecordFile::parse("{\"format\": \"nprl-bench/1\", \"runs\": []}", path) {
            Err(e @ BenchError::Malformed { .. }) => {
                let msg = e.to_string();
                assert!(msg.contains("outside/scipy.json") && msg.contains("source"), "{msg}");
            }
            other => panic!("{other:?}"),
        }
        let mut bad = run("a", "p", 0.0, 3);
        bad.time_s = -1.0;
        let text = serde_json::to_string(&RecordFile::new("t", vec![run("a", "p", 0.0, 3), bad])).expect("json");
        match RecordFile::parse(&text, path) {
            Err(BenchError::BadField { index, field, .. }) => assert_eq!((index, field), (1, "time_s")),
            other => panic!("{other:?}"),
        }
        let mut short = run("a", "p", 0.0, 3);
        short.x0 = Some(vec![1.0]);
        let text = serde_json::to_string(&RecordFile::new("t", vec![short])).expect("json");
        assert!(matches!(
            RecordFile::parse(&text, path),
            Err(BenchError::BadField { field: "x0", .. })
        ));
        let mut rising = run("a", "p", 0.0, 3);
        rising.trace = vec![(1, 1.0), (2, 2.0)];
        let text = serde_json::to_string(&RecordFile::new("t", vec![rising])).expect("json");
        assert!(matches!(
            RecordFile::parse(&text, path),
            Err(BenchError::BadField { field: "trace", .. })
        ));
        let text = serde_json::to_string(&RecordFile {
            format: "other/2".into(),
            ..RecordFile::new("t", vec![])
        })
        .expect("json");
        assert!(matches!(
            RecordFile::parse(&text, path),
            Err(BenchError::BadField { field: "format", .. })
        ));
    }

    #[test]
    fn thinning_keeps_ends_and_tenfold_drops() {
        let trace: Vec<(u64, f64)> = (0..100).map(|i| (i + 1, 1.0 + 0.99f64.powi(i as i32))).collect();
        let thin = thin_trace(&trace);
        assert_eq!(thin.first(), trace.first());
        assert_eq!(thin.last(), trace.last());
        assert!(thin.len() < trace.len() / 2, "{}", thin.len());
        let f_end = trace[99].1;
        for w in thin.windows(2).take(thin.len() - 2) {
            assert!(w[1].1 - f_end <= 0.9 * (w[0].1 - f_end));
        }
        assert!(thin_trace(&[]).is_empty());
    }
}
