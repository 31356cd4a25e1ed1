//! The band form on two threads ([`crate::gauss_newton::split`]): part 0 of the normal
//! equations on this thread, part 1 on the helper, each eliminating the
//! coefficients only it touches; this thread factorises the Schur
//! complement on the few coefficients both touch.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use super::{Damping, NormalEquations};
use crate::error::{Result, TrajoptError};
use crate::gauss_newton::parallel::Helpers;
use crate::gauss_newton::split::{SplitDone, SplitJob, SplitPart, split_points};
use crate::least_squares::{BandForm, LeastSquaresProblem, Point};
use crate::linalg::BandLayout;

/// The band form on two threads ([`crate::gauss_newton::split`]): part 0 here, part 1
/// on the helper; only the gradient, the diagonals, the Schur blocks on
/// the overlap $S$ and the step's pieces cross threads.
pub(crate) struct SplitSystem<'p> {
    /// The problem's band form, looked up once per solve.
    form: &'p dyn BandForm,
    layout: Arc<BandLayout>,
    second_order: bool,
    mine: SplitPart,
    helpers: Helpers,
    /// The diagonal of $H$ (global positions) and of $S$ (parameter order).
    diagonal: Vec<f64>,
    diag_s: Vec<f64>,
    has_s: bool,
    jtj_current: bool,
    /// The overlap $S = [s_0, s_1)$ of the last assembly.
    split: (usize, usize),
    /// The damping and the right-hand side per global position.
    damp: Vec<f64>,
    rhs: Vec<f64>,
    /// The last step (global positions) and the model matrix times it,
    /// from the back substitution, with the model it used.
    step: Vec<f64>,
    product: Vec<f64>,
    product_of: Option<(bool, Vec<f64>)>,
    /// Set by the first part whose elimination fails, to stop the other.
    abort: Arc<AtomicBool>,
}

impl<'p> SplitSystem<'p> {
    pub(crate) fn new(form: &'p dyn BandForm, layout: BandLayout, second_order: bool, helpers: Helpers) -> Self {
        let n = layout.position.len();
        Self {
            form,
            mine: SplitPart::new(0, &layout),
            layout: Arc::new(layout),
            second_order,
            helpers,
            diagonal: vec![0.0; n],
            diag_s: vec![0.0; n],
            has_s: false,
            jtj_current: false,
            split: (0, 0),
            damp: vec![0.0; n],
            rhs: vec![0.0; n],
            step: vec![0.0; n],
            product: vec![0.0; n],
            product_of: None,
            abort: Arc::new(AtomicBool::new(false)),
        }
    }

    fn helper_lost() -> TrajoptError {
        TrajoptError::InvalidParameter {
            name: "helper thread",
            reason: "it stopped (the problem panicked on it)".into(),
        }
    }
}

