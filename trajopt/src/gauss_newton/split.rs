//! The band normal equations of [`GaussNewton::solve_parallel`](crate::GaussNewton::solve_parallel)
//! on two threads, kept in two parts and factorised in two parts.
//!
//! The problem forms $H = H_0 + H_1$ in two parts
//! ([`LeastSquaresProblem::band_normal_equations_part`]), one on each
//! thread. For a time-ordered problem such as Eq. 3, $H_0$ is zero outside
//! the leading positions $[0, s_1)$ and $H_1$ outside the trailing ones
//! $[s_0, n)$, and the overlap $S = [s_0, s_1)$ is a few dozen
//! coefficients (those whose basis functions reach over the split time).
//! With the positions ordered as (interior of part 0, interior of part 1,
//! $S$), $H + \mu D$ is a block arrow, so each thread eliminates its own
//! interior in its own copy of its part,
//! $$C_p = H_{p,SS} - H_{p,SI_p} (H_{p,I_pI_p} + \mu D_{I_p})^{-1} H_{p,I_pS},$$
//! and only the small Schur blocks $C_p$ and the right-hand side's $S$
//! entries cross threads: the step on $S$ solves
//! $(C_0 + C_1 + \mu D_S)\,\delta_S = b_S - \ldots$, and each thread then
//! back-substitutes its interior. Part 1 is formed in the reversed
//! position order (a valid band layout with the same bandwidth), so that
//! its interior comes first there too and both threads run the same
//! leading elimination ([`BandedSym::eliminate_leading`]). The matrix
//! $H + \mu D$ is positive definite exactly when both interior blocks and
//! $C_0 + C_1 + \mu D_S$ are, so failures are detected as in one piece;
//! the first part to meet a pivot that is not positive stops the other
//! through a shared flag ([`BandedSym::eliminate_leading`]'s `abort`).
//!
//! This replaces adding the helper's half into the solver's matrix and
//! factorising all of it on one thread; the iterates agree with the
//! one-piece solve up to rounding (another elimination order), and are the
//! same for every run.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use crate::error::Result;
use crate::gauss_newton::band_model::BandModel;
use crate::least_squares::{BandForm, BandNormalEquations, Part, Point};
use crate::linalg::{BandLayout, BandedSym};

/// One part's normal equations and the work on them, on the thread that
/// formed them.
pub(crate) struct SplitPart {
    /// 0 (positions in the problem's order) or 1 (reversed).
    part: usize,
    /// The problem's layout in this part's position order.
    layout: Arc<BandLayout>,
    n: usize,
    /// $J^\top J$ (+ $S$) of this part's residuals, and $J^\top J$ alone
    /// on demand.
    band: BandModel,
    /// The damped matrix, eliminated.
    work: BandedSym,
    /// This part's $J^\top r$ and diag $S$ (parameter order).
    pub(crate) grad: Vec<f64>,
    pub(crate) diag_s: Vec<f64>,
    /// The right-hand side, then the solution, in this part's order.
    x: Vec<f64>,
    product: Vec<f64>,
    /// The nonzero extent (global positions) and finiteness of `h` and
    /// `grad`, found when they were formed.
    extent: Option<(usize, usize)>,
    finite: bool,
    /// The last elimination: interior columns and the model it used.
    interior: usize,
    newton: bool,
    /// The parameter at each local position.
    parameter: Vec<usize>,
    /// The interior's damping and right-hand side (local positions).
    damp: Vec<f64>,
    rhs: Vec<f64>,
}

/// The local ranges of a part for the global split `s0..s1`: interior
/// columns, start of $S$, end of the part's nonzero positions.
fn local_ranges(part: usize, n: usize, s0: usize, s1: usize) -> (usize, usize, usize) {
    if part == 0 {
        (s0, s0, s1)
    } else {
        (n - s1, n - s1, n - s0)
    }
}

impl SplitPart {
    /// Part `part` (0 or 1) of a problem with band layout `layout` (in the
    /// problem's order; part 1 reverses it).
    pub(crate) fn new(part: usize, layout: &BandLayout) -> Self {
        let n = layout.position.len();
        let kd = layout.half_bandwidth;
        let layout = if part == 0 {
            layout.clone()
        } else {
            BandLayout {
                position: layout.position.iter().map(|&p| n - 1 - p).collect(),
                half_bandwidth: kd,
            }
        };
        let mut parameter = vec![0; n];
        for (i, &p) in layout.position.iter().enumerate() {
            parameter[p] = i;
        }
        Self {
            parameter,
            damp: vec![0.0; n],
            rhs: vec![0.0; n],
            part,
            layout: Arc::new(layout),
            n,
            band: BandModel::new(n, kd),
            work: BandedSym::zeros(n, kd),
            grad: vec![0.0; n],
            diag_s: vec![0.0; n],
            x: vec![0.0; n],
            product: vec![0.0; n],
            extent: None,
            finite: true,
            interior: 0,
            newton: false,
        }
    }

