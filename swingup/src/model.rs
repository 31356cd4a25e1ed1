//! The robot's learned model, as a `trajopt` dynamics model.
//!
//! As in the paper, the model does not know the task's structure: a
//! locally weighted regression predicts the per-sample change of the
//! pendulum's angular velocity and of the hand's velocity,
//! $(\Delta\dot\theta, \Delta\dot x) = g(\theta, \dot\theta, x, \dot x, u)$, from
//! everything the robot observed. Positions follow by the trapezoid rule,
//! $\theta_{k+1} = \theta_k + \tfrac{\Delta t}{2}(\dot\theta_k + \dot\theta_{k+1})$
//! and likewise for $x$ (kinematics, known). The hand's velocity is
//! learned too: the robot's hand lags its command, so $\Delta\dot x = u\,\Delta t$
//! does not hold.
//!
//! Where no stored point carries kernel weight, the LWR has no answer; the
//! model then falls back on a global linear least-squares fit of the same
//! data (documented fallback, counted in [`LearnedModel::fallbacks`]), so
//! that a planner exploring far from the data still gets a finite, smooth,
//! if crude, prediction.

use std::sync::atomic::{AtomicUsize, Ordering};

use faer::Mat;
use faer::prelude::*;
use lwr::LwrModel;

/// Names of the model inputs, in order.
pub const INPUTS: [&str; 5] = ["theta", "theta_dot", "x", "x_dot", "u"];

/// A learned model $f(s, u)$ for the planner; see the [module docs](self).
#[derive(Debug)]
pub struct LearnedModel {
    lwr: LwrModel,
    /// Global linear fallback: rows = outputs, columns = [1, inputs].
    linear: [[f64; 6]; 2],
    dt: f64,
    fallbacks: AtomicUsize,
}

impl LearnedModel {
    /// Wraps a fitted LWR model (5 inputs, 2 outputs) and fits the fallback
    /// to the same data.
    pub fn new(lwr: LwrModel, dt: f64) -> anyhow::Result<Self> {
        anyhow::ensure!(
            lwr.database().n_inputs() == 5 && lwr.database().n_outputs() == 2,
            "the model needs 5 inputs and 2 outputs"
        );
        anyhow::ensure!(!lwr.database().is_empty(), "the model has no data");
        let linear = global_linear_fit(&lwr)?;
        Ok(Self {
            lwr,
            linear,
            dt,
            fallbacks: AtomicUsize::new(0),
        })
    }

    /// The LWR model.
    pub fn lwr(&self) -> &LwrModel {
        &self.lwr
    }

    /// How many predictions used the global linear fallback.
    pub fn fallbacks(&self) -> usize {
        self.fallbacks.load(Ordering::Relaxed)
    }

    /// $(\Delta\dot\theta, \Delta\dot x)$ and their Jacobian (2 × 5) at `z`:
    /// the LWR prediction where its support $n_{lwr}$ (effective number of
    /// points) is at least [`FULL_SUPPORT`], the global linear fit where it
    /// is below [`NO_SUPPORT`], and a smoothstep blend in between, so that
    /// predictions fade to the crude global model where data run out
    /// instead of extrapolating a local fit made from a handful of points.
    /// The Jacobian is exact where the weight is 0 or 1 and treats the
    /// weight as constant in the blend.
    fn predict(&self, z: &[f64; 5], with_jacobian: bool) -> ([f64; 2], [[f64; 5]; 2]) {
        let lin_mean: [f64; 2] =
            std::array::from_fn(|o| self.linear[o][0] + (0..5).map(|c| self.linear[o][c + 1] * z[c]).sum::<f64>());
        let lin_jac: [[f64; 5]; 2] = std::array::from_fn(|o| std::array::from_fn(|c| self.linear[o][c + 1]));
        // the Jacobian costs a second pass over the neighbours: only when asked
        let fitted = if with_jacobian {
            self.lwr.predict_with_jacobian(z).ok().map(|(p, j)| (p, Some(j)))
        } else {
            self.lwr.predict(z).ok().map(|p| (p, None))
        };
        let local = fitted.and_then(|(p, j)| {
            let jac: [[f64; 5]; 2] =
                std::array::from_fn(|o| std::array::from_fn(|c| j.as_ref().map_or(0.0, |j| j[(o, c)])));
            let usable = matches!(p.status, lwr::FitStatus::Ok | lwr::FitStatus::Regularized)
                && p.mean.iter().all(|v| v.is_finite())
                && jac.iter().flatten().all(|v| v.is_finite());
            usable.then(|| ([p.mean[0], p.mean[1]], jac, p.n_lwr))
        });
        match local {
            Some((mean, jac, n_lwr)) => {
                let s = ((n_lwr - NO_SUPPORT) / (FULL_SUPPORT - NO_SUPPORT)).clamp(0.0, 1.0);
                let w = s * s * (3.0 - 2.0 * s);
                (
                    std::array::from_fn(|o| w * mean[o] + (1.0 - w) * lin_mean[o]),
                    std::array::from_fn(|o| std::array::from_fn(|c| w * jac[o][c] + (1.0 - w) * lin_jac[o][c])),
                )
            }
            None => {
                self.fallbacks.fetch_add(1, Ordering::Relaxed);
                (lin_mean, lin_jac)
            }
        }
    }
}

/// Support (effective number of points) from which the LWR prediction is used alone.
pub const FULL_SUPPORT: f64 = 10.0;

/// Support below which only the global linear fit is used.
pub const NO_SUPPORT: f64 = 1.0;

