//! `proptest` strategies for data sets (enabled by the `proptest` feature).
//! The crate's own property tests use them.
//!
//! Inputs lie in $[-1, 1]^d$ and may repeat (duplicate points are common in
//! logged trajectories); outputs are exact functions of the inputs plus
//! optional noise drawn by the strategy, so every case is reproducible from
//! proptest's seed.

use std::ops::Range;

use faer::Mat;
use proptest::collection::vec;
use proptest::prelude::*;

use crate::error::Result;
use crate::model::LwrModel;
use crate::settings::{Degree, Kernel, LwrSettings};

/// A data set: inputs and outputs, one row per point.
#[derive(Debug, Clone, PartialEq)]
pub struct DataSet {
    /// Input rows, each of length $d$.
    pub inputs: Vec<Vec<f64>>,
    /// Output rows, each of length $o$.
    pub outputs: Vec<Vec<f64>>,
}

impl DataSet {
    /// Number of inputs $d$ (0 for an empty set).
    pub fn n_inputs(&self) -> usize {
        self.inputs.first().map_or(0, Vec::len)
    }

    /// Number of outputs $o$ (0 for an empty set).
    pub fn n_outputs(&self) -> usize {
        self.outputs.first().map_or(0, Vec::len)
    }

    /// A model holding these points.
    pub fn to_model(&self, settings: LwrSettings) -> Result<LwrModel> {
        let mut m = LwrModel::new(self.n_inputs(), self.n_outputs(), settings)?;
        m.insert_many(&self.inputs, &self.outputs)?;
        Ok(m)
    }
}

/// Seeded uniform numbers in $[-1, 1)$: the top 53 bits of Knuth's MMIX
/// linear congruential generator, so that tests, examples and benches that
/// want fixed data (outside proptest) draw the same numbers on every
/// platform.
///
/// ```
/// let mut rand = lwr::strategies::uniform(1);
/// let x = rand();
/// assert!((-1.0..1.0).contains(&x));
/// assert_eq!(x, lwr::strategies::uniform(1)());
/// ```
pub fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// A local fit's normal matrix $Z^\top K Z + \lambda \operatorname{diag}(0, 1, \dots, 1)$
/// ($p \times p$, row-major, symmetric positive definite for enough rows):
/// `rows` design rows $z = [1, u_1, \dots, u_{p-1}]$ and kernel weights
/// $k = k_0 + k_1 u$ (`weight` $= (k_0, k_1)$), every $u$ drawn from `rand`
/// in that order. For the Cholesky's test and bench.
pub fn normal_matrix(
    p: usize,
    rows: usize,
    weight: (f64, f64),
    ridge: f64,
    rand: &mut impl FnMut() -> f64,
) -> Vec<f64> {
    let mut a = vec![0.0; p * p];
    for _ in 0..rows {
        let z: Vec<f64> = (0..p).map(|c| if c == 0 { 1.0 } else { rand() }).collect();
        let k = weight.0 + weight.1 * rand();
        for r in 0..p {
            for c in 0..p {
                a[r * p + c] += k * z[r] * z[c];
            }
        }
    }
    for r in 1..p {
        a[r * p + r] += ridge;
    }
    a
}

/// Any of the four kernels.
pub fn kernels() -> impl Strategy<Value = Kernel> {
    prop_oneof![
        Just(Kernel::Gaussian),
        Just(Kernel::Tricube),
        Just(Kernel::Epanechnikov),
        Just(Kernel::Bisquare)
    ]
}

/// Any of the three degrees.
pub fn degrees() -> impl Strategy<Value = Degree> {
    prop_oneof![Just(Degree::Constant), Just(Degree::Linear), Just(Degree::Quadratic)]
}

/// Diagonal metric scales for `d` inputs: each 0 (the input ignored) or in
/// $[0.3, 2)$.
pub fn metric_scales(d: usize) -> impl Strategy<Value = Vec<f64>> {
    vec(prop_oneof![Just(0.0), 0.3..2.0f64], d)
}

/// `n` input points in $[-1, 1]^d$; with `duplicates`, about one in five
/// is a copy of an earlier point.
pub fn inputs(d: usize, n: Range<usize>, duplicates: bool) -> impl Strategy<Value = Vec<Vec<f64>>> {
    vec((vec(-1.0..1.0f64, d), 0..5u8, any::<prop::sample::Index>()), n).prop_map(move |rows| {
        let mut out: Vec<Vec<f64>> = Vec::with_capacity(rows.len());
        for (x, dup, idx) in rows {
            if duplicates && dup == 0 && !out.is_empty() {
                let prev = out[idx.index(out.len())].clone();
                out.push(prev);
            } else {
                out.push(x);
            }
        }
        out
    })
}

/// Noise values in $[-a, a]$, one per point and output.
fn noise(n: usize, o: usize, amplitude: f64) -> impl Strategy<Value = Vec<f64>> {
    vec(-1.0..1.0f64, n * o).prop_map(move |v| v.into_iter().map(|e| e * amplitude).collect())
}

