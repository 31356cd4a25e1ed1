//! The problem: the dynamics (the workspace's one model contract,
//! [`systems::Dynamics`]), the cost trait, horizon, initial state, warm
//! start and control limits.
//!
//! Matrices cross these traits as row-major slices: entry $(i, j)$ of an
//! $r \times c$ matrix is `a[i * c + j]`. The solver owns every buffer and
//! zeroes it before each call, so an implementation only writes its nonzeros.
//!
//! How DDP treats what a model returns: non-finite output is allowed (a
//! learned model far from its data may return anything) and counts as a
//! blown-up rollout; a [`Dynamics::step`] that returns an error is a
//! blown-up trial rollout in the line search, and an `Err` of
//! [`Ddp::solve`](crate::Ddp::solve) in the warm start's rollout (where
//! there is nothing to fall back on); failed or non-finite Jacobians end
//! the solve with [`DdpStatus::NonFiniteDerivatives`](crate::DdpStatus::NonFiniteDerivatives);
//! a failed [`Dynamics::weighted_hessian`] adds no tensor term at that
//! knot (an iLQR step there).

pub use systems::Dynamics;

use crate::error::{DdpError, Result, check_finite, check_len};

/// First and second derivatives of a running cost $\ell(x, u, k)$ at one
/// knot, filled by [`Cost::running_derivatives`] (row-major matrices).
#[derive(Debug, Clone, PartialEq)]
pub struct CostDerivatives {
    /// $\ell_x$, length $n$.
    pub lx: Vec<f64>,
    /// $\ell_u$, length $m$.
    pub lu: Vec<f64>,
    /// $\ell_{xx}$, $n \times n$.
    pub lxx: Vec<f64>,
    /// $\ell_{uu}$, $m \times m$.
    pub luu: Vec<f64>,
    /// $\ell_{ux}$, $m \times n$.
    pub lux: Vec<f64>,
}

impl CostDerivatives {
    /// Zeroed derivatives for state dimension `n` and control dimension `m`.
    pub fn zeros(n: usize, m: usize) -> Self {
        Self {
            lx: vec![0.0; n],
            lu: vec![0.0; m],
            lxx: vec![0.0; n * n],
            luu: vec![0.0; m * m],
            lux: vec![0.0; m * n],
        }
    }

    pub(crate) fn clear(&mut self) {
        for b in [&mut self.lx, &mut self.lu, &mut self.lxx, &mut self.luu, &mut self.lux] {
            b.fill(0.0);
        }
    }
}

/// The objective $J = \sum_{k=0}^{N-1} \ell(x_k, u_k, k) + \ell_f(x_N)$.
pub trait Cost {
    /// Running cost $\ell(x, u, k)$ at knot $k \in \{0, \dots, N-1\}$.
    fn running(&self, k: usize, x: &[f64], u: &[f64]) -> f64;
    /// Writes the gradient and Hessian of $\ell(\cdot, \cdot, k)$ at $(x, u)$
    /// into `d` (zeroed beforehand).
    fn running_derivatives(&self, k: usize, x: &[f64], u: &[f64], d: &mut CostDerivatives);
    /// Terminal cost $\ell_f(x_N)$.
    fn terminal(&self, x: &[f64]) -> f64;
    /// Writes $\partial \ell_f / \partial x$ (length $n$) and
    /// $\partial^2 \ell_f / \partial x^2$ ($n \times n$, row-major), both zeroed
    /// beforehand.
    fn terminal_derivatives(&self, x: &[f64], lx: &mut [f64], lxx: &mut [f64]);
}

/// A DDP problem: minimise $\sum_{k<N} \ell(x_k, u_k, k) + \ell_f(x_N)$
/// subject to $x_{k+1} = f(x_k, u_k)$, $x_0$ given, and optionally
/// $u^{lo} \le u_k \le u^{hi}$.
///
/// The horizon $N$ is the number of controls; the initial control sequence
/// is the warm start (zeros from [`DdpProblem::new`]).
#[derive(Debug, Clone)]
pub struct DdpProblem<D, C> {
    dynamics: D,
    cost: C,
    initial_state: Vec<f64>,
    initial_controls: Vec<Vec<f64>>,
    limits: Option<(Vec<f64>, Vec<f64>)>,
}

