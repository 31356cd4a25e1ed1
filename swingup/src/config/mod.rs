//! Everything a learning run depends on ([`Config`]): the plants, the
//! planner ([`PlannerConfig`]), the learned model ([`ModelConfig`]), with
//! their defaults and the checks of every key's range
//! ([`Config::validate`]). `swingup config` prints the defaults as TOML.
// issue 51: no panic on user input in the programs' paths
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use lwr::{Degree, Kernel};
use serde::{Deserialize, Serialize};

use crate::plant::basin::{BalanceTest, CatchSpec};
use crate::plant::demo::HumanSwingup;

mod checks;
use crate::plant::{PlantParams, PlantPatch};
pub use checks::{Workload, limits};

/// Everything a learning run depends on. `swingup config` prints the
/// defaults as TOML; `--config FILE` reads one (missing fields keep their
/// defaults).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// Seed of the sensor noise (each trial draws from `seed` and its index).
    pub seed: u64,
    /// Trials before giving up (the first one imitates).
    pub max_trials: usize,
    /// The human who demonstrates (a `[human]` table may set some fields;
    /// the others keep [`PlantParams::human`]'s).
    #[serde(deserialize_with = "human_plant")]
    pub human: PlantParams,
    /// The robot that learns (a `[robot]` table may set some fields; the
    /// others keep [`PlantParams::robot`]'s).
    #[serde(deserialize_with = "robot_plant")]
    pub robot: PlantParams,
    /// The human's swing-up strategy.
    pub human_swingup: HumanSwingup,
    /// Samples of the swing-up window (the demonstration and the plans).
    pub horizon: usize,
    /// Samples of balancing after the window.
    pub balance: usize,
    /// Standard deviations of the robot's sensor noise on $(\theta, \dot\theta, x, \dot x)$.
    #[serde(deserialize_with = "crate::format::exact_array")]
    pub sensor_noise: [f64; 4],
    /// Gains $(k_p, k_d)$ of the robot's hand servo, which adds
    /// $k_p (x^{plan} - x) + k_d (\dot x^{plan} - \dot x)$ to the planned
    /// acceleration so that the hand follows the planned hand trajectory
    /// (as a robot arm's own servo would); the pendulum is not fed back.
    #[serde(deserialize_with = "crate::format::exact_array")]
    pub hand_servo: [f64; 2],
    /// Feedback along the plan, $(q_\theta, q_{\dot\theta}, q_x, q_{\dot x}, r)$:
    /// the robot executes a plan with the time-varying LQR of these weights
    /// on its model's linearisation along the plan (the local linear policy
    /// of the paper's Eq. 2), instead of open loop with the hand servo.
    /// All $q = 0$ (the default): plans run open loop with the hand servo.
    /// With (10, 1, 10, 1, 0.1) or (10, 1, 1, 1, 1) and the pure LWR,
    /// fewer seeds learned (1 of 8 and 0 of 8 against 3 of 8 open loop):
    /// gains computed on an inaccurate model push the hand out of its
    /// workspace.
    #[serde(deserialize_with = "crate::format::exact_array")]
    pub feedback: [f64; 5],
    /// When the balancing LQR takes over from the swing-up: the box of
    /// `catch_angle` and `catch_rate` (the default) or the controller's
    /// calibrated region of attraction ([`CatchKind::Basin`]).
    pub catch: CatchKind,
    /// The LQR takes over within this angle of upright (rad)...
    pub catch_angle: f64,
    /// ...and below this angular speed (rad/s) (with `catch = "box"`).
    pub catch_rate: f64,
    /// With `catch = "basin"`: the level $c$ of the LQR's cost to go
    /// $e^\top P e$ below which it takes over; absent, it is calibrated by
    /// simulation at the start of every run
    /// ([`crate::plant::basin::calibrate`], deterministic).
    pub catch_level: Option<f64>,
    /// Success: within this angle of upright (rad)...
    pub success_angle: f64,
    /// ...over the last this many seconds.
    pub success_seconds: f64,
    /// The planner.
    pub planner: PlannerConfig,
    /// The learned model.
    pub model: ModelConfig,
    /// Learn from the demonstration (the paper's) or without one.
    pub start: Start,
    /// Without a demonstration: the largest command of the exploration
    /// trial (m/s²).
    pub exploration: f64,
    /// How the robot executes a plan: open loop (the paper's) or by
    /// replanning from the measured state ([`Controller::Mpc`], settings in
    /// [`Config::mpc`]).
    pub controller: Controller,
    /// The receding-horizon controller's settings (with `controller = "mpc"`).
    pub mpc: MpcConfig,
}

