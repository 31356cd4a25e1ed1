//! Sparse Gauss-Newton / Levenberg-Marquardt for [`LeastSquaresProblem`]s.
//!
//! Minimises $F(\theta) = \lVert r(\theta) \rVert^2$. Each iteration solves
//! the damped normal equations
//! $$(J^\top J + \mu D)\,\delta = -J^\top r, \qquad D = \operatorname{diag}(\max(J^\top J, d_{\min})),$$
//! by a sparse Cholesky factorisation $LL^\top$ (faer) whose symbolic part
//! (fill-reducing ordering, elimination tree) is computed once and reused;
//! $J^\top J$ is formed by a sparse product whose pattern is also computed
//! once. With [`DampingScale::RunningMax`], $D$ is instead the running
//! maximum over the iterations of that diagonal, as MINPACK's `lmder`
//! keeps the running maximum of the column norms. The step is
//! accepted when the gain ratio
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
//! $\ell \le A(\theta + \delta) \le u$. A box on the parameters (each row
//! of $A$ one positive entry, as [`crate::LeastSquares::bounds`] and the
//! control bounds give) takes projected Newton steps (Bertsekas 1982): a
//! few factorisations in the unbounded step's sparse pattern, no QP solver,
//! and no `bounds` feature needed. Other linear bounds make the step a
//! sparse convex QP solved by clarabel's interior-point method (the
//! `bounds` feature). An infeasible start is first moved to the nearest
//! feasible point (the cost comparison starts there).
//!
//! For Eq. 3 ([`Eq3Problem`](crate::Eq3Problem)) every residual touches the
//! few coefficients whose basis functions overlap one time step, so $J^\top J$
//! is banded once the coefficients are ordered by time, and an iteration costs
//! time linear in the horizon. Such a problem can say so
//! ([`LeastSquaresProblem::band_form`]) and form its normal equations
//! itself in band storage ([`BandForm::normal_equations`](crate::BandForm::normal_equations)):
//! the solver then skips the sparse Jacobian, the sparse product and the
//! sparse factorisation, and factorises band matrices ([`crate::linalg`],
//! $O(N k^2)$ for half-bandwidth $k$, 30 for the benchmark pendulum at every
//! horizon). Without bounds this is the default ([`LinearSolver::Auto`]); the iterates are
//! those of the sparse form up to rounding. In Newton mode the band form
//! holds $J^\top J + S$; when an iteration falls back to a Gauss-Newton
//! step, $J^\top J$ is recovered as $(J^\top J + S) - S$ from the problem's
//! $S$ alone ([`BandForm::second_order_part`](crate::BandForm::second_order_part)), or formed a
//! second time if the problem does not give it.
//!
//! The settings and their defaults: [`settings`].
//!
//! With [`StepModel::Newton`], a problem that evaluates the second-order term
//! $S = \sum_i r_i \nabla^2 r_i$ ([`SecondOrder::values`](crate::SecondOrder::values))
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
//! ([`BandForm::normal_equations_part`](crate::BandForm::normal_equations_part)), one on this thread
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
//!
//! # Layout
//!
//! This file holds the solver's entry points and the set-up (the start,
//! the bounds, the back end chosen once per solve); `iteration.rs` one
//! iteration (the damped step, the gain ratio, the stopping tests, the
//! adaptive model choice) as a step function run by [`solve::drive`];
//! [`settings`] and [`result`] the public types; `damping.rs` the damping and shift rules; and
//! `normal_equations/` the three ways of forming and solving the normal
//! equations behind one trait (`sparse.rs`, `band.rs`, and `split.rs` for
//! two threads).

// the modules only Gauss-Newton uses: the band model of Eq. 3's normal
// equations, their two-thread split, the helper threads, and the bounded
// steps' QP
pub(crate) mod band_model;
pub(crate) mod box_qp;
pub(crate) mod parallel;
#[cfg(feature = "bounds")]
pub(crate) mod qp;
/// Without the `bounds` feature there is no QP solver: Gauss-Newton refuses
/// a bounded problem before its first step, so these are never reached.
#[cfg(not(feature = "bounds"))]
pub(crate) mod qp {
    use faer::sparse::SparseColMat;