impl<P: LeastSquaresProblem + ?Sized> NormalEquations<P> for SplitSystem<'_> {
    fn helpers_degraded(&mut self) -> bool {
        self.helpers.degraded()
    }

    fn residuals(&mut self, _problem: &P, theta: &[f64], r: &mut [f64]) -> Result<()> {
        self.helpers.residuals(self.form, theta, r)
    }

    /// Both parts at `theta`.
    fn assemble(&mut self, _problem: &P, at: Point<'_>, grad: &mut [f64], want_s: bool) -> Result<Option<bool>> {
        let Point { theta, r } = at;
        self.product_of = None;
        self.jtj_current = false;
        let mut want = self.second_order && want_s;
        let (finite, theirs) = loop {
            let job = SplitJob::Assemble {
                layout: Arc::clone(&self.layout),
                theta: theta.to_vec(),
                r: r.to_vec(),
                want_s: want,
            };
            let (mine, theirs) = self
                .helpers
                .split_alongside(job, || self.mine.assemble(self.form, at, want));
            let Some(SplitDone::Assembled {
                result,
                finite,
                grad,
                diag_s,
                diagonal,
                extent,
            }) = theirs
            else {
                return Err(Self::helper_lost());
            };
            let (mine, theirs) = (mine?, result?);
            // S from one part only: both without it
            if want && mine != theirs {
                want = false;
                continue;
            }
            self.has_s = mine && theirs;
            break (self.mine.finite() && finite, (grad, diag_s, diagonal, extent));
        };
        let (mut their_grad, their_diag_s, mut their_diagonal, mut their_extent) = theirs;
        if !finite {
            // a non-finite S only rules out Newton steps
            if !self.has_s {
                return Ok(None);
            }
            let job = SplitJob::ReplaceByJtj {
                theta: theta.to_vec(),
                r: r.to_vec(),
            };
            let (mine, theirs) = self
                .helpers
                .split_alongside(job, || self.mine.replace_by_jtj(self.form, at));
            let Some(SplitDone::Replaced {
                result,
                grad,
                diagonal,
                extent,
            }) = theirs
            else {
                return Err(Self::helper_lost());
            };
            if !(mine? && result?) {
                return Ok(None);
            }
            (their_grad, their_diagonal, their_extent) = (grad, diagonal, extent);
            self.has_s = false;
        }
        for ((g, a), b) in grad.iter_mut().zip(&self.mine.grad).zip(&their_grad) {
            *g = a + b;
        }
        if self.has_s {
            for ((d, a), b) in self.diag_s.iter_mut().zip(&self.mine.diag_s).zip(&their_diag_s) {
                *d = a + b;
            }
        }
        self.diagonal.copy_from_slice(&their_diagonal);
        self.mine.add_diagonal(&mut self.diagonal);
        self.split = split_points(self.diagonal.len(), self.mine.extent(), their_extent);
        Ok(Some(self.has_s))
    }

    fn jtj_diagonal(&self, out: &mut [f64]) {
        for (i, (o, &p)) in out.iter_mut().zip(&self.layout.position).enumerate() {
            *o = self.diagonal[p] - if self.has_s { self.diag_s[i] } else { 0.0 };
        }
    }

    fn ensure_gauss_newton(&mut self, _problem: &P, at: Point<'_>) -> Result<bool> {
        if !self.has_s || self.jtj_current {
            return Ok(true);
        }
        let job = SplitJob::GaussNewton {
            theta: at.theta.to_vec(),
            r: at.r.to_vec(),
        };
        let (mine, theirs) = self
            .helpers
            .split_alongside(job, || self.mine.ensure_gauss_newton(self.form, at));
        let Some(SplitDone::GaussNewton(theirs)) = theirs else {
            return Err(Self::helper_lost());
        };
        let ok = mine? && theirs?;
        self.jtj_current = ok;
        Ok(ok)
    }

    /// `step` holds $-g$ on entry and $\delta$ on success; false if the
    /// damped matrix is not positive definite (or the helper is gone).
    fn damped_step(&mut self, damping: Damping<'_>, step: &mut [f64]) -> bool {
        let Damping { newton, total, scale } = damping;
        self.product_of = None;
        let pos = &self.layout.position;
        for ((&p, &d), &g) in pos.iter().zip(scale).zip(step.iter()) {
            self.rhs[p] = g;
            self.damp[p] = total * d;
        }
        let (s0, s1) = self.split;
        let s_len = s1 - s0;
        let kd_s = self.layout.half_bandwidth.min(s_len.saturating_sub(1));
        // the helper's interior needs only its own numbers; it is idle now,
        // so the flag can be cleared for this elimination
        self.abort.store(false, Ordering::Relaxed);
        let job = SplitJob::Eliminate {
            newton,
            total,
            split: self.split,
            kd_s,
            abort: Arc::clone(&self.abort),
        };
        let (mine, theirs) = self.helpers.split_alongside(job, || {
            let global = Some((&self.damp[..], &self.rhs[..]));
            self.mine
                .eliminate(newton, total, global, self.split, kd_s, Some(&self.abort))
        });
        let Some(SplitDone::Eliminated(theirs)) = theirs else {
            return false;
        };
        let (Some((mut schur, mut b_s)), Some((their_schur, their_b))) = (mine, theirs) else {
            return false;
        };
        // the step on S: (C_0 + C_1 + damping) x_S = b_S
        schur.add_scaled(1.0, &their_schur);
        schur.add_to_diagonal(&self.damp[s0..s1]);
        for (b, t) in b_s.iter_mut().zip(&their_b) {
            *b += t;
        }
        match schur.cholesky_in_place() {
            Ok(chol) => chol.solve_in_place(&mut b_s),
            Err(_) => return false,
        }
        let job = SplitJob::BackSubstitute { x_s: b_s.clone(), s0 };
        let ((), theirs) = self.helpers.split_alongside(job, || {
            self.product.fill(0.0);
            self.step[s0..s1].copy_from_slice(&b_s);
            self.mine.back_substitute(&b_s, s0, &mut self.step, &mut self.product);
        });
        let Some(SplitDone::BackSubstituted {
            step: their_step,
            product: their_product,
        }) = theirs
        else {
            return false;
        };
        // part 1's interior, and the sum of the products
        for (s, t) in self.step[s1..].iter_mut().zip(&their_step[s1..]) {
            *s = *t;
        }
        for (p, t) in self.product.iter_mut().zip(&their_product) {
            *p += t;
        }
        for (d, &p) in step.iter_mut().zip(pos) {
            *d = self.step[p];
        }
        self.product_of = Some((newton, step.to_vec()));
        true
    }

    fn model_mul(&mut self, newton: bool, step: &[f64], out: &mut [f64]) {
        let pos = &self.layout.position;
        let cached = matches!(&self.product_of, Some((nw, st)) if *nw == newton && st[..] == step[..]);
        if !cached {
            for (&d, &p) in step.iter().zip(pos) {
                self.rhs[p] = d;
            }
            let job = SplitJob::Product {
                newton,
                x: self.rhs.clone(),
            };
            let ((), theirs) = self.helpers.split_alongside(job, || {
                self.product.fill(0.0);
                self.mine.add_product(newton, &self.rhs, &mut self.product);
            });
            match theirs {
                Some(SplitDone::Product(theirs)) => {
                    for (p, t) in self.product.iter_mut().zip(&theirs) {
                        *p += t;
                    }
                }
                // the helper is gone: no prediction (the step is then refused)
                _ => self.product.fill(f64::NAN),
            }
        }
        for (o, &p) in out.iter_mut().zip(pos) {
            *o = self.product[p];
        }
    }
}
