//! Problem sets ([`ProblemSet`]), their instances ([`Instance`]: a problem
//! and a starting point), and the counting view every solver sees
//! ([`Counted`]).
//!
//! Every instance is a [`LeastSquaresProblem`]: Gauss-Newton uses it as
//! it is, the derivative-free solvers see only $f = \lVert r \rVert^2$, and
//! argmin's gradient solvers $\nabla f = 2 J^\top r$. **Adding a set** (as
//! the trajectory set, [`crate::trajectory`]): a variant of
//! [`ProblemSet`], its name in [`ProblemSet::name`] and
//! [`ProblemSet::ALL`], its convergence test in [`ProblemSet::test`], and
//! its instances in [`ProblemSet::instances`]; solvers that need another
//! form of the same problem (DDP) get it through a field of [`Instance`]
//! ([`Instance::rollout`]) and say in
//! [`Solver::applies_to`](crate::solvers::Solver::applies_to) where they run.

use std::cell::{Cell, RefCell};
use std::sync::Arc;
use std::time::{Duration, Instant};

use std::ops::Range;

use faer::sparse::{SymbolicSparseColMat, SymbolicSparseRowMat};
use trajopt::problems::mgh;
use trajopt::{
    BandForm, BandLayout, BandNormalEquations, BandedSym, LeastSquaresProblem, Part, Point, SecondOrder, TrajoptError,
};

use crate::error::{BenchError, Result};
pub use crate::instance::{Instance, SharedProblem};
use crate::profiles::ConvergenceTest;

/// A named set of benchmark problems.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ProblemSet {
    /// The 35 Moré-Garbow-Hillstrom problems at their standard sizes
    /// ([`trajopt::problems::mgh`]), each from $x_0$, $10 x_0$ and $100 x_0$.
    Mgh,
    /// The trajectory swing-ups in Eq. 3 and DDP form and the learned-LWR
    /// swing-up plan ([`crate::trajectory`]).
    Trajectory,
    /// The 27 NIST StRD nonlinear regression problems ([`crate::nist`]),
    /// each from its two certified starts (the records' `scale` is the
    /// start's number, 1 or 2), judged by the log relative error of the
    /// parameters.
    Nist,
}

impl ProblemSet {
    /// Every set.
    pub const ALL: [Self; 3] = [Self::Mgh, Self::Trajectory, Self::Nist];

    /// The set's name on the command line and in the records.
    pub fn name(self) -> &'static str {
        match self {
            Self::Mgh => "mgh",
            Self::Trajectory => crate::instance::TRAJECTORY_SET,
            Self::Nist => crate::nist::SET,
        }
    }

    /// The convergence test its runs are judged by.
    pub fn test(self) -> ConvergenceTest {
        match self {
            Self::Mgh | Self::Nist => ConvergenceTest::MoreWild,
            Self::Trajectory => ConvergenceTest::RelativeToBest,
        }
    }

    /// Where its report goes in the report directory: `benchmarks` for
    /// the MGH set (`benchmarks.md`, `.json`), `benchmarks_<set>` for the
    /// others.
    pub fn report_stem(self) -> String {
        match self {
            Self::Mgh => "benchmarks".into(),
            other => format!("benchmarks_{}", other.name()),
        }
    }

    /// Its default output directory: `results/benchmarks` for the MGH
    /// set, `results/benchmarks/<set>` for the others.
    pub fn default_out(self) -> std::path::PathBuf {
        match self {
            Self::Mgh => "results/benchmarks".into(),
            other => std::path::Path::new("results/benchmarks").join(other.name()),
        }
    }

    /// The set named `name`.
    ///
    /// # Errors
    /// [`BenchError::UnknownSet`] listing the names known.
    pub fn parse(name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|s| s.name() == name.trim())
            .ok_or_else(|| BenchError::UnknownSet {
                name: name.into(),
                known: Self::ALL.map(Self::name).join(", "),
            })
    }

    /// The names of the set's problems, without building the trajectory
    /// set's (its learned-LWR instance runs two learning trials).
    ///
    /// # Errors
    /// As [`instances`](Self::instances) for the MGH and NIST sets.
    pub fn names(self) -> Result<Vec<String>> {
        Ok(match self {
            Self::Trajectory => crate::trajectory::names(),
            _ => self.instances(None)?.into_iter().map(|i| i.problem).collect(),
        })
    }

    /// The set's instances whose problem names contain `filter` (all when
    /// `None`), in a fixed order.
    ///
    /// # Errors
    /// A trajectory problem that cannot be built.
    pub fn instances(self, filter: Option<&str>) -> Result<Vec<Instance>> {
        let keep = |i: &Instance| filter.is_none_or(|f| i.problem.contains(f));
        Ok(match self {
            Self::Trajectory => crate::trajectory::instances(filter)?,
            Self::Nist => crate::nist::all()?
                .into_iter()
                .flat_map(|p| {
                    let p = Arc::new(p);
                    [1u8, 2].map(|start| Instance {
                        set: self.name(),
                        problem: p.name.clone(),
                        scale: f64::from(start),
                        start: p.starts[usize::from(start) - 1].clone(),
                        f_star: Some(p.certified_rss),
                        residuals: p.m(),
                        least_squares: p.clone(),
                        rollout: None,
                    })
                })
                .filter(keep)
                .collect(),
            Self::Mgh => mgh::all()
                .into_iter()
                .flat_map(|p| {
                    [1.0, 10.0, 100.0].map(|scale| Instance {
                        set: self.name(),
                        problem: format!("{:02}_{}", p.id(), p.function().key()),
                        scale,
                        start: p.start(scale),
                        f_star: p.optimal_value(),
                        residuals: p.m(),
                        least_squares: Arc::new(p),
                        rollout: None,
                    })
                })
                .filter(keep)
                .collect(),
        })
    }
}

