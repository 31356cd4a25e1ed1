//! The paper's nonparametric model: locally weighted regression of the
//! pendulum's change of angular velocity on all five inputs, on top of a
//! prior (a global linear fit, or any [`PendulumRegression`]).

use std::sync::atomic::{AtomicUsize, Ordering};

use faer::Mat;
use faer::prelude::*;
use lwr::LwrModel;

use crate::models::{KnownHand, PendulumRegression};

/// The paper's nonparametric model: locally weighted regression of
/// $\Delta\dot\theta$ on all five inputs, on top of a global linear fit.
///
/// Where the data run out, a local fit made from a few far points
/// extrapolates wildly, and where they end entirely it has no answer. So
/// the LWR fits the residuals of a global linear least-squares fit $\ell(z)$
/// of the same data, with a ridge on its intercept as well as on its slopes
/// (`intercept_ridge`, `ridge` of [`lwr::LwrSettings`]):
/// $g(z) = \ell(z) + \hat r(z)$, and $\hat r \to 0$ smoothly as the total
/// kernel weight $n_{lwr} = \sum_i k_i$ falls below the ridge. The model is
/// the LWR where the data are dense and the crude global fit far from them,
/// with no switch in between (a switch would stall the planner's
/// Gauss-Newton steps on the jump). Where no stored point carries weight
/// the residual is exactly 0 (counted in [`LwrRegression::fallbacks`]).
///
/// The prior need not be linear: [`LwrRegression::fit_with_prior`] takes
/// any regression (e.g. the parametric model, which makes the LWR a
/// semiparametric correction of it).
pub struct LwrRegression {
    lwr: LwrModel,
    /// Which of the five inputs the LWR sees, in order (all five unless
    /// [`select_inputs`](crate::models::selection::select_inputs) dropped some).
    inputs: Vec<usize>,
    prior: Box<dyn PendulumRegression + Send + Sync>,
    prior_name: &'static str,
    fallbacks: AtomicUsize,
}

impl std::fmt::Debug for LwrRegression {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LwrRegression")
            .field("points", &self.lwr.len())
            .field("inputs", &self.inputs)
            .field("prior", &self.prior_name)
            .finish()
    }
}

/// A global linear fit $\ell(z) = c_0 + \sum_j c_j z_j$, the default prior
/// of [`LwrRegression`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearRegression {
    /// $[c_0, c_1, \dots, c_5]$.
    pub coefficients: [f64; 6],
}

impl LinearRegression {
    /// Least squares of the output on $[1, z]$ (a tiny ridge keeps it
    /// defined for degenerate data).
    pub fn fit(xs: &[[f64; 5]], ys: &[[f64; 1]]) -> crate::Result<Self> {
        Self::fit_inputs(xs, ys, &ALL_INPUTS)
    }

    /// [`fit`](Self::fit) on the inputs `inputs` alone (indices into the
    /// five); the others get coefficient 0.
    pub fn fit_inputs(xs: &[[f64; 5]], ys: &[[f64; 1]], inputs: &[usize]) -> crate::Result<Self> {
        Ok(Self {
            coefficients: global_linear_fit(xs, ys, inputs)?,
        })
    }
}

/// The indices of all five inputs.
pub const ALL_INPUTS: [usize; 5] = [0, 1, 2, 3, 4];

impl PendulumRegression for LinearRegression {
    fn delta_omega(&self, z: &[f64; 5], jacobian: Option<&mut [f64; 5]>) -> f64 {
        if let Some(j) = jacobian {
            *j = std::array::from_fn(|c| self.coefficients[c + 1]);
        }
        linear_value(&self.coefficients, z)
    }
}

/// The LWR model of the robot with known hand kinematics.
pub type LearnedModel = KnownHand<LwrRegression>;

impl LwrRegression {
    /// Fits the global linear model to `(xs, ys)`, then inserts the
    /// residuals into an LWR model with `settings` (not yet tuned; see
    /// [`lwr_mut`](Self::lwr_mut)).
    pub fn fit(xs: &[[f64; 5]], ys: &[[f64; 1]], settings: lwr::LwrSettings) -> crate::Result<Self> {
        Self::fit_inputs(xs, ys, &ALL_INPUTS, settings)
    }

