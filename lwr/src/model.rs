//! The model: a database, settings, and predictions with confidence.

use faer::Mat;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use statrs::distribution::{ContinuousCDF, Normal, StudentsT};

use crate::database::{Database, DatabaseData};
use crate::error::{LwrError, Result};
use crate::fit::{LocalFit, Want, local_fit};
use crate::metric::Metric;
use crate::scaled::ScaledIndex;
use crate::settings::{Kernel, LwrSettings};

/// How much a [`Prediction`] can be trusted, from best to worst.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum FitStatus {
    /// A well-conditioned fit with local degrees of freedom
    /// $n_{lwr} - p_{lwr} \ge 1/2$: mean, noise and intervals are all defined.
    Ok,
    /// The fit is well conditioned but $n_{lwr} - p_{lwr} < 1/2$: the data
    /// determine the mean but leave (almost) nothing to estimate the noise
    /// with. The noise variance and standard errors are NaN and the intervals
    /// infinite.
    NoDegreesOfFreedom,
    /// The normal matrix was ill-conditioned (condition estimate above
    /// `max_condition`): the fallback ridge was added, so the mean is biased
    /// towards a flatter local model. Intervals are computed for the
    /// regularised fit.
    Regularized,
    /// Fewer points carry weight than the local model has coefficients: the
    /// fit is underdetermined and only the ridge (or the fallback ridge) makes
    /// it unique. Treat the mean as a guess: the noise variance and standard
    /// errors are NaN and the intervals infinite.
    TooFewPoints,
    /// No point was within the kernel's support of the query: the
    /// fit/predict surface ([`LwrModel::predict_many`]) fitted it with the
    /// support widened to twice the distance of its nearest point, so the
    /// mean comes from the nearest points alone. Treat it as an
    /// extrapolation; [`LwrModel::predict`] refuses such a query instead
    /// ([`LwrError::NoWeightedData`](crate::LwrError::NoWeightedData)).
    Extrapolated,
}

/// A prediction at one query, per output $o$.
///
/// The fit is a linear smoother $\hat y(q) = l(q)^\top y$ with
/// $l_i = k_i z_i^\top P e_0$ and $P = (Z^\top K Z + \Lambda)^{-1}$. With
/// $n_{lwr} = \sum_i k_i$, $p_{lwr} = \sum_i k_i^2 z_i^\top P z_i$ and residuals
/// $r_i = y_i - \beta^\top z_i$ of the local model:
///
/// - noise $\sigma^2 = \sum_i k_i r_i^2 / (n_{lwr} - p_{lwr})$,
/// - standard error of the mean $\sqrt{\sigma^2 |l|^2}$,
/// - confidence interval $\hat y \pm t_{1-\alpha/2,\, n_{lwr} - p_{lwr}} \sqrt{\sigma^2 |l|^2}$,
/// - prediction interval $\hat y \pm t \sqrt{\sigma^2 (1 + |l|^2)}$.
///
/// Support: $n_{lwr}$ is the weight mass at the query (about the number of
/// points within a bandwidth) and `leverage` $= |l|^2$ is how much of one
/// observation's noise reaches the mean: near $1/n_{lwr}$ inside the data,
/// near or above 1 when the prediction leans on a single point or
/// extrapolates.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// $\hat y(q)$, one entry per output.
    pub mean: Vec<f64>,
    /// Local noise variance $\sigma^2$ per output (NaN without degrees of freedom).
    pub noise_variance: Vec<f64>,
    /// Standard error of the mean $\sqrt{\sigma^2 |l|^2}$ per output.
    pub std_error: Vec<f64>,
    /// Half width of the confidence interval of the mean per output
    /// (infinite without degrees of freedom).
    pub confidence_half_width: Vec<f64>,
    /// Half width of the prediction interval of a new observation per output
    /// (infinite without degrees of freedom).
    pub prediction_half_width: Vec<f64>,
    /// The Student-t quantile used for the intervals.
    pub t_quantile: f64,
    /// $n_{lwr} = \sum_i k_i$.
    pub n_lwr: f64,
    /// $p_{lwr} = \sum_i k_i^2 z_i^\top P z_i$.
    pub p_lwr: f64,
    /// Local degrees of freedom $n_{lwr} - p_{lwr}$.
    pub dof: f64,
    /// $|l(q)|^2$: the variance of the mean in units of $\sigma^2$.
    pub leverage: f64,
    /// Number of stored points with positive weight.
    pub n_neighbors: usize,
    /// Number of coefficients $p$ of the local model.
    pub n_coeffs: usize,
    /// Condition estimate of the diagonally scaled normal matrix.
    pub condition: f64,
    /// How far the prediction can be trusted.
    pub status: FitStatus,
}