impl<D: Dynamics, S: systems::StageCost> DdpProblem<D, crate::ResidualCost<S>> {
    /// A problem whose cost is a stage cost in residual form
    /// ([`systems::StageCost`], the one Eq. 3 plans too), wrapped in a
    /// [`ResidualCost`](crate::ResidualCost) sized by `dynamics` and
    /// `horizon`; otherwise as [`new`](Self::new).
    ///
    /// ```
    /// use ddp::{Ddp, DdpProblem, DdpSettings, Pendulum};
    /// use systems::{ModelResult, StageCost};
    ///
    /// // the control's effort while running; the state's error at the end
    /// struct Effort;
    /// impl StageCost for Effort {
    ///     fn n_residuals(&self) -> usize { 1 }
    ///     fn n_terminal_residuals(&self) -> usize { 2 }
    ///     fn residuals(&self, _k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
    ///         match u {
    ///             Some(u) => r[0] = 0.1 * u[0],
    ///             None => r.copy_from_slice(&[10.0 * (x[0] - std::f64::consts::PI), 3.0 * x[1]]),
    ///         }
    ///         Ok(())
    ///     }
    /// }
    /// let problem = DdpProblem::with_stage_cost(Pendulum::default(), Effort, &[0.0, 0.0], 100)?;
    /// let plan = Ddp::new(DdpSettings::default())?.solve(&problem)?;
    /// assert!(plan.status.is_converged());
    /// # Ok::<(), ddp::DdpError>(())
    /// ```
    ///
    /// # Errors
    /// As [`new`](Self::new).
    pub fn with_stage_cost(dynamics: D, stage: S, initial_state: &[f64], horizon: usize) -> Result<Self> {
        let (n, m) = (dynamics.state_dim(), dynamics.control_dim());
        Self::new(
            dynamics,
            crate::ResidualCost::new(stage, n, m, horizon),
            initial_state,
            horizon,
        )
    }
}

impl<D: Dynamics, C: Cost> DdpProblem<D, C> {
    /// A problem over `horizon` steps from `initial_state`, warm-started with
    /// zero controls.
    ///
    /// # Errors
    /// A zero horizon or dimension, a wrong-sized or non-finite initial state.
    pub fn new(dynamics: D, cost: C, initial_state: &[f64], horizon: usize) -> Result<Self> {
        let (n, m) = (dynamics.state_dim(), dynamics.control_dim());
        if n == 0 || m == 0 {
            return Err(DdpError::InvalidParameter {
                name: "dynamics",
                reason: format!("state and control dimensions must be positive (got {n} and {m})"),
            });
        }
        if horizon == 0 {
            return Err(DdpError::InvalidParameter {
                name: "horizon",
                reason: "must be at least 1".into(),
            });
        }
        check_len("initial state", n, initial_state.len())?;
        check_finite("initial state", initial_state)?;
        Ok(Self {
            dynamics,
            cost,
            initial_state: initial_state.to_vec(),
            initial_controls: vec![vec![0.0; m]; horizon],
            limits: None,
        })
    }

    /// Replaces the warm start (one control per step; sets the horizon).
    ///
    /// # Errors
    /// An empty sequence, a control of the wrong size or a non-finite value.
    pub fn with_initial_controls(mut self, controls: Vec<Vec<f64>>) -> Result<Self> {
        if controls.is_empty() {
            return Err(DdpError::InvalidParameter {
                name: "initial controls",
                reason: "the horizon must be at least 1".into(),
            });
        }
        let m = self.dynamics.control_dim();
        for u in &controls {
            check_len("initial control", m, u.len())?;
            check_finite("initial control", u)?;
        }
        self.initial_controls = controls;
        Ok(self)
    }

    /// Replaces the initial state (for receding-horizon use).
    ///
    /// # Errors
    /// A wrong-sized or non-finite state.
    pub fn with_initial_state(mut self, x0: &[f64]) -> Result<Self> {
        check_len("initial state", self.dynamics.state_dim(), x0.len())?;
        check_finite("initial state", x0)?;
        self.initial_state = x0.to_vec();
        Ok(self)
    }

