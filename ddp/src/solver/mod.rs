//! The DDP / iLQR solver with Tassa's regularisation schedule, a
//! backtracking line search on the feedforward term and a box-constrained
//! backward pass.
//!
//! This file holds [`Ddp`] and its outer loop; `settings` the
//! [`DdpSettings`] and [`DdpMethod`]; `result` the [`DdpResult`] and
//! [`DdpStatus`]; `work` the per-solve buffers; `forward` the rollouts;
//! `backward` the linearisation and backward pass; `regularization` the
//! [`Regularization`] choice and Tassa's schedule for $\mu$.

mod backward;
mod forward;
mod regularization;
mod result;
mod settings;
mod work;

use std::time::Instant;

pub use regularization::Regularization;
pub use result::{DdpResult, DdpStatus};
pub use settings::{DdpMethod, DdpSettings};

use crate::error::Result;
use crate::problem::{Cost, DdpProblem, Dynamics};
use forward::Rollout;
use regularization::Schedule;
use solve::{Finish as _, Watch};
use work::{History, Work};

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
/// Needs a [`Dynamics`] (first derivatives analytic or, by default, by
/// central differences; second ones optional, used by [`DdpMethod::Ddp`])
/// and a [`Cost`] with gradient and Hessian. Settings: [`DdpSettings`].
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
    /// are statuses of the result, not errors; so is a step of the dynamics
    /// that fails during the line search (that trial rollout counts as blown
    /// up) and derivatives that fail
    /// ([`DdpStatus::NonFiniteDerivatives`]).
    ///
    /// # Errors
    /// [`DdpError::Model`](crate::DdpError::Model) (or whatever error the
    /// dynamics return) when a step of the warm start's rollout fails: there
    /// is no trajectory to improve on.
    pub fn solve<D: Dynamics, C: Cost>(&self, problem: &DdpProblem<D, C>) -> Result<DdpResult> {
        self.solve_watched(problem, &mut Watch::new())
    }

    /// [`solve`](Self::solve) under a [`Watch`]: its observers see every
    /// iteration (the cost, the rollouts so far, the controls flattened)
    /// and may stop the solve ([`DdpStatus::Stopped`]); its time limit is
    /// checked at every iteration and before every trial rollout
    /// ([`DdpStatus::TimeLimit`]). Either way the result holds the last
    /// accepted trajectory with the policy at it (one more backward pass).
    ///
    /// ```
    /// use solve::{Control, Progress, Watch};
    /// use ddp::{Ddp, DdpSettings, DdpStatus};
    /// use ddp::problems::pendulum_swingup;
    ///
    /// let problem = pendulum_swingup(100)?;
    /// let mut once = |_: &Progress<'_>| Control::Stop;
    /// let mut watch = Watch::new().with_observer(&mut once);
    /// let r = Ddp::new(DdpSettings::default())?.solve_watched(&problem, &mut watch)?;
    /// assert_eq!((r.status, r.iterations), (DdpStatus::Stopped, 1));
    /// assert_eq!(r.gains.len(), 100);
    /// # Ok::<(), ddp::DdpError>(())
    /// ```
    ///
    /// # Errors
    /// As [`solve`](Self::solve).
    pub fn solve_watched<D: Dynamics, C: Cost>(
        &self,
        problem: &DdpProblem<D, C>,
        watch: &mut Watch<'_>,
    ) -> Result<DdpResult> {
        let mut run = self.start(problem)?;
        let Ok(status) = solve::drive(&mut run, watch);
        Ok(run.finish(status))
    }

    /// The solve's state before its first iteration (the warm start's
    /// rollout done), for a loop other than
    /// [`solve_watched`](Self::solve_watched)'s: argmin's `Executor`
    /// through `solve::argmin::Stepper` (feature `argmin`), or the
    /// caller's own, calling [`solve::Iterate::next_iter`] until it
    /// returns a status and then [`solve::Finish::finish`] (which computes
    /// the policy at the returned trajectory, as the solve does). When the
    /// warm start's rollout diverged, the first iteration ends the run with
    /// [`DdpStatus::InitialRolloutDiverged`].
    ///
    /// ```
    /// use solve::{Finish, Iterate, Watch};
    /// use ddp::{Ddp, DdpSettings};
    /// use ddp::problems::pendulum_swingup;
    ///
    /// let problem = pendulum_swingup(100)?;
    /// let ddp = Ddp::new(DdpSettings::default())?;
    /// let mut run = ddp.start(&problem)?;
    /// let watch = Watch::new();
    /// let status = loop {
    ///     if let Ok(Some(status)) = run.next_iter(&watch) {
    ///         break status;
    ///     }
    /// };
    /// let r = run.finish(status);
    /// assert!(r.status.is_converged());
    /// assert_eq!(r.controls, ddp.solve(&problem)?.controls);
    /// # Ok::<(), ddp::DdpError>(())
    /// ```
    ///
    /// # Errors
    /// As [`solve`](Self::solve).
    pub fn start<'a, D: Dynamics, C: Cost>(&'a self, problem: &'a DdpProblem<D, C>) -> Result<DdpRun<'a, D, C>> {
        let started = Instant::now();
        let s = &self.settings;
        let mut work = Work::new(problem, s);
        let (cost, diverged) = match work.initial_rollout()? {
            Rollout::Ok(c) => (c, None),
            Rollout::Diverged(step) => (f64::INFINITY, Some(step)),
        };
        Ok(DdpRun {
            work,
            started,
            diverged,
            cost,
            costs: vec![cost],
            regs: Vec::new(),
            steps: Vec::new(),
            reg: Schedule::new(s.reg_init, s.reg_factor, s.reg_min),
            need_derivatives: true,
            policy_current: false,
            iterations: 0,
            // the initial rollout, then every trial one
            rollouts: 1,
        })
    }
}

