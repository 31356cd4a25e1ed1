//! What the runner writes: the per-run table (CSV and Markdown), the
//! profiles (JSON), the goals of the project's issues 21 and 33, the
//! six-row summary (evaluations only), and the stamp (commit, machine, runs) on all of it.
//! On the MGH set every count of instances solved is at the minimum
//! ([`crate::minima`]), degenerate instances left out.

use std::fmt::Write as _;
use std::process::Command;

use serde::{Deserialize, Serialize};

use crate::analysis::{Analysis, Criterion};
use crate::error::{BenchError, Result};
pub use crate::files::write;
use crate::minima;
use crate::profiles::Profile;

/// Where and on what the numbers were measured (saved in every
/// `benchmarks*.json` as `stamp`, and read back by the tests that check
/// the saved reports against their records).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stamp {
    /// The commit the runs' binary was built from ([`store::code_version`],
    /// recorded with the runs: [`crate::record::RecordFile::made_by`]), or
    /// `unknown`.
    pub commit: String,
    /// Whether that binary's code differed from the commit.
    pub dirty: bool,
    /// Cores available to the process.
    pub cores: usize,
    /// `/proc/loadavg`'s 1-minute load before and after the run.
    pub load_before: Option<f64>,
    /// The same after.
    pub load_after: Option<f64>,
    /// UTC date and time of the report.
    pub date: String,
    /// Number of solver runs in the report (ours and outside).
    pub runs: usize,
    /// Times each of our solves was timed (the median is reported).
    pub repeats: u32,
    /// The evaluation budget per run the runs were made with, in simplex
    /// gradients ($n + 1$).
    pub budget_simplex_gradients: u64,
    /// Their time budget per run, seconds.
    pub budget_time_s: f64,
    /// The sources of the records merged (ours and the outside scripts').
    pub sources: Vec<String>,
    /// Wall time of the runner's own runs (0 when reused), seconds.
    pub elapsed_s: f64,
}

impl Stamp {
    /// The 1-minute load average, where `/proc/loadavg` exists.
    pub fn load() -> Option<f64> {
        std::fs::read_to_string("/proc/loadavg")
            .ok()?
            .split_whitespace()
            .next()?
            .parse()
            .ok()
    }

    /// The UTC date and time now, `YYYY-MM-DDTHH:MM:SSZ` (from `date -u`),
    /// or `unknown`.
    pub fn date() -> String {
        Command::new("date")
            .args(["-u", "+%Y-%m-%dT%H:%M:%SZ"])
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map_or_else(
                || "unknown".into(),
                |o| String::from_utf8_lossy(&o.stdout).trim().to_string(),
            )
    }
}

/// One measured comparison: ours against a reference on the instances
/// both ran.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// What is compared.
    pub task: String,
    /// Our solver.
    pub ours: String,
    /// The reference solver.
    pub reference: String,
    /// Our figure (a count, or a median).
    pub ours_value: Option<f64>,
    /// The reference's figure.
    pub reference_value: Option<f64>,
    /// The ratio ours / reference (for medians: the median of the
    /// per-instance ratios).
    pub ratio: Option<f64>,
    /// Solver runs behind the figures.
    pub runs: usize,
    /// The unit of the values (`instances`, `s`, `evaluations`).
    pub unit: String,
}

/// A goal of issue 21, measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Goal {
    /// The goal as stated.
    pub goal: String,
    /// Met, not met, or not measured (a solver's records missing).
    pub verdict: String,
    /// The comparisons it rests on.
    pub evidence: Vec<Comparison>,
}

/// The median of `v` (the mean of the middle two for an even count;
/// `None` when empty).
pub(crate) fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let k = v.len();
    Some(if k % 2 == 1 {
        v[k / 2]
    } else {
        0.5 * (v[k / 2 - 1] + v[k / 2])
    })
}

/// Instances solved by `criterion` by `ours` and by `reference`, on the
/// instances both ran (degenerate ones left out).
pub fn solved_counts(a: &Analysis, ours: &str, reference: &str, criterion: Criterion) -> Comparison {
    let mut c = Comparison {
        task: format!("MGH instances solved ({})", criterion.label()),
        ours: ours.into(),
        reference: reference.into(),
        ours_value: None,
        reference_value: None,
        ratio: None,
        runs: 0,
        unit: "instances".into(),
    };
    let (Some(s), Some(r)) = (a.column(ours), a.column(reference)) else {
        return c;
    };
    let rows = a.common_rows(&[s, r]);
    let count = |col: usize| {
        rows.iter()
            .filter(|&&p| a.judge(p, col, criterion).is_some_and(|o| o.solved))
            .count() as f64
    };
    let (x, y) = (count(s), count(r));
    c.ours_value = Some(x);
    c.reference_value = Some(y);
    c.ratio = (y > 0.0).then(|| x / y);
    c.runs = 2 * rows.len();
    c
}

