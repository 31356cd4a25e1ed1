//! The weighted least-squares fit at one query: weights, normal equations,
//! the scaled Cholesky factorisation (`factor.rs`), confidence
//! sums and the exact query Jacobian.

use crate::database::Database;
use crate::error::{LwrError, Result};
use crate::factor::{Factor, factorise};
use crate::metric::Metric;
use crate::scaled::ScaledIndex;
use crate::settings::{Degree, Kernel, LwrSettings};

/// What to compute beyond the coefficients.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Want {
    pub(crate) confidence: bool,
    pub(crate) jacobian: bool,
}

/// Everything a local fit produces; the public [`Prediction`](crate::Prediction)
/// is built from it.
#[derive(Debug, Clone)]
pub(crate) struct LocalFit {
    /// Number of coefficients $p$.
    pub(crate) p: usize,
    /// Coefficients, $p \times o$ row-major.
    pub(crate) beta: Vec<f64>,
    /// $s = P e_0$.
    pub(crate) s: Vec<f64>,
    /// Points with positive weight.
    pub(crate) n_neighbors: usize,
    /// $n_{lwr} = \sum_i k_i$.
    pub(crate) sum_w: f64,
    /// Condition estimate of the scaled normal matrix (before any fallback).
    pub(crate) condition: f64,
    /// Whether the fallback ridge was added.
    pub(crate) regularized: bool,
    /// $p_{lwr} = \sum_i k_i^2 z_i^\top P z_i$ (confidence only).
    pub(crate) p_lwr: f64,
    /// $|l|^2 = \sum_i k_i^2 (z_i^\top P e_0)^2$ (confidence only).
    pub(crate) l_norm2: f64,
    /// $\sum_i k_i r_i^2$ per output (confidence only).
    pub(crate) wrss: Vec<f64>,
    /// Jacobian, $o \times d$ row-major (jacobian only).
    pub(crate) jacobian: Vec<f64>,
}

/// Writes the design row $z$ for input `x` at query `q`.
#[inline]
pub(crate) fn design_row(degree: Degree, x: &[f64], q: &[f64], z: &mut [f64]) {
    z[0] = 1.0;
    if degree == Degree::Constant {
        return;
    }
    let d = q.len();
    for j in 0..d {
        z[1 + j] = x[j] - q[j];
    }
    if degree == Degree::Quadratic {
        let mut t = 1 + d;
        for a in 0..d {
            for b in a..d {
                z[t] = z[1 + a] * z[1 + b];
                t += 1;
            }
        }
    }
}

/// $v^\top \partial z / \partial q_j$ for a row with offsets `delta = x - q`,
/// reading `v` with stride `stride` (coefficient `a` at `v[a * stride]`).
fn dz_dot(degree: Degree, delta: &[f64], j: usize, v: &[f64], stride: usize) -> f64 {
    if degree == Degree::Constant {
        return 0.0;
    }
    let d = delta.len();
    let mut s = -v[(1 + j) * stride];
    if degree == Degree::Quadratic {
        let mut t = 1 + d;
        for a in 0..d {
            for b in a..d {
                let mut g = 0.0;
                if a == j {
                    g -= delta[b];
                }
                if b == j {
                    g -= delta[a];
                }
                s += g * v[t * stride];
                t += 1;
            }
        }
    }
    s
}

/// The length in input units over which coefficient `c` ($\ge 1$) of the
/// local polynomial is penalised: $h / m_j$ for the slope of input $j$,
/// $(h / m_a)(h / m_b)$ for a quadratic term; infinite where a scale is 0.
pub(crate) fn coefficient_length(degree: Degree, metric: &Metric, h: f64, d: usize, c: usize) -> f64 {
    let length = |j: usize| h / metric.input_scale(j);
    if c <= d {
        return length(c - 1);
    }
    debug_assert_eq!(degree, Degree::Quadratic);
    let mut t = d + 1;
    for a in 0..d {
        for b in a..d {
            if t == c {
                return length(a) * length(b);
            }
            t += 1;
        }
    }
    unreachable!("coefficient {c} of a quadratic in {d} inputs")
}

