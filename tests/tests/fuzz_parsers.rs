//! Fuzz targets for every parser a user feeds (issue 37, item 6): the TOML
//! configuration (`swingup --config`, a run's `config.toml`), the CSV
//! tables of `swingup fit` and `lwr-fit`, the saved `runs.jsonl` of a grid,
//! and the benchmark's `runs.json` and NIST data files.
//!
//! Each target is a [bolero](https://docs.rs/bolero) harness. Under
//! `cargo test` it runs a fixed number of random inputs ([`iterations`]
//! per target, a second or two each); the inputs are drawn afresh on every
//! run, and a failure prints the `BOLERO_RANDOM_SEED` that replays it.
//! Longer runs: `BOLERO_RANDOM_ITERATIONS=1000000 cargo test -p
//! integration-tests --test fuzz_parsers -- --test-threads 1` (the
//! variable replaces the count of every target; about 15 minutes). The
//! same targets are meant to run coverage-guided under `cargo bolero`
//! (libFuzzer or AFL, on nightly; not part of CI, and not tried here).
//!
//! Random bytes never get past a TOML or JSON parser, so most inputs are
//! mutations of valid files (the default configuration, the committed
//! `results/**/runs.jsonl` and `runs.json`, the test CSVs, NIST's files):
//! byte edits, cuts, copies and insertions of tokens each parser cares
//! about. Every crash found is kept as a plain regression test at the end
//! of this file.

use std::path::Path;
use std::sync::OnceLock;

use bolero::{TypeGenerator, check};
use swingup::config::{BasisKind, Config, Controller, Solver, Start};
use swingup::experiments::RunSummary;

mod fuzz;
use fuzz::{Edit, Input, Tally, apply, head, numbers, place, with_file};
use integration_tests::read_workspace_file as read;

/// Random inputs of each target under `cargo test`, about a second each
/// on a CI machine (two cores); `BOLERO_RANDOM_ITERATIONS` replaces them.
mod iterations {
    pub(crate) const CONFIG: usize = 5_000;
    pub(crate) const CSV: usize = 10_000;
    pub(crate) const RUNS_JSONL: usize = 15_000;
    pub(crate) const TORN_TAIL: usize = 5_000;
    pub(crate) const RUNS_JSON: usize = 20_000;
    pub(crate) const NIST: usize = 20_000;
    pub(crate) const CARTPOLE_TRIAL: usize = 3_000;
}

// ---------------------------------------------------------------------------
// TOML configuration

/// Each line of the default configuration, as a token (keys a mutation
/// can repeat or move), and values that test the checks' edges.
const CONFIG_TOKENS: &[&str] = &[
    "-1.0",
    "0.0",
    "1e-9",
    "1e9",
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "-0.0",
    "1e-320",
    "1e308",
    "1e309",
    "4000000000",
    "9223372036854775807",
    "18446744073709551615",
    "true",
    "\"",
    "'''",
    "[",
    "]",
    "{ }",
    "=",
    ",",
    "\n",
    "#",
    "1_000",
    "0x10",
    "1979-05-27",
    "[robot]\n",
    "[human]\n",
    "[human_swingup]\n",
    "[planner]\n",
    "[model]\n",
    "[mpc]\n",
    "\"mpc\"",
    "\"scratch\"",
    "\"powell\"",
    "\"ddp\"",
    "\"derivative-free\"",
    "\"wavelet\"",
    "\"quadratic\"",
    "\"gaussian\"",
    "\"lwr\"",
    "\"true\"",
    "\"constant\"",
];

/// Configurations to mutate: the defaults as `swingup config` prints them,
/// the defaults with every choice switched, and partial files.
fn config_seeds() -> &'static [Vec<u8>] {
    static SEEDS: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    SEEDS.get_or_init(|| {
        let default = Config::default();
        let mut switched = default.clone();
        switched.controller = Controller::Mpc;
        switched.start = Start::Scratch;
        switched.planner.solver = Solver::Powell;
        switched.planner.basis = BasisKind::Wavelet;
        switched.model.select_inputs = true;
        switched.robot.lag = 0.05;
        let mut ddp = default.clone();
        ddp.planner.solver = Solver::Ddp;
        ddp.max_trials = 2;
        [
            toml::to_string(&default).expect("the defaults serialise"),
            toml::to_string(&switched).expect("serialises"),
            toml::to_string(&ddp).expect("serialises"),
            String::new(),
            "seed = 3\nmax_trials = 2\nhorizon = 120\nbalance = 120\n".into(),
            "[planner]\nlambda = 10.0\nsolver = \"gauss-newton\"\n[model]\nkind = \"lwr\"\n".into(),
        ]
        .into_iter()
        .map(String::into_bytes)
        .collect()
    })
}