    /// Box limits $u^{lo} \le u_k \le u^{hi}$ on every control (infinite
    /// entries allowed). The solver then uses the box-constrained backward
    /// pass and clamps the warm start into the box.
    ///
    /// # Errors
    /// Wrong sizes, NaN, or a lower limit above its upper limit.
    pub fn with_control_limits(mut self, lower: &[f64], upper: &[f64]) -> Result<Self> {
        let m = self.dynamics.control_dim();
        check_len("lower control limit", m, lower.len())?;
        check_len("upper control limit", m, upper.len())?;
        for (i, (&lo, &hi)) in lower.iter().zip(upper).enumerate() {
            if lo.is_nan() || hi.is_nan() || lo > hi || lo == f64::INFINITY || hi == f64::NEG_INFINITY {
                return Err(DdpError::InvalidParameter {
                    name: "control limits",
                    reason: format!("need lower <= upper with a nonempty box, got [{lo}, {hi}] for control {i}"),
                });
            }
        }
        self.limits = Some((lower.to_vec(), upper.to_vec()));
        Ok(self)
    }

    /// The dynamics.
    pub fn dynamics(&self) -> &D {
        &self.dynamics
    }

    /// The cost.
    pub fn cost(&self) -> &C {
        &self.cost
    }

    /// The horizon $N$ (number of controls; there are $N + 1$ states).
    pub fn horizon(&self) -> usize {
        self.initial_controls.len()
    }

    /// The initial state $x_0$.
    pub fn initial_state(&self) -> &[f64] {
        &self.initial_state
    }

    /// The warm-start controls.
    pub fn initial_controls(&self) -> &[Vec<f64>] {
        &self.initial_controls
    }

    /// The control limits `(lower, upper)`, if any.
    pub fn control_limits(&self) -> Option<(&[f64], &[f64])> {
        self.limits.as_ref().map(|(l, u)| (l.as_slice(), u.as_slice()))
    }

    /// The total cost of the open-loop rollout of `controls` from $x_0$
    /// (infinite if the rollout is not finite).
    ///
    /// # Errors
    /// A control sequence of the wrong length, a control of the wrong size,
    /// or a failed step of the dynamics.
    pub fn rollout_cost(&self, controls: &[Vec<f64>]) -> Result<f64> {
        check_len("controls", self.horizon(), controls.len())?;
        let m = self.dynamics.control_dim();
        let mut x = self.initial_state.clone();
        let mut next = vec![0.0; x.len()];
        let mut total = 0.0;
        for (k, u) in controls.iter().enumerate() {
            check_len("control", m, u.len())?;
            total += self.cost.running(k, &x, u);
            self.dynamics.step(&x, u, &mut next)?;
            std::mem::swap(&mut x, &mut next);
        }
        total += self.cost.terminal(&x);
        Ok(if total.is_finite() { total } else { f64::INFINITY })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::{Pendulum, QuadraticCost};

    fn cost() -> QuadraticCost {
        QuadraticCost::diagonal(&[1.0, 1.0], &[1.0], &[1.0, 1.0]).expect("cost")
    }

    #[test]
    fn invalid_problems_are_errors() {
        let p = Pendulum::default();
        assert!(DdpProblem::new(p, cost(), &[0.0, 0.0], 0).is_err());
        assert!(matches!(
            DdpProblem::new(p, cost(), &[0.0], 5),
            Err(DdpError::DimensionMismatch {
                expected: 2,
                actual: 1,
                ..
            })
        ));
        assert!(DdpProblem::new(p, cost(), &[f64::NAN, 0.0], 5).is_err());
        let ok = DdpProblem::new(p, cost(), &[0.0, 0.0], 5).expect("valid");
        assert_eq!(ok.horizon(), 5);
        assert!(ok.clone().with_initial_controls(vec![]).is_err());
        assert!(ok.clone().with_initial_controls(vec![vec![0.0, 1.0]]).is_err());
        assert!(ok.clone().with_control_limits(&[1.0], &[-1.0]).is_err());
        assert!(ok.clone().with_control_limits(&[f64::NAN], &[1.0]).is_err());
        let limited = ok
            .with_initial_controls(vec![vec![0.5]; 7])
            .expect("controls")
            .with_control_limits(&[f64::NEG_INFINITY], &[1.0])
            .expect("limits");
        assert_eq!(limited.horizon(), 7);
        assert_eq!(limited.control_limits(), Some((&[f64::NEG_INFINITY][..], &[1.0][..])));
        assert!(limited.rollout_cost(&[vec![0.0]]).is_err());
        assert!(limited.rollout_cost(&vec![vec![0.0]; 7]).expect("rollout").is_finite());
    }
}
