//! The robot's models of its own dynamics, written once to the workspace's
//! model contract (`systems::Dynamics`, re-exported by `trajopt` and
//! `ddp`).
//!
//! As in the paper, the hand's kinematics are known and the pendulum's are
//! learned: a regression $g$ predicts the per-sample change of the
//! pendulum's angular velocity, $\dot\theta_{k+1} - \dot\theta_k = g(\theta_k,
//! \dot\theta_k, x_k, \dot x_k, u_k)$, from everything the robot observed; the
//! angle follows by the trapezoid rule,
//! $\theta_{k+1} = \theta_k + \tfrac{\Delta t}{2}(\dot\theta_k + \dot\theta_{k+1})$,
//! and the hand by exact zero-order-hold kinematics,
//! $\dot x_{k+1} = \dot x_k + u_k \Delta t$,
//! $x_{k+1} = x_k + \dot x_k \Delta t + u_k \Delta t^2 / 2$
//! ([`KnownHand`]). The hand kinematics are exact for a robot whose hand does
//! what it is told (`lag = 0`, the default robot); with a lag they are not,
//! and the hand servo hides part of the error.
//!
//! Two regressions: [`LwrRegression`], locally weighted regression on all
//! inputs (the paper's nonparametric model), and the parametric model of
//! [`parametric`].

pub mod learned;
pub mod nonparametric;
pub mod parametric;
pub mod selection;
pub mod truth;
use trajopt::ModelResult;

pub use nonparametric::{ControlAffineRegression, LearnedModel, LinearRegression, LwrRegression};

/// Least squares of each of `O` outputs on the `P` regressors `row(x)` by
/// the normal equations, with the relative ridge `ridge`
/// ($A^\top A + \mathrm{ridge}\,(I + \mathrm{diag}\,A^\top A)$) that keeps it
/// defined for degenerate data (a regressor that is 0 throughout gets
/// coefficient 0); the coefficients of output $o$ are row $o$ of the result.
/// The pendulum's global priors and the cart-pole's share it; `what` names
/// the fit in its errors.
///
/// # Errors
/// A training point that is not finite, or a normal matrix that is not
/// positive definite even with the ridge.
pub(crate) fn ridge_least_squares<const I: usize, const O: usize, const P: usize>(
    xs: &[[f64; I]],
    ys: &[[f64; O]],
    ridge: f64,
    what: &str,
    row: impl Fn(&[f64; I]) -> [f64; P],
) -> crate::Result<[[f64; P]; O]> {
    use faer::prelude::Solve;
    let mut ata = faer::Mat::<f64>::zeros(P, P);
    let mut aty = faer::Mat::<f64>::zeros(P, O);
    for (x, y) in xs.iter().zip(ys) {
        crate::error::ensure_data!(
            x.iter().chain(y).all(|v| v.is_finite()),
            "{what}: a training point is not finite: {x:?} -> {y:?}"
        );
        let row = row(x);
        for a in 0..P {
            for b in 0..P {
                ata[(a, b)] += row[a] * row[b];
            }
            for (o, yo) in y.iter().enumerate() {
                aty[(a, o)] += row[a] * yo;
            }
        }
    }
    for a in 0..P {
        ata[(a, a)] += ridge * (1.0 + ata[(a, a)]);
    }
    let sol = ata
        .llt(faer::Side::Lower)
        .map_err(|e| crate::Error::data(format!("{what} failed: {e:?}")))?
        .solve(&aty);
    Ok(std::array::from_fn(|o| std::array::from_fn(|c| sol[(c, o)])))
}

/// Names of the model inputs, in order.
pub const INPUTS: [&str; 5] = ["theta", "theta_dot", "x", "x_dot", "u"];

/// A learned regression of the pendulum's per-sample change of angular
/// velocity on $z = (\theta, \dot\theta, x, \dot x, u)$. `Sync`, so that
/// the planner can query it at many points in parallel.
pub trait PendulumRegression: Sync {
    /// $g(z)$ and, when `jacobian` is given, $\partial g / \partial z$ written into it.
    fn delta_omega(&self, z: &[f64; 5], jacobian: Option<&mut [f64; 5]>) -> f64;

