//! Proptest strategies generating well-posed problems with known solutions
//! (feature `proptest`), so users can property-test their own solvers
//! against ours on the same work. The crate's own property tests use them.

use faer::Mat;
use faer::sparse::{SparseRowMat, SymbolicSparseRowMat};
use proptest::collection::vec;
use proptest::prelude::*;
use splines::BSplineBasis;

use crate::eq3::{Dynamics, Eq3Problem, Lambda, TrackingCost};
use crate::least_squares::LinearLeastSquares;
use crate::models::LinearModel;

/// A consistent linear least-squares problem $\min \lVert A\theta - b \rVert^2$
/// with $b = A \theta^\star$ and $A$ of full column rank (its top block is a
/// scaled identity), returned with its unique minimiser $\theta^\star$.
pub fn linear_least_squares(max_params: usize) -> impl Strategy<Value = (LinearLeastSquares, Vec<f64>)> {
    (1..=max_params.max(1))
        .prop_flat_map(|n| {
            let extra = 0..(2 * n + 1);
            (
                Just(n),
                vec(-5.0..5.0f64, n),
                extra,
                vec((0..n, -3.0..3.0f64), 0..(4 * n + 1)),
                0.5..3.0f64,
            )
        })
        .prop_map(|(n, solution, extra, entries, diag)| {
            // rows 0..n: diag * I; then `extra` rows with entries scattered among them
            let mut rows: Vec<Vec<(usize, f64)>> = (0..n).map(|i| vec![(i, diag)]).collect();
            rows.extend((0..extra).map(|_| Vec::new()));
            for (k, (col, v)) in entries.into_iter().enumerate() {
                if extra > 0 {
                    rows[n + k % extra].push((col, v));
                }
            }
            let mut row_ptr = vec![0];
            let (mut cols, mut vals) = (Vec::new(), Vec::new());
            for mut row in rows {
                row.sort_by_key(|e| e.0);
                row.dedup_by_key(|e| e.0);
                for (c, v) in row {
                    cols.push(c);
                    vals.push(v);
                }
                row_ptr.push(cols.len());
            }
            let m = row_ptr.len() - 1;
            let a = SparseRowMat::new(SymbolicSparseRowMat::new_checked(m, n, row_ptr, None, cols), vals);
            let b = (0..m)
                .map(|i| {
                    let c = a.symbolic().col_idx_of_row_raw(i);
                    c.iter().zip(a.val_of_row(i)).map(|(&j, &v)| v * solution[j]).sum()
                })
                .collect();
            let problem = LinearLeastSquares::new(a, b).expect("finite by construction");
            (problem, solution)
        })
}

/// A random nonlinear least-squares problem with a known, unique
/// minimiser: $r(x) = h(Ax) - h(Ax^\star)$, $h(z) = z + \beta \tanh z$
/// elementwise, $A$ ($m \times n$, $m \ge n$) of full column rank (a
/// scaled identity on top, random rows below), $\beta \in [0, 3)$. As $h$
/// is strictly increasing ($h' \ge 1$), $r(x) = 0$ only at $x^\star$:
/// the global minimum, cost 0, and the Jacobian
/// $\operatorname{diag}(h'(Ax)) A$ has full column rank everywhere.
/// Residuals, the exact Jacobian and the pattern come as a
/// [`LeastSquaresProblem`](crate::LeastSquaresProblem), and as closures for [`crate::LeastSquares`].
#[derive(Debug, Clone, PartialEq)]
pub struct NonlinearLeastSquares {
    /// $A$, $m \times n$ row-major.
    pub a: Vec<f64>,
    /// $m$.
    pub m: usize,
    /// $n$.
    pub n: usize,
    /// $\beta$, the nonlinearity's weight.
    pub beta: f64,
    /// $h(Ax^\star)$.
    pub target: Vec<f64>,
}

impl NonlinearLeastSquares {
    /// The problem of `a` ($m \times n$, row-major) with minimiser `x_star`.
    pub fn new(a: Vec<f64>, m: usize, n: usize, beta: f64, x_star: &[f64]) -> Self {
        let mut problem = Self {
            a,
            m,
            n,
            beta,
            target: vec![0.0; m],
        };
        let mut target = vec![0.0; m];
        problem.residuals_into(x_star, &mut target);
        problem.target = target;
        problem
    }

    fn h(&self, z: f64) -> (f64, f64) {
        let t = z.tanh();
        (z + self.beta * t, 1.0 + self.beta * (1.0 - t * t))
    }

    fn az(&self, x: &[f64], i: usize) -> f64 {
        (0..self.n).map(|j| self.a[i * self.n + j] * x[j]).sum()
    }

    /// $r(x)$ into `r` (length $m$).
    pub fn residuals_into(&self, x: &[f64], r: &mut [f64]) {
        for (i, ri) in r.iter_mut().enumerate() {
            *ri = self.h(self.az(x, i)).0 - self.target[i];
        }
    }

    /// $J(x) = \operatorname{diag}(h'(Ax)) A$ into `j` ($m \times n$,
    /// row-major).
    pub fn jacobian_into(&self, x: &[f64], j: &mut [f64]) {
        for i in 0..self.m {
            let slope = self.h(self.az(x, i)).1;
            for k in 0..self.n {
                j[i * self.n + k] = slope * self.a[i * self.n + k];
            }
        }
    }
}

impl crate::least_squares::LeastSquaresProblem for NonlinearLeastSquares {
    fn n_params(&self) -> usize {
        self.n
    }

    fn n_residuals(&self) -> usize {
        self.m
    }

