//! Residuals and Jacobians of functions 1 to 19 (fixed $n$; the data-fitting
//! problems). Sizes are checked by the caller: `x` has $n$ entries, `r` has
//! $m$, `jac` has $m n$ (row-major) and arrives zeroed. Indices are 0-based
//! here: `x[0]` is the paper's $x_1$, row `i` is $f_{i+1}$.

use std::f64::consts::PI;

use super::MghFunction;
use super::data::{BARD_Y, GAUSSIAN_Y, KOWALIK_OSBORNE_U, KOWALIK_OSBORNE_Y, MEYER_Y, OSBORNE1_Y, OSBORNE2_Y};

use MghFunction as F;

/// Helical valley's $\theta(x_1, x_2)$ (see [`MghFunction::HelicalValley`]).
fn helical_theta(x1: f64, x2: f64) -> f64 {
    if x1 > 0.0 {
        (x2 / x1).atan() / (2.0 * PI)
    } else if x1 < 0.0 {
        (x2 / x1).atan() / (2.0 * PI) + 0.5
    } else if x2 >= 0.0 {
        0.25
    } else {
        -0.25
    }
}

/// Gulf's abscissa $t_i$ and $y_i = 25 + (-50 \ln t_i)^{2/3}$ for the
/// 1-based index `i`.
fn gulf_ty(i: usize) -> (f64, f64) {
    let t = i as f64 / 100.0;
    // -50 ln t >= 0 for t <= 1; max(0) keeps t = 1 from giving -0
    (t, 25.0 + (-50.0 * t.ln()).max(0.0).powf(2.0 / 3.0))
}

/// Biggs EXP6's data $y_i$ at $t_i$.
fn biggs_y(t: f64) -> f64 {
    (-t).exp() - 5.0 * (-10.0 * t).exp() + 3.0 * (-4.0 * t).exp()
}

/// The residuals of functions 1 to 19.
pub(super) fn residuals(f: MghFunction, x: &[f64], r: &mut [f64]) {
    match f {
        F::Rosenbrock => {
            r[0] = 10.0 * (x[1] - x[0] * x[0]);
            r[1] = 1.0 - x[0];
        }
        F::FreudensteinRoth => {
            r[0] = -13.0 + x[0] + ((5.0 - x[1]) * x[1] - 2.0) * x[1];
            r[1] = -29.0 + x[0] + ((x[1] + 1.0) * x[1] - 14.0) * x[1];
        }
        F::PowellBadlyScaled => {
            r[0] = 1e4 * x[0] * x[1] - 1.0;
            r[1] = (-x[0]).exp() + (-x[1]).exp() - 1.0001;
        }
        F::BrownBadlyScaled => {
            r[0] = x[0] - 1e6;
            r[1] = x[1] - 2e-6;
            r[2] = x[0] * x[1] - 2.0;
        }
        F::Beale => {
            for (i, (ri, y)) in r.iter_mut().zip([1.5, 2.25, 2.625]).enumerate() {
                *ri = y - x[0] * (1.0 - x[1].powi(i as i32 + 1));
            }
        }
        F::JennrichSampson => {
            for (i, ri) in r.iter_mut().enumerate() {
                let k = (i + 1) as f64;
                *ri = 2.0 + 2.0 * k - ((k * x[0]).exp() + (k * x[1]).exp());
            }
        }
        F::HelicalValley => {
            r[0] = 10.0 * (x[2] - 10.0 * helical_theta(x[0], x[1]));
            r[1] = 10.0 * (x[0].hypot(x[1]) - 1.0);
            r[2] = x[2];
        }
        F::Bard => {
            for (i, ri) in r.iter_mut().enumerate() {
                let (u, v) = ((i + 1) as f64, (15 - i) as f64);
                *ri = BARD_Y[i] - (x[0] + u / (v * x[1] + u.min(v) * x[2]));
            }
        }
        F::Gaussian => {
            for (i, ri) in r.iter_mut().enumerate() {
                let s = (7.0 - i as f64) / 2.0 - x[2];
                *ri = x[0] * (-x[1] * s * s / 2.0).exp() - GAUSSIAN_Y[i];
            }
        }
        F::Meyer => {
            for (i, ri) in r.iter_mut().enumerate() {
                let t = 45.0 + 5.0 * (i + 1) as f64;
                *ri = x[0] * (x[1] / (t + x[2])).exp() - MEYER_Y[i];
            }
        }
        F::Gulf => {
            for (i, ri) in r.iter_mut().enumerate() {
                let (t, y) = gulf_ty(i + 1);
                *ri = (-(y - x[1]).abs().powf(x[2]) / x[0]).exp() - t;
            }
        }
        F::Box3d => {
            for (i, ri) in r.iter_mut().enumerate() {
                let t = (i + 1) as f64 / 10.0;
                *ri = (-t * x[0]).exp() - (-t * x[1]).exp() - x[2] * ((-t).exp() - (-10.0 * t).exp());
            }
        }
        F::PowellSingular => {
            r[0] = x[0] + 10.0 * x[1];
            r[1] = 5f64.sqrt() * (x[2] - x[3]);
            r[2] = (x[1] - 2.0 * x[2]).powi(2);
            r[3] = 10f64.sqrt() * (x[0] - x[3]).powi(2);
        }
        F::Wood => {
            r[0] = 10.0 * (x[1] - x[0] * x[0]);
            r[1] = 1.0 - x[0];
            r[2] = 90f64.sqrt() * (x[3] - x[2] * x[2]);
            r[3] = 1.0 - x[2];
            r[4] = 10f64.sqrt() * (x[1] + x[3] - 2.0);
            r[5] = (x[1] - x[3]) / 10f64.sqrt();
        }
        F::KowalikOsborne => {
            for (i, ri) in r.iter_mut().enumerate() {
                let u = KOWALIK_OSBORNE_U[i];
                *ri = KOWALIK_OSBORNE_Y[i] - x[0] * (u * u + u * x[1]) / (u * u + u * x[2] + x[3]);
            }
        }
        F::BrownDennis => {
            for (i, ri) in r.iter_mut().enumerate() {
                let t = (i + 1) as f64 / 5.0;
                let a = x[0] + t * x[1] - t.exp();
                let b = x[2] + x[3] * t.sin() - t.cos();
                *ri = a * a + b * b;
            }
        }
        F::Osborne1 => {
            for (i, ri) in r.iter_mut().enumerate() {
                let t = 10.0 * i as f64;
                *ri = OSBORNE1_Y[i] - (x[0] + x[1] * (-t * x[3]).exp() + x[2] * (-t * x[4]).exp());
            }
        }
        F::BiggsExp6 => {
            for (i, ri) in r.iter_mut().enumerate() {
                let t = (i + 1) as f64 / 10.0;
                *ri = x[2] * (-t * x[0]).exp() - x[3] * (-t * x[1]).exp() + x[5] * (-t * x[4]).exp() - biggs_y(t);
            }
        }
        F::Osborne2 => {
            for (i, ri) in r.iter_mut().enumerate() {
                let t = i as f64 / 10.0;
                let mut model = x[0] * (-t * x[4]).exp();
                for k in 0..3 {
                    let d = t - x[8 + k];
                    model += x[1 + k] * (-d * d * x[5 + k]).exp();
                }
                *ri = OSBORNE2_Y[i] - model;
            }
        }
        _ => {}
    }
}

