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

use super::{Eq3Problem, LocalDerivatives, Model, StageCost, expect_len};
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

    /// The basis rows of step `k` into `rows`; false if one of them is not
    /// a contiguous range of coefficients (then the window cannot be used).
    fn contiguous_rows(&self, k: usize, rows: &mut BasisRows) -> bool {
        let terminal = k == self.horizon;
        contiguous_row(&self.phi_x, k, &mut rows.x)
            && (terminal || contiguous_row(&self.phi_x, k + 1, &mut rows.x_next))
            && (terminal || contiguous_row(&self.phi_u, k, &mut rows.u))
    }

    /// $J^\top J$ (and $S$) in band form and $J^\top r$; see the module docs.
    pub(super) fn band_normal_equations_impl(
        &self,
        theta: &[f64],
        r: &[f64],
        layout: &BandLayout,
        jtj: &mut BandedSym,
        grad: &mut [f64],
        mut second_order: Option<&mut BandedSym>,
    ) -> Result<bool> {
        let n_p = self.n_params();
        expect_len("parameters", n_p, theta.len())?;
        expect_len("residuals", self.n_residuals(), r.len())?;
        expect_len("gradient", n_p, grad.len())?;
        expect_len("band layout", n_p, layout.position.len())?;
        for b in std::iter::once(&*jtj).chain(second_order.as_deref()) {
            if b.size() != n_p || b.half_bandwidth() < layout.half_bandwidth {
                return Err(TrajoptError::DimensionMismatch {
                    what: "band matrix size",
                    expected: n_p,
                    actual: b.size(),
                });
            }
        }
        let (n, m, nc) = (self.n, self.m, self.cost.n_residuals());
        let nz = n + m;
        let (x, u) = self.sample(theta);
        let st = self.local_structure();
        // which second derivatives the Jacobian structures allow
        let (stage_s, terminal_s, model_s) = if second_order.is_some() {
            self.local_hessian_structure()
        } else {
            Default::default()
        };
        let mut d = LocalDerivatives {
            jx: vec![0.0; nc * n],
            ju: vec![0.0; nc * m],
            fx: vec![0.0; n * n],
            fu: vec![0.0; n * m],
        };
        jtj.clear();
        let mut band_grad = vec![0.0; n_p];
        let mut with_s = second_order.is_some();
        if let Some(s) = second_order.as_deref_mut() {
            s.clear();
        }
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
        let limit: Vec<usize> = (0..nz).map(|a| if a < n { ncx } else { ncu }).collect();
        let (mut window, mut s_window) = (Window::new(nz), Window::new(nz));
        let mut rows_k = BasisRows::new(n);
        let (mut need_first, mut need_len) = (vec![0; nz], vec![0; nz]);
        let mut spread = vec![Vec::new(); nz];
        let mut next = vec![Vec::new(); n];
        // the initial-state rows r = sqrt(w0) (x_0 - x0) sit after all steps
        if let Some((_, w0)) = &self.initial_state {
            let init_row = self.n_residuals() - n;
            carry_diag.fill(*w0);
            for (g, ri) in carry_grad.iter_mut().zip(&r[init_row..]) {
                *g = w0.sqrt() * ri;
            }
        }
        let mut row = 0;
        for k in 0..=self.horizon {
            let terminal = k == self.horizon;
            let dim = if terminal { n } else { nz };
            self.local_derivatives(k, &x, &u, &mut d)?;
            mask(&mut d.jx, &st.jx);
            mask(&mut d.ju, &st.ju);
            mask(&mut d.fx, &st.fx);
            mask(&mut d.fu, &st.fu);
            let r_cost = &r[row..row + nc];
            row += nc;
            q.fill(0.0);
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
                let r_cons = &r[row..row + n];
                row += n;
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
            // the basis rows as coefficient ranges, when they are contiguous
            let rows = self.contiguous_rows(k, &mut rows_k);
            if !rows {
                self.spread_at(k, &layout.position, &mut spread, &mut next);
            }
            // gradient
            for (a, &ga) in gl.iter().enumerate().take(dim) {
                if rows {
                    let (first, vals) = rows_k.row(a);
                    for (i, &v) in vals.iter().enumerate() {
                        band_grad[layout.position[base[a] + first + i]] += ga * v;
                    }
                } else {
                    for &(p, v) in &spread[a] {
                        band_grad[p] += ga * v;
                    }
                }
            }
            if rows {
                let mut fits = true;
                for a in 0..nz {
                    let (f, l) = if a >= dim {
                        (0, 0)
                    } else if a < n && !terminal {
                        let (f, l) = (rows_k.x.0, rows_k.x.1.len());
                        let (f1, l1) = (rows_k.x_next.0, rows_k.x_next.1.len());
                        let lo = f.min(f1);
                        (lo, (f + l).max(f1 + l1) - lo)
                    } else {
                        let row = rows_k.row(a);
                        (row.0, row.1.len())
                    };
                    need_first[a] = f;
                    need_len[a] = l;
                    fits &= l == 0 || window.holds(a, f, l);
                }
                if !fits {
                    window.flush(jtj, &base, &layout.position)?;
                    window.open(&need_first, &need_len, &limit);
                }
                rows_k.accumulate(&mut window, &q, nz, dim);
                if !terminal {
                    rows_k.accumulate_cross(&mut window, &cross, n, nz);
                }
            } else {
                window.flush(jtj, &base, &layout.position)?;
                spread_block(jtj, &q, nz, dim, &spread);
                if !terminal {
                    spread_cross(jtj, &cross, n, nz, &spread, &next);
                }
            }
            // the second-order term on (x_k, u_k)
            if let (true, Some(s)) = (with_s, second_order.as_deref_mut()) {
                hz.fill(0.0);
                let u_k = (!terminal).then(|| &u[k * m..(k + 1) * m]);
                let xk = &x[k * n..(k + 1) * n];
                with_s = self.cost.weighted_hessian(k, xk, u_k, r_cost, &mut hz[..dim * dim])?;
                if with_s && !terminal && self.lambda[k] > 0.0 {
                    let w = self.scale * self.lambda[k].sqrt();
                    for (wi, ri) in wm.iter_mut().zip(&r[row - n..row]) {
                        *wi = -w * ri;
                    }
                    hm.fill(0.0);
                    with_s = self.model.weighted_hessian(xk, u_k.unwrap_or(&[]), &wm, &mut hm)?;
                    for (a, b) in hz.iter_mut().zip(&hm) {
                        *a += b;
                    }
                }
                if with_s {
                    if let Some(i) = hz[..dim * dim].iter().position(|v| !v.is_finite()) {
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
                    if let Some(i) = (0..dim * dim).find(|&i| hz[i] != 0.0 && !allowed(i)) {
                        return Err(TrajoptError::InvalidParameter {
                            name: "model",
                            reason: format!(
                                "a second derivative at step {k} ({}, {}) lies outside the Jacobian structure",
                                i / dim,
                                i % dim
                            ),
                        });
                    }
                    // hz is dim x dim, row-major: to the nz stride of q
                    for a in 0..dim {
                        q[a * nz..a * nz + dim].copy_from_slice(&hz[a * dim..(a + 1) * dim]);
                    }
                    if rows {
                        if !(0..nz).all(|a| need_len[a] == 0 || s_window.holds(a, need_first[a], need_len[a])) {
                            s_window.flush(s, &base, &layout.position)?;
                            s_window.open(&need_first, &need_len, &limit);
                        }
                        rows_k.accumulate(&mut s_window, &q, nz, dim);
                    } else {
                        s_window.flush(s, &base, &layout.position)?;
                        spread_block(s, &q, nz, dim, &spread);
                    }
                }
            }
        }
        window.flush(jtj, &base, &layout.position)?;
        if let Some(s) = second_order.as_deref_mut() {
            s_window.flush(s, &base, &layout.position)?;
        }
        debug_assert_eq!(row + self.initial_state.as_ref().map_or(0, |_| n), self.n_residuals());
        for (g, &p) in grad.iter_mut().zip(&layout.position) {
            *g = band_grad[p];
        }
        Ok(with_s && second_order.is_some())
    }
}

