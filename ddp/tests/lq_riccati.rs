//! On a linear-quadratic problem DDP takes one Newton step to the discrete
//! Riccati solution: gains, value function and trajectory to 1e-9.

use ddp::strategies::{LqProblem, lq_problem};
use ddp::{Ddp, DdpSettings, DdpStatus, Regularization};
use proptest::prelude::*;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * (1.0 + b.abs())
}

fn check(lq: &LqProblem, settings: DdpSettings) -> Result<(), TestCaseError> {
    let result = Ddp::new(settings)
        .expect("valid settings")
        .solve(&lq.to_ddp_problem())
        .expect("solve");
    let ric = &lq.riccati;
    prop_assert_eq!(result.status, DdpStatus::Converged);
    prop_assert_eq!(result.iterations, 1);
    prop_assert!(close(result.cost, ric.cost), "cost {} vs {}", result.cost, ric.cost);
    let n = lq.x0.len();
    for k in 0..lq.horizon {
        let (g, gr) = (&result.gains[k], &ric.gains[k]);
        for i in 0..g.nrows() {
            prop_assert!(close(result.controls[k][i], ric.controls[k][i]));
            for j in 0..n {
                prop_assert!(
                    close(g[(i, j)], gr[(i, j)]),
                    "K[{k}]({i},{j}) {} vs {}",
                    g[(i, j)],
                    gr[(i, j)]
                );
            }
        }
    }
    for k in 0..=lq.horizon {
        let p = &ric.value_hessians[k];
        let x = &ric.states[k];
        let mut v0 = 0.0;
        for i in 0..n {
            prop_assert!(close(result.states[k][i], x[i]));
            let px: f64 = (0..n).map(|j| p[(i, j)] * x[j]).sum();
            v0 += 0.5 * x[i] * px;
            prop_assert!(close(result.value_gradient[k][i], px), "Vx[{k}]");
            for j in 0..n {
                prop_assert!(close(result.value_hessian[k][(i, j)], p[(i, j)]), "Vxx[{k}]");
            }
        }
        prop_assert!(close(result.value[k], v0), "V0[{k}] {} vs {v0}", result.value[k]);
    }
    // the returned policy evaluates Eq. 2 and the value model Eq. 1
    let x = vec![0.1; n];
    let u = result.policy(0, &x).expect("policy");
    prop_assert_eq!(u.len(), lq.b.ncols());
    let v = result.value_model(0, &x).expect("value model");
    let pv: f64 = (0..n)
        .map(|i| 0.5 * x[i] * (0..n).map(|j| ric.value_hessians[0][(i, j)] * x[j]).sum::<f64>())
        .sum();
    prop_assert!(close(v, pv));
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn ddp_equals_riccati_in_one_iteration(lq in lq_problem(4, 3, 40)) {
        check(&lq, DdpSettings::default())?;
    }

    #[test]
    fn state_regularised_ddp_equals_riccati(lq in lq_problem(3, 2, 20)) {
        check(&lq, DdpSettings { regularization: Regularization::State, ..DdpSettings::default() })?;
    }
}
