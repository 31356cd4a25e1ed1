//! The task cost of Eq. 3 in residual form, and the paper's Eq. 5 tracking cost.

use faer::Mat;

use crate::error::{Result, TrajoptError, check_finite, expect_len};

/// A stage cost in residual form, $c_k(x, u) = \lVert r^c_k(x, u) \rVert^2$.
pub trait StageCost {
    /// Number of residuals per stage (the same for every stage).
    fn n_residuals(&self) -> usize;

    /// Writes $r^c_k(x_k, u_k)$; `u` is `None` at the terminal stage $k = N$.
    fn residuals(&self, k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> Result<()>;

    /// Writes $\partial r^c_k / \partial x$ (`n_residuals` $\times n$) and
    /// $\partial r^c_k / \partial u$ (`n_residuals` $\times m$), row-major;
    /// at the terminal stage `ju` is ignored.
    fn jacobians(&self, k: usize, x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> Result<()>;

    /// Which entries of the residual Jacobians can be nonzero at any stage
    /// (row-major, as in [`jacobians`](Self::jacobians)); the default says
    /// all. Must not leave out any entry that can be nonzero.
    fn jacobian_structure(&self, jx: &mut [bool], ju: &mut [bool]) {
        jx.fill(true);
        ju.fill(true);
    }

    /// Writes $\sum_a w_a \nabla^2 r^c_{k,a}$ over $z = (x, u)$ (at the
    /// terminal stage over $x$ alone), row-major, and returns `true`; or
    /// returns `false` (the default) when the cost has no second
    /// derivatives (then [`GaussNewton`](crate::GaussNewton) keeps to
    /// Gauss-Newton steps). Nonzeros only where some residual's
    /// [Jacobian structure](Self::jacobian_structure) has both entries.
    fn weighted_hessian(&self, k: usize, x: &[f64], u: Option<&[f64]>, w: &[f64], hess: &mut [f64]) -> Result<bool> {
        let _ = (k, x, u, w, hess);
        Ok(false)
    }
}

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

    fn residuals(&self, k: usize, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) -> Result<()> {
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
    ) -> Result<bool> {
        hess.fill(0.0);
        Ok(true)
    }

    fn jacobians(&self, _k: usize, _x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) -> Result<()> {
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
