//! The systems against independent references: the Euler Jacobians against
//! central differences of the step, the energies against the Cartesian
//! energies of the point masses, energy conservation of the unforced
//! continuous dynamics, the equilibria, and the pendulum's small-oscillation
//! period $2\pi\sqrt{l/g}$.

use proptest::collection::vec;
use proptest::prelude::*;
use systems::{Acrobot, CartPole, DT, Mechanics, Pendulum, STANDARD_LAMBDAS, SwingUpModel, System};

/// Central differences of the step over $z = (x, u)$, row-major
/// $n \times (n + 1)$.
fn differenced(model: &impl Mechanics, x: &[f64], u: &[f64]) -> Vec<f64> {
    let n = x.len();
    let z: Vec<f64> = x.iter().chain(u).copied().collect();
    let mut jac = vec![0.0; n * (n + 1)];
    let (mut plus, mut minus) = (vec![0.0; n], vec![0.0; n]);
    for j in 0..=n {
        let h = 1e-6 * z[j].abs().max(1.0);
        let (mut zp, mut zm) = (z.clone(), z.clone());
        zp[j] += h;
        zm[j] -= h;
        model.euler_step(&zp[..n], &zp[n..], &mut plus);
        model.euler_step(&zm[..n], &zm[n..], &mut minus);
        for i in 0..n {
            jac[i * (n + 1) + j] = (plus[i] - minus[i]) / (2.0 * h);
        }
    }
    jac
}

fn check_jacobians(model: &impl Mechanics, x: &[f64], u: &[f64]) -> Result<(), TestCaseError> {
    let n = model.n_x();
    prop_assert_eq!(n, x.len());
    let (mut fx, mut fu) = (vec![f64::NAN; n * n], vec![f64::NAN; n]);
    model.euler_jacobians(x, u, &mut fx, &mut fu);
    let fd = differenced(model, x, u);
    for i in 0..n {
        for j in 0..=n {
            let exact = if j < n { fx[i * n + j] } else { fu[i] };
            let diff = fd[i * (n + 1) + j];
            prop_assert!(
                (exact - diff).abs() < 1e-7 * (1.0 + diff.abs()),
                "row {i} col {j}: {exact} vs {diff}"
            );
        }
    }
    Ok(())
}

proptest! {
    #[test]
    fn pendulum_jacobians_are_central_differences(x in vec(-4.0..4.0f64, 2), u in -5.0..5.0f64,
                                                  damping in 0.0..0.5f64, mass in 0.5..2.0f64) {
        check_jacobians(&Pendulum { damping, mass, dt: 0.05, ..Pendulum::default() }, &x, &[u])?;
    }

    #[test]
    fn cart_pole_jacobians_are_central_differences(x in vec(-4.0..4.0f64, 4), u in -10.0..10.0f64,
                                                   pole_mass in 0.05..1.0f64, length in 0.3..1.5f64) {
        check_jacobians(&CartPole { pole_mass, length, dt: 0.05, ..CartPole::default() }, &x, &[u])?;
    }

    #[test]
    fn acrobot_jacobians_are_central_differences(x in vec(-4.0..4.0f64, 4), u in -10.0..10.0f64,
                                                 mass1 in 0.5..2.0f64, length2 in 0.5..1.5f64) {
        check_jacobians(&Acrobot { mass1, length2, dt: 0.05, ..Acrobot::default() }, &x, &[u])?;
    }

    #[test]
    fn swing_up_models_jacobians_are_central_differences(x in vec(-3.0..3.0f64, 4), u in -10.0..10.0f64) {
        for system in System::ALL {
            let model = system.model();
            check_jacobians(&model, &x[..model.n_x()], &[u])?;
        }
    }

    /// The curvature is the theta-derivative of the contracted Jacobian's
    /// (theta) column, by central differences.
    #[test]
    fn pendulum_curvature_is_the_derivative_of_its_jacobian(x in vec(-4.0..4.0f64, 2), v in vec(-3.0..3.0f64, 2)) {
        let p = Pendulum { dt: 0.05, ..Pendulum::default() };
        let column = |theta: f64| {
            let (mut fx, mut fu) = ([0.0; 4], [0.0; 2]);
            p.euler_jacobians(&[theta, x[1]], &[0.0], &mut fx, &mut fu);
            v[0] * fx[0] + v[1] * fx[2]
        };
        let h = 1e-5;
        let diff = (column(x[0] + h) - column(x[0] - h)) / (2.0 * h);
        let exact = p.euler_curvature(&x, &v);
        prop_assert!((exact - diff).abs() < 1e-7, "{exact} vs {diff}");
    }
}

