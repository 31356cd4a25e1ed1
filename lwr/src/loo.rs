//! Leave-one-out cross-validation in closed form, fitted group by group of
//! a k-d tree over the metric's scaled coordinates, and the early-stopping
//! objective that [`LwrModel::tune`] minimises.

use rayon::prelude::*;

use crate::database::Database;
use crate::error::{LwrError, Result};
use crate::fit::{LocalFit, Scratch, Want, fit_found};
use crate::kdtree::{KdTree, Leaf};
use crate::metric::{FullMetric, Metric, diag_dist2};
use crate::model::LwrModel;
use crate::scale_grad::{GradScratch, residual_derivatives};
use crate::scaled::ScaledMap;
use crate::settings::LwrSettings;

/// Smallest $1 - L_{ii}$ for which a leave-one-out residual is computed.
const MIN_ONE_MINUS_LEVERAGE: f64 = 1e-8;

/// Per point: fitted values, LOO residuals, leverage, undetermined,
/// regularised, and (when asked for) the residuals' derivatives with respect
/// to the logarithms of the scales ($o \times d$, zero for an undetermined
/// point; empty otherwise).
type PointLoo = (Vec<f64>, Vec<f64>, f64, bool, bool, Vec<f64>);

/// Number of blocks of points between the early-stopping checks of a tuning
/// evaluation.
const N_BLOCKS: usize = 32;

/// Smallest number of points in a block.
const MIN_BLOCK: usize = 64;

/// Relative margin by which a partial sum must exceed the acceptance bound
/// before an evaluation is stopped: far above the rounding of the sums
/// ($n \epsilon_{mach} \approx 10^{-10}$ at $n = 10^6$).
pub(crate) const BOUND_MARGIN: f64 = 1e-9;

/// Signature of [`scan_any`] and [`scan_fixed`].
type Scan = fn(&[usize], &[f64], &[f64], &[f64], f64, &mut Vec<(usize, f64)>);

/// Appends `(index, d^2)` for every candidate (indices and row-major
/// inputs) with $d^2 <$ `r2` from `q`, in the candidates' order.
fn scan_any(candidates: &[usize], coords: &[f64], q: &[f64], scales: &[f64], r2: f64, out: &mut Vec<(usize, f64)>) {
    for (&c, x) in candidates.iter().zip(coords.chunks_exact(q.len())) {
        let d2 = diag_dist2(x, q, scales);
        if d2 < r2 {
            out.push((c, d2));
        }
    }
}

/// [`scan_any`] for `D` inputs known at compile time (bitwise the same
/// distances: the same operations in the same order).
fn scan_fixed<const D: usize>(
    candidates: &[usize],
    coords: &[f64],
    q: &[f64],
    scales: &[f64],
    r2: f64,
    out: &mut Vec<(usize, f64)>,
) {
    let (Ok(q), Ok(scales)) = (<&[f64; D]>::try_from(q), <&[f64; D]>::try_from(scales)) else {
        return scan_any(candidates, coords, q, scales, r2, out);
    };
    for (&c, x) in candidates.iter().zip(coords.chunks_exact(D)) {
        let mut d2 = 0.0;
        for j in 0..D {
            let t = scales[j] * (x[j] - q[j]);
            d2 += t * t;
        }
        if d2 < r2 {
            out.push((c, d2));
        }
    }
}

/// [`scan_any`] for a full metric.
fn scan_full(
    candidates: &[usize],
    coords: &[f64],
    q: &[f64],
    metric: &FullMetric,
    r2: f64,
    out: &mut Vec<(usize, f64)>,
) {
    for (&c, x) in candidates.iter().zip(coords.chunks_exact(q.len())) {
        let d2 = metric.dist2(x, q);
        if d2 < r2 {
            out.push((c, d2));
        }
    }
}

/// Largest number of points in a group of [`QueryGroups`].
const GROUP: usize = 32;