impl Prediction {
    /// Whether `status` is [`FitStatus::Ok`].
    pub fn is_ok(&self) -> bool {
        self.status == FitStatus::Ok
    }

    /// Confidence interval of the mean of output `o`,
    /// $\hat y \pm t \sqrt{\sigma^2 |l|^2}$ (infinite without degrees of
    /// freedom), or `None` if `o` is out of range.
    pub fn confidence_interval(&self, o: usize) -> Option<(f64, f64)> {
        let (m, w) = (self.mean.get(o)?, self.confidence_half_width.get(o)?);
        Some((m - w, m + w))
    }

    /// Prediction interval of a new observation of output `o`,
    /// $\hat y \pm t \sqrt{\sigma^2 (1 + |l|^2)}$, or `None` if `o` is out
    /// of range.
    pub fn prediction_interval(&self, o: usize) -> Option<(f64, f64)> {
        let (m, w) = (self.mean.get(o)?, self.prediction_half_width.get(o)?);
        Some((m - w, m + w))
    }
}

/// The two-sided Student-t quantile $t_{1 - \alpha/2, \nu}$ for confidence
/// `level` $= 1 - \alpha$ and $\nu > 0$ degrees of freedom (not necessarily
/// an integer): statrs for $\nu \le 1000$, a Cornish-Fisher expansion
/// (Abramowitz & Stegun 26.7.5) above; infinite for $0 < \nu < 1/2$ (where
/// the quantile exceeds $10^{2}$ even at 95 % and the interval says nothing).
/// NaN for $\nu \le 0$ or a level outside $(0, 1)$.
pub fn t_quantile(level: f64, dof: f64) -> f64 {
    if dof.is_nan() || dof <= 0.0 || level.is_nan() || level <= 0.0 || level >= 1.0 {
        return f64::NAN;
    }
    if dof < 0.5 {
        return f64::INFINITY;
    }
    let p = 0.5 + 0.5 * level;
    if dof <= 1000.0 {
        return match StudentsT::new(0.0, 1.0, dof) {
            Ok(t) => t.inverse_cdf(p),
            Err(_) => f64::NAN,
        };
    }
    // large dof: Cornish-Fisher expansion around the normal quantile
    // (Abramowitz & Stegun 26.7.5), exact to rounding for dof > 1000
    let z = match Normal::new(0.0, 1.0) {
        Ok(n) => n.inverse_cdf(p),
        Err(_) => return f64::NAN,
    };
    let z2 = z * z;
    let g1 = z * (z2 + 1.0) / 4.0;
    let g2 = z * ((5.0 * z2 + 16.0) * z2 + 3.0) / 96.0;
    let g3 = z * (((3.0 * z2 + 19.0) * z2 + 17.0) * z2 - 15.0) / 384.0;
    let g4 = z * ((((79.0 * z2 + 776.0) * z2 + 1482.0) * z2 - 1920.0) * z2 - 945.0) / 92160.0;
    let v = 1.0 / dof;
    z + v * (g1 + v * (g2 + v * (g3 + v * g4)))
}

