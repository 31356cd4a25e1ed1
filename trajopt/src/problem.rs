//! The paper's Eq. 3 over basis coefficients.
//!
//! States $x_k \in \mathbb{R}^n$ at the sample times $t_0, \dots, t_N$ and
//! controls $u_k \in \mathbb{R}^m$ at $t_0, \dots, t_{N-1}$ are represented
//! separately, each by a basis from [`splines`]:
//! $x_k = (\Phi_x C_x)_k$, $u_k = (\Phi_u C_u)_k$. The criterion is
//! $$C(C_x, C_u) = \sum_{k=0}^{N} \lVert r^c_k(x_k, u_k) \rVert^2 +
//!   \sum_{k=0}^{N-1} \lambda_k s^2 \lVert x_{k+1} - f(x_k, u_k) \rVert^2 \;[+\;
//!   w_0 \lVert x_0 - \bar x_0 \rVert^2],$$
//! the first sum the task cost (a [`StageCost`] in residual form, the
//! terminal stage $k = N$ without control), the second the paper's soft
//! dynamics constraint with the per-step consistency weight $\lambda_k$
//! ([`Lambda`]) and a scale $s$ (1 by default; $1/\Delta t$ measures the
//! mismatch in rate units, so that per-step errors do not shrink with the
//! step), the last an optional penalty fixing the initial state.
//!
//! The parameter vector is $\theta = [\operatorname{vec} C_x, \operatorname{vec} C_u]$,
//! each coefficient matrix column by column (channel by channel).

use faer::Mat;
use faer::sparse::{SparseRowMat, SymbolicSparseColMat, SymbolicSparseRowMat};
use splines::TrajectoryBasis;

use crate::banded::{BandLayout, BandedSym};
use crate::error::{Result, TrajoptError, check_finite};
use crate::least_squares::{LeastSquaresProblem, LinearBounds};

mod band;

/// A discrete-time dynamics model $x_{k+1} = f(x_k, u_k)$.
pub trait Model {
    /// State dimension $n$.
    fn state_dim(&self) -> usize;

    /// Control dimension $m$.
    fn control_dim(&self) -> usize;

    /// Writes $f(x, u)$ into `next`.
    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> Result<()>;

    /// Writes $\partial f / \partial x$ ($n \times n$) and $\partial f / \partial u$
    /// ($n \times m$), row-major, and returns `true`; or returns `false`
    /// (the default) to have them computed by central differences.
    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<bool> {
        let _ = (x, u, fx, fu);
        Ok(false)
    }

    /// Which entries of $\partial f / \partial x$ and $\partial f / \partial u$
    /// (row-major, as in [`jacobians`](Self::jacobians)) can be nonzero; the
    /// default says all. A model that leaves structural zeros out shrinks
    /// the planner's Jacobian and normal equations; it must not leave out
    /// any entry that can be nonzero.
    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        fx.fill(true);
        fu.fill(true);
    }

    /// Writes the weighted second derivative
    /// $\sum_i w_i \nabla^2 f_i(z)$ over $z = (x, u)$, an $(n+m) \times (n+m)$
    /// symmetric matrix, row-major, and returns `true`; or returns `false`
    /// (the default) when the model has no second derivatives. With them,
    /// [`GaussNewton`](crate::GaussNewton) can take exact Newton steps
    /// ([`GaussNewtonSettings::second_order`](crate::GaussNewtonSettings::second_order)).
    /// Its nonzeros must lie where some row $i$ of the
    /// [Jacobian structure](Self::jacobian_structure) has both entries.
    fn weighted_hessian(&self, x: &[f64], u: &[f64], w: &[f64], hess: &mut [f64]) -> Result<bool> {
        let _ = (x, u, w, hess);
        Ok(false)
    }

    /// The model's confidence at $(x, u)$, if it has one (a learned model's
    /// support or inverse variance); used by [`Lambda::from_confidence`].
    fn confidence(&self, x: &[f64], u: &[f64]) -> Option<f64> {
        let _ = (x, u);
        None
    }

    /// [`step`](Self::step) at many points: `xs` ($K \times n$), `us`
    /// ($K \times m$) and `next` ($K \times n$), row-major. The default
    /// takes one point at a time; a model whose evaluation is expensive (a
    /// learned model's regression) may evaluate the points in parallel.
    /// [`Eq3Problem`] calls it once per residual evaluation. The results
    /// must be those of `step`, point by point.
    fn step_batch(&self, xs: &[f64], us: &[f64], next: &mut [f64]) -> Result<()> {
        let (n, m) = (self.state_dim(), self.control_dim());
        for k in 0..xs.len() / n.max(1) {
            self.step(
                &xs[k * n..(k + 1) * n],
                &us[k * m..(k + 1) * m],
                &mut next[k * n..(k + 1) * n],
            )?;
        }
        Ok(())
    }

    /// [`jacobians`](Self::jacobians) at many points: `fx` ($K \times n
    /// \times n$) and `fu` ($K \times n \times m$), row-major, point after
    /// point; returns `false` if the model has no Jacobians (then nothing is
    /// written). The default takes one point at a time (see
    /// [`step_batch`](Self::step_batch)).
    fn jacobians_batch(&self, xs: &[f64], us: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<bool> {
        let (n, m) = (self.state_dim(), self.control_dim());
        for k in 0..xs.len() / n.max(1) {
            let (x, u) = (&xs[k * n..(k + 1) * n], &us[k * m..(k + 1) * m]);
            if !self.jacobians(
                x,
                u,
                &mut fx[k * n * n..(k + 1) * n * n],
                &mut fu[k * n * m..(k + 1) * n * m],
            )? {
                return Ok(false);
            }
        }
        Ok(true)
    }
}

/// A reference to a model is a model, so that one model can serve several
/// problems (a continuation, a comparison of planners).
impl<M: Model + ?Sized> Model for &M {
    fn state_dim(&self) -> usize {
        (**self).state_dim()
    }

    fn control_dim(&self) -> usize {
        (**self).control_dim()
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> Result<()> {
        (**self).step(x, u, next)
    }

    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<bool> {
        (**self).jacobians(x, u, fx, fu)
    }

    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        (**self).jacobian_structure(fx, fu)
    }

    fn weighted_hessian(&self, x: &[f64], u: &[f64], w: &[f64], hess: &mut [f64]) -> Result<bool> {
        (**self).weighted_hessian(x, u, w, hess)
    }

    fn confidence(&self, x: &[f64], u: &[f64]) -> Option<f64> {
        (**self).confidence(x, u)
    }

    fn step_batch(&self, xs: &[f64], us: &[f64], next: &mut [f64]) -> Result<()> {
        (**self).step_batch(xs, us, next)
    }

    fn jacobians_batch(&self, xs: &[f64], us: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<bool> {
        (**self).jacobians_batch(xs, us, fx, fu)
    }
}

/// A stage cost in residual form, $c_k(x, u) = \lVert r^c_k(x, u) \rVert^2$.
pub trait StageCost {
    /// Number of residuals per stage (the same for every stage).
    fn n_residuals(&self) -> usize;

