//! Eq. 3's second-order term $S = \sum_i r_i \nabla^2 r_i$ from the
//! model's and the stage cost's weighted Hessians: its pattern, its values,
//! and its quadratic form along a step.

use faer::sparse::SymbolicSparseColMat;

use super::{Dynamics, Eq3Problem, StageCost};
use crate::error::{Result, TrajoptError, expect_len};
use crate::least_squares::{LeastSquaresProblem, SecondOrder};

impl<M: Dynamics, C: StageCost> Eq3Problem<M, C> {
    /// Which pairs of local variables $z = (x_k, u_k)$ the second
    /// derivatives can couple: (stage, terminal stage, model), row-major
    /// boolean matrices of sides $n+m$, $n$, $n+m$. A second derivative
    /// $\partial^2 r / \partial z_a \partial z_b$ can be nonzero only if $r$
    /// depends on both $z_a$ and $z_b$, so the Jacobian structures give them.
    pub(super) fn local_hessian_structure(&self) -> (Vec<bool>, Vec<bool>, Vec<bool>) {
        let (n, m, nc) = (self.n, self.m, self.nc());
        let nz = n + m;
        let (mut bx, mut bu) = (vec![false; nc * n], vec![false; nc * m]);
        self.stage_structure(&mut bx, &mut bu);
        let (mut mx, mut mu) = (vec![false; n * n], vec![false; n * m]);
        self.model.jacobian_structure(&mut mx, &mut mu);
        let pairs = |rows: usize, jx: &[bool], ju: &[bool], dim: usize| {
            let mut out = vec![false; dim * dim];
            for a in 0..rows {
                let z: Vec<usize> = (0..dim)
                    .filter(|&c| if c < n { jx[a * n + c] } else { ju[a * m + c - n] })
                    .collect();
                for &i in &z {
                    for &j in &z {
                        out[i * dim + j] = true;
                    }
                }
            }
            out
        };
        (pairs(nc, &bx, &bu, nz), pairs(nc, &bx, &bu, n), pairs(n, &mx, &mu, nz))
    }

    /// The coefficient columns (and basis values) of local variable `a` of
    /// $z_k = (x_k, u_k)$.
    pub(super) fn local_cols(&self, k: usize, a: usize, out: &mut Vec<(usize, f64)>) {
        out.clear();
        if a < self.n {
            out.extend(self.state_cols(k, a).filter(|e| e.1 != 0.0));
        } else {
            out.extend(self.control_cols(k, a - self.n).filter(|e| e.1 != 0.0));
        }
    }

    /// The pattern of $S = \sum_i r_i \nabla^2 r_i$ over the coefficients:
    /// $S = \sum_k \Phi_k^\top S_k \Phi_k$ with $S_k$ local to step $k$.
    pub(super) fn hessian_pattern(&self) -> &SymbolicSparseColMat<usize> {
        self.hessian_pattern.get_or_init(|| self.build_hessian_pattern())
    }

