//! `swingup experiments` on a tiny grid: the lambda sweep's two ends and
//! the claims table built from them.

use swingup::cartpole::CartPoleSettings;
use swingup::config::ModelKind;
use swingup::experiments::{CARTPOLE_VARIANT, Experiment, ExperimentSettings, ExperimentsReport, run_experiments};
use swingup::output::grid;

/// The learning experiment's derivative-free variant records, per plan,
/// Gauss-Newton's criterion on the same problem, and its plans reach it
/// (the semiparametric model: smooth, a short test).
#[test]
fn derivative_free_plans_are_checked_against_gauss_newton() -> Result<(), Box<dyn std::error::Error>> {
    let settings = ExperimentSettings {
        seeds: 1,
        learning_seeds: 0,
        wavelet_seeds: 0,
        powell_seeds: 0,
        derivative_free_seeds: 1,
        paper_basis_seeds: 0,
        max_trials: 2,
        powell_evals: 1000,
        lambdas: vec![],
        model: ModelKind::LwrParametric,
        mpc_seeds: 0,
        cartpole: Default::default(),
    };
    let report = run_experiments(
        &[Experiment::Learning],
        &settings,
        vec![],
        true,
        None,
        &[],
        &|_, _, _| Ok(()),
    )?;
    let runs: Vec<_> = report
        .runs
        .iter()
        .filter(|r| r.variant == "derivative-free/bspline")
        .collect();
    assert_eq!(runs.len(), 1);
    let run = runs[0];
    assert!(!run.plan_statuses.is_empty());
    assert_eq!(run.plan_costs.len(), run.plan_statuses.len());
    assert!(run.plan_gauss_newton_costs.iter().all(Option::is_some));
    let (plans, converged, same, compared) =
        swingup::experiments::claims::plan_agreement(&report.runs, "learning", "derivative-free/bspline");
    assert_eq!((plans, compared), (run.plan_statuses.len(), plans));
    assert_eq!(converged, plans, "{:?}", run.plan_statuses);
    assert_eq!(
        same, plans,
        "{:?} against {:?}",
        run.plan_costs, run.plan_gauss_newton_costs
    );
    let c2 = report.claims.iter().find(|c| c.id == "C2").ok_or("no C2 row")?;
    assert!(
        c2.ours.contains("derivative-free least squares: 0/1")
            || c2.ours.contains("derivative-free least squares: 1/1"),
        "{}",
        c2.ours
    );
    Ok(())
}

#[test]
fn lambda_zero_fails_and_a_moderate_lambda_learns() -> Result<(), Box<dyn std::error::Error>> {
    let settings = ExperimentSettings {
        seeds: 1,
        learning_seeds: 0,
        wavelet_seeds: 0,
        powell_seeds: 0,
        derivative_free_seeds: 0,
        paper_basis_seeds: 0,
        max_trials: 3,
        powell_evals: 1000,
        lambdas: vec![0.0, 1e3],
        // the semiparametric model learns in two trials: a short test
        model: ModelKind::LwrParametric,
        mpc_seeds: 0,
        cartpole: Default::default(),
    };
    let report = run_experiments(&[Experiment::Lambda], &settings, vec![], true, None, &[], &|_, _, _| {
        Ok(())
    })?;
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
        &[],
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
        &[],
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
            &[],
            &|_, _, r| {
                assert_eq!(r.variant, "lambda=1e3", "shard {k} ran {}", r.variant);
                Ok(())
            },
        )?;
        assert_eq!(part.runs.len(), 1, "shard {k}");
        assert_eq!(part.runs[0].variant, back.runs[k - 1].variant, "shard {k}");
    }
    // saved as the records of two parts (the grid's and a shard's): a torn
    // last line is skipped with a warning naming the file and line, a bad
    // complete line is an error naming them
    let scratch = store::ScratchDir::new("swingup-saved-runs")?;
    let dir = scratch.path().to_path_buf();
    for name in ["settings.json", "settings-2-of-2.json"] {
        let path = dir.join(name);
        grid::grid_manifest(&settings, &path)?.write(&path)?;
    }
    let lines: Vec<String> = report
        .runs
        .iter()
        .map(serde_json::to_string)
        .collect::<Result<_, _>>()?;
    let whole = format!("{}\n{}\n", lines[0], lines[1]);
    std::fs::write(dir.join("runs.jsonl"), format!("{whole}{}", &lines[0][..20]))?;
    std::fs::write(dir.join("runs-2-of-2.jsonl"), format!("{}\n", lines[1]))?;
    let opened = grid::open_grid(&dir, &settings, None, grid::GridMode::ReportOnly)?;
    assert_eq!(opened.previous.len(), 2, "both runs once, the torn copy skipped");
    assert_eq!(opened.warnings.len(), 1, "{:?}", opened.warnings);
    assert!(
        opened.warnings[0].contains("runs.jsonl line 3"),
        "{:?}",
        opened.warnings
    );
    std::fs::write(
        dir.join("runs.jsonl"),
        format!("{}\nnot json\n{}\n", lines[0], lines[1]),
    )?;
    let e = grid::open_grid(&dir, &settings, None, grid::GridMode::ReportOnly)
        .expect_err("bad line")
        .to_string();
    assert!(e.contains("runs.jsonl line 2"), "{e}");
    let md = swingup::output::grid_report::markdown(&report);
    assert!(md.contains("| claim | paper | ours | reproduced |"));
    Ok(())
}