/// Adds `LwrSettings::slope_ridge` to the normal matrix `a` ($p \times p$,
/// full): $\lambda_s L_c^2$ on the diagonal of every coefficient $c \ge 1$
/// of length $L_c$ ([`coefficient_length`]); a coefficient of infinite
/// length is removed instead (its row and column of `a` and `b2` cleared,
/// its diagonal set to 1, its right-hand sides in `b` to 0), so that it
/// comes out exactly 0 and the other coefficients are the fit without it.
#[allow(clippy::too_many_arguments)]
fn add_slope_ridge(
    ridge: f64,
    degree: Degree,
    metric: &Metric,
    h: f64,
    d: usize,
    o: usize,
    a: &mut [f64],
    b: &mut [f64],
    b2: &mut [f64],
) {
    let p = degree.n_coeffs(d);
    for c in 1..p {
        let length = coefficient_length(degree, metric, h, d, c);
        if length.is_finite() {
            a[c * p + c] += ridge * length * length;
            continue;
        }
        for r in 0..p {
            a[r * p + c] = 0.0;
            a[c * p + r] = 0.0;
            if !b2.is_empty() {
                b2[r * p + c] = 0.0;
                b2[c * p + r] = 0.0;
            }
        }
        a[c * p + c] = 1.0;
        b[c * o..(c + 1) * o].fill(0.0);
    }
}

/// The kernel weight $K(u)$ at $u = \sqrt{d^2} / h$; the Gaussian's as
/// $e^{-d^2 / (2 h^2)}$, without the square root.
#[inline]
pub(crate) fn weight(kernel: Kernel, d2: f64, h: f64) -> f64 {
    match kernel {
        Kernel::Gaussian => (-0.5 * (d2 / (h * h))).exp(),
        _ => kernel.value(d2.sqrt() / h),
    }
}

/// What the compile-time-sized passes read: the data, the number of
/// outputs, the query and the kernel with its bandwidth.
#[derive(Clone, Copy)]
struct Local<'a> {
    inputs: &'a [f64],
    outputs: &'a [f64],
    o: usize,
    q: &'a [f64],
    h: f64,
    kernel: Kernel,
}

/// The most inputs of the compile-time-sized passes
/// ([`accumulate_linear`], [`jacobian_linear`]).
const MAX_SIZED: usize = 12;

/// Signature of [`accumulate_linear`].
type AccumulateLinear =
    fn(Local<'_>, &[(usize, f64)], &mut [f64], &mut [f64], Option<&mut Vec<(usize, f64, f64)>>) -> (f64, usize);

/// The first pass of [`fit_found`] for a local linear fit in `D` inputs
/// without confidence or Jacobian: adds $k_i z_i z_i^\top$ (lower triangle,
/// packed by rows) to `a_lower` and $k_i z_i y_i^\top$ to `b` for every
/// neighbour with positive weight, and returns $\sum_i k_i$ and the number of
/// such neighbours; with `keep`, pushes `(index, k, u)` of each of them for
/// the Jacobian's pass ([`jacobian_linear`]). The same operations in the
/// same order as the general loop (bitwise the same sums), with the loop
/// bounds known at compile time.
#[inline(never)]
fn accumulate_linear<const D: usize>(
    local: Local<'_>,
    found: &[(usize, f64)],
    a_lower: &mut [f64],
    b: &mut [f64],
    mut keep: Option<&mut Vec<(usize, f64, f64)>>,
) -> (f64, usize) {
    let Local {
        inputs,
        outputs,
        o,
        q,
        h,
        kernel,
    } = local;
    let q: &[f64; D] = match q.try_into() {
        Ok(q) => q,
        Err(_) => return (0.0, 0),
    };
    debug_assert_eq!(a_lower.len(), (D + 1) * (D + 2) / 2);
    debug_assert_eq!(b.len(), (D + 1) * o);
    let mut sum_w = 0.0;
    let mut n = 0;
    let mut z = [1.0; MAX_SIZED + 1];
    // the sums in registers or on the stack, with every loop bound known at
    // compile time (the triangle has (D + 1)(D + 2) / 2 <= 91 entries); the
    // caller's buffers are zero, so adding the sums to them is exact
    let mut a_acc = [0.0; (MAX_SIZED + 1) * (MAX_SIZED + 2) / 2];
    let mut b_acc = [0.0; MAX_SIZED + 1];
    for &(i, d2) in found {
        let k = weight(kernel, d2, h);
        if k <= 0.0 {
            continue;
        }
        n += 1;
        if let Some(keep) = keep.as_mut() {
            keep.push((i, k, d2.sqrt() / h));
        }
        let x = &inputs[i * D..(i + 1) * D];
        for j in 0..D {
            z[1 + j] = x[j] - q[j];
        }
        let y = &outputs[i * o..(i + 1) * o];
        sum_w += k;
        let mut t = 0;
        // exclusive ranges: `0..=D` compiles to a loop with an exhaustion
        // flag that is not unrolled (8 % slower tuning at n = 400, d = 3)
        for r in 0..D + 1 {
            let kz = k * z[r];
            for c in 0..r + 1 {
                a_acc[t + c] += kz * z[c];
            }
            t += r + 1;
            if o == 1 {
                b_acc[r] += kz * y[0];
            } else {
                for (bo, yo) in b[r * o..(r + 1) * o].iter_mut().zip(y) {
                    *bo += kz * yo;
                }
            }
        }
    }
    for (a, v) in a_lower.iter_mut().zip(&a_acc) {
        *a += v;
    }
    if o == 1 {
        for (bo, v) in b.iter_mut().zip(&b_acc) {
            *bo += v;
        }
    }
    (sum_w, n)
}

/// The solved local linear fit that [`jacobian_linear`] differentiates:
/// coefficients $\beta$ ($(1 + D) \times o$, row-major) and $s = P e_0$.
#[derive(Clone, Copy)]
struct LinearSums<'a> {
    beta: &'a [f64],
    s: &'a [f64],
}

