use std::f64::consts::PI;

use super::*;
use crate::check::{check_jacobian, check_model_jacobians};

#[test]
fn model_jacobians_match_central_differences() {
    let points = [[0.7, -1.3, 2.0, 0.4], [3.0, 0.2, -1.5, 2.5], [-2.2, 2.9, 0.1, -3.0]];
    for system in System::ALL {
        // coarser steps make the discrete Jacobians less close to identity
        let model = match system.model() {
            SwingUpModel::Pendulum(p) => SwingUpModel::Pendulum(Pendulum {
                dt: 0.05,
                damping: 0.3,
                ..p
            }),
            SwingUpModel::CartPole(c) => SwingUpModel::CartPole(CartPole { dt: 0.05, ..c }),
            SwingUpModel::Acrobot(a) => SwingUpModel::Acrobot(Acrobot {
                dt: 0.05,
                mass1: 0.6,
                length2: 1.4,
                ..a
            }),
        };
        for p in points {
            let worst = check_model_jacobians(&model, &p[..model.state_dim()], &[1.7])
                .expect("check")
                .expect("analytic");
            assert!(worst.max_rel_error < 1e-7, "{system:?} at {p:?}: {worst:?}");
        }
    }
}

#[test]
fn eq3_jacobians_and_gradients_match_central_differences() {
    for system in System::ALL {
        let (problem, theta0) = system.problem(6, 3.0).expect("problem");
        let theta: Vec<f64> = theta0
            .iter()
            .enumerate()
            .map(|(i, v)| v + (0.7 * i as f64).sin())
            .collect();
        let worst = check_jacobian(&problem, &theta).expect("check");
        assert!(worst.max_rel_error < 1e-6, "{system:?}: {worst:?}");
        let g = problem.gradient(&theta).expect("gradient");
        for (j, &gj) in g.iter().enumerate() {
            let h = 1e-5;
            let (mut p, mut m) = (theta.clone(), theta.clone());
            p[j] += h;
            m[j] -= h;
            let fd = (problem.cost(&p).expect("cost") - problem.cost(&m).expect("cost")) / (2.0 * h);
            assert!(
                (fd - gj).abs() <= 1e-6 * gj.abs().max(1.0),
                "{system:?} d/d theta{j}: {gj} vs {fd}"
            );
        }
    }
}

#[test]
fn equilibria_are_fixed_points() {
    for system in System::ALL {
        let model = system.model();
        let w = system.weights();
        let mut next = vec![0.0; w.target.len()];
        for x in [&w.initial_state, &w.target] {
            model.step(x, &[0.0], &mut next).expect("step");
            for (a, b) in next.iter().zip(x.iter()) {
                assert!((a - b).abs() < 1e-14, "{system:?}: {x:?} -> {next:?}");
            }
        }
    }
}

#[test]
fn cartpole_linearisation_at_upright_is_the_hand_derived_one() {
    // phi = theta - pi small: xdd = (f + mp g phi) / mc, thdd = (f + (mc + mp) g phi) / (l mc);
    // semi-implicit Euler: A = [[I + dt^2 Aq, dt I], [dt Aq, I]], B = [dt^2 b; dt b]
    let c = CartPole::default();
    let (mc, mp, l, g, dt) = (c.cart_mass, c.pole_mass, c.length, c.gravity, c.dt);
    let aq = [[0.0, mp * g / mc], [0.0, (mc + mp) * g / (l * mc)]];
    let b = [1.0 / mc, 1.0 / (l * mc)];
    let mut a_hand = [[0.0; 4]; 4];
    for i in 0..2 {
        for j in 0..2 {
            let id = if i == j { 1.0 } else { 0.0 };
            a_hand[i][j] = id + dt * dt * aq[i][j];
            a_hand[i][2 + j] = dt * id;
            a_hand[2 + i][j] = dt * aq[i][j];
            a_hand[2 + i][2 + j] = id;
        }
    }
    let b_hand = [dt * dt * b[0], dt * dt * b[1], dt * b[0], dt * b[1]];
    let (mut fx, mut fu) = (vec![0.0; 16], vec![0.0; 4]);
    c.jacobians(&[0.0, PI, 0.0, 0.0], &[0.0], &mut fx, &mut fu)
        .expect("jacobians");
    for i in 0..4 {
        for j in 0..4 {
            assert!((fx[i * 4 + j] - a_hand[i][j]).abs() < 1e-14, "A[{i}][{j}]");
        }
        assert!((fu[i] - b_hand[i]).abs() < 1e-14, "B[{i}]");
    }
}