/// A `[human]` table over the human's defaults.
fn human_plant<'de, D: serde::Deserializer<'de>>(d: D) -> Result<PlantParams, D::Error> {
    PlantPatch::deserialize(d).map(|p| p.over(PlantParams::human()))
}

/// A `[robot]` table over the robot's defaults.
fn robot_plant<'de, D: serde::Deserializer<'de>>(d: D) -> Result<PlantParams, D::Error> {
    PlantPatch::deserialize(d).map(|p| p.over(PlantParams::robot()))
}

/// How the robot executes a trial's plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Controller {
    /// The paper's: the plan's commands with the hand servoed to the planned
    /// hand path, the pendulum open loop (or the time-varying LQR of
    /// [`Config::feedback`]).
    #[value(
        help = "The paper's: the plan's commands, the hand servoed to the planned hand path, the pendulum open loop (or the time-varying LQR of `feedback`)"
    )]
    OpenLoop,
    /// Model-predictive control, beyond the paper: the trial starts with
    /// the planner's plan, then Eq. 3 is replanned by Gauss-Newton from the
    /// measured state every [`MpcConfig::every`] steps over a window of
    /// [`MpcConfig::window`] steps, warm-started from the previous plan
    /// (see [`crate::planning::mpc`]), and each observed transition joins
    /// the model at once when it learns online (the LWR). The LQR catch
    /// near upright stays. After the swing-up window the reference is
    /// upright at rest, and replanning goes on until the catch.
    #[value(
        help = "Model-predictive control, beyond the paper: Eq. 3 replanned by Gauss-Newton from the measured state every `mpc.every` steps over a window of `mpc.window` steps, warm-started from the previous plan; the LQR catch near upright stays"
    )]
    Mpc,
}

/// The receding-horizon controller ([`Controller::Mpc`]).
///
/// | field | default | range |
/// |---|---|---|
/// | `window` | 150 samples (2.5 s) | at least `control_coeffs` |
/// | `every` | 1 (60 Hz) | at least 1 |
/// | `iterations` | 1 Gauss-Newton iteration per replan | at least 1 |
/// | `budget_ms` | 0 (no time limit) | finite, nonnegative |
/// | `state_coeffs`, `control_coeffs` | 25, 20 | at least 4 |
/// | `online` | true | |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MpcConfig {
    /// Steps of the replanned window.
    pub window: usize,
    /// Replan every this many control steps.
    pub every: usize,
    /// Gauss-Newton iterations per replan (the best iterate is used). One,
    /// the default, is the real-time iteration scheme of nonlinear MPC
    /// (Diehl, Bock and Schlöder, SIAM J. Control Optim. 2005): the warm
    /// start is close, so one step per frame tracks the optimum as it moves.
    pub iterations: usize,
    /// Wall time per replan (ms) after which its result is discarded and
    /// the previous plan kept; 0: no limit (runs reproducible bit for bit).
    pub budget_ms: f64,
    /// B-spline coefficients of the window's states.
    pub state_coeffs: usize,
    /// B-spline coefficients of the window's commands.
    pub control_coeffs: usize,
    /// Insert each observed transition into the model during the trial
    /// (models that learn online: the LWR).
    pub online: bool,
    /// Hard bounds in every replan (issue 35): the hand's position within
    /// `planner.x_max` and the command within `planner.u_max` at every
    /// sample of the window, enforced by Gauss-Newton's bounded (QP) step
    /// ([`trajopt::Eq3Problem::with_state_bounds`]) on top of the soft
    /// bounds of the task cost. Off by default: a first check with the
    /// pure LWR found no gain (issue 35's closing note; no saved grid yet).
    pub hard_bounds: bool,
}

impl Default for MpcConfig {
    fn default() -> Self {
        Self {
            window: 150,
            every: 1,
            iterations: 1,
            budget_ms: 0.0,
            state_coeffs: 25,
            control_coeffs: 20,
            online: true,
            hard_bounds: false,
        }
    }
}

/// When the balancing controller takes over ([`Config::catch`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum CatchKind {
    /// Within `catch_angle` of upright and below `catch_rate`: a box that
    /// holds states the LQR cannot balance (moving away from upright) and
    /// misses states it can (`swingup basin` maps both).
    #[default]
    Box,
    /// Where the LQR's cost to go $e^\top P e$ is below a level calibrated
    /// so that at least 99 % of the states below it are balanced
    /// ([`crate::plant::basin`]).
    #[value(
        help = "Where the LQR's cost to go is below a level calibrated so that at least 99 % of the states below it are balanced (`swingup basin`)"
    )]
    Basin,
}

