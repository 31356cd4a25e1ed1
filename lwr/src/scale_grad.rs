//! The exact derivatives of the leave-one-out residuals with respect to the
//! logarithms of the metric scales, for the Levenberg-Marquardt tuning
//! ([`TuneMethod::LevenbergMarquardt`](crate::TuneMethod)).
//!
//! At query $q = x_i$ the local fit solves $(Z^\top K Z + R)\beta = Z^\top K y$
//! with $P = (Z^\top K Z + R)^{-1}$, $s = P e_0$, $\hat y_i = e_0^\top \beta$
//! and the leverage $L_{ii} = s_0$ (the point's own weight is $K(0) = 1$).
//! The design rows $z_k$ use the raw offsets $x_k - q$, so only the weights
//! $k_k = K(u_k)$, $u_k^2 = \sum_j m_j^2 (x_{kj} - q_j)^2 / h^2$, and the
//! slope ridge ($\lambda_s L_c^2$, $L_c = h / m_j$) depend on
//! $\theta_j = \log m_j$:
//! $$\frac{\partial k_k}{\partial \theta_j} = \frac{K'(u_k)}{u_k}\,
//! \frac{m_j^2 (x_{kj} - q_j)^2}{h^2}, \qquad
//! \frac{\partial R_{cc}}{\partial \theta_j} = -2\, t_{cj} R_{cc},$$
//! $t_{cj}$ the number of times input $j$ appears in coefficient $c$. With
//! $r_k = y_k - z_k^\top \beta$ and $v_k = z_k^\top s$,
//! $$\partial \hat y_i = \sum_k \partial k_k\, v_k r_k - \sum_c \partial R_{cc}\, s_c \beta_c,
//! \qquad \partial L_{ii} = -\sum_k \partial k_k\, v_k^2 - \sum_c \partial R_{cc}\, s_c^2,$$
//! and the leave-one-out residual $e_i = (y_i - \hat y_i) / (1 - L_{ii})$ has
//! $$\partial e_i = \frac{-\partial \hat y_i + e_i\, \partial L_{ii}}{1 - L_{ii}}.$$
//! The fallback ridge of an ill-conditioned fit is held fixed, and the
//! truncation of the Gaussian at `gaussian_cutoff` bandwidths (a weight of
//! $e^{-12.5}$ at the default) is not differentiated.

use crate::database::Database;
use crate::fit::{LocalFit, coefficient_length, design_row, weight};
use crate::metric::Metric;
use crate::settings::{Degree, LwrSettings};

/// Buffers of [`residual_derivatives`], reused across queries.
#[derive(Debug, Default)]
pub(crate) struct GradScratch {
    z: Vec<f64>,
    /// $\partial \hat y / \partial \theta$, $o \times d$.
    dyhat: Vec<f64>,
    /// $\partial L_{ii} / \partial \theta$, $d$.
    dl: Vec<f64>,
    /// How many times each input appears in one coefficient.
    count: Vec<f64>,
    /// $v_k r_k$ per output.
    vr: Vec<f64>,
}

/// Adds to `count` how often each input appears in coefficient `c` of the
/// local polynomial ($c \ge 1$).
fn inputs_of_coefficient(degree: Degree, d: usize, c: usize, count: &mut [f64]) {
    if c <= d {
        count[c - 1] += 1.0;
        return;
    }
    debug_assert_eq!(degree, Degree::Quadratic);
    let mut t = d + 1;
    for a in 0..d {
        for b in a..d {
            if t == c {
                count[a] += 1.0;
                count[b] += 1.0;
                return;
            }
            t += 1;
        }
    }
}

/// The derivatives of point `i`'s leave-one-out residuals `e` ($o$ of them)
/// with respect to $\theta_j = \log m_j$, written to `out` ($o \times d$,
/// row-major), from its fit at $q = x_i$ (leverage `lii` $< 1$), the
/// neighbours the fit used (`found`, `(index, d^2)`) and the diagonal
/// metric's `scales`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn residual_derivatives(
    db: &Database,
    settings: &LwrSettings,
    metric: &Metric,
    scales: &[f64],
    i: usize,
    fit: &LocalFit,
    found: &[(usize, f64)],
    e: &[f64],
    scratch: &mut GradScratch,
    out: &mut [f64],
) {
    let (d, o) = (db.n_inputs(), db.n_outputs());
    let p = fit.p;
    let h = settings.bandwidth;
    let h2 = h * h;
    let inputs = db.inputs();
    let outputs = db.outputs();
    let q = &inputs[i * d..(i + 1) * d];
    let GradScratch {
        z,
        dyhat,
        dl,
        count,
        vr,
    } = scratch;
    z.clear();
    z.resize(p, 0.0);
    dyhat.clear();
    dyhat.resize(o * d, 0.0);
    dl.clear();
    dl.resize(d, 0.0);
    for &(k, d2) in found {
        let w = weight(settings.kernel, d2, h);
        if w <= 0.0 || k == i {
            continue;
        }
        let u = d2.sqrt() / h;
        let g = settings.kernel.slope_over_u(u);
        let x = &inputs[k * d..(k + 1) * d];
        design_row(settings.degree, x, q, z);
        let v: f64 = z.iter().zip(&fit.s).map(|(a, b)| a * b).sum();
        // v r_k per output, r_k the local fit's residual at the neighbour
        vr.clear();
        vr.extend((0..o).map(|oo| {
            let pred: f64 = z.iter().enumerate().map(|(r, zr)| zr * fit.beta[r * o + oo]).sum();
            v * (outputs[k * o + oo] - pred)
        }));
        for j in 0..d {
            let t = scales[j] * (x[j] - q[j]);
            let dk = g * t * t / h2;
            dl[j] -= dk * v * v;
            for (oo, vr) in vr.iter().enumerate() {
                dyhat[oo * d + j] += dk * vr;
            }
        }
    }
    if settings.slope_ridge > 0.0 {
        count.clear();
        count.resize(d, 0.0);
        for c in 1..p {
            let length = coefficient_length(settings.degree, metric, h, d, c);
            if !length.is_finite() {
                // removed from the fit: its coefficient is 0 whatever the scales
                continue;
            }
            let r_cc = settings.slope_ridge * length * length;
            count.fill(0.0);
            inputs_of_coefficient(settings.degree, d, c, count);
            for j in 0..d {
                let dr = -2.0 * count[j] * r_cc;
                if dr == 0.0 {
                    continue;
                }
                dl[j] -= dr * fit.s[c] * fit.s[c];
                for oo in 0..o {
                    dyhat[oo * d + j] -= dr * fit.s[c] * fit.beta[c * o + oo];
                }
            }
        }
    }
    let one_minus = 1.0 - fit.s[0];
    for oo in 0..o {
        for j in 0..d {
            out[oo * d + j] = (-dyhat[oo * d + j] + e[oo] * dl[j]) / one_minus;
        }
    }
}
