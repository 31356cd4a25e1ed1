//! The 35 functions of J. J. Moré, B. S. Garbow, K. E. Hillstrom, "Testing
//! Unconstrained Optimization Software", *ACM Transactions on Mathematical
//! Software* 7(1), 17-41 (1981), as nonlinear least-squares problems
//! $$f(x) = \sum_{i=1}^m f_i(x)^2,$$
//! each with its residuals $f_i$, a hand-derived Jacobian, the paper's
//! starting point, and the minima the paper lists.
//!
//! [`MghProblem`] is one function at one size; it implements
//! [`LeastSquaresProblem`] (a dense Jacobian pattern) for
//! [`GaussNewton`](crate::GaussNewton), [`Objective`] for
//! [`Powell`](crate::Powell), and argmin's `CostFunction` and `Gradient`
//! (the gradient $2 J^\top f$) for argmin's solvers. [`all`] gives the 35
//! at their standard sizes, [`by_id`] and [`by_name`] one of them, and
//! [`MghProblem::with_size`] any size the paper allows. The formulas are in
//! the docs of [`MghFunction`]'s variants.
//!
//! # Example
//!
//! ```
//! use trajopt::problems::mgh;
//! use trajopt::{GaussNewton, GaussNewtonSettings, Powell, PowellSettings};
//!
//! // Helical valley: n = m = 3, f* = 0 at (1, 0, 0)
//! let problem = mgh::by_name("helical valley").expect("one of the 35");
//! let x0 = problem.start(1.0);
//! assert_eq!(problem.cost(&x0)?, 2500.0);
//!
//! let gn = GaussNewton::new(GaussNewtonSettings::default())?.solve(&problem, &x0)?;
//! assert!(gn.status.is_converged() && gn.cost < 1e-20);
//! assert!((gn.x[0] - 1.0).abs() < 1e-10 && gn.x[1].abs() < 1e-10 && gn.x[2].abs() < 1e-10);
//!
//! // Powell's method sees only the cost f(x), through `Objective`
//! let powell = Powell::new(PowellSettings::default())?.solve(&problem, &x0)?;
//! assert!(powell.status.is_converged() && powell.cost < 1e-8);
//! # Ok::<(), trajopt::TrajoptError>(())
//! ```
//!
//! # Sizes
//!
//! The paper fixes $n$ and $m$ for most functions and leaves them free for
//! the others. For those, the standard sizes here ([`MghProblem::new`],
//! [`all`]) are the first sizes of MINPACK-1's test drivers (Moré, Garbow,
//! Hillstrom, "User Guide for MINPACK-1", ANL-80-74, 1980, whose printed
//! results the tests compare with) where they test the function: Jennrich
//! and Sampson $m = 10$, Box $m = 10$, Brown and Dennis $m = 20$, Watson
//! $n = 6$, the linear functions $n = 5$, $m = 10$, and $n = 10$ for
//! Brown almost-linear, Trigonometric, the discrete boundary value and
//! integral equations and the two Broyden functions; Chebyquad
//! $n = m = 10$ (MINPACK-1 runs 8, 9 and 10). Where the paper gives $f^*$
//! for some sizes only, the standard size is one of them: Biggs EXP6
//! $m = 13$, Penalty I and II $n = 10$. The rest: Gulf $m = 99$ (the
//! paper allows up to 100, but $y_{100} = 25 = x_2^*$, where
//! $|y_i - x_2|^{x_3}$ is not twice differentiable), Extended Rosenbrock
//! and Variably dimensioned $n = 10$, Extended Powell singular $n = 12$ (a
//! multiple of 4). Other sizes: [`MghProblem::with_size`] and
//! [`MghProblem::with_n`].
//!
//! | # | function | $n$ | $m$ | $f^*$ |
//! |---|---|---|---|---|
//! | 1 | Rosenbrock | 2 | 2 | 0 |
//! | 2 | Freudenstein and Roth | 2 | 2 | 0 (local: 48.9842) |
//! | 3 | Powell badly scaled | 2 | 2 | 0 |
//! | 4 | Brown badly scaled | 2 | 3 | 0 |
//! | 5 | Beale | 2 | 3 | 0 |
//! | 6 | Jennrich and Sampson | 2 | 10 ($m \ge n$) | 124.362 |
//! | 7 | Helical valley | 3 | 3 | 0 |
//! | 8 | Bard | 3 | 15 | 8.21487e-3 (also 17.4286 at infinity) |
//! | 9 | Gaussian | 3 | 15 | 1.12793e-8 |
//! | 10 | Meyer | 3 | 16 | 87.9458 |
//! | 11 | Gulf research and development | 3 | 99 ($3 \le m \le 100$) | 0 |
//! | 12 | Box three-dimensional | 3 | 10 ($m \ge n$) | 0 |
//! | 13 | Powell singular | 4 | 4 | 0 |
//! | 14 | Wood | 4 | 6 | 0 |
//! | 15 | Kowalik and Osborne | 4 | 11 | 3.07505e-4 (also 1.02734e-3 at infinity) |
//! | 16 | Brown and Dennis | 4 | 20 ($m \ge n$) | 85822.2 |
//! | 17 | Osborne 1 | 5 | 33 | 5.46489e-5 |
//! | 18 | Biggs EXP6 | 6 | 13 ($m \ge n$) | 0 (local: 5.65565e-3) |
//! | 19 | Osborne 2 | 11 | 65 | 4.01377e-2 |
//! | 20 | Watson | 6 ($2 \le n \le 31$) | 31 | 2.28767e-3 (1.39976e-6 for $n = 9$, 4.72238e-10 for $n = 12$) |
//! | 21 | Extended Rosenbrock | 10 (even) | $n$ | 0 |
//! | 22 | Extended Powell singular | 12 (multiple of 4) | $n$ | 0 |
//! | 23 | Penalty I | 10 | $n + 1$ | 7.08765e-5 (2.24997e-5 for $n = 4$) |
//! | 24 | Penalty II | 10 | $2n$ | 2.93660e-4 (9.37629e-6 for $n = 4$) |
//! | 25 | Variably dimensioned | 10 | $n + 2$ | 0 |
//! | 26 | Trigonometric | 10 | $n$ | 0 |
//! | 27 | Brown almost-linear | 10 | $n$ | 0 (also 1 at $(0, \ldots, 0, n + 1)$) |
//! | 28 | Discrete boundary value | 10 | $n$ | 0 |
//! | 29 | Discrete integral equation | 10 | $n$ | 0 |
//! | 30 | Broyden tridiagonal | 10 | $n$ | 0 |
//! | 31 | Broyden banded | 10 | $n$ | 0 |
//! | 32 | Linear function - full rank | 5 | 10 ($m \ge n$) | $m - n$ = 5 |
//! | 33 | Linear function - rank 1 | 5 | 10 ($m \ge n$) | $\frac{m(m-1)}{2(2m+1)}$ = 2.142857... |
//! | 34 | Linear function - rank 1 with zero columns and rows | 5 | 10 ($m \ge n \ge 3$) | $\frac{m^2+3m-6}{2(2m-3)}$ = 3.647058... |
//! | 35 | Chebyquad | 10 | 10 ($m \ge n$) | 6.50395e-3 (3.51687e-3 for $n = m = 8$; 0 for $n = m \le 7$ or $9$) |
//!
//! # Minima
//!
//! [`MghProblem::known_minima`] lists what the paper says about the minima
//! at the problem's size: every listed value with its printed precision
//! ([`KnownMinimum::tolerance`]: a whole unit in the last printed digit,
//! since some values are truncated rather than rounded, e.g. Meyer's
//! 87.9458 for 87.945855...), and the minimiser where the paper gives it in
//! closed form (for a set of minimisers, one point of it). The smallest
//! listed value, $f^*$, is [`MghProblem::optimal_value`]; it is `None` at
//! sizes for which the paper gives no value (Watson with $n \ne 6, 9, 12$,
//! Penalty I and II with $n \ne 4, 10$, Jennrich and Sampson with
//! $m \ne 10$, Brown and Dennis with $m \ne 20$, Chebyquad with
//! $m \ne n$ or $n > 10$). Biggs EXP6's $f^* = 0$ at $(1, 10, 1, 5, 4, 3)$
//! (its data are exact), with the paper's $5.65565 \cdot 10^{-3}$ for
//! $m = 13$ listed as a local minimum.
//!
//! # Scaled starts
//!
//! The paper also starts from $10 x_0$ and $100 x_0$:
//! [`MghProblem::start`]`(scale)` gives them. Watson's $x_0 = 0$ scales to
//! itself; there (as MINPACK-1's test driver does) a scale other than 1
//! gives $(\text{scale}, \ldots, \text{scale})$.
//!
//! # Checks
//!
//! `tests/mgh.rs` checks every Jacobian against central differences at
//! $x_0$, $10 x_0$, $100 x_0$ and perturbed points; $f(x^*) = f^*$ and
//! $\nabla f(x^*) = 0$ where the minimiser is known; every residual at
//! $x_0$ and at a second point against an independent NumPy implementation
//! (`scripts/golden/mgh_golden.py` → `tests/data/mgh_golden.json`); the
//! norms $\lVert f(s\, x_0) \rVert$, $s = 1, 10, 100$, printed in
//! MINPACK-1's test results (Moré, Garbow, Hillstrom, ANL-80-74, 1980) for
//! 24 of the problems at one or more sizes; and which minima
//! [`GaussNewton`](crate::GaussNewton) reaches from $x_0$ (its run prints
//! the table with `--nocapture`, next to what MINPACK's `lmdif` reaches
//! through scipy, recorded in the JSON).
//!
//! # Gauss-Newton from $x_0$
//!
//! With `damping_scale: DampingScale::RunningMax` and more iterations, Gauss-Newton reaches $f^*$
//! from the standard start on 33 of the 35 problems (Brown and Dennis only
//! after thousands of iterations: its residuals stay large, so the
//! convergence is linear). The exceptions: Freudenstein and Roth stops at
//! the paper's other, local minimum 48.9842, as MINPACK does; and
//! Trigonometric ($n = 10$) at the local minimum $2.79506 \cdot 10^{-5}$,
//! which the paper does not list, as MINPACK does. (Penalty II needs
//! `damping_scale: DampingScale::RunningMax`, the running maximum of
//! $\operatorname{diag}(J^\top J)$ as in MINPACK: with the default, the
//! current diagonal, the steps crawl and stay far from $f^*$.) The runner in `bench/` compares every solver on
//! all three starts.
//!
//! [`MghProblem`]: crate::problems::mgh::MghProblem
//! [`MghProblem::new`]: crate::problems::mgh::MghProblem::new
//! [`MghProblem::with_size`]: crate::problems::mgh::MghProblem::with_size
//! [`MghProblem::with_n`]: crate::problems::mgh::MghProblem::with_n
//! [`MghProblem::known_minima`]: crate::problems::mgh::MghProblem::known_minima
//! [`MghProblem::optimal_value`]: crate::problems::mgh::MghProblem::optimal_value
//! [`MghProblem::start`]: crate::problems::mgh::MghProblem::start
//! [`KnownMinimum::tolerance`]: crate::problems::mgh::KnownMinimum::tolerance
//! [`MghFunction`]: crate::problems::mgh::MghFunction
//! [`LeastSquaresProblem`]: crate::LeastSquaresProblem
//! [`Objective`]: crate::powell::Objective
//! [`all`]: crate::problems::mgh::all
//! [`by_id`]: crate::problems::mgh::by_id
//! [`by_name`]: crate::problems::mgh::by_name

