//! Sparse Gauss-Newton / Levenberg-Marquardt for [`LeastSquaresProblem`]s.
//!
//! Minimises $F(\theta) = \lVert r(\theta) \rVert^2$. Each iteration solves
//! the damped normal equations
//! $$(J^\top J + \mu D)\,\delta = -J^\top r, \qquad D = \operatorname{diag}(\max(J^\top J, d_{\min})),$$
//! by a sparse Cholesky factorisation $LL^\top$ (faer) whose symbolic part
//! (fill-reducing ordering, elimination tree) is computed once and reused;
//! $J^\top J$ is formed by a sparse product whose pattern is also computed
//! once. The step is accepted when the gain ratio
//! $\rho = (F(\theta) - F(\theta + \delta)) / (L(0) - L(\delta))$ is positive
//! ($L$ the local linear model), and $\mu$ follows Nielsen's rule:
//! $\mu \leftarrow \mu \max(1/3, 1 - (2\rho - 1)^3)$ on success,
//! $\mu \leftarrow \mu \nu$, $\nu \leftarrow 2 \nu$ on failure. With
//! `initial_damping = 0` the first step is the pure Gauss-Newton step (a
//! linear least-squares problem is solved in one iteration); damping is
//! switched on only if a step fails.
//!
//! With [bounds](LeastSquaresProblem::bounds) $\ell \le A\theta \le u$, the
//! step instead minimises the same damped model subject to
//! $\ell \le A(\theta + \delta) \le u$, a sparse convex QP solved by clarabel's
//! interior-point method; an infeasible start is first moved to the nearest
//! feasible point (the cost comparison starts there).
//!
//! For Eq. 3 ([`Eq3Problem`](crate::Eq3Problem)) every residual touches the
//! few coefficients whose basis functions overlap one time step, so $J^\top J$
//! is banded once the coefficients are ordered by time, and an iteration costs
//! time linear in the horizon. Such a problem can say so
//! ([`LeastSquaresProblem::band_layout`]) and form its normal equations
//! itself in band storage ([`LeastSquaresProblem::band_normal_equations`]):
//! the solver then skips the sparse Jacobian, the sparse product and the
//! sparse factorisation, and factorises band matrices ([`crate::banded`],
//! $O(N k^2)$ for half-bandwidth $k$, 30 for the benchmark pendulum at every
//! horizon). Without bounds this is the default (`band`); the iterates are
//! those of the sparse form up to rounding. In Newton mode the band form
//! holds $J^\top J + S$; when an iteration falls back to a Gauss-Newton
//! step, $J^\top J$ is recovered as $(J^\top J + S) - S$ from the problem's
//! $S$ alone ([`LeastSquaresProblem::band_second_order_part`]), or formed a
//! second time if the problem does not give it.
//!
//! | setting | default | meaning |
//! |---|---|---|
//! | `max_iters` | 200 | iteration cap |
//! | `tol_grad` | 1e-10 | stop when $\lVert J^\top r \rVert_\infty \le$ `tol_grad` $\max(1, F)$ |
//! | `tol_step` | 1e-12 | stop when $\lVert \delta \rVert \le$ `tol_step` $(\lVert \theta \rVert + $ `tol_step`$)$ |
//! | `tol_cost` | 1e-14 | stop when an accepted step lowers $F$ by less than `tol_cost` $F$ |
//! | `initial_damping` | 1e-6 | $\mu_0 = $ `initial_damping` (relative to $D$) |
//! | `second_order` | false | Newton steps with the problem's exact $S$ |
//! | `adaptive` | false | with `second_order`: per iteration, the model (Gauss-Newton or Newton) that predicted the last step better |
//! | `band` | true | the band form of the normal equations, when the problem has one |
//!
//! With `second_order`, a problem that evaluates the second-order term
//! $S = \sum_i r_i \nabla^2 r_i$ ([`LeastSquaresProblem::second_order_values`])
//! has it added: $H = J^\top J + S$ is half the exact Hessian of $F$, the
//! step is a damped Newton step, and the gain ratio compares with the
//! quadratic model $F + 2 g^\top \delta + \delta^\top H \delta$ (its
//! second-order Taylor expansion). $H$ may be indefinite away from a
//! minimum: it is then shifted to $H + \sigma D$, with $\sigma$ found as in
//! IPOPT's inertia correction (from $10^{-8}$, times 8 until the Cholesky
//! factorisation succeeds, divided by 3 at the next iteration, and by 300
//! after a Newton step whose actual reduction was within 25% of the
//! predicted one: the model is then trusted at that scale, as a trust
//! region grows after a very successful step); when that
//! takes $\sigma > 10^{-3}$, the iteration takes a Gauss-Newton step instead
//! (far from a solution the residuals' curvature can make the Newton model
//! useless, and Gauss-Newton's is always convex). The damping $\mu$ and the
//! gain ratio then work as above, so the cost never increases; near a
//! minimum with positive definite $H$ the steps are Newton steps and
//! converge quadratically (Gauss-Newton converges only linearly when the
//! residuals at the solution are large, as in Eq. 3 with a finite
//! $\lambda$). The pattern of $S$ is merged into that of $J^\top J$ once, so
//! the symbolic factorisation is still reused; only the upper triangle of
//! $H$ is formed and factorised.
//!
//! The iteration also stops (`ConvergedCost`) when the lightly damped
//! model predicts a decrease below `tol_cost` $F$: further steps would only
//! compare rounding errors; and when a step predicted to gain less than
//! the rounding bound of the cost itself ($n_r \epsilon F$ for $n_r$
//! residuals) is rejected, as raising the damping would only shrink the
//! step until it stalls (`Stalled`) at what is a minimum to working
//! precision.
//!
//! [`GaussNewton::solve_parallel`] forms the band normal equations in parts
//! ([`LeastSquaresProblem::band_normal_equations_part`]), one on this thread
//! and one on each helper thread. On two threads each thread keeps its
//! part and eliminates the coefficients only its part touches, and only
//! the Schur complement on the few coefficients both parts touch is
//! factorised on this thread (a two-domain decomposition of the band
//! matrix; see `trajopt/src/split.rs`); on more threads the parts are
//! added up in a fixed order and factorised here. Either way the iterates
//! are [`GaussNewton::solve`]'s up to rounding, and the same for every run
//! with the same number of threads.
//!
//! References: K. Madsen, H. B. Nielsen, O. Tingleff, *Methods for Non-Linear
//! Least Squares Problems* (2004), §3.2; J. Nocedal, S. Wright, *Numerical
//! Optimization* (2006), ch. 10.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use faer::Side;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::linalg::matmul::sparse_sparse_matmul_symbolic;
use faer::sparse::{SparseColMat, SparseRowMat, SymbolicSparseColMat, SymbolicSparseRowMat};
use faer::{Conj, MatMut, Par};

use crate::banded::{BandLayout, BandedSym};
use crate::error::{Result, TrajoptError, check_finite};
use crate::least_squares::{LeastSquaresProblem, LinearBounds};
use crate::parallel::Helpers;
use crate::split::{SplitDone, SplitJob, SplitPart, split_points};

/// Settings of [`GaussNewton`]; see the [module docs](self) for the defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct GaussNewtonSettings {
    /// Iteration cap.
    pub max_iters: usize,
    /// Gradient tolerance, relative to $\max(1, F)$.
    pub tol_grad: f64,
    /// Step tolerance, relative to $\lVert \theta \rVert$.
    pub tol_step: f64,
    /// Relative cost-decrease tolerance.
    pub tol_cost: f64,
    /// Initial damping $\mu_0$ (0: start with pure Gauss-Newton steps).
    pub initial_damping: f64,
    /// Add the problem's exact second-order term $S = \sum_i r_i \nabla^2 r_i$
    /// ([`LeastSquaresProblem::second_order_values`]) to $J^\top J$ when it
    /// has one: damped Newton steps instead of Gauss-Newton steps, which
    /// converge quadratically on large-residual problems. Ignored with
    /// bounds, and at points where the problem cannot evaluate $S$.
    ///
    /// Off by default: on the benchmark pendulum
    /// ([`pendulum_swingup`](crate::problems::pendulum_swingup)) with
    /// $\lambda = 10^2$ it needs 17-21 iterations instead of 101-113 at
    /// horizons 150 to 20000; but with $\lambda \ge 10^3$ (dynamics nearly enforced) it is
    /// worse: at $N = 1000$ neither mode converges within 200 iterations for
    /// $\lambda = 10^3, 10^4$ and Gauss-Newton does in 102 for $10^5$, and
    /// the Newton mode ends at a higher cost each time.
    pub second_order: bool,
    /// With `second_order`: choose at every iteration between the
    /// Gauss-Newton model ($J^\top J$) and the Newton model ($J^\top J + S$),
    /// taking the one whose predicted reduction for the last step was
    /// relatively closer to the actual reduction (the model switch of
    /// NL2SOL: Dennis, Gay and Welsch, ACM TOMS 7, 1981). $S$ is formed
    /// only at iterations that use it; the other model's prediction needs
    /// $\delta^\top S \delta$, from
    /// [`LeastSquaresProblem::second_order_form`] ([`Eq3Problem`](crate::Eq3Problem)
    /// evaluates it exactly, per step), or else from central differences of
    /// the residuals along the step (two residual evaluations per iteration,
    /// counted in `residual_evals`; a probe the problem cannot evaluate
    /// leaves the choice as it was). Nothing is spent on the choice until
    /// the problem has given $S$ once.
    ///
    /// On the benchmark pendulum at $N = 1000$ it takes 44, 175 and 446
    /// iterations at $\lambda = 10^2, 10^3, 10^4$, where Gauss-Newton takes
    /// 113, 358 and 446 and the Newton mode 17, 301 and no convergence in
    /// 1000. Off by default.
    pub adaptive: bool,
    /// Work on the band form of the normal equations when the problem has
    /// one ([`LeastSquaresProblem::band_layout`]; [`Eq3Problem`](crate::Eq3Problem)
    /// does) and there are no bounds: the problem forms $J^\top J$ (and
    /// $S$) directly in band storage and a band Cholesky factorisation
    /// replaces the sparse one. The iterates are the same up to rounding;
    /// `false` forces the general sparse path.
    pub band: bool,
    /// Let [`GaussNewton::solve_parallel`] go on with one thread when its
    /// helpers do not start or answer in time (a busy machine), instead of
    /// waiting for them at every hand-over. On by default; off, the result
    /// depends only on the number of threads, bit for bit, however slow
    /// the machine (reproducible runs, tests of the parallel path).
    pub one_thread_fallback: bool,
}