/// A locally weighted regression model: a [`Database`] and the
/// [`LwrSettings`] of the fit at each query.
///
/// Predictions are computed at query time (lazy learning): inserting points
/// costs a tree insertion only.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(try_from = "ModelData", into = "ModelData")]
pub struct LwrModel {
    settings: LwrSettings,
    /// The distance of `settings`, with the products $A = \operatorname{diag}(m) M$
    /// and $A^\top A$ of a full metric computed once.
    metric: Metric,
    db: Database,
    /// The points in the metric's scaled coordinates, for the fits'
    /// neighbour searches (see `scaled.rs`).
    index: ScaledIndex,
}

#[derive(Serialize, Deserialize)]
struct ModelData {
    settings: LwrSettings,
    database: DatabaseData,
}

impl From<LwrModel> for ModelData {
    fn from(m: LwrModel) -> Self {
        Self {
            settings: m.settings,
            database: m.db.into(),
        }
    }
}

impl TryFrom<ModelData> for LwrModel {
    type Error = LwrError;

    fn try_from(data: ModelData) -> Result<Self> {
        LwrModel::from_database(Database::try_from(data.database)?, data.settings)
    }
}

impl LwrModel {
    /// An empty model for `n_inputs` inputs and `n_outputs` outputs.
    pub fn new(n_inputs: usize, n_outputs: usize, settings: LwrSettings) -> Result<Self> {
        Self::from_database(Database::new(n_inputs, n_outputs)?, settings)
    }

    /// A model over an existing database.
    pub fn from_database(db: Database, settings: LwrSettings) -> Result<Self> {
        settings.validate(db.n_inputs())?;
        let metric = Metric::of_settings(&settings, db.n_inputs());
        let index = ScaledIndex::new(&db, &metric);
        Ok(Self {
            settings,
            metric,
            db,
            index,
        })
    }

    /// The settings.
    pub fn settings(&self) -> &LwrSettings {
        &self.settings
    }

    /// Replaces the settings (validated first; unchanged on error).
    pub fn set_settings(&mut self, settings: LwrSettings) -> Result<()> {
        settings.validate(self.db.n_inputs())?;
        self.metric = Metric::of_settings(&settings, self.db.n_inputs());
        if !self.index.is_of(&self.metric, self.db.n_inputs()) {
            self.index = ScaledIndex::new(&self.db, &self.metric);
        }
        self.settings = settings;
        Ok(())
    }

    /// The database.
    pub fn database(&self) -> &Database {
        &self.db
    }

    /// Number of stored points.
    pub fn len(&self) -> usize {
        self.db.len()
    }

    /// Whether the database is empty.
    pub fn is_empty(&self) -> bool {
        self.db.is_empty()
    }

    /// Stores one point; see [`Database::insert`].
    pub fn insert(&mut self, x: &[f64], y: &[f64]) -> Result<usize> {
        let i = self.db.insert(x, y)?;
        self.index.extend(&self.db);
        Ok(i)
    }

    /// Stores many points; see [`Database::insert_many`].
    pub fn insert_many<X: AsRef<[f64]>, Y: AsRef<[f64]>>(&mut self, xs: &[X], ys: &[Y]) -> Result<()> {
        self.db.insert_many(xs, ys)?;
        self.index.extend(&self.db);
        Ok(())
    }

    pub(crate) fn fit_with(&self, q: &[f64], want: Want) -> Result<LocalFit> {
        self.db.check_point_query(q)?;
        local_fit(&self.db, &self.index, &self.settings, &self.metric, q, want)
    }

    /// The mean $\hat y(q)$ only (no confidence sums: the cheapest query).
    ///
    /// ```
    /// # use lwr::{LwrModel, LwrSettings};
    /// let mut m = LwrModel::new(1, 1, LwrSettings::default())?;
    /// for i in 0..20 {
    ///     let x = i as f64 * 0.1;
    ///     m.insert(&[x], &[3.0 * x - 1.0])?;
    /// }
    /// let y = m.predict_mean(&[0.55])?;
    /// assert!((y[0] - 0.65).abs() < 1e-10); // local linear reproduces lines
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    pub fn predict_mean(&self, q: &[f64]) -> Result<Vec<f64>> {
        let fit = self.fit_with(q, Want::default())?;
        Ok(fit.beta[..self.db.n_outputs()].to_vec())
    }

