//! The front door for a user's own nonlinear least-squares problem: a
//! residual closure and a start, the Jacobian optional.
//!
//! $$\min_x F(x) = \lVert r(x) \rVert^2, \qquad r : \mathbb R^n \to \mathbb R^m$$
//!
//! [`LeastSquares`] wraps the closure $r$ (and, if given, the dense
//! Jacobian $J = \partial r / \partial x$) as a [`LeastSquaresProblem`] of
//! dense pattern and solves it with damped Gauss-Newton (Levenberg-Marquardt,
//! [`GaussNewton`]), the Jacobian differenced (central by default, scipy's
//! steps) when it is not given; with a sparsity pattern (declared, or
//! found by probing) the differences move a group of structurally
//! orthogonal columns at once (Curtis, Powell and Reid), so a large sparse
//! problem costs a few residual evaluations per Jacobian. The result,
//! [`LeastSquaresFit`], holds the point, the residuals and the Jacobian
//! there, and gives the estimate's covariance
//! $\hat\sigma^2 (J^\top J)^{-1}$, $\hat\sigma^2 = F / (m - n)$, and its
//! standard errors, as NIST's certified values and scipy's `curve_fit`
//! define them.
//!
//! | setting | default | meaning |
//! |---|---|---|
//! | [`jacobian`](LeastSquares::jacobian) | none: differenced | $J$, $m \times n$ row-major |
//! | [`difference`](LeastSquares::difference) | [`Difference::Central`] | the differences without a Jacobian |
//! | [`method`](LeastSquares::method) | [`Method::GaussNewton`] | the solver: Gauss-Newton / Levenberg-Marquardt, the derivative-free mode, or Powell |
//! | [`settings`](LeastSquares::settings) | [`GaussNewtonSettings::default`] | iterations and tolerances (Gauss-Newton and the derivative-free mode; its `step_model` chooses the Newton modes) |
//! | [`powell_settings`](LeastSquares::powell_settings) | [`PowellSettings::default`] | Powell's tolerances and budget |
//! | [`loss`](LeastSquares::loss) | [`Loss::Linear`], scale 1 | a robust loss and its residual scale |
//! | [`bounds`](LeastSquares::bounds) | none | box bounds $l \le x \le u$ |
//! | [`pattern`](LeastSquares::pattern), [`detect_pattern`](LeastSquares::detect_pattern) | dense | the Jacobian's sparsity, declared or found by probing: the differences then take one residual evaluation per Curtis-Powell-Reid group of columns (forward), not per column |
//!
//! # Example
//!
//! NIST's Misra1a, $y = b_1 (1 - e^{-b_2 x})$, from its first start:
//!
//! ```
//! let x = [77.6, 114.9, 141.1, 190.8, 239.9, 289.0, 332.8, 378.4, 434.8, 477.3, 536.8, 593.1, 689.1, 760.0];
//! let y = [10.07, 14.73, 17.94, 23.93, 29.61, 35.18, 40.02, 44.82, 50.76, 55.05, 61.01, 66.40, 75.47, 81.78];
//! let fit = trajopt::LeastSquares::new(x.len(), |b: &[f64], r: &mut [f64]| {
//!     for i in 0..x.len() {
//!         r[i] = y[i] - b[0] * (1.0 - (-b[1] * x[i]).exp());
//!     }
//! })
//! .solve(&[500.0, 1e-4])?;
//! let se = fit.standard_errors()?;
//! assert!(fit.status.is_converged());
//! assert!((fit.x[0] / 2.3894212918e2 - 1.0).abs() < 1e-6); // NIST's certified b1
//! assert!((se[0] / 2.7070075241 - 1.0).abs() < 1e-3); // and its standard error
//! # Ok::<(), trajopt::TrajoptError>(())
//! ```

use faer::sparse::SymbolicSparseRowMat;

use crate::derivative_free::{DerivativeFree, DerivativeFreeSettings, Difference};
use crate::error::{Result, TrajoptError};
use crate::gauss_newton::{GaussNewton, GaussNewtonSettings, GaussNewtonStatus};
use crate::least_squares::{LeastSquaresProblem, LinearBounds};
use crate::powell::{Powell, PowellSettings, PowellStatus};

mod loss;
mod problem;
mod result;

pub use loss::Loss;
use problem::Closures;
pub use problem::dense_pattern;
pub use result::LeastSquaresFit;

/// A closure writing $m$ values for a point (residuals, or a Jacobian's
/// $m n$ entries row-major).
type Closure<'a> = Box<dyn Fn(&[f64], &mut [f64]) + 'a>;

/// Which solver [`LeastSquares::solve`] runs: every least-squares mode
/// of the crate, one setting away.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum Method {
    /// Damped Gauss-Newton / Levenberg-Marquardt ([`GaussNewton`]) on the
    /// Jacobian given or differenced; [`GaussNewtonSettings::step_model`]
    /// chooses its Newton and adaptive modes.
    #[default]
    GaussNewton,
    /// The derivative-free least-squares mode ([`DerivativeFree`]): the
    /// same steps on a Jacobian it differences itself, with its own
    /// stationarity test and a budget of residual evaluations. It
    /// differences the loss-transformed residuals, which stalls with a
    /// robust [`Loss`], so it is refused with one (the default method,
    /// without a Jacobian, differences the raw residuals and is the
    /// derivative-free choice there).
    DerivativeFree,
    /// Powell's conjugate-direction method ([`Powell`]) on the cost, with
    /// the bounds kept by its line searches (no QP); no derivative of any
    /// kind.
    Powell,
}

