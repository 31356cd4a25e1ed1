//! Powell's iteration: a sweep of line searches over the direction set,
//! the replacement test, the stopping tests and the restart on a bound.

use super::line_search::{Line, Search, feasible_interval, fill_trial};
use super::{PowellSettings, PowellStatus, invalid};
use crate::error::{TrajoptError, check_finite};

/// The state of one Powell run, shared by [`Powell::solve`](super::Powell::solve)
/// and [`PowellArgmin`](super::PowellArgmin).
#[derive(Debug, Clone)]
pub(super) struct Engine {
    pub(super) n: usize,
    pub(super) x: Vec<f64>,
    pub(super) fx: f64,
    /// Row-major $n \times n$: row $i$ is direction $u_i$.
    pub(super) dirs: Vec<f64>,
    /// The first bracketing trial along each direction: the step length
    /// accepted by the last line search along it ($1$ at the start).
    steps: Vec<f64>,
    /// $\phi''(\alpha)$ along each direction from its last line search
    /// (NaN: unknown).
    curvatures: Vec<f64>,
    x_start: Vec<f64>,
    new_dir: Vec<f64>,
    trial: Vec<f64>,
    bounds: Option<(Vec<f64>, Vec<f64>)>,
    pub(super) evals: usize,
    pub(super) iters: usize,
    max_iterations: usize,
    max_evals: usize,
    tol_step: f64,
    tol_cost: f64,
    tol_line: f64,
    initial_step: f64,
    /// `settings.principal_axes`.
    principal_axes: usize,
    /// A stopping test fired on the last sweep and the direction set was
    /// reset: the next sweep confirms (or refutes) the convergence.
    confirming: bool,
    /// The curvature along the new direction from its line search.
    new_curvature: f64,
    /// `settings.stop_cost` ($-\infty$ for none).
    stop_cost: f64,
    /// An evaluation reached `stop_cost`.
    reached: bool,

    /// The decrease of the last iteration ($+\infty$ before the first).
    last_decrease: f64,

    pub(super) status: Option<PowellStatus>,
}

/// Largest ratio of successive decreases the tail estimate of the
/// stopping test assumes: the decrease still to come is taken as at most
/// $1 / (1 - 0.99) = 100$ times the last.
const MAX_RATIO: f64 = 0.99;

enum Which {
    Row(usize),
    New,
}

impl Engine {
    pub(super) fn start<F, E>(settings: &PowellSettings, x0: &[f64], eval: &mut F) -> std::result::Result<Self, E>
    where
        F: FnMut(&Vec<f64>) -> std::result::Result<f64, E>,
        E: From<TrajoptError>,
    {
        settings.validate()?;
        let n = x0.len();
        if n == 0 {
            return Err(invalid("x0", "the start point is empty").into());
        }
        check_finite("x0", x0)?;
        let mut x = x0.to_vec();
        if let Some((lower, upper)) = &settings.bounds {
            if lower.len() != n {
                return Err(TrajoptError::DimensionMismatch {
                    what: "bounds",
                    expected: n,
                    actual: lower.len(),
                }
                .into());
            }
            for ((t, &l), &u) in x.iter_mut().zip(lower).zip(upper) {
                *t = t.max(l).min(u);
            }
        }
        let fx = eval(&x)?;
        if !fx.is_finite() {
            return Err(TrajoptError::NonFiniteStart { value: fx }.into());
        }
        let mut dirs = vec![0.0; n * n];
        for i in 0..n {
            dirs[i * n + i] = settings.initial_step;
        }
        Ok(Self {
            n,
            trial: x.clone(),
            x_start: x.clone(),
            new_dir: vec![0.0; n],
            x,
            fx,
            dirs,
            steps: vec![1.0; n],
            curvatures: vec![f64::NAN; n],
            bounds: settings.bounds.clone(),
            evals: 1,
            iters: 0,
            max_iterations: settings.max_iterations.unwrap_or(1000 * n),
            max_evals: settings.max_evals.unwrap_or(1000 * n),
            tol_step: settings.tol_step,
            tol_cost: settings.tol_cost,
            tol_line: settings.tol_line,
            initial_step: settings.initial_step,
            principal_axes: settings.principal_axes,
            confirming: false,
            new_curvature: f64::NAN,
            stop_cost: settings.stop_cost.unwrap_or(f64::NEG_INFINITY),
            reached: settings.stop_cost.is_some_and(|stop| fx <= stop),
            last_decrease: f64::INFINITY,
            status: None,
        })
    }

