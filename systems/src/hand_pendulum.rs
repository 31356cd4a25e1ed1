//! The hand-held pendulum of the paper's swing-up with a learned pendulum:
//! the hand's kinematics known, the pendulum's change of angular velocity
//! per sample, $g(z)$ with $z = (\theta, \dot\theta, x, \dot x, u)$, given
//! by a regression. State $s = (\theta, \dot\theta, x, \dot x)$, command
//! $u$ (the hand's acceleration), sample period $\Delta t$:
//! $$\dot\theta' = \dot\theta + g(z), \quad \theta' = \theta + \tfrac{\Delta t}{2}(\dot\theta + \dot\theta'),
//! \quad x' = x + \dot x \Delta t + u \Delta t^2 / 2, \quad \dot x' = \dot x + u \Delta t$$
//! (the trapezoid rule for the angle, exact zero-order-hold kinematics for
//! the hand). These are the step and its Jacobians as functions of $g$ and
//! $\partial g / \partial z$, for the models built on a regression
//! (`swingup`'s learned models, the benchmark's `pendulum-lwr` instance).

/// The next state from $s$ = `x`, $u$ and $g(z)$ = `g`.
pub fn step(dt: f64, x: &[f64], u: f64, g: f64, next: &mut [f64]) {
    let w1 = x[1] + g;
    next[0] = x[0] + 0.5 * dt * (x[1] + w1);
    next[1] = w1;
    next[2] = x[2] + dt * x[3] + 0.5 * dt * dt * u;
    next[3] = x[3] + dt * u;
}

/// The step's Jacobians from $\partial g / \partial z$ = `grad`: $f_s$
/// (4 x 4) into `fx` and $f_u$ (4 x 1) into `fu`, row-major.
pub fn jacobians(dt: f64, grad: &[f64; 5], fx: &mut [f64], fu: &mut [f64]) {
    let h = 0.5 * dt;
    fx.fill(0.0);
    // the row of theta_dot' is g's gradient plus 1 on theta_dot
    let dw: [f64; 5] = std::array::from_fn(|c| grad[c] + if c == 1 { 1.0 } else { 0.0 });
    for c in 0..4 {
        fx[4 + c] = dw[c];
        fx[c] = h * dw[c] + if c == 1 { h } else { 0.0 } + if c == 0 { 1.0 } else { 0.0 };
    }
    fx[8 + 2] = 1.0;
    fx[8 + 3] = dt;
    fx[12 + 3] = 1.0;
    fu[0] = h * dw[4];
    fu[1] = dw[4];
    fu[2] = 0.5 * dt * dt;
    fu[3] = dt;
}

/// Which entries of the Jacobians may be nonzero: the hand's rows do not
/// depend on the pendulum.
pub fn jacobian_structure(fx: &mut [bool], fu: &mut [bool]) {
    for (i, v) in fx.iter_mut().enumerate() {
        *v = i / 4 < 2 || i % 4 >= 2;
    }
    fu.fill(true);
}

/// The swing-up's soft bounds on the hand's position $x$ and the command
/// $u$: the residuals $\sqrt{w_b}\,(|x| - x_{max})_+$ and
/// $\sqrt{w_b}\,(|u| - u_{max})_+$ (a hinge squared in the cost, so
/// continuously differentiable), the command's 0 at the terminal stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoftBounds {
    /// The hand's bound $x_{max}$.
    pub x_max: f64,
    /// The command's bound $u_{max}$.
    pub u_max: f64,
    /// $\sqrt{w_b}$.
    pub sqrt_weight: f64,
}

/// $(|v| - m)_+$ and its derivative in $v$.
fn hinge(v: f64, m: f64) -> (f64, f64) {
    if v.abs() > m {
        (v.abs() - m, v.signum())
    } else {
        (0.0, 0.0)
    }
}

impl SoftBounds {
    /// The two residuals at state `x` and command `u` (`None` at the
    /// terminal stage) into `r[0..2]`.
    pub fn residuals(&self, x: &[f64], u: Option<&[f64]>, r: &mut [f64]) {
        r[0] = self.sqrt_weight * hinge(x[2], self.x_max).0;
        r[1] = u.map_or(0.0, |u| self.sqrt_weight * hinge(u[0], self.u_max).0);
    }

