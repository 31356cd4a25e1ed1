//! The trajectory problems of `trajopt::problems::trajectory` (Eq. 3 form)
//! and `ddp::problems` (DDP form) are the same problems: for every
//! registered instance the model (one `nprl-systems` type under each
//! crate's trait) steps the same state and control to
//! the same next state with the same Jacobians (each passing its crate's
//! check), the two costs give the same stage and terminal costs of the same
//! trajectory, and DDP's optimum costs the same in both forms; and both
//! solvers swing each system up to comparable costs.

use ddp::Dynamics;
use ddp::strategies::check_dynamics;
use integration_tests::gauss_newton_plan;
use trajopt::problems::trajectory::{self, SwingUpProblem, parameters_of};
use trajopt::{StageCost, check_model_jacobians};

/// Deterministic spread-out test points: states in $[-3, 3]^n$ (angles
/// beyond $\pm\pi/2$, fast rates), controls in $[-8, 8]$.
fn points(n: usize) -> Vec<(Vec<f64>, Vec<f64>)> {
    (0..12)
        .map(|p| {
            let x = (0..n)
                .map(|i| 3.0 * (1.3 * p as f64 + 2.1 * i as f64 + 0.4).sin())
                .collect();
            (x, vec![8.0 * (0.9 * p as f64 + 0.2).cos()])
        })
        .collect()
}

/// The DDP form of the same instance (`Instance::ddp_name`).
fn ddp_twin(instance: &trajectory::Instance) -> ddp::problems::Instance {
    ddp::problems::by_name(&instance.ddp_name()).expect("every Eq. 3 instance has a DDP twin")
}

/// The stage costs $c_0, \dots, c_{N-1}$ and the terminal cost of Eq. 3's
/// task cost on the given trajectory.
fn eq3_stage_costs(problem: &SwingUpProblem, states: &[Vec<f64>], controls: &[Vec<f64>]) -> (Vec<f64>, f64) {
    let cost = problem.stage_cost();
    let mut r = vec![0.0; cost.n_residuals()];
    let mut sum_sq = |k: usize, x: &[f64], u: Option<&[f64]>| {
        cost.residuals(k, x, u, &mut r).expect("residuals");
        r.iter().map(|v| v * v).sum::<f64>()
    };
    let stages = controls
        .iter()
        .enumerate()
        .map(|(k, u)| sum_sq(k, &states[k], Some(u)))
        .collect();
    let n = controls.len();
    (stages, sum_sq(n, &states[n], None))
}

#[test]
fn every_instance_has_a_ddp_twin_with_the_same_setup() {
    let instances = trajectory::standard_instances();
    assert!(instances.len() >= 2 * ddp::problems::standard_instances().len());
    for ddp_instance in ddp::problems::standard_instances() {
        assert!(
            instances.iter().any(|i| i.ddp_name() == ddp_instance.name()),
            "{} has no Eq. 3 form",
            ddp_instance.name()
        );
    }
    for instance in &instances {
        let twin = ddp_twin(instance);
        let (problem, _) = instance.problem().expect("problem");
        let ddp_problem = twin.problem().expect("problem");
        assert_eq!(problem.horizon(), ddp_problem.horizon(), "{}", instance.name());
        let (w, dw) = (instance.system.weights(), twin.system.weights());
        assert_eq!(
            (&w.state, &w.control, &w.terminal, &w.target, &w.initial_state),
            (&dw.state, &dw.control, &dw.terminal, &dw.target, &dw.initial_state),
            "{}",
            instance.name()
        );
        assert_eq!(ddp_problem.initial_state(), w.initial_state.as_slice());
        assert_eq!(trajectory::DT, ddp::problems::DT);
    }
}