    use crate::least_squares::LinearBounds;

    pub(crate) fn bounded_step(
        _: &SparseColMat<usize, f64>,
        _: &[f64],
        _: &LinearBounds,
        _: &[f64],
    ) -> Option<Vec<f64>> {
        None
    }

    pub(crate) fn projection(_: &LinearBounds, _: &[f64]) -> Option<Vec<f64>> {
        None
    }
}
mod damping;
mod geodesic;
mod iteration;
mod normal_equations;
pub mod result;
pub mod settings;
pub(crate) mod split;
mod trust_region;

use std::time::Instant;

use crate::error::{Result, TrajoptError, check_point};
use crate::gauss_newton::parallel::Helpers;
use crate::least_squares::LeastSquaresProblem;
use iteration::{Iteration, Start};
use normal_equations::{BandSystem, MAX_HALF_BANDWIDTH, NormalEquations, SparseSystem, SplitSystem, sum_sq};

pub use result::{GaussNewtonResult, GaussNewtonStatus};
use solve::{Finish as _, Watch};

/// The solver's name in [`solve::Progress`].
const NAME: &str = "gauss-newton";
pub use settings::{DampingScale, GaussNewtonSettings, LinearSolver, StepControl, StepModel};

/// Below this many parameters [`GaussNewton::solve_parallel`] runs on one
/// thread: the hand-overs cost more than the parts save. The threshold
/// lies between the benchmark pendulum at 300 steps (257 parameters,
/// slower on two threads) and at 1000 steps (812 parameters, faster);
/// `cargo bench -p nprl-trajopt --bench gauss_newton` measures both (the
/// measurement behind the choice is in the message of commit 035022b).
pub const MIN_PARALLEL_PARAMS: usize = 500;

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
        self.solve_with(problem, theta0, None, &mut Watch::new(), None)
    }

    /// [`solve`](Self::solve) under a [`Watch`]: its observers see every
    /// iteration (after the step is accepted, with the cost, the residual
    /// evaluations and the parameters) and may stop the solve
    /// ([`GaussNewtonStatus::Stopped`]); its time limit is checked at every
    /// iteration and every trial step ([`GaussNewtonStatus::TimeLimit`]).
    /// Either way the result holds the best parameters so far.
    ///
    /// ```
    /// use std::time::Duration;
    /// use solve::{Control, Progress, Watch};
    /// use trajopt::{GaussNewton, GaussNewtonSettings, GaussNewtonStatus};
    /// use trajopt::problems::pendulum_swingup;
    ///
    /// let (problem, theta0) = pendulum_swingup(100, 10.0)?;
    /// let gn = GaussNewton::new(GaussNewtonSettings::default())?;
    /// // stop after two iterations
    /// let mut two = |p: &Progress<'_>| if p.iteration >= 2 { Control::Stop } else { Control::Continue };
    /// let mut watch = Watch::new().with_time_limit(Duration::from_secs(1)).with_observer(&mut two);
    /// let r = gn.solve_watched(&problem, &theta0, &mut watch)?;
    /// assert_eq!((r.status, r.iterations), (GaussNewtonStatus::Stopped, 2));
    /// assert!(r.cost < r.initial_cost);
    /// # Ok::<(), trajopt::TrajoptError>(())
    /// ```
    pub fn solve_watched<P: LeastSquaresProblem + ?Sized>(
        &self,
        problem: &P,
        theta0: &[f64],
        watch: &mut Watch<'_>,
    ) -> Result<GaussNewtonResult> {
        self.solve_with(problem, theta0, None, watch, None)
    }

    /// [`solve`](Self::solve) with the band normal equations formed, and
    /// the residuals evaluated, on `threads` threads: this one and
    /// `threads - 1` helpers living for the solve, each doing one part
    /// ([`BandForm::normal_equations_part`](crate::BandForm::normal_equations_part),
    /// [`BandForm::residuals_part`](crate::BandForm::residuals_part)). With two threads the
    /// factorisations are split too: each thread eliminates the
    /// coefficients only its part touches (part 1 in reversed order) and
    /// this thread factorises the Schur complement on the overlap, a few
    /// dozen coefficients for Eq. 3 (the [module docs](self)); with more,
    /// the parts are added up and factorised on this thread. `threads` is capped at the cores the system reports
    /// ([`std::thread::available_parallelism`]); with one thread, or
    /// without a band form (bounds, [`LinearSolver::Sparse`], or a problem without
    /// a [`BandForm`](crate::BandForm)), it is [`solve`](Self::solve).
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
        self.solve_parallel_watched(problem, theta0, threads, &mut Watch::new())
    }

    /// [`solve_parallel`](Self::solve_parallel) under a [`Watch`], as
    /// [`solve_watched`](Self::solve_watched) (the observers are called on
    /// this thread).
    pub fn solve_parallel_watched<P: LeastSquaresProblem + Sync + ?Sized>(
        &self,
        problem: &P,
        theta0: &[f64],
        threads: usize,
        watch: &mut Watch<'_>,
    ) -> Result<GaussNewtonResult> {
        // spinning helpers beyond the cores would take turns with the solver,
        // and small problems gain less from the parts than the hand-overs cost
        let cores = std::thread::available_parallelism().map_or(1, usize::from);
        if problem.n_params() < MIN_PARALLEL_PARAMS {
            return self.solve_with(problem, theta0, None, watch, None);
        }
        self.solve_threads(problem, theta0, threads.min(cores), watch)
    }

    /// [`solve_parallel`](Self::solve_parallel) without the cap on
    /// `threads`.
    fn solve_threads<P: LeastSquaresProblem + Sync + ?Sized>(
        &self,
        problem: &P,
        theta0: &[f64],
        threads: usize,
        watch: &mut Watch<'_>,
    ) -> Result<GaussNewtonResult> {
        // only the band form is split
        if threads <= 1 || !self.settings.band() || problem.bounds().is_some() {
            return self.solve_with(problem, theta0, None, watch, None);
        }
        std::thread::scope(|scope| {
            let helpers = Helpers::spawn(scope, problem, threads - 1);
            self.solve_with(problem, theta0, Some(helpers), watch, None)
        })
    }

    fn solve_with<P: LeastSquaresProblem + ?Sized>(
        &self,
        problem: &P,
        theta0: &[f64],
        helpers: Option<Helpers>,
        watch: &mut Watch<'_>,
        evaluations: Option<&dyn EvalCount>,
    ) -> Result<GaussNewtonResult> {
        let mut run = self.start_with(problem, theta0, helpers, evaluations)?;
        let status = solve::drive(&mut run, watch)?;
        Ok(run.finish(status))
    }

    /// The solve's state before its first iteration, for a loop other
    /// than [`solve_watched`](Self::solve_watched)'s: argmin's `Executor`
    /// through `solve::argmin::Stepper` (feature `argmin`), or the
    /// caller's own, calling [`solve::Iterate::next_iter`] until it
    /// returns a status and then [`solve::Finish::finish`]. Evaluates the
    /// residuals at `theta0` (after moving it into the bounds, if any) and
    /// chooses the back end, as [`solve`](Self::solve) does; runs on one
    /// thread.
    ///
    /// ```
    /// use solve::{Finish, Iterate, Watch};
    /// use trajopt::{GaussNewton, GaussNewtonSettings};
    /// use trajopt::problems::pendulum_swingup;
    ///
    /// let (problem, theta0) = pendulum_swingup(100, 10.0)?;
    /// let gn = GaussNewton::new(GaussNewtonSettings::default())?;
    /// // a loop of one's own, printing the cost of each iteration
    /// let mut run = gn.start(&problem, &theta0)?;
    /// let watch = Watch::new();
    /// let status = loop {
    ///     if let Some(status) = run.next_iter(&watch)? {
    ///         break status;
    ///     }
    ///     let at = run.snapshot();
    ///     println!("{}: {:.3e}", at.iteration, at.cost);
    /// };
    /// let r = run.finish(status);
    /// assert!(r.status.is_converged());
    /// // the same iterates as the solver's own loop
    /// assert_eq!(r.x, gn.solve(&problem, &theta0)?.x);
    /// # Ok::<(), trajopt::TrajoptError>(())
    /// ```
    ///
    /// # Errors
    /// As [`solve`](Self::solve), for the start.
    pub fn start<'a, P: LeastSquaresProblem + ?Sized>(
        &'a self,
        problem: &'a P,
        theta0: &[f64],
    ) -> Result<GaussNewtonRun<'a, P>> {
        self.start_with(problem, theta0, None, None)
    }

    /// [`start`](Self::start) reporting `evaluations`' count to the
    /// watch instead of its own count of residual evaluations (the
    /// derivative-free mode's, whose differences it does not see).
    pub(crate) fn start_counted<'a, P: LeastSquaresProblem + ?Sized>(
        &'a self,
        problem: &'a P,
        theta0: &[f64],
        evaluations: &'a dyn EvalCount,
    ) -> Result<GaussNewtonRun<'a, P>> {
        self.start_with(problem, theta0, None, Some(evaluations))
    }

    fn start_with<'a, P: LeastSquaresProblem + ?Sized>(
        &'a self,
        problem: &'a P,
        theta0: &[f64],
        helpers: Option<Helpers>,
        evaluations: Option<&'a dyn EvalCount>,
    ) -> Result<GaussNewtonRun<'a, P>> {
        let started = Instant::now();
        let (n_p, n_r) = (problem.n_params(), problem.n_residuals());
        check_point("initial parameters", n_p, theta0)?;
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
            let box_bounds = b.as_box(n_p);
            if !cfg!(feature = "bounds") && box_bounds.is_none() {
                return Err(TrajoptError::InvalidParameter {
                    name: "bounds",
                    reason: "linear bounds other than a box on the parameters need trajopt's `bounds` feature (their \
                             QP steps are solved by clarabel)"
                        .into(),
                });
            }
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
                match &box_bounds {
                    Some((lower, upper)) => {
                        for ((t, l), u) in theta.iter_mut().zip(lower).zip(upper) {
                            *t = t.max(*l).min(*u);
                        }
                    }
                    None => {
                        let delta =
                            crate::gauss_newton::qp::projection(b, &theta).ok_or(TrajoptError::InfeasibleBounds)?;
                        for (t, d) in theta.iter_mut().zip(delta) {
                            *t += d;
                        }
                    }
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

        // the back end, chosen once: the band form (looked up here, held by
        // the system) only when it is narrow (a basis with wide supports,
        // such as a multilevel wavelet, makes it dense)
        let band = match bounds {
            None if s.band() => problem
                .band_form()
                .map(|form| (form, form.layout()))
                .filter(|(_, l)| l.half_bandwidth <= MAX_HALF_BANDWIDTH),
            _ => None,
        };
        // kept to go on with one thread when the helpers wait for cores
        let band_layout = band.clone();
        let system: Box<dyn NormalEquations<P> + '_> = match band {
            Some((form, layout)) => {
                layout.validate(n_p)?;
                match helpers {
                    Some(helpers) if helpers.count() == 1 => {
                        Box::new(SplitSystem::new(form, layout, s.second_order(), helpers))
                    }
                    helpers => Box::new(BandSystem::new(form, layout, s.second_order(), helpers)),
                }
            }
            None => Box::new(SparseSystem::new(
                problem,
                n_r,
                n_p,
                s.second_order() && bounds.is_none(),
            )?),
        };

        let iteration = Iteration::new(Start {
            problem,
            settings: s,
            band_layout,
            evaluations,
            system,
            theta,
            r,
            cost,
            residual_evals,
        });
        Ok(GaussNewtonRun {
            iteration,
            initial_cost,
            started,
        })
    }
}