fn config_tokens() -> &'static [&'static [u8]] {
    static TOKENS: OnceLock<Vec<&'static [u8]>> = OnceLock::new();
    TOKENS.get_or_init(|| {
        let default: &'static str = Box::leak(
            toml::to_string(&Config::default())
                .expect("the defaults serialise")
                .into_boxed_str(),
        );
        CONFIG_TOKENS
            .iter()
            .map(|t| t.as_bytes())
            .chain(default.split_inclusive('\n').map(str::as_bytes))
            .collect()
    })
}

/// Samples a demonstration of this configuration simulates, and plant
/// steps of its robot's LQR design, at most: `Config::validate` does not
/// bound sizes yet (issue 37, item 3: `balance = 1000000000` aborts,
/// `substeps = 4000000000` hangs), so larger configurations are only
/// parsed and checked here.
const AFFORDABLE_STEPS: u64 = 2_000_000;

fn affordable(cfg: &Config) -> bool {
    let samples = cfg.horizon.saturating_add(cfg.balance);
    samples.saturating_mul(cfg.human.substeps) as u64 <= AFFORDABLE_STEPS
        && cfg.robot.substeps.saturating_mul(10) as u64 <= AFFORDABLE_STEPS
}

/// The property: parsing and checking never panic; a configuration that
/// passes its checks is written as `config.toml` and read back unchanged
/// (`--resume` does that), and the demonstration and the robot's catch,
/// which every run starts with, are made without a panic. Whether the
/// configuration passed its checks.
fn check_config(text: &str) -> bool {
    let Ok(cfg) = toml::from_str::<Config>(text) else {
        return false;
    };
    if cfg.validate().is_err() {
        return false;
    }
    let saved = toml::to_string(&cfg).expect("a checked configuration serialises");
    let back: Config =
        toml::from_str(&saved).unwrap_or_else(|e| panic!("config.toml does not read back: {e}\n{saved}"));
    assert_eq!(
        toml::to_string(&back).expect("serialises"),
        saved,
        "config.toml changes when read back"
    );
    if affordable(&cfg) {
        if let Ok(demo) = swingup::plant::demo::demonstration(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance)
        {
            assert_eq!(demo.controls.len(), cfg.horizon);
            assert_eq!(demo.states.len(), cfg.horizon + 1);
        }
        let _ = swingup::plant::basin::Catch::design(&cfg.robot, cfg.catch_spec(), &cfg.balance_test());
    }
    true
}

#[test]
fn fuzz_config_toml() {
    let (seeds, tokens) = (config_seeds(), config_tokens());
    // the seeds themselves are valid configurations
    for seed in seeds {
        let text = std::str::from_utf8(seed).expect("utf-8");
        let cfg: Config = toml::from_str(text).expect("a seed parses");
        cfg.validate().expect("a seed passes the checks");
    }
    let tally = Tally::default();
    check!()
        .with_type::<Input>()
        .with_iterations(iterations::CONFIG)
        .for_each(|input| tally.count(check_config(&String::from_utf8_lossy(&input.bytes(seeds, tokens)))));
    tally.assert_accepted("configurations", 0.1);
}

// ---------------------------------------------------------------------------
// CSV tables

const CSV_TOKENS: &[&str] = &[
    ",", "\n", "\r\n", "\r", "\"", "\"\"", " ", "\t", "\0", "#", "\u{feff}", "é", "nan", "NaN", "inf", "-inf",
    "infinity", "1e308", "1e309", "-0", "1e-400", "0x1", "+1", ".5", "5.", "1_0", "1e", "a", "y", "x,y\n", "1,2\n",
];

