//! The single-shooting view of a [`DdpProblem`]: its cost as a function of
//! the stacked controls $U = (u_0, \dots, u_{N-1}) \in \mathbb{R}^{N m}$
//! (the rollout from $x_0$), with the gradient by the adjoint recursion
//! $$p_N = \nabla \ell_f(x_N), \quad
//! \nabla_{u_k} J = \ell_u(x_k, u_k) + f_u^\top p_{k+1}, \quad
//! p_k = \ell_x(x_k, u_k) + f_x^\top p_{k+1},$$
//! so that any optimiser over $\mathbb{R}^{N m}$ (argmin's, for example) can
//! be compared with DDP on the same problem. Control limits are not part of
//! this view.

use crate::error::{DdpError, Result, check_finite, check_len};
use crate::problem::{Cost, CostDerivatives, DdpProblem, Dynamics};

impl<D: Dynamics, C: Cost> DdpProblem<D, C> {
    fn unstack<'a>(&self, controls: &'a [f64]) -> Result<std::slice::ChunksExact<'a, f64>> {
        let m = self.dynamics().control_dim();
        check_len("stacked controls", self.horizon() * m, controls.len())?;
        check_finite("stacked controls", controls)?;
        Ok(controls.chunks_exact(m))
    }

    /// The states $x_0, \dots, x_N$ of the rollout of the stacked controls
    /// $U$ (`controls[k * m + j]` is $u_{k,j}$).
    ///
    /// # Errors
    /// A wrong length, a non-finite control or a failed step.
    pub fn rollout_stacked(&self, controls: &[f64]) -> Result<Vec<Vec<f64>>> {
        let mut states = vec![self.initial_state().to_vec()];
        for u in self.unstack(controls)? {
            let mut next = vec![0.0; self.dynamics().state_dim()];
            self.dynamics().step(&states[states.len() - 1], u, &mut next)?;
            states.push(next);
        }
        Ok(states)
    }

    /// The cost $J(U)$ of the rollout of the stacked controls (infinite if
    /// the rollout is not finite): [`rollout_cost`](Self::rollout_cost) over
    /// a flat vector.
    ///
    /// # Errors
    /// A wrong length, a non-finite control or a failed step.
    pub fn shooting_cost(&self, controls: &[f64]) -> Result<f64> {
        let states = self.rollout_stacked(controls)?;
        let mut total = 0.0;
        for (k, u) in self.unstack(controls)?.enumerate() {
            total += self.cost().running(k, &states[k], u);
        }
        total += self.cost().terminal(&states[self.horizon()]);
        Ok(if total.is_finite() { total } else { f64::INFINITY })
    }

    /// The gradient $\nabla_U J$ of [`shooting_cost`](Self::shooting_cost)
    /// by the adjoint recursion $p_N = \nabla \ell_f(x_N)$,
    /// $\nabla_{u_k} J = \ell_u + f_u^\top p_{k+1}$,
    /// $p_k = \ell_x + f_x^\top p_{k+1}$, with the
    /// dynamics' Jacobians from [`Dynamics::jacobians`].
    ///
    /// # Errors
    /// A wrong length, a non-finite control, a failed step or derivative,
    /// or a rollout that is not finite ([`DdpError::Model`]: there is no
    /// gradient there).
    pub fn shooting_gradient(&self, controls: &[f64]) -> Result<Vec<f64>> {
        let (n, m) = (self.dynamics().state_dim(), self.dynamics().control_dim());
        let states = self.rollout_stacked(controls)?;
        if states.iter().flatten().any(|v| !v.is_finite()) {
            return Err(DdpError::Model("the rollout is not finite: no gradient".into()));
        }
        let horizon = self.horizon();
        let (mut p, mut lxx) = (vec![0.0; n], vec![0.0; n * n]);
        self.cost().terminal_derivatives(&states[horizon], &mut p, &mut lxx);
        let (mut fx, mut fu) = (vec![0.0; n * n], vec![0.0; n * m]);
        let mut d = CostDerivatives::zeros(n, m);
        let mut grad = vec![0.0; horizon * m];
        let us: Vec<&[f64]> = self.unstack(controls)?.collect();
        for k in (0..horizon).rev() {
            fx.fill(0.0);
            fu.fill(0.0);
            d.clear();
            systems::jacobians_or_differences(self.dynamics(), &states[k], us[k], &mut fx, &mut fu)?;
            self.cost().running_derivatives(k, &states[k], us[k], &mut d);
            for j in 0..m {
                grad[k * m + j] = d.lu[j] + (0..n).map(|i| fu[i * m + j] * p[i]).sum::<f64>();
            }
            let next_p: Vec<f64> = (0..n)
                .map(|c| d.lx[c] + (0..n).map(|i| fx[i * n + c] * p[i]).sum::<f64>())
                .collect();
            p = next_p;
        }
        Ok(grad)
    }
}

/// The single-shooting cost $J(U)$ for argmin's solvers (parameters: the
/// stacked controls; see [`DdpProblem::shooting_cost`]).
#[cfg(feature = "argmin")]
impl<D: Dynamics, C: Cost> argmin::core::CostFunction for DdpProblem<D, C> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, controls: &Self::Param) -> std::result::Result<f64, argmin::core::Error> {
        self.shooting_cost(controls).map_err(argmin::core::Error::new)
    }
}

/// The adjoint gradient $\nabla_U J$ for argmin's solvers.
#[cfg(feature = "argmin")]
impl<D: Dynamics, C: Cost> argmin::core::Gradient for DdpProblem<D, C> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;

    fn gradient(&self, controls: &Self::Param) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        self.shooting_gradient(controls).map_err(argmin::core::Error::new)
    }
}

#[cfg(test)]
mod tests {
    use crate::problems::{System, cartpole_swingup};

    #[test]
    fn shooting_cost_is_the_rollout_cost() {
        let p = cartpole_swingup(30).expect("problem");
        let controls: Vec<f64> = (0..30).map(|k| (0.3 * k as f64).sin()).collect();
        let nested: Vec<Vec<f64>> = controls.iter().map(|&u| vec![u]).collect();
        assert_eq!(
            p.shooting_cost(&controls).expect("cost"),
            p.rollout_cost(&nested).expect("cost")
        );
        assert!(p.shooting_cost(&controls[1..]).is_err());
        assert!(p.shooting_gradient(&[f64::NAN; 30]).is_err());
    }

    #[test]
    fn shooting_gradient_matches_central_differences() {
        for system in System::ALL {
            let p = system.problem(25).expect("problem");
            let controls: Vec<f64> = (0..25).map(|k| 2.0 * (0.4 * k as f64).cos()).collect();
            let grad = p.shooting_gradient(&controls).expect("gradient");
            let mut numeric = vec![0.0; 25];
            let mut scratch = vec![0.0; 27];
            crate::diff::central_jacobian(
                |u, out| {
                    out[0] = p.shooting_cost(u)?;
                    Ok(())
                },
                &controls,
                1,
                &mut numeric,
                &mut scratch,
            )
            .expect("differences");
            let scale = grad.iter().fold(1.0_f64, |a, g| a.max(g.abs()));
            for (k, (a, d)) in grad.iter().zip(&numeric).enumerate() {
                assert!((a - d).abs() < 1e-6 * scale, "{system:?} u{k}: {a} vs {d}");
            }
        }
    }
}