/// Why a [`LeastSquares`] solve stopped: the status of the [`Method`]'s
/// solver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum FitStatus {
    /// [`Method::GaussNewton`] and [`Method::DerivativeFree`].
    GaussNewton(GaussNewtonStatus),
    /// [`Method::Powell`].
    Powell(PowellStatus),
}

impl FitStatus {
    /// Whether the solver's convergence test passed.
    pub fn is_converged(self) -> bool {
        match self {
            Self::GaussNewton(s) => s.is_converged(),
            Self::Powell(s) => s.is_converged(),
        }
    }
}

/// The solver's status's name (`ConvergedCost`).
impl std::fmt::Display for FitStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::GaussNewton(s) => s.fmt(f),
            Self::Powell(s) => s.fmt(f),
        }
    }
}

impl solve::Status for FitStatus {
    fn termination(&self) -> solve::Termination {
        match self {
            Self::GaussNewton(s) => s.termination(),
            Self::Powell(s) => s.termination(),
        }
    }
}

/// A nonlinear least-squares problem given by closures, and how to solve
/// it (see the [module docs](self)).
pub struct LeastSquares<'a> {
    m: usize,
    residuals: Closure<'a>,
    jacobian: Option<Closure<'a>>,
    difference: Difference,
    settings: GaussNewtonSettings,
    method: Method,
    powell: PowellSettings,
    loss: Loss,
    scale: f64,
    bounds: Option<(Vec<f64>, Vec<f64>)>,
    sparsity: Sparsity,
}

/// Where the Jacobian's pattern comes from.
#[derive(Debug, Clone)]
enum Sparsity {
    Dense,
    Declared(SymbolicSparseRowMat<usize>),
    Detect,
}

impl std::fmt::Debug for LeastSquares<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LeastSquares")
            .field("m", &self.m)
            .field("jacobian", &self.jacobian.is_some())
            .field("difference", &self.difference)
            .field("settings", &self.settings)
            .field("method", &self.method)
            .field("powell", &self.powell)
            .field("loss", &self.loss)
            .field("scale", &self.scale)
            .field("bounds", &self.bounds)
            .field("sparsity", &self.sparsity)
            .finish()
    }
}

impl<'a> LeastSquares<'a> {
    /// The problem of the `m` residuals that `residuals(x, r)` writes into
    /// `r` (of length `m`) at the point `x`; its size $n$ is the start's.
    pub fn new(m: usize, residuals: impl Fn(&[f64], &mut [f64]) + 'a) -> Self {
        Self {
            m,
            residuals: Box::new(residuals),
            jacobian: None,
            difference: Difference::Central,
            settings: GaussNewtonSettings::default(),
            method: Method::GaussNewton,
            powell: PowellSettings::default(),
            loss: Loss::Linear,
            scale: 1.0,
            bounds: None,
            sparsity: Sparsity::Dense,
        }
    }

    /// The Jacobian: `jacobian(x, j)` writes $\partial r_i / \partial x_k$
    /// into `j[i * n + k]` ($m \times n$, row-major). Without it the
    /// Jacobian is differenced.
    pub fn jacobian(mut self, jacobian: impl Fn(&[f64], &mut [f64]) + 'a) -> Self {
        self.jacobian = Some(Box::new(jacobian));
        self
    }

    /// The differences used without a Jacobian (central by default: two
    /// residual evaluations per parameter, errors $O(h^2)$).
    pub fn difference(mut self, difference: Difference) -> Self {
        self.difference = difference;
        self
    }

    /// The iteration's settings ([`GaussNewtonSettings`]).
    pub fn settings(mut self, settings: GaussNewtonSettings) -> Self {
        self.settings = settings;
        self
    }

