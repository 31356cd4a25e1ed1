//! The front door for a user's least-squares problem ([`LeastSquares`])
//! reaches the optimum the underlying solvers reach configured by hand, on
//! random nonlinear problems with known minimisers
//! ([`strategies::nonlinear_least_squares`]).

use proptest::prelude::*;
use trajopt::strategies::nonlinear_least_squares;
use trajopt::{
    DerivativeFree, DerivativeFreeSettings, GaussNewton, GaussNewtonSettings, LeastSquares, LeastSquaresProblem, Method,
};

fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol * (1.0 + y.abs()))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn the_front_door_reaches_the_hand_configured_optimum((problem, x_star, x0) in nonlinear_least_squares(6)) {
        let m = problem.n_residuals();
        let by_hand = GaussNewton::new(GaussNewtonSettings::default()).expect("settings").solve(&problem, &x0).expect("solves");
        prop_assert!(by_hand.status.is_converged(), "{:?}", by_hand.status);
        prop_assert!(close(&by_hand.x, &x_star, 1e-6), "{:?} vs {:?}", by_hand.x, x_star);

        let residuals = |x: &[f64], r: &mut [f64]| problem.residuals_into(x, r);
        // with the Jacobian: the same iteration, so the same point
        let front = LeastSquares::new(m, residuals).jacobian(|x: &[f64], j: &mut [f64]| problem.jacobian_into(x, j)).solve(&x0).expect("solves");
        prop_assert!(close(&front.x, &by_hand.x, 1e-12), "{:?} vs {:?}", front.x, by_hand.x);
        prop_assert_eq!(front.iterations, by_hand.iterations);

        // without it (differenced), and in the derivative-free mode, whose
        // hand-configured twin differences the same residuals
        let differenced = LeastSquares::new(m, residuals).solve(&x0).expect("solves");
        prop_assert!(differenced.status.is_converged(), "{:?}", differenced.status);
        prop_assert!(close(&differenced.x, &x_star, 1e-6), "{:?} vs {:?}", differenced.x, x_star);
        let free = LeastSquares::new(m, residuals).method(Method::DerivativeFree).solve(&x0).expect("solves");
        let free_by_hand = DerivativeFree::new(DerivativeFreeSettings::default()).expect("settings").solve(&problem, &x0).expect("solves");
        prop_assert!(close(&free.x, &x_star, 1e-6), "{:?} vs {:?}", free.x, x_star);
        prop_assert!(close(&free_by_hand.x, &x_star, 1e-6), "{:?} vs {:?}", free_by_hand.x, x_star);
        prop_assert!(free.cost <= 1e-12 && front.cost <= 1e-12);
    }
}
