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
}
