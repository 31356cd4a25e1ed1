//! The Levenberg-Marquardt damping $\mu$ (Nielsen's rule) and the shift
//! $\sigma$ that makes an indefinite Newton matrix positive definite.

/// The shift of an indefinite $J^\top J + S$ (relative to $D$) starts at
/// `SHIFT_MIN`, grows by `SHIFT_INCREASE` until the factorisation succeeds,
/// and shrinks by `SHIFT_DECREASE` at each iteration (as IPOPT's inertia
/// correction); beyond `SHIFT_MAX` the Newton model is too far from convex
/// to be worth it and the iteration takes a Gauss-Newton step instead (far
/// from the solution, where the residuals' curvature is large).
///
/// After a Newton step with gain ratio $\rho$ within `ACCURATE` of 1 (the
/// trust-region rule's "very successful" $\rho > 3/4$, from both sides),
/// the shift shrinks by a further `SHIFT_DECREASE_ACCURATE`: the shifted
/// model predicted well, so a much smaller shift is likely enough at the
/// next point too, and the steps tend to the undamped Newton step and its
/// quadratic convergence sooner. If that shift is too small, it grows from
/// there by `SHIFT_INCREASE`, which mostly finds a smaller working shift
/// than the plain decrease would have tried (measured: going back to the
/// plain decrease's value after such a failure takes more iterations).
/// On the benchmark pendulum at $\lambda = 10^2$ this took the Newton mode
/// from 26-31 iterations to 17-26 at horizons 100 to 20000 (17 instead of
/// 28 at $N = 1000$), with fewer factorisations.
pub(super) const SHIFT_MIN: f64 = 1e-8;
pub(super) const SHIFT_INCREASE: f64 = 8.0;
pub(super) const SHIFT_DECREASE: f64 = 1.0 / 3.0;
pub(super) const SHIFT_DECREASE_ACCURATE: f64 = 1.0 / 100.0;
pub(super) const ACCURATE: f64 = 0.25;
pub(super) const SHIFT_MAX: f64 = 1e-3;

/// The damping scale $D$: each parameter's largest $(J^\top J)_{jj}$ so
/// far (`seen`, updated), at least $10^{-12}$, written over the current
/// diagonal `diag`.
///
/// With the current diagonal alone, a parameter whose column of $J$
/// vanishes near the current point (as on Penalty II, where the dominant
/// residual's column is $2 (n - j + 1) x_j$ and some $x_j$ pass through 0)
/// gets almost no damping: its steps are limited only by raising $\mu$
/// for every parameter, until the others barely move (measured there: $\mu$
/// near $10^6$, $F$ crawling from 6.06 to 5.6 in 3500 iterations).
/// MINPACK's `lmder` keeps the running maximum of the column norms for
/// that reason (Moré, "The Levenberg-Marquardt algorithm: implementation
/// and theory", 1978), and so does this.
pub(super) fn running_max_scale(diag: &mut [f64], seen: &mut [f64]) {
    for (d, s) in diag.iter_mut().zip(seen.iter_mut()) {
        *s = s.max(*d);
        *d = s.max(1e-12);
    }
}

/// $\mu \leftarrow \max(\mu \nu, 10^{-12})$, $\nu \leftarrow 2\nu$; false once
/// the damping is hopelessly large.
pub(super) fn raise_damping(mu: &mut f64, nu: &mut f64) -> bool {
    *mu = (*mu * *nu).max(1e-12);
    *nu *= 2.0;
    *mu < 1e16
}

/// Nielsen's update after an accepted step with gain ratio $\rho$:
/// $\mu \leftarrow \mu \max(1/3, 1 - (2\rho - 1)^3)$.
pub(super) fn lower_damping(mu: &mut f64, rho: f64) {
    *mu *= (1.0 / 3.0f64).max(1.0 - (2.0 * rho - 1.0).powi(3));
}

/// Where [adaptive](super::StepModel::Adaptive) iterations probe the
/// residuals' curvature: at $\theta \pm t \delta$ with this $t$ (central
/// differences: truncation error $O(t^2)$, rounding $O(\epsilon / t^2)$ relative).
pub(super) const PROBE: f64 = 1e-3;

/// The adaptive choice for the next iteration: whether the Newton model
/// predicted the last step's `actual` reduction relatively better than the
/// Gauss-Newton model, given the prediction `predicted` of the model used
/// (`newton` or not) and $\delta^\top S \delta$ (`s_form`). Ties keep the
/// model used.
pub(super) fn prefer_newton(newton: bool, predicted: f64, s_form: f64, actual: f64) -> bool {
    // the predicted reductions of both models for this step
    let (gauss_newton, full) = if newton {
        (predicted + s_form, predicted)
    } else {
        (predicted, predicted - s_form)
    };
    let error = |p: f64| (actual - p).abs() / p.abs().max(f64::MIN_POSITIVE);
    let (e_gn, e_full) = (error(gauss_newton), error(full));
    if newton { e_full <= e_gn } else { e_full < e_gn }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scale_is_the_running_maximum_of_the_diagonal() {
        let mut seen = vec![0.0; 3];
        let mut diag = vec![4.0, 0.0, 1.0];
        running_max_scale(&mut diag, &mut seen);
        assert_eq!(diag, vec![4.0, 1e-12, 1.0]);
        let mut diag = vec![1.0, 2.0, 1e-9];
        running_max_scale(&mut diag, &mut seen);
        assert_eq!((diag, seen), (vec![4.0, 2.0, 1.0], vec![4.0, 2.0, 1.0]));
    }

    #[test]
    fn damping_grows_geometrically_and_gives_up_when_hopeless() {
        let (mut mu, mut nu) = (0.0, 2.0);
        assert!(raise_damping(&mut mu, &mut nu));
        assert_eq!((mu, nu), (1e-12, 4.0));
        assert!(raise_damping(&mut mu, &mut nu));
        assert_eq!((mu, nu), (4e-12, 8.0));
        let (mut mu, mut nu) = (6e15, 2.0);
        assert!(!raise_damping(&mut mu, &mut nu));
    }

    #[test]
    fn a_perfect_prediction_divides_the_damping_by_three() {
        let mut mu = 3.0;
        lower_damping(&mut mu, 1.0);
        assert!((mu - 1.0).abs() < 1e-15);
        // a poor one (rho near 0) keeps it nearly unchanged
        let mut mu = 1.0;
        lower_damping(&mut mu, 1e-6);
        assert!(mu > 1.9);
    }

    #[test]
    fn the_model_that_predicted_better_is_preferred() {
        // Gauss-Newton step predicted 1.0, S-form 0.5: Newton predicts 0.5
        assert!(prefer_newton(false, 1.0, 0.5, 0.5));
        assert!(!prefer_newton(false, 1.0, 0.5, 1.0));
        // a Newton step predicted 1.0: Gauss-Newton would have said 1.5
        assert!(prefer_newton(true, 1.0, 0.5, 1.0));
        assert!(!prefer_newton(true, 1.0, 0.5, 1.5));
    }
}
