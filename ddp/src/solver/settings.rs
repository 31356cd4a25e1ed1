//! The solver's settings and the choice of method.

use super::regularization::Regularization;
use crate::error::{DdpError, Result};

/// Which second-order model of the dynamics the backward pass uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum DdpMethod {
    /// iLQR (Li and Todorov 2004): the dynamics linearised, $Q$-Hessians of
    /// Gauss-Newton form (positive semidefinite whenever the cost Hessians
    /// are). The default.
    #[default]
    Ilqr,
    /// Full DDP (Jacobson and Mayne 1970): adds the tensor terms
    /// $V_x' \cdot f_{xx}$, $V_x' \cdot f_{ux}$, $V_x' \cdot f_{uu}$ from
    /// [`Dynamics::weighted_hessian`](crate::Dynamics::weighted_hessian) (contracted with $V_x'$);
    /// dynamics without second derivatives fall back to iLQR.
    Ddp,
}

/// Settings of [`Ddp`](crate::Ddp).
///
/// | field | default | meaning |
/// |---|---|---|
/// | `max_iterations` | 200 | iterations (backward pass + line search), failed ones included |
/// | `tol_cost` | 1e-12 | converged when the full step's expected reduction $-(\Delta_1 + \Delta_2) \le$ tol $\cdot \max(1, \lvert J \rvert)$ |
/// | `tol_step` | 1e-9 | converged when $\max_{k,i} \lvert k_{k,i} \rvert / (1 + \lvert u_{k,i} \rvert) \le$ tol |
/// | `regularization` | [`Regularization::State`] | where $\mu$ enters |
/// | `reg_init` | 0 | $\mu$ at the start (0: the first step is a pure Newton step) |
/// | `reg_min` | 1e-6 | below it $\mu$ snaps to 0 |
/// | `reg_max` | 1e10 | above it the solver gives up |
/// | `reg_factor` | 2 | Tassa's $\Delta_0$ |
/// | `n_line_search` | 10 | step sizes tried: $\alpha = 1, \beta, \dots, \beta^{9}$ |
/// | `line_search_factor` | 0.5 | $\beta$ |
/// | `min_reduction_ratio` | 0.1 | accept $\alpha$ when actual / expected reduction exceeds it |
/// | `max_state_norm` | 1e8 | a rollout with $\lVert x \rVert_\infty$ beyond it has blown up |
/// | `method` | [`DdpMethod::Ilqr`] | [`DdpMethod::Ddp`] uses the dynamics' second derivatives when provided (full DDP) |
/// | `box_qp_max_iterations` | 100 | projected-Newton iterations per knot with control limits |
///
/// iLQR is the default because on the swing-ups here full DDP never took
/// fewer iterations and often took more (pendulum, $N = 500$: 14 against 6;
/// $N = 5000$: 19 against 14), each one dearer; iLQR's Gauss-Newton
/// $Q$-Hessians are positive semidefinite whenever the cost Hessians are.
///
/// A heavily regularised step is small without being converged: when the
/// tests pass with $\mu > 10\,\mu_{min}$, convergence is only declared if an
/// unregularised backward pass passes them too.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DdpSettings {
    /// Maximum iterations.
    pub max_iterations: usize,
    /// Relative tolerance on the expected cost reduction.
    pub tol_cost: f64,
    /// Tolerance on the relative feedforward step.
    pub tol_step: f64,
    /// Where the regularisation enters.
    pub regularization: Regularization,
    /// Initial regularisation $\mu$.
    pub reg_init: f64,
    /// Smallest nonzero regularisation.
    pub reg_min: f64,
    /// Largest regularisation before giving up.
    pub reg_max: f64,
    /// Tassa's factor $\Delta_0 > 1$.
    pub reg_factor: f64,
    /// Number of step sizes tried per iteration.
    pub n_line_search: usize,
    /// Step-size shrink factor $\beta \in (0, 1)$.
    pub line_search_factor: f64,
    /// Acceptance threshold on actual over expected reduction.
    pub min_reduction_ratio: f64,
    /// Blow-up threshold on $\lVert x_k \rVert_\infty$.
    pub max_state_norm: f64,
    /// iLQR or full DDP.
    pub method: DdpMethod,
    /// Iteration cap of the box-constrained QP at each knot.
    pub box_qp_max_iterations: usize,
}

impl Default for DdpSettings {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            tol_cost: 1e-12,
            tol_step: 1e-9,
            regularization: Regularization::State,
            reg_init: 0.0,
            reg_min: 1e-6,
            reg_max: 1e10,
            reg_factor: 2.0,
            n_line_search: 10,
            line_search_factor: 0.5,
            min_reduction_ratio: 0.1,
            max_state_norm: 1e8,
            method: DdpMethod::Ilqr,
            box_qp_max_iterations: 100,
        }
    }
}

