//! The damped Gauss-Newton step under box bounds, without a QP solver:
//! Bertsekas's projected Newton method on the step's quadratic model.
//!
//! The step $\delta$ minimises $m(\delta) = g^\top \delta + \tfrac12
//! \delta^\top H \delta$ ($H$ the damped model matrix, positive definite)
//! subject to $lo \le \delta \le hi$ ($lo = \ell - \theta \le 0 \le hi = u -
//! \theta$). From $\delta = 0$, each iteration
//! - finds the binding set $B$: the components at a bound whose model
//!   gradient $q = g + H\delta$ points out of the box;
//! - takes the Newton step on the others, $H_{FF}\, p_F = -q_F$, $p_B = 0$,
//!   solved in $H$'s own sparsity pattern (the rows and columns of $B$
//!   replaced by the identity's), so the sparse Cholesky factorisation's
//!   symbolic part is the unbounded step's;
//! - moves along the projection arc $P(\delta + \alpha p)$, halving
//!   $\alpha$ from 1 until Armijo's condition holds;
//!
//! and stops when the projected gradient vanishes (the KKT conditions, to
//! rounding): usually within a few iterations, as many bounds entering or
//! leaving $B$ at once as the arc crosses.
//!
//! Reference: D. P. Bertsekas, "Projected Newton methods for optimization
//! problems with simple constraints", SIAM J. Control Optim. 20 (1982).

use faer::sparse::SparseColMat;

/// $y = Hx$ for a symmetric $H$ given by its upper triangle.
pub(crate) fn sym_mul(h: &SparseColMat<usize, f64>, x: &[f64], y: &mut [f64]) {
    y.fill(0.0);
    for j in 0..h.ncols() {
        for (&i, &v) in h.symbolic().row_idx_of_col_raw(j).iter().zip(h.val_of_col(j)) {
            if i < j {
                y[i] += v * x[j];
                y[j] += v * x[i];
            } else if i == j {
                y[i] += v * x[i];
            }
        }
    }
}

/// Factorises a matrix (upper triangle) and overwrites the right-hand
/// side with the solution; false when the matrix is not positive definite.
pub(crate) type ReducedSolve<'a> = dyn FnMut(&SparseColMat<usize, f64>, &mut [f64]) -> bool + 'a;

/// The projection of `x` onto $[lo, hi]$.
fn project(x: f64, lo: f64, hi: f64) -> f64 {
    x.max(lo).min(hi)
}

