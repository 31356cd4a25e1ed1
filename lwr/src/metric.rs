//! The distance of a fit: diagonal scales, or a full matrix.
//!
//! Diagonal: $d^2(x, q) = \sum_j m_j^2 (x_j - q_j)^2$. Full:
//! $d^2(x, q) = |A (x - q)|^2$ with $A = \operatorname{diag}(m) M$ for the
//! user's $d \times d$ matrix $M$ (`LwrSettings::metric`), that is the metric
//! $A^\top A = M^\top \operatorname{diag}(m)^2 M$; the scales then weigh the
//! rows of $M$ (the axes of the coordinates $M x$).
//!
//! The k-d tree prunes with a lower bound on $d^2$ over a box of offsets
//! $v = x - q \in [l, u]$. For the full metric it is, row by row of $A$,
//! $$|A v|^2 = \sum_k (a_k^\top v)^2 \ge \sum_k \min_{v \in [l, u]} (a_k^\top v)^2,$$
//! where $a_k^\top v$ ranges over the interval
//! $[\sum_j \min(a_{kj} l_j, a_{kj} u_j), \sum_j \max(a_{kj} l_j, a_{kj} u_j)]$.
//! The bound holds for every $A$, singular ones included (a row of zeros
//! adds nothing; a direction $A$ ignores is never pruned on), and for a
//! diagonal $A$ it is the exact box distance. It is the distance to the box
//! in the coordinates $A x$ relaxed to a box there, so a search is as tight
//! as the tree's boxes are in those coordinates; the candidates are then
//! filtered by their exact distance. A relative slack of $10^{-12}$ keeps
//! rounding from pruning a point at the edge of the support.

/// Relative slack of the full metric's box bound against rounding.
const BOUND_SLACK: f64 = 1.0 - 1e-12;

/// A full metric $A = \operatorname{diag}(m) M$ and $G = A^\top A$.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct FullMetric {
    d: usize,
    /// $A$, row-major $d \times d$.
    a: Vec<f64>,
    /// $G = A^\top A$, row-major $d \times d$.
    g: Vec<f64>,
}

/// The distance of a fit (validated: lengths match the inputs).
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Metric {
    /// Per-dimension scales $m_j \ge 0$.
    Diagonal(Vec<f64>),
    /// $|A (x - q)|$.
    Full(FullMetric),
}

impl FullMetric {
    /// $A = \operatorname{diag}(m) M$ from the scales and the row-major
    /// matrix $M$ (lengths $d$ and $d^2$, checked by the caller).
    pub(crate) fn new(scales: &[f64], matrix: &[f64]) -> Self {
        let d = scales.len();
        debug_assert_eq!(matrix.len(), d * d);
        let a: Vec<f64> = (0..d * d).map(|t| scales[t / d] * matrix[t]).collect();
        let mut g = vec![0.0; d * d];
        for r in 0..d {
            for c in 0..d {
                g[r * d + c] = (0..d).map(|k| a[k * d + r] * a[k * d + c]).sum();
            }
        }
        Self { d, a, g }
    }

    /// $|A (x - q)|^2$.
    #[inline]
    pub(crate) fn dist2(&self, x: &[f64], q: &[f64]) -> f64 {
        let d = self.d;
        let mut s = 0.0;
        for row in self.a.chunks_exact(d) {
            let mut t = 0.0;
            for j in 0..d {
                t += row[j] * (x[j] - q[j]);
            }
            s += t * t;
        }
        s
    }

    /// A lower bound on $|A v|^2$ over the box of offsets $v \in [l, u]$,
    /// given per dimension by `offsets(j)` $= (l_j, u_j)$.
    #[inline]
    pub(crate) fn min_dist2_with(&self, offsets: impl Fn(usize) -> (f64, f64)) -> f64 {
        let d = self.d;
        let mut s = 0.0;
        for row in self.a.chunks_exact(d) {
            let (mut lo, mut hi) = (0.0, 0.0);
            for (j, a) in row.iter().enumerate() {
                let (l, u) = offsets(j);
                let (p, q) = (a * l, a * u);
                if p < q {
                    lo += p;
                    hi += q;
                } else {
                    lo += q;
                    hi += p;
                }
            }
            let t = if lo > 0.0 {
                lo
            } else if hi < 0.0 {
                hi
            } else {
                0.0
            };
            s += t * t;
        }
        s * BOUND_SLACK
    }

    /// The rows of $A$.
    pub(crate) fn rows(&self) -> std::slice::ChunksExact<'_, f64> {
        self.a.chunks_exact(self.d)
    }

    /// $(G v)_j$.
    #[inline]
    pub(crate) fn g_row_dot(&self, j: usize, v: &[f64]) -> f64 {
        let d = self.d;
        self.g[j * d..(j + 1) * d].iter().zip(v).map(|(g, v)| g * v).sum()
    }
}

impl Metric {
    /// The metric of validated settings for `n_inputs` inputs.
    pub(crate) fn of_settings(settings: &crate::LwrSettings, n_inputs: usize) -> Self {
        let scales = settings.scales_for(n_inputs);
        if settings.metric.is_empty() {
            Metric::Diagonal(scales)
        } else {
            Metric::Full(FullMetric::new(&scales, &settings.metric))
        }
    }

    /// The metric's scale along input $j$: $m_j$, or $\sqrt{G_{jj}}$ for
    /// the full metric (0 exactly when the metric ignores input $j$).
    pub(crate) fn input_scale(&self, j: usize) -> f64 {
        match self {
            Metric::Diagonal(scales) => scales[j],
            Metric::Full(f) => f.g[j * f.d + j].sqrt(),
        }
    }

