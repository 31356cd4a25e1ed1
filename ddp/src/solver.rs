//! The DDP / iLQR solver with Tassa's regularisation schedule, a
//! backtracking line search on the feedforward term and a box-constrained
//! backward pass.

use std::time::{Duration, Instant};

use faer::Mat;

use crate::error::{DdpError, Result};
use crate::linalg::{BoxQp, add_at_b, add_at_x, cholesky, cholesky_solve, set_a_b};
use crate::problem::{Cost, CostDerivatives, DdpProblem, Dynamics};

/// Where the Levenberg-Marquardt term $\mu$ is added in the backward pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Regularization {
    /// $\tilde Q_{uu} = Q_{uu} + \mu I$ (the classic Levenberg-Marquardt choice).
    Control,
    /// $\tilde Q_{uu} = Q_{uu} + \mu f_u^\top f_u$, $\tilde Q_{ux} = Q_{ux} + \mu f_u^\top f_x$,
    /// i.e. $V'_{xx} + \mu I$: a quadratic penalty on deviating from the
    /// current states rather than the current controls (Tassa et al. 2012,
    /// Eq. 10), invariant to the scaling of the controls. The default: with
    /// second derivatives (full DDP, where $V_{xx}$ may be indefinite) it is
    /// markedly more robust here (pendulum swing-up, $N = 5000$: converged in
    /// 18 iterations, against `NotPositiveDefinite` with [`Control`](Self::Control)).
    #[default]
    State,
}

