//! `proptest` strategies generating random stabilisable linear-quadratic
//! problems with their discrete Riccati solution (feature `proptest`), so
//! users can property-test their own DDP / iLQR against ours on the same
//! work, and [`check_jacobian`] / [`check_dynamics`], which compare analytic
//! derivatives with central differences. The crate's own tests use them.

use faer::Mat;
use faer::linalg::solvers::Solve;
use proptest::collection::vec;
use proptest::prelude::*;

use crate::error::{DdpError, Result, check_len};
use crate::models::{LinearDynamics, QuadraticCost};
use crate::problem::{DdpProblem, Dynamics};

/// A finite-horizon linear-quadratic problem
/// $\min \sum_{k<N} \tfrac12 (x_k^\top Q x_k + u_k^\top R u_k) + \tfrac12 x_N^\top Q_f x_N$,
/// $x_{k+1} = A x_k + B u_k$, with its Riccati solution.
#[derive(Debug, Clone)]
pub struct LqProblem {
    /// $A$ ($n \times n$).
    pub a: Mat<f64>,
    /// $B$ ($n \times m$).
    pub b: Mat<f64>,
    /// $Q \succeq 0$.
    pub q: Mat<f64>,
    /// $R \succ 0$.
    pub r: Mat<f64>,
    /// $Q_f \succeq 0$.
    pub qf: Mat<f64>,
    /// $x_0$.
    pub x0: Vec<f64>,
    /// Horizon $N$.
    pub horizon: usize,
    /// The solution of the Riccati recursion.
    pub riccati: RiccatiSolution,
}

impl LqProblem {
    /// The problem as a [`DdpProblem`] warm-started with zero controls (its
    /// [`QuadraticCost`] weights are $Q/2$, $R/2$, $Q_f/2$).
    ///
    /// # Panics
    /// Never for strategy output (the data is valid by construction).
    pub fn to_ddp_problem(&self) -> DdpProblem<LinearDynamics, QuadraticCost> {
        let dynamics = LinearDynamics::new(&self.a, &self.b).expect("valid by construction");
        // QuadraticCost has no 1/2: half the weights
        let half = |w: &Mat<f64>| Mat::from_fn(w.nrows(), w.ncols(), |i, j| 0.5 * w[(i, j)]);
        let cost = QuadraticCost::new(&half(&self.q), &half(&self.r), &half(&self.qf)).expect("valid by construction");
        DdpProblem::new(dynamics, cost, &self.x0, self.horizon).expect("valid by construction")
    }
}

/// The discrete-time finite-horizon Riccati solution: $P_N = Q_f$,
/// $K_k = -(R + B^\top P_{k+1} B)^{-1} B^\top P_{k+1} A$,
/// $P_k = Q + A^\top P_{k+1} (A + B K_k)$; optimal $u_k = K_k x_k$ and
/// optimal cost-to-go $\tfrac12 x_k^\top P_k x_k$.
#[derive(Debug, Clone)]
pub struct RiccatiSolution {
    /// $K_0, \dots, K_{N-1}$ ($m \times n$).
    pub gains: Vec<Mat<f64>>,
    /// $P_0, \dots, P_N$ (the value Hessians $V_{xx}$).
    pub value_hessians: Vec<Mat<f64>>,
    /// Optimal states $x_0, \dots, x_N$.
    pub states: Vec<Vec<f64>>,
    /// Optimal controls $u_0, \dots, u_{N-1}$.
    pub controls: Vec<Vec<f64>>,
    /// Optimal cost $\tfrac12 x_0^\top P_0 x_0$.
    pub cost: f64,
}

