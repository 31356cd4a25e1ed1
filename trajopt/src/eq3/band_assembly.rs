//! Eq. 3's normal equations formed directly in band form.
//!
//! Every residual of step $k$ depends on the local variables
//! $z_k = (x_k, u_k, x_{k+1})$ only, and $z_k = P_k \theta$ with $P_k$ the
//! basis rows at $t_k$ and $t_{k+1}$. So
//! $$J^\top J = \sum_k P_k^\top G_k^\top G_k P_k, \qquad J^\top r = \sum_k P_k^\top G_k^\top r_k,$$
//! with $G_k$ the local Jacobian: the stage cost's $[J^x_k\; J^u_k\; 0]$ and
//! the consistency rows' $w_k [-F^x_k\; -F^u_k\; I]$, $w_k = s \sqrt{\lambda_k}$.
//! The local products are formed first (a few dozen numbers per step) and
//! then spread over the coefficients. The block of $x_{k+1}$ with itself,
//! $w_k^2 I$, does not depend on $\theta$ and is added to the next step's
//! $x$ block, so each step spreads one $(n+m)^2$ block on $t_k$'s basis rows
//! and one $(n+m) \times n$ cross block on $t_k$'s and $t_{k+1}$'s, instead
//! of every Jacobian row's outer product. The second-order term
//! $S = \sum_k P_k^\top S_k P_k$ comes from the same loop.
//!
//! The parameters are ordered by the first sample time their basis
//! function touches (channels interleaved), so both matrices are banded
//! with a half-bandwidth set by how many coefficients overlap two
//! consecutive samples.

use super::jacobian::LocalDerivatives;
use super::{Dynamics, Eq3Problem, StageCost};
use crate::error::{Result, TrajoptError, expect_len};
use crate::least_squares::{BandForm, BandNormalEquations, LeastSquaresProblem, Part, Point};
use crate::linalg::kernels::{
    BasisRows, FixedShape, KronWindow, StepSpread, add_outer, contiguous_row, with_fixed_shape,
};
use crate::linalg::{BandLayout, BandedSym};

/// The band positions and basis values of one local variable at one sample.
type Spread = Vec<(usize, f64)>;

impl<M: Dynamics, C: StageCost> Eq3Problem<M, C> {
    /// The parameter order by first touched sample, and the half-bandwidth
    /// of the normal equations in it.
    fn band_layout_impl(&self) -> BandLayout {
        let (n, m) = (self.n, self.m);
        let (ncx, ncu) = (self.n_state_coeffs(), self.n_control_coeffs());
        let first_row = |phi: &faer::sparse::SparseRowMat<usize, f64>, ncols: usize| {
            let mut first = vec![usize::MAX; ncols];
            for k in 0..phi.nrows() {
                for (&c, &v) in phi.symbolic().col_idx_of_row_raw(k).iter().zip(phi.val_of_row(k)) {
                    if v != 0.0 && first[c] == usize::MAX {
                        first[c] = k;
                    }
                }
            }
            first
        };
        let (fx, fu) = (first_row(&self.phi_x, ncx), first_row(&self.phi_u, ncu));
        // (first sample, channel) per parameter, in the parameter order
        let keys: Vec<(usize, usize)> = (0..n)
            .flat_map(|c| fx.iter().map(move |&f| (f, c)))
            .chain((0..m).flat_map(|c| fu.iter().map(move |&f| (f, n + c))))
            .collect();
        let mut order: Vec<usize> = (0..keys.len()).collect();
        order.sort_by_key(|&i| keys[i]);
        let mut position = vec![0; keys.len()];
        for (p, &i) in order.iter().enumerate() {
            position[i] = p;
        }
        // every local variable of step k (x_k, u_k, x_{k+1}) can couple with every other
        let mut half_bandwidth = 0;
        let mut spread = vec![Vec::new(); n + m];
        let mut next = vec![Vec::new(); n];
        for k in 0..=self.horizon {
            self.spread_at(k, &position, &mut spread, &mut next);
            let all = spread.iter().chain(next.iter()).flatten().map(|e| e.0);
            let (lo, hi) = all.fold((usize::MAX, 0), |(lo, hi), p| (lo.min(p), hi.max(p)));
            if lo <= hi {
                half_bandwidth = half_bandwidth.max(hi - lo);
            }
        }
        BandLayout {
            position,
            half_bandwidth,
        }
    }

