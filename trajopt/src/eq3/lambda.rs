//! The per-step consistency weights $\lambda_k$.

use faer::Mat;

use crate::eq3::Dynamics;
use crate::error::{Result, TrajoptError, check_finite, expect_len};

/// The consistency weight $\lambda_k$ of each step.
#[derive(Debug, Clone, PartialEq)]
pub enum Lambda {
    /// The same $\lambda$ at every step.
    Constant(f64),
    /// One $\lambda_k$ per step $k = 0, \dots, N-1$.
    PerStep(Vec<f64>),
}

impl Lambda {
    /// Per-step weights from the model's confidence along a trajectory:
    /// $\lambda_k = g(\text{confidence}(x_k, u_k))$, `default` where the model
    /// has no confidence. The weights are fixed for a solve (evaluate them at
    /// the initial plan, or between solves for a schedule).
    pub fn from_confidence<M: Dynamics>(
        model: &M,
        states: &Mat<f64>,
        controls: &Mat<f64>,
        default: f64,
        g: impl Fn(f64) -> f64,
    ) -> Lambda {
        let x = |k: usize| (0..states.ncols()).map(|i| states[(k, i)]).collect::<Vec<_>>();
        let u = |k: usize| (0..controls.ncols()).map(|j| controls[(k, j)]).collect::<Vec<_>>();
        Lambda::PerStep(
            (0..controls.nrows())
                .map(|k| model.confidence(&x(k), &u(k)).map_or(default, &g))
                .collect(),
        )
    }

    pub(super) fn resolve(&self, horizon: usize) -> Result<Vec<f64>> {
        let values = match self {
            Lambda::Constant(l) => vec![*l; horizon],
            Lambda::PerStep(v) => {
                expect_len("lambda per step", horizon, v.len())?;
                v.clone()
            }
        };
        check_finite("lambda", &values)?;
        if let Some(k) = values.iter().position(|&l| l < 0.0) {
            return Err(TrajoptError::InvalidParameter {
                name: "lambda",
                reason: format!("lambda[{k}] = {} is negative", values[k]),
            });
        }
        Ok(values)
    }
}
