//! The CSV fit tool (`lwr-fit`, `swingup fit`) on CSV files: a fit with an
//! irrelevant input, the predictions file, and errors naming the file, row
//! and column for bad files.

use std::fs;
use std::path::PathBuf;

use clap::Parser;
use lwr::csv_fit::{
    DegreeArg, FitArgs, FitError, FitReport, KernelArg, error_chain, fit_command, fit_report, fit_report_with,
    write_atomic,
};
use lwr::strategies::uniform;

/// A temporary directory, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        let dir = std::env::temp_dir().join(format!("lwr-fit-{tag}-{}-{nanos}", std::process::id()));
        fs::create_dir_all(&dir).expect("create temp dir");
        Self(dir)
    }

    fn write(&self, name: &str, text: &str) -> PathBuf {
        let path = self.0.join(name);
        fs::write(&path, text).expect("write temp file");
        path
    }

    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

/// `a,b,c,y,z` with y = sin(3a) + 0.5 b + noise, z = cos(2b) + noise; c is
/// irrelevant to both.
fn data(n: usize, seed: u64) -> String {
    let mut rand = uniform(seed);
    let mut text = String::from("a,b,c,y,z\n");
    for _ in 0..n {
        let (a, b, c) = (rand(), rand(), rand());
        let y = (3.0 * a).sin() + 0.5 * b + 0.05 * rand();
        let z = (2.0 * b).cos() + 0.05 * rand();
        text.push_str(&format!("{a},{b},{c},{y},{z}\n"));
    }
    text
}

fn scale_of(report: &FitReport, name: &str) -> f64 {
    report
        .inputs
        .iter()
        .find(|i| i.name == name)
        .map(|i| i.scale)
        .expect("input present")
}

#[test]
fn fits_tunes_and_predicts_with_an_irrelevant_input() {
    let dir = TempDir::new("good");
    let train = dir.write("train.csv", &data(400, 1));
    let test = dir.write("test.csv", &data(150, 2));
    let out = dir.path("pred.csv");
    let mut args = FitArgs::new(&train, &["y", "z"]);
    args.test = Some(test.clone());
    args.out = Some(out.clone());

    let report = fit_report(&args).expect("fit succeeds");
    assert_eq!(report.n_train, 400);
    let names: Vec<&str> = report.inputs.iter().map(|i| i.name.as_str()).collect();
    assert_eq!(names, ["a", "b", "c"]);
    assert!(report.loo_nmse < 0.05, "LOO nMSE {}", report.loo_nmse);
    assert!(report.loo_nmse <= report.initial_loo_nmse);
    assert!(report.bandwidth > 0.0);
    // c matters for neither target: the tuned metric drops it
    let c = scale_of(&report, "c");
    assert!(
        c < 0.05 * scale_of(&report, "a").max(scale_of(&report, "b")),
        "scale of c {c}"
    );
    assert!(scale_of(&report, "a") > 0.0);

    let t = report.test.as_ref().expect("test report");
    assert_eq!((t.n_rows, t.n_predicted), (150, 150));
    assert!(t.unpredicted.is_empty());
    let nmse = t.nmse.expect("test has targets");
    assert!(nmse < 0.02, "test nMSE {nmse}");
    for e in &t.targets {
        assert!(e.nmse < 0.03, "{}: {}", e.name, e.nmse);
        assert!(e.coverage > 0.85, "{}: coverage {}", e.name, e.coverage);
    }

    let text = fs::read_to_string(&out).expect("prediction file");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("y_pred,y_std,y_lo,y_hi,z_pred,z_std,z_lo,z_hi"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|c| c.parse::<f64>().expect("number")).collect())
        .collect();
    assert_eq!(rows.len(), 150);
    let mut no_noise_estimate = 0;
    for r in &rows {
        assert_eq!(r.len(), 8);
        for k in [0, 4] {
            let (pred, std, lo, hi) = (r[k], r[k + 1], r[k + 2], r[k + 3]);
            assert!(pred.is_finite());
            if std.is_nan() {
                // a fit without degrees of freedom for the noise: no interval
                assert!(lo == f64::NEG_INFINITY && hi == f64::INFINITY, "{lo} {hi}");
                no_noise_estimate += 1;
                continue;
            }
            assert!(std > 0.0 && std < 0.2, "std {std}");
            assert!(lo < pred && pred < hi, "{lo} {pred} {hi}");
            // the prediction interval is wider than the mean's standard error
            assert!(hi - pred > 1.96 * std);
        }
    }
    assert!(
        no_noise_estimate <= 6,
        "{no_noise_estimate} predictions without a noise estimate"
    );
    assert_eq!(report.out_file.as_deref(), Some(out.as_path()));

    // the printing command works in both formats
    fit_command(&args).expect("text summary");
    args.json = true;
    args.out = None;
    fit_command(&args).expect("json summary");
    let json = serde_json::to_value(&report).expect("serialisable");
    assert_eq!(json["inputs"][2]["name"], "c");
    assert!(report.to_string().contains("LOO normalised MSE"));
}

