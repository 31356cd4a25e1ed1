use super::*;
use crate::Lambda;
use crate::least_squares::SecondOrder;
use crate::problems::pendulum_swingup;

/// Dense $J^\top J$, $S$, $J^\top r$ and $r$.
type Dense = (Vec<Vec<f64>>, Vec<Vec<f64>>, Vec<f64>, Vec<f64>);

/// $J^\top J$, $S$ and $J^\top r$ from the sparse Jacobian and the sparse
/// second-order term, dense.
fn reference<P: SecondOrder + LeastSquaresProblem>(p: &P, theta: &[f64]) -> Dense {
    let (n_p, n_r) = (p.n_params(), p.n_residuals());
    let mut r = vec![0.0; n_r];
    p.residuals(theta, &mut r).expect("residuals");
    let pattern = p.jacobian_pattern();
    let mut vals = vec![0.0; pattern.col_idx().len()];
    p.jacobian_values(theta, &mut vals).expect("jacobian");
    let mut jtj = vec![vec![0.0; n_p]; n_p];
    let mut grad = vec![0.0; n_p];
    for (i, &ri) in r.iter().enumerate() {
        let (s, e) = (pattern.row_ptr()[i], pattern.row_ptr()[i + 1]);
        for a in s..e {
            grad[pattern.col_idx()[a]] += vals[a] * ri;
            for b in s..e {
                jtj[pattern.col_idx()[a]][pattern.col_idx()[b]] += vals[a] * vals[b];
            }
        }
    }
    let sp = SecondOrder::pattern(p);
    let mut sv = vec![0.0; sp.row_idx().len()];
    assert!(SecondOrder::values(p, theta, &r, &mut sv).expect("S"));
    let mut s = vec![vec![0.0; n_p]; n_p];
    for j in 0..n_p {
        for (q, &i) in sp.row_idx_of_col_raw(j).iter().enumerate() {
            s[i][j] = sv[sp.col_ptr()[j] + q];
        }
    }
    (jtj, s, grad, r)
}

/// Compares the band form with the sparse one at a point away from the start.
fn check_band_equals_sparse<P: BandForm + SecondOrder>(problem: &P, theta: &[f64]) {
    let (jtj_ref, s_ref, grad_ref, r) = reference(problem, theta);
    let layout = problem.layout();
    let n_p = problem.n_params();
    layout.validate(n_p).expect("permutation");
    let mut jtj = BandedSym::zeros(n_p, layout.half_bandwidth);
    let mut full = jtj.clone();
    let mut grad = vec![0.0; n_p];
    let mut grad_full = vec![0.0; n_p];
    let mut diag_s = vec![0.0; n_p];
    let form = |theta: &[f64], h: &mut BandedSym, grad: &mut [f64], second_order_diagonal: Option<&mut [f64]>| {
        let out = BandNormalEquations {
            h,
            grad,
            second_order_diagonal,
        };
        problem.normal_equations(Point { theta, r: &r }, &layout, out)
    };
    assert!(!form(theta, &mut jtj, &mut grad, None).expect("band"));
    assert!(form(theta, &mut full, &mut grad_full, Some(&mut diag_s)).expect("band"));
    assert_eq!(grad, grad_full);
    let pos = &layout.position;
    let scale = jtj_ref.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    for i in 0..n_p {
        assert!(
            (grad[i] - grad_ref[i]).abs() <= 1e-9 * (1.0 + grad_ref[i].abs()),
            "grad {i}"
        );
        assert!(
            (diag_s[i] - s_ref[i][i]).abs() <= 1e-9 * (1.0 + s_ref[i][i].abs()),
            "diag S {i}"
        );
        for j in 0..n_p {
            // an entry outside the band must be zero in the reference
            let (a, b) = (pos[i].max(pos[j]), pos[i].min(pos[j]));
            let inside = a - b <= layout.half_bandwidth;
            let got = if inside { jtj.get(pos[i], pos[j]) } else { 0.0 };
            assert!(
                (got - jtj_ref[i][j]).abs() <= 1e-12 * scale,
                "J^T J ({i}, {j}): {got} vs {}",
                jtj_ref[i][j]
            );
            let expected = jtj_ref[i][j] + s_ref[i][j];
            let got_full = if inside { full.get(pos[i], pos[j]) } else { 0.0 };
            assert!(
                (got_full - expected).abs() <= 1e-12 * scale + 1e-9 * s_ref[i][j].abs(),
                "J^T J + S ({i}, {j}): {got_full} vs {expected}"
            );
        }
    }
    check_parts_add_up(problem, theta, &r, &layout, (&jtj, &full), &grad, &diag_s);
    // S alone, whole and in parts, against the reference S
    for parts in [1, 2, 5] {
        let mut s_band = BandedSym::zeros(n_p, layout.half_bandwidth);
        let mut part_s = s_band.clone();
        for part in 0..parts {
            assert!(
                problem
                    .second_order_part(
                        Part {
                            index: part,
                            count: parts
                        },
                        Point { theta, r: &r },
                        &layout,
                        &mut part_s
                    )
                    .expect("S part")
            );
            s_band.add_scaled(1.0, &part_s);
        }
        let s_scale = s_ref.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
        for i in 0..n_p {
            for j in 0..n_p {
                let (a, b) = (pos[i].max(pos[j]), pos[i].min(pos[j]));
                let got = if a - b <= layout.half_bandwidth {
                    s_band.get(pos[i], pos[j])
                } else {
                    0.0
                };
                assert!(
                    (got - s_ref[i][j]).abs() <= 1e-12 * s_scale,
                    "S ({i}, {j}) in {parts} parts: {got} vs {}",
                    s_ref[i][j]
                );
            }
        }
    }
    // bad sizes are errors
    let mut small = BandedSym::zeros(n_p - 1, layout.half_bandwidth);
    assert!(form(theta, &mut small, &mut grad, None).is_err());
    assert!(form(&theta[1..], &mut jtj, &mut grad, None).is_err());
}