/// The database's points in the coordinates of the fit's metric, for
/// batched leave-one-out: a k-d tree over $s_i = (m_j x_{ij})_j$, or
/// $s_i = A x_i$ for a full metric, in which the distance is Euclidean.
///
/// The database's own tree is compact in the inputs' own units, but a tuned
/// metric often weighs the inputs very differently (or ignores some): a
/// leaf of it then spans many support radii along a heavily weighted input,
/// its candidates (which every point of the leaf scans) are many times its
/// points' neighbours, and a box search visits many leaves that are wide
/// in the weighted inputs. A tree built in the scaled coordinates, once per
/// evaluation in $O(n \log n)$, has leaves compact under the metric (the
/// groups of queries) and prunes tightly.
///
/// Its candidates for a group (the points within the support, slightly
/// inflated against rounding, of the group's box in scaled coordinates) are
/// a superset of each query's neighbours; each query then keeps those whose
/// distance, computed exactly as a single query computes it, is within the
/// support. So every fit is still bitwise that of a single query.
struct QueryGroups {
    /// The tree over the scaled coordinates.
    tree: KdTree,
    /// Squared radius of the candidate search: the support radius, inflated.
    r2: f64,
    /// The Euclidean metric of the scaled coordinates.
    euclidean: Metric,
    /// Number of coordinates of the tree's points.
    d: usize,
}

impl QueryGroups {
    fn new(db: &Database, metric: &Metric, radius: f64) -> Self {
        let d = db.n_inputs();
        let inputs = db.inputs();
        // scaled coordinates (without the rows the metric ignores), and the
        // largest magnitude of the terms summed in them (what the rounding of
        // their differences scales with)
        let map = ScaledMap::new(metric, d);
        let k = map.dim();
        let mut magnitude = 0.0f64;
        let mut scaled = Vec::with_capacity(db.len() * k);
        for x in inputs.chunks_exact(d) {
            magnitude = magnitude.max(map.push(x, &mut scaled));
        }
        if k == 0 || !magnitude.is_finite() {
            // a metric that ignores every input (all points are neighbours),
            // or scales so large that the scaled coordinates overflow: group
            // the points in their own units and take every point as a
            // candidate
            return Self {
                tree: KdTree::build(inputs, d),
                r2: f64::INFINITY,
                euclidean: Metric::Diagonal(vec![0.0; d]),
                d,
            };
        }
        Self {
            tree: KdTree::build(&scaled, k),
            r2: ScaledMap::inflated_r2(radius, magnitude, d),
            euclidean: Metric::Diagonal(vec![1.0; k]),
            d: k,
        }
    }

    /// The groups: the leaves of the scaled tree (indices, scaled
    /// coordinates, box), a leaf of more than [`GROUP`] points (identical in
    /// scaled coordinates) cut into pieces with the leaf's box.
    fn leaves(&self) -> Vec<Leaf<'_>> {
        let d = self.d;
        let mut out = Vec::new();
        for leaf in self.tree.leaves() {
            for (indices, coords) in leaf.indices.chunks(GROUP).zip(leaf.coords.chunks(GROUP * d)) {
                out.push(Leaf {
                    indices,
                    coords,
                    lo: leaf.lo,
                    hi: leaf.hi,
                });
            }
        }
        out
    }

    /// Appends the candidates of a group: every point within the inflated
    /// support of its box, in scaled coordinates.
    fn candidates(&self, group: &Leaf<'_>, out: &mut Vec<usize>) {
        self.tree
            .within_box(self.d, group.lo, group.hi, &self.euclidean, self.r2, out);
    }
}

/// Buffers of the leave-one-out fits of one leaf.
#[derive(Default)]
struct LeafScratch {
    /// Indices of the points within the support of the leaf's box, sorted.
    candidates: Vec<usize>,
    /// Their inputs, row-major.
    coords: Vec<f64>,
    /// The fit's buffers.
    fit: Scratch,
    /// The derivatives' buffers.
    grad: GradScratch,
}

