//! The swing-up instances' data: time step, systems, weights, horizons and
//! consistency weights.

use std::f64::consts::PI;

use crate::{Accelerations, Acrobot, CartPole, Mechanics, Pendulum};

/// Time step of the swing-up benchmarks (s).
pub const DT: f64 = 0.01;

/// The consistency weights $\lambda$ of the Eq. 3 registry
/// (`trajopt::problems::trajectory`).
pub const STANDARD_LAMBDAS: [f64; 2] = [1.0, 100.0];

/// The three swing-up systems; see the [crate docs](crate).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum System {
    /// The torque-driven [`Pendulum`].
    Pendulum,
    /// The force-driven [`CartPole`].
    CartPole,
    /// The elbow-driven [`Acrobot`].
    Acrobot,
}

/// The weights and target of a swing-up's quadratic cost (no $\tfrac12$),
/// and its start; see the [crate docs](crate).
#[derive(Debug, Clone, PartialEq)]
pub struct SwingUpWeights {
    /// Running state weights $q$ (diagonal).
    pub state: Vec<f64>,
    /// Running control weights $r$ (diagonal).
    pub control: Vec<f64>,
    /// Terminal state weights $q^f$ (diagonal).
    pub terminal: Vec<f64>,
    /// The target state $x^r$ (running and terminal).
    pub target: Vec<f64>,
    /// The initial state $x_0$.
    pub initial_state: Vec<f64>,
}

impl System {
    /// The three, in the order of the registries.
    pub const ALL: [System; 3] = [System::Pendulum, System::CartPole, System::Acrobot];

    /// The name used in instance names: `"pendulum"`, `"cartpole"`, `"acrobot"`.
    pub fn name(self) -> &'static str {
        match self {
            System::Pendulum => "pendulum",
            System::CartPole => "cartpole",
            System::Acrobot => "acrobot",
        }
    }

    /// The model with its default parameters at $\Delta t$ = [`DT`].
    pub fn model(self) -> SwingUpModel {
        match self {
            System::Pendulum => SwingUpModel::Pendulum(Pendulum {
                dt: DT,
                ..Pendulum::default()
            }),
            System::CartPole => SwingUpModel::CartPole(CartPole {
                dt: DT,
                ..CartPole::default()
            }),
            System::Acrobot => SwingUpModel::Acrobot(Acrobot {
                dt: DT,
                ..Acrobot::default()
            }),
        }
    }

    /// The cost weights, target and start of the swing-up: $q_i =
    /// \tfrac12 \Delta t$ on positions and $0.05 \Delta t$ on rates,
    /// $r = 0.005 \Delta t$, $q^f_i$ 50 on positions and 5 on rates, from
    /// rest hanging down to upright.
    pub fn weights(self) -> SwingUpWeights {
        let (nq, target) = match self {
            System::Pendulum => (1, vec![PI, 0.0]),
            System::CartPole => (2, vec![0.0, PI, 0.0, 0.0]),
            System::Acrobot => (2, vec![PI, 0.0, 0.0, 0.0]),
        };
        let per = |pos: f64, rate: f64| [vec![pos; nq], vec![rate; nq]].concat();
        SwingUpWeights {
            state: per(0.5 * DT, 0.05 * DT),
            control: vec![0.005 * DT],
            terminal: per(50.0, 5.0),
            initial_state: vec![0.0; 2 * nq],
            target,
        }
    }

    /// The horizons of the registries' instances (steps of [`DT`]).
    pub fn standard_horizons(self) -> &'static [usize] {
        match self {
            System::Pendulum => &[50, 100, 200],
            System::CartPole => &[100, 200, 400],
            System::Acrobot => &[200, 400],
        }
    }

    /// `"<system>-h<horizon>"`, e.g. `"pendulum-h100"`: the name of the
    /// system's swing-up over `horizon` steps (see [`find_instance`]).
    pub fn instance_name(self, horizon: usize) -> String {
        format!("{}-h{horizon}", self.name())
    }
}

/// One of the three models, so that every instance has the same type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SwingUpModel {
    /// A [`Pendulum`].
    Pendulum(Pendulum),
    /// A [`CartPole`].
    CartPole(CartPole),
    /// An [`Acrobot`].
    Acrobot(Acrobot),
}

/// Each method is the wrapped model's.
impl Mechanics for SwingUpModel {
    fn n_q(&self) -> usize {
        match self {
            SwingUpModel::Pendulum(p) => p.n_q(),
            SwingUpModel::CartPole(c) => c.n_q(),
            SwingUpModel::Acrobot(a) => a.n_q(),
        }
    }
    fn dt(&self) -> f64 {
        match self {
            SwingUpModel::Pendulum(p) => p.dt,
            SwingUpModel::CartPole(c) => c.dt,
            SwingUpModel::Acrobot(a) => a.dt,
        }
    }
    #[inline]
    fn accelerations(&self, x: &[f64], u: &[f64]) -> Accelerations {
        match self {
            SwingUpModel::Pendulum(p) => p.accelerations(x, u),
            SwingUpModel::CartPole(c) => c.accelerations(x, u),
            SwingUpModel::Acrobot(a) => a.accelerations(x, u),
        }
    }
}

/// The first of `instances` whose `name_of` is `name`; otherwise `Err` with
/// a message naming `name` and what names look like (`example`), for the
/// caller's own error type.
///
/// # Errors
/// The message, when no instance is named `name`.
pub fn find_instance<I>(
    instances: impl IntoIterator<Item = I>,
    name: &str,
    name_of: impl Fn(&I) -> String,
    example: &str,
) -> Result<I, String> {
    instances
        .into_iter()
        .find(|i| name_of(i) == name)
        .ok_or_else(|| format!("no standard instance is named {name:?} (names look like {example:?})"))
}

/// Defines, in the calling crate, `pub enum System { Pendulum, CartPole,
/// Acrobot }` mirroring [`System`] (its data methods delegate to it), so
/// that the crate can add its own inherent `problem` constructor.
#[macro_export]
macro_rules! system_enum {
    () => {
        /// The three swing-up systems (`nprl-systems`' `System`, which
        /// holds their data); see the [module docs](self).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum System {
            /// The torque-driven [`Pendulum`].
            Pendulum,
            /// The force-driven [`CartPole`].
            CartPole,
            /// The elbow-driven [`Acrobot`].
            Acrobot,
        }

        impl System {
            /// The three, in the order of the registry.
            pub const ALL: [System; 3] = [System::Pendulum, System::CartPole, System::Acrobot];

            /// The same system in `nprl-systems`.
            pub fn spec(self) -> $crate::System {
                match self {
                    System::Pendulum => $crate::System::Pendulum,
                    System::CartPole => $crate::System::CartPole,
                    System::Acrobot => $crate::System::Acrobot,
                }
            }

            /// The name used in instance names: `"pendulum"`, `"cartpole"`, `"acrobot"`.
            pub fn name(self) -> &'static str {
                self.spec().name()
            }

            /// The model with its default parameters at $\Delta t$ = [`DT`].
            pub fn model(self) -> SwingUpModel {
                self.spec().model()
            }

            /// The cost weights, target and start of the swing-up.
            pub fn weights(self) -> SwingUpWeights {
                self.spec().weights()
            }

            /// The horizons of the registry's instances (steps of [`DT`]).
            pub fn standard_horizons(self) -> &'static [usize] {
                self.spec().standard_horizons()
            }
        }
    };
}
