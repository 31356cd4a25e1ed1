//! Residuals and Jacobians of functions 20 to 35 (variable $n$). Sizes are
//! checked by the caller: `x` has $n$ entries, `r` has $m$, `jac` has $m n$
//! (row-major) and arrives zeroed. Indices are 0-based here: `x[0]` is the
//! paper's $x_1$, row `i` is $f_{i+1}$.

use super::MghFunction;

use MghFunction as F;

/// Penalty I and II's weight $a = 10^{-5}$.
const PENALTY_A: f64 = 1e-5;

/// $h = 1/(n+1)$ and $t_j = j h$ for the 0-based index `j` (the paper's
/// $t_{j+1}$), computed as $j / (n + 1)$ (correctly rounded).
fn grid(n: usize, j: usize) -> (f64, f64) {
    let np1 = n as f64 + 1.0;
    (1.0 / np1, (j + 1) as f64 / np1)
}

/// The shifted Chebyshev polynomials $T_0, \ldots, T_m$ at $x$ and their
/// derivatives with respect to $x$ (recurrences in $y = 2x - 1$:
/// $T_{k+1} = 2 y T_k - T_{k-1}$, $T'_{k+1} = 4 T_k + 2 y T'_k - T'_{k-1}$,
/// the 4 being $2\,dy/dx$).
fn chebyshev(x: f64, m: usize, t: &mut Vec<f64>, dt: &mut Vec<f64>) {
    let y = 2.0 * x - 1.0;
    t.clear();
    dt.clear();
    t.extend([1.0, y]);
    dt.extend([0.0, 2.0]);
    for k in 1..m {
        t.push(2.0 * y * t[k] - t[k - 1]);
        dt.push(4.0 * t[k] + 2.0 * y * dt[k] - dt[k - 1]);
    }
}

/// Chebyquad's $\int_0^1 T_i$ for the 1-based `i`.
fn chebyshev_integral(i: usize) -> f64 {
    if i.is_multiple_of(2) {
        let k = i as f64;
        -1.0 / (k * k - 1.0)
    } else {
        0.0
    }
}

/// Watson's $t_i$, $\sum_{j \ge 2} (j - 1) x_j t^{j-2}$ and
/// $\sum_j x_j t^{j-1}$ for the 0-based row `i` < 29.
fn watson_sums(x: &[f64], i: usize) -> (f64, f64, f64) {
    let t = (i + 1) as f64 / 29.0;
    let (mut s1, mut s2, mut p) = (0.0, 0.0, 1.0);
    for (j, &xj) in x.iter().enumerate() {
        // p = t^j; x[j] is the paper's x_{j+1}
        s2 += xj * p;
        if j + 1 < x.len() {
            s1 += (j + 1) as f64 * x[j + 1] * p;
        }
        p *= t;
    }
    (t, s1, s2)
}