impl Default for GaussNewtonSettings {
    fn default() -> Self {
        Self {
            max_iters: 200,
            tol_grad: 1e-10,
            tol_step: 1e-12,
            tol_cost: 1e-14,
            initial_damping: 1e-6,
            second_order: false,
            adaptive: false,
            band: true,
            one_thread_fallback: true,
        }
    }
}

impl GaussNewtonSettings {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("tol_grad", self.tol_grad),
            ("tol_step", self.tol_step),
            ("tol_cost", self.tol_cost),
            ("initial_damping", self.initial_damping),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(TrajoptError::InvalidParameter {
                    name,
                    reason: format!("must be finite and nonnegative, got {v}"),
                });
            }
        }
        Ok(())
    }
}

/// Why [`GaussNewton`] stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GaussNewtonStatus {
    /// The gradient $J^\top r$ is below tolerance.
    ConvergedGradient,
    /// The step is below tolerance.
    ConvergedStep,
    /// The cost no longer decreases.
    ConvergedCost,
    /// The iteration cap was reached.
    MaxIterations,
    /// Steps kept failing until the damping made them negligible, while the
    /// gradient is not small: the residuals are not smooth enough here for
    /// their linearisation to predict them (a rough learned model, or a
    /// Jacobian that does not match the residuals). Not a converged point.
    Stalled,
    /// The residuals or Jacobian became non-finite at every trial step, or
    /// the normal equations could not be factorised even with damping.
    NumericalError,
}

impl GaussNewtonStatus {
    /// Whether this is one of the converged statuses.
    pub fn converged(self) -> bool {
        matches!(
            self,
            Self::ConvergedGradient | Self::ConvergedStep | Self::ConvergedCost
        )
    }
}

/// What [`GaussNewton::solve`] returns.
#[derive(Debug, Clone)]
pub struct GaussNewtonResult {
    /// The best parameters found.
    pub theta: Vec<f64>,
    /// $F$ at `theta`.
    pub cost: f64,
    /// $F$ at the start.
    pub initial_cost: f64,
    /// Why it stopped.
    pub status: GaussNewtonStatus,
    /// Iterations (Jacobian evaluations).
    pub iterations: usize,
    /// Residual evaluations.
    pub residual_evals: usize,
    /// Jacobian evaluations.
    pub jacobian_evals: usize,
    /// Numerical Cholesky factorisations (one per trial step, more when
    /// $J^\top J + S$ needs a shift).
    pub factorizations: usize,
    /// Accepted cost after each iteration.
    pub cost_history: Vec<f64>,
    /// Wall time.
    pub elapsed: Duration,
    /// With [`GaussNewton::solve_parallel`]: the iteration from which the
    /// solve went on with one thread because its helpers answered late (a
    /// busy machine); `None` when it did not (and always without helpers).
    pub one_thread_from: Option<usize>,
}

/// Where [adaptive](GaussNewtonSettings::adaptive) iterations probe the
/// residuals' curvature: at $\theta \pm t \delta$ with this $t$ (central
/// differences: truncation error $O(t^2)$, rounding $O(\epsilon / t^2)$ relative).
const PROBE: f64 = 1e-3;

/// Sparse Gauss-Newton / Levenberg-Marquardt; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct GaussNewton {
    settings: GaussNewtonSettings,
}

impl GaussNewton {
    /// A solver with validated settings.
    pub fn new(settings: GaussNewtonSettings) -> Result<Self> {
        settings.validate()?;
        Ok(Self { settings })
    }

    /// The settings.
    pub fn settings(&self) -> &GaussNewtonSettings {
        &self.settings
    }

    /// Minimises $\lVert r(\theta) \rVert^2$ from `theta0`.
    ///
    /// # Errors
    /// Wrong dimensions, a non-finite `theta0`, a non-finite cost at
    /// `theta0` ([`TrajoptError::NonFiniteStart`]), or an error from the
    /// problem. Not converging is a status, not an error.
    pub fn solve<P: LeastSquaresProblem + ?Sized>(&self, problem: &P, theta0: &[f64]) -> Result<GaussNewtonResult> {
        self.solve_with(problem, theta0, None)
    }

    /// [`solve`](Self::solve) with the band normal equations formed, and
    /// the residuals evaluated, on `threads` threads: this one and
    /// `threads - 1` helpers living for the solve, each doing one part
    /// ([`LeastSquaresProblem::band_normal_equations_part`],
    /// [`LeastSquaresProblem::residuals_part`]). With two threads the
    /// factorisations are split too: each thread eliminates the
    /// coefficients only its part touches (part 1 in reversed order) and
    /// this thread factorises the Schur complement on the overlap, a few
    /// dozen coefficients for Eq. 3 (the [module docs](self)); with more,
    /// the parts are added up and factorised on this thread. `threads` is capped at the cores the system reports
    /// ([`std::thread::available_parallelism`]); with one thread, or
    /// without a band form (bounds, `band` off, or a problem without
    /// [`LeastSquaresProblem::band_layout`]), it is [`solve`](Self::solve).
    ///
    /// The parts' sums differ from one thread's by rounding only, so the
    /// iterates agree with [`solve`](Self::solve)'s to rounding (and the
    /// result does not depend on timing unless the solve fell back to one
    /// thread, see below: the same `threads` gives the same
    /// bits). Forming the normal equations is most of an iteration for
    /// [`Eq3Problem`](crate::Eq3Problem): on the benchmark pendulum at
    /// 1000 steps two threads take the Newton mode's solve from 11.7 to
    /// 6.8 ms (best of two runs of `scripts/compare_trajopt.py`), at
    /// 20000 steps from 283 to 172 ms (one run). Problems with fewer than
    /// [`MIN_PARALLEL_PARAMS`] parameters run on one thread. On a busy
    /// machine the helpers may wait for a core at every hand-over; once one
    /// of their answers came late (later than twice this thread's own work in the
    /// meantime, plus 1 ms) the solve goes on with one thread from the next
    /// iteration, whose arithmetic is then [`solve`](Self::solve)'s (so
    /// under load the result may differ from run to run by rounding;
    /// [`GaussNewtonSettings::one_thread_fallback`] turns this off). The
    /// helpers spin for up to 2 ms
    /// waiting for the next part before they park, as waking a parked
    /// thread costs tens of microseconds: a helper keeps its core busy
    /// while the solver factorises, so `threads` should not exceed the
    /// cores free for the solve (nor should the problem's own model
    /// evaluation be parallel on the same cores).
    ///
    /// # Errors
    /// As [`solve`](Self::solve); and [`TrajoptError::InvalidParameter`]
    /// if the problem's residual parts do not cover every row once.
    pub fn solve_parallel<P: LeastSquaresProblem + Sync + ?Sized>(
        &self,
        problem: &P,
        theta0: &[f64],
        threads: usize,
    ) -> Result<GaussNewtonResult> {
        // spinning helpers beyond the cores would take turns with the solver,
        // and small problems gain less from the parts than the hand-overs cost
        let cores = std::thread::available_parallelism().map_or(1, usize::from);
        if problem.n_params() < MIN_PARALLEL_PARAMS {
            return self.solve(problem, theta0);
        }
        self.solve_threads(problem, theta0, threads.min(cores))
    }

    /// [`solve_parallel`](Self::solve_parallel) without the cap on
    /// `threads`.
    fn solve_threads<P: LeastSquaresProblem + Sync + ?Sized>(
        &self,
        problem: &P,
        theta0: &[f64],
        threads: usize,
    ) -> Result<GaussNewtonResult> {
        // only the band form is split
        if threads <= 1 || !self.settings.band || problem.bounds().is_some() {
            return self.solve(problem, theta0);
        }
        std::thread::scope(|scope| {
            let helpers = Helpers::spawn(scope, problem, threads - 1);
            self.solve_with(problem, theta0, Some(helpers))
        })
    }