    /// The global position of local position `l` (and back: the map is
    /// its own inverse).
    #[inline]
    fn global(&self, l: usize) -> usize {
        if self.part == 0 { l } else { self.n - 1 - l }
    }

    /// Forms this part of $J^\top J$ (+ $S$ if `want_s`) and $J^\top r$;
    /// whether $S$ was added.
    pub(crate) fn assemble(&mut self, form: &dyn BandForm, at: Point<'_>, want_s: bool) -> Result<bool> {
        let part = self.part();
        let diag_s = want_s.then_some(&mut self.diag_s[..]);
        let out = BandNormalEquations {
            h: &mut self.band.h,
            grad: &mut self.grad,
            second_order_diagonal: diag_s,
        };
        self.band.has_s = form.normal_equations_part(part, at, &self.layout, out)?;
        if !self.band.has_s {
            self.diag_s.fill(0.0);
        }
        self.band.jtj_current = false;
        self.scan();
        Ok(self.band.has_s)
    }

    /// This part of two.
    fn part(&self) -> Part {
        Part {
            index: self.part,
            count: 2,
        }
    }

    /// Finds the extent and finiteness of the matrix and gradient just
    /// formed.
    fn scan(&mut self) {
        let (extent, finite) = self.band.h.nonzero_extent_and_finite();
        self.finite = finite && self.grad.iter().all(|v| v.is_finite());
        self.extent = extent.map(|(first, last)| {
            let (a, b) = (self.global(first), self.global(last));
            (a.min(b), a.max(b))
        });
    }

    /// Whether the matrix and gradient are finite.
    pub(crate) fn finite(&self) -> bool {
        self.finite
    }

    /// The first and last global positions with a nonzero entry (a
    /// non-finite entry counts as nonzero).
    pub(crate) fn extent(&self) -> Option<(usize, usize)> {
        self.extent
    }

    /// Adds this part's diagonal into `out` (global positions).
    pub(crate) fn add_diagonal(&self, out: &mut [f64]) {
        for l in 0..self.n {
            out[self.global(l)] += self.band.h.diagonal(l);
        }
    }

    /// This part's $J^\top J$ alone ([`BandModel::form_jtj`]); false if
    /// not finite.
    fn form_jtj(&mut self, form: &dyn BandForm, at: Point<'_>) -> Result<bool> {
        let (part, layout) = (self.part(), &self.layout);
        self.band
            .form_jtj(|out| form.normal_equations_part(part, at, layout, out))
    }

    /// After a non-finite $S$: $J^\top J$ alone becomes the matrix; false
    /// if it is not finite either.
    pub(crate) fn replace_by_jtj(&mut self, form: &dyn BandForm, at: Point<'_>) -> Result<bool> {
        if !self.form_jtj(form, at)? {
            return Ok(false);
        }
        self.band.replace_by_jtj();
        self.grad.copy_from_slice(&self.band.grad);
        self.diag_s.fill(0.0);
        self.band.jtj_current = false;
        self.scan();
        Ok(true)
    }

    /// Makes this part's $J^\top J$ available (from $S$ alone when the
    /// problem gives it, else formed again); false if not finite.
    pub(crate) fn ensure_gauss_newton(&mut self, form: &dyn BandForm, at: Point<'_>) -> Result<bool> {
        if !self.band.has_s || self.band.jtj_current {
            return Ok(true);
        }
        let (part, layout) = (self.part(), &self.layout);
        let from_s = self
            .band
            .jtj_from_second_order(|s| form.second_order_part(part, at, layout, s))?;
        if from_s {
            return Ok(true);
        }
        self.form_jtj(form, at)
    }