    /// Writes $r^c_k(x_k, u_k)$; `u` is `None` at the terminal stage $k = N$.
    fn residuals(&self, k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> Result<()>;

    /// Writes $\partial r^c_k / \partial x$ (`n_residuals` $\times n$) and
    /// $\partial r^c_k / \partial u$ (`n_residuals` $\times m$), row-major;
    /// at the terminal stage `ju` is ignored.
    fn jacobians(&self, k: usize, x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> Result<()>;

    /// Which entries of the residual Jacobians can be nonzero at any stage
    /// (row-major, as in [`jacobians`](Self::jacobians)); the default says
    /// all. Must not leave out any entry that can be nonzero.
    fn jacobian_structure(&self, jx: &mut [bool], ju: &mut [bool]) {
        jx.fill(true);
        ju.fill(true);
    }

    /// Writes $\sum_a w_a \nabla^2 r^c_{k,a}$ over $z = (x, u)$ (at the
    /// terminal stage over $x$ alone), row-major, and returns `true`; or
    /// returns `false` (the default) when the cost has no second
    /// derivatives (then [`GaussNewton`](crate::GaussNewton) keeps to
    /// Gauss-Newton steps). Nonzeros only where some residual's
    /// [Jacobian structure](Self::jacobian_structure) has both entries.
    fn weighted_hessian(&self, k: usize, x: &[f64], u: Option<&[f64]>, w: &[f64], hess: &mut [f64]) -> Result<bool> {
        let _ = (k, x, u, w, hess);
        Ok(false)
    }
}

/// The paper's Eq. 5 as a built-in stage cost: quadratic tracking of a state
/// reference $x^d$ and a control reference $u^d$ with diagonal weights,
/// $$c_k = \sum_i q_i (x_{k,i} - x^d_{k,i})^2 + \sum_j r_j (u_{k,j} - u^d_{k,j})^2,
/// \qquad c_N = \sum_i q^f_i (x_{N,i} - x^d_{N,i})^2.$$
/// With a zero control reference this is the paper's $u^\top R u$; with the
/// demonstration's controls, $\lambda = 0$ plans the demonstration itself.
#[derive(Debug, Clone)]
pub struct TrackingCost {
    state_ref: Mat<f64>,
    control_ref: Mat<f64>,
    sqrt_q: Vec<f64>,
    sqrt_r: Vec<f64>,
    sqrt_qf: Vec<f64>,
}

impl TrackingCost {
    /// A tracking cost: `state_ref` is $(N+1) \times n$, `control_ref` is
    /// $N \times m$; `q`, `r`, `q_final` are the nonnegative diagonal weights.
    pub fn new(state_ref: Mat<f64>, control_ref: Mat<f64>, q: &[f64], r: &[f64], q_final: &[f64]) -> Result<Self> {
        let (n, m) = (state_ref.ncols(), control_ref.ncols());
        expect_len("q", n, q.len())?;
        expect_len("q_final", n, q_final.len())?;
        expect_len("r", m, r.len())?;
        expect_len(
            "control reference rows",
            state_ref.nrows().saturating_sub(1),
            control_ref.nrows(),
        )?;
        for (what, w) in [("q", q), ("r", r), ("q_final", q_final)] {
            check_finite(what, w)?;
            if let Some(i) = w.iter().position(|&v| v < 0.0) {
                return Err(TrajoptError::InvalidParameter {
                    name: what,
                    reason: format!("weight {i} is negative ({})", w[i]),
                });
            }
        }
        for (what, mat) in [("state reference", &state_ref), ("control reference", &control_ref)] {
            for j in 0..mat.ncols() {
                if let Some((i, &v)) = mat.col(j).iter().enumerate().find(|(_, v)| !v.is_finite()) {
                    return Err(TrajoptError::NotFinite {
                        what,
                        index: i * mat.ncols() + j,
                        value: v,
                    });
                }
            }
        }
        Ok(Self {
            state_ref,
            control_ref,
            sqrt_q: q.iter().map(|v| v.sqrt()).collect(),
            sqrt_r: r.iter().map(|v| v.sqrt()).collect(),
            sqrt_qf: q_final.iter().map(|v| v.sqrt()).collect(),
        })
    }

    /// The horizon $N$ implied by the references.
    pub fn horizon(&self) -> usize {
        self.control_ref.nrows()
    }
}

impl StageCost for TrackingCost {
    fn n_residuals(&self) -> usize {
        self.sqrt_q.len() + self.sqrt_r.len()
    }

    fn residuals(&self, k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> Result<()> {
        let n = self.sqrt_q.len();
        let w = if u.is_some() { &self.sqrt_q } else { &self.sqrt_qf };
        for i in 0..n {
            r[i] = w[i] * (x[i] - self.state_ref[(k, i)]);
        }
        for (j, rj) in r[n..].iter_mut().enumerate() {
            *rj = match u {
                Some(u) => self.sqrt_r[j] * (u[j] - self.control_ref[(k, j)]),
                None => 0.0,
            };
        }
        Ok(())
    }

    fn jacobian_structure(&self, jx: &mut [bool], ju: &mut [bool]) {
        let (n, m) = (self.sqrt_q.len(), self.sqrt_r.len());
        jx.fill(false);
        ju.fill(false);
        for i in 0..n {
            jx[i * n + i] = true;
        }
        for j in 0..m {
            ju[(n + j) * m + j] = true;
        }
    }

    /// The residuals are linear: zero.
    fn weighted_hessian(
        &self,
        _k: usize,
        _x: &[f64],
        _u: Option<&[f64]>,
        _w: &[f64],
        hess: &mut [f64],
    ) -> Result<bool> {
        hess.fill(0.0);
        Ok(true)
    }

    fn jacobians(&self, _k: usize, _x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> Result<()> {
        let (n, m) = (self.sqrt_q.len(), self.sqrt_r.len());
        let w = if u.is_some() { &self.sqrt_q } else { &self.sqrt_qf };
        jx.fill(0.0);
        ju.fill(0.0);
        for i in 0..n {
            jx[i * n + i] = w[i];
        }
        if u.is_some() {
            for j in 0..m {
                ju[(n + j) * m + j] = self.sqrt_r[j];
            }
        }
        Ok(())
    }
}

/// The consistency weight $\lambda_k$ of each step.
#[derive(Debug, Clone, PartialEq)]
pub enum Lambda {
    /// The same $\lambda$ at every step.
    Constant(f64),
    /// One $\lambda_k$ per step $k = 0, \dots, N-1$.
    PerStep(Vec<f64>),
}

impl Lambda {
    /// Per-step weights from the model's confidence along a trajectory:
    /// $\lambda_k = g(\text{confidence}(x_k, u_k))$, `default` where the model
    /// has no confidence. The weights are fixed for a solve (evaluate them at
    /// the initial plan, or between solves for a schedule).
    pub fn from_confidence<M: Model>(
        model: &M,
        states: &Mat<f64>,
        controls: &Mat<f64>,
        default: f64,
        g: impl Fn(f64) -> f64,
    ) -> Lambda {
        let x = |k: usize| (0..states.ncols()).map(|i| states[(k, i)]).collect::<Vec<_>>();
        let u = |k: usize| (0..controls.ncols()).map(|j| controls[(k, j)]).collect::<Vec<_>>();
        Lambda::PerStep(
            (0..controls.nrows())
                .map(|k| model.confidence(&x(k), &u(k)).map_or(default, &g))
                .collect(),
        )
    }

    fn resolve(&self, horizon: usize) -> Result<Vec<f64>> {
        let values = match self {
            Lambda::Constant(l) => vec![*l; horizon],
            Lambda::PerStep(v) => {
                expect_len("lambda per step", horizon, v.len())?;
                v.clone()
            }
        };
        check_finite("lambda", &values)?;
        if let Some(k) = values.iter().position(|&l| l < 0.0) {
            return Err(TrajoptError::InvalidParameter {
                name: "lambda",
                reason: format!("lambda[{k}] = {} is negative", values[k]),
            });
        }
        Ok(values)
    }
}

/// The criterion split into its parts (all squared norms as in the module
/// docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CostBreakdown {
    /// Everything: task + inconsistency + initial-state penalty.
    pub total: f64,
    /// $\sum_k c(x_k, u_k)$.
    pub task: f64,
    /// $\sum_k \lambda_k s^2 \lVert x_{k+1} - f(x_k, u_k) \rVert^2$.
    pub inconsistency: f64,
    /// The initial-state penalty.
    pub initial_state: f64,
    /// $\max_k \lVert x_{k+1} - f(x_k, u_k) \rVert_\infty$ (unweighted).
    pub max_mismatch: f64,
}

/// Eq. 3 over basis coefficients; see the [module docs](self).
///
/// It is a [`LeastSquaresProblem`] (for [`GaussNewton`](crate::GaussNewton))
/// and evaluates its scalar cost for derivative-free solvers
/// ([`cost`](Self::cost)).
pub struct Eq3Problem<M, C> {
    model: M,
    cost: C,
    n: usize,
    m: usize,
    horizon: usize,
    phi_x: SparseRowMat<usize, f64>,
    phi_u: SparseRowMat<usize, f64>,
    lambda: Vec<f64>,
    scale: f64,
    initial_state: Option<(Vec<f64>, f64)>,
    pattern: SymbolicSparseRowMat<usize>,
    /// Position in the Jacobian's values of each term of `for_each_term`.
    jacobian_slots: Vec<usize>,
    /// Pattern of the second-order term (both triangles, by columns), built
    /// on first use (only the Newton mode needs it).
    hessian_pattern: std::sync::OnceLock<SymbolicSparseColMat<usize>>,
    bounds: Option<LinearBounds>,
}

impl<M, C> std::fmt::Debug for Eq3Problem<M, C> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (lo, hi) = self
            .lambda
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &l| (a.min(l), b.max(l)));
        f.debug_struct("Eq3Problem")
            .field("state_dim", &self.n)
            .field("control_dim", &self.m)
            .field("horizon", &self.horizon)
            .field("state_coeffs", &self.phi_x.ncols())
            .field("control_coeffs", &self.phi_u.ncols())
            .field("lambda_range", &(lo, hi))
            .field("consistency_scale", &self.scale)
            .field("initial_state", &self.initial_state)
            .field("bounded_quantities", &self.bounds.as_ref().map_or(0, |b| b.a.nrows()))
            .finish()
    }
}

impl<M: Model, C: StageCost> Eq3Problem<M, C> {
    /// The problem on sample times `times` ($t_0 < \dots < t_N$, inside
    /// both bases' domains); controls are sampled at $t_0, \dots, t_{N-1}$.
    pub fn new(
        model: M,
        cost: C,
        state_basis: &impl TrajectoryBasis,
        control_basis: &impl TrajectoryBasis,
        times: &[f64],
        lambda: Lambda,
    ) -> Result<Self> {
        check_finite("times", times)?;
        if times.len() < 2 {
            return Err(TrajoptError::InvalidParameter {
                name: "times",
                reason: format!("need at least two sample times, got {}", times.len()),
            });
        }
        if let Some(k) = (1..times.len()).find(|&k| times[k] <= times[k - 1]) {
            return Err(TrajoptError::InvalidParameter {
                name: "times",
                reason: format!(
                    "sample times must increase: times[{k}] = {} after {}",
                    times[k],
                    times[k - 1]
                ),
            });
        }
        let horizon = times.len() - 1;
        let (n, m) = (model.state_dim(), model.control_dim());
        if n == 0 {
            return Err(TrajoptError::InvalidParameter {
                name: "model",
                reason: "the state dimension is zero".into(),
            });
        }
        let phi_x = state_basis.design_matrix_rows(times, 0)?;
        let phi_u = control_basis.design_matrix_rows(&times[..horizon], 0)?;
        let lambda = lambda.resolve(horizon)?;
        let mut problem = Self {
            model,
            cost,
            n,
            m,
            horizon,
            phi_x,
            phi_u,
            lambda,
            scale: 1.0,
            initial_state: None,
            pattern: SymbolicSparseRowMat::new_checked(0, 0, vec![0], None, vec![]),
            jacobian_slots: Vec::new(),
            hessian_pattern: std::sync::OnceLock::new(),
            bounds: None,
        };
        problem.rebuild_patterns();
        Ok(problem)
    }