/// Outputs exactly linear in the inputs, $y = a + B x$ with random $a$, $B$
/// (no noise): local linear and quadratic fits reproduce them exactly.
pub fn linear_data(d: usize, o: usize, n: Range<usize>, duplicates: bool) -> impl Strategy<Value = DataSet> {
    (inputs(d, n, duplicates), vec(-2.0..2.0f64, o * (d + 1))).prop_map(move |(xs, coef)| {
        let outputs = xs
            .iter()
            .map(|x| {
                (0..o)
                    .map(|k| {
                        let c = &coef[k * (d + 1)..(k + 1) * (d + 1)];
                        c[0] + c[1..].iter().zip(x).map(|(a, b)| a * b).sum::<f64>()
                    })
                    .collect()
            })
            .collect();
        DataSet { inputs: xs, outputs }
    })
}

/// A smooth nonlinear target plus uniform noise of amplitude `noise_amp`:
/// output $k$ is $\sin(\sum_j c_{kj} x_j) + \frac12 x_0^2$ with random $c$.
pub fn smooth_data(
    d: usize,
    o: usize,
    n: Range<usize>,
    duplicates: bool,
    noise_amp: f64,
) -> impl Strategy<Value = DataSet> {
    (inputs(d, n, duplicates), vec(-2.0..2.0f64, o * d)).prop_flat_map(move |(xs, coef)| {
        let len = xs.len();
        (Just(xs), Just(coef), noise(len, o, noise_amp)).prop_map(move |(xs, coef, e)| {
            let outputs = xs
                .iter()
                .enumerate()
                .map(|(i, x)| {
                    (0..o)
                        .map(|k| {
                            let s: f64 = coef[k * d..(k + 1) * d].iter().zip(x).map(|(a, b)| a * b).sum();
                            s.sin() + 0.5 * x[0] * x[0] + e[i * o + k]
                        })
                        .collect()
                })
                .collect();
            DataSet { inputs: xs, outputs }
        })
    })
}

/// One output depending on the first `relevant` inputs only,
/// $y = \sin(2 x_0) + \sum_{1 \le j < \text{relevant}} x_j^2$, plus `irrelevant`
/// pure-noise inputs and output noise of amplitude `noise_amp`.
pub fn irrelevant_input_data(
    relevant: usize,
    irrelevant: usize,
    n: Range<usize>,
    noise_amp: f64,
) -> impl Strategy<Value = DataSet> {
    let d = relevant + irrelevant;
    inputs(d, n, false).prop_flat_map(move |xs| {
        let len = xs.len();
        (Just(xs), noise(len, 1, noise_amp)).prop_map(move |(xs, e)| {
            let outputs = xs
                .iter()
                .zip(&e)
                .map(|(x, e)| {
                    let mut y = (2.0 * x[0]).sin() + e;
                    for v in &x[1..relevant.max(1)] {
                        y += v * v;
                    }
                    vec![y]
                })
                .collect();
            DataSet { inputs: xs, outputs }
        })
    })
}

/// The worst disagreement found by [`check_jacobian`]: the workspace's one
/// record of a derivative check, with its error measure.
pub use solve::JacobianCheck;

/// Compares an analytic Jacobian `jacobian` ($o \times d$, of `f` at `q`)
/// with central differences of `f` and returns the worst relative error and
/// where it is.
///
/// The differences are fourth-order central ones with step $e$ = `step`,
/// $$\frac{8 (f(q + e u_j) - f(q - e u_j)) - (f(q + 2 e u_j) - f(q - 2 e u_j))}{12 e},$$
/// whose truncation error ($O(e^4)$) is negligible at a step large enough
/// for the rounding of `f` (amplified by the local fit's condition) to
/// stay small: $e = 10^{-3}$ suits fits with condition up to $10^6$. The
/// queries move by up to $2e$ along each input; an input along which `f`
/// fails at one of them is skipped and counted in
/// [`n_skipped`](JacobianCheck::n_skipped).
///
/// ```
/// use faer::Mat;
/// use lwr::strategies::check_jacobian;
/// // f(q) = (q0 q1, sin q0), with a wrong entry d f1 / d q1 = 1
/// let f = |q: &[f64]| Ok::<_, lwr::LwrError>(vec![q[0] * q[1], q[0].sin()]);
/// let q = [0.3f64, -0.5];
/// let jac = Mat::from_fn(2, 2, |o, j| [[q[1], q[0]], [q[0].cos(), 1.0]][o][j]);
/// let check = check_jacobian(f, &q, &jac, 1e-3);
/// assert_eq!((check.row, check.col), (1, 1));
/// assert!((check.max_rel_error - 1.0).abs() < 1e-9);
/// ```
pub fn check_jacobian<F, E>(f: F, q: &[f64], jacobian: &Mat<f64>, step: f64) -> JacobianCheck
where
    F: Fn(&[f64]) -> std::result::Result<Vec<f64>, E>,
{
    let mut check = JacobianCheck::new();
    let at = |j: usize, t: f64| {
        let mut shifted = q.to_vec();
        shifted[j] += t;
        f(&shifted)
    };
    for j in 0..q.len().min(jacobian.ncols()) {
        let (Ok(p1), Ok(m1), Ok(p2), Ok(m2)) = (at(j, step), at(j, -step), at(j, 2.0 * step), at(j, -2.0 * step))
        else {
            check.n_skipped += 1;
            continue;
        };
        for o in 0..jacobian.nrows().min(p1.len()) {
            let numeric = (8.0 * (p1[o] - m1[o]) - (p2[o] - m2[o])) / (12.0 * step);
            check.record(o, j, jacobian[(o, j)], numeric);
        }
    }
    check
}