    /// The band positions and basis values of the local variables of step
    /// `k`: `spread[a]` for $a$ in $(x_k, u_k)$ ($u$ absent at $k = N$),
    /// `next[i]` for $x_{k+1}$ (empty at $k = N$).
    fn spread_at(&self, k: usize, position: &[usize], spread: &mut [Spread], next: &mut [Spread]) {
        let (n, m) = (self.n, self.m);
        let (ncx, ncu) = (self.n_state_coeffs(), self.n_control_coeffs());
        let off = ncx * n;
        let row = |phi: &faer::sparse::SparseRowMat<usize, f64>, k: usize, base: usize, out: &mut Spread| {
            out.clear();
            let cols = phi.symbolic().col_idx_of_row_raw(k);
            out.extend(
                cols.iter()
                    .zip(phi.val_of_row(k))
                    .filter(|e| *e.1 != 0.0)
                    .map(|(&c, &v)| (position[base + c], v)),
            );
        };
        for i in 0..n {
            row(&self.phi_x, k, i * ncx, &mut spread[i]);
            if k < self.horizon {
                row(&self.phi_x, k + 1, i * ncx, &mut next[i]);
            } else {
                next[i].clear();
            }
        }
        for j in 0..m {
            if k < self.horizon {
                row(&self.phi_u, k, off + j * ncu, &mut spread[n + j]);
            } else {
                spread[n + j].clear();
            }
        }
    }

    /// Calls `f(parameter, value)` for each basis entry of local variable
    /// `a` of step `k` (`base[a]`: the parameter of its channel's first
    /// coefficient).
    #[inline]
    fn for_each_basis_entry(&self, k: usize, a: usize, base: &[usize], mut f: impl FnMut(usize, f64)) {
        let phi = if a < self.n { &self.phi_x } else { &self.phi_u };
        for (&c, &v) in phi.symbolic().col_idx_of_row_raw(k).iter().zip(phi.val_of_row(k)) {
            f(base[a] + c, v);
        }
    }