/// Medians of time or evaluations to solve by `criterion` over the
/// instances both solved, and the median of the per-instance ratios.
pub fn median_costs(a: &Analysis, ours: &str, reference: &str, criterion: Criterion, by_time: bool) -> Comparison {
    let mut c = Comparison {
        task: format!(
            "MGH {} to solve, median over instances both solve ({})",
            if by_time { "time" } else { "evaluations" },
            criterion.label()
        ),
        ours: ours.into(),
        reference: reference.into(),
        ours_value: None,
        reference_value: None,
        ratio: None,
        runs: 0,
        unit: if by_time { "s" } else { "evaluations" }.into(),
    };
    let (Some(s), Some(r)) = (a.column(ours), a.column(reference)) else {
        return c;
    };
    let cost = |p: usize, col: usize| {
        let o = a.judge(p, col, criterion)?;
        if by_time { o.time_s } else { o.evals.map(|e| e as f64) }
    };
    let pairs: Vec<(f64, f64)> = a
        .common_rows(&[s, r])
        .into_iter()
        .filter_map(|p| Some((cost(p, s)?, cost(p, r)?)))
        .collect();
    c.ours_value = median(pairs.iter().map(|p| p.0).collect());
    c.reference_value = median(pairs.iter().map(|p| p.1).collect());
    c.ratio = median(pairs.iter().map(|p| p.0 / p.1.max(f64::MIN_POSITIVE)).collect());
    c.runs = 2 * pairs.len();
    c
}

/// The criterion of the goals and the summary on the MGH set.
pub const GOAL: Criterion = Criterion::AtMinimum;

/// The outside derivative-free solvers of issue 33: Powell's own NEWUOA
/// and BOBYQA (PDFO), NLopt's NEWUOA and PRAXIS.
pub const ISSUE_33_REFERENCES: [&str; 4] = ["nlopt-praxis", "nlopt-newuoa", "pdfo-newuoa", "pdfo-bobyqa"];

/// Our derivative-free solvers measured by issue 33's goal.
pub const ISSUE_33_OURS: [&str; 2] = ["powell", "dfo-ls"];

/// The outside least-squares solvers of issue 52: scipy's `trf` and
/// MINPACK's `lm` (through scipy).
pub const ISSUE_52_REFERENCES: [&str; 2] = ["scipy-trf", "scipy-lm"];

/// Our least-squares solvers measured by issue 52's goal.
pub const ISSUE_52_OURS: [&str; 3] = ["gauss-newton", "trust-region", "trust-region-geodesic"];

/// Issue 52's goal on the MGH set: one of [`ISSUE_52_OURS`] solves at the
/// minimum strictly more instances than each of [`ISSUE_52_REFERENCES`],
/// with a median of evaluations no higher (pairwise, as
/// [`issue_33_goal`]). The evidence lists every pair; not measured
/// without a reference's records or any of ours.
pub fn issue_52_goal(a: &Analysis) -> Goal {
    let mut evidence = Vec::new();
    let mut measured = ISSUE_52_REFERENCES.iter().all(|r| a.column(r).is_some());
    let mut any_ours = false;
    let mut met = false;
    for ours in ISSUE_52_OURS {
        if a.column(ours).is_none() {
            continue;
        }
        any_ours = true;
        let mut leads = true;
        for reference in ISSUE_52_REFERENCES {
            let solved = solved_counts(a, ours, reference, GOAL);
            let evals = median_costs(a, ours, reference, GOAL, false);
            leads &= solved.ours_value > solved.reference_value
                && matches!((evals.ours_value, evals.reference_value), (Some(x), Some(y)) if x <= y);
            evidence.push(solved);
            evidence.push(evals);
        }
        met |= leads;
    }
    measured &= any_ours;
    Goal {
        goal: format!(
            "(issue 52) one of {} solves at the minimum strictly more MGH instances than each of {}, with a median of evaluations no higher (pairwise: medians over the instances both solve)",
            ISSUE_52_OURS.join(", "),
            ISSUE_52_REFERENCES.join(", ")
        ),
        verdict: verdict(measured, met),
        evidence,
    }
}

fn verdict(measured: bool, met: bool) -> String {
    match (measured, met) {
        (false, _) => "not measured",
        (true, true) => "met",
        (true, false) => "not met",
    }
    .to_string()
}

