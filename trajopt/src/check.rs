//! Checking analytic Jacobians against central differences.
//!
//! [`check_jacobian`] compares every entry of $J(\theta)$ that a
//! [`LeastSquaresProblem`] returns with the central difference
//! $(r(\theta + h e_j) - r(\theta - h e_j)) / 2h$, $h = \epsilon^{1/3}
//! \max(1, |\theta_j|)$ (truncation error $O(h^2)$, rounding
//! $O(\epsilon / h)$), and reports the worst relative error
//! $|J_{ij} - D_{ij}| / \max(1, |J_{ij}|, |D_{ij}|)$ and where it occurred.
//! Entries outside the Jacobian's pattern count as analytic zeros, so a
//! pattern that misses a dependence shows up too.
//! [`check_model_jacobians`] and [`check_stage_cost_jacobians`] do the same
//! for the two halves of Eq. 3, a [`Dynamics`] and a [`StageCost`], over
//! $z = (x, u)$ (columns: the state, then the control), with their declared
//! Jacobian structures as the pattern. The field names are those of the
//! other crates' checks (`ddp::strategies::check_jacobian`,
//! `lwr::strategies::check_jacobian`).
//!
//! ```
//! use trajopt::check::{check_jacobian, check_model_jacobians};
//! use trajopt::problems::{HandPendulum, pendulum_swingup};
//!
//! let (problem, theta) = pendulum_swingup(20, 1e2)?;
//! let worst = check_jacobian(&problem, &theta)?;
//! assert!(worst.max_rel_error < 1e-6, "{worst:?}");
//! let worst = check_model_jacobians(&HandPendulum::default(), &[2.0, -1.0, 0.3, 0.1], &[4.0])?;
//! assert!(worst.expect("analytic").max_rel_error < 1e-6);
//! # Ok::<(), trajopt::TrajoptError>(())
//! ```

use crate::eq3::{Dynamics, StageCost};
use crate::error::{Result, check_point};
use crate::least_squares::{LeastSquaresProblem, check_jacobian_pattern};

/// The worst disagreement found by [`check_jacobian`],
/// [`check_model_jacobians`] or [`check_stage_cost_jacobians`]: the
/// workspace's one record of a derivative check, with its error measure
/// (entries outside a Jacobian's pattern or structure count as analytic
/// zeros).
pub use solve::JacobianCheck;

/// Compares the problem's analytic Jacobian at `theta` with central
/// differences of its residuals; see the [module docs](self).
///
/// # Errors
/// Wrong sizes, a non-finite `theta`, a Jacobian pattern of the wrong
/// shape, or an error from evaluating the problem.
pub fn check_jacobian<P: LeastSquaresProblem + ?Sized>(problem: &P, theta: &[f64]) -> Result<JacobianCheck> {
    let (n_p, n_r) = (problem.n_params(), problem.n_residuals());
    check_point("parameters", n_p, theta)?;
    let pattern = problem.jacobian_pattern();
    check_jacobian_pattern(&pattern, n_r, n_p)?;
    let mut values = vec![0.0; pattern.col_idx().len()];
    problem.jacobian_values(theta, &mut values)?;
    // the analytic Jacobian dense, row-major
    let mut analytic = vec![0.0; n_r * n_p];
    for i in 0..n_r {
        let (start, end) = (pattern.row_ptr()[i], pattern.row_ptr()[i + 1]);
        for (&j, &v) in pattern.col_idx()[start..end].iter().zip(&values[start..end]) {
            analytic[i * n_p + j] += v;
        }
    }
    worst_difference(theta, n_r, &analytic, |t, r| problem.residuals(t, r))
}

/// Compares a [`Dynamics`]'s analytic $\partial f / \partial x$ and
/// $\partial f / \partial u$ at $(x, u)$ with central differences of
/// [`Dynamics::step`], columns $0..n$ the state and $n..n+m$ the control.
/// Entries outside [`Dynamics::jacobian_structure`] count as analytic zeros.
/// Returns `None` when the model has no analytic Jacobians
/// ([`Dynamics::jacobians`] returns `false`): the solvers then difference it
/// themselves and there is nothing to check.
///
/// # Errors
/// Wrong-sized or non-finite `x` or `u`, or an error from the model.
pub fn check_model_jacobians<M: Dynamics + ?Sized>(model: &M, x: &[f64], u: &[f64]) -> Result<Option<JacobianCheck>> {
    let (n, m) = (model.state_dim(), model.control_dim());
    check_point("state", n, x)?;
    check_point("control", m, u)?;
    let (mut fx, mut fu) = (vec![0.0; n * n], vec![0.0; n * m]);
    if !model.jacobians(x, u, &mut fx, &mut fu)? {
        return Ok(None);
    }
    let (mut sx, mut su) = (vec![true; n * n], vec![true; n * m]);
    model.jacobian_structure(&mut sx, &mut su);
    let analytic = join_columns(n, (&fx, &sx, n), (&fu, &su, m));
    let z: Vec<f64> = x.iter().chain(u).copied().collect();
    worst_difference(&z, n, &analytic, |z, next| Ok(model.step(&z[..n], &z[n..], next)?)).map(Some)
}

