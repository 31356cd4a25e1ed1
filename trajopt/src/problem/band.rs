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

use super::{Eq3Problem, LocalDerivatives, Model, StageCost, central_differences, expect_len};
use crate::banded::{BandLayout, BandedSym};
use crate::error::{Result, TrajoptError};
use crate::least_squares::LeastSquaresProblem;

/// The band positions and basis values of one local variable at one sample.
type Spread = Vec<(usize, f64)>;

impl<M: Model, C: StageCost> Eq3Problem<M, C> {
    /// The parameter order by first touched sample, and the half-bandwidth
    /// of the normal equations in it.
    pub(super) fn band_layout_impl(&self) -> BandLayout {
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
    /// of the stages `steps` (`0..=horizon` for all); see the module docs.
    /// The stages of one call see the same sums in the same order whatever
    /// range the call has: the contributions of disjoint ranges add up to
    /// the whole up to the rounding of that addition.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn band_normal_equations_impl(
        &self,
        theta: &[f64],
        r: &[f64],
        layout: &BandLayout,
        h: &mut BandedSym,
        grad: &mut [f64],
        second_order: Option<&mut [f64]>,
        steps: std::ops::Range<usize>,
    ) -> Result<bool> {
        // the common sizes compiled with their dimensions known, which
        // unrolls the small per-step loops (the arithmetic is the same)
        match (self.n, self.m, self.cost.n_residuals()) {
            (4, 1, 5) => self.band_body::<4, 1, 5, false>(theta, r, layout, h, grad, second_order, steps),
            (2, 1, 3) => self.band_body::<2, 1, 3, false>(theta, r, layout, h, grad, second_order, steps),
            _ => self.band_body::<0, 0, 0, false>(theta, r, layout, h, grad, second_order, steps),
        }
    }

    /// The second-order term $S$ alone, in band form, from the stages
    /// `steps`: what [`band_normal_equations_impl`](Self::band_normal_equations_impl)
    /// adds to $J^\top J$. False (with `s` cleared) when $S$ is not
    /// available.
    pub(super) fn band_second_order_impl(
        &self,
        theta: &[f64],
        r: &[f64],
        layout: &BandLayout,
        s: &mut BandedSym,
        steps: std::ops::Range<usize>,
    ) -> Result<bool> {
        let mut grad = vec![0.0; self.n_params()];
        let found = match (self.n, self.m, self.cost.n_residuals()) {
            (4, 1, 5) => self.band_body::<4, 1, 5, true>(theta, r, layout, s, &mut grad, None, steps),
            (2, 1, 3) => self.band_body::<2, 1, 3, true>(theta, r, layout, s, &mut grad, None, steps),
            _ => self.band_body::<0, 0, 0, true>(theta, r, layout, s, &mut grad, None, steps),
        }?;
        if !found {
            s.clear();
        }
        Ok(found)
    }

    /// [`band_normal_equations_impl`](Self::band_normal_equations_impl)
    /// for `NX` states, `NU` controls and `NC` stage-cost residuals (all 0:
    /// the problem's own sizes, at run time); with `S_ONLY`, $S$ alone
    /// into `h` (the Jacobian terms, the gradient and `second_order`
    /// skipped), returning whether $S$ is available.
    #[allow(clippy::too_many_arguments)]
    fn band_body<const NX: usize, const NU: usize, const NC: usize, const S_ONLY: bool>(
        &self,
        theta: &[f64],
        r: &[f64],
        layout: &BandLayout,
        h: &mut BandedSym,
        grad: &mut [f64],
        second_order: Option<&mut [f64]>,
        steps: std::ops::Range<usize>,
    ) -> Result<bool> {
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
            (self.n, self.m, self.cost.n_residuals())
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
                central_differences(
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
                self.cost.jacobians(k, xk, uk, &mut d.jx, &mut d.ju)?;
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
                with_s = self.cost.weighted_hessian(k, xk, u_k, r_cost, &mut hz[..dim * dim])?;
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
                    return self.band_body::<NX, NU, NC, false>(theta, r, layout, h, grad, None, k0..k1);
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
                    window.flush(h)?;
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
                window.flush(h)?;
                spread_block(h, &q, nz, dim, &spread);
                if !terminal && !S_ONLY {
                    spread_cross(h, &cross, n, nz, &spread, &next);
                }
            }
        }
        window.flush(h)?;
        debug_assert!(k1 <= self.horizon || row + self.initial_state.as_ref().map_or(0, |_| n) == self.n_residuals());
        grad.copy_from_slice(&grad_acc);
        if let Some(diag) = second_order {
            diag.copy_from_slice(&diag_s);
        }
        Ok(with_s)
    }
}

