//! The balancing controller's region of attraction, measured by
//! simulation, and the catch rule built on it.
//!
//! The LQR of [`crate::plant::lqr`] balances the pendulum from states near
//! upright, but "near" is not a box: a pendulum 0.25 rad from upright and
//! still moving away from it at 1.9 rad/s falls, while one 1 rad away and
//! coming back at 5 rad/s is caught. Its region of attraction is close to a
//! level set of its own cost to go, $V(s) = e^\top P e$ ($P$ the Riccati
//! matrix, $e$ the offset from upright at rest with the hand home): $V$
//! decreases along the linearised closed loop's trajectories. The catch
//! [`CatchRule::Basin`] hands over to the LQR when $V(s) < c$, with the
//! level $c$ calibrated here:
//!
//! 1. **Samples.** `samples` states drawn uniformly (by volume) from the
//!    ellipsoid $V(s) \le V_\max$ (a uniform point $z$ of the 4-ball of
//!    radius $\sqrt{V_\max}$ mapped by $e = L^{-\top} z$, $P = L L^\top$),
//!    so that for every $c \le V_\max$ the samples with $V < c$ are uniform
//!    in the region the rule would catch.
//! 2. **Balanced?** Each is simulated on the robot ([`BalanceTest`]) as a
//!    run's balancing phase: the LQR on the noisy observed state (the
//!    run's sensor noise, one noise seed per sample), the command clipped
//!    to the actuator, the hand's actual acceleration starting at 0 when
//!    the plant lags, for `balance` samples. It is balanced when the hand
//!    stays inside its workspace and the last `success_seconds` stay within
//!    `success_angle` of upright: a trial's own success test.
//! 3. **Level.** $c$ is the largest sampled $V$ such that at least
//!    `coverage` (99 %) of the samples with $V$ at most $c$ are balanced
//!    (and at least [`MIN_INSIDE`] of them). $V_\max$ starts at
//!    `initial_level` and is quadrupled while $c$ comes out above half of
//!    it, so the samples always reach past the level.
//!
//! The calibration is deterministic (its own seed) and takes 1 to 2 s on
//! one core for the default 2000 samples (rayon spreads them).
//! `swingup basin` prints it with a map of the basin around upright.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::plant::lqr::Lqr;
use crate::plant::{Plant, PlantParams, PlantState, from_upright};

/// Fewest samples inside a calibrated level.
pub const MIN_INSIDE: usize = 50;

/// What "the LQR balances the pendulum from this state" means: a run's
/// balancing phase, judged by a trial's success test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BalanceTest {
    /// The robot.
    pub plant: PlantParams,
    /// Standard deviations of the sensor noise on $(\theta, \dot\theta, x, \dot x)$.
    pub sensor_noise: [f64; 4],
    /// Samples simulated from the start state.
    pub steps: usize,
    /// Balanced: the last `tail` samples within this angle of upright (rad).
    pub success_angle: f64,
    /// Samples at the end that must stay within `success_angle`.
    pub tail: usize,
}

impl BalanceTest {
    /// Whether `lqr`, started at `start` (the hand's acceleration at 0),
    /// keeps the hand inside its workspace and ends balanced, with the
    /// sensor noise drawn from `seed`.
    pub fn balances(&self, lqr: &Lqr, start: &[f64; 4], seed: u64) -> bool {
        let plant = Plant::new(self.plant);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let noise: Vec<Option<Normal<f64>>> = self
            .sensor_noise
            .iter()
            .map(|&s| if s > 0.0 { Normal::new(0.0, s).ok() } else { None })
            .collect();
        let mut st = PlantState { s: *start, a: 0.0 };
        if st.s[2].abs() > self.plant.x_limit {
            return false;
        }
        for k in 0..self.steps {
            let obs: [f64; 4] =
                std::array::from_fn(|i| st.s[i] + noise[i].as_ref().map_or(0.0, |n| n.sample(&mut rng)));
            let u = lqr.control(&obs).clamp(-self.plant.u_limit, self.plant.u_limit);
            st = plant.step(&st, u);
            if st.s[2].abs() > self.plant.x_limit || !st.s.iter().all(|v| v.is_finite()) {
                return false;
            }
            if k + self.tail >= self.steps && from_upright(st.s[0]).abs() >= self.success_angle {
                return false;
            }
        }
        true
    }
}

/// How the calibration samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BasinSettings {
    /// States simulated per round.
    pub samples: usize,
    /// Fraction of the samples inside the level that must be balanced.
    pub coverage: f64,
    /// $V_\max$ of the first round.
    pub initial_level: f64,
    /// Seed of the samples and their sensor noise.
    pub seed: u64,
}