    /// The solver ([`Method`]; Gauss-Newton / Levenberg-Marquardt by
    /// default).
    pub fn method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }

    /// Powell's settings, for [`Method::Powell`] (its `bounds` are the
    /// problem's, from [`bounds`](Self::bounds)).
    pub fn powell_settings(mut self, settings: PowellSettings) -> Self {
        self.powell = settings;
        self
    }

    /// A robust loss ([`Loss`]) with the residual scale $C$ at which it
    /// departs from the squared loss (scipy's `f_scale`).
    pub fn loss(mut self, loss: Loss, scale: f64) -> Self {
        self.loss = loss;
        self.scale = scale;
        self
    }

    /// Box bounds $l_k \le x_k \le u_k$ (infinite for none), kept by each
    /// step of the iteration, with no QP solver (Gauss-Newton and the
    /// derivative-free mode: projected Newton steps on the damped model,
    /// [`crate::gauss_newton`]; Powell: by its line searches); the start
    /// must lie within them.
    pub fn bounds(mut self, lower: &[f64], upper: &[f64]) -> Self {
        self.bounds = Some((lower.to_vec(), upper.to_vec()));
        self
    }

    /// The Jacobian's sparsity pattern ($m \times n$, row-major): which
    /// $\partial r_i / \partial x_k$ can be nonzero. Without a Jacobian,
    /// the differences then perturb a whole Curtis-Powell-Reid group of
    /// structurally orthogonal columns at once ([`ColumnGroups`](crate::derivative_free::ColumnGroups)): one
    /// residual evaluation per group (forward; two, central) instead of
    /// one per parameter. With a Jacobian, only its entries in the pattern
    /// are read. The pattern must not leave out an entry that can be
    /// nonzero.
    pub fn pattern(mut self, pattern: SymbolicSparseRowMat<usize>) -> Self {
        self.sparsity = Sparsity::Declared(pattern);
        self
    }

    /// Finds the pattern by probing, before the solve: each parameter is
    /// moved alone at the start and at a second point near it, and the
    /// residuals that change are marked ($2(n + 1)$ residual evaluations,
    /// counted in [`LeastSquaresFit::evals`]); then as
    /// [`pattern`](Self::pattern). An entry that happens to vanish at both
    /// points is missed: declare the pattern where it is known.
    pub fn detect_pattern(mut self) -> Self {
        self.sparsity = Sparsity::Detect;
        self
    }

    /// Checks the sizes, the loss scale and the bounds against `x0`;
    /// returns the bounds as [`LinearBounds`] (a row per bounded
    /// coordinate).
    fn check(&self, x0: &[f64]) -> Result<Option<LinearBounds>> {
        let (m, n) = (self.m, x0.len());
        let invalid = |name, reason: String| Err(TrajoptError::InvalidParameter { name, reason });
        if m == 0 || n == 0 {
            return invalid(
                "problem size",
                format!("need at least one residual and one parameter, got m = {m}, n = {n}"),
            );
        }
        if !(self.scale > 0.0 && self.scale.is_finite()) {
            return invalid("loss scale", format!("must be finite and positive, got {}", self.scale));
        }
        let Some((lower, upper)) = &self.bounds else {
            return Ok(None);
        };
        if lower.len() != n || upper.len() != n {
            return Err(TrajoptError::DimensionMismatch {
                what: "bounds",
                expected: n,
                actual: if lower.len() == n { upper.len() } else { lower.len() },
            });
        }
        for k in 0..n {
            if lower[k].is_nan() || upper[k].is_nan() || lower[k] >= upper[k] {
                return invalid(
                    "bounds",
                    format!("need lower < upper, got [{}, {}] for x[{k}]", lower[k], upper[k]),
                );
            }
            if !(lower[k] <= x0[k] && x0[k] <= upper[k]) {
                return invalid(
                    "start",
                    format!("x0[{k}] = {} is outside its bounds [{}, {}]", x0[k], lower[k], upper[k]),
                );
            }
        }
        let rows: Vec<usize> = (0..n)
            .filter(|&k| lower[k].is_finite() || upper[k].is_finite())
            .collect();
        let triplets: Vec<faer::sparse::Triplet<usize, usize, f64>> = rows
            .iter()
            .enumerate()
            .map(|(i, &k)| faer::sparse::Triplet::new(i, k, 1.0))
            .collect();
        let a = faer::sparse::SparseRowMat::try_new_from_triplets(rows.len(), n, &triplets).map_err(|e| {
            TrajoptError::InvalidParameter {
                name: "bounds",
                reason: format!("{e:?}"),
            }
        })?;
        let bounds = LinearBounds {
            a,
            lower: rows.iter().map(|&k| lower[k]).collect(),
            upper: rows.iter().map(|&k| upper[k]).collect(),
        };
        bounds.validate()?;
        Ok(Some(bounds))
    }

    /// Solves from `x0`.
    ///
    /// # Errors
    /// No residuals or no parameters, a scale that is not positive, bounds
    /// of the wrong size or empty, a start outside them, invalid settings,
    /// or residuals that are not finite at `x0` (a failure later is a
    /// status, not an error).
    pub fn solve(&self, x0: &[f64]) -> Result<LeastSquaresFit> {
        let bounds = self.check(x0)?;
        let m = self.m;
        let problem = Closures::new(self, x0, bounds)?;
        let (x, initial_cost, status, iterations, solve_time) = match self.method {
            Method::GaussNewton => {
                let r = GaussNewton::new(self.settings.clone())?.solve(&problem, x0)?;
                let status = FitStatus::GaussNewton(r.status);
                (r.x, r.initial_cost, status, r.iterations, r.solve_time)
            }
            Method::DerivativeFree => {
                if self.loss != Loss::Linear {
                    return Err(TrajoptError::InvalidParameter {
                        name: "method",
                        reason: "the derivative-free mode differences the loss-transformed residuals and stalls \
                                 with a robust loss; use Method::GaussNewton without a Jacobian, which differences \
                                 the raw residuals"
                            .into(),
                    });
                }
                let settings = DerivativeFreeSettings {
                    gauss_newton: self.settings.clone(),
                    difference: self.difference,
                    ..DerivativeFreeSettings::default()
                };
                let r = DerivativeFree::new(settings)?.solve(&problem, x0)?;
                let status = FitStatus::GaussNewton(r.status);
                (r.x, r.initial_cost, status, r.iterations, r.solve_time)
            }
            Method::Powell => {
                let settings = PowellSettings {
                    bounds: self.bounds.clone(),
                    ..self.powell.clone()
                };
                let mut r_buf = vec![0.0; m];
                let cost = std::cell::RefCell::new(&mut r_buf);
                let objective = |x: &[f64]| -> Result<f64> {
                    let mut r = cost.borrow_mut();
                    problem.residuals(x, &mut r)?;
                    Ok(r.iter().map(|v| v * v).sum())
                };
                let r = Powell::new(settings)?.solve(&objective, x0)?;
                let status = FitStatus::Powell(r.status);
                (r.x, r.initial_cost, status, r.iterations, r.solve_time)
            }
        };
        let mut residuals = vec![0.0; m];
        problem.raw_residuals(&x, &mut residuals);
        let (cost, weights): (f64, Vec<f64>) = {
            let t: Vec<(f64, f64)> = residuals.iter().map(|&r| self.loss.transform(r, self.scale)).collect();
            (
                t.iter().map(|(rt, _)| rt * rt).sum(),
                t.iter().map(|&(_, w)| w).collect(),
            )
        };
        let jacobian = problem.outer_jacobian(&x);
        // the user's calls, counted where they are made (the solvers count
        // their requests, some of which the last residuals or Jacobian
        // answer): the answer's residuals and Jacobian included
        let evals = problem.residual_calls.get();
        let jacobian_evals = problem.jacobian_calls.get();
        Ok(LeastSquaresFit {
            x,
            cost,
            initial_cost,
            status,
            iterations,
            evals,
            jacobian_evals,
            solve_time,
            residuals,
            jacobian,
            weights,
        })
    }
}

