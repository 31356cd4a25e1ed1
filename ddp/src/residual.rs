//! A stage cost of the one model contract ([`StageCost`], residual form) as
//! a DDP [`Cost`], so that the cost a user writes for Eq. 3 plans with DDP
//! unchanged.

use std::cell::RefCell;

use systems::{StageCost, residual_count};

use crate::problem::{Cost, CostDerivatives};

/// A [`StageCost`] $c_k = \lVert r_k(x, u) \rVert^2$ as a DDP cost: value
/// $\lVert r \rVert^2$, gradient $2 J^\top r$ and Hessian
/// $2 J^\top J + 2 \sum_a r_a \nabla^2 r_a$ (the second term only where the
/// stage cost gives [`StageCost::weighted_hessian`]; without it the Hessian
/// is the Gauss-Newton one, exact for linear residuals such as Eq. 5's).
/// The terminal cost is stage $N$ without control.
///
/// DDP costs cannot fail: where the stage cost returns an error the value
/// and the derivatives are NaN, which the solver reports as a blow-up or
/// non-finite derivatives.
#[derive(Debug)]
pub struct ResidualCost<C> {
    stage: C,
    n: usize,
    m: usize,
    horizon: usize,
    scratch: RefCell<Scratch>,
}

#[derive(Debug)]
struct Scratch {
    r: Vec<f64>,
    jx: Vec<f64>,
    ju: Vec<f64>,
    w: Vec<f64>,
    hzz: Vec<f64>,
}

impl<C: StageCost> ResidualCost<C> {
    /// Wraps `stage` for state dimension `n`, control dimension `m` and
    /// horizon $N$ (the terminal cost is stage $N$).
    pub fn new(stage: C, n: usize, m: usize, horizon: usize) -> Self {
        let nr = stage.n_residuals().max(stage.n_terminal_residuals());
        Self {
            stage,
            n,
            m,
            horizon,
            scratch: RefCell::new(Scratch {
                r: vec![0.0; nr],
                jx: vec![0.0; nr * n],
                ju: vec![0.0; nr * m],
                w: vec![0.0; nr],
                hzz: vec![0.0; (n + m) * (n + m)],
            }),
        }
    }

    /// The wrapped stage cost.
    pub fn stage(&self) -> &C {
        &self.stage
    }

    /// The horizon $N$.
    pub fn horizon(&self) -> usize {
        self.horizon
    }

    fn value(&self, k: usize, x: &[f64], u: Option<&[f64]>) -> f64 {
        let mut s = self.scratch.borrow_mut();
        let r = &mut s.r[..residual_count(&self.stage, u.is_none())];
        match self.stage.residuals(k, x, u, r) {
            Ok(()) => r.iter().map(|v| v * v).sum(),
            Err(_) => f64::NAN,
        }
    }