/// Kinetic plus potential energy of point masses at `(px, py)` moving at
/// `(vx, vy)`, `y` up.
fn cartesian(gravity: f64, masses: &[(f64, [f64; 2], [f64; 2])]) -> f64 {
    masses
        .iter()
        .map(|(m, p, v)| 0.5 * m * (v[0] * v[0] + v[1] * v[1]) + m * gravity * p[1])
        .sum()
}

#[test]
fn energies_match_the_cartesian_energies() {
    let states: [[f64; 4]; 3] = [[0.3, -1.2, 2.0, -0.5], [2.9, 0.4, -1.0, 3.0], [0.0; 4]];
    for x in states {
        let p = Pendulum {
            mass: 0.7,
            length: 1.3,
            ..Pendulum::default()
        };
        let (l, th, w) = (p.length, x[0], x[1]);
        let want = cartesian(
            p.gravity,
            &[(
                p.mass,
                [l * th.sin(), -l * th.cos()],
                [l * th.cos() * w, l * th.sin() * w],
            )],
        );
        assert!((p.energy(&x[..2]) - want).abs() < 1e-12, "pendulum at {x:?}");

        let c = CartPole {
            pole_mass: 0.3,
            length: 0.8,
            ..CartPole::default()
        };
        let (l, th, v, w) = (c.length, x[1], x[2], x[3]);
        let want = cartesian(
            c.gravity,
            &[
                (c.cart_mass, [x[0], 0.0], [v, 0.0]),
                (
                    c.pole_mass,
                    [x[0] + l * th.sin(), -l * th.cos()],
                    [v + l * th.cos() * w, l * th.sin() * w],
                ),
            ],
        );
        assert!((c.energy(&x) - want).abs() < 1e-12, "cart-pole at {x:?}");

        let a = Acrobot {
            mass1: 0.7,
            length2: 1.3,
            ..Acrobot::default()
        };
        let (t1, t12, w1, w12) = (x[0], x[0] + x[1], x[2], x[2] + x[3]);
        let p1 = [a.length1 * t1.sin(), -a.length1 * t1.cos()];
        let v1 = [a.length1 * t1.cos() * w1, a.length1 * t1.sin() * w1];
        let p2 = [p1[0] + a.length2 * t12.sin(), p1[1] - a.length2 * t12.cos()];
        let v2 = [v1[0] + a.length2 * t12.cos() * w12, v1[1] + a.length2 * t12.sin() * w12];
        let want = cartesian(a.gravity, &[(a.mass1, p1, v1), (a.mass2, p2, v2)]);
        assert!((a.energy(&x) - want).abs() < 1e-12, "acrobot at {x:?}");
    }
}

/// The worst relative energy error over 1 s of unforced Euler steps.
fn drift(model: &impl Mechanics, energy: impl Fn(&[f64]) -> f64, x0: &[f64], dt: f64) -> f64 {
    let (mut x, mut next) = (x0.to_vec(), vec![0.0; x0.len()]);
    let e0 = energy(&x);
    let mut worst: f64 = 0.0;
    for _ in 0..(1.0 / dt).round() as usize {
        model.euler_step(&x, &[0.0], &mut next);
        std::mem::swap(&mut x, &mut next);
        worst = worst.max((energy(&x) - e0).abs());
    }
    worst / e0.abs()
}