    /// Eliminates the interior of the damped model matrix for the global
    /// split `s0..s1`, and runs the forward substitution of the right-hand
    /// side: the damping and the right-hand side per global position from
    /// `global` (`(damp, rhs)`; part 1 leaves the $S$ entries of the
    /// right-hand side to part 0), or, without it (part 1 only), this
    /// part's own $\text{total} \cdot \max(\operatorname{diag} J^\top J, 10^{-12})$
    /// and $-J^\top r$ on its interior: the solver's own numbers there, as
    /// no other part touches those coefficients. Returns this part's Schur
    /// block on $S$ (half-bandwidth `kd_s`) and its $S$ entries of the
    /// right-hand side, or `None` if the interior block is not positive
    /// definite.
    ///
    /// `abort` is shared with the other part's elimination: the first to
    /// find a pivot that is not positive stops the other (the whole matrix
    /// is then not positive definite).
    pub(crate) fn eliminate(
        &mut self,
        newton: bool,
        total: f64,
        global: Option<(&[f64], &[f64])>,
        (s0, s1): (usize, usize),
        kd_s: usize,
        abort: Option<&AtomicBool>,
    ) -> Option<(BandedSym, Vec<f64>)> {
        let (interior, s_start, end) = local_ranges(self.part, self.n, s0, s1);
        let s_len = s1 - s0;
        let rhs_end = if self.part == 0 { end } else { interior };
        match global {
            Some((damp, rhs)) => {
                for l in 0..interior {
                    self.damp[l] = damp[self.global(l)];
                }
                for l in 0..rhs_end {
                    self.rhs[l] = rhs[self.global(l)];
                }
            }
            None => {
                debug_assert_eq!(self.part, 1, "part 0 needs the solver's S entries");
                for l in 0..interior {
                    let i = self.parameter[l];
                    let jtj = self.band.h.diagonal(l) - if self.band.has_s { self.diag_s[i] } else { 0.0 };
                    self.damp[l] = total * jtj.max(1e-12);
                    self.rhs[l] = -self.grad[i];
                }
            }
        }
        // the damped model matrix
        self.work.copy_leading_columns(self.band.matrix(newton), end);
        self.work.add_to_diagonal(&self.damp[..interior]);
        let ok = self.work.eliminate_leading(interior, abort);
        self.interior = interior;
        self.newton = newton;
        if !ok {
            return None;
        }
        // global S index of local S index a
        let g = |a: usize| if self.part == 0 { a } else { s_len - 1 - a };
        let mut schur = BandedSym::zeros(s_len, kd_s);
        for a in 0..s_len {
            for b in a..s_len.min(a + kd_s + 1) {
                let v = self.work.get(s_start + b, s_start + a);
                if v != 0.0 {
                    // inside the band of the whole matrix, so of S's
                    let _ = schur.add(g(b), g(a), v);
                }
            }
        }
        self.x.fill(0.0);
        self.x[..rhs_end].copy_from_slice(&self.rhs[..rhs_end]);
        self.work.forward_leading(interior, &mut self.x);
        let mut b_s = vec![0.0; s_len];
        for a in 0..s_len {
            b_s[g(a)] = self.x[s_start + a];
        }
        Some((schur, b_s))
    }

    /// Back substitution after [`eliminate`](Self::eliminate) given the
    /// step on $S$ (`x_s`, global order of $S$ from `s0`): writes the step
    /// on this part's interior into `step` and adds this part's model
    /// matrix times the step into `product` (global positions).
    pub(crate) fn back_substitute(&mut self, x_s: &[f64], s0: usize, step: &mut [f64], product: &mut [f64]) {
        let s_len = x_s.len();
        let s1 = s0 + s_len;
        let (interior, s_start, end) = local_ranges(self.part, self.n, s0, s1);
        for a in 0..s_len {
            let g = if self.part == 0 { a } else { s_len - 1 - a };
            self.x[s_start + a] = x_s[g];
        }
        self.work.backward_leading(interior, &mut self.x);
        for l in 0..interior {
            step[self.global(l)] = self.x[l];
        }
        self.band
            .matrix(self.newton)
            .mul_vec_leading(end, &self.x, &mut self.product);
        for l in 0..end {
            product[self.global(l)] += self.product[l];
        }
    }

    /// Adds this part's model matrix times `x` (global positions) into
    /// `product`.
    pub(crate) fn add_product(&mut self, newton: bool, x: &[f64], product: &mut [f64]) {
        for l in 0..self.n {
            self.x[l] = x[self.global(l)];
        }
        self.band.matrix(newton).mul_vec(&self.x, &mut self.product);
        for l in 0..self.n {
            product[self.global(l)] += self.product[l];
        }
    }
}

