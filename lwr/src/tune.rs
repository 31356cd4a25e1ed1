//! Tuning of the bandwidth and metric scales by a compass search that
//! minimises the leave-one-out error of [`LwrModel::loo`].

use std::collections::HashMap;

mod lm;

use serde::{Deserialize, Serialize};

use crate::error::{LwrError, Result};
use crate::loo::{BOUND_MARGIN, Objective};
use crate::model::LwrModel;
use crate::settings::LwrSettings;
use solve::{Finish as _, Termination, Watch};

/// Smallest relative decrease of the objective that counts as a move.
const MIN_IMPROVEMENT: f64 = 1e-9;

/// How [`LwrModel::tune`] searches for the bandwidth and scales.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum TuneMethod {
    /// A compass (coordinate pattern) search in log space: derivative-free,
    /// multiplicative steps from `initial_factor` down to `min_factor`; any
    /// metric.
    #[default]
    Compass,
    /// Levenberg-Marquardt on the leave-one-out residuals as functions of
    /// the logarithms of the scales, with their exact Jacobian
    /// (`scale_grad.rs`). With `tune_bandwidth`, the compass search over the
    /// bandwidth alone comes first, down to a factor 1.5 (a global start:
    /// from too narrow a bandwidth a descent can head for fits that isolate
    /// every point); then the nonzero scales descend with the bandwidth
    /// fixed (only $m_j / h$ matters); after each descent, with `try_zero`,
    /// each input is tried at zero, and if one is dropped the descent starts
    /// again over the inputs left. The compass search's sweeps over every
    /// coordinate at a factor 1.1 end it (then no coordinate moved by 10 %,
    /// nor an input tried at zero or back on, lowers the objective). Without
    /// `tune_scales` it is the compass search. A diagonal metric only. On
    /// the diabetes and Friedman data of `scripts/lwr_diabetes.py` it ends
    /// at a leave-one-out error about as low as the compass search's, in a
    /// fraction of the evaluations.
    LevenbergMarquardt,
}

/// Settings of [`LwrModel::tune`].
///
/// | name | default | meaning |
/// |---|---|---|
/// | `tune_bandwidth` | true | search over $h$ |
/// | `tune_scales` | true | search over each $m_j$ |
/// | `try_zero` | true | also try $m_j = 0$ (drop input $j$ from the metric) |
/// | `zero_tolerance` | $10^{-6}$ | drop an input if that raises the objective by less than this, relatively |
/// | `initial_factor` | 4 | first multiplicative step |
/// | `min_factor` | 1.05 | stop when the step falls below this factor |
/// | `max_evals` | 300 | budget of leave-one-out evaluations |
/// | `stop_early` | true | stop an evaluation once it certainly cannot be accepted |
/// | `search_points` | 0 (all) | cross-validate only about this many points during the search |
/// | `method` | [`TuneMethod::Compass`] | the search |
#[derive(Debug, Clone, PartialEq)]
pub struct TuneSettings {
    /// Search over the bandwidth.
    pub tune_bandwidth: bool,
    /// Search over the metric scales.
    pub tune_scales: bool,
    /// Also try a zero scale for each input.
    pub try_zero: bool,
    /// Largest relative increase of the objective accepted for dropping an
    /// input (a simpler metric wins near-ties), $\ge 0$.
    pub zero_tolerance: f64,
    /// First multiplicative step, $> 1$.
    pub initial_factor: f64,
    /// Smallest multiplicative step, in $(1, $ `initial_factor` $]$.
    pub min_factor: f64,
    /// Largest number of objective evaluations.
    pub max_evals: usize,
    /// Stop an evaluation as soon as the partial sum of its leave-one-out
    /// errors exceeds what the search would accept (the search takes the
    /// same path and returns the same result either way; only the history
    /// records lower bounds for the stopped evaluations, see
    /// [`TuneStep::complete`]). Bad trial metrics, which are often the ones
    /// with the widest neighbourhoods, then cost a fraction of a full pass.
    pub stop_early: bool,
    /// With $0 <$ `search_points` $< n$, the search compares settings by the
    /// leave-one-out errors of about `search_points` of the points only (the
    /// points $i$ with $i \bmod s = 0$, $s = \lceil n /$ `search_points`
    /// $\rceil$; their fits still use every point), which makes each
    /// evaluation $n /$ `search_points` times cheaper. The result's
    /// `objective` and `initial_objective` are then evaluated over all the
    /// points once the search ends (and if the tuned settings are worse than
    /// the initial ones over all the points, the initial ones are returned);
    /// the history's objectives are those of the subset. 0 (the default):
    /// every point, the exact search.
    pub search_points: usize,
    /// The search: the compass search, or Levenberg-Marquardt on the
    /// leave-one-out residuals (see [`TuneMethod`]; `initial_factor` then
    /// caps the step at a factor `initial_factor`$^2$ per scale, and the
    /// descent ends when the scales move by less than a tenth of
    /// `min_factor`'s step).
    pub method: TuneMethod,
}