#[test]
fn a_test_file_without_targets_predicts_only() {
    let dir = TempDir::new("notarget");
    let train = dir.write("train.csv", &data(200, 3));
    let test = dir.write("test.csv", "c,a,b\n0.1,0.2,0.3\n0,0,0\n");
    let out = dir.path("pred.csv");
    let mut args = FitArgs::new(&train, &["y", "z"]);
    args.test = Some(test);
    args.out = Some(out.clone());
    args.tune_evals = 40;
    let report = fit_report(&args).expect("fit succeeds");
    let t = report.test.expect("test report");
    assert_eq!(t.nmse, None);
    assert!(t.targets.is_empty());
    let text = fs::read_to_string(&out).expect("prediction file");
    assert_eq!(text.lines().count(), 3);
    // columns are matched by name, not position
    let first: f64 = text
        .lines()
        .nth(1)
        .and_then(|l| l.split(',').next())
        .and_then(|c| c.parse().ok())
        .expect("number");
    assert!((first - ((0.6f64).sin() + 0.15)).abs() < 0.1, "{first}");
}

/// Runs the command on a bad training file and returns the error message.
fn train_error(name: &str, text: &str) -> (String, bool) {
    let dir = TempDir::new(name);
    let train = dir.write(&format!("{name}.csv"), text);
    let err = fit_report(&FitArgs::new(&train, &["y"])).expect_err("bad file");
    // a bad file is refused before any model is built
    let typed = !matches!(err, FitError::Model { .. } | FitError::Write { .. });
    let msg = error_chain(&err);
    assert!(msg.contains(&format!("{name}.csv")), "file not named: {msg}");
    (msg, typed)
}

#[test]
fn bad_training_files_name_row_and_column() {
    // each bad file, and what the message must say about it
    let cases: [(&str, &str, &[&str]); 10] = [
        (
            "missing_target",
            "a,b,c\n1,2,3\n4,5,6\n",
            &["header (line 1)", "no column 'y'"],
        ),
        (
            "non_numeric",
            "a,b,y\n1,2,3\n4,5,6\n7,abc,9\n",
            &["line 4 (data row 3), column 2 'b'", "'abc'"],
        ),
        (
            "nan_cell",
            "a,b,y\n1,2,3\n4,5,NaN\n",
            &["line 3 (data row 2), column 3 'y'", "not a finite"],
        ),
        (
            "empty_cell",
            "a,b,y\n1,,3\n",
            &["line 2 (data row 1), column 2 'b'", "empty cell"],
        ),
        ("empty", "", &["empty"]),
        ("header_only", "a,b,y\n", &["no data rows"]),
        (
            "ragged_short",
            "a,b,y\n1,2,3\n4,5\n",
            &["line 3 (data row 2)", "column 3 'y' is missing"],
        ),
        (
            "ragged_long",
            "a,b,y\n1,2,3,4\n",
            &["line 2 (data row 1)", "column 4 is extra"],
        ),
        (
            "constant",
            "a,b,y\n1,2,3\n1,5,6\n1,4,2\n1,3,3\n1,1,1\n",
            &["column 1 'a'", "constant"],
        ),
        ("only_targets", "y\n1\n2\n", &["input"]),
    ];
    for (name, text, wants) in cases {
        let (msg, typed) = train_error(name, text);
        assert!(typed, "{name}: {msg}");
        for want in wants {
            assert!(msg.contains(want), "{name}: want '{want}' in: {msg}");
        }
    }

    let dir = TempDir::new("missing");
    let err = fit_report(&FitArgs::new(dir.path("nope.csv"), &["y"])).expect_err("no file");
    assert!(matches!(err, FitError::Io { .. }), "{err:?}");
    assert!(error_chain(&err).contains("nope.csv"));
}