    fn solve_with<P: LeastSquaresProblem + ?Sized>(
        &self,
        problem: &P,
        theta0: &[f64],
        helpers: Option<Helpers>,
    ) -> Result<GaussNewtonResult> {
        let start = Instant::now();
        let (n_p, n_r) = (problem.n_params(), problem.n_residuals());
        if theta0.len() != n_p {
            return Err(TrajoptError::DimensionMismatch {
                what: "initial parameters",
                expected: n_p,
                actual: theta0.len(),
            });
        }
        check_finite("initial parameters", theta0)?;
        let s = &self.settings;

        let mut theta = theta0.to_vec();
        let mut r = vec![0.0; n_r];
        problem.residuals(&theta, &mut r)?;
        let mut cost = sum_sq(&r);
        if !cost.is_finite() {
            return Err(TrajoptError::NonFiniteStart { value: cost });
        }
        let mut residual_evals = 1;
        let bounds = problem.bounds();
        if let Some(b) = bounds {
            b.validate()?;
            if b.a.ncols() != n_p {
                return Err(TrajoptError::DimensionMismatch {
                    what: "bound matrix columns",
                    expected: n_p,
                    actual: b.a.ncols(),
                });
            }
            // an infeasible start is first moved to the nearest feasible point
            if b.violation(&theta) > 1e-9 {
                let delta = crate::qp::projection(b, &theta).ok_or(TrajoptError::InfeasibleBounds)?;
                for (t, d) in theta.iter_mut().zip(delta) {
                    *t += d;
                }
                problem.residuals(&theta, &mut r)?;
                residual_evals += 1;
                cost = sum_sq(&r);
                if !cost.is_finite() {
                    return Err(TrajoptError::NonFiniteStart { value: cost });
                }
            }
        }
        let initial_cost = cost;
        let mut jacobian_evals = 0;
        let mut cost_history = Vec::new();

        // the band form only when it is narrow (a basis with wide supports,
        // such as a multilevel wavelet, makes it dense)
        let band = match bounds {
            None if s.band => problem.band_layout().filter(|l| l.half_bandwidth <= MAX_HALF_BANDWIDTH),
            _ => None,
        };
        // kept to go on with one thread when the helpers wait for cores
        let band_layout = band.clone();
        let mut one_thread_from = None;
        let mut system = match band {
            Some(layout) => {
                layout.validate(n_p)?;
                match helpers {
                    Some(helpers) if helpers.count() == 1 => {
                        System::Split(Box::new(SplitSystem::new(layout, s.second_order, helpers)))
                    }
                    helpers => System::Band(Box::new(BandSystem::new(layout, s.second_order, helpers))),
                }
            }
            None => System::Sparse(Box::new(SparseSystem::new(
                problem,
                n_r,
                n_p,
                s.second_order && bounds.is_none(),
            )?)),
        };

        let mut grad = vec![0.0; n_p];
        let mut scale = vec![0.0; n_p];
        let mut step = vec![0.0; n_p];
        let mut h_step = vec![0.0; n_p];
        let mut trial = vec![0.0; n_p];
        let mut r_trial = vec![0.0; n_r];
        let mut mu = s.initial_damping;
        let mut nu = 2.0;
        let mut status = GaussNewtonStatus::MaxIterations;
        let mut iterations = 0;
        // the shift making J^T J + S positive definite, relative to D
        let mut shift = 0.0f64;
        // whether the last accepted step was a Newton step whose reduction
        // the model predicted within ACCURATE (relative)
        let mut accurate = false;
        let mut factorizations = 0;
        // adaptive: which model the next iteration uses, and the residuals
        // on either side of a step (its curvature probe)
        let adaptive = s.adaptive && s.second_order && bounds.is_none();
        let mut prefer_newton = true;
        // whether the problem has given S yet (no probes before: a problem
        // without second derivatives takes Gauss-Newton steps at no extra cost)
        let mut s_seen = false;
        let (mut r_plus, mut r_minus) = if adaptive {
            (vec![0.0; n_r], vec![0.0; n_r])
        } else {
            (Vec::new(), Vec::new())
        };

        'outer: while iterations < s.max_iters {
            if let (true, true, Some(layout)) = (s.one_thread_fallback, system.helpers_degraded(), &band_layout) {
                // the helpers wait for cores (a busy machine): one thread is faster
                one_thread_from = Some(iterations + 1);
                system = System::Band(Box::new(BandSystem::new(layout.clone(), s.second_order, None)));
            }
            iterations += 1;
            jacobian_evals += 1;
            let want_s = !adaptive || prefer_newton;
            let Some(mut newton) = system.assemble(problem, &theta, &r, &mut grad, want_s)? else {
                status = GaussNewtonStatus::NumericalError;
                break;
            };
            s_seen |= newton;
            // the damping scale comes from J^T J alone (positive)
            system.jtj_diagonal(&mut scale);
            for d in &mut scale {
                *d = d.max(1e-12);
            }
            let g_inf = grad.iter().fold(0.0f64, |a, g| a.max(g.abs()));
            if g_inf <= s.tol_grad * cost.max(1.0) {
                status = GaussNewtonStatus::ConvergedGradient;
                break;
            }

            // inner loop: raise the damping until a step is accepted
            if newton {
                shift *= if accurate {
                    SHIFT_DECREASE * SHIFT_DECREASE_ACCURATE
                } else {
                    SHIFT_DECREASE
                };
            }
            loop {
                let total = if newton { mu + shift } else { mu };
                let solved = match bounds {
                    // bounded: the damped model minimised subject to the bounds (a QP)
                    Some(b) => system.bounded_step(newton, total, &scale, &grad, b, &theta, &mut step),
                    None => {
                        factorizations += 1;
                        system.damped_step(newton, total, &scale, &grad, &mut step)
                    }
                };
                if !(solved && step.iter().all(|v| v.is_finite())) {
                    if newton {
                        // J^T J + S + mu D is indefinite: shift it, or
                        // take a Gauss-Newton step if it takes a large shift
                        shift = (shift * SHIFT_INCREASE).max(SHIFT_MIN);
                        if shift > SHIFT_MAX {
                            newton = false;
                            if !system.ensure_gauss_newton(problem, &theta, &r)? {
                                status = GaussNewtonStatus::NumericalError;
                                break 'outer;
                            }
                        }
                        continue;
                    }
                    // not positive definite: more damping
                    if !raise_damping(&mut mu, &mut nu) {
                        status = GaussNewtonStatus::NumericalError;
                        break 'outer;
                    }
                    continue;
                }
                let step_norm = sum_sq(&step).sqrt();
                let theta_norm = sum_sq(&theta).sqrt();
                if step_norm <= s.tol_step * (theta_norm + s.tol_step) {
                    // a negligible step is convergence only if the damping did
                    // not force it: with mu >= 1 the damping term outweighs the
                    // curvature and the gradient is still large
                    status = if mu < 1.0 {
                        GaussNewtonStatus::ConvergedStep
                    } else {
                        GaussNewtonStatus::Stalled
                    };
                    break 'outer;
                }
                // L(d) = |r + J d|^2 = F + 2 g.d + d.H.d: predicted reduction L(0) - L(d)
                // (with S, the second-order Taylor model of F)
                system.model_mul(newton, &step, &mut h_step);
                let predicted: f64 = -step
                    .iter()
                    .zip(grad.iter().zip(&h_step))
                    .map(|(d, (g, hd))| d * (2.0 * g + hd))
                    .sum::<f64>();
                if predicted >= 0.0 && predicted <= s.tol_cost * cost && mu < 1.0 {
                    // the (barely damped) model has nothing left to gain: further
                    // steps would only compare rounding errors
                    status = GaussNewtonStatus::ConvergedCost;
                    break 'outer;
                }
                for j in 0..n_p {
                    trial[j] = theta[j] + step[j];
                }
                system.residuals(problem, &trial, &mut r_trial)?;
                residual_evals += 1;
                let trial_cost = sum_sq(&r_trial);
                let rho = if predicted > 0.0 && trial_cost.is_finite() {
                    (cost - trial_cost) / predicted
                } else {
                    -1.0
                };
                // whether `trial` was overwritten by curvature probes
                let mut probes_in_trial = false;
                if adaptive && s_seen && trial_cost.is_finite() {
                    // delta^T S delta = sum_i r_i delta^T (grad^2 r_i) delta: from the
                    // problem, or by central differences of r along the step
                    let s_form = match problem.second_order_form(&theta, &r, &step).ok().flatten() {
                        Some(form) => form,
                        None => {
                            probes_in_trial = true;
                            let mut probed = true;
                            for (sign, out) in [(1.0, &mut r_plus), (-1.0, &mut r_minus)] {
                                for j in 0..n_p {
                                    trial[j] = theta[j] + sign * PROBE * step[j];
                                }
                                probed &= problem.residuals(&trial, out).is_ok();
                            }
                            residual_evals += 2;
                            if probed {
                                (0..n_r)
                                    .map(|i| r[i] * (r_plus[i] - 2.0 * r[i] + r_minus[i]))
                                    .sum::<f64>()
                                    / (PROBE * PROBE)
                            } else {
                                f64::NAN
                            }
                        }
                    };
                    if s_form.is_finite() {
                        // the predicted reductions of both models for this step
                        let (gauss_newton, full) = if newton {
                            (predicted + s_form, predicted)
                        } else {
                            (predicted, predicted - s_form)
                        };
                        let actual = cost - trial_cost;
                        let error = |p: f64| (actual - p).abs() / p.abs().max(f64::MIN_POSITIVE);
                        let (e_gn, e_full) = (error(gauss_newton), error(full));
                        prefer_newton = if newton { e_full <= e_gn } else { e_full < e_gn };
                    }
                }
                if rho > 0.0 && trial_cost.is_finite() && trial_cost <= cost {
                    let decrease = cost - trial_cost;
                    if probes_in_trial {
                        for j in 0..n_p {
                            trial[j] = theta[j] + step[j];
                        }
                    }
                    std::mem::swap(&mut theta, &mut trial);
                    std::mem::swap(&mut r, &mut r_trial);
                    cost = trial_cost;
                    cost_history.push(cost);
                    mu *= (1.0 / 3.0f64).max(1.0 - (2.0 * rho - 1.0).powi(3));
                    accurate = newton && (rho - 1.0).abs() < ACCURATE;
                    nu = 2.0;
                    if decrease <= s.tol_cost * cost {
                        status = GaussNewtonStatus::ConvergedCost;
                        break 'outer;
                    }
                    break;
                }
                // a rejected step whose predicted gain is below the cost's
                // own rounding (n_r eps F bounds that of a sum of n_r
                // squares) cannot be told from noise: nothing is left to gain
                // (more damping would only shrink the step until it stalls)
                if trial_cost.is_finite()
                    && predicted >= 0.0
                    && predicted <= n_r as f64 * f64::EPSILON * cost
                    && mu < 1.0
                {
                    status = GaussNewtonStatus::ConvergedCost;
                    break 'outer;
                }
                if !raise_damping(&mut mu, &mut nu) {
                    status = GaussNewtonStatus::NumericalError;
                    break 'outer;
                }
            }
        }
        Ok(GaussNewtonResult {
            theta,
            cost,
            initial_cost,
            status,
            iterations,
            residual_evals,
            jacobian_evals,
            factorizations,
            cost_history,
            elapsed: start.elapsed(),
            one_thread_from,
        })
    }
}

