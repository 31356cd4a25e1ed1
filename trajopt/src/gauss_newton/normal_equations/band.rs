//! The band form of the normal equations: $J^\top J$ (or $J^\top J + S$)
//! formed by the problem in band storage
//! ([`BandForm`](crate::BandForm)), on this thread or in parts on helper
//! threads, and a band Cholesky factorisation ([`crate::linalg`]).

use std::sync::Arc;

use super::{Damping, NormalEquations};
use crate::error::Result;
use crate::gauss_newton::band_model::BandModel;
use crate::gauss_newton::parallel::Helpers;
use crate::least_squares::{BandForm, BandNormalEquations, LeastSquaresProblem, Part, Point};
use crate::linalg::{BandLayout, BandedSym};

/// The band form: $J^\top J$ (or $J^\top J + S$) formed by the problem in
/// band storage, a band Cholesky factorisation ([`crate::linalg`]).
pub(crate) struct BandSystem<'p> {
    /// The problem's band form, looked up once per solve.
    form: &'p dyn BandForm,
    layout: Arc<BandLayout>,
    /// Threads forming parts of the normal equations, if any.
    helpers: Option<Helpers>,
    second_order: bool,
    /// The model matrix ($J^\top J + S$ or $J^\top J$), and $J^\top J$
    /// alone on demand.
    band: BandModel,
    /// The diagonal of $S$ (parameter order), to recover $D$ from `h`.
    diag_s: Vec<f64>,
    /// The damped matrix and its factor (the same storage).
    work: Option<BandedSym>,
    /// Vectors in the band order.
    rhs: Vec<f64>,
    product: Vec<f64>,
}

impl<'p> BandSystem<'p> {
    pub(crate) fn new(
        form: &'p dyn BandForm,
        layout: BandLayout,
        second_order: bool,
        helpers: Option<Helpers>,
    ) -> Self {
        let n = layout.position.len();
        let band = BandModel::new(n, layout.half_bandwidth);
        Self {
            form,
            second_order,
            work: Some(band.h.clone()),
            band,
            diag_s: vec![0.0; n],
            layout: Arc::new(layout),
            helpers,
            rhs: vec![0.0; n],
            product: vec![0.0; n],
        }
    }

    /// $J^\top J$ alone ([`BandModel::form_jtj`]); false if it is not
    /// finite.
    fn form_jtj(&mut self, at: Point<'_>) -> Result<bool> {
        let (helpers, form, layout) = (&mut self.helpers, self.form, &self.layout);
        self.band.form_jtj(|out| form_band(helpers, form, at, layout, out))
    }

    /// $J^\top J = H - S$ from the problem's $S$ alone
    /// ([`BandForm::second_order_part`](crate::BandForm::second_order_part)), cheaper than
    /// forming $J^\top J$; false if the problem does not give $S$ alone or
    /// the difference is not finite.
    fn jtj_from_second_order(&mut self, at: Point<'_>) -> Result<bool> {
        let (helpers, form, layout) = (&mut self.helpers, self.form, &self.layout);
        self.band.jtj_from_second_order(|s| match helpers {
            Some(helpers) => helpers.band_parts(form, at, layout, s.into()),
            None => form.second_order_part(Part::WHOLE, at, layout, s),
        })
    }
}

impl<P: LeastSquaresProblem + ?Sized> NormalEquations<P> for BandSystem<'_> {
    fn helpers_degraded(&mut self) -> bool {
        self.helpers.as_mut().is_some_and(Helpers::degraded)
    }

    fn residuals(&mut self, problem: &P, theta: &[f64], r: &mut [f64]) -> Result<()> {
        match self.helpers.as_mut() {
            Some(helpers) => helpers.residuals(self.form, theta, r),
            None => problem.residuals(theta, r),
        }
    }

    fn assemble(&mut self, _problem: &P, at: Point<'_>, grad: &mut [f64], want_s: bool) -> Result<Option<bool>> {
        let diag_s = (self.second_order && want_s).then_some(&mut self.diag_s[..]);
        let out = BandNormalEquations {
            h: &mut self.band.h,
            grad,
            second_order_diagonal: diag_s,
        };
        self.band.has_s = form_band(&mut self.helpers, self.form, at, &self.layout, out)?;
        self.band.jtj_current = false;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(finite(self.band.h.band()) && finite(grad)) {
            // a non-finite S only rules out Newton steps
            if !self.band.has_s || !self.form_jtj(at)? {
                return Ok(None);
            }
            grad.copy_from_slice(&self.band.grad);
            self.band.replace_by_jtj();
        }
        Ok(Some(self.band.has_s))
    }

    /// Makes $J^\top J$ available for Gauss-Newton steps at this iterate.
    fn ensure_gauss_newton(&mut self, _problem: &P, at: Point<'_>) -> Result<bool> {
        if !self.band.has_s || self.band.jtj_current {
            return Ok(true);
        }
        if self.jtj_from_second_order(at)? {
            return Ok(true);
        }
        self.form_jtj(at)
    }

    /// The diagonal of $J^\top J$ in the parameter order.
    fn jtj_diagonal(&self, out: &mut [f64]) {
        for (i, (o, &p)) in out.iter_mut().zip(&self.layout.position).enumerate() {
            *o = self.band.h.diagonal(p) - if self.band.has_s { self.diag_s[i] } else { 0.0 };
        }
    }

    /// `step` holds $-g$ on entry and $\delta$ on success.
    fn damped_step(&mut self, damping: Damping<'_>, step: &mut [f64]) -> bool {
        let Damping { newton, total, scale } = damping;
        let Some(mut work) = self.work.take() else {
            return false;
        };
        work.copy_from(self.band.matrix(newton));
        let pos = &self.layout.position;
        for ((&p, &d), &g) in pos.iter().zip(scale).zip(step.iter()) {
            self.rhs[p] = g;
            self.product[p] = total * d;
        }
        work.add_to_diagonal(&self.product);
        match work.cholesky_in_place() {
            Ok(chol) => {
                chol.solve_in_place(&mut self.rhs);
                for (d, &p) in step.iter_mut().zip(pos) {
                    *d = self.rhs[p];
                }
                self.work = Some(chol.into_inner());
                true
            }
            Err(work) => {
                self.work = Some(work);
                false
            }
        }
    }

    fn model_mul(&mut self, newton: bool, step: &[f64], out: &mut [f64]) {
        let pos = &self.layout.position;
        for (&d, &p) in step.iter().zip(pos) {
            self.rhs[p] = d;
        }
        self.band.matrix(newton).mul_vec(&self.rhs, &mut self.product);
        for (o, &p) in out.iter_mut().zip(pos) {
            *o = self.product[p];
        }
    }
}

/// The band normal equations, split over the helpers if there are any.
fn form_band(
    helpers: &mut Option<Helpers>,
    form: &dyn BandForm,
    at: Point<'_>,
    layout: &Arc<BandLayout>,
    out: BandNormalEquations<'_>,
) -> Result<bool> {
    match helpers {
        Some(helpers) => helpers.band_parts(form, at, layout, out.into()),
        None => form.normal_equations(at, layout, out),
    }
}
