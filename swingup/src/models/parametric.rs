//! The learned parametric model, the paper's alternative to LWR: least
//! squares of the per-sample change of angular velocity on physically
//! structured features.
//!
//! Discretising the pendulum on a hand ([`crate::plant`]),
//! $\ddot\theta = -(g/l)\sin\theta - (a/l)\cos\theta - b\dot\theta$ with the
//! hand doing what it is told ($a = u$), by one explicit step of length
//! $\Delta t$ gives
//! $$\Delta\dot\theta \approx c_1 \sin\theta_m + c_2 \dot\theta + c_3\, u \cos\theta_m,
//! \qquad c = \Delta t\,\bigl(-g/l,\; -b,\; -1/l\bigr),$$
//! linear in $c$, so $c$ is fitted by least squares (column-scaled QR, faer)
//! to everything the robot observed. The angle $\theta_m = \theta + h\dot\theta$
//! at which gravity and the hand act is either
//!
//! - the sample's start, $h = 0$ ([`ParametricRegression::fit`]): forward
//!   Euler, features $[\sin\theta, \dot\theta, u\cos\theta]$; or
//! - the sample's midpoint, $h = \Delta t / 2$
//!   ([`ParametricRegression::fit_midpoint`]): a second-order step, whose
//!   features still span the exact one-step map to $O(\Delta t^2)$.
//!
//! The difference matters for the damping. The exact one-step change is
//! $\Delta t f + \tfrac{\Delta t^2}{2}(f_\theta \dot\theta - b f) + O(\Delta t^3)$;
//! with Euler features the term $-\tfrac{\Delta t^2}{2}\tfrac{g}{l}\cos\theta\,\dot\theta$
//! is not in their span and the fit loads it onto the $\dot\theta$
//! coefficient, by up to $\Delta t\, g / 2 l \approx 0.14$/s on the robot
//! against $b = 0.2$/s. On the robot's noiseless imitation trial the Euler
//! fit's damping is 0.31/s (55 % off) while $g/l$ and $1/l$ are within
//! 0.5 %; the midpoint fit's are all within 0.3 %, with a residual 25
//! times smaller. Midpoint features take that term in, leaving
//! $-\tfrac{\Delta t^2}{2} b f$, which is in the span and is undone by
//! [`ParametricRegression::physical`]. [`learn_parametric`] uses them.
//!
//! **No intercept.** The equation has no constant term, and the model must
//! predict exactly zero change hanging at rest ($z = 0$), where every plan
//! starts: a fitted intercept would absorb nothing physical (the sensor
//! noise has zero mean) and would make the model's pendulum drift from
//! rest. Hand position and velocity do not enter (claim C7: they are
//! irrelevant to the next angular velocity).

use faer::Mat;
use faer::prelude::*;

use crate::config::Config;
use crate::models::{INPUTS, KnownHand, PendulumRegression};
use crate::record::training_data;
use crate::record::{ModelSummary, TrialRecord};

/// Names of the features, in the order of [`ParametricRegression::coefficients`].
pub const FEATURES: [&str; 3] = ["sin(theta_m)", "theta_dot", "u cos(theta_m)"];

/// Smallest ratio of the smallest to the largest singular value of the
/// column-normalised design matrix; below it the data do not determine
/// the three coefficients.
pub const MIN_SINGULAR_RATIO: f64 = 1e-8;

pub use crate::error::ParametricError;

/// Physical parameters read off the fitted coefficients; see
/// [`ParametricRegression::physical`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhysicalEstimate {
    /// $g / l$ (1/s²).
    pub gravity_over_length: f64,
    /// $1 / l$ (1/m).
    pub inverse_length: f64,
    /// Viscous damping $b$ (1/s).
    pub damping: f64,
}

impl PhysicalEstimate {
    /// The pendulum length $l = 1 / (1/l)$ (m).
    pub fn length(&self) -> f64 {
        1.0 / self.inverse_length
    }

    /// Gravity $g = (g/l) / (1/l)$ (m/s²).
    pub fn gravity(&self) -> f64 {
        self.gravity_over_length / self.inverse_length
    }
}