/// The normal equations in one of two forms: the general sparse one (a
/// sparse Jacobian, $J^\top J$ by a sparse product, a sparse Cholesky
/// factorisation) or the band form of problems that provide one
/// ([`LeastSquaresProblem::band_layout`]).
enum System {
    Sparse(Box<SparseSystem>),
    Band(Box<BandSystem>),
    /// The band form on two threads, kept and factorised in two parts
    /// ([`crate::split`]).
    Split(Box<SplitSystem>),
}

/// Below this many parameters [`GaussNewton::solve_parallel`] runs on one
/// thread: the hand-overs cost more than the parts save (the benchmark
/// pendulum at 300 steps, 257 parameters, took 7.3 ms on two threads
/// against 4.6 ms on one on an idle machine; at 1000 steps, 812
/// parameters, 6.8 against 11.7 ms).
pub const MIN_PARALLEL_PARAMS: usize = 500;

impl System {
    /// Whether this system's helper threads answered late often enough
    /// that one thread would be faster ([`Helpers::degraded`]).
    fn helpers_degraded(&mut self) -> bool {
        match self {
            Self::Band(b) => b.helpers.as_mut().is_some_and(Helpers::degraded),
            Self::Split(b) => b.helpers.degraded(),
            Self::Sparse(_) => false,
        }
    }

    /// Forms $J^\top J$ (and $J^\top J + S$ when asked and available) and
    /// $g = J^\top r$ at $\theta$. `None` if the Jacobian is not finite;
    /// otherwise whether the Newton matrix $J^\top J + S$ is ready.
    fn assemble<P: LeastSquaresProblem + ?Sized>(
        &mut self,
        problem: &P,
        theta: &[f64],
        r: &[f64],
        grad: &mut [f64],
        want_s: bool,
    ) -> Result<Option<bool>> {
        match self {
            Self::Sparse(s) => s.assemble(problem, theta, r, grad, want_s),
            Self::Band(b) => b.assemble(problem, theta, r, grad, want_s),
            Self::Split(b) => b.assemble(problem, theta, r, grad, want_s),
        }
    }

    /// $r(\theta)$, split over the helper threads if there are any.
    fn residuals<P: LeastSquaresProblem + ?Sized>(&mut self, problem: &P, theta: &[f64], r: &mut [f64]) -> Result<()> {
        match self {
            Self::Band(b) => match b.helpers.as_mut() {
                Some(helpers) => helpers.residuals(problem, theta, r),
                None => problem.residuals(theta, r),
            },
            Self::Split(b) => b.helpers.residuals(problem, theta, r),
            Self::Sparse(_) => problem.residuals(theta, r),
        }
    }

    /// The diagonal of $J^\top J$, in the parameter order.
    fn jtj_diagonal(&self, out: &mut [f64]) {
        match self {
            Self::Sparse(s) => {
                for (o, &p) in out.iter_mut().zip(&s.diag_pos) {
                    *o = s.h.val()[p];
                }
            }
            Self::Band(b) => b.jtj_diagonal(out),
            Self::Split(b) => b.jtj_diagonal(out),
        }
    }

    /// Solves $(H + \text{total}\, D)\,\delta = -g$ ($H$ the Newton matrix
    /// if `newton`, else $J^\top J$); false if it is not numerically
    /// positive definite.
    fn damped_step(&mut self, newton: bool, total: f64, scale: &[f64], grad: &[f64], step: &mut [f64]) -> bool {
        for (d, g) in step.iter_mut().zip(grad) {
            *d = -g;
        }
        match self {
            Self::Sparse(s) => {
                s.damp(newton, total, scale);
                let n = step.len();
                let rhs = MatMut::from_column_major_slice_mut(step, n, 1);
                s.factor.solve(s.h_damped.as_ref(), rhs)
            }
            Self::Band(b) => b.damped_step(newton, total, scale, step),
            Self::Split(b) => b.damped_step(newton, total, scale, step),
        }
    }

    /// Makes the Gauss-Newton matrix $J^\top J$ available at this iterate
    /// (the band form may hold only $J^\top J + S$); false if it is not
    /// finite.
    fn ensure_gauss_newton<P: LeastSquaresProblem + ?Sized>(
        &mut self,
        problem: &P,
        theta: &[f64],
        r: &[f64],
    ) -> Result<bool> {
        match self {
            Self::Sparse(_) => Ok(true),
            Self::Band(b) => b.ensure_gauss_newton(problem, theta, r),
            Self::Split(b) => b.ensure_gauss_newton(problem, theta, r),
        }
    }

    /// The damped model minimised subject to the bounds (sparse form only).
    #[allow(clippy::too_many_arguments)]
    fn bounded_step(
        &mut self,
        newton: bool,
        total: f64,
        scale: &[f64],
        grad: &[f64],
        bounds: &LinearBounds,
        theta: &[f64],
        step: &mut [f64],
    ) -> bool {
        let Self::Sparse(s) = self else {
            return false;
        };
        s.damp(newton, total, scale);
        match crate::qp::bounded_step(&s.h_damped, grad, bounds, theta) {
            Some(d) => {
                step.copy_from_slice(&d);
                true
            }
            None => false,
        }
    }

    /// $H \delta$ with the undamped model matrix.
    fn model_mul(&mut self, newton: bool, step: &[f64], out: &mut [f64]) {
        match self {
            Self::Sparse(s) => sym_mat_vec(if newton { &s.h_full } else { &s.h }, step, out),
            Self::Band(b) => b.model_mul(newton, step, out),
            Self::Split(b) => b.model_mul(newton, step, out),
        }
    }
}

/// For each value of the problem's $S$, its index and its position in the
/// values of $H$; and $S$'s values.
type SecondOrderValues = (Vec<(usize, usize)>, Vec<f64>);

/// The general form: $J$ sparse, $J^\top J$ (+ $S$) in a fixed sparse
/// pattern, a sparse Cholesky factorisation with a reused symbolic part.
struct SparseSystem {
    jac: SparseRowMat<usize, f64>,
    nnz_problem: usize,
    /// $J^\top J$, $J^\top J + S$, and the damped matrix (upper triangles).
    h: SparseColMat<usize, f64>,
    h_full: SparseColMat<usize, f64>,
    h_damped: SparseColMat<usize, f64>,
    diag_pos: Vec<usize>,
    /// Where each value of $S$ goes in $H$, and $S$'s values.
    second_order: Option<SecondOrderValues>,
    normal: NormalEquations,
    factor: Factor,
}