fn csv_seeds() -> &'static [Vec<u8>] {
    static SEEDS: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    SEEDS.get_or_init(|| {
        let plant = read("swingup/tests/data/plant_robot_lag.csv");
        // the golden trajectories without their comments and text column
        let plant_rows: String = plant
            .lines()
            .filter(|l| !l.starts_with('#'))
            .take(12)
            .filter_map(|l| l.split_once(','))
            .map(|(_, rest)| format!("{rest}\n"))
            .collect();
        [
            head(&read("lwr/tests/data/fit_demo.csv"), 16),
            plant_rows,
            head(&plant, 6),
            "a, b\r\n1,2\n\n 3 ,4e-1\n".into(),
            "\u{feff}\n  \n\"a\",b\n \n\"1\",2\n".into(),
            "x\n1\n2\n3\n".into(),
        ]
        .into_iter()
        .map(String::into_bytes)
        .collect()
    })
}

/// A table back as CSV: names quoted, numbers in Rust's shortest form
/// that reads back exactly.
fn to_csv(t: &lwr::csv_fit::Table) -> String {
    let mut out = String::new();
    let names: Vec<String> = t
        .names
        .iter()
        .map(|n| format!("\"{}\"", n.replace('"', "\"\"")))
        .collect();
    out.push_str(&names.join(","));
    out.push('\n');
    for row in &t.rows {
        let cells: Vec<String> = row.iter().map(|v| format!("{v:?}")).collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

/// The property: parsing never panics; a table read has distinct, nonempty
/// names, at least one row, every row as long as the header and of finite
/// numbers, lines in order after the header's; written back as CSV it
/// reads as the same table. Whether the text was a table.
fn check_table(text: &str) -> bool {
    let path = Path::new("fuzz.csv");
    let Ok(t) = lwr::csv_fit::Table::parse(text, path) else {
        return false;
    };
    assert!(!t.names.is_empty() && !t.rows.is_empty(), "{t:?}");
    for (j, name) in t.names.iter().enumerate() {
        assert!(
            !name.is_empty() && !t.names[..j].contains(name),
            "bad names {:?}",
            t.names
        );
    }
    for row in &t.rows {
        assert_eq!(row.len(), t.names.len(), "a ragged row in {t:?}");
        assert!(row.iter().all(|v| v.is_finite()), "a cell not finite in {row:?}");
    }
    assert_eq!(t.lines.len(), t.rows.len());
    assert!(
        t.lines.first().is_some_and(|&l| l > t.header_line) && t.lines.windows(2).all(|w| w[0] < w[1]),
        "lines out of order: header {} rows {:?}",
        t.header_line,
        t.lines
    );
    let again = lwr::csv_fit::Table::parse(&to_csv(&t), path).unwrap_or_else(|e| panic!("written back: {e}"));
    assert_eq!((&again.names, &again.rows), (&t.names, &t.rows), "written back");
    true
}

#[test]
fn fuzz_csv_table() {
    let seeds = csv_seeds();
    let tokens: Vec<&[u8]> = CSV_TOKENS.iter().map(|t| t.as_bytes()).collect();
    for seed in &seeds[..2] {
        let text = std::str::from_utf8(seed).expect("utf-8");
        lwr::csv_fit::Table::parse(text, Path::new("seed.csv")).expect("a seed parses");
    }
    let tally = Tally::default();
    check!()
        .with_type::<Input>()
        .with_iterations(iterations::CSV)
        .for_each(|input| {
            let bytes = input.bytes(seeds, &tokens);
            let accepted = match std::str::from_utf8(&bytes) {
                Ok(text) => check_table(text),
                // what `read` makes of a file that is not UTF-8: an error, no panic
                Err(_) => {
                    let read = with_file("table.csv", &bytes, lwr::csv_fit::Table::read);
                    assert!(read.is_err(), "not UTF-8, yet read");
                    check_table(&String::from_utf8_lossy(&bytes))
                }
            };
            tally.count(accepted);
        });
    tally.assert_accepted("tables", 0.1);
}

// ---------------------------------------------------------------------------
// Saved runs.jsonl

const JSON_TOKENS: &[&str] = &[
    "\n",
    "\r\n",
    " ",
    "null",
    "NaN",
    "1e309",
    "-1",
    "1.5",
    "18446744073709551616",
    "\"",
    "{",
    "}",
    "[",
    "]",
    "[]",
    ",",
    ":",
    "\"seed\":",
    "\"trials\":",
    "\"success_trial\":",
    "true",
    "\\u0000",
    "\\ud800",
    "\u{0}",
    "é",
];

/// Whole lines of the committed grids' `runs.jsonl` (the main grid, MPC's
/// and the derivative-free planner's), a few of each kind.
fn run_lines() -> &'static [String] {
    static LINES: OnceLock<Vec<String>> = OnceLock::new();
    LINES.get_or_init(|| {
        let mut lines = Vec::new();
        for file in [
            "results/runs.jsonl",
            "results/mpc/runs.jsonl",
            "results/derivative-free/runs.jsonl",
        ] {
            let text = read(file);
            // a spread over the file: its first lines and every 25th
            for (i, line) in text.lines().enumerate() {
                if i < 3 || i % 25 == 0 {
                    lines.push(format!("{line}\n"));
                }
            }
        }
        lines
    })
}

fn jsonl_seeds() -> &'static [Vec<u8>] {
    static SEEDS: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    SEEDS.get_or_init(|| {
        let lines = run_lines();
        let mut seeds: Vec<Vec<u8>> = lines.iter().map(|l| l.clone().into_bytes()).collect();
        seeds.push(lines[..3].concat().into_bytes());
        seeds.push(format!("{}\n{}", lines[0], lines[1]).into_bytes());
        seeds
    })
}

