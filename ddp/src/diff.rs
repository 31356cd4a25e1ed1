//! Central differences for `strategies::check_jacobian` (the proptest feature)
//! and the shooting gradient checks; the models' own differences are
//! `systems::central_differences`, with the same step.

use crate::error::Result;

/// The central-difference step for a coordinate of value `z`:
/// $h = \epsilon^{1/3} \max(1, \lvert z \rvert)$, which balances the
/// $O(h^2)$ truncation error against the $O(\epsilon / h)$ rounding error
/// (both about $10^{-11}$ relative for smooth $f$ of unit scale). The rule
/// of `trajopt`'s finite-difference Jacobians.
pub(crate) fn step_size(z: f64) -> f64 {
    f64::EPSILON.cbrt() * z.abs().max(1.0)
}

/// The central-difference Jacobian of $f: \mathbb{R}^p \to \mathbb{R}^q$ at
/// `z`, written into `jac` ($q \times p$, row-major): column $j$ is
/// $(f(z + h_j e_j) - f(z - h_j e_j)) / (2 h_j)$ with $h_j$ from
/// [`step_size`]. `f(z, out)` writes $f(z)$ into `out` (length $q$);
/// `scratch` holds at least $p + 2q$ values.
///
/// # Errors
/// The first error `f` returns.
pub(crate) fn central_jacobian(
    mut f: impl FnMut(&[f64], &mut [f64]) -> Result<()>,
    z: &[f64],
    q: usize,
    jac: &mut [f64],
    scratch: &mut [f64],
) -> Result<()> {
    let p = z.len();
    let (zh, rest) = scratch.split_at_mut(p);
    let (plus, rest) = rest.split_at_mut(q);
    let minus = &mut rest[..q];
    zh.copy_from_slice(z);
    for j in 0..p {
        let h = step_size(z[j]);
        zh[j] = z[j] + h;
        f(zh, plus)?;
        zh[j] = z[j] - h;
        f(zh, minus)?;
        zh[j] = z[j];
        for i in 0..q {
            jac[i * p + j] = (plus[i] - minus[i]) / (2.0 * h);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_of_a_quadratic_are_exact_to_rounding() {
        // f(z) = (z0^2 + 3 z1, z0 z1): J = [[2 z0, 3], [z1, z0]]
        let z = [1.5, -2.0];
        let mut jac = [0.0; 4];
        let mut scratch = [0.0; 6];
        central_jacobian(
            |z, out| {
                out[0] = z[0] * z[0] + 3.0 * z[1];
                out[1] = z[0] * z[1];
                Ok(())
            },
            &z,
            2,
            &mut jac,
            &mut scratch,
        )
        .expect("no error");
        for (a, b) in jac.iter().zip([3.0, 3.0, -2.0, 1.5]) {
            assert!((a - b).abs() < 1e-9, "{jac:?}");
        }
        assert_eq!(step_size(0.1), step_size(-1.0));
        assert_eq!(step_size(-4.0), 4.0 * step_size(1.0));
    }
}