/// The parts of the normal equations (with and without $S$) add up to
/// the whole, for several part counts (more parts than time steps
/// included: some parts are then empty).
fn check_parts_add_up<P: BandForm>(
    problem: &P,
    theta: &[f64],
    r: &[f64],
    layout: &BandLayout,
    (jtj, full): (&BandedSym, &BandedSym),
    grad: &[f64],
    diag_s: &[f64],
) {
    let n_p = problem.n_params();
    let scale = full.band().iter().fold(0.0f64, |a, v| a.max(v.abs()));
    for parts in [1, 2, 3, 7, 300] {
        for with_s in [false, true] {
            let mut sum = BandedSym::zeros(n_p, layout.half_bandwidth);
            let (mut grad_sum, mut diag_sum) = (vec![0.0; n_p], vec![0.0; n_p]);
            let (mut part_h, mut part_grad, mut part_diag) = (sum.clone(), vec![0.0; n_p], vec![0.0; n_p]);
            for part in 0..parts {
                let diag = with_s.then_some(&mut part_diag[..]);
                let got = problem
                    .normal_equations_part(
                        Part {
                            index: part,
                            count: parts,
                        },
                        Point { theta, r },
                        layout,
                        BandNormalEquations {
                            h: &mut part_h,
                            grad: &mut part_grad,
                            second_order_diagonal: diag,
                        },
                    )
                    .expect("part");
                assert_eq!(got, with_s, "part {part} of {parts}");
                sum.add_scaled(1.0, &part_h);
                for (a, b) in grad_sum.iter_mut().zip(&part_grad) {
                    *a += b;
                }
                for (a, b) in diag_sum.iter_mut().zip(&part_diag) {
                    *a += b;
                }
            }
            let whole = if with_s { full } else { jtj };
            for (a, b) in sum.band().iter().zip(whole.band()) {
                assert!((a - b).abs() <= 1e-13 * scale, "{a} vs {b} ({parts} parts)");
            }
            for (a, b) in grad_sum.iter().zip(grad) {
                assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "grad {a} vs {b}");
            }
            if with_s {
                for (a, b) in diag_sum.iter().zip(diag_s) {
                    assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "diag S {a} vs {b}");
                }
            }
        }
    }
    let mut h = BandedSym::zeros(n_p, layout.half_bandwidth);
    let mut g = vec![0.0; n_p];
    assert!(
        problem
            .normal_equations_part(
                Part { index: 2, count: 2 },
                Point { theta, r },
                layout,
                BandNormalEquations {
                    h: &mut h,
                    grad: &mut g,
                    second_order_diagonal: None
                }
            )
            .is_err()
    );
}