/// A log read back: never a panic; the records it keeps write back as the
/// same records.
fn check_log(bytes: &[u8]) -> Option<store::LogContents<RunSummary>> {
    let contents = with_file("runs.jsonl", bytes, store::read_log::<RunSummary>).ok()?;
    assert!(contents.whole_len <= bytes.len() as u64);
    for r in &contents.records {
        let line = serde_json::to_string(r).expect("a record serialises");
        let back: RunSummary = serde_json::from_str(&line).expect("a record reads back");
        assert_eq!(serde_json::to_string(&back).expect("serialises"), line);
    }
    Some(contents)
}

#[test]
fn fuzz_runs_jsonl() {
    let seeds = jsonl_seeds();
    let tokens: Vec<&[u8]> = JSON_TOKENS.iter().map(|t| t.as_bytes()).collect();
    let tally = Tally::default();
    check!()
        .with_type::<Input>()
        .with_iterations(iterations::RUNS_JSONL)
        .for_each(|input| tally.count(check_log(&input.bytes(seeds, &tokens)).is_some()));
    tally.assert_accepted("logs", 0.1);
}

/// A log as a crash leaves it: whole records, then a torn last one.
#[derive(Debug, Clone, TypeGenerator)]
struct TornLog {
    /// The whole records (indices into the seed lines), blank lines between some.
    #[generator(bolero::generator::produce::<Vec<(u8, bool)>>().with().len(0usize..=8))]
    records: Vec<(u8, bool)>,
    /// The torn tail: a record cut at a fraction of its length...
    cut: Option<(u8, u16)>,
    /// ...or bytes (newlines dropped), when `cut` is `None`.
    #[generator(bolero::generator::produce::<Vec<u8>>().with().len(0usize..=48))]
    tail: Vec<u8>,
}

/// The property of a torn tail: every whole record before it is read, in
/// order, and the tail is reported, never an error for the whole log.
#[test]
fn fuzz_runs_jsonl_torn_tail() {
    let lines = run_lines();
    check!()
        .with_type::<TornLog>()
        .with_iterations(iterations::TORN_TAIL)
        .for_each(|log| {
            let mut bytes = Vec::new();
            let mut expected = Vec::new();
            for &(i, blank) in &log.records {
                let line = &lines[usize::from(i) % lines.len()];
                bytes.extend_from_slice(line.as_bytes());
                if blank {
                    bytes.extend_from_slice(b" \n");
                }
                expected.push(serde_json::from_str::<RunSummary>(line).expect("a seed line parses"));
            }
            let whole = bytes.len() as u64;
            let tail: Vec<u8> = match log.cut {
                Some((i, at)) => {
                    let line = lines[usize::from(i) % lines.len()].trim_end().as_bytes();
                    line[..place(at, line.len())].to_vec()
                }
                None => log.tail.iter().copied().filter(|&b| b != b'\n').collect(),
            };
            bytes.extend_from_slice(&tail);
            let contents = check_log(&bytes).unwrap_or_else(|| panic!("a torn tail fails the whole log: {tail:?}"));
            assert_eq!(contents.records, expected, "the whole records");
            assert_eq!(contents.whole_len, whole);
            assert_eq!(contents.torn.is_some(), !tail.is_empty(), "torn tail {tail:?}");
        });
}