    /// The model's support at $z$ (effective number of data points), if it has one.
    fn support(&self, z: &[f64; 5]) -> Option<f64> {
        let _ = z;
        None
    }

    /// The model's support and the standard error of $g(z)$, if it has them.
    fn uncertainty(&self, z: &[f64; 5]) -> Option<(f64, f64)> {
        let _ = z;
        None
    }

    /// Adds one observed transition, $g(z) = y$, to the model at once
    /// (online learning, for the MPC controller), and says whether the
    /// model learns online; by default it does not (its data change between
    /// trials only).
    ///
    /// # Errors
    /// A transition the model cannot store (say, not finite).
    fn observe(&mut self, z: &[f64; 5], y: f64) -> crate::Result<bool> {
        let _ = (z, y);
        Ok(false)
    }
}

/// A full model $f(s, u)$ of the robot: a [`PendulumRegression`] for the
/// pendulum, known kinematics for the hand; see the [module docs](self).
#[derive(Debug)]
pub struct KnownHand<G> {
    /// The pendulum's regression.
    pub regression: G,
    /// Sample period (s).
    pub dt: f64,
}

impl<G: PendulumRegression> KnownHand<G> {
    /// Wraps a regression.
    pub fn new(regression: G, dt: f64) -> Self {
        Self { regression, dt }
    }

    fn next(&self, x: &[f64], u: f64, next: &mut [f64]) {
        let g = self.regression.delta_omega(&[x[0], x[1], x[2], x[3], u], None);
        systems::hand_pendulum::step(self.dt, x, u, g, next);
    }

    /// Row-major $f_x$ (4 × 4) and $f_u$ (4 × 1).
    fn derivs(&self, x: &[f64], u: f64, fx: &mut [f64], fu: &mut [f64]) {
        let mut grad = [0.0; 5];
        self.regression
            .delta_omega(&[x[0], x[1], x[2], x[3], u], Some(&mut grad));
        systems::hand_pendulum::jacobians(self.dt, &grad, fx, fu);
    }
}

/// Points per parallel task in the batch evaluations: a regression query
/// costs microseconds, so smaller tasks would spend more on scheduling.
const BATCH_CHUNK: usize = 32;

impl<G: PendulumRegression> trajopt::Dynamics for KnownHand<G> {
    fn state_dim(&self) -> usize {
        4
    }