    /// One line minimisation along a stored direction from the current point;
    /// moves there if the cost went down. Returns the step length.
    fn line_search<F, E>(
        &mut self,
        which: Which,
        known: Option<(f64, f64)>,
        eval: &mut F,
    ) -> std::result::Result<f64, E>
    where
        F: FnMut(&Vec<f64>) -> std::result::Result<f64, E>,
    {
        let n = self.n;
        let (dir, step, curvature) = match which {
            Which::Row(i) => (&self.dirs[i * n..(i + 1) * n], self.steps[i], self.curvatures[i]),
            Which::New => (&self.new_dir[..], 1.0, f64::NAN),
        };
        let curvature = curvature.is_finite().then_some(curvature);
        let bounds = self.bounds.as_ref();
        let (lo, hi) = feasible_interval(&self.x, dir, bounds);
        let mut line = Line {
            origin: &self.x,
            dir,
            bounds,
            trial: &mut self.trial,
            eval,
            evals: &mut self.evals,
            max_evals: self.max_evals,
            stop_cost: self.stop_cost,
            hit: None,
        };
        let (alpha, f, c) = line.minimise_or_hit(Search {
            f0: self.fx,
            lo,
            hi,
            step,
            known,
            curvature,
            tol: self.tol_line,
        })?;
        self.reached |= line.hit.is_some();
        match which {
            Which::Row(i) => self.curvatures[i] = c,
            Which::New => self.new_curvature = c,
        }
        if alpha != 0.0 && f < self.fx {
            if let Which::Row(i) = which {
                self.steps[i] = alpha;
            }
            // the same arithmetic as the evaluated trial: bit-identical point
            fill_trial(&mut self.trial, &self.x, dir, alpha, bounds);
            self.x.copy_from_slice(&self.trial);
            self.fx = f;
            Ok(alpha)
        } else {
            Ok(0.0)
        }
    }

    /// One iteration; returns the status once finished.
    pub(super) fn iterate<F, E>(&mut self, eval: &mut F) -> std::result::Result<Option<PowellStatus>, E>
    where
        F: FnMut(&Vec<f64>) -> std::result::Result<f64, E>,
    {
        if let Some(status) = self.status {
            return Ok(Some(status));
        }
        let n = self.n;
        let f_start = self.fx;
        self.x_start.copy_from_slice(&self.x);
        let (mut biggest, mut delta) = (0, 0.0);
        for i in 0..n {
            if self.reached {
                break;
            }
            let f_before = self.fx;
            self.line_search(Which::Row(i), None, eval)?;
            if f_before - self.fx > delta {
                delta = f_before - self.fx;
                biggest = i;
            }
        }
        self.iters += 1;
        match self.check(f_start) {
            Some(status) if !status.is_converged() || self.confirming => {
                // out of budget, or the test held again on the sweep over
                // the fresh coordinate set
                self.status = Some(status);
                return Ok(Some(status));
            }
            Some(_) => {
                // not yet a convergence: confirm it on a fresh set
                self.restart();
                self.confirming = true;
            }
            None => {
                self.confirming = false;
                self.replace_direction(f_start, delta, biggest, eval)?;
                if self.principal_axes > 0 && self.iters.is_multiple_of(self.principal_axes) {
                    self.reset_to_principal_axes();
                }
            }
        }
        self.last_decrease = f_start - self.fx;
        let status = if self.evals >= self.max_evals {
            Some(PowellStatus::MaxEvaluations)
        } else if self.iters >= self.max_iterations {
            Some(PowellStatus::MaxIterations)
        } else {
            None
        };
        self.status = status;
        Ok(status)
    }

