//! Every SIMD kernel of the crate, and the table of the fixed shapes that
//! are compiled with their sizes known.
//!
//! - [`CholeskyKernel`]: the band Cholesky factorisation's loops
//!   ([`BandedSym::cholesky_in_place`](crate::linalg::BandedSym::cholesky_in_place)).
//! - [`KronWindow`] with [`StepSpread`]: Eq. 3's per-step local blocks
//!   spread over the basis coefficients as Kronecker products
//!   ([`crate::eq3`]'s band assembly), with the 4 x 4 basis-row shapes
//!   unrolled ([`KronWindow::kron`]).
//! - [`with_fixed_shape`] holds the (states, controls, stage-cost residuals)
//!   sizes for which the band assembly is compiled with its dimensions known.
//!
//! Each kernel is compiled for the widest vector instructions the
//! processor has (chosen at run time by `pulp`), with the same rounding on
//! every path: the accumulations are fused multiply-adds ([`f64::mul_add`]).

use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::Result;

/// A computation compiled for `NX` states, `NU` controls and `NC`
/// stage-cost residuals known at compile time (all 0: the sizes are known
/// only at run time), which unrolls the small per-step loops (the
/// arithmetic is the same).
pub(crate) trait FixedShape {
    /// What the computation returns.
    type Output;
    /// Runs the computation for the given sizes.
    fn run<const NX: usize, const NU: usize, const NC: usize>(self) -> Self::Output;
}

/// The fixed-shape dispatch table: the common sizes (the cart-pole-sized
/// 4 states, 1 control, 5 cost residuals; the pendulum's 2, 1, 3) compiled
/// with their dimensions known, every other size at run time.
pub(crate) fn with_fixed_shape<F: FixedShape>((n, m, nc): (usize, usize, usize), f: F) -> F::Output {
    match (n, m, nc) {
        (4, 1, 5) => f.run::<4, 1, 5>(),
        (2, 1, 3) => f.run::<2, 1, 3>(),
        _ => f.run::<0, 0, 0>(),
    }
}

/// The band Cholesky factorisation's loops, compiled for the widest vector
/// instructions the processor has (chosen at run time by `pulp`). The
/// rounding is the same on every path: each update is one fused
/// multiply-add ([`f64::mul_add`], rounded once), an FMA instruction on
/// the vector paths and exact in software on any other. Two columns at a
/// time: the trailing entries are loaded and stored once for both, which
/// the factorisation's speed is bound by.
pub(crate) struct CholeskyKernel<'a> {
    pub(crate) n: usize,
    /// The columns to eliminate (`n` for the whole factorisation).
    pub(crate) columns: usize,
    pub(crate) kd: usize,
    pub(crate) ab: &'a mut [f64],
    /// Shared with other eliminations of one matrix's parts: set on a
    /// failure, and a failure when found set (checked every
    /// `ABORT_CHECK` columns).
    pub(crate) abort: Option<&'a AtomicBool>,
}

/// How often an elimination with an abort flag looks at it.
const ABORT_CHECK: usize = 16;