mod data;
mod facts;
mod fixed;
mod function;
mod variable;

use faer::sparse::SymbolicSparseRowMat;

use crate::error::{Result, TrajoptError};
use crate::least_squares::LeastSquaresProblem;
use crate::powell::Objective;

pub use function::MghFunction;

/// A minimum that the paper lists for a problem (see the
/// [module docs](self#minima)).
#[derive(Debug, Clone, PartialEq)]
pub struct KnownMinimum {
    /// The value of $f$ there, as the paper prints it (exact when
    /// [`tolerance`](Self::tolerance) is 0).
    pub value: f64,
    /// How far the true value may be from [`value`](Self::value): a whole
    /// unit in the last printed digit, or 0 for a value the paper gives in
    /// closed form.
    pub tolerance: f64,
    /// A minimiser, where the paper gives one in closed form (one point of
    /// the set where the minimisers form a set).
    pub minimiser: Option<Vec<f64>>,
    /// Whether this is the smallest value the paper lists ($f^*$).
    pub global: bool,
}

impl KnownMinimum {
    /// Whether `f` matches this minimum's value: within
    /// [`tolerance`](Self::tolerance), and at least to the relative
    /// `rel` (or absolutely `rel` when the value is 0).
    pub fn matches(&self, f: f64, rel: f64) -> bool {
        let scale = if self.value == 0.0 { 1.0 } else { self.value.abs() };
        (f - self.value).abs() <= self.tolerance.max(rel * scale)
    }
}

