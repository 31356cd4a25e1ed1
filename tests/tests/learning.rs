//! The main job end to end, short: the robot imitates the demonstration
//! and fails, then learns a model and plans with Eq. 3 until it swings the
//! pendulum up and balances it. Asserts on the written report, and that an
//! interrupted run resumed gives the same trials.

use swingup::config::{Config, ModelKind, Start};
use swingup::learn::run;
use swingup::output::run_report;
use swingup::record::{TrialKind, TrialRecord};

/// A fresh scratch directory, removed afterwards.
fn scratch(tag: &str) -> store::ScratchDir {
    store::ScratchDir::new(&format!("learning-{tag}")).expect("scratch directory")
}

fn config(max_trials: usize) -> Config {
    Config {
        max_trials,
        ..Config::default()
    }
}

#[test]
fn imitation_fails_and_learning_succeeds() -> Result<(), Box<dyn std::error::Error>> {
    let dir = scratch("default");
    let cfg = config(4);
    let record = run(&cfg, vec![], &mut |_: &TrialRecord| {})?;
    run_report::write_run(dir.path(), &record)?;
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json"))?)?;
    let trials = json["trials"].as_array().ok_or("no trials in report.json")?;
    // trial 1 imitates and does not get halfway up (claim C1)
    assert_eq!(record.trials[0].kind, TrialKind::Imitation);
    let first = trials[0]["max_angle"].as_f64().ok_or("no max angle")?;
    assert!(first < std::f64::consts::FRAC_PI_2, "imitation reached {first} rad");
    assert_eq!(trials[0]["success"], serde_json::Value::Bool(false));
    // a learned plan succeeds within the cap, and the report says when
    let success = json["success_trial"].as_u64().ok_or("no success within 4 trials")?;
    assert!((2..=4).contains(&success), "success at trial {success}");
    let last = &record.trials[success as usize - 1];
    assert!(last.success && last.kind == TrialKind::Planned);
    assert!(last.plan.is_some() && last.model.is_some());
    // the balanced tail: within the success angle of upright at the end
    let end = last.states.last().ok_or("no states")?;
    assert!(swingup::plant::from_upright(end[0]).abs() < cfg.success_angle);
    Ok(())
}

#[test]
fn an_interrupted_run_resumes_to_the_same_trials() -> Result<(), Box<dyn std::error::Error>> {
    let dir = scratch("resume");
    let whole = run(&config(3), vec![], &mut |_: &TrialRecord| {})?;
    // "interrupted" after one trial: only trial 1 was saved
    let mut saved = Vec::new();
    let first = run(&config(1), vec![], &mut |t: &TrialRecord| saved.push(t.clone()))?;
    assert_eq!(first.trials.len(), 1);
    for t in &saved {
        run_report::write_trial(dir.path(), t)?;
    }
    let previous = run_report::read_trials(dir.path())?;
    let resumed = run(&config(3), previous, &mut |_: &TrialRecord| {})?;
    assert_eq!(whole.trials.len(), resumed.trials.len());
    assert_eq!(whole.success_trial, resumed.success_trial);
    for (a, b) in whole.trials.iter().zip(&resumed.trials) {
        assert_eq!(a.commands, b.commands, "trial {} commands differ", a.index);
        assert_eq!(a.states, b.states, "trial {} states differ", a.index);
        assert_eq!(a.success, b.success);
    }
    Ok(())
}

/// Learning from scratch: trial 1 explores (no demonstration), and trial 2
/// plans from what trial 1 observed, not from the demonstration.
#[test]
fn learning_from_scratch_explores_then_plans_from_it() -> Result<(), Box<dyn std::error::Error>> {
    let mut cfg = config(2);
    cfg.start = Start::Scratch;
    cfg.model.kind = ModelKind::Parametric;
    let record = run(&cfg, vec![], &mut |_: &TrialRecord| {})?;
    assert_eq!(record.trials.len(), 2);
    let (first, second) = (&record.trials[0], &record.trials[1]);
    assert_eq!(first.kind, TrialKind::Exploration);
    assert!(first.plan.is_none());
    // the exploration commands are not the demonstration's
    let demo = &record.demonstration.controls;
    assert!(first.commands.iter().zip(demo).any(|(a, b)| (a - b).abs() > 1e-3));
    assert_eq!(second.kind, TrialKind::Planned);
    let plan = second.plan.as_ref().ok_or("trial 2 has no plan")?;
    assert!(plan.cost.is_finite() && plan.cost <= plan.initial_cost);
    Ok(())
}