/// Solves the finite-horizon Riccati recursion (with faer's dense Cholesky;
/// independent of the DDP code). `None` if $R + B^\top P B$ is not positive
/// definite at some step.
pub fn riccati(
    a: &Mat<f64>,
    b: &Mat<f64>,
    q: &Mat<f64>,
    r: &Mat<f64>,
    qf: &Mat<f64>,
    x0: &[f64],
    horizon: usize,
) -> Option<RiccatiSolution> {
    let n = a.nrows();
    let mut p = qf.clone();
    let mut hessians = vec![p.clone()];
    let mut gains = Vec::with_capacity(horizon);
    for _ in 0..horizon {
        let pb = &p * b;
        let pa = &p * a;
        let h = r + b.transpose() * &pb;
        let h = Mat::from_fn(h.nrows(), h.ncols(), |i, j| 0.5 * (h[(i, j)] + h[(j, i)]));
        let llt = h.llt(faer::Side::Lower).ok()?;
        let rhs = -(b.transpose() * &pa);
        let k = llt.solve(&rhs);
        let next = q + a.transpose() * (&pa + &pb * &k);
        p = Mat::from_fn(n, n, |i, j| 0.5 * (next[(i, j)] + next[(j, i)]));
        hessians.push(p.clone());
        gains.push(k);
    }
    gains.reverse();
    hessians.reverse();
    let mut states = vec![x0.to_vec()];
    let mut controls = Vec::with_capacity(horizon);
    for k in 0..horizon {
        let x = Mat::from_fn(n, 1, |i, _| states[k][i]);
        let u = &gains[k] * &x;
        let xn = a * &x + b * &u;
        controls.push((0..u.nrows()).map(|i| u[(i, 0)]).collect());
        states.push((0..n).map(|i| xn[(i, 0)]).collect());
    }
    let x = Mat::from_fn(n, 1, |i, _| x0[i]);
    let cost = 0.5 * (x.transpose() * &hessians[0] * &x)[(0, 0)];
    Some(RiccatiSolution {
        gains,
        value_hessians: hessians,
        states,
        controls,
        cost,
    })
}

/// Random stabilisable linear-quadratic problems with state dimension
/// `1..=max_n`, control dimension `1..=max_m`, horizon `1..=max_horizon`:
/// $A = I + 0.2\,G$ with $G$ entries in $[-1, 1]$ (spectral radius at most
/// $1 + 0.2 n$), $B$ whose top $m$ rows hold $0.1 + $ a diagonal in $[0.5, 1]$
/// when $m \le n$ (so $(A, B)$ is controllable for generic $G$), $Q = C C^\top$,
/// $R = D D^\top + 0.1 I$, $Q_f = Q + I$, $x_0 \in [-1, 1]^n$; with their
/// Riccati solution.
pub fn lq_problem(max_n: usize, max_m: usize, max_horizon: usize) -> impl Strategy<Value = LqProblem> {
    (1..=max_n.max(1), 1..=max_m.max(1), 1..=max_horizon.max(1))
        .prop_flat_map(|(n, m, horizon)| {
            (
                Just((n, m, horizon)),
                vec(-1.0..1.0f64, n * n),
                vec(-1.0..1.0f64, n * m),
                vec(0.5..1.0f64, m),
                vec(-1.0..1.0f64, n * n),
                vec(-1.0..1.0f64, m * m),
                vec(-1.0..1.0f64, n),
            )
        })
        .prop_map(|((n, m, horizon), g, bv, bdiag, c, d, x0)| {
            let a = Mat::from_fn(n, n, |i, j| if i == j { 1.0 } else { 0.0 } + 0.2 * g[i * n + j]);
            let b = Mat::from_fn(n, m, |i, j| {
                let base = 0.1 * bv[i * m + j];
                if i == j { base + bdiag[j] } else { base }
            });
            let cm = Mat::from_fn(n, n, |i, j| c[i * n + j]);
            let dm = Mat::from_fn(m, m, |i, j| d[i * m + j]);
            let sym = |x: Mat<f64>| Mat::from_fn(x.nrows(), x.ncols(), |i, j| 0.5 * (x[(i, j)] + x[(j, i)]));
            let q = sym(&cm * cm.transpose());
            let r = sym(&dm * dm.transpose() + Mat::<f64>::identity(m, m) * faer::Scale(0.1));
            let qf = sym(&q + Mat::<f64>::identity(n, n));
            let riccati = riccati(&a, &b, &q, &r, &qf, &x0, horizon).expect("R is positive definite");
            LqProblem {
                a,
                b,
                q,
                r,
                qf,
                x0,
                horizon,
                riccati,
            }
        })
}