/// Where learning starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Start {
    /// From a human's demonstration (the paper's): trial 1 imitates it,
    /// the task cost tracks it, and every plan starts from it.
    Demonstration,
    /// Without a demonstration (a baseline, beyond the paper): trial 1
    /// sends random smooth commands (a cubic B-spline of
    /// `control_coeffs` coefficients drawn uniformly within
    /// $\pm$ `exploration`, the hand servoed to its home); the task cost
    /// tracks upright at rest over the whole window with $u^d = 0$; and
    /// each plan starts from the previous trial's observed trajectory.
    #[value(
        help = "Without a demonstration (a baseline, beyond the paper): trial 1 sends random smooth commands within +- `exploration`; the task cost tracks upright at rest; each plan starts from the previous trial"
    )]
    Scratch,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            seed: 1,
            max_trials: 8,
            human: PlantParams::human(),
            robot: PlantParams::robot(),
            human_swingup: HumanSwingup::default(),
            horizon: 150,
            balance: 180,
            sensor_noise: [0.005, 0.02, 0.002, 0.01],
            hand_servo: [40.0, 10.0],
            feedback: [0.0, 0.0, 0.0, 0.0, 0.1],
            catch: CatchKind::Box,
            catch_angle: 0.3,
            catch_rate: 2.0,
            catch_level: None,
            success_angle: 0.2,
            success_seconds: 2.0,
            planner: PlannerConfig::default(),
            model: ModelConfig::default(),
            start: Start::Demonstration,
            exploration: 6.0,
            controller: Controller::OpenLoop,
            mpc: MpcConfig::default(),
        }
    }
}

/// Which planner makes the plans.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Solver {
    /// Eq. 3 by sparse Gauss-Newton / Levenberg-Marquardt (`trajopt`).
    GaussNewton,
    /// Eq. 3 by Powell's derivative-free method, as in the paper (`trajopt`).
    Powell,
    /// Eq. 3 by derivative-free least squares (`trajopt::derivative_free`):
    /// Levenberg-Marquardt on a Jacobian differenced from the criterion's
    /// residuals in Curtis-Powell-Reid column groups; the model's Jacobian
    /// is never asked for.
    DerivativeFree,
    /// Differential dynamic programming through the model (`ddp`); no
    /// consistency weight: every rollout is exactly consistent.
    Ddp,
}

/// How the derivative-free planner ([`Solver::DerivativeFree`]) differences
/// Eq. 3's Jacobian; neither asks the model for its Jacobian.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Differences {
    /// Per step: forward differences of the model in each of its inputs,
    /// every step at once ($n + m + 1$ model evaluations per step, about 6
    /// criterion evaluations per Jacobian; `trajopt::derivative_free::Differenced`).
    #[value(
        help = "Per step: forward differences of the model in each input, every step at once (n + m + 1 model evaluations per step)"
    )]
    #[default]
    Elements,
    /// Per coefficient group: Curtis-Powell-Reid groups of the criterion's
    /// residuals (14 criterion evaluations per Jacobian;
    /// `trajopt::DerivativeFree`).
    Groups,
}

/// Which differences the derivative-free planner takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum DifferenceKind {
    /// $(f(z + h) - f(z)) / h$: first-order accurate, the fewest evaluations.
    #[value(help = "(f(z + h) - f(z)) / h: first-order accurate, the fewest evaluations")]
    #[default]
    Forward,
    /// $(f(z + h) - f(z - h)) / 2h$: second-order accurate, about twice the evaluations.
    #[value(help = "(f(z + h) - f(z - h)) / 2h: second-order accurate, about twice the evaluations")]
    Central,
}

/// Which basis represents the planned trajectories (Eq. 3 planners).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum BasisKind {
    /// Clamped uniform cubic B-splines (`state_coeffs`, `control_coeffs`).
    Bspline,
    /// Daubechies-4 wavelets, periodised, one coefficient per sample.
    Wavelet,
}

/// Which model the robot learns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum ModelKind {
    /// Locally weighted regression on all five inputs (the paper's).
    Lwr,
    /// Least squares on the physically structured features (the `parametric` module).
    Parametric,
    /// Semiparametric (beyond the paper, the default): the LWR corrects the
    /// parametric model instead of a global linear fit.
    LwrParametric,
    /// The robot's true dynamics (a reference, not learned).
    True,
}