impl Default for TuneSettings {
    fn default() -> Self {
        Self {
            tune_bandwidth: true,
            tune_scales: true,
            try_zero: true,
            zero_tolerance: 1e-6,
            initial_factor: 4.0,
            min_factor: 1.05,
            max_evals: 300,
            stop_early: true,
            search_points: 0,
            method: TuneMethod::Compass,
        }
    }
}

impl TuneSettings {
    /// Checks every field.
    pub fn validate(&self) -> Result<()> {
        if !(self.initial_factor.is_finite() && self.initial_factor > 1.0) {
            return Err(LwrError::InvalidParameter {
                name: "initial_factor",
                reason: format!("must be finite and > 1, got {}", self.initial_factor),
            });
        }
        if !(self.min_factor > 1.0 && self.min_factor <= self.initial_factor) {
            return Err(LwrError::InvalidParameter {
                name: "min_factor",
                reason: format!(
                    "must be in (1, initial_factor = {}], got {}",
                    self.initial_factor, self.min_factor
                ),
            });
        }
        if !(self.zero_tolerance.is_finite() && self.zero_tolerance >= 0.0) {
            return Err(LwrError::InvalidParameter {
                name: "zero_tolerance",
                reason: format!("must be finite and >= 0, got {}", self.zero_tolerance),
            });
        }
        if self.max_evals == 0 {
            return Err(LwrError::InvalidParameter {
                name: "max_evals",
                reason: "must be at least 1".into(),
            });
        }
        Ok(())
    }
}

/// Why tuning stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum TuneStatus {
    /// The step fell below `min_factor` with no improving move.
    Converged,
    /// The evaluation budget ran out.
    MaxEvals,
    /// The [`Watch`]'s time limit passed (checked before every
    /// evaluation).
    TimeLimit,
    /// An observer of the [`Watch`] stopped the search (after a sweep).
    Stopped,
}

solve::from_interrupt!(TuneStatus);

impl solve::Status for TuneStatus {
    fn termination(&self) -> Termination {
        match self {
            Self::Converged => Termination::Converged,
            Self::MaxEvals => Termination::MaxEvaluations,
            Self::TimeLimit => Termination::TimeLimit,
            Self::Stopped => Termination::Stopped,
        }
    }
}

/// The evaluations of one search: the leave-one-out objective at a point,
/// stopped early above the largest value the search would accept, with the
/// outcomes kept by the exact bits of the point.
///
/// The search revisits some settings (a dropped input tried back on, a
/// coordinate retried after the others moved back): the outcomes are
/// reused when they still answer the question (an exact value, or a lower
/// bound above the new bound); a revisit still counts as an evaluation, so
/// the path is the same with or without the cache.
struct Evaluator<'m> {
    model: &'m LwrModel,
    base: LwrSettings,
    stop_early: bool,
    /// Cross-validate every `stride`-th point during the search.
    stride: usize,
    cache: HashMap<Vec<u64>, Objective>,
}

