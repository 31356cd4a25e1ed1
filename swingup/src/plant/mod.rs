//! The plant: a pendulum whose pivot, the hand, moves horizontally.
//!
//! State $s = (\theta, \dot\theta, x, \dot x)$, $\theta = 0$ hanging down and
//! $\pi$ upright, $x$ the hand position; the control $u$ is the commanded
//! hand acceleration, held constant over each 60 Hz sample (zero-order
//! hold). With the actual hand acceleration $a$ and a point mass at
//! length $l$,
//! $$\ddot\theta = -\frac{g}{l}\sin\theta - \frac{a}{l}\cos\theta - b\,\dot\theta, \qquad \ddot x = a .$$
//! A human hand does what it is told ($a = u$); a robot's lags its command,
//! $\dot a = (u - a) / \tau$. The equations are integrated by classic RK4
//! with `substeps` steps per sample.

pub mod basin;
pub mod demo;
pub mod lqr;

use serde::{Deserialize, Serialize};

/// Physical parameters of a plant; see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlantParams {
    /// Gravity $g$ (m/s²).
    pub gravity: f64,
    /// Pendulum length $l$ (m).
    pub length: f64,
    /// Viscous damping $b$ (1/s).
    pub damping: f64,
    /// Time constant $\tau$ (s) of the hand's response to its command; 0 for none.
    pub lag: f64,
    /// Sample period (s), 1/60 as in the paper.
    pub dt: f64,
    /// RK4 steps per sample.
    pub substeps: usize,
    /// Hand workspace $|x| \le$ `x_limit` (m).
    pub x_limit: f64,
    /// Actuator limit $|u| \le$ `u_limit` (m/s²); commands are clipped.
    pub u_limit: f64,
}

impl PlantParams {
    /// The "human" who demonstrates: $l = 0.5$ m, $b = 0.05$/s, no lag.
    pub fn human() -> Self {
        Self {
            gravity: 9.81,
            length: 0.5,
            damping: 0.05,
            lag: 0.0,
            dt: 1.0 / 60.0,
            substeps: 10,
            x_limit: 0.8,
            u_limit: 15.0,
        }
    }

    /// The robot that learns: a longer pendulum ($l = 0.6$ m) and more
    /// damping ($b = 0.2$/s); replaying the demonstration on it gets the
    /// pendulum to 87 degrees, short of halfway (the paper's claim C1). A
    /// hand lag (`lag`, e.g. 0.05 s) makes the mismatch larger; it is off by
    /// default.
    pub fn robot() -> Self {
        Self {
            length: 0.6,
            damping: 0.2,
            ..Self::human()
        }
    }

    /// Checks every field against its range:
    ///
    /// | field | range |
    /// |---|---|
    /// | `gravity` | (0, 1000] m/s² |
    /// | `length` | (0, 100] m |
    /// | `damping` | [0, 1000] 1/s |
    /// | `lag` | [0, 10] s |
    /// | `dt` | (0, 1] s |
    /// | `substeps` | 1 to [`MAX_SUBSTEPS`] |
    /// | `x_limit` | (0, 100] m |
    /// | `u_limit` | (0, 10⁴] m/s² |
    ///
    /// The upper bounds are far beyond any pendulum a hand swings; they
    /// keep the simulation's numbers finite.
    ///
    /// # Errors
    /// The first field out of its range, named (without the plant's
    /// table: the caller prefixes `human.` or `robot.`), with its value.
    pub fn validate(&self) -> Result<(), String> {
        let ranges = [
            ("gravity", self.gravity, false, 1e3),
            ("length", self.length, false, 1e2),
            ("damping", self.damping, true, 1e3),
            ("lag", self.lag, true, 10.0),
            ("dt", self.dt, false, 1.0),
            ("x_limit", self.x_limit, false, 1e2),
            ("u_limit", self.u_limit, false, 1e4),
        ];
        for (name, v, zero_ok, max) in ranges {
            let low_ok = if zero_ok { v >= 0.0 } else { v > 0.0 };
            if !(v.is_finite() && low_ok && v <= max) {
                let low = if zero_ok { "[0" } else { "(0" };
                return Err(format!("{name} must be in {low}, {max}], got {v}"));
            }
        }
        if !(1..=MAX_SUBSTEPS).contains(&self.substeps) {
            return Err(format!("substeps must be 1 to {MAX_SUBSTEPS}, got {}", self.substeps));
        }
        Ok(())
    }
}

