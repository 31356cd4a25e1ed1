//! The bounded Gauss-Newton step as a sparse QP, solved by clarabel.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus};
use faer::sparse::SparseColMat;

use crate::least_squares::LinearBounds;

/// $\arg\min_\delta\, g^\top \delta + \tfrac12 \delta^\top H \delta$ subject to
/// $\ell \le A(\theta + \delta) \le u$; `h` holds the upper triangle (any
/// entries below the diagonal are ignored). `None` if
/// the QP could not be solved.
pub(crate) fn bounded_step(
    h: &SparseColMat<usize, f64>,
    grad: &[f64],
    bounds: &LinearBounds,
    theta: &[f64],
) -> Option<Vec<f64>> {
    let n = h.ncols();
    // upper triangle of H, columns in order, rows sorted
    let (mut colptr, mut rowval, mut nzval) = (vec![0], Vec::new(), Vec::new());
    for j in 0..n {
        for (&i, &v) in h.symbolic().row_idx_of_col_raw(j).iter().zip(h.val_of_col(j)) {
            if i <= j {
                rowval.push(i);
                nzval.push(v);
            }
        }
        colptr.push(rowval.len());
    }
    let p = CscMatrix::new(n, n, colptr, rowval, nzval);
    solve(&p, grad, bounds, theta)
}

/// The smallest step (in the Euclidean norm) onto $\ell \le A(\theta + \delta) \le u$.
pub(crate) fn projection(bounds: &LinearBounds, theta: &[f64]) -> Option<Vec<f64>> {
    let n = theta.len();
    let p = CscMatrix::new(n, n, (0..=n).collect(), (0..n).collect(), vec![1.0; n]);
    solve(&p, &vec![0.0; n], bounds, theta)
}

fn solve(p: &CscMatrix<f64>, q: &[f64], bounds: &LinearBounds, theta: &[f64]) -> Option<Vec<f64>> {
    let n = theta.len();
    let at = bounds.apply(theta);
    // A d <= u - A theta and -A d <= A theta - l, one row per finite side
    let mut triplets = Vec::new();
    let mut b = Vec::new();
    for (i, &ati) in at.iter().enumerate() {
        let cols = bounds.a.symbolic().col_idx_of_row_raw(i);
        let vals = bounds.a.val_of_row(i);
        for (sign, rhs) in [(1.0, bounds.upper[i] - ati), (-1.0, ati - bounds.lower[i])] {
            if rhs.is_finite() {
                let row = b.len();
                triplets.extend(
                    cols.iter()
                        .zip(vals)
                        .map(|(&c, &v)| faer::sparse::Triplet::new(row, c, sign * v)),
                );
                b.push(rhs);
            }
        }
    }
    let a = SparseColMat::<usize, f64>::try_new_from_triplets(b.len(), n, &triplets).ok()?;
    let a = CscMatrix::new(
        b.len(),
        n,
        a.symbolic().col_ptr().to_vec(),
        a.symbolic().row_idx().to_vec(),
        a.val().to_vec(),
    );
    let cones = [NonnegativeConeT(b.len())];
    let settings = DefaultSettings {
        verbose: false,
        ..DefaultSettings::default()
    };
    let mut solver = DefaultSolver::new(p, q, &a, &b, &cones, settings).ok()?;
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => {
            let x = solver.solution.x.clone();
            x.iter().all(|v| v.is_finite()).then_some(x)
        }
        _ => None,
    }
}