#[test]
fn bad_test_files_name_row_and_column() {
    let dir = TempDir::new("badtest");
    let train = dir.write("train.csv", &data(60, 4));
    let cases = [
        (
            "no_input.csv",
            "a,b\n0,0\n",
            vec!["header (line 1)", "no column 'c' (input)"],
        ),
        (
            "unknown.csv",
            "a,b,c,w\n0,0,0,1\n",
            vec!["column 4 'w'", "not a column"],
        ),
        (
            "bad_cell.csv",
            "a,b,c\n0,0,0\n0,x,0\n",
            vec!["line 3 (data row 2), column 2 'b'"],
        ),
    ];
    for (name, text, wants) in cases {
        let mut args = FitArgs::new(&train, &["y", "z"]);
        args.tune_evals = 5;
        args.test = Some(dir.write(name, text));
        let err = fit_report(&args).expect_err("bad test file");
        let msg = error_chain(&err);
        assert!(msg.contains(name), "{msg}");
        for w in wants {
            assert!(msg.contains(w), "{name}: want '{w}' in: {msg}");
        }
    }
}

#[test]
fn bad_arguments_are_errors() {
    let dir = TempDir::new("args");
    let train = dir.write("train.csv", &data(30, 5));
    let mut args = FitArgs::new(&train, &["y", "y"]);
    assert!(fit_report(&args).is_err());
    args.targets = vec!["y".into()];
    args.bandwidth = Some(0.0);
    assert!(fit_report(&args).is_err());
    args.bandwidth = None;
    args.level = 1.5;
    assert!(fit_report(&args).is_err());
}

#[derive(Debug, Parser)]
struct Cli {
    #[command(flatten)]
    fit: FitArgs,
}

#[test]
fn command_line_parses_with_defaults() {
    let cli = Cli::try_parse_from(["fit", "--train", "t.csv", "--target", "y", "--target", "z"]).expect("parses");
    assert_eq!(cli.fit.targets, ["y", "z"]);
    assert_eq!(cli.fit.tune_evals, 300);
    assert_eq!(cli.fit.level, 0.95);
    assert!(!cli.fit.json);
    let cli = Cli::try_parse_from([
        "fit",
        "--train",
        "t.csv",
        "--test",
        "s.csv",
        "--target",
        "y",
        "--out",
        "p.csv",
        "--json",
        "--kernel",
        "tricube",
        "--degree",
        "quadratic",
        "--bandwidth",
        "2",
        "--tune-evals",
        "10",
    ])
    .expect("parses");
    assert_eq!(cli.fit.bandwidth, Some(2.0));
    assert!(cli.fit.json);
    // a target is required, and --out needs --test
    assert!(Cli::try_parse_from(["fit", "--train", "t.csv"]).is_err());
    assert!(Cli::try_parse_from(["fit", "--train", "t.csv", "--target", "y", "--out", "p.csv"]).is_err());
}