impl SparseSystem {
    fn new<P: LeastSquaresProblem + ?Sized>(problem: &P, n_r: usize, n_p: usize, second_order: bool) -> Result<Self> {
        // J is augmented with structurally present, zero-valued unit rows so that
        // the diagonal of J^T J is always in its pattern (a parameter that no
        // residual touches is then simply left alone by the damped step)
        let pattern = augment_with_diagonal(&problem.jacobian_pattern(), n_r, n_p)?;
        let nnz = pattern.col_idx().len();
        let jac = SparseRowMat::new(pattern, vec![0.0; nnz]);
        let jac_cols = jac.to_col_major().map_err(alloc_error)?;
        let (jtj_symbolic, _) = sparse_sparse_matmul_symbolic(jac.as_ref().transpose().symbolic(), jac_cols.symbolic())
            .map_err(alloc_error)?;
        // the second-order term, merged into the pattern of J^T J
        let (h_symbolic, second_order) = match second_order.then(|| problem.second_order_pattern()).flatten() {
            Some(pattern) => {
                if pattern.nrows() != n_p || pattern.ncols() != n_p {
                    return Err(TrajoptError::DimensionMismatch {
                        what: "second-order pattern size",
                        expected: n_p,
                        actual: if pattern.nrows() != n_p {
                            pattern.nrows()
                        } else {
                            pattern.ncols()
                        },
                    });
                }
                let union = upper_union(&jtj_symbolic, Some(&pattern));
                let positions = positions_in(&union, &pattern);
                let values = vec![0.0; pattern.row_idx().len()];
                (union, Some((positions, values)))
            }
            None => (upper_union(&jtj_symbolic, None), None),
        };
        let diag_pos = diagonal_positions(&h_symbolic)?;
        let h_nnz = h_symbolic.row_idx().len();
        let h = SparseColMat::new(h_symbolic, vec![0.0; h_nnz]);
        let factor = Factor::new(h.symbolic())?;
        let normal = NormalEquations::new(&jac, jac_cols, &h.symbolic().to_owned().map_err(alloc_error)?)?;
        Ok(Self {
            jac,
            nnz_problem: nnz - n_p,
            h_full: h.clone(),
            h_damped: h.clone(),
            h,
            diag_pos,
            second_order,
            normal,
            factor,
        })
    }

    fn assemble<P: LeastSquaresProblem + ?Sized>(
        &mut self,
        problem: &P,
        theta: &[f64],
        r: &[f64],
        grad: &mut [f64],
        want_s: bool,
    ) -> Result<Option<bool>> {
        problem.jacobian_values(theta, &mut self.jac.val_mut()[..self.nnz_problem])?;
        if self.jac.val().iter().any(|v| !v.is_finite()) {
            return Ok(None);
        }
        self.normal.form(&self.jac, &mut self.h);
        let mut newton = false;
        if let Some((positions, values)) = self.second_order.as_mut().filter(|_| want_s)
            && problem.second_order_values(theta, r, values)?
        {
            let h_vals = self.h_full.val_mut();
            h_vals.copy_from_slice(self.h.val());
            for &(p, q) in positions.iter() {
                h_vals[q] += values[p];
            }
            newton = h_vals.iter().all(|v| v.is_finite());
        }
        // g = J^T r (the augmented rows have zero residual and contribute nothing)
        grad.fill(0.0);
        for (i, &ri) in r.iter().enumerate() {
            let cols = self.jac.symbolic().col_idx_of_row_raw(i);
            for (&c, &v) in cols.iter().zip(self.jac.val_of_row(i)) {
                grad[c] += v * ri;
            }
        }
        Ok(Some(newton))
    }

    /// `h_damped` = the model matrix + `total` D.
    fn damp(&mut self, newton: bool, total: f64, scale: &[f64]) {
        let model = if newton { &self.h_full } else { &self.h };
        self.h_damped.val_mut().copy_from_slice(model.val());
        let vals = self.h_damped.val_mut();
        for (&p, &d) in self.diag_pos.iter().zip(scale) {
            vals[p] += total * d;
        }
    }
}

/// The band form: $J^\top J$ (or $J^\top J + S$) formed by the problem in
/// band storage, a band Cholesky factorisation ([`crate::banded`]).
struct BandSystem {
    layout: Arc<BandLayout>,
    /// Threads forming parts of the normal equations, if any.
    helpers: Option<Helpers>,
    /// $S$ alone, for $J^\top J = H - S$ (formed on demand).
    s_band: Option<BandedSym>,
    second_order: bool,
    /// The model matrix: $J^\top J + S$ when `has_s`, else $J^\top J$.
    h: BandedSym,
    has_s: bool,
    /// The diagonal of $S$ (parameter order), to recover $D$ from `h`.
    diag_s: Vec<f64>,
    /// $J^\top J$ when `h` holds $J^\top J + S$ and a Gauss-Newton step is
    /// wanted (formed on demand: most Newton iterations need no second pass).
    jtj: Option<BandedSym>,
    jtj_current: bool,
    /// The damped matrix and its factor (the same storage).
    work: Option<BandedSym>,
    /// Vectors in the band order.
    rhs: Vec<f64>,
    product: Vec<f64>,
    scratch: Vec<f64>,
}

impl BandSystem {
    fn new(layout: BandLayout, second_order: bool, helpers: Option<Helpers>) -> Self {
        let n = layout.position.len();
        let h = BandedSym::zeros(n, layout.half_bandwidth);
        Self {
            second_order,
            work: Some(h.clone()),
            h,
            has_s: false,
            diag_s: vec![0.0; n],
            jtj: None,
            jtj_current: false,
            layout: Arc::new(layout),
            helpers,
            s_band: None,
            rhs: vec![0.0; n],
            product: vec![0.0; n],
            scratch: vec![0.0; n],
        }
    }

    fn assemble<P: LeastSquaresProblem + ?Sized>(
        &mut self,
        problem: &P,
        theta: &[f64],
        r: &[f64],
        grad: &mut [f64],
        want_s: bool,
    ) -> Result<Option<bool>> {
        let diag_s = (self.second_order && want_s).then_some(&mut self.diag_s[..]);
        self.has_s = band_form(
            &mut self.helpers,
            problem,
            theta,
            r,
            &self.layout,
            &mut self.h,
            grad,
            diag_s,
        )?;
        self.jtj_current = false;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(finite(self.h.band()) && finite(grad)) {
            // a non-finite S only rules out Newton steps
            if !self.has_s || !self.form_jtj(problem, theta, r)? {
                return Ok(None);
            }
            self.has_s = false;
            grad.copy_from_slice(&self.scratch);
            if let Some(jtj) = self.jtj.as_mut() {
                std::mem::swap(&mut self.h, jtj);
            }
        }
        Ok(Some(self.has_s))
    }

    /// Forms $J^\top J$ alone into `jtj`; false if it is not finite.
    fn form_jtj<P: LeastSquaresProblem + ?Sized>(&mut self, problem: &P, theta: &[f64], r: &[f64]) -> Result<bool> {
        let jtj = self
            .jtj
            .get_or_insert_with(|| BandedSym::zeros(self.h.size(), self.h.half_bandwidth()));
        band_form(
            &mut self.helpers,
            problem,
            theta,
            r,
            &self.layout,
            jtj,
            &mut self.scratch,
            None,
        )?;
        self.jtj_current = true;
        Ok(jtj.band().iter().chain(&self.scratch).all(|v| v.is_finite()))
    }

    /// Makes $J^\top J$ available for Gauss-Newton steps at this iterate.
    fn ensure_gauss_newton<P: LeastSquaresProblem + ?Sized>(
        &mut self,
        problem: &P,
        theta: &[f64],
        r: &[f64],
    ) -> Result<bool> {
        if !self.has_s || self.jtj_current {
            return Ok(true);
        }
        if self.jtj_from_second_order(problem, theta, r)? {
            return Ok(true);
        }
        self.form_jtj(problem, theta, r)
    }

    /// $J^\top J = H - S$ from the problem's $S$ alone
    /// ([`LeastSquaresProblem::band_second_order_part`]), cheaper than
    /// forming $J^\top J$; false if the problem does not give $S$ alone or
    /// the difference is not finite.
    fn jtj_from_second_order<P: LeastSquaresProblem + ?Sized>(
        &mut self,
        problem: &P,
        theta: &[f64],
        r: &[f64],
    ) -> Result<bool> {
        let (n, kd) = (self.h.size(), self.h.half_bandwidth());
        let s = self.s_band.get_or_insert_with(|| BandedSym::zeros(n, kd));
        let found = match &mut self.helpers {
            Some(helpers) => helpers.band_second_order(problem, theta, r, &self.layout, s)?,
            None => problem.band_second_order_part(0, 1, theta, r, &self.layout, s)?,
        };
        if !found {
            return Ok(false);
        }
        let jtj = self.jtj.get_or_insert_with(|| BandedSym::zeros(n, kd));
        jtj.copy_from(&self.h);
        jtj.add_scaled(-1.0, s);
        if !jtj.band().iter().all(|v| v.is_finite()) {
            return Ok(false);
        }
        self.jtj_current = true;
        Ok(true)
    }

    /// The diagonal of $J^\top J$ in the parameter order.
    fn jtj_diagonal(&self, out: &mut [f64]) {
        for (i, (o, &p)) in out.iter_mut().zip(&self.layout.position).enumerate() {
            *o = self.h.diagonal(p) - if self.has_s { self.diag_s[i] } else { 0.0 };
        }
    }

    fn model(&self, newton: bool) -> &BandedSym {
        match (&self.jtj, self.has_s && !newton) {
            (Some(jtj), true) => jtj,
            _ => &self.h,
        }
    }