/// The solver's name in [`solve::Progress`].
const NAME: &str = "ddp";

impl<D: Dynamics, C: Cost> solve::Finish for DdpRun<'_, D, C> {
    type Output = DdpResult;

    /// The result: a policy at the returned trajectory (one more backward
    /// pass when the last iteration did not leave one), the history, and
    /// the time since [`Ddp::start`].
    fn finish(self, mut status: DdpStatus) -> DdpResult {
        let DdpRun {
            mut work,
            started,
            diverged,
            cost,
            costs,
            regs,
            steps,
            mut reg,
            need_derivatives,
            mut policy_current,
            iterations,
            ..
        } = self;
        let mut result = if let Some(step) = diverged {
            work.result_diverged(step)
        } else {
            let s = work.s;
            // a policy at the returned trajectory, if one was not just computed
            if !policy_current
                && matches!(
                    status,
                    DdpStatus::MaxIterations | DdpStatus::TimeLimit | DdpStatus::Stopped
                )
            {
                if need_derivatives && !work.linearise() {
                    status = DdpStatus::NonFiniteDerivatives;
                } else {
                    loop {
                        if work.backward(reg.mu).is_some() {
                            policy_current = true;
                            break;
                        }
                        reg.increase();
                        if reg.mu > s.reg_max {
                            break;
                        }
                    }
                }
            }
            let history = History {
                cost,
                initial_cost: costs[0],
                cost_history: costs,
                regularizations: regs,
                step_sizes: steps,
                mu: reg.mu,
                iterations,
            };
            work.result(status, history, policy_current)
        };
        result.solve_time = started.elapsed();
        result
    }
}

/// A DDP solve between iterations ([`Ddp::start`]): a [`solve::Iterate`]
/// state, and a [`solve::Finish`] one whose result is the [`DdpResult`].
pub struct DdpRun<'a, D, C> {
    work: Work<'a, D, C>,
    started: Instant,
    /// The step at which the warm start's rollout diverged: the run ends
    /// at its first iteration.
    diverged: Option<usize>,
    cost: f64,
    costs: Vec<f64>,
    regs: Vec<f64>,
    steps: Vec<f64>,
    reg: Schedule,
    need_derivatives: bool,
    policy_current: bool,
    iterations: usize,
    rollouts: usize,
}

