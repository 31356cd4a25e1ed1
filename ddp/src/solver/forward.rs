//! Rollouts: the open-loop rollout of the warm start and the closed-loop
//! trial rollouts of the line search.

use super::work::Work;
use crate::error::Result;
use crate::problem::{Cost, Dynamics};

/// Why a forward rollout failed.
pub(super) enum Rollout {
    /// A finite rollout and its cost.
    Ok(f64),
    /// The rollout blew up at this state index.
    Diverged(usize),
}

impl<D: Dynamics, C: Cost> Work<'_, D, C> {
    /// Open-loop rollout of `self.us` into `self.xs`.
    ///
    /// # Errors
    /// The dynamics' error if a step fails (there is no iterate to return).
    pub(super) fn initial_rollout(&mut self) -> Result<Rollout> {
        self.evals += 1;
        let (n, m) = (self.n, self.m);
        let (dynamics, cost) = (self.p.dynamics(), self.p.cost());
        self.xs[..n].copy_from_slice(self.p.initial_state());
        let mut total = 0.0;
        for k in 0..self.horizon {
            let (cur, next) = self.xs[k * n..(k + 2) * n].split_at_mut(n);
            let u = &self.us[k * m..(k + 1) * m];
            let l = cost.running(k, cur, u);
            self.stage[k] = l;
            total += l;
            dynamics.step(cur, u, next)?;
            if self.diverged(&self.xs[(k + 1) * n..(k + 2) * n]) {
                return Ok(Rollout::Diverged(k + 1));
            }
        }
        let lf = cost.terminal(&self.xs[self.horizon * n..]);
        self.stage[self.horizon] = lf;
        total += lf;
        Ok(if total.is_finite() {
            Rollout::Ok(total)
        } else {
            Rollout::Diverged(self.horizon)
        })
    }

    /// Closed-loop rollout with step size `alpha` into the `_try` buffers. A
    /// step of the dynamics that fails counts as a blow-up at that step.
    pub(super) fn forward(&mut self, alpha: f64) -> Rollout {
        self.evals += 1;
        let (n, m) = (self.n, self.m);
        let (dynamics, cost) = (self.p.dynamics(), self.p.cost());
        self.xs_try[..n].copy_from_slice(&self.xs[..n]);
        let mut total = 0.0;
        for k in 0..self.horizon {
            for j in 0..n {
                self.dx[j] = self.xs_try[k * n + j] - self.xs[k * n + j];
            }
            for i in 0..m {
                let row = &self.gain[(k * m + i) * n..(k * m + i + 1) * n];
                let fb: f64 = row.iter().zip(&self.dx).map(|(a, b)| a * b).sum();
                let u = self.us[k * m + i] + alpha * self.kff[k * m + i] + fb;
                self.us_try[k * m + i] = u.clamp(self.lower[i], self.upper[i]);
            }
            let (cur, next) = self.xs_try[k * n..(k + 2) * n].split_at_mut(n);
            let u = &self.us_try[k * m..(k + 1) * m];
            let l = cost.running(k, cur, u);
            self.stage_try[k] = l;
            total += l;
            if dynamics.step(cur, u, next).is_err() || self.diverged(&self.xs_try[(k + 1) * n..(k + 2) * n]) {
                return Rollout::Diverged(k + 1);
            }
        }
        let lf = cost.terminal(&self.xs_try[self.horizon * n..]);
        self.stage_try[self.horizon] = lf;
        total += lf;
        if total.is_finite() {
            Rollout::Ok(total)
        } else {
            Rollout::Diverged(self.horizon)
        }
    }
}