/// A count of evaluations the observers see in place of Gauss-Newton's
/// own (the derivative-free mode's, the differences' included).
pub(crate) trait EvalCount {
    /// The evaluations so far.
    fn evals(&self) -> usize;
}

/// A Gauss-Newton solve between iterations ([`GaussNewton::start`]): a
/// [`solve::Iterate`] state, and a [`solve::Finish`] one whose result is
/// the [`GaussNewtonResult`] (its `solve_time` counted from the start).
pub struct GaussNewtonRun<'a, P: LeastSquaresProblem + ?Sized> {
    iteration: Iteration<'a, P>,
    initial_cost: f64,
    started: Instant,
}

impl<P: LeastSquaresProblem + ?Sized> std::fmt::Debug for GaussNewtonRun<'_, P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let it = &self.iteration;
        f.debug_struct("GaussNewtonRun")
            .field("iterations", &it.iterations)
            .field("cost", &it.cost)
            .field("initial_cost", &self.initial_cost)
            .finish_non_exhaustive()
    }
}

impl<P: LeastSquaresProblem + ?Sized> solve::Iterate for GaussNewtonRun<'_, P> {
    type Status = GaussNewtonStatus;
    type Error = TrajoptError;
    const NAME: &'static str = NAME;

    #[inline]
    fn next_iter(&mut self, watch: &Watch<'_>) -> Result<Option<GaussNewtonStatus>> {
        self.iteration.next_iter(watch)
    }

    #[inline]
    fn snapshot(&self) -> solve::Snapshot<'_> {
        self.iteration.snapshot()
    }
}