    /// Adds $2 J_x^\top r$, $2 J_x^\top J_x$ and, with a control,
    /// $2 J_u^\top r$, $2 J_u^\top J_u$, $2 J_u^\top J_x$ (row-major) to the
    /// zeroed buffers, then the residuals' own curvature where the stage
    /// cost gives it.
    fn derivatives(
        &self,
        k: usize,
        x: &[f64],
        u: Option<&[f64]>,
        lx: &mut [f64],
        lxx: &mut [f64],
        mut rest: Option<(&mut [f64], &mut [f64], &mut [f64])>,
    ) {
        let (n, m) = (self.n, self.m);
        let mut guard = self.scratch.borrow_mut();
        let s = &mut *guard;
        // the stage's own count of residuals (the terminal one may differ)
        let nr = residual_count(&self.stage, u.is_none());
        let (sr, sjx, sju, sw) = (&mut s.r[..nr], &mut s.jx[..nr * n], &mut s.ju[..nr * m], &mut s.w[..nr]);
        let ok = self.stage.residuals(k, x, u, sr).is_ok() && self.stage.jacobians(k, x, u, sjx, sju).is_ok();
        if !ok {
            lx.fill(f64::NAN);
            lxx.fill(f64::NAN);
            if let Some((lu, luu, lux)) = rest {
                for b in [lu, luu, lux] {
                    b.fill(f64::NAN);
                }
            }
            return;
        }
        for (q, &r) in sr.iter().enumerate() {
            let jx = &sjx[q * n..(q + 1) * n];
            for i in 0..n {
                lx[i] += 2.0 * jx[i] * r;
                for j in 0..n {
                    lxx[i * n + j] += 2.0 * jx[i] * jx[j];
                }
            }
        }
        if let Some((lu, luu, lux)) = rest.as_mut() {
            for (q, &r) in sr.iter().enumerate() {
                let (jx, ju) = (&sjx[q * n..(q + 1) * n], &sju[q * m..(q + 1) * m]);
                for a in 0..m {
                    lu[a] += 2.0 * ju[a] * r;
                    for b in 0..m {
                        luu[a * m + b] += 2.0 * ju[a] * ju[b];
                    }
                    for j in 0..n {
                        lux[a * n + j] += 2.0 * ju[a] * jx[j];
                    }
                }
            }
        }
        // + 2 sum_a r_a hess(r_a), over z = (x, u), or x alone at the end
        for (w, r) in sw.iter_mut().zip(sr.iter()) {
            *w = 2.0 * r;
        }
        let z = if u.is_some() { n + m } else { n };
        let hzz = &mut s.hzz[..z * z];
        hzz.fill(0.0);
        match self.stage.weighted_hessian(k, x, u, sw, hzz) {
            Ok(true) => {}
            Ok(false) => return,
            Err(_) => {
                lxx.fill(f64::NAN);
                return;
            }
        }
        for i in 0..n {
            for j in 0..n {
                lxx[i * n + j] += hzz[i * z + j];
            }
        }
        if let Some((_, luu, lux)) = rest {
            for a in 0..m {
                for j in 0..n {
                    lux[a * n + j] += hzz[(n + a) * z + j];
                }
                for b in 0..m {
                    luu[a * m + b] += hzz[(n + a) * z + n + b];
                }
            }
        }
    }
}

impl<C: StageCost> Cost for ResidualCost<C> {
    fn running(&self, k: usize, x: &[f64], u: &[f64]) -> f64 {
        self.value(k, x, Some(u))
    }

    fn running_derivatives(&self, k: usize, x: &[f64], u: &[f64], d: &mut CostDerivatives) {
        self.derivatives(
            k,
            x,
            Some(u),
            &mut d.lx,
            &mut d.lxx,
            Some((&mut d.lu, &mut d.luu, &mut d.lux)),
        );
    }

    fn terminal(&self, x: &[f64]) -> f64 {
        self.value(self.horizon, x, None)
    }

    fn terminal_derivatives(&self, x: &[f64], lx: &mut [f64], lxx: &mut [f64]) {
        self.derivatives(self.horizon, x, None, lx, lxx, None);
    }
}

#[cfg(test)]
mod tests {
    use systems::ModelResult;

    use super::*;
    use crate::QuadraticCost;

    /// $\sqrt{q_i}(x_i - 1)$, $\sqrt{r} u$, and one nonlinear residual
    /// $\sin x_0 \cdot u$ (zero at the terminal stage) with its curvature.
    struct Stage {
        nonlinear: bool,
    }

    const Q: [f64; 2] = [2.0, 0.5];
    const R: f64 = 0.3;

