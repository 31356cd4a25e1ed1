//! Small dense kernels on row-major slices for the backward pass (state
//! dimensions of a few units: plain loops beat any BLAS call here).
//!
//! The Cholesky factorisation of $\tilde Q_{uu}$ and its solves stay hand
//! written: `benches/cholesky.rs` times the knot's solve ($k$ and $K$ from
//! an $m \times m$ $\tilde Q_{uu}$, $m \in \{1, 2\}$, $n \in \{2, 4, 6\}$)
//! with faer's `cholesky_in_place` / `solve_in_place` and nalgebra's
//! `Cholesky`, both on preallocated buffers, and these loops are faster at
//! every size (40-140 ns against nalgebra's 67-182 ns and faer's
//! 130-169 ns). A test checks them against faer's `llt` to 1e-12.

/// $C \mathrel{+}= A^\top B$ with $A$ of shape $r \times p$, $B$ of shape
/// $r \times q$, $C$ of shape $p \times q$.
#[inline]
pub(crate) fn add_at_b(a: &[f64], b: &[f64], r: usize, p: usize, q: usize, c: &mut [f64]) {
    for k in 0..r {
        let ak = &a[k * p..(k + 1) * p];
        let bk = &b[k * q..(k + 1) * q];
        for (i, &aki) in ak.iter().enumerate() {
            let ci = &mut c[i * q..(i + 1) * q];
            for (cij, &bkj) in ci.iter_mut().zip(bk) {
                *cij += aki * bkj;
            }
        }
    }
}

/// $C = A B$ with $A$ of shape $p \times r$, $B$ of shape $r \times q$.
#[inline]
pub(crate) fn set_a_b(a: &[f64], b: &[f64], p: usize, r: usize, q: usize, c: &mut [f64]) {
    c[..p * q].fill(0.0);
    for i in 0..p {
        let ci = &mut c[i * q..(i + 1) * q];
        for k in 0..r {
            let aik = a[i * r + k];
            for (cij, &bkj) in ci.iter_mut().zip(&b[k * q..(k + 1) * q]) {
                *cij += aik * bkj;
            }
        }
    }
}

/// $y \mathrel{+}= A^\top x$ with $A$ of shape $r \times p$.
#[inline]
pub(crate) fn add_at_x(a: &[f64], x: &[f64], r: usize, p: usize, y: &mut [f64]) {
    for k in 0..r {
        let xk = x[k];
        for (yi, &aki) in y.iter_mut().zip(&a[k * p..(k + 1) * p]) {
            *yi += aki * xk;
        }
    }
}

/// The dense Cholesky kernels, shared with `lwr` ([`solve::dense`]).
pub(crate) use solve::dense::{cholesky, cholesky_solve};

/// Workspace of [`box_qp`].
#[derive(Debug, Clone)]
pub(crate) struct BoxQp {
    m: usize,
    grad: Vec<f64>,
    dir: Vec<f64>,
    trial: Vec<f64>,
    rhs: Vec<f64>,
    /// Cholesky factor of $H_{ff}$ over the free set, dense $m_f \times m_f$.
    pub(crate) factor: Vec<f64>,
    /// Free (not clamped) coordinates at the solution.
    pub(crate) free: Vec<usize>,
}

impl BoxQp {
    pub(crate) fn new(m: usize) -> Self {
        Self {
            m,
            grad: vec![0.0; m],
            dir: vec![0.0; m],
            trial: vec![0.0; m],
            rhs: vec![0.0; m],
            factor: vec![0.0; m * m],
            free: Vec::with_capacity(m),
        }
    }

    fn value(h: &[f64], g: &[f64], x: &[f64]) -> f64 {
        let m = x.len();
        let mut v = 0.0;
        for i in 0..m {
            let hx: f64 = (0..m).map(|j| h[i * m + j] * x[j]).sum();
            v += x[i] * (g[i] + 0.5 * hx);
        }
        v
    }