/// Data a local fit cannot be made from is refused before any work, with
/// what is wrong with it: identical rows (not "a constant column"), fewer
/// rows than coefficients, a local polynomial too large to hold (300 inputs
/// at quadratic degree used to allocate until the process was killed), and
/// a constant target (whose normalised errors would divide by zero).
#[test]
fn data_too_small_for_the_model_is_refused_with_the_reason() {
    let dir = TempDir::new("size");
    let message = |train: &PathBuf, degree: &str| {
        let mut args = FitArgs::new(train, &["y"]);
        args.degree = match degree {
            "quadratic" => DegreeArg::Quadratic,
            _ => DegreeArg::Linear,
        };
        error_chain(&fit_report(&args).expect_err("refused"))
    };
    let twins = dir.write("twins.csv", "a,b,y\n1,2,3\n1,2,3\n");
    let e = message(&twins, "linear");
    assert!(
        e.contains("all 2 data rows are identical") && !e.contains("constant"),
        "{e}"
    );

    let few = dir.write("few.csv", "a,b,c,y\n1,2,3,4\n2,1,3,5\n3,3,1,6\n");
    let e = message(&few, "linear");
    assert!(
        e.contains("4 coefficients") && e.contains("at least 5 training rows") && e.contains("has 3"),
        "{e}"
    );

    let mut wide = (0..300).map(|j| format!("x{j}")).collect::<Vec<_>>().join(",");
    wide.push_str(",y\n");
    let mut rand = uniform(3);
    for _ in 0..10 {
        let row: Vec<String> = (0..301).map(|_| rand().to_string()).collect();
        wide.push_str(&row.join(","));
        wide.push('\n');
    }
    let wide = dir.write("wide.csv", &wide);
    let e = message(&wide, "quadratic");
    assert!(
        e.contains("quadratic fit in 300 inputs has 45451 coefficients") && e.contains("at most 2000"),
        "{e}"
    );

    let flat = dir.write("flat.csv", "a,y\n1,7\n2,7\n3,7\n4,7\n");
    let e = message(&flat, "linear");
    assert!(e.contains("target column 2 'y' is 7 in every row"), "{e}");
}

/// `--out` naming the training or test file is refused and the file kept;
/// test rows none of which can be predicted are reported as such, not as a
/// missing target column.
#[test]
fn predictions_never_overwrite_the_inputs_and_unpredictable_tests_say_so() {
    let dir = TempDir::new("out");
    let text = data(40, 8);
    let train = dir.write("train.csv", &text);
    let test = dir.write("test.csv", "a,b,c,y\n50,50,50,1\n60,60,60,2\n");
    for out in [&train, &test] {
        let mut args = FitArgs::new(&train, &["y", "z"]);
        args.tune_evals = 0;
        args.test = Some(test.clone());
        args.out = Some(out.clone());
        let e = error_chain(&fit_report(&args).expect_err("refused"));
        assert!(e.contains("writing the predictions would destroy it"), "{e}");
    }
    assert_eq!(fs::read_to_string(&train).expect("kept"), text);
    let mut args = FitArgs::new(&train, &["y", "z"]);
    args.tune_evals = 0;
    args.kernel = KernelArg::Tricube;
    args.test = Some(test);
    let report = fit_report(&args).expect("fit");
    assert_eq!(report.test.as_ref().map(|t| t.n_predicted), Some(0));
    let shown = report.to_string();
    assert!(shown.contains("no test row could be predicted"), "{shown}");
}