    /// The prediction at `q` with its confidence (see [`Prediction`]).
    ///
    /// Errors: wrong length or non-finite query, an empty database, or
    /// [`LwrError::NoWeightedData`] when no point is within the kernel's
    /// support.
    ///
    /// ```
    /// # use lwr::{LwrModel, LwrSettings, FitStatus};
    /// let mut m = LwrModel::new(1, 1, LwrSettings { bandwidth: 0.3, ..Default::default() })?;
    /// for i in 0..50 {
    ///     let x = i as f64 * 0.04;
    ///     m.insert(&[x], &[x.sin() + 0.01 * (7.0 * i as f64).sin()])?;
    /// }
    /// let p = m.predict(&[1.0])?;
    /// assert_eq!(p.status, FitStatus::Ok);
    /// assert!((p.mean[0] - 1f64.sin()).abs() < 3.0 * p.prediction_half_width[0]);
    /// // far away: refused, not extrapolated
    /// assert!(m.predict(&[100.0]).is_err());
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    pub fn predict(&self, q: &[f64]) -> Result<Prediction> {
        let want = Want {
            confidence: true,
            jacobian: false,
        };
        let fit = self.fit_with(q, want)?;
        Ok(self.prediction(&fit))
    }

    /// [`predict`](Self::predict), or for a query outside the kernel's
    /// support around every point, the fit with the support widened to twice
    /// the distance of its nearest point (the Gaussian's cutoff, its
    /// bandwidth too if that point is more than 20 bandwidths away; a compact
    /// kernel's bandwidth), with the status
    /// [`FitStatus::Extrapolated`].
    pub(crate) fn predict_or_widen(&self, q: &[f64]) -> Result<Prediction> {
        match self.predict(q) {
            Err(LwrError::NoWeightedData { nearest_distance, .. }) if nearest_distance.is_finite() => {
                let mut settings = self.settings.clone();
                match settings.kernel {
                    Kernel::Gaussian => {
                        // the nearest point within 20 bandwidths, where its
                        // weight (e^-200) is far from underflowing
                        settings.bandwidth = settings.bandwidth.max(nearest_distance / 20.0);
                        settings.gaussian_cutoff = 2.0 * nearest_distance / settings.bandwidth;
                    }
                    _ => settings.bandwidth = 2.0 * nearest_distance,
                }
                let want = Want {
                    confidence: true,
                    jacobian: false,
                };
                let fit = local_fit(&self.db, &self.index, &settings, &self.metric, q, want)?;
                let mut p = self.prediction(&fit);
                p.status = FitStatus::Extrapolated;
                Ok(p)
            }
            other => other,
        }
    }