/// An objective evaluation that may have stopped early.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Objective {
    /// The exact objective.
    Exact(f64),
    /// A lower bound, already above the acceptance bound.
    Above(f64),
}

/// What every point's leave-one-out residual needs: validated settings and
/// the outputs' mean and variance.
struct LooContext<'a> {
    settings: &'a LwrSettings,
    metric: Metric,
    n: usize,
    o: usize,
    /// Only the points $i$ with $i \bmod$ `stride` $= 0$ are cross-validated
    /// (1: all).
    stride: usize,
    /// Their number.
    n_queries: usize,
    /// Whether to differentiate the residuals with respect to the
    /// logarithms of the scales (a diagonal metric only).
    grad: bool,
    mean: Vec<f64>,
    var: Vec<f64>,
}

impl<'a> LooContext<'a> {
    fn new(model: &LwrModel, settings: &'a LwrSettings, stride: usize) -> Result<Self> {
        let db = model.database();
        settings.validate(db.n_inputs())?;
        if db.is_empty() {
            return Err(LwrError::EmptyDatabase);
        }
        let metric = Metric::of_settings(settings, db.n_inputs());
        let n = db.len();
        let o = db.n_outputs();
        let mut mean = vec![0.0; o];
        for i in 0..n {
            for (m, y) in mean.iter_mut().zip(&db.outputs()[i * o..(i + 1) * o]) {
                *m += y / n as f64;
            }
        }
        let mut var = vec![0.0; o];
        for i in 0..n {
            for ((v, y), m) in var.iter_mut().zip(&db.outputs()[i * o..(i + 1) * o]).zip(&mean) {
                *v += (y - m) * (y - m) / n as f64;
            }
        }
        for v in &mut var {
            if *v <= 0.0 {
                *v = 1.0;
            }
        }
        Ok(Self {
            settings,
            metric,
            n,
            stride: stride.max(1),
            n_queries: n.div_ceil(stride.max(1)),
            grad: false,
            o,
            mean,
            var,
        })
    }

    /// Leave-one-out outcome of point `i` from its fit at $x_i$.
    fn outcome(&self, model: &LwrModel, i: usize, fit: &Result<LocalFit>) -> PointLoo {
        let o = self.o;
        let y = &model.database().outputs()[i * o..(i + 1) * o];
        let mean = &self.mean;
        match fit {
            Ok(fit) => {
                let lii = fit.s[0];
                let fitted = fit.beta[..o].to_vec();
                let one_minus = 1.0 - lii;
                if one_minus >= MIN_ONE_MINUS_LEVERAGE {
                    let e = y.iter().zip(&fitted).map(|(y, f)| (y - f) / one_minus).collect();
                    (fitted, e, lii, false, fit.regularized, Vec::new())
                } else {
                    let e = y.iter().zip(mean).map(|(y, m)| y - m).collect();
                    (fitted, e, lii, true, fit.regularized, Vec::new())
                }
            }
            Err(_) => {
                let e = y.iter().zip(mean).map(|(y, m)| y - m).collect();
                (mean.clone(), e, 1.0, true, false, Vec::new())
            }
        }
    }