/// What one run may spend: evaluation equivalents (in units of $n + 1$,
/// Moré and Wild's simplex gradients) and wall time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Budget {
    /// Evaluation equivalents per run, in units of $n + 1$.
    pub simplex_gradients: u64,
    /// Wall time per run.
    pub time: Duration,
}

impl Budget {
    /// The evaluation equivalents allowed on a problem with `n` parameters.
    pub fn evals(&self, n: usize) -> u64 {
        self.simplex_gradients * (n as u64 + 1)
    }
}

/// The message of the error a [`Counted`] problem returns once its budget
/// is spent (the solver stops; the runner reports the best point found).
pub const BUDGET_SPENT: &str = "benchmark budget spent";

/// A problem seen through counters: residual and Jacobian evaluations, the
/// trace of the best $f$ so far (and the point where it was found), and the
/// budget, which makes every evaluation past it an error.
///
/// Its [`SecondOrder`] is the problem's own when it has one (Eq. 3:
/// counted as one Jacobian evaluation, $\delta^\top S \delta$ as one
/// residual evaluation), else $S = \sum_i r_i \nabla^2 r_i$ from central
/// differences of the analytic Jacobian ($2n$ Jacobians, counted), for the
/// Newton modes. A problem with a [`BandForm`] (Eq. 3) keeps it: its
/// normal equations count as one Jacobian evaluation, two when they
/// include $S$.
pub struct Counted<'a> {
    inner: &'a (dyn LeastSquaresProblem + Send + Sync),
    band: Option<&'a dyn BandForm>,
    n: usize,
    max_evals: u64,
    deadline: Instant,
    f_evals: Cell<u64>,
    jac_evals: Cell<u64>,
    spent: Cell<bool>,
    best: Cell<f64>,
    best_x: RefCell<Vec<f64>>,
    trace: RefCell<Vec<(u64, f64)>>,
}

impl<'a> Counted<'a> {
    /// `instance`'s problem under `budget`, counting from now.
    pub fn new(instance: &'a Instance, budget: &Budget) -> Self {
        let n = instance.n();
        let inner = instance.least_squares.as_ref();
        Self {
            inner,
            band: inner.band_form(),
            n,
            max_evals: budget.evals(n),
            deadline: Instant::now() + budget.time,
            f_evals: Cell::new(0),
            jac_evals: Cell::new(0),
            spent: Cell::new(false),
            best: Cell::new(f64::INFINITY),
            best_x: RefCell::new(instance.start.clone()),
            trace: RefCell::new(Vec::new()),
        }
    }

    /// Evaluation equivalents so far: residual evaluations plus $n$ per
    /// Jacobian.
    pub fn evals(&self) -> u64 {
        self.f_evals.get() + self.n as u64 * self.jac_evals.get()
    }