    /// The prediction and its exact Jacobian $\partial \hat y / \partial q$
    /// ($o \times d$).
    ///
    /// With $\beta = P b$, $A = \sum_i k_i z_i z_i^\top + \Lambda$,
    /// $b = \sum_i k_i z_i y_i^\top$ and $s = P e_0$, differentiating
    /// $A \beta = b$ gives
    /// $$\frac{\partial \hat y}{\partial q_j} = \sum_i \Big(\frac{\partial k_i}{\partial q_j} s^\top z_i + k_i s^\top \frac{\partial z_i}{\partial q_j}\Big) r_i^\top - k_i (s^\top z_i) \Big(\frac{\partial z_i}{\partial q_j}\Big)^\top \beta,$$
    /// with $\partial k_i / \partial q_j = -\frac{K'(u_i)}{u_i} (G (x_i - q))_j / h^2$
    /// for the metric $d_i^2 = (x_i - q)^\top G (x_i - q)$ ($G = \operatorname{diag}(m)^2$,
    /// or $M^\top \operatorname{diag}(m)^2 M$ with a full metric),
    /// and $\partial z_i / \partial q_j$ from the centring of $z_i$ at $q$.
    /// For a local linear fit the last term is the local slope
    /// $\beta_{1+j}$; the others correct it for the weights moving with $q$.
    ///
    /// Exact where the prediction is differentiable: away from points
    /// crossing a compact kernel's support (or the Gaussian's cutoff), and
    /// for fits without the fallback ridge (whose dependence on $q$ is
    /// ignored).
    ///
    /// ```
    /// # use lwr::{LwrModel, LwrSettings, Degree};
    /// // y = x0 * x1 sampled on a grid: the quadratic fit is exact, and so is
    /// // its Jacobian (x1, x0)
    /// let settings = LwrSettings { degree: Degree::Quadratic, bandwidth: 0.5, ..Default::default() };
    /// let mut m = LwrModel::new(2, 1, settings)?;
    /// for i in 0..11 {
    ///     for j in 0..11 {
    ///         let x = [i as f64 / 10.0, j as f64 / 10.0];
    ///         m.insert(&x, &[x[0] * x[1]])?;
    ///     }
    /// }
    /// let (p, jac) = m.predict_with_jacobian(&[0.33, 0.71])?;
    /// assert!((p.mean[0] - 0.33 * 0.71).abs() < 1e-10);
    /// assert!((jac[(0, 0)] - 0.71).abs() < 1e-8 && (jac[(0, 1)] - 0.33).abs() < 1e-8);
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    pub fn predict_with_jacobian(&self, q: &[f64]) -> Result<(Prediction, Mat<f64>)> {
        let want = Want {
            confidence: true,
            jacobian: true,
        };
        let fit = self.fit_with(q, want)?;
        let d = self.db.n_inputs();
        let jac = Mat::from_fn(self.db.n_outputs(), d, |o, j| fit.jacobian[o * d + j]);
        Ok((self.prediction(&fit), jac))
    }

    /// The mean $\hat y(q)$ and its exact Jacobian $\partial \hat y / \partial q$
    /// ($o \times d$) without the confidence sums: bitwise the mean of
    /// [`predict_mean`](Self::predict_mean) and the Jacobian of
    /// [`predict_with_jacobian`](Self::predict_with_jacobian) (see its
    /// formula), at the cost of a second pass over the neighbours only. The
    /// query a planner linearising a learned model makes.
    ///
    /// ```
    /// # use lwr::{LwrModel, LwrSettings};
    /// let mut m = LwrModel::new(2, 1, LwrSettings { bandwidth: 0.3, ..Default::default() })?;
    /// for i in 0..15 {
    ///     for j in 0..15 {
    ///         let x = [i as f64 / 14.0, j as f64 / 14.0];
    ///         m.insert(&x, &[2.0 * x[0] - x[1]])?;
    ///     }
    /// }
    /// let (mean, jac) = m.predict_mean_with_jacobian(&[0.4, 0.6])?;
    /// assert!((mean[0] - 0.2).abs() < 1e-10);
    /// assert!((jac[(0, 0)] - 2.0).abs() < 1e-8 && (jac[(0, 1)] + 1.0).abs() < 1e-8);
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    pub fn predict_mean_with_jacobian(&self, q: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        let want = Want {
            confidence: false,
            jacobian: true,
        };
        let fit = self.fit_with(q, want)?;
        let (d, o) = (self.db.n_inputs(), self.db.n_outputs());
        let jac = Mat::from_fn(o, d, |oo, j| fit.jacobian[oo * d + j]);
        Ok((fit.beta[..o].to_vec(), jac))
    }

