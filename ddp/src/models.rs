//! Built-in dynamics and costs: [`LinearDynamics`], [`QuadraticCost`], and
//! three benchmark systems, [`Pendulum`], [`CartPole`] and [`Acrobot`],
//! discretised by semi-implicit Euler (the discretisation of Crocoddyl's
//! `IntegratedActionModelEuler`).

use faer::Mat;

/// The benchmark systems of `nprl-systems` (the very types `trajopt`'s
/// Eq. 3 swing-ups step), here as [`Dynamics`]: a torque-driven
/// pendulum, a cart-pole and an acrobot, and the enum of the three. The
/// pendulum has analytic second derivatives, so with
/// [`DdpMethod::Ddp`](crate::DdpMethod::Ddp) DDP on it is full DDP; on the
/// others the solver is iLQR.
pub use systems::{Acrobot, CartPole, Pendulum, SwingUpModel};

use crate::error::{DdpError, Result, check_finite, check_len};
use crate::problem::{Cost, CostDerivatives, Dynamics};
use systems::ModelResult;

fn to_row_major(what: &'static str, a: &Mat<f64>) -> Result<Vec<f64>> {
    let v: Vec<f64> = (0..a.nrows())
        .flat_map(|i| (0..a.ncols()).map(move |j| a[(i, j)]))
        .collect();
    check_finite(what, &v)?;
    Ok(v)
}

/// Linear dynamics $x_{k+1} = A x_k + B u_k$.
///
/// Its second derivatives are zero, so DDP and iLQR coincide on it.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearDynamics {
    n: usize,
    m: usize,
    a: Vec<f64>,
    b: Vec<f64>,
}

impl LinearDynamics {
    /// Dynamics from $A$ ($n \times n$) and $B$ ($n \times m$).
    ///
    /// # Errors
    /// Wrong shapes, empty dimensions or non-finite entries.
    pub fn new(a: &Mat<f64>, b: &Mat<f64>) -> Result<Self> {
        let n = a.nrows();
        check_len("A columns", n, a.ncols())?;
        check_len("B rows", n, b.nrows())?;
        if n == 0 || b.ncols() == 0 {
            return Err(DdpError::InvalidParameter {
                name: "LinearDynamics",
                reason: "state and control dimensions must be positive".into(),
            });
        }
        Ok(Self {
            n,
            m: b.ncols(),
            a: to_row_major("A", a)?,
            b: to_row_major("B", b)?,
        })
    }

    /// $A$.
    pub fn a(&self) -> Mat<f64> {
        Mat::from_fn(self.n, self.n, |i, j| self.a[i * self.n + j])
    }

    /// $B$.
    pub fn b(&self) -> Mat<f64> {
        Mat::from_fn(self.n, self.m, |i, j| self.b[i * self.m + j])
    }
}

impl Dynamics for LinearDynamics {
    fn state_dim(&self) -> usize {
        self.n
    }
    fn control_dim(&self) -> usize {
        self.m
    }
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        for (i, out) in next.iter_mut().enumerate() {
            let ax: f64 = self.a[i * self.n..(i + 1) * self.n]
                .iter()
                .zip(x)
                .map(|(a, x)| a * x)
                .sum();
            let bu: f64 = self.b[i * self.m..(i + 1) * self.m]
                .iter()
                .zip(u)
                .map(|(b, u)| b * u)
                .sum();
            *out = ax + bu;
        }
        Ok(())
    }
    fn jacobians(&self, _x: &[f64], _u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        fx.copy_from_slice(&self.a);
        fu.copy_from_slice(&self.b);
        Ok(true)
    }
    fn weighted_hessian(&self, _: &[f64], _: &[f64], _: &[f64], hess: &mut [f64]) -> ModelResult<bool> {
        hess.fill(0.0); // linear
        Ok(true)
    }
}