/// The learned parametric model
/// $\Delta\dot\theta = c_1 \sin\theta_m + c_2 \dot\theta + c_3 u \cos\theta_m$,
/// $\theta_m = \theta + h\dot\theta$; see the [module docs](self).
#[derive(Debug, Clone, PartialEq)]
pub struct ParametricRegression {
    coefficients: [f64; 3],
    lead: f64,
    residual_rms: f64,
    loo_nmse: f64,
    n_points: usize,
}

impl ParametricRegression {
    /// Fits Euler features $[\sin\theta, \dot\theta, u\cos\theta]$ ($h = 0$)
    /// to inputs $z = (\theta, \dot\theta, x, \dot x, u)$ and outputs
    /// $\Delta\dot\theta$.
    ///
    /// # Errors
    /// [`ParametricError`]: fewer than 3 points, lengths that differ, a
    /// non-finite value, or data that do not determine the coefficients.
    ///
    /// ```
    /// use swingup::models::parametric::ParametricRegression;
    /// // data exactly in the model: Δθ̇ = -0.27 sin θ - 0.003 θ̇ - 0.028 u cos θ
    /// let xs: Vec<[f64; 5]> = (0..50)
    ///     .map(|i| { let t = i as f64; [(0.37 * t).sin() * 3.0, (0.91 * t).cos() * 4.0, 0.0, 0.0, (0.53 * t).sin() * 10.0] })
    ///     .collect();
    /// let ys: Vec<[f64; 1]> = xs
    ///     .iter()
    ///     .map(|z| [-0.27 * z[0].sin() - 0.003 * z[1] - 0.028 * z[4] * z[0].cos()])
    ///     .collect();
    /// let model = ParametricRegression::fit(&xs, &ys)?;
    /// let c = model.coefficients();
    /// assert!((c[0] + 0.27).abs() < 1e-12 && (c[1] + 0.003).abs() < 1e-12 && (c[2] + 0.028).abs() < 1e-12);
    /// assert!(model.residual_rms() < 1e-12);
    /// # Ok::<(), swingup::Error>(())
    /// ```
    pub fn fit(xs: &[[f64; 5]], ys: &[[f64; 1]]) -> crate::Result<Self> {
        Ok(Self::fit_with_lead(xs, ys, 0.0)?)
    }