/// The most RK4 steps per sample a plant may take ([`PlantParams::validate`]).
pub const MAX_SUBSTEPS: usize = 1_000;

/// [`PlantParams`] with every field optional: a `[human]` or `[robot]`
/// table of a configuration file that sets some fields, the others keeping
/// the plant's defaults ([`PlantPatch::over`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlantPatch {
    /// [`PlantParams::gravity`].
    pub gravity: Option<f64>,
    /// [`PlantParams::length`].
    pub length: Option<f64>,
    /// [`PlantParams::damping`].
    pub damping: Option<f64>,
    /// [`PlantParams::lag`].
    pub lag: Option<f64>,
    /// [`PlantParams::dt`].
    pub dt: Option<f64>,
    /// [`PlantParams::substeps`].
    pub substeps: Option<usize>,
    /// [`PlantParams::x_limit`].
    pub x_limit: Option<f64>,
    /// [`PlantParams::u_limit`].
    pub u_limit: Option<f64>,
}

impl PlantPatch {
    /// `base` with the fields this patch sets replaced.
    pub fn over(self, base: PlantParams) -> PlantParams {
        PlantParams {
            gravity: self.gravity.unwrap_or(base.gravity),
            length: self.length.unwrap_or(base.length),
            damping: self.damping.unwrap_or(base.damping),
            lag: self.lag.unwrap_or(base.lag),
            dt: self.dt.unwrap_or(base.dt),
            substeps: self.substeps.unwrap_or(base.substeps),
            x_limit: self.x_limit.unwrap_or(base.x_limit),
            u_limit: self.u_limit.unwrap_or(base.u_limit),
        }
    }
}

/// A plant's full state: the observable $(\theta, \dot\theta, x, \dot x)$ and
/// the actual hand acceleration $a$ (equal to the command without lag).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantState {
    /// $(\theta, \dot\theta, x, \dot x)$.
    pub s: [f64; 4],
    /// Actual hand acceleration $a$.
    pub a: f64,
}

impl PlantState {
    /// Hanging at rest with the hand at the origin.
    pub fn hanging() -> Self {
        Self { s: [0.0; 4], a: 0.0 }
    }
}

/// A simulated plant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plant {
    /// Its parameters.
    pub params: PlantParams,
}

impl Plant {
    /// A plant with the given parameters.
    pub fn new(params: PlantParams) -> Self {
        Self { params }
    }

    /// Time derivative of $(\theta, \dot\theta, x, \dot x, a)$ under command `u`.
    fn deriv(&self, z: &[f64; 5], u: f64) -> [f64; 5] {
        let p = &self.params;
        let a = if p.lag > 0.0 { z[4] } else { u };
        let theta_dd = -(p.gravity / p.length) * z[0].sin() - (a / p.length) * z[0].cos() - p.damping * z[1];
        let a_dot = if p.lag > 0.0 { (u - z[4]) / p.lag } else { 0.0 };
        [z[1], theta_dd, z[3], a, a_dot]
    }

