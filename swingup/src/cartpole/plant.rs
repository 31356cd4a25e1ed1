//! PILCO's cart-pole, simulated: a uniform rod on a cart pushed by a
//! horizontal force, with viscous friction between cart and ground.
//!
//! State $s = [x, \dot x, \dot\theta, \theta]$ in PILCO's order (cart
//! position, cart velocity, angular velocity, angle; $\theta = 0$ hanging,
//! $\theta = \pi$ upright). With the rod's length $l$ and mass $m$, the
//! cart's mass $M$, friction $b$ and force $f$ (`dynamics_cp.m` of the PILCO
//! MATLAB package, derived in Deisenroth's thesis, appendix C):
//! $$\ddot x = \frac{2 m l \dot\theta^2 \sin\theta + 3 m g \sin\theta\cos\theta + 4 f - 4 b \dot x}{4 (M + m) - 3 m \cos^2\theta},$$
//! $$\ddot\theta = \frac{-3 m l \dot\theta^2 \sin\theta\cos\theta - 6 (M + m) g \sin\theta - 6 (f - b \dot x)\cos\theta}{4 l (M + m) - 3 m l \cos^2\theta}.$$
//! The 4/3 factors are the uniform rod's: its centre at $l/2$, its inertia
//! about the pivot $m l^2 / 3$; the energy is
//! $E = \tfrac12 (M + m)\dot x^2 + \tfrac16 m l^2 \dot\theta^2 + \tfrac12 m l (\dot x\dot\theta - g)\cos\theta$.
//!
//! The force is held for one control period (zero-order hold, as PILCO's
//! `zoh`), clipped to $\pm f_{max}$, and the ODE integrated by classical
//! Runge-Kutta with `substeps` steps per period (PILCO integrates with
//! `ode45`; with the default 20 substeps of 5 ms the two agree far below the
//! sensor noise). The measured state adds Gaussian noise of standard
//! deviation `sensor_noise` to each component (PILCO's `plant.noise`,
//! $0.01^2$ on the diagonal); the true state evolves noise-free.

use serde::{Deserialize, Serialize};
use trajopt::ModelResult;

/// Physical constants of the cart-pole and its actuator.
///
/// | name | default | source |
/// |---|---|---|
/// | `cart_mass` | 0.5 kg | `dynamics_cp.m`: `M = 0.5` |
/// | `pole_mass` | 0.5 kg | `dynamics_cp.m`: `m = 0.5` |
/// | `pole_length` | 0.5 m | `dynamics_cp.m`: `l = 0.5` (the ICML 2011 paper's text says 0.6 m) |
/// | `friction` | 0.1 N s/m | `dynamics_cp.m`: `b = 0.1` |
/// | `gravity` | 9.82 m/s² | `dynamics_cp.m`: `g = 9.82` |
/// | `max_force` | 10 N | `settings_cp.m`: `policy.maxU = 10` |
/// | `dt` | 0.1 s | `settings_cp.m`: `dt = 0.10` |
/// | `substeps` | 20 | RK4 steps per control period (ours) |
/// | `sensor_noise` | 0.01 | `settings_cp.m`: `plant.noise = diag(ones(1,4)*0.01.^2)` |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CartPoleParams {
    /// Cart mass $M$ \[kg\].
    pub cart_mass: f64,
    /// Pole (uniform rod) mass $m$ \[kg\].
    pub pole_mass: f64,
    /// Pole length $l$ \[m\] (pivot to tip).
    pub pole_length: f64,
    /// Viscous friction between cart and ground $b$ \[N s/m\].
    pub friction: f64,
    /// Gravity $g$ \[m/s²\].
    pub gravity: f64,
    /// Force limit $f_{max}$ \[N\]; commands are clipped to $\pm f_{max}$.
    pub max_force: f64,
    /// Control period \[s\] (zero-order hold).
    pub dt: f64,
    /// RK4 steps per control period.
    pub substeps: usize,
    /// Standard deviation of the additive sensor noise on each state.
    pub sensor_noise: f64,
}

impl Default for CartPoleParams {
    fn default() -> Self {
        Self {
            cart_mass: 0.5,
            pole_mass: 0.5,
            pole_length: 0.5,
            friction: 0.1,
            gravity: 9.82,
            max_force: 10.0,
            dt: 0.1,
            substeps: 20,
            sensor_noise: 0.01,
        }
    }
}

impl CartPoleParams {
    /// Checks every field.
    pub fn validate(&self) -> crate::Result<()> {
        crate::error::ensure_positive(
            "cartpole.plant.",
            &[
                ("cart_mass", self.cart_mass),
                ("pole_mass", self.pole_mass),
                ("pole_length", self.pole_length),
                ("gravity", self.gravity),
                ("max_force", self.max_force),
                ("dt", self.dt),
            ],
        )?;
        crate::error::ensure_nonnegative(
            "cartpole.plant.",
            &[("friction", self.friction), ("sensor_noise", self.sensor_noise)],
        )?;
        crate::error::ensure_config!(
            "cartpole.plant.substeps",
            self.substeps >= 1,
            "cartpole.plant.substeps must be at least 1"
        );
        Ok(())
    }