    /// Powell's replacement step after a sweep from `x_start` (cost
    /// `f_start`) whose largest single decrease `delta` was along direction
    /// `biggest`.
    fn replace_direction<F, E>(
        &mut self,
        f_start: f64,
        delta: f64,
        biggest: usize,
        eval: &mut F,
    ) -> std::result::Result<(), E>
    where
        F: FnMut(&Vec<f64>) -> std::result::Result<f64, E>,
    {
        let n = self.n;
        // the extrapolated point x_n + d, d = x_n - x_0, pulled back into the box
        for ((d, &x), &x0) in self.new_dir.iter_mut().zip(&self.x).zip(&self.x_start) {
            *d = x - x0;
        }
        let (_, hi) = feasible_interval(&self.x, &self.new_dir, self.bounds.as_ref());
        let reach = hi.min(1.0);
        if reach <= 0.0 || self.evals >= self.max_evals || self.reached {
            return Ok(());
        }
        fill_trial(&mut self.trial, &self.x, &self.new_dir, reach, self.bounds.as_ref());
        self.evals += 1;
        let fe = eval(&self.trial)?;
        let fe = if fe.is_finite() { fe } else { f64::INFINITY };
        let fx = self.fx;
        if fe <= self.stop_cost {
            self.reached = true;
            if fe < fx {
                self.x.copy_from_slice(&self.trial);
                self.fx = fe;
            }
            return Ok(());
        }
        if fe >= f_start {
            return Ok(());
        }
        let t = 2.0 * (f_start - 2.0 * fx + fe) * (f_start - fx - delta).powi(2) - delta * (f_start - fe).powi(2);
        if t >= 0.0 {
            if fe < fx {
                // keep the set, but not a better point already paid for
                self.x.copy_from_slice(&self.trial);
                self.fx = fe;
            }
            return Ok(());
        }
        let alpha = self.line_search(Which::New, Some((reach, fe)), eval)?;
        if alpha != 0.0 {
            for d in &mut self.new_dir {
                *d *= alpha;
            }
            // u_m <- u_n, u_n <- alpha d
            self.dirs.copy_within((n - 1) * n..n * n, biggest * n);
            self.dirs[(n - 1) * n..].copy_from_slice(&self.new_dir);
            self.steps[biggest] = self.steps[n - 1];
            self.steps[n - 1] = 1.0;
            self.curvatures[biggest] = self.curvatures[n - 1];
            // phi along alpha d: the curvature along d times alpha^2
            self.curvatures[n - 1] = self.new_curvature * alpha * alpha;
        }
        Ok(())
    }

    /// Replaces the direction set by the principal axes of the quadratic
    /// model it implies (Brent 1973, PRAXIS). If the directions $u_i$ are
    /// conjugate with curvatures $c_i = u_i^\top H u_i$ (the last line
    /// searches' $\phi''$), then $H^{-1} = \sum_i u_i u_i^\top / c_i = M M^\top$
    /// with $M = [u_i / \sqrt{c_i}]$; the singular value decomposition
    /// $M = U S W^\top$ gives $H^{-1} = U S^2 U^\top$, so the new directions
    /// are $s_i U_i$, orthogonal, each of curvature 1 in the model (the
    /// line search's first parabola). Returns false, and keeps the set,
    /// while a curvature is unknown or not positive.
    fn reset_to_principal_axes(&mut self) -> bool {
        let n = self.n;
        if !self.curvatures.iter().all(|c| c.is_finite() && *c > 0.0) {
            return false;
        }
        let m = faer::Mat::from_fn(n, n, |r, i| self.dirs[i * n + r] / self.curvatures[i].sqrt());
        let Ok(svd) = m.svd() else {
            return false;
        };
        let (u, s) = (svd.U(), svd.S().column_vector());
        let largest = (0..n).map(|i| s[i]).fold(0.0, f64::max);
        if !(largest.is_finite() && largest > 0.0) {
            return false;
        }
        for i in 0..n {
            // a (nearly) null axis: the set had lost a dimension; search it
            // anew at the scale of the others, its curvature unknown
            let (scale, curvature) = if s[i] > 1e-8 * largest {
                (s[i], 1.0)
            } else {
                (1e-8 * largest, f64::NAN)
            };
            for r in 0..n {
                self.dirs[i * n + r] = u[(r, i)] * scale;
            }
            self.curvatures[i] = curvature;
            self.steps[i] = 1.0;
        }
        true
    }

    /// Resets the direction set to the initial (coordinate) directions and
    /// the first trials to 1.
    fn restart(&mut self) {
        let n = self.n;
        self.dirs.fill(0.0);
        for i in 0..n {
            self.dirs[i * n + i] = self.initial_step;
        }
        self.steps.fill(1.0);
        self.curvatures.fill(f64::NAN);
    }

