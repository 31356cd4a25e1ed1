//! [`GaussNewtonSettings`] and its choices: the [`StepModel`] and the
//! [`LinearSolver`].
//!
//! | field | default | range | meaning |
//! |---|---|---|---|
//! | `max_iterations` | 200 | any | iteration cap |
//! | `tol_grad` | 1e-10 | finite, $\ge 0$ | stop when $\lVert J^\top r \rVert_\infty \le$ `tol_grad` $\max(1, F)$ |
//! | `tol_step` | 1e-12 | finite, $\ge 0$ | stop when $\lVert \delta \rVert \le$ `tol_step` $(\lVert \theta \rVert + $ `tol_step`$)$ |
//! | `tol_cost` | 1e-14 | finite, $\ge 0$ | stop when an accepted step lowers $F$ by less than `tol_cost` $F$ |
//! | `initial_damping` | 1e-6 | finite, $\ge 0$ | $\mu_0$ (relative to $D$) |
//! | `step_model` | [`StepModel::GaussNewton`] | | which quadratic model each step minimises |
//! | `linear_solver` | [`LinearSolver::Auto`] | | the band form of the normal equations when the problem has one |
//! | `damping_scale` | [`DampingScale::Current`] | | the diagonal $D$ the damping $\mu D$ is scaled by |
//! | `step_control` | [`StepControl::Damping`] | | how the step's length is controlled: the damping rule or a trust region |
//! | `geodesic_acceleration` | false | | with the trust region, bend each step along the residuals' curvature |
//! | `one_thread_fallback` | true | | [`GaussNewton::solve_parallel`](crate::GaussNewton::solve_parallel) goes on alone when its helpers answer late |

use crate::error::{Result, TrajoptError, check_nonnegative};

/// Which quadratic model of $F$ each step of [`GaussNewton`](crate::GaussNewton)
/// minimises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum StepModel {
    /// The Gauss-Newton model $J^\top J$ (always convex; converges only
    /// linearly when the residuals stay large at the solution).
    #[default]
    GaussNewton,
    /// The Newton model $J^\top J + S$ with the problem's exact
    /// second-order term $S = \sum_i r_i \nabla^2 r_i$
    /// ([`LeastSquaresProblem::second_order`](crate::LeastSquaresProblem::second_order)):
    /// damped Newton steps, which converge quadratically on large-residual
    /// problems. Ignored with bounds, and at points where the problem
    /// cannot evaluate $S$ (a problem without [`SecondOrder`](crate::SecondOrder)
    /// takes Gauss-Newton steps).
    ///
    /// On the benchmark pendulum
    /// ([`pendulum_swingup`](crate::problems::pendulum_swingup)) with
    /// $\lambda = 10^2$ it needs 17-21 iterations instead of 101-113 at
    /// horizons 150 to 20000; but with $\lambda \ge 10^3$ (dynamics nearly
    /// enforced) it is worse: at $N = 1000$ neither mode converges within
    /// 200 iterations for $\lambda = 10^3, 10^4$ and Gauss-Newton does in
    /// 102 for $10^5$, and the Newton mode ends at a higher cost each time.
    Newton,
    /// At every iteration, the model (Gauss-Newton or Newton) whose
    /// predicted reduction for the last step was relatively closer to the
    /// actual reduction (the model switch of NL2SOL: Dennis, Gay and
    /// Welsch, ACM TOMS 7, 1981). $S$ is formed only at iterations that use
    /// it; the other model's prediction needs $\delta^\top S \delta$, from
    /// [`SecondOrder::form`](crate::SecondOrder::form)
    /// ([`Eq3Problem`](crate::Eq3Problem) evaluates it exactly, per step),
    /// or else from central differences of the residuals along the step
    /// (two residual evaluations per iteration, counted in
    /// `evals`; a probe the problem cannot evaluate leaves the
    /// choice as it was). Nothing is spent on the choice until the problem
    /// has given $S$ once.
    ///
    /// On the benchmark pendulum at $N = 1000$ it takes 44, 175 and 446
    /// iterations at $\lambda = 10^2, 10^3, 10^4$, where Gauss-Newton takes
    /// 113, 358 and 446 and the Newton mode 17, 301 and no convergence in
    /// 1000.
    Adaptive,
}

impl StepModel {
    /// Whether the model may use the second-order term $S$.
    pub fn uses_second_order(self) -> bool {
        !matches!(self, Self::GaussNewton)
    }
}