    /// The gradient $H x + g$ at `x` into `self.grad`, and into `self.free`
    /// the coordinates not clamped: not at a bound the gradient pushes
    /// against. Inlined into both call sites, as the loops it replaces were.
    #[inline(always)]
    fn gradient_and_free_set(&mut self, h: &[f64], g: &[f64], lo: &[f64], hi: &[f64], x: &[f64]) {
        let m = self.m;
        for i in 0..m {
            self.grad[i] = g[i] + (0..m).map(|j| h[i * m + j] * x[j]).sum::<f64>();
        }
        self.free.clear();
        for i in 0..m {
            let clamped = (x[i] <= lo[i] && self.grad[i] > 0.0) || (x[i] >= hi[i] && self.grad[i] < 0.0);
            if !clamped {
                self.free.push(i);
            }
        }
    }

    /// Factors $H$ restricted to `self.free` into `self.factor`.
    fn factor_free(&mut self, h: &[f64]) -> bool {
        let mf = self.free.len();
        for (a, &i) in self.free.iter().enumerate() {
            for (b, &j) in self.free.iter().enumerate() {
                self.factor[a * mf + b] = h[i * self.m + j];
            }
        }
        cholesky(&mut self.factor[..mf * mf], mf).is_some()
    }

    /// Projected-Newton solution of $\min_x \tfrac12 x^\top H x + g^\top x$
    /// subject to $lo \le x \le hi$ (Tassa, Mansard and Todorov 2014,
    /// Algorithm 1), warm-started from `x` (clamped first) and written back
    /// into it. On return `self.free` and `self.factor` describe the free set
    /// and the Cholesky factor of $H_{ff}$ there. Returns `false` if $H_{ff}$
    /// is not positive definite.
    pub(crate) fn solve(
        &mut self,
        h: &[f64],
        g: &[f64],
        lo: &[f64],
        hi: &[f64],
        x: &mut [f64],
        max_iterations: usize,
    ) -> bool {
        const MIN_GRAD: f64 = 1e-12;
        const MIN_REL_IMPROVE: f64 = 1e-12;
        const ARMIJO: f64 = 0.1;
        const STEP_DEC: f64 = 0.6;
        const MIN_STEP: f64 = 1e-22;
        let m = self.m;
        for i in 0..m {
            x[i] = x[i].clamp(lo[i], hi[i]);
        }
        let mut value = Self::value(h, g, x);
        for _ in 0..max_iterations {
            self.gradient_and_free_set(h, g, lo, hi, x);
            if self.free.is_empty() {
                return true;
            }
            if !self.factor_free(h) {
                return false;
            }
            let gnorm: f64 = self
                .free
                .iter()
                .map(|&i| self.grad[i] * self.grad[i])
                .sum::<f64>()
                .sqrt();
            if gnorm < MIN_GRAD {
                return true;
            }
            // Newton step on the free set, clamped coordinates fixed:
            // x_f <- -H_ff^{-1} (g_f + H_fc x_c), i.e. dir_f = that - x_f.
            let mf = self.free.len();
            for (a, &i) in self.free.iter().enumerate() {
                self.rhs[a] = self.grad[i];
            }
            cholesky_solve(&self.factor[..mf * mf], mf, &mut self.rhs[..mf]);
            self.dir.fill(0.0);
            for (a, &i) in self.free.iter().enumerate() {
                self.dir[i] = -self.rhs[a];
            }
            let sdotg: f64 = self.dir.iter().zip(&self.grad).map(|(d, g)| d * g).sum();
            if sdotg >= 0.0 {
                return true;
            }
            // projected Armijo backtracking
            let mut step = 1.0;
            let mut accepted = false;
            let mut trial_value = value;
            while step >= MIN_STEP {
                for i in 0..m {
                    self.trial[i] = (x[i] + step * self.dir[i]).clamp(lo[i], hi[i]);
                }
                trial_value = Self::value(h, g, &self.trial);
                if (trial_value - value) / (step * sdotg) >= ARMIJO {
                    accepted = true;
                    break;
                }
                step *= STEP_DEC;
            }
            if !accepted {
                return true;
            }
            let improvement = (value - trial_value).abs() / value.abs().max(1e-300);
            x.copy_from_slice(&self.trial);
            value = trial_value;
            if improvement < MIN_REL_IMPROVE {
                break;
            }
        }
        // final free set and factor at the returned point
        self.gradient_and_free_set(h, g, lo, hi, x);
        self.factor_free(h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_and_detects_indefinite() {
        let mut a = vec![4.0, 2.0, 2.0, 3.0];
        assert!(cholesky(&mut a, 2).is_some());
        let mut b = vec![6.0, 5.0];
        cholesky_solve(&a, 2, &mut b);
        assert!((b[0] - 1.0).abs() < 1e-14 && (b[1] - 1.0).abs() < 1e-14);
        let mut bad = vec![1.0, 2.0, 2.0, 1.0];
        assert!(cholesky(&mut bad, 2).is_none());
    }

    /// The hand-written factorisation and solve agree with faer's `llt` to
    /// 1e-12 relative on symmetric positive definite matrices of the
    /// backward pass's sizes and a little beyond.
    #[test]
    fn cholesky_agrees_with_faer() {
        use faer::Mat;
        use faer::linalg::solvers::Solve;
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            // xorshift, deterministic
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for m in 1..=6 {
            for _ in 0..20 {
                let g = Mat::from_fn(m, m, |_, _| next());
                let a = &g * g.transpose() + Mat::<f64>::identity(m, m) * faer::Scale(0.05);
                let a = Mat::from_fn(m, m, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
                let rhs = Mat::from_fn(m, 3, |_, _| next());
                let reference = a.llt(faer::Side::Lower).expect("positive definite").solve(&rhs);
                let mut l: Vec<f64> = (0..m * m).map(|k| a[(k / m, k % m)]).collect();
                assert!(cholesky(&mut l, m).is_some());
                for c in 0..3 {
                    let mut b: Vec<f64> = (0..m).map(|i| rhs[(i, c)]).collect();
                    cholesky_solve(&l, m, &mut b);
                    let scale = (0..m).map(|i| reference[(i, c)].abs()).fold(0.0, f64::max);
                    for i in 0..m {
                        let err = (b[i] - reference[(i, c)]).abs();
                        assert!(
                            err <= 1e-12 * scale.max(1.0),
                            "m={m}: {} vs {}",
                            b[i],
                            reference[(i, c)]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn products_match_hand_computation() {
        let a = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]; // 2x3
        let b = [1.0, 0.0, 0.0, 1.0]; // 2x2
        let mut c = [0.0; 6];
        add_at_b(&a, &b, 2, 3, 2, &mut c); // A^T B, 3x2
        assert_eq!(c, [1.0, 4.0, 2.0, 5.0, 3.0, 6.0]);
        let mut d = [0.0; 6];
        set_a_b(&b, &a, 2, 2, 3, &mut d);
        assert_eq!(d, a);
        let mut y = [0.0; 3];
        add_at_x(&a, &[1.0, 1.0], 2, 3, &mut y);
        assert_eq!(y, [5.0, 7.0, 9.0]);
    }

    #[test]
    fn box_qp_matches_enumeration() {
        // min 1/2 x^T H x + g^T x on [-1, 1]^2; the unconstrained minimiser is outside
        let h = [2.0, 0.5, 0.5, 1.0];
        let g = [-5.0, 0.2];
        let mut qp = BoxQp::new(2);
        let mut x = [0.0, 0.0];
        assert!(qp.solve(&h, &g, &[-1.0, -1.0], &[1.0, 1.0], &mut x, 100));
        // brute force on a fine grid
        let mut best = (f64::INFINITY, [0.0, 0.0]);
        for i in 0..=400 {
            for j in 0..=400 {
                let p = [-1.0 + i as f64 / 200.0, -1.0 + j as f64 / 200.0];
                let v = BoxQp::value(&h, &g, &p);
                if v < best.0 {
                    best = (v, p);
                }
            }
        }
        assert!(BoxQp::value(&h, &g, &x) <= best.0 + 1e-12, "{x:?} vs {best:?}");
        assert_eq!(x[0], 1.0);
        assert!((x[1] + 0.7).abs() < 1e-12);
        assert_eq!(qp.free, vec![1]);
        // both bounds active: no free coordinate
        let mut x = [0.0, 0.0];
        assert!(qp.solve(&h, &[-5.0, 1.0], &[-1.0, -1.0], &[1.0, 1.0], &mut x, 100));
        assert_eq!(x, [1.0, -1.0]);
        assert!(qp.free.is_empty());
    }
}