    /// The physics, [`systems::CartPole`] with a uniform rod and friction
    /// (its state order is $(x, \theta, \dot x, \dot\theta)$).
    pub fn physics(&self) -> systems::CartPole {
        systems::CartPole {
            cart_mass: self.cart_mass,
            pole_mass: self.pole_mass,
            length: self.pole_length,
            gravity: self.gravity,
            dt: self.dt,
            friction: self.friction,
            pole: systems::Pole::UniformRod,
        }
    }

    /// The angular frequency of small swings about hanging with the cart
    /// free and no friction, $\omega_0^2 = 6 g (M + m) / (l (4 M + m))$
    /// (from the linearised Lagrangian of a uniform rod on a free cart).
    pub fn hanging_frequency(&self) -> f64 {
        let (mc, mp, l, g) = (self.cart_mass, self.pole_mass, self.pole_length, self.gravity);
        (6.0 * g * (mc + mp) / (l * (4.0 * mc + mp))).sqrt()
    }
}

/// PILCO's cart-pole as a plant: the physics of [`systems::CartPole`]
/// (a uniform rod, friction) integrated by RK4 under zero-order hold in
/// PILCO's state order, the force clipped; see the [module docs](self).
#[derive(Debug, Clone, PartialEq)]
pub struct CartPolePlant {
    /// The physical constants.
    pub params: CartPoleParams,
    physics: systems::CartPole,
}

impl CartPolePlant {
    /// The plant with `params` (checked).
    pub fn new(params: CartPoleParams) -> crate::Result<Self> {
        params.validate()?;
        let physics = params.physics();
        Ok(Self { params, physics })
    }

    /// The force actually applied for command `u`: clipped to the limit
    /// (a non-finite command applies no force).
    pub fn clip(&self, u: f64) -> f64 {
        if u.is_finite() {
            u.clamp(-self.params.max_force, self.params.max_force)
        } else {
            0.0
        }
    }

    /// $\dot s$ at state `s` under force `f` (not clipped).
    pub fn derivative(&self, s: &[f64; 4], f: f64) -> [f64; 4] {
        let [_, v, w, th] = *s;
        let [acc, ang] = self.physics.acceleration(th, v, w, f);
        [v, acc, ang, w]
    }

    /// The mechanical energy of state `s` (zero hanging at rest is
    /// $-m g l / 2$).
    pub fn energy(&self, s: &[f64; 4]) -> f64 {
        self.physics.energy(&[s[0], s[3], s[1], s[2]])
    }

    /// One control period from `s` with command `u` (clipped, held).
    pub fn step(&self, s: &[f64; 4], u: f64) -> [f64; 4] {
        let f = self.clip(u);
        let h = self.params.dt / self.params.substeps as f64;
        let mut x = *s;
        for _ in 0..self.params.substeps {
            let add = |a: &[f64; 4], k: &[f64; 4], c: f64| -> [f64; 4] { std::array::from_fn(|i| a[i] + c * k[i]) };
            let k1 = self.derivative(&x, f);
            let k2 = self.derivative(&add(&x, &k1, 0.5 * h), f);
            let k3 = self.derivative(&add(&x, &k2, 0.5 * h), f);
            let k4 = self.derivative(&add(&x, &k3, h), f);
            x = std::array::from_fn(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        }
        x
    }

    /// The pole tip's position $(x + l\sin\theta, -l\cos\theta)$.
    pub fn tip(&self, s: &[f64; 4]) -> (f64, f64) {
        let l = self.params.pole_length;
        (s[0] + l * s[3].sin(), -l * s[3].cos())
    }

    /// The distance of the pole tip from the target, the tip upright above
    /// the origin, $(0, l)$ (PILCO's `loss_cp.m` target `[0 0 0 pi]`).
    pub fn tip_distance(&self, s: &[f64; 4]) -> f64 {
        let (tx, ty) = self.tip(s);
        tx.hypot(ty - self.params.pole_length)
    }
}

/// The true plant as a planning model (the reference the learned model is
/// measured against; Jacobians by central differences): one control
/// period, the force clipped.
impl trajopt::Dynamics for CartPolePlant {
    fn state_dim(&self) -> usize {
        4
    }