/// Minimises $g^\top \delta + \tfrac12 \delta^\top H \delta$ over $lo \le
/// \delta \le hi$ ($lo \le 0 \le hi$; `h` the upper triangle of a positive
/// definite $H$) into `step`. `solve(m, rhs)` factorises `m` (upper
/// triangle, `h`'s pattern) and overwrites `rhs` with $m^{-1}$ `rhs`,
/// returning false when `m` is not positive definite. Returns false when a
/// reduced matrix is not; the step is otherwise the best found (feasible,
/// and a descent step whenever $\delta = 0$ is not optimal).
pub(crate) fn box_step(
    h: &SparseColMat<usize, f64>,
    g: &[f64],
    lo: &[f64],
    hi: &[f64],
    solve: &mut ReducedSolve<'_>,
    step: &mut [f64],
) -> bool {
    let n = g.len();
    for k in 0..n {
        step[k] = project(0.0, lo[k], hi[k]);
    }
    let mut reduced = h.clone();
    let (mut hd, mut q, mut p, mut trial, mut h_trial) =
        (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut binding = vec![false; n];
    let model = |d: &[f64], hd: &[f64]| -> f64 {
        d.iter()
            .zip(g.iter().zip(hd))
            .map(|(d, (g, hd))| d * (g + 0.5 * hd))
            .sum()
    };
    let g_scale = g.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    sym_mul(h, step, &mut hd);
    // a strictly convex QP: the binding set settles after a few rounds;
    // the cap only guards against rounding cycles
    for _ in 0..n + 50 {
        let mut violation = 0.0_f64;
        let mut scale = g_scale;
        for k in 0..n {
            q[k] = g[k] + hd[k];
            scale = scale.max(hd[k].abs());
            binding[k] = (step[k] <= lo[k] && q[k] >= 0.0) || (step[k] >= hi[k] && q[k] <= 0.0);
            if !binding[k] {
                violation = violation.max(q[k].abs());
            }
        }
        if violation <= 1e-12 * scale || scale == 0.0 {
            return true;
        }
        // the Newton step on the free components, in H's own pattern
        for j in 0..n {
            // `reduced` has `h`'s pattern: its rows are read from `h`
            let rows = h.symbolic().row_idx_of_col_raw(j);
            for ((&i, v), &h_ij) in rows.iter().zip(reduced.val_of_col_mut(j)).zip(h.val_of_col(j)) {
                *v = if binding[i] || binding[j] {
                    if i == j { 1.0 } else { 0.0 }
                } else {
                    h_ij
                };
            }
        }
        for k in 0..n {
            p[k] = if binding[k] { 0.0 } else { -q[k] };
        }
        if !solve(&reduced, &mut p) || p.iter().any(|v| !v.is_finite()) {
            return false;
        }
        // Armijo along the projection arc
        let m0 = model(step, &hd);
        let mut alpha = 1.0;
        let mut accepted = false;
        for _ in 0..50 {
            for k in 0..n {
                trial[k] = project(step[k] + alpha * p[k], lo[k], hi[k]);
            }
            sym_mul(h, &trial, &mut h_trial);
            let linear: f64 = q
                .iter()
                .zip(trial.iter().zip(step.iter()))
                .map(|(q, (t, d))| q * (t - d))
                .sum();
            if model(&trial, &h_trial) <= m0 + 1e-4 * linear {
                accepted = true;
                break;
            }
            alpha *= 0.5;
        }
        if !accepted || trial == step {
            // no further progress to rounding: the step found is kept
            return true;
        }
        step.copy_from_slice(&trial);
        hd.copy_from_slice(&h_trial);
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A dense solve of the reduced system, for the tests.
    fn dense_solve(m: &SparseColMat<usize, f64>, rhs: &mut [f64]) -> bool {
        let n = rhs.len();
        let mut a = faer::Mat::<f64>::zeros(n, n);
        for j in 0..n {
            for (&i, &v) in m.symbolic().row_idx_of_col_raw(j).iter().zip(m.val_of_col(j)) {
                if i <= j {
                    a[(i, j)] = v;
                    a[(j, i)] = v;
                }
            }
        }
        match a.llt(faer::Side::Lower) {
            Ok(llt) => {
                let x = faer::linalg::solvers::Solve::solve(&llt, faer::Mat::<f64>::from_fn(n, 1, |i, _| rhs[i]));
                for (i, r) in rhs.iter_mut().enumerate() {
                    *r = x[(i, 0)];
                }
                true
            }
            Err(_) => false,
        }
    }

    /// The upper triangle of $M M^\top + n I$ from `entries` ($n \times n$).
    fn spd(n: usize, entries: &[f64]) -> SparseColMat<usize, f64> {
        let m = |i: usize, j: usize| entries[i * n + j];
        let mut triplets = Vec::new();
        for j in 0..n {
            for i in 0..=j {
                let v: f64 = (0..n).map(|k| m(i, k) * m(j, k)).sum::<f64>() + if i == j { 0.5 } else { 0.0 };
                triplets.push(faer::sparse::Triplet::new(i, j, v));
            }
        }
        SparseColMat::try_new_from_triplets(n, n, &triplets).expect("matrix")
    }

    fn case() -> impl Strategy<Value = (usize, Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>)> {
        (1usize..8).prop_flat_map(|n| {
            (
                Just(n),
                proptest::collection::vec(-2.0..2.0f64, n * n),
                proptest::collection::vec(-5.0..5.0f64, n),
                // a bound's width; beyond 2 the side is unbounded
                proptest::collection::vec(0.0..2.5f64, n),
                proptest::collection::vec(0.0..2.5f64, n),
            )
        })
    }

    proptest! {
        /// The step satisfies the KKT conditions of the box QP: feasible,
        /// the gradient zero on the free components and pointing out of
        /// the box on the active ones; and it is no worse than any other
        /// feasible point drawn.
        #[test]
        fn box_steps_satisfy_the_kkt_conditions((n, entries, g, below, above) in case()) {
            let h = spd(n, &entries);
            let side = |w: f64, sign: f64| if w > 2.0 { sign * f64::INFINITY } else { sign * w };
            let lo: Vec<f64> = below.iter().map(|&w| side(w, -1.0)).collect();
            let hi: Vec<f64> = above.iter().map(|&w| side(w, 1.0)).collect();
            let mut d = vec![0.0; n];
            prop_assert!(box_step(&h, &g, &lo, &hi, &mut dense_solve, &mut d));
            let mut hd = vec![0.0; n];
            sym_mul(&h, &d, &mut hd);
            let scale = 1.0 + g.iter().chain(&hd).fold(0.0_f64, |a, v| a.max(v.abs()));
            for k in 0..n {
                prop_assert!(lo[k] <= d[k] && d[k] <= hi[k]);
                let q = g[k] + hd[k];
                if d[k] > lo[k] && d[k] < hi[k] {
                    prop_assert!(q.abs() <= 1e-9 * scale, "free {k}: gradient {q}");
                } else if d[k] <= lo[k] && d[k] < hi[k] {
                    prop_assert!(q >= -1e-9 * scale, "at its lower bound {k}: gradient {q}");
                } else if d[k] >= hi[k] && d[k] > lo[k] {
                    prop_assert!(q <= 1e-9 * scale, "at its upper bound {k}: gradient {q}");
                }
            }
            let model = |x: &[f64]| {
                let mut hx = vec![0.0; n];
                sym_mul(&h, x, &mut hx);
                x.iter().zip(g.iter().zip(&hx)).map(|(x, (g, hx))| x * (g + 0.5 * hx)).sum::<f64>()
            };
            // the corners and the centre of the (finite part of the) box
            for mask in 0..(1u32 << n.min(6)) {
                let x: Vec<f64> = (0..n)
                    .map(|k| {
                        let (l, u) = (lo[k].max(-2.0), hi[k].min(2.0));
                        if k < 6 && mask & (1 << k) != 0 { u } else { l }
                    })
                    .collect();
                prop_assert!(model(&d) <= model(&x) + 1e-9 * scale * scale);
            }
        }
    }

    #[test]
    fn an_unbounded_box_gives_the_newton_step() {
        let h = spd(3, &[1.0, 0.5, 0.0, -0.3, 1.0, 0.2, 0.0, 0.4, 1.0]);
        let g = [1.0, -2.0, 0.5];
        let mut d = vec![0.0; 3];
        let inf = [f64::INFINITY; 3];
        assert!(box_step(&h, &g, &inf.map(|v| -v), &inf, &mut dense_solve, &mut d));
        let mut newton = g.map(|v| -v).to_vec();
        assert!(dense_solve(&h, &mut newton));
        for (a, b) in d.iter().zip(&newton) {
            assert!((a - b).abs() <= 1e-12, "{d:?} vs {newton:?}");
        }
    }
}