/// The global split from the parts' extents: $S = [s_0, s_1)$ holds every
/// position both parts may touch, part 0 nothing beyond $s_1$ and part 1
/// nothing before $s_0$.
pub(crate) fn split_points(n: usize, first: Option<(usize, usize)>, second: Option<(usize, usize)>) -> (usize, usize) {
    let end0 = first.map_or(0, |(_, hi)| hi + 1);
    let start1 = second.map_or(n, |(lo, _)| lo);
    (end0.min(start1), end0.max(start1))
}

/// What the solver thread asks of the helper's part.
pub(crate) enum SplitJob {
    /// [`SplitPart::assemble`], creating the part at the first call.
    Assemble {
        layout: Arc<BandLayout>,
        theta: Vec<f64>,
        r: Vec<f64>,
        want_s: bool,
    },
    /// [`SplitPart::replace_by_jtj`] at the last assembly's point.
    ReplaceByJtj { theta: Vec<f64>, r: Vec<f64> },
    /// [`SplitPart::ensure_gauss_newton`].
    GaussNewton { theta: Vec<f64>, r: Vec<f64> },
    /// [`SplitPart::eliminate`] with the part's own damping and gradient.
    Eliminate {
        newton: bool,
        total: f64,
        split: (usize, usize),
        kd_s: usize,
        abort: Arc<AtomicBool>,
    },
    /// [`SplitPart::back_substitute`].
    BackSubstitute { x_s: Vec<f64>, s0: usize },
    /// [`SplitPart::add_product`].
    Product { newton: bool, x: Vec<f64> },
}

/// The helper's answers, in the order of [`SplitJob`].
pub(crate) enum SplitDone {
    Assembled {
        result: Result<bool>,
        finite: bool,
        grad: Vec<f64>,
        diag_s: Vec<f64>,
        diagonal: Vec<f64>,
        extent: Option<(usize, usize)>,
    },
    Replaced {
        result: Result<bool>,
        grad: Vec<f64>,
        diagonal: Vec<f64>,
        extent: Option<(usize, usize)>,
    },
    GaussNewton(Result<bool>),
    Eliminated(Option<(BandedSym, Vec<f64>)>),
    BackSubstituted {
        step: Vec<f64>,
        product: Vec<f64>,
    },
    Product(Vec<f64>),
}