    /// `step` holds $-g$ on entry and $\delta$ on success.
    fn damped_step(&mut self, newton: bool, total: f64, scale: &[f64], step: &mut [f64]) -> bool {
        let Some(mut work) = self.work.take() else {
            return false;
        };
        work.copy_from(self.model(newton));
        let pos = &self.layout.position;
        for ((&p, &d), &g) in pos.iter().zip(scale).zip(step.iter()) {
            self.rhs[p] = g;
            self.product[p] = total * d;
        }
        work.add_to_diagonal(&self.product);
        match work.cholesky_in_place() {
            Ok(chol) => {
                chol.solve_in_place(&mut self.rhs);
                for (d, &p) in step.iter_mut().zip(pos) {
                    *d = self.rhs[p];
                }
                self.work = Some(chol.into_inner());
                true
            }
            Err(work) => {
                self.work = Some(work);
                false
            }
        }
    }

    fn model_mul(&mut self, newton: bool, step: &[f64], out: &mut [f64]) {
        let pos = &self.layout.position;
        for (&d, &p) in step.iter().zip(pos) {
            self.rhs[p] = d;
        }
        let model = match (&self.jtj, self.has_s && !newton) {
            (Some(jtj), true) => jtj,
            _ => &self.h,
        };
        model.mul_vec(&self.rhs, &mut self.product);
        for (o, &p) in out.iter_mut().zip(pos) {
            *o = self.product[p];
        }
    }
}

/// The band form on two threads ([`crate::split`]): part 0 here, part 1
/// on the helper; only the gradient, the diagonals, the Schur blocks on
/// the overlap $S$ and the step's pieces cross threads.
struct SplitSystem {
    layout: Arc<BandLayout>,
    second_order: bool,
    mine: SplitPart,
    helpers: Helpers,
    /// The diagonal of $H$ (global positions) and of $S$ (parameter order).
    diagonal: Vec<f64>,
    diag_s: Vec<f64>,
    has_s: bool,
    jtj_current: bool,
    /// The overlap $S = [s_0, s_1)$ of the last assembly.
    split: (usize, usize),
    /// The damping and the right-hand side per global position.
    damp: Vec<f64>,
    rhs: Vec<f64>,
    /// The last step (global positions) and the model matrix times it,
    /// from the back substitution, with the model it used.
    step: Vec<f64>,
    product: Vec<f64>,
    product_of: Option<(bool, Vec<f64>)>,
    /// Set by the first part whose elimination fails, to stop the other.
    abort: Arc<AtomicBool>,
}

impl SplitSystem {
    fn new(layout: BandLayout, second_order: bool, helpers: Helpers) -> Self {
        let n = layout.position.len();
        Self {
            mine: SplitPart::new(0, &layout),
            layout: Arc::new(layout),
            second_order,
            helpers,
            diagonal: vec![0.0; n],
            diag_s: vec![0.0; n],
            has_s: false,
            jtj_current: false,
            split: (0, 0),
            damp: vec![0.0; n],
            rhs: vec![0.0; n],
            step: vec![0.0; n],
            product: vec![0.0; n],
            product_of: None,
            abort: Arc::new(AtomicBool::new(false)),
        }
    }

    fn helper_lost() -> TrajoptError {
        TrajoptError::InvalidParameter {
            name: "helper thread",
            reason: "it stopped (the problem panicked on it)".into(),
        }
    }

    /// Both parts at `theta`; see [`System::assemble`].
    fn assemble<P: LeastSquaresProblem + ?Sized>(
        &mut self,
        problem: &P,
        theta: &[f64],
        r: &[f64],
        grad: &mut [f64],
        want_s: bool,
    ) -> Result<Option<bool>> {
        self.product_of = None;
        self.jtj_current = false;
        let mut want = self.second_order && want_s;
        let (finite, theirs) = loop {
            let job = SplitJob::Assemble {
                layout: Arc::clone(&self.layout),
                theta: theta.to_vec(),
                r: r.to_vec(),
                want_s: want,
            };
            let sent = self.helpers.split_send(job);
            let mine = self.mine.assemble(problem, theta, r, want);
            let Some(SplitDone::Assembled {
                result,
                finite,
                grad,
                diag_s,
                diagonal,
                extent,
            }) = sent.then(|| self.helpers.split_receive()).flatten()
            else {
                return Err(Self::helper_lost());
            };
            let (mine, theirs) = (mine?, result?);
            // S from one part only: both without it
            if want && mine != theirs {
                want = false;
                continue;
            }
            self.has_s = mine && theirs;
            break (self.mine.finite() && finite, (grad, diag_s, diagonal, extent));
        };
        let (mut their_grad, their_diag_s, mut their_diagonal, mut their_extent) = theirs;
        if !finite {
            // a non-finite S only rules out Newton steps
            if !self.has_s {
                return Ok(None);
            }
            let sent = self.helpers.split_send(SplitJob::ReplaceByJtj {
                theta: theta.to_vec(),
                r: r.to_vec(),
            });
            let mine = self.mine.replace_by_jtj(problem, theta, r);
            let Some(SplitDone::Replaced {
                result,
                grad,
                diagonal,
                extent,
            }) = sent.then(|| self.helpers.split_receive()).flatten()
            else {
                return Err(Self::helper_lost());
            };
            if !(mine? && result?) {
                return Ok(None);
            }
            (their_grad, their_diagonal, their_extent) = (grad, diagonal, extent);
            self.has_s = false;
        }
        for ((g, a), b) in grad.iter_mut().zip(&self.mine.grad).zip(&their_grad) {
            *g = a + b;
        }
        if self.has_s {
            for ((d, a), b) in self.diag_s.iter_mut().zip(&self.mine.diag_s).zip(&their_diag_s) {
                *d = a + b;
            }
        }
        self.diagonal.copy_from_slice(&their_diagonal);
        self.mine.add_diagonal(&mut self.diagonal);
        self.split = split_points(self.diagonal.len(), self.mine.extent(), their_extent);
        Ok(Some(self.has_s))
    }

    fn jtj_diagonal(&self, out: &mut [f64]) {
        for (i, (o, &p)) in out.iter_mut().zip(&self.layout.position).enumerate() {
            *o = self.diagonal[p] - if self.has_s { self.diag_s[i] } else { 0.0 };
        }
    }

    fn ensure_gauss_newton<P: LeastSquaresProblem + ?Sized>(
        &mut self,
        problem: &P,
        theta: &[f64],
        r: &[f64],
    ) -> Result<bool> {
        if !self.has_s || self.jtj_current {
            return Ok(true);
        }
        let sent = self.helpers.split_send(SplitJob::GaussNewton {
            theta: theta.to_vec(),
            r: r.to_vec(),
        });
        let mine = self.mine.ensure_gauss_newton(problem, theta, r);
        let Some(SplitDone::GaussNewton(theirs)) = sent.then(|| self.helpers.split_receive()).flatten() else {
            return Err(Self::helper_lost());
        };
        let ok = mine? && theirs?;
        self.jtj_current = ok;
        Ok(ok)
    }

    /// `step` holds $-g$ on entry and $\delta$ on success; false if the
    /// damped matrix is not positive definite (or the helper is gone).
    fn damped_step(&mut self, newton: bool, total: f64, scale: &[f64], step: &mut [f64]) -> bool {
        self.product_of = None;
        let pos = &self.layout.position;
        for ((&p, &d), &g) in pos.iter().zip(scale).zip(step.iter()) {
            self.rhs[p] = g;
            self.damp[p] = total * d;
        }
        let (s0, s1) = self.split;
        let s_len = s1 - s0;
        let kd_s = self.layout.half_bandwidth.min(s_len.saturating_sub(1));
        // the helper's interior needs only its own numbers; it is idle now,
        // so the flag can be cleared for this elimination
        self.abort.store(false, Ordering::Relaxed);
        let sent = self.helpers.split_send(SplitJob::Eliminate {
            newton,
            total,
            split: self.split,
            kd_s,
            abort: Arc::clone(&self.abort),
        });
        let mine = self.mine.eliminate(
            newton,
            total,
            Some((&self.damp, &self.rhs)),
            self.split,
            kd_s,
            Some(&self.abort),
        );
        let Some(SplitDone::Eliminated(theirs)) = sent.then(|| self.helpers.split_receive()).flatten() else {
            return false;
        };
        let (Some((mut schur, mut b_s)), Some((their_schur, their_b))) = (mine, theirs) else {
            return false;
        };
        // the step on S: (C_0 + C_1 + damping) x_S = b_S
        schur.add_scaled(1.0, &their_schur);
        schur.add_to_diagonal(&self.damp[s0..s1]);
        for (b, t) in b_s.iter_mut().zip(&their_b) {
            *b += t;
        }
        match schur.cholesky_in_place() {
            Ok(chol) => chol.solve_in_place(&mut b_s),
            Err(_) => return false,
        }
        let sent = self
            .helpers
            .split_send(SplitJob::BackSubstitute { x_s: b_s.clone(), s0 });
        self.product.fill(0.0);
        self.step[s0..s1].copy_from_slice(&b_s);
        self.mine.back_substitute(&b_s, s0, &mut self.step, &mut self.product);
        let Some(SplitDone::BackSubstituted {
            step: their_step,
            product: their_product,
        }) = sent.then(|| self.helpers.split_receive()).flatten()
        else {
            return false;
        };
        // part 1's interior, and the sum of the products
        for (s, t) in self.step[s1..].iter_mut().zip(&their_step[s1..]) {
            *s = *t;
        }
        for (p, t) in self.product.iter_mut().zip(&their_product) {
            *p += t;
        }
        for (d, &p) in step.iter_mut().zip(pos) {
            *d = self.step[p];
        }
        self.product_of = Some((newton, step.to_vec()));
        true
    }