/// The residuals of functions 20 to 35.
pub(super) fn residuals(f: MghFunction, x: &[f64], r: &mut [f64]) {
    let (n, m) = (x.len(), r.len());
    let nf = n as f64;
    match f {
        F::Watson => {
            for (i, ri) in r.iter_mut().take(29).enumerate() {
                let (_, s1, s2) = watson_sums(x, i);
                *ri = s1 - s2 * s2 - 1.0;
            }
            r[29] = x[0];
            r[30] = x[1] - x[0] * x[0] - 1.0;
        }
        F::ExtendedRosenbrock => {
            for (ri, xi) in r.chunks_exact_mut(2).zip(x.chunks_exact(2)) {
                ri[0] = 10.0 * (xi[1] - xi[0] * xi[0]);
                ri[1] = 1.0 - xi[0];
            }
        }
        F::ExtendedPowellSingular => {
            for (ri, xi) in r.chunks_exact_mut(4).zip(x.chunks_exact(4)) {
                ri[0] = xi[0] + 10.0 * xi[1];
                ri[1] = 5f64.sqrt() * (xi[2] - xi[3]);
                ri[2] = (xi[1] - 2.0 * xi[2]).powi(2);
                ri[3] = 10f64.sqrt() * (xi[0] - xi[3]).powi(2);
            }
        }
        F::PenaltyI => {
            for (ri, &xi) in r.iter_mut().zip(x) {
                *ri = PENALTY_A.sqrt() * (xi - 1.0);
            }
            r[n] = x.iter().map(|v| v * v).sum::<f64>() - 0.25;
        }
        F::PenaltyII => {
            let sa = PENALTY_A.sqrt();
            r[0] = x[0] - 0.2;
            for i in 1..n {
                let y = ((i + 1) as f64 / 10.0).exp() + (i as f64 / 10.0).exp();
                r[i] = sa * ((x[i] / 10.0).exp() + (x[i - 1] / 10.0).exp() - y);
                r[n + i - 1] = sa * ((x[i] / 10.0).exp() - (-0.1f64).exp());
            }
            r[m - 1] = x.iter().enumerate().map(|(j, v)| (n - j) as f64 * v * v).sum::<f64>() - 1.0;
        }
        F::VariablyDimensioned => {
            for (ri, &xi) in r.iter_mut().zip(x) {
                *ri = xi - 1.0;
            }
            let s: f64 = x.iter().enumerate().map(|(j, v)| (j + 1) as f64 * (v - 1.0)).sum();
            r[n] = s;
            r[n + 1] = s * s;
        }
        F::Trigonometric => {
            let sum_cos: f64 = x.iter().map(|v| v.cos()).sum();
            for (i, (ri, &xi)) in r.iter_mut().zip(x).enumerate() {
                *ri = nf - sum_cos + (i + 1) as f64 * (1.0 - xi.cos()) - xi.sin();
            }
        }
        F::BrownAlmostLinear => {
            let sum: f64 = x.iter().sum();
            for (ri, &xi) in r.iter_mut().zip(x).take(n - 1) {
                *ri = xi + sum - (nf + 1.0);
            }
            r[n - 1] = x.iter().product::<f64>() - 1.0;
        }
        F::DiscreteBoundaryValue => {
            for (i, ri) in r.iter_mut().enumerate() {
                let (h, t) = grid(n, i);
                let prev = if i > 0 { x[i - 1] } else { 0.0 };
                let next = if i + 1 < n { x[i + 1] } else { 0.0 };
                *ri = 2.0 * x[i] - prev - next + h * h * (x[i] + t + 1.0).powi(3) / 2.0;
            }
        }
        F::DiscreteIntegralEquation => {
            // q_j = (x_j + t_j + 1)^3; the two sums as prefix and suffix sums
            let q: Vec<f64> = (0..n).map(|j| (x[j] + grid(n, j).1 + 1.0).powi(3)).collect();
            let mut below: f64 = 0.0;
            let mut above: f64 = (0..n).map(|j| (1.0 - grid(n, j).1) * q[j]).sum();
            for (i, ri) in r.iter_mut().enumerate() {
                let (h, t) = grid(n, i);
                below += t * q[i];
                above -= (1.0 - t) * q[i];
                *ri = x[i] + h * ((1.0 - t) * below + t * above) / 2.0;
            }
        }
        F::BroydenTridiagonal => {
            for (i, ri) in r.iter_mut().enumerate() {
                let prev = if i > 0 { x[i - 1] } else { 0.0 };
                let next = if i + 1 < n { x[i + 1] } else { 0.0 };
                *ri = (3.0 - 2.0 * x[i]) * x[i] - prev - 2.0 * next + 1.0;
            }
        }
        F::BroydenBanded => {
            for (i, ri) in r.iter_mut().enumerate() {
                let band: f64 = (i.saturating_sub(5)..(i + 2).min(n))
                    .filter(|&j| j != i)
                    .map(|j| x[j] * (1.0 + x[j]))
                    .sum();
                *ri = x[i] * (2.0 + 5.0 * x[i] * x[i]) + 1.0 - band;
            }
        }
        F::LinearFullRank => {
            let c = 2.0 / m as f64 * x.iter().sum::<f64>() + 1.0;
            for (i, ri) in r.iter_mut().enumerate() {
                *ri = x.get(i).copied().unwrap_or(0.0) - c;
            }
        }
        F::LinearRank1 => {
            let s: f64 = x.iter().enumerate().map(|(j, v)| (j + 1) as f64 * v).sum();
            for (i, ri) in r.iter_mut().enumerate() {
                *ri = (i + 1) as f64 * s - 1.0;
            }
        }
        F::LinearRank1ZeroColumnsRows => {
            let s: f64 = (1..n - 1).map(|j| (j + 1) as f64 * x[j]).sum();
            for (i, ri) in r.iter_mut().enumerate() {
                *ri = if i == 0 || i == m - 1 { -1.0 } else { i as f64 * s - 1.0 };
            }
        }
        F::Chebyquad => {
            let (mut t, mut dt) = (Vec::with_capacity(m + 1), Vec::with_capacity(m + 1));
            r.fill(0.0);
            for &xj in x {
                chebyshev(xj, m, &mut t, &mut dt);
                for (ri, tk) in r.iter_mut().zip(&t[1..]) {
                    *ri += tk;
                }
            }
            for (i, ri) in r.iter_mut().enumerate() {
                *ri = *ri / nf - chebyshev_integral(i + 1);
            }
        }
        _ => {}
    }
}

