//! The benchmark's learned-LWR instance (`pendulum-lwr`) is a saved file,
//! `bench/data/pendulum-lwr.json`, so that `nprl-bench` does not depend on
//! the `swingup` program. This test makes that file from the program's own
//! planner problem (seed 1, trials 1 and 2, the default configuration with
//! the pure LWR) and checks that
//!
//! - the problem the benchmark defines from the file equals the program's
//!   (residuals and Jacobian values, at the start and away from it);
//! - the committed file defines the problem the program makes today.
//!
//! To write the file again (after a change to the swing-up program's
//! learning or planner):
//! `cargo test --release -p integration-tests --test pendulum_lwr_instance -- --ignored`

use bench::lwr_instance::LwrInstanceFile;
use swingup::config::{BasisKind, Config, ModelKind, Start};
use swingup::plant::demo::demonstration;
use trajopt::LeastSquaresProblem;

const PATH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../bench/data/pendulum-lwr.json");

/// The program's planner problem and the file that describes it.
fn generate() -> (impl LeastSquaresProblem, Vec<f64>, LwrInstanceFile) {
    let mut cfg = Config {
        seed: 1,
        max_trials: 2,
        ..Config::default()
    };
    cfg.model.kind = ModelKind::Lwr;
    assert_eq!(
        cfg.planner.basis,
        BasisKind::Bspline,
        "the file describes B-spline bases"
    );
    let record = swingup::learn::run(&cfg, vec![], &mut |_: &swingup::record::TrialRecord| {}).expect("learning run");
    let trials = &record.trials[..2];
    let (model, _) = swingup::models::learned::learn_model(&cfg.model, cfg.robot.dt, trials).expect("model");
    let demo = demonstration(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance).expect("demonstration");
    assert_eq!(model.dt, demo.dt, "one sample period for the model and the plan");

    // the prior is linear: its value and gradient at 0 are its coefficients
    let mut slopes = [0.0; 5];
    let c0 = model.regression.prior().delta_omega(&[0.0; 5], Some(&mut slopes));
    let n = demo.horizon();
    let upright = [std::f64::consts::PI, 0.0, 0.0, 0.0];
    let tracked = cfg.start == Start::Demonstration;
    let p = &cfg.planner;
    let file_fields = (
        model.regression.lwr().clone(),
        model.regression.inputs().to_vec(),
        [c0, slopes[0], slopes[1], slopes[2], slopes[3], slopes[4]],
    );
    let (problem, start) = swingup::planning::eq3::build_problem(&cfg, &demo, model, None).expect("problem");
    let file = LwrInstanceFile {
        source: "cargo test --release -p integration-tests --test pendulum_lwr_instance -- --ignored \
                 (swingup's planner problem: seed 1, trials 1 and 2, the default configuration with \
                 model.kind = lwr)"
            .into(),
        dt: demo.dt,
        prior: file_fields.2,
        inputs: file_fields.1,
        lwr: file_fields.0,
        state_reference: (0..=n)
            .map(|k| if tracked && k < n { demo.states[k] } else { upright })
            .collect(),
        control_reference: (0..n).map(|k| if tracked { demo.controls[k] } else { 0.0 }).collect(),
        state_weights: p.state_weights,
        control_weight: p.control_weight,
        terminal_weights: p.terminal_weights,
        x_max: p.x_max,
        u_max: p.u_max,
        bound_weight: p.bound_weight,
        state_coeffs: p.state_coeffs,
        control_coeffs: p.control_coeffs,
        lambda: p.lambda,
        initial_state_weight: p.initial_state_weight,
        start: start.clone(),
    };
    (problem, start, file)
}

/// The largest relative difference between two vectors.
fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / x.abs().max(y.abs()).max(1e-300))
        .fold(0.0, f64::max)
}

/// Residuals and Jacobian values of both problems at `theta`.
fn compare_at(ours: &impl LeastSquaresProblem, theirs: &impl LeastSquaresProblem, theta: &[f64]) -> (f64, f64) {
    let (mut r1, mut r2) = (vec![0.0; ours.n_residuals()], vec![0.0; theirs.n_residuals()]);
    ours.residuals(theta, &mut r1).expect("residuals");
    theirs.residuals(theta, &mut r2).expect("residuals");
    let (p1, p2) = (ours.jacobian_pattern(), theirs.jacobian_pattern());
    assert_eq!(p1.row_ptr(), p2.row_ptr(), "the same Jacobian pattern");
    assert_eq!(p1.col_idx(), p2.col_idx(), "the same Jacobian pattern");
    let (mut j1, mut j2) = (vec![0.0; p1.col_idx().len()], vec![0.0; p2.col_idx().len()]);
    ours.jacobian_values(theta, &mut j1).expect("jacobian");
    theirs.jacobian_values(theta, &mut j2).expect("jacobian");
    (rel_diff(&r1, &r2), rel_diff(&j1, &j2))
}

#[test]
fn the_benchmark_instance_is_the_programs_planner_problem() {
    let (program, start, file) = generate();
    // the file's text round trip, as the benchmark reads it
    let text = serde_json::to_string(&file).expect("serialise");
    let (bench, bench_start) = LwrInstanceFile::parse(&text)
        .expect("parse")
        .problem()
        .expect("problem");
    assert_eq!(bench_start, start);
    assert_eq!(
        (bench.n_params(), bench.n_residuals()),
        (program.n_params(), program.n_residuals())
    );
    let away: Vec<f64> = start
        .iter()
        .enumerate()
        .map(|(i, t)| t + 0.05 * (0.7 * i as f64).sin())
        .collect();
    for theta in [&start, &away] {
        let (r, j) = compare_at(&bench, &program, theta);
        assert!(r < 1e-12 && j < 1e-10, "residuals differ by {r:e}, Jacobians by {j:e}");
    }

    // the committed file defines today's problem (learning is seeded; the
    // LWR's sums may round differently on another machine, so a tolerance)
    let committed = LwrInstanceFile::parse(&std::fs::read_to_string(PATH).expect("bench/data/pendulum-lwr.json"))
        .expect("the committed file parses");
    let (saved, saved_start) = committed.problem().expect("the committed file defines a problem");
    assert!(
        rel_diff(&saved_start, &start) < 1e-9,
        "the committed start differs from today's: regenerate the file (see the module docs)"
    );
    for theta in [&start, &away] {
        let (r, j) = compare_at(&saved, &program, theta);
        assert!(
            r < 1e-9 && j < 1e-7,
            "the committed file's problem differs from today's (residuals {r:e}, Jacobians {j:e}): \
             regenerate it (see the module docs)"
        );
    }
    // and it is the one the benchmark compiles in
    let compiled = LwrInstanceFile::compiled_in().expect("compiled in");
    assert_eq!(compiled.start, committed.start);
}

/// Writes `bench/data/pendulum-lwr.json` (ignored: run it on purpose).
#[test]
#[ignore = "writes bench/data/pendulum-lwr.json"]
fn write_the_instance_file() {
    let (_, _, file) = generate();
    let text = serde_json::to_string(&file).expect("serialise") + "\n";
    store::replace_file(std::path::Path::new(PATH), text.as_bytes()).expect("write");
}