    /// Leave-one-out outcomes of the points of one group (a leaf of the
    /// scaled tree), as `(index, outcome)`.
    ///
    /// The queries are the group's own points, so their neighbours are found
    /// together: one tree search collects every point within the (inflated)
    /// support of the group's box (a superset of each query's neighbours), sorted
    /// by index once; each query then filters that list by its own distance.
    /// The neighbour lists are exactly those of a tree search per query, in
    /// the same (index) order, so every fit is bitwise that of a single
    /// query at $x_i$, without a search and a sort per query.
    fn leaf(
        &self,
        model: &LwrModel,
        groups: &QueryGroups,
        leaf: &Leaf<'_>,
        scratch: &mut LeafScratch,
    ) -> Vec<(usize, PointLoo)> {
        let db = model.database();
        let d = db.n_inputs();
        let radius = self.settings.support_radius();
        let r2 = radius * radius;
        let LeafScratch {
            candidates,
            coords,
            fit,
            grad,
        } = scratch;
        candidates.clear();
        groups.candidates(leaf, candidates);
        candidates.sort_unstable();
        coords.clear();
        for &c in candidates.iter() {
            coords.extend_from_slice(&db.inputs()[c * d..(c + 1) * d]);
        }
        let mut out = Vec::with_capacity(leaf.indices.len());
        let scan: Scan = match d {
            1 => scan_fixed::<1>,
            2 => scan_fixed::<2>,
            3 => scan_fixed::<3>,
            4 => scan_fixed::<4>,
            5 => scan_fixed::<5>,
            6 => scan_fixed::<6>,
            7 => scan_fixed::<7>,
            8 => scan_fixed::<8>,
            9 => scan_fixed::<9>,
            10 => scan_fixed::<10>,
            11 => scan_fixed::<11>,
            12 => scan_fixed::<12>,
            _ => scan_any,
        };
        for &i in leaf.indices.iter().filter(|&&i| i % self.stride == 0) {
            let q = &db.inputs()[i * d..(i + 1) * d];
            fit.found.clear();
            match &self.metric {
                Metric::Diagonal(scales) => scan(candidates, coords, q, scales, r2, &mut fit.found),
                Metric::Full(full) => scan_full(candidates, coords, q, full, r2, &mut fit.found),
            }
            let result = fit_found(db, self.settings, &self.metric, q, Want::default(), fit);
            let mut point = self.outcome(model, i, &result);
            if self.grad {
                let mut row = vec![0.0; self.o * d];
                if let (Ok(local), false, Metric::Diagonal(scales)) = (&result, point.3, &self.metric) {
                    residual_derivatives(
                        db,
                        self.settings,
                        &self.metric,
                        scales,
                        i,
                        local,
                        &fit.found,
                        &point.1,
                        grad,
                        &mut row,
                    );
                }
                point.5 = row;
            }
            out.push((i, point));
        }
        out
    }

