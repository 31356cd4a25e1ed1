//! `swingup experiments` on a tiny grid: the lambda sweep's two ends and
//! the claims table built from them.

use swingup::config::ModelKind;
use swingup::experiments::{Experiment, ExperimentSettings, ExperimentsReport, run_experiments};

#[test]
fn lambda_zero_fails_and_a_moderate_lambda_learns() -> Result<(), Box<dyn std::error::Error>> {
    let settings = ExperimentSettings {
        seeds: 1,
        learning_seeds: 0,
        wavelet_seeds: 0,
        powell_seeds: 0,
        max_trials: 3,
        powell_evals: 1000,
        lambdas: vec![0.0, 1e3],
        // the semiparametric model learns in two trials: a short test
        model: ModelKind::LwrParametric,
        mpc_seeds: 0,
    };
    let report = run_experiments(&[Experiment::Lambda], &settings, vec![], true, None, &|_, _, _| {})?;
    assert_eq!(report.runs.len(), 2);
    let by = |v: &str| report.variants.iter().find(|x| x.variant == v);
    let zero = by("lambda=0e0").ok_or("no lambda = 0 variant")?;
    let mid = by("lambda=1e3").ok_or("no lambda = 1e3 variant")?;
    // lambda = 0 plans the demonstration, which the robot cannot do (C4)
    assert_eq!(zero.successes, 0);
    assert_eq!(mid.successes, 1);
    let c4 = report.claims.iter().find(|c| c.id == "C4").ok_or("no C4 row")?;
    assert_eq!(c4.reproduced, "yes");
    let c1 = report.claims.iter().find(|c| c.id == "C1").ok_or("no C1 row")?;
    assert_eq!(c1.reproduced, "yes");
    // the JSON round-trips and the markdown opens with the claims table
    let back: ExperimentsReport = serde_json::from_str(&serde_json::to_string(&report)?)?;
    assert_eq!(back.runs.len(), report.runs.len());
    // resumed with its runs, nothing runs again and the result is the same
    let again = run_experiments(
        &[Experiment::Lambda],
        &settings,
        back.runs.clone(),
        true,
        None,
        &|_, _, _| panic!("a finished run ran again"),
    )?;
    assert_eq!(again.variants, report.variants);
    // the report of the saved runs alone, one of them dropped: nothing runs
    let fewer = run_experiments(
        &[Experiment::Lambda],
        &settings,
        back.runs[..1].to_vec(),
        false,
        None,
        &|_, _, _| panic!("nothing may run"),
    )?;
    assert_eq!(fewer.runs.len(), 1);
    // two shards, with the lambda = 0 run saved: the first shard holds it
    // and runs nothing, the second runs the other one alone
    for k in [1usize, 2] {
        let shard: swingup::experiments::Shard = format!("{k}/2").parse()?;
        let part = run_experiments(
            &[Experiment::Lambda],
            &settings,
            back.runs[..1].to_vec(),
            true,
            Some(shard),
            &|_, _, r| assert_eq!(r.variant, "lambda=1e3", "shard {k} ran {}", r.variant),
        )?;
        assert_eq!(part.runs.len(), 1, "shard {k}");
        assert_eq!(part.runs[0].variant, back.runs[k - 1].variant, "shard {k}");
    }
    // saved as runs.jsonl records: a torn last line is skipped with a
    // warning naming the file and line, a bad complete line is an error
    let dir = std::env::temp_dir().join(format!("swingup-saved-runs-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let lines: Vec<String> = report
        .runs
        .iter()
        .map(serde_json::to_string)
        .collect::<Result<_, _>>()?;
    let whole = format!("{}\n{}\n", lines[0], lines[1]);
    std::fs::write(dir.join("runs.jsonl"), format!("{whole}{}", &lines[0][..20]))?;
    std::fs::write(dir.join("runs-2-of-2.jsonl"), format!("{}\n", lines[1]))?;
    let (runs, warnings) = swingup::output::grid::read_saved_runs(&dir)?;
    assert_eq!(runs.len(), 2, "both runs once, the torn copy skipped");
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].contains("runs.jsonl line 3"), "{warnings:?}");
    std::fs::write(
        dir.join("runs.jsonl"),
        format!("{}\nnot json\n{}\n", lines[0], lines[1]),
    )?;
    let e = swingup::output::grid::read_saved_runs(&dir)
        .expect_err("bad line")
        .to_string();
    assert!(e.contains("runs.jsonl line 2"), "{e}");
    std::fs::remove_dir_all(&dir)?;
    let md = swingup::output::grid_report::markdown(&report);
    assert!(md.contains("| claim | paper | ours | reproduced |"));
    Ok(())
}