/// The phases are reported in order, and the predictions file is replaced
/// whole through a temporary file that does not stay behind.
#[test]
fn progress_is_reported_and_the_predictions_replace_the_old_file() {
    let dir = TempDir::new("progress");
    let train = dir.write("train.csv", &data(60, 9));
    let test = dir.write("test.csv", &data(7, 10));
    let out = dir.write("pred.csv", "old contents\n");
    let mut args = FitArgs::new(&train, &["y"]);
    args.tune_evals = 5;
    args.test = Some(test);
    args.out = Some(out.clone());
    let mut phases = Vec::new();
    fit_report_with(&args, &mut |p: &str| phases.push(p.to_owned())).expect("fit");
    assert_eq!(phases.len(), 3, "{phases:?}");
    assert!(
        phases[0].starts_with("tuning the metric: up to 5 leave-one-out evaluations over 60 of 60 rows, each about")
            && phases[0].ends_with("in all, estimated on a sample)"),
        "{phases:?}"
    );
    assert!(
        phases[1].starts_with("leave-one-out cross-validation of the final model (about "),
        "{phases:?}"
    );
    assert_eq!(phases[2], "predicting 7 test rows");
    let text = fs::read_to_string(&out).expect("predictions");
    assert_eq!(text.lines().count(), 8);
    assert!(text.starts_with("y_pred,y_std,y_lo,y_hi\n"));
    let names: Vec<String> = fs::read_dir(&dir.0)
        .expect("list")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!names.iter().any(|n| n.ends_with(".tmp")), "{names:?}");

    // a file that cannot be written: a typed error naming it, nothing left
    let nowhere = dir.path("no_such_dir").join("p.csv");
    let e = write_atomic(&nowhere, "x").expect_err("no directory");
    assert!(
        e.to_string().contains(".p.csv.") && e.to_string().contains(".tmp"),
        "{e}"
    );
    args.out = Some(nowhere.clone());
    let err = fit_report(&args).expect_err("cannot write");
    assert!(matches!(err, FitError::Write { .. }), "{err:?}");
    let msg = error_chain(&err);
    assert!(msg.contains("p.csv: writing the predictions: creating"), "{msg}");
    assert!(!nowhere.exists());
}

/// `lwr-fit` prints the summary on stdout and the phases on stderr, and a
/// bad file exits with an error naming its line, row and column.
#[test]
fn the_binary_fits_and_reports_bad_files() {
    let dir = TempDir::new("binary");
    let train = dir.write("train.csv", &data(80, 11));
    let bin = env!("CARGO_BIN_EXE_lwr-fit");
    let run = |args: &[&str]| std::process::Command::new(bin).args(args).output().expect("runs");
    let train_arg = train.to_str().expect("utf-8 path");
    let ok = run(&["--train", train_arg, "--target", "y", "--tune-evals", "5"]);
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    let stdout = String::from_utf8_lossy(&ok.stdout);
    assert!(
        stdout.contains("training: 80 rows") && stdout.contains("LOO normalised MSE"),
        "{stdout}"
    );
    let stderr = String::from_utf8_lossy(&ok.stderr);
    assert!(
        stderr.contains("leave-one-out cross-validation of the final model (about "),
        "{stderr}"
    );

    let json = run(&["--train", train_arg, "--target", "y", "--tune-evals", "0", "--json"]);
    let value: serde_json::Value = serde_json::from_slice(&json.stdout).expect("JSON summary");
    assert_eq!(value["n_train"], 80);

    // issue 37: with stdout and stderr closed (`| head`), no panic; the
    // predictions are saved before anything is printed; issue 51: the
    // status then says the summary was lost
    let test = dir.write("test.csv", &data(9, 12));
    let out = dir.path("closed.csv");
    let mut child = std::process::Command::new(bin)
        .args(["--train", train_arg, "--target", "y", "--tune-evals", "3", "--test"])
        .arg(&test)
        .arg("--out")
        .arg(&out)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawns");
    drop(child.stdout.take());
    drop(child.stderr.take());
    let status = child.wait().expect("waits");
    assert_eq!(status.code(), Some(1), "{status:?}");
    assert_eq!(fs::read_to_string(&out).expect("predictions saved").lines().count(), 10);

    let bad = dir.write("bad.csv", "a,b,y\n1,2,3\n4,x,6\n");
    let failed = run(&["--train", bad.to_str().expect("utf-8 path"), "--target", "y"]);
    assert!(!failed.status.success());
    let stderr = String::from_utf8_lossy(&failed.stderr);
    assert!(
        stderr.contains("error: ") && stderr.contains("bad.csv: line 3 (data row 2), column 2 'b'"),
        "{stderr}"
    );
}

