//! Planning the swing-up with the learned LWR model: the Eq. 3 plan
//! (Gauss-Newton over cubic B-splines, the default planner with its
//! lambda continuation) with the pure LWR learned from trials 1-2 of a
//! fixed seed, on one and on two threads, cold (from the demonstration,
//! with the lambda continuation) and warm (from trial 2's plan, the
//! previous trial's, as `planner.warm_start` plans); one model query with its
//! Jacobian, the planner's inner loop; and one warm-started replan of the
//! model-predictive controller (`replan_lwr`, one thread) over windows of
//! 60, 90 and 150 steps, against the 16.7 ms of a 60 Hz frame. And the
//! cold plan by each derivative-free planner on one thread
//! (`plan_lwr_derivative_free`: Gauss-Newton for reference, the
//! derivative-free mode by element and by group differences, Powell at the
//! claims grid's budget of 10,000 evaluations), each one's status, evaluations and criterion printed first.
//!
//! And the same replan with the model of a late trial (`replan_lwr_late`:
//! 8 trials of the pure LWR under MPC), each trial's replan times during
//! that run printed first.
//!
//! `cargo bench -p swingup --bench plan_lwr`

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use swingup::config::{Config, Controller, Differences, ModelKind, Solver};
use swingup::learn::run;
use swingup::models::learned::learn_model;
use swingup::models::{LearnedModel, PendulumRegression};
use swingup::planning::eq3::{plan, plan_from, window_cost};
use swingup::planning::mpc::{ReplanSettings, Window, WindowPlan, replan, shifted};
use swingup::record::PlanSummary;

/// The default configuration with the pure LWR, its model learned from
/// the first two trials of seed 1, the demonstration, and trial 2's plan
/// (made with the model of trial 1).
fn setup() -> (Config, LearnedModel, swingup::plant::demo::Demonstration, PlanSummary) {
    let mut cfg = Config {
        seed: 1,
        max_trials: 2,
        ..Config::default()
    };
    cfg.model.kind = ModelKind::Lwr;
    let record = run(&cfg, vec![], &mut |_: &swingup::record::TrialRecord| {}).expect("learning run");
    let (model, summary) = learn_model(&cfg.model, cfg.robot.dt, &record.trials[..2]).expect("model");
    let demo =
        swingup::plant::demo::demonstration(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance).expect("demo");
    let p = plan(&cfg, &demo, &model, None).expect("plan");
    let previous = record.trials[1].plan.clone().expect("trial 2 is planned");
    let w = plan_from(&cfg, &demo, &model, None, Some(&previous)).expect("warm plan");
    eprintln!(
        "plan_lwr: model of {} points (bandwidth {:.3}, scales {:?}); the plan takes {} iterations ({}), warm {} ({})",
        summary.n_points, summary.bandwidth, summary.scales, p.iterations, p.status, w.iterations, w.status
    );
    (cfg, model, demo, previous)
}

fn plan_with_lwr(c: &mut Criterion) {
    let (cfg, model, demo, previous) = setup();
    let mut group = c.benchmark_group("plan_lwr");
    group.sample_size(10);
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        group.bench_with_input(BenchmarkId::new("threads", threads), &threads, |b, _| {
            b.iter(|| pool.install(|| plan(&cfg, &demo, &model, None).expect("plan")));
        });
    }
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool");
    group.bench_function("warm/1", |b| {
        b.iter(|| one.install(|| plan_from(&cfg, &demo, &model, None, Some(&previous)).expect("plan")));
    });
    group.finish();

    // the same cold plan by each derivative-free planner, on one thread
    let mut group = c.benchmark_group("plan_lwr_derivative_free");
    group.sample_size(10);
    for (name, solver, differences) in [
        ("gauss-newton", Solver::GaussNewton, Differences::Elements),
        ("elements", Solver::DerivativeFree, Differences::Elements),
        ("groups", Solver::DerivativeFree, Differences::Groups),
        ("powell", Solver::Powell, Differences::Elements),
    ] {
        let mut c = cfg.clone();
        c.planner.solver = solver;
        c.planner.differences = differences;
        // Powell at the claims grid's budget and, as there, at the final lambda only
        if solver == Solver::Powell {
            c.planner.powell_evals = 10_000;
            c.planner.lambda_start = 0.0;
        }
        let p = plan(&c, &demo, &model, None).expect("plan");
        eprintln!(
            "plan_lwr_derivative_free/{name}: {} after {} iterations, {} criterion evaluations, criterion {:.6e}",
            p.status, p.iterations, p.evaluations, p.cost
        );
        group.bench_function(name, |b| {
            b.iter(|| one.install(|| plan(&c, &demo, &model, None).expect("plan")));
        });
    }
    group.finish();

    // one query with its Jacobian at points of the demonstration
    let points: Vec<[f64; 5]> = demo
        .controls
        .iter()
        .zip(&demo.states)
        .map(|(u, s)| [s[0], s[1], s[2], s[3], *u])
        .collect();
    let mut group = c.benchmark_group("lwr_query_with_jacobian");
    group.bench_function("demonstration_points", |b| {
        b.iter(|| {
            let mut j = [0.0; 5];
            points
                .iter()
                .map(|z| model.regression.delta_omega(black_box(z), Some(&mut j)))
                .sum::<f64>()
        });
    });
    group.finish();

    // one replan one step into the trial, warm-started from the plan
    // shifted by one step, from the state the plan predicted there
    let first = plan(&cfg, &demo, &model, None).expect("plan");
    let settings = ReplanSettings {
        max_iterations: cfg.mpc.iterations,
        ..ReplanSettings::default()
    };
    let mut group = c.benchmark_group("replan_lwr");
    group.sample_size(20);
    for samples in [60usize, 90, 150] {
        let window = Window::new(samples, cfg.robot.dt, 25.min(samples / 2), 20.min(samples / 2)).expect("window");
        let previous = WindowPlan {
            states: faer::Mat::from_fn(samples + 1, 4, |k, i| first.states[k.min(first.states.len() - 1)][i]),
            controls: faer::Mat::from_fn(samples, 1, |k, _| first.controls[k.min(first.controls.len() - 1)]),
        };
        let warm = shifted(&previous, 1);
        let x0 = first.states[1];
        group.bench_with_input(BenchmarkId::new("window", samples), &samples, |b, _| {
            b.iter(|| {
                one.install(|| {
                    let cost = window_cost(&cfg.planner, cfg.start, &demo, 1, samples).expect("cost");
                    let problem = window
                        .problem(&model, cost, cfg.planner.lambda, &x0, cfg.planner.initial_state_weight)
                        .expect("problem");
                    replan(&window, &problem, &warm, &x0, &settings).expect("replan")
                })
            });
        });
    }
    group.finish();
}