#[cfg(test)]
// indices over the parallel arrays of the data read as the model's formula
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    /// NIST StRD Misra1a: data and certified values (bench/data/nist/Misra1a.dat).
    const X: [f64; 14] = [
        77.6, 114.9, 141.1, 190.8, 239.9, 289.0, 332.8, 378.4, 434.8, 477.3, 536.8, 593.1, 689.1, 760.0,
    ];
    const Y: [f64; 14] = [
        10.07, 14.73, 17.94, 23.93, 29.61, 35.18, 40.02, 44.82, 50.76, 55.05, 61.01, 66.40, 75.47, 81.78,
    ];
    const B: [f64; 2] = [2.3894212918e2, 5.5015643181e-4];
    const SE: [f64; 2] = [2.7070075241, 7.2668688436e-6];
    const RSS: f64 = 1.2455138894e-1;

    /// Log relative error: the digits of `got` that agree with `want`.
    fn lre(got: f64, want: f64) -> f64 {
        -((got - want).abs() / want.abs()).log10()
    }

    fn misra1a<'a>() -> LeastSquares<'a> {
        LeastSquares::new(X.len(), |b: &[f64], r: &mut [f64]| {
            for i in 0..X.len() {
                r[i] = Y[i] - b[0] * (1.0 - (-b[1] * X[i]).exp());
            }
        })
    }

    /// `evals` and `jacobian_evals` are every call of the user's
    /// functions, those at the answer included, for every method.
    #[test]
    fn evaluation_counts_are_the_users_calls() {
        for (method, with_jacobian) in [
            (Method::GaussNewton, false),
            (Method::GaussNewton, true),
            (Method::DerivativeFree, false),
            (Method::Powell, false),
            (Method::Powell, true),
        ] {
            let (calls, jacobian_calls) = (std::cell::Cell::new(0), std::cell::Cell::new(0));
            let mut fit = LeastSquares::new(X.len(), |b: &[f64], r: &mut [f64]| {
                calls.set(calls.get() + 1);
                for i in 0..X.len() {
                    r[i] = Y[i] - b[0] * (1.0 - (-b[1] * X[i]).exp());
                }
            })
            .method(method);
            if with_jacobian {
                fit = fit.jacobian(|b: &[f64], j: &mut [f64]| {
                    jacobian_calls.set(jacobian_calls.get() + 1);
                    for i in 0..X.len() {
                        let e = (-b[1] * X[i]).exp();
                        j[2 * i] = -(1.0 - e);
                        j[2 * i + 1] = -b[0] * X[i] * e;
                    }
                });
            }
            let fit = fit.solve(&[250.0, 5e-4]).expect("solves");
            assert_eq!(fit.evals, calls.get(), "{method:?}, jacobian {with_jacobian}");
            assert_eq!(
                fit.jacobian_evals,
                jacobian_calls.get(),
                "{method:?}, jacobian {with_jacobian}"
            );
        }
    }

    /// Feature `serde`: a fit, its status and every solver's settings
    /// travel as JSON and come back equal; a unit status is its name.
    #[cfg(feature = "serde")]
    #[test]
    fn results_statuses_and_settings_round_trip_through_serde() {
        let fit = misra1a().solve(&[500.0, 1e-4]).expect("solves");
        let json = serde_json::to_string(&fit).expect("json");
        let back: LeastSquaresFit = serde_json::from_str(&json).expect("read");
        assert_eq!(
            (back.x, back.status, back.evals),
            (fit.x.clone(), fit.status, fit.evals)
        );
        assert_eq!(
            serde_json::to_value(GaussNewtonStatus::ConvergedCost).expect("json"),
            serde_json::json!("ConvergedCost")
        );
        // Display is the name serde writes, for every status
        for status in [
            GaussNewtonStatus::ConvergedGradient,
            GaussNewtonStatus::ConvergedStep,
            GaussNewtonStatus::ConvergedCost,
            GaussNewtonStatus::MaxIterations,
            GaussNewtonStatus::MaxEvaluations,
            GaussNewtonStatus::Stalled,
            GaussNewtonStatus::NumericalError,
            GaussNewtonStatus::TimeLimit,
            GaussNewtonStatus::Stopped,
        ] {
            let fit_status = FitStatus::GaussNewton(status);
            assert_eq!(
                serde_json::json!(fit_status.to_string()),
                serde_json::to_value(status).expect("json")
            );
        }
        for status in [
            PowellStatus::ConvergedCost,
            PowellStatus::ConvergedStep,
            PowellStatus::MaxIterations,
            PowellStatus::MaxEvaluations,
            PowellStatus::TimeLimit,
            PowellStatus::Stopped,
            PowellStatus::ReachedStopCost,
        ] {
            assert_eq!(
                serde_json::json!(status.to_string()),
                serde_json::to_value(status).expect("json")
            );
        }
        let gn = GaussNewtonSettings::default();
        assert_eq!(
            serde_json::from_str::<GaussNewtonSettings>(&serde_json::to_string(&gn).expect("json")).expect("read"),
            gn
        );
        let powell = PowellSettings::default();
        assert_eq!(
            serde_json::from_str::<PowellSettings>(&serde_json::to_string(&powell).expect("json")).expect("read"),
            powell
        );
        let dfo = DerivativeFreeSettings::default();
        assert_eq!(
            serde_json::from_str::<DerivativeFreeSettings>(&serde_json::to_string(&dfo).expect("json")).expect("read"),
            dfo
        );
    }

    /// Broyden's tridiagonal function (MGH 30) of `n` parameters.
    fn broyden<'a>(n: usize) -> LeastSquares<'a> {
        LeastSquares::new(n, move |x: &[f64], r: &mut [f64]| {
            for i in 0..n {
                let left = if i > 0 { x[i - 1] } else { 0.0 };
                let right = if i + 1 < n { x[i + 1] } else { 0.0 };
                r[i] = (3.0 - 2.0 * x[i]) * x[i] - left - 2.0 * right + 1.0;
            }
        })
    }

    /// The tridiagonal pattern of [`broyden`].
    fn tridiagonal(n: usize) -> SymbolicSparseRowMat<usize> {
        let mut row_ptr = vec![0];
        let mut col_idx = Vec::new();
        for i in 0..n {
            col_idx.extend(i.saturating_sub(1)..(i + 2).min(n));
            row_ptr.push(col_idx.len());
        }
        SymbolicSparseRowMat::new_checked(n, n, row_ptr, None, col_idx)
    }

    /// A sparse problem through the front door: the pattern declared or
    /// probed gives 3 groups, so each differenced Jacobian costs 3
    /// evaluations (central: 6) instead of n (2n); the same optimum as the
    /// dense differences, with or without the Jacobian, in every mode.
    #[test]
    fn a_declared_or_probed_pattern_differences_by_groups() {
        let n = 60;
        let x0 = vec![-1.0; n];
        let dense = broyden(n).solve(&x0).expect("dense");
        assert!(
            dense.status.is_converged() && dense.cost < 1e-20,
            "{:?} {}",
            dense.status,
            dense.cost
        );
        for (label, fit) in [
            (
                "declared",
                broyden(n).pattern(tridiagonal(n)).solve(&x0).expect("declared"),
            ),
            ("probed", broyden(n).detect_pattern().solve(&x0).expect("probed")),
            (
                "probed, derivative-free",
                broyden(n)
                    .detect_pattern()
                    .method(Method::DerivativeFree)
                    .solve(&x0)
                    .expect("derivative-free"),
            ),
        ] {
            assert!(
                fit.status.is_converged() && fit.cost < 1e-20,
                "{label}: {:?} {}",
                fit.status,
                fit.cost
            );
            for k in 0..n {
                assert!(
                    (fit.x[k] - dense.x[k]).abs() < 1e-8,
                    "{label}: x[{k}] {} vs {}",
                    fit.x[k],
                    dense.x[k]
                );
            }
            // 3 groups against n columns: far fewer residual evaluations,
            // the probing's 2 (n + 1) included
            let probing = if label.starts_with("probed") { 2 * (n + 1) } else { 0 };
            assert!(
                5 * (fit.evals - probing) < dense.evals,
                "{label}: {} vs dense {}",
                fit.evals,
                dense.evals
            );
        }
        // the probed pattern is the tridiagonal one: 3n - 2 entries, and the
        // Jacobian at the answer has exactly their values
        let probed = broyden(n).detect_pattern().solve(&x0).expect("probed");
        let nonzeros = probed.jacobian.iter().filter(|v| **v != 0.0).count();
        assert_eq!(nonzeros, 3 * n - 2);
        for i in 0..n {
            let want = 3.0 - 4.0 * probed.x[i];
            assert!((probed.jacobian[i * n + i] - want).abs() < 1e-6, "J[{i}][{i}]");
        }
        // with the Jacobian, only the pattern's entries are read
        let exact = broyden(n)
            .pattern(tridiagonal(n))
            .jacobian(move |x: &[f64], j: &mut [f64]| {
                j.fill(f64::NAN); // outside the pattern: never read
                for i in 0..n {
                    j[i * n + i] = 3.0 - 4.0 * x[i];
                    if i > 0 {
                        j[i * n + i - 1] = -1.0;
                    }
                    if i + 1 < n {
                        j[i * n + i + 1] = -2.0;
                    }
                }
            })
            .solve(&x0)
            .expect("exact");
        assert!(exact.status.is_converged() && exact.cost < 1e-20, "{:?}", exact.status);
        let e = broyden(n)
            .pattern(tridiagonal(n + 1))
            .solve(&x0)
            .expect_err("wrong size")
            .to_string();
        assert!(e.contains("pattern") && e.contains("61 x 61"), "{e}");
    }

    /// Every method from one setting: the derivative-free mode reaches
    /// NIST's values as Gauss-Newton does; Powell, on a problem whose
    /// parameters differ by six orders of magnitude, reaches its cost to
    /// 6 digits and the parameters to 4 from the nearer start.
    #[test]
    fn every_method_fits_misra1a() {
        for start in [[500.0, 1e-4], [250.0, 5e-4]] {
            let fit = misra1a().method(Method::DerivativeFree).solve(&start).expect("solves");
            assert!(fit.status.is_converged(), "{start:?}: {:?}", fit.status);
            assert!(matches!(fit.status, FitStatus::GaussNewton(_)));
            assert!(fit.jacobian_evals == 0 && fit.evals > 0);
            for k in 0..2 {
                assert!(lre(fit.x[k], B[k]) >= 6.0, "dfo {start:?} b{}: {}", k + 1, fit.x[k]);
            }
        }
        let powell = PowellSettings {
            tol_cost: 1e-15,
            tol_step: 1e-12,
            max_evals: Some(200_000),
            max_iterations: Some(100_000),
            ..PowellSettings::default()
        };
        let fit = misra1a()
            .method(Method::Powell)
            .powell_settings(powell)
            .solve(&[250.0, 5e-4])
            .expect("solves");
        assert!(matches!(fit.status, FitStatus::Powell(_)), "{:?}", fit.status);
        assert!(lre(fit.cost, RSS) >= 6.0, "powell: RSS {} ({:?})", fit.cost, fit.status);
        for k in 0..2 {
            assert!(lre(fit.x[k], B[k]) >= 4.0, "powell b{}: {}", k + 1, fit.x[k]);
        }
    }

    /// Powell keeps box bounds by itself (no QP): an active bound holds
    /// exactly and the free parameter is optimal given it.
    #[test]
    fn powell_keeps_bounds_without_a_qp() {
        // r = (x0 - 3, x1 - 1): the bound x0 <= 2 is active
        let fit = LeastSquares::new(2, |x: &[f64], r: &mut [f64]| {
            r[0] = x[0] - 3.0;
            r[1] = x[1] - 1.0;
        })
        .method(Method::Powell)
        .bounds(&[-5.0, -5.0], &[2.0, 5.0])
        .solve(&[0.0, 0.0])
        .expect("solves");
        assert!(fit.x[0] <= 2.0 && (fit.x[0] - 2.0).abs() < 1e-6, "{:?}", fit.x);
        assert!((fit.x[1] - 1.0).abs() < 1e-6, "{:?}", fit.x);
        assert!((fit.cost - 1.0).abs() < 1e-9);
    }

    #[test]
    fn the_derivative_free_mode_refuses_a_robust_loss() {
        let e = misra1a()
            .method(Method::DerivativeFree)
            .loss(Loss::SoftL1, 1.0)
            .solve(&[500.0, 1e-4])
            .expect_err("refused")
            .to_string();
        assert!(e.contains("method") && e.contains("robust loss"), "{e}");
    }

    /// Both NIST starts, with and without the Jacobian, and with forward
    /// differences: LRE >= 6 on the parameters and the residual sum of
    /// squares, standard errors within 1 % of the certified ones.
    #[test]
    fn misra1a_reaches_nists_certified_values() {
        let jacobian = |b: &[f64], j: &mut [f64]| {
            for i in 0..X.len() {
                let e = (-b[1] * X[i]).exp();
                j[2 * i] = -(1.0 - e);
                j[2 * i + 1] = -b[0] * X[i] * e;
            }
        };
        for start in [[500.0, 1e-4], [250.0, 5e-4]] {
            for (label, problem) in [
                ("central", misra1a()),
                ("forward", misra1a().difference(Difference::Forward)),
                ("jacobian", misra1a().jacobian(jacobian)),
            ] {
                let fit = problem.solve(&start).expect("solves");
                assert!(fit.status.is_converged(), "{label} {start:?}: {:?}", fit.status);
                for k in 0..2 {
                    assert!(lre(fit.x[k], B[k]) >= 6.0, "{label} {start:?} b{}: {}", k + 1, fit.x[k]);
                }
                assert!(lre(fit.cost, RSS) >= 6.0, "{label} {start:?}: RSS {}", fit.cost);
                let se = fit.standard_errors().expect("standard errors");
                for k in 0..2 {
                    assert!(
                        (se[k] / SE[k] - 1.0).abs() < 0.01,
                        "{label} {start:?} se{}: {}",
                        k + 1,
                        se[k]
                    );
                }
                assert_eq!(fit.jacobian_evals > 0, label == "jacobian");
            }
        }
    }

    /// A linear problem: the covariance equals $\sigma^2 (A^\top A)^{-1}$
    /// computed by hand, and the fit is the normal equations' solution.
    #[test]
    fn the_covariance_of_a_line_fit_is_the_closed_form() {
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        let y = [1.1, 2.9, 5.2, 6.8, 9.1];
        let fit = LeastSquares::new(5, |p: &[f64], r: &mut [f64]| {
            for i in 0..5 {
                r[i] = p[0] + p[1] * t[i] - y[i];
            }
        })
        .solve(&[0.0, 0.0])
        .expect("solves");
        // closed form: sums for A = [1 t]
        let (s, st, stt) = (5.0, 10.0, 30.0);
        let sy: f64 = y.iter().sum();
        let sty: f64 = t.iter().zip(&y).map(|(a, b)| a * b).sum();
        let det = s * stt - st * st;
        let slope = (s * sty - st * sy) / det;
        let intercept = (sy - slope * st) / s;
        assert!(
            (fit.x[0] - intercept).abs() < 1e-9 && (fit.x[1] - slope).abs() < 1e-9,
            "{:?}",
            fit.x
        );
        let rss: f64 = (0..5).map(|i| (intercept + slope * t[i] - y[i]).powi(2)).sum();
        let sigma2 = rss / 3.0;
        let want = [
            sigma2 * stt / det,
            -sigma2 * st / det,
            -sigma2 * st / det,
            sigma2 * s / det,
        ];
        let cov = fit.covariance().expect("covariance");
        for k in 0..4 {
            assert!(
                (cov[k] - want[k]).abs() < 1e-9 * want[k].abs().max(1e-3),
                "{cov:?} vs {want:?}"
            );
        }
    }

    /// Bad sizes are errors; a rank-deficient Jacobian has no covariance.
    #[test]
    fn bad_sizes_and_rank_deficiency_are_errors() {
        let none = LeastSquares::new(0, |_: &[f64], _: &mut [f64]| {});
        assert!(none.solve(&[1.0]).is_err());
        assert!(misra1a().solve(&[]).is_err());
        // x1 and x2 enter only as their sum
        let fit = LeastSquares::new(3, |p: &[f64], r: &mut [f64]| {
            for (i, ri) in r.iter_mut().enumerate() {
                *ri = p[0] + p[1] - i as f64;
            }
        })
        .solve(&[0.0, 0.0])
        .expect("solves");
        let e = fit.covariance().expect_err("deficient").to_string();
        assert!(e.contains("full column rank"), "{e}");
    }

    /// Each loss's $\rho'$ equals central differences of $\rho$, and the
    /// transformed residual squares to the scaled loss with the slope its
    /// differences give.
    #[test]
    fn losses_match_their_derivatives_and_transforms() {
        let losses = [Loss::Linear, Loss::SoftL1, Loss::Huber, Loss::Cauchy, Loss::Arctan];
        for loss in losses {
            for z in [0.0f64, 1e-3, 0.3, 0.999, 1.001, 2.0, 50.0] {
                let h = 1e-6 * z.max(1e-3);
                let (rho, drho) = loss.rho(z);
                if z > h {
                    let d = (loss.rho(z + h).0 - loss.rho(z - h).0) / (2.0 * h);
                    assert!(
                        (d - drho).abs() < 1e-6 * drho.abs().max(1.0),
                        "{loss:?} z {z}: {d} vs {drho}"
                    );
                }
                assert!(rho >= 0.0 && rho <= z + 1e-15, "{loss:?} z {z}: rho {rho}");
            }
            for (r, c) in [(0.0f64, 1.0f64), (0.3, 1.0), (-2.5, 1.0), (4.0, 0.5), (-1e-9, 2.0)] {
                let (rt, slope) = loss.transform(r, c);
                let rho = loss.rho((r / c) * (r / c)).0;
                assert!(
                    (rt * rt - c * c * rho).abs() < 1e-12 * (1.0 + rt * rt),
                    "{loss:?} r {r}"
                );
                let h = 1e-6;
                let d = (loss.transform(r + h, c).0 - loss.transform(r - h, c).0) / (2.0 * h);
                assert!((d - slope).abs() < 1e-5, "{loss:?} r {r} c {c}: {d} vs {slope}");
            }
        }
    }

    /// A line with two gross outliers: every robust loss lands on a
    /// stationary point of its own cost (its gradient, differenced
    /// independently, vanishes), below the cost of the plain fit's point,
    /// and nearer the true line than the plain fit; Huber with a scale
    /// past every residual is the plain fit.
    #[test]
    fn robust_losses_fit_through_outliers() {
        let t: Vec<f64> = (0..20).map(f64::from).collect();
        let mut y: Vec<f64> = t.iter().map(|t| 1.0 + 0.5 * t + 0.01 * (t * 7.3).sin()).collect();
        y[4] += 30.0;
        y[15] -= 25.0;
        let line = |loss: Loss, c: f64, start: &[f64]| {
            let (t, y) = (t.clone(), y.clone());
            LeastSquares::new(20, move |p: &[f64], r: &mut [f64]| {
                for i in 0..20 {
                    r[i] = p[0] + p[1] * t[i] - y[i];
                }
            })
            .loss(loss, c)
            .solve(start)
            .expect("solves")
        };
        let robust_cost = |loss: Loss, c: f64, p: &[f64]| -> f64 {
            (0..20)
                .map(|i| c * c * loss.rho(((p[0] + p[1] * t[i] - y[i]) / c).powi(2)).0)
                .sum()
        };
        let plain = line(Loss::Linear, 1.0, &[0.0, 0.0]);
        // each robust fit from the plain one's answer (arctan saturates: far
        // from the data every residual's pull vanishes)
        for loss in [Loss::SoftL1, Loss::Huber, Loss::Cauchy, Loss::Arctan] {
            let fit = line(loss, 1.0, &plain.x);
            assert!(fit.status.is_converged(), "{loss:?}: {:?}", fit.status);
            assert!((fit.cost - robust_cost(loss, 1.0, &fit.x)).abs() < 1e-9 * fit.cost.max(1.0));
            for k in 0..2 {
                let h = 1e-6;
                let (mut a, mut b) = (fit.x.clone(), fit.x.clone());
                a[k] += h;
                b[k] -= h;
                let g = (robust_cost(loss, 1.0, &a) - robust_cost(loss, 1.0, &b)) / (2.0 * h);
                assert!(g.abs() < 1e-6 * fit.cost.max(1.0), "{loss:?}: gradient {g} in x{k}");
            }
            assert!(fit.cost < robust_cost(loss, 1.0, &plain.x), "{loss:?}");
            assert!(
                (fit.x[1] - 0.5).abs() < (plain.x[1] - 0.5).abs(),
                "{loss:?}: {:?} vs {:?}",
                fit.x,
                plain.x
            );
            // the redescending losses ignore the outliers; the others keep
            // a bounded pull from each (soft-L1 and Huber grow like |r|)
            let tol = if matches!(loss, Loss::Cauchy | Loss::Arctan) {
                0.01
            } else {
                0.05
            };
            assert!(
                (fit.x[1] - 0.5).abs() < tol,
                "{loss:?}: {:?} (plain {:?})",
                fit.x,
                plain.x
            );
        }
        let wide = line(Loss::Huber, 1e3, &[0.0, 0.0]);
        assert!((wide.x[0] - plain.x[0]).abs() < 1e-8 && (wide.x[1] - plain.x[1]).abs() < 1e-8);
    }

    /// Bounds holding the optimum leave it (NIST's values); a bound that
    /// cuts it off is active at the answer, and the free parameter is the
    /// one-parameter fit's with the other held at its bound; one-sided
    /// bounds, the user's Jacobian and a robust loss go through the same
    /// change of variables.
    // no `bounds` feature needed: CI runs it without clarabel too
    #[test]
    fn box_bounds_keep_the_answer_inside_them() {
        let inside = misra1a()
            .bounds(&[200.0, 0.0], &[300.0, 1e-3])
            .solve(&[250.0, 5e-4])
            .expect("solves");
        assert!(
            lre(inside.x[0], B[0]) >= 6.0 && lre(inside.x[1], B[1]) >= 6.0,
            "{:?}",
            inside.x
        );
        for (lower, upper, k, bound) in [
            ([f64::NEG_INFINITY, f64::NEG_INFINITY], [230.0, f64::INFINITY], 0, 230.0),
            ([f64::NEG_INFINITY, 6e-4], [f64::INFINITY, f64::INFINITY], 1, 6e-4),
            ([100.0, 1e-5], [230.0, 1e-3], 0, 230.0),
        ] {
            let mut start = [220.0, 7e-4];
            start[k] = if k == 0 { 220.0 } else { 7e-4 };
            let fit = misra1a().bounds(&lower, &upper).solve(&start).expect("solves");
            assert!(
                (fit.x[k] / bound - 1.0).abs() < 1e-6,
                "{lower:?} {upper:?}: {:?}",
                fit.x
            );
            for j in 0..2 {
                assert!(lower[j] <= fit.x[j] && fit.x[j] <= upper[j], "{:?}", fit.x);
            }
            // the other parameter: the fit with this one held at its bound
            let free = 1 - k;
            let held = LeastSquares::new(X.len(), |p: &[f64], r: &mut [f64]| {
                let b = if k == 0 { [bound, p[0]] } else { [p[0], bound] };
                for i in 0..X.len() {
                    r[i] = Y[i] - b[0] * (1.0 - (-b[1] * X[i]).exp());
                }
            })
            .solve(&[start[free]])
            .expect("solves");
            assert!(
                lre(fit.x[free], held.x[0]) >= 5.0,
                "{lower:?} {upper:?}: {:?} ({:?}, cost {}) vs {:?} ({:?}, cost {})",
                fit.x,
                fit.status,
                fit.cost,
                held.x,
                held.status,
                held.cost
            );
        }
        let jacobian = |b: &[f64], j: &mut [f64]| {
            for i in 0..X.len() {
                let e = (-b[1] * X[i]).exp();
                j[2 * i] = -(1.0 - e);
                j[2 * i + 1] = -b[0] * X[i] * e;
            }
        };
        let by_hand = misra1a()
            .jacobian(jacobian)
            .loss(Loss::SoftL1, 0.1)
            .bounds(&[200.0, 0.0], &[300.0, 1e-3])
            .solve(&[250.0, 5e-4])
            .expect("solves");
        let differenced = misra1a()
            .loss(Loss::SoftL1, 0.1)
            .bounds(&[200.0, 0.0], &[300.0, 1e-3])
            .solve(&[250.0, 5e-4])
            .expect("solves");
        assert!(
            by_hand.status.is_converged() && differenced.status.is_converged(),
            "{:?} {:?} / {:?} {:?}",
            by_hand.status,
            by_hand.x,
            differenced.status,
            differenced.x
        );
        for k in 0..2 {
            assert!(
                lre(by_hand.x[k], differenced.x[k]) >= 5.0,
                "{:?} vs {:?}",
                by_hand.x,
                differenced.x
            );
        }
        let e = misra1a()
            .bounds(&[0.0, 0.0], &[100.0, 1.0])
            .solve(&[500.0, 1e-4])
            .expect_err("outside");
        assert!(e.to_string().contains("x0[0] = 500 is outside its bounds"), "{e}");
        let e = misra1a()
            .bounds(&[0.0], &[1.0])
            .solve(&[500.0, 1e-4])
            .expect_err("sizes");
        assert!(e.to_string().contains("bounds"), "{e}");
        assert!(misra1a().loss(Loss::Huber, 0.0).solve(&[500.0, 1e-4]).is_err());
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(32))]

        /// On random linear problems $r = A x - b$ ($m > n$) the front
        /// door, without a Jacobian, reaches the normal equations' solution
        /// solved independently (a Cholesky of $A^\top A$).
        #[test]
        fn the_front_door_reaches_the_linear_solution(
            n in 1usize..5,
            extra in 1usize..6,
            seed in proptest::prelude::any::<u64>(),
        ) {
            let m = n + extra;
            let mut state = seed | 1;
            let mut next = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state % 2001) as f64 / 1000.0 - 1.0
            };
            let a: Vec<f64> = (0..m * n).map(|e| next() + if e % (n + 1) == 0 { 2.0 } else { 0.0 }).collect();
            let b: Vec<f64> = (0..m).map(|_| next()).collect();
            let mut ata = vec![0.0; n * n];
            let mut atb = vec![0.0; n];
            for p in 0..n {
                for q in 0..n {
                    ata[p * n + q] = (0..m).map(|i| a[i * n + p] * a[i * n + q]).sum();
                }
                atb[p] = (0..m).map(|i| a[i * n + p] * b[i]).sum();
            }
            proptest::prop_assume!(solve::dense::cholesky(&mut ata, n).is_some_and(|(lo, hi)| lo > 1e-3 * hi));
            solve::dense::cholesky_solve(&ata, n, &mut atb);
            let fit = LeastSquares::new(m, |x: &[f64], r: &mut [f64]| {
                for i in 0..m {
                    r[i] = (0..n).map(|k| a[i * n + k] * x[k]).sum::<f64>() - b[i];
                }
            })
            .solve(&vec![0.0; n])
            .expect("solves");
            for k in 0..n {
                proptest::prop_assert!((fit.x[k] - atb[k]).abs() < 1e-7 * (1.0 + atb[k].abs()), "{:?} vs {:?}", fit.x, atb);
            }
        }
    }
}