impl pulp::WithSimd for CholeskyKernel<'_> {
    type Output = bool;

    /// Columns two at a time: each entry below them gets column $j$'s
    /// update and then column $j+1$'s, as one column at a time would give
    /// it (the same bits), but is loaded and stored once for both.
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> bool {
        let (n, kd) = (self.n, self.kd);
        let w = kd + 1;
        let columns = self.columns.min(n);
        let fail = |abort: Option<&AtomicBool>| {
            if let Some(abort) = abort {
                abort.store(true, Ordering::Relaxed);
            }
            false
        };
        let mut j = 0;
        while j < columns {
            if let Some(abort) = self.abort
                && j % ABORT_CHECK == 0
                && abort.load(Ordering::Relaxed)
            {
                return false;
            }
            let kn0 = kd.min(n - 1 - j);
            if j + 1 == columns {
                // the last column alone
                let (head, tail) = self.ab.split_at_mut((j + 1) * w);
                let col = &mut head[j * w..];
                if !factor_column(col, kn0) {
                    return fail(self.abort);
                }
                // A[j+c.., j+c] -= L[j+c.., j] L[j+c, j]
                for c in 1..=kn0 {
                    let lc = col[c];
                    if lc != 0.0 {
                        update_column(&mut tail[(c - 1) * w..(c - 1) * w + (kn0 - c + 1)], &col[c..=kn0], lc);
                    }
                }
                j += 1;
                continue;
            }
            let (head, tail) = self.ab.split_at_mut((j + 2) * w);
            let (c0, c1) = head[j * w..].split_at_mut(w);
            if !factor_column(c0, kn0) {
                return fail(self.abort);
            }
            // column j + 1 takes column j's update before its own pivot
            if kn0 > 0 && c0[1] != 0.0 {
                update_column(&mut c1[..kn0], &c0[1..=kn0], c0[1]);
            }
            let kn1 = kd.min(n - 2 - j);
            if !factor_column(c1, kn1) {
                return fail(self.abort);
            }
            // column t = j + 1 + cp (offset c = cp + 1 from column j): rows
            // t..=j+kn0 from both columns, the rows below from column j + 1
            for cp in 1..=kn1 {
                let c = cp + 1;
                let (lc0, lc1) = (if c <= kn0 { c0[c] } else { 0.0 }, c1[cp]);
                let target = &mut tail[(cp - 1) * w..(cp - 1) * w + (kn1 - cp + 1)];
                match (lc0 != 0.0, lc1 != 0.0) {
                    (true, true) => {
                        let len0 = kn0 - c + 1;
                        let (both, below) = target.split_at_mut(len0);
                        for ((t, &a), &b) in both.iter_mut().zip(&c0[c..=kn0]).zip(&c1[cp..cp + len0]) {
                            *t = (-b).mul_add(lc1, (-a).mul_add(lc0, *t));
                        }
                        update_column(below, &c1[cp + len0..=kn1], lc1);
                    }
                    (true, false) => update_column(&mut target[..kn0 - c + 1], &c0[c..=kn0], lc0),
                    (false, true) => update_column(target, &c1[cp..=kn1], lc1),
                    (false, false) => {}
                }
            }
            j += 2;
        }
        true
    }
}

/// Turns the band entries `col` of a column (diagonal first, `kn` below
/// it) into the factor's; false if the pivot is not positive and finite.
#[inline(always)]
fn factor_column(col: &mut [f64], kn: usize) -> bool {
    let d = col[0];
    if !(d > 0.0 && d.is_finite()) {
        return false;
    }
    let l = d.sqrt();
    col[0] = l;
    let inv = 1.0 / l;
    for v in &mut col[1..=kn] {
        *v *= inv;
    }
    true
}