/// One function of the set at one size: see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MghProblem {
    function: MghFunction,
    n: usize,
    m: usize,
}

/// The 35 problems at their standard sizes, in the paper's order.
pub fn all() -> Vec<MghProblem> {
    MghFunction::ALL.into_iter().map(MghProblem::new).collect()
}

/// The problem with the paper's number `id` (1 to 35) at its standard size.
pub fn by_id(id: usize) -> Option<MghProblem> {
    MghFunction::from_id(id).map(MghProblem::new)
}

/// The problem named `name` at its standard size; see
/// [`MghFunction::from_name`] for the names accepted.
pub fn by_name(name: &str) -> Option<MghProblem> {
    MghFunction::from_name(name).map(MghProblem::new)
}

impl MghProblem {
    /// `function` at its standard size (see the [module docs](self#sizes)).
    pub fn new(function: MghFunction) -> Self {
        let (n, m) = facts::standard_size(function);
        Self { function, n, m }
    }

    /// `function` with `n` parameters and `m` residuals.
    ///
    /// # Errors
    /// [`TrajoptError::InvalidParameter`] for a size the paper does not allow
    /// (see [`MghFunction`]'s variants).
    pub fn with_size(function: MghFunction, n: usize, m: usize) -> Result<Self> {
        facts::check_size(function, n, m)?;
        Ok(Self { function, n, m })
    }