impl<P: LeastSquaresProblem + ?Sized> solve::Finish for GaussNewtonRun<'_, P> {
    type Output = GaussNewtonResult;

    fn finish(self, status: GaussNewtonStatus) -> GaussNewtonResult {
        let it = self.iteration;
        GaussNewtonResult {
            x: it.theta,
            cost: it.cost,
            initial_cost: self.initial_cost,
            status,
            iterations: it.iterations,
            evals: it.residual_evals,
            jacobian_evals: it.jacobian_evals,
            factorizations: it.factorizations,
            cost_history: it.cost_history,
            solve_time: self.started.elapsed(),
            one_thread_from: it.one_thread_from,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problems::pendulum_swingup;

    /// Without the `bounds` feature (no QP solver) a bounded problem is
    /// refused with an error naming the feature, never solved as if free;
    /// run by CI with `--no-default-features`.
    #[cfg(not(feature = "bounds"))]
    #[test]
    fn a_bounded_problem_needs_the_bounds_feature() {
        let (p, theta0) = pendulum_swingup(30, 10.0).expect("problem");
        let p = p.with_control_bounds(&[-1.0], &[1.0]).expect("bounds");
        let err = GaussNewton::new(GaussNewtonSettings::default())
            .expect("settings")
            .solve(&p, &theta0)
            .expect_err("refused");
        assert!(
            matches!(&err, TrajoptError::InvalidParameter { name: "bounds", reason } if reason.contains("`bounds` feature")),
            "{err:?}"
        );
    }

    /// Threads without the cap, whatever the machine's cores: two (the
    /// split system) and three (three parts summed in order) reach one
    /// thread's minimum in every mode, and every run gives the same bits
    /// (without the fallback to one thread on a busy machine).
    #[test]
    fn uncapped_threads_agree_with_one() {
        let (p, theta0) = pendulum_swingup(120, 1e2).expect("problem");
        for step_model in [StepModel::GaussNewton, StepModel::Newton, StepModel::Adaptive] {
            let solver = GaussNewton::new(GaussNewtonSettings {
                step_model,
                one_thread_fallback: false,
                ..GaussNewtonSettings::default()
            })
            .expect("settings");
            let one = solver.solve(&p, &theta0).expect("solve");
            for threads in [2, 3] {
                let par = solver
                    .solve_threads(&p, &theta0, threads, &mut Watch::new())
                    .expect("solve");
                let again = solver
                    .solve_threads(&p, &theta0, threads, &mut Watch::new())
                    .expect("solve");
                assert!(one.status.is_converged() && par.status.is_converged());
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
                assert_eq!(par.x, again.x);
            }
        }
    }
}
