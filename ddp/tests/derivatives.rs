//! Analytic derivatives of the built-in costs and dynamics equal central
//! differences ([`ddp::strategies::check_jacobian`]), and the default
//! finite-difference derivatives of [`Dynamics`] equal the analytic ones.

use ddp::strategies::{JacobianCheck, check_dynamics, check_jacobian};
use ddp::{Acrobot, CartPole, Cost, CostDerivatives, Dynamics, Pendulum, QuadraticCost, Result};
use faer::Mat;
use proptest::collection::vec;
use proptest::prelude::*;
use systems::jacobians_or_differences;

fn assert_close(what: &str, check: JacobianCheck, tol: f64) -> Result<(), TestCaseError> {
    prop_assert!(check.max_rel_error <= tol, "{what}: {check:?}");
    Ok(())
}

/// Checks the Jacobians (and the weighted second derivative if provided) of `f` at `(x, u)`.
fn check_model<D: Dynamics>(f: &D, x: &[f64], u: &[f64], v: &[f64]) -> Result<(), TestCaseError> {
    let (n, m) = (f.state_dim(), f.control_dim());
    let (cx, cu) = check_dynamics(f, x, u).expect("sizes");
    assert_close("fx", cx, 1e-7)?;
    assert_close("fu", cu, 1e-7)?;
    let z = n + m;
    let mut hzz = vec![0.0; z * z];
    if f.weighted_hessian(x, u, v, &mut hzz).expect("second derivatives") {
        // the blocks of the packed (n + m) x (n + m) matrix
        let block = |rows: std::ops::Range<usize>, cols: std::ops::Range<usize>| -> Vec<f64> {
            rows.flat_map(|i| cols.clone().map(move |j| (i, j)))
                .map(|(i, j)| hzz[i * z + j])
                .collect()
        };
        let (hxx, hux, huu) = (block(0..n, 0..n), block(n..z, 0..n), block(n..z, n..z));
        let hxu = block(0..n, n..z);
        for a in 0..m {
            for j in 0..n {
                prop_assert_eq!(hxu[j * m + a], hux[a * n + j], "symmetric");
            }
        }
        // d/dx (v^T f_x), d/dx (v^T f_u), d/du (v^T f_u)
        let vt = |a: &[f64], cols: usize| {
            (0..cols)
                .map(|j| (0..n).map(|i| v[i] * a[i * cols + j]).sum())
                .collect()
        };
        let vfx = |x: &[f64], u: &[f64]| -> (Vec<f64>, Vec<f64>) {
            let (mut fx, mut fu) = (vec![0.0; n * n], vec![0.0; n * m]);
            jacobians_or_differences(f, x, u, &mut fx, &mut fu).expect("derivatives");
            (vt(&fx, n), vt(&fu, m))
        };
        assert_close("fxx", check_jacobian(|z| vfx(z, u).0, x, &hxx).expect("sizes"), 1e-6)?;
        assert_close("fux", check_jacobian(|z| vfx(z, u).1, x, &hux).expect("sizes"), 1e-6)?;
        assert_close("fuu", check_jacobian(|z| vfx(x, z).1, u, &huu).expect("sizes"), 1e-6)?;
    }
    Ok(())
}

fn sym(n: usize, e: &[f64], shift: f64) -> Mat<f64> {
    Mat::from_fn(n, n, |i, j| {
        e[i.min(j) * n + i.max(j)] + if i == j { shift } else { 0.0 }
    })
}