/// How far a window's coefficient block reaches beyond the first support
/// that opened it: the window then serves the next few spans before it is
/// flushed (a wider block costs nothing per step, only per flush).
const WINDOW_REACH: usize = 4;

/// A dense accumulator for the contributions of a run of consecutive steps
/// whose basis rows all fall in the same coefficient ranges (one range per
/// local channel: $n$ state channels, then $m$ control channels). Each step
/// adds small dense outer products at fixed offsets (no position lookups,
/// no branches, contiguous rows); the block is added to the band matrix
/// once, when a step leaves the ranges. Only the blocks $(a, b)$ with
/// $a \le b$ are kept (the matrix is symmetric), the diagonal blocks whole.
struct Window {
    /// First coefficient index of each channel's range (`usize::MAX`: closed).
    start: Vec<usize>,
    len: Vec<usize>,
    /// Offset of each channel's range in the slots.
    off: Vec<usize>,
    size: usize,
    acc: Vec<f64>,
}

impl Window {
    fn new(channels: usize) -> Self {
        Self {
            start: vec![usize::MAX; channels],
            len: vec![0; channels],
            off: vec![0; channels],
            size: 0,
            acc: Vec::new(),
        }
    }

    /// Whether coefficients `first..first + len` of channel `a` are inside.
    fn holds(&self, a: usize, first: usize, len: usize) -> bool {
        self.start[a] != usize::MAX && first >= self.start[a] && first + len <= self.start[a] + self.len[a]
    }