/// What the pure LWR falls back on where it has no data (the prior whose
/// residuals it fits; [`ModelKind::Lwr`] only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum LwrPrior {
    /// A global linear fit on the LWR's inputs: extrapolates the data's
    /// average slopes.
    Linear,
    /// The data's mean: far from the data the model predicts the average
    /// change, i.e. no force it has not seen.
    Constant,
    /// A global control-affine fit on the angle's sine and cosine and the
    /// other inputs ([`ControlAffineRegression`](crate::models::ControlAffineRegression)):
    /// extrapolates how the command's effect depends on the state.
    #[value(
        help = "A global control-affine fit on the angle's sine and cosine and the other inputs: extrapolates how the command's effect depends on the state"
    )]
    ControlAffine,
}

/// The planner's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlannerConfig {
    /// The planner.
    pub solver: Solver,
    /// The trajectory basis of the Eq. 3 planners.
    pub basis: BasisKind,
    /// Consistency weight $\lambda$ (mismatch in rate units).
    pub lambda: f64,
    /// A schedule over trials (beyond the paper): trial $t \ge 2$ plans with
    /// $\lambda \cdot$ `lambda_growth`$^{t-2}$, trusting the model more as its
    /// data grow; 1 keeps $\lambda$ constant.
    pub lambda_growth: f64,
    /// Continuation: the plan is first solved with this $\lambda$, then
    /// with ten times more, warm-started, until `lambda` (0 or
    /// $\ge$ `lambda`: solve with `lambda` directly). Starting near the
    /// demonstration and letting the model bend the plan gradually keeps
    /// Gauss-Newton on the swing-up instead of collapsing to the nearest
    /// consistent (and useless) trajectory.
    pub lambda_start: f64,
    /// Warm start (beyond the paper): each plan after a trial's first
    /// starts from the last planned trial's plan, at the final $\lambda$
    /// (no continuation), instead of from the demonstration. The previous
    /// plan already swings up, so re-solving it with the model's new data
    /// takes a fraction of the continuation's iterations. Off (the
    /// default): every plan starts from the demonstration, as the paper's.
    pub warm_start: bool,
    /// Per-point consistency weight from the model's confidence (beyond the
    /// paper): $\lambda_k = \lambda \max(\epsilon, \min(1, n_k / n_{full}))$
    /// with $n_k$ the model's support at the plan's $(x_k, u_k)$, re-evaluated
    /// at each continuation stage (and under MPC at each replan, along
    /// its warm start), $n_{full}$ = `confidence_full` and
    /// $\epsilon$ this value; 0 turns it off (constant $\lambda$). Models without
    /// a support (parametric, true) get the constant.
    pub confidence_floor: f64,
    /// $n_{full}$ of `confidence_floor`: the support (effective number of
    /// data points) at which the model is fully trusted.
    pub confidence_full: f64,
    /// Cubic B-spline coefficients per state channel.
    pub state_coeffs: usize,
    /// Cubic B-spline coefficients for the control.
    pub control_coeffs: usize,
    /// Diagonal of $Q$ on $(\theta, \dot\theta, x, \dot x)$ (tracking the demonstration).
    #[serde(deserialize_with = "crate::format::exact_array")]
    pub state_weights: [f64; 4],
    /// Weight $r$ on $(u - u^d)^2$.
    pub control_weight: f64,
    /// Diagonal of the terminal weight on reaching upright at rest.
    #[serde(deserialize_with = "crate::format::exact_array")]
    pub terminal_weights: [f64; 4],
    /// Weight of the penalty fixing the initial state (hanging at rest).
    pub initial_state_weight: f64,
    /// Largest planned command (m/s²), below the actuator limit.
    pub u_max: f64,
    /// Weight $w_b$ of the soft bounds on $|x|$ and $|u|$ (see [`crate::planning::cost`]).
    pub bound_weight: f64,
    /// Largest planned hand excursion (m), inside the robot's workspace
    /// to leave the hand servo room.
    pub x_max: f64,
    /// How [`Solver::DerivativeFree`] differences the Jacobian.
    pub differences: Differences,
    /// Forward or central differences for [`Solver::DerivativeFree`].
    pub difference_kind: DifferenceKind,
    /// With the Powell and derivative-free planners: also solve each plan's
    /// problem by Gauss-Newton (same model, start and continuation) and
    /// record its criterion in the plan (`gauss_newton_cost`), to check that
    /// the derivative-free plan is the same optimum. Off by default (it
    /// costs a second solve, not counted in the plan's time).
    pub compare_gauss_newton: bool,
    /// Iteration cap of Gauss-Newton and the derivative-free mode (per
    /// continuation stage) and DDP. 1000: at the earlier 200, 15 of 249
    /// derivative-free and 11 of 227 Gauss-Newton plans of the pure LWR's
    /// learning runs (seeds 1-40, made at 2421dec; `git show
    /// 10efb54:results/derivative-free/runs.jsonl`) stopped at the cap, still
    /// descending; a plan that converges stops long before it.
    pub max_iters: usize,
    /// Cost-evaluation budget of Powell's method (per continuation stage).
    /// Powell evaluates Eq. 3 term by term ([`trajopt::powell::BandTerms`]:
    /// a trial point re-evaluates only the time steps its changed
    /// coefficients touch); every evaluation counts, partial or not.
    pub powell_evals: usize,
    /// Powell's principal-axes period ([`trajopt::PowellSettings::principal_axes`]):
    /// every this many iterations its direction set becomes the principal
    /// axes of its quadratic model (Brent's PRAXIS); 0 never. 5: on the
    /// pure LWR's trial-2 plans of two seeds (120 coefficients, one stage
    /// at the final $\lambda$, 100,000 evaluations) it ended at criteria
    /// several times lower than without it, below Gauss-Newton's
    /// (`results/derivative-free/README.md`); the claims grid's Powell
    /// rows, at 10,000 evaluations, have not been rerun with it.
    pub powell_principal_axes: usize,
    /// Relative cost-decrease tolerance of Gauss-Newton: a stage ends
    /// (`ConvergedCost`) once an accepted step lowers the criterion by less
    /// than this fraction of it. The criterion is only as accurate as the
    /// learned model, so iterating on for gains of $10^{-8}$ and less only
    /// polishes the model's errors: with the pure LWR of 2 and 5 trials,
    /// $10^{-6}$ ends the plans at criteria within $10^{-4}$ of the ones
    /// $10^{-14}$ reaches, in a third to a half of the iterations; over
    /// seeds 1-20 (`swingup learn --model lwr --max-trials 8`, commit
    /// fb7f531) as many runs learned (8) in 58 % of the run time.
    pub tol_cost: f64,
    /// Weight $w$ of the penalty on planning where the robot has no data
    /// ([`crate::planning::support`]): each planned sample pays up to $w$ by how
    /// little data lie near its $(s_k, u_k)$; 0 (the default) turns it
    /// off. Measured with the pure LWR over 40 seeds it made learning less
    /// likely, not more (the plans stop short of upright where the data
    /// end; the numbers are in the closing note of the session that added
    /// it): it is there to measure, not a fix.
    pub support_weight: f64,
    /// Bandwidth $h$ of the data support, in units of each input's spread.
    pub support_bandwidth: f64,
    /// $n_0$ of the data support: the sum of kernel weights at which the
    /// penalty has fallen to half its full weight.
    pub support_full: f64,
    /// Scales of the data support's metric on
    /// $(\theta, \dot\theta, x, \dot x, u)$, relative to each input's spread.
    #[serde(deserialize_with = "crate::format::exact_array")]
    pub support_scales: [f64; 5],
}