/// How far a window's coefficient ranges reach beyond the supports that
/// opened it: the window then serves the next few spans before it is
/// flushed (a wider window costs nothing per step, only per flush).
const WINDOW_REACH: usize = 4;

/// A dense accumulator for a run of consecutive steps whose basis rows fall
/// in the same coefficient ranges: `x_len` state coefficients from
/// `x_start` (shared by the $n$ state channels) and `u_len` control
/// coefficients from `u_start`. The slots are coefficient-major (slot
/// `i * n + a` is coefficient `x_start + i` of state channel `a`, the
/// control slots follow), so that a local block $Q$ spread over basis rows
/// $\phi, \psi$ is a Kronecker product $\phi \psi^\top \otimes Q$ whose rows
/// are contiguous: a step adds a few dense vectors of length
/// $|\psi| \cdot$ channels, with no position lookups.
///
/// It holds $A$ with $H = A + A^\top$, so that a symmetric pair of blocks
/// $X + X^\top$ is added once (as $X$); the window goes into the band
/// matrix when a step leaves its ranges.
struct KronWindow {
    n: usize,
    m: usize,
    x_start: usize,
    x_len: usize,
    u_start: usize,
    u_len: usize,
    size: usize,
    /// Row-major `size x size`.
    acc: Vec<f64>,
    /// The band position of each slot.
    slot_pos: Vec<usize>,
    /// One row of a Kronecker product.
    row: Vec<f64>,
}

/// One side of a Kronecker block: the basis row `phi` from coefficient
/// `first` on, of the state channels or of the control channels.
#[derive(Clone, Copy)]
struct Side<'a> {
    first: usize,
    phi: &'a [f64],
    state: bool,
}

impl KronWindow {
    fn new(n: usize, m: usize) -> Self {
        Self {
            n,
            m,
            x_start: 0,
            x_len: 0,
            u_start: 0,
            u_len: 0,
            size: 0,
            acc: Vec::new(),
            slot_pos: Vec::new(),
            row: Vec::new(),
        }
    }

    /// Whether the state range `x` and the control range `u`
    /// ((first, length); length 0: not needed) are inside.
    fn holds(&self, x: (usize, usize), u: (usize, usize)) -> bool {
        let inside = |(f, l): (usize, usize), start: usize, len: usize| l == 0 || (f >= start && f + l <= start + len);
        self.size > 0 && inside(x, self.x_start, self.x_len) && inside(u, self.u_start, self.u_len)
    }

    /// Opens the window on ranges from `x.0` and `u.0`, reaching
    /// `WINDOW_REACH` coefficients beyond the lengths (clipped to the
    /// `ncx` and `ncu` coefficients); `base` and `position` map a
    /// channel's coefficient to its band position.
    fn open(
        &mut self,
        x: (usize, usize),
        u: (usize, usize),
        (ncx, ncu): (usize, usize),
        base: &[usize],
        position: &[usize],
    ) {
        let (n, m) = (self.n, self.m);
        self.x_start = x.0.min(ncx);
        self.x_len = (x.1 + WINDOW_REACH).min(ncx - self.x_start);
        self.u_start = u.0.min(ncu);
        self.u_len = (u.1 + WINDOW_REACH).min(ncu - self.u_start);
        self.size = self.x_len * n + self.u_len * m;
        self.acc.clear();
        self.acc.resize(self.size * self.size, 0.0);
        self.slot_pos.clear();
        for i in 0..self.x_len {
            self.slot_pos
                .extend((0..n).map(|a| position[base[a] + self.x_start + i]));
        }
        for i in 0..self.u_len {
            self.slot_pos
                .extend((0..m).map(|j| position[base[n + j] + self.u_start + i]));
        }
    }

    /// The slot of coefficient `first` of `side`'s first channel.
    fn slot(&self, side: Side<'_>) -> usize {
        if side.state {
            (side.first - self.x_start) * self.n
        } else {
            self.x_len * self.n + (side.first - self.u_start) * self.m
        }
    }

