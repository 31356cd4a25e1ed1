//! The Levenberg-Marquardt search of [`TuneMethod::LevenbergMarquardt`]:
//! the leave-one-out residuals are a nonlinear least-squares problem in the
//! logarithms of the scales, with an exact Jacobian
//! ([`LwrModel::loo_jacobian`](crate::LwrModel)).

use super::{Evaluator, TuneRun, TuneStatus, TuneStep, halted};
use crate::error::Result;
use crate::factor::{chol_solve, cholesky};
use crate::loo::LooJacobian;
use solve::Watch;

/// Largest damping (relative to the running maximum of the normal
/// matrix's diagonal) before the search gives up on a step.
const MAX_DAMPING: f64 = 1e16;

/// A step of the logarithms below this fraction of $\log$ `min_factor` ends
/// the descent.
const STEP_FRACTION: f64 = 0.1;

/// A relative decrease of the objective below this ends the descent.
const MIN_DECREASE: f64 = 1e-5;

/// The factor of the compass search's sweeps that end the search: no
/// coordinate moved by this factor (or tried at zero) lowers the objective
/// at the end. On a rough objective (leave-one-out errors amplified by
/// leverages near 1) the descent can stop where a move of a few percent
/// still pays (a proptest found one).
const FINISH_FACTOR: f64 = 1.1;

/// The compass search over the bandwidth alone hands over to
/// Levenberg-Marquardt over the scales once its factor falls below this.
/// A coarse bandwidth suffices (the scales then move relative to it), but a
/// global one: from a start too narrow the descent can follow the
/// objective down towards fits that isolate every point (each then scored
/// as predicting the mean, an objective of 1), which the compass search's
/// factor-4 steps jump over.
pub(super) const SWITCH_FACTOR: f64 = 1.5;

/// The state of the search between iterations.
#[derive(Debug, Clone)]
pub(super) struct Lm {
    /// The coordinates of the search point that move: $1 + j$ for the scale
    /// of input $j$.
    free: Vec<usize>,
    /// The residuals and their Jacobian (in $\log m_j$) at the point.
    at: LooJacobian,
    /// The damping $\mu$ (NaN: not yet set) and its growth factor $\nu$.
    mu: f64,
    nu: f64,
    /// The running maximum of the normal matrix's diagonal, per free
    /// coordinate (Marquardt's scaling, as MINPACK keeps it).
    diag: Vec<f64>,
    /// Whether the descent has ended (next: the inputs tried at zero).
    settled: bool,
}

impl Lm {
    /// The search over the nonzero scales of `x` from its residuals and
    /// Jacobian `at` (none: a point whose objective is not a number, from
    /// which nothing moves).
    pub(super) fn new(x: &[f64], at: Option<LooJacobian>) -> Self {
        let free: Vec<usize> = match at {
            Some(_) => (1..x.len()).filter(|&c| x[c] > 0.0).collect(),
            None => Vec::new(),
        };
        Self {
            diag: vec![0.0; free.len()],
            free,
            at: at.unwrap_or_default(),
            mu: f64::NAN,
            nu: 2.0,
            settled: false,
        }
    }

    /// A new descent over the free coordinates from the current point.
    fn restart(&mut self) {
        self.diag = vec![0.0; self.free.len()];
        self.mu = f64::NAN;
        self.nu = 2.0;
        self.settled = false;
    }

    /// Entry `(row, c)` of the Jacobian of the free coordinates.
    fn column(&self, d: usize, row: usize, c: usize) -> f64 {
        self.at.jacobian[row * d + self.free[c] - 1]
    }
}