impl Evaluator<'_> {
    /// The settings at a point $(h, m_1, \dots, m_d)$ of the search.
    fn settings_at(&self, x: &[f64]) -> LwrSettings {
        LwrSettings {
            bandwidth: x[0],
            scales: x[1..].to_vec(),
            ..self.base.clone()
        }
    }

    /// The objective at `x` (with `stop_early`, a lower bound once it is
    /// certainly above `bound`), recorded in `history`.
    fn eval(&mut self, x: &[f64], bound: f64, history: &mut Vec<TuneStep>) -> f64 {
        let bound = if self.stop_early { bound } else { f64::INFINITY };
        let key: Vec<u64> = x.iter().map(|v| v.to_bits()).collect();
        let known = match self.cache.get(&key) {
            Some(&Objective::Exact(f)) => Some(Objective::Exact(f)),
            Some(&Objective::Above(f)) if f > bound * (1.0 + BOUND_MARGIN) => Some(Objective::Above(f)),
            _ => None,
        };
        let outcome = known.unwrap_or_else(|| {
            let outcome = match self.model.loo_objective(&self.settings_at(x), bound, self.stride) {
                Ok(Objective::Exact(f)) if !f.is_nan() => Objective::Exact(f),
                Ok(Objective::Above(f)) => Objective::Above(f),
                Ok(Objective::Exact(_)) | Err(_) => Objective::Exact(f64::INFINITY),
            };
            self.cache.insert(key, outcome);
            outcome
        });
        let (f, complete) = match outcome {
            Objective::Exact(f) => (f, true),
            Objective::Above(f) => (f, false),
        };
        history.push(TuneStep {
            bandwidth: x[0],
            scales: x[1..].to_vec(),
            objective: f,
            accepted: false,
            complete,
        });
        f
    }

    /// The objective at `x` over every point (the end checks with
    /// [`TuneSettings::search_points`]).
    fn exact(&self, x: &[f64]) -> f64 {
        match self.model.loo_objective(&self.settings_at(x), f64::INFINITY, 1) {
            Ok(Objective::Exact(f)) if !f.is_nan() => f,
            _ => f64::INFINITY,
        }
    }
}

/// A metric search between sweeps ([`LwrModel::tune_start`]): a
/// [`solve::Iterate`] state (one iteration is one sweep over the
/// coordinates), and a [`solve::Finish`] one whose result is the
/// [`TuneResult`].
pub struct TuneRun<'m> {
    tune: TuneSettings,
    eval: Evaluator<'m>,
    coords: Vec<usize>,
    x: Vec<f64>,
    f: f64,
    last_nonzero: Vec<f64>,
    history: Vec<TuneStep>,
    factor: f64,
    sweeps: usize,
    /// The start and its objective.
    x_initial: Vec<f64>,
    initial: f64,
    /// The Levenberg-Marquardt state ([`TuneMethod::LevenbergMarquardt`]).
    lm: Option<lm::Lm>,
    /// Whether Levenberg-Marquardt over the scales follows the compass
    /// search's over the bandwidth.
    lm_after: bool,
}

impl std::fmt::Debug for TuneRun<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TuneRun")
            .field("sweeps", &self.sweeps)
            .field("evals", &self.history.len())
            .field("x", &self.x)
            .field("objective", &self.f)
            .finish_non_exhaustive()
    }
}

impl TuneRun<'_> {
    /// Evaluates at `y` and moves there if it is below `accept`.
    fn try_point(&mut self, y: Vec<f64>, bound: f64, accept: impl Fn(f64) -> bool) -> Option<f64> {
        let fy = self.eval.eval(&y, bound, &mut self.history);
        if !accept(fy) {
            return None;
        }
        self.x = y;
        if let Some(h) = self.history.last_mut() {
            h.accepted = true;
        }
        Some(fy)
    }
}