impl Default for PlannerConfig {
    fn default() -> Self {
        Self {
            solver: Solver::GaussNewton,
            basis: BasisKind::Bspline,
            lambda: 1e3,
            lambda_growth: 1.0,
            lambda_start: 1.0,
            warm_start: false,
            confidence_floor: 0.0,
            confidence_full: 10.0,
            state_coeffs: 25,
            control_coeffs: 20,
            state_weights: [1.0, 0.1, 1.0, 0.1],
            control_weight: 0.01,
            terminal_weights: [1e4, 1e3, 1e3, 1e2],
            initial_state_weight: 1e4,
            u_max: 12.0,
            x_max: 0.7,
            bound_weight: 1e4,
            differences: Differences::Elements,
            difference_kind: DifferenceKind::Forward,
            compare_gauss_newton: false,
            max_iters: 1000,
            powell_evals: 200_000,
            powell_principal_axes: 5,
            tol_cost: 1e-6,
            support_weight: 0.0,
            support_bandwidth: 0.3,
            support_full: 3.0,
            support_scales: [1.0; 5],
        }
    }
}

/// The learned model's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModelConfig {
    /// The model.
    pub kind: ModelKind,
    /// Initial bandwidth (inputs normalised by their spread).
    pub bandwidth: f64,
    /// Ridge on the local fits' slopes.
    pub ridge: f64,
    /// Ridge on the local fits' slopes per bandwidth unit
    /// ([`lwr::LwrSettings::slope_ridge`]), in units of kernel weight (data
    /// points): scale-free, and inputs the tuned metric ignores leave the
    /// local fits. Off by default: with the pure LWR it makes tuning pick
    /// more local models and plans several times faster, but learning
    /// succeeded in fewer runs over seeds 1-20 (`swingup learn --model lwr
    /// --max-trials 8`; the counts are in the message of commit 673903d).
    pub slope_ridge: f64,
    /// Evaluations of the cross-validated metric tuning per trial (0: no tuning).
    pub tune_evals: usize,
    /// Compare metrics during the tuning by the leave-one-out errors of
    /// about this many data points only ([`lwr::TuneSettings::search_points`]:
    /// each evaluation $n /$ `tune_points` times cheaper; the tuned metric's
    /// error is still measured over all points); 0 (the default): every
    /// point. A run whose leave-one-out work is estimated past
    /// [`limits::LOO_PAIRS`] is warned at
    /// its start, naming this key.
    #[serde(default)]
    pub tune_points: usize,
    /// Ridge on the LWR's intercept: the weight of the prior that the
    /// residual of the global linear fit is 0 (see
    /// [`LwrRegression`](crate::models::LwrRegression)); in units of kernel weight, i.e. data points.
    pub prior_weight: f64,
    /// The LWR kernel. Tricube goes to zero smoothly at the edge of its
    /// support; the Gaussian's truncation makes the prediction jump by a
    /// few parts in a million when a point crosses it, enough to stall
    /// Gauss-Newton at the jump.
    pub kernel: Kernel,
    /// The pure LWR's prior (see [`LwrPrior`]); [`validate`](Config::validate) refuses any
    /// but `linear` with another model kind.
    pub prior: LwrPrior,
    /// Choose the LWR's inputs by cross-validation over whole trials
    /// (backward elimination; see [`crate::models::selection`]) before
    /// tuning its metric; off (the default): the LWR sees all five inputs.
    /// The selection drops the hand's position and velocity, as the paper's
    /// cross-validation found them irrelevant, and the models predict the
    /// next trial better; it did not make learning succeed more often
    /// (the counts are in the message of the commit that added it), so it
    /// is there to measure, not a fix.
    pub select_inputs: bool,
    /// The number of contiguous blocks each trial is cut into for the
    /// grouped cross-validation of [`select_inputs`](Self::select_inputs).
    pub cv_blocks: usize,
    /// Degree of the local polynomial (`Linear`, the paper's; `Quadratic`
    /// adds the products of the inputs, such as the command times the
    /// angle, at $1 + d + d(d+1)/2$ coefficients per fit).
    pub degree: Degree,
    /// Gaussian kernel truncation, in bandwidths.
    pub cutoff: f64,
    /// Initial metric scales relative to each input's spread (0 leaves an
    /// input out of the distance; tuning starts from these).
    #[serde(deserialize_with = "crate::format::exact_array")]
    pub input_scales: [f64; 5],
}