    /// The basis rows of step `k` (first coefficient and values); `None` if
    /// one of them is not a contiguous range of coefficients (then the
    /// window cannot be used).
    fn contiguous_rows(&self, k: usize) -> Option<BasisRows<'_>> {
        let terminal = k == self.horizon;
        let empty = (0, &[][..]);
        Some(BasisRows {
            x: contiguous_row(&self.phi_x, k)?,
            x_next: if terminal {
                empty
            } else {
                contiguous_row(&self.phi_x, k + 1)?
            },
            u: if terminal {
                empty
            } else {
                contiguous_row(&self.phi_u, k)?
            },
        })
    }

    /// $J^\top J$ (and $S$) in band form and $J^\top r$ from the residuals
    /// of the stages `job.steps` (`0..=horizon` for all); see the module docs.
    /// The stages of one call see the same sums in the same order whatever
    /// range the call has: the contributions of disjoint ranges add up to
    /// the whole up to the rounding of that addition.
    fn band_normal_equations_impl(&self, job: BandJob<'_>) -> Result<bool> {
        with_fixed_shape(
            self.local_sizes(),
            BandBody::<'_, '_, M, C, false> { problem: self, job },
        )
    }

    /// The second-order term $S$ alone, in band form, from the stages
    /// `steps`: what [`band_normal_equations_impl`](Self::band_normal_equations_impl)
    /// adds to $J^\top J$. False (with `s` cleared) when $S$ is not
    /// available.
    fn band_second_order_impl(
        &self,
        at: Point<'_>,
        layout: &BandLayout,
        s: &mut BandedSym,
        steps: std::ops::Range<usize>,
    ) -> Result<bool> {
        let mut grad = vec![0.0; self.n_params()];
        let job = BandJob {
            at,
            layout,
            out: BandNormalEquations {
                h: &mut *s,
                grad: &mut grad,
                second_order_diagonal: None,
            },
            steps,
        };
        let found = with_fixed_shape(
            self.local_sizes(),
            BandBody::<'_, '_, M, C, true> { problem: self, job },
        )?;
        if !found {
            s.clear();
        }
        Ok(found)
    }

    /// (states, controls, stage-cost residuals): the key of the
    /// fixed-shape table ([`with_fixed_shape`]).
    fn local_sizes(&self) -> (usize, usize, usize) {
        (self.n, self.m, self.nc())
    }

    /// [`band_normal_equations_impl`](Self::band_normal_equations_impl)
    /// for `NX` states, `NU` controls and `NC` stage-cost residuals (all 0:
    /// the problem's own sizes, at run time); with `S_ONLY`, $S$ alone
    /// into `h` (the Jacobian terms, the gradient and the diagonal of $S$
    /// skipped), returning whether $S$ is available.
    fn band_body<const NX: usize, const NU: usize, const NC: usize, const S_ONLY: bool>(
        &self,
        job: BandJob<'_>,
    ) -> Result<bool> {
        let BandJob {
            at: Point { theta, r },
            layout,
            out:
                BandNormalEquations {
                    h,
                    grad,
                    second_order_diagonal: second_order,
                },
            steps,
        } = job;
        let n_p = self.n_params();
        expect_len("parameters", n_p, theta.len())?;
        expect_len("residuals", self.n_residuals(), r.len())?;
        expect_len("gradient", n_p, grad.len())?;
        expect_len("band layout", n_p, layout.position.len())?;
        if h.size() != n_p || h.half_bandwidth() < layout.half_bandwidth {
            return Err(TrajoptError::DimensionMismatch {
                what: "band matrix size",
                expected: n_p,
                actual: h.size(),
            });
        }
        if let Some(diag) = &second_order {
            expect_len("second-order diagonal", n_p, diag.len())?;
        }
        let (n, m, nc) = if NX > 0 {
            (NX, NU, NC)
        } else {
            (self.n, self.m, self.nc())
        };
        let nz = n + m;
        let (x, u) = self.sample_range(theta, steps.clone());
        let st = self.local_structure();
        // which second derivatives the Jacobian structures allow
        let (stage_s, terminal_s, model_s) = if S_ONLY || second_order.is_some() {
            self.local_hessian_structure()
        } else {
            Default::default()
        };
        let stage_or_model_s: Vec<bool> = stage_s.iter().zip(&model_s).map(|(&a, &b)| a || b).collect();
        // the model's Jacobians at every step at once (a model may evaluate
        // them in parallel), central differences if it has none
        let horizon = self.horizon;
        let (k0, k1) = (steps.start.min(horizon + 1), steps.end.min(horizon + 1));
        if k0 >= k1 {
            // no stages: nothing to add
            h.clear();
            grad.fill(0.0);
            return Ok(match second_order {
                Some(diag) => {
                    diag.fill(0.0);
                    true
                }
                None => false,
            });
        }
        // the model's steps among them (k0..k_model), offset by k0
        let k_model = k1.min(horizon).max(k0);
        let n_model = k_model - k0;
        let (mut model_fx, mut model_fu) = (vec![0.0; n_model * n * n], vec![0.0; n_model * n * m]);
        if !S_ONLY
            && !self.model.jacobians_batch(
                &x[k0 * n..k_model * n],
                &u[k0 * m..k_model * m],
                &mut model_fx,
                &mut model_fu,
            )?
        {
            for k in 0..n_model {
                systems::central_differences(
                    &self.model,
                    &x[(k0 + k) * n..(k0 + k + 1) * n],
                    &u[(k0 + k) * m..(k0 + k + 1) * m],
                    &mut model_fx[k * n * n..(k + 1) * n * n],
                    &mut model_fu[k * n * m..(k + 1) * n * m],
                )?;
            }
        }
        let mut d = LocalDerivatives {
            jx: vec![0.0; nc * n],
            ju: vec![0.0; nc * m],
            fx: vec![0.0; n * n],
            fu: vec![0.0; n * m],
        };
        h.clear();
        let mut grad_acc = vec![0.0; n_p];
        let mut with_s = S_ONLY || second_order.is_some();
        let mut diag_s = vec![0.0; if with_s { n_p } else { 0 }];
        // local Gauss-Newton block on (x_k, u_k), its gradient, the cross
        // block with x_{k+1}, and what step k leaves for x_{k+1}
        let (mut q, mut gl, mut cross) = (vec![0.0; nz * nz], vec![0.0; nz], vec![0.0; nz * n]);
        let (mut carry_diag, mut carry_grad) = (vec![0.0; n], vec![0.0; n]);
        let (mut hz, mut hm, mut wm) = (vec![0.0; nz * nz], vec![0.0; nz * nz], vec![0.0; n]);
        let (mut g_row, mut f_rows) = (vec![0.0; nz], vec![0.0; n * nz]);
        let (ncx, ncu) = (self.n_state_coeffs(), self.n_control_coeffs());
        // parameter index of coefficient 0 of each channel, and its number of coefficients
        let base: Vec<usize> = (0..n)
            .map(|c| c * ncx)
            .chain((0..m).map(|j| n * ncx + j * ncu))
            .collect();
        let mut window = KronWindow::new(n, m);
        let mut spread = vec![Vec::new(); nz];
        let mut next = vec![Vec::new(); n];
        if k0 == 0 {
            // the initial-state rows r = sqrt(w0) (x_0 - x0) sit after all steps
            if let Some((_, w0)) = &self.initial_state {
                let init_row = self.n_residuals() - n;
                carry_diag.fill(*w0);
                for (g, ri) in carry_grad.iter_mut().zip(&r[init_row..]) {
                    *g = w0.sqrt() * ri;
                }
            }
        } else if k0 < k1 {
            // what step k0 - 1's consistency rows leave for x_{k0}
            let w = self.scale * self.lambda[k0 - 1].sqrt();
            let r_cons = &r[(k0 - 1) * (nc + n) + nc..k0 * (nc + n)];
            carry_diag.fill(w * w);
            for (g, ri) in carry_grad.iter_mut().zip(r_cons) {
                *g = w * ri;
            }
        }
        let mut row = k0 * (nc + n);
        for k in k0..k1 {
            let terminal = k == self.horizon;
            let dim = if terminal { n } else { nz };
            // the stage cost's derivatives; the model's come from one batch
            let xk = &x[k * n..(k + 1) * n];
            let uk = (!terminal).then(|| &u[k * m..(k + 1) * m]);
            let r_cost = &r[row..row + nc];
            row += nc;
            let r_cons = if terminal { &r[row..row] } else { &r[row..row + n] };
            row += r_cons.len();
            q.fill(0.0);
            if !S_ONLY {
                self.stage_jacobians(k, xk, uk, &mut d.jx, &mut d.ju)?;
                if !terminal {
                    let km = k - k0;
                    d.fx.copy_from_slice(&model_fx[km * n * n..(km + 1) * n * n]);
                    d.fu.copy_from_slice(&model_fu[km * n * m..(km + 1) * n * m]);
                }
                mask(&mut d.jx, &st.jx);
                mask(&mut d.ju, &st.ju);
                mask(&mut d.fx, &st.fx);
                mask(&mut d.fu, &st.fu);
                gl.fill(0.0);
                // the stage cost: [jx ju]^T [jx ju] and [jx ju]^T r, rows of G as [jx ju]
                for (a, &ra) in r_cost.iter().enumerate() {
                    for (c, g) in g_row.iter_mut().enumerate().take(dim) {
                        *g = if c < n { d.jx[a * n + c] } else { d.ju[a * m + c - n] };
                    }
                    add_outer(&mut q, &mut gl, &g_row[..dim], nz, 1.0, ra);
                }
                // what step k - 1 (or the initial state) left for x_k
                for i in 0..n {
                    q[i * nz + i] += carry_diag[i];
                    gl[i] += carry_grad[i];
                }
                if !terminal {
                    // consistency rows w (x_{k+1} - f): G = w [-fx -fu I]
                    let w = self.scale * self.lambda[k].sqrt();
                    for (i, &ri) in r_cons.iter().enumerate() {
                        for c in 0..nz {
                            f_rows[i * nz + c] = if c < n { d.fx[i * n + c] } else { d.fu[i * m + c - n] };
                        }
                        add_outer(&mut q, &mut gl, &f_rows[i * nz..(i + 1) * nz], nz, w * w, -w * ri);
                    }
                    for c in 0..nz {
                        for i in 0..n {
                            cross[c * n + i] = -w * w * f_rows[i * nz + c];
                        }
                    }
                    for i in 0..n {
                        carry_diag[i] = w * w;
                        carry_grad[i] = w * r_cons[i];
                    }
                }
            }
            // the basis rows as coefficient ranges, when they are contiguous
            let rows_k = self.contiguous_rows(k);
            if rows_k.is_none() {
                self.spread_at(k, &layout.position, &mut spread, &mut next);
            }
            // gradient
            if !S_ONLY {
                for (a, &ga) in gl.iter().enumerate().take(dim) {
                    if ga != 0.0 {
                        self.for_each_basis_entry(k, a, &base, |c, v| {
                            grad_acc[c] += ga * v;
                        });
                    }
                }
            }
            // the second-order term on (x_k, u_k), added to the local block
            if with_s {
                hz.fill(0.0);
                let u_k = (!terminal).then(|| &u[k * m..(k + 1) * m]);
                let xk = &x[k * n..(k + 1) * n];
                with_s = self.stage_hessian(k, xk, u_k, r_cost, &mut hz[..dim * dim])?;
                if with_s && !terminal && self.lambda[k] > 0.0 {
                    let w = self.scale * self.lambda[k].sqrt();
                    for (wi, ri) in wm.iter_mut().zip(r_cons) {
                        *wi = -w * ri;
                    }
                    hm.fill(0.0);
                    with_s = self.model.weighted_hessian(xk, u_k.unwrap_or(&[]), &wm, &mut hm)?;
                    for (a, b) in hz.iter_mut().zip(&hm) {
                        *a += b;
                    }
                }
                if !with_s {
                    if S_ONLY {
                        return Ok(false);
                    }
                    // not available here: J^T J alone, from the start
                    return self.band_body::<NX, NU, NC, false>(BandJob {
                        at: Point { theta, r },
                        layout,
                        out: BandNormalEquations {
                            h,
                            grad,
                            second_order_diagonal: None,
                        },
                        steps: k0..k1,
                    });
                }
                // one pass for the common case: every entry finite, and zero
                // outside the structure (the errors below name the first offender)
                let mask = if terminal {
                    &terminal_s
                } else if self.lambda[k] > 0.0 {
                    &stage_or_model_s
                } else {
                    &stage_s
                };
                let clean = hz[..dim * dim]
                    .iter()
                    .zip(mask)
                    .all(|(&v, &ok)| v == 0.0 || (ok && v.is_finite()));
                if !clean && let Some(i) = hz[..dim * dim].iter().position(|v| !v.is_finite()) {
                    return Err(TrajoptError::NotFinite {
                        what: "second derivatives",
                        index: i,
                        value: hz[i],
                    });
                }
                let allowed = |i: usize| {
                    if terminal {
                        terminal_s[i]
                    } else {
                        stage_s[i] || (self.lambda[k] > 0.0 && model_s[i])
                    }
                };
                if !clean && let Some(i) = (0..dim * dim).find(|&i| hz[i] != 0.0 && !allowed(i)) {
                    return Err(TrajoptError::InvalidParameter {
                        name: "model",
                        reason: format!(
                            "a second derivative at step {k} ({}, {}) lies outside the Jacobian structure",
                            i / dim,
                            i % dim
                        ),
                    });
                }
                // hz is dim x dim, row-major, symmetric: onto the upper triangle
                // of q, and its diagonal spread for diag(S)
                for a in 0..dim {
                    for b in a..dim {
                        q[a * nz + b] += hz[a * dim + b];
                    }
                    let saa = hz[a * dim + a];
                    if saa != 0.0 && !S_ONLY {
                        self.for_each_basis_entry(k, a, &base, |c, v| {
                            diag_s[c] += saa * v * v;
                        });
                    }
                }
            }
            // the local block whole (only its upper triangle was formed)
            for a in 0..dim {
                for b in 0..a {
                    q[a * nz + b] = q[b * nz + a];
                }
            }
            if let Some(rows_k) = &rows_k {
                let ranges = rows_k.ranges(terminal);
                if !window.holds(ranges.0, ranges.1) {
                    window.flush(|i, j, v| h.add(i, j, v))?;
                    window.open(ranges.0, ranges.1, (ncx, ncu), &base, &layout.position);
                }
                pulp::Arch::new().dispatch(StepSpread {
                    rows: rows_k,
                    window: &mut window,
                    q: &q,
                    cross: (!terminal && !S_ONLY).then_some(&cross[..]),
                    n,
                    nz,
                    terminal,
                });
            } else {
                window.flush(|i, j, v| h.add(i, j, v))?;
                spread_block(h, &q, nz, dim, &spread);
                if !terminal && !S_ONLY {
                    spread_cross(h, &cross, n, nz, &spread, &next);
                }
            }
        }
        window.flush(|i, j, v| h.add(i, j, v))?;
        debug_assert!(k1 <= self.horizon || row + self.initial_state.as_ref().map_or(0, |_| n) == self.n_residuals());
        grad.copy_from_slice(&grad_acc);
        if let Some(diag) = second_order {
            diag.copy_from_slice(&diag_s);
        }
        Ok(with_s)
    }
}

