//! The one record of a derivative check: the worst entry of an analytic
//! Jacobian against finite differences, with one error measure for every
//! crate of the workspace (`lwr`, `trajopt` and `ddp` each difference their
//! own functions and keep the worst entry here).

/// The worst disagreement between an analytic Jacobian $J$ and its finite
/// differences $D$ over the entries checked.
///
/// The error of an entry is
/// $\lvert J_{ij} - D_{ij} \rvert / \max(1, \lvert J_{ij} \rvert, \lvert D_{ij} \rvert)$
/// ([`relative_error`](Self::relative_error)): relative for large entries,
/// absolute for small ones, and the same whichever side is wrong. A NaN on
/// either side is the worst error of all.
///
/// ```
/// use solve::JacobianCheck;
/// let mut check = JacobianCheck::new();
/// check.record(0, 0, 2.0, 2.0 + 1e-9);
/// check.record(1, 0, 1.0, 0.0); // a wrong entry
/// check.record(1, 1, 5.0, 5.0);
/// assert_eq!((check.row, check.col, check.max_rel_error), (1, 0, 1.0));
/// check.record(0, 1, f64::NAN, 3.0);
/// assert!(check.max_rel_error.is_nan() && (check.row, check.col) == (0, 1));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JacobianCheck {
    /// The largest error over the checked entries (0 if none was checked,
    /// NaN if an entry was NaN).
    pub max_rel_error: f64,
    /// The output (row) of the worst entry.
    pub row: usize,
    /// The input (column) of the worst entry.
    pub col: usize,
    /// The analytic entry there (NaN if none was checked).
    pub analytic: f64,
    /// The finite difference there (NaN if none was checked).
    pub numeric: f64,
    /// Inputs not checked, because the function failed at a shifted point
    /// (only checks that skip such inputs count them; the others fail).
    pub n_skipped: usize,
}

impl Default for JacobianCheck {
    fn default() -> Self {
        Self::new()
    }
}

impl JacobianCheck {
    /// No entry checked yet: error 0.
    pub fn new() -> Self {
        Self {
            max_rel_error: 0.0,
            row: 0,
            col: 0,
            analytic: f64::NAN,
            numeric: f64::NAN,
            n_skipped: 0,
        }
    }

    /// The error of one entry: $\lvert a - d \rvert / \max(1, \lvert a \rvert, \lvert d \rvert)$,
    /// NaN if either is NaN.
    pub fn relative_error(analytic: f64, numeric: f64) -> f64 {
        if analytic.is_nan() || numeric.is_nan() {
            return f64::NAN;
        }
        (analytic - numeric).abs() / 1f64.max(analytic.abs()).max(numeric.abs())
    }

    /// Checks entry (`row`, `col`): keeps it if its error is worse than the
    /// worst so far (the first NaN stays the worst).
    pub fn record(&mut self, row: usize, col: usize, analytic: f64, numeric: f64) {
        let error = Self::relative_error(analytic, numeric);
        let worse = error > self.max_rel_error || (error.is_nan() && !self.max_rel_error.is_nan());
        if worse {
            *self = Self {
                max_rel_error: error,
                row,
                col,
                analytic,
                numeric,
                ..*self
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_error_is_symmetric_relative_for_large_entries_and_absolute_for_small_ones() {
        assert_eq!(JacobianCheck::relative_error(1e6, 1e6 + 1.0), 1.0 / (1e6 + 1.0));
        assert_eq!(JacobianCheck::relative_error(1e6 + 1.0, 1e6), 1.0 / (1e6 + 1.0));
        assert_eq!(JacobianCheck::relative_error(1e-3, 2e-3), 1e-3);
        assert_eq!(JacobianCheck::relative_error(0.0, 0.0), 0.0);
        assert!(JacobianCheck::relative_error(f64::NAN, 0.0).is_nan());
        assert!(JacobianCheck::relative_error(0.0, f64::INFINITY).is_nan());
    }

    #[test]
    fn the_worst_entry_is_kept_and_a_nan_is_never_replaced() {
        let mut check = JacobianCheck::new();
        assert_eq!(check.max_rel_error, 0.0);
        check.record(2, 3, 1.0, 1.5);
        check.record(0, 0, 1.0, 1.1);
        assert_eq!((check.row, check.col, check.analytic, check.numeric), (2, 3, 1.0, 1.5));
        check.record(4, 1, 0.0, f64::NAN);
        check.record(5, 5, 0.0, 1e9);
        assert!(check.max_rel_error.is_nan());
        assert_eq!((check.row, check.col), (4, 1));
        check.n_skipped = 2;
        check.record(6, 6, f64::NAN, 0.0);
        assert_eq!((check.row, check.col, check.n_skipped), (4, 1, 2));
    }
}