fn perturbed(theta: &[f64]) -> Vec<f64> {
    theta
        .iter()
        .enumerate()
        .map(|(i, t)| t + 0.3 * (i as f64 * 0.77).sin())
        .collect()
}

#[test]
fn band_normal_equations_equal_the_sparse_ones() {
    let (problem, theta0) = pendulum_swingup(120, 1e2).expect("problem");
    // a zero weight at one step, and the initial-state rows
    let mut lambda = vec![1e2; 120];
    lambda[7] = 0.0;
    lambda[8] = 3e3;
    let mut problem = problem.with_initial_state(&[0.1, 0.0, 0.0, 0.0], 7.0).expect("x0");
    problem.set_lambda(Lambda::PerStep(lambda)).expect("lambda");
    let layout = problem.layout();
    assert!(
        layout.half_bandwidth < problem.n_params() / 3,
        "not banded: {}",
        layout.half_bandwidth
    );
    check_band_equals_sparse(&problem, &perturbed(&theta0));
}

/// Sizes without a fast path compiled for them (3 states, 2 controls):
/// the loops with the problem's sizes at run time.
#[test]
fn band_normal_equations_hold_for_other_sizes() {
    let (horizon, dt) = (30, 0.05);
    let times: Vec<f64> = (0..=horizon).map(|k| k as f64 * dt).collect();
    let a = faer::Mat::from_fn(3, 3, |i, j| if i == j { 1.0 } else { 0.1 * (i + 2 * j) as f64 * dt });
    let b = faer::Mat::from_fn(3, 2, |i, j| (1 + i + j) as f64 * dt);
    let model = crate::LinearModel::new(a, b).expect("model");
    let state_ref = faer::Mat::from_fn(horizon + 1, 3, |k, i| ((k + i) as f64 * 0.2).sin());
    let cost = crate::TrackingCost::new(
        state_ref,
        faer::Mat::zeros(horizon, 2),
        &[1.0, 0.5, 2.0],
        &[0.1, 0.2],
        &[5.0; 3],
    )
    .expect("cost");
    let state_basis = splines::BSplineBasis::clamped_uniform(10, 3, 0.0, times[horizon]).expect("basis");
    let control_basis = splines::BSplineBasis::clamped_uniform(8, 3, 0.0, times[horizon]).expect("basis");
    let problem = Eq3Problem::new(
        model,
        cost,
        &state_basis,
        &control_basis,
        &times,
        Lambda::Constant(30.0),
    )
    .expect("problem")
    .with_initial_state(&[0.1, 0.0, -0.2], 3.0)
    .expect("x0");
    let theta: Vec<f64> = (0..problem.n_params()).map(|i| 0.3 * (i as f64 * 0.61).sin()).collect();
    check_band_equals_sparse(&problem, &theta);
}

/// Bases whose rows are not 4 contiguous coefficients: a wavelet basis
/// for the states (rows spread over levels: the per-entry path), a
/// quadratic B-spline for the controls (3 coefficients per row).
#[test]
fn band_normal_equations_hold_for_other_bases() {
    use splines::wavelet::{Boundary, Wavelet, WaveletBasis};
    let horizon = 40;
    let dt = crate::problems::PENDULUM_DT;
    let times: Vec<f64> = (0..=horizon).map(|k| k as f64 * dt).collect();
    let state_ref = faer::Mat::from_fn(horizon + 1, 4, |k, i| crate::problems::swingup_reference(k)[i]);
    let cost = crate::TrackingCost::new(state_ref, faer::Mat::zeros(horizon, 1), &[1.0; 4], &[0.01], &[10.0; 4])
        .expect("cost");
    let state_basis =
        WaveletBasis::new(Wavelet::Db2, Boundary::Periodization, horizon + 1, None, 0.0, dt).expect("basis");
    let control_basis = splines::BSplineBasis::clamped_uniform(9, 2, 0.0, times[horizon]).expect("basis");
    let problem = Eq3Problem::new(
        crate::problems::HandPendulum::default(),
        cost,
        &state_basis,
        &control_basis,
        &times,
        Lambda::Constant(50.0),
    )
    .expect("problem");
    let theta: Vec<f64> = (0..problem.n_params()).map(|i| 0.2 * (i as f64 * 0.37).cos()).collect();
    check_band_equals_sparse(&problem, &theta);
}