    /// Leave-one-out outcomes of the points of `leaves`, in parallel over
    /// the leaves, in the leaves' order.
    fn leaves(&self, model: &LwrModel, groups: &QueryGroups, leaves: &[Leaf<'_>]) -> Vec<(usize, PointLoo)> {
        let per_leaf: Vec<Vec<(usize, PointLoo)>> = leaves
            .par_iter()
            .map_init(LeafScratch::default, |scratch, leaf| {
                self.leaf(model, groups, leaf, scratch)
            })
            .collect();
        per_leaf.into_iter().flatten().collect()
    }

    /// Mean over outputs of PRESS$/(n \operatorname{var} y_o)$ (over the
    /// cross-validated points).
    fn normalized_mse(&self, press: &[f64]) -> f64 {
        let nf = self.n_queries as f64;
        let mut f = 0.0;
        for (p, v) in press.iter().zip(&self.var) {
            f += p / (nf * v) / self.o as f64;
        }
        f
    }
}

/// Leave-one-out residuals over the whole database and their summaries.
///
/// For point $i$ the model is fitted at $q = x_i$ (point $i$ included, with
/// weight $K(0) = 1$); its own weight in that fit is
/// $L_{ii} = K(0)\, z_i^\top P(x_i) z_i = P_{00}(x_i)$ since $z_i = e_0$ at
/// its own input. Removing the point is a rank-one update, so exactly
/// $$e_{(-i)} = \frac{y_i - \hat y(x_i)}{1 - L_{ii}},$$
/// ridge included. When $1 - L_{ii} < 10^{-8}$ (the point alone
/// determines its fit, so leaving it out leaves no data) the residual is
/// taken as $y_i - \bar y$ against the database mean and the point is
/// counted in `n_undetermined`: isolating points is penalised, never
/// rewarded. Fits that needed the fallback ridge are cross-validated as
/// regularised fits (counted in `n_regularized`).
#[derive(Debug, Clone, PartialEq)]
pub struct LooResult {
    /// $e_{(-i)}$, $n \times o$ row-major.
    pub residuals: Vec<f64>,
    /// $\hat y(x_i)$ with the point included, $n \times o$ row-major.
    pub fitted: Vec<f64>,
    /// $L_{ii}$ per point.
    pub leverages: Vec<f64>,
    /// PRESS $= \sum_i e_{(-i)}^2$ per output.
    pub press: Vec<f64>,
    /// GCV $= n\,\mathrm{RSS} / (n - \operatorname{tr} L)^2$ per output.
    pub gcv: Vec<f64>,
    /// Mean over outputs of PRESS$/n$.
    pub mse: f64,
    /// Mean over outputs of PRESS$/(n \operatorname{var} y_o)$: the
    /// scale-free objective of [`LwrModel::tune`] (1 is as good as
    /// predicting the mean).
    pub normalized_mse: f64,
    /// Points whose leave-one-out fit had no data.
    pub n_undetermined: usize,
    /// Points whose fit used the fallback ridge.
    pub n_regularized: usize,
}

impl LwrModel {
    /// Leave-one-out cross-validation of the current settings over the
    /// whole database. See [`LooResult`].
    ///
    /// The points are fitted in groups that are compact under the metric
    /// (the leaves of a k-d tree built over the scaled coordinates $m_j x_j$,
    /// or $A x$ for a full metric), in parallel over the groups: one search
    /// of that tree finds every point within the kernel's support of the
    /// group's box, sorted by index once, and each of the group's points then
    /// keeps those within its own support (by the distance a single query
    /// computes). The fits
    /// are bitwise those of single queries at $x_i$ (the same neighbours,
    /// summed in the same order), without a tree search and a sort per
    /// point.
    ///
    /// ```
    /// # use lwr::{LwrModel, LwrSettings};
    /// let mut m = LwrModel::new(1, 1, LwrSettings { bandwidth: 0.3, ..Default::default() })?;
    /// for i in 0..40 {
    ///     let x = i as f64 / 40.0;
    ///     m.insert(&[x], &[3.0 * x + 1.0])?;
    /// }
    /// let loo = m.loo()?;
    /// // a line is predicted exactly even without the point itself
    /// assert!(loo.press[0] < 1e-20);
    /// assert_eq!(loo.leverages.len(), 40);
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    pub fn loo(&self) -> Result<LooResult> {
        self.loo_with(self.settings())
    }

    /// [`loo`](Self::loo) for other settings (validated), without changing
    /// the model.
    pub fn loo_with(&self, settings: &LwrSettings) -> Result<LooResult> {
        let ctx = LooContext::new(self, settings, 1)?;
        let n = ctx.n;
        let o = ctx.o;
        let db = self.database();
        let mut per_point: Vec<Option<PointLoo>> = vec![None; n];
        let groups = QueryGroups::new(db, &ctx.metric, settings.support_radius());
        for (i, point) in ctx.leaves(self, &groups, &groups.leaves()) {
            per_point[i] = Some(point);
        }

        let mut res = LooResult {
            residuals: Vec::with_capacity(n * o),
            fitted: Vec::with_capacity(n * o),
            leverages: Vec::with_capacity(n),
            press: vec![0.0; o],
            gcv: vec![0.0; o],
            mse: 0.0,
            normalized_mse: 0.0,
            n_undetermined: 0,
            n_regularized: 0,
        };
        let mut rss = vec![0.0; o];
        let mut trace = 0.0;
        for (i, point) in per_point.into_iter().enumerate() {
            debug_assert!(point.is_some(), "every point is in one leaf");
            let Some((fitted, e, lii, undetermined, regularized, _)) = point else {
                continue;
            };
            let y = &db.outputs()[i * o..(i + 1) * o];
            for oo in 0..o {
                res.press[oo] += e[oo] * e[oo];
                rss[oo] += (y[oo] - fitted[oo]).powi(2);
            }
            trace += lii;
            res.n_undetermined += usize::from(undetermined);
            res.n_regularized += usize::from(regularized);
            res.residuals.extend(e);
            res.fitted.extend(fitted);
            res.leverages.push(lii);
        }
        let nf = n as f64;
        for ((gcv, rss), press) in res.gcv.iter_mut().zip(&rss).zip(&res.press) {
            *gcv = nf * rss / (nf - trace).powi(2);
            res.mse += press / nf / o as f64;
        }
        res.normalized_mse = ctx.normalized_mse(&res.press);
        Ok(res)
    }