impl Default for ModelConfig {
    fn default() -> Self {
        Self {
            kind: ModelKind::LwrParametric,
            bandwidth: 0.5,
            ridge: 1e-6,
            slope_ridge: 0.0,
            tune_evals: 40,
            tune_points: 0,
            prior_weight: 1.0,
            kernel: Kernel::Tricube,
            prior: LwrPrior::Linear,
            select_inputs: false,
            cv_blocks: 5,
            degree: Degree::Linear,
            cutoff: 5.0,
            input_scales: [1.0; 5],
        }
    }
}

impl Config {
    /// How the robot's catch is chosen ([`Catch::design`](crate::plant::basin::Catch::design)
    /// builds it): [`Config::catch`] with its angle, rate or level.
    pub fn catch_spec(&self) -> CatchSpec {
        match self.catch {
            CatchKind::Box => CatchSpec::Box {
                angle: self.catch_angle,
                rate: self.catch_rate,
            },
            CatchKind::Basin => CatchSpec::Basin {
                level: self.catch_level,
            },
        }
    }

    /// A run's balancing phase on the robot, as [`crate::plant::basin`] simulates it.
    pub fn balance_test(&self) -> BalanceTest {
        BalanceTest {
            plant: self.robot,
            sensor_noise: self.sensor_noise,
            steps: self.balance,
            success_angle: self.success_angle,
            tail: ((self.success_seconds / self.robot.dt).round() as usize).min(self.balance),
        }
    }
}

