//! One Gauss-Newton / LM iteration over its state, as [`solve::drive`]
//! runs it: assemble the normal equations, test the gradient, then raise
//! the damping until a step is accepted (or a stopping test passes). The
//! set-up (the start, the bounds' projection, the back end's choice) and
//! the result are in `mod.rs`.

use super::damping::{
    self, ACCURATE, PROBE, SHIFT_DECREASE, SHIFT_DECREASE_ACCURATE, SHIFT_INCREASE, SHIFT_MAX, SHIFT_MIN,
    lower_damping, raise_damping,
};
use super::geodesic::{Acceleration, Geodesic};
use super::normal_equations::{BandSystem, Damping, NormalEquations, sum_sq};
use super::trust_region::TrustRegion;
use super::{DampingScale, EvalCount, GaussNewtonSettings, GaussNewtonStatus, NAME};
use crate::error::{Result, TrajoptError};
use crate::least_squares::{BandForm, LeastSquaresProblem, LinearBounds, Point};
use crate::linalg::BandLayout;
use solve::Watch;

/// The state of one solve between iterations.
pub(super) struct Iteration<'a, P: LeastSquaresProblem + ?Sized> {
    pub(super) problem: &'a P,
    pub(super) settings: &'a GaussNewtonSettings,
    pub(super) bounds: Option<&'a LinearBounds>,
    /// The bounds as a box on the parameters, when they are one: kept by
    /// projected Newton steps ([`super::box_qp`]) instead of a QP.
    box_bounds: Option<(Vec<f64>, Vec<f64>)>,
    /// The box relative to the current point, $l - \theta$ and $u - \theta$.
    box_lo: Vec<f64>,
    box_hi: Vec<f64>,
    /// The band form and its layout, kept to go on with one thread when the
    /// helpers wait for cores.
    pub(super) band_layout: Option<(&'a dyn BandForm, BandLayout)>,
    /// Counts the evaluations the observers see, when not `residual_evals`
    /// (the derivative-free mode's).
    pub(super) evaluations: Option<&'a dyn EvalCount>,
    pub(super) system: Box<dyn NormalEquations<P> + 'a>,
    /// The iteration from which the solve went on with one thread.
    pub(super) one_thread_from: Option<usize>,
    pub(super) theta: Vec<f64>,
    pub(super) r: Vec<f64>,
    pub(super) cost: f64,
    pub(super) residual_evals: usize,
    pub(super) jacobian_evals: usize,
    pub(super) factorizations: usize,
    pub(super) iterations: usize,
    pub(super) cost_history: Vec<f64>,
    grad: Vec<f64>,
    scale: Vec<f64>,
    /// The largest diag(J^T J) seen so far, per parameter.
    scale_max: Vec<f64>,
    /// diag(J^T J) at the current point, when the scale may differ from it.
    jtj_diag: Vec<f64>,
    /// The trust region, when the steps are trust-region steps.
    trust: Option<TrustRegion>,
    /// Geodesic acceleration's buffers, when the steps are accelerated.
    geodesic: Option<Geodesic>,
    step: Vec<f64>,
    h_step: Vec<f64>,
    trial: Vec<f64>,
    r_trial: Vec<f64>,
    mu: f64,
    nu: f64,
    /// The shift making J^T J + S positive definite, relative to D.
    shift: f64,
    /// Whether the last accepted step was a Newton step whose reduction
    /// the model predicted within ACCURATE (relative).
    accurate: bool,
    /// Adaptive: whether the model is chosen per iteration.
    adaptive: bool,
    /// Adaptive: which model the next iteration uses.
    prefer_newton: bool,
    /// Whether the problem has given S yet (no probes before: a problem
    /// without second derivatives takes Gauss-Newton steps at no extra
    /// cost).
    s_seen: bool,
    /// Adaptive: the residuals on either side of a step (its curvature
    /// probe).
    r_plus: Vec<f64>,
    r_minus: Vec<f64>,
}