/// Quadratic tracking cost
/// $$\ell(x, u, k) = (x - x^r_k)^\top Q (x - x^r_k) + (u - u^r_k)^\top R (u - u^r_k),
/// \qquad \ell_f(x) = (x - x^r_N)^\top Q_f (x - x^r_N),$$
/// without a factor $\tfrac12$: the scaling of `trajopt`'s `TrackingCost`
/// ($c_k = \sum_i q_i (x_{k,i} - x^d_{k,i})^2 + \dots$), so that the same
/// diagonal weights give the same cost in both crates. (Up to version 0.1
/// this cost carried a $\tfrac12$; halving old weights gives exactly the
/// old cost, optimum and value function.) Gradients $2 Q (x - x^r_k)$,
/// Hessians $2 Q$.
///
/// References default to zero; a per-step reference shorter than the
/// horizon holds its last value. $Q$, $R$, $Q_f$ must be symmetric (not
/// necessarily definite: the solver regularises).
#[derive(Debug, Clone, PartialEq)]
pub struct QuadraticCost {
    n: usize,
    m: usize,
    q: Vec<f64>,
    r: Vec<f64>,
    qf: Vec<f64>,
    x_ref: Vec<Vec<f64>>,
    u_ref: Vec<Vec<f64>>,
}

fn check_symmetric(what: &'static str, a: &[f64], n: usize) -> Result<()> {
    for i in 0..n {
        for j in 0..i {
            let (x, y) = (a[i * n + j], a[j * n + i]);
            if (x - y).abs() > 1e-12 * (1.0 + x.abs().max(y.abs())) {
                return Err(DdpError::InvalidParameter {
                    name: what,
                    reason: format!("not symmetric: entry ({i}, {j}) is {x}, ({j}, {i}) is {y}"),
                });
            }
        }
    }
    Ok(())
}

impl QuadraticCost {
    /// A cost regulating to zero with weights $Q$ ($n \times n$), $R$
    /// ($m \times m$) and $Q_f$ ($n \times n$).
    ///
    /// # Errors
    /// Non-square, mismatched, asymmetric or non-finite weights.
    pub fn new(q: &Mat<f64>, r: &Mat<f64>, qf: &Mat<f64>) -> Result<Self> {
        let (n, m) = (q.nrows(), r.nrows());
        check_len("Q columns", n, q.ncols())?;
        check_len("R columns", m, r.ncols())?;
        check_len("Q_f rows", n, qf.nrows())?;
        check_len("Q_f columns", n, qf.ncols())?;
        let (q, r, qf) = (to_row_major("Q", q)?, to_row_major("R", r)?, to_row_major("Q_f", qf)?);
        check_symmetric("Q", &q, n)?;
        check_symmetric("R", &r, m)?;
        check_symmetric("Q_f", &qf, n)?;
        Ok(Self {
            n,
            m,
            q,
            r,
            qf,
            x_ref: vec![vec![0.0; n]],
            u_ref: vec![vec![0.0; m]],
        })
    }

    /// Diagonal weights: $Q = \mathrm{diag}(q)$, $R = \mathrm{diag}(r)$, $Q_f = \mathrm{diag}(q_f)$.
    ///
    /// # Errors
    /// Mismatched lengths or non-finite entries.
    pub fn diagonal(q: &[f64], r: &[f64], qf: &[f64]) -> Result<Self> {
        let diag = |d: &[f64]| Mat::from_fn(d.len(), d.len(), |i, j| if i == j { d[i] } else { 0.0 });
        Self::new(&diag(q), &diag(r), &diag(qf))
    }

    /// A constant state target $x^r_k = x^r$ for every $k$ (terminal included).
    ///
    /// # Errors
    /// Wrong size or non-finite entries.
    pub fn with_state_target(self, target: &[f64]) -> Result<Self> {
        self.with_state_reference(vec![target.to_vec()])
    }

    /// A per-step state reference $x^r_0, \dots, x^r_N$ (a shorter one holds
    /// its last value).
    ///
    /// # Errors
    /// An empty reference, wrong sizes or non-finite entries.
    pub fn with_state_reference(mut self, reference: Vec<Vec<f64>>) -> Result<Self> {
        check_reference("state reference", &reference, self.n)?;
        self.x_ref = reference;
        Ok(self)
    }