/// One band assembly: the point, the layout, where the normal equations
/// go, and the stages whose residuals contribute.
struct BandJob<'a> {
    at: Point<'a>,
    layout: &'a BandLayout,
    out: BandNormalEquations<'a>,
    steps: std::ops::Range<usize>,
}

/// [`Eq3Problem::band_body`] as a [`FixedShape`] computation.
struct BandBody<'p, 'a, M, C, const S_ONLY: bool> {
    problem: &'p Eq3Problem<M, C>,
    job: BandJob<'a>,
}

impl<M: Dynamics, C: StageCost, const S_ONLY: bool> FixedShape for BandBody<'_, '_, M, C, S_ONLY> {
    type Output = Result<bool>;

    fn run<const NX: usize, const NU: usize, const NC: usize>(self) -> Result<bool> {
        self.problem.band_body::<NX, NU, NC, S_ONLY>(self.job)
    }
}

impl<M: Dynamics, C: StageCost> BandForm for Eq3Problem<M, C> {
    fn layout(&self) -> BandLayout {
        self.band_layout_impl()
    }

    fn normal_equations(&self, at: Point<'_>, layout: &BandLayout, out: BandNormalEquations<'_>) -> Result<bool> {
        let steps = 0..self.horizon + 1;
        self.band_normal_equations_impl(BandJob { at, layout, out, steps })
    }

