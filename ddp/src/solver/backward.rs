//! The backward pass: derivatives along the trajectory, the recursion on
//! the $Q$-function and the convergence test.

use super::regularization::Regularization;
use super::settings::DdpMethod;
use super::work::Work;
use crate::linalg::{add_at_b, add_at_x, cholesky, cholesky_solve, set_a_b};
use crate::problem::{Cost, Dynamics};

impl<D: Dynamics, C: Cost> Work<'_, D, C> {
    /// Derivatives along the current trajectory; `false` if any is not
    /// finite or the dynamics' derivatives failed.
    pub(super) fn linearise(&mut self) -> bool {
        self.jacobian_evals += 1;
        let (n, m) = (self.n, self.m);
        let (dynamics, cost) = (self.p.dynamics(), self.p.cost());
        let mut finite = true;
        for k in 0..self.horizon {
            let x = &self.xs[k * n..(k + 1) * n];
            let u = &self.us[k * m..(k + 1) * m];
            let fx = &mut self.fx[k * n * n..(k + 1) * n * n];
            let fu = &mut self.fu[k * n * m..(k + 1) * n * m];
            fx.fill(0.0);
            fu.fill(0.0);
            finite &= systems::jacobians_or_differences(dynamics, x, u, fx, fu).is_ok();
            let d = &mut self.cd[k];
            d.clear();
            cost.running_derivatives(k, x, u, d);
            finite &= fx.iter().chain(fu.iter()).all(|v| v.is_finite())
                && [&d.lx, &d.lu, &d.lxx, &d.luu, &d.lux]
                    .iter()
                    .all(|b| b.iter().all(|v| v.is_finite()));
        }
        self.lfx.fill(0.0);
        self.lfxx.fill(0.0);
        cost.terminal_derivatives(&self.xs[self.horizon * n..], &mut self.lfx, &mut self.lfxx);
        finite && self.lfx.iter().chain(&self.lfxx).all(|v| v.is_finite())
    }

    /// Backward pass with regularisation `mu`: fills `kff`, `gain`, `vx`,
    /// `vxx` and returns the expected-reduction terms $(\sum k^\top Q_u,
    /// \tfrac12 \sum k^\top Q_{uu} k)$, or `None` if $\tilde Q_{uu}$ is not
    /// positive definite at some knot.
    pub(super) fn backward(&mut self, mu: f64) -> Option<(f64, f64)> {
        let (n, m, horizon) = (self.n, self.m, self.horizon);
        let use_second = self.s.method == DdpMethod::Ddp;
        let state_reg = self.s.regularization == Regularization::State;
        self.vx[horizon * n..].copy_from_slice(&self.lfx);
        self.vxx[horizon * n * n..].copy_from_slice(&self.lfxx);
        let (mut dv1, mut dv2) = (0.0, 0.0);
        for k in (0..horizon).rev() {
            let fx = &self.fx[k * n * n..(k + 1) * n * n];
            let fu = &self.fu[k * n * m..(k + 1) * n * m];
            let d = &self.cd[k];
            let (vx_cur, vx_next) = self.vx[k * n..(k + 2) * n].split_at_mut(n);
            let (vxx_cur, vxx_next) = self.vxx[k * n * n..(k + 2) * n * n].split_at_mut(n * n);

            self.qx.copy_from_slice(&d.lx);
            add_at_x(fx, vx_next, n, n, &mut self.qx);
            self.qu.copy_from_slice(&d.lu);
            add_at_x(fu, vx_next, n, m, &mut self.qu);
            set_a_b(vxx_next, fx, n, n, n, &mut self.vxx_fx);
            set_a_b(vxx_next, fu, n, n, m, &mut self.vxx_fu);
            self.qxx.copy_from_slice(&d.lxx);
            add_at_b(fx, &self.vxx_fx, n, n, n, &mut self.qxx);
            self.quu.copy_from_slice(&d.luu);
            add_at_b(fu, &self.vxx_fu, n, m, m, &mut self.quu);
            self.qux.copy_from_slice(&d.lux);
            add_at_b(fu, &self.vxx_fx, n, m, n, &mut self.qux);
            if use_second {
                self.hzz.fill(0.0);
                let x = &self.xs[k * n..(k + 1) * n];
                let u = &self.us[k * m..(k + 1) * m];
                // V_x' . f_zz; a model that fails here adds no tensor term at this knot
                let has = matches!(
                    self.p.dynamics().weighted_hessian(x, u, vx_next, &mut self.hzz),
                    Ok(true)
                );
                if has {
                    self.second_order = true;
                    let z = n + m;
                    for i in 0..n {
                        for j in 0..n {
                            self.qxx[i * n + j] += self.hzz[i * z + j];
                        }
                    }
                    for a in 0..m {
                        for j in 0..n {
                            self.qux[a * n + j] += self.hzz[(n + a) * z + j];
                        }
                        for b in 0..m {
                            self.quu[a * m + b] += self.hzz[(n + a) * z + n + b];
                        }
                    }
                }
            }
            symmetrise(&mut self.qxx, n);
            symmetrise(&mut self.quu, m);

            // regularised copies
            self.quu_reg.copy_from_slice(&self.quu);
            self.qux_reg.copy_from_slice(&self.qux);
            if mu > 0.0 {
                if state_reg {
                    // quu_reg += mu fu^T fu ; qux_reg += mu fu^T fx
                    self.reg_uu.fill(0.0);
                    add_at_b(fu, fu, n, m, m, &mut self.reg_uu);
                    for (q, a) in self.quu_reg.iter_mut().zip(&self.reg_uu) {
                        *q += mu * a;
                    }
                    self.tmp_mn.fill(0.0);
                    add_at_b(fu, fx, n, m, n, &mut self.tmp_mn);
                    for (q, a) in self.qux_reg.iter_mut().zip(&self.tmp_mn) {
                        *q += mu * a;
                    }
                } else {
                    for i in 0..m {
                        self.quu_reg[i * m + i] += mu;
                    }
                }
            }

            let kk = &mut self.kff[k * m..(k + 1) * m];
            let gk = &mut self.gain[k * m * n..(k + 1) * m * n];
            if !self.limited {
                cholesky(&mut self.quu_reg, m)?;
                for (k, q) in kk.iter_mut().zip(&self.qu) {
                    *k = -q;
                }
                cholesky_solve(&self.quu_reg, m, kk);
                // K = -Quu^{-1} Qux, column by column
                for j in 0..n {
                    for i in 0..m {
                        self.tmp_m[i] = -self.qux_reg[i * n + j];
                    }
                    cholesky_solve(&self.quu_reg, m, &mut self.tmp_m);
                    for i in 0..m {
                        gk[i * n + j] = self.tmp_m[i];
                    }
                }
            } else {
                for i in 0..m {
                    let u = self.us[k * m + i];
                    self.lo[i] = self.lower[i] - u;
                    self.hi[i] = self.upper[i] - u;
                }
                if !self.qp.solve(
                    &self.quu_reg,
                    &self.qu,
                    &self.lo,
                    &self.hi,
                    kk,
                    self.s.box_qp_max_iterations,
                ) {
                    return None;
                }
                gk.fill(0.0);
                let mf = self.qp.free.len();
                for j in 0..n {
                    for (a, &i) in self.qp.free.iter().enumerate() {
                        self.tmp_m[a] = -self.qux_reg[i * n + j];
                    }
                    cholesky_solve(&self.qp.factor[..mf * mf], mf, &mut self.tmp_m[..mf]);
                    for (a, &i) in self.qp.free.iter().enumerate() {
                        gk[i * n + j] = self.tmp_m[a];
                    }
                }
            }
            if kk.iter().chain(gk.iter()).any(|v| !v.is_finite()) {
                return None;
            }

            // expected reduction and value update (unregularised Q)
            for i in 0..m {
                self.tmp_m[i] = self.qu[i] + (0..m).map(|j| self.quu[i * m + j] * kk[j]).sum::<f64>();
            }
            dv1 += kk.iter().zip(&self.qu).map(|(a, b)| a * b).sum::<f64>();
            dv2 += 0.5
                * (0..m)
                    .map(|i| kk[i] * (0..m).map(|j| self.quu[i * m + j] * kk[j]).sum::<f64>())
                    .sum::<f64>();
            // vx = qx + K^T (quu k + qu) + qux^T k
            vx_cur.copy_from_slice(&self.qx);
            add_at_x(gk, &self.tmp_m, m, n, vx_cur);
            add_at_x(&self.qux, kk, m, n, vx_cur);
            // vxx = qxx + K^T quu K + K^T qux + qux^T K
            vxx_cur.copy_from_slice(&self.qxx);
            // tmp_mn = quu K + qux  => K^T tmp_mn = K^T quu K + K^T qux
            set_a_b(&self.quu, gk, m, m, n, &mut self.tmp_mn);
            for (t, q) in self.tmp_mn.iter_mut().zip(&self.qux) {
                *t += q;
            }
            add_at_b(gk, &self.tmp_mn, m, n, n, vxx_cur);
            add_at_b(&self.qux, gk, m, n, n, vxx_cur);
            symmetrise(vxx_cur, n);
        }
        Some((dv1, dv2))
    }

    /// The convergence test on the last backward pass, whose expected
    /// reduction at full step is `-dv`.
    pub(super) fn converged(&self, dv: f64, cost: f64) -> bool {
        -dv <= self.s.tol_cost * cost.abs().max(1.0) || self.feedforward_norm() <= self.s.tol_step
    }

    pub(super) fn feedforward_norm(&self) -> f64 {
        self.kff
            .iter()
            .zip(&self.us)
            .map(|(k, u)| k.abs() / (1.0 + u.abs()))
            .fold(0.0, f64::max)
    }
}

fn symmetrise(a: &mut [f64], n: usize) {
    for i in 0..n {
        for j in 0..i {
            let v = 0.5 * (a[i * n + j] + a[j * n + i]);
            a[i * n + j] = v;
            a[j * n + i] = v;
        }
    }
}