impl solve::Iterate for TuneRun<'_> {
    type Status = TuneStatus;
    type Error = std::convert::Infallible;
    const NAME: &'static str = "lwr-tune";

    fn next_iter(&mut self, watch: &Watch<'_>) -> std::result::Result<Option<TuneStatus>, Self::Error> {
        // the settings are plain values: a copy keeps `self` free to move
        if self.lm.is_some() {
            return Ok(self.lm_iter(watch));
        }
        if self.lm_after && self.factor < lm::SWITCH_FACTOR.max(self.tune.min_factor) {
            return Ok(self.lm_switch(watch));
        }
        let tune = self.tune.clone();
        let tune = &tune;
        if self.factor < tune.min_factor {
            return Ok(Some(TuneStatus::Converged));
        }
        let mut improved = false;
        for i in 0..self.coords.len() {
            let c = self.coords[i];
            if let Some(why) = halted(self.history.len(), tune, watch) {
                return Ok(Some(why));
            }
            let f = self.f;
            if self.x[c] == 0.0 {
                // try turning a dropped input back on
                let mut y = self.x.clone();
                y[c] = self.last_nonzero[c];
                let bound = f * (1.0 - tune.zero_tolerance);
                if let Some(fy) = self.try_point(y, bound, |fy| fy < bound) {
                    self.f = fy;
                    improved = true;
                }
                continue;
            }
            let mut moved = false;
            for dir in [self.factor, 1.0 / self.factor] {
                loop {
                    if let Some(why) = halted(self.history.len(), tune, watch) {
                        return Ok(Some(why));
                    }
                    let mut y = self.x.clone();
                    y[c] *= dir;
                    let bound = self.f * (1.0 - MIN_IMPROVEMENT);
                    match self.try_point(y, bound, |fy| fy < bound) {
                        Some(fy) => {
                            self.f = fy;
                            moved = true;
                        }
                        None => break,
                    }
                }
                if moved {
                    break;
                }
            }
            improved |= moved;
            if c > 0 && tune.try_zero {
                if let Some(why) = halted(self.history.len(), tune, watch) {
                    return Ok(Some(why));
                }
                let mut y = self.x.clone();
                y[c] = 0.0;
                let (f, was) = (self.f, self.x[c]);
                let bound = f * (1.0 + tune.zero_tolerance);
                if let Some(fy) = self.try_point(y, bound, |fy| fy <= bound) {
                    self.last_nonzero[c] = was;
                    improved |= fy < f * (1.0 - MIN_IMPROVEMENT);
                    self.f = fy;
                }
            }
        }
        if !improved {
            self.factor = self.factor.sqrt();
        }
        self.sweeps += 1;
        // reported only when the search goes on (a last sweep converged)
        Ok((self.factor < tune.min_factor && !self.lm_after).then_some(TuneStatus::Converged))
    }

    fn snapshot(&self) -> solve::Snapshot<'_> {
        solve::Snapshot {
            iteration: self.sweeps,
            evals: self.history.len(),
            cost: self.f,
            x: &self.x,
        }
    }
}

/// Why the search must stop before its next evaluation, if it must: the
/// evaluation budget, then the watch's time limit.
fn halted(evals: usize, tune: &TuneSettings, watch: &Watch<'_>) -> Option<TuneStatus> {
    if evals >= tune.max_evals {
        return Some(TuneStatus::MaxEvals);
    }
    watch.out_of_time().map(TuneStatus::from)
}

/// One evaluated point of the search.
#[derive(Debug, Clone, PartialEq)]
pub struct TuneStep {
    /// Bandwidth tried.
    pub bandwidth: f64,
    /// Scales tried.
    pub scales: Vec<f64>,
    /// Its normalised leave-one-out MSE (infinite if the evaluation failed);
    /// a lower bound when `complete` is false; over the subset of points
    /// with [`TuneSettings::search_points`].
    pub objective: f64,
    /// Whether the search moved there.
    pub accepted: bool,
    /// Whether `objective` is the full leave-one-out MSE. False for an
    /// evaluation stopped early (see [`TuneSettings::stop_early`]) because
    /// it was certainly too high to be accepted: `objective` is then a lower
    /// bound that already exceeds the acceptance threshold.
    pub complete: bool,
}

/// The outcome of [`LwrModel::tune`].
#[derive(Debug, Clone, PartialEq)]
pub struct TuneResult {
    /// The tuned settings (the input settings with `bandwidth` and `scales`
    /// replaced).
    pub settings: LwrSettings,
    /// Normalised leave-one-out MSE at the tuned settings.
    pub objective: f64,
    /// Normalised leave-one-out MSE at the initial settings.
    pub initial_objective: f64,
    /// Every evaluation, in order.
    pub history: Vec<TuneStep>,
    /// Number of evaluations.
    pub evals: usize,
    /// Why the search stopped.
    pub status: TuneStatus,
}

/// The objective is the cost; every evaluation counts as an iteration.
impl solve::Outcome for TuneResult {
    fn summary(&self) -> solve::Summary {
        solve::Summary {
            cost: self.objective,
            initial_cost: self.initial_objective,
            iterations: self.evals,
            evals: self.evals,
            termination: solve::Status::termination(&self.status),
            solve_time: None,
        }
    }
}