/// The two goals of issue 21, at the minimum ([`GOAL`]): Powell needs no
/// more evaluations than PRAXIS (median ratio at most 1), and
/// Gauss-Newton solves at least as many instances as MINPACK
/// (`scipy-lm`) in less time (median time ratio below 1); then issue 33's
/// goal for each of [`ISSUE_33_OURS`] ([`issue_33_goal`]); then issue 52's
/// ([`issue_52_goal`]).
pub fn goals(a: &Analysis) -> Vec<Goal> {
    let powell = median_costs(a, "powell", "nlopt-praxis", GOAL, false);
    let powell_measured = powell.ratio.is_some();
    let powell_met = powell.ratio.is_some_and(|r| r <= 1.0);
    let solved = solved_counts(a, "gauss-newton", "scipy-lm", GOAL);
    let time = median_costs(a, "gauss-newton", "scipy-lm", GOAL, true);
    let gn_measured = solved.ours_value.is_some() && time.ratio.is_some();
    let gn_met = solved.ours_value >= solved.reference_value && time.ratio.is_some_and(|r| r < 1.0);
    let mut goals = vec![
        Goal {
            goal: "(issue 21) Powell needs no more function evaluations than NLopt's PRAXIS on the MGH set (median per-instance ratio over instances both solve at the minimum <= 1)".into(),
            verdict: verdict(powell_measured, powell_met),
            evidence: vec![powell],
        },
        Goal {
            goal: "(issue 21) Gauss-Newton/LM solves at the minimum at least as many MGH instances as MINPACK (scipy lm), in less time (median per-instance time ratio < 1; scipy lm runs from Python with NumPy residuals, so the time is not like for like: the evaluations row of the summary is)".into(),
            verdict: verdict(gn_measured, gn_met),
            evidence: vec![solved, time],
        },
    ];
    goals.extend(ISSUE_33_OURS.iter().map(|ours| issue_33_goal(a, ours)));
    goals.push(issue_52_goal(a));
    goals
}

/// Issue 33's goal for our derivative-free solver `ours`: it solves at the
/// minimum at least as many MGH instances as each of
/// [`ISSUE_33_REFERENCES`], and its median evaluations to the minimum are
/// no higher than the best of theirs. Convention: each comparison is
/// pairwise, on the instances both ran (counts) or both solved (medians of
/// each solver's evaluations there), so the goal is met when every count
/// is at least the reference's and every median at most the reference's.
/// Not measured when `ours` or a reference has no records.
pub fn issue_33_goal(a: &Analysis, ours: &str) -> Goal {
    let mut evidence = Vec::new();
    let (mut measured, mut met) = (a.column(ours).is_some(), true);
    for reference in ISSUE_33_REFERENCES {
        let solved = solved_counts(a, ours, reference, GOAL);
        let evals = median_costs(a, ours, reference, GOAL, false);
        measured &= solved.ours_value.is_some();
        met &= solved.ours_value >= solved.reference_value
            && match (evals.ours_value, evals.reference_value) {
                (Some(x), Some(y)) => x <= y,
                // nothing both solve: no median to compare
                _ => false,
            };
        evidence.push(solved);
        evidence.push(evals);
    }
    Goal {
        goal: format!(
            "(issue 33) `{ours}` solves at the minimum at least as many MGH instances as each of {}, with a median of evaluations no higher than the best of them (pairwise: medians over the instances both solve)",
            ISSUE_33_REFERENCES.join(", ")
        ),
        verdict: verdict(measured, met),
        evidence,
    }
}

/// The rows of the summary, each a solved count and a median of
/// evaluations where both solve: Gauss-Newton against MINPACK (scipy `lm`),
/// the trust region with and without geodesic acceleration against scipy's
/// `trf`, Powell against PRAXIS, and the derivative-free mode against DFO-LS.
///
/// No row compares time: the outside solvers run under Python (NumPy
/// residuals, a Python callback per evaluation) and ours compiled, so a
/// time ratio would measure the languages; [`summary_markdown`] says so,
/// and the times stay in the per-solver tables and profiles.
pub fn summary(a: &Analysis) -> Vec<Comparison> {
    vec![
        solved_counts(a, "gauss-newton", "scipy-lm", GOAL),
        median_costs(a, "gauss-newton", "scipy-lm", GOAL, false),
        solved_counts(a, "trust-region", "scipy-trf", GOAL),
        median_costs(a, "trust-region", "scipy-trf", GOAL, false),
        solved_counts(a, "trust-region-geodesic", "scipy-trf", GOAL),
        median_costs(a, "trust-region-geodesic", "scipy-trf", GOAL, false),
        solved_counts(a, "powell", "nlopt-praxis", GOAL),
        median_costs(a, "powell", "nlopt-praxis", GOAL, false),
        solved_counts(a, "dfo-ls", "dfols", GOAL),
        median_costs(a, "dfo-ls", "dfols", GOAL, false),
    ]
}

/// A value in its unit for the tables (`-` when missing).
pub(crate) fn num(v: Option<f64>, unit: &str) -> String {
    match v {
        None => "-".into(),
        Some(x) if unit == "instances" => format!("{x:.0}"),
        Some(x) if unit == "s" => format!("{:.3} ms", x * 1e3),
        Some(x) => format!("{x:.1}"),
    }
}

/// The first line of a README's generated benchmark summary.
pub const README_START: &str = "<!-- benchmarks:start -->\n";
/// The line after a README's generated benchmark summary.
pub const README_END: &str = "<!-- benchmarks:end -->";

/// `readme` with the text between [`README_START`] and [`README_END`]
/// replaced by `summary`, or `None` when the two lines are not there in
/// that order. Each marker counts only as a whole line of its own (a
/// marker quoted in prose, as `` `<!-- benchmarks:start -->` `` in a
/// sentence, is text, not a marker).
pub fn with_readme_summary(readme: &str, summary: &str) -> Option<String> {
    store::with_block(readme, README_START, README_END, summary)
}

