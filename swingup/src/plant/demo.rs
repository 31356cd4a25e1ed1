//! The demonstration: a swing-up performed by the "human" plant.
//!
//! The human is modelled by an energy-pumping controller (Åström and
//! Furuta, 2000): with the pendulum's energy relative to hanging at rest,
//! $E = \tfrac12 l^2 \dot\theta^2 + g l (1 - \cos\theta)$, and
//! $\dot E = -a\, l\, \dot\theta \cos\theta - b\, l^2 \dot\theta^2$, the hand
//! accelerates with
//! $a = -k_E (E_{\text{up}} - E)\tanh(\dot\theta\cos\theta / \epsilon) - k_x x - k_v \dot x$,
//! which pumps energy in until the pendulum reaches upright while keeping the
//! hand near the origin, after an initial push; near upright an LQR catches
//! it. The demonstration is the swing-up window (the first `horizon`
//! samples at 60 Hz) as the robot would record it.

use serde::{Deserialize, Serialize};

use crate::plant::lqr::Lqr;
use crate::plant::{Plant, PlantParams, PlantState, from_upright};

/// A recorded demonstration: states at $t_0, \dots, t_N$, commands at
/// $t_0, \dots, t_{N-1}$.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Demonstration {
    /// Sample period (s).
    pub dt: f64,
    /// $(\theta, \dot\theta, x, \dot x)$ at each sample, $N + 1$ of them.
    pub states: Vec<[f64; 4]>,
    /// Hand acceleration commands, $N$ of them.
    pub controls: Vec<f64>,
}

impl Demonstration {
    /// Number of steps $N$.
    pub fn horizon(&self) -> usize {
        self.controls.len()
    }

    /// The sample times $k\,\Delta t$, $k = 0, \dots, N$.
    pub fn times(&self) -> Vec<f64> {
        (0..=self.horizon()).map(|k| k as f64 * self.dt).collect()
    }
}

/// Parameters of the human's energy-pumping swing-up.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HumanSwingup {
    /// Energy gain $k_E$ (1/(m s)).
    pub energy_gain: f64,
    /// Hand centring gains $k_x$, $k_v$.
    #[serde(deserialize_with = "crate::format::exact_array")]
    pub centring: [f64; 2],
    /// Smoothing $\epsilon$ of the sign (rad/s).
    pub smoothing: f64,
    /// Initial push: this acceleration (m/s²) for `push_samples` samples.
    pub push: f64,
    /// Length of the initial push in samples.
    pub push_samples: usize,
    /// Largest command the human uses (m/s²).
    pub max_command: f64,
}

impl Default for HumanSwingup {
    fn default() -> Self {
        Self {
            energy_gain: 2.0,
            centring: [40.0, 5.0],
            smoothing: 0.2,
            push: 8.0,
            push_samples: 12,
            max_command: 12.0,
        }
    }
}

/// Whether the catch condition holds: $|\theta - \pi| <$ `angle` and $|\dot\theta| <$ `rate`.
pub fn near_upright(s: &[f64; 4], angle: f64, rate: f64) -> bool {
    from_upright(s[0]).abs() < angle && s[1].abs() < rate
}

/// The human's demonstration on plant `human` with strategy `strategy`:
/// `horizon` samples of swing-up (the run's balancing part, `balance`
/// samples, is simulated to check the catch and then dropped).
///
/// # Errors
/// [`Error::Controller`](crate::Error::Controller) when no LQR catch can be
/// designed for the human's plant.
pub fn demonstration(
    human: &PlantParams,
    strategy: &HumanSwingup,
    horizon: usize,
    balance: usize,
) -> crate::Result<Demonstration> {
    demonstrate(human, strategy, horizon, balance)
        .map(|(demo, _)| demo)
        .ok_or(crate::Error::Controller { plant: "human" })
}

/// Runs the human on `params` for `horizon` samples of swing-up (the
/// demonstration) followed by `balance` samples with the catch; returns the
/// demonstration and the whole run's states (to check that it succeeded).
pub fn demonstrate(
    params: &PlantParams,
    human: &HumanSwingup,
    horizon: usize,
    balance: usize,
) -> Option<(Demonstration, Vec<[f64; 4]>)> {
    let plant = Plant::new(*params);
    let lqr = Lqr::design(params, [10.0, 1.0, 1.0, 1.0], 0.1)?;
    let e_up = 2.0 * params.gravity * params.length;
    let mut st = PlantState::hanging();
    let mut states = vec![st.s];
    let mut controls = Vec::new();
    let mut caught = false;
    for k in 0..horizon + balance {
        let s = st.s;
        caught = caught || near_upright(&s, 0.3, 2.0);
        let u = if caught {
            lqr.control(&s)
        } else if k < human.push_samples {
            human.push
        } else {
            let e = plant.energy(&s);
            let pump = -human.energy_gain * (e_up - e) * (s[1] * s[0].cos() / human.smoothing).tanh();
            pump - human.centring[0] * s[2] - human.centring[1] * s[3]
        };
        let u = u.clamp(-human.max_command, human.max_command);
        st = plant.step(&st, u);
        if k < horizon {
            controls.push(u);
        }
        states.push(st.s);
    }
    let demo = Demonstration {
        dt: params.dt,
        states: states[..=horizon].to_vec(),
        controls,
    };
    Some((demo, states))
}

/// The imitation trial's regression data, noiseless: the default robot
/// replaying the default demonstration's commands (150 samples) from rest,
/// each sample's $(\theta, \dot\theta, x, \dot x, u)$ and its change of
/// angular velocity.
#[cfg(test)]
pub(crate) fn imitation_data() -> (Vec<[f64; 5]>, Vec<[f64; 1]>) {
    let (demo, _) = demonstrate(&PlantParams::human(), &HumanSwingup::default(), 150, 0).expect("demo");
    let robot = Plant::new(PlantParams::robot());
    let mut st = PlantState::hanging();
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    for &u in &demo.controls {
        let next = robot.step(&st, u);
        xs.push([st.s[0], st.s[1], st.s[2], st.s[3], u]);
        ys.push([next.s[1] - st.s[1]]);
        st = next;
    }
    (xs, ys)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_human_swings_up_and_balances_within_the_workspace() {
        let params = PlantParams::human();
        let (demo, run) = demonstrate(&params, &HumanSwingup::default(), 150, 180).expect("lqr");
        assert_eq!(demo.states.len(), 151);
        assert_eq!(demo.controls.len(), 150);
        // upright at the end of the window and for the whole balancing phase
        let last = &run[run.len() - 120..];
        assert!(
            last.iter().all(|s| from_upright(s[0]).abs() < 0.2),
            "not balanced: {:?}",
            run.last()
        );
        assert!(
            run.iter().all(|s| s[2].abs() <= params.x_limit),
            "hand left the workspace"
        );
        assert!(
            near_upright(&demo.states[150], 0.3, 2.0),
            "not caught within the window: {:?}",
            demo.states[150]
        );
    }
}