/// Least squares of each output on $[1, z]$ over the whole database (a tiny
/// ridge keeps it defined for degenerate data).
fn global_linear_fit(lwr: &LwrModel) -> anyhow::Result<[[f64; 6]; 2]> {
    let db = lwr.database();
    let mut ata = Mat::<f64>::zeros(6, 6);
    let mut aty = Mat::<f64>::zeros(6, 2);
    for i in 0..db.len() {
        let (Some(x), Some(y)) = (db.input(i), db.output(i)) else {
            continue;
        };
        let row: [f64; 6] = std::array::from_fn(|c| if c == 0 { 1.0 } else { x[c - 1] });
        for a in 0..6 {
            for b in 0..6 {
                ata[(a, b)] += row[a] * row[b];
            }
            for o in 0..2 {
                aty[(a, o)] += row[a] * y[o];
            }
        }
    }
    for a in 0..6 {
        ata[(a, a)] += 1e-9 * (1.0 + ata[(a, a)]);
    }
    let sol = ata
        .llt(faer::Side::Lower)
        .map_err(|e| anyhow::anyhow!("global linear fit failed: {e:?}"))?
        .solve(&aty);
    Ok(std::array::from_fn(|o| std::array::from_fn(|c| sol[(c, o)])))
}

impl trajopt::Model for LearnedModel {
    fn state_dim(&self) -> usize {
        4
    }

    fn control_dim(&self) -> usize {
        1
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> trajopt::Result<()> {
        let z = [x[0], x[1], x[2], x[3], u[0]];
        let (d, _) = self.predict(&z, false);
        let (w1, v1) = (x[1] + d[0], x[3] + d[1]);
        next[1] = w1;
        next[0] = x[0] + 0.5 * self.dt * (x[1] + w1);
        next[3] = v1;
        next[2] = x[2] + 0.5 * self.dt * (x[3] + v1);
        Ok(())
    }

    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> trajopt::Result<bool> {
        let z = [x[0], x[1], x[2], x[3], u[0]];
        let (_, j) = self.predict(&z, true);
        let h = 0.5 * self.dt;
        // d(omega')/dz = e_omega + J0 ; d(v')/dz = e_v + J1
        let dw: [f64; 5] = std::array::from_fn(|c| j[0][c] + if c == 1 { 1.0 } else { 0.0 });
        let dv: [f64; 5] = std::array::from_fn(|c| j[1][c] + if c == 3 { 1.0 } else { 0.0 });
        for c in 0..4 {
            fx[4 + c] = dw[c];
            fx[c] = if c == 0 { 1.0 } else { 0.0 } + h * (if c == 1 { 1.0 } else { 0.0 } + dw[c]);
            fx[12 + c] = dv[c];
            fx[8 + c] = if c == 2 { 1.0 } else { 0.0 } + h * (if c == 3 { 1.0 } else { 0.0 } + dv[c]);
        }
        fu[1] = dw[4];
        fu[0] = h * dw[4];
        fu[3] = dv[4];
        fu[2] = h * dv[4];
        Ok(true)
    }

    fn confidence(&self, x: &[f64], u: &[f64]) -> Option<f64> {
        let z = [x[0], x[1], x[2], x[3], u[0]];
        self.lwr.predict(&z).ok().map(|p| p.n_lwr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lwr::{Kernel, LwrSettings};
    use trajopt::Model;

    /// A model of known linear dynamics: its Jacobians must match central differences.
    #[test]
    fn jacobians_match_central_differences() {
        let settings = LwrSettings {
            kernel: Kernel::Gaussian,
            bandwidth: 2.0,
            ..LwrSettings::default()
        };
        let mut lwr = LwrModel::new(5, 2, settings).expect("valid");
        let mut seed = 7u64;
        let mut rand = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..300 {
            let z = [rand() * 3.0, rand() * 5.0, rand() * 0.5, rand() * 2.0, rand() * 10.0];
            let y = [-0.3 * z[0].sin() - 0.01 * z[4] * z[0].cos(), 0.016 * z[4] - 0.1 * z[3]];
            lwr.insert(&z, &y).expect("finite");
        }
        let model = LearnedModel::new(lwr, 1.0 / 60.0).expect("data");
        let (x, u) = ([0.4, -1.0, 0.1, 0.3], [2.0]);
        let (mut fx, mut fu) = (vec![0.0; 16], vec![0.0; 4]);
        assert!(model.jacobians(&x, &u, &mut fx, &mut fu).expect("ok"));
        let h = 1e-5;
        let (mut a, mut b) = (vec![0.0; 4], vec![0.0; 4]);
        for c in 0..5 {
            let (mut xp, mut xm, mut up, mut um) = (x, x, u, u);
            if c < 4 {
                xp[c] += h;
                xm[c] -= h;
            } else {
                up[0] += h;
                um[0] -= h;
            }
            model.step(&xp, &up, &mut a).expect("ok");
            model.step(&xm, &um, &mut b).expect("ok");
            for i in 0..4 {
                let fd = (a[i] - b[i]) / (2.0 * h);
                let an = if c < 4 { fx[i * 4 + c] } else { fu[i] };
                assert!(
                    (fd - an).abs() < 1e-6 * an.abs().max(1.0),
                    "d next[{i}] / d z[{c}]: {an} vs {fd}"
                );
            }
        }
        assert_eq!(model.fallbacks(), 0);
        // far from all data the fallback answers, finitely
        let mut next = vec![0.0; 4];
        model
            .step(&[50.0, 50.0, 50.0, 50.0], &[50.0], &mut next)
            .expect("fallback");
        assert!(next.iter().all(|v| v.is_finite()));
    }
}
