//! The model matrix of the band normal equations, $J^\top J$ or
//! $J^\top J + S$, with $J^\top J$ alone next to it on demand (for
//! Gauss-Newton steps between Newton ones): the state that the one-piece
//! band system and each part of the two-thread split
//! ([`crate::gauss_newton::split::SplitPart`]) keep alike.

use crate::error::Result;
use crate::least_squares::BandNormalEquations;
use crate::linalg::BandedSym;

/// $H$ ($J^\top J$, or $J^\top J + S$ when `has_s`) and $J^\top J$ alone
/// when a Gauss-Newton step asks for it.
pub(crate) struct BandModel {
    /// The model matrix: $J^\top J + S$ when `has_s`, else $J^\top J$.
    pub(crate) h: BandedSym,
    pub(crate) has_s: bool,
    /// $J^\top J$ when `h` holds $J^\top J + S$ and a Gauss-Newton step is
    /// wanted (formed on demand: most Newton iterations need no second pass).
    jtj: Option<BandedSym>,
    /// Whether `jtj` is $J^\top J$ at the current iterate.
    pub(crate) jtj_current: bool,
    /// $S$ alone, for $J^\top J = H - S$ (formed on demand).
    s_band: Option<BandedSym>,
    /// $J^\top r$, formed with $J^\top J$ alone.
    pub(crate) grad: Vec<f64>,
}

impl BandModel {
    /// Zero matrices of size `n` and half-bandwidth `kd`.
    pub(crate) fn new(n: usize, kd: usize) -> Self {
        Self {
            h: BandedSym::zeros(n, kd),
            has_s: false,
            jtj: None,
            jtj_current: false,
            s_band: None,
            grad: vec![0.0; n],
        }
    }

    /// The undamped model matrix of a Newton (`newton`) or a Gauss-Newton
    /// step: $J^\top J$ alone when `h` holds $S$ too and it is formed.
    pub(crate) fn matrix(&self, newton: bool) -> &BandedSym {
        match (&self.jtj, self.has_s && !newton) {
            (Some(jtj), true) => jtj,
            _ => &self.h,
        }
    }

    /// Forms $J^\top J$ alone (and $J^\top r$ into `grad`) by `form` (the
    /// normal equations without $S$); false if they are not finite.
    pub(crate) fn form_jtj(&mut self, form: impl FnOnce(BandNormalEquations<'_>) -> Result<bool>) -> Result<bool> {
        let jtj = self
            .jtj
            .get_or_insert_with(|| BandedSym::zeros(self.h.size(), self.h.half_bandwidth()));
        form(BandNormalEquations {
            h: &mut *jtj,
            grad: &mut self.grad,
            second_order_diagonal: None,
        })?;
        self.jtj_current = true;
        Ok(jtj.band().iter().chain(&self.grad).all(|v| v.is_finite()))
    }

    /// $J^\top J = H - S$ from $S$ alone, formed by `form_s` (false if the
    /// problem does not give it), cheaper than forming $J^\top J$; false
    /// if there is no $S$ alone or the difference is not finite.
    pub(crate) fn jtj_from_second_order(
        &mut self,
        form_s: impl FnOnce(&mut BandedSym) -> Result<bool>,
    ) -> Result<bool> {
        let (n, kd) = (self.h.size(), self.h.half_bandwidth());
        let s = self.s_band.get_or_insert_with(|| BandedSym::zeros(n, kd));
        if !form_s(s)? {
            return Ok(false);
        }
        let jtj = self.jtj.get_or_insert_with(|| BandedSym::zeros(n, kd));
        jtj.copy_from(&self.h);
        jtj.add_scaled(-1.0, s);
        if !jtj.band().iter().all(|v| v.is_finite()) {
            return Ok(false);
        }
        self.jtj_current = true;
        Ok(true)
    }

    /// After a non-finite $S$: $J^\top J$ alone, just formed by
    /// [`form_jtj`](Self::form_jtj), becomes the model matrix.
    pub(crate) fn replace_by_jtj(&mut self) {
        if let Some(jtj) = self.jtj.as_mut() {
            std::mem::swap(&mut self.h, jtj);
        }
        self.has_s = false;
    }
}