    /// [`fit`](Self::fit) on the inputs `inputs` alone (indices into the
    /// five, e.g. from [`select_inputs`](crate::models::selection::select_inputs)), for the global linear fit and the
    /// LWR both; `settings.scales` has one scale per entry of `inputs`.
    pub fn fit_inputs(
        xs: &[[f64; 5]],
        ys: &[[f64; 1]],
        inputs: &[usize],
        settings: lwr::LwrSettings,
    ) -> crate::Result<Self> {
        let linear = LinearRegression::fit_inputs(xs, ys, inputs)?;
        Self::fit_on(xs, ys, inputs, settings, Box::new(linear), "linear")
    }

    /// [`fit`](Self::fit) on the residuals of a given `prior` (already
    /// fitted), named `name` in reports.
    pub fn fit_with_prior(
        xs: &[[f64; 5]],
        ys: &[[f64; 1]],
        settings: lwr::LwrSettings,
        prior: Box<dyn PendulumRegression + Send + Sync>,
        name: &'static str,
    ) -> crate::Result<Self> {
        Self::fit_on(xs, ys, &ALL_INPUTS, settings, prior, name)
    }

    /// [`fit_with_prior`](Self::fit_with_prior) with the LWR on the inputs
    /// `inputs` alone (indices into the five, strictly increasing);
    /// `settings.scales` has one scale per entry of `inputs`.
    pub fn fit_on(
        xs: &[[f64; 5]],
        ys: &[[f64; 1]],
        inputs: &[usize],
        settings: lwr::LwrSettings,
        prior: Box<dyn PendulumRegression + Send + Sync>,
        name: &'static str,
    ) -> crate::Result<Self> {
        crate::error::ensure_data!(
            !inputs.is_empty() && inputs.windows(2).all(|w| w[0] < w[1]) && inputs.iter().all(|&j| j < 5),
            "the LWR's inputs must be strictly increasing indices below 5, got {inputs:?}"
        );
        crate::error::ensure_data!(!xs.is_empty(), "the model has no data");
        crate::error::ensure_data!(xs.len() == ys.len(), "{} inputs but {} outputs", xs.len(), ys.len());
        let resid: Vec<[f64; 1]> = xs
            .iter()
            .zip(ys)
            .map(|(x, y)| [y[0] - prior.delta_omega(x, None)])
            .collect();
        let mut lwr = LwrModel::new(inputs.len(), 1, settings)?;
        let projected: Vec<Vec<f64>> = xs.iter().map(|x| inputs.iter().map(|&j| x[j]).collect()).collect();
        lwr.insert_many(&projected, &resid)?;
        Ok(Self {
            lwr,
            inputs: inputs.to_vec(),
            prior,
            prior_name: name,
            fallbacks: AtomicUsize::new(0),
        })
    }

    /// The LWR model of the residuals.
    pub fn lwr(&self) -> &LwrModel {
        &self.lwr
    }

    /// The LWR model of the residuals, e.g. to tune its metric.
    pub fn lwr_mut(&mut self) -> &mut LwrModel {
        &mut self.lwr
    }

    /// The inputs the LWR sees (indices into the five).
    pub fn inputs(&self) -> &[usize] {
        &self.inputs
    }

    /// `z` restricted to the LWR's inputs.
    fn project(&self, z: &[f64; 5]) -> ([f64; 5], usize) {
        let mut q = [0.0; 5];
        for (q, &j) in q.iter_mut().zip(&self.inputs) {
            *q = z[j];
        }
        (q, self.inputs.len())
    }

    /// The prior the LWR corrects.
    pub fn prior(&self) -> &(dyn PendulumRegression + Send + Sync) {
        self.prior.as_ref()
    }

    /// How many predictions had no weighted data (the global fit alone).
    pub fn fallbacks(&self) -> usize {
        self.fallbacks.load(Ordering::Relaxed)
    }
}