    fn normal_equations_part(
        &self,
        part: Part,
        at: Point<'_>,
        layout: &BandLayout,
        out: BandNormalEquations<'_>,
    ) -> Result<bool> {
        let steps = self.part_steps(part)?;
        self.band_normal_equations_impl(BandJob { at, layout, out, steps })
    }

    fn residuals_part(&self, part: Part, theta: &[f64], r: &mut [f64]) -> Result<std::ops::Range<usize>> {
        self.residuals_range(theta, r, self.part_steps(part)?)
    }

    fn second_order_part(&self, part: Part, at: Point<'_>, layout: &BandLayout, s: &mut BandedSym) -> Result<bool> {
        let steps = self.part_steps(part)?;
        self.band_second_order_impl(at, layout, s, steps)
    }
}

/// Zeroes the entries outside the declared structure.
#[inline(always)]
fn mask(values: &mut [f64], structure: &[bool]) {
    for (v, &s) in values.iter_mut().zip(structure) {
        if !s {
            *v = 0.0;
        }
    }
}

/// Adds $P^\top Q P$ for the symmetric local block `q` (upper triangle
/// used, stride `nz`, size `dim`) on one sample's basis rows `spread`.
fn spread_block(h: &mut BandedSym, q: &[f64], nz: usize, dim: usize, spread: &[Spread]) {
    for a in 0..dim {
        let sa = &spread[a];
        // a with itself: each unordered pair of its coefficients once
        let qaa = q[a * nz + a];
        if qaa != 0.0 {
            for (i, &(pi, vi)) in sa.iter().enumerate() {
                for &(pj, vj) in &sa[..=i] {
                    let (hi, lo) = if pi >= pj { (pi, pj) } else { (pj, pi) };
                    h.add_lower(hi, lo, qaa * vi * vj);
                }
            }
        }
        // a with b > a: distinct coefficients, each ordered pair once
        for (b, sb) in spread.iter().enumerate().take(dim).skip(a + 1) {
            let qab = q[a * nz + b];
            if qab != 0.0 {
                add_pair(h, qab, sa, sb);
            }
        }
    }
}