impl LwrModel {
    /// Tunes the bandwidth $h$ and the metric scales $m_j$ by minimising the
    /// normalised leave-one-out MSE ([`LooResult::normalized_mse`](crate::LooResult::normalized_mse)).
    ///
    /// Method: a compass (coordinate pattern) search in log space. Each
    /// sweep visits $h, m_1, \dots, m_d$; a coordinate is multiplied and
    /// divided by the current factor and keeps moving while that improves;
    /// with `try_zero` a nonzero scale is also tried at 0 (the input dropped
    /// from the metric; accepted if the objective rises by less than
    /// `zero_tolerance`, relatively), and a zero scale is tried back at its
    /// last nonzero value (accepted only if better by more than
    /// `zero_tolerance`, so the search cannot cycle). Moves must lower the
    /// objective by a relative $10^{-9}$ at least. A sweep with no improvement takes the
    /// square root of the factor; the search stops below `min_factor` or
    /// after `max_evals` evaluations. Deterministic; finds a local minimum
    /// along the coordinates.
    ///
    /// Speed: each evaluation is a full leave-one-out pass, fitted group by
    /// group of a tree over the scaled coordinates (see [`loo`](Self::loo)). With `stop_early` (the
    /// default) a trial is abandoned as soon as the partial sum of its
    /// leave-one-out errors, over blocks of points spread across the data,
    /// exceeds what the search would accept; this changes neither the path
    /// nor the result (only the history of the abandoned trials, see
    /// [`TuneStep::complete`]) and makes the bad trials, which tend to be the
    /// ones with the widest neighbourhoods, cheap.
    ///
    /// With [`TuneSettings::search_points`] the search cross-validates only a
    /// fixed subset of the points (spread over the insertion order), each
    /// evaluation being that much cheaper, and evaluates its start and end
    /// over every point; the path then differs from the exact search's.
    ///
    /// Only $m_j / h$ matters, so the result is one of a family of equivalent
    /// settings. Returns the tuned settings and the history; the model is not
    /// changed (apply with [`set_settings`](Self::set_settings)).
    ///
    /// ```
    /// # use lwr::{LwrModel, LwrSettings, TuneSettings};
    /// // y depends on x0 only; x1 is a pure-noise input
    /// let mut m = LwrModel::new(2, 1, LwrSettings { bandwidth: 0.3, ..Default::default() })?;
    /// for i in 0..200 {
    ///     let x0 = (i as f64 * 0.618).fract() * 2.0 - 1.0;
    ///     let x1 = (i as f64 * 0.377).fract() * 2.0 - 1.0;
    ///     m.insert(&[x0, x1], &[(3.0 * x0).sin()])?;
    /// }
    /// let tuned = m.tune(&TuneSettings::default())?;
    /// assert_eq!(tuned.settings.scales[1], 0.0); // x1 dropped from the metric
    /// assert!(tuned.settings.scales[0] > 0.0);
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    pub fn tune(&self, tune: &TuneSettings) -> Result<TuneResult> {
        self.tune_watched(tune, &mut Watch::new())
    }

    /// [`tune`](Self::tune) under a [`Watch`]: its observers see every
    /// sweep (the evaluations so far, the best objective, the point
    /// $(h, m_1, \dots, m_d)$) and may stop the search
    /// ([`TuneStatus::Stopped`]); its time limit is checked before every
    /// evaluation ([`TuneStatus::TimeLimit`]). Either way the result holds
    /// the best settings so far (with [`TuneSettings::search_points`] the
    /// check of the end over every point still follows).
    ///
    /// # Errors
    /// As [`tune`](Self::tune).
    pub fn tune_watched(&self, tune: &TuneSettings, watch: &mut Watch<'_>) -> Result<TuneResult> {
        let mut run = self.tune_start(tune)?;
        let Ok(status) = solve::drive(&mut run, watch);
        Ok(run.finish(status))
    }