/// Settings of [`Ddp`].
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_iterations` | 200 | iterations (backward pass + line search), failed ones included |
/// | `tol_expected_reduction` | 1e-12 | converged when the full step's expected reduction $-(\Delta_1 + \Delta_2) \le$ tol $\cdot \max(1, \lvert J \rvert)$ |
/// | `tol_feedforward` | 1e-9 | converged when $\max_{k,i} \lvert k_{k,i} \rvert / (1 + \lvert u_{k,i} \rvert) \le$ tol |
/// | `regularization` | [`Regularization::State`] | where $\mu$ enters |
/// | `reg_init` | 0 | $\mu$ at the start (0: the first step is a pure Newton step) |
/// | `reg_min` | 1e-6 | below it $\mu$ snaps to 0 |
/// | `reg_max` | 1e10 | above it the solver gives up |
/// | `reg_factor` | 2 | Tassa's $\Delta_0$ |
/// | `n_line_search` | 10 | step sizes tried: $\alpha = 1, \beta, \dots, \beta^{9}$ |
/// | `line_search_factor` | 0.5 | $\beta$ |
/// | `min_reduction_ratio` | 0.1 | accept $\alpha$ when actual / expected reduction exceeds it |
/// | `max_state_norm` | 1e8 | a rollout with $\lVert x \rVert_\infty$ beyond it has blown up |
/// | `second_order` | `false` | use the dynamics' second derivatives when provided (full DDP); `false` is iLQR |
/// | `box_qp_max_iterations` | 100 | projected-Newton iterations per knot with control limits |
///
/// iLQR is the default because on the swing-ups here full DDP never took
/// fewer iterations and often took more (pendulum, $N = 500$: 14 against 6;
/// $N = 5000$: 19 against 14), each one dearer; iLQR's Gauss-Newton
/// $Q$-Hessians are positive semidefinite whenever the cost Hessians are.
///
/// A heavily regularised step is small without being converged: when the
/// tests pass with $\mu > 10\,\mu_{min}$, convergence is only declared if an
/// unregularised backward pass passes them too.
#[derive(Debug, Clone, PartialEq)]
pub struct DdpSettings {
    /// Maximum iterations.
    pub max_iterations: usize,
    /// Relative tolerance on the expected cost reduction.
    pub tol_expected_reduction: f64,
    /// Tolerance on the relative feedforward step.
    pub tol_feedforward: f64,
    /// Where the regularisation enters.
    pub regularization: Regularization,
    /// Initial regularisation $\mu$.
    pub reg_init: f64,
    /// Smallest nonzero regularisation.
    pub reg_min: f64,
    /// Largest regularisation before giving up.
    pub reg_max: f64,
    /// Tassa's factor $\Delta_0 > 1$.
    pub reg_factor: f64,
    /// Number of step sizes tried per iteration.
    pub n_line_search: usize,
    /// Step-size shrink factor $\beta \in (0, 1)$.
    pub line_search_factor: f64,
    /// Acceptance threshold on actual over expected reduction.
    pub min_reduction_ratio: f64,
    /// Blow-up threshold on $\lVert x_k \rVert_\infty$.
    pub max_state_norm: f64,
    /// Use second derivatives of the dynamics when available.
    pub second_order: bool,
    /// Iteration cap of the box-constrained QP at each knot.
    pub box_qp_max_iterations: usize,
}

impl Default for DdpSettings {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            tol_expected_reduction: 1e-12,
            tol_feedforward: 1e-9,
            regularization: Regularization::State,
            reg_init: 0.0,
            reg_min: 1e-6,
            reg_max: 1e10,
            reg_factor: 2.0,
            n_line_search: 10,
            line_search_factor: 0.5,
            min_reduction_ratio: 0.1,
            max_state_norm: 1e8,
            second_order: false,
            box_qp_max_iterations: 100,
        }
    }
}

impl DdpSettings {
    /// Checks every setting.
    ///
    /// # Errors
    /// [`DdpError::InvalidParameter`] naming the first bad setting.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, reason: &str| {
            Err(DdpError::InvalidParameter {
                name,
                reason: reason.into(),
            })
        };
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        if !nonneg(self.tol_expected_reduction) {
            return bad("tol_expected_reduction", "must be finite and >= 0");
        }
        if !nonneg(self.tol_feedforward) {
            return bad("tol_feedforward", "must be finite and >= 0");
        }
        if !(self.reg_min.is_finite() && self.reg_min > 0.0) {
            return bad("reg_min", "must be finite and > 0");
        }
        if !(self.reg_max.is_finite() && self.reg_max >= self.reg_min) {
            return bad("reg_max", "must be finite and >= reg_min");
        }
        if !(nonneg(self.reg_init) && self.reg_init <= self.reg_max) {
            return bad("reg_init", "must be in [0, reg_max]");
        }
        if !(self.reg_factor.is_finite() && self.reg_factor > 1.0) {
            return bad("reg_factor", "must be finite and > 1");
        }
        if self.n_line_search == 0 {
            return bad("n_line_search", "must be at least 1");
        }
        if !(self.line_search_factor > 0.0 && self.line_search_factor < 1.0) {
            return bad("line_search_factor", "must be in (0, 1)");
        }
        if !(self.min_reduction_ratio.is_finite() && self.min_reduction_ratio >= 0.0 && self.min_reduction_ratio < 1.0)
        {
            return bad("min_reduction_ratio", "must be in [0, 1)");
        }
        if self.max_state_norm.is_nan() || self.max_state_norm <= 0.0 {
            return bad("max_state_norm", "must be > 0");
        }
        if self.box_qp_max_iterations == 0 {
            return bad("box_qp_max_iterations", "must be at least 1");
        }
        Ok(())
    }
}

/// How a solve ended. Only [`DdpStatus::Converged`] is a success; every
/// other status still comes with the last good (finite) iterate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum DdpStatus {
    /// The expected reduction or the feedforward step fell below tolerance.
    Converged,
    /// `max_iterations` reached.
    MaxIterations,
    /// The initial rollout (warm start, open loop) left the finite region or
    /// exceeded `max_state_norm` at state `step`; the result holds the
    /// states before it and no policy.
    InitialRolloutDiverged {
        /// Index of the first bad state $x_{step}$.
        step: usize,
    },
    /// Every trial rollout of the line search blew up, and raising the
    /// regularisation to `reg_max` did not help.
    RolloutDiverged,
    /// $\tilde Q_{uu}$ stayed indefinite up to `reg_max`.
    NotPositiveDefinite,
    /// No step size reduced the cost, up to `reg_max`.
    NoDescent,
    /// The dynamics or cost returned non-finite derivatives at a finite
    /// trajectory.
    NonFiniteDerivatives,
}

impl DdpStatus {
    /// `true` for [`DdpStatus::Converged`].
    pub fn is_converged(&self) -> bool {
        matches!(self, Self::Converged)
    }

    /// `true` for the statuses saying the model or the local quadratic
    /// model failed (everything but `Converged` and `MaxIterations`).
    pub fn is_failure(&self) -> bool {
        !matches!(self, Self::Converged | Self::MaxIterations)
    }
}

/// The outcome of [`Ddp::solve`]: the trajectory, the local linear policy
/// (Eq. 2) and the local quadratic value function (Eq. 1) along it, and the
/// solver's history.
///
/// The policy and value terms come from a backward pass at the returned
/// trajectory (with regularisation `regularization`); they are empty when
/// that pass was impossible (statuses `InitialRolloutDiverged`,
/// `NotPositiveDefinite`, `NonFiniteDerivatives`).
#[derive(Debug, Clone, PartialEq)]
pub struct DdpResult {
    /// States $x^*_0, \dots, x^*_N$ (fewer only with `InitialRolloutDiverged`).
    pub states: Vec<Vec<f64>>,
    /// Controls $u^*_0, \dots, u^*_{N-1}$.
    pub controls: Vec<Vec<f64>>,
    /// Feedforward terms $k_t$ of the last backward pass (near zero at convergence).
    pub feedforward: Vec<Vec<f64>>,
    /// Feedback gains $K_t$ ($m \times n$): $u = u^*_t + K_t (x - x^*_t)$.
    pub gains: Vec<Mat<f64>>,
    /// Cost-to-go $V_0(t) = \sum_{j \ge t} \ell(x^*_j, u^*_j, j) + \ell_f(x^*_N)$, $t = 0..N$.
    pub value: Vec<f64>,
    /// $V_x(t)$, $t = 0..N$.
    pub value_gradient: Vec<Vec<f64>>,
    /// $V_{xx}(t)$ ($n \times n$), $t = 0..N$.
    pub value_hessian: Vec<Mat<f64>>,
    /// Final cost $J$ (infinite only with `InitialRolloutDiverged`).
    pub cost: f64,
    /// Cost of the warm start.
    pub initial_cost: f64,
    /// Cost before the first iteration and after each iteration (length `iterations + 1`).
    pub costs: Vec<f64>,
    /// Regularisation $\mu$ used by each iteration's accepted backward pass.
    pub regularizations: Vec<f64>,
    /// Accepted step size of each iteration (0 when the line search failed).
    pub step_sizes: Vec<f64>,
    /// Regularisation of the backward pass that produced the policy.
    pub regularization: f64,
    /// Iterations performed.
    pub iterations: usize,
    /// Whether second derivatives of the dynamics were used (DDP) or not (iLQR).
    pub second_order: bool,
    /// How the solve ended.
    pub status: DdpStatus,
    /// Wall-clock solve time.
    pub solve_time: Duration,
}

impl DdpResult {
    /// The local linear policy (Eq. 2) at step `t`:
    /// $u = u^*_t + K_t (x - x^*_t)$ (without feedforward). `None` when the
    /// result holds no policy or `t` is out of range.
    pub fn policy(&self, t: usize, x: &[f64]) -> Option<Vec<f64>> {
        let gain = self.gains.get(t)?;
        let (xs, us) = (self.states.get(t)?, self.controls.get(t)?);
        Some(
            (0..us.len())
                .map(|i| us[i] + (0..xs.len()).map(|j| gain[(i, j)] * (x[j] - xs[j])).sum::<f64>())
                .collect(),
        )
    }

    /// The local quadratic value model (Eq. 1) at step `t`:
    /// $V_0(t) + V_x(t)^\top \delta x + \tfrac12 \delta x^\top V_{xx}(t) \delta x$,
    /// $\delta x = x - x^*_t$. `None` when the result holds no value model or
    /// `t` is out of range.
    pub fn value_model(&self, t: usize, x: &[f64]) -> Option<f64> {
        let (v0, vx, vxx, xs) = (
            self.value.get(t)?,
            self.value_gradient.get(t)?,
            self.value_hessian.get(t)?,
            self.states.get(t)?,
        );
        let d: Vec<f64> = x.iter().zip(xs).map(|(a, b)| a - b).collect();
        let n = d.len();
        let mut v = *v0;
        for i in 0..n {
            v += vx[i] * d[i] + 0.5 * d[i] * (0..n).map(|j| vxx[(i, j)] * d[j]).sum::<f64>();
        }
        Some(v)
    }
}

/// Differential dynamic programming (Jacobson and Mayne 1970) / iLQR.
///
/// Each iteration linearises the dynamics and quadratises the cost along the
/// current trajectory $(x^*, u^*)$ and runs the backward pass from
/// $V_x(N) = \ell_{f,x}$, $V_{xx}(N) = \ell_{f,xx}$:
/// $$\begin{aligned}
/// Q_x &= \ell_x + f_x^\top V_x', & Q_u &= \ell_u + f_u^\top V_x', \\
/// Q_{xx} &= \ell_{xx} + f_x^\top V_{xx}' f_x + V_x' \cdot f_{xx}, &
/// Q_{uu} &= \ell_{uu} + f_u^\top V_{xx}' f_u + V_x' \cdot f_{uu}, \\
/// Q_{ux} &= \ell_{ux} + f_u^\top V_{xx}' f_x + V_x' \cdot f_{ux}, &
/// k &= -\tilde Q_{uu}^{-1} Q_u, \quad K = -\tilde Q_{uu}^{-1} \tilde Q_{ux}, \\
/// V_x &= Q_x + K^\top Q_{uu} k + K^\top Q_u + Q_{ux}^\top k, &
/// V_{xx} &= Q_{xx} + K^\top Q_{uu} K + K^\top Q_{ux} + Q_{ux}^\top K,
/// \end{aligned}$$
/// (the tensor terms only with second derivatives; $\tilde Q$ regularised by
/// $\mu$, see [`Regularization`]), accumulating the expected reduction
/// $\Delta J(\alpha) = \alpha \sum k^\top Q_u + \tfrac{\alpha^2}{2} \sum k^\top Q_{uu} k$.
/// With control limits, $k$ solves the box QP
/// $\min_{\delta u} \tfrac12 \delta u^\top \tilde Q_{uu} \delta u + Q_u^\top \delta u$,
/// $u^{lo} \le u^* + \delta u \le u^{hi}$, by projected Newton, and the rows
/// of $K$ of clamped controls are zero (Tassa, Mansard and Todorov 2014).
///
/// The forward pass rolls out $\hat u_t = \mathrm{clamp}(u^*_t + \alpha k_t + K_t(\hat x_t - x^*_t))$
/// for $\alpha = 1, \beta, \beta^2, \dots$ and accepts the first $\alpha$ with
/// $(J - \hat J) / (-\Delta J(\alpha)) > $ `min_reduction_ratio` (or, if
/// $\Delta J(\alpha) \ge 0$, any decrease), so accepted iterations never
/// increase the cost. Rollouts that leave the finite region or exceed
/// `max_state_norm` are rejected. $\mu$ follows Tassa's schedule (Tassa,
/// Erez and Todorov 2012, Sec. II-F): on failure
/// $\Delta \leftarrow \max(\Delta_0, \Delta \Delta_0)$, $\mu \leftarrow \max(\mu_{min}, \mu \Delta)$;
/// on success $\Delta \leftarrow \min(1/\Delta_0, \Delta / \Delta_0)$,
/// $\mu \leftarrow \mu \Delta$ (0 below $\mu_{min}$).
///
/// Needs a [`Dynamics`] with first derivatives (second ones optional) and a
/// [`Cost`] with gradient and Hessian. Settings: [`DdpSettings`].
///
/// References: D. H. Jacobson and D. Q. Mayne, *Differential Dynamic
/// Programming*, 1970; Y. Tassa, T. Erez and E. Todorov, "Synthesis and
/// stabilization of complex behaviors through online trajectory
/// optimization", IROS 2012; Y. Tassa, N. Mansard and E. Todorov,
/// "Control-limited differential dynamic programming", ICRA 2014.
#[derive(Debug, Clone, PartialEq)]
pub struct Ddp {
    settings: DdpSettings,
}

impl Ddp {
    /// A solver with validated settings.
    ///
    /// # Errors
    /// Invalid settings ([`DdpSettings::validate`]).
    pub fn new(settings: DdpSettings) -> Result<Self> {
        settings.validate()?;
        Ok(Self { settings })
    }

    /// The settings.
    pub fn settings(&self) -> &DdpSettings {
        &self.settings
    }

    /// Solves `problem` from its warm start. Not converging and blowing up
    /// are statuses of the result, not errors.
    ///
    /// # Errors
    /// None at present (the problem was checked when built); the `Result`
    /// keeps room for user-model failures.
    pub fn solve<D: Dynamics, C: Cost>(&self, problem: &DdpProblem<D, C>) -> Result<DdpResult> {
        let start = Instant::now();
        let mut w = Work::new(problem, &self.settings);
        let mut result = w.run();
        result.solve_time = start.elapsed();
        Ok(result)
    }
}

/// Why a forward rollout failed.
enum Rollout {
    Ok(f64),
    Diverged(usize),
}

/// The solver's buffers for one solve (row-major, knot-major).
struct Work<'a, D, C> {
    p: &'a DdpProblem<D, C>,
    s: &'a DdpSettings,
    n: usize,
    m: usize,
    horizon: usize,
    lower: Vec<f64>,
    upper: Vec<f64>,
    limited: bool,
    xs: Vec<f64>,
    us: Vec<f64>,
    stage: Vec<f64>,
    xs_try: Vec<f64>,
    us_try: Vec<f64>,
    stage_try: Vec<f64>,
    fx: Vec<f64>,
    fu: Vec<f64>,
    cd: Vec<CostDerivatives>,
    lfx: Vec<f64>,
    lfxx: Vec<f64>,
    kff: Vec<f64>,
    gain: Vec<f64>,
    vx: Vec<f64>,
    vxx: Vec<f64>,
    // scratch
    qx: Vec<f64>,
    qu: Vec<f64>,
    qxx: Vec<f64>,
    quu: Vec<f64>,
    qux: Vec<f64>,
    quu_reg: Vec<f64>,
    qux_reg: Vec<f64>,
    vxx_fx: Vec<f64>,
    vxx_fu: Vec<f64>,
    hxx: Vec<f64>,
    hux: Vec<f64>,
    huu: Vec<f64>,
    tmp_m: Vec<f64>,
    reg_uu: Vec<f64>,
    tmp_mn: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    dx: Vec<f64>,
    qp: BoxQp,
    second_order: bool,
}

impl<'a, D: Dynamics, C: Cost> Work<'a, D, C> {
    fn new(p: &'a DdpProblem<D, C>, s: &'a DdpSettings) -> Self {
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
            hxx: vec![0.0; n * n],
            hux: vec![0.0; m * n],
            huu: vec![0.0; m * m],
            tmp_m: vec![0.0; m],
            reg_uu: vec![0.0; m * m],
            tmp_mn: vec![0.0; m * n],
            lo: vec![0.0; m],
            hi: vec![0.0; m],
            dx: vec![0.0; n],
            qp: BoxQp::new(m),
            second_order: false,
        }
    }

    fn diverged(&self, x: &[f64]) -> bool {
        x.iter().any(|v| !v.is_finite() || v.abs() > self.s.max_state_norm)
    }

    /// Open-loop rollout of `self.us` into `self.xs`.
    fn initial_rollout(&mut self) -> Rollout {
        let (n, m) = (self.n, self.m);
        let (dynamics, cost) = (self.p.dynamics(), self.p.cost());
        self.xs[..n].copy_from_slice(self.p.initial_state());
        let mut total = 0.0;
        for k in 0..self.horizon {
            let (cur, next) = self.xs[k * n..(k + 2) * n].split_at_mut(n);
            let u = &self.us[k * m..(k + 1) * m];
            let l = cost.running(k, cur, u);
            self.stage[k] = l;
            total += l;
            dynamics.step(cur, u, next);
            if self.diverged(&self.xs[(k + 1) * n..(k + 2) * n]) {
                return Rollout::Diverged(k + 1);
            }
        }
        let lf = cost.terminal(&self.xs[self.horizon * n..]);
        self.stage[self.horizon] = lf;
        total += lf;
        if total.is_finite() {
            Rollout::Ok(total)
        } else {
            Rollout::Diverged(self.horizon)
        }
    }

    /// Closed-loop rollout with step size `alpha` into the `_try` buffers.
    fn forward(&mut self, alpha: f64) -> Rollout {
        let (n, m) = (self.n, self.m);
        let (dynamics, cost) = (self.p.dynamics(), self.p.cost());
        self.xs_try[..n].copy_from_slice(&self.xs[..n]);
        let mut total = 0.0;
        for k in 0..self.horizon {
            for j in 0..n {
                self.dx[j] = self.xs_try[k * n + j] - self.xs[k * n + j];
            }
            for i in 0..m {
                let row = &self.gain[(k * m + i) * n..(k * m + i + 1) * n];
                let fb: f64 = row.iter().zip(&self.dx).map(|(a, b)| a * b).sum();
                let u = self.us[k * m + i] + alpha * self.kff[k * m + i] + fb;
                self.us_try[k * m + i] = u.clamp(self.lower[i], self.upper[i]);
            }
            let (cur, next) = self.xs_try[k * n..(k + 2) * n].split_at_mut(n);
            let u = &self.us_try[k * m..(k + 1) * m];
            let l = cost.running(k, cur, u);
            self.stage_try[k] = l;
            total += l;
            dynamics.step(cur, u, next);
            if self.diverged(&self.xs_try[(k + 1) * n..(k + 2) * n]) {
                return Rollout::Diverged(k + 1);
            }
        }
        let lf = cost.terminal(&self.xs_try[self.horizon * n..]);
        self.stage_try[self.horizon] = lf;
        total += lf;
        if total.is_finite() {
            Rollout::Ok(total)
        } else {
            Rollout::Diverged(self.horizon)
        }
    }

    /// Derivatives along the current trajectory; `false` if any is not finite.
    fn linearise(&mut self) -> bool {
        let (n, m) = (self.n, self.m);
        let (dynamics, cost) = (self.p.dynamics(), self.p.cost());
        let mut finite = true;
        for k in 0..self.horizon {
            let x = &self.xs[k * n..(k + 1) * n];
            let u = &self.us[k * m..(k + 1) * m];
            let fx = &mut self.fx[k * n * n..(k + 1) * n * n];
            let fu = &mut self.fu[k * n * m..(k + 1) * n * m];
            fx.fill(0.0);
            fu.fill(0.0);
            dynamics.derivatives(x, u, fx, fu);
            let d = &mut self.cd[k];
            d.clear();
            cost.running_derivatives(k, x, u, d);
            finite &= fx.iter().chain(fu.iter()).all(|v| v.is_finite())
                && [&d.lx, &d.lu, &d.lxx, &d.luu, &d.lux]
                    .iter()
                    .all(|b| b.iter().all(|v| v.is_finite()));
        }
        self.lfx.fill(0.0);
        self.lfxx.fill(0.0);
        cost.terminal_derivatives(&self.xs[self.horizon * n..], &mut self.lfx, &mut self.lfxx);
        finite && self.lfx.iter().chain(&self.lfxx).all(|v| v.is_finite())
    }

    /// Backward pass with regularisation `mu`: fills `kff`, `gain`, `vx`,
    /// `vxx` and returns the expected-reduction terms $(\sum k^\top Q_u,
    /// \tfrac12 \sum k^\top Q_{uu} k)$, or `None` if $\tilde Q_{uu}$ is not
    /// positive definite at some knot.
    fn backward(&mut self, mu: f64) -> Option<(f64, f64)> {
        let (n, m, horizon) = (self.n, self.m, self.horizon);
        let use_second = self.s.second_order;
        let state_reg = self.s.regularization == Regularization::State;
        self.vx[horizon * n..].copy_from_slice(&self.lfx);
        self.vxx[horizon * n * n..].copy_from_slice(&self.lfxx);
        let (mut dv1, mut dv2) = (0.0, 0.0);
        for k in (0..horizon).rev() {
            let fx = &self.fx[k * n * n..(k + 1) * n * n];
            let fu = &self.fu[k * n * m..(k + 1) * n * m];
            let d = &self.cd[k];
            let (vx_cur, vx_next) = self.vx[k * n..(k + 2) * n].split_at_mut(n);
            let (vxx_cur, vxx_next) = self.vxx[k * n * n..(k + 2) * n * n].split_at_mut(n * n);

            self.qx.copy_from_slice(&d.lx);
            add_at_x(fx, vx_next, n, n, &mut self.qx);
            self.qu.copy_from_slice(&d.lu);
            add_at_x(fu, vx_next, n, m, &mut self.qu);
            set_a_b(vxx_next, fx, n, n, n, &mut self.vxx_fx);
            set_a_b(vxx_next, fu, n, n, m, &mut self.vxx_fu);
            self.qxx.copy_from_slice(&d.lxx);
            add_at_b(fx, &self.vxx_fx, n, n, n, &mut self.qxx);
            self.quu.copy_from_slice(&d.luu);
            add_at_b(fu, &self.vxx_fu, n, m, m, &mut self.quu);
            self.qux.copy_from_slice(&d.lux);
            add_at_b(fu, &self.vxx_fx, n, m, n, &mut self.qux);
            if use_second {
                self.hxx.fill(0.0);
                self.hux.fill(0.0);
                self.huu.fill(0.0);
                let x = &self.xs[k * n..(k + 1) * n];
                let u = &self.us[k * m..(k + 1) * m];
                let has =
                    self.p
                        .dynamics()
                        .second_derivatives(x, u, vx_next, &mut self.hxx, &mut self.hux, &mut self.huu);
                if has {
                    self.second_order = true;
                    for (q, h) in self.qxx.iter_mut().zip(&self.hxx) {
                        *q += h;
                    }
                    for (q, h) in self.qux.iter_mut().zip(&self.hux) {
                        *q += h;
                    }
                    for (q, h) in self.quu.iter_mut().zip(&self.huu) {
                        *q += h;
                    }
                }
            }
            symmetrise(&mut self.qxx, n);
            symmetrise(&mut self.quu, m);

            // regularised copies
            self.quu_reg.copy_from_slice(&self.quu);
            self.qux_reg.copy_from_slice(&self.qux);
            if mu > 0.0 {
                if state_reg {
                    // quu_reg += mu fu^T fu ; qux_reg += mu fu^T fx
                    self.reg_uu.fill(0.0);
                    add_at_b(fu, fu, n, m, m, &mut self.reg_uu);
                    for (q, a) in self.quu_reg.iter_mut().zip(&self.reg_uu) {
                        *q += mu * a;
                    }
                    self.tmp_mn.fill(0.0);
                    add_at_b(fu, fx, n, m, n, &mut self.tmp_mn);
                    for (q, a) in self.qux_reg.iter_mut().zip(&self.tmp_mn) {
                        *q += mu * a;
                    }
                } else {
                    for i in 0..m {
                        self.quu_reg[i * m + i] += mu;
                    }
                }
            }

            let kk = &mut self.kff[k * m..(k + 1) * m];
            let gk = &mut self.gain[k * m * n..(k + 1) * m * n];
            if !self.limited {
                if !cholesky(&mut self.quu_reg, m) {
                    return None;
                }
                for (k, q) in kk.iter_mut().zip(&self.qu) {
                    *k = -q;
                }
                cholesky_solve(&self.quu_reg, m, kk);
                // K = -Quu^{-1} Qux, column by column
                for j in 0..n {
                    for i in 0..m {
                        self.tmp_m[i] = -self.qux_reg[i * n + j];
                    }
                    cholesky_solve(&self.quu_reg, m, &mut self.tmp_m);
                    for i in 0..m {
                        gk[i * n + j] = self.tmp_m[i];
                    }
                }
            } else {
                for i in 0..m {
                    let u = self.us[k * m + i];
                    self.lo[i] = self.lower[i] - u;
                    self.hi[i] = self.upper[i] - u;
                }
                if !self.qp.solve(
                    &self.quu_reg,
                    &self.qu,
                    &self.lo,
                    &self.hi,
                    kk,
                    self.s.box_qp_max_iterations,
                ) {
                    return None;
                }
                gk.fill(0.0);
                let mf = self.qp.free.len();
                for j in 0..n {
                    for (a, &i) in self.qp.free.iter().enumerate() {
                        self.tmp_m[a] = -self.qux_reg[i * n + j];
                    }
                    cholesky_solve(&self.qp.factor[..mf * mf], mf, &mut self.tmp_m[..mf]);
                    for (a, &i) in self.qp.free.iter().enumerate() {
                        gk[i * n + j] = self.tmp_m[a];
                    }
                }
            }
            if kk.iter().chain(gk.iter()).any(|v| !v.is_finite()) {
                return None;
            }

            // expected reduction and value update (unregularised Q)
            for i in 0..m {
                self.tmp_m[i] = self.qu[i] + (0..m).map(|j| self.quu[i * m + j] * kk[j]).sum::<f64>();
            }
            dv1 += kk.iter().zip(&self.qu).map(|(a, b)| a * b).sum::<f64>();
            dv2 += 0.5
                * (0..m)
                    .map(|i| kk[i] * (0..m).map(|j| self.quu[i * m + j] * kk[j]).sum::<f64>())
                    .sum::<f64>();
            // vx = qx + K^T (quu k + qu) + qux^T k
            vx_cur.copy_from_slice(&self.qx);
            add_at_x(gk, &self.tmp_m, m, n, vx_cur);
            add_at_x(&self.qux, kk, m, n, vx_cur);
            // vxx = qxx + K^T quu K + K^T qux + qux^T K
            vxx_cur.copy_from_slice(&self.qxx);
            // tmp_mn = quu K + qux  => K^T tmp_mn = K^T quu K + K^T qux
            set_a_b(&self.quu, gk, m, m, n, &mut self.tmp_mn);
            for (t, q) in self.tmp_mn.iter_mut().zip(&self.qux) {
                *t += q;
            }
            add_at_b(gk, &self.tmp_mn, m, n, n, vxx_cur);
            add_at_b(&self.qux, gk, m, n, n, vxx_cur);
            symmetrise(vxx_cur, n);
        }
        Some((dv1, dv2))
    }

    /// The convergence test on the last backward pass, whose expected
    /// reduction at full step is `-dv`.
    fn converged(&self, dv: f64, cost: f64) -> bool {
        -dv <= self.s.tol_expected_reduction * cost.abs().max(1.0) || self.feedforward_norm() <= self.s.tol_feedforward
    }

    fn feedforward_norm(&self) -> f64 {
        self.kff
            .iter()
            .zip(&self.us)
            .map(|(k, u)| k.abs() / (1.0 + u.abs()))
            .fold(0.0, f64::max)
    }

    fn increase(&self, mu: &mut f64, delta: &mut f64) {
        let f = self.s.reg_factor;
        *delta = (*delta * f).max(f);
        *mu = (*mu * *delta).max(self.s.reg_min);
    }

    fn decrease(&self, mu: &mut f64, delta: &mut f64) {
        let f = self.s.reg_factor;
        *delta = (*delta / f).min(1.0 / f);
        *mu *= *delta;
        if *mu < self.s.reg_min {
            *mu = 0.0;
        }
    }

    fn run(&mut self) -> DdpResult {
        let s = self.s;
        let mut cost = match self.initial_rollout() {
            Rollout::Ok(c) => c,
            Rollout::Diverged(step) => return self.result_diverged(step),
        };
        let initial_cost = cost;
        let mut costs = vec![cost];
        let (mut regs, mut steps) = (Vec::new(), Vec::new());
        let (mut mu, mut delta) = (s.reg_init, 1.0);
        let mut status = DdpStatus::MaxIterations;
        let mut need_derivatives = true;
        let mut policy_current = false;
        let mut iterations = 0;
        'outer: loop {
            if need_derivatives {
                if !self.linearise() {
                    status = DdpStatus::NonFiniteDerivatives;
                    break;
                }
                need_derivatives = false;
            }
            let (dv1, dv2) = loop {
                policy_current = false;
                match self.backward(mu) {
                    Some(dv) => break dv,
                    None => {
                        self.increase(&mut mu, &mut delta);
                        if mu > s.reg_max {
                            status = DdpStatus::NotPositiveDefinite;
                            break 'outer;
                        }
                    }
                }
            };
            policy_current = true;
            if self.converged(dv1 + dv2, cost) {
                if mu <= 10.0 * s.reg_min {
                    status = DdpStatus::Converged;
                    break;
                }
                // a heavily regularised step is small without being converged:
                // confirm with an unregularised backward pass
                match self.backward(0.0) {
                    Some((d1, d2)) if self.converged(d1 + d2, cost) => {
                        mu = 0.0;
                        status = DdpStatus::Converged;
                        break;
                    }
                    _ => {
                        if self.backward(mu).is_none() {
                            policy_current = false;
                            status = DdpStatus::NotPositiveDefinite;
                            break;
                        }
                    }
                }
            }
            if iterations == s.max_iterations {
                break;
            }
            iterations += 1;
            regs.push(mu);

            let mut alpha = 1.0;
            let mut accepted = None;
            let mut all_diverged = true;
            for _ in 0..s.n_line_search {
                if let Rollout::Ok(trial) = self.forward(alpha) {
                    all_diverged = false;
                    let expected = -alpha * (dv1 + alpha * dv2);
                    let actual = cost - trial;
                    let ok = if expected > 0.0 {
                        actual / expected > s.min_reduction_ratio
                    } else {
                        actual > 0.0
                    };
                    if ok && trial <= cost {
                        accepted = Some((alpha, trial));
                        break;
                    }
                }
                alpha *= s.line_search_factor;
            }
            match accepted {
                Some((alpha, trial)) => {
                    std::mem::swap(&mut self.xs, &mut self.xs_try);
                    std::mem::swap(&mut self.us, &mut self.us_try);
                    std::mem::swap(&mut self.stage, &mut self.stage_try);
                    cost = trial;
                    steps.push(alpha);
                    costs.push(cost);
                    need_derivatives = true;
                    policy_current = false;
                    self.decrease(&mut mu, &mut delta);
                }
                None => {
                    steps.push(0.0);
                    costs.push(cost);
                    self.increase(&mut mu, &mut delta);
                    if mu > s.reg_max {
                        status = if all_diverged {
                            DdpStatus::RolloutDiverged
                        } else {
                            DdpStatus::NoDescent
                        };
                        break;
                    }
                }
            }
        }
        // a policy at the returned trajectory, if one was not just computed
        if !policy_current && matches!(status, DdpStatus::MaxIterations) {
            if need_derivatives && !self.linearise() {
                status = DdpStatus::NonFiniteDerivatives;
            } else {
                loop {
                    if self.backward(mu).is_some() {
                        policy_current = true;
                        break;
                    }
                    self.increase(&mut mu, &mut delta);
                    if mu > s.reg_max {
                        break;
                    }
                }
            }
        }
        self.result(
            status,
            cost,
            initial_cost,
            costs,
            regs,
            steps,
            mu,
            iterations,
            policy_current,
        )
    }

    fn result_diverged(&self, step: usize) -> DdpResult {
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
            costs: vec![f64::INFINITY],
            regularizations: Vec::new(),
            step_sizes: Vec::new(),
            regularization: self.s.reg_init,
            iterations: 0,
            second_order: false,
            status: DdpStatus::InitialRolloutDiverged { step },
            solve_time: Duration::ZERO,
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn result(
        &self,
        status: DdpStatus,
        cost: f64,
        initial_cost: f64,
        costs: Vec<f64>,
        regularizations: Vec<f64>,
        step_sizes: Vec<f64>,
        mu: f64,
        iterations: usize,
        policy: bool,
    ) -> DdpResult {
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
            cost,
            initial_cost,
            costs,
            regularizations,
            step_sizes,
            regularization: mu,
            iterations,
            second_order: self.second_order,
            status,
            solve_time: Duration::ZERO,
        }
    }
}

fn symmetrise(a: &mut [f64], n: usize) {
    for i in 0..n {
        for j in 0..i {
            let v = 0.5 * (a[i * n + j] + a[j * n + i]);
            a[i * n + j] = v;
            a[j * n + i] = v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_settings_are_valid_and_bad_ones_are_named() {
        assert!(Ddp::new(DdpSettings::default()).is_ok());
        let cases: [(DdpSettings, &str); 6] = [
            (
                DdpSettings {
                    reg_min: 0.0,
                    ..DdpSettings::default()
                },
                "reg_min",
            ),
            (
                DdpSettings {
                    reg_factor: 1.0,
                    ..DdpSettings::default()
                },
                "reg_factor",
            ),
            (
                DdpSettings {
                    line_search_factor: 1.0,
                    ..DdpSettings::default()
                },
                "line_search_factor",
            ),
            (
                DdpSettings {
                    n_line_search: 0,
                    ..DdpSettings::default()
                },
                "n_line_search",
            ),
            (
                DdpSettings {
                    max_state_norm: f64::NAN,
                    ..DdpSettings::default()
                },
                "max_state_norm",
            ),
            (
                DdpSettings {
                    tol_expected_reduction: -1.0,
                    ..DdpSettings::default()
                },
                "tol_expected_reduction",
            ),
        ];
        for (settings, name) in cases {
            match Ddp::new(settings) {
                Err(DdpError::InvalidParameter { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{name}: {other:?}"),
            }
        }
    }

    #[test]
    fn tassa_schedule_grows_and_snaps_to_zero() {
        let s = DdpSettings::default();
        let problem = crate::problems::pendulum_swingup(2).expect("problem");
        let w = Work::new(&problem, &s);
        let (mut mu, mut delta) = (0.0, 1.0);
        w.increase(&mut mu, &mut delta);
        assert_eq!((mu, delta), (s.reg_min, 2.0));
        w.increase(&mut mu, &mut delta);
        assert_eq!((mu, delta), (4.0 * s.reg_min, 4.0));
        w.decrease(&mut mu, &mut delta);
        assert_eq!((mu, delta), (2.0 * s.reg_min, 0.5));
        w.decrease(&mut mu, &mut delta);
        assert_eq!((mu, delta), (0.0, 0.25));
    }
}