/// The summary as a Markdown table (task, ours, reference, ratio, runs).
pub fn summary_markdown(rows: &[Comparison], stamp: &Stamp) -> String {
    let mut s = String::from("| task | ours | reference | ratio | runs |\n|---|---|---|---|---|\n");
    for c in rows {
        let _ = writeln!(
            s,
            "| {} | {}: {} | {}: {} | {} | {} |",
            c.task,
            c.ours,
            num(c.ours_value, &c.unit),
            c.reference,
            num(c.reference_value, &c.unit),
            ratio_text(c.ratio),
            c.runs
        );
    }
    s.push_str("\nEvaluations only, no times: the outside solvers run from Python (NumPy residuals, a Python call per evaluation), ours compiled with analytic Jacobians where they use any; times are in `results/benchmarks.md`.\n");
    let _ = writeln!(
        s,
        "\nGenerated by `nprl-bench` at commit {}{} on {} cores (load {}), {} runs, {}.",
        short(&stamp.commit),
        if stamp.dirty { " (dirty)" } else { "" },
        stamp.cores,
        stamp.load_before.map_or("?".into(), |l| format!("{l:.2}")),
        stamp.runs,
        stamp.date
    );
    s
}

/// A ratio with three significant digits (`-` when missing).
pub(crate) fn ratio_text(r: Option<f64>) -> String {
    match r {
        None => "-".into(),
        Some(r) if r != 0.0 && r.abs() < 0.01 => format!("{r:.2e}"),
        Some(r) => format!("{r:.3}"),
    }
}

fn short(commit: &str) -> &str {
    commit.get(..12).unwrap_or(commit)
}

/// One row per run: instance, solver, status, values and outcomes at both
/// taus.
pub fn runs_csv(a: &Analysis) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let csv_err = |e: csv::Error| BenchError::Io {
        path: "table.csv".into(),
        source: std::io::Error::other(e),
    };
    let mut header: Vec<String> = [
        "set",
        "problem",
        "scale",
        "n",
        "solver",
        "status",
        "converged",
        "f0",
        "f",
        "f_low",
        "f_star",
        "f_evals",
        "jac_evals",
        "evals",
        "time_s",
    ]
    .map(String::from)
    .to_vec();
    header.push("degenerate".into());
    header.push("at_minimum".into());
    header.push("evals_to_minimum".into());
    for tau in a.taus() {
        header.push(format!("solved_{tau:e}"));
        header.push(format!("evals_to_{tau:e}"));
    }
    w.write_record(&header).map_err(csv_err)?;
    for (p, key) in a.instances.iter().enumerate() {
        for (s, run) in a.runs[p].iter().enumerate() {
            let Some(r) = run else { continue };
            let mut row = vec![
                key.0.clone(),
                key.1.clone(),
                key.2.clone(),
                r.n.to_string(),
                r.solver.clone(),
                r.status.clone(),
                r.converged.to_string(),
                format!("{:e}", r.f0),
                format!("{:e}", r.f),
                format!("{:e}", a.f_low[p]),
                r.f_star.map_or(String::new(), |v| format!("{v:e}")),
                r.f_evals.to_string(),
                r.jac_evals.to_string(),
                r.evals.to_string(),
                format!("{:e}", r.time_s),
            ];
            row.push(a.degenerate(p).unwrap_or("").to_string());
            let m = a.at_minimum(p, s);
            row.push(m.map_or(String::new(), |o| o.solved.to_string()));
            row.push(m.and_then(|o| o.evals).map_or(String::new(), |e| e.to_string()));
            for tau in a.taus() {
                let o = a.outcome(p, s, tau);
                row.push(o.is_some_and(|o| o.solved).to_string());
                row.push(o.and_then(|o| o.evals).map_or(String::new(), |e| e.to_string()));
            }
            w.write_record(&row).map_err(csv_err)?;
        }
    }
    let bytes = w.into_inner().map_err(|e| BenchError::Io {
        path: "table.csv".into(),
        source: std::io::Error::other(e.to_string()),
    })?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// Per problem and start: each solver's final $f$ (bold where it solved