/// The README's `lwr-fit` command: on `tests/data/fit_demo.csv` the tuned
/// metric drops the irrelevant input `c`.
#[test]
fn the_readme_example_drops_the_irrelevant_input() {
    let train = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/fit_demo.csv");
    let mut args = FitArgs::new(&train, &["y"]);
    args.tune_evals = 100;
    let report = fit_report(&args).expect("fit");
    assert_eq!(report.n_train, 200);
    assert!(report.loo_nmse < 0.05, "{}", report.loo_nmse);
    assert!(scale_of(&report, "c") < 0.05 * scale_of(&report, "a"), "{report}");
}

/// Issue 37, case 9: a training file named like the predictions file's
/// temporary (`p.csv.tmp` beside `--out p.csv`) is never touched; every
/// write goes through a temporary file of its own, created new.
#[test]
fn a_training_file_named_like_a_temporary_file_is_kept() {
    let dir = TempDir::new("tmpname");
    let text = data(50, 21);
    let train = dir.write("p.csv.tmp", &text);
    let test = dir.write("test.csv", &data(5, 22));
    let out = dir.path("p.csv");
    let mut args = FitArgs::new(&train, &["y"]);
    args.tune_evals = 0;
    args.test = Some(test);
    args.out = Some(out.clone());
    fit_report(&args).expect("fit");
    assert_eq!(fs::read_to_string(&train).expect("training file kept"), text);
    assert_eq!(fs::read_to_string(&out).expect("predictions").lines().count(), 6);
    // nor is a file named like write_atomic's own temporaries
    let decoy = dir.write(&format!(".q.csv.{}-0.tmp", std::process::id()), "mine\n");
    write_atomic(&dir.path("q.csv"), "new\n").expect("written");
    assert_eq!(fs::read_to_string(&decoy).expect("decoy"), "mine\n");
}