    /// $d^2(x, q)$.
    #[inline]
    pub(crate) fn dist2(&self, x: &[f64], q: &[f64]) -> f64 {
        match self {
            Metric::Diagonal(scales) => diag_dist2(x, q, scales),
            Metric::Full(f) => f.dist2(x, q),
        }
    }

    /// A lower bound on $d^2(x, q)$ over the offsets $x - q \in [l, u]$
    /// (exact for the diagonal metric).
    #[cfg(test)]
    pub(crate) fn min_dist2_offsets(&self, l: &[f64], u: &[f64]) -> f64 {
        self.min_dist2_with(l.len(), |j| (l[j], u[j]))
    }

    /// A lower bound on $d^2(x, q)$ over the offsets $x - q \in [l, u]$,
    /// given per dimension by `offsets(j)` $= (l_j, u_j)$, $l_j \le u_j$
    /// (exact for the diagonal metric).
    #[inline]
    pub(crate) fn min_dist2_with(&self, d: usize, offsets: impl Fn(usize) -> (f64, f64)) -> f64 {
        match self {
            Metric::Diagonal(scales) => {
                let mut s = 0.0;
                for (j, m) in scales.iter().enumerate().take(d) {
                    let (l, u) = offsets(j);
                    let gap = if l > 0.0 {
                        l
                    } else if u < 0.0 {
                        -u
                    } else {
                        0.0
                    };
                    let t = m * gap;
                    s += t * t;
                }
                s
            }
            Metric::Full(f) => f.min_dist2_with(offsets),
        }
    }

    /// $\frac12 \partial d^2 / \partial x_j = (G (x - q))_j$ for the offsets
    /// `delta` $= x - q$.
    #[inline]
    pub(crate) fn half_grad(&self, j: usize, delta: &[f64]) -> f64 {
        match self {
            Metric::Diagonal(scales) => scales[j] * scales[j] * delta[j],
            Metric::Full(f) => f.g_row_dot(j, delta),
        }
    }
}

/// Squared scaled distance $\sum_j (m_j (x_j - q_j))^2$.
#[inline]
pub(crate) fn diag_dist2(x: &[f64], q: &[f64], scales: &[f64]) -> f64 {
    let mut s = 0.0;
    for j in 0..q.len() {
        let t = scales[j] * (x[j] - q[j]);
        s += t * t;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    #[test]
    fn box_bound_is_below_every_distance_in_the_box() {
        let mut seed = 3;
        for d in 1..=4 {
            for singular in [false, true] {
                let mut matrix: Vec<f64> = (0..d * d).map(|_| lcg(&mut seed)).collect();
                if singular && d > 1 {
                    // the last row a copy of the first: rank d - 1
                    let first = matrix[..d].to_vec();
                    matrix[(d - 1) * d..].copy_from_slice(&first);
                }
                let scales: Vec<f64> = (0..d)
                    .map(|j| {
                        if j == 0 && singular {
                            0.0
                        } else {
                            1.0 + lcg(&mut seed).abs()
                        }
                    })
                    .collect();
                let metric = Metric::Full(FullMetric::new(&scales, &matrix));
                for _ in 0..200 {
                    let l: Vec<f64> = (0..d).map(|_| lcg(&mut seed)).collect();
                    let u: Vec<f64> = l.iter().map(|v| v + 0.5 * (lcg(&mut seed) + 1.0)).collect();
                    let bound = metric.min_dist2_offsets(&l, &u);
                    // corners and random points of the box
                    for _ in 0..50 {
                        let v: Vec<f64> = (0..d)
                            .map(|j| l[j] + (u[j] - l[j]) * 0.5 * (lcg(&mut seed) + 1.0))
                            .collect();
                        let zero = vec![0.0; d];
                        assert!(
                            metric.dist2(&v, &zero) >= bound,
                            "d {d}: bound {bound} above a distance"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn diagonal_matrix_equals_diagonal_scales() {
        let scales = [0.5, 2.0, 0.0];
        let matrix = [3.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 7.0];
        let full = Metric::Full(FullMetric::new(&scales, &matrix));
        let diag = Metric::Diagonal(vec![1.5, 2.0, 0.0]);
        let (x, q) = ([0.3, -0.2, 1.0], [0.1, 0.4, -2.0]);
        assert!((full.dist2(&x, &q) - diag.dist2(&x, &q)).abs() < 1e-15);
        let (l, u) = ([0.2, -1.0, 0.5], [0.4, -0.5, 0.7]);
        let (bf, bd) = (full.min_dist2_offsets(&l, &u), diag.min_dist2_offsets(&l, &u));
        assert!(bf <= bd && bf >= bd * (1.0 - 1e-11), "{bf} vs {bd}");
        let delta = [0.3, -0.1, 2.0];
        for j in 0..3 {
            assert!((full.half_grad(j, &delta) - diag.half_grad(j, &delta)).abs() < 1e-15);
        }
    }

    #[test]
    fn half_gradient_matches_differences() {
        let mut seed = 9;
        let d = 3;
        let matrix: Vec<f64> = (0..d * d).map(|_| lcg(&mut seed)).collect();
        let metric = Metric::Full(FullMetric::new(&[1.0, 0.5, 2.0], &matrix));
        let q = [0.0; 3];
        let x = [0.3, -0.7, 0.2];
        for j in 0..d {
            let e = 1e-6;
            let (mut xp, mut xm) = (x, x);
            xp[j] += e;
            xm[j] -= e;
            let fd = (metric.dist2(&xp, &q) - metric.dist2(&xm, &q)) / (4.0 * e);
            assert!((fd - metric.half_grad(j, &x)).abs() < 1e-8);
        }
    }
}