    /// When the run's time is up.
    pub fn deadline(&self) -> Instant {
        self.deadline
    }

    /// The budget in evaluation equivalents.
    pub fn max_evals(&self) -> u64 {
        self.max_evals
    }

    /// Residual (cost) evaluations so far.
    pub fn f_evals(&self) -> u64 {
        self.f_evals.get()
    }

    /// Jacobian (gradient) evaluations so far.
    pub fn jac_evals(&self) -> u64 {
        self.jac_evals.get()
    }

    /// Whether an evaluation was refused for the budget.
    pub fn spent(&self) -> bool {
        self.spent.get()
    }

    /// The best $f$ evaluated.
    pub fn best(&self) -> f64 {
        self.best.get()
    }

    /// The point of the best $f$ (the start before any evaluation).
    pub fn best_point(&self) -> Vec<f64> {
        self.best_x.borrow().clone()
    }

    /// The improvement trace `[evals, f]`, unthinned.
    pub fn trace(&self) -> Vec<(u64, f64)> {
        self.trace.borrow().clone()
    }

    /// An error once the next evaluation (`cost` equivalents) would pass
    /// the budget.
    fn charge(&self, cost: u64) -> trajopt::Result<()> {
        if self.evals() + cost > self.max_evals || Instant::now() > self.deadline {
            self.spent.set(true);
            return Err(TrajoptError::Model(BUDGET_SPENT.into()));
        }
        Ok(())
    }

    /// $f(x) = \lVert r(x) \rVert^2$, counted and traced.
    pub fn cost(&self, x: &[f64]) -> trajopt::Result<f64> {
        let mut r = vec![0.0; self.inner.n_residuals()];
        self.residuals(x, &mut r)?;
        Ok(r.iter().map(|v| v * v).sum())
    }

    /// $\nabla f = 2 J^\top r$, counted as one Jacobian evaluation (the
    /// residuals at `x` come with it, uncounted: a solver asks for the
    /// gradient where it has the cost).
    pub fn gradient(&self, x: &[f64]) -> trajopt::Result<Vec<f64>> {
        let mut r = vec![0.0; self.inner.n_residuals()];
        self.inner.residuals(x, &mut r)?;
        let pattern = self.inner.jacobian_pattern();
        let mut values = vec![0.0; pattern.compute_nnz()];
        self.jacobian_values(x, &mut values)?;
        let mut g = vec![0.0; self.n];
        for (i, ri) in r.iter().enumerate() {
            let range = pattern.row_range(i);
            for (&j, v) in pattern.col_idx()[range.clone()].iter().zip(&values[range]) {
                g[j] += 2.0 * v * ri;
            }
        }
        Ok(g)
    }

    /// Counts `k` more Jacobian evaluations without checking the budget
    /// (for work the solver asked for together with a counted one).
    fn add_jacobians(&self, k: u64) {
        self.jac_evals.set(self.jac_evals.get() + k);
    }

    /// The dense row-major Jacobian, counted.
    pub(crate) fn dense_jacobian(&self, x: &[f64]) -> trajopt::Result<Vec<f64>> {
        let pattern = self.inner.jacobian_pattern();
        let mut values = vec![0.0; pattern.compute_nnz()];
        self.jacobian_values(x, &mut values)?;
        let mut dense = vec![0.0; self.inner.n_residuals() * self.n];
        for i in 0..pattern.nrows() {
            let range = pattern.row_range(i);
            for (&j, v) in pattern.col_idx()[range.clone()].iter().zip(&values[range]) {
                dense[i * self.n + j] = *v;
            }
        }
        Ok(dense)
    }
}