    fn control_dim(&self) -> usize {
        1
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        self.next(x, u[0], next);
        Ok(())
    }

    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        self.derivs(x, u[0], fx, fu);
        Ok(true)
    }

    fn jacobian_structure(&self, fx: &mut [bool], fu: &mut [bool]) {
        systems::hand_pendulum::jacobian_structure(fx, fu);
    }

    fn confidence(&self, x: &[f64], u: &[f64]) -> Option<f64> {
        self.regression.support(&[x[0], x[1], x[2], x[3], u[0]])
    }

    /// The points in parallel (rayon), each exactly as [`step`](trajopt::Dynamics::step).
    fn step_batch(&self, xs: &[f64], us: &[f64], next: &mut [f64]) -> ModelResult<()> {
        use rayon::prelude::*;
        next.par_chunks_mut(4 * BATCH_CHUNK).enumerate().for_each(|(c, out)| {
            for (i, o) in out.chunks_exact_mut(4).enumerate() {
                let k = c * BATCH_CHUNK + i;
                self.next(&xs[4 * k..4 * k + 4], us[k], o);
            }
        });
        Ok(())
    }

    /// The points in parallel (rayon), each exactly as [`jacobians`](trajopt::Dynamics::jacobians).
    fn jacobians_batch(&self, xs: &[f64], us: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        use rayon::prelude::*;
        fx.par_chunks_mut(16 * BATCH_CHUNK)
            .zip(fu.par_chunks_mut(4 * BATCH_CHUNK))
            .enumerate()
            .for_each(|(c, (fx, fu))| {
                for (i, (fx, fu)) in fx.chunks_exact_mut(16).zip(fu.chunks_exact_mut(4)).enumerate() {
                    let k = c * BATCH_CHUNK + i;
                    self.derivs(&xs[4 * k..4 * k + 4], us[k], fx, fu);
                }
            });
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lwr::{Kernel, LwrSettings};
    use trajopt::Dynamics;

    fn check_against_differences(model: &impl Dynamics, x: [f64; 4], u: [f64; 1], tol: f64) {
        let worst = trajopt::check_model_jacobians(model, &x, &u)
            .expect("check")
            .expect("analytic");
        assert!(worst.max_rel_error < tol, "at {x:?}: {worst:?}");
    }

    fn model_of(n: usize, spread: f64, kernel: Kernel) -> LearnedModel {
        let settings = LwrSettings {
            kernel,
            bandwidth: if kernel == Kernel::Gaussian { 0.3 } else { 0.8 },
            scales: vec![1.0, 0.3, 2.0, 1.0, 0.1],
            ridge: 1e-3,
            intercept_ridge: 1.0,
            ..LwrSettings::default()
        };
        let mut seed = 7u64;
        let mut rand = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for _ in 0..n {
            let z = [rand() * spread, rand() * 5.0, rand() * 0.5, rand() * 2.0, rand() * 10.0];
            ys.push([-0.3 * z[0].sin() - 0.01 * z[4] * z[0].cos()]);
            xs.push(z);
        }
        KnownHand::new(LwrRegression::fit(&xs, &ys, settings).expect("data"), 1.0 / 60.0)
    }

    /// Inside the data, at the edge (where the weight of the data falls
    /// against the intercept ridge) and beyond: the Jacobians match central
    /// differences.
    /// The per-point lambda of the planner and the MPC's replans
    /// ([`crate::planning::eq3::confidence_lambda`]) follows the LWR's
    /// support at each step: full inside the data, the floor far outside
    /// it, never above lambda; and it rises where observed transitions are
    /// inserted online.
    #[test]
    fn confidence_lambda_follows_the_support() {
        use crate::planning::eq3::confidence_lambda;
        let mut model = model_of(400, 1.0, Kernel::Gaussian);
        // fully trusted at half the support at the centre of the data
        let centre = model.regression.support(&[0.0; 5]).expect("the LWR has a support");
        let p = crate::config::PlannerConfig {
            confidence_floor: 0.01,
            confidence_full: 0.5 * centre,
            ..crate::config::PlannerConfig::default()
        };
        let lambda = 1e3;
        // inside the data, at its edge, far outside it
        let states = faer::Mat::from_fn(3, 4, |k, i| {
            [[0.0, 0.0, 0.0, 0.0], [0.9, 4.0, 0.4, 1.5], [3.0, 40.0, 0.6, 10.0]][k][i]
        });
        let controls = faer::Mat::from_fn(3, 1, |k, _| [0.0, 8.0, 60.0][k]);
        let weights = |model: &LearnedModel| match confidence_lambda(&p, model, &states, &controls, lambda) {
            trajopt::Lambda::PerStep(w) => w,
            other => panic!("not per step: {other:?}"),
        };
        let w = weights(&model);
        for k in 0..3 {
            let n = model
                .regression
                .support(&[
                    states[(k, 0)],
                    states[(k, 1)],
                    states[(k, 2)],
                    states[(k, 3)],
                    controls[(k, 0)],
                ])
                .expect("the LWR has a support");
            assert_eq!(w[k], lambda * (n / p.confidence_full).clamp(0.01, 1.0), "step {k}");
            assert!(w[k] <= lambda && w[k] >= 0.01 * lambda);
        }
        assert_eq!(w[0], lambda, "inside the data: {w:?}");
        assert_eq!(w[2], 0.01 * lambda, "far outside: {w:?}");
        // data observed at the far point raise its weight
        let far = [3.0, 40.0, 0.6, 10.0, 60.0];
        for _ in 0..20 {
            model.regression.observe(&far, 0.0).expect("insert");
        }
        assert!(weights(&model)[2] > w[2], "{:?} -> {:?}", w, weights(&model));
    }

    /// An observed transition joins the LWR at once: one more point, and
    /// the prediction there moves towards the observed value (a local fit
    /// through it); a non-finite transition is refused and changes nothing.
    #[test]
    fn observed_transitions_join_the_lwr_online() {
        let mut model = model_of(200, 1.0, Kernel::Tricube);
        let z = [0.3, 1.0, 0.1, 0.5, 2.0];
        let before = model.regression.delta_omega(&z, None);
        let target = before + 0.5;
        let n = model.regression.lwr().len();
        for _ in 0..5 {
            assert!(model.regression.observe(&z, target).expect("insert"));
        }
        assert_eq!(model.regression.lwr().len(), n + 5);
        let after = model.regression.delta_omega(&z, None);
        assert!(
            (after - target).abs() < 0.5 * (before - target).abs(),
            "{before} -> {after}, observed {target}"
        );
        assert!(model.regression.observe(&[f64::NAN, 0.0, 0.0, 0.0, 0.0], 0.0).is_err());
        assert_eq!(model.regression.lwr().len(), n + 5);
        let mut truth = KnownHand::new(truth::TrueRegression::robot(), 1.0 / 60.0);
        assert!(!truth.regression.observe(&z, 0.0).expect("no-op"));
    }

    #[test]
    fn jacobians_match_central_differences() {
        for kernel in [Kernel::Gaussian, Kernel::Tricube] {
            jacobians_match_for(kernel);
        }
    }

    /// An LWR on a subset of the inputs: its Jacobian matches central
    /// differences, is exactly 0 along the inputs left out, and its
    /// prediction does not move when they do.
    #[test]
    fn subset_model_ignores_the_inputs_left_out() {
        let full = model_of(300, 1.0, Kernel::Tricube);
        let settings = LwrSettings {
            kernel: Kernel::Tricube,
            bandwidth: 0.8,
            scales: vec![1.0, 0.1],
            ridge: 1e-3,
            intercept_ridge: 1.0,
            ..LwrSettings::default()
        };
        let (xs, ys): (Vec<[f64; 5]>, Vec<[f64; 1]>) = (0..full.regression.lwr().len())
            .map(|i| {
                let x = full.regression.lwr().database().input(i).expect("stored");
                let z = [x[0], x[1], x[2], x[3], x[4]];
                (z, [-0.3 * z[0].sin() - 0.01 * z[4] * z[0].cos()])
            })
            .unzip();
        let sub = LwrRegression::fit_inputs(&xs, &ys, &[0, 4], settings).expect("fit");
        assert_eq!(sub.inputs(), &[0, 4]);
        let z = [0.4, -0.5, 0.1, 0.3, 2.0];
        let mut j = [f64::NAN; 5];
        let g = sub.delta_omega(&z, Some(&mut j));
        assert_eq!([j[1], j[2], j[3]], [0.0; 3], "{j:?}");
        let moved = sub.delta_omega(&[0.4, 3.0, -0.4, -2.0, 2.0], None);
        assert_eq!(g, moved);
        let model = KnownHand::new(sub, 1.0 / 60.0);
        for i in 0..10 {
            let x = [-0.6 + 0.12 * i as f64, 0.2, 0.1, -0.3];
            check_against_differences(&model, x, [1.5 - 0.3 * i as f64], 1e-5);
        }
        // the inputs must be strictly increasing indices below 5
        let settings = LwrSettings::default();
        assert!(LwrRegression::fit_inputs(&xs, &ys, &[4, 0], settings.clone()).is_err());
        assert!(LwrRegression::fit_inputs(&xs, &ys, &[5], settings.clone()).is_err());
        assert!(LwrRegression::fit_inputs(&xs, &ys, &[], settings).is_err());
    }

    /// The parallel batches give exactly the point-by-point values, for a
    /// number of points that is not a multiple of the task size.
    #[test]
    fn batches_equal_point_by_point_evaluation() {
        use trajopt::Dynamics;
        let model = model_of(300, 1.0, Kernel::Gaussian);
        let k = 2 * BATCH_CHUNK + 13;
        let xs: Vec<f64> = (0..4 * k).map(|i| (i as f64 * 0.37).sin() * 2.0).collect();
        let us: Vec<f64> = (0..k).map(|i| (i as f64 * 0.91).cos() * 5.0).collect();
        let (mut next, mut fx, mut fu) = (vec![0.0; 4 * k], vec![0.0; 16 * k], vec![0.0; 4 * k]);
        model.step_batch(&xs, &us, &mut next).expect("batch");
        assert!(model.jacobians_batch(&xs, &us, &mut fx, &mut fu).expect("batch"));
        for p in 0..k {
            let (x, u) = (&xs[4 * p..4 * p + 4], &us[p..p + 1]);
            let (mut n1, mut fx1, mut fu1) = ([0.0; 4], [0.0; 16], [0.0; 4]);
            model.step(x, u, &mut n1).expect("step");
            assert!(model.jacobians(x, u, &mut fx1, &mut fu1).expect("jacobians"));
            assert_eq!(&next[4 * p..4 * p + 4], &n1[..], "point {p}");
            assert_eq!(&fx[16 * p..16 * p + 16], &fx1[..], "point {p}");
            assert_eq!(&fu[4 * p..4 * p + 4], &fu1[..], "point {p}");
        }
    }

    fn jacobians_match_for(kernel: Kernel) {
        let model = model_of(300, 1.0, kernel);
        // from dense data through the thin edge to outside: along a line in theta
        let mut thin = 0;
        for i in 0..=30 {
            let x = [0.2 + 0.1 * i as f64, -1.0 + 0.1 * i as f64, 0.1, 0.3];
            check_against_differences(&model, x, [2.0], 1e-5);
            let n = model
                .regression
                .support(&[x[0], x[1], x[2], x[3], 2.0])
                .expect("support");
            if n > 0.0 && n < 1.0 {
                thin += 1;
            }
        }
        // the thin edge was visited: support below the intercept ridge
        assert!(thin > 0, "{kernel:?}: no query at the thin edge");
        // far from all data the global fit answers, finitely, and is the limit
        // of the shrunk LWR
        let mut next = vec![0.0; 4];
        model
            .step(&[50.0, 50.0, 50.0, 50.0], &[50.0], &mut next)
            .expect("fallback");
        assert!(next.iter().all(|v| v.is_finite()));
        let far = [2.6, 6.0, 0.8, 2.5, 13.0];
        let g = model.regression.delta_omega(&far, None);
        let lin = model.regression.prior().delta_omega(&far, None);
        assert!(
            (g - lin).abs() < 0.1 * lin.abs().max(1e-3),
            "{kernel:?}: at the edge of the data the model is not near the global fit"
        );
    }

    /// The hand rows are exact zero-order-hold kinematics.
    #[test]
    fn hand_kinematics_are_exact() {
        let model = model_of(50, 1.0, Kernel::Gaussian);
        let dt = model.dt;
        let mut next = vec![0.0; 4];
        model.step(&[0.1, 0.2, 0.3, 0.4], &[5.0], &mut next).expect("ok");
        assert!((next[3] - (0.4 + 5.0 * dt)).abs() < 1e-15);
        assert!((next[2] - (0.3 + 0.4 * dt + 2.5 * dt * dt)).abs() < 1e-15);
        // and the structure leaves out only true zeros
        let (mut sx, mut su) = (vec![false; 16], vec![false; 4]);
        model.jacobian_structure(&mut sx, &mut su);
        let (mut fx, mut fu) = (vec![0.0; 16], vec![0.0; 4]);
        model
            .jacobians(&[0.1, 0.2, 0.3, 0.4], &[5.0], &mut fx, &mut fu)
            .expect("ok");
        for (v, keep) in fx.iter().zip(&sx) {
            assert!(*keep || *v == 0.0);
        }
    }
}