    fn model_mul(&mut self, newton: bool, step: &[f64], out: &mut [f64]) {
        let pos = &self.layout.position;
        let cached = matches!(&self.product_of, Some((nw, st)) if *nw == newton && st[..] == step[..]);
        if !cached {
            for (&d, &p) in step.iter().zip(pos) {
                self.rhs[p] = d;
            }
            let sent = self.helpers.split_send(SplitJob::Product {
                newton,
                x: self.rhs.clone(),
            });
            self.product.fill(0.0);
            self.mine.add_product(newton, &self.rhs, &mut self.product);
            match sent.then(|| self.helpers.split_receive()).flatten() {
                Some(SplitDone::Product(theirs)) => {
                    for (p, t) in self.product.iter_mut().zip(&theirs) {
                        *p += t;
                    }
                }
                // the helper is gone: no prediction (the step is then refused)
                _ => self.product.fill(f64::NAN),
            }
        }
        for (o, &p) in out.iter_mut().zip(pos) {
            *o = self.product[p];
        }
    }
}

/// The band normal equations, split over the helpers if there are any.
#[allow(clippy::too_many_arguments)]
fn band_form<P: LeastSquaresProblem + ?Sized>(
    helpers: &mut Option<Helpers>,
    problem: &P,
    theta: &[f64],
    r: &[f64],
    layout: &Arc<BandLayout>,
    h: &mut BandedSym,
    grad: &mut [f64],
    second_order: Option<&mut [f64]>,
) -> Result<bool> {
    match helpers {
        Some(helpers) => helpers.band_normal_equations(problem, theta, r, layout, h, grad, second_order),
        None => problem.band_normal_equations(theta, r, layout, h, grad, second_order),
    }
}

/// Sparse Cholesky factorisation $H = LL^\top$ of the upper triangle, its
/// symbolic part (AMD ordering, elimination tree) computed once, the
/// numerical values and the workspace reused across factorisations.
struct Factor {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
    buffer: MemBuffer,
}

impl Factor {
    fn new(h: faer::sparse::SymbolicSparseColMatRef<'_, usize>) -> Result<Self> {
        let symbolic = factorize_symbolic_cholesky(
            h,
            Side::Upper,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(alloc_error)?;
        let scratch = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        let buffer = MemBuffer::try_new(scratch).map_err(alloc_error)?;
        let values = vec![0.0; symbolic.len_val()];
        Ok(Self {
            symbolic,
            values,
            buffer,
        })
    }

    /// Factorises `h` (upper triangle) and solves $H x = $ `rhs` in place;
    /// false if `h` is not numerically positive definite.
    fn solve(&mut self, h: SparseColMatRef<'_, usize, f64>, rhs: MatMut<'_, f64>) -> bool {
        let stack = MemStack::new(&mut self.buffer);
        match self.symbolic.factorize_numeric_llt::<f64>(
            &mut self.values,
            h,
            Side::Upper,
            LltRegularization::default(),
            Par::Seq,
            stack,
            Default::default(),
        ) {
            Ok(llt) => {
                let stack = MemStack::new(&mut self.buffer);
                llt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, stack);
                true
            }
            Err(_) => false,
        }
    }
}

/// The shift of an indefinite $J^\top J + S$ (relative to $D$) starts at
/// `SHIFT_MIN`, grows by `SHIFT_INCREASE` until the factorisation succeeds,
/// and shrinks by `SHIFT_DECREASE` at each iteration (as IPOPT's inertia
/// correction); beyond `SHIFT_MAX` the Newton model is too far from convex
/// to be worth it and the iteration takes a Gauss-Newton step instead (far
/// from the solution, where the residuals' curvature is large).
///
/// After a Newton step with gain ratio $\rho$ within `ACCURATE` of 1 (the
/// trust-region rule's "very successful" $\rho > 3/4$, from both sides),
/// the shift shrinks by a further `SHIFT_DECREASE_ACCURATE`: the shifted
/// model predicted well, so a much smaller shift is likely enough at the
/// next point too, and the steps tend to the undamped Newton step and its
/// quadratic convergence sooner. If that shift is too small, it grows from
/// there by `SHIFT_INCREASE`, which mostly finds a smaller working shift
/// than the plain decrease would have tried (measured: going back to the
/// plain decrease's value after such a failure takes more iterations).
/// On the benchmark pendulum at $\lambda = 10^2$ this took the Newton mode
/// from 26-31 iterations to 17-26 at horizons 100 to 20000 (17 instead of
/// 28 at $N = 1000$), with fewer factorisations.
const SHIFT_MIN: f64 = 1e-8;
const SHIFT_INCREASE: f64 = 8.0;
const SHIFT_DECREASE: f64 = 1.0 / 3.0;
const SHIFT_DECREASE_ACCURATE: f64 = 1.0 / 100.0;
const ACCURATE: f64 = 0.25;
const SHIFT_MAX: f64 = 1e-3;

/// The widest band worth factorising as a band: beyond it the sparse
/// factorisation with a fill-reducing ordering wins.
const MAX_HALF_BANDWIDTH: usize = 96;

/// $\mu \leftarrow \max(\mu \nu, 10^{-12})$, $\nu \leftarrow 2\nu$; false once
/// the damping is hopelessly large.
fn raise_damping(mu: &mut f64, nu: &mut f64) -> bool {
    *mu = (*mu * *nu).max(1e-12);
    *nu *= 2.0;
    *mu < 1e16
}

fn sum_sq(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum()
}

fn alloc_error(e: impl std::fmt::Debug) -> TrajoptError {
    TrajoptError::InvalidParameter {
        name: "problem size",
        reason: format!("sparse structure could not be built: {e:?}"),
    }
}

/// The pattern of $[J; I]$: the problem's rows, then one row per parameter.
fn augment_with_diagonal(
    pattern: &SymbolicSparseRowMat<usize>,
    n_residuals: usize,
    n_params: usize,
) -> Result<SymbolicSparseRowMat<usize>> {
    if pattern.nrows() != n_residuals || pattern.ncols() != n_params {
        return Err(TrajoptError::DimensionMismatch {
            what: "jacobian pattern rows",
            expected: n_residuals,
            actual: pattern.nrows(),
        });
    }
    let mut row_ptr = pattern.row_ptr().to_vec();
    let mut col_idx = pattern.col_idx().to_vec();
    for j in 0..n_params {
        col_idx.push(j);
        row_ptr.push(col_idx.len());
    }
    Ok(SymbolicSparseRowMat::new_checked(
        n_residuals + n_params,
        n_params,
        row_ptr,
        None,
        col_idx,
    ))
}

/// `out` $= H d$ for a symmetric CSC matrix stored as its upper triangle.
fn sym_mat_vec(h: &SparseColMat<usize, f64>, d: &[f64], out: &mut [f64]) {
    out.fill(0.0);
    for j in 0..h.ncols() {
        let dj = d[j];
        let mut acc = 0.0;
        for (&i, &v) in h.symbolic().row_idx_of_col_raw(j).iter().zip(h.val_of_col(j)) {
            out[i] += v * dj;
            if i != j {
                acc += v * d[i];
            }
        }
        out[j] += acc;
    }
}

/// The upper triangle of the union of two square CSC patterns (sorted rows).
fn upper_union(
    a: &SymbolicSparseColMat<usize>,
    b: Option<&SymbolicSparseColMat<usize>>,
) -> SymbolicSparseColMat<usize> {
    let mut col_ptr = Vec::with_capacity(a.ncols() + 1);
    col_ptr.push(0);
    let mut row_idx = Vec::with_capacity(a.row_idx().len() / 2 + a.ncols());
    let mut column = Vec::new();
    for j in 0..a.ncols() {
        column.clear();
        column.extend(a.row_idx_of_col_raw(j).iter().filter(|&&i| i <= j));
        if let Some(b) = b {
            column.extend(b.row_idx_of_col_raw(j).iter().filter(|&&i| i <= j));
        }
        column.sort_unstable();
        column.dedup();
        row_idx.extend_from_slice(&column);
        col_ptr.push(row_idx.len());
    }
    SymbolicSparseColMat::new_checked(a.nrows(), a.ncols(), col_ptr, None, row_idx)
}