    /// `function` with `n` parameters and the $m$ that goes with it: the
    /// paper's when it fixes $m$, else $m = 2n$ for the linear functions and
    /// $m = n$ for Chebyquad.
    ///
    /// # Errors
    /// [`TrajoptError::InvalidParameter`] for an `n` the paper does not
    /// allow.
    pub fn with_n(function: MghFunction, n: usize) -> Result<Self> {
        let m = facts::residuals_for(function, n)?;
        Ok(Self { function, n, m })
    }

    /// Which function this is.
    pub fn function(&self) -> MghFunction {
        self.function
    }

    /// The paper's number, 1 to 35.
    pub fn id(&self) -> usize {
        self.function.id()
    }

    /// The paper's name of the function.
    pub fn name(&self) -> &'static str {
        self.function.name()
    }

    /// Number of parameters $n$.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of residuals $m$.
    pub fn m(&self) -> usize {
        self.m
    }

    /// The starting point `scale` $\cdot x_0$ (the paper uses 1, 10 and 100);
    /// for Watson, whose $x_0 = 0$, a scale other than 1 gives
    /// $(\text{scale}, \ldots, \text{scale})$ as in MINPACK-1's test driver.
    pub fn start(&self, scale: f64) -> Vec<f64> {
        let x0 = facts::start_point(self.function, self.n);
        if scale != 1.0 && x0.iter().all(|&v| v == 0.0) {
            return vec![scale; self.n];
        }
        x0.into_iter().map(|v| scale * v).collect()
    }

    /// The minima the paper lists at this size, $f^*$ first (empty where it
    /// lists none); see the [module docs](self#minima).
    pub fn known_minima(&self) -> Vec<KnownMinimum> {
        facts::known_minima(self.function, self.n, self.m)
    }

    /// The paper's optimal value $f^*$ at this size, if it gives one (to
    /// the precision of [`KnownMinimum::tolerance`]).
    pub fn optimal_value(&self) -> Option<f64> {
        self.known_minima().first().map(|k| k.value)
    }

    /// A minimiser attaining [`optimal_value`](Self::optimal_value), where
    /// the paper gives one in closed form.
    pub fn minimiser(&self) -> Option<Vec<f64>> {
        self.known_minima().into_iter().next().and_then(|k| k.minimiser)
    }

    /// The residuals $f_1(x), \ldots, f_m(x)$.
    ///
    /// # Errors
    /// [`TrajoptError::DimensionMismatch`] unless `x` has $n$ entries.
    pub fn residuals(&self, x: &[f64]) -> Result<Vec<f64>> {
        let mut r = vec![0.0; self.m];
        self.residuals_into(x, &mut r)?;
        Ok(r)
    }

    /// Writes the residuals into `r`.
    ///
    /// # Errors
    /// [`TrajoptError::DimensionMismatch`] unless `x` has $n$ entries and `r`
    /// has $m$.
    pub fn residuals_into(&self, x: &[f64], r: &mut [f64]) -> Result<()> {
        expect_len("parameters", self.n, x.len())?;
        expect_len("residuals", self.m, r.len())?;
        if self.id() <= 19 {
            fixed::residuals(self.function, x, r);
        } else {
            variable::residuals(self.function, x, r);
        }
        Ok(())
    }

    /// The Jacobian $J_{ij} = \partial f_i / \partial x_j$, dense, row-major
    /// ($m \times n$).
    ///
    /// # Errors
    /// [`TrajoptError::DimensionMismatch`] unless `x` has $n$ entries.
    pub fn jacobian(&self, x: &[f64]) -> Result<Vec<f64>> {
        let mut jac = vec![0.0; self.m * self.n];
        self.jacobian_into(x, &mut jac)?;
        Ok(jac)
    }

    /// Writes the Jacobian (dense, row-major) into `jac`.
    ///
    /// # Errors
    /// [`TrajoptError::DimensionMismatch`] unless `x` has $n$ entries and
    /// `jac` has $m n$.
    pub fn jacobian_into(&self, x: &[f64], jac: &mut [f64]) -> Result<()> {
        expect_len("parameters", self.n, x.len())?;
        expect_len("jacobian entries", self.m * self.n, jac.len())?;
        jac.fill(0.0);
        if self.id() <= 19 {
            fixed::jacobian(self.function, x, jac);
        } else {
            variable::jacobian(self.function, x, jac);
        }
        Ok(())
    }

    /// $f(x) = \sum_i f_i(x)^2$.
    ///
    /// # Errors
    /// [`TrajoptError::DimensionMismatch`] unless `x` has $n$ entries.
    pub fn cost(&self, x: &[f64]) -> Result<f64> {
        Ok(self.residuals(x)?.iter().map(|r| r * r).sum())
    }

    /// The gradient $\nabla f(x) = 2 J^\top f$.
    ///
    /// # Errors
    /// [`TrajoptError::DimensionMismatch`] unless `x` has $n$ entries.
    pub fn gradient(&self, x: &[f64]) -> Result<Vec<f64>> {
        let r = self.residuals(x)?;
        let jac = self.jacobian(x)?;
        let mut g = vec![0.0; self.n];
        for (row, ri) in jac.chunks_exact(self.n).zip(&r) {
            for (gj, jij) in g.iter_mut().zip(row) {
                *gj += 2.0 * jij * ri;
            }
        }
        Ok(g)
    }
}

