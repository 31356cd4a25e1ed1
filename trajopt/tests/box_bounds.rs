//! Gauss-Newton under box bounds without a QP solver (projected Newton
//! steps) reaches the optimum the QP-per-step path reaches on the same
//! bounds, and the closed-form one where there is one.
#![cfg(feature = "bounds")]

use faer::sparse::{SparseRowMat, SymbolicSparseRowMat, Triplet};
use proptest::prelude::*;
use trajopt::{GaussNewton, GaussNewtonSettings, LeastSquaresProblem, LinearBounds};

/// Residuals `f(x)` with a dense Jacobian `jac(x)` (row-major) and bounds.
struct Bounded<F, J> {
    n: usize,
    m: usize,
    f: F,
    jac: J,
    bounds: LinearBounds,
}

impl<F, J> LeastSquaresProblem for Bounded<F, J>
where
    F: Fn(&[f64], &mut [f64]),
    J: Fn(&[f64], &mut [f64]),
{
    fn n_params(&self) -> usize {
        self.n
    }

    fn n_residuals(&self) -> usize {
        self.m
    }

    fn residuals(&self, x: &[f64], r: &mut [f64]) -> trajopt::Result<()> {
        (self.f)(x, r);
        Ok(())
    }

    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
        let (m, n) = (self.m, self.n);
        SymbolicSparseRowMat::new_checked(
            m,
            n,
            (0..=m).map(|i| i * n).collect(),
            None,
            (0..m * n).map(|k| k % n).collect(),
        )
    }

    fn jacobian_values(&self, x: &[f64], values: &mut [f64]) -> trajopt::Result<()> {
        (self.jac)(x, values);
        Ok(())
    }

    fn bounds(&self) -> Option<&LinearBounds> {
        Some(&self.bounds)
    }
}

/// The box `lower <= x <= upper` as linear bounds; with `general`, one
/// more row, $x_0 + x_1$ unbounded, which makes them no box (the QP path).
fn bounds(lower: &[f64], upper: &[f64], general: bool) -> LinearBounds {
    let n = lower.len();
    let mut triplets: Vec<Triplet<usize, usize, f64>> = (0..n).map(|k| Triplet::new(k, k, 1.0)).collect();
    let (mut lo, mut hi) = (lower.to_vec(), upper.to_vec());
    if general {
        triplets.extend([Triplet::new(n, 0, 1.0), Triplet::new(n, 1.min(n - 1), 1.0)]);
        lo.push(f64::NEG_INFINITY);
        hi.push(f64::INFINITY);
    }
    let rows = if general { n + 1 } else { n };
    LinearBounds {
        a: SparseRowMat::try_new_from_triplets(rows, n, &triplets).expect("bounds"),
        lower: lo,
        upper: hi,
    }
}

fn tight() -> GaussNewtonSettings {
    GaussNewtonSettings {
        max_iterations: 500,
        tol_cost: 1e-15,
        tol_step: 1e-15,
        tol_grad: 1e-15,
        ..GaussNewtonSettings::default()
    }
}

/// Rosenbrock's residuals $(10 (x_1 - x_0^2), 1 - x_0)$ with $x_0 \le 1/2$:
/// the optimum is $(1/2, 1/4)$ with cost $1/4$, on the bound.
#[test]
fn rosenbrock_cut_by_a_bound_ends_on_it_by_either_path() {
    for general in [false, true] {
        let p = Bounded {
            n: 2,
            m: 2,
            f: |x: &[f64], r: &mut [f64]| {
                r[0] = 10.0 * (x[1] - x[0] * x[0]);
                r[1] = 1.0 - x[0];
            },
            jac: |x: &[f64], j: &mut [f64]| j.copy_from_slice(&[-20.0 * x[0], 10.0, -1.0, 0.0]),
            bounds: bounds(&[f64::NEG_INFINITY, f64::NEG_INFINITY], &[0.5, f64::INFINITY], general),
        };
        let fit = GaussNewton::new(tight())
            .expect("settings")
            .solve(&p, &[-1.2, 1.0])
            .expect("solves");
        // the projected steps land on the bound exactly (the free
        // coordinate to the cost test); clarabel's interior point stops
        // about 1e-10 inside the bound
        let tol = if general { 1e-8 } else { 1e-10 };
        assert!(
            (fit.x[0] - 0.5).abs() < tol && (fit.x[1] - 0.25).abs() < tol,
            "general {general}: {:?} ({:?})",
            fit.x,
            fit.status
        );
        assert!((fit.cost - 0.25).abs() < tol, "general {general}: cost {}", fit.cost);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// A random linear least-squares problem in a random box: the
    /// projected Newton path and the QP path end at the same point (the
    /// problem is strictly convex: one minimiser).
    #[test]
    fn linear_problems_in_a_box_agree_with_the_qp_path(
        n in 2usize..6,
        entries in proptest::collection::vec(-2.0..2.0f64, 8 * 6),
        b in proptest::collection::vec(-5.0..5.0f64, 8),
        widths in proptest::collection::vec(0.1..3.0f64, 12),
    ) {
        let m = 8;
        let a: Vec<f64> = (0..m * n).map(|k| entries[k] + if k % (n + 1) == 0 { 3.0 } else { 0.0 }).collect();
        let lower: Vec<f64> = (0..n).map(|k| -widths[k]).collect();
        let upper: Vec<f64> = (0..n).map(|k| widths[6 + k]).collect();
        let solve = |general: bool| {
            let (a, b) = (a.clone(), b.clone());
            let a2 = a.clone();
            let p = Bounded {
                n,
                m,
                f: move |x: &[f64], r: &mut [f64]| {
                    for i in 0..m {
                        r[i] = (0..n).map(|k| a[i * n + k] * x[k]).sum::<f64>() - b[i];
                    }
                },
                jac: move |_: &[f64], j: &mut [f64]| j.copy_from_slice(&a2),
                bounds: bounds(&lower, &upper, general),
            };
            GaussNewton::new(tight()).expect("settings").solve(&p, &vec![0.0; n]).expect("solves")
        };
        let (boxed, qp) = (solve(false), solve(true));
        for k in 0..n {
            prop_assert!(lower[k] <= boxed.x[k] && boxed.x[k] <= upper[k]);
            prop_assert!((boxed.x[k] - qp.x[k]).abs() <= 1e-6 * (1.0 + qp.x[k].abs()),
                "{:?} vs {:?}", boxed.x, qp.x);
        }
        prop_assert!(boxed.cost <= qp.cost * (1.0 + 1e-9) + 1e-12, "{} vs {}", boxed.cost, qp.cost);
    }
}