#[test]
fn models_step_alike_and_pass_both_jacobian_checks() {
    for instance in trajectory::standard_instances() {
        let (problem, _) = instance.problem().expect("problem");
        let ddp_problem = ddp_twin(&instance).problem().expect("problem");
        let (model, dyn_) = (problem.model(), ddp_problem.dynamics());
        // one type (`systems::SwingUpModel`) under the one model contract
        let n = Dynamics::state_dim(model);
        assert_eq!(
            (n, Dynamics::control_dim(model)),
            (Dynamics::state_dim(dyn_), Dynamics::control_dim(dyn_))
        );
        for (x, u) in points(n) {
            let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
            Dynamics::step(model, &x, &u, &mut a).expect("step");
            Dynamics::step(dyn_, &x, &u, &mut b).expect("step");
            for i in 0..n {
                assert!(
                    (a[i] - b[i]).abs() <= 1e-12 * (1.0 + b[i].abs()),
                    "{} {x:?}: {a:?} vs {b:?}",
                    instance.name()
                );
            }
            // the same Jacobians, and each right by its own crate's check
            let (mut fx, mut fu) = (vec![0.0; n * n], vec![0.0; n]);
            assert!(model.jacobians(&x, &u, &mut fx, &mut fu).expect("jacobians"));
            let (mut gx, mut gu) = (vec![0.0; n * n], vec![0.0; n]);
            assert!(dyn_.jacobians(&x, &u, &mut gx, &mut gu).expect("jacobians"));
            for (p, q) in fx.iter().chain(&fu).zip(gx.iter().chain(&gu)) {
                assert!((p - q).abs() <= 1e-12 * (1.0 + q.abs()), "{} {x:?}", instance.name());
            }
            let worst = check_model_jacobians(model, &x, &u).expect("check").expect("analytic");
            assert!(worst.max_rel_error < 1e-6, "{} {x:?}: {worst:?}", instance.name());
            let (cx, cu) = check_dynamics(dyn_, &x, &u).expect("check");
            assert!(
                cx.max_rel_error < 1e-6 && cu.max_rel_error < 1e-6,
                "{} {x:?}: {cx:?} {cu:?}",
                instance.name()
            );
        }
    }
}

#[test]
fn costs_agree_stage_by_stage_on_the_same_trajectory() {
    for instance in trajectory::standard_instances() {
        let (problem, _) = instance.problem().expect("problem");
        let ddp_problem = ddp_twin(&instance).problem().expect("problem");
        let n_steps = problem.horizon();
        // a swinging rollout of the DDP model: consistent, from the start
        let controls: Vec<Vec<f64>> = (0..n_steps).map(|k| vec![4.0 * (0.07 * k as f64).sin()]).collect();
        let stacked: Vec<f64> = controls.iter().flatten().copied().collect();
        let states = ddp_problem.rollout_stacked(&stacked).expect("rollout");
        let (stages, terminal) = eq3_stage_costs(&problem, &states, &controls);
        let cost = ddp_problem.cost();
        for k in 0..n_steps {
            let want = ddp::Cost::running(cost, k, &states[k], &controls[k]);
            assert!(
                (stages[k] - want).abs() <= 1e-12 * want.max(1e-12),
                "{} stage {k}",
                instance.name()
            );
        }
        let want = ddp::Cost::terminal(cost, &states[n_steps]);
        assert!((terminal - want).abs() <= 1e-12 * want, "{} terminal", instance.name());
        // the whole criterion: consistent and from the start, so C = task = J
        let theta = parameters_of(&problem, &states, &controls).expect("parameters");
        let parts = problem.cost_breakdown(&theta).expect("cost");
        let j = ddp_problem.rollout_cost(&controls).expect("cost");
        assert!(
            (parts.task - j).abs() <= 1e-10 * j,
            "{}: {} vs {j}",
            instance.name(),
            parts.task
        );
        assert!(
            (parts.total - j).abs() <= 1e-8 * j,
            "{}: {parts:?} vs {j}",
            instance.name()
        );
    }
}

