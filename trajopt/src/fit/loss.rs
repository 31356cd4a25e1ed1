//! The robust losses of [`LeastSquares`](super::LeastSquares), with scipy's
//! names and definitions, and the residual transform that lets every
//! least-squares solver minimise them.

/// A robust loss $\rho$ applied to each squared residual, with scipy's
/// names and definitions: with $z = (r / C)^2$ ($C$ the scale,
/// [`LeastSquares::loss`](super::LeastSquares::loss)) the cost is $\sum_i C^2 \rho(z_i)$.
///
/// | loss | $\rho(z)$ |
/// |---|---|
/// | `Linear` | $z$ (plain least squares) |
/// | `SoftL1` | $2(\sqrt{1 + z} - 1)$ |
/// | `Huber` | $z$ for $z \le 1$, $2\sqrt z - 1$ beyond |
/// | `Cauchy` | $\ln(1 + z)$ |
/// | `Arctan` | $\arctan z$ |
///
/// The solvers minimise it as the plain sum of squares of the
/// transformed residuals $\tilde r_i = \operatorname{sign}(r_i) C
/// \sqrt{\rho(z_i)}$ (so $\sum \tilde r_i^2$ is the robust cost and its
/// stationary points are the robust cost's), with the Jacobian's rows
/// scaled by $d\tilde r_i / dr_i = \rho'(z_i) |r_i| / (C \sqrt{\rho(z_i)})$.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum Loss {
    /// $\rho(z) = z$.
    #[default]
    Linear,
    /// $\rho(z) = 2(\sqrt{1 + z} - 1)$.
    SoftL1,
    /// $\rho(z) = z$ for $z \le 1$, $2\sqrt z - 1$ beyond.
    Huber,
    /// $\rho(z) = \ln(1 + z)$.
    Cauchy,
    /// $\rho(z) = \arctan z$.
    Arctan,
}

impl Loss {
    /// $\rho(z)$ and $\rho'(z)$.
    pub fn rho(self, z: f64) -> (f64, f64) {
        match self {
            Self::Linear => (z, 1.0),
            Self::SoftL1 => {
                // 2 (s - 1) as 2 z / (s + 1): no cancellation for small z
                let s = (1.0 + z).sqrt();
                (2.0 * z / (s + 1.0), 1.0 / s)
            }
            Self::Huber if z <= 1.0 => (z, 1.0),
            Self::Huber => {
                let s = z.sqrt();
                (2.0 * s - 1.0, 1.0 / s)
            }
            Self::Cauchy => (z.ln_1p(), 1.0 / (1.0 + z)),
            Self::Arctan => (z.atan(), 1.0 / (1.0 + z * z)),
        }
    }

    /// The transformed residual $\tilde r$ of `r` at scale `c`, and
    /// $d\tilde r / dr$.
    pub(super) fn transform(self, r: f64, c: f64) -> (f64, f64) {
        if self == Self::Linear {
            return (r, 1.0);
        }
        let z = (r / c).powi(2);
        let (rho, drho) = self.rho(z);
        let root = rho.max(0.0).sqrt();
        let slope = if root > 0.0 { drho * r.abs() / (c * root) } else { 1.0 };
        (r.signum() * c * root, slope)
    }
}