/// `data` with column `name` multiplied by `factor`.
fn scaled(text: &str, name: &str, factor: f64) -> String {
    let mut lines = text.lines();
    let header = lines.next().expect("header");
    let j = header.split(',').position(|c| c == name).expect("column");
    let mut out = format!("{header}\n");
    for line in lines {
        let cells: Vec<String> = line
            .split(',')
            .enumerate()
            .map(|(i, c)| {
                if i == j {
                    format!("{:e}", c.parse::<f64>().expect("number") * factor)
                } else {
                    c.to_owned()
                }
            })
            .collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

/// Issue 37, section 5: the fit is the same in any units. An input
/// scaled by 1e200 is neither "constant" nor overflowing, a target scaled
/// by 1e300 gives the same normalised error (not NaN), and the spreads
/// and metric scales are reported in the file's units.
#[test]
fn the_fit_does_not_depend_on_the_columns_units() {
    let dir = TempDir::new("units");
    let text = data(80, 23);
    let fit = |name: &str, body: &str| {
        let train = dir.write(name, body);
        let mut args = FitArgs::new(&train, &["y"]);
        args.tune_evals = 0;
        fit_report(&args).unwrap_or_else(|e| panic!("{name}: {}", error_chain(&e)))
    };
    let plain = fit("plain.csv", &text);
    for (column, factor) in [("a", 1e200), ("c", 1e-200), ("y", 1e300), ("y", 1e-300)] {
        let report = fit(&format!("{column}.csv"), &scaled(&text, column, factor));
        assert!(report.loo_nmse.is_finite(), "{column} x {factor}");
        assert!(
            (report.loo_nmse - plain.loo_nmse).abs() <= 1e-9 * plain.loo_nmse,
            "{column} x {factor}: {} against {}",
            report.loo_nmse,
            plain.loo_nmse
        );
        if let Some(i) = report.inputs.iter().position(|i| i.name == column) {
            let (r, p) = (&report.inputs[i], &plain.inputs[i]);
            assert!((r.spread / (p.spread * factor) - 1.0).abs() < 1e-9, "{column}: {r:?}");
            assert!(
                (r.metric_scale * factor / p.metric_scale - 1.0).abs() < 1e-9,
                "{column}: {r:?}"
            );
            assert!((r.scale - p.scale).abs() < 1e-9, "{column}: {r:?}");
        }
    }
}

/// Issue 37, section 5: a column that varies by round-off of its
/// magnitude only is constant, for inputs and targets alike; one that
/// varies relative to it is not, however small its values.
#[test]
fn constant_columns_are_judged_relative_to_their_magnitude() {
    let dir = TempDir::new("constant");
    let mut body = String::from("a,b,y\n");
    for i in 0..30 {
        let a = i as f64 / 30.0;
        // b: 1e6 plus a few units in its last place
        let b = 1e6 + (i % 3) as f64 * 1e-10;
        body.push_str(&format!("{a},{b},{}\n", a * a));
    }
    let train = dir.write("b.csv", &body);
    let mut args = FitArgs::new(&train, &["y"]);
    args.tune_evals = 0;
    let e = fit_report(&args).expect_err("b is constant");
    assert!(
        matches!(&e, FitError::ConstantInput { name, .. } if name == "b"),
        "{e:?}"
    );
    args.targets = vec!["b".into()];
    let e = fit_report(&args).expect_err("b is a constant target");
    assert!(
        matches!(&e, FitError::ConstantTarget { name, .. } if name == "b"),
        "{e:?}"
    );
    // tiny, but varying: fitted
    let tiny = scaled(&data(40, 24), "b", 1e-300);
    let train = dir.write("tiny.csv", &tiny);
    let mut args = FitArgs::new(&train, &["y"]);
    args.tune_evals = 0;
    assert!(fit_report(&args).expect("tiny inputs fit").loo_nmse.is_finite());
}

/// Issue 37, section 5: rows whose inputs repeat make leave-one-out
/// optimistic; they are counted and the summary warns.
#[test]
fn duplicated_rows_are_reported() {
    let dir = TempDir::new("dups");
    let text = data(40, 25);
    let rows: Vec<&str> = text.lines().skip(1).collect();
    let twice = format!(
        "{}\n{}\n{}\n",
        text.lines().next().expect("header"),
        rows.join("\n"),
        rows.join("\n")
    );
    let mut args = FitArgs::new(dir.write("twice.csv", &twice), &["y"]);
    args.tune_evals = 0;
    let report = fit_report(&args).expect("fit");
    assert_eq!(report.duplicate_inputs, 40);
    let shown = report.to_string();
    assert!(shown.contains("warning: 40 of 80 training rows repeat"), "{shown}");
    let mut args = FitArgs::new(dir.write("once.csv", &text), &["y"]);
    args.tune_evals = 0;
    let report = fit_report(&args).expect("fit");
    assert_eq!(report.duplicate_inputs, 0);
    assert!(!report.to_string().contains("warning"));
}

/// Issue 51: `--out` never writes through a link or over a device (as root
/// `--out /dev/full` once replaced the device with a file); the refusal
/// comes before any work and names the path; `--force` deletes a link
/// (never its target); a file keeps its mode; a 254-byte name works; `-`
/// writes the predictions on standard output.
#[cfg(unix)]
#[test]
fn the_predictions_never_go_through_a_link_or_over_a_device() {
    use std::os::unix::fs::PermissionsExt as _;
    let dir = TempDir::new("safety");
    let train = dir.write("train.csv", &data(40, 31));
    let test = dir.write("test.csv", &data(6, 32));
    let sentinel = store::Sentinel::new("lwr-fit-sentinel").expect("sentinel");
    let before = sentinel.snapshot();
    let mut targets = vec![sentinel.victim(), sentinel.path().join("dir")];
    if let Some((null, full)) = sentinel.devices() {
        targets.extend([null.clone(), full.clone()]);
    }
    let args_for = |out: PathBuf, force: bool| {
        let mut args = FitArgs::new(&train, &["y"]);
        args.tune_evals = 0;
        args.test = Some(test.clone());
        args.out = Some(out);
        args.force = force;
        args
    };
    for (k, target) in targets.iter().enumerate() {
        let link = dir.path(&format!("pred{k}.csv"));
        std::os::unix::fs::symlink(target, &link).expect("link");
        let err = fit_report(&args_for(link.clone(), false)).expect_err("a link");
        let msg = error_chain(&err);
        assert!(msg.contains("symbolic link") && msg.contains("--force"), "{msg}");
        fit_report(&args_for(link.clone(), true)).expect("--force deletes the link");
        assert!(fs::symlink_metadata(&link).expect("written").is_file());
        // a device or a directory named directly (`--out /dev/full`)
        if !fs::symlink_metadata(target).expect("target").is_file() {
            let err = fit_report(&args_for(target.clone(), true)).expect_err("not a regular file");
            assert!(
                error_chain(&err).contains("never written through links"),
                "{}",
                error_chain(&err)
            );
        }
    }
    sentinel.assert_unchanged(&before, "the run");
    // a FIFO at --out is refused before any work, without blocking on it
    let fifo = dir.path("pred.fifo");
    if std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success())
    {
        let err = fit_report(&args_for(fifo.clone(), true)).expect_err("a FIFO");
        assert!(error_chain(&err).contains("FIFO"), "{}", error_chain(&err));
    }
    // the mode of a replaced file is kept
    let out = dir.path("mode.csv");
    fs::write(&out, "old\n").expect("write");
    fs::set_permissions(&out, fs::Permissions::from_mode(0o600)).expect("chmod");
    fit_report(&args_for(out.clone(), false)).expect("fit");
    assert_eq!(fs::metadata(&out).expect("meta").permissions().mode() & 0o777, 0o600);
    // a valid name of 254 bytes
    let long = dir.path(&format!("{}.csv", "p".repeat(250)));
    fit_report(&args_for(long.clone(), false)).expect("a long name");
    assert_eq!(fs::read_to_string(&long).expect("written").lines().count(), 7);
    // `--out -`: the predictions on stdout, the summary on stderr
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_lwr-fit"))
        .args(["--target", "y", "--tune-evals", "0", "--out", "-", "--train"])
        .arg(&train)
        .arg("--test")
        .arg(&test)
        .output()
        .expect("runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.starts_with("y_pred,y_std,y_lo,y_hi\n") && stdout.lines().count() == 7,
        "{stdout}"
    );
    assert!(!dir.path("-").exists());
}

/// Issue 51: an error echoes a bad cell (or a column's name) of a 1 MB
/// cell cut to a few hundred characters, with its length.
#[test]
fn a_huge_bad_cell_is_echoed_cut() {
    let dir = TempDir::new("huge-cell");
    let cell = "x".repeat(1_000_000);
    let train = dir.write("train.csv", &format!("a,y\n1,2\n{cell},3\n"));
    let err = fit_report(&FitArgs::new(&train, &["y"])).expect_err("a bad cell");
    let msg = error_chain(&err);
    assert!(msg.len() < 600, "{} bytes", msg.len());
    assert!(
        msg.contains("line 3 (data row 2), column 1 'a'") && msg.contains("(1000000 bytes in all)"),
        "{msg}"
    );
}

/// The help a person reads (issue 50, item 7): no LaTeX or rustdoc link
/// syntax; `--version` names the commit.
#[test]
fn help_is_plain_text_and_the_version_names_the_commit() {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_lwr-fit"))
        .arg("--help")
        .output()
        .expect("runs");
    let help = String::from_utf8_lossy(&o.stdout);
    for bad in ["[`", "`]", "$", "crate::"] {
        assert!(!help.contains(bad), "--help holds {bad:?}:\n{help}");
    }
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_lwr-fit"))
        .arg("--version")
        .output()
        .expect("runs");
    let v = String::from_utf8_lossy(&o.stdout);
    assert!(v.contains("commit") && v.starts_with("lwr-fit 0."), "{v}");
}