/// Trials of the late model's run: the claims grid's cap.
const LATE_TRIALS: usize = 8;

/// The replan of [`plan_with_lwr`]'s `replan_lwr` group with the model of a
/// late trial: seed 1 learned with the pure LWR (the paper's linear prior)
/// under `--controller mpc` for [`LATE_TRIALS`] trials on one thread (it does
/// not succeed, so every trial runs; each trial's replan times during the
/// run are printed: median, 99th percentile, worst), then the model of all
/// its trials, replanned over the default 150-step window from the last
/// trial's measured states (every fifth sample in turn, one per criterion
/// iteration), warm-started from that trial's plan shifted to the state,
/// as the controller replans; the same pass timed once is printed as its
/// 99th percentile.
fn replan_with_late_model(c: &mut Criterion) {
    let mut cfg = Config {
        seed: 1,
        max_trials: LATE_TRIALS,
        controller: Controller::Mpc,
        ..Config::default()
    };
    cfg.model.kind = ModelKind::Lwr;
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool");
    let record = one
        .install(|| run(&cfg, vec![], &mut |_: &swingup::record::TrialRecord| {}))
        .expect("learning run");
    for t in &record.trials {
        if let Some(trace) = &t.mpc {
            eprintln!(
                "replan_lwr_late: trial {} (success {}): {} replans during the run, median {:.2} ms, \
                 99th percentile {:.2} ms, worst {:.2} ms",
                t.index,
                t.success,
                trace.replans,
                trace.replan_quantile(0.5),
                trace.replan_quantile(0.99),
                trace.replan_quantile(1.0)
            );
        }
    }
    let last = record.trials.last().expect("a trial");
    let (model, summary) = learn_model(&cfg.model, cfg.robot.dt, &record.trials).expect("model");
    let demo =
        swingup::plant::demo::demonstration(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance).expect("demo");
    let initial = last.plan.clone().expect("the last trial is planned");
    let m = &cfg.mpc;
    let window = Window::new(m.window, cfg.robot.dt, m.state_coeffs, m.control_coeffs).expect("window");
    let (ns, nc) = (initial.states.len(), initial.controls.len());
    let first = WindowPlan {
        states: faer::Mat::from_fn(m.window + 1, 4, |k, i| initial.states[k.min(ns - 1)][i]),
        controls: faer::Mat::from_fn(m.window, 1, |k, _| initial.controls[k.min(nc - 1)]),
    };
    let settings = ReplanSettings {
        max_iterations: m.iterations,
        tol_cost: cfg.planner.tol_cost,
        ..ReplanSettings::default()
    };
    // the replans of the last trial's swing-up, where the controller replans
    let steps: Vec<usize> = (1..cfg.horizon.min(last.observed.len())).step_by(5).collect();
    let replan_at = |k: usize| {
        let cost = window_cost(&cfg.planner, cfg.start, &demo, k, m.window).expect("cost");
        let x0 = last.observed[k];
        let problem = window
            .problem(&model, cost, cfg.planner.lambda, &x0, cfg.planner.initial_state_weight)
            .expect("problem");
        replan(&window, &problem, &shifted(&first, k.min(m.window)), &x0, &settings).expect("replan")
    };
    let ms: Vec<f64> = steps
        .iter()
        .map(|&k| {
            let started = std::time::Instant::now();
            one.install(|| black_box(replan_at(k)));
            started.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    eprintln!(
        "replan_lwr_late: model of {} points after {} trials; {} replans along trial {}: median {:.2} ms, \
         99th percentile {:.2} ms (a 60 Hz frame is 16.7 ms)",
        summary.n_points,
        record.trials.len(),
        ms.len(),
        last.index,
        swingup::record::quantile(&ms, 0.5),
        swingup::record::quantile(&ms, 0.99)
    );
    let mut group = c.benchmark_group("replan_lwr_late");
    group.sample_size(20);
    let mut next = steps.iter().cycle();
    group.bench_function(BenchmarkId::new("window", m.window), |b| {
        b.iter(|| {
            let k = *next.next().expect("steps");
            one.install(|| replan_at(k))
        });
    });
    group.finish();
}

criterion_group!(benches, plan_with_lwr, replan_with_late_model);
criterion_main!(benches);