#[test]
fn check_jacobian_finds_a_wrong_entry_and_rejects_wrong_sizes() {
    let p = Pendulum::default();
    let (x, u) = ([0.4, -1.0], [0.5]);
    let (mut fx, mut fu) = ([0.0; 4], [0.0; 2]);
    assert!(p.jacobians(&x, &u, &mut fx, &mut fu).expect("derivatives"));
    let step = |z: &[f64]| {
        let mut next = vec![0.0; 2];
        p.step(z, &u, &mut next).expect("step");
        next
    };
    assert!(check_jacobian(step, &x, &fx).expect("sizes").max_rel_error < 1e-8);
    fx[2] += 1e-3;
    let bad = check_jacobian(step, &x, &fx).expect("sizes");
    assert_eq!((bad.row, bad.col), (1, 0));
    assert!((bad.max_rel_error - 1e-3).abs() < 1e-6, "{bad:?}");
    assert_eq!(bad.analytic, fx[2]);
    assert!(check_jacobian(step, &x, &fx[..3]).is_err());
    fx[2] = f64::NAN;
    // a NaN entry is the worst error of all, reported as NaN (no tolerance passes it)
    let nan = check_jacobian(step, &x, &fx).expect("sizes");
    assert!(nan.max_rel_error.is_nan() && (nan.row, nan.col) == (1, 0), "{nan:?}");
    assert!(check_dynamics(&p, &[0.0], &u).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn pendulum_derivatives(x in vec(-4.0..4.0f64, 2), u in vec(-5.0..5.0f64, 1), v in vec(-3.0..3.0f64, 2),
                            damping in 0.0..0.5f64, mass in 0.5..2.0f64) {
        let p = Pendulum { damping, mass, dt: 0.05, ..Pendulum::default() };
        check_model(&p, &x, &u, &v)?;
    }

    #[test]
    fn cartpole_derivatives(x in vec(-3.0..3.0f64, 4), u in vec(-10.0..10.0f64, 1)) {
        check_model(&CartPole { dt: 0.05, ..CartPole::default() }, &x, &u, &[0.0; 4])?;
    }

    #[test]
    fn acrobot_derivatives(x in vec(-4.0..4.0f64, 4), u in vec(-10.0..10.0f64, 1),
                           mass1 in 0.5..2.0f64, length2 in 0.5..1.5f64) {
        let a = Acrobot { mass1, length2, dt: 0.05, ..Acrobot::default() };
        check_model(&a, &x, &u, &[0.0; 4])?;
    }

    #[test]
    fn swingup_models_derivatives(x in vec(-3.0..3.0f64, 4), u in vec(-10.0..10.0f64, 1)) {
        for system in ddp::problems::System::ALL {
            let model = system.model();
            let n = model.state_dim();
            check_model(&model, &x[..n], &u, &x[..n])?;
        }
    }

    /// Central differences of `step` (for a model without Jacobians) equal
    /// the analytic Jacobians.
    #[test]
    fn default_derivatives_are_central_differences(x in vec(-4.0..4.0f64, 2), u in vec(-5.0..5.0f64, 1)) {
        let p = Pendulum { damping: 0.1, dt: 0.05, ..Pendulum::default() };
        let (mut fx, mut fu) = ([0.0; 4], [0.0; 2]);
        prop_assert!(p.jacobians(&x, &u, &mut fx, &mut fu).expect("analytic"));
        let (mut dx, mut du) = ([0.0; 4], [0.0; 2]);
        prop_assert!(!jacobians_or_differences(&systems::StepOnly(p), &x, &u, &mut dx, &mut du).expect("differences"));
        for (a, d) in fx.iter().chain(&fu).zip(dx.iter().chain(&du)) {
            prop_assert!((a - d).abs() <= 1e-8 * a.abs().max(1.0), "{fx:?} {fu:?} vs {dx:?} {du:?}");
        }
    }

    #[test]
    fn quadratic_cost_derivatives(
        (n, m) in (1..4usize, 1..3usize),
        q in vec(-1.0..1.0f64, 9), r in vec(-1.0..1.0f64, 4), qf in vec(-1.0..1.0f64, 9),
        x in vec(-2.0..2.0f64, 3), u in vec(-2.0..2.0f64, 2),
        xr in vec(-1.0..1.0f64, 3), ur in vec(-1.0..1.0f64, 2), k in 0..5usize,
    ) {
        let cost = QuadraticCost::new(&sym(n, &q, 1.0), &sym(m, &r, 1.0), &sym(n, &qf, 0.0))
            .expect("symmetric")
            .with_state_reference(vec![vec![0.0; n], xr[..n].to_vec()])
            .expect("sizes")
            .with_control_reference(vec![ur[..m].to_vec()])
            .expect("sizes");
        let (x, u) = (&x[..n], &u[..m]);
        let mut d = CostDerivatives::zeros(n, m);
        cost.running_derivatives(k, x, u, &mut d);
        let check = |what, f: &dyn Fn(&[f64]) -> Vec<f64>, z: &[f64], analytic: &[f64]| {
            assert_close(what, check_jacobian(f, z, analytic).expect("sizes"), 1e-7)
        };
        check("lx", &|z| vec![cost.running(k, z, u)], x, &d.lx)?;
        check("lu", &|z| vec![cost.running(k, x, z)], u, &d.lu)?;
        let grads = |x: &[f64], u: &[f64]| {
            let mut d = CostDerivatives::zeros(n, m);
            cost.running_derivatives(k, x, u, &mut d);
            d
        };
        check("lxx", &|z| grads(z, u).lx, x, &d.lxx)?;
        check("luu", &|z| grads(x, z).lu, u, &d.luu)?;
        check("lux", &|z| grads(z, u).lu, x, &d.lux)?;
        let (mut lx, mut lxx) = (vec![0.0; n], vec![0.0; n * n]);
        cost.terminal_derivatives(x, &mut lx, &mut lxx);
        check("lfx", &|z| vec![cost.terminal(z)], x, &lx)?;
        let tgrad = |z: &[f64]| {
            let (mut g, mut h) = (vec![0.0; n], vec![0.0; n * n]);
            cost.terminal_derivatives(z, &mut g, &mut h);
            g
        };
        check("lfxx", &tgrad, x, &lxx)?;
    }
}