impl DdpSettings {
    /// Checks every setting.
    ///
    /// # Errors
    /// [`DdpError::InvalidParameter`] naming the first bad setting.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &'static str, reason: &str| {
            Err(DdpError::InvalidParameter {
                name,
                reason: reason.into(),
            })
        };
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        if !nonneg(self.tol_cost) {
            return bad("tol_cost", "must be finite and >= 0");
        }
        if !nonneg(self.tol_step) {
            return bad("tol_step", "must be finite and >= 0");
        }
        if !(self.reg_min.is_finite() && self.reg_min > 0.0) {
            return bad("reg_min", "must be finite and > 0");
        }
        if !(self.reg_max.is_finite() && self.reg_max >= self.reg_min) {
            return bad("reg_max", "must be finite and >= reg_min");
        }
        if !(nonneg(self.reg_init) && self.reg_init <= self.reg_max) {
            return bad("reg_init", "must be in [0, reg_max]");
        }
        if !(self.reg_factor.is_finite() && self.reg_factor > 1.0) {
            return bad("reg_factor", "must be finite and > 1");
        }
        if self.n_line_search == 0 {
            return bad("n_line_search", "must be at least 1");
        }
        if !(self.line_search_factor > 0.0 && self.line_search_factor < 1.0) {
            return bad("line_search_factor", "must be in (0, 1)");
        }
        if !(self.min_reduction_ratio.is_finite() && self.min_reduction_ratio >= 0.0 && self.min_reduction_ratio < 1.0)
        {
            return bad("min_reduction_ratio", "must be in [0, 1)");
        }
        if self.max_state_norm.is_nan() || self.max_state_norm <= 0.0 {
            return bad("max_state_norm", "must be > 0");
        }
        if self.box_qp_max_iterations == 0 {
            return bad("box_qp_max_iterations", "must be at least 1");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Ddp;

    /// Makes one setting invalid.
    type Spoil = fn(&mut DdpSettings);

    /// Feature `serde`: the settings and every status travel as JSON
    /// and come back equal; a unit status is its name.
    #[cfg(feature = "serde")]
    #[test]
    fn settings_and_statuses_round_trip_through_serde() {
        use crate::DdpStatus;
        let settings = DdpSettings::default();
        let json = serde_json::to_string(&settings).expect("json");
        assert_eq!(serde_json::from_str::<DdpSettings>(&json).expect("read"), settings);
        for status in [
            DdpStatus::Converged,
            DdpStatus::InitialRolloutDiverged { step: 3 },
            DdpStatus::NoDescent,
        ] {
            let json = serde_json::to_string(&status).expect("json");
            assert_eq!(serde_json::from_str::<DdpStatus>(&json).expect("read"), status);
        }
        assert_eq!(
            serde_json::to_string(&DdpStatus::Converged).expect("json"),
            "\"Converged\""
        );
        // a whole result, its gains and value Hessians (faer matrices) as rows
        let problem = crate::DdpProblem::new(
            crate::Pendulum::default(),
            crate::QuadraticCost::diagonal(&[1.0, 0.1], &[0.01], &[100.0, 10.0])
                .and_then(|c| c.with_state_target(&[std::f64::consts::PI, 0.0]))
                .expect("cost"),
            &[0.0, 0.0],
            50,
        )
        .expect("problem");
        let result = Ddp::new(settings).expect("settings").solve(&problem).expect("solves");
        let json = serde_json::to_string(&result).expect("json");
        let back: crate::DdpResult = serde_json::from_str(&json).expect("read");
        // (serde_json's default float parsing may differ in the last bit)
        let same = |a: &[faer::Mat<f64>], b: &[faer::Mat<f64>]| {
            a.len() == b.len()
                && a.iter().zip(b).all(|(x, y)| {
                    x.shape() == y.shape()
                        && (0..x.nrows()).all(|i| {
                            (0..x.ncols()).all(|j| (x[(i, j)] - y[(i, j)]).abs() <= 1e-14 * (1.0 + y[(i, j)].abs()))
                        })
                })
        };
        assert!(same(&back.gains, &result.gains) && !result.gains.is_empty());
        assert!(same(&back.value_hessian, &result.value_hessian) && !result.value_hessian.is_empty());
        assert_eq!(
            (back.cost, back.status, back.states.len()),
            (result.cost, result.status, 51)
        );
        // a matrix whose rows differ in length is refused
        assert!(
            serde_json::from_str::<crate::DdpResult>(&json.replacen("\"gains\":[[[", "\"gains\":[[[1.0],[", 1))
                .is_err()
        );
    }

    #[test]
    fn default_settings_are_valid_and_bad_ones_are_named() {
        assert!(Ddp::new(DdpSettings::default()).is_ok());
        // one bad setting at a time, and the name the error must give
        let cases: [(Spoil, &str); 6] = [
            (|s| s.reg_min = 0.0, "reg_min"),
            (|s| s.reg_factor = 1.0, "reg_factor"),
            (|s| s.line_search_factor = 1.0, "line_search_factor"),
            (|s| s.n_line_search = 0, "n_line_search"),
            (|s| s.max_state_norm = f64::NAN, "max_state_norm"),
            (|s| s.tol_cost = -1.0, "tol_cost"),
        ];
        for (spoil, name) in cases {
            let mut settings = DdpSettings::default();
            spoil(&mut settings);
            match Ddp::new(settings) {
                Err(DdpError::InvalidParameter { name: n, .. }) => assert_eq!(n, name),
                other => panic!("{name}: {other:?}"),
            }
        }
    }
}