    /// $A \mathrel{+}= \text{scale} \cdot (\phi_r \phi_c^\top) \otimes Q$, $Q$
    /// the `rows.channels x cols.channels` block of `q` (row stride
    /// `stride`) at (`q_row`, `q_col`).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn kron(
        &mut self,
        rows: Side<'_>,
        cols: Side<'_>,
        q: &[f64],
        stride: usize,
        q_row: usize,
        q_col: usize,
        scale: f64,
    ) {
        let (nr, ncl) = (
            if rows.state { self.n } else { self.m },
            if cols.state { self.n } else { self.m },
        );
        let (r0, c0) = (self.slot(rows), self.slot(cols));
        // the common shapes, unrolled: cubic B-splines, n = 4 or 2 states, m = 1 control
        macro_rules! fixed {
            ($($nr:literal, $nc:literal);*) => {
                match (rows.phi.len(), cols.phi.len(), nr, ncl) {
                    $((4, 4, $nr, $nc) => {
                        return kron_fixed::<$nr, $nc>(&mut self.acc, self.size, (r0, c0), rows.phi, cols.phi, q, stride, (q_row, q_col), scale);
                    })*
                    _ => {}
                }
            };
        }
        fixed!(4, 4; 1, 4; 1, 1; 2, 2; 1, 2);
        let width = cols.phi.len() * ncl;
        self.row.resize(width, 0.0);
        for a in 0..nr {
            // the row of the Kronecker product for channel a, up to phi_r[i]
            let qa = &q[(q_row + a) * stride + q_col..(q_row + a) * stride + q_col + ncl];
            if qa.iter().all(|&v| v == 0.0) {
                continue;
            }
            for (chunk, &pj) in self.row.chunks_exact_mut(ncl).zip(cols.phi) {
                for (w, &qb) in chunk.iter_mut().zip(qa) {
                    *w = scale * pj * qb;
                }
            }
            for (i, &pi) in rows.phi.iter().enumerate() {
                let start = (r0 + i * nr + a) * self.size + c0;
                for (h, &w) in self.acc[start..start + width].iter_mut().zip(&self.row) {
                    *h = pi.mul_add(w, *h);
                }
            }
        }
    }

    /// Adds $H = A + A^\top$ into `h` and closes the window.
    fn flush(&mut self, h: &mut BandedSym) -> Result<()> {
        let size = self.size;
        for s1 in 0..size {
            let p1 = self.slot_pos[s1];
            let v = 2.0 * self.acc[s1 * size + s1];
            if v != 0.0 {
                h.add(p1, p1, v)?;
            }
            for s2 in s1 + 1..size {
                let v = self.acc[s1 * size + s2] + self.acc[s2 * size + s1];
                if v != 0.0 {
                    h.add(p1, self.slot_pos[s2], v)?;
                }
            }
        }
        self.size = 0;
        Ok(())
    }
}

/// One step's Kronecker spreads ([`BasisRows::accumulate`], and
/// [`BasisRows::accumulate_cross`] with a cross block) compiled for the
/// widest vector instructions the processor has (chosen at run time by
/// `pulp`; the same rounding on every path: the accumulations are fused
/// multiply-adds, [`f64::mul_add`], as in the band factorisation).
struct StepSpread<'a, 'b> {
    rows: &'a BasisRows<'b>,
    window: &'a mut KronWindow,
    q: &'a [f64],
    cross: Option<&'a [f64]>,
    n: usize,
    nz: usize,
    terminal: bool,
}

impl pulp::WithSimd for StepSpread<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        self.rows
            .accumulate(self.window, self.q, self.n, self.nz, self.terminal);
        if let Some(cross) = self.cross {
            self.rows.accumulate_cross(self.window, cross, self.n);
        }
    }
}

/// [`KronWindow::kron`] for 4 x 4 basis rows and `NR x NC` channel blocks.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn kron_fixed<const NR: usize, const NC: usize>(
    acc: &mut [f64],
    size: usize,
    (r0, c0): (usize, usize),
    phi: &[f64],
    psi: &[f64],
    q: &[f64],
    stride: usize,
    (q_row, q_col): (usize, usize),
    scale: f64,
) {
    let (Ok(phi), Ok(psi)) = (<&[f64; 4]>::try_from(phi), <&[f64; 4]>::try_from(psi)) else {
        return;
    };
    for a in 0..NR {
        let start = (q_row + a) * stride + q_col;
        let Ok(qa) = <&[f64; NC]>::try_from(&q[start..start + NC]) else {
            return;
        };
        // a zero row adds only zeros (S alone is mostly zero rows)
        if qa.iter().all(|&v| v == 0.0) {
            continue;
        }
        let mut row = [[0.0; NC]; 4];
        for (chunk, &pj) in row.iter_mut().zip(psi) {
            for (w, &qb) in chunk.iter_mut().zip(qa) {
                *w = scale * pj * qb;
            }
        }
        let row = row.as_flattened();
        for (i, &pi) in phi.iter().enumerate() {
            let start = (r0 + i * NR + a) * size + c0;
            // one bounds check per row of the window
            let Some(h) = acc.get_mut(start..start + 4 * NC) else {
                return;
            };
            for (hv, &w) in h.iter_mut().zip(row) {
                *hv = pi.mul_add(w, *hv);
            }
        }
    }
}