impl Default for BasinSettings {
    fn default() -> Self {
        Self {
            samples: 2000,
            coverage: 0.99,
            initial_level: 64.0,
            seed: 20_261_205,
        }
    }
}

/// One simulated state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BasinSample {
    /// $(\theta, \dot\theta, x, \dot x)$.
    pub state: [f64; 4],
    /// $V$ there.
    pub value: f64,
    /// Whether the LQR balanced it.
    pub balanced: bool,
}

/// A calibrated level and the samples of its last round.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Basin {
    /// The level $c$: catch when $V(s) < c$.
    pub level: f64,
    /// $V_\max$ of the last round.
    pub sampled_to: f64,
    /// Samples of the last round with $V$ below the level.
    pub inside: usize,
    /// Of those, balanced.
    pub balanced_inside: usize,
    /// The last round's samples, in increasing $V$.
    pub samples: Vec<BasinSample>,
}

/// Why no level could be calibrated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BasinError {
    /// The settings are out of range.
    #[error("basin settings: {0}")]
    Settings(String),
    /// Fewer than [`MIN_INSIDE`] samples near upright were balanced often enough.
    #[error(
        "the balancing controller does not balance {coverage} of the states near upright \
         (of the {MIN_INSIDE} closest samples, {balanced} were balanced)"
    )]
    NoBasin {
        /// The coverage asked for.
        coverage: f64,
        /// Balanced among the closest samples.
        balanced: usize,
    },
}

/// Calibrates the level of [`CatchRule::Basin`] for `lqr` (see the
/// [module docs](self)).
///
/// # Errors
/// [`BasinError::Settings`] for fewer than [`MIN_INSIDE`] samples, a
/// coverage outside $(0, 1]$ or a non-positive initial level;
/// [`BasinError::NoBasin`] when the controller fails too often even next to
/// upright.
pub fn calibrate(lqr: &Lqr, test: &BalanceTest, settings: &BasinSettings) -> Result<Basin, BasinError> {
    if settings.samples < MIN_INSIDE {
        return Err(BasinError::Settings(format!(
            "samples must be at least {MIN_INSIDE}, got {}",
            settings.samples
        )));
    }
    if !(settings.coverage > 0.0 && settings.coverage <= 1.0) {
        return Err(BasinError::Settings(format!(
            "coverage must be in (0, 1], got {}",
            settings.coverage
        )));
    }
    if !(settings.initial_level.is_finite() && settings.initial_level > 0.0) {
        return Err(BasinError::Settings(format!(
            "initial_level must be finite and > 0, got {}",
            settings.initial_level
        )));
    }
    let Some(root) = cholesky(&lqr.riccati) else {
        return Err(BasinError::Settings(
            "the Riccati matrix is not positive definite".into(),
        ));
    };
    let mut top = settings.initial_level;
    let mut previous = None;
    for round in 0..24u64 {
        let seed = settings.seed.wrapping_add(round);
        let samples = sample(lqr, test, &root, top, settings.samples, seed);
        let (at, balanced) = level_index(&samples, settings.coverage);
        let Some(at) = at else {
            // the samples nearest upright already fail too often: at this
            // spread they are all far out, so the previous round stands
            return previous.ok_or(BasinError::NoBasin {
                coverage: settings.coverage,
                balanced,
            });
        };
        let level = samples[at].value;
        let balanced_inside = samples[..=at].iter().filter(|s| s.balanced).count();
        let basin = Basin {
            level,
            sampled_to: top,
            inside: at + 1,
            balanced_inside,
            samples,
        };
        if level <= 0.5 * top {
            return Ok(basin);
        }
        previous = Some(basin);
        top *= 4.0;
    }
    previous.ok_or(BasinError::NoBasin {
        coverage: settings.coverage,
        balanced: 0,
    })
}

/// `n` states uniform in the ellipsoid $V \le$ `top`, simulated, sorted by $V$.
fn sample(lqr: &Lqr, test: &BalanceTest, root: &[[f64; 4]; 4], top: f64, n: usize, seed: u64) -> Vec<BasinSample> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let up = [std::f64::consts::PI, 0.0, 0.0, 0.0];
    let points: Vec<([f64; 4], u64)> = (0..n)
        .map(|_| {
            // a uniform point of the 4-ball of radius sqrt(top)
            let g: [f64; 4] = std::array::from_fn(|_| StandardNormal.sample(&mut rng));
            let norm = g.iter().map(|v| v * v).sum::<f64>().sqrt().max(f64::MIN_POSITIVE);
            let radius = top.sqrt() * rng.random::<f64>().powf(0.25);
            let z: [f64; 4] = std::array::from_fn(|i| g[i] / norm * radius);
            let e = solve_upper(root, &z);
            (std::array::from_fn(|i| up[i] + e[i]), rng.random::<u64>())
        })
        .collect();
    let mut samples: Vec<BasinSample> = points
        .par_iter()
        .map(|(s, noise_seed)| BasinSample {
            state: *s,
            value: lqr.value(s),
            balanced: test.balances(lqr, s, *noise_seed),
        })
        .collect();
    samples.sort_by(|a, b| a.value.total_cmp(&b.value));
    samples
}