/// Compares a [`StageCost`]'s analytic residual Jacobians at stage `k` with
/// central differences of [`StageCost::residuals`], over $z = (x, u)$, or
/// over $x$ alone at the terminal stage (`terminal`, where the cost sees no
/// control and `u` only gives the control dimension $m$). Entries outside
/// [`StageCost::jacobian_structure`] count as analytic zeros.
///
/// # Errors
/// A non-finite `x` or `u`, or an error from the cost.
pub fn check_stage_cost_jacobians<C: StageCost + ?Sized>(
    cost: &C,
    k: usize,
    x: &[f64],
    u: &[f64],
    terminal: bool,
) -> Result<JacobianCheck> {
    let (n, m, q) = (x.len(), u.len(), systems::residual_count(cost, terminal));
    check_point("state", n, x)?;
    check_point("control", m, u)?;
    let control = (!terminal).then_some(u);
    let (mut jx, mut ju) = (vec![0.0; q * n], vec![0.0; q * m]);
    cost.jacobians(k, x, control, &mut jx, &mut ju)?;
    let (mut sx, mut su) = (vec![true; q * n], vec![true; q * m]);
    // the structure describes the running stages' rows; a terminal stage
    // of its own size is checked as dense
    if !terminal || cost.n_terminal_residuals() == cost.n_residuals() {
        cost.jacobian_structure(&mut sx, &mut su);
    }
    if terminal {
        let analytic = join_columns(q, (&jx, &sx, n), (&[], &[], 0));
        return worst_difference(x, q, &analytic, |x, r| Ok(cost.residuals(k, x, None, r)?));
    }
    let analytic = join_columns(q, (&jx, &sx, n), (&ju, &su, m));
    let z: Vec<f64> = x.iter().chain(u).copied().collect();
    worst_difference(&z, q, &analytic, |z, r| {
        Ok(cost.residuals(k, &z[..n], Some(&z[n..]), r)?)
    })
}

/// The row-major $q \times (n + m)$ matrix $[J_x \; J_u]$ from two
/// row-major blocks, each given with its structure (entries outside it
/// read as 0) and its number of columns.
fn join_columns(q: usize, left: (&[f64], &[bool], usize), right: (&[f64], &[bool], usize)) -> Vec<f64> {
    let width = left.2 + right.2;
    let mut joined = vec![0.0; q * width];
    for i in 0..q {
        for (offset, (values, keep, cols)) in [(0, left), (left.2, right)] {
            for j in 0..cols {
                if keep[i * cols + j] {
                    joined[i * width + offset + j] = values[i * cols + j];
                }
            }
        }
    }
    joined
}

