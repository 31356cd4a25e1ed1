//! The solver's buffers for one solve (row-major, knot-major) and the
//! assembly of the result from them.

use std::time::Duration;

use faer::Mat;

use super::result::{DdpResult, DdpStatus};
use super::settings::{DdpMethod, DdpSettings};
use crate::linalg::BoxQp;
use crate::problem::{Cost, CostDerivatives, DdpProblem, Dynamics};

/// The solver's buffers for one solve (row-major, knot-major).
pub(super) struct Work<'a, D, C> {
    pub(super) p: &'a DdpProblem<D, C>,
    pub(super) s: &'a DdpSettings,
    pub(super) n: usize,
    pub(super) m: usize,
    pub(super) horizon: usize,
    pub(super) lower: Vec<f64>,
    pub(super) upper: Vec<f64>,
    pub(super) limited: bool,
    pub(super) xs: Vec<f64>,
    pub(super) us: Vec<f64>,
    pub(super) stage: Vec<f64>,
    pub(super) xs_try: Vec<f64>,
    pub(super) us_try: Vec<f64>,
    pub(super) stage_try: Vec<f64>,
    pub(super) fx: Vec<f64>,
    pub(super) fu: Vec<f64>,
    pub(super) cd: Vec<CostDerivatives>,
    pub(super) lfx: Vec<f64>,
    pub(super) lfxx: Vec<f64>,
    pub(super) kff: Vec<f64>,
    pub(super) gain: Vec<f64>,
    pub(super) vx: Vec<f64>,
    pub(super) vxx: Vec<f64>,
    // scratch
    pub(super) qx: Vec<f64>,
    pub(super) qu: Vec<f64>,
    pub(super) qxx: Vec<f64>,
    pub(super) quu: Vec<f64>,
    pub(super) qux: Vec<f64>,
    pub(super) quu_reg: Vec<f64>,
    pub(super) qux_reg: Vec<f64>,
    pub(super) vxx_fx: Vec<f64>,
    pub(super) vxx_fu: Vec<f64>,
    /// The model's weighted second derivative over $z = (x, u)$, $(n+m)^2$.
    pub(super) hzz: Vec<f64>,
    pub(super) tmp_m: Vec<f64>,
    pub(super) reg_uu: Vec<f64>,
    pub(super) tmp_mn: Vec<f64>,
    pub(super) lo: Vec<f64>,
    pub(super) hi: Vec<f64>,
    pub(super) dx: Vec<f64>,
    pub(super) qp: BoxQp,
    pub(super) second_order: bool,
    pub(super) evals: usize,
    pub(super) jacobian_evals: usize,
}

impl<'a, D: Dynamics, C: Cost> Work<'a, D, C> {
    pub(super) fn new(p: &'a DdpProblem<D, C>, s: &'a DdpSettings) -> Self {
        let (n, m, horizon) = (p.dynamics().state_dim(), p.dynamics().control_dim(), p.horizon());
        let (lower, upper, limited) = match p.control_limits() {
            Some((l, u)) => (l.to_vec(), u.to_vec(), true),
            None => (vec![f64::NEG_INFINITY; m], vec![f64::INFINITY; m], false),
        };
        let mut us: Vec<f64> = p.initial_controls().iter().flatten().copied().collect();
        for (i, u) in us.iter_mut().enumerate() {
            *u = u.clamp(lower[i % m], upper[i % m]);
        }
        Self {
            p,
            s,
            n,
            m,
            horizon,
            lower,
            upper,
            limited,
            xs: vec![0.0; (horizon + 1) * n],
            us,
            stage: vec![0.0; horizon + 1],
            xs_try: vec![0.0; (horizon + 1) * n],
            us_try: vec![0.0; horizon * m],
            stage_try: vec![0.0; horizon + 1],
            fx: vec![0.0; horizon * n * n],
            fu: vec![0.0; horizon * n * m],
            cd: vec![CostDerivatives::zeros(n, m); horizon],
            lfx: vec![0.0; n],
            lfxx: vec![0.0; n * n],
            kff: vec![0.0; horizon * m],
            gain: vec![0.0; horizon * m * n],
            vx: vec![0.0; (horizon + 1) * n],
            vxx: vec![0.0; (horizon + 1) * n * n],
            qx: vec![0.0; n],
            qu: vec![0.0; m],
            qxx: vec![0.0; n * n],
            quu: vec![0.0; m * m],
            qux: vec![0.0; m * n],
            quu_reg: vec![0.0; m * m],
            qux_reg: vec![0.0; m * n],
            vxx_fx: vec![0.0; n * n],
            vxx_fu: vec![0.0; n * m],
            hzz: vec![0.0; (n + m) * (n + m)],
            tmp_m: vec![0.0; m],
            reg_uu: vec![0.0; m * m],
            tmp_mn: vec![0.0; m * n],
            lo: vec![0.0; m],
            hi: vec![0.0; m],
            dx: vec![0.0; n],
            qp: BoxQp::new(m),
            second_order: false,
            evals: 0,
            jacobian_evals: 0,
        }
    }