/// Semi-implicit Euler is first order: the energy error shrinks with the step.
#[test]
fn unforced_steps_conserve_energy_as_dt_shrinks() {
    let x0 = [2.0, -0.7, 0.5, 1.0];
    let errors = |dt: f64| {
        let p = Pendulum {
            dt,
            ..Pendulum::default()
        };
        let c = CartPole {
            dt,
            ..CartPole::default()
        };
        let a = Acrobot {
            dt,
            ..Acrobot::default()
        };
        [
            drift(&p, |x| p.energy(x), &x0[..2], dt),
            drift(&c, |x| c.energy(x), &x0, dt),
            drift(&a, |x| a.energy(x), &x0, dt),
        ]
    };
    let (coarse, fine) = (errors(1e-3), errors(1e-4));
    for (c, f) in coarse.iter().zip(fine) {
        assert!(f < 2e-3, "{f}");
        assert!(f < 0.2 * c, "{c} -> {f}");
    }
}

#[test]
fn hanging_and_upright_are_fixed_points_and_controls_push_the_right_way() {
    let pi = std::f64::consts::PI;
    let cases: [(SwingUpModel, Vec<[f64; 4]>); 3] = [
        (System::Pendulum.model(), vec![[0.0; 4], [pi, 0.0, 0.0, 0.0]]),
        (
            System::CartPole.model(),
            vec![[0.5, 0.0, 0.0, 0.0], [0.0, pi, 0.0, 0.0]],
        ),
        (System::Acrobot.model(), vec![[0.0; 4], [pi, 0.0, 0.0, 0.0]]),
    ];
    for (model, states) in cases {
        let n = model.n_x();
        let mut next = vec![0.0; n];
        for x in states {
            model.euler_step(&x[..n], &[0.0], &mut next);
            for i in 0..n {
                assert!((next[i] - x[i]).abs() < 1e-14, "{model:?} at {x:?} -> {next:?}");
            }
        }
    }
    let mut next = [0.0; 4];
    // a push on the cart moves it forward and swings the hanging pole back
    System::CartPole.model().euler_step(&[0.0; 4], &[1.0], &mut next);
    assert!(next[2] > 0.0 && next[3] < 0.0, "{next:?}");
    // elbow torque swings the second link one way and the first the other
    System::Acrobot.model().euler_step(&[0.0; 4], &[1.0], &mut next);
    assert!(next[3] > 0.0 && next[2] < 0.0, "{next:?}");
}

/// A small swing lasts $2\pi\sqrt{l/g}$: the time from the release at
/// rest to the next turn at rest is half of it.
#[test]
fn pendulum_small_oscillations_have_the_linear_period() {
    let p = Pendulum {
        length: 0.8,
        dt: 1e-5,
        ..Pendulum::default()
    };
    let (mut x, mut next) = ([0.01, 0.0], [0.0; 2]);
    let mut t = 0.0;
    loop {
        p.euler_step(&x, &[0.0], &mut next);
        t += p.dt;
        if next[1] >= 0.0 && x[1] < 0.0 {
            break;
        }
        x = next;
    }
    let half_period = std::f64::consts::PI * (p.length / p.gravity).sqrt();
    assert!((t - half_period).abs() < 1e-3 * half_period, "{t} vs {half_period}");
}

#[test]
fn registry_data_is_consistent() {
    assert_eq!(DT, 0.01);
    assert!(STANDARD_LAMBDAS.iter().all(|l| l.is_finite() && *l > 0.0));
    for system in System::ALL {
        let (model, w) = (system.model(), system.weights());
        let n = model.n_x();
        for v in [&w.state, &w.terminal, &w.target, &w.initial_state] {
            assert_eq!(v.len(), n, "{system:?}");
        }
        assert_eq!(w.control.len(), model.n_u());
        assert_eq!(model.dt(), DT);
        assert!(w.initial_state.iter().all(|&x| x == 0.0));
        // the target is an equilibrium without control
        let mut next = vec![0.0; n];
        model.euler_step(&w.target, &[0.0], &mut next);
        assert!(
            next.iter().zip(&w.target).all(|(a, b)| (a - b).abs() < 1e-12),
            "{system:?}"
        );
        assert!(
            system
                .instance_name(system.standard_horizons()[0])
                .starts_with(system.name())
        );
    }
}