    pub(super) fn build_hessian_pattern(&self) -> SymbolicSparseColMat<usize> {
        let (n, m) = (self.n, self.m);
        let nz = n + m;
        let (stage, terminal, model) = self.local_hessian_structure();
        let n_p = self.n_params();
        let mut columns: Vec<Vec<usize>> = vec![Vec::new(); n_p];
        let mut cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); nz];
        for k in 0..=self.horizon {
            let dim = if k == self.horizon { n } else { nz };
            for (a, c) in cols.iter_mut().enumerate().take(dim) {
                self.local_cols(k, a, c);
            }
            for a in 0..dim {
                for b in 0..dim {
                    let coupled = if k == self.horizon {
                        terminal[a * n + b]
                    } else {
                        stage[a * nz + b] || (self.lambda[k] > 0.0 && model[a * nz + b])
                    };
                    if !coupled {
                        continue;
                    }
                    for &(cb, _) in &cols[b] {
                        columns[cb].extend(cols[a].iter().map(|e| e.0));
                    }
                }
            }
        }
        let mut col_ptr = vec![0];
        let mut row_idx = Vec::new();
        for mut c in columns {
            c.sort_unstable();
            c.dedup();
            row_idx.extend(c);
            col_ptr.push(row_idx.len());
        }
        SymbolicSparseColMat::new_checked(n_p, n_p, col_ptr, None, row_idx)
    }

    /// The second-order term of step `k` over its local variables,
    /// $\sum_i r_i \nabla^2 r_i$ for the step's cost and consistency
    /// residuals, into `hz` (row-major, side $n + m$, or $n$ at the
    /// terminal step; `hm` and `w` are workspace); false if the cost or the
    /// model has no second derivatives.
    pub(super) fn local_hessian(
        &self,
        k: usize,
        x: &[f64],
        u: &[f64],
        r: &[f64],
        (hz, hm, w): (&mut [f64], &mut [f64], &mut [f64]),
    ) -> Result<bool> {
        let (n, m, nc) = (self.n, self.m, self.nc());
        let xk = &x[k * n..(k + 1) * n];
        let row = k * (nc + n);
        hz.fill(0.0);
        if k == self.horizon {
            return self.stage_hessian(k, xk, None, &r[row..row + nc], &mut hz[..n * n]);
        }
        let uk = &u[k * m..(k + 1) * m];
        if !self.stage_hessian(k, xk, Some(uk), &r[row..row + nc], hz)? {
            return Ok(false);
        }
        if self.lambda[k] > 0.0 {
            // r = s sqrt(lambda) (x_{k+1} - f): its second derivative is -s sqrt(lambda) f''
            let ws = self.scale * self.lambda[k].sqrt();
            for (wi, ri) in w.iter_mut().zip(&r[row + nc..row + nc + n]) {
                *wi = -ws * ri;
            }
            hm.fill(0.0);
            if !self.model.weighted_hessian(xk, uk, w, hm)? {
                return Ok(false);
            }
            for (a, b) in hz.iter_mut().zip(hm.iter()) {
                *a += b;
            }
        }
        Ok(true)
    }

    /// $\delta^\top S \delta$ from the per-step second derivatives; see
    /// [`SecondOrder::form`](crate::SecondOrder::form). `None` also when it is
    /// not finite (the solver then probes the residuals instead).
    pub(super) fn second_order_form_impl(&self, theta: &[f64], r: &[f64], delta: &[f64]) -> Result<Option<f64>> {
        expect_len("parameters", self.n_params(), theta.len())?;
        expect_len("residuals", self.n_residuals(), r.len())?;
        expect_len("direction", self.n_params(), delta.len())?;
        let (n, m) = (self.n, self.m);
        let nz = n + m;
        let (x, u) = self.sample(theta);
        // the basis is linear: the local variables move by the sampled direction
        let (dx, du) = self.sample(delta);
        let (mut hz, mut hm, mut w) = (vec![0.0; nz * nz], vec![0.0; nz * nz], vec![0.0; n]);
        let mut z = vec![0.0; nz];
        let mut form = 0.0;
        for k in 0..=self.horizon {
            if !self.local_hessian(k, &x, &u, r, (&mut hz, &mut hm, &mut w))? {
                return Ok(None);
            }
            let dim = if k == self.horizon { n } else { nz };
            z[..n].copy_from_slice(&dx[k * n..(k + 1) * n]);
            if k < self.horizon {
                z[n..].copy_from_slice(&du[k * m..(k + 1) * m]);
            }
            for a in 0..dim {
                let row: f64 = (0..dim).map(|b| hz[a * dim + b] * z[b]).sum();
                form += z[a] * row;
            }
        }
        Ok(form.is_finite().then_some(form))
    }

    /// Writes $S(\theta)$ into the values of the Hessian pattern; `false`
    /// if the model or the cost has no second derivatives.
    pub(super) fn hessian_values(&self, theta: &[f64], r: &[f64], values: &mut [f64]) -> Result<bool> {
        expect_len("parameters", self.n_params(), theta.len())?;
        expect_len("residuals", self.n_residuals(), r.len())?;
        expect_len(
            "second-order values",
            self.hessian_pattern().row_idx().len(),
            values.len(),
        )?;
        let (n, m) = (self.n, self.m);
        let nz = n + m;
        let (x, u) = self.sample(theta);
        values.fill(0.0);
        let (mut hz, mut hm, mut w) = (vec![0.0; nz * nz], vec![0.0; nz * nz], vec![0.0; n]);
        let mut cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); nz];
        let mut loaded = vec![false; nz];
        let mut starts: Vec<((usize, usize, usize), Vec<usize>)> = vec![((usize::MAX, 0, 0), Vec::new()); nz * nz];
        let pattern = self.hessian_pattern();
        for k in 0..=self.horizon {
            let terminal = k == self.horizon;
            let dim = if terminal { n } else { nz };
            if !self.local_hessian(k, &x, &u, r, (&mut hz, &mut hm, &mut w))? {
                return Ok(false);
            }
            loaded.fill(false);
            for a in 0..dim {
                for b in 0..dim {
                    let v = hz[a * dim + b];
                    if v == 0.0 {
                        continue;
                    }
                    if !v.is_finite() {
                        return Err(TrajoptError::NotFinite {
                            what: "second derivatives",
                            index: a * dim + b,
                            value: v,
                        });
                    }
                    for c in [a, b] {
                        if !loaded[c] {
                            self.local_cols(k, c, &mut cols[c]);
                            loaded[c] = true;
                        }
                    }
                    let (Some(&(ca0, _)), Some(&(cb0, _))) = (cols[a].first(), cols[b].first()) else {
                        continue;
                    };
                    // where cols[a][0] sits in each column of cols[b]: the same
                    // for the steps that share their basis spans, so cached
                    let cache = &mut starts[a * nz + b];
                    if cache.0 != (ca0, cb0, cols[b].len()) {
                        cache.0 = (ca0, cb0, cols[b].len());
                        cache.1.clear();
                        cache.1.extend(cols[b].iter().map(|&(cb, _)| {
                            pattern.col_ptr()[cb] + pattern.row_idx_of_col_raw(cb).partition_point(|&i| i < ca0)
                        }));
                    }
                    for (&(cb, vb), &first) in cols[b].iter().zip(&cache.1) {
                        let end = pattern.col_ptr()[cb + 1];
                        let rows = pattern.row_idx();
                        // the columns of a increase: walk from the first
                        let mut p = first;
                        for &(ca, va) in &cols[a] {
                            while p < end && rows[p] < ca {
                                p += 1;
                            }
                            if p == end || rows[p] != ca {
                                return Err(TrajoptError::InvalidParameter {
                                    name: "model",
                                    reason: format!(
                                        "a second derivative at step {k} ({a}, {b}) lies outside the Jacobian structure"
                                    ),
                                });
                            }
                            values[p] += v * va * vb;
                        }
                    }
                }
            }
        }
        Ok(true)
    }
}

impl<M: Dynamics, C: StageCost> SecondOrder for Eq3Problem<M, C> {
    fn pattern(&self) -> SymbolicSparseColMat<usize> {
        self.hessian_pattern().clone()
    }

    fn values(&self, theta: &[f64], r: &[f64], values: &mut [f64]) -> Result<bool> {
        self.hessian_values(theta, r, values)
    }

    fn form(&self, theta: &[f64], r: &[f64], delta: &[f64]) -> Result<Option<f64>> {
        self.second_order_form_impl(theta, r, delta)
    }
}