/// What [`Iteration::new`] takes from the set-up.
pub(super) struct Start<'a, P: LeastSquaresProblem + ?Sized> {
    pub(super) problem: &'a P,
    pub(super) settings: &'a GaussNewtonSettings,
    pub(super) band_layout: Option<(&'a dyn BandForm, BandLayout)>,
    pub(super) evaluations: Option<&'a dyn EvalCount>,
    pub(super) system: Box<dyn NormalEquations<P> + 'a>,
    pub(super) theta: Vec<f64>,
    pub(super) r: Vec<f64>,
    pub(super) cost: f64,
    pub(super) residual_evals: usize,
}

impl<'a, P: LeastSquaresProblem + ?Sized> Iteration<'a, P> {
    /// The state before the first iteration.
    pub(super) fn new(start: Start<'a, P>) -> Self {
        let (n_p, n_r) = (start.theta.len(), start.r.len());
        let s = start.settings;
        let bounds = start.problem.bounds();
        let adaptive = s.adaptive() && bounds.is_none();
        let box_bounds = bounds.and_then(|b| b.as_box(n_p));
        let (r_plus, r_minus) = if adaptive {
            (vec![0.0; n_r], vec![0.0; n_r])
        } else {
            (Vec::new(), Vec::new())
        };
        Self {
            problem: start.problem,
            settings: s,
            bounds,
            box_lo: if box_bounds.is_some() {
                vec![0.0; n_p]
            } else {
                Vec::new()
            },
            box_hi: if box_bounds.is_some() {
                vec![0.0; n_p]
            } else {
                Vec::new()
            },
            box_bounds,
            band_layout: start.band_layout,
            evaluations: start.evaluations,
            system: start.system,
            one_thread_from: None,
            theta: start.theta,
            r: start.r,
            cost: start.cost,
            residual_evals: start.residual_evals,
            jacobian_evals: 0,
            factorizations: 0,
            iterations: 0,
            cost_history: Vec::new(),
            grad: vec![0.0; n_p],
            scale: vec![0.0; n_p],
            scale_max: vec![0.0; n_p],
            jtj_diag: vec![0.0; n_p],
            trust: (s.trust_region() && bounds.is_none()).then(|| TrustRegion::new(n_p)),
            geodesic: (s.trust_region() && s.geodesic_acceleration && bounds.is_none())
                .then(|| Geodesic::new(n_p, n_r)),
            step: vec![0.0; n_p],
            h_step: vec![0.0; n_p],
            trial: vec![0.0; n_p],
            r_trial: vec![0.0; n_r],
            mu: s.initial_damping,
            nu: 2.0,
            shift: 0.0,
            accurate: false,
            adaptive,
            prefer_newton: true,
            s_seen: false,
            r_plus,
            r_minus,
        }
    }
}

impl<P: LeastSquaresProblem + ?Sized> Iteration<'_, P> {
    /// Whether the damping outweighs the model's curvature (then a
    /// negligible step is a stall, not convergence): $\mu \ge 1$ relative
    /// to $D = \operatorname{diag}(J^\top J)$, or, with another scale or a
    /// trust region, $\mu D_j \ge (J^\top J)_{jj}$ for some $j$.
    fn damping_dominates(&self) -> bool {
        let mu = match &self.trust {
            Some(trust) => trust.lambda,
            None if self.settings.damping_scale != DampingScale::Identity => return self.mu >= 1.0,
            None => self.mu,
        };
        let diag = if self.settings.damping_scale == DampingScale::Identity {
            &self.jtj_diag
        } else {
            // the scale is diag(J^T J) or its running maximum
            &self.scale
        };
        mu > 0.0
            && self
                .scale
                .iter()
                .zip(diag)
                .any(|(d, a)| mu * d >= a.max(f64::MIN_POSITIVE))
    }
}