    fn control_dim(&self) -> usize {
        1
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        let s = [x[0], x[1], x[2], x[3]];
        next[..4].copy_from_slice(&CartPolePlant::step(self, &s, u[0]));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frictionless() -> CartPolePlant {
        CartPolePlant::new(CartPoleParams {
            friction: 0.0,
            ..CartPoleParams::default()
        })
        .expect("valid")
    }

    /// Without force and friction the energy is conserved over 10 s of
    /// large swings (RK4's drift is tiny), and it is not with friction.
    #[test]
    fn energy_is_conserved_without_force_and_friction() {
        let plant = frictionless();
        let mut s = [0.0, 0.3, 4.0, 2.5];
        let e0 = plant.energy(&s);
        for _ in 0..100 {
            s = plant.step(&s, 0.0);
        }
        assert!(
            (plant.energy(&s) - e0).abs() < 1e-6 * e0.abs().max(1.0),
            "{} vs {e0}",
            plant.energy(&s)
        );
        let damped = CartPolePlant::new(CartPoleParams::default()).expect("valid");
        let mut s = [0.0, 0.3, 4.0, 2.5];
        for _ in 0..100 {
            s = damped.step(&s, 0.0);
        }
        assert!(damped.energy(&s) < e0 - 1e-3);
    }

    /// The energy formula is consistent with the dynamics: its rate equals
    /// the power of the force minus friction's, $\dot E = (f - b\dot x)\dot x$.
    #[test]
    fn energy_rate_is_the_power_in() {
        let plant = CartPolePlant::new(CartPoleParams::default()).expect("valid");
        let s = [0.2, -0.7, 1.3, 0.9];
        let f = 3.0;
        let d = plant.derivative(&s, f);
        let h = 1e-6;
        let ep: [f64; 4] = std::array::from_fn(|i| s[i] + h * d[i]);
        let em: [f64; 4] = std::array::from_fn(|i| s[i] - h * d[i]);
        let rate = (plant.energy(&ep) - plant.energy(&em)) / (2.0 * h);
        let power = (f - plant.params.friction * s[1]) * s[1];
        assert!((rate - power).abs() < 1e-6, "{rate} vs {power}");
    }

    /// Small swings about hanging, the cart free, have the period of the
    /// linearised uniform rod on a free cart, $2\pi / \omega_0$.
    #[test]
    fn small_swing_period_matches_closed_form() {
        let plant = frictionless();
        let mut s = [0.0, 0.0, 0.0, 0.01];
        let mut crossings = Vec::new();
        let dt = plant.params.dt;
        for k in 0..400 {
            let next = plant.step(&s, 0.0);
            if s[3] > 0.0 && next[3] <= 0.0 {
                // linear interpolation of the downward zero crossing
                crossings.push((k as f64 + s[3] / (s[3] - next[3])) * dt);
            }
            s = next;
        }
        assert!(crossings.len() >= 5);
        let n = crossings.len() - 1;
        let period = (crossings[n] - crossings[0]) / n as f64;
        let expected = 2.0 * std::f64::consts::PI / plant.params.hanging_frequency();
        assert!((period - expected).abs() < 1e-3 * expected, "{period} vs {expected}");
        // the rod on a fixed pivot would swing slower: the free cart matters
        let fixed = 2.0 * std::f64::consts::PI / (1.5 * plant.params.gravity / plant.params.pole_length).sqrt();
        assert!((period - fixed).abs() > 1e-2);
    }

    /// Commands beyond the limit act as the limit.
    #[test]
    fn force_is_clipped() {
        let plant = CartPolePlant::new(CartPoleParams::default()).expect("valid");
        let s = [0.0, 0.0, 0.0, 0.3];
        assert_eq!(plant.step(&s, 50.0), plant.step(&s, 10.0));
        assert_eq!(plant.step(&s, -1e9), plant.step(&s, -10.0));
        assert_ne!(plant.step(&s, 5.0), plant.step(&s, 10.0));
        assert_eq!(plant.step(&s, f64::NAN), plant.step(&s, 0.0));
    }

    /// Upright at the origin the tip is on target; hanging it is $2l$ away.
    #[test]
    fn tip_distance_of_upright_and_hanging() {
        let plant = CartPolePlant::new(CartPoleParams::default()).expect("valid");
        assert!(plant.tip_distance(&[0.0, 0.0, 0.0, std::f64::consts::PI]) < 1e-12);
        assert!((plant.tip_distance(&[0.0; 4]) - 1.0).abs() < 1e-12);
    }

    /// Bad constants are refused.
    #[test]
    fn validate_refuses_bad_params() {
        for p in [
            CartPoleParams {
                pole_length: 0.0,
                ..CartPoleParams::default()
            },
            CartPoleParams {
                friction: -1.0,
                ..CartPoleParams::default()
            },
            CartPoleParams {
                substeps: 0,
                ..CartPoleParams::default()
            },
            CartPoleParams {
                dt: f64::NAN,
                ..CartPoleParams::default()
            },
        ] {
            assert!(CartPolePlant::new(p).is_err());
        }
    }
}