/// The worst entry of the row-major `analytic` ($q \times$ `z.len()`)
/// against central differences of `f` at `z`.
fn worst_difference(
    z: &[f64],
    q: usize,
    analytic: &[f64],
    mut f: impl FnMut(&[f64], &mut [f64]) -> Result<()>,
) -> Result<JacobianCheck> {
    let p = z.len();
    let mut worst = JacobianCheck::new();
    let (mut plus, mut minus) = (vec![0.0; q], vec![0.0; q]);
    let mut probe = z.to_vec();
    for j in 0..p {
        let h = f64::EPSILON.cbrt() * z[j].abs().max(1.0);
        probe[j] = z[j] + h;
        f(&probe, &mut plus)?;
        probe[j] = z[j] - h;
        f(&probe, &mut minus)?;
        probe[j] = z[j];
        for i in 0..q {
            let numeric = (plus[i] - minus[i]) / (2.0 * h);
            worst.record(i, j, analytic[i * p + j], numeric);
        }
    }
    Ok(worst)
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::SymbolicSparseRowMat;
    use systems::ModelResult;

    /// $r = (\theta_0^2 - 1, \theta_0 \theta_1)$, its Jacobian right or
    /// with a wrong entry, and a pattern missing $\partial r_1 / \partial
    /// \theta_0$ when `drop`.
    struct Small {
        wrong: bool,
        drop: bool,
    }

    impl LeastSquaresProblem for Small {
        fn n_params(&self) -> usize {
            2
        }
        fn n_residuals(&self) -> usize {
            2
        }
        fn residuals(&self, t: &[f64], r: &mut [f64]) -> Result<()> {
            r[0] = t[0] * t[0] - 1.0;
            r[1] = t[0] * t[1];
            Ok(())
        }
        fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
            if self.drop {
                SymbolicSparseRowMat::new_checked(2, 2, vec![0, 1, 2], None, vec![0, 1])
            } else {
                SymbolicSparseRowMat::new_checked(2, 2, vec![0, 1, 3], None, vec![0, 0, 1])
            }
        }
        fn jacobian_values(&self, t: &[f64], v: &mut [f64]) -> Result<()> {
            if self.drop {
                v.copy_from_slice(&[2.0 * t[0], t[0]]);
            } else {
                let d00 = if self.wrong { 3.0 * t[0] } else { 2.0 * t[0] };
                v.copy_from_slice(&[d00, t[1], t[0]]);
            }
            Ok(())
        }
    }

    #[test]
    fn a_right_jacobian_passes_and_a_wrong_one_is_located() {
        let theta = [1.5, -2.0];
        let right = check_jacobian(
            &Small {
                wrong: false,
                drop: false,
            },
            &theta,
        )
        .expect("check");
        assert!(right.max_rel_error < 1e-9, "{right:?}");
        let wrong = check_jacobian(
            &Small {
                wrong: true,
                drop: false,
            },
            &theta,
        )
        .expect("check");
        assert_eq!((wrong.row, wrong.col), (0, 0));
        assert!((wrong.analytic - 4.5).abs() < 1e-12 && (wrong.numeric - 3.0).abs() < 1e-6);
        assert!((wrong.max_rel_error - 1.5 / 4.5).abs() < 1e-6);
        // a dependence missing from the pattern: d r_1 / d theta_0 = theta_1
        let dropped = check_jacobian(
            &Small {
                wrong: false,
                drop: true,
            },
            &theta,
        )
        .expect("check");
        assert_eq!((dropped.row, dropped.col, dropped.analytic), (1, 0, 0.0));
        assert!((dropped.numeric + 2.0).abs() < 1e-6);
    }

    #[test]
    fn bad_input_is_an_error() {
        let p = Small {
            wrong: false,
            drop: false,
        };
        assert!(check_jacobian(&p, &[1.0]).is_err());
        assert!(check_jacobian(&p, &[1.0, f64::NAN]).is_err());
    }
    /// $f(x, u) = (x_0 + x_1 u, \sin x_1)$, its Jacobians right, with a
    /// wrong entry, with a structure that leaves out a nonzero, or absent.
    struct Toy {
        wrong: bool,
        hide: bool,
        analytic: bool,
    }

    impl Dynamics for Toy {
        fn state_dim(&self) -> usize {
            2
        }
        fn control_dim(&self) -> usize {
            1
        }
        fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
            next[0] = x[0] + x[1] * u[0];
            next[1] = x[1].sin();
            Ok(())
        }
        fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
            let d11 = if self.wrong { x[1].sin() } else { x[1].cos() };
            fx.copy_from_slice(&[1.0, u[0], 0.0, d11]);
            fu.copy_from_slice(&[x[1], 0.0]);
            Ok(self.analytic)
        }
        fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
            fx.copy_from_slice(&[true, true, false, true]);
            // hiding d next_0 / d u, which is x_1
            fu.copy_from_slice(&[!self.hide, false]);
        }
    }

    #[test]
    fn model_jacobians_are_checked_over_state_then_control() {
        let toy = |wrong, hide, analytic| Toy { wrong, hide, analytic };
        let (x, u) = ([0.5, 1.2], [-0.7]);
        let right = check_model_jacobians(&toy(false, false, true), &x, &u)
            .expect("check")
            .expect("analytic");
        assert!(right.max_rel_error < 1e-9, "{right:?}");
        let wrong = check_model_jacobians(&toy(true, false, true), &x, &u)
            .expect("check")
            .expect("analytic");
        assert_eq!((wrong.row, wrong.col), (1, 1));
        assert!((wrong.numeric - 1.2f64.cos()).abs() < 1e-8);
        // the structure hides column 2 (the control) of row 0
        let hidden = check_model_jacobians(&toy(false, true, true), &x, &u)
            .expect("check")
            .expect("analytic");
        assert_eq!((hidden.row, hidden.col, hidden.analytic), (0, 2, 0.0));
        assert!((hidden.numeric - 1.2).abs() < 1e-8);
        assert_eq!(
            check_model_jacobians(&toy(false, false, false), &x, &u).expect("check"),
            None
        );
        assert!(check_model_jacobians(&toy(false, false, true), &x, &[]).is_err());
        assert!(check_model_jacobians(&toy(false, false, true), &[f64::NAN, 0.0], &u).is_err());
    }

    #[test]
    fn stage_cost_jacobians_running_and_terminal() {
        use crate::TrackingCost;
        use faer::Mat;
        let xr = Mat::from_fn(3, 2, |k, i| 0.1 * (k + i) as f64);
        let ur = Mat::from_fn(2, 1, |k, _| k as f64);
        let cost = TrackingCost::new(xr, ur, &[2.0, 0.5], &[0.3], &[10.0, 1.0]).expect("cost");
        let running = check_stage_cost_jacobians(&cost, 1, &[0.4, -0.2], &[1.5], false).expect("check");
        assert!(running.max_rel_error < 1e-9, "{running:?}");
        let terminal = check_stage_cost_jacobians(&cost, 2, &[0.4, -0.2], &[1.5], true).expect("check");
        assert!(terminal.max_rel_error < 1e-9, "{terminal:?}");
        assert!(check_stage_cost_jacobians(&cost, 1, &[0.4, f64::INFINITY], &[1.5], false).is_err());
    }
}