impl Evaluator<'_> {
    /// The residuals and Jacobian at `x`, recorded in `history` as one
    /// evaluation (an error or a NaN objective: `None`, recorded as an
    /// infinite objective).
    pub(super) fn eval_jacobian(&mut self, x: &[f64], history: &mut Vec<TuneStep>) -> Option<LooJacobian> {
        let at = self.jacobian_at(x);
        self.record(x, at, history)
    }

    /// Records the outcome of [`jacobian_at`](Self::jacobian_at) at `x` as
    /// [`eval_jacobian`](Self::eval_jacobian) does.
    pub(super) fn record(
        &mut self,
        x: &[f64],
        at: Result<LooJacobian>,
        history: &mut Vec<TuneStep>,
    ) -> Option<LooJacobian> {
        let at = at.ok().filter(|at| !at.objective.is_nan());
        let objective = at.as_ref().map_or(f64::INFINITY, |at| at.objective);
        self.cache.insert(
            x.iter().map(|v| v.to_bits()).collect(),
            crate::loo::Objective::Exact(objective),
        );
        history.push(TuneStep {
            bandwidth: x[0],
            scales: x[1..].to_vec(),
            objective,
            accepted: false,
            complete: true,
        });
        at
    }

    /// The residuals and Jacobian at `x`, or the error of the settings.
    pub(super) fn jacobian_at(&self, x: &[f64]) -> Result<LooJacobian> {
        self.model.loo_jacobian(&self.settings_at(x), self.stride)
    }
}