    /// The first output's mean at a query `z` of a wider space, of which
    /// the model sees the entries `inputs` (its inputs are `z[inputs[0]]`,
    /// `z[inputs[1]]`, ...: a model fitted on a selection of `N` candidate
    /// inputs), with the selection made on the stack; and, when
    /// `jacobian` is given, the derivative with respect to every entry of
    /// `z` written there (zero for the entries not selected). The values
    /// are those of [`predict_mean`](Self::predict_mean) and
    /// [`predict_mean_with_jacobian`](Self::predict_mean_with_jacobian) at
    /// the selected query, bit for bit; `jacobian` is written only on
    /// success.
    ///
    /// ```
    /// # use lwr::{LwrModel, LwrSettings};
    /// // y = 2 z2 - z0, learned from (z0, z2) of a 3-entry z
    /// let mut m = LwrModel::new(2, 1, LwrSettings { bandwidth: 0.3, ..Default::default() })?;
    /// for i in 0..15 {
    ///     for j in 0..15 {
    ///         let (z0, z2) = (i as f64 / 14.0, j as f64 / 14.0);
    ///         m.insert(&[z0, z2], &[2.0 * z2 - z0])?;
    ///     }
    /// }
    /// let mut jac = [f64::NAN; 3];
    /// let y = m.predict_selected(&[0.4, 7.0, 0.6], &[0, 2], Some(&mut jac))?;
    /// assert!((y - 0.8).abs() < 1e-10);
    /// assert!((jac[0] + 1.0).abs() < 1e-8 && jac[1] == 0.0 && (jac[2] - 2.0).abs() < 1e-8);
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    ///
    /// # Errors
    /// [`LwrError::DimensionMismatch`] when `inputs` does not have the
    /// model's input count, [`LwrError::InvalidParameter`] when it names an
    /// entry beyond `z`; and the errors of the two predictions.
    pub fn predict_selected<const N: usize>(
        &self,
        z: &[f64; N],
        inputs: &[usize],
        jacobian: Option<&mut [f64; N]>,
    ) -> Result<f64> {
        let d = self.db.n_inputs();
        if inputs.len() != d {
            return Err(LwrError::DimensionMismatch {
                what: "selected inputs",
                expected: d,
                actual: inputs.len(),
            });
        }
        if let Some(&j) = inputs.iter().find(|&&j| j >= N) {
            return Err(LwrError::InvalidParameter {
                name: "inputs",
                reason: format!("entry {j} of a query of {N}"),
            });
        }
        // more entries than z has (repeated ones) cannot be selected
        let mut q = [0.0; N];
        for (q, &j) in q.iter_mut().zip(inputs) {
            *q = z[j];
        }
        let Some(q) = q.get(..d) else {
            return Err(LwrError::DimensionMismatch {
                what: "selected inputs",
                expected: N,
                actual: d,
            });
        };
        match jacobian {
            Some(full) => {
                let (mean, jac) = self.predict_mean_with_jacobian(q)?;
                full.fill(0.0);
                for (c, &j) in inputs.iter().enumerate() {
                    full[j] += jac[(0, c)];
                }
                Ok(mean[0])
            }
            None => Ok(self.predict_mean(q)?[0]),
        }
    }

    /// Predictions at many queries in parallel (rayon), in order; each one
    /// is a `Result` of its own.
    ///
    /// ```
    /// # use lwr::{LwrModel, LwrSettings};
    /// let mut m = LwrModel::new(1, 1, LwrSettings { bandwidth: 0.2, ..Default::default() })?;
    /// for i in 0..=20 {
    ///     m.insert(&[i as f64 / 20.0], &[2.0 * i as f64 / 20.0])?;
    /// }
    /// let out = m.predict_batch(&[[0.25], [0.5], [9.0]]);
    /// assert!((out[1].as_ref().expect("inside").mean[0] - 1.0).abs() < 1e-10);
    /// assert!(out[2].is_err()); // far from the data
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    pub fn predict_batch<Q: AsRef<[f64]> + Sync>(&self, queries: &[Q]) -> Vec<Result<Prediction>> {
        queries.par_iter().map(|q| self.predict(q.as_ref())).collect()
    }