    /// Fits midpoint features $[\sin\theta_m, \dot\theta, u\cos\theta_m]$,
    /// $\theta_m = \theta + \dot\theta\,\Delta t / 2$, for samples `dt` apart.
    ///
    /// # Errors
    /// As [`fit`](Self::fit), and a `dt` that is not finite and positive.
    pub fn fit_midpoint(xs: &[[f64; 5]], ys: &[[f64; 1]], dt: f64) -> crate::Result<Self> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(ParametricError::InvalidParameter {
                name: "dt",
                reason: format!("must be finite and positive, got {dt}"),
            }
            .into());
        }
        Ok(Self::fit_with_lead(xs, ys, 0.5 * dt)?)
    }

    /// A model with given coefficients and angle lead $h$ (no data: the
    /// residual statistics are NaN).
    ///
    /// # Errors
    /// Non-finite coefficients or lead.
    pub fn from_coefficients(coefficients: [f64; 3], lead: f64) -> Result<Self, ParametricError> {
        if let Some(i) = coefficients.iter().position(|c| !c.is_finite()) {
            return Err(ParametricError::NotFinite {
                what: "coefficients",
                index: i,
                value: coefficients[i],
            });
        }
        if !lead.is_finite() {
            return Err(ParametricError::InvalidParameter {
                name: "lead",
                reason: format!("must be finite, got {lead}"),
            });
        }
        Ok(Self {
            coefficients,
            lead,
            residual_rms: f64::NAN,
            loo_nmse: f64::NAN,
            n_points: 0,
        })
    }

    fn fit_with_lead(xs: &[[f64; 5]], ys: &[[f64; 1]], lead: f64) -> Result<Self, ParametricError> {
        if xs.len() != ys.len() {
            return Err(ParametricError::LengthMismatch {
                inputs: xs.len(),
                outputs: ys.len(),
            });
        }
        let n = xs.len();
        if n < 3 {
            return Err(ParametricError::TooFewPoints { needed: 3, actual: n });
        }
        for (i, (x, y)) in xs.iter().zip(ys).enumerate() {
            if let Some(v) = x.iter().find(|v| !v.is_finite()) {
                return Err(ParametricError::NotFinite {
                    what: "inputs",
                    index: i,
                    value: *v,
                });
            }
            if !y[0].is_finite() {
                return Err(ParametricError::NotFinite {
                    what: "outputs",
                    index: i,
                    value: y[0],
                });
            }
        }
        let a = Mat::from_fn(n, 3, |i, j| features(&xs[i], lead)[j]);
        let b = Mat::from_fn(n, 1, |i, _| ys[i][0]);
        // normalise the columns so that the rank test and the solve do not
        // depend on the units
        let norms: [f64; 3] = std::array::from_fn(|j| a.col(j).iter().map(|v| v * v).sum::<f64>().sqrt());
        if norms.iter().any(|&s| !(s > 0.0 && s.is_finite())) {
            return Err(ParametricError::RankDeficient { ratio: 0.0 });
        }
        let scaled = Mat::from_fn(n, 3, |i, j| a[(i, j)] / norms[j]);
        let sv = scaled
            .singular_values()
            .map_err(|e| ParametricError::Solve(format!("{e:?}")))?;
        let ratio = sv[2] / sv[0];
        if ratio.is_nan() || ratio < MIN_SINGULAR_RATIO {
            return Err(ParametricError::RankDeficient { ratio });
        }
        let sol = scaled.qr().solve_lstsq(&b);
        let coefficients: [f64; 3] = std::array::from_fn(|j| sol[(j, 0)] / norms[j]);
        if coefficients.iter().any(|c| !c.is_finite()) {
            return Err(ParametricError::Solve("non-finite coefficients".into()));
        }
        // residuals and leave-one-out residuals e_i / (1 - h_ii), with the
        // leverages h_ii from the 3 x 3 Gram matrix of the scaled features
        let gram = scaled.transpose() * &scaled;
        let llt = gram
            .llt(faer::Side::Lower)
            .map_err(|e| ParametricError::Solve(format!("{e:?}")))?;
        let mean_y = ys.iter().map(|y| y[0]).sum::<f64>() / n as f64;
        let (mut sse, mut loo_sse, mut sst) = (0.0, 0.0, 0.0);
        for i in 0..n {
            let phi = features(&xs[i], lead);
            let r = ys[i][0] - (0..3).map(|j| coefficients[j] * phi[j]).sum::<f64>();
            let row = Mat::from_fn(3, 1, |j, _| scaled[(i, j)]);
            let g = llt.solve(&row);
            let h: f64 = (0..3).map(|j| row[(j, 0)] * g[(j, 0)]).sum();
            sse += r * r;
            loo_sse += (r / (1.0 - h)).powi(2);
            sst += (ys[i][0] - mean_y).powi(2);
        }
        Ok(Self {
            coefficients,
            lead,
            residual_rms: (sse / n as f64).sqrt(),
            loo_nmse: loo_sse / sst,
            n_points: n,
        })
    }

    /// The coefficients $(c_1, c_2, c_3)$ of [`FEATURES`].
    pub fn coefficients(&self) -> [f64; 3] {
        self.coefficients
    }

    /// The angle lead $h$ of $\theta_m = \theta + h\dot\theta$ (0 for Euler
    /// features, $\Delta t/2$ for midpoint ones).
    pub fn lead(&self) -> f64 {
        self.lead
    }

    /// Root mean square of the fit's residuals (rad/s per sample; NaN without data).
    pub fn residual_rms(&self) -> f64 {
        self.residual_rms
    }

    /// Leave-one-out mean squared error over the variance of the outputs
    /// (exact for least squares, from the leverages; NaN without data).
    pub fn loo_nmse(&self) -> f64 {
        self.loo_nmse
    }

    /// Number of data points fitted.
    pub fn n_points(&self) -> usize {
        self.n_points
    }

    /// Physical parameters from the coefficients, for samples `dt` apart.
    ///
    /// The one-step expansion makes $c = \Delta t (1 - b\Delta t/2)\,
    /// (-g/l, -b, -1/l)$ to second order (the $-\tfrac{\Delta t^2}{2} b f$
    /// term is in the features' span); so $b\Delta t = 1 - \sqrt{1 + 2 c_2}$,
    /// and the others follow by dividing by $\Delta t (1 - b\Delta t/2)$.
    /// With Euler features the damping is biased (see the [module docs](self)).
    /// Non-finite if $c_2 < -1/2$ (a damping beyond any physical one).
    pub fn physical(&self, dt: f64) -> PhysicalEstimate {
        let [c1, c2, c3] = self.coefficients;
        let b_dt = 1.0 - (1.0 + 2.0 * c2).sqrt();
        let scale = dt * (1.0 - 0.5 * b_dt);
        PhysicalEstimate {
            gravity_over_length: -c1 / scale,
            inverse_length: -c3 / scale,
            damping: b_dt / dt,
        }
    }

    /// The model's record for the trial report (`kind` `parametric`; no
    /// metric, so `scales` is empty and `bandwidth` NaN).
    pub fn summary(&self) -> ModelSummary {
        ModelSummary {
            kind: "parametric".into(),
            n_points: self.n_points,
            inputs: INPUTS.iter().map(|s| s.to_string()).collect(),
            scales: Vec::new(),
            bandwidth: f64::NAN,
            loo_nmse: self.loo_nmse,
            lwr_vs_prior: f64::NAN,
            dropped: Vec::new(),
            selection_cv: Vec::new(),
        }
    }
}