/// Signature of [`jacobian_linear`].
type JacobianLinear = fn(Local<'_>, &[(usize, f64, f64)], &Metric, LinearSums<'_>, &mut [f64]);

/// The Jacobian's pass of [`fit_found`] for a local linear fit in `D`
/// inputs without confidence, over the weighted neighbours `nb` as
/// `(index, k, u)`: adds to `jac` ($o \times D$, row-major) the terms of
/// [`LwrModel::predict_with_jacobian`](crate::LwrModel::predict_with_jacobian)'s
/// formula with $\partial z_i / \partial q_j = -e_{1+j}$. The same
/// operations in the same order as the general pass (bitwise the same
/// Jacobian), with the design rows rebuilt from the inputs instead of stored
/// and the loop bounds known at compile time.
#[inline(never)]
fn jacobian_linear<const D: usize>(
    local: Local<'_>,
    nb: &[(usize, f64, f64)],
    metric: &Metric,
    fit: LinearSums<'_>,
    jac: &mut [f64],
) {
    let Local {
        inputs,
        outputs,
        o,
        q,
        h,
        kernel,
    } = local;
    let q: &[f64; D] = match q.try_into() {
        Ok(q) => q,
        Err(_) => return,
    };
    debug_assert_eq!(fit.s.len(), D + 1);
    debug_assert_eq!(fit.beta.len(), (D + 1) * o);
    debug_assert_eq!(jac.len(), o * D);
    let h2 = h * h;
    let mut delta = [0.0; D];
    let mut grad = [0.0; D];
    for &(i, k, u) in nb {
        let x = &inputs[i * D..(i + 1) * D];
        for j in 0..D {
            delta[j] = x[j] - q[j];
        }
        // s^T z_i, summed as the general pass does (from 0, z_0 = 1 first)
        let mut zs_i = 0.0 + fit.s[0];
        for (dj, sj) in delta.iter().zip(&fit.s[1..]) {
            zs_i += dj * sj;
        }
        let g = kernel.slope_over_u(u);
        for (j, gj) in grad.iter_mut().enumerate() {
            *gj = metric.half_grad(j, &delta);
        }
        let y = &outputs[i * o..(i + 1) * o];
        for (oo, &yo) in y.iter().enumerate() {
            let mut pred = 0.0 + fit.beta[oo];
            for (j, dj) in delta.iter().enumerate() {
                pred += dj * fit.beta[(1 + j) * o + oo];
            }
            let res = yo - pred;
            let row = &mut jac[oo * D..(oo + 1) * D];
            for j in 0..D {
                let dk = -g * grad[j] / h2;
                let sdz = -fit.s[1 + j];
                let bdz = -fit.beta[(1 + j) * o + oo];
                row[j] += (dk * zs_i + k * sdz) * res - k * zs_i * bdz;
            }
        }
    }
}