    /// The tuning objective [`LooResult::normalized_mse`] for `settings`,
    /// or, when it is certainly above `bound`, possibly only a lower bound
    /// on it, found without visiting every point.
    ///
    /// The points are visited in up to [`N_BLOCKS`] blocks of query groups
    /// (the leaves of the scaled tree, see [`loo`](Self::loo); block $b$ of
    /// $B$ holds the groups $b, b + B, b + 2B, \dots$ from left
    /// to right, so every block samples the whole input space), each block in
    /// parallel over its groups; after each block the partial sum of the
    /// nonnegative per-point terms is compared with the bound. The
    /// partial sum is a lower bound on the objective up to rounding (a
    /// relative $n \epsilon_{mach}$), so the evaluation stops only when it
    /// exceeds `bound` by the relative margin [`BOUND_MARGIN`]: a stopped
    /// evaluation is one whose exact objective is above `bound`, and a
    /// completed one returns bitwise the value of
    /// [`loo_with`](Self::loo_with). Deterministic: the blocks and their
    /// sums do not depend on the number of threads (where a stopped
    /// evaluation stops depends on the tree's shape, its decision does not).
    ///
    /// With `stride` $> 1$, only the points $i$ with $i \bmod$ `stride`
    /// $= 0$ are cross-validated (their neighbours are still all the points),
    /// and the objective is their normalised MSE.
    pub(crate) fn loo_objective(&self, settings: &LwrSettings, bound: f64, stride: usize) -> Result<Objective> {
        let ctx = LooContext::new(self, settings, stride)?;
        let (n, o) = (ctx.n, ctx.o);
        let groups = QueryGroups::new(self.database(), &ctx.metric, settings.support_radius());
        let leaves = groups.leaves();
        let n_blocks = if bound.is_finite() {
            N_BLOCKS.min(ctx.n_queries.div_ceil(MIN_BLOCK)).min(leaves.len()).max(1)
        } else {
            1
        };
        let mut residuals = vec![0.0; n * o];
        let nf = ctx.n_queries as f64;
        let weights: Vec<f64> = ctx.var.iter().map(|&v| 1.0 / (nf * v) / o as f64).collect();
        let mut partial = 0.0;
        let mut block_leaves = Vec::with_capacity(leaves.len().div_ceil(n_blocks));
        for block in 0..n_blocks {
            block_leaves.clear();
            block_leaves.extend(leaves.iter().skip(block).step_by(n_blocks).copied());
            for (i, (_, e, ..)) in ctx.leaves(self, &groups, &block_leaves) {
                for (oo, e) in e.into_iter().enumerate() {
                    partial += e * e * weights[oo];
                    residuals[i * o + oo] = e;
                }
            }
            if block + 1 < n_blocks && partial > bound * (1.0 + BOUND_MARGIN) && partial > f64::MIN_POSITIVE {
                return Ok(Objective::Above(partial));
            }
        }
        // the sums of loo_with, in the same order
        let mut press = vec![0.0; o];
        for e in residuals.chunks_exact(o) {
            for (p, e) in press.iter_mut().zip(e) {
                *p += e * e;
            }
        }
        Ok(Objective::Exact(ctx.normalized_mse(&press)))
    }
}

/// The leave-one-out residuals of the cross-validated points, weighted so
/// that their sum of squares is the tuning objective, and their derivatives
/// with respect to the logarithms of the metric scales
/// ([`LwrModel::loo_jacobian`]).
#[derive(Debug, Clone, Default)]
pub(crate) struct LooJacobian {
    /// The objective ([`LooResult::normalized_mse`] over the cross-validated
    /// points), summed as [`LwrModel::loo_objective`] sums it.
    pub(crate) objective: f64,
    /// $w_o e_{(-i), o}$ per cross-validated point $i$ (in index order) and
    /// output $o$, $w_o = (n \operatorname{var} y_o\, o)^{-1/2}$.
    pub(crate) residuals: Vec<f64>,
    /// $\partial r / \partial \log m_j$, one row of $d$ per residual.
    pub(crate) jacobian: Vec<f64>,
}

impl LwrModel {
    /// The weighted leave-one-out residuals at `settings` (a diagonal
    /// metric) and their exact derivatives with respect to $\log m_j$ (see
    /// `scale_grad.rs`), over the points $i$ with $i \bmod$ `stride` $= 0$;
    /// the residuals are bitwise those of [`loo_with`](Self::loo_with).
    pub(crate) fn loo_jacobian(&self, settings: &LwrSettings, stride: usize) -> Result<LooJacobian> {
        let mut ctx = LooContext::new(self, settings, stride)?;
        if !matches!(ctx.metric, Metric::Diagonal(_)) {
            return Err(LwrError::InvalidParameter {
                name: "metric",
                reason: "the Levenberg-Marquardt tuning differentiates a diagonal metric only; use the compass \
                         search with a full metric"
                    .into(),
            });
        }
        ctx.grad = true;
        let (n, o) = (ctx.n, ctx.o);
        let d = self.database().n_inputs();
        let groups = QueryGroups::new(self.database(), &ctx.metric, settings.support_radius());
        let mut per_point: Vec<Option<PointLoo>> = vec![None; n];
        for (i, point) in ctx.leaves(self, &groups, &groups.leaves()) {
            per_point[i] = Some(point);
        }
        let nf = ctx.n_queries as f64;
        let weights: Vec<f64> = ctx.var.iter().map(|&v| (1.0 / (nf * v) / o as f64).sqrt()).collect();
        let mut press = vec![0.0; o];
        let mut residuals = Vec::with_capacity(ctx.n_queries * o);
        let mut jacobian = Vec::with_capacity(ctx.n_queries * o * d);
        for (_, e, .., de) in per_point.into_iter().flatten() {
            for (oo, (&e, p)) in e.iter().zip(press.iter_mut()).enumerate() {
                *p += e * e;
                residuals.push(weights[oo] * e);
                jacobian.extend(de[oo * d..(oo + 1) * d].iter().map(|v| weights[oo] * v));
            }
        }
        Ok(LooJacobian {
            objective: ctx.normalized_mse(&press),
            residuals,
            jacobian,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::{Degree, Kernel};

    fn model(n: usize) -> LwrModel {
        let mut rand = crate::strategies::uniform(5u64);
        let settings = LwrSettings {
            bandwidth: 0.2,
            ..Default::default()
        };
        let mut m = LwrModel::new(2, 2, settings).expect("valid");
        for _ in 0..n {
            let x = [rand(), rand()];
            let y = [(3.0 * x[0]).sin() + 0.1 * rand(), x[1] * x[1] + 0.1 * rand()];
            m.insert(&x, &y).expect("finite");
        }
        m
    }

    /// The derivatives of the leave-one-out residuals with respect to
    /// $\log m_j$ against central differences, for each smooth kernel and
    /// degree, with and without the slope ridge, two outputs.
    #[test]
    fn loo_jacobian_matches_central_differences() {
        let m = model(120);
        let mut rand = crate::strategies::uniform(11u64);
        let mut m3 = LwrModel::new(3, 1, LwrSettings::default()).expect("valid");
        for _ in 0..150 {
            let x = [rand(), rand(), rand()];
            m3.insert(&x, &[(2.0 * x[0]).sin() * x[1] + 0.1 * rand()])
                .expect("finite");
        }
        let cases = [
            (Kernel::Gaussian, Degree::Linear, 0.0, 0.3),
            (Kernel::Gaussian, Degree::Quadratic, 0.05, 0.5),
            (Kernel::Gaussian, Degree::Constant, 0.0, 0.2),
            (Kernel::Tricube, Degree::Linear, 0.02, 0.8),
            (Kernel::Bisquare, Degree::Quadratic, 0.0, 1.2),
        ];
        for model in [&m, &m3] {
            let d = model.database().n_inputs();
            for (kernel, degree, slope_ridge, bandwidth) in cases {
                let scales: Vec<f64> = (0..d).map(|j| 0.7 + 0.4 * j as f64).collect();
                let at = |scales: &[f64]| LwrSettings {
                    kernel,
                    degree,
                    slope_ridge,
                    bandwidth,
                    scales: scales.to_vec(),
                    ..Default::default()
                };
                let jac = model.loo_jacobian(&at(&scales), 1).expect("diagonal");
                let exact = model.loo_with(&at(&scales)).expect("valid").normalized_mse;
                let sum: f64 = jac.residuals.iter().map(|r| r * r).sum();
                assert!(
                    (jac.objective - exact).abs() <= 1e-14 * exact,
                    "{} vs {exact}",
                    jac.objective
                );
                assert!((sum - exact).abs() <= 1e-12 * exact, "{sum} vs {exact}");
                let rows = jac.residuals.len();
                let scale = jac.jacobian.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                assert!(scale > 0.0);
                for j in 0..d {
                    let step = 1e-6;
                    let shifted = |t: f64| {
                        let mut s = scales.clone();
                        s[j] *= t.exp();
                        model.loo_jacobian(&at(&s), 1).expect("diagonal").residuals
                    };
                    let (plus, minus) = (shifted(step), shifted(-step));
                    for r in 0..rows {
                        let fd = (plus[r] - minus[r]) / (2.0 * step);
                        let an = jac.jacobian[r * d + j];
                        assert!(
                            (fd - an).abs() <= 1e-6 * scale,
                            "{kernel:?} {degree:?} ridge {slope_ridge}: residual {r}, input {j}: {an} vs {fd}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn objective_is_exact_or_a_lower_bound_above_the_bound() {
        let m = model(1000);
        for s in [
            m.settings().clone(),
            LwrSettings {
                bandwidth: 0.05,
                scales: vec![1.0, 0.0],
                ..Default::default()
            },
        ] {
            let exact = m.loo_with(&s).expect("nonempty").normalized_mse;
            // no bound, or a bound the objective is below: bitwise loo_with
            assert_eq!(m.loo_objective(&s, f64::INFINITY, 1), Ok(Objective::Exact(exact)));
            assert_eq!(m.loo_objective(&s, exact * 1.01, 1), Ok(Objective::Exact(exact)));
            // a bound well below: stopped, with a lower bound above the bound
            match m.loo_objective(&s, 0.3 * exact, 1).expect("valid") {
                Objective::Above(lb) => assert!(lb > 0.3 * exact && lb <= exact * (1.0 + 1e-12), "{lb} vs {exact}"),
                Objective::Exact(f) => panic!("not stopped early: {f}"),
            }
            // just below the objective: never a wrong answer either way
            match m.loo_objective(&s, exact * (1.0 - 1e-6), 1).expect("valid") {
                Objective::Above(lb) => assert!(lb <= exact * (1.0 + 1e-12)),
                Objective::Exact(f) => assert_eq!(f, exact),
            }
        }
    }
}