    /// Scales the dynamics mismatch by `scale` ($s$ in the module docs;
    /// $1 / \Delta t$ measures it in rate units).
    pub fn with_consistency_scale(mut self, scale: f64) -> Result<Self> {
        if !(scale.is_finite() && scale > 0.0) {
            return Err(TrajoptError::InvalidParameter {
                name: "consistency scale",
                reason: format!("must be finite and positive, got {scale}"),
            });
        }
        self.scale = scale;
        Ok(self)
    }

    /// Adds the penalty $w_0 \lVert x_0 - \bar x_0 \rVert^2$ fixing the initial state.
    pub fn with_initial_state(mut self, x0: &[f64], weight: f64) -> Result<Self> {
        expect_len("initial state", self.n, x0.len())?;
        check_finite("initial state", x0)?;
        if !(weight.is_finite() && weight > 0.0) {
            return Err(TrajoptError::InvalidParameter {
                name: "initial state weight",
                reason: format!("must be finite and positive, got {weight}"),
            });
        }
        self.initial_state = Some((x0.to_vec(), weight));
        self.rebuild_patterns();
        Ok(self)
    }

    /// Box bounds `lower[i] <= x_{k,i} <= upper[i]` on every state channel at
    /// every sample time (infinite entries leave a side free), enforced by
    /// [`GaussNewton`](crate::GaussNewton) through a QP step.
    pub fn with_state_bounds(self, lower: &[f64], upper: &[f64]) -> Result<Self> {
        expect_len("state lower bounds", self.n, lower.len())?;
        expect_len("state upper bounds", self.n, upper.len())?;
        let rows = (0..=self.horizon).collect::<Vec<_>>();
        self.add_bounds(true, &rows, lower, upper)
    }