/// The basis rows of one step as (first coefficient, values) over
/// contiguous coefficients: $x_k$'s (shared by the state channels),
/// $x_{k+1}$'s and $u_k$'s.
struct BasisRows<'a> {
    x: (usize, &'a [f64]),
    x_next: (usize, &'a [f64]),
    u: (usize, &'a [f64]),
}

impl BasisRows<'_> {
    fn side<'b>(row: &(usize, &'b [f64]), state: bool) -> Side<'b> {
        Side {
            first: row.0,
            phi: row.1,
            state,
        }
    }

    /// The state and control coefficient ranges step `k` touches.
    fn ranges(&self, terminal: bool) -> ((usize, usize), (usize, usize)) {
        let (f, l) = (self.x.0, self.x.1.len());
        if terminal {
            return ((f, l), (0, 0));
        }
        let (f1, l1) = (self.x_next.0, self.x_next.1.len());
        let lo = f.min(f1);
        ((lo, (f + l).max(f1 + l1) - lo), (self.u.0, self.u.1.len()))
    }

    /// Adds $P^\top Q P$ for the symmetric local block `q` (full, stride
    /// `nz`, on $(x_k, u_k)$, or $x_N$ alone when `terminal`).
    #[inline(always)]
    fn accumulate(&self, window: &mut KronWindow, q: &[f64], n: usize, nz: usize, terminal: bool) {
        let (x, u) = (Self::side(&self.x, true), Self::side(&self.u, false));
        window.kron(x, x, q, nz, 0, 0, 0.5);
        if !terminal {
            window.kron(u, x, q, nz, n, 0, 1.0);
            window.kron(u, u, q, nz, n, n, 0.5);
        }
    }

    /// Adds $P_k^\top E P_{k+1} + P_{k+1}^\top E^\top P_k$ for the cross
    /// block `cross` ($(x_k, u_k) \times x_{k+1}$, stride `n`).
    #[inline(always)]
    fn accumulate_cross(&self, window: &mut KronWindow, cross: &[f64], n: usize) {
        let (x, u, x1) = (
            Self::side(&self.x, true),
            Self::side(&self.u, false),
            Self::side(&self.x_next, true),
        );
        window.kron(x, x1, cross, n, 0, 0, 1.0);
        window.kron(u, x1, cross, n, n, 0, 1.0);
    }
}

/// Row `k` of `phi` as (first column, values) if its columns are contiguous.
fn contiguous_row(phi: &faer::sparse::SparseRowMat<usize, f64>, k: usize) -> Option<(usize, &[f64])> {
    let cols = phi.symbolic().col_idx_of_row_raw(k);
    let Some(&first) = cols.first() else {
        return Some((0, &[]));
    };
    (cols[cols.len() - 1] - first + 1 == cols.len()).then(|| (first, phi.val_of_row(k)))
}