impl TuneRun<'_> {
    /// From the compass search over the bandwidth to Levenberg-Marquardt
    /// over the scales: the residuals and Jacobian at the point (one
    /// evaluation), and every coordinate for the compass search's sweeps at
    /// the end.
    pub(super) fn lm_switch(&mut self, watch: &Watch<'_>) -> Option<TuneStatus> {
        self.lm_after = false;
        if let Some(why) = halted(self.history.len(), &self.tune, watch) {
            return Some(why);
        }
        let d = self.x.len() - 1;
        self.coords = std::iter::once(0).chain(1..=d).collect();
        let x = self.x.clone();
        let at = self.eval.eval_jacobian(&x, &mut self.history);
        if let Some(step) = self.history.last_mut() {
            step.accepted = true;
        }
        if let Some(at) = &at {
            self.f = at.objective;
        }
        self.lm = Some(Lm::new(&x, at));
        self.sweeps += 1;
        None
    }

    /// One iteration of the Levenberg-Marquardt search: a step accepted
    /// (after as many rejected trials as it takes), or, once a descent has
    /// ended, what follows it ([`lm_settled`](Self::lm_settled)); when it
    /// has converged, the compass search takes over for its last sweeps at
    /// [`FINISH_FACTOR`].
    pub(super) fn lm_iter(&mut self, watch: &Watch<'_>) -> Option<TuneStatus> {
        let mut lm = self.lm.take().expect("the Levenberg-Marquardt state");
        let status = if lm.settled {
            self.lm_settled(&mut lm, watch)
        } else {
            self.lm_descend(&mut lm, watch)
        };
        self.sweeps += 1;
        if status == Some(TuneStatus::Converged) {
            // the compass search's last sweeps from here
            self.factor = FINISH_FACTOR.clamp(self.tune.min_factor, self.tune.initial_factor);
            return None;
        }
        self.lm = Some(lm);
        status
    }

    /// Steps until one lowers the objective; ends the descent when the step
    /// or the decrease is negligible, or no damping gives a decrease.
    fn lm_descend(&mut self, lm: &mut Lm, watch: &Watch<'_>) -> Option<TuneStatus> {
        let d = self.x.len() - 1;
        let k = lm.free.len();
        if k == 0 {
            return Some(TuneStatus::Converged);
        }
        let rows = lm.at.residuals.len();
        // J^T J and J^T r over the free coordinates
        let mut h = vec![0.0; k * k];
        let mut g = vec![0.0; k];
        let mut col = vec![0.0; k];
        for row in 0..rows {
            for (c, v) in col.iter_mut().enumerate() {
                *v = lm.column(d, row, c);
            }
            let r = lm.at.residuals[row];
            for a in 0..k {
                g[a] += col[a] * r;
                for b in 0..=a {
                    h[a * k + b] += col[a] * col[b];
                }
            }
        }
        for a in 0..k {
            for b in 0..a {
                h[b * k + a] = h[a * k + b];
            }
            lm.diag[a] = lm.diag[a].max(h[a * k + a]);
        }
        let largest = lm.diag.iter().fold(0.0f64, |m, &v| m.max(v));
        if largest == 0.0 || g.iter().all(|&v| v == 0.0) {
            lm.settled = true;
            return None;
        }
        let floor = largest * 1e-12;
        if lm.mu.is_nan() {
            lm.mu = 1e-3;
        }
        let max_step = 2.0 * self.tune.initial_factor.ln();
        loop {
            if let Some(why) = halted(self.history.len(), &self.tune, watch) {
                return Some(why);
            }
            if lm.mu > MAX_DAMPING {
                lm.settled = true;
                return None;
            }
            let mut a = h.clone();
            for c in 0..k {
                a[c * k + c] += lm.mu * lm.diag[c].max(floor);
            }
            let mut step: Vec<f64> = g.iter().map(|v| -v).collect();
            if cholesky(&mut a, k).is_none() {
                lm.mu *= lm.nu;
                lm.nu *= 2.0;
                continue;
            }
            chol_solve(&a, k, &mut step);
            let longest = step.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if longest > max_step {
                step.iter_mut().for_each(|v| *v *= max_step / longest);
            }
            // the decrease the linear model predicts: -2 g.s - s^T H s
            let mut predicted = 0.0;
            for a in 0..k {
                let hs: f64 = (0..k).map(|b| h[a * k + b] * step[b]).sum();
                predicted -= 2.0 * g[a] * step[a] + step[a] * hs;
            }
            let mut y = self.x.clone();
            for (&c, s) in lm.free.iter().zip(&step) {
                y[c] *= s.exp();
            }
            let f = self.f;
            let trial = self.eval.eval_jacobian(&y, &mut self.history);
            let accepted = trial.filter(|t| t.objective < f);
            let Some(at) = accepted else {
                lm.mu *= lm.nu;
                lm.nu *= 2.0;
                continue;
            };
            let rho = if predicted > 0.0 {
                (f - at.objective) / predicted
            } else {
                0.0
            };
            lm.mu *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
            lm.nu = 2.0;
            if let Some(step) = self.history.last_mut() {
                step.accepted = true;
            }
            self.x = y;
            self.f = at.objective;
            lm.at = at;
            let longest = step.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if longest < STEP_FRACTION * self.tune.min_factor.ln() || f - self.f <= MIN_DECREASE * f {
                lm.settled = true;
            }
            return None;
        }
    }

    /// After a descent: from the bandwidth on to the scales; or, over the
    /// scales, tries each moving input at zero (dropped from the metric when
    /// the objective rises by less than `zero_tolerance`, relatively), in
    /// order: converged when none is dropped, else the descent starts again
    /// over the inputs left.
    fn lm_settled(&mut self, lm: &mut Lm, watch: &Watch<'_>) -> Option<TuneStatus> {
        if !self.tune.try_zero {
            return Some(TuneStatus::Converged);
        }
        let mut dropped = false;
        for c in lm.free.clone() {
            if let Some(why) = halted(self.history.len(), &self.tune, watch) {
                return Some(why);
            }
            let mut y = self.x.clone();
            y[c] = 0.0;
            let bound = self.f * (1.0 + self.tune.zero_tolerance);
            if let Some(fy) = self.try_point(y, bound, |fy| fy <= bound) {
                self.f = fy;
                lm.free.retain(|&f| f != c);
                dropped = true;
            }
        }
        if !dropped || lm.free.is_empty() {
            return Some(TuneStatus::Converged);
        }
        if let Some(why) = halted(self.history.len(), &self.tune, watch) {
            return Some(why);
        }
        let x = self.x.clone();
        match self.eval.eval_jacobian(&x, &mut self.history) {
            Some(at) => {
                self.f = at.objective;
                lm.at = at;
                lm.restart();
                None
            }
            None => Some(TuneStatus::Converged),
        }
    }
}