impl<P: LeastSquaresProblem + ?Sized> solve::Iterate for Iteration<'_, P> {
    type Status = GaussNewtonStatus;
    type Error = TrajoptError;
    const NAME: &'static str = NAME;

    fn next_iter(&mut self, watch: &Watch<'_>) -> Result<Option<GaussNewtonStatus>> {
        let (problem, s, bounds, adaptive) = (self.problem, self.settings, self.bounds, self.adaptive);
        let (n_p, n_r) = (self.theta.len(), self.r.len());
        if self.iterations >= s.max_iterations {
            return Ok(Some(GaussNewtonStatus::MaxIterations));
        }
        if let (true, true, Some((form, layout))) =
            (s.one_thread_fallback, self.system.helpers_degraded(), &self.band_layout)
        {
            // the helpers wait for cores (a busy machine): one thread is faster
            self.one_thread_from = Some(self.iterations + 1);
            self.system = Box::new(BandSystem::new(*form, layout.clone(), s.second_order(), None));
        }
        if let Some(why) = watch.out_of_time() {
            return Ok(Some(why.into()));
        }
        self.iterations += 1;
        self.jacobian_evals += 1;
        let want_s = !adaptive || self.prefer_newton;
        let Some(mut newton) = self.system.assemble(
            problem,
            Point {
                theta: &self.theta,
                r: &self.r,
            },
            &mut self.grad,
            want_s,
        )?
        else {
            return Ok(Some(GaussNewtonStatus::NumericalError));
        };
        self.s_seen |= newton;
        // the damping scale: diag(J^T J) now, or its running maximum (positive)
        self.system.jtj_diagonal(&mut self.scale);
        match s.damping_scale {
            DampingScale::RunningMax => damping::running_max_scale(&mut self.scale, &mut self.scale_max),
            DampingScale::Identity => {
                self.jtj_diag.copy_from_slice(&self.scale);
                self.scale.fill(1.0);
            }
            _ => {
                for d in &mut self.scale {
                    *d = d.max(1e-12);
                }
            }
        }
        let g_inf = self.grad.iter().fold(0.0f64, |a, g| a.max(g.abs()));
        if g_inf <= s.tol_grad * self.cost.max(1.0) {
            return Ok(Some(GaussNewtonStatus::ConvergedGradient));
        }

        // inner loop: raise the damping until a step is accepted
        if newton {
            self.shift *= if self.accurate {
                SHIFT_DECREASE * SHIFT_DECREASE_ACCURATE
            } else {
                SHIFT_DECREASE
            };
        }
        loop {
            let damping = Damping {
                newton,
                total: if newton { self.mu + self.shift } else { self.mu },
                scale: &self.scale,
            };
            let solved = match (bounds, &self.box_bounds) {
                // a box: the damped model minimised in it by projected Newton steps
                (Some(_), Some((lower, upper))) => {
                    for k in 0..n_p {
                        self.box_lo[k] = (lower[k] - self.theta[k]).min(0.0);
                        self.box_hi[k] = (upper[k] - self.theta[k]).max(0.0);
                    }
                    self.factorizations += 1;
                    self.system.as_sparse().is_some_and(|sparse| {
                        sparse.box_step(damping, &self.grad, &self.box_lo, &self.box_hi, &mut self.step)
                    })
                }
                // general linear bounds: the damped model minimised subject to them (a QP)
                (Some(b), None) => self
                    .system
                    .as_sparse()
                    .is_some_and(|sparse| sparse.bounded_step(damping, &self.grad, b, &self.theta, &mut self.step)),
                (None, _) if self.trust.is_some() => {
                    let trust = self.trust.as_mut().expect("checked");
                    let spent = trust.step(&mut *self.system, &self.grad, &self.scale, &self.theta, &mut self.step);
                    self.factorizations += spent.unwrap_or(1);
                    if spent.is_none() {
                        return Ok(Some(GaussNewtonStatus::NumericalError));
                    }
                    true
                }
                (None, _) => {
                    self.factorizations += 1;
                    for (d, g) in self.step.iter_mut().zip(&self.grad) {
                        *d = -g;
                    }
                    self.system.damped_step(damping, &mut self.step)
                }
            };
            if !(solved && self.step.iter().all(|v| v.is_finite())) {
                if newton {
                    // J^T J + S + mu D is indefinite: shift it, or
                    // take a Gauss-Newton step if it takes a large shift
                    self.shift = (self.shift * SHIFT_INCREASE).max(SHIFT_MIN);
                    if self.shift > SHIFT_MAX {
                        newton = false;
                        if !self.system.ensure_gauss_newton(
                            problem,
                            Point {
                                theta: &self.theta,
                                r: &self.r,
                            },
                        )? {
                            return Ok(Some(GaussNewtonStatus::NumericalError));
                        }
                    }
                    continue;
                }
                // not positive definite: more damping
                if !raise_damping(&mut self.mu, &mut self.nu) {
                    return Ok(Some(GaussNewtonStatus::NumericalError));
                }
                continue;
            }
            let step_norm = sum_sq(&self.step).sqrt();
            let theta_norm = sum_sq(&self.theta).sqrt();
            if step_norm <= s.tol_step * (theta_norm + s.tol_step) {
                // a negligible step is convergence only if the damping did
                // not force it: with mu >= 1 the damping term outweighs the
                // curvature and the gradient is still large
                return Ok(Some(if !self.damping_dominates() {
                    GaussNewtonStatus::ConvergedStep
                } else {
                    GaussNewtonStatus::Stalled
                }));
            }
            if let Some(geodesic) = &mut self.geodesic {
                let lambda = self.trust.as_ref().map_or(self.mu, |t| t.lambda);
                let at = Point {
                    theta: &self.theta,
                    r: &self.r,
                };
                let (outcome, spent) =
                    geodesic.accelerate(&mut *self.system, problem, at, lambda, &self.scale, &mut self.step)?;
                self.residual_evals += spent.residuals;
                self.factorizations += spent.factorizations;
                if outcome == Acceleration::Rejected {
                    // the step bends too much for its model: a smaller region
                    let length = TrustRegion::length(&self.step, &self.scale);
                    let slope: f64 = self.step.iter().zip(&self.grad).map(|(d, g)| d * g).sum();
                    if let Some(trust) = &mut self.trust {
                        trust.update(-1.0, length, self.cost, self.cost, slope);
                    }
                    if let Some(why) = watch.out_of_time() {
                        return Ok(Some(why.into()));
                    }
                    continue;
                }
            }
            // L(d) = |r + J d|^2 = F + 2 g.d + d.H.d: predicted reduction L(0) - L(d)
            // (with S, the second-order Taylor model of F)
            self.system.model_mul(newton, &self.step, &mut self.h_step);
            // (summed as d.(2g + Hd), term by term: the damping rule's
            // iterates stay those of earlier versions bit for bit, which the
            // seeded learning runs and the saved benchmark instance rely on)
            let predicted: f64 = -self
                .step
                .iter()
                .zip(self.grad.iter().zip(&self.h_step))
                .map(|(d, (g, hd))| d * (2.0 * g + hd))
                .sum::<f64>();
            // the (barely damped) model has nothing left to gain: this step
            // is the last (further ones would only compare rounding
            // errors). It is still taken: a predicted gain of tol_cost F
            // leaves the parameters about sqrt(tol_cost) from the minimum
            // along a valley, and one more evaluation closes most of that
            // (scipy's ftol, likewise, is tested after its step)
            let last = predicted >= 0.0 && predicted <= s.tol_cost * self.cost && !self.damping_dominates();
            for j in 0..n_p {
                self.trial[j] = self.theta[j] + self.step[j];
            }
            if let Some((lower, upper)) = &self.box_bounds {
                // theta + (l - theta) may round past l
                for j in 0..n_p {
                    self.trial[j] = self.trial[j].max(lower[j]).min(upper[j]);
                }
            }
            self.system.residuals(problem, &self.trial, &mut self.r_trial)?;
            self.residual_evals += 1;
            let trial_cost = sum_sq(&self.r_trial);
            let rho = if predicted > 0.0 && trial_cost.is_finite() {
                (self.cost - trial_cost) / predicted
            } else {
                -1.0
            };
            if let Some(trust) = &mut self.trust {
                // g.d, the slope along the step, for the radius's rule
                let slope: f64 = self.step.iter().zip(&self.grad).map(|(d, g)| d * g).sum();
                let length = TrustRegion::length(&self.step, &self.scale);
                trust.update(rho, length, self.cost, trial_cost, slope);
            }
            // whether `trial` was overwritten by curvature probes
            let mut probes_in_trial = false;
            if adaptive && self.s_seen && trial_cost.is_finite() {
                // delta^T S delta = sum_i r_i delta^T (grad^2 r_i) delta: from the
                // problem, or by central differences of r along the step
                let exact = problem
                    .second_order()
                    .and_then(|so| so.form(&self.theta, &self.r, &self.step).ok().flatten());
                let s_form = match exact {
                    Some(form) => form,
                    None => {
                        probes_in_trial = true;
                        let mut probed = true;
                        for (sign, out) in [(1.0, &mut self.r_plus), (-1.0, &mut self.r_minus)] {
                            for j in 0..n_p {
                                self.trial[j] = self.theta[j] + sign * PROBE * self.step[j];
                            }
                            probed &= problem.residuals(&self.trial, out).is_ok();
                        }
                        self.residual_evals += 2;
                        if probed {
                            (0..n_r)
                                .map(|i| self.r[i] * (self.r_plus[i] - 2.0 * self.r[i] + self.r_minus[i]))
                                .sum::<f64>()
                                / (PROBE * PROBE)
                        } else {
                            f64::NAN
                        }
                    }
                };
                if s_form.is_finite() {
                    self.prefer_newton = damping::prefer_newton(newton, predicted, s_form, self.cost - trial_cost);
                }
            }
            if rho > 0.0 && trial_cost.is_finite() && trial_cost <= self.cost {
                let decrease = self.cost - trial_cost;
                if probes_in_trial {
                    for j in 0..n_p {
                        self.trial[j] = self.theta[j] + self.step[j];
                    }
                }
                std::mem::swap(&mut self.theta, &mut self.trial);
                std::mem::swap(&mut self.r, &mut self.r_trial);
                self.cost = trial_cost;
                self.cost_history.push(self.cost);
                if self.trust.is_none() {
                    lower_damping(&mut self.mu, rho);
                }
                self.accurate = newton && (rho - 1.0).abs() < ACCURATE;
                self.nu = 2.0;
                if last || decrease <= s.tol_cost * self.cost {
                    return Ok(Some(GaussNewtonStatus::ConvergedCost));
                }
                return Ok(None);
            }
            // a rejected step whose predicted gain is below the cost's
            // own rounding (n_r eps F bounds that of a sum of n_r
            // squares) cannot be told from noise: nothing is left to gain
            // (more damping would only shrink the step until it stalls)
            if last
                || (trial_cost.is_finite()
                    && predicted >= 0.0
                    && predicted <= n_r as f64 * f64::EPSILON * self.cost
                    && !self.damping_dominates())
            {
                return Ok(Some(GaussNewtonStatus::ConvergedCost));
            }
            if let Some(why) = watch.out_of_time() {
                return Ok(Some(why.into()));
            }
            // the trust region has shrunk; the damping rule raises the damping
            if self.trust.is_none() && !raise_damping(&mut self.mu, &mut self.nu) {
                return Ok(Some(GaussNewtonStatus::NumericalError));
            }
        }
    }

    fn snapshot(&self) -> solve::Snapshot<'_> {
        solve::Snapshot {
            iteration: self.iterations,
            evals: self.evaluations.map_or(self.residual_evals, EvalCount::evals),
            cost: self.cost,
            x: &self.theta,
        }
    }
}