    /// A per-step control reference $u^r_0, \dots, u^r_{N-1}$ (a shorter one
    /// holds its last value).
    ///
    /// # Errors
    /// An empty reference, wrong sizes or non-finite entries.
    pub fn with_control_reference(mut self, reference: Vec<Vec<f64>>) -> Result<Self> {
        check_reference("control reference", &reference, self.m)?;
        self.u_ref = reference;
        Ok(self)
    }

    fn x_ref(&self, k: usize) -> &[f64] {
        &self.x_ref[k.min(self.x_ref.len() - 1)]
    }

    fn u_ref(&self, k: usize) -> &[f64] {
        &self.u_ref[k.min(self.u_ref.len() - 1)]
    }

    /// The terminal reference index used by [`Cost::terminal`] (the last
    /// entry of the state reference).
    fn x_ref_terminal(&self) -> &[f64] {
        &self.x_ref[self.x_ref.len() - 1]
    }
}

fn check_reference(what: &'static str, reference: &[Vec<f64>], dim: usize) -> Result<()> {
    if reference.is_empty() {
        return Err(DdpError::InvalidParameter {
            name: what,
            reason: "must hold at least one vector".into(),
        });
    }
    for r in reference {
        check_len(what, dim, r.len())?;
        check_finite(what, r)?;
    }
    Ok(())
}

/// $d^\top W d$ with $d = x - r$ and, optionally, its gradient $2 W d$.
fn quad(w: &[f64], x: &[f64], r: &[f64], grad: Option<&mut [f64]>) -> f64 {
    let n = x.len();
    let mut value = 0.0;
    let mut g_local = [0.0; 16];
    let mut g_heap;
    let g: &mut [f64] = match grad {
        Some(g) => g,
        None if n <= 16 => &mut g_local[..n],
        None => {
            g_heap = vec![0.0; n];
            &mut g_heap
        }
    };
    for i in 0..n {
        let wd: f64 = (0..n).map(|j| w[i * n + j] * (x[j] - r[j])).sum();
        g[i] = 2.0 * wd;
        value += (x[i] - r[i]) * wd;
    }
    value
}

/// `out = 2 w`.
fn twice(w: &[f64], out: &mut [f64]) {
    for (o, w) in out.iter_mut().zip(w) {
        *o = 2.0 * w;
    }
}

impl Cost for QuadraticCost {
    fn running(&self, k: usize, x: &[f64], u: &[f64]) -> f64 {
        quad(&self.q, x, self.x_ref(k), None) + quad(&self.r, u, self.u_ref(k), None)
    }
    fn running_derivatives(&self, k: usize, x: &[f64], u: &[f64], d: &mut CostDerivatives) {
        quad(&self.q, x, self.x_ref(k), Some(&mut d.lx));
        quad(&self.r, u, self.u_ref(k), Some(&mut d.lu));
        twice(&self.q, &mut d.lxx);
        twice(&self.r, &mut d.luu);
    }
    fn terminal(&self, x: &[f64]) -> f64 {
        quad(&self.qf, x, self.x_ref_terminal(), None)
    }
    fn terminal_derivatives(&self, x: &[f64], lx: &mut [f64], lxx: &mut [f64]) {
        quad(&self.qf, x, self.x_ref_terminal(), Some(lx));
        twice(&self.qf, lxx);
    }
}