/// The index of the largest level (samples sorted by $V$) whose samples up
/// to it are balanced at least `coverage` of the time, with at least
/// [`MIN_INSIDE`] of them; and the number balanced among the first
/// [`MIN_INSIDE`].
fn level_index(samples: &[BasinSample], coverage: f64) -> (Option<usize>, usize) {
    let mut balanced = 0usize;
    let mut best = None;
    let mut first = 0;
    for (i, s) in samples.iter().enumerate() {
        balanced += usize::from(s.balanced);
        if i + 1 == MIN_INSIDE {
            first = balanced;
        }
        if i + 1 >= MIN_INSIDE && balanced as f64 >= coverage * (i + 1) as f64 {
            best = Some(i);
        }
    }
    (best, first)
}

/// Lower Cholesky factor $L$ of a symmetric positive definite 4 x 4
/// matrix, $P = L L^\top$; `None` if not positive definite.
fn cholesky(p: &[[f64; 4]; 4]) -> Option<[[f64; 4]; 4]> {
    let mut l = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..=i {
            let s = p[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            if i == j {
                if s.is_nan() || s <= 0.0 {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    Some(l)
}

/// Solves $L^\top e = z$ for lower-triangular $L$.
fn solve_upper(l: &[[f64; 4]; 4], z: &[f64; 4]) -> [f64; 4] {
    let mut e = [0.0; 4];
    for i in (0..4).rev() {
        let s = z[i] - (i + 1..4).map(|k| l[k][i] * e[k]).sum::<f64>();
        e[i] = s / l[i][i];
    }
    e
}

/// When the balancing controller takes over from the swing-up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CatchRule {
    /// Within `angle` of upright (rad) and below `rate` (rad/s): the
    /// historical box, which holds states the LQR cannot balance and
    /// misses states it can.
    Box {
        /// Largest angle from upright.
        angle: f64,
        /// Largest angular speed.
        rate: f64,
    },
    /// $V(s) < $ `level`, the controller's calibrated region of attraction.
    Basin {
        /// The level $c$.
        level: f64,
    },
}

/// The balancing controller and when it takes over.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Catch {
    /// The controller.
    pub lqr: Lqr,
    /// When it takes over.
    pub rule: CatchRule,
}

/// How the catch is chosen: plain settings, from the configuration
/// ([`Config::catch_spec`](crate::config::Config::catch_spec)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CatchSpec {
    /// [`CatchRule::Box`].
    Box {
        /// Largest angle from upright (rad).
        angle: f64,
        /// Largest angular speed (rad/s).
        rate: f64,
    },
    /// [`CatchRule::Basin`] at `level`, or calibrated by [`calibrate`] when
    /// `None`.
    Basin {
        /// The level $c$, if given.
        level: Option<f64>,
    },
}

/// The calibrated region of attraction of `lqr` in the balancing phase
/// `test` ([`calibrate`], its error as the crate's).
///
/// # Errors
/// [`Error::Data`](crate::Error::Data) naming why no level was found.
pub fn robot_basin(lqr: &Lqr, test: &BalanceTest, settings: &BasinSettings) -> crate::Result<Basin> {
    calibrate(lqr, test, settings)
        .map_err(|e| crate::Error::Data(format!("calibrating the catch (catch = \"basin\"): {e}")))
}

impl Catch {
    /// The robot's balancing controller ([`Lqr::balancing`]) and when it
    /// takes over (`spec`; a basin without a level is calibrated here on
    /// `test`, deterministically).
    ///
    /// # Errors
    /// [`Error::Controller`](crate::Error::Controller) when the design
    /// fails for `robot`; [`Error::Data`](crate::Error::Data) when no basin
    /// can be calibrated.
    pub fn design(robot: &PlantParams, spec: CatchSpec, test: &BalanceTest) -> crate::Result<Self> {
        let lqr = Lqr::balancing(robot, "robot")?;
        let rule = match spec {
            CatchSpec::Box { angle, rate } => CatchRule::Box { angle, rate },
            CatchSpec::Basin { level } => CatchRule::Basin {
                level: match level {
                    Some(level) => level,
                    None => robot_basin(&lqr, test, &BasinSettings::default())?.level,
                },
            },
        };
        Ok(Self { lqr, rule })
    }

    /// Whether the controller takes over at observed state `s`.
    pub fn holds(&self, s: &[f64; 4]) -> bool {
        match self.rule {
            CatchRule::Box { angle, rate } => from_upright(s[0]).abs() < angle && s[1].abs() < rate,
            CatchRule::Basin { level } => self.lqr.value(s) < level,
        }
    }

    /// The controller's command at observed state `s`.
    pub fn control(&self, s: &[f64; 4]) -> f64 {
        self.lqr.control(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setup() -> (Lqr, BalanceTest) {
        let robot = PlantParams::robot();
        let lqr = Lqr::design(&robot, [10.0, 1.0, 1.0, 1.0], 0.1).expect("lqr");
        let test = BalanceTest {
            plant: robot,
            sensor_noise: [0.005, 0.02, 0.002, 0.01],
            steps: 180,
            success_angle: 0.2,
            tail: 120,
        };
        (lqr, test)
    }

    /// The Cholesky factor and the triangular solve invert each other:
    /// $V(e) = \lVert z \rVert^2$ for $e = L^{-\top} z$.
    #[test]
    fn whitening_maps_the_ball_onto_the_level_sets() {
        let (lqr, _) = setup();
        let l = cholesky(&lqr.riccati).expect("positive definite");
        let z = [0.3, -1.2, 0.7, 2.0];
        let e = solve_upper(&l, &z);
        let s = [std::f64::consts::PI + e[0], e[1], e[2], e[3]];
        let want: f64 = z.iter().map(|v| v * v).sum();
        assert!(
            (lqr.value(&s) - want).abs() < 1e-9 * want,
            "{} against {want}",
            lqr.value(&s)
        );
        assert!(
            cholesky(&[
                [1.0, 2.0, 0.0, 0.0],
                [2.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 0.0, 0.0, 1.0]
            ])
            .is_none()
        );
    }

    /// The calibrated rule keeps its promise on fresh states: of states
    /// drawn anew (another seed) inside the level, at least 97 % are
    /// balanced (99 % asked, sampling error allowed), while the historical
    /// box holds states the controller cannot balance.
    #[test]
    fn states_inside_the_level_are_balanced() {
        let (lqr, test) = setup();
        let settings = BasinSettings {
            samples: 1000,
            ..BasinSettings::default()
        };
        let basin = calibrate(&lqr, &test, &settings).expect("basin");
        assert!(basin.level > 0.0 && basin.level <= basin.sampled_to);
        assert!(basin.balanced_inside as f64 >= 0.99 * basin.inside as f64);
        let root = cholesky(&lqr.riccati).expect("pd");
        let fresh = sample(&lqr, &test, &root, basin.level, 400, 99);
        let balanced = fresh.iter().filter(|s| s.balanced).count();
        assert!(
            balanced as f64 >= 0.97 * fresh.len() as f64,
            "{balanced} of {}",
            fresh.len()
        );
        // the box: near upright but moving away fast enough to fall
        let rule = Catch {
            lqr,
            rule: CatchRule::Box { angle: 0.3, rate: 2.0 },
        };
        let leaving = [std::f64::consts::PI + 0.28, 1.9, 0.0, 0.0];
        assert!(rule.holds(&leaving));
        let falls = (0..5).filter(|&seed| !test.balances(&lqr, &leaving, seed)).count();
        assert_eq!(
            falls,
            5,
            "the LQR balanced {leaving:?} on {} of 5 noise seeds",
            5 - falls
        );
        let basin_rule = Catch {
            lqr,
            rule: CatchRule::Basin { level: basin.level },
        };
        assert!(
            !basin_rule.holds(&leaving),
            "V = {} below {}",
            lqr.value(&leaving),
            basin.level
        );
        // while the same speed towards upright is balanced
        let coming = [std::f64::consts::PI + 0.28, -1.9, 0.0, 0.0];
        assert!((0..5).all(|seed| test.balances(&lqr, &coming, seed)));
    }

    /// Bad settings are refused with the field named.
    #[test]
    fn bad_settings_are_refused() {
        let (lqr, test) = setup();
        for (s, field) in [
            (
                BasinSettings {
                    samples: 3,
                    ..BasinSettings::default()
                },
                "samples",
            ),
            (
                BasinSettings {
                    coverage: 1.5,
                    ..BasinSettings::default()
                },
                "coverage",
            ),
            (
                BasinSettings {
                    initial_level: f64::NAN,
                    ..BasinSettings::default()
                },
                "initial_level",
            ),
        ] {
            let e = calibrate(&lqr, &test, &s).expect_err(field).to_string();
            assert!(e.contains(field), "{e}");
        }
    }
}