    /// One sample: RK4 substeps under the command `u` (clipped to the
    /// actuator limit), returning the next state.
    pub fn step(&self, state: &PlantState, u: f64) -> PlantState {
        let p = &self.params;
        let u = u.clamp(-p.u_limit, p.u_limit);
        let h = p.dt / p.substeps as f64;
        let mut z = [
            state.s[0],
            state.s[1],
            state.s[2],
            state.s[3],
            if p.lag > 0.0 { state.a } else { u },
        ];
        for _ in 0..p.substeps {
            let k1 = self.deriv(&z, u);
            let k2 = self.deriv(&add(&z, &k1, h / 2.0), u);
            let k3 = self.deriv(&add(&z, &k2, h / 2.0), u);
            let k4 = self.deriv(&add(&z, &k3, h), u);
            for i in 0..5 {
                z[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        PlantState {
            s: [z[0], z[1], z[2], z[3]],
            a: if p.lag > 0.0 { z[4] } else { u },
        }
    }

    /// Total energy per unit mass of the pendulum relative to hanging at rest,
    /// $E = \tfrac12 l^2 \dot\theta^2 + g l (1 - \cos\theta)$ (exact for a fixed hand).
    pub fn energy(&self, s: &[f64; 4]) -> f64 {
        let p = &self.params;
        0.5 * p.length * p.length * s[1] * s[1] + p.gravity * p.length * (1.0 - s[0].cos())
    }
}

fn add(z: &[f64; 5], k: &[f64; 5], h: f64) -> [f64; 5] {
    std::array::from_fn(|i| z[i] + h * k[i])
}

/// $\theta - \pi$ wrapped into $(-\pi, \pi]$: the angle from upright.
pub fn from_upright(theta: f64) -> f64 {
    let d = (theta - std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI);
    if d > std::f64::consts::PI {
        d - 2.0 * std::f64::consts::PI
    } else {
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn energy_is_conserved_without_damping_or_hand_motion() {
        let plant = Plant::new(PlantParams {
            damping: 0.0,
            ..PlantParams::human()
        });
        let mut st = PlantState {
            s: [2.5, 0.0, 0.0, 0.0],
            a: 0.0,
        };
        let e0 = plant.energy(&st.s);
        for _ in 0..600 {
            st = plant.step(&st, 0.0);
        }
        let drift = (plant.energy(&st.s) - e0).abs() / e0;
        assert!(drift < 1e-8, "relative energy drift over 10 s: {drift}");
    }

    #[test]
    fn small_angle_period() {
        let params = PlantParams {
            damping: 0.0,
            ..PlantParams::human()
        };
        let plant = Plant::new(params);
        let mut st = PlantState {
            s: [1e-3, 0.0, 0.0, 0.0],
            a: 0.0,
        };
        // time of the first upward zero crossing of theta_dot after a full period
        let mut crossings = Vec::new();
        let mut prev = st.s[0];
        for k in 1..2000 {
            st = plant.step(&st, 0.0);
            if prev > 0.0 && st.s[0] <= 0.0 {
                // linear interpolation of the downward zero crossing
                let t = (k as f64 - 1.0 + prev / (prev - st.s[0])) * params.dt;
                crossings.push(t);
            }
            prev = st.s[0];
        }
        let period = crossings[1] - crossings[0];
        let expected = 2.0 * std::f64::consts::PI * (params.length / params.gravity).sqrt();
        assert!((period - expected).abs() < 1e-4, "{period} vs {expected}");
    }

    #[test]
    fn lag_filters_the_command() {
        let plant = Plant::new(PlantParams {
            lag: 0.05,
            ..PlantParams::robot()
        });
        let mut st = PlantState::hanging();
        st = plant.step(&st, 10.0);
        // after one sample of 1/60 s with tau = 0.05 s: a = 10 (1 - e^{-1/3})
        let expected = 10.0 * (1.0 - (-1.0f64 / 3.0).exp());
        assert!((st.a - expected).abs() < 1e-6, "{} vs {expected}", st.a);
        // commands are clipped to the actuator limit
        let human = Plant::new(PlantParams::human());
        let s2 = human.step(&PlantState::hanging(), 100.0);
        assert_eq!(s2.a, 15.0);
    }

    #[test]
    fn angle_from_upright_wraps() {
        assert!((from_upright(std::f64::consts::PI)).abs() < 1e-15);
        assert!((from_upright(3.0 * std::f64::consts::PI + 0.1) - 0.1).abs() < 1e-12);
        assert!((from_upright(-std::f64::consts::PI - 0.1) + 0.1).abs() < 1e-12);
        assert!((from_upright(0.0).abs() - std::f64::consts::PI).abs() < 1e-12);
    }
}
