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
    /// The Riccati matrix $P$ (row-major): the cost to go of the linearised
    /// closed loop from $e$ is $e^\top P e$, the level sets of which
    /// [`crate::plant::basin`] calibrates as the catch.
    pub riccati: [[f64; 4]; 4],
}

impl Lqr {
    /// The balancing controller every run uses (and the human's catch):
    /// weights (10, 1, 1, 1) on the state, 0.1 on the command, for the
    /// plant `params` (named `plant` in the error).
    ///
    /// # Errors
    /// [`Error::Controller`](crate::Error::Controller) when the design fails.
    pub fn balancing(params: &PlantParams, plant: &'static str) -> crate::Result<Self> {
        Self::design(params, [10.0, 1.0, 1.0, 1.0], 0.1).ok_or(crate::Error::Controller { plant })
    }

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
        // value iteration on the Riccati difference equation until P stops changing
        let mut p = [[0.0; 4]; 4];
        for i in 0..4 {
            p[i][i] = q[i];
        }
        for _ in 0..200_000 {
            let (k, next) = riccati_step(&p, &a, &b, &q, r);
            let mut change: f64 = 0.0;
            let mut size: f64 = 0.0;
            for i in 0..4 {
                for c in 0..4 {
                    change = change.max((next[i][c] - p[i][c]).abs());
                    size = size.max(next[i][c].abs());
                }
            }
            p = next;
            if !size.is_finite() {
                return None;
            }
            if change <= 1e-13 * size {
                return k.iter().all(|g| g.is_finite()).then_some(Self { gain: k, riccati: p });
            }
        }
        None
    }

    /// The command for state `s`.
    pub fn control(&self, s: &[f64; 4]) -> f64 {
        let e = error(s);
        -(0..4).map(|i| self.gain[i] * e[i]).sum::<f64>()
    }

    /// The quadratic form $e^\top P e$ of the Riccati matrix at state `s`,
    /// $e = (\theta - \pi, \dot\theta, x, \dot x)$ with the angle from
    /// upright: the linearised closed loop's cost to go, which decreases
    /// along its trajectories.
    pub fn value(&self, s: &[f64; 4]) -> f64 {
        let e = error(s);
        (0..4)
            .map(|i| e[i] * (0..4).map(|c| self.riccati[i][c] * e[c]).sum::<f64>())
            .sum()
    }
}

/// The state's offset from upright at rest with the hand home.
fn error(s: &[f64; 4]) -> [f64; 4] {
    [from_upright(s[0]), s[1], s[2], s[3]]
}

/// One step of the Riccati difference equation: the gain
/// $K = (r + B^\top P B)^{-1} B^\top P A$ and the symmetrised
/// $P' = Q + A^\top P A - K^\top (r + B^\top P B) K$.
fn riccati_step(p: &[[f64; 4]; 4], a: &[[f64; 4]; 4], b: &[f64; 4], q: &[f64; 4], r: f64) -> ([f64; 4], [[f64; 4]; 4]) {
    let pb: [f64; 4] = std::array::from_fn(|i| (0..4).map(|j| p[i][j] * b[j]).sum());
    let s = r + (0..4).map(|i| b[i] * pb[i]).sum::<f64>();
    let k: [f64; 4] = std::array::from_fn(|c| (0..4).map(|i| pb[i] * a[i][c]).sum::<f64>() / s);
    let pa: [[f64; 4]; 4] = std::array::from_fn(|i| std::array::from_fn(|c| (0..4).map(|j| p[i][j] * a[j][c]).sum()));
    let raw: [[f64; 4]; 4] = std::array::from_fn(|i| {
        std::array::from_fn(|c| {
            (0..4).map(|j| a[j][i] * pa[j][c]).sum::<f64>() - k[i] * s * k[c] + if i == c { q[i] } else { 0.0 }
        })
    });
    // symmetrised
    let next = std::array::from_fn(|i| std::array::from_fn(|c| 0.5 * (raw[i][c] + raw[c][i])));
    (k, next)
}

/// Time-varying LQR gains along a planned trajectory (the paper's Eq. 2
/// local linear policy $u = u^*_k - K_k (x - x^*_k)$): the model's
/// Jacobians $A_k, B_k$ at $(x^*_k, u^*_k)$ and a backward Riccati pass with
/// $Q = \mathrm{diag}(q)$, $R = r$ and terminal weight $Q$. `None` if the
/// model fails or the pass is not finite.
pub fn tracking_gains(
    model: &impl trajopt::Dynamics,
    states: &[[f64; 4]],
    controls: &[f64],
    q: [f64; 4],
    r: f64,
) -> Option<Vec<[f64; 4]>> {
    let n = controls.len();
    if states.len() != n + 1 {
        return None;
    }
    let mut p = [[0.0; 4]; 4];
    for i in 0..4 {
        p[i][i] = q[i];
    }
    let mut gains = vec![[0.0; 4]; n];
    let (mut fx, mut fu) = (vec![0.0; 16], vec![0.0; 4]);
    for k in (0..n).rev() {
        if !matches!(model.jacobians(&states[k], &[controls[k]], &mut fx, &mut fu), Ok(true)) {
            return None;
        }
        let a: [[f64; 4]; 4] = std::array::from_fn(|i| std::array::from_fn(|c| fx[i * 4 + c]));
        let b: [f64; 4] = std::array::from_fn(|i| fu[i]);
        let (g, next) = riccati_step(&p, &a, &b, &q, r);
        if !(g.iter().all(|v| v.is_finite()) && next.iter().flatten().all(|v| v.is_finite())) {
            return None;
        }
        gains[k] = g;
        p = next;
    }
    Some(gains)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Along a plan that sits upright, the time-varying gains far from the
    /// end are the infinite-horizon LQR's (the Riccati recursion converges),
    /// up to the model's trapezoid rule for the angle.
    #[test]
    fn tracking_gains_converge_to_the_stationary_lqr() {
        use crate::models::KnownHand;
        use crate::models::truth::TrueRegression;
        let params = PlantParams::robot();
        let (q, r) = ([10.0, 1.0, 1.0, 1.0], 0.1);
        let lqr = Lqr::design(&params, q, r).expect("converges");
        let model = KnownHand::new(TrueRegression::new(params).expect("valid"), params.dt);
        let n = 900;
        let up = [std::f64::consts::PI, 0.0, 0.0, 0.0];
        let gains = tracking_gains(&model, &vec![up; n + 1], &vec![0.0; n], q, r).expect("finite");
        for (i, (g, want)) in gains[0].iter().zip(&lqr.gain).enumerate() {
            assert!(
                (g - want).abs() < 0.02 * want.abs().max(1.0),
                "gain {i}: {g} vs the stationary {want}"
            );
        }
        // the last step's gain only sees the terminal weight: it differs
        assert!((gains[n - 1][0] - lqr.gain[0]).abs() > 1e-3);
        // a plan of the wrong length is refused
        assert!(tracking_gains(&model, &vec![up; n], &vec![0.0; n], q, r).is_none());
    }

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
