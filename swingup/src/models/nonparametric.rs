//! The paper's nonparametric model: locally weighted regression of the
//! pendulum's change of angular velocity on all five inputs, on top of a
//! prior (a global linear fit, or any [`PendulumRegression`]).

use std::sync::atomic::{AtomicUsize, Ordering};

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

/// The number of regressors of [`ControlAffineRegression`].
const AFFINE_P: usize = 12;

/// A global control-affine fit, $a(s) + b(s)\,u$ with $a$ and $b$ linear
/// in the state's features $\phi(s) = (\sin\theta, \cos\theta, \dot\theta,
/// x, \dot x)$:
/// $$\ell(z) = c_0 + \sum_j c_j \phi_j + u \Bigl(c_6 + \sum_j c_{6+j} \phi_j\Bigr).$$
///
/// It assumes two things of the system, neither its physics: the angle is
/// an angle (the fit sees it through its sine and cosine, so it repeats
/// every turn), and the command enters affinely, with a gain that depends
/// on the state. Least squares decides which of the twelve regressors
/// matter. Why: the demonstration never brings the pendulum near upright,
/// where the hand's effect on the angular acceleration changes sign; a
/// linear prior carries the hanging pendulum's gain up there, this one
/// carries its dependence on the angle, which the swinging data show. It
/// is the pendulum's version of the cart-pole's control-affine prior
/// (`crate::cartpole::model`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlAffineRegression {
    /// $[c_0, \dots, c_{11}]$: the intercept, the five features, the
    /// command, the command times each feature.
    pub coefficients: [f64; AFFINE_P],
}

impl ControlAffineRegression {
    /// Least squares of the output on the twelve regressors, restricted to
    /// `inputs` (indices into the five): an input left out takes its
    /// features with it (the angle both its sine and cosine, the command
    /// all six products); a tiny ridge keeps it defined for degenerate data.
    ///
    /// # Errors
    /// A training point that is not finite, or a fit that fails.
    pub fn fit_inputs(xs: &[[f64; 5]], ys: &[[f64; 1]], inputs: &[usize]) -> crate::Result<Self> {
        Ok(Self {
            coefficients: least_squares(xs, ys, |z| affine_row(z, inputs))?,
        })
    }
}

/// The state's features $\phi(s)$ of [`ControlAffineRegression`], each 0
/// when its input is not in `inputs`.
fn affine_features(z: &[f64; 5], inputs: &[usize]) -> [f64; 5] {
    let on = |j: usize, v: f64| if inputs.contains(&j) { v } else { 0.0 };
    [
        on(0, z[0].sin()),
        on(0, z[0].cos()),
        on(1, z[1]),
        on(2, z[2]),
        on(3, z[3]),
    ]
}

/// The regressors of [`ControlAffineRegression`] at `z`.
fn affine_row(z: &[f64; 5], inputs: &[usize]) -> [f64; AFFINE_P] {
    let u = if inputs.contains(&4) { z[4] } else { 0.0 };
    row_of(&affine_features(z, inputs), u)
}

/// The regressors from the state's features `phi` and the command `u`.
fn row_of(phi: &[f64; 5], u: f64) -> [f64; AFFINE_P] {
    std::array::from_fn(|c| match c {
        0 => 1.0,
        1..=5 => phi[c - 1],
        6 => u,
        _ => u * phi[c - 7],
    })
}

impl PendulumRegression for ControlAffineRegression {
    fn delta_omega(&self, z: &[f64; 5], jacobian: Option<&mut [f64; 5]>) -> f64 {
        let c = &self.coefficients;
        // features of every input: a left-out one has coefficient 0
        let phi = affine_features(z, &ALL_INPUTS);
        let u = z[4];
        if let Some(j) = jacobian {
            // d phi / d theta = (cos, -sin, 0, 0, 0); the other features are inputs
            let gain = |k: usize| c[1 + k] + u * c[7 + k];
            j[0] = gain(0) * phi[1] - gain(1) * phi[0];
            j[1] = gain(2);
            j[2] = gain(3);
            j[3] = gain(4);
            j[4] = c[6] + (0..5).map(|k| c[7 + k] * phi[k]).sum::<f64>();
        }
        // the features computed once (the prior is on the planner's hot path)
        let row = row_of(&phi, u);
        (0..AFFINE_P).map(|k| c[k] * row[k]).sum()
    }
}

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
    least_squares(xs, ys, |x| {
        std::array::from_fn(|c| match c {
            0 => 1.0,
            _ if inputs.contains(&(c - 1)) => x[c - 1],
            _ => 0.0,
        })
    })
}

