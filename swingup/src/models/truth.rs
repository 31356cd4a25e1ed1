//! The true model: the robot plant's own per-sample change of angular
//! velocity, for planning with a perfect pendulum model (the "true model"
//! column of the planner-by-model experiment, claim C6).

use crate::models::PendulumRegression;
use crate::plant::{Plant, PlantParams, PlantState};

/// The exact per-sample $\Delta\dot\theta$ of a plant: one sample of the
/// plant's own RK4 integration ([`Plant::step`]) from
/// $(\theta, \dot\theta, x, \dot x)$ under the command $u$, minus $\dot\theta$.
///
/// Wrapped in [`KnownHand`](crate::models::KnownHand), the angular velocity
/// and the hand are then exact; the angle follows by the trapezoid rule, an
/// $O(\Delta t^3)$ error per sample. The hand's acceleration is taken to
/// equal the command from the start of the sample, so for a plant with a
/// hand lag (`lag > 0`) this is the lag-free plant's dynamics (the lag's
/// state is not in $z$). Commands beyond the plant's `u_limit` are clipped
/// as the plant clips them (the derivative in $u$ is zero there).
///
/// The Jacobian is by central differences with steps
/// $10^{-6}\max(1, |z_j|)$: the RK4 map is smooth, so it is accurate to
/// about $10^{-9}$, ample for planning; it costs ten plant steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrueRegression {
    params: PlantParams,
}

impl TrueRegression {
    /// The true model of a plant.
    ///
    /// # Errors
    /// Invalid plant parameters.
    pub fn new(params: PlantParams) -> crate::Result<Self> {
        params.validate().map_err(crate::Error::Data)?;
        Ok(Self { params })
    }

    /// The true model of the default robot ([`PlantParams::robot`]).
    pub fn robot() -> Self {
        Self {
            params: PlantParams::robot(),
        }
    }

    /// The plant's parameters.
    pub fn params(&self) -> &PlantParams {
        &self.params
    }

    fn value(&self, z: &[f64; 5]) -> f64 {
        let next = Plant::new(self.params).step(
            &PlantState {
                s: [z[0], z[1], z[2], z[3]],
                a: z[4],
            },
            z[4],
        );
        next.s[1] - z[1]
    }
}

impl PendulumRegression for TrueRegression {
    fn delta_omega(&self, z: &[f64; 5], jacobian: Option<&mut [f64; 5]>) -> f64 {
        if let Some(j) = jacobian {
            for c in 0..5 {
                let h = 1e-6 * z[c].abs().max(1.0);
                let (mut zp, mut zm) = (*z, *z);
                zp[c] += h;
                zm[c] -= h;
                j[c] = (self.value(&zp) - self.value(&zm)) / (2.0 * h);
            }
        }
        self.value(z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::KnownHand;

    /// Through [`KnownHand`], the true model reproduces the plant's angular
    /// velocity and hand exactly, and its angle to the trapezoid rule's accuracy.
    #[test]
    fn matches_the_plant() {
        let params = PlantParams::robot();
        let plant = Plant::new(params);
        let model = KnownHand::new(TrueRegression::new(params).expect("valid"), params.dt);
        let mut st = PlantState::hanging();
        let mut worst_angle: f64 = 0.0;
        for k in 0..120 {
            let u = 8.0 * (0.15 * k as f64).sin();
            let mut next = [0.0; 4];
            ddp::Dynamics::step(&model, &st.s, &[u], &mut next).expect("step");
            st = plant.step(&st, u);
            assert!((next[1] - st.s[1]).abs() < 1e-12);
            assert!((next[2] - st.s[2]).abs() < 1e-12 && (next[3] - st.s[3]).abs() < 1e-12);
            worst_angle = worst_angle.max((next[0] - st.s[0]).abs());
        }
        assert!(worst_angle < 1e-4, "trapezoid angle error {worst_angle}");
        assert!(TrueRegression::new(PlantParams { length: -1.0, ..params }).is_err());
    }

    #[test]
    fn jacobian_matches_a_coarser_difference() {
        let m = TrueRegression::robot();
        let z = [2.0, -3.0, 0.1, 0.4, 5.0];
        let mut j = [0.0; 5];
        m.delta_omega(&z, Some(&mut j));
        for c in 0..5 {
            let h = 1e-4;
            let (mut zp, mut zm) = (z, z);
            zp[c] += h;
            zm[c] -= h;
            let fd = (m.delta_omega(&zp, None) - m.delta_omega(&zm, None)) / (2.0 * h);
            assert!((fd - j[c]).abs() < 1e-6, "{c}: {} vs {fd}", j[c]);
        }
        // hand position and velocity do not matter
        assert!(j[2].abs() < 1e-9 && j[3].abs() < 1e-9);
    }
}