/// by the headline criterion, [`Analysis::headline`]: at the minimum on
/// the MGH set) and its evaluations to solve, as Markdown; a degenerate
/// instance says why in its `f_L` cell.
pub fn problems_markdown(a: &Analysis) -> String {
    let criterion = a.headline();
    let low = if a.has_references() { "f*" } else { "f_L" };
    let mut s = format!("| problem | scale | n | {low} | {} |\n", a.solvers.join(" | "));
    let _ = writeln!(s, "|---|---|---|---|{}", "---|".repeat(a.solvers.len()));
    for (p, key) in a.instances.iter().enumerate() {
        let _ = write!(s, "| {} | {} | {} | {:.6e}", key.1, key.2, a.n[p], a.f_low[p]);
        if let Some(why) = a.degenerate(p) {
            let _ = write!(s, " (degenerate: {why})");
        }
        s.push_str(" |");
        for (col, run) in a.runs[p].iter().enumerate() {
            match (run, a.judge(p, col, criterion)) {
                (Some(r), Some(o)) if o.solved && a.degenerate(p).is_none() => {
                    let _ = write!(s, " **{:.4e}** ({}) |", r.f, o.evals.unwrap_or(r.evals));
                }
                (Some(r), _) => {
                    let _ = write!(s, " {:.4e} [{}] |", r.f, status_word(&r.status));
                }
                (None, _) => s.push_str(" - |"),
            }
        }
        s.push('\n');
    }
    s
}

/// The NIST set's tables, Ceres's way: per solver, the problems whose
/// final parameters agree with the certified ones to at least 4 and 6
/// digits (LRE, [`crate::nist::lre`]) from each start; per problem, each
/// solver's LRE from start 1 and start 2 (**bold** at 4 digits or more).
pub fn nist_markdown(a: &Analysis) -> String {
    let difficulty: std::collections::BTreeMap<String, String> = crate::nist::all()
        .map(|all| {
            all.into_iter()
                .map(|p| (p.name, crate::open::status_text(&p.difficulty)))
                .collect()
        })
        .unwrap_or_default();
    let starts = ["1", "2"];
    let mut s = String::from("| solver | runs |");
    for k in crate::nist::DIGITS {
        for start in starts {
            let _ = write!(s, " LRE >= {k} (start {start}) |");
        }
        let _ = write!(s, " LRE >= {k} (both starts) |");
    }
    let _ = writeln!(s, "\n|---|---|{}", "---|".repeat(3 * crate::nist::DIGITS.len()));
    for (col, name) in a.solvers.iter().enumerate() {
        let runs = (0..a.instances.len()).filter(|&p| a.runs[p][col].is_some()).count();
        let _ = write!(s, "| {name} | {runs} |");
        for k in crate::nist::DIGITS {
            let count = |start: Option<&str>| {
                (0..a.instances.len())
                    .filter(|&p| start.is_none_or(|st| a.instances[p].2 == st))
                    .filter(|&p| a.lre(p, col).is_some_and(|l| l >= k))
                    .count()
            };
            for start in starts {
                let _ = write!(s, " {} |", count(Some(start)));
            }
            let _ = write!(s, " {} |", count(None));
        }
        s.push('\n');
    }
    let _ = write!(
        s,
        "\n### Per problem\n\nLRE of the final parameters from start 1 / start 2 (the smallest over the parameters, capped at 11; 0 when no digit agrees); **bold** at 4 digits or more, `-` where the solver did not run.\n\n| problem | difficulty | n | m | {} |\n|---|---|---|---|{}\n",
        a.solvers.join(" | "),
        "---|".repeat(a.solvers.len())
    );
    let mut problems: Vec<&String> = a.instances.iter().map(|k| &k.1).collect();
    problems.dedup();
    for problem in problems {
        let rows: Vec<usize> = (0..a.instances.len())
            .filter(|&p| &a.instances[p].1 == problem)
            .collect();
        let Some(&first) = rows.first() else { continue };
        let m = a.runs[first].iter().flatten().map(|r| r.m).next().unwrap_or(0);
        let _ = write!(
            s,
            "| {problem} | {} | {} | {m} |",
            difficulty.get(problem).map_or("?", String::as_str),
            a.n[first]
        );
        for col in 0..a.solvers.len() {
            let cells: Vec<String> = starts
                .iter()
                .map(|start| {
                    rows.iter()
                        .find(|&&p| a.instances[p].2 == *start)
                        .and_then(|&p| a.lre(p, col))
                        .map_or("-".into(), |l| {
                            if l >= crate::nist::HEADLINE_DIGITS {
                                format!("**{l:.1}**")
                            } else {
                                format!("{l:.1}")
                            }
                        })
                })
                .collect();
            let _ = write!(s, " {} |", cells.join(" / "));
        }
        s.push('\n');
    }
    s
}

/// A short form of a status for the tables.
fn status_word(status: &str) -> String {
    let word = status.split([':', ' ', '(']).next().unwrap_or(status);
    word.chars().take(20).collect()
}