fn expect_len(what: &'static str, expected: usize, actual: usize) -> Result<()> {
    if expected != actual {
        return Err(TrajoptError::DimensionMismatch { what, expected, actual });
    }
    Ok(())
}

/// The residuals and their dense Jacobian, for
/// [`GaussNewton`](crate::GaussNewton).
impl LeastSquaresProblem for MghProblem {
    fn n_params(&self) -> usize {
        self.n
    }

    fn n_residuals(&self) -> usize {
        self.m
    }

    fn residuals(&self, theta: &[f64], r: &mut [f64]) -> Result<()> {
        self.residuals_into(theta, r)
    }

    /// Every entry: the Jacobians are small and mostly dense.
    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
        crate::fit::dense_pattern(self.m, self.n)
    }

    fn jacobian_values(&self, theta: &[f64], values: &mut [f64]) -> Result<()> {
        // the dense pattern's order is row-major
        self.jacobian_into(theta, values)
    }
}

/// The cost $f(x)$, for [`Powell`](crate::Powell).
impl Objective for MghProblem {
    fn cost(&self, x: &[f64]) -> Result<f64> {
        MghProblem::cost(self, x)
    }
}

/// The cost $f(x)$ for argmin's solvers.
#[cfg(feature = "argmin")]
impl argmin::core::CostFunction for MghProblem {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, x: &Self::Param) -> std::result::Result<f64, argmin::core::Error> {
        MghProblem::cost(self, x).map_err(argmin::core::Error::new)
    }
}

/// The gradient $2 J^\top f$ for argmin's solvers.
#[cfg(feature = "argmin")]
impl argmin::core::Gradient for MghProblem {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;

