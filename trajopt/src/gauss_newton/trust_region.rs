//! The trust-region step of [`StepControl::TrustRegion`](super::StepControl::TrustRegion):
//! Moré's Levenberg-Marquardt (MINPACK's `lmder` and `lmpar`).
//!
//! Each step minimises the Gauss-Newton model inside the region
//! $\lVert \delta \rVert_D \le \Delta$, $\lVert \delta \rVert_D^2 = \sum_j D_j \delta_j^2$
//! ($D$ the damping scale). Its solution is $\delta(\lambda) = -(J^\top J + \lambda D)^{-1} g$
//! for the $\lambda \ge 0$ with $\lVert \delta(\lambda) \rVert_D = \Delta$, or
//! $\lambda = 0$ when the Gauss-Newton step lies inside. $\lambda$ is found
//! to 1 % of $\Delta$ by Newton's method on
//! $\phi(\lambda) = \lVert \delta(\lambda) \rVert_D - \Delta$ (nearly linear
//! in $\lambda$ through $1/\lVert\delta\rVert_D$), safeguarded by the bounds
//! $\ell \le \lambda \le u$ that Moré derives, with
//! $\phi'(\lambda) = -(D\delta)^\top (J^\top J + \lambda D)^{-1} (D\delta) / \lVert \delta \rVert_D$:
//! two factorisations per trial $\lambda$, at most 10 trials, usually one or two.
//! The radius follows the gain ratio $\rho$ as in `lmder`: $\rho \le 1/4$
//! shrinks it (by a factor between 1/10 and 1/2 chosen from a quadratic fit of
//! $F$ along the step), $\rho \ge 3/4$ or a step with $\lambda = 0$ sets it
//! to twice the step.
//!
//! Reference: J. J. Moré, "The Levenberg-Marquardt algorithm: implementation
//! and theory", *Numerical Analysis*, Lecture Notes in Mathematics 630
//! (1978), 105-116; MINPACK-1 (Moré, Garbow, Hillstrom, ANL-80-74, 1980).

use super::normal_equations::{Damping, NormalEquations};
use crate::least_squares::LeastSquaresProblem;

/// Trials of $\lambda$ per step (MINPACK's `lmpar` allows 10).
const MAX_TRIALS: usize = 10;
/// $\lambda$ is accepted when $\lvert\phi(\lambda)\rvert \le$ `ACCURACY` $\Delta$:
/// 1 %, as scipy's `trf` solves its subproblem (`lmpar` stops at 10 %).
/// Measured on the MGH set with $D = I$ (`nprl-bench --solvers trust-region`,
/// one run each): 83 of 103 instances at the minimum with 1 %, 82 with 10 %;
/// on NIST StRD 54 of 54 runs to 4 digits with either.
const ACCURACY: f64 = 0.01;

/// The linear solves of one step's search for $\lambda$.
struct Solver<'s, P: LeastSquaresProblem + ?Sized> {
    system: &'s mut dyn NormalEquations<P>,
    scale: &'s [f64],
    factorizations: usize,
    minus_g: &'s mut [f64],
    /// $D\delta$.
    scaled: &'s mut [f64],
}

impl<P: LeastSquaresProblem + ?Sized> Solver<'_, P> {
    /// $\delta(\lambda) = -(J^\top J + \lambda D)^{-1} g$ into `out`; false
    /// if the matrix is not numerically positive definite or the step not
    /// finite.
    fn solve(&mut self, lambda: f64, out: &mut [f64]) -> bool {
        out.copy_from_slice(self.minus_g);
        self.damped(lambda, out)
    }

    fn damped(&mut self, lambda: f64, rhs: &mut [f64]) -> bool {
        self.factorizations += 1;
        let damping = Damping {
            newton: false,
            total: lambda,
            scale: self.scale,
        };
        self.system.damped_step(damping, rhs) && rhs.iter().all(|v| v.is_finite())
    }

    /// $\phi'(\lambda) = -(D\delta)^\top (J^\top J + \lambda D)^{-1} (D\delta) / \lVert\delta\rVert_D$
    /// for the step `d` of length `norm`.
    fn derivative(&mut self, lambda: f64, d: &[f64], norm: f64, work: &mut [f64]) -> Option<f64> {
        for ((s, x), w) in self.scaled.iter_mut().zip(d).zip(self.scale) {
            *s = w * x;
        }
        work.copy_from_slice(self.scaled);
        // the system solves (H + lambda D) x = rhs with rhs given in `work`
        let ok = self.damped(lambda, work);
        ok.then(|| -self.scaled.iter().zip(work.iter()).map(|(a, b)| a * b).sum::<f64>() / norm)
    }
}

