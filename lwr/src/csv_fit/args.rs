//! The command line's values of the kernel, the degree and the tuning's
//! search, and the library's types they stand for.

use serde::Serialize;

use crate::{Degree, Kernel, TuneMethod};

/// The searches of [`TuneMethod`], as command-line values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MethodArg {
    /// [`TuneMethod::LevenbergMarquardt`].
    #[value(help = "Levenberg-Marquardt on the leave-one-out residuals, with their exact derivatives")]
    Lm,
    /// [`TuneMethod::Compass`].
    #[value(help = "the derivative-free compass search (more evaluations)")]
    Compass,
}

impl From<MethodArg> for TuneMethod {
    fn from(m: MethodArg) -> Self {
        match m {
            MethodArg::Lm => TuneMethod::LevenbergMarquardt,
            MethodArg::Compass => TuneMethod::Compass,
        }
    }
}

/// The kernels of [`Kernel`], as command-line values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum KernelArg {
    /// $e^{-u^2/2}$, truncated at 5 bandwidths.
    #[value(help = "exp(-u^2 / 2), truncated at 5 bandwidths")]
    Gaussian,
    /// $(1 - u^3)^3$ on $u < 1$.
    #[value(help = "(1 - u^3)^3 for u < 1")]
    Tricube,
    /// $1 - u^2$ on $u < 1$.
    #[value(help = "1 - u^2 for u < 1")]
    Epanechnikov,
    /// $(1 - u^2)^2$ on $u < 1$.
    #[value(help = "(1 - u^2)^2 for u < 1")]
    Bisquare,
}

impl From<KernelArg> for Kernel {
    fn from(k: KernelArg) -> Self {
        match k {
            KernelArg::Gaussian => Kernel::Gaussian,
            KernelArg::Tricube => Kernel::Tricube,
            KernelArg::Epanechnikov => Kernel::Epanechnikov,
            KernelArg::Bisquare => Kernel::Bisquare,
        }
    }
}

/// The degrees of [`Degree`], as command-line values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DegreeArg {
    /// Local constant (Nadaraya-Watson).
    Constant,
    /// Local linear.
    Linear,
    /// Local quadratic.
    Quadratic,
}

impl From<DegreeArg> for Degree {
    fn from(d: DegreeArg) -> Self {
        match d {
            DegreeArg::Constant => Degree::Constant,
            DegreeArg::Linear => Degree::Linear,
            DegreeArg::Quadratic => Degree::Quadratic,
        }
    }
}