/// The Jacobian (row-major, zeroed on entry) of functions 20 to 35.
pub(super) fn jacobian(f: MghFunction, x: &[f64], jac: &mut [f64]) {
    let n = x.len();
    let m = jac.len() / n;
    let nf = n as f64;
    let mut rows = jac.chunks_exact_mut(n);
    match f {
        F::Watson => {
            for (i, row) in rows.by_ref().take(29).enumerate() {
                let (t, _, s2) = watson_sums(x, i);
                // d/dx_j (paper's j = col + 1): (j - 1) t^{j-2} - 2 s2 t^{j-1}
                let (mut below, mut p) = (0.0, 1.0);
                for (col, v) in row.iter_mut().enumerate() {
                    // p = t^col, below = t^{col-1} (unused at col = 0)
                    *v = col as f64 * below - 2.0 * s2 * p;
                    below = p;
                    p *= t;
                }
            }
            jac[29 * n] = 1.0;
            jac[30 * n] = -2.0 * x[0];
            jac[30 * n + 1] = 1.0;
        }
        F::ExtendedRosenbrock => {
            for k in 0..n / 2 {
                let (a, b) = (2 * k, 2 * k + 1);
                jac[a * n + a] = -20.0 * x[a];
                jac[a * n + b] = 10.0;
                jac[b * n + a] = -1.0;
            }
        }
        F::ExtendedPowellSingular => {
            let (s5, s10) = (5f64.sqrt(), 10f64.sqrt());
            for k in 0..n / 4 {
                let o = 4 * k;
                let (a, b) = (x[o + 1] - 2.0 * x[o + 2], x[o] - x[o + 3]);
                let mut set = |row: usize, col: usize, v: f64| jac[(o + row) * n + o + col] = v;
                set(0, 0, 1.0);
                set(0, 1, 10.0);
                set(1, 2, s5);
                set(1, 3, -s5);
                set(2, 1, 2.0 * a);
                set(2, 2, -4.0 * a);
                set(3, 0, 2.0 * s10 * b);
                set(3, 3, -2.0 * s10 * b);
            }
        }
        F::PenaltyI => {
            for j in 0..n {
                jac[j * n + j] = PENALTY_A.sqrt();
                jac[n * n + j] = 2.0 * x[j];
            }
        }
        F::PenaltyII => {
            let sa = PENALTY_A.sqrt();
            jac[0] = 1.0;
            for i in 1..n {
                let (ei, ep) = ((x[i] / 10.0).exp(), (x[i - 1] / 10.0).exp());
                jac[i * n + i] = sa * ei / 10.0;
                jac[i * n + i - 1] = sa * ep / 10.0;
                jac[(n + i - 1) * n + i] = sa * ei / 10.0;
            }
            for j in 0..n {
                jac[(m - 1) * n + j] = 2.0 * (n - j) as f64 * x[j];
            }
        }
        F::VariablyDimensioned => {
            let s: f64 = x.iter().enumerate().map(|(j, v)| (j + 1) as f64 * (v - 1.0)).sum();
            for j in 0..n {
                let w = (j + 1) as f64;
                jac[j * n + j] = 1.0;
                jac[n * n + j] = w;
                jac[(n + 1) * n + j] = 2.0 * s * w;
            }
        }
        F::Trigonometric => {
            for (i, row) in rows.enumerate() {
                for (v, xj) in row.iter_mut().zip(x) {
                    *v = xj.sin();
                }
                row[i] += (i + 1) as f64 * x[i].sin() - x[i].cos();
            }
        }
        F::BrownAlmostLinear => {
            for (i, row) in rows.by_ref().take(n - 1).enumerate() {
                row.fill(1.0);
                row[i] = 2.0;
            }
            // d prod / d x_j = prod of the others, by prefix and suffix
            // products (no division, so zeros are fine)
            let last = &mut jac[(n - 1) * n..];
            let mut prefix = 1.0;
            for (v, xj) in last.iter_mut().zip(x) {
                *v = prefix;
                prefix *= xj;
            }
            let mut suffix = 1.0;
            for (v, xj) in last.iter_mut().zip(x).rev() {
                *v *= suffix;
                suffix *= xj;
            }
        }
        F::DiscreteBoundaryValue => {
            for (i, row) in rows.enumerate() {
                let (h, t) = grid(n, i);
                row[i] = 2.0 + 1.5 * h * h * (x[i] + t + 1.0).powi(2);
                if i > 0 {
                    row[i - 1] = -1.0;
                }
                if i + 1 < n {
                    row[i + 1] = -1.0;
                }
            }
        }
        F::DiscreteIntegralEquation => {
            for (i, row) in rows.enumerate() {
                let (h, ti) = grid(n, i);
                for (j, v) in row.iter_mut().enumerate() {
                    let tj = grid(n, j).1;
                    let w = if j <= i { (1.0 - ti) * tj } else { ti * (1.0 - tj) };
                    *v = h / 2.0 * w * 3.0 * (x[j] + tj + 1.0).powi(2);
                }
                row[i] += 1.0;
            }
        }
        F::BroydenTridiagonal => {
            for (i, row) in rows.enumerate() {
                row[i] = 3.0 - 4.0 * x[i];
                if i > 0 {
                    row[i - 1] = -1.0;
                }
                if i + 1 < n {
                    row[i + 1] = -2.0;
                }
            }
        }
        F::BroydenBanded => {
            for (i, row) in rows.enumerate() {
                for j in i.saturating_sub(5)..(i + 2).min(n) {
                    row[j] = if j == i {
                        2.0 + 15.0 * x[i] * x[i]
                    } else {
                        -(1.0 + 2.0 * x[j])
                    };
                }
            }
        }
        F::LinearFullRank => {
            for (i, row) in rows.enumerate() {
                row.fill(-2.0 / m as f64);
                if i < n {
                    row[i] += 1.0;
                }
            }
        }
        F::LinearRank1 => {
            for (i, row) in rows.enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    *v = ((i + 1) * (j + 1)) as f64;
                }
            }
        }
        F::LinearRank1ZeroColumnsRows => {
            for (i, row) in rows.enumerate().take(m - 1).skip(1) {
                for (j, v) in row.iter_mut().enumerate().take(n - 1).skip(1) {
                    *v = (i * (j + 1)) as f64;
                }
            }
        }
        F::Chebyquad => {
            let (mut t, mut dt) = (Vec::with_capacity(m + 1), Vec::with_capacity(m + 1));
            for (j, &xj) in x.iter().enumerate() {
                chebyshev(xj, m, &mut t, &mut dt);
                for i in 0..m {
                    jac[i * n + j] = dt[i + 1] / nf;
                }
            }
        }
        _ => {}
    }
}