    pub(super) fn diverged(&self, x: &[f64]) -> bool {
        x.iter().any(|v| !v.is_finite() || v.abs() > self.s.max_state_norm)
    }

    fn method(&self) -> DdpMethod {
        if self.second_order {
            DdpMethod::Ddp
        } else {
            DdpMethod::Ilqr
        }
    }

    /// The result when the warm start's rollout blew up at state `step`.
    pub(super) fn result_diverged(&self, step: usize) -> DdpResult {
        let n = self.n;
        DdpResult {
            states: self.xs[..step * n].chunks(n).map(<[f64]>::to_vec).collect(),
            controls: self.us.chunks(self.m).map(<[f64]>::to_vec).collect(),
            feedforward: Vec::new(),
            gains: Vec::new(),
            value: Vec::new(),
            value_gradient: Vec::new(),
            value_hessian: Vec::new(),
            cost: f64::INFINITY,
            initial_cost: f64::INFINITY,
            cost_history: vec![f64::INFINITY],
            regularizations: Vec::new(),
            step_sizes: Vec::new(),
            regularization: self.s.reg_init,
            iterations: 0,
            method: DdpMethod::Ilqr,
            evals: self.evals,
            jacobian_evals: self.jacobian_evals,
            status: DdpStatus::InitialRolloutDiverged { step },
            solve_time: Duration::ZERO,
        }
    }

    /// The result at the current trajectory, with the policy and value
    /// terms of the last backward pass if `policy`.
    pub(super) fn result(&self, status: DdpStatus, history: History, policy: bool) -> DdpResult {
        let (n, m) = (self.n, self.m);
        let mut value = vec![0.0; self.horizon + 1];
        let mut acc = 0.0;
        for k in (0..=self.horizon).rev() {
            acc += self.stage[k];
            value[k] = acc;
        }
        let (feedforward, gains, value_gradient, value_hessian) = if policy {
            (
                self.kff.chunks(m).map(<[f64]>::to_vec).collect(),
                self.gain
                    .chunks(m * n)
                    .map(|g| Mat::from_fn(m, n, |i, j| g[i * n + j]))
                    .collect(),
                self.vx.chunks(n).map(<[f64]>::to_vec).collect(),
                self.vxx
                    .chunks(n * n)
                    .map(|v| Mat::from_fn(n, n, |i, j| v[i * n + j]))
                    .collect(),
            )
        } else {
            (Vec::new(), Vec::new(), Vec::new(), Vec::new())
        };
        DdpResult {
            states: self.xs.chunks(n).map(<[f64]>::to_vec).collect(),
            controls: self.us.chunks(m).map(<[f64]>::to_vec).collect(),
            feedforward,
            gains,
            value,
            value_gradient,
            value_hessian,
            cost: history.cost,
            initial_cost: history.initial_cost,
            cost_history: history.cost_history,
            regularizations: history.regularizations,
            step_sizes: history.step_sizes,
            regularization: history.mu,
            iterations: history.iterations,
            method: self.method(),
            evals: self.evals,
            jacobian_evals: self.jacobian_evals,
            status,
            solve_time: Duration::ZERO,
        }
    }
}

/// What the outer loop records, handed to [`Work::result`].
#[derive(Debug, Clone, PartialEq)]
pub(super) struct History {
    /// The current cost.
    pub(super) cost: f64,
    /// The warm start's cost.
    pub(super) initial_cost: f64,
    /// The cost before the first and after each iteration.
    pub(super) cost_history: Vec<f64>,
    /// $\mu$ of each iteration's accepted backward pass.
    pub(super) regularizations: Vec<f64>,
    /// Accepted step size of each iteration (0 on failure).
    pub(super) step_sizes: Vec<f64>,
    /// The final $\mu$.
    pub(super) mu: f64,
    /// Iterations performed.
    pub(super) iterations: usize,
}
