//! The paper's Eq. 5 tracking cost, a [`StageCost`] in residual form.

use faer::Mat;

use systems::{ModelResult, StageCost};

use crate::error::{Result, TrajoptError, check_finite, expect_len};

/// The paper's Eq. 5 as a built-in stage cost: quadratic tracking of a state
/// reference $x^d$ and a control reference $u^d$ with diagonal weights,
/// $$c_k = \sum_i q_i (x_{k,i} - x^d_{k,i})^2 + \sum_j r_j (u_{k,j} - u^d_{k,j})^2,
/// \qquad c_N = \sum_i q^f_i (x_{N,i} - x^d_{N,i})^2.$$
/// With a zero control reference this is the paper's $u^\top R u$; with the
/// demonstration's controls, $\lambda = 0$ plans the demonstration itself.
#[derive(Debug, Clone)]
pub struct TrackingCost {
    state_ref: Mat<f64>,
    control_ref: Mat<f64>,
    sqrt_q: Vec<f64>,
    sqrt_r: Vec<f64>,
    sqrt_qf: Vec<f64>,
}

impl TrackingCost {
    /// A tracking cost: `state_ref` is $(N+1) \times n$, `control_ref` is
    /// $N \times m$; `q`, `r`, `q_final` are the nonnegative diagonal weights.
    pub fn new(state_ref: Mat<f64>, control_ref: Mat<f64>, q: &[f64], r: &[f64], q_final: &[f64]) -> Result<Self> {
        let (n, m) = (state_ref.ncols(), control_ref.ncols());
        expect_len("q", n, q.len())?;
        expect_len("q_final", n, q_final.len())?;
        expect_len("r", m, r.len())?;
        expect_len(
            "control reference rows",
            state_ref.nrows().saturating_sub(1),
            control_ref.nrows(),
        )?;
        for (what, w) in [("q", q), ("r", r), ("q_final", q_final)] {
            check_finite(what, w)?;
            if let Some(i) = w.iter().position(|&v| v < 0.0) {
                return Err(TrajoptError::InvalidParameter {
                    name: what,
                    reason: format!("weight {i} is negative ({})", w[i]),
                });
            }
        }
        for (what, mat) in [("state reference", &state_ref), ("control reference", &control_ref)] {
            for j in 0..mat.ncols() {
                if let Some((i, &v)) = mat.col(j).iter().enumerate().find(|(_, v)| !v.is_finite()) {
                    return Err(TrajoptError::NotFinite {
                        what,
                        index: i * mat.ncols() + j,
                        value: v,
                    });
                }
            }
        }
        Ok(Self {
            state_ref,
            control_ref,
            sqrt_q: q.iter().map(|v| v.sqrt()).collect(),
            sqrt_r: r.iter().map(|v| v.sqrt()).collect(),
            sqrt_qf: q_final.iter().map(|v| v.sqrt()).collect(),
        })
    }

    /// The horizon $N$ implied by the references.
    pub fn horizon(&self) -> usize {
        self.control_ref.nrows()
    }
}

impl StageCost for TrackingCost {
    fn n_residuals(&self) -> usize {
        self.sqrt_q.len() + self.sqrt_r.len()
    }

    fn residuals(&self, k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> ModelResult<()> {
        let n = self.sqrt_q.len();
        let w = if u.is_some() { &self.sqrt_q } else { &self.sqrt_qf };
        for i in 0..n {
            r[i] = w[i] * (x[i] - self.state_ref[(k, i)]);
        }
        for (j, rj) in r[n..].iter_mut().enumerate() {
            *rj = match u {
                Some(u) => self.sqrt_r[j] * (u[j] - self.control_ref[(k, j)]),
                None => 0.0,
            };
        }
        Ok(())
    }

    fn jacobian_structure(&self, jx: &mut [bool], ju: &mut [bool]) {
        let (n, m) = (self.sqrt_q.len(), self.sqrt_r.len());
        jx.fill(false);
        ju.fill(false);
        for i in 0..n {
            jx[i * n + i] = true;
        }
        for j in 0..m {
            ju[(n + j) * m + j] = true;
        }
    }

    /// The residuals are linear: zero.
    fn weighted_hessian(
        &self,
        _k: usize,
        _x: &[f64],
        _u: Option<&[f64]>,
        _w: &[f64],
        hess: &mut [f64],
    ) -> ModelResult<bool> {
        hess.fill(0.0);
        Ok(true)
    }

    fn jacobians(&self, _k: usize, _x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> ModelResult<()> {
        let (n, m) = (self.sqrt_q.len(), self.sqrt_r.len());
        let w = if u.is_some() { &self.sqrt_q } else { &self.sqrt_qf };
        jx.fill(0.0);
        ju.fill(0.0);
        for i in 0..n {
            jx[i * n + i] = w[i];
        }
        if u.is_some() {
            for j in 0..m {
                ju[(n + j) * m + j] = self.sqrt_r[j];
            }
        }
        Ok(())
    }
}