/// Reusable buffers of a local fit, so that a query allocates only its
/// small results: one per thread for single queries, one per rayon job in
/// leave-one-out.
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    /// `(index, d^2)` of the points within the support, in index order.
    pub(crate) found: Vec<(usize, f64)>,
    /// `(index, k, u)` of the points with positive weight (second pass only).
    nb: Vec<(usize, f64, f64)>,
    /// Design rows of the weighted points (second pass only).
    zs: Vec<f64>,
    /// One design row (first pass without a second one).
    z: Vec<f64>,
    /// The normal matrix's lower triangle, packed by rows, and the full one.
    a_lower: Vec<f64>,
    a: Vec<f64>,
    /// $Z^\top K y$.
    b: Vec<f64>,
    /// $\sum_i k_i^2 z_i z_i^\top$, packed and full (confidence only).
    b2_lower: Vec<f64>,
    b2: Vec<f64>,
    /// One column.
    col: Vec<f64>,
    /// $d^2$ by point index, NaN where not found (reordering only).
    dense: Vec<f64>,
    /// The factorisation, and its work buffer.
    factor: Factor,
    scaled: Vec<f64>,
    /// Neighbours found by this scratch's last search ([`local_fit`]'s
    /// choice between the tree and one pass over the data).
    last_found: usize,
}

/// [`local_fit`] scans the whole data set instead of searching the tree
/// when the last query's support held more than `1 / WIDE_SUPPORT` of it.
const WIDE_SUPPORT: usize = 4;