/// `target -= lc * src`, fused.
#[inline(always)]
fn update_column(target: &mut [f64], src: &[f64], lc: f64) {
    for (t, &lr) in target.iter_mut().zip(src) {
        *t = (-lr).mul_add(lc, *t);
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
pub(crate) struct KronWindow {
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

/// A channel block $Q$ of a local matrix: `q` row-major with row stride
/// `stride`, the block's first entry at (row, column) `at`.
#[derive(Clone, Copy)]
struct Block<'a> {
    q: &'a [f64],
    stride: usize,
    at: (usize, usize),
}

/// One side of a Kronecker block: the basis row `phi` from coefficient
/// `first` on, of the state channels or of the control channels.
#[derive(Clone, Copy)]
pub(crate) struct Side<'a> {
    first: usize,
    phi: &'a [f64],
    state: bool,
}

impl KronWindow {
    pub(crate) fn new(n: usize, m: usize) -> Self {
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
    pub(crate) fn holds(&self, x: (usize, usize), u: (usize, usize)) -> bool {
        let inside = |(f, l): (usize, usize), start: usize, len: usize| l == 0 || (f >= start && f + l <= start + len);
        self.size > 0 && inside(x, self.x_start, self.x_len) && inside(u, self.u_start, self.u_len)
    }

    /// Opens the window on ranges from `x.0` and `u.0`, reaching
    /// `WINDOW_REACH` coefficients beyond the lengths (clipped to the
    /// `ncx` and `ncu` coefficients); `base` and `position` map a
    /// channel's coefficient to its band position.
    pub(crate) fn open(
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
    #[inline(always)]
    fn kron(&mut self, rows: Side<'_>, cols: Side<'_>, block: Block<'_>, scale: f64) {
        let Block {
            q,
            stride,
            at: (q_row, q_col),
        } = block;
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
                        return kron_fixed::<$nr, $nc>(&mut self.acc, self.size, (r0, c0), (rows.phi, cols.phi), block, scale);
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

    /// Adds $H = A + A^\top$ into a symmetric matrix through `add(i, j, v)`
    /// (e.g. [`BandedSym::add`](crate::linalg::BandedSym::add), which this
    /// file does not import: the band type uses these kernels) and closes
    /// the window.
    pub(crate) fn flush(&mut self, mut add: impl FnMut(usize, usize, f64) -> Result<()>) -> Result<()> {
        let size = self.size;
        for s1 in 0..size {
            let p1 = self.slot_pos[s1];
            let v = 2.0 * self.acc[s1 * size + s1];
            if v != 0.0 {
                add(p1, p1, v)?;
            }
            for s2 in s1 + 1..size {
                let v = self.acc[s1 * size + s2] + self.acc[s2 * size + s1];
                if v != 0.0 {
                    add(p1, self.slot_pos[s2], v)?;
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
pub(crate) struct StepSpread<'a, 'b> {
    pub(crate) rows: &'a BasisRows<'b>,
    pub(crate) window: &'a mut KronWindow,
    pub(crate) q: &'a [f64],
    pub(crate) cross: Option<&'a [f64]>,
    pub(crate) n: usize,
    pub(crate) nz: usize,
    pub(crate) terminal: bool,
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
#[inline(always)]
fn kron_fixed<const NR: usize, const NC: usize>(
    acc: &mut [f64],
    size: usize,
    (r0, c0): (usize, usize),
    (phi, psi): (&[f64], &[f64]),
    block: Block<'_>,
    scale: f64,
) {
    let Block {
        q,
        stride,
        at: (q_row, q_col),
    } = block;
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
pub(crate) struct BasisRows<'a> {
    pub(crate) x: (usize, &'a [f64]),
    pub(crate) x_next: (usize, &'a [f64]),
    pub(crate) u: (usize, &'a [f64]),
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
    pub(crate) fn ranges(&self, terminal: bool) -> ((usize, usize), (usize, usize)) {
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
        window.kron(
            x,
            x,
            Block {
                q,
                stride: nz,
                at: (0, 0),
            },
            0.5,
        );
        if !terminal {
            window.kron(
                u,
                x,
                Block {
                    q,
                    stride: nz,
                    at: (n, 0),
                },
                1.0,
            );
            window.kron(
                u,
                u,
                Block {
                    q,
                    stride: nz,
                    at: (n, n),
                },
                0.5,
            );
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
        window.kron(
            x,
            x1,
            Block {
                q: cross,
                stride: n,
                at: (0, 0),
            },
            1.0,
        );
        window.kron(
            u,
            x1,
            Block {
                q: cross,
                stride: n,
                at: (n, 0),
            },
            1.0,
        );
    }
}

/// Row `k` of `phi` as (first column, values) if its columns are contiguous.
pub(crate) fn contiguous_row(phi: &faer::sparse::SparseRowMat<usize, f64>, k: usize) -> Option<(usize, &[f64])> {
    let cols = phi.symbolic().col_idx_of_row_raw(k);
    let Some(&first) = cols.first() else {
        return Some((0, &[]));
    };
    (cols[cols.len() - 1] - first + 1 == cols.len()).then(|| (first, phi.val_of_row(k)))
}

/// `q += weight g g^T` (upper triangle, stride `nz`) and `gl += r_weight g`
/// for one local Jacobian row `g`.
#[inline(always)]
pub(crate) fn add_outer(q: &mut [f64], gl: &mut [f64], g: &[f64], nz: usize, weight: f64, r_weight: f64) {
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