    /// Their Jacobians, written whole: `jx` (2 x 4) and `ju` (2 x 1),
    /// row-major.
    pub fn jacobians(&self, x: &[f64], u: Option<&[f64]>, jx: &mut [f64], ju: &mut [f64]) {
        jx[..8].fill(0.0);
        ju[..2].fill(0.0);
        jx[2] = self.sqrt_weight * hinge(x[2], self.x_max).1;
        if let Some(u) = u {
            ju[1] = self.sqrt_weight * hinge(u[0], self.u_max).1;
        }
    }

    /// Which entries of [`jacobians`](Self::jacobians) may be nonzero.
    pub fn jacobian_structure(jx: &mut [bool], ju: &mut [bool]) {
        jx[..8].fill(false);
        ju[..2].fill(false);
        jx[2] = true;
        ju[1] = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A linear $g$: the step is linear, so its Jacobians equal central
    /// differences to rounding, and the structure covers every nonzero.
    #[test]
    fn jacobians_are_the_steps_derivatives() {
        let (dt, c) = (0.02, [0.3, -0.2, 0.1, 0.05, -0.4]);
        let g = |z: &[f64; 5]| (0..5).map(|j| c[j] * z[j]).sum::<f64>();
        let (x, u) = ([0.4, -1.0, 0.2, 0.3], 2.0);
        let (mut fx, mut fu) = ([0.0; 16], [0.0; 4]);
        jacobians(dt, &c, &mut fx, &mut fu);
        let (mut sx, mut su) = ([false; 16], [false; 4]);
        jacobian_structure(&mut sx, &mut su);
        let h = 1e-6;
        for col in 0..5 {
            let (mut zp, mut zm) = ([x[0], x[1], x[2], x[3], u], [x[0], x[1], x[2], x[3], u]);
            zp[col] += h;
            zm[col] -= h;
            let (mut np, mut nm) = ([0.0; 4], [0.0; 4]);
            step(dt, &zp[..4], zp[4], g(&zp), &mut np);
            step(dt, &zm[..4], zm[4], g(&zm), &mut nm);
            for row in 0..4 {
                let numeric = (np[row] - nm[row]) / (2.0 * h);
                let (analytic, allowed) = if col < 4 {
                    (fx[4 * row + col], sx[4 * row + col])
                } else {
                    (fu[row], su[row])
                };
                assert!(
                    (numeric - analytic).abs() < 1e-8,
                    "({row}, {col}): {numeric} vs {analytic}"
                );
                assert!(allowed || analytic == 0.0, "({row}, {col}) outside the structure");
            }
        }
    }

    /// With $g = 0$ the pendulum keeps its angular velocity and the hand
    /// moves as a double integrator, exactly.
    #[test]
    fn without_g_the_kinematics_are_exact() {
        let mut next = [0.0; 4];
        step(0.1, &[1.0, 2.0, 0.5, -1.0], 3.0, 0.0, &mut next);
        let want = [1.0 + 0.1 * 2.0, 2.0, 0.5 - 0.1 + 0.5 * 0.01 * 3.0, -1.0 + 0.3];
        for (a, b) in next.iter().zip(want) {
            assert!((a - b).abs() < 1e-15, "{next:?} vs {want:?}");
        }
    }

    /// Inside the bounds the residuals vanish; outside they are the
    /// excess times sqrt(w_b), with derivative its sign.
    #[test]
    fn soft_bounds_are_hinges() {
        let b = SoftBounds {
            x_max: 0.7,
            u_max: 12.0,
            sqrt_weight: 10.0,
        };
        let mut r = [1.0; 2];
        b.residuals(&[0.1, 0.2, 0.5, 0.4], Some(&[3.0]), &mut r);
        assert_eq!(r, [0.0, 0.0]);
        b.residuals(&[0.1, 0.2, -0.9, 0.4], Some(&[-13.0]), &mut r);
        assert!((r[0] - 2.0).abs() < 1e-12 && (r[1] - 10.0).abs() < 1e-12, "{r:?}");
        let (mut jx, mut ju) = ([1.0; 8], [1.0; 2]);
        b.jacobians(&[0.1, 0.2, -0.9, 0.4], Some(&[-13.0]), &mut jx, &mut ju);
        assert_eq!(jx, [0.0, 0.0, -10.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(ju, [0.0, -10.0]);
        b.residuals(&[0.1, 0.2, 0.9, 0.4], None, &mut r);
        assert_eq!(r[1], 0.0, "no command at the terminal stage");
    }
}