/// The Jacobian (row-major, zeroed on entry) of functions 1 to 19.
pub(super) fn jacobian(f: MghFunction, x: &[f64], jac: &mut [f64]) {
    let n = x.len();
    let rows = jac.chunks_exact_mut(n);
    match f {
        F::Rosenbrock => jac.copy_from_slice(&[-20.0 * x[0], 10.0, -1.0, 0.0]),
        F::FreudensteinRoth => {
            let y = x[1];
            jac.copy_from_slice(&[1.0, 10.0 * y - 3.0 * y * y - 2.0, 1.0, 3.0 * y * y + 2.0 * y - 14.0]);
        }
        F::PowellBadlyScaled => {
            jac.copy_from_slice(&[1e4 * x[1], 1e4 * x[0], -(-x[0]).exp(), -(-x[1]).exp()]);
        }
        F::BrownBadlyScaled => jac.copy_from_slice(&[1.0, 0.0, 0.0, 1.0, x[1], x[0]]),
        F::Beale => {
            for (i, row) in rows.enumerate() {
                let k = i as i32 + 1;
                row[0] = -(1.0 - x[1].powi(k));
                row[1] = x[0] * f64::from(k) * x[1].powi(k - 1);
            }
        }
        F::JennrichSampson => {
            for (i, row) in rows.enumerate() {
                let k = (i + 1) as f64;
                row[0] = -k * (k * x[0]).exp();
                row[1] = -k * (k * x[1]).exp();
            }
        }
        F::HelicalValley => {
            let rho2 = x[0] * x[0] + x[1] * x[1];
            if rho2 > 0.0 {
                let rho = rho2.sqrt();
                // d theta / d x1 = -x2 / (2 pi rho^2), d theta / d x2 = x1 / (2 pi rho^2)
                let c = 100.0 / (2.0 * PI * rho2);
                jac[0] = c * x[1];
                jac[1] = -c * x[0];
                jac[3] = 10.0 * x[0] / rho;
                jac[4] = 10.0 * x[1] / rho;
            }
            jac[2] = 10.0;
            jac[8] = 1.0;
        }
        F::Bard => {
            for (i, row) in rows.enumerate() {
                let (u, v) = ((i + 1) as f64, (15 - i) as f64);
                let w = u.min(v);
                let d = v * x[1] + w * x[2];
                let d2 = d * d;
                row.copy_from_slice(&[-1.0, u * v / d2, u * w / d2]);
            }
        }
        F::Gaussian => {
            for (i, row) in rows.enumerate() {
                let s = (7.0 - i as f64) / 2.0 - x[2];
                let e = (-x[1] * s * s / 2.0).exp();
                row.copy_from_slice(&[e, -x[0] * e * s * s / 2.0, x[0] * e * x[1] * s]);
            }
        }
        F::Meyer => {
            for (i, row) in rows.enumerate() {
                let d = 45.0 + 5.0 * (i + 1) as f64 + x[2];
                let e = (x[1] / d).exp();
                row.copy_from_slice(&[e, x[0] * e / d, -x[0] * e * x[1] / (d * d)]);
            }
        }
        F::Gulf => {
            for (i, row) in rows.enumerate() {
                let (_, y) = gulf_ty(i + 1);
                let a = (y - x[1]).abs();
                let p = a.powf(x[2]);
                let e = (-p / x[0]).exp();
                row[0] = e * p / (x[0] * x[0]);
                if a > 0.0 {
                    // d|y - x2|/dx2 = -sign(y - x2)
                    row[1] = e * x[2] * a.powf(x[2] - 1.0) * (y - x[1]).signum() / x[0];
                    row[2] = -e * p * a.ln() / x[0];
                }
            }
        }
        F::Box3d => {
            for (i, row) in rows.enumerate() {
                let t = (i + 1) as f64 / 10.0;
                row.copy_from_slice(&[
                    -t * (-t * x[0]).exp(),
                    t * (-t * x[1]).exp(),
                    -((-t).exp() - (-10.0 * t).exp()),
                ]);
            }
        }
        F::PowellSingular => {
            let (s5, s10) = (5f64.sqrt(), 10f64.sqrt());
            let (a, b) = (x[1] - 2.0 * x[2], x[0] - x[3]);
            jac.copy_from_slice(&[
                1.0,
                10.0,
                0.0,
                0.0,
                0.0,
                0.0,
                s5,
                -s5,
                0.0,
                2.0 * a,
                -4.0 * a,
                0.0,
                2.0 * s10 * b,
                0.0,
                0.0,
                -2.0 * s10 * b,
            ]);
        }
        F::Wood => {
            let (s90, s10) = (90f64.sqrt(), 10f64.sqrt());
            jac[0] = -20.0 * x[0];
            jac[1] = 10.0;
            jac[4] = -1.0;
            jac[10] = -2.0 * s90 * x[2];
            jac[11] = s90;
            jac[14] = -1.0;
            jac[17] = s10;
            jac[19] = s10;
            jac[21] = 1.0 / s10;
            jac[23] = -1.0 / s10;
        }
        F::KowalikOsborne => {
            for (i, row) in rows.enumerate() {
                let u = KOWALIK_OSBORNE_U[i];
                let num = u * u + u * x[1];
                let den = u * u + u * x[2] + x[3];
                let q = x[0] * num / (den * den);
                row.copy_from_slice(&[-num / den, -x[0] * u / den, q * u, q]);
            }
        }
        F::BrownDennis => {
            for (i, row) in rows.enumerate() {
                let t = (i + 1) as f64 / 5.0;
                let a = x[0] + t * x[1] - t.exp();
                let b = x[2] + x[3] * t.sin() - t.cos();
                row.copy_from_slice(&[2.0 * a, 2.0 * a * t, 2.0 * b, 2.0 * b * t.sin()]);
            }
        }
        F::Osborne1 => {
            for (i, row) in rows.enumerate() {
                let t = 10.0 * i as f64;
                let (e4, e5) = ((-t * x[3]).exp(), (-t * x[4]).exp());
                row.copy_from_slice(&[-1.0, -e4, -e5, t * x[1] * e4, t * x[2] * e5]);
            }
        }
        F::BiggsExp6 => {
            for (i, row) in rows.enumerate() {
                let t = (i + 1) as f64 / 10.0;
                let (e1, e2, e5) = ((-t * x[0]).exp(), (-t * x[1]).exp(), (-t * x[4]).exp());
                row.copy_from_slice(&[-t * x[2] * e1, t * x[3] * e2, e1, -e2, -t * x[5] * e5, e5]);
            }
        }
        F::Osborne2 => {
            for (i, row) in rows.enumerate() {
                let t = i as f64 / 10.0;
                let e = (-t * x[4]).exp();
                row[0] = -e;
                row[4] = t * x[0] * e;
                for k in 0..3 {
                    let d = t - x[8 + k];
                    let g = (-d * d * x[5 + k]).exp();
                    row[1 + k] = -g;
                    row[5 + k] = x[1 + k] * d * d * g;
                    row[8 + k] = -2.0 * x[1 + k] * x[5 + k] * d * g;
                }
            }
        }
        _ => {}
    }
}