#[cfg(test)]
mod tests {
    /// The leave-one-out estimate: the defaults far inside the warning's
    /// limit, a run at the documented size limits far past it, and
    /// `model.tune_points` cutting the tuning's share; no model without
    /// leave-one-out counts.
    #[test]
    fn the_leave_one_out_work_is_estimated() {
        let d = Config::default().workload();
        assert!(
            d.loo_pairs > 0.0 && d.loo_pairs < limits::LOO_PAIRS / 10.0,
            "{}",
            d.loo_pairs
        );
        let mut big = Config {
            horizon: 2000,
            max_trials: 100,
            ..Config::default()
        };
        let full = big.workload().loo_pairs;
        assert!(full > limits::LOO_PAIRS, "{full}");
        big.model.tune_points = 2000;
        let capped = big.workload().loo_pairs;
        assert!(capped < full / 10.0, "{capped} vs {full}");
        // n = 2180 samples after trial 1: 40 evaluations over 2000 points and two full passes
        big.max_trials = 1;
        let n = 2180.0;
        assert_eq!(big.workload().loo_pairs, (40.0 * 2000.0 + 2.0 * n) * n);
        big.model.kind = ModelKind::Parametric;
        assert_eq!(big.workload().loo_pairs, 0.0);
    }

    use super::*;

    /// Bad values are refused with the field's name.
    #[test]
    fn validate_names_bad_fields() {
        let mut cfg = Config::default();
        assert!(cfg.validate().is_ok());
        cfg.planner.lambda_growth = 0.0;
        let e = cfg.validate().expect_err("zero growth").to_string();
        assert!(e.contains("lambda_growth"), "{e}");
        cfg.planner.lambda_growth = 1e300;
        assert!(cfg.validate().is_err(), "lambda overflows over the trials");
        let mut cfg = Config::default();
        cfg.planner.lambda = -1.0;
        assert!(cfg.validate().expect_err("negative").to_string().contains("lambda"));
        for (set, key) in [
            (
                Box::new(|c: &mut Config| c.catch_angle = f64::NAN) as Box<dyn Fn(&mut Config)>,
                "catch_angle",
            ),
            (Box::new(|c: &mut Config| c.balance = 0), "balance"),
            (Box::new(|c: &mut Config| c.planner.max_iters = 0), "planner.max_iters"),
            (
                Box::new(|c: &mut Config| c.planner.lambda_start = f64::NAN),
                "planner.lambda_start",
            ),
            (Box::new(|c: &mut Config| c.feedback[0] = f64::NAN), "feedback"),
            (Box::new(|c: &mut Config| c.planner.tol_cost = 0.0), "planner.tol_cost"),
            (Box::new(|c: &mut Config| c.horizon = 12), "planner.state_coeffs"),
            (Box::new(|c: &mut Config| c.mpc.window = 10), "mpc.window"),
            (Box::new(|c: &mut Config| c.mpc.every = 0), "mpc.every"),
            (Box::new(|c: &mut Config| c.mpc.budget_ms = -1.0), "mpc.budget_ms"),
            (
                Box::new(|c: &mut Config| {
                    c.model.kind = ModelKind::LwrParametric;
                    c.model.prior = LwrPrior::ControlAffine;
                }),
                "model.prior",
            ),
        ] {
            let mut cfg = Config::default();
            set(&mut cfg);
            let e = cfg.validate().expect_err(key).to_string();
            assert!(e.contains(key), "{key}: {e}");
        }
        let mut cfg = Config::default();
        cfg.planner.support_weight = f64::NAN;
        assert!(cfg.validate().expect_err("nan").to_string().contains("support_weight"));
        let mut cfg = Config::default();
        cfg.planner.support_scales = [0.0; 5];
        assert!(cfg.validate().expect_err("zero").to_string().contains("support_scales"));
    }