/// The region between steps.
#[derive(Debug, Clone)]
pub(super) struct TrustRegion {
    /// $\Delta$; `None` before the first step.
    radius: Option<f64>,
    /// The last $\lambda$ (relative to $D$), the next search's start.
    pub(super) lambda: f64,
    /// $D \delta$, then $(J^\top J + \lambda D)^{-1} D \delta$ (for $\phi'$).
    work: Vec<f64>,
    /// $-g$ and $D\delta$, the search's right-hand sides (kept: no
    /// allocation per step).
    minus_g: Vec<f64>,
    scaled: Vec<f64>,
}

impl TrustRegion {
    pub(super) fn new(n_p: usize) -> Self {
        Self {
            radius: None,
            lambda: 0.0,
            work: vec![0.0; n_p],
            minus_g: vec![0.0; n_p],
            scaled: vec![0.0; n_p],
        }
    }

    /// The step minimising the Gauss-Newton model in the region, written
    /// to `step`; the radius starts at $\lVert\theta\rVert_D$ (1 at the
    /// origin, as scipy's `trf`) and never exceeds the first Gauss-Newton
    /// step's length (as `lmder`). Returns the factorisations spent, or
    /// `None` if no trial $\lambda$ gave a finite step.
    pub(super) fn step<P: LeastSquaresProblem + ?Sized>(
        &mut self,
        system: &mut dyn NormalEquations<P>,
        grad: &[f64],
        scale: &[f64],
        theta: &[f64],
        step: &mut [f64],
    ) -> Option<usize> {
        for (m, g) in self.minus_g.iter_mut().zip(grad) {
            *m = -g;
        }
        let mut solver = Solver {
            system,
            scale,
            factorizations: 0,
            minus_g: &mut self.minus_g,
            scaled: &mut self.scaled,
        };
        // the Gauss-Newton step, if J^T J is positive definite
        let gauss_newton = solver.solve(0.0, step);
        let gn_norm = if gauss_newton {
            Self::length(step, scale)
        } else {
            f64::INFINITY
        };
        let radius = *self.radius.get_or_insert_with(|| {
            let at = Self::length(theta, scale);
            let start = if at > 0.0 { at } else { 1.0 };
            start.min(gn_norm)
        });
        if gauss_newton && gn_norm <= (1.0 + ACCURACY) * radius {
            self.lambda = 0.0;
            return Some(solver.factorizations);
        }
        // Moré's bounds on lambda: l from the Gauss-Newton step, u from the gradient
        let mut lower = 0.0f64;
        if gauss_newton
            && let Some(dphi) = solver.derivative(0.0, step, gn_norm, &mut self.work)
            && dphi < 0.0
        {
            lower = -(gn_norm - radius) / dphi;
        }
        let g_scaled = grad.iter().zip(scale).map(|(g, s)| g * g / s).sum::<f64>().sqrt();
        let mut upper = g_scaled / radius;
        if upper.is_nan() || upper <= 0.0 {
            upper = f64::MIN_POSITIVE / radius.min(0.1);
        }
        let mut lambda = self.lambda.clamp(lower, upper.max(lower));
        if lambda == 0.0 {
            lambda = if gauss_newton { g_scaled / gn_norm } else { 1e-3 * upper };
        }
        // the last lambda whose step is finite, and whether `step` holds it
        let mut good = None;
        let mut holds_good = false;
        for _ in 0..MAX_TRIALS {
            if lambda.is_nan() || lambda <= 0.0 {
                lambda = f64::MIN_POSITIVE.max(1e-3 * upper);
            }
            if !solver.solve(lambda, step) {
                // not positive definite to working precision: more damping
                holds_good = false;
                lower = lower.max(lambda);
                lambda *= 10.0;
                continue;
            }
            good = Some(lambda);
            holds_good = true;
            let norm = Self::length(step, scale);
            let phi = norm - radius;
            if phi.abs() <= ACCURACY * radius {
                break;
            }
            let Some(dphi) = solver.derivative(lambda, step, norm, &mut self.work) else {
                break;
            };
            if phi > 0.0 {
                lower = lower.max(lambda);
            } else {
                upper = upper.min(lambda);
            }
            let correction = if dphi < 0.0 {
                -((phi + radius) / radius) * (phi / dphi)
            } else {
                0.0
            };
            let next = (lambda + correction).max(lower);
            lambda = if next > lower && next < upper && next != lambda {
                next
            } else {
                // outside the bounds: Moré's safeguard
                let safe = (1e-3 * upper).max((lower * upper).sqrt());
                if safe == lambda || !safe.is_finite() {
                    break;
                }
                safe
            };
        }
        let good = good?;
        if !holds_good && !solver.solve(good, step) {
            return None;
        }
        self.lambda = good;
        Some(solver.factorizations)
    }