// ---------------------------------------------------------------------------
// The benchmark's runs.json and NIST's files

const BENCH_TOKENS: &[&str] = &[
    "null",
    "NaN",
    "1e309",
    "-1",
    "0",
    "1.5",
    "18446744073709551616",
    "\"",
    "{",
    "}",
    "[",
    "]",
    "[]",
    ",",
    ":",
    "\"nprl-bench/1\"",
    "\"f0\":null,",
    "\"x0\":[1.0],",
    "\"trace\":[],",
    "[[5,1e300],[4,2.0]]",
    "\"n\":0,",
    "\"objective\":1.0,",
    "true",
    "\\u0000",
    "\n",
];

/// Small record files made of a few runs of each committed `runs.json`
/// (the whole files are megabytes: too slow to parse thousands of times).
fn bench_seeds() -> &'static [Vec<u8>] {
    static SEEDS: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    SEEDS.get_or_init(|| {
        let mut seeds = Vec::new();
        for file in [
            "results/benchmarks/runs.json",
            "results/benchmarks/nist/runs.json",
            "results/benchmarks/trajectory/runs.json",
        ] {
            let text = read(file);
            let all = bench::record::RecordFile::parse(&text, Path::new(file)).expect("a committed file parses");
            // a few runs, and one whose start overflowed (f0 null) if any
            let mut runs: Vec<_> = all.runs.iter().take(2).cloned().collect();
            runs.extend(all.runs.iter().find(|r| r.f0.is_nan()).cloned());
            let small = bench::record::RecordFile::new(all.source.clone(), runs);
            seeds.push(serde_json::to_vec(&small).expect("serialises"));
            seeds.push(serde_json::to_vec_pretty(&small).expect("serialises"));
        }
        seeds
    })
}

/// The property: parsing never panics; a file that parses writes back
/// (as `RecordFile::save` does) to one that parses to the same runs.
/// Whether the text was a record file.
fn check_records(text: &str) -> bool {
    let path = Path::new("runs.json");
    let Ok(file) = bench::record::RecordFile::parse(text, path) else {
        return false;
    };
    assert_eq!(file.format, bench::record::FORMAT);
    let saved = serde_json::to_string(&file).expect("serialises");
    let back = bench::record::RecordFile::parse(&saved, path).unwrap_or_else(|e| panic!("written back: {e}"));
    assert_eq!(serde_json::to_string(&back).expect("serialises"), saved, "written back");
    // issue 51: a run of its first record, by the same code, merges into
    // it (never a panic): every key kept, the first run's replaced
    if let Some(first) = file.runs.first() {
        let new = bench::record::RecordFile {
            runs: vec![first.clone()],
            ..file.clone()
        };
        let keys = |f: &bench::record::RecordFile| {
            f.runs
                .iter()
                .map(bench::record::RunRecord::key)
                .collect::<std::collections::BTreeSet<_>>()
        };
        match bench::runner::merge_runs(Some(file.clone()), new, path, false) {
            Ok(merged) => assert_eq!(keys(&merged.file), keys(&file)),
            Err(e) => assert!(file.made_by.is_none() && e.to_string().contains("would mix"), "{e}"),
        }
    }
    true
}

#[test]
fn fuzz_bench_runs_json() {
    let seeds = bench_seeds();
    let tokens: Vec<&[u8]> = BENCH_TOKENS.iter().map(|t| t.as_bytes()).collect();
    let tally = Tally::default();
    check!()
        .with_type::<Input>()
        .with_iterations(iterations::RUNS_JSON)
        .for_each(|input| tally.count(check_records(&String::from_utf8_lossy(&input.bytes(seeds, &tokens)))));
    tally.assert_accepted("record files", 0.1);
}

const NIST_TOKENS: &[&str] = &[
    "\n",
    " ",
    "\r",
    "Level of Difficulty",
    "Lower",
    "Higher",
    "Residual Sum of Squares:",
    "Number of Observations:",
    "Data: y",
    "b1 = ",
    "b2 = ",
    "b9 = ",
    "nan",
    "inf",
    "1e309",
    "-1",
    "0",
    "1e-320",
    "18446744073709551616",
];