/// The diagonal $D$ of the damping term $\mu D$ of
/// [`GaussNewton`](crate::GaussNewton).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum DampingScale {
    /// $D = \operatorname{diag}(J^\top J)$ at the current point (at least
    /// $10^{-12}$). The default: the swing-up plans were measured with it
    /// (with [`RunningMax`](Self::RunningMax), fewer pure-LWR learning
    /// runs succeeded within 8 trials; see the project's issue 21 report).
    #[default]
    Current,
    /// $D_{jj}$ = the largest $(J^\top J)_{jj}$ met so far in the solve,
    /// as MINPACK's `lmder` keeps the running maximum of the column norms
    /// (Moré 1978): a parameter whose column of $J$ vanishes at the current
    /// point keeps the damping its earlier columns gave it. Needed on
    /// Penalty II (MGH 24), where the current diagonal let $\mu$ grow until
    /// the steps crawled.
    RunningMax,
    /// $D = I$: the damping (or the [trust region](StepControl::TrustRegion))
    /// in the parameters' own units, as scipy's `least_squares(method="trf")`
    /// with its default `x_scale=1`. Not invariant to rescaling the
    /// parameters, which the other two are; on badly scaled problems it
    /// needs more iterations, on others it keeps steps from following
    /// a Jacobian column that is small only at the current point.
    Identity,
}

/// How [`GaussNewton`](crate::GaussNewton) controls the length of its steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum StepControl {
    /// Levenberg-Marquardt damping $\mu D$ raised after a rejected step and
    /// lowered after an accepted one by Nielsen's rule (see the
    /// [solver's docs](crate::gauss_newton)): one factorisation per trial
    /// step, the only rule for the Newton models and for bounds, and the
    /// fast one for Eq. 3's band paths.
    #[default]
    Damping,
    /// A trust region $\lVert\delta\rVert_D \le \Delta$
    /// ($\lVert\delta\rVert_D^2 = \sum_j D_j \delta_j^2$), the step that
    /// minimises the Gauss-Newton model in it found by Moré's algorithm
    /// (MINPACK's `lmpar`: the damping $\lambda$ that puts the step on the
    /// region's boundary, to 1 %), and $\Delta$ updated from the gain ratio
    /// as in MINPACK's `lmder`. Two to a few factorisations per trial step:
    /// meant for small dense problems (curve fitting, the MGH and NIST
    /// sets), not for Eq. 3's long horizons. Needs
    /// [`StepModel::GaussNewton`] (the settings are refused otherwise),
    /// and is ignored with bounds (the damping rule is used).
    ///
    /// Use it with [`DampingScale::Identity`] (the region in the
    /// parameters' units, as scipy's `trf` and `lm` with their default
    /// `x_scale=1`): measured by `nprl-bench --solvers trust-region` (one run
    /// each), 83 of the 103 MGH instances end at the minimum with it, 79 with
    /// [`DampingScale::RunningMax`] and 71 with [`DampingScale::Current`]
    /// (whose region changes its meaning at every iteration); on NIST StRD
    /// all 54 runs reach 4 digits with `Identity` and `RunningMax`.
    TrustRegion,
}

/// How [`GaussNewton`](crate::GaussNewton) solves its linear systems.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum LinearSolver {
    /// The band form of the normal equations when the problem has one
    /// ([`LeastSquaresProblem::band_form`](crate::LeastSquaresProblem::band_form);
    /// [`Eq3Problem`](crate::Eq3Problem) does), its band is narrow and
    /// there are no bounds: the problem forms $J^\top J$ (and $S$) directly
    /// in band storage and a band Cholesky factorisation replaces the
    /// sparse one. Otherwise the general sparse path.
    #[default]
    Auto,
    /// Always the general sparse path: a sparse Jacobian, $J^\top J$ by a
    /// sparse product, a sparse Cholesky factorisation. The iterates are
    /// the band form's up to rounding.
    Sparse,
}

/// Settings of [`GaussNewton`](crate::GaussNewton); see the
/// [module docs](self) for the defaults.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct GaussNewtonSettings {
    /// Iteration cap.
    pub max_iterations: usize,
    /// Gradient tolerance, relative to $\max(1, F)$.
    pub tol_grad: f64,
    /// Step tolerance, relative to $\lVert \theta \rVert$.
    pub tol_step: f64,
    /// Relative cost-decrease tolerance.
    pub tol_cost: f64,
    /// Initial damping $\mu_0$ (0: start with pure Gauss-Newton steps).
    pub initial_damping: f64,
    /// Which model each step minimises ([`StepModel`]).
    pub step_model: StepModel,
    /// How the linear systems are solved ([`LinearSolver`]).
    pub linear_solver: LinearSolver,
    /// The diagonal the damping is scaled by ([`DampingScale`]).
    pub damping_scale: DampingScale,
    /// The damping rule or a trust region ([`StepControl`]).
    pub step_control: StepControl,
    /// With [`StepControl::TrustRegion`], bend each step along the
    /// residuals' curvature by geodesic acceleration (Transtrum and Sethna
    /// 2012): one residual evaluation and one factorisation more per trial
    /// step, steps rejected when the bend is large. Off by default; needs
    /// the trust region (refused otherwise), unused on the band forms
    /// (which hold no Jacobian) and with bounds.
    ///
    /// Measured (`nprl-bench --solvers trust-region,trust-region-geodesic`,
    /// one run): on the MGH set it ends at the minimum on 86 of 103
    /// instances instead of 83, but with about 1.7 times the evaluations
    /// (median where both solve); on NIST StRD it reaches 4 digits on 52 of
    /// 54 runs instead of 54.
    pub geodesic_acceleration: bool,
    /// Let [`GaussNewton::solve_parallel`](crate::GaussNewton::solve_parallel)
    /// go on with one thread when its helpers do not start or answer in
    /// time (a busy machine), instead of waiting for them at every
    /// hand-over. On by default; off, the result depends only on the
    /// number of threads, bit for bit, however slow the machine
    /// (reproducible runs, tests of the parallel path).
    pub one_thread_fallback: bool,
}