/// Runs one job on the helper's part (`part`, created at the first
/// assembly).
pub(crate) fn run_job(part: &mut Option<SplitPart>, form: &dyn BandForm, job: SplitJob) -> Option<SplitDone> {
    if let SplitJob::Assemble {
        layout,
        theta,
        r,
        want_s,
    } = job
    {
        let p = part.get_or_insert_with(|| SplitPart::new(1, &layout));
        let result = p.assemble(form, Point { theta: &theta, r: &r }, want_s);
        let mut diagonal = vec![0.0; p.n];
        p.add_diagonal(&mut diagonal);
        return Some(SplitDone::Assembled {
            finite: p.finite(),
            grad: p.grad.clone(),
            diag_s: p.diag_s.clone(),
            extent: p.extent(),
            diagonal,
            result,
        });
    }
    // every other job follows an assembly
    let p = part.as_mut()?;
    Some(match job {
        SplitJob::Assemble { .. } => return None,
        SplitJob::ReplaceByJtj { theta, r } => {
            let result = p.replace_by_jtj(form, Point { theta: &theta, r: &r });
            let mut diagonal = vec![0.0; p.n];
            p.add_diagonal(&mut diagonal);
            SplitDone::Replaced {
                result,
                grad: p.grad.clone(),
                diagonal,
                extent: p.extent(),
            }
        }
        SplitJob::GaussNewton { theta, r } => {
            SplitDone::GaussNewton(p.ensure_gauss_newton(form, Point { theta: &theta, r: &r }))
        }
        SplitJob::Eliminate {
            newton,
            total,
            split,
            kd_s,
            abort,
        } => SplitDone::Eliminated(p.eliminate(newton, total, None, split, kd_s, Some(&abort))),
        SplitJob::BackSubstitute { x_s, s0 } => {
            let (mut step, mut product) = (vec![0.0; p.n], vec![0.0; p.n]);
            p.back_substitute(&x_s, s0, &mut step, &mut product);
            SplitDone::BackSubstituted { step, product }
        }
        SplitJob::Product { newton, x } => {
            let mut product = vec![0.0; p.n];
            p.add_product(newton, &x, &mut product);
            SplitDone::Product(product)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eq3::{Eq3Problem, TrackingCost};
    use crate::least_squares::LeastSquaresProblem;
    use crate::problems::{HandPendulum, pendulum_swingup};

    /// The benchmark swing-up at 120 steps, its start, layout and residuals.
    fn benchmark() -> (Eq3Problem<HandPendulum, TrackingCost>, Vec<f64>, BandLayout, Vec<f64>) {
        let (p, theta) = pendulum_swingup(120, 1e2).expect("problem");
        let layout = BandForm::layout(&p);
        let mut r = vec![0.0; p.n_residuals()];
        p.residuals(&theta, &mut r).expect("residuals");
        (p, theta, layout, r)
    }

    /// The two-part elimination gives the step of the whole damped system,
    /// and the product of the model matrix with it, to rounding; the
    /// overlap is a few dozen positions.
    #[test]
    #[allow(clippy::needless_range_loop)]
    fn the_split_solve_equals_the_whole_solve() {
        let (p, theta, layout, r) = benchmark();
        let n = layout.position.len();
        for with_s in [false, true] {
            let mut whole = BandedSym::zeros(n, layout.half_bandwidth);
            let (mut grad, mut diag_s) = (vec![0.0; n], vec![0.0; n]);
            let out = BandNormalEquations {
                h: &mut whole,
                grad: &mut grad,
                second_order_diagonal: with_s.then_some(&mut diag_s[..]),
            };
            p.normal_equations(Point { theta: &theta, r: &r }, &layout, out)
                .expect("whole");
            let (mut a, mut b) = (SplitPart::new(0, &layout), SplitPart::new(1, &layout));
            assert_eq!(
                a.assemble(&p, Point { theta: &theta, r: &r }, with_s).expect("part 0"),
                with_s
            );
            assert_eq!(
                b.assemble(&p, Point { theta: &theta, r: &r }, with_s).expect("part 1"),
                with_s
            );
            for i in 0..n {
                assert!((a.grad[i] + b.grad[i] - grad[i]).abs() <= 1e-9 * (1.0 + grad[i].abs()));
            }
            let (s0, s1) = split_points(n, a.extent(), b.extent());
            assert!(s0 > 0 && s1 < n && s1 > s0, "overlap {s0}..{s1} of {n}");
            assert!(s1 - s0 <= 2 * (layout.half_bandwidth + 1), "overlap {s0}..{s1}");
            // a damping that makes J^T J + S positive definite here
            let mut factor = 1e-3;
            let damp = loop {
                let damp: Vec<f64> = (0..n).map(|q| factor * whole.diagonal(q).abs() + 1e-6).collect();
                let mut damped = whole.clone();
                damped.add_to_diagonal(&damp);
                if damped.cholesky_in_place().is_ok() {
                    break damp;
                }
                factor *= 4.0;
            };
            let rhs: Vec<f64> = (0..n).map(|q| (q as f64 * 0.37).sin()).collect();
            let kd_s = layout.half_bandwidth.min(s1 - s0 - 1);
            let (mut schur, mut b_s) = a
                .eliminate(with_s, 0.0, Some((&damp, &rhs)), (s0, s1), kd_s, None)
                .expect("part 0 interior");
            let (their_schur, their_b) = b
                .eliminate(with_s, 0.0, Some((&damp, &rhs)), (s0, s1), kd_s, None)
                .expect("part 1 interior");
            schur.add_scaled(1.0, &their_schur);
            schur.add_to_diagonal(&damp[s0..s1]);
            for (x, t) in b_s.iter_mut().zip(&their_b) {
                *x += t;
            }
            schur.cholesky_in_place().expect("overlap").solve_in_place(&mut b_s);
            let (mut step, mut product) = (vec![0.0; n], vec![0.0; n]);
            step[s0..s1].copy_from_slice(&b_s);
            a.back_substitute(&b_s, s0, &mut step, &mut product);
            b.back_substitute(&b_s, s0, &mut step, &mut product);
            // the whole system
            let mut damped = whole.clone();
            damped.add_to_diagonal(&damp);
            let mut reference = rhs.clone();
            damped
                .cholesky_in_place()
                .expect("whole")
                .solve_in_place(&mut reference);
            let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for q in 0..n {
                assert!(
                    (step[q] - reference[q]).abs() <= 1e-9 * scale,
                    "{q}: {} vs {}",
                    step[q],
                    reference[q]
                );
            }
            let mut expected = vec![0.0; n];
            whole.mul_vec(&step, &mut expected);
            let pscale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for q in 0..n {
                assert!((product[q] - expected[q]).abs() <= 1e-10 * pscale, "{q}");
            }
            // and a product on its own
            let mut again = vec![0.0; n];
            a.add_product(with_s, &step, &mut again);
            b.add_product(with_s, &step, &mut again);
            for q in 0..n {
                assert!((again[q] - expected[q]).abs() <= 1e-10 * pscale, "{q}");
            }
        }
    }

    /// The helper's part damps its interior and takes its right-hand side
    /// from its own diagonal and gradient: the same bits as from the
    /// solver's global damping $\text{total} \cdot \max(\operatorname{diag}
    /// J^\top J, 10^{-12})$ and $-J^\top r$ of both parts' sums.
    #[test]
    fn the_helper_part_damps_with_its_own_numbers() {
        let (p, theta, layout, r) = benchmark();
        let n = layout.position.len();
        for with_s in [false, true] {
            let (mut a, mut b) = (SplitPart::new(0, &layout), SplitPart::new(1, &layout));
            a.assemble(&p, Point { theta: &theta, r: &r }, with_s).expect("part 0");
            b.assemble(&p, Point { theta: &theta, r: &r }, with_s).expect("part 1");
            let split = split_points(n, a.extent(), b.extent());
            let kd_s = layout.half_bandwidth.min(split.1 - split.0 - 1);
            // the solver's numbers, from the sums of both parts
            let mut diagonal = vec![0.0; n];
            b.add_diagonal(&mut diagonal);
            a.add_diagonal(&mut diagonal);
            let total = 10.0;
            let (mut damp, mut rhs) = (vec![0.0; n], vec![0.0; n]);
            for (i, &q) in layout.position.iter().enumerate() {
                let ds = if with_s { a.diag_s[i] + b.diag_s[i] } else { 0.0 };
                damp[q] = total * (diagonal[q] - ds).max(1e-12);
                rhs[q] = -(a.grad[i] + b.grad[i]);
            }
            let global = b.eliminate(with_s, total, Some((&damp, &rhs)), split, kd_s, None);
            let local = b.eliminate(with_s, total, None, split, kd_s, None);
            assert!(global.is_some());
            assert_eq!(global, local);
        }
    }

    /// A damped matrix that is not positive definite is refused by the
    /// split elimination as by the whole factorisation.
    #[test]
    fn an_indefinite_system_is_refused_in_parts() {
        let (p, theta, layout, r) = benchmark();
        let n = layout.position.len();
        let (mut a, mut b) = (SplitPart::new(0, &layout), SplitPart::new(1, &layout));
        a.assemble(&p, Point { theta: &theta, r: &r }, false).expect("part 0");
        b.assemble(&p, Point { theta: &theta, r: &r }, false).expect("part 1");
        let (s0, s1) = split_points(n, a.extent(), b.extent());
        let kd_s = layout.half_bandwidth.min(s1 - s0 - 1);
        let rhs = vec![1.0; n];
        // a negative damping on one position of each region
        for q in [s0 / 2, (s0 + s1) / 2, (s1 + n) / 2] {
            let mut damp = vec![0.0; n];
            damp[q] = -1e12;
            let parts = (
                a.eliminate(false, 0.0, Some((&damp, &rhs)), (s0, s1), kd_s, None),
                b.eliminate(false, 0.0, Some((&damp, &rhs)), (s0, s1), kd_s, None),
            );
            let refused = match parts {
                (Some((mut c, _)), Some((c1, _))) => {
                    c.add_scaled(1.0, &c1);
                    c.add_to_diagonal(&damp[s0..s1]);
                    c.cholesky_in_place().is_err()
                }
                _ => true,
            };
            assert!(refused, "position {q}");
        }
    }

    #[test]
    fn split_points_cover_every_position() {
        assert_eq!(split_points(10, Some((0, 5)), Some((4, 9))), (4, 6));
        // part 1 empty: no overlap left
        assert_eq!(split_points(10, Some((0, 9)), None), (10, 10));
        // a gap between the parts goes into the overlap
        assert_eq!(split_points(10, Some((0, 3)), Some((6, 9))), (4, 6));
        assert_eq!(split_points(10, None, Some((0, 9))), (0, 0));
    }
}