/// The worst disagreement found by [`check_jacobian`]: the workspace's one
/// record of a derivative check, with its error measure.
pub use solve::JacobianCheck;

/// Compares the analytic Jacobian `analytic` ($q \times p$, row-major) of
/// $f: \mathbb{R}^p \to \mathbb{R}^q$ at `z` with central differences
/// $(f(z + h e_j) - f(z - h e_j)) / 2h$,
/// $h = \epsilon^{1/3} \max(1, \lvert z_j \rvert)$ (the step of the
/// central differences of [`systems::central_differences`]), and returns the worst entry. For
/// smooth $f$ of unit scale the differences are accurate to about
/// $10^{-10}$, so a correct Jacobian gives `max_rel_error` below $10^{-6}$
/// and a wrong entry typically above $10^{-3}$.
///
/// ```
/// use ddp::strategies::check_jacobian;
/// // f(z) = (z0 z1, sin z0): J = [[z1, z0], [cos z0, 0]]
/// let z = [0.3, -2.0];
/// let f = |z: &[f64]| vec![z[0] * z[1], z[0].sin()];
/// let good = check_jacobian(f, &z, &[-2.0, 0.3, 0.3f64.cos(), 0.0])?;
/// assert!(good.max_rel_error < 1e-8);
/// let bad = check_jacobian(f, &z, &[-2.0, 0.3, 0.3f64.sin(), 0.0])?;
/// assert_eq!((bad.row, bad.col), (1, 0));
/// # Ok::<(), ddp::DdpError>(())
/// ```
///
/// # Errors
/// `analytic` not of length $q p$ (with $q$ the length of $f(z)$), or `f`
/// returning outputs of different lengths.
pub fn check_jacobian(mut f: impl FnMut(&[f64]) -> Vec<f64>, z: &[f64], analytic: &[f64]) -> Result<JacobianCheck> {
    let p = z.len();
    let q = f(z).len();
    check_len("analytic Jacobian", q * p, analytic.len())?;
    let mut numeric = vec![0.0; q * p];
    let mut scratch = vec![0.0; p + 2 * q];
    crate::diff::central_jacobian(
        |z, out| {
            let v = f(z);
            check_len("f(z)", out.len(), v.len())?;
            out.copy_from_slice(&v);
            Ok(())
        },
        z,
        q,
        &mut numeric,
        &mut scratch,
    )?;
    let mut worst = JacobianCheck::new();
    for (k, (&a, &d)) in analytic.iter().zip(&numeric).enumerate() {
        worst.record(k / p, k % p, a, d);
    }
    Ok(worst)
}

/// [`check_jacobian`] for both Jacobians of `dynamics` at $(x, u)$: returns
/// the checks of $f_x$ and $f_u$ as written by [`Dynamics::jacobians`] (central differences where it writes none).
///
/// # Errors
/// Wrong-sized `x` or `u`, or a failed step or derivative of the dynamics.
pub fn check_dynamics<D: Dynamics>(dynamics: &D, x: &[f64], u: &[f64]) -> Result<(JacobianCheck, JacobianCheck)> {
    let (n, m) = (dynamics.state_dim(), dynamics.control_dim());
    check_len("x", n, x.len())?;
    check_len("u", m, u.len())?;
    let (mut fx, mut fu) = (vec![0.0; n * n], vec![0.0; n * m]);
    systems::jacobians_or_differences(dynamics, x, u, &mut fx, &mut fu)?;
    let step = |x: &[f64], u: &[f64]| -> Result<Vec<f64>> {
        let mut next = vec![0.0; n];
        dynamics.step(x, u, &mut next)?;
        Ok(next)
    };
    step(x, u)?;
    // a step that fails at a perturbed point is reported as NaN output
    let or_nan = |r: Result<Vec<f64>>| r.unwrap_or_else(|_: DdpError| vec![f64::NAN; n]);
    let cx = check_jacobian(|z| or_nan(step(z, u)), x, &fx)?;
    let cu = check_jacobian(|z| or_nan(step(x, z)), u, &fu)?;
    Ok((cx, cu))
}