/// NIST's files of a few problems (the small ones; one per model shape).
const NIST_FILES: &[&str] = &[
    "Misra1a", "BoxBOD", "Nelson", "MGH09", "Rat42", "DanWood", "Eckerle4", "Bennett5",
];

/// The property: parsing never panics; a problem read has as many
/// observations as its header says, each with the model's predictors,
/// and the model's number of parameters, all finite. Whether the text
/// was the problem's file.
fn check_nist(name: &str, text: &str) -> bool {
    let Ok(p) = bench::nist::parse(name, text) else {
        return false;
    };
    assert_eq!(p.x.len(), p.y.len());
    assert!(p.x.iter().all(|x| x.len() == p.model.predictors()));
    assert_eq!(p.n(), p.model.n());
    for v in [&p.starts[0], &p.starts[1], &p.standard_deviations] {
        assert_eq!(v.len(), p.n());
    }
    let finite = |v: &[f64]| v.iter().all(|v| v.is_finite());
    assert!(finite(&p.y) && p.x.iter().all(|x| finite(x)) && finite(&p.certified) && p.certified_rss.is_finite());
    true
}

#[test]
fn fuzz_nist_data() {
    let seeds: Vec<Vec<u8>> = NIST_FILES
        .iter()
        .map(|name| read(&format!("bench/data/nist/{name}.dat")).into_bytes())
        .collect();
    let tokens: Vec<&[u8]> = NIST_TOKENS.iter().map(|t| t.as_bytes()).collect();
    let tally = Tally::default();
    check!()
        .with_type::<(u8, Input)>()
        .with_iterations(iterations::NIST)
        .for_each(|(which, input)| {
            // the name of the file the seed came from, or of another problem
            let name = match input.seed_index(NIST_FILES.len()) {
                Some(i) if which % 4 != 0 => NIST_FILES[i],
                _ => NIST_FILES[usize::from(*which) % NIST_FILES.len()],
            };
            tally.count(check_nist(
                name,
                &String::from_utf8_lossy(&input.bytes(&seeds, &tokens)),
            ));
        });
    tally.assert_accepted("NIST files", 0.1);
}

// ---------------------------------------------------------------------------
// Crashes found, kept

/// The mutator itself: edits land inside the buffer whatever its length.
#[test]
fn edits_stay_in_bounds() {
    let tokens: &[&[u8]] = &[b"tok"];
    for len in [0usize, 1, 7] {
        for at in [0, 1, u16::MAX / 2, u16::MAX] {
            assert!(place(at, len) <= len);
            for edit in [
                Edit::Byte { at, byte: b'x' },
                Edit::Delete { at, len: 255 },
                Edit::Overwrite { at, len: 3, token: 0 },
                Edit::Copy {
                    from: at,
                    len: 9,
                    to: u16::MAX - at,
                },
                Edit::Truncate { at },
            ] {
                let mut buf = vec![b'a'; len];
                apply(&mut buf, &edit, tokens);
                assert!(buf.len() <= len + 9, "{edit:?}");
            }
        }
    }
    let mut buf = b"ab".to_vec();
    apply(&mut buf, &Edit::Token { at: u16::MAX, token: 0 }, tokens);
    assert_eq!(buf, b"abtok");
    apply(&mut buf, &Edit::Truncate { at: 0 }, tokens);
    assert!(buf.is_empty());
    let mut buf = b"x = 1.5e-3, y = -2, name = e".to_vec();
    assert_eq!(numbers(&buf), [(4, 10), (16, 18)]);
    apply(&mut buf, &Edit::Number { nth: 3, token: 0 }, tokens);
    assert_eq!(buf, b"x = 1.5e-3, y = tok, name = e");
}

/// `a\r1\r2\r`: a lone carriage return ends a record, and the rows of
/// such a file were all said to be on line 1 (fixed in
/// `lwr::csv_fit::table`); each row is on its own line.
#[test]
fn csv_lone_carriage_returns_end_lines() {
    let t = lwr::csv_fit::Table::parse("a\r1\r2\r", Path::new("mac.csv")).expect("valid");
    assert_eq!((t.header_line, t.lines.as_slice()), (1, [2, 3].as_slice()));
    assert!(check_table("a\r1\r2\r"));
}

