//! Kernels, polynomial degrees and the checked settings of a fit.

use serde::{Deserialize, Serialize};

use crate::error::{LwrError, Result};

/// A weighting kernel $K(u)$ of the scaled distance $u = d / h$, normalised
/// so that $K(0) = 1$.
///
/// | kernel | $K(u)$ | support |
/// |---|---|---|
/// | `Gaussian` | $e^{-u^2/2}$ | $u < c$ (`gaussian_cutoff`, truncated) |
/// | `Tricube` | $(1 - u^3)^3$ | $u < 1$ |
/// | `Epanechnikov` | $1 - u^2$ | $u < 1$ |
/// | `Bisquare` | $(1 - u^2)^2$ | $u < 1$ |
///
/// The Gaussian is truncated at `gaussian_cutoff` bandwidths so that the
/// tree search stays local: with the default cutoff 5 the weights dropped are
/// below $e^{-12.5} \approx 3.7 \cdot 10^{-6}$. The truncation makes the
/// prediction jump (by that much at most, relatively) when a point crosses
/// the cutoff; tricube and bisquare are $C^1$ at the edge of their support,
/// Epanechnikov has a kink there.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum Kernel {
    /// $e^{-u^2/2}$, truncated at `gaussian_cutoff`.
    #[default]
    Gaussian,
    /// $(1 - |u|^3)^3$ on $|u| < 1$.
    Tricube,
    /// $1 - u^2$ on $|u| < 1$.
    Epanechnikov,
    /// $(1 - u^2)^2$ on $|u| < 1$.
    Bisquare,
}

impl Kernel {
    /// $K(u)$ for $u \ge 0$ (the Gaussian without truncation).
    pub fn value(self, u: f64) -> f64 {
        match self {
            Kernel::Gaussian => (-0.5 * u * u).exp(),
            Kernel::Tricube if u < 1.0 => {
                let t = 1.0 - u * u * u;
                t * t * t
            }
            Kernel::Epanechnikov if u < 1.0 => 1.0 - u * u,
            Kernel::Bisquare if u < 1.0 => {
                let t = 1.0 - u * u;
                t * t
            }
            _ => 0.0,
        }
    }

    /// $K'(u) / u$ for $u \ge 0$ (finite at $u = 0$ for every kernel).
    pub fn slope_over_u(self, u: f64) -> f64 {
        match self {
            Kernel::Gaussian => -(-0.5 * u * u).exp(),
            Kernel::Tricube if u < 1.0 => {
                let t = 1.0 - u * u * u;
                -9.0 * u * t * t
            }
            Kernel::Epanechnikov if u < 1.0 => -2.0,
            Kernel::Bisquare if u < 1.0 => -4.0 * (1.0 - u * u),
            _ => 0.0,
        }
    }

    /// Largest $u$ with nonzero weight: `gaussian_cutoff` for the Gaussian,
    /// 1 for the others.
    pub fn support(self, gaussian_cutoff: f64) -> f64 {
        match self {
            Kernel::Gaussian => gaussian_cutoff,
            _ => 1.0,
        }
    }
}

/// Degree of the local polynomial in $x - q$.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum Degree {
    /// $z = 1$: the kernel-weighted mean (Nadaraya-Watson).
    Constant,
    /// $z = [1, x - q]$: $1 + d$ coefficients.
    #[default]
    Linear,
    /// $z = [1, x - q, (x_a - q_a)(x_b - q_b)_{a \le b}]$:
    /// $1 + d + d(d+1)/2$ coefficients.
    Quadratic,
}

impl Degree {
    /// Number of coefficients $p$ of the local model in `d` inputs.
    pub fn n_coeffs(self, d: usize) -> usize {
        match self {
            Degree::Constant => 1,
            Degree::Linear => 1 + d,
            Degree::Quadratic => 1 + d + d * (d + 1) / 2,
        }
    }
}