impl<D, C> std::fmt::Debug for DdpRun<'_, D, C> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DdpRun")
            .field("iterations", &self.iterations)
            .field("cost", &self.cost)
            .field("diverged", &self.diverged)
            .finish_non_exhaustive()
    }
}

impl<D: Dynamics, C: Cost> solve::Iterate for DdpRun<'_, D, C> {
    type Status = DdpStatus;
    type Error = std::convert::Infallible;
    const NAME: &'static str = NAME;

    /// One iteration: linearise, backward pass (raising $\mu$ until it
    /// succeeds), convergence test, line search, update of $\mu$.
    fn next_iter(&mut self, watch: &Watch<'_>) -> std::result::Result<Option<DdpStatus>, Self::Error> {
        if let Some(step) = self.diverged {
            return Ok(Some(DdpStatus::InitialRolloutDiverged { step }));
        }
        let w = &mut self.work;
        let s = w.s;
        if let Some(why) = watch.out_of_time() {
            return Ok(Some(why.into()));
        }
        if self.need_derivatives {
            if !w.linearise() {
                return Ok(Some(DdpStatus::NonFiniteDerivatives));
            }
            self.need_derivatives = false;
        }
        let (dv1, dv2) = loop {
            self.policy_current = false;
            match w.backward(self.reg.mu) {
                Some(dv) => break dv,
                None => {
                    self.reg.increase();
                    if self.reg.mu > s.reg_max {
                        return Ok(Some(DdpStatus::NotPositiveDefinite));
                    }
                }
            }
        };
        self.policy_current = true;
        if w.converged(dv1 + dv2, self.cost) {
            if self.reg.mu <= 10.0 * s.reg_min {
                return Ok(Some(DdpStatus::Converged));
            }
            // a heavily regularised step is small without being converged:
            // confirm with an unregularised backward pass
            match w.backward(0.0) {
                Some((d1, d2)) if w.converged(d1 + d2, self.cost) => {
                    self.reg.mu = 0.0;
                    return Ok(Some(DdpStatus::Converged));
                }
                _ => {
                    if w.backward(self.reg.mu).is_none() {
                        self.policy_current = false;
                        return Ok(Some(DdpStatus::NotPositiveDefinite));
                    }
                }
            }
        }
        if self.iterations == s.max_iterations {
            return Ok(Some(DdpStatus::MaxIterations));
        }
        self.iterations += 1;
        self.regs.push(self.reg.mu);

        let mut alpha = 1.0;
        let mut accepted = None;
        let mut all_diverged = true;
        for _ in 0..s.n_line_search {
            if let Some(why) = watch.out_of_time() {
                return Ok(Some(why.into()));
            }
            self.rollouts += 1;
            if let Rollout::Ok(trial) = w.forward(alpha) {
                all_diverged = false;
                let expected = -alpha * (dv1 + alpha * dv2);
                let actual = self.cost - trial;
                let ok = if expected > 0.0 {
                    actual / expected > s.min_reduction_ratio
                } else {
                    actual > 0.0
                };
                if ok && trial <= self.cost {
                    accepted = Some((alpha, trial));
                    break;
                }
            }
            alpha *= s.line_search_factor;
        }
        match accepted {
            Some((alpha, trial)) => {
                std::mem::swap(&mut w.xs, &mut w.xs_try);
                std::mem::swap(&mut w.us, &mut w.us_try);
                std::mem::swap(&mut w.stage, &mut w.stage_try);
                self.cost = trial;
                self.steps.push(alpha);
                self.costs.push(self.cost);
                self.need_derivatives = true;
                self.policy_current = false;
                self.reg.decrease();
            }
            None => {
                self.steps.push(0.0);
                self.costs.push(self.cost);
                self.reg.increase();
                if self.reg.mu > s.reg_max {
                    return Ok(Some(if all_diverged {
                        DdpStatus::RolloutDiverged
                    } else {
                        DdpStatus::NoDescent
                    }));
                }
            }
        }
        Ok(None)
    }

    fn snapshot(&self) -> solve::Snapshot<'_> {
        solve::Snapshot {
            iteration: self.iterations,
            evals: self.rollouts,
            cost: self.cost,
            x: &self.work.us,
        }
    }
}
