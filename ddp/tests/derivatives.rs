//! Analytic derivatives of the built-in costs and dynamics equal central
//! differences.

use ddp::{CartPole, Cost, CostDerivatives, Dynamics, Pendulum, QuadraticCost};
use faer::Mat;
use proptest::collection::vec;
use proptest::prelude::*;

const H: f64 = 1e-6;

/// Central-difference Jacobian of `f: R^p -> R^q` at `z` (row-major q x p).
fn jacobian(f: impl Fn(&[f64]) -> Vec<f64>, z: &[f64]) -> Vec<f64> {
    let p = z.len();
    let q = f(z).len();
    let mut jac = vec![0.0; q * p];
    for j in 0..p {
        let (mut zp, mut zm) = (z.to_vec(), z.to_vec());
        zp[j] += H;
        zm[j] -= H;
        let (fp, fm) = (f(&zp), f(&zm));
        for i in 0..q {
            jac[i * p + j] = (fp[i] - fm[i]) / (2.0 * H);
        }
    }
    jac
}

fn assert_close(what: &str, analytic: &[f64], numeric: &[f64], tol: f64) -> Result<(), TestCaseError> {
    prop_assert_eq!(analytic.len(), numeric.len());
    for (i, (a, b)) in analytic.iter().zip(numeric).enumerate() {
        prop_assert!(
            (a - b).abs() <= tol * (1.0 + b.abs()),
            "{what}[{i}]: analytic {a}, numeric {b}"
        );
    }
    Ok(())
}

/// Checks `derivatives` (and `second_derivatives` if provided) of `f` at `(x, u)`.
fn check_dynamics<D: Dynamics>(f: &D, x: &[f64], u: &[f64], v: &[f64]) -> Result<(), TestCaseError> {
    let (n, m) = (f.state_dim(), f.control_dim());
    let step = |x: &[f64], u: &[f64]| {
        let mut next = vec![0.0; n];
        f.step(x, u, &mut next);
        next
    };
    let (mut fx, mut fu) = (vec![0.0; n * n], vec![0.0; n * m]);
    f.derivatives(x, u, &mut fx, &mut fu);
    assert_close("fx", &fx, &jacobian(|z| step(z, u), x), 1e-6)?;
    assert_close("fu", &fu, &jacobian(|z| step(x, z), u), 1e-6)?;
    let (mut hxx, mut hux, mut huu) = (vec![0.0; n * n], vec![0.0; m * n], vec![0.0; m * m]);
    if f.second_derivatives(x, u, v, &mut hxx, &mut hux, &mut huu) {
        // d/dx (v^T f_x), d/dx (v^T f_u), d/du (v^T f_u)
        let vt = |a: &[f64], cols: usize| {
            (0..cols)
                .map(|j| (0..n).map(|i| v[i] * a[i * cols + j]).sum())
                .collect()
        };
        let vfx = |x: &[f64], u: &[f64]| {
            let (mut fx, mut fu) = (vec![0.0; n * n], vec![0.0; n * m]);
            f.derivatives(x, u, &mut fx, &mut fu);
            (vt(&fx, n), vt(&fu, m))
        };
        assert_close("fxx", &hxx, &jacobian(|z| vfx(z, u).0, x), 1e-5)?;
        assert_close("fux", &hux, &jacobian(|z| vfx(z, u).1, x), 1e-5)?;
        assert_close("fuu", &huu, &jacobian(|z| vfx(x, z).1, u), 1e-5)?;
    }
    Ok(())
}

fn sym(n: usize, e: &[f64], shift: f64) -> Mat<f64> {
    Mat::from_fn(n, n, |i, j| {
        e[i.min(j) * n + i.max(j)] + if i == j { shift } else { 0.0 }
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn pendulum_derivatives(x in vec(-4.0..4.0f64, 2), u in vec(-5.0..5.0f64, 1), v in vec(-3.0..3.0f64, 2),
                            damping in 0.0..0.5f64, mass in 0.5..2.0f64) {
        let p = Pendulum { damping, mass, dt: 0.05, ..Pendulum::default() };
        check_dynamics(&p, &x, &u, &v)?;
    }

    #[test]
    fn cartpole_derivatives(x in vec(-3.0..3.0f64, 4), u in vec(-10.0..10.0f64, 1)) {
        check_dynamics(&CartPole { dt: 0.05, ..CartPole::default() }, &x, &u, &[0.0; 4])?;
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
        assert_close("lx", &d.lx, &jacobian(|z| vec![cost.running(k, z, u)], x), 1e-6)?;
        assert_close("lu", &d.lu, &jacobian(|z| vec![cost.running(k, x, z)], u), 1e-6)?;
        let grads = |x: &[f64], u: &[f64]| {
            let mut d = CostDerivatives::zeros(n, m);
            cost.running_derivatives(k, x, u, &mut d);
            d
        };
        assert_close("lxx", &d.lxx, &jacobian(|z| grads(z, u).lx, x), 1e-6)?;
        assert_close("luu", &d.luu, &jacobian(|z| grads(x, z).lu, u), 1e-6)?;
        assert_close("lux", &d.lux, &jacobian(|z| grads(z, u).lu, x), 1e-6)?;
        let (mut lx, mut lxx) = (vec![0.0; n], vec![0.0; n * n]);
        cost.terminal_derivatives(x, &mut lx, &mut lxx);
        assert_close("lfx", &lx, &jacobian(|z| vec![cost.terminal(z)], x), 1e-6)?;
        let tgrad = |z: &[f64]| {
            let (mut g, mut h) = (vec![0.0; n], vec![0.0; n * n]);
            cost.terminal_derivatives(z, &mut g, &mut h);
            g
        };
        assert_close("lfxx", &lxx, &jacobian(tgrad, x), 1e-6)?;
    }
}