/// Settings of a locally weighted fit.
///
/// | name | default | range | meaning |
/// |---|---|---|---|
/// | `kernel` | `Gaussian` | | weighting kernel $K$ |
/// | `bandwidth` | 1 | $> 0$ | $h$ in $k_i = K(d_i / h)$ |
/// | `scales` | `[]` (all 1) | $m_j \ge 0$, length $d$ or empty | metric $d_i^2 = \sum_j m_j^2 (x_{ij} - q_j)^2$; $m_j = 0$ ignores input $j$ in the weights |
/// | `metric` | `[]` (diagonal) | $M$, $d^2$ finite entries row-major, or empty | full metric $d_i = \lVert \operatorname{diag}(m) M (x_i - q) \rVert$ |
/// | `degree` | `Linear` | | local constant, linear or quadratic model |
/// | `ridge` | 0 | $\ge 0$ | $\lambda$ added to the diagonal of $Z^\top K Z$ except the intercept's |
/// | `slope_ridge` | 0 | $\ge 0$ | $\lambda_s$: ridge on each slope per bandwidth unit, $\lambda_s (h / m_j)^2$ on the slope of input $j$; terms of inputs with $m_j = 0$ leave the local polynomial |
/// | `intercept_ridge` | 0 | $\ge 0$ | $\lambda_0$ added to the intercept's diagonal entry: shrinks the prediction towards 0 where the total weight $\sum_i k_i$ is not large against it (a prior mean of 0, e.g. for residuals of a global model) |
/// | `gaussian_cutoff` | 5 | $> 0$ | Gaussian truncated at $u = c$ |
/// | `confidence_level` | 0.95 | $(0, 1)$ | level of the confidence and prediction intervals |
/// | `max_condition` | $10^{10}$ | $> 1$ | largest accepted condition estimate of the (diagonally scaled) normal matrix |
/// | `fallback_ridge` | $10^{-8}$ | $> 0$ | relative ridge added to the scaled normal matrix when it is ill-conditioned |
///
/// The scale of the bandwidth and the scales $m_j$ are redundant (only
/// $m_j / h$ matters); both exist so that $h$ is a single "width" knob and
/// $m$ a shape.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LwrSettings {
    /// Weighting kernel.
    pub kernel: Kernel,
    /// Bandwidth $h > 0$.
    pub bandwidth: f64,
    /// Metric scales $m_j \ge 0$, one per input; empty means all 1.
    pub scales: Vec<f64>,
    /// Full metric matrix $M$, $d \times d$ row-major; empty (the default)
    /// means the diagonal metric. When given, the distance is
    /// $d(x, q) = |\operatorname{diag}(m) M (x - q)|$: the metric
    /// $M^\top \operatorname{diag}(m)^2 M$, with the scales $m$ weighing the
    /// rows of $M$ (the coordinates $M x$), so that [`LwrModel::tune`](crate::LwrModel::tune)
    /// tunes them along $M$'s axes. Models saved before it existed load
    /// with the diagonal metric.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub metric: Vec<f64>,
    /// Degree of the local polynomial.
    pub degree: Degree,
    /// Ridge $\lambda \ge 0$ on every coefficient but the intercept.
    pub ridge: f64,
    /// Ridge $\lambda_s \ge 0$ on the slopes *per bandwidth unit*: the
    /// slope $\beta_j$ of input $j$ pays $\lambda_s (\beta_j h / m_j)^2$,
    /// the change of the local model over one bandwidth along input $j$, so
    /// that one value serves inputs of any unit and any tuned scale (a
    /// quadratic term $\beta_{ab}$ pays $\lambda_s (\beta_{ab} h^2 / (m_a m_b))^2$;
    /// with a full metric $m_j = \sqrt{G_{jj}}$, $G$ the metric's matrix).
    /// Where the metric ignores an input ($m_j = 0$) the penalty is
    /// infinite: the input's terms leave the local polynomial, which then
    /// fits only the inputs the weights see, instead of a slope along the
    /// whole slab of data the zero scale lets in. With $\lambda_s = 0$
    /// (the default) nothing changes. Its derivative in the query is zero,
    /// so predictions' Jacobians stay exact. Models saved before it
    /// existed load with 0.
    #[serde(default)]
    pub slope_ridge: f64,
    /// Ridge $\lambda_0 \ge 0$ on the intercept. With it, and `ridge` on the
    /// slopes, the local model shrinks smoothly to 0 as the data thin out,
    /// instead of extrapolating a fit made from a few far points. Models
    /// saved before it existed load with 0.
    #[serde(default)]
    pub intercept_ridge: f64,
    /// Truncation of the Gaussian kernel, in bandwidths.
    pub gaussian_cutoff: f64,
    /// Level of the intervals, in $(0, 1)$.
    pub confidence_level: f64,
    /// Largest accepted condition estimate before the fallback ridge.
    pub max_condition: f64,
    /// Relative ridge of the regularised fallback.
    pub fallback_ridge: f64,
}

impl Default for LwrSettings {
    fn default() -> Self {
        Self {
            kernel: Kernel::Gaussian,
            bandwidth: 1.0,
            scales: Vec::new(),
            metric: Vec::new(),
            degree: Degree::Linear,
            ridge: 0.0,
            slope_ridge: 0.0,
            intercept_ridge: 0.0,
            gaussian_cutoff: 5.0,
            confidence_level: 0.95,
            max_condition: 1e10,
            fallback_ridge: 1e-8,
        }
    }
}

fn invalid(name: &'static str, reason: String) -> LwrError {
    LwrError::InvalidParameter { name, reason }
}

