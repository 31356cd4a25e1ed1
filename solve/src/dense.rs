//! Dense Cholesky kernels for the small symmetric systems the workspace's
//! solvers factor at every step (a local fit's normal matrix in `lwr`, at
//! $p$ = 3 to 10; DDP's $Q_{uu}$ in `ddp`): written once, row-major,
//! allocation-free.
//!
//! Hand-written on purpose: at these sizes they beat nalgebra's `Cholesky`
//! and faer's `llt` with preallocated buffers (`lwr/benches/cholesky.rs`
//! and `ddp/benches/cholesky.rs` time them against both), and the tests
//! check them against a closed form and against the matrix they factor.
//!
//! ```
//! use solve::dense::{cholesky, cholesky_solve};
//! // A = [[4, 2], [2, 3]] = L L^T, L = [[2, 0], [1, sqrt 2]]
//! let mut a = [4.0, 2.0, 2.0, 3.0];
//! let (lo, hi) = cholesky(&mut a, 2).expect("positive definite");
//! assert_eq!((lo, hi), (2f64.sqrt(), 2.0));
//! let mut b = [2.0, 1.0]; // A x = b at x = (0.5, 0)
//! cholesky_solve(&a, 2, &mut b);
//! assert!((b[0] - 0.5).abs() < 1e-15 && b[1].abs() < 1e-15);
//! assert!(cholesky(&mut [1.0, 2.0, 2.0, 1.0], 2).is_none()); // indefinite
//! ```

/// In-place Cholesky $A = L L^\top$ of the row-major $n \times n$ symmetric
/// matrix `a` (its lower triangle read, $L$ written there; the strict upper
/// triangle is left as it was). Returns the smallest and largest pivots
/// $L_{jj}$, or `None` when a pivot is not positive and finite (the matrix
/// is not numerically positive definite, or holds a NaN).
#[inline]
pub fn cholesky(a: &mut [f64], n: usize) -> Option<(f64, f64)> {
    debug_assert!(a.len() >= n * n);
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for j in 0..n {
        let mut djj = a[j * n + j];
        for k in 0..j {
            djj -= a[j * n + k] * a[j * n + k];
        }
        if !(djj > 0.0 && djj.is_finite()) {
            return None;
        }
        let ljj = djj.sqrt();
        lo = lo.min(ljj);
        hi = hi.max(ljj);
        a[j * n + j] = ljj;
        for i in j + 1..n {
            let mut v = a[i * n + j];
            for k in 0..j {
                v -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = v / ljj;
        }
    }
    Some((lo, hi))
}

/// Solves $L L^\top x = b$ in place, $L$ from [`cholesky`] (lower triangle
/// of the row-major $n \times n$ `l`).
#[inline]
pub fn cholesky_solve(l: &[f64], n: usize, b: &mut [f64]) {
    debug_assert!(l.len() >= n * n && b.len() >= n);
    for i in 0..n {
        let mut v = b[i];
        for k in 0..i {
            v -= l[i * n + k] * b[k];
        }
        b[i] = v / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut v = b[i];
        for k in i + 1..n {
            v -= l[k * n + i] * b[k];
        }
        b[i] = v / l[i * n + i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Random symmetric positive definite matrices $A = B B^\top + I$: the
    /// factor reproduces $A$, the solve inverts it, and the pivots are
    /// those of the factor's diagonal.
    #[test]
    fn factors_and_solves_random_positive_definite_matrices() {
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for n in 1..=10 {
            let b: Vec<f64> = (0..n * n).map(|_| next()).collect();
            let a: Vec<f64> = (0..n * n)
                .map(|ij| {
                    let (i, j) = (ij / n, ij % n);
                    (0..n).map(|k| b[i * n + k] * b[j * n + k]).sum::<f64>() + f64::from(u8::from(i == j))
                })
                .collect();
            let mut l = a.clone();
            let (lo, hi) = cholesky(&mut l, n).expect("positive definite");
            let diag: Vec<f64> = (0..n).map(|j| l[j * n + j]).collect();
            assert_eq!(lo, diag.iter().copied().fold(f64::INFINITY, f64::min));
            assert_eq!(hi, diag.iter().copied().fold(0.0, f64::max));
            for i in 0..n {
                for j in 0..=i {
                    let llt: f64 = (0..=j).map(|k| l[i * n + k] * l[j * n + k]).sum();
                    assert!((llt - a[i * n + j]).abs() < 1e-12, "n {n}: (L L^T)[{i}][{j}]");
                }
            }
            let x: Vec<f64> = (0..n).map(|_| next()).collect();
            let mut rhs: Vec<f64> = (0..n).map(|i| (0..n).map(|j| a[i * n + j] * x[j]).sum()).collect();
            cholesky_solve(&l, n, &mut rhs);
            for (got, want) in rhs.iter().zip(&x) {
                assert!((got - want).abs() < 1e-10, "n {n}: {got} against {want}");
            }
        }
    }

    #[test]
    fn indefinite_singular_and_nan_matrices_are_refused() {
        assert!(cholesky(&mut [1.0, 2.0, 2.0, 1.0], 2).is_none());
        assert!(cholesky(&mut [1.0, 1.0, 1.0, 1.0], 2).is_none());
        assert!(cholesky(&mut [f64::NAN, 0.0, 0.0, 1.0], 2).is_none());
        assert!(cholesky(&mut [1.0, 0.0, 0.0, f64::INFINITY], 2).is_none());
        assert_eq!(cholesky(&mut [], 0), Some((f64::INFINITY, 0.0)));
    }
}
