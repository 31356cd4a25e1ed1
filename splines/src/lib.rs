//! Trajectory bases linear in their coefficients: B-splines and wavelets.
//!
//! A trajectory is $y(t) = \sum_j c_j \phi_j(t)$: its samples at times
//! $t_k$ are $\Phi c$ with the sparse design matrix
//! $\Phi_{kj} = \phi_j^{(r)}(t_k)$ ($r$ the derivative order), so an
//! optimiser working on the coefficients gets exact, sparse Jacobians. This is
//! how the paper represents the planned states $x(t)$ and controls $u(t)$
//! (Atkeson 1997, Eq. 3 and Eqs. 6-7: "we can parameterize the trajectory
//! using the spline knot points").
//!
//! - [`TrajectoryBasis`]: the trait: number of coefficients, domain, rows of
//!   the design matrix, sparse design matrices (faer CSR and CSC), evaluation.
//! - [`BSplineBasis`]: B-splines of any degree on clamped, uniform or any
//!   nondecreasing knots; derivatives of any order; knot insertion.
//! - [`wavelet`]: Haar and Daubechies wavelets, multilevel analysis and
//!   synthesis with perfect reconstruction for any signal length, and the
//!   synthesis operator as a basis (coarse-to-fine coefficients).
//! - [`fit_channel`], [`fit_matrix`], [`Trajectory`]: weighted least-squares
//!   fits with ridge or P-spline smoothing, and multi-channel trajectories
//!   sharing one basis (by reference or `Arc`, never copied).
//! - `strategies` (feature `proptest`): proptest strategies for knot
//!   vectors, degrees, sample times and signals.
//!
//! Errors are a typed [`SplineError`]; nothing panics on user input. Times
//! outside a basis' domain are refused, never clamped or extrapolated.
//!
//! # Example: initialise a plan from a demonstration
//!
//! ```
//! use faer::Mat;
//! use splines::{BSplineBasis, FitSettings, Trajectory, TrajectoryBasis};
//!
//! // a demonstration sampled at 60 Hz for 2.5 s: angle and angular velocity
//! let dt = 1.0 / 60.0;
//! let times: Vec<f64> = (0..=150).map(|k| k as f64 * dt).collect();
//! let demo = Mat::from_fn(times.len(), 2, |k, ch| {
//!     let t = times[k];
//!     if ch == 0 { (3.0 * t).sin() } else { 3.0 * (3.0 * t).cos() }
//! });
//!
//! // 25 cubic B-spline coefficients per channel, fitted by least squares
//! let basis = BSplineBasis::clamped_uniform(25, 3, 0.0, 2.5)?;
//! let plan = Trajectory::fit(&basis, &times, demo.as_ref(), &FitSettings::default())?;
//! assert_eq!(plan.coeffs().nrows(), 25);
//!
//! // the sparse design matrix maps coefficients to samples: 4 nonzeros per row
//! let phi = basis.design_matrix(&times, 0)?;
//! assert_eq!(phi.compute_nnz(), 4 * times.len());
//!
//! // the fitted angle is close to the demonstration, and so is its derivative
//! let y = plan.evaluate(&[1.0], 0)?;
//! let dy = plan.evaluate(&[1.0], 1)?;
//! assert!((y[(0, 0)] - 3.0f64.sin()).abs() < 1e-4);
//! assert!((dy[(0, 0)] - 3.0 * 3.0f64.cos()).abs() < 1e-2);
//! # Ok::<(), splines::SplineError>(())
//! ```
#![warn(missing_docs)]

pub mod basis;
pub mod bspline;
pub mod error;
pub mod fit;
#[cfg(feature = "proptest")]
pub mod strategies;
pub mod wavelet;

pub use basis::TrajectoryBasis;
pub use bspline::BSplineBasis;
pub use error::{Result, SplineError};
pub use fit::{FitSettings, Trajectory, fit_channel, fit_matrix};