#[test]
fn frictionless_energy_drift_shrinks_with_the_step() {
    // 1 s without control from a swinging state; the energy error of
    // semi-implicit Euler is O(dt)
    let energy = |m: &SwingUpModel, x: &[f64]| match m {
        SwingUpModel::Pendulum(p) => {
            0.5 * p.mass * (p.length * x[1]).powi(2) - p.mass * p.gravity * p.length * x[0].cos()
        }
        SwingUpModel::Acrobot(a) => a.energy(x),
        SwingUpModel::CartPole(c) => {
            // cart and tip velocities, tip height -l cos(theta)
            let (vx, vy) = (x[2] + c.length * x[1].cos() * x[3], c.length * x[1].sin() * x[3]);
            0.5 * c.cart_mass * x[2] * x[2] + 0.5 * c.pole_mass * (vx * vx + vy * vy)
                - c.pole_mass * c.gravity * c.length * x[1].cos()
        }
    };
    for system in System::ALL {
        let drift = |dt: f64| {
            let model = match system.model() {
                SwingUpModel::Pendulum(p) => SwingUpModel::Pendulum(Pendulum { dt, ..p }),
                SwingUpModel::CartPole(c) => SwingUpModel::CartPole(CartPole { dt, ..c }),
                SwingUpModel::Acrobot(a) => SwingUpModel::Acrobot(Acrobot { dt, ..a }),
            };
            let n = model.state_dim();
            let (mut x, mut next) = ([2.0, -0.7, 0.5, 1.0][..n].to_vec(), vec![0.0; n]);
            let e0 = energy(&model, &x);
            let mut worst: f64 = 0.0;
            for _ in 0..(1.0 / dt).round() as usize {
                model.step(&x, &[0.0], &mut next).expect("step");
                std::mem::swap(&mut x, &mut next);
                worst = worst.max((energy(&model, &x) - e0).abs());
            }
            worst / e0.abs().max(1.0)
        };
        let (coarse, fine) = (drift(1e-3), drift(1e-4));
        assert!(fine < 5e-3 && fine < 0.2 * coarse, "{system:?}: {coarse} -> {fine}");
    }
}

#[test]
fn parameters_are_the_samples_and_the_start_is_consistent() {
    for system in System::ALL {
        let (problem, theta0) = system.problem(20, 100.0).expect("problem");
        let n = problem.model().state_dim();
        let states: Vec<Vec<f64>> = (0..=20)
            .map(|k| (0..n).map(|i| (0.3 * (k + i) as f64).sin()).collect())
            .collect();
        let controls: Vec<Vec<f64>> = (0..20).map(|k| vec![(0.2 * k as f64).cos()]).collect();
        let theta = parameters_of(&problem, &states, &controls).expect("parameters");
        let (xs, us) = problem.trajectory(&theta).expect("trajectory");
        for k in 0..=20 {
            for i in 0..n {
                assert!((xs[(k, i)] - states[k][i]).abs() < 1e-14);
            }
        }
        for k in 0..20 {
            assert!((us[(k, 0)] - controls[k][0]).abs() < 1e-14);
        }
        // the start is the rest state, consistent: C = task = 20 stages + terminal
        let parts = problem.cost_breakdown(&theta0).expect("cost");
        let w = system.weights();
        let sq = |q: &[f64]| q.iter().zip(&w.target).map(|(q, t)| q * t * t).sum::<f64>();
        assert_eq!((parts.inconsistency, parts.initial_state), (0.0, 0.0));
        assert!((parts.task - (20.0 * sq(&w.state) + sq(&w.terminal))).abs() < 1e-12);
        assert!(parameters_of(&problem, &states[1..], &controls).is_err());
    }
}

#[test]
fn invalid_horizons_and_lambdas_are_named_errors() {
    for (h, l, name) in [(1, 1.0, "horizon"), (10, 0.0, "lambda"), (10, f64::NAN, "lambda")] {
        match System::Pendulum.problem(h, l) {
            Err(TrajoptError::InvalidParameter { name: got, .. }) => assert_eq!(got, name),
            other => panic!("{h} {l}: {other:?}"),
        }
    }
}

#[test]
fn registry_names_are_unique_and_found() {
    let all = standard_instances();
    assert_eq!(all.len(), 8 * STANDARD_LAMBDAS.len());
    for i in &all {
        assert_eq!(by_name(&i.name()).ok(), Some(*i));
        assert!(i.name().starts_with(&format!("{}-lambda", i.ddp_name())));
    }
    assert_eq!(
        by_name("pendulum-h50-lambda1e2").ok(),
        Some(Instance {
            system: System::Pendulum,
            horizon: 50,
            lambda: 100.0
        })
    );
    assert!(matches!(
        by_name("pendulum-h50"),
        Err(TrajoptError::InvalidParameter {
            name: "instance name",
            ..
        })
    ));
}