/// Each solver's count of instances solved at the minimum (the MGH set)
/// and at both taus, and the share of its profile at ratio 1 (best) by
/// time and evaluations; degenerate instances are not counted.
pub fn solvers_markdown(a: &Analysis) -> String {
    let all: Vec<usize> = (0..a.solvers.len()).collect();
    let [loose, strict] = a.taus();
    let minimum = a.has_references();
    // on a set judged by f* (MGH), the runs whose final f reaches it to 4
    // and 6 digits (minima::digits) besides the headline's 8
    let by_digits = minimum && a.references.iter().flatten().all(|r| r.certified.is_none());
    let digit_columns: String = if by_digits {
        minima::REPORTED_DIGITS
            .iter()
            .map(|k| format!(" f to {k} digits |"))
            .collect()
    } else {
        String::new()
    };
    let mut s = format!(
        "| solver | derivative-free | runs |{}{digit_columns} solved (tau {loose:e}) | solved (tau {strict:e}) | fastest of ours (tau {strict:e}) | fewest evaluations (tau {strict:e}) |\n|---|---|---|{}{}---|---|---|---|\n",
        if minimum { " at the minimum |" } else { "" },
        if minimum { "---|" } else { "" },
        if by_digits {
            "---|".repeat(minima::REPORTED_DIGITS.len())
        } else {
            String::new()
        },
    );
    // times only among our (compiled) solvers: the outside ones run from Python
    let (time, _) = a.performance(strict, &a.our_columns());
    let (_, evals) = a.performance(strict, &all);
    let counted: Vec<usize> = (0..a.instances.len()).filter(|&p| a.degenerate(p).is_none()).collect();
    for (col, name) in a.solvers.iter().enumerate() {
        let runs = counted.iter().filter(|&&p| a.runs[p][col].is_some()).count();
        let solved = |c: Criterion| {
            counted
                .iter()
                .filter(|&&p| a.judge(p, col, c).is_some_and(|o| o.solved))
                .count()
        };
        let best = |profiles: &[Profile]| profiles.get(col).map_or(0.0, |p| p.at(1.0));
        let fastest = if col < a.ours {
            format!("{:.0}%", 100.0 * best(&time))
        } else {
            "-".to_string()
        };
        let digits: String = if by_digits {
            minima::REPORTED_DIGITS
                .iter()
                .map(|&k| {
                    let n = counted
                        .iter()
                        .filter(|&&p| {
                            let f_star = a.references[p].as_ref().map(|r| r.f_star);
                            a.runs[p][col]
                                .as_ref()
                                .zip(f_star)
                                .is_some_and(|(r, f_star)| minima::digits(r.f, f_star) >= k)
                        })
                        .count();
                    format!(" {n} |")
                })
                .collect()
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "| {name} | {} | {runs} |{}{digits} {} | {} | {fastest} | {:.0}% |",
            if a.derivative_free[col] { "yes" } else { "no" },
            if minimum {
                format!(" {} |", solved(Criterion::AtMinimum))
            } else {
                String::new()
            },
            solved(Criterion::Tau(loose)),
            solved(Criterion::Tau(strict)),
            100.0 * best(&evals),
        );
    }
    s
}

/// What the runner recomputed from the records (f(x0) from the start, f
/// at the stored final point) and where a record disagreed, as Markdown.
pub fn checks_markdown(a: &Analysis) -> String {
    let mut s = String::new();
    let runs = a.runs.iter().flatten().flatten().count();
    let with_x = a.runs.iter().flatten().flatten().filter(|r| r.x.is_some()).count();
    let _ = write!(
        s,
        "\n### Checks\n\nThe runner computed f(x0) of every run from its instance's start, and f at the final x stored in {with_x} of the {runs} runs (the others are judged by their own f). Differences from the records (beyond 1e-9 relative): {}.\n",
        if a.discrepancies.is_empty() {
            "none".to_string()
        } else {
            a.discrepancies.len().to_string()
        }
    );
    for d in &a.discrepancies {
        let _ = writeln!(s, "- {} on {} from {} x0: {}", d.solver, d.problem, d.scale, d.what);
    }
    s
}

/// The best-known minima by problem, with sources, the degenerate
/// instances, and what the runner did not reproduce from the records, as
/// Markdown (the MGH set).
pub fn references_markdown(a: &Analysis) -> String {
    let mut s = String::from("| problem | n | f* | source |\n|---|---|---|---|\n");
    let mut seen = Vec::new();
    for (p, key) in a.instances.iter().enumerate() {
        let Some(r) = &a.references[p] else { continue };
        if seen.contains(&key.1) {
            continue;
        }
        seen.push(key.1.clone());
        let _ = writeln!(s, "| {} | {} | {:e} | {} |", key.1, a.n[p], r.f_star, r.source);
    }
    let degenerate: Vec<String> = (0..a.instances.len())
        .filter_map(|p| {
            Some(format!(
                "- {} from {} x0: {}",
                a.instances[p].1,
                a.instances[p].2,
                a.degenerate(p)?
            ))
        })
        .collect();
    let _ = write!(
        s,
        "\n### Degenerate instances ({}, left out of every count and profile)\n\n{}\n",
        degenerate.len(),
        degenerate.join("\n")
    );
    s.push_str(&checks_markdown(a));
    let below: Vec<String> = a
        .instances
        .iter()
        .enumerate()
        .flat_map(|(p, key)| {
            let f_star = a.references[p].as_ref().map(|r| r.f_star);
            a.runs[p].iter().flatten().filter_map(move |r| {
                let f_star = f_star?;
                (r.f < f_star - crate::minima::tolerance(f_star)).then(|| {
                    format!(
                        "- {} on {} from {} x0: f = {:e} < f* = {f_star:e}",
                        r.solver, key.1, key.2, r.f
                    )
                })
            })
        })
        .collect();
    let _ = writeln!(
        s,
        "\nRuns below a best-known minimum by more than the tolerance (the table would need a new value): {}.",
        if below.is_empty() {
            "none".to_string()
        } else {
            format!("{}\n{}", below.len(), below.join("\n"))
        }
    );
    s
}