    /// Box bounds on every control channel at every control sample time
    /// (e.g. acceleration limits); see [`with_state_bounds`](Self::with_state_bounds).
    pub fn with_control_bounds(self, lower: &[f64], upper: &[f64]) -> Result<Self> {
        expect_len("control lower bounds", self.m, lower.len())?;
        expect_len("control upper bounds", self.m, upper.len())?;
        let rows = (0..self.horizon).collect::<Vec<_>>();
        self.add_bounds(false, &rows, lower, upper)
    }

    fn add_bounds(mut self, state: bool, samples: &[usize], lower: &[f64], upper: &[f64]) -> Result<Self> {
        let mut row_ptr = vec![0];
        let (mut cols, mut vals, mut lo, mut hi) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        if let Some(b) = &self.bounds {
            for i in 0..b.a.nrows() {
                cols.extend_from_slice(b.a.symbolic().col_idx_of_row_raw(i));
                vals.extend_from_slice(b.a.val_of_row(i));
                row_ptr.push(cols.len());
            }
            lo.extend_from_slice(&b.lower);
            hi.extend_from_slice(&b.upper);
        }
        for (ch, (&l, &u)) in lower.iter().zip(upper).enumerate() {
            if l == f64::NEG_INFINITY && u == f64::INFINITY {
                continue;
            }
            for &k in samples {
                let entries: Vec<(usize, f64)> = if state {
                    self.state_cols(k, ch).collect()
                } else {
                    self.control_cols(k, ch).collect()
                };
                for (c, v) in entries {
                    cols.push(c);
                    vals.push(v);
                }
                row_ptr.push(cols.len());
                lo.push(l);
                hi.push(u);
            }
        }
        let n_rows = lo.len();
        let a = SparseRowMat::new(
            SymbolicSparseRowMat::new_checked(n_rows, self.n_params(), row_ptr, None, cols),
            vals,
        );
        let bounds = LinearBounds {
            a,
            lower: lo,
            upper: hi,
        };
        bounds.validate()?;
        self.bounds = Some(bounds);
        Ok(self)
    }

    /// Number of state coefficients per channel.
    pub fn n_state_coeffs(&self) -> usize {
        self.phi_x.ncols()
    }

    /// Number of control coefficients per channel.
    pub fn n_control_coeffs(&self) -> usize {
        self.phi_u.ncols()
    }

    /// The horizon $N$ (number of steps).
    pub fn horizon(&self) -> usize {
        self.horizon
    }

    /// Replaces the consistency weights, keeping everything else: for a
    /// continuation in $\lambda$, each solve warm-started from the last.
    /// The Jacobian's pattern is rebuilt (a $\lambda_k$ of zero drops its
    /// rows' model entries), so a solver must be restarted afterwards.
    ///
    /// ```
    /// # use faer::Mat;
    /// # use splines::BSplineBasis;
    /// # use trajopt::{Eq3Problem, Lambda, TrackingCost, models::LinearModel};
    /// let model = LinearModel::new(Mat::identity(1, 1), Mat::identity(1, 1))?;
    /// let cost = TrackingCost::new(Mat::zeros(5, 1), Mat::zeros(4, 1), &[1.0], &[1.0], &[1.0])?;
    /// let basis = BSplineBasis::clamped_uniform(5, 3, 0.0, 4.0)?;
    /// let times = [0.0, 1.0, 2.0, 3.0, 4.0];
    /// let mut p = Eq3Problem::new(model, cost, &basis, &basis, &times, Lambda::Constant(1.0))?;
    /// p.set_lambda(Lambda::Constant(10.0))?;
    /// assert_eq!(p.lambda(), &[10.0; 4]);
    /// assert!(p.set_lambda(Lambda::Constant(-1.0)).is_err());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn set_lambda(&mut self, lambda: Lambda) -> Result<()> {
        self.lambda = lambda.resolve(self.horizon)?;
        self.rebuild_patterns();
        Ok(())
    }