fn linear_value(c: &[f64; 6], z: &[f64; 5]) -> f64 {
    c[0] + (0..5).map(|j| c[j + 1] * z[j]).sum::<f64>()
}

impl PendulumRegression for LwrRegression {
    fn delta_omega(&self, z: &[f64; 5], jacobian: Option<&mut [f64; 5]>) -> f64 {
        let mut j_prior = [0.0; 5];
        let prior = self.prior.delta_omega(z, jacobian.is_some().then_some(&mut j_prior));
        // the Jacobian costs a second pass over the neighbours: only when asked
        let mut j_resid = [0.0; 5];
        let resid = self
            .lwr
            .predict_selected(z, &self.inputs, jacobian.is_some().then_some(&mut j_resid))
            .unwrap_or(f64::NAN);
        let usable = resid.is_finite() && j_resid.iter().all(|v: &f64| v.is_finite());
        let (resid, j_resid) = if usable {
            (resid, j_resid)
        } else {
            self.fallbacks.fetch_add(1, Ordering::Relaxed);
            (0.0, [0.0; 5])
        };
        if let Some(jac) = jacobian {
            *jac = std::array::from_fn(|c| j_prior[c] + j_resid[c]);
        }
        prior + resid
    }

    /// Inserts the transition into the LWR (its residual from the prior,
    /// which stays as fitted); the metric stays as tuned until the next
    /// trial's fit.
    fn observe(&mut self, z: &[f64; 5], y: f64) -> crate::Result<bool> {
        crate::error::ensure_data!(
            z.iter().all(|v| v.is_finite()) && y.is_finite(),
            "an observed transition is not finite: {z:?} -> {y}"
        );
        let resid = y - self.prior.delta_omega(z, None);
        let (q, d) = self.project(z);
        self.lwr.insert(&q[..d], &[resid])?;
        Ok(true)
    }

    fn support(&self, z: &[f64; 5]) -> Option<f64> {
        let (q, d) = self.project(z);
        Some(self.lwr.predict(&q[..d]).map_or(0.0, |p| p.n_lwr))
    }

    /// The LWR's support and the standard error of its correction (the
    /// prior is taken as exact); no weighted data: support 0, error NaN.
    fn uncertainty(&self, z: &[f64; 5]) -> Option<(f64, f64)> {
        let (q, d) = self.project(z);
        Some(
            self.lwr
                .predict(&q[..d])
                .map_or((0.0, f64::NAN), |p| (p.n_lwr, p.std_error[0])),
        )
    }
}

/// Least squares of the output on $[1, z_{inputs}]$, the other inputs with
/// coefficient 0 (a tiny ridge keeps it defined for degenerate data).
fn global_linear_fit(xs: &[[f64; 5]], ys: &[[f64; 1]], inputs: &[usize]) -> crate::Result<[f64; 6]> {
    let mut ata = Mat::<f64>::zeros(6, 6);
    let mut aty = Mat::<f64>::zeros(6, 1);
    for (x, y) in xs.iter().zip(ys) {
        crate::error::ensure_data!(
            x.iter().chain(y).all(|v| v.is_finite()),
            "a training point is not finite: {x:?} -> {y:?}"
        );
        let row: [f64; 6] = std::array::from_fn(|c| match c {
            0 => 1.0,
            _ if inputs.contains(&(c - 1)) => x[c - 1],
            _ => 0.0,
        });
        for a in 0..6 {
            for b in 0..6 {
                ata[(a, b)] += row[a] * row[b];
            }
            aty[(a, 0)] += row[a] * y[0];
        }
    }
    for a in 0..6 {
        ata[(a, a)] += 1e-9 * (1.0 + ata[(a, a)]);
    }
    let sol = ata
        .llt(faer::Side::Lower)
        .map_err(|e| crate::Error::data(format!("global linear fit failed: {e:?}")))?
        .solve(&aty);
    Ok(std::array::from_fn(|c| sol[(c, 0)]))
}