#[cfg(test)]
mod tests {
    /// Issue 37, case 8, as issue 51 revised it: a symlinked README is
    /// never written through (a link planted among the outputs could point
    /// anywhere, a device included): the write is refused naming the link,
    /// and the link, its target (mode included) and a `README.tmp` beside
    /// it are left as they were; a regular file keeps its mode.
    #[cfg(unix)]
    #[test]
    fn write_refuses_a_symlink_and_keeps_modes_and_neighbours() {
        use std::os::unix::fs::PermissionsExt;
        let scratch = store::ScratchDir::new("bench-write").expect("scratch dir");
        let dir = scratch.path();
        let target = dir.join("real.md");
        std::fs::write(&target, "old").expect("write");
        std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o600)).expect("mode");
        std::os::unix::fs::symlink(&target, dir.join("README.md")).expect("link");
        std::fs::write(dir.join("README.tmp"), "mine").expect("write");
        let e = write(&dir.join("README.md"), "new").expect_err("a link");
        assert!(e.to_string().contains("symbolic link"), "{e}");
        assert!(
            std::fs::symlink_metadata(dir.join("README.md"))
                .expect("link")
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read_to_string(&target).expect("target"), "old");
        write(&target, "new").expect("a regular file");
        assert_eq!(std::fs::read_to_string(&target).expect("target"), "new");
        assert_eq!(
            std::fs::metadata(&target).expect("meta").permissions().mode() & 0o777,
            0o600
        );
        assert_eq!(std::fs::read_to_string(dir.join("README.tmp")).expect("tmp"), "mine");
        assert_eq!(std::fs::read_dir(dir).expect("dir").count(), 3, "no temporary left");
    }

    use super::*;
    use crate::record::tests::run;

    fn analysis() -> Analysis {
        // instance p: gauss-newton solves in 0.5 s, 6 evals; lm in 1.0 s, 12
        // instance q: gauss-newton fails, lm solves
        let mut gp = run("gauss-newton", "p", 0.0, 6);
        gp.time_s = 0.5;
        let mut lp = run("scipy-lm", "p", 0.0, 12);
        lp.time_s = 1.0;
        let gq = run("gauss-newton", "q", 5.0, 6);
        let lq = run("scipy-lm", "q", 0.0, 8);
        Analysis::new(vec![gp, lp, gq, lq], &["gauss-newton".into()]).with_references(|_| {
            Some(crate::minima::Reference {
                f0: 10.0,
                f_star: 0.0,
                source: "exact".into(),
                degenerate: None,
                certified: None,
            })
        })
    }

    #[test]
    fn comparisons_and_goals_by_hand() {
        let a = analysis();
        let solved = solved_counts(&a, "gauss-newton", "scipy-lm", GOAL);
        assert_eq!(
            (solved.ours_value, solved.reference_value, solved.runs),
            (Some(1.0), Some(2.0), 4)
        );
        assert_eq!(solved.ratio, Some(0.5));
        let time = median_costs(&a, "gauss-newton", "scipy-lm", GOAL, true);
        assert_eq!((time.ratio, time.runs), (Some(0.5), 2));
        let evals = median_costs(&a, "gauss-newton", "scipy-lm", GOAL, false);
        assert_eq!((evals.ours_value, evals.reference_value), (Some(6.0), Some(12.0)));
        let g = goals(&a);
        assert_eq!(g[0].verdict, "not measured");
        assert_eq!(g[1].verdict, "not met");
        assert_eq!(summary(&a).len(), 10);
        let readme = format!("intro\n{README_START}old\n{README_END}\nrest\n");
        assert_eq!(
            with_readme_summary(&readme, "new\n").as_deref(),
            Some(format!("intro\n{README_START}new\n{README_END}\nrest\n").as_str())
        );
        // issue 37, case 8: a marker quoted in prose is not a marker
        let quoted = format!(
            "Run with `{}` lines.\nintro\n{README_START}old\n{README_END}\nrest\n",
            README_START.trim_end()
        );
        assert_eq!(
            with_readme_summary(&quoted, "new\n").as_deref(),
            Some(quoted.replace("old\n", "new\n").as_str())
        );
        assert_eq!(with_readme_summary(&format!("say `{README_END}`\n"), "x"), None);
        assert_eq!(
            with_readme_summary(&format!("{README_END}\n{README_START}"), "new\n"),
            None
        );
        let md = summary_markdown(
            &summary(&a),
            &Stamp {
                commit: "0123456789abcdef".into(),
                dirty: false,
                cores: 2,
                load_before: Some(0.5),
                load_after: None,
                date: "today".into(),
                runs: 4,
                repeats: 1,
                budget_simplex_gradients: 1,
                budget_time_s: 1.0,
                sources: vec![],
                elapsed_s: 0.0,
            },
        );
        assert!(
            md.contains("| 0.500 | 4 |") && md.contains("0123456789ab on 2 cores"),
            "{md}"
        );
        let csv = runs_csv(&a).expect("csv");
        assert_eq!(csv.lines().count(), 5);
        assert!(problems_markdown(&a).contains("**0.0000e0** (6)"));
        assert!(solvers_markdown(&a).contains("| scipy-lm | yes | 2 | 2 | 2 |"));
    }

    #[test]
    fn medians() {
        assert_eq!(median(vec![]), None);
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), Some(2.5));
    }

    #[test]
    fn values_and_ratios_as_text() {
        assert_eq!(num(Some(79.0), "instances"), "79");
        assert_eq!(num(Some(2.5e-5), "s"), "0.025 ms");
        assert_eq!(num(None, "s"), "-");
        assert_eq!(ratio_text(Some(0.81922)), "0.819");
        assert_eq!(ratio_text(Some(0.0029346)), "2.93e-3");
        assert_eq!(ratio_text(None), "-");
    }

    /// Issue 33's goal by hand: `powell` solves both instances at the
    /// minimum in 10 and 30 evaluations (median 20); each reference solves
    /// one, instance p, in `evals` (the median over instances both solve
    /// is then powell's 10 against it).
    #[test]
    fn the_issue_33_goal_compares_counts_and_medians_with_every_reference() {
        let with_refs = |evals: [u64; 4], drop: Option<&str>| {
            let mut runs = vec![run("powell", "p", 0.0, 10), run("powell", "q", 0.0, 30)];
            for (name, e) in ISSUE_33_REFERENCES.iter().zip(evals) {
                if Some(*name) == drop {
                    continue;
                }
                runs.push(run(name, "p", 0.0, e));
                runs.push(run(name, "q", 1.0, 5));
            }
            Analysis::new(runs, &["powell".into()]).with_references(|_| {
                Some(crate::minima::Reference {
                    f0: 10.0,
                    f_star: 0.0,
                    source: "test".into(),
                    degenerate: None,
                    certified: None,
                })
            })
        };
        let met = issue_33_goal(&with_refs([10, 11, 40, 12], None), "powell");
        assert_eq!(met.verdict, "met", "{met:?}");
        assert_eq!(met.evidence.len(), 8);
        assert_eq!(
            (met.evidence[0].ours_value, met.evidence[0].reference_value),
            (Some(2.0), Some(1.0))
        );
        assert_eq!(
            (met.evidence[1].ours_value, met.evidence[1].reference_value),
            (Some(10.0), Some(10.0))
        );
        // one reference needs fewer evaluations than powell's 10: not met
        assert_eq!(
            issue_33_goal(&with_refs([10, 9, 40, 12], None), "powell").verdict,
            "not met"
        );
        // a reference without records: not measured; ours without records too
        assert_eq!(
            issue_33_goal(&with_refs([10, 11, 40, 12], Some("pdfo-bobyqa")), "powell").verdict,
            "not measured"
        );
        assert_eq!(
            issue_33_goal(&with_refs([10, 11, 40, 12], None), "dfo-ls").verdict,
            "not measured"
        );
        // the table of references lists f* and its source
        let md = references_markdown(&with_refs([10, 11, 40, 12], None));
        assert!(
            md.contains("| p | 2 | 0e0 | test |") && md.contains("Degenerate instances (0"),
            "{md}"
        );
    }

    /// Issue 52's goal by hand: `trust-region` solves p and q (10 and 30
    /// evaluations), each reference solves p only, in `evals`.
    #[test]
    fn the_issue_52_goal_needs_one_solver_ahead_of_both_references() {
        let with = |evals: [u64; 2], ours_q: f64| {
            let mut runs = vec![run("trust-region", "p", 0.0, 10), run("trust-region", "q", ours_q, 30)];
            for (name, e) in ISSUE_52_REFERENCES.iter().zip(evals) {
                runs.push(run(name, "p", 0.0, e));
                runs.push(run(name, "q", 1.0, 5));
            }
            Analysis::new(runs, &["trust-region".into()]).with_references(|_| {
                Some(crate::minima::Reference {
                    f0: 10.0,
                    f_star: 0.0,
                    source: "test".into(),
                    degenerate: None,
                    certified: None,
                })
            })
        };
        let met = issue_52_goal(&with([10, 12], 0.0));
        assert_eq!(met.verdict, "met", "{met:?}");
        assert_eq!(met.evidence.len(), 4);
        // one reference needs fewer evaluations: not met
        assert_eq!(issue_52_goal(&with([9, 12], 0.0)).verdict, "not met");
        // a tie in instances solved is not strictly more
        assert_eq!(issue_52_goal(&with([10, 12], 1.0)).verdict, "not met");
    }
}
