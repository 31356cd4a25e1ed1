//! Eq. 3's sparse Jacobian: its pattern, the per-step local derivatives
//! (central differences of the model when it gives no Jacobians) and the
//! values in the pattern's order.

use faer::sparse::SymbolicSparseRowMat;

use super::{Dynamics, Eq3Problem, StageCost, expect_len};
use crate::error::Result;
use crate::least_squares::LeastSquaresProblem;

impl<M: Dynamics, C: StageCost> Eq3Problem<M, C> {
    pub(super) fn build_pattern(&self) -> SymbolicSparseRowMat<usize> {
        let n_rows = self.n_residuals();
        let mut row_ptr = vec![0];
        let mut col_idx = Vec::new();
        let mut entries: Vec<usize> = Vec::new();
        let flush = |entries: &mut Vec<usize>, col_idx: &mut Vec<usize>, row_ptr: &mut Vec<usize>| {
            entries.sort_unstable();
            entries.dedup();
            col_idx.append(entries);
            row_ptr.push(col_idx.len());
        };
        // with unit local derivatives, a term is zero only where the
        // structure, the fixed basis value or lambda_k = 0 makes it so
        let result = self.for_each_term(
            &self.local_structure(),
            |_, d| {
                for v in [&mut d.jx, &mut d.ju, &mut d.fx, &mut d.fu] {
                    v.fill(1.0);
                }
                Ok(())
            },
            |row, c, v| {
                while row_ptr.len() <= row {
                    flush(&mut entries, &mut col_idx, &mut row_ptr);
                }
                if v != 0.0 {
                    entries.push(c);
                }
            },
        );
        debug_assert!(result.is_ok());
        while row_ptr.len() <= n_rows {
            flush(&mut entries, &mut col_idx, &mut row_ptr);
        }
        SymbolicSparseRowMat::new_checked(n_rows, self.n_params(), row_ptr, None, col_idx)
    }

    /// Fills the local derivatives of cost and model at step `k`.
    pub(super) fn local_derivatives(&self, k: usize, x: &[f64], u: &[f64], d: &mut LocalDerivatives) -> Result<()> {
        let (n, m) = (self.n, self.m);
        let xk = &x[k * n..(k + 1) * n];
        if k == self.horizon {
            return self.stage_jacobians(k, xk, None, &mut d.jx, &mut d.ju);
        }
        let uk = &u[k * m..(k + 1) * m];
        self.stage_jacobians(k, xk, Some(uk), &mut d.jx, &mut d.ju)?;
        if !self.model.jacobians(xk, uk, &mut d.fx, &mut d.fu)? {
            systems::central_differences(&self.model, xk, uk, &mut d.fx, &mut d.fu)?;
        }
        Ok(())
    }

    /// The structural nonzeros of the local derivatives.
    pub(super) fn local_structure(&self) -> LocalStructure {
        let (n, m, nc) = (self.n, self.m, self.nc());
        let (mut jx, mut ju) = (vec![false; nc * n], vec![false; nc * m]);
        self.stage_structure(&mut jx, &mut ju);
        let (mut fx, mut fu) = (vec![false; n * n], vec![false; n * m]);
        self.model.jacobian_structure(&mut fx, &mut fu);
        LocalStructure { jx, ju, fx, fu }
    }