/// Largest $|x_{N,i} - x^r_i|$.
fn end_error(end: &[f64], target: &[f64]) -> f64 {
    end.iter().zip(target).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max)
}

/// Each system's shortest standard horizon, solved by Gauss-Newton on
/// Eq. 3 at $\lambda = 100$ from the rest start, and by DDP (iLQR) from
/// the zero warm start and from Gauss-Newton's controls, DDP's answer the
/// cheaper of the two (on the acrobot, iLQR from zero controls stops in a
/// worse local minimum, short of upright; the test prints both costs). Both answers end within 0.2 (rad, m,
/// rad/s, m/s) of upright, Gauss-Newton's plan nearly obeys the dynamics,
/// its controls replayed open loop on DDP's model cost within 10% of DDP's
/// optimum, and DDP's optimum costs the same in the Eq. 3 form. Wrong
/// dynamics in either crate (a sign, a mass, the state order) break the
/// end state or the costs.
#[test]
fn both_solvers_swing_each_system_up_at_comparable_cost() {
    for system in trajectory::System::ALL {
        let horizon = system.standard_horizons()[0];
        let instance = trajectory::Instance {
            system,
            horizon,
            lambda: 100.0,
        };
        let name = instance.name();
        let target = system.weights().target;
        let ddp_problem = ddp_twin(&instance).problem().expect("problem");
        let (problem, theta0) = instance.problem().expect("problem");
        let plan = gauss_newton_plan(&problem, &theta0, 500);
        let (g, parts, xs, us) = (plan.result, plan.parts, plan.states, plan.controls);
        let gn_end = end_error(
            &(0..target.len()).map(|i| xs[(horizon, i)]).collect::<Vec<_>>(),
            &target,
        );
        let gn_controls: Vec<Vec<f64>> = (0..horizon).map(|k| vec![us[(k, 0)]]).collect();
        let replayed = ddp_problem.rollout_cost(&gn_controls).expect("cost");

        let settings = ddp::DdpSettings {
            max_iterations: 500,
            ..ddp::DdpSettings::default()
        };
        let solver = ddp::Ddp::new(settings).expect("settings");
        let from_zero = solver.solve(&ddp_problem).expect("solve");
        let warm = ddp_problem
            .clone()
            .with_initial_controls(gn_controls)
            .expect("warm start");
        let from_gn = solver.solve(&warm).expect("solve");
        let zero_cost = from_zero.cost;
        let d = if from_gn.cost < from_zero.cost {
            from_gn
        } else {
            from_zero
        };
        assert!(!d.status.is_failure(), "{name}: {:?}", d.status);
        let ddp_end = end_error(&d.states[horizon], &target);

        // DDP's optimum in Eq. 3 form: consistent, so C = J
        let ddp_theta = parameters_of(&problem, &d.states, &d.controls).expect("parameters");
        let c_at_ddp = problem.cost(&ddp_theta).expect("cost");
        eprintln!(
            "{name}: DDP J {} (from zero {zero_cost}; {:?}, {} it, end {ddp_end:.3e}); GN C {} task {} ({:?}, {} it, end {gn_end:.3e}, \
             mismatch {:.2e}), replayed on DDP's model {replayed}; C at DDP's optimum {c_at_ddp}",
            d.cost, d.status, d.iterations, g.cost, parts.task, g.status, g.iterations, parts.max_mismatch
        );
        assert!(
            (c_at_ddp - d.cost).abs() <= 1e-8 * d.cost,
            "{name}: {c_at_ddp} vs {}",
            d.cost
        );
        assert!(ddp_end < 0.2 && gn_end < 0.2, "{name}: ends {ddp_end} {gn_end}");
        assert!(parts.max_mismatch < 1e-3, "{name}: {parts:?}");
        assert!(
            (replayed - d.cost).abs() <= 0.1 * d.cost,
            "{name}: GN's controls cost {replayed} on DDP's model, DDP {}",
            d.cost
        );
    }
}