    /// The per-step consistency weights $\lambda_k$.
    pub fn lambda(&self) -> &[f64] {
        &self.lambda
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The parameter vector $\theta$ of coefficient matrices $C_x$
    /// (`n_state_coeffs` $\times n$) and $C_u$ (`n_control_coeffs` $\times m$).
    pub fn pack(&self, cx: &Mat<f64>, cu: &Mat<f64>) -> Result<Vec<f64>> {
        expect_len("state coefficient rows", self.n_state_coeffs(), cx.nrows())?;
        expect_len("state coefficient columns", self.n, cx.ncols())?;
        expect_len("control coefficient rows", self.n_control_coeffs(), cu.nrows())?;
        expect_len("control coefficient columns", self.m, cu.ncols())?;
        let mut theta = Vec::with_capacity(self.n_params());
        for mat in [cx, cu] {
            for j in 0..mat.ncols() {
                theta.extend(mat.col(j).iter());
            }
        }
        check_finite("coefficients", &theta)?;
        Ok(theta)
    }

    /// The coefficient matrices $(C_x, C_u)$ of a parameter vector.
    pub fn unpack(&self, theta: &[f64]) -> Result<(Mat<f64>, Mat<f64>)> {
        expect_len("parameters", self.n_params(), theta.len())?;
        let (ncx, ncu) = (self.n_state_coeffs(), self.n_control_coeffs());
        let off = ncx * self.n;
        Ok((
            Mat::from_fn(ncx, self.n, |j, i| theta[i * ncx + j]),
            Mat::from_fn(ncu, self.m, |j, i| theta[off + i * ncu + j]),
        ))
    }

    /// States $(N+1) \times n$ and controls $N \times m$ of a parameter vector.
    pub fn trajectory(&self, theta: &[f64]) -> Result<(Mat<f64>, Mat<f64>)> {
        expect_len("parameters", self.n_params(), theta.len())?;
        let (x, u) = self.sample(theta);
        Ok((
            Mat::from_fn(self.horizon + 1, self.n, |k, i| x[k * self.n + i]),
            Mat::from_fn(self.horizon, self.m, |k, j| u[k * self.m + j]),
        ))
    }

    /// States (row-major, $(N+1) n$) and controls (row-major, $N m$).
    fn sample(&self, theta: &[f64]) -> (Vec<f64>, Vec<f64>) {
        self.sample_range(theta, 0..self.horizon + 1)
    }

    /// The residuals of the stages `steps` (and, with the last stage, the
    /// initial-state rows) into their rows of `r`; returns those rows.
    fn residuals_range(
        &self,
        theta: &[f64],
        r: &mut [f64],
        steps: std::ops::Range<usize>,
    ) -> Result<std::ops::Range<usize>> {
        expect_len("parameters", self.n_params(), theta.len())?;
        expect_len("residuals", self.n_residuals(), r.len())?;
        let (n, m, nc) = (self.n, self.m, self.cost.n_residuals());
        let horizon = self.horizon;
        let (k0, k1) = (steps.start.min(horizon + 1), steps.end.min(horizon + 1));
        if k0 >= k1 {
            return Ok(0..0);
        }
        let (mut x, u) = self.sample_range(theta, k0..k1);
        let last = k1 == horizon + 1;
        if last && k0 > 0 && self.initial_state.is_some() {
            // the initial-state rows need x_0
            let (x0, _) = self.sample_range(theta, 0..0);
            x[..n].copy_from_slice(&x0[..n]);
        }
        // f(x_k, u_k) for every step at once (a model may evaluate them in parallel)
        let k_model = k1.min(horizon);
        let mut next = vec![0.0; (k_model - k0) * n];
        self.model
            .step_batch(&x[k0 * n..k_model * n], &u[k0 * m..k_model * m], &mut next)?;
        let first_row = k0 * (nc + n);
        let mut row = first_row;
        for k in k0..k1 {
            let xk = &x[k * n..(k + 1) * n];
            let uk = (k < horizon).then(|| &u[k * m..(k + 1) * m]);
            self.cost.residuals(k, xk, uk, &mut r[row..row + nc])?;
            row += nc;
            if k < horizon {
                let w = self.scale * self.lambda[k].sqrt();
                for i in 0..n {
                    r[row + i] = w * (x[(k + 1) * n + i] - next[(k - k0) * n + i]);
                }
                row += n;
            }
        }
        if let (true, Some((x0, w0))) = (last, &self.initial_state) {
            let w = w0.sqrt();
            for i in 0..n {
                r[row + i] = w * (x[i] - x0[i]);
            }
            row += n;
        }
        Ok(first_row..row)
    }

    /// The stages of part `part` when stages $0..=N$ are split into `parts`
    /// consecutive runs (the split of the `*_part` methods).
    fn part_steps(&self, part: usize, parts: usize) -> Result<std::ops::Range<usize>> {
        crate::least_squares::check_part(part, parts)?;
        let stages = self.horizon + 1;
        Ok(stages * part / parts..stages * (part + 1) / parts)
    }

    /// [`sample`](Self::sample) at the stages `steps` only: the states
    /// $x_k$ for $k$ from `steps.start` through `steps.end` (the next
    /// state of the last step) and the controls $u_k$ for $k$ in `steps`;
    /// the other entries stay zero.
    fn sample_range(&self, theta: &[f64], steps: std::ops::Range<usize>) -> (Vec<f64>, Vec<f64>) {
        let (ncx, ncu) = (self.n_state_coeffs(), self.n_control_coeffs());
        let off = ncx * self.n;
        let mut x = vec![0.0; (self.horizon + 1) * self.n];
        for k in steps.start.min(self.horizon + 1)..=steps.end.min(self.horizon) {
            let cols = self.phi_x.symbolic().col_idx_of_row_raw(k);
            let vals = self.phi_x.val_of_row(k);
            for i in 0..self.n {
                x[k * self.n + i] = cols.iter().zip(vals).map(|(&j, &v)| v * theta[i * ncx + j]).sum();
            }
        }
        let mut u = vec![0.0; self.horizon * self.m];
        for k in steps.start.min(self.horizon)..steps.end.min(self.horizon) {
            let cols = self.phi_u.symbolic().col_idx_of_row_raw(k);
            let vals = self.phi_u.val_of_row(k);
            for i in 0..self.m {
                u[k * self.m + i] = cols.iter().zip(vals).map(|(&j, &v)| v * theta[off + i * ncu + j]).sum();
            }
        }
        (x, u)
    }

    /// The criterion and its parts at $\theta$. A model or cost returning a
    /// non-finite value gives a non-finite total (derivative-free solvers
    /// treat it as $+\infty$).
    pub fn cost_breakdown(&self, theta: &[f64]) -> Result<CostBreakdown> {
        expect_len("parameters", self.n_params(), theta.len())?;
        let (x, u) = self.sample(theta);
        let (n, m, nc) = (self.n, self.m, self.cost.n_residuals());
        let mut r = vec![0.0; nc];
        let mut next = vec![0.0; n];
        let mut out = CostBreakdown {
            total: 0.0,
            task: 0.0,
            inconsistency: 0.0,
            initial_state: 0.0,
            max_mismatch: 0.0,
        };
        for k in 0..=self.horizon {
            let xk = &x[k * n..(k + 1) * n];
            let uk = (k < self.horizon).then(|| &u[k * m..(k + 1) * m]);
            self.cost.residuals(k, xk, uk, &mut r)?;
            out.task += r.iter().map(|v| v * v).sum::<f64>();
            if let Some(uk) = uk {
                self.model.step(xk, uk, &mut next)?;
                let mut sq = 0.0;
                for i in 0..n {
                    let d = x[(k + 1) * n + i] - next[i];
                    sq += d * d;
                    out.max_mismatch = out.max_mismatch.max(d.abs());
                }
                out.inconsistency += self.lambda[k] * self.scale * self.scale * sq;
            }
        }
        if let Some((x0, w)) = &self.initial_state {
            out.initial_state = w * x0.iter().zip(&x[..n]).map(|(a, b)| (b - a) * (b - a)).sum::<f64>();
        }
        out.total = out.task + out.inconsistency + out.initial_state;
        Ok(out)
    }

    /// The scalar criterion $C(\theta)$ ([`CostBreakdown::total`]).
    pub fn cost(&self, theta: &[f64]) -> Result<f64> {
        Ok(self.cost_breakdown(theta)?.total)
    }

    fn rows_per_step(&self) -> usize {
        self.cost.n_residuals() + self.n
    }

    /// Columns of a state channel's coefficients touched by $\Phi_x$ row `k`.
    fn state_cols(&self, k: usize, channel: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let ncx = self.n_state_coeffs();
        let cols = self.phi_x.symbolic().col_idx_of_row_raw(k);
        let vals = self.phi_x.val_of_row(k);
        cols.iter().zip(vals).map(move |(&j, &v)| (channel * ncx + j, v))
    }

    /// Columns of a control channel's coefficients touched by $\Phi_u$ row `k`.
    fn control_cols(&self, k: usize, channel: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let off = self.n_state_coeffs() * self.n;
        let ncu = self.n_control_coeffs();
        let cols = self.phi_u.symbolic().col_idx_of_row_raw(k);
        let vals = self.phi_u.val_of_row(k);
        cols.iter().zip(vals).map(move |(&j, &v)| (off + channel * ncu + j, v))
    }

    fn rebuild_patterns(&mut self) {
        self.pattern = self.build_pattern();
        self.jacobian_slots = self.build_jacobian_slots();
        self.hessian_pattern = std::sync::OnceLock::new();
    }

    /// Which pairs of local variables $z = (x_k, u_k)$ the second
    /// derivatives can couple: (stage, terminal stage, model), row-major
    /// boolean matrices of sides $n+m$, $n$, $n+m$. A second derivative
    /// $\partial^2 r / \partial z_a \partial z_b$ can be nonzero only if $r$
    /// depends on both $z_a$ and $z_b$, so the Jacobian structures give them.
    fn local_hessian_structure(&self) -> (Vec<bool>, Vec<bool>, Vec<bool>) {
        let (n, m, nc) = (self.n, self.m, self.cost.n_residuals());
        let nz = n + m;
        let (mut bx, mut bu) = (vec![false; nc * n], vec![false; nc * m]);
        self.cost.jacobian_structure(&mut bx, &mut bu);
        let (mut mx, mut mu) = (vec![false; n * n], vec![false; n * m]);
        self.model.jacobian_structure(&mut mx, &mut mu);
        let pairs = |rows: usize, jx: &[bool], ju: &[bool], dim: usize| {
            let mut out = vec![false; dim * dim];
            for a in 0..rows {
                let z: Vec<usize> = (0..dim)
                    .filter(|&c| if c < n { jx[a * n + c] } else { ju[a * m + c - n] })
                    .collect();
                for &i in &z {
                    for &j in &z {
                        out[i * dim + j] = true;
                    }
                }
            }
            out
        };
        (pairs(nc, &bx, &bu, nz), pairs(nc, &bx, &bu, n), pairs(n, &mx, &mu, nz))
    }

    /// The coefficient columns (and basis values) of local variable `a` of
    /// $z_k = (x_k, u_k)$.
    fn local_cols(&self, k: usize, a: usize, out: &mut Vec<(usize, f64)>) {
        out.clear();
        if a < self.n {
            out.extend(self.state_cols(k, a).filter(|e| e.1 != 0.0));
        } else {
            out.extend(self.control_cols(k, a - self.n).filter(|e| e.1 != 0.0));
        }
    }

    /// The pattern of $S = \sum_i r_i \nabla^2 r_i$ over the coefficients:
    /// $S = \sum_k \Phi_k^\top S_k \Phi_k$ with $S_k$ local to step $k$.
    fn hessian_pattern(&self) -> &SymbolicSparseColMat<usize> {
        self.hessian_pattern.get_or_init(|| self.build_hessian_pattern())
    }

    fn build_hessian_pattern(&self) -> SymbolicSparseColMat<usize> {
        let (n, m) = (self.n, self.m);
        let nz = n + m;
        let (stage, terminal, model) = self.local_hessian_structure();
        let n_p = self.n_params();
        let mut columns: Vec<Vec<usize>> = vec![Vec::new(); n_p];
        let mut cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); nz];
        for k in 0..=self.horizon {
            let dim = if k == self.horizon { n } else { nz };
            for (a, c) in cols.iter_mut().enumerate().take(dim) {
                self.local_cols(k, a, c);
            }
            for a in 0..dim {
                for b in 0..dim {
                    let coupled = if k == self.horizon {
                        terminal[a * n + b]
                    } else {
                        stage[a * nz + b] || (self.lambda[k] > 0.0 && model[a * nz + b])
                    };
                    if !coupled {
                        continue;
                    }
                    for &(cb, _) in &cols[b] {
                        columns[cb].extend(cols[a].iter().map(|e| e.0));
                    }
                }
            }
        }
        let mut col_ptr = vec![0];
        let mut row_idx = Vec::new();
        for mut c in columns {
            c.sort_unstable();
            c.dedup();
            row_idx.extend(c);
            col_ptr.push(row_idx.len());
        }
        SymbolicSparseColMat::new_checked(n_p, n_p, col_ptr, None, row_idx)
    }

    /// The second-order term of step `k` over its local variables,
    /// $\sum_i r_i \nabla^2 r_i$ for the step's cost and consistency
    /// residuals, into `hz` (row-major, side $n + m$, or $n$ at the
    /// terminal step; `hm` and `w` are workspace); false if the cost or the
    /// model has no second derivatives.
    fn local_hessian(
        &self,
        k: usize,
        x: &[f64],
        u: &[f64],
        r: &[f64],
        (hz, hm, w): (&mut [f64], &mut [f64], &mut [f64]),
    ) -> Result<bool> {
        let (n, m, nc) = (self.n, self.m, self.cost.n_residuals());
        let xk = &x[k * n..(k + 1) * n];
        let row = k * (nc + n);
        hz.fill(0.0);
        if k == self.horizon {
            return self
                .cost
                .weighted_hessian(k, xk, None, &r[row..row + nc], &mut hz[..n * n]);
        }
        let uk = &u[k * m..(k + 1) * m];
        if !self.cost.weighted_hessian(k, xk, Some(uk), &r[row..row + nc], hz)? {
            return Ok(false);
        }
        if self.lambda[k] > 0.0 {
            // r = s sqrt(lambda) (x_{k+1} - f): its second derivative is -s sqrt(lambda) f''
            let ws = self.scale * self.lambda[k].sqrt();
            for (wi, ri) in w.iter_mut().zip(&r[row + nc..row + nc + n]) {
                *wi = -ws * ri;
            }
            hm.fill(0.0);
            if !self.model.weighted_hessian(xk, uk, w, hm)? {
                return Ok(false);
            }
            for (a, b) in hz.iter_mut().zip(hm.iter()) {
                *a += b;
            }
        }
        Ok(true)
    }

    /// $\delta^\top S \delta$ from the per-step second derivatives; see
    /// [`LeastSquaresProblem::second_order_form`]. `None` also when it is
    /// not finite (the solver then probes the residuals instead).
    fn second_order_form_impl(&self, theta: &[f64], r: &[f64], delta: &[f64]) -> Result<Option<f64>> {
        expect_len("parameters", self.n_params(), theta.len())?;
        expect_len("residuals", self.n_residuals(), r.len())?;
        expect_len("direction", self.n_params(), delta.len())?;
        let (n, m) = (self.n, self.m);
        let nz = n + m;
        let (x, u) = self.sample(theta);
        // the basis is linear: the local variables move by the sampled direction
        let (dx, du) = self.sample(delta);
        let (mut hz, mut hm, mut w) = (vec![0.0; nz * nz], vec![0.0; nz * nz], vec![0.0; n]);
        let mut z = vec![0.0; nz];
        let mut form = 0.0;
        for k in 0..=self.horizon {
            if !self.local_hessian(k, &x, &u, r, (&mut hz, &mut hm, &mut w))? {
                return Ok(None);
            }
            let dim = if k == self.horizon { n } else { nz };
            z[..n].copy_from_slice(&dx[k * n..(k + 1) * n]);
            if k < self.horizon {
                z[n..].copy_from_slice(&du[k * m..(k + 1) * m]);
            }
            for a in 0..dim {
                let row: f64 = (0..dim).map(|b| hz[a * dim + b] * z[b]).sum();
                form += z[a] * row;
            }
        }
        Ok(form.is_finite().then_some(form))
    }

    /// Writes $S(\theta)$ into the values of the Hessian pattern; `false`
    /// if the model or the cost has no second derivatives.
    fn hessian_values(&self, theta: &[f64], r: &[f64], values: &mut [f64]) -> Result<bool> {
        expect_len("parameters", self.n_params(), theta.len())?;
        expect_len("residuals", self.n_residuals(), r.len())?;
        expect_len(
            "second-order values",
            self.hessian_pattern().row_idx().len(),
            values.len(),
        )?;
        let (n, m) = (self.n, self.m);
        let nz = n + m;
        let (x, u) = self.sample(theta);
        values.fill(0.0);
        let (mut hz, mut hm, mut w) = (vec![0.0; nz * nz], vec![0.0; nz * nz], vec![0.0; n]);
        let mut cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); nz];
        let mut loaded = vec![false; nz];
        let mut starts: Vec<((usize, usize, usize), Vec<usize>)> = vec![((usize::MAX, 0, 0), Vec::new()); nz * nz];
        let pattern = self.hessian_pattern();
        for k in 0..=self.horizon {
            let terminal = k == self.horizon;
            let dim = if terminal { n } else { nz };
            if !self.local_hessian(k, &x, &u, r, (&mut hz, &mut hm, &mut w))? {
                return Ok(false);
            }
            loaded.fill(false);
            for a in 0..dim {
                for b in 0..dim {
                    let v = hz[a * dim + b];
                    if v == 0.0 {
                        continue;
                    }
                    if !v.is_finite() {
                        return Err(TrajoptError::NotFinite {
                            what: "second derivatives",
                            index: a * dim + b,
                            value: v,
                        });
                    }
                    for c in [a, b] {
                        if !loaded[c] {
                            self.local_cols(k, c, &mut cols[c]);
                            loaded[c] = true;
                        }
                    }
                    let (Some(&(ca0, _)), Some(&(cb0, _))) = (cols[a].first(), cols[b].first()) else {
                        continue;
                    };
                    // where cols[a][0] sits in each column of cols[b]: the same
                    // for the steps that share their basis spans, so cached
                    let cache = &mut starts[a * nz + b];
                    if cache.0 != (ca0, cb0, cols[b].len()) {
                        cache.0 = (ca0, cb0, cols[b].len());
                        cache.1.clear();
                        cache.1.extend(cols[b].iter().map(|&(cb, _)| {
                            pattern.col_ptr()[cb] + pattern.row_idx_of_col_raw(cb).partition_point(|&i| i < ca0)
                        }));
                    }
                    for (&(cb, vb), &first) in cols[b].iter().zip(&cache.1) {
                        let end = pattern.col_ptr()[cb + 1];
                        let rows = pattern.row_idx();
                        // the columns of a increase: walk from the first
                        let mut p = first;
                        for &(ca, va) in &cols[a] {
                            while p < end && rows[p] < ca {
                                p += 1;
                            }
                            if p == end || rows[p] != ca {
                                return Err(TrajoptError::InvalidParameter {
                                    name: "model",
                                    reason: format!(
                                        "a second derivative at step {k} ({a}, {b}) lies outside the Jacobian structure"
                                    ),
                                });
                            }
                            values[p] += v * va * vb;
                        }
                    }
                }
            }
        }
        Ok(true)
    }

    fn build_pattern(&self) -> SymbolicSparseRowMat<usize> {
        let n_rows = self.n_residuals();
        let mut row_ptr = vec![0];
        let mut col_idx = Vec::new();
        let mut entries: Vec<usize> = Vec::new();
        let flush = |entries: &mut Vec<usize>, col_idx: &mut Vec<usize>, row_ptr: &mut Vec<usize>| {
            entries.sort_unstable();
            entries.dedup();
            col_idx.append(entries);
            row_ptr.push(col_idx.len());
        };
        // with unit local derivatives, a term is zero only where the
        // structure, the fixed basis value or lambda_k = 0 makes it so
        let result = self.for_each_term(
            &self.local_structure(),
            |_, d| {
                for v in [&mut d.jx, &mut d.ju, &mut d.fx, &mut d.fu] {
                    v.fill(1.0);
                }
                Ok(())
            },
            |row, c, v| {
                while row_ptr.len() <= row {
                    flush(&mut entries, &mut col_idx, &mut row_ptr);
                }
                if v != 0.0 {
                    entries.push(c);
                }
            },
        );
        debug_assert!(result.is_ok());
        while row_ptr.len() <= n_rows {
            flush(&mut entries, &mut col_idx, &mut row_ptr);
        }
        SymbolicSparseRowMat::new_checked(n_rows, self.n_params(), row_ptr, None, col_idx)
    }

    /// Fills the local derivatives of cost and model at step `k`.
    fn local_derivatives(&self, k: usize, x: &[f64], u: &[f64], d: &mut LocalDerivatives) -> Result<()> {
        let (n, m) = (self.n, self.m);
        let xk = &x[k * n..(k + 1) * n];
        if k == self.horizon {
            return self.cost.jacobians(k, xk, None, &mut d.jx, &mut d.ju);
        }
        let uk = &u[k * m..(k + 1) * m];
        self.cost.jacobians(k, xk, Some(uk), &mut d.jx, &mut d.ju)?;
        if !self.model.jacobians(xk, uk, &mut d.fx, &mut d.fu)? {
            central_differences(&self.model, xk, uk, &mut d.fx, &mut d.fu)?;
        }
        Ok(())
    }

    /// The structural nonzeros of the local derivatives.
    fn local_structure(&self) -> LocalStructure {
        let (n, m, nc) = (self.n, self.m, self.cost.n_residuals());
        let (mut jx, mut ju) = (vec![false; nc * n], vec![false; nc * m]);
        self.cost.jacobian_structure(&mut jx, &mut ju);
        let (mut fx, mut fu) = (vec![false; n * n], vec![false; n * m]);
        self.model.jacobian_structure(&mut fx, &mut fu);
        LocalStructure { jx, ju, fx, fu }
    }

    /// Calls `term(row, column, value)` for every term of the Jacobian (a
    /// column may repeat within a row: the terms add up), in an order that
    /// depends only on the structure, not on $\theta$; `local(k, d)` fills
    /// the local derivatives of step `k` first.
    fn for_each_term(
        &self,
        st: &LocalStructure,
        mut local: impl FnMut(usize, &mut LocalDerivatives) -> Result<()>,
        mut term: impl FnMut(usize, usize, f64),
    ) -> Result<()> {
        let (n, m, nc) = (self.n, self.m, self.cost.n_residuals());
        let mut d = LocalDerivatives {
            jx: vec![0.0; nc * n],
            ju: vec![0.0; nc * m],
            fx: vec![0.0; n * n],
            fu: vec![0.0; n * m],
        };
        let mut row = 0;
        for k in 0..=self.horizon {
            local(k, &mut d)?;
            let terminal = k == self.horizon;
            for a in 0..nc {
                for i in (0..n).filter(|&i| st.jx[a * n + i]) {
                    let g = d.jx[a * n + i];
                    self.state_cols(k, i).for_each(|(c, v)| term(row, c, g * v));
                }
                if !terminal {
                    for j in (0..m).filter(|&j| st.ju[a * m + j]) {
                        let g = d.ju[a * m + j];
                        self.control_cols(k, j).for_each(|(c, v)| term(row, c, g * v));
                    }
                }
                row += 1;
            }
            if terminal {
                break;
            }
            let w = self.scale * self.lambda[k].sqrt();
            for i in 0..n {
                self.state_cols(k + 1, i).for_each(|(c, v)| term(row, c, w * v));
                for c in (0..n).filter(|&c| st.fx[i * n + c]) {
                    let g = -w * d.fx[i * n + c];
                    self.state_cols(k, c).for_each(|(col, v)| term(row, col, g * v));
                }
                for j in (0..m).filter(|&j| st.fu[i * m + j]) {
                    let g = -w * d.fu[i * m + j];
                    self.control_cols(k, j).for_each(|(col, v)| term(row, col, g * v));
                }
                row += 1;
            }
        }
        if let Some((_, w0)) = &self.initial_state {
            let w = w0.sqrt();
            for i in 0..n {
                self.state_cols(0, i).for_each(|(c, v)| term(row, c, w * v));
                row += 1;
            }
        }
        debug_assert_eq!(row, self.n_residuals());
        Ok(())
    }

    /// Where each term of [`for_each_term`](Self::for_each_term) goes in
    /// the Jacobian's values (`usize::MAX`: a structural zero, dropped).
    fn build_jacobian_slots(&self) -> Vec<usize> {
        let row_ptr = self.pattern.row_ptr();
        let col_idx = self.pattern.col_idx();
        let mut slots = Vec::new();
        let result = self.for_each_term(
            &self.local_structure(),
            |_, _| Ok(()),
            |row, c, _| {
                let (start, end) = (row_ptr[row], row_ptr[row + 1]);
                slots.push(col_idx[start..end].binary_search(&c).map_or(usize::MAX, |p| start + p));
            },
        );
        debug_assert!(result.is_ok());
        slots
    }
}