    fn residuals(&self, theta: &[f64], r: &mut [f64]) -> crate::Result<()> {
        self.residuals_into(theta, r);
        Ok(())
    }

    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
        crate::fit::dense_pattern(self.m, self.n)
    }

    fn jacobian_values(&self, theta: &[f64], values: &mut [f64]) -> crate::Result<()> {
        self.jacobian_into(theta, values);
        Ok(())
    }
}

/// A [`NonlinearLeastSquares`] problem of `1..=max_params` parameters
/// ($n \le m \le 3n$), its minimiser $x^\star$ (entries in $[-2, 2]$) and a
/// start within 1.5 of it in each coordinate.
pub fn nonlinear_least_squares(
    max_params: usize,
) -> impl Strategy<Value = (NonlinearLeastSquares, Vec<f64>, Vec<f64>)> {
    (1..=max_params.max(1))
        .prop_flat_map(|n| {
            (
                Just(n),
                0..(2 * n + 1),
                vec(-1.0..1.0f64, 2 * n * n),
                0.5..2.0f64,
                0.0..3.0f64,
                vec(-2.0..2.0f64, n),
                vec(-1.5..1.5f64, n),
            )
        })
        .prop_map(|(n, extra, entries, diag, beta, x_star, offset)| {
            let m = n + extra;
            let mut a = vec![0.0; m * n];
            for i in 0..n {
                a[i * n + i] = diag;
            }
            for (k, v) in a[n * n..].iter_mut().enumerate() {
                *v = entries[k % entries.len()];
            }
            let problem = NonlinearLeastSquares::new(a, m, n, beta, &x_star);
            let x0 = x_star.iter().zip(&offset).map(|(x, d)| x + d).collect();
            (problem, x_star, x0)
        })
}

/// A convex quadratic $f(x) = (x - x^\star)^\top (L L^\top + I)(x - x^\star)$
/// in `1..=max_dim` dimensions, as its Hessian factor $L$ and minimiser
/// $x^\star$ (minimum value 0).
pub fn convex_quadratic(max_dim: usize) -> impl Strategy<Value = (Mat<f64>, Vec<f64>)> {
    (1..=max_dim.max(1))
        .prop_flat_map(|n| (vec(-2.0..2.0f64, n * n), vec(-5.0..5.0f64, n)))
        .prop_map(|(l, x)| {
            let n = x.len();
            (Mat::from_fn(n, n, |i, j| l[i * n + j]), x)
        })
}

/// Evaluates the [`convex_quadratic`] $f(x)$ for factor `l` and minimiser `xs`.
pub fn convex_quadratic_value(l: &Mat<f64>, xs: &[f64], x: &[f64]) -> f64 {
    let d: Vec<f64> = x.iter().zip(xs).map(|(a, b)| a - b).collect();
    let n = d.len();
    let lt_d: f64 = (0..n)
        .map(|j| (0..n).map(|i| l[(i, j)] * d[i]).sum::<f64>().powi(2))
        .sum();
    lt_d + d.iter().map(|v| v * v).sum::<f64>()
}

/// A soft-dynamics problem (Eq. 3) with a random stable-ish linear model
/// whose exact solution is known: the reference is a rollout of the model
/// under random controls, both represented exactly (degree-1 B-splines with
/// a knot at every sample, so $x_k$ and $u_k$ are coefficients), so the
/// optimum has zero task cost and zero inconsistency for every $\lambda \ge 0$.
/// Returned with that optimum's parameter vector.
pub fn linear_soft_dynamics() -> impl Strategy<Value = (Eq3Problem<LinearModel, TrackingCost>, Vec<f64>)> {
    (1usize..=3, 1usize..=2, 3usize..=25, 0.0..1e4f64)
        .prop_flat_map(|(n, m, horizon, lambda)| {
            (
                Just((n, m, horizon, lambda)),
                vec(-0.3..0.3f64, n * n),
                vec(-1.0..1.0f64, n * m),
                vec(-1.0..1.0f64, n),
                vec(-1.0..1.0f64, horizon * m),
            )
        })
        .prop_map(|((n, m, horizon, lambda), a, b, x0, u)| {
            let a = Mat::from_fn(n, n, |i, j| a[i * n + j] + if i == j { 0.9 } else { 0.0 });
            let b = Mat::from_fn(n, m, |i, j| b[i * m + j]);
            let model = LinearModel::new(a, b).expect("finite");
            let mut states = vec![x0];
            for k in 0..horizon {
                let mut next = vec![0.0; n];
                model
                    .step(&states[k], &u[k * m..(k + 1) * m], &mut next)
                    .expect("linear step");
                states.push(next);
            }
            let state_ref = Mat::from_fn(horizon + 1, n, |k, i| states[k][i]);
            let control_ref = Mat::from_fn(horizon, m, |k, j| u[k * m + j]);
            let cost = TrackingCost::new(
                state_ref.clone(),
                control_ref.clone(),
                &vec![1.0; n],
                &vec![0.1; m],
                &vec![1.0; n],
            )
            .expect("valid weights");
            let times: Vec<f64> = (0..=horizon).map(|k| k as f64).collect();
            let xb = BSplineBasis::clamped(&times, 1).expect("valid");
            let ub = BSplineBasis::clamped(&times[..horizon.max(2)], 1).expect("valid");
            let problem = Eq3Problem::new(model, cost, &xb, &ub, &times, Lambda::Constant(lambda)).expect("valid");
            // controls at t_0..t_{N-1}: coefficient k of the control basis is u_k
            let cu = Mat::from_fn(problem.n_control_coeffs(), m, |k, j| {
                if k < horizon { u[k * m + j] } else { 0.0 }
            });
            let theta = problem.pack(&state_ref, &cu).expect("shapes agree");
            (problem, theta)
        })
}