/// `q += weight g g^T` (upper triangle, stride `nz`) and `gl += r_weight g`
/// for one local Jacobian row `g`.
#[inline(always)]
fn add_outer(q: &mut [f64], gl: &mut [f64], g: &[f64], nz: usize, weight: f64, r_weight: f64) {
    for (c, &gc) in g.iter().enumerate() {
        if gc == 0.0 {
            continue;
        }
        gl[c] += r_weight * gc;
        let wc = weight * gc;
        for (qe, &ge) in q[c * nz + c..c * nz + g.len()].iter_mut().zip(&g[c..]) {
            *qe += wc * ge;
        }
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
            if qab == 0.0 {
                continue;
            }
            for &(pi, vi) in sa {
                let qv = qab * vi;
                for &(pj, vj) in sb {
                    let (hi, lo) = if pi >= pj { (pi, pj) } else { (pj, pi) };
                    h.add_lower(hi, lo, qv * vj);
                }
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
            if e == 0.0 {
                continue;
            }
            for &(pa, va) in sa {
                let ev = e * va;
                for &(pn, vn) in sn {
                    // the same coefficient on both sides meets itself twice
                    match pa.cmp(&pn) {
                        std::cmp::Ordering::Greater => h.add_lower(pa, pn, ev * vn),
                        std::cmp::Ordering::Less => h.add_lower(pn, pa, ev * vn),
                        std::cmp::Ordering::Equal => h.add_lower(pa, pa, 2.0 * ev * vn),
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Lambda;
    use crate::problems::pendulum_swingup;

    /// Dense $J^\top J$, $S$, $J^\top r$ and $r$.
    type Dense = (Vec<Vec<f64>>, Vec<Vec<f64>>, Vec<f64>, Vec<f64>);

    /// $J^\top J$, $S$ and $J^\top r$ from the sparse Jacobian and the sparse
    /// second-order term, dense.
    fn reference<P: LeastSquaresProblem>(p: &P, theta: &[f64]) -> Dense {
        let (n_p, n_r) = (p.n_params(), p.n_residuals());
        let mut r = vec![0.0; n_r];
        p.residuals(theta, &mut r).expect("residuals");
        let pattern = p.jacobian_pattern();
        let mut vals = vec![0.0; pattern.col_idx().len()];
        p.jacobian_values(theta, &mut vals).expect("jacobian");
        let mut jtj = vec![vec![0.0; n_p]; n_p];
        let mut grad = vec![0.0; n_p];
        for (i, &ri) in r.iter().enumerate() {
            let (s, e) = (pattern.row_ptr()[i], pattern.row_ptr()[i + 1]);
            for a in s..e {
                grad[pattern.col_idx()[a]] += vals[a] * ri;
                for b in s..e {
                    jtj[pattern.col_idx()[a]][pattern.col_idx()[b]] += vals[a] * vals[b];
                }
            }
        }
        let sp = p.second_order_pattern().expect("pattern");
        let mut sv = vec![0.0; sp.row_idx().len()];
        assert!(p.second_order_values(theta, &r, &mut sv).expect("S"));
        let mut s = vec![vec![0.0; n_p]; n_p];
        for j in 0..n_p {
            for (q, &i) in sp.row_idx_of_col_raw(j).iter().enumerate() {
                s[i][j] = sv[sp.col_ptr()[j] + q];
            }
        }
        (jtj, s, grad, r)
    }

    /// Compares the band form with the sparse one at a point away from the start.
    fn check_band_equals_sparse<P: LeastSquaresProblem>(problem: &P, theta: &[f64]) {
        let (jtj_ref, s_ref, grad_ref, r) = reference(problem, theta);
        let layout = problem.band_layout().expect("band form");
        let n_p = problem.n_params();
        layout.validate(n_p).expect("permutation");
        let mut jtj = BandedSym::zeros(n_p, layout.half_bandwidth);
        let mut full = jtj.clone();
        let mut grad = vec![0.0; n_p];
        let mut grad_full = vec![0.0; n_p];
        let mut diag_s = vec![0.0; n_p];
        let with_s = problem
            .band_normal_equations(theta, &r, &layout, &mut jtj, &mut grad, None)
            .expect("band");
        assert!(!with_s);
        let with_s = problem
            .band_normal_equations(theta, &r, &layout, &mut full, &mut grad_full, Some(&mut diag_s))
            .expect("band");
        assert!(with_s);
        assert_eq!(grad, grad_full);
        let pos = &layout.position;
        let scale = jtj_ref.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
        for i in 0..n_p {
            assert!(
                (grad[i] - grad_ref[i]).abs() <= 1e-9 * (1.0 + grad_ref[i].abs()),
                "grad {i}"
            );
            assert!(
                (diag_s[i] - s_ref[i][i]).abs() <= 1e-9 * (1.0 + s_ref[i][i].abs()),
                "diag S {i}"
            );
            for j in 0..n_p {
                // an entry outside the band must be zero in the reference
                let (a, b) = (pos[i].max(pos[j]), pos[i].min(pos[j]));
                let inside = a - b <= layout.half_bandwidth;
                let got = if inside { jtj.get(pos[i], pos[j]) } else { 0.0 };
                assert!(
                    (got - jtj_ref[i][j]).abs() <= 1e-12 * scale,
                    "J^T J ({i}, {j}): {got} vs {}",
                    jtj_ref[i][j]
                );
                let expected = jtj_ref[i][j] + s_ref[i][j];
                let got_full = if inside { full.get(pos[i], pos[j]) } else { 0.0 };
                assert!(
                    (got_full - expected).abs() <= 1e-12 * scale + 1e-9 * s_ref[i][j].abs(),
                    "J^T J + S ({i}, {j}): {got_full} vs {expected}"
                );
            }
        }
        check_parts_add_up(problem, theta, &r, &layout, (&jtj, &full), &grad, &diag_s);
        // S alone, whole and in parts, against the reference S
        for parts in [1, 2, 5] {
            let mut s_band = BandedSym::zeros(n_p, layout.half_bandwidth);
            let mut part_s = s_band.clone();
            for part in 0..parts {
                assert!(
                    problem
                        .band_second_order_part(part, parts, theta, &r, &layout, &mut part_s)
                        .expect("S part")
                );
                s_band.add_scaled(1.0, &part_s);
            }
            let s_scale = s_ref.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
            for i in 0..n_p {
                for j in 0..n_p {
                    let (a, b) = (pos[i].max(pos[j]), pos[i].min(pos[j]));
                    let got = if a - b <= layout.half_bandwidth {
                        s_band.get(pos[i], pos[j])
                    } else {
                        0.0
                    };
                    assert!(
                        (got - s_ref[i][j]).abs() <= 1e-12 * s_scale,
                        "S ({i}, {j}) in {parts} parts: {got} vs {}",
                        s_ref[i][j]
                    );
                }
            }
        }
        // bad sizes are errors
        let mut small = BandedSym::zeros(n_p - 1, layout.half_bandwidth);
        assert!(
            problem
                .band_normal_equations(theta, &r, &layout, &mut small, &mut grad, None)
                .is_err()
        );
        assert!(
            problem
                .band_normal_equations(&theta[1..], &r, &layout, &mut jtj, &mut grad, None)
                .is_err()
        );
    }

    /// The parts of the normal equations (with and without $S$) add up to
    /// the whole, for several part counts (more parts than time steps
    /// included: some parts are then empty).
    fn check_parts_add_up<P: LeastSquaresProblem>(
        problem: &P,
        theta: &[f64],
        r: &[f64],
        layout: &BandLayout,
        (jtj, full): (&BandedSym, &BandedSym),
        grad: &[f64],
        diag_s: &[f64],
    ) {
        let n_p = problem.n_params();
        let scale = full.band().iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for parts in [1, 2, 3, 7, 300] {
            for with_s in [false, true] {
                let mut sum = BandedSym::zeros(n_p, layout.half_bandwidth);
                let (mut grad_sum, mut diag_sum) = (vec![0.0; n_p], vec![0.0; n_p]);
                let (mut part_h, mut part_grad, mut part_diag) = (sum.clone(), vec![0.0; n_p], vec![0.0; n_p]);
                for part in 0..parts {
                    let diag = with_s.then_some(&mut part_diag[..]);
                    let got = problem
                        .band_normal_equations_part(part, parts, theta, r, layout, &mut part_h, &mut part_grad, diag)
                        .expect("part");
                    assert_eq!(got, with_s, "part {part} of {parts}");
                    sum.add_scaled(1.0, &part_h);
                    for (a, b) in grad_sum.iter_mut().zip(&part_grad) {
                        *a += b;
                    }
                    for (a, b) in diag_sum.iter_mut().zip(&part_diag) {
                        *a += b;
                    }
                }
                let whole = if with_s { full } else { jtj };
                for (a, b) in sum.band().iter().zip(whole.band()) {
                    assert!((a - b).abs() <= 1e-13 * scale, "{a} vs {b} ({parts} parts)");
                }
                for (a, b) in grad_sum.iter().zip(grad) {
                    assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "grad {a} vs {b}");
                }
                if with_s {
                    for (a, b) in diag_sum.iter().zip(diag_s) {
                        assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "diag S {a} vs {b}");
                    }
                }
            }
        }
        let mut h = BandedSym::zeros(n_p, layout.half_bandwidth);
        let mut g = vec![0.0; n_p];
        assert!(
            problem
                .band_normal_equations_part(2, 2, theta, r, layout, &mut h, &mut g, None)
                .is_err()
        );
    }

    fn perturbed(theta: &[f64]) -> Vec<f64> {
        theta
            .iter()
            .enumerate()
            .map(|(i, t)| t + 0.3 * (i as f64 * 0.77).sin())
            .collect()
    }

    #[test]
    fn band_normal_equations_equal_the_sparse_ones() {
        let (problem, theta0) = pendulum_swingup(120, 1e2).expect("problem");
        // a zero weight at one step, and the initial-state rows
        let mut lambda = vec![1e2; 120];
        lambda[7] = 0.0;
        lambda[8] = 3e3;
        let mut problem = problem.with_initial_state(&[0.1, 0.0, 0.0, 0.0], 7.0).expect("x0");
        problem.set_lambda(Lambda::PerStep(lambda)).expect("lambda");
        let layout = problem.band_layout().expect("band form");
        assert!(
            layout.half_bandwidth < problem.n_params() / 3,
            "not banded: {}",
            layout.half_bandwidth
        );
        check_band_equals_sparse(&problem, &perturbed(&theta0));
    }

    /// Sizes without a fast path compiled for them (3 states, 2 controls):
    /// the loops with the problem's sizes at run time.
    #[test]
    fn band_normal_equations_hold_for_other_sizes() {
        let (horizon, dt) = (30, 0.05);
        let times: Vec<f64> = (0..=horizon).map(|k| k as f64 * dt).collect();
        let a = faer::Mat::from_fn(3, 3, |i, j| if i == j { 1.0 } else { 0.1 * (i + 2 * j) as f64 * dt });
        let b = faer::Mat::from_fn(3, 2, |i, j| (1 + i + j) as f64 * dt);
        let model = crate::LinearModel::new(a, b).expect("model");
        let state_ref = faer::Mat::from_fn(horizon + 1, 3, |k, i| ((k + i) as f64 * 0.2).sin());
        let cost = crate::TrackingCost::new(
            state_ref,
            faer::Mat::zeros(horizon, 2),
            &[1.0, 0.5, 2.0],
            &[0.1, 0.2],
            &[5.0; 3],
        )
        .expect("cost");
        let state_basis = splines::BSplineBasis::clamped_uniform(10, 3, 0.0, times[horizon]).expect("basis");
        let control_basis = splines::BSplineBasis::clamped_uniform(8, 3, 0.0, times[horizon]).expect("basis");
        let problem = Eq3Problem::new(
            model,
            cost,
            &state_basis,
            &control_basis,
            &times,
            Lambda::Constant(30.0),
        )
        .expect("problem")
        .with_initial_state(&[0.1, 0.0, -0.2], 3.0)
        .expect("x0");
        let theta: Vec<f64> = (0..problem.n_params()).map(|i| 0.3 * (i as f64 * 0.61).sin()).collect();
        check_band_equals_sparse(&problem, &theta);
    }

    /// Bases whose rows are not 4 contiguous coefficients: a wavelet basis
    /// for the states (rows spread over levels: the per-entry path), a
    /// quadratic B-spline for the controls (3 coefficients per row).
    #[test]
    fn band_normal_equations_hold_for_other_bases() {
        use splines::wavelet::{Boundary, Wavelet, WaveletBasis};
        let horizon = 40;
        let dt = crate::problems::PENDULUM_DT;
        let times: Vec<f64> = (0..=horizon).map(|k| k as f64 * dt).collect();
        let state_ref = faer::Mat::from_fn(horizon + 1, 4, |k, i| crate::problems::swingup_reference(k)[i]);
        let cost = crate::TrackingCost::new(state_ref, faer::Mat::zeros(horizon, 1), &[1.0; 4], &[0.01], &[10.0; 4])
            .expect("cost");
        let state_basis =
            WaveletBasis::new(Wavelet::Db2, Boundary::Periodization, horizon + 1, None, 0.0, dt).expect("basis");
        let control_basis = splines::BSplineBasis::clamped_uniform(9, 2, 0.0, times[horizon]).expect("basis");
        let problem = Eq3Problem::new(
            crate::problems::Pendulum::default(),
            cost,
            &state_basis,
            &control_basis,
            &times,
            Lambda::Constant(50.0),
        )
        .expect("problem");
        let theta: Vec<f64> = (0..problem.n_params()).map(|i| 0.2 * (i as f64 * 0.37).cos()).collect();
        check_band_equals_sparse(&problem, &theta);
    }
}