/// Which local derivatives can be nonzero (see [`LocalDerivatives`]).
struct LocalStructure {
    jx: Vec<bool>,
    ju: Vec<bool>,
    fx: Vec<bool>,
    fu: Vec<bool>,
}

#[derive(Clone)]
struct LocalDerivatives {
    jx: Vec<f64>,
    ju: Vec<f64>,
    fx: Vec<f64>,
    fu: Vec<f64>,
}

/// Central differences of the model, step $\sqrt[3]{\epsilon} \max(1, |z|)$
/// per coordinate.
fn central_differences<M: Model>(model: &M, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> Result<()> {
    let (n, m) = (x.len(), u.len());
    let mut xp = x.to_vec();
    let mut up = u.to_vec();
    let (mut plus, mut minus) = (vec![0.0; n], vec![0.0; n]);
    let eps = f64::EPSILON.cbrt();
    for c in 0..n + m {
        let z = if c < n { x[c] } else { u[c - n] };
        let h = eps * z.abs().max(1.0);
        let set = |xp: &mut Vec<f64>, up: &mut Vec<f64>, v: f64| {
            if c < n { xp[c] = v } else { up[c - n] = v }
        };
        set(&mut xp, &mut up, z + h);
        model.step(&xp, &up, &mut plus)?;
        set(&mut xp, &mut up, z - h);
        model.step(&xp, &up, &mut minus)?;
        set(&mut xp, &mut up, z);
        for i in 0..n {
            let g = (plus[i] - minus[i]) / (2.0 * h);
            if c < n {
                fx[i * n + c] = g;
            } else {
                fu[i * m + c - n] = g;
            }
        }
    }
    Ok(())
}

impl<M: Model, C: StageCost> LeastSquaresProblem for Eq3Problem<M, C> {
    fn n_params(&self) -> usize {
        self.n_state_coeffs() * self.n + self.n_control_coeffs() * self.m
    }

    fn n_residuals(&self) -> usize {
        let init = if self.initial_state.is_some() { self.n } else { 0 };
        self.horizon * self.rows_per_step() + self.cost.n_residuals() + init
    }

    fn residuals(&self, theta: &[f64], r: &mut [f64]) -> Result<()> {
        self.residuals_range(theta, r, 0..self.horizon + 1).map(|_| ())
    }

    fn residuals_part(
        &self,
        part: usize,
        parts: usize,
        theta: &[f64],
        r: &mut [f64],
    ) -> Result<std::ops::Range<usize>> {
        self.residuals_range(theta, r, self.part_steps(part, parts)?)
    }

    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
        self.pattern.clone()
    }

    fn bounds(&self) -> Option<&LinearBounds> {
        self.bounds.as_ref()
    }

    fn second_order_pattern(&self) -> Option<SymbolicSparseColMat<usize>> {
        Some(self.hessian_pattern().clone())
    }

    fn second_order_values(&self, theta: &[f64], r: &[f64], values: &mut [f64]) -> Result<bool> {
        self.hessian_values(theta, r, values)
    }

    fn second_order_form(&self, theta: &[f64], r: &[f64], delta: &[f64]) -> Result<Option<f64>> {
        self.second_order_form_impl(theta, r, delta)
    }

    fn band_layout(&self) -> Option<BandLayout> {
        Some(self.band_layout_impl())
    }

    fn band_normal_equations(
        &self,
        theta: &[f64],
        r: &[f64],
        layout: &BandLayout,
        h: &mut BandedSym,
        grad: &mut [f64],
        second_order: Option<&mut [f64]>,
    ) -> Result<bool> {
        self.band_normal_equations_impl(theta, r, layout, h, grad, second_order, 0..self.horizon + 1)
    }

    fn band_normal_equations_part(
        &self,
        part: usize,
        parts: usize,
        theta: &[f64],
        r: &[f64],
        layout: &BandLayout,
        h: &mut BandedSym,
        grad: &mut [f64],
        second_order: Option<&mut [f64]>,
    ) -> Result<bool> {
        let steps = self.part_steps(part, parts)?;
        self.band_normal_equations_impl(theta, r, layout, h, grad, second_order, steps)
    }

    fn band_second_order_part(
        &self,
        part: usize,
        parts: usize,
        theta: &[f64],
        r: &[f64],
        layout: &BandLayout,
        s: &mut BandedSym,
    ) -> Result<bool> {
        let steps = self.part_steps(part, parts)?;
        self.band_second_order_impl(theta, r, layout, s, steps)
    }

    fn jacobian_values(&self, theta: &[f64], values: &mut [f64]) -> Result<()> {
        expect_len("parameters", self.n_params(), theta.len())?;
        expect_len("jacobian values", self.pattern.col_idx().len(), values.len())?;
        let (x, u) = self.sample(theta);
        values.fill(0.0);
        let slots = &self.jacobian_slots;
        let mut t = 0;
        self.for_each_term(
            &self.local_structure(),
            |k, d| self.local_derivatives(k, &x, &u, d),
            |_, _, v| {
                let slot = slots[t];
                t += 1;
                if slot != usize::MAX {
                    values[slot] += v;
                }
            },
        )
    }
}

/// Eq. 3's scalar criterion for [`Powell`](crate::powell::Powell).
impl<M: Model, C: StageCost> crate::powell::Objective for Eq3Problem<M, C> {
    fn cost(&self, theta: &[f64]) -> Result<f64> {
        Eq3Problem::cost(self, theta)
    }
}

/// Eq. 3's scalar criterion for argmin's solvers (parameters as `Vec<f64>`).
impl<M: Model, C: StageCost> argmin::core::CostFunction for Eq3Problem<M, C> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, theta: &Self::Param) -> std::result::Result<f64, argmin::core::Error> {
        Eq3Problem::cost(self, theta).map_err(argmin::core::Error::new)
    }
}

fn expect_len(what: &'static str, expected: usize, actual: usize) -> Result<()> {
    if expected != actual {
        return Err(TrajoptError::DimensionMismatch { what, expected, actual });
    }
    Ok(())
}