/// The features $[\sin\theta_m, \dot\theta, u\cos\theta_m]$, $\theta_m = \theta + h\dot\theta$.
fn features(z: &[f64; 5], lead: f64) -> [f64; 3] {
    let (s, c) = (z[0] + lead * z[1]).sin_cos();
    [s, z[1], z[4] * c]
}

impl PendulumRegression for ParametricRegression {
    /// $g(z) = c^\top \phi(z)$ with the exact Jacobian
    /// $\partial g/\partial\theta = c_1\cos\theta_m - c_3 u \sin\theta_m =: D$,
    /// $\partial g/\partial\dot\theta = c_2 + hD$, $\partial g/\partial u = c_3\cos\theta_m$,
    /// zero for the hand.
    fn delta_omega(&self, z: &[f64; 5], jacobian: Option<&mut [f64; 5]>) -> f64 {
        let [c1, c2, c3] = self.coefficients;
        let (s, c) = (z[0] + self.lead * z[1]).sin_cos();
        if let Some(j) = jacobian {
            let d = c1 * c - c3 * z[4] * s;
            *j = [d, c2 + self.lead * d, 0.0, 0.0, c3 * c];
        }
        c1 * s + c2 * z[1] + c3 * z[4] * c
    }
}

/// Fits the parametric model (midpoint features) to all trials so far, the
/// counterpart of [`crate::models::learned::learn_model`] for `--model parametric`.
///
/// # Errors
/// No data, or the data do not determine the model ([`ParametricError`]).
pub fn learn_parametric(
    cfg: &Config,
    trials: &[TrialRecord],
) -> crate::Result<(KnownHand<ParametricRegression>, ModelSummary)> {
    let (xs, ys) = training_data(trials);
    let model = ParametricRegression::fit_midpoint(&xs, &ys, cfg.robot.dt)?;
    let summary = model.summary();
    Ok((KnownHand::new(model, cfg.robot.dt), summary))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plant::{Plant, PlantParams, PlantState};
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Noiseless per-sample data from the robot plant at random states and commands.
    fn plant_data(params: PlantParams, n: usize, seed: u64) -> (Vec<[f64; 5]>, Vec<[f64; 1]>) {
        let plant = Plant::new(params);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut xs = Vec::with_capacity(n);
        let mut ys = Vec::with_capacity(n);
        for _ in 0..n {
            let z = [
                rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
                rng.random_range(-6.0..6.0),
                rng.random_range(-0.5..0.5),
                rng.random_range(-2.0..2.0),
                rng.random_range(-12.0..12.0),
            ];
            let next = plant.step(
                &PlantState {
                    s: [z[0], z[1], z[2], z[3]],
                    a: z[4],
                },
                z[4],
            );
            xs.push(z);
            ys.push([next.s[1] - z[1]]);
        }
        (xs, ys)
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    /// Data exactly in the model's span are fitted exactly, whatever the lead.
    #[test]
    fn reproduces_a_model_in_its_span_exactly() {
        let (xs, _) = plant_data(PlantParams::robot(), 200, 3);
        let truth = [-0.27, -0.0033, -0.028];
        for lead in [0.0, 1.0 / 120.0] {
            let ys: Vec<[f64; 1]> = xs
                .iter()
                .map(|z| {
                    let phi = features(z, lead);
                    [(0..3).map(|j| truth[j] * phi[j]).sum()]
                })
                .collect();
            let m = ParametricRegression::fit_with_lead(&xs, &ys, lead).expect("fit");
            for (c, t) in m.coefficients().iter().zip(truth) {
                assert!(rel(*c, t) < 1e-12, "{:?}", m.coefficients());
            }
            assert!(m.residual_rms() < 1e-14);
        }
    }

    /// On noiseless robot-plant data (RK4, 10 substeps per 1/60 s sample)
    /// at random states and commands, the midpoint fit recovers $g/l$ and
    /// $1/l$ to 2e-4 and $b$ to 6e-4 (its $O(\Delta t^3)$ remainder); the
    /// Euler fit gets all three within 1.5 % here, because over uniformly
    /// random angles the $\cos\theta\,\dot\theta$ term it misses averages
    /// out; on swing-up data it does not (next test).
    #[test]
    fn recovers_the_robot_plant_from_noiseless_data() {
        let params = PlantParams::robot();
        let dt = params.dt;
        let (xs, ys) = plant_data(params, 2000, 11);
        let (gl, il, b) = (params.gravity / params.length, 1.0 / params.length, params.damping);

        let mid = ParametricRegression::fit_midpoint(&xs, &ys, dt).expect("fit");
        let p = mid.physical(dt);
        eprintln!(
            "midpoint: g/l {} (true {gl}), 1/l {} (true {il}), b {} (true {b}), rms {}",
            p.gravity_over_length,
            p.inverse_length,
            p.damping,
            mid.residual_rms()
        );
        assert!(rel(p.gravity_over_length, gl) < 5e-4, "{p:?}");
        assert!(rel(p.inverse_length, il) < 5e-4, "{p:?}");
        assert!(rel(p.damping, b) < 3e-3, "{p:?}");
        assert!(rel(p.length(), params.length) < 5e-4 && rel(p.gravity(), params.gravity) < 5e-4);

        let euler = ParametricRegression::fit(&xs, &ys).expect("fit");
        let q = euler.physical(dt);
        eprintln!(
            "euler: g/l {} (true {gl}), 1/l {} (true {il}), b {} (true {b}), rms {}",
            q.gravity_over_length,
            q.inverse_length,
            q.damping,
            euler.residual_rms()
        );
        assert!(rel(q.gravity_over_length, gl) < 0.01, "{q:?}");
        assert!(rel(q.inverse_length, il) < 0.01, "{q:?}");
        assert!(rel(q.damping, b) < 0.05, "{q:?}");
        // the midpoint features fit the plant far better
        assert!(mid.residual_rms() < 0.1 * euler.residual_rms());
    }

    /// On swing-up data (the robot replaying the demonstration, trial 1 of
    /// a run, noiseless) the Euler fit's damping is badly biased, the
    /// midpoint fit's is not.
    #[test]
    fn euler_damping_is_biased_on_swing_up_data() {
        let cfg = Config::default();
        let (xs, ys) = crate::plant::demo::imitation_data();
        let dt = cfg.robot.dt;
        let b = cfg.robot.damping;
        let gl = cfg.robot.gravity / cfg.robot.length;
        let euler = ParametricRegression::fit(&xs, &ys).expect("fit").physical(dt);
        let mid = ParametricRegression::fit_midpoint(&xs, &ys, dt)
            .expect("fit")
            .physical(dt);
        eprintln!("euler {euler:?}\nmidpoint {mid:?}");
        assert!(rel(euler.damping, b) > 0.3, "{euler:?}");
        assert!(rel(euler.gravity_over_length, gl) < 0.02, "{euler:?}");
        assert!(rel(mid.damping, b) < 0.01, "{mid:?}");
        assert!(rel(mid.gravity_over_length, gl) < 1e-3 && rel(mid.inverse_length, 1.0 / cfg.robot.length) < 1e-3);
    }

    fn check_jacobian(m: &ParametricRegression, z: [f64; 5]) -> Result<(), TestCaseError> {
        let mut j = [0.0; 5];
        let g = m.delta_omega(&z, Some(&mut j));
        prop_assert_eq!(g, m.delta_omega(&z, None));
        let worst =
            ddp::strategies::check_jacobian(|z| vec![m.delta_omega(&z.try_into().expect("5 inputs"), None)], &z, &j)
                .expect("check");
        prop_assert!(worst.max_rel_error < 1e-7, "at {:?}: {:?}", z, worst);
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// The exact Jacobian equals central differences.
        #[test]
        fn jacobian_matches_central_differences(
            c in prop::array::uniform3(-1.0f64..1.0),
            lead in prop_oneof![Just(0.0), 0.0f64..0.05],
            z in prop::array::uniform5(-10.0f64..10.0),
        ) {
            let m = ParametricRegression::from_coefficients(c, lead).expect("finite");
            check_jacobian(&m, z)?;
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let err = |r: crate::Result<ParametricRegression>| -> ParametricError {
            match r.expect_err("must fail") {
                crate::Error::Parametric(e) => e,
                other => panic!("not a parametric error: {other}"),
            }
        };
        let (xs, ys) = plant_data(PlantParams::robot(), 20, 5);
        assert!(matches!(
            err(ParametricRegression::fit(&xs[..2], &ys[..2])),
            ParametricError::TooFewPoints { needed: 3, actual: 2 }
        ));
        assert!(matches!(
            err(ParametricRegression::fit(&[], &[])),
            ParametricError::TooFewPoints { .. }
        ));
        assert!(matches!(
            err(ParametricRegression::fit(&xs, &ys[..10])),
            ParametricError::LengthMismatch {
                inputs: 20,
                outputs: 10
            }
        ));
        let mut bad = xs.clone();
        bad[4][1] = f64::NAN;
        assert!(matches!(
            err(ParametricRegression::fit(&bad, &ys)),
            ParametricError::NotFinite {
                what: "inputs",
                index: 4,
                ..
            }
        ));
        let mut bad_y = ys.clone();
        bad_y[7][0] = f64::INFINITY;
        assert!(matches!(
            err(ParametricRegression::fit(&xs, &bad_y)),
            ParametricError::NotFinite {
                what: "outputs",
                index: 7,
                ..
            }
        ));
        // hanging at rest, the hand never moving: all features vanish
        let still = vec![[0.0; 5]; 10];
        assert!(matches!(
            err(ParametricRegression::fit(&still, &[[0.0]; 10])),
            ParametricError::RankDeficient { .. }
        ));
        // u = 2 tan(theta), so u cos(theta) = 2 sin(theta): collinear columns
        let collinear: Vec<[f64; 5]> = (0..10)
            .map(|i| {
                let t = 0.1 * i as f64 + 0.05;
                [t, (i as f64).sin(), 0.0, 0.0, 2.0 * t.tan()]
            })
            .collect();
        assert!(matches!(
            err(ParametricRegression::fit(&collinear, &[[0.1]; 10])),
            ParametricError::RankDeficient { .. }
        ));
        assert!(matches!(
            err(ParametricRegression::fit_midpoint(&xs, &ys, 0.0)),
            ParametricError::InvalidParameter { name: "dt", .. }
        ));
        assert!(ParametricRegression::from_coefficients([f64::NAN, 0.0, 0.0], 0.0).is_err());
    }

    /// Through [`KnownHand`], the parametric model is a `trajopt` model whose
    /// Jacobians match central differences, and it keeps the pendulum
    /// hanging at rest.
    #[test]
    fn known_hand_wrapper_is_consistent() {
        use trajopt::Dynamics;
        let params = PlantParams::robot();
        let (xs, ys) = plant_data(params, 300, 9);
        let model = KnownHand::new(
            ParametricRegression::fit_midpoint(&xs, &ys, params.dt).expect("fit"),
            params.dt,
        );
        let mut next = vec![0.0; 4];
        model.step(&[0.0; 4], &[0.0], &mut next).expect("step");
        assert_eq!(next, vec![0.0; 4]);
        let (x, u) = ([2.0, -3.0, 0.2, 0.5], [4.0]);
        let worst = trajopt::check_model_jacobians(&model, &x, &u)
            .expect("check")
            .expect("analytic");
        assert!(worst.max_rel_error < 1e-7, "{worst:?}");
    }
}