/// Adds $P_k^\top E P_{k+1} + P_{k+1}^\top E^\top P_k$ for the cross block
/// `cross` ($(x_k, u_k) \times x_{k+1}$, stride `n`).
fn spread_cross(h: &mut BandedSym, cross: &[f64], n: usize, nz: usize, spread: &[Spread], next: &[Spread]) {
    for (a, sa) in spread.iter().enumerate().take(nz) {
        for (i, sn) in next.iter().enumerate() {
            let e = cross[a * n + i];
            if e != 0.0 {
                add_pair(h, e, sa, sn);
            }
        }
    }
}

/// Adds $e\,(P_a^\top P_b + P_b^\top P_a)$ for the spreads `sa`, `sb` of two
/// distinct local variables: each ordered pair of coefficients once, in
/// the lower triangle; a coefficient on both sides (the same state channel
/// at two samples) meets itself twice.
#[inline(always)]
fn add_pair(h: &mut BandedSym, e: f64, sa: &[(usize, f64)], sb: &[(usize, f64)]) {
    for &(pa, va) in sa {
        let ev = e * va;
        for &(pb, vb) in sb {
            match pa.cmp(&pb) {
                std::cmp::Ordering::Greater => h.add_lower(pa, pb, ev * vb),
                std::cmp::Ordering::Less => h.add_lower(pb, pa, ev * vb),
                std::cmp::Ordering::Equal => h.add_lower(pa, pa, 2.0 * ev * vb),
            }
        }
    }
}

#[cfg(test)]
mod tests;