/// Least squares of the one output on the regressors `row(x)`
/// ([`ridge_least_squares`](super::ridge_least_squares) with the pendulum's
/// ridge, $10^{-9}$).
fn least_squares<const P: usize>(
    xs: &[[f64; 5]],
    ys: &[[f64; 1]],
    row: impl Fn(&[f64; 5]) -> [f64; P],
) -> crate::Result<[f64; P]> {
    let [coefficients] = super::ridge_least_squares(xs, ys, 1e-9, "global least-squares fit", row)?;
    Ok(coefficients)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use crate::plant::{Plant, PlantState};
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Data exactly in the control-affine prior's span are fitted exactly;
    /// an input left out gets coefficient 0 on all of its regressors.
    #[test]
    fn the_control_affine_prior_reproduces_a_function_in_its_span() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let truth: [f64; AFFINE_P] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
        let xs: Vec<[f64; 5]> = (0..300)
            .map(|_| std::array::from_fn(|j| rng.random_range(-4.0..4.0) * if j == 4 { 3.0 } else { 1.0 }))
            .collect();
        let value = |c: &[f64; AFFINE_P], z: &[f64; 5]| -> f64 {
            let row = affine_row(z, &ALL_INPUTS);
            (0..AFFINE_P).map(|k| c[k] * row[k]).sum()
        };
        let ys: Vec<[f64; 1]> = xs.iter().map(|z| [value(&truth, z)]).collect();
        let m = ControlAffineRegression::fit_inputs(&xs, &ys, &ALL_INPUTS).expect("fit");
        for (c, t) in m.coefficients.iter().zip(&truth) {
            assert!((c - t).abs() < 1e-7, "{:?} against {truth:?}", m.coefficients);
        }
        for z in &xs[..20] {
            assert!((m.delta_omega(z, None) - value(&truth, z)).abs() < 1e-7);
        }
        // without the hand's position (input 2): its regressor and its product are 0
        let no_x = ControlAffineRegression::fit_inputs(&xs, &ys, &[0, 1, 3, 4]).expect("fit");
        assert_eq!((no_x.coefficients[4], no_x.coefficients[10]), (0.0, 0.0));
        // without the command (input 4): no command terms at all
        let no_u = ControlAffineRegression::fit_inputs(&xs, &ys, &[0, 1, 2, 3]).expect("fit");
        assert!(
            no_u.coefficients[6..].iter().all(|&c| c == 0.0),
            "{:?}",
            no_u.coefficients
        );
    }

    /// Trained on the imitation trial alone (the robot replaying the
    /// demonstration, noiseless: the pendulum swings to 87 degrees and no
    /// further), the control-affine prior's derivatives at upright, in the
    /// command and in the angle, have the plant's signs and are within 10 %
    /// of the plant's; the linear prior carries the hanging pendulum's up
    /// there, with the wrong signs.
    #[test]
    fn the_control_affine_prior_extrapolates_the_hand_gain_to_upright() {
        let (xs, ys) = crate::plant::demo::imitation_data();
        let robot = Plant::new(Config::default().robot);
        assert!(
            xs.iter().all(|z| z[0].abs() < 1.6),
            "the demonstration stays below horizontal"
        );
        // the plant's derivatives at upright at rest, by central differences
        let upright = [std::f64::consts::PI, 0.0, 0.0, 0.0, 0.0];
        let plant_g = |z: &[f64; 5]| {
            let s = PlantState {
                s: [z[0], z[1], z[2], z[3]],
                a: z[4],
            };
            robot.step(&s, z[4]).s[1] - z[1]
        };
        let diff = |f: &dyn Fn(&[f64; 5]) -> f64, j: usize| {
            let h = 1e-5;
            let (mut p, mut m) = (upright, upright);
            p[j] += h;
            m[j] -= h;
            (f(&p) - f(&m)) / (2.0 * h)
        };
        let affine = ControlAffineRegression::fit_inputs(&xs, &ys, &ALL_INPUTS).expect("fit");
        let linear = LinearRegression::fit(&xs, &ys).expect("fit");
        let mut j_affine = [0.0; 5];
        let mut j_linear = [0.0; 5];
        affine.delta_omega(&upright, Some(&mut j_affine));
        linear.delta_omega(&upright, Some(&mut j_linear));
        for j in [0, 4] {
            let truth = diff(&plant_g, j);
            eprintln!(
                "d/d{}: plant {truth:.3e}, control-affine {:.3e}, linear {:.3e}",
                crate::models::INPUTS[j],
                j_affine[j],
                j_linear[j]
            );
            assert!(
                (j_affine[j] - truth).abs() < 0.1 * truth.abs(),
                "{j}: {j_affine:?} against {truth}"
            );
            assert!(j_linear[j] * truth < 0.0, "{j}: {j_linear:?} against {truth}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// The control-affine prior's exact Jacobian equals central differences.
        #[test]
        fn the_control_affine_jacobian_matches_central_differences(
            c in prop::array::uniform12(-1.0f64..1.0),
            z in prop::array::uniform5(-10.0f64..10.0),
        ) {
            let m = ControlAffineRegression { coefficients: c };
            let mut j = [0.0; 5];
            let g = m.delta_omega(&z, Some(&mut j));
            prop_assert_eq!(g, m.delta_omega(&z, None));
            let worst = ddp::strategies::check_jacobian(
                |z| vec![m.delta_omega(&z.try_into().expect("5 inputs"), None)],
                &z,
                &j,
            )
            .expect("check");
            prop_assert!(worst.max_rel_error < 1e-7, "at {:?}: {:?}", z, worst);
        }
    }
}