impl LeastSquaresProblem for Counted<'_> {
    fn n_params(&self) -> usize {
        self.n
    }

    fn n_residuals(&self) -> usize {
        self.inner.n_residuals()
    }

    fn residuals(&self, theta: &[f64], r: &mut [f64]) -> trajopt::Result<()> {
        self.charge(1)?;
        self.inner.residuals(theta, r)?;
        self.f_evals.set(self.f_evals.get() + 1);
        let f: f64 = r.iter().map(|v| v * v).sum();
        // a point with an infinite coordinate is no answer, even where f
        // is finite there (Jennrich-Sampson at x = -inf): its record could
        // hold no point to recompute f from
        if f < self.best.get() && theta.iter().all(|v| v.is_finite()) {
            self.best.set(f);
            self.best_x.borrow_mut().copy_from_slice(theta);
            self.trace.borrow_mut().push((self.evals(), f));
        }
        Ok(())
    }

    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
        self.inner.jacobian_pattern()
    }

    fn jacobian_values(&self, theta: &[f64], values: &mut [f64]) -> trajopt::Result<()> {
        self.charge(self.n as u64)?;
        self.jac_evals.set(self.jac_evals.get() + 1);
        self.inner.jacobian_values(theta, values)
    }

    fn second_order(&self) -> Option<&dyn SecondOrder> {
        Some(self)
    }

    fn band_form(&self) -> Option<&dyn BandForm> {
        self.band.map(|_| self as &dyn BandForm)
    }
}

/// The problem's band form, counted (see [`Counted`]).
impl BandForm for Counted<'_> {
    fn layout(&self) -> BandLayout {
        match self.band {
            Some(b) => b.layout(),
            None => BandLayout {
                position: (0..self.n).collect(),
                half_bandwidth: self.n.saturating_sub(1),
            },
        }
    }

    fn normal_equations(
        &self,
        at: Point<'_>,
        layout: &BandLayout,
        out: BandNormalEquations<'_>,
    ) -> trajopt::Result<bool> {
        let band = self.band.ok_or_else(|| TrajoptError::Model("no band form".into()))?;
        self.charge(self.n as u64)?;
        self.add_jacobians(1);
        let with_s = band.normal_equations(at, layout, out)?;
        if with_s {
            self.add_jacobians(1);
        }
        Ok(with_s)
    }

    fn residuals_part(&self, part: Part, theta: &[f64], r: &mut [f64]) -> trajopt::Result<Range<usize>> {
        part.check()?;
        if part.index > 0 {
            return Ok(0..0);
        }
        self.residuals(theta, r)?;
        Ok(0..self.n_residuals())
    }

    fn second_order_part(
        &self,
        part: Part,
        at: Point<'_>,
        layout: &BandLayout,
        s: &mut BandedSym,
    ) -> trajopt::Result<bool> {
        let band = self.band.ok_or_else(|| TrajoptError::Model("no band form".into()))?;
        if part.index == 0 {
            self.charge(self.n as u64)?;
            self.add_jacobians(1);
        }
        band.second_order_part(part, at, layout, s)
    }
}