    fn gradient(&self, x: &Self::Param) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        MghProblem::gradient(self, x).map_err(argmin::core::Error::new)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mgh_numbers_names_and_standard_sizes_are_consistent() {
        let problems = all();
        assert_eq!(problems.len(), 35);
        for (i, p) in problems.iter().enumerate() {
            assert_eq!(p.id(), i + 1);
            assert_eq!(by_id(p.id()), Some(*p));
            assert_eq!(by_name(p.name()), Some(*p), "{}", p.name());
            assert_eq!(by_name(&p.function().key().to_uppercase()), Some(*p));
            assert_eq!(MghProblem::with_size(p.function(), p.n(), p.m()), Ok(*p));
            assert_eq!(MghProblem::with_n(p.function(), p.n()), Ok(*p), "{}", p.name());
            assert_eq!(p.start(1.0).len(), p.n());
            assert!(p.m() >= p.n(), "{}", p.name());
        }
        assert_eq!(by_id(0), None);
        assert_eq!(by_id(36), None);
        assert_eq!(by_name("no such function"), None);
        assert_eq!(by_name("Box three-dimensional function").map(|p| p.id()), Some(12));
    }

    #[test]
    fn mgh_sizes_outside_the_paper_are_refused() {
        use MghFunction as F;
        for (f, n, m) in [
            (F::Rosenbrock, 3, 3),
            (F::Rosenbrock, 2, 3),
            (F::Gulf, 3, 101),
            (F::Gulf, 3, 2),
            (F::Watson, 1, 31),
            (F::Watson, 6, 30),
            (F::ExtendedRosenbrock, 3, 3),
            (F::ExtendedPowellSingular, 6, 6),
            (F::PenaltyII, 4, 7),
            (F::LinearFullRank, 5, 4),
            (F::LinearRank1ZeroColumnsRows, 2, 10),
            (F::Chebyquad, 0, 0),
            (F::Box3d, 3, 2),
        ] {
            assert!(
                matches!(
                    MghProblem::with_size(f, n, m),
                    Err(TrajoptError::InvalidParameter { .. })
                ),
                "{f:?} {n} {m}"
            );
        }
        let watson = MghProblem::with_n(F::Watson, 9).expect("n = 9");
        assert_eq!((watson.m(), watson.optimal_value()), (31, Some(1.39976e-6)));
        assert_eq!(MghProblem::with_n(F::Watson, 7).expect("n = 7").optimal_value(), None);
    }

    #[test]
    fn mgh_wrong_lengths_are_dimension_errors() {
        for p in all() {
            let short = vec![0.5; p.n() - 1];
            assert!(matches!(
                p.residuals(&short),
                Err(TrajoptError::DimensionMismatch { .. })
            ));
            assert!(matches!(
                p.jacobian(&short),
                Err(TrajoptError::DimensionMismatch { .. })
            ));
            assert!(matches!(
                p.gradient(&short),
                Err(TrajoptError::DimensionMismatch { .. })
            ));
            let x = p.start(1.0);
            let mut r = vec![0.0; p.m() + 1];
            assert!(matches!(
                p.residuals_into(&x, &mut r),
                Err(TrajoptError::DimensionMismatch { .. })
            ));
            let mut jac = vec![0.0; p.m() * p.n() - 1];
            assert!(matches!(
                p.jacobian_into(&x, &mut jac),
                Err(TrajoptError::DimensionMismatch { .. })
            ));
        }
    }

    #[test]
    fn mgh_scaled_starts_follow_the_paper_and_minpack() {
        let rosenbrock = by_id(1).expect("1");
        assert_eq!(rosenbrock.start(10.0), vec![-12.0, 10.0]);
        let watson = by_id(20).expect("20");
        assert_eq!(watson.start(1.0), vec![0.0; 6]);
        assert_eq!(watson.start(100.0), vec![100.0; 6]);
    }

    #[test]
    fn mgh_gradient_is_twice_jt_f() {
        // Rosenbrock at x0: f = (-4.4, 2.2), J = [[24, 10], [-1, 0]]
        let p = by_id(1).expect("1");
        let g = p.gradient(&[-1.2, 1.0]).expect("gradient");
        assert!((g[0] - 2.0 * (-4.4 * 24.0 - 2.2)).abs() < 1e-12);
        assert!((g[1] - 2.0 * (-4.4 * 10.0)).abs() < 1e-12);
    }
}