    /// Issue 37: sizes that would exhaust memory or never finish, and
    /// ranges that make a result meaningless, are refused by name before
    /// any work (each of these once aborted, hung or reported a success).
    #[test]
    fn sizes_and_meaningless_ranges_are_refused_with_the_estimate() {
        type Set = Box<dyn Fn(&mut Config)>;
        let cases: Vec<(Set, &str, &str)> = vec![
            (Box::new(|c| c.balance = 1_000_000_000), "balance", "at most 100000"),
            (Box::new(|c| c.horizon = 100_000_000), "horizon", "at most 10000"),
            (Box::new(|c| c.robot.substeps = 4_000_000_000), "robot", "substeps"),
            (Box::new(|c| c.human.gravity = 1e300), "human", "gravity"),
            (Box::new(|c| c.max_trials = 1_000_000), "max_trials", "1 to 1000"),
            (
                Box::new(|c| {
                    c.catch_angle = 4.0;
                    c.success_angle = 4.0
                }),
                "catch_angle",
                "pi/2",
            ),
            (Box::new(|c| c.success_angle = 2.0), "success_angle", "pi/2"),
            (
                Box::new(|c| c.sensor_noise = [1e300, 0.0, 0.0, 0.0]),
                "sensor_noise",
                "at most 1",
            ),
            (
                Box::new(|c| c.human_swingup.energy_gain = f64::NAN),
                "energy_gain",
                "[0, 1e4]",
            ),
            // each within its own bound, together beyond the memory limit
            (
                Box::new(|c| {
                    c.balance = 100_000;
                    c.max_trials = 1_000
                }),
                "balance",
                "GiB",
            ),
            (
                Box::new(|c| {
                    c.balance = 100_000;
                    c.max_trials = 30;
                    c.robot.substeps = 1_000;
                    c.human.substeps = 1_000
                }),
                "robot.substeps",
                "RK4 steps",
            ),
            (
                Box::new(|c| {
                    c.controller = Controller::Mpc;
                    c.balance = 50_000;
                    c.mpc.window = 10_000;
                    c.max_trials = 10
                }),
                "mpc.window",
                "linearised samples",
            ),
        ];
        for (set, key, words) in cases {
            let mut cfg = Config::default();
            set(&mut cfg);
            let e = cfg.validate().expect_err(key).to_string();
            assert!(e.contains(key) && e.contains(words), "{key}: {e}");
        }
        // the defaults and the largest single sizes are inside the estimates
        let w = Config::default().workload();
        assert_eq!(w.data_points, 330.0 * 8.0);
        assert_eq!(w.plant_steps, 330.0 * (8.0 * 10.0 + 10.0));
        assert_eq!(w.replan_samples, 0.0);
        let cfg = Config {
            horizon: limits::HORIZON,
            ..Config::default()
        };
        assert!(cfg.validate().is_ok(), "{:?}", cfg.validate());
    }

    /// Issue 37: a `[robot]` or `[human]` table that sets some keys keeps
    /// each plant's own defaults for the others, as the docs say; unknown
    /// keys and arrays of the wrong length are refused, naming them.
    #[test]
    fn partial_tables_keep_their_defaults_and_bad_keys_are_refused() {
        let cfg: Config = toml::from_str(
            "horizon = 120\n[robot]\ngravity = 9.0\n[human]\nlength = 0.4\n[human_swingup]\npush = 6.0\n",
        )
        .expect("partial tables");
        assert_eq!(
            cfg.robot,
            PlantParams {
                gravity: 9.0,
                ..PlantParams::robot()
            }
        );
        assert_eq!(
            cfg.human,
            PlantParams {
                length: 0.4,
                ..PlantParams::human()
            }
        );
        assert_eq!(
            cfg.human_swingup,
            HumanSwingup {
                push: 6.0,
                ..HumanSwingup::default()
            }
        );
        assert_eq!(cfg.horizon, 120);
        assert_eq!(cfg.planner, PlannerConfig::default());
        for (text, word) in [
            ("[robot]\ngravty = 9.0\n", "gravty"),
            ("[human_swingup]\npussh = 1.0\n", "pussh"),
            ("sensor_noise = [0.1, 0.1, 0.1, 0.1, 0.1]\n", "sensor_noise"),
            ("sensor_noise = [0.1, 0.1]\n", "sensor_noise"),
            ("[planner]\nsupport_scales = [1.0]\n", "support_scales"),
            ("horizn = 3\n", "horizn"),
        ] {
            let e = toml::from_str::<Config>(text).expect_err(text).to_string();
            assert!(e.contains(word), "{text}: {e}");
        }
        // and the defaults, printed and read back, are the defaults
        let printed = toml::to_string(&Config::default()).expect("print");
        assert_eq!(toml::from_str::<Config>(&printed).expect("read"), Config::default());
    }
}