    /// Predictions and Jacobians at many queries in parallel (rayon), in
    /// order; see [`predict_with_jacobian`](Self::predict_with_jacobian).
    pub fn predict_batch_with_jacobian<Q: AsRef<[f64]> + Sync>(
        &self,
        queries: &[Q],
    ) -> Vec<Result<(Prediction, Mat<f64>)>> {
        queries
            .par_iter()
            .map(|q| self.predict_with_jacobian(q.as_ref()))
            .collect()
    }

    fn prediction(&self, fit: &LocalFit) -> Prediction {
        let o = self.db.n_outputs();
        let s = &self.settings;
        let dof = fit.sum_w - fit.p_lwr;
        let status = if fit.n_neighbors < fit.p {
            FitStatus::TooFewPoints
        } else if fit.regularized {
            FitStatus::Regularized
        } else if dof.is_nan() || dof < 0.5 {
            FitStatus::NoDegreesOfFreedom
        } else {
            FitStatus::Ok
        };
        let t = t_quantile(s.confidence_level, dof);
        let mut p = Prediction {
            mean: fit.beta[..o].to_vec(),
            noise_variance: vec![f64::NAN; o],
            std_error: vec![f64::NAN; o],
            confidence_half_width: vec![f64::INFINITY; o],
            prediction_half_width: vec![f64::INFINITY; o],
            t_quantile: t,
            n_lwr: fit.sum_w,
            p_lwr: fit.p_lwr,
            dof,
            leverage: fit.l_norm2,
            n_neighbors: fit.n_neighbors,
            n_coeffs: fit.p,
            condition: fit.condition,
            status,
        };
        if dof >= 0.5 && t.is_finite() && status != FitStatus::TooFewPoints {
            for oo in 0..o {
                let sigma2 = fit.wrss[oo] / dof;
                let se = (sigma2 * fit.l_norm2).sqrt();
                p.noise_variance[oo] = sigma2;
                p.std_error[oo] = se;
                p.confidence_half_width[oo] = t * se;
                p.prediction_half_width[oo] = t * (sigma2 * (1.0 + fit.l_norm2)).sqrt();
            }
        }
        p
    }