    /// The tests after the direction sweep.
    fn check(&self, f_start: f64) -> Option<PowellStatus> {
        let fx = self.fx;
        if self.reached {
            return Some(PowellStatus::ReachedStopCost);
        }
        if self.evals >= self.max_evals {
            // the sweep may have been cut short: not a convergence
            return Some(PowellStatus::MaxEvaluations);
        }
        // the decrease still to come if the decreases keep shrinking by the
        // ratio r of the last two (a geometric tail), r at most MAX_RATIO
        let decrease = f_start - fx;
        let r = if self.last_decrease > 0.0 {
            (decrease / self.last_decrease).min(MAX_RATIO)
        } else {
            0.0
        };
        let tail = decrease / (1.0 - r);
        if 2.0 * tail <= self.tol_cost * (f_start.abs() + fx.abs()) + 1e-20 {
            return Some(PowellStatus::ConvergedCost);
        }
        let small_step = self
            .x
            .iter()
            .zip(&self.x_start)
            .all(|(&x, &x0)| (x - x0).abs() <= self.tol_step * (1.0 + x.abs()));
        small_step.then_some(PowellStatus::ConvergedStep)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Result;

    /// On a quadratic $\tfrac12 x^\top H x$, a set of conjugate directions
    /// with their exact curvatures becomes $H$'s principal axes: orthogonal,
    /// each of curvature 1, and conjugate; a set with an unknown curvature
    /// is kept.
    #[test]
    fn principal_axes_of_a_conjugate_set_are_the_hessians_axes() {
        // H = [[4, 1], [1, 2]]: conjugate pair u1 = e1, u2 = (-1/4, 1)
        let h = [[4.0, 1.0], [1.0, 2.0]];
        let quad =
            |u: &[f64], v: &[f64]| -> f64 { (0..2).map(|i| (0..2).map(|j| u[i] * h[i][j] * v[j]).sum::<f64>()).sum() };
        let mut eval = |x: &Vec<f64>| -> Result<f64> { Ok(0.5 * quad(x, x)) };
        let mut engine = Engine::start(&PowellSettings::default(), &[1.0, 1.0], &mut eval).expect("start");
        let (u1, u2) = ([1.0, 0.0], [-0.25, 1.0]);
        assert!(quad(&u1, &u2).abs() < 1e-15);
        engine.dirs = vec![u1[0], u1[1], u2[0], u2[1]];
        engine.curvatures = vec![f64::NAN, quad(&u2, &u2)];
        let before = engine.dirs.clone();
        assert!(!engine.reset_to_principal_axes());
        assert_eq!(engine.dirs, before);
        engine.curvatures = vec![quad(&u1, &u1), quad(&u2, &u2)];
        assert!(engine.reset_to_principal_axes());
        let (a, b) = (&engine.dirs[..2], &engine.dirs[2..]);
        assert!((a[0] * b[0] + a[1] * b[1]).abs() < 1e-12, "not orthogonal: {a:?} {b:?}");
        assert!(quad(a, b).abs() < 1e-12, "not conjugate: {a:?} {b:?}");
        for d in [a, b] {
            assert!((quad(d, d) - 1.0).abs() < 1e-12, "curvature {} along {d:?}", quad(d, d));
        }
        assert_eq!(engine.curvatures, vec![1.0, 1.0]);
    }

    #[test]
    fn first_trials_are_the_last_accepted_steps() {
        // separable: one sweep along the coordinates lands on c, with the
        // steps c_i; a second sweep then starts each search at c_i
        let c = [0.5, -2.0, 3.0];
        let mut eval = |x: &Vec<f64>| -> Result<f64> { Ok(x.iter().zip(&c).map(|(x, c)| (x - c).powi(2)).sum()) };
        let mut engine = Engine::start(&PowellSettings::default(), &[0.0; 3], &mut eval).expect("start");
        assert_eq!(engine.steps, vec![1.0; 3]);
        engine.iterate(&mut eval).expect("sweep");
        for (step, c) in engine.steps.iter().zip(&c) {
            assert!((step - c).abs() < 1e-6, "{:?}", engine.steps);
        }
    }
}