    /// The step's length in the region's norm.
    pub(super) fn length(step: &[f64], scale: &[f64]) -> f64 {
        step.iter().zip(scale).map(|(x, d)| d * x * x).sum::<f64>().sqrt()
    }

    /// The radius after a trial step of length `length` ($D$-norm) with
    /// gain ratio `rho`, cost `cost` before and `trial_cost` after, and
    /// directional derivative `slope` $= g^\top\delta$ (`lmder`'s rule).
    pub(super) fn update(&mut self, rho: f64, length: f64, cost: f64, trial_cost: f64, slope: f64) {
        let Some(radius) = self.radius.as_mut() else {
            return;
        };
        if rho <= 0.25 {
            let actual = cost - trial_cost;
            // the minimiser of the quadratic through F, its slope 2 g.d and F(trial)
            let mut factor = if actual >= 0.0 || !actual.is_finite() {
                0.5
            } else {
                0.5 * slope / (slope + 0.5 * actual)
            };
            if !trial_cost.is_finite() || trial_cost >= 100.0 * cost || factor.is_nan() || factor < 0.1 {
                factor = 0.1;
            }
            *radius = factor * radius.min(10.0 * length);
            self.lambda /= factor;
        } else if self.lambda == 0.0 || rho >= 0.75 {
            *radius = 2.0 * length;
            self.lambda *= 0.5;
        }
    }