    /// The model as JSON (settings and points; the tree is rebuilt on load).
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string(self).map_err(|e| LwrError::Serde(e.to_string()))
    }

    /// A model from [`to_json`](Self::to_json)'s output, validated: invalid
    /// settings or points give the same typed errors as building the model.
    pub fn from_json(text: &str) -> Result<Self> {
        let data: ModelData = serde_json::from_str(text).map_err(|e| LwrError::Serde(e.to_string()))?;
        Self::try_from(data)
    }

    /// Writes the model as JSON.
    pub fn save<W: std::io::Write>(&self, writer: W) -> Result<()> {
        serde_json::to_writer(writer, self).map_err(|e| LwrError::Serde(e.to_string()))
    }

    /// Reads a model written by [`save`](Self::save), validated like
    /// [`from_json`](Self::from_json).
    pub fn load<R: std::io::Read>(reader: R) -> Result<Self> {
        let data: ModelData = serde_json::from_reader(reader).map_err(|e| LwrError::Serde(e.to_string()))?;
        Self::try_from(data)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The selected query gives the plain predictions' bits, the
    /// Jacobian lands on the selected entries (zero elsewhere), and bad
    /// selections are errors that leave the Jacobian untouched.
    #[test]
    fn a_selected_query_is_the_plain_prediction_on_its_entries() {
        let mut m = LwrModel::new(
            2,
            1,
            LwrSettings {
                bandwidth: 0.4,
                ..Default::default()
            },
        )
        .expect("model");
        for i in 0..12 {
            for j in 0..12 {
                let (a, b) = (i as f64 / 11.0, j as f64 / 11.0);
                m.insert(&[a, b], &[(3.0 * a).sin() + a * b * b]).expect("insert");
            }
        }
        let z = [0.9, 0.3, -5.0, 0.55];
        let mut jac = [f64::NAN; 4];
        let y = m.predict_selected(&z, &[3, 1], Some(&mut jac)).expect("selected");
        let (mean, j) = m.predict_mean_with_jacobian(&[0.55, 0.3]).expect("plain");
        assert_eq!(y.to_bits(), mean[0].to_bits());
        assert_eq!(jac, [0.0, j[(0, 1)], 0.0, j[(0, 0)]]);
        assert!(j[(0, 0)] != 0.0 && j[(0, 1)] != 0.0);
        let y = m.predict_selected(&z, &[3, 1], None).expect("selected");
        assert_eq!(y.to_bits(), m.predict_mean(&[0.55, 0.3]).expect("plain")[0].to_bits());

        let mut untouched = [7.0; 4];
        assert!(matches!(
            m.predict_selected(&z, &[3], Some(&mut untouched)),
            Err(LwrError::DimensionMismatch { .. })
        ));
        assert!(matches!(
            m.predict_selected(&z, &[3, 4], Some(&mut untouched)),
            Err(LwrError::InvalidParameter { name: "inputs", .. })
        ));
        assert!(matches!(
            m.predict_selected(&[0.5], &[0, 0], Some(&mut [7.0])),
            Err(LwrError::DimensionMismatch { .. })
        ));
        assert!(
            m.predict_selected(&[0.5, 9.0, 9.0, 9.0], &[1, 2], Some(&mut untouched))
                .is_err()
        );
        assert_eq!(untouched, [7.0; 4]);
    }

    #[test]
    fn t_quantiles_match_tables() {
        // two-sided 95 %: t_{0.975, nu}
        let table = [
            (1.0, 12.706204736174694),
            (2.0, 4.302652729749462),
            (5.0, 2.5705818356363146),
            (10.0, 2.228138851986274),
            (30.0, 2.0422724563012378),
            (1000.0, 1.9623390808264083),
            (1001.0, 1.9623367052808798),
            (3000.0, 1.960755055322458),
            (1e5, 1.9599877075346095),
            (1e6, 1.959966356814107),
            (1e8, 1.9599640082627663),
        ];
        for (nu, want) in table {
            let got = t_quantile(0.95, nu);
            assert!((got - want).abs() < 1e-9 * want, "nu {nu}: {got} vs {want}");
        }
        // 99 %, non-integer dof (scipy.stats.t.ppf(0.995, 3.5))
        let got = t_quantile(0.99, 3.5);
        assert!((got - 5.085702223091256).abs() < 1e-9 * 5.1, "{got}");
        // tiny and large dof, extreme levels (scipy.stats.t.ppf)
        for (nu, level, want) in [
            (0.5, 0.999, 411396.462526262),
            (0.999, 0.99, 63.90967242332076),
            (7.3, 0.999, 5.283211758939497),
            (500.0, 0.5, 0.6749807379659394),
        ] {
            let got = t_quantile(level, nu);
            assert!((got - want).abs() < 1e-9 * want, "nu {nu}: {got} vs {want}");
        }
        assert!(t_quantile(0.95, 0.0).is_nan());
        assert_eq!(t_quantile(0.95, 0.3), f64::INFINITY);
    }

    #[test]
    fn empty_and_far_queries_are_errors() {
        let mut m = LwrModel::new(2, 1, LwrSettings::default()).expect("valid");
        assert_eq!(m.predict(&[0.0, 0.0]), Err(LwrError::EmptyDatabase));
        m.insert(&[0.0, 0.0], &[1.0]).expect("valid");
        assert!(matches!(m.predict(&[100.0, 0.0]), Err(LwrError::NoWeightedData { .. })));
        assert!(matches!(m.predict(&[0.0]), Err(LwrError::DimensionMismatch { .. })));
        assert!(matches!(m.predict(&[f64::NAN, 0.0]), Err(LwrError::NotFinite { .. })));
        // one point, three coefficients: a guess, and said so
        let p = m.predict(&[0.1, 0.0]).expect("weighted");
        assert_eq!(p.status, FitStatus::TooFewPoints);
        assert!((p.mean[0] - 1.0).abs() < 1e-6);
        assert!(p.confidence_half_width[0].is_infinite());
    }
}
