//! The planner's stage cost: the paper's Eq. 5 tracking cost plus soft
//! bounds on the hand's workspace and the command.
//!
//! $$c_k = \underbrace{\sum_i q_i (s_{k,i} - s^d_{k,i})^2 + r (u_k - u^d_k)^2}_{\text{Eq. 5}} +
//! w_b \big[(|x_k| - x_{max})_+^2 + (|u_k| - u_{max})_+^2\big].$$
//!
//! The bounds are penalties, not constraints: a hinge squared is
//! continuously differentiable, so Gauss-Newton keeps its plain sparse
//! Cholesky step (hard bounds through a QP made its steps stall on the
//! learned model), and Powell and DDP see the same cost. With $w_b$ large
//! a plan exceeds a bound by little; the robot's actuator clips the rest.

use std::sync::Arc;
use trajopt::ModelResult;

use systems::hand_pendulum::SoftBounds;
use trajopt::{StageCost, TrackingCost};

use crate::planning::support::DataSupport;

/// See the [module docs](self).
#[derive(Debug, Clone)]
pub struct SwingupCost {
    tracking: TrackingCost,
    bounds: SoftBounds,
    support: Option<Arc<DataSupport>>,
}

impl SwingupCost {
    /// Eq. 5 `tracking` (4 states, 1 control) with soft bounds $|x| \le$
    /// `x_max`, $|u| \le$ `u_max` of weight `weight` (infinite bounds are off).
    pub fn new(tracking: TrackingCost, x_max: f64, u_max: f64, weight: f64) -> crate::Result<Self> {
        crate::error::ensure_data!(
            x_max > 0.0 && u_max > 0.0,
            "the soft bounds must be positive, got x_max = {x_max}, u_max = {u_max}"
        );
        crate::error::ensure_data!(
            weight.is_finite() && weight >= 0.0,
            "the bound weight must be finite and nonnegative, got {weight}"
        );
        crate::error::ensure_data!(
            tracking.n_residuals() == 5,
            "the tracking cost must have 4 states and 1 control"
        );
        Ok(Self {
            tracking,
            bounds: SoftBounds {
                x_max,
                u_max,
                sqrt_weight: weight.sqrt(),
            },
            support: None,
        })
    }

    /// Adds the penalty on leaving the data ([`DataSupport::residual`]) at
    /// every stage but the terminal one (an eighth residual, 0 without it).
    pub fn with_support(mut self, support: Option<Arc<DataSupport>>) -> Self {
        self.support = support.filter(|s| s.is_active());
        self
    }
}

impl StageCost for SwingupCost {
    fn n_residuals(&self) -> usize {
        7 + usize::from(self.support.is_some())
    }

    fn residuals(&self, k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
        self.tracking.residuals(k, x, u, &mut r[..5])?;
        self.bounds.residuals(x, u, &mut r[5..7]);
        if let Some(s) = &self.support {
            r[7] = u.map_or(0.0, |u| s.residual(&[x[0], x[1], x[2], x[3], u[0]], None));
        }
        Ok(())
    }

    fn jacobians(&self, k: usize, x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> ModelResult<()> {
        // rows of 4 state columns and 1 control column
        self.tracking.jacobians(k, x, u, &mut jx[..20], &mut ju[..5])?;
        jx[28..].fill(0.0);
        ju[7..].fill(0.0);
        self.bounds.jacobians(x, u, &mut jx[20..28], &mut ju[5..7]);
        if let (Some(u), Some(s)) = (u, &self.support) {
            let mut g = [0.0; 5];
            s.residual(&[x[0], x[1], x[2], x[3], u[0]], Some(&mut g));
            jx[28..32].copy_from_slice(&g[..4]);
            ju[7] = g[4];
        }
        Ok(())
    }

    fn jacobian_structure(&self, jx: &mut [bool], ju: &mut [bool]) {
        self.tracking.jacobian_structure(&mut jx[..20], &mut ju[..5]);
        jx[28..].fill(false);
        ju[7..].fill(false);
        SoftBounds::jacobian_structure(&mut jx[20..28], &mut ju[5..7]);
        if self.support.is_some() {
            jx[28..32].fill(true);
            ju[7] = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    fn cost() -> SwingupCost {
        let tracking = TrackingCost::new(
            Mat::zeros(3, 4),
            Mat::zeros(2, 1),
            &[1.0, 2.0, 3.0, 4.0],
            &[0.5],
            &[10.0; 4],
        )
        .expect("valid");
        SwingupCost::new(tracking, 0.7, 12.0, 100.0).expect("valid")
    }

    /// Inside the bounds the cost is Eq. 5; outside, the hinge squared.
    #[test]
    fn penalises_only_outside_the_bounds() {
        let c = cost();
        let mut r = [0.0; 7];
        c.residuals(0, &[0.1, 0.2, 0.5, 0.4], Some(&[3.0]), &mut r).expect("ok");
        assert_eq!(&r[5..], &[0.0, 0.0]);
        c.residuals(0, &[0.1, 0.2, -0.9, 0.4], Some(&[-13.0]), &mut r)
            .expect("ok");
        assert!((r[5] - 10.0 * 0.2).abs() < 1e-12 && (r[6] - 10.0).abs() < 1e-12);
        assert!((r[2] - 3f64.sqrt() * -0.9).abs() < 1e-12);
    }

    /// The Jacobians match central differences away from the kinks.
    #[test]
    fn jacobians_match_differences() {
        let c = cost();
        for (x, u) in [
            ([0.3, -1.0, 0.9, 0.2], 14.0),
            ([0.3, -1.0, -0.8, 0.2], -12.5),
            ([0.3, 1.0, 0.1, 0.2], 1.0),
        ] {
            let worst = trajopt::check_stage_cost_jacobians(&c, 1, &x, &[u], false).expect("check");
            assert!(worst.max_rel_error < 1e-6, "{worst:?}");
            let (mut jx, mut ju) = ([0.0; 28], [0.0; 7]);
            c.jacobians(1, &x, Some(&[u]), &mut jx, &mut ju).expect("ok");
            let (mut sx, mut su) = ([false; 28], [false; 7]);
            c.jacobian_structure(&mut sx, &mut su);
            assert!(jx.iter().zip(&sx).all(|(v, keep)| *keep || *v == 0.0));
            assert!(ju.iter().zip(&su).all(|(v, keep)| *keep || *v == 0.0));
        }
    }
}