// The swing-up systems implement the one model contract, `systems::Dynamics`,
// themselves (semi-implicit Euler, exact Jacobians, the torque pendulum's
// second derivatives).

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_dynamics_steps_and_rejects_bad_shapes() {
        let a = Mat::from_fn(2, 2, |i, j| [[1.0, 0.1], [0.0, 1.0]][i][j]);
        let b = Mat::from_fn(2, 1, |i, _| [0.0, 0.1][i]);
        let f = LinearDynamics::new(&a, &b).expect("valid");
        let mut next = [0.0; 2];
        f.step(&[1.0, 2.0], &[3.0], &mut next).expect("step");
        assert_eq!(next, [1.2, 2.3]);
        assert!(LinearDynamics::new(&a, &Mat::zeros(3, 1)).is_err());
        assert_eq!(f.a(), a);
        assert_eq!(f.b(), b);
    }

    #[test]
    fn quadratic_cost_values_and_validation() {
        let c = QuadraticCost::diagonal(&[2.0, 0.0], &[4.0], &[6.0, 6.0])
            .expect("valid")
            .with_state_target(&[1.0, 0.0])
            .expect("valid");
        // no 1/2: q (x - x^r)^2 + r u^2, as trajopt's TrackingCost
        assert_eq!(c.running(0, &[2.0, 5.0], &[1.0]), 2.0 + 4.0);
        assert_eq!(c.terminal(&[0.0, 1.0]), 6.0 * 2.0);
        let asym = Mat::from_fn(2, 2, |i, j| if i < j { 1.0 } else { 0.0 });
        assert!(QuadraticCost::new(&asym, &Mat::identity(1, 1), &Mat::identity(2, 2)).is_err());
        assert!(c.clone().with_state_reference(vec![]).is_err());
        assert!(c.with_control_reference(vec![vec![f64::NAN]]).is_err());
    }

    /// Halved weights give exactly (bit for bit) the cost, gradient and
    /// Hessian of the former $\tfrac12$-scaled cost, which callers rely on
    /// to keep their optimum.
    #[test]
    fn halved_weights_reproduce_the_former_half_scaled_cost_exactly() {
        let q = Mat::from_fn(2, 2, |i, j| [[3.0, 0.7], [0.7, 0.1]][i][j]);
        let r = Mat::from_fn(1, 1, |_, _| 0.01 * 0.01);
        let half = |a: &Mat<f64>| Mat::from_fn(a.nrows(), a.ncols(), |i, j| 0.5 * a[(i, j)]);
        let c = QuadraticCost::new(&half(&q), &half(&r), &half(&q))
            .expect("valid")
            .with_state_target(&[std::f64::consts::PI, 0.0])
            .expect("valid");
        let (x, u) = ([0.3, -1.7], [2.5]);
        let d = [x[0] - std::f64::consts::PI, x[1]];
        let qd = [q[(0, 0)] * d[0] + q[(0, 1)] * d[1], q[(1, 0)] * d[0] + q[(1, 1)] * d[1]];
        // the former implementation: sum_i 1/2 d_i (W d)_i, gradient W d, Hessian W
        let former_state = 0.5 * d[0] * qd[0] + 0.5 * d[1] * qd[1];
        let former_control = 0.5 * u[0] * (r[(0, 0)] * u[0]);
        assert_eq!(c.running(0, &x, &u), former_state + former_control);
        assert_eq!(c.terminal(&x), former_state);
        let mut der = CostDerivatives::zeros(2, 1);
        c.running_derivatives(0, &x, &u, &mut der);
        assert_eq!(der.lx, qd.to_vec());
        assert_eq!(der.lu, vec![r[(0, 0)] * u[0]]);
        assert_eq!(der.lxx, vec![3.0, 0.7, 0.7, 0.1]);
        assert_eq!(der.luu, vec![r[(0, 0)]]);
    }

    #[test]
    fn pendulum_falls_under_gravity() {
        let p = Pendulum::default();
        let mut next = [0.0; 2];
        p.step(&[1.0, 0.0], &[0.0], &mut next).expect("step");
        assert!(next[1] < 0.0 && next[0] < 1.0);
    }

    #[test]
    fn cartpole_rests_hanging_down() {
        let c = CartPole::default();
        let mut next = [0.0; 4];
        c.step(&[0.5, 0.0, 0.0, 0.0], &[0.0], &mut next).expect("step");
        assert_eq!(next, [0.5, 0.0, 0.0, 0.0]);
        c.step(&[0.0, 0.0, 0.0, 0.0], &[1.0], &mut next).expect("step");
        assert!(next[2] > 0.0 && next[3] < 0.0, "{next:?}");
    }
}