/// The `mpc` experiment's cart-pole part run alone (`--variant cartpole`)
/// on a tiny cart-pole: only the cart-pole run runs, beside a saved
/// pendulum run that the report keeps; its record (per-trial success,
/// replan quantiles, commit) round-trips through a runs file; resuming
/// with other cart-pole settings is refused, naming the setting.
#[test]
fn the_cartpole_part_runs_alone_round_trips_and_refuses_other_settings() -> Result<(), Box<dyn std::error::Error>> {
    let settings = ExperimentSettings {
        mpc_seeds: 1,
        max_trials: 2,
        cartpole: CartPoleSettings::quick(),
        ..ExperimentSettings::quick()
    };
    // a pendulum run of the same grid, saved earlier by other code
    let saved = swingup::experiments::RunSummary {
        experiment: "mpc".into(),
        variant: "open-loop/true".into(),
        seed: 1,
        success_trial: Some(2),
        trials: 2,
        robot_seconds: 11.0,
        max_angles: vec![1.5, 3.2],
        failures: vec![String::new(); 2],
        seconds: 1.0,
        trial_success: vec![false, true],
        code_version: "commit earlier".into(),
        ..Default::default()
    };
    let report = run_experiments(
        &[Experiment::Mpc],
        &settings,
        vec![saved.clone()],
        true,
        None,
        &["cartpole".to_string()],
        &|_, _, r| {
            assert_eq!(r.variant, CARTPOLE_VARIANT, "ran {}", r.variant);
            Ok(())
        },
    )?;
    assert_eq!(report.runs.len(), 2, "the saved pendulum run and the new cart-pole run");
    assert_eq!(report.ran, Some(1));
    let run = report
        .runs
        .iter()
        .find(|r| r.variant == CARTPOLE_VARIANT)
        .ok_or("no cart-pole run")?;
    assert_eq!(run.seed, 1);
    assert_eq!(run.trial_success.len(), run.trials);
    assert_eq!(
        run.success_trial,
        run.trial_success.iter().position(|s| *s).map(|i| i + 1)
    );
    // one replan time pair per MPC trial (the random trial has none)
    assert_eq!(run.replan_ms.len(), run.trials - 1);
    assert!(run.replan_ms.iter().all(|[m, p]| m.is_finite() && m <= p));
    assert_eq!(run.first_plan_ms.len(), run.trials - 1);
    assert!(!run.code_version.is_empty());
    // the cart-pole is timed by this invocation, the pendulum run by none
    let cart = report.task_time("cartpole").ok_or("no cart-pole wall time")?;
    assert_eq!((cart.ran, cart.invocation_ran), (Some(1), Some(1)));
    assert!(report.task_time("pendulum").is_none());
    let block = swingup::output::grid_report::mpc_readme_block(&report);
    assert!(block.contains("| after trial | 1 | 2 |"), "{block}");
    assert!(
        block.contains("| PILCO | 17.5 s |") && block.contains("| GP-MPC | 9 s |"),
        "{block}"
    );
    // saved as a runs file and read back, the record is the same
    let scratch = store::ScratchDir::new("swingup-cartpole-runs")?;
    let dir = scratch.path().to_path_buf();
    let settings_file = dir.join(grid::SETTINGS_FILE);
    grid::grid_manifest(&settings, &settings_file)?.write(&settings_file)?;
    let lines: Vec<String> = report
        .runs
        .iter()
        .map(serde_json::to_string)
        .collect::<Result<_, _>>()?;
    std::fs::write(dir.join("runs.jsonl"), format!("{}\n", lines.join("\n")))?;
    let opened = grid::open_grid(&dir, &settings, None, grid::GridMode::ReportOnly)?;
    assert!(opened.warnings.is_empty(), "{:?}", opened.warnings);
    assert_eq!(opened.previous, report.runs);
    // resumed with its runs, nothing runs again
    let again = run_experiments(
        &[Experiment::Mpc],
        &settings,
        opened.previous,
        true,
        None,
        &["cartpole".to_string()],
        &|_, _, r| panic!("{} ran again", r.variant),
    )?;
    assert_eq!(again.variants, report.variants);
    // the settings are recorded; resuming with another cart-pole is refused
    let mut other = settings.clone();
    other.cartpole.max_trials = 2;
    let e = grid::open_grid(&dir, &other, None, grid::GridMode::Resume)
        .expect_err("other cart-pole settings")
        .to_string();
    assert!(e.contains("cartpole.max_trials differs"), "{e}");
    // settings saved before the cart-pole was part of the grid (and before
    // manifests) read back as its defaults: a grid of the defaults
    // resumes, another does not
    std::fs::remove_file(dir.join("runs.jsonl"))?;
    let mut legacy: serde_json::Value = serde_json::to_value(ExperimentSettings::full())?;
    legacy.as_object_mut().ok_or("settings object")?.remove("cartpole");
    std::fs::write(&settings_file, serde_json::to_string(&legacy)?)?;
    grid::open_grid(&dir, &ExperimentSettings::full(), None, grid::GridMode::ReportOnly)?;
    let mut changed = ExperimentSettings::full();
    changed.cartpole.episode = 3.0;
    assert!(grid::open_grid(&dir, &changed, None, grid::GridMode::ReportOnly).is_err());
    Ok(())
}