    /// Opens ranges starting at `first[a]` of `len[a] + WINDOW_REACH` (clipped to `limit[a]` coefficients).
    fn open(&mut self, first: &[usize], len: &[usize], limit: &[usize]) {
        let mut size = 0;
        for a in 0..self.start.len() {
            self.start[a] = first[a];
            self.len[a] = (len[a] + WINDOW_REACH).min(limit[a] - first[a]);
            self.off[a] = size;
            size += self.len[a];
        }
        self.size = size;
        self.acc.clear();
        self.acc.resize(size * size, 0.0);
    }

    /// `block(a, b) += q u v^T`, `u` from coefficient `fa` of channel `a`
    /// on, `v` from `fb` of channel `b` on (requires `a <= b`).
    #[inline]
    fn add_outer(&mut self, a: usize, (fa, u): (usize, &[f64]), b: usize, (fb, v): (usize, &[f64]), q: f64) {
        debug_assert!(a <= b);
        let row0 = self.off[a] + fa - self.start[a];
        let col0 = self.off[b] + fb - self.start[b];
        let size = self.size;
        // cubic B-splines: 4 x 4, unrolled and vectorised
        if let (Ok(u4), Ok(v4)) = (<&[f64; 4]>::try_from(u), <&[f64; 4]>::try_from(v)) {
            for (i, &ui) in u4.iter().enumerate() {
                let qu = q * ui;
                let start = (row0 + i) * size + col0;
                if let Ok(row) = <&mut [f64; 4]>::try_from(&mut self.acc[start..start + 4]) {
                    for (h, &vj) in row.iter_mut().zip(v4) {
                        *h += qu * vj;
                    }
                }
            }
            return;
        }
        for (i, &ui) in u.iter().enumerate() {
            let qu = q * ui;
            let start = (row0 + i) * size + col0;
            for (h, &vj) in self.acc[start..start + v.len()].iter_mut().zip(v) {
                *h += qu * vj;
            }
        }
    }

    /// Adds the accumulated block into `h` (coefficient `c` of channel `a`
    /// is parameter `base[a] + c`, at `position[..]`) and closes the window.
    fn flush(&mut self, h: &mut BandedSym, base: &[usize], position: &[usize]) -> Result<()> {
        let channels = self.start.len();
        if self.size == 0 {
            return Ok(());
        }
        for a in 0..channels {
            for i in 0..self.len[a] {
                let pa = position[base[a] + self.start[a] + i];
                let row = (self.off[a] + i) * self.size;
                for b in a..channels {
                    // a diagonal block is whole: its upper triangle suffices
                    let first = if b == a { i } else { 0 };
                    for j in first..self.len[b] {
                        let v = self.acc[row + self.off[b] + j];
                        if v != 0.0 {
                            h.add(pa, position[base[b] + self.start[b] + j], v)?;
                        }
                    }
                }
            }
        }
        self.start.fill(usize::MAX);
        self.size = 0;
        Ok(())
    }
}

/// The basis rows of one step as (first coefficient, values) over
/// contiguous coefficients: $x_k$'s (shared by the state channels),
/// $x_{k+1}$'s and $u_k$'s.
struct BasisRows {
    n: usize,
    x: (usize, Vec<f64>),
    x_next: (usize, Vec<f64>),
    u: (usize, Vec<f64>),
}

impl BasisRows {
    fn new(n: usize) -> Self {
        Self {
            n,
            x: (0, Vec::new()),
            x_next: (0, Vec::new()),
            u: (0, Vec::new()),
        }
    }

    /// The row of local channel `a` at step k.
    fn row(&self, a: usize) -> (usize, &[f64]) {
        let r = if a < self.n { &self.x } else { &self.u };
        (r.0, &r.1)
    }