    /// $\Delta$ (0 before the first step).
    #[cfg(test)]
    pub(super) fn radius(&self) -> f64 {
        self.radius.unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use faer::sparse::{SparseRowMat, SymbolicSparseRowMat};

    use super::*;
    use crate::gauss_newton::normal_equations::SparseSystem;
    use crate::least_squares::{LinearLeastSquares, Point};

    /// $r = \operatorname{diag}(a)\,\theta - b$: with $D = I$ the step is
    /// $\delta_j(\lambda) = -g_j / (a_j^2 + \lambda)$, $g_j = a_j (a_j \theta_j - b_j)$,
    /// so the $\lambda$ on the boundary solves a scalar equation.
    fn diagonal(a: &[f64], b: &[f64]) -> LinearLeastSquares {
        let n = a.len();
        let pattern = SymbolicSparseRowMat::new_checked(n, n, (0..=n).collect(), None, (0..n).collect());
        LinearLeastSquares::new(SparseRowMat::new(pattern, a.to_vec()), b.to_vec()).expect("finite")
    }

    fn first_step(a: &[f64], b: &[f64], theta: &[f64], region: &mut TrustRegion) -> (Vec<f64>, Vec<f64>) {
        let problem = diagonal(a, b);
        let n = a.len();
        let mut system = SparseSystem::new(&problem, n, n, false).expect("system");
        let r: Vec<f64> = (0..n).map(|j| a[j] * theta[j] - b[j]).collect();
        let mut grad = vec![0.0; n];
        let at = Point { theta, r: &r };
        let ready = NormalEquations::<LinearLeastSquares>::assemble(&mut system, &problem, at, &mut grad, false);
        assert!(ready.expect("assembles").is_some());
        let mut step = vec![0.0; n];
        let spent = region.step::<LinearLeastSquares>(&mut system, &grad, &vec![1.0; n], theta, &mut step);
        assert!(spent.expect("a step") >= 1);
        (step, grad)
    }

    #[test]
    fn inside_the_region_the_step_is_gauss_newtons() {
        // the Gauss-Newton step (-1, -2), length sqrt 5, is shorter than |theta| = sqrt 13
        let (a, b, theta) = ([1.0, 2.0], [1.0, 2.0], [2.0, 3.0]);
        let mut region = TrustRegion::new(2);
        let (step, _) = first_step(&a, &b, &theta, &mut region);
        assert!(
            (step[0] + 1.0).abs() < 1e-12 && (step[1] + 2.0).abs() < 1e-12,
            "{step:?}"
        );
        assert_eq!(region.lambda, 0.0);
        // the first radius is capped at the Gauss-Newton step's length (lmder)
        assert!((region.radius() - 5f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn on_the_boundary_the_step_solves_the_secular_equation() {
        // |theta| = 0.141 is far shorter than the Gauss-Newton step (9.9, -10.1)
        let (a, b, theta) = ([1.0, 3.0], [10.0, -30.0], [0.1, 0.1]);
        let mut region = TrustRegion::new(2);
        let (step, grad) = first_step(&a, &b, &theta, &mut region);
        let radius = region.radius();
        assert!((radius - 0.02f64.sqrt()).abs() < 1e-12);
        let length = TrustRegion::length(&step, &[1.0, 1.0]);
        assert!((length - radius).abs() <= ACCURACY * radius, "{length} vs {radius}");
        // the step is -(J^T J + lambda I)^-1 g for the lambda reported
        let lambda = region.lambda;
        assert!(lambda > 0.0);
        for j in 0..2 {
            let expected = -grad[j] / (a[j] * a[j] + lambda);
            assert!(
                (step[j] - expected).abs() <= 1e-10 * expected.abs(),
                "{j}: {} vs {expected}",
                step[j]
            );
        }
        // and lambda is near the root of sum g_j^2 / (a_j^2 + l)^2 = radius^2, by bisection
        let norm = |l: f64| {
            (0..2)
                .map(|j| (grad[j] / (a[j] * a[j] + l)).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let (mut lo, mut hi) = (0.0, 1e6);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if norm(mid) > radius { lo = mid } else { hi = mid }
        }
        assert!((lambda - lo).abs() <= 0.05 * lo, "{lambda} vs {lo}");
    }

    #[test]
    fn the_radius_follows_lmders_rule() {
        let fresh = |radius: f64, lambda: f64| TrustRegion {
            radius: Some(radius),
            lambda,
            ..TrustRegion::new(0)
        };
        // a poor step that still lowered F: half the radius, twice the damping
        let mut t = fresh(1.0, 2.0);
        t.update(0.1, 1.0, 1.0, 0.99, -0.05);
        assert_eq!((t.radius(), t.lambda), (0.5, 4.0));
        // a step that raised F a hundredfold: a tenth
        let mut t = fresh(1.0, 2.0);
        t.update(-5.0, 1.0, 1.0, 150.0, -0.05);
        assert!((t.radius() - 0.1).abs() < 1e-15 && (t.lambda - 20.0).abs() < 1e-12);
        // a very successful step: twice its length, half the damping
        let mut t = fresh(1.0, 2.0);
        t.update(0.9, 0.8, 1.0, 0.2, -0.5);
        assert_eq!((t.radius(), t.lambda), (1.6, 1.0));
        // a fair step with damping on: unchanged
        let mut t = fresh(1.0, 2.0);
        t.update(0.5, 1.0, 1.0, 0.5, -0.5);
        assert_eq!((t.radius(), t.lambda), (1.0, 2.0));
    }
}