/// Puts `found` (`(index, d^2)` pairs with distinct indices below `n`)
/// in increasing index order: by a sort when they are few, by scattering
/// them into `dense` ($O(n)$, no comparisons) when they are a large part of
/// the data, as with a wide bandwidth or inputs scaled to 0. Either way the
/// same pairs in the same order.
fn in_index_order(found: &mut Vec<(usize, f64)>, n: usize, dense: &mut Vec<f64>) {
    // a sort costs about k log2 k comparisons, the scatter about 2 n steps
    let k = found.len();
    if k < 2 || k * (usize::BITS - k.leading_zeros()) as usize <= 2 * n {
        found.sort_unstable_by_key(|&(i, _)| i);
        return;
    }
    dense.clear();
    // d^2 < r^2 for every found point: NaN marks the others
    dense.resize(n, f64::NAN);
    for &(i, d2) in found.iter() {
        dense[i] = d2;
    }
    found.clear();
    found.extend(
        dense
            .iter()
            .enumerate()
            .filter(|(_, d2)| !d2.is_nan())
            .map(|(i, &d2)| (i, d2)),
    );
    debug_assert_eq!(found.len(), k);
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// Puts every point with $d^2 <$ `radius`$^2$ into `scratch.found`, as
/// `(index, d^2)` in increasing index order. The same neighbours in the same
/// order either way: by one pass over the data when the scratch's last
/// search found more than `1 / WIDE_SUPPORT` of it (a planner's queries
/// along a trajectory have alike supports), by the tree's search and a
/// sort otherwise.
fn find_neighbours(db: &Database, index: &ScaledIndex, metric: &Metric, q: &[f64], radius: f64, scratch: &mut Scratch) {
    scratch.found.clear();
    if scratch.last_found * WIDE_SUPPORT > db.len() {
        ScaledIndex::scan(db, metric, q, radius, &mut scratch.found);
    } else {
        index.within(db, metric, q, radius, &mut scratch.found);
        in_index_order(&mut scratch.found, db.len(), &mut scratch.dense);
    }
    scratch.last_found = scratch.found.len();
}

/// Fits at `q` with this thread's scratch buffers: finds the neighbours
/// with `index` (the tree in the metric's scaled coordinates, which gives
/// the same neighbours and distances as `db`'s own tree), sorts them by
/// index and calls [`fit_found`]. The caller has validated `settings`,
/// `metric` (of the settings, and `index`'s) and `q`.
pub(crate) fn local_fit(
    db: &Database,
    index: &ScaledIndex,
    settings: &LwrSettings,
    metric: &Metric,
    q: &[f64],
    want: Want,
) -> Result<LocalFit> {
    if db.is_empty() {
        return Err(LwrError::EmptyDatabase);
    }
    let fit_in = |scratch: &mut Scratch| {
        find_neighbours(db, index, metric, q, settings.support_radius(), scratch);
        fit_found(db, settings, metric, q, want, scratch)
    };
    SCRATCH.with(|s| match s.try_borrow_mut() {
        Ok(mut s) => fit_in(&mut s),
        // re-entered on this thread (not done by this crate): fresh buffers
        Err(_) => fit_in(&mut Scratch::default()),
    })
}

/// Fits at `q` over the neighbours in `scratch.found`: every point with
/// $d^2 <$ (support radius)$^2$, as `(index, d^2)` in increasing index
/// order. The caller has validated `settings`, `metric` and `q`.
///
/// The sums run over the neighbours in index order, so that the result does
/// not depend on the tree's shape or on how the neighbours were found (a
/// model saved and loaded, or built in another insertion order, gives
/// bitwise the same predictions, and leave-one-out the same fits as
/// [`local_fit`]).
pub(crate) fn fit_found(
    db: &Database,
    settings: &LwrSettings,
    metric: &Metric,
    q: &[f64],
    want: Want,
    scratch: &mut Scratch,
) -> Result<LocalFit> {
    debug_assert!(scratch.found.windows(2).all(|w| w[0].0 < w[1].0));
    let d = db.n_inputs();
    let o = db.n_outputs();
    let degree = settings.degree;
    let p = degree.n_coeffs(d);
    let h = settings.bandwidth;
    let kernel = settings.kernel;
    let radius = settings.support_radius();
    let second_pass = want.confidence || want.jacobian;

    let Scratch {
        found,
        nb,
        zs,
        z,
        a_lower,
        a,
        b,
        b2_lower,
        b2,
        col,
        factor,
        scaled,
        dense: _,
        last_found: _,
    } = scratch;
    nb.clear();
    zs.clear();
    z.clear();
    z.resize(p, 0.0);

    // weights and normal equations in one pass
    let inputs = db.inputs();
    let outputs = db.outputs();
    let n_lower = p * (p + 1) / 2;
    let zeroed = |v: &mut Vec<f64>, len: usize| {
        v.clear();
        v.resize(len, 0.0);
    };
    zeroed(a_lower, n_lower);
    zeroed(b, p * o);
    zeroed(b2_lower, if want.confidence { n_lower } else { 0 });
    let mut sum_w = 0.0;
    let mut n_neighbors = 0;
    // the compile-time-sized first pass: a linear fit without confidence,
    // keeping the weighted neighbours for the Jacobian's pass if one follows
    let fast = !want.confidence && degree == Degree::Linear;
    let local = Local {
        inputs,
        outputs,
        o,
        q,
        h,
        kernel,
    };
    // the compile-time-sized passes, both or neither
    let sized: Option<(AccumulateLinear, JacobianLinear)> = match d {
        _ if !fast => None,
        1 => Some((accumulate_linear::<1>, jacobian_linear::<1>)),
        2 => Some((accumulate_linear::<2>, jacobian_linear::<2>)),
        3 => Some((accumulate_linear::<3>, jacobian_linear::<3>)),
        4 => Some((accumulate_linear::<4>, jacobian_linear::<4>)),
        5 => Some((accumulate_linear::<5>, jacobian_linear::<5>)),
        6 => Some((accumulate_linear::<6>, jacobian_linear::<6>)),
        7 => Some((accumulate_linear::<7>, jacobian_linear::<7>)),
        8 => Some((accumulate_linear::<8>, jacobian_linear::<8>)),
        9 => Some((accumulate_linear::<9>, jacobian_linear::<9>)),
        10 => Some((accumulate_linear::<10>, jacobian_linear::<10>)),
        11 => Some((accumulate_linear::<11>, jacobian_linear::<11>)),
        12 => Some((accumulate_linear::<12>, jacobian_linear::<12>)),
        _ => None,
    };
    if let Some((accumulate, _)) = sized {
        let keep = want.jacobian.then_some(&mut *nb);
        (sum_w, n_neighbors) = accumulate(local, found, a_lower, b, keep);
    }
    for &(i, d2) in found.iter().filter(|_| sized.is_none()) {
        let k = weight(kernel, d2, h);
        if k <= 0.0 {
            continue;
        }
        n_neighbors += 1;
        let x = &inputs[i * d..(i + 1) * d];
        let y = &outputs[i * o..(i + 1) * o];
        let z: &[f64] = if second_pass {
            nb.push((i, k, d2.sqrt() / h));
            let start = zs.len();
            zs.resize(start + p, 0.0);
            design_row(degree, x, q, &mut zs[start..]);
            &zs[start..]
        } else {
            design_row(degree, x, q, z);
            z
        };
        sum_w += k;
        // lower triangles packed row by row: the same products in the same
        // order as a loop over (r, c <= r), without index arithmetic
        let mut lower = a_lower.iter_mut();
        for (r, (&zr, b_row)) in z.iter().zip(b.chunks_exact_mut(o)).enumerate() {
            let kz = k * zr;
            // z first: zip stops without taking a triangle entry too many
            for (zc, acc) in z[..=r].iter().zip(lower.by_ref()) {
                *acc += kz * zc;
            }
            for (bo, yo) in b_row.iter_mut().zip(y) {
                *bo += kz * yo;
            }
        }
        if want.confidence {
            let mut lower = b2_lower.iter_mut();
            for (r, &zr) in z.iter().enumerate() {
                let kkz = k * (k * zr);
                for (zc, acc) in z[..=r].iter().zip(lower.by_ref()) {
                    *acc += kkz * zc;
                }
            }
        }
    }
    if n_neighbors == 0 {
        let nearest = db
            .nearest_sq(q, metric, 1)
            .first()
            .map_or(f64::INFINITY, |&(_, d2)| d2.sqrt());
        return Err(LwrError::NoWeightedData {
            nearest_distance: nearest,
            support: radius,
        });
    }
    zeroed(a, p * p);
    zeroed(b2, if want.confidence { p * p } else { 0 });
    let mut t = 0;
    for r in 0..p {
        for c in 0..r + 1 {
            a[r * p + c] = a_lower[t];
            a[c * p + r] = a_lower[t];
            if want.confidence {
                b2[r * p + c] = b2_lower[t];
                b2[c * p + r] = b2_lower[t];
            }
            t += 1;
        }
        a[r * p + r] += if r > 0 {
            settings.ridge
        } else {
            settings.intercept_ridge
        };
    }
    if settings.slope_ridge > 0.0 {
        add_slope_ridge(settings.slope_ridge, degree, metric, h, d, o, a, b, b2);
    }
    let (condition, regularized) = factorise(a, p, settings, factor, scaled)?;

    // coefficients: one factorisation, o right-hand sides
    let mut beta = vec![0.0; p * o];
    zeroed(col, p);
    for oo in 0..o {
        for r in 0..p {
            col[r] = b[r * o + oo];
        }
        factor.apply(col);
        for r in 0..p {
            beta[r * o + oo] = col[r];
        }
    }
    let mut s = vec![0.0; p];
    s[0] = 1.0;
    factor.apply(&mut s);

    let mut fit = LocalFit {
        p,
        beta,
        s,
        n_neighbors,
        sum_w,
        condition,
        regularized,
        p_lwr: f64::NAN,
        l_norm2: f64::NAN,
        wrss: Vec::new(),
        jacobian: Vec::new(),
    };
    if !second_pass {
        return Ok(fit);
    }

    if want.confidence {
        // p_lwr = trace(P B2), with P column by column
        let mut p_lwr = 0.0;
        for c in 0..p {
            col.fill(0.0);
            col[c] = 1.0;
            factor.apply(col);
            for r in 0..p {
                p_lwr += col[r] * b2[r * p + c];
            }
        }
        fit.p_lwr = p_lwr;
        fit.l_norm2 = 0.0;
        fit.wrss = vec![0.0; o];
    }
    if want.jacobian {
        fit.jacobian = vec![0.0; o * d];
    }
    if let Some((_, jacobian)) = sized {
        // the fast first pass kept (index, k, u) but no design rows
        let sums = LinearSums {
            beta: &fit.beta,
            s: &fit.s,
        };
        jacobian(local, nb, metric, sums, &mut fit.jacobian);
        return Ok(fit);
    }
    let h2 = h * h;
    let mut resid = vec![0.0; o];
    let mut delta = vec![0.0; d];
    for (row, &(i, k, u)) in nb.iter().enumerate() {
        let z = &zs[row * p..(row + 1) * p];
        let y = &outputs[i * o..(i + 1) * o];
        let zs_i: f64 = z.iter().zip(&fit.s).map(|(a, b)| a * b).sum();
        for (oo, (res, yo)) in resid.iter_mut().zip(y).enumerate() {
            let pred: f64 = z.iter().enumerate().map(|(r, zr)| zr * fit.beta[r * o + oo]).sum();
            *res = yo - pred;
        }
        if want.confidence {
            fit.l_norm2 += k * k * zs_i * zs_i;
            for (w, r) in fit.wrss.iter_mut().zip(&resid) {
                *w += k * r * r;
            }
        }
        if want.jacobian {
            let x = &inputs[i * d..(i + 1) * d];
            for j in 0..d {
                delta[j] = x[j] - q[j];
            }
            let g = kernel.slope_over_u(u);
            for j in 0..d {
                // d k_i / d q_j = -K'(u)/u (G (x_i - q))_j / h^2
                let dk = -g * metric.half_grad(j, &delta) / h2;
                let sdz = dz_dot(degree, &delta, j, &fit.s, 1);
                for (oo, res) in resid.iter().enumerate() {
                    let bdz = dz_dot(degree, &delta, j, &fit.beta[oo..], o);
                    fit.jacobian[oo * d + j] += (dk * zs_i + k * sdz) * res - k * zs_i * bdz;
                }
            }
        }
    }
    Ok(fit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_from_squared_distances_equal_the_kernels() {
        for kernel in [
            Kernel::Gaussian,
            Kernel::Tricube,
            Kernel::Epanechnikov,
            Kernel::Bisquare,
        ] {
            for h in [0.01, 0.7, 3.0] {
                for u in [0.0, 0.1, 0.5, 0.99, 1.5, 4.9] {
                    let d2 = (u * h) * (u * h);
                    let (got, want) = (weight(kernel, d2, h), kernel.value(d2.sqrt() / h));
                    assert!((got - want).abs() <= 1e-14 * want, "{kernel:?} u {u}: {got} vs {want}");
                }
            }
        }
    }

    #[test]
    fn linear_fast_path_equals_general_loop() {
        // predict_mean takes the compile-time-sized path for d <= 8, predict
        // (which wants confidence) the general one: bitwise the same mean
        let mut rand = crate::strategies::uniform(3u64);
        for d in 1..=9 {
            for kernel in [Kernel::Gaussian, Kernel::Tricube] {
                let settings = LwrSettings {
                    kernel,
                    bandwidth: 0.4 * d as f64,
                    ridge: 1e-3,
                    ..Default::default()
                };
                let mut m = crate::LwrModel::new(d, 2, settings).expect("valid");
                for _ in 0..300 {
                    let x: Vec<f64> = (0..d).map(|_| rand()).collect();
                    let y = [x.iter().map(|v| v.sin()).sum::<f64>(), rand()];
                    m.insert(&x, &y).expect("finite");
                }
                for _ in 0..10 {
                    let q: Vec<f64> = (0..d).map(|_| 0.8 * rand()).collect();
                    let (Ok(mean), Ok(p)) = (m.predict_mean(&q), m.predict(&q)) else {
                        continue;
                    };
                    assert_eq!(mean, p.mean, "d {d}, {kernel:?}");
                }
            }
        }
    }

    #[test]
    fn mean_and_jacobian_fast_path_equals_general_pass() {
        // predict_mean_with_jacobian takes the compile-time-sized passes for
        // d <= 8, predict_with_jacobian (which wants confidence) the general
        // ones: bitwise the same mean and Jacobian, with a diagonal metric
        // that ignores an input, a full metric, and the ridges
        let mut rand = crate::strategies::uniform(5u64);
        let mut compared = 0;
        for d in 1..=9 {
            for (case, kernel) in [Kernel::Gaussian, Kernel::Tricube, Kernel::Bisquare]
                .into_iter()
                .enumerate()
            {
                let mut settings = LwrSettings {
                    kernel,
                    bandwidth: 0.5 * d as f64,
                    ridge: 1e-3,
                    ..Default::default()
                };
                match case {
                    0 if d > 1 => {
                        settings.scales = (0..d)
                            .map(|j| if j == 1 { 0.0 } else { 1.0 + 0.3 * j as f64 })
                            .collect();
                        settings.slope_ridge = 0.1;
                        settings.intercept_ridge = 0.01;
                    }
                    1 => {
                        settings.metric = (0..d * d)
                            .map(|t| if t % (d + 1) == 0 { 1.0 } else { 0.2 * rand() })
                            .collect()
                    }
                    _ => {}
                }
                let mut m = crate::LwrModel::new(d, 2, settings).expect("valid");
                for _ in 0..200 {
                    let x: Vec<f64> = (0..d).map(|_| rand()).collect();
                    let y = [x.iter().map(|v| v.sin()).sum::<f64>(), x[0] * x[d - 1] + 0.1 * rand()];
                    m.insert(&x, &y).expect("finite");
                }
                for _ in 0..10 {
                    let q: Vec<f64> = (0..d).map(|_| 0.8 * rand()).collect();
                    let (Ok((mean, jac)), Ok((p, want))) =
                        (m.predict_mean_with_jacobian(&q), m.predict_with_jacobian(&q))
                    else {
                        continue;
                    };
                    assert_eq!(mean, p.mean, "d {d}, {kernel:?}");
                    assert_eq!(mean, m.predict_mean(&q).expect("fitted"), "d {d}, {kernel:?}");
                    for (oo, j) in (0..2).flat_map(|oo| (0..d).map(move |j| (oo, j))) {
                        assert_eq!(
                            jac[(oo, j)].to_bits(),
                            want[(oo, j)].to_bits(),
                            "d {d}, {kernel:?}, ({oo}, {j})"
                        );
                    }
                    compared += 1;
                }
            }
        }
        assert!(compared > 200, "only {compared} queries had a fit");
    }

    /// The one pass over the data and the tree's search find the same
    /// neighbours, bitwise, in the same order, for narrow and wide supports;
    /// a wide support makes the next search a pass and a narrow one the tree.
    #[test]
    fn the_pass_over_the_data_finds_what_the_tree_finds() {
        let d = 3;
        let mut seed = 11u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let n = 800;
        let xs: Vec<Vec<f64>> = (0..n).map(|_| (0..d).map(|_| next()).collect()).collect();
        let mut db = Database::new(d, 1).expect("valid");
        db.insert_many(&xs, &vec![vec![0.0]; n]).expect("finite");
        for metric in [Metric::Diagonal(vec![1.0, 0.0, 3.0]), Metric::Diagonal(vec![1.0; 3])] {
            let index = ScaledIndex::new(&db, &metric);
            for t in 0..20 {
                let q: Vec<f64> = if t % 2 == 0 {
                    xs[t * 37].clone()
                } else {
                    (0..d).map(|_| next()).collect()
                };
                for radius in [0.0, 0.05, 0.3, 2.0] {
                    let mut tree = Scratch::default();
                    find_neighbours(&db, &index, &metric, &q, radius, &mut tree);
                    let mut pass = Scratch {
                        last_found: n,
                        ..Scratch::default()
                    };
                    find_neighbours(&db, &index, &metric, &q, radius, &mut pass);
                    let bits = |v: &[(usize, f64)]| v.iter().map(|&(i, d2)| (i, d2.to_bits())).collect::<Vec<_>>();
                    assert_eq!(bits(&tree.found), bits(&pass.found), "{metric:?} r {radius}");
                    assert!(tree.found.windows(2).all(|w| w[0].0 < w[1].0));
                    // the next search's way follows this one's count
                    assert_eq!(pass.last_found, tree.found.len());
                }
            }
        }
    }

    #[test]
    fn index_order_by_scatter_equals_the_sort() {
        // every size from few points (the sort) to all of them (the scatter)
        let mut rand = crate::strategies::uniform(11u64);
        let n = 300;
        let mut dense = Vec::new();
        for k in [0, 1, 2, 10, 40, 80, 150, 299, 300] {
            let mut idx: Vec<usize> = (0..n).collect();
            // a random permutation's first k
            for t in (1..n).rev() {
                let u = ((rand() + 1.0) / 2.0 * (t + 1) as f64) as usize;
                idx.swap(t, u.min(t));
            }
            let mut found: Vec<(usize, f64)> = idx[..k].iter().map(|&i| (i, rand().abs())).collect();
            let mut want = found.clone();
            want.sort_unstable_by_key(|&(i, _)| i);
            in_index_order(&mut found, n, &mut dense);
            assert_eq!(found, want, "k {k}");
        }
    }

    #[test]
    fn quadratic_row_derivative_matches_differences() {
        let x = [0.3, -0.7, 1.1];
        let q = [0.1, 0.2, -0.4];
        let p = Degree::Quadratic.n_coeffs(3);
        let v: Vec<f64> = (0..p).map(|i| (i as f64 * 0.37).sin()).collect();
        let delta: Vec<f64> = x.iter().zip(&q).map(|(a, b)| a - b).collect();
        for j in 0..3 {
            let e = 1e-6;
            let mut qp = q;
            qp[j] += e;
            let mut qm = q;
            qm[j] -= e;
            let (mut zp, mut zm) = (vec![0.0; p], vec![0.0; p]);
            design_row(Degree::Quadratic, &x, &qp, &mut zp);
            design_row(Degree::Quadratic, &x, &qm, &mut zm);
            let fd: f64 = (0..p).map(|t| v[t] * (zp[t] - zm[t]) / (2.0 * e)).sum();
            let an = dz_dot(Degree::Quadratic, &delta, j, &v, 1);
            assert!((fd - an).abs() < 1e-8, "{fd} vs {an}");
        }
    }
}
