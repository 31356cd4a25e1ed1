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

use crate::error::{Result, TrajoptError, check_finite, expect_len};
use crate::least_squares::{BandForm, LeastSquaresProblem, LinearBounds, Part, SecondOrder};

mod band_assembly;
mod jacobian;
mod lambda;
mod second_order;
mod stage_cost;

pub use lambda::Lambda;
pub use stage_cost::TrackingCost;
/// Eq. 3's dynamics model: the workspace's one model contract,
/// [`systems::Dynamics`], under the name this crate has always used. How
/// Eq. 3 uses it: [`Eq3Problem`] calls `step_batch` (and `jacobians_batch`)
/// once per residual (Jacobian) evaluation, differences the steps where the
/// model writes no Jacobians, keeps to `jacobian_structure` in its band
/// form, takes exact Newton steps with `weighted_hessian`
/// ([`GaussNewtonSettings::step_model`](crate::GaussNewtonSettings::step_model)),
/// and weighs the consistency term by `confidence` with
/// [`Lambda::from_confidence`].
pub use systems::Dynamics;
pub use systems::StageCost;
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

impl<M: Dynamics, C: StageCost> Eq3Problem<M, C> {
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

    /// The stage cost $c_k$ (e.g. to evaluate one stage of a trajectory).
    pub fn stage_cost(&self) -> &C {
        &self.cost
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
        let (n, m, nc) = (self.n, self.m, self.nc());
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
            self.stage_residuals(k, xk, uk, &mut r[row..row + nc])?;
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
    fn part_steps(&self, part: Part) -> Result<std::ops::Range<usize>> {
        part.check()?;
        let stages = self.horizon + 1;
        Ok(stages * part.index / part.count..stages * (part.index + 1) / part.count)
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
        let (n, m, nc) = (self.n, self.m, self.nc());
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
            self.stage_residuals(k, xk, uk, &mut r)?;
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

    /// The gradient $\nabla C(\theta) = 2 J^\top r$ of the criterion, from
    /// the residuals and the Jacobian that [`GaussNewton`](crate::GaussNewton) uses.
    pub fn gradient(&self, theta: &[f64]) -> Result<Vec<f64>> {
        let mut r = vec![0.0; self.n_residuals()];
        self.residuals(theta, &mut r)?;
        let mut values = vec![0.0; self.pattern.col_idx().len()];
        self.jacobian_values(theta, &mut values)?;
        let mut g = vec![0.0; self.n_params()];
        let row_ptr = self.pattern.row_ptr();
        for (i, ri) in r.iter().enumerate() {
            for idx in row_ptr[i]..row_ptr[i + 1] {
                g[self.pattern.col_idx()[idx]] += 2.0 * values[idx] * ri;
            }
        }
        Ok(g)
    }

    /// The rows of every stage's cost block: the larger of the running
    /// and the terminal counts ([`StageCost::n_terminal_residuals`]); a
    /// stage with fewer fills the rest with zeros (rows that add nothing
    /// to the cost, its gradient or $J^\top J$).
    pub(super) fn nc(&self) -> usize {
        self.cost.n_residuals().max(self.cost.n_terminal_residuals())
    }

    /// The stage's own residual count.
    fn stage_count(&self, terminal: bool) -> usize {
        systems::residual_count(&self.cost, terminal)
    }

    /// The cost's residuals of stage `k` into the first rows of `r` (of
    /// [`nc`](Self::nc) rows), zeros below.
    fn stage_residuals(&self, k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> Result<()> {
        let (own, pad) = r.split_at_mut(self.stage_count(u.is_none()));
        pad.fill(0.0);
        Ok(self.cost.residuals(k, x, u, own)?)
    }

    /// The cost's Jacobians of stage `k` into the first rows of `jx` and
    /// `ju` ([`nc`](Self::nc) rows each), zeros below.
    fn stage_jacobians(&self, k: usize, x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> Result<()> {
        let rows = self.stage_count(u.is_none());
        let (own_x, pad_x) = jx.split_at_mut(rows * self.n);
        let (own_u, pad_u) = ju.split_at_mut(rows * self.m);
        pad_x.fill(0.0);
        pad_u.fill(0.0);
        Ok(self.cost.jacobians(k, x, u, own_x, own_u)?)
    }

    /// The cost's weighted Hessian of stage `k`, the weights of its own
    /// rows (the first of `w`'s [`nc`](Self::nc)).
    fn stage_hessian(&self, k: usize, x: &[f64], u: Option<&[f64]>, w: &[f64], hess: &mut [f64]) -> Result<bool> {
        let rows = self.stage_count(u.is_none());
        Ok(self.cost.weighted_hessian(k, x, u, &w[..rows], hess)?)
    }

    /// The structure of the cost blocks' Jacobians ([`nc`](Self::nc) rows):
    /// the cost's own when every stage has as many residuals; otherwise the
    /// running stages' with every state entry of the terminal stage's rows
    /// (the structure is one for all stages).
    fn stage_structure(&self, jx: &mut [bool], ju: &mut [bool]) {
        let (nr, nt) = (self.cost.n_residuals(), self.cost.n_terminal_residuals());
        if nr == nt {
            self.cost.jacobian_structure(jx, ju);
            return;
        }
        jx.fill(false);
        ju.fill(false);
        self.cost
            .jacobian_structure(&mut jx[..nr * self.n], &mut ju[..nr * self.m]);
        jx[..nt * self.n].fill(true);
    }

    fn rows_per_step(&self) -> usize {
        self.nc() + self.n
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
}

impl<M: Dynamics, C: StageCost> LeastSquaresProblem for Eq3Problem<M, C> {
    fn n_params(&self) -> usize {
        self.n_state_coeffs() * self.n + self.n_control_coeffs() * self.m
    }

    fn n_residuals(&self) -> usize {
        let init = if self.initial_state.is_some() { self.n } else { 0 };
        self.horizon * self.rows_per_step() + self.nc() + init
    }

    fn residuals(&self, theta: &[f64], r: &mut [f64]) -> Result<()> {
        self.residuals_range(theta, r, 0..self.horizon + 1).map(|_| ())
    }

    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
        self.pattern.clone()
    }

    fn jacobian_values(&self, theta: &[f64], values: &mut [f64]) -> Result<()> {
        self.jacobian_values_impl(theta, values)
    }

    fn bounds(&self) -> Option<&LinearBounds> {
        self.bounds.as_ref()
    }

    fn second_order(&self) -> Option<&dyn SecondOrder> {
        Some(self)
    }

    fn band_form(&self) -> Option<&dyn BandForm> {
        Some(self)
    }
}

/// Eq. 3's scalar criterion for [`Powell`](crate::powell::Powell).
impl<M: Dynamics, C: StageCost> crate::powell::Objective for Eq3Problem<M, C> {
    fn cost(&self, theta: &[f64]) -> Result<f64> {
        Eq3Problem::cost(self, theta)
    }
}

/// Eq. 3's scalar criterion for argmin's solvers (parameters as `Vec<f64>`).
#[cfg(feature = "argmin")]
impl<M: Dynamics, C: StageCost> argmin::core::CostFunction for Eq3Problem<M, C> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, theta: &Self::Param) -> std::result::Result<f64, argmin::core::Error> {
        Eq3Problem::cost(self, theta).map_err(argmin::core::Error::new)
    }
}

/// The gradient $2 J^\top r$ for argmin's solvers ([`Eq3Problem::gradient`]).
#[cfg(feature = "argmin")]
impl<M: Dynamics, C: StageCost> argmin::core::Gradient for Eq3Problem<M, C> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;

    fn gradient(&self, theta: &Self::Param) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        Eq3Problem::gradient(self, theta).map_err(argmin::core::Error::new)
    }
}