/// `horizon = 18446744073709551615` (or `[mpc] window = ...`) made
/// `Config::validate` panic on an overflow (`horizon + 1`) in debug builds;
/// in release builds it wraps and refuses the configuration with a wrong
/// reason; refused since the size checks come first.
#[test]
fn a_config_at_usize_max_is_refused_without_a_panic() {
    for text in [
        "horizon = 18446744073709551615\n",
        "[mpc]\nwindow = 18446744073709551615\n",
    ] {
        let cfg: Config = toml::from_str(text).expect("TOML reads the largest u64");
        let checked = std::panic::catch_unwind(|| cfg.validate());
        assert!(checked.is_ok_and(|r| r.is_err()), "{text}: not refused, or a panic");
    }
}

/// `[human_swingup] max_command = -inf` (or any negative or NaN value) in
/// an otherwise default configuration passed `Config::validate`, and the
/// demonstration panicked ("min > max, or either was NaN"); refused since
/// `Config::validate` checks `human_swingup`.
#[test]
fn a_negative_max_command_is_refused() {
    for value in ["-inf", "-1.0", "nan"] {
        let text = toml::to_string(&Config::default())
            .expect("the defaults serialise")
            .replace("max_command = 12.0", &format!("max_command = {value}"));
        let cfg: Config = toml::from_str(&text).expect("parses");
        assert!(cfg.validate().is_err(), "max_command = {value} passes the checks");
    }
}

// ---------------------------------------------------------------------------
// The cart-pole's trial files (issue 51: saved as each trial ends, read
// back by `learn --task cartpole --resume`)

/// The quick cart-pole settings the seeds were made with.
fn quick_cartpole() -> swingup::cartpole::CartPoleSettings {
    swingup::cartpole::CartPoleSettings {
        max_trials: 1,
        stop_at_success: false,
        ..swingup::cartpole::CartPoleSettings::quick()
    }
}

/// The two trials of a quick run (seed 3): the random one and an MPC one,
/// as `trial_NN.json` holds them.
fn cartpole_trials() -> &'static [swingup::cartpole::CartPoleTrial] {
    static TRIALS: OnceLock<Vec<swingup::cartpole::CartPoleTrial>> = OnceLock::new();
    TRIALS.get_or_init(|| {
        swingup::cartpole::run(&quick_cartpole(), 3)
            .expect("a quick run")
            .trials
    })
}

fn cartpole_seeds() -> &'static [Vec<u8>] {
    static SEEDS: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    SEEDS.get_or_init(|| {
        cartpole_trials()
            .iter()
            .map(|t| serde_json::to_vec_pretty(t).expect("serialises"))
            .collect()
    })
}

/// The property: a trial file read back never panics, and one that parses
/// either replays as the run's trial of its number (after the run's
/// trials before it) or is refused naming that trial; the unedited seeds
/// replay. Whether the bytes were a trial.
fn check_cartpole_trial(bytes: &[u8]) -> bool {
    let Ok(trial) = serde_json::from_slice::<swingup::cartpole::CartPoleTrial>(bytes) else {
        return false;
    };
    let saved = cartpole_trials();
    let unedited = saved
        .iter()
        .any(|t| serde_json::to_vec_pretty(t).expect("serialises") == bytes);
    let n = trial.trial;
    let mut previous: Vec<_> = saved
        .iter()
        .take(n.saturating_sub(1).min(saved.len()))
        .cloned()
        .collect();
    previous.push(trial);
    match swingup::cartpole::replay_trials(&quick_cartpole(), 3, &previous) {
        Ok(transitions) => assert_eq!(transitions, previous.len() * 15),
        Err(e) => {
            assert!(!unedited, "an unedited trial does not replay: {e}");
            let e = e.to_string();
            assert!(
                e.contains("does not replay") || e.contains("saved trials, more than"),
                "{e}"
            );
        }
    }
    true
}

#[test]
fn fuzz_cartpole_trial_json() {
    let seeds = cartpole_seeds();
    let tokens: Vec<&[u8]> = JSON_TOKENS.iter().map(|t| t.as_bytes()).collect();
    let tally = Tally::default();
    check!()
        .with_type::<Input>()
        .with_iterations(iterations::CARTPOLE_TRIAL)
        .for_each(|input| tally.count(check_cartpole_trial(&input.bytes(seeds, &tokens))));
    tally.assert_accepted("trial files", 0.1);
    for seed in seeds {
        assert!(check_cartpole_trial(seed));
    }
}