    /// Adds $P^\top Q P$ for the local block `q` (upper triangle, stride
    /// `nz`, size `dim`).
    fn accumulate(&self, window: &mut Window, q: &[f64], nz: usize, dim: usize) {
        for a in 0..dim {
            let (fa, ua) = self.row(a);
            for b in a..dim {
                let qab = q[a * nz + b];
                if qab != 0.0 {
                    let (fb, ub) = self.row(b);
                    window.add_outer(a, (fa, ua), b, (fb, ub), qab);
                }
            }
        }
    }

    /// Adds $P_k^\top E P_{k+1} + P_{k+1}^\top E^\top P_k$ for the cross
    /// block `cross` ($(x_k, u_k) \times x_{k+1}$, stride `n`).
    fn accumulate_cross(&self, window: &mut Window, cross: &[f64], n: usize, nz: usize) {
        let (f1, u1) = (self.x_next.0, &self.x_next.1[..]);
        for a in 0..nz {
            let (fa, ua) = self.row(a);
            for i in 0..n {
                let e = cross[a * n + i];
                if e == 0.0 {
                    continue;
                }
                match a.cmp(&i) {
                    std::cmp::Ordering::Less => window.add_outer(a, (fa, ua), i, (f1, u1), e),
                    std::cmp::Ordering::Greater => window.add_outer(i, (f1, u1), a, (fa, ua), e),
                    std::cmp::Ordering::Equal => {
                        window.add_outer(a, (fa, ua), a, (f1, u1), e);
                        window.add_outer(a, (f1, u1), a, (fa, ua), e);
                    }
                }
            }
        }
    }
}

/// Row `k` of `phi` as (first column, values) if its columns are contiguous.
fn contiguous_row(phi: &faer::sparse::SparseRowMat<usize, f64>, k: usize, out: &mut (usize, Vec<f64>)) -> bool {
    let cols = phi.symbolic().col_idx_of_row_raw(k);
    let Some(&first) = cols.first() else {
        out.0 = 0;
        out.1.clear();
        return true;
    };
    if cols[cols.len() - 1] - first + 1 != cols.len() {
        return false;
    }
    out.0 = first;
    out.1.clear();
    out.1.extend_from_slice(phi.val_of_row(k));
    true
}

/// `q += weight g g^T` (upper triangle, stride `nz`) and `gl += r_weight g`
/// for one local Jacobian row `g`.
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

    #[test]
    fn band_normal_equations_equal_the_sparse_ones() {
        let (problem, theta0) = pendulum_swingup(120, 1e2).expect("problem");
        // a zero weight at one step, and the initial-state rows
        let mut lambda = vec![1e2; 120];
        lambda[7] = 0.0;
        lambda[8] = 3e3;
        let mut problem = problem.with_initial_state(&[0.1, 0.0, 0.0, 0.0], 7.0).expect("x0");
        problem.set_lambda(Lambda::PerStep(lambda)).expect("lambda");
        let theta: Vec<f64> = theta0
            .iter()
            .enumerate()
            .map(|(i, t)| t + 0.3 * (i as f64 * 0.77).sin())
            .collect();
        let (jtj_ref, s_ref, grad_ref, r) = reference(&problem, &theta);
        let layout = problem.band_layout().expect("band form");
        let n_p = problem.n_params();
        layout.validate(n_p).expect("permutation");
        assert!(layout.half_bandwidth < n_p / 3, "not banded: {}", layout.half_bandwidth);
        let mut jtj = BandedSym::zeros(n_p, layout.half_bandwidth);
        let mut s = jtj.clone();
        let mut grad = vec![0.0; n_p];
        let with_s = problem
            .band_normal_equations(&theta, &r, &layout, &mut jtj, &mut grad, Some(&mut s))
            .expect("band");
        assert!(with_s);
        let pos = &layout.position;
        let scale = jtj_ref.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
        for i in 0..n_p {
            assert!(
                (grad[i] - grad_ref[i]).abs() <= 1e-9 * (1.0 + grad_ref[i].abs()),
                "grad {i}"
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
                let got_s = if inside { s.get(pos[i], pos[j]) } else { 0.0 };
                assert!(
                    (got_s - s_ref[i][j]).abs() <= 1e-9 * (1.0 + s_ref[i][j].abs()),
                    "S ({i}, {j}): {got_s} vs {}",
                    s_ref[i][j]
                );
            }
        }
        // bad sizes are errors
        let mut small = BandedSym::zeros(n_p - 1, layout.half_bandwidth);
        assert!(
            problem
                .band_normal_equations(&theta, &r, &layout, &mut small, &mut grad, None)
                .is_err()
        );
        assert!(
            problem
                .band_normal_equations(&theta[1..], &r, &layout, &mut jtj, &mut grad, None)
                .is_err()
        );
    }
}