/// The problem's own $S$, counted, or $S = \sum_i r_i \nabla^2 r_i$ by
/// central differences of the Jacobian, symmetrised, dense.
impl SecondOrder for Counted<'_> {
    fn pattern(&self) -> SymbolicSparseColMat<usize> {
        if let Some(own) = self.inner.second_order() {
            return own.pattern();
        }
        let n = self.n;
        let col_ptr = (0..=n).map(|j| j * n).collect();
        let row_idx = (0..n).flat_map(|_| 0..n).collect();
        SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx)
    }

    fn values(&self, theta: &[f64], r: &[f64], values: &mut [f64]) -> trajopt::Result<bool> {
        if let Some(own) = self.inner.second_order() {
            self.charge(self.n as u64)?;
            self.add_jacobians(1);
            return own.values(theta, r, values);
        }
        let n = self.n;
        let mut s = vec![0.0; n * n];
        let mut x = theta.to_vec();
        for j in 0..n {
            // h ~ eps^(1/3): truncation O(h^2) against rounding O(eps / h)
            let h = 6e-6 * theta[j].abs().max(1.0);
            x[j] = theta[j] + h;
            let plus = self.dense_jacobian(&x)?;
            x[j] = theta[j] - h;
            let minus = self.dense_jacobian(&x)?;
            x[j] = theta[j];
            // column j of S: sum_i r_i d(grad r_i)/dx_j
            for (i, ri) in r.iter().enumerate() {
                for k in 0..n {
                    s[k * n + j] += ri * (plus[i * n + k] - minus[i * n + k]) / (2.0 * h);
                }
            }
        }
        for j in 0..n {
            for k in 0..n {
                values[j * n + k] = 0.5 * (s[k * n + j] + s[j * n + k]);
            }
        }
        Ok(true)
    }

    fn form(&self, theta: &[f64], r: &[f64], delta: &[f64]) -> trajopt::Result<Option<f64>> {
        match self.inner.second_order() {
            Some(own) => {
                self.charge(1)?;
                self.f_evals.set(self.f_evals.get() + 1);
                own.form(theta, r, delta)
            }
            None => Ok(None),
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// MGH's Rosenbrock from $x_0$ (n = 2) and a budget of
    /// `simplex_gradients` and a minute.
    pub(crate) fn rosenbrock(simplex_gradients: u64) -> (Instance, Budget) {
        let inst = ProblemSet::Mgh
            .instances(Some("rosenbrock"))
            .expect("mgh")
            .swap_remove(0);
        let budget = Budget {
            simplex_gradients,
            time: Duration::from_secs(60),
        };
        (inst, budget)
    }

    #[test]
    fn the_mgh_set_has_105_instances_with_unique_names() {
        let all = ProblemSet::Mgh.instances(None).expect("mgh");
        assert_eq!(all.len(), 105);
        let mut keys: Vec<_> = all.iter().map(|i| (i.problem.clone(), i.scale.to_bits())).collect();
        keys.sort();
        keys.dedup();
        assert_eq!(keys.len(), 105);
        assert_eq!(all[69].problem, "24_penalty2");
        assert!(matches!(ProblemSet::parse("cute"), Err(BenchError::UnknownSet { .. })));
        assert_eq!(ProblemSet::parse("mgh").expect("known"), ProblemSet::Mgh);
    }

    #[test]
    fn counting_and_budget() {
        let (inst, budget) = rosenbrock(2);
        let inst = &inst;
        let c = Counted::new(inst, &budget);
        let f0 = c.cost(&inst.start).expect("cost");
        assert!((f0 - 24.2).abs() < 1e-12);
        let g = c.gradient(&[1.0, 1.0]).expect("gradient");
        assert_eq!(g, vec![0.0, 0.0]);
        assert_eq!((c.f_evals(), c.jac_evals(), c.evals()), (1, 1, 3));
        assert_eq!(c.cost(&[1.0, 1.0]).expect("cost"), 0.0);
        assert_eq!(c.trace(), vec![(1, f0), (4, 0.0)]);
        // 6 = 2 (n + 1) allowed: two more residuals, then an error
        c.cost(&[1.0, 1.0]).expect("5");
        c.cost(&[1.0, 1.0]).expect("6");
        assert!(c.cost(&[1.0, 1.0]).is_err() && c.spent());
    }

    /// Jennrich-Sampson's residuals $2 + 2i - e^{i x_1} - e^{i x_2}$ are
    /// finite at $x = -\infty$ (f = 2020): that evaluation counts, but it
    /// is not the run's answer, which must be a point.
    #[test]
    fn a_point_with_an_infinite_coordinate_is_never_the_best() {
        let inst = ProblemSet::Mgh.instances(Some("jennrich")).expect("mgh").swap_remove(0);
        let budget = Budget {
            simplex_gradients: 100,
            time: Duration::from_secs(60),
        };
        let c = Counted::new(&inst, &budget);
        let at_infinity = c.cost(&[f64::NEG_INFINITY; 2]).expect("cost");
        assert_eq!(at_infinity, 2020.0);
        assert_eq!(c.f_evals(), 1);
        assert!(c.best().is_infinite() && c.best_point() == inst.start && c.trace().is_empty());
        let f = c.cost(&[0.25, 0.25]).expect("cost");
        assert!(f.is_finite());
        assert_eq!((c.best(), c.best_point()), (f, vec![0.25, 0.25]));
    }

    #[test]
    fn second_order_matches_rosenbrock_by_hand() {
        // r = (10 (x2 - x1^2), 1 - x1): S = r1 * [[-20, 0], [0, 0]]
        let (inst, budget) = rosenbrock(100);
        let inst = &inst;
        let c = Counted::new(inst, &budget);
        let x = [0.5, 2.0];
        let r = [10.0 * (2.0 - 0.25), 0.5];
        let mut s = vec![0.0; 4];
        assert!(c.values(&x, &r, &mut s).expect("S"));
        let want = [-20.0 * r[0], 0.0, 0.0, 0.0];
        for (a, b) in s.iter().zip(want) {
            assert!((a - b).abs() < 1e-6, "{s:?}");
        }
        assert_eq!(c.jac_evals(), 4);
    }
}