/// For each upper-triangle entry of the pattern `sub`, its index in `sub`'s
/// values and its position in the values of `upper` (an upper-triangular
/// pattern containing it).
fn positions_in(upper: &SymbolicSparseColMat<usize>, sub: &SymbolicSparseColMat<usize>) -> Vec<(usize, usize)> {
    let mut out = Vec::with_capacity(sub.row_idx().len() / 2 + sub.ncols());
    for j in 0..sub.ncols() {
        let rows = upper.row_idx_of_col_raw(j);
        let start = upper.col_ptr()[j];
        let sub_start = sub.col_ptr()[j];
        for (p, i) in sub.row_idx_of_col_raw(j).iter().enumerate() {
            if let Ok(q) = rows.binary_search(i) {
                out.push((sub_start + p, start + q));
            }
        }
    }
    out
}

/// Positions of the diagonal entries in the values of a CSC matrix.
fn diagonal_positions(h: &SymbolicSparseColMat<usize>) -> Result<Vec<usize>> {
    (0..h.ncols())
        .map(|j| {
            let rows = h.row_idx_of_col_raw(j);
            let start = h.col_ptr()[j];
            rows.iter()
                .position(|&i| i == j)
                .map(|p| start + p)
                .ok_or_else(|| TrajoptError::InvalidParameter {
                    name: "problem",
                    reason: format!("parameter {j} does not appear in any residual"),
                })
        })
        .collect()
}

/// Forms the upper triangle of $H = J^\top J$ into a fixed pattern, column by column (Gustavson):
/// $H_{:,j} = \sum_{i : J_{ij} \ne 0} J_{ij} J_{i,:}$, accumulated in a dense
/// vector that is cleared entry by entry through the pattern of $H_{:,j}$, so
/// the cost is $\sum_i \mathrm{nnz}(J_{i,:})^2$, linear in the horizon (a
/// general sparse product clears its whole accumulator per column, which is
/// quadratic in the number of parameters).
struct NormalEquations {
    /// The pattern of $J$ by columns.
    cols: SymbolicSparseColMat<usize>,
    /// Position in $J$'s rows of each entry of `cols`.
    col_to_row: Vec<usize>,
    /// The order in which the columns are formed: by their first row, so
    /// that columns sharing rows are formed together (the rows stay in
    /// cache; in the parameter order, the channels of one time step are far
    /// apart).
    order: Vec<usize>,
    /// The pattern of $H$ (column pointers and row indices).
    h_col_ptr: Vec<usize>,
    h_row_idx: Vec<usize>,
    work: Vec<f64>,
}

impl NormalEquations {
    fn new(
        rows: &SparseRowMat<usize, f64>,
        cols: SparseColMat<usize, f64>,
        h: &SymbolicSparseColMat<usize>,
    ) -> Result<Self> {
        // entries of a column are sorted by row, so walking the rows in order
        // meets each column's entries in storage order
        let mut next: Vec<usize> = cols.symbolic().col_ptr()[..cols.ncols()].to_vec();
        let row_to_col: Vec<usize> = rows
            .symbolic()
            .col_idx()
            .iter()
            .map(|&c| {
                let p = next[c];
                next[c] += 1;
                p
            })
            .collect();
        let mut col_to_row = vec![0; row_to_col.len()];
        for (q, &p) in row_to_col.iter().enumerate() {
            col_to_row[p] = q;
        }
        let work = vec![0.0; cols.ncols()];
        let cols = cols.symbolic().to_owned().map_err(alloc_error)?;
        let mut order: Vec<usize> = (0..cols.ncols()).collect();
        order.sort_by_key(|&j| cols.row_idx_of_col_raw(j).first().copied().unwrap_or(usize::MAX));
        Ok(Self {
            cols,
            col_to_row,
            order,
            h_col_ptr: h.col_ptr().to_vec(),
            h_row_idx: h.row_idx().to_vec(),
            work,
        })
    }

    fn form(&mut self, rows: &SparseRowMat<usize, f64>, h: &mut SparseColMat<usize, f64>) {
        let row_ptr = rows.symbolic().row_ptr();
        let row_cols = rows.symbolic().col_idx();
        let row_vals = rows.val();
        let (col_ptr, h_rows) = (&self.h_col_ptr, &self.h_row_idx);
        let (j_col_ptr, j_rows) = (self.cols.col_ptr(), self.cols.row_idx());
        let h_vals = h.val_mut();
        let work = &mut self.work;
        for &j in &self.order {
            let (start, end) = (j_col_ptr[j], j_col_ptr[j + 1]);
            for (&i, &q_end) in j_rows[start..end].iter().zip(&self.col_to_row[start..end]) {
                let v = row_vals[q_end];
                // the upper triangle: the row's entries up to column j
                let q = row_ptr[i];
                for (&c, &w) in row_cols[q..=q_end].iter().zip(&row_vals[q..=q_end]) {
                    work[c] += v * w;
                }
            }
            let (h_start, h_end) = (col_ptr[j], col_ptr[j + 1]);
            for (&r, hv) in h_rows[h_start..h_end].iter().zip(&mut h_vals[h_start..h_end]) {
                *hv = work[r];
                work[r] = 0.0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problems::pendulum_swingup;
    use faer::Mat;

    /// Threads without the cap, whatever the machine's cores: two (the
    /// split system) and three (three parts summed in order) reach one
    /// thread's minimum in every mode, and every run gives the same bits
    /// (without the fallback to one thread on a busy machine).
    #[test]
    fn uncapped_threads_agree_with_one() {
        let (p, theta0) = pendulum_swingup(120, 1e2).expect("problem");
        for (second_order, adaptive) in [(false, false), (true, false), (true, true)] {
            let solver = GaussNewton::new(GaussNewtonSettings {
                second_order,
                adaptive,
                one_thread_fallback: false,
                ..GaussNewtonSettings::default()
            })
            .expect("settings");
            let one = solver.solve(&p, &theta0).expect("solve");
            for threads in [2, 3] {
                let par = solver.solve_threads(&p, &theta0, threads).expect("solve");
                let again = solver.solve_threads(&p, &theta0, threads).expect("solve");
                assert!(one.status.converged() && par.status.converged());
                assert!(
                    (par.cost - one.cost).abs() <= 1e-10 * one.cost,
                    "{threads} threads: {} vs {}",
                    par.cost,
                    one.cost
                );
                // Gauss-Newton's last iterations gain ~1e-14 of the cost each,
                // so the summation order decides where it stops (at N = 120:
                // 112 iterations on one thread, 109 on two, 100 on three)
                assert!(par.iterations.abs_diff(one.iterations) <= 3.max(one.iterations / 5));
                assert_eq!(par.theta, again.theta);
            }
        }
    }

    /// A random-looking sparse symmetric pattern with its diagonal, both triangles.
    fn symmetric_pattern(n: usize, seed: usize) -> SymbolicSparseColMat<usize> {
        let mut cols = vec![vec![]; n];
        for (j, col) in cols.iter_mut().enumerate() {
            for i in 0..n {
                if i == j || (i * 7 + j * 7 + seed).is_multiple_of(5) {
                    col.push(i);
                }
            }
        }
        let mut col_ptr = vec![0];
        let mut rows = vec![];
        for c in cols {
            rows.extend(c);
            col_ptr.push(rows.len());
        }
        SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows)
    }

    #[test]
    fn upper_union_holds_both_patterns_upper_triangles_and_nothing_else() {
        let (a, b) = (symmetric_pattern(9, 0), symmetric_pattern(9, 3));
        let u = upper_union(&a, Some(&b));
        for j in 0..9 {
            for i in 0..9 {
                let expected = i <= j && (a.row_idx_of_col_raw(j).contains(&i) || b.row_idx_of_col_raw(j).contains(&i));
                assert_eq!(u.row_idx_of_col_raw(j).contains(&i), expected, "({i}, {j})");
            }
            assert!(u.row_idx_of_col_raw(j).windows(2).all(|w| w[0] < w[1]));
        }
        // positions of b's upper entries point at the same (row, column) in u
        for (p, q) in positions_in(&u, &b) {
            let j = (0..9).find(|&j| b.col_ptr()[j + 1] > p).expect("column");
            let i = b.row_idx()[p];
            assert!(i <= j);
            let k = q - u.col_ptr()[j];
            assert_eq!(u.row_idx_of_col_raw(j)[k], i);
        }
    }

    #[test]
    fn symmetric_product_from_the_upper_triangle_equals_the_dense_product() {
        let n = 9;
        let u = upper_union(&symmetric_pattern(n, 1), None);
        let vals: Vec<f64> = (0..u.row_idx().len()).map(|p| ((p * 13 % 7) as f64) - 2.5).collect();
        let h = SparseColMat::new(u, vals);
        let mut dense = Mat::<f64>::zeros(n, n);
        for j in 0..n {
            for (&i, &v) in h.symbolic().row_idx_of_col_raw(j).iter().zip(h.val_of_col(j)) {
                dense[(i, j)] = v;
                dense[(j, i)] = v;
            }
        }
        let d = Mat::from_fn(n, 1, |i, _| (i as f64 * 0.9).cos());
        let expected = &dense * &d;
        let mut got = vec![0.0; n];
        sym_mat_vec(
            &h,
            d.col(0).try_as_col_major().expect("contiguous").as_slice(),
            &mut got,
        );
        for i in 0..n {
            assert!(
                (got[i] - expected[(i, 0)]).abs() < 1e-12,
                "{} vs {}",
                got[i],
                expected[(i, 0)]
            );
        }
    }
}