impl Default for GaussNewtonSettings {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            tol_grad: 1e-10,
            tol_step: 1e-12,
            tol_cost: 1e-14,
            initial_damping: 1e-6,
            step_model: StepModel::GaussNewton,
            linear_solver: LinearSolver::Auto,
            damping_scale: DampingScale::Current,
            step_control: StepControl::Damping,
            geodesic_acceleration: false,
            one_thread_fallback: true,
        }
    }
}

impl GaussNewtonSettings {
    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        check_nonnegative([
            ("tol_grad", self.tol_grad),
            ("tol_step", self.tol_step),
            ("tol_cost", self.tol_cost),
            ("initial_damping", self.initial_damping),
        ])?;
        if self.geodesic_acceleration && self.step_control != StepControl::TrustRegion {
            return Err(TrajoptError::InvalidParameter {
                name: "geodesic_acceleration",
                reason: "geodesic acceleration needs step_control StepControl::TrustRegion".into(),
            });
        }
        if self.step_control == StepControl::TrustRegion && self.step_model != StepModel::GaussNewton {
            return Err(TrajoptError::InvalidParameter {
                name: "step_control",
                reason: format!(
                    "the trust region takes Gauss-Newton steps; step_model {:?} needs StepControl::Damping",
                    self.step_model
                ),
            });
        }
        Ok(())
    }

    /// Whether the steps are trust-region steps.
    pub(crate) fn trust_region(&self) -> bool {
        self.step_control == StepControl::TrustRegion
    }

    /// Whether the steps may use the second-order term.
    pub(crate) fn second_order(&self) -> bool {
        self.step_model.uses_second_order()
    }

    /// Whether the iterations choose between the two models.
    pub(crate) fn adaptive(&self) -> bool {
        self.step_model == StepModel::Adaptive
    }

    /// Whether the band form may be used.
    pub(crate) fn band(&self) -> bool {
        self.linear_solver == LinearSolver::Auto
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_gauss_newton_on_the_band_form() {
        let s = GaussNewtonSettings::default();
        assert!(!s.second_order() && !s.adaptive() && s.band());
        assert_eq!(s.max_iterations, 200);
        s.validate().expect("defaults are valid");
    }

    #[test]
    fn the_step_models_map_to_the_old_switches() {
        let with = |step_model| GaussNewtonSettings {
            step_model,
            ..GaussNewtonSettings::default()
        };
        assert!(with(StepModel::Newton).second_order() && !with(StepModel::Newton).adaptive());
        assert!(with(StepModel::Adaptive).second_order() && with(StepModel::Adaptive).adaptive());
        let sparse = GaussNewtonSettings {
            linear_solver: LinearSolver::Sparse,
            ..GaussNewtonSettings::default()
        };
        assert!(!sparse.band());
    }

    #[test]
    fn validate_names_the_bad_field() {
        for field in ["tol_grad", "tol_step", "tol_cost", "initial_damping"] {
            let mut s = GaussNewtonSettings::default();
            match field {
                "tol_grad" => s.tol_grad = f64::NAN,
                "tol_step" => s.tol_step = -1.0,
                "tol_cost" => s.tol_cost = f64::INFINITY,
                _ => s.initial_damping = -1e-3,
            }
            match s.validate() {
                Err(TrajoptError::InvalidParameter { name, .. }) => assert_eq!(name, field),
                other => panic!("{field}: {other:?}"),
            }
        }
    }

    #[test]
    fn the_trust_region_refuses_the_newton_models() {
        for step_model in [StepModel::Newton, StepModel::Adaptive] {
            let s = GaussNewtonSettings {
                step_model,
                step_control: StepControl::TrustRegion,
                ..GaussNewtonSettings::default()
            };
            match s.validate() {
                Err(TrajoptError::InvalidParameter { name, .. }) => assert_eq!(name, "step_control"),
                other => panic!("{step_model:?}: {other:?}"),
            }
        }
        let s = GaussNewtonSettings {
            step_control: StepControl::TrustRegion,
            ..GaussNewtonSettings::default()
        };
        assert!(s.validate().is_ok() && s.trust_region());
        let geodesic_alone = GaussNewtonSettings {
            geodesic_acceleration: true,
            ..GaussNewtonSettings::default()
        };
        match geodesic_alone.validate() {
            Err(TrajoptError::InvalidParameter { name, .. }) => assert_eq!(name, "geodesic_acceleration"),
            other => panic!("{other:?}"),
        }
    }
}