    /// The search's state before its first sweep (the start evaluated), for
    /// a loop other than [`tune_watched`](Self::tune_watched)'s: argmin's
    /// `Executor` through `solve::argmin::Stepper` (`nprl-solve`'s feature
    /// `argmin`), or the caller's own, calling [`solve::Iterate::next_iter`]
    /// until it returns a status and then [`solve::Finish::finish`] (which
    /// does the end checks of [`TuneSettings::search_points`]).
    ///
    /// ```
    /// # use lwr::{LwrModel, LwrSettings, TuneSettings};
    /// use solve::{Finish, Iterate, Watch};
    /// let mut m = LwrModel::new(1, 1, LwrSettings { bandwidth: 0.3, ..Default::default() })?;
    /// for i in 0..100 {
    ///     let x = (i as f64 * 0.618).fract() * 2.0 - 1.0;
    ///     m.insert(&[x], &[(3.0 * x).sin()])?;
    /// }
    /// let mut run = m.tune_start(&TuneSettings::default())?;
    /// let status = loop {
    ///     if let Ok(Some(status)) = run.next_iter(&Watch::new()) {
    ///         break status;
    ///     }
    /// };
    /// assert_eq!(run.finish(status), m.tune(&TuneSettings::default())?);
    /// # Ok::<(), lwr::LwrError>(())
    /// ```
    ///
    /// # Errors
    /// As [`tune`](Self::tune).
    pub fn tune_start(&self, tune: &TuneSettings) -> Result<TuneRun<'_>> {
        tune.validate()?;
        let d = self.database().n_inputs();
        let base = self.settings().clone();
        let x: Vec<f64> = std::iter::once(base.bandwidth).chain(base.scales_for(d)).collect();
        let last_nonzero: Vec<f64> = x.iter().map(|&v| if v > 0.0 { v } else { 1.0 }).collect();
        let n = self.database().len();
        let stride = if tune.search_points == 0 || tune.search_points >= n {
            1
        } else {
            n.div_ceil(tune.search_points)
        };
        let mut eval = Evaluator {
            model: self,
            base,
            stop_early: tune.stop_early,
            stride,
            cache: HashMap::new(),
        };
        let mut history = Vec::new();
        let mut coords = Vec::new();
        if tune.tune_bandwidth {
            coords.push(0);
        }
        if tune.tune_scales {
            coords.extend(1..=d);
        }
        let lm_scales = tune.method == TuneMethod::LevenbergMarquardt && tune.tune_scales;
        if lm_scales && !eval.base.metric.is_empty() {
            return Err(LwrError::InvalidParameter {
                name: "metric",
                reason: "the Levenberg-Marquardt tuning differentiates a diagonal metric only; use the compass \
                         search with a full metric"
                    .into(),
            });
        }
        let (f, lm, lm_after) = if lm_scales && !tune.tune_bandwidth {
            // the start's errors are the caller's
            let at = eval.jacobian_at(&x)?;
            let at = eval.record(&x, Ok(at), &mut history);
            let f = at.as_ref().map_or(f64::INFINITY, |at| at.objective);
            (f, Some(lm::Lm::new(&x, at)), false)
        } else {
            // the compass search alone, or first over the bandwidth alone
            // before Levenberg-Marquardt over the scales
            if lm_scales {
                coords = vec![0];
            }
            (eval.eval(&x, f64::INFINITY, &mut history), None, lm_scales)
        };
        if let Some(h) = history.last_mut() {
            h.accepted = true;
        }
        Ok(TuneRun {
            tune: tune.clone(),
            eval,
            coords,
            x_initial: x.clone(),
            x,
            f,
            initial: f,
            last_nonzero,
            history,
            factor: tune.initial_factor,
            sweeps: 0,
            lm,
            lm_after,
        })
    }
}

impl solve::Finish for TuneRun<'_> {
    type Output = TuneResult;

    fn finish(self, status: TuneStatus) -> TuneResult {
        let TuneRun {
            eval,
            mut x,
            f,
            history,
            x_initial,
            initial,
            ..
        } = self;
        let evals = history.len();
        let (mut f, mut initial) = (f, initial);
        if eval.stride > 1 {
            // the search's objectives are over a subset: evaluate the ends
            // over every point, and never return worse than the start
            initial = eval.exact(&x_initial);
            f = if x == x_initial { initial } else { eval.exact(&x) };
            if f > initial {
                x = x_initial;
                f = initial;
            }
        }
        TuneResult {
            settings: eval.settings_at(&x),
            objective: f,
            initial_objective: initial,
            history,
            evals,
            status,
        }
    }
}