    impl StageCost for Stage {
        fn n_residuals(&self) -> usize {
            4
        }
        fn residuals(&self, _k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
            let u0 = u.map_or(0.0, |u| u[0]);
            r[0] = Q[0].sqrt() * (x[0] - 1.0);
            r[1] = Q[1].sqrt() * (x[1] - 1.0);
            r[2] = R.sqrt() * u0;
            r[3] = if self.nonlinear { x[0].sin() * u0 } else { 0.0 };
            Ok(())
        }
        fn jacobians(
            &self,
            _k: usize,
            x: &[f64],
            u: Option<&[f64]>,
            jx: &mut [f64],
            ju: &mut [f64],
        ) -> ModelResult<()> {
            let u0 = u.map_or(0.0, |u| u[0]);
            let nl = if self.nonlinear { 1.0 } else { 0.0 };
            jx.copy_from_slice(&[Q[0].sqrt(), 0.0, 0.0, Q[1].sqrt(), 0.0, 0.0, nl * x[0].cos() * u0, 0.0]);
            if u.is_some() {
                ju.copy_from_slice(&[0.0, 0.0, R.sqrt(), nl * x[0].sin()]);
            }
            Ok(())
        }
        fn weighted_hessian(
            &self,
            _k: usize,
            x: &[f64],
            u: Option<&[f64]>,
            w: &[f64],
            hess: &mut [f64],
        ) -> ModelResult<bool> {
            hess.fill(0.0);
            if self.nonlinear {
                // r_3 = sin(x0) u over z = (x0, x1, u)
                let u0 = u.map_or(0.0, |u| u[0]);
                hess[0] = -w[3] * x[0].sin() * u0;
                if u.is_some() {
                    hess[2] = w[3] * x[0].cos();
                    hess[6] = w[3] * x[0].cos();
                }
            }
            Ok(true)
        }
    }

    /// With linear residuals the wrapped cost is the diagonal quadratic cost
    /// exactly (value, gradient and Hessian).
    #[test]
    fn linear_residuals_are_the_quadratic_cost() {
        let wrapped = ResidualCost::new(Stage { nonlinear: false }, 2, 1, 5);
        let quadratic = QuadraticCost::diagonal(&Q, &[R], &Q)
            .expect("weights")
            .with_state_target(&[1.0, 1.0])
            .expect("target");
        let (x, u) = ([0.4, -2.0], [1.5]);
        assert!((wrapped.running(0, &x, &u) - quadratic.running(0, &x, &u)).abs() < 1e-12);
        assert!((wrapped.terminal(&x) - quadratic.terminal(&x)).abs() < 1e-12);
        let (mut a, mut b) = (CostDerivatives::zeros(2, 1), CostDerivatives::zeros(2, 1));
        wrapped.running_derivatives(0, &x, &u, &mut a);
        quadratic.running_derivatives(0, &x, &u, &mut b);
        for (p, q) in [
            (&a.lx, &b.lx),
            (&a.lu, &b.lu),
            (&a.lxx, &b.lxx),
            (&a.luu, &b.luu),
            (&a.lux, &b.lux),
        ] {
            for (p, q) in p.iter().zip(q.iter()) {
                assert!((p - q).abs() < 1e-12, "{a:?} vs {b:?}");
            }
        }
    }

    /// With a nonlinear residual the Hessian is the second difference of
    /// the value, the curvature term included.
    #[test]
    fn the_hessian_includes_the_residuals_curvature() {
        let wrapped = ResidualCost::new(Stage { nonlinear: true }, 2, 1, 5);
        let z0 = [0.7, -0.4, 1.3];
        let f = |z: &[f64]| wrapped.running(0, &z[..2], &z[2..]);
        let mut d = CostDerivatives::zeros(2, 1);
        wrapped.running_derivatives(0, &z0[..2], &z0[2..], &mut d);
        let h = 1e-4;
        let second = |i: usize, j: usize| {
            let at = |si: f64, sj: f64| {
                let mut z = z0;
                z[i] += si * h;
                z[j] += sj * h;
                f(&z)
            };
            (at(1.0, 1.0) - at(1.0, -1.0) - at(-1.0, 1.0) + at(-1.0, -1.0)) / (4.0 * h * h)
        };
        let close = |a: f64, b: f64| (a - b).abs() < 1e-5 * (1.0 + b.abs());
        assert!(close(d.lxx[0], second(0, 0)), "{} vs {}", d.lxx[0], second(0, 0));
        assert!(close(d.lux[0], second(2, 0)), "{} vs {}", d.lux[0], second(2, 0));
        assert!(close(d.luu[0], second(2, 2)), "{} vs {}", d.luu[0], second(2, 2));
    }
}
