//! Locally weighted regression on a k-d tree (Atkeson, Moore & Schaal,
//! "Locally weighted learning", 1997).
//!
//! A [`LwrModel`] stores points $(x_i, y_i)$ and answers each query $q$ with
//! a weighted least-squares fit around it. With the diagonal metric
//! $d_i^2 = \sum_j m_j^2 (x_{ij} - q_j)^2$ (or the full metric
//! $d_i = |\operatorname{diag}(m) M (x_i - q)|$ for a matrix $M$ given in
//! [`LwrSettings::metric`]), kernel weights
//! $k_i = K(d_i / h)$, design rows $z_i = [1, x_i - q]$ (or $z_i = 1$, or with
//! the quadratic terms) and the ridge $\Lambda = \lambda\,\mathrm{diag}(0, 1, \dots, 1)$
//! that leaves the intercept free:
//!
//! $$P = (Z^\top K Z + \Lambda)^{-1}, \quad \beta = P Z^\top K y, \quad \hat y(q) = \beta_0 = l(q)^\top y, \quad l_i = k_i z_i^\top P e_0 .$$
//!
//! Confidence ([`Prediction`]): $n_{lwr} = \sum_i k_i$,
//! $p_{lwr} = \sum_i k_i^2 z_i^\top P z_i$,
//! $\sigma^2 = \sum_i k_i r_i^2 / (n_{lwr} - p_{lwr})$,
//! $\operatorname{Var} \hat y = \sigma^2 |l|^2$ and Student-t intervals with
//! $n_{lwr} - p_{lwr}$ degrees of freedom. Leave-one-out residuals are
//! closed form, $e_{(-i)} = (y_i - \hat y(x_i)) / (1 - L_{ii})$ with
//! $L_{ii} = K(0) z_i^\top P(x_i) z_i$ ([`LooResult`]), and
//! [`LwrModel::tune`] minimises them over $h$ and every $m_j$, down to
//! $m_j = 0$ for an input the weights do not need (an irrelevant input, or
//! one the local model already captures globally, such as a linear effect
//! under a local linear fit). The search is exact by default; with
//! [`TuneSettings::search_points`] it compares settings by the
//! leave-one-out errors of a fixed subset of the points (much cheaper on
//! large databases) and reports the full objective at its start and end.
//!
//! - [`Database`]: the points and a k-d tree with incremental inserts;
//!   radius and k-nearest queries under the diagonal metric. Fits under a
//!   full metric search the same tree with a lower bound on the distance
//!   to each node's box (exact pruning, then an exact distance filter).
//! - [`LwrSettings`], [`Kernel`], [`Degree`]: the checked settings of a fit,
//!   among them the metric: diagonal `scales`, optionally with a full
//!   matrix `metric` $M$ (the scales then weigh the rows of $M$, so tuning
//!   works along $M$'s axes; $M$ itself is not tuned).
//! - [`LwrModel`], the model: [`predict`](LwrModel::predict),
//!   [`predict_with_jacobian`](LwrModel::predict_with_jacobian) (exact
//!   $\partial \hat y / \partial q$), [`predict_batch`](LwrModel::predict_batch) and
//!   [`predict_batch_with_jacobian`](LwrModel::predict_batch_with_jacobian)
//!   (rayon), [`loo`](LwrModel::loo), [`tune`](LwrModel::tune), save and load
//!   (serde JSON).
//! - `strategies` (feature `proptest`): proptest strategies for data sets,
//!   and `check_jacobian`, the worst relative error of a Jacobian against
//!   central differences and where it is.
//! - Feature `nalgebra`: `Database::from_matrices` and
//!   `LwrModel::from_matrices` (one point per row of nalgebra's `DMatrix`),
//!   queries as `DVector`s and the Jacobian as a `DMatrix`
//!   (`LwrModel::predict_with_jacobian_dmatrix`).
//! - `csv_fit` (feature `cli`): the CSV fit tool, with typed errors naming
//!   the file, line, row and column; the binary `lwr-fit` runs it
//!   (`cargo run -p lwr --features cli --bin lwr-fit -- --help`).
//!
//! Errors are a typed [`LwrError`]; nothing panics on user input. A query
//! where no point carries weight is an error ([`LwrError::NoWeightedData`]),
//! never a silent number; a fit that exists but is weak says so in
//! [`Prediction::status`].
//!
//! # Example
//!
//! ```
//! use lwr::{Kernel, LwrModel, LwrSettings, TuneSettings};
//!
//! // y = sin(3 x0) + 0.5 x1 + noise, and a third input that does not matter
//! let settings = LwrSettings { kernel: Kernel::Gaussian, bandwidth: 0.3, ..Default::default() };
//! let mut model = LwrModel::new(3, 1, settings)?;
//! let mut seed = 1u64;
//! let mut rand = move || {
//!     seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
//!     (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
//! };
//! for _ in 0..400 {
//!     let x = [rand(), rand(), rand()];
//!     let y = (3.0 * x[0]).sin() + 0.5 * x[1] + 0.02 * rand();
//!     model.insert(&x, &[y])?; // any time, no rebuild from scratch
//! }
//!
//! // tune the bandwidth and metric by leave-one-out cross-validation
//! let tuned = model.tune(&TuneSettings { max_evals: 80, ..Default::default() })?;
//! assert!(tuned.objective < tuned.initial_objective);
//! println!("scales {:?}, h {}", tuned.settings.scales, tuned.settings.bandwidth);
//! model.set_settings(tuned.settings)?;
//!
//! // prediction with confidence
//! let q = [0.1, 0.2, 0.0];
//! let p = model.predict(&q)?;
//! assert!(p.is_ok());
//! let truth = (0.3f64).sin() + 0.1;
//! assert!((p.mean[0] - truth).abs() < 0.05);
//! println!("{:.3} +- {:.3} (n_lwr = {:.1})", p.mean[0], p.confidence_half_width[0], p.n_lwr);
//!
//! // exact Jacobian of the prediction with respect to the query
//! let (_, jac) = model.predict_with_jacobian(&q)?;
//! assert!((jac[(0, 0)] - 3.0 * (0.3f64).cos()).abs() < 0.5);
//! assert!((jac[(0, 1)] - 0.5).abs() < 0.3);
//!
//! // save and load
//! let text = model.to_json()?;
//! let back = LwrModel::from_json(&text)?;
//! assert_eq!(back.predict(&q)?.mean, p.mean);
//! # Ok::<(), lwr::LwrError>(())
//! ```
#![warn(missing_docs)]

#[cfg(feature = "cli")]
pub mod csv_fit;
mod database;
mod error;
mod factor;
mod fit;
mod kdtree;
mod loo;
mod metric;
mod model;
#[cfg(feature = "nalgebra")]
mod nalgebra_interop;
mod settings;
#[cfg(feature = "proptest")]
pub mod strategies;
mod tune;

/// The local fits' hand-written Cholesky factorisation and solve, public only
/// so that `benches/cholesky.rs` times the crate's own code against nalgebra
/// and faer (instead of a copy that could drift); not part of the API.
#[doc(hidden)]
pub mod bench {
    pub use crate::factor::{chol_solve, cholesky};
}

pub use database::{Database, Neighbor};
pub use error::{LwrError, Result};
pub use loo::LooResult;
pub use model::{FitStatus, LwrModel, Prediction, t_quantile};
pub use settings::{Degree, Kernel, LwrSettings};
pub use tune::{TuneResult, TuneSettings, TuneStatus, TuneStep};