    /// Calls `term(row, column, value)` for every term of the Jacobian (a
    /// column may repeat within a row: the terms add up), in an order that
    /// depends only on the structure, not on $\theta$; `local(k, d)` fills
    /// the local derivatives of step `k` first.
    pub(super) fn for_each_term(
        &self,
        st: &LocalStructure,
        mut local: impl FnMut(usize, &mut LocalDerivatives) -> Result<()>,
        mut term: impl FnMut(usize, usize, f64),
    ) -> Result<()> {
        let (n, m, nc) = (self.n, self.m, self.nc());
        let mut d = LocalDerivatives {
            jx: vec![0.0; nc * n],
            ju: vec![0.0; nc * m],
            fx: vec![0.0; n * n],
            fu: vec![0.0; n * m],
        };
        let mut row = 0;
        for k in 0..=self.horizon {
            local(k, &mut d)?;
            let terminal = k == self.horizon;
            for a in 0..nc {
                for i in (0..n).filter(|&i| st.jx[a * n + i]) {
                    let g = d.jx[a * n + i];
                    self.state_cols(k, i).for_each(|(c, v)| term(row, c, g * v));
                }
                if !terminal {
                    for j in (0..m).filter(|&j| st.ju[a * m + j]) {
                        let g = d.ju[a * m + j];
                        self.control_cols(k, j).for_each(|(c, v)| term(row, c, g * v));
                    }
                }
                row += 1;
            }
            if terminal {
                break;
            }
            let w = self.scale * self.lambda[k].sqrt();
            for i in 0..n {
                self.state_cols(k + 1, i).for_each(|(c, v)| term(row, c, w * v));
                for c in (0..n).filter(|&c| st.fx[i * n + c]) {
                    let g = -w * d.fx[i * n + c];
                    self.state_cols(k, c).for_each(|(col, v)| term(row, col, g * v));
                }
                for j in (0..m).filter(|&j| st.fu[i * m + j]) {
                    let g = -w * d.fu[i * m + j];
                    self.control_cols(k, j).for_each(|(col, v)| term(row, col, g * v));
                }
                row += 1;
            }
        }
        if let Some((_, w0)) = &self.initial_state {
            let w = w0.sqrt();
            for i in 0..n {
                self.state_cols(0, i).for_each(|(c, v)| term(row, c, w * v));
                row += 1;
            }
        }
        debug_assert_eq!(row, self.n_residuals());
        Ok(())
    }

    /// Where each term of [`for_each_term`](Self::for_each_term) goes in
    /// the Jacobian's values (`usize::MAX`: a structural zero, dropped).
    pub(super) fn build_jacobian_slots(&self) -> Vec<usize> {
        let row_ptr = self.pattern.row_ptr();
        let col_idx = self.pattern.col_idx();
        let mut slots = Vec::new();
        let result = self.for_each_term(
            &self.local_structure(),
            |_, _| Ok(()),
            |row, c, _| {
                let (start, end) = (row_ptr[row], row_ptr[row + 1]);
                slots.push(col_idx[start..end].binary_search(&c).map_or(usize::MAX, |p| start + p));
            },
        );
        debug_assert!(result.is_ok());
        slots
    }

    /// The values of $J(\theta)$ in the order of the pattern.
    pub(super) fn jacobian_values_impl(&self, theta: &[f64], values: &mut [f64]) -> Result<()> {
        expect_len("parameters", self.n_params(), theta.len())?;
        expect_len("jacobian values", self.pattern.col_idx().len(), values.len())?;
        let (x, u) = self.sample(theta);
        values.fill(0.0);
        let slots = &self.jacobian_slots;
        let mut t = 0;
        self.for_each_term(
            &self.local_structure(),
            |k, d| self.local_derivatives(k, &x, &u, d),
            |_, _, v| {
                let slot = slots[t];
                t += 1;
                if slot != usize::MAX {
                    values[slot] += v;
                }
            },
        )
    }
}

/// Which local derivatives can be nonzero (see [`LocalDerivatives`]).
pub(super) struct LocalStructure {
    pub(super) jx: Vec<bool>,
    pub(super) ju: Vec<bool>,
    pub(super) fx: Vec<bool>,
    pub(super) fu: Vec<bool>,
}

#[derive(Clone)]
pub(super) struct LocalDerivatives {
    pub(super) jx: Vec<f64>,
    pub(super) ju: Vec<f64>,
    pub(super) fx: Vec<f64>,
    pub(super) fu: Vec<f64>,
}
