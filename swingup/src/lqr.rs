//! The balancing controller: a discrete LQR on the upright linearisation.
//!
//! The paper learned its balancing controller separately; here it is
//! designed from the plant's parameters: $A, B$ are the Jacobians of one
//! 60 Hz sample at upright rest (central differences of [`Plant::step`]
//! without lag), and $K$ solves the discrete algebraic Riccati equation
//! $P = Q + A^\top P A - A^\top P B (R + B^\top P B)^{-1} B^\top P A$ by
//! fixed-point iteration; the control is $u = -K (s - s_{\text{up}})$ with
//! the angle measured from upright.

use crate::plant::{Plant, PlantParams, PlantState, from_upright};

/// A state-feedback balancing controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lqr {
    /// Gain $K$ on $(\theta - \pi, \dot\theta, x, \dot x)$.
    pub gain: [f64; 4],
}

impl Lqr {
    /// The LQR for `params` with weights $Q = \mathrm{diag}(q)$, $R = r$.
    /// `None` if the Riccati iteration does not converge.
    pub fn design(params: &PlantParams, q: [f64; 4], r: f64) -> Option<Self> {
        let plant = Plant::new(PlantParams { lag: 0.0, ..*params });
        let up = [std::f64::consts::PI, 0.0, 0.0, 0.0];
        let h = 1e-6;
        let mut a = [[0.0; 4]; 4];
        let mut b = [0.0; 4];
        for c in 0..5 {
            let (mut sp, mut sm, mut up_u, mut um_u) = (up, up, 0.0, 0.0);
            if c < 4 {
                sp[c] += h;
                sm[c] -= h;
            } else {
                up_u = h;
                um_u = -h;
            }
            let fp = plant.step(&PlantState { s: sp, a: 0.0 }, up_u).s;
            let fm = plant.step(&PlantState { s: sm, a: 0.0 }, um_u).s;
            for i in 0..4 {
                let d = (fp[i] - fm[i]) / (2.0 * h);
                if c < 4 {
                    a[i][c] = d;
                } else {
                    b[i] = d;
                }
            }
        }
        // value iteration on the Riccati difference equation, symmetrised,
        // until P stops changing
        let mut p = [[0.0; 4]; 4];
        for i in 0..4 {
            p[i][i] = q[i];
        }
        for _ in 0..200_000 {
            let pb: [f64; 4] = std::array::from_fn(|i| (0..4).map(|j| p[i][j] * b[j]).sum());
            let s = r + (0..4).map(|i| b[i] * pb[i]).sum::<f64>();
            // K = (R + B'PB)^-1 B'PA
            let k: [f64; 4] = std::array::from_fn(|c| (0..4).map(|i| pb[i] * a[i][c]).sum::<f64>() / s);
            // P' = Q + A'PA - K' s K
            let pa: [[f64; 4]; 4] =
                std::array::from_fn(|i| std::array::from_fn(|c| (0..4).map(|j| p[i][j] * a[j][c]).sum()));
            let mut next = [[0.0; 4]; 4];
            let mut change: f64 = 0.0;
            let mut size: f64 = 0.0;
            for i in 0..4 {
                for c in 0..4 {
                    let v = (0..4).map(|j| a[j][i] * pa[j][c]).sum::<f64>() - k[i] * s * k[c]
                        + if i == c { q[i] } else { 0.0 };
                    next[i][c] = v;
                }
            }
            for i in 0..4 {
                for c in 0..4 {
                    let v = 0.5 * (next[i][c] + next[c][i]);
                    change = change.max((v - p[i][c]).abs());
                    size = size.max(v.abs());
                    p[i][c] = v;
                }
            }
            if !size.is_finite() {
                return None;
            }
            if change <= 1e-13 * size {
                return k.iter().all(|g| g.is_finite()).then_some(Self { gain: k });
            }
        }
        None
    }

    /// The command for state `s`.
    pub fn control(&self, s: &[f64; 4]) -> f64 {
        let e = [from_upright(s[0]), s[1], s[2], s[3]];
        -(0..4).map(|i| self.gain[i] * e[i]).sum::<f64>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn balances_both_plants_from_a_nudge() {
        for params in [PlantParams::human(), PlantParams::robot()] {
            let lqr = Lqr::design(&params, [10.0, 1.0, 1.0, 1.0], 0.1).expect("converges");
            let plant = Plant::new(params);
            let mut st = PlantState {
                s: [std::f64::consts::PI + 0.15, 0.5, 0.1, 0.0],
                a: 0.0,
            };
            for _ in 0..600 {
                st = plant.step(&st, lqr.control(&st.s));
            }
            assert!(from_upright(st.s[0]).abs() < 1e-3, "{params:?}: {:?}", st.s);
            assert!(st.s[2].abs() < 0.05);
        }
    }
}