/// What a scalar setting must be, in words, and the test of it.
type Requirement = (&'static str, fn(f64) -> bool);

const FINITE_POSITIVE: Requirement = ("finite and positive", |v| v.is_finite() && v > 0.0);
const FINITE_NONNEGATIVE: Requirement = ("finite and >= 0", |v| v.is_finite() && v >= 0.0);

/// `Ok` if `value` meets the requirement, else an [`LwrError::InvalidParameter`]
/// naming the setting: "must be (what), got (value)".
fn require(name: &'static str, value: f64, (what, ok): Requirement) -> Result<()> {
    if ok(value) {
        Ok(())
    } else {
        Err(invalid(name, format!("must be {what}, got {value}")))
    }
}

impl LwrSettings {
    /// Checks every field for `n_inputs`-dimensional inputs.
    pub fn validate(&self, n_inputs: usize) -> Result<()> {
        require("bandwidth", self.bandwidth, FINITE_POSITIVE)?;
        if !self.scales.is_empty() && self.scales.len() != n_inputs {
            return Err(LwrError::DimensionMismatch {
                what: "metric scales",
                expected: n_inputs,
                actual: self.scales.len(),
            });
        }
        if let Some(j) = self.scales.iter().position(|m| !(m.is_finite() && *m >= 0.0)) {
            return Err(invalid(
                "scales",
                format!("scale {j} must be finite and nonnegative, got {}", self.scales[j]),
            ));
        }
        if !self.metric.is_empty() && self.metric.len() != n_inputs * n_inputs {
            return Err(LwrError::DimensionMismatch {
                what: "metric matrix (n_inputs^2 entries, row-major)",
                expected: n_inputs * n_inputs,
                actual: self.metric.len(),
            });
        }
        if let Some(t) = self.metric.iter().position(|v| !v.is_finite()) {
            return Err(invalid(
                "metric",
                format!(
                    "entry ({}, {}) must be finite, got {}",
                    t / n_inputs,
                    t % n_inputs,
                    self.metric[t]
                ),
            ));
        }
        require("ridge", self.ridge, FINITE_NONNEGATIVE)?;
        require("slope_ridge", self.slope_ridge, FINITE_NONNEGATIVE)?;
        require("intercept_ridge", self.intercept_ridge, FINITE_NONNEGATIVE)?;
        require("gaussian_cutoff", self.gaussian_cutoff, FINITE_POSITIVE)?;
        require(
            "confidence_level",
            self.confidence_level,
            ("in (0, 1)", |v| v > 0.0 && v < 1.0),
        )?;
        require(
            "max_condition",
            self.max_condition,
            ("finite and > 1", |v| v.is_finite() && v > 1.0),
        )?;
        require("fallback_ridge", self.fallback_ridge, FINITE_POSITIVE)?;
        Ok(())
    }

    /// The metric scales for `n_inputs` inputs (all 1 when `scales` is empty).
    pub fn scales_for(&self, n_inputs: usize) -> Vec<f64> {
        if self.scales.is_empty() {
            vec![1.0; n_inputs]
        } else {
            self.scales.clone()
        }
    }

    /// Largest scaled distance carrying weight: $h$ times the kernel's support.
    pub fn support_radius(&self) -> f64 {
        self.bandwidth * self.kernel.support(self.gaussian_cutoff)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_slopes_match_finite_differences() {
        for k in [
            Kernel::Gaussian,
            Kernel::Tricube,
            Kernel::Epanechnikov,
            Kernel::Bisquare,
        ] {
            assert_eq!(k.value(0.0), 1.0);
            for &u in &[0.1, 0.4, 0.7, 0.95] {
                let e = 1e-6;
                let fd = (k.value(u + e) - k.value(u - e)) / (2.0 * e);
                let an = k.slope_over_u(u) * u;
                assert!((fd - an).abs() < 1e-6, "{k:?} at {u}: {fd} vs {an}");
            }
            if k != Kernel::Gaussian {
                assert_eq!(k.value(1.0), 0.0);
            }
        }
    }

    #[test]
    fn validate_rejects_bad_fields() {
        let ok = LwrSettings::default();
        assert!(ok.validate(2).is_ok());
        let bad = [
            LwrSettings {
                bandwidth: 0.0,
                ..ok.clone()
            },
            LwrSettings {
                bandwidth: f64::NAN,
                ..ok.clone()
            },
            LwrSettings {
                scales: vec![1.0],
                ..ok.clone()
            },
            LwrSettings {
                scales: vec![1.0, -1.0],
                ..ok.clone()
            },
            LwrSettings {
                ridge: -1.0,
                ..ok.clone()
            },
            LwrSettings {
                metric: vec![1.0, 0.0, 0.0],
                ..ok.clone()
            },
            LwrSettings {
                metric: vec![1.0, 0.0, f64::INFINITY, 1.0],
                ..ok.clone()
            },
            LwrSettings {
                confidence_level: 1.0,
                ..ok.clone()
            },
            LwrSettings {
                gaussian_cutoff: 0.0,
                ..ok.clone()
            },
        ];
        for s in bad {
            assert!(s.validate(2).is_err(), "{s:?}");
        }
        assert_eq!(Degree::Quadratic.n_coeffs(3), 10);
    }
}
